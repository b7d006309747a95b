//! Preconditioned conjugate gradients.
//!
//! Standard PCG for SPD `A` and SPD `M` (any [`Preconditioner`]). The loop runs on the
//! recursive residual `r_k`, which drifts from the true `b - A x_k` by rounding (by 5 orders
//! on an ill-conditioned 2D scene: recursive 1e-12, true 4.6e-7). So when `||r_k|| <= rtol
//! ||b||`, the true residual is recomputed; if it is above the target, CG restarts from it
//! (`r = b - A x`, `p = M^{-1} r`) within the same `max_iter`. A run either returns a true
//! residual `<= rtol` or an error: [`CgError::NotConverged`] at `max_iter`,
//! [`CgError::ResidualAboveTarget`] when a restart no longer halves the true residual (the
//! attainable accuracy `~ eps kappa` is above `rtol`), [`CgError::NonFinite`] on overflow.
//! Works on any [`LinearOperator`], so the same code serves assembled and matrix-free
//! operators.
//!
//! Why not `faer::matrix_free::conjugate_gradient`: faer's CG works on its own `LinOp`/`MatMut`
//! types with a `MemStack` per call and has no hook for our parallel dot products over `&[f64]`
//! or for reporting the true residual at exit; this loop is 40 lines and keeps every solve's
//! iteration counts identical to the published ones in docs/benchmarks.md.

use super::preconditioner::Preconditioner;
use linpd_core::progress::{NoProgress, Progress, Task};
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
    /// The recursive residual met `rtol` but the true one did not, and a restart from the true
    /// residual no longer halved it: rounding limits the accuracy above `rtol`.
    #[error(
        "CG reached a true relative residual of {rel_residual:e} after {iterations} iterations, above the requested \
         {rtol:e}: rounding limits the attainable accuracy (the system is ill-conditioned); raise rtol or use a direct solver"
    )]
    ResidualAboveTarget {
        /// Iterations taken.
        iterations: usize,
        /// True relative residual `||b - A x|| / ||b||` reached.
        rel_residual: f64,
        /// Target.
        rtol: f64,
    },
    /// A residual or curvature became NaN or infinite: the operator, the preconditioner or the
    /// right-hand side overflows.
    #[error("CG met a non-finite {what} at iteration {iteration}: the operator or the right-hand side overflows")]
    NonFinite {
        /// Iteration.
        iteration: usize,
        /// `"residual"` or `"curvature p.Ap"`.
        what: &'static str,
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

/// One CG update: iteration `it`, relative residual `rel`.
fn report(task: &Task<'_>, it: usize, rel: f64) {
    if task.is_on() {
        task.set(it as u64, &format!("iteration {it}, relative residual {rel:.2e}"));
    }
}

/// Solves `A x = b` from the initial guess in `x`, preconditioned by `m_inv` (`z = M^{-1} r`);
/// `Ok` only when the true relative residual is at most `rtol` (see the module docs).
pub fn pcg(
    a: &impl LinearOperator,
    m_inv: &impl Preconditioner,
    b: &[f64],
    x: &mut [f64],
    params: &CgParams,
) -> Result<CgInfo, CgError> {
    pcg_with_progress(a, m_inv, b, x, params, &NoProgress)
}

/// [`pcg`] reporting to `progress`: a task `"CG"` with no total whose updates carry the
/// iteration and the message `"iteration <k>, relative residual <r>"` (the recursive residual
/// `||r_k|| / ||b||`, the true one at each (re)start and at exit), at most every
/// [`linpd_core::progress::REPORT_INTERVAL`]; the last update is the final iteration count.
pub fn pcg_with_progress(
    a: &impl LinearOperator,
    m_inv: &impl Preconditioner,
    b: &[f64],
    x: &mut [f64],
    params: &CgParams,
    progress: &dyn Progress,
) -> Result<CgInfo, CgError> {
    let n = a.n();
    assert_eq!(b.len(), n);
    assert_eq!(x.len(), n);
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return Ok(CgInfo { iterations: 0, rel_residual: 0.0 });
    }
    let task = Task::start(progress, "CG", None);
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut ap = vec![0.0; n];
    let mut it = 0;
    let target = params.rtol * bnorm;
    // True residual at the previous (re)start: a restart must at least halve it.
    let mut last_restart = f64::INFINITY;
    loop {
        // (Re)start from the true residual.
        a.apply(x, &mut r);
        r.par_iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
        let true_norm = dot(&r, &r).sqrt();
        if !true_norm.is_finite() {
            return Err(CgError::NonFinite { iteration: it, what: "residual" });
        }
        let rel_residual = true_norm / bnorm;
        report(&task, it, rel_residual);
        if true_norm <= target {
            return Ok(CgInfo { iterations: it, rel_residual });
        }
        if it == params.max_iter {
            return Err(CgError::NotConverged { iterations: it, rel_residual, rtol: params.rtol });
        }
        if true_norm > 0.5 * last_restart {
            return Err(CgError::ResidualAboveTarget { iterations: it, rel_residual, rtol: params.rtol });
        }
        last_restart = true_norm;
        m_inv.apply(&r, &mut z);
        p.copy_from_slice(&z);
        let mut rz = dot(&r, &z);
        loop {
            let r_norm = dot(&r, &r).sqrt();
            if task.due() {
                report(&task, it, r_norm / bnorm);
            }
            // Not `r_norm <= target`: a NaN residual leaves the loop too (caught at the restart).
            if !(r_norm > target && it < params.max_iter) {
                break;
            }
            a.apply(&p, &mut ap);
            let pap = dot(&p, &ap);
            if !pap.is_finite() {
                return Err(CgError::NonFinite { iteration: it, what: "curvature p.Ap" });
            }
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
    }
}
