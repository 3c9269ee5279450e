//! Contact solver back-ends: each solves a [`StepProblem`] and reports its status.

mod active_set;
pub mod certificate;
mod clarabel_qp;
pub mod envelope;
mod interior;
pub mod lemke;
pub mod polish;
mod rows;
pub mod semidefinite;
mod sparse;
mod visited;

pub use active_set::ActiveSetSolver;
pub use clarabel_qp::ClarabelSolver;
pub use sparse::SparseSolver;

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
    /// Solve `problem` into `out`, whose buffers a back-end may reuse (the impact stepper
    /// recycles its solutions: a step of a small scene need not allocate). On an error `out` is
    /// unspecified.
    fn solve_into(
        &mut self,
        problem: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure>;
    /// [`ContactSolver::solve_into`] a new solution.
    fn solve(&mut self, problem: &StepProblem) -> Result<StepSolution, SolveFailure> {
        let mut out = StepSolution::default();
        self.solve_into(problem, &mut out)?;
        Ok(out)
    }
    /// Steps this back-end handed to its fallback (Clarabel).
    fn fallbacks(&self) -> u64 {
        0
    }
    /// Factorisations of a Newton matrix (the sparse back-end; for diagnostics and benchmarks).
    fn factorisations(&self) -> u64 {
        0
    }
    /// Problems handed to the sparse back-end's interior-point rescue (for diagnostics and
    /// benchmarks).
    fn rescues(&self) -> u64 {
        0
    }
    /// Rows taken into or out of the sparse back-end's factors by rank-one updates (for
    /// diagnostics and benchmarks).
    fn factor_updates(&self) -> u64 {
        0
    }
    /// The certificates of its solutions, where it certifies them (`native.certify`).
    fn certified(&self) -> Option<certificate::Certified> {
        None
    }
    /// The back-end's state between problems (warm starts, kept factors, counters), for a
    /// checkpoint ([`crate::native::checkpoint`]).
    fn save(&self) -> Vec<u8>;
    /// Take the state [`ContactSolver::save`] gave, into a back-end made for the same settings:
    /// its next solutions are the saved back-end's, to the bit.
    fn restore(&mut self, state: &[u8]) -> Result<(), String>;
}

/// `x` as CBOR (every `f64` to the bit).
pub fn to_bytes<T: serde::Serialize>(x: &T) -> Vec<u8> {
    let mut bytes = Vec::new();
    ciborium::into_writer(x, &mut bytes).expect("writing CBOR into memory");
    bytes
}

/// Saved state within another's (a back-end's in its wrapper's, the stepper's in a checkpoint):
/// one CBOR byte string, not a sequence of numbers.
pub struct Blob(pub Vec<u8>);

impl serde::Serialize for Blob {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> serde::Deserialize<'de> for Blob {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Blob, D::Error> {
        struct Bytes;
        impl serde::de::Visitor<'_> for Bytes {
            type Value = Blob;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Blob, E> {
                Ok(Blob(v.to_vec()))
            }
            fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Blob, E> {
                Ok(Blob(v))
            }
        }
        d.deserialize_byte_buf(Bytes)
    }
}

/// A `T` from the CBOR of [`to_bytes`]; the error names `what`.
pub fn from_bytes<T: serde::de::DeserializeOwned>(bytes: &[u8], what: &str) -> Result<T, String> {
    use ciborium::de::Error;
    ciborium::from_reader(bytes).map_err(|e| match e {
        Error::Io(e) => format!("{what}: cannot read: {e}"),
        Error::Syntax(at) => format!("{what}: not CBOR at byte {at}"),
        Error::Semantic(Some(at), m) => format!("{what}: {m} at byte {at}"),
        Error::Semantic(None, m) => format!("{what}: {m}"),
        Error::RecursionLimitExceeded => format!("{what}: nested too deeply"),
    })
}

/// A fast back-end with Clarabel behind it: a step the primary cannot solve is solved by
/// Clarabel and counted.
pub struct WithFallback {
    primary: Box<dyn ContactSolver>,
    backup: ClarabelSolver,
    fallbacks: u64,
}

impl WithFallback {
    pub fn new(primary: Box<dyn ContactSolver>, s: &NativeSettings) -> Self {
        WithFallback {
            primary,
            backup: ClarabelSolver::new(s),
            fallbacks: 0,
        }
    }
}

impl ContactSolver for WithFallback {
    fn name(&self) -> &'static str {
        self.primary.name()
    }
    fn solve_into(
        &mut self,
        problem: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        if self.primary.solve_into(problem, out).is_ok() {
            return Ok(());
        }
        self.fallbacks += 1;
        self.backup.solve_into(problem, out)
    }
    fn fallbacks(&self) -> u64 {
        self.fallbacks + self.primary.fallbacks()
    }
    fn save(&self) -> Vec<u8> {
        to_bytes(&(Blob(self.primary.save()), self.fallbacks))
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let (primary, fallbacks): (Blob, u64) =
            from_bytes(state, "the back-end with Clarabel behind it")?;
        self.primary.restore(&primary.0)?;
        self.fallbacks = fallbacks;
        Ok(())
    }
    fn factorisations(&self) -> u64 {
        self.primary.factorisations()
    }
    fn rescues(&self) -> u64 {
        self.primary.rescues()
    }
    fn factor_updates(&self) -> u64 {
        self.primary.factor_updates()
    }
}

/// Largest problem (in DOFs, 3 per block) the dense active-set back-end takes under `auto`;
/// larger ones go to the sparse back-end. Measured on whole 1 s runs of rocking columns of
/// 1.0 x 0.5 m blocks (per step, quiet machine): dense 8 / 30 / 44 / 56-62 / 62-64 / 78 / 149
/// us at 5 / 10 / 12 / 13 / 14 / 15 / 20 blocks, sparse 28 / 59 / 69-72 / 62-66 / 65-68 / 65
/// / 71 us; they cross between 14 and 15 blocks.
pub const AUTO_DENSE_MAX_DOFS: usize = 42;

/// Most contact points (two rows each) of a problem the dense back-end takes under `auto`: a
/// move of its working-set search refactorises the working set, so its cost grows with the
/// rows, which a column has few of (two points an interface: 28 at the crossover of
/// `AUTO_DENSE_MAX_DOFS`) and a wall many (a block touches the blocks beside, above and below
/// it). Measured on walls of 0.6 x 0.25 m blocks under a one-sine pulse of 0.8 g for 0.3 s
/// (0.5 s, impacts located, 2026-11-29), with the DOF limit alone -> with this too: 2x3 / 3x3 /
/// 2x4 / 2x6 / 3x4 / 4x3 courses x blocks (7 to 14 blocks, 22 to 60 points) 0.036 / 0.166 /
/// 0.122 / 0.343 / 0.470 / 0.624 s -> 0.038 / 0.047 / 0.029 / 0.055 / 0.068 / 0.094 s.
pub const AUTO_DENSE_MAX_POINTS: usize = 28;

/// `auto`: the dense active-set back-end for small problems, the sparse one for large
/// assemblies and for the small problems the dense one cannot solve (its working-set search
/// can cycle on the nearly dependent rows of flat interfaces: measured, 172 problems of the
/// 42-block toppling wall, `validation/scenes/wall-in-motion-pulse.toml`, in 2 s), with
/// Clarabel behind the sparse one.
pub struct Auto {
    dense: ActiveSetSolver,
    sparse: WithFallback,
}

impl ContactSolver for Auto {
    fn name(&self) -> &'static str {
        "auto (active-set up to 42 DOFs and 28 points, sparse above)"
    }
    fn solve_into(
        &mut self,
        problem: &StepProblem,
        out: &mut StepSolution,
    ) -> Result<(), SolveFailure> {
        if problem.n_dof() <= AUTO_DENSE_MAX_DOFS
            && problem.contacts.len() <= AUTO_DENSE_MAX_POINTS
            && self.dense.solve_into(problem, out).is_ok()
        {
            return Ok(());
        }
        self.sparse.solve_into(problem, out)
    }
    fn fallbacks(&self) -> u64 {
        self.sparse.fallbacks()
    }
    fn save(&self) -> Vec<u8> {
        to_bytes(&(Blob(self.dense.save()), Blob(self.sparse.save())))
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let (dense, sparse): (Blob, Blob) = from_bytes(state, "the auto back-end")?;
        self.dense.restore(&dense.0)?;
        self.sparse.restore(&sparse.0)
    }
    fn factorisations(&self) -> u64 {
        self.sparse.factorisations()
    }
    fn rescues(&self) -> u64 {
        self.sparse.rescues()
    }
    fn factor_updates(&self) -> u64 {
        self.sparse.factor_updates()
    }
}

/// The back-end a scene's settings ask for: with `native.islands` (the default), each island
/// of touching blocks gets its own (see [`crate::native::islands`]).
pub fn solver_for(s: &NativeSettings) -> Box<dyn ContactSolver> {
    certified_if_asked(s, built_for(s, SparseSolver::new))
}

/// `solver`, certifying its solutions if the settings ask (`native.certify`: the step
/// problems' displacements; the velocity problems and projections are posed with a step of 1,
/// their bounds in other units, and are not certified in a run).
fn certified_if_asked(
    s: &NativeSettings,
    solver: Box<dyn ContactSolver>,
) -> Box<dyn ContactSolver> {
    if s.certify {
        Box::new(certificate::Certifying::new(solver))
    } else {
        solver
    }
}

/// The back-end of the impact stepper's velocity problems (settled end velocities and plastic
/// impacts): as [`solver_for`], its sparse back-end from [`SparseSolver::for_velocities`].
pub fn velocity_solver_for(s: &NativeSettings) -> Box<dyn ContactSolver> {
    built_for(s, SparseSolver::for_velocities)
}

fn built_for(s: &NativeSettings, sparse: fn() -> SparseSolver) -> Box<dyn ContactSolver> {
    if s.islands {
        let whole = whole_built_for(s, sparse);
        let name = whole.name();
        let settings = s.clone();
        return Box::new(crate::native::islands::Islands::new(
            name,
            Box::new(move || whole_built_for(&settings, sparse)),
        ));
    }
    whole_built_for(s, sparse)
}

/// The back-end for a whole problem (no split into islands).
pub fn whole_solver_for(s: &NativeSettings) -> Box<dyn ContactSolver> {
    whole_built_for(s, SparseSolver::new)
}

fn whole_built_for(s: &NativeSettings, sparse: fn() -> SparseSolver) -> Box<dyn ContactSolver> {
    match s.solver {
        SolverKind::Clarabel => Box::new(ClarabelSolver::new(s)),
        SolverKind::ActiveSet => Box::new(WithFallback::new(Box::new(ActiveSetSolver::new()), s)),
        SolverKind::Sparse => Box::new(WithFallback::new(Box::new(sparse()), s)),
        SolverKind::Auto => Box::new(Auto {
            dense: ActiveSetSolver::new(),
            sparse: WithFallback::new(Box::new(sparse()), s),
        }),
    }
}
