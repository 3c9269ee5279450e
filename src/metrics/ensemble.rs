//! Ensembles of runs of one scene: where a scene's answer is decided at round-off (a wall in
//! motion, whose impacts depend on their order), two settings are compared by their ensembles'
//! means against the ensembles' spread, not run against run.
//!
//! An ensemble holds one vector of final quantities per member (for a wall, every block's final
//! horizontal displacement). Per component `j`, over the `m` members: the mean, and the sample
//! standard deviation `s_j` (divisor `m - 1`). The **spread** is the RMS of `s_j` over the
//! components. Two ensembles `a`, `b` differ by the RMS over the components of
//! `mean_a,j - mean_b,j`; its **standard error** is the RMS of
//! `sqrt(s_a,j^2 / m_a + s_b,j^2 / m_b)`, what that difference would be from the spread alone.
//! A ratio of the two near 1 says the settings are not told apart at this ensemble size;
//! well above it, that they give different answers.

/// Per-component mean and sample standard deviation of an ensemble.
#[derive(Debug, Clone, PartialEq)]
pub struct Ensemble {
    pub members: usize,
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
}

/// How two ensembles' means differ (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnsembleDifference {
    /// RMS over the components of the difference of the means.
    pub rms: f64,
    /// Largest difference of the means over the components.
    pub max: f64,
    /// RMS over the components of the difference's standard error.
    pub standard_error: f64,
}

impl Ensemble {
    /// The statistics of `members` (each a vector of the same length). Needs two members or
    /// more, of equal lengths and finite values.
    pub fn of(members: &[Vec<f64>]) -> Result<Ensemble, String> {
        let m = members.len();
        if m < 2 {
            return Err(format!("an ensemble needs two members or more (got {m})"));
        }
        let n = members[0].len();
        if let Some(k) = members.iter().position(|v| v.len() != n) {
            return Err(format!(
                "member {k} has {} values where member 0 has {n}",
                members[k].len()
            ));
        }
        if let Some(k) = members
            .iter()
            .position(|v| v.iter().any(|x| !x.is_finite()))
        {
            return Err(format!("member {k} has a value that is not finite"));
        }
        let mean: Vec<f64> = (0..n)
            .map(|j| members.iter().map(|v| v[j]).sum::<f64>() / m as f64)
            .collect();
        let std = (0..n)
            .map(|j| {
                let ss: f64 = members.iter().map(|v| (v[j] - mean[j]).powi(2)).sum();
                (ss / (m - 1) as f64).sqrt()
            })
            .collect();
        Ok(Ensemble {
            members: m,
            mean,
            std,
        })
    }

    /// RMS over the components of the standard deviation.
    pub fn spread(&self) -> f64 {
        rms(self.std.iter().copied())
    }

    /// Largest standard deviation over the components.
    pub fn largest_spread(&self) -> f64 {
        self.std.iter().fold(0.0f64, |a, &s| a.max(s))
    }

    /// How this ensemble's mean differs from `other`'s (the same components).
    pub fn difference(&self, other: &Ensemble) -> Result<EnsembleDifference, String> {
        if other.mean.len() != self.mean.len() {
            return Err(format!(
                "ensembles of {} and {} components cannot be compared",
                self.mean.len(),
                other.mean.len()
            ));
        }
        let d = self.mean.iter().zip(&other.mean).map(|(a, b)| a - b);
        let se = self.std.iter().zip(&other.std).map(|(sa, sb)| {
            (sa * sa / self.members as f64 + sb * sb / other.members as f64).sqrt()
        });
        Ok(EnsembleDifference {
            rms: rms(d.clone()),
            max: d.fold(0.0f64, |a, x| a.max(x.abs())),
            standard_error: rms(se),
        })
    }
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in values {
        s += v * v;
        n += 1;
    }
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_deviation_per_component() {
        let e = Ensemble::of(&[vec![0.0, 1.0], vec![2.0, 3.0], vec![4.0, 8.0]]).unwrap();
        assert_eq!(e.members, 3);
        assert_eq!(e.mean, vec![2.0, 4.0]);
        // (4 + 0 + 4) / 2 = 4 and (9 + 1 + 16) / 2 = 13.
        assert!((e.std[0] - 2.0).abs() < 1e-15);
        assert!((e.std[1] - 13f64.sqrt()).abs() < 1e-15);
        assert!((e.spread() - ((4.0 + 13.0) / 2.0f64).sqrt()).abs() < 1e-15);
        assert!((e.largest_spread() - 13f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn bad_ensembles_are_refused_with_the_reason() {
        assert!(
            Ensemble::of(&[vec![1.0]])
                .unwrap_err()
                .contains("two members")
        );
        let e = Ensemble::of(&[vec![1.0], vec![1.0, 2.0]]).unwrap_err();
        assert!(e.contains("member 1 has 2 values"), "{e}");
        let e = Ensemble::of(&[vec![1.0], vec![f64::NAN]]).unwrap_err();
        assert!(e.contains("not finite"), "{e}");
        let a = Ensemble::of(&[vec![1.0], vec![2.0]]).unwrap();
        let b = Ensemble::of(&[vec![1.0, 1.0], vec![2.0, 2.0]]).unwrap();
        assert!(a.difference(&b).is_err());
    }

    /// Members drawn around a mean with a known spread (a fixed linear congruential sequence,
    /// uniform on [-1, 1) scaled to unit deviation): the same distribution gives a difference of
    /// the order of its standard error, a shifted one the shift.
    #[test]
    fn a_shift_stands_out_of_the_spread_and_noise_does_not() {
        let mut signed = crate::test_random::signed(12345);
        let mut draw = move || signed() * 3f64.sqrt();
        let n = 200;
        let mut sample = |shift: f64, m: usize| -> Vec<Vec<f64>> {
            (0..m)
                .map(|_| (0..n).map(|_| shift + 1e-3 * draw()).collect())
                .collect()
        };
        let a = Ensemble::of(&sample(0.0, 8)).unwrap();
        let b = Ensemble::of(&sample(0.0, 8)).unwrap();
        let c = Ensemble::of(&sample(5e-3, 8)).unwrap();
        assert!((a.spread() / 1e-3 - 1.0).abs() < 0.15, "{}", a.spread());
        let same = a.difference(&b).unwrap();
        // The standard error of a difference of two means of 8: sqrt(2 / 8) = 0.5 spreads.
        assert!(
            (same.standard_error / 0.5e-3 - 1.0).abs() < 0.15,
            "{same:?}"
        );
        assert!(same.rms / same.standard_error < 1.3, "{same:?}");
        let shifted = c.difference(&a).unwrap();
        assert!((shifted.rms - 5e-3).abs() < 0.1 * 5e-3, "{shifted:?}");
        assert!(shifted.rms / shifted.standard_error > 8.0, "{shifted:?}");
        assert!(shifted.max >= shifted.rms);
    }
}
