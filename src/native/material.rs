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
//! Every point detection makes is a vertex of B on a face of A (`geometry::block_contacts`
//! makes the ends of a face-to-face overlap so, whichever block they belong to), and `g_n` is
//! the exact distance of the vertex from the face line whatever the motion; at `q0` the
//! gradients are the rows of `assembly::contact_rows`.
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
use std::cell::OnceCell;

/// An increment `k dq` from the start of the step (`k = 1/2`: the midpoint, without a copy of
/// `dq`), with each body's rotation over it computed once: `(sin a, cos a, cos a - 1)`, the
/// last as `-2 sin^2(a/2)` (see `Carrier::displacement`). Build one per increment and evaluate
/// all of a step's points with it: the trigonometry is per body, not per point.
pub struct Increment<'a> {
    dq: &'a [f64],
    k: f64,
    turns: Turns,
}

/// A body's rotation over an increment, `(sin a, cos a, cos a - 1)`.
type Turn = (f64, f64, f64);

/// Bodies whose turns an [`Increment`] computes at once and holds inline: the steps of small
/// scenes, the cheapest, build several increments each and allocate none.
const INLINE_BODIES: usize = 4;

/// The turns of an increment's bodies.
enum Turns {
    /// Every body's, computed at once (at most `INLINE_BODIES`).
    Few([Turn; INLINE_BODIES]),
    /// Computed when a point first asks (a step of one island among many asks for few bodies).
    Many(Vec<OnceCell<Turn>>),
}

/// Body `b`'s turn over the increment `k dq`.
#[inline]
fn turn_of(dq: &[f64], k: f64, b: usize) -> Turn {
    let a = k * dq[3 * b + 2];
    let (s, c) = a.sin_cos();
    let h = (0.5 * a).sin();
    (s, c, -2.0 * h * h)
}

impl<'a> Increment<'a> {
    pub fn new(dq: &'a [f64], k: f64) -> Self {
        let bodies = dq.len() / 3;
        let turns = if bodies <= INLINE_BODIES {
            let mut few = [(0.0, 1.0, 0.0); INLINE_BODIES];
            for (b, turn) in few.iter_mut().enumerate().take(bodies) {
                *turn = turn_of(dq, k, b);
            }
            Turns::Few(few)
        } else {
            Turns::Many(vec![OnceCell::new(); bodies])
        };
        Increment { dq, k, turns }
    }
    /// `(sin a, cos a, cos a - 1)` of body `b`'s rotation `a` over the increment.
    #[inline(always)]
    fn turn(&self, b: usize) -> Turn {
        match &self.turns {
            Turns::Few(turns) => turns[b],
            Turns::Many(cells) => *cells[b].get_or_init(|| turn_of(self.dq, self.k, b)),
        }
    }
    #[inline(always)]
    fn at(&self, i: usize) -> f64 {
        self.k * self.dq[i]
    }
    /// The whole increment (`k = 1`) as a slice.
    #[inline]
    fn whole(&self) -> &[f64] {
        debug_assert!(self.k == 1.0);
        self.dq
    }
}

type Incr<'b, 'a> = &'b Increment<'a>;

/// One body's share of a contact point: its index, and the point's offset from the centroid
/// at the start of the step.
#[derive(Debug, Clone, Copy)]
struct Carrier {
    body: usize,
    rho: (f64, f64),
}

impl Carrier {
    #[inline]
    fn new(body: usize, pose: &Pose, p: (f64, f64)) -> Self {
        Carrier {
            body,
            rho: (p.0 - pose.x, p.1 - pose.z),
        }
    }
    /// The offset turned by the step's increment `dq`: `R(dphi) rho`.
    #[inline(always)]
    fn arm(&self, dq: Incr) -> (f64, f64) {
        rotate(self.rho, dq.turn(self.body))
    }
    /// The point's displacement over the increment `dq`: `dc + (R(dphi) - I) rho`, formed from
    /// the increments alone so that it keeps their relative precision however far the body is
    /// from the origin (`cos a - 1 = -2 sin^2(a/2)`).
    #[inline(always)]
    fn displacement(&self, dq: Incr) -> (f64, f64) {
        let (s, _, cm1) = dq.turn(self.body);
        let i = 3 * self.body;
        (
            dq.at(i) + cm1 * self.rho.0 - s * self.rho.1,
            dq.at(i + 1) + s * self.rho.0 + cm1 * self.rho.1,
        )
    }
}

/// `R(a) v` for a rotation given as `(sin a, cos a, _)`.
#[inline(always)]
fn rotate(v: (f64, f64), (s, c, _): (f64, f64, f64)) -> (f64, f64) {
    (c * v.0 - s * v.1, s * v.0 + c * v.1)
}

/// `perp(v) = (-v_z, v_x)`: the derivative of `R(a) v` with respect to `a`.
#[inline(always)]
fn perp(v: (f64, f64)) -> (f64, f64) {
    (-v.1, v.0)
}

#[inline(always)]
fn dot(a: (f64, f64), b: (f64, f64)) -> f64 {
    a.0 * b.0 + a.1 * b.1
}

/// A gradient over at most two bodies' DOFs: (DOF, coefficient), B's three then A's.
pub type Gradient = [(usize, f64); 6];

/// A contact point as a pair of material points (see the module docs). Configurations are
/// given as increments `dq` from the start of the step, `q = q0 + dq`: both material points
/// start at the detected location, so the separation is a difference of displacements and the
/// gap functions keep the increments' relative precision (the discrete gradients divide by
/// `dq' M dq`).
#[derive(Debug, Clone, Copy)]
pub struct MaterialContact {
    a: Option<Carrier>,
    b: Carrier,
    n0: (f64, f64),
    g0: f64,
}

impl MaterialContact {
    #[inline]
    pub fn new(c: &ContactPoint, poses: &[Pose]) -> Self {
        MaterialContact {
            a: c.a.map(|a| Carrier::new(a, &poses[a], c.point)),
            b: Carrier::new(c.b, &poses[c.b], c.point),
            n0: c.normal,
            g0: c.gap,
        }
    }

    #[inline]
    fn normal(&self, dq: Incr) -> (f64, f64) {
        match &self.a {
            Some(a) => rotate(self.n0, dq.turn(a.body)),
            None => self.n0,
        }
    }

    /// `d = p_B - p_A` at `q0 + dq` (zero at `q0`).
    #[inline]
    fn separation(&self, dq: Incr) -> (f64, f64) {
        let db = self.b.displacement(dq);
        let da = self.a.as_ref().map_or((0.0, 0.0), |a| a.displacement(dq));
        (db.0 - da.0, db.1 - da.1)
    }

    /// `(g_n, g_t)` at `q0 + dq`.
    #[inline]
    pub fn gaps(&self, dq: Incr) -> (f64, f64) {
        let (dn, dt) = self.increments(dq);
        (self.g0 + dn, dt)
    }

    /// `(g_n - g0, g_t)` at `q0 + dq`: the change of the gaps over the increment.
    #[inline]
    pub fn increments(&self, dq: Incr) -> (f64, f64) {
        let n = self.normal(dq);
        let t = (n.1, -n.0);
        let d = self.separation(dq);
        (dot(n, d), dot(t, d))
    }

    /// Gradients of `g_n` and `g_t` at `q0 + dq`, as (DOF, coefficient) pairs: B's three DOFs,
    /// then A's (the layout of `assembly::contact_rows`).
    #[inline]
    pub fn gradients(&self, dq: Incr) -> (Gradient, Gradient, usize) {
        let n = self.normal(dq);
        self.gradients_along(dq, n, || self.separation(dq))
    }

    /// [`Self::increments`] and [`Self::gradients`] at `q0 + dq` together (the normal and the
    /// separation formed once).
    #[inline]
    pub fn increments_and_gradients(&self, dq: Incr) -> ((f64, f64), (Gradient, Gradient, usize)) {
        let n = self.normal(dq);
        let t = (n.1, -n.0);
        let d = self.separation(dq);
        ((dot(n, d), dot(t, d)), self.gradients_along(dq, n, || d))
    }

    /// The gradients at `q0 + dq` whose normal there is `n` (`separation` gives `d`, asked
    /// only of a point between two blocks).
    #[inline]
    fn gradients_along(
        &self,
        dq: Incr,
        n: (f64, f64),
        separation: impl FnOnce() -> (f64, f64),
    ) -> (Gradient, Gradient, usize) {
        let t = (n.1, -n.0);
        let mut gn = [(0, 0.0); 6];
        let mut gt = [(0, 0.0); 6];
        let ib = 3 * self.b.body;
        let rb = perp(self.b.arm(dq));
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
        let ra = perp(a.arm(dq));
        let d = separation();
        gn[3] = (ia, -n.0);
        gn[4] = (ia + 1, -n.1);
        gn[5] = (ia + 2, -dot(n, ra) + dot(perp(n), d));
        gt[3] = (ia, -t.0);
        gt[4] = (ia + 1, -t.1);
        gt[5] = (ia + 2, -dot(t, ra) + dot(perp(t), d));
        (gn, gt, 6)
    }

    /// The discrete gradients of `g_n` and `g_t` over the increment `dq` (module docs), given
    /// with its midpoint `half` (`Increment::new(dq, 0.5)`); `mass` the diagonal of M. With no
    /// motion of the point's bodies, the gradient at `q0`.
    pub fn discrete_gradients(&self, dq: Incr, half: Incr, mass: &[f64]) -> (SparseRow, SparseRow) {
        let (gn, gt, len) = self.discrete_gradient_entries(dq, half, mass);
        (
            SparseRow::from_slice(&gn[..len]),
            SparseRow::from_slice(&gt[..len]),
        )
    }

    /// [`Self::discrete_gradients`] as fixed arrays and their length.
    #[inline]
    fn discrete_gradient_entries(
        &self,
        dq: Incr,
        half: Incr,
        mass: &[f64],
    ) -> (Gradient, Gradient, usize) {
        let (mut gn, mut gt, len) = self.gradients(half);
        let dq_all = dq.whole();
        let norm: f64 = gn[..len]
            .iter()
            .map(|&(i, _)| mass[i] * dq_all[i] * dq_all[i])
            .sum();
        if norm > 0.0 {
            let (dn, dt) = self.increments(dq);
            let along = |g: &[(usize, f64)]| g.iter().map(|&(i, c)| c * dq_all[i]).sum::<f64>();
            let cn = (dn - along(&gn[..len])) / norm;
            let ct = (dt - along(&gt[..len])) / norm;
            for k in 0..len {
                let i = gn[k].0;
                gn[k].1 += cn * mass[i] * dq_all[i];
                gt[k].1 += ct * mass[i] * dq_all[i];
            }
        }
        (gn, gt, len)
    }

    /// Replace the rows of `r` (built by `assembly::contact_rows` for this point) by the
    /// discrete gradients over the increment `dq` (with its midpoint `half`); offsets unchanged.
    #[inline]
    pub fn set_rows(&self, r: &mut ContactRows, dq: Incr, half: Incr, mass: &[f64]) {
        let (n, t, len) = self.discrete_gradient_entries(dq, half, mass);
        r.nrow.clear();
        r.nrow.extend_from_slice(&n[..len]);
        r.trow.clear();
        r.trow.extend_from_slice(&t[..len]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ContactPoint;
    use crate::native::assembly::{contact_rows, poses};

    fn sample(offset: f64) -> (MaterialContact, Vec<f64>, ContactPoint) {
        let q0 = vec![0.1 + offset, 0.5, 0.2, -0.3 + offset, 1.4, -0.15];
        let c = ContactPoint {
            a: Some(0),
            b: 1,
            point: (0.05 + offset, 0.93),
            normal: (-(0.2f64.sin()), 0.2f64.cos()),
            gap: 1e-4,
            feature: 3,
        };
        (MaterialContact::new(&c, &poses(&q0)), q0, c)
    }

    fn along(g: &SparseRow, dq: &[f64]) -> f64 {
        g.iter().map(|&(i, c)| c * dq[i]).sum()
    }

    #[test]
    fn gradients_at_the_start_are_the_assembly_rows() {
        let (m, q0, c) = sample(0.0);
        let r = contact_rows(&c, &poses(&q0), 0.0, (0.0, 0.0));
        let (gn, gt, len) = m.gradients(&Increment::new(&[0.0; 6], 1.0));
        assert_eq!(len, 6);
        for (a, b) in gn.iter().zip(&r.nrow).chain(gt.iter().zip(&r.trow)) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).abs() < 1e-15, "{a:?} {b:?}");
        }
        assert_eq!(m.gaps(&Increment::new(&[0.0; 6], 1.0)), (1e-4, 0.0));
    }

    /// Over a large motion (slip and both bodies turned), the normal gap is the distance of B's
    /// vertex from A's face line (`geometry::block_contacts` makes every point a vertex on a
    /// face, so this holds for all of them).
    #[test]
    fn the_normal_gap_is_the_vertex_distance_from_the_face_line() {
        let turned = |v: (f64, f64), a: f64| rotate(v, (a.sin(), a.cos(), 0.0));
        let (m, q0, c) = sample(0.0);
        let dq = [0.03, -0.01, 0.2, -0.05, 0.02, -0.3];
        let (gn, _) = m.gaps(&Increment::new(&dq, 1.0));
        // Where a material point of body `i` at `p` (at q0) is at q0 + dq.
        let moved = |i: usize, p: (f64, f64)| {
            let arm = turned((p.0 - q0[3 * i], p.1 - q0[3 * i + 1]), dq[3 * i + 2]);
            (
                q0[3 * i] + dq[3 * i] + arm.0,
                q0[3 * i + 1] + dq[3 * i + 1] + arm.1,
            )
        };
        let n0 = c.normal;
        // A's face line passes `gap` below the vertex at q0, and turns with A.
        let on_face = (c.point.0 - c.gap * n0.0, c.point.1 - c.gap * n0.1);
        let (v, f, n) = (moved(1, c.point), moved(0, on_face), turned(n0, dq[2]));
        let exact = dot(n, (v.0 - f.0, v.1 - f.1));
        assert!((gn - exact).abs() < 1e-15, "{gn:e} against {exact:e}");
    }

    #[test]
    fn gradients_match_finite_differences() {
        let (m, _, _) = sample(0.0);
        let dq = [0.07; 6];
        let (gn, gt, _) = m.gradients(&Increment::new(&dq, 1.0));
        for k in 0..6 {
            let h = 1e-6;
            let (mut qp, mut qm) = (dq, dq);
            qp[gn[k].0] += h;
            qm[gn[k].0] -= h;
            let (np, tp) = m.gaps(&Increment::new(&qp, 1.0));
            let (nm, tm) = m.gaps(&Increment::new(&qm, 1.0));
            assert!(((np - nm) / (2.0 * h) - gn[k].1).abs() < 1e-8, "n {k}");
            assert!(((tp - tm) / (2.0 * h) - gt[k].1).abs() < 1e-8, "t {k}");
        }
    }

    #[test]
    fn the_discrete_gradient_is_exact_over_the_step() {
        let (m, _, _) = sample(0.0);
        let dq: Vec<f64> = (0..6).map(|i| 0.03 * (i as f64 - 2.5)).collect();
        let mass = [2.0, 2.0, 0.3, 5.0, 5.0, 0.9];
        let (whole, half) = (Increment::new(&dq, 1.0), Increment::new(&dq, 0.5));
        let (gn, gt) = m.discrete_gradients(&whole, &half, &mass);
        let (n1, t1) = m.gaps(&whole);
        assert!((1e-4 + along(&gn, &dq) - n1).abs() < 1e-15);
        assert!((along(&gt, &dq) - t1).abs() < 1e-15);
    }

    /// Tiny increments of bodies far from the origin: the discrete gradient stays within
    /// round-off of the midpoint gradient (its correction is O(|dq|^2)), where gaps formed
    /// from absolute positions would divide their round-off by `dq' M dq`.
    #[test]
    fn the_discrete_gradient_of_a_tiny_increment_is_the_midpoint_gradient() {
        let (m, _, _) = sample(1000.0);
        let mass = [2.0, 2.0, 0.3, 5.0, 5.0, 0.9];
        for scale in [1e-6, 1e-9, 1e-12] {
            let dq: Vec<f64> = (0..6).map(|i| scale * (i as f64 - 2.5)).collect();
            let halved: Vec<f64> = dq.iter().map(|d| 0.5 * d).collect();
            let (mn, mt, len) = m.gradients(&Increment::new(&halved, 1.0));
            let (whole, half) = (Increment::new(&dq, 1.0), Increment::new(&dq, 0.5));
            let (gn, gt) = m.discrete_gradients(&whole, &half, &mass);
            for k in 0..len {
                assert!((gn[k].1 - mn[k].1).abs() < 1e-9, "{scale} n {k}");
                assert!((gt[k].1 - mt[k].1).abs() < 1e-9, "{scale} t {k}");
            }
        }
    }
}
