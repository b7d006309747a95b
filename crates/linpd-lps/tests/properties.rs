//! Properties of the LPS tangent and force on small lattices: the tangent is the Jacobian of
//! the nonlinear force (central finite differences), symmetric, positive semi-definite with
//! the rigid motions in its null space; the force is the gradient of the energy; affine
//! fields give zero force away from the surface; pure dilatation has the closed-form energy
//! `kappa theta^2 / 2`; the matrix-free apply matches the assembled matrix; bad input gives
//! typed errors.
//!
//! Material: `K = 2`, `G = 0.5` (`G != 3K/5`, so the `(3K - 5G)` dilatation term is non-zero),
//! spacing `h = 0.1`.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix notation A[i][j]

use linpd_core::{BondFamily, Grid, Placement};
use linpd_lps::{assemble_tangent, Influence, LpsError, LpsModel, LpsParams, PlaneModel};

mod common;
use common::{dense, max_abs, random_vec};

const H: f64 = 0.1;

fn params(ratio: f64, influence: Influence, pv: bool, plane: Option<PlaneModel>) -> LpsParams {
    LpsParams { K: 2.0, G: 0.5, horizon: ratio * H, influence, partial_volume: pv, plane }
}

fn grid(dim: usize, nodes: usize) -> Grid {
    let max = vec![(nodes - 1) as f64 * H; dim];
    Grid::new(&vec![0.0; dim], &max, H, 0.0, Placement::Vertex).unwrap()
}

fn model(dim: usize, nodes: usize, p: &LpsParams) -> LpsModel {
    LpsModel::new(&grid(dim, nodes), p).unwrap()
}

/// The variants exercised: (dim, nodes per axis, params).
fn variants() -> Vec<(usize, usize, LpsParams)> {
    vec![
        (3, 5, params(2.0, Influence::InverseDistance, true, None)),
        (3, 5, params(2.0, Influence::Constant, false, None)),
        (2, 8, params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain))),
        (2, 8, params(3.0, Influence::Constant, true, Some(PlaneModel::Stress))),
    ]
}

/// Every variant, homogeneous and with per-node moduli ([`model_of`]).
fn with_heterogeneous() -> Vec<(usize, usize, LpsParams, bool)> {
    variants().into_iter().flat_map(|(d, n, p)| [(d, n, p, false), (d, n, p, true)]).collect()
}

/// [`model`], with `hetero` per-node moduli `K_i` in [1, 4] and `G_i` in [0.3, 1.2] (Poisson
/// ratios 0.07 to 0.46), pseudo-random: a heterogeneous material in the energy's per-node form.
fn model_of(dim: usize, nodes: usize, p: &LpsParams, hetero: bool) -> LpsModel {
    let m = model(dim, nodes, p);
    if !hetero {
        return m;
    }
    let n = m.n_nodes();
    let (a, b) = (random_vec(n, 3), random_vec(n, 5));
    let bulk: Vec<f64> = a.iter().map(|v| 2.5 + 1.5 * v.clamp(-1.0, 1.0)).collect();
    let shear: Vec<f64> = b.iter().map(|v| 0.75 + 0.45 * v.clamp(-1.0, 1.0)).collect();
    m.with_node_moduli(&bulk, &shear).unwrap()
}

/// `u = H x`.
fn affine(m: &LpsModel, hmat: &[[f64; 3]; 3]) -> Vec<f64> {
    let d = m.dim();
    let mut u = vec![0.0; m.n_dofs()];
    for (i, x) in m.positions().iter().enumerate() {
        for a in 0..d {
            u[d * i + a] = (0..d).map(|b| hmat[a][b] * x[b]).sum();
        }
    }
    u
}

#[test]
fn tangent_equals_central_difference_jacobian_of_the_force() {
    for (dim, nodes, p, hetero) in with_heterogeneous() {
        let m = model_of(dim, nodes, &p, hetero);
        let a = dense(&assemble_tangent(&m));
        let s = max_abs(&a);
        let n = m.n_dofs();
        let eps = 1e-6 * H;
        let mut worst = 0.0f64;
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        for col in 0..n {
            let mut u = vec![0.0; n];
            u[col] = eps;
            m.internal_force(&u, &mut fp);
            u[col] = -eps;
            m.internal_force(&u, &mut fm);
            for row in 0..n {
                let fd = -(fp[row] - fm[row]) / (2.0 * eps);
                worst = worst.max((fd - a[row][col]).abs());
            }
        }
        eprintln!(
            "FD Jacobian dim {dim} {:?} heterogeneous {hetero}: max|A - J_fd| / max|A| = {:.2e}",
            p.influence,
            worst / s
        );
        assert!(worst <= 1e-7 * s, "dim {dim}: FD mismatch {:.3e} of max|A| {s:.3e}", worst / s);
    }
}

#[test]
fn force_is_minus_the_gradient_of_the_energy() {
    // At a random finite displacement (1% of h), where the geometric terms are active.
    for (dim, nodes, p, hetero) in with_heterogeneous() {
        let m = model_of(dim, nodes, &p, hetero);
        let n = m.n_dofs();
        let u: Vec<f64> = random_vec(n, 7).iter().map(|v| 1e-2 * H * v).collect();
        let mut f = vec![0.0; n];
        m.internal_force(&u, &mut f);
        let fmax = f.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let eps = 1e-5 * H;
        let mut worst = 0.0f64;
        for k in (0..n).step_by(3) {
            let mut up = u.clone();
            up[k] += eps;
            let mut um = u.clone();
            um[k] -= eps;
            let g = (m.energy(&up) - m.energy(&um)) / (2.0 * eps);
            worst = worst.max((f[k] + g).abs());
        }
        eprintln!("dim {dim}: max|F + dE/du| / max|F| = {:.2e}", worst / fmax);
        // Central difference of an energy sum: truncation ~1e-10, cancellation ~1e-16 E / eps.
        assert!(worst <= 1e-6 * fmax, "dim {dim}: force is not -grad E ({:.3e})", worst / fmax);
    }
}

#[test]
fn tangent_is_symmetric_psd_with_rigid_null_space() {
    for (dim, nodes, p, hetero) in with_heterogeneous() {
        let m = model_of(dim, nodes, &p, hetero);
        let a = dense(&assemble_tangent(&m));
        let s = max_abs(&a);
        let n = m.n_dofs();
        let mut asym = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                asym = asym.max((a[i][j] - a[j][i]).abs());
            }
        }
        assert!(asym <= 1e3 * f64::EPSILON * s, "dim {dim}: asymmetry {asym:.3e}");
        // Rigid motions: translations and the infinitesimal rotations u = W x, W skew.
        let mut modes: Vec<Vec<f64>> = Vec::new();
        for c in 0..dim {
            modes.push((0..n).map(|k| if k % dim == c { 1.0 } else { 0.0 }).collect());
        }
        let planes: &[(usize, usize)] = if dim == 2 { &[(0, 1)] } else { &[(0, 1), (1, 2), (0, 2)] };
        for &(q, r) in planes {
            let mut w = [[0.0; 3]; 3];
            w[q][r] = 1.0;
            w[r][q] = -1.0;
            modes.push(affine(&m, &w));
        }
        assert_eq!(modes.len(), if dim == 3 { 6 } else { 3 });
        let mut worst = 0.0f64;
        for mode in &modes {
            let mnorm = mode.iter().fold(0.0f64, |x, v| x.max(v.abs()));
            for row in a.iter() {
                let v: f64 = row.iter().zip(mode).map(|(x, y)| x * y).sum();
                worst = worst.max(v.abs() / (s * mnorm));
            }
        }
        assert!(worst <= 1e-12, "dim {dim}: rigid motion not in null space ({worst:.3e})");
        // The tangent is symmetric to round-off (checked above); read its lower triangle.
        let mut ev = faer::Mat::from_fn(n, n, |i, j| a[i][j]).self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        ev.sort_by(|x, y| x.partial_cmp(y).unwrap());
        let zeros = ev.iter().filter(|&&x| x.abs() <= 1e-10 * s).count();
        eprintln!(
            "dim {dim} {:?}: n = {n}, asym/max|A| = {:.1e}, rigid residual {worst:.1e}, lambda_min/max|A| = {:.2e}, \
             #|lambda| <= 1e-10 max|A| = {zeros}, first non-rigid lambda/max|A| = {:.3e}",
            p.plane,
            asym / s,
            ev[0] / s,
            ev[modes.len()] / s
        );
        assert!(ev[0] >= -1e-10 * s, "dim {dim}: negative eigenvalue {:.3e}", ev[0]);
        assert_eq!(zeros, modes.len(), "dim {dim}: null space is exactly the rigid motions");
    }
}

#[test]
fn affine_field_gives_zero_force_two_horizons_from_the_surface() {
    let hmat = [[1e-3, 2e-3, -1e-3], [0.5e-3, -2e-3, 1.5e-3], [-1e-3, 0.7e-3, 3e-3]];
    let cases = [
        (3, 9, params(2.0, Influence::InverseDistance, true, None)),
        (2, 11, params(2.0, Influence::Constant, true, Some(PlaneModel::Strain))),
        (2, 13, params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Stress))),
    ];
    for (dim, nodes, p) in cases {
        let m = model(dim, nodes, &p);
        let u = affine(&m, &hmat);
        let n = m.n_dofs();
        let (mut lin, mut nonlin) = (vec![0.0; n], vec![0.0; n]);
        m.apply_tangent(&u, &mut lin);
        m.internal_force(&u, &mut nonlin);
        let reach = (2.0 * p.horizon / H).round() as i64;
        let top = nodes as i64 - 1;
        let (mut interior, mut worst_lin, mut worst_nl) = (0, 0.0f64, 0.0f64);
        let max_lin = lin.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let max_nl = nonlin.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..m.n_nodes() {
            let k = m.grid().unwrap().lattice_index(i);
            if (0..dim).all(|a| k[a] >= reach && k[a] <= top - reach) {
                interior += 1;
                for c in 0..dim {
                    worst_lin = worst_lin.max(lin[dim * i + c].abs());
                    worst_nl = worst_nl.max(nonlin[dim * i + c].abs());
                }
            }
        }
        assert!(interior > 0);
        eprintln!(
            "affine dim {dim}: {interior} interior nodes, max|A u| there / max|A u| = {:.1e}, nonlinear {:.1e}",
            worst_lin / max_lin,
            worst_nl / max_nl
        );
        assert!(worst_lin <= 1e-12 * max_lin, "linear force at interior {worst_lin:.3e}");
        assert!(worst_nl <= 1e-10 * max_nl, "nonlinear force at interior {worst_nl:.3e}");
    }
}

#[test]
fn pure_dilatation_energy_density_is_kappa_theta_squared_over_two() {
    // u = eps x: e = eps |xi| for every bond, so theta = (d/m) sum omega |xi|^2 eps nu V = d eps
    // exactly at EVERY node (m is the same lattice sum), e^d = 0, and W = kappa (d eps)^2 / 2.
    let eps = 1e-3;
    let cases = [
        (3, 6, params(2.0, Influence::InverseDistance, true, None), 2.0),
        (3, 6, params(3.0, Influence::Constant, false, None), 2.0),
        (2, 8, params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain)), 2.0 + 0.5 / 3.0),
        (2, 8, params(3.0, Influence::InverseDistance, true, Some(PlaneModel::Stress)), 9.0 / 8.0),
    ];
    for (dim, nodes, p, kappa) in cases {
        let m = model(dim, nodes, &p);
        assert!((m.kappa() - kappa).abs() <= 1e-15 * kappa);
        let mut hm = [[0.0; 3]; 3];
        for (a, row) in hm.iter_mut().enumerate() {
            row[a] = eps;
        }
        let u = affine(&m, &hm);
        let theta_exact = dim as f64 * eps;
        let w_exact = 0.5 * kappa * theta_exact * theta_exact;
        let theta = m.theta(&u);
        let theta_lin = m.linearized_theta(&u);
        let w = m.energy_density(&u);
        let mut worst: f64 = 0.0;
        for i in 0..m.n_nodes() {
            worst = worst.max((theta[i] - theta_exact).abs() / theta_exact);
            worst = worst.max((theta_lin[i] - theta_exact).abs() / theta_exact);
            worst = worst.max((w[i] - w_exact).abs() / w_exact);
        }
        // 0.5 u^T A u equals the total energy (the linearized extension is exact here).
        let mut au = vec![0.0; m.n_dofs()];
        m.apply_tangent(&u, &mut au);
        let quad = 0.5 * u.iter().zip(&au).map(|(x, y)| x * y).sum::<f64>();
        let total = m.n_nodes() as f64 * m.volume() * w_exact;
        eprintln!(
            "dilatation dim {dim} {:?}: W = {w_exact:.6e}, max rel. dev. (theta, W) {worst:.1e}, \
             |u^T A u / 2 - E| / E = {:.1e}",
            p.plane,
            (quad - total).abs() / total
        );
        // e = |(1+eps) xi| - |xi| loses ~log10(1/eps) digits to cancellation.
        assert!(worst <= 1e-10, "dim {dim}: dilatation/energy mismatch {worst:.3e}");
        assert!((quad - total).abs() <= 1e-12 * total);
    }
}

#[test]
fn matrix_free_apply_matches_assembled_matvec() {
    for (dim, nodes, p, hetero) in with_heterogeneous() {
        let m = model_of(dim, nodes, &p, hetero);
        let a = assemble_tangent(&m);
        let n = m.n_dofs();
        let u = random_vec(n, 42);
        let mut y = vec![0.0; n];
        m.apply_tangent(&u, &mut y);
        let mut z = vec![0.0; n];
        for j in 0..n {
            for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                z[i] += v * u[j];
            }
        }
        let s = z.iter().fold(0.0f64, |x, v| x.max(v.abs()));
        let diff = y.iter().zip(&z).fold(0.0f64, |x, (p, q)| x.max((p - q).abs()));
        eprintln!("dim {dim}: matrix-free vs assembled max diff / max|Au| = {:.1e}, nnz = {}", diff / s, a.val().len());
        assert!(diff <= 1e-12 * s, "dim {dim}: apply mismatch {:.3e}", diff / s);
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let g3 = grid(3, 4);
    let base = params(2.0, Influence::InverseDistance, true, None);
    let err = |p: LpsParams| LpsModel::new(&g3, &p).unwrap_err();
    assert!(matches!(err(LpsParams { K: 0.0, ..base }), LpsError::BulkModulus(_)));
    assert!(matches!(err(LpsParams { K: f64::NAN, ..base }), LpsError::BulkModulus(_)));
    assert!(matches!(err(LpsParams { G: -1.0, ..base }), LpsError::ShearModulus(_)));
    // nu = (3 - 2e-17) / (6 + 2e-17) rounds to 1/2.
    let e = err(LpsParams { K: 1.0, G: 1e-17, ..base });
    assert!(matches!(e, LpsError::PoissonRatio { .. }), "{e}");
    assert!(e.to_string().contains("outside (-1, 1/2)"));
    let e = err(LpsParams { horizon: 0.5 * H, ..base });
    assert!(matches!(e, LpsError::Horizon { .. }), "{e}");
    assert!(e.to_string().contains("spacing"));
    let g2 = grid(2, 4);
    assert!(matches!(LpsModel::new(&g2, &base).unwrap_err(), LpsError::MissingPlane));
    let g1 = Grid::new(&[0.0], &[1.0], H, 0.0, Placement::Vertex).unwrap();
    assert!(matches!(LpsModel::new(&g1, &base).unwrap_err(), LpsError::Dimension(1)));
    // A node without bonds: m = 0.
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); g3.len()];
    lists[1].push(2);
    lists[2].push(1);
    let e = LpsModel::with_family(&g3, BondFamily::from_lists(lists), &base).unwrap_err();
    assert!(matches!(e, LpsError::ZeroWeightedVolume { node: 0, .. }), "{e}");
    assert!(e.to_string().contains("m = 0"));
    // A one-way bond is rejected, not silently asymmetric.
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); g3.len()];
    lists[0].push(1);
    let e = LpsModel::with_family(&g3, BondFamily::from_lists(lists), &base).unwrap_err();
    assert!(matches!(e, LpsError::Family(_)), "{e}");
}
