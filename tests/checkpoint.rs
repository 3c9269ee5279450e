//! `rockbench run --checkpoint`: a native run stopped after any step and resumed from its
//! checkpoint writes the uninterrupted run's outputs, to the bit; a checkpoint of another scene,
//! of another build or not a checkpoint at all is one clear error.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

fn scene(name: &str) -> PathBuf {
    common::root()
        .join("validation/scenes")
        .join(format!("{name}.toml"))
}

fn run(scene: &Path, sets: &[&str], out: &Path, extra: &[&str]) -> Output {
    let mut cmd = common::bin();
    cmd.args(["run", scene.to_str().unwrap(), "--quiet", "--out"])
        .arg(out);
    for s in sets {
        cmd.args(["--set", s]);
    }
    cmd.args(extra).output().unwrap()
}

/// The summary without what differs between processes: the wall time, the command, the note
/// of the resumption.
fn summary_without_wall(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let mut s: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = s.as_object_mut().unwrap();
    o.remove("wall_time_s");
    o.remove("command");
    let notes = o.get_mut("notes").unwrap().as_array_mut().unwrap();
    notes.retain(|n| !n.as_str().unwrap().starts_with("resumed from a checkpoint"));
    s
}

/// Run `name` whole, then stopped after `stop` and resumed: the same trajectory bytes and
/// summary (counters of factorisations, rescues and located impacts included). Returns the
/// notes of the run.
fn resumed_is_uninterrupted(name: &str, sets: &[&str], stop: u64) -> String {
    let dir = common::tmp("rb-checkpoint", &format!("{name}-{stop}"));
    let path = scene(name);
    let whole = run(&path, sets, &dir.join("whole"), &[]);
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stderr)
    );

    let ck = dir.join("run.ckpt");
    let ck_arg = ck.to_str().unwrap();
    let stopped = run(
        &path,
        sets,
        &dir.join("resumed"),
        &[
            "--checkpoint",
            ck_arg,
            "--stop-after-step",
            &stop.to_string(),
        ],
    );
    assert!(
        !stopped.status.success(),
        "{name}: the stopped run exited 0"
    );
    let err = String::from_utf8_lossy(&stopped.stderr);
    assert!(err.contains(&format!("stopped after step {stop}")), "{err}");
    assert!(ck.exists(), "{name}: no checkpoint");
    assert!(
        !dir.join("resumed").exists(),
        "{name}: the stopped run wrote outputs"
    );

    let resumed = run(&path, sets, &dir.join("resumed"), &["--checkpoint", ck_arg]);
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(
        !ck.exists(),
        "{name}: the checkpoint outlived the finished run"
    );
    assert!(!dir.join("run.ckpt.part").exists());
    let bytes = |d: &str| std::fs::read(dir.join(d).join("trajectory.csv")).unwrap();
    assert!(
        bytes("whole") == bytes("resumed"),
        "{name} {sets:?}: the resumed trajectory differs from the uninterrupted one"
    );
    assert_eq!(
        summary_without_wall(&dir.join("whole")),
        summary_without_wall(&dir.join("resumed")),
        "{name} {sets:?}: summaries differ"
    );
    let notes = std::fs::read_to_string(dir.join("resumed/summary.json")).unwrap();
    assert!(notes.contains(&format!("resumed from a checkpoint after step {stop}")));
    summary_without_wall(&dir.join("whole"))["notes"].to_string()
}

/// The 42-block wall toppling under its pulse, stopped while its blocks rock (the sparse
/// back-end's factors, islands and located impacts in the checkpoint).
#[test]
fn a_toppling_wall_resumed_mid_motion_is_the_uninterrupted_run() {
    let notes = resumed_is_uninterrupted("wall-in-motion-pulse", &["duration=0.35"], 260);
    assert!(!notes.contains(" 0 split at a located impact"), "{notes}");
    assert!(!notes.contains(" 0 factorisations"), "{notes}");
}

/// The same wall with its impacts at the end of their step, stopped while its projections of a
/// penetration go on (their back-end's warm start in the checkpoint).
#[test]
fn a_toppling_wall_at_step_ends_resumed_mid_motion_is_the_uninterrupted_run() {
    let notes = resumed_is_uninterrupted(
        "wall-in-motion-pulse",
        &["duration=0.35", "native.locate_impacts=false"],
        260,
    );
    assert!(notes.contains(" 0 split at a located impact"), "{notes}");
    assert!(!notes.contains(" 0 position projections"), "{notes}");
}

/// The two-block statue under each stepper and law, on Clarabel, stopped while it comes to rest,
/// and a column put to sleep.
#[test]
fn resumed_runs_of_every_stepper_law_and_sleep_are_the_uninterrupted_runs() {
    let two = "two-block-free-rocking";
    resumed_is_uninterrupted(two, &["duration=2"], 1234);
    resumed_is_uninterrupted(two, &["duration=2", "native.stepper=\"paper\""], 777);
    let coulomb = resumed_is_uninterrupted(
        two,
        &["duration=2", "native.friction_law=\"coulomb\""],
        1500,
    );
    assert!(coulomb.contains("Coulomb friction: "), "{coulomb}");
    resumed_is_uninterrupted(two, &["duration=1", "native.solver=\"clarabel\""], 400);
    // The certificates' record is carried: the resumed run reports the whole run's.
    let certified = resumed_is_uninterrupted(two, &["duration=1", "native.certify=true"], 600);
    assert!(certified.contains("certificates: "), "{certified}");
    // Stopped within the window of `native.stop_at_rest` (the blocks come to rest at 5.131 s).
    let rest = resumed_is_uninterrupted(two, &["duration=8", "native.stop_at_rest=true"], 5110);
    assert!(
        rest.contains("every block at rest from t = 5.1310 s"),
        "{rest}"
    );
    let sleep = resumed_is_uninterrupted(
        "standing-column",
        &["duration=1.5", "native.sleep=true"],
        900,
    );
    assert!(
        sleep.contains("sleeping islands: 1 put to sleep"),
        "{sleep}"
    );
}

/// A Ctrl-C (SIGINT) of a checkpointed run, sent once its first progress line is out: it writes
/// its checkpoint at the step it reached and exits 130 with one line saying how to resume,
/// writing no output; the same command resumes it to the uninterrupted run, to the bit.
#[cfg(unix)]
#[test]
fn a_checkpointed_run_stopped_by_ctrl_c_resumes_to_the_uninterrupted_run() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = common::tmp("rb-checkpoint", "sigint");
    let path = scene("wall-in-motion-pulse");
    let sets = ["duration=0.35"];
    let whole = run(&path, &sets, &dir.join("whole"), &[]);
    assert!(whole.status.success());

    let ck = dir.join("run.ckpt");
    let mut child = common::bin()
        .args(["run", path.to_str().unwrap(), "--set", sets[0], "--out"])
        .arg(dir.join("resumed"))
        .args([
            "--checkpoint",
            ck.to_str().unwrap(),
            "--progress-interval",
            "0.05",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = BufReader::new(child.stderr.take().unwrap());
    let reader = std::thread::spawn(move || {
        let mut lines = Vec::new();
        for line in stderr.lines() {
            let line = line.unwrap();
            let _ = tx.send(());
            lines.push(line);
        }
        lines
    });
    rx.recv().expect("a progress line before the run ends");
    // SAFETY: signals a child of this process, which has not been waited for.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let status = child.wait().unwrap();
    let err = reader.join().unwrap();
    let last = err.last().unwrap();
    assert_eq!(status.code(), Some(130), "{err:?}");
    assert!(
        last.starts_with("error: interrupted after step ") && last.contains("resumes the run"),
        "{err:?}"
    );
    let step: u64 = last["error: interrupted after step ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(step < 350, "{last}");
    assert!(ck.exists(), "no checkpoint");
    assert!(
        !dir.join("resumed").exists(),
        "the interrupted run wrote outputs"
    );

    let resumed = run(
        &path,
        &sets,
        &dir.join("resumed"),
        &["--checkpoint", ck.to_str().unwrap()],
    );
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(!ck.exists());
    let bytes = |d: &str| std::fs::read(dir.join(d).join("trajectory.csv")).unwrap();
    assert!(
        bytes("whole") == bytes("resumed"),
        "the resumed trajectory differs"
    );
    assert_eq!(
        summary_without_wall(&dir.join("whole")),
        summary_without_wall(&dir.join("resumed"))
    );
    let notes = std::fs::read_to_string(dir.join("resumed/summary.json")).unwrap();
    assert!(
        notes.contains(&format!("resumed from a checkpoint after step {step} ")),
        "{notes}"
    );
}

#[test]
fn a_checkpoint_of_another_scene_or_not_a_checkpoint_is_one_clear_error() {
    let dir = common::tmp("rb-checkpoint", "refused");
    let path = scene("two-block-free-rocking");
    let ck = dir.join("run.ckpt");
    let ck_arg = ck.to_str().unwrap();
    let stopped = run(
        &path,
        &["duration=1"],
        &dir.join("a"),
        &["--checkpoint", ck_arg, "--stop-after-step", "100"],
    );
    assert!(!stopped.status.success());
    let written = std::fs::read(&ck).unwrap();
    let one_error = |o: &Output, says: &str| {
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(says), "{err}");
    };
    // Other overrides: another scene.
    let other = run(
        &path,
        &["duration=1.5"],
        &dir.join("b"),
        &["--checkpoint", ck_arg],
    );
    one_error(
        &other,
        "written for another scene, other --set overrides or other record files",
    );
    assert!(!dir.join("b").exists());
    // Another engine.
    let rapier = run(
        &path,
        &["duration=1"],
        &dir.join("c"),
        &["--engine", "housner", "--checkpoint", ck_arg],
    );
    one_error(&rapier, "only the native engine resumes from a checkpoint");
    // A file that is not a checkpoint.
    std::fs::write(&ck, "not cbor at all").unwrap();
    let junk = run(
        &path,
        &["duration=1"],
        &dir.join("d"),
        &["--checkpoint", ck_arg],
    );
    one_error(&junk, "not a rockbench checkpoint");
    assert!(!dir.join("d").exists());
    // A sealed file (its SHA-256 holds) whose content is not a checkpoint: a map of another
    // field, and the first half of a checkpoint file's bytes.
    let half = written[..written.len() / 2].to_vec();
    for (name, payload) in [("map", b"\xa1\x61a\x01".to_vec()), ("half", half)] {
        std::fs::write(&ck, rockbench::native::checkpoint::seal(payload)).unwrap();
        let o = run(
            &path,
            &["duration=1"],
            &dir.join(name),
            &["--checkpoint", ck_arg],
        );
        one_error(&o, "not a rockbench checkpoint");
        assert!(!dir.join(name).exists());
    }
}

/// The samples go to `FILE.samples`, appended at each write (here after every step). A run
/// interrupted after an append and before its checkpoint is renamed leaves samples the checkpoint
/// does not count: the resumed run drops them and writes the uninterrupted run's outputs; the
/// finished run removes the file. A samples file shorter than its checkpoint says, or whose
/// counted samples are not those the checkpoint hashed, is one error.
#[test]
fn samples_beyond_the_checkpoint_are_dropped_and_missing_or_damaged_ones_are_one_error() {
    let dir = common::tmp("rb-checkpoint", "samples");
    let path = scene("two-block-free-rocking");
    let sets = ["duration=1", "output_interval=0.002"];
    let whole = run(&path, &sets, &dir.join("whole"), &[]);
    assert!(whole.status.success());
    let ck = dir.join("run.ckpt");
    let ck_arg = ck.to_str().unwrap();
    let samples = dir.join("run.ckpt.samples");
    let every_step = ["--checkpoint", ck_arg, "--checkpoint-interval", "0"];
    let stop = |step: &str| {
        let mut args = every_step.to_vec();
        args.extend(["--stop-after-step", step]);
        let o = run(&path, &sets, &dir.join("resumed"), &args);
        assert!(!o.status.success());
        assert!(ck.exists() && samples.exists());
    };
    // Two blocks: a sample is 13 values. Stopped after step 300 (samples at t = 0, 0.002, ...,
    // 0.3: 151), then garbage after them, as an append whose checkpoint was never renamed.
    stop("300");
    let per_sample = 13 * 8;
    assert_eq!(std::fs::metadata(&samples).unwrap().len(), 151 * per_sample);
    let mut bytes = std::fs::read(&samples).unwrap();
    bytes.extend(std::iter::repeat_n(0x7f, 2 * per_sample as usize + 5));
    std::fs::write(&samples, &bytes).unwrap();
    // Resumed, written again every step, stopped again, resumed to the end.
    stop("640");
    assert_eq!(std::fs::metadata(&samples).unwrap().len(), 321 * per_sample);
    let resumed = run(&path, &sets, &dir.join("resumed"), &every_step);
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(!ck.exists() && !samples.exists());
    let bytes = |d: &str| std::fs::read(dir.join(d).join("trajectory.csv")).unwrap();
    assert!(bytes("whole") == bytes("resumed"));
    assert_eq!(
        summary_without_wall(&dir.join("whole")),
        summary_without_wall(&dir.join("resumed"))
    );

    // Samples cut short: one error naming the file, no outputs.
    stop("300");
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(&samples)
        .unwrap();
    file.set_len(100 * per_sample).unwrap();
    let short = run(&path, &sets, &dir.join("short"), &every_step);
    assert!(!short.status.success());
    let err = String::from_utf8_lossy(&short.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("run.ckpt.samples: holds 100 samples of 2 blocks, the checkpoint needs 151"),
        "{err}"
    );
    assert!(!dir.join("short").exists());

    // One value changed within the counted samples (a damaged disk, or another run's samples
    // under the same name): one error, no outputs.
    std::fs::remove_file(&ck).unwrap();
    stop("300");
    let mut bytes = std::fs::read(&samples).unwrap();
    let at = 77 * per_sample as usize + 3 * 8;
    bytes[at] ^= 1;
    std::fs::write(&samples, &bytes).unwrap();
    let damaged = run(&path, &sets, &dir.join("damaged"), &every_step);
    assert!(!damaged.status.success());
    let err = String::from_utf8_lossy(&damaged.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains(
            "run.ckpt.samples: its first 151 samples are not those the checkpoint counted"
        ),
        "{err}"
    );
    assert!(!dir.join("damaged").exists());
}

/// Run `scene` in `dir` with a checkpoint, stopped after step `stop`: the checkpoint's path, its
/// bytes and those of its samples.
fn stopped_after(
    dir: &Path,
    scene: &Path,
    sets: &[&str],
    stop: u64,
) -> (PathBuf, Vec<u8>, Vec<u8>) {
    let ck = dir.join("run.ckpt");
    let stop = stop.to_string();
    let stopped = run(
        scene,
        sets,
        &dir.join("a"),
        &[
            "--checkpoint",
            ck.to_str().unwrap(),
            "--stop-after-step",
            &stop,
        ],
    );
    assert!(!stopped.status.success() && ck.exists());
    let checkpoint = std::fs::read(&ck).unwrap();
    let samples = std::fs::read(dir.join("run.ckpt.samples")).unwrap();
    (ck, checkpoint, samples)
}

/// One bit changed anywhere in a checkpoint (a damaged disk) is one error and no outputs, never
/// a resumed run: unsealed, such a bit in a number of the state resumed into another trajectory
/// (2 of 41 bits, one every 96 bytes of the file).
#[test]
fn a_checkpoint_damaged_anywhere_is_one_error() {
    let dir = common::tmp("rb-checkpoint", "damaged-checkpoint");
    let path = scene("two-block-free-rocking");
    let sets = ["duration=1"];
    let (ck, checkpoint, samples) = stopped_after(&dir, &path, &sets, 300);
    let ck_arg = ck.to_str().unwrap();
    let n = checkpoint.len();
    let mut said_damaged = 0;
    // Some 60 bits, the first and the last byte's among them.
    let positions: Vec<usize> = (0..n).step_by(n / 60).chain([n - 1]).collect();
    for &at in &positions {
        let mut bytes = checkpoint.clone();
        bytes[at] ^= 1 << (at % 8);
        std::fs::write(&ck, &bytes).unwrap();
        std::fs::write(dir.join("run.ckpt.samples"), &samples).unwrap();
        let out = dir.join(format!("b{at}"));
        let o = run(&path, &sets, &out, &["--checkpoint", ck_arg]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "byte {at} of {n} changed: resumed");
        assert_eq!(err.trim().lines().count(), 1, "byte {at}: {err}");
        assert!(
            err.contains("run.ckpt: damaged: its bytes are not those it was written with")
                || err.contains("run.ckpt: not a rockbench checkpoint"),
            "byte {at}: {err}"
        );
        assert!(!out.exists(), "byte {at}: outputs written");
        said_damaged += usize::from(err.contains("damaged"));
    }
    // Most bits are the state's, refused by the seal rather than by the format.
    assert!(
        said_damaged * 10 >= positions.len() * 9,
        "{said_damaged} of {}",
        positions.len()
    );
}

/// A record changed between a checkpoint and its resumption would splice two records into one
/// run: the resumption is refused, naming what differs.
#[test]
fn a_checkpoint_resumes_only_with_the_records_it_was_written_with() {
    let dir = common::tmp("rb-checkpoint", "record");
    let record = |scale: f64| common::sine_record(scale, 12.0, 2001);
    std::fs::write(dir.join("rec.csv"), record(4.0)).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "name = \"r\"\nduration = 1.0\n[[blocks]]\nname = \"b\"\nwidth = 0.5\nheight = 2.0\n\
         [excitation.horizontal]\nkind = \"record\"\nfile = \"rec.csv\"\n",
    )
    .unwrap();
    let ck = dir.join("run.ckpt");
    let ck_arg = ck.to_str().unwrap();
    let stopped = run(
        &path,
        &[],
        &dir.join("a"),
        &["--checkpoint", ck_arg, "--stop-after-step", "300"],
    );
    assert!(!stopped.status.success());
    assert!(ck.exists());
    std::fs::write(dir.join("rec.csv"), record(0.8)).unwrap();
    let resumed = run(&path, &[], &dir.join("a"), &["--checkpoint", ck_arg]);
    assert!(!resumed.status.success());
    let err = String::from_utf8_lossy(&resumed.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("other record files"), "{err}");
    assert!(!dir.join("a").exists());
}

/// `cbor` with its first number within a nested state (a back-end's, inside the stepper's)
/// set to `x`.
fn first_float_set(cbor: &[u8], x: f64) -> Vec<u8> {
    use ciborium::Value;
    use rockbench::native::solver::{from_bytes, to_bytes};
    fn set(v: &mut Value, x: f64, nested: bool) -> bool {
        match v {
            Value::Float(f) if nested => {
                *f = x;
                true
            }
            Value::Array(items) => items.iter_mut().any(|i| set(i, x, nested)),
            Value::Map(entries) => entries.iter_mut().any(|(_, e)| set(e, x, nested)),
            Value::Bytes(b) => {
                let Ok(mut inner) = from_bytes::<Value>(b, "") else {
                    return false;
                };
                let found = set(&mut inner, x, true);
                if found {
                    *b = to_bytes(&inner);
                }
                found
            }
            _ => false,
        }
    }
    let mut value: Value = from_bytes(cbor, "").unwrap();
    assert!(set(&mut value, x, false), "no number in a nested state");
    to_bytes(&value)
}

/// The seal holds against damage, not against a checkpoint written again by hand and sealed
/// anew. One whose state does not fit the run (the state of another number of blocks, numbers
/// that are not finite, the stepper's and its back-ends' included, another step, instant or
/// count of samples) is one error naming the file and the field, and no outputs: before the
/// check the first resumed into a panic and most of the others into a run that ended as if
/// nothing were wrong (a NaN in a back-end's saved rows among them).
#[test]
fn a_sealed_checkpoint_that_does_not_fit_the_run_is_one_error_naming_its_field() {
    use rockbench::native::checkpoint::{Checkpoint, seal, unseal};
    use rockbench::native::solver::{from_bytes, to_bytes};
    let dir = common::tmp("rb-checkpoint", "forged");
    let path = scene("two-block-free-rocking");
    let sets = ["duration=0.5"];
    let (ck, file, samples) = stopped_after(&dir, &path, &sets, 100);
    let ck_arg = ck.to_str().unwrap();
    let content = unseal(&file).unwrap();
    type Change = fn(&mut Checkpoint);
    let forged: [(&str, Change, &str); 15] = [
        ("unchanged", |_| {}, ""),
        (
            "stepper-nan",
            |c| c.stepper.0 = first_float_set(&c.stepper.0, f64::NAN),
            "field `stepper.solver",
        ),
        (
            "stepper-inf",
            |c| c.stepper.0 = first_float_set(&c.stepper.0, f64::NEG_INFINITY),
            "field `stepper.solver",
        ),
        (
            "q-short",
            |c| c.state.q.truncate(5),
            "field `state.q`: 5 values",
        ),
        (
            "v-long",
            |c| c.state.v.push(0.0),
            "field `state.v`: 7 values",
        ),
        (
            "q-nan",
            |c| c.state.q[4] = f64::NAN,
            "field `state.q`: value 4 is NaN",
        ),
        (
            "v-inf",
            |c| c.state.v[0] = f64::INFINITY,
            "field `state.v`: value 0 is inf",
        ),
        (
            "steps-beyond",
            |c| c.steps_done = 10_000,
            "field `steps_done`: 10000",
        ),
        ("step", |c| c.state.step += 7, "field `state.step`: 107"),
        ("t", |c| c.state.t += 0.25, "field `state.t`: 0.3"),
        (
            "ground",
            |c| c.state.ground_w.1 = f64::NAN,
            "field `state.ground_w`",
        ),
        (
            "ground-t",
            |c| c.state.ground_t += 1e-3,
            "field `state.ground_t`",
        ),
        ("samples", |c| c.samples -= 1, "field `samples`: 100"),
        ("still", |c| c.still = 101, "field `still`: 101"),
        ("wall", |c| c.wall_s = -1.0, "field `wall_s`: -1"),
    ];
    for (name, change, says) in forged {
        let mut c: Checkpoint = from_bytes(&content, "checkpoint").unwrap();
        change(&mut c);
        std::fs::write(&ck, seal(to_bytes(&c))).unwrap();
        std::fs::write(dir.join("run.ckpt.samples"), &samples).unwrap();
        let out = dir.join(name);
        let o = run(&path, &sets, &out, &["--checkpoint", ck_arg]);
        let err = String::from_utf8_lossy(&o.stderr);
        if says.is_empty() {
            assert!(o.status.success(), "{name}: {err}");
            continue;
        }
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
        assert!(err.contains(&format!("run.ckpt: {says}")), "{name}: {err}");
        if let Some(x) = name.strip_prefix("stepper-") {
            let x = if x == "nan" { "NaN" } else { "-inf" };
            assert!(
                err.trim()
                    .ends_with(&format!("`: {x}, not a finite number")),
                "{name}: {err}"
            );
        }
        assert!(!out.exists(), "{name}: outputs written");
    }
}
