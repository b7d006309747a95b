//! Sparse Cholesky `P A P^T = L L^T` with a reusable symbolic analysis (faer).

use crate::SolveError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError as DenseLltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::SparseColMat;
use faer::{Conj, Mat, Par, Side};
use std::sync::Arc;

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

pub(crate) fn par() -> Par {
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
                .map_err(SolveError::Factorization)?;
        Ok(Cholesky { symbolic: Arc::new(symbolic) })
    }

    /// Stored entries of `L`.
    pub fn nnz_factor(&self) -> usize {
        self.symbolic.len_val()
    }

    /// Floating-point operations of the numeric factorization, `sum_j c_j^2` with `c_j` the
    /// entries of column `j` of `L` (diagonal included): the standard count of a left-looking
    /// or multifrontal `L L^T` (George & Liu 1981), known from the symbolic analysis alone.
    pub fn flops(&self) -> f64 {
        let sq = |c: usize| (c as f64) * (c as f64);
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => s.col_ptr().windows(2).map(|w| sq(w[1] - w[0])).sum(),
            SymbolicCholeskyRaw::Supernodal(s) => {
                // Supernode k: columns begin..end share the rows below the diagonal block, so
                // its i-th column holds (width - i) diagonal-block entries plus those rows.
                let (begin, end, rows) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_row_idx());
                (0..s.n_supernodes())
                    .map(|k| {
                        let width = end[k] - begin[k];
                        let below = rows[k + 1] - rows[k];
                        (0..width).map(|i| sq(width - i + below)).sum::<f64>()
                    })
                    .sum()
            }
        }
    }

    /// The bytes the numeric factorization holds at its peak: the values of `L` and faer's
    /// workspace (the pattern is the symbolic analysis', already allocated).
    pub fn factor_bytes(&self) -> f64 {
        let req = self.symbolic.factorize_numeric_llt_scratch::<f64>(par(), Default::default());
        self.symbolic.len_val() as f64 * 8.0 + req.size_bytes() as f64
    }

    /// How many [`Cholesky`] handles share this analysis (tests use it to prove reuse).
    pub fn share_count(&self) -> usize {
        Arc::strong_count(&self.symbolic)
    }

    /// Numeric factorization of `a`, which must have the analysed pattern.
    ///
    /// The factor's fill is known from the symbolic analysis: its values and the numeric
    /// workspace are checked against the available memory before they are allocated
    /// ([`SolveError::Memory`]), so a too-large factor is an error, not an abort.
    pub fn factor(&self, a: &SparseColMat<usize, f64>) -> Result<CholeskyFactor, SolveError> {
        let req = self.symbolic.factorize_numeric_llt_scratch::<f64>(par(), Default::default());
        let len = self.symbolic.len_val();
        linpd_core::memory::check(
            format!("the Cholesky factor ({len:.3e} entries of L and the factorization's workspace)", len = len as f64),
            self.factor_bytes(),
            "use the cg solver (\"type\": \"cg\") or a coarser model",
        )?;
        let mut l_values = Vec::new();
        l_values
            .try_reserve_exact(self.symbolic.len_val())
            .map_err(|_| SolveError::FactorAllocation { entries: self.symbolic.len_val() })?;
        l_values.resize(self.symbolic.len_val(), 0.0);
        let mut mem = MemBuffer::try_new(req).map_err(|e| SolveError::Factorization(e.into()))?;
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
