//! Primal-dual interior-point iterations (Mehrotra's predictor-corrector) for the sparse
//! back-end's problem
//!
//! ```text
//! min 1/2 u' P u + q' u   s.t.  D u + r = s,  s >= 0      (P diagonal)
//! ```
//!
//! with multipliers `l >= 0` (`P u + q = D' l`, `l_i s_i = 0` at the solution). Each iteration
//! solves the Newton system of the perturbed conditions `l_i s_i = sigma mu` through
//!
//! ```text
//! (P + D' W D) du = -r_d - D' (W r_p + r_c / s),      W = diag(l_i / s_i)
//! dl = -W (r_p + D du) - r_c / s,   ds = -(r_c + s dl) / l
//! ```
//!
//! (`r_d = P u + q - D' l`, `r_p = D u + r - s`, `r_c = s l - sigma mu` plus Mehrotra's
//! second-order term), factorised on the same envelope as the augmented Lagrangian's Newton
//! matrix: every row enters it, weighted. The primal variables `(u, s)` and the dual ones `l`
//! then step to 0.995 of their own boundaries, each with its own length. The number of iterations does not depend on how far
//! the solution's active rows are from a starting guess, which is what the augmented Lagrangian
//! needs when a wall's loads change abruptly (see [`super::sparse`]); its result is handed to
//! the augmented Lagrangian, which settles it to the back-end's tolerances.

use super::envelope::Envelope;
use super::rows::{EdgeRow, dots_into};

/// Iterations allowed.
const MAX_ITERATIONS: usize = 60;
/// Fraction of the step to the boundary of `s, l >= 0` taken.
const TO_BOUNDARY: f64 = 0.995;
/// Largest weight of a row in the Newton matrix, normalised as the augmented Lagrangian's
/// penalties are (`w_i D_i P^-1 D_i'`): as `s_i -> 0` on a closed row `l_i / s_i` grows without
/// bound, and the envelope factorisation refuses a matrix whose pivots fall below 1e-15 of
/// their diagonal (random chains of 3-40 blocks, the tests below, at iteration 10 uncapped or
/// capped at 1e16). With the cap the direction keeps stationarity and the complementarity
/// equations exact and leaves part of a capped row's residual `D u + r - s` to the next
/// iterations (a primal regularisation), which slows the last iterations when the cap is low.
/// Measured on the 430-block wall under El Centro x2, its first 4.24 s (it moves from 4.2 s;
/// some 1300 rescues), caps 1e10 / 1e12 / 1e13 / 1e14 / 1e16 / none: 18.5 / 13.1 / 13.8 / 12.4 /
/// 11.5 / 12.1 ms a step, 88 / 2 / 2 / 0 / 0 / 0 rescues not converged in `MAX_ITERATIONS`.
const WEIGHT_MAX: f64 = 1e14;
/// The iterate kept for the next solve's start: the first whose mean complementarity `mu` is
/// below this. Measured on the sliding walls of 215 / 430 / 860 blocks (ten pulse steps at
/// step ends, all factorisations, this start alone, without the held rows of
/// [`super::sparse`]), levels 1e-7 / 1e-8 / 1e-9 / 1e-10 / 1e-11: 522 / 527 / 531 / 599 / 540,
/// 798 / 794 / 790 / 785 / 780, 1700 / 1631 / 1493 / 1526 / 1540 against 634 / 820 / 1719 from
/// the least-squares start; at 1e-7 two starts of the 860-block wall failed. A start from
/// the iterate of a problem with other rows (matched by key, new rows centred) failed in
/// `MAX_PATH_ITERATIONS` every time it was tried there.
const PATH_MU: f64 = 1e-8;
/// Iterations allowed from a kept iterate before the solve starts again cold.
const MAX_PATH_ITERATIONS: usize = 30;

/// Where the iterations start.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Start {
    /// Mehrotra's least-squares point.
    LeastSquares,
    /// The kept iterate at `PATH_MU` of a problem with the same rows.
    Path,
    /// The iterate in hand, for at most this many iterations.
    Current(usize),
}

/// How iterations that did not fail ended.
enum Ended {
    /// At the tolerance, after this many iterations.
    Converged(usize),
    /// Out of iterations (this many), the last iterate in hand.
    OutOfIterations(usize),
}

impl Ended {
    /// The iterations taken to the tolerance, or the error of a solve that ran out of them.
    fn converged(self) -> Result<usize, String> {
        match self {
            Ended::Converged(iterations) => Ok(iterations),
            Ended::OutOfIterations(max) => {
                Err(format!("interior point: not converged in {max} iterations"))
            }
        }
    }
}

/// A problem: `(P, q)` and the rows `(D, r)`.
pub type Problem<'a> = ((&'a [f64], &'a [f64]), (&'a [EdgeRow], &'a [f64]));

/// Buffers of the iteration.
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct InteriorPoint {
    s: Vec<f64>,
    /// `min(l_i / s_i, w_max_i)`, the rows' weights in the Newton matrix.
    w: Vec<f64>,
    w_max: Vec<f64>,
    rp: Vec<f64>,
    rc: Vec<f64>,
    rd: Vec<f64>,
    du: Vec<f64>,
    dl: Vec<f64>,
    ds: Vec<f64>,
    du_aff: Vec<f64>,
    dl_aff: Vec<f64>,
    ds_aff: Vec<f64>,
    /// The last solve's iterate at `PATH_MU` (its rows' keys, `u`, `s`, `l`), if it got there.
    path_keys: Vec<u64>,
    path_u: Vec<f64>,
    path_s: Vec<f64>,
    path_l: Vec<f64>,
    /// Scratch: the kept iterate's rows by key.
    path_by_key: Vec<(u64, usize)>,
    /// Solves started from a kept iterate, and those of them that failed and started again cold.
    pub path_starts: u64,
    pub path_failures: u64,
}

impl InteriorPoint {
    /// Solve `(P, q)` under `(D, r)` to residuals below `tolerance` (rows relative to
    /// `1 + |r_i|`, stationarity relative to `1 + |q|_inf`) and a mean complementarity
    /// `mu = s'l / m` below `tolerance^2`; `(u, l)` receive the solution and its multipliers,
    /// [`InteriorPoint::slack`] its slacks; returns the iterations. Fails (with the reason)
    /// when a Newton matrix is not positive definite, a step is not finite or the iterations
    /// run out. Every factorisation is counted in `factorisations`.
    ///
    /// With `from_path`, a problem whose rows are the last solve's (the same keys, in any
    /// order) starts from that solve's iterate at `PATH_MU`, a point near the central path of a
    /// neighbouring problem (the second discrete-gradient solve of a step differs from the
    /// first by its drift): some 20 iterations instead of 40 on the 860-block wall. If that
    /// does not converge in `MAX_PATH_ITERATIONS`, the solve starts again cold.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        envelope: &mut Envelope,
        (p, q): (&[f64], &[f64]),
        (rows, r): (&[EdgeRow], &[f64]),
        tolerance: f64,
        (u, l): (&mut Vec<f64>, &mut Vec<f64>),
        factorisations: &mut u64,
        from_path: bool,
    ) -> Result<usize, String> {
        if from_path && self.start_from_path(p.len(), rows, u, l) {
            self.path_starts += 1;
            let problem = ((p, q), (rows, r));
            match self
                .iterate(
                    envelope,
                    problem,
                    tolerance,
                    (u, l),
                    factorisations,
                    Start::Path,
                )
                .and_then(Ended::converged)
            {
                Ok(iterations) => return Ok(iterations),
                Err(_) => self.path_failures += 1,
            }
        }
        self.iterate(
            envelope,
            ((p, q), (rows, r)),
            tolerance,
            (u, l),
            factorisations,
            Start::LeastSquares,
        )
        .and_then(Ended::converged)
    }

    /// The last solve continued from its final iterate (`u`, `l` as it returned them, its
    /// slacks kept) towards a smaller `tolerance`, on the same problem, for at most
    /// `max_iterations`: whether it got there; either way `(u, l)` and the slacks are its last
    /// iterate. Fails as [`InteriorPoint::solve`] does, but for running out of iterations.
    pub fn resume(
        &mut self,
        envelope: &mut Envelope,
        problem: Problem,
        tolerance: f64,
        (u, l): (&mut Vec<f64>, &mut Vec<f64>),
        factorisations: &mut u64,
        max_iterations: usize,
    ) -> Result<bool, String> {
        let ((p, _), (rows, _)) = problem;
        if self.s.len() != rows.len() || l.len() != rows.len() || u.len() != p.len() {
            return Err("interior point: no iterate of this problem to resume".into());
        }
        self.iterate(
            envelope,
            problem,
            tolerance,
            (u, l),
            factorisations,
            Start::Current(max_iterations),
        )
        .map(|ended| matches!(ended, Ended::Converged(_)))
    }

    /// `u`, `l` and the slacks from the kept iterate, when the problem has its rows and DOFs.
    fn start_from_path(
        &mut self,
        n: usize,
        rows: &[EdgeRow],
        u: &mut Vec<f64>,
        l: &mut Vec<f64>,
    ) -> bool {
        if self.path_u.len() != n || self.path_keys.len() != rows.len() {
            return false;
        }
        self.path_by_key.clear();
        self.path_by_key
            .extend(self.path_keys.iter().copied().zip(0..));
        self.path_by_key.sort_unstable();
        self.s.clear();
        l.clear();
        for row in rows {
            let Ok(k) = self.path_by_key.binary_search_by_key(&row.key, |e| e.0) else {
                return false;
            };
            let i = self.path_by_key[k].1;
            self.s.push(self.path_s[i]);
            l.push(self.path_l[i]);
        }
        u.clone_from(&self.path_u);
        true
    }

    /// The iterations, from the kept iterate (`from_path`, `u`, `l` and the slacks set by
    /// [`InteriorPoint::start_from_path`]) or from the least-squares point.
    fn iterate(
        &mut self,
        envelope: &mut Envelope,
        ((p, q), (rows, r)): Problem,
        tolerance: f64,
        (u, l): (&mut Vec<f64>, &mut Vec<f64>),
        factorisations: &mut u64,
        start: Start,
    ) -> Result<Ended, String> {
        let from_path = start == Start::Path;
        let (n, m) = (p.len(), rows.len());
        self.w_max.clear();
        self.w_max.extend(rows.iter().map(|row| {
            let d: f64 = (0..row.len)
                .map(|j| row.coef[j] * row.coef[j] / p[row.idx[j]])
                .sum();
            WEIGHT_MAX / d
        }));
        if start == Start::LeastSquares {
            self.least_squares_start(envelope, (p, q), (rows, r), (u, l), factorisations)?;
        }
        let q_size = 1.0 + q.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let max_iterations = match start {
            Start::LeastSquares => MAX_ITERATIONS,
            Start::Path => MAX_PATH_ITERATIONS,
            Start::Current(max) => max,
        };
        // The kept iterate is replaced by this solve's at `PATH_MU` (not by its start); a
        // resumed solve keeps its own.
        let mut kept = matches!(start, Start::Current(_));
        if !kept {
            self.path_keys.clear();
        }
        for iteration in 1..=max_iterations {
            // Residuals.
            self.rd.clear();
            self.rd.extend((0..n).map(|j| p[j] * u[j] + q[j]));
            for (row, &li) in rows.iter().zip(l.iter()) {
                row.axpy(-li, &mut self.rd);
            }
            let mut primal = 0.0f64;
            dots_into(rows, u, &mut self.rp);
            for (i, rp) in self.rp.iter_mut().enumerate() {
                *rp = *rp + r[i] - self.s[i];
                primal = primal.max(rp.abs() / (1.0 + r[i].abs()));
            }
            let dual = self.rd.iter().fold(0.0f64, |a, x| a.max(x.abs())) / q_size;
            let mu = self.s.iter().zip(l.iter()).map(|(s, x)| s * x).sum::<f64>() / m as f64;
            if !kept && mu <= PATH_MU && !(from_path && iteration == 1) {
                kept = true;
                self.path_keys.extend(rows.iter().map(|row| row.key));
                self.path_u.clone_from(u);
                self.path_s.clone_from(&self.s);
                self.path_l.clone_from(l);
            }
            if primal <= tolerance && dual <= tolerance && mu <= tolerance * tolerance {
                return Ok(Ended::Converged(iteration - 1));
            }
            // The Newton matrix.
            self.w.clear();
            self.w
                .extend((0..m).map(|i| (l[i] / self.s[i]).min(self.w_max[i])));
            envelope.clear();
            for (j, &pj) in p.iter().enumerate() {
                envelope.add_diagonal(j, pj);
            }
            for (row, &w) in rows.iter().zip(&self.w) {
                envelope.add_outer(w, &row.idx[..row.len], &row.coef[..row.len]);
            }
            *factorisations += 1;
            if !envelope.factor() {
                return Err(format!(
                    "interior point: Newton matrix not positive definite at iteration {iteration}"
                ));
            }
            // Predictor (affine scaling): r_c = s l.
            self.rc.clear();
            self.rc
                .extend(self.s.iter().zip(l.iter()).map(|(s, x)| s * x));
            self.direction(envelope, rows, l);
            let (primal, dual) = self.steps_to_boundary(l, 1.0);
            let alpha = primal.min(dual);
            let mu_affine = self
                .s
                .iter()
                .zip(l.iter())
                .enumerate()
                .map(|(i, (s, x))| (s + alpha * self.ds[i]) * (x + alpha * self.dl[i]))
                .sum::<f64>()
                / m as f64;
            let sigma = (mu_affine / mu).clamp(0.0, 1.0).powi(3);
            std::mem::swap(&mut self.du, &mut self.du_aff);
            std::mem::swap(&mut self.dl, &mut self.dl_aff);
            std::mem::swap(&mut self.ds, &mut self.ds_aff);
            // Corrector: r_c = s l + ds_aff dl_aff - sigma mu.
            for (i, (rc, li)) in self.rc.iter_mut().zip(l.iter()).enumerate() {
                *rc = self.s[i] * li + self.ds_aff[i] * self.dl_aff[i] - sigma * mu;
            }
            self.direction(envelope, rows, l);
            // The primal (u, s) and dual (l) variables step apart, each to `TO_BOUNDARY` of its
            // own boundary (the predictor's length, which sets `sigma`, is the shorter of the
            // two). Against one common length (`wall_steps`, all factorisations): the sliding
            // walls of 215 / 430 / 860 blocks (ten pulse steps at step ends) 554 / 758 / 1430 ->
            // 474 / 726 / 1229, the located 215-block wall (ten steps) 11146 -> 10383, the
            // 215-block wall under El Centro x2 (5 s) where both rest or both slide at the same
            // scale of the record 4507 -> 4259 (x1.998) and 98846 -> 93499 (x1.999).
            let (primal, dual) = self.steps_to_boundary(l, TO_BOUNDARY);
            if !(primal.is_finite() && dual.is_finite()) || self.du.iter().any(|d| !d.is_finite()) {
                return Err(format!(
                    "interior point: non-finite step at iteration {iteration}"
                ));
            }
            for (uj, d) in u.iter_mut().zip(&self.du) {
                *uj += primal * d;
            }
            for (i, li) in l.iter_mut().enumerate() {
                self.s[i] = (self.s[i] + primal * self.ds[i]).max(f64::MIN_POSITIVE);
                *li = (*li + dual * self.dl[i]).max(f64::MIN_POSITIVE);
            }
        }
        Ok(Ended::OutOfIterations(max_iterations))
    }

    /// Mehrotra's start: the minimiser of `1/2 u'Pu + q'u + 1/2 |D u + r|^2`, whose multiplier
    /// estimate is `-(D u + r)`, both shifted into the interior.
    fn least_squares_start(
        &mut self,
        envelope: &mut Envelope,
        (p, q): (&[f64], &[f64]),
        (rows, r): (&[EdgeRow], &[f64]),
        (u, l): (&mut Vec<f64>, &mut Vec<f64>),
        factorisations: &mut u64,
    ) -> Result<(), String> {
        envelope.clear();
        for (j, &pj) in p.iter().enumerate() {
            envelope.add_diagonal(j, pj);
        }
        for row in rows {
            envelope.add_outer(1.0, &row.idx[..row.len], &row.coef[..row.len]);
        }
        *factorisations += 1;
        if !envelope.factor() {
            return Err("interior point: first Newton matrix not positive definite".into());
        }
        u.clear();
        u.extend(q.iter().map(|qj| -qj));
        for (row, &ri) in rows.iter().zip(r) {
            row.axpy(-ri, u);
        }
        envelope.solve(u);
        self.s.clear();
        l.clear();
        for (row, &ri) in rows.iter().zip(r) {
            let c = row.dot(u) + ri;
            self.s.push(c);
            l.push(-c);
        }
        let shift_s = (-1.5 * self.s.iter().cloned().fold(f64::INFINITY, f64::min)).max(0.0);
        let shift_l = (-1.5 * l.iter().cloned().fold(f64::INFINITY, f64::min)).max(0.0);
        self.s.iter_mut().for_each(|s| *s += shift_s);
        l.iter_mut().for_each(|x| *x += shift_l);
        let sl: f64 = self.s.iter().zip(l.iter()).map(|(s, x)| s * x).sum();
        let (sum_s, sum_l) = (self.s.iter().sum::<f64>(), l.iter().sum::<f64>());
        let (extra_s, extra_l) = if sl > 0.0 {
            (0.5 * sl / sum_l, 0.5 * sl / sum_s)
        } else {
            (1.0, 1.0)
        };
        self.s
            .iter_mut()
            .for_each(|s| *s = (*s + extra_s).max(f64::MIN_POSITIVE));
        l.iter_mut()
            .for_each(|x| *x = (*x + extra_l).max(f64::MIN_POSITIVE));
        Ok(())
    }

    /// The slacks `s = D u + r` of the last solve.
    pub fn slack(&self) -> &[f64] {
        &self.s
    }

    /// `du`, `dl`, `ds` for the residuals in hand and `r_c` (the factor is in `envelope`).
    fn direction(&mut self, envelope: &mut Envelope, rows: &[EdgeRow], l: &[f64]) {
        self.du.clear();
        self.du.extend(self.rd.iter().map(|x| -x));
        for (i, row) in rows.iter().enumerate() {
            row.axpy(
                -(self.w[i] * self.rp[i] + self.rc[i] / self.s[i]),
                &mut self.du,
            );
        }
        envelope.solve(&mut self.du);
        // `dl` first holds `D du`.
        dots_into(rows, &self.du, &mut self.dl);
        self.ds.clear();
        for (i, dl) in self.dl.iter_mut().enumerate() {
            *dl = -self.w[i] * (self.rp[i] + *dl) - self.rc[i] / self.s[i];
            self.ds.push(-(self.rc[i] + self.s[i] * *dl) / l[i]);
        }
    }

    /// The largest steps `<= 1` keeping `s` (primal) and `l` (dual) positive, times `fraction`.
    fn steps_to_boundary(&self, l: &[f64], fraction: f64) -> (f64, f64) {
        let (mut primal, mut dual) = (1.0f64, 1.0f64);
        for (i, li) in l.iter().enumerate() {
            if self.ds[i] < 0.0 {
                primal = primal.min(-fraction * self.s[i] / self.ds[i]);
            }
            if self.dl[i] < 0.0 {
                dual = dual.min(-fraction * li / self.dl[i]);
            }
        }
        (primal, dual)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_random::signed as sequence;

    /// Rows of a chain of `n_blocks` blocks: four random rows on each neighbouring pair and
    /// four on the first block alone (the ground), with offsets `r >= 0` (so `u = 0` is
    /// feasible).
    fn chain(n_blocks: usize, rnd: &mut impl FnMut() -> f64) -> (Vec<EdgeRow>, Vec<f64>) {
        let (mut rows, mut r) = (Vec::new(), Vec::new());
        for b in 0..n_blocks {
            for _ in 0..4 {
                let mut row = EdgeRow::default();
                let dofs: Vec<usize> = if b == 0 {
                    (0..3).collect()
                } else {
                    (3 * (b - 1)..3 * (b + 1)).collect()
                };
                for (j, &d) in dofs.iter().enumerate() {
                    row.idx[j] = d;
                    row.coef[j] = rnd();
                }
                row.len = dofs.len();
                rows.push(row);
                r.push(0.25 * (rnd() + 1.0));
            }
        }
        (rows, r)
    }

    /// A chain's problem: its envelope, its rows and offsets ([`chain`]), and a random `P`
    /// (diagonal, 0.5 to 2) and `q`.
    #[allow(clippy::type_complexity)]
    fn chain_problem(
        n_blocks: usize,
        rnd: &mut impl FnMut() -> f64,
    ) -> (Envelope, (Vec<EdgeRow>, Vec<f64>), (Vec<f64>, Vec<f64>)) {
        let n = 3 * n_blocks;
        let pairs: Vec<(usize, usize)> = (1..n_blocks).map(|b| (b - 1, b)).collect();
        let envelope = Envelope::new(n_blocks, &pairs);
        let rows = chain(n_blocks, rnd);
        let p: Vec<f64> = (0..n).map(|_| 1.25 + 0.75 * rnd()).collect();
        let q: Vec<f64> = (0..n).map(|_| 3.0 * rnd()).collect();
        (envelope, rows, (p, q))
    }

    /// The KKT conditions of the QP at `(u, l)` to `tolerance`; returns the rows that bind.
    fn assert_kkt(
        n_blocks: usize,
        (p, q): (&[f64], &[f64]),
        (rows, r): (&[EdgeRow], &[f64]),
        (u, l): (&[f64], &[f64]),
        tolerance: f64,
    ) -> usize {
        let n = p.len();
        let mut stationarity: Vec<f64> = (0..n).map(|j| p[j] * u[j] + q[j]).collect();
        for (row, &li) in rows.iter().zip(l) {
            row.axpy(-li, &mut stationarity);
        }
        let worst = stationarity.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        assert!(
            worst < 4.0 * tolerance,
            "{n_blocks} blocks: stationarity {worst:.2e}"
        );
        let mut closed = 0;
        for (i, row) in rows.iter().enumerate() {
            let c = row.dot(u) + r[i];
            assert!(c > -tolerance, "{n_blocks} blocks, row {i}: {c:.2e}");
            assert!(l[i] > 0.0);
            assert!(
                c * l[i] < tolerance,
                "{n_blocks} blocks, row {i}: c l {:.2e}",
                c * l[i]
            );
            closed += usize::from(c < 1e-6);
        }
        closed
    }

    /// On random chains the solution meets the KKT conditions of the QP (which, the problem
    /// being convex, make it the minimiser): stationarity, rows, signs and complementarity.
    #[test]
    fn interior_point_meets_the_kkt_conditions() {
        let mut rnd = sequence(11);
        for n_blocks in [1usize, 3, 12, 40] {
            let (mut envelope, (rows, r), (p, q)) = chain_problem(n_blocks, &mut rnd);
            let (mut u, mut l) = (Vec::new(), Vec::new());
            let mut factorisations = 0;
            let tolerance = 1e-8;
            let iterations = InteriorPoint::default()
                .solve(
                    &mut envelope,
                    (&p, &q),
                    (&rows, &r),
                    tolerance,
                    (&mut u, &mut l),
                    &mut factorisations,
                    false,
                )
                .unwrap();
            assert_eq!(factorisations, iterations as u64 + 1);
            let closed = assert_kkt(n_blocks, (&p, &q), (&rows, &r), (&u, &l), tolerance);
            // The loads make some rows bind (else the test says little).
            assert!(closed > 0, "{n_blocks} blocks: no row binds");
        }
    }

    /// A solve resumed from where it stopped to a smaller tolerance meets the KKT conditions to
    /// that tolerance, in fewer factorisations than a solve to it from the least-squares start;
    /// a resume out of iterations says so and leaves its last iterate (finite, inside the bounds);
    /// a resume with no iterate in hand is refused.
    #[test]
    fn a_resumed_solve_goes_on_to_a_smaller_tolerance() {
        let mut rnd = sequence(7);
        let n_blocks = 40;
        let (mut envelope, (rows, r), (p, q)) = chain_problem(n_blocks, &mut rnd);
        let problem = ((&p[..], &q[..]), (&rows[..], &r[..]));
        let (mut u, mut l) = (Vec::new(), Vec::new());
        let mut resumed = InteriorPoint::default();
        assert!(
            resumed
                .resume(&mut envelope, problem, 1e-10, (&mut u, &mut l), &mut 0, 60)
                .is_err()
        );
        resumed
            .solve(
                &mut envelope,
                problem.0,
                problem.1,
                1e-6,
                (&mut u, &mut l),
                &mut 0,
                false,
            )
            .unwrap();
        let mut once = InteriorPoint::default();
        let (mut u_once, mut l_once) = (u.clone(), l.clone());
        once.s.clone_from(&resumed.s);
        let reached = once
            .resume(
                &mut envelope,
                problem,
                1e-10,
                (&mut u_once, &mut l_once),
                &mut 0,
                1,
            )
            .unwrap();
        assert!(!reached, "one iteration from 1e-6 to 1e-10");
        assert!(u_once.iter().chain(&l_once).all(|x| x.is_finite()));
        assert!(once.s.iter().chain(&l_once).all(|&x| x > 0.0) && u_once != u);
        let mut further = 0;
        let reached = resumed
            .resume(
                &mut envelope,
                problem,
                1e-10,
                (&mut u, &mut l),
                &mut further,
                60,
            )
            .unwrap();
        assert!(reached);
        assert_kkt(n_blocks, problem.0, problem.1, (&u, &l), 1e-10);
        let (mut u_cold, mut l_cold) = (Vec::new(), Vec::new());
        let mut cold = 0;
        InteriorPoint::default()
            .solve(
                &mut envelope,
                problem.0,
                problem.1,
                1e-10,
                (&mut u_cold, &mut l_cold),
                &mut cold,
                false,
            )
            .unwrap();
        assert!(
            further > 0 && further < cold,
            "factorisations resumed {further}, cold {cold}"
        );
        let apart = u
            .iter()
            .zip(&u_cold)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(apart < 1e-8, "resumed and cold solutions {apart:.2e} apart");
    }

    /// A problem with the last solve's rows (here shuffled, their offsets moved by up to 1e-3 as
    /// a drift moves them) starts from that solve's iterate near the central path, meets the
    /// KKT conditions, and takes fewer iterations than from the least-squares start.
    #[test]
    fn a_neighbouring_problem_starts_from_the_last_iterate() {
        let mut rnd = sequence(5);
        let n_blocks = 40;
        let (mut envelope, (mut rows, mut r), (p, q)) = chain_problem(n_blocks, &mut rnd);
        for (k, row) in rows.iter_mut().enumerate() {
            row.key = k as u64;
        }
        let tolerance = 1e-8;
        let mut kept = InteriorPoint::default();
        let mut solve = |ip: &mut InteriorPoint, rows: &[EdgeRow], r: &[f64], from_path| {
            let (mut u, mut l) = (Vec::new(), Vec::new());
            let iterations = ip
                .solve(
                    &mut envelope,
                    (&p, &q),
                    (rows, r),
                    tolerance,
                    (&mut u, &mut l),
                    &mut 0,
                    from_path,
                )
                .unwrap();
            (iterations, u, l)
        };
        solve(&mut kept, &rows, &r, true);
        // Nothing kept yet: the first solve starts from the least-squares point.
        assert_eq!(kept.path_starts, 0);
        rows.reverse();
        r.reverse();
        for ri in r.iter_mut() {
            *ri += 1e-3 * rnd();
        }
        let (from_path, u, l) = solve(&mut kept, &rows, &r, true);
        assert_eq!((kept.path_starts, kept.path_failures), (1, 0));
        let closed = assert_kkt(n_blocks, (&p, &q), (&rows, &r), (&u, &l), tolerance);
        assert!(closed > 0, "no row binds");
        let (cold, ..) = solve(&mut InteriorPoint::default(), &rows, &r, false);
        assert!(
            from_path < cold,
            "{from_path} iterations from the path, {cold} cold"
        );
        // Rows that are not the kept iterate's: the least-squares start.
        rows[0].key = 1000;
        solve(&mut kept, &rows, &r, true);
        assert_eq!(kept.path_starts, 1);
    }

    /// An infeasible problem (`u >= 1` and `u <= 0` on one DOF) is a failure, not a solution.
    #[test]
    fn interior_point_fails_on_an_infeasible_problem() {
        let mut envelope = Envelope::new(1, &[]);
        let row = |c: f64| EdgeRow {
            idx: [0; 6],
            coef: [c, 0.0, 0.0, 0.0, 0.0, 0.0],
            len: 1,
            key: 0,
        };
        let (mut u, mut l) = (Vec::new(), Vec::new());
        let result = InteriorPoint::default().solve(
            &mut envelope,
            (&[1.0, 1.0, 1.0], &[0.0, 0.0, 0.0]),
            (&[row(1.0), row(-1.0)], &[-1.0, 0.0]),
            1e-8,
            (&mut u, &mut l),
            &mut 0,
            false,
        );
        assert!(result.is_err(), "{result:?} {u:?}");
    }
}
