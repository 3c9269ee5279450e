//! Settings of the rapier2d engine (`[rapier]` in a scene), with documented defaults.
//!
//! This module is compiled in every build, so scene files with a `[rapier]` table parse and
//! are checked even when the `rapier` feature (the engine itself) is off.
//!
//! The defaults are the tuned values that make rapier rock like Housner's model (measured on
//! `validation/scenes/housner-{slender,square}.toml`, see `docs/engines-rapier.md`); rapier's
//! own defaults are kept in [`RapierSettings::rapier_defaults`] for comparison.

use crate::scene::SceneError;
use serde::{Deserialize, Serialize};

/// How rapier combines the coefficients of two touching colliders (rapier's
/// `CoefficientCombineRule`; when the two colliders' rules differ the one later in this list
/// wins: average < min < multiply < max < clamped-sum < geometric-mean).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum CombineRule {
    /// `(a + b) / 2` (rapier's default).
    #[default]
    Average,
    /// `min(a, b)`.
    Min,
    /// `a * b`.
    Multiply,
    /// `max(a, b)`.
    Max,
    /// `clamp(a + b, 0, 1)`.
    ClampedSum,
    /// `sqrt(a * b)`.
    GeometricMean,
}

/// Which friction coefficient a contact between two bodies gets.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum FrictionRule {
    /// The scene's interface friction, exactly as the native engine uses it: a block on the
    /// ground gets `contact.interfaces.<block>.friction` (or `contact.friction`), two blocks
    /// get the value keyed by the upper (later-listed) block. Set per contact pair by a contact
    /// hook; raised to `min_friction`.
    #[default]
    Interface,
    /// Rapier's own combination of per-collider coefficients: each block's collider carries
    /// the friction of the interface under it, the ground carries `contact.friction`, and the
    /// pair's coefficient is combined by this rule (then raised to `min_friction`).
    Average,
    Min,
    Multiply,
    Max,
    ClampedSum,
    GeometricMean,
}

fn d_dt() -> f64 {
    1e-3
}
fn d_solver_iterations() -> u32 {
    8
}
fn d_one() -> u32 {
    1
}
fn d_stabilization() -> u32 {
    4
}
fn d_frequency() -> f64 {
    240.0
}
/// The smallest positive contact damping ratio rapier's soft contact takes.
pub const MIN_DAMPING_RATIO: f64 = 1e-12;
/// The largest contact damping ratio rapier's soft contact takes.
pub const MAX_DAMPING_RATIO: f64 = 1e12;

fn d_damping_ratio() -> f64 {
    10.0
}
fn d_prediction() -> f64 {
    0.002
}
fn d_allowed_linear_error() -> f64 {
    0.005
}
fn d_max_corrective_velocity() -> f64 {
    3.0
}
fn d_max_linear_velocity() -> f64 {
    400.0
}
fn d_warmstart() -> f64 {
    1.0
}

/// `[rapier]` settings: every rapier parameter that changes the answer.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RapierSettings {
    /// Time step, s (default 1e-3; rapier's own default is 1/60).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// Solver iterations per step (rapier's `num_solver_iterations`; each one is a sub-step of
    /// length `dt / solver_iterations` with its own velocity solve and position update), so the
    /// effective integration step is `dt / solver_iterations` (default 8: 1.25e-4 s; rapier: 4).
    #[serde(default = "d_solver_iterations")]
    pub solver_iterations: u32,
    /// Projected Gauss-Seidel sweeps per sub-step (rapier's `num_internal_pgs_iterations`,
    /// default 1).
    #[serde(default = "d_one")]
    pub pgs_iterations: u32,
    /// Stabilization (unbiased relaxation) sweeps per sub-step (rapier's
    /// `num_internal_stabilization_iterations`). The decisive setting: with rapier's 1 the
    /// penetration-correction velocity of the biased pass survives an impact and a square
    /// block's first amplitude after impact doubles; 4 removes it (default 4; rapier: 1).
    #[serde(default = "d_stabilization")]
    pub stabilization_iterations: u32,
    /// Reuse contact points while two bodies moved less than rapier's recycle distance
    /// instead of recomputing them every step. Recycled points lag a rocking block's corner
    /// (default false; rapier: true).
    #[serde(default)]
    pub contact_recycling: bool,
    /// Natural frequency of the contact spring between two moving bodies, Hz. Contacts in
    /// rapier are soft constraints: penetration is pushed out like a spring-damper of this
    /// frequency per unit of the contact's effective mass (default 240; rapier: 30).
    #[serde(default = "d_frequency")]
    pub contact_frequency: f64,
    /// Damping ratio of that contact spring (default 10: strongly over-damped, no bounce;
    /// rapier: 10).
    #[serde(default = "d_damping_ratio")]
    pub contact_damping_ratio: f64,
    /// Natural frequency of contacts with a fixed body, Hz: the ground of the inertial-force
    /// route. Rapier does not count a kinematic body as fixed, so with `moving-ground` the
    /// ground contacts use `contact_frequency` and `contact_damping_ratio` (measured); the
    /// defaults keep the two equal so both routes see the same contact (default 240;
    /// rapier: 60).
    #[serde(default = "d_frequency")]
    pub static_contact_frequency: f64,
    /// Damping ratio of contacts with a fixed body (default 10; rapier: 10).
    #[serde(default = "d_damping_ratio")]
    pub static_contact_damping_ratio: f64,
    /// Gap, m, below which rapier creates (speculative) contact points before bodies touch
    /// (rapier's `normalized_prediction_distance`, length unit 1 m). A large value makes a
    /// lifted corner hold contact too long (default 0.002; rapier: 0.02).
    #[serde(default = "d_prediction")]
    pub prediction_distance: f64,
    /// Penetration, m, rapier tolerates without correcting it (rapier's
    /// `normalized_allowed_linear_error`; default 0.005, rapier's value).
    #[serde(default = "d_allowed_linear_error")]
    pub allowed_linear_error: f64,
    /// Largest velocity, m/s, at which penetration is pushed out (rapier's
    /// `normalized_max_corrective_velocity`; default 3, rapier's value).
    #[serde(default = "d_max_corrective_velocity")]
    pub max_corrective_velocity: f64,
    /// Rapier's speed limit, m/s: it clamps every body's speed to this value after each
    /// sub-step (`normalized_max_linear_velocity`). A run in which a block reaches it fails
    /// instead of returning the clamped motion (default 400, rapier's value).
    #[serde(default = "d_max_linear_velocity")]
    pub max_linear_velocity: f64,
    /// Fraction of the previous step's contact impulses the solver starts from, in [0, 1]
    /// (default 1, rapier's value).
    #[serde(default = "d_warmstart")]
    pub warmstart_coefficient: f64,
    /// Also apply friction in the biased (penetration-correcting) pass (default false,
    /// rapier's value).
    #[serde(default)]
    pub friction_in_bias_pass: bool,
    /// Coefficient of restitution of every collider, in [0, 1] (default 0). Housner's
    /// coefficient is NOT a contact restitution: with 0 the old pivot lifts off by itself and
    /// the angular velocity drops by `1 - 1.5 sin^2 alpha`; any non-zero value adds a bounce.
    #[serde(default)]
    pub restitution: f64,
    /// How two colliders' restitutions combine (default average: with 0 on every collider
    /// every rule gives 0).
    #[serde(default)]
    pub restitution_rule: CombineRule,
    /// Which friction coefficient a contact gets (default `interface`: the scene's interface
    /// friction, as in the native engine; or one of rapier's combine rules).
    #[serde(default)]
    pub friction_rule: FrictionRule,
    /// Lower bound on every contact's friction coefficient (default 0: the scene's friction is
    /// used as given). Raising it stops a pivot from slipping at impact in a scene whose
    /// friction is too low for rapier's iterative friction.
    #[serde(default)]
    pub min_friction: f64,
    /// Linear velocity damping of every block, 1/s (`v' = -c v`; default 0).
    #[serde(default)]
    pub linear_damping: f64,
    /// Angular velocity damping of every block, 1/s (default 0).
    #[serde(default)]
    pub angular_damping: f64,
    /// Let rapier put bodies that barely move to sleep (frozen until disturbed). Off by
    /// default: a sleeping block reports exactly zero motion, which hides small rocking
    /// (default false; rapier: true).
    #[serde(default)]
    pub can_sleep: bool,
}

impl Default for RapierSettings {
    fn default() -> Self {
        RapierSettings {
            dt: d_dt(),
            solver_iterations: d_solver_iterations(),
            pgs_iterations: d_one(),
            stabilization_iterations: d_stabilization(),
            contact_recycling: false,
            contact_frequency: d_frequency(),
            contact_damping_ratio: d_damping_ratio(),
            static_contact_frequency: d_frequency(),
            static_contact_damping_ratio: d_damping_ratio(),
            prediction_distance: d_prediction(),
            allowed_linear_error: d_allowed_linear_error(),
            max_corrective_velocity: d_max_corrective_velocity(),
            max_linear_velocity: d_max_linear_velocity(),
            warmstart_coefficient: d_warmstart(),
            friction_in_bias_pass: false,
            restitution: 0.0,
            restitution_rule: CombineRule::Average,
            friction_rule: FrictionRule::Interface,
            min_friction: 0.0,
            linear_damping: 0.0,
            angular_damping: 0.0,
            can_sleep: false,
        }
    }
}

impl RapierSettings {
    /// Rapier 0.36's own defaults (`IntegrationParameters::default()`, default body and
    /// collider builders), with the scene's interface friction kept.
    pub fn rapier_defaults() -> Self {
        RapierSettings {
            dt: 1.0 / 60.0,
            solver_iterations: 4,
            pgs_iterations: 1,
            stabilization_iterations: 1,
            contact_recycling: true,
            contact_frequency: 30.0,
            contact_damping_ratio: 10.0,
            static_contact_frequency: 60.0,
            static_contact_damping_ratio: 10.0,
            prediction_distance: 0.02,
            allowed_linear_error: 0.005,
            max_corrective_velocity: 3.0,
            max_linear_velocity: 400.0,
            warmstart_coefficient: 1.0,
            friction_in_bias_pass: false,
            restitution: 0.0,
            restitution_rule: CombineRule::Average,
            friction_rule: FrictionRule::Interface,
            min_friction: 0.0,
            linear_damping: 0.0,
            angular_damping: 0.0,
            can_sleep: true,
        }
    }

    /// The scene's `[rapier]` table, parsed and checked (one-line errors naming
    /// `rapier.<field>`).
    pub fn of(scene: &crate::scene::Scene) -> Result<RapierSettings, SceneError> {
        let s: RapierSettings = scene.parse_table("rapier")?;
        s.validate(&scene.source)?;
        crate::scene::check_step(scene, "rapier.dt", s.dt)?;
        Ok(s)
    }

    /// Check every value; errors name `rapier.<field>`.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let e = |f: &str, m: String| Err(SceneError::new(file, format!("rapier.{f}"), m));
        let positive = |f: &str, v: f64, unit: &str| {
            if !v.is_finite() || v <= 0.0 {
                return e(
                    f,
                    format!(
                        "must be a positive number{unit} (got {})",
                        crate::scene::num(v)
                    ),
                );
            }
            Ok(())
        };
        let non_negative = |f: &str, v: f64, unit: &str| {
            if !v.is_finite() || v < 0.0 {
                return e(
                    f,
                    format!(
                        "must be a non-negative number{unit} (got {})",
                        crate::scene::num(v)
                    ),
                );
            }
            Ok(())
        };
        // Rapier's soft contact turns a ratio below 1e-12 or above 1e12 (but 0) into a NaN
        // state (measured at 1e-300 and 1e300 on housner-slender; 1e-100 and 1e30 run).
        let damping_ratio = |f: &str, v: f64| {
            if !(v == 0.0 || (MIN_DAMPING_RATIO..=MAX_DAMPING_RATIO).contains(&v)) {
                return e(
                    f,
                    format!(
                        "must be 0 or from {MIN_DAMPING_RATIO:e} to {MAX_DAMPING_RATIO:e} (got {})",
                        crate::scene::num(v)
                    ),
                );
            }
            Ok(())
        };
        positive("dt", self.dt, " of seconds")?;
        if self.dt > 0.1 {
            return e(
                "dt",
                format!(
                    "must be at most 0.1 s (got {}): blocks would fly apart",
                    crate::scene::num(self.dt)
                ),
            );
        }
        if self.solver_iterations == 0 {
            return e("solver_iterations", "must be at least 1".into());
        }
        if self.pgs_iterations == 0 {
            return e("pgs_iterations", "must be at least 1".into());
        }
        if self.solver_iterations > 1000 || self.pgs_iterations > 1000 {
            let (f, v) = if self.solver_iterations > 1000 {
                ("solver_iterations", self.solver_iterations)
            } else {
                ("pgs_iterations", self.pgs_iterations)
            };
            return e(f, format!("must be at most 1000 (got {v})"));
        }
        if self.stabilization_iterations > 1000 {
            return e(
                "stabilization_iterations",
                format!(
                    "must be at most 1000 (got {})",
                    self.stabilization_iterations
                ),
            );
        }
        positive("contact_frequency", self.contact_frequency, " of Hz")?;
        damping_ratio("contact_damping_ratio", self.contact_damping_ratio)?;
        positive(
            "static_contact_frequency",
            self.static_contact_frequency,
            " of Hz",
        )?;
        damping_ratio(
            "static_contact_damping_ratio",
            self.static_contact_damping_ratio,
        )?;
        non_negative(
            "prediction_distance",
            self.prediction_distance,
            " of metres",
        )?;
        non_negative(
            "allowed_linear_error",
            self.allowed_linear_error,
            " of metres",
        )?;
        positive(
            "max_corrective_velocity",
            self.max_corrective_velocity,
            " of m/s",
        )?;
        positive("max_linear_velocity", self.max_linear_velocity, " of m/s")?;
        if !self.warmstart_coefficient.is_finite()
            || !(0.0..=1.0).contains(&self.warmstart_coefficient)
        {
            return e(
                "warmstart_coefficient",
                format!(
                    "must be in [0, 1] (got {})",
                    crate::scene::num(self.warmstart_coefficient)
                ),
            );
        }
        if !self.restitution.is_finite() || !(0.0..=1.0).contains(&self.restitution) {
            return e(
                "restitution",
                format!(
                    "must be in [0, 1] (got {})",
                    crate::scene::num(self.restitution)
                ),
            );
        }
        non_negative("min_friction", self.min_friction, "")?;
        non_negative("linear_damping", self.linear_damping, " per second")?;
        non_negative("angular_damping", self.angular_damping, " per second")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_bad_values_name_the_field() {
        RapierSettings::default().validate("s.toml").unwrap();
        RapierSettings::rapier_defaults()
            .validate("s.toml")
            .unwrap();
        let bad = |f: fn(&mut RapierSettings), field: &str| {
            let mut s = RapierSettings::default();
            f(&mut s);
            let err = s.validate("s.toml").unwrap_err();
            assert_eq!(err.field, format!("rapier.{field}"), "{err}");
            assert_eq!(err.to_string().lines().count(), 1);
        };
        bad(|s| s.dt = 0.0, "dt");
        bad(|s| s.dt = f64::NAN, "dt");
        bad(|s| s.solver_iterations = 0, "solver_iterations");
        bad(|s| s.pgs_iterations = 0, "pgs_iterations");
        bad(|s| s.contact_frequency = -1.0, "contact_frequency");
        bad(
            |s| s.static_contact_damping_ratio = -1.0,
            "static_contact_damping_ratio",
        );
        // Ratios that made rapier's state NaN; 0 and the bounds themselves are taken.
        bad(
            |s| s.contact_damping_ratio = 1e-300,
            "contact_damping_ratio",
        );
        bad(
            |s| s.static_contact_damping_ratio = 1e300,
            "static_contact_damping_ratio",
        );
        for ratio in [0.0, MIN_DAMPING_RATIO, MAX_DAMPING_RATIO] {
            let s = RapierSettings {
                contact_damping_ratio: ratio,
                ..RapierSettings::default()
            };
            assert!(s.validate("s.toml").is_ok(), "{ratio}");
        }
        bad(|s| s.prediction_distance = -1e-3, "prediction_distance");
        bad(|s| s.restitution = 1.5, "restitution");
        bad(|s| s.warmstart_coefficient = 2.0, "warmstart_coefficient");
        bad(|s| s.min_friction = -0.1, "min_friction");
        bad(|s| s.max_linear_velocity = 0.0, "max_linear_velocity");
        bad(|s| s.angular_damping = -0.1, "angular_damping");
    }

    #[test]
    fn toml_table_parses_with_kebab_case_rules() {
        let s: RapierSettings = toml::from_str(
            "dt = 5e-4\nfriction_rule = \"geometric-mean\"\nrestitution_rule = \"max\"\n",
        )
        .unwrap();
        assert_eq!(s.dt, 5e-4);
        assert_eq!(s.friction_rule, FrictionRule::GeometricMean);
        assert_eq!(s.restitution_rule, CombineRule::Max);
        assert_eq!(s.stabilization_iterations, 4);
        assert!(toml::from_str::<RapierSettings>("substeps = 3\n").is_err());
    }
}
