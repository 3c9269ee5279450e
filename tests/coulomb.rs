//! Non-associative (Coulomb) friction (`native.friction_law = "coulomb"`): the sliding block's
//! stopping distance and the absence of lift, identity with the associative law where nothing
//! slides, the back-ends against each other, and a failure naming its step.

use rockbench::engines::{engine_by_name, run_timed};
use rockbench::native::coulomb::{
    Coulomb, CoulombMethod, LEMKE_MAX_UNKNOWNS, lemke_pivot_budget, lemke_step,
};
use rockbench::native::solver::{ActiveSetSolver, SparseSolver};
use rockbench::native::stepper_for;
use rockbench::native::{StepProblem, StepSolution};
use rockbench::scene::{Scene, load_scene_with_overrides, parse_scene_str};
use rockbench::trajectory::Trajectory;
use rockbench::walls::WallSpec;
use std::path::Path;

mod common;

fn scene_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("validation/scenes/{name}.toml"))
}

fn run(name: &str, set: &[&str]) -> Trajectory {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let s = load_scene_with_overrides(&scene_path(name), &set).unwrap();
    run_timed(engine_by_name("native").unwrap().as_ref(), &s)
        .unwrap_or_else(|e| panic!("{name} {set:?}: {e}"))
        .0
        .trajectory
}

/// Largest rotation difference over every block and sample, rad.
fn max_rotation_difference(a: &Trajectory, b: &Trajectory) -> f64 {
    let mut m = 0.0f64;
    for (ba, bb) in a.blocks.iter().zip(&b.blocks) {
        assert_eq!(ba.phi.len(), bb.phi.len());
        for (p, q) in ba.phi.iter().zip(&bb.phi) {
            m = m.max((p - q).abs());
        }
    }
    m
}

const COULOMB: &str = "native.friction_law=\"coulomb\"";

/// sliding-block (2 m/s, mu 0.5): the block stops at v^2 / (2 mu g) and its centre stays at
/// its resting height. The impact stepper (midpoint kinematics) and the position stepper at
/// theta 1/2 are within 1e-5 m of the closed form at dt 1e-3; the position stepper at theta
/// 0.7 falls short by its first-order `(theta - 1/2) v0 dt` (4e-4 m, as under the associative law).
#[test]
fn sliding_block_stops_at_the_closed_form_distance_without_lift() {
    let (v0, mu, g) = (2.0, 0.5, 9.81);
    let want = v0 * v0 / (2.0 * mu * g);
    for (stepper, theta, short) in [
        ("position", 0.5, 0.0),
        ("position", 0.7, 0.2 * v0 * 1e-3),
        ("impact", 0.5, 0.0),
    ] {
        for solver in ["active-set", "sparse", "clarabel"] {
            let st = format!("native.stepper=\"{stepper}\"");
            let th = format!("native.theta={theta}");
            let sv = format!("native.solver=\"{solver}\"");
            let tr = run("sliding-block", &[COULOMB, &st, &th, &sv]);
            let b = &tr.blocks[0];
            let x = *b.x.last().unwrap();
            let lift = b.z.iter().fold(0.0f64, |m, z| m.max((z - 0.25).abs()));
            eprintln!(
                "{stepper} theta {theta} {solver}: stopped at {x:.9} m (closed form {want:.9}, short by {:.3e}), |z - 0.25| <= {lift:.2e} m",
                want - x
            );
            assert!(
                (want - x - short).abs() < 1e-5,
                "{stepper} theta {theta} {solver}: stopped at {x} m, closed form {want} m"
            );
            if stepper == "impact" || theta > 0.5 {
                // (The position stepper at theta 1/2 leaves the velocity of a stopped block
                // alternating in sign; the impact stepper stops it in the step its slip stops.)
                assert!(b.vx.last().unwrap().abs() < 1e-9, "still moving");
            }
            if stepper == "impact" {
                let spin = b.omega.iter().fold(0.0f64, |m, w| m.max(w.abs()));
                assert!(spin < 1e-12, "{solver}: the block turns, {spin} rad/s");
            }
            assert!(
                lift < 1e-9,
                "{stepper} {solver}: centre off its resting height by {lift} m"
            );
        }
    }
}

/// The associative law lifts the sliding block by millimetres; Coulomb's does not (the same
/// scene, the same check as above, so the check can fail).
#[test]
fn the_associative_law_lifts_the_sliding_block() {
    let b = &run("sliding-block", &[]).blocks[0];
    let lift = b.z.iter().fold(0.0f64, |m, z| m.max(z - 0.25));
    assert!(lift > 1e-3, "associative lift {lift} m");
}

/// Where nothing slides (Housner's blocks at the scenes' mu 0.7, above the 0.29 and 0.60 that
/// their impacts need, and at 1.0 and 2.0) the two laws give the same rotation history to
/// 1e-9 rad under both steppers (the impact stepper settles the end velocity of a point that
/// did not slip as under the associative law). One exception, measured and bounded instead: the slender
/// block under the position stepper at mu 1.0 and 2.0 lands nearly flat late in its motion
/// (|phi| ~ 1e-5 rad, t ~ 2.9 s), in a step that closes both corners and reverses the rotation
/// (the position law's rebound): a corner slips by ~1e-10 m, which the associative law turns
/// into lift and Coulomb's does not; 2.8e-9 and 5.5e-9 rad apart by the end.
#[test]
fn housner_blocks_at_high_friction_move_as_under_the_associative_law() {
    for name in ["housner-slender", "housner-square"] {
        for stepper in ["position", "impact"] {
            for mu in ["0.7", "1.0", "2.0"] {
                let st = format!("native.stepper=\"{stepper}\"");
                let f = format!("contact.friction={mu}");
                let a = run(name, &[&st, &f]);
                let c = run(name, &[&st, &f, COULOMB]);
                let d = max_rotation_difference(&a, &c);
                let peak = a.blocks[0].phi.iter().fold(0.0f64, |m, p| m.max(p.abs()));
                eprintln!(
                    "{name} {stepper} mu {mu}: largest difference {d:.2e} rad (peak |phi| {peak:.3})"
                );
                assert!(peak > 0.1, "{name}: the block does not rock");
                let tol = if name == "housner-slender" && stepper == "position" && mu != "0.7" {
                    1e-8
                } else {
                    1e-9
                };
                assert!(d < tol, "{name} {stepper} mu {mu}: laws differ by {d} rad");
            }
        }
    }
}

/// A random 4-block stack (tilted 0.33 rad, mu 1.2, theta 1, dt 5.7e-4) whose first step the
/// slip-offset iteration does not settle (measured: the offsets still change by 4e-6 m after
/// 100 solves): Lemke's method solves that step (its answer checked against the law inside),
/// the run completes and the Lemke step agrees with the law here too: no point penetrates or
/// lifts while loaded, and the sliding points' friction opposes their slip.
#[test]
fn the_step_the_fixed_point_does_not_settle_is_solved_by_lemke() {
    let scene = parse_scene_str(UNSETTLED, false, "unsettled", &[]).unwrap();
    let (st, state) = stepper_for(&scene).unwrap();
    let pr = st.next_problem(&state);
    // The fast path does not settle on this step (so the solve goes on to Lemke's method)...
    let mut fp = Coulomb::default();
    let mut dense = ActiveSetSolver::new();
    let sol = fp.solve(&mut dense, &pr).unwrap();
    assert_eq!(fp.lemke_solves, 1, "the fixed point settled");
    check_coulomb("fixed point then Lemke", &pr, &sol);
    // ...and Lemke's method alone gives the same step.
    let (l, pivots) = lemke_step(&pr).unwrap();
    eprintln!("Lemke: {pivots} pivots, {} points", pr.contacts.len());
    assert_eq!(l.dq, sol.dq);
    let out = run_timed(engine_by_name("native").unwrap().as_ref(), &scene)
        .unwrap()
        .0;
    let note = out.notes.join(" ");
    assert!(note.contains("solved by Lemke's method"), "{note}");
    assert!(!note.contains(" 0 solved by Lemke's method"), "{note}");
}

/// Coulomb's law on a solved step, to 1e-9 of the problem's scales; lengths also to 1e-12 m,
/// the fixed point's accuracy (`COULOMB_TOLERANCE (1 + s / COULOMB_SCALE)` for slips s up to
/// 1e-3 m).
fn check_coulomb(who: &str, pr: &StepProblem, sol: &StepSolution) {
    let dot = |r: &[(usize, f64)], x: &[f64]| r.iter().map(|&(i, c)| c * x[i]).sum::<f64>();
    let fmax = sol.normal.iter().fold(1e-30f64, |m, n| m.max(n.abs()));
    // Lengths: the step's largest displacement, at least what gravity alone gives in a step.
    let dmax = sol
        .dq
        .iter()
        .fold(10.0 * pr.dt * pr.dt, |m, d| m.max(d.abs()));
    for (k, c) in pr.contacts.iter().enumerate() {
        let (n, t) = (sol.normal[k], sol.tangential[k]);
        let dn = c.g_n + dot(&c.nrow, &sol.dq);
        let dt = c.g_t + dot(&c.trow, &sol.dq);
        assert!(
            n >= 0.0 && dn > -1e-9 * dmax - 1e-12,
            "{who} point {k}: N {n}, d_n {dn}"
        );
        if n > 1e-9 * fmax {
            assert!(
                dn.abs() < 1e-9 * dmax + 1e-12,
                "{who} point {k}: loaded and open by {dn}"
            );
        }
        assert!(
            t.abs() <= c.mu * n + 1e-9 * fmax,
            "{who} point {k}: T {t} outside the cone"
        );
        if dt.abs() > 1e-9 * dmax + 1e-12 && n > 1e-9 * fmax {
            assert!(
                (t + c.mu * n * dt.signum()).abs() < 1e-9 * fmax,
                "{who} point {k}: slides by {dt} with T {t}, N {n}"
            );
        }
    }
}

/// Two independent solutions of every step's Coulomb problem: the slip-offset fixed point on
/// the dense active-set back-end and Lemke's method on the LCP, on the first 0.8 s of the
/// two-block case (rocking, impacts, both steppers), the sliding block, the stack above and
/// the first 0.12 s of the 22-block wall sliding whole; the displacements agree to 1e-9 of
/// the step's largest plus the fixed point's own 1e-12 m (a point's tangential force at a flat
/// interface is not unique, its motion is), and both satisfy the law. Lemke's method takes
/// at most half its pivot budget on every problem (measured: at most 0.13 of it).
#[test]
fn lemke_and_the_fixed_point_agree_on_every_step() {
    let cases: Vec<(Scene, usize)> = vec![
        (
            load_scene_with_overrides(&scene_path("two-block-free-rocking"), &[COULOMB.into()])
                .unwrap(),
            800,
        ),
        (
            load_scene_with_overrides(
                &scene_path("two-block-free-rocking"),
                &[COULOMB.into(), "native.stepper=\"impact\"".into()],
            )
            .unwrap(),
            800,
        ),
        (
            load_scene_with_overrides(&scene_path("sliding-block"), &[COULOMB.into()]).unwrap(),
            500,
        ),
        (
            parse_scene_str(UNSETTLED, false, "unsettled", &[]).unwrap(),
            330,
        ),
        (
            load_scene_with_overrides(&scene_path("wall-sliding-whole"), &[COULOMB.into()])
                .unwrap(),
            120,
        ),
    ];
    for (scene, steps) in cases {
        let (mut st, mut s) = stepper_for(&scene).unwrap();
        let mut fp = Coulomb::default();
        let mut dense = ActiveSetSolver::new();
        let mut worst = 0.0f64;
        let mut compared = 0;
        // Lemke's pivots as a share of its budget (the largest over the problems).
        let mut budget_used = 0.0f64;
        for _ in 0..steps {
            let pr = st.next_problem(&s);
            if !pr.contacts.is_empty() {
                let (l, pivots) = lemke_step(&pr).unwrap();
                let unknowns =
                    pr.contacts.len() + 3 * pr.contacts.iter().filter(|c| c.mu > 0.0).count();
                budget_used = budget_used.max(pivots as f64 / lemke_pivot_budget(unknowns) as f64);
                check_coulomb("Lemke", &pr, &l);
                if let Ok(f) = fp.solve(&mut dense, &pr) {
                    check_coulomb("fixed point", &pr, &f);
                    let scale =
                        f.dq.iter()
                            .fold(10.0 * pr.dt * pr.dt, |m, d| m.max(d.abs()));
                    // The fixed point settles the offsets to 1e-13 m (1 + s / 1e-4 m).
                    for (a, b) in l.dq.iter().zip(&f.dq) {
                        worst = worst.max((a - b).abs() / (1e-9 * scale + 1e-12));
                    }
                    compared += 1;
                }
            }
            st.step(&mut s).unwrap();
        }
        eprintln!(
            "{}: {compared} problems compared, largest difference {worst:.2e} of 1e-9 of the step + 1e-12 m, at most {budget_used:.3} of Lemke's pivot budget",
            scene.name
        );
        assert!(compared > steps / 2);
        // Every answer well within the budget: an attempt that runs to it has lost its way.
        assert!(budget_used < 0.5, "{}: {budget_used}", scene.name);
        assert!(worst < 1.0, "{}: {worst}", scene.name);
    }
}

/// Lemke's method alone (no fixed point) on the sliding block: the same stopping distance
/// (within 1e-5 m of v^2 / (2 mu g) under the impact stepper) and no lift.
#[test]
fn lemke_alone_stops_the_sliding_block_at_the_closed_form_distance() {
    let scene = load_scene_with_overrides(
        &scene_path("sliding-block"),
        &[COULOMB.into(), "native.stepper=\"impact\"".into()],
    )
    .unwrap();
    let (mut st, mut s) = stepper_for(&scene).unwrap();
    st.coulomb.method = CoulombMethod::Lemke;
    let mut lift = 0.0f64;
    while s.t < scene.duration - 1e-9 {
        st.step(&mut s).unwrap();
        lift = lift.max((s.q[1] - 0.25).abs());
    }
    let want = 2.0 * 2.0 / (2.0 * 0.5 * 9.81);
    eprintln!(
        "Lemke alone: stopped at {:.9} m, |z - 0.25| <= {lift:.2e} m",
        s.q[0]
    );
    assert_eq!(st.coulomb.lemke_solves, st.coulomb.problems);
    assert!((s.q[0] - want).abs() < 1e-5, "{} vs {want}", s.q[0]);
    assert!(lift < 1e-9, "{lift}");
}

const UNSETTLED: &str = r#"name = "random"
duration = 1.8943207076912374e-1
gravity = 9.81e0
output_interval = 5.725058733987224e-4

[[blocks]]
name = "b0"
width = 5.632392885666264e-1
height = 7.24583469876297e-2
density = 2.723575916214896e3
offset = 1.420519492352133e-1

[[blocks]]
name = "b1"
width = 5.09879603164716e-1
height = 1.05401127614813e0
density = 3.194680944458047e3
offset = -1.1343323282196358e-1

[[blocks]]
name = "b2"
width = 2.1987835454172058e0
height = 9.364980053020877e-2
density = 5.345718704923555e2
offset = -2.0758365536421777e-1

[[blocks]]
name = "b3"
width = 1.5319996592700909e0
height = 8.177618909402884e-1
density = 2.4650478418793963e1
offset = -1.0510205316549308e-1

[initial]
tilt = -3.3426096987493475e-1

[initial.blocks.b0]
rotation = 0e0
omega = 0e0
vx = 4.581032393022421e-1

[initial.blocks.b1]
rotation = 0e0
omega = 0e0
vx = 0e0

[initial.blocks.b2]
rotation = 1.294351433409809e-1
omega = 0e0
vx = 0e0

[initial.blocks.b3]
rotation = -1.283487397065175e-1
omega = 0e0
vx = -1.2740940077154775e-1

[contact]
friction = 1.2054895718611291e0

[contact.interfaces.b3]
friction = 2.99554731989464e-1

[native]
# found by `make proptest` under the paper's stepper, whose step problems these tests solve
stepper = "paper"
solver = "auto"
theta = 1e0
dt = 5.725058733987224e-4
formulation = "dual"
friction_law = "coulomb"
"#;

/// The two-block case at mu 0.7 with Coulomb friction: the sparse back-end (and Clarabel,
/// position stepper) against the dense one. Measured: position stepper 4.4e-13 (sparse) and
/// 1.7e-13 rad (Clarabel) up to the statue's first impact (0.6 s), 8.0e-10 and 1.1e-9 rad at
/// 1 s; impact stepper, sparse, 8.5e-12 and 6.1e-9 rad. (Clarabel with the impact stepper
/// is 1.9e-6 rad off by 0.6 s: its interior-point forces decide a located impact
/// differently, as under the associative law.)
/// The impact stepper as it is now, sparse: 1.6e-12 rad to 0.6 s and 1.5e-11 rad to 1 s.
#[test]
fn back_ends_agree_on_the_two_block_case_with_coulomb_friction() {
    let max_diff = |a: &Trajectory, b: &Trajectory, until: f64| -> f64 {
        let mut m = 0.0f64;
        for (ba, bb) in a.blocks.iter().zip(&b.blocks) {
            for (k, (p, q)) in ba.phi.iter().zip(&bb.phi).enumerate() {
                if a.t[k] <= until + 1e-9 {
                    m = m.max((p - q).abs());
                }
            }
        }
        m
    };
    for (stepper, solver, before, after) in [
        ("position", "sparse", 1e-11, 1e-8),
        ("position", "clarabel", 1e-11, 1e-8),
        ("impact", "sparse", 1e-9, 1e-7),
    ] {
        let st = format!("native.stepper=\"{stepper}\"");
        let dense = run(
            "two-block-free-rocking",
            &[COULOMB, &st, "duration=1.0", "native.solver=\"active-set\""],
        );
        let sv = format!("native.solver=\"{solver}\"");
        let other = run(
            "two-block-free-rocking",
            &[COULOMB, &st, "duration=1.0", &sv],
        );
        let (d1, d2) = (max_diff(&dense, &other, 0.6), max_diff(&dense, &other, 1.0));
        eprintln!("{stepper} {solver}: {d1:.2e} rad to 0.6 s, {d2:.2e} rad to 1 s");
        assert!(d1 < before && d2 < after, "{stepper} {solver}: {d1}, {d2}");
    }
}

/// A random stack from `make proptest` whose mirrored run failed at step 2: the fixed point
/// creeps (still 7e-12 m after 40 solves) and Lemke's method with a pivot tolerance of 1e-9
/// pivots on a round-off entry (7e-6 m penetration, caught by the check); with the next
/// tolerance pair it solves the step. The mirrored run and the run itself complete.
#[test]
fn the_mirrored_random_stack_runs_through_lemke() {
    let scene = parse_scene_str(MIRRORED, false, "mirrored", &[]).unwrap();
    for (k, s) in [rockbench::invariants::mirror_scene(&scene), scene]
        .iter()
        .enumerate()
    {
        let out = run_timed(engine_by_name("native").unwrap().as_ref(), s)
            .unwrap_or_else(|e| panic!("{e}"))
            .0;
        let notes = out.notes.join("; ");
        eprintln!("{notes}");
        if k == 0 {
            assert!(!notes.contains(" 0 solved by Lemke"), "{notes}");
        }
    }
}

const MIRRORED: &str = r#"name = "random"
duration = 1e-2
gravity = 9.81e0
output_interval = 1.114957184526186e-3

[[blocks]]
name = "b0"
width = 4.837412383706373e-1
height = 1e0
density = 3.006034002968289e2
offset = 0e0

[[blocks]]
name = "b1"
width = 1e0
height = 5.850770202276096e-2
density = 1.832344214593523e2
offset = 1.4288590361255657e-1

[[blocks]]
name = "b2"
width = 1e0
height = 1.3456768007052186e-1
density = 6.072131659140416e2
offset = -3.703690714163645e-1

[[blocks]]
name = "b3"
width = 1.9779539917988074e0
height = 7.099148684338151e-1
density = 4.044835782785327e3
offset = -1.1246133300931829e-1

[initial]
tilt = -1.299497111787646e-1

[initial.blocks.b0]
rotation = 0e0
omega = 0e0
vx = 0e0

[initial.blocks.b1]
rotation = 0e0
omega = -9.03935136229939e-1
vx = 2.4849164455925898e-1

[initial.blocks.b2]
rotation = -9.544677646893256e-3
omega = 0e0
vx = 3.014374194577913e-1

[initial.blocks.b3]
rotation = 0e0
omega = 0e0
vx = -9.16260646083452e-2

[contact]
friction = 1.6078953530464082e0

[native]
# found by `make proptest` under the paper's stepper, whose step problems these tests solve
stepper = "paper"
solver = "auto"
theta = 8.289334362928629e-1
dt = 1.114957184526186e-3
formulation = "primal"
friction_law = "coulomb"
"#;

/// A random stack from `make proptest` (theta 0.5, 3 blocks) whose step 172 the fixed point
/// does not settle and which Lemke's method solves only with a pivot tolerance of 1e-5 (at
/// 1e-11 to 1e-7 it ends on a false ray or pivots on round-off; checked against an exact
/// rational solution): the run completes, with Lemke's method on 4 steps.
#[test]
fn a_random_stack_needing_a_wide_pivot_tolerance_runs_through_lemke() {
    let scene = parse_scene_str(WIDE_PIVOT, false, "wide-pivot", &[]).unwrap();
    let out = run_timed(engine_by_name("native").unwrap().as_ref(), &scene)
        .unwrap_or_else(|e| panic!("{e}"))
        .0;
    let notes = out.notes.join("; ");
    eprintln!("{notes}");
    assert!(!notes.contains(" 0 solved by Lemke"), "{notes}");
}

const WIDE_PIVOT: &str = r#"name = "random"
duration = 2.2078621677631627e-1
gravity = 2.7712333448770634e0
output_interval = 1.2376387660026395e-3

[[blocks]]
name = "b0"
width = 2.9351085532580756e-1
height = 3.906171043130434e0
density = 5.131235453612536e2
offset = 5.3284653318879235e-3

[[blocks]]
name = "b1"
width = 3.1793215502337335e-1
height = 1.5878017128238886e-1
density = 6.791849464707875e1
offset = -2.724122841998121e-2

[[blocks]]
name = "b2"
width = 1.5752572078710356e0
height = 2.5836377421257295e-1
density = 9.200845634346057e2
offset = 9.520398757199554e-2

[initial]
tilt = 4.6582449015135724e-2

[initial.blocks.b0]
rotation = 0e0
omega = -1.8714432033430023e-1
vx = -1.5488010793658813e-1

[initial.blocks.b1]
rotation = -7.12320409824387e-2
omega = 0e0
vx = 3.076234718875278e-1

[initial.blocks.b2]
rotation = 0e0
omega = 0e0
vx = 0e0

[contact]
friction = 3.9979342028590936e-1

[contact.interfaces.b2]
friction = 1.2502443177507454e0

[native]
# found by `make proptest` under the paper's stepper, whose step problems these tests solve
stepper = "paper"
solver = "auto"
theta = 5e-1
dt = 1.2376387660026395e-3
formulation = "dual"
friction_law = "coulomb"

[excitation]
applied_as = "moving-ground"

[excitation.horizontal]
kind = "one-sine"
amplitude = -1.8635473397950317e1
duration = 5.800492827628907e-1
start = 4.6871818064231116e-2
"#;

/// The two-block case at mu 0.7 with Coulomb friction under the impact stepper converges:
/// the pedestal's ground impact and the statue's first five crossings (events of the run
/// summary) move by less than 0.1 ms between dt 1e-3 and 2.5e-4. Measured: at most 1.3 us
/// (0.605648 s; 0.618260, 1.746322, 2.474495, 3.004316, 3.406421 s at 2.5e-4); Siconos at
/// step 1e-4 gives 0.6182, 1.7461, 2.4743, 3.0040, 3.4059 s (docs/method.md).
#[test]
fn the_two_block_case_converges_with_coulomb_friction_under_the_impact_stepper() {
    let events = |dt: &str| {
        let set = [
            COULOMB.to_string(),
            "native.stepper=\"impact\"".to_string(),
            format!("native.dt={dt}"),
        ];
        common::two_block_events(&set, 5)
    };
    let (coarse, fine) = (events("1e-3"), events("2.5e-4"));
    for (k, (a, b)) in coarse.iter().zip(&fine).enumerate() {
        eprintln!("event {k}: {a:.6} s at dt 1e-3, {b:.6} s at 2.5e-4");
        assert!((a - b).abs() < 1e-4, "event {k}: {a} s against {b} s");
    }
}

/// The first step of a 215-block wall sliding whole (10 courses of 21, joints at 0.7 on a
/// ground at 0.5, a pulse of 0.8 g; 1208 points, an LCP of 4832 unknowns, beyond Lemke's dense
/// method), solved by a back-end whose displacements carry alternating round-off: at 1e-12 m
/// (its slips of some 3e-7 m settle to `COULOMB_TOLERANCE` 1e-13 m, to `COULOMB_ROUNDOFF`
/// 1e-11 m) the offsets cannot settle and the least-changed iterate is accepted at the
/// back-ends' row tolerance, no loaded point lifting or sinking by more; at 1e-9 m it is not,
/// and the step fails naming both reasons.
#[test]
fn offsets_that_round_off_keeps_from_settling_are_accepted_at_the_row_tolerance() {
    let wall = WallSpec::sliding_whole(10, 21);
    let scene = parse_scene_str(&wall.to_toml(), false, "wall", &[COULOMB.into()]).unwrap();
    let (st, state) = stepper_for(&scene).unwrap();
    let pr = st.next_problem(&state);
    assert!(4 * pr.contacts.len() > LEMKE_MAX_UNKNOWNS);
    let dot = |r: &[(usize, f64)], x: &[f64]| r.iter().map(|&(i, c)| c * x[i]).sum::<f64>();
    for (eps, settles) in [(1e-12, true), (1e-9, false)] {
        let mut fp = Coulomb::default();
        let mut noisy = common::AlternatingError::new(Box::new(SparseSolver::new()), eps);
        match fp.solve(&mut noisy, &pr) {
            Ok(sol) => {
                assert!(settles, "round-off {eps}: accepted");
                assert_eq!((fp.roundoff_settles, fp.iterations), (1, 40));
                // Lemke's method gave no answer: none counted as its.
                assert_eq!(fp.lemke_solves, 0);
                let mut lift = 0.0f64;
                for (k, c) in pr.contacts.iter().enumerate() {
                    if sol.normal[k] > 0.0 {
                        lift = lift.max((c.g_n + dot(&c.nrow, &sol.dq)).abs());
                    }
                }
                eprintln!("round-off {eps}: loaded points open or closed by up to {lift:.2e} m");
                assert!(lift < 1e-11, "{lift}");
            }
            Err(e) => {
                assert!(!settles, "round-off {eps}: {e}");
                assert_eq!(fp.roundoff_settles, 0);
                let e = e.to_string();
                assert!(e.contains("did not settle") && e.contains("Lemke"), "{e}");
                assert!(e.contains("more than Lemke's dense method takes"), "{e}");
            }
        }
    }
}
