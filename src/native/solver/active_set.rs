//! A dense, warm-started primal active-set solver for small problems.
//!
//! It solves the scaled primal QP (see [`crate::native::problem::Scaled`])
//!
//! ```text
//! min 1/2 u' P u + q' u   s.t.  D u + r >= 0      (P diagonal, two rows per contact)
//! ```
//!
//! by keeping a working set W of rows held as equalities. For a given W the step is
//! `u = P^-1 (D_W' l - q)` with `(D_W P^-1 D_W') l = D_W P^-1 q - r_W`, solved on the
//! independent rows of W (see [`super::semidefinite`]): the rows of a flat interface are
//! dependent, and the dependent ones get no multiplier. Then the most violated
//! row outside W is added, or else the row with the most negative multiplier is dropped,
//! until the KKT conditions hold. W starts from the rows that were active in the previous
//! step (matched by contact key), so a step whose active set does not change costs one
//! factorisation of a matrix of the size of W.
//!
//! A problem it cannot settle within its move limit, on which its search meets a working set
//! again (the search is deterministic, so it cycles and would only reach the limit), or whose
//! working set turns out inconsistent, is reported as a failure; the `auto` back-end then gives
//! it to the sparse back-end.

use super::rows::{EdgeRow, edge_rows, step_solution_into};
use super::semidefinite::PivotedCholesky;
use super::visited::{Rule, VisitedSets};
use super::{ContactSolver, SolveFailure};
use crate::native::problem::{StepProblem, StepSolution};

#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct ActiveSetSolver {
    /// The working sets of the current search (see `solve_scaled`), one after the other.
    #[serde(skip)]
    visited: VisitedSets,
    /// Keys of the rows active at the previous solution, sorted.
    previous: Vec<u64>,
    rows: Vec<EdgeRow>,
    r: Vec<f64>,
    work: Vec<usize>,
    s: Vec<f64>,
    rhs: Vec<f64>,
    lambda: Vec<f64>,
    #[serde(skip)]
    cholesky: PivotedCholesky,
    u: Vec<f64>,
    pinv: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

impl ActiveSetSolver {
    pub fn new() -> Self {
        Self::default()
    }

    /// Solve the equality problem on the working set into `self.u` and `self.lambda`
    /// (indexed like `self.work`). Returns false on a numerical breakdown.
    fn solve_working_set(&mut self, q: &[f64]) -> bool {
        let m = self.work.len();
        let n = q.len();
        self.s.clear();
        self.s.resize(m * m, 0.0);
        self.rhs.clear();
        for a in 0..m {
            let ra = &self.rows[self.work[a]];
            let mut b_a = -self.r[self.work[a]];
            for j in 0..ra.len {
                b_a += ra.coef[j] * self.pinv[ra.idx[j]] * q[ra.idx[j]];
            }
            self.rhs.push(b_a);
            for b in 0..=a {
                let v = ra.weighted_dot(&self.rows[self.work[b]], &self.pinv);
                self.s[a * m + b] = v;
                self.s[b * m + a] = v;
            }
        }
        // Cholesky with diagonal pivoting, stopping at the numerical rank: dependent rows get 0.
        self.cholesky.factor(&mut self.s, m);
        self.cholesky.solve(&self.s, m, &self.rhs, &mut self.lambda);
        self.u.clear();
        self.u.extend((0..n).map(|j| -q[j] * self.pinv[j]));
        for a in 0..m {
            let row = &self.rows[self.work[a]];
            for j in 0..row.len {
                self.u[row.idx[j]] += row.coef[j] * self.lambda[a] * self.pinv[row.idx[j]];
            }
        }
        self.lambda.iter().chain(&self.u).all(|x| x.is_finite())
    }

    fn fail(status: String) -> SolveFailure {
        SolveFailure {
            solver: "active-set",
            status,
        }
    }
}

impl ContactSolver for ActiveSetSolver {
    fn name(&self) -> &'static str {
        "active-set"
    }

    fn save(&self) -> Vec<u8> {
        super::to_bytes(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = super::from_bytes(state, "the active-set back-end")?;
        Ok(())
    }

    fn solve_into(&mut self, pr: &StepProblem, out: &mut StepSolution) -> Result<(), SolveFailure> {
        let (mut p, mut q) = (std::mem::take(&mut self.p), std::mem::take(&mut self.q));
        let scale = pr.scale_into(&mut p, &mut q);
        self.pinv.clear();
        self.pinv.extend(p.iter().map(|p| 1.0 / p));
        let mut result = self.solve_scaled(pr, &q, scale, Rule::MostViolated, out);
        if result.is_err() {
            // Cycling among nearly dependent rows: Bland's rule from a cold start.
            result = self.solve_scaled(pr, &q, scale, Rule::Bland, out);
        }
        (self.p, self.q) = (p, q);
        result
    }
}

impl ActiveSetSolver {
    fn solve_scaled(
        &mut self,
        pr: &StepProblem,
        q: &[f64],
        scale: f64,
        rule: Rule,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        edge_rows(pr, &mut self.rows, &mut self.r);
        let nrows = self.rows.len();
        self.work.clear();
        for i in 0..nrows {
            let warm = if self.previous.is_empty() {
                self.r[i] <= 0.0
            } else {
                self.previous.binary_search(&self.rows[i].key).is_ok()
            };
            if warm {
                self.work.push(i);
            }
        }
        let max_moves = match rule {
            Rule::MostViolated => 3 * nrows + 10,
            Rule::Bland => 20 * nrows + 50,
        };
        let mut moves = 0;
        // Every working set this search has solved, in order: the search is deterministic, so
        // meeting one again means it cycles and would reach `max_moves` without an answer.
        self.visited.clear();
        loop {
            if !self.solve_working_set(q) {
                self.previous.clear();
                return Err(Self::fail("non-finite working-set solution".into()));
            }
            let lmax = self.lambda.iter().fold(1e-300f64, |a, &b| a.max(b.abs()));
            // Most violated row outside the working set.
            let mut worst: Option<(usize, f64)> = None;
            for i in 0..nrows {
                let v = self.rows[i].dot(&self.u) + self.r[i];
                if v < -1e-11 * (1.0 + self.r[i].abs())
                    && !self.work.contains(&i)
                    && worst.is_none_or(|w| rule == Rule::MostViolated && v < w.1)
                {
                    worst = Some((i, v));
                }
            }
            let action = if let Some((i, _)) = worst {
                Some((true, i))
            } else {
                // Most negative multiplier.
                let negative = self
                    .lambda
                    .iter()
                    .enumerate()
                    .filter(|&(_, &l)| l < -1e-10 * lmax);
                match rule {
                    Rule::MostViolated => negative.min_by(|a, b| a.1.total_cmp(b.1)),
                    Rule::Bland => negative.min_by_key(|&(a, _)| self.work[a]),
                }
                .map(|(a, _)| (false, a))
            };
            match action {
                None => break,
                Some(_) if moves >= max_moves => {
                    self.previous.clear();
                    return Err(Self::fail(format!(
                        "no optimal working set after {moves} moves"
                    )));
                }
                Some(_) if !self.visited.insert(&self.work) => {
                    self.previous.clear();
                    return Err(Self::fail(format!(
                        "the working set search cycles after {moves} moves"
                    )));
                }
                Some((true, i)) => self.work.push(i),
                Some((false, a)) => {
                    self.work.remove(a);
                }
            }
            moves += 1;
        }
        // Every working row must hold (an inconsistent dependent row would not).
        for &i in &self.work {
            let v = self.rows[i].dot(&self.u) + self.r[i];
            if v < -1e-9 * (1.0 + self.r[i].abs()) {
                self.previous.clear();
                return Err(Self::fail("inconsistent working set".into()));
            }
        }
        self.previous.clear();
        self.previous
            .extend(self.work.iter().map(|&i| self.rows[i].key));
        self.previous.sort_unstable();
        self.z.clear();
        self.z.resize(self.rows.len(), 0.0);
        for (a, &i) in self.work.iter().enumerate() {
            self.z[i] = self.lambda[a];
        }
        step_solution_into(pr, scale, &self.u, &self.z, moves as u32 + 1, out);
        Ok(())
    }
}
