//! The rapier2d engine: the same scenes in a second, independent Rust physics engine
//! (`rapier2d-f64` 0.36 with `enhanced-determinism`), behind the cargo feature `rapier`.
//!
//! ## Model
//! Every block is a dynamic rigid body with one cuboid collider of the block's width and
//! height and the block's density (rapier's 2D mass is density x area, so mass and centroidal
//! inertia are the scene's per-metre values `rho B H` and `m (B^2 + H^2) / 12`). The ground is
//! a wide box whose top face is the line z = 0 at t = 0. Gravity is `(0, -g)`. The initial
//! positions and velocities are the scene's [`crate::scene::Layout`]. Settings: `[rapier]`,
//! see [`super::rapier_settings::RapierSettings`].
//!
//! ## Coordinates (rapier -> rockbench, stated once)
//! Rapier's 2D frame is x to the right, y up, angles counter-clockwise; rockbench's is x to
//! the right, z up, rotations counter-clockwise. So `x = translation.x`, `z = translation.y`,
//! `phi = rotation.angle()` (unwrapped continuously from step to step, so a block that turns
//! past pi keeps counting), `vx, vz = linvel`, `omega = angvel`. The body origin is the
//! collider's centre, which is the centroid. When the ground moves, the ground body's
//! displacement and velocity are subtracted, so the output is relative to the ground like
//! every other engine's.
//!
//! ## Ground excitation: two routes (`excitation.applied_as`)
//! - `inertial-forces` (the default): the ground is a fixed body and every block carries the
//!   force `-m a_g`. Over each step the force is the step-averaged ground acceleration
//!   `(v_g(t + dt) - v_g(t)) / dt`, so the velocity impulse per step is exact for pulses,
//!   acceleration records and displacement histories alike (the latter have their
//!   acceleration concentrated at the samples).
//! - `moving-ground`: the ground is a kinematic position-based body moved each step to the
//!   prescribed displacement `d_g(t + dt)`; rapier gives it the velocity
//!   `(d_g(t + dt) - d_g(t)) / dt` for the contacts. Positions and velocities are reported
//!   relative to that body.
//!
//! Both routes give the same relative motion up to rapier's contact softness; the test
//! `excitation_routes_agree` in `tests/rapier.rs` measures the difference.
//!
//! ## Friction
//! With `friction_rule = "interface"` (default) every contact pair gets the scene's interface
//! friction, exactly as in the native engine (a block on the ground: the value keyed by that
//! block; two blocks: the value keyed by the later-listed block), raised to `min_friction`.
//! When all interfaces share one value, every collider carries it and rapier's own average
//! gives it; otherwise (or with `min_friction > 0`) a contact hook sets each pair's value, and
//! rapier then never recycles those pairs' contacts (`contact_recycling` has no effect; the
//! summary's `settings.friction_hook` says which). Rapier's combine rules are available for
//! comparison.

use super::rapier_settings::{CombineRule, FrictionRule, RapierSettings};
use super::{Engine, EngineError, Progress, RunOutput, RunSteps};
use crate::excitation::GroundMotion;
use crate::scene::{AppliedAs, Scene};
use crate::trajectory::Trajectory;
use rapier2d_f64::prelude::*;

/// The rapier crate this engine is built on (checked against Cargo.lock by a test).
pub const RAPIER_VERSION: &str = "0.36.1";

/// `user_data` of the ground collider; block colliders carry their block index.
const GROUND_TAG: u128 = u128::MAX;

pub struct RapierEngine;

fn combine_rule(r: CombineRule) -> CoefficientCombineRule {
    match r {
        CombineRule::Average => CoefficientCombineRule::Average,
        CombineRule::Min => CoefficientCombineRule::Min,
        CombineRule::Multiply => CoefficientCombineRule::Multiply,
        CombineRule::Max => CoefficientCombineRule::Max,
        CombineRule::ClampedSum => CoefficientCombineRule::ClampedSum,
        CombineRule::GeometricMean => CoefficientCombineRule::GeometricMean,
    }
}

/// The combine rule behind a friction rule (`interface` has none: the hook sets the value).
fn friction_combine(r: FrictionRule) -> Option<CombineRule> {
    match r {
        FrictionRule::Interface => None,
        FrictionRule::Average => Some(CombineRule::Average),
        FrictionRule::Min => Some(CombineRule::Min),
        FrictionRule::Multiply => Some(CombineRule::Multiply),
        FrictionRule::Max => Some(CombineRule::Max),
        FrictionRule::ClampedSum => Some(CombineRule::ClampedSum),
        FrictionRule::GeometricMean => Some(CombineRule::GeometricMean),
    }
}

/// The friction block `i` has on what it initially rests on, as rapier applies it: the
/// interface's (`friction_rule = "interface"`), or rapier's combination of the two colliders'
/// coefficients (the block's: the interface under it; the ground's: `contact.friction`; a
/// block's below: the interface under that block), raised to `min_friction`.
fn friction_on_support(
    scene: &Scene,
    supports: &[Option<usize>],
    s: &RapierSettings,
    i: usize,
) -> f64 {
    let mu = match friction_combine(s.friction_rule).map(combine_rule) {
        None => scene.friction_below(i),
        Some(rule) => {
            let under = match supports[i] {
                None => scene.contact.friction,
                Some(j) => scene.friction_below(j),
            };
            CoefficientCombineRule::combine(scene.friction_below(i), under, rule, rule)
        }
    };
    mu.max(s.min_friction)
}

/// Sets each contact pair's friction (see the module docs).
struct FrictionHook {
    /// Friction of the interface under each block (`Scene::friction_below`).
    below: Vec<f64>,
    /// `None`: rapier's combined value is kept (only raised to `min`).
    interface: bool,
    min: f64,
}

impl FrictionHook {
    /// The interface friction between two colliders' tags.
    fn interface_friction(&self, a: u128, b: u128) -> Option<f64> {
        let upper = match (a, b) {
            (GROUND_TAG, GROUND_TAG) => return None,
            (GROUND_TAG, x) | (x, GROUND_TAG) => x,
            (x, y) => x.max(y),
        };
        self.below.get(usize::try_from(upper).ok()?).copied()
    }
}

impl PhysicsHooks for FrictionHook {
    fn modify_solver_contacts(&self, ctx: &mut ContactModificationContext) {
        let a = ctx.colliders[ctx.collider1].user_data;
        let b = ctx.colliders[ctx.collider2].user_data;
        let mu = if self.interface {
            self.interface_friction(a, b)
        } else {
            None
        };
        if let Some(m) = ctx.rigid_mut() {
            let value = mu.unwrap_or(*m.friction);
            *m.friction = value.max(self.min);
        }
    }
}

/// rapier's integration parameters from the settings.
fn integration_parameters(s: &RapierSettings) -> IntegrationParameters {
    let mut p = IntegrationParameters {
        dt: s.dt,
        ..IntegrationParameters::default()
    };
    p.num_solver_iterations = s.solver_iterations as usize;
    p.num_internal_pgs_iterations = s.pgs_iterations as usize;
    p.num_internal_stabilization_iterations = s.stabilization_iterations as usize;
    p.contact_recycling = s.contact_recycling;
    p.contact_softness = SpringCoefficients::new(s.contact_frequency, s.contact_damping_ratio);
    p.static_contact_softness =
        SpringCoefficients::new(s.static_contact_frequency, s.static_contact_damping_ratio);
    p.normalized_prediction_distance = s.prediction_distance;
    p.normalized_allowed_linear_error = s.allowed_linear_error;
    p.normalized_max_corrective_velocity = s.max_corrective_velocity;
    p.normalized_max_linear_velocity = s.max_linear_velocity;
    p.warmstart_coefficient = s.warmstart_coefficient;
    p.friction_in_bias_pass = s.friction_in_bias_pass;
    p.length_unit = 1.0;
    p
}

/// A rapier world built from a scene, stepped one `dt` at a time.
pub struct RapierSim {
    world: PhysicsWorld,
    hook: FrictionHook,
    /// Whether the colliders call the friction hook.
    hooked: bool,
    blocks: Vec<RigidBodyHandle>,
    names: Vec<String>,
    masses: Vec<f64>,
    ground: RigidBodyHandle,
    ground_half_height: f64,
    /// Half the ground box's width, m: a block whose centre comes within its half-diagonal of
    /// the box's edge ends the run (rapier's ground is finite, the scene's is not).
    ground_half_width: f64,
    /// Each block's half-diagonal, m.
    reach: Vec<f64>,
    motion: GroundMotion,
    applied_as: AppliedAs,
    /// Unwrapped rotation of each block and the raw angle it was unwrapped from.
    phi: Vec<(f64, f64)>,
    pub t: f64,
    pub steps: u64,
}

impl RapierSim {
    pub fn new(scene: &Scene) -> Result<RapierSim, EngineError> {
        let s = &RapierSettings::of(scene)?;
        let motion = GroundMotion::from_scene(scene)?;
        let applied_as = scene.applied_as();
        let moving = applied_as == AppliedAs::MovingGround && !motion.is_none();
        let mut world = PhysicsWorld {
            gravity: Vector::new(0.0, -scene.gravity),
            integration_parameters: integration_parameters(s),
            ..PhysicsWorld::default()
        };
        let layout = scene.layout();
        let fr_rule = friction_combine(s.friction_rule).map(combine_rule);
        // The hook is needed when the interface frictions differ (rapier's own combination of
        // equal coefficients already gives the interface value) or a minimum applies. Rapier
        // never recycles the contacts of a hooked pair.
        let below: Vec<f64> = (0..scene.blocks.len())
            .map(|i| scene.friction_below(i))
            .collect();
        let uniform = below.iter().all(|&mu| mu == scene.contact.friction);
        let hooked = (fr_rule.is_none() && !uniform) || s.min_friction > 0.0;
        let hooks = if hooked {
            ActiveHooks::MODIFY_SOLVER_CONTACTS
        } else {
            ActiveHooks::empty()
        };
        let material = |b: ColliderBuilder, mu: f64| {
            let b = b
                .friction(mu)
                .restitution(s.restitution)
                .restitution_combine_rule(combine_rule(s.restitution_rule))
                .active_hooks(hooks);
            match fr_rule {
                Some(r) => b.friction_combine_rule(r),
                None => b,
            }
        };

        // Ground: a box far wider than anything in the scene, its top face at z = 0.
        let reach: f64 = scene
            .blocks
            .iter()
            .zip(&layout.blocks)
            .map(|(b, st)| st.x.abs() + b.width + b.height)
            .sum();
        let extent: f64 = scene.blocks.iter().map(|b| b.width + b.height).sum();
        let ground_hx = 10.0 * (reach + extent) + 10.0;
        let ground_hy = extent.max(1.0);
        // Initial ground velocity (zero for pulses and records; the first segment's slope for a
        // displacement history starting at t = 0): the layout's velocities are relative to it.
        let (gvx, gvz) = if moving { motion.vel(0.0) } else { (0.0, 0.0) };
        let ground_body = if moving {
            RigidBodyBuilder::kinematic_position_based().linvel(Vector::new(gvx, gvz))
        } else {
            RigidBodyBuilder::fixed()
        }
        .translation(Vector::new(0.0, -ground_hy));
        let (ground, _) = world.insert(
            ground_body,
            material(
                ColliderBuilder::cuboid(ground_hx, ground_hy),
                scene.contact.friction,
            )
            .user_data(GROUND_TAG),
        );

        let mut blocks = Vec::with_capacity(scene.blocks.len());
        let mut masses = Vec::with_capacity(scene.blocks.len());
        for (i, (b, st)) in scene.blocks.iter().zip(&layout.blocks).enumerate() {
            let body = RigidBodyBuilder::dynamic()
                .translation(Vector::new(st.x, st.z))
                .rotation(st.phi)
                .linvel(Vector::new(st.vx + gvx, st.vz + gvz))
                .angvel(st.omega)
                .linear_damping(s.linear_damping)
                .angular_damping(s.angular_damping)
                .can_sleep(s.can_sleep);
            let coll = material(
                ColliderBuilder::cuboid(b.width / 2.0, b.height / 2.0).density(b.density),
                scene.friction_below(i),
            )
            .user_data(i as u128);
            let (h, _) = world.insert(body, coll);
            masses.push(world.bodies[h].mass());
            blocks.push(h);
        }
        let hook = FrictionHook {
            below,
            interface: fr_rule.is_none(),
            min: s.min_friction,
        };
        let phi = layout.blocks.iter().map(|b| (b.phi, b.phi)).collect();
        Ok(RapierSim {
            world,
            hook,
            hooked,
            blocks,
            names: scene.blocks.iter().map(|b| b.name.clone()).collect(),
            masses,
            ground,
            ground_half_height: ground_hy,
            ground_half_width: ground_hx,
            reach: scene
                .blocks
                .iter()
                .map(|b| 0.5 * b.width.hypot(b.height))
                .collect(),
            motion,
            applied_as: if moving {
                AppliedAs::MovingGround
            } else {
                AppliedAs::InertialForces
            },
            phi,
            t: 0.0,
            steps: 0,
        })
    }

    /// Whether contact pairs go through the friction hook (see the module docs).
    pub fn friction_hook_active(&self) -> bool {
        self.hooked
    }

    /// Mass of each block as rapier computed it from the collider, kg per metre.
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }

    /// Centroidal moment of inertia of block `i` as rapier computed it.
    pub fn inertia(&self, i: usize) -> f64 {
        self.world.bodies[self.blocks[i]]
            .mass_properties()
            .local_mprops
            .principal_inertia()
    }

    /// Advance one step of `dt`. Never inlined, so that callgrind can count a step's
    /// instructions by its name (`crate::instructions`).
    #[inline(never)]
    pub fn step(&mut self) -> Result<(), EngineError> {
        let dt = self.world.integration_parameters.dt;
        self.advance((self.steps + 1) as f64 * dt, dt)
    }

    /// Take step `k` (from 1) of `steps`: `dt` long, or the run's shorter last step.
    pub fn take(&mut self, steps: &RunSteps, k: u64) -> Result<(), EngineError> {
        match steps.short_end(k) {
            Some(t_end) => self.step_to(t_end),
            None => self.step(),
        }
    }

    /// Advance one step shorter than `dt`, to `t_end`: the last step of a run whose duration is
    /// not a whole number of steps.
    pub fn step_to(&mut self, t_end: f64) -> Result<(), EngineError> {
        let dt = self.world.integration_parameters.dt;
        let h = t_end - self.t;
        self.world.integration_parameters.dt = h;
        let advanced = self.advance(t_end, h);
        self.world.integration_parameters.dt = dt;
        advanced
    }

    /// Advance one step of length `dt`, rapier's step, to `t1`.
    fn advance(&mut self, t1: f64, dt: f64) -> Result<(), EngineError> {
        let t0 = self.t;
        if !self.motion.is_none() {
            match self.applied_as {
                AppliedAs::InertialForces => {
                    let (v0, v1) = (self.motion.vel(t0), self.motion.vel(t1));
                    let a = ((v1.0 - v0.0) / dt, (v1.1 - v0.1) / dt);
                    for (h, m) in self.blocks.iter().zip(&self.masses) {
                        let rb = &mut self.world.bodies[*h];
                        rb.reset_forces(false);
                        rb.add_force(Vector::new(-m * a.0, -m * a.1), true);
                    }
                }
                AppliedAs::MovingGround => {
                    let d = self.motion.disp(t1);
                    self.world.bodies[self.ground].set_next_kinematic_translation(Vector::new(
                        d.0,
                        d.1 - self.ground_half_height,
                    ));
                }
            }
        }
        self.world.step_with_events(&self.hook, &());
        self.steps += 1;
        self.t = t1;
        if let Some(h) = self.world.quarantine().bodies().first() {
            let which = self
                .blocks
                .iter()
                .position(|b| b == h)
                .map(|i| format!("block `{}`", self.names[i]))
                .unwrap_or_else(|| "the ground".into());
            return Err(EngineError::Failed {
                engine: "rapier",
                message: format!("the state of {which} became NaN or infinite at t = {t1:.6} s"),
            });
        }
        let cap = self.world.integration_parameters.max_linear_velocity();
        for (i, h) in self.blocks.iter().enumerate() {
            let speed = self.world.bodies[*h].linvel().length();
            if speed >= cap * (1.0 - 1e-9) {
                return Err(EngineError::Failed {
                    engine: "rapier",
                    message: format!(
                        "block `{}` reached rapier's speed limit rapier.max_linear_velocity = {} m/s at t = {t1:.6} s; rapier would clamp its motion",
                        self.names[i],
                        crate::scene::num(cap)
                    ),
                });
            }
        }
        let ground_x = self.world.bodies[self.ground].translation().x;
        for (i, h) in self.blocks.iter().enumerate() {
            let x = self.world.bodies[*h].translation().x - ground_x;
            if x.abs() + self.reach[i] >= self.ground_half_width {
                return Err(EngineError::Failed {
                    engine: "rapier",
                    message: format!(
                        "block `{}` reached the edge of rapier's ground box (x = {x:.3} m, the box \
                         {:.3} m either side of the scene's centre) at t = {t1:.6} s: past it the \
                         block would fall off a ground the scene does not have",
                        self.names[i], self.ground_half_width
                    ),
                });
            }
        }
        for (k, h) in self.blocks.iter().enumerate() {
            let raw = self.world.bodies[*h].rotation().angle();
            let (acc, prev) = self.phi[k];
            let mut d = raw - prev;
            d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
            self.phi[k] = (acc + d, raw);
        }
        Ok(())
    }

    /// `(x, z, phi, vx, vz, omega)` of every block relative to the ground.
    pub fn relative_states(&self) -> Result<Vec<[f64; 6]>, EngineError> {
        let g = &self.world.bodies[self.ground];
        let (gx, gz, gvx, gvz) = match self.applied_as {
            AppliedAs::MovingGround => {
                let p = g.translation();
                let v = g.linvel();
                (p.x, p.y + self.ground_half_height, v.x, v.y)
            }
            AppliedAs::InertialForces => (0.0, 0.0, 0.0, 0.0),
        };
        let out: Vec<[f64; 6]> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(k, h)| {
                let rb = &self.world.bodies[*h];
                let p = rb.translation();
                let v = rb.linvel();
                [
                    p.x - gx,
                    p.y - gz,
                    self.phi[k].0,
                    v.x - gvx,
                    v.y - gvz,
                    rb.angvel(),
                ]
            })
            .collect();
        if let Some(i) = out.iter().position(|s| s.iter().any(|x| !x.is_finite())) {
            return Err(EngineError::Failed {
                engine: "rapier",
                message: format!(
                    "the state of block `{}` became NaN or infinite at t = {:.6} s",
                    self.names[i], self.t
                ),
            });
        }
        Ok(out)
    }

    /// How the excitation was applied (`inertial-forces` also when there is none).
    pub fn applied_as(&self) -> AppliedAs {
        self.applied_as
    }
}

impl Engine for RapierEngine {
    fn name(&self) -> &'static str {
        "rapier"
    }

    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError> {
        let s = &RapierSettings::of(scene)?;
        let mut sim = RapierSim::new(scene)?;
        let dt = s.dt;
        let steps = RunSteps::new(scene.duration, dt);
        let n_steps = steps.count();
        let every = ((scene.output_interval / dt).round() as u64).max(1);
        let names: Vec<String> = scene.blocks.iter().map(|b| b.name.clone()).collect();
        let mut tr = Trajectory::new(&names);
        tr.push(0.0, &sim.relative_states()?);
        for k in 1..=n_steps {
            sim.take(&steps, k)?;
            if k % every == 0 || k == n_steps {
                tr.push(sim.t, &sim.relative_states()?);
            }
            if progress(sim.t).is_break() {
                return Err(EngineError::Interrupted {
                    engine: "rapier",
                    t: sim.t,
                });
            }
        }
        let mut settings = serde_json::to_value(s).expect("settings serialise");
        if let Some(o) = settings.as_object_mut() {
            let exc = if sim.motion.is_none() {
                "none".to_string()
            } else {
                match sim.applied_as() {
                    AppliedAs::InertialForces => {
                        "inertial-forces: fixed ground, force -m (v_g(t+dt) - v_g(t))/dt on every block".into()
                    }
                    AppliedAs::MovingGround => {
                        "moving-ground: kinematic position-based ground body at d_g(t+dt)".into()
                    }
                }
            };
            o.insert("excitation_route".into(), exc.into());
            o.insert(
                "applied_as".into(),
                serde_json::to_value(scene.excitation.as_ref().map(|e| e.applied_as))
                    .unwrap_or_default(),
            );
            o.insert("output_interval".into(), (every as f64 * dt).into());
            o.insert("friction_hook".into(), sim.friction_hook_active().into());
            let supports = scene.layout().supports;
            o.insert(
                "interface_friction".into(),
                scene
                    .blocks
                    .iter()
                    .enumerate()
                    .map(|(i, b)| {
                        (
                            b.name.clone(),
                            serde_json::Value::from(friction_on_support(scene, &supports, s, i)),
                        )
                    })
                    .collect::<serde_json::Map<_, _>>()
                    .into(),
            );
            o.insert(
                "fixed".into(),
                serde_json::json!({
                    "length_unit": 1.0,
                    "ccd": false,
                    "block_solver_feature": true,
                    "enhanced_determinism": true,
                    "ground": "cuboid, top face at z = 0",
                }),
            );
        }
        let mut notes = Vec::new();
        if *s != RapierSettings::default() {
            notes.push("rapier settings differ from rockbench's tuned defaults".to_string());
        }
        Ok(RunOutput {
            trajectory: tr,
            settings,
            engine_version: format!(
                "rockbench {} (rapier2d-f64 {RAPIER_VERSION}, enhanced-determinism)",
                env!("CARGO_PKG_VERSION")
            ),
            steps: sim.steps,
            solver_iterations: None,
            exact_impacts: None,
            valid_until: None,
            notes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `RapierSettings::rapier_defaults()` really is rapier's default configuration.
    #[test]
    fn rapier_defaults_are_rapiers() {
        let s = RapierSettings::rapier_defaults();
        assert_eq!(integration_parameters(&s), IntegrationParameters::default());
        let rb = RigidBodyBuilder::dynamic().build();
        assert_eq!(rb.linear_damping(), s.linear_damping);
        assert_eq!(rb.angular_damping(), s.angular_damping);
        assert_eq!(
            rb.activation().normalized_linear_threshold > 0.0,
            s.can_sleep
        );
        let c = ColliderBuilder::cuboid(1.0, 1.0).build();
        assert_eq!(c.restitution(), s.restitution);
        assert_eq!(
            c.restitution_combine_rule(),
            combine_rule(s.restitution_rule)
        );
        assert_eq!(c.friction_combine_rule(), CoefficientCombineRule::Average);
    }

    #[test]
    fn interface_friction_is_keyed_by_the_upper_block() {
        let h = FrictionHook {
            below: vec![0.5, 0.6, 0.9],
            interface: true,
            min: 0.0,
        };
        assert_eq!(h.interface_friction(GROUND_TAG, 0), Some(0.5));
        assert_eq!(h.interface_friction(2, GROUND_TAG), Some(0.9));
        assert_eq!(h.interface_friction(0, 1), Some(0.6));
        assert_eq!(h.interface_friction(2, 1), Some(0.9));
        assert_eq!(h.interface_friction(GROUND_TAG, GROUND_TAG), None);
    }
}
