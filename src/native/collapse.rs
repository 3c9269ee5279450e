//! The static collapse acceleration of a scene that starts at rest, and the first instant its
//! loading exceeds it.
//!
//! The rest interval `[a_lo, a_hi]` of horizontal ground accelerations under which admissible
//! forces on the closed points balance gravity and `-m a` ([`super::sleep::rest_interval`], the
//! static theorem of limit analysis: exact for the associative law) bounds where the scene can
//! stay at rest: while the ground acceleration stays inside it, the blocks do not move (the
//! step problems' optimality conditions hold with `dq = 0`); once it leaves it, a mechanism can
//! start. The walls of the dynamic series start to move exactly there (docs/walls.md, "Which
//! walls of the series move, and when").

use super::stepper_for;
use crate::excitation::{DefinedBy, GroundMotion};
use crate::scene::{Scene, SceneError};

/// Spacing of the instants at which the loading is compared with the interval, s.
pub const SCAN_STEP: f64 = 1e-4;

/// A scene's rest interval against its loading.
#[derive(Debug, Clone, PartialEq)]
pub struct CollapseOnset {
    /// The rest interval at the start, in units of the scene's gravity; `None` when the blocks
    /// do not start at rest (an initial velocity) or no admissible forces balance gravity
    /// alone (a block that starts tilted off its base).
    pub interval: Option<(f64, f64)>,
    /// The largest horizontal ground acceleration over the scene's duration, in units of the
    /// scene's gravity.
    pub peak: f64,
    /// The first instant (on a grid of `SCAN_STEP`) at which the horizontal ground acceleration
    /// is outside the interval; `None` if it never is within the duration, or if there is no
    /// interval or the scene has a vertical excitation (the rest condition is then a region of
    /// the plane of accelerations, not an interval).
    pub leaves_at: Option<f64>,
    /// Whether the scene has a vertical excitation.
    pub vertical: bool,
    /// Whether the horizontal motion is a displacement record: its velocity jumps at every
    /// sample (impulses of acceleration), which no interval of accelerations bounds, so the
    /// onset is not computed.
    pub displacement: bool,
}

/// The rest interval of `scene` at its start and where its horizontal loading leaves it.
pub fn collapse_onset(scene: &Scene) -> Result<CollapseOnset, SceneError> {
    let (stepper, state) = stepper_for(scene)?;
    let g = scene.gravity;
    let interval = if state.v.iter().all(|v| *v == 0.0) {
        stepper
            .rest_interval_of(&state)
            .map(|(lo, hi)| (lo / g, hi / g))
    } else {
        None
    };
    let motion = GroundMotion::from_scene(scene)?;
    let vertical = motion.vertical.is_some();
    let displacement = motion
        .horizontal
        .as_ref()
        .is_some_and(|c| c.defined_by() == DefinedBy::Displacement);
    let (mut peak, mut leaves_at) = (0.0f64, None);
    for k in 0..=(scene.duration / SCAN_STEP).round() as usize {
        let t = k as f64 * SCAN_STEP;
        let a = motion.acc(t).0 / g;
        peak = peak.max(a.abs());
        if leaves_at.is_none()
            && !vertical
            && !displacement
            && interval.is_some_and(|(lo, hi)| a < lo || a > hi)
        {
            leaves_at = Some(t);
        }
    }
    Ok(CollapseOnset {
        interval,
        peak,
        leaves_at,
        vertical,
        displacement,
    })
}

impl std::fmt::Display for CollapseOnset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const DISPLACEMENT: &str = "the loading is a displacement record, whose velocity jumps at its samples: the onset is not computed";
        let Some((lo, hi)) = self.interval else {
            if self.displacement {
                return write!(
                    f,
                    "no rest interval (the blocks do not start at rest); {DISPLACEMENT}"
                );
            }
            return write!(
                f,
                "no rest interval (the blocks do not start at rest); the loading peaks at {:.4} g",
                self.peak
            );
        };
        if lo > 0.0 || hi < 0.0 {
            return write!(
                f,
                "rest interval [{lo:.4}, {hi:.4}] g (static theorem, associative law): without a ground acceleration in it the blocks do not rest where they start"
            );
        }
        if self.displacement {
            return write!(
                f,
                "rest interval [{lo:.4}, {hi:.4}] g (static theorem, associative law); {DISPLACEMENT}"
            );
        }
        write!(
            f,
            "rest interval [{lo:.4}, {hi:.4}] g (static theorem, associative law); the loading peaks at {:.4} g",
            self.peak
        )?;
        match (self.vertical, self.leaves_at) {
            (true, _) => write!(f, "; with a vertical excitation the onset is not computed"),
            (false, Some(t)) => write!(f, " and leaves the interval at {t:.4} s"),
            (false, None) => write!(f, " and stays inside the interval"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    fn onset(text: &str) -> CollapseOnset {
        collapse_onset(&parse_scene_str(text, false, "collapse-test", &[]).unwrap()).unwrap()
    }

    const BLOCK: &str = "name = \"b\"\nduration = 1\n[[blocks]]\nname = \"b\"\nwidth = 0.5\nheight = 2.0\n[contact]\nfriction = 0.7\n";

    /// A block of B/H = 0.25 rests while `|a| <= 0.25 g` (the rocking threshold, below the
    /// friction coefficient); a rectangular pulse of 0.3 g from 0.2 s leaves the interval at its
    /// start, one of 0.2 g never does.
    #[test]
    fn a_blocks_interval_is_its_rocking_threshold_and_a_pulse_leaves_it_at_its_start() {
        let pulse = |g: f64| {
            format!(
                "{BLOCK}[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {}\nduration = 0.5\nstart = 0.2\n",
                g * 9.81
            )
        };
        let above = onset(&pulse(0.3));
        let (lo, hi) = above.interval.unwrap();
        assert!(
            (hi - 0.25).abs() < 1e-6 && (lo + 0.25).abs() < 1e-6,
            "{above}"
        );
        assert!((above.peak - 0.3).abs() < 1e-12, "{above}");
        let t = above.leaves_at.unwrap();
        assert!((0.2..=0.2 + SCAN_STEP).contains(&t), "{above}");
        let below = onset(&pulse(0.2));
        assert_eq!(below.leaves_at, None, "{below}");
        assert!(!below.vertical);
    }

    /// A displacement record's loading is velocity jumps: no onset is claimed (the block does
    /// rock under one whose acceleration between samples is zero).
    #[test]
    fn a_displacement_record_has_no_onset() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("d.csv"),
            "0,0\n0.01,0\n0.02,0.05\n0.03,0\n0.2,0\n",
        )
        .unwrap();
        let text = format!(
            "{BLOCK}[excitation.horizontal]\nkind = \"displacement\"\nfile = \"{}\"\n",
            dir.path().join("d.csv").display()
        );
        let scene = parse_scene_str(&text, false, "collapse-test", &[]).unwrap();
        let o = collapse_onset(&scene).unwrap();
        assert!(o.displacement && o.leaves_at.is_none(), "{o}");
        assert!(o.to_string().ends_with("the onset is not computed"), "{o}");
    }

    /// A block thrown with an initial velocity has no rest interval.
    #[test]
    fn a_moving_start_has_no_interval() {
        let text = format!("{BLOCK}[initial.blocks.b]\nvx = 0.1\n");
        let o = onset(&text);
        assert_eq!((o.interval, o.leaves_at), (None, None), "{o}");
    }
}
