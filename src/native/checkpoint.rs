//! A native run's checkpoint: everything the run carries from one step to the next (the state,
//! the stepper's warm starts, factors and counters, the samples so far), so that a run
//! interrupted after any step and resumed from its checkpoint writes the uninterrupted run's
//! outputs, to the bit.
//!
//! The checkpoint is CBOR, written whole to a temporary file and renamed over the last one, so
//! an interruption leaves the previous checkpoint or the new one, never a part. It is sealed
//! with the SHA-256 of its bytes (`Sealed`): a damaged file is refused, where one changed
//! bit of a number in the state would resume into another answer. It is refused by another
//! build (`RB_SOURCE_HASH`) or for another scene (the scene as run, overrides applied), and
//! one whose state does not fit the run ([`Checkpoint::fits`]): the seal tells damage, not a
//! file written again and sealed anew.
//! The samples go to a file beside it ([`SampleLog`], `FILE.samples`), appended at each write:
//! a write costs the samples since the last one, not the whole history (a 215-block wall sampled
//! every step gathers 10 kB a step). The checkpoint keeps the SHA-256 of the samples it counts,
//! so that samples damaged or written by another run are refused, not resumed into an answer.

use super::solver::{Blob, from_bytes, to_bytes};
use super::stepper::NativeState;
use crate::digest::{hex, sha256_hex};
use crate::trajectory::Trajectory;
use sha2::{Digest, Sha256};
use std::io::Read as _;
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
    /// Samples so far: the first this many of the [`SampleLog`] beside the checkpoint.
    pub samples: u64,
    /// SHA-256 of those samples' bytes ([`SampleLog::sha256`]).
    pub samples_sha256: String,
    /// Wall time of the run before this checkpoint, s (all its processes).
    pub wall_s: f64,
}

/// The checkpoint file: a [`Checkpoint`]'s CBOR bytes and their SHA-256 (hex).
#[derive(serde::Serialize, serde::Deserialize)]
struct Sealed {
    sha256: String,
    checkpoint: Blob,
}

/// The temporary file a checkpoint is written to before it is renamed over `path`.
fn part_of(path: &Path) -> std::path::PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".part");
    tmp.into()
}

/// The file of the samples beside the checkpoint `path`.
fn samples_of(path: &Path) -> std::path::PathBuf {
    let mut samples = path.as_os_str().to_owned();
    samples.push(".samples");
    samples.into()
}

/// Remove a finished run's checkpoint, its samples, and the temporary file an interrupted write
/// left.
pub fn remove(path: &Path) -> Result<(), String> {
    for p in [path.to_path_buf(), part_of(path), samples_of(path)] {
        if p.exists() {
            std::fs::remove_file(&p).map_err(|e| format!("removing {}: {e}", p.display()))?;
        }
    }
    Ok(())
}

/// This build's identity in a checkpoint.
pub fn this_build() -> String {
    crate::build_info::SOURCE_HASH.to_string()
}

impl Checkpoint {
    /// Write to `path` whole (a temporary file beside it, renamed over it).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let bytes = seal(to_bytes(self));
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
        let bytes =
            crate::input_file::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Self::from_file_bytes(&bytes, scene).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// A checkpoint file's bytes, as [`Checkpoint::read`] checks them; the error does not name
    /// the file.
    pub fn from_file_bytes(bytes: &[u8], scene: &str) -> Result<Checkpoint, String> {
        let c: Checkpoint = from_bytes(&unseal(bytes)?, "not a rockbench checkpoint")?;
        if c.build != this_build() {
            return Err(format!(
                "written by another rockbench build (source hash {}, this build {}): a checkpoint resumes only in the build that wrote it",
                c.build,
                this_build()
            ));
        }
        if c.scene != scene {
            return Err(
                "written for another scene, other --set overrides or other record files".into(),
            );
        }
        Ok(c)
    }
}

/// What a run of the scene is made of, for [`Checkpoint::fits`].
#[derive(Debug, Clone, Copy)]
pub struct RunShape {
    pub blocks: usize,
    /// Steps of the whole run.
    pub steps: u64,
    pub dt: f64,
    /// A sample every this many steps.
    pub sample_every: u64,
}

impl Checkpoint {
    /// Whether this checkpoint is one the run `shape` writes: after a step before its last, with
    /// the state of every block, finite numbers, the step's instant and its samples. The seal
    /// holds against damage, not against a file written again by hand and sealed anew, which
    /// would otherwise resume into a panic or into an answer of another run. Of the stepper's
    /// state inside ([`super::Stepper::restore`]), what would index outside its arrays is
    /// checked (its blocks, the sparse back-end's envelope) and every number must be finite;
    /// finite warm starts and counters that another run would not have written are not
    /// detected (they resume; every step's solution is still held to its back-end's tolerances).
    pub fn fits(&self, shape: RunShape) -> Result<(), String> {
        let k = self.steps_done;
        let bad = |field: &str, problem: String| Err(format!("field `{field}`: {problem}"));
        if k == 0 || k >= shape.steps {
            return bad(
                "steps_done",
                format!(
                    "{k}, not one of the steps before this run's last ({})",
                    shape.steps
                ),
            );
        }
        let state = &self.state;
        if state.step != k {
            return bad(
                "state.step",
                format!("{}, not the steps done ({k})", state.step),
            );
        }
        let t = k as f64 * shape.dt;
        if state.t != t {
            return bad(
                "state.t",
                format!("{}, not the instant of step {k} ({t})", state.t),
            );
        }
        for (field, values) in [("state.q", &state.q), ("state.v", &state.v)] {
            if values.len() != 3 * shape.blocks {
                return bad(
                    field,
                    format!(
                        "{} values, where the scene's {} blocks have {}",
                        values.len(),
                        shape.blocks,
                        3 * shape.blocks
                    ),
                );
            }
            if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                return bad(field, format!("value {i} is {}", values[i]));
            }
        }
        let (gd, gw) = (state.ground_d, state.ground_w);
        for (field, x) in [
            ("state.ground_d", gd.0),
            ("state.ground_d", gd.1),
            ("state.ground_w", gw.0),
            ("state.ground_w", gw.1),
            ("wall_s", self.wall_s),
        ] {
            if !x.is_finite() {
                return bad(field, format!("{x}, not a finite number"));
            }
        }
        if self.wall_s < 0.0 {
            return bad("wall_s", format!("{}, a negative time", self.wall_s));
        }
        // The ground's increments add up to the instant of the step, to their rounding.
        if !state.ground_t.is_finite() || (state.ground_t - t).abs() > 1e-6 * shape.dt {
            return bad(
                "state.ground_t",
                format!("{}, not the instant of step {k} ({t})", state.ground_t),
            );
        }
        // Every number of the stepper's state, its back-ends' within it: a warm start that is
        // not a number would be one for the steps that follow.
        let stepper = from_bytes::<ciborium::Value>(&self.stepper.0, "");
        if let Some((path, x)) = stepper.ok().as_ref().and_then(first_non_finite) {
            return bad(
                &format!("stepper{path}"),
                format!("{x}, not a finite number"),
            );
        }
        if self.still > k {
            return bad("still", format!("{} still steps of {k} done", self.still));
        }
        let samples = 1 + k / shape.sample_every;
        if self.samples != samples {
            return bad(
                "samples",
                format!(
                    "{}, where {k} steps sampled every {} take {samples}",
                    self.samples, shape.sample_every
                ),
            );
        }
        Ok(())
    }
}

/// The first number of a saved state (CBOR, and the CBOR of its byte strings: the nested states
/// of [`Blob`], to `NESTED_STATES` levels) that is not finite, with its path in the state
/// (`.field[index]...`).
fn first_non_finite(value: &ciborium::Value) -> Option<(String, f64)> {
    first_non_finite_within(value, NESTED_STATES)
}

/// Byte strings read as nested states: the stepper's holds its back-ends' (two levels where
/// islands wrap a back-end); a forged file's byte strings nested deeper are not followed, so
/// they cannot take the stack.
const NESTED_STATES: usize = 8;

fn first_non_finite_within(value: &ciborium::Value, levels: usize) -> Option<(String, f64)> {
    use ciborium::Value;
    let walk = |v| first_non_finite_within(v, levels);
    match value {
        Value::Float(x) if !x.is_finite() => Some((String::new(), *x)),
        Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, v)| walk(v).map(|(path, x)| (format!("[{i}]{path}"), x))),
        Value::Map(entries) => entries.iter().find_map(|(key, v)| {
            walk(v).map(|(path, x)| match key {
                Value::Text(name) => (format!(".{name}{path}"), x),
                other => (format!("[{other:?}]{path}"), x),
            })
        }),
        Value::Bytes(b) if levels > 0 => from_bytes::<Value>(b, "")
            .ok()
            .and_then(|inner| first_non_finite_within(&inner, levels - 1)),
        Value::Tag(_, v) => walk(v),
        _ => None,
    }
}

/// A checkpoint file's bytes: `checkpoint` (a [`Checkpoint`]'s CBOR) sealed with its SHA-256.
pub fn seal(checkpoint: Vec<u8>) -> Vec<u8> {
    to_bytes(&Sealed {
        sha256: sha256_hex(&checkpoint),
        checkpoint: Blob(checkpoint),
    })
}

/// The sealed bytes of a checkpoint file, if their SHA-256 is the one sealed with them.
pub fn unseal(file: &[u8]) -> Result<Vec<u8>, String> {
    let sealed: Sealed = from_bytes(file, "not a rockbench checkpoint")?;
    if sha256_hex(&sealed.checkpoint.0) != sealed.sha256 {
        return Err(
            "damaged: its bytes are not those it was written with (their SHA-256 differs)".into(),
        );
    }
    Ok(sealed.checkpoint.0)
}

/// The samples of a checkpointed run, in the file beside its checkpoint: each sample `t`, then
/// `(x, z, phi, vx, vz, omega)` of every block, as little-endian `f64` (every value to the
/// bit). Written by appending the samples taken since the last write, before the checkpoint
/// that counts them is renamed into place; a run interrupted between the two leaves samples
/// beyond the checkpoint's count, which its resumption drops.
pub struct SampleLog {
    path: std::path::PathBuf,
    /// Samples in the file.
    written: usize,
    /// The running SHA-256 of the file's bytes.
    digest: Sha256,
}

impl SampleLog {
    /// The log beside checkpoint `path`, empty: the first [`SampleLog::append`] starts the file
    /// afresh.
    pub fn beside(path: &Path) -> Self {
        SampleLog {
            path: samples_of(path),
            written: 0,
            digest: Sha256::new(),
        }
    }

    /// The SHA-256 of the samples written so far, as hex.
    pub fn sha256(&self) -> String {
        hex(&self.digest.clone().finalize())
    }

    fn values_per_sample(tr: &Trajectory) -> usize {
        1 + 6 * tr.blocks.len()
    }

    /// Append the samples of `tr` after those already written, and flush them to the disk.
    pub fn append(&mut self, tr: &Trajectory) -> Result<(), String> {
        use std::io::Write;
        let fail = |e: std::io::Error| format!("{}: {e}", self.path.display());
        debug_assert!(tr.len() >= self.written, "a trajectory only grows");
        let mut bytes = Vec::with_capacity(
            tr.len().saturating_sub(self.written) * Self::values_per_sample(tr) * 8,
        );
        for k in self.written..tr.len() {
            bytes.extend_from_slice(&tr.t[k].to_le_bytes());
            for b in &tr.blocks {
                for v in [b.x[k], b.z[k], b.phi[k], b.vx[k], b.vz[k], b.omega[k]] {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(self.written > 0)
            .write(true)
            .truncate(self.written == 0)
            .open(&self.path)
            .map_err(fail)?;
        file.write_all(&bytes).map_err(fail)?;
        file.sync_data().map_err(fail)?;
        if self.written == 0 {
            self.digest = Sha256::new();
        }
        self.digest.update(&bytes);
        self.written = tr.len();
        Ok(())
    }

    /// Read the first `count` samples into `tr` (its blocks named, no samples), which must hash
    /// to `sha256`, and cut the file after them, so that the next append follows them.
    pub fn read(&mut self, tr: &mut Trajectory, count: u64, sha256: &str) -> Result<(), String> {
        let fail = |e: std::io::Error| format!("{}: {e}", self.path.display());
        let per = Self::values_per_sample(tr);
        let count = usize::try_from(count)
            .map_err(|_| format!("{}: too many samples", self.path.display()))?;
        let need = count
            .checked_mul(per * 8)
            .ok_or_else(|| format!("{}: too many samples", self.path.display()))?;
        // The samples the checkpoint counts, and no more: the file grows with the run, and
        // what an interrupted write appended after them is cut below.
        let file = std::fs::File::open(&self.path).map_err(fail)?;
        let length = file.metadata().map_err(fail)?.len();
        if length < need as u64 {
            return Err(format!(
                "{}: holds {} samples of {} blocks, the checkpoint needs {count}",
                self.path.display(),
                length / (per as u64 * 8),
                tr.blocks.len()
            ));
        }
        let mut bytes = Vec::new();
        bytes.try_reserve_exact(need).map_err(|_| {
            format!(
                "{}: no memory for the {need} bytes of its samples",
                self.path.display()
            )
        })?;
        file.take(need as u64)
            .read_to_end(&mut bytes)
            .map_err(fail)?;
        if bytes.len() < need {
            return Err(format!(
                "{}: ended after {} of its {need} bytes while it was read",
                self.path.display(),
                bytes.len()
            ));
        }
        let digest = Sha256::new_with_prefix(&bytes);
        if hex(&digest.clone().finalize()) != sha256 {
            return Err(format!(
                "{}: its first {count} samples are not those the checkpoint counted (damaged, or written by another run)",
                self.path.display()
            ));
        }
        let values: Vec<f64> = bytes
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("eight bytes")))
            .collect();
        let mut states = vec![[0.0; 6]; tr.blocks.len()];
        for sample in values.chunks_exact(per) {
            for (s, v) in states.iter_mut().zip(sample[1..].chunks_exact(6)) {
                s.copy_from_slice(v);
            }
            tr.push(sample[0], &states);
        }
        if length > need as u64 {
            std::fs::OpenOptions::new()
                .write(true)
                .open(&self.path)
                .and_then(|f| f.set_len(need as u64))
                .map_err(fail)?;
        }
        self.written = count;
        self.digest = digest;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ciborium::Value;

    /// `inner` inside `levels` byte strings, each a map `{"state": <bytes>}`.
    fn nested(inner: Value, levels: usize) -> Value {
        (0..levels).fold(inner, |v, _| {
            Value::Map(vec![(
                Value::Text("state".into()),
                Value::Bytes(to_bytes(&v)),
            )])
        })
    }

    #[test]
    fn a_number_that_is_not_finite_is_found_with_its_path_through_nested_states() {
        let state = Value::Map(vec![
            (
                Value::Text("q".into()),
                Value::Array(vec![1.0.into(), 2.0.into()]),
            ),
            (
                Value::Text("l".into()),
                Value::Array(vec![0.5.into(), f64::NAN.into()]),
            ),
        ]);
        let (path, x) = first_non_finite(&nested(state.clone(), 2)).unwrap();
        assert_eq!(path, ".state.state.l[1]");
        assert!(x.is_nan());
        let finite = Value::Array(vec![1.0.into(), f64::MAX.into(), (-0.0).into()]);
        assert_eq!(first_non_finite(&nested(finite, 2)), None);
        // A forged file's byte strings nested without end are followed to `NESTED_STATES`
        // levels only, not to the end of the stack.
        assert!(first_non_finite(&nested(state.clone(), NESTED_STATES)).is_some());
        assert_eq!(first_non_finite(&nested(state, NESTED_STATES + 1)), None);
        let deep = nested(Value::Float(f64::INFINITY), 20_000);
        assert_eq!(first_non_finite(&deep), None);
    }
}
