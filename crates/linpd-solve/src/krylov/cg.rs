//! Preconditioned conjugate gradients.
//!
//! Standard PCG for SPD `A` and SPD `M` (any [`Preconditioner`]): stops when
//! `||r_k|| <= rtol ||b||` on the recursive residual; the true residual is recomputed at exit
//! and reported, so the reported value never hides drift. Works on any [`LinearOperator`], so
//! the same code serves assembled and matrix-free operators.
//!
//! Why not `faer::matrix_free::conjugate_gradient`: faer's CG works on its own `LinOp`/`MatMut`
//! types with a `MemStack` per call and has no hook for our parallel dot products over `&[f64]`
//! or for reporting the true residual at exit; this loop is 40 lines and keeps every solve's
//! iteration counts identical to the published ones in docs/benchmarks.md.

use crate::precond::Preconditioner;
use linpd_core::LinearOperator;
use rayon::prelude::*;
use serde::Serialize;

/// CG parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CgParams {
    /// Relative residual target `||r|| / ||b||`.
    pub rtol: f64,
    /// Iteration limit.
    pub max_iter: usize,
}

impl Default for CgParams {
    fn default() -> Self {
        CgParams { rtol: 1e-10, max_iter: 20_000 }
    }
}

/// What a converged CG run did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CgInfo {
    /// Iterations taken.
    pub iterations: usize,
    /// Final true relative residual `||b - A x|| / ||b||`.
    pub rel_residual: f64,
}

/// A CG failure, with the state reached.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CgError {
    /// The iteration limit was reached.
    #[error("CG did not converge in {iterations} iterations: relative residual {rel_residual:e} > target {rtol:e}")]
    NotConverged {
        /// Iterations taken.
        iterations: usize,
        /// Relative residual reached.
        rel_residual: f64,
        /// Target.
        rtol: f64,
    },
    /// `p . A p <= 0`, or a non-positive diagonal entry for Jacobi: `A` is not SPD.
    #[error("CG broke down at iteration {iteration}: the operator is not positive definite (p.Ap = {curvature:e})")]
    Breakdown {
        /// Iteration.
        iteration: usize,
        /// The offending curvature.
        curvature: f64,
    },
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.par_iter().zip(b).with_min_len(4096).map(|(x, y)| x * y).sum()
}

/// Solves `A x = b` from the initial guess in `x`, preconditioned by `m_inv` (`z = M^{-1} r`).
pub fn pcg(
    a: &impl LinearOperator,
    m_inv: &impl Preconditioner,
    b: &[f64],
    x: &mut [f64],
    params: &CgParams,
) -> Result<CgInfo, CgError> {
    let n = a.n();
    assert_eq!(b.len(), n);
    assert_eq!(x.len(), n);
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return Ok(CgInfo { iterations: 0, rel_residual: 0.0 });
    }
    let mut r = vec![0.0; n];
    a.apply(x, &mut r);
    r.par_iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
    let mut z = vec![0.0; n];
    m_inv.apply(&r, &mut z);
    let mut p = z.clone();
    let mut ap = vec![0.0; n];
    let mut rz = dot(&r, &z);
    let mut it = 0;
    let target = params.rtol * bnorm;
    while dot(&r, &r).sqrt() > target {
        if it == params.max_iter {
            let rel = true_residual(a, b, x) / bnorm;
            return Err(CgError::NotConverged { iterations: it, rel_residual: rel, rtol: params.rtol });
        }
        a.apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if !(pap > 0.0) {
            return Err(CgError::Breakdown { iteration: it, curvature: pap });
        }
        let alpha = rz / pap;
        x.par_iter_mut().zip(&p).for_each(|(xi, pi)| *xi += alpha * pi);
        r.par_iter_mut().zip(&ap).for_each(|(ri, api)| *ri -= alpha * api);
        m_inv.apply(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        p.par_iter_mut().zip(&z).for_each(|(pi, zi)| *pi = zi + beta * *pi);
        it += 1;
    }
    Ok(CgInfo { iterations: it, rel_residual: true_residual(a, b, x) / bnorm })
}

fn true_residual(a: &impl LinearOperator, b: &[f64], x: &[f64]) -> f64 {
    let mut r = vec![0.0; b.len()];
    a.apply(x, &mut r);
    r.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>().sqrt()
}
