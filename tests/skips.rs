//! Work the native engine skips must not change the answer.

use rockbench::engines::{RunOutput, engine_by_name, run_timed};
use rockbench::scene::load_scene_with_overrides;
use rockbench::summary::Summary;
use std::path::Path;

fn run(scene: &str, set: &[&str]) -> (RunOutput, Summary) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("validation/scenes")
        .join(scene);
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let s = load_scene_with_overrides(&p, &set).unwrap();
    run_timed(engine_by_name("native").unwrap().as_ref(), &s).unwrap()
}

fn max_diff(a: &RunOutput, b: &RunOutput) -> f64 {
    assert_eq!(a.trajectory.t.len(), b.trajectory.t.len());
    a.trajectory
        .blocks
        .iter()
        .zip(&b.trajectory.blocks)
        .flat_map(|(x, y)| {
            [(&x.x, &y.x), (&x.z, &y.z), (&x.phi, &y.phi)]
                .into_iter()
                .flat_map(|(u, v)| u.iter().zip(v).map(|(p, q)| (p - q).abs()))
        })
        .fold(0.0, f64::max)
}

#[test]
fn stopping_at_rest_holds_the_state_the_full_run_reaches() {
    let (full, _) = run("two-block-free-rocking.toml", &[]);
    let (short, s) = run("two-block-free-rocking.toml", &["native.stop_at_rest=true"]);
    assert!(
        short.steps < full.steps,
        "{} vs {} steps",
        short.steps,
        full.steps
    );
    assert!(s.notes.iter().any(|n| n.contains("at rest from")));
    let d = max_diff(&full, &short);
    assert!(d < 1e-12, "largest difference {d:e}");
}

#[test]
fn leaving_out_far_contact_points_does_not_change_the_motion() {
    // A reach of 100 block sizes keeps every vertex in the problem.
    for scene in ["two-block-free-rocking.toml", "housner-square.toml"] {
        let (a, _) = run(scene, &["duration=2.0"]);
        let (b, _) = run(scene, &["duration=2.0", "native.contact_reach=100.0"]);
        let d = max_diff(&a, &b);
        assert!(d < 1e-9, "{scene}: largest difference {d:e}");
    }
}

#[test]
fn an_absent_excitation_is_a_zero_excitation() {
    let (a, _) = run("housner-slender.toml", &["duration=1.5"]);
    let (b, _) = run(
        "housner-slender.toml",
        &[
            "duration=1.5",
            "excitation.horizontal.kind=\"rectangular\"",
            "excitation.horizontal.amplitude=0.0",
            "excitation.horizontal.duration=1.0",
        ],
    );
    assert_eq!(max_diff(&a, &b), 0.0);
}

/// `auto` answers a single-block question with the Housner engine, and a stack with the
/// native engine.
#[test]
fn auto_engine_takes_the_housner_fast_path_only_where_it_applies() {
    let load = |name: &str| {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("validation/scenes")
            .join(name);
        load_scene_with_overrides(&p, &[]).unwrap()
    };
    let auto = engine_by_name("auto").unwrap();
    let slender = load("housner-slender.toml");
    let (a, sa) = run_timed(auto.as_ref(), &slender).unwrap();
    let (h, _) = run_timed(engine_by_name("housner").unwrap().as_ref(), &slender).unwrap();
    assert_eq!(a.trajectory, h.trajectory);
    assert!(sa.notes[0].contains("Housner"), "{:?}", sa.notes);
    let stack = load("two-block-free-rocking.toml");
    let (_, ss) = run_timed(auto.as_ref(), &stack).unwrap();
    assert!(
        ss.notes[0].contains("native") && ss.notes[0].contains("2 blocks"),
        "{:?}",
        ss.notes
    );
    let slipping = load_scene_with_overrides(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/housner-square.toml"),
        &["contact.friction=0.3".into()],
    )
    .unwrap();
    let (_, sp) = run_timed(auto.as_ref(), &slipping).unwrap();
    assert!(
        sp.notes[0].contains("native") && sp.notes[0].contains("friction"),
        "{:?}",
        sp.notes
    );
}
