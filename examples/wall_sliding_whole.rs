//! Walls that slide whole, cost against accuracy (`make bench-walls-sliding-whole`): running-bond
//! walls (`rockbench::walls`, `--courses` of 21 blocks of 0.6 x 0.25 m, bed joints at friction
//! 0.7) on a ground at friction 0.5, under a rectangular pulse of 0.8 g for 0.2 s, run to rest
//! (0.5 s). Where the 0.5 g the sliding base transmits is inside the wall's rest interval, every
//! block ends where the sliding block's closed form puts it (`rockbench::sliding`); each
//! configuration's cost a step, the largest error of a block's final displacement against it
//! and the range of the bottom course's errors (where the wall rocks as it slides, how far
//! its base falls short) are written to `OUT/results.csv` and as a table on stdout, and each
//! wall's work-precision figure (largest error against the wall time for the 0.5 s, one curve
//! per configuration through its step sizes) to `OUT/work_precision_BLOCKS.svg`
//! (docs/walls.md, "A wall that slides whole, against its closed form"). The table, also in
//! `OUT/results.md`, ends with what made its timings (the program's commit and sources, each
//! engine's version, the machine, the date), which `OUT/provenance.json` holds with the command.
//!
//! A sliding wall's path is decided at round-off, and so is its cost: `--paths K` runs every
//! configuration on K paths, the pulse's amplitude times `1 + k 1e-12` (k = 0 .. K-1), as the
//! walls' sensitivity study does. The CSV has a row a run; the table, the slopes and the
//! figures take the median cost a step over the paths (the table gives its range too) and
//! the largest error over them.

#[path = "common/flags.rs"]
mod flags;

use anyhow::{Context, bail};
use flags::{arg, check_flags};
use rockbench::bench::{ConfigPoint, configs_plot, median};
use rockbench::engines::{engine_by_name, run_timed};
use rockbench::loglog;
use rockbench::report::provenance::Provenance;
use rockbench::scene::parse_scene_str;
use rockbench::sensitivity::parse_configs;
use rockbench::sliding::Slide;
use rockbench::summary::Summary;
use rockbench::trajectory::Trajectory;
use rockbench::walls::{SLIDING_GROUND_FRICTION, SLIDING_PULSE, WallSpec};
use std::fmt::Write as _;
use std::path::Path;

const USAGE: &str = "cargo run --release --example wall_sliding_whole -- \
[--courses 3,10,20] [--per-course 21] [--configs ENGINE[:KEY=VALUE[;KEY=VALUE]],...] [--paths 1] \
[--out out/bench-walls-sliding-whole]";

const FLAGS: [&str; 5] = ["--courses", "--per-course", "--configs", "--paths", "--out"];

/// The relative step between two paths' pulse amplitudes: a perturbation at round-off level
/// (the walls' sensitivity study's `--epsilon`).
const PATH_EPSILON: f64 = 1e-12;

/// The native engine's default (impacts located) and at two finer steps, its impacts at step
/// ends, its Coulomb law; rapier at its defaults and three finer steps, and with more
/// iterations at two steps (each method's step sizes make one curve of the work-precision
/// figures).
const DEFAULT_CONFIGS: &str = "native,\
native:native.dt=5e-4,\
native:native.dt=2.5e-4,\
native:native.locate_impacts=false,\
native:native.friction_law=\"coulomb\",\
rapier,\
rapier:rapier.dt=5e-4,\
rapier:rapier.dt=2.5e-4,\
rapier:rapier.dt=1e-4,\
rapier:rapier.solver_iterations=16,\
rapier:rapier.solver_iterations=16;rapier.dt=2.5e-4";

fn main() {
    rockbench::allocator::keep_freed_memory();
    if let Err(e) = benchmark() {
        // One line: the error and its causes.
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn benchmark() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("{USAGE}");
        return Ok(());
    }
    check_flags(&args, &FLAGS, USAGE)?;
    let courses: Vec<usize> = arg(&args, "--courses", "3,10,20")
        .split(',')
        .map(|c| match c.trim().parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => bail!("--courses: {c:?} is not a whole number of courses, 1 or more"),
        })
        .collect::<anyhow::Result<_>>()?;
    let per_course = match arg(&args, "--per-course", "21").trim().parse::<usize>() {
        Ok(n) if n >= 2 => n,
        _ => bail!("--per-course: not a whole number of blocks, 2 or more"),
    };
    let configs = parse_configs(arg(&args, "--configs", DEFAULT_CONFIGS))?;
    let paths = match arg(&args, "--paths", "1").trim().parse::<usize>() {
        Ok(k) if k >= 1 => k,
        _ => bail!("--paths: not a whole number of round-off paths, 1 or more"),
    };
    let (amplitude, t1) = SLIDING_PULSE;
    let path_amplitude = |k: usize| amplitude * (1.0 + k as f64 * PATH_EPSILON);
    let out = Path::new(arg(&args, "--out", "out/bench-walls-sliding-whole"));
    // Every scene and override checked before anything runs: per wall and configuration, one
    // scene a path.
    let mut runs = Vec::new();
    for &c in &courses {
        let w = WallSpec::sliding_whole(c, per_course);
        let (text, blocks) = (w.to_toml(), w.n_blocks());
        for config in &configs {
            let scenes = (0..paths)
                .map(|k| {
                    let mut sets = config.sets.clone();
                    if k > 0 {
                        sets.push(format!(
                            "excitation.horizontal.amplitude={:?}",
                            path_amplitude(k)
                        ));
                    }
                    parse_scene_str(&text, false, "wall", &sets)
                        .with_context(|| format!("{} on {c} courses, path {k}", config.label))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            runs.push((c, blocks, config, scenes));
        }
    }
    let g = runs.first().map_or(9.81, |r| r.3[0].gravity);
    let slide =
        |k: usize| Slide::under_pulse(path_amplitude(k), t1, SLIDING_GROUND_FRICTION, g).distance();
    let mut csv = String::from(
        "courses,per_course,blocks,config,path,pulse_amplitude,wall_time_s,steps,ms_per_step,max_abs_error_m,rms_error_m,bottom_course_min_error_m,bottom_course_max_error_m\n",
    );
    let over_paths = if paths > 1 {
        format!(
            " Each configuration on {paths} round-off paths (the pulse's amplitude times 1 + k {PATH_EPSILON:e}): \
             the median cost a step, its range, and the largest errors over the paths."
        )
    } else {
        String::new()
    };
    let mut table = format!(
        "Closed form: every block {:.6} m back relative to the ground.{over_paths}\n\n\
         | blocks | configuration | s for the 0.5 s | ms a step | ms a step, range over the paths | largest error, m | rms error, m | bottom course's errors, m |\n|---|---|---|---|---|---|---|---|\n",
        -slide(0)
    );
    // Per configuration, (blocks, ms a step) of the runs that finished; per wall, the runs'
    // (configuration, wall time, largest error) for its work-precision figure.
    let mut costs: Vec<Vec<(f64, f64)>> = vec![Vec::new(); configs.len()];
    let provenance = Provenance::collect(&std::env::args().collect::<Vec<_>>().join(" "));
    // (engine, version) of every finished run.
    let mut versions: Vec<(String, String)> = Vec::new();
    let mut accuracy: Vec<(usize, ConfigPoint)> = Vec::new();
    for (i, (c, blocks, config, scenes)) in runs.iter().enumerate() {
        let mut done: Vec<PathRun> = Vec::new();
        let mut failure = None;
        let engine = engine_by_name(&config.engine)?;
        let label = config.label.replace('"', "\"\"");
        for (k, scene) in scenes.iter().enumerate() {
            eprintln!("{} blocks, {}, path {k} ...", blocks, config.label);
            match run_timed(engine.as_ref(), scene) {
                Ok((output, summary)) => {
                    versions.push((config.engine.clone(), output.engine_version.clone()));
                    let r = PathRun::of(&output.trajectory, &summary, slide(k));
                    let _ = writeln!(
                        csv,
                        "{c},{per_course},{blocks},\"{label}\",{k},{:?},{},{},{},{:e},{:e},{:e},{:e}",
                        path_amplitude(k),
                        r.wall_time_s,
                        summary.steps,
                        r.ms_per_step,
                        r.max_error,
                        r.rms_error,
                        r.bottom.0,
                        r.bottom.1
                    );
                    done.push(r);
                }
                // A run that fails is reported as such (e.g. Coulomb friction beyond its solvers).
                Err(e) => {
                    let _ = writeln!(
                        csv,
                        "{c},{per_course},{blocks},\"{label}\",{k},{:?},,,,,,,",
                        path_amplitude(k)
                    );
                    failure.get_or_insert(format!("path {k}: {e}"));
                }
            }
        }
        let row = match failure {
            Some(e) => format!(
                "failed: {e} ({} of {paths} paths failed) | - | - | - | - | -",
                paths - done.len()
            ),
            None => {
                let wall = median(done.iter().map(|r| r.wall_time_s).collect());
                let ms = median(done.iter().map(|r| r.ms_per_step).collect());
                let (lo, hi) = done.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                    (lo.min(r.ms_per_step), hi.max(r.ms_per_step))
                });
                let max = done.iter().fold(0.0f64, |m, r| m.max(r.max_error));
                let rms = done.iter().fold(0.0f64, |m, r| m.max(r.rms_error));
                let (bottom_min, bottom_max) = done
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
                        (a.min(r.bottom.0), b.max(r.bottom.1))
                    });
                costs[i % configs.len()].push((*blocks as f64, ms));
                accuracy.push((
                    *blocks,
                    ConfigPoint {
                        config,
                        cost: wall,
                        error: max,
                    },
                ));
                format!(
                    "{wall:.2} | {ms:.3} | {lo:.3} to {hi:.3} | {max:.3e} | {rms:.3e} | {bottom_min:.3e} to {bottom_max:.3e}"
                )
            }
        };
        let _ = writeln!(table, "| {blocks} | `{}` | {row} |", config.label);
    }
    table.push_str(
        "\nGrowth of the cost a step with the blocks (all of them in motion): log-log slope\n\n\
         | configuration | fitted slope | standard error | between neighbours |\n|---|---|---|---|\n",
    );
    for (config, pairs) in configs.iter().zip(&costs) {
        if let Some(f) = loglog::fit(pairs) {
            let _ = writeln!(
                table,
                "| `{}` | {:.2} | {} | {:.2} to {:.2} |",
                config.label,
                f.slope,
                f.std_error.map_or("-".into(), |e| format!("{e:.2}")),
                f.local.0,
                f.local.1
            );
        }
    }
    let engines = || versions.iter().map(|(e, v)| (&e[..], &v[..]));
    table.push_str(&provenance.markdown(engines()));
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let write = |name: &str, text: &str| {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
    };
    write("results.csv", &csv)?;
    write("results.md", &table)?;
    write(
        "provenance.json",
        &serde_json::to_string_pretty(&provenance.json_with_engines(engines()))?,
    )?;
    let path = out.join("results.csv");
    let mut walls: Vec<usize> = accuracy.iter().map(|a| a.0).collect();
    walls.dedup();
    for blocks in walls {
        let points: Vec<ConfigPoint> = accuracy
            .iter()
            .filter(|a| a.0 == blocks)
            .map(|a| a.1.clone())
            .collect();
        let plot = configs_plot(
            &format!("{blocks}-block wall sliding whole: largest error against cost"),
            "log10 wall time for the 0.5 s (s)",
            "log10 largest error of a final displacement (m)",
            &points,
        );
        let figure = out.join(format!("work_precision_{blocks}.svg"));
        std::fs::write(&figure, plot.render())
            .with_context(|| format!("cannot write {}", figure.display()))?;
        eprintln!("wrote {}", figure.display());
    }
    print!("{table}");
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// One run's cost and its errors against the closed form.
struct PathRun {
    wall_time_s: f64,
    ms_per_step: f64,
    /// The largest and the rms error of a block's final displacement.
    max_error: f64,
    rms_error: f64,
    /// The least and the largest error of the bottom course (`c0b*`), the blocks on the
    /// sliding ground.
    bottom: (f64, f64),
}

impl PathRun {
    fn of(tr: &Trajectory, summary: &Summary, slide: f64) -> Self {
        let last = tr.t.len() - 1;
        let errors: Vec<f64> = tr
            .blocks
            .iter()
            .map(|b| (b.x[last] - b.x[0]) - slide)
            .collect();
        let bottom = tr
            .blocks
            .iter()
            .zip(&errors)
            .filter(|(b, _)| b.name.starts_with("c0b"))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, &e)| {
                (lo.min(e), hi.max(e))
            });
        PathRun {
            wall_time_s: summary.wall_time_s,
            ms_per_step: 1e3 * summary.wall_time_s / summary.steps.max(1) as f64,
            max_error: errors.iter().fold(0.0f64, |m, e| m.max(e.abs())),
            rms_error: (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt(),
            bottom,
        }
    }
}
