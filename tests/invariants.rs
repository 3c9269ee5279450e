//! The invariant checks: they hold on the engines' runs of the validation scenes, and each one
//! fails on a trajectory broken in the way it is meant to catch.

mod common;

use rockbench::engines::{Engine, engine_by_name};
use rockbench::invariants::*;
use rockbench::scene::{Scene, load_scene_with_overrides};
use rockbench::trajectory::Trajectory;
use std::path::Path;

fn scene(name: &str, sets: &[&str]) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("validation/scenes")
        .join(name);
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    load_scene_with_overrides(&p, &sets).unwrap()
}

fn run(engine: &str, s: &Scene) -> Trajectory {
    engine_by_name(engine).unwrap().run(s).unwrap().trajectory
}

fn all_checks(engine: &str, s: &Scene) -> InvariantReport {
    let e: Box<dyn Engine> = engine_by_name(engine).unwrap();
    run_checked(
        e.as_ref(),
        s,
        &Tolerances::default(),
        Extra {
            mirror: true,
            rerun: true,
        },
    )
    .unwrap()
    .1
}

fn assert_all_pass(what: &str, r: &InvariantReport, expect_applies: &[&str]) {
    for c in &r.checks {
        assert!(!c.violated(), "{what}: {} violated: {}", c.name, c.detail);
    }
    for n in expect_applies {
        let c = r.get(n).unwrap_or_else(|| panic!("{what}: no {n} check"));
        assert!(c.applies, "{what}: {n} does not apply: {}", c.detail);
    }
}

#[test]
fn native_and_housner_runs_of_the_slender_block_hold_every_invariant() {
    let s = scene("housner-slender.toml", &["duration=2.0"]);
    for e in ["native", "housner"] {
        let r = all_checks(e, &s);
        assert_all_pass(
            e,
            &r,
            &["finite", "penetration", "energy", "mirror", "rerun"],
        );
        assert!(!r.get("standing").unwrap().applies);
    }
}

#[test]
fn native_run_of_the_two_block_stack_holds_every_invariant() {
    let s = scene("two-block-free-rocking.toml", &["duration=1.5"]);
    let r = all_checks("native", &s);
    assert_all_pass(
        "two-block",
        &r,
        &["finite", "penetration", "energy", "mirror", "rerun"],
    );
    // The mirror comparison covers the motion up to the first impact (~0.6 s).
    assert!(
        r.get("mirror")
            .unwrap()
            .detail
            .contains("first impact at 0.6"),
        "{}",
        r.get("mirror").unwrap().detail
    );
}

#[test]
fn a_standing_column_stays_put() {
    let s = scene(
        "two-block-free-rocking.toml",
        &["duration=1.0", "initial.tilt=0.0"],
    );
    let r = all_checks("native", &s);
    assert_all_pass("standing", &r, &["standing", "energy"]);
    assert!(r.get("standing").unwrap().value < 1e-9);
}

#[test]
fn each_check_fails_on_the_fault_it_is_meant_to_catch() {
    let s = scene("housner-slender.toml", &["duration=1.0"]);
    let tol = Tolerances::default();
    let good = run("housner", &s);
    assert!(check_single(&s, &good, &tol).all_passed());

    // NaN.
    let mut t = good.clone();
    t.blocks[0].vx[10] = f64::NAN;
    assert!(check_finite(&t).violated());

    // Sunk by 1 mm: the lowest corner is 1 mm below the ground (limit 1e-4 * 1 m).
    let mut t = good.clone();
    for z in &mut t.blocks[0].z {
        *z -= 1e-3;
    }
    let c = check_penetration(&s, &t, &tol);
    assert!(c.violated(), "{}", c.detail);
    assert!((c.value - 1e-3).abs() < 1e-9, "{}", c.value);

    // Energy added at one sample.
    let mut t = good.clone();
    t.blocks[0].omega[500] *= 1.01;
    assert!(check_energy(&s, &t, &tol).violated());

    // A mirrored run that is not mirrored.
    assert!(check_mirror(&s, &good, &good, &tol).violated());
    let mut m = good.clone();
    for b in &mut m.blocks {
        for v in
            b.x.iter_mut()
                .chain(&mut b.phi)
                .chain(&mut b.vx)
                .chain(&mut b.omega)
        {
            *v = -*v;
        }
    }
    assert!(!check_mirror(&s, &good, &m, &tol).violated());
    // The window ends before the sample that ends the first impact's step: a difference there
    // is not counted, one on the sample before it is.
    let phi = &good.blocks[0].phi;
    let k1 = (1..phi.len())
        .find(|&k| phi[k] != 0.0 && phi[k].signum() != phi[k - 1].signum())
        .expect("the block rocks through zero");
    let mut after = m.clone();
    after.blocks[0].phi[k1] += 1e-3;
    assert!(!check_mirror(&s, &good, &after, &tol).violated());
    let mut before = m.clone();
    before.blocks[0].phi[k1 - 1] += 1e-3;
    assert!(check_mirror(&s, &good, &before, &tol).violated());

    // A rerun that differs in the last bit.
    let mut t = good.clone();
    t.blocks[0].phi[3] = f64::from_bits(t.blocks[0].phi[3].to_bits() ^ 1);
    assert_eq!(check_rerun(&good, &t).value, 1.0);
    assert!(check_rerun(&good, &t).violated());

    // A standing block that creeps by 2e-9 m.
    let st = scene(
        "housner-slender.toml",
        &["duration=1.0", "initial.tilt=0.0"],
    );
    let mut t = run("native", &st);
    assert!(!check_standing(&st, &t, &tol).violated());
    let n = t.len();
    t.blocks[0].x[n - 1] += 2e-9;
    assert!(check_standing(&st, &t, &tol).violated());
}

#[test]
fn block_block_penetration_is_measured_on_stacked_pairs() {
    let s = scene(
        "two-block-free-rocking.toml",
        &["duration=0.2", "initial.tilt=0.0"],
    );
    let mut t = run("native", &s);
    let (g, p, _) = max_penetration(&s, &t);
    assert!(g < 1e-12 && p < 1e-12, "{g} {p}");
    // Lower the statue by 2 mm into the pedestal.
    for z in &mut t.blocks[1].z {
        *z -= 2e-3;
    }
    let (_, p, where_) = max_penetration(&s, &t);
    assert!((p - 2e-3).abs() < 1e-9, "{p}");
    assert!(where_.contains("`statue` into `pedestal`"), "{where_}");
}

#[test]
fn mirroring_twice_gives_the_scene_back() {
    let s = scene(
        "two-block-free-rocking.toml",
        &["initial.blocks.statue.omega=0.3"],
    );
    let mut m = mirror_scene(&mirror_scene(&s));
    m.name = s.name.clone();
    assert_eq!(m, s);
    let once = mirror_scene(&s);
    assert_eq!(once.initial.tilt, -s.initial.tilt);
    assert_eq!(once.initial.blocks["statue"].omega, -0.3);
}

#[test]
fn the_housner_engine_is_exactly_mirror_symmetric() {
    let s = scene("housner-square.toml", &["duration=2.0"]);
    let a = run("housner", &s);
    let b = run("housner", &mirror_scene(&s));
    for (p, q) in a.blocks[0].phi.iter().zip(&b.blocks[0].phi) {
        assert_eq!(*p, -*q);
    }
}

#[test]
fn standing_applies_only_to_statically_stable_scenes() {
    let s = |sets: &[&str]| scene("two-block-free-rocking.toml", sets);
    assert!(is_standing(&s(&["initial.tilt=0.0"])));
    let offset = |o: f64| {
        let mut sc = s(&["initial.tilt=0.0"]);
        sc.blocks[1].offset = o;
        sc
    };
    // The statue's centre 0.6 m off the 1.25 m pedestal's centre: 0.025 m inside its edge.
    assert!(is_standing(&offset(0.6)));
    // 0.65 m off: beyond the edge, it falls.
    assert!(!is_standing(&offset(0.65)));
    // Every grid column, wall and eccentric post of the stress map is standing.
    for c in rockbench::stress::grid(false) {
        if ["blocks", "wall_courses", "standing_time", "eccentricity"].contains(&c.factor) {
            assert!(
                is_standing(c.scene.as_ref().unwrap()),
                "{}={}",
                c.factor,
                c.label
            );
        }
    }
}

#[test]
fn an_overhanging_block_is_not_standing_and_falls() {
    let dir = common::tmp("rb-overhang", "scene");
    let p = dir.join("overhang.toml");
    std::fs::write(
        &p,
        "name = \"overhang\"\nduration = 0.3\n[[blocks]]\nname = \"b0\"\nwidth = 1.0\nheight = 1.0\n[[blocks]]\nname = \"b1\"\nwidth = 1.0\nheight = 1.0\noffset = 0.6\n",
    )
    .unwrap();
    let s = rockbench::scene::load_scene(&p).unwrap();
    assert!(!is_statically_stable(&s));
    assert!(!is_standing(&s));
    let t = run("native", &s);
    // Its centre of mass 0.1 m beyond the edge: it tips over the right edge.
    assert!(
        t.blocks[1].phi.last().unwrap() < &-0.05,
        "{:?}",
        t.blocks[1].phi.last()
    );
}

/// A small block (H = 0.05 m, H/B = 2.5: p = 16.5 1/s) rocking freely for 4 s, as in the
/// stress map's `size` factor: the step scaled with 1/p (`housner.max_phase_step`, p h <= 3e-4)
/// keeps the energy's growth at round-off. With a fixed RK4 step of 1e-4 s (p h = 1.65e-3) the
/// engine gained 9.4e-9 of m g H between impacts: not the step's error but impacts missed
/// within a step, its half-waves at the end of each sequence of impacts shorter than 1e-4 s
/// (`the_housner_engine_locates_every_impact_of_a_step`). With every impact located, the fixed
/// step keeps it at round-off too.
#[test]
fn housner_step_scales_with_the_frequency_parameter() {
    let s = scene(
        "housner-slender.toml",
        &["blocks[0].width=0.02", "blocks[0].height=0.05"],
    );
    let tol = Tolerances::default();
    let e = engine_by_name("housner").unwrap();
    let out = e.run(&s).unwrap();
    let p = out.settings["p"].as_f64().unwrap();
    assert!((p - 16.530296).abs() < 1e-5, "{p}");
    assert_eq!(out.settings["step"].as_f64().unwrap(), 3e-4 / p);
    let c = check_energy(&s, &out.trajectory, &tol);
    assert!(c.value < 1e-12, "{}", c.detail);
    // The fixed step of 1e-4 s alone.
    let mut fixed = s.clone();
    fixed.set_setting("housner", "max_phase_step", 1.0);
    let out = e.run(&fixed).unwrap();
    assert_eq!(out.settings["step"].as_f64().unwrap(), 1e-4);
    let c = check_energy(&fixed, &out.trajectory, &tol);
    assert!(c.value < 1e-12, "{}", c.detail);
    // The validation blocks keep the 1e-4 s step (p = 2.34 and 2.88 1/s).
    for name in ["housner-slender.toml", "housner-square.toml"] {
        let out = e.run(&scene(name, &[])).unwrap();
        assert_eq!(out.settings["step"].as_f64().unwrap(), 1e-4, "{name}");
    }
}

/// A 1.8 x 0.25 m slab of 108 kg/m^3 tilted 0.072 rad under a block 59 times heavier (mu 1.4,
/// theta 0.5, dt 1e-3): the slipping corners hover on associative dilation and re-close every
/// few steps with no numerical damping, which amplifies round-off by about 1.5 a step. The run
/// and its mirror differ by 2.8e-3 rad before the first impact, and so do runs of the scene
/// shifted sideways (round-off probes): the mirror check measures that amplification and
/// passes. On a motion whose probes stay at round-off, a 1e-4 asymmetry is still caught. The
/// chatter is the paper's stepper's (pinned here); the impact stepper runs this scene and its
/// mirror within 4e-12 rad of each other.
#[test]
fn mirror_check_measures_the_round_off_amplification_of_chattering_contacts() {
    let text = "name = \"slab under a heavy block\"\nduration = 0.2287\noutput_interval = 1.0140901470987518e-3\n\n[[blocks]]\nname = \"b0\"\nwidth = 1.799411840318507\nheight = 0.25096456893501534\ndensity = 108.00361661615838\n\n[[blocks]]\nname = \"b1\"\nwidth = 1.11471029902593\nheight = 1.0\ndensity = 2573.504627253181\noffset = 0.3156341976076833\n\n[initial]\ntilt = 0.07193011417367695\n\n[contact]\nfriction = 1.3988828211722588\n\n[native]\nstepper = \"paper\"\ntheta = 0.5\ndt = 1.0140901470987518e-3\n";
    let s =
        rockbench::scene::check_scene_str(text, false, "slab.toml", &[], Path::new(".")).unwrap();
    let tol = Tolerances::default();
    let e = engine_by_name("native").unwrap();
    let a = e.run(&s).unwrap().trajectory;
    let m = e.run(&mirror_scene(&s)).unwrap().trajectory;
    let plain = check_mirror(&s, &a, &m, &tol);
    assert!(plain.violated() && plain.value > 1e-4, "{}", plain.detail);
    let c = mirror_check_run(e.as_ref(), &s, &a, &m, &tol);
    assert_eq!(c.value, plain.value);
    assert!(!c.violated(), "{}", c.detail);
    assert!(c.limit > 1e-5 && c.limit > c.value, "{}", c.detail);

    // The slender block rocking freely: its probes stay at round-off, so a mirrored run off by
    // 1e-4 rad at one sample before the impact is a violation.
    let s = scene("housner-slender.toml", &["duration=0.4"]);
    let a = run("native", &s);
    let mut m = run("native", &mirror_scene(&s));
    let plain = check_mirror(&s, &a, &m, &tol);
    assert!(!plain.violated(), "{}", plain.detail);
    m.blocks[0].phi[200] -= 1e-4;
    let len = largest_dimension(&s);
    let probes: Vec<(f64, Trajectory)> = PROBE_SHIFTS
        .iter()
        .map(|f| (f * len, run("native", &shifted_scene(&s, f * len))))
        .collect();
    let c = check_mirror_with_probes(&s, &a, &m, &probes, &tol);
    assert!(c.violated(), "{}", c.detail);
    assert_eq!(c.limit, tol.mirror_rel, "{}", c.detail);
}

/// `rockbench stress` exits 0 when every engine keeps its contract, and 1 (one line) when a
/// contract is broken: rapier's settling column is within its soft-contact contract, not
/// within round-off. The runs are kept in the run store and read back by the later maps, which
/// judge them afresh against the contract they are given.
#[test]
fn stress_exits_on_a_broken_contract_only() {
    let scratch = common::tmp("rb-stress", "contract");
    let out = scratch.join("out");
    let store = scratch.join("store");
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_rockbench"))
            .args([
                "stress",
                "--quick",
                "--engines",
                "native,rapier",
                "--factors",
                "blocks",
            ])
            .args(["--out", out.to_str().unwrap()])
            .args(["--cache-dir", store.to_str().unwrap()])
            .args(extra)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let o = run(&[]);
    let so = String::from_utf8_lossy(&o.stdout);
    if !so.contains("rapier   blocks") {
        eprintln!("skipped: rapier not built");
        return;
    }
    assert!(
        o.status.success(),
        "{so}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        so.contains("standing") && so.contains("beyond round-off"),
        "{so}"
    );
    assert!(
        so.contains("rapier: soft contact"),
        "the closing note lists the contracts: {so}"
    );
    assert!(!so.contains("(stored)"), "{so}");
    let first_csv = std::fs::read_to_string(out.join("stress.csv")).unwrap();
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(index.contains("id=\"contract-rapier\""));
    // Again: every run from the store, the same map.
    let o = run(&[]);
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{so}");
    let cells = so.lines().filter(|l| l.contains(" blocks ")).count();
    assert!(cells > 0 && so.matches("(stored)").count() == cells, "{so}");
    assert_eq!(
        std::fs::read_to_string(out.join("stress.csv")).unwrap(),
        first_csv
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stress.json")).unwrap()).unwrap();
    assert_eq!(json["runs_from_store"].as_u64(), Some(cells as u64));
    let o = run(&["--contract", "rapier.standing=1e-9"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("broken contract"), "{err}");
    let csv = std::fs::read_to_string(out.join("rapier.csv")).unwrap();
    assert!(
        csv.lines().skip(1).any(|l| l.contains(",standing,")),
        "{csv}"
    );
    let o = run(&["--contract", "rapier.nope=1"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--contract rapier.nope=1"), "{err}");
}

/// At the end of a sequence of impacts a half-wave (`2 |omega| / (p^2 sin alpha)`) can be
/// shorter than the rest of the step in which an impact falls. Integrated on past zero on the
/// old pivot, with only its angle clamped, the block kept a velocity it could not have: a block
/// of 0.411 x 0.768 m released at 3.78e-3 rad (`make proptest`) gained 1.14e-9 of `m g H` at its
/// last sample (0.19269 s, omega 3.5e-4 rad/s at phi = 0), and the slender validation block kept
/// 1.1e-4 rad/s at rest from 3.29 s. Every crossing within a step is now an impact: the energy
/// never grows, and the blocks end at rest.
#[test]
fn the_housner_engine_locates_every_impact_of_a_step() {
    let text = "name = \"tilted\"\nduration = 0.192690614740759\noutput_interval = \
                1.2191168540186086e-3\n[[blocks]]\nname = \"b0\"\nwidth = 0.41139587393677846\n\
                height = 0.7676484352030135\ndensity = 10.0\n[initial]\n\
                tilt = -3.782914927233267e-3\n";
    let tilted = rockbench::scene::parse_scene_str(text, false, "tilted", &[]).unwrap();
    let slender = scene("housner-slender.toml", &[]);
    for s in [&tilted, &slender] {
        let tr = run("housner", s);
        let energy = check_energy(s, &tr, &Tolerances::default());
        assert!(energy.value < 1e-12, "{}: {}", s.name, energy.detail);
        let last = tr.len() - 1;
        let b = &tr.blocks[0];
        assert_eq!(
            (b.phi[last], b.vx[last], b.vz[last], b.omega[last]),
            (0.0, 0.0, 0.0, 0.0),
            "{}: not at rest at its end",
            s.name
        );
    }
}
