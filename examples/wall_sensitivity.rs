//! The sliding wall as ensembles (`make bench-walls-sensitivity`; `rockbench sensitivity` for any
//! scene): a running-bond wall (`rockbench::walls`, `--courses` of 21 blocks of 0.6 x 0.25 m,
//! friction 0.7) slid by a rectangular pulse of `--pulse` g for `--pulse-duration` s and run to
//! `--duration` s, each configuration `--members` times with the pulse's amplitude times
//! `1 + k epsilon` (`rockbench::sensitivity`). The wall is written to `OUT/scene.toml` once it
//! and every configuration's overrides check; the study's runs to `OUT/runs.csv` (an
//! interrupted study resumes) and its tables to `OUT/sensitivity.md` (docs/walls.md, "A sliding
//! wall's answer is decided at round-off").

#[path = "common/flags.rs"]
mod flags;

use anyhow::{Context, bail};
use flags::{arg, check_flags};
use rockbench::sensitivity::{Study, parse_configs};
use rockbench::walls::WallSpec;
use std::path::Path;

const USAGE: &str = "cargo run --release --example wall_sensitivity -- \
[--courses 10] [--pulse 0.8] [--pulse-duration 0.2] [--duration 0.5] [--members 4] [--epsilon 1e-12] \
[--configs ENGINE[:KEY=VALUE[;KEY=VALUE]],...] [--out out/bench-walls-sensitivity]";

const FLAGS: [&str; 8] = [
    "--courses",
    "--pulse",
    "--pulse-duration",
    "--duration",
    "--members",
    "--epsilon",
    "--configs",
    "--out",
];

/// Impacts at the end of their step at four step sizes, located impacts (the default) at two,
/// rapier at its defaults and at a finer step with more sub-steps.
const DEFAULT_CONFIGS: &str = "native:native.locate_impacts=false,\
native:native.locate_impacts=false;native.dt=5e-4,\
native:native.locate_impacts=false;native.dt=2.5e-4,\
native:native.locate_impacts=false;native.dt=1.25e-4,\
native,\
native:native.dt=5e-4,\
rapier,\
rapier:rapier.dt=2.5e-4;rapier.solver_iterations=32";

/// Standard gravity, as the walls benchmark scales its pulses (`bench_dynamic --pulse`).
const G: f64 = 9.81;

/// A number of `name`, checked by `ok` (whose failure is described by `what`).
fn number(
    args: &[String],
    name: &str,
    default: &str,
    what: &str,
    ok: fn(f64) -> bool,
) -> anyhow::Result<f64> {
    let text = arg(args, name, default);
    let v: f64 = text
        .parse()
        .with_context(|| format!("{name}: not a number: {text:?}"))?;
    if !(v.is_finite() && ok(v)) {
        bail!("{name}: must be {what} (got {text})");
    }
    Ok(v)
}

fn main() {
    rockbench::allocator::keep_freed_memory();
    if let Err(e) = study() {
        // One line: the error and its causes.
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn study() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("{USAGE}");
        return Ok(());
    }
    check_flags(&args, &FLAGS, USAGE)?;
    let positive = |v: f64| v > 0.0;
    let whole = |v: f64| v >= 1.0 && v.fract() == 0.0;
    let courses = number(&args, "--courses", "10", "a whole number, 1 or more", whole)? as usize;
    let pulse = number(&args, "--pulse", "0.8", "a positive number of g", positive)?;
    let pulse_duration = number(&args, "--pulse-duration", "0.2", "positive, s", positive)?;
    let duration = number(&args, "--duration", "0.5", "positive, s", positive)?;
    // Their ranges are the study's to check (`Study::check`).
    let members = number(&args, "--members", "4", "a whole number", |v| {
        v >= 0.0 && v.fract() == 0.0
    })? as usize;
    let epsilon = number(&args, "--epsilon", "1e-12", "a number", |_| true)?;
    let out = Path::new(arg(&args, "--out", "out/bench-walls-sensitivity"));

    let wall = WallSpec {
        duration,
        ..WallSpec::running_bond(courses, 21)
    };
    let scene_text = format!(
        "{}\n[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {:?}\n\
         duration = {pulse_duration:?}\nstart = 0\n",
        wall.to_toml(),
        pulse * G
    );
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let pending = out.join("scene.toml.new");
    std::fs::write(&pending, &scene_text)
        .with_context(|| format!("cannot write {}", pending.display()))?;
    let mut study = Study {
        scene: pending.clone(),
        about: format!(
            "a running-bond wall of {} blocks ({courses} courses of 21, 0.6 x 0.25 m, friction \
             0.7) under a rectangular pulse of {pulse} g for {pulse_duration} s, {duration} s",
            wall.n_blocks()
        ),
        perturb: ("excitation.horizontal.amplitude".to_string(), pulse * G),
        epsilon,
        members,
        configs: parse_configs(arg(&args, "--configs", DEFAULT_CONFIGS))?,
        sets: Vec::new(),
    };
    // Checked under its pending name (the study's parameters hash the scene's text, not its
    // path), then named: a refused study leaves the last one's scene.
    let checked = study.check(out);
    if checked.is_err() {
        let _ = std::fs::remove_file(&pending);
    }
    checked?;
    study.scene = out.join("scene.toml");
    std::fs::rename(&pending, &study.scene)
        .with_context(|| format!("cannot write {}", study.scene.display()))?;
    study.run(out, &|line| eprintln!("{line}"))?;
    eprintln!("wrote {}", out.join("sensitivity.md").display());
    Ok(())
}
