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
        Ok(Lu { symbolic })
    }

    /// Numeric factorization of `a`, which must have the analysed pattern.
    pub fn factor(&self, a: &SparseColMat<usize, f64>) -> Result<LuFactor<'_>, SolveError> {
        let mut numeric = NumericLu::<usize, f64>::new();
        let req = self.symbolic.factorize_numeric_lu_scratch::<f64>(par(), Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|e| SolveError::Factorization(e.into()))?;
        self.symbolic
            .factorize_numeric_lu(&mut numeric, a.as_ref(), par(), MemStack::new(&mut mem), Default::default())
            .map_err(failed)?;
        Ok(LuFactor { symbolic: &self.symbolic, numeric })
    }
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
