//! The native engine: the paper's theta-method with a contact QP per step.

use super::{Engine, EngineError, RunOutput};
use crate::excitation::GroundMotion;
use crate::native::stepper_for;

/// How long every block must stay still before `native.stop_at_rest` ends a run, s.
pub const REST_WINDOW: f64 = 0.05;
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
        // Rest detection: the excitation is over and every block has been still for the
        // whole window.
        let excitation_end = GroundMotion::from_scene(scene)?
            .breakpoints()
            .last()
            .copied()
            .unwrap_or(0.0);
        let window = (REST_WINDOW / dt).ceil() as u64;
        let mut still = 0u64;
        let mut stopped_at = None;
        let mut computed = n_steps;
        for k in 1..=n_steps {
            stepper.step(&mut state).map_err(|e| EngineError::Failed {
                engine: "native",
                message: e.to_string(),
            })?;
            // Step k ends at k dt exactly (no accumulated rounding in the sample times).
            state.t = k as f64 * dt;
            let states = stepper.relative_states(&state);
            if k % every == 0 || k == n_steps {
                tr.push(state.t, &states);
            }
            if scene.native.stop_at_rest && state.t > excitation_end {
                let v = scene.native.rest_velocity;
                let is_still = states.iter().zip(&scene.blocks).all(|(st, b)| {
                    st[3].abs() < v && st[4].abs() < v && (st[5] * b.width.max(b.height)).abs() < v
                });
                still = if is_still { still + 1 } else { 0 };
                if still >= window && k < n_steps {
                    // Hold the resting state for the remaining samples.
                    stopped_at = Some(state.t);
                    computed = k;
                    let at_rest: Vec<[f64; 6]> = states
                        .iter()
                        .map(|st| [st[0], st[1], st[2], 0.0, 0.0, 0.0])
                        .collect();
                    for j in k + 1..=n_steps {
                        if j % every == 0 || j == n_steps {
                            tr.push(j as f64 * dt, &at_rest);
                        }
                    }
                    break;
                }
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
            steps: computed,
            solver_iterations: Some(stepper.iterations),
            exact_impacts: None,
            notes: {
                let mut notes = vec![format!(
                    "{} steps, {} split at a located impact, {} position projections after impacts; {} solutions polished on their active set; {} steps fell back to Clarabel",
                    computed,
                    stepper.split_steps,
                    stepper.projections,
                    stepper.polished_steps,
                    stepper.solver_fallbacks()
                )];
                if let Some(t) = stopped_at {
                    notes.push(format!(
                        "every block at rest from t = {t:.4} s (speeds below {:e} m/s for {REST_WINDOW} s): the run stopped there and the rest of the trajectory holds that state",
                        scene.native.rest_velocity
                    ));
                }
                notes
            },
        })
    }
}
