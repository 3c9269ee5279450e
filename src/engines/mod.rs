//! Engines: everything that turns a scene into a trajectory.
//!
//! `Engine::run` is the only way the harness meets an engine (`Engine::run_reporting`, the same
//! run telling how far it has got, and stopped when its observer asks).

pub mod auto;
pub mod external;
pub mod housner;
pub mod native;
#[cfg(feature = "rapier")]
pub mod rapier;
pub mod rapier_settings;
pub mod registry;
pub mod siconos;

use crate::scene::{Scene, SceneError};
use crate::summary::Summary;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

pub use crate::output::RunOutput;

#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    #[error("unknown engine `{0}` (known: {known})", known = registry::names().join(", "))]
    Unknown(String),
    #[error("engine `{engine}` cannot run scene `{scene}`: {reason}")]
    Unsupported {
        engine: &'static str,
        scene: String,
        reason: String,
    },
    #[error("engine `{engine}` failed: {message}")]
    Failed {
        engine: &'static str,
        message: String,
    },
    #[error(
        "engine `{engine}` is not in this build: rebuild with the cargo feature `{feature}` (on by default)"
    )]
    NotBuilt {
        engine: &'static str,
        feature: &'static str,
    },
    #[error("stopped after step {step} as asked: `--checkpoint {path}` resumes the run")]
    Stopped { step: u64, path: String },
    /// `t`: the simulated time reached, NaN where the engine cannot tell (an external worker).
    #[error("engine `{engine}` was interrupted{}, as its caller asked", at_time(*t))]
    Interrupted { engine: &'static str, t: f64 },
    /// Interrupted with a checkpoint written at the step it stopped after.
    #[error(
        "interrupted after step {step} (t = {t} s); its checkpoint is written: `--checkpoint {path}` resumes the run"
    )]
    Suspended { step: u64, t: f64, path: String },
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{0}")]
    Io(String),
}

/// ` at t = T s`, or nothing where the time is not known (NaN).
fn at_time(t: f64) -> String {
    if t.is_nan() {
        String::new()
    } else {
        format!(" at t = {t} s")
    }
}

/// A simulation engine.
pub trait Engine: Send + Sync {
    fn name(&self) -> &'static str;
    /// Run `scene`, calling `progress` with the simulated time reached as it goes (the engines
    /// that step in time do, after every step; an external engine asks with NaN while it waits
    /// for its worker, whose time it does not know; Housner's ignores it). The answer does not
    /// depend on `progress`; when it answers [`ControlFlow::Break`] the run stops there with
    /// [`EngineError::Interrupted`] (a Ctrl-C in the Python bindings).
    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError>;
    /// [`Engine::run_reporting`] without progress.
    fn run(&self, scene: &Scene) -> Result<RunOutput, EngineError> {
        self.run_reporting(scene, &go_on)
    }
    /// Why this engine cannot model the scene's blocks and their initial state, whatever the
    /// loading (`None`: it can). A study asks before any of its runs starts; a run refuses with
    /// the same reason.
    fn cannot_model(&self, _scene: &Scene) -> Option<String> {
        None
    }
}

/// A run's observer ([`Engine::run_reporting`]): told the simulated time reached, it answers
/// whether the run goes on.
pub type Progress<'a> = &'a dyn Fn(f64) -> ControlFlow<()>;

/// The observer that lets every run go on to its end.
pub fn go_on(_t: f64) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// The steps of a fixed-step engine's run: whole steps of `dt`, then, where the duration is not
/// within 1e-9 of a step of a whole number of them, one shorter step that ends at the duration,
/// so that the last sample is the duration's (the native engine's rule; the Python engines'
/// `time_grid`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSteps {
    whole: u64,
    dt: f64,
    /// The end of the shorter last step, if there is one.
    short_to: Option<f64>,
}

impl RunSteps {
    pub fn new(duration: f64, dt: f64) -> Self {
        let steps = duration / dt;
        let whole = (steps + 1e-9).floor();
        RunSteps {
            whole: whole as u64,
            dt,
            short_to: (steps - whole > 1e-9).then_some(duration),
        }
    }

    /// Steps in all.
    pub fn count(&self) -> u64 {
        self.whole + u64::from(self.short_to.is_some())
    }

    /// The end of step `k` (from 1) if it is the shorter last one.
    pub fn short_end(&self, k: u64) -> Option<f64> {
        self.short_to.filter(|_| k > self.whole)
    }

    /// The instants at which the steps end, from 0 (the start) to the last step's end.
    pub fn ends(&self) -> impl Iterator<Item = f64> + '_ {
        (0..=self.whole)
            .map(|k| k as f64 * self.dt)
            .chain(self.short_to)
    }
}

/// The engine named `name` ([`registry::engine`]).
pub fn engine_by_name(name: &str) -> Result<Box<dyn Engine>, EngineError> {
    registry::engine(name)
}

/// Run an engine, timing it, and build its summary.
pub fn run_timed(engine: &dyn Engine, scene: &Scene) -> Result<(RunOutput, Summary), EngineError> {
    run_timed_reporting(engine, scene, &go_on)
}

/// [`run_timed`], with the engine's progress ([`Engine::run_reporting`]).
pub fn run_timed_reporting(
    engine: &dyn Engine,
    scene: &Scene,
    progress: Progress,
) -> Result<(RunOutput, Summary), EngineError> {
    timed(engine.name(), scene, || {
        engine.run_reporting(scene, progress)
    })
}

/// Time `run`, a run of `engine` on `scene`, check its trajectory is finite and its record files
/// unchanged over it, and build its summary (with their SHA-256).
pub fn timed(
    engine: &'static str,
    scene: &Scene,
    run: impl FnOnce() -> Result<RunOutput, EngineError>,
) -> Result<(RunOutput, Summary), EngineError> {
    let records = scene.record_hashes();
    let start = Instant::now();
    let out = run()?;
    let wall = start.elapsed().as_secs_f64();
    let after = scene.record_hashes();
    if let Some((file, _)) = records.iter().find(|(f, h)| after.get(*f) != Some(*h)) {
        return Err(EngineError::Io(format!(
            "{file}: the record changed while the {engine} run read it: run again"
        )));
    }
    if !out.trajectory.is_finite() {
        return Err(EngineError::Failed {
            engine,
            message: "the trajectory contains NaN or infinity".into(),
        });
    }
    let summary = Summary {
        record_sha256: records,
        ..Summary::build(scene, engine, &out, wall)
    };
    Ok((out, summary))
}

/// Write `trajectory.csv`, `summary.json` (with the trajectory file's SHA-256) and the scene as
/// run, `scene.json` (what `rockbench animate` draws; its SHA-256 is the summary's
/// `scene_sha256`), into `dir`.
pub fn write_outputs(
    dir: &Path,
    scene: &Scene,
    out: &RunOutput,
    summary: &Summary,
) -> Result<(), EngineError> {
    let io = |e: std::io::Error| EngineError::Io(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(io)?;
    let scene_json = serde_json::to_string_pretty(&scene.to_json()).expect("scenes serialise");
    std::fs::write(dir.join("scene.json"), scene_json + "\n").map_err(io)?;
    let csv = dir.join("trajectory.csv");
    out.trajectory.write_csv(&csv).map_err(io)?;
    let summary = Summary {
        trajectory_sha256: crate::digest::sha256_hex(&std::fs::read(&csv).map_err(io)?),
        ..summary.clone()
    };
    let json = serde_json::to_string_pretty(&summary).expect("summaries serialise");
    std::fs::write(dir.join("summary.json"), json + "\n").map_err(io)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::RunSteps;

    #[test]
    fn a_run_ends_with_a_shorter_step_only_off_a_whole_number_of_steps() {
        // 1 s in steps of 0.3 s: three whole steps and one of 0.1 s ending at 1 s.
        let s = RunSteps::new(1.0, 0.3);
        assert_eq!(s.count(), 4);
        assert_eq!(s.short_end(3), None);
        assert_eq!(s.short_end(4), Some(1.0));
        let ends: Vec<f64> = s.ends().collect();
        assert_eq!(ends.len(), 5);
        assert!((ends[3] - 0.9).abs() < 1e-15 && ends[4] == 1.0, "{ends:?}");
        // 1 s in steps of 0.1 s is ten whole steps, although 1.0 / 0.1 is not exactly 10.
        let s = RunSteps::new(1.0, 0.1);
        assert_eq!(s.count(), 10);
        assert_eq!(s.short_end(10), None);
        assert!((s.ends().last().unwrap() - 1.0).abs() < 1e-12);
        // A duration shorter than a step is one step, ending at the duration.
        let s = RunSteps::new(0.05, 0.1);
        assert_eq!(s.count(), 1);
        assert_eq!(s.ends().collect::<Vec<_>>(), vec![0.0, 0.05]);
    }
}
