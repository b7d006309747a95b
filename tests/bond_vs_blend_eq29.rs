//! Two implementations of the 1D nonlocal springs of Seleson, Beneddine & Prudhomme (2013),
//! eq. (29), `(L u)_i = sum_{j in F_i} C_ij (u_j - u_i) V_j`, with the discrete inverse-distance
//! kernel (`C = c / |xi|`, `c` set so the lattice sum reproduces `K`, eq. (19)):
//!
//! * linpd-bond: [`BondOperator`] on a 1D lattice; its stiffness is `A = -V_i L` (the force,
//!   not the force density: crates/linpd-bond/src/lib.rs);
//! * linpd-blend: the pure-PD model ([`ModelKind::PurePd`], `beta = 1` at every node), whose
//!   rows are in force form too: `A u = f` with each row multiplied by the node's dual length.
//!
//! Away from the boundary (full families on both sides) the rows must agree entry by entry once
//! each is divided by its own node volume, i.e. as rows of `-L`. Tolerance 1e-12 relative to the
//! row's diagonal: every entry is a handful of roundings in each code path (the amplitude `c` is
//! a sum of `N` terms, then `c g(xi) dx dx`), so the two agree to ~`N eps` = 3e-15 for `N = 15`;
//! 1e-12 keeps a wide margin while any modelling difference (a factor `dx`, `V_i`, 2, the
//! kernel or its normalization) is O(1) or O(dx).

use linpd::blend::{BlendOperator, BlendParams, Blending, ModelKind, Regions};
use linpd::bond::{assemble, BondOperator};
use linpd::core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement};

const TOL: f64 = 1e-12;

/// Compares both operators for spacing `dx`, `N = eps / dx` neighbours per side and modulus `k`.
fn check(dx: f64, n_side: usize, k: f64) {
    let eps = n_side as f64 * dx;
    let mut p = BlendParams::table3(Blending::Cubic);
    p.dx = dx;
    p.horizon = eps;
    p.modulus = k;
    p.kernel = Kernel::InverseDistance;
    // Regions only shape beta in the blended model; PurePd sets beta = 1 everywhere.
    p.regions = Regions { l1: 0.2, l2: 0.3, l3: 0.7, l4: 0.8 };
    let blend = BlendOperator::assemble(&p, ModelKind::PurePd).unwrap();
    assert!(blend.beta.iter().all(|&b| b == 1.0), "pure PD is beta = 1 at every node");
    assert_eq!(blend.n_side, n_side);

    // The same nodes for linpd-bond: the blend PD mesh includes its nonlocal boundary layer.
    let (x0, x1) = (blend.mesh.x[0], *blend.mesh.x.last().unwrap());
    let grid = Grid::new(&[x0], &[x1], dx, 0.0, Placement::Vertex).unwrap();
    assert_eq!(grid.len(), blend.len());
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: k,
        plane: None,
        partial_volume: false,
    };
    let op = BondOperator::on_grid(&grid, eps, &mm, &Material::default()).unwrap();
    let a = assemble(&op, &DofMap::new(1, &vec![false; grid.len()]));
    let v = grid.volume();
    assert!((v - dx).abs() <= 1e-15 * dx, "1D node volume is dx");
    // Full CSC (both triangles): column j of the symmetric A is row j.
    let bond_row = |i: usize| -> Vec<(usize, f64)> {
        let s = a.symbolic();
        let range = s.col_ptr()[i]..s.col_ptr()[i + 1];
        s.row_idx()[range.clone()].iter().copied().zip(a.val()[range].iter().copied()).collect()
    };

    let n = blend.len();
    let mut compared = 0;
    for i in n_side..n - n_side {
        assert!((grid.positions()[i][0] - blend.mesh.x[i]).abs() < 1e-12, "node {i} positions differ");
        let vb = blend.mesh.dual_length(i);
        let row = bond_row(i);
        let diag = row.iter().find(|e| e.0 == i).unwrap().1 / v;
        assert!(diag > 0.0);
        // Same stencil: i and its N neighbours per side, nothing else.
        let cols: Vec<usize> = row.iter().map(|e| e.0).collect();
        assert_eq!(cols, (i - n_side..=i + n_side).collect::<Vec<_>>(), "bond row {i}");
        let blend_cols = &blend.col[blend.row_ptr[i]..blend.row_ptr[i + 1]];
        assert!(blend_cols.iter().all(|&j| j.abs_diff(i) <= n_side), "blend row {i} reaches past the horizon");
        for (j, aij) in row {
            let (lb, lp) = (aij / v, blend.get(i, j) / vb);
            assert!((lb - lp).abs() <= TOL * diag, "row {i}, column {j}: bond {lb:e} vs blend {lp:e}");
        }
        // eq. (19): the discrete normalization reproduces K, so L applied to the quadratic
        // u = (x - x_i)^2 / 2 (centred: u_j - u_i = xi^2 / 2, no cancellation) is K at x_i.
        let lu: f64 =
            (i - n_side..=i + n_side).map(|j| -blend.get(i, j) / vb * 0.5 * ((j as f64 - i as f64) * dx).powi(2)).sum();
        assert!((lu - k).abs() <= TOL * k, "row {i}: L((x - x_i)^2 / 2) = {lu} != K = {k}");
        compared += 1;
    }
    assert!(compared > n / 2, "only {compared} of {n} rows compared");
}

#[test]
fn bond_operator_and_blend_pure_pd_rows_are_eq_29() {
    // Table 3 (dx = 1/300, eps = 0.05, N = 15, K = 1), and a coarser lattice with K != 1 so that
    // a missing modulus or volume factor cannot cancel.
    check(1.0 / 300.0, 15, 1.0);
    check(0.0125, 4, 2.5);
}
