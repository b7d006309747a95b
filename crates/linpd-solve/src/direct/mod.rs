//! Direct solvers, each split into analysis (pattern only, reusable) and factorization:
//! [`Cholesky`] (sparse `L L^T`), [`Lu`] (sparse LU with partial pivoting), [`dense_solve`].

mod cholesky;
mod dense;
mod lu;

pub use cholesky::{Cholesky, CholeskyFactor};
pub use dense::{dense_lu_solve, dense_solve, DENSE_LIMIT};
pub use lu::{Lu, LuFactor, LuOrdering};
