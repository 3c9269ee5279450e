//! The one-step problem as plain data, so that a failing step can be saved and replayed.
//!
//! With `Mbar = M / (theta dt^2)` and `fbar0 = f + Mbar v0 dt`, one step is
//!
//! ```text
//! primal:  min 1/2 dq' Mbar dq - fbar0' dq
//!          s.t. g_n ± mu g_t + (nrow ± mu trow) dq >= 0        (two rows per contact)
//! dual:    min 1/2 (fbar0 + H'c)' Mbar^-1 (fbar0 + H'c) + sum_k (g_n N_k + g_t T_k)
//!          s.t. ±T_k - mu N_k <= 0
//! ```
//!
//! where `H` stacks the rows `nrow_k`, `trow_k`, `g_n = g0 - n·Δd_ground` and
//! `g_t = -t·Δd_ground` (the ground increment is zero unless the ground moves). Both give
//! `Mbar dq = fbar0 + H'c`; the primal multipliers `z±` are the forces along the two cone
//! edges, `N = z+ + z-`, `T = mu (z+ - z-)`.

use serde::{Deserialize, Serialize};

/// A sparse row over the degrees of freedom: (index, coefficient).
pub type SparseRow = Vec<(usize, f64)>;

/// One contact point's rows.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ContactRows {
    /// Identity of the contact point (bodies and feature), stable between steps.
    pub key: u64,
    pub mu: f64,
    /// Normal gap including the ground increment, m.
    pub g_n: f64,
    /// Tangential offset from the ground increment, m.
    pub g_t: f64,
    /// `d(n·du)/d(dq)`.
    pub nrow: SparseRow,
    /// `d(t·du)/d(dq)`.
    pub trow: SparseRow,
}

/// Everything a contact solver needs for one step.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct StepProblem {
    pub theta: f64,
    pub dt: f64,
    /// Diagonal of M: (m, m, I) per block.
    pub mass: Vec<f64>,
    /// Free forces f (gravity, inertial forces), N per m of depth (and N m for moments).
    pub force: Vec<f64>,
    /// Velocities at the start of the step.
    pub v0: Vec<f64>,
    pub contacts: Vec<ContactRows>,
}

/// The primal problem scaled for solvers: unknowns `u = dq/dt`, objective divided by
/// `s = max(M)/theta`: `min 1/2 u' P u + q' u` with `P = M/(theta s)`,
/// `q = -(dt f + M v0/theta)/s`; row offsets become `g/dt`.
#[derive(Debug, Clone)]
pub struct Scaled {
    pub p: Vec<f64>,
    pub q: Vec<f64>,
    pub s: f64,
}

impl StepProblem {
    pub fn scaled(&self) -> Scaled {
        let (mut p, mut q) = (Vec::new(), Vec::new());
        let s = self.scale_into(&mut p, &mut q);
        Scaled { p, q, s }
    }

    /// [`StepProblem::scaled`] into the caller's buffers; returns `s`.
    pub fn scale_into(&self, p: &mut Vec<f64>, q: &mut Vec<f64>) -> f64 {
        let s = self.mass.iter().cloned().fold(0.0, f64::max) / self.theta;
        p.clear();
        p.extend(self.mass.iter().map(|m| m / (self.theta * s)));
        q.clear();
        q.extend(
            (0..self.n_dof())
                .map(|i| -(self.dt * self.force[i] + self.mass[i] * self.v0[i] / self.theta) / s),
        );
        s
    }

    pub fn n_dof(&self) -> usize {
        self.mass.len()
    }
    /// `Mbar` diagonal.
    pub fn mbar(&self) -> Vec<f64> {
        let c = 1.0 / (self.theta * self.dt * self.dt);
        self.mass.iter().map(|m| m * c).collect()
    }
    /// `fbar0 = f + Mbar v0 dt`.
    pub fn fbar0(&self) -> Vec<f64> {
        let c = 1.0 / (self.theta * self.dt);
        (0..self.n_dof())
            .map(|i| self.force[i] + self.mass[i] * self.v0[i] * c)
            .collect()
    }
}

/// A solved step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepSolution {
    /// Displacement increments.
    pub dq: Vec<f64>,
    /// Normal and tangential contact forces per contact (N per m of depth).
    pub normal: Vec<f64>,
    pub tangential: Vec<f64>,
    /// Solver iterations used.
    pub iterations: u32,
    /// Whether the solution was polished on its active set.
    pub polished: bool,
}
