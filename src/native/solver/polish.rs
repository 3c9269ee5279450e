//! Polishing an interior-point solution on its active set.
//!
//! With a working set W of rows taken as equalities, the equality-constrained QP
//!
//! ```text
//! min 1/2 u' P u + q' u   s.t.  D_W u + r_W = 0
//! ```
//!
//! is solved directly: `u = P^-1 (D_W' l - q)` with `(D_W P^-1 D_W') l = D_W P^-1 q - r_W`
//! (pseudo-inverse: the rows of a flat interface can be dependent). W starts from the rows the
//! interior-point solution has closed (slack below multiplier, or a predicted gap below
//! 1e-10 m) and is corrected by active-set moves: add the most violated row, drop the row with
//! the most negative multiplier, until the KKT conditions hold (at most 2 m + 4 moves, and
//! never a working set met before: the moves cycle there, see [`super::visited`]). The
//! polished `u` is used only if it satisfies every row, has non-negative multipliers and stays
//! close to the interior-point solution; otherwise the interior-point solution stands. This
//! takes the step from the solver tolerance (~1e-9 m on near-degenerate steps) to round-off.

use super::visited::VisitedSets;
use nalgebra::{DMatrix, DVector};

/// Largest working set polished (larger problems keep the interior-point solution).
pub const MAX_POLISHED_ROWS: usize = 200;

fn row_value(row: &[(usize, f64)], u: &[f64]) -> f64 {
    row.iter().map(|&(j, c)| c * u[j]).sum()
}

/// Solve the equality QP on working set `w`: returns (u, multipliers of w).
fn solve_eqp(
    p: &[f64],
    q: &[f64],
    rows: &[Vec<(usize, f64)>],
    r: &[f64],
    w: &[usize],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = p.len();
    let m = w.len();
    if m == 0 {
        return Some(((0..n).map(|j| -q[j] / p[j]).collect(), Vec::new()));
    }
    let mut dp = DMatrix::<f64>::zeros(m, n);
    let mut d = DMatrix::<f64>::zeros(m, n);
    for (a, &i) in w.iter().enumerate() {
        for &(j, v) in &rows[i] {
            d[(a, j)] += v;
            dp[(a, j)] += v / p[j];
        }
    }
    let s = &dp * d.transpose();
    let rhs =
        &dp * DVector::from_column_slice(q) - DVector::from_iterator(m, w.iter().map(|&i| r[i]));
    let eps = 1e-13 * s.amax().max(1e-300);
    let lambda = s.svd(true, true).solve(&rhs, eps).ok()?;
    let dl = d.transpose() * &lambda;
    let u = (0..n).map(|j| (dl[j] - q[j]) / p[j]).collect();
    Some((u, lambda.iter().copied().collect()))
}

/// Why a solution was not polished (the interior-point solution stands).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Unpolished {
    #[error("its working set has {0} rows, more than {MAX_POLISHED_ROWS}")]
    TooManyRows(usize),
    #[error("the equality problem on its working set has no solution")]
    Breakdown,
    #[error("its working set search cycles after {0} moves")]
    Cycles(usize),
    #[error("its working set search found no optimal set in {0} moves")]
    MoveLimit(usize),
    #[error("the polished solution is not finite or not close to the interior point's")]
    Far,
}

/// `rows[i] u + r[i] >= 0` are the constraints; `z` the interior-point multipliers.
pub fn polish(
    p: &[f64],
    q: &[f64],
    rows: &[Vec<(usize, f64)>],
    r: &[f64],
    z: &[f64],
    dt: f64,
    u_ipm: &[f64],
) -> Result<Vec<f64>, Unpolished> {
    let mut w: Vec<usize> = (0..rows.len())
        .filter(|&i| {
            let slack = row_value(&rows[i], u_ipm) + r[i];
            slack < z[i] || slack * dt < 1e-10
        })
        .collect();
    let zmax = z.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut visited = VisitedSets::default();
    let limit = 2 * rows.len() + 4;
    for moves in 0..limit {
        if w.len() > MAX_POLISHED_ROWS {
            return Err(Unpolished::TooManyRows(w.len()));
        }
        if !visited.insert(&w) {
            return Err(Unpolished::Cycles(moves));
        }
        let (u, lambda) = solve_eqp(p, q, rows, r, &w).ok_or(Unpolished::Breakdown)?;
        // Most violated row outside W.
        let viol = (0..rows.len())
            .filter(|i| !w.contains(i))
            .map(|i| (i, row_value(&rows[i], &u) + r[i]))
            .filter(|&(i, v)| v < -1e-12 * (1.0 + r[i].abs()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, _)) = viol {
            w.push(i);
            continue;
        }
        // Most negative multiplier inside W.
        let neg = lambda
            .iter()
            .enumerate()
            .filter(|&(_, &l)| l < -1e-9 * zmax.max(1e-300))
            .min_by(|a, b| a.1.total_cmp(b.1));
        if let Some((a, _)) = neg {
            w.remove(a);
            continue;
        }
        let scale = 1.0 + u_ipm.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let close = u
            .iter()
            .zip(u_ipm)
            .all(|(a, b)| (a - b).abs() <= 1e-5 * scale);
        return if close && u.iter().all(|x| x.is_finite()) {
            Ok(u)
        } else {
            Err(Unpolished::Far)
        };
    }
    Err(Unpolished::MoveLimit(limit))
}
