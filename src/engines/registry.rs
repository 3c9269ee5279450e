//! The engine registry: the one list of engines. Each entry says what the harness needs to
//! know of an engine: its name, how to construct it, its settings table (how the table is
//! parsed and checked, and which setting is its time step), its contract
//! ([`crate::contract`]) and whether it can run here (built in, behind a cargo feature, or a
//! Python worker whose interpreter must exist).
//!
//! The command line (`--engine`, `--engines` and their help), `compare`, `bench`, `converge`,
//! `stress`, `gate`, `validate`, `spectrum` and the Python bindings read this list; none of
//! them names an engine. Adding an engine is its module(s) and one entry here.
//!
//! The scene keeps every engine table as written ([`Scene::engines`]); [`check`] checks that
//! each table names an engine and has the engine check it, and [`load_scene`] is the scene
//! loader that does that after the scene's own checks (what the command line and the Python
//! bindings use).

use super::{Engine, EngineError, external, housner, siconos};
use crate::contract::{self, Contract};
use crate::scene::{Scene, SceneError};
use std::path::Path;

/// How an engine runs, and so what it needs to be available.
#[derive(Debug, Clone, Copy)]
pub enum RunsAs {
    /// Compiled into every build.
    BuiltIn,
    /// Compiled in with this cargo feature (on by default).
    Feature(&'static str),
    /// A Python worker process under its own interpreter.
    Worker(&'static external::WorkerSpec),
}

/// Whether an engine can run in this build on this machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Availability {
    Ready,
    /// Not compiled in: rebuild with this cargo feature.
    NotBuilt(&'static str),
    /// Compiled in but something it needs is missing (a worker's interpreter); why.
    Missing(String),
}

/// An engine's settings table.
#[derive(Debug, Clone, Copy)]
pub struct SettingsTable {
    /// The table's name in a scene (`[native]`).
    pub table: &'static str,
    /// Parse and check the scene's table (defaults for an absent one): the settings as the
    /// engine will use them, or one [`SceneError`] line naming `table.field`. Worker engines
    /// check the shape and the harness's own keys here; their worker checks the rest.
    pub check: fn(&Scene) -> Result<serde_json::Value, SceneError>,
    /// The setting that is the engine's time step (`bench`, `converge`), if it has one.
    pub step: Option<&'static str>,
}

/// One engine.
#[derive(Debug, Clone, Copy)]
pub struct EngineInfo {
    pub name: &'static str,
    /// One line for `--help`.
    pub about: &'static str,
    pub runs_as: RunsAs,
    pub settings: Option<SettingsTable>,
    /// The engine's contract (`stress`): what it promises of the invariants.
    pub contract: fn() -> Contract,
    /// Listed among the engines (`auto`, a dispatcher over two others, is not).
    pub listed: bool,
    /// In the default engine list of `rockbench stress` (every listed engine with a measured
    /// contract).
    pub stress_default: bool,
    build: fn() -> Result<Box<dyn Engine>, EngineError>,
    availability: fn() -> Availability,
}

fn ready() -> Availability {
    Availability::Ready
}

fn strict_native() -> Contract {
    contract::strict("native")
}
fn strict_housner() -> Contract {
    contract::strict("housner")
}
fn strict_auto() -> Contract {
    contract::strict("auto")
}

fn json(v: impl serde::Serialize) -> serde_json::Value {
    serde_json::to_value(v).expect("settings serialise")
}

fn worker_available(spec: &'static external::WorkerSpec) -> Availability {
    match external::ExternalEngine::of(spec).interpreter() {
        Ok(p) if p.exists() => Availability::Ready,
        Ok(p) => Availability::Missing(format!("interpreter {} not found", p.display())),
        Err(e) => Availability::Missing(e.to_string()),
    }
}

/// Every engine, in the order reports list them.
pub static ENGINES: &[EngineInfo] = &[
    EngineInfo {
        name: "native",
        about: "the paper's theta-method with a contact QP per step",
        runs_as: RunsAs::BuiltIn,
        settings: Some(SettingsTable {
            table: "native",
            check: |s| crate::native::settings_of(s).map(json),
            step: Some("native.dt"),
        }),
        contract: strict_native,
        listed: true,
        stress_default: true,
        build: || Ok(Box::new(super::native::NativeEngine)),
        availability: ready,
    },
    EngineInfo {
        name: "housner",
        about: "Housner's single block on a rigid base (analytical, RK4 with located impacts)",
        runs_as: RunsAs::BuiltIn,
        settings: Some(SettingsTable {
            table: "housner",
            check: |s| housner::HousnerSettings::of(s).map(json),
            step: None,
        }),
        contract: strict_housner,
        listed: true,
        stress_default: true,
        build: || Ok(Box::new(housner::HousnerEngine)),
        availability: ready,
    },
    EngineInfo {
        name: "rapier",
        about: "rapier2d, soft-contact game physics",
        runs_as: RunsAs::Feature("rapier"),
        settings: Some(SettingsTable {
            table: "rapier",
            check: |s| super::rapier_settings::RapierSettings::of(s).map(json),
            step: Some("rapier.dt"),
        }),
        contract: contract::rapier,
        listed: true,
        stress_default: true,
        #[cfg(feature = "rapier")]
        build: || Ok(Box::new(super::rapier::RapierEngine)),
        #[cfg(not(feature = "rapier"))]
        build: || {
            Err(EngineError::NotBuilt {
                engine: "rapier",
                feature: "rapier",
            })
        },
        #[cfg(feature = "rapier")]
        availability: ready,
        #[cfg(not(feature = "rapier"))]
        availability: || Availability::NotBuilt("rapier"),
    },
    EngineInfo {
        name: "mujoco",
        about: "MuJoCo, soft-contact robotics physics (Python worker)",
        runs_as: RunsAs::Worker(&external::MUJOCO),
        settings: Some(SettingsTable {
            table: "mujoco",
            check: |s| external::check_table(s, "mujoco"),
            step: Some("mujoco.timestep"),
        }),
        contract: contract::mujoco,
        listed: true,
        stress_default: true,
        build: || {
            Ok(Box::new(
                external::ExternalEngine::new("mujoco").expect("a worker"),
            ))
        },
        availability: || worker_available(&external::MUJOCO),
    },
    EngineInfo {
        name: "pybullet",
        about: "PyBullet, soft-contact robotics physics (Python worker)",
        runs_as: RunsAs::Worker(&external::PYBULLET),
        settings: Some(SettingsTable {
            table: "pybullet",
            check: |s| external::check_table(s, "pybullet"),
            step: Some("pybullet.fixed_time_step"),
        }),
        contract: contract::pybullet,
        listed: true,
        stress_default: true,
        build: || Ok(Box::new(external::ExternalEngine::of(&external::PYBULLET))),
        availability: || worker_available(&external::PYBULLET),
    },
    EngineInfo {
        name: "siconos",
        about: "Siconos, nonsmooth contact dynamics (Moreau-Jean, Newton impacts; Python worker)",
        runs_as: RunsAs::Worker(&siconos::WORKER),
        settings: Some(SettingsTable {
            table: "siconos",
            check: |s| external::check_table(s, "siconos"),
            step: Some("siconos.step"),
        }),
        contract: siconos::contract,
        listed: true,
        // Its quick map takes about 20 min through Python on 2 cores: `--engines siconos`.
        stress_default: false,
        build: || Ok(Box::new(external::ExternalEngine::of(&siconos::WORKER))),
        availability: || worker_available(&siconos::WORKER),
    },
    EngineInfo {
        name: "auto",
        about: "Housner for one block on the ground that does not slide, else native",
        runs_as: RunsAs::BuiltIn,
        settings: None,
        contract: strict_auto,
        listed: false,
        stress_default: false,
        build: || Ok(Box::new(super::auto::AutoEngine)),
        availability: ready,
    },
];

impl EngineInfo {
    /// Construct the engine (an error for an engine not compiled in).
    pub fn build(&self) -> Result<Box<dyn Engine>, EngineError> {
        (self.build)()
    }

    /// Whether it can run here.
    pub fn availability(&self) -> Availability {
        (self.availability)()
    }

    /// The worker spec of a worker engine.
    pub fn worker(&self) -> Option<&'static external::WorkerSpec> {
        match self.runs_as {
            RunsAs::Worker(w) => Some(w),
            _ => None,
        }
    }

    /// Compiled into this binary.
    pub fn is_built(&self) -> bool {
        match self.runs_as {
            RunsAs::Feature(_) => !matches!(self.availability(), Availability::NotBuilt(_)),
            _ => true,
        }
    }
}

/// The entry of engine `name`.
pub fn find(name: &str) -> Option<&'static EngineInfo> {
    ENGINES.iter().find(|e| e.name == name)
}

/// Check a command's engine names against the registry before anything runs: an engine this
/// build leaves out is known (its runs are reported as skipped), a misspelt one is an error
/// naming `what` (the option or field that gave it).
pub fn check_names<'a>(what: &str, names: impl IntoIterator<Item = &'a str>) -> Result<(), String> {
    let mut seen: Vec<&str> = Vec::new();
    for name in names {
        if find(name).is_none() {
            return Err(format!(
                "{what}: {}",
                EngineError::Unknown(name.to_string())
            ));
        }
        // A name given twice would be run twice and reported twice (a fit over the copies
        // claims a standard error of zero).
        if seen.contains(&name) {
            return Err(format!("{what}: {name} is given twice"));
        }
        seen.push(name);
    }
    Ok(())
}

/// The listed engines compiled into this binary, in order.
pub fn names() -> Vec<&'static str> {
    ENGINES
        .iter()
        .filter(|e| e.listed && e.is_built())
        .map(|e| e.name)
        .collect()
}

/// The engine named `name`.
pub fn engine(name: &str) -> Result<Box<dyn Engine>, EngineError> {
    match find(name) {
        Some(e) => e.build(),
        None => Err(EngineError::Unknown(name.to_string())),
    }
}

/// The contract of engine `name` (the strict one for a name not in the registry).
pub fn contract(name: &str) -> Contract {
    match find(name) {
        Some(e) => (e.contract)(),
        None => contract::strict(name),
    }
}

/// The setting that is engine `name`'s time step (`native.dt`), if it has one.
pub fn step_setting(name: &str) -> Option<&'static str> {
    find(name).and_then(|e| e.settings).and_then(|s| s.step)
}

/// The engines of `rockbench stress` without `--engines`.
pub fn stress_defaults() -> Vec<&'static str> {
    ENGINES
        .iter()
        .filter(|e| e.listed && e.is_built() && e.stress_default)
        .map(|e| e.name)
        .collect()
}

/// Every engine and whether it runs here, one per line (`--help` texts).
pub fn help() -> String {
    let mut s = String::from("Engines:");
    for e in ENGINES.iter().filter(|e| e.listed) {
        let how = match (e.runs_as, e.availability()) {
            (_, Availability::NotBuilt(f)) => format!("not built: cargo feature `{f}`"),
            (RunsAs::Worker(_), Availability::Missing(why)) => {
                format!("worker, unavailable: {why}")
            }
            (RunsAs::Worker(_), _) => "worker".to_string(),
            (_, Availability::Missing(why)) => format!("unavailable: {why}"),
            _ => "built in".to_string(),
        };
        s.push_str(&format!("\n  {:<9} {} [{how}]", e.name, e.about));
    }
    s
}

/// Check every engine table of a scene: each must name an engine, and each engine checks its
/// own (also an absent one: its defaults against the scene, e.g. `native.dt` against the
/// duration). The first problem, in registry order, as one line.
pub fn check_tables(scene: &Scene) -> Result<(), SceneError> {
    for name in scene.engines.keys() {
        if !ENGINES
            .iter()
            .any(|e| e.settings.is_some_and(|t| t.table == name))
        {
            let tables: Vec<&str> = ENGINES
                .iter()
                .filter_map(|e| e.settings.map(|t| t.table))
                .collect();
            return Err(SceneError::new(
                &scene.source,
                name.as_str(),
                format!(
                    "unknown table `{name}`: not a scene field nor an engine's settings (engines: {})",
                    tables.join(", ")
                ),
            ));
        }
    }
    // The native table first, then the scene's sample count, then the other tables: the order
    // of the checks before the tables left the scene, so a scene with several problems reports
    // the same first one (e.g. a 1e12-step `native.dt` before 1e9 samples, and 1e10 samples
    // before the Housner event tolerance that a 1e5 s duration makes too fine).
    let (first, rest): (Vec<_>, Vec<_>) = ENGINES
        .iter()
        .filter_map(|e| e.settings)
        .partition(|t| t.table == "native");
    for t in first {
        (t.check)(scene)?;
    }
    crate::scene::check_samples(scene)?;
    for t in rest {
        (t.check)(scene)?;
    }
    Ok(())
}

/// Check a scene whole: its own fields, every engine table ([`check_tables`]), its run size.
pub fn check(scene: &Scene) -> Result<(), SceneError> {
    scene.check_with(check_tables)
}

/// Every engine's settings as it would use them (defaults filled in), keyed by table.
pub fn settings(scene: &Scene) -> Result<serde_json::Map<String, serde_json::Value>, SceneError> {
    let mut m = serde_json::Map::new();
    for e in ENGINES {
        if let Some(t) = e.settings {
            m.insert(t.table.to_string(), (t.check)(scene)?);
        }
    }
    Ok(m)
}

/// Read a scene file and check it whole: the scene's fields, then every engine table.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with_overrides(path, &[])
}

/// [`load_scene`] with `key.path=value` overrides.
pub fn load_scene_with_overrides(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    crate::scene::load_scene_checked(path, overrides, Some(check_tables))
}

/// Parse scene text and check it whole, as [`load_scene_with_overrides`] does for a file.
pub fn check_scene_str(
    text: &str,
    is_json: bool,
    file: &str,
    overrides: &[String],
    base_dir: &Path,
) -> Result<Scene, SceneError> {
    crate::scene::check_scene_str_checked(
        text,
        is_json,
        file,
        overrides,
        base_dir,
        Some(check_tables),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    const BLOCK: &str =
        "name = \"s\"\nduration = 1.0\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 2.5\n";

    #[test]
    fn names_are_unique_and_every_listed_engine_builds_or_says_why() {
        let mut seen = std::collections::BTreeSet::new();
        for e in ENGINES {
            assert!(seen.insert(e.name), "{} twice", e.name);
            match e.build() {
                Ok(engine) => assert_eq!(engine.name(), e.name),
                Err(err) => assert!(matches!(err, EngineError::NotBuilt { .. }), "{err}"),
            }
            assert_eq!((e.contract)().engine, e.name);
        }
        assert!(names().contains(&"native") && !names().contains(&"auto"));
        assert_eq!(names().contains(&"rapier"), cfg!(feature = "rapier"));
    }

    #[test]
    fn engine_tables_are_checked_by_their_engine_and_unknown_tables_named() {
        let check_text = |extra: &str| {
            let s = parse_scene_str(&format!("{BLOCK}{extra}"), false, "s.toml", &[]).unwrap();
            check_tables(&s).map_err(|e| e.to_string())
        };
        check_text("").unwrap();
        check_text("[native]\ndt = 5e-4\n[housner]\nmax_step = 1e-4\n[mujoco]\ntimestep = 1e-4\n")
            .unwrap();
        let e = check_text("[native]\ntheta = 0.3\n").unwrap_err();
        assert_eq!(e, "s.toml: native.theta: must be in [0.5, 1] (got 0.3)");
        let e = check_text("[nativ]\ndt = 1e-3\n").unwrap_err();
        assert!(e.starts_with("s.toml: nativ: unknown table `nativ`"), "{e}");
        let e = check_text("[rapier]\ndt = -1.0\n").unwrap_err();
        assert!(
            e.starts_with("s.toml: rapier.dt: must be a positive number"),
            "{e}"
        );
        let e = check_text("[housner]\nrestitution = 2.0\n").unwrap_err();
        assert_eq!(e, "s.toml: housner.restitution: must be in [0, 1] (got 2)");
    }

    #[test]
    fn step_settings_name_a_setting_of_their_own_table() {
        for e in ENGINES {
            if let Some(t) = e.settings
                && let Some(step) = t.step
            {
                assert!(step.starts_with(&format!("{}.", t.table)), "{step}");
            }
        }
        assert_eq!(step_setting("native"), Some("native.dt"));
        assert_eq!(step_setting("housner"), None);
    }
}
