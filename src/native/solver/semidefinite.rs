//! The equality problem of a working set, whose rows may be dependent.
//!
//! An active-set search (the dense back-end's, the Clarabel polish's) holds a working set W of
//! rows as equalities; its multipliers solve `S l = b` with `S = D_W P^-1 D_W'`, symmetric and
//! positive semidefinite. The rows of a flat interface are dependent (two sticking points of a
//! face give four rows on three relative DOFs), so S is singular in exact arithmetic and nearly
//! so in floating point. A Cholesky factorisation with diagonal pivoting that stops at the
//! numerical rank takes an independent subset of the rows, whose equations then hold to
//! round-off; the dependent rows get no multiplier, and whether they hold is the caller's check
//! (the consistency of the working set).

/// A pivot below this share of the largest diagonal entry of S ends the factorisation: the
/// rows left are dependent on the ones taken.
pub const DEPENDENT_PIVOT: f64 = 1e-12;

/// The pivots of a factorisation, and buffers reused from one working set to the next.
#[derive(Default)]
pub(super) struct PivotedCholesky {
    perm: Vec<usize>,
    rank: usize,
    /// The largest diagonal entry of S.
    largest: f64,
    y: Vec<f64>,
}

impl PivotedCholesky {
    /// Factorise S (`m x m`, row-major, overwritten by its factor) on its independent rows.
    /// Returns the numerical rank.
    pub(super) fn factor(&mut self, s: &mut [f64], m: usize) -> usize {
        let perm = &mut self.perm;
        perm.clear();
        perm.extend(0..m);
        let dmax0 = (0..m).map(|i| s[i * m + i]).fold(0.0f64, f64::max);
        let mut rank = 0;
        for k in 0..m {
            let (piv, dmax) = (k..m)
                .map(|i| (i, s[perm[i] * m + perm[i]]))
                .fold((k, f64::NEG_INFINITY), |b, x| if x.1 > b.1 { x } else { b });
            if dmax <= DEPENDENT_PIVOT * dmax0 || dmax <= 0.0 {
                break;
            }
            perm.swap(k, piv);
            let pk = perm[k];
            let l_kk = dmax.sqrt();
            s[pk * m + pk] = l_kk;
            for &pi in &perm[k + 1..m] {
                s[pi * m + pk] /= l_kk;
            }
            for i in k + 1..m {
                let pi = perm[i];
                let lik = s[pi * m + pk];
                for &pj in &perm[k + 1..=i] {
                    let v = s[pi * m + pj] - lik * s[pj * m + pk];
                    s[pi * m + pj] = v;
                    if pi != pj {
                        s[pj * m + pi] = v;
                    }
                }
            }
            rank = k + 1;
        }
        self.rank = rank;
        self.largest = dmax0;
        rank
    }

    /// Whether a row appended to S, with column `b` (its products with S's rows) and diagonal
    /// `c`, would be dependent on S's independent rows: its pivot, the Schur complement
    /// `c - b' S^+ b`, below `DEPENDENT_PIVOT` of the largest diagonal entry.
    pub(super) fn dependent(&mut self, s: &[f64], m: usize, b: &[f64], c: f64) -> bool {
        let (perm, rank) = (&self.perm, self.rank);
        let y = &mut self.y;
        y.clear();
        let mut pivot = c;
        for k in 0..rank {
            let pk = perm[k];
            let mut v = b[pk];
            for (j, yj) in y.iter().enumerate() {
                v -= s[pk * m + perm[j]] * yj;
            }
            let yk = v / s[pk * m + pk];
            pivot -= yk * yk;
            y.push(yk);
        }
        pivot <= DEPENDENT_PIVOT * self.largest.max(c)
    }

    /// Solve `S x = rhs` with the factor of S left by [`PivotedCholesky::factor`]; the
    /// dependent rows' unknowns are 0.
    pub(super) fn solve(&mut self, s: &[f64], m: usize, rhs: &[f64], x: &mut Vec<f64>) {
        let (perm, rank) = (&self.perm, self.rank);
        x.clear();
        x.resize(m, 0.0);
        let y = &mut self.y;
        y.clear();
        y.resize(rank, 0.0);
        for k in 0..rank {
            let pk = perm[k];
            let mut v = rhs[pk];
            for (j, yj) in y.iter().enumerate().take(k) {
                v -= s[pk * m + perm[j]] * yj;
            }
            y[k] = v / s[pk * m + pk];
        }
        for k in (0..rank).rev() {
            let pk = perm[k];
            let mut v = y[k];
            for &pj in &perm[k + 1..rank] {
                v -= s[pj * m + pk] * x[pj];
            }
            x[pk] = v / s[pk * m + pk];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `S = A A'` for rows `a`, row-major.
    fn gram(a: &[[f64; 3]]) -> Vec<f64> {
        let m = a.len();
        let mut s = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                s[i * m + j] = (0..3).map(|k| a[i][k] * a[j][k]).sum();
            }
        }
        s
    }

    /// Four rows on three unknowns, the fourth the sum of the first two: rank 3, the system
    /// solved exactly on the independent rows, and (a consistent right-hand side) the dependent
    /// row's equation holds as well.
    #[test]
    fn dependent_rows_get_no_unknown_and_consistent_equations_hold() {
        let a = [
            [1.0, 0.0, 0.5],
            [0.0, 1.0, -0.25],
            [1.0, 1.0, 0.25],
            [0.3, -0.2, 1.0],
        ];
        let s0 = gram(&a);
        // rhs = S l0 for some l0, so consistent.
        let l0 = [0.7, -1.1, 0.0, 2.0];
        let rhs: Vec<f64> = (0..4)
            .map(|i| (0..4).map(|j| s0[i * 4 + j] * l0[j]).sum())
            .collect();
        let mut s = s0.clone();
        let mut x = Vec::new();
        let mut cholesky = PivotedCholesky::default();
        assert_eq!(cholesky.factor(&mut s, 4), 3);
        cholesky.solve(&s, 4, &rhs, &mut x);
        assert_eq!(x.iter().filter(|&&v| v == 0.0).count(), 1, "{x:?}");
        for i in 0..4 {
            let sx: f64 = (0..4).map(|j| s0[i * 4 + j] * x[j]).sum();
            assert!(
                (sx - rhs[i]).abs() < 1e-12,
                "row {i}: {sx} against {}",
                rhs[i]
            );
        }
    }

    /// A row in the span of the factorised rows is dependent; one off it is not.
    #[test]
    fn a_row_in_the_span_is_dependent() {
        let a = [[1.0, 0.0, 0.5], [0.0, 1.0, -0.25]];
        let mut s = gram(&a);
        let mut cholesky = PivotedCholesky::default();
        assert_eq!(cholesky.factor(&mut s, 2), 2);
        let column = |row: [f64; 3]| -> (Vec<f64>, f64) {
            let b = a
                .iter()
                .map(|ai| (0..3).map(|k| ai[k] * row[k]).sum())
                .collect();
            (b, (0..3).map(|k| row[k] * row[k]).sum())
        };
        let (b, c) = column([2.0, -3.0, 1.75]);
        assert!(cholesky.dependent(&s, 2, &b, c));
        let (b, c) = column([2.0, -3.0, 1.76]);
        assert!(!cholesky.dependent(&s, 2, &b, c));
    }

    /// A positive definite system is solved as by any Cholesky factorisation.
    #[test]
    fn a_definite_system_is_solved_exactly() {
        let a = [[2.0, 0.0, 0.1], [0.3, 1.0, 0.0], [0.0, -0.4, 3.0]];
        let s0 = gram(&a);
        let rhs = [1.0, -2.0, 0.5];
        let mut s = s0.clone();
        let mut x = Vec::new();
        let mut cholesky = PivotedCholesky::default();
        assert_eq!(cholesky.factor(&mut s, 3), 3);
        cholesky.solve(&s, 3, &rhs, &mut x);
        for i in 0..3 {
            let sx: f64 = (0..3).map(|j| s0[i * 3 + j] * x[j]).sum();
            assert!((sx - rhs[i]).abs() < 1e-13, "row {i}");
        }
    }
}
