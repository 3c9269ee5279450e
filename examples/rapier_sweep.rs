//! The measurement behind the rapier engine's defaults: each `[rapier]` setting varied on its
//! own around the tuned defaults (and rapier's own defaults), on the Housner blocks and the
//! paper's two-block case. Prints a Markdown table (`make rapier-sweep`).
//!
//! Columns: first-impact time difference against Housner (ms), relative error of the first
//! amplitude after it (%), RMS rotation error over 3 s (rad, on Housner's 1 ms output grid);
//! for the two-block case the difference of the stack's ground impact and of the statue's
//! first and second crossings after it against the native engine (ms).

use rockbench::engines::rapier_settings::RapierSettings;
use rockbench::engines::{engine_by_name, run_timed};
use rockbench::scene::{Scene, load_scene};
use rockbench::summary::Summary;
use rockbench::trajectory::Trajectory;
use std::path::Path;

fn interp(t: &[f64], y: &[f64], x: f64) -> f64 {
    let k = t.partition_point(|&s| s <= x).clamp(1, t.len() - 1);
    y[k - 1] + (y[k] - y[k - 1]) * (x - t[k - 1]) / (t[k] - t[k - 1])
}

fn rms(a: &Trajectory, b: &Trajectory, t_end: f64) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (t, ya) in a.t.iter().zip(&a.blocks[0].phi) {
        if *t > t_end + 1e-12 {
            break;
        }
        let d = interp(&b.t, &b.blocks[0].phi, *t) - ya;
        s += d * d;
        n += 1;
    }
    (s / n as f64).sqrt()
}

fn run(engine: &str, scene: &Scene) -> Result<(Trajectory, Summary), String> {
    let e = engine_by_name(engine).map_err(|e| e.to_string())?;
    let (o, s) = run_timed(e.as_ref(), scene).map_err(|e| e.to_string())?;
    Ok((o.trajectory, s))
}

fn single(scene: &Scene, reference: &(Trajectory, Summary)) -> String {
    match run("rapier", scene) {
        Err(e) => format!("failed: {e} | | "),
        Ok((tr, s)) => {
            let (ht, hs) = reference;
            let (hb, rb) = (&hs.blocks[0], &s.blocks[0]);
            let imp = rb
                .impacts
                .first()
                .map(|t| format!("{:+.2}", 1e3 * (t - hb.impacts[0])))
                .unwrap_or_else(|| "none".into());
            let amp = rb
                .peaks
                .get(1)
                .map(|p| {
                    format!(
                        "{:+.2}",
                        100.0 * (p.amplitude / hb.peaks[1].amplitude - 1.0)
                    )
                })
                .unwrap_or_else(|| "-".into());
            format!("{imp} | {amp} | {:.2e}", rms(ht, &tr, 3.0))
        }
    }
}

fn two_block(scene: &Scene, native: &Summary) -> String {
    let events = |s: &Summary| -> Vec<f64> {
        let g = s.blocks[0].impacts.first().copied().unwrap_or(f64::NAN);
        let mut v = vec![g];
        v.extend(s.blocks[1].impacts.iter().filter(|&&t| t > g).take(2));
        v
    };
    match run("rapier", scene) {
        Err(e) => format!("failed: {e}"),
        Ok((_, s)) => {
            let (a, b) = (events(native), events(&s));
            (0..3)
                .map(|k| match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => format!("{:+.1}", 1e3 * (y - x)),
                    _ => "-".into(),
                })
                .collect::<Vec<_>>()
                .join(" / ")
        }
    }
}

fn main() {
    if let Err(e) = sweep() {
        // One line: the error and its causes.
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn sweep() -> Result<(), String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes");
    let load = |n: &str| load_scene(&dir.join(n)).map_err(|e| e.to_string());
    let slender = load("housner-slender.toml")?;
    let square = load("housner-square.toml")?;
    let mut two = load("two-block-free-rocking.toml")?;
    two.duration = 2.5;
    let h_slender = run("housner", &slender)?;
    let h_square = run("housner", &square)?;
    let native = run("native", &two)?.1;

    type Edit = fn(&mut RapierSettings);
    let variants: Vec<(&str, Edit)> = vec![
        ("tuned defaults", |_| {}),
        ("rapier's own defaults", |s| {
            *s = RapierSettings::rapier_defaults()
        }),
        ("stabilization_iterations = 1", |s| {
            s.stabilization_iterations = 1
        }),
        ("stabilization_iterations = 2", |s| {
            s.stabilization_iterations = 2
        }),
        ("stabilization_iterations = 8", |s| {
            s.stabilization_iterations = 8
        }),
        ("solver_iterations = 4", |s| s.solver_iterations = 4),
        ("solver_iterations = 12", |s| s.solver_iterations = 12),
        ("solver_iterations = 16", |s| s.solver_iterations = 16),
        ("solver_iterations = 32", |s| s.solver_iterations = 32),
        ("dt = 2e-3", |s| s.dt = 2e-3),
        ("dt = 5e-4", |s| s.dt = 5e-4),
        ("dt = 2e-4", |s| s.dt = 2e-4),
        ("contact_recycling = true", |s| s.contact_recycling = true),
        ("contact frequencies 60 Hz", |s| {
            s.contact_frequency = 60.0;
            s.static_contact_frequency = 60.0
        }),
        ("contact frequencies 120 Hz", |s| {
            s.contact_frequency = 120.0;
            s.static_contact_frequency = 120.0
        }),
        ("contact frequencies 480 Hz", |s| {
            s.contact_frequency = 480.0;
            s.static_contact_frequency = 480.0
        }),
        ("contact damping ratios 1", |s| {
            s.contact_damping_ratio = 1.0;
            s.static_contact_damping_ratio = 1.0
        }),
        ("prediction_distance = 0.02", |s| {
            s.prediction_distance = 0.02
        }),
        ("prediction_distance = 5e-4", |s| {
            s.prediction_distance = 5e-4
        }),
        ("pgs_iterations = 2", |s| s.pgs_iterations = 2),
        ("allowed_linear_error = 5e-4", |s| {
            s.allowed_linear_error = 5e-4
        }),
        ("allowed_linear_error = 0", |s| s.allowed_linear_error = 0.0),
        ("max_corrective_velocity = 0.3", |s| {
            s.max_corrective_velocity = 0.3
        }),
        ("max_corrective_velocity = 30", |s| {
            s.max_corrective_velocity = 30.0
        }),
        ("warmstart_coefficient = 0", |s| {
            s.warmstart_coefficient = 0.0
        }),
        ("friction_in_bias_pass = true", |s| {
            s.friction_in_bias_pass = true
        }),
        ("restitution = 0.25", |s| s.restitution = 0.25),
        ("min_friction = 1", |s| s.min_friction = 1.0),
    ];
    println!(
        "| settings | slender: impact ms | slender: amp % | slender: RMS rad | square: impact ms | square: amp % | square: RMS rad | two-block: ground / 1st / 2nd crossing ms |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (label, edit) in variants {
        let with = |scene: &Scene| {
            let mut s = scene.clone();
            let mut r = RapierSettings::of(&s).expect("the validation scenes' [rapier] is valid");
            edit(&mut r);
            s.set_table("rapier", &r);
            s
        };
        println!(
            "| {label} | {} | {} | {} |",
            single(&with(&slender), &h_slender),
            single(&with(&square), &h_square),
            two_block(&with(&two), &native)
        );
    }
    Ok(())
}
