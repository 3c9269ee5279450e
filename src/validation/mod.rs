//! The validation suite: the cases of `VALIDATION.md` run on every engine, their accuracy
//! gates, and one report with a summary matrix (case x engine).
//!
//! A suite file (`validation/suite.toml`) lists the cases:
//!
//! ```toml
//! [[case]]
//! name = "housner-slender"                 # unique
//! title = "Housner's slender block"
//! description = "..."
//! reference = "housner"                    # engine name, or a trajectory.csv (relative path)
//! references = "../reference-data/housner-slender"   # optional: its reference data
//! paper = false                            # true: the paper's two-block section is built from it
//! [[case.run]]                             # one comparison per run
//! label = "default"
//! scene = "scenes/housner-slender.toml"    # relative to the suite file
//! set = []                                 # optional scene overrides
//! ```
//!
//! Gates (`rockbench::gates`) belong to the case whose run has the same scene and overrides;
//! a gate on a scene of no case is an error. Engine runs go through the gates' run cache, so the
//! comparisons of the report and the gates share them.

pub mod references;
pub mod report;

use crate::compare::{CompareOptions, Comparison, ReferenceSpec, Status, compare_with};
use crate::engines::registry::load_scene_with_overrides;
use crate::gates::{self, CacheStats, Gate, GateOptions, GateResult, Outcome};
use crate::scene::Scene;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// sha256 of the quakeio 0.1.21 wheel whose El Centro record `make records` converts.
pub const ELCENTRO_WHEEL_SHA256: &str =
    "efad0389f0ebf649e47d27296672571bb5a13806bde922e9582524032f3b5fe6";

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteRaw {
    #[serde(default)]
    case: Vec<CaseRaw>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseRaw {
    name: String,
    title: String,
    #[serde(default)]
    description: String,
    reference: String,
    #[serde(default)]
    references: Option<String>,
    #[serde(default)]
    paper: bool,
    #[serde(default)]
    run: Vec<RunRaw>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunRaw {
    label: String,
    scene: String,
    #[serde(default)]
    set: Vec<String>,
}

/// One case of the suite.
#[derive(Debug, Clone)]
pub struct Case {
    pub name: String,
    pub title: String,
    pub description: String,
    pub reference: ReferenceSpec,
    /// Its directory under `reference-data/`, if any.
    pub references: Option<PathBuf>,
    /// The paper's two-block case.
    pub paper: bool,
    pub runs: Vec<CaseRun>,
}

/// One scene (with overrides) of a case.
#[derive(Debug, Clone)]
pub struct CaseRun {
    pub label: String,
    pub scene_path: PathBuf,
    pub set: Vec<String>,
    pub scene: Scene,
}

/// A problem with the suite file: `file: field: message`.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{file}: {field}: {message}")]
pub struct SuiteError {
    pub file: String,
    pub field: String,
    pub message: String,
}

/// Read and check a suite file.
pub fn load_suite(path: &Path) -> Result<Vec<Case>, SuiteError> {
    let file = path.display().to_string();
    let err = |field: String, message: String| SuiteError {
        file: file.clone(),
        field,
        message,
    };
    let text = crate::input_file::read_to_string(path)
        .map_err(|e| err("(file)".into(), format!("cannot read: {e}")))?;
    let value: toml::Value = toml::from_str(&text).map_err(|e| {
        err(
            "(file)".into(),
            format!("invalid TOML: {}", e.message().replace('\n', " ")),
        )
    })?;
    let raw: SuiteRaw = serde_path_to_error::deserialize(value).map_err(|e| {
        err(
            e.path().to_string(),
            e.inner().message().lines().next().unwrap_or("").to_string(),
        )
    })?;
    if raw.case.is_empty() {
        return Err(err("case".into(), "no [[case]] in the file".into()));
    }
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut cases: Vec<Case> = Vec::new();
    for (i, c) in raw.case.into_iter().enumerate() {
        let at = |f: &str| format!("case[{i}] ({}).{f}", c.name);
        if c.name.trim().is_empty() || c.name.contains('/') {
            return Err(err(
                at("name"),
                "must be a non-empty name without `/`".into(),
            ));
        }
        if cases.iter().any(|x| x.name == c.name) {
            return Err(err(at("name"), "another case has this name".into()));
        }
        if c.run.is_empty() {
            return Err(err(
                at("run"),
                "a case needs at least one [[case.run]]".into(),
            ));
        }
        let reference = if c.reference.contains('/') || c.reference.ends_with(".csv") {
            let p = base.join(&c.reference);
            if !p.is_file() {
                return Err(err(
                    at("reference"),
                    format!("no trajectory file {}", p.display()),
                ));
            }
            ReferenceSpec::File(p)
        } else if crate::engines::registry::find(&c.reference).is_none() {
            return Err(err(
                at("reference"),
                crate::engines::EngineError::Unknown(c.reference.clone()).to_string(),
            ));
        } else {
            ReferenceSpec::Engine(c.reference.clone())
        };
        let references = match &c.references {
            Some(r) => {
                let p = base.join(r);
                if !p.join("PROVENANCE.md").is_file() {
                    return Err(err(
                        at("references"),
                        format!("{} has no PROVENANCE.md", p.display()),
                    ));
                }
                Some(p)
            }
            None => None,
        };
        let mut runs: Vec<CaseRun> = Vec::new();
        for (k, r) in c.run.iter().enumerate() {
            let rat = |f: &str| format!("case[{i}] ({}).run[{k}].{f}", c.name);
            if r.label.trim().is_empty() || r.label.contains('/') {
                return Err(err(
                    rat("label"),
                    "must be a non-empty label without `/`".into(),
                ));
            }
            if runs.iter().any(|x| x.label == r.label) {
                return Err(err(rat("label"), "another run of the case has it".into()));
            }
            let scene_path = base.join(&r.scene);
            let scene = load_scene_with_overrides(&scene_path, &r.set)
                .map_err(|e| err(rat("scene"), e.to_string()))?;
            runs.push(CaseRun {
                label: r.label.clone(),
                scene_path,
                set: r.set.clone(),
                scene,
            });
        }
        cases.push(Case {
            name: c.name,
            title: c.title,
            description: c.description,
            reference,
            references,
            paper: c.paper,
            runs,
        });
    }
    Ok(cases)
}

fn same_path(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// The case (index) a gate belongs to: a run of the same scene with the same overrides, in any
/// order (a key is never given twice, so their order does not matter).
pub fn case_of(cases: &[Case], g: &Gate) -> Option<usize> {
    let sorted = |set: &[String]| {
        let mut s = set.to_vec();
        s.sort();
        s
    };
    let gate_set = sorted(&g.set);
    cases.iter().position(|c| {
        c.runs
            .iter()
            .any(|r| same_path(&r.scene_path, &g.scene_path) && sorted(&r.set) == gate_set)
    })
}

/// Assign every gate to its case; a gate on a scene of no case is an error.
pub fn assign_gates(cases: &[Case], gates: &[Gate]) -> Result<Vec<usize>, String> {
    gates
        .iter()
        .map(|g| {
            case_of(cases, g).ok_or_else(|| {
                format!(
                    "gate {}: scene {} (set {:?}) is not a run of any case of the suite",
                    g.name,
                    g.scene_path.display(),
                    g.set
                )
            })
        })
        .collect()
}

/// Options of a suite run.
#[derive(Debug, Clone)]
pub struct ValidateOptions {
    pub engines: Vec<String>,
    pub cache_dir: Option<PathBuf>,
    pub jobs: usize,
    pub progress: bool,
}

/// One comparison of a case.
pub struct RunResult {
    pub label: String,
    /// Output directory of the comparison, relative to the suite's output directory.
    pub dir: String,
    pub comparison: Result<Comparison, String>,
}

/// A case's comparisons and gates.
pub struct CaseResult {
    pub case: Case,
    pub runs: Vec<RunResult>,
    pub gates: Vec<GateResult>,
}

/// One cell of the summary matrix.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// Every gate as expected (`known`: how many of them are known failures).
    Pass {
        gates: usize,
        known: usize,
        worst: Option<String>,
    },
    /// A gate failed (or a known failure passes).
    Fail { bad: usize, worst: Option<String> },
    /// The engine did not run (not built, or cannot model the case).
    Skipped(String),
    /// The engine ran but no gate checks it on this case.
    NoGate(String),
    /// The engine is the case's reference.
    Reference,
    /// The engine was not asked for.
    NotRun,
}

impl Cell {
    pub fn word(&self) -> &'static str {
        match self {
            Cell::Pass { .. } => "pass",
            Cell::Fail { .. } => "FAIL",
            Cell::Skipped(_) => "skipped",
            Cell::NoGate(_) => "no gate",
            Cell::Reference => "reference",
            Cell::NotRun => "not run",
        }
    }
}

/// The worst gate of a list: the largest checked value relative to its tolerance.
fn worst(results: &[&GateResult]) -> Option<String> {
    let ratio = |r: &GateResult| match r.checked {
        Some(q) if r.gate.tolerance > 0.0 => q / r.gate.tolerance,
        Some(q) if q > 0.0 => f64::INFINITY,
        Some(_) => 0.0,
        None => f64::INFINITY,
    };
    let w = results
        .iter()
        .filter(|r| r.outcome != Outcome::KnownFailure)
        .max_by(|a, b| ratio(a).total_cmp(&ratio(b)))?;
    Some(format!(
        "{}{}: {} (tol {})",
        w.gate.metric,
        w.block
            .as_ref()
            .map(|b| format!(" of {b}"))
            .unwrap_or_default(),
        w.checked
            .map(crate::report::num)
            .unwrap_or_else(|| "none".into()),
        crate::report::num(w.gate.tolerance)
    ))
}

impl CaseResult {
    /// The matrix cell of an engine.
    pub fn cell(&self, engine: &str) -> Cell {
        let statuses: Vec<&Status> = self
            .runs
            .iter()
            .filter_map(|r| r.comparison.as_ref().ok())
            .flat_map(|c| c.runs.iter().filter(|x| x.engine == engine))
            .map(|x| &x.status)
            .collect();
        let gates: Vec<&GateResult> = self
            .gates
            .iter()
            .filter(|g| g.gate.engine == engine)
            .collect();
        if !gates.is_empty() {
            let bad = gates.iter().filter(|g| g.outcome.is_bad()).count();
            let known = gates
                .iter()
                .filter(|g| g.outcome == Outcome::KnownFailure)
                .count();
            return if bad > 0 {
                let bads: Vec<&GateResult> = gates
                    .iter()
                    .copied()
                    .filter(|g| g.outcome.is_bad())
                    .collect();
                Cell::Fail {
                    bad,
                    worst: worst(&bads),
                }
            } else {
                Cell::Pass {
                    gates: gates.len(),
                    known,
                    worst: worst(&gates),
                }
            };
        }
        if let ReferenceSpec::Engine(e) = &self.case.reference
            && e == engine
        {
            return Cell::Reference;
        }
        if statuses.is_empty() {
            return Cell::NotRun;
        }
        if statuses.iter().all(|s| matches!(s, Status::Skipped(_))) {
            return Cell::Skipped(statuses[0].reason().unwrap_or("").to_string());
        }
        let failed = statuses
            .iter()
            .filter(|s| matches!(s, Status::Failed(_)))
            .count();
        Cell::NoGate(if failed > 0 {
            format!("{failed} of {} runs failed", statuses.len())
        } else {
            format!("ran {} scene(s)", statuses.len())
        })
    }

    pub fn is_bad(&self) -> bool {
        self.gates.iter().any(|g| g.outcome.is_bad())
    }
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect()
}

/// Run every case's comparisons (engines of `opts`, through the run cache) and the gates of
/// the engines asked for. Gates of other engines are left out.
pub fn validate(
    cases: &[Case],
    gates: &[Gate],
    opts: &ValidateOptions,
) -> Result<(Vec<CaseResult>, CacheStats), String> {
    let owner = assign_gates(cases, gates)?;
    let cache = gates::cache::RunCache::new(opts.cache_dir.clone());
    let runner = |name: &str, scene: &Scene| cache.run(name, scene);
    let mut out: Vec<CaseResult> = Vec::new();
    for c in cases {
        let mut runs = Vec::new();
        for r in &c.runs {
            let mut engines = opts.engines.clone();
            if let ReferenceSpec::Engine(e) = &c.reference
                && !engines.contains(e)
            {
                engines.push(e.clone());
            }
            let mut copts = CompareOptions::new(engines, c.reference.clone());
            copts.jobs = opts.jobs.max(1);
            copts.progress = opts.progress;
            if opts.progress {
                eprintln!("validate: {} / {}", c.name, r.label);
            }
            let cmp = compare_with(&r.scene, &copts, &runner).map_err(|e| e.to_string());
            runs.push(RunResult {
                label: r.label.clone(),
                dir: format!("{}/{}", slug(&c.name), slug(&r.label)),
                comparison: cmp,
            });
        }
        out.push(CaseResult {
            case: c.clone(),
            runs,
            gates: Vec::new(),
        });
    }
    let selected: Vec<(usize, Gate)> = gates
        .iter()
        .zip(&owner)
        .filter(|(g, _)| opts.engines.contains(&g.engine))
        .map(|(g, k)| (*k, g.clone()))
        .collect();
    let list: Vec<Gate> = selected.iter().map(|(_, g)| g.clone()).collect();
    let gopts = GateOptions {
        cache_dir: opts.cache_dir.clone(),
        jobs: opts.jobs,
        progress: opts.progress,
    };
    let (results, gstats) = gates::run_gates(&list, &gopts);
    for ((k, _), r) in selected.iter().zip(results) {
        out[*k].gates.push(r);
    }
    let s = cache.stats();
    Ok((
        out,
        CacheStats {
            hits: s.hits + gstats.hits,
            runs: s.runs + gstats.runs,
        },
    ))
}
