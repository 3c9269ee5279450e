//! Events of a rotation history, one definition for every engine (VALIDATION.md).
//!
//! - **Impact**: a zero crossing of the rotation (relative rotation for a block on another
//!   block), located by linear interpolation between samples. A crossing counts only when the
//!   largest |phi| of the half-wave that ends at it reaches the noise floor (default 1e-5 rad),
//!   so jitter about zero is not counted.
//! - **Peak amplitude**: max |phi| before the first impact and between consecutive impacts.
//! - **Rest time** at epsilon: the earliest sample time after which |phi| stays below epsilon
//!   to the end of the history (`None` if the last sample is not below it).
//! - **Overturning**: |phi| reaches pi/2 (to within [`ON_SIDE_TOLERANCE`]: a block that fell
//!   onto its side rests a hair below pi/2 in a contact engine), or ends beyond the block's
//!   critical angle atan(B/H) and still growing; the overturn time is the last upward crossing
//!   of the critical angle before that.

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

/// Zero crossings that count as impacts (see the module docs).
pub fn impacts(t: &[f64], phi: &[f64], floor: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut last_sign = 0.0f64;
    let mut last_idx = 0usize; // last sample with a non-zero rotation
    let mut wave_max = 0.0f64;
    for k in 0..phi.len() {
        let p = phi[k];
        if p == 0.0 {
            continue;
        }
        let s = p.signum();
        if last_sign != 0.0 && s != last_sign {
            if wave_max >= floor {
                let (t0, p0, t1, p1) = (t[last_idx], phi[last_idx], t[k], p);
                out.push(t0 + (t1 - t0) * p0 / (p0 - p1));
            }
            wave_max = 0.0;
        }
        wave_max = wave_max.max(p.abs());
        last_sign = s;
        last_idx = k;
    }
    out
}

/// Peak amplitudes around the given impacts.
pub fn peaks(t: &[f64], phi: &[f64], impacts: &[f64]) -> Vec<Peak> {
    let mut out: Vec<Peak> = Vec::with_capacity(impacts.len() + 1);
    let mut seg = 0usize;
    let mut cur: Option<Peak> = None;
    for k in 0..t.len() {
        while seg < impacts.len() && t[k] > impacts[seg] {
            if let Some(p) = cur.take() {
                out.push(p);
            }
            seg += 1;
        }
        let a = phi[k].abs();
        if cur.is_none_or(|p| a > p.amplitude) {
            cur = Some(Peak {
                after_impact: seg,
                t: t[k],
                phi: phi[k],
                amplitude: a,
            });
        }
    }
    if let Some(p) = cur {
        out.push(p);
    }
    out
}

/// Earliest time after which |phi| < eps for good.
pub fn rest_time(t: &[f64], phi: &[f64], eps: f64) -> Option<f64> {
    let last = phi.iter().rposition(|p| p.abs() >= eps);
    match last {
        None => t.first().copied(),
        Some(k) if k + 1 < t.len() => Some(t[k + 1]),
        Some(_) => None,
    }
}

/// Whether and when the block overturned.
pub fn overturning(t: &[f64], phi: &[f64], critical: f64) -> (bool, Option<f64>) {
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
            let growing = n >= 2 && phi[n - 1].abs() > phi[n - 2].abs();
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
            let (a0, a1) = (phi[k - 1].abs(), phi[k].abs());
            t[k - 1] + (t[k] - t[k - 1]) * (critical - a0) / (a1 - a0)
        });
    (true, cross.or(Some(t[end])))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|k| k as f64 * dt).collect()
    }

    #[test]
    fn sine_crossings_are_located() {
        let t = grid(4001, 1e-3);
        let phi: Vec<f64> = t
            .iter()
            .map(|&x| 0.1 * (std::f64::consts::PI * x).sin())
            .collect();
        let imp = impacts(&t, &phi, NOISE_FLOOR);
        assert_eq!(imp.len(), 3, "{imp:?}"); // crossings at 1, 2, 3 (4 is the last sample)
        for (k, ti) in imp.iter().enumerate() {
            assert!((ti - (k + 1) as f64).abs() < 1e-6, "{ti}");
        }
    }

    #[test]
    fn jitter_below_the_floor_is_not_an_impact() {
        let t = grid(100, 1e-3);
        let phi: Vec<f64> = (0..100)
            .map(|k| if k % 2 == 0 { 1e-7 } else { -1e-7 })
            .collect();
        assert!(impacts(&t, &phi, NOISE_FLOOR).is_empty());
    }

    #[test]
    fn decaying_sequence_rest_times() {
        // |phi| = 0.1 * 0.5^k on [k, k+1): below 1e-2 from t = 4, below 1e-3 from t = 7.
        let t = grid(20_001, 1e-3);
        let phi: Vec<f64> = t
            .iter()
            .map(|&x| 0.1 * 0.5f64.powi(x.floor() as i32))
            .collect();
        assert!((rest_time(&t, &phi, 1e-2).unwrap() - 4.0).abs() < 1.5e-3);
        assert!((rest_time(&t, &phi, 1e-3).unwrap() - 7.0).abs() < 1.5e-3);
        assert_eq!(rest_time(&t, &phi, 1e-9), None);
    }

    #[test]
    fn peaks_between_impacts() {
        let t = grid(3001, 1e-3);
        // Amplitude 0.2 on [0,1), 0.1 on [1,2), 0.05 on [2,3].
        let phi: Vec<f64> = t
            .iter()
            .map(|&x| {
                let a = 0.2 * 0.5f64.powi(x.floor().min(2.0) as i32);
                a * (std::f64::consts::PI * x).sin()
            })
            .collect();
        let imp = impacts(&t, &phi, NOISE_FLOOR);
        let pk = peaks(&t, &phi, &imp);
        assert_eq!(pk.len(), 3);
        for (k, want) in [0.2, 0.1, 0.05].iter().enumerate() {
            assert_eq!(pk[k].after_impact, k);
            assert!((pk[k].amplitude - want).abs() < 1e-6);
        }
    }

    #[test]
    fn overturning_time_is_the_last_crossing_of_the_critical_angle() {
        let t = grid(2001, 1e-3);
        let phi: Vec<f64> = t.iter().map(|&x| 0.3 + x * x).collect();
        let (over, at) = overturning(&t, &phi, 0.4);
        assert!(over);
        assert!((at.unwrap() - 0.1f64.sqrt()).abs() < 1e-3);
        let (over, _) = overturning(&t, &[0.1; 10], 0.4);
        assert!(!over);
    }

    #[test]
    fn a_block_at_rest_on_its_side_has_overturned() {
        // Rises past the critical angle, then lies still just below pi/2.
        let t = grid(3001, 1e-3);
        let side = std::f64::consts::FRAC_PI_2 - 3e-7;
        let phi: Vec<f64> = t.iter().map(|&x| (0.3 + x * x).min(side)).collect();
        let (over, at) = overturning(&t, &phi, 0.4);
        assert!(over);
        assert!((at.unwrap() - 0.1f64.sqrt()).abs() < 1e-3);
        // Still at rest well below pi/2: not overturned.
        let phi: Vec<f64> = t.iter().map(|&x| (0.3 + x * x).min(1.0)).collect();
        assert!(!overturning(&t, &phi, 0.4).0);
    }
}
