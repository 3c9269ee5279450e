//! The impact stepper's sub-step: rows that are discrete gradients of each point's gap
//! functions between the ends of the sub-step, re-evaluated until the loaded points do not
//! drift (`DRIFT_TOLERANCE`).

use super::{
    CLOSED_GAP, CONVERGED_DRIFT, DISCRETE_GRADIENT_SOLVES, DRIFT_TOLERANCE, Islands, NativeState,
    StepError, Stepper, row_dot,
};
use crate::geometry::{ContactPoint, Pose};
use crate::native::assembly::poses_into;
use crate::native::islands::holding_into;
use crate::native::material::{Gradient, Increment, MaterialContact};
use crate::native::problem::{StepProblem, StepSolution};
use crate::native::settings::{FrictionLaw, StepperKind};
use crate::native::solver::SolveFailure;

/// No gradients (a point that does not end closed).
const NO_GRADIENTS: (Gradient, Gradient, usize) = ([(0, 0.0); 6], [(0, 0.0); 6], 0);

/// Whether each point of a step problem is closed at the end of its solution: its gap,
/// `g_n + n·dq` (under the associative law the lower edge row, `g_n + n·dq - mu |g_t + t·dq|`,
/// whose dilatancy lifts a sliding point by exactly `mu |slip|`) within `CLOSED_GAP`. The
/// impact stepper decides by this, not by which points carry a force: the displacement of a
/// solution is unique, its forces are not (a flat interface has four rows on three relative
/// DOFs, and each back-end splits the load between its two points its own way; deciding by
/// force, Clarabel and the active-set back-end gave the two-block case's first crossing of the
/// statue 7 ms apart).
fn closed_into(pr: &StepProblem, sol: &StepSolution, law: FrictionLaw, closed: &mut Vec<bool>) {
    closed.clear();
    closed.extend(pr.contacts.iter().map(|c| {
        let n = c.g_n + row_dot(&c.nrow, &sol.dq);
        let gap = match law {
            FrictionLaw::Associative => n - c.mu * (c.g_t + row_dot(&c.trow, &sol.dq)).abs(),
            FrictionLaw::Coulomb => n,
        };
        gap <= CLOSED_GAP
    }));
}

impl Stepper {
    /// Advance by `h` from the given contacts. `kept`: whether the sub-step's end state is
    /// known to be kept. A kept one settles its end velocity (impact stepper) and projects out
    /// a penetration (impact stepper without impact location). `step_locating` passes `false`
    /// for the sub-steps whose end it may throw away (the ordinary sub-step and the sub-step to
    /// an impact instant, both until their end positions are judged; the free trial always):
    /// their end velocity, a whole-island velocity problem, is settled
    /// (`settle_velocity`) only once they are kept, from the end gradients this call
    /// leaves in `self.work.end_gradients`.
    /// Returns the step's solution, its problem and, under the impact stepper, which of its
    /// points end closed ([`closed_into`]; empty under the paper's).
    pub(super) fn sub_step(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        h: f64,
        kept: bool,
    ) -> Result<(StepSolution, StepProblem, Vec<bool>), StepError> {
        let mut pr = self.spare_problem();
        let mut ps = std::mem::take(&mut self.work.poses);
        poses_into(&s.q, &mut ps);
        let g = self.problem(s, contacts, h, &ps, &mut pr);
        let fail = |failure| StepError::Solver {
            step: s.step + 1,
            t: s.t,
            failure,
        };
        let impact = self.settings.stepper == StepperKind::Impact;
        let solved = if impact {
            self.solve_discrete_gradient(s, contacts, &ps, &mut pr, h)
        } else {
            // The paper's stepper locates no impacts: nothing asks which points end closed.
            let mut sol = self.spare_solution();
            self.solve_law_into(&pr, &mut sol)
                .map(|()| (sol, Vec::new(), 0.0))
        };
        self.work.poses = ps;
        let (mut sol, ends_closed, drift) = solved.map_err(fail)?;
        if drift > CONVERGED_DRIFT {
            self.give_back_solution(sol);
            self.give_back(pr);
            return Err(StepError::Unconverged {
                step: s.step + 1,
                t: s.t,
                h,
                drift,
            });
        }
        let th = self.kinematic_weight();
        for i in 0..s.q.len() {
            let v = (sol.dq[i] / h - (1.0 - th) * s.v[i]) / th;
            if impact {
                self.accel[i] = (v - s.v[i]) / h;
            }
            s.v[i] = v;
            s.q[i] += sol.dq[i];
        }
        s.ground_d.0 += g.dd.0;
        s.ground_d.1 += g.dd.1;
        s.ground_w = g.w1;
        s.t += h;
        // The instant `g` took the ground to (`ground_step`'s `t1`).
        s.ground_t = s.t;
        self.iterations += sol.iterations as u64;
        self.polished_steps += sol.polished as u64;
        if impact && kept {
            let end = std::mem::take(&mut self.work.end_gradients);
            let settled = self.settle_kept(s, contacts, &end, &ends_closed, &pr, &mut sol);
            self.work.end_gradients = end;
            settled?;
        }
        if kept && impact && !self.settings.locate_impacts {
            self.project_out_penetration_of_step(s)?;
        }
        if !s.q.iter().chain(&s.v).all(|x| x.is_finite()) {
            return Err(StepError::NonFinite {
                step: s.step + 1,
                t: s.t,
            });
        }
        Ok((sol, pr, ends_closed))
    }

    /// The impact stepper's solve: the rows of every point are the discrete gradients of its gap
    /// functions between `q0` and a predicted end of the step (`native::material`), first from
    /// the last smooth acceleration, `q1 = q0 + h v0 + h^2 a/2`, then from each solution, until
    /// the loaded points' gaps at the solution's end agree with the rows to `DRIFT_TOLERANCE`
    /// (at most `DISCRETE_GRADIENT_SOLVES` solves; every one conserves energy exactly, the
    /// iteration only removes the drift of the closed contacts). The closed points' gradients
    /// at the end are left in `self.work.end_gradients` (for `settle_velocity`).
    fn solve_discrete_gradient(
        &mut self,
        s: &NativeState,
        contacts: &[ContactPoint],
        ps: &[Pose],
        pr: &mut StepProblem,
        h: f64,
    ) -> Result<(StepSolution, Vec<bool>, f64), SolveFailure> {
        let mut points = std::mem::take(&mut self.work.points);
        points.clear();
        points.extend(contacts.iter().map(|c| MaterialContact::new(c, ps)));
        let mut dq = std::mem::take(&mut self.work.dq);
        dq.clear();
        dq.extend((0..s.q.len()).map(|i| h * s.v[i] + 0.5 * h * h * self.accel[i]));
        let mut carries = std::mem::take(&mut self.work.closed);
        let mut islands = std::mem::take(&mut self.work.islands);
        let solved = self.iterate_discrete_gradient(
            contacts,
            &points,
            &mut dq,
            &mut carries,
            &mut islands,
            pr,
        );
        self.work.islands = islands;
        self.work.points = points;
        self.work.dq = dq;
        solved.map(|(sol, drift)| (sol, carries, drift))
    }

    /// `solve_discrete_gradient`'s iteration from the predicted increment `dq`; `carries`
    /// receives which points end closed; `islands` is working storage. Returns the last
    /// solution and its drift (m: how far the points its rows hold miss their faces).
    fn iterate_discrete_gradient(
        &mut self,
        contacts: &[ContactPoint],
        points: &[MaterialContact],
        dq: &mut [f64],
        carries: &mut Vec<bool>,
        islands: &mut Islands,
        pr: &mut StepProblem,
    ) -> Result<(StepSolution, f64), SolveFailure> {
        let mut iterations = 0;
        // Once some islands' points stop drifting, only the others are solved again (the
        // problem is separable over islands): an island's solves are those it needs alone.
        // `iterating`: `islands.held` marks the islands solved again (found once, when first
        // needed).
        let mut found = false;
        let mut iterating = false;
        let mut last: Option<StepSolution> = None;
        for solve in 1..=DISCRETE_GRADIENT_SOLVES {
            let of = |k: usize| {
                islands
                    .components
                    .island()
                    .get(contacts[k].b)
                    .copied()
                    .flatten()
            };
            let solved_again = |k: usize| !iterating || of(k).is_some_and(|i| islands.held[i]);
            {
                let (whole, half) = (Increment::new(dq, 1.0), Increment::new(dq, 0.5));
                for (k, (r, m)) in pr.contacts.iter_mut().zip(points).enumerate() {
                    if solved_again(k) {
                        m.set_rows(r, &whole, &half, &self.bodies.mass);
                    }
                }
            }
            let mut sol = match (iterating, last.take()) {
                (true, Some(mut sol)) => {
                    let again: Vec<usize> =
                        (0..contacts.len()).filter(|&k| solved_again(k)).collect();
                    let part = self.solve_law(&StepProblem {
                        theta: pr.theta,
                        dt: pr.dt,
                        mass: pr.mass.clone(),
                        force: pr.force.clone(),
                        v0: pr.v0.clone(),
                        contacts: again.iter().map(|&k| pr.contacts[k].clone()).collect(),
                    })?;
                    for (b, i) in islands.components.island().iter().enumerate() {
                        if i.is_some_and(|i| islands.held[i]) {
                            sol.dq[3 * b..3 * b + 3].copy_from_slice(&part.dq[3 * b..3 * b + 3]);
                        }
                    }
                    for (l, &k) in again.iter().enumerate() {
                        sol.normal[k] = part.normal[l];
                        sol.tangential[k] = part.tangential[l];
                    }
                    sol.iterations = part.iterations;
                    sol.polished |= part.polished;
                    sol
                }
                (_, unused) => {
                    if let Some(sol) = unused {
                        self.give_back_solution(sol);
                    }
                    let mut sol = self.spare_solution();
                    self.solve_law_into(pr, &mut sol)?;
                    sol
                }
            };
            iterations += sol.iterations;
            dq.copy_from_slice(&sol.dq);
            closed_into(pr, &sol, self.settings.friction_law, carries);
            let whole = Increment::new(dq, 1.0);
            // The drift of the points that carry a force, and of the unloaded ones that end
            // closed or through their face: the rows of those were built at the predicted
            // end, which the solution may have left (a light plank struck in the sub-step).
            // The carrying points' gradients at the end are kept for `settle_velocity`.
            let mut drifts = std::mem::take(&mut self.work.drifts);
            let mut end = std::mem::take(&mut self.work.end_gradients);
            drifts.clear();
            end.clear();
            for (k, m) in points.iter().enumerate() {
                let (dn, dt) = if carries[k] {
                    let (increments, gradients) = m.increments_and_gradients(&whole);
                    end.push(gradients);
                    increments
                } else {
                    end.push(NO_GRADIENTS);
                    m.increments(&whole)
                };
                let closes = contacts[k].gap + dn < CLOSED_GAP;
                let r = &pr.contacts[k];
                let dn = dn - row_dot(&r.nrow, dq);
                let dt = dt - row_dot(&r.trow, dq);
                drifts.push(if carries[k] || closes {
                    dn.abs().max(dt.abs())
                } else {
                    0.0
                });
            }
            self.work.end_gradients = end;
            let worst = drifts.iter().copied().fold(0.0f64, f64::max);
            if worst <= DRIFT_TOLERANCE || solve == DISCRETE_GRADIENT_SOLVES {
                self.work.drifts = drifts;
                self.gradient_solves += solve as u64;
                sol.iterations = iterations;
                return Ok((sol, worst));
            }
            if self.bodies.len() == 1 {
                // One island: solved again whole.
                self.work.drifts = drifts;
                last = Some(sol);
                continue;
            }
            if !found {
                islands.components.find(self.bodies.len(), &pr.contacts);
                found = true;
            }
            holding_into(
                islands.components.island(),
                (0..contacts.len())
                    .filter(|&k| drifts[k] > DRIFT_TOLERANCE)
                    .map(|k| contacts[k].b),
                &mut islands.held,
            );
            self.work.drifts = drifts;
            iterating = islands.held.contains(&false);
            last = Some(sol);
        }
        unreachable!("the last solve returns")
    }
}
