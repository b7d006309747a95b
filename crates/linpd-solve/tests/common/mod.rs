//! Test matrices shared by the solver tests.
#![allow(dead_code)]

use faer::sparse::{SparseColMat, Triplet};

/// `||A u - b|| / ||b||` from the entries of `A`, without the library's products.
pub fn residual_by_entries(a: &SparseColMat<usize, f64>, u: &[f64], b: &[f64]) -> f64 {
    let mut r: Vec<f64> = b.iter().map(|v| -v).collect();
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            r[i] += v * u[j];
        }
    }
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    norm(&r) / norm(b)
}

/// A convection-diffusion matrix on an `nx` x `nx` grid: `spd(nx)` plus a skew first-order
/// term of strength `c` (unsymmetric, nonsingular: its symmetric part is `spd`).
pub fn unsym(nx: usize, c: f64) -> SparseColMat<usize, f64> {
    let a = spd(nx);
    let mut t = Vec::new();
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            t.push(Triplet::new(i, j, *v));
        }
    }
    for k in 0..nx * nx {
        if (k + 1) % nx != 0 {
            t.push(Triplet::new(k, k + 1, c));
            t.push(Triplet::new(k + 1, k, -c));
        }
    }
    SparseColMat::try_new_from_triplets(nx * nx, nx * nx, &t).unwrap()
}

/// A shifted 2D grid Laplacian with a seeded pseudo-random diagonal: SPD, kappa ~ 1e3.
pub fn spd(nx: usize) -> SparseColMat<usize, f64> {
    let n = nx * nx;
    let mut t = Vec::new();
    let mut seed = 12345u64;
    for i in 0..nx {
        for j in 0..nx {
            let k = i * nx + j;
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let shift = 1e-2 * ((seed >> 11) as f64 / (1u64 << 53) as f64);
            t.push(Triplet::new(k, k, 4.0 + shift));
            if i + 1 < nx {
                t.push(Triplet::new(k, k + nx, -1.0));
                t.push(Triplet::new(k + nx, k, -1.0));
            }
            if j + 1 < nx {
                t.push(Triplet::new(k, k + 1, -1.0));
                t.push(Triplet::new(k + 1, k, -1.0));
            }
        }
    }
    SparseColMat::try_new_from_triplets(n, n, &t).unwrap()
}
