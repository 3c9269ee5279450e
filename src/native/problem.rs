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
use std::ops::{Deref, DerefMut};

/// Most entries a row has: the three DOFs of each of a contact's two bodies.
pub const ROW_CAPACITY: usize = 6;

/// A sparse row over the degrees of freedom, (index, coefficient) pairs, stored inline (a step
/// builds and drops several rows per contact: on the heap that was a third of a one-block
/// step's cost). It reads as a slice and is written as a sequence, like a `Vec`.
#[derive(Clone, Copy)]
pub struct SparseRow {
    len: usize,
    entries: [(usize, f64); ROW_CAPACITY],
}

impl SparseRow {
    pub const fn new() -> Self {
        SparseRow {
            len: 0,
            entries: [(0, 0.0); ROW_CAPACITY],
        }
    }

    /// Append an entry; a row never has more than [`ROW_CAPACITY`].
    pub fn push(&mut self, entry: (usize, f64)) {
        assert!(
            self.len < ROW_CAPACITY,
            "a contact row has at most {ROW_CAPACITY} entries"
        );
        self.entries[self.len] = entry;
        self.len += 1;
    }

    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Append `entries` (one copy; a row never has more than [`ROW_CAPACITY`]).
    pub fn extend_from_slice(&mut self, entries: &[(usize, f64)]) {
        let end = self.len + entries.len();
        assert!(
            end <= ROW_CAPACITY,
            "a contact row has at most {ROW_CAPACITY} entries"
        );
        self.entries[self.len..end].copy_from_slice(entries);
        self.len = end;
    }

    /// A row holding `entries`.
    pub fn from_slice(entries: &[(usize, f64)]) -> Self {
        let mut row = SparseRow::new();
        row.extend_from_slice(entries);
        row
    }
}

impl Default for SparseRow {
    fn default() -> Self {
        Self::new()
    }
}

impl Deref for SparseRow {
    type Target = [(usize, f64)];
    fn deref(&self) -> &Self::Target {
        &self.entries[..self.len]
    }
}

impl DerefMut for SparseRow {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.entries[..self.len]
    }
}

impl PartialEq for SparseRow {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

impl std::fmt::Debug for SparseRow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl FromIterator<(usize, f64)> for SparseRow {
    fn from_iter<I: IntoIterator<Item = (usize, f64)>>(iter: I) -> Self {
        let mut row = SparseRow::new();
        for e in iter {
            row.push(e);
        }
        row
    }
}

impl Extend<(usize, f64)> for SparseRow {
    fn extend<I: IntoIterator<Item = (usize, f64)>>(&mut self, iter: I) {
        for e in iter {
            self.push(e);
        }
    }
}

impl<const N: usize> From<[(usize, f64); N]> for SparseRow {
    fn from(entries: [(usize, f64); N]) -> Self {
        entries.into_iter().collect()
    }
}

impl<'a> IntoIterator for &'a SparseRow {
    type Item = &'a (usize, f64);
    type IntoIter = std::slice::Iter<'a, (usize, f64)>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl Serialize for SparseRow {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.iter())
    }
}

impl<'de> Deserialize<'de> for SparseRow {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let entries = Vec::<(usize, f64)>::deserialize(deserializer)?;
        if entries.len() > ROW_CAPACITY {
            return Err(serde::de::Error::custom(format!(
                "a contact row has {} entries, at most {ROW_CAPACITY}",
                entries.len()
            )));
        }
        Ok(entries.into_iter().collect())
    }
}

/// One contact point's rows.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
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
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
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
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A row is written as the sequence of its entries (as a `Vec` was) and read back equal;
    /// a saved row with more entries than a contact has is refused, not truncated.
    #[test]
    fn a_row_is_written_as_a_sequence_and_a_longer_one_is_refused() {
        let row: SparseRow = [(3, 0.5), (4, -1.0), (5, 0.25)].into();
        let text = serde_json::to_string(&row).unwrap();
        assert_eq!(text, "[[3,0.5],[4,-1.0],[5,0.25]]");
        assert_eq!(serde_json::from_str::<SparseRow>(&text).unwrap(), row);
        let seven = "[[0,1.0],[1,1.0],[2,1.0],[3,1.0],[4,1.0],[5,1.0],[6,1.0]]";
        let err = serde_json::from_str::<SparseRow>(seven).unwrap_err();
        assert!(
            err.to_string()
                .contains("a contact row has 7 entries, at most 6"),
            "{err}"
        );
    }

    /// Equality looks at the entries only, not at what a cleared row kept.
    #[test]
    fn rows_with_the_same_entries_are_equal() {
        let mut a: SparseRow = [(0, 1.0), (1, 2.0)].into();
        a.clear();
        a.push((7, 3.0));
        let b: SparseRow = [(7, 3.0)].into();
        assert_eq!(a, b);
        assert_eq!(format!("{a:?}"), "[(7, 3.0)]");
    }
}
