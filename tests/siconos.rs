//! The Siconos engine (a worker under its own interpreter, `make siconos`) against Housner's
//! solution at its default settings, and its failures as one-line runs. Nothing is skipped:
//! without the interpreter these tests fail with a message naming `make siconos`.
#![cfg(unix)]

mod common;

use common::root;

use rockbench::engines::external::ExternalEngine;
use rockbench::engines::siconos::{
    DEFAULT_STEP as SICONOS_DEFAULT_STEP, WORKER_SCRIPT as SICONOS_WORKER,
};
use rockbench::engines::{Engine, EngineError, engine_by_name};
use rockbench::scene::load_scene_with_overrides;
use std::path::Path;
use std::process::Command;

/// The Siconos interpreter, or a failure saying how to make it.
fn require_siconos() {
    let e = ExternalEngine::new("siconos").unwrap();
    let py = match e.interpreter() {
        Ok(p) => p,
        Err(err) => panic!("the Siconos interpreter is missing: run `make siconos` ({err})"),
    };
    let ok = Command::new(&py)
        .args(["-c", "import siconos.kernel"])
        .env("OPENBLAS_NUM_THREADS", "1")
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "{} cannot import siconos: run `make siconos`",
        py.display()
    );
}

fn tmp(name: &str) -> common::TmpDir {
    common::tmp("rb-siconos", name)
}

/// `(value, reference)` of a metric of block `block` of engine `siconos`.
fn metric(rows: &[Vec<String>], name: &str) -> (f64, f64) {
    let r = rows
        .iter()
        .find(|r| r[1] == "siconos" && r[2] == "block" && r[3] == name)
        .unwrap_or_else(|| panic!("no siconos {name} in metrics.csv"));
    (r[4].parse().unwrap(), r[5].parse().unwrap())
}

/// Siconos at its defaults against Housner: first impact within 0.05 ms, first amplitude
/// within 0.5 %.
fn agrees_with_housner(scene: &str) {
    require_siconos();
    let out = tmp(scene);
    let st = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .args(["compare"])
        .arg(root().join(format!("validation/scenes/{scene}.toml")))
        .args([
            "--engines",
            "siconos,housner",
            "--reference",
            "housner",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let mut r = csv::Reader::from_path(out.join("metrics.csv")).unwrap();
    let rows: Vec<Vec<String>> = r
        .records()
        .map(|x| x.unwrap().iter().map(String::from).collect())
        .collect();
    let (t1, t1_ref) = metric(&rows, "impact_time_1");
    assert!(
        (t1 - t1_ref).abs() < 0.05e-3,
        "{scene}: first impact {t1} s vs Housner's {t1_ref} s"
    );
    let (a1, a1_ref) = metric(&rows, "peak_amplitude_1");
    assert!(
        (a1 / a1_ref - 1.0).abs() < 5e-3,
        "{scene}: first amplitude {a1} rad vs Housner's {a1_ref} rad"
    );
    // The run's summary records the settings as used and Siconos' version.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("siconos/summary.json")).unwrap())
            .unwrap();
    assert!(
        summary["engine_version"]
            .as_str()
            .unwrap()
            .starts_with("siconos 4."),
        "{summary}"
    );
    for k in [
        "step",
        "theta",
        "scheme",
        "restitution",
        "solver",
        "tolerance",
        "iterations",
        "timeout",
    ] {
        assert!(
            !summary["settings"][k].is_null(),
            "settings.{k} missing: {summary}"
        );
    }
    assert_eq!(summary["settings"]["step"], SICONOS_DEFAULT_STEP);
}

#[test]
fn slender_block_agrees_with_housner_at_the_defaults() {
    agrees_with_housner("housner-slender");
}

#[test]
fn square_block_agrees_with_housner_at_the_defaults() {
    agrees_with_housner("housner-square");
}

fn short(extra: &[&str]) -> rockbench::scene::Scene {
    let mut o = vec!["duration=0.05".to_string()];
    o.extend(extra.iter().map(|s| s.to_string()));
    load_scene_with_overrides(&root().join("validation/scenes/housner-slender.toml"), &o).unwrap()
}

fn failure(r: Result<impl std::fmt::Debug, EngineError>) -> String {
    match r {
        Err(EngineError::Failed { engine, message }) => {
            assert_eq!(engine, "siconos");
            assert!(!message.contains('\n'), "not one line: {message}");
            message
        }
        other => panic!("expected a failed run, got {other:?}"),
    }
}

/// A setting the worker refuses is a scene error naming the field (bad input, as a table
/// checked at load), not a failed run.
#[test]
fn a_bad_setting_is_a_scene_error_naming_the_field() {
    require_siconos();
    let e = engine_by_name("siconos").unwrap();
    for (set, field) in [
        ("siconos.theta=0.2", "siconos.theta"),
        ("siconos.scheme=\"exact\"", "siconos.scheme"),
        ("siconos.iterations=0", "siconos.iterations"),
        ("siconos.solver=\"PATH\"", "siconos.solver"),
        ("siconos.restitution=1.5", "siconos.restitution"),
        ("siconos.tolerance=-1", "siconos.tolerance"),
        ("siconos.sweeps=3", "siconos.sweeps"),
    ] {
        match e.run(&short(&[set])) {
            Err(EngineError::Scene(err)) => {
                assert!(err.field.starts_with("siconos"), "{set}: {err}");
                assert!(err.to_string().contains(field), "{set}: {err}");
                assert_eq!(err.to_string().lines().count(), 1, "{set}: {err}");
            }
            other => panic!("{set}: expected a scene error, got {other:?}"),
        }
    }
    // The step is read here too (it samples the ground motion): a scene error.
    let pulse = load_scene_with_overrides(
        &root().join("validation/scenes/pulse-half-sine-w2-above.toml"),
        &["duration=0.05".into(), "siconos.step=-1e-4".into()],
    )
    .unwrap();
    match e.run(&pulse) {
        Err(EngineError::Scene(err)) => assert_eq!(err.field, "siconos.step"),
        Err(EngineError::Failed { message, .. }) => assert!(message.contains("siconos.step")),
        other => panic!("expected an error naming siconos.step, got {other:?}"),
    }
}

#[test]
fn a_missing_interpreter_says_make_siconos() {
    let e = ExternalEngine::new("siconos")
        .unwrap()
        .with_python("/nonexistent/python");
    let m = failure(e.run(&short(&[])));
    assert!(m.contains("make siconos"), "{m}");
}

#[test]
fn an_interpreter_without_siconos_says_make_siconos() {
    // A python3 without its site packages (no numpy, no siconos): the worker's import fails
    // and says how to install them.
    let dir = tmp("nosiconos");
    let fake = dir.join("python");
    std::fs::write(&fake, "#!/bin/sh\nexec python3 -S \"$@\"\n").unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let e = ExternalEngine::new("siconos").unwrap().with_python(&fake);
    let m = failure(e.run(&short(&[])));
    assert!(m.contains("make siconos"), "{m}");
}

#[test]
fn walls_are_unsupported_not_failed() {
    let scene = load_scene_with_overrides(
        Path::new(&root().join("validation/scenes/running-bond-wall.toml")),
        &["duration=0.05".into()],
    )
    .unwrap();
    let siconos = engine_by_name("siconos").unwrap();
    let known = siconos
        .cannot_model(&scene)
        .expect("a wall is known to be beyond the worker");
    match siconos.run(&scene) {
        Err(EngineError::Unsupported { reason, .. }) => {
            assert!(reason.contains("walls"), "{reason}");
            assert_eq!(reason, known);
        }
        other => panic!("expected unsupported, got {other:?}"),
    }
    // A stack is within it.
    let stack = load_scene_with_overrides(
        Path::new(&root().join("validation/scenes/two-block-free-rocking.toml")),
        &[],
    )
    .unwrap();
    assert_eq!(siconos.cannot_model(&stack), None);
}

#[test]
fn the_default_step_is_the_workers() {
    assert!(
        SICONOS_WORKER.contains(&format!("\"step\": ({SICONOS_DEFAULT_STEP:e},"))
            || SICONOS_WORKER.contains(&format!("\"step\": ({SICONOS_DEFAULT_STEP},")),
        "the worker's default step differs from SICONOS_DEFAULT_STEP = {SICONOS_DEFAULT_STEP}"
    );
    assert_eq!(
        rockbench::bench::step_setting("siconos"),
        Some("siconos.step")
    );
}

#[test]
fn a_run_past_its_timeout_is_killed_and_failed() {
    require_siconos();
    let e = engine_by_name("siconos").unwrap();
    let scene = load_scene_with_overrides(
        &root().join("validation/scenes/housner-slender.toml"),
        &["siconos.timeout=0.5".into()],
    )
    .unwrap();
    let m = failure(e.run(&scene));
    assert!(m.contains("siconos.timeout"), "{m}");
}

/// The two-block case (a stack with an offset-free statue on a pedestal): the pedestal's first
/// ground impact within 1 ms of the native engine's.
#[test]
fn two_block_ground_impact_agrees_with_native() {
    require_siconos();
    let scene = load_scene_with_overrides(
        &root().join("validation/scenes/two-block-free-rocking.toml"),
        &["duration=0.8".into()],
    )
    .unwrap();
    let impact = |name: &str| {
        let (_, s) = rockbench::engines::run_timed(engine_by_name(name).unwrap().as_ref(), &scene)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let b = s.blocks.iter().find(|b| b.name == "pedestal").unwrap();
        *b.impacts
            .first()
            .unwrap_or_else(|| panic!("{name}: no ground impact"))
    };
    let (sic, nat) = (impact("siconos"), impact("native"));
    assert!(
        (sic - nat).abs() < 1e-3,
        "siconos {sic} s vs native {nat} s"
    );
    assert!((0.55..0.65).contains(&sic), "{sic}");
}

/// A block overturned by a pulse has no contact on its side in Siconos' model and falls through
/// the ground: the summary says from when the run leaves the model (a corner 5 % of the block's
/// width below the ground, between the overturn and the end), its events end there, and the
/// overturn, before it, stands, as in Housner's solution.
#[test]
fn a_run_past_its_model_says_where_its_events_end() {
    require_siconos();
    let scene = load_scene_with_overrides(
        &root().join("validation/scenes/pulse-half-sine-w2-above.toml"),
        &["duration=4.5".into()],
    )
    .unwrap();
    let run = |name: &str| {
        rockbench::engines::run_timed(engine_by_name(name).unwrap().as_ref(), &scene)
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .1
    };
    let (sic, housner) = (run("siconos"), run("housner"));
    let overturn = housner.blocks[0]
        .overturn_time
        .expect("Housner: overturned");
    assert!(sic.blocks[0].overturned);
    let until = sic.model_valid_until.expect("the run leaves the model");
    assert!(
        until > overturn && until < scene.duration,
        "{until} vs {overturn}"
    );
    assert!(
        sic.notes
            .iter()
            .any(|n| n.contains("leaves the model") && n.contains("below the ground")),
        "{:?}",
        sic.notes
    );
    assert!(
        sic.blocks[0].max_abs_phi < std::f64::consts::PI,
        "{}",
        sic.blocks[0].max_abs_phi
    );
}
