//! Scene files: blocks, contact, excitation, initial state and engine settings.
//!
//! A scene is read from TOML (or JSON, chosen by the file extension), checked field by field,
//! and kept as plain data. Every problem is reported as one [`SceneError`] line naming the
//! file, the field and what is wrong. The format is documented field by field in
//! `docs/scene-format.md`.

mod layout;
mod load;
mod validate;

pub use layout::{BlockState, Layout};
pub use load::{
    apply_override, check_scene_str, load_scene, load_scene_with_overrides, parse_scene_str,
};
pub(crate) use validate::num;

use crate::engines::rapier_settings::RapierSettings;
use crate::native::NativeSettings;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// One line: `file: field: problem`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {field}: {message}")]
pub struct SceneError {
    pub file: String,
    pub field: String,
    pub message: String,
}

impl SceneError {
    pub fn new(file: &str, field: impl Into<String>, message: impl Into<String>) -> Self {
        SceneError {
            file: one_line(file),
            field: one_line(&field.into()),
            message: one_line(&message.into()),
        }
    }
}

/// Control characters (a newline inside a key or a value quoted in a message) escaped, so an
/// error stays one line.
fn one_line(s: &str) -> String {
    if !s.chars().any(char::is_control) {
        return s.to_string();
    }
    s.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

fn default_gravity() -> f64 {
    9.81
}
fn default_density() -> f64 {
    2500.0
}
fn default_friction() -> f64 {
    0.7
}
fn default_output_interval() -> f64 {
    1e-3
}

/// A scene as written in the file, with defaults filled in.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Scene name, used in reports.
    pub name: String,
    /// Simulated duration, s.
    pub duration: f64,
    /// Gravitational acceleration, m/s^2 (acts in -z).
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// Interval between trajectory samples, s (engines sample at most this often).
    #[serde(default = "default_output_interval")]
    pub output_interval: f64,
    /// Blocks, bottom to top.
    pub blocks: Vec<BlockSpec>,
    #[serde(default)]
    pub initial: InitialSpec,
    #[serde(default)]
    pub contact: ContactSpec,
    /// Ground excitation; absent means free rocking.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excitation: Option<ExcitationSpec>,
    /// Settings of the native theta-method engine.
    #[serde(default)]
    pub native: NativeSettings,
    /// Settings of the analytical Housner engine.
    #[serde(default)]
    pub housner: HousnerSettings,
    /// Settings of the rapier2d engine (parsed and checked in every build, also without the
    /// `rapier` feature).
    #[serde(default)]
    pub rapier: RapierSettings,
    /// Settings read by engines outside this crate's core (MuJoCo, PyBullet): kept as given and
    /// passed to the engine, which validates them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mujoco: Option<serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pybullet: Option<serde_json::Value>,
    /// Settings of the Siconos engine (the worker validates them; the harness reads `step` and
    /// `timeout`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub siconos: Option<serde_json::Value>,
    /// Directory of the scene file: record paths are relative to it.
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// The file the scene was read from (for messages).
    #[serde(skip)]
    pub source: String,
}

/// A rectangular block.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BlockSpec {
    pub name: String,
    /// Width B, m.
    pub width: f64,
    /// Height H, m.
    pub height: f64,
    /// Density, kg/m^3 (mass per metre of depth = density * B * H).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Horizontal offset of the centre from the centre of the block below, m.
    #[serde(default)]
    pub offset: f64,
    /// Absolute horizontal position of the centre, m (instead of `offset`): the block then rests
    /// on the highest previously listed blocks under it, or on the ground. Used for walls.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<f64>,
}

impl BlockSpec {
    pub fn mass(&self) -> f64 {
        self.density * self.width * self.height
    }
    /// Moment of inertia about the centroid, kg m^2 per metre of depth.
    pub fn inertia(&self) -> f64 {
        self.mass() * (self.width * self.width + self.height * self.height) / 12.0
    }
    /// Geometric critical angle atan(B/H), rad.
    pub fn critical_angle(&self) -> f64 {
        (self.width / self.height).atan()
    }
}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Rigid rotation of the whole stack about the bottom block's pivot corner, rad,
    /// counter-clockwise positive (positive: pivot on the left corner).
    #[serde(default)]
    pub tilt: f64,
    /// Per-block initial state, keyed by block name.
    #[serde(default)]
    pub blocks: BTreeMap<String, InitialBlockSpec>,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InitialBlockSpec {
    /// Rotation relative to the block below, rad, about the block's own pivot corner on it.
    #[serde(default)]
    pub rotation: f64,
    /// Angular velocity relative to the block below, rad/s, about the same pivot corner.
    #[serde(default)]
    pub omega: f64,
    /// Horizontal sliding velocity relative to the block below (or the ground), m/s.
    #[serde(default)]
    pub vx: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Coulomb friction coefficient for every interface unless overridden.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Per-interface friction, keyed by the name of the upper block of the interface
    /// (the bottom block's key is its interface with the ground).
    #[serde(default)]
    pub interfaces: BTreeMap<String, InterfaceSpec>,
}

impl Default for ContactSpec {
    fn default() -> Self {
        ContactSpec {
            friction: default_friction(),
            interfaces: BTreeMap::new(),
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSpec {
    pub friction: f64,
}

/// How the native engine applies a ground motion. Both routes give the same relative motion.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum AppliedAs {
    /// Inertial forces `-m a_g(t)` on every block, ground fixed.
    #[default]
    InertialForces,
    /// The ground moves with the prescribed displacement (support movement).
    MovingGround,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ExcitationSpec {
    #[serde(default)]
    pub applied_as: AppliedAs,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizontal: Option<MotionSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertical: Option<MotionSpec>,
}

/// One component of ground motion.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum MotionSpec {
    /// `a(t) = A sin(pi (t - t0) / T)` for `0 <= t - t0 <= T` (T = duration = period / 2).
    HalfSine {
        amplitude: f64,
        #[serde(default)]
        duration: Option<f64>,
        #[serde(default)]
        period: Option<f64>,
        #[serde(default)]
        start: f64,
    },
    /// `a(t) = A sin(2 pi (t - t0) / T)` for `0 <= t - t0 <= T` (T = duration = period).
    OneSine {
        amplitude: f64,
        #[serde(default)]
        duration: Option<f64>,
        #[serde(default)]
        period: Option<f64>,
        #[serde(default)]
        start: f64,
    },
    /// `a(t) = A cos(2 pi (t - t0) / T)` for `0 <= t - t0 <= T` (T = duration = period).
    OneCosine {
        amplitude: f64,
        #[serde(default)]
        duration: Option<f64>,
        #[serde(default)]
        period: Option<f64>,
        #[serde(default)]
        start: f64,
    },
    /// Ricker wavelet (Mexican hat) of peak `A` and period `T_p` (omega_p = 2 pi / T_p):
    /// `a(t) = A (1 - 2 u^2) exp(-u^2)`, `u = pi (t - t0 - 1.5 T_p) / T_p`, for
    /// `0 <= t - t0 <= 3 T_p` (zero outside; the cut-off ends are below 1e-8 A).
    Ricker {
        amplitude: f64,
        period: f64,
        #[serde(default)]
        start: f64,
    },
    /// `a(t) = A` for `0 <= t - t0 <= T`.
    Rectangular {
        amplitude: f64,
        duration: f64,
        #[serde(default)]
        start: f64,
    },
    /// Ground acceleration record: two-column CSV (time s, acceleration m/s^2) or PEER NGA
    /// `.AT2` (acceleration in g), multiplied by `scale`.
    Record {
        file: String,
        #[serde(default = "one")]
        scale: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        format: Option<RecordFormat>,
    },
    /// Prescribed ground displacement history (support movement): two-column CSV
    /// (time s, displacement m), multiplied by `scale`.
    Displacement {
        file: String,
        #[serde(default = "one")]
        scale: f64,
    },
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RecordFormat {
    Csv,
    At2,
}

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
    /// Impact instants are located to this time tolerance, s.
    #[serde(default = "default_housner_event_tol")]
    pub event_tolerance: f64,
}

fn default_housner_step() -> f64 {
    1e-4
}
/// Chosen by measurement (`rockbench stress`, factor `size`): with `p h <= 3e-4` the energy
/// of a free-rocking block (H/B = 2.5, H 0.05 .. 20 m, 4 s) grows by at most 3.9e-13 of m g H
/// between impacts (9.4e-9 at H = 0.05 m with the fixed 1e-4 s step); the validation blocks
/// (p = 2.3 and 2.9 1/s) keep the 1e-4 s step.
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

impl Scene {
    /// Friction of the interface under block `i` (with the ground for a block on the ground).
    pub fn friction_below(&self, i: usize) -> f64 {
        self.contact
            .interfaces
            .get(&self.blocks[i].name)
            .map(|s| s.friction)
            .unwrap_or(self.contact.friction)
    }

    /// Friction of the interface between two bodies (`None` is the ground): the override keyed
    /// by the upper body, else the scene default.
    pub fn friction_between(&self, lower: Option<usize>, upper: usize) -> f64 {
        let _ = lower;
        self.friction_below(upper)
    }

    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.blocks.iter().position(|b| b.name == name)
    }

    /// Check every field (what [`load_scene`] does after parsing): for scenes built in memory.
    pub fn check(&self) -> Result<(), SceneError> {
        validate::validate(self)
    }

    /// The initial configuration (positions, velocities, supports).
    pub fn layout(&self) -> Layout {
        Layout::of(self)
    }

    pub fn has_excitation(&self) -> bool {
        self.excitation
            .as_ref()
            .is_some_and(|e| e.horizontal.is_some() || e.vertical.is_some())
    }

    /// The scene as JSON with record paths made absolute: the form handed to external engines.
    pub fn to_json(&self) -> serde_json::Value {
        let mut scene = self.clone();
        if let Some(exc) = scene.excitation.as_mut() {
            for m in [exc.horizontal.as_mut(), exc.vertical.as_mut()]
                .into_iter()
                .flatten()
            {
                if let MotionSpec::Record { file, .. } | MotionSpec::Displacement { file, .. } = m {
                    *file = self.base_dir.join(&*file).display().to_string();
                }
            }
        }
        serde_json::to_value(&scene).expect("a scene always serialises")
    }
}
