//! Sparse Cholesky in the lattice nested-dissection ordering solves the same systems as in AMD's.

use faer::sparse::{SparseColMat, Triplet};
use linpd_core::family::lattice_stencil;
use linpd_core::{nested_dissection, two_hop_stencil, DofMap, Grid, Placement};
use linpd_solve::Cholesky;

/// A bond-based stiffness on the free DOFs: per bond `(i, j)` with unit vector `e`, weight
/// `w = 1 / |xi|` and blocks `w e e^T` on the diagonal, `-w e e^T` off it. With the clamped
/// planes it is SPD.
fn bond_matrix(g: &Grid, m: f64, dofs: &DofMap) -> SparseColMat<usize, f64> {
    let d = dofs.dim();
    let mut t = Vec::new();
    for i in 0..g.len() {
        let k = g.lattice_index(i);
        for o in lattice_stencil(d, m) {
            let Some(j) = g.node_at([k[0] + o[0], k[1] + o[1], k[2] + o[2]]) else { continue };
            let len = ((o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) as f64).sqrt();
            let e = [o[0] as f64 / len, o[1] as f64 / len, o[2] as f64 / len];
            for a in 0..d {
                for b in 0..d {
                    let v = e[a] * e[b] / len;
                    if let (Some(r), Some(c)) = (dofs.free(d * i + a), dofs.free(d * i + b)) {
                        t.push(Triplet::new(r, c, v));
                    }
                    if let (Some(r), Some(c)) = (dofs.free(d * i + a), dofs.free(d * j + b)) {
                        t.push(Triplet::new(r, c, -v));
                    }
                }
            }
        }
    }
    SparseColMat::try_new_from_triplets(dofs.n_free(), dofs.n_free(), &t).unwrap()
}

/// `A^2`: SPD when `A` is, with the two-hop pattern of an LPS tangent.
fn square(a: &SparseColMat<usize, f64>) -> SparseColMat<usize, f64> {
    let mut t = Vec::new();
    for j in 0..a.ncols() {
        for (k, &akj) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            for (i, &aik) in a.row_idx_of_col(k).zip(a.val_of_col(k)) {
                t.push(Triplet::new(i, j, aik * akj));
            }
        }
    }
    SparseColMat::try_new_from_triplets(a.nrows(), a.ncols(), &t).unwrap()
}

fn max_rel_diff(x: &[f64], y: &[f64]) -> f64 {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter().zip(y).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / scale
}

/// Both factorizations are backward stable, so the two solutions differ by about `kappa * eps`
/// (measured: 1e-15 for the bond matrices, 3e-13 to 9e-13 for their squares, whose condition
/// number is the square); 1e-10 leaves two orders of magnitude, and a wrong permutation (a lost
/// or repeated DOF) gives an O(1) difference or a panic.
#[test]
fn nested_dissection_and_amd_give_the_same_solution() {
    for (dim, nodes, m) in [(2usize, 30usize, 3.0f64), (3, 10, 2.0)] {
        let last = (nodes - 1) as f64;
        let g = Grid::new(&vec![0.0; dim], &vec![last; dim], 1.0, 0.0, Placement::Vertex).unwrap();
        // Whole nodes clamped on the bottom planes, one component pinned on the top plane.
        let mut mask = vec![false; dim * g.len()];
        for n in 0..g.len() {
            let k = g.lattice_index(n)[dim - 1];
            if k < 2 {
                (0..dim).for_each(|a| mask[dim * n + a] = true);
            }
            if k == nodes as i64 - 1 {
                mask[dim * n] = true;
            }
        }
        let dofs = DofMap::new(dim, &mask);
        let bond = bond_matrix(&g, m, &dofs);
        let stencil = lattice_stencil(dim, m);
        let b: Vec<f64> = (0..dofs.n_free()).map(|i| (i as f64 * 0.37).sin()).collect();
        for (a, stencil) in [(bond.clone(), stencil.clone()), (square(&bond), two_hop_stencil(&stencil))] {
            let perm = nested_dissection(&g, &stencil, &dofs);
            let nd = Cholesky::analyze_with_ordering(&a, Some(&perm)).unwrap().factor(&a).unwrap().solve(&b);
            let amd = Cholesky::analyze(&a).unwrap().factor(&a).unwrap().solve(&b);
            let diff = max_rel_diff(&nd, &amd);
            assert!(diff <= 1e-10, "{dim}D, {} DOFs: ND and AMD solutions differ by {diff:.2e}", dofs.n_free());
        }
    }
}
