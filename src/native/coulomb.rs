//! Non-associative (Coulomb) friction (`native.friction_law = "coulomb"`) for one step
//! problem, on top of a back-end of the associative law.
//!
//! De Saxce's modified gap: the associative rows `g_n + s_k + (nrow ± mu trow) dq >= 0` with
//! `s_k = mu_k |g_t + trow dq|` (the dilatancy of the associative law, given back). At the
//! fixed point the row of the sliding edge reads `g_n + nrow dq >= 0` (no lift), its force lies
//! on the cone edge that opposes the slip, and a sticking point (`s = 0`) keeps both rows:
//! exactly Coulomb's law. See docs/method.md.

use super::problem::{SparseRow, StepProblem, StepSolution};
use super::solver::lemke::lemke;
use super::solver::{ContactSolver, SolveFailure};

/// Largest number of solves per problem for non-associative friction (see [`Coulomb::solve`]).
pub const COULOMB_ITERATIONS: usize = 40;
/// Non-associative friction: the slip offsets have settled when no one changes by more than
/// this (m, relative to `COULOMB_SCALE` for large slips).
pub const COULOMB_TOLERANCE: f64 = 1e-13;
pub const COULOMB_SCALE: f64 = 1e-4;
/// Plain fixed-point iterations before secant steps may be taken (see [`Coulomb::solve`]).
pub const COULOMB_PLAIN: usize = 3;
/// When the offsets have not settled to `COULOMB_TOLERANCE` in `COULOMB_ITERATIONS` solves and
/// Lemke's method gives no answer (the LCP beyond its dense limit, or no answer passing the
/// check), the iterate that changed least is accepted if its change is within
/// `COULOMB_ROUNDOFF (1 + s / COULOMB_SCALE)` m: the tolerance to which the sparse and dense
/// back-ends hold every row (`ROW_TOLERANCE`, 1e-11 (1 + |r|)), so a loaded point lifts or
/// sinks by no more than any row may. On large walls the back-end's solutions carry round-off
/// of a few 1e-13 m, below which the offsets cannot settle (docs/walls.md, "A wall that
/// slides whole").
pub const COULOMB_ROUNDOFF: f64 = 1e-11;

/// Why the fixed point did not settle, and its least-changed iterate's offsets and solution
/// if that settled to round-off.
type Unsettled = (String, Option<Box<(Vec<f64>, StepSolution)>>);

fn row_dot(row: &SparseRow, x: &[f64]) -> f64 {
    row.iter().map(|&(i, c)| c * x[i]).sum()
}

/// How the Coulomb problem of a step is solved.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum CoulombMethod {
    /// The fixed point on the slip offsets with the back-end in use, Lemke's method when it
    /// does not settle (the default).
    #[default]
    FixedPointThenLemke,
    /// Lemke's method on every problem (for measurements and cross-checks).
    Lemke,
}

/// The Coulomb solve's state between problems (warm start) and its counters.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Coulomb {
    pub method: CoulombMethod,
    /// Problems solved by Lemke's method (its answer taken), and its pivots in all.
    pub lemke_solves: u64,
    pub lemke_pivots: u64,
    /// Slip offsets `s_k` of the last solution, sorted by contact key (the warm start of the
    /// next problem).
    slide: Vec<(u64, f64)>,
    /// Back-end solves in all, and problems solved.
    pub iterations: u64,
    pub problems: u64,
    /// Problems whose offsets settled only to `COULOMB_ROUNDOFF`.
    #[serde(default)]
    pub roundoff_settles: u64,
}

impl Coulomb {
    /// Solve a step problem under Coulomb's law: the fixed point on the slip offsets with the
    /// given back-end (the fast path), then, if it does not settle in `COULOMB_ITERATIONS`
    /// solves or a back-end fails, Lemke's method on the problem's LCP (which terminates).
    /// Lemke's answer is checked against the law. When it gives none, the fixed point's
    /// least-changed iterate if it settled to round-off (`COULOMB_ROUNDOFF`); else an error.
    pub fn solve(
        &mut self,
        solver: &mut dyn ContactSolver,
        pr: &StepProblem,
    ) -> Result<StepSolution, SolveFailure> {
        if pr.contacts.is_empty() {
            return solver.solve(pr);
        }
        self.problems += 1;
        let (fast, roundoff) = match self.method {
            CoulombMethod::FixedPointThenLemke => match self.fixed_point(solver, pr) {
                Ok(sol) => return Ok(sol),
                Err(unsettled) => unsettled,
            },
            CoulombMethod::Lemke => (String::new(), None),
        };
        self.slide.clear();
        match lemke_step(pr) {
            Ok((sol, pivots)) => {
                self.lemke_solves += 1;
                self.lemke_pivots += pivots as u64;
                self.remember(pr, &sol);
                Ok(sol)
            }
            Err(_) if let Some(settled) = roundoff => {
                let (offsets, sol) = *settled;
                self.roundoff_settles += 1;
                Ok(self.settled(pr, &offsets, sol))
            }
            Err(why) => Err(SolveFailure {
                solver: "coulomb (fixed point, then Lemke)",
                status: if fast.is_empty() {
                    format!("Coulomb friction: {why}")
                } else {
                    format!("Coulomb friction: {fast}; then {why}")
                },
            }),
        }
    }

    /// The next problem's starting offsets from a solution (by contact key).
    fn remember(&mut self, pr: &StepProblem, sol: &StepSolution) {
        self.slide.clear();
        self.slide.extend(pr.contacts.iter().map(|c| {
            let s = c.mu * (c.g_t + row_dot(&c.trow, &sol.dq)).abs();
            (c.key, if s <= COULOMB_TOLERANCE { 0.0 } else { s })
        }));
        self.slide.sort_unstable_by_key(|e| e.0);
    }

    /// The fixed point `s <- mu |d_t(s)|`, each iterate one solve of the back-end; on failure
    /// the reason, and the least-changed iterate's offsets and solution if it settled to
    /// round-off (`COULOMB_ROUNDOFF`).
    fn fixed_point(
        &mut self,
        solver: &mut dyn ContactSolver,
        pr: &StepProblem,
    ) -> Result<StepSolution, Unsettled> {
        let mut shifted = pr.clone();
        let mut s: Vec<f64> = pr
            .contacts
            .iter()
            .map(|c| {
                self.slide
                    .binary_search_by_key(&c.key, |e| e.0)
                    .map_or(0.0, |i| self.slide[i].1)
            })
            .collect();
        let mut iterations = 0;
        let mut last_change = f64::INFINITY;
        // The map's value at the current offsets, and the previous input and value (for the
        // secant step below).
        let mut g = vec![0.0; s.len()];
        let mut previous: Option<(Vec<f64>, Vec<f64>)> = None;
        // Of the iterates that settled to round-off (`COULOMB_ROUNDOFF`), the one that changed
        // least: its change, offsets and solution (kept only for those: no copy otherwise).
        let mut least: Option<(f64, Vec<f64>, StepSolution)> = None;
        for k in 0..COULOMB_ITERATIONS {
            for (r, (c, sk)) in shifted.contacts.iter_mut().zip(pr.contacts.iter().zip(&s)) {
                r.g_n = c.g_n + sk;
            }
            let mut sol = solver.solve(&shifted).map_err(|e| {
                (
                    format!("the back-end failed on a shifted problem ({e})"),
                    None,
                )
            })?;
            iterations += sol.iterations;
            let mut change = 0.0f64;
            let mut size = 0.0f64;
            for (((c, sk), gk), n) in pr
                .contacts
                .iter()
                .zip(&s)
                .zip(g.iter_mut())
                .zip(&sol.normal)
            {
                // Slips at round-off level count as none: a shift of the gaps by ~1e-17 m
                // makes the force-free rows of a wall at rest flip in the dense back-end.
                let new = c.mu * (c.g_t + row_dot(&c.trow, &sol.dq)).abs();
                let new = if new <= COULOMB_TOLERANCE { 0.0 } else { new };
                // A loaded point needs its exact offset (else it lifts or sinks by the
                // difference); an unloaded one only must not penetrate, whatever its offset.
                let error = if *n > 0.0 {
                    (new - sk).abs()
                } else {
                    (-(c.g_n + row_dot(&c.nrow, &sol.dq))).max(0.0)
                };
                change = change.max(error);
                size = size.max(new);
                *gk = new;
            }
            self.iterations += 1;
            let scale = 1.0 + size / COULOMB_SCALE;
            if change <= COULOMB_TOLERANCE * scale {
                sol.iterations = iterations;
                return Ok(self.settled(pr, &s, sol));
            }
            if change <= COULOMB_ROUNDOFF * scale && least.as_ref().is_none_or(|l| change < l.0) {
                least = Some((change, s.clone(), sol.clone()));
            }
            // Next offsets: the plain iterate `g`, or, when it converges slowly or cycles
            // (change not below a tenth of the previous one, after the first few), a secant
            // (Anderson, depth one) step from the last two iterates, kept non-negative.
            let mut next = g.clone();
            if let Some((xp, gp)) = &previous
                && k >= COULOMB_PLAIN
                && change > 0.1 * last_change
            {
                let (mut num, mut den) = (0.0, 0.0);
                for i in 0..s.len() {
                    let dr = (g[i] - s[i]) - (gp[i] - xp[i]);
                    num += (g[i] - s[i]) * dr;
                    den += dr * dr;
                }
                let gamma = num / den;
                if gamma.is_finite() {
                    for i in 0..s.len() {
                        next[i] = (g[i] - gamma * (g[i] - gp[i])).max(0.0);
                    }
                }
            }
            previous = Some((std::mem::replace(&mut s, next), g.clone()));
            last_change = change;
        }
        let roundoff = least.map(|(_, s, mut sol)| {
            sol.iterations = iterations;
            Box::new((s, sol))
        });
        Err((
            format!(
                "the slip offsets did not settle in {COULOMB_ITERATIONS} solves of {} (last change {last_change:.3e} m)",
                solver.name()
            ),
            roundoff,
        ))
    }

    /// A settled fixed point: its offsets kept for the next problem, its solution returned.
    fn settled(&mut self, pr: &StepProblem, s: &[f64], sol: StepSolution) -> StepSolution {
        self.slide.clear();
        self.slide
            .extend(pr.contacts.iter().map(|c| c.key).zip(s.iter().copied()));
        self.slide.sort_unstable_by_key(|e| e.0);
        sol
    }
}

/// Largest LCP (unknowns: one per frictionless point, four per point with friction) given to
/// Lemke's dense method: its basis inverse takes `8 n^2` bytes and `2 n^2` flops a pivot.
pub const LEMKE_MAX_UNKNOWNS: usize = 2000;

/// Pivot and tie tolerances of Lemke's method (see [`lemke`]), tried in turn until an answer
/// passes the check. Measured on steps of the two-block case and of random stacks, each solved
/// in exact rational arithmetic for reference: a tie of 1e-11 ended on a false secondary ray
/// near rest where 1e-10 to 1e-7 solve it; a tie of 1e-9 took a wrong row where 1e-12 to 1e-10
/// are right; a pivot tolerance of 1e-11 pivoted on a round-off entry where 1e-9 is right,
/// 1e-9 on one where only 1e-7 is, and 1e-7 on one (a random stack at theta 0.5) where only
/// 1e-5 is. No single pair solved all five.
pub const LEMKE_TRIES: [(f64, f64); 12] = [
    (1e-9, 1e-11),
    (1e-9, 1e-9),
    (1e-9, 1e-7),
    (1e-7, 1e-11),
    (1e-7, 1e-9),
    (1e-7, 1e-7),
    (1e-5, 1e-11),
    (1e-5, 1e-9),
    (1e-5, 1e-7),
    (1e-11, 1e-11),
    (1e-11, 1e-9),
    (1e-11, 1e-7),
];

/// Pivots allowed to one attempt of Lemke's method on an LCP of `n` unknowns:
/// `LEMKE_PIVOTS_PER_UNKNOWN n + LEMKE_PIVOTS_EXTRA`. Measured (Lemke's method alone on every
/// step of the validation scenes that are not walls, 148,187 problems of up to 160 unknowns,
/// and of the 22-block sliding wall and the wall corner, 607 problems of up to 432): every
/// answer came within 1.25 n pivots (41 at most), within 0.66 n above 100 unknowns. An
/// attempt that does not terminate within the budget has lost its way among ties (on the
/// toppling 42-block wall's step 101, 872 unknowns, ten of the twelve pairs ran to the
/// earlier budget of 50 n + 100, 33 s each, and the answer that came took 236 pivots).
pub const LEMKE_PIVOTS_PER_UNKNOWN: usize = 4;
pub const LEMKE_PIVOTS_EXTRA: usize = 100;

/// The pivot budget of one attempt of Lemke's method (see [`LEMKE_PIVOTS_PER_UNKNOWN`]).
pub fn lemke_pivot_budget(n: usize) -> usize {
    LEMKE_PIVOTS_PER_UNKNOWN * n + LEMKE_PIVOTS_EXTRA
}

/// Relative accuracy asked of Lemke's answer when checking it against the law.
pub const LEMKE_CHECK: f64 = 1e-9;

/// The step problem as an LCP over the contact forces, solved by Lemke's method.
///
/// With `Mbar^-1 = theta dt^2 M^-1`, the free displacement `dq_f = Mbar^-1 fbar0` and the
/// Delassus operator `W = H Mbar^-1 H'` (H: the rows `nrow_k`, `trow_k`), the relative
/// displacements are `d = b + W c`, `b = g + H dq_f`, `c = (N_k, T_k)`. Per point with
/// friction, `T = beta+ - beta-` and the slip magnitude `lambda`:
///
/// ```text
/// d_n              >= 0  ⊥  N      >= 0
/// lambda + d_t     >= 0  ⊥  beta+  >= 0
/// lambda - d_t     >= 0  ⊥  beta-  >= 0
/// mu N - beta+ - beta- >= 0  ⊥  lambda >= 0
/// ```
///
/// which is Coulomb's law: a sliding point (`d_t != 0`) has `lambda = |d_t| > 0`, hence
/// `beta+ + beta- = mu N` with the force on the edge that opposes the slip; a sticking point
/// any force in the cone. Forces are scaled by the largest diagonal entry of `W` so that every
/// entry of the LCP is in metres. Returns the step and the pivots taken.
pub fn lemke_step(pr: &StepProblem) -> Result<(StepSolution, usize), String> {
    let m = pr.contacts.len();
    // The size first: the Delassus operator below is dense, `(2m)^2` entries.
    // Unknowns: N_k at k; for the f-th point with friction, beta+, beta-, lambda at
    // m + 3f, m + 3f + 1, m + 3f + 2.
    let friction: Vec<usize> = (0..m).filter(|&k| pr.contacts[k].mu > 0.0).collect();
    let n = m + 3 * friction.len();
    if n > LEMKE_MAX_UNKNOWNS {
        return Err(format!(
            "the LCP has {n} unknowns ({m} points), more than Lemke's dense method takes ({LEMKE_MAX_UNKNOWNS})"
        ));
    }
    let nd = pr.n_dof();
    let minv: Vec<f64> = pr
        .mass
        .iter()
        .map(|mass| pr.theta * pr.dt * pr.dt / mass)
        .collect();
    let dq_free: Vec<f64> = (0..nd)
        .map(|i| pr.theta * pr.dt * pr.dt * pr.force[i] / pr.mass[i] + pr.dt * pr.v0[i])
        .collect();
    // Rows 2k (normal) and 2k + 1 (tangential), and each DOF's rows.
    let rows: Vec<&SparseRow> = pr
        .contacts
        .iter()
        .flat_map(|c| [&c.nrow, &c.trow])
        .collect();
    let mut by_dof: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nd];
    for (a, r) in rows.iter().enumerate() {
        for &(i, c) in r.iter() {
            by_dof[i].push((a, c));
        }
    }
    let nr = 2 * m;
    let mut w = vec![0.0; nr * nr];
    for (i, list) in by_dof.iter().enumerate() {
        for &(a, ca) in list {
            for &(b, cb) in list {
                w[a * nr + b] += ca * cb * minv[i];
            }
        }
    }
    let kappa = (0..nr).map(|a| w[a * nr + a]).fold(0.0f64, f64::max);
    if !(kappa > 0.0 && kappa.is_finite()) {
        return Err("Lemke's method: the contact rows have no stiffness".into());
    }
    w.iter_mut().for_each(|x| *x /= kappa);
    let b: Vec<f64> = pr
        .contacts
        .iter()
        .flat_map(|c| {
            [
                c.g_n + row_dot(&c.nrow, &dq_free),
                c.g_t + row_dot(&c.trow, &dq_free),
            ]
        })
        .collect();
    // The columns of the LCP matrix that carry W: (LCP column, W row/column, sign).
    let mut force_cols: Vec<(usize, usize, f64)> = (0..m).map(|k| (k, 2 * k, 1.0)).collect();
    for (f, &k) in friction.iter().enumerate() {
        force_cols.push((m + 3 * f, 2 * k + 1, 1.0));
        force_cols.push((m + 3 * f + 1, 2 * k + 1, -1.0));
    }
    let mut mat = vec![0.0; n * n];
    let mut q = vec![0.0; n];
    // Rows that carry W: (LCP row, W row, sign).
    let mut force_rows: Vec<(usize, usize, f64)> = (0..m).map(|k| (k, 2 * k, 1.0)).collect();
    for (f, &k) in friction.iter().enumerate() {
        force_rows.push((m + 3 * f, 2 * k + 1, 1.0));
        force_rows.push((m + 3 * f + 1, 2 * k + 1, -1.0));
    }
    for &(i, a, si) in &force_rows {
        q[i] = si * b[a];
        for &(j, bb, sj) in &force_cols {
            mat[i * n + j] = si * sj * w[a * nr + bb];
        }
    }
    for (f, &k) in friction.iter().enumerate() {
        let (bp, bm, la) = (m + 3 * f, m + 3 * f + 1, m + 3 * f + 2);
        mat[bp * n + la] = 1.0;
        mat[bm * n + la] = 1.0;
        mat[la * n + k] = pr.contacts[k].mu;
        mat[la * n + bp] = -1.0;
        mat[la * n + bm] = -1.0;
    }
    let mut why = String::new();
    let mut pivots = 0;
    for (pivot, tie) in LEMKE_TRIES {
        match lemke(&mat, &q, lemke_pivot_budget(n), pivot, tie) {
            Err(e) => why = format!("{e} (last of {} tolerance pairs)", LEMKE_TRIES.len()),
            Ok(sol) => {
                pivots += sol.pivots;
                let out = lcp_step(pr, &sol.z, m, &friction, kappa, &minv, &dq_free, pivots);
                match check_law(pr, &out, &b, kappa) {
                    Ok(()) => return Ok((out, pivots)),
                    Err(e) => why = format!("{e} (last of {} tolerance pairs)", LEMKE_TRIES.len()),
                }
            }
        }
    }
    Err(why)
}

/// The step from the LCP's solution `z` (see [`lemke_step`]).
#[allow(clippy::too_many_arguments)]
fn lcp_step(
    pr: &StepProblem,
    z: &[f64],
    m: usize,
    friction: &[usize],
    kappa: f64,
    minv: &[f64],
    dq_free: &[f64],
    pivots: usize,
) -> StepSolution {
    let mut normal: Vec<f64> = z[..m].to_vec();
    let mut tangential = vec![0.0; m];
    for (f, &k) in friction.iter().enumerate() {
        tangential[k] = z[m + 3 * f] - z[m + 3 * f + 1];
    }
    // Back to forces, and the step.
    normal.iter_mut().for_each(|x| *x /= kappa);
    tangential.iter_mut().for_each(|x| *x /= kappa);
    let mut dq = dq_free.to_vec();
    for (k, c) in pr.contacts.iter().enumerate() {
        for &(i, v) in &c.nrow {
            dq[i] += minv[i] * v * normal[k];
        }
        for &(i, v) in &c.trow {
            dq[i] += minv[i] * v * tangential[k];
        }
    }
    StepSolution {
        dq,
        normal,
        tangential,
        iterations: pivots as u32,
        polished: false,
    }
}

/// Check a solution against Coulomb's law (no silent wrong answer): no penetration, no
/// tension, no force on an open point, the force within the cone and, where the point slides,
/// on the edge that opposes the slip; to `LEMKE_CHECK` of the problem's scales.
fn check_law(pr: &StepProblem, sol: &StepSolution, b: &[f64], kappa: f64) -> Result<(), String> {
    let len = LEMKE_CHECK * b.iter().fold(0.0f64, |s, x| s.max(x.abs())) + 1e-15;
    // Forces: the largest, or the one that closes the largest offset.
    let force = LEMKE_CHECK
        * sol
            .normal
            .iter()
            .zip(&sol.tangential)
            .fold(len / kappa, |s, (n, t)| s.max(n.abs()).max(t.abs()));
    for (k, c) in pr.contacts.iter().enumerate() {
        let (nk, tk) = (sol.normal[k], sol.tangential[k]);
        let dn = c.g_n + row_dot(&c.nrow, &sol.dq);
        let dt = c.g_t + row_dot(&c.trow, &sol.dq);
        let bad = if dn < -len {
            Some(format!("penetrates by {:.3e} m", -dn))
        } else if dn > len && nk > force {
            Some(format!("open by {dn:.3e} m with a force {nk:.3e}"))
        } else if tk.abs() > c.mu * nk + force {
            Some(format!(
                "friction {tk:.3e} outside the cone (mu N = {:.3e})",
                c.mu * nk
            ))
        } else if dt.abs() > len && (tk + c.mu * nk * dt.signum()).abs() > force {
            Some(format!(
                "slides by {dt:.3e} m with friction {tk:.3e} (Coulomb's {:.3e})",
                -c.mu * nk * dt.signum()
            ))
        } else {
            None
        };
        if let Some(bad) = bad {
            return Err(format!(
                "Lemke's answer fails the law at point {k} (key {}): {bad}",
                c.key
            ));
        }
    }
    Ok(())
}
