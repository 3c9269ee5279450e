//! The core's acceptance checks: Housner's numbers, the native engine against Housner,
//! primal against dual, the paper's two-block case, and the two excitation routes.

mod common;

use rockbench::engines::{engine_by_name, run_timed};
use rockbench::native::solver::{ClarabelSolver, ContactSolver};
use rockbench::native::{Formulation, stepper_for};
use rockbench::scene::{Scene, load_scene, load_scene_with_overrides};
use rockbench::summary::Summary;
use std::path::Path;

fn scene(name: &str, set: &[&str]) -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("validation/scenes")
        .join(name);
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    load_scene_with_overrides(&p, &set).unwrap()
}

fn run(engine: &str, s: &Scene) -> (rockbench::engines::RunOutput, Summary) {
    run_timed(engine_by_name(engine).unwrap().as_ref(), s).unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn housner_slender_block_matches_the_published_numbers() {
    let (_, s) = run("housner", &scene("housner-slender.toml", &[]));
    let b = &s.blocks[0];
    assert!(
        (b.impacts[0] - 0.4674).abs() < 1e-4,
        "first impact {}",
        b.impacts[0]
    );
    for (k, want) in [(1, 0.0856), (2, 0.0513), (3, 0.0314)] {
        let got = b.peaks[k].amplitude;
        assert_eq!(b.peaks[k].after_impact, k);
        assert!(
            rel(got, want) < 3e-3,
            "amplitude after impact {k}: {got} vs {want}"
        );
    }
}

#[test]
fn housner_square_block_matches_the_published_numbers() {
    let (_, s) = run("housner", &scene("housner-square.toml", &[]));
    let b = &s.blocks[0];
    assert!(
        (b.impacts[0] - 0.2425).abs() < 1e-4,
        "first impact {}",
        b.impacts[0]
    );
    assert!(
        rel(b.peaks[1].amplitude, 0.00868) < 5e-3,
        "{}",
        b.peaks[1].amplitude
    );
    assert!(
        rel(b.peaks[2].amplitude, 0.00054) < 2e-2,
        "{}",
        b.peaks[2].amplitude
    );
}

/// Energy is conserved between impacts and multiplied by r^2 at each impact, so the
/// amplitudes follow in closed form: `cos(alpha - A_k) - cos(alpha) = r^2 (cos(alpha - A_{k-1})
/// - cos(alpha))`. Check the integrator against this independent calculation.
#[test]
fn housner_amplitudes_follow_energy_and_restitution_in_closed_form() {
    let (_, s) = run("housner", &scene("housner-slender.toml", &[]));
    let alpha: f64 = (0.5f64 / 1.25).atan();
    let r = 1.0 - 1.5 * alpha.sin().powi(2);
    // Potential energy above the rest position, per unit p^2: cos(alpha) - cos(alpha - A).
    let mut a: f64 = 0.15;
    for k in 1..=4 {
        let e = alpha.cos() - (alpha - a).cos();
        let e_after = r * r * e;
        a = alpha - (alpha.cos() - e_after).acos();
        let got = s.blocks[0].peaks[k].amplitude;
        // The peak is read off the 1 ms output grid: it can fall short by p^2 dt^2 / 8 < 1e-6.
        assert!(
            (got - a).abs() < 1e-6,
            "amplitude {k}: engine {got}, closed form {a}"
        );
    }
}

#[test]
fn native_slender_block_agrees_with_housner() {
    let sc = scene(
        "housner-slender.toml",
        &["native.theta=0.7", "native.dt=1e-3"],
    );
    let (_, h) = run("housner", &sc);
    let (_, n) = run("native", &sc);
    let (h, n) = (&h.blocks[0], &n.blocks[0]);
    assert!(
        (n.impacts[0] - h.impacts[0]).abs() < 1e-3,
        "first impact native {} housner {}",
        n.impacts[0],
        h.impacts[0]
    );
    let e1 = rel(n.peaks[1].amplitude, h.peaks[1].amplitude);
    assert!(
        e1 < 0.02,
        "amplitude after impact 1: native {} housner {}",
        n.peaks[1].amplitude,
        h.peaks[1].amplitude
    );
    for k in [2, 3] {
        let e = rel(n.peaks[k].amplitude, h.peaks[k].amplitude);
        assert!(
            e < 0.04,
            "amplitude after impact {k}: native {} housner {}",
            n.peaks[k].amplitude,
            h.peaks[k].amplitude
        );
    }
}

/// Both QPs solved on the very problems a 1 s primal run of the paper's stepper meets, step by
/// step (the impact stepper's problems depend on its own iterates: its primal and dual runs are
/// compared whole in `dual_formulation_runs_the_same_trajectory`).
#[test]
fn primal_and_dual_give_the_same_step_over_one_second() {
    for name in ["housner-slender.toml", "two-block-free-rocking.toml"] {
        let sc = scene(
            name,
            &[
                "duration=1.0",
                "native.solver=\"clarabel\"",
                "native.stepper=\"paper\"",
            ],
        );
        let (mut stepper, mut state) = stepper_for(&sc).unwrap();
        let ns = rockbench::native::settings_of(&sc).unwrap();
        let mut dual = ClarabelSolver::with_formulation(&ns, Formulation::Dual);
        let mut primal = ClarabelSolver::with_formulation(&ns, Formulation::Primal);
        let mut worst = 0.0f64;
        for _ in 0..1000 {
            let pr = stepper.next_problem(&state);
            let a = primal.solve(&pr).unwrap();
            let b = dual.solve(&pr).unwrap();
            for (x, y) in a.dq.iter().zip(&b.dq) {
                worst = worst.max((x - y).abs());
            }
            let taken = stepper.step(&mut state).unwrap();
            assert_eq!(taken.dq, a.dq, "the stepper solves the same problem");
        }
        assert!(
            worst < 1e-9,
            "{name}: largest |dq_primal - dq_dual| = {worst:e} m"
        );
    }
}

#[test]
fn dual_formulation_runs_the_same_trajectory() {
    let a = scene("housner-slender.toml", &["duration=1.0"]);
    let b = scene(
        "housner-slender.toml",
        &["duration=1.0", "native.formulation=\"dual\""],
    );
    let (ta, _) = run("native", &a);
    let (tb, _) = run("native", &b);
    let worst = ta.trajectory.blocks[0]
        .phi
        .iter()
        .zip(&tb.trajectory.blocks[0].phi)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(worst < 1e-7, "rotation difference {worst:e} rad");
}

#[test]
fn paper_two_block_case_ground_impact_then_upper_block_rocks() {
    let sc = scene("two-block-free-rocking.toml", &[]);
    assert_eq!(sc.duration, 6.0);
    let (out, s) = run("native", &sc);
    assert!((out.trajectory.t.last().unwrap() - 6.0).abs() < 1e-9);
    let lower = &s.blocks[0];
    let upper = &s.blocks[1];
    assert_eq!(upper.rotation, "relative to pedestal");
    let ground = lower.impacts[0];
    assert!(
        (ground - 0.606).abs() < 3e-3,
        "stack ground impact {ground}"
    );
    assert!(
        upper.impacts.len() >= 4,
        "upper block impacts {:?}",
        upper.impacts
    );
    assert!(
        upper.impacts[0] > ground && upper.impacts[0] < ground + 0.03,
        "{:?}",
        upper.impacts
    );
    // The stack rocks as one body until the ground impact.
    let k = out.trajectory.t.iter().position(|&t| t >= 0.3).unwrap();
    let d = (out.trajectory.blocks[0].phi[k] - out.trajectory.blocks[1].phi[k]).abs();
    assert!(d < 1e-6, "relative rotation before the ground impact {d}");
}

#[test]
fn inertial_forces_and_moving_ground_give_the_same_rotation() {
    let a = scene("support-movement-half-sine.toml", &[]);
    let b = scene(
        "support-movement-half-sine.toml",
        &["excitation.applied_as=\"moving-ground\""],
    );
    let (ta, sa) = run("native", &a);
    let (tb, _) = run("native", &b);
    assert!(sa.blocks[0].max_abs_phi > 0.01, "the pulse rocks the block");
    let worst = ta.trajectory.blocks[0]
        .phi
        .iter()
        .zip(&tb.trajectory.blocks[0].phi)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(worst < 1e-6, "rotation difference {worst:e} rad");
}

/// A prescribed displacement history (support movement) through both routes.
#[test]
fn displacement_history_gives_the_same_rotation_through_both_routes() {
    let dir = common::tmp("rb-disp", "record");
    // d(t) of a half-sine acceleration pulse of 6 m/s^2 over 0.3 s, sampled every 1 ms.
    let (amp, dur) = (6.0f64, 0.3f64);
    let mut csv = String::from("time,displacement\n");
    for k in 0..=2000 {
        let t = k as f64 * 1e-3;
        let s = t.min(dur);
        let pi = std::f64::consts::PI;
        let d =
            amp * dur / pi * (s - dur / pi * (pi * s / dur).sin()) + 2.0 * amp * dur / pi * (t - s);
        csv += &format!("{t},{d}\n");
    }
    std::fs::write(dir.join("disp.csv"), csv).unwrap();
    let text = |route: &str| {
        format!(
            "name = \"disp\"\nduration = 1.5\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 2.5\n\
             [excitation]\napplied_as = \"{route}\"\n[excitation.horizontal]\nkind = \"displacement\"\nfile = \"disp.csv\"\n"
        )
    };
    let mut phis = Vec::new();
    for route in ["inertial-forces", "moving-ground"] {
        let p = dir.join(format!("{route}.toml"));
        std::fs::write(&p, text(route)).unwrap();
        let (out, s) = run("native", &load_scene(&p).unwrap());
        assert!(
            s.blocks[0].max_abs_phi > 0.01,
            "{route}: the motion rocks the block"
        );
        phis.push(out.trajectory.blocks[0].phi.clone());
    }
    let worst = phis[0]
        .iter()
        .zip(&phis[1])
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(worst < 1e-6, "rotation difference {worst:e} rad");
}

/// Every velocity jump of a displacement record reaches a frictionless block, whatever the step
/// and the route: its velocity relative to the ground ends at minus the change of the record's
/// slope. The record's samples are at multiples of 1 ms, where `(k - 1) dt + dt` and `k dt`
/// differ in the last bit for some k; while each ground increment started at `k dt` and the
/// last one ended at `(k - 1) dt + dt`, a sample between the two lost its jump (dt 1e-4: 5 %
/// of the final velocity; 2e-4: 1.3 %).
#[test]
fn a_displacement_record_moves_a_frictionless_block_by_its_whole_velocity_at_any_step() {
    let dir = common::tmp("rb-disp-steps", "record");
    let (amp, dur) = (6.0f64, 0.3f64);
    let pi = std::f64::consts::PI;
    // A half-sine ground acceleration of `amp` over `dur`, then a constant velocity.
    let d_of = |t: f64| {
        let s = t.min(dur);
        amp * dur / pi * (s - dur / pi * (pi * s / dur).sin()) + 2.0 * amp * dur / pi * (t - s)
    };
    let ts: Vec<f64> = (0..=500).map(|k| k as f64 * 1e-3).collect();
    let mut csv = String::from("time,displacement\n");
    for &t in &ts {
        csv += &format!("{t},{}\n", d_of(t));
    }
    std::fs::write(dir.join("disp.csv"), csv).unwrap();
    let slope = |k: usize| (d_of(ts[k + 1]) - d_of(ts[k])) / (ts[k + 1] - ts[k]);
    let expected = -(slope(499) - slope(0));
    for route in ["inertial-forces", "moving-ground"] {
        let p = dir.join(format!("{route}.toml"));
        std::fs::write(
            &p,
            format!(
                "name = \"slip\"\nduration = 0.45\n[[blocks]]\nname = \"b\"\nwidth = 2.0\n\
                 height = 0.5\n[contact]\nfriction = 0.0\n[excitation]\napplied_as = \"{route}\"\n\
                 [excitation.horizontal]\nkind = \"displacement\"\nfile = \"disp.csv\"\n"
            ),
        )
        .unwrap();
        for dt in ["1e-3", "5e-4", "2e-4", "1e-4"] {
            let s = load_scene_with_overrides(&p, &[format!("native.dt={dt}")]).unwrap();
            let (out, _) = run("native", &s);
            let vx = *out.trajectory.blocks[0].vx.last().unwrap();
            assert!(
                (vx - expected).abs() < 1e-9,
                "{route}, dt {dt}: final relative velocity {vx} m/s, the record's {expected}"
            );
        }
    }
}

/// A displacement record of a constant 0.3 g ground acceleration, sampled at the step (1 ms),
/// below the block's uplift (0.4 g) and slip (0.7 g): each sample's velocity jump falls in the
/// step that ends at it, so the block stays still. (From 1.001 s, where `(k - 1) dt + dt` falls
/// a bit below `k dt`, the jumps went to the next step, two in one: the block chattered, 1.6e-5
/// rad and 8 impacts.)
#[test]
fn a_displacement_record_sampled_at_the_step_applies_each_jump_in_its_own_step() {
    let dir = common::tmp("rb-disp-steps", "constant");
    let a = 0.3 * 9.81;
    let mut csv = String::from("time,displacement\n");
    for k in 0..=2500 {
        let t = k as f64 * 1e-3;
        csv += &format!("{t},{}\n", 0.5 * a * t * t);
    }
    std::fs::write(dir.join("disp.csv"), csv).unwrap();
    let p = dir.join("still.toml");
    std::fs::write(
        &p,
        "name = \"still\"\nduration = 2.0\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 2.5\n\
         [contact]\nfriction = 0.7\n[native]\ndt = 1e-3\n[excitation.horizontal]\n\
         kind = \"displacement\"\nfile = \"disp.csv\"\n",
    )
    .unwrap();
    let s = load_scene_with_overrides(&p, &[]).unwrap();
    let (out, summary) = run("native", &s);
    let phi = out.trajectory.blocks[0]
        .phi
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs()));
    assert!(phi < 1e-12, "max |phi| {phi:e} rad");
    assert!(
        summary.blocks[0].impacts.is_empty(),
        "{:?}",
        summary.blocks[0].impacts
    );
}

/// The sign convention of ground acceleration is the same in both engines: a +x pulse throws
/// the block back (counter-clockwise, on its left corner), to about the same amplitude.
#[test]
fn native_and_housner_agree_under_a_ground_pulse() {
    let sc = scene("support-movement-half-sine.toml", &[]);
    let (th, h) = run("housner", &sc);
    let (tn, n) = run("native", &sc);
    let first_peak = |tr: &rockbench::trajectory::Trajectory| {
        let phi = &tr.blocks[0].phi;
        phi[phi
            .iter()
            .enumerate()
            .fold(0, |m, (i, p)| if p.abs() > phi[m].abs() { i } else { m })]
    };
    let (ph, pn) = (first_peak(&th.trajectory), first_peak(&tn.trajectory));
    assert!(
        ph > 0.01,
        "a +x ground pulse tips the block counter-clockwise: {ph}"
    );
    assert!(rel(pn, ph) < 0.02, "peak native {pn} housner {ph}");
    assert!((n.blocks[0].impacts[0] - h.blocks[0].impacts[0]).abs() < 2e-3);
}

#[test]
fn housner_refuses_stacks_with_a_clear_message() {
    let e = engine_by_name("housner")
        .unwrap()
        .run(&scene("two-block-free-rocking.toml", &[]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("single block") && e.contains("2 blocks"), "{e}");
}

/// An initial rotation rate is about the pivot corner, where the Housner model has it: the
/// engine takes it (it refused it as a sliding velocity) and rocks as the native engine does;
/// a sliding velocity it still refuses.
#[test]
fn housner_takes_an_initial_rotation_rate_and_refuses_a_sliding_one() {
    let s = scene(
        "housner-slender.toml",
        &["initial.blocks.block.omega=0.3", "duration=1"],
    );
    let (h, _) = run("housner", &s);
    let (n, _) = run("native", &s);
    let at = |out: &rockbench::engines::RunOutput, t: f64| {
        let k = out.trajectory.t.partition_point(|&x| x < t - 1e-12);
        (out.trajectory.t[k], out.trajectory.blocks[0].phi[k])
    };
    // Without the rate the block would turn back from 0.15 rad at once.
    let (t, phi) = at(&h, 0.3);
    assert!((t - 0.3).abs() < 1e-9 && phi > 0.185, "{phi}");
    for t in [0.1, 0.3, 0.5, 1.0] {
        let (th, ph) = at(&h, t);
        let (tn, pn) = at(&n, t);
        assert!((th - tn).abs() < 1e-9);
        assert!((ph - pn).abs() < 1e-5, "t = {t}: housner {ph}, native {pn}");
    }
    let e = engine_by_name("housner")
        .unwrap()
        .run(&scene(
            "housner-slender.toml",
            &["initial.blocks.block.vx=0.1"],
        ))
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not slide; initial vx must be 0"), "{e}");
}

/// A block placed by its absolute `x` is reported there by the Housner engine, as by the
/// native one (it was reported at the origin).
#[test]
fn housner_reports_a_block_placed_by_x_where_it_is() {
    let text = "name = \"placed\"\nduration = 0.5\n[[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1.0\nx = 5.0\n[initial]\ntilt = 0.1\n";
    let s = rockbench::scene::parse_scene_str(text, false, "placed", &[]).unwrap();
    let (h, _) = run("housner", &s);
    let (n, _) = run("native", &s);
    let (xh, xn) = (&h.trajectory.blocks[0].x, &n.trajectory.blocks[0].x);
    assert!(
        (xh[0] - xn[0]).abs() < 1e-12 && (xh[0] - 4.95).abs() < 0.01,
        "{} {}",
        xh[0],
        xn[0]
    );
    let last = |x: &Vec<f64>| *x.last().unwrap();
    assert!(
        (last(xh) - last(xn)).abs() < 1e-4,
        "{} {}",
        last(xh),
        last(xn)
    );
}

/// The tests' scratch directories (`common::tmp`) are removed when their test ends, and kept
/// for inspection when it panics.
#[test]
fn scratch_directories_go_with_their_test_unless_it_fails() {
    let dir = common::tmp("rb-scratch", "passing");
    let path = dir.to_path_buf();
    std::fs::write(dir.join("file"), "x").unwrap();
    assert!(path.join("file").is_file());
    drop(dir);
    assert!(!path.exists(), "{} left behind", path.display());

    let kept = std::sync::Mutex::new(None);
    let outcome = std::panic::catch_unwind(|| {
        let dir = common::tmp("rb-scratch", "failing");
        *kept.lock().unwrap() = Some(dir.to_path_buf());
        panic!("a failing test");
    });
    assert!(outcome.is_err());
    let path = kept.into_inner().unwrap().expect("the directory's path");
    assert!(path.is_dir(), "{} not kept", path.display());
    std::fs::remove_dir_all(&path).unwrap();
}

/// A rectangular pulse that ends where a Housner step starts: the step integrates no pulse, so
/// the angular velocity after it converges at RK4's order in the step (it converged at first
/// order, 1.7e-5 rad/s apart at 1e-4 and 1e-5 s, when that step took the pulse's last value),
/// and agrees with the native engine's.
#[test]
fn housner_steps_after_a_pulse_ends_integrate_no_pulse() {
    let text = "name = \"rect\"\nduration = 0.34\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[contact]\nfriction = 2.0\n[excitation.horizontal]\nkind = \"rectangular\"\namplitude = 5.0\nduration = 0.3\nstart = 0.0\n";
    let omega = |engine: &str, sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let sc = rockbench::scene::parse_scene_str(text, false, "rect", &sets).unwrap();
        let (out, _) = run(engine, &sc);
        let tr = &out.trajectory;
        tr.blocks[0].omega[tr.t.len() - 1]
    };
    let coarse = omega("housner", &["housner.max_step=1e-4"]);
    let fine = omega("housner", &["housner.max_step=1e-5"]);
    assert!((coarse - fine).abs() < 1e-9, "{coarse} against {fine}");
    let native = omega("native", &["native.dt=1e-4"]);
    assert!(
        (native - fine).abs() < 1e-5 * fine.abs(),
        "native {native}, Housner {fine}"
    );
}

/// Housner's model is a block rocking on its base: a ground falling faster than g (the block
/// leaves it) is refused, naming when (it rocked and overturned a block that a vertical pulse
/// alone cannot turn); a ground whose horizontal acceleration exceeds what friction passes,
/// `mu (g + a_z)`, is noted as possible sliding.
#[test]
fn housner_refuses_a_ground_falling_faster_than_g_and_notes_a_drag_beyond_friction() {
    let scene = |ax: f64, az: f64| {
        let text = format!(
            "name = \"v\"\nduration = 1.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[contact]\nfriction = 0.7\n\
             [excitation.horizontal]\nkind = \"rectangular\"\namplitude = {ax:?}\nduration = 0.5\nstart = 0.1\n\
             [excitation.vertical]\nkind = \"rectangular\"\namplitude = {az:?}\nduration = 0.5\nstart = 0.1\n"
        );
        rockbench::scene::parse_scene_str(&text, false, "v", &[]).unwrap()
    };
    let housner = engine_by_name("housner").unwrap();
    match housner.run(&scene(0.0, -12.0)) {
        Err(rockbench::engines::EngineError::Unsupported { reason, .. }) => {
            assert!(
                reason.contains("-12 m/s^2 at t = 0.1 s, at or below -g"),
                "{reason}"
            );
        }
        other => panic!("ran: {:?}", other.map(|o| o.notes)),
    }
    let drag = |ax: f64, az: f64| {
        let out = housner.run(&scene(ax, az)).unwrap();
        out.notes.iter().any(|n| n.contains("the block may slide"))
    };
    // 0.7 (9.81 - 9.5) = 0.217 m/s^2 against 3: the ground drags; 0.7 x 9.81 against 3: not.
    assert!(drag(3.0, -9.5));
    assert!(!drag(3.0, 0.0));
}

/// A record file changed during a run, or between two engines' runs of a comparison, would
/// give an answer of two motions: each is refused, naming the record.
#[test]
fn a_record_changed_while_it_is_read_is_refused() {
    use rockbench::compare::{CompareOptions, ReferenceSpec, compare_with, run_engine};
    let dir = common::tmp("rb-record-changed", "record");
    let record = |scale: f64| common::sine_record(scale, 12.0, 501);
    let file = dir.join("rec.csv");
    std::fs::write(&file, record(4.0)).unwrap();
    let p = dir.join("scene.toml");
    std::fs::write(
        &p,
        "name = \"r\"\nduration = 0.5\n[[blocks]]\nname = \"b\"\nwidth = 0.5\nheight = 2.0\n\
         [excitation.horizontal]\nkind = \"record\"\nfile = \"rec.csv\"\n",
    )
    .unwrap();
    let s = load_scene_with_overrides(&p, &[]).unwrap();
    let native = engine_by_name("native").unwrap();
    let (_, summary) = run_timed(native.as_ref(), &s).unwrap();
    assert_eq!(summary.record_sha256.len(), 1);
    let e = rockbench::engines::timed("native", &s, || {
        std::fs::write(&file, record(1.0)).unwrap();
        native.run(&s)
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("rec.csv: the record changed while the native run read it"),
        "{e}"
    );
    let mut opts = CompareOptions::new(
        vec!["native".into(), "housner".into()],
        ReferenceSpec::Engine("housner".into()),
    );
    opts.jobs = 1;
    let runner = |name: &str, scene: &rockbench::scene::Scene| {
        if name == "housner" {
            std::fs::write(&file, record(2.0)).unwrap();
        }
        run_engine(name, scene)
    };
    let e = compare_with(&s, &opts, &runner).err().unwrap().to_string();
    assert!(
        e.contains("the record files changed between the native and housner runs"),
        "{e}"
    );
}
