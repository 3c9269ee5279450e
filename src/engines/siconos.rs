//! The Siconos engine (INRIA's nonsmooth contact dynamics: Moreau-Jean time stepping, Newton
//! impact law, Coulomb friction), run as a worker (see [`super::external`] for how workers
//! run and fail, `docs/engines-siconos.md` for the model and its settings).
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

use super::EngineError;
use super::external::WorkerSpec;
use crate::contract::{Contract, soft};
use crate::scene::{Scene, SceneError};

/// Environment variable naming the interpreter of the Siconos worker.
pub const PYTHON_ENV: &str = "ROCKBENCH_SICONOS_PYTHON";

/// The Siconos interpreter's directory (`make siconos`), relative to the working directory or
/// the source tree.
pub const VENV: &str = ".siconos-venv";

/// Default `siconos.step`, s (the worker's `SETTINGS["step"]`; a test compares them).
pub const DEFAULT_STEP: f64 = 1e-4;

/// The Siconos worker script, written next to its input for every run.
pub const WORKER_SCRIPT: &str = include_str!("../../python/rockbench/siconos_worker.py");

/// How the harness runs the worker.
pub static WORKER: WorkerSpec = WorkerSpec {
    engine: "siconos",
    python_env: PYTHON_ENV,
    venv: VENV,
    make_target: "siconos",
    script: Some(WORKER_SCRIPT),
    input: Some(input),
    check: Some(|s| step(s).map(|_| ()).map_err(scene_error)),
    // One BLAS thread: the problems are tiny and threads only contend on 2 cores.
    env: &[("OPENBLAS_NUM_THREADS", "1")],
    settings: &[
        "iterations",
        "restitution",
        "scheme",
        "solver",
        "step",
        "theta",
        "timeout",
        "tolerance",
    ],
    unsupported_exit: Some(5),
    cannot_model: Some(cannot_model),
};

/// Walls (blocks placed by absolute `x`) are beyond the worker: it models single blocks and
/// stacks.
fn cannot_model(scene: &Scene) -> Option<String> {
    scene.blocks.iter().find(|b| b.x.is_some()).map(|b| {
        format!(
            "block `{}` is placed by absolute `x` (walls): only single blocks and stacks are modelled",
            b.name
        )
    })
}

fn scene_error(e: EngineError) -> SceneError {
    match e {
        EngineError::Scene(s) => s,
        other => SceneError::new("", "siconos", other.to_string()),
    }
}

/// `siconos.step`: the step the ground motion is sampled at (the worker checks the rest).
pub fn step(scene: &Scene) -> Result<f64, EngineError> {
    let Some(v) = scene.engine_table("siconos").and_then(|t| t.get("step")) else {
        return Ok(DEFAULT_STEP);
    };
    match v.as_f64() {
        Some(s) if s.is_finite() && s > 0.0 => {
            crate::scene::check_step(scene, "siconos.step", s)?;
            Ok(s)
        }
        _ => Err(EngineError::Scene(SceneError::new(
            &scene.source,
            "siconos.step",
            format!("must be a positive number (got {v})"),
        ))),
    }
}

/// What the Siconos worker reads: the scene and what only this crate computes.
pub fn input(scene: &Scene) -> Result<serde_json::Value, EngineError> {
    if let Some(reason) = cannot_model(scene) {
        return Err(EngineError::Unsupported {
            engine: "siconos",
            scene: scene.name.clone(),
            reason,
        });
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
        let step = step(scene)?;
        let gm = crate::excitation::GroundMotion::from_scene(scene).map_err(EngineError::Scene)?;
        // The ground velocity at the worker's step ends, the shorter last one included.
        let ends = super::RunSteps::new(scene.duration, step);
        let (vx, vz): (Vec<f64>, Vec<f64>) = ends.ends().map(|t| gm.vel(t)).unzip();
        input["ground"] = serde_json::json!({ "step": step, "vx": vx, "vz": vz });
    }
    Ok(input)
}

/// Siconos' contract, measured with `rockbench stress --quick --engines siconos` on
/// 2026-11-23 (rockbench 0.1.0, python3-siconos 4.4.0, defaults: Moreau-Jean theta 0.5 with
/// projection, step 1e-4 s, e = 0, NSGS 1e-12). Contacts are hard, so penetration stays at
/// round-off; the projection step and the solver tolerance leave an energy growth at impacts
/// and a mirror asymmetry (NSGS visits the contacts in order). The column of 20 bricks timed
/// out (600 s through the Python relations on loaded shared cores) and an overturned block
/// falls through the ground (the worker models the base corners only): both are listed in
/// `validation/stress-known.toml`.
pub fn contract() -> Contract {
    soft(
        "siconos",
        "nonsmooth contact (Moreau-Jean theta 0.5 with projection, step 1e-4, Newton e = 0, NSGS 1e-12)",
        (
            1e-4,
            "quick map: 1.6e-9 m at most (mass ratio 1e-3, 1 m blocks), 7.5e-10 m on the 0.02 m wide block (3.7e-8 of it): round-off, the strict limit; an overturned block (pulse k = 20) falls through the ground: known",
        ),
        (
            5e-5,
            "quick map: 1.1e-5 (a 5 cm block), 8.6e-6 (a square block), 2.9e-6 (mass ratio 1e-3), 1.6e-6 (the base block, at its first impact); 4.7e-9 (H/B = 20)",
        ),
        (
            1e-8,
            "quick map: 3.5e-9 m (1.4e-9 of the height) for a column of 5 bricks in 2 s; 1 brick 5.6e-17 m; the column of 20 timed out (known)",
        ),
        (
            2e-4,
            "quick map: 5.0e-5 (mass ratio 1000, up to the first impact at 0.857 s), 5.8e-9 (5 bricks); every single-block cell bit-symmetric",
        ),
        "deterministic: bit-identical reruns on every measured cell",
    )
}
