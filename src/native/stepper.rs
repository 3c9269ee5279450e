//! One step of the theta-method.
//!
//! From `(q0, v0)` at `t0`: detect contacts and gaps from the current geometry, assemble
//! `Mbar dq + A c = fbar0`, solve the QP, then `v = (dq/dt - (1 - theta) v0)/theta`,
//! `q = q0 + dq`.
//!
//! Two contact laws in time (`native.stepper`):
//! - `paper` (the paper's scheme): every contact point gets
//!   `g0 + (nrow ± mu trow) dq >= 0`. The step that closes a contact returns a rebound
//!   `e ~ (1 - theta)/theta`.
//! - `impact` (impact-consistent, second order; the default): midpoint kinematics,
//!   `dq = h (v0 + v)/2`; the rows are discrete gradients of each point's gap functions between
//!   the ends of the step (`native::material`, re-evaluated until the loaded points do not
//!   drift), so a closed contact keeps its gap exactly and its force does no work; the end
//!   velocity is made admissible on the loaded points (`settle_velocity`); new impacts are
//!   located within the step and plastic (`step_locating`). See docs/method.md for the
//!   equations and figures.
//!
//! Ground motion is discretised once per step and shared by both routes, so that inertial
//! forces and a moving ground give the same relative motion to round-off:
//! - given as an acceleration: `a_eff = (V(t1) - V(t0))/dt` (exact mean acceleration),
//!   ground velocity `w1 = w0 + dt a_eff`, ground increment `Δd = dt w0 + theta dt^2 a_eff`;
//! - given as a displacement: `Δd = D(t1) - D(t0)` (exact), `w1 = (Δd/dt - (1-theta) w0)/theta`,
//!   `a_eff = (w1 - w0)/dt`.
//!
//! The impact stepper uses the first form with `1/2` for theta for both, so
//! the ground follows the blocks' update (a displacement-defined motion through its exact
//! velocity `V = D'`).
//!
//! Inertial route: coordinates relative to the ground, forces `-m a_eff`. Moving-ground route:
//! absolute coordinates, the ground moves by `Δd`; outputs subtract the ground's `d` and `w`.

use super::assembly::{
    Bodies, contact_key, contact_rows, contact_rows_into, ground_offsets, normal_row, pose, poses,
    poses_into,
};
use super::coulomb::{COULOMB_TOLERANCE, Coulomb};
use super::islands::{Components, holding_into};
use super::material::{Gradient, Increment, MaterialContact};
use super::problem::{ContactRows, SparseRow, StepProblem, StepSolution};
use super::settings::{FrictionLaw, NativeSettings, StepperKind};
use super::sleep::{Sleep, rest_interval};

/// Penetration beyond which the impact-consistent stepper projects positions back, m.
pub const PENETRATION_TOLERANCE: f64 = 1e-9;

/// Impact-consistent stepper: a point whose gap is at most this is closed (velocity-level
/// law, part of an impact), m. Round-off-level gaps of persistent contacts stay below it.
pub const CLOSED_GAP: f64 = PENETRATION_TOLERANCE;

/// Impact stepper: the discrete-gradient rows are re-evaluated until the loaded points' gap
/// functions at the end of the step agree with the rows to this, m.
pub const DRIFT_TOLERANCE: f64 = 1e-15;
/// Impact stepper: an end velocity approaching a loaded point by less than this in a step
/// (m) is kept as it is (see `settle_velocity`). A hundredth of the displacement problem's own
/// row tolerance (`solver::sparse::ROW_TOLERANCE`, 1e-11 m): below it an approach is the
/// round-off of the step's solution, which a whole-wall velocity problem every step would
/// only redistribute (measured at 1e-15 m: walls standing still solved one on every step).
pub const VELOCITY_TOLERANCE: f64 = 1e-13;
/// Impact stepper: most solves of one step for its discrete-gradient rows.
pub const DISCRETE_GRADIENT_SOLVES: usize = 4;
/// Impact stepper: a discrete-gradient iteration that ends at `DISCRETE_GRADIENT_SOLVES` with
/// a drift above this (m) has not converged: its rows do not hold the points at their faces
/// (the drift is how far they miss), and the step is taken again as two halves.
pub const CONVERGED_DRIFT: f64 = PENETRATION_TOLERANCE;
/// Impact stepper: the most times a step is halved for its discrete-gradient iteration to
/// converge; a part of the step `2^-HALVINGS` long that still does not is an error.
pub const HALVINGS: u32 = 10;
/// Impact stepper: an impact instant located within this fraction of the step of the step's
/// end is taken at its end: the ordinary sub-step, whose position-level rows close the points
/// there and whose end velocity is settled plastically, is kept. The rest of the step after
/// such an instant would be a sub-step of a sliver (or of nothing: the closing instant's root
/// can be the end of the step exactly, and the ground's mean acceleration over a sub-step of
/// length zero is 0/0), whose rows divide the closed points' round-off gaps by its length.
pub const END_OF_STEP: f64 = 1e-6;

use super::solver::{Blob, ContactSolver, SolveFailure};
use crate::excitation::{DefinedBy, GroundMotion};
use crate::geometry::{BroadPhase, ContactPoint, Placed, Pose, block_contacts, ground_contacts};
use crate::scene::AppliedAs;

/// No gradients (a point that does not end closed).
const NO_GRADIENTS: (Gradient, Gradient, usize) = ([(0, 0.0); 6], [(0, 0.0); 6], 0);

/// Add `r`'s tangential row and offset to `sum`'s (rows of the same body pair share their DOF
/// layout).
fn add_tangential(sum: &mut ContactRows, r: &ContactRows) {
    sum.g_t += r.g_t;
    for (a, b) in sum.trow.iter_mut().zip(&r.trow) {
        debug_assert_eq!(a.0, b.0);
        a.1 += b.1;
    }
}

/// `w (g + row·v) = 0` as a pair of opposite frictionless rows (keys `key | 1 << 60` and
/// `key | 2 << 60`).
fn equal_to_zero(key: u64, g: f64, row: &SparseRow, w: f64) -> [ContactRows; 2] {
    [(w, 1u64), (-w, 2u64)].map(|(sign, tag)| ContactRows {
        key: key | tag << 60,
        mu: 0.0,
        g_n: sign * g,
        g_t: 0.0,
        nrow: row.iter().map(|&(i, c)| (i, sign * c)).collect(),
        trow: row.iter().map(|&(i, _)| (i, 0.0)).collect(),
    })
}

#[inline]
fn row_dot(row: &[(usize, f64)], x: &[f64]) -> f64 {
    row.iter().map(|&(i, c)| c * x[i]).sum()
}

/// Whether each point of a step problem is closed at the end of its solution: its gap,
/// `g_n + n·dq` (under the associative law the lower edge row, `g_n + n·dq - mu |g_t + t·dq|`,
/// whose dilatancy lifts a sliding point by exactly `mu |slip|`) within `CLOSED_GAP`. The
/// impact stepper decides by this, not by which points carry a force: the displacement of a
/// solution is unique, its forces are not (a flat interface has four rows on three relative
/// DOFs, and each back-end splits the load between its two points its own way; deciding by
/// force, Clarabel and the active-set back-end gave the two-block case's first crossing of the
/// statue 7 ms apart).
fn closed_into(pr: &StepProblem, sol: &StepSolution, law: FrictionLaw, closed: &mut Vec<bool>) {
    closed.clear();
    closed.extend(pr.contacts.iter().map(|c| {
        let n = c.g_n + row_dot(&c.nrow, &sol.dq);
        let gap = match law {
            FrictionLaw::Associative => n - c.mu * (c.g_t + row_dot(&c.trow, &sol.dq)).abs(),
            FrictionLaw::Coulomb => n,
        };
        gap <= CLOSED_GAP
    }));
}

/// Sorted keys of the points of `pr` that `closed` (from [`closed_into`]) marks, into `keys`.
fn closed_keys_into(pr: &StepProblem, closed: &[bool], keys: &mut Vec<u64>) {
    keys.clear();
    keys.extend(
        pr.contacts
            .iter()
            .zip(closed)
            .filter(|(_, l)| **l)
            .map(|(c, _)| c.key),
    );
    keys.sort_unstable();
}

/// Sorted keys of the points of `pr` that `closed` marks.
fn closed_keys(pr: &StepProblem, closed: &[bool]) -> Vec<u64> {
    let mut keys = Vec::new();
    closed_keys_into(pr, closed, &mut keys);
    keys
}

/// Smallest root in (0, h] of `g0 + b tau + c tau^2` with `g0 > 0`; without a real root, the
/// minimum if it lies in (0, h] (only asked for a point that the ordinary step closed).
fn first_root(g0: f64, b: f64, c: f64, h: f64) -> Option<f64> {
    let roots: Vec<f64> = if c.abs() <= 1e-12 * b.abs().max(1e-300) / h {
        if b < 0.0 { vec![-g0 / b] } else { vec![] }
    } else {
        let disc = b * b - 4.0 * c * g0;
        if disc < 0.0 {
            // A graze: the closest approach, where the normal velocity is zero (the two roots
            // merge there as the graze deepens).
            if c > 0.0 {
                vec![-b / (2.0 * c)]
            } else {
                vec![]
            }
        } else {
            // Stable form of the two roots.
            let qq = -0.5 * (b + b.signum() * disc.sqrt());
            let mut r = vec![qq / c];
            if qq != 0.0 {
                r.push(g0 / qq);
            }
            r
        }
    };
    roots
        .into_iter()
        .filter(|&t| t > 0.0 && t <= h)
        .min_by(|a, b| a.total_cmp(b))
}

/// Keep the rows of the islands (`native::islands`) with a row whose point approaches,
/// `approach * h > VELOCITY_TOLERANCE` (`approach` holds the first rows' values; rows past its
/// end are in the islands of those before them): the velocity problem is separable over
/// islands, and each other island's velocity is its own closest admissible one.
fn keep_islands_that_approach(
    n_blocks: usize,
    rows: &mut Vec<ContactRows>,
    approach: &[f64],
    h: f64,
    islands: &mut Islands,
) {
    let block = |r: &ContactRows| r.nrow.first().map(|e| e.0 / 3);
    islands.components.find(n_blocks, rows);
    let island = islands.components.island();
    holding_into(
        island,
        rows.iter()
            .zip(approach)
            .filter(|(_, a)| **a * h > VELOCITY_TOLERANCE)
            .filter_map(|(r, _)| block(r)),
        &mut islands.held,
    );
    let settles = &islands.held;
    rows.retain(|r| block(r).and_then(|b| island[b]).is_none_or(|i| settles[i]));
}

/// Whether, under the associative law, some row `(n ± mu t)·(v - w) >= 0` of a point that ends
/// closed (`carries`; `end`: its gradients at the end configuration) approaches by more than
/// `VELOCITY_TOLERANCE` over `h`: `Stepper::settle_velocity`'s test, with the same sums in the
/// same order, before any row is built.
fn approaches(
    contacts: &[ContactPoint],
    end: &[(Gradient, Gradient, usize)],
    carries: &[bool],
    w: (f64, f64),
    v: &[f64],
    friction: impl Fn(&ContactPoint) -> f64,
    h: f64,
) -> bool {
    let mut worst = 0.0f64;
    for ((c, g), _) in contacts.iter().zip(end).zip(carries).filter(|(_, l)| **l) {
        let (vn, vt) = end_relative_velocity(c, g, w, v);
        worst = worst.max(friction(c) * vt.abs() - vn);
    }
    worst * h > VELOCITY_TOLERANCE
}

/// The normal and tangential relative velocities `(n·(v - w), t·(v - w))` of a point whose
/// gradients at the end configuration are `(gn, gt, len)`; `w` the ground's velocity.
#[inline]
fn end_relative_velocity(
    c: &ContactPoint,
    (gn, gt, len): &(Gradient, Gradient, usize),
    w: (f64, f64),
    v: &[f64],
) -> (f64, f64) {
    let (g_n, g_t) = ground_offsets(c, w);
    (g_n + row_dot(&gn[..*len], v), g_t + row_dot(&gt[..*len], v))
}

/// Working storage for the islands of a problem (`native::islands`): their components and
/// which of them a step marks.
#[derive(Default)]
struct Islands {
    components: Components,
    held: Vec<bool>,
}

/// What a step started from, for `Stepper::locate_per_island`.
struct Start<'a> {
    state: &'a NativeState,
    /// The step's length.
    dt: f64,
    loaded: &'a [u64],
}

/// An island's part of the whole scene's ordinary step, handed to its own `step_locating` as
/// its first sub-step (the step problem is separable over islands).
struct Taken {
    state: NativeState,
    solution: StepSolution,
    problem: StepProblem,
    closed: Vec<bool>,
    /// Its points' end gradients while its end velocity is not settled yet.
    unsettled: Option<Vec<(Gradient, Gradient, usize)>>,
}

/// The ordinary (unsplit) step of the whole scene, for `Stepper::locate_per_island`.
struct Ordinary<'a> {
    problem: &'a StepProblem,
    closed: &'a [bool],
    solution: &'a StepSolution,
    /// Its end gradients while its end velocity is not settled yet (`step_locating`).
    unsettled: Option<&'a [(Gradient, Gradient, usize)]>,
}

/// State of the native engine between steps.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub struct NativeState {
    pub t: f64,
    pub step: u64,
    /// (x, z, phi) per block; absolute when the ground moves, relative to it otherwise.
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    /// Discrete ground displacement and velocity (x, z).
    pub ground_d: (f64, f64),
    pub ground_w: (f64, f64),
}

impl Clone for NativeState {
    fn clone(&self) -> Self {
        NativeState {
            t: self.t,
            step: self.step,
            q: self.q.clone(),
            v: self.v.clone(),
            ground_d: self.ground_d,
            ground_w: self.ground_w,
        }
    }
    /// Into the buffers already held (a located step copies its start state every round).
    fn clone_from(&mut self, source: &Self) {
        self.t = source.t;
        self.step = source.step;
        self.q.clone_from(&source.q);
        self.v.clone_from(&source.v);
        self.ground_d = source.ground_d;
        self.ground_w = source.ground_w;
    }
}

/// Buffers that the impact stepper's sub-steps reuse, so that a step of a small scene does not
/// spend its time allocating (measured: a quarter of a one-block step's instructions went to
/// malloc and free).
#[derive(Default)]
struct Workspace {
    /// Problems given back after their sub-step ([`Stepper::give_back`]).
    problems: Vec<StepProblem>,
    /// Solutions given back ([`Stepper::give_back_solution`]).
    solutions: Vec<StepSolution>,
    /// The state at the start of a located round.
    start: Option<NativeState>,
    /// Poses at the start of a sub-step.
    poses: Vec<Pose>,
    /// A sub-step's points as material points (`solve_discrete_gradient`).
    points: Vec<MaterialContact>,
    /// The gradients of each point's gap functions at the end of a sub-step (the points that
    /// end closed; `NO_GRADIENTS` for the others), for `settle_velocity`.
    end_gradients: Vec<(Gradient, Gradient, usize)>,
    /// The discrete-gradient iteration's drift per point.
    drifts: Vec<f64>,
    /// The islands of a sub-step's problem (`iterate_discrete_gradient`, `settle_velocity`).
    islands: Islands,
    /// The discrete-gradient iteration's predicted increment.
    dq: Vec<f64>,
    /// Which points of a sub-step end closed, given back by `step_locating`.
    closed: Vec<bool>,
    /// What a step that is halved starts again from (`Stepper::advance`), one per halving.
    restarts: Vec<Restart>,
    detection: Detection,
    /// The contact points of the step before last, whose buffer detection fills again.
    contacts: Vec<ContactPoint>,
}

/// What a step changes that its redo as two halves must start from: the state and the impact
/// stepper's memory of the last step (the back-ends' warm starts only change the path at the
/// solvers' tolerance, and sleeping islands woken by the first try stay awake).
struct Restart {
    state: NativeState,
    accel: Vec<f64>,
    loaded: Vec<u64>,
    struck: Vec<u64>,
}

/// Detection's working storage: the placed rectangles, the broad phase's and its pairs.
#[derive(Default)]
struct Detection {
    placed: Vec<Placed>,
    broad: BroadPhase,
    pairs: Vec<(usize, usize)>,
}

/// Spare problems (and solutions) a stepper keeps (a located step holds at most three at once).
const SPARE_PROBLEMS: usize = 4;

/// Ground increment of one step.
#[derive(Debug, Clone, Copy)]
struct GroundStep {
    dd: (f64, f64),
    w1: (f64, f64),
    a_eff: (f64, f64),
}

pub struct Stepper {
    pub settings: NativeSettings,
    pub bodies: Bodies,
    gravity: f64,
    motion: GroundMotion,
    applied_as: AppliedAs,
    solver: Box<dyn ContactSolver>,
    /// The back-end of the velocity problems (impacts, settled end velocities): its own
    /// instance, so that each kind of problem keeps its own warm start.
    velocity_solver: Box<dyn ContactSolver>,
    /// The back-end of the projections of a penetration (`project_out_penetration`), of the
    /// velocity problems' kind, apart from them for the same reason: a projection's warm start
    /// is the last projection's, not the last settled end velocity's (and the next settled
    /// velocity's is not a projection's). See docs/method.md, "Walls".
    projection_solver: Box<dyn ContactSolver>,
    /// Contacts of the last step (for inspection and tests).
    pub last_contacts: Vec<ContactPoint>,
    /// The last step's solution (returned by [`Stepper::step`]).
    last_solution: StepSolution,
    pub iterations: u64,
    /// Sub-steps whose solution was polished on its active set.
    pub polished_steps: u64,
    /// Steps split at a located impact instant.
    pub split_steps: u64,
    /// Position projections after an impact (impact stepper without impact location).
    pub projections: u64,
    /// The potential energy those projections gained, J per metre of depth: the sum over the
    /// projections of `sum m g dz` over their displacements, where positive. It bounds the
    /// impact stepper's energy growth without excitation, which only the projections make
    /// (docs/method.md, "The impact-consistent stepper").
    pub projected_energy: f64,
    /// Impact stepper: solves for the discrete-gradient rows, all steps together.
    pub gradient_solves: u64,
    /// Impact stepper: end velocities made admissible on the loaded points (`settle_velocity`).
    pub settled_velocities: u64,
    /// Impact stepper: plastic impacts at the start of a step on closed points that approach.
    pub start_impacts: u64,
    /// Impact stepper: located impact instants halved because a located point was through its
    /// face at the instant first found.
    pub halved_instants: u64,
    /// Impact stepper: located impact instants taken at the end of their step
    /// (`END_OF_STEP`).
    pub end_of_step_instants: u64,
    /// Impact stepper: steps (or parts of steps) taken again as two halves because their
    /// discrete-gradient iteration did not converge (`CONVERGED_DRIFT`).
    pub halved_steps: u64,
    /// Impact stepper: the acceleration of the last sub-step (the predictor of the next).
    accel: Vec<f64>,
    /// Sorted keys of the points that carried a normal force at the end of the last step
    /// (impact location: a point that did is not a new impact).
    loaded: Vec<u64>,
    /// Sorted keys of the points struck by a located impact in the last step (and in this one
    /// as it goes on): such a point that leaves its face is free of the cone
    /// (`free_until_it_closes`).
    struck: Vec<u64>,
    /// Sorted keys of the points that keep their cone though `free_until_it_closes` would free
    /// them: new impacts left unlocated, while their ordinary sub-step is redone
    /// (`step_locating`). Empty between steps.
    under_cone: Vec<u64>,
    /// Non-associative friction (warm start and counters).
    pub coulomb: Coulomb,
    /// Sleeping islands (`native.sleep`, excitation applied as horizontal inertial forces).
    pub sleep: Option<Sleep>,
    /// The blocks (increasing) that detection considers while one island's step is located
    /// apart from the others (`island_impacts`); `None`: every block.
    scope: Option<Vec<usize>>,
    /// Steps of one island located apart from the others (`island_impacts`).
    pub island_steps: u64,
    /// `settle_velocity`'s working storage: how far each row's point approaches.
    approach: Vec<f64>,
    work: Workspace,
}

/// The stepper's counters, in the order a checkpoint keeps them: a value, or the places
/// [`Stepper::restore`] assigns.
macro_rules! counters {
    ($s:expr) => {
        [
            $s.iterations,
            $s.polished_steps,
            $s.split_steps,
            $s.projections,
            $s.gradient_solves,
            $s.settled_velocities,
            $s.start_impacts,
            $s.halved_instants,
            $s.end_of_step_instants,
            $s.island_steps,
        ]
    };
}

/// [`Stepper::save`]'s fields, borrowed to write them.
#[derive(serde::Serialize)]
struct Carried<'a> {
    last_contacts: &'a [ContactPoint],
    last_solution: &'a StepSolution,
    counters: [u64; 10],
    halved_steps: u64,
    projected_energy: f64,
    accel: &'a [f64],
    loaded: &'a [u64],
    struck: &'a [u64],
    coulomb: &'a Coulomb,
    sleep: &'a Option<Sleep>,
    solver: Blob,
    velocity_solver: Blob,
    projection_solver: Blob,
}

/// [`Carried`], read back.
#[derive(serde::Deserialize)]
struct CarriedOwned {
    last_contacts: Vec<ContactPoint>,
    last_solution: StepSolution,
    counters: [u64; 10],
    /// Absent from the checkpoints of builds that did not halve steps.
    #[serde(default)]
    halved_steps: u64,
    /// Absent from the checkpoints of builds that did not count it.
    #[serde(default)]
    projected_energy: f64,
    accel: Vec<f64>,
    loaded: Vec<u64>,
    struck: Vec<u64>,
    coulomb: Coulomb,
    sleep: Option<Sleep>,
    solver: Blob,
    velocity_solver: Blob,
    projection_solver: Blob,
}

/// A step that could not be taken.
#[derive(Debug, Clone, thiserror::Error)]
pub enum StepError {
    #[error("step {step} (t = {t:.6} s): contact solver failed: {failure}")]
    Solver {
        step: u64,
        t: f64,
        failure: SolveFailure,
    },
    #[error("step {step} (t = {t:.6} s): the state became non-finite")]
    NonFinite { step: u64, t: f64 },
    #[error(
        "step {step} (t = {t:.6} s): the impact stepper's discrete-gradient rows did not converge in a part of the step {h:.3e} s long: the points miss their faces by {drift:.3e} m (more than {CONVERGED_DRIFT:e} m)"
    )]
    Unconverged {
        step: u64,
        t: f64,
        h: f64,
        drift: f64,
    },
}

impl Stepper {
    pub fn new(
        settings: NativeSettings,
        bodies: Bodies,
        gravity: f64,
        motion: GroundMotion,
        applied_as: AppliedAs,
        solver: Box<dyn ContactSolver>,
    ) -> Self {
        let n_blocks = bodies.len();
        let velocity_solver = super::solver::velocity_solver_for(&settings);
        let projection_solver = super::solver::velocity_solver_for(&settings);
        let sleep = (settings.sleep
            && applied_as == AppliedAs::InertialForces
            && motion.vertical.is_none())
        .then(|| {
            let window = (crate::engines::native::REST_WINDOW / settings.dt).ceil() as u32;
            Sleep::new(n_blocks, window, settings.rest_velocity, gravity)
        });
        Stepper {
            settings,
            bodies,
            gravity,
            motion,
            applied_as,
            solver,
            velocity_solver,
            projection_solver,
            last_contacts: Vec::new(),
            last_solution: StepSolution::default(),
            iterations: 0,
            polished_steps: 0,
            split_steps: 0,
            projections: 0,
            projected_energy: 0.0,
            gradient_solves: 0,
            start_impacts: 0,
            halved_instants: 0,
            end_of_step_instants: 0,
            halved_steps: 0,
            settled_velocities: 0,
            accel: vec![0.0; 3 * n_blocks],
            loaded: Vec::new(),
            struck: Vec::new(),
            under_cone: Vec::new(),
            coulomb: Coulomb::default(),
            sleep,
            scope: None,
            island_steps: 0,
            approach: Vec::new(),
            work: Workspace::default(),
        }
    }

    pub fn solver_name(&self) -> &'static str {
        self.solver.name()
    }

    /// What the stepper carries from one step to the next (the last contacts and solution,
    /// the points loaded and struck, the predictor, sleep, both back-ends' warm starts and
    /// factors, the counters), for a checkpoint ([`crate::native::checkpoint`]). The
    /// workspace's buffers are not: every step writes them before it reads them.
    pub fn save(&self) -> Vec<u8> {
        debug_assert!(self.scope.is_none(), "saved within a step");
        let counters = counters!(self);
        super::solver::to_bytes(&Carried {
            last_contacts: &self.last_contacts,
            last_solution: &self.last_solution,
            counters,
            halved_steps: self.halved_steps,
            projected_energy: self.projected_energy,
            accel: &self.accel,
            loaded: &self.loaded,
            struck: &self.struck,
            coulomb: &self.coulomb,
            sleep: &self.sleep,
            solver: Blob(self.solver.save()),
            velocity_solver: Blob(self.velocity_solver.save()),
            projection_solver: Blob(self.projection_solver.save()),
        })
    }

    /// Take the state [`Stepper::save`] gave, into a stepper made for the same scene: the
    /// steps that follow are the saved stepper's, to the bit.
    pub fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let c: CarriedOwned = super::solver::from_bytes(state, "the stepper")?;
        if c.accel.len() != self.accel.len() {
            return Err(format!(
                "the stepper: {} blocks saved, the scene has {}",
                c.accel.len() / 3,
                self.accel.len() / 3
            ));
        }
        self.solver.restore(&c.solver.0)?;
        self.velocity_solver.restore(&c.velocity_solver.0)?;
        self.projection_solver.restore(&c.projection_solver.0)?;
        counters!(self) = c.counters;
        self.halved_steps = c.halved_steps;
        self.projected_energy = c.projected_energy;
        self.last_contacts = c.last_contacts;
        self.last_solution = c.last_solution;
        self.accel = c.accel;
        self.loaded = c.loaded;
        self.struck = c.struck;
        self.coulomb = c.coulomb;
        self.sleep = c.sleep;
        Ok(())
    }

    /// The back-ends: the step problems', the velocity problems', the projections'.
    fn back_ends(&self) -> [&dyn ContactSolver; 3] {
        [
            self.solver.as_ref(),
            self.velocity_solver.as_ref(),
            self.projection_solver.as_ref(),
        ]
    }

    /// Steps the back-ends handed to Clarabel.
    pub fn solver_fallbacks(&self) -> u64 {
        self.back_ends().iter().map(|b| b.fallbacks()).sum()
    }

    /// Newton-matrix factorisations of the back-ends (sparse).
    pub fn solver_factorisations(&self) -> u64 {
        self.back_ends().iter().map(|b| b.factorisations()).sum()
    }

    /// Of [`Stepper::solver_factorisations`], those of the velocity problems (settled end
    /// velocities and plastic impacts) and of the projections of a penetration.
    pub fn velocity_factorisations(&self) -> u64 {
        self.back_ends()[1..]
            .iter()
            .map(|b| b.factorisations())
            .sum()
    }

    /// Rows the sparse back-ends took into or out of their factors by rank-one updates.
    pub fn solver_factor_updates(&self) -> u64 {
        self.back_ends().iter().map(|b| b.factor_updates()).sum()
    }

    /// Problems the sparse back-ends handed to their interior-point rescue.
    pub fn solver_rescues(&self) -> u64 {
        self.back_ends().iter().map(|b| b.rescues()).sum()
    }

    /// The certificates of the step problems' solutions, where they are certified
    /// (`native.certify`).
    pub fn certified(&self) -> Option<super::solver::certificate::Certified> {
        self.solver.certified()
    }

    /// The weight of the end-of-step velocity in the displacement, `dq = dt ((1 - w) v0 + w v)`:
    /// theta, or 1/2 with midpoint kinematics.
    fn kinematic_weight(&self) -> f64 {
        match self.settings.stepper {
            StepperKind::Impact => 0.5,
            StepperKind::Paper => self.settings.theta,
        }
    }

    fn ground_step(&self, s: &NativeState, dt: f64) -> GroundStep {
        let th = self.kinematic_weight();
        // Midpoint kinematics: the ground follows the same update as the blocks,
        // from its exact mean acceleration, for both definitions.
        let from_velocity = self.settings.stepper == StepperKind::Impact;
        let (t0, t1) = (s.t, s.t + dt);
        let comp = |c: Option<&crate::excitation::Component>, w0: f64| -> (f64, f64, f64) {
            match c {
                None => (0.0, w0, 0.0),
                Some(c) if from_velocity || c.defined_by() == DefinedBy::Acceleration => {
                    let a = (c.vel(t1) - c.vel(t0)) / dt;
                    (dt * w0 + th * dt * dt * a, w0 + dt * a, a)
                }
                Some(c) => {
                    let dd = c.disp(t1) - c.disp(t0);
                    let w1 = (dd / dt - (1.0 - th) * w0) / th;
                    (dd, w1, (w1 - w0) / dt)
                }
            }
        };
        let (dx, wx, ax) = comp(self.motion.horizontal.as_ref(), s.ground_w.0);
        let (dz, wz, az) = comp(self.motion.vertical.as_ref(), s.ground_w.1);
        GroundStep {
            dd: (dx, dz),
            w1: (wx, wz),
            a_eff: (ax, az),
        }
    }

    /// Contact points at the current geometry.
    pub fn detect(&self, s: &NativeState) -> Vec<ContactPoint> {
        let mut out = Vec::new();
        self.detect_into(s, &mut Detection::default(), &mut out);
        out
    }

    /// The interval of horizontal ground accelerations (m/s^2) under which every block stays at
    /// rest in the state `s`, all blocks taken together on the points closed there
    /// ([`rest_interval`]: the static theorem, exact for the associative law); `None` as there.
    pub fn rest_interval_of(&self, s: &NativeState) -> Option<(f64, f64)> {
        let blocks: Vec<usize> = (0..self.bodies.len()).collect();
        self.island_rest_interval(&self.detect(s), &poses(&s.q), &blocks)
    }

    /// [`rest_interval`] of the island `blocks` (increasing) on its closed points among
    /// `contacts`, at the poses `ps`.
    fn island_rest_interval(
        &self,
        contacts: &[ContactPoint],
        ps: &[Pose],
        blocks: &[usize],
    ) -> Option<(f64, f64)> {
        let rows: Vec<ContactRows> = contacts
            .iter()
            .filter(|c| c.gap <= CLOSED_GAP && blocks.binary_search(&c.b).is_ok())
            .map(|c| contact_rows(c, ps, self.bodies.friction(c), (0.0, 0.0)))
            .collect();
        rest_interval(blocks, &rows, &self.bodies.mass, self.gravity)
    }

    /// [`Stepper::detect`] into `out`, with `scratch` as working storage.
    fn detect_into(&self, s: &NativeState, scratch: &mut Detection, out: &mut Vec<ContactPoint>) {
        out.clear();
        let Detection {
            placed,
            broad,
            pairs,
        } = scratch;
        let dt = self.settings.dt;
        let frac = self.settings.contact_reach;
        let ground_z = match self.applied_as {
            AppliedAs::MovingGround => s.ground_d.1,
            AppliedAs::InertialForces => 0.0,
        };
        let ground_speed = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w.0.hypot(s.ground_w.1),
            AppliedAs::InertialForces => 0.0,
        };
        let speed = |i: usize, p: (f64, f64)| -> f64 {
            let (vx, vz, om) = (s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2]);
            let (rx, rz) = (p.0 - s.q[3 * i], p.1 - s.q[3 * i + 1]);
            // A reach, not a geometric quantity: sqrt is enough (and cheaper than hypot).
            let (wx, wz) = (vx - om * rz, vz + om * rx);
            (wx * wx + wz * wz).sqrt()
        };
        let asleep = |i: usize| self.sleep.as_ref().is_some_and(|sl| sl.asleep(i));
        if self.sleep.as_ref().is_some_and(Sleep::all_asleep) {
            return;
        }
        let rects = &self.bodies.rects;
        // The blocks detection considers: the island stepped alone, or every block.
        let scope = self.scope.as_deref();
        let member = |k: usize| scope.map_or(k, |blocks| blocks[k]);
        let count = scope.map_or(rects.len(), <[usize]>::len);
        placed.clear();
        placed.extend(
            (0..count)
                .map(member)
                .map(|i| Placed::new(&rects[i], &pose(&s.q, i))),
        );
        for (k, placed_i) in placed.iter().enumerate() {
            let i = member(k);
            if asleep(i) {
                continue;
            }
            let lim = frac * rects[i].min_dim();
            let reach = |p: (f64, f64), gap: f64| {
                gap < lim || gap < 3.0 * (speed(i, p) + ground_speed) * dt
            };
            ground_contacts(i, placed_i, ground_z, &reach, out);
        }
        let margin = |k: usize| {
            // A reach, not a geometric quantity: sqrt is enough (and cheaper than hypot).
            let i = member(k);
            let (vx, vz) = (s.v[3 * i], s.v[3 * i + 1]);
            frac * rects[i].min_dim() + 3.0 * (vx * vx + vz * vz).sqrt() * dt
        };
        if count < 2 {
            return;
        }
        broad.pairs_into(placed, &margin, pairs);
        for &(ki, kj) in pairs.iter() {
            let (i, j) = (member(ki), member(kj));
            if asleep(i) && asleep(j) {
                continue;
            }
            let lim = frac * rects[i].min_dim().min(rects[j].min_dim());
            let reach =
                |p: (f64, f64), gap: f64| gap < lim || gap < 3.0 * (speed(i, p) + speed(j, p)) * dt;
            block_contacts((i, &placed[ki]), (j, &placed[kj]), &reach, out);
        }
    }

    /// Build the problem of the next step into `pr` (its buffers reused), from the poses `ps`
    /// of `s`; returns the ground increment.
    fn problem(
        &self,
        s: &NativeState,
        contacts: &[ContactPoint],
        dt: f64,
        ps: &[Pose],
        pr: &mut StepProblem,
    ) -> GroundStep {
        let g = self.ground_step(s, dt);
        let n = self.bodies.len();
        let (ax, az) = match self.applied_as {
            AppliedAs::InertialForces => g.a_eff,
            AppliedAs::MovingGround => (0.0, 0.0),
        };
        let force = &mut pr.force;
        force.clear();
        force.resize(3 * n, 0.0);
        for i in 0..n {
            if self.sleep.as_ref().is_some_and(|sl| sl.asleep(i)) {
                // No force and no contact point: the step leaves a sleeping block in place.
                continue;
            }
            let m = self.bodies.mass[3 * i];
            force[3 * i] = -m * ax;
            force[3 * i + 1] = -m * (self.gravity + az);
        }
        let ground_step = match self.applied_as {
            AppliedAs::MovingGround => g.dd,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let th = self.kinematic_weight();
        let w0 = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let force = &pr.force;
        let free_motion = std::cell::OnceCell::new();
        // Rows written in place over the last step's (a point's rows are some 240 bytes).
        pr.contacts.truncate(contacts.len());
        pr.contacts
            .resize_with(contacts.len(), ContactRows::default);
        for (c, r) in contacts.iter().zip(pr.contacts.iter_mut()) {
            contact_rows_into(c, ps, self.bodies.friction(c), ground_step, r);
            if self.settings.stepper == StepperKind::Impact {
                // Relative velocity at the start of the step.
                let (mut vn, mut vt) = (row_dot(&r.nrow, &s.v), row_dot(&r.trow, &s.v));
                if c.a.is_none() {
                    let n = c.normal;
                    vn -= n.0 * w0.0 + n.1 * w0.1;
                    vt -= n.1 * w0.0 - n.0 * w0.1;
                }
                if c.gap <= CLOSED_GAP {
                    // Closed: `g0+ + G dq >= 0` with the discrete-gradient rows, i.e. the
                    // mean relative velocity of the step does not approach (a penetration
                    // at round-off level is held, not pushed out: that would do work).
                    r.g_n += c.gap.max(0.0) - c.gap;
                } else if !self.settings.locate_impacts && c.gap + (1.0 - th) * dt * vn <= 0.0 {
                    // Closing within the first half of the step, impacts not located: the
                    // velocity-level law on the end-of-step relative
                    // velocity, (n ± mu t)·v >= 0, i.e.
                    // (nrow ± mu trow) dq - (n ± mu t)·Δd - (1 - w) dt (v_n0 ± mu v_t0) >= 0:
                    // plastic, no rebound.
                    r.g_n += -c.gap - (1.0 - th) * dt * vn;
                    r.g_t += -(1.0 - th) * dt * vt;
                }
                let leaves = || {
                    // The point's gap at the end of the step's free motion,
                    // `dq = h v0 + h^2/2 M^-1 f` (exact gap function).
                    let dq = free_motion.get_or_init(|| {
                        (0..3 * n)
                            .map(|i| dt * s.v[i] + 0.5 * dt * dt * force[i] / self.bodies.mass[i])
                            .collect::<Vec<f64>>()
                    });
                    let mut g = MaterialContact::new(c, ps).gaps(&Increment::new(dq, 1.0)).0;
                    if c.a.is_none() {
                        g -= c.normal.0 * ground_step.0 + c.normal.1 * ground_step.1;
                    }
                    g
                };
                if self.free_until_it_closes(c, r.key, vn, dt, leaves) {
                    if self.under_cone.binary_search(&r.key).is_err() {
                        // Open, or leaving its face: no force before it touches (the gap row
                        // alone); its closing is located.
                        r.mu = 0.0;
                    } else if c.gap > CLOSED_GAP {
                        // Left unlocated, it closes under its cone anchored where it closes:
                        // the slip of its approach is no slip on its face. The instant is the
                        // free motion's closing instant, or the step's end. The anchor moves by
                        // at most `gap / mu`, so that the step's start satisfies the rows: an
                        // anchor the motion does not reach would lift the point, doing work.
                        let c2 = (leaves() - c.gap - vn * dt) / (dt * dt);
                        let slip = vt * first_root(c.gap, vn, c2, dt).unwrap_or(dt);
                        let most = c.gap / r.mu.max(f64::MIN_POSITIVE);
                        r.g_t -= slip.clamp(-most, most);
                    }
                }
            }
        }
        pr.theta = th;
        pr.dt = dt;
        pr.mass.clone_from(&self.bodies.mass);
        pr.v0.clone_from(&s.v);
        g
    }

    /// The problem the next step would solve (for replay and cross-checks).
    pub fn next_problem(&self, s: &NativeState) -> StepProblem {
        let c = self.detect(s);
        let mut pr = StepProblem::default();
        self.problem(s, &c, self.settings.dt, &poses(&s.q), &mut pr);
        pr
    }

    /// A step problem to fill: a spare one given back after an earlier sub-step, or a new one.
    fn spare_problem(&mut self) -> StepProblem {
        self.work.problems.pop().unwrap_or_default()
    }

    /// The step's contact points become `last_contacts`; the buffer of the last ones is
    /// detection's next.
    fn keep_contacts(&mut self, contacts: Vec<ContactPoint>) {
        self.work.contacts = std::mem::replace(&mut self.last_contacts, contacts);
    }

    /// A solution to fill: a spare one given back, or a new one.
    fn spare_solution(&mut self) -> StepSolution {
        self.work.solutions.pop().unwrap_or_default()
    }

    /// Keep a solution that is no longer needed for a later solve to fill.
    fn give_back_solution(&mut self, sol: StepSolution) {
        if self.work.solutions.len() < SPARE_PROBLEMS {
            self.work.solutions.push(sol);
        }
    }

    /// Keep a problem that is no longer needed for a later sub-step to fill.
    fn give_back(&mut self, pr: StepProblem) {
        if self.work.problems.len() < SPARE_PROBLEMS {
            self.work.problems.push(pr);
        }
    }

    /// How fast an open point `c` approaches over a (sub-)step of length `h` from `s`: its
    /// approach speed at the start or the mean speed that closes its gap within `h`, the larger.
    fn approach_speed(&self, c: &ContactPoint, ps: &[Pose], s: &NativeState, h: f64) -> f64 {
        let r = contact_rows(c, ps, 0.0, (0.0, 0.0));
        (-self.normal_speed(c, &r.nrow, &s.v, s.ground_w)).max(c.gap / h)
    }

    /// Whether a point (detected as `c`, its rows' key `key`) touches its face at the start of a
    /// (sub-)step: closed, or loaded at the end of the last step (its closing is no new impact).
    fn touches(&self, c: &ContactPoint, key: u64) -> bool {
        c.gap <= CLOSED_GAP || self.loaded.binary_search(&key).is_ok()
    }

    /// Whether a point's rows `r` (of the point detected as `c`) were freed of its friction cone
    /// (`free_until_it_closes`): they have less friction than its interface, i.e. none.
    fn freed_of_cone(&self, r: &ContactRows, c: &ContactPoint) -> bool {
        r.mu < self.bodies.friction(c)
    }

    /// Whether a point (detected as `c`, its rows' key `key`, normal relative velocity `vn` at
    /// the start of a (sub-)step of length `h`; `free_gap` gives its gap at the end of the
    /// step's free motion) is free of the friction cone until it closes, under the associative
    /// law with impacts located:
    /// - a point that does not touch its face (open, and not located in the last step);
    /// - a point struck by a located impact in this step or the last that touches its face and
    ///   leaves it: it separates (`vn h > CLOSED_GAP`) and its free motion ends the step open
    ///   (a plastic impact with slip leaves a point at `v_n = mu |v_t|`). A pivot the block
    ///   keeps is never freed: its normal velocity at a step's start, O(h^2) from the chord of
    ///   the step, is below the fall of its free motion. The pivot a rocking block lifts off
    ///   was struck by nothing and keeps its cone.
    ///
    /// Such a point carries no force before it touches, as the law says of an open point; the
    /// cone, anchored where the step starts, would bear on it once it slid `|slip| >= gap / mu`
    /// (an O(h) force on a point in the air: the two-block case's pedestal hops after its ground
    /// impact came out different at every dt). Its rows have `mu = 0` (the gap alone), and its
    /// closing is a new impact, whose plastic law is the cone: located, or, approaching slower
    /// than `locate_speed`, closed at the end of its step under the cone anchored where it
    /// closes (`step_locating`). (Left under the cone anchored where the step starts, such slow
    /// closings let a wall just above its static collapse acceleration creep where it must
    /// rest: `tests/walls.rs`, `a_running_bond_wall_starts_to_move_at_its_static_collapse_acceleration`.)
    fn free_until_it_closes(
        &self,
        c: &ContactPoint,
        key: u64,
        vn: f64,
        h: f64,
        free_gap: impl FnOnce() -> f64,
    ) -> bool {
        if self.settings.friction_law != FrictionLaw::Associative || !self.settings.locate_impacts {
            return false;
        }
        if self.touches(c, key) {
            self.struck.binary_search(&key).is_ok()
                && vn * h > CLOSED_GAP
                && free_gap() > CLOSED_GAP
        } else {
            true
        }
    }

    /// Normal relative velocity of a point for block velocities `v` and ground velocity `w`
    /// (the ground's counts only when the ground moves), from the point's rows.
    fn normal_speed(
        &self,
        c: &ContactPoint,
        nrow: &[(usize, f64)],
        v: &[f64],
        w: (f64, f64),
    ) -> f64 {
        let mut vn = row_dot(nrow, v);
        if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
            vn -= c.normal.0 * w.0 + c.normal.1 * w.1;
        }
        vn
    }

    /// Advance one step. With the impact-consistent stepper and `locate_impacts`, a step in
    /// which a point closes that carried no force in the previous step is redone in three
    /// parts: a sub-step to the closing instant, a plastic impact there, and the rest of the
    /// step (see `step_locating`).
    /// Returns the step's solution (its last sub-step's), kept until the next step.
    pub fn step(&mut self, s: &mut NativeState) -> Result<&StepSolution, StepError> {
        self.step_by(s, self.settings.dt)
    }

    /// One step of length `dt` (the impact stepper takes any length: a run's last step is
    /// shortened to end at the duration; the paper's stepper is only ever given its own).
    /// Every step of a run goes through it, never inlined, so that callgrind can count a
    /// step's instructions by its name (`crate::instructions`).
    #[inline(never)]
    pub fn step_by(&mut self, s: &mut NativeState, dt: f64) -> Result<&StepSolution, StepError> {
        let last = std::mem::take(&mut self.last_solution);
        self.give_back_solution(last);
        // The excitation's acceleration of this step, as the step problem will use it.
        // (Read only by sleeping.)
        let ax = match self.sleep {
            Some(_) => self.ground_step(s, dt).a_eff.0,
            None => 0.0,
        };
        let sol = self.advance(s, dt, 0)?;
        s.step += 1;
        self.fall_asleep(s, ax);
        self.last_solution = sol;
        Ok(&self.last_solution)
    }

    /// Take `s` on by `dt` (a step, or a part of one halved `halvings` times): once, or, if a
    /// discrete-gradient iteration does not converge (`StepError::Unconverged`), again from its
    /// start as two halves.
    fn advance(
        &mut self,
        s: &mut NativeState,
        dt: f64,
        halvings: u32,
    ) -> Result<StepSolution, StepError> {
        if self.settings.stepper == StepperKind::Paper {
            return self.advance_once(s, dt);
        }
        let mut restart = match self.work.restarts.pop() {
            Some(mut r) => {
                r.state.clone_from(s);
                r.accel.clone_from(&self.accel);
                r.loaded.clone_from(&self.loaded);
                r.struck.clone_from(&self.struck);
                r
            }
            None => Restart {
                state: s.clone(),
                accel: self.accel.clone(),
                loaded: self.loaded.clone(),
                struck: self.struck.clone(),
            },
        };
        let once = self.advance_once(s, dt);
        let taken = match once {
            Err(StepError::Unconverged { .. }) if halvings < HALVINGS => {
                s.clone_from(&restart.state);
                std::mem::swap(&mut self.accel, &mut restart.accel);
                std::mem::swap(&mut self.loaded, &mut restart.loaded);
                std::mem::swap(&mut self.struck, &mut restart.struck);
                self.under_cone.clear();
                self.halved_steps += 1;
                let t_end = restart.state.t + dt;
                self.advance(s, 0.5 * dt, halvings + 1)
                    .and_then(|first| {
                        self.give_back_solution(first);
                        self.advance(s, 0.5 * dt, halvings + 1)
                    })
                    .inspect(|_| s.t = t_end)
            }
            other => other,
        };
        self.work.restarts.push(restart);
        taken
    }

    /// [`Stepper::advance`] in one go.
    fn advance_once(&mut self, s: &mut NativeState, dt: f64) -> Result<StepSolution, StepError> {
        if self.sleep.is_some() {
            let ax = self.ground_step(s, dt).a_eff.0;
            if let Some(sl) = self.sleep.as_mut() {
                sl.wake_for_excitation(ax);
            }
        }
        let mut contacts = self.detect_waking(s);
        let t_end = s.t + dt;
        if self.settings.stepper == StepperKind::Impact
            && let Some(struck) = self.approaching(s, &contacts)
        {
            // A closed point that approaches (an impact the last step did not resolve): the
            // mean-velocity law would reflect it, so the plastic impact first.
            self.impact(s, &struck, &[])
                .map_err(|failure| StepError::Solver {
                    step: s.step + 1,
                    t: s.t,
                    failure,
                })?;
            self.start_impacts += 1;
            contacts = self.detect_waking(s);
        }
        let sol = if self.settings.stepper == StepperKind::Impact && self.settings.locate_impacts {
            self.step_locating(s, contacts, dt, None)?
        } else {
            let (sol, pr, _) = self.sub_step(s, &contacts, dt, true)?;
            self.give_back(pr);
            self.keep_contacts(contacts);
            sol
        };
        s.t = t_end;
        Ok(sol)
    }

    /// Contact points at the current geometry ([`Stepper::detect`]), after waking every
    /// sleeping island a point joins to an awake block.
    fn detect_waking(&mut self, s: &NativeState) -> Vec<ContactPoint> {
        let mut contacts = std::mem::take(&mut self.work.contacts);
        let mut scratch = std::mem::take(&mut self.work.detection);
        loop {
            self.detect_into(s, &mut scratch, &mut contacts);
            let woke = self
                .sleep
                .as_mut()
                .is_some_and(|sl| sl.wake_touched(&contacts));
            if !woke {
                self.work.detection = scratch;
                return contacts;
            }
        }
    }

    /// Put to sleep the islands of blocks that have been still for the window and that the
    /// ground acceleration of the step just taken, `ax`, cannot move (see `native::sleep`).
    fn fall_asleep(&mut self, s: &mut NativeState, ax: f64) {
        let Some(sl) = self.sleep.as_mut() else {
            return;
        };
        let extent: Vec<f64> = self
            .bodies
            .rects
            .iter()
            .map(|r| 2.0 * r.b.max(r.h))
            .collect();
        if !sl.observe(&s.v, &extent) {
            return;
        }
        let contacts = self.detect(s);
        let ps = poses(&s.q);
        let sl = self.sleep.as_ref().expect("sleep is on");
        let islands = sl.candidates(&contacts);
        for blocks in islands {
            let interval = self.island_rest_interval(&contacts, &ps, &blocks);
            let sl = self.sleep.as_mut().expect("sleep is on");
            let members = blocks.clone();
            if sl.try_sleep(blocks, interval, ax) {
                for b in members {
                    for k in 3 * b..3 * b + 3 {
                        s.v[k] = 0.0;
                        self.accel[k] = 0.0;
                    }
                }
            }
        }
        if let Some(sl) = self.sleep.as_mut() {
            sl.compact();
        }
    }

    /// Whether a closed point (gap within `CLOSED_GAP`) approaches faster than it would close
    /// `CLOSED_GAP` in a step: if so, the points of the islands that hold such a point (all of
    /// them without `island_impacts`; the other islands need no impact).
    fn approaching(&self, s: &NativeState, contacts: &[ContactPoint]) -> Option<Vec<ContactPoint>> {
        let approaches = |c: &ContactPoint| {
            c.gap <= CLOSED_GAP && {
                let (nrow, len) = normal_row(c, &s.q);
                self.normal_speed(c, &nrow[..len], &s.v, s.ground_w) * self.settings.dt
                    < -CLOSED_GAP
            }
        };
        if !contacts.iter().any(approaches) {
            return None;
        }
        if !self.settings.island_impacts || self.bodies.len() == 1 {
            return Some(contacts.to_vec());
        }
        let island = super::islands::components_of_points(self.bodies.len(), contacts);
        let struck = super::islands::holding(
            &island,
            contacts.iter().filter(|c| approaches(c)).map(|c| c.b),
        );
        Some(
            contacts
                .iter()
                .filter(|c| island[c.b].is_some_and(|i| struck[i]))
                .copied()
                .collect(),
        )
    }

    /// One step with the impact instants located.
    ///
    /// The ordinary (sub-)step is taken first. If a point that was open at its start and carried
    /// no force before carries one now (a new impact), the sub-step is retried without those
    /// points (a free trial); each one's gap within it is `g0 + vn0 tau + c2 tau^2` through its
    /// exact gap at the trial's end (`closing_instant`), and the impact instant is the smallest
    /// root. From the start: a sub-step to that instant (without the impacting points), a
    /// plastic impact on every closed point and the located ones (`impact`), and the rest of the
    /// step, located again: up to `native.located_per_step` impacts a step. New impacts left
    /// over (the cap reached, no instant found within the step, or slower than
    /// `native.locate_speed`) close at the end of their
    /// step under their position-level rows with the cone, anchored where each closes (moved by
    /// at most `gap / mu`): the ordinary sub-step, in which they were free of the cone, is
    /// redone (`under_cone`).
    fn step_locating(
        &mut self,
        s: &mut NativeState,
        mut contacts: Vec<ContactPoint>,
        dt: f64,
        mut taken: Option<Taken>,
    ) -> Result<StepSolution, StepError> {
        let t_end = s.t + dt;
        let mut iterations = 0;
        let mut located_here: Vec<u64> = Vec::new();
        let rounds = self.settings.located_per_step as usize;
        // Impacts located per island (see `locate_per_island`).
        let per_island = self.settings.island_impacts
            && self.scope.is_none()
            && self.sleep.is_none()
            && self.bodies.len() > 1;
        for round in 0..=rounds {
            let h = t_end - s.t;
            let mut s0 = self.work.start.take().unwrap_or_else(|| s.clone());
            s0.clone_from(s);
            // The ordinary sub-step. Its end velocity is settled once it is kept (`unsettled`
            // holds its end gradients until then): a located impact throws it away.
            let (mut sol, mut pr, mut carries, mut unsettled) = match taken.take() {
                Some(t) => {
                    *s = t.state;
                    (t.solution, t.problem, t.closed, t.unsettled)
                }
                None => {
                    let (sol, pr, closed) = self.sub_step(s, &contacts, h, false)?;
                    let end = std::mem::take(&mut self.work.end_gradients);
                    (sol, pr, closed, Some(end))
                }
            };
            // New impacts: points that did not touch their faces at the start and end closed,
            // and points that touched them, left them and end closed (`free_until_it_closes`:
            // their rows had less friction than their interface, i.e. none; a frictionless
            // interface's points are freed of nothing). Those slower than `locate_speed` are
            // not located (`timed`): under the associative law they close at the end of the
            // step under their cone like the impacts left over below; under Coulomb's law,
            // whose points are never freed, they are not new impacts.
            let slowest = self.settings.locate_speed;
            let ps0 = std::cell::OnceCell::new();
            let touched = |k: usize| self.touches(&contacts[k], pr.contacts[k].key);
            let freed = |k: usize| self.freed_of_cone(&pr.contacts[k], &contacts[k]);
            let fast = |k: usize| {
                slowest <= 0.0 || {
                    let ps = ps0.get_or_init(|| poses(&s0.q));
                    self.approach_speed(&contacts[k], ps, &s0, h) >= slowest
                }
            };
            let fresh: Vec<usize> = (0..contacts.len())
                .filter(|&k| carries[k] && (freed(k) || (!touched(k) && fast(k))))
                .collect();
            let timed: Vec<usize> = fresh
                .iter()
                .copied()
                .filter(|&k| touched(k) || fast(k))
                .collect();
            if round == 0 && per_island && !fresh.is_empty() {
                // `self.loaded` is still the last step's: only the rounds below change it.
                let loaded0 = self.loaded.clone();
                let start = Start {
                    state: &s0,
                    dt,
                    loaded: &loaded0,
                };
                let ordinary = Ordinary {
                    problem: &pr,
                    closed: &carries,
                    solution: &sol,
                    unsettled: unsettled.as_deref(),
                };
                if let Some(sol) = self.locate_per_island(s, start, &contacts, &fresh, ordinary)? {
                    return Ok(sol);
                }
            }
            let tau = if timed.is_empty() || round == rounds {
                None
            } else {
                let after_ordinary = s.clone();
                iterations += sol.iterations;
                // Free trial.
                *s = s0.clone();
                let free: Vec<ContactPoint> = (0..contacts.len())
                    .filter(|k| !fresh.contains(k))
                    .map(|k| contacts[k])
                    .collect();
                let (trial, trial_problem, _) = self.sub_step(s, &free, h, false)?;
                self.give_back(trial_problem);
                iterations += trial.iterations;
                self.give_back_solution(trial);
                let found = self.closing_instant(&s0, s, &contacts, &timed, h);
                let tau = found.filter(|&tau| tau < h - END_OF_STEP * dt);
                self.end_of_step_instants += u64::from(found.is_some() && tau.is_none());
                if tau.is_none() {
                    // The free motion does not close the points within the step (or closes them
                    // at its end, `END_OF_STEP`): keep the ordinary step.
                    *s = after_ordinary;
                    iterations -= sol.iterations;
                } else {
                    s.clone_from(&s0);
                }
                tau.map(|t| (t, free))
            };
            self.work.start = Some(s0);
            let Some((tau, free)) = tau else {
                if !fresh.is_empty() {
                    // New impacts left unlocated (the cap reached, no instant within the step,
                    // or slower than `locate_speed`) closed in the ordinary sub-step under the
                    // gap row alone, free of
                    // the cone: the sub-step is redone with their rows under the cone, and again
                    // with those of any point it closes free of the cone in turn.
                    let mut closing: Vec<usize> = fresh.clone();
                    while !closing.is_empty() {
                        // The problem's rows are the contacts' in order, with their keys.
                        self.under_cone
                            .extend(closing.iter().map(|&k| pr.contacts[k].key));
                        self.under_cone.sort_unstable();
                        iterations += sol.iterations;
                        self.give_back_solution(sol);
                        self.give_back(pr);
                        s.clone_from(self.work.start.as_ref().expect("the step's start"));
                        let redone = self.sub_step(s, &contacts, h, false);
                        (sol, pr, carries) = match redone {
                            Ok(r) => r,
                            Err(e) => {
                                self.under_cone.clear();
                                return Err(e);
                            }
                        };
                        unsettled = Some(std::mem::take(&mut self.work.end_gradients));
                        closing = (0..contacts.len())
                            .filter(|&k| {
                                carries[k] && self.freed_of_cone(&pr.contacts[k], &contacts[k])
                            })
                            .collect();
                    }
                    self.under_cone.clear();
                }
                if let Some(end) = unsettled.take() {
                    self.settle_kept(s, &contacts, &end, &carries, &pr, &mut sol)?;
                    self.work.end_gradients = end;
                }
                // The located points have just closed: not a new impact in the next step even if
                // the short rest of this one left them without a force (gap within the fall of
                // `g h^2/2`).
                closed_keys_into(&pr, &carries, &mut self.loaded);
                self.loaded.extend(&located_here);
                located_here.sort_unstable();
                located_here.dedup();
                self.struck = located_here;
                self.loaded.sort_unstable();
                self.loaded.dedup();
                sol.iterations += iterations;
                self.keep_contacts(contacts);
                self.give_back(pr);
                self.work.closed = carries;
                return Ok(sol);
            };
            self.give_back(pr);
            self.work.closed = carries;
            self.give_back_solution(sol);
            if let Some(end) = unsettled {
                self.work.end_gradients = end;
            }
            let located: Vec<u64> = {
                let ps = poses(&s.q);
                fresh
                    .iter()
                    .map(|&k| contact_rows(&contacts[k], &ps, 0.0, (0.0, 0.0)).key)
                    .collect()
            };
            // The sub-step to the impact instant, without the located points. Its motion is not
            // the free trial's (measured: a light plank just struck by a heavy block, whose
            // corner the trial closed at 3.1e-4 s, went 1.4 mm through the ground by then), so
            // a located point found through its face at its end halves the instant; from the
            // earlier instant reached, the points are located again (they are not at their
            // faces there: an impact on them would stop the bodies in the air). Halved down to
            // nothing, the impact is at the start.
            let found = tau;
            let mut tau = tau;
            let start = s.clone();
            let mut reached = false;
            while tau > 1e-9 * h {
                // Its end velocity is settled only when it is kept (no point through its face).
                let (mut first, pr, first_closed) = self.sub_step(s, &free, tau, false)?;
                let through = self.passed_through(&start, s, &contacts, &fresh);
                if !through {
                    let end = std::mem::take(&mut self.work.end_gradients);
                    let settled = self.settle_kept(s, &free, &end, &first_closed, &pr, &mut first);
                    self.work.end_gradients = end;
                    settled?;
                }
                iterations += first.iterations;
                self.give_back_solution(first);
                closed_keys_into(&pr, &first_closed, &mut self.loaded);
                self.give_back(pr);
                if !through {
                    reached = true;
                    break;
                }
                *s = start.clone();
                tau *= 0.5;
                self.halved_instants += 1;
            }
            if reached && tau < found {
                self.split_steps += 1;
                contacts = self.detect_waking(s);
                continue;
            }
            let at = self.detect_waking(s);
            iterations += self
                .impact(s, &at, &located)
                .map_err(|failure| StepError::Solver {
                    step: s.step + 1,
                    t: s.t,
                    failure,
                })?;
            located_here.extend(&located);
            self.struck.extend(&located);
            self.struck.sort_unstable();
            self.struck.dedup();
            self.loaded.extend(&located);
            self.loaded.sort_unstable();
            self.loaded.dedup();
            self.split_steps += 1;
            contacts = self.detect_waking(s);
        }
        unreachable!("the last round returns")
    }

    /// Impacts located per island (`native.island_impacts`): after the ordinary step of the
    /// whole scene found new impacts (`fresh`, indices into `contacts`), each island of
    /// touching blocks that holds one goes on alone from its part of the ordinary step
    /// (`step_locating` on its own blocks and points, handed that part as its first sub-step);
    /// every other island keeps its ordinary step, which is its exact step (the step problem
    /// is separable over islands). So an island's step is split at its own impact instants
    /// only, whatever else the scene holds. `s` holds the ordinary step on entry and the step
    /// on return. Returns `None` (nothing done) when the islands with impacts are all the
    /// islands with contact points.
    fn locate_per_island(
        &mut self,
        s: &mut NativeState,
        start: Start,
        contacts: &[ContactPoint],
        fresh: &[usize],
        ordinary: Ordinary,
    ) -> Result<Option<StepSolution>, StepError> {
        let n = self.bodies.len();
        let island = super::islands::components(n, &ordinary.problem.contacts);
        let hit = super::islands::holding(&island, fresh.iter().map(|&k| contacts[k].b));
        if hit.iter().all(|&h| h) {
            return Ok(None);
        }
        let in_hit = |b: usize| island[b].is_some_and(|i| hit[i]);
        let mut sol = ordinary.solution.clone();
        if let Some(end) = ordinary.unsettled {
            // The islands without an impact keep their ordinary step: their end velocity is
            // settled here (the others settle theirs once they keep it, as they would alone).
            let keeping: Vec<bool> = (ordinary.closed.iter().zip(contacts))
                .map(|(&closed, c)| closed && !in_hit(c.b))
                .collect();
            self.settle_kept(s, contacts, end, &keeping, ordinary.problem, &mut sol)?;
        }
        // A point's key holds one of its blocks (`assembly::contact_key`), which is in the
        // point's island.
        let block_of_key = |key: u64| ((key >> 16) & 0xFF_FFFF) as usize;
        let mut loaded: Vec<u64> = closed_keys(ordinary.problem, ordinary.closed)
            .into_iter()
            .filter(|&key| !in_hit(block_of_key(key)))
            .collect();
        let mut last: Vec<ContactPoint> =
            contacts.iter().filter(|c| !in_hit(c.b)).copied().collect();
        // The acceleration of the ordinary step: the predictor of the free trial that follows.
        let after = self.accel.clone();
        let mut accel = after.clone();
        // The last step's struck points; after this one, those struck in it (by islands).
        let struck_before = std::mem::take(&mut self.struck);
        let mut struck = Vec::new();
        let (pr, whole) = (ordinary.problem, ordinary.solution);
        for i in (0..hit.len()).filter(|&i| hit[i]) {
            let blocks: Vec<usize> = (0..n).filter(|&b| island[b] == Some(i)).collect();
            let mine: Vec<usize> = (0..contacts.len())
                .filter(|&k| island[contacts[k].b] == Some(i))
                .collect();
            let points: Vec<ContactPoint> = mine.iter().map(|&k| contacts[k]).collect();
            let taken = Taken {
                state: s.clone(),
                solution: StepSolution {
                    dq: whole.dq.clone(),
                    normal: mine.iter().map(|&k| whole.normal[k]).collect(),
                    tangential: mine.iter().map(|&k| whole.tangential[k]).collect(),
                    // Counted with the whole step's.
                    iterations: 0,
                    polished: false,
                },
                problem: StepProblem {
                    theta: pr.theta,
                    dt: pr.dt,
                    mass: pr.mass.clone(),
                    force: pr.force.clone(),
                    v0: pr.v0.clone(),
                    contacts: mine.iter().map(|&k| pr.contacts[k].clone()).collect(),
                },
                closed: mine.iter().map(|&k| ordinary.closed[k]).collect(),
                unsettled: ordinary
                    .unsettled
                    .map(|end| mine.iter().map(|&k| end[k]).collect()),
            };
            let mut alone = start.state.clone();
            self.accel.copy_from_slice(&after);
            self.loaded.clear();
            self.loaded.extend_from_slice(start.loaded);
            self.struck.clone_from(&struck_before);
            self.scope = Some(blocks);
            let run = self.step_locating(&mut alone, points, start.dt, Some(taken));
            let blocks = self.scope.take().expect("set above");
            sol.iterations += run?.iterations;
            for b in blocks {
                let d = 3 * b..3 * b + 3;
                s.q[d.clone()].copy_from_slice(&alone.q[d.clone()]);
                s.v[d.clone()].copy_from_slice(&alone.v[d.clone()]);
                accel[d.clone()].copy_from_slice(&self.accel[d]);
            }
            loaded.append(&mut self.loaded);
            struck.append(&mut self.struck);
            last.append(&mut self.last_contacts);
            self.island_steps += 1;
        }
        loaded.sort_unstable();
        loaded.dedup();
        self.loaded = loaded;
        struck.sort_unstable();
        self.struck = struck;
        self.accel = accel;
        self.last_contacts = last;
        Ok(Some(sol))
    }

    /// Whether one of the `fresh` points (detected at `s0`) is through its face, by more than
    /// `PENETRATION_TOLERANCE`, at `s1`.
    fn passed_through(
        &self,
        s0: &NativeState,
        s1: &NativeState,
        contacts: &[ContactPoint],
        fresh: &[usize],
    ) -> bool {
        let ps = poses(&s0.q);
        let dq: Vec<f64> = s1.q.iter().zip(&s0.q).map(|(a, b)| a - b).collect();
        let increment = Increment::new(&dq, 1.0);
        fresh.iter().any(|&k| {
            let c = &contacts[k];
            let mut g = MaterialContact::new(c, &ps).gaps(&increment).0;
            if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
                let dd = (s1.ground_d.0 - s0.ground_d.0, s1.ground_d.1 - s0.ground_d.1);
                g -= c.normal.0 * dd.0 + c.normal.1 * dd.1;
            }
            g < -PENETRATION_TOLERANCE
        })
    }

    /// The instant within a sub-step of length `h` from `s0` at which the first of the `fresh`
    /// points closes, from the free trial's end state `s1` (see `step_locating`).
    fn closing_instant(
        &self,
        s0: &NativeState,
        s1: &NativeState,
        contacts: &[ContactPoint],
        fresh: &[usize],
        h: f64,
    ) -> Option<f64> {
        let ps = poses(&s0.q);
        let dq: Vec<f64> = s1.q.iter().zip(&s0.q).map(|(a, b)| a - b).collect();
        let mut tau: Option<f64> = None;
        let increment = Increment::new(&dq, 1.0);
        for &k in fresh {
            let c = &contacts[k];
            let r = contact_rows(c, &ps, 0.0, (0.0, 0.0));
            let vn0 = self.normal_speed(c, &r.nrow, &s0.v, s0.ground_w);
            // The gap within the step, `g0 + vn0 tau + c2 tau^2`, through the point's exact gap
            // at the end of the free trial (local error O(h^3) whatever the motion).
            let mut g1 = MaterialContact::new(c, &ps).gaps(&increment).0;
            if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
                let dd = (s1.ground_d.0 - s0.ground_d.0, s1.ground_d.1 - s0.ground_d.1);
                g1 -= c.normal.0 * dd.0 + c.normal.1 * dd.1;
            }
            // A point that left its face from within `CLOSED_GAP` of it closes where it
            // comes back to the face, not where it crosses a round-off penetration.
            let g0 = c.gap.max(0.0);
            let c2 = (g1 - g0 - vn0 * h) / (h * h);
            if let Some(t) = first_root(g0, vn0, c2, h) {
                tau = Some(tau.map_or(t, |x: f64| x.min(t)));
            }
        }
        tau
    }

    /// A plastic impact at the current instant: the velocities jump to the closest ones (in
    /// the kinetic-energy norm) that satisfy the velocity-level law `(n ± mu t)·v >= 0` on
    /// every closed point (gap below `PENETRATION_TOLERANCE`) and on the located points:
    /// `min 1/2 (v - v-)' M (v - v-)` s.t. those rows, which is the step problem with
    /// theta = dt = 1, no force, `v0 = v-` and the ground's velocity in place of its increment.
    /// Positions do not change. Returns the solver iterations.
    fn impact(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        located: &[u64],
    ) -> Result<u32, SolveFailure> {
        let ps = poses(&s.q);
        let w = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let mut pr = self.spare_problem();
        pr.contacts.clear();
        pr.contacts.extend(
            contacts
                .iter()
                .map(|c| {
                    let mut r = contact_rows(c, &ps, self.bodies.friction(c), w);
                    r.g_n -= c.gap;
                    (c.gap, r)
                })
                .filter(|(gap, r)| *gap <= CLOSED_GAP || located.contains(&r.key))
                .map(|(_, r)| r),
        );
        if pr.contacts.is_empty() {
            self.give_back(pr);
            return Ok(0);
        }
        let iterations = self.closest_admissible_velocity(s, pr, self.settings.friction_law)?;
        self.iterations += iterations as u64;
        Ok(iterations)
    }

    /// The velocities become the closest ones (kinetic-energy norm) that satisfy the
    /// velocity-level law `(n ± mu t)·v >= 0` on the rows of `pr.contacts`: the step problem
    /// with theta = dt = 1, no force and `v0 = v` (set here), under the friction law `law`.
    /// Positions do not change. Returns the solver iterations.
    fn closest_admissible_velocity(
        &mut self,
        s: &mut NativeState,
        mut pr: StepProblem,
        law: FrictionLaw,
    ) -> Result<u32, SolveFailure> {
        pr.theta = 1.0;
        pr.dt = 1.0;
        pr.mass.clone_from(&self.bodies.mass);
        pr.force.clear();
        pr.force.resize(s.v.len(), 0.0);
        pr.v0.clone_from(&s.v);
        let mut sol = self.spare_solution();
        let solved = match law {
            FrictionLaw::Associative => self.velocity_solver.solve_into(&pr, &mut sol),
            FrictionLaw::Coulomb => self
                .coulomb
                .solve(self.velocity_solver.as_mut(), &pr)
                .map(|coulomb| sol = coulomb),
        };
        self.give_back(pr);
        solved?;
        s.v.copy_from_slice(&sol.dq);
        let iterations = sol.iterations;
        self.give_back_solution(sol);
        Ok(iterations)
    }

    /// Advance by `h` from the given contacts. `kept`: whether the sub-step's end state is
    /// known to be kept. A kept one settles its end velocity (impact stepper) and projects out
    /// a penetration (impact stepper without impact location). `step_locating` passes `false`
    /// for the sub-steps whose end it may throw away (the ordinary sub-step and the sub-step to
    /// an impact instant, both until their end positions are judged; the free trial always):
    /// their end velocity, a whole-island velocity problem, is settled
    /// (`settle_velocity`) only once they are kept, from the end gradients this call
    /// leaves in `self.work.end_gradients`.
    /// Returns the step's solution, its problem and, under the impact stepper, which of its
    /// points end closed ([`closed`]; empty under the paper's).
    fn sub_step(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        h: f64,
        kept: bool,
    ) -> Result<(StepSolution, StepProblem, Vec<bool>), StepError> {
        let mut pr = self.spare_problem();
        let mut ps = std::mem::take(&mut self.work.poses);
        poses_into(&s.q, &mut ps);
        let g = self.problem(s, contacts, h, &ps, &mut pr);
        let fail = |failure| StepError::Solver {
            step: s.step + 1,
            t: s.t,
            failure,
        };
        let impact = self.settings.stepper == StepperKind::Impact;
        let solved = if impact {
            self.solve_discrete_gradient(s, contacts, &ps, &mut pr, h)
        } else {
            // The paper's stepper locates no impacts: nothing asks which points end closed.
            let mut sol = self.spare_solution();
            self.solve_law_into(&pr, &mut sol)
                .map(|()| (sol, Vec::new(), 0.0))
        };
        self.work.poses = ps;
        let (mut sol, ends_closed, drift) = solved.map_err(fail)?;
        if drift > CONVERGED_DRIFT {
            self.give_back_solution(sol);
            self.give_back(pr);
            return Err(StepError::Unconverged {
                step: s.step + 1,
                t: s.t,
                h,
                drift,
            });
        }
        let th = self.kinematic_weight();
        for i in 0..s.q.len() {
            let v = (sol.dq[i] / h - (1.0 - th) * s.v[i]) / th;
            if impact {
                self.accel[i] = (v - s.v[i]) / h;
            }
            s.v[i] = v;
            s.q[i] += sol.dq[i];
        }
        s.ground_d.0 += g.dd.0;
        s.ground_d.1 += g.dd.1;
        s.ground_w = g.w1;
        s.t += h;
        self.iterations += sol.iterations as u64;
        self.polished_steps += sol.polished as u64;
        if impact && kept {
            let end = std::mem::take(&mut self.work.end_gradients);
            let settled = self.settle_kept(s, contacts, &end, &ends_closed, &pr, &mut sol);
            self.work.end_gradients = end;
            settled?;
        }
        if kept && impact && !self.settings.locate_impacts {
            self.project_out_penetration(s)
                .map_err(|failure| StepError::Solver {
                    step: s.step + 1,
                    t: s.t,
                    failure,
                })?;
        }
        if !s.q.iter().chain(&s.v).all(|x| x.is_finite()) {
            return Err(StepError::NonFinite {
                step: s.step + 1,
                t: s.t,
            });
        }
        Ok((sol, pr, ends_closed))
    }

    /// The impact stepper's solve: the rows of every point are the discrete gradients of its gap
    /// functions between `q0` and a predicted end of the step (`native::material`), first from
    /// the last smooth acceleration, `q1 = q0 + h v0 + h^2 a/2`, then from each solution, until
    /// the loaded points' gaps at the solution's end agree with the rows to `DRIFT_TOLERANCE`
    /// (at most `DISCRETE_GRADIENT_SOLVES` solves; every one conserves energy exactly, the
    /// iteration only removes the drift of the closed contacts). The closed points' gradients
    /// at the end are left in `self.work.end_gradients` (for `settle_velocity`).
    fn solve_discrete_gradient(
        &mut self,
        s: &NativeState,
        contacts: &[ContactPoint],
        ps: &[Pose],
        pr: &mut StepProblem,
        h: f64,
    ) -> Result<(StepSolution, Vec<bool>, f64), SolveFailure> {
        let mut points = std::mem::take(&mut self.work.points);
        points.clear();
        points.extend(contacts.iter().map(|c| MaterialContact::new(c, ps)));
        let mut dq = std::mem::take(&mut self.work.dq);
        dq.clear();
        dq.extend((0..s.q.len()).map(|i| h * s.v[i] + 0.5 * h * h * self.accel[i]));
        let mut carries = std::mem::take(&mut self.work.closed);
        let mut islands = std::mem::take(&mut self.work.islands);
        let solved = self.iterate_discrete_gradient(
            contacts,
            &points,
            &mut dq,
            &mut carries,
            &mut islands,
            pr,
        );
        self.work.islands = islands;
        self.work.points = points;
        self.work.dq = dq;
        solved.map(|(sol, drift)| (sol, carries, drift))
    }

    /// `solve_discrete_gradient`'s iteration from the predicted increment `dq`; `carries`
    /// receives which points end closed; `islands` is working storage. Returns the last
    /// solution and its drift (m: how far the points its rows hold miss their faces).
    fn iterate_discrete_gradient(
        &mut self,
        contacts: &[ContactPoint],
        points: &[MaterialContact],
        dq: &mut [f64],
        carries: &mut Vec<bool>,
        islands: &mut Islands,
        pr: &mut StepProblem,
    ) -> Result<(StepSolution, f64), SolveFailure> {
        let mut iterations = 0;
        // Once some islands' points stop drifting, only the others are solved again (the
        // problem is separable over islands): an island's solves are those it needs alone.
        // `iterating`: `islands.held` marks the islands solved again (found once, when first
        // needed).
        let mut found = false;
        let mut iterating = false;
        let mut last: Option<StepSolution> = None;
        for solve in 1..=DISCRETE_GRADIENT_SOLVES {
            let of = |k: usize| {
                islands
                    .components
                    .island()
                    .get(contacts[k].b)
                    .copied()
                    .flatten()
            };
            let solved_again = |k: usize| !iterating || of(k).is_some_and(|i| islands.held[i]);
            {
                let (whole, half) = (Increment::new(dq, 1.0), Increment::new(dq, 0.5));
                for (k, (r, m)) in pr.contacts.iter_mut().zip(points).enumerate() {
                    if solved_again(k) {
                        m.set_rows(r, &whole, &half, &self.bodies.mass);
                    }
                }
            }
            let mut sol = match (iterating, last.take()) {
                (true, Some(mut sol)) => {
                    let again: Vec<usize> =
                        (0..contacts.len()).filter(|&k| solved_again(k)).collect();
                    let part = self.solve_law(&StepProblem {
                        theta: pr.theta,
                        dt: pr.dt,
                        mass: pr.mass.clone(),
                        force: pr.force.clone(),
                        v0: pr.v0.clone(),
                        contacts: again.iter().map(|&k| pr.contacts[k].clone()).collect(),
                    })?;
                    for (b, i) in islands.components.island().iter().enumerate() {
                        if i.is_some_and(|i| islands.held[i]) {
                            sol.dq[3 * b..3 * b + 3].copy_from_slice(&part.dq[3 * b..3 * b + 3]);
                        }
                    }
                    for (l, &k) in again.iter().enumerate() {
                        sol.normal[k] = part.normal[l];
                        sol.tangential[k] = part.tangential[l];
                    }
                    sol.iterations = part.iterations;
                    sol.polished |= part.polished;
                    sol
                }
                (_, unused) => {
                    if let Some(sol) = unused {
                        self.give_back_solution(sol);
                    }
                    let mut sol = self.spare_solution();
                    self.solve_law_into(pr, &mut sol)?;
                    sol
                }
            };
            iterations += sol.iterations;
            dq.copy_from_slice(&sol.dq);
            closed_into(pr, &sol, self.settings.friction_law, carries);
            let whole = Increment::new(dq, 1.0);
            // The drift of the points that carry a force, and of the unloaded ones that end
            // closed or through their face: the rows of those were built at the predicted
            // end, which the solution may have left (a light plank struck in the sub-step).
            // The carrying points' gradients at the end are kept for `settle_velocity`.
            let mut drifts = std::mem::take(&mut self.work.drifts);
            let mut end = std::mem::take(&mut self.work.end_gradients);
            drifts.clear();
            end.clear();
            for (k, m) in points.iter().enumerate() {
                let (dn, dt) = if carries[k] {
                    let (increments, gradients) = m.increments_and_gradients(&whole);
                    end.push(gradients);
                    increments
                } else {
                    end.push(NO_GRADIENTS);
                    m.increments(&whole)
                };
                let closes = contacts[k].gap + dn < CLOSED_GAP;
                let r = &pr.contacts[k];
                let dn = dn - row_dot(&r.nrow, dq);
                let dt = dt - row_dot(&r.trow, dq);
                drifts.push(if carries[k] || closes {
                    dn.abs().max(dt.abs())
                } else {
                    0.0
                });
            }
            self.work.end_gradients = end;
            let worst = drifts.iter().copied().fold(0.0f64, f64::max);
            if worst <= DRIFT_TOLERANCE || solve == DISCRETE_GRADIENT_SOLVES {
                self.work.drifts = drifts;
                self.gradient_solves += solve as u64;
                sol.iterations = iterations;
                return Ok((sol, worst));
            }
            if self.bodies.len() == 1 {
                // One island: solved again whole.
                self.work.drifts = drifts;
                last = Some(sol);
                continue;
            }
            if !found {
                islands.components.find(self.bodies.len(), &pr.contacts);
                found = true;
            }
            holding_into(
                islands.components.island(),
                (0..contacts.len())
                    .filter(|&k| drifts[k] > DRIFT_TOLERANCE)
                    .map(|k| contacts[k].b),
                &mut islands.held,
            );
            self.work.drifts = drifts;
            iterating = islands.held.contains(&false);
            last = Some(sol);
        }
        unreachable!("the last solve returns")
    }

    /// `settle_velocity` for a kept sub-step (`sol`, its problem `pr`; `end`, `closed`: its end
    /// gradients and which points ended closed), its iterations counted in `sol` and
    /// `self.iterations`.
    fn settle_kept(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        end: &[(Gradient, Gradient, usize)],
        closed: &[bool],
        pr: &StepProblem,
        sol: &mut StepSolution,
    ) -> Result<(), StepError> {
        let settled = self.settle_velocity(s, contacts, end, closed, pr, sol)?;
        self.iterations += settled as u64;
        sol.iterations += settled;
        Ok(())
    }

    /// The end velocity of an impact-stepper sub-step, `v = 2 dq/h - v0` (`h = pr.dt`), made
    /// admissible on the points that end closed (`carries`): when some `(n ± mu t)·v` (rows at
    /// the end configuration) approaches by more than `VELOCITY_TOLERANCE`, `v` becomes its
    /// closest admissible velocity in the kinetic-energy norm (Moreau's plastic law; kinetic
    /// energy can only drop). Without it the mean-velocity law would leave the end velocity
    /// ringing, `v = -v0`, after a contact sticks or closes. On a smooth motion along a contact
    /// the change is O(h^3) a step. Returns the solver iterations; a solver failure is an error
    /// naming the step.
    fn settle_velocity(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        end: &[(Gradient, Gradient, usize)],
        carries: &[bool],
        pr: &StepProblem,
        sol: &StepSolution,
    ) -> Result<u32, StepError> {
        let w = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let coulomb = self.settings.friction_law == FrictionLaw::Coulomb;
        if !coulomb
            && !approaches(
                contacts,
                end,
                carries,
                w,
                &s.v,
                |c| self.bodies.friction(c),
                pr.dt,
            )
        {
            // Nothing to settle (most steps of a standing or slowly moving scene): no rows built.
            return Ok(0);
        }
        let mut settling = self.spare_problem();
        let rows = &mut settling.contacts;
        rows.clear();
        // Coulomb: per body pair, the sum of its stopping points' tangential rows and offsets.
        let mut stuck: Vec<((Option<usize>, usize), ContactRows, usize)> = Vec::new();
        let mut worst = 0.0f64;
        // How far each row's point approaches (for the islands that need settling; one block
        // is one island).
        let several = self.bodies.len() > 1;
        let mut approach = std::mem::take(&mut self.approach);
        approach.clear();
        for (k, ((c, g), l)) in contacts.iter().zip(end).zip(carries).enumerate() {
            if !*l {
                continue;
            }
            let mu = self.bodies.friction(c);
            let (g_n, g_t) = ground_offsets(c, w);
            let (gn, gt, len) = g;
            let len = *len;
            // The velocity-level rows: `(n ± mu t)·(v - w) >= 0`.
            let mut r = ContactRows {
                key: contact_key(c),
                mu,
                g_n,
                g_t,
                nrow: SparseRow::from_slice(&gn[..len]),
                trow: SparseRow::from_slice(&gt[..len]),
            };
            let (vn, vt) = end_relative_velocity(c, g, w, &s.v);
            if !coulomb {
                let a = mu * vt.abs() - vn;
                worst = worst.max(a);
                rows.push(r);
                if several {
                    approach.push(a);
                }
                continue;
            }
            // Coulomb. A point that did not slip in the step (judged by its slip, not its
            // force: a face's friction is shared between its points in any proportion) is
            // settled as under the associative law, so that the two laws agree where nothing
            // slides. A point that slid keeps its normal row only (no lift); if its end velocity
            // reverses its slip, the slip stopped within the step (friction never reverses one):
            // it stops, no relative velocity either way (held below, by body pair).
            let step_row = &pr.contacts[k];
            let slip = step_row.g_t + row_dot(&step_row.trow, &sol.dq);
            if slip.abs() <= COULOMB_TOLERANCE {
                let a = mu * vt.abs() - vn;
                worst = worst.max(a);
                rows.push(r);
                if several {
                    approach.push(a);
                }
            } else if vt * slip < 0.0 {
                let a = vn.abs().max(vt.abs());
                worst = worst.max(a);
                let pair = (c.a, c.b);
                match stuck.iter_mut().find(|(p, _, _)| *p == pair) {
                    Some((_, t, count)) => {
                        add_tangential(t, &r);
                        *count += 1;
                    }
                    None => stuck.push((pair, r.clone(), 1)),
                }
                rows.extend(equal_to_zero(r.key, r.g_n, &r.nrow, 1.0));
                if several {
                    approach.extend([a, a]);
                }
            } else {
                worst = worst.max(-vn);
                r.mu = 0.0;
                rows.push(r);
                if several {
                    approach.push(-vn);
                }
            }
        }
        // No relative tangential velocity of a body pair's stopping points, on average (the
        // points' own rows are dependent on a face).
        for (_, t, count) in stuck {
            rows.extend(equal_to_zero(
                t.key | 1 << 62,
                t.g_t,
                &t.trow,
                1.0 / count as f64,
            ));
        }
        if several && worst * pr.dt > VELOCITY_TOLERANCE {
            let mut islands = std::mem::take(&mut self.work.islands);
            keep_islands_that_approach(self.bodies.len(), rows, &approach, pr.dt, &mut islands);
            self.work.islands = islands;
        }
        self.approach = approach;
        if worst * pr.dt <= VELOCITY_TOLERANCE {
            self.give_back(settling);
            return Ok(0);
        }
        self.settled_velocities += 1;
        // Under Coulomb too the rows are solved as they are: each carries its own friction.
        self.closest_admissible_velocity(s, settling, FrictionLaw::Associative)
            .map_err(|failure| StepError::Solver {
                step: s.step + 1,
                t: s.t,
                failure,
            })
    }

    /// The velocity-level law leaves a penetration of up to `(1 - theta) dt |v_n|` at an
    /// impact. When a point penetrates deeper than `PENETRATION_TOLERANCE`, the positions
    /// are projected back onto the admissible set, velocities untouched. The kinetic energy is
    /// kept, but pushing a block out lifts it: the projection adds the weight times the lift
    /// (measured on random walls set moving, `tests/proptest_assemblies.rs`: up to 2.3e-7 of
    /// `sum m g H` a projection, penetrations of 1e-8 to 4e-5 m), an error of the first order
    /// in `dt` like the instants of impacts at step ends:
    /// `min 1/2 dq' M dq  s.t.  g + (nrow ± mu trow) dq >= 0`, which is the step problem with
    /// theta = dt = 1, no force and no velocity.
    fn project_out_penetration(&mut self, s: &mut NativeState) -> Result<(), SolveFailure> {
        let contacts = self.detect(s);
        if contacts.iter().all(|c| c.gap >= -PENETRATION_TOLERANCE) {
            return Ok(());
        }
        let ps = poses(&s.q);
        let pr = StepProblem {
            theta: 1.0,
            dt: 1.0,
            mass: self.bodies.mass.clone(),
            force: vec![0.0; s.q.len()],
            v0: vec![0.0; s.q.len()],
            contacts: contacts
                .iter()
                .map(|c| contact_rows(c, &ps, self.bodies.friction(c), (0.0, 0.0)))
                .collect(),
        };
        let sol = self.projection_solver.solve(&pr)?;
        for (q, d) in s.q.iter_mut().zip(&sol.dq) {
            *q += d;
        }
        self.projections += 1;
        let gained: f64 = (0..self.bodies.len())
            .map(|i| self.bodies.mass[3 * i + 1] * self.gravity * sol.dq[3 * i + 1])
            .sum();
        self.projected_energy += gained.max(0.0);
        Ok(())
    }

    /// Solve a step problem under the configured friction law.
    fn solve_law(&mut self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let mut out = StepSolution::default();
        self.solve_law_into(pr, &mut out)?;
        Ok(out)
    }

    /// [`Stepper::solve_law`] into `out`.
    fn solve_law_into(
        &mut self,
        pr: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        match self.settings.friction_law {
            FrictionLaw::Associative => self.solver.solve_into(pr, out),
            FrictionLaw::Coulomb => {
                *out = self.coulomb.solve(self.solver.as_mut(), pr)?;
                Ok(())
            }
        }
    }

    /// Block states relative to the ground: (x, z, phi, vx, vz, omega) per block.
    pub fn relative_states(&self, s: &NativeState) -> Vec<[f64; 6]> {
        let (dx, dz, wx, wz) = match self.applied_as {
            AppliedAs::MovingGround => (s.ground_d.0, s.ground_d.1, s.ground_w.0, s.ground_w.1),
            AppliedAs::InertialForces => (0.0, 0.0, 0.0, 0.0),
        };
        (0..self.bodies.len())
            .map(|i| {
                [
                    s.q[3 * i] - dx,
                    s.q[3 * i + 1] - dz,
                    s.q[3 * i + 2],
                    s.v[3 * i] - wx,
                    s.v[3 * i + 1] - wz,
                    s.v[3 * i + 2],
                ]
            })
            .collect()
    }
}
