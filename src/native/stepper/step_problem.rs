//! A (sub-)step's problem: its rows at the start poses, and which points are free of their
//! friction cone until they close.

use super::locate::first_root;
use super::{CLOSED_GAP, GroundStep, NativeState, Stepper, row_dot};
use crate::geometry::{ContactPoint, Pose};
use crate::native::assembly::{contact_rows, contact_rows_into, poses};
use crate::native::material::{Increment, MaterialContact};
use crate::native::problem::{ContactRows, StepProblem};
use crate::native::settings::{FrictionLaw, StepperKind};
use crate::scene::AppliedAs;

impl Stepper {
    /// Build the problem of the next step into `pr` (its buffers reused), from the poses `ps`
    /// of `s`; returns the ground increment.
    pub(super) fn problem(
        &self,
        s: &NativeState,
        contacts: &[ContactPoint],
        dt: f64,
        ps: &[Pose],
        pr: &mut StepProblem,
    ) -> GroundStep {
        let g = self.ground_step(s, dt);
        let n = self.bodies.len();
        let (ax, az) = match self.applied_as {
            AppliedAs::InertialForces => g.a_eff,
            AppliedAs::MovingGround => (0.0, 0.0),
        };
        let force = &mut pr.force;
        force.clear();
        force.resize(3 * n, 0.0);
        for i in 0..n {
            if self.sleep.as_ref().is_some_and(|sl| sl.asleep(i)) {
                // No force and no contact point: the step leaves a sleeping block in place.
                continue;
            }
            let m = self.bodies.mass[3 * i];
            force[3 * i] = -m * ax;
            force[3 * i + 1] = -m * (self.gravity + az);
        }
        let ground_step = match self.applied_as {
            AppliedAs::MovingGround => g.dd,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let th = self.kinematic_weight();
        let w0 = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let force = &pr.force;
        let free_motion = std::cell::OnceCell::new();
        // Rows written in place over the last step's (a point's rows are some 240 bytes).
        pr.contacts.truncate(contacts.len());
        pr.contacts
            .resize_with(contacts.len(), ContactRows::default);
        for (c, r) in contacts.iter().zip(pr.contacts.iter_mut()) {
            contact_rows_into(c, ps, self.bodies.friction(c), ground_step, r);
            if self.settings.stepper == StepperKind::Impact {
                // Relative velocity at the start of the step.
                let (mut vn, mut vt) = (row_dot(&r.nrow, &s.v), row_dot(&r.trow, &s.v));
                if c.a.is_none() {
                    let n = c.normal;
                    vn -= n.0 * w0.0 + n.1 * w0.1;
                    vt -= n.1 * w0.0 - n.0 * w0.1;
                }
                // Closing within the first half of the step, its impact not located (impacts
                // not located, or this one left over: `under_cone`). Its position-level row
                // would reflect it: `v = 2 dq/h - v0` with `dq_n >= -gap` separates.
                let velocity_level = c.gap > CLOSED_GAP
                    && (!self.settings.locate_impacts
                        || self.under_cone.binary_search(&r.key).is_ok())
                    && c.gap + (1.0 - th) * dt * vn <= 0.0;
                if c.gap <= CLOSED_GAP {
                    // Closed: `g0+ + G dq >= 0` with the discrete-gradient rows, i.e. the
                    // mean relative velocity of the step does not approach (a penetration
                    // at round-off level is held, not pushed out: that would do work).
                    r.g_n += c.gap.max(0.0) - c.gap;
                } else if velocity_level {
                    // Closing within the first half of the step, its impact not located: the
                    // velocity-level law on the end-of-step relative
                    // velocity, (n ± mu t)·v >= 0, i.e.
                    // (nrow ± mu trow) dq - (n ± mu t)·Δd - (1 - w) dt (v_n0 ± mu v_t0) >= 0:
                    // plastic, no rebound.
                    r.g_n += -c.gap - (1.0 - th) * dt * vn;
                    r.g_t += -(1.0 - th) * dt * vt;
                }
                let leaves = || {
                    // The point's gap at the end of the step's free motion,
                    // `dq = h v0 + h^2/2 M^-1 f` (exact gap function).
                    let dq = free_motion.get_or_init(|| {
                        (0..3 * n)
                            .map(|i| dt * s.v[i] + 0.5 * dt * dt * force[i] / self.bodies.mass[i])
                            .collect::<Vec<f64>>()
                    });
                    let mut g = MaterialContact::new(c, ps).gaps(&Increment::new(dq, 1.0)).0;
                    if c.a.is_none() {
                        g -= c.normal.0 * ground_step.0 + c.normal.1 * ground_step.1;
                    }
                    g
                };
                if self.free_until_it_closes(c, r.key, vn, dt, leaves) {
                    if self.under_cone.binary_search(&r.key).is_err() {
                        // Open, or leaving its face: no force before it touches (the gap row
                        // alone); its closing is located.
                        r.mu = 0.0;
                    } else if c.gap > CLOSED_GAP && !velocity_level {
                        // Left unlocated, it closes under its cone anchored where it closes:
                        // the slip of its approach is no slip on its face. The instant is the
                        // free motion's closing instant, or the step's end. The anchor moves by
                        // at most `gap / mu`, so that the step's start satisfies the rows: an
                        // anchor the motion does not reach would lift the point, doing work.
                        let c2 = (leaves() - c.gap - vn * dt) / (dt * dt);
                        let slip = vt * first_root(c.gap, vn, c2, dt).unwrap_or(dt);
                        let most = c.gap / r.mu.max(f64::MIN_POSITIVE);
                        r.g_t -= slip.clamp(-most, most);
                    }
                }
            }
        }
        pr.theta = th;
        pr.dt = dt;
        pr.mass.clone_from(&self.bodies.mass);
        pr.v0.clone_from(&s.v);
        g
    }

    /// The problem the next step would solve (for replay and cross-checks).
    pub fn next_problem(&self, s: &NativeState) -> StepProblem {
        let c = self.detect(s);
        let mut pr = StepProblem::default();
        self.problem(s, &c, self.settings.dt, &poses(&s.q), &mut pr);
        pr
    }

    /// How fast an open point `c` approaches over a (sub-)step of length `h` from `s`: its
    /// approach speed at the start or the mean speed that closes its gap within `h`, the larger.
    pub(super) fn approach_speed(
        &self,
        c: &ContactPoint,
        ps: &[Pose],
        s: &NativeState,
        h: f64,
    ) -> f64 {
        let r = contact_rows(c, ps, 0.0, (0.0, 0.0));
        (-self.normal_speed(c, &r.nrow, &s.v, s.ground_w)).max(c.gap / h)
    }

    /// Whether a point (detected as `c`, its rows' key `key`) touches its face at the start of a
    /// (sub-)step: closed, or loaded at the end of the last step (its closing is no new impact).
    pub(super) fn touches(&self, c: &ContactPoint, key: u64) -> bool {
        c.gap <= CLOSED_GAP || self.loaded.binary_search(&key).is_ok()
    }

    /// Whether a point's rows `r` (of the point detected as `c`) were freed of its friction cone
    /// (`free_until_it_closes`): they have less friction than its interface, i.e. none.
    pub(super) fn freed_of_cone(&self, r: &ContactRows, c: &ContactPoint) -> bool {
        r.mu < self.bodies.friction(c)
    }

    /// Whether a point (detected as `c`, its rows' key `key`, normal relative velocity `vn` at
    /// the start of a (sub-)step of length `h`; `free_gap` gives its gap at the end of the
    /// step's free motion) is free of the friction cone until it closes, under the associative
    /// law with impacts located:
    /// - a point that does not touch its face (open, and not located in the last step);
    /// - a point struck by a located impact in this step or the last that touches its face and
    ///   leaves it: it separates (`vn h > CLOSED_GAP`) and its free motion ends the step open
    ///   (a plastic impact with slip leaves a point at `v_n = mu |v_t|`). A pivot the block
    ///   keeps is never freed: its normal velocity at a step's start, O(h^2) from the chord of
    ///   the step, is below the fall of its free motion. The pivot a rocking block lifts off
    ///   was struck by nothing and keeps its cone.
    ///
    /// Such a point carries no force before it touches, as the law says of an open point; the
    /// cone, anchored where the step starts, would bear on it once it slid `|slip| >= gap / mu`
    /// (an O(h) force on a point in the air: the two-block case's pedestal hops after its ground
    /// impact came out different at every dt). Its rows have `mu = 0` (the gap alone), and its
    /// closing is a new impact, whose plastic law is the cone: located, or, approaching slower
    /// than `locate_speed`, closed at the end of its step under the cone anchored where it
    /// closes (`step_locating`). (Left under the cone anchored where the step starts, such slow
    /// closings let a wall just above its static collapse acceleration creep where it must
    /// rest: `tests/walls.rs`, `a_running_bond_wall_starts_to_move_at_its_static_collapse_acceleration`.)
    fn free_until_it_closes(
        &self,
        c: &ContactPoint,
        key: u64,
        vn: f64,
        h: f64,
        free_gap: impl FnOnce() -> f64,
    ) -> bool {
        if self.settings.friction_law != FrictionLaw::Associative || !self.settings.locate_impacts {
            return false;
        }
        if self.touches(c, key) {
            self.struck.binary_search(&key).is_ok()
                && vn * h > CLOSED_GAP
                && free_gap() > CLOSED_GAP
        } else {
            true
        }
    }

    /// Normal relative velocity of a point for block velocities `v` and ground velocity `w`
    /// (the ground's counts only when the ground moves), from the point's rows.
    pub(super) fn normal_speed(
        &self,
        c: &ContactPoint,
        nrow: &[(usize, f64)],
        v: &[f64],
        w: (f64, f64),
    ) -> f64 {
        self.speed_along(c, c.normal, nrow, v, w)
    }

    /// Relative velocity of a point along `d` (its row along `d`,
    /// [`row_along`](crate::native::assembly::row_along)) for block
    /// velocities `v` and ground velocity `w` (counted only when the ground moves).
    pub(super) fn speed_along(
        &self,
        c: &ContactPoint,
        d: (f64, f64),
        row: &[(usize, f64)],
        v: &[f64],
        w: (f64, f64),
    ) -> f64 {
        let mut speed = row_dot(row, v);
        if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
            speed -= d.0 * w.0 + d.1 * w.1;
        }
        speed
    }
}
