//! The interface the Krylov methods take: `z = M^{-1} r` ([`Preconditioner`]), and no
//! preconditioning ([`Identity`]). Defined here, below the preconditioners of [`crate::precond`]
//! that implement it, so that the Krylov methods depend on none of them.

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

impl Preconditioner for Box<dyn Preconditioner + '_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        (**self).apply(r, z)
    }
    fn summary(&self) -> Option<String> {
        (**self).summary()
    }
    fn operator_copy(&self) -> Option<&dyn linpd_core::LinearOperator> {
        (**self).operator_copy()
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
