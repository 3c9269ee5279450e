//! Settings of the native engine (`[native]` in a scene), with documented defaults.

use crate::scene::SceneError;
use serde::{Deserialize, Serialize};

/// Which of the two dual QPs is solved each step. They give the same step.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Formulation {
    /// Displacement-based QP in the increments `dq` (3 variables per block).
    #[default]
    Primal,
    /// Force-based QP in the contact forces `(N, T)` (2 variables per contact point).
    Dual,
}

/// The contact law in time (see `native::stepper` and docs/method.md).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum StepperKind {
    /// The paper's scheme (`paper`; the older name `position` is accepted): the theta-method
    /// with the position-level law on every contact point. The step that closes a contact
    /// rebounds by about `(1 - theta)/theta`, which makes stocky blocks rebound spuriously;
    /// first order. Kept for the runs that reproduce the paper.
    #[serde(alias = "position")]
    Paper,
    /// Impact-consistent and second order: midpoint kinematics, contact rows as
    /// discrete gradients of the contact points' gap functions over the step (a closed contact
    /// neither drifts nor works), impacts located within the step and plastic there (Moreau's
    /// law, Housner's restitution on a sticking corner). Without excitation energy grows only by
    /// the position projections of impacts not located (`locate_impacts = false`, or left over
    /// by `located_per_step`), first order in dt and counted in the run's notes.
    /// `theta` does not enter it. The default.
    #[default]
    Impact,
}

/// The friction law of the interfaces.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FrictionLaw {
    /// The paper's associative law: `g0 + du_n >= mu |du_t|` (sliding dilates).
    #[default]
    Associative,
    /// True Coulomb (non-associative): no tension, `|T| <= mu N`, slip opposed by the friction
    /// force, no dilatancy. Solved per step as the associative problem with De Saxce's shifted
    /// gaps `g_n + mu |d_t|`, iterated on the slips (plain and secant steps) with the back-end
    /// in use, warm-started; a step that does not settle in 100 solves is an error naming it.
    /// See docs/method.md.
    Coulomb,
}

/// Which located points take a located impact together (impact-consistent stepper with
/// `locate_impacts`; see docs/method.md, "Impacts together or in turn").
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SimultaneousImpacts {
    /// Every point that closes within the rest of the step takes the impact at the first
    /// one's instant (the default): points closing within one step of each other strike
    /// together, so the rule depends on the step (a block landing almost flat, its second
    /// corner 0.09 mm up at the first one's instant, lands dead at dt 1e-3 and rocks at 1e-4).
    #[default]
    Step,
    /// Only the points at their faces at the instant (within `CLOSED_GAP` of the first to
    /// close) take it; the others are located again in later rounds and strike at their own
    /// instants. The limit of `step` as dt goes to zero; the four other engines agree with it
    /// on the almost-flat landing. Walls in motion, whose bed joints close within a step of
    /// each other, move otherwise under it and less consistently over the step.
    Instant,
}

/// Contact solver back-end.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// Clarabel interior-point QP solver (the reference back-end).
    Clarabel,
    /// Dense warm-started active-set solver (small problems), falling back to Clarabel on a
    /// step it cannot solve.
    #[serde(rename = "active-set")]
    ActiveSet,
    /// Sparse augmented-Lagrangian/semismooth-Newton solver with an envelope Cholesky factor
    /// kept while the active rows do not change (large assemblies), falling back to Clarabel
    /// on a step it cannot solve.
    Sparse,
    /// The active-set solver for problems up to 42 DOFs (14 blocks) and 28 contact points, the
    /// sparse one above (the default: on the two-block case it gives the same impacts as
    /// Clarabel, ~50x faster).
    #[default]
    Auto,
}

fn d_theta() -> f64 {
    0.7
}
fn d_dt() -> f64 {
    1e-3
}
fn d_tol() -> f64 {
    1e-10
}
fn d_max_iter() -> u32 {
    200
}
fn d_reach() -> f64 {
    0.25
}

/// `[native]` settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NativeSettings {
    /// Theta of the paper's stepper, in [0.5, 1] (default 0.7, the paper's value):
    /// `v = (dq/dt - (1 - theta) v0) / theta`. The impact stepper does not use it.
    #[serde(default = "d_theta")]
    pub theta: f64,
    /// Time step, s (default 1e-3).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// `primal` (displacement-based) or `dual` (force-based) QP (default primal).
    #[serde(default)]
    pub formulation: Formulation,
    /// `impact` (impact-consistent, second order; the default) or `paper` (the paper's
    /// theta-method with the position-level law; `position` is accepted for it).
    #[serde(default)]
    pub stepper: StepperKind,
    /// Impact-consistent stepper only: locate the instant within a step at which a new contact
    /// closes and apply the plastic impact there (sub-step, impact, rest of the step) rather
    /// than at the end of the step (default true; see `native::stepper` and docs/method.md).
    /// Ignored by the position-level stepper.
    #[serde(default = "d_true")]
    pub locate_impacts: bool,
    /// Impact-consistent stepper with `locate_impacts`: a new contact approaching slower than
    /// this (m/s; its speed at the start of the step or the mean speed that closes its gap
    /// within the step, whichever is larger) is not located: it closes at the end of the step
    /// under the position-level row and the plastic end velocity (default 0: every new contact
    /// is located; see docs/method.md).
    #[serde(default)]
    pub locate_speed: f64,
    /// Impact-consistent stepper with `locate_impacts`: an impact splits the step of its own
    /// island of touching blocks only (default true); the other islands keep the ordinary
    /// step. Off, every located impact splits the step of the whole scene, so that one
    /// object's steps depend on the impacts of every other (see docs/method.md, "Impacts
    /// located per island"). Ignored with `sleep`.
    #[serde(default = "d_true")]
    pub island_impacts: bool,
    /// Impact-consistent stepper with `locate_impacts`: the most impacts located within one
    /// step of an island (default 8, at least 1). A step whose impacts come in more rounds than
    /// this (a wall in motion, where hundreds of joints close a step) leaves the rest to its
    /// ordinary end: each round re-solves the impacting island some ten times (see
    /// docs/method.md, "Located impacts a step"). A run's notes count the steps that reached it
    /// and the impacts they left.
    #[serde(default = "d_located_per_step")]
    pub located_per_step: u32,
    /// Impact-consistent stepper with `locate_impacts`: `step` (default) or `instant`, which
    /// located points take an impact together (see `SimultaneousImpacts`).
    #[serde(default)]
    pub simultaneous_impacts: SimultaneousImpacts,
    /// `associative` (the paper's law, default) or `coulomb` (non-associative).
    #[serde(default)]
    pub friction_law: FrictionLaw,
    /// Contact solver back-end: `auto` (default), `active-set` or `clarabel`.
    #[serde(default)]
    pub solver: SolverKind,
    /// Clarabel's absolute and relative duality-gap and feasibility tolerances on the scaled
    /// problem (default 1e-10).
    #[serde(default = "d_tol")]
    pub tolerance: f64,
    /// Interior-point iteration limit per step (default 200).
    #[serde(default = "d_max_iter")]
    pub max_iterations: u32,
    /// Accept Clarabel's `AlmostSolved` (reduced accuracy) status outright (default false: such
    /// a step is accepted only when the active-set polish verifies its solution, the KKT
    /// conditions to round-off, and is an error otherwise or with `polish = false`).
    #[serde(default)]
    pub accept_almost_solved: bool,
    /// Contact points are kept in the problem while their gap is below this fraction of the
    /// smaller dimension of the bodies involved, or below three times the distance their
    /// closing speed covers in one step (default 0.25). Open points further away cannot close
    /// within the step and are left out.
    #[serde(default = "d_reach")]
    pub contact_reach: f64,
    /// End the run once the excitation is over and every block has stayed still for 0.05 s
    /// (the remaining samples hold the resting state) (default false).
    #[serde(default)]
    pub stop_at_rest: bool,
    /// Certify every contact problem's solution by its duality gap (a bound on each
    /// displacement's distance from the QP's minimiser, `native::solver::certificate`) and
    /// report the largest in the run's notes (default false). The answer is the same; the run
    /// costs more (a conjugate-gradient refit of each problem's multipliers: the two-block
    /// case's run 4 times as long, the toppling 42-block wall's 3 times).
    #[serde(default)]
    pub certify: bool,
    /// Speed below which a block counts as still, m/s (rotation: omega times the block's larger
    /// dimension) (default 1e-9).
    #[serde(default = "d_rest_velocity")]
    pub rest_velocity: f64,
    /// Polish each interior-point solution on its active set (default true): takes the step
    /// from the solver tolerance to round-off. See `native::solver::polish`.
    #[serde(default = "d_true")]
    pub polish: bool,
    /// Solve the independent islands of touching blocks as separate problems, each with its
    /// own back-end (default true; see `native::islands`). The step problem is separable over
    /// islands, so this changes nothing but which back-end `auto` picks for each part (small
    /// islands go to the dense one) and the back-ends' round-off.
    #[serde(default = "d_true")]
    pub islands: bool,
    /// Put islands of blocks at rest to sleep until the excitation or a contact can move them
    /// (default false; see `native::sleep`). Only where the excitation is applied as inertial
    /// forces and has no vertical component; it zeroes speeds below `rest_velocity` of blocks
    /// that have been that still for 0.05 s and skips them while they sleep. Off by default:
    /// awake, the native engine lets some walls loaded below their static collapse
    /// acceleration start moving from round-off (docs/method.md, "Sleeping islands"), which a
    /// sleeping wall does not, so the two answers differ there.
    #[serde(default)]
    pub sleep: bool,
}

/// The largest `rest_velocity`: a block moving faster is not still (a block released tilted was
/// declared at rest, and frozen, with a threshold of 1e300 m/s).
pub const MAX_REST_VELOCITY: f64 = 1e-3;

fn d_rest_velocity() -> f64 {
    1e-9
}

fn d_true() -> bool {
    true
}

fn d_located_per_step() -> u32 {
    8
}

impl Default for NativeSettings {
    fn default() -> Self {
        NativeSettings {
            theta: d_theta(),
            dt: d_dt(),
            formulation: Formulation::default(),
            stepper: StepperKind::default(),
            friction_law: FrictionLaw::default(),
            locate_impacts: true,
            locate_speed: 0.0,
            island_impacts: true,
            located_per_step: d_located_per_step(),
            simultaneous_impacts: SimultaneousImpacts::default(),
            solver: SolverKind::default(),
            tolerance: d_tol(),
            max_iterations: d_max_iter(),
            accept_almost_solved: false,
            contact_reach: d_reach(),
            polish: true,
            islands: true,
            sleep: false,
            stop_at_rest: false,
            certify: false,
            rest_velocity: d_rest_velocity(),
        }
    }
}

impl NativeSettings {
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let e = |f: &str, m: String| Err(SceneError::new(file, format!("native.{f}"), m));
        let num = crate::scene::num;
        if !self.theta.is_finite() || !(0.5..=1.0).contains(&self.theta) {
            return e(
                "theta",
                format!("must be in [0.5, 1] (got {})", num(self.theta)),
            );
        }
        if !self.dt.is_finite() || self.dt <= 0.0 {
            return e(
                "dt",
                format!(
                    "must be a positive number of seconds (got {})",
                    num(self.dt)
                ),
            );
        }
        if !self.tolerance.is_finite() || self.tolerance <= 0.0 || self.tolerance >= 1e-2 {
            return e(
                "tolerance",
                format!("must be in (0, 1e-2) (got {})", num(self.tolerance)),
            );
        }
        if !self.rest_velocity.is_finite()
            || self.rest_velocity <= 0.0
            || self.rest_velocity > MAX_REST_VELOCITY
        {
            return e(
                "rest_velocity",
                format!(
                    "must be a positive speed of at most {MAX_REST_VELOCITY:e} m/s (a block moving faster is not still) (got {})",
                    num(self.rest_velocity)
                ),
            );
        }
        if !self.locate_speed.is_finite() || self.locate_speed < 0.0 {
            return e(
                "locate_speed",
                format!(
                    "must be a speed in m/s, zero or more (got {})",
                    num(self.locate_speed)
                ),
            );
        }
        if self.located_per_step == 0 {
            return e(
                "located_per_step",
                "must be at least 1 (`locate_impacts = false` locates none)".into(),
            );
        }
        if self.max_iterations == 0 {
            return e("max_iterations", "must be at least 1".into());
        }
        if !self.contact_reach.is_finite() || self.contact_reach <= 0.0 {
            return e(
                "contact_reach",
                format!(
                    "must be a positive fraction (got {})",
                    num(self.contact_reach)
                ),
            );
        }
        Ok(())
    }
}
