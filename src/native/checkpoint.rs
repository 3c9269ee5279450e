//! A native run's checkpoint: everything the run carries from one step to the next (the state,
//! the stepper's warm starts, factors and counters, the samples so far), so that a run
//! interrupted after any step and resumed from its checkpoint writes the uninterrupted run's
//! outputs, to the bit.
//!
//! The file is CBOR, written whole to a temporary file and renamed over the last one, so an
//! interruption leaves the previous checkpoint or the new one, never a part. It is refused by
//! another build (`RB_SOURCE_HASH`) or for another scene (the scene as run, overrides applied).

use super::solver::{Blob, from_bytes, to_bytes};
use super::stepper::NativeState;
use crate::trajectory::Trajectory;
use std::path::Path;

/// Where and how often a run writes its checkpoint.
#[derive(Debug, Clone)]
pub struct Checkpointing {
    pub path: std::path::PathBuf,
    /// Wall time between writes (the checkpoint never changes the answer, only what an
    /// interruption loses).
    pub interval: std::time::Duration,
    /// Stop after this step, once its checkpoint is written (a run cut short on purpose: the
    /// tests, a batch job's time limit).
    pub stop_after_step: Option<u64>,
}

/// The run's state after `steps_done` steps.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    /// `RB_SOURCE_HASH` of the build that wrote it.
    pub build: String,
    /// The scene as run, as JSON text.
    pub scene: String,
    pub steps_done: u64,
    /// Consecutive still steps of `native.stop_at_rest`.
    pub still: u64,
    pub state: NativeState,
    /// [`super::Stepper::save`].
    pub stepper: Blob,
    pub trajectory: Trajectory,
    /// Wall time of the run before this checkpoint, s (all its processes).
    pub wall_s: f64,
}

/// The temporary file a checkpoint is written to before it is renamed over `path`.
fn part_of(path: &Path) -> std::path::PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".part");
    tmp.into()
}

/// Remove a finished run's checkpoint, and the temporary file an interrupted write left.
pub fn remove(path: &Path) -> Result<(), String> {
    for p in [path.to_path_buf(), part_of(path)] {
        if p.exists() {
            std::fs::remove_file(&p).map_err(|e| format!("removing {}: {e}", p.display()))?;
        }
    }
    Ok(())
}

/// This build's identity in a checkpoint.
pub fn this_build() -> String {
    env!("RB_SOURCE_HASH").to_string()
}

impl Checkpoint {
    /// Write to `path` whole (a temporary file beside it, renamed over it).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let bytes = to_bytes(self);
        let tmp = part_of(path);
        let fail = |e: std::io::Error| format!("{}: {e}", path.display());
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(fail)?;
        }
        std::fs::write(&tmp, bytes).map_err(fail)?;
        std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            fail(e)
        })
    }

    /// Read `path`, which must have been written by this build for `scene` (the scene's JSON
    /// text as run).
    pub fn read(path: &Path, scene: &str) -> Result<Checkpoint, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let c: Checkpoint = from_bytes(&bytes, "not a rockbench checkpoint")
            .map_err(|e| format!("{}: {e}", path.display()))?;
        if c.build != this_build() {
            return Err(format!(
                "{}: written by another rockbench build (source hash {}, this build {}): a checkpoint resumes only in the build that wrote it",
                path.display(),
                c.build,
                this_build()
            ));
        }
        if c.scene != scene {
            return Err(format!(
                "{}: written for another scene or other --set overrides",
                path.display()
            ));
        }
        Ok(c)
    }
}
