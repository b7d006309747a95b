//! Direct solvers: sparse Cholesky with a reusable symbolic analysis, sparse LU, dense Cholesky.

use crate::SolveError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::SparseColMat;
use faer::{Conj, Mat, MatMut, Par, Side};
use std::sync::Arc;
use std::time::Instant;

/// The symbolic sparse Cholesky analysis of a pattern (AMD ordering, elimination tree,
/// supernodes). Cheap to clone (shared via `Arc`); reuse it for every matrix with the same
/// pattern.
#[derive(Debug, Clone)]
pub struct Cholesky {
    symbolic: Arc<SymbolicCholesky<usize>>,
}

/// A numeric factor `P A P^T = L L^T`.
#[derive(Debug)]
pub struct CholeskyFactor {
    symbolic: Arc<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
}

fn par() -> Par {
    Par::rayon(0)
}

impl Cholesky {
    /// Symbolic analysis of the pattern of `a` (lower triangle read) with AMD ordering.
    pub fn analyze(a: &SparseColMat<usize, f64>) -> Result<Self, SolveError> {
        Self::analyze_with_ordering(a, None)
    }

    /// Symbolic analysis with a caller's fill-reducing permutation `perm[new] = old` (e.g.
    /// nested dissection on the lattice), or AMD when `None`.
    pub fn analyze_with_ordering(a: &SparseColMat<usize, f64>, perm: Option<&[usize]>) -> Result<Self, SolveError> {
        let inv: Vec<usize>;
        let ordering = match perm {
            None => SymmetricOrdering::Amd,
            Some(p) => {
                assert_eq!(p.len(), a.nrows(), "ordering length");
                let mut q = vec![0usize; p.len()];
                for (new, &old) in p.iter().enumerate() {
                    q[old] = new;
                }
                inv = q;
                SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(p, &inv, p.len()))
            }
        };
        let symbolic =
            factorize_symbolic_cholesky(a.symbolic(), Side::Lower, ordering, CholeskySymbolicParams::default())
                .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        Ok(Cholesky { symbolic: Arc::new(symbolic) })
    }

    /// Stored entries of `L`.
    pub fn nnz_factor(&self) -> usize {
        self.symbolic.len_val()
    }

    /// How many [`Cholesky`] handles share this analysis (tests use it to prove reuse).
    pub fn share_count(&self) -> usize {
        Arc::strong_count(&self.symbolic)
    }

    /// Numeric factorization of `a`, which must have the analysed pattern.
    pub fn factor(&self, a: &SparseColMat<usize, f64>) -> Result<CholeskyFactor, SolveError> {
        let mut l_values = Vec::new();
        l_values.try_reserve_exact(self.symbolic.len_val()).map_err(|_| {
            SolveError::Factorization(format!("out of memory for {} factor entries", self.symbolic.len_val()))
        })?;
        l_values.resize(self.symbolic.len_val(), 0.0);
        let req = self.symbolic.factorize_numeric_llt_scratch::<f64>(par(), Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        let result = self.symbolic.factorize_numeric_llt::<f64>(
            &mut l_values,
            a.as_ref(),
            Side::Lower,
            Default::default(),
            par(),
            MemStack::new(&mut mem),
            Default::default(),
        );
        match result {
            Ok(_) => Ok(CholeskyFactor { symbolic: self.symbolic.clone(), l_values }),
            Err(DenseLltError::NonPositivePivot { index }) => {
                // faer's simplicial kernel reports the 1-based count of the failed column, the
                // supernodal one the 0-based column; both in the permuted order.
                let k = match self.symbolic.raw() {
                    SymbolicCholeskyRaw::Simplicial(_) => index.saturating_sub(1),
                    SymbolicCholeskyRaw::Supernodal(_) => index,
                };
                let dof = match self.symbolic.perm() {
                    Some(p) => p.arrays().0[k],
                    None => k,
                };
                Err(SolveError::NotPositiveDefinite { dof })
            }
        }
    }
}

impl CholeskyFactor {
    /// Solves `A x = b`.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let n = b.len();
        let mut x = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
        let llt = LltRef::<'_, usize, f64>::new(&self.symbolic, &self.l_values);
        let req = self.symbolic.solve_in_place_scratch::<f64>(1, par());
        let mut mem = MemBuffer::new(req);
        llt.solve_in_place_with_conj(Conj::No, x.as_mut(), par(), MemStack::new(&mut mem));
        (0..n).map(|i| x[(i, 0)]).collect()
    }
}

/// Sparse LU (COLAMD ordering, partial pivoting) of a general square matrix; returns the
/// solution, the stored entries of `L + U` and the `[symbolic, numeric, solve]` seconds.
pub fn lu_solve(a: &SparseColMat<usize, f64>, b: &[f64]) -> Result<(Vec<f64>, usize, [f64; 3]), SolveError> {
    use faer::prelude::Solve;
    use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
    let t = Instant::now();
    let symbolic = SymbolicLu::try_new(a.symbolic()).map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
    let ts = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let lu = Lu::try_new_with_symbolic(symbolic, a.as_ref()).map_err(|e| match e {
        faer::sparse::linalg::LuError::SymbolicSingular { index } => SolveError::Singular { dof: index },
        other => SolveError::Factorization(format!("{other:?}")),
    })?;
    let tn = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let rhs = Mat::<f64>::from_fn(b.len(), 1, |i, _| b[i]);
    let x = lu.solve(&rhs);
    let tsol = t.elapsed().as_secs_f64();
    // faer does not expose the LU fill directly; report the stored entries of A as a lower bound.
    let nnz = a.val().len();
    Ok(((0..b.len()).map(|i| x[(i, 0)]).collect(), nnz, [ts, tn, tsol]))
}

/// Sparse LU for banded (1D nonlocal) matrices. faer's LU always orders columns by COLAMD, which
/// spent ~27 s on a band of half-width 500 (shared notes, pitfall 2). COLAMD puts columns with
/// more than `max(16, dense_col * n)` entries last without ordering them; `dense_col = 0` makes
/// every band column "dense", so the analysis takes 0.6 s there and the band is kept. Returns
/// the solution and `[symbolic, numeric, solve]` seconds.
pub fn lu_solve_band(a: &SparseColMat<usize, f64>, b: &[f64]) -> Result<(Vec<f64>, [f64; 3]), SolveError> {
    use faer::sparse::linalg::colamd::Control;
    use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuSymbolicParams, NumericLu};
    let t = Instant::now();
    let params = LuSymbolicParams {
        colamd_params: Control { dense_row: 0.0, dense_col: 0.0, aggressive: true },
        ..Default::default()
    };
    let sym = factorize_symbolic_lu(a.symbolic(), params).map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
    let ts = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut num = NumericLu::<usize, f64>::new();
    let mut mem = MemBuffer::try_new(sym.factorize_numeric_lu_scratch::<f64>(par(), Default::default()))
        .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
    let lu = sym
        .factorize_numeric_lu(&mut num, a.as_ref(), par(), MemStack::new(&mut mem), Default::default())
        .map_err(|e| match e {
            faer::sparse::linalg::LuError::SymbolicSingular { index } => SolveError::Singular { dof: index },
            other => SolveError::Factorization(format!("{other:?}")),
        })?;
    let tn = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut x = Mat::<f64>::from_fn(b.len(), 1, |i, _| b[i]);
    let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(1, par()));
    lu.solve_in_place_with_conj(Conj::No, x.as_mut(), par(), MemStack::new(&mut mem));
    Ok(((0..b.len()).map(|i| x[(i, 0)]).collect(), [ts, tn, t.elapsed().as_secs_f64()]))
}

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
