//! Sleeping islands: blocks at rest leave the step problem until something can move them.
//!
//! An island (blocks joined by detected contact points) whose blocks have all been still
//! (speeds below `native.rest_velocity`) for `REST_WINDOW` is at rest. With the excitation
//! applied as inertial forces and only horizontal, it stays exactly at rest under a ground
//! acceleration `a` while admissible contact forces (no tension, within the friction cone) on
//! its closed points balance gravity and the inertial forces `-m a`: with `v0 = 0` and
//! `f + H'c = 0`, `dq = 0` satisfies the optimality conditions of every step problem (both
//! steppers, both QPs). The accelerations for which such forces exist form an interval
//! `[a_lo, a_hi]` (the equilibrium is linear in `a` and the forces), found by two linear
//! programs, the static theorem of limit analysis (exact for the associative law):
//!
//! ```text
//! a_hi = max a,  a_lo = min a   s.t.  sum_k z_k± (nrow_k ± mu_k trow_k) - a m_x = -f_g,  z >= 0
//! ```
//!
//! `m_x` is the mass on every horizontal DOF, `f_g` gravity. A sleeping island keeps its
//! positions with zero velocities; its blocks get no contact point and no force, so every step
//! leaves them where they are, at the cost of nothing but detection's broad phase. It wakes when
//! the step's ground acceleration leaves `[a_lo + WAKE_MARGIN g, a_hi - WAKE_MARGIN g]`, or
//! when a contact point joins it to an awake block (the island the point reaches wakes whole).
//! Waking early changes nothing: the awake step computes the same rest. Putting an island to
//! sleep sets speeds below `rest_velocity` to zero, which moves the answer by at most that
//! speed times the time the island sleeps, in a state the island holds anyway.

use super::problem::ContactRows;
use crate::geometry::ContactPoint;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
};

/// A sleeping island wakes this far (fraction of g) inside its interval of accelerations.
pub const WAKE_MARGIN: f64 = 1e-3;
/// The interval is bounded at this many g either side (an island wedged so that no horizontal
/// acceleration moves it).
pub const LARGEST_INTERVAL: f64 = 1e3;

/// One sleeping island.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Asleep {
    blocks: Vec<usize>,
    /// Ground accelerations (m/s^2) that keep it at rest, the margin taken off.
    a_lo: f64,
    a_hi: f64,
}

/// Which blocks sleep, and the stillness count of the others.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Sleep {
    /// Steps a block must stay still before its island may sleep.
    window: u32,
    rest_speed: f64,
    gravity: f64,
    /// Per block: consecutive still steps.
    still: Vec<u32>,
    /// Per block: its sleeping island (index into `islands`).
    island_of: Vec<Option<usize>>,
    islands: Vec<Option<Asleep>>,
    /// Islands put to sleep, woken (by the excitation, by a contact), block-steps asleep.
    pub fallen_asleep: u64,
    pub woken_by_excitation: u64,
    pub woken_by_contact: u64,
    pub block_steps_asleep: u64,
}

impl Sleep {
    pub fn new(n_blocks: usize, window: u32, rest_speed: f64, gravity: f64) -> Self {
        Sleep {
            window: window.max(1),
            rest_speed,
            gravity,
            still: vec![0; n_blocks],
            island_of: vec![None; n_blocks],
            islands: Vec::new(),
            fallen_asleep: 0,
            woken_by_excitation: 0,
            woken_by_contact: 0,
            block_steps_asleep: 0,
        }
    }

    pub fn asleep(&self, block: usize) -> bool {
        self.island_of[block].is_some()
    }

    pub fn all_asleep(&self) -> bool {
        self.island_of.iter().all(Option::is_some)
    }

    fn wake(&mut self, k: usize) {
        if let Some(island) = self.islands[k].take() {
            for b in island.blocks {
                self.island_of[b] = None;
                self.still[b] = 0;
            }
        }
    }

    /// Wake every island the ground acceleration `ax` of the coming step could move.
    pub fn wake_for_excitation(&mut self, ax: f64) {
        for k in 0..self.islands.len() {
            if let Some(i) = &self.islands[k]
                && !(i.a_lo..=i.a_hi).contains(&ax)
            {
                self.wake(k);
                self.woken_by_excitation += 1;
            }
        }
    }

    /// Wake the sleeping islands that a point joins to an awake block (or to the ground's
    /// points of an awake block); returns whether any woke.
    pub fn wake_touched(&mut self, points: &[ContactPoint]) -> bool {
        let mut woke = false;
        for c in points {
            let Some(a) = c.a else { continue };
            let (sa, sb) = (self.island_of[a], self.island_of[c.b]);
            if sa != sb {
                for k in [sa, sb].into_iter().flatten() {
                    self.wake(k);
                    self.woken_by_contact += 1;
                    woke = true;
                }
            }
        }
        woke
    }

    /// Count the still steps of the awake blocks from their velocities `v` (x, z, omega per
    /// block) and extents (larger dimension); returns whether some block has been still for
    /// the window (its island may sleep).
    pub fn observe(&mut self, v: &[f64], extent: &[f64]) -> bool {
        let mut ready = false;
        for (b, e) in extent.iter().enumerate() {
            if self.asleep(b) {
                self.block_steps_asleep += 1;
                continue;
            }
            let (vx, vz, om) = (v[3 * b], v[3 * b + 1], v[3 * b + 2]);
            let still = vx.abs() < self.rest_speed
                && vz.abs() < self.rest_speed
                && (om * e).abs() < self.rest_speed;
            self.still[b] = if still { self.still[b] + 1 } else { 0 };
            ready |= self.still[b] >= self.window;
        }
        ready
    }

    /// The islands of awake blocks through `points` whose blocks have all been still for the
    /// window.
    pub fn candidates(&self, points: &[ContactPoint]) -> Vec<Vec<usize>> {
        let n = self.still.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        for c in points {
            if let Some(a) = c.a {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, c.b));
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
        let mut by_root: Vec<Vec<usize>> = vec![Vec::new(); n];
        for b in 0..n {
            if !self.asleep(b) {
                let r = root(&mut parent, b);
                by_root[r].push(b);
            }
        }
        by_root
            .into_iter()
            .filter(|blocks| {
                !blocks.is_empty() && blocks.iter().all(|&b| self.still[b] >= self.window)
            })
            .collect()
    }

    /// Put `blocks` to sleep if the ground acceleration `ax` lies inside the interval
    /// `rest_interval` found for them (the margin taken off); otherwise restart their
    /// stillness count (a new attempt after another window). Returns whether they sleep.
    pub fn try_sleep(&mut self, blocks: Vec<usize>, interval: Option<(f64, f64)>, ax: f64) -> bool {
        let margin = WAKE_MARGIN * self.gravity;
        match interval {
            Some((lo, hi)) if lo + margin <= ax && ax <= hi - margin => {
                let k = self.islands.len();
                for &b in &blocks {
                    self.island_of[b] = Some(k);
                }
                self.islands.push(Some(Asleep {
                    blocks,
                    a_lo: lo + margin,
                    a_hi: hi - margin,
                }));
                self.fallen_asleep += 1;
                true
            }
            _ => {
                for b in blocks {
                    self.still[b] = 0;
                }
                false
            }
        }
    }

    /// Forget the islands that have all woken (indices of sleeping ones are kept).
    pub fn compact(&mut self) {
        if self.islands.iter().all(Option::is_none) {
            self.islands.clear();
        }
    }
}

/// The interval of horizontal ground accelerations (m/s^2) under which the blocks `blocks`
/// (global indices) stay at rest on the closed points `rows` (rows at the current
/// configuration, every one of them touching only these blocks and the ground), or `None` if
/// no admissible forces balance gravity alone or the programs fail. `mass`: the diagonal of M.
pub fn rest_interval(
    blocks: &[usize],
    rows: &[ContactRows],
    mass: &[f64],
    gravity: f64,
) -> Option<(f64, f64)> {
    // Local DOFs: 3 per block in the order of `blocks`.
    let mut local = std::collections::HashMap::new();
    for (i, &b) in blocks.iter().enumerate() {
        for k in 0..3 {
            local.insert(3 * b + k, 3 * i + k);
        }
    }
    let n_eq = 3 * blocks.len();
    let n_z = 2 * rows.len();
    let n = n_z + 1;
    // Columns: z+_k, z-_k for each point, then a. Scaled by the largest weight so that the
    // program is O(1).
    let scale = mass.iter().cloned().fold(0.0, f64::max) * gravity;
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (k, r) in rows.iter().enumerate() {
        for (sign, col) in [(1.0, 2 * k), (-1.0, 2 * k + 1)] {
            let mut entries: Vec<(usize, f64)> = Vec::new();
            for &(i, c) in &r.nrow {
                entries.push((*local.get(&i)?, c));
            }
            for &(i, c) in &r.trow {
                let l = *local.get(&i)?;
                match entries.iter_mut().find(|e| e.0 == l) {
                    Some(e) => e.1 += sign * r.mu * c,
                    None => entries.push((l, sign * r.mu * c)),
                }
            }
            cols[col] = entries;
        }
    }
    // a's column: -m on the horizontal DOFs, in units of g.
    cols[n_z] = blocks
        .iter()
        .enumerate()
        .map(|(i, &b)| (3 * i, -mass[3 * b] * gravity / scale))
        .collect();
    // Rows: n_eq equalities, then -z <= 0 and -a_max <= a <= a_max.
    let mut b_vec = vec![0.0; n_eq + n_z + 2];
    for (i, &b) in blocks.iter().enumerate() {
        b_vec[3 * i + 1] = mass[3 * b + 1] * gravity / scale;
    }
    b_vec[n_eq + n_z] = LARGEST_INTERVAL;
    b_vec[n_eq + n_z + 1] = LARGEST_INTERVAL;
    let (mut colptr, mut rowval, mut nzval) = (vec![0usize], Vec::new(), Vec::new());
    for (j, col) in cols.iter_mut().enumerate() {
        col.sort_by_key(|e| e.0);
        for &(i, c) in col.iter() {
            rowval.push(i);
            nzval.push(c);
        }
        if j < n_z {
            rowval.push(n_eq + j);
            nzval.push(-1.0);
        } else {
            rowval.push(n_eq + n_z);
            nzval.push(1.0);
            rowval.push(n_eq + n_z + 1);
            nzval.push(-1.0);
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(n_eq + n_z + 2, n, colptr, rowval, nzval);
    let p = CscMatrix::zeros((n, n));
    let cones = [ZeroConeT(n_eq), NonnegativeConeT(n_z + 2)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-10)
        .tol_gap_rel(1e-10)
        .tol_feas(1e-10)
        .build()
        .ok()?;
    let extreme = |direction: f64| -> Option<f64> {
        let mut q = vec![0.0; n];
        q[n_z] = -direction;
        let mut solver = DefaultSolver::new(&p, &q, &a, &b_vec, &cones, settings.clone()).ok()?;
        solver.solve();
        match solver.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                Some(solver.solution.x[n_z] * gravity)
            }
            _ => None,
        }
    };
    let (lo, hi) = (extreme(-1.0)?, extreme(1.0)?);
    (lo <= hi).then_some((lo, hi))
}
