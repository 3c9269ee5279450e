//! What an engine run returns: the trajectory and what the summary records beside it. Data
//! every engine fills and the summary, compare and gates read; it imports no engine.

use crate::trajectory::Trajectory;

/// What an engine returns.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub trajectory: Trajectory,
    /// Every setting that changes the answer, as used.
    pub settings: serde_json::Value,
    pub engine_version: String,
    pub steps: u64,
    pub solver_iterations: Option<u64>,
    /// Impact times per block located by the engine itself (the Housner engine's exact
    /// events); `None`: events are taken from the trajectory.
    pub exact_impacts: Option<Vec<Vec<f64>>>,
    pub notes: Vec<String>,
    /// The instant from which the engine's model no longer holds (Siconos' contacts, once an
    /// overturned block lands where it has none): the trajectory past it is no physical
    /// motion, and the events are taken from the samples before it. `None`: the whole run.
    pub valid_until: Option<f64>,
}
