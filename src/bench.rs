//! Work-precision benchmark: every engine at every step size (and every native variant), the
//! median wall time of N runs against the error metrics of `crate::metrics`.
//!
//! The step size is set through each engine's own setting, named in the engine registry
//! (`native.dt`, `rapier.dt`, `mujoco.timestep`, ...); engines without one (housner, auto)
//! run once. Runs that fail or blow up stay in the table as failed, with their reason.

use crate::compare::{ReferenceSpec, Status, classify, run_of};
use crate::engines::registry::load_scene_with_overrides;
use crate::engines::{engine_by_name, run_timed_reporting};
use crate::metrics::{Cost, MetricRow, MetricSettings, Run, compare_runs};
use crate::report::provenance::Provenance;
use crate::report::svg::{Curve, Marker, Plot};
use crate::scene::Scene;
use crate::trajectory::Trajectory;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// A native solver/stepper combination benchmarked as its own line.
#[derive(Debug, Clone)]
pub struct Variant {
    pub name: String,
    pub set: Vec<String>,
}

/// The native variants: every back-end with both steppers.
pub fn native_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    for solver in ["active-set", "sparse", "clarabel"] {
        for stepper in ["impact", "position"] {
            v.push(Variant {
                name: format!("{solver}/{stepper}"),
                set: vec![
                    format!("native.solver=\"{solver}\""),
                    format!("native.stepper=\"{stepper}\""),
                ],
            });
        }
    }
    v
}

/// The scene setting that holds an engine's step size (the registry's).
pub fn step_setting(engine: &str) -> Option<&'static str> {
    crate::engines::registry::step_setting(engine)
}

#[derive(Debug, Clone)]
pub struct BenchOptions {
    pub engines: Vec<String>,
    pub dts: Vec<f64>,
    pub repeat: usize,
    pub reference: ReferenceSpec,
    /// Extra `--set` overrides applied to every run.
    pub overrides: Vec<String>,
}

/// One line of `work_precision.csv`.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub engine: String,
    pub variant: String,
    /// Step size, s (`None` for engines without one).
    pub dt: Option<f64>,
    pub status: String,
    pub reason: Option<String>,
    pub runs: usize,
    pub median_wall_s: Option<f64>,
    pub steps: Option<u64>,
    pub us_per_step: Option<f64>,
    /// Largest over blocks of the RMS / max rotation error over the window, rad.
    pub rms_error: Option<f64>,
    pub max_error: Option<f64>,
    /// Largest over blocks of the RMS rotation error up to the reference's first impact, rad.
    pub rms_error_to_impact_1: Option<f64>,
    /// First impact of the bottom block minus the reference's, s.
    pub first_impact_diff: Option<f64>,
    /// Relative error of the bottom block's amplitude after its first impact.
    pub amplitude_1_rel_error: Option<f64>,
    /// The engine's version as its run reported it (`None` where it did not run).
    pub engine_version: Option<String>,
}

/// The median of `v` (NaN for none): the wall time of repeated runs.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Errors of one run against the reference, from the metric rows.
fn errors(scene: &Scene, rows: &[MetricRow], row: &mut BenchRow) {
    let blocks: Vec<&str> = scene.blocks.iter().map(|b| b.name.as_str()).collect();
    let max_of = |metric: &str| -> Option<f64> {
        rows.iter()
            .filter(|r| r.metric == metric && blocks.contains(&r.block.as_str()))
            .filter_map(|r| r.value)
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
    };
    let bottom = |metric: &str| {
        rows.iter()
            .find(|r| r.metric == metric && r.block == blocks[0])
    };
    row.rms_error = max_of("rotation_rms_error");
    row.max_error = max_of("rotation_max_error");
    row.rms_error_to_impact_1 = max_of("rotation_rms_error_to_impact_1");
    row.first_impact_diff = bottom("impact_time_1").and_then(|r| Some(r.value? - r.reference?));
    row.amplitude_1_rel_error =
        bottom("peak_amplitude_1").and_then(|r| Some(r.value? / r.reference? - 1.0));
}

/// The engines and step sizes of a series checked before anything runs: every name in the
/// registry, every step a positive time no longer than the scene (one that is has no step to
/// take, and every cell of it would fail) nor than its fastest block's time scale, none given
/// twice.
pub fn check_engines_and_steps(
    scene: &Scene,
    engines: &[String],
    dts: &[f64],
) -> Result<(), String> {
    crate::engines::registry::check_names("--engines", engines.iter().map(String::as_str))?;
    check_steps(scene, dts)
}

/// `--set` overrides that the series would replace without a word: an engine's step (set from
/// `--dt`), and for `bench` (`variants`) the native solver and stepper of its variants.
pub fn check_series_sets(
    engines: &[String],
    sets: &[String],
    variants: bool,
) -> Result<(), String> {
    let replaced: Vec<&str> = engines
        .iter()
        .filter_map(|e| step_setting(e))
        .chain(
            (variants && engines.iter().any(|e| e == "native"))
                .then_some(["native.solver", "native.stepper"])
                .into_iter()
                .flatten(),
        )
        .collect();
    for s in sets {
        if let Some(r) = replaced
            .iter()
            .find(|r| crate::scene::override_covers(s, r))
        {
            return Err(format!(
                "--set {s}: the series sets {r} in every run ({})",
                if r.ends_with("solver") || r.ends_with("stepper") {
                    "native runs every solver and stepper"
                } else {
                    "from --dt"
                }
            ));
        }
    }
    Ok(())
}

/// The step sizes of a series checked against the scene.
fn check_steps(scene: &Scene, dts: &[f64]) -> Result<(), String> {
    let num = crate::scene::num;
    for (k, &dt) in dts.iter().enumerate() {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(format!(
                "--dt: step sizes must be positive (got {})",
                num(dt)
            ));
        }
        if dt > scene.duration {
            return Err(format!(
                "--dt: {} s is longer than the scene's run, {} s",
                num(dt),
                num(scene.duration)
            ));
        }
        if scene.duration / dt > crate::scene::MAX_STEPS {
            return Err(format!(
                "--dt: {} s makes {} steps of the scene's {} s; at most {:e}",
                num(dt),
                num((scene.duration / dt).ceil()),
                num(scene.duration),
                crate::scene::MAX_STEPS
            ));
        }
        if let Some(problem) = crate::scene::steps_over_motion(scene, dt) {
            return Err(format!("--dt: {problem}"));
        }
        if dts[..k].contains(&dt) {
            return Err(format!("--dt: {} s is given twice", num(dt)));
        }
    }
    Ok(())
}

/// The reference run: an engine run on `scene` through `runner`, or a trajectory file.
pub fn reference_run(
    spec: &ReferenceSpec,
    scene: &Scene,
    runner: &crate::compare::Runner,
) -> Result<Run, String> {
    Ok(match spec {
        ReferenceSpec::Engine(name) => {
            engine_by_name(name).map_err(|e| format!("--reference: {e}"))?;
            let run = runner(name, scene);
            match (&run.output, &run.summary) {
                (Some(out), Some(s)) => run_of(name, out, s),
                _ => {
                    let why = run.status.reason().unwrap_or("no output");
                    return Err(format!("--reference {name} did not run: {why}"));
                }
            }
        }
        ReferenceSpec::File(p) => {
            let run = Run {
                name: p.display().to_string(),
                trajectory: Trajectory::read_csv(p).map_err(|e| format!("--reference: {e}"))?,
                exact_impacts: None,
                cost: Cost::default(),
            };
            crate::metrics::check_reference_file(scene, &run)
                .map_err(|e| format!("--reference: {e}"))?;
            run
        }
    })
}

/// Run the benchmark. `progress` is called with a line per finished cell.
/// A reference engine with a step that is also one of the engines of a series (an exact one,
/// Housner's, is timed beside the others): its run at the scene's own step is no reference for
/// that engine's steps (the equal step has error 0, left out; the
/// finer ones are measured against a coarser run: native against native at 1e-3 gave order
/// 0.99 where it is 2.0). `or` names a further choice.
pub fn check_reference_outside(
    engines: &[String],
    reference: &ReferenceSpec,
    or: &str,
) -> Result<(), String> {
    match reference {
        ReferenceSpec::Engine(r) if engines.contains(r) && step_setting(r).is_some() => {
            Err(format!(
                "--reference {r}: one of the engines studied, and its run at the scene's step is no \
             reference for its own steps: give another engine, a trajectory file{}{or}",
                if or.is_empty() { "" } else { ", " }
            ))
        }
        _ => Ok(()),
    }
}

pub fn bench(
    scene_path: &Path,
    opts: &BenchOptions,
    progress: &dyn Fn(&BenchRow),
) -> Result<Vec<BenchRow>, String> {
    let base = load_scene_with_overrides(scene_path, &opts.overrides).map_err(|e| e.to_string())?;
    check_engines_and_steps(&base, &opts.engines, &opts.dts)?;
    check_series_sets(&opts.engines, &opts.overrides, true)?;
    check_reference_outside(&opts.engines, &opts.reference, "")?;
    // The runs stop on a Ctrl-C (`rockbench bench`, [`crate::interrupt`]).
    let run_reference = |name: &str, scene: &Scene| {
        crate::compare::run_engine_reporting(
            name,
            scene,
            &crate::interrupt::go_on_unless_interrupted,
        )
    };
    let reference = reference_run(&opts.reference, &base, &run_reference)?;
    let mut rows = Vec::new();
    for engine in &opts.engines {
        let variants = if engine == "native" {
            native_variants()
        } else {
            vec![Variant {
                name: "default".into(),
                set: vec![],
            }]
        };
        let dts: Vec<Option<f64>> = match step_setting(engine) {
            Some(_) => opts.dts.iter().map(|&d| Some(d)).collect(),
            None => vec![None],
        };
        for v in &variants {
            for &dt in &dts {
                let mut set = opts.overrides.clone();
                set.extend(v.set.iter().cloned());
                if let (Some(dt), Some(key)) = (dt, step_setting(engine)) {
                    set.push(format!("{key}={dt:e}"));
                }
                let mut row = BenchRow {
                    scene: base.name.clone(),
                    engine: engine.clone(),
                    variant: v.name.clone(),
                    dt,
                    status: "ok".into(),
                    reason: None,
                    runs: 0,
                    median_wall_s: None,
                    steps: None,
                    us_per_step: None,
                    rms_error: None,
                    max_error: None,
                    rms_error_to_impact_1: None,
                    first_impact_diff: None,
                    amplitude_1_rel_error: None,
                    engine_version: None,
                };
                let outcome = load_scene_with_overrides(scene_path, &set)
                    .map_err(|e| e.to_string())
                    .and_then(|scene| {
                        let e = engine_by_name(engine).map_err(|e| {
                            row.status = classify(&e).word().to_string();
                            e.to_string()
                        })?;
                        let mut walls = Vec::new();
                        let mut first = None;
                        for _ in 0..opts.repeat.max(1) {
                            let (out, s) = run_timed_reporting(
                                e.as_ref(),
                                &scene,
                                &crate::interrupt::go_on_unless_interrupted,
                            )
                            .map_err(|err| {
                                if let Status::Skipped(_) = classify(&err) {
                                    row.status = "skipped".into();
                                }
                                err.to_string()
                            })?;
                            walls.push(s.wall_time_s);
                            first.get_or_insert((out, s));
                        }
                        Ok((scene, walls, first.expect("at least one run")))
                    });
                match outcome {
                    Ok((scene, walls, (out, s))) => {
                        let wall = median(walls.clone());
                        row.runs = walls.len();
                        row.median_wall_s = Some(wall);
                        row.steps = Some(s.steps);
                        row.us_per_step = (s.steps > 0).then(|| 1e6 * wall / s.steps as f64);
                        row.engine_version = Some(out.engine_version.clone());
                        let run = run_of(engine, &out, &s);
                        let settings = MetricSettings::default().on_samples_of(&run, &reference);
                        match compare_runs(&scene, &run, &reference, &settings) {
                            Ok(m) => errors(&scene, &m, &mut row),
                            Err(e) => {
                                row.status = "failed".into();
                                row.reason = Some(format!("metrics: {e}"));
                            }
                        }
                    }
                    Err(reason) => {
                        if row.status == "ok" {
                            row.status = "failed".into();
                        }
                        row.reason = Some(reason.replace('\n', " "));
                    }
                }
                progress(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// What made the timings: the program, each engine's version, the machine and the date.
fn provenance_md(rows: &[BenchRow], prov: &Provenance) -> String {
    prov.markdown(
        rows.iter()
            .filter_map(|r| Some((r.engine.as_str(), r.engine_version.as_deref()?))),
    )
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.4e}")).unwrap_or_default()
}

/// `work_precision.csv`, `work_precision.md`, `work_precision.svg`.
pub fn write(dir: &Path, rows: &[BenchRow], command: &str) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut csv = String::from(
        "scene,engine,variant,dt,status,reason,runs,median_wall_s,steps,us_per_step,rms_error,max_error,rms_error_to_impact_1,first_impact_diff,amplitude_1_rel_error\n",
    );
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},\"{}\",{},{},{},{},{},{},{},{},{}",
            r.scene,
            r.engine,
            r.variant,
            opt(r.dt),
            r.status,
            r.reason.clone().unwrap_or_default().replace('"', "'"),
            r.runs,
            opt(r.median_wall_s),
            r.steps.map(|s| s.to_string()).unwrap_or_default(),
            opt(r.us_per_step),
            opt(r.rms_error),
            opt(r.max_error),
            opt(r.rms_error_to_impact_1),
            opt(r.first_impact_diff),
            opt(r.amplitude_1_rel_error)
        );
    }
    let w = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text)
            .map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    w("work_precision.csv", &csv)?;
    let mut md = format!(
        "# Work-precision: {}\n\nMedian wall time of {} run(s) per cell against the rotation error (largest over blocks, rad) versus the reference. Command: `{command}`\n\n",
        rows.first().map(|r| r.scene.as_str()).unwrap_or(""),
        rows.first().map(|r| r.runs).unwrap_or(0)
    );
    md += "| engine | variant | dt (s) | status | wall (s) | us/step | RMS error | max error | RMS to impact 1 | first impact diff (s) | amplitude 1 error |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {}{} | {} | {} | {} | {} | {} | {} | {} |",
            r.engine,
            r.variant,
            opt(r.dt),
            r.status,
            r.reason
                .as_ref()
                .map(|x| format!(": {x}"))
                .unwrap_or_default(),
            opt(r.median_wall_s),
            opt(r.us_per_step),
            opt(r.rms_error),
            opt(r.max_error),
            opt(r.rms_error_to_impact_1),
            opt(r.first_impact_diff),
            r.amplitude_1_rel_error
                .map(|e| format!("{:+.2} %", 100.0 * e))
                .unwrap_or_default()
        );
    }
    md += &provenance_md(rows, &Provenance::collect(command));
    w("work_precision.md", &md)?;
    w("work_precision.svg", &plot(rows).render())?;
    Ok(())
}

/// The curves' colours, in order.
const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
];

/// The work-precision figure: one line per engine/variant through its step sizes, log10
/// error against log10 time.
pub fn plot(rows: &[BenchRow]) -> Plot {
    let mut plot = Plot {
        title: "Work-precision: RMS rotation error against median wall time".into(),
        x_label: "log10 wall time (s)".into(),
        y_label: "log10 RMS rotation error (rad)".into(),
        ..Default::default()
    };
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in rows {
        let k = (r.engine.clone(), r.variant.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (i, (e, v)) in keys.iter().enumerate() {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.engine == e && &r.variant == v && r.status == "ok")
            // The reference itself has no error: it is in the table, not on the log axis.
            .filter(|r| r.rms_error.is_some_and(|e| e > 0.0))
            .filter_map(|r| Some((r.median_wall_s?.log10(), r.rms_error?.log10())))
            .collect();
        if pts.is_empty() {
            continue;
        }
        plot.curves.push(Curve {
            name: if v == "default" {
                e.clone()
            } else {
                format!("{e} {v}")
            },
            color: PALETTE[i % PALETTE.len()].into(),
            dashed: v.ends_with("position"),
            x: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
        });
    }
    plot
}

/// A run of a work-precision study given as a configuration ([`crate::sensitivity::Config`]):
/// its cost and its error, both positive.
#[derive(Debug, Clone)]
pub struct ConfigPoint<'a> {
    pub config: &'a crate::sensitivity::Config,
    pub cost: f64,
    pub error: f64,
}

/// The curve of a configuration in a work-precision figure: its engine and its settings other
/// than the engine's step size (the registry's [`step_setting`]), so that the runs of one
/// method at several step sizes make one curve.
pub fn curve_name(config: &crate::sensitivity::Config) -> String {
    let step = step_setting(&config.engine);
    let others: Vec<&str> = config
        .sets
        .iter()
        .map(String::as_str)
        .filter(|s| s.split_once('=').map(|(k, _)| k.trim()) != step)
        .collect();
    if others.is_empty() {
        config.engine.clone()
    } else {
        format!("{} {}", config.engine, others.join("; "))
    }
}

/// The work-precision figure of configurations: log10 error against log10 cost, one curve per
/// [`curve_name`] through its runs in order of cost, every run marked (a configuration alone in
/// its curve is a mark). Runs without a positive, finite cost and error are left out (an exact
/// answer has no place on a log axis).
pub fn configs_plot(title: &str, x_label: &str, y_label: &str, points: &[ConfigPoint]) -> Plot {
    let mut plot = Plot {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        ..Default::default()
    };
    // The usable runs: (curve, log10 cost, log10 error).
    let named: Vec<(String, f64, f64)> = points
        .iter()
        .filter(|p| p.cost.is_finite() && p.cost > 0.0 && p.error.is_finite() && p.error > 0.0)
        .map(|p| (curve_name(p.config), p.cost.log10(), p.error.log10()))
        .collect();
    let mut names: Vec<&String> = Vec::new();
    for (name, _, _) in &named {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    for (i, name) in names.into_iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()].to_string();
        let mut pts: Vec<(f64, f64)> = named
            .iter()
            .filter(|(n, _, _)| n == name)
            .map(|&(_, x, y)| (x, y))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        plot.markers.extend(pts.iter().map(|&(x, y)| Marker {
            x,
            y,
            color: color.clone(),
        }));
        plot.curves.push(Curve {
            name: name.clone(),
            color,
            dashed: false,
            x: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
        });
    }
    plot
}

#[cfg(test)]
mod tests {
    use super::{BenchRow, ConfigPoint, Provenance, configs_plot, curve_name, median};
    use super::{provenance_md, write};
    use crate::build_info::{GIT_COMMIT, SOURCE_HASH};
    use crate::sensitivity::Config;

    #[test]
    fn the_table_names_the_program_each_engine_s_version_and_the_machine() {
        let row = |engine: &str, dt: f64, version: Option<&str>| BenchRow {
            scene: "s".into(),
            engine: engine.into(),
            variant: "default".into(),
            dt: Some(dt),
            status: if version.is_some() { "ok" } else { "failed" }.into(),
            engine_version: version.map(String::from),
            ..Default::default()
        };
        let rows = [
            row("rapier", 1e-3, Some("rapier2d-f64 0.1")),
            row("rapier", 5e-4, Some("rapier2d-f64 0.1")),
            row("native", 1e-3, Some("rockbench native")),
            row("mujoco", 1e-3, None),
        ];
        let prov = Provenance::collect("rockbench bench s.toml");
        let md = provenance_md(&rows, &prov);
        assert!(
            md.contains(&format!("(commit {GIT_COMMIT}, sources {SOURCE_HASH})")),
            "{md}"
        );
        // Each engine that ran, once, in order of name; the one that did not run has no version.
        let engines: Vec<&str> = md.lines().filter(|l| l.starts_with("- engine")).collect();
        assert_eq!(
            engines,
            [
                "- engine `native`: rockbench native",
                "- engine `rapier`: rapier2d-f64 0.1"
            ]
        );
        assert!(md.contains(&format!("{} cores", prov.cores)) && md.contains(&prov.date));
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), &rows, "rockbench bench s.toml").unwrap();
        let written = std::fs::read_to_string(dir.path().join("work_precision.md")).unwrap();
        // The file ends with the provenance (its date taken again when written).
        let before_machine = &md[..md.find("- machine").unwrap()];
        assert!(written.contains(before_machine), "{written}");
        let last = written.lines().last().unwrap();
        assert!(last.starts_with("- date (UTC): 20"), "{last}");
    }

    #[test]
    fn configurations_at_several_steps_make_one_curve_in_order_of_cost() {
        // Written out rather than parsed: the registry's step settings hold in every build,
        // while parsing checks that each engine is built.
        let configs: Vec<Config> = [
            "rapier:rapier.dt=1e-4",
            "rapier",
            "native",
            "rapier:rapier.solver_iterations=16;rapier.dt=2.5e-4",
            "rapier:rapier.dt=5e-4",
            "native:native.friction_law=\"coulomb\"",
        ]
        .iter()
        .map(|label| {
            let (engine, sets) = label.split_once(':').unwrap_or((label, ""));
            Config {
                label: label.to_string(),
                engine: engine.to_string(),
                sets: sets
                    .split(';')
                    .filter(|s| !s.is_empty())
                    .map(String::from)
                    .collect(),
            }
        })
        .collect();
        assert_eq!(curve_name(&configs[0]), "rapier");
        assert_eq!(curve_name(&configs[1]), "rapier");
        assert_eq!(
            curve_name(&configs[3]),
            "rapier rapier.solver_iterations=16"
        );
        assert_eq!(
            curve_name(&configs[5]),
            "native native.friction_law=\"coulomb\""
        );
        // (cost, error) per configuration, in the order given; the Coulomb run is exact.
        let measured = [
            (10.0, 1e-2),
            (1.0, 2e-2),
            (2.0, 1e-6),
            (5.0, 1.5e-2),
            (3.0, 1.8e-2),
            (4.0, 0.0),
        ];
        let points: Vec<ConfigPoint> = configs
            .iter()
            .zip(measured)
            .map(|(config, (cost, error))| ConfigPoint {
                config,
                cost,
                error,
            })
            .collect();
        let plot = configs_plot("t", "x", "y", &points);
        let names: Vec<&str> = plot.curves.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            ["rapier", "native", "rapier rapier.solver_iterations=16"]
        );
        // The rapier curve through its three step sizes, cheapest first, on log axes.
        let rapier = &plot.curves[0];
        let expected_x = [1.0f64.log10(), 3.0f64.log10(), 10.0f64.log10()];
        let expected_y = [2e-2f64.log10(), 1.8e-2f64.log10(), 1e-2f64.log10()];
        for k in 0..3 {
            assert!(
                (rapier.x[k] - expected_x[k]).abs() < 1e-12,
                "{:?}",
                rapier.x
            );
            assert!(
                (rapier.y[k] - expected_y[k]).abs() < 1e-12,
                "{:?}",
                rapier.y
            );
        }
        // Every usable run is marked in its curve's colour; the exact one is left out.
        assert_eq!(plot.markers.len(), 5);
        assert_eq!(
            plot.markers
                .iter()
                .filter(|m| m.color == rapier.color)
                .count(),
            3
        );
        assert!(plot.render().starts_with("<svg"));
    }

    #[test]
    fn medians_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(Vec::new()).is_nan());
    }
}
