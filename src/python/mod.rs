//! Python bindings (`rockbench._native`, feature `python`): thin wrappers over the crate.
//!
//! - `load_scene(path | dict, overrides=())` reads and checks a scene; a bad scene raises
//!   `ValueError` with the one-line [`SceneError`](crate::scene::SceneError) message.
//! - `run(scene, engine="native", overrides=())` runs any engine of
//!   [`engine_by_name`](crate::engines::engine_by_name) with the GIL released and returns a
//!   `Run`: sample times and per-block histories as numpy arrays, and the summary as a dict.
//!   A failed run raises `RuntimeError` with the engine's one-line reason. Called from the
//!   main thread, a Ctrl-C stops the native and rapier engines within [`SIGNAL_CHECK`] and a
//!   step, kills an external engine's worker (MuJoCo, PyBullet, Siconos) within another 20 ms,
//!   and raises `KeyboardInterrupt`; Housner's closed form finishes first. `compare_rows` is
//!   stopped the same way, and `fragility_study` starts no further run and stops those under
//!   way (the runs finished are in its cache).
//! - `Scene.layout()` and `Scene.ground_motion(t)` expose the crate's single definitions of the
//!   initial configuration and of the ground motion to the Python engines.
//!
//! The public Python package `rockbench` re-exports these names; the stubs are
//! `python/rockbench/_native.pyi`.

mod convert;

use crate::engines::{EngineError, engine_by_name, registry, run_timed_reporting};
use crate::excitation::GroundMotion;
use crate::scene::{self, Scene as CoreScene};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::Duration;

/// How often a run started from Python's main thread looks for a Ctrl-C.
pub const SIGNAL_CHECK: Duration = Duration::from_millis(50);

/// Run `work` with the GIL released. Called from Python's main thread (the only one on which
/// Python runs signal handlers), `work` runs on a thread of its own while this one looks for a
/// Ctrl-C every [`SIGNAL_CHECK`]; on one, `stop` is set, `work` is waited for (its runs see the
/// flag and end) and the `KeyboardInterrupt` is raised instead of its result.
fn interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&Arc<AtomicBool>) -> T + Send,
) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    let threading = py.import("threading")?;
    let on_main_thread = threading
        .call_method0("current_thread")?
        .is(&threading.call_method0("main_thread")?);
    if !on_main_thread {
        return Ok(py.detach(|| work(&stop)));
    }
    let (done, mut result) = mpsc::channel();
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("rockbench-run".into())
            // The main thread's size: a run has the stack it has from the command line.
            .stack_size(8 << 20)
            .spawn_scoped(s, || {
                let _ = done.send(work(&stop));
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the run's thread: {e}")))?;
        loop {
            // The receiver goes to the detached waiting and back (it is not `Sync`).
            let (received, back) = py.detach(move || (result.recv_timeout(SIGNAL_CHECK), result));
            result = back;
            match received {
                // A Ctrl-C that came as the work ended is raised too.
                Ok(value) => return py.check_signals().map(|()| value),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Err(interrupt) = py.check_signals() {
                        stop.store(true, Ordering::Relaxed);
                        let _ = py.detach(move || result.recv());
                        return Err(interrupt);
                    }
                }
                // The work panicked: the scope's end raises it.
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err(
                        "the run's thread ended without a result",
                    ));
                }
            }
        }
    })
}

/// A run's observer that stops it once `stop` is set.
fn until(stop: &AtomicBool) -> ControlFlow<()> {
    if stop.load(Ordering::Relaxed) {
        ControlFlow::Break(())
    } else {
        ControlFlow::Continue(())
    }
}

/// A checked scene.
#[pyclass(frozen, module = "rockbench._native", name = "Scene")]
pub struct PyScene {
    inner: CoreScene,
}

#[pymethods]
impl PyScene {
    /// Scene name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// Simulated duration, s.
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.duration
    }

    /// Interval between trajectory samples, s.
    #[getter]
    fn output_interval(&self) -> f64 {
        self.inner.output_interval
    }

    /// Gravitational acceleration, m/s^2.
    #[getter]
    fn gravity(&self) -> f64 {
        self.inner.gravity
    }

    /// Block names, bottom to top.
    #[getter]
    fn block_names(&self) -> Vec<String> {
        self.inner.blocks.iter().map(|b| b.name.clone()).collect()
    }

    /// The file the scene was read from (`<dict>` for a scene given as a dict).
    #[getter]
    fn source(&self) -> String {
        self.inner.source.clone()
    }

    /// The scene as a dict (record paths made absolute): the form handed to external engines.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.inner.to_json())
    }

    /// The scene as a JSON string (same content as `to_dict`).
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(&self.inner.to_json()).expect("scenes serialise")
    }

    /// Initial state of every block: dicts with `name`, `support` (name or None), `x`, `z`,
    /// `phi`, `vx`, `vz`, `omega` (centroid, SI units, rotation counter-clockwise).
    fn layout<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let layout = self.inner.layout();
        let list = PyList::empty(py);
        for (i, (b, s)) in self.inner.blocks.iter().zip(&layout.blocks).enumerate() {
            let d = PyDict::new(py);
            d.set_item("name", &b.name)?;
            d.set_item(
                "support",
                layout.supports[i].map(|j| self.inner.blocks[j].name.clone()),
            )?;
            for (k, v) in [
                ("x", s.x),
                ("z", s.z),
                ("phi", s.phi),
                ("vx", s.vx),
                ("vz", s.vz),
                ("omega", s.omega),
            ] {
                d.set_item(k, v)?;
            }
            list.append(d)?;
        }
        Ok(list)
    }

    /// Friction coefficient of a contact between `lower` (a block index, or None for the
    /// ground) and block `upper`: `upper`'s interface friction below, whichever body below it
    /// touches (the scene's contact law).
    #[pyo3(signature = (lower, upper))]
    fn friction_between(&self, lower: Option<usize>, upper: usize) -> PyResult<f64> {
        let n = self.inner.blocks.len();
        if upper >= n || lower.is_some_and(|l| l >= n) {
            return Err(PyValueError::new_err(format!(
                "block index out of range (the scene has {n} blocks)"
            )));
        }
        if lower == Some(upper) {
            return Err(PyValueError::new_err(format!(
                "friction_between: block {upper} cannot touch itself"
            )));
        }
        Ok(self.inner.friction_between(lower, upper))
    }

    /// Ground motion at the times `t` (a number or a 1-D sequence of them, s): a dict of
    /// arrays `ax`, `az` (m/s^2), `vx`, `vz` (m/s), `dx`, `dz` (m), from the same definitions
    /// the Rust engines use (zero without excitation). A time that is not finite, or not a
    /// real number, is a `ValueError`.
    fn ground_motion<'py>(
        &self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let gm = GroundMotion::from_scene(&self.inner)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let numpy = py.import("numpy")?;
        // Real numbers only: NumPy would drop a complex time's imaginary part and read
        // booleans as 0 and 1.
        let kind: String = numpy
            .call_method1("asarray", (t,))?
            .getattr("dtype")?
            .getattr("kind")?
            .extract()?;
        if !matches!(kind.as_str(), "f" | "i" | "u") {
            return Err(PyValueError::new_err(format!(
                "ground_motion: t must be real numbers of seconds (got an array of NumPy kind '{kind}')"
            )));
        }
        // At least 1-D, contiguous float64 (a number becomes one time).
        let t = numpy.call_method1("ascontiguousarray", (t, "float64"))?;
        let ndim: usize = t.getattr("ndim")?.extract()?;
        if ndim != 1 {
            return Err(PyValueError::new_err(format!(
                "ground_motion: t must be a number or a 1-D sequence of times (got {ndim} dimensions)"
            )));
        }
        let t: PyReadonlyArray1<'py, f64> = t.extract()?;
        let t = t.as_slice()?;
        if let Some(k) = t.iter().position(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "ground_motion: t[{k}] = {} is not a finite time",
                t[k]
            )));
        }
        let mut cols: [Vec<f64>; 6] = Default::default();
        for &ti in t {
            let (ax, az) = gm.acc(ti);
            let (vx, vz) = gm.vel(ti);
            let (dx, dz) = gm.disp(ti);
            for (c, v) in cols.iter_mut().zip([ax, az, vx, vz, dx, dz]) {
                c.push(v);
            }
        }
        let d = PyDict::new(py);
        for (k, c) in ["ax", "az", "vx", "vz", "dx", "dz"].into_iter().zip(cols) {
            d.set_item(k, PyArray1::from_vec(py, c))?;
        }
        Ok(d)
    }

    /// Instants where the ground acceleration is not smooth, sorted.
    fn excitation_breakpoints(&self) -> PyResult<Vec<f64>> {
        let gm = GroundMotion::from_scene(&self.inner)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(gm.breakpoints())
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(name={:?}, blocks={:?}, duration={})",
            self.inner.name,
            self.block_names(),
            self.inner.duration
        )
    }
}

/// The result of one engine run.
#[pyclass(frozen, module = "rockbench._native", name = "Run")]
pub struct PyRun {
    /// Engine name.
    #[pyo3(get)]
    engine: String,
    /// Sample times, s.
    #[pyo3(get)]
    t: Py<PyArray1<f64>>,
    /// Per block name: dict of arrays `x`, `z`, `phi`, `vx`, `vz`, `omega`.
    #[pyo3(get)]
    blocks: Py<PyDict>,
    /// The run's summary.json content.
    #[pyo3(get)]
    summary: Py<PyAny>,
}

#[pymethods]
impl PyRun {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Run(engine={:?}, samples={}, blocks={:?})",
            self.engine,
            self.t.bind(py).len().unwrap_or_default(),
            self.blocks
                .bind(py)
                .keys()
                .iter()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
        )
    }
}

/// The first float of a scene dict that is not finite: its field (`a.b[2].c`) and value.
fn non_finite(obj: &Bound<'_, PyAny>, at: String) -> Option<(String, f64)> {
    let join = |key: String| {
        if at.is_empty() {
            key
        } else {
            format!("{at}.{key}")
        }
    };
    if let Ok(d) = obj.cast::<PyDict>() {
        return d
            .iter()
            .find_map(|(k, v)| non_finite(&v, join(k.str().ok()?.to_string())));
    }
    if let Ok(l) = obj.cast::<pyo3::types::PyList>() {
        return l
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(&v, format!("{at}[{i}]")));
    }
    if let Ok(f) = obj.cast::<pyo3::types::PyFloat>() {
        let x = f.value();
        return (!x.is_finite()).then_some((at, x));
    }
    None
}

/// A scene from a path (str or os.PathLike) or a dict (same fields as the TOML file).
fn scene_from(obj: &Bound<'_, PyAny>, overrides: &[String]) -> PyResult<CoreScene> {
    if let Ok(s) = obj.cast::<PyScene>() {
        if !overrides.is_empty() {
            return Err(PyValueError::new_err(
                "overrides apply to a scene file or dict, not to a loaded Scene",
            ));
        }
        return Ok(s.get().inner.clone());
    }
    let err = |e: scene::SceneError| PyValueError::new_err(e.to_string());
    if obj.cast::<PyDict>().is_ok() {
        let py = obj.py();
        let json_module = py.import("json")?;
        // NumPy scalars and arrays as their Python values; Python's encoder refuses cycles and
        // nesting deeper than its recursion limit.
        let as_python = pyo3::types::PyCFunction::new_closure(
            py,
            None,
            None,
            |args: &Bound<'_, pyo3::types::PyTuple>,
             _kwargs: Option<&Bound<'_, PyDict>>|
             -> PyResult<Py<PyAny>> {
                let o = args.get_item(0)?;
                if o.hasattr("tolist")? {
                    return Ok(o.call_method0("tolist")?.unbind());
                }
                Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "Object of type {} is not JSON serializable",
                    o.get_type().name()?
                )))
            },
        )?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("default", as_python)?;
        let json: String = json_module
            .call_method("dumps", (obj,), Some(&kwargs))
            .map_err(|e| PyValueError::new_err(format!("<dict>: (file): not JSON data: {e}")))?
            .extract()?;
        // JSON has no NaN or infinity: named here, as a scene file names them.
        let plain = json_module.call_method1("loads", (&json,))?;
        if let Some((field, x)) = non_finite(&plain, String::new()) {
            return Err(PyValueError::new_err(format!(
                "<dict>: {field}: must be a finite number (got {x})"
            )));
        }
        let s = scene::parse_scene_str(&json, true, "<dict>", overrides).map_err(err)?;
        crate::engines::registry::check(&s).map_err(err)?;
        return Ok(s);
    }
    let path: PathBuf = obj.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "a scene is a path (str or os.PathLike), a dict or a Scene, not {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })?;
    crate::engines::registry::load_scene_with_overrides(&path, overrides).map_err(err)
}

/// Read and check a scene.
#[pyfunction]
#[pyo3(signature = (source, overrides = Vec::new()))]
fn load_scene(source: &Bound<'_, PyAny>, overrides: Vec<String>) -> PyResult<PyScene> {
    Ok(PyScene {
        inner: scene_from(source, &overrides)?,
    })
}

/// Run an engine on a scene, with the GIL released during the run.
#[pyfunction]
#[pyo3(signature = (scene, engine = "native", overrides = Vec::new()))]
fn run(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    engine: &str,
    overrides: Vec<String>,
) -> PyResult<PyRun> {
    let scene = scene_from(scene, &overrides)?;
    let eng = engine_by_name(engine).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let result = interruptible(py, |stop| {
        run_timed_reporting(eng.as_ref(), &scene, &|_t| until(stop))
    })?;
    let (out, summary) = result.map_err(|e| match e {
        EngineError::Failed { .. } | EngineError::Io(_) => PyRuntimeError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    })?;
    let blocks = PyDict::new(py);
    for b in out.trajectory.blocks {
        let d = PyDict::new(py);
        for (k, v) in [
            ("x", b.x),
            ("z", b.z),
            ("phi", b.phi),
            ("vx", b.vx),
            ("vz", b.vz),
            ("omega", b.omega),
        ] {
            d.set_item(k, PyArray1::from_vec(py, v))?;
        }
        blocks.set_item(b.name, d)?;
    }
    let summary = serde_json::to_value(&summary).expect("summaries serialise");
    Ok(PyRun {
        engine: engine.to_string(),
        t: PyArray1::from_vec(py, out.trajectory.t).unbind(),
        blocks: blocks.unbind(),
        summary: convert::json_to_py(py, &summary)?.unbind(),
    })
}

/// Run engines on a scene and compare them with a reference (an engine name or a
/// trajectory.csv path): the metric rows of `rockbench compare` as a list of dicts (scene,
/// engine, block, metric, value, reference, unit), plus each engine's status. GIL released.
#[pyfunction]
#[pyo3(signature = (scene, engines, reference = "native", overrides = Vec::new()))]
fn compare_rows(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    engines: Vec<String>,
    reference: &str,
    overrides: Vec<String>,
) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
    let scene = scene_from(scene, &overrides)?;
    let opts = crate::compare::CompareOptions::new(
        engines,
        crate::compare::ReferenceSpec::parse(reference),
    );
    let c = interruptible(py, |stop| {
        let runner = |name: &str, scene: &CoreScene| {
            crate::compare::run_engine_reporting(name, scene, &|_t| until(stop))
        };
        crate::compare::compare_with_runner(&scene, &opts, &runner)
    })?
    .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let rows = serde_json::to_value(&c.rows).expect("metric rows serialise");
    let status: serde_json::Map<String, serde_json::Value> = c
        .runs
        .iter()
        .map(|r| {
            let word = r.status.word();
            let text = match r.status.reason() {
                Some(why) => format!("{word}: {why}"),
                None => word.to_string(),
            };
            (r.engine.clone(), serde_json::Value::String(text))
        })
        .collect();
    Ok((
        convert::json_to_py(py, &rows)?.unbind(),
        convert::json_to_py(py, &serde_json::Value::Object(status))?.unbind(),
    ))
}

fn load_study(study: &std::path::Path) -> PyResult<crate::fragility::study::Study> {
    crate::fragility::study::load_study(study).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// A run cache folder given to a function: an empty path is refused (it would be the working
/// directory, filled with run files).
fn cache_path(function: &str, cache: PathBuf) -> PyResult<PathBuf> {
    if cache.as_os_str().is_empty() {
        return Err(PyValueError::new_err(format!(
            "{function}: cache: an empty path (name the run cache folder)"
        )));
    }
    Ok(cache)
}

/// A fragility study (`rockbench fragility`): read and check STUDY.toml, run it (GIL
/// released; cached runs reused) and return fragility.json as a dict; with `out`, also write
/// the outputs there; with `cache`, use that run cache instead of the study's. `command`: how
/// the study was run, as its outputs record it (the Python call or command line, a cluster
/// and the runs its workers made); default this call.
#[pyfunction]
#[pyo3(signature = (study, out = None, quiet = true, cache = None, command = None))]
fn fragility_study(
    py: Python<'_>,
    study: PathBuf,
    out: Option<PathBuf>,
    quiet: bool,
    cache: Option<PathBuf>,
    command: Option<String>,
) -> PyResult<Py<PyAny>> {
    let mut st = load_study(&study)?;
    if let Some(c) = cache {
        st.cache_dir = cache_path("fragility_study", c)?;
    }
    if let Some(dir) = &out {
        crate::fragility::report::replaceable_out(dir).map_err(PyValueError::new_err)?;
    }
    let res = interruptible(py, |stop| {
        crate::fragility::run_study_stopped_by(&st, quiet, stop.clone())
    })?
    .map_err(PyRuntimeError::new_err)?;
    let command = command
        .unwrap_or_else(|| format!("rockbench._native.fragility_study({})", study.display()));
    if let Some(dir) = out {
        crate::fragility::report::write_all(&dir, &st, &res, &command, false)
            .map_err(PyRuntimeError::new_err)?;
    }
    let j = crate::fragility::report::json(&st, &res, &command);
    Ok(convert::json_to_py(py, &j)?.unbind())
}

/// The run cache folder of a study (as the study file sets it, made absolute).
#[pyfunction]
fn fragility_cache_dir(study: PathBuf) -> PyResult<String> {
    let st = load_study(&study)?;
    std::path::absolute(&st.cache_dir)
        .map(|p| p.display().to_string())
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The IDA jobs of a study: `[(scene_index, engine, record_id), ...]` in the study's order
/// (empty without `[ida]`).
#[pyfunction]
fn fragility_ida_jobs(study: PathBuf) -> PyResult<Vec<(usize, String, String)>> {
    Ok(crate::fragility::ida_jobs(&load_study(&study)?))
}

/// Runs made, runs found in the cache, and every run given (made or found) as
/// `(key, outcome_json)`.
type IdaBatch = (usize, usize, Vec<(String, String)>);

/// Run the IDA jobs `jobs` of a study through the run cache `cache` (GIL released): finished
/// runs are read, missing ones run and stored. Returns `(made, cached, [(key, outcome_json),
/// ...])`: the run counts and every run the hunt used, made or read (the client's store may
/// lack those this cache held).
#[pyfunction]
fn fragility_ida_batch(
    py: Python<'_>,
    study: PathBuf,
    jobs: Vec<(usize, String, String)>,
    cache: PathBuf,
) -> PyResult<IdaBatch> {
    let st = load_study(&study)?;
    let cache = cache_path("fragility_ida_batch", cache)?;
    crate::fragility::check_ida_jobs(&st, &jobs)
        .map_err(|e| PyValueError::new_err(format!("fragility_ida_batch: {e}")))?;
    py.detach(|| -> Result<_, String> {
        let runner = crate::fragility::Runner::new(cache, true);
        crate::fragility::run_ida_jobs(&st, &runner, &jobs)?;
        let runs = runner
            .runs()
            .into_iter()
            .map(|(k, o)| (k, serde_json::to_string(&o).expect("outcomes serialise")))
            .collect();
        Ok((
            runner.made(),
            runner.cached.load(std::sync::atomic::Ordering::Relaxed),
            runs,
        ))
    })
    .map_err(PyRuntimeError::new_err)
}

/// Store outcomes `[(key, outcome_json), ...]` (as tasks return them) in the run cache `cache`
/// where it has no entry yet (atomically, as every run is stored). Returns how many were new.
#[pyfunction]
fn fragility_store(cache: PathBuf, runs: Vec<(String, String)>) -> PyResult<usize> {
    let cache = cache_path("fragility_store", cache)?;
    let mut new = 0;
    for (key, text) in runs {
        if !crate::run_store::is_key(&key) {
            return Err(PyValueError::new_err(format!("not a run key: {key:?}")));
        }
        let o: crate::fragility::run::RunOutcome = serde_json::from_str(&text)
            .map_err(|e| PyValueError::new_err(format!("run {key}: outcome: {e}")))?;
        o.check()
            .map_err(|e| PyValueError::new_err(format!("run {key}: outcome: {e}")))?;
        if crate::run_store::load::<crate::fragility::run::RunOutcome>(&cache, &key).is_none() {
            crate::run_store::store(&cache, &key, &o).map_err(PyRuntimeError::new_err)?;
            new += 1;
        }
    }
    Ok(new)
}

/// Run the runs `specs` (JSON specs of `fragility_run_specs`) one after the other through the
/// run cache `cache` (GIL released): a run whose outcome is stored is not run again.
/// Returns `[(key, made, outcome_json), ...]` (`made` false for a run found in the cache).
#[pyfunction]
fn fragility_run_batch(
    py: Python<'_>,
    specs: Vec<String>,
    cache: PathBuf,
) -> PyResult<Vec<(String, bool, String)>> {
    let specs: Vec<crate::fragility::run::RunSpec> = specs
        .iter()
        .map(|s| serde_json::from_str(s))
        .collect::<Result<_, _>>()
        .map_err(|e| PyValueError::new_err(format!("spec: {e}")))?;
    let cache = cache_path("fragility_run_batch", cache)?;
    py.detach(|| {
        let runner = crate::fragility::Runner::new(cache, true);
        specs
            .iter()
            .map(|s| {
                let (o, cached) = runner.get(s)?;
                let text = serde_json::to_string(&o).expect("outcomes serialise");
                Ok((s.key(), !cached, text))
            })
            .collect::<Result<Vec<_>, String>>()
    })
    .map_err(PyRuntimeError::new_err)
}

/// Which of the runs `keys` (content hashes) have an outcome in the run cache `cache`.
#[pyfunction]
fn fragility_cache_has(py: Python<'_>, cache: PathBuf, keys: Vec<String>) -> PyResult<Vec<bool>> {
    let cache = cache_path("fragility_cache_has", cache)?;
    Ok(py.detach(|| {
        keys.iter()
            .map(|k| {
                crate::run_store::load::<crate::fragility::run::RunOutcome>(&cache, k).is_some()
            })
            .collect()
    }))
}

/// Whether runs of `engine` are Python worker runs (MuJoCo, PyBullet), which a Dask worker
/// runs in its own Python (`rockbench.worker.run`) instead of a worker process per run. An
/// engine name the registry does not know is a `ValueError`.
#[pyfunction]
fn fragility_is_python_worker(engine: &str) -> PyResult<bool> {
    crate::fragility::run::check_engine(engine)
        .map_err(|e| PyValueError::new_err(format!("fragility_is_python_worker: {e}")))?;
    Ok(crate::fragility::run::is_python_worker(engine))
}

/// The scene of a run spec as the JSON a Python worker reads (`Scene::to_json`).
#[pyfunction]
fn fragility_worker_scene(spec: &str) -> PyResult<String> {
    let spec = parse_spec(spec)?;
    Ok(serde_json::to_string_pretty(&spec.scene.to_json()).expect("scenes serialise"))
}

/// The early-stop rule of a Python worker run as JSON (the file `python -m rockbench.worker
/// --early-stop` reads), or None when the run goes to its end.
#[pyfunction]
fn fragility_worker_early_stop(spec: &str) -> PyResult<Option<String>> {
    let spec = parse_spec(spec)?;
    let rule = crate::fragility::run::worker_early_stop(&spec)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(rule.map(|r| serde_json::to_string(&r).expect("early-stop rules serialise")))
}

/// Finish a Python worker run: read the outputs the worker code wrote to `out_dir`, make the
/// outcome as a run of the harness does, store it in the run cache `cache` and return it as
/// JSON.
#[pyfunction]
fn fragility_worker_outcome(
    spec: &str,
    out_dir: PathBuf,
    wall_s: f64,
    cache: PathBuf,
) -> PyResult<String> {
    let spec = parse_spec(spec)?;
    let cache = cache_path("fragility_worker_outcome", cache)?;
    let o = crate::fragility::run::outcome_from_worker_output(&spec, &out_dir, wall_s)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    crate::run_store::store(&cache, &spec.key(), &o).map_err(PyRuntimeError::new_err)?;
    Ok(serde_json::to_string(&o).expect("outcomes serialise"))
}

fn parse_spec(spec: &str) -> PyResult<crate::fragility::run::RunSpec> {
    serde_json::from_str(spec).map_err(|e| PyValueError::new_err(format!("spec: {e}")))
}

/// The stripes' runs of a study as JSON strings (the serialisable unit of work) with their
/// cache keys: `[(key, spec_json), ...]`.
#[pyfunction]
fn fragility_run_specs(study: PathBuf) -> PyResult<Vec<(String, String)>> {
    let st = load_study(&study)?;
    Ok(crate::fragility::stripe_specs(&st)
        .iter()
        .map(|s| (s.key(), serde_json::to_string(s).expect("specs serialise")))
        .collect())
}

/// One run of a study from its JSON spec (see `fragility_run_specs`): the outcome as JSON.
/// GIL released.
#[pyfunction]
fn fragility_run(py: Python<'_>, spec: &str) -> PyResult<String> {
    let spec = parse_spec(spec)?;
    let o = py
        .detach(|| crate::fragility::run::run_one(&spec))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(serde_json::to_string(&o).expect("outcomes serialise"))
}

/// Names of the engines `run` accepts.
#[pyfunction]
fn engine_names() -> Vec<&'static str> {
    registry::names()
}

/// Refuse an empty or unknown engine name with `ValueError` (`what: unknown engine ...`), as
/// the command line refuses them before any run.
#[pyfunction]
fn check_engine_names(what: &str, names: Vec<String>) -> PyResult<()> {
    if names.is_empty() {
        return Err(PyValueError::new_err(format!(
            "{what}: name at least one engine"
        )));
    }
    registry::check_names(what, names.iter().map(String::as_str)).map_err(PyValueError::new_err)
}

/// The folder a study writes its outputs to, checked before the study runs as the command line
/// checks it (`fragility::report::check_study_out`): `ValueError` naming it, else it made
/// absolute.
#[pyfunction]
fn check_study_out(out: PathBuf, cache: PathBuf) -> PyResult<String> {
    crate::fragility::report::check_study_out(&out, &cache)
        .map(|p| p.display().to_string())
        .map_err(PyValueError::new_err)
}

#[pymodule]
#[pyo3(name = "_native")]
fn native_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Load NumPy's C API now: loaded on first use instead, it imports NumPy, and a Ctrl-C that
    // arrives during that import turns into a panic of the numpy crate.
    PyArray1::<f64>::zeros(m.py(), 0, false);
    m.add("__version__", crate::build_info::VERSION)?;
    m.add("__git_commit__", crate::build_info::GIT_COMMIT)?;
    m.add("__source_hash__", crate::build_info::SOURCE_HASH)?;
    m.add_class::<PyScene>()?;
    m.add_class::<PyRun>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(engine_names, m)?)?;
    m.add_function(wrap_pyfunction!(check_engine_names, m)?)?;
    m.add_function(wrap_pyfunction!(check_study_out, m)?)?;
    m.add(
        "OUTCOME_COLUMNS",
        crate::fragility::report::OUTCOME_COLUMNS.to_vec(),
    )?;
    m.add_function(wrap_pyfunction!(compare_rows, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_study, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_run_specs, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_run, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_cache_dir, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_ida_jobs, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_ida_batch, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_run_batch, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_store, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_cache_has, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_is_python_worker, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_worker_scene, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_worker_early_stop, m)?)?;
    m.add_function(wrap_pyfunction!(fragility_worker_outcome, m)?)?;
    Ok(())
}
