//! Jacobi: `M = diag(A)`.

use super::Preconditioner;
use crate::krylov::cg::CgError;
use rayon::prelude::*;

/// `z_i = r_i / A_ii`.
#[derive(Debug, Clone)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// From the diagonal of `A`. A non-positive (or NaN) entry already proves that `A` is not
    /// SPD (`e_i . A e_i <= 0`): reported as a CG breakdown at iteration 0 with that entry.
    pub fn new(diag: &[f64]) -> Result<Self, CgError> {
        if let Some(&d) = diag.iter().find(|&&d| !(d > 0.0)) {
            return Err(CgError::Breakdown { iteration: 0, curvature: d });
        }
        Ok(Jacobi { inv_diag: diag.iter().map(|d| 1.0 / d).collect() })
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.par_iter_mut().zip(r).zip(&self.inv_diag).for_each(|((zi, ri), mi)| *zi = ri * mi);
    }
}
