//! Contact points followed through a step as material points: the gap functions whose
//! gradients are the contact rows, evaluated away from the start of the step.
//!
//! A point detected at `q0` (location `p`, normal `n0` from A into B, gap `g0`) is carried by
//! both bodies: `p_i(q) = c_i + R(phi_i - phi_i0) (p - c_i0)` (the ground's point stays put),
//! and the normal turns with the face owner, `n(q) = R(phi_A - phi_A0) n0`, `t = (n_z, -n_x)`.
//! With `d = p_B - p_A`:
//!
//! ```text
//! g_n(q) = g0 + n(q)·d(q)        g_t(q) = t(q)·d(q)
//! ```
//!
//! For a vertex of B on a face of A, `g_n` is the exact distance of the vertex from the face
//! line whatever the motion; at `q0` the gradients are the rows of `assembly::contact_rows`.
//! The impact-consistent stepper takes its rows as a *discrete gradient* of these functions
//! between the ends of the step (Gonzalez's midpoint discrete gradient in the mass metric):
//!
//! ```text
//! G(q0, q1) = grad g(qm) + (g(q1) - g(q0) - grad g(qm)·dq) / (dq' M dq) M dq,  qm = (q0 + q1)/2
//! ```
//!
//! so that `g(q1) = g(q0) + G dq` exactly: a closed contact held by `G dq >= 0` does not drift
//! into or away from its face, and its force, complementary to `G dq`, does no work.

use super::problem::{ContactRows, SparseRow};
use crate::geometry::{ContactPoint, Pose};

/// One body's share of a contact point: its index, pose at the start of the step and the
/// point's offset from the centroid then.
#[derive(Debug, Clone, Copy)]
struct Carrier {
    body: usize,
    phi0: f64,
    rho: (f64, f64),
}

impl Carrier {
    fn new(body: usize, pose: &Pose, p: (f64, f64)) -> Self {
        Carrier {
            body,
            phi0: pose.phi,
            rho: (p.0 - pose.x, p.1 - pose.z),
        }
    }
    /// The offset turned to configuration `q`: `R(phi - phi0) rho`.
    fn arm(&self, q: &[f64]) -> (f64, f64) {
        rotate(self.rho, q[3 * self.body + 2] - self.phi0)
    }
    fn point(&self, q: &[f64]) -> (f64, f64) {
        let r = self.arm(q);
        (q[3 * self.body] + r.0, q[3 * self.body + 1] + r.1)
    }
}

fn rotate(v: (f64, f64), a: f64) -> (f64, f64) {
    let (s, c) = a.sin_cos();
    (c * v.0 - s * v.1, s * v.0 + c * v.1)
}

/// `perp(v) = (-v_z, v_x)`: the derivative of `R(a) v` with respect to `a`.
fn perp(v: (f64, f64)) -> (f64, f64) {
    (-v.1, v.0)
}

fn dot(a: (f64, f64), b: (f64, f64)) -> f64 {
    a.0 * b.0 + a.1 * b.1
}

/// A gradient over at most two bodies' DOFs: (DOF, coefficient), B's three then A's.
pub type Gradient = [(usize, f64); 6];

/// A contact point as a pair of material points (see the module docs).
#[derive(Debug, Clone, Copy)]
pub struct MaterialContact {
    a: Option<Carrier>,
    b: Carrier,
    /// Where A's point starts (the ground's point when A is the ground).
    p: (f64, f64),
    n0: (f64, f64),
    g0: f64,
}

impl MaterialContact {
    pub fn new(c: &ContactPoint, poses: &[Pose]) -> Self {
        MaterialContact {
            a: c.a.map(|a| Carrier::new(a, &poses[a], c.point)),
            b: Carrier::new(c.b, &poses[c.b], c.point),
            p: c.point,
            n0: c.normal,
            g0: c.gap,
        }
    }

    fn normal(&self, q: &[f64]) -> (f64, f64) {
        match &self.a {
            Some(a) => rotate(self.n0, q[3 * a.body + 2] - a.phi0),
            None => self.n0,
        }
    }

    fn separation(&self, q: &[f64]) -> (f64, f64) {
        let pb = self.b.point(q);
        let pa = self.a.as_ref().map_or(self.p, |a| a.point(q));
        (pb.0 - pa.0, pb.1 - pa.1)
    }

    /// `(g_n(q), g_t(q))`.
    pub fn gaps(&self, q: &[f64]) -> (f64, f64) {
        let n = self.normal(q);
        let t = (n.1, -n.0);
        let d = self.separation(q);
        (self.g0 + dot(n, d), dot(t, d))
    }

    /// Gradients of `g_n` and `g_t` at `q`, as (DOF, coefficient) pairs: B's three DOFs, then
    /// A's (the layout of `assembly::contact_rows`).
    pub fn gradients(&self, q: &[f64]) -> (Gradient, Gradient, usize) {
        let n = self.normal(q);
        let t = (n.1, -n.0);
        let mut gn = [(0, 0.0); 6];
        let mut gt = [(0, 0.0); 6];
        let ib = 3 * self.b.body;
        let rb = perp(self.b.arm(q));
        gn[0] = (ib, n.0);
        gn[1] = (ib + 1, n.1);
        gn[2] = (ib + 2, dot(n, rb));
        gt[0] = (ib, t.0);
        gt[1] = (ib + 1, t.1);
        gt[2] = (ib + 2, dot(t, rb));
        let Some(a) = &self.a else {
            return (gn, gt, 3);
        };
        let ia = 3 * a.body;
        let ra = perp(a.arm(q));
        let d = self.separation(q);
        gn[3] = (ia, -n.0);
        gn[4] = (ia + 1, -n.1);
        gn[5] = (ia + 2, -dot(n, ra) + dot(perp(n), d));
        gt[3] = (ia, -t.0);
        gt[4] = (ia + 1, -t.1);
        gt[5] = (ia + 2, -dot(t, ra) + dot(perp(t), d));
        (gn, gt, 6)
    }

    /// The discrete gradients of `g_n` and `g_t` between `q0` and `q1` (module docs), `mass` the
    /// diagonal of M. With no motion of the point's bodies, the gradient at `q0`.
    pub fn discrete_gradients(
        &self,
        q0: &[f64],
        q1: &[f64],
        mass: &[f64],
    ) -> (SparseRow, SparseRow) {
        let qm: Vec<f64> = q0.iter().zip(q1).map(|(a, b)| 0.5 * (a + b)).collect();
        let (mut gn, mut gt, len) = self.gradients(&qm);
        let dq = |i: usize| q1[i] - q0[i];
        let norm: f64 = gn[..len]
            .iter()
            .map(|&(i, _)| mass[i] * dq(i) * dq(i))
            .sum();
        if norm > 0.0 {
            let (n0, t0) = self.gaps(q0);
            let (n1, t1) = self.gaps(q1);
            let along = |g: &[(usize, f64)]| g.iter().map(|&(i, c)| c * dq(i)).sum::<f64>();
            let cn = (n1 - n0 - along(&gn[..len])) / norm;
            let ct = (t1 - t0 - along(&gt[..len])) / norm;
            for k in 0..len {
                let i = gn[k].0;
                gn[k].1 += cn * mass[i] * dq(i);
                gt[k].1 += ct * mass[i] * dq(i);
            }
        }
        (gn[..len].to_vec(), gt[..len].to_vec())
    }

    /// Replace the rows of `r` (built by `assembly::contact_rows` for this point) by the
    /// discrete gradients between `q0` and `q1`; offsets unchanged.
    pub fn set_rows(&self, r: &mut ContactRows, q0: &[f64], q1: &[f64], mass: &[f64]) {
        let (n, t) = self.discrete_gradients(q0, q1, mass);
        r.nrow = n;
        r.trow = t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ContactPoint;
    use crate::native::assembly::{contact_rows, poses};

    fn sample() -> (MaterialContact, Vec<f64>, ContactPoint) {
        let q0 = vec![0.1, 0.5, 0.2, -0.3, 1.4, -0.15];
        let c = ContactPoint {
            a: Some(0),
            b: 1,
            point: (0.05, 0.93),
            normal: (-(0.2f64.sin()), 0.2f64.cos()),
            gap: 1e-4,
            feature: 3,
        };
        (MaterialContact::new(&c, &poses(&q0)), q0, c)
    }

    #[test]
    fn gradients_at_the_start_are_the_assembly_rows() {
        let (m, q0, c) = sample();
        let r = contact_rows(&c, &poses(&q0), 0.0, (0.0, 0.0));
        let (gn, gt, len) = m.gradients(&q0);
        assert_eq!(len, 6);
        for (a, b) in gn.iter().zip(&r.nrow).chain(gt.iter().zip(&r.trow)) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).abs() < 1e-15, "{a:?} {b:?}");
        }
        let (gn, gt) = m.gaps(&q0);
        assert!((gn - 1e-4).abs() < 1e-17 && gt.abs() < 1e-16, "{gn} {gt}");
    }

    #[test]
    fn gradients_match_finite_differences() {
        let (m, q0, _) = sample();
        let q: Vec<f64> = q0.iter().map(|x| x + 0.07).collect();
        let (gn, gt, _) = m.gradients(&q);
        for k in 0..6 {
            let h = 1e-6;
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[gn[k].0] += h;
            qm[gn[k].0] -= h;
            let (np, tp) = m.gaps(&qp);
            let (nm, tm) = m.gaps(&qm);
            assert!(((np - nm) / (2.0 * h) - gn[k].1).abs() < 1e-8, "n {k}");
            assert!(((tp - tm) / (2.0 * h) - gt[k].1).abs() < 1e-8, "t {k}");
        }
    }

    #[test]
    fn the_discrete_gradient_is_exact_over_the_step() {
        let (m, q0, _) = sample();
        let q1: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.03 * (i as f64 - 2.5))
            .collect();
        let mass = [2.0, 2.0, 0.3, 5.0, 5.0, 0.9];
        let (gn, gt) = m.discrete_gradients(&q0, &q1, &mass);
        let along = |g: &SparseRow| g.iter().map(|&(i, c)| c * (q1[i] - q0[i])).sum::<f64>();
        let (n0, t0) = m.gaps(&q0);
        let (n1, t1) = m.gaps(&q1);
        assert!(
            (n0 + along(&gn) - n1).abs() < 1e-15,
            "{}",
            n0 + along(&gn) - n1
        );
        assert!((t0 + along(&gt) - t1).abs() < 1e-15);
    }
}
