//! The native engine's method: the theta-method with a contact QP per step.
//!
//! See [`stepper`] for the step, [`problem`] for the QPs, [`solver`] for the back-ends and
//! [`settings`] for the `[native]` table.

pub mod assembly;
pub mod coulomb;
pub mod problem;
pub mod settings;
pub mod solver;
pub mod stepper;

pub use problem::{StepProblem, StepSolution};
pub use settings::{Formulation, FrictionLaw, Kinematics, NativeSettings, SolverKind, StepperKind};
pub use stepper::{NativeState, StepError, Stepper};

use crate::excitation::GroundMotion;
use crate::scene::{Scene, SceneError};

/// A stepper and its initial state for a scene.
pub fn stepper_for(scene: &Scene) -> Result<(Stepper, NativeState), SceneError> {
    let motion = GroundMotion::from_scene(scene)?;
    let applied_as = scene
        .excitation
        .as_ref()
        .map(|e| e.applied_as)
        .unwrap_or_default();
    let bodies = assembly::Bodies::of(scene);
    let solver = solver::solver_for(&scene.native);
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
        Stepper::new(
            scene.native.clone(),
            bodies,
            scene.gravity,
            motion,
            applied_as,
            solver,
        ),
        state,
    ))
}
