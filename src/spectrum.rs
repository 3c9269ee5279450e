//! Overturning spectra of a block (or a stack) under pulse families (`rockbench spectrum`).
//!
//! Dimensionless axes (Zhang & Makris 2001; Dimitrakopoulos & DeJong 2012): the frequency
//! ratio `Pi = omega_p / p` and the amplitude `A = a_p / (g tan alpha)`, with `p` and `alpha` of
//! the bottom block (`p = sqrt(3 g / (4 R))`, `alpha = atan(B/H)`; for one block they are the
//! block's). The pulse of frequency `omega_p` lasts
//!
//! | pulse | duration t_d | acceleration (s = t - start) |
//! |---|---|---|
//! | rectangular | `pi / omega_p` (as a half-sine of the same omega_p; `p t_d = pi / Pi`) | `a_p` |
//! | half-sine | `pi / omega_p` | `a_p sin(omega_p s)` |
//! | one-sine | `2 pi / omega_p` | `a_p sin(omega_p s)` |
//! | one-cosine | `2 pi / omega_p` | `a_p cos(omega_p s)` |
//! | ricker | `3 T_p`, `T_p = 2 pi / omega_p` | Ricker wavelet of period `T_p` (docs/scene-format.md) |
//!
//! A run lasts `t_d + tail / p` (default tail 30). It overturns when [`events::overturning`]
//! says so for any block (rotation relative to its support, critical angle atan(B/H) of that
//! block); an overturn "without impact" has no impact of that block before it (the Housner
//! engine's own impacts, else [`events::impacts`] of the samples).
//!
//! **Minimum overturning amplitude** at each ratio: the overturn/safe boundary is not
//! monotone in A (safe regions above the minimum for one-sine and one-cosine pulses), so the
//! search first scans upward from `scan_from` (default 1, below which a block does not rock)
//! by factors `1 + scan_step` (default 5 %) to the first amplitude that overturns, then bisects
//! between it and the safe scan point below to a relative width `tolerance` (default 1e-4).
//! The result is the lowest amplitude found to overturn (the bracket's upper end); an
//! overturning band narrower than one scan step below it would be missed. If the first scan
//! point already overturns the scan steps down first, through safe bands to A = 1 when it
//! starts above it, to the lowest overturning scan point.
//!
//! **Early stop** (opt-in, on for `rockbench spectrum`, native engine only; every stop is
//! recorded with its reason): after the pulse has ended a native run stops when a block lies on
//! its side (overturned; beyond its critical angle turning outwards is not enough: in flight or
//! sliding a block can land on its corner and turn back), when every block has been still for
//! [`REST_WINDOW`] (at rest), or, for a single
//! block inside its critical angle, when its mechanical energy above the upright block's rest (whatever tilt the scene starts from) is below
//! [`SAFE_ENERGY_FRACTION`] of the tipping barrier `m g (R - H/2)` (free rocking only loses
//! energy, so it cannot overturn later). The Housner engine is cheap enough to run to the
//! end; the other engines run their full duration through [`Engine::run`].

use crate::engines::native::REST_WINDOW;
use crate::engines::{Engine, EngineError, engine_by_name};
use crate::events;
use crate::excitation::GroundMotion;
use crate::scene::{ExcitationSpec, MotionSpec, Scene, num};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;
use std::time::Instant;

/// A single block below this fraction of its tipping energy after the pulse is safe (early stop).
pub const SAFE_ENERGY_FRACTION: f64 = 0.9;

/// Pulse families of the spectra.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pulse {
    Rectangular,
    HalfSine,
    OneSine,
    OneCosine,
    Ricker,
}

pub const PULSE_NAMES: &str = "rectangular, half-sine, one-sine, one-cosine, ricker";

impl Pulse {
    pub fn parse(s: &str) -> Result<Pulse, String> {
        Ok(match s {
            "rectangular" => Pulse::Rectangular,
            "half-sine" => Pulse::HalfSine,
            "one-sine" => Pulse::OneSine,
            "one-cosine" => Pulse::OneCosine,
            "ricker" => Pulse::Ricker,
            other => return Err(format!("unknown pulse `{other}` (known: {PULSE_NAMES})")),
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Pulse::Rectangular => "rectangular",
            Pulse::HalfSine => "half-sine",
            Pulse::OneSine => "one-sine",
            Pulse::OneCosine => "one-cosine",
            Pulse::Ricker => "ricker",
        }
    }

    /// Duration of the pulse (the Ricker wavelet's window), s, at frequency `omega_p`.
    pub fn duration(self, omega_p: f64) -> f64 {
        match self {
            Pulse::Rectangular | Pulse::HalfSine => PI / omega_p,
            Pulse::OneSine | Pulse::OneCosine => 2.0 * PI / omega_p,
            Pulse::Ricker => crate::excitation::RICKER_WINDOW * 2.0 * PI / omega_p,
        }
    }

    /// The scene's excitation of amplitude `a_p` (m/s^2) and frequency `omega_p` (1/s).
    pub fn motion(self, a_p: f64, omega_p: f64) -> MotionSpec {
        let d = self.duration(omega_p);
        match self {
            Pulse::Rectangular => MotionSpec::Rectangular {
                amplitude: a_p,
                duration: d,
                start: 0.0,
            },
            Pulse::HalfSine => MotionSpec::HalfSine {
                amplitude: a_p,
                duration: Some(d),
                period: None,
                start: 0.0,
            },
            Pulse::OneSine => MotionSpec::OneSine {
                amplitude: a_p,
                duration: Some(d),
                period: None,
                start: 0.0,
            },
            Pulse::OneCosine => MotionSpec::OneCosine {
                amplitude: a_p,
                duration: Some(d),
                period: None,
                start: 0.0,
            },
            Pulse::Ricker => MotionSpec::Ricker {
                amplitude: a_p,
                period: 2.0 * PI / omega_p,
                start: 0.0,
            },
        }
    }
}

/// Root of a function increasing through zero on [lo, hi], by bisection to 1e-13.
fn root(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    while hi - lo > 1e-13 * hi {
        let m = 0.5 * (lo + hi);
        if f(m) < 0.0 { lo = m } else { hi = m }
    }
    0.5 * (lo + hi)
}

/// Closed forms of the linearised slender block (VULNERABILITY.md), at `Pi = omega_p / p`:
/// the rectangular pulse's and the half-sine's minimum overturning amplitude and the one-sine
/// pulse's boundary of overturning without impact; `None` for the other pulses.
pub fn closed_form(pulse: Pulse, ratio: f64) -> Option<f64> {
    match pulse {
        Pulse::Rectangular => Some(1.0 / (1.0 - (-PI / ratio).exp())),
        Pulse::HalfSine => Some(root(
            |a| a - (ratio - (a * a - 1.0).sqrt()) * ((PI - (1.0 / a).asin()) / ratio).exp(),
            1.0,
            1e4,
        )),
        Pulse::OneSine => Some(root(
            |a| ((a * a - 1.0).sqrt() - ratio) * ((2.0 * PI - (1.0 / a).asin()) / ratio).exp() - a,
            1.0,
            1e4,
        )),
        _ => None,
    }
}

/// What the closed form of [`closed_form`] is a boundary of.
pub fn closed_form_kind(pulse: Pulse) -> Option<&'static str> {
    match pulse {
        Pulse::Rectangular | Pulse::HalfSine => Some("minimum overturning amplitude"),
        Pulse::OneSine => Some("overturning without impact"),
        _ => None,
    }
}

/// p and alpha of the bottom block.
pub fn p_alpha(scene: &Scene) -> (f64, f64) {
    let b = &scene.blocks[0];
    let r = (b.width / 2.0).hypot(b.height / 2.0);
    (
        (3.0 * scene.gravity / (4.0 * r)).sqrt(),
        (b.width / b.height).atan(),
    )
}

/// Search and run settings.
#[derive(Debug, Clone, Serialize)]
pub struct Settings {
    /// Run length after the pulse, in units of 1/p.
    pub tail: f64,
    /// Relative width of the final bisection bracket.
    pub tolerance: f64,
    /// First amplitude A of the upward scan.
    pub scan_from: f64,
    /// Relative step of the scan.
    pub scan_step: f64,
    /// Largest amplitude A scanned.
    pub scan_to: f64,
    /// Early stop of native runs (see the module docs).
    pub early_stop: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            tail: 30.0,
            tolerance: 1e-4,
            scan_from: 1.0,
            scan_step: 0.05,
            scan_to: 100.0,
            early_stop: true,
        }
    }
}

/// The tail beyond `ln(1 / tolerance)`, in units of 1/p, that a spectrum's runs must have.
const TAIL_MARGIN: f64 = 3.0;

/// The amplitude below which the downward scan stops: a minimum under it is reported as 0.
const SCAN_FLOOR: f64 = 1e-3;

/// The largest p dt of the native engine's step a spectrum takes (see [`Spectrum::check_step`]).
pub const MAX_P_DT: f64 = 0.02;

/// A = 1 (a_p = g tan(alpha)): below it a single block at rest does not start to rock. A scan
/// that starts above it and overturns there scans down through safe amplitudes to it.
const ROCKING_ONSET: f64 = 1.0;

impl Settings {
    /// One line naming a bad setting.
    pub fn check(&self) -> Result<(), String> {
        let pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number (got {})", num(x)))
            }
        };
        pos("--tail", self.tail)?;
        pos("--tolerance", self.tolerance)?;
        pos("--scan-from", self.scan_from)?;
        pos("--scan-step", self.scan_step)?;
        if !self.scan_to.is_finite() || self.scan_to <= self.scan_from {
            return Err(format!(
                "--scan-to must be finite and exceed --scan-from (got {} and {})",
                num(self.scan_to),
                num(self.scan_from)
            ));
        }
        // The scan moves by factors (1 + scan_step): up to `scan_to`, or down to 1e-3 (`minimum`).
        let factors = |from: f64, to: f64| (to / from).ln().max(0.0) / self.scan_step.ln_1p();
        let scans = factors(self.scan_from, self.scan_to).max(factors(SCAN_FLOOR, self.scan_from));
        if scans > MAX_POINTS as f64 {
            return Err(format!(
                "--scan-step {}: {} scan points by factors (1 + scan-step) from --scan-from to --scan-to (or down to {SCAN_FLOOR}); at most {MAX_POINTS} (each is a run)",
                num(self.scan_step),
                num(scans.ceil())
            ));
        }
        if self.tolerance < MIN_TOLERANCE {
            return Err(format!(
                "--tolerance must be at least {MIN_TOLERANCE:e} (got {}): a narrower bracket is below the bisection's floating-point resolution",
                num(self.tolerance)
            ));
        }
        if self.tolerance >= self.scan_step {
            return Err(format!(
                "--tolerance {} must be below --scan-step {}",
                num(self.tolerance),
                num(self.scan_step)
            ));
        }
        // A run within the tolerance of the boundary leaves the unstable equilibrium as
        // exp(p t): it overturns some ln(1 / tolerance) / p after the pulse, and a shorter run
        // calls it safe (a half-sine minimum at omega_p / p = 2 came out 1.80270 at --tail 3
        // and 1.87881 at 1, against 1.80129 from 5 to 30).
        let shortest = (1.0 / self.tolerance).ln() + TAIL_MARGIN;
        if self.tail < shortest {
            return Err(format!(
                "--tail {}: runs within --tolerance {} of the boundary take some ln(1 / tolerance) = {:.1} / p to overturn after the pulse; the tail must be at least {:.1} (in units of 1/p)",
                num(self.tail),
                num(self.tolerance),
                (1.0 / self.tolerance).ln(),
                shortest
            ));
        }
        Ok(())
    }
}

/// The most points a range (`from:to:n`) or a scan may have: each is at least one run.
pub const MAX_POINTS: usize = 100_000;

/// The narrowest relative bracket of a minimum's bisection (some 4500 times the floating-point
/// resolution; a narrower one was never reached, the search never ended).
pub const MIN_TOLERANCE: f64 = 1e-12;

/// Why a run ended (spectra and fragility studies alike).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// The full duration was run.
    End,
    /// Early stop: a single block beyond its critical angle, turning outwards, after the pulse;
    /// in an assembly, a block on its side.
    Overturned,
    /// Early stop: every block still for the rest window after the pulse.
    AtRest,
    /// Early stop: a single block below the safe fraction of its tipping energy after the pulse.
    BelowTippingEnergy,
}

impl Stop {
    /// Whether a block whose rotation relative to its support ends at `last` overturned by
    /// this stop's word: the stop says overturned and the block is on its side, or is the
    /// scene's single block beyond its critical angle `alpha` (the stop is made there; the
    /// samples end there, and a slender block turns too slowly there for
    /// [`events::overturning`], which ends at the rest threshold, to call it overturned yet).
    pub fn overturns(self, last: f64, blocks: usize, alpha: f64) -> bool {
        self == Stop::Overturned
            && (last.abs() >= std::f64::consts::FRAC_PI_2 - events::ON_SIDE_TOLERANCE
                || (blocks == 1 && last.abs() > alpha))
    }

    pub fn name(self) -> &'static str {
        match self {
            Stop::End => "end",
            Stop::Overturned => "overturned",
            Stop::AtRest => "at-rest",
            Stop::BelowTippingEnergy => "below-tipping-energy",
        }
    }
}

/// The outcome of one run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Outcome {
    pub amplitude: f64,
    pub overturned: bool,
    /// Overturned with no impact of the overturning block before it.
    pub without_impact: bool,
    /// p times the overturn time (the last upward crossing of the critical angle).
    pub p_t_overturn: Option<f64>,
    pub stop: Stop,
    /// p times the time the run ended.
    pub p_t_end: f64,
}

/// One block or stack, an engine, and a pulse family: runs at (ratio, amplitude).
pub struct Spectrum<'a> {
    pub base: &'a Scene,
    pub engine: &'a dyn Engine,
    pub pulse: Pulse,
    pub settings: &'a Settings,
    pub p: f64,
    pub alpha: f64,
    /// Engine settings and version of the last run.
    pub engine_settings: std::cell::RefCell<Option<EngineReport>>,
    /// The run store ([`crate::run_store`]) the runs are read from and kept in, if any.
    pub store: Option<&'a Path>,
    /// Runs read from the store.
    pub from_store: std::cell::Cell<usize>,
}

/// Bumped when the meaning of a stored spectrum run changes.
const STORE_FORMAT: u32 = 1;

/// A spectrum run as kept in the run store: its outcome and, for the runs that report them,
/// the engine's settings and version.
#[derive(Serialize, Deserialize)]
struct StoredRun {
    outcome: Outcome,
    engine_settings: Option<EngineReport>,
}

impl StoredRun {
    /// Whether a stored run can be the run at `amplitude`: that amplitude, finite times in
    /// order, no overturn time without an overturn (an entry edited or damaged on disk, read
    /// as it was, put an amplitude of -7 and negative times in map.csv).
    fn plausible(&self, amplitude: f64) -> bool {
        let o = &self.outcome;
        o.amplitude.to_bits() == amplitude.to_bits()
            && o.p_t_end.is_finite()
            && o.p_t_end >= 0.0
            && o.p_t_overturn
                .is_none_or(|t| t.is_finite() && (0.0..=o.p_t_end).contains(&t) && o.overturned)
            && (o.overturned || !o.without_impact)
    }
}

/// An engine's settings and version, as a run reports them.
pub type EngineReport = (serde_json::Value, String);

impl<'a> Spectrum<'a> {
    pub fn new(
        base: &'a Scene,
        engine: &'a dyn Engine,
        pulse: Pulse,
        settings: &'a Settings,
    ) -> Self {
        let (p, alpha) = p_alpha(base);
        Spectrum {
            base,
            engine,
            pulse,
            settings,
            p,
            alpha,
            engine_settings: std::cell::RefCell::new(None),
            store: None,
            from_store: std::cell::Cell::new(0),
        }
    }

    /// The same, its runs read from the run store `dir` when there and kept in it when made.
    pub fn with_store(mut self, dir: Option<&'a Path>) -> Self {
        self.store = dir;
        self
    }

    /// The scene of one run: the base scene (its initial state kept) with the pulse as its
    /// horizontal excitation.
    pub fn scene(&self, ratio: f64, amplitude: f64) -> Scene {
        let omega_p = ratio * self.p;
        let a_p = amplitude * self.base.gravity * self.alpha.tan();
        let mut s = self.base.clone();
        let applied_as = s.applied_as();
        s.excitation = Some(ExcitationSpec {
            applied_as,
            horizontal: Some(self.pulse.motion(a_p, omega_p)),
            vertical: None,
        });
        s.duration = self.pulse.duration(omega_p) + self.settings.tail / self.p;
        s.name = format!(
            "{} {} Pi={} A={}",
            self.base.name,
            self.pulse.name(),
            num(ratio),
            num(amplitude)
        );
        s
    }

    /// The native engine's step against the block's time scale 1/p: the minima converge at
    /// second order in p dt, and on small blocks the default step is coarse (p dt = 0.086, a
    /// 2 mm block at 1 ms, put a half-sine minimum 1.9 % above Housner's and a one-cosine one,
    /// which has no closed form to flag it, 0.7 %). At most [`MAX_P_DT`], some 0.1 %.
    pub fn check_step(&self) -> Result<(), String> {
        // An engine that cannot model the block at all says so before any engine runs (the
        // native engine's slenderness bound came after Housner's whole search).
        if let Some(reason) = self.engine.cannot_model(self.base) {
            return Err(format!(
                "engine {} cannot model `{}`: {reason}",
                self.engine.name(),
                self.base.name
            ));
        }
        if self.engine.name() != "native" {
            return Ok(());
        }
        let dt = crate::native::settings_of(self.base)
            .map_err(|e| e.to_string())?
            .dt;
        if self.p * dt > MAX_P_DT {
            return Err(format!(
                "native.dt {}: p dt = {:.3} (p = {:.4} 1/s) is above {MAX_P_DT}: the step resolves the block's rocking coarsely (the minima err by some (p dt)^2 x 2.6); give --set native.dt={:.1e} or less",
                num(dt),
                self.p * dt,
                self.p,
                MAX_P_DT / self.p
            ));
        }
        Ok(())
    }

    /// The longest run of these ratios (the lowest: the longest pulse, then the tail) checked as
    /// a scene, so that a run too long for a step's count is one line naming `--tail` and `p`
    /// before any run, not an engine's setting at its first run.
    pub fn check_longest_run<'r>(
        &self,
        ratios: impl Iterator<Item = &'r f64>,
    ) -> Result<(), String> {
        let Some(lowest) = ratios.copied().reduce(f64::min) else {
            return Ok(());
        };
        // No amplitude: the run's length is the subject here ([`check_largest_amplitude`]).
        let scene = self.scene(lowest, 0.0);
        crate::engines::registry::check(&scene).map_err(|e| {
            format!(
                "--tail {}: the longest run, {} at omega_p/p = {}, lasts {:e} s (the pulse, then --tail / p with p = {:e} 1/s), too long: {}: {}",
                num(self.settings.tail),
                self.pulse.name(),
                num(lowest),
                scene.duration,
                self.p,
                e.field,
                e.message
            )
        })
    }

    /// Run at (ratio, amplitude) and decide.
    pub fn run(&self, ratio: f64, amplitude: f64) -> Result<Outcome, EngineError> {
        let scene = self.scene(ratio, amplitude);
        let key = self.store.map(|dir| {
            let key = crate::run_store::key(
                self.engine.name(),
                serde_json::json!({
                    "kind": "spectrum-run",
                    "format": STORE_FORMAT,
                    "scene": scene.to_json(),
                    "early_stop": self.settings.early_stop,
                }),
            );
            (dir, key)
        });
        let stored = key
            .as_ref()
            .and_then(|(dir, key)| crate::run_store::load::<StoredRun>(dir, key))
            .filter(|s| s.plausible(amplitude));
        let run = match stored {
            Some(stored) => {
                self.from_store.set(self.from_store.get() + 1);
                stored
            }
            None => {
                // No run starts once a Ctrl-C has come (`rockbench spectrum`).
                if crate::interrupt::requested() {
                    return Err(EngineError::Interrupted {
                        engine: self.engine.name(),
                        t: 0.0,
                    });
                }
                let (outcome, engine_settings) = self.simulate(&scene, amplitude)?;
                let run = StoredRun {
                    outcome,
                    engine_settings,
                };
                if let Some((dir, key)) = &key {
                    crate::run_store::store(dir, key, &run)
                        .map_err(|e| EngineError::Io(format!("the run store: {e}")))?;
                }
                run
            }
        };
        // The last run that reports its engine's settings and version sets them.
        if run.engine_settings.is_some() {
            *self.engine_settings.borrow_mut() = run.engine_settings;
        }
        Ok(run.outcome)
    }

    /// One run made (not read from the store): its outcome, and its engine's settings and
    /// version where the engine reports them (not the early-stopped native and Housner runs).
    fn simulate(
        &self,
        scene: &Scene,
        amplitude: f64,
    ) -> Result<(Outcome, Option<EngineReport>), EngineError> {
        let mut reported = None;
        let early = self.settings.early_stop;
        let (tr, exact, stop) = if self.engine.name() == "native" && early {
            let (tr, stop) = native_early_stop(scene)?;
            (tr, None, stop)
        } else if self.engine.name() == "housner" && early && scene.blocks.len() == 1 {
            let (tr, impacts, stop) = housner_early_stop(scene, false)?;
            (tr, Some(vec![impacts]), stop)
        } else {
            let out = self
                .engine
                .run_reporting(scene, &crate::interrupt::go_on_unless_interrupted)?;
            if !out.trajectory.is_finite() {
                return Err(EngineError::Failed {
                    engine: self.engine.name(),
                    message: "the trajectory contains NaN or infinity".into(),
                });
            }
            reported = Some((out.settings.clone(), out.engine_version.clone()));
            (out.trajectory, out.exact_impacts, Stop::End)
        };
        let layout = scene.layout();
        let mut first: Option<(f64, bool)> = None;
        for (i, b) in scene.blocks.iter().enumerate() {
            let (rel, rate) = tr.rotation(i, layout.supports[i]);
            let h = events::History::new(&tr.t, &rel, &rate);
            let alpha = (b.width / b.height).atan();
            let (mut over, mut t_over) = events::overturning(&h, alpha);
            if !over
                && let Some(&last) = rel.last()
                && stop.overturns(last, scene.blocks.len(), alpha)
            {
                // The last crossing of the critical angle, else the stop.
                over = true;
                t_over = (1..rel.len())
                    .rev()
                    .find(|&k| rel[k - 1].abs() <= alpha && rel[k].abs() > alpha)
                    .map(|k| {
                        let w = (alpha - rel[k - 1].abs()) / (rel[k].abs() - rel[k - 1].abs());
                        tr.t[k - 1] + w * (tr.t[k] - tr.t[k - 1])
                    })
                    .or(tr.t.last().copied());
            }
            if !over {
                continue;
            }
            let t_over = t_over.unwrap_or(f64::INFINITY);
            let impacts = match &exact {
                Some(e) => e[i].clone(),
                None => events::impacts(&h, events::NOISE_FLOOR, &[]),
            };
            let clean = impacts.iter().all(|&t| t >= t_over);
            if first.is_none_or(|(t, _)| t_over < t) {
                first = Some((t_over, clean));
            }
        }
        let outcome = Outcome {
            amplitude,
            overturned: first.is_some(),
            without_impact: first.is_some_and(|(_, c)| c),
            p_t_overturn: first.map(|(t, _)| t * self.p),
            stop,
            p_t_end: tr.t.last().copied().unwrap_or(0.0) * self.p,
        };
        Ok((outcome, reported))
    }

    /// Lowest amplitude at `ratio` for which `pred` holds (see the module docs): the bracket
    /// (safe, holds) and the runs made.
    pub fn minimum(
        &self,
        ratio: f64,
        pred: impl Fn(&Outcome) -> bool,
    ) -> Result<Minimum, EngineError> {
        let st = self.settings;
        let f = 1.0 + st.scan_step;
        let mut runs = 0usize;
        let mut test = |a: f64| -> Result<bool, EngineError> {
            runs += 1;
            Ok(pred(&self.run(ratio, a)?))
        };
        let (mut lo, mut hi);
        if test(st.scan_from)? {
            // Step down to a safe amplitude, and on down through safe bands to the amplitude
            // below which a block at rest does not rock (when the scan starts above it): an
            // overturning band lower down is the minimum (stopping at the first safe amplitude
            // reported 2.35 for a one-sine pulse whose minimum is 1.22).
            hi = st.scan_from;
            let scan_safe_down_to = if st.scan_from > ROCKING_ONSET {
                ROCKING_ONSET
            } else {
                f64::INFINITY
            };
            let mut a = hi;
            loop {
                a /= f;
                if test(a)? {
                    hi = a;
                    if a < SCAN_FLOOR {
                        return Ok(Minimum::found(ratio, 0.0, hi, runs));
                    }
                } else if a < scan_safe_down_to {
                    break;
                }
            }
            // The scan point below the lowest that overturns, found safe.
            lo = hi / f;
        } else {
            lo = st.scan_from;
            hi = lo * f;
            while !test(hi)? {
                lo = hi;
                hi *= f;
                if hi > st.scan_to {
                    return Ok(Minimum {
                        ratio,
                        amplitude: None,
                        safe_below: lo,
                        runs,
                    });
                }
            }
        }
        while (hi - lo) / hi > st.tolerance {
            let mid = 0.5 * (lo + hi);
            if test(mid)? { hi = mid } else { lo = mid }
        }
        Ok(Minimum::found(ratio, lo, hi, runs))
    }

    /// The overturn/safe map on a grid.
    pub fn map(
        &self,
        ratios: &[f64],
        amplitudes: &[f64],
    ) -> Result<Vec<(f64, Outcome)>, EngineError> {
        let mut out = Vec::new();
        for &r in ratios {
            for &a in amplitudes {
                out.push((r, self.run(r, a)?));
            }
        }
        Ok(out)
    }
}

/// Curves of [`similarity`]: p t and phi/alpha of the two scenes.
pub type Similarity = (Vec<f64>, Vec<f64>, Vec<f64>);

/// The similarity law (Dimitrakopoulos & DeJong 2012): `phi/alpha` of the bottom block against
/// `p t` of two scenes driven by the same pulse at the same `Pi` and `A` (full runs, no early
/// stop), on a common grid of `n` points over `[0, p t_d + tail]`: (p t, curve of `a`, curve of
/// `b`). The samples are interpolated linearly.
pub fn similarity(
    a: &Scene,
    b: &Scene,
    engine: &dyn Engine,
    (pulse, ratio, amplitude): (Pulse, f64, f64),
    settings: &Settings,
    n: usize,
) -> Result<Similarity, EngineError> {
    let curve = |s: &Scene| -> Result<(Vec<f64>, Vec<f64>, f64), EngineError> {
        let sp = Spectrum::new(s, engine, pulse, settings);
        let scene = sp.scene(ratio, amplitude);
        let out = engine.run_reporting(&scene, &crate::interrupt::go_on_unless_interrupted)?;
        let b = &out.trajectory.blocks[0];
        let pt: Vec<f64> = out.trajectory.t.iter().map(|t| t * sp.p).collect();
        let y: Vec<f64> = b.phi.iter().map(|x| x / sp.alpha).collect();
        let end = scene.duration * sp.p;
        Ok((pt, y, end))
    };
    let (xa, ya, ea) = curve(a)?;
    let (xb, yb, eb) = curve(b)?;
    let end = ea.min(eb);
    let grid: Vec<f64> = (0..n).map(|k| end * k as f64 / (n - 1) as f64).collect();
    let interp = |x: &[f64], y: &[f64], t: f64| -> f64 {
        let k = x.partition_point(|&s| s <= t).clamp(1, x.len() - 1);
        let f = ((t - x[k - 1]) / (x[k] - x[k - 1])).clamp(0.0, 1.0);
        y[k - 1] + f * (y[k] - y[k - 1])
    };
    let ga = grid.iter().map(|&t| interp(&xa, &ya, t)).collect();
    let gb = grid.iter().map(|&t| interp(&xb, &yb, t)).collect();
    Ok((grid, ga, gb))
}

/// The result of a minimum search at one ratio.
#[derive(Debug, Clone, Serialize)]
pub struct Minimum {
    pub ratio: f64,
    /// The lowest amplitude found to overturn; `None`: nothing overturned up to `scan_to`.
    pub amplitude: Option<f64>,
    /// The highest amplitude below it found safe.
    pub safe_below: f64,
    pub runs: usize,
}

impl Minimum {
    fn found(ratio: f64, lo: f64, hi: f64, runs: usize) -> Minimum {
        Minimum {
            ratio,
            amplitude: Some(hi),
            safe_below: lo,
            runs,
        }
    }
}

/// The native engine's stepping (as [`crate::engines::native::NativeEngine`], sampling every
/// step), with the early stops of the module docs.
pub fn native_early_stop(scene: &Scene) -> Result<(Trajectory, Stop), EngineError> {
    let failed = |m: String| EngineError::Failed {
        engine: "native",
        message: m,
    };
    let (mut stepper, mut state) = crate::native::stepper_for(scene)?;
    let ns = stepper.settings.clone();
    let dt = ns.dt;
    let n_steps = ((scene.duration / dt - 1e-9).ceil() as u64).max(1);
    let names: Vec<String> = scene.blocks.iter().map(|b| b.name.clone()).collect();
    let mut tr = Trajectory::new(&names);
    tr.push(0.0, &stepper.relative_states(&state));
    let pulse_end = GroundMotion::from_scene(scene)?
        .breakpoints()
        .last()
        .copied()
        .unwrap_or(0.0);
    let layout = scene.layout();
    let crit: Vec<f64> = scene.blocks.iter().map(|b| b.critical_angle()).collect();
    let window = (REST_WINDOW / dt).ceil() as u64;
    let mut still = 0u64;
    let single = scene.blocks.len() == 1;
    let b0 = &scene.blocks[0];
    // The energy is measured from the upright block's rest, not from the scene's start (a
    // tilted start sits above it).
    let z_rest = layout.upright[0].1;
    let barrier = b0.tipping_energy_per_mass(scene.gravity);
    for k in 1..=n_steps {
        stepper
            .step(&mut state)
            .map_err(|e| failed(e.to_string()))?;
        state.t = k as f64 * dt;
        let states = stepper.relative_states(&state);
        tr.push(state.t, &states);
        if !states.iter().flatten().all(|x| x.is_finite()) {
            return Err(failed("the trajectory contains NaN or infinity".into()));
        }
        let rel = layout.relative_rotations(&states);
        if state.t > pulse_end {
            // A block lying on its side has overturned ([`events::overturning`]). Beyond its
            // critical angle and turning outwards is not enough, even for one block on the
            // ground: in flight, or sliding, it can land on its corner and turn back.
            if rel.iter().any(|&(phi, _)| {
                phi.abs() >= std::f64::consts::FRAC_PI_2 - events::ON_SIDE_TOLERANCE
            }) {
                return Ok((tr, Stop::Overturned));
            }
            let v = ns.rest_velocity;
            let is_still = states.iter().zip(&scene.blocks).all(|(st, b)| {
                st[3].abs() < v && st[4].abs() < v && (st[5] * b.width.max(b.height)).abs() < v
            });
            still = if is_still { still + 1 } else { 0 };
            if still >= window {
                return Ok((tr, Stop::AtRest));
            }
            if single
                && rel[0].0.abs() < crit[0]
                && b0.energy_per_mass(&states[0], scene.gravity, z_rest)
                    < SAFE_ENERGY_FRACTION * barrier
            {
                {
                    return Ok((tr, Stop::BelowTippingEnergy));
                }
            }
        }
    }
    Ok((tr, Stop::End))
}

/// The Housner engine's integration ([`crate::engines::housner::integrate`], the engine's settings) through
/// the pulse, then free rocking in chunks of 1/p with the early stops of the module docs
/// checked between chunks. Returns the trajectory (the engine's centroid states), the impact
/// instants above the noise floor and the stop.
///
/// With `exact_peak` a run stops below its tipping energy only once the angle that energy can
/// reach is no larger than the largest |theta| sampled, so that the run's largest rotation is
/// that of its run to the end (a fragility study's rotation limit states); without it, as soon
/// as the energy is below the fraction (the overturning verdict alone).
pub fn housner_early_stop(
    scene: &Scene,
    exact_peak: bool,
) -> Result<(Trajectory, Vec<f64>, Stop), EngineError> {
    use crate::engines::housner::{self, HousnerBlock, HousnerEngine, Span};
    if let Some(reason) = HousnerEngine.cannot_model(scene) {
        return Err(EngineError::Unsupported {
            engine: "housner",
            scene: scene.name.clone(),
            reason,
        });
    }
    let gm = GroundMotion::from_scene(scene)?;
    let b = &scene.blocks[0];
    let hs = housner::HousnerSettings::of(scene)?;
    let blk = HousnerBlock::new(b.width, b.height, scene.gravity, hs.restitution);
    let step = housner::housner_step(&blk, &hs);
    let span = |duration: f64| Span {
        duration,
        output_interval: scene.output_interval,
        max_step: step,
        event_tolerance: hs.event_tolerance,
    };
    let pulse_end = gm.breakpoints().last().copied().unwrap_or(0.0);
    let chunk = (1.0 / blk.p2.sqrt()).max(scene.output_interval);
    let mut tr = Trajectory::new(std::slice::from_ref(&b.name));
    let mut impacts = Vec::new();
    let z_rest = 0.5 * b.height;
    let barrier = b.tipping_energy_per_mass(scene.gravity);
    let free = GroundMotion::default();
    // From the scene's start (a tilt or a rotation rate a scene file gives), as the engine.
    let start = scene.layout().blocks[0];
    let (mut t0, mut state) = (0.0, (start.phi, start.omega));
    let mut first = true;
    let mut peak = 0.0f64;
    loop {
        let len = if first {
            pulse_end.min(scene.duration)
        } else {
            chunk.min(scene.duration - t0)
        };
        let run = housner::integrate(&blk, if first { &gm } else { &free }, state, span(len));
        for (k, (t, s)) in run.trajectory.iter().enumerate() {
            if k > 0 || first {
                tr.push(t0 + t, &[*s]);
                peak = peak.max(s[2].abs());
            }
        }
        impacts.extend(
            run.impacts
                .iter()
                .filter(|(_, amp)| *amp >= events::NOISE_FLOOR)
                .map(|(t, _)| t0 + t),
        );
        first = false;
        t0 += len;
        let s = run.trajectory.last().expect("one sample").1;
        let (th, om) = (s[2], s[5]);
        state = (th, om);
        if t0 >= scene.duration - 1e-12 {
            return Ok((tr, impacts, Stop::End));
        }
        if th.abs() >= std::f64::consts::FRAC_PI_2 - events::ON_SIDE_TOLERANCE
            || (th.abs() > blk.alpha && th * om > 0.0)
        {
            return Ok((tr, impacts, Stop::Overturned));
        }
        if th == 0.0 && om == 0.0 {
            return Ok((tr, impacts, Stop::AtRest));
        }
        if th.abs() < blk.alpha
            && b.energy_per_mass(&s, scene.gravity, z_rest) < SAFE_ENERGY_FRACTION * barrier
            && (!exact_peak || b.reachable_angle(&s, scene.gravity, z_rest) <= peak)
        {
            return Ok((tr, impacts, Stop::BelowTippingEnergy));
        }
    }
}

/// The engine's name, checked (one line for an unknown one).
pub fn engine(name: &str) -> Result<Box<dyn Engine>, String> {
    engine_by_name(name).map_err(|e| e.to_string())
}

/// Parse a block given as `BxH` (metres), e.g. `0.2x4`.
pub fn parse_block(s: &str) -> Option<(f64, f64)> {
    let (b, h) = s.split_once(['x', 'X'])?;
    let (b, h) = (b.trim().parse::<f64>().ok()?, h.trim().parse::<f64>().ok()?);
    Some((b, h))
}

/// The scene of a single block `B x H` on the ground with the given friction.
pub fn block_scene(
    width: f64,
    height: f64,
    friction: f64,
    overrides: &[String],
) -> Result<Scene, String> {
    let (w, h) = (num(width), num(height));
    if !(width.is_finite() && width > 0.0 && height.is_finite() && height > 0.0) {
        return Err(format!("a block is BxH with B, H > 0 metres (got {w}x{h})"));
    }
    let text = format!(
        "name = \"block {w}x{h}\"\nduration = 1.0\n\n[[blocks]]\nname = \"block\"\nwidth = {width:?}\nheight = {height:?}\n\n[contact]\nfriction = {friction:?}\n"
    );
    let s = crate::scene::parse_scene_str(&text, false, "block", overrides)
        .map_err(|e| e.to_string())?;
    crate::engines::registry::check(&s).map_err(|e| e.to_string())?;
    Ok(s)
}

/// Parse a list of positive numbers `a,b,c` or a range `from:to:n` (n points, linear).
pub fn parse_list(s: &str, what: &str) -> Result<Vec<f64>, String> {
    let bad = |x: &str| format!("{what}: `{x}` is not a positive number");
    let v: Vec<f64> = if let [a, b, n] = s.split(':').collect::<Vec<_>>()[..] {
        let a: f64 = a.trim().parse().map_err(|_| bad(a))?;
        let b: f64 = b.trim().parse().map_err(|_| bad(b))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("{what}: `{n}` is not a whole number of points"))?;
        if n < 2 {
            return Err(format!("{what}: a range needs at least 2 points (got {n})"));
        }
        if n > MAX_POINTS {
            return Err(format!(
                "{what}: a range of at most {MAX_POINTS} points (got {n}): each is at least one run"
            ));
        }
        (0..n)
            .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
            .collect()
    } else {
        s.split(',')
            .map(|x| x.trim().parse::<f64>().map_err(|_| bad(x)))
            .collect::<Result<_, _>>()?
    };
    if v.is_empty() {
        return Err(format!("{what}: empty list"));
    }
    if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
        return Err(format!("{what} must be finite and > 0 (got {})", num(*x)));
    }
    Ok(v)
}

/// A whole spectrum: pulses x engines, minimum curves and maps.
#[derive(Debug, Clone)]
pub struct Request {
    pub pulses: Vec<Pulse>,
    pub engines: Vec<String>,
    /// Ratios of the minimum search.
    pub ratios: Vec<f64>,
    /// The map grid (empty: no map).
    pub map_ratios: Vec<f64>,
    pub map_amplitudes: Vec<f64>,
    /// Also search the lowest amplitude that overturns without impact.
    pub no_impact: bool,
    pub settings: Settings,
    /// The run store the runs are read from and kept in (`None`: every run is made).
    pub store: Option<std::path::PathBuf>,
}

impl Request {
    /// One line naming a pulse, an engine, a ratio or an amplitude given twice (each would be
    /// computed again and written twice).
    pub fn check_lists(&self) -> Result<(), String> {
        fn twice<T: PartialEq + std::fmt::Display>(what: &str, list: &[T]) -> Result<(), String> {
            for (k, x) in list.iter().enumerate() {
                if list[..k].contains(x) {
                    return Err(format!("{what}: {x} is given twice"));
                }
            }
            Ok(())
        }
        let pulses: Vec<&str> = self.pulses.iter().map(|p| p.name()).collect();
        twice("--pulse", &pulses)?;
        twice("--engines", &self.engines)?;
        twice("--ratios", &self.ratios)?;
        twice("--map-ratios", &self.map_ratios)?;
        twice("--amplitudes", &self.map_amplitudes)
    }
}

/// One minimum of one engine and pulse.
#[derive(Debug, Clone, Serialize)]
pub struct MinimumRow {
    pub engine: String,
    pub pulse: Pulse,
    pub ratio: f64,
    /// p t_d of the pulse.
    pub p_td: f64,
    /// Lowest amplitude that overturns, and the safe one below it.
    pub minimum: Minimum,
    /// Lowest amplitude that overturns without impact (with `no_impact`).
    pub without_impact: Option<Minimum>,
    pub closed_form: Option<f64>,
    pub wall_s: f64,
}

/// One cell of a map.
#[derive(Debug, Clone, Serialize)]
pub struct MapCell {
    pub engine: String,
    pub pulse: Pulse,
    pub ratio: f64,
    pub outcome: Outcome,
}

/// Everything a spectrum computed.
#[derive(Debug, Clone, Serialize)]
pub struct Results {
    pub minima: Vec<MinimumRow>,
    pub map: Vec<MapCell>,
    /// Engine -> (settings of its last run, version).
    pub engines: std::collections::BTreeMap<String, serde_json::Value>,
    pub p: f64,
    pub alpha: f64,
    pub wall_s: f64,
    /// Runs read from the run store rather than made.
    pub from_store: usize,
}

fn native_version() -> String {
    format!(
        "rockbench {} (clarabel {}, nalgebra {})",
        env!("CARGO_PKG_VERSION"),
        env!("RB_VERSION_CLARABEL"),
        env!("RB_VERSION_NALGEBRA")
    )
}

/// The largest amplitude a spectrum may run (the scan's highest, `--scan-to` or one factor above
/// `--scan-from`, and the map's) as a ground acceleration `a_p = A g tan(alpha)`: at most a
/// scene's [`crate::scene::MAX_PEAK_G`].
fn check_largest_amplitude(base: &Scene, req: &Request) -> Result<(), String> {
    let st = &req.settings;
    let largest = req.map_amplitudes.iter().copied().fold(
        st.scan_to.max(st.scan_from * (1.0 + st.scan_step)),
        f64::max,
    );
    let (_, alpha) = p_alpha(base);
    let unit = base.gravity * alpha.tan();
    let limit = crate::scene::MAX_PEAK_G * crate::excitation::records::STANDARD_GRAVITY;
    if largest * unit > limit {
        return Err(format!(
            "the largest amplitude scanned or mapped, {} g tan(alpha), is a ground acceleration of {} m/s^2 (g tan(alpha) = {} m/s^2), above {} g ({} m/s^2): lower --scan-to or --amplitudes",
            num(largest),
            num(largest * unit),
            num(unit),
            crate::scene::MAX_PEAK_G,
            num(limit)
        ));
    }
    Ok(())
}

/// Run a whole spectrum; `progress` gets one line per minimum and per map row.
pub fn compute(base: &Scene, req: &Request, progress: &dyn Fn(&str)) -> Result<Results, String> {
    // The closed forms are a single block's starting at rest: beside a stack's minimum, or a
    // tilted block's, they would be a meaningless error.
    let closed_forms_apply = base.blocks.len() == 1
        && base
            .layout()
            .blocks
            .iter()
            .all(|b| b.phi == 0.0 && b.omega == 0.0 && b.vx == 0.0 && b.vz == 0.0);
    req.settings.check()?;
    let start = Instant::now();
    let (p, alpha) = p_alpha(base);
    let mut res = Results {
        minima: Vec::new(),
        map: Vec::new(),
        engines: Default::default(),
        p,
        alpha,
        wall_s: 0.0,
        from_store: 0,
    };
    req.check_lists()?;
    // The strongest pulse and every engine's longest run under every pulse are checked before
    // any run.
    check_largest_amplitude(base, req)?;
    for name in &req.engines {
        let eng = engine(name)?;
        for &pulse in &req.pulses {
            let sp = Spectrum::new(base, eng.as_ref(), pulse, &req.settings);
            sp.check_step()?;
            sp.check_longest_run(req.ratios.iter().chain(&req.map_ratios))?;
        }
    }
    for name in &req.engines {
        let eng = engine(name)?;
        let fail = |e: EngineError| format!("{name}: {e}");
        let note = housner_sliding_note(name, base);
        if let Some(note) = &note {
            progress(&format!("{name}: {note}"));
        }
        for &pulse in &req.pulses {
            let sp = Spectrum::new(base, eng.as_ref(), pulse, &req.settings)
                .with_store(req.store.as_deref());
            let stored = |since: usize| match sp.from_store.get() - since {
                0 => String::new(),
                n => format!(", {n} from the store"),
            };
            for &r in &req.ratios {
                let t0 = Instant::now();
                let since = sp.from_store.get();
                let m = sp.minimum(r, |o| o.overturned).map_err(fail)?;
                let w = if req.no_impact {
                    Some(sp.minimum(r, |o| o.without_impact).map_err(fail)?)
                } else {
                    None
                };
                let row = MinimumRow {
                    engine: name.clone(),
                    pulse,
                    ratio: r,
                    p_td: pulse.duration(r * p) * p,
                    minimum: m,
                    without_impact: w,
                    // The closed forms are those of a block starting at rest.
                    closed_form: closed_form(pulse, r).filter(|_| closed_forms_apply),
                    wall_s: t0.elapsed().as_secs_f64(),
                };
                progress(&format!(
                    "{name} {} Pi={}: A_min {}{} ({} runs{}, {:.2} s)",
                    pulse.name(),
                    num(r),
                    row.minimum
                        .amplitude
                        .map_or("none".into(), |a| format!("{a:.5}")),
                    row.without_impact
                        .as_ref()
                        .and_then(|w| w.amplitude)
                        .map_or(String::new(), |a| format!(", without impact {a:.5}")),
                    row.minimum.runs + row.without_impact.as_ref().map_or(0, |w| w.runs),
                    stored(since),
                    row.wall_s
                ));
                res.minima.push(row);
            }
            for &r in &req.map_ratios {
                let t0 = Instant::now();
                let since = sp.from_store.get();
                let cells = sp.map(&[r], &req.map_amplitudes).map_err(fail)?;
                let n = cells.iter().filter(|(_, o)| o.overturned).count();
                progress(&format!(
                    "{name} {} Pi={}: map {n}/{} overturn ({:.2} s{})",
                    pulse.name(),
                    num(r),
                    cells.len(),
                    t0.elapsed().as_secs_f64(),
                    stored(since)
                ));
                res.map
                    .extend(cells.into_iter().map(|(ratio, outcome)| MapCell {
                        engine: name.clone(),
                        pulse,
                        ratio,
                        outcome,
                    }));
            }
            let (settings, version) = if name == "native" && req.settings.early_stop {
                (
                    crate::native::settings_of(base)
                        .ok()
                        .and_then(|s| serde_json::to_value(s).ok())
                        .unwrap_or_default(),
                    native_version(),
                )
            } else if name == "housner" && req.settings.early_stop && base.blocks.len() == 1 {
                (
                    serde_json::json!({
                        "housner": crate::engines::housner::HousnerSettings::of(base).ok(),
                        "integrator": "RK4 with bisection event location (housner::integrate), restarted every 1/p after the pulse for the early stop",
                    }),
                    format!("rockbench {} housner", env!("CARGO_PKG_VERSION")),
                )
            } else {
                sp.engine_settings
                    .borrow()
                    .clone()
                    .unwrap_or((serde_json::Value::Null, String::new()))
            };
            res.from_store += sp.from_store.get();
            let mut entry = serde_json::json!({"version": version, "settings": settings});
            if let Some(note) = &note {
                entry["notes"] = serde_json::json!([note]);
            }
            res.engines.insert(name.clone(), entry);
        }
    }
    res.wall_s = start.elapsed().as_secs_f64();
    Ok(res)
}

/// The Housner engine's note on a block whose friction lets it slide ([`crate::engines::housner::sliding_note`]).
fn housner_sliding_note(engine: &str, base: &Scene) -> Option<String> {
    use crate::engines::housner::{self, HousnerBlock, HousnerSettings};
    if engine != "housner" || base.blocks.len() != 1 {
        return None;
    }
    let b = &base.blocks[0];
    let restitution = HousnerSettings::of(base).ok()?.restitution;
    let blk = HousnerBlock::new(b.width, b.height, base.gravity, restitution);
    housner::sliding_note(&blk, base.friction_below(0))
}

fn opt(x: Option<f64>) -> String {
    x.map_or(String::new(), |x| format!("{x:.6}"))
}

/// `minimum.csv`.
pub fn minimum_csv(res: &Results) -> String {
    let mut s = String::from(
        "engine,pulse,ratio,p_td,a_min,a_safe_below,runs,a_min_without_impact,a_safe_below_without_impact,runs_without_impact,closed_form,closed_form_kind,error_pct,wall_s\n",
    );
    for r in &res.minima {
        let w = r.without_impact.as_ref();
        // The closed form is compared with the boundary it describes.
        let measured = match r.pulse {
            Pulse::OneSine => w.and_then(|w| w.amplitude),
            _ => r.minimum.amplitude,
        };
        let err = match (measured, r.closed_form) {
            (Some(m), Some(c)) => format!("{:.4}", (m / c - 1.0) * 100.0),
            _ => String::new(),
        };
        s += &format!(
            "{},{},{},{:.6},{},{:.6},{},{},{},{},{},{},{err},{:.3}\n",
            r.engine,
            r.pulse.name(),
            r.ratio,
            r.p_td,
            opt(r.minimum.amplitude),
            r.minimum.safe_below,
            r.minimum.runs,
            opt(w.and_then(|w| w.amplitude)),
            w.map_or(String::new(), |w| format!("{:.6}", w.safe_below)),
            w.map_or(String::new(), |w| w.runs.to_string()),
            opt(r.closed_form),
            closed_form_kind(r.pulse).unwrap_or(""),
            r.wall_s
        );
    }
    s
}

/// `map.csv`.
pub fn map_csv(res: &Results) -> String {
    let mut s = String::from(
        "engine,pulse,ratio,amplitude,overturned,without_impact,p_t_overturn,stop,p_t_end\n",
    );
    for c in &res.map {
        let o = &c.outcome;
        s += &format!(
            "{},{},{},{},{},{},{},{},{:.4}\n",
            c.engine,
            c.pulse.name(),
            c.ratio,
            o.amplitude,
            o.overturned,
            o.without_impact,
            opt(o.p_t_overturn),
            o.stop.name(),
            o.p_t_end
        );
    }
    s
}

/// A curve of the spectrum plot: name, colour, dashed, width, points.
type Line<'a> = (String, &'a str, bool, f64, Vec<(f64, f64)>);

const COLORS: [&str; 5] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// One SVG per pulse: a panel per engine with the overturn/safe map (filled: overturns,
/// empty: safe) and the minimum curves of every engine and the closed form.
pub fn svg(res: &Results, pulse: Pulse, engines: &[String]) -> String {
    use std::fmt::Write as _;
    let mins: Vec<&MinimumRow> = res.minima.iter().filter(|r| r.pulse == pulse).collect();
    let cells: Vec<&MapCell> = res.map.iter().filter(|c| c.pulse == pulse).collect();
    let xs: Vec<f64> = mins
        .iter()
        .map(|r| r.ratio)
        .chain(cells.iter().map(|c| c.ratio))
        .collect();
    let ys: Vec<f64> = mins
        .iter()
        .filter_map(|r| r.minimum.amplitude)
        .chain(cells.iter().map(|c| c.outcome.amplitude))
        .collect();
    let (x0, x1) = (0.0, xs.iter().cloned().fold(1.0, f64::max) * 1.05);
    let (y0, y1) = (0.0, ys.iter().cloned().fold(2.0, f64::max) * 1.05);
    let (pw, ph, ml, mt, mb) = (420.0, 320.0, 60.0, 40.0, 50.0);
    let n = engines.len().max(1);
    let width = n as f64 * (pw + ml + 20.0);
    let legend = 15.0 * (2 * engines.len() + 2) as f64;
    let height = ph + mt + mb + 30.0 + legend;
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = write!(
        s,
        r#"<rect width="100%" height="100%" fill="white"/><text x="10" y="18" font-size="14">{} pulse: minimum overturning amplitude and map (p = {:.4} 1/s, alpha = {:.4} rad)</text>"#,
        pulse.name(),
        res.p,
        res.alpha
    );
    for (k, eng) in engines.iter().enumerate() {
        let ox = k as f64 * (pw + ml + 20.0) + ml;
        let px = |x: f64| ox + (x - x0) / (x1 - x0) * pw;
        let py = |y: f64| mt + ph - (y - y0) / (y1 - y0) * ph;
        let _ = write!(
            s,
            r#"<clipPath id="panel{k}"><rect x="{ox}" y="{mt}" width="{pw}" height="{ph}"/></clipPath><rect x="{ox}" y="{mt}" width="{pw}" height="{ph}" fill="none" stroke="black"/><text x="{}" y="{}" text-anchor="middle" font-size="13">{}</text>"#,
            ox + pw / 2.0,
            mt - 6.0,
            esc(eng)
        );
        for t in crate::report::svg::ticks(x0, x1, 6) {
            let _ = write!(
                s,
                r#"<line x1="{0}" x2="{0}" y1="{1}" y2="{2}" stroke="black"/><text x="{0}" y="{3}" text-anchor="middle">{t}</text>"#,
                px(t),
                mt + ph,
                mt + ph + 5.0,
                mt + ph + 18.0
            );
        }
        for t in crate::report::svg::ticks(y0, y1, 6) {
            let _ = write!(
                s,
                r#"<line x1="{0}" x2="{1}" y1="{2}" y2="{2}" stroke="black"/><text x="{3}" y="{4}" text-anchor="end">{t}</text>"#,
                ox - 5.0,
                ox,
                py(t),
                ox - 8.0,
                py(t) + 4.0
            );
        }
        let _ = write!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">omega_p / p</text><text x="{}" y="{}" text-anchor="middle" transform="rotate(-90 {} {})">a_p / (g tan alpha)</text>"#,
            ox + pw / 2.0,
            mt + ph + 36.0,
            ox - 42.0,
            mt + ph / 2.0,
            ox - 42.0,
            mt + ph / 2.0
        );
        for c in cells.iter().filter(|c| &c.engine == eng) {
            let (x, y) = (px(c.ratio), py(c.outcome.amplitude));
            if c.outcome.overturned {
                let fill = if c.outcome.without_impact {
                    "#333"
                } else {
                    "#e08040"
                };
                let _ = write!(
                    s,
                    r##"<circle cx="{x:.2}" cy="{y:.2}" r="3" fill="{fill}"/>"##
                );
            } else {
                let _ = write!(
                    s,
                    r##"<circle cx="{x:.2}" cy="{y:.2}" r="3" fill="none" stroke="#999"/>"##
                );
            }
        }
        // Closed form (dashed), then every engine's minimum curve; this panel's engine bold.
        let mut lines: Vec<Line> = Vec::new();
        let rs: Vec<f64> = {
            let mut v: Vec<f64> = mins.iter().map(|r| r.ratio).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        if mins.iter().any(|r| r.closed_form.is_some()) && !rs.is_empty() {
            let (a, b) = (rs[0], rs[rs.len() - 1]);
            let pts = (0..=100)
                .map(|i| a + (b - a) * i as f64 / 100.0)
                .filter_map(|r| closed_form(pulse, r).map(|c| (r, c)))
                .filter(|&(_, c)| c <= y1)
                .collect();
            lines.push((
                format!("closed form ({})", closed_form_kind(pulse).unwrap_or("")),
                "black",
                true,
                1.0,
                pts,
            ));
        }
        for (j, e) in engines.iter().enumerate() {
            let pts = mins
                .iter()
                .filter(|r| &r.engine == e)
                .filter_map(|r| r.minimum.amplitude.map(|a| (r.ratio, a)))
                .collect();
            let w = if e == eng { 2.5 } else { 1.0 };
            lines.push((format!("{e}: minimum"), COLORS[j % 5], false, w, pts));
            let pts: Vec<(f64, f64)> = mins
                .iter()
                .filter(|r| &r.engine == e)
                .filter_map(|r| {
                    r.without_impact
                        .as_ref()
                        .and_then(|m| m.amplitude)
                        .map(|a| (r.ratio, a))
                })
                .collect();
            if !pts.is_empty() {
                lines.push((
                    format!("{e}: minimum without impact"),
                    COLORS[j % 5],
                    true,
                    w,
                    pts,
                ));
            }
        }
        for (li, (name, color, dashed, w, pts)) in lines.iter().enumerate() {
            if pts.is_empty() {
                continue;
            }
            let d: Vec<String> = pts
                .iter()
                .map(|&(x, y)| format!("{:.2},{:.2}", px(x), py(y)))
                .collect();
            let dash = if *dashed {
                r#" stroke-dasharray="6 4""#
            } else {
                ""
            };
            let _ = write!(
                s,
                r#"<polyline points="{}" fill="none" stroke="{color}" stroke-width="{w}"{dash} clip-path="url(#panel{k})"/>"#,
                d.join(" ")
            );
            let ly = mt + ph + 56.0 + 15.0 * li as f64;
            let _ = write!(
                s,
                r#"<line x1="{}" x2="{}" y1="{ly}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/><text x="{}" y="{}">{}</text>"#,
                ox + 8.0,
                ox + 30.0,
                ox + 34.0,
                ly + 4.0,
                esc(name)
            );
        }
        if !cells.is_empty() {
            let ly = mt + ph + 56.0 + 15.0 * lines.len() as f64;
            let _ = write!(
                s,
                r##"<circle cx="{}" cy="{ly}" r="3" fill="#333"/><text x="{}" y="{}">overturns without impact</text><circle cx="{}" cy="{ly}" r="3" fill="#e08040"/><text x="{}" y="{}">after impact</text><circle cx="{}" cy="{ly}" r="3" fill="none" stroke="#999"/><text x="{}" y="{}">safe</text>"##,
                ox + 14.0,
                ox + 22.0,
                ly + 4.0,
                ox + 184.0,
                ox + 192.0,
                ly + 4.0,
                ox + 284.0,
                ox + 292.0,
                ly + 4.0
            );
        }
    }
    s += "</svg>\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scan's points are counted as it makes them, by factors, up to `scan_to` or down to
    /// the floor: 1 to 1e5 by 5 % is 236 runs, within the bound; by 1e-5 the scan down from 1
    /// to 1e-3 is 690779, beyond it; so is a scan down from 1e9 by 1e-4, not by 1e-3.
    #[test]
    fn the_scan_is_bounded_by_its_geometric_count() {
        let with = |scan_from: f64, scan_step: f64, scan_to: f64| Settings {
            scan_from,
            scan_step,
            scan_to,
            tolerance: 1e-6,
            ..Settings::default()
        };
        assert!(with(1.0, 0.05, 1e5).check().is_ok());
        let e = with(1.0, 1e-5, 100.0).check().unwrap_err();
        assert!(e.contains("690779 scan points"), "{e}");
        let e = with(1e9, 1e-4, 2e9).check().unwrap_err();
        assert!(e.contains("scan points"), "{e}");
        assert!(with(1e9, 1e-3, 2e9).check().is_ok());
    }

    /// The closed forms reproduce the design note's numbers.
    #[test]
    fn spectrum_closed_forms_match_the_design_note() {
        // The note gives three decimals (1 / (1 - exp(-0.5)) = 2.54149 appears as 2.542).
        let rect = |ptd: f64| closed_form(Pulse::Rectangular, PI / ptd).unwrap();
        assert!((rect(0.5) - 2.54149).abs() < 1e-5);
        assert!((rect(0.5) - 2.542).abs() < 6e-4);
        assert!((rect(1.0) - 1.582).abs() < 5e-4);
        for (r, a) in [(1.0, 1.322), (2.0, 1.801), (4.0, 2.791), (10.0, 5.787)] {
            let c = closed_form(Pulse::HalfSine, r).unwrap();
            assert!((c - a).abs() < 5e-4, "half-sine {r}: {c}");
        }
        for (r, a) in [
            (1.0, 1.418),
            (2.0, 2.350),
            (4.0, 5.239),
            (6.0, 9.417),
            (10.0, 21.600),
        ] {
            let c = closed_form(Pulse::OneSine, r).unwrap();
            assert!((c - a).abs() < 5e-4, "one-sine {r}: {c}");
        }
        assert!(closed_form(Pulse::Ricker, 2.0).is_none());
    }

    #[test]
    fn spectrum_input_errors_are_one_line() {
        let e = Pulse::parse("triangle").unwrap_err();
        assert!(e.contains("unknown pulse `triangle`") && !e.contains('\n'));
        let e = parse_list("1,0,2", "--ratios").unwrap_err();
        assert_eq!(e, "--ratios must be finite and > 0 (got 0)");
        assert!(parse_list("1,-2", "--ratios").is_err());
        assert!(parse_list("1,x", "--ratios").unwrap_err().contains("`x`"));
        assert_eq!(parse_list("1:3:3", "r").unwrap(), vec![1.0, 2.0, 3.0]);
        assert_eq!(parse_block("0.2x4"), Some((0.2, 4.0)));
        assert!(block_scene(0.0, 4.0, 1.0, &[]).is_err());
        let s = Settings {
            tolerance: 0.1,
            ..Settings::default()
        };
        assert!(s.check().unwrap_err().contains("--tolerance"));
    }
}
