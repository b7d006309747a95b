//! Preconditioners: `z = M^{-1} r` for an `M` close to `A` and cheap to invert.
//!
//! A Krylov method takes any [`Preconditioner`] (the trait is defined with the Krylov methods,
//! [`crate::krylov::preconditioner`], and re-exported here); a new one is one file here
//! implementing the trait plus one [`crate::PreconditionerKind`] variant (the scene's
//! `solver.preconditioner` key) and one arm in [`crate::PreconditionerKind::build`]; no caller
//! changes. What a multilevel preconditioner needs to know about the unknowns besides the
//! matrix is a [`DofGeometry`].
//!
//! * [`Identity`]: `M = I`;
//! * [`Jacobi`]: `M = diag(A)`;
//! * [`Amg`]: smoothed-aggregation algebraic multigrid, one symmetric V-cycle;
//! * [`FactorPreconditioner`]: an exact factorization of an SPD `M` (e.g. the divergence-form
//!   or symmetric part of the blended operator of linpd-blend).

pub mod amg;
mod factor;
mod geometry;
mod jacobi;

pub use crate::krylov::preconditioner::{Identity, Preconditioner};
pub use amg::{Amg, AmgError, AmgOperator, AmgParams, AmgSmoother, AmgStats};
pub use factor::FactorPreconditioner;
pub use geometry::DofGeometry;
pub use jacobi::Jacobi;
