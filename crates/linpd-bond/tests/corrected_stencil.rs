//! The corrected stencil ([`CorrectedStencil`]) against the per-bond apply of the same
//! operator ([`BondOperator::apply`]) on every kind of lattice that leaves the plain stencil:
//! phases (harmonic and arithmetic bond rules), defects (2D segment, 3D plane), a surface
//! correction, bodies with removed sites and cut volumes, and 1D; plus what it stores.
//!
//! Tolerance: factors within `1e-13` of a node's most frequent one count as equal (module
//! docs), so the products agree to `1e-13 |A|_row |u|`; asserted at `1e-12` of
//! `max_i sum_j w_ij * max |u|` (the largest row sum of `|A|` is at most twice that).

use linpd_bond::{BondOperator, CorrectedStencil};
use linpd_core::{
    BondRule, Defect, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel, Region,
};

fn micromodulus(pv: bool) -> Micromodulus {
    Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Continuum,
        modulus: 2.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: pv,
    }
}

/// A smooth, non-affine field (so every bond is stretched differently).
fn field(grid: &Grid) -> Vec<f64> {
    let d = grid.dim();
    (0..grid.len())
        .flat_map(|i| {
            let x = grid.position(i);
            (0..d).map(move |a| (1.3 * x[0] + 0.7 * a as f64).sin() + x[1] * x[1] - 0.4 * x[2] * x[0])
        })
        .collect()
}

/// `max |y_corrected - y_per_bond| / (max_i sum_j w_ij max |u|)` and the corrections.
fn compare(grid: &Grid, horizon: f64, mm: &Micromodulus, op: &BondOperator) -> (f64, usize) {
    let c = CorrectedStencil::new(grid, horizon, mm, op).expect("a lattice operator");
    let u = field(grid);
    let (mut y0, mut y1) = (vec![0.0; u.len()], vec![0.0; u.len()]);
    op.apply(&u, &mut y0);
    c.apply(&u, &mut y1);
    let row: f64 = (0..op.n_nodes()).map(|i| op.weights(i).iter().sum::<f64>()).fold(0.0, f64::max);
    let umax = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e = y0.iter().zip(&y1).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / (row * umax);
    (e, c.n_corrections())
}

#[test]
fn a_homogeneous_full_box_stores_no_correction() {
    let g = Grid::new(&[0.0; 3], &[1.0, 0.8, 0.6], 0.1, 0.0, Placement::Vertex).unwrap();
    let mm = micromodulus(true);
    let op = BondOperator::on_grid(&g, 0.3, &mm, &Material::default()).unwrap();
    let (e, n) = compare(&g, 0.3, &mm, &op);
    assert_eq!(n, 0);
    assert!(e <= 1e-14, "{e:e}");
}

#[test]
fn phases_store_the_interface_bonds_only() {
    for rule in [BondRule::Harmonic, BondRule::Arithmetic] {
        let g = Grid::new(&[0.0; 3], &[1.0, 0.8, 0.6], 0.1, 0.0, Placement::Vertex).unwrap();
        let mm = micromodulus(false);
        let material = Material {
            phases: vec![(Region::Ball { center: vec![0.5, 0.4, 0.3], radius: 0.25 }, 1e4)],
            rule,
            defects: vec![],
        };
        let op = BondOperator::on_grid(&g, 0.3, &mm, &material).unwrap();
        let (e, n) = compare(&g, 0.3, &mm, &op);
        assert!(e <= 1e-12, "{rule:?}: {e:e}");
        // only bonds whose ends lie in different phases differ from their node's factor
        let inside = |i: usize| {
            let x = g.position(i);
            (x[0] - 0.5).powi(2) + (x[1] - 0.4).powi(2) + (x[2] - 0.3).powi(2) <= 0.25f64.powi(2)
        };
        let crossing: usize = (0..g.len())
            .map(|i| op.family().neighbors(i).iter().filter(|&&j| inside(i) != inside(j as usize)).count())
            .sum();
        assert!(n > 0 && n <= crossing, "{rule:?}: {n} corrections, {crossing} bonds across the interface");
    }
}

#[test]
fn defects_store_the_cut_bonds_only() {
    // 2D segment
    let g = Grid::new(&[0.0; 2], &[1.0, 0.6], 0.02, 0.0, Placement::Vertex).unwrap();
    let mm = micromodulus(true);
    let material = Material {
        defects: vec![Defect::Segment { a: [-1.0, 0.305], b: [0.4, 0.305], factor: 0.0 }],
        ..Material::default()
    };
    let op = BondOperator::on_grid(&g, 0.06, &mm, &material).unwrap();
    let (e, n) = compare(&g, 0.06, &mm, &op);
    let cut: usize = (0..g.len()).map(|i| op.weights(i).iter().filter(|&&w| w == 0.0).count()).sum();
    assert!(e <= 1e-12, "2D crack: {e:e}");
    assert_eq!(n, cut, "one correction per cut bond end");
    // 3D plane with an extent, factor 0.3
    let g = Grid::new(&[0.0; 3], &[0.6, 0.5, 0.6], 0.05, 0.0, Placement::Vertex).unwrap();
    let material = Material {
        defects: vec![Defect::Plane {
            point: [0.0, 0.0, 0.325],
            normal: [0.0, 0.0, 1.0],
            extent: Some(Region::Box { min: vec![-1.0, -1.0, 0.0], max: vec![0.3, 2.0, 1.0] }),
            factor: 0.3,
        }],
        ..Material::default()
    };
    let op = BondOperator::on_grid(&g, 0.15, &mm, &material).unwrap();
    let (e, n) = compare(&g, 0.15, &mm, &op);
    assert!(e <= 1e-12, "3D notch: {e:e}");
    assert!(n > 0, "the notch cuts bonds");
}

#[test]
fn a_surface_corrected_operator_is_applied_exactly() {
    let g = Grid::new(&[0.0; 2], &[1.0, 0.5], 0.025, 0.0, Placement::Vertex).unwrap();
    let mm = micromodulus(true);
    let op = BondOperator::on_grid(&g, 0.075, &mm, &Material::default()).unwrap();
    let (op, _) = op.with_energy_correction(&g, 0.075, &mm, linpd_core::surface::SurfaceTarget::Classical);
    let (e, n) = compare(&g, 0.075, &mm, &op);
    assert!(e <= 1e-12, "{e:e}");
    assert!(n > 0, "the layer near the faces is corrected");
}

#[test]
fn bodies_with_removed_sites_and_cut_volumes() {
    let hole = |x: &linpd_core::Point| (x[0] - 0.5).powi(2) + (x[1] - 0.25).powi(2) > 0.1f64.powi(2);
    let box_grid = Grid::new(&[0.0; 2], &[1.0, 0.5], 0.02, 0.0, Placement::Vertex).unwrap();
    let mm = micromodulus(false);
    for cut in [false, true] {
        let g = box_grid.with_body(hole).unwrap();
        let g = if cut { g.with_cut_volumes(hole) } else { g };
        assert!(!g.is_full() && CorrectedStencil::fits(&g));
        let op = BondOperator::on_grid(&g, 0.06, &mm, &Material::default()).unwrap();
        let (e, n) = compare(&g, 0.06, &mm, &op);
        assert!(e <= 1e-12, "hole (cut volumes {cut}): {e:e}");
        assert!(n > 0);
    }
    // a body that keeps less than half the box is refused by name
    let g = box_grid.with_body(|x| x[0] < 0.3).unwrap();
    assert!(!CorrectedStencil::fits(&g));
    let op = BondOperator::on_grid(&g, 0.06, &mm, &Material::default()).unwrap();
    let e = CorrectedStencil::new(&g, 0.06, &mm, &op).unwrap_err().to_string();
    assert!(e.contains("less than 0.5 of the lattice box"), "{e}");
}

#[test]
fn one_dimension_with_phases() {
    let g = Grid::new(&[0.0], &[1.0], 0.01, 0.0, Placement::Vertex).unwrap();
    let mm = Micromodulus { plane: None, ..micromodulus(true) };
    let material = Material {
        phases: vec![(Region::Box { min: vec![0.3], max: vec![0.55] }, 3.0)],
        rule: BondRule::Harmonic,
        defects: vec![Defect::Point { x: 0.805, factor: 0.0 }],
    };
    let op = BondOperator::on_grid(&g, 0.03, &mm, &material).unwrap();
    let (e, n) = compare(&g, 0.03, &mm, &op);
    assert!(e <= 1e-12, "{e:e}");
    assert!(n > 0);
}

/// The homogeneous model without bonds (`LatticeBondModel::stencil`) answers every question
/// the solvers and the nodal fields ask as the model with its bonds does: products, diagonal,
/// block rows (the same blocks in the same order, to 1e-15 of the largest), partners and the
/// bond count; its operator, built on request, is the per-bond one. A horizon below `sqrt 2`
/// spacings is refused as `on_grid` refuses it.
#[test]
fn the_stencil_model_without_bonds_is_the_model_with_them() {
    use linpd_bond::LatticeBondModel;
    use linpd_core::Model;
    let g = Grid::new(&[0.0; 3], &[1.0, 0.8, 0.6], 0.1, 0.2, Placement::Vertex).unwrap();
    let mm = micromodulus(true);
    let op = BondOperator::on_grid(&g, 0.3, &mm, &Material::default()).unwrap();
    let with = LatticeBondModel::new(op, g.clone(), 0.3, Some(mm.clone()));
    let without = LatticeBondModel::stencil(g.clone(), 0.3, mm.clone()).unwrap();
    let u = field(&g);
    let (mut y0, mut y1) = (vec![0.0; u.len()], vec![0.0; u.len()]);
    with.apply(&u, &mut y0);
    without.apply(&u, &mut y1);
    let scale = y0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(y0.iter().zip(&y1).all(|(a, b)| (a - b).abs() <= 1e-13 * scale));
    let (d0, d1) = (Model::diagonal(&with), Model::diagonal(&without));
    assert!(d0.iter().zip(&d1).all(|(a, b)| (a - b).abs() <= 1e-14 * a.abs()));
    for i in [0, 7, g.len() / 2, g.len() - 1] {
        let (mut b0, mut b1) = (Vec::new(), Vec::new());
        with.for_each_block(i, &mut |j, b| b0.push((j, b.to_vec())));
        without.for_each_block(i, &mut |j, b| b1.push((j, b.to_vec())));
        assert_eq!(b0.len(), b1.len(), "node {i}");
        let big = b0.iter().flat_map(|(_, b)| b.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
        for ((j0, x), (j1, y)) in b0.iter().zip(&b1) {
            assert_eq!(j0, j1, "node {i}");
            assert!(x.iter().zip(y).all(|(a, b)| (a - b).abs() <= 1e-15 * big), "node {i}, partner {j0}");
        }
        let (mut p0, mut p1) = (Vec::new(), Vec::new());
        with.for_each_partner(i, &mut |j| p0.push(j));
        without.for_each_partner(i, &mut |j| p1.push(j));
        assert_eq!(p0, p1, "node {i}");
    }
    assert_eq!(with.n_bonds(), without.n_bonds());
    assert_eq!(without.operator().weights(3), with.operator().weights(3));
    let e = LatticeBondModel::stencil(g, 0.12, mm).unwrap_err().to_string();
    assert!(e.contains("only along the axes"), "{e}");
}
