//! Ground motion: analytic pulses, acceleration records and prescribed displacements.
//!
//! Sign convention: a positive horizontal ground acceleration moves the ground towards +x;
//! the inertial force on a block of mass m is `-m a_x`. A positive vertical acceleration moves
//! the ground up (effective gravity `g + a_z`).
//!
//! Each component gives the exact acceleration `a(t)`, velocity `v(t)` and displacement
//! `d(t)` of the ground, with `v(0) = d(0) = 0` (the ground is at rest before t = 0).
//! Records are piecewise linear in acceleration (or in displacement), zero outside their span.

pub mod records;
pub mod suite;

use crate::scene::{MotionSpec, RecordFormat, Scene, SceneError};
use std::f64::consts::PI;

/// Whether a component was given as an acceleration or as a displacement history.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DefinedBy {
    Acceleration,
    Displacement,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PulseShape {
    HalfSine,
    OneSine,
    /// `A cos(2 pi s / T)` over one period T.
    OneCosine,
    /// Ricker wavelet of period `T_p = duration / RICKER_WINDOW`, centred in its window.
    Ricker,
    Rectangular,
}

/// A Ricker pulse lasts this many of its periods T_p (centred: |t - t_c| <= 1.5 T_p, where
/// |a| < 1e-8 A).
pub const RICKER_WINDOW: f64 = 3.0;

/// Ricker wavelet on its window: (acceleration, velocity, displacement) per unit amplitude at
/// `s` in [0, d] (d the window), from rest at s = 0; exact integrals (`d/du [u e^{-u^2}] =
/// (1 - 2 u^2) e^{-u^2}`).
fn ricker(d: f64, s: f64) -> (f64, f64, f64) {
    let tp = d / RICKER_WINDOW;
    let k = PI / tp;
    let c = 0.5 * d;
    let u = k * (s - c);
    let u0 = -k * c;
    let (e, e0) = ((-u * u).exp(), (-u0 * u0).exp());
    (
        (1.0 - 2.0 * u * u) * e,
        (u * e - u0 * e0) / k,
        (0.5 * (e0 - e) - u0 * e0 * (u - u0)) / (k * k),
    )
}

/// One component (horizontal or vertical) of ground motion.
#[derive(Debug, Clone)]
pub enum Component {
    Pulse {
        shape: PulseShape,
        amplitude: f64,
        duration: f64,
        start: f64,
    },
    /// Piecewise-linear acceleration with exact cumulative velocity and displacement at the
    /// samples.
    AccelerationRecord {
        t: Vec<f64>,
        a: Vec<f64>,
        v: Vec<f64>,
        d: Vec<f64>,
    },
    /// Piecewise-linear displacement (velocity piecewise constant).
    DisplacementRecord { t: Vec<f64>, d: Vec<f64> },
}

impl Component {
    pub fn defined_by(&self) -> DefinedBy {
        match self {
            Component::DisplacementRecord { .. } => DefinedBy::Displacement,
            _ => DefinedBy::Acceleration,
        }
    }

    /// Ground acceleration at t, m/s^2 (zero between samples of a displacement record; NaN at
    /// a NaN time, as [`Component::vel`] and [`Component::disp`]).
    pub fn acc(&self, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        match self {
            Component::Pulse {
                shape,
                amplitude: a,
                duration: d,
                start,
            } => {
                let s = t - start;
                if !(0.0..=*d).contains(&s) {
                    return 0.0;
                }
                match shape {
                    PulseShape::HalfSine => a * (PI * s / d).sin(),
                    PulseShape::OneSine => a * (2.0 * PI * s / d).sin(),
                    PulseShape::OneCosine => a * (2.0 * PI * s / d).cos(),
                    PulseShape::Ricker => a * ricker(*d, s).0,
                    PulseShape::Rectangular => *a,
                }
            }
            Component::AccelerationRecord { t: ts, a, .. } => {
                // The record's samples are its values, the last one included (after it, 0).
                if t == ts[ts.len() - 1] {
                    return a[a.len() - 1];
                }
                let Some(k) = segment(ts, t) else { return 0.0 };
                let f = (t - ts[k]) / (ts[k + 1] - ts[k]);
                a[k] + f * (a[k + 1] - a[k])
            }
            Component::DisplacementRecord { .. } => 0.0,
        }
    }

    /// The acceleration's one-sided limit at t, m/s^2: from the right (`after`, the value a
    /// step starting at t integrates) or from the left (a step ending at t). [`Component::acc`]
    /// is one of the two at a breakpoint (the pulse's value at its end, the record's last
    /// sample), which is the wrong one for the step on the other side of it. An instant within
    /// 1e-12 relative of a breakpoint is on it (the breakpoints are computed sums).
    pub fn acc_side(&self, t: f64, after: bool) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        match self {
            Component::Pulse {
                duration: d, start, ..
            } => {
                let s = t - start;
                let eps = 1e-12 * (1.0 + start.abs() + d);
                let inside = if after {
                    s >= -eps && s < d - eps
                } else {
                    s > eps && s <= d + eps
                };
                if inside {
                    self.acc(start + s.clamp(0.0, *d))
                } else {
                    0.0
                }
            }
            Component::AccelerationRecord { t: ts, a, .. } => {
                let (first, last) = (ts[0], ts[ts.len() - 1]);
                let eps = 1e-12 * (1.0 + t.abs());
                let inside = if after {
                    t >= first - eps && t < last - eps
                } else {
                    t > first + eps && t <= last + eps
                };
                if !inside {
                    0.0
                } else if t >= last {
                    a[a.len() - 1]
                } else {
                    self.acc(t.max(first))
                }
            }
            Component::DisplacementRecord { .. } => 0.0,
        }
    }

    /// The lowest acceleration of the motion and when, (t, a): a record's lowest sample (it
    /// is linear between them), a pulse's lowest of 10 001 points over its duration; zero
    /// outside them, and for a displacement record (whose acceleration is impulses).
    pub fn lowest_acceleration(&self) -> (f64, f64) {
        let lowest = |pts: &mut dyn Iterator<Item = (f64, f64)>| {
            pts.fold((0.0, 0.0), |m: (f64, f64), p| if p.1 < m.1 { p } else { m })
        };
        match self {
            Component::Pulse {
                duration: d, start, ..
            } => lowest(&mut (0..=10_000).map(|k| {
                let t = start + d * k as f64 / 10_000.0;
                (t, self.acc_side(t, k < 10_000))
            })),
            Component::AccelerationRecord { t, a, .. } => {
                lowest(&mut t.iter().copied().zip(a.iter().copied()))
            }
            Component::DisplacementRecord { .. } => (0.0, 0.0),
        }
    }

    /// Ground velocity at t, m/s.
    pub fn vel(&self, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        match self {
            Component::Pulse {
                shape,
                amplitude: a,
                duration: d,
                start,
            } => {
                let s = (t - start).clamp(0.0, *d);
                match shape {
                    PulseShape::HalfSine => a * d / PI * (1.0 - (PI * s / d).cos()),
                    PulseShape::OneSine => a * d / (2.0 * PI) * (1.0 - (2.0 * PI * s / d).cos()),
                    PulseShape::OneCosine => a * d / (2.0 * PI) * (2.0 * PI * s / d).sin(),
                    PulseShape::Ricker => a * ricker(*d, s).1,
                    PulseShape::Rectangular => a * s,
                }
            }
            Component::AccelerationRecord { t: ts, a, v, .. } => {
                if t <= ts[0] {
                    return 0.0;
                }
                let n = ts.len();
                if t >= ts[n - 1] {
                    return v[n - 1];
                }
                let k = segment(ts, t).unwrap();
                let h = t - ts[k];
                let slope = (a[k + 1] - a[k]) / (ts[k + 1] - ts[k]);
                v[k] + a[k] * h + 0.5 * slope * h * h
            }
            // Piecewise constant, its jump at a sample taken from the right; within 1e-12
            // relative below a sample is on it (a step's end, computed as a sum, lands a bit
            // below the sample it is meant to reach, and the jump went to the next step).
            Component::DisplacementRecord { t: ts, d } => {
                match segment(ts, t + 1e-12 * (1.0 + t.abs())) {
                    Some(k) => (d[k + 1] - d[k]) / (ts[k + 1] - ts[k]),
                    None => 0.0,
                }
            }
        }
    }

    /// Ground displacement at t, m.
    pub fn disp(&self, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        match self {
            Component::Pulse {
                shape,
                amplitude: a,
                duration: d,
                start,
            } => {
                let s = (t - start).max(0.0);
                let sc = s.min(*d);
                let (d_end, v_end) = match shape {
                    PulseShape::HalfSine => (
                        a * d / PI * (sc - d / PI * (PI * sc / d).sin()),
                        a * d / PI * (1.0 - (PI * sc / d).cos()),
                    ),
                    PulseShape::OneSine => {
                        let w = 2.0 * PI / d;
                        (
                            a / w * (sc - (w * sc).sin() / w),
                            a / w * (1.0 - (w * sc).cos()),
                        )
                    }
                    PulseShape::OneCosine => {
                        let w = 2.0 * PI / d;
                        (a / (w * w) * (1.0 - (w * sc).cos()), a / w * (w * sc).sin())
                    }
                    PulseShape::Ricker => {
                        let (_, v, x) = ricker(*d, sc);
                        (a * x, a * v)
                    }
                    PulseShape::Rectangular => (0.5 * a * sc * sc, a * sc),
                };
                d_end + v_end * (s - sc)
            }
            Component::AccelerationRecord { t: ts, a, v, d } => {
                if t <= ts[0] {
                    return 0.0;
                }
                let n = ts.len();
                if t >= ts[n - 1] {
                    return d[n - 1] + v[n - 1] * (t - ts[n - 1]);
                }
                let k = segment(ts, t).unwrap();
                let h = t - ts[k];
                let slope = (a[k + 1] - a[k]) / (ts[k + 1] - ts[k]);
                d[k] + v[k] * h + 0.5 * a[k] * h * h + slope * h * h * h / 6.0
            }
            Component::DisplacementRecord { t: ts, d } => {
                if t <= ts[0] {
                    return d[0];
                }
                let n = ts.len();
                if t >= ts[n - 1] {
                    return d[n - 1];
                }
                let k = segment(ts, t).unwrap();
                let f = (t - ts[k]) / (ts[k + 1] - ts[k]);
                d[k] + f * (d[k + 1] - d[k])
            }
        }
    }

    /// Instants where the acceleration is not smooth (integrators should step onto them).
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            Component::Pulse {
                duration, start, ..
            } => vec![*start, start + duration],
            Component::AccelerationRecord { t, .. } | Component::DisplacementRecord { t, .. } => {
                t.clone()
            }
        }
    }
}

/// Index k with `t[k] <= x < t[k+1]`, if x is inside the samples (never for a NaN).
fn segment(t: &[f64], x: f64) -> Option<usize> {
    if !(x >= t[0] && x < t[t.len() - 1]) {
        return None;
    }
    Some(t.partition_point(|&s| s <= x) - 1)
}

/// Horizontal and vertical ground motion of a scene.
#[derive(Debug, Clone, Default)]
pub struct GroundMotion {
    pub horizontal: Option<Component>,
    pub vertical: Option<Component>,
}

impl GroundMotion {
    /// Build from a scene's `[excitation]`, reading record files relative to the scene file.
    pub fn from_scene(scene: &Scene) -> Result<GroundMotion, SceneError> {
        let Some(exc) = &scene.excitation else {
            return Ok(GroundMotion::default());
        };
        let build = |m: &Option<MotionSpec>, comp: &str| -> Result<Option<Component>, SceneError> {
            m.as_ref()
                .map(|m| component(scene, m, &format!("excitation.{comp}")))
                .transpose()
        };
        Ok(GroundMotion {
            horizontal: build(&exc.horizontal, "horizontal")?,
            vertical: build(&exc.vertical, "vertical")?,
        })
    }

    pub fn is_none(&self) -> bool {
        self.horizontal.is_none() && self.vertical.is_none()
    }

    /// Ground acceleration (a_x, a_z) at t.
    pub fn acc(&self, t: f64) -> (f64, f64) {
        (
            self.horizontal.as_ref().map_or(0.0, |c| c.acc(t)),
            self.vertical.as_ref().map_or(0.0, |c| c.acc(t)),
        )
    }
    /// The one-sided limits ([`Component::acc_side`]) of (a_x, a_z) at t.
    pub fn acc_side(&self, t: f64, after: bool) -> (f64, f64) {
        (
            self.horizontal
                .as_ref()
                .map_or(0.0, |c| c.acc_side(t, after)),
            self.vertical.as_ref().map_or(0.0, |c| c.acc_side(t, after)),
        )
    }
    pub fn vel(&self, t: f64) -> (f64, f64) {
        (
            self.horizontal.as_ref().map_or(0.0, |c| c.vel(t)),
            self.vertical.as_ref().map_or(0.0, |c| c.vel(t)),
        )
    }
    pub fn disp(&self, t: f64) -> (f64, f64) {
        (
            self.horizontal.as_ref().map_or(0.0, |c| c.disp(t)),
            self.vertical.as_ref().map_or(0.0, |c| c.disp(t)),
        )
    }
    pub fn any_displacement_defined(&self) -> bool {
        [&self.horizontal, &self.vertical].iter().any(|c| {
            c.as_ref()
                .is_some_and(|c| c.defined_by() == DefinedBy::Displacement)
        })
    }
    /// Sorted, de-duplicated instants where the acceleration is not smooth.
    pub fn breakpoints(&self) -> Vec<f64> {
        let mut b: Vec<f64> = [&self.horizontal, &self.vertical]
            .iter()
            .filter_map(|c| c.as_ref())
            .flat_map(|c| c.breakpoints())
            .collect();
        b.sort_by(|a, c| a.total_cmp(c));
        b.dedup();
        b
    }
}

fn component(scene: &Scene, m: &MotionSpec, field: &str) -> Result<Component, SceneError> {
    let file = scene.source.as_str();
    Ok(match m {
        MotionSpec::HalfSine {
            amplitude,
            duration,
            period,
            start,
        } => Component::Pulse {
            shape: PulseShape::HalfSine,
            amplitude: *amplitude,
            duration: duration.unwrap_or_else(|| period.unwrap_or(0.0) / 2.0),
            start: *start,
        },
        MotionSpec::OneSine {
            amplitude,
            duration,
            period,
            start,
        } => Component::Pulse {
            shape: PulseShape::OneSine,
            amplitude: *amplitude,
            duration: duration.or(*period).unwrap_or(0.0),
            start: *start,
        },
        MotionSpec::OneCosine {
            amplitude,
            duration,
            period,
            start,
        } => Component::Pulse {
            shape: PulseShape::OneCosine,
            amplitude: *amplitude,
            duration: duration.or(*period).unwrap_or(0.0),
            start: *start,
        },
        MotionSpec::Ricker {
            amplitude,
            period,
            start,
        } => Component::Pulse {
            shape: PulseShape::Ricker,
            amplitude: *amplitude,
            duration: RICKER_WINDOW * period,
            start: *start,
        },
        MotionSpec::Rectangular {
            amplitude,
            duration,
            start,
        } => Component::Pulse {
            shape: PulseShape::Rectangular,
            amplitude: *amplitude,
            duration: *duration,
            start: *start,
        },
        MotionSpec::Record {
            file: rec,
            scale,
            format,
        } => {
            let path = scene.base_dir.join(rec);
            let fmt = format.unwrap_or_else(|| {
                if rec.to_ascii_lowercase().ends_with(".at2") {
                    RecordFormat::At2
                } else {
                    RecordFormat::Csv
                }
            });
            let text = read(&path, file, field)?;
            let (s, unit) = records::parse_acceleration(fmt, &text).map_err(|e| {
                SceneError::new(
                    file,
                    format!("{field}.file"),
                    format!("{}: {e}", path.display()),
                )
            })?;
            let a: Vec<f64> = s.v.iter().map(|x| x * unit * scale).collect();
            let (v, d) = integrate_piecewise_linear(&s.t, &a);
            let finite =
                |a: &[f64], v: &[f64], d: &[f64]| a.iter().chain(v).chain(d).all(|x| x.is_finite());
            if !finite(&a, &v, &d) {
                // The record itself (its times or values), or only its scale?
                let own: Vec<f64> = s.v.iter().map(|x| x * unit).collect();
                let (ov, od) = integrate_piecewise_linear(&s.t, &own);
                if !finite(&own, &ov, &od) {
                    return Err(SceneError::new(
                        file,
                        format!("{field}.file"),
                        format!(
                            "{}: the record's velocity or displacement is not finite (its samples span {} s)",
                            path.display(),
                            crate::scene::num(s.t[s.t.len() - 1] - s.t[0])
                        ),
                    ));
                }
                return Err(SceneError::new(
                    file,
                    format!("{field}.scale"),
                    format!(
                        "{}: the scaled acceleration (scale {}) or its velocity or displacement is not finite",
                        path.display(),
                        crate::scene::num(*scale)
                    ),
                ));
            }
            Component::AccelerationRecord { t: s.t, a, v, d }
        }
        MotionSpec::Displacement { file: rec, scale } => {
            let path = scene.base_dir.join(rec);
            let text = read(&path, file, field)?;
            let s =
                records::parse_two_column(&text, records::Quantity::Displacement).map_err(|e| {
                    SceneError::new(
                        file,
                        format!("{field}.file"),
                        format!("{}: {e}", path.display()),
                    )
                })?;
            if s.v[0] != 0.0 {
                return Err(SceneError::new(
                    file,
                    format!("{field}.file"),
                    format!(
                        "{}: the displacement must start at 0 (got {})",
                        path.display(),
                        s.v[0]
                    ),
                ));
            }
            let d: Vec<f64> = s.v.iter().map(|x| x * scale).collect();
            let slopes_finite =
                s.t.windows(2)
                    .zip(d.windows(2))
                    .all(|(t, d)| ((d[1] - d[0]) / (t[1] - t[0])).is_finite());
            if !d.iter().all(|x| x.is_finite()) || !slopes_finite {
                return Err(SceneError::new(
                    file,
                    format!("{field}.scale"),
                    format!(
                        "{}: the scaled displacement (scale {}) or its velocity is not finite",
                        path.display(),
                        crate::scene::num(*scale)
                    ),
                ));
            }
            Component::DisplacementRecord { t: s.t, d }
        }
    })
}

fn read(path: &std::path::Path, file: &str, field: &str) -> Result<String, SceneError> {
    let text = crate::input_file::read_to_string(path).map_err(|e| {
        SceneError::new(
            file,
            format!("{field}.file"),
            format!("cannot read {}: {e}", path.display()),
        )
    })?;
    if text.trim().is_empty() {
        return Err(SceneError::new(
            file,
            format!("{field}.file"),
            format!("{} is empty", path.display()),
        ));
    }
    Ok(text)
}

/// Exact velocity and displacement at the samples of a piecewise-linear acceleration that is
/// zero before the first sample.
fn integrate_piecewise_linear(t: &[f64], a: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = t.len();
    let mut v = vec![0.0; n];
    let mut d = vec![0.0; n];
    for k in 0..n - 1 {
        let h = t[k + 1] - t[k];
        v[k + 1] = v[k] + 0.5 * h * (a[k] + a[k + 1]);
        d[k + 1] = d[k] + v[k] * h + h * h * (a[k] / 3.0 + a[k + 1] / 6.0);
    }
    (v, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pulse(shape: PulseShape) -> Component {
        Component::Pulse {
            shape,
            amplitude: 2.0,
            duration: 0.4,
            start: 0.1,
        }
    }

    /// A NaN time gives NaN motion, never a panic (it indexed before the first sample).
    #[test]
    fn a_nan_time_gives_nan_motion_for_every_kind() {
        let t = vec![0.0, 0.01, 0.02];
        let record = Component::AccelerationRecord {
            t: t.clone(),
            a: vec![0.0, 1.0, 0.0],
            v: vec![0.0, 0.005, 0.01],
            d: vec![0.0, 0.0, 0.0001],
        };
        let displacement = Component::DisplacementRecord {
            t,
            d: vec![0.0, 0.001, 0.0],
        };
        for c in [pulse(PulseShape::HalfSine), record, displacement] {
            assert!(c.acc(f64::NAN).is_nan(), "{c:?}");
            assert!(c.vel(f64::NAN).is_nan(), "{c:?}");
            assert!(c.disp(f64::NAN).is_nan(), "{c:?}");
        }
    }

    /// The one-sided limits at a pulse's ends and a record's last sample: the value inside
    /// from inside, zero from outside, whatever the rounding of the breakpoint's sum.
    #[test]
    fn one_sided_limits_at_the_breakpoints() {
        let rect = pulse(PulseShape::Rectangular);
        let end = 0.1 + 0.4;
        for t in [end, end - 1e-17, end + 1e-16] {
            assert_eq!(rect.acc_side(t, true), 0.0, "after {t}");
            assert_eq!(rect.acc_side(t, false), 2.0, "before {t}");
        }
        assert_eq!(rect.acc_side(0.1, true), 2.0);
        assert_eq!(rect.acc_side(0.1, false), 0.0);
        assert_eq!(rect.acc_side(0.3, true), rect.acc(0.3));
        let cosine = pulse(PulseShape::OneCosine);
        assert!((cosine.acc_side(end, false) - 2.0).abs() < 1e-12);
        assert_eq!(cosine.acc_side(end, true), 0.0);
        let record = Component::AccelerationRecord {
            t: vec![0.0, 0.01, 0.02],
            a: vec![0.5, 1.0, 3.0],
            v: vec![0.0, 0.0075, 0.0275],
            d: vec![0.0, 0.0, 0.0002],
        };
        assert_eq!(record.acc_side(0.02, false), 3.0);
        assert_eq!(record.acc_side(0.02, true), 0.0);
        assert_eq!(record.acc_side(0.0, true), 0.5);
        assert_eq!(record.acc_side(0.0, false), 0.0);
        assert_eq!(record.acc_side(0.015, true), record.acc(0.015));
    }

    /// The closed-form velocity and displacement are the integrals of the acceleration.
    #[test]
    fn pulse_integrals_match_quadrature() {
        for shape in [
            PulseShape::HalfSine,
            PulseShape::OneSine,
            PulseShape::OneCosine,
            PulseShape::Ricker,
            PulseShape::Rectangular,
        ] {
            let c = pulse(shape);
            let h = 1e-5;
            let (mut v, mut d) = (0.0, 0.0);
            // Exactly 80,000 midpoint steps to t = 0.8 (summing `t += h` would take one step
            // too many through round-off).
            let n = (0.8f64 / h).round() as usize;
            for k in 0..n {
                let a0 = c.acc((k as f64 + 0.5) * h);
                d += v * h + 0.5 * a0 * h * h;
                v += a0 * h;
            }
            assert!(
                (v - c.vel(0.8)).abs() < 1e-6,
                "{shape:?} v {v} vs {}",
                c.vel(0.8)
            );
            assert!(
                (d - c.disp(0.8)).abs() < 1e-6,
                "{shape:?} d {d} vs {}",
                c.disp(0.8)
            );
        }
    }

    /// The one-cosine and Ricker pulses end at rest (zero ground velocity); the Ricker
    /// wavelet peaks at A in the middle of its window and the one-cosine pulse starts at A.
    #[test]
    fn one_cosine_and_ricker_shapes() {
        for shape in [PulseShape::OneCosine, PulseShape::Ricker] {
            let c = pulse(shape);
            assert!(
                c.vel(0.5).abs() < 1e-9,
                "{shape:?} ends moving: {}",
                c.vel(0.5)
            );
        }
        assert!((pulse(PulseShape::Ricker).acc(0.3) - 2.0).abs() < 1e-12);
        assert!((pulse(PulseShape::OneCosine).acc(0.1) - 2.0).abs() < 1e-12);
        // The Ricker window's ends: below 1e-8 of the amplitude.
        assert!(pulse(PulseShape::Ricker).acc(0.1).abs() < 2e-8);
        assert!(pulse(PulseShape::Ricker).acc(0.5).abs() < 2e-8);
    }

    #[test]
    fn record_integrals_are_exact_for_linear_acceleration() {
        // a = t on [0, 1]: v = t^2/2, d = t^3/6.
        let t: Vec<f64> = (0..=10).map(|i| i as f64 * 0.1).collect();
        let a = t.clone();
        let (v, d) = integrate_piecewise_linear(&t, &a);
        let c = Component::AccelerationRecord { t, a, v, d };
        for x in [0.05, 0.37, 0.99] {
            assert!((c.vel(x) - x * x / 2.0).abs() < 1e-14);
            assert!((c.disp(x) - x * x * x / 6.0).abs() < 1e-14);
        }
    }

    /// A record's acceleration at each of its samples is the sample, the last one included;
    /// before the first and after the last it is 0.
    #[test]
    fn a_record_is_its_samples_at_their_times_and_zero_outside() {
        let t = vec![0.5, 0.51, 0.52];
        let a = vec![1.0, 2.0, 3.0];
        let (v, d) = integrate_piecewise_linear(&t, &a);
        let c = Component::AccelerationRecord {
            t: t.clone(),
            a: a.clone(),
            v,
            d,
        };
        for (ti, ai) in t.iter().zip(&a) {
            assert_eq!(c.acc(*ti), *ai, "at {ti}");
        }
        assert_eq!(c.acc(0.4999), 0.0);
        assert_eq!(c.acc(0.5201), 0.0);
    }
}
