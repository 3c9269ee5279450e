//! Polishing an interior-point solution on its active set.
//!
//! With a working set W of rows taken as equalities, the equality-constrained QP
//!
//! ```text
//! min 1/2 u' P u + q' u   s.t.  D_W u + r_W = 0
//! ```
//!
//! is solved directly: `u = P^-1 (D_W' l - q)` with `(D_W P^-1 D_W') l = D_W P^-1 q - r_W`, on
//! the independent rows of W (see [`super::semidefinite`]: the rows of a flat interface are
//! dependent, and the dependent ones get no multiplier). W starts from the rows the
//! interior-point solution has closed (slack below multiplier, or a predicted gap below
//! 1e-10 m) and is corrected by active-set moves: add the most violated row, drop the row with
//! the most negative multiplier (at most 2 m + 4 moves, and never a working set met before: the
//! moves cycle there, see `solver::visited`; then again from the start under Bland's rule).
//!
//! The polished `u` is accepted when it meets the KKT conditions of the convex QP, which make it
//! the QP's one minimiser whatever the interior point's status or distance: stationarity (by
//! construction), non-negative multipliers (to 1e-9 of the interior point's largest), every row
//! outside W satisfied to 1e-12 (1 + |r_i|), and every row of W held. The independent rows of W
//! hold to round-off; a row dependent on the independent ones (a violated row outside W whose
//! entry would not raise the working set's rank, or a dependent row of W) must hold to
//! `CONSISTENT`, the dense back-end's consistency tolerance: in floating point the four rows of
//! a face's two sticking points on its three relative DOFs disagree at round-off. Otherwise the
//! interior-point solution stands (and a step whose status needed the check fails). This takes
//! the step from the solver tolerance (~1e-9 m on near-degenerate steps, and far more where
//! the interior point stalls) to round-off.

use super::semidefinite::PivotedCholesky;
use super::visited::{Rule, VisitedSets};

/// Largest working set polished (larger problems keep the interior-point solution).
pub const MAX_POLISHED_ROWS: usize = 200;

/// How far below zero a row dependent on the working set may be left, relative to
/// `1 + |r_i|` (the dense back-end's consistency test).
const CONSISTENT: f64 = 1e-9;

/// How far below zero any other row may be left, relative to `1 + |r_i|`.
const SATISFIED: f64 = 1e-12;

fn row_value(row: &[(usize, f64)], u: &[f64]) -> f64 {
    row.iter().map(|&(j, c)| c * u[j]).sum()
}

/// Why a solution was not polished (the interior-point solution stands).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Unpolished {
    #[error("its working set has {0} rows, more than {MAX_POLISHED_ROWS}")]
    TooManyRows(usize),
    #[error("the equality problem on its working set has no finite solution")]
    Breakdown,
    #[error("a violated row dependent on its working set can take no row's place")]
    Inconsistent,
    #[error("its working set search cycles after {0} moves")]
    Cycles(usize),
    #[error("its working set search found no optimal set in {0} moves")]
    MoveLimit(usize),
}

/// `rows[i] u + r[i] >= 0` are the constraints; `z` the interior-point multipliers. The
/// search from the interior point's closed rows moves by the most violated row and the most
/// negative multiplier; if that cycles or reaches its limit, it is searched again from there
/// under Bland's rule, which cannot cycle.
pub fn polish(
    p: &[f64],
    q: &[f64],
    rows: &[Vec<(usize, f64)>],
    r: &[f64],
    z: &[f64],
    dt: f64,
    u_ipm: &[f64],
) -> Result<Vec<f64>, Unpolished> {
    let start: Vec<usize> = (0..rows.len())
        .filter(|&i| {
            let slack = row_value(&rows[i], u_ipm) + r[i];
            slack < z[i] || slack * dt < 1e-10
        })
        .collect();
    let zmax = z.iter().fold(0.0f64, |a, &b| a.max(b));
    let problem = Problem {
        p,
        q,
        rows,
        r,
        zmax,
    };
    let mut eqp = Equalities::default();
    match problem.search(start.clone(), Rule::MostViolated, &mut eqp) {
        Err(Unpolished::Cycles(_) | Unpolished::MoveLimit(_)) => {
            problem.search(start, Rule::Bland, &mut eqp)
        }
        done => done,
    }
}

/// The QP whose solution is polished, and the interior point's largest multiplier.
struct Problem<'a> {
    p: &'a [f64],
    q: &'a [f64],
    rows: &'a [Vec<(usize, f64)>],
    r: &'a [f64],
    zmax: f64,
}

/// The equality problem's buffers and solution.
#[derive(Default)]
struct Equalities {
    cholesky: PivotedCholesky,
    dp: Vec<f64>,
    s: Vec<f64>,
    rhs: Vec<f64>,
    /// The multipliers of W's rows (0 on its dependent rows).
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// The products of a row outside W with W's rows, and its coefficients on them.
    column: Vec<f64>,
    alpha: Vec<f64>,
    /// A row outside W times `P^-1`, dense.
    row: Vec<f64>,
}

impl Problem<'_> {
    /// `rows[i] u + r[i]`.
    fn value(&self, i: usize, u: &[f64]) -> f64 {
        row_value(&self.rows[i], u) + self.r[i]
    }

    /// Solve the equality problem on working set `w` into `eqp`. False on a breakdown.
    fn solve(&self, w: &[usize], eqp: &mut Equalities) -> bool {
        let (p, q, rows, n, m) = (self.p, self.q, self.rows, self.p.len(), w.len());
        // Row a of D_W P^-1, dense.
        eqp.dp.clear();
        eqp.dp.resize(m * n, 0.0);
        for (a, &i) in w.iter().enumerate() {
            for &(j, v) in &rows[i] {
                eqp.dp[a * n + j] += v / p[j];
            }
        }
        eqp.s.clear();
        eqp.s.resize(m * m, 0.0);
        eqp.rhs.clear();
        for (a, &i) in w.iter().enumerate() {
            let dp_a = &eqp.dp[a * n..(a + 1) * n];
            eqp.rhs
                .push(dp_a.iter().zip(q).map(|(x, y)| x * y).sum::<f64>() - self.r[i]);
            for (b, &k) in w.iter().enumerate().take(a + 1) {
                let v = row_value(&rows[k], dp_a);
                eqp.s[a * m + b] = v;
                eqp.s[b * m + a] = v;
            }
        }
        eqp.cholesky.factor(&mut eqp.s, m);
        eqp.cholesky.solve(&eqp.s, m, &eqp.rhs, &mut eqp.lambda);
        eqp.u.clear();
        eqp.u.extend((0..n).map(|j| -q[j] / p[j]));
        for (a, &i) in w.iter().enumerate() {
            for &(j, v) in &rows[i] {
                eqp.u[j] += v * eqp.lambda[a] / p[j];
            }
        }
        eqp.lambda.iter().chain(&eqp.u).all(|x| x.is_finite())
    }

    /// The working-set search from `w` under `rule`; `eqp` holds W's solution.
    fn search(
        &self,
        mut w: Vec<usize>,
        rule: Rule,
        eqp: &mut Equalities,
    ) -> Result<Vec<f64>, Unpolished> {
        let rows = self.rows.len();
        let mut visited = VisitedSets::default();
        let limit = match rule {
            Rule::MostViolated => 2 * rows + 4,
            Rule::Bland => 20 * rows + 50,
        };
        for moves in 0..limit {
            if w.len() > MAX_POLISHED_ROWS {
                return Err(Unpolished::TooManyRows(w.len()));
            }
            if !visited.insert(&w) {
                return Err(Unpolished::Cycles(moves));
            }
            if !self.solve(&w, eqp) {
                return Err(Unpolished::Breakdown);
            }
            // A violated row outside W enters; one dependent on W's independent rows takes the
            // place of one of them (below), unless it holds to `CONSISTENT`.
            let mut consistent: Vec<usize> = Vec::new();
            let enters = loop {
                let mut violated = (0..rows)
                    .filter(|i| !w.contains(i) && !consistent.contains(i))
                    .map(|i| (i, self.value(i, &eqp.u)))
                    .filter(|&(i, v)| v < -SATISFIED * (1.0 + self.r[i].abs()));
                let candidate = match rule {
                    Rule::MostViolated => violated.min_by(|a, b| a.1.total_cmp(&b.1)),
                    Rule::Bland => violated.next(),
                };
                let Some((i, v)) = candidate else { break None };
                if !self.dependent(&w, i, eqp) {
                    break Some((i, None));
                }
                if v >= -CONSISTENT * (1.0 + self.r[i].abs()) {
                    consistent.push(i);
                    continue;
                }
                match self.exchanged(&w, eqp) {
                    Some(a) => break Some((i, Some(a))),
                    None => return Err(Unpolished::Inconsistent),
                }
            };
            match enters {
                Some((i, None)) => {
                    w.push(i);
                    continue;
                }
                Some((i, Some(a))) => {
                    w.remove(a);
                    w.push(i);
                    continue;
                }
                None => {}
            }
            // Else a negative multiplier leaves.
            let negative = eqp
                .lambda
                .iter()
                .enumerate()
                .filter(|&(_, &l)| l < -1e-9 * self.zmax.max(1e-300));
            let leaves = match rule {
                Rule::MostViolated => negative.min_by(|a, b| a.1.total_cmp(b.1)),
                Rule::Bland => negative.min_by_key(|&(a, _)| w[a]),
            };
            if let Some((a, _)) = leaves {
                w.remove(a);
                continue;
            }
            // A dependent row of W (it got no multiplier) that does not hold to `CONSISTENT`
            // leaves W, to enter again in another's place.
            if let Some(a) = (0..w.len())
                .find(|&a| self.value(w[a], &eqp.u) < -CONSISTENT * (1.0 + self.r[w[a]].abs()))
            {
                w.remove(a);
                continue;
            }
            return Ok(eqp.u.clone());
        }
        Err(Unpolished::MoveLimit(limit))
    }

    /// `D_W P^-1 d_i'`, the products of row i with W's rows, into `eqp.column`.
    fn column(&self, w: &[usize], i: usize, eqp: &mut Equalities) {
        let n = self.p.len();
        eqp.column.clear();
        eqp.column
            .extend((0..w.len()).map(|a| row_value(&self.rows[i], &eqp.dp[a * n..(a + 1) * n])));
    }

    /// Whether row i is dependent on the independent rows of W (as solved in `eqp`).
    fn dependent(&self, w: &[usize], i: usize, eqp: &mut Equalities) -> bool {
        self.column(w, i, eqp);
        // `d_i P^-1 d_i'` (a row's entries can repeat a DOF: its normal and tangential parts).
        eqp.row.clear();
        eqp.row.resize(self.p.len(), 0.0);
        for &(j, v) in &self.rows[i] {
            eqp.row[j] += v / self.p[j];
        }
        let c = row_value(&self.rows[i], &eqp.row);
        eqp.cholesky.dependent(&eqp.s, w.len(), &eqp.column, c)
    }

    /// For a row dependent on W's independent rows, `d_i = sum_a alpha_a d_{w_a}` (from the
    /// column [`Problem::dependent`] left in `eqp`): the place `a` it takes, where the
    /// multipliers `l_a - t alpha_a` (and `t` on row i) stay non-negative longest (the ratio
    /// test), or None if no `alpha_a` is positive (the rows cannot all hold).
    fn exchanged(&self, w: &[usize], eqp: &mut Equalities) -> Option<usize> {
        let Equalities {
            cholesky,
            s,
            column,
            alpha,
            lambda,
            ..
        } = eqp;
        cholesky.solve(s, w.len(), column, alpha);
        let largest = alpha.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        (0..w.len())
            .filter(|&a| alpha[a] > 1e-12 * largest)
            .min_by(|&a, &b| {
                (lambda[a].max(0.0) / alpha[a]).total_cmp(&(lambda[b].max(0.0) / alpha[b]))
            })
    }
}
