//! Phases and defects in the assembled blended operator (crate::material): a homogeneous
//! material is Algorithm A bit for bit; with phases and defects the asymmetry stays in the
//! transition rows, the CE model stays symmetric, every row annihilates constants, and
//! misplaced defects or interfaces are refused by name.

use linpd_blend::{BlendOperator, BlendParams, Blending, ModelKind};
use linpd_core::{BondRule, Defect, Material, Region};

fn interval(a: f64, b: f64) -> Region {
    Region::Box { min: vec![a], max: vec![b] }
}

/// N = 8 on dx = 1/320 with a coarse CE mesh (4 dx): transition rows' stencils cover
/// [0.12 - 2 eps, 0.25 + 2 eps] = [0.07, 0.30] and [0.70, 0.93] (eps = 0.025).
fn params(material: Material) -> BlendParams {
    let mut p = BlendParams::table3(Blending::Cubic);
    p.dx = 1.0 / 320.0;
    p.horizon = 8.0 / 320.0;
    p.ce_spacing = Some(4.0 / 320.0);
    p.material = material;
    p
}

/// Phases in both CE zones and the PD zone, a weakened point and a pre-crack in the PD zone.
fn heterogeneous() -> Material {
    let dx = 1.0 / 320.0;
    Material {
        phases: vec![(interval(0.0, 0.05), 2.0), (interval(0.4, 0.45), 3.0), (interval(0.95, 1.0), 0.5)],
        rule: BondRule::Harmonic,
        defects: vec![
            Defect::Point { x: 0.5 + dx / 2.0, factor: 0.1 },
            Defect::Point { x: 0.6 + dx / 2.0, factor: 0.0 },
        ],
    }
}

/// One phase with the model's modulus (everywhere, or on part of the bar with another bond
/// rule): the same CSR arrays, bit for bit (bond factors are exactly 1 and a face of one
/// modulus returns it), for every blending, with and without a coarse CE mesh.
#[test]
fn a_homogeneous_material_is_algorithm_a_bit_for_bit() {
    for blending in [Blending::Constant { value: 0.5 }, Blending::Linear, Blending::Cubic] {
        for coarse in [None, Some(8.0 / 300.0)] {
            let mut plain = BlendParams::table3(blending.clone());
            plain.ce_spacing = coarse;
            let a = BlendOperator::assemble(&plain, ModelKind::Blended).unwrap();
            for material in [
                Material { phases: vec![(Region::All, 1.0)], ..Material::default() },
                Material { phases: vec![(interval(0.3, 0.6), 1.0)], rule: BondRule::Min, defects: vec![] },
            ] {
                let mut p = plain.clone();
                p.material = material;
                let b = BlendOperator::assemble(&p, ModelKind::Blended).unwrap();
                assert_eq!((&a.row_ptr, &a.col), (&b.row_ptr, &b.col));
                assert!(a.val.iter().zip(&b.val).all(|(x, y)| x.to_bits() == y.to_bits()), "{blending:?} {coarse:?}");
            }
        }
    }
}

/// With phases in every pure zone and defects in the PD zone, entries `(i, j)` and `(j, i)`
/// differ only where `i` or `j` is a transition row (the PD part has symmetric bond factors,
/// the CE part shares each face modulus); the pure CE model with phases is exactly symmetric.
/// Dirichlet rows (the ends) are skipped. Tolerance 1e-13 of the largest entry: both entries
/// are the same products, summed in different orders.
#[test]
fn asymmetry_stays_in_the_transition_rows() {
    let p = params(heterogeneous());
    for kind in [ModelKind::Blended, ModelKind::PureCe] {
        let mut p = p.clone();
        if kind == ModelKind::PureCe {
            p.material.defects.clear();
        }
        let op = BlendOperator::assemble(&p, kind).unwrap();
        let scale = op.val.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let last = op.len() - 1;
        let mut asymmetric = 0;
        for i in 1..last {
            for q in op.row_ptr[i]..op.row_ptr[i + 1] {
                let j = op.col[q];
                if j == 0 || j == last {
                    continue;
                }
                let d = (op.val[q] - op.get(j, i)).abs();
                if d > 1e-13 * scale {
                    assert!(kind == ModelKind::Blended, "ce: ({i}, {j}) asymmetric by {d:e}");
                    assert!(op.transition[i] || op.transition[j], "({i}, {j}) outside the transition rows: {d:e}");
                    asymmetric += 1;
                }
            }
        }
        assert_eq!(asymmetric > 0, kind == ModelKind::Blended, "{kind:?}");
    }
}

/// Every row annihilates constants (the nonlocal differences and the local derivatives of a
/// constant vanish), whatever the material; rows of the pre-crack cut every bond across it.
/// Tolerance: 16 eps of the row's absolute sum.
#[test]
fn rows_annihilate_constants_and_the_crack_cuts() {
    let p = params(heterogeneous());
    let op = BlendOperator::assemble(&p, ModelKind::Blended).unwrap();
    let mut y = vec![0.0; op.len()];
    op.apply(&vec![1.0; op.len()], &mut y);
    for (i, v) in y.iter().enumerate() {
        let s: f64 = (op.row_ptr[i]..op.row_ptr[i + 1]).map(|q| op.val[q].abs()).sum();
        assert!(v.abs() <= 16.0 * f64::EPSILON * s, "row {i}: {v:e}");
    }
    let x = &op.mesh.x;
    let xd = 0.6 + p.dx / 2.0;
    for i in 0..op.len() {
        for q in op.row_ptr[i]..op.row_ptr[i + 1] {
            let j = op.col[q];
            if (x[i] - xd) * (x[j] - xd) < 0.0 {
                assert_eq!(op.val[q], 0.0, "bond ({i}, {j}) crosses the pre-crack");
            }
        }
    }
}

/// Misplaced defects and interfaces are refused with the key that names them.
#[test]
fn misplaced_defects_and_interfaces_are_refused() {
    let dx = 1.0 / 320.0;
    let cases = [
        (
            Material { defects: vec![Defect::Point { x: 0.26, factor: 0.0 }], ..Material::default() },
            "material.defects[0]: x = 0.26 is not in the pure PD zone",
        ),
        (
            Material { defects: vec![Defect::Point { x: 0.03, factor: 0.5 }], ..Material::default() },
            "material.defects[0]: x = 0.03 is not in the pure PD zone",
        ),
        (
            Material { phases: vec![(interval(0.4, 0.6), 2.0), (interval(0.28, 0.35), 2.0)], ..Material::default() },
            "material.phases[1].region: its boundary at x = 0.28",
        ),
        (
            Material { phases: vec![(interval(0.08, 0.5), 2.0)], ..Material::default() },
            "material.phases[0].region: its boundary at x = 0.08",
        ),
    ];
    for (material, expected) in cases {
        let e = match BlendOperator::assemble(&params(material), ModelKind::Blended) {
            Ok(_) => panic!("accepted: {expected}"),
            Err(e) => e.to_string(),
        };
        assert!(e.starts_with(expected), "expected {expected:?}, got {e:?}");
    }
    // A phase covering a whole transition zone is fine (K is one value on every transition
    // stencil), so is an interface just outside the transition stencils (0.06 < L1 - 2 eps),
    // and a defect anywhere in the pure PD model.
    let outside = Material { phases: vec![(interval(0.06, 0.5), 2.0)], ..Material::default() };
    BlendOperator::assemble(&params(outside), ModelKind::Blended).unwrap();
    let covering = Material { phases: vec![(interval(0.0, 0.5), 2.0)], ..Material::default() };
    BlendOperator::assemble(&params(covering), ModelKind::Blended).unwrap();
    let crack = Material { defects: vec![Defect::Point { x: 0.26 + dx / 2.0, factor: 0.0 }], ..Material::default() };
    BlendOperator::assemble(&params(crack.clone()), ModelKind::PurePd).unwrap();
    let e = BlendOperator::assemble(&params(crack), ModelKind::PureCe).map(|_| ()).unwrap_err().to_string();
    assert!(e.starts_with("material.defects[0]: ce models have no bonds"), "{e}");
}
