//! Lemke's complementary pivoting method for a dense linear complementarity problem:
//! find `z >= 0` with `w = q + M z >= 0` and `z' w = 0`.
//!
//! With an artificial variable `z0` and the covering vector `e = (1, ..., 1)`, the system
//! `I w - M z - e z0 = q` starts from the basis of the `w` with `z0 = -min q` (the row of the
//! most negative `q_i` leaves) and then pivots complementarily: the complement of the variable
//! that just left enters, the leaving one is chosen by the minimum ratio test, until `z0`
//! leaves (a solution) or the entering column has no positive entry (a secondary ray). Ties in
//! the ratio test are broken lexicographically on the rows of `[x_B, B^-1]`, which keeps the
//! basis sequence from cycling on degenerate problems (the dependent rows of a flat interface),
//! so the method terminates in a finite number of pivots. For a copositive `M` (the Coulomb
//! problem's, see `crate::native::coulomb`) a secondary ray only arises when the problem has
//! no solution of the kind sought (Cottle, Pang and Stone, The Linear Complementarity Problem,
//! 1992, section 4.4).
//!
//! The basis inverse `B^-1` is kept dense and updated by each pivot (`O(n^2)` a pivot); the
//! final basic solution is refined by two steps of iterative refinement on the basis.

/// Why Lemke's method stopped without a solution.
#[derive(Debug, Clone, PartialEq)]
pub enum LemkeFailure {
    /// The entering column has no positive entry (secondary ray) after this many pivots.
    Ray { pivots: usize },
    /// More pivots than allowed.
    PivotLimit { pivots: usize },
    /// A non-finite number appeared.
    NonFinite { pivots: usize },
}

impl std::fmt::Display for LemkeFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LemkeFailure::Ray { pivots } => {
                write!(
                    f,
                    "Lemke's method ended on a secondary ray after {pivots} pivots"
                )
            }
            LemkeFailure::PivotLimit { pivots } => {
                write!(f, "Lemke's method did not terminate in {pivots} pivots")
            }
            LemkeFailure::NonFinite { pivots } => {
                write!(
                    f,
                    "Lemke's method met a non-finite number after {pivots} pivots"
                )
            }
        }
    }
}

/// A solution: `z` and the number of pivots taken.
#[derive(Debug, Clone)]
pub struct LemkeSolution {
    pub z: Vec<f64>,
    pub pivots: usize,
}

/// Solve the LCP `(q, M)`, `M` dense row-major `n x n`, in at most `max_pivots` pivots.
///
/// Ratios (and lexicographic entries) within `tie` (relative) of the smallest count as tied,
/// and the artificial variable leaves on a tie: the dependent rows of a (nearly) flat
/// interface make the basis ill-conditioned, so that ratios equal in exact arithmetic come out
/// up to ~1e-10 apart, while too wide a tie takes a wrong row. Entries of the entering column
/// below `pivot` times its largest are not pivoted on (round-off entries of dependent rows).
/// Which pair works depends on the problem: callers try several and check the answer.
pub fn lemke(
    m: &[f64],
    q: &[f64],
    max_pivots: usize,
    pivot: f64,
    tie: f64,
) -> Result<LemkeSolution, LemkeFailure> {
    let n = q.len();
    assert_eq!(m.len(), n * n, "Lemke: M must be n x n");
    // Variables: w_i = i, z_j = n + j, z0 = 2n.
    let z0 = 2 * n;
    let complement = |v: usize| if v < n { v + n } else { v - n };
    let Some((r0, qmin)) = q
        .iter()
        .copied()
        .enumerate()
        // The last of equal minima keeps the rows of [x_B, B^-1] lexicographically positive.
        .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
            Some((_, b)) if v > b => best,
            _ => Some((i, v)),
        })
    else {
        return Ok(LemkeSolution {
            z: vec![],
            pivots: 0,
        });
    };
    if qmin >= 0.0 {
        return Ok(LemkeSolution {
            z: vec![0.0; n],
            pivots: 0,
        });
    }
    // The LCP is homogeneous in (q, z): solve it for q / max|q|, so that the ratio test's
    // tolerances are relative.
    let qscale = q.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let q: Vec<f64> = q.iter().map(|v| v / qscale).collect();
    let q = &q[..];
    let mut basis: Vec<usize> = (0..n).collect();
    let mut binv = vec![0.0; n * n];
    for i in 0..n {
        binv[i * n + i] = 1.0;
    }
    let mut x = q.to_vec();
    // The column of a variable in `I w - M z - e z0 = q`.
    let column = |v: usize, out: &mut [f64]| {
        if v < n {
            out.fill(0.0);
            out[v] = 1.0;
        } else if v < z0 {
            let j = v - n;
            for i in 0..n {
                out[i] = -m[i * n + j];
            }
        } else {
            out.fill(-1.0);
        }
    };
    let mut a = vec![0.0; n];
    let mut d = vec![0.0; n];
    let do_pivot = |r: usize, d: &[f64], x: &mut [f64], binv: &mut [f64]| {
        let dr = d[r];
        x[r] /= dr;
        for k in 0..n {
            binv[r * n + k] /= dr;
        }
        for i in 0..n {
            if i != r && d[i] != 0.0 {
                let f = d[i];
                x[i] -= f * x[r];
                for k in 0..n {
                    binv[i * n + k] -= f * binv[r * n + k];
                }
            }
        }
    };
    // First pivot: z0 enters, the row of the most negative q leaves.
    column(z0, &mut a);
    d.copy_from_slice(&a); // B = I
    do_pivot(r0, &d, &mut x, &mut binv);
    let mut entering = complement(basis[r0]);
    basis[r0] = z0;
    let mut pivots = 1;
    let mut ties: Vec<usize> = Vec::new();
    loop {
        if pivots >= max_pivots {
            return Err(LemkeFailure::PivotLimit { pivots });
        }
        column(entering, &mut a);
        for i in 0..n {
            d[i] = (0..n).map(|k| binv[i * n + k] * a[k]).sum();
        }
        let dmax = d.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        if !dmax.is_finite() {
            return Err(LemkeFailure::NonFinite { pivots });
        }
        let tol = pivot * dmax;
        // Minimum ratio, then lexicographic ties.
        let mut best = f64::INFINITY;
        for i in 0..n {
            if d[i] > tol {
                best = best.min(x[i].max(0.0) / d[i]);
            }
        }
        if !best.is_finite() {
            return Err(LemkeFailure::Ray { pivots });
        }
        // Ties are decided to `tie`: the dependent rows of a (nearly) flat interface
        // make the basis ill-conditioned, and ratios equal in exact arithmetic come out ~1e-10
        // apart.
        let slack = tie * (1.0 + best.abs());
        ties.clear();
        ties.extend((0..n).filter(|&i| d[i] > tol && x[i].max(0.0) / d[i] <= best + slack));
        let r = if let Some(&r) = ties.iter().find(|&&i| basis[i] == z0) {
            r
        } else {
            let mut k = 0;
            while ties.len() > 1 && k < n {
                let (lo, size) = ties.iter().fold((f64::INFINITY, 0.0f64), |(lo, size), &i| {
                    let v = binv[i * n + k] / d[i];
                    (lo.min(v), size.max(v.abs()))
                });
                ties.retain(|&i| binv[i * n + k] / d[i] <= lo + tie * (1.0 + size));
                k += 1;
            }
            ties[0]
        };
        do_pivot(r, &d, &mut x, &mut binv);
        pivots += 1;
        let leaving = basis[r];
        basis[r] = entering;
        if leaving == z0 {
            break;
        }
        entering = complement(leaving);
    }
    // Iterative refinement of the basic solution: x += B^-1 (q - B x).
    let mut res = vec![0.0; n];
    for _ in 0..2 {
        res.copy_from_slice(q);
        for (i, &v) in basis.iter().enumerate() {
            column(v, &mut a);
            for k in 0..n {
                res[k] -= a[k] * x[i];
            }
        }
        for i in 0..n {
            x[i] += (0..n).map(|k| binv[i * n + k] * res[k]).sum::<f64>();
        }
    }
    let mut z = vec![0.0; n];
    for (i, &v) in basis.iter().enumerate() {
        if (n..z0).contains(&v) {
            z[v - n] = x[i].max(0.0) * qscale;
        }
    }
    if !z.iter().all(|v| v.is_finite()) {
        return Err(LemkeFailure::NonFinite { pivots });
    }
    Ok(LemkeSolution { z, pivots })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w_of(m: &[f64], q: &[f64], z: &[f64]) -> Vec<f64> {
        let n = q.len();
        (0..n)
            .map(|i| q[i] + (0..n).map(|j| m[i * n + j] * z[j]).sum::<f64>())
            .collect()
    }

    fn check(m: &[f64], q: &[f64], z: &[f64]) {
        let w = w_of(m, q, z);
        for i in 0..q.len() {
            assert!(z[i] >= 0.0 && w[i] >= -1e-12, "z {z:?} w {w:?}");
            assert!((z[i] * w[i]).abs() < 1e-12, "z {z:?} w {w:?}");
        }
    }

    #[test]
    fn a_positive_q_needs_no_pivot() {
        let s = lemke(&[2.0, 1.0, 1.0, 2.0], &[1.0, 0.5], 10, 1e-9, 1e-11).unwrap();
        assert_eq!(s.pivots, 0);
        assert_eq!(s.z, vec![0.0, 0.0]);
    }

    /// A symmetric positive definite M: the LCP is the KKT system of a convex QP, whose unique
    /// solution is found by hand: z = (4/3, 7/3)... checked through w and complementarity.
    #[test]
    fn solves_a_positive_definite_problem_and_its_degenerate_variant() {
        let m = [2.0, 1.0, 1.0, 2.0];
        let s = lemke(&m, &[-5.0, -6.0], 10, 1e-9, 1e-11).unwrap();
        assert!((s.z[0] - 4.0 / 3.0).abs() < 1e-14 && (s.z[1] - 7.0 / 3.0).abs() < 1e-14);
        check(&m, &[-5.0, -6.0], &s.z);
        // Degenerate: two equal rows of q (ties in the ratio test).
        let q = [-1.0, -1.0];
        let s = lemke(&m, &q, 10, 1e-9, 1e-11).unwrap();
        check(&m, &q, &s.z);
        assert!((s.z[0] - 1.0 / 3.0).abs() < 1e-14);
    }

    /// A singular positive semi-definite M (two identical rows: a flat interface's dependent
    /// points) with every ratio tied: lexicographic pivoting terminates at a solution.
    #[test]
    fn terminates_on_a_singular_degenerate_problem() {
        let m = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let q = [-1.0, -1.0, -1.0];
        let s = lemke(&m, &q, 50, 1e-9, 1e-11).unwrap();
        check(&m, &q, &s.z);
        assert!((s.z.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    }

    /// An infeasible LCP (w_1 = -1 - z_1 can never be non-negative) ends on a ray.
    #[test]
    fn an_infeasible_problem_ends_on_a_ray() {
        let m = [-1.0, 0.0, 0.0, 1.0];
        let q = [-1.0, 1.0];
        assert!(matches!(
            lemke(&m, &q, 10, 1e-9, 1e-11),
            Err(LemkeFailure::Ray { .. })
        ));
    }
}
