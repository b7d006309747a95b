//! Preconditioners: `z = M^{-1} r` for an `M` close to `A` and cheap to invert.
//!
//! A Krylov method takes any [`Preconditioner`]; a new one is one file here implementing the
//! trait plus one [`crate::PreconditionerKind`] variant (the scene's `solver.preconditioner`
//! key) and one arm in [`crate::PreconditionerKind::build`]; no caller changes.
//!
//! * [`Identity`]: `M = I`;
//! * [`Jacobi`]: `M = diag(A)`;
//! * [`Amg`]: smoothed-aggregation algebraic multigrid, one symmetric V-cycle;
//! * [`FactorPreconditioner`]: an exact factorization of an SPD `M` (e.g. the divergence-form
//!   or symmetric part of the blended operator of linpd-blend).

pub mod amg;
mod factor;
mod jacobi;

pub use amg::{Amg, AmgError, AmgOperator, AmgParams, AmgSmoother, AmgStats};
pub use factor::FactorPreconditioner;
pub use jacobi::Jacobi;

/// `z = M^{-1} r`.
pub trait Preconditioner: Sync {
    /// Sets `z = M^{-1} r` (`z` is overwritten).
    fn apply(&self, r: &[f64], z: &mut [f64]);
    /// What was built, for the solve report (e.g. a multigrid hierarchy's levels).
    fn summary(&self) -> Option<String> {
        None
    }
    /// `A` itself, when the preconditioner holds a copy whose product is cheaper than the
    /// caller's (multigrid's block copy of level 0: 8 bytes per entry and one index per
    /// block, against 16 bytes per entry of a `usize` CSC); Krylov callers use it for their
    /// products. `None`: the caller's operator.
    fn operator_copy(&self) -> Option<&dyn linpd_core::LinearOperator> {
        None
    }
}

/// No preconditioning: `z = r`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}
