//! `summary.json`: what an engine run produced, with the settings and versions behind it.

use crate::engines::RunOutput;
use crate::events::{self, Peak};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Events of one block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlockSummary {
    pub name: String,
    /// The body the block initially rests on (`null`: the ground).
    pub support: Option<String>,
    /// Which rotation the impacts and peaks are measured on: `absolute` for a block on the
    /// ground, `relative to <support>` for a block on another block.
    pub rotation: String,
    /// Impact times, s.
    pub impacts: Vec<f64>,
    pub peaks: Vec<Peak>,
    /// Rest time at the default threshold (1e-4 rad), s; `null` if never at rest.
    pub rest_time: Option<f64>,
    /// Rest time at each threshold (keys "1e-4", "1e-3", "1e-2", "3e-2"), on the absolute
    /// rotation.
    pub rest_times: BTreeMap<String, Option<f64>>,
    pub overturned: bool,
    pub overturn_time: Option<f64>,
    /// Largest |phi| (absolute), rad.
    pub max_abs_phi: f64,
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub rockbench_version: String,
    pub engine: String,
    pub engine_version: String,
    pub scene: String,
    pub scene_file: String,
    /// Every setting that changes the answer, as used.
    pub settings: serde_json::Value,
    pub status: String,
    pub duration: f64,
    pub wall_time_s: f64,
    pub steps: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver_iterations: Option<u64>,
    pub samples: usize,
    pub blocks: Vec<BlockSummary>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
}

/// The rotation on which block i's impacts are measured, and its label.
pub fn measured_rotation(scene: &Scene, out: &RunOutput, i: usize) -> (Vec<f64>, String) {
    let supports = scene.layout().supports;
    let phi = &out.trajectory.blocks[i].phi;
    match supports[i] {
        None => (phi.clone(), "absolute".into()),
        Some(s) => {
            let base = &out.trajectory.blocks[s].phi;
            (
                phi.iter().zip(base).map(|(a, b)| a - b).collect(),
                format!("relative to {}", scene.blocks[s].name),
            )
        }
    }
}

impl Summary {
    pub fn build(scene: &Scene, engine: &str, out: &RunOutput, wall_time_s: f64) -> Summary {
        let layout = scene.layout();
        let t = &out.trajectory.t;
        let blocks = scene
            .blocks
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let (rot, label) = measured_rotation(scene, out, i);
                let impacts = match &out.exact_impacts {
                    Some(ex) => ex[i].clone(),
                    None => events::impacts(t, &rot, events::NOISE_FLOOR),
                };
                let peaks = events::peaks(t, &rot, &impacts);
                let phi = &out.trajectory.blocks[i].phi;
                let rest_times: BTreeMap<String, Option<f64>> = events::REST_THRESHOLDS
                    .iter()
                    .map(|(k, eps)| (k.to_string(), events::rest_time(t, phi, *eps)))
                    .collect();
                let (overturned, overturn_time) = events::overturning(t, phi, b.critical_angle());
                BlockSummary {
                    name: b.name.clone(),
                    support: layout.supports[i].map(|s| scene.blocks[s].name.clone()),
                    rotation: label,
                    impacts,
                    peaks,
                    rest_time: events::rest_time(t, phi, events::DEFAULT_REST),
                    rest_times,
                    overturned,
                    overturn_time,
                    max_abs_phi: phi.iter().fold(0.0, |m, p| m.max(p.abs())),
                }
            })
            .collect();
        Summary {
            rockbench_version: env!("CARGO_PKG_VERSION").to_string(),
            engine: engine.to_string(),
            engine_version: out.engine_version.clone(),
            scene: scene.name.clone(),
            scene_file: scene.source.clone(),
            settings: out.settings.clone(),
            status: "ok".into(),
            duration: scene.duration,
            wall_time_s,
            steps: out.steps,
            solver_iterations: out.solver_iterations,
            samples: out.trajectory.len(),
            blocks,
            notes: out.notes.clone(),
            command: None,
        }
    }
}
