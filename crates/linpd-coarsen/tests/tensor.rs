//! 2D/3D tensor coarsening of bond-based operators and of the LPS tangent: static condensation,
//! the force property (9), the neighbourhood cache, dense vs sparse local solves, the radius
//! rule and the errors of singular local problems.
#![allow(clippy::needless_range_loop)]

mod common;
use common::solve_dirichlet;
use linpd_bond::{assemble, BondOperator};
use linpd_coarsen::{coarsen, coarsen_with, local_resolvent, retain_every, CoarsenError, LevelModel, Options, Radius};
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};
use linpd_lps::{assemble_tangent, Influence, LpsModel, LpsParams};

const H: f64 = 0.1;

fn grid(dim: usize, n: usize) -> Grid {
    Grid::new(&vec![0.0; dim], &vec![(n - 1) as f64 * H; dim], H, 0.0, Placement::Vertex).unwrap()
}

/// Bond-based level 0 on an `n^dim` lattice, horizon `m h`.
fn bond_level(dim: usize, n: usize, m: f64) -> LevelModel {
    let g = grid(dim, n);
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Continuum,
        modulus: 1.0,
        plane: (dim == 2).then_some(PlaneModel::Stress),
        partial_volume: false,
    };
    let op = BondOperator::on_grid(&g, m * H, &mm, &Material::default()).unwrap();
    let k = assemble(&op, &DofMap::all_free(g.len(), dim));
    LevelModel::from_stiffness(dim, g.positions(), vec![g.volume(); g.len()], &k).unwrap()
}

/// LPS tangent level 0 (plane strain in 2D), horizon `m h`.
fn lps_level(dim: usize, n: usize, m: f64) -> LevelModel {
    let g = grid(dim, n);
    let p = LpsParams {
        K: 2.0,
        G: 0.5,
        horizon: m * H,
        influence: Influence::InverseDistance,
        partial_volume: false,
        plane: (dim == 2).then_some(PlaneModel::Strain),
    };
    let model = LpsModel::new(&g, &p).unwrap();
    let k = assemble_tangent(&model);
    LevelModel::from_stiffness(dim, g.positions(), vec![g.volume(); g.len()], &k).unwrap()
}

fn random(n: usize, mut s: u64) -> Vec<f64> {
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
        .collect()
}

/// Fixes every DOF of the shared nodes with x = 0, pulls the shared nodes with x = max; solves
/// at level 0 and at the coarse level with the same nodal forces; returns max |u^1 - u^0| /
/// max |u^0| at the shared nodes.
fn condensation_error(fine: &LevelModel, c: &linpd_coarsen::Coarsened) -> f64 {
    let d = fine.dim();
    let xmax = fine.positions().iter().map(|p| p[0]).fold(0.0, f64::max);
    let coarse = &c.model;
    let mut fixed_f = Vec::new();
    let mut fixed_c = Vec::new();
    let mut f0 = vec![0.0; d * fine.len()];
    let mut f1 = vec![0.0; d * coarse.len()];
    for (k, &p) in c.parent.iter().enumerate() {
        let x = fine.positions()[p];
        if x[0] < 1e-12 {
            for a in 0..d {
                fixed_f.push((d * p + a, 0.0));
                fixed_c.push((d * k + a, 0.0));
            }
        } else if (x[0] - xmax).abs() < 1e-12 {
            for a in 0..d {
                let load = if a == 0 { 1.0 } else { 0.3 };
                f0[d * p + a] = load;
                f1[d * k + a] = load;
            }
        }
    }
    let u0 = solve_dirichlet(fine, &f0, &fixed_f).unwrap();
    let u1 = solve_dirichlet(coarse, &f1, &fixed_c).unwrap();
    let umax = u0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut err: f64 = 0.0;
    for (k, &p) in c.parent.iter().enumerate() {
        for a in 0..d {
            err = err.max((u1[d * k + a] - u0[d * p + a]).abs());
        }
    }
    err / umax
}

#[test]
fn whole_body_neighbourhood_is_static_condensation_2d_3d_bond_and_lps() {
    // N_x = the whole body: coarsening is exact static condensation. Tolerance 1e-9: the
    // fine systems have condition numbers ~1e5-1e6 (eps * cond ~ 1e-10).
    let cases: Vec<(&str, LevelModel)> = vec![
        ("2D bond 13x13, delta = 2h", bond_level(2, 13, 2.0)),
        ("3D bond 9^3, delta = 1.5h", bond_level(3, 9, 1.5)),
        ("2D LPS 13x13, delta = 2h", lps_level(2, 13, 2.0)),
    ];
    for (name, m0) in &cases {
        let c1 = coarsen(m0, &retain_every(m0, 2).unwrap(), 100.0).unwrap();
        let e1 = condensation_error(m0, &c1);
        let c2 = coarsen(&c1.model, &retain_every(&c1.model, 2).unwrap(), 100.0).unwrap();
        // level 2 vs level 0: compose the parent maps
        let composed = linpd_coarsen::Coarsened {
            model: c2.model.clone(),
            parent: c2.parent.iter().map(|&p| c1.parent[p]).collect(),
            report: c2.report.clone(),
            transfer: c2.transfer.clone(),
        };
        let e2 = condensation_error(m0, &composed);
        println!(
            "{name}: {} -> {} -> {} nodes; rel. error at shared nodes level 1 = {e1:.2e}, level 2 = {e2:.2e}; asymmetry C1 = {:.1e}, C2 = {:.1e}",
            m0.len(),
            c1.model.len(),
            c2.model.len(),
            c1.report.asymmetry,
            c2.report.asymmetry
        );
        assert!(e1 < 1e-9 && e2 < 1e-9, "{name}");
        assert!(c1.report.asymmetry < 1e-10 && c2.report.asymmetry < 1e-10, "{name}");
        assert_eq!(c1.report.tail, 0.0);
    }
}

/// Property (9) with a finite radius: for random level-m displacements and the excluded nodes of
/// N_x in equilibrium (u^{m-1} = S u^m from the full resolvent (14), an independent path from
/// the transposed solve used by `coarsen`), the level-(m-1) nodal force at x equals the level-m
/// one. Returns the worst mismatch relative to the sum of |bond force terms|.
fn property_9(fine: &LevelModel, radius: f64) -> f64 {
    let d = fine.dim();
    let ret = retain_every(fine, 2).unwrap();
    let c = coarsen(fine, &ret, radius).unwrap();
    let um = random(d * c.model.len(), 17);
    let mut is_ret = vec![false; fine.len()];
    let mut cidx = vec![usize::MAX; fine.len()];
    for (k, &p) in c.parent.iter().enumerate() {
        is_ret[p] = true;
        cidx[p] = k;
    }
    let mut worst: f64 = 0.0;
    for (k, &xi) in c.parent.iter().enumerate().step_by(3) {
        let loc = local_resolvent(fine, &is_ret, xi, radius).unwrap();
        let mut u0 = vec![0.0; d * fine.len()];
        for (l, &p) in loc.nodes.iter().enumerate() {
            for a in 0..d {
                let mut s = 0.0;
                for (lq, &q) in loc.nodes[..loc.n_retained].iter().enumerate() {
                    for b in 0..d {
                        s += loc.s[(d * l + a, d * lq + b)] * um[d * cidx[q] + b];
                    }
                }
                u0[d * p + a] = s;
            }
        }
        let f_fine: Vec<f64> = fine.force_density_at(xi, &u0).iter().map(|t| t * fine.volumes()[xi]).collect();
        let f_coarse: Vec<f64> = c.model.force_density_at(k, &um).iter().map(|t| t * c.model.volumes()[k]).collect();
        let scale: f64 = fine
            .partners(xi)
            .iter()
            .zip(fine.blocks(xi).chunks(d * d))
            .map(|(&p, b)| {
                (0..d * d).map(|e| (b[e] * (u0[d * p + e % d] - u0[d * xi + e % d])).abs()).sum::<f64>()
                    * fine.volumes()[p]
            })
            .sum::<f64>()
            * fine.volumes()[xi];
        for a in 0..d {
            worst = worst.max((f_fine[a] - f_coarse[a]).abs() / scale);
        }
    }
    worst
}

#[test]
fn force_property_eq9_finite_radius_2d_3d_lps() {
    // Tolerance 1e-11: two different solves of local systems with condition ~1e3-1e4.
    for (name, m0, r) in [
        ("2D bond 15x15 delta=2h, r=4h", bond_level(2, 15, 2.0), 4.0 * H),
        ("3D bond 7^3 delta=1.5h, r=3h", bond_level(3, 7, 1.5), 3.0 * H),
        ("2D LPS 13x13 delta=2h, r=4h", lps_level(2, 13, 2.0), 4.0 * H),
    ] {
        let e = property_9(&m0, r);
        println!("{name}: property (9) max rel. mismatch = {e:.2e}");
        assert!(e < 1e-11, "{name}: {e}");
    }
}

#[test]
fn cache_and_sparse_local_solves_reproduce_the_uncached_dense_rows() {
    let m0 = bond_level(2, 31, 2.0);
    let ret = retain_every(&m0, 2).unwrap();
    let r = 4.0 * H;
    let base = Options::fixed(r);
    let cached = coarsen_with(&m0, &ret, &base).unwrap();
    let plain = coarsen_with(&m0, &ret, &Options { cache: false, ..base }).unwrap();
    let sparse = coarsen_with(&m0, &ret, &Options { dense_limit: 0, ..base }).unwrap();
    let diff = |a: &LevelModel, b: &LevelModel| {
        let (oa, ca, va) = a.csr();
        let (ob, cb, vb) = b.csr();
        assert_eq!((oa, ca), (ob, cb), "same sparsity");
        va.iter().zip(vb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / a.max_abs()
    };
    let (dc, ds) = (diff(&cached.model, &plain.model), diff(&sparse.model, &plain.model));
    let rep = &cached.report;
    println!(
        "2D 31x31, every 2nd, r = 4h: {} retained nodes, {} classes, hit rate {:.3}; cached vs uncached {dc:.1e}, sparse vs dense {ds:.1e}; uncached classes {}",
        rep.n_coarse, rep.classes, rep.hit_rate, plain.report.classes
    );
    // nodes at least r from every edge share one class: 12 x 12 of the 16 x 16 retained nodes
    assert!(rep.classes <= 256 - 143, "classes {}", rep.classes);
    assert_eq!(plain.report.classes, rep.n_coarse);
    // cached rows come from a translated copy of the same data (quantum 1e-12): ~eps * cond
    assert!(dc < 1e-12 && ds < 1e-12, "{dc} {ds}");
    assert_eq!(sparse.report.dense_solves, 0);
}

#[test]
fn radius_rule_stops_at_the_tolerance_and_reports_the_tail() {
    let m0 = bond_level(2, 41, 2.0);
    let ret = retain_every(&m0, 2).unwrap();
    let tol = 1e-3;
    let opts = Options { radius: Radius::Auto { tol, start: None, growth: 1.25, max: None }, ..Options::fixed(1.0) };
    let c = coarsen_with(&m0, &ret, &opts).unwrap();
    println!(
        "2D 41x41 delta = 2h, tol {tol:.0e}: tried (r/h, tail) = {:?}",
        c.report.tried.iter().map(|(r, t)| (r / H, *t)).collect::<Vec<_>>()
    );
    let tried = &c.report.tried;
    assert!(c.report.tail <= tol);
    assert!((tried[0].0 - 4.0 * H).abs() < 1e-12, "starts at 2 delta");
    assert!(tried[..tried.len() - 1].iter().all(|t| t.1 > tol), "stops at the first radius below tol");
    assert!(tried.windows(2).all(|w| w[1].0 > w[0].0));
    // a tolerance that cannot be met below the maximum radius is an error, not a silent result
    let strict = Options { radius: Radius::Auto { tol: 1e-14, start: None, growth: 1.5, max: Some(6.0 * H) }, ..opts };
    let e = coarsen_with(&m0, &ret, &strict).unwrap_err();
    println!("{e}");
    assert!(matches!(e, CoarsenError::TailNotReached { .. }));
}

#[test]
fn a_mechanism_in_a_local_problem_is_named() {
    // node z keeps only bonds along x: it has no stiffness in y, so (13) is singular for every
    // retained node whose N_x contains it
    let m0 = bond_level(2, 9, 2.0);
    let z = 9 + 1; // lattice (1, 1): excluded by every-2nd
    let (d, x) = (2, m0.positions().to_vec());
    let mut offsets = vec![0];
    let (mut cols, mut vals) = (Vec::new(), Vec::new());
    for i in 0..m0.len() {
        for (&j, b) in m0.partners(i).iter().zip(m0.blocks(i).chunks(d * d)) {
            let touches = i == z || j == z;
            if touches && (x[i][1] - x[j][1]).abs() > 1e-12 {
                continue;
            }
            cols.push(j);
            vals.extend_from_slice(b);
        }
        offsets.push(cols.len());
    }
    let m = LevelModel::from_csr(d, x, m0.volumes().to_vec(), (0..m0.len()).collect(), offsets, cols, vals).unwrap();
    let e = coarsen(&m, &retain_every(&m, 2).unwrap(), 4.0 * H).unwrap_err();
    println!("{e}");
    match &e {
        CoarsenError::SingularLocal { excluded, reason, .. } => {
            assert_eq!(*excluded, z);
            assert!(reason.contains("not held in every direction"), "{reason}");
        }
        other => panic!("unexpected {other:?}"),
    }
}
