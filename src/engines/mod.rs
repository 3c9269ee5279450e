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
    #[error("engine `{engine}` was interrupted at t = {t} s, as its caller asked")]
    Interrupted { engine: &'static str, t: f64 },
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{0}")]
    Io(String),
}

/// A simulation engine.
pub trait Engine: Send + Sync {
    fn name(&self) -> &'static str;
    /// Run `scene`, calling `progress` with the simulated time reached as it goes (the engines
    /// that step in time do, after every step; the others ignore it). The answer does not
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

/// Time `run`, a run of `engine` on `scene`, check its trajectory is finite and build its
/// summary.
pub fn timed(
    engine: &'static str,
    scene: &Scene,
    run: impl FnOnce() -> Result<RunOutput, EngineError>,
) -> Result<(RunOutput, Summary), EngineError> {
    let start = Instant::now();
    let out = run()?;
    let wall = start.elapsed().as_secs_f64();
    if !out.trajectory.is_finite() {
        return Err(EngineError::Failed {
            engine,
            message: "the trajectory contains NaN or infinity".into(),
        });
    }
    let summary = Summary::build(scene, engine, &out, wall);
    Ok((out, summary))
}

/// Write `trajectory.csv` and `summary.json` into `dir`.
pub fn write_outputs(dir: &Path, out: &RunOutput, summary: &Summary) -> Result<(), EngineError> {
    let io = |e: std::io::Error| EngineError::Io(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(io)?;
    out.trajectory
        .write_csv(&dir.join("trajectory.csv"))
        .map_err(io)?;
    let json = serde_json::to_string_pretty(summary).expect("summaries serialise");
    std::fs::write(dir.join("summary.json"), json + "\n").map_err(io)?;
    Ok(())
}
