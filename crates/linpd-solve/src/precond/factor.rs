//! An exact Cholesky factorization of an SPD matrix `M` that approximates `A`.
//!
//! linpd-blend preconditions GMRES on the unsymmetric blended operator with the Cholesky
//! factor of its divergence-form (or symmetric) part: a few iterations, one band factorization.

use super::Preconditioner;
use crate::direct::CholeskyFactor;

/// `z = M^{-1} r` by the triangular solves of a Cholesky factor of `M`.
#[derive(Debug)]
pub struct FactorPreconditioner(pub CholeskyFactor);

impl Preconditioner for FactorPreconditioner {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(&self.0.solve(r));
    }
}
