//! Early stops of the soft-contact engines (rapier in process, MuJoCo and PyBullet in their
//! Python worker, `make .venv`): on a stack of two blocks (the paper's statue at 1/5 scale)
//! under short sine bursts that cover the three cases — below the static threshold (at rest
//! from the start), rocking that dies out after the burst (at rest later), overturning — a run
//! with early stops gives the outcome of the full-length run, and after an at-rest stop the
//! full-length run never moves again (the rest test hides no motion).

mod common;
use common::tmp;
use rockbench::fragility::early::{SOFT_REST_SPEED, SOFT_UPRIGHT};
use rockbench::fragility::run::{RunOutcome, Stop, outcome, simulate};
use rockbench::scene::{Scene, parse_scene_str};
use std::path::Path;

/// The static threshold of the stack (that of the paper's statue: scale-free), fraction of g.
fn threshold() -> f64 {
    let (mp, ms) = (1.25 * 1.25, 2.5);
    0.625 / ((mp * 0.625 + ms * 2.5) / (mp + ms))
}

/// A sine burst of `cycles` periods `period` and peak `peak` (fraction of g), then zeros
/// until `end` s, as a CSV record (s, m/s^2).
fn burst(dir: &Path, name: &str, peak: f64, period: f64, cycles: f64, end: f64) -> String {
    let f = dir.join(format!("{name}.csv"));
    let mut csv = String::from("t,a\n");
    let n = (end / 0.005).round() as usize;
    for k in 0..=n {
        let t = k as f64 * 0.005;
        let a = if t <= cycles * period {
            peak * 9.81 * (2.0 * std::f64::consts::PI * t / period).sin()
        } else {
            0.0
        };
        csv += &format!("{t},{a}\n");
    }
    std::fs::write(&f, csv).unwrap();
    f.display().to_string()
}

/// The paper's statue at 1/5 scale on its pedestal under `record`, `duration` s.
fn stack(record: &str, duration: f64) -> Scene {
    let text = format!(
        "name = \"stack\"\nduration = {duration}\n[[blocks]]\nname = \"pedestal\"\nwidth = 0.25\nheight = 0.25\ndensity = 2500\n[[blocks]]\nname = \"statue\"\nwidth = 0.2\nheight = 0.5\ndensity = 2500\n[contact]\nfriction = 0.7\n[excitation.horizontal]\nkind = \"record\"\nfile = \"{record}\"\nscale = 1.0\n"
    );
    parse_scene_str(&text, false, "stack", &[]).unwrap()
}

/// The three cases: (name, scene, the stop the early run must make).
fn cases(dir: &Path) -> Vec<(&'static str, Scene, Stop)> {
    let thr = threshold();
    vec![
        (
            "below-threshold",
            stack(&burst(dir, "below", 0.8 * thr, 0.3, 2.0, 1.0), 1.5),
            Stop::AtRest,
        ),
        (
            "rocking",
            stack(&burst(dir, "rocking", 1.6 * thr, 0.3, 1.0, 0.6), 3.0),
            Stop::AtRest,
        ),
        (
            "overturn",
            stack(&burst(dir, "overturn", 2.5, 0.6, 2.0, 1.2), 2.5),
            Stop::Overturned,
        ),
    ]
}

fn check_engine(engine: &str) {
    let dir = tmp("rb-fragility-engines", engine);
    for (name, scene, want) in cases(&dir) {
        let full = simulate(engine, &scene, false).unwrap();
        let early = simulate(engine, &scene, true).unwrap();
        let (of, oe): (RunOutcome, RunOutcome) = (outcome(&scene, &full), outcome(&scene, &early));
        eprintln!(
            "{engine} {name}: {} at {:.3} s of {} s; rotation {:?} (full {:?})",
            oe.stop.name(),
            oe.t_end,
            scene.duration,
            oe.rotation,
            of.rotation
        );
        assert_eq!(of.stop, Stop::End, "{engine} {name}");
        assert_eq!(oe.stop, want, "{engine} {name}: {oe:?}");
        assert!(
            oe.t_end < 0.9 * scene.duration,
            "{engine} {name}: stopped at {}",
            oe.t_end
        );
        // An overturn exceeds every limit state: which other blocks fall after the stop is
        // not an outcome.
        assert_eq!(oe.any_overturned(), of.any_overturned(), "{engine} {name}");
        if want == Stop::Overturned {
            assert!(oe.any_overturned(), "{engine} {name}");
            continue;
        }
        assert_eq!(oe.overturned, of.overturned, "{engine} {name}");
        assert!(!of.any_overturned(), "{engine} {name}");
        if name == "rocking" {
            assert!(
                of.rotation[1] > 0.1,
                "{engine}: the statue does not rock: {:?}",
                of.rotation
            );
        }
        // Rotations (over alpha) and sliding as in the full run: the largest rotation comes
        // before the stop, and the full run stays at rest after it.
        for i in 0..2 {
            assert!(
                (oe.rotation[i] - of.rotation[i]).abs() <= 1e-3,
                "{engine} {name} block {i}: {oe:?} vs {of:?}"
            );
            let (se, sf) = (oe.sliding[i].unwrap(), of.sliding[i].unwrap());
            assert!(
                (se - sf).abs() <= 1e-4,
                "{engine} {name} sliding {i}: {se} vs {sf}"
            );
        }
        let tr = &full.trajectory;
        for k in 0..tr.t.len() {
            if tr.t[k] <= oe.t_end {
                continue;
            }
            for (i, b) in tr.blocks.iter().enumerate() {
                let size = scene.blocks[i].width.max(scene.blocks[i].height);
                let rel = if i == 0 {
                    b.phi[k]
                } else {
                    b.phi[k] - tr.blocks[0].phi[k]
                };
                let speed = b.vx[k]
                    .abs()
                    .max(b.vz[k].abs())
                    .max((b.omega[k] * size).abs());
                assert!(
                    speed < SOFT_REST_SPEED && rel.abs() < SOFT_UPRIGHT,
                    "{engine} {name}: block {i} moves at t = {} after the stop at {}: speed {speed:e} m/s, rotation {rel:e} rad",
                    tr.t[k],
                    oe.t_end
                );
            }
        }
    }
}

#[cfg(feature = "rapier")]
#[test]
fn rapier_early_stops_change_no_outcome() {
    check_engine("rapier");
}

#[test]
fn mujoco_early_stops_change_no_outcome() {
    check_engine("mujoco");
}

#[test]
fn pybullet_early_stops_change_no_outcome() {
    check_engine("pybullet");
}
