//! Helpers shared by the LPS test files.
#![allow(dead_code)]

use faer::sparse::SparseColMat;
use linpd_lps::{Influence, LpsParams, PlaneModel};

/// Lattice spacing of the test grids.
pub const H: f64 = 0.1;

/// The LPS parameters of the tests: K = 2, G = 0.5 (the dilatation term active), horizon
/// `ratio * H`.
pub fn params(ratio: f64, influence: Influence, partial_volume: bool, plane: Option<PlaneModel>) -> LpsParams {
    LpsParams { K: 2.0, G: 0.5, horizon: ratio * H, influence, partial_volume, plane }
}

/// Dense copy of a CSC matrix (small test matrices only).
pub fn dense(a: &SparseColMat<usize, f64>) -> Vec<Vec<f64>> {
    let mut m = vec![vec![0.0; a.ncols()]; a.nrows()];
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            m[i][j] += *v;
        }
    }
    m
}

/// Largest absolute entry.
pub fn max_abs(m: &[Vec<f64>]) -> f64 {
    m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()))
}

/// Seeded xorshift in [-1, 1).
pub fn random_vec(n: usize, mut s: u64) -> Vec<f64> {
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
        .collect()
}
