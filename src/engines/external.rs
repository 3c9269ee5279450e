//! Engines that run in a Python worker process: `mujoco`, `pybullet` and `siconos`.
//!
//! The scene is written as JSON ([`Scene::to_json`]) into a fresh temporary directory and
//! `PYTHON -m rockbench.worker --engine E --scene scene.json --out DIR` is run there
//! (`python/rockbench/worker.py`). The worker writes `trajectory.csv` and `summary.json`; the
//! trajectory is read back with [`Trajectory::read_csv`] and the settings, version and step
//! count from the worker's summary. Events are then computed here, by
//! [`Summary::build`](crate::summary::Summary::build), as for every engine.
//!
//! With an early-stop rule ([`ExternalEngine::run_with_early_stop`], fragility studies) the
//! rule ([`crate::fragility::early::EarlyStopSpec`]) is written as JSON next to the scene and
//! passed as `--early-stop FILE`; the worker ends the run at the stop and records it and its
//! instant in the summary's `early_stop` (`{"stop": "overturned" | "at-rest" | "end", "t": s}`).
//!
//! The interpreter is `$ROCKBENCH_PYTHON`, else `./.venv/bin/python`, else the `.venv` of
//! this source tree (made by `make .venv`). The worker gets `timeout` seconds of wall time
//! (the engine table's `timeout` setting, default [`DEFAULT_TIMEOUT_S`]); past it the worker is
//! killed. A missing interpreter or package, a crash, a hang past the timeout, a NaN, or a
//! missing or truncated output file is an [`EngineError::Failed`] with a one-line reason.
//!
//! What differs between worker engines is a [`WorkerSpec`]: the interpreter's environment
//! variable and venv, and for a worker that cannot import `rockbench` (Siconos,
//! [`super::siconos`]) a standalone script, its own input and an exit code for scenes it
//! cannot model ([`EngineError::Unsupported`], skipped by the harness).

use super::{Engine, EngineError, Progress, RunOutput};

/// The exit code with which a worker refuses a setting of its table (`WorkerError(2, ...)`).
pub const SETTINGS_EXIT: i32 = 2;
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

/// A worker's input built from the scene.
pub type WorkerInput = fn(&Scene) -> Result<serde_json::Value, EngineError>;
/// A check of the table keys the harness reads.
pub type TableKeysCheck = fn(&Scene) -> Result<(), SceneError>;

/// What distinguishes one worker engine from another.
#[derive(Debug)]
pub struct WorkerSpec {
    pub engine: &'static str,
    /// Environment variable naming its interpreter.
    pub python_env: &'static str,
    /// The venv (`<venv>/bin/python`) looked for in the working directory, then in this
    /// source tree.
    pub venv: &'static str,
    /// The make target that creates the venv (for messages).
    pub make_target: &'static str,
    /// A standalone worker script, written next to its input and run as
    /// `PYTHON SCRIPT --input INPUT --out DIR --source FILE`; `None`: `python -m
    /// rockbench.worker --engine E --scene SCENE --out DIR --source FILE`.
    pub script: Option<&'static str>,
    /// The worker's input; `None`: the scene as JSON ([`Scene::to_json`]).
    pub input: Option<WorkerInput>,
    /// Checks of the table keys the harness reads itself (besides `timeout`).
    pub check: Option<TableKeysCheck>,
    /// Environment variables set for the worker.
    pub env: &'static [(&'static str, &'static str)],
    /// The names of the settings its table may give (its worker's specification, kept equal
    /// to it by a test): an unknown one is refused when the scene is checked, not at its run.
    pub settings: &'static [&'static str],
    /// The exit code by which the worker says it cannot model the scene (its stderr says why).
    pub unsupported_exit: Option<i32>,
    /// What the harness knows the worker cannot model ([`Engine::cannot_model`]).
    pub cannot_model: Option<fn(&Scene) -> Option<String>>,
}

/// MuJoCo (`python/rockbench/engines/mujoco_engine.py`).
pub static MUJOCO: WorkerSpec = WorkerSpec::rockbench_worker(
    "mujoco",
    &[
        "cone",
        "depth",
        "excitation_interval",
        "impratio",
        "integrator",
        "iterations",
        "solimp",
        "solref",
        "solver",
        "timeout",
        "timestep",
        "tolerance",
    ],
);
/// PyBullet (`python/rockbench/engines/pybullet_engine.py`).
pub static PYBULLET: WorkerSpec = WorkerSpec {
    cannot_model: Some(pybullet_cannot_model),
    ..PYBULLET_WORKER
};

const PYBULLET_WORKER: WorkerSpec = WorkerSpec::rockbench_worker(
    "pybullet",
    &[
        "contact_erp",
        "depth",
        "erp",
        "fixed_time_step",
        "friction_erp",
        "ground_friction",
        "ground_half_size",
        "lateral_friction",
        "num_solver_iterations",
        "num_sub_steps",
        "timeout",
    ],
);

/// What PyBullet's friction cannot give. It combines two bodies' coefficients as their
/// product; with `pybullet.lateral_friction` unset each block's coefficient is its interface's
/// friction over the coefficient of the body it rests on, so a block resting on friction 0 has
/// coefficient 0 (or any, when nothing on it has friction), and a friction on such a block is
/// no product.
fn pybullet_cannot_model(scene: &Scene) -> Option<String> {
    let one_coefficient = scene
        .engine_table("pybullet")
        .and_then(|t| t.get("lateral_friction"))
        .is_some_and(|v| !v.is_null());
    if one_coefficient {
        return None;
    }
    let layout = scene.layout();
    // Whether a block's coefficient is 0 (the ground's, `ground_friction`, is positive), from
    // the lowest block up: each after the one it rests on.
    let mut order: Vec<usize> = (0..scene.blocks.len()).collect();
    order.sort_by(|a, b| layout.upright[*a].1.total_cmp(&layout.upright[*b].1));
    let mut zero = vec![false; scene.blocks.len()];
    for i in order {
        let support = &layout.supports[i];
        let mu = scene.friction_between(*support, i);
        match support {
            Some(s) if zero[*s] && mu != 0.0 => {
                return Some(format!(
                    "block `{}` has friction {} on `{}`, whose own coefficient must be 0 (it rests on \
                     friction 0): PyBullet's friction is the product of two bodies' coefficients \
                     (pybullet.lateral_friction sets one coefficient for every body)",
                    scene.blocks[i].name,
                    crate::scene::num(mu),
                    scene.blocks[*s].name
                ));
            }
            Some(s) if zero[*s] => {}
            _ => zero[i] = mu == 0.0,
        }
    }
    None
}

impl WorkerSpec {
    /// An engine of `python -m rockbench.worker` in `.venv` with the settings `settings`.
    pub const fn rockbench_worker(
        engine: &'static str,
        settings: &'static [&'static str],
    ) -> WorkerSpec {
        WorkerSpec {
            engine,
            settings,
            python_env: PYTHON_ENV,
            venv: ".venv",
            make_target: ".venv",
            script: None,
            input: None,
            check: None,
            env: &[],
            unsupported_exit: None,
            cannot_model: None,
        }
    }
}

/// The table of worker engine `engine`: a table, with the keys the harness reads itself
/// checked (`timeout`, Siconos' `step`); the worker checks the rest when it runs.
pub fn check_table(scene: &Scene, engine: &str) -> Result<serde_json::Value, SceneError> {
    let table: serde_json::Map<String, serde_json::Value> = scene.parse_table(engine)?;
    if let Some(spec) = super::registry::find(engine).and_then(|e| e.worker())
        && let Some(unknown) = table.keys().find(|k| !spec.settings.contains(&k.as_str()))
    {
        return Err(SceneError::new(
            &scene.source,
            format!("{engine}.{unknown}"),
            format!("unknown setting (known: {})", spec.settings.join(", ")),
        ));
    }
    let as_scene_error = |e: EngineError| match e {
        EngineError::Scene(s) => s,
        other => SceneError::new(&scene.source, engine, other.to_string()),
    };
    if let Some(e) = ExternalEngine::new(engine) {
        e.timeout(scene).map_err(as_scene_error)?;
        if let Some(check) = e.spec.check {
            check(scene)?;
        }
    }
    Ok(serde_json::Value::Object(table))
}

/// The interpreter that runs worker engine `engine` here ([`ExternalEngine::interpreter`]), or
/// `none`: part of the keys of stored results, so that another interpreter never reuses this
/// one's runs. `None` for the engines of this program. One interpreter is one spelling
/// ([`interpreter_spelling`]).
pub fn interpreter_id(engine: &str) -> Option<String> {
    let worker = ExternalEngine::new(engine)?;
    Some(match worker.interpreter() {
        Ok(p) => interpreter_spelling(&p).display().to_string(),
        Err(_) => "none".into(),
    })
}

/// An interpreter's path spelled one way: its folder absolute with symbolic links and `..`
/// resolved, and the name `python` where that is the same file in the folder (a venv's
/// `python3`, `python3.11`). The file itself is not resolved: a venv's `bin/python` links to
/// its base Python, whose packages are others.
pub fn interpreter_spelling(python: &Path) -> PathBuf {
    let absolute = std::path::absolute(python).unwrap_or_else(|_| python.to_path_buf());
    let (Some(folder), Some(name)) = (absolute.parent(), absolute.file_name()) else {
        return absolute;
    };
    let folder = folder
        .canonicalize()
        .unwrap_or_else(|_| folder.to_path_buf());
    let (path, plain) = (folder.join(name), folder.join("python"));
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
    if path != plain && same(&path, &plain) {
        plain
    } else {
        path
    }
}

/// An engine run by `python -m rockbench.worker`.
#[derive(Debug, Clone)]
pub struct ExternalEngine {
    pub engine: &'static str,
    pub spec: &'static WorkerSpec,
    /// Interpreter to use instead of the default search (`$ROCKBENCH_PYTHON`, `.venv`).
    pub python: Option<PathBuf>,
    /// Extra environment variables for the worker.
    pub env: Vec<(String, String)>,
}

impl ExternalEngine {
    /// The worker engine named `name` in the registry.
    pub fn new(name: &str) -> Option<ExternalEngine> {
        let spec = super::registry::find(name)?.worker()?;
        Some(Self::of(spec))
    }

    /// The engine of a worker spec.
    pub fn of(spec: &'static WorkerSpec) -> ExternalEngine {
        ExternalEngine {
            engine: spec.engine,
            spec,
            python: None,
            env: Vec::new(),
        }
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

    /// The interpreter that runs the worker: the one given, else `$<python_env>`, else
    /// `./<venv>/bin/python`, else the venv of this source tree.
    pub fn interpreter(&self) -> Result<PathBuf, EngineError> {
        if let Some(p) = &self.python {
            return Ok(p.clone());
        }
        let spec = self.spec;
        if let Some(p) = std::env::var_os(spec.python_env).filter(|p| !p.is_empty()) {
            return Ok(PathBuf::from(p));
        }
        let here = Path::new(spec.venv).join("bin/python");
        if here.exists() {
            return Ok(here);
        }
        let tree = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(spec.venv)
            .join("bin/python");
        if tree.exists() {
            return Ok(tree);
        }
        Err(self.failed(format!(
            "no {}Python interpreter: neither ./{}/bin/python nor {} exists: run `make {}` \
             (or set {})",
            if spec.python_env == PYTHON_ENV {
                String::new()
            } else {
                format!("{} ", capitalised(spec.engine))
            },
            spec.venv,
            tree.display(),
            spec.make_target,
            spec.python_env
        )))
    }

    /// The scene's table of this engine's settings.
    fn table<'a>(&self, scene: &'a Scene) -> Option<&'a serde_json::Value> {
        scene.engine_table(self.engine)
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
                format!("must be a positive number of seconds below 1e9 (got {v})"),
            ))),
        }
    }

    /// Run with an early-stop rule: the worker checks it as it steps and stops there
    /// (`--early-stop FILE`); returns the output and the stop the worker recorded (`end`,
    /// `overturned`, `at-rest`; `None` from a worker that does not stop early).
    pub fn run_with_early_stop(
        &self,
        scene: &Scene,
        early_stop: &crate::fragility::early::EarlyStopSpec,
        progress: Progress,
    ) -> Result<(RunOutput, Option<String>), EngineError> {
        if self.spec.script.is_some() {
            return Err(self.failed("this worker has no early stops"));
        }
        let dir = temp_dir(self.engine)
            .map_err(|e| self.failed(format!("cannot create a temporary directory: {e}")))?;
        let value = serde_json::to_value(early_stop).expect("early-stop specs serialise");
        let result = self.run_in(scene, &dir, Some(&value), progress);
        let _ = std::fs::remove_dir_all(&dir);
        result
    }

    fn run_in(
        &self,
        scene: &Scene,
        dir: &Path,
        early_stop: Option<&serde_json::Value>,
        progress: Progress,
    ) -> Result<(RunOutput, Option<String>), EngineError> {
        let spec = self.spec;
        let input = match spec.input {
            Some(f) => Some(f(scene)?),
            None => None,
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
        if let Some(text) = spec.script {
            let script = dir.join(format!("{}_worker.py", self.engine));
            std::fs::write(&script, text)
                .map_err(|e| self.failed(format!("cannot write {}: {e}", script.display())))?;
            cmd.arg(&script).arg("--input");
        } else {
            if let Some(v) = early_stop {
                let path = dir.join("early_stop.json");
                std::fs::write(&path, v.to_string())
                    .map_err(|e| self.failed(format!("cannot write {}: {e}", path.display())))?;
                cmd.arg("-m")
                    .arg("rockbench.worker")
                    .arg("--early-stop")
                    .arg(&path);
            } else {
                cmd.args(["-m", "rockbench.worker"]);
            }
            cmd.args(["--engine", self.engine, "--scene"]);
        }
        cmd.arg(&scene_json)
            .arg("--out")
            .arg(&out)
            .arg("--source")
            .arg(&scene.source)
            .stdin(Stdio::null())
            .stdout(log("stdout.txt")?)
            .stderr(log("stderr.txt")?);
        for (k, v) in spec.env {
            cmd.env(k, v);
        }
        for (k, v) in &self.env {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().map_err(|e| {
            // Where the interpreter's path came from, so that a wrong one can be found.
            let from_env = self.python.is_none()
                && std::env::var_os(spec.python_env).is_some_and(|p| !p.is_empty());
            if from_env {
                self.failed(format!(
                    "cannot start the Python worker {} (from ${}): {e}: set {} to a Python \
                     interpreter, or unset it for ./{}/bin/python (`make {}`)",
                    python.display(),
                    spec.python_env,
                    spec.python_env,
                    spec.venv,
                    spec.make_target
                ))
            } else {
                self.failed(format!(
                    "cannot start the Python worker {}: {e}: run `make {}` (or set {})",
                    python.display(),
                    spec.make_target,
                    spec.python_env
                ))
            }
        })?;
        let start = Instant::now();
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                // The worker's simulated time is not known here: the observer is asked with
                // NaN whether the run goes on (a Ctrl-C in the Python bindings).
                Ok(None) if crate::interrupt::requested() || progress(f64::NAN).is_break() => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(EngineError::Interrupted {
                        engine: self.engine,
                        t: f64::NAN,
                    });
                }
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
        if spec.unsupported_exit.is_some() && status.code() == spec.unsupported_exit {
            return Err(EngineError::Unsupported {
                engine: self.engine,
                scene: scene.name.clone(),
                reason: one_line(stderr.trim()),
            });
        }
        if status.code() == Some(SETTINGS_EXIT)
            && let Some(e) = self.settings_error(scene, &stderr)
        {
            return Err(EngineError::Scene(e));
        }
        if !status.success() {
            return Err(self.failed(self.exit_reason(&python, status, &stderr)));
        }
        self.read_outputs(scene, &out)
    }

    /// A worker's refusal of a setting (exit code [`SETTINGS_EXIT`]), its last line on stderr
    /// `SOURCE: TABLE.FIELD: MESSAGE`, as the scene error naming that field, as a table checked
    /// at load would be (`None` for another line with that code).
    fn settings_error(&self, scene: &Scene, stderr: &str) -> Option<SceneError> {
        let last = stderr
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| !l.is_empty())?;
        let line = last
            .strip_prefix(&format!("{}: ", scene.source))
            .unwrap_or(last);
        let (field, message) = line.split_once(": ")?;
        let ours = field == self.engine || field.starts_with(&format!("{}.", self.engine));
        ours.then(|| SceneError::new(&scene.source, field, message))
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

    /// What a worker wrote to `out` (trajectory.csv, summary.json), read and checked against
    /// the scene, with the early stop the worker reports (`None`: it ran to the end): the
    /// harness after its worker process, and callers that ran the worker's code in their own
    /// Python (a study's runs in a Dask worker).
    pub fn read_outputs(
        &self,
        scene: &Scene,
        out: &Path,
    ) -> Result<(RunOutput, Option<String>), EngineError> {
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
        // A run the worker stopped early ends at the stop's instant.
        let stopped = match summary.get("early_stop") {
            None | Some(serde_json::Value::Null) => None,
            Some(v) => {
                let stop = v.get("stop").and_then(|s| s.as_str());
                let t = v.get("t").and_then(|t| t.as_f64());
                match (stop, t) {
                    (Some(s), Some(t)) if t.is_finite() => Some((s.to_string(), t)),
                    _ => {
                        return Err(self.failed(format!(
                            "worker output: {}: `early_stop` needs `stop` and `t` (got {v})",
                            path.display()
                        )));
                    }
                }
            }
        };
        let valid_until = match summary.get("model_valid_until") {
            None | Some(serde_json::Value::Null) => None,
            Some(v) => match v.as_f64() {
                Some(t) if t.is_finite() => Some(t),
                _ => {
                    return Err(self.failed(format!(
                        "worker output: {}: `model_valid_until` is not a time (got {v})",
                        path.display()
                    )));
                }
            },
        };
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
        let end = match &stopped {
            Some((s, t)) if s != "end" => *t,
            _ => scene.duration,
        };
        if last < end - 0.5 * scene.output_interval.min(end) {
            return Err(self.failed(format!(
                "worker output: the trajectory is truncated: it ends at t = {last} s of {end} s"
            )));
        }
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
        if let Some((s, t)) = &stopped
            && s != "end"
        {
            notes.push(format!("stopped early at t = {t} s: {s}"));
        }
        Ok((
            RunOutput {
                trajectory,
                settings,
                engine_version,
                steps,
                solver_iterations: None,
                exact_impacts: None,
                notes,
                valid_until,
            },
            stopped.map(|(s, _)| s),
        ))
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

fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().collect::<String>() + c.as_str())
        .unwrap_or_default()
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

    fn cannot_model(&self, scene: &Scene) -> Option<String> {
        self.spec.cannot_model.and_then(|f| f(scene))
    }

    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError> {
        let dir = temp_dir(self.engine)
            .map_err(|e| self.failed(format!("cannot create a temporary directory: {e}")))?;
        let result = self.run_in(scene, &dir, None, progress).map(|(out, _)| out);
        let _ = std::fs::remove_dir_all(&dir);
        result
    }
}
