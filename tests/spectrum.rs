//! `rockbench spectrum` against the closed forms of the linearised slender block
//! (VULNERABILITY.md), the similarity law, and its one-line errors.

mod common;

use rockbench::engines::{Engine, housner::HousnerEngine, native::NativeEngine};
use rockbench::spectrum::*;
use std::f64::consts::PI;
use std::process::Command;

/// The closed-form block: B = 0.06 m, H = 2 m (alpha = 0.030 rad, p = 2.71 1/s), friction 2
/// (pure rocking), native step 5e-4 s (p dt = 1.4e-3).
fn slender() -> rockbench::scene::Scene {
    block_scene(0.06, 2.0, 2.0, &["native.dt=5e-4".to_string()]).unwrap()
}

/// (pulse, ratio, the design note's number, the minimum searched: `true` overturning without
/// impact).
fn cases() -> Vec<(Pulse, f64, f64, bool)> {
    vec![
        // Rectangular at p t_d = 0.5, 1, 2 (omega_p = pi / t_d): 1 / (1 - exp(-p t_d)).
        (Pulse::Rectangular, PI / 0.5, 2.542, false),
        (Pulse::Rectangular, PI / 1.0, 1.582, false),
        (
            Pulse::Rectangular,
            PI / 2.0,
            1.0 / (1.0 - (-2.0f64).exp()),
            false,
        ),
        (Pulse::HalfSine, 1.0, 1.322, false),
        (Pulse::HalfSine, 2.0, 1.801, false),
        (Pulse::HalfSine, 4.0, 2.791, false),
        (Pulse::OneSine, 1.0, 1.418, true),
        (Pulse::OneSine, 2.0, 2.350, true),
        (Pulse::OneSine, 4.0, 5.239, true),
    ]
}

fn check_engine(engine: &dyn Engine) {
    let scene = slender();
    let st = Settings::default();
    let mut worst = 0.0f64;
    for (pulse, ratio, note, no_impact) in cases() {
        let cf = closed_form(pulse, ratio).unwrap();
        // The closed form is the design note's number (rounded there to 3 decimals).
        assert!(
            (cf - note).abs() < 6e-4,
            "{pulse:?} {ratio}: {cf} vs {note}"
        );
        let sp = Spectrum::new(&scene, engine, pulse, &st);
        let m = if no_impact {
            sp.minimum(ratio, |o| o.without_impact).unwrap()
        } else {
            sp.minimum(ratio, |o| o.overturned).unwrap()
        };
        let a = m.amplitude.expect("overturns");
        let err = a / cf - 1.0;
        println!(
            "{} {:?} Pi={ratio:.4}: {a:.5} vs {cf:.5} ({:+.4} %), {} runs",
            engine.name(),
            pulse,
            err * 100.0,
            m.runs
        );
        // The bracket is the stated tolerance wide.
        assert!((a - m.safe_below) / a <= st.tolerance * 1.0001);
        assert!(
            err.abs() < 0.005,
            "{} {pulse:?} Pi={ratio}: {a} is {:.3} % from the closed form {cf}",
            engine.name(),
            err * 100.0
        );
        worst = worst.max(err.abs());
    }
    println!("{}: worst {:.4} %", engine.name(), worst * 100.0);
}

/// The early stops keep the minimum of slender blocks: an early stop says overturned once the
/// block is past its critical angle turning outwards, where the samples end and a block of B/H
/// 1e-3 or less turns too slowly for the rest threshold of `events::overturning` (1.80112 at
/// B/H = 1e-3, 3.36903 at 1e-5 and none at 1e-7 before, against 1.80077). The native engine
/// keeps it down to B/H = 1e-4 and refuses slenderer blocks (40 % off at 1e-6).
#[test]
fn early_stops_keep_the_minimum_of_slender_blocks() {
    let cf = closed_form(Pulse::HalfSine, 2.0).unwrap();
    let st = Settings::default();
    let cases: [(&dyn Engine, &[f64]); 2] = [
        (&HousnerEngine, &[1e-3, 1e-5, 1e-7]),
        (&NativeEngine, &[1e-3, 1e-4]),
    ];
    for (engine, widths) in cases {
        for &b in widths {
            let scene = block_scene(b, 1.0, 2.0, &[]).unwrap();
            let sp = Spectrum::new(&scene, engine, Pulse::HalfSine, &st);
            let a = sp.minimum(2.0, |o| o.overturned).unwrap().amplitude;
            let a = a.unwrap_or_else(|| panic!("{} B/H = {b:e}: no overturn", engine.name()));
            assert!(
                (a / cf - 1.0).abs() < 2.0 * st.tolerance,
                "{} B/H = {b:e}: {a} against the closed form {cf}",
                engine.name()
            );
        }
    }
    let needle = block_scene(1e-6, 1.0, 2.0, &[]).unwrap();
    let sp = Spectrum::new(&needle, &NativeEngine, Pulse::HalfSine, &st);
    let e = sp.run(2.0, 2.0).unwrap_err().to_string();
    assert!(
        e.contains("B/H = 1e-6: the native engine is measured down to B/H = 1e-4"),
        "{e}"
    );
}

#[test]
fn spectrum_minima_match_closed_forms_housner() {
    check_engine(&HousnerEngine);
}

#[test]
fn spectrum_minima_match_closed_forms_native() {
    check_engine(&NativeEngine);
}

/// Below the one-sine no-impact boundary the block still overturns after an impact (mode 1)
/// at Pi = 2: the minimum overturning amplitude lies below the no-impact boundary.
#[test]
fn spectrum_one_sine_overturns_after_impact_below_the_no_impact_boundary() {
    let scene = slender();
    let st = Settings::default();
    let sp = Spectrum::new(&scene, &HousnerEngine, Pulse::OneSine, &st);
    let any = sp
        .minimum(2.0, |o| o.overturned)
        .unwrap()
        .amplitude
        .unwrap();
    let clean = sp
        .minimum(2.0, |o| o.without_impact)
        .unwrap()
        .amplitude
        .unwrap();
    assert!(any < 0.9 * clean, "{any} vs {clean}");
    let o = sp.run(2.0, 0.5 * (any + clean)).unwrap();
    assert!(o.overturned && !o.without_impact, "{o:?}");
}

/// A scan started above the one-sine pulse's safe band (overturning after an impact low down,
/// safe above it, overturning without impact higher up) finds the same minimum as one started
/// at A = 1: it steps down through the safe band (it stopped at the band, reporting the
/// no-impact boundary, 2.35 against 1.22 on a 0.2 x 2 m block).
#[test]
fn a_scan_started_above_a_safe_band_finds_the_minimum_below_it() {
    let scene = block_scene(0.2, 2.0, 2.0, &[]).unwrap();
    let from_one = Settings::default();
    let sp = Spectrum::new(&scene, &HousnerEngine, Pulse::OneSine, &from_one);
    let want = sp
        .minimum(2.0, |o| o.overturned)
        .unwrap()
        .amplitude
        .unwrap();
    let clean = sp
        .minimum(2.0, |o| o.without_impact)
        .unwrap()
        .amplitude
        .unwrap();
    let above = Settings {
        scan_from: 3.0,
        ..Settings::default()
    };
    let sp = Spectrum::new(&scene, &HousnerEngine, Pulse::OneSine, &above);
    // The band, just below the no-impact boundary: one of the scan's points down from 3.
    let safe = (1..30)
        .map(|k| 3.0 / 1.05f64.powi(k))
        .filter(|a| *a > 1.1 * want)
        .any(|a| !sp.run(2.0, a).unwrap().overturned);
    assert!(safe, "no safe band between {want} and {clean}");
    let got = sp
        .minimum(2.0, |o| o.overturned)
        .unwrap()
        .amplitude
        .unwrap();
    assert!(
        (got / want - 1.0).abs() <= 2.0 * from_one.tolerance,
        "{got} from {} against {want} from 1",
        above.scan_from
    );
}

/// The early stop does not change a minimum by more than the bisection tolerance.
#[test]
fn spectrum_early_stop_keeps_the_minimum() {
    let scene = slender();
    for engine in [&HousnerEngine as &dyn Engine, &NativeEngine] {
        let on = Settings::default();
        let off = Settings {
            early_stop: false,
            tail: 15.0,
            ..Settings::default()
        };
        let on_ = Settings { tail: 15.0, ..on };
        let a = Spectrum::new(&scene, engine, Pulse::HalfSine, &on_)
            .minimum(2.0, |o| o.overturned)
            .unwrap()
            .amplitude
            .unwrap();
        let b = Spectrum::new(&scene, engine, Pulse::HalfSine, &off)
            .minimum(2.0, |o| o.overturned)
            .unwrap()
            .amplitude
            .unwrap();
        assert!((a / b - 1.0).abs() <= 2.0 * on.tolerance, "{a} vs {b}");
    }
}

/// The similarity law: blocks 0.1 x 2 m (alpha = 0.050) and 0.12 x 6 m (alpha = 0.020), 3x the
/// size, driven by a half-sine at Pi = 3, A = 2.2 (below the minimum 2.29: the block rocks and
/// impacts), with the restitution held at 0.95: phi/alpha against p t agree to 1 % of alpha
/// over p t in [0, 22] (the linearised model is exact as alpha -> 0; here the difference is
/// O(alpha^2)). The native engine (its own impact law, restitution not settable) is checked up
/// to the first impact.
#[test]
fn spectrum_similarity_law() {
    let r = [
        "housner.restitution=0.95".to_string(),
        "native.dt=2e-4".to_string(),
    ];
    let a = block_scene(0.1, 2.0, 2.0, &r).unwrap();
    let b = block_scene(0.12, 6.0, 2.0, &r).unwrap();
    let st = Settings {
        early_stop: false,
        tail: 22.0 - PI / 3.0,
        ..Settings::default()
    };
    let (pt, ya, yb) = similarity(
        &a,
        &b,
        &HousnerEngine,
        (Pulse::HalfSine, 3.0, 2.2),
        &st,
        2201,
    )
    .unwrap();
    let peak = ya.iter().fold(0.0f64, |m, y| m.max(y.abs()));
    let diff = ya
        .iter()
        .zip(&yb)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    let impacts = ya.windows(2).filter(|w| w[0] * w[1] < 0.0).count();
    println!(
        "housner: peak phi/alpha {peak:.4}, max difference {diff:.5}, {impacts} impacts over p t = {:.1}",
        pt[pt.len() - 1]
    );
    assert!(
        peak > 0.3 && impacts >= 3,
        "the blocks rock: peak {peak}, {impacts} impacts"
    );
    assert!(diff < 0.01, "housner: phi/alpha differ by {diff}");
    // Not the same curve when the amplitude differs by 2 %: the test can tell.
    let (_, yc, _) = similarity(
        &a,
        &b,
        &HousnerEngine,
        (Pulse::HalfSine, 3.0, 2.2 * 1.02),
        &st,
        2201,
    )
    .unwrap();
    let d2 = ya
        .iter()
        .zip(&yc)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        d2 > 3.0 * diff,
        "a 2 % change in A moves the curve by {d2}, similarity {diff}"
    );

    let (pt, ya, yb) = similarity(
        &a,
        &b,
        &NativeEngine,
        (Pulse::HalfSine, 3.0, 2.2),
        &st,
        2201,
    )
    .unwrap();
    let first = ya.iter().position(|y| *y < -1e-3).unwrap_or(ya.len());
    let diff = ya[..first]
        .iter()
        .zip(&yb[..first])
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    println!(
        "native: max difference {diff:.5} up to the first impact at p t = {:.2}",
        pt[first.min(pt.len() - 1)]
    );
    assert!(
        first > 100,
        "the native block impacts at p t = {}",
        pt[first]
    );
    assert!(diff < 0.01, "native: phi/alpha differ by {diff}");
}

/// Run the program; a spectrum makes every run (the run store is the subject of its own test).
fn rockbench(args: &[&str]) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_rockbench"));
    cmd.args(args);
    if args.first() == Some(&"spectrum") && !args.contains(&"--cache-dir") {
        cmd.arg("--no-cache");
    }
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Bad input stops before running anything, with one line naming the problem.
#[test]
fn spectrum_bad_input_one_line_errors() {
    let scratch = common::tmp("rb-spectrum", "bad");
    let dir = scratch.join("out");
    let d = dir.to_str().unwrap();
    let scene_file = common::root().join("validation/scenes/housner-slender.toml");
    let scene_file = scene_file.to_str().unwrap();
    for (args, expect) in [
        // Inputs a spectrum used to ignore without a word.
        (
            vec![scene_file, "--friction", "0.5"],
            "/validation/scenes/housner-slender.toml gives its own friction",
        ),
        (
            vec!["0.2x4", "--similarity-at", "3,2"],
            "--similarity-at: only with --similarity",
        ),
        (
            vec!["0.2x4", "--similarity", "0.1x2", "--similarity-at", "3,1e6"],
            "--similarity-at: the amplitude 1000000 g tan(alpha) of 0.1x2",
        ),
        (
            vec!["0.2x4", "--set", "duration=0.2"],
            "--set duration=0.2: a spectrum's runs last their pulse plus --tail",
        ),
        // A block so small that the native step does not resolve its rocking (its minima
        // were 1.9 % off at p dt = 0.086, in silence).
        (
            vec!["0.00006x0.002", "--engines", "housner,native"],
            "native.dt 0.001: p dt = 0.086 (p = 85.7566 1/s) is above 0.02",
        ),
        // A block the native engine refuses: before Housner's whole search, not after it.
        (
            vec!["1e-5x1", "--engines", "housner,native"],
            "engine native cannot model `block 0.00001x1`: blocks[0]: `block` is 0.00001 m wide",
        ),
        (
            vec![
                "0.2x4",
                "--set",
                "native.dt=1e-3",
                "--set",
                "native.dt=5e-4",
            ],
            "--set: `native.dt` is given twice",
        ),
        (
            vec!["0.2x4", "--pulse", "triangle"],
            "unknown pulse `triangle`",
        ),
        (
            vec!["0.2x4", "--ratios", "1,0"],
            "--ratios must be finite and > 0 (got 0)",
        ),
        (
            vec!["0.2x4", "--ratios", "-1"],
            "--ratios must be finite and > 0",
        ),
        (
            vec!["0.2x4", "--ratios", "1e999"],
            "--ratios must be finite and > 0 (got inf)",
        ),
        (
            vec!["0.2x4", "--amplitudes", "1,x"],
            "`x` is not a positive number",
        ),
        (
            vec!["0.2x4", "--engines", "ode45"],
            "unknown engine `ode45`",
        ),
        (vec!["0x4"], "B, H > 0"),
        (vec!["nope.toml"], "neither a scene file nor a block"),
        (
            vec!["0.2x4", "--tolerance", "0"],
            "--tolerance must be a positive number",
        ),
        (vec!["0.2x4", "--set", "native.dt=-1"], "native.dt"),
        (
            vec!["0.2x4", "--ratios", "2,3,2"],
            "--ratios: 2 is given twice",
        ),
        (
            vec!["0.2x4", "--map-ratios", "2,3", "--amplitudes", "none"],
            "--map-ratios: there is no map with --amplitudes none",
        ),
        // Work without end: a range's points (an allocation of 800 TB aborted), a bracket
        // narrower than floating point, a scan to infinity or of 1e300 points.
        (
            vec!["0.2x4", "--amplitudes", "1:10:100000000000000"],
            "--amplitudes: a range of at most 100000 points",
        ),
        (
            vec!["0.2x4", "--tolerance", "1e-300"],
            "--tolerance must be at least 1e-12",
        ),
        (
            vec!["0.2x4", "--scan-to", "inf"],
            "--scan-to must be finite",
        ),
        // A similarity run that cannot be made is refused before the spectrum's runs, not
        // after its outputs are written.
        (
            vec![
                "0.2x4",
                "--engines",
                "housner",
                "--ratios",
                "2",
                "--amplitudes",
                "none",
                "--similarity",
                "0.4x8",
                "--similarity-at",
                "1e-300,2",
            ],
            "--similarity: --tail 30: the longest run, half-sine at omega_p/p = 1e-300",
        ),
        (
            vec!["0.2x4", "--scan-step", "1e-300", "--tolerance", "1e-301"],
            "--scan-step 1e-300:",
        ),
        (
            vec!["0.2x4", "--amplitudes", "1,2,1"],
            "--amplitudes: 1 is given twice",
        ),
        // A block so stocky that the scan's amplitudes are thousands of g (it printed a note,
        // then blamed --tail), and a similarity block without a finite inertia.
        (
            vec![
                "4294967297x1",
                "--engines",
                "housner",
                "--amplitudes",
                "none",
            ],
            "the largest amplitude scanned or mapped, 100 g tan(alpha), is a ground acceleration of 4.2133618093001963e12 m/s^2",
        ),
        (
            vec!["0.2x4", "--amplitudes", "none", "--similarity", "1e300x1"],
            "--similarity 1e300x1: block: blocks[0]: mass 2.5000000000000002e303 kg/m",
        ),
        // Runs cut before a block near the boundary can overturn: a wrong minimum, exit 0.
        (
            vec!["0.2x4", "--tail", "5"],
            "--tail 5: runs within --tolerance 0.0001 of the boundary take some ln(1 / tolerance) = 9.2 / p to overturn after the pulse; the tail must be at least 12.2",
        ),
        // Below it the Housner model's angles underflow: no minimum was found, exit 0.
        (
            vec!["1e-200x1", "--engines", "housner", "--amplitudes", "none"],
            "B/H = 1e-200 is below 1e-100",
        ),
        (
            vec!["0.2x4", "--pulse", "half-sine,rectangular,half-sine"],
            "--pulse: half-sine is given twice",
        ),
        (
            vec!["0.2x4", "--engines", "housner,housner"],
            "--engines: housner is given twice",
        ),
        // A run too long for the steps is --tail's, not an engine setting's at its first run.
        (
            vec!["0.2x4", "--tail", "1e9", "--engines", "housner"],
            "--tail 1000000000: the longest run, half-sine at omega_p/p = 1, lasts",
        ),
        // Sizes beyond what TOML's integers hold are read as the numbers they are.
        (
            vec!["1e300x1e300", "--engines", "housner"],
            "mass inf kg/m and moment of inertia inf",
        ),
    ] {
        let mut all = args.clone();
        all.extend(["--out", d]);
        let (ok, _, err) = rockbench(&[&["spectrum"], &all[..]].concat());
        assert!(!ok, "{args:?} should fail");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(expect), "{args:?}: {err}");
    }
    assert!(!dir.exists(), "nothing is written on bad input");
}

/// The command writes its CSV, SVG and JSON; every map cell records its stop.
#[test]
fn spectrum_command_writes_outputs() {
    let scratch = common::tmp("rb-spectrum", "outputs");
    let dir = scratch.join("out");
    let d = dir.to_str().unwrap();
    let (ok, out, err) = rockbench(&[
        "spectrum",
        "0.2x4",
        "--pulse",
        "half-sine,ricker",
        "--ratios",
        "2,4",
        "--amplitudes",
        "1:5:5",
        "--engines",
        "housner,native",
        "--out",
        d,
    ]);
    assert!(ok, "{out}{err}");
    let min = std::fs::read_to_string(dir.join("minimum.csv")).unwrap();
    assert_eq!(min.lines().count(), 1 + 2 * 2 * 2);
    let map = std::fs::read_to_string(dir.join("map.csv")).unwrap();
    assert_eq!(map.lines().count(), 1 + 2 * 2 * 2 * 5);
    assert!(map.lines().skip(1).all(|l| {
        ["end", "overturned", "at-rest", "below-tipping-energy"]
            .iter()
            .any(|s| l.contains(&format!(",{s},")))
    }));
    for p in ["half-sine", "ricker"] {
        let svg = std::fs::read_to_string(dir.join(format!("spectrum-{p}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("omega_p / p"));
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("spectrum.json")).unwrap()).unwrap();
    assert!(json["command"].as_str().unwrap().contains("spectrum"));
    assert!(
        json["engines"]["native"]["version"]
            .as_str()
            .unwrap()
            .contains("clarabel")
    );
    assert!(json["engines"]["housner"]["version"].is_string());
}

/// Housner's spectrum of a block whose friction lets it slide says so, on the terminal and in
/// `spectrum.json`, and names both thresholds (B/H to start rocking, and the pivot's at impact);
/// a block with friction enough to rock carries no such note.
#[test]
fn spectrum_notes_when_housner_ignores_the_sliding_its_friction_allows() {
    let scratch = common::tmp("rb-spectrum", "housner-sliding");
    for (friction, noted) in [("0", true), ("0.1", true), ("0.17", true), ("0.7", false)] {
        let dir = scratch.join(friction);
        let d = dir.to_str().unwrap();
        let (ok, out, err) = rockbench(&[
            "spectrum",
            "0.2x1",
            "--friction",
            friction,
            "--ratios",
            "2",
            "--amplitudes",
            "none",
            "--engines",
            "housner",
            "--out",
            d,
        ]);
        assert!(ok, "{out}{err}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("spectrum.json")).unwrap())
                .unwrap();
        let notes = &json["engines"]["housner"]["notes"];
        let printed = format!("{out}{err}").contains("the Housner model ignores sliding");
        assert_eq!(printed, noted, "friction {friction}: {out}{err}");
        if noted {
            let note = notes[0].as_str().unwrap();
            assert!(note.contains("ignores sliding"), "{note}");
            // B/H = 0.2: below it the block slides before it rocks.
            assert_eq!(
                note.contains("B/H = 0.200"),
                friction.parse::<f64>().unwrap() < 0.2,
                "{note}"
            );
        } else {
            assert!(notes.is_null(), "friction {friction}: {notes}");
        }
    }
}

/// A spectrum keeps each run in its run store and reads it back: run again, every run comes
/// from the store and the minima and map are the same; with one ratio more (a spectrum that
/// was stopped before it, resumed) only that ratio's runs are made. `--no-cache` makes them all.
#[test]
fn spectrum_runs_are_kept_in_the_store_and_read_back() {
    let scratch = common::tmp("rb-spectrum", "store");
    let store = scratch.join("store");
    let run = |ratios: &str, out: &str, extra: &[&str]| {
        let dir = scratch.join(out);
        let mut args = vec![
            "spectrum",
            "0.2x2",
            "--pulse",
            "half-sine",
            "--ratios",
            ratios,
            "--amplitudes",
            "1:4:4",
            "--engines",
            "housner,native",
            "--cache-dir",
            store.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (ok, stdout, stderr) = rockbench(&args);
        assert!(ok, "{stdout}{stderr}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("spectrum.json")).unwrap())
                .unwrap();
        // Every column but minimum.csv's last, the wall time, which a run read back does not
        // repeat.
        let strip = |name: &str| -> Vec<String> {
            std::fs::read_to_string(dir.join(name))
                .unwrap()
                .lines()
                .map(|l| match name {
                    "minimum.csv" => l.rsplit_once(',').map_or(l, |(head, _)| head).to_string(),
                    _ => l.to_string(),
                })
                .collect()
        };
        let runs: u64 = json["minima"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["minimum"]["runs"].as_u64().unwrap())
            .sum();
        let stored = json["runs_from_store"].as_u64().unwrap();
        (
            strip("minimum.csv"),
            strip("map.csv"),
            runs + 2 * 4,
            stored,
            stderr,
        )
    };
    // A first spectrum reads from the store only the runs it repeats itself (a map cell at an
    // amplitude the search already ran).
    let (min1, map1, total1, stored1, _) = run("2", "first", &[]);
    assert!(stored1 < total1 / 4, "{stored1} of {total1}");
    let (min2, map2, total2, stored2, log2) = run("2", "again", &[]);
    assert_eq!((min2, map2), (min1.clone(), map1.clone()));
    assert_eq!(stored2, total2, "{log2}");
    assert_eq!(total2, total1);
    assert!(log2.contains("from the store"), "{log2}");
    let (min3, map3, total3, stored3, _) = run("2,3", "more", &[]);
    assert!(
        stored3 >= total1,
        "{stored3} < {total1}: ratio 2 is made again"
    );
    assert!(
        stored3 < total3 - total1 / 2,
        "ratio 3 is made: {stored3} of {total3}"
    );
    assert!(min3.starts_with(&min1[..2]) && map3.len() > map1.len());
    let (_, _, _, stored4, _) = run("2", "fresh", &["--no-cache"]);
    assert_eq!(stored4, 0);
    // Entries damaged on disk are not read back: the runs are made again, to the same answer.
    // Sealed again with the damage (an amplitude not the key's, a negative end: the spectrum's
    // own checks refuse them), or left with their seal (the store refuses them).
    let mut damaged = 0;
    let mut dirs = vec![store.clone()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
                continue;
            }
            let Ok(mut v) = serde_json::from_str::<serde_json::Value>(
                &std::fs::read_to_string(&p).unwrap_or_default(),
            ) else {
                continue;
            };
            let Some(o) = v["entry"].get_mut("outcome") else {
                continue;
            };
            if damaged % 2 == 0 {
                o["amplitude"] = serde_json::json!(-7.0);
            } else {
                o["p_t_end"] = serde_json::json!(-1.0);
            }
            let entry = serde_json::to_string(&v["entry"]).unwrap();
            let mut sealed = rockbench::run_store::seal(&entry);
            if damaged % 4 >= 2 {
                let new = rockbench::digest::sha256_hex(entry.as_bytes());
                sealed = sealed.replacen(&new, v["sha256"].as_str().unwrap(), 1);
            }
            damaged += 1;
            std::fs::write(&p, sealed).unwrap();
        }
    }
    assert!(damaged as u64 >= total1, "{damaged} entries");
    let (min5, map5, _, stored5, _) = run("2", "damaged", &[]);
    assert_eq!((min5, map5), (min1, map1));
    // Only the runs it repeats itself, as the first spectrum.
    assert_eq!(stored5, stored1);
}

/// The first row of minimum.csv of the 1 x 2.5 m block released at 0.3 rad, half-sine at
/// ratio 2, on `engine`, its fields split.
fn tilted_minimum(scratch: &std::path::Path, engine: &str, extra: &[&str]) -> Vec<String> {
    let dir = scratch.join(format!("{engine}{}", extra.len()));
    let mut args = vec![
        "spectrum",
        "1x2.5",
        "--friction",
        "0.7",
        "--engines",
        engine,
        "--ratios",
        "2",
        "--amplitudes",
        "none",
        "--out",
        dir.to_str().unwrap(),
        "--set",
        "initial.tilt=0.3",
    ];
    args.extend(extra);
    let (ok, out, err) = rockbench(&args);
    assert!(ok, "{out}{err}");
    let csv = std::fs::read_to_string(dir.join("minimum.csv")).unwrap();
    csv.lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(String::from)
        .collect()
}

/// A scene starting tilted: the Housner engine's early-stopped runs start from the tilt, as
/// its runs to the end do (they started upright, so the minimum was the upright block's), and
/// no closed form (a block starting at rest) is set beside the minima.
#[test]
fn a_tilted_start_is_kept_by_the_early_stopped_housner_runs() {
    let scratch = common::tmp("rb-spectrum", "tilted");
    let minimum = |extra: &[&str]| {
        let row = tilted_minimum(&scratch, "housner", extra);
        (row[4].parse::<f64>().unwrap(), row[10].clone())
    };
    let (early, closed) = minimum(&[]);
    let (whole, _) = minimum(&["--no-early-stop"]);
    assert!(
        (early - whole).abs() <= 1e-3 * whole,
        "{early} against {whole}"
    );
    // Upright, the same block needs 1.80 times g tan(alpha) (the closed form).
    assert!(early < 1.0, "{early}");
    assert_eq!(closed, "", "a closed form beside a tilted start");
}

/// The native engine on the same tilted start: its early stops measure the energy from the
/// upright block's rest, so they keep the minimum of its runs to the end, which is Housner's
/// (the block overturns before its first impact, where the two models are one). Measured from
/// the tilted start, they called runs safe that overturn: 0.5498 against 0.4176.
#[test]
fn a_tilted_start_gives_native_the_minimum_of_its_runs_to_the_end_and_housners() {
    let scratch = common::tmp("rb-spectrum", "tilted-native");
    let minimum = |engine: &str, extra: &[&str]| {
        tilted_minimum(&scratch, engine, extra)[4]
            .parse::<f64>()
            .unwrap()
    };
    let early = minimum("native", &[]);
    let whole = minimum("native", &["--no-early-stop"]);
    let housner = minimum("housner", &[]);
    assert!(
        (early - whole).abs() <= 1e-3 * whole,
        "early-stopped {early} against {whole}"
    );
    assert!(
        (early - housner).abs() <= 2e-3 * housner,
        "native {early} against Housner {housner}"
    );
}

/// A 1 x 1 m block under a one-cosine pulse at ratio 3 and A = 4 is thrown into the air past
/// its critical angle turning outwards, lands on its corner at -0.998 rad and rights itself:
/// the early-stopped native run is not counted as overturned there (it was), and its verdict
/// is the run to the end's.
#[test]
fn a_block_thrown_past_its_critical_angle_that_lands_back_is_not_overturned_early() {
    let scratch = common::tmp("rb-spectrum", "thrown");
    let cell = |extra: &[&str]| {
        let dir = scratch.join(format!("out{}", extra.len()));
        let mut args = vec![
            "spectrum",
            "1x1",
            "--friction",
            "2",
            "--engines",
            "native",
            "--pulse",
            "one-cosine",
            "--ratios",
            "3",
            "--map-ratios",
            "3",
            "--amplitudes",
            "4",
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend(extra);
        let (ok, out, err) = rockbench(&args);
        assert!(ok, "{out}{err}");
        let csv = std::fs::read_to_string(dir.join("map.csv")).unwrap();
        let head: Vec<String> = csv
            .lines()
            .next()
            .unwrap()
            .split(',')
            .map(String::from)
            .collect();
        let row: Vec<String> = csv
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .map(String::from)
            .collect();
        let col = |name: &str| row[head.iter().position(|h| h == name).unwrap()].clone();
        (col("overturned"), col("stop"))
    };
    let (early, stop) = cell(&[]);
    let (whole, _) = cell(&["--no-early-stop"]);
    assert_eq!(whole, "false", "the run to the end rights itself");
    assert_eq!(early, whole, "stopped as {stop}");
}

/// The closed forms are a single block's: a stack's minimum gets none beside it (it was set
/// beside the statue-on-pedestal's minimum as a -57 % error).
#[test]
fn a_stack_has_no_closed_form_beside_its_minimum() {
    let dir = common::tmp("rb-spectrum", "stack").join("out");
    let root = common::root();
    let scene = root.join("validation/scenes/two-block-free-rocking.toml");
    let (ok, out, err) = rockbench(&[
        "spectrum",
        scene.to_str().unwrap(),
        "--set",
        "initial.tilt=0",
        "--engines",
        "native",
        "--ratios",
        "2",
        "--amplitudes",
        "none",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(ok, "{out}{err}");
    let csv = std::fs::read_to_string(dir.join("minimum.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert!(row[4].parse::<f64>().unwrap() > 0.0, "{csv}");
    assert_eq!((row[10], row[12]), ("", ""), "{csv}");
}

/// A host name with a path separator (the run store names its temporary files by it) is no
/// panic: the store keeps the characters a file name can hold.
#[test]
fn a_host_name_with_a_slash_does_not_stop_the_run_store() {
    let scratch = common::tmp("rb-spectrum", "host");
    let out = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .env("HOSTNAME", "a/b")
        .args(["spectrum", "0.4x4", "--engines", "housner", "--ratios", "2"])
        .args(["--amplitudes", "none", "--cache-dir"])
        .arg(scratch.join("store"))
        .arg("--out")
        .arg(scratch.join("out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::read_dir(scratch.join("store")).unwrap().count() > 0);
}

/// A spectrum written where an earlier one was: the figures of pulses it does not run are
/// removed, so the folder holds one spectrum.
#[test]
fn a_spectrum_written_again_removes_the_figures_it_does_not_make() {
    let scratch = common::tmp("rb-spectrum", "again");
    let out = scratch.join("out");
    let spectrum = |pulses: &str| {
        let (ok, so, se) = rockbench(&[
            "spectrum",
            "0.4x4",
            "--engines",
            "housner",
            "--pulse",
            pulses,
            "--ratios",
            "2",
            "--amplitudes",
            "none",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{so}{se}");
    };
    spectrum("half-sine,ricker");
    assert!(out.join("spectrum-ricker.svg").is_file());
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    spectrum("one-sine");
    assert!(out.join("spectrum-one-sine.svg").is_file());
    assert!(
        !out.join("spectrum-ricker.svg").exists() && !out.join("spectrum-half-sine.svg").exists()
    );
    assert!(
        out.join("notes.txt").is_file(),
        "a file the spectrum does not write was removed"
    );
}
