//! Native-engine defects found by the random-scene and stress tests, pinned by regression
//! tests: the dual QP on a step without contacts (now free flight, no QP) and the dual QP
//! without friction (now with an explicit no-tension row).

use rockbench::engines::engine_by_name;
use rockbench::scene::check_scene_str;
use std::path::Path;

/// A 1 x 0.087 m slab tilted 0.21 rad onto its corner and sliding at 0.45 m/s is thrown into
/// the air by associative friction (vz = 0.24 m/s after one step); with the dual (force-based)
/// QP the first step without any contact in reach panics inside Clarabel's qdldl
/// ("index out of bounds: the len is 0 but the index is 0"). The primal QP runs it.
#[test]
fn native_dual_step_without_contacts_does_not_panic() {
    let text = r#"
name = "slab thrown up"
duration = 0.15
output_interval = 0.005
[[blocks]]
name = "b0"
width = 1.0
height = 0.08737635141452439
density = 10.0
[initial]
tilt = 0.21031964322876254
[initial.blocks.b0]
vx = -0.4466833447641569
[contact]
friction = 1.0408723343171289
[native]
theta = 0.5
dt = 0.005
solver = "clarabel"
formulation = "dual"
"#;
    let scene = check_scene_str(text, false, "slab.toml", &[], Path::new(".")).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene);
    assert!(out.is_ok(), "{:?}", out.err());
}

/// The same scene with the primal QP: it runs (the block flies and lands).
#[test]
fn native_primal_runs_the_thrown_slab() {
    let text = r#"
name = "slab thrown up"
duration = 0.15
output_interval = 0.005
[[blocks]]
name = "b0"
width = 1.0
height = 0.08737635141452439
density = 10.0
[initial]
tilt = 0.21031964322876254
[initial.blocks.b0]
vx = -0.4466833447641569
[contact]
friction = 1.0408723343171289
[native]
theta = 0.5
dt = 0.005
"#;
    let scene = check_scene_str(text, false, "slab.toml", &[], Path::new(".")).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene).unwrap();
    // Airborne after the first step: the lowest corner is above the ground.
    assert!(
        out.trajectory.blocks[0].vz[1] > 0.1,
        "{}",
        out.trajectory.blocks[0].vz[1]
    );
}

/// A 1.40 x 1.12 m block tilted -0.033 rad, no friction, theta 0.5, dt 5e-3: with the dual QP
/// the first step slams it flat (phi -0.0326 -> +1.2e-5 rad) with vz = -8.9 m/s and
/// omega = 13 rad/s, creating 5.6 m g H of energy; the primal QP gives phi = -0.03251 rad,
/// omega = 0.046 rad/s. A silent wrong answer of the dual formulation when mu = 0.
#[test]
fn native_dual_frictionless_block_does_not_gain_energy() {
    let run = |formulation: &str| {
        let text = format!(
            "name = \"z\"\nduration = 0.005\noutput_interval = 0.005\n[[blocks]]\nname = \"b0\"\nwidth = 1.3963544808980008\nheight = 1.1241386622693024\ndensity = 10.0\n[initial]\ntilt = -0.032624395728264845\n[contact]\nfriction = 0.0\n[native]\ntheta = 0.5\ndt = 0.005\nsolver = \"clarabel\"\nformulation = \"{formulation}\"\n"
        );
        let scene = check_scene_str(&text, false, "z.toml", &[], Path::new(".")).unwrap();
        engine_by_name("native")
            .unwrap()
            .run(&scene)
            .unwrap()
            .trajectory
    };
    let (p, d) = (run("primal"), run("dual"));
    let (pp, dp) = (p.blocks[0].phi[1], d.blocks[0].phi[1]);
    assert!((pp - dp).abs() < 1e-9, "primal phi {pp}, dual phi {dp}");
}
