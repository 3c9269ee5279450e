//! The native engine: the paper's theta-method with a contact QP per step.

use super::{Engine, EngineError, Progress, RunOutput};
use crate::excitation::GroundMotion;
use crate::native::checkpoint::{Checkpoint, Checkpointing, RunShape, SampleLog, this_build};
use crate::native::solver::Blob;
use crate::native::stepper_for;
use std::time::Instant;

/// How long every block must stay still before `native.stop_at_rest` ends a run, s.
pub const REST_WINDOW: f64 = 0.05;
use crate::scene::Scene;
use crate::trajectory::Trajectory;

pub struct NativeEngine;

impl Engine for NativeEngine {
    fn name(&self) -> &'static str {
        "native"
    }

    /// A block slenderer than the engine is measured for (`native::MIN_SLENDERNESS`).
    fn cannot_model(&self, scene: &Scene) -> Option<String> {
        crate::native::check_slenderness(scene)
            .err()
            .map(|e| format!("{}: {}", e.field, e.message))
    }

    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError> {
        self.run_checkpointed(scene, progress, None)
    }
}

impl NativeEngine {
    /// [`Engine::run_reporting`] with a checkpoint: resumed from `checkpointing.path` if the
    /// file is there (written by this build for this scene, else an error), written there
    /// every `checkpointing.interval` of wall time. The outputs are those of a run without it.
    pub fn run_checkpointed(
        &self,
        scene: &Scene,
        progress: Progress,
        checkpointing: Option<&Checkpointing>,
    ) -> Result<RunOutput, EngineError> {
        let started = Instant::now();
        let (mut stepper, mut state) = stepper_for(scene)?;
        let ns = stepper.settings.clone();
        let dt = ns.dt;
        // Whole steps of `dt`; the last one may pass the duration. The impact stepper then
        // shortens it to `last_fraction` of a step, to end at the duration. The paper's stepper
        // takes it whole and the sample at the duration is interpolated linearly within it: a
        // shortened step would not do there (the position-level law closes a gap error delta
        // within the step, at a speed delta/(theta h), so a short step injects energy); the
        // interpolation cuts the chord of a rotating corner's arc, up to r (omega dt)^2 / 8
        // below the face, which the impact stepper, which holds closed points at 1e-11 m, must
        // not have (a 6 x 47 cm block pivoting at 6.2 rad/s, dt 5e-3: 2.5e-5 m).
        let n_steps = ((scene.duration / dt - 1e-9).ceil() as u64).max(1);
        let last_fraction = (scene.duration - (n_steps - 1) as f64 * dt) / dt;
        let last_fraction = if (last_fraction - 1.0).abs() <= 1e-9 {
            1.0
        } else {
            last_fraction
        };
        let time_of = |k: u64| {
            if k == n_steps {
                scene.duration
            } else {
                k as f64 * dt
            }
        };
        let every = ((scene.output_interval / dt).round() as u64).max(1);
        let names: Vec<String> = scene.blocks.iter().map(|b| b.name.clone()).collect();
        let mut tr = Trajectory::new(&names);
        tr.push(0.0, &stepper.relative_states(&state));
        // The scene as run and the bytes of its records: a record changed between a checkpoint
        // and its resumption would splice two records into one run.
        let scene_text = checkpointing.map(|_| {
            format!(
                "{}\n{}",
                scene.to_json(),
                serde_json::Value::Object(scene.record_hashes())
            )
        });
        let mut first = 1;
        let mut still = 0u64;
        let mut wall_before = 0.0;
        let mut resumed = None;
        let mut samples = checkpointing.map(|c| SampleLog::beside(&c.path));
        if let Some(c) = checkpointing.filter(|c| c.path.exists()) {
            let io = EngineError::Io;
            let saved =
                Checkpoint::read(&c.path, scene_text.as_deref().unwrap_or_default()).map_err(io)?;
            let shape = RunShape {
                blocks: scene.blocks.len(),
                steps: n_steps,
                dt,
                sample_every: every,
            };
            saved
                .fits(shape)
                .map_err(|e| io(format!("{}: {e}", c.path.display())))?;
            stepper
                .restore(&saved.stepper.0)
                .map_err(|e| io(format!("{}: {e}", c.path.display())))?;
            tr = Trajectory::new(&names);
            if let Some(log) = samples.as_mut() {
                log.read(&mut tr, saved.samples, &saved.samples_sha256)
                    .map_err(io)?;
            }
            (state, still, wall_before) = (saved.state, saved.still, saved.wall_s);
            first = saved.steps_done + 1;
            resumed = Some((saved.steps_done, state.t));
        }
        let mut last_write = Instant::now();
        // Rest detection: the excitation is over and every block has been still for the
        // whole window.
        let excitation_end = GroundMotion::from_scene(scene)?
            .breakpoints()
            .last()
            .copied()
            .unwrap_or(0.0);
        let window = (REST_WINDOW / dt).ceil() as u64;
        let mut stopped_at = None;
        let mut computed = n_steps;
        let shorten_last = ns.stepper == crate::native::StepperKind::Impact;
        for k in first..=n_steps {
            let partial = k == n_steps && last_fraction < 1.0;
            let before = (partial && !shorten_last).then(|| stepper.relative_states(&state));
            let h = if partial && shorten_last {
                last_fraction * dt
            } else {
                dt
            };
            stepper
                .step_by(&mut state, h)
                .map_err(|e| EngineError::Failed {
                    engine: "native",
                    message: e.to_string(),
                })?;
            // Step k ends at k dt exactly (no accumulated rounding in the sample times).
            state.t = if partial && shorten_last {
                scene.duration
            } else {
                k as f64 * dt
            };
            let mut states = stepper.relative_states(&state);
            if let Some(b) = before {
                // The sample at the duration, within the last step: a convex combination of
                // its two ends, so it has no more energy than they have.
                for (s1, s0) in states.iter_mut().zip(&b) {
                    for (x1, x0) in s1.iter_mut().zip(s0) {
                        *x1 = x0 + last_fraction * (*x1 - x0);
                    }
                }
            }
            if k % every == 0 || k == n_steps {
                tr.push(time_of(k), &states);
            }
            // Asked to stop, a checkpointed run first finishes this step's bookkeeping (its
            // rest count) and writes its checkpoint below, so that it resumes after this step
            // (at its last step it has nothing left to resume: it ends).
            let interrupted = progress(time_of(k)).is_break();
            if interrupted && checkpointing.is_none() {
                return Err(EngineError::Interrupted {
                    engine: "native",
                    t: time_of(k),
                });
            }
            if ns.stop_at_rest && state.t > excitation_end {
                let v = ns.rest_velocity;
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
                            tr.push(time_of(j), &at_rest);
                        }
                    }
                    // The run is done: an answer to stop changes nothing.
                    let _ = progress(scene.duration);
                    break;
                }
            }
            if let Some(c) = checkpointing.filter(|_| k < n_steps) {
                let stop = c.stop_after_step == Some(k);
                if stop || interrupted || last_write.elapsed() >= c.interval {
                    let mut samples_sha256 = String::new();
                    if let Some(log) = samples.as_mut() {
                        log.append(&tr).map_err(EngineError::Io)?;
                        samples_sha256 = log.sha256();
                    }
                    Checkpoint {
                        build: this_build(),
                        scene: scene_text.clone().unwrap_or_default(),
                        steps_done: k,
                        still,
                        state: state.clone(),
                        stepper: Blob(stepper.save()),
                        samples: tr.len() as u64,
                        samples_sha256,
                        wall_s: wall_before + started.elapsed().as_secs_f64(),
                    }
                    .write(&c.path)
                    .map_err(EngineError::Io)?;
                    last_write = Instant::now();
                }
                if stop {
                    return Err(EngineError::Stopped {
                        step: k,
                        path: c.path.display().to_string(),
                    });
                }
                if interrupted {
                    return Err(EngineError::Suspended {
                        step: k,
                        t: state.t,
                        path: c.path.display().to_string(),
                    });
                }
            }
        }
        let mut settings = serde_json::to_value(&ns).expect("settings serialise");
        if let Some(o) = settings.as_object_mut() {
            o.insert("solver_backend".into(), stepper.solver_name().into());
            o.insert(
                "applied_as".into(),
                serde_json::to_value(scene.excitation.as_ref().map(|e| e.applied_as))
                    .unwrap_or_default(),
            );
            o.insert("output_interval".into(), (every as f64 * dt).into());
            o.insert("last_fraction".into(), last_fraction.into());
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
            valid_until: None,
            notes: {
                let mut notes = vec![format!(
                    "{} steps, {} split at a located impact, {} position projections after impacts (gaining {:.3e} J/m of potential energy); {} solutions polished on their active set; {} steps fell back to Clarabel; {} factorisations; {} rows updated into or out of a factor; {} interior-point rescues",
                    computed,
                    stepper.split_steps,
                    stepper.projections,
                    stepper.projected_energy,
                    stepper.polished_steps,
                    stepper.solver_fallbacks(),
                    stepper.solver_factorisations(),
                    stepper.solver_factor_updates(),
                    stepper.solver_rescues()
                )];
                if stepper.gradient_solves > 0 {
                    notes.push(format!(
                        "impact stepper: {} solves for the discrete-gradient rows ({:.2} a step), {} end velocities settled, {} plastic impacts at the start of a step, {} impact instants halved, {} found again from their sub-step, {} taken at the end of their step, {} island steps located apart from the others, {} steps or parts of steps halved for their rows to converge",
                        stepper.gradient_solves,
                        stepper.gradient_solves as f64 / computed.max(1) as f64,
                        stepper.settled_velocities,
                        stepper.start_impacts,
                        stepper.halved_instants,
                        stepper.refound_instants,
                        stepper.end_of_step_instants,
                        stepper.island_steps,
                        stepper.halved_steps
                    ));
                }
                if stepper.struck_open > 0 {
                    notes.push(format!(
                        "impact stepper: {} located impacts struck points still open at their instant, by up to {:.3e} m, because they close later in the same step (`native.simultaneous_impacts = \"instant\"` strikes each at its own instant; docs/method.md, \"Impacts together or in turn\")",
                        stepper.struck_open, stepper.widest_struck_gap
                    ));
                }
                if stepper.capped_steps > 0 {
                    notes.push(format!(
                        "impact stepper: {} steps (or island steps) reached `native.located_per_step` = {}, leaving {} new impacts unlocated, taken at the end of their step (first order in dt; docs/method.md, \"Located impacts a step\")",
                        stepper.capped_steps, ns.located_per_step, stepper.capped_impacts
                    ));
                }
                if let Some(c) = stepper.certified() {
                    notes.push(format!(
                        "certificates: {} step problems solved, each displacement within {:.3e} m of its QP's minimiser by the duality gap ({} bounded only above {:.0e} m, {} with a row violated; displacements up to {:.3e} m a step)",
                        c.solutions,
                        c.worst,
                        c.above,
                        crate::native::solver::certificate::REPORTED_BOUND,
                        c.violated,
                        c.largest_dq
                    ));
                }
                if stepper.coulomb.problems > 0 {
                    notes.push(format!(
                        "Coulomb friction: {} contact problems, {} back-end solves ({:.3} a problem), {} settled to the back-ends' row tolerance, {} solved by Lemke's method ({} pivots)",
                        stepper.coulomb.problems,
                        stepper.coulomb.iterations,
                        stepper.coulomb.iterations as f64 / stepper.coulomb.problems as f64,
                        stepper.coulomb.roundoff_settles,
                        stepper.coulomb.lemke_solves,
                        stepper.coulomb.lemke_pivots
                    ));
                }
                if ns.sleep && stepper.sleep.is_none() {
                    notes.push(
                        "native.sleep: off for this scene (blocks sleep only under a horizontal excitation applied as inertial forces)".into(),
                    );
                }
                if let Some(sl) = stepper.sleep.as_ref().filter(|sl| sl.fallen_asleep > 0) {
                    notes.push(format!(
                        "sleeping islands: {} put to sleep, {} woken by the excitation, {} by a contact; {:.1} % of block-steps asleep",
                        sl.fallen_asleep,
                        sl.woken_by_excitation,
                        sl.woken_by_contact,
                        100.0 * sl.block_steps_asleep as f64
                            / (computed.max(1) * scene.blocks.len() as u64) as f64
                    ));
                }
                if let Some((k, t)) = resumed {
                    notes.push(format!(
                        "resumed from a checkpoint after step {k} (t = {t:.4} s); the run's processes before it took {wall_before:.1} s of wall time"
                    ));
                }
                if let Some(t) = stopped_at {
                    notes.push(format!(
                        "every block at rest from t = {t:.4} s (speeds below {:e} m/s for {REST_WINDOW} s): the run stopped there and the rest of the trajectory holds that state",
                        ns.rest_velocity
                    ));
                }
                notes
            },
        })
    }
}
