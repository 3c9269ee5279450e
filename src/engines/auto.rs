//! `auto`: the fast path for single-block questions. A scene that is one block on the ground,
//! released without sliding, with friction enough for the pivot not to slip at impact and a
//! ground motion given as an acceleration (or none) is exactly Housner's problem: it runs on
//! the Housner engine (microseconds per simulated second). Anything else runs on the native
//! engine. The summary's notes say which engine ran and why.

use super::housner::{HousnerBlock, HousnerEngine, HousnerSettings};
use super::native::NativeEngine;
use super::{Engine, EngineError, Progress, RunOutput};
use crate::excitation::GroundMotion;
use crate::scene::Scene;

pub struct AutoEngine;

/// Why a scene is not Housner's problem, or `None` if it is.
pub fn not_housner(scene: &Scene) -> Option<String> {
    if scene.blocks.len() != 1 {
        return Some(format!("{} blocks", scene.blocks.len()));
    }
    if scene.initial.blocks.values().any(|s| s.vx != 0.0) {
        return Some("initial sliding velocity".into());
    }
    match GroundMotion::from_scene(scene) {
        Ok(g) if g.any_displacement_defined() => {
            return Some("ground motion given as a displacement history".into());
        }
        Err(e) => return Some(e.to_string()),
        Ok(_) => {}
    }
    let b = &scene.blocks[0];
    let restitution = match HousnerSettings::of(scene) {
        Ok(h) => h.restitution,
        Err(e) => return Some(e.to_string()),
    };
    let blk = HousnerBlock::new(b.width, b.height, scene.gravity, restitution);
    let r = blk.restitution;
    let needed = (blk.h / blk.b) * (1.0 - r) / (1.0 + r);
    let mu = scene.friction_below(0);
    if mu < needed {
        return Some(format!(
            "friction {mu} below the {needed:.3} the pivot needs not to slip"
        ));
    }
    None
}

impl Engine for AutoEngine {
    fn name(&self) -> &'static str {
        "auto"
    }

    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError> {
        let (mut out, note) = match not_housner(scene) {
            None => (
                HousnerEngine.run_reporting(scene, progress)?,
                "auto: ran the Housner engine (one block on the ground, no sliding)".to_string(),
            ),
            Some(why) => (
                NativeEngine.run_reporting(scene, progress)?,
                format!("auto: ran the native engine ({why})"),
            ),
        };
        out.notes.insert(0, note);
        Ok(out)
    }
}
