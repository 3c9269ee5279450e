//! Engines that run in a Python worker process: `mujoco` and `pybullet`.
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

/// Names of the engines run by the Python worker.
pub const EXTERNAL_ENGINES: [&str; 2] = ["mujoco", "pybullet"];

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

    /// The worker's wall-clock limit from the scene's `<engine>.timeout`.
    pub fn timeout(&self, scene: &Scene) -> Result<Duration, EngineError> {
        let table = match self.engine {
            "mujoco" => scene.mujoco.as_ref(),
            _ => scene.pybullet.as_ref(),
        };
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
        let python = self.interpreter()?;
        let timeout = self.timeout(scene)?;
        let scene_json = dir.join("scene.json");
        let out = dir.join("out");
        let json = serde_json::to_string_pretty(&scene.to_json()).expect("scenes serialise");
        std::fs::write(&scene_json, json)
            .map_err(|e| self.failed(format!("cannot write {}: {e}", scene_json.display())))?;
        let log = |name: &str| {
            std::fs::File::create(dir.join(name))
                .map_err(|e| self.failed(format!("cannot create {}: {e}", dir.display())))
        };
        let mut cmd = Command::new(&python);
        cmd.args(["-m", "rockbench.worker", "--engine", self.engine, "--scene"])
            .arg(&scene_json)
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
            self.failed(format!(
                "cannot start the Python worker {}: {e}: run `make .venv` (or set {PYTHON_ENV})",
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
