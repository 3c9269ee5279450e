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
//! point already overturns the scan steps down first.
//!
//! **Early stop** (opt-in, on for `rockbench spectrum`, native engine only; every stop is
//! recorded with its reason): after the pulse has ended a native run stops when a block is
//! beyond its critical angle and still turning outwards (it can no longer come back: it has
//! overturned), when every block has been still for [`REST_WINDOW`] (at rest), or, for a single
//! block inside its critical angle, when its mechanical energy relative to the ground is below
//! [`SAFE_ENERGY_FRACTION`] of the tipping barrier `m g (R - H/2)` (free rocking only loses
//! energy, so it cannot overturn later). The Housner engine is cheap enough to run to the
//! end; the other engines run their full duration through [`Engine::run`].

use crate::engines::native::REST_WINDOW;
use crate::engines::{Engine, EngineError, engine_by_name};
use crate::events;
use crate::excitation::GroundMotion;
use crate::scene::{ExcitationSpec, MotionSpec, Scene};
use crate::trajectory::Trajectory;
use serde::Serialize;
use std::f64::consts::PI;

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

impl Settings {
    /// One line naming a bad setting.
    pub fn check(&self) -> Result<(), String> {
        let pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number (got {x})"))
            }
        };
        pos("--tail", self.tail)?;
        pos("--tolerance", self.tolerance)?;
        pos("--scan-from", self.scan_from)?;
        pos("--scan-step", self.scan_step)?;
        if !(self.scan_to > self.scan_from) {
            return Err(format!(
                "--scan-to must exceed --scan-from (got {} and {})",
                self.scan_to, self.scan_from
            ));
        }
        if self.tolerance >= self.scan_step {
            return Err(format!(
                "--tolerance {} must be below --scan-step {}",
                self.tolerance, self.scan_step
            ));
        }
        Ok(())
    }
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// The full duration was run.
    End,
    /// Early stop: a block beyond its critical angle, turning outwards, after the pulse.
    Overturned,
    /// Early stop: every block still for the rest window after the pulse.
    AtRest,
    /// Early stop: a single block below the safe fraction of its tipping energy after the pulse.
    BelowTippingEnergy,
}

impl Stop {
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
#[derive(Debug, Clone, Serialize)]
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
    pub engine_settings: std::cell::RefCell<Option<(serde_json::Value, String)>>,
}

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
        }
    }

    /// The scene of one run: the base scene with the pulse as its horizontal excitation.
    pub fn scene(&self, ratio: f64, amplitude: f64) -> Scene {
        let omega_p = ratio * self.p;
        let a_p = amplitude * self.base.gravity * self.alpha.tan();
        let mut s = self.base.clone();
        let applied_as = s
            .excitation
            .as_ref()
            .map(|e| e.applied_as)
            .unwrap_or_default();
        s.excitation = Some(ExcitationSpec {
            applied_as,
            horizontal: Some(self.pulse.motion(a_p, omega_p)),
            vertical: None,
        });
        s.duration = self.pulse.duration(omega_p) + self.settings.tail / self.p;
        s.name = format!(
            "{} {} Pi={ratio} A={amplitude}",
            self.base.name,
            self.pulse.name()
        );
        s
    }

    /// Run at (ratio, amplitude) and decide.
    pub fn run(&self, ratio: f64, amplitude: f64) -> Result<Outcome, EngineError> {
        let scene = self.scene(ratio, amplitude);
        let (tr, exact, stop) = if self.engine.name() == "native" && self.settings.early_stop {
            let (tr, stop) = native_early_stop(&scene)?;
            (tr, None, stop)
        } else {
            let out = self.engine.run(&scene)?;
            if !out.trajectory.is_finite() {
                return Err(EngineError::Failed {
                    engine: self.engine.name(),
                    message: "the trajectory contains NaN or infinity".into(),
                });
            }
            *self.engine_settings.borrow_mut() =
                Some((out.settings.clone(), out.engine_version.clone()));
            (out.trajectory, out.exact_impacts, Stop::End)
        };
        let layout = scene.layout();
        let mut first: Option<(f64, bool)> = None;
        for (i, b) in scene.blocks.iter().enumerate() {
            let (rel, rate) = tr.rotation(i, layout.supports[i]);
            let h = events::History::new(&tr.t, &rel, &rate);
            let (over, t_over) = events::overturning(&h, (b.width / b.height).atan());
            if !over {
                continue;
            }
            let t_over = t_over.unwrap_or(f64::INFINITY);
            let impacts = match &exact {
                Some(e) => e[i].clone(),
                None => events::impacts(&h, events::NOISE_FLOOR),
            };
            let clean = impacts.iter().all(|&t| t >= t_over);
            if first.is_none_or(|(t, _)| t_over < t) {
                first = Some((t_over, clean));
            }
        }
        Ok(Outcome {
            amplitude,
            overturned: first.is_some(),
            without_impact: first.is_some_and(|(_, c)| c),
            p_t_overturn: first.map(|(t, _)| t * self.p),
            stop,
            p_t_end: tr.t.last().copied().unwrap_or(0.0) * self.p,
        })
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
            // Step down to a safe amplitude.
            hi = st.scan_from;
            lo = hi / f;
            while test(lo)? {
                hi = lo;
                lo /= f;
                if lo < 1e-3 {
                    return Ok(Minimum::found(ratio, 0.0, hi, runs));
                }
            }
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
    let dt = scene.native.dt;
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
    let crit: Vec<f64> = scene
        .blocks
        .iter()
        .map(|b| (b.width / b.height).atan())
        .collect();
    let window = (REST_WINDOW / dt).ceil() as u64;
    let mut still = 0u64;
    let single = scene.blocks.len() == 1;
    let b0 = &scene.blocks[0];
    let z_rest = layout.blocks[0].z;
    let barrier = scene.gravity * (0.5 * b0.width.hypot(b0.height) - 0.5 * b0.height);
    let mut prev: Vec<f64> = vec![0.0; scene.blocks.len()];
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
        let rel: Vec<(f64, f64)> = (0..states.len())
            .map(|i| match layout.supports[i] {
                Some(j) => (states[i][2] - states[j][2], states[i][5] - states[j][5]),
                None => (states[i][2], states[i][5]),
            })
            .collect();
        if state.t > pulse_end {
            for (i, &(phi, w)) in rel.iter().enumerate() {
                if phi.abs() > crit[i] && phi * w > 0.0 && phi.abs() > prev[i] {
                    return Ok((tr, Stop::Overturned));
                }
            }
            let v = scene.native.rest_velocity;
            let is_still = states.iter().zip(&scene.blocks).all(|(st, b)| {
                st[3].abs() < v && st[4].abs() < v && (st[5] * b.width.max(b.height)).abs() < v
            });
            still = if is_still { still + 1 } else { 0 };
            if still >= window {
                return Ok((tr, Stop::AtRest));
            }
            if single && rel[0].0.abs() < crit[0] {
                // Energy per unit mass: kinetic (centroid and rotation about it) + potential.
                let s = &states[0];
                let i_over_m = (b0.width * b0.width + b0.height * b0.height) / 12.0;
                let e = 0.5 * (s[3] * s[3] + s[4] * s[4] + i_over_m * s[5] * s[5])
                    + scene.gravity * (s[1] - z_rest);
                if e < SAFE_ENERGY_FRACTION * barrier {
                    return Ok((tr, Stop::BelowTippingEnergy));
                }
            }
        }
        for (p, r) in prev.iter_mut().zip(&rel) {
            *p = r.0.abs();
        }
    }
    Ok((tr, Stop::End))
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
pub fn block_scene(width: f64, height: f64, friction: f64) -> Result<Scene, String> {
    if !(width.is_finite() && width > 0.0 && height.is_finite() && height > 0.0) {
        return Err(format!(
            "a block is BxH with B, H > 0 metres (got {width}x{height})"
        ));
    }
    let text = format!(
        "name = \"block {width}x{height}\"\nduration = 1.0\n\n[[blocks]]\nname = \"block\"\nwidth = {width}\nheight = {height}\n\n[contact]\nfriction = {friction}\n"
    );
    let s = crate::scene::parse_scene_str(&text, false, "block", &[]).map_err(|e| e.to_string())?;
    s.check().map_err(|e| e.to_string())?;
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
        return Err(format!("{what} must be > 0 (got {x})"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed forms reproduce the design note's numbers.
    #[test]
    fn spectrum_closed_forms_match_the_design_note() {
        let rect = |ptd: f64| closed_form(Pulse::Rectangular, PI / ptd).unwrap();
        assert!((rect(0.5) - 2.542).abs() < 5e-4);
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
        assert_eq!(e, "--ratios must be > 0 (got 0)");
        assert!(parse_list("1,-2", "--ratios").is_err());
        assert!(parse_list("1,x", "--ratios").unwrap_err().contains("`x`"));
        assert_eq!(parse_list("1:3:3", "r").unwrap(), vec![1.0, 2.0, 3.0]);
        assert_eq!(parse_block("0.2x4"), Some((0.2, 4.0)));
        assert!(block_scene(0.0, 4.0, 1.0).is_err());
        let s = Settings {
            tolerance: 0.1,
            ..Settings::default()
        };
        assert!(s.check().unwrap_err().contains("--tolerance"));
    }
}
