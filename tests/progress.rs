//! `rockbench run`'s progress lines: the simulated time reached, on stderr, at most one per
//! `--progress-interval`, none with `--quiet`, and the same answer either way; and a run's
//! observer that asks it to stop (a Ctrl-C in the Python bindings).

mod common;

/// The simulated times of the progress lines of `engine` in `stderr`.
fn reported_times(stderr: &str, engine: &str) -> Vec<f64> {
    stderr
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("{engine}: ")))
        .filter(|l| l.contains(" s simulated ("))
        .map(|l| l.split(" of ").next().unwrap().parse::<f64>().unwrap())
        .collect()
}

fn run(engine: &str, out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let scene = common::root().join("tests/scenes/housner-stocky.toml");
    let o = common::bin()
        .args([
            "run",
            scene.to_str().unwrap(),
            "--engine",
            engine,
            "--set",
            "duration=0.3",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

#[test]
fn a_run_reports_the_simulated_time_it_reached_and_its_answer_does_not_change() {
    let dir = common::tmp("rb-progress", "lines");
    let engines: &[&str] = if cfg!(feature = "rapier") {
        &["native", "rapier"]
    } else {
        &["native"]
    };
    for &engine in engines {
        let loud = run(
            engine,
            &dir.join(format!("{engine}-loud")),
            &["--progress-interval", "0"],
        );
        let times = reported_times(&String::from_utf8_lossy(&loud.stderr), engine);
        assert!(
            times.len() >= 10,
            "{engine}: {} progress lines",
            times.len()
        );
        assert!(
            times.windows(2).all(|w| w[1] > w[0]),
            "{engine}: simulated times not increasing: {times:?}"
        );
        let last = *times.last().unwrap();
        assert!(
            (last - 0.3).abs() < 1e-9,
            "{engine}: the last line says {last}"
        );

        let quiet = run(engine, &dir.join(format!("{engine}-quiet")), &["--quiet"]);
        let said = reported_times(&String::from_utf8_lossy(&quiet.stderr), engine);
        assert!(
            said.is_empty(),
            "{engine}: --quiet printed {} lines",
            said.len()
        );
        let trajectory = |d: &str| std::fs::read(dir.join(d).join("trajectory.csv")).unwrap();
        assert_eq!(
            trajectory(&format!("{engine}-loud")),
            trajectory(&format!("{engine}-quiet")),
            "{engine}: the trajectory changed with the progress lines"
        );
    }
}

#[test]
fn a_negative_progress_interval_is_one_clear_error() {
    let dir = common::tmp("rb-progress", "bad");
    let scene = common::root().join("tests/scenes/housner-stocky.toml");
    let o = common::bin()
        .args([
            "run",
            scene.to_str().unwrap(),
            "--progress-interval=-1",
            "--out",
        ])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--progress-interval"), "{err}");
    assert!(!dir.join("out").exists(), "an output was written");
}

#[test]
fn an_observer_that_asks_to_stop_stops_the_run_there() {
    use rockbench::engines::{EngineError, engine_by_name};
    use std::cell::Cell;
    use std::ops::ControlFlow;
    let path = common::root().join("tests/scenes/housner-stocky.toml");
    let scene =
        rockbench::scene::load_scene_with_overrides(&path, &["duration=2.0".to_string()]).unwrap();
    let engines: &[&str] = if cfg!(feature = "rapier") {
        &["native", "rapier"]
    } else {
        &["native"]
    };
    for &name in engines {
        let engine = engine_by_name(name).unwrap();
        let last_seen = Cell::new(0.0);
        let stop_at_half_a_second = |t: f64| {
            last_seen.set(t);
            if t >= 0.5 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        match engine.run_reporting(&scene, &stop_at_half_a_second) {
            Err(EngineError::Interrupted { engine, t }) => {
                assert_eq!(engine, name);
                assert!((0.5..0.51).contains(&t), "{name}: stopped at {t}");
                assert_eq!(t, last_seen.get(), "{name}: went on after the stop");
            }
            other => panic!("{name}: {:?}", other.map(|o| o.trajectory.t.len())),
        }
    }
}
