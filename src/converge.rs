//! Observed order of accuracy: every engine at a series of step sizes, the error of each
//! quantity against a reference, and the slope of log error against log dt.
//!
//! Quantities (per measured series: a block on the ground, or the interface of a block on
//! another), with their errors:
//! - `impact_time_1` (s), `peak_amplitude_1..3` (rad), `rest_time_1e-4` (s): |value -
//!   reference value|, the events of `crate::events`;
//! - `rotation_rms_error_to_impact_1`, `..._to_impact_3` (rad): the RMS rotation error itself
//!   (`crate::metrics`).
//!
//! The reference is an engine, a `trajectory.csv`, or `self`: each engine's own finest run
//! (Richardson's view: the finest run has no error and is left out of the fit). The observed
//! order is the least-squares slope of `ln error` against `ln dt` over the step sizes with a
//! non-zero error, with the slope's standard error (three points or more) and the smallest and
//! largest of the local orders `ln(e_i / e_j) / ln(dt_i / dt_j)` of consecutive step sizes.
//! Runs that fail stay listed with their reason.

use crate::bench::{reference_run, step_setting};
use crate::compare::{ReferenceSpec, Runner, Status, run_of};
use crate::engines::registry::load_scene_with_overrides;
use crate::metrics::{MetricRow, MetricSettings, Run, compare_runs, series_of};
use crate::report::svg::{Curve, Plot};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// The quantities whose convergence is reported: metric name, what it is, unit.
pub const QUANTITIES: [(&str, &str, &str); 7] = [
    ("impact_time_1", "first impact instant", "s"),
    ("peak_amplitude_1", "amplitude after impact 1", "rad"),
    ("peak_amplitude_2", "amplitude after impact 2", "rad"),
    ("peak_amplitude_3", "amplitude after impact 3", "rad"),
    (
        "rotation_rms_error_to_impact_1",
        "RMS rotation error to impact 1",
        "rad",
    ),
    (
        "rotation_rms_error_to_impact_3",
        "RMS rotation error to impact 3",
        "rad",
    ),
    ("rest_time_1e-4", "rest time at 1e-4 rad", "s"),
];

/// What the errors are measured against.
#[derive(Debug, Clone)]
pub enum ConvergeReference {
    /// An engine or a trajectory file, the same for every engine.
    Common(ReferenceSpec),
    /// Each engine's own finest run.
    Finest,
}

impl ConvergeReference {
    pub fn parse(s: &str) -> ConvergeReference {
        if s == "self" {
            ConvergeReference::Finest
        } else {
            ConvergeReference::Common(ReferenceSpec::parse(s))
        }
    }

    pub fn label(&self) -> String {
        match self {
            ConvergeReference::Common(r) => r.label(),
            ConvergeReference::Finest => "self (each engine's finest run)".into(),
        }
    }
}

#[derive(Debug, Clone)]
pub struct ConvergeOptions {
    pub engines: Vec<String>,
    pub dts: Vec<f64>,
    pub reference: ConvergeReference,
    /// Extra `--set` overrides applied to every run.
    pub overrides: Vec<String>,
}

/// One run of one engine at one step size.
#[derive(Debug, Clone, Serialize)]
pub struct ConvergeRun {
    pub engine: String,
    pub dt: f64,
    /// `ok`, `failed` or `skipped`.
    pub status: String,
    pub reason: Option<String>,
    pub wall_time_s: Option<f64>,
    pub steps: Option<u64>,
    pub engine_version: Option<String>,
    /// The engine's settings as run (from its summary).
    pub settings: Option<serde_json::Value>,
    /// Read back from the run cache (its wall time is that of the run that made it).
    pub cached: bool,
}

impl ConvergeRun {
    /// The step size as written in tables, `-` for an engine without one.
    pub fn dt_label(&self) -> String {
        if self.dt.is_finite() {
            format!("{:e}", self.dt)
        } else {
            "-".into()
        }
    }
}

/// The error of one quantity of one series in one run.
#[derive(Debug, Clone, Serialize)]
pub struct ConvergePoint {
    pub engine: String,
    pub dt: f64,
    pub series: String,
    pub quantity: String,
    pub value: Option<f64>,
    pub reference: Option<f64>,
    /// `None` where either side is undefined, or for the reference run itself (`self`).
    pub error: Option<f64>,
}

/// The observed order of one quantity of one series of one engine.
#[derive(Debug, Clone, Serialize)]
pub struct Order {
    pub engine: String,
    pub series: String,
    pub quantity: String,
    /// Step sizes with a non-zero error used in the fit.
    pub points: usize,
    pub order: Option<f64>,
    /// Standard error of the fitted slope (three points or more).
    pub std_error: Option<f64>,
    pub local_min: Option<f64>,
    pub local_max: Option<f64>,
}

/// Everything `converge` measured.
#[derive(Debug, Clone, Serialize)]
pub struct Convergence {
    pub scene: String,
    pub reference: String,
    pub runs: Vec<ConvergeRun>,
    pub points: Vec<ConvergePoint>,
    pub orders: Vec<Order>,
}

/// Least-squares slope of `ln e` against `ln dt` with its standard error, and the range of
/// the local orders between consecutive step sizes ([`crate::loglog::fit`]).
pub fn observed_order(pairs: &[(f64, f64)]) -> (Option<f64>, Option<f64>, Option<(f64, f64)>) {
    match crate::loglog::fit(pairs) {
        Some(f) => (Some(f.slope), f.std_error, Some(f.local)),
        None => (None, None, None),
    }
}

/// The error of a quantity from its metric row.
fn error_of(quantity: &str, row: &MetricRow) -> Option<f64> {
    if quantity.starts_with("rotation_") {
        row.value.map(f64::abs)
    } else {
        Some((row.value? - row.reference?).abs())
    }
}

/// Run the study, each engine run through `runner` (the run cache, or
/// [`crate::compare::run_engine`]). `progress` is called with each finished run.
pub fn converge(
    scene_path: &Path,
    opts: &ConvergeOptions,
    runner: &Runner,
    progress: &dyn Fn(&ConvergeRun),
) -> Result<Convergence, String> {
    let base = load_scene_with_overrides(scene_path, &opts.overrides).map_err(|e| e.to_string())?;
    crate::bench::check_engines_and_steps(&base, &opts.engines, &opts.dts)?;
    crate::bench::check_series_sets(&opts.engines, &opts.overrides, false)?;
    if let ConvergeReference::Common(spec) = &opts.reference {
        crate::bench::check_reference_outside(
            &opts.engines,
            spec,
            "or `self` (each engine's finest run)",
        )?;
    }
    let common = match &opts.reference {
        ConvergeReference::Common(spec) => Some(reference_run(spec, &base, runner)?),
        ConvergeReference::Finest => None,
    };
    let labels: Vec<String> = series_of(&base)
        .into_iter()
        .filter(|s| s.measured)
        .map(|s| s.label)
        .collect();
    let mut dts = opts.dts.clone();
    dts.sort_by(|a, b| b.total_cmp(a)); // coarsest first; the finest is last
    let mut runs = Vec::new();
    let mut points = Vec::new();
    for engine in &opts.engines {
        let Some(key) = step_setting(engine) else {
            let r = ConvergeRun {
                engine: engine.clone(),
                dt: f64::NAN,
                status: "skipped".into(),
                reason: Some("the engine has no step size".into()),
                wall_time_s: None,
                steps: None,
                engine_version: None,
                settings: None,
                cached: false,
            };
            progress(&r);
            runs.push(r);
            continue;
        };
        let mut done: Vec<(f64, Run)> = Vec::new();
        for &dt in &dts {
            let mut set = opts.overrides.clone();
            set.push(format!("{key}={dt:e}"));
            let mut r = ConvergeRun {
                engine: engine.clone(),
                dt,
                status: "ok".into(),
                reason: None,
                wall_time_s: None,
                steps: None,
                engine_version: None,
                settings: None,
                cached: false,
            };
            match load_scene_with_overrides(scene_path, &set) {
                Ok(scene) => {
                    let run = runner(engine, &scene);
                    r.cached = run.cached;
                    match (&run.status, &run.output, &run.summary) {
                        (Status::Ok, Some(out), Some(s)) => {
                            r.wall_time_s = Some(s.wall_time_s);
                            r.steps = Some(s.steps);
                            r.engine_version = Some(s.engine_version.clone());
                            r.settings = Some(s.settings.clone());
                            done.push((dt, run_of(engine, out, s)));
                        }
                        (status, ..) => {
                            r.status = match status {
                                Status::Ok => "failed",
                                other => other.word(),
                            }
                            .into();
                            r.reason = Some(
                                status
                                    .reason()
                                    .unwrap_or("the run gave no output")
                                    .replace('\n', " "),
                            );
                        }
                    }
                }
                Err(e) => {
                    r.status = "failed".into();
                    r.reason = Some(e.to_string().replace('\n', " "));
                }
            }
            progress(&r);
            runs.push(r);
        }
        // The reference of this engine's runs.
        let Some((finest_dt, finest)) = done.last() else {
            continue;
        };
        for (dt, run) in &done {
            let (reference, is_reference) = match &common {
                Some(c) => (c, false),
                None => (finest, dt == finest_dt),
            };
            let settings = MetricSettings::default().on_samples_of(run, reference);
            let rows = match compare_runs(&base, run, reference, &settings) {
                Ok(rows) => rows,
                Err(e) => {
                    if let Some(r) = runs.iter_mut().find(|r| &r.engine == engine && r.dt == *dt) {
                        r.status = "failed".into();
                        r.reason = Some(format!("metrics: {e}"));
                    }
                    continue;
                }
            };
            for label in &labels {
                for (q, _, _) in QUANTITIES {
                    let row = rows.iter().find(|m| m.metric == q && &m.block == label);
                    points.push(ConvergePoint {
                        engine: engine.clone(),
                        dt: *dt,
                        series: label.clone(),
                        quantity: q.to_string(),
                        value: row.and_then(|m| m.value),
                        reference: row.and_then(|m| m.reference),
                        error: if is_reference {
                            None
                        } else {
                            row.and_then(|m| error_of(q, m))
                        },
                    });
                }
            }
        }
    }
    let mut orders = Vec::new();
    for engine in &opts.engines {
        for label in &labels {
            for (q, _, _) in QUANTITIES {
                let mine: Vec<&ConvergePoint> = points
                    .iter()
                    .filter(|p| &p.engine == engine && &p.series == label && p.quantity == q)
                    .collect();
                if mine.is_empty() {
                    continue;
                }
                let pairs: Vec<(f64, f64)> =
                    mine.iter().filter_map(|p| Some((p.dt, p.error?))).collect();
                let (order, std_error, range) = observed_order(&pairs);
                orders.push(Order {
                    engine: engine.clone(),
                    series: label.clone(),
                    quantity: q.to_string(),
                    points: pairs.iter().filter(|p| p.1 > 0.0).count(),
                    order,
                    std_error,
                    local_min: range.map(|r| r.0),
                    local_max: range.map(|r| r.1),
                });
            }
        }
    }
    Ok(Convergence {
        scene: base.name.clone(),
        reference: opts.reference.label(),
        runs,
        points,
        orders,
    })
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.6e}")).unwrap_or_default()
}

fn order_cell(o: &Order) -> String {
    match o.order {
        None => "n/a".into(),
        Some(v) => {
            let mut s = format!("{v:.2}");
            if let Some(e) = o.std_error {
                let _ = write!(s, " ± {e:.2}");
            }
            if let (Some(lo), Some(hi)) = (o.local_min, o.local_max) {
                let _ = write!(s, " [{lo:.2}, {hi:.2}]");
            }
            s
        }
    }
}

/// `converge.csv`, `orders.csv`, `converge.json`, `converge.md` and one log-log SVG per
/// quantity (`converge-<quantity>.svg`).
pub fn write(dir: &Path, c: &Convergence, command: &str) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let w = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text)
            .map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    let mut csv = String::from("scene,engine,dt,series,quantity,value,reference,error\n");
    for p in &c.points {
        let _ = writeln!(
            csv,
            "{},{},{:e},{},{},{},{},{}",
            c.scene,
            p.engine,
            p.dt,
            p.series,
            p.quantity,
            opt(p.value),
            opt(p.reference),
            opt(p.error)
        );
    }
    w("converge.csv", &csv)?;
    let mut ocsv =
        String::from("scene,engine,series,quantity,points,order,std_error,local_min,local_max\n");
    for o in &c.orders {
        let f = |x: Option<f64>| x.map(|v| format!("{v:.4}")).unwrap_or_default();
        let _ = writeln!(
            ocsv,
            "{},{},{},{},{},{},{},{},{}",
            c.scene,
            o.engine,
            o.series,
            o.quantity,
            o.points,
            f(o.order),
            f(o.std_error),
            f(o.local_min),
            f(o.local_max)
        );
    }
    w("orders.csv", &ocsv)?;
    let json = serde_json::json!({
        "rockbench_version": env!("CARGO_PKG_VERSION"),
        "command": command,
        "provenance": crate::report::provenance::Provenance::collect(command),
        "convergence": c,
    });
    w(
        "converge.json",
        &(serde_json::to_string_pretty(&json).expect("serialises") + "\n"),
    )?;
    w("converge.md", &markdown(c, command))?;
    for (q, what, unit) in QUANTITIES {
        w(
            &format!("converge-{q}.svg"),
            &plot(c, q, what, unit).render(),
        )?;
    }
    Ok(())
}

/// The Markdown summary: observed orders, then the errors at every step size, then the runs.
pub fn markdown(c: &Convergence, command: &str) -> String {
    let mut md = format!(
        "# Observed order of accuracy: {}\n\nReference: {}. Order: least-squares slope of ln(error) against ln(dt) ± its standard error [smallest, largest local order between consecutive step sizes]. Command: `{command}`\n\n",
        c.scene, c.reference
    );
    md += "## Observed orders\n\n| engine | series |";
    for (_, what, _) in QUANTITIES {
        let _ = write!(md, " {what} |");
    }
    md += "\n|---|---|";
    md += &"---|".repeat(QUANTITIES.len());
    md += "\n";
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for o in &c.orders {
        if !keys.contains(&(o.engine.as_str(), o.series.as_str())) {
            keys.push((o.engine.as_str(), o.series.as_str()));
        }
    }
    for (e, s) in &keys {
        let _ = write!(md, "| {e} | {s} |");
        for (q, _, _) in QUANTITIES {
            let cell = c
                .orders
                .iter()
                .find(|o| o.engine == *e && o.series == *s && o.quantity == q)
                .map(order_cell)
                .unwrap_or_default();
            let _ = write!(md, " {cell} |");
        }
        md += "\n";
    }
    md += "\n## Errors\n\n| engine | dt (s) | series |";
    for (_, what, unit) in QUANTITIES {
        let _ = write!(md, " {what} ({unit}) |");
    }
    md += "\n|---|---|---|";
    md += &"---|".repeat(QUANTITIES.len());
    md += "\n";
    let mut rows: Vec<(&str, f64, &str)> = Vec::new();
    for p in &c.points {
        let k = (p.engine.as_str(), p.dt, p.series.as_str());
        if !rows.contains(&k) {
            rows.push(k);
        }
    }
    for (e, dt, s) in rows {
        let _ = write!(md, "| {e} | {dt:e} | {s} |");
        for (q, _, _) in QUANTITIES {
            let cell = c
                .points
                .iter()
                .find(|p| p.engine == e && p.dt == dt && p.series == s && p.quantity == q)
                .map(|p| match (p.error, p.value) {
                    (Some(err), _) => format!("{err:.3e}"),
                    (None, Some(_)) => "reference".into(),
                    (None, None) => "n/a".into(),
                })
                .unwrap_or_default();
            let _ = write!(md, " {cell} |");
        }
        md += "\n";
    }
    md += "\n## Runs\n\n| engine | dt (s) | status | wall (s) | steps |\n|---|---|---|---|---|\n";
    // A run read back from the run cache shows the wall time of the run that made it.
    for r in &c.runs {
        let _ = writeln!(
            md,
            "| {} | {} | {}{} | {} | {} |",
            r.engine,
            r.dt_label(),
            r.status,
            r.reason
                .as_ref()
                .map(|x| format!(": {x}"))
                .unwrap_or_default(),
            r.wall_time_s
                .map(|w| format!("{w:.4}{}", if r.cached { " (cached)" } else { "" }))
                .unwrap_or_default(),
            r.steps.map(|s| s.to_string()).unwrap_or_default()
        );
    }
    md
}

/// Log-log plot of one quantity's error against dt, a line per engine and series.
pub fn plot(c: &Convergence, quantity: &str, what: &str, unit: &str) -> Plot {
    let palette = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
    ];
    let mut plot = Plot {
        title: format!("Convergence: error of the {what}"),
        x_label: "log10 dt (s)".into(),
        y_label: format!("log10 error ({unit})"),
        ..Default::default()
    };
    for (i, o) in c
        .orders
        .iter()
        .filter(|o| o.quantity == quantity)
        .enumerate()
    {
        let pts: Vec<(f64, f64)> = c
            .points
            .iter()
            .filter(|p| p.engine == o.engine && p.series == o.series && p.quantity == quantity)
            .filter_map(|p| Some((p.dt, p.error?)))
            .filter(|(_, e)| *e > 0.0)
            .map(|(d, e)| (d.log10(), e.log10()))
            .collect();
        if pts.is_empty() {
            continue;
        }
        let order = o
            .order
            .map(|v| format!(" (order {v:.2})"))
            .unwrap_or_default();
        plot.curves.push(Curve {
            name: format!("{} {}{order}", o.engine, o.series),
            color: palette[i % palette.len()].into(),
            dashed: false,
            x: pts.iter().map(|p| p.0).collect(),
            y: pts.iter().map(|p| p.1).collect(),
        });
    }
    plot
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observed_order_of_a_power_law_is_its_exponent() {
        let pairs: Vec<(f64, f64)> = [2e-3, 1e-3, 5e-4, 2.5e-4]
            .iter()
            .map(|&d: &f64| (d, 3.0 * d.powi(2)))
            .collect();
        let (order, se, range) = observed_order(&pairs);
        assert!((order.unwrap() - 2.0).abs() < 1e-12);
        assert!(se.unwrap() < 1e-10);
        let (lo, hi) = range.unwrap();
        assert!((lo - 2.0).abs() < 1e-12 && (hi - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_scattered_series_reports_its_spread_and_zero_errors_are_left_out() {
        // Errors 1, 0.6, 0.1 at dt 4, 2, 1: local orders ln(1/0.6)/ln 2 and ln 6/ln 2.
        let pairs = [(4.0, 1.0), (2.0, 0.6), (1.0, 0.1), (0.5, 0.0)];
        let (order, se, range) = observed_order(&pairs);
        let (lo, hi) = range.unwrap();
        assert!((lo - (1.0f64 / 0.6).ln() / 2f64.ln()).abs() < 1e-12);
        assert!((hi - 6f64.ln() / 2f64.ln()).abs() < 1e-12);
        assert!(order.unwrap() > lo && order.unwrap() < hi);
        assert!(se.unwrap() > 0.1);
        assert_eq!(observed_order(&[(1.0, 1.0)]), (None, None, None));
    }
}
