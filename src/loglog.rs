//! Slopes on log-log axes: the least-squares slope of `ln y` against `ln x` with its standard
//! error, the slopes between neighbouring points, and the slope end to end. The observed order
//! of accuracy ([`crate::converge`]: an error against the step size) and the growth of a cost
//! with a problem's size (the walls' dynamic series, `make bench-dynamic`) are both such slopes.

/// A log-log fit of `y` against `x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogLogFit {
    /// Least-squares slope of `ln y` against `ln x`.
    pub slope: f64,
    /// Its standard error (three points or more).
    pub std_error: Option<f64>,
    /// The smallest and largest slope between neighbouring points (sorted by `x`).
    pub local: (f64, f64),
    /// The slope from the point of smallest `x` to the point of largest `x`.
    pub end_to_end: f64,
    /// Points fitted.
    pub points: usize,
}

/// Fit `pairs` of `(x, y)`. Points whose `x` or `y` is not a positive finite number are left
/// out (an error of zero has no logarithm); `None` when fewer than two distinct `x` remain.
pub fn fit(pairs: &[(f64, f64)]) -> Option<LogLogFit> {
    let positive = |v: f64| v > 0.0 && v.is_finite();
    let mut pts: Vec<(f64, f64)> = pairs
        .iter()
        .filter(|(x, y)| positive(*x) && positive(*y))
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / nf;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx == 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let std_error = (n >= 3).then(|| {
        let ssr: f64 = pts
            .iter()
            .map(|p| (p.1 - my - slope * (p.0 - mx)).powi(2))
            .sum();
        (ssr / (nf - 2.0) / sxx).sqrt()
    });
    let local = pts
        .windows(2)
        .filter(|w| w[1].0 != w[0].0)
        .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let (first, last) = (pts[0], pts[n - 1]);
    Some(LogLogFit {
        slope,
        std_error,
        local,
        end_to_end: (last.1 - first.1) / (last.0 - first.0),
        points: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_power_law_has_its_exponent_everywhere() {
        let pairs: Vec<(f64, f64)> = [43.0, 107.0, 215.0, 430.0]
            .iter()
            .map(|&n| (n, 3e-3 * f64::powf(n, 1.2)))
            .collect();
        let f = fit(&pairs).unwrap();
        for s in [f.slope, f.end_to_end, f.local.0, f.local.1] {
            assert!((s - 1.2).abs() < 1e-12, "{f:?}");
        }
        assert!(f.std_error.unwrap() < 1e-12);
        assert_eq!(f.points, 4);
    }

    #[test]
    fn a_bent_series_is_told_apart_end_to_end_and_fitted() {
        // slope 1 then 2: the ends give 1.5, the neighbours 1 and 2, the fit in between with
        // a standard error that is not zero
        let pairs = [(1.0, 1.0), (10.0, 10.0), (100.0, 1000.0)];
        let f = fit(&pairs).unwrap();
        assert!((f.end_to_end - 1.5).abs() < 1e-12);
        assert!((f.local.0 - 1.0).abs() < 1e-12 && (f.local.1 - 2.0).abs() < 1e-12);
        assert!((f.slope - 1.5).abs() < 1e-12);
        assert!(f.std_error.unwrap() > 0.1);
        // the order of the pairs does not matter
        let g = fit(&[pairs[2], pairs[0], pairs[1]]).unwrap();
        assert_eq!(f, g);
    }

    #[test]
    fn points_without_a_logarithm_are_left_out() {
        let f = fit(&[(1.0, 2.0), (2.0, 0.0), (4.0, 16.0), (f64::NAN, 1.0)]).unwrap();
        assert_eq!(f.points, 2);
        assert!((f.slope - 1.5).abs() < 1e-12);
        assert!(f.std_error.is_none());
        assert_eq!(fit(&[(1.0, 1.0)]), None);
        assert_eq!(fit(&[(2.0, 1.0), (2.0, 3.0)]), None);
    }
}
