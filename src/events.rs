//! Events of a rotation history, one definition for every engine (VALIDATION.md).
//!
//! Every event is located from the samples on its smooth side, never by interpolating across
//! a sample interval that holds a velocity jump. From a sample `k` with rotation `phi_k`, rate
//! `omega_k` and the one-sided acceleration `a_k` (the derivative at `t_k` of the quadratic
//! through the rates of samples `k-2, k-1, k` of the same stretch; first order with two),
//! the history after `t_k` is extrapolated as
//! `phi(t_k + tau) = phi_k + omega_k tau + a_k tau^2 / 2` (local error O(h^3)), and a level is
//! crossed at the smallest root tau in `(0, t_{k+1} - t_k]`. Where that quadratic has no root
//! in the interval (soft contacts can reverse within it) the crossing is interpolated linearly.
//!
//! - **Impact**: a zero crossing of the rotation (relative rotation for a block on another
//!   block), extrapolated from the last sample before the sign change. A crossing counts only
//!   when the largest |phi| of the half-wave that ends at it reaches the noise floor (default
//!   1e-5 rad; its extremum between the samples where its largest sample is within a factor
//!   2 below), so jitter about zero is not counted. Another block's impact inside the interval,
//!   before the crossing, is a kink of the rate: the crossing is then read backwards from the
//!   sample after it. A half-wave that ends flat (within
//!   [`FLAT`] of zero: a block stopped dead by the impact, lying on its face) counts as an
//!   impact where it reaches zero, whether the block stays flat or later lifts off, unless
//!   the history ends on that one flat sample; while flat, the sign of its round-off is no
//!   half-wave (a block lying on its face between two rocking episodes flips the sign of a
//!   1e-21 rad rotation, which counted as impacts).
//! - **Peak amplitude**: max |phi| before the first impact and between consecutive impacts,
//!   at the extremum: the zero of omega inside a sample interval, where the cubic Hermite
//!   interpolant of (phi, omega) at its two ends peaks (local error O(h^4)); a parabola through
//!   the three samples around the largest |phi| where the rate does not change sign; the
//!   largest sample at the ends of a stretch. The other blocks' impacts are kinks of the rate
//!   too: no interpolant spans one; the kink's value is extrapolated from the nearer end. A last
//!   stretch still growing where the history ends has no peak, unless it is the only one.
//! - **Largest rotation**: max |phi| of the history, located as a peak is ([`max_abs`]).
//! - **Rest time** at epsilon: the earliest time after which |phi| stays below epsilon to the
//!   end of the history, extrapolated from the last sample at or above epsilon (`None` if the
//!   last sample is not below it).
//! - **Overturning**: |phi| reaches pi/2 (to within [`ON_SIDE_TOLERANCE`]: a block that fell
//!   onto its side rests a hair below pi/2 in a contact engine), or ends beyond the block's
//!   critical angle atan(B/H) and still growing, not at rest there ([`RESTING_RATE`]: a block
//!   at rest beyond it creeps by round-off or contact compliance, outwards in one engine and
//!   back in another); the overturn time is the last upward crossing of the critical angle
//!   before that, extrapolated from the sample below it.
//!
//! An engine that locates its own impacts (the Housner engine) reports them instead; the
//! summary says which source each block's impacts came from ([`ImpactSource`]).

use serde::{Deserialize, Serialize};

/// Default noise floor for impacts, rad.
pub const NOISE_FLOOR: f64 = 1e-5;
/// Rest thresholds reported for every block, rad, with their JSON keys.
pub const REST_THRESHOLDS: [(&str, f64); 4] = [
    ("1e-4", 1e-4),
    ("1e-3", 1e-3),
    ("1e-2", 1e-2),
    ("3e-2", 3e-2),
];
/// A block whose |phi| comes this close to pi/2 lies on its side, rad (an overturned block in
/// the native engine comes to rest at pi/2 - 3e-7 rad on the pulse-overturning cases).
pub const ON_SIDE_TOLERANCE: f64 = 1e-3;
/// The default rest threshold.
pub const DEFAULT_REST: f64 = 1e-4;
/// A block rests where its history ends (overturning: not "still growing") when its rate
/// |omega| stays at most `RESTING_RATE` (rad/s) over the last `RESTING_WINDOW` (s). Leaning on
/// a neighbour or on debris beyond its critical angle, a contact engine's block creeps by
/// round-off or compliance, outwards in one engine and back in another (the colonnade of
/// `validation/scenes/colonnade-elcentro.toml`, El Centro x2: rapier up to 1.3e-5 rad/s, MuJoCo
/// 1e-7, PyBullet 1.5e-7, the native engine 1e-11), and the sign of that creep must not decide
/// whether it overturned. A block that turns outwards beyond its critical angle `alpha` is not
/// at rest: it accelerates at about `p^2 (phi - alpha)`, so its rate exceeds the floor within
/// the window unless it turns within some `2 RESTING_RATE / (p^2 RESTING_WINDOW)` of `alpha`.
pub const RESTING_RATE: f64 = 1e-4;
/// The end of a history over which a block's rate is read for rest (s; see [`RESTING_RATE`]).
pub const RESTING_WINDOW: f64 = 0.1;

/// Where a block's impact instants come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImpactSource {
    /// Located by the engine itself (the Housner engine: to 1e-10 s).
    Engine,
    /// From the output samples, extrapolated from the pre-impact side (this module).
    Samples,
}

/// A sampled rotation history: times (s), rotation (rad) and its rate (rad/s), of equal length.
#[derive(Debug, Clone, Copy)]
pub struct History<'a> {
    pub t: &'a [f64],
    pub phi: &'a [f64],
    pub omega: &'a [f64],
}

impl<'a> History<'a> {
    pub fn new(t: &'a [f64], phi: &'a [f64], omega: &'a [f64]) -> Self {
        assert!(
            t.len() == phi.len() && t.len() == omega.len(),
            "a history's series have one length"
        );
        History { t, phi, omega }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Whether the history ends at rest: |omega| at most [`RESTING_RATE`] at every sample of
    /// its last [`RESTING_WINDOW`], which it covers.
    pub fn resting(&self) -> bool {
        let Some(&end) = self.t.last() else {
            return false;
        };
        self.t[0] <= end - RESTING_WINDOW
            && self
                .t
                .iter()
                .zip(self.omega)
                .rev()
                .take_while(|&(&t, _)| t >= end - RESTING_WINDOW)
                .all(|(_, w)| w.abs() <= RESTING_RATE)
    }

    /// The samples with index in `range`.
    pub fn slice(&self, range: std::ops::Range<usize>) -> History<'a> {
        History {
            t: &self.t[range.clone()],
            phi: &self.phi[range.clone()],
            omega: &self.omega[range],
        }
    }

    /// d omega / dt at sample `k` from samples `lo..=k` only (at most three of them): the
    /// derivative at `t_k` of the quadratic through the last three rates, or the backward
    /// difference of the last two; 0 from a single sample.
    fn one_sided_acceleration(&self, k: usize, lo: usize) -> f64 {
        let (t, w) = (self.t, self.omega);
        if k >= lo + 2 {
            let h1 = t[k] - t[k - 1];
            let h2 = t[k - 1] - t[k - 2];
            if h1 > 0.0 && h2 > 0.0 {
                return w[k] * (2.0 * h1 + h2) / (h1 * (h1 + h2))
                    - w[k - 1] * (h1 + h2) / (h1 * h2)
                    + w[k - 2] * h1 / (h2 * (h1 + h2));
            }
        }
        if k > lo && t[k] > t[k - 1] {
            return (w[k] - w[k - 1]) / (t[k] - t[k - 1]);
        }
        0.0
    }

    /// d omega / dt at sample `k` from samples `k..hi` only: the mirror image of
    /// [`Self::one_sided_acceleration`], for a history read backwards from `k`.
    fn one_sided_acceleration_ahead(&self, k: usize, hi: usize) -> f64 {
        let (t, w) = (self.t, self.omega);
        if k + 2 < hi {
            let h1 = t[k + 1] - t[k];
            let h2 = t[k + 2] - t[k + 1];
            if h1 > 0.0 && h2 > 0.0 {
                return -w[k] * (2.0 * h1 + h2) / (h1 * (h1 + h2))
                    + w[k + 1] * (h1 + h2) / (h1 * h2)
                    - w[k + 2] * h1 / (h2 * (h1 + h2));
            }
        }
        if k + 1 < hi && t[k + 1] > t[k] {
            return (w[k + 1] - w[k]) / (t[k + 1] - t[k]);
        }
        0.0
    }

    /// `phi_k + omega_k tau + a tau^2 / 2` for tau between 0 and `span` (either sign): its
    /// value at the end `span`, and its stationary point where that lies inside, as (t, phi).
    fn quadratic_ends(&self, k: usize, span: f64, a: f64) -> QuadraticEnds {
        let (p, w) = (self.phi[k], self.omega[k]);
        let at = |tau: f64| (self.t[k] + tau, p + w * tau + 0.5 * a * tau * tau);
        let tau = -w / a;
        let inside = a != 0.0
            && if span > 0.0 {
                tau > 0.0 && tau < span
            } else {
                tau < 0.0 && tau > span
            };
        QuadraticEnds {
            end: at(span),
            stationary: inside.then(|| at(tau)),
        }
    }

    /// Where the extrapolation from sample `k` (acceleration from samples `lo..=k`) reaches
    /// zero inside `(t_k, t_next]`, heading there from sample `k`'s side.
    fn reaches_zero_between(&self, k: usize, next: usize, lo: usize) -> Option<f64> {
        let (p, w) = (self.phi[k], self.omega[k]);
        if p == 0.0 || p * w >= 0.0 {
            return None;
        }
        let span = self.t[next] - self.t[k];
        let a = self.one_sided_acceleration(k, lo);
        smallest_root_in(p, w, 0.5 * a, span).map(|tau| self.t[k] + tau)
    }

    /// The time in `(t_k, t_next]` at which phi reaches `level`, extrapolated from sample `k`
    /// with the acceleration from samples `lo..=k` (see the module docs); linear interpolation
    /// between samples `k` and `next` where the extrapolation finds no crossing.
    fn crossing_from(&self, k: usize, next: usize, lo: usize, level: f64) -> f64 {
        let (t0, t1) = (self.t[k], self.t[next]);
        let span = t1 - t0;
        let d = self.phi[k] - level;
        let lin = |p1: f64| {
            let d1 = p1 - level;
            if d == d1 {
                t0
            } else {
                t0 + span * d / (d - d1)
            }
        };
        if d == 0.0 {
            return t0;
        }
        let w = self.omega[k];
        let a = self.one_sided_acceleration(k, lo);
        match smallest_root_in(d, w, 0.5 * a, span) {
            Some(tau) => t0 + tau,
            None => lin(self.phi[next]),
        }
    }

    /// The zero crossing between sample `k` and the next sample `next`, on the other side of
    /// zero, where the interval may hold `kinks` (other blocks' impacts, sorted). Extrapolated
    /// from `k` (acceleration from `lo..=k`) when it crosses before the first kink; else from
    /// `next` backwards (the motion after this block's own impact, acceleration from the
    /// samples after `next` on its side) when that crosses after the last kink and `next` is
    /// not flat; else, with no smooth side to read, as [`Self::crossing_from`].
    fn crossing_between_kinks(&self, k: usize, next: usize, lo: usize, kinks: &[f64]) -> f64 {
        let (t0, t1) = (self.t[k], self.t[next]);
        let first = kinks.partition_point(|&x| x <= t0);
        let inside = &kinks[first..first + kinks[first..].partition_point(|&x| x < t1)];
        let (Some(&first_kink), Some(&last_kink)) = (inside.first(), inside.last()) else {
            return self.crossing_from(k, next, lo, 0.0);
        };
        let span = t1 - t0;
        let ahead = smallest_root_in(
            self.phi[k],
            self.omega[k],
            0.5 * self.one_sided_acceleration(k, lo),
            span,
        )
        .map(|tau| t0 + tau);
        if let Some(tc) = ahead.filter(|&tc| tc <= first_kink) {
            return tc;
        }
        // Read backwards from `next`: phi(t1 - tau) = phi - omega tau + a tau^2 / 2. (A flat
        // `next`, lying on its face, tells nothing of when it landed.)
        if self.phi[next].abs() <= FLAT {
            return self.crossing_from(k, next, lo, 0.0);
        }
        let s = self.phi[next].signum();
        let hi = (next..self.len().min(next + 3))
            .take_while(|&j| self.phi[j].signum() == s && self.phi[j].abs() > FLAT)
            .last()
            .map_or(next + 1, |j| j + 1);
        let back = smallest_root_in(
            self.phi[next],
            -self.omega[next],
            0.5 * self.one_sided_acceleration_ahead(next, hi),
            span,
        )
        .map(|tau| t1 - tau);
        match back.filter(|&tc| tc >= last_kink) {
            Some(tc) => tc,
            None => self.crossing_from(k, next, lo, 0.0),
        }
    }
}

/// A quadratic extrapolation over a span ([`History::quadratic_ends`]).
struct QuadraticEnds {
    end: (f64, f64),
    stationary: Option<(f64, f64)>,
}

/// Smallest root of `c + b tau + a tau^2` in `(0, span]`, if any.
fn smallest_root_in(c: f64, b: f64, a: f64, span: f64) -> Option<f64> {
    let ok = |tau: f64| tau.is_finite() && tau > 0.0 && tau <= span;
    let roots: [f64; 2] = if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        [-c / b, f64::NAN]
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        // The stable pair: q = -(b + sign(b) sqrt(disc)) / 2, roots q / a and c / q.
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        if q == 0.0 {
            [0.0, f64::NAN]
        } else {
            [q / a, c / q]
        }
    };
    roots
        .into_iter()
        .filter(|&r| ok(r))
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.min(r))))
}

/// Largest |phi| on one stretch of the history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// 0: before the first impact; k: between impact k and impact k+1 (or the end).
    pub after_impact: usize,
    /// Time of the peak, s.
    pub t: f64,
    /// Signed rotation at the peak, rad.
    pub phi: f64,
    /// |phi|, rad.
    pub amplitude: f64,
}

/// A rotation at most this is flat (rad): round-off of a block lying on its face.
pub const FLAT: f64 = 1e-12;

/// Zero crossings that count as impacts (see the module docs). `kinks` (sorted) are the other
/// blocks' impacts, where this block's rate may jump too: a crossing is extrapolated from the
/// side of its interval that has no kink before it, where one side has none.
pub fn impacts(h: &History, floor: f64, kinks: &[f64]) -> Vec<f64> {
    let (t, phi) = (h.t, h.phi);
    let n = phi.len();
    let mut out = Vec::new();
    let mut last_sign = 0.0f64; // sign of the current half-wave; 0 while flat
    let mut last_idx = 0usize; // last sample of the current half-wave
    let mut stretch_start = 0usize; // first sample of the current half-wave
    let mut wave_max = 0.0f64;
    let land = |out: &mut Vec<f64>, from: usize, k: usize, lo: usize| {
        let tc = h.crossing_between_kinks(from, k, lo, kinks);
        out.push(tc.clamp(t[from], t[k]));
    };
    // Whether the half-wave on samples `start..=end` reaches the floor: its largest sample, or
    // below that its extremum between the samples (a half-wave whose samples peak just under
    // the floor can peak above it between them).
    let reaches_floor = |start: usize, end: usize, wave_max: f64| {
        wave_max >= floor
            || (wave_max >= 0.5 * floor
                && stretch_peak(h, start, end + 1, 0, kinks).amplitude >= floor)
    };
    for k in 0..n {
        let p = phi[k];
        if p.abs() <= FLAT {
            // The half-wave ends flat: the block landed on its face, and the sign of its
            // round-off while it lies there is no rotation. An impact where it reaches zero,
            // unless the history ends on this one flat sample (it may end on a crossing).
            if last_sign != 0.0 && k + 1 < n && reaches_floor(stretch_start, last_idx, wave_max) {
                // Passing through zero at the rate it arrived with, the sample is the crossing
                // (to FLAT / |omega|); stopped or turned there, the crossing is extrapolated
                // from the last sample of the half-wave.
                let w = h.omega[k];
                let through = -last_sign * w > 0.0 && w.abs() >= 0.5 * h.omega[last_idx].abs();
                if through {
                    out.push((t[k] - p / w).clamp(t[last_idx], t[k + 1]));
                } else {
                    land(&mut out, last_idx, k, stretch_start.min(last_idx));
                }
            }
            last_sign = 0.0;
            wave_max = 0.0;
            continue;
        }
        let s = p.signum();
        if last_sign == 0.0 {
            stretch_start = k;
        } else if s != last_sign {
            if reaches_floor(stretch_start, last_idx, wave_max) {
                land(&mut out, last_idx, k, stretch_start.min(last_idx));
            }
            wave_max = 0.0;
            stretch_start = k;
        } else if landed_within(h, last_idx, k)
            && let Some(tc) = h.reaches_zero_between(last_idx, k, stretch_start.min(last_idx))
        {
            // Landed and rebounded inside the interval: the half-wave ended at its crossing,
            // and what follows on the same side is a new one.
            if reaches_floor(stretch_start, last_idx, wave_max) {
                out.push(tc);
            }
            wave_max = 0.0;
            stretch_start = k;
        }
        wave_max = wave_max.max(p.abs());
        last_sign = s;
        last_idx = k;
    }
    out
}

/// Whether the block, heading to zero at sample `k`, is seen at `next` stopped by a landing
/// inside the interval: `next` lies at zero to [`LANDED`] of the way the rate of `k` covers in
/// the interval, and its rate has collapsed to a tenth of `k`'s. (Still heading in, or stopped
/// short of zero by a soft contact or a neighbour, it has not landed: a looser test put
/// landings where none happened, and made a soft-contact engine's count depend on its
/// sampling.)
fn landed_within(h: &History, k: usize, next: usize) -> bool {
    let rate = h.omega[k].abs();
    h.phi[k] * h.omega[k] < 0.0
        && h.phi[next].abs() <= LANDED * rate * (h.t[next] - h.t[k])
        && h.omega[next].abs() <= 0.1 * rate
}

/// See [`landed_within`].
const LANDED: f64 = 0.05;

/// Peak amplitudes around the given impacts (see the module docs). `kinks` (sorted) are the
/// other instants where the rate may jump: the impacts of the other blocks of the scene, whose
/// impulses reach this block through its contacts. No interpolant is taken across one. A last
/// stretch still growing where the history ends has no peak (its largest |phi| is where the
/// history stops), unless it is the only one.
pub fn peaks(h: &History, impacts: &[f64], kinks: &[f64]) -> Vec<Peak> {
    let t = h.t;
    // Sample ranges of the stretches between impacts.
    let mut out: Vec<Peak> = Vec::with_capacity(impacts.len() + 1);
    let mut k = 0usize;
    for seg in 0..=impacts.len() {
        let start = k;
        while k < t.len() && (seg == impacts.len() || t[k] <= impacts[seg]) {
            k += 1;
        }
        if k > start {
            out.push(stretch_peak(h, start, k, seg, kinks));
        }
    }
    if let (Some(last), Some(&end)) = (out.last(), t.last())
        && last.t >= end
        && out.len() > 1
    {
        out.pop();
    }
    out
}

/// Every block's impacts in a scene of `n` blocks whose rotation histories (measured rotation
/// and rate on the times `t`) `history` makes: each block's crossings read with the others'
/// impacts as kinks ([`impacts`]), those found first without kinks.
pub fn scene_impacts(
    n: usize,
    t: &[f64],
    history: impl Fn(usize) -> (Vec<f64>, Vec<f64>),
    floor: f64,
) -> Vec<Vec<f64>> {
    let of = |i: usize, kinks: &[f64]| {
        let (phi, omega) = history(i);
        impacts(&History::new(t, &phi, &omega), floor, kinks)
    };
    let first: Vec<Vec<f64>> = (0..n).map(|i| of(i, &[])).collect();
    if n < 2 {
        return first;
    }
    (0..n)
        .map(|i| {
            let others = first
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, imp)| imp.as_slice());
            of(i, &all_impacts(others))
        })
        .collect()
}

/// The largest |phi| of the history, at its extremum between the samples (as a peak is
/// located: [`peaks`], `kinks` the instants where the rate may jump), not at its largest
/// sample; 0 for an empty history.
pub fn max_abs(h: &History, kinks: &[f64]) -> f64 {
    if h.is_empty() {
        return 0.0;
    }
    stretch_peak(h, 0, h.len(), 0, kinks).amplitude
}

/// Every impact of the blocks whose impacts are given, in order: the instants where a rate may
/// jump in every block touching them (the `kinks` of [`peaks`]).
pub fn all_impacts<'a>(impacts: impl IntoIterator<Item = &'a [f64]>) -> Vec<f64> {
    let mut all: Vec<f64> = impacts.into_iter().flatten().copied().collect();
    all.sort_by(f64::total_cmp);
    all.dedup();
    all
}

/// The extremum of |phi| over samples `start..end`, one stretch between impacts.
fn stretch_peak(h: &History, start: usize, end: usize, after_impact: usize, kinks: &[f64]) -> Peak {
    let (t, phi, w) = (h.t, h.phi, h.omega);
    let k = (start..end).fold(
        start,
        |m, j| if phi[j].abs() > phi[m].abs() { j } else { m },
    );
    let sample = Peak {
        after_impact,
        t: t[k],
        phi: phi[k],
        amplitude: phi[k].abs(),
    };
    let s = phi[k].signum();
    // A kink strictly inside the interval (t_i, t_{i+1}).
    let kink_in = |i: usize| -> Option<f64> {
        let j = kinks.partition_point(|&x| x <= t[i]);
        kinks.get(j).copied().filter(|&x| x < t[i + 1])
    };
    // The rate changes sign from outward (s w > 0) to inward inside an adjacent interval.
    let hermite = |i: usize| -> Option<Peak> {
        if i < start || i + 1 >= end || kink_in(i).is_some() {
            return None;
        }
        let (w0, w1) = (s * w[i], s * w[i + 1]);
        if !(w0 >= 0.0 && w1 <= 0.0) || w0 == w1 {
            return None;
        }
        let (tp, p) = hermite_extremum(t[i], t[i + 1], phi[i], phi[i + 1], w[i], w[i + 1])?;
        Some(Peak {
            after_impact,
            t: tp,
            phi: p,
            amplitude: p.abs(),
        })
    };
    // An interval holding a kink: the value at the kink, and each side's turning point.
    let across = |i: usize| -> Option<Peak> {
        if i < start || i + 1 >= end {
            return None;
        }
        let tk = kink_in(i)?;
        let (before_span, after_span) = (tk - t[i], tk - t[i + 1]);
        let before = h.quadratic_ends(i, before_span, h.one_sided_acceleration(i, start));
        let after = h.quadratic_ends(
            i + 1,
            after_span,
            h.one_sided_acceleration_ahead(i + 1, end),
        );
        // The kink's value from the nearer side (the farther side's extrapolation, over most
        // of the interval and from a single sample's rate near a stretch's end, overshoots:
        // +21 % on a 4e-5 rad peak), and each side's turning point inside its own span.
        let at_kink = if before_span <= -after_span {
            before.end
        } else {
            after.end
        };
        let (tp, p) = [before.stationary, after.stationary]
            .into_iter()
            .flatten()
            .fold(at_kink, |m, c| if s * c.1 > s * m.1 { c } else { m });
        Some(Peak {
            after_impact,
            t: tp,
            phi: p,
            amplitude: p.abs(),
        })
    };
    let parabola = || {
        let no_kink = k > start && k + 1 < end && kink_in(k - 1).is_none() && kink_in(k).is_none();
        no_kink
            .then(|| parabola_extremum(h, k, start, end, after_impact))
            .flatten()
    };
    // The extremum of the intervals on either side of the largest sample that hold one: a
    // turning of the rate, or a kink (both sides of the sample may hold another block's
    // impact).
    let previous = k.checked_sub(1);
    let refined = [
        hermite(k),
        previous.and_then(hermite),
        across(k),
        previous.and_then(across),
    ]
    .into_iter()
    .flatten()
    .filter(|p| p.phi.signum() == s)
    .reduce(|m, c| if c.amplitude > m.amplitude { c } else { m })
    .or_else(parabola);
    match refined {
        Some(p) if p.amplitude >= sample.amplitude && p.phi.signum() == s => p,
        _ => sample,
    }
}

/// The stationary point of the cubic Hermite interpolant of (p, w) on `[t0, t1]`.
fn hermite_extremum(t0: f64, t1: f64, p0: f64, p1: f64, w0: f64, w1: f64) -> Option<(f64, f64)> {
    let hs = t1 - t0;
    if hs <= 0.0 {
        return None;
    }
    let (m0, m1) = (hs * w0, hs * w1);
    // p(s) = h00 p0 + h10 m0 + h01 p1 + h11 m1; dp/ds = A s^2 + B s + C.
    let a = 6.0 * p0 + 3.0 * m0 - 6.0 * p1 + 3.0 * m1;
    let b = -6.0 * p0 - 4.0 * m0 + 6.0 * p1 - 2.0 * m1;
    let c = m0;
    let sroot = if c == 0.0 {
        0.0
    } else if m1 == 0.0 {
        1.0
    } else {
        smallest_root_in(c, b, a, 1.0)?
    };
    let s = sroot;
    let (s2, s3) = (s * s, s * s * s);
    let p = (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * m0
        + (-2.0 * s3 + 3.0 * s2) * p1
        + (s3 - s2) * m1;
    Some((t0 + s * hs, p))
}

/// The vertex of the parabola through samples `k-1, k, k+1`, where all three lie in
/// `start..end` and the vertex lies between the outer two.
fn parabola_extremum(
    h: &History,
    k: usize,
    start: usize,
    end: usize,
    after_impact: usize,
) -> Option<Peak> {
    if k == start || k + 1 >= end {
        return None;
    }
    let (t, phi) = (h.t, h.phi);
    let (ta, tb, tc) = (t[k - 1], t[k], t[k + 1]);
    let (pa, pb, pc) = (phi[k - 1], phi[k], phi[k + 1]);
    // Divided differences: p(t) = pb + d1 (t - tb) + d2 (t - tb)(t - ta)... in Newton form.
    let dab = (pb - pa) / (tb - ta);
    let dbc = (pc - pb) / (tc - tb);
    let d2 = (dbc - dab) / (tc - ta);
    if d2 == 0.0 || !d2.is_finite() {
        return None;
    }
    // p(t) = pa + dab (t - ta) + d2 (t - ta)(t - tb); p'(t*) = 0.
    let ts = 0.5 * (ta + tb) - dab / (2.0 * d2);
    if !(ts > ta && ts < tc) {
        return None;
    }
    let p = pa + dab * (ts - ta) + d2 * (ts - ta) * (ts - tb);
    Some(Peak {
        after_impact,
        t: ts,
        phi: p,
        amplitude: p.abs(),
    })
}

/// Earliest time after which |phi| < eps for good (see the module docs).
pub fn rest_time(h: &History, eps: f64) -> Option<f64> {
    let (t, phi) = (h.t, h.phi);
    let last = phi.iter().rposition(|p| p.abs() >= eps);
    match last {
        None => t.first().copied(),
        Some(k) if k + 1 < t.len() => {
            let s = phi[k].signum();
            let lo = stretch_start(phi, k);
            Some(h.crossing_from(k, k + 1, lo, s * eps).clamp(t[k], t[k + 1]))
        }
        Some(_) => None,
    }
}

/// First index of the run of samples of the same sign as `phi[k]` that ends at `k`.
fn stretch_start(phi: &[f64], k: usize) -> usize {
    let s = phi[k].signum();
    let mut lo = k;
    while lo > 0 && phi[lo - 1].signum() == s && phi[lo - 1] != 0.0 {
        lo -= 1;
    }
    lo
}

/// Whether and when the block overturned (see the module docs).
pub fn overturning(h: &History, critical: f64) -> (bool, Option<f64>) {
    let (t, phi) = (h.t, h.phi);
    let n = phi.len();
    if n == 0 {
        return (false, None);
    }
    let flat = phi
        .iter()
        .position(|p| p.abs() >= std::f64::consts::FRAC_PI_2 - ON_SIDE_TOLERANCE);
    let end = match flat {
        Some(k) => k,
        None => {
            let growing = n >= 2 && phi[n - 1].abs() > phi[n - 2].abs() && !h.resting();
            if phi[n - 1].abs() > critical && growing {
                n - 1
            } else {
                return (false, None);
            }
        }
    };
    let cross = (1..=end)
        .rev()
        .find(|&k| phi[k - 1].abs() <= critical && phi[k].abs() > critical)
        .map(|k| {
            let s = phi[k].signum();
            let lo = stretch_start(phi, k - 1);
            h.crossing_from(k - 1, k, lo, s * critical)
                .clamp(t[k - 1], t[k])
        });
    (true, cross.or(Some(t[end])))
}
#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|k| k as f64 * dt).collect()
    }

    /// Samples of `f(t) -> (phi, omega)` on `t`.
    fn sample(t: &[f64], f: impl Fn(f64) -> (f64, f64)) -> (Vec<f64>, Vec<f64>) {
        t.iter().map(|&x| f(x)).unzip()
    }

    /// The linearised Housner motion of a block released from `phi0` at rest: half-waves
    /// `phi = s (alpha - (alpha - A) cosh(p tau) + (w/p) sinh(p tau))`, the rate multiplied by
    /// `r` at each zero crossing. Returns the exact crossing instants and the exact peaks.
    struct Rocking {
        alpha: f64,
        p: f64,
        r: f64,
        phi0: f64,
    }

    impl Rocking {
        /// (impact instants, amplitudes after each impact incl. the first half-wave's).
        fn exact(&self, n: usize) -> (Vec<f64>, Vec<f64>) {
            let (al, p) = (self.alpha, self.p);
            let (mut t0, mut amp, mut imps, mut amps) = (0.0, self.phi0, vec![], vec![self.phi0]);
            for _ in 0..n {
                // From a peak `amp` (at rest), the crossing after acosh(alpha/(alpha-amp))/p.
                let tau = (al / (al - amp)).acosh() / p;
                let w = p * (al - amp) * (p * tau).sinh(); // speed at the crossing
                let w1 = self.r * w;
                // Next peak: energy of the linear motion: (al - A1)^2 = al^2 - (w1/p)^2.
                let a1 = al - (al * al - (w1 / p).powi(2)).sqrt();
                let rise = (w1 / (p * al)).atanh() / p;
                imps.push(t0 + tau);
                amps.push(a1);
                t0 += tau + rise;
                amp = a1;
            }
            (imps, amps)
        }

        fn at(&self, t: f64) -> (f64, f64) {
            let (al, p) = (self.alpha, self.p);
            let (mut t0, mut amp, mut s) = (0.0, self.phi0, 1.0);
            loop {
                if amp < 1e-15 {
                    return (0.0, 0.0); // past the accumulation point of the impacts: at rest
                }
                let tau = (al / (al - amp)).acosh() / p;
                if t <= t0 + tau {
                    let x = p * (t - t0);
                    return (
                        s * (al - (al - amp) * x.cosh()),
                        -s * p * (al - amp) * x.sinh(),
                    );
                }
                let w1 = self.r * p * (al - amp) * (p * tau).sinh();
                let a1 = al - (al * al - (w1 / p).powi(2)).sqrt();
                let rise = (w1 / (p * al)).atanh() / p;
                if t <= t0 + tau + rise {
                    let x = p * (t - t0 - tau);
                    return (
                        -s * (al - al * x.cosh() + (w1 / p) * x.sinh()),
                        -s * (-al * p * x.sinh() + w1 * x.cosh()),
                    );
                }
                t0 += tau + rise;
                amp = a1;
                s = -s;
            }
        }
    }

    const SQUARE: Rocking = Rocking {
        alpha: std::f64::consts::FRAC_PI_4,
        p: 2.88,
        r: 0.25,
        phi0: 0.15,
    };

    #[test]
    fn an_impact_inside_a_sample_interval_is_located_from_its_pre_impact_side() {
        let (exact, _) = SQUARE.exact(3);
        let t = grid(800, 1e-3);
        let (phi, omega) = sample(&t, |x| SQUARE.at(x));
        let found = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert!(found.len() >= 3, "{found:?}");
        for (k, (f, e)) in found.iter().zip(&exact).enumerate() {
            // Linear interpolation across the jump is ~0.3 ms late here; the extrapolation's
            // local error is O(h^3).
            let i = t.partition_point(|x| x < e);
            let linear = t[i - 1] + 1e-3 * phi[i - 1] / (phi[i - 1] - phi[i]);
            assert!((linear - e).abs() > 5e-5, "impact {k}: not a biased case");
            assert!((f - e).abs() < 5e-8, "impact {k}: found {f}, exact {e}");
        }
    }

    #[test]
    fn peaks_are_the_extrema_not_the_largest_samples() {
        let (imps, amps) = SQUARE.exact(3);
        let t = grid(800, 1e-3);
        let (phi, omega) = sample(&t, |x| SQUARE.at(x));
        let h = History::new(&t, &phi, &omega);
        let pk = peaks(&h, &imps, &[]);
        for k in 1..3 {
            let p = pk.iter().find(|p| p.after_impact == k).unwrap();
            let largest = phi
                .iter()
                .zip(&t)
                .filter(|(_, x)| **x > imps[k - 1] && **x < imps[k])
                .fold(0.0f64, |m, (p, _)| m.max(p.abs()));
            assert!(
                (p.amplitude - amps[k]).abs() < 1e-3 * (amps[k] - largest).abs(),
                "peak {k}: {} vs exact {}, largest sample {largest}",
                p.amplitude,
                amps[k]
            );
            assert!(
                (p.amplitude - amps[k]).abs() < 1e-11,
                "{} {}",
                p.amplitude,
                amps[k]
            );
        }
    }

    /// A rotation whose rate jumps from outward to inward at `tk`, inside a sample interval
    /// (another block's impact): its peak is at the jump, extrapolated from either side.
    #[test]
    fn a_peak_at_a_kink_is_extrapolated_to_it_from_both_sides() {
        let tk = 0.0503;
        let f = |t: f64| {
            let u = t - tk;
            if t < tk {
                (0.01 + 0.5 * u - 2.0 * u * u, 0.5 - 4.0 * u)
            } else {
                (0.01 - 0.3 * u - 1.0 * u * u, -0.3 - 2.0 * u)
            }
        };
        let t: Vec<f64> = grid(16, 1e-3).iter().map(|t| 0.045 + t).collect();
        let (phi, omega) = sample(&t, f);
        assert!(phi.iter().all(|p| *p > 0.0));
        let h = History::new(&t, &phi, &omega);
        let with = peaks(&h, &[], &[tk]);
        assert!(
            (with[0].amplitude - 0.01).abs() < 1e-15 && (with[0].t - tk).abs() < 1e-15,
            "{with:?}"
        );
        // Without the kink, the cubic through the jump (the rate's sign changes in it) misses.
        let without = peaks(&h, &[], &[]);
        assert!((without[0].amplitude - 0.01).abs() > 1e-5, "{without:?}");
    }

    /// A kink 55 us after a sample, the stretch ending one sample after it: the kink's value is
    /// extrapolated from the nearer side, not from the farther one's single sample (its rate
    /// carried back 0.945 ms, which overshot by 45 %).
    #[test]
    fn a_peak_at_a_kink_is_taken_from_the_nearer_side() {
        let tk = 5.055e-3;
        let f = |t: f64| {
            let u = t - tk;
            if t < tk {
                (4e-5 + 0.002 * u - u * u, 0.002 - 2.0 * u)
            } else {
                (4e-5 - 0.005 * u - 20.0 * u * u, -0.005 - 40.0 * u)
            }
        };
        let t = grid(11, 1e-3);
        let (phi, omega) = sample(&t, f);
        assert!(phi[..7].iter().all(|p| *p > 0.0), "{phi:?}");
        let pk = peaks(&History::new(&t, &phi, &omega), &[6.5e-3], &[tk]);
        assert!((pk[0].amplitude - 4e-5).abs() < 1e-12, "{pk:?}");
    }

    /// A landing, its rebound and the block's settling inside one sample interval, the next
    /// sample a hair above zero on the same side (the pedestal's landing at 4.8533 s in
    /// `two-block-free-rocking`): the impact is where the half-wave reaches zero, not where the
    /// block is next seen flat (1.6 ms late at 1 ms output).
    #[test]
    fn a_landing_rebounding_below_the_floor_within_an_interval_is_located_where_it_lands() {
        let t = grid(8, 1e-3);
        let mut phi: Vec<f64> = t.iter().map(|t| 3.5e-5 - 0.01 * t).collect();
        let mut omega = vec![-0.01; 8];
        (phi[4], omega[4]) = (3e-9, -3e-4);
        for k in 5..8 {
            (phi[k], omega[k]) = (-1.9e-17, 4e-19);
        }
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert_eq!(imp.len(), 1, "{imp:?}");
        assert!((imp[0] - 3.5e-3).abs() < 1e-12, "{imp:?}");
        // Seen still heading in, not stopped (a rate reversal before the interval bent the
        // extrapolation to zero: an impact 570 us early in a three-block stack), it lands after
        // that sample.
        (phi[4], omega[4]) = (3e-6, -7e-3);
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert!(imp.len() == 1 && imp[0] > 4e-3, "{imp:?}");
        // Seen above the floor on the same side, the block turned back before zero: it lands
        // after that sample.
        phi[4] = 2e-5;
        omega[4] = 1e-3;
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert!(imp.len() == 1 && imp[0] > 4e-3, "{imp:?}");
    }

    #[test]
    fn a_parabola_refines_a_peak_without_rates() {
        // Rates zero everywhere (a file without them): the parabola through the samples.
        let t = grid(101, 1e-2);
        let phi: Vec<f64> = t.iter().map(|&x| 1.0 - (x - 0.503).powi(2)).collect();
        let omega = vec![0.0; t.len()];
        let pk = peaks(&History::new(&t, &phi, &omega), &[], &[]);
        assert!((pk[0].amplitude - 1.0).abs() < 1e-12 && (pk[0].t - 0.503).abs() < 1e-12);
    }

    #[test]
    fn a_block_stopped_dead_lands_once() {
        // A quarter of a sine down to zero at t = 0.5, then flat at +1e-17 (round-off): one
        // impact where it reaches zero; the same history ending at the landing sample: none.
        let t = grid(1001, 1e-3);
        let pi = std::f64::consts::PI;
        let (phi, omega) = sample(&t, |x| {
            if x < 0.5 {
                (0.1 * (pi * x).cos(), -0.1 * pi * (pi * x).sin())
            } else {
                (1e-17, 0.0)
            }
        });
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert_eq!(imp.len(), 1, "{imp:?}");
        // Extrapolated from the sample before: local error O(h^3), h = 1e-3.
        assert!((imp[0] - 0.5).abs() < 1e-8, "{imp:?}");
        let n = 501;
        let ended = impacts(
            &History::new(&t[..n], &phi[..n], &omega[..n]),
            NOISE_FLOOR,
            &[],
        );
        assert!(ended.is_empty(), "{ended:?}");
    }

    #[test]
    fn sine_crossings_are_located() {
        let t = grid(4001, 1e-3);
        let pi = std::f64::consts::PI;
        let (phi, omega) = sample(&t, |x| (0.1 * (pi * x).sin(), 0.1 * pi * (pi * x).cos()));
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert_eq!(imp.len(), 3, "{imp:?}"); // crossings at 1, 2, 3 (4 is the last sample)
        for (k, ti) in imp.iter().enumerate() {
            assert!((ti - (k + 1) as f64).abs() < 1e-9, "{ti}");
        }
    }

    /// A block that lands dead on its face, lies there while its rotation's round-off flips
    /// sign, then rocks again on the same side and lands again: two impacts, at the landings,
    /// and the same for its mirror image (the round-off's sign made phantom impacts while it
    /// lay flat and dropped the first landing).
    #[test]
    fn a_block_lying_flat_between_two_episodes_lands_twice_whatever_its_round_off() {
        let t = grid(3001, 1e-3);
        // Half-waves 0.01 sin(pi t / 0.5) on [0, 0.5] and [1.5, 2.0], stopped dead at their
        // ends (rate 0 after them); between and after, a round-off of 1e-20 rad whose sign
        // is set below.
        let wave = |x: f64| {
            let on = (0.0..0.5).contains(&x) || (1.5..2.0).contains(&x);
            let s = std::f64::consts::PI * (x % 1.5) / 0.5;
            if on {
                (0.01 * s.sin(), 0.01 * std::f64::consts::PI / 0.5 * s.cos())
            } else {
                (0.0, 0.0)
            }
        };
        let (mut phi, omega) = sample(&t, wave);
        for (k, p) in phi.iter_mut().enumerate() {
            if p.abs() < 1e-15 {
                // The wave's own sign for a while after it lands, then flipping.
                *p = if k < 600 || k % 2 == 0 { 1e-20 } else { -1e-20 };
            }
        }
        let mirrored: (Vec<f64>, Vec<f64>) = (
            phi.iter().map(|p| -p).collect(),
            omega.iter().map(|w| -w).collect(),
        );
        for (phi, omega) in [(&phi, &omega), (&mirrored.0, &mirrored.1)] {
            let imp = impacts(&History::new(&t, phi, omega), NOISE_FLOOR, &[]);
            assert_eq!(imp.len(), 2, "{imp:?}");
            assert!((imp[0] - 0.5).abs() < 1e-6, "{imp:?}");
            assert!((imp[1] - 2.0).abs() < 1e-6, "{imp:?}");
        }
    }

    #[test]
    fn jitter_below_the_floor_is_not_an_impact() {
        let t = grid(100, 1e-3);
        let phi: Vec<f64> = (0..100)
            .map(|k| if k % 2 == 0 { 1e-7 } else { -1e-7 })
            .collect();
        let omega = vec![0.0; 100];
        assert!(impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]).is_empty());
    }

    /// A half-wave whose samples all lie below the floor while it peaks above it between them
    /// ends in an impact: its refined extremum is what reaches the floor.
    #[test]
    fn a_half_wave_peaking_above_the_floor_between_its_samples_counts() {
        // Sine half-waves of 4 ms, -1e-3 / +1.02e-5 / -1e-3 rad, sampled at 0.5 + k ms: the
        // small one's samples peak at 1.02e-5 sin(3 pi / 8) = 9.42e-6.
        let amp = [-1e-3, 1.02e-5, -1e-3];
        let wave = |t: f64| {
            let i = ((t / 4e-3) as usize).min(2);
            let x = std::f64::consts::PI * (t - 4e-3 * i as f64) / 4e-3;
            (
                amp[i] * x.sin(),
                amp[i] * std::f64::consts::PI / 4e-3 * x.cos(),
            )
        };
        let t: Vec<f64> = (0..12).map(|k| 0.5e-3 + k as f64 * 1e-3).collect();
        let (phi, omega) = sample(&t, wave);
        assert!(phi[4..8].iter().all(|p| p.abs() < NOISE_FLOOR));
        let imp = impacts(&History::new(&t, &phi, &omega), NOISE_FLOOR, &[]);
        assert_eq!(imp.len(), 2, "{imp:?}");
        assert!(
            (imp[0] - 4e-3).abs() < 5e-5 && (imp[1] - 8e-3).abs() < 5e-5,
            "{imp:?}"
        );
    }

    /// Another block's impact inside the interval of this block's crossing changed its rate
    /// before it crossed: the crossing is read backwards from the sample after it, not
    /// extrapolated across the kink from the sample before (300 us early here).
    #[test]
    fn a_crossing_after_another_blocks_impact_is_read_from_after_it() {
        // Rate -1 rad/s to the kink at 1.2 ms, -0.5 after it: zero at 1.8 ms; then -0.4 rad/s.
        let motion = |t: f64| {
            if t <= 1.2e-3 {
                (5e-4 - (t - 1e-3), -1.0)
            } else if t <= 1.8e-3 {
                (3e-4 - 0.5 * (t - 1.2e-3), -0.5)
            } else {
                (-0.4 * (t - 1.8e-3), -0.4)
            }
        };
        let t = grid(6, 1e-3);
        let (phi, omega) = sample(&t, motion);
        let h = History::new(&t, &phi, &omega);
        let across = impacts(&h, NOISE_FLOOR, &[]);
        assert!((across[0] - 1.5e-3).abs() < 1e-9, "{across:?}");
        let read = impacts(&h, NOISE_FLOOR, &[0.5e-3, 1.2e-3, 3.0e-3]);
        assert_eq!(read.len(), 1);
        assert!((read[0] - 1.8e-3).abs() < 1e-9, "{read:?}");
        // A kink after the crossing leaves the extrapolation from before it.
        let kept = impacts(&h, NOISE_FLOOR, &[1.9e-3]);
        assert!((kept[0] - 1.5e-3).abs() < 1e-9, "{kept:?}");
    }

    /// A last stretch still growing where the history ends has no peak (its largest sample is
    /// where the history stops), unless it is the only stretch.
    #[test]
    fn a_stretch_still_growing_at_the_end_has_no_peak() {
        let t = grid(40, 1e-3);
        let (phi, omega) = sample(&t, |x| {
            if x < 10e-3 {
                let y = x - 5e-3;
                (1e-3 - 10.0 * y * y, -20.0 * y)
            } else {
                (-0.05 * (x - 10e-3), -0.05)
            }
        });
        let h = History::new(&t, &phi, &omega);
        let imp = impacts(&h, NOISE_FLOOR, &[]);
        assert_eq!(imp.len(), 1, "{imp:?}");
        let pk = peaks(&h, &imp, &[]);
        assert_eq!(pk.len(), 1, "{pk:?}");
        assert!((pk[0].amplitude - 1e-3).abs() < 1e-12 && pk[0].after_impact == 0);
        // Alone, it is the history's peak.
        let before = h.slice(12..40);
        assert_eq!(peaks(&before, &[], &[]).len(), 1);
    }

    /// The largest |phi| is the extremum between the samples, not the largest sample (the
    /// peaks half way between two samples: 1.2 % low).
    #[test]
    fn the_largest_rotation_is_the_extremum_between_samples() {
        let t: Vec<f64> = (0..40).map(|k| 5e-3 + k as f64 * 1e-2).collect();
        let w = 2.0 * std::f64::consts::PI / 0.2;
        let (phi, omega) = sample(&t, |x| (1e-2 * (w * x).sin(), 1e-2 * w * (w * x).cos()));
        let h = History::new(&t, &phi, &omega);
        let largest_sample = phi.iter().fold(0.0f64, |m, p| m.max(p.abs()));
        assert!(largest_sample < 0.99e-2);
        // The cubic Hermite interpolant errs by O((w h)^4): 2.5e-5 relative at w h = 0.31.
        let refined = max_abs(&h, &[]);
        assert!((refined - 1e-2).abs() < 1e-6, "{refined}");
        assert_eq!(max_abs(&h.slice(0..0), &[]), 0.0);
    }

    #[test]
    fn rest_time_is_the_crossing_of_the_threshold_not_the_next_sample() {
        // phi = 0.1 exp(-t): below 1e-2 from ln 10.
        let t = grid(5001, 1e-3);
        let (phi, omega) = sample(&t, |x| (0.1 * (-x).exp(), -0.1 * (-x).exp()));
        let h = History::new(&t, &phi, &omega);
        let rest = rest_time(&h, 1e-2).unwrap();
        assert!((rest - 10f64.ln()).abs() < 1e-9, "{rest}");
        assert_eq!(rest_time(&h, 1e-9), None);
        assert_eq!(rest_time(&h, 1.0), Some(0.0));
    }

    #[test]
    fn decaying_sequence_rest_times() {
        // |phi| = 0.1 * 0.5^k on [k, k+1): below 1e-2 from t = 4, below 1e-3 from t = 7.
        let t = grid(20_001, 1e-3);
        let phi: Vec<f64> = t
            .iter()
            .map(|&x| 0.1 * 0.5f64.powi(x.floor() as i32))
            .collect();
        let omega = vec![0.0; t.len()];
        let h = History::new(&t, &phi, &omega);
        assert!((rest_time(&h, 1e-2).unwrap() - 4.0).abs() < 1.5e-3);
        assert!((rest_time(&h, 1e-3).unwrap() - 7.0).abs() < 1.5e-3);
    }

    #[test]
    fn peaks_between_impacts() {
        let t = grid(3001, 1e-3);
        let pi = std::f64::consts::PI;
        // Amplitude 0.2 on [0,1), 0.1 on [1,2), 0.05 on [2,3].
        let (phi, omega) = sample(&t, |x| {
            let a = 0.2 * 0.5f64.powi(x.floor().min(2.0) as i32);
            (a * (pi * x).sin(), a * pi * (pi * x).cos())
        });
        let h = History::new(&t, &phi, &omega);
        let imp = impacts(&h, NOISE_FLOOR, &[]);
        let pk = peaks(&h, &imp, &[]);
        assert_eq!(pk.len(), 3);
        for (k, want) in [0.2, 0.1, 0.05].iter().enumerate() {
            assert_eq!(pk[k].after_impact, k);
            assert!(
                (pk[k].amplitude - want).abs() < 1e-12,
                "{}",
                pk[k].amplitude
            );
            assert!((pk[k].t - (k as f64 + 0.5)).abs() < 1e-6, "{}", pk[k].t);
        }
    }

    #[test]
    fn overturning_time_is_the_last_crossing_of_the_critical_angle() {
        let t = grid(2001, 1e-3);
        let (phi, omega) = sample(&t, |x| (0.3 + x * x, 2.0 * x));
        let (over, at) = overturning(&History::new(&t, &phi, &omega), 0.4);
        assert!(over);
        assert!((at.unwrap() - 0.1f64.sqrt()).abs() < 1e-12, "{at:?}");
        let flat = [0.1; 10];
        let (over, _) = overturning(&History::new(&t[..10], &flat, &[0.0; 10]), 0.4);
        assert!(!over);
    }

    #[test]
    fn a_block_at_rest_on_its_side_has_overturned() {
        // Rises past the critical angle, then lies still just below pi/2.
        let t = grid(3001, 1e-3);
        let side = std::f64::consts::FRAC_PI_2 - 3e-7;
        let (phi, omega) = sample(&t, |x| {
            let p = 0.3 + x * x;
            if p < side { (p, 2.0 * x) } else { (side, 0.0) }
        });
        let (over, at) = overturning(&History::new(&t, &phi, &omega), 0.4);
        assert!(over);
        assert!((at.unwrap() - 0.1f64.sqrt()).abs() < 1e-12);
        // Still at rest well below pi/2: not overturned.
        let (phi, omega) = sample(&t, |x| {
            let p = 0.3 + x * x;
            if p < 1.0 { (p, 2.0 * x) } else { (1.0, 0.0) }
        });
        assert!(!overturning(&History::new(&t, &phi, &omega), 0.4).0);
    }

    /// A column leaning at rest on a fallen neighbour, beyond its critical angle: contact
    /// engines end it creeping by round-off or compliance, outwards or back, and the verdict
    /// must not follow the creep's sign. A block that falls there, or turns outwards there
    /// after coming back, is not at rest.
    #[test]
    fn a_block_creeping_at_rest_beyond_its_critical_angle_has_not_overturned() {
        let t = grid(1001, 1e-2);
        let creeping = |creep: f64| {
            let phi: Vec<f64> = t.iter().map(|&x| 1.32 + creep * x).collect();
            overturning(&History::new(&t, &phi, &vec![creep; t.len()]), 0.124).0
        };
        // rapier's, MuJoCo's and PyBullet's creep on a colonnade under El Centro x2 (rad/s).
        for creep in [1.3e-5, 1.0e-7, -1.5e-7, 0.0] {
            assert!(!creeping(creep), "creep {creep}");
        }
        assert!(creeping(10.0 * RESTING_RATE));
        // Falling from 1e-3 rad beyond the angle at p = 2.
        let (alpha, p) = (0.124, 2.0);
        let phi: Vec<f64> = t.iter().map(|&x| alpha + 1e-3 * (p * x).cosh()).collect();
        let omega: Vec<f64> = t.iter().map(|&x| 1e-3 * p * (p * x).sinh()).collect();
        assert!(overturning(&History::new(&t[..50], &phi[..50], &omega[..50]), alpha).0);
        // A slender block after a one-sine pulse (alpha 0.030 rad, p 2.71 1/s), 7.8e-3 rad
        // beyond its critical angle, that was coming back and turns outwards 0.3 ms before the
        // history ends (sampled every 5e-4 s): it accelerates outwards at p^2 (phi - alpha).
        let (alpha, a) = (0.030, 2.71f64.powi(2) * 7.8e-3);
        let t = grid(401, 5e-4);
        let turn = t[400] - 3e-4;
        let phi: Vec<f64> = t
            .iter()
            .map(|&x| 0.0378 + 0.5 * a * (x - turn).powi(2))
            .collect();
        let omega: Vec<f64> = t.iter().map(|&x| a * (x - turn)).collect();
        assert!(overturning(&History::new(&t, &phi, &omega), alpha).0);
    }

    #[test]
    fn the_stable_quadratic_root_is_the_smallest_in_the_interval() {
        assert_eq!(smallest_root_in(-1.0, 1.0, 0.0, 2.0), Some(1.0));
        assert_eq!(smallest_root_in(-1.0, 1.0, 0.0, 0.5), None);
        // (tau - 1)(tau - 3) = tau^2 - 4 tau + 3.
        let r = smallest_root_in(3.0, -4.0, 1.0, 10.0).unwrap();
        assert!((r - 1.0).abs() < 1e-15);
        assert_eq!(smallest_root_in(1.0, 0.0, 1.0, 10.0), None);
    }
}
