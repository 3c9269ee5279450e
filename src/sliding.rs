//! The closed form of a rigid block sliding on the ground under Coulomb friction: pushed
//! relative to the ground at a constant acceleration for a while (a rectangular pulse of ground
//! acceleration above `mu g`, or none), then slowed at `mu g` until it stops. The reference of
//! the sliding cases and of a wall that slides whole (reference-data/, docs/walls.md).

/// A sliding block: starts with velocity `v0` relative to the ground, is first accelerated
/// relative to the ground by `a_rel` for `t_push` s (0: no push), then slides with constant
/// deceleration `mu_g` until it stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slide {
    pub v0: f64,
    pub a_rel: f64,
    pub t_push: f64,
    pub mu_g: f64,
}

impl Slide {
    /// A block at rest on a ground that accelerates at `a` (m/s^2, above `mu g`) for `t1` s:
    /// relative to the ground it accelerates at `-(a - mu g)` while the pulse lasts.
    pub fn under_pulse(a: f64, t1: f64, mu: f64, g: f64) -> Self {
        Slide {
            v0: 0.0,
            a_rel: -(a - mu * g),
            t_push: t1,
            mu_g: mu * g,
        }
    }

    /// Displacement and velocity relative to the ground at time `t`.
    pub fn at(&self, t: f64) -> (f64, f64) {
        let Slide {
            v0,
            a_rel,
            t_push,
            mu_g,
        } = *self;
        // State at the end of the push.
        let v1 = v0 + a_rel * t_push;
        let x1 = v0 * t_push + 0.5 * a_rel * t_push * t_push;
        let t_stop = t_push + v1.abs() / mu_g;
        if t <= t_push {
            (v0 * t + 0.5 * a_rel * t * t, v0 + a_rel * t)
        } else if t < t_stop {
            let s = t - t_push;
            let d = -v1.signum() * mu_g;
            (x1 + v1 * s + 0.5 * d * s * s, v1 + d * s)
        } else {
            (x1 + v1 * v1.abs() / (2.0 * mu_g), 0.0)
        }
    }

    /// Where it stops, relative to where it started.
    pub fn distance(&self) -> f64 {
        let v1 = self.v0 + self.a_rel * self.t_push;
        self.at(self.t_push + v1.abs() / self.mu_g).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pulse's closed form, `-(a - mu g) t1^2 / 2 - ((a - mu g) t1)^2 / (2 mu g)`, and the
    /// launched block's `v0^2 / (2 mu g)`, at rest from the stopping time on, continuous at the
    /// pulse's end.
    #[test]
    fn the_block_stops_at_the_closed_form_distance() {
        let (a, t1, mu, g) = (7.848, 0.2, 0.5, 9.81);
        let s = Slide::under_pulse(a, t1, mu, g);
        let r = a - mu * g;
        let want = -(0.5 * r * t1 * t1 + (r * t1).powi(2) / (2.0 * mu * g));
        assert!((s.distance() - want).abs() < 1e-15, "{}", s.distance());
        assert_eq!(s.at(10.0), (s.distance(), 0.0));
        let (before, after) = (s.at(t1 - 1e-12), s.at(t1 + 1e-12));
        // Across 2e-12 s at 0.59 m/s: 1.2e-12 m; a jump would be of millimetres.
        assert!((before.0 - after.0).abs() < 1e-11 && (before.1 - after.1).abs() < 1e-10);
        let launched = Slide {
            v0: 2.0,
            a_rel: 0.0,
            t_push: 0.0,
            mu_g: mu * g,
        };
        assert!((launched.distance() - 4.0 / (2.0 * mu * g)).abs() < 1e-15);
    }
}
