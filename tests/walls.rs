//! Walls in motion: the sparse back-end and the split into islands against references.
//! The El Centro record comes from `make records`.

mod common;

use rockbench::native::stepper_for;
use rockbench::scene::{Scene, parse_scene_str};
use rockbench::walls::WallSpec;

fn record() -> String {
    common::root()
        .join("validation/records/elcentro-1940.AT2")
        .display()
        .to_string()
}

fn scene(text: &str, set: &[&str]) -> Scene {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    parse_scene_str(text, false, "walls-test", &set).unwrap()
}

/// Positions after `steps` steps.
fn positions(s: &Scene, steps: usize) -> Vec<f64> {
    let (mut stepper, mut state) = stepper_for(s).unwrap();
    for _ in 0..steps {
        stepper.step(&mut state).unwrap();
    }
    state.q
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The 215-block running-bond wall under El Centro x2: the default back-end (sparse, split
/// into islands) and the dense interior-point reference (Clarabel, polished, one problem) give
/// the same positions over the first 200 steps (the wall stands: the record is still weak),
/// and over 200 steps taken from the state at 2.5 s, when the wall rocks and blocks fly.
#[test]
fn the_215_block_wall_matches_the_clarabel_reference_over_200_steps() {
    let mut w = WallSpec::running_bond(10, 21);
    w.record = Some((record(), 2.0));
    let text = w.to_toml();
    let fast = scene(&text, &[]);
    let reference = scene(&text, &["native.solver=\"clarabel\"", "native.islands=false"]);
    let (mut a, mut sa) = stepper_for(&fast).unwrap();
    let (mut b, mut sb) = stepper_for(&reference).unwrap();
    for _ in 0..200 {
        a.step(&mut sa).unwrap();
        b.step(&mut sb).unwrap();
    }
    let d = largest_difference(&sa.q, &sb.q);
    assert!(d < 1e-9, "first 200 steps: largest position difference {d:.3e} m");
    assert_eq!(a.solver_fallbacks(), 0);
    // On to 2.5 s with the default back-end, then 200 steps with each from that state.
    while sa.step < 2500 {
        a.step(&mut sa).unwrap();
    }
    let speed = sa.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(speed > 0.05, "the wall is not in motion at 2.5 s ({speed:.3e})");
    let mut sb = sa.clone();
    let start = sa.q.clone();
    for _ in 0..200 {
        a.step(&mut sa).unwrap();
        b.step(&mut sb).unwrap();
    }
    let moved = largest_difference(&sa.q, &start);
    assert!(moved > 1e-3, "the wall did not move ({moved:.3e} m)");
    let d = largest_difference(&sa.q, &sb.q);
    assert!(d < 1e-8, "200 steps in motion: largest position difference {d:.3e} m (moved {moved:.3e} m)");
    assert_eq!(a.solver_fallbacks(), 0);
}

/// Two columns far apart and a lone block: solving the islands separately gives the
/// same motion as one problem (same back-end), to round-off.
#[test]
fn islands_give_the_answer_of_the_whole_problem() {
    let mut text = String::from("name = \"islands\"\nduration = 1.0\n");
    for (col, x) in [(0, 0.0), (1, 5.0)] {
        for i in 0..6 {
            text += &format!(
                "[[blocks]]\nname = \"k{col}b{i}\"\nwidth = 0.4\nheight = 0.3\nx = {x}\n"
            );
        }
    }
    text += "[[blocks]]\nname = \"lone\"\nwidth = 0.3\nheight = 0.9\nx = 10.0\n";
    text += &format!(
        "[contact]\nfriction = 0.7\n[excitation.horizontal]\nkind = \"record\"\nfile = \"{}\"\nscale = 2.5\n",
        record()
    );
    for solver in ["sparse", "active-set"] {
        let set = format!("native.solver=\"{solver}\"");
        let split = positions(&scene(&text, &[&set]), 700);
        let whole = positions(&scene(&text, &[&set, "native.islands=false"]), 700);
        let start = positions(&scene(&text, &[&set]), 0);
        assert!(largest_difference(&split, &start) > 1e-3, "{solver}: nothing moved");
        let d = largest_difference(&split, &whole);
        assert!(d < 1e-9, "{solver}: islands differ from the whole by {d:.3e}");
    }
}
