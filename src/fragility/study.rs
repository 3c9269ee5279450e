//! The study file (`rockbench fragility STUDY.toml`): scenes, a record suite, intensity
//! levels, engines, limit states and methods. Read and checked completely (every scene, the
//! suite and each of its records) before anything runs; a problem is one line
//! `file: field: problem`. The format is in docs/fragility.md.

use crate::engines::engine_by_name;
use crate::excitation::suite::{Suite, load_suite};
use crate::scene::{Scene, SceneError, load_scene, num};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Intensity measures. A rigid block has no period: no spectral measure is offered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Measure {
    /// Peak ground acceleration, g.
    Pga,
    /// Peak ground velocity, m/s.
    Pgv,
    /// PGA / (g tan alpha), dimensionless.
    PgaRatio,
    /// PGV p / (g tan alpha), dimensionless.
    PgvRatio,
    /// The FEMA P695 scale factor: the record times its normalisation factor times the level.
    P695,
}

impl Measure {
    pub fn name(self) -> &'static str {
        match self {
            Measure::Pga => "pga",
            Measure::Pgv => "pgv",
            Measure::PgaRatio => "pga-ratio",
            Measure::PgvRatio => "pgv-ratio",
            Measure::P695 => "p695",
        }
    }
    pub fn label(self) -> &'static str {
        match self {
            Measure::Pga => "PGA (g)",
            Measure::Pgv => "PGV (m/s)",
            Measure::PgaRatio => "PGA / (g tan alpha)",
            Measure::PgvRatio => "PGV p / (g tan alpha)",
            Measure::P695 => "P695 scale factor (normalised record x level)",
        }
    }
}

/// Limit-state kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LimitKind {
    /// max |phi| / alpha of any block (rotation relative to its support) reaches `threshold`.
    Rotation,
    /// max |phi| / alpha of the named `block` relative to the block it stands on.
    RelativeRotation,
    /// Residual sliding of any block relative to its support reaches `threshold` metres.
    Sliding,
    /// A block overturns.
    Overturn,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LimitState {
    pub name: String,
    pub kind: LimitKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<String>,
}

impl IntensitySpec {
    /// The lowest and the highest stripe level.
    pub fn range(&self) -> (f64, f64) {
        let lowest = self.levels.iter().copied().fold(f64::INFINITY, f64::min);
        let highest = self.levels.iter().copied().fold(0.0, f64::max);
        (lowest, highest)
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntensitySpec {
    pub measure: Measure,
    /// The stripes' levels, in the measure's unit.
    pub levels: Vec<f64>,
    /// The block whose p and alpha make the dimensionless measures (default: the bottom one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<String>,
}

fn d_true() -> bool {
    true
}
fn d_factor() -> f64 {
    2.0
}
fn d_tol() -> f64 {
    0.05
}
/// The most levels an IDA fills in below its bracket.
pub const MAX_FILL: usize = 100;
/// The most steps of an IDA hunt from its start to its highest level.
const MAX_HUNT_STEPS: f64 = 200.0;

/// The strongest scaled record a study may run, in g: a scene's ([`crate::scene::MAX_PEAK_G`]).
pub use crate::scene::MAX_PEAK_G;

fn d_fill() -> usize {
    3
}
fn d_boot() -> usize {
    1000
}
fn d_seed() -> u64 {
    1
}
fn d_tail() -> f64 {
    5.0
}

/// IDA by hunt and fill (per record and limit state).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdaSpec {
    /// First level of the hunt (default: the lowest stripe level).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<f64>,
    /// The hunt multiplies the level by this until the limit state is exceeded.
    #[serde(default = "d_factor")]
    pub factor: f64,
    /// Bisection (geometric) until hi/lo - 1 is below this.
    #[serde(default = "d_tol")]
    pub tolerance: f64,
    /// Highest level tried (default: the highest stripe level); a record that does not reach
    /// the limit state there is censored at it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// Levels run (geometrically spaced) below the bracket to catch resurrection.
    #[serde(default = "d_fill")]
    pub fill: usize,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSpec {
    /// Bootstrap resamples (over record pairs) of the 95 % intervals.
    #[serde(default = "d_boot")]
    pub bootstrap: usize,
    #[serde(default = "d_seed")]
    pub seed: u64,
}

impl Default for FitSpec {
    fn default() -> Self {
        FitSpec {
            bootstrap: d_boot(),
            seed: d_seed(),
        }
    }
}

/// The initial state of every run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Initial {
    /// Every block upright and at rest (the scene's `[initial]` is dropped).
    #[default]
    AtRest,
    /// The scene's own initial state.
    Scene,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: String,
    pub scenes: Vec<String>,
    pub suite: String,
    pub engines: Vec<String>,
    pub intensity: IntensitySpec,
    #[serde(default, rename = "limit_state")]
    pub limit_states: Vec<LimitState>,
    /// Multiple-stripe analysis (every record at every level).
    #[serde(default = "d_true")]
    pub stripes: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ida: Option<IdaSpec>,
    #[serde(default)]
    pub fit: FitSpec,
    #[serde(default)]
    pub initial: Initial,
    /// Seconds run after the record ends (early stops end most runs sooner).
    #[serde(default = "d_tail")]
    pub tail: f64,
    /// Stop a run early when every block has overturned or all are at rest after the record.
    #[serde(default = "d_true")]
    pub early_stop: bool,
    /// The run cache folder, relative to the study file (default `.cache/rockbench/fragility`
    /// in the working directory).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache: Option<String>,
}

/// A study, read and checked.
#[derive(Debug, Clone)]
pub struct Study {
    pub file: StudyFile,
    pub path: PathBuf,
    pub scenes: Vec<Scene>,
    pub suite: Suite,
    pub limit_states: Vec<LimitState>,
    pub cache_dir: PathBuf,
}

/// The limit states when a study lists none: max |phi|/alpha of any block at 0.1 and 0.5, and
/// overturning.
pub fn default_limit_states() -> Vec<LimitState> {
    let rot = |t: f64| LimitState {
        name: format!("rotation-{t}"),
        kind: LimitKind::Rotation,
        threshold: Some(t),
        block: None,
    };
    vec![
        rot(0.1),
        rot(0.5),
        LimitState {
            name: "overturn".into(),
            kind: LimitKind::Overturn,
            threshold: None,
            block: None,
        },
    ]
}

/// Most bootstrap resamples a study may ask for (the 95 % intervals settle within a few
/// thousand; a million already holds some 20 MB of fits a curve).
pub const MAX_BOOTSTRAP: usize = 1_000_000;

/// Read and check a study and everything it names.
pub fn load_study(path: &Path) -> Result<Study, SceneError> {
    let file = path.display().to_string();
    let text = crate::input_file::read_to_string(path)
        .map_err(|e| SceneError::new(&file, "study", format!("cannot read the study: {e}")))?;
    let f: StudyFile = crate::scene::toml_fields(&file, &text, "study")?;
    let err = |field: &str, msg: String| SceneError::new(&file, field, msg);
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    if f.name.trim().is_empty() {
        return Err(err(
            "name",
            "must not be empty (it names the study's report)".into(),
        ));
    }
    if f.scenes.is_empty() {
        return Err(err("scenes", "lists no scene".into()));
    }
    if f.engines.is_empty() {
        return Err(err("engines", "lists no engine".into()));
    }
    for (k, e) in f.engines.iter().enumerate() {
        if let Err(why) = super::run::check_engine(e) {
            return Err(err(&format!("engines[{k}]"), why));
        }
        if f.engines[..k].contains(e) {
            return Err(err(
                &format!("engines[{k}]"),
                format!("`{e}` is listed twice"),
            ));
        }
    }
    if f.intensity.levels.is_empty() {
        return Err(err("intensity.levels", "lists no level".into()));
    }
    for (k, l) in f.intensity.levels.iter().enumerate() {
        if !(l.is_finite() && *l > 0.0) {
            return Err(err(
                &format!("intensity.levels[{k}]"),
                format!("an intensity level must be > 0 (got {})", num(*l)),
            ));
        }
        // A stripe run twice would count its records twice in the fit (levels a rounding
        // apart, 0.2 and 0.1 + 0.1 + ..., are the same stripe).
        if f.intensity.levels[..k]
            .iter()
            .any(|o| (o - l).abs() <= 1e-9 * o.abs().max(l.abs()))
        {
            return Err(err(
                &format!("intensity.levels[{k}]"),
                format!("{} is listed twice", num(*l)),
            ));
        }
    }
    if !(f.tail.is_finite() && f.tail >= 0.0) {
        return Err(err("tail", format!("must be >= 0 s (got {})", num(f.tail))));
    }
    if !f.stripes && f.ida.is_none() {
        return Err(err(
            "stripes",
            "false and no [ida]: the study would run nothing".into(),
        ));
    }
    if let Some(ida) = &f.ida {
        if !(ida.factor.is_finite() && ida.factor > 1.0) {
            return Err(err(
                "ida.factor",
                format!("must be > 1 (got {})", num(ida.factor)),
            ));
        }
        if !(ida.tolerance.is_finite() && ida.tolerance >= crate::spectrum::MIN_TOLERANCE) {
            return Err(err(
                "ida.tolerance",
                format!(
                    "must be at least {:e} (got {}): a narrower bracket is below the bisection's floating-point resolution",
                    crate::spectrum::MIN_TOLERANCE,
                    num(ida.tolerance)
                ),
            ));
        }
        if ida.fill > MAX_FILL {
            return Err(err(
                "ida.fill",
                format!(
                    "at most {MAX_FILL} levels below the bracket (got {}): each is a run per record and limit state",
                    ida.fill
                ),
            ));
        }
        for (name, v) in [("ida.start", ida.start), ("ida.max", ida.max)] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                return Err(err(name, format!("must be > 0 (got {})", num(v))));
            }
        }
        // The hunt starts below its highest level (each defaults to the stripes' ends).
        let (lowest, highest) = f.intensity.range();
        let (start, max) = (ida.start.unwrap_or(lowest), ida.max.unwrap_or(highest));
        if start >= max {
            let field = if ida.start.is_some() {
                "ida.start"
            } else {
                "ida.max"
            };
            return Err(err(
                field,
                format!(
                    "the hunt starts at {} and may go no higher than {}: the start must be below the highest level",
                    num(start),
                    num(max)
                ),
            ));
        }
        // Each of the hunt's steps is a run per record and limit state.
        let steps = (max / start).ln() / ida.factor.ln();
        if steps > MAX_HUNT_STEPS {
            let field = if ida.start.is_some() {
                "ida.start"
            } else {
                "ida.factor"
            };
            return Err(err(
                field,
                format!(
                    "the hunt from {} to {} by factors of {} takes {} steps; at most {MAX_HUNT_STEPS} (each is a run per record and limit state)",
                    num(start),
                    num(max),
                    num(ida.factor),
                    num(steps.ceil())
                ),
            ));
        }
    }
    if f.fit.bootstrap == 1 {
        return Err(err(
            "fit.bootstrap",
            "one resample gives no interval: use 0 or >= 2".into(),
        ));
    }
    if f.fit.bootstrap > MAX_BOOTSTRAP {
        return Err(err(
            "fit.bootstrap",
            format!(
                "at most {MAX_BOOTSTRAP} resamples (got {}): each keeps its fit in memory",
                f.fit.bootstrap
            ),
        ));
    }
    let mut scenes: Vec<Scene> = Vec::new();
    // The same file under two spellings (`scene.toml`, `./scene.toml`) is listed twice too.
    let same_file = |a: &str, b: &str| {
        a == b
            || matches!(
                (std::fs::canonicalize(base.join(a)), std::fs::canonicalize(base.join(b))),
                (Ok(x), Ok(y)) if x == y
            )
    };
    for (k, s) in f.scenes.iter().enumerate() {
        if f.scenes[..k].iter().any(|o| same_file(o, s)) {
            return Err(err(
                &format!("scenes[{k}]"),
                format!("`{s}` is listed twice"),
            ));
        }
        let p = base.join(s);
        let sc = load_scene(&p).map_err(|e| {
            err(
                &format!("scenes[{k}]"),
                format!("{}: {}: {}", e.file, e.field, e.message),
            )
        })?;
        for (j, e) in f.engines.iter().enumerate() {
            let reason = engine_by_name(e)
                .ok()
                .and_then(|engine| engine.cannot_model(&sc));
            if let Some(reason) = reason {
                return Err(err(
                    &format!("engines[{j}]"),
                    format!("`{e}` cannot run scenes[{k}] (`{}`): {reason}", sc.name),
                ));
            }
        }
        // Rows, fits and figures are keyed by the scene's name: two scenes of one name would
        // be pooled into one fit.
        if let Some(j) = scenes.iter().position(|o| o.name.trim() == sc.name.trim()) {
            return Err(err(
                &format!("scenes[{k}]"),
                format!(
                    "its scene name `{}` is also scenes[{j}]'s (`{}`): give each scene its own name",
                    sc.name, f.scenes[j]
                ),
            ));
        }
        scenes.push(sc);
    }
    let suite = load_suite(&base.join(&f.suite))
        .map_err(|e| err("suite", format!("{}: {}: {}", e.file, e.field, e.message)))?;
    if f.intensity.measure == Measure::P695
        && let Some(r) = suite.records.iter().find(|r| r.p695_factor.is_none())
    {
        return Err(err(
            "intensity.measure",
            format!(
                "p695 needs every record's p695_factor; record `{}` of the suite has none",
                r.id
            ),
        ));
    }
    if let Some(b) = &f.intensity.block
        && let Some(s) = scenes.iter().find(|s| s.index_of(b).is_none())
    {
        return Err(err(
            "intensity.block",
            format!("scene `{}` has no block `{b}`", s.name),
        ));
    }
    let limit_states = if f.limit_states.is_empty() {
        default_limit_states()
    } else {
        f.limit_states.clone()
    };
    for (k, ls) in limit_states.iter().enumerate() {
        let field = |x: &str| format!("limit_state[{k}].{x}");
        if ls.name.trim().is_empty() {
            return Err(err(&field("name"), "must not be empty".into()));
        }
        // A limit state is a column of outcomes.csv (and of the Python tables): a name of
        // another column made two columns of one name, and the tables kept the limit state's.
        if super::report::OUTCOME_COLUMNS.contains(&ls.name.trim()) {
            return Err(err(
                &field("name"),
                format!(
                    "`{}` names a column of outcomes.csv; give the limit state another name",
                    ls.name
                ),
            ));
        }
        if limit_states[..k]
            .iter()
            .any(|o| o.name.trim() == ls.name.trim())
        {
            return Err(err(
                &field("name"),
                format!("`{}` is listed twice", ls.name),
            ));
        }
        let needs_threshold = ls.kind != LimitKind::Overturn;
        match (needs_threshold, ls.threshold) {
            (true, None) => return Err(err(&field("threshold"), "missing".into())),
            (true, Some(t)) if !(t.is_finite() && t > 0.0) => {
                return Err(err(
                    &field("threshold"),
                    format!("must be > 0 (got {})", num(t)),
                ));
            }
            (false, Some(_)) => {
                return Err(err(
                    &field("threshold"),
                    "overturn takes no threshold".into(),
                ));
            }
            _ => {}
        }
        match (ls.kind, &ls.block) {
            (LimitKind::RelativeRotation, None) => {
                return Err(err(
                    &field("block"),
                    "missing: which block (e.g. \"statue\")".into(),
                ));
            }
            (LimitKind::RelativeRotation, Some(b)) => {
                for s in &scenes {
                    match s.index_of(b) {
                        None => {
                            return Err(err(
                                &field("block"),
                                format!("scene `{}` has no block `{b}`", s.name),
                            ));
                        }
                        Some(i) if s.layout().supports[i].is_none() => {
                            return Err(err(
                                &field("block"),
                                format!(
                                    "block `{b}` of scene `{}` stands on the ground, not on a pedestal",
                                    s.name
                                ),
                            ));
                        }
                        _ => {}
                    }
                }
            }
            (_, Some(_)) => {
                return Err(err(
                    &field("block"),
                    "only relative-rotation names a block".into(),
                ));
            }
            _ => {}
        }
    }
    let cache_dir = match &f.cache {
        Some(c) => base.join(c),
        None => PathBuf::from(".cache/rockbench/fragility"),
    };
    if cache_dir.exists() && !cache_dir.is_dir() {
        return Err(err(
            "cache",
            format!("{} is a file, not a folder", cache_dir.display()),
        ));
    }
    let study = Study {
        file: f,
        path: path.to_path_buf(),
        scenes,
        suite,
        limit_states,
        cache_dir,
    };
    check_extreme_runs(&study)?;
    Ok(study)
}

/// The study's extreme runs checked as scenes before any run: on each scene, under the longest
/// record and under the record scaled most, both at the highest level the study reaches (its
/// highest stripe, or the hunt's ceiling when that is higher). A run too long for the steps or
/// a scaled record that is not finite is then one line naming the tail, the record or the
/// level, where it would otherwise fail every run that reaches it.
fn check_extreme_runs(study: &Study) -> Result<(), SceneError> {
    let f = &study.file;
    let file = study.path.display().to_string();
    let (_, highest_stripe) = f.intensity.range();
    let (level, level_field) = match f.ida.as_ref().and_then(|ida| ida.max) {
        Some(max) if max > highest_stripe => (max, "ida.max".to_string()),
        _ => {
            let k = f
                .intensity
                .levels
                .iter()
                .position(|&l| l == highest_stripe)
                .unwrap_or(0);
            (highest_stripe, format!("intensity.levels[{k}]"))
        }
    };
    let records = &study.suite.records;
    for scene in &study.scenes {
        let scale =
            |r: &crate::excitation::suite::SuiteRecord| super::scale_for(study, scene, r, level);
        let longest = records
            .iter()
            .max_by(|a, b| a.duration.total_cmp(&b.duration));
        let scaled_most = records.iter().max_by(|a, b| scale(a).total_cmp(&scale(b)));
        if let Some(rec) = records
            .iter()
            .find(|r| !(r.pga.is_finite() && r.pgv.is_finite()))
        {
            return Err(SceneError::new(
                &file,
                "suite",
                format!(
                    "record `{}` ({}): its peak ground acceleration or velocity is not finite (PGA {} g, PGV {} m/s)",
                    rec.id,
                    rec.file.display(),
                    num(rec.pga),
                    num(rec.pgv)
                ),
            ));
        }
        let beyond = |peak: f64| peak.is_nan() || peak > MAX_PEAK_G;
        // A P695 factor that alone, at level 1, takes a record beyond the bound is the suite's
        // error, not the level's.
        if f.intensity.measure == Measure::P695
            && let Some((rec, factor)) = records
                .iter()
                .find_map(|r| r.p695_factor.filter(|&k| beyond(r.pga * k)).map(|k| (r, k)))
        {
            return Err(SceneError::new(
                &file,
                "suite",
                format!(
                    "record `{}`: its p695_factor {} scales its PGA of {:.4} g to {:.4e} g at level 1; at most {MAX_PEAK_G} g",
                    rec.id,
                    num(factor),
                    rec.pga,
                    rec.pga * factor
                ),
            ));
        }
        if let Some(rec) = scaled_most.filter(|r| beyond(r.pga * scale(r))) {
            return Err(SceneError::new(
                &file,
                level_field.clone(),
                format!(
                    "level {} scales record `{}` (PGA {:.4} g) by {:.4e} to a peak of {:.4e} g; at most {MAX_PEAK_G} g",
                    num(level),
                    rec.id,
                    rec.pga,
                    scale(rec),
                    rec.pga * scale(rec)
                ),
            ));
        }
        for (rec, what) in [
            (longest, "the longest record"),
            (scaled_most, "the record scaled most"),
        ] {
            let Some(rec) = rec else { continue };
            let engine = f.engines.first().map_or("native", String::as_str);
            let run = super::spec_for(study, scene, engine, rec, scale(rec)).scene;
            let Err(e) = crate::engines::registry::check(&run) else {
                continue;
            };
            // Which input the user must change: the level for an amplitude, else the longer of
            // the record and the tail.
            let field = if e.field.ends_with(".scale") {
                level_field.clone()
            } else if f.tail > rec.duration {
                "tail".to_string()
            } else {
                "suite".to_string()
            };
            return Err(SceneError::new(
                &file,
                field,
                format!(
                    "scene `{}` under {what}, `{}` ({} s, scaled x{} for level {}), with the tail of {} s: {}: {}",
                    scene.name,
                    rec.id,
                    num(rec.duration),
                    num(scale(rec)),
                    num(level),
                    num(f.tail),
                    e.field,
                    e.message
                ),
            ));
        }
    }
    Ok(())
}
