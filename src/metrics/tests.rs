//! Metric tests on synthetic histories with known answers and on the Housner engine's output.

use super::*;
use crate::engines::{Engine, housner::HousnerEngine};
use crate::scene::parse_scene_str;
use std::f64::consts::PI;

const ONE_BLOCK: &str = r#"
name = "synthetic"
duration = 4.0
[[blocks]]
name = "block"
width = 1.0
height = 2.5
"#;

const TWO_BLOCKS: &str = r#"
name = "synthetic-stack"
duration = 4.0
[[blocks]]
name = "pedestal"
width = 1.25
height = 1.25
[[blocks]]
name = "statue"
width = 1.0
height = 2.5
"#;

fn scene(text: &str) -> Scene {
    parse_scene_str(text, false, "test.toml", &[]).unwrap()
}

/// A run whose blocks have the given rotation histories (everything else zero).
fn synthetic(name: &str, blocks: &[&str], t: &[f64], phis: &[Vec<f64>]) -> Run {
    let names: Vec<String> = blocks.iter().map(|s| s.to_string()).collect();
    let mut tr = Trajectory::new(&names);
    for k in 0..t.len() {
        let states: Vec<[f64; 6]> = phis
            .iter()
            .map(|p| [0.0, 0.0, p[k], 0.0, 0.0, 0.0])
            .collect();
        tr.push(t[k], &states);
    }
    Run {
        name: name.into(),
        trajectory: tr,
        exact_impacts: None,
        cost: Cost::default(),
    }
}

fn times(t1: f64, dt: f64) -> Vec<f64> {
    grid::uniform_grid(0.0, t1, dt)
}

fn get(rows: &[MetricRow], block: &str, metric: &str) -> (Option<f64>, Option<f64>) {
    let r = rows
        .iter()
        .find(|r| r.block == block && r.metric == metric)
        .unwrap_or_else(|| panic!("no row {block} {metric}"));
    (r.value, r.reference)
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol,
        "{what}: {a} vs expected {b} (tol {tol})"
    );
}

#[test]
fn shifted_sines_have_the_closed_form_rms_and_max_error() {
    // phi_ref = A cos(2 pi t), phi = A cos(2 pi (t - s)) on [0, 2] (two whole periods);
    // the difference is -2 A sin(pi s) sin(2 pi t - pi s): RMS sqrt(2) A |sin(pi s)|,
    // max 2 A |sin(pi s)|. The engine is sampled at 0.5 ms and the reference at 2 ms, so
    // the common grid does the work.
    let (a, s) = (0.1, 0.01);
    let ta = times(2.0, 5e-4);
    let tr = times(2.0, 2e-3);
    let run = synthetic(
        "shifted",
        &["block"],
        &ta,
        &[ta.iter().map(|t| a * (2.0 * PI * (t - s)).cos()).collect()],
    );
    let reference = synthetic(
        "ref",
        &["block"],
        &tr,
        &[tr.iter().map(|t| a * (2.0 * PI * t).cos()).collect()],
    );
    let sc = scene(ONE_BLOCK);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    let want_rms = 2f64.sqrt() * a * (PI * s).sin();
    let want_max = 2.0 * a * (PI * s).sin();
    close(
        get(&rows, "block", "rotation_rms_error").0.unwrap(),
        want_rms,
        1e-3 * want_rms,
        "rms",
    );
    close(
        get(&rows, "block", "rotation_max_error").0.unwrap(),
        want_max,
        1e-3 * want_max,
        "max",
    );
    close(
        get(&rows, "block", "rotation_rms_error_normalised")
            .0
            .unwrap(),
        want_rms / a,
        1e-3 * want_rms / a,
        "normalised rms",
    );
    // Up to the reference's first impact (t = 0.25): the mean square of the closed-form
    // difference over the 1 ms grid points of [0, 0.25].
    let g = grid::uniform_grid(0.0, 0.25, 1e-3);
    let ms: f64 = g
        .iter()
        .map(|t| {
            let d = -2.0 * a * (PI * s).sin() * (2.0 * PI * t - PI * s).sin();
            d * d
        })
        .sum::<f64>()
        / g.len() as f64;
    close(
        get(&rows, "block", "rotation_rms_error_to_impact_1")
            .0
            .unwrap(),
        ms.sqrt(),
        2e-3 * ms.sqrt(),
        "rms to impact 1",
    );
    // Crossings of the reference at 0.25, 0.75, 1.25, 1.75, of the engine 10 ms later.
    assert_eq!(get(&rows, "block", "impact_count"), (Some(4.0), Some(4.0)));
    assert_eq!(get(&rows, "block", "impacts_unmatched").0, Some(0.0));
    for k in 1..=4 {
        let want = 0.5 * k as f64 - 0.25;
        let (v, r) = get(&rows, "block", &format!("impact_time_{k}"));
        close(r.unwrap(), want, 1e-5, "reference crossing");
        close(v.unwrap(), want + s, 1e-6, "engine crossing");
    }
    close(
        get(&rows, "block", "impact_time_max_abs_diff").0.unwrap(),
        s,
        1e-5,
        "max impact time difference",
    );
    // Every half-wave peaks at A (the last one, still rising at t = 2, is not a peak).
    for k in 0..=3 {
        let (v, r) = get(&rows, "block", &format!("peak_amplitude_{k}"));
        close(v.unwrap(), a, 1e-6, "engine peak");
        close(r.unwrap(), a, 1e-6, "reference peak");
    }
    assert!(!rows.iter().any(|r| r.metric == "peak_amplitude_4"));
}

#[test]
fn extra_crossings_are_unmatched() {
    // Reference sin(2 pi t) on [0, 2.25]: crossings 0.5, 1, 1.5, 2. Engine sin(2 pi 1.3 t):
    // crossings k / 2.6 for k = 1..5 (0.385 ... 1.923).
    let t = times(2.25, 1e-3);
    let run = synthetic(
        "fast",
        &["block"],
        &t,
        &[t.iter().map(|x| 0.1 * (2.6 * PI * x).sin()).collect()],
    );
    let reference = synthetic(
        "ref",
        &["block"],
        &t,
        &[t.iter().map(|x| 0.1 * (2.0 * PI * x).sin()).collect()],
    );
    let rows = compare_runs(
        &scene(ONE_BLOCK),
        &run,
        &reference,
        &MetricSettings::default(),
    )
    .unwrap();
    assert_eq!(get(&rows, "block", "impact_count"), (Some(5.0), Some(4.0)));
    assert_eq!(get(&rows, "block", "impacts_unmatched").0, Some(1.0));
    let (v, r) = get(&rows, "block", "impact_time_5");
    close(v.unwrap(), 5.0 / 2.6, 1e-6, "5th engine crossing");
    assert_eq!(r, None);
    // Matched pairs in order: the largest difference is the 4th, 2.0 - 4/2.6.
    close(
        get(&rows, "block", "impact_time_max_abs_diff").0.unwrap(),
        2.0 - 4.0 / 2.6,
        1e-6,
        "max diff",
    );
}

/// Amplitudes after each impact for a block whose angular velocity is multiplied by `r` at
/// each impact (energy ratio r^2): A_k from E(A_k) = r^2 E(A_{k-1}).
fn housner_amplitudes(alpha: f64, a0: f64, r: f64, n: usize) -> Vec<f64> {
    let e = |a: f64| (alpha - a).cos() - alpha.cos();
    let mut out = vec![a0];
    for _ in 1..n {
        let en = r * r * e(*out.last().unwrap());
        out.push(alpha - (alpha.cos() + en).acos());
    }
    out
}

#[test]
fn decaying_sequence_restitution_and_rest_times() {
    // |phi| = A_k |sin(pi t)| on [k, k+1), alternating sign (impacts at the integers), with
    // A_k following an energy ratio r^2 per impact: the effective restitution is r.
    let sc = scene(ONE_BLOCK);
    let alpha = sc.blocks[0].critical_angle();
    let r = 0.8;
    let amps = housner_amplitudes(alpha, 0.1, r, 18);
    assert!(amps[17] < 1e-4);
    let t = times(17.5, 1e-3);
    let phi: Vec<f64> = t
        .iter()
        .map(|x| {
            let k = (x.floor() as usize).min(17);
            amps[k] * (PI * x).sin()
        })
        .collect();
    let run = synthetic("decay", &["block"], &t, std::slice::from_ref(&phi));
    // Reference: the same with r = 0.7.
    let amps7 = housner_amplitudes(alpha, 0.1, 0.7, 18);
    let phi7: Vec<f64> = t
        .iter()
        .map(|x| amps7[(x.floor() as usize).min(17)] * (PI * x).sin())
        .collect();
    let reference = synthetic("decay7", &["block"], &t, &[phi7]);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    for k in 1..=12 {
        let (v, rr) = get(&rows, "block", &format!("restitution_{k}"));
        close(v.unwrap(), r, 1e-6, &format!("restitution {k}"));
        close(
            rr.unwrap(),
            0.7,
            1e-6,
            &format!("reference restitution {k}"),
        );
    }
    close(
        get(&rows, "block", "housner_restitution").0.unwrap(),
        1.0 - 1.5 * alpha.sin().powi(2),
        1e-12,
        "Housner's r",
    );
    // Rest time at eps: the last segment with A_k >= eps falls below eps for good at
    // t = k + 1 - asin(eps / A_k) / pi (then the next sample).
    for (key, eps) in crate::events::REST_THRESHOLDS {
        let k = amps.iter().rposition(|a| *a >= eps).unwrap();
        let want = k as f64 + 1.0 - (eps / amps[k]).asin() / PI;
        let got = get(&rows, "block", &format!("rest_time_{key}")).0.unwrap();
        close(got, want, 1.01e-3, &format!("rest time at {key}"));
    }
}

#[test]
fn overturning_disagreement_is_reported() {
    let t = times(2.0, 1e-3);
    let run = synthetic(
        "falls",
        &["block"],
        &t,
        &[t.iter().map(|x| 0.2 + x * x).collect()],
    );
    let reference = synthetic("stands", &["block"], &t, &[vec![0.05; t.len()]]);
    let sc = scene(ONE_BLOCK);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    assert_eq!(get(&rows, "block", "overturned"), (Some(1.0), Some(0.0)));
    assert_eq!(get(&rows, "block", "overturning_agrees").0, Some(0.0));
    // |phi| crosses atan(0.4) at t = sqrt(atan(0.4) - 0.2).
    let want = (0.4f64.atan() - 0.2).sqrt();
    close(
        get(&rows, "block", "overturn_time").0.unwrap(),
        want,
        1e-6,
        "overturn time",
    );
}

/// Over an assembly (interfaces not counted): the run overturns the statue alone, the
/// reference both blocks together: one block against two, one disagreement (the pedestal).
#[test]
fn overturned_blocks_are_counted_over_the_assembly() {
    let t = times(2.0, 1e-3);
    let still = vec![0.0; t.len()];
    let falls: Vec<f64> = t.iter().map(|x| 0.2 + x * x).collect();
    let run = synthetic(
        "statue falls",
        &["pedestal", "statue"],
        &t,
        &[still.clone(), falls.clone()],
    );
    let reference = synthetic(
        "pedestal falls",
        &["pedestal", "statue"],
        &t,
        &[falls.clone(), falls],
    );
    let sc = scene(TWO_BLOCKS);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    assert_eq!(
        get(&rows, RUN_ROW, "overturned_count"),
        (Some(1.0), Some(2.0))
    );
    assert_eq!(
        get(&rows, RUN_ROW, "overturning_disagreements"),
        (Some(1.0), None)
    );
    let same = compare_runs(&sc, &run, &run, &MetricSettings::default()).unwrap();
    assert_eq!(
        get(&same, RUN_ROW, "overturning_disagreements"),
        (Some(0.0), None)
    );
}

/// The statue (1.0 m wide) slides off its pedestal by 1.5 m in the run and by 0.5 m in the
/// reference, tilting to 0.1 rad, below its critical angle atan(1/2.5): displaced in the run
/// only, overturned in neither.
#[test]
fn a_block_that_falls_off_without_overturning_is_displaced() {
    let t = times(2.0, 1e-3);
    let names = ["pedestal".to_string(), "statue".to_string()];
    let sliding = |name: &str, dx: f64| {
        let mut tr = Trajectory::new(&names);
        for &tk in &t {
            let s = (tk / 1.5).min(1.0);
            tr.push(tk, &[[0.0; 6], [dx * s, 0.0, 0.1 * s, 0.0, 0.0, 0.0]]);
        }
        Run {
            name: name.into(),
            trajectory: tr,
            exact_impacts: None,
            cost: Cost::default(),
        }
    };
    let (run, reference) = (sliding("off", 1.5), sliding("on", 0.5));
    let sc = scene(TWO_BLOCKS);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    assert_eq!(get(&rows, "statue", "overturned"), (Some(0.0), Some(0.0)));
    assert_eq!(get(&rows, "statue", "displaced"), (Some(1.0), Some(0.0)));
    assert_eq!(get(&rows, "pedestal", "displaced"), (Some(0.0), Some(0.0)));
    assert_eq!(
        get(&rows, RUN_ROW, "displaced_count"),
        (Some(1.0), Some(0.0))
    );
    assert_eq!(
        get(&rows, RUN_ROW, "displacement_disagreements"),
        (Some(1.0), None)
    );
    assert_eq!(
        get(&rows, RUN_ROW, "overturning_disagreements"),
        (Some(0.0), None)
    );
    // The largest difference of a final displacement over the blocks: the statue's 1.5 - 0.5.
    let (diff, none) = get(&rows, RUN_ROW, "displacement_x_final_max_abs_diff");
    assert!(none.is_none());
    close(diff.unwrap(), 1.0, 1e-12, "largest displacement difference");
    let same = compare_runs(&sc, &run, &run, &MetricSettings::default()).unwrap();
    assert_eq!(
        get(&same, RUN_ROW, "displacement_x_final_max_abs_diff"),
        (Some(0.0), None)
    );
    // An overturned block is displaced wherever it lies.
    assert!(is_displaced(true, Some(0.0), 1.0));
    assert!(!is_displaced(false, None, 1.0));
}

#[test]
fn interfaces_use_the_relative_rotation() {
    // Pedestal phi_p = 0.01 sin(pi t); statue phi_s = phi_p + 0.05 sin(2 pi t): the interface
    // crosses zero at 0.5, 1, 1.5 while the statue's absolute rotation does not there.
    let sc = scene(TWO_BLOCKS);
    let labels: Vec<String> = series_of(&sc).into_iter().map(|s| s.label).collect();
    assert_eq!(labels, ["pedestal", "statue", "pedestal/statue"]);
    let t = times(2.0, 1e-3);
    let p: Vec<f64> = t.iter().map(|x| 0.01 * (PI * x).sin()).collect();
    let rel: Vec<f64> = t.iter().map(|x| 0.05 * (2.0 * PI * x).sin()).collect();
    let s: Vec<f64> = p.iter().zip(&rel).map(|(a, b)| a + b).collect();
    let run = synthetic("a", &["pedestal", "statue"], &t, &[p.clone(), s.clone()]);
    // Reference: the statue rotated rigidly with the pedestal (relative rotation zero).
    let reference = synthetic("ref", &["pedestal", "statue"], &t, &[p.clone(), p.clone()]);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    let (v, r) = get(&rows, "pedestal/statue", "impact_count");
    assert_eq!((v, r), (Some(3.0), Some(0.0)));
    close(
        get(&rows, "pedestal/statue", "impact_time_1").0.unwrap(),
        0.5,
        1e-6,
        "interface crossing",
    );
    // Interface error = relative rotation itself: RMS 0.05 / sqrt(2) over whole periods.
    close(
        get(&rows, "pedestal/statue", "rotation_rms_error")
            .0
            .unwrap(),
        0.05 / 2f64.sqrt(),
        1e-4,
        "interface rms",
    );
    // The pedestal is identical in both.
    assert_eq!(get(&rows, "pedestal", "rotation_max_error").0, Some(0.0));
    // Impact metrics are not reported on the statue's absolute rotation.
    assert!(
        !rows
            .iter()
            .any(|r| r.block == "statue" && r.metric == "impact_count")
    );
}

#[test]
fn mismatched_blocks_are_an_error() {
    let t = times(1.0, 1e-3);
    let run = synthetic("a", &["other"], &t, &[vec![0.0; t.len()]]);
    let reference = synthetic("ref", &["block"], &t, &[vec![0.0; t.len()]]);
    let e = compare_runs(
        &scene(ONE_BLOCK),
        &run,
        &reference,
        &MetricSettings::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("other"), "{e}");
}

fn housner_run(text: &str, name: &str) -> Run {
    let sc = scene(text);
    let out = HousnerEngine.run(&sc).unwrap();
    Run {
        name: name.into(),
        trajectory: out.trajectory,
        exact_impacts: out.exact_impacts,
        cost: Cost::default(),
    }
}

const SLENDER: &str = r#"
name = "housner-slender"
duration = 4.0
[[blocks]]
name = "block"
width = 1.0
height = 2.5
density = 2500
[initial]
tilt = 0.15
"#;

#[test]
fn housner_output_gives_housners_numbers() {
    let sc = scene(SLENDER);
    let run = housner_run(SLENDER, "housner");
    let rows = compare_runs(&sc, &run, &run, &MetricSettings::default()).unwrap();
    // Against itself: no error, everything matched.
    assert_eq!(get(&rows, "block", "rotation_max_error").0, Some(0.0));
    assert_eq!(get(&rows, "block", "impacts_unmatched").0, Some(0.0));
    // The checked numbers of the slender block (FORMULATION.md).
    close(
        get(&rows, "block", "impact_time_1").0.unwrap(),
        0.4674,
        1e-4,
        "first impact",
    );
    for (k, a) in [(1, 0.0856), (2, 0.0513), (3, 0.0314)] {
        close(
            get(&rows, "block", &format!("peak_amplitude_{k}"))
                .0
                .unwrap(),
            a,
            1e-4,
            &format!("amplitude after impact {k}"),
        );
    }
    // The effective restitution read back from the peaks is Housner's coefficient.
    let alpha = 0.4f64.atan();
    let r = 1.0 - 1.5 * alpha.sin().powi(2);
    for k in 1..=5 {
        close(
            get(&rows, "block", &format!("restitution_{k}")).0.unwrap(),
            r,
            2e-5,
            &format!("restitution {k}"),
        );
    }
    // Energy: initially m g (R cos(alpha - 0.15) - h); after the first impact r^2 of it
    // (energy is conserved between impacts in Housner's model).
    let b = &sc.blocks[0];
    let big_r = (0.5f64).hypot(1.25);
    let e0 = b.mass() * 9.81 * (big_r * (alpha - 0.15).cos() - 1.25);
    close(
        get(&rows, "block", "energy_initial").0.unwrap(),
        e0,
        1e-6 * e0,
        "initial energy",
    );
    let e = block_energy(&sc, &run.trajectory, 0, rest_heights(&sc)[0]);
    let t1 = get(&rows, "block", "impact_time_1").0.unwrap();
    let t2 = get(&rows, "block", "impact_time_2").0.unwrap();
    let k = run.trajectory.t.partition_point(|t| *t < 0.5 * (t1 + t2));
    close(e[k], r * r * e0, 1e-6 * e0, "energy after the first impact");
}

#[test]
fn housner_with_another_restitution_agrees_until_the_first_impact() {
    let sc = scene(SLENDER);
    let reference = housner_run(SLENDER, "housner");
    let run = housner_run(
        &format!("{SLENDER}\n[housner]\nrestitution = 0.75\n"),
        "housner-r0.75",
    );
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    assert!(
        get(&rows, "block", "rotation_max_error_to_impact_1")
            .0
            .unwrap()
            < 1e-12
    );
    close(
        get(&rows, "block", "impact_time_1").0.unwrap(),
        get(&rows, "block", "impact_time_1").1.unwrap(),
        1e-12,
        "first impact",
    );
    close(
        get(&rows, "block", "restitution_1").0.unwrap(),
        0.75,
        2e-5,
        "restitution",
    );
    // A smaller restitution ends the rocking earlier, and the whole-window error is not zero.
    let (rest, rest_ref) = get(&rows, "block", "rest_time_1e-3");
    assert!(rest.unwrap() < rest_ref.unwrap());
    assert!(get(&rows, "block", "rotation_rms_error").0.unwrap() > 1e-3);
}

#[test]
fn known_metric_names() {
    for m in [
        "rotation_rms_error",
        "rotation_max_error_normalised_to_impact_3",
        "impact_time_12",
        "rest_time_3e-2",
        "restitution_1",
        "peak_amplitude_0",
        "wall_time",
    ] {
        assert!(is_known_metric(m), "{m}");
    }
    for m in [
        "rest_time_5e-2",
        "impact_time_",
        "rotation_rms",
        "peak_amplitude_x",
        "impact_time_0",
        "restitution_01",
        "rotation_rms_error_to_impact_0",
    ] {
        assert!(!is_known_metric(m), "{m}");
    }
}

/// A reference read from a file is checked as data: its blocks, at least two samples, times
/// that increase and cover the run, and every value finite; a good one passes.
#[test]
fn a_reference_file_needs_two_finite_samples_of_the_scenes_blocks() {
    let sc = scene(ONE_BLOCK);
    assert_eq!(sc.duration, 4.0);
    // A reference held at the scene's start.
    let start = sc.layout().blocks[0];
    let at_start = |t: &[f64]| {
        let mut r = synthetic("ref.csv", &["block"], t, &[vec![start.phi; t.len()]]);
        for b in &mut r.trajectory.blocks {
            b.x.iter_mut().for_each(|x| *x = start.x);
            b.z.iter_mut().for_each(|z| *z = start.z);
        }
        r
    };
    let good = at_start(&[0.0, 2.0, 4.0]);
    assert_eq!(check_reference_file(&sc, &good), Ok(()));
    // Within its last interval of the duration, or past it: the run is covered.
    for times in [[0.0, 2.5, 3.5], [0.0, 2.0, 5.0]] {
        let covers = at_start(&times);
        assert_eq!(check_reference_file(&sc, &covers), Ok(()), "{times:?}");
    }
    // Starting elsewhere: the reference of another scene (it was compared as this one's).
    let elsewhere = synthetic(
        "ref.csv",
        &["block"],
        &[0.0, 2.0, 4.0],
        &[vec![start.phi; 3]],
    );
    assert_eq!(
        check_reference_file(&sc, &elsewhere)
            .unwrap_err()
            .to_string(),
        format!(
            "ref.csv: starts with block_z = 0 where the scene starts at {}: the reference of another scene or placement",
            start.z
        )
    );
    // Short of the duration, or from after 0 or before it: metrics of part of the run.
    for (times, covers) in [
        ([0.0, 1.0, 2.0], "0 to 2 s"),
        ([0.1, 2.0, 4.0], "0.1 to 4 s"),
        ([-0.1, 2.0, 4.0], "-0.1 to 4 s"),
    ] {
        let part = synthetic("ref.csv", &["block"], &times, &[vec![0.1; 3]]);
        assert_eq!(
            check_reference_file(&sc, &part).unwrap_err().to_string(),
            format!(
                "ref.csv: covers {covers}; a reference must cover the run, 0 to 4 s (its metrics are of the whole run)"
            )
        );
    }
    let one = synthetic("ref.csv", &["block"], &[0.0], &[vec![0.1]]);
    assert_eq!(
        check_reference_file(&sc, &one).unwrap_err().to_string(),
        "ref.csv: 1 sample(s); a reference needs at least two"
    );
    let nan = synthetic("ref.csv", &["block"], &[0.0, 1e-3], &[vec![0.1, f64::NAN]]);
    assert_eq!(
        check_reference_file(&sc, &nan).unwrap_err().to_string(),
        "ref.csv: `block_phi` is not finite at sample 1"
    );
    let other = synthetic("ref.csv", &["statue"], &[0.0, 1e-3], &[vec![0.1, 0.1]]);
    assert!(matches!(
        check_reference_file(&sc, &other),
        Err(MetricsError::Blocks { .. })
    ));
    // Two states at one time: which one the reference means there is not said.
    let repeated = synthetic(
        "ref.csv",
        &["block"],
        &[0.0, 1e-3, 1e-3, 2e-3],
        &[vec![0.1, 0.1, 0.09, 0.08]],
    );
    assert_eq!(
        check_reference_file(&sc, &repeated)
            .unwrap_err()
            .to_string(),
        "ref.csv: time 0.001 s is repeated at sample 2; a reference's times must increase (which of its states would hold there?)"
    );
}

/// A reference that does not rock (its largest |phi| at round-off, below the impacts' noise
/// floor) has no normalised error: a ratio of round-off said 1e12 %. With no impact in either
/// run, no impact instant differs.
#[test]
fn a_still_reference_has_no_normalised_error_and_no_impact_differs() {
    let sc = scene(ONE_BLOCK);
    let t = times(1.0, 1e-3);
    let still: Vec<f64> = t.iter().map(|x| 1e-16 * (7.0 * x).sin()).collect();
    let small: Vec<f64> = t.iter().map(|x| 3e-6 * (3.0 * x).sin().abs()).collect();
    let reference = synthetic("ref", &["block"], &t, &[still]);
    let run = synthetic("run", &["block"], &t, &[small]);
    let rows = compare_runs(&sc, &run, &reference, &MetricSettings::default()).unwrap();
    assert!(get(&rows, "block", "rotation_rms_error").0.unwrap() > 1e-6);
    assert_eq!(get(&rows, "block", "rotation_rms_error_normalised").0, None);
    assert_eq!(get(&rows, "block", "rotation_max_error_normalised").0, None);
    assert_eq!(get(&rows, "block", "impact_count"), (Some(0.0), Some(0.0)));
    assert_eq!(get(&rows, "block", "impact_time_max_abs_diff").0, Some(0.0));
}

/// A window that starts while the block falls back from a swing (1 s into the slender block's
/// free rocking) has no peak before its first impact: the rotation at its first sample was taken
/// for one, and the first restitution came out 1.018 against Housner's 0.793. One that starts
/// at the release keeps the initial tilt as its first peak.
#[test]
fn a_window_cut_in_a_fall_has_no_first_peak() {
    let sc = scene(SLENDER);
    let run = housner_run(SLENDER, "housner");
    let settings = |window| MetricSettings {
        window,
        ..MetricSettings::default()
    };
    let rows = compare_runs(&sc, &run, &run, &settings(Some((1.0, 4.0)))).unwrap();
    assert_eq!(get(&rows, "block", "peak_amplitude_0").0, None);
    assert_eq!(get(&rows, "block", "restitution_1").0, None);
    let e = get(&rows, "block", "restitution_2").0.unwrap();
    assert!((e - 0.7931).abs() < 1e-3, "{e}");
    let rows = compare_runs(&sc, &run, &run, &settings(None)).unwrap();
    assert_eq!(get(&rows, "block", "peak_amplitude_0").0, Some(0.15));
}
