//! The 2D/3D blended model (`linpd_blend::lattice`): PD rows where `beta = 1`, exactness for
//! affine fields everywhere (patch test) and for quadratic fields on full-family rows,
//! symmetry of the local zone and asymmetry of transitions, and the named errors.

use linpd_blend::BlendError;
use linpd_blend::{beta_from_zone, LatticeBlend, Profile};
use linpd_bond::BondOperator;
use linpd_core::sparse::Csc;
use linpd_core::{Defect, DofMap, Grid, Kernel, Material, Micromodulus, Model, Normalization, Placement, PlaneModel};
use linpd_solve::{solve_model, Dirichlet, SolverSpec};

fn micromodulus() -> Micromodulus {
    Micromodulus {
        kernel: Kernel::Constant,
        normalization: Normalization::Continuum,
        modulus: 2.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: true,
    }
}

/// A box of `n` nodes a side (`n/2` along z in 3D), `h = 1/n`, horizon `3h`.
fn setting(dim: usize, n: usize) -> (Grid, BondOperator, f64) {
    let h = 1.0 / n as f64;
    let max = [1.0, 1.0, 0.5];
    let g = Grid::new(&vec![0.0; dim], &max[..dim], h, 0.0, Placement::Cell).unwrap();
    let horizon = 3.0 * h;
    let op = BondOperator::on_grid(&g, horizon, &micromodulus(), &Material::default()).unwrap();
    (g, op, horizon)
}

/// `beta`: 1 on the nodes with `x < x_pd`, a `profile` transition of width `w` beyond.
fn beta_left(g: &Grid, x_pd: f64, w: f64, profile: Profile) -> Vec<f64> {
    let inside: Vec<bool> = (0..g.len()).map(|i| g.position(i)[0] < x_pd).collect();
    beta_from_zone(g, &inside, w, profile)
}

fn full_dofs(model: &dyn Model) -> DofMap {
    DofMap::new(model.dim(), &vec![false; model.dim() * model.n_nodes()])
}

fn apply(model: &dyn Model, u: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; u.len()];
    model.apply(u, &mut y);
    y
}

fn max_abs(a: &Csc) -> f64 {
    a.val().iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Nodes at least `r` (lattice steps) inside every face of the grid box.
fn interior(g: &Grid, r: i64) -> Vec<usize> {
    let c = g.counts();
    (0..g.len())
        .filter(|&i| {
            let k = g.lattice_index(i);
            (0..g.dim()).all(|a| k[a] >= r && k[a] < c[a] as i64 - r)
        })
        .collect()
}

#[test]
fn beta_one_everywhere_is_the_bond_model() {
    for dim in [2, 3] {
        let (g, op, horizon) = setting(dim, if dim == 2 { 16 } else { 8 });
        let blend = LatticeBlend::new(&op, &g, horizon, vec![1.0; g.len()], None, &vec![false; g.len()]).unwrap();
        let dofs = full_dofs(&op);
        let a = op.assemble_free(&dofs);
        let b = blend.assemble_free(&dofs);
        // the same products summed in the same family order: agreement to a few eps of max |A|
        let u: Vec<f64> = (0..a.nrows()).map(|k| ((k * 7919) % 113) as f64 / 113.0 - 0.5).collect();
        let (ya, yb) = (apply(&op, &u), apply(&blend, &u));
        let err = ya.iter().zip(&yb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(err <= 64.0 * f64::EPSILON * max_abs(&a), "{dim}D: |A u - A_blend u| = {err:e}");
        assert_eq!(a.val().len(), b.val().len(), "{dim}D: same pattern");
        let z = blend.zones();
        assert_eq!((z.pd, z.transition, z.local), (g.len(), 0, 0));
        assert!(blend.asymmetry(&dofs) <= 1e-15);
    }
}

#[test]
fn affine_and_quadratic_fields_match_the_pd_rows() {
    for (dim, profile) in [(2, Profile::Linear), (2, Profile::Cubic), (2, Profile::Constant(0.5)), (3, Profile::Cubic)]
    {
        let n = if dim == 2 { 30 } else { 16 };
        let (g, op, horizon) = setting(dim, n);
        let h = g.spacing();
        let beta = beta_left(&g, 0.4, 4.0 * h, profile);
        let blend = LatticeBlend::new(&op, &g, horizon, beta, None, &vec![false; g.len()]).unwrap();
        let z = blend.zones();
        assert!(z.pd > 0 && z.transition > 0 && z.local > 0, "{dim}D {profile:?}: {z:?}");
        let scale = max_abs(&op.assemble_free(&full_dofs(&op)));
        let grad = [[1.0, 0.3, -0.2], [-0.4, 0.7, 0.1], [0.25, -0.5, 0.6]];
        let field = |q: bool| -> Vec<f64> {
            let mut u = vec![0.0; dim * g.len()];
            for i in 0..g.len() {
                let x = g.position(i);
                for a in 0..dim {
                    let mut v: f64 = (0..dim).map(|b| grad[a][b] * x[b]).sum();
                    if q {
                        v += (0..dim).map(|b| grad[(a + b) % dim][b] * x[b] * x[(b + a) % dim]).sum::<f64>();
                    }
                    u[dim * i + a] = v;
                }
            }
            u
        };
        // every row whose elements' corners have full families (4 = delta/h + 1 steps from the
        // free faces) equals the PD row; tolerance: round-off of |A| |u| summed over the
        // ~(2 delta/h)^d terms of a row and the h^-2 of the differences
        for (q, rows) in [(false, interior(&g, 4)), (true, interior(&g, 4))] {
            let u = field(q);
            let (yp, yb) = (apply(&op, &u), apply(&blend, &u));
            let umax = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = rows
                .iter()
                .flat_map(|&i| (0..dim).map(move |a| dim * i + a))
                .map(|k| (yp[k] - yb[k]).abs())
                .fold(0.0, f64::max);
            let tol = 1e4 * f64::EPSILON * scale * umax;
            assert!(err <= tol, "{dim}D {profile:?} quadratic={q}: |A_pd u - A_blend u| = {err:e} > {tol:e}");
        }
    }
}

#[test]
fn patch_test_affine_boundary_data_give_the_affine_field() {
    for dim in [2, 3] {
        let n = if dim == 2 { 30 } else { 14 };
        // a layer of three nodes (= delta) all around holds the affine field
        let h = 1.0 / n as f64;
        let max = [1.0, 1.0, 0.5];
        let g = Grid::new(&vec![0.0; dim], &max[..dim], h, 3.0 * h, Placement::Cell).unwrap();
        let horizon = 3.0 * h;
        let op = BondOperator::on_grid(&g, horizon, &micromodulus(), &Material::default()).unwrap();
        let beta = beta_left(&g, 0.35, 3.0 * h, Profile::Cubic);
        let layer: Vec<bool> = (0..g.len()).map(|i| g.is_layer(i)).collect();
        let blend = LatticeBlend::new(&op, &g, horizon, beta, None, &layer).unwrap();
        let z = blend.zones();
        assert!(z.pd > 0 && z.transition > 0 && z.local > 0, "{dim}D: {z:?}");
        let constrained: Vec<bool> = (0..dim * g.len()).map(|k| g.is_layer(k / dim)).collect();
        let grad = [[1e-3, 2e-3, -1e-3], [-5e-4, 3e-3, 1e-3], [2e-3, 0.0, -1e-3]];
        let exact: Vec<f64> = (0..dim * g.len())
            .map(|k| {
                let x = g.position(k / dim);
                (0..dim).map(|b| grad[k % dim][b] * x[b]).sum()
            })
            .collect();
        let ubar: Vec<f64> = exact.iter().zip(&constrained).map(|(v, &c)| if c { *v } else { 0.0 }).collect();
        let bc = Dirichlet::new(dim, &constrained, ubar);
        let sol = solve_model(&blend, &bc, &vec![0.0; dim * g.len()], &SolverSpec::Lu, &linpd_core::NoProgress)
            .expect("solve");
        let umax = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let err = sol.u.iter().zip(&exact).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
        // 1e-12: the patch-test tolerance (LU on a few thousand unknowns, cond ~ 1e3)
        assert!(err <= 1e-12, "{dim}D patch test: relative error {err:e}");
    }
}

#[test]
fn local_zone_is_symmetric_and_transitions_are_not() {
    let (g, op, horizon) = setting(2, 20);
    let dofs = full_dofs(&op);
    let local = LatticeBlend::new(&op, &g, horizon, vec![0.0; g.len()], None, &vec![false; g.len()]).unwrap();
    assert!(local.asymmetry(&dofs) <= 1e-14, "local zone: asymmetry {:e}", local.asymmetry(&dofs));
    let z = local.zones();
    assert_eq!((z.pd, z.transition, z.local), (0, 0, g.len()));
    // the element rows: 9 neighbours in 2D against 29 for delta = 3h
    assert!(z.nnz * 3 < z.nnz_pd, "{z:?}");
    // rigid motions are in the null space of the local model (free surfaces everywhere)
    for mode in 0..3 {
        let u: Vec<f64> = (0..2 * g.len())
            .map(|k| {
                let x = g.position(k / 2);
                match (mode, k % 2) {
                    (0, 0) | (1, 1) => 1.0,
                    (2, 0) => -x[1],
                    (2, 1) => x[0],
                    _ => 0.0,
                }
            })
            .collect();
        let y = apply(&local, &u);
        let err = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(err <= 1e3 * f64::EPSILON * max_abs(local.stiffness()), "rigid mode {mode}: |A u| = {err:e}");
    }
    let beta = beta_left(&g, 0.5, 3.0 * g.spacing(), Profile::Linear);
    let blended = LatticeBlend::new(&op, &g, horizon, beta, None, &vec![false; g.len()]).unwrap();
    assert!(blended.asymmetry(&dofs) > 1e-3, "transitions: asymmetry {:e}", blended.asymmetry(&dofs));
}

#[test]
fn a_defect_within_reach_of_a_local_share_is_refused() {
    let (g, _, horizon) = setting(2, 20);
    let material = Material {
        defects: vec![Defect::Segment { a: [0.7, 0.3], b: [0.7, 0.6], factor: 0.0 }],
        ..Material::default()
    };
    let op = BondOperator::on_grid(&g, horizon, &micromodulus(), &material).unwrap();
    // regular: the nodes with no cut bond
    let hom = BondOperator::on_grid(&g, horizon, &micromodulus(), &Material::default()).unwrap();
    let regular: Vec<bool> = (0..g.len()).map(|i| op.weights(i) == hom.weights(i)).collect();
    let beta = beta_left(&g, 0.5, 3.0 * g.spacing(), Profile::Linear);
    let err = LatticeBlend::new(&op, &g, horizon, beta, Some(&regular), &vec![false; g.len()]).unwrap_err();
    assert!(matches!(&err, BlendError::NotLocal { reason, .. } if reason.contains("defect")), "{err}");
    // with the crack more than a horizon inside the PD region (x < 0.9) it builds: the
    // crack at x = 0.7 cuts bonds of nodes up to x = 0.85, and nodes from x = 0.75 on reach
    // the transition; so shift the crack to x = 0.5
    let material = Material {
        defects: vec![Defect::Segment { a: [0.5, 0.3], b: [0.5, 0.6], factor: 0.0 }],
        ..Material::default()
    };
    let op = BondOperator::on_grid(&g, horizon, &micromodulus(), &material).unwrap();
    let regular: Vec<bool> = (0..g.len()).map(|i| op.weights(i) == hom.weights(i)).collect();
    let beta = beta_left(&g, 0.9, 3.0 * g.spacing(), Profile::Linear);
    if let Err(e) = LatticeBlend::new(&op, &g, horizon, beta, Some(&regular), &vec![false; g.len()]) {
        panic!("crack in the PD region: {e}");
    }
}

/// The SPD companion that preconditions the blend: symmetric, the bond model where `beta = 1`,
/// the elements where `beta = 0`, and positive definite on a supported body (a Cholesky runs).
#[test]
fn energy_form_is_symmetric_and_positive_definite() {
    let (g, op, horizon) = setting(2, 20);
    let dofs = full_dofs(&op);
    let none = vec![false; g.len()];
    let pd = LatticeBlend::new(&op, &g, horizon, vec![1.0; g.len()], None, &none).unwrap();
    let m = pd.spd_approximation(&dofs).unwrap().matrix;
    let a = pd.assemble_free(&dofs);
    let diff = m.val().iter().zip(a.val()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(diff <= 64.0 * f64::EPSILON * max_abs(&a), "beta = 1: |M - A| = {diff:e}");
    let local = LatticeBlend::new(&op, &g, horizon, vec![0.0; g.len()], None, &none).unwrap();
    let m = local.spd_approximation(&dofs).unwrap().matrix;
    let a = local.assemble_free(&dofs);
    let diff = m.val().iter().zip(a.val()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(diff <= 64.0 * f64::EPSILON * max_abs(&a), "beta = 0: |M - A| = {diff:e}");
    // blended, clamped on the left three columns: M symmetric and SPD
    let beta = beta_left(&g, 0.5, 3.0 * g.spacing(), Profile::Constant(0.5));
    let blend = LatticeBlend::new(&op, &g, horizon, beta, None, &none).unwrap();
    let constrained: Vec<bool> = (0..2 * g.len()).map(|k| g.position(k / 2)[0] < 0.15).collect();
    let dofs = DofMap::new(2, &constrained);
    let m = blend.spd_approximation(&dofs).unwrap().matrix;
    assert!(linpd_core::sparse::relative_asymmetry(&m) <= 1e-14);
    let chol = linpd_solve::Cholesky::analyze_with_ordering(&m, None).unwrap();
    assert!(chol.factor(&m).is_ok(), "M is not positive definite");
}
