//! Contact solver back-ends: each solves a [`StepProblem`] and reports its status.

mod active_set;
mod clarabel_qp;
pub mod polish;

pub use active_set::ActiveSetSolver;
pub use clarabel_qp::ClarabelSolver;

use super::settings::{NativeSettings, SolverKind};

use super::problem::{StepProblem, StepSolution};

/// Why a back-end could not give an acceptable solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{solver}: {status}")]
pub struct SolveFailure {
    pub solver: &'static str,
    pub status: String,
}

/// A contact solver back-end.
pub trait ContactSolver: Send {
    fn name(&self) -> &'static str;
    fn solve(&mut self, problem: &StepProblem) -> Result<StepSolution, SolveFailure>;
    /// Steps this back-end handed to its fallback (Clarabel).
    fn fallbacks(&self) -> u64 {
        0
    }
}

/// A fast back-end with Clarabel behind it: a step the primary cannot solve is solved by
/// Clarabel and counted.
pub struct WithFallback {
    primary: Box<dyn ContactSolver>,
    backup: ClarabelSolver,
    fallbacks: u64,
    /// Problems with more DOFs than this go straight to Clarabel.
    max_dofs: usize,
}

impl ContactSolver for WithFallback {
    fn name(&self) -> &'static str {
        self.primary.name()
    }
    fn solve(&mut self, problem: &StepProblem) -> Result<StepSolution, SolveFailure> {
        if problem.n_dof() <= self.max_dofs
            && let Ok(s) = self.primary.solve(problem)
        {
            return Ok(s);
        }
        self.fallbacks += 1;
        self.backup.solve(problem)
    }
    fn fallbacks(&self) -> u64 {
        self.fallbacks
    }
}

/// Largest problem (in DOFs, 3 per block) the dense active-set back-end takes under `auto`.
pub const AUTO_DENSE_MAX_DOFS: usize = 60;

/// The back-end a scene's settings ask for.
pub fn solver_for(s: &NativeSettings) -> Box<dyn ContactSolver> {
    match s.solver {
        SolverKind::Clarabel => Box::new(ClarabelSolver::new(s)),
        SolverKind::ActiveSet => Box::new(WithFallback {
            primary: Box::new(ActiveSetSolver::new()),
            backup: ClarabelSolver::new(s),
            fallbacks: 0,
            max_dofs: usize::MAX,
        }),
        SolverKind::Auto => Box::new(WithFallback {
            primary: Box::new(ActiveSetSolver::new()),
            backup: ClarabelSolver::new(s),
            fallbacks: 0,
            max_dofs: AUTO_DENSE_MAX_DOFS,
        }),
    }
}
