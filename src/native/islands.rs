//! Independent islands of touching blocks, solved as separate problems.
//!
//! The one-step problem (see [`super::problem`]) couples two blocks only through a contact
//! point between them: `Mbar` is diagonal and a ground point's rows hold one block's DOFs. Its
//! objective and constraints are therefore sums over the connected components of the graph
//! whose nodes are the blocks and whose edges are the block-block points (ground points do not
//! connect), and the QP splits exactly into one QP per component (an *island*). [`Islands`]
//! splits a [`StepProblem`] (whatever stepper built it), solves each island with its own
//! back-end (kept from step to step, so that its warm start and factor stay its own), and
//! reassembles the solution; a block without any contact point moves freely,
//! `dq = dt v0 + theta dt^2 f/m` (the unconstrained minimiser of the primal).
//!
//! Islands are solved in parallel (rayon) when there are at least two with `PARALLEL_DOFS`
//! DOFs or more; smaller ones are not worth a thread.
//!
//! A problem that is one island of every block (a block on the ground, a stack, a standing
//! wall) goes to its back-end whole, without a copy.
//!
//! An island's back-end is keyed by the island's lowest block index; when islands merge or
//! split, each part keeps the back-end of its lowest block (multipliers are matched by contact
//! key, so the warm start survives a change of membership).

use super::problem::{ContactRows, SparseRow, StepProblem, StepSolution};
use super::solver::{Blob, ContactSolver, SolveFailure};
use crate::geometry::ContactPoint;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Islands of at least this many DOFs are worth solving on a thread of their own.
pub const PARALLEL_DOFS: usize = 150;

/// The connected components of the blocks through block-block contact points: for each block
/// its island (numbered by increasing lowest block), or `None` for a block without contacts.
pub fn components(n_blocks: usize, contacts: &[ContactRows]) -> Vec<Option<usize>> {
    let mut scratch = Components::default();
    scratch.find(n_blocks, contacts);
    scratch.island
}

/// Which islands (numbered as by [`components`], `island` block by block) hold one of
/// `blocks`.
pub fn holding(island: &[Option<usize>], blocks: impl IntoIterator<Item = usize>) -> Vec<bool> {
    let mut held = Vec::new();
    holding_into(island, blocks, &mut held);
    held
}

/// [`holding`] into `held`.
pub fn holding_into(
    island: &[Option<usize>],
    blocks: impl IntoIterator<Item = usize>,
    held: &mut Vec<bool>,
) {
    held.clear();
    held.resize(island.iter().flatten().max().map_or(0, |m| m + 1), false);
    for b in blocks {
        if let Some(i) = island[b] {
            held[i] = true;
        }
    }
}

/// [`components`] of detected contact points (before any rows are built).
pub fn components_of_points(n_blocks: usize, points: &[ContactPoint]) -> Vec<Option<usize>> {
    let mut scratch = Components::default();
    scratch.link(n_blocks, points.iter().map(|c| (c.a.unwrap_or(c.b), c.b)));
    scratch.island
}

/// The blocks of each island (numbered as by [`components`]), in increasing order; blocks
/// without contacts are in none.
pub fn members(island: &[Option<usize>]) -> Vec<Vec<usize>> {
    let mut sets = vec![Vec::new(); island.iter().flatten().max().map_or(0, |m| m + 1)];
    for (block, i) in island.iter().enumerate() {
        if let Some(i) = i {
            sets[*i].push(block);
        }
    }
    sets
}

/// [`components`] with its working storage kept from call to call.
#[derive(Default, serde::Serialize, serde::Deserialize)]
pub struct Components {
    parent: Vec<usize>,
    touched: Vec<bool>,
    number: Vec<usize>,
    /// The result of the last [`Components::find`].
    island: Vec<Option<usize>>,
}

impl Components {
    /// [`components`] of `contacts`: the result is [`Components::island`].
    pub fn find(&mut self, n_blocks: usize, contacts: &[ContactRows]) {
        self.link(
            n_blocks,
            contacts.iter().filter_map(|c| {
                let first = c.nrow.first().map(|e| e.0 / 3);
                let last = c.nrow.last().map(|e| e.0 / 3);
                first.zip(last)
            }),
        );
    }

    /// Each block's island found by the last [`Components::find`].
    pub fn island(&self) -> &[Option<usize>] {
        &self.island
    }

    /// The components of the graph of the blocks joined by `links` (a block linked to itself
    /// is in an island of its own).
    fn link(&mut self, n_blocks: usize, links: impl Iterator<Item = (usize, usize)>) {
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let parent = &mut self.parent;
        parent.clear();
        parent.extend(0..n_blocks);
        let touched = &mut self.touched;
        touched.clear();
        touched.resize(n_blocks, false);
        for (a, b) in links {
            touched[a] = true;
            touched[b] = true;
            let (ra, rb) = (root(parent, a), root(parent, b));
            if ra != rb {
                // The lower index becomes the root, so that roots are lowest blocks.
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
        self.number.clear();
        self.number.resize(n_blocks, usize::MAX);
        self.island.clear();
        self.island.resize(n_blocks, None);
        let mut next = 0;
        for (b, &touched) in touched.iter().enumerate() {
            if !touched {
                continue;
            }
            let r = root(parent, b);
            if self.number[r] == usize::MAX {
                self.number[r] = next;
                next += 1;
            }
            self.island[b] = Some(self.number[r]);
        }
    }
}

/// One island's sub-problem and where its parts go in the whole.
struct Part {
    /// Lowest block index (the key of its back-end).
    key: usize,
    /// Global block indices, increasing.
    blocks: Vec<usize>,
    /// Global contact indices, increasing.
    contacts: Vec<usize>,
    problem: StepProblem,
}

/// A back-end that solves each island of a problem with its own instance of another.
pub struct Islands {
    make: Box<dyn Fn() -> Box<dyn ContactSolver> + Send>,
    name: &'static str,
    solvers: BTreeMap<usize, Box<dyn ContactSolver>>,
    /// Fallbacks, factorisations, rescues and factor updates of back-ends already dropped.
    retired: (u64, u64, u64, u64),
    /// Islands solved in all (for diagnostics).
    pub islands_solved: u64,
    components: Components,
}

impl Islands {
    /// A counter summed over the islands' back-ends in use.
    fn counted(&self, counter: impl Fn(&dyn ContactSolver) -> u64) -> u64 {
        self.solvers.values().map(|s| counter(s.as_ref())).sum()
    }

    pub fn new(name: &'static str, make: Box<dyn Fn() -> Box<dyn ContactSolver> + Send>) -> Self {
        Islands {
            make,
            name,
            solvers: BTreeMap::new(),
            retired: (0, 0, 0, 0),
            islands_solved: 0,
            components: Components::default(),
        }
    }

    /// Retire the back-ends of islands that no longer exist, keeping their counts: those keyed
    /// by a block that is in one of this problem's islands (`island`) but keys none of them
    /// (`keys`). A back-end keyed by a block this problem does not hold (no contact point) is
    /// kept: the stepper hands the back-end one island's problem at a time when it locates
    /// impacts per island, and the other islands' back-ends must keep their warm starts.
    fn retire(&mut self, keys: &[usize], island: &[Option<usize>]) {
        let gone: Vec<usize> = self
            .solvers
            .keys()
            .copied()
            .filter(|&k| !keys.contains(&k) && island.get(k).is_some_and(Option::is_some))
            .collect();
        for k in gone {
            if let Some(s) = self.solvers.remove(&k) {
                self.retired.0 += s.fallbacks();
                self.retired.1 += s.factorisations();
                self.retired.2 += s.rescues();
                self.retired.3 += s.factor_updates();
            }
        }
    }

    /// Split a problem into its islands (numbered by [`components`]) and the blocks without
    /// contacts.
    fn split(pr: &StepProblem, island: &[Option<usize>]) -> (Vec<Part>, Vec<usize>) {
        let n_blocks = pr.n_dof() / 3;
        let n_islands = island.iter().flatten().max().map_or(0, |m| m + 1);
        let mut blocks = vec![Vec::new(); n_islands];
        let mut free = Vec::new();
        for (b, i) in island.iter().enumerate() {
            match i {
                Some(i) => blocks[*i].push(b),
                None => free.push(b),
            }
        }
        let mut contacts = vec![Vec::new(); n_islands];
        for (k, c) in pr.contacts.iter().enumerate() {
            if let Some(&(dof, _)) = c.nrow.first()
                && let Some(i) = island[dof / 3]
            {
                contacts[i].push(k);
            }
        }
        let mut local = vec![usize::MAX; n_blocks];
        let parts = blocks
            .into_iter()
            .zip(contacts)
            .map(|(blocks, contacts)| {
                for (l, &b) in blocks.iter().enumerate() {
                    local[b] = l;
                }
                let dofs = |v: &[f64]| -> Vec<f64> {
                    blocks
                        .iter()
                        .flat_map(|&b| v[3 * b..3 * b + 3].iter().copied())
                        .collect()
                };
                let remap = |row: &[(usize, f64)]| -> SparseRow {
                    row.iter()
                        .map(|&(i, c)| (3 * local[i / 3] + i % 3, c))
                        .collect()
                };
                let problem = StepProblem {
                    theta: pr.theta,
                    dt: pr.dt,
                    mass: dofs(&pr.mass),
                    force: dofs(&pr.force),
                    v0: dofs(&pr.v0),
                    contacts: contacts
                        .iter()
                        .map(|&k| {
                            let c = &pr.contacts[k];
                            ContactRows {
                                key: c.key,
                                mu: c.mu,
                                g_n: c.g_n,
                                g_t: c.g_t,
                                nrow: remap(&c.nrow),
                                trow: remap(&c.trow),
                            }
                        })
                        .collect(),
                };
                Part {
                    key: blocks[0],
                    blocks,
                    contacts,
                    problem,
                }
            })
            .collect();
        (parts, free)
    }
}

impl Islands {
    /// Solve a problem that is one island with the back-end of block 0's island, into `out`.
    fn solve_whole(
        &mut self,
        pr: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        self.islands_solved += 1;
        let make = &self.make;
        self.solvers
            .entry(0)
            .or_insert_with(|| make())
            .solve_into(pr, out)
    }

    /// Solve a problem of several blocks island by island, into `out`.
    fn solve_split(
        &mut self,
        pr: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        self.components.find(pr.n_dof() / 3, &pr.contacts);
        let island = &self.components.island;
        if !island.is_empty() && island.iter().all(|&i| i == Some(0)) {
            // One island of every block (a single block on the ground, a stack, a standing
            // wall): its sub-problem would be the problem itself.
            let island = std::mem::take(&mut self.components.island);
            self.retire(&[0], &island);
            self.components.island = island;
            return self.solve_whole(pr, out);
        }
        let (parts, free) = Self::split(pr, island);
        let keys: Vec<usize> = parts.iter().map(|p| p.key).collect();
        let island = std::mem::take(&mut self.components.island);
        self.retire(&keys, &island);
        self.components.island = island;
        let mut work: Vec<(Part, Box<dyn ContactSolver>)> = parts
            .into_iter()
            .map(|p| {
                let s = self.solvers.remove(&p.key).unwrap_or_else(|| (self.make)());
                (p, s)
            })
            .collect();
        let large = work
            .iter()
            .filter(|(p, _)| p.problem.n_dof() >= PARALLEL_DOFS)
            .count();
        let results: Vec<Result<StepSolution, SolveFailure>> = if large >= 2 {
            work.par_iter_mut()
                .map(|(p, s)| s.solve(&p.problem))
                .collect()
        } else {
            work.iter_mut().map(|(p, s)| s.solve(&p.problem)).collect()
        };
        self.islands_solved += work.len() as u64;
        out.dq.clear();
        out.dq.resize(pr.n_dof(), 0.0);
        out.normal.clear();
        out.normal.resize(pr.contacts.len(), 0.0);
        out.tangential.clear();
        out.tangential.resize(pr.contacts.len(), 0.0);
        out.iterations = 0;
        out.polished = false;
        let mut failure = None;
        for ((p, s), r) in work.into_iter().zip(results) {
            self.solvers.insert(p.key, s);
            match r {
                Ok(sol) => {
                    for (l, &b) in p.blocks.iter().enumerate() {
                        out.dq[3 * b..3 * b + 3].copy_from_slice(&sol.dq[3 * l..3 * l + 3]);
                    }
                    for (l, &k) in p.contacts.iter().enumerate() {
                        out.normal[k] = sol.normal[l];
                        out.tangential[k] = sol.tangential[l];
                    }
                    out.iterations += sol.iterations;
                    out.polished |= sol.polished;
                }
                Err(e) => failure = failure.or(Some(e)),
            }
        }
        if let Some(e) = failure {
            return Err(e);
        }
        // Free blocks: the unconstrained minimiser, Mbar dq = fbar0.
        for b in free {
            for i in 3 * b..3 * b + 3 {
                out.dq[i] = pr.dt * (pr.v0[i] + pr.theta * pr.dt * pr.force[i] / pr.mass[i]);
            }
        }
        Ok(())
    }
}

impl ContactSolver for Islands {
    fn name(&self) -> &'static str {
        self.name
    }

    fn solve_into(&mut self, pr: &StepProblem, out: &mut StepSolution) -> Result<(), SolveFailure> {
        if pr.n_dof() == 3 && !pr.contacts.is_empty() {
            // One block with contact points: one island, no other back-end to retire.
            return self.solve_whole(pr, out);
        }
        self.solve_split(pr, out)
    }

    fn fallbacks(&self) -> u64 {
        self.retired.0 + self.counted(|s| s.fallbacks())
    }

    fn factorisations(&self) -> u64 {
        self.retired.1 + self.counted(|s| s.factorisations())
    }

    fn rescues(&self) -> u64 {
        self.retired.2 + self.counted(|s| s.rescues())
    }

    fn factor_updates(&self) -> u64 {
        self.retired.3 + self.counted(|s| s.factor_updates())
    }

    /// Each island's back-end by its key, the retired counts and the components' storage.
    fn save(&self) -> Vec<u8> {
        let solvers: Vec<(usize, Blob)> = self
            .solvers
            .iter()
            .map(|(&k, s)| (k, Blob(s.save())))
            .collect();
        super::solver::to_bytes(&(solvers, self.retired, self.islands_solved, &self.components))
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        type Saved = (Vec<(usize, Blob)>, (u64, u64, u64, u64), u64, Components);
        let (solvers, retired, solved, components): Saved =
            super::solver::from_bytes(state, "the islands' back-ends")?;
        self.solvers.clear();
        for (key, bytes) in solvers {
            let mut solver = (self.make)();
            solver.restore(&bytes.0)?;
            self.solvers.insert(key, solver);
        }
        (self.retired, self.islands_solved, self.components) = (retired, solved, components);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::native::solver::SparseSolver;

    fn point(key: u64, a: Option<usize>, b: usize) -> ContactRows {
        let mut nrow = SparseRow::new();
        if let Some(a) = a {
            nrow.extend([(3 * a, 0.0), (3 * a + 1, -1.0), (3 * a + 2, 0.1)]);
        }
        nrow.extend([(3 * b, 0.0), (3 * b + 1, 1.0), (3 * b + 2, -0.1)]);
        let trow = nrow.iter().map(|&(i, c)| (i, 1.0 - c)).collect();
        ContactRows {
            key,
            mu: 0.5,
            g_n: 0.0,
            g_t: 0.0,
            nrow,
            trow,
        }
    }

    #[test]
    fn blocks_join_islands_through_block_points_only() {
        // 0-1 touch, 1 and 3 on the ground, 2 free, 3-4 touch, 5 on the ground alone.
        let contacts = vec![
            point(1, Some(0), 1),
            point(2, None, 1),
            point(3, None, 3),
            point(4, Some(4), 3),
            point(5, None, 5),
        ];
        let c = components(6, &contacts);
        assert_eq!(c, vec![Some(0), Some(0), None, Some(1), Some(1), Some(2)]);
    }

    #[test]
    fn members_lists_each_islands_blocks_and_leaves_free_blocks_out() {
        let island = [Some(1), None, Some(0), Some(1), Some(0)];
        assert_eq!(members(&island), [vec![2, 4], vec![0, 3]]);
        assert!(members(&[None, None]).is_empty());
    }

    /// A problem with two islands and a free block: the split solution equals the whole one
    /// solved by the same back-end, forces on the right contacts.
    #[test]
    fn the_split_solution_is_the_whole_solution() {
        let n = 6;
        let mass: Vec<f64> = (0..3 * n).map(|i| 1.0 + (i % 3) as f64 * 0.1).collect();
        let force: Vec<f64> = (0..3 * n)
            .map(|i| if i % 3 == 1 { -9.81 } else { 0.3 })
            .collect();
        let v0: Vec<f64> = (0..3 * n).map(|i| 0.01 * (i as f64).sin()).collect();
        let pr = StepProblem {
            theta: 0.7,
            dt: 1e-3,
            mass,
            force,
            v0,
            contacts: vec![
                point(1, Some(0), 1),
                point(2, None, 0),
                point(3, None, 3),
                point(4, Some(3), 4),
                point(5, None, 5),
            ],
        };
        let whole = SparseSolver::new().solve(&pr).unwrap();
        let mut split = Islands::new("sparse", Box::new(|| Box::new(SparseSolver::new())));
        let parts = split.solve(&pr).unwrap();
        for i in 0..3 * n {
            assert!(
                (whole.dq[i] - parts.dq[i]).abs() <= 1e-15 + 1e-9 * whole.dq[i].abs(),
                "dof {i}: {} vs {}",
                whole.dq[i],
                parts.dq[i]
            );
        }
        for k in 0..pr.contacts.len() {
            let scale = 1.0 + whole.normal[k].abs();
            assert!((whole.normal[k] - parts.normal[k]).abs() <= 1e-9 * scale);
            assert!((whole.tangential[k] - parts.tangential[k]).abs() <= 1e-9 * scale);
        }
        assert!(whole.normal.iter().any(|&n| n > 0.0));
    }

    /// A problem that is one island of every block goes to that island's back-end whole:
    /// the same answer, to the bit, as the back-end alone; and the island keeps its back-end
    /// (and its counts) through a step in which it split in two.
    #[test]
    fn one_island_of_every_block_is_solved_whole() {
        let n = 3;
        let problem = |contacts: Vec<ContactRows>| StepProblem {
            theta: 0.5,
            dt: 1e-3,
            mass: vec![1.0; 3 * n],
            force: (0..3 * n)
                .map(|i| if i % 3 == 1 { -9.81 } else { 0.2 })
                .collect(),
            v0: vec![0.0; 3 * n],
            contacts,
        };
        let joined = problem(vec![
            point(1, None, 0),
            point(2, Some(0), 1),
            point(3, Some(1), 2),
        ]);
        let split_apart = problem(vec![
            point(1, None, 0),
            point(2, Some(0), 1),
            point(3, None, 2),
        ]);
        let whole = SparseSolver::new().solve(&joined).unwrap();
        let mut islands = Islands::new("sparse", Box::new(|| Box::new(SparseSolver::new())));
        let first = islands.solve(&joined).unwrap();
        assert_eq!(first.dq, whole.dq);
        assert_eq!(first.normal, whole.normal);
        assert_eq!(islands.islands_solved, 1);
        let factorisations = islands.factorisations();
        assert!(factorisations > 0);
        islands.solve(&split_apart).unwrap();
        assert_eq!(islands.islands_solved, 3);
        islands.solve(&joined).unwrap();
        assert_eq!(islands.islands_solved, 4);
        assert!(islands.factorisations() >= factorisations);
    }
}
