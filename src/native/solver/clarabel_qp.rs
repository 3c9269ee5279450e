//! The reference back-end: Clarabel on the primal (displacement) or dual (force) QP.
//!
//! Scaling: raw `Mbar` is ~1e10 at dt = 1e-3, so the unknowns are velocities `u = dq/dt`
//! and the objective is divided by `s = max(M)/theta`:
//!
//! ```text
//! primal:  min 1/2 u' P u + q' u   s.t.  -(nrow ± mu trow) u <= (g_n ± mu g_t)/dt
//!          P = M/(theta s),  q = -(dt f + M v0/theta)/s
//! dual:    min 1/2 c' (H P^-1 H') c + (g/dt - H P^-1 q)' c   s.t. ±T - mu N <= 0
//!          u = P^-1 (H'c - q)
//! ```
//!
//! The scaled dual variables are `c dt / s`. Presolve is off. The solution is polished on its
//! active set (see [`super::polish`]) unless `native.polish = false`. `Solved` is accepted;
//! `AlmostSolved` (reduced accuracy) when the settings allow it; `AlmostSolved`,
//! `InsufficientProgress` and `MaxIterations` when the polished solution passes the polish's
//! optimality check (every row satisfied, non-negative multipliers on the working set: the KKT
//! conditions of the convex QP, to round-off), which makes the step's displacement exact
//! whatever the interior-point status said; any other status is the step's error.

use super::{ContactSolver, SolveFailure, polish};
use crate::native::problem::{Scaled, StepProblem, StepSolution};
use crate::native::settings::{Formulation, NativeSettings};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT,
    SolverStatus,
};
use std::collections::BTreeMap;

/// The polish's outcome: done, or why not (`None`: the polish is off).
type Polish = Result<(), Option<polish::Unpolished>>;

pub struct ClarabelSolver {
    formulation: Formulation,
    settings: DefaultSettings<f64>,
    accept_almost: bool,
    polish: bool,
}

impl ClarabelSolver {
    pub fn new(s: &NativeSettings) -> Self {
        Self::with_formulation(s, s.formulation)
    }

    pub fn with_formulation(s: &NativeSettings, formulation: Formulation) -> Self {
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .tol_gap_abs(s.tolerance)
            .tol_gap_rel(s.tolerance)
            .tol_feas(s.tolerance)
            .max_iter(s.max_iterations)
            .build()
            .expect("clarabel settings are valid");
        ClarabelSolver {
            formulation,
            settings,
            accept_almost: s.accept_almost_solved,
            polish: s.polish,
        }
    }

    /// Solve `min 1/2 x'Px + q'x  s.t.  Ax <= b` (`rows` inequality rows) and check the status.
    fn run(
        &self,
        p: &CscMatrix<f64>,
        q: &[f64],
        a: &CscMatrix<f64>,
        b: &[f64],
        rows: usize,
    ) -> Result<(DefaultSolver<f64>, Option<SolverStatus>), SolveFailure> {
        let cones = if rows > 0 {
            vec![NonnegativeConeT(rows)]
        } else {
            vec![]
        };
        let mut solver =
            DefaultSolver::new(p, q, a, b, &cones, self.settings.clone()).map_err(|e| {
                SolveFailure {
                    solver: "clarabel",
                    status: format!("setup failed: {e:?}"),
                }
            })?;
        solver.solve();
        let verify = self.check(solver.solution.status)?;
        Ok((solver, verify))
    }

    /// Whether the status is acceptable outright (`Ok(None)`), acceptable once the polished
    /// solution passes its optimality check (`Ok(Some(status))`: a reduced-accuracy or stalled
    /// interior point, `AlmostSolved`, `InsufficientProgress`, `MaxIterations`), or an error
    /// (infeasibility, numerical failure).
    fn check(&self, status: SolverStatus) -> Result<Option<SolverStatus>, SolveFailure> {
        match status {
            SolverStatus::Solved => Ok(None),
            SolverStatus::AlmostSolved if self.accept_almost => Ok(None),
            SolverStatus::AlmostSolved
            | SolverStatus::InsufficientProgress
            | SolverStatus::MaxIterations
                if self.polish =>
            {
                Ok(Some(status))
            }
            other => Err(SolveFailure {
                solver: "clarabel",
                status: format!("{other:?}"),
            }),
        }
    }

    /// Whether the solution was polished; the error of a solution that needed the polish's
    /// check and did not pass it.
    fn polished_or_error(
        polish: Polish,
        verify: Option<SolverStatus>,
    ) -> Result<bool, SolveFailure> {
        match (polish, verify) {
            (Ok(()), _) => Ok(true),
            (Err(_), None) => Ok(false),
            (Err(why), Some(status)) => Err(SolveFailure {
                solver: "clarabel",
                status: match why {
                    Some(why) => format!(
                        "{status:?} (its active-set polish did not verify the solution: {why})"
                    ),
                    None => format!("{status:?} (unverified: the polish is off)"),
                },
            }),
        }
    }
}

/// Build a CSC matrix from (row, col) -> value entries.
fn csc(m: usize, n: usize, entries: &BTreeMap<(usize, usize), f64>) -> CscMatrix<f64> {
    let mut colptr = vec![0usize; n + 1];
    let mut rowval = Vec::with_capacity(entries.len());
    let mut nzval = Vec::with_capacity(entries.len());
    // BTreeMap is ordered by (row, col); CSC needs column-major order.
    let mut by_col: Vec<(usize, usize, f64)> =
        entries.iter().map(|(&(r, c), &v)| (c, r, v)).collect();
    by_col.sort_by_key(|a| (a.0, a.1));
    for &(c, r, v) in &by_col {
        colptr[c + 1] += 1;
        rowval.push(r);
        nzval.push(v);
    }
    for c in 0..n {
        colptr[c + 1] += colptr[c];
    }
    CscMatrix::new(m, n, colptr, rowval, nzval)
}

/// The primal rows `(nrow ± mu trow)` and offsets `(g_n ± mu g_t)/dt`, two per contact.
fn edge_rows(pr: &StepProblem) -> (Vec<Vec<(usize, f64)>>, Vec<f64>) {
    let mut rows = Vec::with_capacity(2 * pr.contacts.len());
    let mut r = Vec::with_capacity(2 * pr.contacts.len());
    for c in &pr.contacts {
        for sign in [1.0, -1.0] {
            let mut row: Vec<(usize, f64)> = c.nrow.to_vec();
            row.extend(c.trow.iter().map(|&(i, v)| (i, sign * c.mu * v)));
            rows.push(row);
            r.push((c.g_n + sign * c.mu * c.g_t) / pr.dt);
        }
    }
    (rows, r)
}

impl ClarabelSolver {
    /// Replace `u` by its polished value when polishing succeeds; `z` are the edge multipliers.
    fn polish(&self, pr: &StepProblem, sc: &Scaled, u: &mut Vec<f64>, z: &[f64]) -> Polish {
        if !self.polish {
            return Err(None);
        }
        let (rows, r) = edge_rows(pr);
        *u = polish::polish(&sc.p, &sc.q, &rows, &r, z, pr.dt, u).map_err(Some)?;
        Ok(())
    }

    fn solve_primal(&self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let n = pr.n_dof();
        let sc = pr.scaled();
        let mut pe = BTreeMap::new();
        for (i, &v) in sc.p.iter().enumerate() {
            pe.insert((i, i), v);
        }
        let m = 2 * pr.contacts.len();
        let mut ae = BTreeMap::new();
        let mut b = Vec::with_capacity(m);
        for (k, c) in pr.contacts.iter().enumerate() {
            for (r, sign) in [(2 * k, 1.0), (2 * k + 1, -1.0)] {
                for &(i, v) in &c.nrow {
                    *ae.entry((r, i)).or_insert(0.0) -= v;
                }
                for &(i, v) in &c.trow {
                    *ae.entry((r, i)).or_insert(0.0) -= sign * c.mu * v;
                }
                b.push((c.g_n + sign * c.mu * c.g_t) / pr.dt);
            }
        }
        let p = csc(n, n, &pe);
        let a = csc(m, n, &ae);
        let (solver, verify) = self.run(&p, &sc.q, &a, &b, m)?;
        let mut u = solver.solution.x.clone();
        let polished =
            Self::polished_or_error(self.polish(pr, &sc, &mut u, &solver.solution.z), verify)?;
        let dq: Vec<f64> = u.iter().map(|u| u * pr.dt).collect();
        let zscale = sc.s / pr.dt;
        let (mut normal, mut tangential) = (Vec::new(), Vec::new());
        for (k, c) in pr.contacts.iter().enumerate() {
            let (zp, zm) = (
                solver.solution.z[2 * k] * zscale,
                solver.solution.z[2 * k + 1] * zscale,
            );
            normal.push(zp + zm);
            tangential.push(c.mu * (zp - zm));
        }
        Ok(StepSolution {
            dq,
            normal,
            tangential,
            iterations: solver.solution.iterations,
            polished,
        })
    }

    fn solve_dual(&self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let n = pr.n_dof();
        let sc = pr.scaled();
        let k = pr.contacts.len();
        // Rows of H: 2k (N) and 2k+1 (T).
        let mut rows: Vec<&[(usize, f64)]> = Vec::with_capacity(2 * k);
        for c in &pr.contacts {
            rows.push(&c.nrow);
            rows.push(&c.trow);
        }
        // Rows touching each DOF, for the sparse product H P^-1 H'.
        let mut by_dof: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for (r, row) in rows.iter().enumerate() {
            for &(i, v) in row.iter() {
                by_dof[i].push((r, v));
            }
        }
        let mut pe: BTreeMap<(usize, usize), f64> = BTreeMap::new();
        for (i, list) in by_dof.iter().enumerate() {
            let w = 1.0 / sc.p[i];
            for &(r1, v1) in list {
                for &(r2, v2) in list {
                    if r1 <= r2 {
                        *pe.entry((r1, r2)).or_insert(0.0) += v1 * w * v2;
                    }
                }
            }
        }
        let mut qd = vec![0.0; 2 * k];
        for (r, row) in rows.iter().enumerate() {
            qd[r] = -row.iter().map(|&(i, v)| v * sc.q[i] / sc.p[i]).sum::<f64>();
        }
        for (kk, c) in pr.contacts.iter().enumerate() {
            qd[2 * kk] += c.g_n / pr.dt;
            qd[2 * kk + 1] += c.g_t / pr.dt;
        }
        let mut ae = BTreeMap::new();
        let mut b = Vec::with_capacity(3 * k);
        for (kk, c) in pr.contacts.iter().enumerate() {
            // T - mu N <= 0 ; -T - mu N <= 0 ; -N <= 0 (no tension: implied by the first two
            // only when mu > 0).
            let r = 3 * kk;
            ae.insert((r, 2 * kk), -c.mu);
            ae.insert((r, 2 * kk + 1), 1.0);
            ae.insert((r + 1, 2 * kk), -c.mu);
            ae.insert((r + 1, 2 * kk + 1), -1.0);
            ae.insert((r + 2, 2 * kk), -1.0);
            b.extend([0.0, 0.0, 0.0]);
        }
        let p = csc(2 * k, 2 * k, &pe);
        let a = csc(3 * k, 2 * k, &ae);
        let (solver, verify) = self.run(&p, &qd, &a, &b, 3 * k)?;
        let c = &solver.solution.x;
        let mut u: Vec<f64> = sc.q.iter().map(|q| -q).collect();
        for (r, row) in rows.iter().enumerate() {
            for &(i, v) in row.iter() {
                u[i] += v * c[r];
            }
        }
        for (ui, pi) in u.iter_mut().zip(&sc.p) {
            *ui /= pi;
        }
        // Edge multipliers from (N, T): z± = (N ± T/mu)/2 (z± = N/2 without friction).
        let z: Vec<f64> = pr
            .contacts
            .iter()
            .enumerate()
            .flat_map(|(kk, ct)| {
                let (nn, tt) = (c[2 * kk], c[2 * kk + 1]);
                let t_mu = if ct.mu > 0.0 { tt / ct.mu } else { 0.0 };
                [0.5 * (nn + t_mu), 0.5 * (nn - t_mu)]
            })
            .collect();
        let polished = Self::polished_or_error(self.polish(pr, &sc, &mut u, &z), verify)?;
        let dq = u.iter().map(|ui| ui * pr.dt).collect();
        let fscale = sc.s / pr.dt;
        Ok(StepSolution {
            dq,
            normal: (0..k).map(|kk| c[2 * kk] * fscale).collect(),
            tangential: (0..k).map(|kk| c[2 * kk + 1] * fscale).collect(),
            iterations: solver.solution.iterations,
            polished,
        })
    }
}

impl ContactSolver for ClarabelSolver {
    fn name(&self) -> &'static str {
        match self.formulation {
            Formulation::Primal => "clarabel-primal",
            Formulation::Dual => "clarabel-dual",
        }
    }

    /// Nothing: every problem is solved afresh from the scene's settings.
    fn save(&self) -> Vec<u8> {
        Vec::new()
    }

    fn restore(&mut self, _state: &[u8]) -> Result<(), String> {
        Ok(())
    }

    fn solve_into(
        &mut self,
        problem: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        *out = self.solve_problem(problem)?;
        Ok(())
    }
}

impl ClarabelSolver {
    /// The step problem in the configured formulation (free flight without a solver).
    fn solve_problem(&mut self, problem: &StepProblem) -> Result<StepSolution, SolveFailure> {
        if problem.contacts.is_empty() {
            // Free flight: the unconstrained minimiser u = -q / P, no solver needed.
            let sc = problem.scaled();
            return Ok(StepSolution {
                dq: sc
                    .q
                    .iter()
                    .zip(&sc.p)
                    .map(|(q, p)| -q / p * problem.dt)
                    .collect(),
                normal: Vec::new(),
                tangential: Vec::new(),
                iterations: 0,
                polished: false,
            });
        }
        match self.formulation {
            Formulation::Primal => self.solve_primal(problem),
            Formulation::Dual => self.solve_dual(problem),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::native::problem::ContactRows;

    /// A point mass on the ground under gravity: the contact holds it, N = m g.
    fn resting_mass() -> StepProblem {
        StepProblem {
            theta: 0.7,
            dt: 1e-3,
            mass: vec![2.0, 2.0, 1.0],
            force: vec![0.0, -2.0 * 9.81, 0.0],
            v0: vec![0.0; 3],
            contacts: vec![ContactRows {
                key: 0,
                mu: 0.5,
                g_n: 0.0,
                g_t: 0.0,
                nrow: [(1, 1.0)].into(),
                trow: [(0, 1.0)].into(),
            }],
        }
    }

    #[test]
    fn resting_mass_primal_and_dual_give_zero_increment_and_weight() {
        for f in [Formulation::Primal, Formulation::Dual] {
            let mut s = ClarabelSolver::with_formulation(&NativeSettings::default(), f);
            let sol = s.solve(&resting_mass()).unwrap();
            assert!(sol.dq.iter().all(|d| d.abs() < 1e-12), "{f:?} {:?}", sol.dq);
            assert!(
                (sol.normal[0] / (2.0 * 9.81) - 1.0).abs() < 1e-6,
                "{f:?} N = {}",
                sol.normal[0]
            );
            assert!(sol.tangential[0].abs() < 1e-6);
        }
    }

    /// A step without contact points is free flight under gravity, in both formulations.
    #[test]
    fn a_step_without_contacts_is_free_flight() {
        let mut pr = resting_mass();
        pr.contacts.clear();
        pr.v0 = vec![1.0, 2.0, 3.0];
        for f in [Formulation::Primal, Formulation::Dual] {
            let sol = ClarabelSolver::with_formulation(&NativeSettings::default(), f)
                .solve(&pr)
                .unwrap();
            // dq = dt v0 + theta dt^2 f / m.
            let want = [1e-3, 2e-3 - 0.7 * 1e-6 * 9.81, 3e-3];
            for (d, w) in sol.dq.iter().zip(want) {
                assert!((d - w).abs() < 1e-15, "{f:?}: {:?}", sol.dq);
            }
        }
    }

    #[test]
    fn pushed_mass_slides_with_friction_force_mu_n() {
        // A horizontal push of 3 m g exceeds mu m g: it slides, T = -mu N opposes it
        // (associative law: it also lifts by mu |du_t|).
        let mut pr = resting_mass();
        pr.force[0] = 3.0 * 2.0 * 9.81;
        for f in [Formulation::Primal, Formulation::Dual] {
            let mut s = ClarabelSolver::with_formulation(&NativeSettings::default(), f);
            let sol = s.solve(&pr).unwrap();
            assert!(sol.dq[0] > 0.0);
            assert!((sol.tangential[0] + 0.5 * sol.normal[0]).abs() < 1e-6 * sol.normal[0].abs());
            assert!(
                (sol.dq[1] - 0.5 * sol.dq[0]).abs() < 1e-12,
                "dilatancy dz = mu dx"
            );
        }
    }
}
