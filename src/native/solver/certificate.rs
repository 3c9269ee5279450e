//! An a-posteriori bound on a step's distance from the minimiser of its QP.
//!
//! In the scaled primal problem ([`crate::native::problem::Scaled`], the rows of
//! `rows::edge_rows`) `min f(u) = 1/2 u' P u + q' u` s.t. `s(u) = D u + r >= 0`, any
//! multipliers `z >= 0` give the dual bound `f(u*) >= min_u f(u) - z' s(u)`, so that for a
//! feasible `u`, with the stationarity residual `g = P u + q - D' z`,
//!
//! ```text
//! 1/2 |u - u*|_P^2  <=  f(u) - f(u*)  <=  1/2 g' P^-1 g + z' s(u)      (the duality gap)
//! ```
//!
//! (the first inequality because `u*` minimises the strongly convex `f` over a convex set).
//! The certificate takes as closed the rows with `|s_r| <= CLOSED (1 + |r_r|)` and moves their
//! offsets by `-s_r` so that they hold exactly: `u` is then feasible, `z' s = 0`, and the bound
//! is that of the problem so moved (a backward error of at most `CLOSED` in the offsets, the
//! back-ends' own row tolerance). Its multipliers are the solution's forces
//! (`z± = (N ± T/mu)/2` scaled) refitted to the closed rows: the least-squares correction
//! `min |g - D_C' dz|_{P^-1}` by conjugate gradients, then clipped at zero. Each displacement is
//! then within `dt sqrt(2 gap / p_j)` of that problem's minimiser's. The bound uses no working
//! set and no other solver: it certifies a solution of any size from its displacements and
//! forces alone.

use super::rows::{EdgeRow, edge_rows};
use super::{Blob, ContactSolver, SolveFailure, from_bytes, to_bytes};
use crate::native::problem::{StepProblem, StepSolution};

/// Rows within this of zero, relative to `1 + |r_r|`, are taken as closed. The back-ends hold
/// their rows to 1e-11 and accept dependent rows at 1e-9; at 1e-9 here such rows, loaded, fell
/// outside, and the sliding 215-block wall's first ten problems were certified to 2.3e-12 -
/// 1.9e-8 m where 1e-8 gives 1.3e-15 - 7.7e-11 m.
const CLOSED: f64 = 1e-8;
/// Conjugate-gradient steps of the multipliers' refit, at most.
const FIT_STEPS: usize = 20000;
/// The refit's clipped gap is evaluated every `FIT_CHECK` steps, and it stops after
/// `FIT_PATIENCE` evaluations without a better one.
const FIT_CHECK: usize = 10;
const FIT_PATIENCE: usize = 20;
/// Rounds of the refit, each without the rows the last one clipped.
const FIT_ROUNDS: usize = 10;

/// A solution's certificate (scaled units of [`crate::native::problem::Scaled`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Certificate {
    /// `1/2 g' P^-1 g` with the solution's own forces (their equilibrium's error).
    pub forces_gap: f64,
    /// The duality gap with the refitted multipliers, `1/2 g' P^-1 g`.
    pub gap: f64,
    /// The largest move of a closed row's offset, relative to `1 + |r_r|` (the backward error).
    pub offsets_moved: f64,
    /// The largest violation of a row that is not closed, relative to `1 + |r_r|` (the bound
    /// does not hold if this is positive).
    pub violation: f64,
    /// The bound on any displacement's distance from the minimiser's, m:
    /// `dt max_j sqrt(2 gap / p_j)`.
    pub dq_bound: f64,
}

/// `1/2 g' P^-1 g`.
fn half_norm(g: &[f64], p: &[f64]) -> f64 {
    0.5 * g.iter().zip(p).map(|(g, p)| g * g / p).sum::<f64>()
}

/// `g = P u + q - D' z`.
fn residual(p: &[f64], q: &[f64], u: &[f64], rows: &[EdgeRow], z: &[f64]) -> Vec<f64> {
    let mut g: Vec<f64> = (0..p.len()).map(|j| p[j] * u[j] + q[j]).collect();
    for (row, &z) in rows.iter().zip(z) {
        row.axpy(-z, &mut g);
    }
    g
}

/// The certificate of `solution` for `problem` (the associative rows; a Coulomb step's QPs
/// have the same form).
pub fn certify(problem: &StepProblem, solution: &StepSolution) -> Certificate {
    let scaled = problem.scaled();
    let (p, q, dt) = (&scaled.p, &scaled.q, problem.dt);
    let (mut rows, mut r) = (Vec::new(), Vec::new());
    edge_rows(problem, &mut rows, &mut r);
    let zscale = scaled.s / dt;
    let u: Vec<f64> = solution.dq.iter().map(|dq| dq / dt).collect();
    let mut z = Vec::with_capacity(rows.len());
    for (k, c) in problem.contacts.iter().enumerate() {
        let (n, t) = (solution.normal[k] / zscale, solution.tangential[k] / zscale);
        let slip = if c.mu > 0.0 { t / c.mu } else { 0.0 };
        z.push(0.5 * (n + slip));
        z.push(0.5 * (n - slip));
    }
    let (mut closed, mut offsets_moved, mut violation) = (Vec::new(), 0.0f64, 0.0f64);
    for (i, row) in rows.iter().enumerate() {
        let s = (row.dot(&u) + r[i]) / (1.0 + r[i].abs());
        if s.abs() <= CLOSED {
            closed.push(i);
            offsets_moved = offsets_moved.max(s.abs());
        } else {
            violation = violation.max(-s);
            z[i] = 0.0;
        }
    }
    let forces_gap = half_norm(&residual(p, q, &u, &rows, &z), p);
    // Rounds of the refit; the rows whose multipliers it clipped to zero leave the next.
    for _ in 0..FIT_ROUNDS {
        refit(p, q, &u, &rows, &closed, &mut z);
        let before = closed.len();
        closed.retain(|&i| z[i] > 0.0);
        if closed.len() == before {
            break;
        }
    }
    let gap = half_norm(&residual(p, q, &u, &rows, &z), p);
    let dq_bound = dt * p.iter().map(|p| (2.0 * gap / p).sqrt()).fold(0.0, f64::max);
    Certificate {
        forces_gap,
        gap,
        offsets_moved,
        violation,
        dq_bound,
    }
}

/// `z_C += dz` reducing `|g - D_C' dz|_{P^-1}` with `z` kept non-negative: conjugate
/// gradients on the normal equations `D_C P^-1 D_C' dz = D_C P^-1 g` (Jacobi-preconditioned),
/// whose iterates are taken clipped (`z + dz >= 0`) and the best kept: the closed rows of a
/// flat interface are dependent, and on such singular equations round-off grows the iterates
/// along their null space once the residual is at its floor.
fn refit(p: &[f64], q: &[f64], u: &[f64], rows: &[EdgeRow], closed: &[usize], z: &mut [f64]) {
    let m = closed.len();
    let clipped_gap = |z: &[f64], x: &[f64]| {
        let mut trial = z.to_vec();
        for (a, &i) in closed.iter().enumerate() {
            trial[i] = (z[i] + x[a]).max(0.0);
        }
        (half_norm(&residual(p, q, u, rows, &trial), p), trial)
    };
    if m == 0 {
        return;
    }
    let (mut best, _) = clipped_gap(z, &vec![0.0; m]);
    let w: Vec<f64> = p.iter().map(|p| 1.0 / p).collect();
    let wg: Vec<f64> = residual(p, q, u, rows, z)
        .iter()
        .zip(&w)
        .map(|(g, w)| g * w)
        .collect();
    let diag: Vec<f64> = closed
        .iter()
        .map(|&i| rows[i].weighted_dot(&rows[i], &w).max(f64::MIN_POSITIVE))
        .collect();
    let mut res: Vec<f64> = closed.iter().map(|&i| rows[i].dot(&wg)).collect();
    let mut pre: Vec<f64> = res.iter().zip(&diag).map(|(r, d)| r / d).collect();
    let mut dir = pre.clone();
    let mut rz: f64 = res.iter().zip(&pre).map(|(a, b)| a * b).sum();
    let mut x = vec![0.0; m];
    let mut best_x = x.clone();
    let mut v = vec![0.0; p.len()];
    let mut worse = 0;
    for step in 1..=FIT_STEPS {
        if rz.is_nan() || rz <= 0.0 {
            break;
        }
        // `v = D_C' dir`; `N dir = D_C P^-1 v`.
        v.iter_mut().for_each(|v| *v = 0.0);
        for (a, &i) in closed.iter().enumerate() {
            rows[i].axpy(dir[a], &mut v);
        }
        let wv: Vec<f64> = v.iter().zip(&w).map(|(v, w)| v * w).collect();
        let nd: Vec<f64> = closed.iter().map(|&i| rows[i].dot(&wv)).collect();
        let dnd: f64 = dir.iter().zip(&nd).map(|(a, b)| a * b).sum();
        if dnd.is_nan() || dnd <= 0.0 {
            break;
        }
        let alpha = rz / dnd;
        for a in 0..m {
            x[a] += alpha * dir[a];
            res[a] -= alpha * nd[a];
            pre[a] = res[a] / diag[a];
        }
        let next: f64 = res.iter().zip(&pre).map(|(a, b)| a * b).sum();
        let beta = next / rz;
        rz = next;
        for a in 0..m {
            dir[a] = pre[a] + beta * dir[a];
        }
        if step % FIT_CHECK == 0 {
            let (gap, _) = clipped_gap(z, &x);
            if gap < best {
                best = gap;
                best_x.clone_from(&x);
                worse = 0;
            } else {
                worse += 1;
                if worse == FIT_PATIENCE {
                    break;
                }
            }
        }
    }
    // The last iterate too (the iteration may stop between two evaluations).
    let (gap, _) = clipped_gap(z, &x);
    if gap < best {
        best_x = x;
    }
    let (_, trial) = clipped_gap(z, &best_x);
    z.copy_from_slice(&trial);
}

/// A bound reported as loose by [`Certified::above`], m.
pub const REPORTED_BOUND: f64 = 1e-9;

/// The certificates of the solutions a [`Certifying`] back-end gave.
#[derive(Debug, Default, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Certified {
    /// Solutions certified.
    pub solutions: u64,
    /// The largest bound on a displacement's distance from its QP's minimiser, m.
    pub worst: f64,
    /// Solutions bounded only above [`REPORTED_BOUND`].
    pub above: u64,
    /// Solutions with a row violated outside the closed ones (their bound does not hold).
    pub violated: u64,
    /// The largest displacement of a step certified, m.
    pub largest_dq: f64,
}

impl Certified {
    fn add(&mut self, c: &Certificate, solution: &StepSolution) {
        self.solutions += 1;
        self.worst = self.worst.max(c.dq_bound);
        self.above += u64::from(c.dq_bound > REPORTED_BOUND);
        self.violated += u64::from(c.violation > 0.0);
        self.largest_dq = solution
            .dq
            .iter()
            .fold(self.largest_dq, |m, d| m.max(d.abs()));
    }
}

/// A back-end that certifies every solution of the one it wraps (`native.certify`); its
/// solutions are the wrapped back-end's, unchanged.
pub struct Certifying {
    inner: Box<dyn ContactSolver>,
    record: Certified,
}

impl Certifying {
    pub fn new(inner: Box<dyn ContactSolver>) -> Self {
        Certifying {
            inner,
            record: Certified::default(),
        }
    }
}

impl ContactSolver for Certifying {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn solve_into(
        &mut self,
        problem: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        self.inner.solve_into(problem, out)?;
        self.record.add(&certify(problem, out), out);
        Ok(())
    }
    fn fallbacks(&self) -> u64 {
        self.inner.fallbacks()
    }
    fn factorisations(&self) -> u64 {
        self.inner.factorisations()
    }
    fn rescues(&self) -> u64 {
        self.inner.rescues()
    }
    fn factor_updates(&self) -> u64 {
        self.inner.factor_updates()
    }
    fn certified(&self) -> Option<Certified> {
        Some(self.record)
    }
    fn save(&self) -> Vec<u8> {
        to_bytes(&(Blob(self.inner.save()), self.record))
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let (inner, record): (Blob, Certified) = from_bytes(state, "the certified back-end")?;
        self.inner.restore(&inner.0)?;
        self.record = record;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::native::problem::ContactRows;

    /// A unit block (m = 1, I = 1/6) on the ground on its two bottom corners, pushed sideways
    /// at its centre by `push`, friction 0.5.
    fn block_on_the_ground(push: f64) -> StepProblem {
        let corner = |key: u64, x: f64| ContactRows {
            key,
            mu: 0.5,
            g_n: 0.0,
            g_t: 0.0,
            // The corner (x, -0.5) from the centre: n = (0, 1), t = (1, 0).
            nrow: [(0, 0.0), (1, 1.0), (2, x)].into(),
            trow: [(0, 1.0), (1, 0.0), (2, 0.5)].into(),
        };
        StepProblem {
            theta: 0.5,
            dt: 1e-3,
            mass: vec![1.0, 1.0, 1.0 / 6.0],
            force: vec![push, -9.81, 0.0],
            v0: vec![0.0; 3],
            contacts: vec![corner(0, -0.5), corner(1, 0.5)],
        }
    }

    /// The minimiser of the sliding block's step (push above `mu m g`, below the rocking
    /// threshold `m g`): both corners on their cone's trailing edge (rows 1 and 3), solved
    /// from the equality problem `P u + q = D_C' z`, `D_C u + r_C = 0`, a 5 x 5 system; and a
    /// move that keeps both rows closed (the null space of `D_C`: 3 DOFs, 2 rows).
    fn sliding(pr: &StepProblem) -> (StepSolution, [f64; 3]) {
        use nalgebra::{DMatrix, DVector, Vector3};
        let sc = pr.scaled();
        let (mut rows, mut r) = (Vec::new(), Vec::new());
        edge_rows(pr, &mut rows, &mut r);
        let dense = |i: usize| {
            let mut d = Vector3::<f64>::zeros();
            for (&j, &c) in rows[i].idx.iter().zip(&rows[i].coef).take(rows[i].len) {
                d[j] += c;
            }
            d
        };
        let (d1, d3) = (dense(1), dense(3));
        let mut a = DMatrix::<f64>::zeros(5, 5);
        let mut b = DVector::<f64>::zeros(5);
        for j in 0..3 {
            a[(j, j)] = sc.p[j];
            b[j] = -sc.q[j];
            for (k, d) in [d1, d3].iter().enumerate() {
                a[(j, 3 + k)] = -d[j];
                a[(3 + k, j)] = d[j];
            }
        }
        b[3] = -r[1];
        b[4] = -r[3];
        let x = a.lu().solve(&b).expect("a regular equality problem");
        let zscale = sc.s / pr.dt;
        let (z1, z3) = (x[3], x[4]);
        assert!(z1 > 0.0 && z3 > 0.0, "the trailing edges carry the block");
        let solution = StepSolution {
            dq: (0..3).map(|j| x[j] * pr.dt).collect(),
            normal: vec![z1 * zscale, z3 * zscale],
            tangential: vec![-0.5 * z1 * zscale, -0.5 * z3 * zscale],
            iterations: 0,
            polished: false,
        };
        let null = d1.cross(&d3).normalize();
        (solution, [null[0], null[1], null[2]])
    }

    /// The minimiser's bound is at round-off; its displacements with forces off equilibrium are
    /// certified as well (the forces are refitted); moved by `e` along its closed rows, the
    /// bound covers `e` within the mass ratio.
    #[test]
    fn the_minimiser_is_certified_and_a_moved_solution_is_bounded() {
        let pr = block_on_the_ground(0.6 * 9.81);
        let (exact, null) = sliding(&pr);
        assert!(
            exact.dq[0] > 0.0 && exact.dq[1] > 0.0,
            "it slides and lifts"
        );
        let c = certify(&pr, &exact);
        assert!(c.dq_bound < 1e-13, "{c:?}");
        assert!(c.violation <= 0.0 && c.offsets_moved < 1e-14, "{c:?}");
        let mut off = exact.clone();
        off.normal[0] *= 1.1;
        let c = certify(&pr, &off);
        assert!(c.forces_gap > 1e6 * c.gap, "{c:?}");
        assert!(c.dq_bound < 1e-13, "{c:?}");
        for e in [1e-10, 1e-7] {
            let mut moved = exact.clone();
            for (dq, n) in moved.dq.iter_mut().zip(null) {
                *dq += e * n;
            }
            let c = certify(&pr, &moved);
            assert!(c.offsets_moved < 1e-14, "{c:?}");
            let largest = null.iter().map(|n| (e * n).abs()).fold(0.0, f64::max);
            assert!(c.dq_bound >= largest, "moved by {largest:e}: {c:?}");
            assert!(c.dq_bound < 10.0 * largest, "moved by {largest:e}: {c:?}");
        }
    }
}
