//! Fragility studies (`rockbench fragility STUDY.toml`): scenes x record suite x intensity
//! levels x engines, by multiple stripes and by IDA (hunt and fill), with fitted lognormal
//! fragility curves per engine and limit state. See docs/fragility.md.
//!
//! - [`study`]: the study file and its checks (everything is read before anything runs).
//! - [`early`]: the early stops of rapier, MuJoCo and PyBullet (the soft-contact rule).
//! - [`run`]: one run as data ([`run::RunSpec`]) -> [`run::RunOutcome`]; the one place where
//!   an engine is called.
//! - this module: scaling records to levels, the run cache, parallel runs, hunt and fill, the
//!   outcome matrix and the fits with bootstrap intervals.
//! - [`fit`]: probit and censored lognormal maximum likelihood.
//! - [`report`]: CSV, JSON, the HTML report and `--paper`.

pub mod early;
pub mod fit;
pub mod report;
pub mod run;
pub mod study;

use crate::excitation::suite::SuiteRecord;
use crate::run_store;
use crate::scene::{ExcitationSpec, InitialSpec, MotionSpec, Scene};
use fit::{Lognormal, Rng};
use rayon::prelude::*;
use run::{RunOutcome, RunSpec, Stop};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use study::{Initial, LimitKind, LimitState, Measure, Study};

/// `p` and `alpha` of the block that makes the dimensionless measures: `p = sqrt(3 g / (4 R))`.
pub fn p_alpha(scene: &Scene, block: Option<&str>) -> (f64, f64) {
    let i = block.and_then(|b| scene.index_of(b)).unwrap_or(0);
    let b = &scene.blocks[i];
    let r = 0.5 * b.width.hypot(b.height);
    ((0.75 * scene.gravity / r).sqrt(), b.critical_angle())
}

/// The factor that scales a record to intensity `level`.
pub fn scale_for(study: &Study, scene: &Scene, rec: &SuiteRecord, level: f64) -> f64 {
    let (p, alpha) = p_alpha(scene, study.file.intensity.block.as_deref());
    let g_over = crate::excitation::records::STANDARD_GRAVITY / scene.gravity;
    match study.file.intensity.measure {
        Measure::Pga => level / rec.pga,
        Measure::Pgv => level / rec.pgv,
        // PGA in g: PGA / (g tan alpha) with the scene's g.
        Measure::PgaRatio => level * alpha.tan() / (rec.pga * g_over),
        Measure::PgvRatio => level * scene.gravity * alpha.tan() / (p * rec.pgv),
        Measure::P695 => level * rec.p695_factor.unwrap_or(1.0),
    }
}

/// The run of `scene` under `rec` times `scale` on `engine`.
pub fn spec_for(
    study: &Study,
    scene: &Scene,
    engine: &str,
    rec: &SuiteRecord,
    scale: f64,
) -> RunSpec {
    let mut s = scene.clone();
    let applied_as = s.applied_as();
    s.excitation = Some(ExcitationSpec {
        applied_as,
        horizontal: Some(MotionSpec::Record {
            file: rec.file.display().to_string(),
            scale,
            format: Some(rec.format),
        }),
        vertical: None,
    });
    if study.file.initial == Initial::AtRest {
        s.initial = InitialSpec::default();
    }
    s.duration = rec.duration + study.file.tail;
    s.name = format!("{} {} x{scale}", scene.name, rec.id);
    RunSpec {
        engine: engine.to_string(),
        scene: s,
        record_id: rec.id.clone(),
        record_sha256: rec.sha256.clone(),
        scale,
        early_stop: study.file.early_stop,
        python: crate::engines::external::interpreter_id(engine),
    }
}

/// The stripes' runs of a study, in the order [`run_study`] makes them (scene, engine, record,
/// level): the units of work a distributed runner hands out.
pub fn stripe_specs(study: &Study) -> Vec<RunSpec> {
    let mut out = Vec::new();
    // A study without stripes (IDA only) has no stripe runs (a cluster ran them for nothing).
    if !study.file.stripes {
        return out;
    }
    for scene in &study.scenes {
        for e in &study.file.engines {
            for r in &study.suite.records {
                for &l in &study.file.intensity.levels {
                    out.push(spec_for(study, scene, e, r, scale_for(study, scene, r, l)));
                }
            }
        }
    }
    out
}

/// Whether a run exceeds a limit state (an overturn exceeds every one).
pub fn exceeded(ls: &LimitState, scene: &Scene, o: &RunOutcome) -> bool {
    if o.any_overturned() {
        return true;
    }
    let t = ls.threshold.unwrap_or(f64::INFINITY);
    match ls.kind {
        LimitKind::Overturn => false,
        LimitKind::Rotation => o.rotation.iter().any(|&r| r >= t),
        LimitKind::RelativeRotation => {
            let i = ls
                .block
                .as_deref()
                .and_then(|b| scene.index_of(b))
                .unwrap_or(0);
            o.rotation[i] >= t
        }
        LimitKind::Sliding => o.sliding.iter().any(|s| s.is_none_or(|s| s >= t)),
    }
}

/// Which analysis a run belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    Stripes,
    Ida,
}

/// One cell of the outcome matrix.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub scene: String,
    pub engine: String,
    pub record: String,
    pub pair: String,
    pub level: f64,
    pub scale: f64,
    pub method: Method,
    pub outcome: RunOutcome,
    /// Per limit state (study order).
    pub exceeded: Vec<bool>,
    pub cached: bool,
}

/// An IDA capacity of one record.
#[derive(Debug, Clone, Serialize)]
pub struct Capacity {
    pub scene: String,
    pub engine: String,
    pub record: String,
    pub pair: String,
    pub limit_state: String,
    /// Lowest level found to exceed (or the highest level tried, when censored).
    pub capacity: f64,
    pub censored: bool,
    /// A level above an exceeding one that does not exceed.
    pub resurrection: bool,
    pub runs: usize,
}

/// A fit with its bootstrap interval.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    pub scene: String,
    pub engine: String,
    pub limit_state: String,
    pub method: Method,
    pub fit: Option<Lognormal>,
    /// Why there is no fit.
    pub problem: Option<String>,
    pub theta_ci: Option<(f64, f64)>,
    pub beta_ci: Option<(f64, f64)>,
    /// Resamples whose fit succeeded.
    pub resamples: usize,
    /// Pointwise 95 % band of the curve on [`Results::grid`].
    #[serde(skip)]
    pub band: Option<(Vec<f64>, Vec<f64>)>,
    /// The median of every resample (None where it failed), for paired differences.
    #[serde(skip)]
    pub boot_theta: Vec<Option<f64>>,
}

impl Fit {
    /// A fit whose intervals come from fewer resamples than asked: how many, and why the others
    /// are left out (a resample whose records are perfectly separated, or have too few levels
    /// between all and none, has no finite fit). The intervals are then conditional on a fit
    /// existing, narrower than the whole bootstrap's.
    pub fn resample_note(&self, asked: usize) -> Option<String> {
        (self.fit.is_some() && asked > 0 && self.resamples < asked).then(|| {
            format!(
                "intervals over {} of {asked} resamples (the others have no finite fit)",
                self.resamples
            )
        })
    }
}

/// An engine's median against the reference engine's (the first of the study), paired over
/// the same bootstrap resamples.
#[derive(Debug, Clone, Serialize)]
pub struct Difference {
    pub scene: String,
    pub limit_state: String,
    pub method: Method,
    pub engine: String,
    pub reference: String,
    /// theta_engine - theta_reference, in the measure's unit.
    pub difference: f64,
    pub difference_ci: Option<(f64, f64)>,
    /// theta_engine / theta_reference.
    pub ratio: f64,
    pub ratio_ci: Option<(f64, f64)>,
    pub resamples: usize,
}

/// Counters of a study run.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Counts {
    pub runs: usize,
    pub cached: usize,
    /// Runs made by this study run (not taken from the cache); a run that several rows share
    /// (a stripe level an IDA hunt also visits) counts once.
    pub made: usize,
    pub early_stopped: usize,
    pub wall_s: f64,
    /// Summed wall time of the runs made (not cached), s.
    pub run_wall_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Results {
    pub rows: Vec<Row>,
    pub capacities: Vec<Capacity>,
    pub fits: Vec<Fit>,
    pub differences: Vec<Difference>,
    /// The intensity grid of the curves and bands.
    pub grid: Vec<f64>,
    pub counts: Counts,
    /// Engine -> version as run.
    pub engine_versions: BTreeMap<String, String>,
}

/// The run cache and the progress line.
pub struct Runner {
    dir: PathBuf,
    pub done: AtomicUsize,
    pub cached: AtomicUsize,
    pub early: AtomicUsize,
    run_wall: Mutex<f64>,
    /// The runs this runner gave, made or read from the cache: (key, outcome), in order.
    runs: Mutex<Vec<(String, RunOutcome)>>,
    pub expected: AtomicUsize,
    start: Instant,
    last: Mutex<Instant>,
    quiet: bool,
    /// Set from outside (a Ctrl-C in the Python bindings): no run starts after it, nor after
    /// a signal caught by [`crate::interrupt::Interrupt`] (the command line), and the runs
    /// under way stop.
    stop: Arc<AtomicBool>,
}

/// What a run asked for after its study was stopped says.
pub const STOPPED: &str = "the study was stopped (its finished runs are in the cache)";

impl Runner {
    pub fn new(dir: PathBuf, quiet: bool) -> Runner {
        Runner {
            dir,
            done: AtomicUsize::new(0),
            cached: AtomicUsize::new(0),
            early: AtomicUsize::new(0),
            run_wall: Mutex::new(0.0),
            runs: Mutex::new(Vec::new()),
            expected: AtomicUsize::new(0),
            start: Instant::now(),
            last: Mutex::new(Instant::now()),
            quiet,
            stop: Arc::new(AtomicBool::new(false)),
        }
    }

    /// A runner that starts no run once `stop` is set and stops the runs under way (not
    /// stored): the study resumes from the runs stored before.
    pub fn stopped_by(mut self, stop: Arc<AtomicBool>) -> Runner {
        self.stop = stop;
        self
    }

    /// The outcome of a run: from the cache, or run and stored ([`run_store::store`]: an
    /// interrupted study leaves whole entries only).
    pub fn get(&self, spec: &RunSpec) -> Result<(RunOutcome, bool), String> {
        let key = spec.key();
        // An entry that cannot be this run's (another block count, a value not finite) is run
        // again and replaced.
        if let Some(o) = run_store::load::<RunOutcome>(&self.dir, &key)
            .filter(|o| o.fits(spec.scene.blocks.len()))
        {
            self.cached.fetch_add(1, Ordering::Relaxed);
            self.tick(o.stop);
            self.runs
                .lock()
                .expect("not poisoned")
                .push((key, o.clone()));
            return Ok((o, true));
        }
        if self.stop.load(Ordering::Relaxed) || crate::interrupt::requested() {
            return Err(STOPPED.to_string());
        }
        // The run under way stops too, and what it answered is not kept.
        let go_on = |t: f64| {
            if self.stop.load(Ordering::Relaxed) {
                std::ops::ControlFlow::Break(())
            } else {
                crate::interrupt::go_on_unless_interrupted(t)
            }
        };
        let o = run::run_one_reporting(spec, &go_on).map_err(|e| {
            format!(
                "{}: record {} x{}: {e}",
                spec.engine, spec.record_id, spec.scale
            )
        })?;
        *self.run_wall.lock().expect("not poisoned") += o.wall_s;
        // A run that cannot be stored would leave a study that cannot resume: an error.
        run_store::store(&self.dir, &key, &o).map_err(|e| format!("the run cache: {e}"))?;
        self.runs
            .lock()
            .expect("not poisoned")
            .push((key, o.clone()));
        self.tick(o.stop);
        Ok((o, false))
    }

    /// The runs given so far, made or read from the cache, (key, outcome): what a distributed
    /// task sends back, so that its results reach the client's store even when the worker's
    /// cache is not the client's.
    pub fn runs(&self) -> Vec<(String, RunOutcome)> {
        self.runs.lock().expect("not poisoned").clone()
    }

    /// Runs made (not taken from the cache) so far.
    pub fn made(&self) -> usize {
        self.done.load(Ordering::Relaxed) - self.cached.load(Ordering::Relaxed)
    }

    fn tick(&self, stop: Stop) {
        if stop != Stop::End {
            self.early.fetch_add(1, Ordering::Relaxed);
        }
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if self.quiet {
            return;
        }
        let mut last = self.last.lock().expect("not poisoned");
        if last.elapsed().as_secs_f64() < 1.0 {
            return;
        }
        *last = Instant::now();
        let el = self.start.elapsed().as_secs_f64();
        let exp = self.expected.load(Ordering::Relaxed).max(done);
        let left = el / done as f64 * (exp - done) as f64;
        eprintln!(
            "fragility: {done}/{exp} runs ({} from the cache, {} stopped early), {el:.0} s, about {left:.0} s left",
            self.cached.load(Ordering::Relaxed),
            self.early.load(Ordering::Relaxed)
        );
    }
}

/// Run a study: the stripes, then IDA, then the fits.
pub fn run_study(study: &Study, quiet: bool) -> Result<Results, String> {
    run_study_stopped_by(study, quiet, Arc::new(AtomicBool::new(false)))
}

/// [`run_study`], starting no run once `stop` is set (then an error, [`STOPPED`]).
pub fn run_study_stopped_by(
    study: &Study,
    quiet: bool,
    stop: Arc<AtomicBool>,
) -> Result<Results, String> {
    let start = Instant::now();
    let runner = Runner::new(study.cache_dir.clone(), quiet).stopped_by(stop);
    let f = &study.file;
    let levels = &f.intensity.levels;
    let recs = &study.suite.records;
    let n_ls = study.limit_states.len();
    let mut expected = 0;
    if f.stripes {
        expected += study.scenes.len() * f.engines.len() * recs.len() * levels.len();
    }
    if f.ida.is_some() {
        expected += study.scenes.len() * f.engines.len() * recs.len() * n_ls * 8;
    }
    runner.expected.store(expected, Ordering::Relaxed);
    let mut rows = Vec::new();
    if f.stripes {
        let jobs: Vec<(usize, &String, &SuiteRecord, f64)> = study
            .scenes
            .iter()
            .enumerate()
            .flat_map(|(si, _)| {
                f.engines.iter().flat_map(move |e| {
                    recs.iter()
                        .flat_map(move |r| levels.iter().map(move |&l| (si, e, r, l)))
                })
            })
            .collect();
        let out: Result<Vec<Row>, String> = jobs
            .par_iter()
            .map(|&(si, e, r, l)| {
                let scene = &study.scenes[si];
                let scale = scale_for(study, scene, r, l);
                let spec = spec_for(study, scene, e, r, scale);
                let (o, cached) = runner.get(&spec)?;
                Ok(row(
                    study,
                    scene,
                    e,
                    r,
                    l,
                    scale,
                    Method::Stripes,
                    o,
                    cached,
                ))
            })
            .collect();
        rows.extend(out?);
    }
    let mut capacities = Vec::new();
    if f.ida.is_some() {
        let jobs: Vec<(usize, &String, &SuiteRecord)> = (0..study.scenes.len())
            .flat_map(|si| {
                f.engines
                    .iter()
                    .flat_map(move |e| recs.iter().map(move |r| (si, e, r)))
            })
            .collect();
        let out: Result<Vec<IdaRecord>, String> = jobs
            .par_iter()
            .map(|&(si, e, r)| ida_record(study, &runner, si, e, r))
            .collect();
        for (r, c) in out? {
            rows.extend(r);
            capacities.extend(c);
        }
    }
    let mut engine_versions = BTreeMap::new();
    for r in &rows {
        engine_versions
            .entry(r.engine.clone())
            .or_insert_with(|| r.outcome.engine_version.clone());
    }
    let (fits, differences, grid) = fits(study, &rows, &capacities);
    let counts = Counts {
        runs: rows.len(),
        cached: runner.cached.load(Ordering::Relaxed),
        made: runner.made(),
        early_stopped: runner.early.load(Ordering::Relaxed),
        wall_s: start.elapsed().as_secs_f64(),
        run_wall_s: *runner.run_wall.lock().expect("not poisoned"),
    };
    if !quiet {
        eprintln!(
            "fragility: {} runs ({} from the cache, {} stopped early) in {:.1} s",
            counts.runs, counts.cached, counts.early_stopped, counts.wall_s
        );
    }
    Ok(Results {
        rows,
        capacities,
        fits,
        differences,
        grid,
        counts,
        engine_versions,
    })
}

/// The IDA jobs of a study, in the order [`run_study`] makes them: (scene index, engine,
/// record id), one per scene x engine x record (a job hunts and fills every limit state).
pub fn ida_jobs(study: &Study) -> Vec<(usize, String, String)> {
    if study.file.ida.is_none() {
        return Vec::new();
    }
    let mut out = Vec::new();
    for si in 0..study.scenes.len() {
        for e in &study.file.engines {
            for r in &study.suite.records {
                out.push((si, e.clone(), r.id.clone()));
            }
        }
    }
    out
}

/// IDA jobs checked against their study (jobs may come from elsewhere: a Dask task): each
/// names a scene, an engine and a record of the study, and the study has an `[ida]` table.
/// Returns each job's record.
pub fn check_ida_jobs<'a>(
    study: &'a Study,
    jobs: &[(usize, String, String)],
) -> Result<Vec<&'a SuiteRecord>, String> {
    if study.file.ida.is_none() && !jobs.is_empty() {
        return Err(format!(
            "{} IDA jobs given, but the study has no [ida] table",
            jobs.len()
        ));
    }
    jobs.iter()
        .map(|(si, e, id)| {
            if *si >= study.scenes.len() || !study.file.engines.contains(e) {
                return Err(format!("IDA job ({si}, {e}, {id}) is not in the study"));
            }
            study
                .suite
                .records
                .iter()
                .find(|r| &r.id == id)
                .ok_or_else(|| format!("IDA job ({si}, {e}, {id}): no such record in the suite"))
        })
        .collect()
}

/// Run IDA jobs of [`ida_jobs`] through `runner` (its cache): the runs a distributed study
/// hands out record by record, as the hunt and fill of a record is sequential. Returns the
/// jobs' rows and capacities.
pub fn run_ida_jobs(
    study: &Study,
    runner: &Runner,
    jobs: &[(usize, String, String)],
) -> Result<Vec<IdaRecord>, String> {
    let records = check_ida_jobs(study, jobs)?;
    jobs.iter()
        .zip(records)
        .map(|((si, e, _), r)| ida_record(study, runner, *si, e, r))
        .collect()
}

/// The most levels an IDA hunt steps down from its start, each `factor` below the last, when
/// the start already exceeds (2^-30 of the start at the default factor 2).
const MAX_STEPS_DOWN: usize = 30;

/// The hunt and fill of one record (scene `si`, engine `e`) for every limit state.
fn ida_record(
    study: &Study,
    runner: &Runner,
    si: usize,
    e: &str,
    r: &SuiteRecord,
) -> Result<IdaRecord, String> {
    let f = &study.file;
    let Some(ida) = &f.ida else {
        return Ok((Vec::new(), Vec::new()));
    };
    let (lo, hi) = f.intensity.range();
    let (start_l, max_l) = (
        ida.start.unwrap_or(lo),
        ida.max.unwrap_or(hi).max(ida.start.unwrap_or(lo)),
    );
    let scene = &study.scenes[si];
    let mut memo: Vec<Row> = Vec::new();
    // The runs each limit state's hunt made.
    let mut hunts: Vec<usize> = Vec::new();
    for k in 0..study.limit_states.len() {
        let mut runs = 0;
        let mut at = |l: f64, memo: &mut Vec<Row>| -> Result<bool, String> {
            if let Some(row) = memo.iter().find(|x| x.level == l) {
                return Ok(row.exceeded[k]);
            }
            runs += 1;
            let scale = scale_for(study, scene, r, l);
            let spec = spec_for(study, scene, e, r, scale);
            let (o, cached) = runner.get(&spec)?;
            let rw = row(study, scene, e, r, l, scale, Method::Ida, o, cached);
            let x = rw.exceeded[k];
            memo.push(rw);
            Ok(x)
        };
        // Hunt: step up until exceeded.
        let mut safe = None;
        let mut l = start_l;
        let mut hit = None;
        loop {
            if at(l, &mut memo)? {
                hit = Some(l);
                break;
            }
            safe = Some(l);
            if l >= max_l {
                break;
            }
            l = (l * ida.factor).min(max_l);
        }
        let Some(mut hi_l) = hit else {
            hunts.push(runs);
            continue;
        };
        // Exceeded at the start: step down until a level is safe (the start's exceedance was
        // the capacity, 13 % above a record's closed-form threshold, and counted as exact).
        let mut steps_down = 0;
        while safe.is_none() {
            if steps_down == MAX_STEPS_DOWN {
                return Err(format!(
                    "record {}: limit state `{}` is exceeded at every level from the IDA's start {} down to {} (the scene exceeds it without its record?): no capacity",
                    r.id,
                    study.limit_states[k].name,
                    crate::scene::num(start_l),
                    crate::scene::num(hi_l)
                ));
            }
            steps_down += 1;
            let down = hi_l / ida.factor;
            if at(down, &mut memo)? {
                hi_l = down;
            } else {
                safe = Some(down);
            }
        }
        // Bisect the bracket (geometric mid-points).
        if let Some(mut lo_l) = safe {
            while hi_l / lo_l - 1.0 > ida.tolerance {
                let mid = (lo_l * hi_l).sqrt();
                if at(mid, &mut memo)? {
                    hi_l = mid;
                } else {
                    lo_l = mid;
                }
            }
            // Fill below the bracket: levels between the start and lo.
            let bottom = start_l.min(lo_l);
            for j in 1..=ida.fill {
                let fl = bottom * (lo_l / bottom).powf(j as f64 / (ida.fill + 1) as f64);
                at(fl, &mut memo)?;
            }
        }
        hunts.push(runs);
    }
    // The capacity is the lowest level run that exceeds, over every limit state's runs of the
    // record (all hunts done: a later hunt's runs count for an earlier limit state, so the
    // order of the limit states changes nothing), censored at the ceiling when none does.
    let mut lv: Vec<&Row> = memo.iter().collect();
    lv.sort_by(|a, b| a.level.total_cmp(&b.level));
    let caps = study
        .limit_states
        .iter()
        .enumerate()
        .zip(&hunts)
        .map(
            |((k, ls), &runs)| match lv.iter().find(|x| x.exceeded[k]).map(|x| x.level) {
                Some(first) => {
                    let resurrection = lv.iter().any(|x| x.level > first && !x.exceeded[k]);
                    capacity(scene, e, r, ls, first, false, resurrection, runs)
                }
                None => capacity(scene, e, r, ls, max_l, true, false, runs),
            },
        )
        .collect();
    Ok((memo, caps))
}

#[allow(clippy::too_many_arguments)]
fn row(
    study: &Study,
    scene: &Scene,
    e: &str,
    r: &SuiteRecord,
    level: f64,
    scale: f64,
    method: Method,
    o: RunOutcome,
    cached: bool,
) -> Row {
    Row {
        scene: scene.name.clone(),
        engine: e.to_string(),
        record: r.id.clone(),
        pair: r.pair.clone(),
        level,
        scale,
        method,
        exceeded: study
            .limit_states
            .iter()
            .map(|ls| exceeded(ls, scene, &o))
            .collect(),
        outcome: o,
        cached,
    }
}

#[allow(clippy::too_many_arguments)]
fn capacity(
    scene: &Scene,
    e: &str,
    r: &SuiteRecord,
    ls: &LimitState,
    c: f64,
    censored: bool,
    resurrection: bool,
    runs: usize,
) -> Capacity {
    Capacity {
        scene: scene.name.clone(),
        engine: e.to_string(),
        record: r.id.clone(),
        pair: r.pair.clone(),
        limit_state: ls.name.clone(),
        capacity: c,
        censored,
        resurrection,
        runs,
    }
}

/// Stripes of the records in `sample` (record ids, repeated as drawn): (ln level, n, hits).
fn stripes_of(rows: &[&Row], k: usize, weight: &BTreeMap<&str, f64>) -> Vec<(f64, f64, f64)> {
    let mut by: BTreeMap<u64, (f64, f64, f64)> = BTreeMap::new();
    for r in rows {
        let w = weight.get(r.record.as_str()).copied().unwrap_or(0.0);
        if w == 0.0 {
            continue;
        }
        let e = by
            .entry(r.level.to_bits())
            .or_insert((r.level.ln(), 0.0, 0.0));
        e.1 += w;
        if r.exceeded[k] {
            e.2 += w;
        }
    }
    by.into_values().collect()
}

/// The IDA runs and capacities of one record.
pub type IdaRecord = (Vec<Row>, Vec<Capacity>);

type FitOut = (Vec<Fit>, Vec<Difference>, Vec<f64>);

/// Every fit (scene x engine x limit state x method) with bootstrap intervals, and the paired
/// differences of medians against the first engine.
fn fits(study: &Study, rows: &[Row], caps: &[Capacity]) -> FitOut {
    let f = &study.file;
    let (lo, hi) = f.intensity.range();
    let (glo, ghi) = (lo / 2.0, hi * 1.5);
    let grid: Vec<f64> = (0..60)
        .map(|k| glo * (ghi / glo).powf(k as f64 / 59.0))
        .collect();
    // Record pairs and the resamples (the same for every engine: paired).
    let mut pairs: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for r in &study.suite.records {
        pairs
            .entry(r.pair.as_str())
            .or_default()
            .push(r.id.as_str());
    }
    let pair_list: Vec<&Vec<&str>> = pairs.values().collect();
    let mut rng = Rng::new(f.fit.seed);
    let resamples: Vec<BTreeMap<&str, f64>> = (0..f.fit.bootstrap)
        .map(|_| {
            let mut w: BTreeMap<&str, f64> = BTreeMap::new();
            for _ in 0..pair_list.len() {
                for id in pair_list[rng.below(pair_list.len())] {
                    *w.entry(id).or_insert(0.0) += 1.0;
                }
            }
            w
        })
        .collect();
    let all: BTreeMap<&str, f64> = study
        .suite
        .records
        .iter()
        .map(|r| (r.id.as_str(), 1.0))
        .collect();
    let mut fits = Vec::new();
    for scene in &study.scenes {
        for e in &f.engines {
            for (k, ls) in study.limit_states.iter().enumerate() {
                for method in [Method::Stripes, Method::Ida] {
                    let fit_with = |w: &BTreeMap<&str, f64>| -> Result<Lognormal, String> {
                        match method {
                            Method::Stripes => {
                                let rs: Vec<&Row> = rows
                                    .iter()
                                    .filter(|r| {
                                        r.method == Method::Stripes
                                            && r.scene == scene.name
                                            && &r.engine == e
                                    })
                                    .collect();
                                fit::probit(&stripes_of(&rs, k, w))
                            }
                            Method::Ida => {
                                let mut c = Vec::new();
                                for x in caps.iter().filter(|x| {
                                    x.scene == scene.name
                                        && &x.engine == e
                                        && x.limit_state == ls.name
                                }) {
                                    let n =
                                        w.get(x.record.as_str()).copied().unwrap_or(0.0) as usize;
                                    for _ in 0..n {
                                        c.push((x.capacity, x.censored));
                                    }
                                }
                                fit::censored_lognormal(&c)
                            }
                        }
                    };
                    let has = match method {
                        Method::Stripes => f.stripes,
                        Method::Ida => f.ida.is_some(),
                    };
                    if !has {
                        continue;
                    }
                    let point = fit_with(&all);
                    let boot: Vec<Option<Lognormal>> =
                        resamples.par_iter().map(|w| fit_with(w).ok()).collect();
                    let ok: Vec<Lognormal> = boot.iter().flatten().copied().collect();
                    let ci = |v: Vec<f64>| -> Option<(f64, f64)> {
                        Some((fit::quantile(&v, 0.025)?, fit::quantile(&v, 0.975)?))
                    };
                    let band = (ok.len() >= 2).then(|| {
                        let lo: Vec<f64> = grid
                            .iter()
                            .map(|&x| {
                                fit::quantile(&ok.iter().map(|l| l.p(x)).collect::<Vec<_>>(), 0.025)
                                    .unwrap_or(0.0)
                            })
                            .collect();
                        let hi: Vec<f64> = grid
                            .iter()
                            .map(|&x| {
                                fit::quantile(&ok.iter().map(|l| l.p(x)).collect::<Vec<_>>(), 0.975)
                                    .unwrap_or(1.0)
                            })
                            .collect();
                        (lo, hi)
                    });
                    fits.push(Fit {
                        scene: scene.name.clone(),
                        engine: e.clone(),
                        limit_state: ls.name.clone(),
                        method,
                        fit: point.as_ref().ok().copied(),
                        problem: point.err(),
                        theta_ci: if ok.len() >= 2 {
                            ci(ok.iter().map(|l| l.theta).collect())
                        } else {
                            None
                        },
                        beta_ci: if ok.len() >= 2 {
                            ci(ok.iter().map(|l| l.beta).collect())
                        } else {
                            None
                        },
                        resamples: ok.len(),
                        band,
                        boot_theta: boot.iter().map(|b| b.map(|l| l.theta)).collect(),
                    });
                }
            }
        }
    }
    let mut diffs = Vec::new();
    let reference = &f.engines[0];
    for a in fits.iter().filter(|x| &x.engine != reference) {
        let Some(b) = fits.iter().find(|x| {
            &x.engine == reference
                && x.scene == a.scene
                && x.limit_state == a.limit_state
                && x.method == a.method
        }) else {
            continue;
        };
        let (Some(fa), Some(fb)) = (a.fit, b.fit) else {
            continue;
        };
        let (mut d, mut r) = (Vec::new(), Vec::new());
        for (x, y) in a.boot_theta.iter().zip(&b.boot_theta) {
            if let (Some(x), Some(y)) = (x, y) {
                d.push(x - y);
                r.push(x / y);
            }
        }
        let ci = |v: &[f64]| -> Option<(f64, f64)> {
            if v.len() < 2 {
                return None;
            }
            Some((fit::quantile(v, 0.025)?, fit::quantile(v, 0.975)?))
        };
        diffs.push(Difference {
            scene: a.scene.clone(),
            limit_state: a.limit_state.clone(),
            method: a.method,
            engine: a.engine.clone(),
            reference: reference.clone(),
            difference: fa.theta - fb.theta,
            difference_ci: ci(&d),
            ratio: fa.theta / fb.theta,
            ratio_ci: ci(&r),
            resamples: d.len(),
        });
    }
    (fits, diffs, grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit whose intervals come from fewer resamples than asked says so; one from all of
    /// them, or with no fit, says nothing.
    #[test]
    fn a_fit_from_fewer_resamples_than_asked_says_how_many() {
        let fit = |resamples: usize, point: bool| Fit {
            scene: "s".into(),
            engine: "native".into(),
            limit_state: "overturn".into(),
            method: Method::Stripes,
            fit: point.then_some(fit::Lognormal {
                theta: 1.0,
                beta: 0.3,
            }),
            problem: None,
            theta_ci: None,
            beta_ci: None,
            resamples,
            band: None,
            boot_theta: Vec::new(),
        };
        assert_eq!(
            fit(86, true).resample_note(200).as_deref(),
            Some("intervals over 86 of 200 resamples (the others have no finite fit)")
        );
        assert_eq!(fit(200, true).resample_note(200), None);
        assert_eq!(fit(0, false).resample_note(200), None);
        assert_eq!(fit(0, true).resample_note(0), None);
    }
}
