//! Properties of the bond-based operator that hold for any kernel and lattice:
//! symmetry, zero block-row sums, rigid-motion null space, agreement between the assembled,
//! matrix-free and stencil applies, and `A = -dF/du` for the nonlinear PMB force.

use faer::sparse::SparseColMat;
use linpd_bond::{assemble, pmb_force, BondOperator, StencilOperator};
use linpd_core::check_support;
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};

fn op(dim: usize, kernel: Kernel, pv: bool) -> (Grid, BondOperator, Micromodulus) {
    let max = [1.0, 0.7, 0.5];
    let g = Grid::new(&vec![0.0; dim], &max[..dim], 0.1, 0.0, Placement::Vertex).unwrap();
    let mm = Micromodulus {
        kernel,
        normalization: Normalization::Continuum,
        modulus: 3.0,
        plane: Some(PlaneModel::Strain),
        partial_volume: pv,
    };
    let o = BondOperator::on_grid(&g, 0.3, &mm, &Material::default()).unwrap();
    (g, o, mm)
}

fn dense(a: &SparseColMat<usize, f64>) -> Vec<Vec<f64>> {
    let mut m = vec![vec![0.0; a.ncols()]; a.nrows()];
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            m[i][j] += *v;
        }
    }
    m
}

/// Largest |entry| of A, the scale for round-off tolerances.
fn scale(m: &[Vec<f64>]) -> f64 {
    m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()))
}

#[test]
fn assembled_matrix_is_symmetric_with_zero_row_sums_and_rigid_null_space() {
    for dim in 1..=3 {
        for kernel in [Kernel::InverseDistance, Kernel::Tent, Kernel::Constant] {
            let (_, o, _) = op(dim, kernel.clone(), true);
            let n = o.n_dofs();
            let a = dense(&assemble(&o, &DofMap::all_free(o.n_nodes(), dim)));
            let s = scale(&a);
            // Round-off bound: each entry is a sum of at most ~n_bonds terms of size s.
            let tol = 1e3 * f64::EPSILON * s;
            for i in 0..n {
                for j in 0..n {
                    assert!((a[i][j] - a[j][i]).abs() <= tol, "asymmetric at ({i},{j}) dim {dim}");
                }
            }
            // Rigid motions: translations and infinitesimal rotations give zero force.
            let x = o.positions();
            let mut modes: Vec<Vec<f64>> =
                (0..dim).map(|a| (0..n).map(|k| if k % dim == a { 1.0 } else { 0.0 }).collect()).collect();
            if dim >= 2 {
                for (p, q) in [(0usize, 1usize), (1, 2), (0, 2)].into_iter().take(if dim == 2 { 1 } else { 3 }) {
                    let mut m = vec![0.0; n];
                    for (i, xi) in x.iter().enumerate() {
                        m[dim * i + p] = -xi[q];
                        m[dim * i + q] = xi[p];
                    }
                    modes.push(m);
                }
            }
            assert_eq!(modes.len(), [1, 3, 6][dim - 1]);
            for m in &modes {
                let mut y = vec![0.0; n];
                o.apply(m, &mut y);
                let r = y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                assert!(r <= 1e3 * f64::EPSILON * s, "rigid mode not in the null space: {r:e}, dim {dim}");
            }
            // The matrix-free apply equals the assembled matrix.
            let u: Vec<f64> = (0..n).map(|k| ((k * 7919) % 97) as f64 / 97.0 - 0.5).collect();
            let mut y = vec![0.0; n];
            o.apply(&u, &mut y);
            for i in 0..n {
                let ai: f64 = (0..n).map(|j| a[i][j] * u[j]).sum();
                assert!((ai - y[i]).abs() <= 1e3 * f64::EPSILON * s, "apply != assembled");
            }
        }
    }
}

#[test]
fn stencil_apply_equals_bond_apply_on_a_homogeneous_lattice() {
    for dim in 1..=3 {
        let (g, o, mm) = op(dim, Kernel::InverseDistance, true);
        assert_stencil_is_the_operator(&g, &o, &mm, 0.3);
    }
}

/// The stencil's apply against the per-bond operator's on a smooth field: 1e-13 of max |A u|
/// (the two sum the same bonds in different orders).
fn assert_stencil_is_the_operator(g: &Grid, o: &BondOperator, mm: &Micromodulus, horizon: f64) {
    let st = StencilOperator::new(g, horizon, mm).unwrap();
    let n = o.n_dofs();
    let u: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
    let (mut y1, mut y2) = (vec![0.0; n], vec![0.0; n]);
    o.apply(&u, &mut y1);
    st.apply(&u, &mut y2);
    let s = y1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for k in 0..n {
        assert!((y1[k] - y2[k]).abs() <= 1e-13 * s, "dim {} dof {k}: {} vs {}", g.dim(), y1[k], y2[k]);
    }
}

/// Rows longer than the stencil apply's segment (1D bars, long 2D rows) are cut into segments
/// computed apart: the seams must not change the product (1e-13 relative, as above).
#[test]
fn stencil_apply_is_seamless_across_row_segments() {
    for (dim, max) in [(1, vec![299.9]), (2, vec![249.9, 0.9])] {
        let g = Grid::new(&vec![0.0; dim], &max, 0.1, 0.0, Placement::Vertex).unwrap();
        assert!(g.counts()[0] > 2048, "the row must span several segments");
        let mm = Micromodulus {
            kernel: Kernel::InverseDistance,
            normalization: Normalization::Continuum,
            modulus: 3.0,
            plane: Some(PlaneModel::Strain),
            partial_volume: true,
        };
        let o = BondOperator::on_grid(&g, 0.3, &mm, &Material::default()).unwrap();
        assert_stencil_is_the_operator(&g, &o, &mm, 0.3);
    }
}

#[test]
fn stiffness_is_minus_the_jacobian_of_the_pmb_force() {
    // Central differences of the nonlinear PMB force: truncation O(eps^2 |F'''|) and round-off
    // O(macheps |F| / eps); with eps = 1e-6 h both are below 1e-7 relative to max |A|.
    for dim in 2..=3 {
        let (g, o, _) = op(dim, Kernel::InverseDistance, false);
        let n = o.n_dofs();
        let a = dense(&assemble(&o, &DofMap::all_free(o.n_nodes(), dim)));
        let s = scale(&a);
        let eps = 1e-6 * g.spacing();
        // Probe a few columns (full Jacobian is n^2 force evaluations).
        for col in [0, n / 3, n / 2 + 1, n - 1] {
            let mut up = vec![0.0; n];
            let mut um = vec![0.0; n];
            up[col] = eps;
            um[col] = -eps;
            let (fp, fm) = (pmb_force(&o, &up), pmb_force(&o, &um));
            for row in 0..n {
                let jac = (fp[row] - fm[row]) / (2.0 * eps);
                assert!((jac + a[row][col]).abs() <= 1e-7 * s, "dim {dim} ({row},{col}): {jac} vs {}", -a[row][col]);
            }
        }
    }
}

#[test]
fn support_check_finds_floating_pieces() {
    let (g, o, _) = op(2, Kernel::InverseDistance, false);
    let n = o.n_nodes();
    // Nothing constrained: 3 free modes.
    let free = DofMap::all_free(n, 2);
    assert_eq!(check_support(&o, &free).unwrap_err().free_modes, 3);
    // One node pinned: the rotation about it is still free.
    let mut c = vec![false; 2 * n];
    c[0] = true;
    c[1] = true;
    assert_eq!(check_support(&o, &DofMap::new(2, &c)).unwrap_err().free_modes, 1);
    // The left column of nodes pinned: supported.
    for i in 0..n {
        if g.position(i)[0] < 1e-12 {
            c[2 * i] = true;
            c[2 * i + 1] = true;
        }
    }
    assert!(check_support(&o, &DofMap::new(2, &c)).is_ok());
}

/// `StencilOperator::diagonal_block` (one block per boundary class) equals the diagonal block
/// of the block row (`for_each_block`, a sum over the node's own offsets) at every node, exactly
/// (the same terms added in the same order), on boxes with fewer and more sites per axis than
/// the stencil's width, in 2D and 3D.
#[test]
fn diagonal_blocks_by_class_equal_the_block_rows() {
    for (dim, counts, horizon) in [(3, [4.0, 9.0, 12.0], 3.0), (3, [10.0, 10.0, 10.0], 2.0), (2, [5.0, 20.0, 0.0], 3.5)]
    {
        let max: Vec<f64> = counts[..dim].iter().map(|n| n - 1.0).collect();
        let g = Grid::new(&vec![0.0; dim], &max, 1.0, 0.0, Placement::Vertex).unwrap();
        let mm = Micromodulus {
            kernel: Kernel::InverseDistance,
            normalization: Normalization::Discrete,
            modulus: 1.0,
            plane: (dim == 2).then_some(PlaneModel::Stress),
            partial_volume: false,
        };
        let st = StencilOperator::new(&g, horizon, &mm).unwrap();
        let dd = dim * dim;
        for i in 0..g.len() {
            let mut want = vec![0.0; dd];
            st.for_each_block(i, &mut |j, b| {
                if j == i {
                    want.copy_from_slice(&b[..dd]);
                }
            });
            let mut got = [0.0; 9];
            st.diagonal_block(i, &mut got);
            assert_eq!(&got[..dd], &want[..], "{dim}D node {i}");
        }
    }
}
