//! The fast back-ends against the reference (Clarabel) on whole runs.

use rockbench::engines::{RunOutput, engine_by_name, run_timed};
use rockbench::native::problem::ContactRows;
use rockbench::native::solver::polish::polish;
use rockbench::native::solver::{ActiveSetSolver, ClarabelSolver, ContactSolver, SparseSolver};
use rockbench::native::{NativeSettings, StepProblem, StepSolution};
use rockbench::scene::load_scene_with_overrides;
use rockbench::summary::Summary;
use rockbench::trajectory::Trajectory;
use std::path::Path;

fn run(scene: &str, solver: &str, stepper: &str) -> (RunOutput, Summary) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("validation/scenes")
        .join(scene);
    let s = load_scene_with_overrides(
        &p,
        &[
            format!("native.solver=\"{solver}\""),
            format!("native.stepper=\"{stepper}\""),
        ],
    )
    .unwrap();
    run_timed(engine_by_name("native").unwrap().as_ref(), &s).unwrap()
}

/// Each fast back-end against Clarabel, under both steppers: the same rotations to 1e-6 rad up
/// to the first impact and the same first four impacts of every block to 1 ms; under the impact
/// stepper, the same positions over the whole run to 1e-9 m (measured: at most 8.4e-11 m, the
/// sparse back-end on the two-block case; with the polish's least-squares working sets before
/// 2026-12-01 Clarabel was 7.0e-7 m off there and 3.3e-8 m on the square block). (The impact
/// stepper decides which points are closed by their gaps, never by their forces, which each
/// back-end splits its own way on a flat interface: deciding by force, Clarabel put the
/// two-block case's first crossing of the statue 7 ms after the active-set back-end. The
/// paper's stepper leaves the two-block case's back-ends 1e-9 m apart at 1.87 s and 2 mm apart
/// later.)
#[test]
fn fast_back_ends_match_clarabel_up_to_the_first_impact_and_in_impact_times() {
    for solver in ["active-set", "sparse"] {
        for (scene, stepper, impacts) in [
            ("two-block-free-rocking.toml", "paper", 4),
            ("two-block-free-rocking.toml", "impact", 4),
            ("housner-slender.toml", "paper", 4),
            ("housner-slender.toml", "impact", 4),
            ("housner-square.toml", "paper", 4),
            ("housner-square.toml", "impact", 4),
        ] {
            compare_with_clarabel(scene, solver, stepper, impacts);
        }
    }
}

/// The largest difference of any block's position (x or z) at any sample.
fn largest_position_difference(a: &Trajectory, b: &Trajectory) -> f64 {
    assert_eq!(a.t.len(), b.t.len(), "the same samples");
    a.blocks
        .iter()
        .zip(&b.blocks)
        .flat_map(|(x, y)| [(&x.x, &y.x), (&x.z, &y.z)])
        .flat_map(|(x, y)| x.iter().zip(y))
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

fn compare_with_clarabel(scene: &str, solver: &str, stepper: &str, impacts: usize) {
    let (a, sa) = run(scene, "clarabel", stepper);
    let (b, sb) = run(scene, solver, stepper);
    assert_eq!(
        b.settings["solver_backend"], solver,
        "{scene}: back-end recorded"
    );
    if stepper == "impact" {
        let worst = largest_position_difference(&a.trajectory, &b.trajectory);
        assert!(
            worst < 1e-9,
            "{scene} {solver}: positions {worst:e} m from Clarabel's"
        );
    }
    let first = sa.blocks[0].impacts[0];
    for (ba, bb) in a.trajectory.blocks.iter().zip(&b.trajectory.blocks) {
        let worst = a
            .trajectory
            .t
            .iter()
            .zip(ba.phi.iter().zip(&bb.phi))
            .filter(|(t, _)| **t <= first)
            .fold(0.0f64, |m, (_, (x, y))| m.max((x - y).abs()));
        assert!(
            worst < 1e-6,
            "{scene} {solver} {}: rotation difference {worst:e} rad before the first impact",
            ba.name
        );
    }
    for (x, y) in sa.blocks.iter().zip(&sb.blocks) {
        let n = x.impacts.len().min(y.impacts.len()).min(impacts);
        assert!(n >= 1, "{scene}: impacts");
        for k in 0..n {
            assert!(
                (x.impacts[k] - y.impacts[k]).abs() <= 1e-3,
                "{scene} {stepper} {} impact {k}: clarabel {} {solver} {}",
                x.name,
                x.impacts[k],
                y.impacts[k]
            );
        }
    }
}

/// Forced Clarabel (the reference) and `auto` (the dense and sparse back-ends): the largest
/// difference of any block's position at any sample, primal and dual, on scenes whose flat
/// interfaces give dependent rows (four rows of two sticking points on three relative DOFs):
/// the two-block case (6 s), the stack of masses three orders apart of `make proptest`, and a
/// 10-block wall struck at its corner (its first 0.4 s). The interior point alone is far less
/// accurate there than its tolerance, and its solutions stand only where the polish cannot
/// certify one. Measured: 6.6e-13 / 1.6e-14 / 4.9e-11 m; before the polish took the working
/// sets' independent rows, 7.0e-7 / 1.5e-5 / 5.7e-7 m (primal), and the dual runs of the first
/// two stopped at steps 1985 and 11 (`InsufficientProgress`, the polish not verifying).
#[test]
fn clarabel_gives_autos_positions_where_rows_are_dependent() {
    let positions = |scene: &Path, overrides: &[String]| {
        let s = load_scene_with_overrides(scene, overrides).unwrap();
        let (out, _) = run_timed(engine_by_name("native").unwrap().as_ref(), &s)
            .unwrap_or_else(|e| panic!("{}: {overrides:?}: {e}", scene.display()));
        out.trajectory
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (scene, cut, tolerance) in [
        (
            root.join("validation/scenes/two-block-free-rocking.toml"),
            None,
            1e-11,
        ),
        (test_scene("almost-solved-stack.toml"), None, 1e-11),
        (
            root.join("validation/scenes/wall-corner-pulse.toml"),
            Some(0.4),
            1e-9,
        ),
    ] {
        let cut: Vec<String> = cut.iter().map(|d| format!("duration={d}")).collect();
        let auto = positions(&scene, &cut);
        for formulation in ["primal", "dual"] {
            let mut overrides = cut.clone();
            overrides.push("native.solver=\"clarabel\"".into());
            overrides.push(format!("native.formulation=\"{formulation}\""));
            let clarabel = positions(&scene, &overrides);
            let worst = largest_position_difference(&auto, &clarabel);
            assert!(
                worst < tolerance,
                "{} {formulation}: Clarabel {worst:e} m from auto",
                scene.display()
            );
        }
    }
}

/// A point mass on the ground with a sideways push above the friction limit: both back-ends
/// give the same increment and the friction force mu N.
#[test]
fn tiny_problem_with_known_answer() {
    let pr = StepProblem {
        theta: 0.7,
        dt: 1e-3,
        mass: vec![2.0, 2.0, 1.0],
        force: vec![3.0 * 2.0 * 9.81, -2.0 * 9.81, 0.0],
        v0: vec![0.0; 3],
        contacts: vec![ContactRows {
            key: 1,
            mu: 0.5,
            g_n: 0.0,
            g_t: 0.0,
            nrow: [(0, 0.0), (1, 1.0), (2, 0.0)].into(),
            trow: [(0, 1.0), (1, 0.0), (2, 0.0)].into(),
        }],
    };
    let a = ClarabelSolver::new(&NativeSettings::default())
        .solve(&pr)
        .unwrap();
    let b = ActiveSetSolver::new().solve(&pr).unwrap();
    let c = SparseSolver::new().solve(&pr).unwrap();
    for (x, y) in a.dq.iter().zip(&b.dq) {
        assert!((x - y).abs() < 1e-12, "{:?} vs {:?}", a.dq, b.dq);
    }
    for (x, y) in a.dq.iter().zip(&c.dq) {
        assert!((x - y).abs() < 1e-12, "{:?} vs {:?}", a.dq, c.dq);
    }
    assert!((c.tangential[0] + 0.5 * c.normal[0]).abs() < 1e-9 * c.normal[0]);
    // Sliding on the cone edge: dz = mu dx and T = -mu N.
    assert!((b.dq[1] - 0.5 * b.dq[0]).abs() < 1e-14);
    assert!((b.tangential[0] + 0.5 * b.normal[0]).abs() < 1e-9 * b.normal[0]);
}

/// A column of `n` blocks 1.0 x 0.2 m, tilted by half its slenderness angle.
fn column(n: usize, solver: &str, duration: f64) -> rockbench::scene::Scene {
    let mut s =
        format!("name = \"column\"\nduration = {duration}\n[native]\nsolver = \"{solver}\"\n");
    for i in 0..n {
        s += &format!("[[blocks]]\nname = \"b{i}\"\nwidth = 1.0\nheight = 0.2\n");
    }
    s += &format!(
        "[initial]\ntilt = {}\n",
        0.5 * (1.0f64 / (0.2 * n as f64)).atan()
    );
    rockbench::scene::parse_scene_str(&s, false, "column", &[]).unwrap()
}

/// A rocking 25-block column (75 DOFs: `auto` gives it to the sparse back-end): sparse and
/// the dense active-set back-end agree to 1e-6 rad up to the first impact and in its time,
/// and the sparse back-end needs Clarabel on no step.
#[test]
fn sparse_matches_the_dense_back_end_on_a_rocking_column() {
    let native = engine_by_name("native").unwrap();
    let (a, sa) = run_timed(native.as_ref(), &column(25, "active-set", 1.0)).unwrap();
    let (b, sb) = run_timed(native.as_ref(), &column(25, "auto", 1.0)).unwrap();
    assert!(
        b.settings["solver_backend"]
            .as_str()
            .unwrap()
            .starts_with("auto"),
        "{}",
        b.settings["solver_backend"]
    );
    for s in [&sa, &sb] {
        assert!(
            s.notes
                .iter()
                .any(|n| n.contains(" 0 steps fell back to Clarabel")),
            "{:?}",
            s.notes
        );
    }
    let first = sa.blocks[0].impacts[0];
    assert!(
        (first - sb.blocks[0].impacts[0]).abs() <= 1e-3,
        "first impact {first} vs {}",
        sb.blocks[0].impacts[0]
    );
    for (ba, bb) in a.trajectory.blocks.iter().zip(&b.trajectory.blocks) {
        for ((t, x), y) in a.trajectory.t.iter().zip(&ba.phi).zip(&bb.phi) {
            if *t <= first {
                assert!((x - y).abs() < 1e-6, "{} at {t}: {x} vs {y}", ba.name);
            }
        }
    }
}

/// The running-bond wall at rest: the sparse back-end keeps its factorisation from step to
/// step (the active rows do not change), and nothing moves.
#[test]
fn sparse_reuses_its_factor_on_a_wall_at_rest() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/running-bond-wall.toml");
    let scene = load_scene_with_overrides(&p, &["native.solver=\"sparse\"".into()]).unwrap();
    let (mut stepper, mut state) = rockbench::native::stepper_for(&scene).unwrap();
    let q0 = state.q.clone();
    let mut sparse = SparseSolver::new();
    let steps = 500;
    for _ in 0..steps {
        let pr = stepper.next_problem(&state);
        let sol = sparse.solve(&pr).unwrap();
        stepper.step(&mut state).unwrap();
        assert!(sol.dq.iter().all(|x| x.abs() < 1e-9), "the wall moves");
    }
    assert!(
        sparse.factorisations <= 20,
        "{} factorisations in {steps} steps",
        sparse.factorisations
    );
    let drift = q0
        .iter()
        .zip(&state.q)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(drift < 1e-9, "drift {drift:e}");
}

/// The running-bond wall (22 blocks, 66 DOFs) shaken by a half-sine pulse above its friction
/// limit, so that it slides and the active rows change from step to step. Along the Clarabel
/// trajectory every step's problem is also solved by the sparse back-end: its step holds every
/// row, its objective is never above Clarabel's (the QP is strictly convex: the lower of two
/// feasible objectives is the better), and the two steps agree to 1e-8 m. (Whole trajectories
/// are not compared: once blocks slide, 1e-9 m differences decide stick or slip. On some of
/// these steps the dense back-end cycles and Clarabel at 1e-12 stops at `AlmostSolved`.)
#[test]
fn sparse_solves_the_steps_of_a_sliding_wall_at_least_as_well_as_clarabel() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/running-bond-wall.toml");
    // The paper's stepper: one solve of `next_problem` a step (the impact stepper re-solves with
    // rows re-evaluated at the predicted end of the step, so its step is not this problem's).
    let scene = load_scene_with_overrides(
        &p,
        &[
            "native.stepper=\"paper\"".into(),
            "native.solver=\"clarabel\"".into(),
            "native.polish=false".into(),
            "excitation.horizontal.kind=\"half-sine\"".into(),
            "excitation.horizontal.amplitude=12.0".into(),
            "excitation.horizontal.duration=0.3".into(),
        ],
    )
    .unwrap();
    let (mut stepper, mut state) = rockbench::native::stepper_for(&scene).unwrap();
    let mut sparse = SparseSolver::new();
    let x0: Vec<f64> = state.q.iter().step_by(3).copied().collect();
    let (mut worst_gap, mut worst_diff) = (0.0f64, 0.0f64);
    for step in 0..90 {
        let pr = stepper.next_problem(&state);
        let a = sparse.solve(&pr).unwrap();
        let b = stepper.step(&mut state).unwrap();
        let mbar = pr.mbar();
        let f0 = pr.fbar0();
        let objective = |dq: &[f64]| -> f64 {
            (0..dq.len())
                .map(|i| 0.5 * mbar[i] * dq[i] * dq[i] - f0[i] * dq[i])
                .sum()
        };
        let scale: f64 = (0..f0.len()).map(|i| (f0[i] * b.dq[i]).abs()).sum();
        for c in &pr.contacts {
            let n: f64 = c.nrow.iter().map(|&(i, x)| x * a.dq[i]).sum();
            let t: f64 = c.trow.iter().map(|&(i, x)| x * a.dq[i]).sum();
            for sign in [1.0, -1.0] {
                let row = c.g_n + sign * c.mu * c.g_t + n + sign * c.mu * t;
                worst_gap = worst_gap.min(row);
            }
        }
        assert!(
            objective(&a.dq) <= objective(&b.dq) + 1e-9 * scale,
            "step {step}: sparse objective {:e} above Clarabel's {:e}",
            objective(&a.dq),
            objective(&b.dq)
        );
        let diff =
            a.dq.iter()
                .zip(&b.dq)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        worst_diff = worst_diff.max(diff);
    }
    assert!(worst_gap > -1e-12, "a row violated by {worst_gap:e} m");
    assert!(worst_diff < 1e-8, "steps differ by {worst_diff:e} m");
    let slip = state
        .q
        .iter()
        .step_by(3)
        .zip(&x0)
        .fold(0.0f64, |m, (x, x0)| m.max((x - x0).abs()));
    assert!(
        slip > 1e-4,
        "the pulse must make the wall slide (slip {slip:e} m)"
    );
}

/// `tests/scenes/<file>`.
fn test_scene(file: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/scenes")
        .join(file)
}

/// Data stored as JSON in `tests/scenes/<file>`: a step problem, or a polish's inputs.
fn stored<T: serde::de::DeserializeOwned>(file: &str) -> T {
    serde_json::from_str(&std::fs::read_to_string(test_scene(file)).unwrap()).unwrap()
}

/// A step problem stored as data, `tests/scenes/<file>`.
fn stored_problem(file: &str) -> StepProblem {
    stored(file)
}

/// Clarabel's solution of `pr` in the dual formulation, which stops with `status`: without the
/// polish that is the step's error; with it the polished solution is accepted.
fn polished_dual_solution(pr: &StepProblem, status: &str) -> StepSolution {
    let mut dual = NativeSettings {
        formulation: rockbench::native::Formulation::Dual,
        polish: false,
        ..NativeSettings::default()
    };
    let err = ClarabelSolver::new(&dual).solve(pr).unwrap_err();
    assert!(err.to_string().contains(status), "{err}");
    dual.polish = true;
    let sol = ClarabelSolver::new(&dual).solve(pr).unwrap();
    assert!(sol.polished, "the accepted solution is the polished one");
    sol
}

/// Clarabel's `AlmostSolved` is accepted only when the active-set polish verifies the solution
/// (every row satisfied, non-negative multipliers: the KKT conditions of the step's convex QP).
/// tests/scenes/almost-solved-step.json is a step on which Clarabel stops with `AlmostSolved`:
/// step 22 of the stack of tests/scenes/almost-solved-stack.toml (from `make proptest`) as the
/// impact stepper built it before points in the air were freed of the friction cone (the
/// stack's run no longer meets that step, so the step is stored as data). Without the polish
/// the status is the step's error; with it the solution is accepted and meets the KKT
/// conditions. The stack itself runs to its end with no block inside another or the ground.
#[test]
fn an_almost_solved_step_is_accepted_when_its_polish_verifies_it() {
    let pr = stored_problem("almost-solved-step.json");
    let sol = polished_dual_solution(&pr, "AlmostSolved");
    // Rows, signs and the cone of the forces, and stationarity `Mbar dq = fbar0 + H'c`.
    let mbar: Vec<f64> = pr
        .mass
        .iter()
        .map(|m| m / (pr.theta * pr.dt * pr.dt))
        .collect();
    let mut residual: Vec<f64> = (0..pr.mass.len())
        .map(|i| mbar[i] * sol.dq[i] - pr.force[i] - mbar[i] * pr.v0[i] * pr.dt)
        .collect();
    let dot = |row: &[(usize, f64)]| row.iter().map(|&(i, c)| c * sol.dq[i]).sum::<f64>();
    for (k, c) in pr.contacts.iter().enumerate() {
        let (n, t) = (sol.normal[k], sol.tangential[k]);
        let (gn, gt) = (c.g_n + dot(&c.nrow), c.g_t + dot(&c.trow));
        for edge in [gn + c.mu * gt, gn - c.mu * gt] {
            // Within the polish's working-set tolerance (1e-10 m; measured: 1.7e-12 m).
            assert!(edge > -1e-10, "point {k}: a row violated by {edge:e} m");
        }
        assert!(
            n >= 0.0 && t.abs() <= c.mu * n * (1.0 + 1e-9) + 1e-9,
            "point {k}: N {n}, T {t}"
        );
        for &(i, a) in c.nrow.iter() {
            residual[i] -= n * a;
        }
        for &(i, a) in c.trow.iter() {
            residual[i] -= t * a;
        }
    }
    // Against the largest term of the balance (the inertia terms dwarf gravity here).
    let scale = (0..pr.mass.len())
        .map(|i| {
            let inertia = (mbar[i] * sol.dq[i])
                .abs()
                .max((mbar[i] * pr.v0[i] * pr.dt).abs());
            inertia.max(pr.force[i].abs())
        })
        .fold(0.0f64, f64::max);
    let worst = residual.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    // Measured: 4.9e-9 of it (a mass ratio of ~1300 in the stack).
    assert!(
        worst < 1e-7 * scale,
        "stationarity residual {worst:e} against terms of {scale:e}"
    );
    let p = test_scene("almost-solved-stack.toml");
    let dense = "native.solver=\"active-set\"".to_string();
    let s = load_scene_with_overrides(&p, std::slice::from_ref(&dense)).unwrap();
    let (out, _) = run_timed(engine_by_name("native").unwrap().as_ref(), &s).unwrap();
    let (depth, _, what) = rockbench::invariants::max_penetration(&s, &out.trajectory);
    assert!(depth < 1e-6, "penetration {depth:e} m ({what})");
}

/// `auto` hands the small problems its dense back-end cannot solve (the working-set search
/// cycling on a flat interface's nearly dependent rows) to the sparse back-end, not to
/// Clarabel: the two-block case, 21 of whose problems fell back to Clarabel, needs none.
#[test]
fn auto_needs_no_clarabel_fallback_on_the_two_block_case() {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/two-block-free-rocking.toml");
    let s = load_scene_with_overrides(&p, &[]).unwrap();
    let (mut stepper, mut state) = rockbench::native::stepper_for(&s).unwrap();
    while state.t < s.duration - 1e-9 {
        stepper.step(&mut state).unwrap();
    }
    assert_eq!(stepper.solver_fallbacks(), 0);
}

/// `solve_into` gives what `solve` gives, bit for bit, whatever the buffers it is handed held
/// (longer, shorter, other values), on every back-end and through the islands and `auto`
/// wrappers: problems of a 3-block column rocking (one island) and of two separate blocks (two
/// islands), each at several steps.
#[test]
fn solve_into_reuses_any_buffer_and_gives_what_solve_gives() {
    let stale = || StepSolution {
        dq: vec![7.0; 40],
        normal: vec![-3.0; 1],
        tangential: vec![],
        iterations: 99,
        polished: true,
    };
    let two_blocks = rockbench::scene::parse_scene_str(
        "name = \"pair\"\nduration = 1.0\n\
         [[blocks]]\nname = \"a\"\nwidth = 0.4\nheight = 1.0\nx = 0.0\n\
         [[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1.0\nx = 2.0\n\
         [initial]\ntilt = 0.1\n",
        false,
        "pair",
        &[],
    )
    .unwrap();
    let mut compared = 0;
    for scene in [column(3, "auto", 1.0), two_blocks] {
        let (mut stepper, mut state) = rockbench::native::stepper_for(&scene).unwrap();
        for step in 0..60 {
            if step % 20 == 5 {
                let pr = stepper.next_problem(&state);
                assert!(!pr.contacts.is_empty());
                for kind in ["active-set", "sparse", "clarabel", "auto"] {
                    let settings: NativeSettings =
                        toml::from_str(&format!("solver = \"{kind}\"")).unwrap();
                    let (mut a, mut b) = (
                        rockbench::native::solver::solver_for(&settings),
                        rockbench::native::solver::solver_for(&settings),
                    );
                    let expected = a.solve(&pr).unwrap();
                    let mut out = stale();
                    b.solve_into(&pr, &mut out).unwrap();
                    assert_eq!(out, expected, "{} {kind} step {step}", scene.name);
                    compared += 1;
                }
            }
            stepper.step(&mut state).unwrap();
        }
    }
    assert_eq!(compared, 24);
}

/// The sparse back-end's warm multipliers are impulses over the step: from a step of another
/// length they are scaled by the ratio of the lengths (a located impact's sub-steps), so that
/// the forces carry over. The running-bond wall at rest (22 blocks), its step solved at 1 ms and
/// then, warm, at a quarter of it: the quarter step's forces are the full step's (a wall at rest
/// carries its weight whatever the step) and its warm solve takes no more Newton steps and no
/// more factorisations than solving the full step again (measured: 1 Newton step and none,
/// against 4 and 1; with warm multipliers four times too large, as before they were scaled, 13
/// Newton steps and 8 factorisations).
#[test]
fn sparse_warm_multipliers_carry_the_forces_across_step_lengths() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/running-bond-wall.toml");
    let scene = load_scene_with_overrides(&p, &["native.solver=\"sparse\"".into()]).unwrap();
    let (stepper, state) = rockbench::native::stepper_for(&scene).unwrap();
    let full = stepper.next_problem(&state);
    let mut quarter = full.clone();
    quarter.dt = full.dt / 4.0;
    let mut sparse = SparseSolver::new();
    let first = sparse.solve(&full).unwrap();
    let before = sparse.factorisations;
    let again = sparse.solve(&full).unwrap();
    let (again_newton, again_factorisations) = (again.iterations, sparse.factorisations - before);
    let before = sparse.factorisations;
    let short = sparse.solve(&quarter).unwrap();
    let (short_newton, short_factorisations) = (short.iterations, sparse.factorisations - before);
    let largest = first.normal.iter().fold(0.0f64, |m, n| m.max(n.abs()));
    assert!(largest > 1.0, "no load: {largest} N");
    for (a, b) in first.normal.iter().zip(&short.normal) {
        assert!((a - b).abs() <= 1e-6 * largest, "{a} N vs {b} N");
    }
    assert!(
        short_newton <= again_newton && short_factorisations <= again_factorisations,
        "a quarter step: {short_newton} Newton steps, {short_factorisations} factorisations; \
         the same step again: {again_newton}, {again_factorisations}"
    );
}

/// The impact stepper's velocity back-end (`SparseSolver::for_velocities`) starts a problem
/// cold when the last solution moved: on the velocity problems of a rocking 25-block column
/// (`min 1/2 (v - v*)' M (v - v*)` under its contact rows, `v*` the column rocking about its
/// corner, then the same motion a thousand times slower), the second is solved exactly as by
/// a new back-end, where the general back-end starts it from the first one's impulses, to the
/// same velocities at a higher cost.
#[test]
fn velocity_problems_after_motion_start_cold() {
    let scene = column(25, "sparse", 1.0);
    let (stepper, state) = rockbench::native::stepper_for(&scene).unwrap();
    let mut pr = stepper.next_problem(&state);
    pr.theta = 1.0;
    pr.dt = 1.0;
    pr.force.iter_mut().for_each(|f| *f = 0.0);
    // The column rocking about the right corner of its base at 1 rad/s: block k at height
    // z_k moves by (-z_k, x_k) omega, and turns at omega.
    let n = pr.v0.len() / 3;
    let rocking: Vec<f64> = (0..n)
        .flat_map(|k| {
            let z = 0.2 * k as f64 + 0.1;
            [-z, -0.5, 1.0]
        })
        .collect();
    let with = |scale: f64| {
        let mut p = pr.clone();
        p.v0 = rocking.iter().map(|v| v * scale).collect();
        p
    };
    let (moving, slower) = (with(1.0), with(1e-3));
    let mut new_back_end = SparseSolver::for_velocities();
    let fresh = new_back_end.solve(&slower).unwrap();
    let mut velocities = SparseSolver::for_velocities();
    let first = velocities.solve(&moving).unwrap();
    assert!(
        first.dq.iter().any(|v| v.abs() > 1e-3),
        "the column does not move"
    );
    let before = velocities.factorisations;
    let again = velocities.solve(&slower).unwrap();
    assert_eq!(again.dq, fresh.dq, "not solved as by a new back-end");
    assert_eq!(again.normal, fresh.normal);
    assert_eq!(
        velocities.factorisations - before,
        new_back_end.factorisations
    );
    // The general back-end starts it from the first problem's impulses, a thousand times too
    // large, and pays for it (measured: 69 factorisations against 25).
    let mut general = SparseSolver::new();
    general.solve(&moving).unwrap();
    let before = general.factorisations;
    let warm = general.solve(&slower).unwrap();
    // The same velocities to the back-end's tolerance (rows hold to 1e-11; measured 1.0e-11
    // apart).
    for (a, b) in warm.dq.iter().zip(&fresh.dq) {
        assert!((a - b).abs() <= 1e-10, "{a} vs {b}");
    }
    assert!(general.factorisations - before > new_back_end.factorisations);
}

/// tests/scenes/cycling-working-set-step.json is a displacement problem of a running-bond wall of
/// 3 courses of 4 blocks pushed at its top (39 DOFs, 60 points, 120 rows; impacts located), on
/// which the dense back-end's working-set search cycles among the nearly dependent rows of its
/// flat interfaces, under both of its rules. It went on to each rule's move limit (`3 rows +
/// 10`, then `20 rows + 50`), refactorising the working set at every move: 55 such problems
/// cost 2.3 s of the wall's 3.7 s over 10 steps, before `auto` gave them to the sparse
/// back-end. A working set met again now ends the search: the same failure, found at once.
#[test]
fn a_cycling_working_set_search_fails_at_its_first_repeat() {
    let pr = stored_problem("cycling-working-set-step.json");
    let rows = 2 * pr.contacts.len();
    let err = ActiveSetSolver::new().solve(&pr).unwrap_err().to_string();
    let moves: usize = err
        .strip_prefix("active-set: the working set search cycles after ")
        .and_then(|rest| rest.strip_suffix(" moves"))
        .unwrap_or_else(|| panic!("not a cycle found: {err}"))
        .parse()
        .unwrap();
    assert!(moves < 3 * rows + 10, "{moves} moves for {rows} rows");
    // The problem itself is sound: the sparse back-end (where `auto` sends it) and Clarabel
    // agree on it.
    let sparse = SparseSolver::new().solve(&pr).unwrap();
    let clarabel = ClarabelSolver::new(&NativeSettings::default())
        .solve(&pr)
        .unwrap();
    let largest = clarabel.dq.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let worst = sparse
        .dq
        .iter()
        .zip(&clarabel.dq)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        largest > 1e-6 && worst < 1e-9,
        "sparse against Clarabel: {worst:e} m (largest dq {largest:e} m)"
    );
}

/// The inputs of Clarabel's active-set polish (the scaled QP, its rows, the interior-point
/// solution and multipliers), stored as data.
#[derive(serde::Deserialize)]
struct PolishInputs {
    p: Vec<f64>,
    q: Vec<f64>,
    rows: Vec<Vec<(usize, f64)>>,
    r: Vec<f64>,
    z: Vec<f64>,
    dt: f64,
    u: Vec<f64>,
}

/// tests/scenes/cycling-polish.json holds the polish's inputs for a problem of 13 blocks (39
/// DOFs, 36 rows) from a running-bond wall of 8 courses of 8 blocks pushed at its top, solved with
/// `solver = "clarabel"`. The polish's moves used to cycle there among the nearly dependent rows
/// of the blocks' flat interfaces, and the interior-point solution stood. Its working sets now
/// take the independent rows (a dependent row that does not hold takes the place of one of
/// them), and the polish finds the QP's minimiser: the same as Lemke's method gives on the QP's
/// dual LCP, `w = D P^-1 D' l + r - D P^-1 q >= 0`, `l >= 0`, `l'w = 0`, `u = P^-1 (D'l - q)`.
#[test]
fn the_polish_of_a_wall_problem_with_dependent_rows_finds_the_minimiser() {
    use rockbench::native::solver::lemke::lemke;
    let d: PolishInputs = stored("cycling-polish.json");
    let polished = polish(&d.p, &d.q, &d.rows, &d.r, &d.z, d.dt, &d.u).expect("polished");
    // The rows, dense, and the LCP.
    let (n, m) = (d.p.len(), d.rows.len());
    let mut dense = vec![0.0; m * n];
    for (i, row) in d.rows.iter().enumerate() {
        for &(j, v) in row {
            dense[i * n + j] += v;
        }
    }
    let mut mat = vec![0.0; m * m];
    let mut lcp_q = d.r.clone();
    for i in 0..m {
        for j in 0..m {
            mat[i * m + j] = (0..n)
                .map(|k| dense[i * n + k] * dense[j * n + k] / d.p[k])
                .sum();
        }
        lcp_q[i] -= (0..n)
            .map(|k| dense[i * n + k] * d.q[k] / d.p[k])
            .sum::<f64>();
    }
    let l = lemke(&mat, &lcp_q, 100 * m, 1e-9, 1e-11).expect("Lemke solves the dual LCP");
    let u: Vec<f64> = (0..n)
        .map(|k| ((0..m).map(|i| dense[i * n + k] * l.z[i]).sum::<f64>() - d.q[k]) / d.p[k])
        .collect();
    let scale = u.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let worst = u
        .iter()
        .zip(&polished)
        .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    assert!(scale > 1e-3, "the wall moves: largest |u| {scale:e}");
    // Measured: 5e-16 of the largest |u|.
    assert!(
        worst < 1e-10 * scale,
        "polish against Lemke: {worst:e} (largest |u| {scale:e})"
    );
    let violated = d.rows.iter().zip(&d.r).fold(0.0f64, |a, (row, r)| {
        a.min(row.iter().map(|&(j, c)| c * polished[j]).sum::<f64>() + r)
    });
    assert!(violated > -1e-9, "a row violated by {violated:e}");
}

/// `auto` gives the dense back-end problems of at most `AUTO_DENSE_MAX_DOFS` DOFs and
/// `AUTO_DENSE_MAX_POINTS` points. tests/scenes/wall-step-of-60-points.json, a displacement
/// problem of the 13-block wall above (39 DOFs, 60 points), is one the dense back-end solves,
/// at a dense factorisation of its working set a move; it goes to the sparse back-end, which
/// factorises its envelope. The same problem cut to its first 28 points goes to the dense one,
/// which does not.
#[test]
fn auto_gives_the_dense_back_end_few_points() {
    use rockbench::native::solver::{AUTO_DENSE_MAX_DOFS, AUTO_DENSE_MAX_POINTS, whole_solver_for};
    let wall = stored_problem("wall-step-of-60-points.json");
    assert!(wall.n_dof() <= AUTO_DENSE_MAX_DOFS && wall.contacts.len() > AUTO_DENSE_MAX_POINTS);
    let mut few = wall.clone();
    few.contacts.truncate(AUTO_DENSE_MAX_POINTS);
    for pr in [&wall, &few] {
        ActiveSetSolver::new()
            .solve(pr)
            .expect("the dense back-end solves it");
    }
    for (pr, sparse) in [(&wall, true), (&few, false)] {
        let mut auto = whole_solver_for(&NativeSettings::default());
        auto.solve(pr).unwrap();
        assert_eq!(
            auto.factorisations() > 0,
            sparse,
            "{} points: {} factorisations",
            pr.contacts.len(),
            auto.factorisations()
        );
    }
}
