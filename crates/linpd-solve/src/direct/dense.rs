//! Dense Cholesky and LU for small systems (and as an independent reference in tests).

use crate::SolveError;
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::sparse::SparseColMat;
use faer::{Conj, Mat, MatMut, Side};

/// Largest system the dense solver accepts (8 * n^2 bytes = 800 MB at the limit).
pub const DENSE_LIMIT: usize = 10_000;

/// The dense copy of a small CSC matrix (duplicates summed), refused above [`DENSE_LIMIT`].
fn densify(a: &SparseColMat<usize, f64>) -> Result<Mat<f64>, SolveError> {
    let n = a.nrows();
    if n > DENSE_LIMIT {
        return Err(SolveError::TooLargeForDense { n, limit: DENSE_LIMIT });
    }
    let mut m = Mat::<f64>::zeros(n, n);
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    for j in 0..n {
        for p in cp[j]..cp[j + 1] {
            m[(ri[p], j)] += a.val()[p];
        }
    }
    Ok(m)
}

/// Dense LU with partial pivoting of a (small, possibly unsymmetric) matrix in CSC form.
/// A zero or non-finite solution is reported by the caller's residual check: faer's partial
/// pivoting LU does not fail on singular matrices.
pub fn dense_lu_solve(a: &SparseColMat<usize, f64>, b: &[f64]) -> Result<Vec<f64>, SolveError> {
    use faer::prelude::Solve;
    let n = a.nrows();
    let lu = densify(a)?.partial_piv_lu();
    let x = lu.solve(Mat::<f64>::from_fn(n, 1, |i, _| b[i]));
    Ok((0..n).map(|i| x[(i, 0)]).collect())
}

/// Dense Cholesky of a (small) SPD matrix given in CSC form.
pub fn dense_solve(a: &SparseColMat<usize, f64>, b: &[f64]) -> Result<Vec<f64>, SolveError> {
    let n = a.nrows();
    let m = densify(a)?;
    let llt = m.llt(Side::Lower).map_err(|e| match e {
        DenseLltError::NonPositivePivot { index } => SolveError::NotPositiveDefinite { dof: index },
    })?;
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    {
        use faer::linalg::solvers::SolveCore;
        let xm: MatMut<'_, f64> = x.as_mut();
        llt.solve_in_place_with_conj(Conj::No, xm);
    }
    Ok((0..n).map(|i| x[(i, 0)]).collect())
}
