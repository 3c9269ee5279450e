//! Cross-validation of engines on one scene: run every engine once (in parallel where they
//! are independent), compare each with the reference ([`crate::metrics`]) and write the
//! metrics, the trajectories, the summaries and the report.
//!
//! [`compare`] returns the metric rows as data ([`Comparison::rows`]) so that other front
//! ends (the Python bindings) can wrap it; [`write_run_files`] writes the metrics, trajectories
//! and summaries, and [`crate::report::write_comparison`] those and the report. The report
//! reads a [`Comparison`]; this module does not know the report.

use crate::engines::{
    EngineError, Progress, RunOutput, engine_by_name, run_timed_reporting, write_outputs,
};
use crate::metrics::{self, Cost, MetricRow, MetricSettings, Run};
use crate::scene::Scene;
use crate::summary::Summary;
use crate::trajectory::Trajectory;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Where the reference comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ReferenceSpec {
    /// An engine run on the same scene.
    Engine(String),
    /// A `trajectory.csv` (any engine's output, or a published reference converted to it).
    File(PathBuf),
}

impl ReferenceSpec {
    /// A path to an existing file, or anything that looks like a path (contains `/` or ends
    /// in `.csv`), is a file; anything else an engine name.
    pub fn parse(s: &str) -> ReferenceSpec {
        let p = Path::new(s);
        if p.is_file() || s.contains('/') || s.ends_with(".csv") {
            ReferenceSpec::File(p.to_path_buf())
        } else {
            ReferenceSpec::Engine(s.to_string())
        }
    }

    pub fn label(&self) -> String {
        match self {
            ReferenceSpec::Engine(e) => e.clone(),
            ReferenceSpec::File(p) => p.display().to_string(),
        }
    }
}

/// What to compare, and how.
#[derive(Debug, Clone)]
pub struct CompareOptions {
    /// Engines to run, in report order.
    pub engines: Vec<String>,
    pub reference: ReferenceSpec,
    pub metrics: MetricSettings,
    /// How many engines run at once (default: the number of cores, at most 2).
    pub jobs: usize,
    /// Show a progress indicator on stderr.
    pub progress: bool,
    /// Each engine is run this many times and its wall time is the median (default 1: a
    /// single run). The trajectory is the first run's.
    pub timing_runs: usize,
}

impl CompareOptions {
    pub fn new(engines: Vec<String>, reference: ReferenceSpec) -> Self {
        CompareOptions {
            engines,
            reference,
            metrics: MetricSettings::default(),
            jobs: default_jobs(),
            progress: false,
            timing_runs: 1,
        }
    }
}

pub fn default_jobs() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 2)
}

/// Outcome of one engine.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", content = "reason", rename_all = "lowercase")]
pub enum Status {
    Ok,
    /// The engine is not available in this build, or cannot run this kind of scene.
    Skipped(String),
    /// The engine ran and failed.
    Failed(String),
    /// The engine refused the scene's settings of it: bad input (a worker engine's table,
    /// checked by its worker), which stops a comparison before anything is written.
    Refused(String),
}

impl Status {
    pub fn word(&self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Skipped(_) => "skipped",
            Status::Failed(_) => "failed",
            Status::Refused(_) => "refused",
        }
    }
    pub fn reason(&self) -> Option<&str> {
        match self {
            Status::Ok => None,
            Status::Skipped(r) | Status::Failed(r) | Status::Refused(r) => Some(r),
        }
    }
}

/// One engine's run.
#[derive(Debug, Clone)]
pub struct EngineRun {
    pub engine: String,
    pub status: Status,
    pub output: Option<RunOutput>,
    pub summary: Option<Summary>,
    /// Served from a run cache (gates).
    pub cached: bool,
}

/// A run for the metrics, from an engine's output and summary.
pub fn run_of(name: &str, out: &RunOutput, s: &Summary) -> Run {
    Run {
        name: name.to_string(),
        trajectory: out.trajectory.clone(),
        exact_impacts: out.exact_impacts.clone(),
        cost: Cost {
            wall_time_s: Some(s.wall_time_s),
            steps: Some(s.steps),
            solver_iterations: s.solver_iterations,
        },
    }
}
impl EngineRun {
    /// The run as a metrics input.
    pub fn as_run(&self) -> Option<Run> {
        Some(run_of(
            &self.engine,
            self.output.as_ref()?,
            self.summary.as_ref()?,
        ))
    }
}

/// Everything a comparison produced.
#[derive(Debug, Clone)]
pub struct Comparison {
    pub scene: Scene,
    /// Name of the reference (engine name or file path).
    pub reference: String,
    pub reference_is_file: bool,
    /// The reference as compared (absent if its engine failed).
    pub reference_run: Option<Run>,
    /// Engine runs in the order asked for (the reference engine included).
    pub runs: Vec<EngineRun>,
    /// Metrics of every engine that ran against the reference.
    pub rows: Vec<MetricRow>,
    pub settings: MetricSettings,
    /// Engines that ran but could not be compared, and why.
    pub notes: Vec<String>,
    /// How many engines ran at once.
    pub jobs: usize,
    /// Runs per engine behind each wall time (median).
    pub timing_runs: usize,
}

impl Comparison {
    /// Runs that produced a trajectory.
    pub fn ok_runs(&self) -> impl Iterator<Item = &EngineRun> {
        self.runs.iter().filter(|r| r.status == Status::Ok)
    }
}

/// Errors that stop a comparison before any engine runs.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("--engines: {0}")]
    Engines(String),
    /// An engine name that is not in the registry, with the option that gave it.
    #[error("{0}")]
    Name(String),
    #[error("--reference {file}: {message}")]
    ReferenceFile { file: String, message: String },
    #[error("reference engine `{engine}` did not run: {reason}")]
    ReferenceFailed { engine: String, reason: String },
    /// An engine's settings in the scene are bad input.
    #[error("{0}")]
    Refused(String),
}

/// How an engine is run: normally [`run_engine`]; the gates put a cache in front of it.
pub type Runner<'a> = dyn Fn(&str, &Scene) -> EngineRun + Sync + 'a;

/// Run one engine, classifying the outcome.
pub fn run_engine(name: &str, scene: &Scene) -> EngineRun {
    run_engine_reporting(name, scene, &crate::engines::go_on)
}

/// [`run_engine`] with an observer of the run's time that may stop it
/// ([`crate::engines::Progress`]).
pub fn run_engine_reporting(name: &str, scene: &Scene, progress: Progress) -> EngineRun {
    let result =
        engine_by_name(name).and_then(|e| run_timed_reporting(e.as_ref(), scene, progress));
    match result {
        Ok((out, summary)) => EngineRun {
            engine: name.to_string(),
            status: Status::Ok,
            output: Some(out),
            summary: Some(summary),
            cached: false,
        },
        Err(e) => EngineRun {
            engine: name.to_string(),
            status: classify(&e),
            output: None,
            summary: None,
            cached: false,
        },
    }
}

/// Engines not built in, and scenes an engine cannot model, are skipped; the rest failed.
pub fn classify(e: &EngineError) -> Status {
    let line = e.to_string().replace('\n', " ");
    match e {
        EngineError::Unknown(_) => Status::Skipped(format!("not available in this build: {line}")),
        EngineError::Unsupported { .. } => Status::Skipped(line),
        EngineError::Scene(_) => Status::Refused(line),
        _ => Status::Failed(line),
    }
}

/// Run the engines and compare them with the reference.
pub fn compare(scene: &Scene, opts: &CompareOptions) -> Result<Comparison, CompareError> {
    compare_with_runner(scene, opts, &run_engine)
}

/// [`compare`], its engines run by `runner` (one that a Ctrl-C can stop, in the Python
/// bindings): the engine names checked first.
pub fn compare_with_runner(
    scene: &Scene,
    opts: &CompareOptions,
    runner: &Runner<'_>,
) -> Result<Comparison, CompareError> {
    use crate::engines::registry::check_names;
    if opts.engines.is_empty() {
        return Err(CompareError::Name(
            "--engines: name at least one engine".into(),
        ));
    }
    check_names("--engines", opts.engines.iter().map(|e| e.trim())).map_err(CompareError::Name)?;
    if let ReferenceSpec::Engine(r) = &opts.reference {
        check_names("--reference", [r.as_str()]).map_err(CompareError::Name)?;
    }
    compare_with(scene, opts, runner)
}

/// [`compare`] with a given way of running an engine.
pub fn compare_with(
    scene: &Scene,
    opts: &CompareOptions,
    runner: &Runner<'_>,
) -> Result<Comparison, CompareError> {
    let mut names: Vec<String> = Vec::new();
    for e in &opts.engines {
        let e = e.trim();
        if e.is_empty() {
            return Err(CompareError::Engines("an empty engine name".into()));
        }
        if !names.iter().any(|n| n == e) {
            names.push(e.to_string());
        }
    }
    if let ReferenceSpec::Engine(r) = &opts.reference
        && !names.contains(r)
    {
        names.push(r.clone());
    }
    if names.is_empty() {
        return Err(CompareError::Engines("no engine given".into()));
    }
    // A reference file is read (and checked) before any engine runs.
    let file_ref = match &opts.reference {
        ReferenceSpec::File(p) => {
            let err = |message: String| CompareError::ReferenceFile {
                file: p.display().to_string(),
                message,
            };
            // The messages name the file; `err` names it once.
            let prefix = format!("{}: ", p.display());
            let unprefixed = |m: String| m.strip_prefix(&prefix).unwrap_or(&m).to_string();
            let tr = Trajectory::read_csv(p).map_err(|m| err(unprefixed(m)))?;
            let run = Run {
                name: p.display().to_string(),
                trajectory: tr,
                exact_impacts: None,
                cost: Cost::default(),
            };
            metrics::check_reference_file(scene, &run)
                .map_err(|e| err(unprefixed(e.to_string())))?;
            Some(run)
        }
        ReferenceSpec::Engine(_) => None,
    };

    let runs = run_all(scene, &names, opts, runner);
    if let Some(reason) = runs.iter().find_map(|r| match &r.status {
        Status::Refused(reason) => Some(reason),
        _ => None,
    }) {
        return Err(CompareError::Refused(reason.clone()));
    }
    // One motion for every engine: a record file changed between two engines' runs (each run
    // checks its own) would compare runs of two motions.
    let mut read = runs
        .iter()
        .filter_map(|r| r.summary.as_ref().map(|s| (&r.engine, &s.record_sha256)));
    if let Some((first, records)) = read.next()
        && let Some((other, _)) = read.find(|(_, r)| *r != records)
    {
        return Err(CompareError::Refused(format!(
            "the record files changed between the {first} and {other} runs: compare again"
        )));
    }

    let (reference_run, reference) = match &opts.reference {
        ReferenceSpec::File(p) => (file_ref, p.display().to_string()),
        ReferenceSpec::Engine(r) => {
            let er = runs.iter().find(|x| &x.engine == r).expect("reference ran");
            if let Some(reason) = er.status.reason() {
                return Err(CompareError::ReferenceFailed {
                    engine: r.clone(),
                    reason: reason.to_string(),
                });
            }
            (er.as_run(), r.clone())
        }
    };
    let reference_run = reference_run.expect("reference available");
    let mut rows = Vec::new();
    let mut notes = Vec::new();
    for er in &runs {
        if matches!(&opts.reference, ReferenceSpec::Engine(r) if *r == er.engine) {
            continue;
        }
        let Some(run) = er.as_run() else { continue };
        match metrics::compare_runs(scene, &run, &reference_run, &opts.metrics) {
            Ok(r) => rows.extend(r),
            Err(e) => notes.push(format!("{}: not compared: {e}", er.engine)),
        }
    }
    Ok(Comparison {
        scene: scene.clone(),
        reference,
        reference_is_file: matches!(opts.reference, ReferenceSpec::File(_)),
        reference_run: Some(reference_run),
        runs,
        rows,
        settings: opts.metrics.clone(),
        notes,
        jobs: opts.jobs.max(1),
        timing_runs: opts.timing_runs.max(1),
    })
}

/// Run every engine, `opts.jobs` at a time, with a progress indicator.
fn run_all(
    scene: &Scene,
    names: &[String],
    opts: &CompareOptions,
    runner: &Runner<'_>,
) -> Vec<EngineRun> {
    let bar = if opts.progress {
        let pb = indicatif::ProgressBar::new(names.len() as u64);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:24} {pos}/{len} engines  {msg}",
            )
            .expect("valid template"),
        );
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
        pb
    } else {
        indicatif::ProgressBar::hidden()
    };
    let next = Mutex::new(0usize);
    let running: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let results: Mutex<Vec<Option<EngineRun>>> = Mutex::new(vec![None; names.len()]);
    let jobs = opts.jobs.clamp(1, names.len().max(1));
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| {
                loop {
                    let i = {
                        let mut n = next.lock().expect("lock");
                        if *n >= names.len() {
                            break;
                        }
                        *n += 1;
                        *n - 1
                    };
                    let name = &names[i];
                    {
                        let mut r = running.lock().expect("lock");
                        r.push(name.clone());
                        bar.set_message(format!("running {}", r.join(", ")));
                    }
                    let mut er = runner(name, scene);
                    if opts.timing_runs > 1 && !er.cached {
                        median_wall_time(&mut er, scene, opts.timing_runs);
                    }
                    {
                        let mut r = running.lock().expect("lock");
                        r.retain(|x| x != name);
                        let line = match (&er.status, &er.summary) {
                            (Status::Ok, Some(s)) => format!(
                                "{name}: ok, {} steps, {:.2} s wall{}",
                                s.steps,
                                s.wall_time_s,
                                if er.cached { " (cached)" } else { "" }
                            ),
                            (st, _) => {
                                format!("{name}: {}: {}", st.word(), st.reason().unwrap_or(""))
                            }
                        };
                        // After a Ctrl-C the runs are stopped or not run: the command says so once.
                        if opts.progress && !crate::interrupt::requested() {
                            bar.suspend(|| eprintln!("{line}"));
                        }
                        bar.inc(1);
                        bar.set_message(if r.is_empty() {
                            String::new()
                        } else {
                            format!("running {}", r.join(", "))
                        });
                    }
                    results.lock().expect("lock")[i] = Some(er);
                }
            });
        }
    });
    bar.finish_and_clear();
    results
        .into_inner()
        .expect("lock")
        .into_iter()
        .map(|r| r.expect("every engine ran"))
        .collect()
}

/// Re-run a successful engine `n - 1` more times and record the median wall time.
fn median_wall_time(er: &mut EngineRun, scene: &Scene, n: usize) {
    let Some(first) = er.summary.as_ref().map(|s| s.wall_time_s) else {
        return;
    };
    let Ok(engine) = engine_by_name(&er.engine) else {
        return;
    };
    let mut walls = vec![first];
    for _ in 1..n {
        match run_timed_reporting(
            engine.as_ref(),
            scene,
            &crate::interrupt::go_on_unless_interrupted,
        ) {
            Ok((_, s)) => walls.push(s.wall_time_s),
            Err(_) => return,
        }
    }
    walls.sort_by(f64::total_cmp);
    let m = walls.len();
    let median = if m % 2 == 1 {
        walls[m / 2]
    } else {
        0.5 * (walls[m / 2 - 1] + walls[m / 2])
    };
    if let Some(s) = er.summary.as_mut() {
        s.wall_time_s = median;
        s.notes.push(format!(
            "wall time: median of {m} runs (min {:.4} s, max {:.4} s)",
            walls[0],
            walls[m - 1]
        ));
    }
}

/// `metrics.json`: the rows with the runs and settings behind them.
#[derive(Serialize)]
struct MetricsJson<'a> {
    scene: &'a str,
    scene_file: &'a str,
    reference: &'a str,
    settings: &'a MetricSettings,
    runs: Vec<RunJson<'a>>,
    notes: &'a [String],
    rows: &'a [MetricRow],
}

#[derive(Serialize)]
struct RunJson<'a> {
    engine: &'a str,
    #[serde(flatten)]
    status: &'a Status,
    engine_version: Option<&'a str>,
    wall_time_s: Option<f64>,
    steps: Option<u64>,
}

/// Write `metrics.csv` (long format).
pub fn write_metrics_csv(path: &Path, rows: &[MetricRow]) -> std::io::Result<()> {
    let mut w = csv::Writer::from_path(path)?;
    w.write_record([
        "scene",
        "engine",
        "block",
        "metric",
        "value",
        "reference",
        "unit",
    ])?;
    // Whole numbers (counts, steps) as integers; everything else in shortest round-trip form.
    let f = |x: Option<f64>| {
        x.map(|v| {
            if v.fract() == 0.0 && v.abs() < 1e15 {
                format!("{}", v as i64)
            } else {
                format!("{v:e}")
            }
        })
        .unwrap_or_default()
    };
    for r in rows {
        w.write_record([
            r.scene.as_str(),
            &r.engine,
            &r.block,
            &r.metric,
            &f(r.value),
            &f(r.reference),
            &r.unit,
        ])?;
    }
    w.flush()
}

/// Write the data files of a comparison into `dir`: `metrics.csv`, `metrics.json`,
/// `<engine>/trajectory.csv`, `<engine>/summary.json` and `<engine>/scene.json` for every engine
/// that ran (the report
/// is [`crate::report::write_comparison`]).
pub fn write_run_files(dir: &Path, c: &Comparison, command: &str) -> Result<(), String> {
    let io = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    for er in c.ok_runs() {
        if let (Some(out), Some(s)) = (&er.output, &er.summary) {
            let mut s = s.clone();
            s.command = Some(command.to_string());
            write_outputs(&dir.join(&er.engine), &c.scene, out, &s).map_err(|e| e.to_string())?;
        }
    }
    let p = dir.join("metrics.csv");
    write_metrics_csv(&p, &c.rows).map_err(|e| io(&p, e))?;
    let runs = c
        .runs
        .iter()
        .map(|r| RunJson {
            engine: &r.engine,
            status: &r.status,
            engine_version: r.summary.as_ref().map(|s| s.engine_version.as_str()),
            wall_time_s: r.summary.as_ref().map(|s| s.wall_time_s),
            steps: r.summary.as_ref().map(|s| s.steps),
        })
        .collect();
    let json = MetricsJson {
        scene: &c.scene.name,
        scene_file: &c.scene.source,
        reference: &c.reference,
        settings: &c.settings,
        runs,
        notes: &c.notes,
        rows: &c.rows,
    };
    let p = dir.join("metrics.json");
    std::fs::write(
        &p,
        serde_json::to_string_pretty(&json).expect("metrics serialise") + "\n",
    )
    .map_err(|e| io(&p, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    const SLENDER: &str = "name = \"s\"\nduration = 2.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n";

    fn scene() -> Scene {
        parse_scene_str(SLENDER, false, "s.toml", &[]).unwrap()
    }

    /// A runner in which engine `failing` fails, "diverged at step 7", and the others run.
    fn failing_runner(failing: &'static str) -> impl Fn(&str, &Scene) -> EngineRun + Sync {
        move |name: &str, sc: &Scene| {
            if name == failing {
                EngineRun {
                    engine: name.into(),
                    status: classify(&EngineError::Failed {
                        engine: failing,
                        message: "diverged at step 7".into(),
                    }),
                    output: None,
                    summary: None,
                    cached: false,
                }
            } else {
                run_engine(name, sc)
            }
        }
    }

    #[test]
    fn failing_and_unknown_engines_are_listed_and_the_rest_compared() {
        // `broken` fails; `nosuch` is not an engine at all.
        let runner = failing_runner("broken");
        let opts = CompareOptions::new(
            vec!["broken".into(), "nosuch".into(), "housner".into()],
            ReferenceSpec::Engine("housner".into()),
        );
        let c = compare_with(&scene(), &opts, &runner).unwrap();
        let st = |e: &str| {
            c.runs
                .iter()
                .find(|r| r.engine == e)
                .unwrap()
                .status
                .clone()
        };
        assert!(matches!(st("broken"), Status::Failed(r) if r.contains("diverged at step 7")));
        assert!(matches!(st("nosuch"), Status::Skipped(r) if r.contains("not available")));
        assert_eq!(st("housner"), Status::Ok);
        // Nothing but the reference ran, so there are no rows, and the summary says why.
        assert!(c.rows.is_empty());
    }

    #[test]
    fn a_failing_reference_engine_stops_the_comparison_with_its_reason() {
        // `native` fails in this runner; `compare` itself refuses a name it does not know.
        let runner = failing_runner("native");
        let opts = CompareOptions::new(
            vec!["housner".into()],
            ReferenceSpec::Engine("native".into()),
        );
        let e = compare_with(&scene(), &opts, &runner).unwrap_err();
        assert!(
            e.to_string()
                .contains("reference engine `native` did not run")
                && e.to_string().contains("diverged at step 7"),
            "{e}"
        );
        let opts = CompareOptions::new(vec!["housner".into()], ReferenceSpec::Engine("x".into()));
        let e = compare(&scene(), &opts).unwrap_err();
        assert!(
            e.to_string().starts_with("--reference: unknown engine `x`"),
            "{e}"
        );
    }

    #[test]
    fn wall_time_is_the_median_of_the_timing_runs() {
        let mut opts = CompareOptions::new(
            vec!["housner".into(), "native".into()],
            ReferenceSpec::Engine("housner".into()),
        );
        opts.timing_runs = 3;
        let c = compare(&scene(), &opts).unwrap();
        for r in &c.runs {
            let notes = &r.summary.as_ref().unwrap().notes;
            assert!(
                notes
                    .iter()
                    .any(|n| n.starts_with("wall time: median of 3 runs")),
                "{notes:?}"
            );
        }
        // native was compared with housner: rows exist and name the engine.
        assert!(c.rows.iter().all(|r| r.engine == "native"));
        assert!(c.rows.iter().any(|r| r.metric == "impact_time_1"));
    }

    #[test]
    fn reference_spec_parsing() {
        assert_eq!(
            ReferenceSpec::parse("native"),
            ReferenceSpec::Engine("native".into())
        );
        assert!(matches!(
            ReferenceSpec::parse("out/x/trajectory.csv"),
            ReferenceSpec::File(_)
        ));
        assert!(matches!(
            ReferenceSpec::parse("ref.csv"),
            ReferenceSpec::File(_)
        ));
    }
}
