//! The primal rows shared by the active-set back-ends.
//!
//! Each contact point gives two rows of the scaled primal problem (see
//! [`crate::native::problem::Scaled`]), one per edge of the friction cone:
//! `(nrow ± mu trow) u + (g_n ± mu g_t)/dt >= 0`. Their multipliers `z±` are the forces along
//! the cone edges: `N = z+ + z-`, `T = mu (z+ - z-)`.

use crate::native::problem::{StepProblem, StepSolution};

/// One primal row over at most six DOFs (two blocks).
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub struct EdgeRow {
    pub idx: [usize; 6],
    pub coef: [f64; 6],
    pub len: usize,
    /// `(contact key << 1) | edge`: stable between steps, used for warm starts.
    pub key: u64,
}

impl EdgeRow {
    #[inline(always)]
    pub fn dot(&self, u: &[f64]) -> f64 {
        // A row holds one or two whole bodies; the fixed lengths unroll the same sum, in the
        // same order, as the general loop.
        let (c, i) = (&self.coef, &self.idx);
        match self.len {
            6 => two_bodies(c, [u[i[0]], u[i[1]], u[i[2]], u[i[3]], u[i[4]], u[i[5]]]),
            3 => [c[0] * u[i[0]], c[1] * u[i[1]], c[2] * u[i[2]]]
                .into_iter()
                .sum(),
            len => (0..len).map(|j| c[j] * u[i[j]]).sum(),
        }
    }
    /// `(a · u, b · u)` for the two edge rows of one contact point (the same DOFs: rows `2k`
    /// and `2k + 1` of [`edge_rows`]), each summed as [`EdgeRow::dot`] sums it, `u` gathered once.
    #[inline(always)]
    pub fn dot_pair(a: &EdgeRow, b: &EdgeRow, u: &[f64]) -> (f64, f64) {
        debug_assert!(a.len == b.len && a.idx[..a.len] == b.idx[..b.len]);
        let (ca, cb, i) = (&a.coef, &b.coef, &a.idx);
        match a.len {
            6 => {
                let g = [u[i[0]], u[i[1]], u[i[2]], u[i[3]], u[i[4]], u[i[5]]];
                (two_bodies(ca, g), two_bodies(cb, g))
            }
            _ => (a.dot(u), b.dot(u)),
        }
    }
    /// `row · diag(w) · other`. A row holds whole bodies, three consecutive DOFs each (B's,
    /// then A's: `assembly::contact_rows`), so rows share DOFs only by sharing a body: the
    /// bodies are matched, not every pair of entries.
    #[inline]
    pub fn weighted_dot(&self, other: &EdgeRow, w: &[f64]) -> f64 {
        let mut v = 0.0;
        for j in (0..self.len).step_by(3) {
            for k in (0..other.len).step_by(3) {
                if self.idx[j] == other.idx[k] {
                    for d in 0..3 {
                        v += self.coef[j + d] * other.coef[k + d] * w[self.idx[j + d]];
                    }
                }
            }
        }
        v
    }
    /// `x += a * row'`.
    pub fn axpy(&self, a: f64, x: &mut [f64]) {
        for j in 0..self.len {
            x[self.idx[j]] += a * self.coef[j];
        }
    }
}

/// `c · g` for a row on two bodies, `g` its six DOFs' values gathered: the one order of
/// summation that [`EdgeRow::dot`] and [`EdgeRow::dot_pair`] share.
#[inline(always)]
fn two_bodies(c: &[f64; 6], g: [f64; 6]) -> f64 {
    [
        c[0] * g[0],
        c[1] * g[1],
        c[2] * g[2],
        c[3] * g[3],
        c[4] * g[4],
        c[5] * g[5],
    ]
    .into_iter()
    .sum()
}

/// `out[i] = rows[i] · x` for rows in edge pairs (as [`edge_rows`] makes them), each pair's `x`
/// gathered once ([`EdgeRow::dot_pair`]).
pub fn dots_into(rows: &[EdgeRow], x: &[f64], out: &mut Vec<f64>) {
    assert!(rows.len().is_multiple_of(2), "edge rows come in pairs");
    out.resize(rows.len(), 0.0);
    for (pair, dots) in rows.chunks_exact(2).zip(out.chunks_exact_mut(2)) {
        (dots[0], dots[1]) = EdgeRow::dot_pair(&pair[0], &pair[1], x);
    }
}

/// Fill `rows` and their offsets `r` (row 2k is contact k's `+` edge, 2k + 1 its `-` edge).
pub fn edge_rows(pr: &StepProblem, rows: &mut Vec<EdgeRow>, r: &mut Vec<f64>) {
    // Written in place over the last problem's rows (a row is some 100 bytes).
    rows.resize_with(2 * pr.contacts.len(), Default::default);
    r.clear();
    for (c, pair) in pr.contacts.iter().zip(rows.chunks_exact_mut(2)) {
        debug_assert!(
            c.nrow.len() % 3 == 0
                && c.nrow
                    .chunks(3)
                    .all(|b| b[1].0 == b[0].0 + 1 && b[2].0 == b[0].0 + 2),
            "a row holds whole bodies, three consecutive DOFs each"
        );
        for ((e, sign), row) in [(0u64, 1.0), (1u64, -1.0)].into_iter().zip(pair) {
            row.key = (c.key << 1) | e;
            row.len = c.nrow.len();
            for (j, (&(i, vn), &(it, vt))) in c.nrow.iter().zip(&c.trow).enumerate() {
                debug_assert_eq!(i, it);
                row.idx[j] = i;
                row.coef[j] = vn + sign * c.mu * vt;
            }
            if row.len < row.idx.len() {
                row.idx[row.len..].fill(0);
                row.coef[row.len..].fill(0.0);
            }
            r.push((c.g_n + sign * c.mu * c.g_t) / pr.dt);
        }
    }
}

/// The step from the scaled solution `u` and the scaled edge multipliers `lambda` (one per
/// row, in the order of [`edge_rows`]); `s` is the objective scale of
/// [`crate::native::problem::Scaled`].
pub fn step_solution(
    pr: &StepProblem,
    s: f64,
    u: &[f64],
    lambda: &[f64],
    iterations: u32,
) -> StepSolution {
    let mut out = StepSolution::default();
    step_solution_into(pr, s, u, lambda, iterations, &mut out);
    out
}

/// [`step_solution`] into `out`'s buffers.
pub fn step_solution_into(
    pr: &StepProblem,
    s: f64,
    u: &[f64],
    lambda: &[f64],
    iterations: u32,
    out: &mut StepSolution,
) {
    let zscale = s / pr.dt;
    out.dq.clear();
    out.dq.extend(u.iter().map(|u| u * pr.dt));
    out.normal.clear();
    out.normal
        .extend((0..pr.contacts.len()).map(|c| (lambda[2 * c] + lambda[2 * c + 1]) * zscale));
    out.tangential.clear();
    out.tangential.extend(
        pr.contacts
            .iter()
            .enumerate()
            .map(|(c, ct)| ct.mu * (lambda[2 * c] - lambda[2 * c + 1]) * zscale),
    );
    out.iterations = iterations;
    out.polished = false;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::native::problem::{ContactRows, SparseRow};

    /// Contact `k`'s rows: a point between two blocks (six entries) or on the ground (three).
    fn contact(k: u64, between_blocks: bool, rnd: &mut impl FnMut() -> f64) -> ContactRows {
        let bodies: &[usize] = if between_blocks { &[1, 0] } else { &[2] };
        let entries = |rnd: &mut dyn FnMut() -> f64| {
            let mut row = SparseRow::new();
            for &b in bodies {
                for d in 0..3 {
                    row.push((3 * b + d, rnd()));
                }
            }
            row
        };
        ContactRows {
            key: k,
            mu: 0.5 + 0.5 * rnd(),
            g_n: 1e-4 * rnd(),
            g_t: 1e-4 * rnd(),
            nrow: entries(rnd),
            trow: entries(rnd),
        }
    }

    fn problem(kinds: &[bool], rnd: &mut impl FnMut() -> f64) -> StepProblem {
        StepProblem {
            theta: 0.5,
            dt: 1e-3,
            mass: vec![1.0; 9],
            force: vec![0.0; 9],
            v0: vec![0.0; 9],
            contacts: kinds
                .iter()
                .enumerate()
                .map(|(k, &b)| contact(k as u64, b, rnd))
                .collect(),
        }
    }

    fn same(a: &EdgeRow, b: &EdgeRow) -> bool {
        a.idx == b.idx
            && a.coef.map(f64::to_bits) == b.coef.map(f64::to_bits)
            && a.len == b.len
            && a.key == b.key
    }

    #[test]
    fn edge_rows_written_over_other_rows_are_the_rows_of_a_fresh_buffer() {
        let mut rnd = crate::test_random::signed(7);
        let first = problem(&[true, true, true], &mut rnd);
        // Fewer contacts, a ground point (three entries) where a six-entry row was.
        let second = problem(&[false, true], &mut rnd);
        let (mut rows, mut r) = (Vec::new(), Vec::new());
        edge_rows(&first, &mut rows, &mut r);
        assert_eq!(rows.len(), 6);
        edge_rows(&second, &mut rows, &mut r);
        let (mut fresh, mut fresh_r) = (Vec::new(), Vec::new());
        edge_rows(&second, &mut fresh, &mut fresh_r);
        assert_eq!(rows.len(), 4);
        assert!(rows.iter().zip(&fresh).all(|(a, b)| same(a, b)));
        assert_eq!(r, fresh_r);
        assert_eq!((rows[0].len, rows[2].len), (3, 6));
        assert_eq!(
            (&rows[0].idx[3..], &rows[0].coef[3..]),
            (&[0; 3][..], &[0.0; 3][..])
        );
        // The `+` and `-` edges of contact 0: `(nrow ± mu trow)`, offsets `(g_n ± mu g_t)/dt`.
        let c = &second.contacts[0];
        for (row, sign) in rows[..2].iter().zip([1.0, -1.0]) {
            for j in 0..3 {
                assert_eq!(row.coef[j], c.nrow[j].1 + sign * c.mu * c.trow[j].1);
            }
        }
        assert_eq!(r[1], (c.g_n - c.mu * c.g_t) / second.dt);
    }

    #[test]
    fn pair_dots_are_each_rows_dot_to_the_bit() {
        let mut rnd = crate::test_random::signed(11);
        let pr = problem(&[true, false, true, true, false], &mut rnd);
        let (mut rows, mut r) = (Vec::new(), Vec::new());
        edge_rows(&pr, &mut rows, &mut r);
        let x: Vec<f64> = (0..9).map(|_| 1e3 * rnd()).collect();
        let mut dots = vec![f64::NAN; 3];
        dots_into(&rows, &x, &mut dots);
        assert_eq!(dots.len(), rows.len());
        for (row, d) in rows.iter().zip(&dots) {
            let by_hand: f64 = (0..row.len).map(|j| row.coef[j] * x[row.idx[j]]).sum();
            assert_eq!(d.to_bits(), row.dot(&x).to_bits());
            assert!((d - by_hand).abs() <= 1e-12 * by_hand.abs().max(1.0));
        }
    }
}
