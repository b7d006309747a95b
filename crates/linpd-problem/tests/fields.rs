//! The nodal strain of [`linpd_problem::fields`] on every static model with positions and
//! partners: bond-based (1D bar, 2D plate with a hole and one-sided layers, 2D plate with a
//! crack that cuts bonds, 3D cantilever, a 2D point cloud with per-node volumes), LPS (2D
//! plate, 3D bar, 2D edge-notched plate with pre-cracks) and a coarsened level
//! (`AssembledModel` from a moduli file).
//!
//! * An affine field `u = c + A x` gives `eps_i = sym(A)` at every node, layer and surface
//!   nodes and the crack's faces included: least squares reproduces affine data exactly
//!   (module docs), so the error is round-off of `u_j - u_i` (`|x| / |xi| <= 100` digits of
//!   cancellation, `~1e-14 |A|`); bound 1e-12 `|A|`.
//! * A linearized rigid motion `u = c + W x`, `W` skew, gives `eps_i = 0` (same bound).
//! * No node of these models has a singular shape tensor.

use linpd_core::{AssembledModel, Model};
use linpd_problem::{nodal_strain, ModuliFile, Problem};
use std::path::Path;

fn scene(name: &str) -> Problem {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data").join(name);
    Problem::from_path(&path).unwrap()
}

/// `(label, model, node volumes)` of every case.
fn models() -> Vec<(String, Box<dyn Model>, Vec<f64>)> {
    let mut out: Vec<(String, Box<dyn Model>, Vec<f64>)> = Vec::new();
    let volumes = |p: &Problem| (0..p.nodes().len()).map(|n| p.nodes().volume(n)).collect::<Vec<_>>();
    for name in [
        "bar-point-load.json",
        "plate-hole-2d.json",
        "plate-crack-2d.json",
        "cantilever-3d.json",
        "bracket-cloud-2d.json",
    ] {
        let p = scene(name);
        out.push((name.into(), Box::new(p.operator().unwrap()), volumes(&p)));
    }
    for name in ["lps-plate-2d.json", "lps-tension-3d.json", "plate-notch-2d.json"] {
        let p = scene(name);
        let m = p.lps_model().unwrap();
        let v = (0..m.n_nodes()).map(|n| m.node_volume(n)).collect();
        out.push((name.into(), Box::new(m), v));
    }
    // a coarsened 2D level: 6 x 6 nodes, spacing 0.2, C_ij = c n n^T within 1.5 h
    let (m, h) = (6usize, 0.2);
    let positions: Vec<[f64; 3]> = (0..m * m).map(|q| [(q % m) as f64 * h, (q / m) as f64 * h, 0.0]).collect();
    let mut entries = Vec::new();
    for i in 0..m * m {
        for j in 0..m * m {
            let dx = [positions[j][0] - positions[i][0], positions[j][1] - positions[i][1]];
            let r = dx[0].hypot(dx[1]);
            if i != j && r <= 1.5 * h * (1.0 + 1e-9) {
                let nv = [dx[0] / r, dx[1] / r];
                for a in 0..2 {
                    for b in 0..2 {
                        entries.push((2 * i + a, 2 * j + b, (1.0 + r / h) * nv[a] * nv[b]));
                    }
                }
            }
        }
    }
    let file = ModuliFile {
        level: 1,
        dim: 2,
        positions: positions.clone(),
        volumes: vec![h * h; m * m],
        level0: (0..m * m).collect(),
        entries,
    };
    out.push((
        "coarsened level".into(),
        Box::new(AssembledModel::new("coarsened", 2, positions, file.stiffness().unwrap())),
        file.volumes,
    ));
    out
}

fn affine(model: &dyn Model, c: [f64; 3], a: &[[f64; 3]; 3]) -> Vec<f64> {
    let d = model.dim();
    let mut u = vec![0.0; d * model.n_nodes()];
    for i in 0..model.n_nodes() {
        let x = model.position(i);
        for p in 0..d {
            u[d * i + p] = c[p] + (0..d).map(|q| a[p][q] * x[q]).sum::<f64>();
        }
    }
    u
}

#[test]
fn affine_fields_give_their_symmetric_gradient_and_rotations_give_zero() {
    let general = [[0.3, -1.1, 0.7], [0.4, -0.5, 0.2], [-0.9, 0.6, 1.3]];
    let skew = [[0.0, -0.6, 0.3], [0.6, 0.0, -0.7], [-0.3, 0.7, 0.0]];
    let (mut worst_affine, mut worst_rigid) = (0.0f64, 0.0f64);
    for (name, model, volumes) in models() {
        let d = model.dim();
        for (a, rigid) in [(general, false), (skew, true)] {
            let s = nodal_strain(model.as_ref(), &volumes, &affine(model.as_ref(), [0.1, -0.2, 0.3], &a));
            assert!(s.singular.is_empty(), "{name}: singular shape tensors at {:?}", s.singular);
            let mut err = 0.0f64;
            for (i, eps) in s.tensor.iter().enumerate() {
                for p in 0..3 {
                    for q in 0..3 {
                        let exact = if p < d && q < d && !rigid { 0.5 * (a[p][q] + a[q][p]) } else { 0.0 };
                        let e = (eps[3 * p + q] - exact).abs();
                        assert!(e < 1e-12, "{name}: node {i} eps[{p}][{q}] = {:e}, expected {exact:e}", eps[3 * p + q]);
                        err = err.max(e);
                    }
                }
            }
            eprintln!("{name} ({}): max |eps - exact| = {err:.2e}", if rigid { "rotation" } else { "affine" });
            if rigid {
                worst_rigid = worst_rigid.max(err);
            } else {
                worst_affine = worst_affine.max(err);
            }
        }
    }
    eprintln!("worst: affine {worst_affine:.2e}, rotation {worst_rigid:.2e} (|A| ~ 1)");
}

/// The Voigt order of the docs: `[xx, yy, zz, yz, xz, xy]`, `[xx, yy, xy]`, `xx`.
#[test]
fn voigt_order_is_the_documented_one() {
    let s = linpd_problem::NodalStrain {
        dim: 3,
        tensor: vec![[11.0, 12.0, 13.0, 12.0, 22.0, 23.0, 13.0, 23.0, 33.0]],
        singular: vec![],
    };
    assert_eq!(s.voigt(0), vec![11.0, 22.0, 33.0, 23.0, 13.0, 12.0]);
    let s2 =
        linpd_problem::NodalStrain { dim: 2, tensor: vec![[11.0, 12.0, 0.0, 12.0, 22.0, 0.0, 0.0, 0.0, 0.0]], ..s };
    assert_eq!(s2.voigt(0), vec![11.0, 22.0, 12.0]);
}

/// A 2D level whose nodes lie on one line has a singular shape tensor at every node: strain 0
/// (not NaN) and every node listed; a fourth node off the line makes every shape tensor
/// invertible.
#[test]
fn collinear_partners_give_a_listed_zero_strain() {
    let level = |positions: Vec<[f64; 3]>| {
        let n = positions.len();
        let mut entries = Vec::new();
        for i in 0..n {
            for j in 0..n {
                if i != j {
                    (0..2).for_each(|a| entries.push((2 * i + a, 2 * j + a, 1.0)));
                }
            }
        }
        let file = ModuliFile {
            level: 1,
            dim: 2,
            positions: positions.clone(),
            volumes: vec![1.0; n],
            level0: (0..n).collect(),
            entries,
        };
        AssembledModel::new("coarsened", 2, positions, file.stiffness().unwrap())
    };
    let line = level(vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]);
    let u = affine(&line, [0.0; 3], &[[1.0, 2.0, 0.0], [3.0, 4.0, 0.0], [0.0; 3]]);
    let s = nodal_strain(&line, &[1.0; 3], &u);
    assert_eq!(s.singular, vec![0, 1, 2]);
    assert!(s.tensor.iter().all(|t| t.iter().all(|&x| x == 0.0)));
    let kite = level(vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 1.0, 0.0]]);
    let u = affine(&kite, [0.0; 3], &[[1.0, 2.0, 0.0], [3.0, 4.0, 0.0], [0.0; 3]]);
    let s = nodal_strain(&kite, &[1.0; 4], &u);
    assert!(s.singular.is_empty());
    assert!(s
        .tensor
        .iter()
        .all(|t| (t[0] - 1.0).abs() < 1e-14 && (t[1] - 2.5).abs() < 1e-14 && (t[4] - 4.0).abs() < 1e-14));
}
