//! The native engine: the paper's theta-method with a contact QP per step.

use super::{Engine, EngineError, RunOutput};
use crate::native::stepper_for;
use crate::scene::Scene;
use crate::trajectory::Trajectory;

pub struct NativeEngine;

impl Engine for NativeEngine {
    fn name(&self) -> &'static str {
        "native"
    }

    fn run(&self, scene: &Scene) -> Result<RunOutput, EngineError> {
        let (mut stepper, mut state) = stepper_for(scene)?;
        let dt = scene.native.dt;
        let n_steps = (scene.duration / dt - 1e-9).ceil() as u64;
        let every = ((scene.output_interval / dt).round() as u64).max(1);
        let names: Vec<String> = scene.blocks.iter().map(|b| b.name.clone()).collect();
        let mut tr = Trajectory::new(&names);
        tr.push(0.0, &stepper.relative_states(&state));
        for k in 1..=n_steps {
            stepper.step(&mut state).map_err(|e| EngineError::Failed {
                engine: "native",
                message: e.to_string(),
            })?;
            if k % every == 0 || k == n_steps {
                tr.push(state.t, &stepper.relative_states(&state));
            }
        }
        let mut settings = serde_json::to_value(&scene.native).expect("settings serialise");
        if let Some(o) = settings.as_object_mut() {
            o.insert("solver_backend".into(), stepper.solver_name().into());
            o.insert(
                "applied_as".into(),
                serde_json::to_value(scene.excitation.as_ref().map(|e| e.applied_as))
                    .unwrap_or_default(),
            );
            o.insert("output_interval".into(), (every as f64 * dt).into());
        }
        Ok(RunOutput {
            trajectory: tr,
            settings,
            engine_version: format!(
                "rockbench {} (clarabel {}, nalgebra {})",
                env!("CARGO_PKG_VERSION"),
                env!("RB_VERSION_CLARABEL"),
                env!("RB_VERSION_NALGEBRA")
            ),
            steps: n_steps,
            solver_iterations: Some(stepper.iterations),
            exact_impacts: None,
            notes: vec![format!(
                "{} steps, {} split at a located impact; {} solutions polished on their active set; {} steps fell back to Clarabel",
                n_steps,
                stepper.split_steps,
                stepper.polished_steps,
                stepper.solver_fallbacks()
            )],
        })
    }
}
