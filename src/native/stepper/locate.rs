//! Impact instants located within a step (`native.locate_impacts`): the ordinary sub-step, the
//! new impacts it closes, the instant of the first, and the step redone in parts around it,
//! for the whole scene or island by island.

use super::{CLOSED_GAP, END_OF_STEP, NativeState, PENETRATION_TOLERANCE, StepError, Stepper};
use crate::geometry::ContactPoint;
use crate::native::assembly::{contact_key, contact_rows, normal_row, poses, row_along};
use crate::native::material::{Gradient, Increment, MaterialContact};
use crate::native::problem::{StepProblem, StepSolution};
use crate::native::settings::{FrictionLaw, SimultaneousImpacts};
use crate::scene::AppliedAs;

/// Sorted keys of the points of `pr` that `closed` marks (which points end closed, as the
/// discrete-gradient sub-step finds them), into `keys`.
fn closed_keys_into(pr: &StepProblem, closed: &[bool], keys: &mut Vec<u64>) {
    keys.clear();
    keys.extend(
        pr.contacts
            .iter()
            .zip(closed)
            .filter(|(_, l)| **l)
            .map(|(c, _)| c.key),
    );
    keys.sort_unstable();
}

/// Sorted keys of the points of `pr` that `closed` marks.
fn closed_keys(pr: &StepProblem, closed: &[bool]) -> Vec<u64> {
    let mut keys = Vec::new();
    closed_keys_into(pr, closed, &mut keys);
    keys
}

/// Smallest root in (0, h] of `g0 + b tau + c tau^2` with `g0 > 0`; without a real root, the
/// minimum if it lies in (0, h] (only asked for a point that the ordinary step closed).
pub(super) fn first_root(g0: f64, b: f64, c: f64, h: f64) -> Option<f64> {
    let roots: Vec<f64> = if c.abs() <= 1e-12 * b.abs().max(1e-300) / h {
        if b < 0.0 { vec![-g0 / b] } else { vec![] }
    } else {
        let disc = b * b - 4.0 * c * g0;
        if disc < 0.0 {
            // A graze: the closest approach, where the normal velocity is zero (the two roots
            // merge there as the graze deepens).
            if c > 0.0 {
                vec![-b / (2.0 * c)]
            } else {
                vec![]
            }
        } else {
            // Stable form of the two roots.
            let qq = -0.5 * (b + b.signum() * disc.sqrt());
            let mut r = vec![qq / c];
            if qq != 0.0 {
                r.push(g0 / qq);
            }
            r
        }
    };
    roots
        .into_iter()
        .filter(|&t| t > 0.0 && t <= h)
        .min_by(|a, b| a.total_cmp(b))
}

/// What a step started from, for `Stepper::locate_per_island`.
struct Start<'a> {
    state: &'a NativeState,
    /// The step's length.
    dt: f64,
    loaded: &'a [u64],
}

/// An island's part of the whole scene's ordinary step, handed to its own `step_locating` as
/// its first sub-step (the step problem is separable over islands).
pub(super) struct Taken {
    state: NativeState,
    solution: StepSolution,
    problem: StepProblem,
    closed: Vec<bool>,
    /// Its points' end gradients while its end velocity is not settled yet.
    unsettled: Option<Vec<(Gradient, Gradient, usize)>>,
}

/// The ordinary (unsplit) step of the whole scene, for `Stepper::locate_per_island`.
struct Ordinary<'a> {
    problem: &'a StepProblem,
    closed: &'a [bool],
    solution: &'a StepSolution,
    /// Its end gradients while its end velocity is not settled yet (`step_locating`).
    unsettled: Option<&'a [(Gradient, Gradient, usize)]>,
}

/// The most times the instant of a located impact is found again from the sub-step to it, when
/// that sub-step takes a located point through its face (see `step_locating`).
const INSTANT_REFINEMENTS: u32 = 4;

impl Stepper {
    /// Whether a closed point (gap within `CLOSED_GAP`) approaches faster than it would close
    /// `CLOSED_GAP` in a step, under the velocity-level law of the friction law: `n·v` under
    /// Coulomb's; `(n ± mu t)·v`, the cone's rows, under the associative law (a closed point
    /// sliding without lifting by `mu |slip|`, as a block launched along the ground starts:
    /// the mean-velocity law reflected its velocity about the cone, an elastic hop of 131 mm
    /// for 33 mm). If so, the points of the islands that hold such a point (all of them
    /// without `island_impacts`; the other islands need no impact).
    pub(super) fn approaching(
        &self,
        s: &NativeState,
        contacts: &[ContactPoint],
    ) -> Option<Vec<ContactPoint>> {
        let approaches = |c: &ContactPoint| {
            c.gap <= CLOSED_GAP && {
                let (nrow, len) = normal_row(c, &s.q);
                let vn = self.normal_speed(c, &nrow[..len], &s.v, s.ground_w);
                let approach = match self.settings.friction_law {
                    FrictionLaw::Coulomb => vn,
                    FrictionLaw::Associative => {
                        let t = (c.normal.1, -c.normal.0);
                        let (trow, len) = row_along(c, &s.q, t);
                        let vt = self.speed_along(c, t, &trow[..len], &s.v, s.ground_w);
                        vn - self.bodies.friction(c) * vt.abs()
                    }
                };
                approach * self.settings.dt < -CLOSED_GAP
            }
        };
        if !contacts.iter().any(approaches) {
            return None;
        }
        if !self.settings.island_impacts || self.bodies.len() == 1 {
            return Some(contacts.to_vec());
        }
        let island = crate::native::islands::components_of_points(self.bodies.len(), contacts);
        let struck = crate::native::islands::holding(
            &island,
            contacts.iter().filter(|c| approaches(c)).map(|c| c.b),
        );
        Some(
            contacts
                .iter()
                .filter(|c| island[c.b].is_some_and(|i| struck[i]))
                .copied()
                .collect(),
        )
    }

    /// The located points that take the impact at the instant reached (its points `at`): all
    /// of them under `simultaneous_impacts = "step"` (counted in `struck_open` when one is
    /// still open there); under `"instant"`, those at their faces, within `CLOSED_GAP` of the
    /// first to close, the others left to later rounds.
    fn striking_now(&mut self, at: &[ContactPoint], located: Vec<u64>) -> Vec<u64> {
        // The located points' gaps, in one pass over the points detected at the instant.
        let mut keys = located.clone();
        keys.sort_unstable();
        let gaps: Vec<(u64, f64)> = at
            .iter()
            .map(|c| (contact_key(c), c.gap))
            .filter(|(key, _)| keys.binary_search(key).is_ok())
            .collect();
        let first = gaps.iter().fold(f64::INFINITY, |m, g| m.min(g.1)).max(0.0);
        if self.settings.simultaneous_impacts == SimultaneousImpacts::Step {
            let widest = gaps.iter().fold(0.0f64, |m, g| m.max(g.1));
            if widest > first + CLOSED_GAP {
                self.struck_open += 1;
                self.widest_struck_gap = self.widest_struck_gap.max(widest);
            }
            return located;
        }
        let at_face = |key: &u64| {
            gaps.iter()
                .any(|(k, g)| k == key && *g <= first + CLOSED_GAP)
        };
        let at_faces: Vec<u64> = located.iter().copied().filter(at_face).collect();
        if at_faces.is_empty() {
            located
        } else {
            at_faces
        }
    }

    /// One step with the impact instants located.
    ///
    /// The ordinary (sub-)step is taken first. If a point that was open at its start and carried
    /// no force before carries one now (a new impact), the sub-step is retried without those
    /// points (a free trial); each one's gap within it is `g0 + vn0 tau + c2 tau^2` through its
    /// exact gap at the trial's end (`closing_instant`), and the impact instant is the smallest
    /// root. From the start: a sub-step to that instant (without the impacting points), a
    /// plastic impact on every closed point and the located ones (`impact`), and the rest of the
    /// step, located again: up to `native.located_per_step` impacts a step. New impacts left
    /// over (the cap reached, no instant found within the step, or slower than
    /// `native.locate_speed`) close at the end of their
    /// step under their position-level rows with the cone, anchored where each closes (moved by
    /// at most `gap / mu`): the ordinary sub-step, in which they were free of the cone, is
    /// redone (`under_cone`).
    pub(super) fn step_locating(
        &mut self,
        s: &mut NativeState,
        mut contacts: Vec<ContactPoint>,
        dt: f64,
        mut taken: Option<Taken>,
    ) -> Result<StepSolution, StepError> {
        let t_end = s.t + dt;
        let mut iterations = 0;
        let mut located_here: Vec<u64> = Vec::new();
        let rounds = self.settings.located_per_step as usize;
        // Impacts located per island (see `locate_per_island`).
        let per_island = self.settings.island_impacts
            && self.scope.is_none()
            && self.sleep.is_none()
            && self.bodies.len() > 1;
        for round in 0..=rounds {
            let h = t_end - s.t;
            let mut s0 = self.work.start.take().unwrap_or_else(|| s.clone());
            s0.clone_from(s);
            // The ordinary sub-step. Its end velocity is settled once it is kept (`unsettled`
            // holds its end gradients until then): a located impact throws it away.
            let (mut sol, mut pr, mut carries, mut unsettled) = match taken.take() {
                Some(t) => {
                    *s = t.state;
                    (t.solution, t.problem, t.closed, t.unsettled)
                }
                None => {
                    let (sol, pr, closed) = self.sub_step(s, &contacts, h, false)?;
                    let end = std::mem::take(&mut self.work.end_gradients);
                    (sol, pr, closed, Some(end))
                }
            };
            // New impacts: points that did not touch their faces at the start and end closed,
            // and points that touched them, left them and end closed (`free_until_it_closes`:
            // their rows had less friction than their interface, i.e. none; a frictionless
            // interface's points are freed of nothing). Those slower than `locate_speed` are
            // not located (`timed`): under the associative law they close at the end of the
            // step under their cone like the impacts left over below; under Coulomb's law,
            // whose points are never freed, they are not new impacts.
            let slowest = self.settings.locate_speed;
            let ps0 = std::cell::OnceCell::new();
            let touched = |k: usize| self.touches(&contacts[k], pr.contacts[k].key);
            let freed = |k: usize| self.freed_of_cone(&pr.contacts[k], &contacts[k]);
            let fast = |k: usize| {
                slowest <= 0.0 || {
                    let ps = ps0.get_or_init(|| poses(&s0.q));
                    self.approach_speed(&contacts[k], ps, &s0, h) >= slowest
                }
            };
            let fresh: Vec<usize> = (0..contacts.len())
                .filter(|&k| carries[k] && (freed(k) || (!touched(k) && fast(k))))
                .collect();
            let timed: Vec<usize> = fresh
                .iter()
                .copied()
                .filter(|&k| touched(k) || fast(k))
                .collect();
            if round == 0 && per_island && !fresh.is_empty() {
                // `self.loaded` is still the last step's: only the rounds below change it.
                let loaded0 = self.loaded.clone();
                let start = Start {
                    state: &s0,
                    dt,
                    loaded: &loaded0,
                };
                let ordinary = Ordinary {
                    problem: &pr,
                    closed: &carries,
                    solution: &sol,
                    unsettled: unsettled.as_deref(),
                };
                if let Some(sol) = self.locate_per_island(s, start, &contacts, &fresh, ordinary)? {
                    return Ok(sol);
                }
            }
            if round == rounds && !timed.is_empty() {
                // The cap reached: these close at the end of the step (below).
                self.capped_steps += 1;
                self.capped_impacts += timed.len() as u64;
            }
            let tau = if timed.is_empty() || round == rounds {
                None
            } else {
                let after_ordinary = s.clone();
                iterations += sol.iterations;
                // Free trial.
                *s = s0.clone();
                let free: Vec<ContactPoint> = (0..contacts.len())
                    .filter(|k| !fresh.contains(k))
                    .map(|k| contacts[k])
                    .collect();
                let (trial, trial_problem, _) = self.sub_step(s, &free, h, false)?;
                self.give_back(trial_problem);
                iterations += trial.iterations;
                self.give_back_solution(trial);
                let found = self.closing_instant(&s0, s, &contacts, &timed, h);
                let tau = found.filter(|&tau| tau < h - END_OF_STEP * dt);
                self.end_of_step_instants += u64::from(found.is_some() && tau.is_none());
                if tau.is_none() {
                    // The free motion does not close the points within the step (or closes them
                    // at its end, `END_OF_STEP`): keep the ordinary step.
                    *s = after_ordinary;
                    iterations -= sol.iterations;
                } else {
                    s.clone_from(&s0);
                }
                tau.map(|t| (t, free))
            };
            self.work.start = Some(s0);
            let Some((tau, free)) = tau else {
                if !fresh.is_empty() {
                    // New impacts left unlocated (the cap reached, no instant within the step,
                    // or slower than `locate_speed`) closed in the ordinary sub-step under the
                    // gap row alone, free of
                    // the cone: the sub-step is redone with their rows under the cone, and again
                    // with those of any point it closes free of the cone in turn.
                    let mut closing: Vec<usize> = fresh.clone();
                    while !closing.is_empty() {
                        // The problem's rows are the contacts' in order, with their keys.
                        self.under_cone
                            .extend(closing.iter().map(|&k| pr.contacts[k].key));
                        self.under_cone.sort_unstable();
                        iterations += sol.iterations;
                        self.give_back_solution(sol);
                        self.give_back(pr);
                        s.clone_from(self.work.start.as_ref().expect("the step's start"));
                        let redone = self.sub_step(s, &contacts, h, false);
                        (sol, pr, carries) = match redone {
                            Ok(r) => r,
                            Err(e) => {
                                self.under_cone.clear();
                                return Err(e);
                            }
                        };
                        unsettled = Some(std::mem::take(&mut self.work.end_gradients));
                        closing = (0..contacts.len())
                            .filter(|&k| {
                                carries[k] && self.freed_of_cone(&pr.contacts[k], &contacts[k])
                            })
                            .collect();
                    }
                    self.under_cone.clear();
                }
                if let Some(end) = unsettled.take() {
                    self.settle_kept(s, &contacts, &end, &carries, &pr, &mut sol)?;
                    self.work.end_gradients = end;
                }
                if !fresh.is_empty() {
                    // Those closing within the first half of the step closed under the
                    // velocity-level law, plastic, which leaves them up to `(1 - theta) h |v_n|`
                    // inside their faces, as impacts at step ends do.
                    self.project_out_penetration_of_step(s)?;
                }
                // The located points have just closed: not a new impact in the next step even if
                // the short rest of this one left them without a force (gap within the fall of
                // `g h^2/2`).
                closed_keys_into(&pr, &carries, &mut self.loaded);
                self.loaded.extend(&located_here);
                located_here.sort_unstable();
                located_here.dedup();
                self.struck = located_here;
                self.loaded.sort_unstable();
                self.loaded.dedup();
                sol.iterations += iterations;
                self.keep_contacts(contacts);
                self.give_back(pr);
                self.work.closed = carries;
                return Ok(sol);
            };
            self.give_back(pr);
            self.work.closed = carries;
            self.give_back_solution(sol);
            if let Some(end) = unsettled {
                self.work.end_gradients = end;
            }
            let located: Vec<u64> = {
                let ps = poses(&s.q);
                fresh
                    .iter()
                    .map(|&k| contact_rows(&contacts[k], &ps, 0.0, (0.0, 0.0)).key)
                    .collect()
            };
            // The sub-step to the impact instant, without the located points. Its motion is not
            // the free trial's (measured: a light plank just struck by a heavy block, whose
            // corner the trial closed at 3.1e-4 s, went 1.4 mm through the ground by then; a
            // block landing almost flat, whose other corner closed later in the trial, was put
            // 2 % late by it), so a located point found through its face at its end gives the
            // instant again from this sub-step's own motion (`closing_instant` on it, at most
            // `INSTANT_REFINEMENTS` times), else halves it; from an earlier instant reached, the
            // points are located again (they are not at their faces there: an impact on them
            // would stop the bodies in the air). Halved down to nothing, the impact is at the
            // start. (Halving alone, the landing block's corner was reached a little short of
            // its face round after round, its gap halved each time, until the rounds ran out
            // and the impact was left to the mean-velocity law, which rebounded it: 98 % of the
            // landing's kinetic energy kept instead of lost.)
            let mut tau = tau;
            let start = s.clone();
            let mut reached = false;
            let mut refinements = 0;
            let mut halved = false;
            while tau > 1e-9 * h {
                // Its end velocity is settled only when it is kept (no point through its face).
                let (mut first, pr, first_closed) = self.sub_step(s, &free, tau, false)?;
                let through = self.passed_through(&start, s, &contacts, &fresh);
                if !through {
                    let end = std::mem::take(&mut self.work.end_gradients);
                    let settled = self.settle_kept(s, &free, &end, &first_closed, &pr, &mut first);
                    self.work.end_gradients = end;
                    settled?;
                }
                iterations += first.iterations;
                self.give_back_solution(first);
                closed_keys_into(&pr, &first_closed, &mut self.loaded);
                self.give_back(pr);
                if !through {
                    reached = true;
                    break;
                }
                let again = (refinements < INSTANT_REFINEMENTS)
                    .then(|| self.closing_instant(&start, s, &contacts, &fresh, tau))
                    .flatten()
                    .filter(|&t| t < tau);
                *s = start.clone();
                match again {
                    Some(t) => {
                        tau = t;
                        refinements += 1;
                        self.refound_instants += 1;
                        halved = false;
                    }
                    None => {
                        tau *= 0.5;
                        self.halved_instants += 1;
                        halved = true;
                    }
                }
            }
            // Reached at a halved instant, the points are short of their faces: located again
            // from there. At the instant found (first or again), they are at their faces.
            if reached && halved {
                self.split_steps += 1;
                contacts = self.detect_waking(s);
                continue;
            }
            let at = self.detect_waking(s);
            let located = self.striking_now(&at, located);
            iterations += self
                .impact(s, &at, &located)
                .map_err(|failure| StepError::Solver {
                    step: s.step + 1,
                    t: s.t,
                    failure,
                })?;
            located_here.extend(&located);
            self.struck.extend(&located);
            self.struck.sort_unstable();
            self.struck.dedup();
            self.loaded.extend(&located);
            self.loaded.sort_unstable();
            self.loaded.dedup();
            self.split_steps += 1;
            contacts = self.detect_waking(s);
        }
        unreachable!("the last round returns")
    }

    /// Impacts located per island (`native.island_impacts`): after the ordinary step of the
    /// whole scene found new impacts (`fresh`, indices into `contacts`), each island of
    /// touching blocks that holds one goes on alone from its part of the ordinary step
    /// (`step_locating` on its own blocks and points, handed that part as its first sub-step);
    /// every other island keeps its ordinary step, which is its exact step (the step problem
    /// is separable over islands). So an island's step is split at its own impact instants
    /// only, whatever else the scene holds. `s` holds the ordinary step on entry and the step
    /// on return. Returns `None` (nothing done) when the islands with impacts are all the
    /// islands with contact points.
    fn locate_per_island(
        &mut self,
        s: &mut NativeState,
        start: Start,
        contacts: &[ContactPoint],
        fresh: &[usize],
        ordinary: Ordinary,
    ) -> Result<Option<StepSolution>, StepError> {
        let n = self.bodies.len();
        let island = crate::native::islands::components(n, &ordinary.problem.contacts);
        let hit = crate::native::islands::holding(&island, fresh.iter().map(|&k| contacts[k].b));
        if hit.iter().all(|&h| h) {
            return Ok(None);
        }
        let in_hit = |b: usize| island[b].is_some_and(|i| hit[i]);
        let mut sol = ordinary.solution.clone();
        if let Some(end) = ordinary.unsettled {
            // The islands without an impact keep their ordinary step: their end velocity is
            // settled here (the others settle theirs once they keep it, as they would alone).
            let keeping: Vec<bool> = (ordinary.closed.iter().zip(contacts))
                .map(|(&closed, c)| closed && !in_hit(c.b))
                .collect();
            self.settle_kept(s, contacts, end, &keeping, ordinary.problem, &mut sol)?;
        }
        // A point's key holds one of its blocks (`assembly::contact_key`), which is in the
        // point's island.
        let block_of_key = |key: u64| ((key >> 16) & 0xFF_FFFF) as usize;
        let mut loaded: Vec<u64> = closed_keys(ordinary.problem, ordinary.closed)
            .into_iter()
            .filter(|&key| !in_hit(block_of_key(key)))
            .collect();
        let mut last: Vec<ContactPoint> =
            contacts.iter().filter(|c| !in_hit(c.b)).copied().collect();
        // The acceleration of the ordinary step: the predictor of the free trial that follows.
        let after = self.accel.clone();
        let mut accel = after.clone();
        // The last step's struck points; after this one, those struck in it (by islands).
        let struck_before = std::mem::take(&mut self.struck);
        let mut struck = Vec::new();
        let (pr, whole) = (ordinary.problem, ordinary.solution);
        for i in (0..hit.len()).filter(|&i| hit[i]) {
            let blocks: Vec<usize> = (0..n).filter(|&b| island[b] == Some(i)).collect();
            let mine: Vec<usize> = (0..contacts.len())
                .filter(|&k| island[contacts[k].b] == Some(i))
                .collect();
            let points: Vec<ContactPoint> = mine.iter().map(|&k| contacts[k]).collect();
            let taken = Taken {
                state: s.clone(),
                solution: StepSolution {
                    dq: whole.dq.clone(),
                    normal: mine.iter().map(|&k| whole.normal[k]).collect(),
                    tangential: mine.iter().map(|&k| whole.tangential[k]).collect(),
                    // Counted with the whole step's.
                    iterations: 0,
                    polished: false,
                },
                problem: StepProblem {
                    theta: pr.theta,
                    dt: pr.dt,
                    mass: pr.mass.clone(),
                    force: pr.force.clone(),
                    v0: pr.v0.clone(),
                    contacts: mine.iter().map(|&k| pr.contacts[k].clone()).collect(),
                },
                closed: mine.iter().map(|&k| ordinary.closed[k]).collect(),
                unsettled: ordinary
                    .unsettled
                    .map(|end| mine.iter().map(|&k| end[k]).collect()),
            };
            let mut alone = start.state.clone();
            self.accel.copy_from_slice(&after);
            self.loaded.clear();
            self.loaded.extend_from_slice(start.loaded);
            self.struck.clone_from(&struck_before);
            self.scope = Some(blocks);
            let run = self.step_locating(&mut alone, points, start.dt, Some(taken));
            let blocks = self.scope.take().expect("set above");
            sol.iterations += run?.iterations;
            for b in blocks {
                let d = 3 * b..3 * b + 3;
                s.q[d.clone()].copy_from_slice(&alone.q[d.clone()]);
                s.v[d.clone()].copy_from_slice(&alone.v[d.clone()]);
                accel[d.clone()].copy_from_slice(&self.accel[d]);
            }
            loaded.append(&mut self.loaded);
            struck.append(&mut self.struck);
            last.append(&mut self.last_contacts);
            self.island_steps += 1;
        }
        loaded.sort_unstable();
        loaded.dedup();
        self.loaded = loaded;
        struck.sort_unstable();
        self.struck = struck;
        self.accel = accel;
        self.last_contacts = last;
        Ok(Some(sol))
    }

    /// Whether one of the `fresh` points (detected at `s0`) is through its face, by more than
    /// `PENETRATION_TOLERANCE`, at `s1`.
    fn passed_through(
        &self,
        s0: &NativeState,
        s1: &NativeState,
        contacts: &[ContactPoint],
        fresh: &[usize],
    ) -> bool {
        let ps = poses(&s0.q);
        let dq: Vec<f64> = s1.q.iter().zip(&s0.q).map(|(a, b)| a - b).collect();
        let increment = Increment::new(&dq, 1.0);
        fresh.iter().any(|&k| {
            let c = &contacts[k];
            let mut g = MaterialContact::new(c, &ps).gaps(&increment).0;
            if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
                let dd = (s1.ground_d.0 - s0.ground_d.0, s1.ground_d.1 - s0.ground_d.1);
                g -= c.normal.0 * dd.0 + c.normal.1 * dd.1;
            }
            g < -PENETRATION_TOLERANCE
        })
    }

    /// The instant within a sub-step of length `h` from `s0` at which the first of the `fresh`
    /// points closes, from the free trial's end state `s1` (see `step_locating`).
    fn closing_instant(
        &self,
        s0: &NativeState,
        s1: &NativeState,
        contacts: &[ContactPoint],
        fresh: &[usize],
        h: f64,
    ) -> Option<f64> {
        let ps = poses(&s0.q);
        let dq: Vec<f64> = s1.q.iter().zip(&s0.q).map(|(a, b)| a - b).collect();
        let mut tau: Option<f64> = None;
        let increment = Increment::new(&dq, 1.0);
        for &k in fresh {
            let c = &contacts[k];
            let r = contact_rows(c, &ps, 0.0, (0.0, 0.0));
            let vn0 = self.normal_speed(c, &r.nrow, &s0.v, s0.ground_w);
            // The gap within the step, `g0 + vn0 tau + c2 tau^2`, through the point's exact gap
            // at the end of the free trial (local error O(h^3) whatever the motion).
            let mut g1 = MaterialContact::new(c, &ps).gaps(&increment).0;
            if c.a.is_none() && self.applied_as == AppliedAs::MovingGround {
                let dd = (s1.ground_d.0 - s0.ground_d.0, s1.ground_d.1 - s0.ground_d.1);
                g1 -= c.normal.0 * dd.0 + c.normal.1 * dd.1;
            }
            // A point that left its face from within `CLOSED_GAP` of it closes where it
            // comes back to the face, not where it crosses a round-off penetration.
            let g0 = c.gap.max(0.0);
            let c2 = (g1 - g0 - vn0 * h) / (h * h);
            if let Some(t) = first_root(g0, vn0, c2, h) {
                tau = Some(tau.map_or(t, |x: f64| x.min(t)));
            }
        }
        tau
    }
}
