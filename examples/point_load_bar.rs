//! A 1D peridynamic bar under a point load, solved from Rust instead of a scene file, and
//! checked against two things a reader can verify by hand.
//!
//! Setting: Seleson, Beneddine & Prudhomme (2013), Table 3: bar (0, 1), K = 1, horizon
//! eps = 0.05, dx = 1/300 (N = 15 neighbours per side), unit point load at x = 0.5, u = 0 on
//! nonlocal layers of width eps at both ends.
//!
//! 1. **Force balance.** The reactions at the constrained layer nodes, `R = A u - f` there,
//!    must cancel the applied load: `sum R + F = 0`, to round-off.
//! 2. **Classical limit away from the load.** Classical elasticity with the same load gives the
//!    tent `u = x / 2` on the left half (K u'' = -F delta(x - 1/2), u(0) = u(1) = 0). The
//!    nonlocal solution differs near the load (a spike of width ~eps) and near the layers; at
//!    the quarter points, several horizons from both, it must agree with the tent to a few
//!    percent of the peak.
//!
//! Run: `cargo run --release --example point_load_bar`.

use linpd::bond::{assemble, BondOperator};
use linpd::core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, Region};
use linpd::solve::{solve_assembled, MatrixHints, SolverSpec};

fn main() {
    let h = 1.0 / 300.0;
    let eps = 0.05;
    let grid = Grid::new(&[0.0], &[1.0], h, eps, Placement::Vertex).expect("grid");
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete, // c = 2K / (N (N + 1) dx^2), eq. (19)
        modulus: 1.0,
        plane: None,
        partial_volume: false,
    };
    let op = BondOperator::on_grid(&grid, eps, &mm, &Material::default()).expect("operator");

    // Constrain both layers (the nodes outside (0, 1), plus the end nodes themselves).
    let layers = Region::Union(vec![
        Region::Box { min: vec![-1.0], max: vec![0.0] },
        Region::Box { min: vec![1.0], max: vec![2.0] },
    ]);
    let mut constrained = vec![false; grid.len()];
    for n in layers.nodes(&grid) {
        constrained[n] = true;
    }
    let dofs = DofMap::new(1, &constrained);

    // Unit point load at the node at x = 0.5 (a force, so b_p dx = 1 as in section 5.2).
    let (p, _) = grid.nearest_node(&[0.5]);
    let mut f_full = vec![0.0; grid.len()];
    f_full[p] = 1.0;

    let a = assemble(&op, &dofs);
    let (u_free, report) =
        solve_assembled(&a, &dofs.gather(&f_full), &SolverSpec::Cholesky, &MatrixHints::symmetric(1)).expect("solve");
    let mut u = vec![0.0; grid.len()];
    dofs.scatter(&u_free, &mut u);
    println!("solved {} unknowns with {}: relative residual {:.2e}", report.n, report.solver, report.rel_residual);

    // 1. Force balance: reactions at the constrained nodes cancel the load.
    let mut au = vec![0.0; grid.len()];
    op.apply(&u, &mut au);
    let reactions: f64 = (0..grid.len()).filter(|&n| constrained[n]).map(|n| au[n] - f_full[n]).sum();
    println!("sum of reactions = {reactions:.15}  (load = 1)");
    // The residual of the free equations is ~1e-14; the reactions inherit it: 1e-10 is ample.
    assert!((reactions + 1.0).abs() < 1e-10, "force balance violated: {reactions}");

    // 2. Classical limit at the quarter points.
    let peak = u.iter().cloned().fold(0.0, f64::max);
    for x in [0.25, 0.75] {
        let (n, _) = grid.nearest_node(&[x]);
        let classical = 0.5 * x.min(1.0 - x);
        let diff = (u[n] - classical).abs();
        println!(
            "u({x}) = {:.6}, classical {classical:.6}, difference {:.2e} ({:.2}% of the peak {peak:.4})",
            u[n],
            diff,
            100.0 * diff / peak
        );
        assert!(diff < 0.05 * peak, "nonlocal and classical solutions differ by {diff} at x = {x}");
    }
}
