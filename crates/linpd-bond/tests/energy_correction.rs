//! The bond-based `energy` surface correction (issue #14; (S3) and (S5) of
//! `linpd_bond::surface`): bond weights symmetric bit for bit, rigid motions in the null space,
//! positive factors, and the interior: unchanged with the lattice target, all alike (and not
//! unchanged) with the classical one.

use linpd_core::surface::SurfaceTarget;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};

use linpd_bond::BondOperator;

/// A box of `nodes` per side with spacing 0.1 and horizon `ratio * h`, its plain operator
/// and its micromodulus (continuum normalization, partial volumes on).
fn plain(dim: usize, nodes: usize, ratio: f64) -> (Grid, BondOperator, Micromodulus, f64) {
    let h = 0.1;
    let max = vec![(nodes - 1) as f64 * h; dim];
    let g = Grid::new(&vec![0.0; dim], &max, h, 0.0, Placement::Vertex).unwrap();
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Continuum,
        modulus: 2.0,
        plane: Some(PlaneModel::Strain),
        partial_volume: true,
    };
    let o = BondOperator::on_grid(&g, ratio * h, &mm, &Material::default()).unwrap();
    (g, o, mm, ratio * h)
}

/// Distance from node position `x` to the nearest face of the box.
fn to_surface(x: &[f64], dim: usize, nodes: usize) -> f64 {
    (0..dim).map(|a| x[a].min((nodes - 1) as f64 * 0.1 - x[a])).fold(f64::INFINITY, f64::min)
}

#[test]
fn corrected_weights_are_symmetric_positive_and_keep_the_rigid_null_space() {
    for (dim, nodes, ratio) in [(2, 12, 3.0), (3, 8, 2.0), (3, 8, 3.0)] {
        for target in [SurfaceTarget::Classical, SurfaceTarget::Lattice] {
            let (g, o, mm, delta) = plain(dim, nodes, ratio);
            let (c, summary) = o.clone().with_energy_correction(&g, delta, &mm, target);
            assert!(summary.corrected_nodes > 0 && summary.factor_range[0] > 0.0, "{summary:?}");
            let fam = c.family();
            for i in 0..c.n_nodes() {
                for (b, &j) in fam.neighbors(i).iter().enumerate() {
                    let j = j as usize;
                    let back = fam.neighbors(j).iter().position(|&k| k as usize == i).unwrap();
                    // (S3) and (S5) are symmetric in the pair and evaluated in the same order
                    // from both ends: equal bit for bit
                    assert_eq!(c.weights(i)[b], c.weights(j)[back], "w_ij != w_ji at ({i}, {j})");
                    assert!(c.weights(i)[b] > 0.0);
                }
            }
            // rigid motions: translations and linearized rotations give zero force; round-off
            // bound ~ n_bonds eps of the largest single bond force
            let n = c.n_dofs();
            let x = c.positions();
            let mut modes: Vec<Vec<f64>> =
                (0..dim).map(|a| (0..n).map(|k| f64::from(k % dim == a)).collect()).collect();
            let pairs: &[(usize, usize)] = if dim == 3 { &[(0, 1), (1, 2), (0, 2)] } else { &[(0, 1)] };
            for &(a, b) in pairs {
                let mut r = vec![0.0; n];
                for (i, p) in x.iter().enumerate() {
                    r[dim * i + a] = -p[b];
                    r[dim * i + b] = p[a];
                }
                modes.push(r);
            }
            let w_max = (0..c.n_nodes()).flat_map(|i| c.weights(i).iter().copied()).fold(0.0, f64::max);
            for r in &modes {
                let mut y = vec![0.0; n];
                c.apply(r, &mut y);
                let worst = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                assert!(worst <= 1e3 * f64::EPSILON * w_max, "dim {dim} {}: |A r| = {worst:e}", target.name());
            }
        }
    }
}

/// Nodes farther than three horizons from every face (their partners' factors and trace ratios
/// are the interior's) keep their weights bit for bit with the lattice target; with the
/// classical target they all carry the same weights, which differ from the plain ones.
#[test]
fn interior_weights_are_unchanged_or_all_alike() {
    for (dim, nodes, ratio) in [(2, 25, 3.0), (3, 15, 2.0)] {
        for target in [SurfaceTarget::Lattice, SurfaceTarget::Classical] {
            let (g, o, mm, delta) = plain(dim, nodes, ratio);
            let (c, _) = o.clone().with_energy_correction(&g, delta, &mm, target);
            let mut interior: Option<&[f64]> = None;
            let mut checked = 0;
            for (i, x) in g.positions().iter().enumerate() {
                let what = format!("dim {dim} {}: node {i} at {x:?}", target.name());
                if to_surface(x, dim, nodes) > 3.0 * delta * (1.0 + 1e-9) {
                    match target {
                        SurfaceTarget::Lattice => assert_eq!(c.weights(i), o.weights(i), "{what}"),
                        SurfaceTarget::Classical => {
                            assert_ne!(c.weights(i), o.weights(i), "{what}");
                            assert_eq!(c.weights(i), *interior.get_or_insert(c.weights(i)), "{what}");
                        }
                    }
                    checked += 1;
                } else if to_surface(x, dim, nodes) < 0.5 * delta {
                    assert_ne!(c.weights(i), o.weights(i), "{what}: a face node is not corrected");
                }
            }
            assert!(checked > 0);
        }
    }
}
