//! The velocity problems: plastic impacts (the closest admissible velocities in the
//! kinetic-energy norm), end velocities made admissible on the loaded points, and the
//! projection of a penetration out of the positions.

use super::{
    CLOSED_GAP, Islands, NativeState, PENETRATION_TOLERANCE, StepError, Stepper,
    VELOCITY_TOLERANCE, row_dot,
};
use crate::geometry::ContactPoint;
use crate::native::assembly::{contact_key, contact_rows, ground_offsets, poses};
use crate::native::coulomb::COULOMB_TOLERANCE;
use crate::native::islands::holding_into;
use crate::native::material::Gradient;
use crate::native::problem::{ContactRows, SparseRow, StepProblem, StepSolution};
use crate::native::settings::FrictionLaw;
use crate::native::solver::SolveFailure;
use crate::scene::AppliedAs;

/// Add `r`'s tangential row and offset to `sum`'s (rows of the same body pair share their DOF
/// layout).
fn add_tangential(sum: &mut ContactRows, r: &ContactRows) {
    sum.g_t += r.g_t;
    for (a, b) in sum.trow.iter_mut().zip(&r.trow) {
        debug_assert_eq!(a.0, b.0);
        a.1 += b.1;
    }
}

/// `w (g + row·v) = 0` as a pair of opposite frictionless rows (keys `key | 1 << 60` and
/// `key | 2 << 60`).
fn equal_to_zero(key: u64, g: f64, row: &SparseRow, w: f64) -> [ContactRows; 2] {
    [(w, 1u64), (-w, 2u64)].map(|(sign, tag)| ContactRows {
        key: key | tag << 60,
        mu: 0.0,
        g_n: sign * g,
        g_t: 0.0,
        nrow: row.iter().map(|&(i, c)| (i, sign * c)).collect(),
        trow: row.iter().map(|&(i, _)| (i, 0.0)).collect(),
    })
}

/// Keep the rows of the islands (`native::islands`) with a row whose point approaches,
/// `approach * h > VELOCITY_TOLERANCE` (`approach` holds the first rows' values; rows past its
/// end are in the islands of those before them): the velocity problem is separable over
/// islands, and each other island's velocity is its own closest admissible one.
fn keep_islands_that_approach(
    n_blocks: usize,
    rows: &mut Vec<ContactRows>,
    approach: &[f64],
    h: f64,
    islands: &mut Islands,
) {
    let block = |r: &ContactRows| r.nrow.first().map(|e| e.0 / 3);
    islands.components.find(n_blocks, rows);
    let island = islands.components.island();
    holding_into(
        island,
        rows.iter()
            .zip(approach)
            .filter(|(_, a)| **a * h > VELOCITY_TOLERANCE)
            .filter_map(|(r, _)| block(r)),
        &mut islands.held,
    );
    let settles = &islands.held;
    rows.retain(|r| block(r).and_then(|b| island[b]).is_none_or(|i| settles[i]));
}

/// Whether, under the associative law, some row `(n ± mu t)·(v - w) >= 0` of a point that ends
/// closed (`carries`; `end`: its gradients at the end configuration) approaches by more than
/// `VELOCITY_TOLERANCE` over `h`: `Stepper::settle_velocity`'s test, with the same sums in the
/// same order, before any row is built.
fn approaches(
    contacts: &[ContactPoint],
    end: &[(Gradient, Gradient, usize)],
    carries: &[bool],
    w: (f64, f64),
    v: &[f64],
    friction: impl Fn(&ContactPoint) -> f64,
    h: f64,
) -> bool {
    let mut worst = 0.0f64;
    for ((c, g), _) in contacts.iter().zip(end).zip(carries).filter(|(_, l)| **l) {
        let (vn, vt) = end_relative_velocity(c, g, w, v);
        worst = worst.max(friction(c) * vt.abs() - vn);
    }
    worst * h > VELOCITY_TOLERANCE
}

/// The normal and tangential relative velocities `(n·(v - w), t·(v - w))` of a point whose
/// gradients at the end configuration are `(gn, gt, len)`; `w` the ground's velocity.
#[inline]
fn end_relative_velocity(
    c: &ContactPoint,
    (gn, gt, len): &(Gradient, Gradient, usize),
    w: (f64, f64),
    v: &[f64],
) -> (f64, f64) {
    let (g_n, g_t) = ground_offsets(c, w);
    (g_n + row_dot(&gn[..*len], v), g_t + row_dot(&gt[..*len], v))
}

impl Stepper {
    /// A plastic impact at the current instant: the velocities jump to the closest ones (in
    /// the kinetic-energy norm) that satisfy the velocity-level law `(n ± mu t)·v >= 0` on
    /// every closed point (gap below `PENETRATION_TOLERANCE`) and on the located points:
    /// `min 1/2 (v - v-)' M (v - v-)` s.t. those rows, which is the step problem with
    /// theta = dt = 1, no force, `v0 = v-` and the ground's velocity in place of its increment.
    /// Positions do not change. Returns the solver iterations.
    pub(super) fn impact(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        located: &[u64],
    ) -> Result<u32, SolveFailure> {
        let ps = poses(&s.q);
        let w = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let mut pr = self.spare_problem();
        pr.contacts.clear();
        pr.contacts.extend(
            contacts
                .iter()
                .map(|c| {
                    let mut r = contact_rows(c, &ps, self.bodies.friction(c), w);
                    r.g_n -= c.gap;
                    (c.gap, r)
                })
                .filter(|(gap, r)| *gap <= CLOSED_GAP || located.contains(&r.key))
                .map(|(_, r)| r),
        );
        if pr.contacts.is_empty() {
            self.give_back(pr);
            return Ok(0);
        }
        let iterations = self.closest_admissible_velocity(s, pr, self.settings.friction_law)?;
        self.iterations += iterations as u64;
        Ok(iterations)
    }

    /// The velocities become the closest ones (kinetic-energy norm) that satisfy the
    /// velocity-level law `(n ± mu t)·v >= 0` on the rows of `pr.contacts`: the step problem
    /// with theta = dt = 1, no force and `v0 = v` (set here), under the friction law `law`.
    /// Positions do not change. Returns the solver iterations.
    fn closest_admissible_velocity(
        &mut self,
        s: &mut NativeState,
        mut pr: StepProblem,
        law: FrictionLaw,
    ) -> Result<u32, SolveFailure> {
        pr.theta = 1.0;
        pr.dt = 1.0;
        pr.mass.clone_from(&self.bodies.mass);
        pr.force.clear();
        pr.force.resize(s.v.len(), 0.0);
        pr.v0.clone_from(&s.v);
        let mut sol = self.spare_solution();
        let solved = match law {
            FrictionLaw::Associative => self.velocity_solver.solve_into(&pr, &mut sol),
            FrictionLaw::Coulomb => self
                .coulomb
                .solve(self.velocity_solver.as_mut(), &pr)
                .map(|coulomb| sol = coulomb),
        };
        self.give_back(pr);
        solved?;
        s.v.copy_from_slice(&sol.dq);
        let iterations = sol.iterations;
        self.give_back_solution(sol);
        Ok(iterations)
    }

    /// `settle_velocity` for a kept sub-step (`sol`, its problem `pr`; `end`, `closed`: its end
    /// gradients and which points ended closed), its iterations counted in `sol` and
    /// `self.iterations`.
    pub(super) fn settle_kept(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        end: &[(Gradient, Gradient, usize)],
        closed: &[bool],
        pr: &StepProblem,
        sol: &mut StepSolution,
    ) -> Result<(), StepError> {
        let settled = self.settle_velocity(s, contacts, end, closed, pr, sol)?;
        self.iterations += settled as u64;
        sol.iterations += settled;
        Ok(())
    }

    /// The end velocity of an impact-stepper sub-step, `v = 2 dq/h - v0` (`h = pr.dt`), made
    /// admissible on the points that end closed (`carries`): when some `(n ± mu t)·v` (rows at
    /// the end configuration) approaches by more than `VELOCITY_TOLERANCE`, `v` becomes its
    /// closest admissible velocity in the kinetic-energy norm (Moreau's plastic law; kinetic
    /// energy can only drop). Without it the mean-velocity law would leave the end velocity
    /// ringing, `v = -v0`, after a contact sticks or closes. On a smooth motion along a contact
    /// the change is O(h^3) a step. Returns the solver iterations; a solver failure is an error
    /// naming the step.
    fn settle_velocity(
        &mut self,
        s: &mut NativeState,
        contacts: &[ContactPoint],
        end: &[(Gradient, Gradient, usize)],
        carries: &[bool],
        pr: &StepProblem,
        sol: &StepSolution,
    ) -> Result<u32, StepError> {
        let w = match self.applied_as {
            AppliedAs::MovingGround => s.ground_w,
            AppliedAs::InertialForces => (0.0, 0.0),
        };
        let coulomb = self.settings.friction_law == FrictionLaw::Coulomb;
        if !coulomb
            && !approaches(
                contacts,
                end,
                carries,
                w,
                &s.v,
                |c| self.bodies.friction(c),
                pr.dt,
            )
        {
            // Nothing to settle (most steps of a standing or slowly moving scene): no rows built.
            return Ok(0);
        }
        let mut settling = self.spare_problem();
        let rows = &mut settling.contacts;
        rows.clear();
        // Coulomb: per body pair, the sum of its stopping points' tangential rows and offsets.
        let mut stuck: Vec<((Option<usize>, usize), ContactRows, usize)> = Vec::new();
        let mut worst = 0.0f64;
        // How far each row's point approaches (for the islands that need settling; one block
        // is one island).
        let several = self.bodies.len() > 1;
        let mut approach = std::mem::take(&mut self.approach);
        approach.clear();
        for (k, ((c, g), l)) in contacts.iter().zip(end).zip(carries).enumerate() {
            if !*l {
                continue;
            }
            let mu = self.bodies.friction(c);
            let (g_n, g_t) = ground_offsets(c, w);
            let (gn, gt, len) = g;
            let len = *len;
            // The velocity-level rows: `(n ± mu t)·(v - w) >= 0`.
            let mut r = ContactRows {
                key: contact_key(c),
                mu,
                g_n,
                g_t,
                nrow: SparseRow::from_slice(&gn[..len]),
                trow: SparseRow::from_slice(&gt[..len]),
            };
            let (vn, vt) = end_relative_velocity(c, g, w, &s.v);
            if !coulomb {
                let a = mu * vt.abs() - vn;
                worst = worst.max(a);
                rows.push(r);
                if several {
                    approach.push(a);
                }
                continue;
            }
            // Coulomb. A point that did not slip in the step (judged by its slip, not its
            // force: a face's friction is shared between its points in any proportion) is
            // settled as under the associative law, so that the two laws agree where nothing
            // slides. A point that slid keeps its normal row only (no lift); if its end velocity
            // reverses its slip, the slip stopped within the step (friction never reverses one):
            // it stops, no relative velocity either way (held below, by body pair).
            let step_row = &pr.contacts[k];
            let slip = step_row.g_t + row_dot(&step_row.trow, &sol.dq);
            if slip.abs() <= COULOMB_TOLERANCE {
                let a = mu * vt.abs() - vn;
                worst = worst.max(a);
                rows.push(r);
                if several {
                    approach.push(a);
                }
            } else if vt * slip < 0.0 {
                let a = vn.abs().max(vt.abs());
                worst = worst.max(a);
                let pair = (c.a, c.b);
                match stuck.iter_mut().find(|(p, _, _)| *p == pair) {
                    Some((_, t, count)) => {
                        add_tangential(t, &r);
                        *count += 1;
                    }
                    None => stuck.push((pair, r.clone(), 1)),
                }
                rows.extend(equal_to_zero(r.key, r.g_n, &r.nrow, 1.0));
                if several {
                    approach.extend([a, a]);
                }
            } else {
                worst = worst.max(-vn);
                r.mu = 0.0;
                rows.push(r);
                if several {
                    approach.push(-vn);
                }
            }
        }
        // No relative tangential velocity of a body pair's stopping points, on average (the
        // points' own rows are dependent on a face).
        for (_, t, count) in stuck {
            rows.extend(equal_to_zero(
                t.key | 1 << 62,
                t.g_t,
                &t.trow,
                1.0 / count as f64,
            ));
        }
        if several && worst * pr.dt > VELOCITY_TOLERANCE {
            let mut islands = std::mem::take(&mut self.work.islands);
            keep_islands_that_approach(self.bodies.len(), rows, &approach, pr.dt, &mut islands);
            self.work.islands = islands;
        }
        self.approach = approach;
        if worst * pr.dt <= VELOCITY_TOLERANCE {
            self.give_back(settling);
            return Ok(0);
        }
        self.settled_velocities += 1;
        // Under Coulomb too the rows are solved as they are: each carries its own friction.
        self.closest_admissible_velocity(s, settling, FrictionLaw::Associative)
            .map_err(|failure| StepError::Solver {
                step: s.step + 1,
                t: s.t,
                failure,
            })
    }

    /// The velocity-level law leaves a penetration of up to `(1 - theta) dt |v_n|` at an
    /// impact. When a point penetrates deeper than `PENETRATION_TOLERANCE`, the positions
    /// are projected back onto the admissible set, velocities untouched. The kinetic energy is
    /// kept, but pushing a block out lifts it: the projection adds the weight times the lift
    /// (measured on random walls set moving, `tests/proptest_assemblies.rs`: up to 2.3e-7 of
    /// `sum m g H` a projection, penetrations of 1e-8 to 4e-5 m), an error of the first order
    /// in `dt` like the instants of impacts at step ends:
    /// `min 1/2 dq' M dq  s.t.  g + (nrow ± mu trow) dq >= 0`, which is the step problem with
    /// theta = dt = 1, no force and no velocity.
    pub(super) fn project_out_penetration(
        &mut self,
        s: &mut NativeState,
    ) -> Result<(), SolveFailure> {
        let contacts = self.detect(s);
        if contacts.iter().all(|c| c.gap >= -PENETRATION_TOLERANCE) {
            return Ok(());
        }
        let ps = poses(&s.q);
        let pr = StepProblem {
            theta: 1.0,
            dt: 1.0,
            mass: self.bodies.mass.clone(),
            force: vec![0.0; s.q.len()],
            v0: vec![0.0; s.q.len()],
            contacts: contacts
                .iter()
                .map(|c| contact_rows(c, &ps, self.bodies.friction(c), (0.0, 0.0)))
                .collect(),
        };
        let sol = self.projection_solver.solve(&pr)?;
        for (q, d) in s.q.iter_mut().zip(&sol.dq) {
            *q += d;
        }
        self.projections += 1;
        let gained: f64 = (0..self.bodies.len())
            .map(|i| self.bodies.mass[3 * i + 1] * self.gravity * sol.dq[3 * i + 1])
            .sum();
        self.projected_energy += gained.max(0.0);
        Ok(())
    }

    /// [`Stepper::project_out_penetration`] at the end of a step, its failure an error naming
    /// the step.
    pub(super) fn project_out_penetration_of_step(
        &mut self,
        s: &mut NativeState,
    ) -> Result<(), StepError> {
        self.project_out_penetration(s)
            .map_err(|failure| StepError::Solver {
                step: s.step + 1,
                t: s.t,
                failure,
            })
    }
}
