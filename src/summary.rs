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
    /// The SHA-256 of each record file the run read, by path ([`Scene::record_hashes`]),
    /// unchanged over the run.
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub record_sha256: serde_json::Map<String, serde_json::Value>,
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
    /// The instant from which the engine's model no longer holds ([`RunOutput::valid_until`]):
    /// the events, rest times, overturns and largest rotations are of the samples before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_valid_until: Option<f64>,
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

impl Summary {
    pub fn build(scene: &Scene, engine: &str, out: &RunOutput, wall_time_s: f64) -> Summary {
        if let Some(until) = out.valid_until {
            let within = RunOutput {
                trajectory: out.trajectory.before(until),
                valid_until: None,
                ..out.clone()
            };
            return Summary {
                samples: out.trajectory.len(),
                model_valid_until: Some(until),
                ..Self::build(scene, engine, &within, wall_time_s)
            };
        }
        let layout = scene.layout();
        let t = &out.trajectory.t;
        // Every block's impacts first: they are the kinks of the others' crossings and peaks.
        // (The measured rotations are made again rather than kept: a wall's would all be in
        // memory.)
        let impacts: Vec<(Vec<f64>, ImpactSource)> = match &out.exact_impacts {
            Some(ex) => ex
                .iter()
                .map(|e| (e.clone(), ImpactSource::Engine))
                .collect(),
            None => events::scene_impacts(
                scene.blocks.len(),
                t,
                |i| {
                    let (rot, rate, _) = measured_rotation(scene, &layout.supports, out, i);
                    (rot, rate)
                },
                events::NOISE_FLOOR,
            )
            .into_iter()
            .map(|imp| (imp, ImpactSource::Samples))
            .collect(),
        };
        let kinks = events::all_impacts(impacts.iter().map(|(imp, _)| imp.as_slice()));
        let blocks = scene
            .blocks
            .iter()
            .zip(impacts)
            .enumerate()
            .map(|(i, (b, (impacts, impacts_source)))| {
                let (rot, rate, label) = measured_rotation(scene, &layout.supports, out, i);
                let peaks = events::peaks(&History::new(t, &rot, &rate), &impacts, &kinks);
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
                    max_abs_phi: events::max_abs(&absolute, &kinks),
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
            record_sha256: serde_json::Map::new(),
            settings: out.settings.clone(),
            status: "ok".into(),
            duration: scene.duration,
            output_interval: out
                .settings
                .get("output_interval")
                .and_then(serde_json::Value::as_f64)
                .filter(|dt| dt.is_finite() && *dt > 0.0)
                .or_else(|| {
                    // The samples' times carry round-off: at the interval asked for within it,
                    // they are at that interval.
                    out.trajectory.sample_interval().map(|gap| {
                        if (gap - scene.output_interval).abs() <= 1e-9 * scene.output_interval {
                            scene.output_interval
                        } else {
                            gap
                        }
                    })
                })
                .unwrap_or(scene.output_interval),
            wall_time_s,
            steps: out.steps,
            solver_iterations: out.solver_iterations,
            samples: out.trajectory.len(),
            blocks,
            notes: out.notes.clone(),
            command: None,
            model_valid_until: None,
            trajectory_sha256: String::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run whose model ends at 1 s (past it, here, the block is thrown upside down, as a
    /// Siconos block falls through what it has no contact with): its events, overturn and
    /// largest rotation are those of the samples before 1 s, its sample count the whole run's.
    #[test]
    fn the_events_end_where_the_model_does() {
        let scene = crate::scene::parse_scene_str(
            "name = \"s\"\nduration = 2.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n",
            false,
            "s.toml",
            &[],
        )
        .unwrap();
        let mut out = crate::engines::engine_by_name("native")
            .unwrap()
            .run(&scene)
            .unwrap();
        let whole = Summary::build(&scene, "native", &out, 0.0);
        let before_one = out.trajectory.t.iter().filter(|&&t| t < 1.0).count();
        for (t, phi) in out
            .trajectory
            .t
            .iter()
            .zip(&mut out.trajectory.blocks[0].phi)
        {
            if *t >= 1.0 {
                *phi = std::f64::consts::PI;
            }
        }
        assert!(Summary::build(&scene, "native", &out, 0.0).blocks[0].overturned);
        out.valid_until = Some(1.0);
        let s = Summary::build(&scene, "native", &out, 0.0);
        assert_eq!(s.model_valid_until, Some(1.0));
        assert_eq!(s.samples, out.trajectory.len());
        assert!(!s.blocks[0].overturned);
        assert!(
            s.blocks[0].max_abs_phi <= 0.15 + 1e-12,
            "{}",
            s.blocks[0].max_abs_phi
        );
        let impacts_before: Vec<f64> = whole.blocks[0]
            .impacts
            .iter()
            .copied()
            .filter(|&t| t < out.trajectory.t[before_one - 1])
            .collect();
        assert!(!impacts_before.is_empty());
        assert_eq!(
            s.blocks[0].impacts[..impacts_before.len()],
            impacts_before[..]
        );
    }
}
