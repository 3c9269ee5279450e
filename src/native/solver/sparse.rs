//! A sparse back-end for large assemblies: an augmented Lagrangian method with semismooth
//! Newton steps on the scaled primal problem (see [`crate::native::problem::Scaled`])
//!
//! ```text
//! min 1/2 u' P u + q' u   s.t.  D u + r >= 0      (P diagonal, two rows per contact)
//! ```
//!
//! For multipliers `l >= 0` and penalties `rho_i > 0` the augmented Lagrangian
//!
//! ```text
//! phi(u) = 1/2 u' P u + q' u + sum_i rho_i/2 min(0, D_i u + r_i - l_i/rho_i)^2
//! ```
//!
//! is convex, piecewise quadratic and once differentiable. It is minimised by Newton steps
//! `(P + sum_{i in A} rho_i D_i' D_i) du = -grad phi(u)` on the rows
//! `A = {i : y_i = D_i u + r_i - l_i/rho_i < eps_i}`, each followed by an exact line search (phi
//! is piecewise quadratic along du); then `l_i <- max(0, l_i - rho_i (D_i u + r_i))`. On a wide
//! envelope (below) the margin `eps_i = CLOSED_MARGIN (1 + |r_i|)` keeps in the Newton matrix
//! the closed rows that carry no force (a wall's head joints, a sticking point's far cone edge),
//! which sit at `y_i = 0` to round-off and would otherwise flip in and out of A from one Newton
//! step to the next; elsewhere `eps_i = 0`. The gradient and the line search use the exact
//! pieces, so the fixed point is the same. A fixed point satisfies the KKT conditions exactly
//! (`P u + q = D' l`, `D u + r >= 0`, `l >= 0`, `l_i (D_i u + r_i) = 0`); the iteration stops
//! when no multiplier moves by more than `rho_i * 1e-11 (1 + |r_i|)`, i.e. every row holds to
//! the dense back-end's tolerance.
//! Dependent rows (a flat interface has four rows on three relative DOFs) need no special
//! treatment: the Newton matrix stays positive definite through P.
//!
//! The penalties are normalised, `rho_i = RHO / (D_i P^-1 D_i')`, so that every row is
//! stiffened alike whatever the masses and lever arms; a problem on a wide envelope (below)
//! starts from `RHO_WIDE` instead, its last retry from `RHO`. The Newton matrix is factorised
//! by an envelope Cholesky factorisation over a reverse Cuthill-McKee order of the blocks (see
//! [`super::envelope`]). The multipliers start from the previous step's (matched by row key),
//! and the factor is kept from step to step while the set A does not change: at rest, a step
//! costs a few solves with the kept factor and no factorisation. Within a problem, a factor
//! built from its rows follows a few rows entering or leaving A by rank-one updates of the
//! factor ([`Envelope::update`], `UPDATE_SHARE`), each a seventh to a fifteenth of a
//! factorisation. A kept factor was built from
//! slightly different rows, so a Newton step with it is inexact; the iteration still converges
//! to the exact fixed point, and the factor is rebuilt from the current rows when a step with
//! a kept factor does not shrink the next one tenfold.
//!
//! A factorisation costs about `n w^2 / 2` for an envelope of mean row width `w`, a Newton step
//! with the factor in hand about `n w` plus a pass over the rows. Where `w` is at least
//! `WIDE_ENVELOPE` DOFs (a wall of more than about six courses) the closed rows are held in the
//! Newton matrix and a new factor is trusted again until it fails, both of which trade
//! factorisations for Newton steps; on narrower envelopes (small islands, low walls) they cost
//! more than they save (measured below). A problem of `LARGE_PROBLEM` DOFs or more is treated as
//! wide whatever its envelope (a large wall whose joints open as it moves).
//!
//! On a wide envelope a problem whose first solve does not converge in `MAX_NEWTON_WIDE`
//! Newton steps, or takes a Newton step that the line search cuts below `STALLED_STEP`, goes to
//! the interior-point rescue (see [`SparseSolver::rescue`] and
//! [`super::interior`]): a wall that moves changes hundreds of active rows from one problem to
//! the next, which the augmented Lagrangian's Newton steps find a few at a time.

use super::envelope::Envelope;
use super::interior::InteriorPoint;
use super::rows::{EdgeRow, dots_into, edge_rows, step_solution};
use super::{ContactSolver, SolveFailure};
use crate::native::problem::{StepProblem, StepSolution};

/// Normalised penalty each step starts from: `rho_i D_i P^-1 D_i' = RHO`. Measured on a
/// rocking 25-block column and the 210-block wall at rest: 1e1-1e2 leave the multipliers
/// creeping (no convergence in 60 updates), 1e6-1e8 make the active rows of a warm start
/// (`D_i u + r_i < l_i / rho_i`) too thin a margin, so a rocking column re-factorises ten
/// times a step; 1e4 needs about two factorisations a step there and none at rest.
pub const RHO: f64 = 1e4;
/// Normalised penalty a problem starts from on a wide envelope (`WIDE_ENVELOPE`) and on a still
/// narrow one (`STILL_SPEED`), except on its last retry (which starts from `RHO`). Measured on the
/// walls under El Centro x2 (a probe stepping the stepper, dt 1e-3; base 1e4 / 1e5 / 1e6 / 1e7 /
/// 1e8): the 215-block wall's 5 s 2.02 / 1.21 / 1.21 / 0.754 / 0.757 ms a step (5.4 / 2.3 / 2.6 /
/// 0.92 / 1.2 factorisations a step), the 860-block wall's first second 5.20 / 3.46 / 2.58 / 2.17 /
/// 2.04 ms a step (13.9 / 7.5 / 4.7 / 3.2 / 2.7 Newton steps): from a stiff start the warm-started
/// multipliers settle in one or two updates where the ladder from 1e4 took up to ten (see
/// docs/walls.md). The 430-block wall's cold last retries fail from 1e7 (at 4.216 s, every retry
/// and Clarabel) and not from 1e4.
pub const RHO_WIDE: f64 = 1e7;
/// A problem on a narrower envelope starts from `RHO_WIDE` too when it has the rows of the
/// last one and the last solution moved no DOF faster than this (m/s, rad/s; `u = dq/dt`): a
/// wall or stack standing under an earthquake, whose warm multipliers are as good as a wide
/// wall's. Measured (running-bond walls of 2-5 courses of 21 blocks under El Centro x2, 5 s,
/// `bench_dynamic`, 1e4 start -> this rule): 43 / 64 / 86 / 107 blocks 0.122 / 0.244 / 0.384 /
/// 0.543 -> 0.072 / 0.119 / 0.182 / 0.254 ms a step (the 107-block wall the same at 1e-4
/// m/s). Where blocks move the soft start stays: a tilted column of 25 blocks rocking freely
/// took 25 factorisations a problem from the stiff start against 7.9 from 1e4 (the thin
/// margins of `RHO`'s text).
pub const STILL_SPEED: f64 = 1e-6;
/// Largest normalised penalty: when the multipliers converge slowly (a change not below a
/// quarter of the previous one) every penalty grows tenfold, up to this.
pub const RHO_MAX: f64 = 1e10;
/// A row holds when `D_i u + r_i >= -ROW_TOLERANCE (1 + |r_i|)` (as in the dense back-end).
pub const ROW_TOLERANCE: f64 = 1e-11;
/// Rows that stop converging at the stiffest penalty are accepted when they hold to this (the
/// dense back-end's test of an inconsistent working set).
pub const CONSISTENCY_TOLERANCE: f64 = 1e-9;
/// Newton's iteration stops when the step is below `NEWTON_TOLERANCE (1 + |u|_inf)`.
pub const NEWTON_TOLERANCE: f64 = 1e-12;
/// Below `NEWTON_TOLERANCE` Newton's iteration goes on to this while its steps still halve, at
/// most `MAX_REFINEMENTS` steps more: on badly scaled problems a step of 1e-12 (1 + |u|) on a
/// heavy block's DOFs leaves a stationarity residual whose work the impact stepper's energy
/// balance sees (`make proptest`: a 3 m stack of blocks of 0.5, 414 and 1906 kg per metre
/// rocking on its light bottom block gained 1.3e-6 J/m a step, 1.05e-9 of m g H in 0.01 s,
/// with this back-end and not with the others; refined, none: its energy falls by 2.8e-7 J/m).
/// On a wide envelope a refinement never factorises: it uses the factor in hand, and stops
/// where the rows in the Newton matrix change. On a narrow envelope, where a factorisation is
/// cheap, it factorises when they change, unless the solution is still (no DOF of `u` faster
/// than `STILL_SPEED`: the residual's work is its product with `u`). A heavy plank turning on
/// the corner of a light post (`make proptest`, the sparse back-end forced) stopped every
/// step's second solve so, and the residual of its momentum balance (1.5e-8 N s/m) did 1.2e-9
/// J/m of work a step, 3.3e-9 of m g H in 0.25 s (1.2e-11 refined; the dense back-end
/// 1.5e-14). Refined also where the solution is still, the 65-block wall at 0.99 of its static
/// collapse acceleration moved at 1.4e-3 m/s after 200 steps (the growing mode of "Sleeping
/// islands" in docs/method.md), against 2e-8. On the toppling 42-block wall (narrow islands,
/// another path at round-off: 11209 -> 11433 split steps, rapier's 10 blocks overturned instead
/// of c2b1 for c4b7) 519523 -> 576916 factorisations. The residual's work on the light
/// blocks scales with the ratio of the lightest block's mass to the heaviest's, so on a wide
/// envelope a problem refines to `NEWTON_TOLERANCE * m_min / m_max`, at least to this (the
/// stack above: 2.9e-4): equal blocks do not refine, a wall of blocks and half blocks refines
/// to 5e-13. Measured on the walls under El Centro x2 (first second, a probe stepping the
/// stepper): the refinements to 1e-15 were 2-3 of a problem's 3.5-9 Newton steps; with the
/// ratio, 215 blocks 0.77-0.81 -> 0.68-0.69 ms a step and 860 blocks 6.8 -> 5.9. On narrow
/// envelopes (small islands) every problem refines to this: with the ratio there the toppling
/// 42-block wall took another path at round-off and factorised more a sub-step (81660 -> 95342
/// factorisations, 6752 -> 7532 sub-steps, 19.4 -> 22.5 s).
const REFINED_TOLERANCE: f64 = 1e-15;
const MAX_REFINEMENTS: usize = 3;
const MAX_NEWTON: usize = 60;
/// Newton steps of a minimisation on a wide envelope before the problem goes to the
/// interior-point rescue (not while the rescue's solution is settled). Measured on the walls
/// under El Centro x2 (probe, rescue on): the 430-block wall's 12 steps from 4.21 s (where it
/// starts to move) 26.7 / 20.4 / 16.9 / 15.6 / 14.4 s with 60 / 25 / 15 / 10 / 8 (6 s of
/// them the quiet 4.21 s before), the 215-block wall's last second of 5 s 1.77 / 1.83 / 2.06 /
/// 2.57 ms a step with 60 / 15 / 10 / 8 (there warm problems that need more steps succeed).
const MAX_NEWTON_WIDE: usize = 15;
/// A warm start of a wide problem (on an envelope at least `WIDE_ENVELOPE` wide) that takes a
/// Newton step the line search cuts below this factor goes to the interior-point rescue at once
/// (not while a rescue's solution is settled, nor on the last retry). Such a step marks a warm
/// start that fails: along its direction rows that carry no force are crossed at once ("Why
/// the warm starts fail there", docs/walls.md), and such starts went on to fail after 4-8
/// factorisations and to the rescue all the same. Traced on the located 215-block wall (ten
/// steps, 10383 factorisations): the 311 rescued problems had spent 2014 factorisations in
/// their failed warm starts (6.5 each), the 173 wide problems solved warm 326 (1.9 each).
/// Measured (`wall_steps`, all factorisations; docs/walls.md, "Warm starts given up at a
/// stalled step"): the sliding walls of 215 / 430 / 860 blocks (ten pulse steps at step ends)
/// 474 / 726 / 1229 -> 389 / 641 / 1075, the located 215-block wall (ten steps) 10383 -> 9806.
/// Other factors and the `K`-th such step instead of the first, without the envelope's width
/// in the rule: 1e-6 (`K` 1) 389 / 641 / 1062 and 9506; 3e-7 / 1e-5 / 1e-4 397 / 645 / 1069,
/// 386 / 640 / 1060, 383 / 638 / 1060 and 9663 / 10095 / 9794; 1e-6 with `K` 2 / 3 / 4 407 /
/// 652 / 1083, 427 / 656 / 1110, 446 / 675 / 1137 and 9677 / 10197 / 10509. Without the width
/// the 107-block wall under El Centro x2 (5 s; wide by `LARGE_PROBLEM`, its envelope 18 DOFs)
/// gave up 14 warm starts that would have succeeded: 808 -> 1052 factorisations (808 with it).
const STALLED_STEP: f64 = 1e-6;
/// The interior-point rescue stops at residuals below this (`super::interior`), and holds in
/// the Newton matrix the rows whose slack is below it or below their multiplier.
const RESCUE_TOLERANCE: f64 = 1e-8;
/// Where a rescue whose settle failed takes its interior point on to (residuals, and `mu` below
/// its square) before it settles again: the rows closed at `RESCUE_TOLERANCE` that the settle
/// could not hold are then told apart. Without it such a problem went to the cold retries,
/// which rebuild its working rows a few at a time. Measured (`wall_steps`, all factorisations,
/// without -> with, `RESUMED_ITERATIONS` 12): the sliding walls of 215 / 430 / 860 blocks at
/// step ends (30 pulse steps) 2060 / 2614 / 3764 -> 2042 / 2575 / 3424, their cold retries 48 /
/// 149 / 490 factorisations against 33 / 27 / 102 for the resumed rescues (4 / 4 / 12, every
/// one settled, no cold retry left); the located sliding 215-block wall (ten steps) 10442 ->
/// 9163 (25 cold retries of 1500 factorisations against 24 resumed rescues of 185).
const RESUMED_TOLERANCE: f64 = 1e-10;
/// The interior point's iterations allowed from where a rescue stopped towards
/// `RESUMED_TOLERANCE`; the last iterate is settled whether it got there or not. Uncapped, 47
/// resumes on the walls measured there took 3-9 iterations but for three, of 16, 35 and
/// 60 (the last out of iterations, its `mu` stalled at 1e-19 on a settled end velocity of the
/// sliding 215-block wall, which the cold retries then solved in 47 factorisations more); with
/// the cap every resumed rescue settled.
const RESUMED_ITERATIONS: usize = 12;
/// Newton steps of the last retry: measured on a 430-block wall at 4.2 s of El Centro x2, a cold
/// start rebuilt about 900 active rows some 30 a step (the exact line search stops at the first
/// breaks), past 60 steps.
const MAX_NEWTON_LAST_RETRY: usize = 1000;
/// Rows with `0 <= y_i < CLOSED_MARGIN (1 + |r_i|)` (closed and unloaded, at zero to
/// round-off) stay in the Newton matrix on a wide envelope and on the last retry (see the
/// module's text). Measured on the walls under El Centro x2 (215 blocks, 1 s; 430 blocks,
/// 0.5 s): without the margin the velocity problems of the impact stepper, whose closed rows
/// all sit at `y = 0`, took 5 factorisations and some 17 Newton steps each, and the Newton
/// matrix was factorised 1287 / 2734 times; with it 631 / 326 times, the trajectories the same
/// to 1e-10 (the round-off of those walls).
const CLOSED_MARGIN: f64 = 1e-11;
/// Mean row width of the envelope, in DOFs, from which the closed rows are held in the Newton
/// matrix and a new factor is trusted again (see the module's text). Measured (`rockbench run`,
/// El Centro x2 or the toppling pulse, both off against both on): the 215-block wall (width
/// 31.5) 1 s 1.84 -> 1.32 s and the 430-block wall (56) 0.5 s 6.21 -> 1.62 s; the 107-block
/// wall (18.3) 0.693 -> 0.752 ms a step and the toppling 42-block wall (islands up to 16.7)
/// 30.2 -> 46.4 s, slower.
const WIDE_ENVELOPE: f64 = 24.0;
/// A problem of this many DOFs or more is taken as wide whatever its envelope's width (the
/// rules of `WIDE_ENVELOPE`, the stiff start and the interior-point rescue). A wall that moves
/// opens joints, and with fewer pairs in contact its envelope can fall below `WIDE_ENVELOPE`:
/// measured on the 215-block wall sliding under a rectangular pulse of 0.8 g (first 60 steps,
/// 10 of them in the pulse), 418 of its problems (519 to 645 DOFs) were solved as narrow, 76 of
/// them failed their warm start of 60 Newton steps and took 167 factorisations each in the cold
/// retries (12669 of the 32995 factorisations), where the rescue takes some 25; taken as wide,
/// 6.07 -> 4.52 s (4.67 s from 450 DOFs), the first 150 steps 41.3 -> 38.6 s. A long low wall
/// (2 courses of 80 blocks, 483 DOFs, El Centro x2, 5 s) 2.19 -> 2.17 s, the 107-block wall (321
/// DOFs) 1.94 -> 1.78 s; the standing 215-block wall is wide already (unchanged).
const LARGE_PROBLEM: usize = 300;
/// On a wide envelope and on the last retry Newton's iteration also stops when its steps stop
/// shrinking below this (`STAGNATION_TOLERANCE (1 + |u|_inf)`): measured on a 430-block wall,
/// steps of 6e-12 to 2e-11 for 60 iterations, the round-off of the Newton matrix with its
/// stiffened rows; on the 215-block wall in El Centro x2's strong phase the impact stepper's
/// velocity problems (|u| about 1e-8) stall at steps of 3e-12 to 1e-10 whose line-search
/// factors swing between 1.5 and 2.6 with an exact factor (directions of round-off), and
/// before this was accepted there they failed warm and cold (60 Newton steps and some 25
/// factorisations each) before the last retry solved them. Whether the point is a solution is
/// then the multiplier loop's test of every row. Narrow envelopes keep the strict test: there
/// stagnation accepted on every solve moved the sleep test's wall (docs/walls.md).
const STAGNATION_TOLERANCE: f64 = 1e-9;
/// On a problem whose rows are homogeneous (every `r_i = 0`: the impact stepper's velocity
/// problems, where `g' u` is exactly the work of the residual `g` of the minimisation), steps
/// that stagnate (`STAGNATION_TOLERANCE`) while `u` moves (faster than `STILL_SPEED`) are
/// accepted only where `|g' u| <= STAGNATION_WORK u' P u`, or where nothing is left to change:
/// no rows held, an exact factor. Otherwise the iteration goes on without the held rows, then
/// with a new factor. Found on a colonnade of 60 light posts (0.073 x 1 m, 10 kg/m^3) under 59
/// heavy lintels (0.98 x 0.052 m, 381 kg/m^3) set swaying (357 DOFs, wide by `LARGE_PROBLEM`):
/// the settled end velocities after a rescue stagnated at steps of 7e-10 to 1.2e-9 (1 + |u|)
/// with line-search factors of 1.1 to 11 (the Newton matrix stiffened by rows the rescue held,
/// or a factor of other rows), and one step gained 6.6e-10 of m g H (Clarabel: 7.2e-12 over the
/// run); now 1.3e-14, and at most 3e-12 on nine such colonnades (51 / 60 / 75 posts, lintels at
/// 0.2 / 0.3 / 0.45 m/s) where the old rule let 4 of them gain 6.8e-11 to 6.6e-10. On other
/// problems `g' u` is not the residual's work alone (it also holds the multipliers' errors
/// against the offsets `r`), and applied to every problem the rule cost the sliding walls of
/// 215 / 860 blocks (ten pulse steps at step ends) 38.9 -> 54.8 / 111 -> 336 factorisations a
/// step.
const STAGNATION_WORK: f64 = 1e-12;
const MAX_OUTER: usize = 60;
/// A factor built from a problem's rows follows the rows of its Newton matrix by rank-one
/// updates while at most this share of the envelope's mean width of them changed since (see
/// [`SparseSolver::update_factor`]); beyond, the factor is kept or computed afresh as before.
/// Measured (`wall_steps`; the sliding walls of 215 / 430 blocks, ten steps of the 0.8 g
/// pulse, impacts at step ends): 0.1 / 0.25 / 0.5 / 1 / 2 / 4 gave 723 / 686 / 646 / 614 / 577 /
/// 549 and 965 / 920 / 895 / 870 / 841 / 813 factorisations, against 889 and 1488 without
/// updates, and 41-47 / 145-275 ms a step, flat within the runs' spread up to 1 and slower
/// beyond (the updates' cost; measured with the first, column-by-column kernel, a third as
/// fast); the toppling 42-block wall's first 0.4 s the same at 0.25 and 1.
const UPDATE_SHARE: f64 = 0.25;

/// Whether a row with value `c = D_i u + r_i` and multiplier `l` meets the complementarity
/// conditions to `tolerance` (relative to `1 + |r_i|`): it holds, and it is closed if loaded.
fn row_holds(c: f64, l: f64, r: f64, tolerance: f64) -> bool {
    let tol = tolerance * (1.0 + r.abs());
    c >= -tol && (l == 0.0 || c <= tol)
}

#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct SparseSolver {
    rows: Vec<EdgeRow>,
    r: Vec<f64>,
    rho: Vec<f64>,
    /// The penalties at the normalised level `RHO` (a problem on a wide envelope starts
    /// `RHO_WIDE / RHO` times stiffer; the ladder stops at `RHO_MAX / RHO` times these).
    rho_base: Vec<f64>,
    lambda: Vec<f64>,
    pinv: Vec<f64>,
    u: Vec<f64>,
    du: Vec<f64>,
    /// `D_i u + r_i - l_i / rho_i`.
    y: Vec<f64>,
    /// Whether each row is in the Newton matrix (`y_i` below its margin, or held).
    in_matrix: Vec<bool>,
    /// Rows held in the Newton matrix whatever their `y_i` (the interior-point rescue's closed
    /// rows, while the augmented Lagrangian settles its solution); empty otherwise.
    held: Vec<bool>,
    /// Whether the augmented Lagrangian is settling an interior-point solution.
    settling: bool,
    /// Whether the last problem was rescued; then the sorted keys of its rows and of the rows
    /// the rescue held (see `SparseSolver::solve_step`).
    last_rescued: bool,
    rescued_keys: Vec<u64>,
    rescued_held: Vec<u64>,
    /// Whether this solve holds the rows the last rescue held (a problem with its rows).
    hold_rescued: bool,
    /// The step's length of the last problem handed to the interior point.
    rescued_dt: f64,
    /// The velocities at the start of the step of the last problem handed to the interior
    /// point: a problem that starts from them is another solve of that step (see
    /// `SparseSolver::solve_step`).
    rescued_v0: Vec<f64>,
    /// Scratch: the current rows' keys, sorted.
    keys_now: Vec<u64>,
    interior: InteriorPoint,
    breaks: Vec<(f64, usize)>,
    /// Scratch: `D_i x` of every row for the `x` of the pass over the rows at hand (`u`, or
    /// the line search's `du`).
    #[serde(skip)]
    row_values: Vec<f64>,
    /// Row keys and multipliers of the previous solution, in row order, and its step's length.
    /// (The multipliers are impulses over the step, `normal dt / s`: a warm start from a step
    /// of another length scales them by the ratio, so that the forces carry over.)
    previous_keys: Vec<u64>,
    previous_lambda: Vec<f64>,
    previous_dt: f64,
    /// The same, sorted by key (for steps whose rows changed).
    by_key: Vec<(u64, f64)>,
    /// Pairs of blocks in contact, from which the envelope was built.
    pairs: Vec<(usize, usize)>,
    pairs_now: Vec<(usize, usize)>,
    envelope: Envelope,
    /// Whether a usable factor is in hand (of this problem's rows while `fresh`, else of an
    /// earlier problem's).
    factored: bool,
    /// Which rows are in the current factor, while it is fresh (`in_matrix` when it was built
    /// or last updated): the factor is exact when they are the rows now in the Newton matrix.
    factored_in: Vec<bool>,
    /// Whether the factor was built from this step's rows.
    fresh: bool,
    /// Factorisations computed (for diagnostics and benchmarks).
    pub factorisations: u64,
    /// Problems solved again cold after a warm start did not converge.
    pub cold_restarts: u64,
    /// Problems solved by the last retry (cold, a longer Newton iteration, stagnation at
    /// round-off accepted).
    pub last_retries: u64,
    /// Problems handed to the interior-point rescue (see `SparseSolver::rescue`).
    pub rescues: u64,
    /// Problems after a rescue solved from its held rows (see `SparseSolver::solve_step`).
    pub rescues_reused: u64,
    /// Rescues whose settle failed and whose interior point went on towards `RESUMED_TOLERANCE`
    /// (see `SparseSolver::rescue`), and of them those settled then.
    pub resumed_rescues: u64,
    pub resumed_settled: u64,
    /// Problems tried with the rows the last rescue held (`SparseSolver::solve_holding_rescued`).
    pub rescue_holds_tried: u64,
    /// Warm starts of wide problems given up at a stalled Newton step (`STALLED_STEP`).
    pub stalled_warm_starts: u64,
    /// Rows taken into or out of a factor by rank-one updates (see `SparseSolver::update_factor`).
    pub updates: u64,
    /// Minimisations ended where their Newton steps stagnated (`STAGNATION_TOLERANCE`) on a
    /// problem whose rows have offsets (not `homogeneous`): the multiplier loop's test of every
    /// row then decides whether the point is a solution.
    #[serde(default)]
    pub stagnations_with_offsets: u64,
    /// Whether the interior-point rescue is used (on from [`SparseSolver::new`]; off only to
    /// compare it with the cold retries it precedes).
    pub rescue: bool,
    /// Whether a factor follows small changes of its rows by rank-one updates (on from
    /// [`SparseSolver::new`]; off only to compare them with factorisations afresh).
    pub update_factors: bool,
    /// Whether a problem reuses the work of a rescue before it: the rows the rescue held, and
    /// its interior-point iterate near the central path (see `SparseSolver::solve_step`; on
    /// from [`SparseSolver::new`], off only to compare).
    pub reuse_rescues: bool,
    /// Whether a wide problem's warm start goes to the rescue at its first stalled Newton step
    /// (`STALLED_STEP`; on from [`SparseSolver::new`], off only to compare).
    pub give_up_stalled: bool,
    /// Whether a rescue whose settle failed goes on with its interior point before the cold
    /// retries (`RESUMED_TOLERANCE`; on from [`SparseSolver::new`], off only to compare).
    pub resume_rescues: bool,
    /// Whether a problem starts cold when the last solution moved (see
    /// [`SparseSolver::for_velocities`]).
    pub cold_after_motion: bool,
    /// Whether this is the last retry (`MAX_NEWTON_LAST_RETRY`).
    last_retry: bool,
    /// Whether the envelope is at least `WIDE_ENVELOPE` wide or the problem has at least
    /// `LARGE_PROBLEM` DOFs.
    wide: bool,
    /// Whether the last solution moved no DOF faster than `STILL_SPEED`.
    still: bool,
    /// Where refinements stop (see [`REFINED_TOLERANCE`]).
    refined_tolerance: f64,
    /// Whether every row's offset `r_i` is zero (the impact stepper's velocity problems): then
    /// `g' u` is the work of the residual `g` of the minimisation exactly (`STAGNATION_WORK`).
    #[serde(default)]
    homogeneous: bool,
}

impl SparseSolver {
    pub fn new() -> Self {
        Self {
            rescue: true,
            update_factors: true,
            reuse_rescues: true,
            give_up_stalled: true,
            resume_rescues: true,
            ..Self::default()
        }
    }

    /// The back-end of the impact stepper's velocity problems (`min 1/2 (v - v*)' M (v - v*)`
    /// under the closed points' rows): a problem whose last solution moved (faster than
    /// `STILL_SPEED`) starts cold, from `v*` and no multipliers. The last problem's impulses
    /// and working rows are another instant's (a step, or a sub-step to an impact, earlier),
    /// of another size and pattern, where the end velocities of a displacement problem are the
    /// next one's continuous start. Measured (`wall_steps`, the velocity problems'
    /// factorisations, warm -> cold after motion): a column of 25 blocks rocking freely (5 s)
    /// 49393 -> 8737, where a warm start took 17-22 factorisations two times in three (its
    /// penalties climbing the ladder); the sliding walls of 215 / 430 / 860 blocks (ten pulse
    /// steps at step ends) 362 / 493 / 937 -> 313 / 398 / 827; the toppling 42-block wall's
    /// first 0.4 s 2897 -> 2138. A wall standing still keeps its warm start: started cold, the
    /// 107-block wall's rare velocity problems under El Centro x2 (0.01 a step) took 105 instead
    /// of 4 factorisations.
    pub fn for_velocities() -> Self {
        Self {
            cold_after_motion: true,
            ..Self::new()
        }
    }

    /// Whether the envelope's mean row width is at least `WIDE_ENVELOPE` DOFs.
    fn envelope_is_wide(&self) -> bool {
        self.envelope.stored() as f64 >= WIDE_ENVELOPE * self.envelope.dofs() as f64
    }

    /// Interior-point solves started from the iterate of the solve before
    /// (`InteriorPoint::solve`), and those of them that started again cold.
    pub fn interior_path_starts(&self) -> (u64, u64) {
        (self.interior.path_starts, self.interior.path_failures)
    }

    /// The next solve starts from no solution, no multipliers and no factor.
    fn start_cold(&mut self) {
        self.u.clear();
        self.held.clear();
        self.previous_keys.clear();
        self.previous_lambda.clear();
        self.factored = false;
        self.still = false;
    }

    fn fail(status: String) -> SolveFailure {
        SolveFailure {
            solver: "sparse",
            status,
        }
    }

    /// The blocks in contact, and a new envelope when they changed.
    fn update_envelope(&mut self, n_blocks: usize) {
        self.pairs_now.clear();
        for row in &self.rows {
            let a = row.idx[0] / 3;
            let b = row.idx[row.len - 1] / 3;
            if a != b {
                self.pairs_now.push((a.min(b), a.max(b)));
            }
        }
        self.pairs_now.sort_unstable();
        self.pairs_now.dedup();
        if self.pairs_now != self.pairs || self.envelope.dofs() != 3 * n_blocks {
            std::mem::swap(&mut self.pairs, &mut self.pairs_now);
            self.envelope = Envelope::new(n_blocks, &self.pairs);
            self.factored = false;
        }
    }

    /// Factorise `P + sum_{i in A} rho_i D_i' D_i` for the current active rows.
    fn factorise(&mut self, p: &[f64]) -> Result<(), SolveFailure> {
        self.envelope.clear();
        for (i, &pi) in p.iter().enumerate() {
            self.envelope.add_diagonal(i, pi);
        }
        for (i, row) in self.rows.iter().enumerate() {
            if self.in_matrix[i] {
                self.envelope
                    .add_outer(self.rho[i], &row.idx[..row.len], &row.coef[..row.len]);
            }
        }
        self.factorisations += 1;
        if !self.envelope.factor() {
            self.factored = false;
            return Err(Self::fail("Newton matrix not positive definite".into()));
        }
        self.factored = true;
        self.factored_in.clone_from(&self.in_matrix);
        self.fresh = true;
        Ok(())
    }

    /// Bring a factor built from this problem's rows to the rows now in the Newton matrix by
    /// rank-one updates ([`Envelope::update`]), when at most `UPDATE_SHARE` of the envelope's
    /// mean width of them changed (an update costs a seventh to a fifteenth of a factorisation,
    /// [`super::envelope`]); else the factor is left as it is. A refused downdate drops the
    /// factor. Returns whether the factor is now that of the rows in the Newton matrix.
    fn update_factor(&mut self) -> bool {
        let width = self.envelope.stored() as f64 / self.envelope.dofs() as f64;
        let changed = self
            .in_matrix
            .iter()
            .zip(&self.factored_in)
            .filter(|(a, b)| a != b)
            .count();
        if changed as f64 > UPDATE_SHARE * width {
            return false;
        }
        // Rows entering first: an update cannot fail, and the downdates then take out rows
        // from a matrix that holds more.
        for entering in [true, false] {
            for (i, row) in self.rows.iter().enumerate() {
                if self.in_matrix[i] == entering && self.factored_in[i] != entering {
                    let sigma = if entering { self.rho[i] } else { -self.rho[i] };
                    if !self
                        .envelope
                        .update(sigma, &row.idx[..row.len], &row.coef[..row.len])
                    {
                        self.factored = false;
                        return false;
                    }
                }
            }
        }
        self.updates += changed as u64;
        self.factored = true;
        self.factored_in.clone_from(&self.in_matrix);
        true
    }

    /// Rows with `y_i` below `margin (1 + |r_i|)` are in the Newton matrix (see
    /// [`CLOSED_MARGIN`]).
    fn margin(&self) -> f64 {
        if self.wide || self.last_retry {
            CLOSED_MARGIN
        } else {
            0.0
        }
    }

    /// Whether the factor in hand is that of this problem's rows now in the Newton matrix.
    fn factor_is_exact(&self) -> bool {
        self.fresh && self.factored && self.factored_in == self.in_matrix
    }

    /// `y` at the current `u`, and which rows are in the Newton matrix.
    fn classify(&mut self) {
        let n = self.rows.len();
        self.y.resize(n, 0.0);
        self.in_matrix.resize(n, false);
        dots_into(&self.rows, &self.u, &mut self.row_values);
        let margin = self.margin();
        for i in 0..n {
            let y = self.row_values[i] + self.r[i] - self.lambda[i] / self.rho[i];
            self.in_matrix[i] =
                y < margin * (1.0 + self.r[i].abs()) || self.held.get(i).copied().unwrap_or(false);
            self.y[i] = y;
        }
    }

    /// Whether `u` and the multipliers satisfy the complementarity conditions to the row
    /// tolerance: every row holds, and every loaded row is closed. (Stationarity,
    /// `P u + q = D' l`, holds to Newton's tolerance where this is called.)
    fn kkt_holds(&self, tolerance: f64) -> bool {
        self.rows.iter().enumerate().all(|(i, row)| {
            row_holds(
                row.dot(&self.u) + self.r[i],
                self.lambda[i],
                self.r[i],
                tolerance,
            )
        })
    }

    /// The minimiser of phi along `du` from `u` (phi' is piecewise linear and increasing).
    fn line_search(&mut self, p: &[f64], q: &[f64]) -> f64 {
        let (mut alpha, mut beta) = (0.0, 0.0);
        for (j, &d) in self.du.iter().enumerate() {
            alpha += d * (p[j] * self.u[j] + q[j]);
            beta += d * p[j] * d;
        }
        if beta.is_nan() || beta <= 0.0 {
            return 0.0;
        }
        self.breaks.clear();
        dots_into(&self.rows, &self.du, &mut self.row_values);
        for i in 0..self.rows.len() {
            let d = self.row_values[i];
            let y = self.y[i];
            let rho = self.rho[i];
            if y < 0.0 || (y == 0.0 && d < 0.0) {
                alpha += rho * d * y;
                beta += rho * d * d;
                if d > 0.0 {
                    self.breaks.push((-y / d, i));
                }
            } else if d < 0.0 {
                self.breaks.push((-y / d, i));
            }
        }
        // The breaks are taken in increasing order only up to the minimiser: those below the
        // minimiser of the current pieces are moved to the front and sorted, crossed, and the
        // rest looked at again (a full sort of every break was a sixth of a wall's step).
        let mut done = 0;
        loop {
            let minimiser = -alpha / beta;
            let rest = &mut self.breaks[done..];
            let mut below = 0;
            for k in 0..rest.len() {
                if rest[k].0 < minimiser {
                    rest.swap(k, below);
                    below += 1;
                }
            }
            if below == 0 {
                return minimiser;
            }
            rest[..below].sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            for k in done..done + below {
                let (t, i) = self.breaks[k];
                if -alpha <= beta * t {
                    return -alpha / beta;
                }
                let d = self.row_values[i];
                let (y, rho) = (self.y[i], self.rho[i]);
                // Crossing t toggles row i: active rows with d > 0 leave, others enter.
                let sign = if y < 0.0 || (y == 0.0 && d < 0.0) {
                    -1.0
                } else {
                    1.0
                };
                alpha += sign * rho * d * y;
                beta += sign * rho * d * d;
            }
            done += below;
        }
    }

    /// Minimise phi for the current multipliers; returns the Newton steps taken.
    ///
    /// The factor in hand is used even when it is not exact (built in an earlier step, or for
    /// a slightly different active set) as long as each step shrinks the next one at least
    /// tenfold; otherwise the Newton matrix is factorised from the current rows. A closed
    /// contact carrying no force (a head joint of a wall) sits at `y = 0` to round-off and
    /// flips between active and inactive from one step to the next; the factor in hand
    /// serves it as well as an exact one.
    fn minimise(&mut self, p: &[f64], q: &[f64]) -> Result<usize, SolveFailure> {
        let mut last_step = f64::INFINITY;
        let mut trusted = true;
        let mut refinements = 0;
        let mut still = true;
        let max_newton = if self.last_retry {
            MAX_NEWTON_LAST_RETRY
        } else if self.wide && !self.settling {
            MAX_NEWTON_WIDE
        } else {
            MAX_NEWTON
        };
        for it in 1..=max_newton {
            self.classify();
            let mut exact = self.factor_is_exact();
            if !exact && self.update_factors && self.fresh && self.factored {
                exact = self.update_factor();
            }
            if !self.factored || (!exact && !trusted) {
                if refinements > 0 && (self.wide || still) {
                    // On a wide envelope a refinement is never worth a factorisation, nor where
                    // nothing moves: the residual's work is its dot product with `u`. On a
                    // narrow envelope it is cheap (`REFINED_TOLERANCE`).
                    return Ok(it - 1);
                }
                self.factorise(p)?;
                // On a wide envelope a new factor is trusted until a step with it fails to
                // shrink the next one tenfold (measured on the walls of `WIDE_ENVELOPE`:
                // factorising again at every later change of A doubles the factorisations).
                if self.wide {
                    trusted = true;
                }
            }
            let exact = self.factor_is_exact();
            self.du.clear();
            self.du
                .extend((0..p.len()).map(|j| -(p[j] * self.u[j] + q[j])));
            for (i, row) in self.rows.iter().enumerate() {
                if self.y[i] < 0.0 {
                    row.axpy(-self.rho[i] * self.y[i], &mut self.du);
                }
            }
            // The work of the residual `-du` before the solve, against `u' P u`: on homogeneous
            // rows only (`STAGNATION_WORK`).
            let (mut residual_work, mut kinetic) = (0.0, 0.0);
            if self.homogeneous {
                for (j, (&d, &u)) in self.du.iter().zip(&self.u).enumerate() {
                    residual_work += d * u;
                    kinetic += p[j] * u * u;
                }
            }
            self.envelope.solve(&mut self.du);
            let tau = self.line_search(p, q);
            if tau < STALLED_STEP
                && self.give_up_stalled
                && self.wide
                && self.envelope_is_wide()
                && self.rescue
                && !self.settling
                && !self.last_retry
            {
                self.stalled_warm_starts += 1;
                self.factored = false;
                return Err(Self::fail(format!(
                    "a Newton step cut to {tau:.1e} by the line search on a wide problem"
                )));
            }
            // Converged when the full Newton step is negligible (a step cut short by the line
            // search says nothing about convergence).
            let mut step = 0.0f64;
            let mut size = 0.0f64;
            for (u, d) in self.u.iter_mut().zip(&self.du) {
                *u += tau * d;
                step = step.max(d.abs());
                size = size.max(u.abs());
            }
            still = size <= STILL_SPEED;
            if !(step.is_finite() && tau.is_finite()) {
                self.factored = false;
                return Err(Self::fail("non-finite Newton step".into()));
            }
            if step <= NEWTON_TOLERANCE * (1.0 + size)
                && (step <= self.refined_tolerance * (1.0 + size)
                    || step >= 0.5 * last_step
                    || refinements == MAX_REFINEMENTS)
            {
                return Ok(it);
            }
            if step <= NEWTON_TOLERANCE * (1.0 + size) {
                refinements += 1;
            }
            if (self.last_retry || self.wide)
                && step <= STAGNATION_TOLERANCE * (1.0 + size)
                && step >= 0.5 * last_step
            {
                // Steps that stop shrinking: at the round-off floor of a stiff Newton matrix the
                // outer loop's KKT test decides. Where the residual of homogeneous rows does
                // work, the floor is that of a Newton matrix of other rows (`STAGNATION_WORK`):
                // rows held that the augmented Lagrangian leaves open, or a factor of other
                // rows; the iteration goes on without the first and with a new factor.
                let working = self.homogeneous
                    && size > STILL_SPEED
                    && residual_work.abs() > STAGNATION_WORK * kinetic;
                if working && self.held.contains(&true) {
                    self.held.clear();
                    last_step = f64::INFINITY;
                    continue;
                }
                if working && !exact {
                    trusted = false;
                    last_step = f64::INFINITY;
                    continue;
                }
                if !self.homogeneous {
                    self.stagnations_with_offsets += 1;
                }
                return Ok(it);
            }
            if !exact && step > 0.1 * last_step {
                trusted = false;
            }
            last_step = step;
        }
        self.factored = false;
        Err(Self::fail(format!(
            "Newton's iteration did not converge in {max_newton} steps"
        )))
    }
}

impl ContactSolver for SparseSolver {
    fn name(&self) -> &'static str {
        "sparse"
    }
    fn factorisations(&self) -> u64 {
        self.factorisations
    }
    fn rescues(&self) -> u64 {
        self.rescues
    }
    fn factor_updates(&self) -> u64 {
        self.updates
    }
    fn save(&self) -> Vec<u8> {
        super::to_bytes(self)
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let restored: Self = super::from_bytes(state, "the sparse back-end")?;
        restored
            .envelope
            .check_built_from(&restored.pairs)
            .map_err(|e| format!("the sparse back-end: {e}"))?;
        *self = restored;
        Ok(())
    }

    /// See `SparseSolver::solve_step`.
    fn solve_into(&mut self, pr: &StepProblem, out: &mut StepSolution) -> Result<(), SolveFailure> {
        *out = self.solve_step(pr)?;
        Ok(())
    }
}

impl SparseSolver {
    /// Warm from the last problem's solution and multipliers (after a rescued problem, a
    /// problem of the same step with the same rows first with the rows the rescue held:
    /// [`SparseSolver::solve_holding_rescued`]);
    /// on a wide envelope a problem that
    /// does not converge from there goes to the interior-point rescue; a problem still unsolved
    /// is solved again cold before it counts as failed. (The impact
    /// stepper's velocity problems are homogeneous in the velocities, whose size changes by
    /// orders of magnitude from one to the next, so a warm start can set the working rows at
    /// the wrong scale: measured, Newton's iteration stalls on 100 of 200 steps of a 215-block
    /// wall at rest, and converges on every one of them cold.) A problem the cold start does
    /// not solve either gets a last retry, cold, with up to `MAX_NEWTON_LAST_RETRY` Newton steps
    /// and stagnation at round-off accepted (`STAGNATION_TOLERANCE`, accepted on every solve of
    /// a wide envelope).
    /// (The 29 problems of the 215-block wall under El Centro x2, 5 s, that fell back to
    /// Clarabel before closed rows were held in the Newton matrix, `CLOSED_MARGIN`, did not
    /// converge in 60 Newton steps warm or cold.)
    fn solve_step(&mut self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        if self.cold_after_motion && !self.still {
            self.start_cold();
        }
        let warm = !self.u.is_empty() || !self.previous_keys.is_empty();
        let after_rescue = std::mem::take(&mut self.last_rescued);
        let reused = if after_rescue && warm && self.reuse_rescues && pr.v0 == self.rescued_v0 {
            self.rescue_holds_tried += 1;
            self.solve_holding_rescued(pr).ok()
        } else {
            None
        };
        self.rescues_reused += u64::from(reused.is_some());
        let mut result = match reused {
            Some(solution) => Ok(solution),
            None => self.solve_warm(pr),
        };
        if result.is_err() && self.wide && self.rescue {
            result = self.rescue(pr);
        }
        if result.is_err() {
            self.start_cold();
            // On a wide envelope the cold start is the last retry from the outset: the two
            // differ there only in the Newton steps allowed, so a cold start that failed would
            // be repeated step for step by the last retry and then continued.
            let mut last_retried = false;
            if warm {
                self.cold_restarts += 1;
                last_retried = self.wide;
                self.last_retries += u64::from(last_retried);
                self.last_retry = last_retried;
                result = self.solve_warm(pr);
                self.last_retry = false;
                if result.is_err() {
                    self.start_cold();
                }
            }
            if result.is_err() && !last_retried {
                // The last retry: cold, a longer Newton iteration, stagnation accepted.
                self.last_retries += 1;
                self.last_retry = true;
                result = self.solve_warm(pr);
                self.last_retry = false;
                if result.is_err() {
                    self.start_cold();
                }
            }
        }
        result
    }
}

impl SparseSolver {
    /// The interior-point rescue of a problem on a wide envelope whose first solve failed.
    /// Where a wall moves, a problem's active rows differ from the last problem's by hundreds,
    /// and the augmented Lagrangian's Newton steps from a warm (or cold) start stall: along
    /// each Newton direction rows that carry no force are crossed at once (line-search factors
    /// of 1e-7 to 1e-4; measured on the 215-block wall under a 0.8 g pulse), and a cold start
    /// builds its active rows a few at a time (some 200 factorisations a problem on the
    /// 430-block wall). Interior-point iterations, whose count does not depend on the active
    /// rows, go to `RESCUE_TOLERANCE` (some 20-30 iterations, one factorisation each); the
    /// augmented Lagrangian then settles their solution to this back-end's tolerances from
    /// their multipliers, with the rows they closed held in the Newton matrix (without the hold
    /// its Newton steps from there stalled as before), in one to three factorisations.
    ///
    /// A problem with the rows of the last interior-point solve, and its step's length, starts
    /// from that solve's iterate near the central path (`InteriorPoint::solve`). Where the
    /// settle fails, the interior point goes on from where it stopped towards
    /// `RESUMED_TOLERANCE` for at most `RESUMED_ITERATIONS`, and its last iterate is settled
    /// again (`resume_rescues`); what still fails goes on to the cold retries.
    fn rescue(&mut self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let sc = pr.scaled();
        if self.rows.is_empty() || self.envelope.dofs() != sc.p.len() {
            return Err(Self::fail("no rows to rescue".into()));
        }
        self.rescues += 1;
        self.factored = false;
        let (mut u, mut l) = (Vec::new(), Vec::new());
        // The interior point's kept iterate is that of the last solve, whatever its outcome.
        let from_path = self.reuse_rescues && pr.dt == self.rescued_dt;
        self.rescued_dt = pr.dt;
        self.interior
            .solve(
                &mut self.envelope,
                (&sc.p, &sc.q),
                (&self.rows, &self.r),
                RESCUE_TOLERANCE,
                (&mut u, &mut l),
                &mut self.factorisations,
                from_path,
            )
            .map_err(Self::fail)?;
        let kept = self.resume_rescues.then(|| (u.clone(), l.clone()));
        let mut result = self.settle_rescued(pr, u, l);
        if let (Err(_), Some((mut u, mut l))) = (&result, kept) {
            self.resumed_rescues += 1;
            self.interior
                .resume(
                    &mut self.envelope,
                    ((&sc.p, &sc.q), (&self.rows, &self.r)),
                    RESUMED_TOLERANCE,
                    (&mut u, &mut l),
                    &mut self.factorisations,
                    RESUMED_ITERATIONS,
                )
                .map_err(Self::fail)?;
            // The interior point's iterations replaced the envelope's factor; its last iterate
            // is settled whether or not it reached `RESUMED_TOLERANCE` (the settle decides).
            self.factored = false;
            result = self.settle_rescued(pr, u, l);
            self.resumed_settled += u64::from(result.is_ok());
        }
        self.last_rescued = result.is_ok();
        self.rescued_v0.clone_from(&pr.v0);
        result
    }

    /// The augmented Lagrangian's settle of an interior-point solution `(u, l)`: the rows it
    /// closed (`s_i < l_i`, or `s_i` below `RESCUE_TOLERANCE`) held in the Newton matrix.
    fn settle_rescued(
        &mut self,
        pr: &StepProblem,
        u: Vec<f64>,
        l: Vec<f64>,
    ) -> Result<StepSolution, SolveFailure> {
        let slack = self.interior.slack();
        self.held.clear();
        self.held.extend(
            (0..self.rows.len())
                .map(|i| slack[i] < l[i] || slack[i] < RESCUE_TOLERANCE * (1.0 + self.r[i].abs())),
        );
        self.rescued_keys.clear();
        self.rescued_keys.extend(self.rows.iter().map(|r| r.key));
        self.rescued_keys.sort_unstable();
        self.rescued_held.clear();
        self.rescued_held.extend(
            (0..self.rows.len())
                .filter(|&i| self.held[i])
                .map(|i| self.rows[i].key),
        );
        self.rescued_held.sort_unstable();
        self.u = u;
        self.previous_keys.clear();
        self.previous_keys.extend(self.rows.iter().map(|r| r.key));
        self.previous_lambda = l;
        self.previous_dt = pr.dt;
        self.settling = true;
        let result = self.solve_warm(pr);
        self.settling = false;
        self.held.clear();
        result
    }

    /// A problem after a rescued one, with its rows (the second discrete-gradient solve of a
    /// step, which differs from the first by its drift), solved from the warm start as the
    /// rescue's solution was settled: the rows the rescue held stay in the Newton matrix. From
    /// the warm start alone its Newton steps stall as the first problem's did ("Why the warm
    /// starts fail there", docs/walls.md). If this fails, the problem is solved as any other,
    /// from the same warm start.
    ///
    /// Only a problem that starts from the rescued problem's velocities (its step, or a
    /// sub-step from the same instant) is tried so: the next step's rows can have the same
    /// keys, but the rows the rescue held no longer match its solution, and there the Newton
    /// steps with them zigzag (the exact line search stretching them 1.5 to 2.9 times,
    /// alternately, up to 4.1 in the first steps) until `MAX_NEWTON` runs out. Measured
    /// (`wall_steps`, ten steps of the 0.8 g pulse; docs/walls.md, "A rigidly sliding wall"):
    /// the 215-block wall sliding as one piece (its base at friction 0.5) 274 -> 247
    /// factorisations and 11.1 -> 7.8 ms a step at step ends, 216 -> 195 and 9.2 -> 6.5 ms
    /// located; the located sliding 107-block wall 45.0 -> 27.3 factorisations and 8.8 -> 5.1 ms
    /// a step; the sliding walls of 215 / 430 / 860 blocks at step ends and the located
    /// 215-block wall the same factorisations.
    fn solve_holding_rescued(&mut self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let start = self.u.clone();
        self.hold_rescued = true;
        self.settling = true;
        let result = self.solve_warm(pr);
        self.hold_rescued = false;
        self.settling = false;
        self.held.clear();
        if result.is_err() {
            self.u = start;
        }
        result
    }

    fn solve_warm(&mut self, pr: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let sc = pr.scaled();
        let n = pr.n_dof();
        if !n.is_multiple_of(3) {
            return Err(Self::fail(format!("{n} DOFs is not 3 per block")));
        }
        self.pinv.clear();
        self.pinv.extend(sc.p.iter().map(|p| 1.0 / p));
        edge_rows(pr, &mut self.rows, &mut self.r);
        self.homogeneous = self.r.iter().all(|&r| r == 0.0);
        self.fresh = false;
        if self.hold_rescued {
            self.keys_now.clear();
            self.keys_now.extend(self.rows.iter().map(|r| r.key));
            self.keys_now.sort_unstable();
            if self.keys_now != self.rescued_keys {
                return Err(Self::fail("not the rescued problem's rows".into()));
            }
            self.held.clear();
            self.held.extend(
                self.rows
                    .iter()
                    .map(|r| self.rescued_held.binary_search(&r.key).is_ok()),
            );
        }
        if self.rows.is_empty() {
            // Free flight.
            self.u.clear();
            self.u.extend((0..n).map(|j| -sc.q[j] * self.pinv[j]));
            self.previous_keys.clear();
            self.previous_lambda.clear();
            return Ok(step_solution(pr, sc.s, &self.u, &[], 0));
        }
        self.rho_base.clear();
        for row in &self.rows {
            let w: f64 = (0..row.len)
                .map(|j| row.coef[j] * row.coef[j] * self.pinv[row.idx[j]])
                .sum();
            if w.is_nan() || w <= 0.0 {
                return Err(Self::fail("a contact row without coefficients".into()));
            }
            self.rho_base.push(RHO / w);
        }
        // Multipliers from the previous step: row by row while the rows are the same ones,
        // else by key (new rows start unloaded).
        let same_rows = self.envelope.dofs() == n
            && self.rows.len() == self.previous_keys.len()
            && self
                .rows
                .iter()
                .zip(&self.previous_keys)
                .all(|(r, &k)| r.key == k);
        self.lambda.clear();
        if same_rows {
            self.lambda.extend_from_slice(&self.previous_lambda);
        } else {
            self.by_key.clear();
            self.by_key.extend(
                self.previous_keys
                    .iter()
                    .copied()
                    .zip(self.previous_lambda.iter().copied()),
            );
            self.by_key.sort_unstable_by_key(|e| e.0);
            for row in &self.rows {
                let l = self
                    .by_key
                    .binary_search_by_key(&row.key, |e| e.0)
                    .map_or(0.0, |k| self.by_key[k].1);
                self.lambda.push(l);
            }
            self.update_envelope(n / 3);
        }
        if self.previous_dt > 0.0 && self.previous_dt != pr.dt {
            let ratio = pr.dt / self.previous_dt;
            for l in &mut self.lambda {
                *l *= ratio;
            }
        }
        self.wide = self.envelope_is_wide() || n >= LARGE_PROBLEM;
        let start = if (self.wide || (same_rows && self.still)) && !self.last_retry {
            RHO_WIDE / RHO
        } else {
            1.0
        };
        self.rho.clear();
        self.rho.extend(self.rho_base.iter().map(|b| b * start));
        self.refined_tolerance = REFINED_TOLERANCE;
        if self.wide {
            let (lightest, heaviest) =
                sc.p.iter()
                    .step_by(3)
                    .fold((f64::INFINITY, 0.0f64), |(lo, hi), &m| {
                        (lo.min(m), hi.max(m))
                    });
            self.refined_tolerance = NEWTON_TOLERANCE
                * (lightest / heaviest).clamp(REFINED_TOLERANCE / NEWTON_TOLERANCE, 1.0);
        }
        // Start from the previous step's solution (velocities are continuous), or else from
        // the minimiser of the Lagrangian for the warm-started multipliers.
        if self.u.len() != n {
            self.u.clear();
            self.u.extend((0..n).map(|j| -sc.q[j]));
            for (row, &l) in self.rows.iter().zip(&self.lambda) {
                row.axpy(l, &mut self.u);
            }
            for (u, pi) in self.u.iter_mut().zip(&self.pinv) {
                *u *= pi;
            }
        }
        let mut newton = 0;
        let mut converged = false;
        let mut last_change = f64::INFINITY;
        for _ in 0..MAX_OUTER {
            newton += self.minimise(&sc.p, &sc.q)?;
            // The update, and `kkt_holds(ROW_TOLERANCE)` with the new multipliers in the same
            // pass over the rows.
            let mut change = 0.0f64;
            let mut holds = true;
            dots_into(&self.rows, &self.u, &mut self.row_values);
            for i in 0..self.rows.len() {
                let c = self.row_values[i] + self.r[i];
                let l = (self.lambda[i] - self.rho[i] * c).max(0.0);
                change = change.max((l - self.lambda[i]).abs() / self.rho[i]);
                self.lambda[i] = l;
                holds &= row_holds(c, l, self.r[i], ROW_TOLERANCE);
            }
            if holds {
                converged = true;
                break;
            }
            let stiffest = self.rho[0] >= self.rho_base[0] * RHO_MAX / RHO;
            if stiffest && change > 0.9 * last_change && self.kkt_holds(CONSISTENCY_TOLERANCE) {
                // Rows that are dependent in exact arithmetic (a flat interface) can disagree
                // by more than the row tolerance in floating point; the multipliers then creep
                // for ever. Accepted at the dense back-end's consistency level.
                converged = true;
                break;
            }
            // Slow multiplier convergence: stiffen every row tenfold (a new Newton matrix).
            if change > 0.25 * last_change && !stiffest {
                for (rho, base) in self.rho.iter_mut().zip(&self.rho_base) {
                    *rho = (*rho * 10.0).min(base * RHO_MAX / RHO);
                }
                self.factored = false;
            }
            last_change = change;
        }
        if !converged {
            return Err(Self::fail(format!(
                "multipliers did not settle in {MAX_OUTER} updates"
            )));
        }
        self.still = self.u.iter().all(|u| u.abs() <= STILL_SPEED);
        self.previous_keys.clear();
        self.previous_keys.extend(self.rows.iter().map(|r| r.key));
        self.previous_lambda.clone_from(&self.lambda);
        self.previous_dt = pr.dt;
        Ok(step_solution(
            pr,
            sc.s,
            &self.u,
            &self.lambda,
            newton as u32,
        ))
    }
}
