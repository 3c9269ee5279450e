//! Fragility fits (docs/fragility.md has the equations).
//!
//! - **Stripes**: binomial maximum likelihood of `P(IM) = Phi((ln IM - ln theta) / beta)`
//!   (Baker 2015), a probit GLM on ln IM solved by iteratively reweighted least squares:
//!   `eta = b0 + b1 ln IM`, `theta = exp(-b0 / b1)`, `beta = 1 / b1`.
//! - **IDA capacities**: lognormal maximum likelihood, right-censored at the highest level for
//!   records that never reach the limit state: without censoring `ln theta = mean(ln c)`,
//!   `beta = sqrt(mean((ln c - ln theta)^2))`; with it, Newton's method on the censored
//!   log-likelihood.
//! - **Intervals**: percentiles 2.5 and 97.5 of the fits to bootstrap resamples of record
//!   pairs ([`Rng`], seeded: reproducible).

use serde::Serialize;

/// Standard normal CDF.
pub fn ncdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}
/// Standard normal survival function 1 - Phi(x), accurate in the upper tail.
pub fn nsf(x: f64) -> f64 {
    0.5 * libm::erfc(x / std::f64::consts::SQRT_2)
}
/// Standard normal density.
pub fn npdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// A lognormal fragility: median `theta` and dispersion `beta`.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Lognormal {
    pub theta: f64,
    pub beta: f64,
}

impl Lognormal {
    pub fn p(&self, im: f64) -> f64 {
        ncdf((im.ln() - self.theta.ln()) / self.beta)
    }
}

/// Probit MLE on stripes: `(ln IM, trials, exceedances)` per level. `Err` says why there is
/// no estimate (no exceedance, all exceed, perfect separation, a decreasing fit).
pub fn probit(stripes: &[(f64, f64, f64)]) -> Result<Lognormal, String> {
    let trials: f64 = stripes.iter().map(|s| s.1).sum();
    let hits: f64 = stripes.iter().map(|s| s.2).sum();
    if hits == 0.0 {
        return Err("no run exceeds the limit state".into());
    }
    if hits == trials {
        return Err("every run exceeds the limit state".into());
    }
    // Separation: every level below some point has none, every level above has all.
    let mut sorted: Vec<&(f64, f64, f64)> = stripes.iter().filter(|s| s.1 > 0.0).collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let fracs: Vec<f64> = sorted.iter().map(|s| s.2 / s.1).collect();
    if fracs.iter().all(|&f| f == 0.0 || f == 1.0) && fracs.windows(2).all(|w| w[0] <= w[1]) {
        return Err("perfect separation (0 below a level, all above): no finite dispersion".into());
    }
    // IRLS from mu = (y + 0.5) / (n + 1).
    let mut eta: Vec<f64> = sorted
        .iter()
        .map(|s| {
            let mu: f64 = (s.2 + 0.5) / (s.1 + 1.0);
            inv_ncdf(mu)
        })
        .collect();
    let mut b = (0.0, 0.0);
    for it in 0..200 {
        let (mut sw, mut swx, mut swxx, mut swz, mut swxz) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (s, &e) in sorted.iter().zip(&eta) {
            let mu = ncdf(e).clamp(1e-300, 1.0 - 1e-16);
            let q = nsf(e).max(1e-300);
            let d = npdf(e).max(1e-300);
            let w = s.1 * d * d / (mu * q);
            let z = e + (s.2 / s.1 - mu) / d;
            let x = s.0;
            sw += w;
            swx += w * x;
            swxx += w * x * x;
            swz += w * z;
            swxz += w * x * z;
        }
        let det = sw * swxx - swx * swx;
        if !(det.is_finite() && det > 0.0) {
            return Err(
                "the probit fit is singular (fewer than two levels with 0 < fraction < 1)".into(),
            );
        }
        let nb = (
            (swxx * swz - swx * swxz) / det,
            (sw * swxz - swx * swz) / det,
        );
        let change = (nb.0 - b.0).abs() + (nb.1 - b.1).abs();
        b = nb;
        for (e, s) in eta.iter_mut().zip(&sorted) {
            *e = b.0 + b.1 * s.0;
        }
        if !(b.0.is_finite() && b.1.is_finite()) || b.1.abs() > 1e8 {
            return Err("the probit fit diverges (separation)".into());
        }
        if change < 1e-12 * (1.0 + b.0.abs() + b.1.abs()) && it > 0 {
            break;
        }
        if it == 199 {
            return Err("the probit fit did not converge in 200 iterations".into());
        }
    }
    if b.1 <= 0.0 {
        return Err(format!(
            "the fitted probability decreases with the intensity (slope {:.3})",
            b.1
        ));
    }
    // The same fraction at every level fits a slope of round-off, of either sign (a median of
    // infinity and a dispersion of 1e15 were reported as a fit).
    let span = sorted.last().map_or(0.0, |s| s.0) - sorted.first().map_or(0.0, |s| s.0);
    if b.1 * span <= 1e-9 {
        return Err(format!(
            "the fitted probability does not change with the intensity (slope {:e} over the levels' span of {span:e} in ln IM)",
            b.1
        ));
    }
    let fit = Lognormal {
        theta: (-b.0 / b.1).exp(),
        beta: 1.0 / b.1,
    };
    if !(fit.theta.is_finite() && fit.theta > 0.0 && fit.beta.is_finite()) {
        return Err(format!(
            "the fitted median exp({:e}) lies beyond any intensity",
            -b.0 / b.1
        ));
    }
    Ok(fit)
}

/// Inverse standard normal CDF (Newton on [`ncdf`] from Acklam-free start; |error| < 1e-14).
pub fn inv_ncdf(p: f64) -> f64 {
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    // Start from a logistic approximation, then Newton (Phi is smooth and monotone).
    let mut x = (p / (1.0 - p)).ln() / 1.702;
    for _ in 0..60 {
        let f = ncdf(x) - p;
        let d = npdf(x).max(1e-300);
        let step = (f / d).clamp(-2.0, 2.0);
        x -= step;
        if step.abs() < 1e-15 * (1.0 + x.abs()) {
            break;
        }
    }
    x
}

/// Censored lognormal MLE of capacities: `(capacity, censored)`; a censored record did not
/// reach the limit state up to `capacity`.
pub fn censored_lognormal(c: &[(f64, bool)]) -> Result<Lognormal, String> {
    let unc: Vec<f64> = c.iter().filter(|x| !x.1).map(|x| x.0.ln()).collect();
    let cen: Vec<f64> = c.iter().filter(|x| x.1).map(|x| x.0.ln()).collect();
    if unc.is_empty() {
        return Err("no record reaches the limit state".into());
    }
    let n = unc.len() as f64;
    let mean = unc.iter().sum::<f64>() / n;
    let var = unc.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / n;
    if cen.is_empty() {
        if var <= 0.0 {
            return Err("every capacity is the same: no dispersion".into());
        }
        return Ok(Lognormal {
            theta: mean.exp(),
            beta: var.sqrt(),
        });
    }
    // Log-likelihood in (mu, s = ln sigma) and its gradient.
    let ll = |mu: f64, s: f64| -> f64 {
        let sig = s.exp();
        let a: f64 = unc
            .iter()
            .map(|y| {
                let z = (y - mu) / sig;
                -s - 0.5 * z * z
            })
            .sum();
        let b: f64 = cen.iter().map(|y| nsf((y - mu) / sig).ln()).sum();
        a + b
    };
    let grad = |mu: f64, s: f64| -> (f64, f64) {
        let sig = s.exp();
        let (mut gm, mut gs) = (0.0, 0.0);
        for y in &unc {
            let z = (y - mu) / sig;
            gm += z / sig;
            gs += -1.0 + z * z;
        }
        for y in &cen {
            let z = (y - mu) / sig;
            let h = npdf(z) / nsf(z).max(1e-300);
            gm += h / sig;
            gs += h * z;
        }
        (gm, gs)
    };
    let mut mu = mean;
    let mut s = var.sqrt().max(0.1).ln();
    let mut f = ll(mu, s);
    for _ in 0..500 {
        let (gm, gs) = grad(mu, s);
        if gm.abs() + gs.abs() < 1e-11 {
            break;
        }
        // Hessian by central differences of the analytical gradient.
        let h = 1e-6;
        let (a1, b1) = grad(mu + h, s);
        let (a0, b0) = grad(mu - h, s);
        let (c1, d1) = grad(mu, s + h);
        let (c0, d0) = grad(mu, s - h);
        let (hmm, hms, hss) = (
            (a1 - a0) / (2.0 * h),
            0.5 * ((b1 - b0) + (c1 - c0)) / (2.0 * h),
            (d1 - d0) / (2.0 * h),
        );
        let det = hmm * hss - hms * hms;
        // Newton where the Hessian is negative definite, else gradient ascent.
        let (mut dm, mut ds) = if hmm < 0.0 && det > 0.0 {
            (-(hss * gm - hms * gs) / det, -(hmm * gs - hms * gm) / det)
        } else {
            (0.1 * gm, 0.1 * gs)
        };
        let mut t = 1.0;
        loop {
            let (m2, s2) = (mu + t * dm, s + t * ds);
            let f2 = ll(m2, s2);
            if f2.is_finite() && f2 >= f - 1e-14 * f.abs() {
                mu = m2;
                s = s2;
                f = f2;
                break;
            }
            t *= 0.5;
            if t < 1e-12 {
                dm = 0.0;
                ds = 0.0;
                break;
            }
        }
        if dm == 0.0 && ds == 0.0 {
            break;
        }
        if !(s.is_finite() && mu.is_finite() && (-30.0..=10.0).contains(&s)) {
            return Err("the censored fit diverges".into());
        }
    }
    Ok(Lognormal {
        theta: mu.exp(),
        beta: s.exp(),
    })
}

/// splitmix64: a small seeded generator for the bootstrap (reproducible across platforms).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        z ^ (z >> 31)
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }
}

/// The `q` quantile (linear interpolation between order statistics) of unsorted values.
pub fn quantile(v: &[f64], q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let pos = q * (s.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos - pos.floor());
    Some(if i + 1 < s.len() {
        s[i] + f * (s[i + 1] - s[i])
    } else {
        s[i]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stripes drawn exactly from a lognormal curve (fractional counts) give it back.
    #[test]
    fn probit_recovers_the_generating_curve() {
        let truth = Lognormal {
            theta: 0.4,
            beta: 0.35,
        };
        let stripes: Vec<(f64, f64, f64)> = [0.2, 0.3, 0.4, 0.5, 0.7]
            .iter()
            .map(|&x: &f64| (x.ln(), 1000.0, 1000.0 * truth.p(x)))
            .collect();
        let f = probit(&stripes).unwrap();
        assert!((f.theta / 0.4 - 1.0).abs() < 1e-9, "{f:?}");
        assert!((f.beta / 0.35 - 1.0).abs() < 1e-9, "{f:?}");
    }

    /// The same fraction exceeding at every level: no slope to fit, whatever round-off's sign.
    #[test]
    fn probit_refuses_a_flat_fraction() {
        let ln = f64::ln;
        for s in [
            // 2 of 6 at 1.5 and at 2.5: a slope of +5e-16 was a fit (median inf, beta 1.9e15).
            vec![(ln(1.5), 6.0, 2.0), (ln(2.5), 6.0, 2.0)],
            vec![(ln(1.5), 6.0, 2.0), (ln(2.0), 6.0, 2.0)],
            vec![(0.0, 6.0, 2.0), (0.5, 6.0, 2.0)],
            vec![(0.3, 6.0, 2.0), (0.4, 3.0, 1.0), (0.9, 6.0, 2.0)],
            vec![(-1.0, 10.0, 3.0), (0.0, 10.0, 3.0), (1.0, 10.0, 3.0)],
        ] {
            let e = probit(&s).unwrap_err();
            assert!(
                e.contains("does not change") || e.contains("decreases"),
                "{s:?}: {e}"
            );
        }
    }

    #[test]
    fn probit_reports_separation_and_no_exceedance() {
        let s = [(0.0, 10.0, 0.0), (1.0, 10.0, 10.0)];
        assert!(probit(&s).unwrap_err().contains("separation"));
        let s = [(0.0, 10.0, 0.0), (1.0, 10.0, 0.0)];
        assert!(probit(&s).unwrap_err().contains("no run"));
    }

    #[test]
    fn uncensored_capacities_are_the_log_moments() {
        let c = [(1.0, false), (2.0, false), (4.0, false)];
        let f = censored_lognormal(&c).unwrap();
        assert!((f.theta - 2.0).abs() < 1e-12);
        let sd = ((2.0f64.ln().powi(2) * 2.0) / 3.0).sqrt();
        assert!((f.beta - sd).abs() < 1e-12);
    }

    /// Censoring raises the median: the censored records would have needed more.
    #[test]
    fn censoring_raises_the_median_and_the_gradient_vanishes() {
        let c = [
            (1.0, false),
            (2.0, false),
            (4.0, false),
            (4.0, true),
            (4.0, true),
        ];
        let f = censored_lognormal(&c).unwrap();
        assert!(f.theta > 2.0, "{f:?}");
        // Gradient of the log-likelihood at the estimate, by differences.
        let ll = |m: f64, s: f64| -> f64 {
            c.iter()
                .map(|&(x, cen)| {
                    let z = (x.ln() - m) / s;
                    if cen {
                        nsf(z).ln()
                    } else {
                        -s.ln() - 0.5 * z * z
                    }
                })
                .sum()
        };
        let (m, s, h) = (f.theta.ln(), f.beta, 1e-6);
        assert!(((ll(m + h, s) - ll(m - h, s)) / (2.0 * h)).abs() < 1e-6);
        assert!(((ll(m, s + h) - ll(m, s - h)) / (2.0 * h)).abs() < 1e-6);
    }

    #[test]
    fn inverse_normal_cdf_round_trips() {
        for p in [1e-10, 0.01, 0.3, 0.5, 0.9, 0.999999] {
            assert!((ncdf(inv_ncdf(p)) / p - 1.0).abs() < 1e-12, "{p}");
        }
    }
}
