//! Linear solvers for linpd, and the one static solve of a [`linpd_core::Model`].
//!
//! * [`mod@plan`]: what a static solve will run (assembled or matrix-free, the preconditioner's
//!   hierarchy), decided once from a model's offers and the solver asked for;
//! * [`statics::solve_model`]: support check, Dirichlet elimination ([`bc`]), assembled or
//!   matrix-free solve by the plan, report: every static solve in linpd goes through it;
//! * [`statics::solve_assembled`]: the solver dispatch on an assembled matrix, by
//!   [`SolverSpec`] (`auto` resolved by size and dimension; unsymmetric matrices go to LU);
//! * [`direct`]: sparse Cholesky and sparse LU, each analysed once and factored many times,
//!   and dense Cholesky; a non-positive pivot names the DOF it belongs to;
//! * [`krylov`]: CG and restarted GMRES over any [`LinearOperator`], generic over a
//!   [`Preconditioner`] ([`precond`]: Jacobi, a Cholesky factor of an approximation);
//! * [`SolveReport`]: the relative residual `||A u - f|| / ||f||`, phase timings, nonzeros,
//!   iterations and peak memory, with the [`SolverId`] that ran.
#![deny(missing_docs)]

pub mod bc;
pub mod cost;
pub mod direct;
pub mod krylov;
pub mod memory;
pub mod modes;
pub mod plan;
pub mod precond;
pub mod report;
pub mod spec;
pub mod statics;

pub use bc::{Dirichlet, ReducedOperator};
pub use direct::{dense_lu_solve, dense_solve, Cholesky, CholeskyFactor, Lu, LuFactor, LuOrdering, DENSE_LIMIT};
pub use krylov::cg::{pcg, pcg_with_progress, CgError, CgInfo, CgParams};
pub use krylov::gmres::{gmres, gmres_with_progress, GmresError, GmresInfo, GmresParams};
pub use linpd_core::sparse::{diagonal, matvec, relative_residual, sym_matvec, GeneralCsc, SymCsc};
pub use linpd_core::LinearOperator;
pub use plan::{plan, Apply, Hierarchy, Offers, Route, SolvePlan};
pub use precond::amg::{rigid_body_modes, Amg, AmgError, AmgOperator, AmgParams, AmgSmoother, AmgStats};
pub use precond::kind::{ModelInput, PreconditionerInput};
pub use precond::{CoarseSpace, DofGeometry, FactorPreconditioner, Identity, Jacobi, LatticeMultigrid, Preconditioner};
pub use report::{peak_rss_bytes, SolveReport, Timings};
pub use spec::{CholeskyOrdering, GmresPreconditioner, MatrixFree, PreconditionerKind, SolverId, SolverSpec};
pub use statics::{
    reduced_rhs_checked, reduced_system, solve_assembled, solve_assembled_with_progress, solve_model, solve_planned,
    MatrixHints, StaticError, StaticSolution,
};

/// A failed solve.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// Cholesky met a non-positive pivot: the system is singular or indefinite there.
    #[error("the stiffness is not positive definite: zero or negative pivot at free DOF {dof}")]
    NotPositiveDefinite {
        /// Free DOF (in the caller's numbering) of the pivot.
        dof: usize,
    },
    /// LU met a structurally singular column.
    #[error("the stiffness is singular: no pivot for free DOF {dof}")]
    Singular {
        /// Free DOF of the failed pivot.
        dof: usize,
    },
    /// A diagonal entry of `A_ff` is zero (or, for a symmetric `A_ff`, negative): the
    /// stiffness is singular there (a DOF nothing holds: a mechanism or a missing constraint).
    #[error("{solver}: the stiffness's diagonal entry at free DOF {dof} is {value:e}: the stiffness is singular")]
    ZeroDiagonal {
        /// The solver (or setup) that found it: `"lu"`, `"gmres (jacobi)"`, `"the row system"`.
        solver: String,
        /// Free DOF of the entry.
        dof: usize,
        /// The entry.
        value: f64,
    },
    /// LU met a zero pivot (its solution is not finite though `A` and `f` are).
    #[error("{solver}: singular matrix (a pivot is zero): the body is not held or has a mechanism; add constraints")]
    ZeroPivot {
        /// The solver that ran.
        solver: SolverId,
    },
    /// A direct solve returned a residual above [`direct::DIRECT_RESIDUAL_LIMIT`].
    #[error("the reduced stiffness is numerically singular (relative residual {rel_residual:.2e} after {solver}); add constraints")]
    NumericallySingular {
        /// The residual reached.
        rel_residual: f64,
        /// The solver that ran.
        solver: SolverId,
    },
    /// CG did not converge or broke down.
    #[error(transparent)]
    Cg(#[from] CgError),
    /// GMRES did not converge or broke down.
    #[error("gmres ({preconditioner}): {source}")]
    Gmres {
        /// The preconditioner's name.
        preconditioner: &'static str,
        /// What happened.
        source: GmresError,
    },
    /// No offered solver fits this system (memory, missing geometry).
    #[error("no solver fits: {0}")]
    NoSolverFits(String),
    /// The system is too large for the dense solver.
    #[error("dense solver refused: {n} unknowns (limit {limit}); use cholesky or cg")]
    TooLargeForDense {
        /// Unknowns.
        n: usize,
        /// Limit.
        limit: usize,
    },
    /// The factorization ran out of memory or its indices overflowed (faer's error).
    #[error("factorization failed: {0}")]
    Factorization(faer::sparse::FaerError),
    /// The values of the factor could not be allocated.
    #[error("factorization failed: out of memory for {entries} factor entries")]
    FactorAllocation {
        /// Stored entries of the factor.
        entries: usize,
    },
    /// The estimated memory of a step (the factor of a sparse Cholesky) exceeds what the
    /// machine has available.
    #[error(transparent)]
    Memory(Box<linpd_core::memory::OutOfMemory>),
    /// The AMG preconditioner could not be set up.
    #[error(transparent)]
    Amg(#[from] AmgError),
    /// NaN or infinite values in the stiffness, the load vector, the solution or its residual:
    /// an overflow of the moduli, volumes, loads or prescribed displacements, caught where it
    /// appears (a factorization would call it "not positive definite", a residual NaN).
    #[error("{what} has non-finite values ({at}): an overflow; use smaller units for the moduli, loads or prescribed displacements")]
    NonFinite {
        /// `"the stiffness"`, `"the load vector"`, `"the solution"`, ...
        what: &'static str,
        /// Where (`"first at entry (i, j) = inf"`, `"||f||^2 = inf"`).
        at: String,
    },
    /// The eigensolver converged fewer pairs than asked ([`modes::lowest_modes`]).
    #[error("the eigensolver converged {converged} of the {asked} modes asked for")]
    Eigen {
        /// Pairs converged.
        converged: usize,
        /// Pairs asked for.
        asked: usize,
    },
}

impl From<linpd_core::memory::OutOfMemory> for SolveError {
    fn from(e: linpd_core::memory::OutOfMemory) -> Self {
        SolveError::Memory(Box::new(e))
    }
}
