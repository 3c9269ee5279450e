//! Native-engine defects found by the random-scene and stress tests, pinned by regression
//! tests: the dual QP on a step without contacts (now free flight, no QP) and the dual QP
//! without friction (now with an explicit no-tension row).

mod common;

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

/// The native trajectory ends exactly at the duration (docs/scene-format.md): 0.4005 s at
/// dt = 1e-3 is 401 steps. Under the paper's stepper the last one is whole and the last sample
/// is interpolated half-way within it: up to 0.400 s the run is bit for bit the one of 0.401
/// s, and its last sample is the mid-point of that run's states at 0.400 and 0.401 s.
#[test]
fn native_trajectory_ends_at_the_duration() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let load = |duration: &str| {
        rockbench::scene::load_scene_with_overrides(
            &root.join("validation/scenes/housner-slender.toml"),
            &[
                format!("duration={duration}"),
                "native.dt=1e-3".into(),
                "native.stepper=\"paper\"".into(),
            ],
        )
        .unwrap()
    };
    let native = engine_by_name("native").unwrap();
    let short = native.run(&load("0.4005")).unwrap();
    let long = native.run(&load("0.401")).unwrap();
    let (ts, tl) = (&short.trajectory, &long.trajectory);
    assert_eq!(*ts.t.last().unwrap(), 0.4005);
    assert_eq!(*tl.t.last().unwrap(), 0.401);
    assert_eq!(ts.len(), 402);
    assert_eq!(ts.t[400], 0.4);
    assert_eq!(short.steps, 401);
    let lam = short.settings["last_fraction"].as_f64().unwrap();
    assert!((lam - 0.5).abs() < 1e-9, "{lam}");
    assert_eq!(long.settings["last_fraction"].as_f64().unwrap(), 1.0);
    let (bs, bl) = (&ts.blocks[0], &tl.blocks[0]);
    for (s, l) in [
        (&bs.x, &bl.x),
        (&bs.z, &bl.z),
        (&bs.phi, &bl.phi),
        (&bs.vx, &bl.vx),
        (&bs.vz, &bl.vz),
        (&bs.omega, &bl.omega),
    ] {
        assert_eq!(s[..401], l[..401]);
        let mid = l[400] + lam * (l[401] - l[400]);
        assert!(
            (s[401] - mid).abs() <= 1e-15 * mid.abs().max(1e-3),
            "{} {mid}",
            s[401]
        );
    }
    assert!(bs.phi[401] < bl.phi[400] && bs.phi[401] > bl.phi[401]);
}

/// OPEN defect (ignored until fixed; run with `--ignored`): a frictionless stack of three small
/// blocks (a 10 kg/m^3 slab under two heavy blocks tilted together by 0.45 rad), theta 0.5,
/// dt 5e-3, gains 1.8e-2 of m g H in 0.12 s, and its top block sinks 2.7e-4 m into the one
/// below. The pair rotates by 0.058 rad a step; the contact rows are linear in the rotation
/// increment, so the step leaves a second-order overlap (about d dphi^2 / 2 with d the centroid
/// distance, 1.1e-4 m; measured 2.7e-4 m, the same every step), which the next step's
/// position-level law removes within one step: the contact force works through it
/// (N delta ~ 0.06 J/m a step, the measured growth is 0.078), and at theta 0.5 nothing damps
/// it. A projection of positions after the step (velocities untouched), as the impact
/// stepper does, would remove the overlap without that work.
#[test]
#[ignore = "open defect of the paper's stepper: the position-level law's re-detection works against the linearisation overlap"]
fn native_frictionless_stack_at_theta_half_does_not_gain_energy() {
    frictionless_stack_does_not_gain_energy("paper");
}

/// The same stack under the impact stepper, whose discrete-gradient rows leave no overlap and
/// whose contact forces do no work: no energy growth (within 1e-9 of m g H).
#[test]
fn impact_stepper_frictionless_stack_does_not_gain_energy() {
    frictionless_stack_does_not_gain_energy("impact");
}

fn frictionless_stack_does_not_gain_energy(stepper: &str) {
    let text = r#"
name = "frictionless stack"
duration = 0.12
output_interval = 5e-3
[[blocks]]
name = "b0"
width = 0.42672246303699607
height = 0.07073679108586302
density = 10.0
[[blocks]]
name = "b1"
width = 0.14684317033065053
height = 0.06188667239645831
density = 2411.099967337493
[[blocks]]
name = "b2"
width = 0.14363736169437477
height = 0.0699957893108563
density = 3667.0460564166506
[initial]
tilt = 0.2561707870803173
[initial.blocks.b1]
rotation = 0.19485098844192222
[contact]
friction = 0.0
[native]
theta = 0.5
dt = 5e-3
"#;
    let text = text.replace(
        "[native]\n",
        &format!("[native]\nstepper = \"{stepper}\"\n"),
    );
    let scene = check_scene_str(&text, false, "stack.toml", &[], Path::new(".")).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene).unwrap();
    let tol = rockbench::invariants::Tolerances::default();
    let c = rockbench::invariants::check_energy(&scene, &out.trajectory, &tol);
    assert!(!c.violated(), "{}", c.detail);
}

/// Under the impact stepper (the default) the last of those 401 steps is shortened to end at
/// 0.4005 s: up to 0.400 s the run is bit for bit the one of 0.401 s, and its last sample is as
/// accurate as the others against Housner (the interpolated one would cut the chord of the
/// arc: for a corner on its face, a penetration).
#[test]
fn impact_stepper_ends_at_the_duration_with_a_shortened_step() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let load = |duration: &str| {
        rockbench::scene::load_scene_with_overrides(
            &root.join("validation/scenes/housner-slender.toml"),
            &[format!("duration={duration}"), "native.dt=1e-3".into()],
        )
        .unwrap()
    };
    let native = engine_by_name("native").unwrap();
    let housner = engine_by_name("housner").unwrap();
    let short = native.run(&load("0.4005")).unwrap();
    let long = native.run(&load("0.401")).unwrap();
    let exact = housner.run(&load("0.4005")).unwrap();
    let (ts, tl, te) = (&short.trajectory, &long.trajectory, &exact.trajectory);
    assert_eq!(*ts.t.last().unwrap(), 0.4005);
    assert_eq!(ts.len(), 402);
    assert_eq!(short.steps, 401);
    assert_eq!(ts.blocks[0].phi[..401], tl.blocks[0].phi[..401]);
    assert_eq!(*te.t.last().unwrap(), 0.4005);
    let err = |k: usize| (ts.blocks[0].phi[k] - te.blocks[0].phi[k]).abs();
    let (at_400, at_end) = (err(400), err(401));
    eprintln!("error against Housner: {at_400:.2e} rad at 0.400 s, {at_end:.2e} at 0.4005 s");
    assert!(at_end <= 2.0 * at_400 + 1e-12, "{at_end} vs {at_400}");
    let mid = tl.blocks[0].phi[400] + 0.5 * (tl.blocks[0].phi[401] - tl.blocks[0].phi[400]);
    assert!(
        ts.blocks[0].phi[401] != mid,
        "the last sample is not interpolated"
    );
}

/// The scene `tests/scenes/<file>` and the native engine's run of it.
fn native_run_of(file: &str) -> (rockbench::scene::Scene, rockbench::engines::RunOutput) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/scenes")
        .join(file);
    let scene = rockbench::scene::load_scene_with_overrides(&path, &[]).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene).unwrap();
    (scene, out)
}

/// A heavy block (mass ratio about 240) rocking over from one bottom corner to the other on a
/// light plank, at theta 0.5 and dt 4.4e-3 (`make proptest`). The impact stepper left it 1.67 mm
/// inside the plank: in the last sub-step of the step in which it landed on its other corner
/// (after 7 located impacts), the plank's and the block's unloaded points ended through their
/// faces, their discrete-gradient rows having been built at the predicted end of the sub-step,
/// which the solution left, and the rows' drift was checked on loaded points only. It is now
/// checked also on the points that end closed or through their faces.
#[test]
fn a_heavy_block_landing_on_a_light_plank_stays_out_of_it() {
    stays_out_of_its_faces("heavy-block-on-light-plank.toml");
}

/// The native engine's run of `tests/scenes/<file>` keeps every block out of the ground and of
/// the others to `limit(scene)` m; the run is returned for further checks.
fn penetrates_at_most(
    file: &str,
    limit: impl Fn(&rockbench::scene::Scene) -> f64,
) -> (rockbench::scene::Scene, rockbench::engines::RunOutput) {
    let (scene, out) = native_run_of(file);
    let (ground, pair, where_) = rockbench::invariants::max_penetration(&scene, &out.trajectory);
    let limit = limit(&scene);
    assert!(
        ground <= limit && pair <= limit,
        "penetration {ground:.3e} / {pair:.3e} m ({where_}), limit {limit:.3e} m"
    );
    (scene, out)
}

/// [`penetrates_at_most`] 1e-4 of the smallest dimension (the invariant's limit).
fn stays_out_of_its_faces(file: &str) -> (rockbench::scene::Scene, rockbench::engines::RunOutput) {
    penetrates_at_most(file, |scene| {
        1e-4 * rockbench::invariants::smallest_dimension(scene)
    })
}

/// [`penetrates_at_most`] the impact stepper's penetration tolerance (1e-9 m).
fn stays_within_the_penetration_tolerance(file: &str) {
    penetrates_at_most(file, |_| rockbench::native::stepper::PENETRATION_TOLERANCE);
}

/// A 92-block wall set moving at 0.36 m/s with its impacts at the end of their step (`make
/// proptest-assemblies`): each such impact leaves its point up to `dt |v_n| / 2` inside its
/// face, and projecting it out lifts blocks. Its energy grew by 1.13e-6 of `sum m g H`, above
/// the fixed 1e-6 the random assemblies excused at step ends; the growth is bounded by what the
/// projections gained, which the run's notes now give, and which the random assemblies excuse.
/// (Its launch, points closed and sliding outside the associative cone, is now a plastic impact
/// at the start: the energy no longer grows past its start, while the projections still lift
/// blocks, 3.2e-2 J/m in 11 projections.)
#[test]
fn a_wall_at_step_ends_gains_no_more_energy_than_its_projections() {
    let (scene, out) = native_run_of("wall-set-moving-at-step-ends.toml");
    let scale = rockbench::invariants::energy_scale(&scene);
    let tol = rockbench::invariants::Tolerances::default();
    let growth = rockbench::invariants::check_energy(&scene, &out.trajectory, &tol).value * scale;
    let projected = common::projected_energy(&out.notes).expect("the notes give it");
    assert!(
        projected > 1e-6 * scale,
        "the projections gained {projected:.3e} J/m only (the case is gone)"
    );
    assert!(
        growth <= projected + 1e-9 * scale,
        "energy grew by {growth:.3e} J/m, the projections gained {projected:.3e} J/m"
    );
}

/// The ends of a face-to-face overlap that are the lower block's corners, under a plank that
/// slides and turns on it (Coulomb friction, so no dilatancy hides them). They were followed
/// as ends of the post's face, along the post's normal turning with the post, and the first
/// step put a corner 6.1e-6 m into the plank (slip times turn); each is now a vertex of the post
/// on the plank's face.
#[test]
fn a_post_under_a_sliding_turning_plank_stays_out_of_it() {
    stays_within_the_penetration_tolerance("plank-sliding-and-turning-on-a-post.toml");
}

/// A running-bond wall rocking with the corners at its course ends flush to round-off: where
/// they were 1.6e-10 to 3.2e-10 m apart, neither corner was a contact point (the windows of the
/// two faces left a gap), and the block above sank 2.07e-6 m into the half block below.
#[test]
fn a_rocking_wall_keeps_its_flush_course_ends_apart() {
    stays_within_the_penetration_tolerance("wall-course-ends-flush-to-round-off.toml");
}

/// A block landing flat with one end overhanging the edge of the block below: its other
/// corner, an end of its own face (the pair's reference face) over the lower block's face, was
/// measured along its own normal, 0.014 rad off the lower face's, and as it slid 2 mm in a
/// step it ended 2.8e-5 m inside (`make proptest`). It is now a vertex on the lower face.
#[test]
fn a_block_landing_flat_on_an_overhang_stays_out_of_the_block_below() {
    stays_within_the_penetration_tolerance("block-landing-flat-on-an-overhang.toml");
}

/// The run's energy never grows above its lowest value so far by more than 1e-10 of `sum m g
/// H`, and block `block` ends turned by more than `least` rad (the scene did what it is for).
fn gains_no_energy_while_turning(
    scene: &rockbench::scene::Scene,
    out: &rockbench::engines::RunOutput,
    block: usize,
    least: f64,
) {
    let e = rockbench::invariants::energy(scene, &out.trajectory);
    let growth = e
        .iter()
        .enumerate()
        .map(|(k, &ek)| ek - e[..=k].iter().copied().fold(f64::INFINITY, f64::min))
        .fold(0.0f64, f64::max)
        / rockbench::invariants::energy_scale(scene);
    assert!(growth <= 1e-10, "energy grew by {growth:.3e} of m g H");
    let turned = out.trajectory.blocks[block].phi.last().unwrap().abs();
    assert!(
        turned > least,
        "block {block} turned by {turned:.3e} rad only"
    );
}

/// A 3 m stack rocking as one body on the corner of its light bottom block (0.55, 414 and
/// 1906 kg per metre; `make proptest`), solved by the sparse back-end: the stack gained
/// 1.3e-6 J/m a step (1.05e-9 of m g H in 0.01 s, above the invariant's 1e-9), and not with the
/// dense or Clarabel back-ends. Newton's iteration stopped at steps of 1e-12 (1 + |u|), whose
/// stationarity residual on the heavy blocks' DOFs does work; it now refines to 1e-15 while its
/// steps still halve, with the factor in hand.
#[test]
fn the_sparse_back_end_adds_no_energy_to_a_heavy_stack_on_a_light_base() {
    let (scene, out) = native_run_of("heavy-stack-on-light-base.toml");
    gains_no_energy_while_turning(&scene, &out, 2, 1e-3);
}

/// A heavy plank turning on the corner of a light post, the sparse back-end forced (`make
/// proptest`): every step's second discrete-gradient solve stopped at a Newton step of 1e-12
/// (1 + |u|) because the refinement's active rows had changed and a refinement never
/// factorised; the residual of its momentum balance (1.5e-8 N s/m) did 1.2e-9 J/m of work a
/// step, 3.3e-9 of m g H over the run (dense and Clarabel: 1.5e-14). On a narrow envelope a
/// refinement of a solution that moves now factorises: 1.2e-11.
#[test]
fn the_sparse_back_end_adds_no_energy_to_a_heavy_plank_on_a_light_post() {
    let (scene, out) = native_run_of("heavy-plank-on-light-post.toml");
    gains_no_energy_while_turning(&scene, &out, 1, 0.1);
}

/// A colonnade of 60 light posts (0.073 x 1 m, 10 kg/m^3) under 59 heavy lintels (0.98 x 0.052
/// m, 381 kg/m^3), the lintels set moving at 0.3 m/s: one island of 357 DOFs, wide for the
/// sparse back-end. Its settled end velocities after an interior-point rescue stopped where
/// Newton's steps stagnated at 7e-10 to 1.2e-9 (1 + |u|), held rows and factors of other rows
/// making the steps too short, and their residual did work: one step gained 6.6e-10 of m g H
/// (Clarabel 7.2e-12 over the run). Stagnation is now accepted only where the residual does no
/// work (`STAGNATION_WORK`): 1.3e-14.
#[test]
fn the_sparse_back_end_adds_no_energy_to_a_swaying_colonnade() {
    let mut text = String::from(
        "name = \"colonnade\"\nduration = 0.3\noutput_interval = 0.001\n\
         [contact]\nfriction = 3.0\n[native]\nsolver = \"sparse\"\ndt = 1e-3\n",
    );
    for i in 0..60 {
        text += &format!(
            "[[blocks]]\nname = \"p{i}\"\nwidth = 0.073\nheight = 1.0\ndensity = 10.0\nx = {i}.0\n"
        );
    }
    for i in 0..59 {
        text += &format!(
            "[[blocks]]\nname = \"l{i}\"\nwidth = 0.98\nheight = 0.052\ndensity = 381.0\n\
             x = {i}.5\n"
        );
    }
    for i in 0..59 {
        text += &format!("[initial.blocks.l{i}]\nvx = 0.3\n");
    }
    let scene = rockbench::scene::parse_scene_str(&text, false, "colonnade", &[]).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene).unwrap();
    gains_no_energy_while_turning(&scene, &out, 30, 0.01);
}

/// A light post squeezed from under a stack 4e4 times heavier, spinning out at some 60 rad/s
/// (`make proptest`): its corner ended 1.49 mm inside the ground. The discrete-gradient iteration
/// of the step stopped at `DISCRETE_GRADIENT_SOLVES` with the rows' drift at 1.5e-3 m (it swung
/// between 5e-2 and 1.5e-3 m from solve to solve), and the last solution was kept as if it had
/// converged. Such a step is now taken again as two halves (`CONVERGED_DRIFT`); the run's
/// energy, with no excitation, must not grow either, and the post must still spin out.
#[test]
fn a_light_post_squeezed_from_under_a_stack_stays_out_of_the_ground() {
    let (scene, out) = stays_out_of_its_faces("light-post-squeezed-from-under-a-stack.toml");
    gains_no_energy_while_turning(&scene, &out, 0, 1.0);
}

/// A 1 x 2.5 m block thrown up by its ground (a vertical half-sine of -15 m/s^2 for 0.2 s from
/// 0.5 s, with a horizontal one of `horizontal` m/s^2) under the native engine at `dt` with the
/// `[native]` lines `native`: its energy at 0.9 s (the rotation's included, above its rest), its
/// largest rotation after 0.8 s (it lands at 0.80 s) and the run's notes.
fn thrown_block(horizontal: f64, dt: f64, native: &str) -> (f64, f64, String) {
    let text = format!(
        "name = \"landing\"\nduration = 0.9\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 2.5\n\
         [excitation.vertical]\nkind = \"half-sine\"\namplitude = -15.0\nduration = 0.2\nstart = 0.5\n\
         [excitation.horizontal]\nkind = \"half-sine\"\namplitude = {horizontal:e}\nduration = 0.2\n\
         start = 0.5\n[output]\ninterval = 1e-3\n[native]\ndt = {dt:e}\n{native}\n"
    );
    let scene = check_scene_str(&text, false, "landing.toml", &[], Path::new(".")).unwrap();
    let out = engine_by_name("native").unwrap().run(&scene).unwrap();
    let b = &out.trajectory.blocks[0];
    let m = scene.blocks[0].mass();
    let k = b.vx.len() - 1;
    let energy = 0.5 * m * (b.vx[k].powi(2) + b.vz[k].powi(2))
        + 0.5 * scene.blocks[0].inertia() * b.omega[k].powi(2)
        + m * scene.gravity * (b.z[k] - 1.25);
    let after = out.trajectory.t.iter().position(|&t| t > 0.8).unwrap();
    let rocked = b.phi[after..].iter().fold(0.0f64, |a, p| a.max(p.abs()));
    (energy, rocked, out.notes.join("; "))
}

/// [`thrown_block`] at `dt` (`coarse`) against dt 1e-4 (`fine`): the energy at 0.9 s and the
/// largest rotation after landing agree to 2 %.
fn lands_as_at_the_fine_step(coarse: &(f64, f64, String), fine: &(f64, f64, String), dt: f64) {
    assert!(
        (coarse.0 / fine.0 - 1.0).abs() < 0.02,
        "energy at 0.9 s: {} J/m at dt {dt:e}, {} at dt 1e-4",
        coarse.0,
        fine.0
    );
    assert!(
        (coarse.1 / fine.1 - 1.0).abs() < 0.02,
        "largest rotation after landing: {} rad at dt {dt:e}, {} at dt 1e-4",
        coarse.1,
        fine.1
    );
}

/// A block thrown up by its ground (a vertical half-sine of -15 m/s^2 with a horizontal one)
/// lands almost flat at 0.80 s, both corners within 0.4 ms: at dt 1e-3 it rebounded 0.7 m/s,
/// keeping 98 % of its kinetic energy (2193 J/m at 0.9 s, against 33 J/m at dt 1e-4), and
/// rocked to 0.036 rad for 0.0022. The sub-step to its first corner's instant went through the
/// face; halved, it stopped short, round after round, until the located rounds ran out and the
/// mean-velocity law took the impact (elastic). Now the instant is found again from that
/// sub-step's own motion and the impact is plastic at every step: the energy at 0.9 s and the
/// largest rotation after landing are dt 1e-4's to 2 %.
#[test]
fn a_block_landing_almost_flat_does_not_rebound_elastically() {
    let run = |dt: f64| thrown_block(1.0, dt, "");
    let (coarse, fine) = (run(1e-3), run(1e-4));
    assert!(
        !coarse.2.contains(" 0 found again from their sub-step"),
        "the landing's instant is found again: {}",
        coarse.2
    );
    lands_as_at_the_fine_step(&coarse, &fine, 1e-3);
}

/// The same block landing almost flat with a weaker horizontal pulse (0.5 m/s^2): its second
/// corner is 0.09 mm up at the first one's instant and closes some 0.1 ms later.
/// - Under `simultaneous_impacts = "step"` (the default), every point closing within the rest
///   of the step strikes at the first instant: at dt 1e-3 the second corner, still in the air,
///   takes the plastic impact too and the block lands dead (measured: 6.6e-9 of dt 1e-4's
///   energy left at 0.9 s); the run's notes say so, with the gap. At dt 1e-4 the step
///   resolves the two instants and both rules give the same run.
/// - Under `"instant"`, each corner strikes at its own instant: dt 2e-3 and 1e-3 give dt
///   1e-4's energy at 0.9 s and largest rotation after landing to 2 % (rapier, MuJoCo,
///   PyBullet and Siconos rock it too: docs/method.md, "Impacts together or in turn").
#[test]
fn points_closing_later_in_the_step_strike_at_their_own_instant_under_instant_impacts() {
    let run =
        |rule: &str, dt: f64| thrown_block(0.5, dt, &format!("simultaneous_impacts = \"{rule}\""));
    let fine = run("instant", 1e-4);
    for dt in [2e-3, 1e-3] {
        let coarse = run("instant", dt);
        lands_as_at_the_fine_step(&coarse, &fine, dt);
        assert!(
            !coarse.2.contains("struck points still open"),
            "{}",
            coarse.2
        );
    }
    let together = run("step", 1e-3);
    assert!(
        together.0 < 1e-3 * fine.0,
        "landed dead under \"step\" at dt 1e-3: {} J/m",
        together.0
    );
    let note = together
        .2
        .split("; ")
        .find(|n| n.contains("struck points still open"))
        .unwrap_or_else(|| panic!("no note of the open strike: {}", together.2));
    let widest: f64 = note
        .split("by up to ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|g| g.parse().ok())
        .unwrap_or_else(|| panic!("no gap in {note}"));
    assert!((5e-5..2e-4).contains(&widest), "{note}");
    let resolved = run("step", 1e-4);
    assert_eq!((resolved.0, resolved.1), (fine.0, fine.1));
}
