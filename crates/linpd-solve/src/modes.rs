//! The lowest natural modes of `K phi = omega^2 M phi` with a symmetric positive semi-definite
//! stiffness `K` and a lumped (diagonal, positive) mass `M` ([`lowest_modes`]).
//!
//! # Method
//!
//! Shift and invert about `-s` (`s > 0`): with `K~ = M^(-1/2) K M^(-1/2)`, the largest
//! eigenvalues `mu` of
//!
//! ```text
//! (K~ + s I)^(-1) = M^(1/2) (K + s M)^(-1) M^(1/2)
//! ```
//!
//! are `1 / (omega^2 + s)` for the lowest `omega^2`: one sparse Cholesky factor of `K + s M`
//! (SPD also when `K` is singular, a free-free body: its rigid motions are `omega^2 = 0`), and
//! faer's Krylov-Schur eigensolver for self-adjoint operators
//! ([`faer::matrix_free::eigen::partial_self_adjoint_eigen`]) on the operator. Then
//! `omega^2 = 1/mu - s` and `phi = M^(-1/2) psi`. The shift is `s = 1e-8 max_i K_ii / M_ii`
//! (the operator's condition number is then at most about 1e8): rigid modes come out at
//! `|omega^2| <~ 1e-8 s`, far below any elastic one.

use crate::direct::Cholesky;
use crate::SolveError;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::matrix_free::eigen::{partial_self_adjoint_eigen, partial_self_adjoint_eigen_scratch, PartialEigenParams};
use faer::matrix_free::LinOp;
use faer::sparse::SparseColMat;
use faer::{Col, Mat, MatMut, MatRef, Par};

/// The shift's size relative to `max_i K_ii / M_ii` (see the module docs).
pub const SHIFT_RATIO: f64 = 1e-8;

/// Eigenpairs of `K phi = omega^2 M phi`, ascending.
#[derive(Debug, Clone)]
pub struct ModesResult {
    /// `omega^2` of each mode, ascending.
    pub omega2: Vec<f64>,
    /// Each mode's shape (one value per DOF of `K`), `M`-orthonormal: `phi^T M phi = 1`.
    pub shapes: Vec<Vec<f64>>,
    /// The shift `s`.
    pub shift: f64,
}

/// `M^(1/2) (K + s M)^(-1) M^(1/2)` (see the module docs).
struct ShiftInvert {
    factor: crate::CholeskyFactor,
    sqrt_m: Vec<f64>,
}

impl std::fmt::Debug for ShiftInvert {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ShiftInvert({} rows)", self.sqrt_m.len())
    }
}

impl LinOp<f64> for ShiftInvert {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.sqrt_m.len()
    }
    fn ncols(&self) -> usize {
        self.sqrt_m.len()
    }
    fn apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _par: Par, _stack: &mut MemStack) {
        let mut out = out;
        for c in 0..rhs.ncols() {
            let b: Vec<f64> = (0..self.sqrt_m.len()).map(|i| self.sqrt_m[i] * rhs[(i, c)]).collect();
            let x = self.factor.solve(&b);
            for i in 0..x.len() {
                out[(i, c)] = self.sqrt_m[i] * x[i];
            }
        }
    }
    fn conj_apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        self.apply(out, rhs, par, stack);
    }
}

/// The `count` lowest modes of `K phi = omega^2 M phi` (`k` symmetric, both triangles or the
/// lower one stored; `mass` the diagonal of `M`, positive), to the relative `tolerance` of
/// the shifted-inverse eigenvalues (see the module docs).
///
/// # Errors
/// [`SolveError::NotPositiveDefinite`] when `K + s M` is not (an indefinite `K`), and
/// [`SolveError::Factorization`] when the eigensolver does not converge `count` pairs.
pub fn lowest_modes(
    k: &SparseColMat<usize, f64>,
    mass: &[f64],
    count: usize,
    tolerance: f64,
) -> Result<ModesResult, SolveError> {
    let n = mass.len();
    assert_eq!(k.nrows(), n, "one mass per DOF");
    assert!(count >= 1 && count <= n, "1 <= count <= n");
    assert!(mass.iter().all(|&m| m > 0.0 && m.is_finite()), "positive masses");
    let diag = linpd_core::sparse::diagonal(k);
    let ratio = diag.iter().zip(mass).fold(0.0f64, |r, (k, m)| r.max(k / m));
    let shift = SHIFT_RATIO * ratio.max(f64::MIN_POSITIVE);
    // K + s M: the diagonal entries gain s m_j (every column of a stiffness has its diagonal)
    let (cp, ri) = (k.symbolic().col_ptr(), k.symbolic().row_idx());
    let mut shifted = k.clone();
    let v = shifted.val_mut();
    for j in 0..n {
        for p in cp[j]..cp[j + 1] {
            if ri[p] == j {
                v[p] += shift * mass[j];
            }
        }
    }
    let factor = Cholesky::analyze(&shifted)?.factor(&shifted)?;
    drop(shifted);
    let op = ShiftInvert { factor, sqrt_m: mass.iter().map(|m| m.sqrt()).collect() };
    let params = PartialEigenParams { max_dim: (2 * count + 20).min(n), ..Default::default() };
    let par = Par::Seq;
    let mut mem = MemBuffer::new(partial_self_adjoint_eigen_scratch::<f64>(&op, count, par, params));
    let mut vecs = Mat::<f64>::zeros(n, count);
    let mut mu = vec![0.0; count];
    // a start vector with a component along every mode: smooth, not orthogonal to the rigid ones
    let v0 = Col::<f64>::from_fn(n, |i| 1.0 + ((i * 7919) % 101) as f64 / 101.0);
    let v0 = &v0 * (1.0 / v0.norm_l2());
    let info = partial_self_adjoint_eigen(
        vecs.as_mut(),
        &mut mu,
        &op,
        v0.as_ref(),
        tolerance,
        par,
        MemStack::new(&mut mem),
        params,
    );
    if info.n_converged_eigen < count {
        return Err(SolveError::Eigen { converged: info.n_converged_eigen, asked: count });
    }
    let mut pairs: Vec<(f64, Vec<f64>)> = (0..count)
        .map(|c| {
            let omega2 = 1.0 / mu[c] - shift;
            let phi: Vec<f64> = (0..n).map(|i| vecs[(i, c)] / op.sqrt_m[i]).collect();
            (omega2, phi)
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (omega2, shapes) = pairs.into_iter().unzip();
    Ok(ModesResult { omega2, shapes, shift })
}
