//! Linear solvers for the reduced (constrained-DOF-eliminated) stiffness systems of linpd.
//!
//! * [`direct::Cholesky`]: sparse `L L^T` (faer), symbolic analysis kept and reused when only
//!   values change ("symbolic once, numeric many"); a non-positive pivot is reported with the
//!   original DOF it belongs to;
//! * [`direct::lu_solve`]: sparse LU for unsymmetric systems; [`direct::lu_solve_band`] the
//!   same without COLAMD's cost on banded matrices;
//! * [`gmres::gmres`]: restarted, right-preconditioned GMRES for unsymmetric systems;
//! * [`direct::dense_solve`]: dense Cholesky for tiny systems;
//! * [`cg::pcg`]: Jacobi-preconditioned conjugate gradients over any [`LinearOperator`]
//!   (assembled or matrix-free), with the Params / Info / Error triple;
//! * [`solve`]: dispatch by [`SolverKind`], returning a [`SolveReport`] with the relative
//!   residual `||A u - f|| / ||f||`, phase timings, nonzeros of `A` and of the factor,
//!   iterations and peak memory.
#![deny(missing_docs)]

pub mod cg;
pub mod direct;
pub mod gmres;
pub mod report;

pub use cg::{pcg, CgError, CgInfo, CgParams, LinearOperator};
pub use direct::{dense_solve, lu_solve, lu_solve_band, Cholesky};
pub use gmres::{gmres, GmresError, GmresInfo, GmresParams};
pub use report::{peak_rss_bytes, SolveReport, Timings};

use faer::sparse::SparseColMat;
use rayon::prelude::*;
use std::time::Instant;

/// Which solver to use.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverKind {
    /// 1D and small 2D/3D: sparse Cholesky; large 3D (or large 2D): Jacobi-PCG.
    Auto,
    /// Sparse Cholesky.
    Cholesky,
    /// Sparse LU (for unsymmetric operators; works on SPD ones too).
    Lu,
    /// Jacobi-preconditioned CG.
    Cg(CgParams),
    /// Dense Cholesky (tiny systems only).
    Dense,
}

/// A failed solve.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// Cholesky met a non-positive pivot: the system is singular or indefinite there.
    #[error("the stiffness is not positive definite: zero or negative pivot at free DOF {dof}")]
    NotPositiveDefinite {
        /// Free DOF (in the caller's numbering) of the pivot.
        dof: usize,
    },
    /// LU met a structurally singular column.
    #[error("the stiffness is singular: no pivot for free DOF {dof}")]
    Singular {
        /// Free DOF of the failed pivot.
        dof: usize,
    },
    /// CG did not converge or broke down.
    #[error(transparent)]
    Cg(#[from] CgError),
    /// The system is too large for the dense solver.
    #[error("dense solver refused: {n} unknowns (limit {limit}); use cholesky or cg")]
    TooLargeForDense {
        /// Unknowns.
        n: usize,
        /// Limit.
        limit: usize,
    },
    /// The factorization ran out of memory or failed for a non-numerical reason.
    #[error("factorization failed: {0}")]
    Factorization(String),
    /// The solution is not finite (overflow): never returned as a result.
    #[error("the solution contains non-finite values")]
    NonFinite,
}

/// `y = A x` for a symmetric CSC matrix, parallel over columns (column j of a symmetric
/// matrix is row j, so each output entry is one independent dot product; faer's own CSC
/// product is sequential).
pub fn sym_matvec(a: &SparseColMat<usize, f64>, x: &[f64], y: &mut [f64]) {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let v = a.val();
    y.par_iter_mut().enumerate().with_min_len(256).for_each(|(j, yj)| {
        let mut s = 0.0;
        for p in cp[j]..cp[j + 1] {
            s += v[p] * x[ri[p]];
        }
        *yj = s;
    });
}

/// `y = A x` for a general CSC matrix (sequential scatter).
pub fn matvec(a: &SparseColMat<usize, f64>, x: &[f64], y: &mut [f64]) {
    y.iter_mut().for_each(|v| *v = 0.0);
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let v = a.val();
    for j in 0..a.ncols() {
        for p in cp[j]..cp[j + 1] {
            y[ri[p]] += v[p] * x[j];
        }
    }
}

/// Diagonal of a CSC matrix.
pub fn diagonal(a: &SparseColMat<usize, f64>) -> Vec<f64> {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    (0..a.ncols()).map(|j| (cp[j]..cp[j + 1]).filter(|&p| ri[p] == j).map(|p| a.val()[p]).sum()).collect()
}

/// `||A x - b|| / ||b||` (or `||A x||` when `b = 0`).
pub fn relative_residual(a: &SparseColMat<usize, f64>, symmetric: bool, x: &[f64], b: &[f64]) -> f64 {
    let mut r = vec![0.0; b.len()];
    if symmetric {
        sym_matvec(a, x, &mut r);
    } else {
        matvec(a, x, &mut r);
    }
    let num: f64 = r.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    if den > 0.0 {
        num / den
    } else {
        num
    }
}

/// The solver [`SolverKind::Auto`] picks for `n` unknowns in dimension `dim`.
///
/// 1D operators are banded and badly conditioned (kappa ~ (N/m)^2): always direct. 2D up to
/// 200k unknowns: direct. 3D: direct only up to 3000 unknowns. With faer's AMD ordering the 3D
/// fill is large: a 23^3-node cube with delta = 3h (28k unknowns) took 10.6 s and 1.1 GiB by
/// Cholesky against 0.44 s by Jacobi-PCG on this 2-core machine.
pub fn auto_choice(dim: usize, n: usize) -> SolverKind {
    match dim {
        1 => SolverKind::Cholesky,
        2 if n <= 200_000 => SolverKind::Cholesky,
        3 if n <= 3_000 => SolverKind::Cholesky,
        _ => SolverKind::Cg(CgParams::default()),
    }
}

/// Solves the SPD system `A u = f` with the chosen solver and reports what it cost.
pub fn solve(
    a: &SparseColMat<usize, f64>,
    f: &[f64],
    kind: &SolverKind,
    dim: usize,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    solve_with_ordering(a, f, kind, dim, None)
}

/// [`solve`] with a fill-reducing permutation (`perm[new] = old`) for the Cholesky solver.
pub fn solve_with_ordering(
    a: &SparseColMat<usize, f64>,
    f: &[f64],
    kind: &SolverKind,
    dim: usize,
    perm: Option<&[usize]>,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    let n = a.nrows();
    let kind = match kind {
        SolverKind::Auto => auto_choice(dim, n),
        k => k.clone(),
    };
    let mut report = SolveReport::new(n, a.val().len());
    let t0 = Instant::now();
    let u = match &kind {
        SolverKind::Cholesky | SolverKind::Auto => {
            report.solver = if perm.is_some() { "cholesky-nd" } else { "cholesky-amd" }.into();
            let t = Instant::now();
            let chol = Cholesky::analyze_with_ordering(a, perm)?;
            report.timings.symbolic = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let factor = chol.factor(a)?;
            report.timings.numeric = t.elapsed().as_secs_f64();
            report.nnz_factor = Some(chol.nnz_factor());
            let t = Instant::now();
            let u = factor.solve(f);
            report.timings.solve = t.elapsed().as_secs_f64();
            u
        }
        SolverKind::Lu => {
            report.solver = "lu".into();
            let (u, nnz, ts) = lu_solve(a, f)?;
            report.nnz_factor = Some(nnz);
            report.timings.symbolic = ts[0];
            report.timings.numeric = ts[1];
            report.timings.solve = ts[2];
            u
        }
        SolverKind::Dense => {
            report.solver = "dense".into();
            let t = Instant::now();
            let u = dense_solve(a, f)?;
            report.timings.numeric = t.elapsed().as_secs_f64();
            report.nnz_factor = Some(n * (n + 1) / 2);
            u
        }
        SolverKind::Cg(params) => {
            report.solver = "cg-jacobi".into();
            let t = Instant::now();
            let mut u = vec![0.0; n];
            let op = SymCsc(a);
            let info = pcg(&op, &diagonal(a), f, &mut u, params)?;
            report.timings.solve = t.elapsed().as_secs_f64();
            report.iterations = Some(info.iterations);
            u
        }
    };
    if u.iter().any(|v| !v.is_finite()) {
        return Err(SolveError::NonFinite);
    }
    report.timings.total = t0.elapsed().as_secs_f64();
    report.rel_residual = relative_residual(a, true, &u, f);
    report.peak_rss_bytes = peak_rss_bytes();
    Ok((u, report))
}

/// A symmetric CSC matrix as a [`LinearOperator`].
pub struct SymCsc<'a>(pub &'a SparseColMat<usize, f64>);

impl LinearOperator for SymCsc<'_> {
    fn n(&self) -> usize {
        self.0.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        sym_matvec(self.0, x, y)
    }
}
