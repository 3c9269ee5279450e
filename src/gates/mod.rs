//! Accuracy gates: declarative checks of one metric of one engine against a reference, with
//! an expected status, evaluated from cached runs.
//!
//! A gate file (TOML) holds `[[gate]]` tables:
//!
//! ```toml
//! [[gate]]
//! name = "native-slender-first-impact"   # unique; names the gate in every message
//! scene = "scenes/housner-slender.toml"  # relative to the gate file
//! set = ["native.dt=5e-4"]               # optional scene overrides
//! engine = "native"
//! reference = "housner"                  # an engine name, or a trajectory.csv (relative path)
//! block = "block"                        # block, `lower/upper` interface or `(run)`;
//!                                        # optional when only one has this metric
//! metric = "impact_time_1"               # a metric of metrics.csv
//! tolerance = 1e-3                       # the gate passes when the checked quantity <= this
//! check = "abs-diff"                     # abs-diff: |value - reference| (default when the
//!                                        # metric has a reference value); value: |value|
//!                                        # (default otherwise: error metrics);
//!                                        # rel-diff: |value - reference| / |reference|
//! target = 3.5                           # optional: a stated number (closed form, published
//!                                        # claim) used instead of the reference's value
//! expect = "pass"                        # or "known-failure", with `reason`
//! reason = "..."
//! ```
//!
//! Runs are cached under a content hash of the scene as run (its JSON after overrides, with
//! the engine tables as written, and the contents of any record files), the engine name, the
//! rockbench version and a hash of the rockbench executable (so a rebuilt binary never
//! reuses an older build's results). A re-run of unchanged gates runs no engine. An external
//! engine's package version is only known after a run: after upgrading one, clear the cache
//! or pass `--no-cache`.

pub mod cache;
pub mod junit;

use crate::compare::{CompareOptions, EngineRun, ReferenceSpec, Status, compare_with};
use crate::engines::registry::load_scene_with_overrides;
use crate::metrics::{self, MetricRow};
use crate::scene::Scene;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One line naming the file, the gate and the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {field}: {message}")]
pub struct GateError {
    pub file: String,
    pub field: String,
    pub message: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Expect {
    Pass,
    KnownFailure,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Check {
    AbsDiff,
    Value,
    RelDiff,
}

impl Check {
    fn word(self) -> &'static str {
        match self {
            Check::AbsDiff => "|value - reference|",
            Check::Value => "|value|",
            Check::RelDiff => "|value - reference| / |reference|",
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct GateFileRaw {
    /// Other gate files whose gates come first (relative paths).
    #[serde(default)]
    include: Vec<String>,
    #[serde(default)]
    gate: Vec<GateRaw>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct GateRaw {
    name: String,
    scene: String,
    #[serde(default)]
    set: Vec<String>,
    engine: String,
    reference: String,
    #[serde(default)]
    block: Option<String>,
    metric: String,
    tolerance: f64,
    #[serde(default)]
    check: Option<Check>,
    #[serde(default)]
    target: Option<f64>,
    #[serde(default = "default_expect")]
    expect: Expect,
    #[serde(default)]
    reason: Option<String>,
}

fn default_expect() -> Expect {
    Expect::Pass
}

/// A checked gate.
#[derive(Debug, Clone)]
pub struct Gate {
    pub name: String,
    pub scene_path: PathBuf,
    pub set: Vec<String>,
    pub scene: Scene,
    pub engine: String,
    pub reference: ReferenceSpec,
    pub block: Option<String>,
    pub metric: String,
    pub tolerance: f64,
    pub check: Option<Check>,
    /// A stated number compared instead of the reference's value.
    pub target: Option<f64>,
    pub expect: Expect,
    pub reason: Option<String>,
}

/// Read and check a gate file. Every problem is one line naming the gate and the field.
/// `include = ["other.toml"]` (relative to the file) takes another file's gates first.
pub fn load_gates(path: &Path) -> Result<Vec<Gate>, GateError> {
    load_gates_nested(path, 0)
}

fn load_gates_nested(path: &Path, depth: usize) -> Result<Vec<Gate>, GateError> {
    let file = path.display().to_string();
    let err = |field: String, message: String| GateError {
        file: file.clone(),
        field,
        message,
    };
    let text = crate::input_file::read_to_string(path)
        .map_err(|e| err("(file)".into(), format!("cannot read: {e}")))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| {
        let (line, message) = crate::scene::toml_error_at(&text, &e, "(file)");
        err(line, message)
    })?;
    let raw: GateFileRaw =
        serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
            let p = e.path().to_string();
            err(
                if p == "." { "(top level)".into() } else { p },
                e.inner().message().lines().next().unwrap_or("").to_string(),
            )
        })?;
    if raw.gate.is_empty() && raw.include.is_empty() {
        return Err(err("gate".into(), "no [[gate]] in the file".into()));
    }
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut gates: Vec<Gate> = Vec::new();
    for (k, inc) in raw.include.iter().enumerate() {
        if depth >= 8 {
            return Err(err(
                format!("include[{k}]"),
                "includes nested more than 8 deep (a cycle?)".into(),
            ));
        }
        let p = base.join(inc);
        if !p.is_file() {
            return Err(err(
                format!("include[{k}]"),
                format!("no gate file {}", p.display()),
            ));
        }
        for g in load_gates_nested(&p, depth + 1)? {
            if gates.iter().any(|x| x.name.trim() == g.name.trim()) {
                return Err(err(
                    format!("include[{k}]"),
                    format!(
                        "{} gives gate `{}`, which an earlier include gives already",
                        p.display(),
                        g.name
                    ),
                ));
            }
            gates.push(g);
        }
    }
    let mut scenes: BTreeMap<(PathBuf, Vec<String>), Scene> = BTreeMap::new();
    for (i, g) in raw.gate.into_iter().enumerate() {
        let at = |f: &str| {
            if g.name.trim().is_empty() {
                format!("gate[{i}].{f}")
            } else {
                format!("gate[{i}] ({}).{f}", g.name)
            }
        };
        if g.name.trim().is_empty() {
            return Err(err(at("name"), "must not be empty".into()));
        }
        if gates.iter().any(|x| x.name.trim() == g.name.trim()) {
            return Err(err(at("name"), "another gate has this name".into()));
        }
        if g.engine.trim().is_empty() {
            return Err(err(at("engine"), "must not be empty".into()));
        }
        if crate::engines::registry::find(&g.engine).is_none() {
            return Err(err(
                at("engine"),
                crate::engines::EngineError::Unknown(g.engine.clone()).to_string(),
            ));
        }
        if !metrics::is_known_metric(&g.metric) {
            return Err(err(
                at("metric"),
                format!(
                    "`{}` is not a metric rockbench computes (see metrics.csv)",
                    g.metric
                ),
            ));
        }
        // The errors up to an impact are computed up to the first and the third.
        let up_to = metrics::MetricSettings::default().up_to_impacts;
        if let Some(k) = g
            .metric
            .split_once("_to_impact_")
            .and_then(|(_, k)| k.parse::<usize>().ok())
            && !up_to.contains(&k)
        {
            return Err(err(
                at("metric"),
                format!(
                    "`{}`: gates compute the errors up to impacts {}, not {k}",
                    g.metric,
                    up_to
                        .iter()
                        .map(|k| k.to_string())
                        .collect::<Vec<_>>()
                        .join(" and ")
                ),
            ));
        }
        if !(g.tolerance.is_finite() && g.tolerance >= 0.0) {
            return Err(err(
                at("tolerance"),
                format!(
                    "must be a finite number >= 0 (got {})",
                    crate::scene::num(g.tolerance)
                ),
            ));
        }
        if let Some(t) = g.target
            && !t.is_finite()
        {
            return Err(err(
                at("target"),
                format!("must be a finite number (got {t})"),
            ));
        }
        if g.check == Some(Check::Value) && g.target.is_some() {
            return Err(err(
                at("target"),
                "check = \"value\" compares |value| and would not use it: give abs-diff or rel-diff"
                    .into(),
            ));
        }
        if g.check == Some(Check::RelDiff) && g.target == Some(0.0) {
            return Err(err(
                at("target"),
                "check = \"rel-diff\" divides by |target|, which is 0: give abs-diff".into(),
            ));
        }
        if g.reference == g.engine {
            return Err(err(
                at("reference"),
                format!(
                    "`{}` is the gate's engine: a run compared with itself measures nothing",
                    g.engine
                ),
            ));
        }
        match (g.expect, &g.reason) {
            (Expect::KnownFailure, None) => {
                return Err(err(
                    at("reason"),
                    "a known failure must say why (reason = \"...\")".into(),
                ));
            }
            (Expect::KnownFailure, Some(r)) if r.trim().is_empty() => {
                return Err(err(at("reason"), "must not be empty".into()));
            }
            (Expect::Pass, Some(_)) => {
                return Err(err(
                    at("reason"),
                    "only a gate with expect = \"known-failure\" has a reason".into(),
                ));
            }
            _ => {}
        }
        crate::scene::check_override_keys(&g.set).map_err(|e| err(at("set"), e))?;
        let scene_path = base.join(&g.scene);
        let key = (scene_path.clone(), g.set.clone());
        let scene = match scenes.get(&key) {
            Some(s) => s.clone(),
            None => {
                let s = load_scene_with_overrides(&scene_path, &g.set)
                    .map_err(|e| err(at("scene"), e.to_string()))?;
                scenes.insert(key, s.clone());
                s
            }
        };
        if let Some(b) = &g.block {
            let labels: Vec<String> = metrics::series_of(&scene)
                .into_iter()
                .map(|s| s.label)
                .chain([metrics::RUN_ROW.to_string()])
                .collect();
            if !labels.contains(b) {
                return Err(err(
                    at("block"),
                    format!("`{b}` is not one of {}", labels.join(", ")),
                ));
            }
        }
        let reference = {
            let looks_like_file = g.reference.contains('/') || g.reference.ends_with(".csv");
            if looks_like_file {
                let p = base.join(&g.reference);
                if !p.is_file() {
                    return Err(err(
                        at("reference"),
                        format!("no trajectory file {}", p.display()),
                    ));
                }
                // Read and checked now: a reference that cannot be compared would otherwise
                // fail its gate as a result, or leave a known failure "still failing".
                crate::bench::reference_run(
                    &ReferenceSpec::File(p.clone()),
                    &scene,
                    &crate::compare::run_engine,
                )
                .map_err(|e| {
                    err(
                        at("reference"),
                        e.trim_start_matches("--reference: ").to_string(),
                    )
                })?;
                ReferenceSpec::File(p)
            } else if g.reference.trim().is_empty() {
                return Err(err(at("reference"), "must not be empty".into()));
            } else if crate::engines::registry::find(&g.reference).is_none() {
                return Err(err(
                    at("reference"),
                    crate::engines::EngineError::Unknown(g.reference.clone()).to_string(),
                ));
            } else {
                ReferenceSpec::Engine(g.reference.clone())
            }
        };
        gates.push(Gate {
            name: g.name,
            scene_path,
            set: g.set,
            scene,
            engine: g.engine,
            reference,
            block: g.block,
            metric: g.metric,
            tolerance: g.tolerance,
            check: g.check,
            target: g.target,
            expect: g.expect,
            reason: g.reason,
        });
    }
    Ok(gates)
}

/// How a gate came out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Expected to pass and passes.
    Pass,
    /// Expected to pass and fails.
    Fail,
    /// A known failure that still fails.
    KnownFailure,
    /// A known failure that now passes: reported so the gate is updated.
    UnexpectedPass,
}

impl Outcome {
    pub fn word(self) -> &'static str {
        match self {
            Outcome::Pass => "PASS",
            Outcome::Fail => "FAIL",
            Outcome::KnownFailure => "known failure",
            Outcome::UnexpectedPass => "UNEXPECTED PASS",
        }
    }
    /// Whether this outcome makes the gate run fail.
    pub fn is_bad(self) -> bool {
        matches!(self, Outcome::Fail | Outcome::UnexpectedPass)
    }
}

/// A gate's result.
#[derive(Debug, Clone)]
pub struct GateResult {
    pub gate: Gate,
    pub block: Option<String>,
    pub value: Option<f64>,
    pub reference: Option<f64>,
    pub unit: String,
    /// The quantity compared with the tolerance.
    pub checked: Option<f64>,
    pub check: Option<Check>,
    pub passed: bool,
    pub outcome: Outcome,
    /// Why it failed (or the known-failure reason), one line.
    pub message: String,
    /// Wall time of the engine run, s (0 when served from the cache).
    pub time_s: f64,
    pub cached: bool,
}

/// Options of a gate run.
#[derive(Debug, Clone)]
pub struct GateOptions {
    /// `None`: no cache.
    pub cache_dir: Option<PathBuf>,
    pub jobs: usize,
    pub progress: bool,
}

/// Counts of the run cache.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CacheStats {
    pub hits: usize,
    pub runs: usize,
}

/// Evaluate every gate; runs are shared between gates on the same scene and served from the
/// cache when unchanged.
pub fn run_gates(gates: &[Gate], opts: &GateOptions) -> (Vec<GateResult>, CacheStats) {
    let cache = cache::RunCache::new(opts.cache_dir.clone());
    // Group by (scene, overrides, reference): one comparison per group.
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for (i, g) in gates.iter().enumerate() {
        match groups.iter_mut().find(|(k, _)| {
            let h = &gates[*k];
            h.scene_path == g.scene_path && h.set == g.set && h.reference == g.reference
        }) {
            Some((_, v)) => v.push(i),
            None => groups.push((i, vec![i])),
        }
    }
    let mut results: Vec<Option<GateResult>> = vec![None; gates.len()];
    for (first, members) in &groups {
        let g0 = &gates[*first];
        let mut engines: Vec<String> = Vec::new();
        for &i in members {
            if !engines.contains(&gates[i].engine) {
                engines.push(gates[i].engine.clone());
            }
        }
        let mut copts = CompareOptions::new(engines, g0.reference.clone());
        copts.jobs = opts.jobs.max(1);
        copts.progress = opts.progress;
        let runner = |name: &str, scene: &Scene| cache.run(name, scene);
        let cmp = compare_with(&g0.scene, &copts, &runner);
        for &i in members {
            let g = &gates[i];
            results[i] = Some(match &cmp {
                Ok(c) => {
                    let run = c.runs.iter().find(|r| r.engine == g.engine);
                    evaluate(g, &c.rows, run)
                }
                Err(e) => failed(g, format!("no comparison: {e}"), None),
            });
        }
    }
    (
        results.into_iter().map(|r| r.expect("evaluated")).collect(),
        cache.stats(),
    )
}

/// A gate that could not be evaluated: a failure, the known failures too (a known failure is
/// a value beyond its tolerance; a gate whose metric is not produced, or whose engine did not
/// run, is broken, and says so).
fn failed(g: &Gate, message: String, run: Option<&EngineRun>) -> GateResult {
    let (outcome, message) = match g.expect {
        Expect::Pass => (Outcome::Fail, message),
        Expect::KnownFailure => (
            Outcome::Fail,
            format!("a known failure that cannot be evaluated: {message}"),
        ),
    };
    GateResult {
        gate: g.clone(),
        block: g.block.clone(),
        value: None,
        reference: None,
        unit: String::new(),
        checked: None,
        check: g.check,
        passed: false,
        outcome,
        message,
        time_s: run_time(run),
        cached: run.is_some_and(|r| r.cached),
    }
}

fn run_time(run: Option<&EngineRun>) -> f64 {
    match run {
        Some(r) if !r.cached => r.summary.as_ref().map(|s| s.wall_time_s).unwrap_or(0.0),
        _ => 0.0,
    }
}

fn evaluate(g: &Gate, rows: &[MetricRow], run: Option<&EngineRun>) -> GateResult {
    if let Some(r) = run
        && r.status != Status::Ok
    {
        return failed(
            g,
            format!(
                "engine {} {}: {}",
                g.engine,
                r.status.word(),
                r.status.reason().unwrap_or("")
            ),
            run,
        );
    }
    let candidates: Vec<&MetricRow> = rows
        .iter()
        .filter(|r| r.engine == g.engine && r.metric == g.metric)
        .filter(|r| g.block.as_ref().is_none_or(|b| &r.block == b))
        .collect();
    let row = match candidates.as_slice() {
        [one] => *one,
        [] => {
            // The usual cause: fewer impacts, in the run or the reference, than the index.
            let counts: Vec<String> = rows
                .iter()
                .filter(|r| r.engine == g.engine && r.metric == "impact_count")
                .filter(|r| g.block.as_ref().is_none_or(|b| &r.block == b))
                .map(|r| {
                    let count = |v: Option<f64>| v.map_or("-".into(), |v| v.to_string());
                    format!(
                        "{}: {} impacts, the reference {}",
                        r.block,
                        count(r.value),
                        count(r.reference)
                    )
                })
                .collect();
            let counts = if counts.is_empty() {
                "e.g. fewer impacts than its index".to_string()
            } else {
                format!("in the compared window, {}", counts.join("; "))
            };
            return failed(
                g,
                format!(
                    "metric {}{} not produced ({counts})",
                    g.metric,
                    g.block
                        .as_ref()
                        .map(|b| format!(" of {b}"))
                        .unwrap_or_default()
                ),
                run,
            );
        }
        many => {
            let blocks: Vec<&str> = many.iter().map(|r| r.block.as_str()).collect();
            return failed(
                g,
                format!(
                    "metric {} exists for several blocks ({}): give `block`",
                    g.metric,
                    blocks.join(", ")
                ),
                run,
            );
        }
    };
    let row = &MetricRow {
        reference: g.target.or(row.reference),
        ..row.clone()
    };
    // A quantity of both runs is compared with the reference's, present or not (a row without
    // it compares with nothing); a difference between the two is a value.
    let check = g.check.unwrap_or(
        if row.reference.is_some() || crate::metrics::is_paired_metric(&g.metric) {
            Check::AbsDiff
        } else {
            Check::Value
        },
    );
    let checked = match (check, row.value, row.reference) {
        (Check::Value, Some(v), _) => Some(v.abs()),
        (Check::AbsDiff, Some(v), Some(r)) => Some((v - r).abs()),
        (Check::AbsDiff, None, None) => Some(0.0),
        (Check::RelDiff, Some(v), Some(r)) if r != 0.0 => Some((v - r).abs() / r.abs()),
        (Check::RelDiff, None, None) => Some(0.0),
        _ => None,
    };
    let passed = checked.is_some_and(|q| q.is_finite() && q <= g.tolerance);
    let outcome = match (g.expect, passed) {
        (Expect::Pass, true) => Outcome::Pass,
        (Expect::Pass, false) => Outcome::Fail,
        (Expect::KnownFailure, false) => Outcome::KnownFailure,
        (Expect::KnownFailure, true) => Outcome::UnexpectedPass,
    };
    let shown = |x: Option<f64>| {
        x.map(|v| format!("{v:.6e}"))
            .unwrap_or_else(|| "none".into())
    };
    let message = match outcome {
        Outcome::Pass => format!("{} = {} <= {}", check.word(), shown(checked), g.tolerance),
        Outcome::Fail => format!(
            "{} = {} exceeds the tolerance {} (value {}, reference {})",
            check.word(),
            shown(checked),
            g.tolerance,
            shown(row.value),
            shown(row.reference)
        ),
        Outcome::KnownFailure => format!(
            "known failure ({}): {} = {} > {}",
            g.reason.as_deref().unwrap_or(""),
            check.word(),
            shown(checked),
            g.tolerance
        ),
        Outcome::UnexpectedPass => format!(
            "known failure now passes ({} = {} <= {}): update the gate (reason was: {})",
            check.word(),
            shown(checked),
            g.tolerance,
            g.reason.as_deref().unwrap_or("")
        ),
    };
    GateResult {
        gate: g.clone(),
        block: Some(row.block.clone()),
        value: row.value,
        reference: row.reference,
        unit: row.unit.clone(),
        checked,
        check: Some(check),
        passed,
        outcome,
        message,
        time_s: run_time(run),
        cached: run.is_some_and(|r| r.cached),
    }
}

/// The results as a text table.
pub fn table(results: &[GateResult]) -> String {
    let head = [
        "gate",
        "engine",
        "reference",
        "block",
        "metric",
        "value",
        "ref value",
        "checked",
        "tolerance",
        "expected",
        "result",
        "run",
    ];
    let f = |x: Option<f64>| x.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into());
    let rows: Vec<Vec<String>> = results
        .iter()
        .map(|r| {
            vec![
                r.gate.name.clone(),
                r.gate.engine.clone(),
                r.gate.reference_label(),
                r.block.clone().unwrap_or_else(|| "-".into()),
                r.gate.metric.clone(),
                f(r.value),
                f(r.reference),
                f(r.checked),
                format!("{:e}", r.gate.tolerance),
                match r.gate.expect {
                    Expect::Pass => "pass".into(),
                    Expect::KnownFailure => "known failure".into(),
                },
                r.outcome.word().into(),
                if r.cached {
                    "cached".into()
                } else {
                    "ran".into()
                },
            ]
        })
        .collect();
    crate::text_table::aligned(&head, &rows)
}

impl Gate {
    pub fn reference_label(&self) -> String {
        match &self.reference {
            ReferenceSpec::Engine(e) => e.clone(),
            ReferenceSpec::File(p) => p
                .file_name()
                .map(|f| f.to_string_lossy().to_string())
                .unwrap_or_default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gate of `metric` on the slender block, native against Housner.
    fn gate(metric: &str, tolerance: f64, extra: &str) -> Gate {
        let dir =
            std::env::temp_dir().join(format!("rb-gate-unit-{}-{metric}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/validation/scenes/housner-slender.toml"
        );
        let file = dir.join("gates.toml");
        std::fs::write(
            &file,
            format!(
                "[[gate]]\nname = \"g\"\nscene = \"{scene}\"\nengine = \"native\"\n\
                 reference = \"housner\"\nmetric = \"{metric}\"\ntolerance = {tolerance:e}\n{extra}"
            ),
        )
        .unwrap();
        let g = load_gates(&file).unwrap().remove(0);
        let _ = std::fs::remove_dir_all(&dir);
        g
    }

    fn row(metric: &str, value: Option<f64>, reference: Option<f64>) -> MetricRow {
        MetricRow {
            scene: "s".into(),
            engine: "native".into(),
            block: "block".into(),
            metric: metric.into(),
            value,
            reference,
            unit: "rad".into(),
        }
    }

    /// A quantity the reference does not have (its 19th peak, of 18) compares with nothing:
    /// the gate fails. It passed, the engine's value taken for a difference (1.8e-5 <= 2e-3).
    #[test]
    fn a_paired_metric_without_the_references_value_fails() {
        let g = gate("peak_amplitude_19", 2e-3, "");
        let r = evaluate(&g, &[row("peak_amplitude_19", Some(1.8e-5), None)], None);
        assert_eq!(r.outcome, Outcome::Fail, "{}", r.message);
        assert!(r.message.contains("reference none"), "{}", r.message);
        let r = evaluate(
            &g,
            &[row("peak_amplitude_19", Some(1.8e-5), Some(1.9e-5))],
            None,
        );
        assert_eq!(r.outcome, Outcome::Pass, "{}", r.message);
        // A difference of the two runs is checked as it is.
        let g = gate("rotation_rms_error", 1e-3, "");
        let r = evaluate(&g, &[row("rotation_rms_error", Some(1e-4), None)], None);
        assert_eq!(r.outcome, Outcome::Pass, "{}", r.message);
    }

    /// A known failure is a value beyond its tolerance; one that cannot be evaluated (its
    /// metric not produced) is a broken gate, and fails.
    #[test]
    fn a_known_failure_that_cannot_be_evaluated_fails() {
        let g = gate(
            "impact_time_19",
            1e-3,
            "expect = \"known-failure\"\nreason = \"the 19th impact is late\"\n",
        );
        let r = evaluate(&g, &[row("impact_time_19", Some(3.2), Some(3.0))], None);
        assert_eq!(r.outcome, Outcome::KnownFailure, "{}", r.message);
        let r = evaluate(&g, &[row("impact_count", Some(18.0), Some(18.0))], None);
        assert_eq!(r.outcome, Outcome::Fail, "{}", r.message);
        assert!(
            r.message
                .starts_with("a known failure that cannot be evaluated: metric impact_time_19"),
            "{}",
            r.message
        );
    }
}
