//! Assembly of the one-step problem: mass, contact rows and free forces.
//!
//! Relative displacement at a contact point p: `du = du_B(p) - du_A(p)` with
//! `du_i(p) = (dx_i - dphi_i (p_z - z_i), dz_i + dphi_i (p_x - x_i))`; the rows are
//! `nrow = d(n·du)/d(dq)` and `trow = d(t·du)/d(dq)`, `t = (n_z, -n_x)`.

use super::problem::{ContactRows, SparseRow};
use crate::geometry::{ContactPoint, Pose, Rect};
use crate::scene::Scene;

/// Bodies of a scene as the native engine sees them.
#[derive(Debug, Clone)]
pub struct Bodies {
    pub rects: Vec<Rect>,
    /// Diagonal of M: (m, m, I) per block.
    pub mass: Vec<f64>,
    /// Friction with the ground, per block.
    pub ground_friction: Vec<f64>,
    /// Friction with other blocks, keyed by the upper (higher-index) block.
    pub block_friction: Vec<f64>,
}

impl Bodies {
    pub fn of(scene: &Scene) -> Bodies {
        let rects = scene
            .blocks
            .iter()
            .map(|b| Rect {
                b: b.width / 2.0,
                h: b.height / 2.0,
            })
            .collect();
        let mass = scene
            .blocks
            .iter()
            .flat_map(|b| [b.mass(), b.mass(), b.inertia()])
            .collect();
        let fr: Vec<f64> = (0..scene.blocks.len())
            .map(|i| scene.friction_below(i))
            .collect();
        Bodies {
            rects,
            mass,
            ground_friction: fr.clone(),
            block_friction: fr,
        }
    }
    pub fn len(&self) -> usize {
        self.rects.len()
    }
    pub fn is_empty(&self) -> bool {
        self.rects.is_empty()
    }
    pub fn friction(&self, c: &ContactPoint) -> f64 {
        match c.a {
            None => self.ground_friction[c.b],
            Some(a) => self.block_friction[a.max(c.b)],
        }
    }
}

pub fn poses(q: &[f64]) -> Vec<Pose> {
    let mut ps = Vec::new();
    poses_into(q, &mut ps);
    ps
}

/// [`poses`] into the caller's buffer.
pub fn poses_into(q: &[f64], ps: &mut Vec<Pose>) {
    ps.clear();
    ps.extend((0..q.len() / 3).map(|i| pose(q, i)));
}

/// Block `i`'s pose from the positions `q` (x, z, phi per block).
pub fn pose(q: &[f64], i: usize) -> Pose {
    Pose {
        x: q[3 * i],
        z: q[3 * i + 1],
        phi: q[3 * i + 2],
    }
}

/// Coefficients of `d·du_i(p)` on body i's DOFs for a direction d.
fn body_entries(
    i: usize,
    pose: &Pose,
    p: (f64, f64),
    d: (f64, f64),
    sign: f64,
) -> [(usize, f64); 3] {
    let rx = p.0 - pose.x;
    let rz = p.1 - pose.z;
    [
        (3 * i, sign * d.0),
        (3 * i + 1, sign * d.1),
        (3 * i + 2, sign * (-d.0 * rz + d.1 * rx)),
    ]
}

fn body_terms(row: &mut SparseRow, i: usize, pose: &Pose, p: (f64, f64), d: (f64, f64), sign: f64) {
    row.extend(body_entries(i, pose, p, d, sign));
}

/// The normal row of one contact point (the `nrow` of [`contact_rows`]) at the positions `q`,
/// without allocating: its entries and their number.
#[inline]
pub fn normal_row(c: &ContactPoint, q: &[f64]) -> ([(usize, f64); 6], usize) {
    row_along(c, q, c.normal)
}

/// The row of one contact point's relative displacement along `d` at the positions `q`
/// (`d` the normal: [`normal_row`]; its tangent `(n.1, -n.0)`: the `trow` of
/// [`contact_rows`]), without allocating: its entries and their number.
#[inline]
pub fn row_along(c: &ContactPoint, q: &[f64], d: (f64, f64)) -> ([(usize, f64); 6], usize) {
    let mut row = [(0, 0.0); 6];
    row[..3].copy_from_slice(&body_entries(c.b, &pose(q, c.b), c.point, d, 1.0));
    let Some(a) = c.a else {
        return (row, 3);
    };
    row[3..].copy_from_slice(&body_entries(a, &pose(q, a), c.point, d, -1.0));
    (row, 6)
}

/// Rows of one contact point; `ground_step` is the ground's displacement over the step.
pub fn contact_rows(
    c: &ContactPoint,
    poses: &[Pose],
    mu: f64,
    ground_step: (f64, f64),
) -> ContactRows {
    let mut rows = ContactRows::default();
    contact_rows_into(c, poses, mu, ground_step, &mut rows);
    rows
}

/// [`contact_rows`] written over `out` (a problem's rows are rebuilt in place every step).
pub fn contact_rows_into(
    c: &ContactPoint,
    poses: &[Pose],
    mu: f64,
    ground_step: (f64, f64),
    out: &mut ContactRows,
) {
    let n = c.normal;
    let t = (n.1, -n.0);
    out.nrow.clear();
    out.trow.clear();
    body_terms(&mut out.nrow, c.b, &poses[c.b], c.point, n, 1.0);
    body_terms(&mut out.trow, c.b, &poses[c.b], c.point, t, 1.0);
    if let Some(a) = c.a {
        body_terms(&mut out.nrow, a, &poses[a], c.point, n, -1.0);
        body_terms(&mut out.trow, a, &poses[a], c.point, t, -1.0);
    }
    let (g_n, g_t) = ground_offsets(c, ground_step);
    out.key = contact_key(c);
    out.mu = mu;
    out.g_n = c.gap + g_n;
    out.g_t = g_t;
}

/// The offsets a ground point's rows take from the ground's displacement `ground_step`,
/// `(-n·Δd, -t·Δd)` (none for a point between blocks).
pub fn ground_offsets(c: &ContactPoint, ground_step: (f64, f64)) -> (f64, f64) {
    if c.a.is_some() {
        return (0.0, 0.0);
    }
    let n = c.normal;
    let t = (n.1, -n.0);
    (
        -(n.0 * ground_step.0 + n.1 * ground_step.1),
        -(t.0 * ground_step.0 + t.1 * ground_step.1),
    )
}

/// A contact point's identity, stable between steps: its pair of bodies, in index order
/// (`0 << 40 | b << 16` for the ground), and its feature (which, for a pair of blocks, names the
/// face owner). The bits from 16 up name the pair's higher-indexed block. Detection makes a
/// pair's points together, so a step's keys come nearly sorted, and the sets of keys it sorts
/// are cheap to sort.
pub fn contact_key(c: &ContactPoint) -> u64 {
    let (low, high) = match c.a {
        None => (0, c.b),
        Some(a) => (a.min(c.b) + 1, a.max(c.b)),
    };
    ((low as u64) << 40) | ((high as u64) << 16) | c.feature as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_written_over_another_points_rows_are_that_points_rows() {
        let ps = [
            Pose {
                x: 0.0,
                z: 0.5,
                phi: 0.01,
            },
            Pose {
                x: 0.1,
                z: 1.5,
                phi: -0.02,
            },
        ];
        let between = ContactPoint {
            a: Some(0),
            b: 1,
            point: (0.3, 1.0),
            normal: (0.0, 1.0),
            gap: 1e-6,
            feature: 3,
        };
        let on_ground = ContactPoint {
            a: None,
            b: 0,
            point: (-0.5, 0.0),
            normal: (0.0, 1.0),
            gap: -2e-9,
            feature: 0,
        };
        let mut rows = contact_rows(&between, &ps, 0.7, (1e-3, 0.0));
        assert_eq!((rows.nrow.len(), rows.trow.len()), (6, 6));
        contact_rows_into(&on_ground, &ps, 0.5, (1e-3, 2e-4), &mut rows);
        let fresh = contact_rows(&on_ground, &ps, 0.5, (1e-3, 2e-4));
        assert_eq!(rows, fresh);
        assert_eq!(
            (rows.nrow.len(), rows.key, rows.mu),
            (3, contact_key(&on_ground), 0.5)
        );
        // The ground's displacement enters the offsets: `g_n = gap - n·Δd`, `g_t = -t·Δd`.
        assert_eq!((rows.g_n, rows.g_t), (-2e-9 - 2e-4, -1e-3));
    }
}
