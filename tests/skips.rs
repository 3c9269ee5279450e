//! Work the native engine skips must not change the answer.

use rockbench::engines::{RunOutput, engine_by_name, run_timed};
use rockbench::geometry::{Placed, Pose, Rect, broad_phase};
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

/// The grid broad phase finds exactly the pairs an all-pairs test finds: random layouts of
/// few and many blocks of similar and of very different sizes, and a running-bond wall whose
/// blocks touch exactly (closed intervals).
#[test]
fn broad_phase_equals_all_pairs() {
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut layouts: Vec<(Vec<Rect>, Vec<Pose>)> = Vec::new();
    for case in 0..80 {
        let n = [5, 30, 200][case % 3];
        let spread = if case % 2 == 0 { 1.0 } else { 8.0 };
        let rects: Vec<Rect> = (0..n)
            .map(|_| Rect {
                b: 0.05 + spread * rnd() * rnd(),
                h: 0.05 + spread * rnd() * rnd(),
            })
            .collect();
        let poses: Vec<Pose> = (0..n)
            .map(|_| Pose {
                x: 20.0 * rnd(),
                z: 5.0 * rnd(),
                phi: rnd() - 0.5,
            })
            .collect();
        layouts.push((rects, poses));
    }
    let (mut rects, mut poses) = (Vec::new(), Vec::new());
    for c in 0..12 {
        for i in 0..15 {
            rects.push(Rect { b: 0.6, h: 0.25 });
            let shift = if c % 2 == 1 { 0.3 } else { 0.0 };
            poses.push(Pose {
                x: 0.3 + 0.6 * i as f64 + shift,
                z: 0.125 + 0.25 * c as f64,
                phi: 0.0,
            });
        }
    }
    layouts.push((rects, poses));
    for (rects, poses) in &layouts {
        let n = rects.len();
        let margin = |_: usize| 0.05;
        let placed: Vec<Placed> = rects
            .iter()
            .zip(poses)
            .map(|(r, p)| Placed::new(r, p))
            .collect();
        let got = broad_phase(&placed, &margin);
        let bb = |i: usize| {
            let v = rects[i].vertices(&poses[i]);
            let xs = v.iter().map(|p| p.0);
            let zs = v.iter().map(|p| p.1);
            (
                xs.clone().fold(f64::INFINITY, f64::min) - 0.05,
                xs.fold(f64::NEG_INFINITY, f64::max) + 0.05,
                zs.clone().fold(f64::INFINITY, f64::min) - 0.05,
                zs.fold(f64::NEG_INFINITY, f64::max) + 0.05,
            )
        };
        let mut want = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (bb(i), bb(j));
                if a.0 <= b.1 && b.0 <= a.1 && a.2 <= b.3 && b.2 <= a.3 {
                    want.push((i, j));
                }
            }
        }
        assert!(!want.is_empty() || n < 10);
        assert_eq!(got, want, "{n} blocks");
    }
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
