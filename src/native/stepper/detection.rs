//! Contact detection at a state, and sleep: the blocks detection skips, the islands a
//! contact wakes and those a step puts to sleep (`native::sleep`).

use super::{CLOSED_GAP, NativeState, Stepper};
use crate::geometry::{BroadPhase, ContactPoint, Placed, Pose, block_contacts, ground_contacts};
use crate::native::assembly::{contact_rows, pose, poses};
use crate::native::problem::ContactRows;
use crate::native::sleep::{Sleep, rest_interval};
use crate::scene::AppliedAs;

/// Detection's working storage: the placed rectangles, the broad phase's and its pairs.
#[derive(Default)]
pub(super) struct Detection {
    placed: Vec<Placed>,
    broad: BroadPhase,
    pairs: Vec<(usize, usize)>,
}

impl Stepper {
    /// Contact points at the current geometry.
    pub fn detect(&self, s: &NativeState) -> Vec<ContactPoint> {
        let mut out = Vec::new();
        self.detect_into(s, &mut Detection::default(), &mut out);
        out
    }

    /// The interval of horizontal ground accelerations (m/s^2) under which every block stays at
    /// rest in the state `s`, all blocks taken together on the points closed there
    /// ([`rest_interval`]: the static theorem, exact for the associative law); `None` as there.
    pub fn rest_interval_of(&self, s: &NativeState) -> Option<(f64, f64)> {
        let blocks: Vec<usize> = (0..self.bodies.len()).collect();
        self.island_rest_interval(&self.detect(s), &poses(&s.q), &blocks)
    }

    /// [`rest_interval`] of the island `blocks` (increasing) on its closed points among
    /// `contacts`, at the poses `ps`.
    fn island_rest_interval(
        &self,
        contacts: &[ContactPoint],
        ps: &[Pose],
        blocks: &[usize],
    ) -> Option<(f64, f64)> {
        let rows: Vec<ContactRows> = contacts
            .iter()
            .filter(|c| c.gap <= CLOSED_GAP && blocks.binary_search(&c.b).is_ok())
            .map(|c| contact_rows(c, ps, self.bodies.friction(c), (0.0, 0.0)))
            .collect();
        rest_interval(blocks, &rows, &self.bodies.mass, self.gravity)
    }

    /// [`Stepper::detect`] into `out`, with `scratch` as working storage.
    fn detect_into(&self, s: &NativeState, scratch: &mut Detection, out: &mut Vec<ContactPoint>) {
        out.clear();
        let Detection {
            placed,
            broad,
            pairs,
        } = scratch;
        let dt = self.settings.dt;
        let frac = self.settings.contact_reach;
        let ground_z = match self.applied_as {
            AppliedAs::MovingGround => s.ground_d.1,
            AppliedAs::InertialForces => 0.0,
        };
        let ground_speed = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w.0.hypot(s.ground_w.1),
            AppliedAs::InertialForces => 0.0,
        };
        let speed = |i: usize, p: (f64, f64)| -> f64 {
            let (vx, vz, om) = (s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2]);
            let (rx, rz) = (p.0 - s.q[3 * i], p.1 - s.q[3 * i + 1]);
            // A reach, not a geometric quantity: sqrt is enough (and cheaper than hypot).
            let (wx, wz) = (vx - om * rz, vz + om * rx);
            (wx * wx + wz * wz).sqrt()
        };
        let asleep = |i: usize| self.sleep.as_ref().is_some_and(|sl| sl.asleep(i));
        if self.sleep.as_ref().is_some_and(Sleep::all_asleep) {
            return;
        }
        let rects = &self.bodies.rects;
        // The blocks detection considers: the island stepped alone, or every block.
        let scope = self.scope.as_deref();
        let member = |k: usize| scope.map_or(k, |blocks| blocks[k]);
        let count = scope.map_or(rects.len(), <[usize]>::len);
        placed.clear();
        placed.extend(
            (0..count)
                .map(member)
                .map(|i| Placed::new(&rects[i], &pose(&s.q, i))),
        );
        for (k, placed_i) in placed.iter().enumerate() {
            let i = member(k);
            if asleep(i) {
                continue;
            }
            let lim = frac * rects[i].min_dim();
            let reach = |p: (f64, f64), gap: f64| {
                gap < lim || gap < 3.0 * (speed(i, p) + ground_speed) * dt
            };
            ground_contacts(i, placed_i, ground_z, &reach, out);
        }
        let margin = |k: usize| {
            // A reach, not a geometric quantity: sqrt is enough (and cheaper than hypot).
            let i = member(k);
            let (vx, vz) = (s.v[3 * i], s.v[3 * i + 1]);
            frac * rects[i].min_dim() + 3.0 * (vx * vx + vz * vz).sqrt() * dt
        };
        if count < 2 {
            return;
        }
        broad.pairs_into(placed, &margin, pairs);
        for &(ki, kj) in pairs.iter() {
            let (i, j) = (member(ki), member(kj));
            if asleep(i) && asleep(j) {
                continue;
            }
            let lim = frac * rects[i].min_dim().min(rects[j].min_dim());
            let reach =
                |p: (f64, f64), gap: f64| gap < lim || gap < 3.0 * (speed(i, p) + speed(j, p)) * dt;
            block_contacts((i, &placed[ki]), (j, &placed[kj]), &reach, out);
        }
    }

    /// Contact points at the current geometry ([`Stepper::detect`]), after waking every
    /// sleeping island a point joins to an awake block.
    pub(super) fn detect_waking(&mut self, s: &NativeState) -> Vec<ContactPoint> {
        let mut contacts = std::mem::take(&mut self.work.contacts);
        let mut scratch = std::mem::take(&mut self.work.detection);
        loop {
            self.detect_into(s, &mut scratch, &mut contacts);
            let woke = self
                .sleep
                .as_mut()
                .is_some_and(|sl| sl.wake_touched(&contacts));
            if !woke {
                self.work.detection = scratch;
                return contacts;
            }
        }
    }

    /// Put to sleep the islands of blocks that have been still for the window and that the
    /// ground acceleration of the step just taken, `ax`, cannot move (see `native::sleep`).
    pub(super) fn fall_asleep(&mut self, s: &mut NativeState, ax: f64) {
        let Some(sl) = self.sleep.as_mut() else {
            return;
        };
        let extent: Vec<f64> = self
            .bodies
            .rects
            .iter()
            .map(|r| 2.0 * r.b.max(r.h))
            .collect();
        if !sl.observe(&s.v, &extent) {
            return;
        }
        let contacts = self.detect(s);
        let ps = poses(&s.q);
        let sl = self.sleep.as_ref().expect("sleep is on");
        let islands = sl.candidates(&contacts);
        for blocks in islands {
            let interval = self.island_rest_interval(&contacts, &ps, &blocks);
            let sl = self.sleep.as_mut().expect("sleep is on");
            let members = blocks.clone();
            if sl.try_sleep(blocks, interval, ax) {
                for b in members {
                    for k in 3 * b..3 * b + 3 {
                        s.v[k] = 0.0;
                        self.accel[k] = 0.0;
                    }
                }
            }
        }
        if let Some(sl) = self.sleep.as_mut() {
            sl.compact();
        }
    }
}
