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
pub use settings::{
    Formulation, FrictionLaw, NativeSettings, SimultaneousImpacts, SolverKind, StepperKind,
};
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

/// The slenderest block (width over height) the native engine takes: its overturning spectra
/// match Housner's closed form to the bisection's 1e-4 from B/H = 1e-2 down to 1e-4, are up to
/// 0.2 % off at 1e-5 (on the smallest block measured) and 40 % off at 1e-6 (docs/spectrum.md).
pub const MIN_SLENDERNESS: f64 = 1e-4;

/// One line naming the first block slenderer than [`MIN_SLENDERNESS`].
pub fn check_slenderness(scene: &Scene) -> Result<(), SceneError> {
    match scene
        .blocks
        .iter()
        .enumerate()
        .find(|(_, b)| b.width / b.height < MIN_SLENDERNESS)
    {
        Some((i, b)) => Err(SceneError::new(
            &scene.source,
            format!("blocks[{i}]"),
            format!(
                "`{}` is {} m wide and {} m high, B/H = {:e}: the native engine is measured down to B/H = {MIN_SLENDERNESS:e} (docs/spectrum.md); use the housner engine for a slenderer single block",
                b.name,
                crate::scene::num(b.width),
                crate::scene::num(b.height),
                b.width / b.height
            ),
        )),
        None => Ok(()),
    }
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
    check_slenderness(scene)?;
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
        ground_t: 0.0,
    };
    Ok((
        Stepper::new(settings, bodies, scene.gravity, motion, applied_as, solver),
        state,
    ))
}
