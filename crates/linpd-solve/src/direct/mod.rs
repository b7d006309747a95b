//! Direct solvers, each split into analysis (pattern only, reusable) and factorization:
//! [`Cholesky`] (sparse `L L^T`), [`Lu`] (sparse LU with partial pivoting), [`dense_solve`].

mod cholesky;
mod dense;
mod lu;

pub use cholesky::{Cholesky, CholeskyFactor};
pub use dense::{dense_lu_solve, dense_solve, DENSE_LIMIT};
pub use lu::{Lu, LuFactor, LuOrdering};

/// A direct solve whose relative residual exceeds this is reported as numerically singular
/// rather than returned: backward-stable factorizations reach `eps * kappa`, and `kappa`
/// beyond 1e10 means a mechanism the support check could not see (e.g. zero moduli).
pub const DIRECT_RESIDUAL_LIMIT: f64 = 1e-6;
