//! Engines that run in a Python worker process: `mujoco`, `pybullet` and `siconos`.
//!
//! The scene is written as JSON ([`Scene::to_json`]) into a fresh temporary directory and
//! `PYTHON -m rockbench.worker --engine E --scene scene.json --out DIR` is run there
//! (`python/rockbench/worker.py`). The worker writes `trajectory.csv` and `summary.json`; the
//! trajectory is read back with [`Trajectory::read_csv`] and the settings, version and step
//! count from the worker's summary. Events are then computed here, by
//! [`Summary::build`](crate::summary::Summary::build), as for every engine.
//!
//! The interpreter is `$ROCKBENCH_PYTHON`, else `./.venv/bin/python`, else the `.venv` of
//! this source tree (made by `make .venv`). The worker gets `timeout` seconds of wall time
//! (the engine table's `timeout` setting, default [`DEFAULT_TIMEOUT_S`]); past it the worker is
//! killed. A missing interpreter or package, a crash, a hang past the timeout, a NaN, or a
//! missing or truncated output file is an [`EngineError::Failed`] with a one-line reason.
//!
//! Siconos (Debian's `python3-siconos`, built against numpy 1.x) cannot share the `.venv`
//! (numpy 2): it runs under its own interpreter, `$ROCKBENCH_SICONOS_PYTHON`, else
//! `./.siconos-venv/bin/python`, else the `.siconos-venv` of this source tree (made by
//! `make siconos`). Its worker, `python/rockbench/siconos_worker.py`, is a standalone script
//! (compiled into this crate and written next to the input) that imports neither `rockbench`
//! nor its extension, so what needs the Rust side is computed here and written into its input:
//! the initial layout, the supports, each interface's friction and the ground velocity at every
//! step boundary (`siconos.step`). Scenes it cannot model (walls placed by absolute `x`) are
//! [`EngineError::Unsupported`] (skipped by the harness).

use super::{Engine, EngineError, RunOutput};
use crate::scene::{Scene, SceneError};
use crate::trajectory::Trajectory;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Default wall-clock limit of one worker run, s (setting `<engine>.timeout`).
pub const DEFAULT_TIMEOUT_S: f64 = 600.0;

/// Environment variable naming the Python interpreter of the workers.
pub const PYTHON_ENV: &str = "ROCKBENCH_PYTHON";

/// Environment variable naming the interpreter of the Siconos worker.
pub const SICONOS_PYTHON_ENV: &str = "ROCKBENCH_SICONOS_PYTHON";

/// The Siconos interpreter's directory (`make siconos`), relative to the working directory or
/// the source tree.
pub const SICONOS_VENV: &str = ".siconos-venv";

/// Default `siconos.step`, s (the worker's `SETTINGS["step"]`; a test compares them).
pub const SICONOS_DEFAULT_STEP: f64 = 1e-4;

/// The Siconos worker script, written next to its input for every run.
pub const SICONOS_WORKER: &str = include_str!("../../python/rockbench/siconos_worker.py");

/// Names of the engines run by a Python worker.
pub const EXTERNAL_ENGINES: [&str; 3] = ["mujoco", "pybullet", "siconos"];

/// An engine run by `python -m rockbench.worker`.
#[derive(Debug, Clone)]
pub struct ExternalEngine {
    /// `mujoco` or `pybullet`.
    pub engine: &'static str,
    /// Interpreter to use instead of the default search (`$ROCKBENCH_PYTHON`, `.venv`).
    pub python: Option<PathBuf>,
    /// Extra environment variables for the worker.
    pub env: Vec<(String, String)>,
}

impl ExternalEngine {
    /// The engine named `name` (`mujoco` or `pybullet`).
    pub fn new(name: &str) -> Option<ExternalEngine> {
        let engine = *EXTERNAL_ENGINES.iter().find(|e| **e == name)?;
        Some(ExternalEngine {
            engine,
            python: None,
            env: Vec::new(),
        })
    }

    /// Use this interpreter.
    pub fn with_python(mut self, python: impl Into<PathBuf>) -> Self {
        self.python = Some(python.into());
        self
    }

    /// Set an environment variable for the worker.
    pub fn with_env(mut self, key: &str, value: &str) -> Self {
        self.env.push((key.to_string(), value.to_string()));
        self
    }

    fn failed(&self, message: impl Into<String>) -> EngineError {
        let m: String = message.into();
        EngineError::Failed {
            engine: self.engine,
            message: one_line(&m),
        }
    }

    /// The interpreter that runs the worker.
    pub fn interpreter(&self) -> Result<PathBuf, EngineError> {
        if let Some(p) = &self.python {
            return Ok(p.clone());
        }
        if self.engine == "siconos" {
            return self.siconos_interpreter();
        }
        if let Some(p) = std::env::var_os(PYTHON_ENV).filter(|p| !p.is_empty()) {
            return Ok(PathBuf::from(p));
        }
        let here = PathBuf::from(".venv/bin/python");
        if here.exists() {
            return Ok(here);
        }
        let tree = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
        if tree.exists() {
            return Ok(tree);
        }
        Err(self.failed(format!(
            "no Python interpreter: neither ./.venv/bin/python nor {} exists: run `make .venv` \
             (or set {PYTHON_ENV})",
            tree.display()
        )))
    }

    fn siconos_interpreter(&self) -> Result<PathBuf, EngineError> {
        if let Some(p) = std::env::var_os(SICONOS_PYTHON_ENV).filter(|p| !p.is_empty()) {
            return Ok(PathBuf::from(p));
        }
        let here = Path::new(SICONOS_VENV).join("bin/python");
        if here.exists() {
            return Ok(here);
        }
        let tree = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(SICONOS_VENV)
            .join("bin/python");
        if tree.exists() {
            return Ok(tree);
        }
        Err(self.failed(format!(
            "no Siconos interpreter: neither ./{SICONOS_VENV}/bin/python nor {} exists: run \
             `make siconos` (or set {SICONOS_PYTHON_ENV})",
            tree.display()
        )))
    }

    /// The scene's table of this engine's settings.
    fn table<'a>(&self, scene: &'a Scene) -> Option<&'a serde_json::Value> {
        match self.engine {
            "mujoco" => scene.mujoco.as_ref(),
            "siconos" => scene.siconos.as_ref(),
            _ => scene.pybullet.as_ref(),
        }
    }

    /// `siconos.step`: the step the ground motion is sampled at (the worker checks the rest).
    pub fn siconos_step(scene: &Scene) -> Result<f64, EngineError> {
        let Some(v) = scene.siconos.as_ref().and_then(|t| t.get("step")) else {
            return Ok(SICONOS_DEFAULT_STEP);
        };
        match v.as_f64() {
            Some(s) if s.is_finite() && s > 0.0 => Ok(s),
            _ => Err(EngineError::Scene(SceneError::new(
                &scene.source,
                "siconos.step",
                format!("must be a positive number (got {v})"),
            ))),
        }
    }

    /// What the Siconos worker reads: the scene and what only this crate computes.
    fn siconos_input(&self, scene: &Scene) -> Result<serde_json::Value, EngineError> {
        for b in &scene.blocks {
            if b.x.is_some() {
                return Err(EngineError::Unsupported {
                    engine: "siconos",
                    scene: scene.name.clone(),
                    reason: format!(
                        "block `{}` is placed by absolute `x` (walls): only single blocks and \
                         stacks are modelled",
                        b.name
                    ),
                });
            }
        }
        let layout = scene.layout();
        let blocks: Vec<serde_json::Value> = layout
            .blocks
            .iter()
            .map(|b| {
                serde_json::json!({
                    "x": b.x, "z": b.z, "phi": b.phi, "vx": b.vx, "vz": b.vz, "omega": b.omega
                })
            })
            .collect();
        let friction: Vec<f64> = (0..scene.blocks.len())
            .map(|i| scene.friction_below(i))
            .collect();
        let mut input = serde_json::json!({
            "scene": scene.to_json(),
            "layout": blocks,
            "supports": layout.supports,
            "friction_below": friction,
        });
        if scene.has_excitation() {
            let step = Self::siconos_step(scene)?;
            let gm =
                crate::excitation::GroundMotion::from_scene(scene).map_err(EngineError::Scene)?;
            let n = (scene.duration / step).round().max(1.0) as usize;
            let (mut vx, mut vz) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
            for k in 0..=n {
                let (a, b) = gm.vel(k as f64 * step);
                vx.push(a);
                vz.push(b);
            }
            input["ground"] = serde_json::json!({ "step": step, "vx": vx, "vz": vz });
        }
        Ok(input)
    }

    /// The worker's wall-clock limit from the scene's `<engine>.timeout`.
    pub fn timeout(&self, scene: &Scene) -> Result<Duration, EngineError> {
        let table = self.table(scene);
        let Some(v) = table.and_then(|t| t.get("timeout")) else {
            return Ok(Duration::from_secs_f64(DEFAULT_TIMEOUT_S));
        };
        match v.as_f64() {
            Some(s) if s.is_finite() && s > 0.0 && s < 1e9 => Ok(Duration::from_secs_f64(s)),
            _ => Err(EngineError::Scene(SceneError::new(
                &scene.source,
                format!("{}.timeout", self.engine),
                format!("must be a positive number of seconds (got {v})"),
            ))),
        }
    }

    fn run_in(&self, scene: &Scene, dir: &Path) -> Result<RunOutput, EngineError> {
        let siconos = self.engine == "siconos";
        let input = if siconos {
            Some(self.siconos_input(scene)?)
        } else {
            None
        };
        let python = self.interpreter()?;
        let timeout = self.timeout(scene)?;
        let scene_json = dir.join("scene.json");
        let out = dir.join("out");
        let json = match &input {
            Some(v) => serde_json::to_string(v),
            None => serde_json::to_string_pretty(&scene.to_json()),
        }
        .expect("scenes serialise");
        std::fs::write(&scene_json, json)
            .map_err(|e| self.failed(format!("cannot write {}: {e}", scene_json.display())))?;
        let log = |name: &str| {
            std::fs::File::create(dir.join(name))
                .map_err(|e| self.failed(format!("cannot create {}: {e}", dir.display())))
        };
        let mut cmd = Command::new(&python);
        if siconos {
            let script = dir.join("siconos_worker.py");
            std::fs::write(&script, SICONOS_WORKER)
                .map_err(|e| self.failed(format!("cannot write {}: {e}", script.display())))?;
            cmd.arg(&script)
                .arg("--input")
                .env("OPENBLAS_NUM_THREADS", "1");
        } else {
            cmd.args(["-m", "rockbench.worker", "--engine", self.engine, "--scene"]);
        }
        cmd.arg(&scene_json)
            .arg("--out")
            .arg(&out)
            .arg("--source")
            .arg(&scene.source)
            .stdin(Stdio::null())
            .stdout(log("stdout.txt")?)
            .stderr(log("stderr.txt")?);
        for (k, v) in &self.env {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().map_err(|e| {
            let (make, env) = if siconos {
                ("siconos", SICONOS_PYTHON_ENV)
            } else {
                (".venv", PYTHON_ENV)
            };
            self.failed(format!(
                "cannot start the Python worker {}: {e}: run `make {make}` (or set {env})",
                python.display()
            ))
        })?;
        let start = Instant::now();
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if start.elapsed() >= timeout => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(self.failed(format!(
                        "the worker did not finish within the {} s timeout and was killed \
                         (setting {}.timeout)",
                        timeout.as_secs_f64(),
                        self.engine
                    )));
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => return Err(self.failed(format!("waiting for the worker: {e}"))),
            }
        };
        let stderr = std::fs::read_to_string(dir.join("stderr.txt")).unwrap_or_default();
        if siconos && status.code() == Some(5) {
            return Err(EngineError::Unsupported {
                engine: "siconos",
                scene: scene.name.clone(),
                reason: one_line(stderr.trim()),
            });
        }
        if !status.success() {
            return Err(self.failed(self.exit_reason(&python, status, &stderr)));
        }
        self.read_outputs(scene, &out)
    }

    fn exit_reason(&self, python: &Path, status: ExitStatus, stderr: &str) -> String {
        if stderr.contains("No module named rockbench")
            || stderr.contains("No module named 'rockbench'")
        {
            return format!(
                "the Python package `rockbench` is not installed for {}: run `make .venv`",
                python.display()
            );
        }
        let last = stderr
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| !l.is_empty())
            .unwrap_or("");
        let how = match (status.code(), signal_of(status)) {
            (_, Some(sig)) => format!("the worker was killed by signal {sig}"),
            (Some(c), _) => format!("the worker exited with code {c}"),
            _ => "the worker failed".to_string(),
        };
        if last.is_empty() {
            how
        } else {
            format!("{how}: {last}")
        }
    }

    fn read_outputs(&self, scene: &Scene, out: &Path) -> Result<RunOutput, EngineError> {
        let trajectory = Trajectory::read_csv(&out.join("trajectory.csv"))
            .map_err(|e| self.failed(format!("worker output: {e}")))?;
        let names: Vec<&str> = trajectory.blocks.iter().map(|b| b.name.as_str()).collect();
        let want: Vec<&str> = scene.blocks.iter().map(|b| b.name.as_str()).collect();
        if names != want {
            return Err(self.failed(format!(
                "worker output: blocks {names:?} do not match the scene's {want:?}"
            )));
        }
        if !trajectory.is_finite() {
            return Err(self.failed("worker output: the trajectory contains NaN or infinity"));
        }
        let last = *trajectory.t.last().expect("read_csv rejects empty files");
        if last < scene.duration - 0.5 * scene.output_interval.min(scene.duration) {
            return Err(self.failed(format!(
                "worker output: the trajectory is truncated: it ends at t = {last} s of {} s",
                scene.duration
            )));
        }
        let path = out.join("summary.json");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| self.failed(format!("worker output: {}: {e}", path.display())))?;
        let summary: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| self.failed(format!("worker output: {}: {e}", path.display())))?;
        let field = |k: &str| {
            summary.get(k).ok_or_else(|| {
                self.failed(format!("worker output: {} has no `{k}`", path.display()))
            })
        };
        let engine_version = field("engine_version")?
            .as_str()
            .unwrap_or_default()
            .to_string();
        let settings = field("settings")?.clone();
        let steps = field("steps")?.as_u64().unwrap_or(0);
        let mut notes: Vec<String> = summary
            .get("notes")
            .and_then(|n| n.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|x| x.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default();
        if let Some(w) = summary.get("wall_time_s").and_then(|w| w.as_f64()) {
            notes.push(format!("worker wall time (engine only): {w:.3} s"));
        }
        if let Some(r) = summary.get("max_out_of_plane_rad").and_then(|w| w.as_f64()) {
            notes.push(format!("max out-of-plane rotation: {r:.3e} rad"));
        }
        Ok(RunOutput {
            trajectory,
            settings,
            engine_version,
            steps,
            solver_iterations: None,
            exact_impacts: None,
            notes,
        })
    }
}

#[cfg(unix)]
fn signal_of(status: ExitStatus) -> Option<i32> {
    use std::os::unix::process::ExitStatusExt;
    status.signal()
}

#[cfg(not(unix))]
fn signal_of(_: ExitStatus) -> Option<i32> {
    None
}

/// At most one line of at most 400 characters.
fn one_line(s: &str) -> String {
    let l = s.split_whitespace().collect::<Vec<_>>().join(" ");
    if l.chars().count() > 400 {
        l.chars().take(397).collect::<String>() + "..."
    } else {
        l
    }
}

/// A fresh private directory for one run.
fn temp_dir(engine: &str) -> std::io::Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "rockbench-{engine}-{}-{}-{nanos}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

impl Engine for ExternalEngine {
    fn name(&self) -> &'static str {
        self.engine
    }

    fn run(&self, scene: &Scene) -> Result<RunOutput, EngineError> {
        let dir = temp_dir(self.engine)
            .map_err(|e| self.failed(format!("cannot create a temporary directory: {e}")))?;
        let result = self.run_in(scene, &dir);
        let _ = std::fs::remove_dir_all(&dir);
        result
    }
}
