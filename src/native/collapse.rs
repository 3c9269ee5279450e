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
    /// The largest horizontal ground acceleration over the gravity the vertical excitation
    /// leaves, `|a_x| / (g + a_z)` (the ground's acceleration upwards adds to gravity), where
    /// the scene has one: the interval scales with that gravity (the static theorem's loads are
    /// homogeneous), so this ratio is what it bounds. Infinite where the ground falls faster
    /// than gravity.
    pub peak_on_gravity_left: Option<f64>,
    /// The first instant (on a grid of `SCAN_STEP`) at which the horizontal ground acceleration
    /// over the gravity the vertical excitation leaves (`a_x / (g + a_z)`; `a_x / g` without
    /// one) is outside the interval, or at which the ground falls faster than gravity; `None`
    /// if it never is within the duration, or if there is no interval.
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
    let (mut peak, mut peak_on_left, mut leaves_at) = (0.0f64, 0.0f64, None);
    for k in 0..=(scene.duration / SCAN_STEP).round() as usize {
        let t = k as f64 * SCAN_STEP;
        let (ax, az) = motion.acc(t);
        peak = peak.max((ax / g).abs());
        let left = g + az;
        let a = if left > 0.0 { ax / left } else { f64::INFINITY };
        peak_on_left = peak_on_left.max(a.abs());
        if leaves_at.is_none()
            && !displacement
            && interval.is_some_and(|(lo, hi)| !(lo..=hi).contains(&a))
        {
            leaves_at = Some(t);
        }
    }
    Ok(CollapseOnset {
        interval,
        peak,
        peak_on_gravity_left: vertical.then_some(peak_on_left),
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
        if let Some(r) = self.peak_on_gravity_left {
            write!(
                f,
                ", {r:.4} of the gravity its vertical excitation leaves (g + a_z, which the interval scales with)"
            )?;
        }
        match self.leaves_at {
            Some(t) => write!(f, " and leaves the interval at {t:.4} s"),
            None => write!(f, " and stays inside the interval"),
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

    /// A vertical excitation scales the interval with the gravity it leaves, `g + a_z`: a
    /// horizontal pulse of 0.2 g, inside the interval of 0.25 g alone, leaves it when the
    /// ground falls at 0.3 g at the same time (0.2 / 0.7 = 0.286), and not when it rises. (The
    /// interval for gravity alone was quoted, with "the onset is not computed": a reader took
    /// 0.2 g inside 0.25 g for rest, and the block rocks.)
    #[test]
    fn a_vertical_excitation_scales_the_interval_with_the_gravity_it_leaves() {
        let with = |az: f64| {
            format!(
                "{BLOCK}[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {}\nduration = 0.5\nstart = 0.2\n\
                 [excitation.vertical]\nkind = \"rectangular\"\namplitude = {}\nduration = 0.5\nstart = 0.2\n",
                0.2 * 9.81,
                az * 9.81
            )
        };
        let falling = onset(&with(-0.3));
        let t = falling.leaves_at.unwrap();
        assert!((0.2..=0.2 + SCAN_STEP).contains(&t), "{falling}");
        let r = falling.peak_on_gravity_left.unwrap();
        assert!((r - 0.2 / 0.7).abs() < 1e-9, "{falling}");
        assert!(
            falling.to_string().contains("leaves the interval at 0.2"),
            "{falling}"
        );
        let rising = onset(&with(0.3));
        assert_eq!(rising.leaves_at, None, "{rising}");
        assert!(
            (rising.peak_on_gravity_left.unwrap() - 0.2 / 1.3).abs() < 1e-9,
            "{rising}"
        );
        // Falling faster than gravity, the ground leaves the block at once.
        let free_fall = onset(&with(-1.5));
        assert!(
            free_fall.leaves_at.is_some() && free_fall.peak_on_gravity_left == Some(f64::INFINITY)
        );
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
