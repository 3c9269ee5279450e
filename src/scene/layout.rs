//! The initial configuration of a scene: where each block is, what it rests on, and how it
//! moves at t = 0.
//!
//! Blocks are first placed upright (bottom to top), then each is rotated by its relative
//! `rotation` about its pivot corner on its support (left corner for a positive,
//! counter-clockwise rotation), composed up the stack, and finally the whole assembly is
//! rotated rigidly by `tilt` about the bottom block's pivot corner.

use super::Scene;
use serde::{Deserialize, Serialize};

/// Position and velocity of one block's centroid: `x`, `z` (m), `phi` (rad, counter-clockwise),
/// and their rates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BlockState {
    pub x: f64,
    pub z: f64,
    pub phi: f64,
    pub vx: f64,
    pub vz: f64,
    pub omega: f64,
}

/// Initial configuration of a scene.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Initial state of every block (same order as the scene).
    pub blocks: Vec<BlockState>,
    /// The body each block rests on initially: `None` is the ground.
    pub supports: Vec<Option<usize>>,
    /// Upright centre of each block before any rotation.
    pub upright: Vec<(f64, f64)>,
    /// Pivot corner (world, upright coordinates) of each block's relative rotation.
    pub pivots: Vec<(f64, f64)>,
}

/// A rigid motion of the plane: `p -> R(angle) p + t`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rigid {
    pub angle: f64,
    pub t: (f64, f64),
}

impl Rigid {
    pub const IDENTITY: Rigid = Rigid {
        angle: 0.0,
        t: (0.0, 0.0),
    };
    /// Rotation by `angle` about point `c`.
    pub fn about(c: (f64, f64), angle: f64) -> Rigid {
        let (s, co) = angle.sin_cos();
        Rigid {
            angle,
            t: (c.0 - (co * c.0 - s * c.1), c.1 - (s * c.0 + co * c.1)),
        }
    }
    pub fn apply(&self, p: (f64, f64)) -> (f64, f64) {
        let (s, c) = self.angle.sin_cos();
        (c * p.0 - s * p.1 + self.t.0, s * p.0 + c * p.1 + self.t.1)
    }
    /// `self ∘ other`.
    pub fn then_after(&self, other: &Rigid) -> Rigid {
        let t = self.apply(other.t);
        Rigid {
            angle: self.angle + other.angle,
            t,
        }
    }
}

/// Horizontal overlaps below this fraction of the narrower block are round-off: the blocks
/// stand side by side.
pub const SIDE_BY_SIDE: f64 = 1e-9;

/// Horizontal overlap length of two intervals.
pub(crate) fn overlap(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.1.min(b.1) - a.0.max(b.0)).max(0.0)
}

impl Layout {
    /// Each block's rotation and rate relative to the body it initially rests on (as they
    /// are, on the ground), from the blocks' states `(x, z, phi, vx, vz, omega)`.
    pub fn relative_rotations(&self, states: &[[f64; 6]]) -> Vec<(f64, f64)> {
        states
            .iter()
            .zip(&self.supports)
            .map(|(s, support)| match *support {
                Some(j) => (s[2] - states[j][2], s[5] - states[j][5]),
                None => (s[2], s[5]),
            })
            .collect()
    }

    pub fn of(scene: &Scene) -> Layout {
        let n = scene.blocks.len();
        let mut upright = Vec::with_capacity(n);
        let mut supports = Vec::with_capacity(n);
        for (i, b) in scene.blocks.iter().enumerate() {
            let (x, bottom, support) = match b.x {
                None if i == 0 => (b.offset, 0.0, None),
                None => {
                    let (xb, zb): (f64, f64) = upright[i - 1];
                    let top = zb + scene.blocks[i - 1].height / 2.0;
                    (xb + b.offset, top, Some(i - 1))
                }
                Some(x) => {
                    let span = (x - b.width / 2.0, x + b.width / 2.0);
                    let mut best: (f64, Option<usize>, f64) = (0.0, None, 0.0);
                    for (j, &(xj, zj)) in upright.iter().enumerate().take(i) {
                        let bj = &scene.blocks[j];
                        let ov = overlap(span, (xj - bj.width / 2.0, xj + bj.width / 2.0));
                        // Side by side: blocks placed edge to edge overlap by round-off (a
                        // block at x = 8.7 of width 0.6 starts at 8.399999999999999), which
                        // must not stack one on the other.
                        if ov <= SIDE_BY_SIDE * b.width.min(bj.width) {
                            continue;
                        }
                        // The highest top, then the largest overlap; overlaps equal to
                        // round-off (a block centred on a running-bond joint) go to the block
                        // listed first, so that the choice, and every quantity measured
                        // relative to the support, does not follow the sign of a round-off.
                        let top = zj + bj.height / 2.0;
                        let tie = SIDE_BY_SIDE * b.width.min(bj.width);
                        if top > best.0 + 1e-12 || (top > best.0 - 1e-12 && ov > best.2 + tie) {
                            best = (top, Some(j), ov);
                        }
                    }
                    (x, best.0, best.1)
                }
            };
            upright.push((x, bottom + b.height / 2.0));
            supports.push(support);
        }

        // Relative rotations, composed bottom-up; the pivot is the support's-top corner on the
        // side of the rotation (left for positive).
        let init = |i: usize| scene.initial.blocks.get(&scene.blocks[i].name);
        let mut maps: Vec<Rigid> = Vec::with_capacity(n);
        let mut pivots = Vec::with_capacity(n);
        for i in 0..n {
            let b = &scene.blocks[i];
            let (x, z) = upright[i];
            let bottom = z - b.height / 2.0;
            let rel = init(i).map(|s| s.rotation).unwrap_or(0.0);
            let omega = init(i).map(|s| s.omega).unwrap_or(0.0);
            let total_for_sign = if i == 0 {
                rel + scene.initial.tilt
            } else {
                rel
            };
            let sign = if total_for_sign != 0.0 {
                total_for_sign.signum()
            } else if omega != 0.0 {
                omega.signum()
            } else {
                1.0
            };
            let (lo, hi) = match supports[i] {
                None => (x - b.width / 2.0, x + b.width / 2.0),
                Some(s) => {
                    let (xs, _) = upright[s];
                    let ws = scene.blocks[s].width;
                    (
                        (x - b.width / 2.0).max(xs - ws / 2.0),
                        (x + b.width / 2.0).min(xs + ws / 2.0),
                    )
                }
            };
            let pivot = (if sign > 0.0 { lo } else { hi }, bottom);
            pivots.push(pivot);
            let base = supports[i].map(|s| maps[s]).unwrap_or(Rigid::IDENTITY);
            maps.push(base.then_after(&Rigid::about(pivot, rel)));
        }
        let tilt = Rigid::about(pivots[0], scene.initial.tilt);
        let maps: Vec<Rigid> = maps.iter().map(|m| tilt.then_after(m)).collect();

        // Velocities: each block adds its relative angular velocity about its (current) pivot
        // and its sliding velocity along its support's top face.
        let mut blocks: Vec<BlockState> = Vec::with_capacity(n);
        for i in 0..n {
            let (cx, cz) = maps[i].apply(upright[i]);
            let s = init(i).cloned().unwrap_or_default();
            let (mut vx, mut vz, mut om) = (0.0, 0.0, 0.0);
            let mut support_angle = 0.0;
            if let Some(sp) = supports[i] {
                let p = &blocks[sp];
                om = p.omega;
                vx = p.vx - p.omega * (cz - p.z);
                vz = p.vz + p.omega * (cx - p.x);
                support_angle = p.phi;
            }
            let piv = maps[i].apply(pivots[i]);
            vx += -s.omega * (cz - piv.1) + s.vx * support_angle.cos();
            vz += s.omega * (cx - piv.0) + s.vx * support_angle.sin();
            om += s.omega;
            blocks.push(BlockState {
                x: cx,
                z: cz,
                phi: maps[i].angle,
                vx,
                vz,
                omega: om,
            });
        }
        Layout {
            blocks,
            supports,
            upright,
            pivots,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::load::parse_scene_str;

    /// A pedestal on the ground carrying a statue turned about its corner on it.
    fn stack(pedestal: f64, statue: f64) -> crate::scene::Scene {
        let text = format!(
            "name = \"stack\"\nduration = 1\n[[blocks]]\nname = \"p\"\nwidth = 1.25\nheight = 1.25\n\
             [[blocks]]\nname = \"s\"\nwidth = 1.0\nheight = 2.5\n\
             [initial.blocks.p]\nrotation = {pedestal}\nomega = 0.5\n\
             [initial.blocks.s]\nrotation = {statue}\nomega = -0.25\n"
        );
        parse_scene_str(&text, false, "stack.toml", &[]).unwrap()
    }

    /// A block centred on the joint of two below rests on the one listed first, whatever the
    /// round-off of the positions (a mirrored wall's joint blocks took the other support).
    #[test]
    fn a_block_centred_on_a_joint_rests_on_the_block_listed_first() {
        for (left, right, top) in [
            (0.15, 0.45, 0.3),
            (0.15, 0.45 + 1e-15, 0.3),
            (0.15 - 1e-15, 0.45, 0.3 + 2e-16),
            (0.45, 0.15, 0.3),
        ] {
            let text = format!(
                "name = \"joint\"\nduration = 1\n[[blocks]]\nname = \"a\"\nwidth = 0.3\nheight = 0.2\nx = {left:?}\n\
                 [[blocks]]\nname = \"b\"\nwidth = 0.3\nheight = 0.2\nx = {right:?}\n\
                 [[blocks]]\nname = \"c\"\nwidth = 0.3\nheight = 0.2\nx = {top:?}\n"
            );
            let scene = parse_scene_str(&text, false, "joint.toml", &[]).unwrap();
            assert_eq!(scene.layout().supports[2], Some(0), "{left} {right} {top}");
        }
    }

    fn states(layout: &super::Layout) -> Vec<[f64; 6]> {
        let s = &layout.blocks;
        s.iter()
            .map(|b| [b.x, b.z, b.phi, b.vx, b.vz, b.omega])
            .collect()
    }

    #[test]
    fn relative_rotations_are_taken_against_the_support() {
        let layout = stack(0.1, -0.05).layout();
        let rel = layout.relative_rotations(&states(&layout));
        assert!((rel[0].0 - 0.1).abs() < 1e-15 && (rel[0].1 - 0.5).abs() < 1e-15);
        assert!((rel[1].0 + 0.05).abs() < 1e-15, "{:?}", rel[1]);
        assert!((rel[1].1 + 0.25).abs() < 1e-15, "{:?}", rel[1]);
    }

    /// At its critical angle a block's centroid stands above its pivot, `R` high: its
    /// potential energy above rest is the tipping energy `g (R - H/2)`.
    #[test]
    fn a_block_turned_to_its_critical_angle_holds_its_tipping_energy() {
        let scene = stack(0.0, 0.0);
        let statue = &scene.blocks[1];
        let at_rest = stack(0.0, 0.0).layout();
        let at_rest = states(&at_rest)[1];
        let mut tipped = states(&stack(0.0, statue.critical_angle()).layout())[1];
        tipped[3..].fill(0.0); // at rest there
        let g = 9.81;
        let e = statue.energy_per_mass(&tipped, g, at_rest[1]);
        let tipping = statue.tipping_energy_per_mass(g);
        assert!(
            (e - tipping).abs() < 1e-12 * tipping,
            "{e} against {tipping}"
        );
        assert_eq!(
            statue.energy_per_mass(&[0.0, at_rest[1], 0.0, 0.0, 0.0, 0.0], g, at_rest[1]),
            0.0
        );
        // Kinetic: a rate about the centroid alone, `I/m omega^2 / 2`.
        let spin = statue.energy_per_mass(&[0.0, at_rest[1], 0.0, 0.0, 0.0, 2.0], g, at_rest[1]);
        assert!((spin - 0.5 * (1.0 + 6.25) / 12.0 * 4.0).abs() < 1e-15);
    }
}
