//! The per-node output fields of the linearized LPS model ([`linpd_lps::fields`]):
//!
//! * `sum_i W_i V_i = u . A u / 2` for random `u` (2D plane strain and stress, 3D, with and
//!   without the surface correction): an identity in exact arithmetic (the module docs expand
//!   it), so the bound is round-off, 1e-12 relative (a sum of a few hundred `>= 0` terms
//!   against one dot product of a matrix-free product);
//! * a linearized rigid motion `u = c + W x` (`W` skew) gives `theta = 0` and `W_i = 0` up to
//!   round-off, measured against the scale `|W| h` of the displacement differences;
//! * a uniform dilation `u = epsilon x` gives `theta_i = d epsilon` at every node without the
//!   surface correction (the lattice sums of `theta` and `m` coincide; model docs), to 1e-12
//!   relative, and at interior nodes with it.
//!
//! Models: 2D plane strain and stress, 3D, both influence functions, partial volumes on and
//! off, surface correction on and off, and a 2D model with a cut and a weakened line of bonds
//! ([`LpsModel::with_defects`]). Material: `K = 2`, `G = 0.5`, spacing `h = 0.1` (as in
//! `properties.rs`).

use linpd_core::{Defect, Grid, Placement};
use linpd_lps::{Influence, LpsModel, PlaneModel, SurfaceCorrection};

mod common;
use common::random_vec;

use common::H;

fn models() -> Vec<(&'static str, LpsModel)> {
    let params = common::params;
    let grid = |dim: usize, nodes: usize| {
        Grid::new(&vec![0.0; dim], &vec![(nodes - 1) as f64 * H; dim], H, 0.0, Placement::Vertex).unwrap()
    };
    let mut out = Vec::new();
    for (name, dim, nodes, p) in [
        ("3d", 3, 6, params(2.0, Influence::InverseDistance, true, None)),
        ("3d-const", 3, 5, params(2.0, Influence::Constant, false, None)),
        ("2d-strain", 2, 9, params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain))),
        ("2d-stress", 2, 9, params(3.0, Influence::Constant, true, Some(PlaneModel::Stress))),
    ] {
        let m = LpsModel::new(&grid(dim, nodes), &p).unwrap();
        out.push((name, m.clone()));
        out.push((name, m.with_surface_correction(SurfaceCorrection::BulkWeightedVolume)));
    }
    // pre-cracks: a cut (factor 0) and a weakened line (factor 0.3) in 2D
    let mid = 4.5 * H;
    let defects = [
        Defect::Segment { a: [mid, -1.0], b: [mid, 0.4], factor: 0.0 },
        Defect::Segment { a: [-1.0, mid - 0.02], b: [0.4, mid - 0.02], factor: 0.3 },
    ];
    let p = params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain));
    out.push(("2d-defects", LpsModel::with_defects(&grid(2, 10), &p, &defects).unwrap()));
    out
}

fn affine(m: &LpsModel, c: [f64; 3], a: [[f64; 3]; 3]) -> Vec<f64> {
    let d = m.dim();
    let mut u = vec![0.0; m.n_dofs()];
    for (i, x) in m.positions().iter().enumerate() {
        for p in 0..d {
            u[d * i + p] = c[p] + (0..d).map(|q| a[p][q] * x[q]).sum::<f64>();
        }
    }
    u
}

#[test]
fn energy_density_sums_to_half_u_a_u() {
    let mut worst = 0.0f64;
    for (seed, (name, m)) in models().into_iter().enumerate() {
        let u = random_vec(m.n_dofs(), 0x9e37_79b9 + seed as u64);
        let mut au = vec![0.0; m.n_dofs()];
        m.apply_tangent(&u, &mut au);
        let energy = 0.5 * u.iter().zip(&au).map(|(a, b)| a * b).sum::<f64>();
        let w = m.linearized_energy_density(&u);
        assert!(w.iter().all(|x| *x >= 0.0), "{name}: W_i >= 0");
        let summed: f64 = w.iter().enumerate().map(|(i, w)| w * m.node_volume(i)).sum();
        let rel = (summed / energy - 1.0).abs();
        worst = worst.max(rel);
        assert!(rel < 1e-12, "{name} ({:?}): sum W V = {summed:e}, u.Au/2 = {energy:e}", m.surface_correction());
    }
    eprintln!("max |sum W V / (u.Au/2) - 1| = {worst:.2e}");
}

#[test]
fn rigid_motion_has_no_dilatation_and_no_energy() {
    let mut worst = (0.0f64, 0.0f64);
    for (name, m) in models() {
        // |W| = 1: displacement differences of size |xi| <= 3 h; e, theta ~ eps |xi|
        let skew = [[0.0, -0.6, 0.3], [0.6, 0.0, -0.7], [-0.3, 0.7, 0.0]];
        let u = affine(&m, [0.4, -0.2, 0.9], skew);
        let theta = m.linearized_theta(&u);
        let w = m.linearized_energy_density(&u);
        let t = theta.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // W ~ kappa theta^2: round-off squared against the energy of a unit strain (kappa ~ 1)
        let e = w.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        worst = (worst.0.max(t), worst.1.max(e));
        assert!(t < 1e-13, "{name}: max |theta| = {t:e}");
        assert!(e < 1e-26, "{name}: max W = {e:e}");
    }
    eprintln!("rigid motion: max |theta| = {:.2e}, max W = {:.2e}", worst.0, worst.1);
}

#[test]
fn uniform_dilation_gives_theta_d_epsilon() {
    let eps = 1e-3;
    let mut worst = 0.0f64;
    for (name, m) in models() {
        let d = m.dim();
        let mut a = [[0.0; 3]; 3];
        (0..d).for_each(|p| a[p][p] = eps);
        let theta = m.linearized_theta(&affine(&m, [0.0; 3], a));
        let expected = d as f64 * eps;
        let corrected = m.surface_correction() != SurfaceCorrection::None;
        let reach = m.params().horizon;
        let extent = m.positions().iter().fold(0.0f64, |a, x| a.max(x[0]));
        for (i, x) in m.positions().iter().enumerate() {
            let interior = (0..d).all(|p| x[p] >= reach - 1e-12 && x[p] <= extent - reach + 1e-12);
            if corrected && !interior {
                continue;
            }
            let rel = (theta[i] / expected - 1.0).abs();
            worst = worst.max(rel);
            assert!(rel < 1e-12, "{name}: theta[{i}] at {x:?} = {:e}, expected {expected:e}", theta[i]);
        }
    }
    eprintln!("uniform dilation: max |theta / (d eps) - 1| = {worst:.2e}");
}
