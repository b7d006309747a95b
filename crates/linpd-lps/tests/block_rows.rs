//! Block rows on demand (`Model::for_each_block`, [`LpsModel::tangent_block_row`]; issue #16)
//! and the closed-form diagonal ([`LpsModel::tangent_diagonal`], issue #35): every block row
//! and the diagonal equal the rows of the assembled tangent ([`assemble_tangent`], the matrix
//! `assemble_free` restricts) and of the matrix-free apply, on lattices in 2D and 3D with
//! defects (a cut and a weakened bond set), per-node (cut-cell) volumes, every surface
//! correction, and on a jittered point cloud with a cut.
//!
//! Tolerance `1e-13 max|A|`: an entry is a sum of up to `2 |F|^2` terms (`|F|` <= 32 partners
//! here) that the block row adds in column `i` and the assembly in column `j` (the same
//! products, another order and the transposed factor order), so they may differ by about
//! `|F|^2 eps max|term|`; `max|term|` is within a few `max|A|`. Measured: 1.8e-15 on the
//! lattices, 1.2e-15 on the clouds (printed by the tests). A wrong term, partner or
//! transposition changes an entry by O(max|A|) (a transposed block: 0.13 max|A|; the dilatation
//! and pair parts are of the same order here, `K = 2`, `G = 0.5`). The apply check sums the
//! block row against a random `u` and compares with the factored apply: `|F|` more terms per
//! entry, same bound relative to `max|A u|`.

mod common;
use common::{random_vec, H};
use linpd_core::{Defect, Grid, Model, Placement, Region};
use linpd_lps::{assemble_tangent, Influence, LpsModel, LpsParams, PlaneModel, SurfaceCorrection};
use std::collections::BTreeMap;

const RTOL: f64 = 1e-13;

fn variants() -> Vec<(usize, usize, LpsParams)> {
    let p = common::params;
    vec![
        (3, 5, p(2.0, Influence::InverseDistance, true, None)),
        (2, 8, p(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain))),
        (2, 8, p(3.0, Influence::Constant, false, Some(PlaneModel::Stress))),
    ]
}

/// A cut (factor 0) across half the body between lattice planes and a weakened plane (0.3).
fn defects(dim: usize, max: &[f64], nodes: usize) -> Vec<Defect> {
    let mid = ((nodes - 1) / 2) as f64 * H + 0.5 * H;
    if dim == 2 {
        vec![
            Defect::Segment { a: [mid, -1.0], b: [mid, 0.45 * max[1]], factor: 0.0 },
            Defect::Segment { a: [-1.0, mid - 0.02], b: [0.45 * max[0], mid - 0.02], factor: 0.3 },
        ]
    } else {
        vec![
            Defect::Plane {
                point: [mid, 0.0, 0.0],
                normal: [1.0, 0.0, 0.0],
                extent: Some(Region::Box { min: vec![-1.0; 3], max: vec![9.0, 0.2, 9.0] }),
                factor: 0.0,
            },
            Defect::Plane { point: [0.0, mid - 0.02, 0.0], normal: [0.0, 1.0, 0.0], extent: None, factor: 0.3 },
        ]
    }
}

/// Compares every block row of `m` with the assembled tangent and the apply; returns the
/// largest difference relative to `max|A|`.
fn check(m: &LpsModel, what: &str) -> f64 {
    let d = m.dim();
    let a = assemble_tangent(m);
    let (cp, ri, val) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    let scale = val.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    // the assembled rows: (row, col) -> value, nonzeros only (the lattice pattern keeps
    // structural zeros that the block rows leave out)
    let mut rows: Vec<BTreeMap<usize, f64>> = vec![BTreeMap::new(); a.nrows()];
    for c in 0..a.ncols() {
        for p in cp[c]..cp[c + 1] {
            if val[p] != 0.0 {
                rows[ri[p]].insert(c, val[p]);
            }
        }
    }
    let u = random_vec(a.nrows(), 11);
    let mut y = vec![0.0; a.nrows()];
    m.apply(&u, &mut y);
    let y_scale = y.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let mut worst = 0.0f64;
    let mut worst_apply = 0.0f64;
    for i in 0..m.n_nodes() {
        let mut seen = Vec::new();
        let mut got: Vec<BTreeMap<usize, f64>> = vec![BTreeMap::new(); d];
        assert!(Model::for_each_block(m, i, &mut |j, b| {
            assert_eq!(b.len(), d * d);
            seen.push(j);
            for r in 0..d {
                for c in 0..d {
                    got[r].insert(d * j + c, b[r * d + c]);
                }
            }
        }));
        let n_seen = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), n_seen, "{what}: node {i}: a partner twice");
        assert!(seen.binary_search(&i).is_ok(), "{what}: node {i}: no diagonal block");
        for r in 0..d {
            let want = &rows[d * i + r];
            // every assembled nonzero is offered, and every offered entry matches (0 if absent)
            for col in want.keys() {
                assert!(got[r].contains_key(col), "{what}: row {} misses column {col}", d * i + r);
            }
            for (col, v) in &got[r] {
                worst = worst.max((v - want.get(col).copied().unwrap_or(0.0)).abs() / scale);
            }
            let yi: f64 = got[r].iter().map(|(col, v)| v * u[*col]).sum();
            worst_apply = worst_apply.max((yi - y[d * i + r]).abs() / y_scale);
        }
    }
    // the closed-form diagonal against the assembled one
    let diag = Model::diagonal(m);
    let want = linpd_core::sparse::diagonal(&a);
    let worst_diag = diag.iter().zip(&want).fold(0.0f64, |w, (x, y)| w.max((x - y).abs() / scale));
    assert!(worst_diag <= RTOL, "{what}: the diagonal differs from the assembled one by {worst_diag:e} max|A|");
    assert!(worst <= RTOL, "{what}: block rows differ from the assembled tangent by {worst:e} max|A|");
    assert!(worst_apply <= RTOL, "{what}: block rows times u differ from the apply by {worst_apply:e} max|A u|");
    worst.max(worst_apply).max(worst_diag)
}

#[test]
fn block_rows_equal_the_assembled_tangent_on_lattices() {
    let mut worst = 0.0f64;
    for (dim, nodes, p) in variants() {
        let max = vec![(nodes - 1) as f64 * H; dim];
        let g = Grid::new(&vec![0.0; dim], &max, H, 0.0, Placement::Vertex).unwrap();
        for s in [
            SurfaceCorrection::None,
            SurfaceCorrection::BulkWeightedVolume,
            SurfaceCorrection::Energy,
            SurfaceCorrection::PositionAware,
        ] {
            let plain = LpsModel::new(&g, &p).unwrap().with_surface_correction(s);
            worst = worst.max(check(&plain, &format!("{dim}D {s:?}")));
            let cracked =
                LpsModel::with_defects(&g, &p, &defects(dim, &max, nodes)).unwrap().with_surface_correction(s);
            worst = worst.max(check(&cracked, &format!("{dim}D {s:?} with defects")));
        }
        // per-node volumes: a body with a hole and cut-cell volumes
        let c = 0.5 * max[0];
        let inside = |x: &linpd_core::Point| (0..dim).map(|a| (x[a] - c).powi(2)).sum::<f64>() >= (0.17f64).powi(2);
        let cut = g.with_body(inside).unwrap().with_cut_volumes(inside);
        worst = worst.max(check(&LpsModel::new(&cut, &p).unwrap(), &format!("{dim}D cut cells")));
    }
    eprintln!("lattices: worst block-row difference {worst:.2e} max|A|");
}

#[test]
fn block_rows_equal_the_assembled_tangent_on_a_point_cloud() {
    let mut worst = 0.0f64;
    for (dim, nodes, p) in variants() {
        let max = vec![(nodes - 1) as f64 * H; dim];
        let g = Grid::new(&vec![0.0; dim], &max, H, 0.0, Placement::Vertex).unwrap();
        let jitter = random_vec(3 * g.len(), 17);
        let scale = random_vec(g.len(), 23);
        let positions: Vec<[f64; 3]> = g
            .positions()
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let mut y = *x;
                (0..dim).for_each(|a| y[a] += 0.2 * H * jitter[3 * i + a]);
                y
            })
            .collect();
        let volumes: Vec<f64> = scale.iter().map(|s| g.volume() * (1.0 + 0.2 * s)).collect();
        let m = LpsModel::on_points(dim, positions, &volumes, &p, &defects(dim, &max, nodes)).unwrap();
        worst = worst.max(check(&m, &format!("{dim}D cloud")));
    }
    eprintln!("point clouds: worst block-row difference {worst:.2e} max|A|");
}
