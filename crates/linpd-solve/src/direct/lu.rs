//! Sparse LU with partial pivoting (faer), split into a symbolic analysis (column ordering,
//! reusable for every matrix of the same pattern) and a numeric factorization.
//!
//! Two column orderings: COLAMD ([`LuOrdering::Colamd`]) for general sparse matrices, and
//! [`LuOrdering::Band`] for banded (1D nonlocal) ones. faer's LU always runs COLAMD, which spent
//! ~27 s on a band of half-width 500 (shared notes, pitfall 2). COLAMD puts columns with more
//! than `max(16, dense_col * n)` entries last without ordering them; `dense_col = 0` makes every
//! band column "dense", so the analysis takes 0.6 s there and the band is kept.

use crate::direct::cholesky::par;
use crate::SolveError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::colamd::Control;
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu};
use faer::sparse::linalg::LuError;
use faer::sparse::SparseColMat;
use faer::{Conj, Mat};

/// Column ordering of the LU analysis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LuOrdering {
    /// COLAMD with faer's default controls.
    #[default]
    Colamd,
    /// Keep a band: every column counts as dense for COLAMD (see the module docs).
    Band,
}

/// The symbolic LU analysis of a pattern.
#[derive(Debug)]
pub struct Lu {
    symbolic: SymbolicLu<usize>,
    fill_bound: usize,
}

/// A numeric factor `P A Q = L U`.
#[derive(Debug)]
pub struct LuFactor<'a> {
    symbolic: &'a SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
}

fn failed(e: LuError) -> SolveError {
    match e {
        LuError::SymbolicSingular { index } => SolveError::Singular { dof: index },
        LuError::Generic(e) => SolveError::Factorization(e),
    }
}

impl Lu {
    /// Symbolic analysis of the pattern of `a`.
    pub fn analyze(a: &SparseColMat<usize, f64>, ordering: LuOrdering) -> Result<Self, SolveError> {
        let params = match ordering {
            LuOrdering::Colamd => LuSymbolicParams::default(),
            LuOrdering::Band => LuSymbolicParams {
                colamd_params: Control { dense_row: 0.0, dense_col: 0.0, aggressive: true },
                ..Default::default()
            },
        };
        let symbolic = factorize_symbolic_lu(a.symbolic(), params).map_err(SolveError::Factorization)?;
        let fill_bound = ata_factor_entries(a, symbolic.col_perm());
        Ok(Lu { symbolic, fill_bound })
    }

    /// An upper bound of the entries of `L` (or of `U`) for any row pivoting: the entries of
    /// the Cholesky factor `R^T` of `Q^T A^T A Q` under the analysis' column order `Q` (George &
    /// Ng 1987: the structures of `L` and `U` of `P A Q = L U` lie in those of the Householder
    /// vectors and of `R` of `A Q = Q_h R`, both within `R`'s pattern).
    pub fn fill_bound(&self) -> usize {
        self.fill_bound
    }

    /// The bytes the numeric factorization may hold at its peak: `L` and `U` at
    /// [`Lu::fill_bound`] entries each (8 bytes of value, 8 of row index) and faer's workspace.
    pub fn factor_bytes(&self) -> f64 {
        let req = self.symbolic.factorize_numeric_lu_scratch::<f64>(par(), Default::default());
        2.0 * 16.0 * self.fill_bound as f64 + req.size_bytes() as f64
    }

    /// Numeric factorization of `a`, which must have the analysed pattern.
    ///
    /// Its fill is bounded from the symbolic analysis ([`Lu::factor_bytes`]) and checked
    /// against the available memory before anything is allocated ([`SolveError::Memory`]).
    pub fn factor(&self, a: &SparseColMat<usize, f64>) -> Result<LuFactor<'_>, SolveError> {
        linpd_core::memory::check(
            format!(
                "the sparse LU factors (at most {:.3e} entries each of L and U, from the Cholesky factor of A^T A)",
                self.fill_bound as f64
            ),
            self.factor_bytes(),
            "use the gmres solver (\"type\": \"gmres\") or a coarser model",
        )?;
        let mut numeric = NumericLu::<usize, f64>::new();
        let req = self.symbolic.factorize_numeric_lu_scratch::<f64>(par(), Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|e| SolveError::Factorization(e.into()))?;
        self.symbolic
            .factorize_numeric_lu(&mut numeric, a.as_ref(), par(), MemStack::new(&mut mem), Default::default())
            .map_err(failed)?;
        Ok(LuFactor { symbolic: &self.symbolic, numeric })
    }
}

/// The entries of the Cholesky factor of `Q^T A^T A Q` (`Q` = `col_perm`), from its column
/// counts (faer's column elimination tree and `A^T A` column counts, without forming `A^T A`).
fn ata_factor_entries(a: &SparseColMat<usize, f64>, col_perm: faer::perm::PermRef<'_, usize>) -> usize {
    use faer::sparse::linalg::qr::{col_etree, col_etree_scratch, column_counts_aat_scratch, column_counts_ata};
    use faer::sparse::linalg::qr::{postorder, postorder_scratch};
    let (m, n) = (a.nrows(), a.ncols());
    let at = a.transpose().to_col_major().expect("the transpose of a valid matrix");
    let req =
        col_etree_scratch::<usize>(m, n).or(postorder_scratch::<usize>(n)).or(column_counts_aat_scratch::<usize>(m, n));
    let mut mem = MemBuffer::new(req);
    let stack = MemStack::new(&mut mem);
    let mut etree = vec![0usize; n];
    let etree = col_etree(a.symbolic(), Some(col_perm), &mut etree, stack);
    let mut post = vec![0usize; n];
    postorder(&mut post, etree, stack);
    let (mut counts, mut min_col) = (vec![0usize; n], vec![0usize; m]);
    column_counts_ata(&mut counts, &mut min_col, at.symbolic(), Some(col_perm), etree, &post, stack);
    counts.iter().sum()
}

impl LuFactor<'_> {
    /// Solves `A x = b`.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = Mat::<f64>::from_fn(b.len(), 1, |i, _| b[i]);
        // The numeric part came from `factorize_numeric_lu` of this symbolic analysis, which is
        // what `LuRef::new_unchecked` requires.
        let lu = LuRef::new_unchecked(self.symbolic, &self.numeric);
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(1, par()));
        lu.solve_in_place_with_conj(Conj::No, x.as_mut(), par(), MemStack::new(&mut mem));
        (0..b.len()).map(|i| x[(i, 0)]).collect()
    }
}
