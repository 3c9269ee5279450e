//! The native engine's method: the theta-method with a contact QP per step.
//!
//! See [`stepper`] for the step, [`problem`] for the QPs, [`solver`] for the back-ends and
//! [`settings`] for the `[native]` table.

pub mod assembly;
pub mod checkpoint;
pub mod collapse;
pub mod coulomb;
pub mod islands;
pub mod material;
pub mod problem;
pub mod settings;
pub mod sleep;
pub mod solver;
pub mod stepper;

pub use problem::{StepProblem, StepSolution};
pub use settings::{Formulation, FrictionLaw, NativeSettings, SolverKind, StepperKind};
pub use stepper::{NativeState, StepError, Stepper};

use crate::excitation::GroundMotion;
use crate::scene::{Scene, SceneError};

/// The scene's `[native]` table, parsed and checked: one-line errors naming
/// `native.<field>`, the time step against the duration included.
pub fn settings_of(scene: &Scene) -> Result<NativeSettings, SceneError> {
    let s: NativeSettings = scene.parse_table("native")?;
    s.validate(&scene.source)?;
    crate::scene::check_step(scene, "native.dt", s.dt)?;
    Ok(s)
}

/// A stepper and its initial state for a scene.
pub fn stepper_for(scene: &Scene) -> Result<(Stepper, NativeState), SceneError> {
    stepper_with(scene, solver::solver_for(&settings_of(scene)?))
}

/// A stepper for a scene that solves its problems with `solver` instead of the back-end its
/// settings name (a back-end wrapped for a test or a probe), and its initial state.
pub fn stepper_with(
    scene: &Scene,
    solver: Box<dyn solver::ContactSolver>,
) -> Result<(Stepper, NativeState), SceneError> {
    let settings = settings_of(scene)?;
    let motion = GroundMotion::from_scene(scene)?;
    let applied_as = scene.applied_as();
    let bodies = assembly::Bodies::of(scene);
    let layout = scene.layout();
    let q = layout
        .blocks
        .iter()
        .flat_map(|b| [b.x, b.z, b.phi])
        .collect();
    let v = layout
        .blocks
        .iter()
        .flat_map(|b| [b.vx, b.vz, b.omega])
        .collect();
    let state = NativeState {
        t: 0.0,
        step: 0,
        q,
        v,
        ground_d: (0.0, 0.0),
        ground_w: (0.0, 0.0),
    };
    Ok((
        Stepper::new(settings, bodies, scene.gravity, motion, applied_as, solver),
        state,
    ))
}
