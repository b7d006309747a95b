//! What to solve with ([`SolverSpec`], validated from a scene's `solver` section) and what
//! ran ([`SolverId`], in every [`crate::SolveReport`]).

use crate::krylov::cg::CgParams;
pub use crate::precond::kind::PreconditionerKind;
use serde::{Serialize, Serializer};
use std::fmt;

/// Which solver a static solve uses. Validated: a combination that cannot run (matrix-free
/// with a direct solver) is not representable.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverSpec {
    /// Chosen by [`SolverSpec::resolve`] from the dimension and size; when it picks CG it
    /// uses these parameters.
    Auto(CgParams),
    /// Sparse Cholesky (the model's ordering, else AMD).
    Cholesky,
    /// Sparse LU (COLAMD; keeping the band of a banded model).
    Lu,
    /// Dense Cholesky, or dense LU with partial pivoting for an unsymmetric `A` (small systems).
    Dense,
    /// Preconditioned CG.
    Cg {
        /// Tolerance and iteration limit.
        params: CgParams,
        /// The preconditioner.
        preconditioner: PreconditionerKind,
        /// Apply the model without assembling it.
        matrix_free: bool,
    },
    /// Restarted GMRES (right-preconditioned, on the assembled `A_ff`, symmetric or not) to
    /// `params.rtol` of the true residual, at most `params.max_iter` iterations.
    Gmres {
        /// Tolerance and iteration limit.
        params: CgParams,
        /// Jacobi, or multigrid built from `A_ff` itself.
        preconditioner: PreconditionerKind,
    },
}

impl Default for SolverSpec {
    fn default() -> Self {
        SolverSpec::Auto(CgParams::default())
    }
}

impl SolverSpec {
    /// Assembled Jacobi-PCG with these parameters.
    pub fn cg(params: CgParams) -> Self {
        SolverSpec::Cg { params, preconditioner: PreconditionerKind::JACOBI, matrix_free: false }
    }

    /// The solver `auto` stands for before looking at the matrix (other specs are returned
    /// unchanged): in 1D always sparse Cholesky (banded operators, badly conditioned:
    /// kappa ~ (N/m)^2); in 2D and 3D `auto` itself, decided on the assembled matrix by the
    /// cost model of [`crate::cost`].
    pub fn resolve(&self, dim: usize, _n: usize) -> SolverSpec {
        match self {
            SolverSpec::Auto(_) if dim == 1 => SolverSpec::Cholesky,
            other => other.clone(),
        }
    }
}

impl fmt::Display for SolverSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolverSpec::Auto(_) => write!(f, "auto"),
            SolverSpec::Cholesky => write!(f, "cholesky"),
            SolverSpec::Lu => write!(f, "lu"),
            SolverSpec::Dense => write!(f, "dense"),
            SolverSpec::Cg { params, preconditioner, matrix_free } => write!(
                f,
                "cg ({}{}, rtol {:e}, max_iter {})",
                preconditioner.name(),
                if *matrix_free { ", matrix-free" } else { "" },
                params.rtol,
                params.max_iter
            ),
            SolverSpec::Gmres { params, preconditioner } => {
                write!(f, "gmres ({}, rtol {:e}, max_iter {})", preconditioner.name(), params.rtol, params.max_iter)
            }
        }
    }
}

/// The fill-reducing ordering a sparse Cholesky ran with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CholeskyOrdering {
    /// Approximate minimum degree (faer).
    Amd,
    /// Nested dissection on the lattice.
    NestedDissection,
    /// The natural order of a 1D lattice.
    Natural,
    /// The natural order of a 1D band (linpd-blend's name for it).
    Band,
}

/// How a matrix-free Krylov solve applied the operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixFree {
    /// Assembled `A_ff`.
    No,
    /// The model's own apply (e.g. bond sums).
    Model,
    /// A faster apply the model offers ([`linpd_core::FastApply`], e.g. the lattice stencil).
    Fast(&'static str),
}

/// The SPD matrix whose Cholesky factor preconditions GMRES (a model's
/// [`linpd_core::SpdApproximation`]).
pub use linpd_core::SpdApproximationKind as GmresPreconditioner;

/// The solver that ran. Displayed (and serialized) as the short names of the reports:
/// `cholesky-nd`, `cholesky-amd`, `lu`, `cg-jacobi-matrix-free-stencil`, ...
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverId {
    /// Sparse Cholesky.
    Cholesky(CholeskyOrdering),
    /// Sparse LU, COLAMD ordering.
    Lu,
    /// Sparse LU keeping a band.
    LuBand,
    /// Dense Cholesky.
    Dense,
    /// Dense LU with partial pivoting.
    DenseLu,
    /// Preconditioned CG.
    Cg {
        /// The preconditioner.
        preconditioner: PreconditionerKind,
        /// Assembled or how it ran matrix-free.
        matrix_free: MatrixFree,
    },
    /// GMRES preconditioned by a Cholesky factor.
    Gmres(GmresPreconditioner),
    /// GMRES with an iterative preconditioner.
    GmresIterative(PreconditionerKind),
    /// GMRES on the model's matrix-free apply, preconditioned by the multigrid of its SPD
    /// companion's block rows ([`linpd_core::Model::multigrid_companion`]).
    GmresMatrixFree(PreconditionerKind),
}

impl fmt::Display for SolverId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolverId::Cholesky(o) => write!(
                f,
                "cholesky-{}",
                match o {
                    CholeskyOrdering::Amd => "amd",
                    CholeskyOrdering::NestedDissection => "nd",
                    CholeskyOrdering::Natural => "natural",
                    CholeskyOrdering::Band => "band",
                }
            ),
            SolverId::Lu => write!(f, "lu"),
            SolverId::LuBand => write!(f, "lu-band"),
            SolverId::Dense => write!(f, "dense"),
            SolverId::DenseLu => write!(f, "dense-lu"),
            SolverId::Cg { preconditioner, matrix_free } => {
                write!(f, "cg-{}", preconditioner.name())?;
                match matrix_free {
                    MatrixFree::No => Ok(()),
                    MatrixFree::Model => write!(f, "-matrix-free"),
                    MatrixFree::Fast(label) => write!(f, "-matrix-free-{label}"),
                }
            }
            SolverId::Gmres(GmresPreconditioner::DivergenceForm) => write!(f, "cholesky(divergence form)+gmres"),
            SolverId::Gmres(GmresPreconditioner::SymmetricPart) => write!(f, "cholesky(sym part)+gmres"),
            SolverId::Gmres(GmresPreconditioner::EnergyForm) => write!(f, "cholesky(energy form)+gmres"),
            SolverId::GmresIterative(p) => write!(f, "gmres-{}", p.name()),
            SolverId::GmresMatrixFree(p) => write!(f, "gmres-{}-matrix-free", p.name()),
        }
    }
}

impl Serialize for SolverId {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}
