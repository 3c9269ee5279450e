//! A scene's answer as an ensemble (`make bench-walls-sensitivity`): each configuration runs the
//! scene `--members` times, member `k` with one scene value (`--perturb KEY=VALUE`) set to
//! `VALUE (1 + k epsilon)` (`--epsilon`, 1e-12 by default: a perturbation at round-off level).
//! Per run: every block's final horizontal displacement (`rockbench::metrics::displacement`),
//! the blocks that overturned, and the cost. Per configuration (`rockbench::metrics::ensemble`):
//! the ensemble's spread, how its mean differs from the first configuration's and from every
//! other's, in mm and in standard errors of that difference, and whether its members overturn
//! the same blocks.
//! Where a setting's difference is within a few standard errors, the two settings are not told
//! apart by a scene whose answer is decided at round-off (docs/method.md, "A sliding wall's
//! answer is decided at round-off").
//!
//! Without `--scene`, the scene is a running-bond wall (`rockbench::walls`, `--courses` of 21
//! blocks of 0.6 x 0.25 m, friction 0.7) slid by a rectangular pulse of `--pulse` g for
//! `--pulse-duration` s, run to `--duration` s, and the pulse's amplitude is perturbed.
//!
//! A configuration is `ENGINE[:KEY=VALUE[;KEY=VALUE...]]` (scene overrides, as `--set`);
//! configurations are separated by commas. Every run is appended to `OUT/runs.csv` as it ends,
//! and a run already there is not run again: an interrupted study resumes where it stopped.
//! `OUT/runs.csv` starts with the study's parameters (the scene's text hashed); another study's
//! directory is refused. Writes `OUT/sensitivity.md`, and for the generated wall `OUT/scene.toml`
//! (the scene as run, before the overrides).

#[path = "common/flags.rs"]
mod flags;

use anyhow::{Context, bail};
use flags::check_flags;
use rockbench::engines::registry::load_scene_with_overrides;
use rockbench::engines::{engine_by_name, run_timed};
use rockbench::metrics::displacement;
use rockbench::metrics::ensemble::Ensemble;
use rockbench::walls::WallSpec;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

const USAGE: &str = "cargo run --release --example wall_sensitivity -- \
[--courses 10 --pulse 0.8 --pulse-duration 0.2 | --scene FILE --perturb KEY=VALUE] \
[--duration 0.5] [--members 4] [--epsilon 1e-12] \
[--configs ENGINE[:KEY=VALUE[;KEY=VALUE]],...] [--out out/bench-walls-sensitivity]";

const FLAGS: [&str; 10] = [
    "--scene",
    "--perturb",
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

struct Config {
    label: String,
    engine: String,
    sets: Vec<String>,
}

struct Run {
    config: String,
    member: usize,
    wall_s: f64,
    steps: u64,
    engine_version: String,
    /// The overturned blocks' indices.
    overturned: Vec<usize>,
    final_dx: Vec<f64>,
}

fn arg<'a>(args: &'a [String], name: &str, default: &'a str) -> &'a str {
    args.iter()
        .position(|a| a == name)
        .map_or(default, |i| args[i + 1].as_str())
}

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

fn parse_configs(text: &str) -> anyhow::Result<Vec<Config>> {
    let mut configs = Vec::new();
    for label in text.split(',').map(str::trim) {
        let (engine, sets) = label.split_once(':').unwrap_or((label, ""));
        if engine.is_empty() {
            bail!("--configs: a configuration without an engine: {label:?}");
        }
        if let Err(e) = engine_by_name(engine) {
            bail!("--configs: {label:?}: {e}");
        }
        let sets: Vec<String> = sets
            .split(';')
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect();
        if let Some(s) = sets.iter().find(|s| !s.contains('=')) {
            bail!("--configs: {label:?}: {s:?} is not KEY=VALUE");
        }
        if configs.iter().any(|c: &Config| c.label == label) {
            bail!("--configs: {label:?} given twice");
        }
        configs.push(Config {
            label: label.to_string(),
            engine: engine.to_string(),
            sets,
        });
    }
    Ok(configs)
}

/// The runs already in `path` (made with `parameters`, for `n_blocks` blocks).
fn read_runs(path: &Path, parameters: &str, n_blocks: usize) -> anyhow::Result<Vec<Run>> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => bail!("cannot read {}: {e}", path.display()),
    };
    let mut lines = text.lines();
    if lines.next() != Some(parameters) {
        bail!(
            "{}: holds the runs of another study (its first line is not {parameters:?}): remove \
             it or give another --out",
            path.display()
        );
    }
    lines.next(); // The header.
    let mut runs = Vec::new();
    for (k, line) in lines.enumerate() {
        let bad = || {
            format!(
                "{}: line {}: not a run of this study",
                path.display(),
                k + 3
            )
        };
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 + n_blocks {
            bail!("{}", bad());
        }
        let overturned = f[5]
            .split(';')
            .filter(|x| !x.is_empty())
            .map(|x| x.parse::<usize>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(bad)?;
        let final_dx = f[6..]
            .iter()
            .map(|x| x.parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(bad)?;
        runs.push(Run {
            config: f[0].to_string(),
            member: f[1].parse().with_context(bad)?,
            wall_s: f[2].parse().with_context(bad)?,
            steps: f[3].parse().with_context(bad)?,
            engine_version: f[4].to_string(),
            overturned,
            final_dx,
        });
    }
    Ok(runs)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// FNV-1a of the scene's text: a study's runs belong to one scene.
fn text_hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf29ce484222325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100000001b3)
    })
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
    let given = |name: &str| args.iter().any(|a| a == name);
    let positive = |v: f64| v > 0.0;
    let members = number(&args, "--members", "4", "a whole number, 2 or more", |v| {
        v >= 2.0 && v.fract() == 0.0
    })? as usize;
    let epsilon = number(
        &args,
        "--epsilon",
        "1e-12",
        "positive and below 1e-3",
        |v| v > 0.0 && v < 1e-3,
    )?;
    let configs = parse_configs(arg(&args, "--configs", DEFAULT_CONFIGS))?;
    let out = Path::new(arg(&args, "--out", "out/bench-walls-sensitivity"));

    // The scene's text, the perturbed key and its value, and the scene's description.
    let (scene_text, key, value, about) = if given("--scene") {
        if let Some(f) = ["--courses", "--pulse", "--pulse-duration"]
            .into_iter()
            .find(|f| given(f))
        {
            bail!("{f}: for the generated wall only (not with --scene)");
        }
        let file = arg(&args, "--scene", "");
        let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {file}"))?;
        let perturb = arg(&args, "--perturb", "");
        let Some((key, v)) = perturb.split_once('=') else {
            bail!("--perturb: needs KEY=VALUE with --scene (got {perturb:?})");
        };
        let value: f64 = v
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite() && *x != 0.0)
            .with_context(|| format!("--perturb: {v:?} is not a finite non-zero number"))?;
        (text, key.to_string(), value, format!("`{file}`"))
    } else {
        if given("--perturb") {
            bail!("--perturb: with --scene only (the generated wall perturbs its pulse)");
        }
        let courses = number(&args, "--courses", "10", "a whole number, 1 or more", |v| {
            v >= 1.0 && v.fract() == 0.0
        })? as usize;
        let pulse = number(&args, "--pulse", "0.8", "a positive number of g", positive)?;
        let pulse_duration = number(&args, "--pulse-duration", "0.2", "positive, s", positive)?;
        let wall = WallSpec::running_bond(courses, 21);
        let text = format!(
            "{}\n[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {:?}\n\
             duration = {pulse_duration:?}\nstart = 0\n",
            wall.to_toml(),
            pulse * G
        );
        let about = format!(
            "a running-bond wall of {} blocks ({courses} courses of 21, 0.6 x 0.25 m, friction \
             0.7) under a rectangular pulse of {pulse} g for {pulse_duration} s",
            wall.n_blocks()
        );
        (
            text,
            "excitation.horizontal.amplitude".to_string(),
            pulse * G,
            about,
        )
    };
    let mut common: Vec<String> = Vec::new();
    if given("--duration") || !given("--scene") {
        let duration = number(&args, "--duration", "0.5", "positive, s", positive)?;
        common.push(format!("duration={duration:?}"));
    }
    let parameters = format!(
        "# wall_sensitivity: scene {:016x}, {key} = {value:?} x (1 + k {epsilon:e}), {}, rockbench {}",
        text_hash(&scene_text),
        common.join(" "),
        env!("CARGO_PKG_VERSION")
    );
    let runs_path = out.join("runs.csv");
    // The scene as run: the given file (its records found beside it), or the generated wall
    // written to OUT/scene.toml. It is checked, and the runs already made read, before anything
    // of the study is written.
    let scene_path = if given("--scene") {
        PathBuf::from(arg(&args, "--scene", ""))
    } else {
        out.join("scene.toml")
    };
    let check = |path: &Path| -> anyhow::Result<(rockbench::scene::Scene, Vec<Run>)> {
        for c in &configs {
            let mut sets = common.clone();
            sets.push(format!("{key}={value:?}"));
            sets.extend(c.sets.iter().cloned());
            load_scene_with_overrides(path, &sets).with_context(|| c.label.clone())?;
        }
        let base = load_scene_with_overrides(path, &common)?;
        let runs = read_runs(&runs_path, &parameters, base.blocks.len())?;
        Ok((base, runs))
    };
    let (base, mut runs) = if given("--scene") {
        check(&scene_path)?
    } else {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        let pending = out.join("scene.toml.new");
        std::fs::write(&pending, &scene_text)
            .with_context(|| format!("cannot write {}", pending.display()))?;
        let checked = check(&pending);
        if checked.is_err() {
            let _ = std::fs::remove_file(&pending);
        }
        let checked = checked?;
        std::fs::rename(&pending, &scene_path)
            .with_context(|| format!("cannot write {}", scene_path.display()))?;
        checked
    };
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let names: Vec<String> = base.blocks.iter().map(|b| b.name.clone()).collect();
    let duration = base.duration;
    if runs.is_empty() {
        let header: String = names.iter().map(|n| format!(",{n}")).collect();
        std::fs::write(
            &runs_path,
            format!("{parameters}\nconfig,member,wall_s,steps,engine_version,overturned{header}\n"),
        )
        .with_context(|| format!("cannot write {}", runs_path.display()))?;
    }
    let mut file = std::fs::OpenOptions::new()
        .append(true)
        .open(&runs_path)
        .with_context(|| format!("cannot append to {}", runs_path.display()))?;

    let total = configs.len() * members;
    for c in &configs {
        for k in 0..members {
            if runs.iter().any(|r| r.config == c.label && r.member == k) {
                continue;
            }
            let mut sets = common.clone();
            sets.push(format!("{key}={:?}", value * (1.0 + k as f64 * epsilon)));
            sets.extend(c.sets.iter().cloned());
            let scene = load_scene_with_overrides(&scene_path, &sets)
                .with_context(|| format!("{}: the scene with {sets:?}", c.label))?;
            let engine = engine_by_name(&c.engine)?;
            let (o, s) = run_timed(engine.as_ref(), &scene)
                .with_context(|| format!("{}, member {k}", c.label))?;
            let final_dx: Vec<f64> = (0..names.len())
                .map(|i| {
                    displacement(&o.trajectory, i, (0.0, duration))
                        .0
                        .unwrap_or(f64::NAN)
                })
                .collect();
            let run = Run {
                config: c.label.clone(),
                member: k,
                wall_s: s.wall_time_s,
                steps: s.steps,
                engine_version: s.engine_version.replace(',', ";"),
                overturned: (0..names.len())
                    .filter(|&i| s.blocks[i].overturned)
                    .collect(),
                final_dx,
            };
            let overturned: Vec<String> = run.overturned.iter().map(|i| i.to_string()).collect();
            let dx: String = run.final_dx.iter().map(|x| format!(",{x:?}")).collect();
            writeln!(
                file,
                "{},{},{},{},{},{}{dx}",
                run.config,
                run.member,
                run.wall_s,
                run.steps,
                run.engine_version,
                overturned.join(";")
            )?;
            file.flush()?;
            runs.push(run);
            let done = configs
                .iter()
                .map(|c| {
                    (0..members)
                        .filter(|&m| runs.iter().any(|r| r.config == c.label && r.member == m))
                        .count()
                })
                .sum::<usize>();
            eprintln!(
                "[{done}/{total}] {}, member {k}: {:.1} s, {:.2} ms a step",
                c.label,
                s.wall_time_s,
                1e3 * s.wall_time_s / s.steps.max(1) as f64
            );
        }
    }

    let mut md = String::new();
    let _ = writeln!(
        md,
        "# A scene's answer as an ensemble\n\n{about}, {duration} s; {members} members a \
         configuration, member k with `{key}` = {value:?} x (1 + k {epsilon:e}). Final \
         horizontal displacements of every block, relative to the ground (the scene in \
         `{}`; the runs in `runs.csv`). Spread: RMS over the blocks of the members' sample \
         deviation (largest in brackets). Difference: of each ensemble's mean from the first \
         configuration's, RMS over the blocks (largest in brackets), and over its standard \
         error (docs/quantities.md, \"Ensembles\"). Overturned: each member's count, and the \
         blocks that some members overturn and others do not.\n",
        scene_path.display()
    );
    let _ = writeln!(
        md,
        "| configuration | engine version | ms a step (median) | s a run (median) | mean shift, mm (largest) | spread, mm | difference, mm | in standard errors | overturned | not in every member |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut first: Option<Ensemble> = None;
    let mut ensembles: Vec<Ensemble> = Vec::new();
    for c in &configs {
        let mine: Vec<&Run> = runs.iter().filter(|r| r.config == c.label).collect();
        let e = Ensemble::of(&mine.iter().map(|r| r.final_dx.clone()).collect::<Vec<_>>())
            .map_err(|e| anyhow::anyhow!("{}: {e}", c.label))?;
        let step_ms = median(
            mine.iter()
                .map(|r| 1e3 * r.wall_s / r.steps.max(1) as f64)
                .collect(),
        );
        let run_s = median(mine.iter().map(|r| r.wall_s).collect());
        let shift = e.mean.iter().sum::<f64>() / e.mean.len() as f64;
        let largest = e.mean.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let difference = match &first {
            None => "(reference) | -".to_string(),
            Some(f) => {
                let d = e.difference(f).map_err(|e| anyhow::anyhow!(e))?;
                let ratio = d.rms / d.standard_error;
                let ratio = if ratio < 1e3 {
                    format!("{ratio:.1}")
                } else {
                    format!("{ratio:.1e}")
                };
                format!("{:.3} ({:.3}) | {ratio}", 1e3 * d.rms, 1e3 * d.max)
            }
        };
        let counts: Vec<String> = mine
            .iter()
            .map(|r| r.overturned.len().to_string())
            .collect();
        let split: Vec<&str> = (0..names.len())
            .filter(|i| {
                let n = mine.iter().filter(|r| r.overturned.contains(i)).count();
                n > 0 && n < mine.len()
            })
            .map(|i| names[i].as_str())
            .collect();
        let _ = writeln!(
            md,
            "| `{}` | {} | {step_ms:.3} | {run_s:.2} | {:.2} ({:.2}) | {:.3} ({:.3}) | {difference} | {} | {} |",
            c.label,
            mine[0].engine_version,
            1e3 * shift,
            1e3 * largest,
            1e3 * e.spread(),
            1e3 * e.largest_spread(),
            counts.join(" / "),
            if split.is_empty() {
                "-".to_string()
            } else {
                split.join(", ")
            }
        );
        first.get_or_insert_with(|| e.clone());
        ensembles.push(e);
    }
    let _ = writeln!(
        md,
        "\nEvery pair of configurations: the difference of their means, RMS over the blocks \
         (largest in brackets), and over its standard error.\n\n| configuration | against | \
         difference, mm | in standard errors |\n|---|---|---|---|"
    );
    for (i, a) in ensembles.iter().enumerate() {
        for (j, b) in ensembles.iter().enumerate().skip(i + 1) {
            let d = b.difference(a).map_err(|e| anyhow::anyhow!(e))?;
            let _ = writeln!(
                md,
                "| `{}` | `{}` | {:.3} ({:.3}) | {:.1} |",
                configs[j].label,
                configs[i].label,
                1e3 * d.rms,
                1e3 * d.max,
                d.rms / d.standard_error
            );
        }
    }
    let md_path = out.join("sensitivity.md");
    std::fs::write(&md_path, &md).with_context(|| format!("cannot write {}", md_path.display()))?;
    print!("{md}");
    eprintln!("wrote {}", md_path.display());
    Ok(())
}
