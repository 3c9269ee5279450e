//! Contact solver back-ends: each solves a [`StepProblem`] and reports its status.

mod clarabel_qp;
pub mod polish;

pub use clarabel_qp::ClarabelSolver;

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
}
