//! The common grid: linear interpolation of sampled histories onto one uniform grid.

/// Uniform grid `t0, t0 + dt, ...` up to `t1` (inclusive within 1e-9 dt).
pub fn uniform_grid(t0: f64, t1: f64, dt: f64) -> Vec<f64> {
    if t1.is_nan() || t0.is_nan() || t1 < t0 || dt.is_nan() || dt <= 0.0 {
        return Vec::new();
    }
    let n = ((t1 - t0) / dt + 1e-9).floor() as usize + 1;
    (0..n).map(|k| t0 + k as f64 * dt).collect()
}

/// Linear interpolation of `(t, y)` (t non-decreasing) at the sorted times `at`.
/// Times outside `[t[0], t[last]]` take the end values.
pub fn interpolate(t: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    let n = t.len().min(y.len());
    let mut out = Vec::with_capacity(at.len());
    if n == 0 {
        return vec![f64::NAN; at.len()];
    }
    let mut j = 0usize;
    for &x in at {
        if x <= t[0] {
            out.push(y[0]);
            continue;
        }
        if x >= t[n - 1] {
            out.push(y[n - 1]);
            continue;
        }
        while j + 1 < n && t[j + 1] < x {
            j += 1;
        }
        // t[j] < x <= t[j + 1]
        let (t0, t1) = (t[j], t[j + 1]);
        let v = if t1 > t0 {
            y[j] + (y[j + 1] - y[j]) * (x - t0) / (t1 - t0)
        } else {
            y[j + 1]
        };
        out.push(v);
    }
    out
}

/// RMS and max of |a - b| over the first `n` points.
pub fn rms_and_max(a: &[f64], b: &[f64], n: usize) -> (f64, f64) {
    let n = n.min(a.len()).min(b.len());
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let (mut s, mut m) = (0.0f64, 0.0f64);
    for k in 0..n {
        let d = (a[k] - b[k]).abs();
        s += d * d;
        m = m.max(d);
    }
    ((s / n as f64).sqrt(), m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_includes_both_ends() {
        let g = uniform_grid(0.0, 1.0, 1e-3);
        assert_eq!(g.len(), 1001);
        assert!((g[1000] - 1.0).abs() < 1e-12);
        assert!(uniform_grid(1.0, 0.0, 1e-3).is_empty());
    }

    #[test]
    fn interpolation_is_exact_on_lines_and_clamped_outside() {
        let t = [0.0, 0.3, 1.0, 2.5];
        let y: Vec<f64> = t.iter().map(|x| 2.0 * x - 1.0).collect();
        let at = [-1.0, 0.0, 0.1, 0.3, 0.77, 2.0, 2.5, 3.0];
        let v = interpolate(&t, &y, &at);
        let want = [-1.0, -1.0, -0.8, -0.4, 0.54, 3.0, 4.0, 4.0];
        for (a, b) in v.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
