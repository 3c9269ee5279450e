//! Scene files: blocks, contact, excitation, initial state and engine settings.
//!
//! A scene is read from TOML (or JSON, chosen by the file extension), checked field by field,
//! and kept as plain data. Every problem is reported as one [`SceneError`] line naming the
//! file, the field and what is wrong. The format is documented field by field in
//! `docs/scene-format.md`.
//!
//! The scene knows no engine. Each engine's table (`[native]`, `[housner]`, `[rapier]`, ...) is
//! kept as written (with `--set` overrides applied) in [`Scene::engines`]; the engine parses
//! and checks its own table ([`Scene::parse_table`] gives its errors the scene's one-line form),
//! and `crate::engines::registry` checks every table of a scene, and that each names an engine,
//! when a scene is loaded for running (`crate::engines::registry::load_scene`). The loaders here
//! ([`load_scene`], [`check_scene_str`]) check the scene's own fields only.

mod layout;
mod load;
mod validate;

pub use layout::{BlockState, Layout};
pub use load::{
    apply_override, check_override_keys, check_scene_str, check_scene_str_checked, load_scene,
    load_scene_checked, load_scene_with_overrides, override_covers, parse_scene_str,
};
pub(crate) use load::{toml_error_at, toml_fields};
pub(crate) use validate::num;
pub use validate::{
    MAX_FRICTION, MAX_PEAK_G, MAX_STEPS, MIN_EVENT_TOLERANCE_REL, check_samples, check_step,
    fastest_block, steps_over_motion,
};

use serde::{Deserialize, Serialize, Serializer};
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

/// A check of a scene's engine tables, supplied by the engine registry to the loaders
/// ([`load_scene_checked`]); the scene knows no engine. It runs after the scene's field checks
/// and runs [`check_samples`] itself, so that the first problem reported is the same as
/// before the tables left the scene.
pub type TableCheck = fn(&Scene) -> Result<(), SceneError>;

/// Engine settings tables keyed by engine name, each kept as written (a JSON object).
pub type EngineTables = BTreeMap<String, serde_json::Value>;

/// The label of the outputs' run-level rows (metrics.csv's cost rows), which no block may take.
pub const RUN_ROW: &str = "(run)";

/// The scene's own top-level fields; any other top-level table is an engine's settings table.
pub const SCENE_FIELDS: [&str; 8] = [
    "name",
    "duration",
    "gravity",
    "output_interval",
    "blocks",
    "initial",
    "contact",
    "excitation",
];

/// A scene as written in the file, with defaults filled in.
#[derive(Debug, Clone, Deserialize, PartialEq)]
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
    /// Engine settings tables keyed by engine name (`native`, `housner`, `rapier`, ...), as
    /// written: top-level tables that are not scene fields ([`SCENE_FIELDS`]). Serialised back
    /// at the top level.
    #[serde(skip)]
    pub engines: EngineTables,
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
    /// Mechanical energy per unit mass of the state `s = (x, z, phi, vx, vz, omega)` relative
    /// to the ground: kinetic (centroid and rotation about it) plus potential above `z_rest`.
    pub fn energy_per_mass(&self, s: &[f64; 6], g: f64, z_rest: f64) -> f64 {
        let i_over_m = (self.width * self.width + self.height * self.height) / 12.0;
        0.5 * (s[3] * s[3] + s[4] * s[4] + i_over_m * s[5] * s[5]) + g * (s[1] - z_rest)
    }
    /// The largest |phi| the block with centroid state `s` can reach in free rocking on the
    /// ground, from its energy above rest (`z_rest` its upright centroid height): where that
    /// energy is all potential, `g (R cos(alpha - phi) - H/2) = E`; at least `|s[2]|`.
    pub fn reachable_angle(&self, s: &[f64; 6], g: f64, z_rest: f64) -> f64 {
        let e = self.energy_per_mass(s, g, z_rest);
        let r = 0.5 * self.width.hypot(self.height);
        let alpha = (self.width / self.height).atan();
        let c = ((e / g + 0.5 * self.height) / r).clamp(-1.0, 1.0);
        (alpha - c.acos()).max(s[2].abs())
    }
    /// Housner's frequency parameter `p = sqrt(3 g / (4 R))`, 1/s (`R` the half-diagonal): `1/p`
    /// is the time scale of the block's rocking, and of any motion of a body its size under
    /// gravity.
    pub fn frequency_parameter(&self, g: f64) -> f64 {
        (3.0 * g / (2.0 * self.width.hypot(self.height))).sqrt()
    }
    /// The energy per unit mass the block at rest needs to tip over its corner: `g (R - H/2)`.
    pub fn tipping_energy_per_mass(&self, g: f64) -> f64 {
        g * (0.5 * self.width.hypot(self.height) - 0.5 * self.height)
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

#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RecordFormat {
    Csv,
    At2,
}

/// Read by hand so that a wrong value names the field: inside an excitation (a table tagged by
/// its `kind`) the error's path stops at the excitation.
impl<'de> Deserialize<'de> for RecordFormat {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        match s.as_str() {
            "csv" => Ok(RecordFormat::Csv),
            "at2" => Ok(RecordFormat::At2),
            other => Err(serde::de::Error::custom(format!(
                "format = {other:?}: expected \"csv\" or \"at2\""
            ))),
        }
    }
}

/// The scene as written: its fields, then each engine table at the top level.
impl Serialize for Scene {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Written<'a> {
            name: &'a str,
            duration: f64,
            gravity: f64,
            output_interval: f64,
            blocks: &'a [BlockSpec],
            initial: &'a InitialSpec,
            contact: &'a ContactSpec,
            #[serde(skip_serializing_if = "Option::is_none")]
            excitation: Option<&'a ExcitationSpec>,
            #[serde(flatten)]
            engines: &'a EngineTables,
        }
        Written {
            name: &self.name,
            duration: self.duration,
            gravity: self.gravity,
            output_interval: self.output_interval,
            blocks: &self.blocks,
            initial: &self.initial,
            contact: &self.contact,
            excitation: self.excitation.as_ref(),
            engines: &self.engines,
        }
        .serialize(serializer)
    }
}

impl Scene {
    /// How the excitation is applied (the default when the scene has none).
    pub fn applied_as(&self) -> AppliedAs {
        self.excitation
            .as_ref()
            .map(|e| e.applied_as)
            .unwrap_or_default()
    }

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

    /// Check the scene's own fields (what [`load_scene`] does after parsing): for scenes built
    /// in memory. The engine tables are checked by `crate::engines::registry::check`.
    pub fn check(&self) -> Result<(), SceneError> {
        validate::validate(self, None)
    }

    /// [`Scene::check`] with `tables` checking the engine tables (see [`TableCheck`]).
    pub fn check_with(&self, tables: TableCheck) -> Result<(), SceneError> {
        validate::validate(self, Some(tables))
    }

    /// The engine table `name` as written, if the scene has one.
    pub fn engine_table(&self, name: &str) -> Option<&serde_json::Value> {
        self.engines.get(name)
    }

    /// Parse the engine table `name` into its settings type (defaults for an absent table);
    /// a problem is one [`SceneError`] naming `name.<field>`. Range checks are the engine's.
    pub fn parse_table<T: serde::de::DeserializeOwned>(&self, name: &str) -> Result<T, SceneError> {
        let empty = serde_json::Value::Object(Default::default());
        let value = self.engines.get(name).unwrap_or(&empty);
        if !value.is_object() {
            return Err(SceneError::new(
                &self.source,
                name,
                format!("must be a table of settings (`[{name}]`)"),
            ));
        }
        serde_path_to_error::deserialize(value).map_err(|e| {
            let path = e.path().to_string();
            let field = if path == "." {
                name.to_string()
            } else {
                format!("{name}.{path}")
            };
            SceneError::new(
                &self.source,
                field,
                load::clean_serde_message(&e.inner().to_string()),
            )
        })
    }

    /// Set `name.key = value` in the engine table `name` (created if absent): for scenes
    /// changed in memory (`--set name.key=value` does the same on the file's tree).
    pub fn set_setting(&mut self, name: &str, key: &str, value: impl Serialize) {
        let v = serde_json::to_value(value).expect("settings serialise");
        let table = self
            .engines
            .entry(name.to_string())
            .or_insert_with(|| serde_json::Value::Object(Default::default()));
        if !table.is_object() {
            *table = serde_json::Value::Object(Default::default());
        }
        table
            .as_object_mut()
            .expect("made a table above")
            .insert(key.to_string(), v);
    }

    /// Replace the engine table `name` with `settings` serialised.
    pub fn set_table(&mut self, name: &str, settings: &impl Serialize) {
        let v = serde_json::to_value(settings).expect("settings serialise");
        self.engines.insert(name.to_string(), v);
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
                    // Absolute: a scene read through a relative path names its records from
                    // wherever its JSON is read next (a run directory's scene.json).
                    let path = self.base_dir.join(&*file);
                    *file = std::path::absolute(&path)
                        .unwrap_or(path)
                        .display()
                        .to_string();
                }
            }
        }
        serde_json::to_value(&scene).expect("a scene always serialises")
    }

    /// The SHA-256 of every record file the scene reads, by absolute path (a file that cannot
    /// be read says so): what the scene's text alone does not fix.
    pub fn record_hashes(&self) -> serde_json::Map<String, serde_json::Value> {
        let mut records = serde_json::Map::new();
        for p in self.record_files() {
            let h = crate::input_file::read(&p)
                .map(|b| crate::digest::sha256_hex(&b))
                .unwrap_or_else(|e| format!("unreadable: {e}"));
            records.insert(p.display().to_string(), h.into());
        }
        records
    }

    /// The record files the excitation reads (acceleration or displacement), absolute.
    pub fn record_files(&self) -> Vec<PathBuf> {
        let Some(exc) = &self.excitation else {
            return Vec::new();
        };
        [exc.horizontal.as_ref(), exc.vertical.as_ref()]
            .into_iter()
            .flatten()
            .filter_map(|m| match m {
                MotionSpec::Record { file, .. } | MotionSpec::Displacement { file, .. } => {
                    let p = self.base_dir.join(file);
                    Some(std::path::absolute(&p).unwrap_or(p))
                }
                _ => None,
            })
            .collect()
    }

    /// The SHA-256 of the scene as [`Scene::to_json`] gives it (a `scene.json` written from
    /// it has the same: [`json_sha256`]).
    pub fn sha256(&self) -> String {
        json_sha256(&self.to_json())
    }
}

/// The SHA-256 of a scene's JSON value, as [`Scene::sha256`] computes it: of its compact text,
/// keys in order.
pub fn json_sha256(scene: &serde_json::Value) -> String {
    let text = serde_json::to_string(scene).expect("JSON values serialise");
    crate::digest::sha256_hex(text.as_bytes())
}
