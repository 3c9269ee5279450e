//! `summary.json`: what an engine run produced, with the settings and versions behind it.

use crate::events::{self, History, ImpactSource, Peak};
use crate::output::RunOutput;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

fn samples_source() -> ImpactSource {
    ImpactSource::Samples
}

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
    /// Where the impact times come from: `engine` (located by the engine itself) or `samples`
    /// (extrapolated from the pre-impact side of the output samples, `crate::events`).
    #[serde(default = "samples_source")]
    pub impacts_source: ImpactSource,
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
    /// The commit the program was built from ([`crate::build_info::GIT_COMMIT`]); empty in
    /// summaries written before it was recorded.
    #[serde(default)]
    pub rockbench_git_commit: String,
    /// The hash of the program's sources ([`crate::build_info::SOURCE_HASH`]); empty in
    /// summaries written before it was recorded.
    #[serde(default)]
    pub rockbench_source_hash: String,
    pub engine: String,
    pub engine_version: String,
    pub scene: String,
    pub scene_file: String,
    /// The SHA-256 of the scene as run, overrides applied ([`Scene::sha256`]; the run
    /// directory's `scene.json` is that scene): what ties the summary to its scene. Empty in
    /// summaries written before it was recorded.
    #[serde(default)]
    pub scene_sha256: String,
    /// Every setting that changes the answer, as used.
    pub settings: serde_json::Value,
    pub status: String,
    pub duration: f64,
    /// The interval of the engine's samples, s: the scene's `[output] interval`, which a
    /// fixed-step engine rounds to whole steps (as its settings record it, else the median
    /// spacing of the trajectory's times); events are located from these samples.
    #[serde(default)]
    pub output_interval: f64,
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
    /// The SHA-256 of the `trajectory.csv` written beside the summary (set as both are
    /// written, [`crate::engines::write_outputs`]; empty for a summary with no such file).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub trajectory_sha256: String,
}

/// The rotation (and its rate) on which block i's impacts are measured, and its label;
/// `supports` is the scene's layout's (`Scene::layout`, built once per scene: it costs O(n^2)).
pub fn measured_rotation(
    scene: &Scene,
    supports: &[Option<usize>],
    out: &RunOutput,
    i: usize,
) -> (Vec<f64>, Vec<f64>, String) {
    let support = supports[i];
    let (phi, omega) = out.trajectory.rotation(i, support);
    let label = match support {
        None => "absolute".into(),
        Some(s) => format!("relative to {}", scene.blocks[s].name),
    };
    (phi, omega, label)
}

/// The median spacing of the sample times `t` (`None` for fewer than two samples).
fn sample_interval(t: &[f64]) -> Option<f64> {
    let mut gaps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    Some(gaps[gaps.len() / 2])
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
                let (rot, rate, label) = measured_rotation(scene, &layout.supports, out, i);
                let measured = History::new(t, &rot, &rate);
                let (impacts, impacts_source) = match &out.exact_impacts {
                    Some(ex) => (ex[i].clone(), ImpactSource::Engine),
                    None => (
                        events::impacts(&measured, events::NOISE_FLOOR),
                        ImpactSource::Samples,
                    ),
                };
                let peaks = events::peaks(&measured, &impacts);
                let b_tr = &out.trajectory.blocks[i];
                let phi = &b_tr.phi;
                let absolute = History::new(t, phi, &b_tr.omega);
                let rest_times: BTreeMap<String, Option<f64>> = events::REST_THRESHOLDS
                    .iter()
                    .map(|(k, eps)| (k.to_string(), events::rest_time(&absolute, *eps)))
                    .collect();
                let (overturned, overturn_time) =
                    events::overturning(&absolute, b.critical_angle());
                BlockSummary {
                    name: b.name.clone(),
                    support: layout.supports[i].map(|s| scene.blocks[s].name.clone()),
                    rotation: label,
                    impacts,
                    impacts_source,
                    peaks,
                    rest_time: events::rest_time(&absolute, events::DEFAULT_REST),
                    rest_times,
                    overturned,
                    overturn_time,
                    max_abs_phi: phi.iter().fold(0.0, |m, p| m.max(p.abs())),
                }
            })
            .collect();
        Summary {
            rockbench_version: crate::build_info::VERSION.to_string(),
            rockbench_git_commit: crate::build_info::GIT_COMMIT.to_string(),
            rockbench_source_hash: crate::build_info::SOURCE_HASH.to_string(),
            engine: engine.to_string(),
            engine_version: out.engine_version.clone(),
            scene: scene.name.clone(),
            scene_file: scene.source.clone(),
            scene_sha256: scene.sha256(),
            settings: out.settings.clone(),
            status: "ok".into(),
            duration: scene.duration,
            output_interval: out
                .settings
                .get("output_interval")
                .and_then(serde_json::Value::as_f64)
                .filter(|dt| dt.is_finite() && *dt > 0.0)
                .or_else(|| sample_interval(t))
                .unwrap_or(scene.output_interval),
            wall_time_s,
            steps: out.steps,
            solver_iterations: out.solver_iterations,
            samples: out.trajectory.len(),
            blocks,
            notes: out.notes.clone(),
            command: None,
            trajectory_sha256: String::new(),
        }
    }
}
