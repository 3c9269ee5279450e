//! # rockbench
//!
//! Rigid-block rocking dynamics for museum artworks (a statue on its pedestal), computed with
//! the contact-dynamics method of "Vulnerability assessment of monumental artworks using
//! contact time-history analysis", and cross-checked against other engines.
//!
//! ## Units and sign conventions (stated once)
//! SI units throughout; 2D plane motion, forces per metre of depth. `x` is horizontal, `z` up,
//! rotations counter-clockwise positive. A positive rotation of a block on its support pivots
//! on its left corner. A positive horizontal ground acceleration moves the ground towards +x
//! (inertial force `-m a_x` on each block). Contact normals point from the body owning the
//! face into the other body; gaps are positive when open (see [`geometry`]).
//!
//! ## The method (native engine)
//! Each block has DOFs `q_i = [x_i, z_i, phi_i]` at its centroid and `M_i = diag(m, m, I)`.
//! Contact points are vertex-face pairs re-detected from the geometry every step, with no
//! tension and associative Coulomb friction: per point, `g0 + (nrow ± mu trow) dq >= 0`. The
//! theta-method (`a = (v - v0)/dt`, `v = (dq/dt - (1 - theta) v0)/theta`) gives
//! `Mbar dq + A c = fbar0` with `Mbar = M/(theta dt^2)`, `fbar0 = f + Mbar v0 dt`, solved each
//! step as one of two dual QPs (displacement-based or force-based): see [`native::problem`].
//!
//! ## Layout
//! [`scene`] (files, checks, initial layout) · [`excitation`] (pulses, records) ·
//! [`geometry`] (contact detection) · [`native`] (the theta step and its QP solvers) ·
//! [`engines`] (every engine; [`engines::registry`] the one list of them) · [`trajectory`] ·
//! [`output`] (what a run returns) · [`events`] · [`summary`] ·
//! [`metrics`] (comparing two trajectories) · [`compare`] (running engines against a reference)
//! · [`report`] (HTML and Markdown) · [`gates`] (accuracy gates, run cache, JUnit XML) · [`validation`] (the validation suite,
//! its reference-data generator and report).

pub mod allocator;
pub mod bench;
pub mod build_info;
pub mod cli;
pub mod colonnade;
pub mod compare;
pub mod contract;
pub mod converge;
pub mod digest;
pub mod engines;
pub mod events;
pub mod excitation;
pub mod fragility;
pub mod gallery;
pub mod gates;
pub mod geometry;
pub mod input_file;
pub mod instructions;
pub mod interrupt;
pub mod invariants;
pub mod loglog;
pub mod metrics;
pub mod native;
pub mod output;
pub mod paper;
#[cfg(feature = "python")]
pub mod python;
pub mod report;
pub mod run_store;
pub mod scene;
pub mod sensitivity;
pub mod sliding;
pub mod spectrum;
pub mod stress;
pub mod summary;
#[cfg(test)]
mod test_random;
pub mod text_table;
pub mod trajectory;
pub mod validation;
pub mod walls;
pub mod worker_sources;
pub mod writable;
