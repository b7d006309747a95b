//! Dense Cholesky for tiny systems (and as an independent reference in tests).

use crate::SolveError;
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::sparse::SparseColMat;
use faer::{Conj, Mat, MatMut, Side};

/// Largest system the dense solver accepts (8 * n^2 bytes = 800 MB at the limit).
pub const DENSE_LIMIT: usize = 10_000;

/// Dense Cholesky of a (small) SPD matrix given in CSC form.
pub fn dense_solve(a: &SparseColMat<usize, f64>, b: &[f64]) -> Result<Vec<f64>, SolveError> {
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
