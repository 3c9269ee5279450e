//! The analytical reference: Housner's (1963) single rigid block on a rigid base.
//!
//! Rectangle 2b x 2h (B = 2b, H = 2h), `R = sqrt(b^2 + h^2)`, `alpha = atan(b/h)`,
//! `p^2 = 3 g / (4 R)`. With theta counter-clockwise (theta > 0: rocking on the left corner),
//! a ground acceleration `a_x` (+x) and `a_z` (up):
//!
//! ```text
//! theta'' = -p^2 [ (1 + a_z/g) sin(alpha s - theta) - (a_x/g) cos(alpha s - theta) ],  s = sgn(theta)
//! ```
//!
//! At each impact (theta = 0) the angular velocity is multiplied by `1 - 1.5 sin^2 alpha`
//! (overridable as `housner.restitution`). A block at rest starts rocking when
//! `|a_x| > (g + a_z) tan alpha`. The equation is integrated with classical RK4 (steps of at
//! most `min(housner.max_step, housner.max_phase_step / p)`, landing on every output time and
//! excitation breakpoint, so that each step sees a smooth excitation: its first stage takes the
//! excitation's limit from the right, its last from the left, and a pulse that ends where a
//! step starts is zero over that step; taking the pulse's last value there made a
//! rectangular or one-cosine pulse's end a first-order error, 1.7e-4 relative in the angular
//! velocity at the default step); impacts
//! are located by bisection on the step length to `housner.event_tolerance`. When the
//! amplitude after an impact would be below 1e-12 rad, or the remaining infinite sequence of
//! ever smaller impacts (durations 2|omega|/(p^2 sin alpha), ratio r) ends within the current
//! step, the block is at rest at the end of that step; otherwise every crossing of zero within
//! the step is located and is an impact. The block overturns when
//! |theta| reaches pi/2; it is then held there. Sliding is not modelled.

use super::{Engine, EngineError, Progress, RunOutput};
use crate::events::NOISE_FLOOR;
use crate::excitation::GroundMotion;
use crate::scene::{MAX_STEPS, MIN_EVENT_TOLERANCE_REL, Scene, SceneError};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// Settings of the analytical Housner engine.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HousnerSettings {
    /// Factor applied to the angular velocity at each impact; default `1 - 1.5 sin^2 alpha`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restitution: Option<f64>,
    /// Largest RK4 step, s.
    #[serde(default = "default_housner_step")]
    pub max_step: f64,
    /// Largest RK4 step as a phase of the block's frequency parameter, `p h` (dimensionless):
    /// the step is `min(max_step, max_phase_step / p)`, so small (fast) blocks get
    /// proportionally smaller steps.
    #[serde(default = "default_housner_phase_step")]
    pub max_phase_step: f64,
    /// Impact instants are located to this time tolerance, s. Default 1e-10 s, or
    /// [`MIN_EVENT_TOLERANCE_REL`] of the duration for runs longer than 1000 s, where time's
    /// round-off is coarser.
    #[serde(default = "default_housner_event_tol")]
    pub event_tolerance: f64,
}

fn default_housner_step() -> f64 {
    1e-4
}
/// Chosen by measurement (`rockbench stress`, factor `size`): with `p h <= 3e-4` the energy
/// of a free-rocking block (H/B = 2.5, H 0.05 .. 20 m, 4 s) grows by at most 3.9e-13 of m g H
/// between impacts; the validation blocks (p = 2.3 and 2.9 1/s) keep the 1e-4 s step. (The
/// 9.4e-9 at H = 0.05 m with the fixed 1e-4 s step that the choice was measured against came
/// from impacts missed within a step, fixed since: with every impact located the fixed step
/// gives 2.7e-16 there.)
fn default_housner_phase_step() -> f64 {
    3e-4
}
fn default_housner_event_tol() -> f64 {
    1e-10
}

impl Default for HousnerSettings {
    fn default() -> Self {
        HousnerSettings {
            restitution: None,
            max_step: default_housner_step(),
            max_phase_step: default_housner_phase_step(),
            event_tolerance: default_housner_event_tol(),
        }
    }
}

impl HousnerSettings {
    /// The scene's `[housner]` table, parsed and checked (one-line errors naming
    /// `housner.<field>`).
    pub fn of(scene: &Scene) -> Result<HousnerSettings, SceneError> {
        let mut s: HousnerSettings = scene.parse_table("housner")?;
        let given = |field: &str| {
            scene
                .engine_table("housner")
                .and_then(|t| t.get(field))
                .is_some()
        };
        if !given("event_tolerance") {
            s.event_tolerance = s
                .event_tolerance
                .max(MIN_EVENT_TOLERANCE_REL * scene.duration.max(1.0));
        }
        s.validate(scene)?;
        Ok(s)
    }

    fn validate(&self, scene: &Scene) -> Result<(), SceneError> {
        let err =
            |f: &str, m: String| Err(SceneError::new(&scene.source, format!("housner.{f}"), m));
        let num = crate::scene::num;
        for (f, v) in [
            ("max_step", self.max_step),
            ("max_phase_step", self.max_phase_step),
            ("event_tolerance", self.event_tolerance),
        ] {
            if !v.is_finite() || v <= 0.0 {
                return err(f, format!("must be a positive number (got {})", num(v)));
            }
        }
        let tol_floor = MIN_EVENT_TOLERANCE_REL * scene.duration.max(1.0);
        if self.event_tolerance < tol_floor {
            return err(
                "event_tolerance",
                format!(
                    "must be at least {tol_floor:e} s (1e-13 of max(duration, 1 s)); below that time round-off stops the event bisection (got {})",
                    num(self.event_tolerance)
                ),
            );
        }
        let housner_steps = scene.duration / self.max_step;
        if housner_steps > MAX_STEPS {
            return err(
                "max_step",
                format!(
                    "duration / max_step = {housner_steps:e} steps; at most {MAX_STEPS:e} are allowed (a unit slip?)"
                ),
            );
        }
        // The fastest block's step, `max_phase_step / p`, bounds the steps as well.
        let p_max = crate::scene::fastest_block(scene).map_or(0.0, |(_, p)| p);
        let phase_steps = scene.duration * p_max / self.max_phase_step;
        if phase_steps > MAX_STEPS {
            return err(
                "max_phase_step",
                format!(
                    "duration x p / max_phase_step = {phase_steps:e} steps for the fastest block; at most {MAX_STEPS:e} are allowed"
                ),
            );
        }
        let smallest_step = self.max_step.min(self.max_phase_step / p_max);
        if self.event_tolerance >= smallest_step {
            return err(
                "event_tolerance",
                format!(
                    "must be smaller than the RK4 step ({} s for the fastest block): impacts would be located no better than a step (got {})",
                    num(smallest_step),
                    num(self.event_tolerance)
                ),
            );
        }
        if let Some(r) = self.restitution
            && (!r.is_finite() || !(0.0..=1.0).contains(&r))
        {
            return err("restitution", format!("must be in [0, 1] (got {})", num(r)));
        }
        Ok(())
    }
}

pub struct HousnerEngine;

/// Parameters of one block.
#[derive(Debug, Clone, Copy)]
pub struct HousnerBlock {
    pub b: f64,
    pub h: f64,
    pub alpha: f64,
    pub p2: f64,
    pub g: f64,
    pub restitution: f64,
}

impl HousnerBlock {
    /// The friction below which the block slides where the model has it rock: `B/H` to start
    /// rocking before it slides, `(H/B) (1 - r) / (1 + r)` for the pivot not to slip at impact.
    pub fn friction_to_rock(&self) -> (f64, f64) {
        let r = self.restitution;
        (self.b / self.h, (self.h / self.b) * (1.0 - r) / (1.0 + r))
    }

    pub fn new(width: f64, height: f64, g: f64, restitution: Option<f64>) -> Self {
        let (b, h) = (width / 2.0, height / 2.0);
        let r = b.hypot(h);
        let alpha = (b / h).atan();
        HousnerBlock {
            b,
            h,
            alpha,
            p2: 3.0 * g / (4.0 * r),
            g,
            restitution: restitution.unwrap_or(1.0 - 1.5 * alpha.sin().powi(2)),
        }
    }

    /// Angular acceleration on pivot s (+1 left corner, -1 right corner).
    pub fn accel(&self, theta: f64, s: f64, a: (f64, f64)) -> f64 {
        let arg = self.alpha * s - theta;
        -self.p2 * ((1.0 + a.1 / self.g) * arg.sin() - (a.0 / self.g) * arg.cos())
    }

    /// Centroid position and velocity relative to the upright position's base centre.
    pub fn centroid(&self, theta: f64, omega: f64, s: f64) -> [f64; 6] {
        let (sn, cs) = theta.sin_cos();
        let (b, h) = (self.b, self.h);
        [
            -s * b + s * b * cs - h * sn,
            s * b * sn + h * cs,
            theta,
            (-s * b * sn - h * cs) * omega,
            (s * b * cs - h * sn) * omega,
            omega,
        ]
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Rocking,
    Rest,
    Overturned,
}

/// One RK4 step over [t, t + h], a span the ground motion is smooth on (steps end on its
/// breakpoints): the first stage takes the acceleration's limit from the right at t, the last
/// its limit from the left at t + h (a pulse that ends at t is 0 after it; the value at t is
/// its last one).
fn rk4(blk: &HousnerBlock, gm: &GroundMotion, t: f64, y: (f64, f64), s: f64, h: f64) -> (f64, f64) {
    let f = |a: (f64, f64), th: f64| blk.accel(th, s, a);
    let (th, om) = y;
    let mid = gm.acc(t + 0.5 * h);
    let k1 = (om, f(gm.acc_side(t, true), th));
    let k2 = (om + 0.5 * h * k1.1, f(mid, th + 0.5 * h * k1.0));
    let k3 = (om + 0.5 * h * k2.1, f(mid, th + 0.5 * h * k2.0));
    let k4 = (om + h * k3.1, f(gm.acc_side(t + h, false), th + h * k3.0));
    (
        th + h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0),
        om + h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1),
    )
}

/// Result of integrating one block.
pub struct HousnerRun {
    pub trajectory: Vec<(f64, [f64; 6])>,
    /// All located impacts: (time, largest |theta| of the half-wave before it).
    pub impacts: Vec<(f64, f64)>,
    pub steps: u64,
}

/// Time span and resolution of an integration.
#[derive(Debug, Clone, Copy)]
pub struct Span {
    pub duration: f64,
    pub output_interval: f64,
    pub max_step: f64,
    pub event_tolerance: f64,
}

/// Integrate from (theta0, omega0) over `span`, sampling every `span.output_interval`.
pub fn integrate(
    blk: &HousnerBlock,
    gm: &GroundMotion,
    (theta0, omega0): (f64, f64),
    span: Span,
) -> HousnerRun {
    let Span {
        duration,
        output_interval,
        max_step,
        event_tolerance: event_tol,
    } = span;
    let breaks = gm.breakpoints();
    let mut phase = if theta0 == 0.0 && omega0 == 0.0 {
        Phase::Rest
    } else {
        Phase::Rocking
    };
    let mut s = if theta0 != 0.0 {
        theta0.signum()
    } else if omega0 != 0.0 {
        omega0.signum()
    } else {
        1.0
    };
    let (mut th, mut om) = (theta0, omega0);
    let mut t = 0.0;
    let mut out = vec![(0.0, blk.centroid(th, om, s))];
    let mut impacts = Vec::new();
    let mut wave_max = th.abs();
    let mut steps = 0u64;
    let n_out = (duration / output_interval - 1e-9).ceil() as usize;
    let onset = |t: f64| -> f64 {
        // > 0 when the ground acceleration can lift the block; sign gives the pivot.
        let (ax, az) = gm.acc(t);
        let lim = (blk.g + az) * blk.alpha.tan();
        if ax > lim {
            ax - lim
        } else if ax < -lim {
            ax + lim
        } else {
            0.0
        }
    };
    for k in 1..=n_out {
        let t_next = (k as f64 * output_interval).min(duration);
        while t < t_next - 1e-15 {
            // Step end: output time, next breakpoint, or max_step.
            let mut t1 = t_next.min(t + max_step);
            if let Some(&bp) = breaks.iter().find(|&&b| b > t + 1e-15 && b < t1) {
                t1 = bp;
            }
            steps += 1;
            match phase {
                Phase::Overturned => {
                    t = t1;
                }
                Phase::Rest => {
                    let c1 = onset(t1);
                    if c1 == 0.0 {
                        t = t1;
                        continue;
                    }
                    // Locate the onset: the last instant with no lift.
                    let (mut lo, mut hi) = (t, t1);
                    while hi - lo > event_tol {
                        let mid = 0.5 * (lo + hi);
                        if onset(mid) == 0.0 {
                            lo = mid
                        } else {
                            hi = mid
                        }
                    }
                    s = c1.signum();
                    let (th1, om1) = rk4(blk, gm, hi, (0.0, 0.0), s, t1 - hi);
                    if th1 * s > 0.0 {
                        phase = Phase::Rocking;
                        (th, om) = (th1, om1);
                        wave_max = th.abs();
                    }
                    t = t1;
                }
                Phase::Rocking => {
                    // From `tc` to the step's end, locating every crossing of zero: near the end
                    // of a sequence of impacts a half-wave can be shorter than the rest of the
                    // step (integrated on past zero on the old pivot, a random stack's block
                    // gained 1.1e-9 of m g H at its last sample).
                    let mut tc = t;
                    loop {
                        let (th1, om1) = rk4(blk, gm, tc, (th, om), s, t1 - tc);
                        if th1 * s >= 0.0 {
                            th = th1;
                            om = om1;
                            wave_max = wave_max.max(th.abs());
                            if th.abs() >= FRAC_PI_2 {
                                phase = Phase::Overturned;
                                th = FRAC_PI_2 * s;
                                om = 0.0;
                            }
                            break;
                        }
                        // Crossed zero before the step's end: bisect on the time from `tc`.
                        let (mut lo, mut hi) = (0.0, t1 - tc);
                        while hi - lo > event_tol {
                            let mid = 0.5 * (lo + hi);
                            let (thm, _) = rk4(blk, gm, tc, (th, om), s, mid);
                            if thm * s > 0.0 { lo = mid } else { hi = mid }
                        }
                        let tau = 0.5 * (lo + hi);
                        let (_, om_imp) = rk4(blk, gm, tc, (th, om), s, tau);
                        let t_imp = tc + tau;
                        impacts.push((t_imp, wave_max));
                        wave_max = 0.0;
                        let om_after = om_imp * blk.restitution;
                        let decel = blk.p2 * blk.alpha.sin();
                        let amp = om_after * om_after / (2.0 * decel);
                        // Near theta = 0, theta'' ~ -p^2 sin(alpha) on either pivot, so a
                        // half-wave launched at om lasts 2|om|/(p^2 sin alpha) and the remaining
                        // impacts (each scaling om by r < 1) all end by the Zeno instant below.
                        // When that falls within this step the block is at rest at its end.
                        let zeno = if blk.restitution < 1.0 {
                            t_imp + 2.0 * om_after.abs() / (decel * (1.0 - blk.restitution))
                        } else {
                            f64::INFINITY
                        };
                        s = -s;
                        if amp < 1e-12 || om_after * s <= 0.0 || zeno <= t1 {
                            phase = Phase::Rest;
                            th = 0.0;
                            om = 0.0;
                            break;
                        }
                        // Go on from the impact on the new pivot.
                        (th, om, tc) = (0.0, om_after, t_imp);
                    }
                    t = t1;
                }
            }
        }
        t = t_next;
        out.push((t, blk.centroid(th, om, s)));
    }
    HousnerRun {
        trajectory: out,
        impacts,
        steps,
    }
}

/// The RK4 step of a block: `min(max_step, max_phase_step / p)` (RK4's energy error per
/// half-wave depends on `p h`, so a fixed step in seconds is too coarse for small blocks).
pub fn housner_step(blk: &HousnerBlock, hs: &HousnerSettings) -> f64 {
    hs.max_step.min(hs.max_phase_step / blk.p2.sqrt())
}

/// The first output instant where the ground's horizontal acceleration exceeds what friction
/// can pass to a block at rest, `mu (g + a_z)` (a strong pulse, or a vertical acceleration
/// that unloads the base): the block may slide there, which the model ignores.
fn drag_note(gm: &GroundMotion, scene: &Scene) -> Option<String> {
    let mu = scene.friction_below(0);
    let n = (scene.duration / scene.output_interval).ceil() as u64;
    (0..=n)
        .map(|k| (k as f64 * scene.output_interval).min(scene.duration))
        .find(|&t| {
            let (ax, az) = gm.acc(t);
            ax.abs() > mu * (scene.gravity + az)
        })
        .map(|t| {
            let (ax, az) = gm.acc(t);
            format!(
                "at t = {} s the ground's horizontal acceleration {:.4} m/s^2 exceeds friction's {} (g + a_z) = {:.4} m/s^2: the block may slide, which the Housner model ignores",
                crate::scene::num(t),
                ax,
                crate::scene::num(mu),
                mu * (scene.gravity + az)
            )
        })
}

/// A note when friction `mu` lets the block slide where the Housner model, which has no
/// sliding, rocks it ([`HousnerBlock::friction_to_rock`]).
pub fn sliding_note(blk: &HousnerBlock, mu: f64) -> Option<String> {
    // Three decimals, or scientific notation where they would say nothing or too much.
    let short = |x: f64| {
        if (1e-3..1e6).contains(&x) {
            format!("{x:.3}")
        } else {
            format!("{x:.3e}")
        }
    };
    let (to_start, at_impact) = blk.friction_to_rock();
    let mut why = Vec::new();
    if mu < to_start {
        why.push(format!(
            "B/H = {} for the block to rock before it slides",
            short(to_start)
        ));
    }
    if mu < at_impact {
        why.push(format!(
            "{} for the pivot not to slip at impact",
            short(at_impact)
        ));
    }
    (!why.is_empty()).then(|| {
        format!(
            "friction {} is below {}; the Housner model ignores sliding",
            crate::scene::num(mu),
            why.join(" and ")
        )
    })
}

/// The most slender block the Housner engine takes (`B/H`): its spectra match the closed forms
/// down to 1e-170 and lose them below 1e-175, where `alpha^2` underflows.
pub const MIN_SLENDERNESS: f64 = 1e-100;

impl Engine for HousnerEngine {
    fn name(&self) -> &'static str {
        "housner"
    }

    fn cannot_model(&self, scene: &Scene) -> Option<String> {
        if scene.blocks.len() != 1 {
            return Some(format!(
                "the Housner model is a single block on a rigid base; this scene has {} blocks",
                scene.blocks.len()
            ));
        }
        // A rotation rate is about the pivot corner (the centre then moves); only a sliding
        // velocity is beyond the model.
        if scene.initial.blocks.values().any(|s| s.vx != 0.0) {
            return Some("the Housner model does not slide; initial vx must be 0".into());
        }
        let b = &scene.blocks[0];
        if b.width / b.height < MIN_SLENDERNESS {
            return Some(format!(
                "B/H = {} is below {MIN_SLENDERNESS:e}: the model's angles, of the order of alpha, underflow in its arithmetic",
                crate::scene::num(b.width / b.height)
            ));
        }
        // Where the ground falls faster than g the block leaves it: no pivot, no rocking
        // equation (a record that cannot be read is the run's error, not this check's).
        let gm = GroundMotion::from_scene(scene);
        if gm
            .as_ref()
            .is_ok_and(GroundMotion::any_displacement_defined)
        {
            return Some(
                "the Housner model needs the ground acceleration; this scene prescribes a displacement history".into(),
            );
        }
        if let Ok(gm) = &gm
            && let Some(v) = &gm.vertical
        {
            let (t, a) = v.lowest_acceleration();
            if scene.gravity + a <= 0.0 {
                return Some(format!(
                    "the ground's vertical acceleration reaches {} m/s^2 at t = {} s, at or below -g: the block leaves the ground, which the Housner model (a block rocking on its base) does not describe",
                    crate::scene::num(a),
                    crate::scene::num(t)
                ));
            }
        }
        None
    }

    fn run_reporting(&self, scene: &Scene, _progress: Progress) -> Result<RunOutput, EngineError> {
        let refuse = |reason: String| EngineError::Unsupported {
            engine: "housner",
            scene: scene.name.clone(),
            reason,
        };
        if let Some(reason) = self.cannot_model(scene) {
            return Err(refuse(reason));
        }
        let gm = GroundMotion::from_scene(scene)?;
        let b = &scene.blocks[0];
        let st = scene.layout().blocks[0];
        let hs = &HousnerSettings::of(scene)?;
        let blk = HousnerBlock::new(b.width, b.height, scene.gravity, hs.restitution);
        let step = housner_step(&blk, hs);
        let run = integrate(
            &blk,
            &gm,
            (st.phi, st.omega),
            Span {
                duration: scene.duration,
                output_interval: scene.output_interval,
                max_step: step,
                event_tolerance: hs.event_tolerance,
            },
        );
        let mut tr = Trajectory::new(std::slice::from_ref(&b.name));
        for (t, mut s) in run.trajectory {
            // The centre's place on the ground: `x` where the scene gives it, else `offset`.
            s[0] += b.x.unwrap_or(b.offset);
            tr.push(t, &[s]);
        }
        let impacts: Vec<f64> = run
            .impacts
            .iter()
            .filter(|(_, amp)| *amp >= NOISE_FLOOR)
            .map(|(t, _)| *t)
            .collect();
        let r = blk.restitution;
        let mut notes: Vec<String> = sliding_note(&blk, scene.friction_below(0))
            .into_iter()
            .collect();
        notes.extend(drag_note(&gm, scene));
        Ok(RunOutput {
            trajectory: tr,
            settings: serde_json::json!({
                "restitution": r,
                "restitution_rule": if hs.restitution.is_some() { "given" } else { "1 - 1.5 sin^2 alpha" },
                "max_step": hs.max_step,
                "max_phase_step": hs.max_phase_step,
                "step": step,
                "event_tolerance": hs.event_tolerance,
                "integrator": "RK4 with bisection event location",
                "output_interval": scene.output_interval,
                "alpha": blk.alpha,
                "p": blk.p2.sqrt(),
            }),
            engine_version: format!("rockbench {} housner", env!("CARGO_PKG_VERSION")),
            steps: run.steps,
            solver_iterations: None,
            exact_impacts: Some(vec![impacts]),
            valid_until: None,
            notes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    fn scene(duration: f64, table: &str) -> Scene {
        let text = format!(
            "name = \"long\"\nduration = {duration}\n[[blocks]]\nname = \"b\"\nwidth = 0.4\n\
             height = 1.0\n[initial]\ntilt = 0.05\n{table}"
        );
        parse_scene_str(&text, false, "long.toml", &[]).unwrap()
    }

    #[test]
    fn the_default_event_tolerance_follows_long_durations_and_a_given_one_is_checked() {
        let tol = |s: &Scene| HousnerSettings::of(s).map(|h| h.event_tolerance);
        assert_eq!(tol(&scene(10.0, "")).unwrap(), 1e-10);
        assert_eq!(tol(&scene(1000.0, "")).unwrap(), 1e-10);
        let four_hours = tol(&scene(14400.0, "")).unwrap();
        assert!((four_hours - 1.44e-9).abs() < 1e-24, "{four_hours}");
        let given = tol(&scene(14400.0, "[housner]\nevent_tolerance = 1e-10\n")).unwrap_err();
        assert!(
            given
                .to_string()
                .contains("housner.event_tolerance: must be at least"),
            "{given}"
        );
        let fine = tol(&scene(14400.0, "[housner]\nevent_tolerance = 2e-9\n")).unwrap();
        assert_eq!(fine, 2e-9);
        let coarse = tol(&scene(10.0, "[housner]\nevent_tolerance = 1e-4\n")).unwrap_err();
        assert!(
            coarse.to_string().contains(
                "housner.event_tolerance: must be smaller than the RK4 step (8.11625379238725e-5 s for the fastest block)"
            ),
            "{coarse}"
        );
    }
}
