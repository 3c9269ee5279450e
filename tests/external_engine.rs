//! The external-engine harness against stand-in workers: small shell scripts given as the
//! "interpreter", each misbehaving in one way. Every failure must come back as a failed run
//! with a one-line reason, and the harness must go on. (The real MuJoCo and PyBullet workers
//! are tested from Python: tests/python/.)
#![cfg(unix)]

mod common;

use rockbench::engines::external::ExternalEngine;
use rockbench::engines::{Engine, EngineError, run_timed};
use rockbench::scene::{Scene, load_scene_with_overrides};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A 10 ms single-block scene (11 samples).
fn short_scene(extra: &[&str]) -> Scene {
    let mut o = vec!["duration=0.01".to_string()];
    o.extend(extra.iter().map(|s| s.to_string()));
    load_scene_with_overrides(Path::new("validation/scenes/housner-slender.toml"), &o).unwrap()
}

/// An executable stand-in for the interpreter, in a scratch directory that lives as long as
/// the directory returned with it. `$out` is the worker's `--out` directory.
fn fake_python(name: &str, body: &str) -> (common::TmpDir, PathBuf) {
    let dir = common::tmp("rb-ext-test", name);
    let path = dir.join("python");
    let script = format!(
        "#!/bin/sh\nwhile [ $# -gt 0 ]; do case \"$1\" in --out) out=\"$2\"; shift;; esac; shift; done\n{body}\n"
    );
    std::fs::write(&path, script).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    (dir, path)
}

const HEADER: &str = "t,block_x,block_z,block_phi,block_vx,block_vz,block_omega";

/// Shell lines writing a trajectory of `n` samples 1 ms apart (phi decreasing through zero
/// at t = 5 ms) and a summary.
fn good_outputs(n: usize, phi_nan_at: Option<usize>) -> String {
    let mut rows = vec![HEADER.to_string()];
    for k in 0..n {
        let t = k as f64 * 1e-3;
        let phi = if phi_nan_at == Some(k) {
            "nan".to_string()
        } else {
            format!("{}", 0.01 - 2.0 * t)
        };
        rows.push(format!("{t},0,1.25,{phi},0,0,-2"));
    }
    format!(
        "mkdir -p \"$out\"\nprintf '{}\\n' > \"$out/trajectory.csv\"\n\
         printf '{{\"engine\":\"mujoco\",\"engine_version\":\"stand-in 1.0\",\"settings\":{{\"timestep\":0.001}},\"steps\":10,\"wall_time_s\":0.1,\"notes\":[]}}\\n' > \"$out/summary.json\"",
        rows.join("\\n")
    )
}

fn engine(python: &Path) -> ExternalEngine {
    ExternalEngine::new("mujoco").unwrap().with_python(python)
}

fn failure(r: Result<impl std::fmt::Debug, EngineError>) -> String {
    match r {
        Err(EngineError::Failed { engine, message }) => {
            assert_eq!(engine, "mujoco");
            assert!(!message.contains('\n'), "not one line: {message}");
            message
        }
        other => panic!("expected a failed run, got {other:?}"),
    }
}

#[test]
fn a_well_behaved_worker_is_read_back_and_its_events_computed_here() {
    let (_scratch, py) = fake_python("ok", &good_outputs(11, None));
    let (out, summary) = run_timed(&engine(&py), &short_scene(&[])).unwrap();
    assert_eq!(out.trajectory.len(), 11);
    assert_eq!(summary.engine_version, "stand-in 1.0");
    assert_eq!(summary.settings["timestep"], 0.001);
    assert_eq!(summary.steps, 10);
    // phi = 0.01 - 2 t crosses zero at 5 ms: the impact is located by Summary::build.
    let imp = &summary.blocks[0].impacts;
    assert_eq!(imp.len(), 1, "{imp:?}");
    assert!((imp[0] - 0.005).abs() < 1e-12, "{imp:?}");
}

#[test]
fn a_crashing_worker_is_a_failed_run_with_its_last_error_line() {
    let (_scratch, py) = fake_python(
        "crash",
        "echo 'Traceback (most recent call last):' >&2\necho 'mujoco: RuntimeError: boom' >&2\nexit 1",
    );
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(
        m.contains("exited with code 1") && m.contains("boom"),
        "{m}"
    );
}

#[test]
fn a_hanging_worker_is_killed_at_the_timeout() {
    let (_scratch, py) = fake_python("hang", "exec sleep 30");
    let start = Instant::now();
    let m = failure(engine(&py).run(&short_scene(&["mujoco.timeout=0.5"])));
    let took = start.elapsed();
    assert!(m.contains("timeout") && m.contains("mujoco.timeout"), "{m}");
    assert!(took < Duration::from_secs(5), "took {took:?}");
    assert!(took >= Duration::from_millis(500), "took {took:?}");
}

#[test]
fn a_worker_killed_mid_run_is_a_failed_run_and_the_harness_goes_on() {
    let (scratch, py) = fake_python("killed", "echo $$ > \"$PIDFILE\"\nexec sleep 30");
    let pidfile = scratch.join("pid");
    let eng = engine(&py).with_env("PIDFILE", pidfile.to_str().unwrap());
    let scene = short_scene(&[]);
    let worker = std::thread::spawn(move || eng.run(&scene));
    let deadline = Instant::now() + Duration::from_secs(10);
    let pid = loop {
        if let Ok(s) = std::fs::read_to_string(&pidfile)
            && s.ends_with('\n')
        {
            break s.trim().to_string();
        }
        assert!(Instant::now() < deadline, "the worker never started");
        std::thread::sleep(Duration::from_millis(10));
    };
    let st = std::process::Command::new("kill")
        .args(["-9", &pid])
        .status()
        .unwrap();
    assert!(st.success());
    let m = failure(worker.join().unwrap());
    assert!(m.contains("killed by signal 9"), "{m}");
    // The harness goes on: the next run works.
    let (_scratch, py) = fake_python("after-kill", &good_outputs(11, None));
    assert!(engine(&py).run(&short_scene(&[])).is_ok());
}

#[test]
fn a_nan_in_the_trajectory_is_a_failed_run() {
    let (_scratch, py) = fake_python("nan", &good_outputs(11, Some(7)));
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(m.contains("NaN"), "{m}");
}

#[test]
fn a_trajectory_that_stops_early_is_a_failed_run() {
    let (_scratch, py) = fake_python("short", &good_outputs(6, None));
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(m.contains("truncated") && m.contains("0.005"), "{m}");
}

#[test]
fn a_trajectory_cut_mid_line_is_a_failed_run_naming_the_line() {
    let body = format!(
        "{}\nprintf '0.011,0,1.2' >> \"$out/trajectory.csv\"",
        good_outputs(11, None)
    );
    let (_scratch, py) = fake_python("cut", &body);
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(m.contains("line 13"), "{m}");
}

#[test]
fn a_missing_summary_is_a_failed_run() {
    let body = format!("{}\nrm \"$out/summary.json\"", good_outputs(11, None));
    let (_scratch, py) = fake_python("nosummary", &body);
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(m.contains("summary.json"), "{m}");
}

#[test]
fn a_missing_interpreter_says_how_to_install_it() {
    let m = failure(engine(Path::new("/nonexistent/python")).run(&short_scene(&[])));
    assert!(m.contains("make .venv"), "{m}");
}

#[test]
fn a_python_without_rockbench_says_how_to_install_it() {
    let (_scratch, py) = fake_python(
        "nomodule",
        "echo '/usr/bin/python3: Error while finding module specification for '\\''rockbench.worker'\\'' (ModuleNotFoundError: No module named '\\''rockbench'\\'')' >&2\nexit 1",
    );
    let m = failure(engine(&py).run(&short_scene(&[])));
    assert!(m.contains("`rockbench`") && m.contains("make .venv"), "{m}");
}

#[test]
fn a_bad_timeout_setting_names_the_field() {
    let (_scratch, py) = fake_python("badtimeout", &good_outputs(11, None));
    match engine(&py).run(&short_scene(&["mujoco.timeout=-1"])) {
        Err(EngineError::Scene(e)) => assert_eq!(e.field, "mujoco.timeout", "{e}"),
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn external_engines_are_registered_by_name() {
    for name in ["mujoco", "pybullet"] {
        let e = rockbench::engines::engine_by_name(name).unwrap();
        assert_eq!(e.name(), name);
        assert!(rockbench::engines::registry::names().contains(&name));
    }
}

/// An interpreter named by `$ROCKBENCH_PYTHON` that cannot start: the one line says the path
/// came from the variable, so a stale setting is found.
#[test]
fn a_missing_interpreter_from_the_environment_names_the_variable() {
    let dir = common::tmp("rb-ext-test", "env-python");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .current_dir(common::root())
        .env("ROCKBENCH_PYTHON", "/nonexistent/python")
        .args(["run", "validation/scenes/housner-slender.toml", "--engine"])
        .args(["mujoco", "--set", "duration=0.01", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("/nonexistent/python (from $ROCKBENCH_PYTHON)"),
        "{err}"
    );
}

/// PyBullet's friction is the product of two bodies' coefficients: a stack whose middle block
/// rests on friction 0 and carries friction 0.5 cannot be made, and is a scene PyBullet cannot
/// model (skipped with the reason, not a crash in the worker); with friction 0 above it too, or
/// one coefficient for every body (`pybullet.lateral_friction`), it can.
#[test]
fn pybullet_cannot_model_a_friction_on_a_block_resting_on_none() {
    let scene = |frictions: [f64; 3], extra: &str| {
        let text = format!(
            "name = \"f\"\nduration = 0.1\n[[blocks]]\nname = \"b1\"\nwidth = 1.0\nheight = 0.5\n\
             [[blocks]]\nname = \"b2\"\nwidth = 1.0\nheight = 0.5\n[[blocks]]\nname = \"b3\"\n\
             width = 1.0\nheight = 0.5\n[contact]\nfriction = 0.5\n[contact.interfaces]\n\
             b1 = {{ friction = {} }}\nb2 = {{ friction = {} }}\nb3 = {{ friction = {} }}\n{extra}",
            frictions[0], frictions[1], frictions[2]
        );
        rockbench::scene::parse_scene_str(&text, false, "f.toml", &[]).unwrap()
    };
    let pybullet = rockbench::engines::engine_by_name("pybullet").unwrap();
    let why = pybullet
        .cannot_model(&scene([0.5, 0.0, 0.5], ""))
        .expect("refused");
    assert!(
        why.starts_with("block `b3` has friction 0.5 on `b2`, whose own coefficient must be 0"),
        "{why}"
    );
    assert_eq!(pybullet.cannot_model(&scene([0.5, 0.0, 0.0], "")), None);
    assert_eq!(pybullet.cannot_model(&scene([0.0, 0.0, 0.5], "")), None);
    assert_eq!(
        pybullet.cannot_model(&scene(
            [0.5, 0.0, 0.5],
            "[pybullet]\nlateral_friction = 0.5\n"
        )),
        None
    );
}
