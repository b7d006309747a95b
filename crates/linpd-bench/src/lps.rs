//! `linpd bench --lps`: the linearized LPS tangent on 3D cubes with `delta = 3h`, against the
//! bond-based operator of the same grid, and against a finite-difference tangent (the method
//! Peridigm uses by default) where that is affordable.
//!
//! The LPS tangent couples nodes up to `2 delta` apart: ~925 neighbours per node at `delta = 3h`
//! versus 122 for bonds, so 40^3 assembled would hold ~5e8 entries (~8.5 GB). That case runs
//! matrix-free (factored apply) only.

use linpd_bond::BondOperator;
use linpd_core::FnOperator;
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_lps::{assemble_tangent, Influence, LpsModel, LpsParams};
use linpd_solve::{diagonal, pcg, peak_rss_bytes, CgParams, Identity, Jacobi, ReducedOperator, SymCsc};
use serde_json::{json, Value};
use std::time::Instant;

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The static problem of every case: bottom three planes clamped, a downward force on each
/// node of the top plane. Returns the DOF map and the full force vector.
fn clamped_cube(grid: &Grid, nodes: usize) -> (DofMap, Vec<f64>) {
    let n = 3 * grid.len();
    let mut mask = vec![false; n];
    let mut f = vec![0.0; n];
    for node in 0..grid.len() {
        let k = grid.lattice_index(node);
        if k[2] < 3 {
            (0..3).for_each(|c| mask[3 * node + c] = true);
        }
        if k[2] == nodes as i64 - 1 {
            f[3 * node + 2] = -1e-3;
        }
    }
    (DofMap::new(3, &mask), f)
}

/// Runs the LPS cases; `quick` shrinks them.
pub fn run(quick: bool) -> Value {
    let sizes: &[(usize, bool)] =
        if quick { &[(6, true), (8, false)] } else { &[(10, true), (20, true), (30, true), (40, false)] };
    let mut out = serde_json::Map::new();
    for &(nodes, assembled) in sizes {
        reset_peak_rss();
        let name = format!("lps-3d-{nodes}");
        eprintln!("[bench] {name}");
        let h = 1.0;
        let last = (nodes - 1) as f64 * h;
        let grid = Grid::new(&[0.0; 3], &[last; 3], h, 0.0, Placement::Vertex).expect("grid");
        let params = LpsParams {
            K: 2.0,
            G: 0.5,
            horizon: 3.0 * h,
            influence: Influence::InverseDistance,
            partial_volume: false,
            plane: None,
        };
        let t = Instant::now();
        let model = LpsModel::new(&grid, &params).expect("model");
        let t_model = secs(t);
        // The bond-based operator of the same grid, for the nnz and apply comparisons.
        let mm = Micromodulus {
            kernel: Kernel::InverseDistance,
            normalization: Normalization::Discrete,
            modulus: 2.0,
            plane: None,
            partial_volume: false,
        };
        let bond = BondOperator::on_grid(&grid, 3.0 * h, &mm, &Material::default()).expect("bond");
        let bond_nnz = bond.family().n_bonds() * 9 + grid.len() * 9;
        let n = 3 * grid.len();
        let x: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
        let mut y = vec![0.0; n];
        let t = Instant::now();
        let reps = 3;
        for _ in 0..reps {
            model.apply_tangent(&x, &mut y);
        }
        let t_apply = secs(t) / reps as f64;
        let t = Instant::now();
        for _ in 0..reps {
            bond.apply(&x, &mut y);
        }
        let t_bond_apply = secs(t) / reps as f64;
        let mut case = json!({"nodes": grid.len(), "dofs": n, "time_model": t_model, "apply_matrix_free": t_apply,
            "bond_apply_matrix_free": t_bond_apply, "bond_nnz": bond_nnz});
        if assembled {
            let t = Instant::now();
            let a = assemble_tangent(&model);
            let t_asm = secs(t);
            case["time_assembly"] = json!(t_asm);
            case["nnz"] = json!(a.val().len());
            case["nnz_ratio_to_bond"] = json!(a.val().len() as f64 / bond_nnz as f64);
            if nodes <= 10 {
                // Finite-difference tangent (central differences column by column, local
                // neighbourhoods only), the method Peridigm uses by default.
                let t = Instant::now();
                let fd = linpd_lps::fd_tangent(&model, 1e-6 * h);
                let t_fd = secs(t);
                let diff = fd.val().iter().zip(a.val()).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
                let scale = a.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
                case["fd_tangent"] =
                    json!({"time": t_fd, "ratio_to_analytic": t_fd / t_asm, "max_rel_difference": diff / scale});
            }
            let (dofs, f) = clamped_cube(&grid, nodes);
            let ar = linpd_problem::reduce_to_free(&a, &dofs);
            drop(a);
            let fr = dofs.gather(&f);
            let mut u = vec![0.0; fr.len()];
            let t = Instant::now();
            let info = Jacobi::new(&diagonal(&ar))
                .and_then(|m| pcg(&SymCsc(&ar), &m, &fr, &mut u, &CgParams { rtol: 1e-8, max_iter: 20_000 }));
            let t_cg = secs(t);
            case["cg"] = match info {
                Ok(i) => json!({"time": t_cg, "iterations": i.iterations, "rel_residual": i.rel_residual}),
                Err(e) => json!({"error": e.to_string()}),
            };
        } else {
            case["assembled"] = json!(format!("skipped: ~{} stored entries", 3 * grid.len() * 3 * 925));
            // Matrix-free CG in factored form. Unpreconditioned: the Jacobi diagonal would need
            // the assembled tangent (on a homogeneous lattice it is constant away from the
            // surface, so Jacobi would change little).
            let (dofs, f) = clamped_cube(&grid, nodes);
            let fr = dofs.gather(&f);
            let full = FnOperator { n: dofs.n_dofs(), apply: |x: &[f64], y: &mut [f64]| model.apply_tangent(x, y) };
            let op = ReducedOperator::new(&full, &dofs);
            let mut u = vec![0.0; fr.len()];
            let t = Instant::now();
            let info = pcg(&op, &Identity, &fr, &mut u, &CgParams { rtol: 1e-8, max_iter: 5_000 });
            let t_cg = secs(t);
            case["cg_matrix_free_unpreconditioned"] = match info {
                Ok(i) => json!({"time": t_cg, "iterations": i.iterations, "rel_residual": i.rel_residual}),
                Err(e) => json!({"error": e.to_string(), "time": t_cg}),
            };
        }
        case["peak_rss_bytes"] = json!(peak_rss_bytes());
        eprintln!("[bench] {name}: {case}");
        out.insert(name, case);
    }
    Value::Object(out)
}
