//! Metrics between two trajectories, one of them the reference: the definitions of
//! `VALIDATION.md`, implemented once. Impacts, peaks, rest times and overturning come from
//! [`crate::events`]; this module only compares them.
//!
//! ## Series
//! Every block has its **absolute rotation** (series named after the block). A block standing
//! on another block also has the **relative rotation** `phi_upper - phi_lower` of its interface
//! (series `lower/upper`): that is what rocks there. A block's *measured* rotation (the one its
//! impacts, peaks and effective restitution are read from) is the absolute one for a block on
//! the ground and the interface's relative one otherwise, as in `summary.json`
//! ([`crate::summary::measured_rotation`]).
//!
//! ## Metrics (`metric` column of `metrics.csv`; `value` is the engine's, `reference` the
//! reference's)
//! - `rotation_rms_error`, `rotation_max_error` (rad) and `..._normalised` (divided by the
//!   reference's largest |phi| of that series over the window): both histories are linearly
//!   interpolated onto one uniform grid (default 1 ms) over the common window (the overlap of
//!   the two histories). `..._to_impact_K`: the same on the grid points up to the reference's
//!   K-th impact of the block's measured rotation (K = 1, 3 by default; absent if the
//!   reference has fewer impacts).
//! - `impact_count` (engine's and reference's count in the window), `impacts_unmatched`
//!   (impacts are matched in order, the i-th with the i-th; the rest are unmatched),
//!   `impact_time_K` (s, K = 1, 2, ...; one side empty when unmatched),
//!   `impact_time_max_abs_diff` (s, over the matched pairs).
//! - `peak_amplitude_K` (rad): largest |phi| after impact K (K = 0: before the first impact).
//!   A last stretch that is still growing when the history ends is not a peak, nor a first
//!   stretch that a window starting later cuts while it falls back (its peak came before).
//! - `restitution_K`: effective restitution of impact K from the peaks before and after it
//!   through energy, `sqrt(E(A_K) / E(A_{K-1}))` with `E(A) = cos(alpha - A) - cos(alpha)`
//!   (the rise of the centroid of a block rocking on a fixed base, alpha = atan(B/H)); to be
//!   compared with Housner's `housner_restitution = 1 - 1.5 sin^2 alpha`. Exact for a single
//!   block in free rocking; for a block on a moving block an indicator.
//! - `rest_time_1e-4`, `rest_time_1e-3`, `rest_time_1e-2`, `rest_time_3e-2` (s): the earliest
//!   time after which |phi| stays below the threshold to the window's end (empty: not at rest
//!   by then); a block at rest from before the window came to rest when the history before
//!   it says.
//! - `overturned` (1 or 0), `overturn_time` (s), `overturning_agrees` (1 when engine and
//!   reference agree on whether the block overturned).
//! - `max_abs_rotation` (rad).
//! - Energy per block (absolute series only), J per metre of depth: `energy_initial`,
//!   `energy_final` (at the end of the window) and `energy_rms_diff` (on the grid), with
//!   `E = m (vx^2 + vz^2) / 2 + I omega^2 / 2 + m g (z - z_rest)`, `z_rest` the centroid height
//!   of the block in the upright stack.
//! - Displacement per block (absolute series only), m: `displacement_x_final` (horizontal
//!   displacement of the centroid from the first to the last sample of the window, relative to
//!   the ground: sliding) and `max_drift` (largest distance of the centroid from its first
//!   position: nothing may move in a standing assembly); `max_drift` of block `(run)`: the
//!   largest of every block's.
//! - `displaced` (1 or 0, absolute series only): the block overturned, or its centroid ended
//!   more than its own width from where it started horizontally ([`is_displaced`]). Over the
//!   assembly (block `(run)`): `overturned_count` and `displaced_count` (run and reference), and
//!   `overturning_disagreements` and `displacement_disagreements`, the blocks counted in one of
//!   the two and not the other.
//! - Cost (block `(run)`): `wall_time` (s), `steps`, `solver_iterations`.

pub mod ensemble;
pub mod grid;

use crate::events::{self, History, Peak};
use crate::scene::Scene;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};

/// The block column of the cost rows (no block may take the name).
pub use crate::scene::RUN_ROW;

/// What a run of an engine (or a trajectory file) brings to a comparison.
#[derive(Debug, Clone)]
pub struct Run {
    /// Engine name, or the file the trajectory was read from.
    pub name: String,
    pub trajectory: Trajectory,
    /// Impact times per block on its measured rotation, located by the engine itself
    /// (the Housner engine); `None`: taken from the trajectory.
    pub exact_impacts: Option<Vec<Vec<f64>>>,
    pub cost: Cost,
}

/// Cost of a run (unknown for a trajectory file).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    pub wall_time_s: Option<f64>,
    pub steps: Option<u64>,
    pub solver_iterations: Option<u64>,
}

/// Settings of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricSettings {
    /// Spacing of the common grid, s (default 1e-3).
    pub grid_dt: f64,
    /// Rotation errors are also reported up to the reference's K-th impact for these K
    /// (default 1 and 3).
    pub up_to_impacts: Vec<usize>,
    /// Crossings while the amplitude is below this are not impacts, rad (default 1e-5).
    pub noise_floor: f64,
    /// Window `[t0, t1]`, s; default the overlap of the two histories.
    pub window: Option<(f64, f64)>,
}

impl Default for MetricSettings {
    fn default() -> Self {
        MetricSettings {
            grid_dt: 1e-3,
            up_to_impacts: vec![1, 3],
            noise_floor: events::NOISE_FLOOR,
            window: None,
        }
    }
}

impl MetricSettings {
    /// These settings on a common grid no finer than either run's samples. Between samples a
    /// history is interpolated linearly, whose error is the run's: an engine stepping at 2 ms
    /// samples every 2 ms, and on a 1 ms grid the interpolation of those samples (2.1e-6 rad
    /// RMS on the slender block's exact rotation) outweighs the engine's own error (2.4e-7),
    /// which then seems to converge at third order. Studies over step sizes (`converge`,
    /// `bench`) measure on this grid.
    pub fn on_samples_of(&self, run: &Run, reference: &Run) -> MetricSettings {
        let coarsest = [run, reference]
            .iter()
            .filter_map(|r| r.trajectory.sample_interval())
            .fold(self.grid_dt, f64::max);
        MetricSettings {
            grid_dt: coarsest,
            ..self.clone()
        }
    }
}

/// One line of `metrics.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricRow {
    pub scene: String,
    pub engine: String,
    /// Block name, interface `lower/upper`, or `(run)` for costs.
    pub block: String,
    pub metric: String,
    /// The engine's value (`None`: not defined, e.g. never at rest).
    pub value: Option<f64>,
    /// The reference's value (`None` for error metrics and where not defined).
    pub reference: Option<f64>,
    pub unit: String,
}

/// Absolute rotation of a block, or relative rotation of an interface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Series {
    pub label: String,
    /// The block (the upper block of an interface).
    pub block: usize,
    /// For an interface: the lower block.
    pub lower: Option<usize>,
    /// Whether this is the block's measured rotation (impacts, peaks, restitution).
    pub measured: bool,
}

impl Series {
    pub fn is_interface(&self) -> bool {
        self.lower.is_some()
    }

    /// The series' rotation history, rad.
    pub fn rotation(&self, tr: &Trajectory) -> Vec<f64> {
        self.rotation_and_rate(tr).0
    }

    /// The series' rotation (rad) and its rate (rad/s).
    pub fn rotation_and_rate(&self, tr: &Trajectory) -> (Vec<f64>, Vec<f64>) {
        tr.rotation(self.block, self.lower)
    }
}

/// The series of a scene: per block its absolute rotation, then for blocks on blocks the
/// interface's relative rotation.
pub fn series_of(scene: &Scene) -> Vec<Series> {
    let supports = scene.layout().supports;
    let mut out = Vec::new();
    for (i, b) in scene.blocks.iter().enumerate() {
        out.push(Series {
            label: b.name.clone(),
            block: i,
            lower: None,
            measured: supports[i].is_none(),
        });
    }
    for (i, b) in scene.blocks.iter().enumerate() {
        if let Some(s) = supports[i] {
            out.push(Series {
                label: format!("{}/{}", scene.blocks[s].name, b.name),
                block: i,
                lower: Some(s),
                measured: true,
            });
        }
    }
    out
}

/// Events of one series of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeriesEvents {
    pub label: String,
    pub measured: bool,
    /// Impacts of the block's measured rotation, s (for an upper block's absolute series: its
    /// interface's).
    pub impacts: Vec<f64>,
    /// Peaks of this series (measured series only).
    pub peaks: Vec<Peak>,
    /// Effective restitution of impact K (index K - 1), from the peaks through energy.
    pub restitution: Vec<Option<f64>>,
    /// Housner's `1 - 1.5 sin^2 alpha` of the block.
    pub housner_restitution: f64,
    /// Rest time at each threshold of [`events::REST_THRESHOLDS`], s.
    pub rest_times: Vec<(String, Option<f64>)>,
    pub overturned: bool,
    pub overturn_time: Option<f64>,
    pub max_abs_rotation: f64,
}

/// Events of every series of a run, within `[t0, t1]`.
pub fn run_events(
    scene: &Scene,
    run: &Run,
    settings: &MetricSettings,
    window: (f64, f64),
) -> Vec<SeriesEvents> {
    let all = series_of(scene);
    let tr = &run.trajectory;
    // Impacts of each block's measured rotation.
    let measured = |i: usize| {
        all.iter()
            .find(|s| s.block == i && s.measured)
            .expect("every block has a measured series")
            .rotation_and_rate(tr)
    };
    let found = match &run.exact_impacts {
        Some(ex) => (0..scene.blocks.len())
            .map(|i| ex.get(i).cloned().unwrap_or_default())
            .collect(),
        None => events::scene_impacts(scene.blocks.len(), &tr.t, measured, settings.noise_floor),
    };
    let measured_impacts: Vec<Vec<f64>> = found
        .into_iter()
        .map(|imp| {
            imp.into_iter()
                .filter(|t| *t >= window.0 && *t <= window.1)
                .collect()
        })
        .collect();
    let kinks = events::all_impacts(measured_impacts.iter().map(Vec::as_slice));
    all.iter()
        .map(|s| series_events(scene, s, tr, &measured_impacts[s.block], &kinks, window))
        .collect()
}

fn series_events(
    scene: &Scene,
    s: &Series,
    tr: &Trajectory,
    impacts: &[f64],
    kinks: &[f64],
    window: (f64, f64),
) -> SeriesEvents {
    // Samples inside the window.
    let k0 = tr.t.partition_point(|t| *t < window.0);
    let k1 = tr.t.partition_point(|t| *t <= window.1);
    let (rot_all, rate_all) = s.rotation_and_rate(tr);
    let h = History::new(&tr.t, &rot_all, &rate_all).slice(k0..k1);
    let t = h.t;
    let b = &scene.blocks[s.block];
    let alpha = b.critical_angle();
    let (peaks, restitution) = if s.measured {
        let mut pk = events::peaks(&h, impacts, kinks);
        // A first stretch cut by a window that starts after the history, where it is already
        // falling back (its largest |phi| at the window's first sample, the rate inward), has
        // no peak either: its peak came before the window (one taken there made a restitution
        // > 1).
        if k0 > 0
            && let (Some(first), Some(&t_start)) = (pk.first(), t.first())
            && first.t <= t_start
            && h.phi[0] * h.omega[0] < 0.0
        {
            pk.remove(0);
        }
        let energy = |a: f64| (alpha - a).cos() - alpha.cos();
        let rest: Vec<Option<f64>> = (1..=impacts.len())
            .map(|k| {
                let before = pk.iter().find(|p| p.after_impact == k - 1)?;
                let after = pk.iter().find(|p| p.after_impact == k)?;
                let (e0, e1) = (energy(before.amplitude), energy(after.amplitude));
                (e0 > 0.0 && e1 >= 0.0).then(|| (e1 / e0).sqrt())
            })
            .collect();
        (pk, rest)
    } else {
        (Vec::new(), Vec::new())
    };
    // A block at rest from before the window came to rest then, not at the window's start
    // (both engines "at rest from 3.3 s", the window's start, agreed to 0 %): its rest time is
    // read from the history up to the window's end.
    let to_window_end = History::new(&tr.t, &rot_all, &rate_all).slice(0..k1);
    let rest_times = events::REST_THRESHOLDS
        .iter()
        .map(|(k, eps)| {
            let within = events::rest_time(&h, *eps);
            let at_start = within.is_some() && within == h.t.first().copied() && k0 > 0;
            let t = if at_start {
                events::rest_time(&to_window_end, *eps)
            } else {
                within
            };
            (k.to_string(), t)
        })
        .collect();
    let (overturned, overturn_time) = events::overturning(&h, alpha);
    SeriesEvents {
        label: s.label.clone(),
        measured: s.measured,
        impacts: impacts.to_vec(),
        peaks,
        restitution,
        housner_restitution: 1.0 - 1.5 * alpha.sin().powi(2),
        rest_times,
        overturned,
        overturn_time,
        max_abs_rotation: events::max_abs(&h, kinks),
    }
}

/// Why two runs cannot be compared.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricsError {
    #[error("{run}: blocks {found:?} do not match the scene's blocks {expected:?}")]
    Blocks {
        run: String,
        found: Vec<String>,
        expected: Vec<String>,
    },
    #[error("{run} and {reference} do not overlap in time (or the window is empty)")]
    NoOverlap { run: String, reference: String },
    #[error("{run}: times are not increasing at sample {index}")]
    Times { run: String, index: usize },
    #[error(
        "{run}: time {t} s is repeated at sample {index}; a reference's times must increase (which of its states would hold there?)"
    )]
    RepeatedTime { run: String, index: usize, t: f64 },
    #[error(
        "{run}: covers {first} to {last} s; a reference must cover the run, 0 to {duration} s (its metrics are of the whole run)"
    )]
    Coverage {
        run: String,
        first: f64,
        last: f64,
        duration: f64,
    },
    #[error(
        "{run}: starts with {column} = {found} where the scene starts at {expected}: the reference of another scene or placement"
    )]
    Start {
        run: String,
        column: String,
        found: f64,
        expected: f64,
    },
    #[error("grid spacing: {0}")]
    Grid(String),
    #[error("{run}: {samples} sample(s); a reference needs at least two")]
    TooShort { run: String, samples: usize },
    #[error("{run}: `{column}` is not finite at sample {index}")]
    NotFinite {
        run: String,
        column: String,
        index: usize,
    },
}

/// Check that a run can be compared on this scene.
pub fn check_run(scene: &Scene, run: &Run) -> Result<(), MetricsError> {
    let found: Vec<String> = run
        .trajectory
        .blocks
        .iter()
        .map(|b| b.name.clone())
        .collect();
    let expected: Vec<String> = scene.blocks.iter().map(|b| b.name.clone()).collect();
    if found != expected {
        return Err(MetricsError::Blocks {
            run: run.name.clone(),
            found,
            expected,
        });
    }
    if let Some(k) = run
        .trajectory
        .t
        .windows(2)
        .position(|w| w[1].is_nan() || w[1] < w[0])
    {
        return Err(MetricsError::Times {
            run: run.name.clone(),
            index: k + 1,
        });
    }
    Ok(())
}

/// Check that a trajectory read from a file can serve as the reference of runs of this scene:
/// the scene's blocks, times that increase, at least two samples and every value finite (an
/// engine's own run is judged by its contracts instead; a file is data to be checked).
pub fn check_reference_file(scene: &Scene, run: &Run) -> Result<(), MetricsError> {
    check_run(scene, run)?;
    let tr = &run.trajectory;
    if let Some(k) = tr.t.windows(2).position(|w| w[1] == w[0]) {
        return Err(MetricsError::RepeatedTime {
            run: run.name.clone(),
            index: k + 1,
            t: tr.t[k],
        });
    }
    if tr.t.len() < 2 {
        return Err(MetricsError::TooShort {
            run: run.name.clone(),
            samples: tr.t.len(),
        });
    }
    let not_finite = |column: String, index: usize| MetricsError::NotFinite {
        run: run.name.clone(),
        column,
        index,
    };
    if let Some(k) = tr.t.iter().position(|t| !t.is_finite()) {
        return Err(not_finite("t".into(), k));
    }
    for b in &tr.blocks {
        for (field, values) in [
            ("x", &b.x),
            ("z", &b.z),
            ("phi", &b.phi),
            ("vx", &b.vx),
            ("vz", &b.vz),
            ("omega", &b.omega),
        ] {
            if let Some(k) = values.iter().position(|v| !v.is_finite()) {
                return Err(not_finite(format!("{}_{field}", b.name), k));
            }
        }
    }
    // The run's metrics (impacts, peaks, rest) are of the whole run: the reference must cover
    // it, from 0 to the duration within its own last sample interval.
    let (first, last) = (tr.t[0], tr.t[tr.t.len() - 1]);
    let last_interval = last - tr.t[tr.t.len() - 2];
    if first.abs() > 1e-9 || last < scene.duration - last_interval {
        return Err(MetricsError::Coverage {
            run: run.name.clone(),
            first,
            last,
            duration: scene.duration,
        });
    }
    // Its first sample is the scene's start (to the digits a file keeps).
    let layout = scene.layout();
    for (b, st) in tr.blocks.iter().zip(&layout.blocks) {
        for (field, found, expected) in [
            ("x", b.x[0], st.x),
            ("z", b.z[0], st.z),
            ("phi", b.phi[0], st.phi),
        ] {
            if (found - expected).abs() > REFERENCE_START_TOLERANCE * (1.0 + expected.abs()) {
                return Err(MetricsError::Start {
                    run: run.name.clone(),
                    column: format!("{}_{field}", b.name),
                    found,
                    expected,
                });
            }
        }
    }
    Ok(())
}

/// How far a reference file's first sample may lie from the scene's start (m or rad, relative
/// above 1): files keep some nine digits.
pub const REFERENCE_START_TOLERANCE: f64 = 1e-6;

/// The window on which two runs are compared: their overlap, cut to the requested window.
pub fn common_window(
    run: &Run,
    reference: &Run,
    settings: &MetricSettings,
) -> Result<(f64, f64), MetricsError> {
    let (a, b) = (&run.trajectory.t, &reference.trajectory.t);
    let no = || MetricsError::NoOverlap {
        run: run.name.clone(),
        reference: reference.name.clone(),
    };
    let (a0, a1) = (*a.first().ok_or_else(no)?, *a.last().ok_or_else(no)?);
    let (b0, b1) = (*b.first().ok_or_else(no)?, *b.last().ok_or_else(no)?);
    let (mut t0, mut t1) = (a0.max(b0), a1.min(b1));
    if let Some((w0, w1)) = settings.window {
        t0 = t0.max(w0);
        t1 = t1.min(w1);
    }
    if t1.is_nan() || t0.is_nan() || t1 <= t0 {
        return Err(no());
    }
    Ok((t0, t1))
}

/// Rotation difference `run - reference` of every series on the common grid.
pub struct ErrorHistory {
    pub t: Vec<f64>,
    /// Per series (in [`series_of`] order): engine, reference, difference.
    pub series: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

/// The most points of the common grid (a finer grid is a slip of units, and its histories
/// would not fit in memory).
pub const MAX_GRID_POINTS: f64 = 1e7;
/// The fewest intervals of the common grid over the compared span (a coarser one measures the
/// histories at a handful of instants).
pub const MIN_GRID_INTERVALS: f64 = 10.0;

/// Whether a common grid of spacing `dt` over `span` seconds can compare two runs: `dt`
/// positive, at most [`MAX_GRID_POINTS`] points and at least [`MIN_GRID_INTERVALS`] intervals.
pub fn check_grid(dt: f64, span: f64) -> Result<(), String> {
    let num = crate::scene::num;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(format!(
            "must be a positive number of seconds (got {})",
            num(dt)
        ));
    }
    let intervals = span / dt;
    if intervals > MAX_GRID_POINTS {
        return Err(format!(
            "{} s makes {} points over the compared {} s; at most {MAX_GRID_POINTS:e}",
            num(dt),
            num(intervals.floor() + 1.0),
            num(span)
        ));
    }
    if intervals < MIN_GRID_INTERVALS {
        return Err(format!(
            "{} s leaves fewer than {MIN_GRID_INTERVALS} intervals in the compared {} s",
            num(dt),
            num(span)
        ));
    }
    Ok(())
}

pub fn error_history(
    scene: &Scene,
    run: &Run,
    reference: &Run,
    settings: &MetricSettings,
) -> Result<ErrorHistory, MetricsError> {
    let (t0, t1) = common_window(run, reference, settings)?;
    check_grid(settings.grid_dt, t1 - t0).map_err(MetricsError::Grid)?;
    let g = grid::uniform_grid(t0, t1, settings.grid_dt);
    let series = series_of(scene)
        .iter()
        .map(|s| {
            let a = grid::interpolate(&run.trajectory.t, &s.rotation(&run.trajectory), &g);
            let r = grid::interpolate(
                &reference.trajectory.t,
                &s.rotation(&reference.trajectory),
                &g,
            );
            let d = a.iter().zip(&r).map(|(x, y)| x - y).collect();
            (a, r, d)
        })
        .collect();
    Ok(ErrorHistory { t: g, series })
}

/// Energy of a block above the upright rest state (its centroid at `z_rest`, from
/// [`rest_heights`]), J per metre of depth, per sample.
pub fn block_energy(scene: &Scene, tr: &Trajectory, i: usize, z_rest: f64) -> Vec<f64> {
    let b = &scene.blocks[i];
    let (m, inertia, g) = (b.mass(), b.inertia(), scene.gravity);
    let h = &tr.blocks[i];
    (0..tr.t.len())
        .map(|k| {
            0.5 * m * (h.vx[k] * h.vx[k] + h.vz[k] * h.vz[k])
                + 0.5 * inertia * h.omega[k] * h.omega[k]
                + m * g * (h.z[k] - z_rest)
        })
        .collect()
}

/// Centroid height of every block in the upright stack, m (one layout of the scene: it costs
/// O(n^2) in the blocks).
pub fn rest_heights(scene: &Scene) -> Vec<f64> {
    let supports = scene.layout().supports;
    (0..scene.blocks.len())
        .map(|i| {
            let mut z = scene.blocks[i].height / 2.0;
            let mut cur = supports[i];
            let mut guard = 0;
            while let Some(s) = cur {
                z += scene.blocks[s].height;
                cur = supports[s];
                guard += 1;
                if guard > scene.blocks.len() {
                    break;
                }
            }
            z
        })
        .collect()
}

/// Horizontal displacement of block `i`'s centroid from its first to its last sample in the
/// window, and its largest distance from its first position (`hypot(x - x0, z - z0)`), m.
pub fn displacement(tr: &Trajectory, i: usize, window: (f64, f64)) -> (Option<f64>, Option<f64>) {
    let k0 = tr.t.partition_point(|t| *t < window.0);
    let k1 = tr.t.partition_point(|t| *t <= window.1);
    if k1 <= k0 {
        return (None, None);
    }
    let h = &tr.blocks[i];
    let (x0, z0) = (h.x[k0], h.z[k0]);
    let drift = (k0..k1).fold(0.0f64, |m, k| m.max((h.x[k] - x0).hypot(h.z[k] - z0)));
    (Some(h.x[k1 - 1] - x0), Some(drift))
}

/// Whether a block left its place: it overturned, or its centre ended more than its own width
/// `width` from where it started horizontally (`final_dx`, over the compared window). A block
/// that falls off an assembly can come to rest tilted on the debris below its critical angle,
/// which the overturning test alone does not count (docs/quantities.md).
pub fn is_displaced(overturned: bool, final_dx: Option<f64>, width: f64) -> bool {
    overturned || final_dx.is_some_and(|d| d.abs() > width)
}

/// Every metric of `run` against `reference` (see the module docs).
pub fn compare_runs(
    scene: &Scene,
    run: &Run,
    reference: &Run,
    settings: &MetricSettings,
) -> Result<Vec<MetricRow>, MetricsError> {
    check_run(scene, run)?;
    check_run(scene, reference)?;
    let window = common_window(run, reference, settings)?;
    let eh = error_history(scene, run, reference, settings)?;
    let z_rest = rest_heights(scene);
    let ev = run_events(scene, run, settings, window);
    let er = run_events(scene, reference, settings, window);
    let all = series_of(scene);
    let mut rows = Vec::new();
    let mut push = |block: &str, metric: String, value: Option<f64>, reff: Option<f64>, unit| {
        rows.push(MetricRow {
            scene: scene.name.clone(),
            engine: run.name.clone(),
            block: block.to_string(),
            metric,
            value,
            reference: reff,
            unit: String::from(unit),
        });
    };
    // Blocks overturned in the run and in the reference, and blocks on which they disagree;
    // the same for blocks displaced (overturned, or moved more than their width).
    let mut overturned = (0usize, 0usize, 0usize);
    let mut displaced = (0usize, 0usize, 0usize);
    // The largest difference of a block's final horizontal displacement (run - reference).
    let mut displacement_diff: Option<f64> = None;
    for (si, s) in all.iter().enumerate() {
        let (a, r, _) = &eh.series[si];
        let (e, f) = (&ev[si], &er[si]);
        let lab = s.label.as_str();
        // Rotation-history errors.
        // Normalised by the reference's largest |phi|; not at all where the reference does not
        // rock (below the impacts' noise floor, a ratio of round-off).
        let scale = r.iter().fold(0.0f64, |m, p| m.max(p.abs()));
        let norm = |x: f64| (scale > crate::events::NOISE_FLOOR).then(|| x / scale);
        let mut err_rows = |suffix: &str, n: usize| {
            let (rms, max) = grid::rms_and_max(a, r, n);
            push(
                lab,
                format!("rotation_rms_error{suffix}"),
                Some(rms),
                None,
                "rad",
            );
            push(
                lab,
                format!("rotation_max_error{suffix}"),
                Some(max),
                None,
                "rad",
            );
            push(
                lab,
                format!("rotation_rms_error_normalised{suffix}"),
                norm(rms),
                None,
                "1",
            );
            push(
                lab,
                format!("rotation_max_error_normalised{suffix}"),
                norm(max),
                None,
                "1",
            );
        };
        err_rows("", eh.t.len());
        for &k in &settings.up_to_impacts {
            if k >= 1
                && let Some(&tk) = f.impacts.get(k - 1)
            {
                let n = eh.t.partition_point(|t| *t <= tk);
                err_rows(&format!("_to_impact_{k}"), n);
            }
        }
        if s.measured {
            let (ni, nr) = (e.impacts.len(), f.impacts.len());
            push(
                lab,
                "impact_count".into(),
                Some(ni as f64),
                Some(nr as f64),
                "1",
            );
            push(
                lab,
                "impacts_unmatched".into(),
                Some(ni.abs_diff(nr) as f64),
                None,
                "1",
            );
            let mut max_diff: Option<f64> = None;
            for k in 0..ni.max(nr) {
                let (x, y) = (e.impacts.get(k).copied(), f.impacts.get(k).copied());
                if let (Some(x), Some(y)) = (x, y) {
                    max_diff = Some(max_diff.unwrap_or(0.0).max((x - y).abs()));
                }
                push(lab, format!("impact_time_{}", k + 1), x, y, "s");
            }
            // No impact in either: no instant differs.
            let max_diff = max_diff.or((ni == 0 && nr == 0).then_some(0.0));
            push(lab, "impact_time_max_abs_diff".into(), max_diff, None, "s");
            let n_peaks = e
                .peaks
                .iter()
                .chain(&f.peaks)
                .map(|p| p.after_impact + 1)
                .max()
                .unwrap_or(0);
            for k in 0..n_peaks {
                let pa = |v: &SeriesEvents| {
                    v.peaks
                        .iter()
                        .find(|p| p.after_impact == k)
                        .map(|p| p.amplitude)
                };
                push(lab, format!("peak_amplitude_{k}"), pa(e), pa(f), "rad");
            }
            for k in 0..e.restitution.len().max(f.restitution.len()) {
                push(
                    lab,
                    format!("restitution_{}", k + 1),
                    e.restitution.get(k).copied().flatten(),
                    f.restitution.get(k).copied().flatten(),
                    "1",
                );
            }
            push(
                lab,
                "housner_restitution".into(),
                Some(e.housner_restitution),
                Some(f.housner_restitution),
                "1",
            );
        }
        for ((key, x), (_, y)) in e.rest_times.iter().zip(&f.rest_times) {
            push(lab, format!("rest_time_{key}"), *x, *y, "s");
        }
        let b01 = |b: bool| Some(if b { 1.0 } else { 0.0 });
        push(
            lab,
            "overturned".into(),
            b01(e.overturned),
            b01(f.overturned),
            "1",
        );
        push(
            lab,
            "overturn_time".into(),
            e.overturn_time,
            f.overturn_time,
            "s",
        );
        push(
            lab,
            "overturning_agrees".into(),
            b01(e.overturned == f.overturned),
            None,
            "1",
        );
        if !s.is_interface() {
            overturned.0 += usize::from(e.overturned);
            overturned.1 += usize::from(f.overturned);
            overturned.2 += usize::from(e.overturned != f.overturned);
        }
        push(
            lab,
            "max_abs_rotation".into(),
            Some(e.max_abs_rotation),
            Some(f.max_abs_rotation),
            "rad",
        );
        if !s.is_interface() {
            let ea = block_energy(scene, &run.trajectory, s.block, z_rest[s.block]);
            let fa = block_energy(scene, &reference.trajectory, s.block, z_rest[s.block]);
            let ga = grid::interpolate(&run.trajectory.t, &ea, &eh.t);
            let gr = grid::interpolate(&reference.trajectory.t, &fa, &eh.t);
            let (first, last) = (0, eh.t.len() - 1);
            push(
                lab,
                "energy_initial".into(),
                Some(ga[first]),
                Some(gr[first]),
                "J/m",
            );
            push(
                lab,
                "energy_final".into(),
                Some(ga[last]),
                Some(gr[last]),
                "J/m",
            );
            let (rms, _) = grid::rms_and_max(&ga, &gr, eh.t.len());
            push(lab, "energy_rms_diff".into(), Some(rms), None, "J/m");
            let (dx, dr) = (
                displacement(&run.trajectory, s.block, window),
                displacement(&reference.trajectory, s.block, window),
            );
            push(lab, "displacement_x_final".into(), dx.0, dr.0, "m");
            if let (Some(x), Some(y)) = (dx.0, dr.0) {
                displacement_diff = Some(displacement_diff.unwrap_or(0.0).max((x - y).abs()));
            }
            push(lab, "max_drift".into(), dx.1, dr.1, "m");
            let width = scene.blocks[s.block].width;
            let (de, df) = (
                is_displaced(e.overturned, dx.0, width),
                is_displaced(f.overturned, dr.0, width),
            );
            push(lab, "displaced".into(), b01(de), b01(df), "1");
            displaced.0 += usize::from(de);
            displaced.1 += usize::from(df);
            displaced.2 += usize::from(de != df);
        }
    }
    // The largest drift of any block (standing assemblies: nothing may move).
    let drift = |tr: &Trajectory| {
        (0..scene.blocks.len())
            .filter_map(|i| displacement(tr, i, window).1)
            .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |x| x.max(d))))
    };
    push(
        RUN_ROW,
        "max_drift".into(),
        drift(&run.trajectory),
        drift(&reference.trajectory),
        "m",
    );
    push(
        RUN_ROW,
        "displacement_x_final_max_abs_diff".into(),
        displacement_diff,
        None,
        "m",
    );
    for ((count, disagreements), (run_n, ref_n, differ)) in [
        (
            ("overturned_count", "overturning_disagreements"),
            overturned,
        ),
        (("displaced_count", "displacement_disagreements"), displaced),
    ] {
        let n = |k: usize| Some(k as f64);
        push(RUN_ROW, count.into(), n(run_n), n(ref_n), "1");
        push(RUN_ROW, disagreements.into(), n(differ), None, "1");
    }
    let c = (&run.cost, &reference.cost);
    push(
        RUN_ROW,
        "wall_time".into(),
        c.0.wall_time_s,
        c.1.wall_time_s,
        "s",
    );
    let u = |x: Option<u64>| x.map(|v| v as f64);
    push(RUN_ROW, "steps".into(), u(c.0.steps), u(c.1.steps), "1");
    push(
        RUN_ROW,
        "solver_iterations".into(),
        u(c.0.solver_iterations),
        u(c.1.solver_iterations),
        "1",
    );
    Ok(rows)
}

/// Whether `name` is a metric [`compare_runs`] can produce (for checking gate files).
/// Whether metric `name` is a quantity of the run beside the same quantity of the reference
/// (`impact_time_3`, `rest_time_1e-4`, ...), rather than a difference between the two
/// (`rotation_rms_error`, `impact_time_max_abs_diff`, ...): a row of it without the
/// reference's value (fewer impacts in the reference) compares with nothing.
pub fn is_paired_metric(name: &str) -> bool {
    const PAIRED: &[&str] = &[
        "impact_count",
        "housner_restitution",
        "overturned",
        "overturn_time",
        "max_abs_rotation",
        "energy_initial",
        "energy_final",
        "displacement_x_final",
        "max_drift",
        "displaced",
        "overturned_count",
        "displaced_count",
        "wall_time",
        "steps",
        "solver_iterations",
    ];
    PAIRED.contains(&name)
        || [
            "impact_time_",
            "peak_amplitude_",
            "restitution_",
            "rest_time_",
        ]
        .iter()
        .any(|p| {
            name.strip_prefix(p)
                .is_some_and(|k| k.starts_with(|c: char| c.is_ascii_digit()))
        }) && is_known_metric(name)
}

pub fn is_known_metric(name: &str) -> bool {
    const FIXED: &[&str] = &[
        "impact_count",
        "impacts_unmatched",
        "impact_time_max_abs_diff",
        "housner_restitution",
        "overturned",
        "overturn_time",
        "overturning_agrees",
        "max_abs_rotation",
        "energy_initial",
        "energy_final",
        "energy_rms_diff",
        "displacement_x_final",
        "displacement_x_final_max_abs_diff",
        "max_drift",
        "overturned_count",
        "overturning_disagreements",
        "displaced",
        "displaced_count",
        "displacement_disagreements",
        "wall_time",
        "steps",
        "solver_iterations",
    ];
    if FIXED.contains(&name) {
        return true;
    }
    if let Some(k) = name.strip_prefix("rest_time_") {
        return events::REST_THRESHOLDS.iter().any(|(t, _)| *t == k);
    }
    // Impacts count from 1 (`impact_time_1` is the first); `07` is not a name the rows use.
    let number = |s: &str| s.parse::<u64>().is_ok_and(|k| k >= 1 && k.to_string() == s);
    // Peaks count from 0 (`peak_amplitude_0`: before the first impact).
    if let Some(k) = name.strip_prefix("peak_amplitude_") {
        return k == "0" || number(k);
    }
    for p in ["impact_time_", "restitution_"] {
        if let Some(k) = name.strip_prefix(p) {
            return number(k);
        }
    }
    for base in [
        "rotation_rms_error",
        "rotation_max_error",
        "rotation_rms_error_normalised",
        "rotation_max_error_normalised",
    ] {
        if let Some(rest) = name.strip_prefix(base) {
            if rest.is_empty() {
                return true;
            }
            if let Some(k) = rest.strip_prefix("_to_impact_") {
                return number(k);
            }
        }
    }
    false
}

#[cfg(test)]
mod tests;
