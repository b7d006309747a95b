//! What the setup and the cycle need from a level's matrix `A_l`: its row blocks, diagonal,
//! products with vectors and with a block matrix, and its strength graph. Coarse levels (and
//! an assembled finest level) are [`Vbr`] matrices; a matrix-free finest level is
//! [`super::streamed::Streamed`], whose blocks are computed when a product needs them.

use super::aggregate;
use super::vbr::Vbr;

/// A level's matrix (see the module docs).
pub(crate) trait LevelMatrix: Sync {
    /// Scalar row offset of each row block (`n_row_blocks + 1`); the column blocks are the
    /// same (the matrix is square and symmetric).
    fn rptr(&self) -> &[usize];
    /// Scalar rows.
    fn nrows(&self) -> usize {
        *self.rptr().last().unwrap_or(&0)
    }
    /// Row blocks.
    fn n_row_blocks(&self) -> usize {
        self.rptr().len() - 1
    }
    /// Scalar entries of the matrix (stored or not).
    fn nnz(&self) -> usize;
    /// Bytes the matrix holds (0 for one computed on demand).
    fn bytes(&self) -> usize;
    /// The scalar diagonal.
    fn diagonal(&self) -> Vec<f64>;
    /// `y = A x`.
    fn matvec(&self, x: &[f64], y: &mut [f64]);
    /// `y -= A x`.
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]);
    /// The strong neighbours of every row block ([`aggregate::strong_neighbours`]).
    fn strong_neighbours(&self, theta: f64) -> (Vec<usize>, Vec<u32>);
    /// `A B` for a block matrix `B` whose row blocks are the column blocks of `A`.
    fn mul(&self, b: &Vbr) -> Vbr;
    /// The Galerkin product `R A P` with `R = P^T` ([`super::vbr::galerkin_rows`]: `A P` is
    /// never stored).
    fn galerkin(&self, p: &Vbr, r: &Vbr) -> Vbr;
    /// Calls `f(bj, block)` for every nonzero block of row block `bi` (row-major values).
    fn for_each_row_block(&self, bi: usize, f: &mut dyn FnMut(usize, &[f64]));
}

impl LevelMatrix for Vbr {
    fn rptr(&self) -> &[usize] {
        &self.rptr
    }
    fn nnz(&self) -> usize {
        Vbr::nnz(self)
    }
    fn bytes(&self) -> usize {
        Vbr::bytes(self)
    }
    fn diagonal(&self) -> Vec<f64> {
        Vbr::diagonal(self)
    }
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        Vbr::matvec(self, x, y)
    }
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]) {
        Vbr::matvec_sub(self, x, y)
    }
    fn strong_neighbours(&self, theta: f64) -> (Vec<usize>, Vec<u32>) {
        aggregate::strong_neighbours(self, theta)
    }
    fn mul(&self, b: &Vbr) -> Vbr {
        Vbr::mul(self, b)
    }
    fn galerkin(&self, p: &Vbr, r: &Vbr) -> Vbr {
        Vbr::galerkin(self, p, r)
    }
    fn for_each_row_block(&self, bi: usize, f: &mut dyn FnMut(usize, &[f64])) {
        for b in self.bptr[bi]..self.bptr[bi + 1] {
            f(self.bidx[b] as usize, &self.val[self.voff[b]..self.voff[b + 1]]);
        }
    }
}
