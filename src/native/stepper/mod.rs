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
//!
//! This module holds the stepper, its state and a step's course (`advance`); the parts of a
//! step are its submodules: `detection` (and sleep), `step_problem` (a sub-step's rows),
//! `discrete_gradient` (the impact stepper's sub-step), `velocity` (impacts, settled end
//! velocities, projections) and `locate` (impact instants within a step).

mod detection;
mod discrete_gradient;
mod locate;
mod step_problem;
mod velocity;

use super::assembly::Bodies;
use super::coulomb::Coulomb;
use super::islands::Components;
use super::material::{Gradient, MaterialContact};
use super::problem::{StepProblem, StepSolution};
use super::settings::{FrictionLaw, NativeSettings, StepperKind};
use super::sleep::Sleep;
use super::solver::{Blob, ContactSolver, SolveFailure};
use crate::excitation::{DefinedBy, GroundMotion};
use crate::geometry::{ContactPoint, Pose};
use crate::scene::AppliedAs;
use detection::Detection;

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

#[inline]
fn row_dot(row: &[(usize, f64)], x: &[f64]) -> f64 {
    row.iter().map(|&(i, c)| c * x[i]).sum()
}

/// Working storage for the islands of a problem (`native::islands`): their components and
/// which of them a step marks.
#[derive(Default)]
struct Islands {
    components: Components,
    held: Vec<bool>,
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
    /// The instant the ground motion has been taken to: the end of the last (sub)step's ground
    /// increment, where the next one starts. A run sets `t` to `k dt` after step `k`, which
    /// can differ from the sum of the steps by a rounding; starting each ground increment here
    /// makes the increments add up to the whole motion exactly, so that a displacement
    /// record's velocity jump at a sample between the two is neither lost nor counted twice.
    pub ground_t: f64,
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
            ground_t: self.ground_t,
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
        self.ground_t = source.ground_t;
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
    /// velocity's is not a projection's). See docs/walls.md.
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
    /// Impact stepper: located impact instants found again from the sub-step to them, because
    /// a located point was through its face at its end (`INSTANT_REFINEMENTS`).
    pub refound_instants: u64,
    /// Impact stepper: located impact instants taken at the end of their step
    /// (`END_OF_STEP`).
    pub end_of_step_instants: u64,
    /// Impact stepper: steps (or parts of steps) taken again as two halves because their
    /// discrete-gradient iteration did not converge (`CONVERGED_DRIFT`).
    pub halved_steps: u64,
    /// Impact stepper under `simultaneous_impacts = "step"`: located impacts that struck a
    /// point still open at their instant (by more than `CLOSED_GAP`). Under `"instant"` such
    /// points strike at their own instants.
    pub struck_open: u64,
    /// The widest gap of the points counted in `struck_open` at their impact's instant, m.
    pub widest_struck_gap: f64,
    /// Impact stepper: steps (of the scene or of an island) that reached `located_per_step`
    /// with new impacts still to locate.
    pub capped_steps: u64,
    /// The new impacts those steps left to close at the end of their step, unlocated.
    pub capped_impacts: u64,
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
            $s.refound_instants,
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
    counters: [u64; 11],
    halved_steps: u64,
    projected_energy: f64,
    struck_open: u64,
    widest_struck_gap: f64,
    capped_steps: u64,
    capped_impacts: u64,
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
    counters: [u64; 11],
    /// Absent from the checkpoints of builds that did not halve steps.
    #[serde(default)]
    halved_steps: u64,
    /// Absent from the checkpoints of builds that did not count it.
    #[serde(default)]
    projected_energy: f64,
    #[serde(default)]
    struck_open: u64,
    #[serde(default)]
    widest_struck_gap: f64,
    #[serde(default)]
    capped_steps: u64,
    #[serde(default)]
    capped_impacts: u64,
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
            refound_instants: 0,
            end_of_step_instants: 0,
            halved_steps: 0,
            struck_open: 0,
            widest_struck_gap: 0.0,
            capped_steps: 0,
            capped_impacts: 0,
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
            struck_open: self.struck_open,
            widest_struck_gap: self.widest_struck_gap,
            capped_steps: self.capped_steps,
            capped_impacts: self.capped_impacts,
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
        self.struck_open = c.struck_open;
        self.widest_struck_gap = c.widest_struck_gap;
        self.capped_steps = c.capped_steps;
        self.capped_impacts = c.capped_impacts;
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
        let (t0, t1) = (s.ground_t, s.t + dt);
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
