//! Invariants every run must satisfy, whatever the engine, checked from the trajectory alone.
//!
//! - **finite**: no NaN or infinity anywhere in the trajectory.
//! - **penetration**: from the trajectory geometry (rectangles posed at each sample): the
//!   lowest vertex of every block is at `z >= -tol` (the ground is `z = 0` in the ground's
//!   frame), and every pair of blocks that may touch (a block and its support, and pairs
//!   whose bounding boxes are within half the smaller block dimension at t = 0) overlaps by
//!   at most `tol` (separating-axis depth). `tol = penetration_rel * smallest block dimension`.
//! - **energy**: without excitation, the mechanical energy
//!   `E = sum m (g z + (vx^2 + vz^2)/2) + I omega^2 / 2` (z from the ground) never exceeds its
//!   smallest earlier value by more than `energy_rel * E_ref`, with `E_ref = sum m g H` (the
//!   potential energy of the blocks lifted by their own height): a free system only loses
//!   energy (impacts, friction, numerical damping), so any growth is an error.
//! - **standing**: a scene at rest (no excitation, no initial rotation or velocity) stays put:
//!   every vertex moves by less than `drift` (1e-9 m) over the whole run.
//! - **mirror**: the scene mirrored about `x = 0` gives the mirrored motion
//!   (`x -> -x`, `phi -> -phi`, `vx -> -vx`, `omega -> -omega`) within `mirror_rel` of the
//!   largest block dimension (m) or rad, on the samples before the first impact of the
//!   original run (the sample that ends the impact's step is excluded: whether a contact
//!   closes in that step or the next is decided by round-off). After an
//!   impact, round-off decides discrete contact events (the step in which a corner closes, a
//!   contact kept or dropped), so the two runs may then differ by far more than round-off
//!   (measured: up to 9e-4 rad after several impacts of a single block at theta = 0.5), and a
//!   stack is chaotic after its first impact.
//!   Contacts that chatter before any rocking impact (corners hovering on associative
//!   dilation at theta near 0.5, a light block squeezed between heavy ones) amplify round-off
//!   the same way; when the difference exceeds `mirror_rel`, runs of the scene shifted
//!   sideways (exact symmetry, different round-off) measure that amplification and the limit
//!   becomes `PROBE_FACTOR` times their divergence (see [`check_mirror_with_probes`]).
//! - **rerun**: running the same scene twice gives a bit-identical trajectory.
//!
//! The tolerances are [`Tolerances::default`], chosen by measurement on the native and Housner
//! engines (see `rockbench stress`); each check records its measured value next to its limit.

use crate::engines::{Engine, EngineError, RunOutput};
use crate::scene::{MotionSpec, Scene};
use crate::trajectory::Trajectory;
use serde::Serialize;
use std::fmt::Write as _;

/// Limits of the invariant checks (see the module docs for their meaning).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Tolerances {
    /// Largest penetration as a fraction of the smallest block dimension (default 1e-4:
    /// 0.1 mm on a 1 m block).
    pub penetration_rel: f64,
    /// Largest energy growth as a fraction of `sum m g H` (default 1e-9).
    pub energy_rel: f64,
    /// Largest vertex displacement of a standing assembly, m (default 1e-9).
    pub drift: f64,
    /// Largest difference between a run and its mirror, as a fraction of the largest block
    /// dimension (positions) or in rad (rotations) (default 1e-6).
    pub mirror_rel: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            penetration_rel: 1e-4,
            energy_rel: 1e-9,
            drift: 1e-9,
            mirror_rel: 1e-6,
        }
    }
}

/// One invariant on one run.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    pub name: &'static str,
    /// False when the invariant does not apply to the scene (e.g. energy under excitation).
    pub applies: bool,
    pub passed: bool,
    /// The measured quantity (penetration in m, relative energy growth, drift in m, mirror
    /// difference, number of differing values for a rerun).
    pub value: f64,
    pub limit: f64,
    pub detail: String,
}

impl Check {
    /// A check that could not be made because its run failed (a mirrored run, a rerun).
    pub fn run_failed(name: &'static str, e: EngineError) -> Check {
        Check {
            name,
            applies: true,
            passed: false,
            value: f64::INFINITY,
            limit: 0.0,
            detail: format!("the run failed: {e}"),
        }
    }

    fn not_applicable(name: &'static str, why: &str) -> Check {
        Check {
            name,
            applies: false,
            passed: true,
            value: 0.0,
            limit: 0.0,
            detail: why.to_string(),
        }
    }
    fn measured(name: &'static str, value: f64, limit: f64, detail: String) -> Check {
        Check {
            name,
            applies: true,
            passed: value <= limit,
            value,
            limit,
            detail,
        }
    }
    /// Violated (applies and failed).
    pub fn violated(&self) -> bool {
        self.applies && !self.passed
    }
}

/// The names of all checks, in report order.
pub const CHECK_NAMES: [&str; 7] = [
    "finite",
    "complete",
    "penetration",
    "energy",
    "standing",
    "mirror",
    "rerun",
];

/// All checks of one run.
#[derive(Debug, Clone, Default, Serialize)]
pub struct InvariantReport {
    pub checks: Vec<Check>,
}

impl InvariantReport {
    pub fn get(&self, name: &str) -> Option<&Check> {
        self.checks.iter().find(|c| c.name == name)
    }
    pub fn violations(&self) -> Vec<&Check> {
        self.checks.iter().filter(|c| c.violated()).collect()
    }
    pub fn all_passed(&self) -> bool {
        self.violations().is_empty()
    }
}

/// Vertices of a `width x height` rectangle centred at `(x, z)` rotated by `phi`.
fn vertices(w: f64, h: f64, x: f64, z: f64, phi: f64) -> [(f64, f64); 4] {
    let (s, c) = phi.sin_cos();
    let (b, hh) = (w / 2.0, h / 2.0);
    [(-b, -hh), (b, -hh), (b, hh), (-b, hh)]
        .map(|(lx, lz)| (x + c * lx - s * lz, z + s * lx + c * lz))
}

/// Penetration depth of two convex quadrilaterals (separating-axis test): 0 when separated,
/// otherwise the smallest overlap of their projections on the four face normals.
pub fn overlap_depth(a: &[(f64, f64); 4], b: &[(f64, f64); 4]) -> f64 {
    let mut depth = f64::INFINITY;
    for poly in [a, b] {
        for k in 0..2 {
            let (p, q) = (poly[k], poly[k + 1]);
            let (ex, ez) = (q.0 - p.0, q.1 - p.1);
            let len = ex.hypot(ez);
            let n = (-ez / len, ex / len);
            let proj = |v: &[(f64, f64); 4]| {
                v.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        let d = p.0 * n.0 + p.1 * n.1;
                        (lo.min(d), hi.max(d))
                    })
            };
            let (a0, a1) = proj(a);
            let (b0, b1) = proj(b);
            let o = a1.min(b1) - a0.max(b0);
            if o <= 0.0 {
                return 0.0;
            }
            depth = depth.min(o);
        }
    }
    depth
}

fn block_vertices(scene: &Scene, tr: &Trajectory, i: usize, k: usize) -> [(f64, f64); 4] {
    let b = &scene.blocks[i];
    let h = &tr.blocks[i];
    vertices(b.width, b.height, h.x[k], h.z[k], h.phi[k])
}

/// Pairs of blocks that may touch: each block and its initial support, and pairs whose
/// bounding boxes at t = 0 are within half the smaller block dimension.
pub fn candidate_pairs(scene: &Scene, tr: &Trajectory) -> Vec<(usize, usize)> {
    let n = scene.blocks.len();
    let layout = scene.layout();
    let mut pairs: Vec<(usize, usize)> = (0..n)
        .filter_map(|i| layout.supports[i].map(|s| (s.min(i), s.max(i))))
        .collect();
    if tr.is_empty() {
        return pairs;
    }
    let bbox = |i: usize| {
        let v = block_vertices(scene, tr, i, 0);
        v.iter().fold(
            (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ),
            |bb, p| (bb.0.min(p.0), bb.1.max(p.0), bb.2.min(p.1), bb.3.max(p.1)),
        )
    };
    let boxes: Vec<_> = (0..n).map(bbox).collect();
    let min_dim = |i: usize| scene.blocks[i].width.min(scene.blocks[i].height);
    // Sweep over x: sort by the left edge.
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| boxes[a].0.total_cmp(&boxes[b].0));
    let max_margin = (0..n).map(min_dim).fold(0.0, f64::max) * 0.5;
    for (oi, &i) in order.iter().enumerate() {
        for &j in &order[oi + 1..] {
            if boxes[j].0 > boxes[i].1 + max_margin {
                break;
            }
            let m = 0.5 * min_dim(i).min(min_dim(j));
            let near = boxes[j].0 <= boxes[i].1 + m
                && boxes[i].0 <= boxes[j].1 + m
                && boxes[j].2 <= boxes[i].3 + m
                && boxes[i].2 <= boxes[j].3 + m;
            if near {
                pairs.push((i.min(j), i.max(j)));
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// No NaN or infinity.
pub fn check_finite(tr: &Trajectory) -> Check {
    let bad = tr.t.iter().filter(|x| !x.is_finite()).count()
        + tr.blocks
            .iter()
            .map(|b| {
                [&b.x, &b.z, &b.phi, &b.vx, &b.vz, &b.omega]
                    .iter()
                    .map(|v| v.iter().filter(|x| !x.is_finite()).count())
                    .sum::<usize>()
            })
            .sum::<usize>();
    Check::measured(
        "finite",
        bad as f64,
        0.0,
        format!("{bad} non-finite values"),
    )
}

/// The samples cover the run: times strictly increase from 0 to the duration (an engine
/// taking whole steps may pass it by less than one native step), one history per block.
pub fn check_complete(scene: &Scene, tr: &Trajectory) -> Check {
    let slack = 1e-9 * scene.duration.max(1.0);
    let last = tr.t.last().copied().unwrap_or(f64::NAN);
    let mut problems = Vec::new();
    if tr.blocks.len() != scene.blocks.len() {
        problems.push(format!(
            "{} block histories for {} blocks",
            tr.blocks.len(),
            scene.blocks.len()
        ));
    }
    if tr.blocks.iter().any(|b| {
        [&b.x, &b.z, &b.phi, &b.vx, &b.vz, &b.omega]
            .iter()
            .any(|v| v.len() != tr.t.len())
    }) {
        problems.push("histories of different lengths".into());
    }
    if tr.t.first().is_none_or(|&t0| t0.abs() > slack) {
        problems.push("does not start at t = 0".into());
    }
    if !tr.t.windows(2).all(|w| w[1] > w[0]) {
        problems.push("times do not increase".into());
    }
    // The native and rapier engines end on a whole step past the duration.
    let native_dt = crate::native::settings_of(scene).map_or(0.0, |s| s.dt);
    let rapier_dt =
        crate::engines::rapier_settings::RapierSettings::of(scene).map_or(0.0, |s| s.dt);
    if !(last >= scene.duration - slack && last < scene.duration + native_dt.max(rapier_dt) + slack)
    {
        problems.push(format!(
            "ends at {last} s, the duration is {} s",
            scene.duration
        ));
    }
    Check::measured(
        "complete",
        problems.len() as f64,
        0.0,
        if problems.is_empty() {
            format!("{} samples from 0 to {last} s", tr.len())
        } else {
            problems.join("; ")
        },
    )
}

/// Largest ground and block-block penetration over the run, m.
pub fn max_penetration(scene: &Scene, tr: &Trajectory) -> (f64, f64, String) {
    let pairs = candidate_pairs(scene, tr);
    let (mut ground, mut pair) = (0.0f64, 0.0f64);
    let mut where_ = String::new();
    for k in 0..tr.len() {
        let verts: Vec<_> = (0..scene.blocks.len())
            .map(|i| block_vertices(scene, tr, i, k))
            .collect();
        for (i, v) in verts.iter().enumerate() {
            let low = v.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            if -low > ground {
                ground = -low;
                if ground >= pair {
                    where_ = format!(
                        "`{}` into the ground at t = {}",
                        scene.blocks[i].name, tr.t[k]
                    );
                }
            }
        }
        for &(i, j) in &pairs {
            let d = overlap_depth(&verts[i], &verts[j]);
            if d > pair {
                pair = d;
                if pair >= ground {
                    where_ = format!(
                        "`{}` into `{}` at t = {}",
                        scene.blocks[j].name, scene.blocks[i].name, tr.t[k]
                    );
                }
            }
        }
    }
    (ground, pair, where_)
}

pub fn smallest_dimension(scene: &Scene) -> f64 {
    scene
        .blocks
        .iter()
        .map(|b| b.width.min(b.height))
        .fold(f64::INFINITY, f64::min)
}

pub fn largest_dimension(scene: &Scene) -> f64 {
    scene
        .blocks
        .iter()
        .map(|b| b.width.max(b.height))
        .fold(0.0, f64::max)
}

pub fn check_penetration(scene: &Scene, tr: &Trajectory, tol: &Tolerances) -> Check {
    let (g, p, where_) = max_penetration(scene, tr);
    let limit = tol.penetration_rel * smallest_dimension(scene);
    Check::measured(
        "penetration",
        g.max(p),
        limit,
        format!("ground {g:.3e} m, block-block {p:.3e} m; deepest: {where_}"),
    )
}

/// Mechanical energy at every sample (J per metre of depth), z measured from the ground.
pub fn energy(scene: &Scene, tr: &Trajectory) -> Vec<f64> {
    (0..tr.len())
        .map(|k| {
            scene
                .blocks
                .iter()
                .zip(&tr.blocks)
                .map(|(b, h)| {
                    let m = b.mass();
                    m * (scene.gravity * h.z[k] + 0.5 * (h.vx[k].powi(2) + h.vz[k].powi(2)))
                        + 0.5 * b.inertia() * h.omega[k].powi(2)
                })
                .sum()
        })
        .collect()
}

/// `sum m g H`: the energy scale of the energy check.
pub fn energy_scale(scene: &Scene) -> f64 {
    scene
        .blocks
        .iter()
        .map(|b| b.mass() * scene.gravity * b.height)
        .sum()
}

pub fn check_energy(scene: &Scene, tr: &Trajectory, tol: &Tolerances) -> Check {
    if scene.has_excitation() {
        return Check::not_applicable("energy", "the ground moves: energy is not conserved");
    }
    let e = energy(scene, tr);
    let scale = energy_scale(scene);
    let (mut low, mut worst, mut at) = (f64::INFINITY, 0.0f64, 0.0);
    for (k, &ek) in e.iter().enumerate() {
        low = low.min(ek);
        if ek - low > worst {
            worst = ek - low;
            at = tr.t[k];
        }
    }
    let rel = worst / scale;
    Check::measured(
        "energy",
        rel,
        tol.energy_rel,
        format!("largest growth {worst:.3e} J/m ({rel:.3e} of sum m g H) at t = {at}"),
    )
}

/// A scene at rest that can stay at rest: no excitation, no initial rotation, angular or
/// sliding velocity, and statically stable (see [`is_statically_stable`]).
pub fn is_standing(scene: &Scene) -> bool {
    !scene.has_excitation()
        && scene.initial.tilt == 0.0
        && scene
            .initial
            .blocks
            .values()
            .all(|s| s.rotation == 0.0 && s.omega == 0.0 && s.vx == 0.0)
        && is_statically_stable(scene)
}

/// Upright and at rest, every block with everything it carries (the blocks stacked on it by
/// `offset`) has its centre of mass strictly inside its base as far as it touches what is
/// under it (the ground, or the tops of the blocks at its bottom level). A block whose load
/// overhangs its support falls, legitimately.
pub fn is_statically_stable(scene: &Scene) -> bool {
    let layout = scene.layout();
    let n = scene.blocks.len();
    let span = |i: usize| {
        let (x, _) = layout.upright[i];
        let b = scene.blocks[i].width / 2.0;
        (x - b, x + b)
    };
    for i in 0..n {
        let (_, zi) = layout.upright[i];
        let bottom = zi - scene.blocks[i].height / 2.0;
        let (lo_i, hi_i) = span(i);
        // Contact span: the block's base where it meets the ground or blocks below.
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        if bottom.abs() <= 1e-12 * (1.0 + zi.abs()) {
            (lo, hi) = (lo_i, hi_i);
        } else {
            for j in 0..n {
                let (_, zj) = layout.upright[j];
                let top = zj + scene.blocks[j].height / 2.0;
                if j == i || (top - bottom).abs() > 1e-9 * (1.0 + bottom.abs()) {
                    continue;
                }
                let (lo_j, hi_j) = span(j);
                let (a, b) = (lo_i.max(lo_j), hi_i.min(hi_j));
                if b > a {
                    lo = lo.min(a);
                    hi = hi.max(b);
                }
            }
        }
        if hi <= lo {
            return false;
        }
        // Centre of mass of the block and what it carries through a pure stack (blocks placed
        // by `offset` on the block below). Blocks placed by `x` (walls) may rest on several
        // blocks, so each is checked on its own there.
        let carried: Vec<usize> = (0..n)
            .filter(|&j| {
                let mut k = Some(j);
                while let Some(kk) = k {
                    if kk == i {
                        return true;
                    }
                    if scene.blocks[kk].x.is_some() {
                        return false;
                    }
                    k = layout.supports[kk];
                }
                false
            })
            .collect();
        let m: f64 = carried.iter().map(|&j| scene.blocks[j].mass()).sum();
        let cx = carried
            .iter()
            .map(|&j| scene.blocks[j].mass() * layout.upright[j].0)
            .sum::<f64>()
            / m;
        let margin = 1e-9 * (hi - lo);
        if !(cx > lo + margin && cx < hi - margin) {
            return false;
        }
    }
    true
}

pub fn check_standing(scene: &Scene, tr: &Trajectory, tol: &Tolerances) -> Check {
    if !is_standing(scene) {
        return Check::not_applicable("standing", "the scene does not start at rest");
    }
    let mut worst = 0.0f64;
    let mut who = String::new();
    for i in 0..scene.blocks.len() {
        let v0 = block_vertices(scene, tr, i, 0);
        for k in 1..tr.len() {
            let v = block_vertices(scene, tr, i, k);
            for (p, q) in v.iter().zip(&v0) {
                let d = (p.0 - q.0).hypot(p.1 - q.1);
                if d > worst {
                    worst = d;
                    who = format!("`{}` at t = {}", scene.blocks[i].name, tr.t[k]);
                }
            }
        }
    }
    Check::measured(
        "standing",
        worst,
        tol.drift,
        format!("largest vertex displacement {worst:.3e} m ({who})"),
    )
}

/// The scene mirrored about `x = 0`: offsets, positions, rotations, velocities and the
/// horizontal ground motion change sign.
pub fn mirror_scene(scene: &Scene) -> Scene {
    let mut m = scene.clone();
    for b in &mut m.blocks {
        b.offset = -b.offset;
        b.x = b.x.map(|x| -x);
    }
    m.initial.tilt = -m.initial.tilt;
    for s in m.initial.blocks.values_mut() {
        s.rotation = -s.rotation;
        s.omega = -s.omega;
        s.vx = -s.vx;
    }
    if let Some(h) = m.excitation.as_mut().and_then(|e| e.horizontal.as_mut()) {
        match h {
            MotionSpec::HalfSine { amplitude, .. }
            | MotionSpec::OneSine { amplitude, .. }
            | MotionSpec::OneCosine { amplitude, .. }
            | MotionSpec::Ricker { amplitude, .. }
            | MotionSpec::Rectangular { amplitude, .. } => *amplitude = -*amplitude,
            MotionSpec::Record { scale, .. } | MotionSpec::Displacement { scale, .. } => {
                *scale = -*scale
            }
        }
    }
    m.name = format!("{} (mirrored)", scene.name);
    m
}

/// First time any block's rotation relative to its initial support crosses zero (an impact),
/// or the end of the run.
fn first_impact(scene: &Scene, tr: &Trajectory) -> f64 {
    let layout = scene.layout();
    let mut first = f64::INFINITY;
    for i in 0..scene.blocks.len() {
        let (rel, rate) = tr.rotation(i, layout.supports[i]);
        let h = crate::events::History::new(&tr.t, &rel, &rate);
        if let Some(&t) = crate::events::impacts(&h, crate::events::NOISE_FLOOR, &[]).first() {
            first = first.min(t);
        }
    }
    first
}

/// Largest difference between two runs on the samples before `until`, as a fraction of
/// `len` (positions) or in rad; `sign` -1 compares with a mirror image (x, phi negated), and
/// `dx` is subtracted from the second run's x.
fn window_difference(
    a: &Trajectory,
    b: &Trajectory,
    sign: f64,
    dx: f64,
    until: f64,
    len: f64,
) -> (f64, String) {
    let mut worst = 0.0f64;
    let mut who = String::new();
    for (p, q) in a.blocks.iter().zip(&b.blocks) {
        for k in 0..a.len().min(q.x.len()) {
            if a.t[k] >= until {
                break;
            }
            let d = [
                (p.x[k] - sign * (q.x[k] - dx)).abs() / len,
                (p.z[k] - q.z[k]).abs() / len,
                (p.phi[k] - sign * q.phi[k]).abs(),
            ];
            let m = d.iter().copied().fold(0.0, f64::max);
            if m > worst || m.is_nan() {
                worst = if m.is_nan() { f64::INFINITY } else { m };
                who = format!("`{}` at t = {}", p.name, a.t[k]);
            }
        }
    }
    (worst, who)
}

/// Horizontal shifts of the round-off probes, as fractions of the largest block dimension.
pub const PROBE_SHIFTS: [f64; 2] = [1e-9, 1e-3];

/// How far a mirror difference may exceed the round-off probes' divergence (see
/// [`check_mirror_with_probes`]).
pub const PROBE_FACTOR: f64 = 100.0;

/// The scene moved horizontally by `dx`: the same physics, different round-off.
pub fn shifted_scene(scene: &Scene, dx: f64) -> Scene {
    let mut s = scene.clone();
    for (i, b) in s.blocks.iter_mut().enumerate() {
        match b.x {
            Some(x) => b.x = Some(x + dx),
            None if i == 0 => b.offset += dx,
            None => {}
        }
    }
    s.name = format!("{} (shifted by {dx:e} m)", scene.name);
    s
}

pub fn check_mirror(
    scene: &Scene,
    tr: &Trajectory,
    mirrored: &Trajectory,
    tol: &Tolerances,
) -> Check {
    check_mirror_with_probes(scene, tr, mirrored, &[], tol)
}

/// The mirror check, with the runs of the scene shifted horizontally (`probes`: shift and
/// trajectory, see [`shifted_scene`]). Mirroring and shifting are both exact symmetries whose
/// only effect on a run is a different round-off; a motion in which contacts chatter (a
/// corner that hovers on associative dilation and re-closes step after step at theta near
/// 0.5, a light block squeezed between heavy ones) amplifies round-off exponentially before
/// any rocking impact, and then a shifted run departs from the original as much as the
/// mirrored one does. The limit is `max(mirror_rel, PROBE_FACTOR * largest probe
/// divergence)`: a genuine asymmetry of the scheme (a tie broken by index, a one-sided
/// formula) shows on motions whose probes stay at round-off. PROBE_FACTOR covers the spread
/// of amplified round-off between differently perturbed runs: the mirror difference was 0.2
/// to 25 times the larger probe divergence on the seven chattering scenes measured.
pub fn check_mirror_with_probes(
    scene: &Scene,
    tr: &Trajectory,
    mirrored: &Trajectory,
    probes: &[(f64, Trajectory)],
    tol: &Tolerances,
) -> Check {
    if tr.t != mirrored.t || tr.blocks.len() != mirrored.blocks.len() {
        return Check::measured(
            "mirror",
            f64::INFINITY,
            0.0,
            "the mirrored run has different sample times or blocks".into(),
        );
    }
    let until = first_impact(scene, tr);
    let len = largest_dimension(scene);
    let (worst, who) = window_difference(tr, mirrored, -1.0, 0.0, until, len);
    let window = if until.is_finite() {
        format!("up to the first impact at {until:.4} s")
    } else {
        "over the whole run".to_string()
    };
    let mut detail = format!("largest difference {worst:.3e} {window} ({who})");
    let mut limit = tol.mirror_rel;
    if !probes.is_empty() {
        let sens = probes
            .iter()
            .map(|(dx, p)| {
                if p.t == tr.t && p.blocks.len() == tr.blocks.len() {
                    window_difference(tr, p, 1.0, *dx, until, len).0
                } else {
                    f64::INFINITY
                }
            })
            .fold(0.0f64, f64::max);
        if sens.is_finite() {
            limit = limit.max(PROBE_FACTOR * sens);
        }
        let _ = write!(
            detail,
            "; runs shifted by {:?} of the largest dimension depart by up to {sens:.3e} (round-off amplified by the motion), limit {limit:.3e}",
            PROBE_SHIFTS
        );
    }
    Check::measured("mirror", worst, limit, detail)
}

/// Number of values that differ bit for bit.
pub fn bit_differences(a: &Trajectory, b: &Trajectory) -> usize {
    if a.t.len() != b.t.len() || a.blocks.len() != b.blocks.len() {
        return usize::MAX;
    }
    let same = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .filter(|(p, q)| p.to_bits() != q.to_bits())
            .count()
    };
    same(&a.t, &b.t)
        + a.blocks
            .iter()
            .zip(&b.blocks)
            .map(|(p, q)| {
                same(&p.x, &q.x)
                    + same(&p.z, &q.z)
                    + same(&p.phi, &q.phi)
                    + same(&p.vx, &q.vx)
                    + same(&p.vz, &q.vz)
                    + same(&p.omega, &q.omega)
            })
            .sum::<usize>()
}

pub fn check_rerun(a: &Trajectory, b: &Trajectory) -> Check {
    let n = bit_differences(a, b);
    Check::measured(
        "rerun",
        n as f64,
        0.0,
        if n == usize::MAX {
            "the rerun has a different shape".into()
        } else {
            format!("{n} values differ bit for bit")
        },
    )
}

/// The checks that need one trajectory only.
pub fn check_single(scene: &Scene, tr: &Trajectory, tol: &Tolerances) -> InvariantReport {
    let finite = check_finite(tr);
    let complete = check_complete(scene, tr);
    let ok = finite.passed && complete.passed;
    let mut checks = vec![finite, complete];
    if ok {
        checks.push(check_penetration(scene, tr, tol));
        checks.push(check_energy(scene, tr, tol));
        checks.push(check_standing(scene, tr, tol));
    }
    InvariantReport { checks }
}

/// The mirror check of a run and its mirrored run; when the difference exceeds `mirror_rel`,
/// the shifted round-off probes are run to measure how much the motion amplifies round-off
/// (see [`check_mirror_with_probes`]). A failed probe run leaves the plain check.
pub fn mirror_check_run(
    engine: &dyn Engine,
    scene: &Scene,
    tr: &Trajectory,
    mirrored: &Trajectory,
    tol: &Tolerances,
) -> Check {
    let plain = check_mirror(scene, tr, mirrored, tol);
    if !plain.violated() || !plain.value.is_finite() {
        return plain;
    }
    let len = largest_dimension(scene);
    let mut probes = Vec::new();
    for f in PROBE_SHIFTS {
        let dx = f * len;
        match engine.run(&shifted_scene(scene, dx)) {
            Ok(o) => probes.push((dx, o.trajectory)),
            Err(_) => return plain,
        }
    }
    check_mirror_with_probes(scene, tr, mirrored, &probes, tol)
}

/// Which of the costly comparison runs to make.
#[derive(Debug, Clone, Copy)]
pub struct Extra {
    pub mirror: bool,
    pub rerun: bool,
}

/// Run `engine` on `scene` (and on its mirror and again, as asked) and check every invariant.
/// An engine error on the main run is returned as is; on the mirrored run or the rerun it is a
/// failed check.
pub fn run_checked(
    engine: &dyn Engine,
    scene: &Scene,
    tol: &Tolerances,
    extra: Extra,
) -> Result<(RunOutput, InvariantReport), EngineError> {
    let out = engine.run(scene)?;
    let mut report = check_single(scene, &out.trajectory, tol);
    if extra.mirror {
        let m = mirror_scene(scene);
        report.checks.push(match engine.run(&m) {
            Ok(mo) => mirror_check_run(engine, scene, &out.trajectory, &mo.trajectory, tol),
            Err(e) => Check::run_failed("mirror", e),
        });
    }
    if extra.rerun {
        report.checks.push(match engine.run(scene) {
            Ok(ro) => check_rerun(&out.trajectory, &ro.trajectory),
            Err(e) => Check::run_failed("rerun", e),
        });
    }
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_depth_of_axis_aligned_squares() {
        let a = vertices(1.0, 1.0, 0.0, 0.0, 0.0);
        let b = vertices(1.0, 1.0, 0.0, 0.9, 0.0);
        assert!((overlap_depth(&a, &b) - 0.1).abs() < 1e-12);
        let c = vertices(1.0, 1.0, 0.0, 1.0 + 1e-12, 0.0);
        assert_eq!(overlap_depth(&a, &c), 0.0);
        // A square rotated 45 degrees with its corner 0.05 into the top face.
        let r = std::f64::consts::FRAC_1_SQRT_2;
        let d = vertices(1.0, 1.0, 0.0, 0.5 + r - 0.05, std::f64::consts::FRAC_PI_4);
        assert!(
            (overlap_depth(&a, &d) - 0.05).abs() < 1e-12,
            "{}",
            overlap_depth(&a, &d)
        );
    }

    #[test]
    fn bit_differences_counts_changed_values() {
        let mut a = Trajectory::new(&["b".to_string()]);
        a.push(0.0, &[[0.0, 1.0, 0.1, 0.0, 0.0, 0.0]]);
        a.push(1.0, &[[0.0, 1.0, 0.1, 0.0, 0.0, 0.0]]);
        a.blocks[0].z[0] = 0.0;
        let mut b = a.clone();
        assert_eq!(bit_differences(&a, &b), 0);
        b.blocks[0].phi[1] = 0.1 + 1e-18; // the same f64: 1e-18 is below half an ulp of 0.1
        assert_eq!(bit_differences(&a, &b), 0);
        b.blocks[0].phi[1] = f64::from_bits(0.1f64.to_bits() + 1);
        assert_eq!(bit_differences(&a, &b), 1);
        b.blocks[0].z[0] = -0.0; // differs in sign only
        assert_eq!(bit_differences(&a, &b), 2);
    }
}
