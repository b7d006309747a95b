//! The moment-matching surface corrections of the LPS model (`energy`, `position_aware`;
//! issue #14): consistency of force, energy and tangent, the rigid null space, interior nodes
//! untouched, and exact affine response at every node for `position_aware`.

#![allow(clippy::needless_range_loop)]

mod common;
use common::{dense, max_abs, random_vec};
use linpd_core::{Grid, Placement};
use linpd_lps::{
    assemble_tangent, fd_tangent, Influence, LpsModel, LpsParams, PlaneModel, SurfaceCorrection, SurfaceTarget,
};

use common::H;

/// (dim, nodes per side, params): delta = 3h with both influence functions, and the smallest
/// 3D horizon in use (delta = 2h, whose corner families have 7 bond directions).
fn variants() -> Vec<(usize, usize, LpsParams)> {
    let p = common::params;
    vec![
        (3, 7, p(3.0, Influence::InverseDistance, true, None)),
        (3, 5, p(2.0, Influence::InverseDistance, true, None)),
        (3, 7, p(3.0, Influence::Constant, false, None)),
        (2, 10, p(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain))),
        (2, 10, p(3.0, Influence::Constant, true, Some(PlaneModel::Stress))),
    ]
}

fn grid(dim: usize, nodes: usize) -> Grid {
    let max = vec![(nodes - 1) as f64 * H; dim];
    Grid::new(&vec![0.0; dim], &max, H, 0.0, Placement::Vertex).unwrap()
}

const CORRECTIONS: [SurfaceCorrection; 2] = [SurfaceCorrection::Energy, SurfaceCorrection::PositionAware];

/// For both targets, the tangent is the central-difference Jacobian of the corrected nonlinear force (1e-7 of
/// max|A|, the bound of the uncorrected model's test: FD truncation with eps = 1e-6 h), symmetric
/// (1e-12), equal to the matrix-free apply (1e-12), positive semi-definite with exactly the
/// rigid motions (6 in 3D, 3 in 2D) in its null space, and `sum_i V_i W_i = u.A u / 2` (1e-12).
#[test]
fn corrected_tangents_are_consistent_symmetric_and_keep_the_rigid_null_space() {
    for (dim, nodes, p) in variants() {
        for (c, target) in
            CORRECTIONS.iter().flat_map(|&c| [(c, SurfaceTarget::Classical), (c, SurfaceTarget::Lattice)])
        {
            let (m, summary) = LpsModel::new(&grid(dim, nodes), &p).unwrap().corrected_to(c, target).unwrap();
            let summary = summary.unwrap();
            let a = assemble_tangent(&m);
            let scale = a.val().iter().fold(0.0f64, |x, v| x.max(v.abs()));
            let f = fd_tangent(&m, 1e-6 * H);
            let fd = a.val().iter().zip(f.val()).fold(0.0f64, |x, (u, v)| x.max((u - v).abs())) / scale;
            let ad = dense(&a);
            let n = ad.len();
            let asym = (0..n)
                .flat_map(|r| (0..n).map(move |c| (r, c)))
                .fold(0.0f64, |x, (r, c)| x.max((ad[r][c] - ad[c][r]).abs()))
                / scale;
            let u = random_vec(n, 11);
            let mut y = vec![0.0; n];
            m.apply_tangent(&u, &mut y);
            let au: Vec<f64> = ad.iter().map(|row| row.iter().zip(&u).map(|(a, b)| a * b).sum()).collect();
            let mf =
                y.iter().zip(&au).fold(0.0f64, |x, (a, b)| x.max((a - b).abs())) / max_abs(std::slice::from_ref(&au));
            let half_uau = 0.5 * u.iter().zip(&au).map(|(a, b)| a * b).sum::<f64>();
            let w: f64 = m.linearized_energy_density(&u).iter().enumerate().map(|(i, w)| w * m.node_volume(i)).sum();
            let energy = (w - half_uau).abs() / half_uau.abs();
            let null = rigid_residual(&m, &ad) / scale;
            let pd = definite_without_the_first_layer(&m, &ad);
            eprintln!(
                "dim {dim} {:?} {}: {}; fd {fd:.1e} asym {asym:.1e} mf {mf:.1e} energy {energy:.1e} \
                 rigid {null:.1e} definite {pd}",
                p.influence,
                c.name(),
                summary.describe(),
            );
            assert!(summary.corrected_nodes > 0 && summary.max_mismatch <= 1e-12, "{summary:?}");
            assert!(fd <= 1e-7, "FD Jacobian {fd:e}");
            assert!(asym <= 1e-12, "asymmetry {asym:e}");
            assert!(mf <= 1e-12, "matrix-free {mf:e}");
            assert!(energy <= 1e-12, "energy identity {energy:e}");
            assert!(null <= 1e-13, "rigid motions: |A r| / max|A| = {null:e}");
            assert!(pd, "not positive definite once the rigid motions are held");
        }
    }
}

/// Nodes farther than one horizon (`position_aware`) or two (`energy`: a bond takes the mean of
/// its ends' factors) from every surface keep their bond weights bit for bit with the lattice
/// target; with the classical target they all get the same ones (the full family's fit, bit for
/// bit), which differ from the uncorrected ones (the lattice's anisotropy is corrected); nodes
/// at a surface are corrected. (The weighted volume `m` is the moments' trace, the same for
/// every node the classical target matches.)
#[test]
fn interior_nodes_are_left_exactly_unchanged_or_all_corrected_alike() {
    let (dim, nodes, p) = (2, 16, variants()[3].2);
    let g = grid(dim, nodes);
    let plain = LpsModel::new(&g, &p).unwrap();
    for target in [SurfaceTarget::Lattice, SurfaceTarget::Classical] {
        for (c, reach) in [(SurfaceCorrection::PositionAware, 1.0), (SurfaceCorrection::Energy, 2.0)] {
            let (m, _) = plain.clone().corrected_to(c, target).unwrap();
            let mut interior = None;
            let mut checked = 0;
            for (i, x) in g.positions().iter().enumerate() {
                let to_surface =
                    (0..dim).map(|a| x[a].min((nodes - 1) as f64 * H - x[a])).fold(f64::INFINITY, f64::min);
                let what = format!("{} {}: node {i} at {x:?}", target.name(), c.name());
                let (w, w_plain) = (m.bond_weights(i), plain.bond_weights(i));
                if to_surface > reach * p.horizon * (1.0 + 1e-9) {
                    match target {
                        SurfaceTarget::Lattice => assert_eq!(w, w_plain, "{what}"),
                        SurfaceTarget::Classical => {
                            assert_ne!(w, w_plain, "{what}");
                            assert_eq!(w, *interior.get_or_insert(w), "{what}");
                        }
                    }
                    checked += 1;
                } else if to_surface < 0.5 * p.horizon {
                    assert_ne!(w, w_plain, "{what}: surface node not corrected");
                }
            }
            assert!(checked > 0);
        }
    }
}

/// The classical energy density of a strain `diag(e)` for the LPS parameters (3D, or the
/// plane model's 2D elasticity).
fn classical_energy(p: &LpsParams, dim: usize, e: &[f64]) -> f64 {
    let (k, g) = (p.K, p.G);
    let tr: f64 = e.iter().sum();
    match (dim, p.plane) {
        (3, _) => 0.5 * k * tr * tr + g * (e.iter().map(|x| x * x).sum::<f64>() - tr * tr / 3.0),
        (2, Some(PlaneModel::Stress)) => {
            let (young, nu) = (9.0 * k * g / (3.0 * k + g), (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g)));
            0.5 * young / (1.0 - nu * nu) * (e[0] * e[0] + e[1] * e[1] + 2.0 * nu * e[0] * e[1])
        }
        _ => 0.5 * ((k + 4.0 * g / 3.0) * (e[0] * e[0] + e[1] * e[1]) + 2.0 * (k - 2.0 * g / 3.0) * e[0] * e[1]),
    }
}

/// `position_aware`: for an affine field `u = H x` whose strain is diagonal in the lattice axes
/// (random normal strains plus a random linearized rotation) every node, corners included, has
/// the dilatation `tr H` and, with the lattice target, the interior's energy density, with the
/// classical target the classical one, to 1e-12 relative (Newton stops at 1e-13 of the moments;
/// sums over ~30-120 bonds); without the correction the surface nodes are off by 20-100 %, and
/// the uncorrected interior misses the classical energy by the lattice's anisotropy (2.4e-4..0.14).
#[test]
fn position_aware_nodes_respond_to_affine_fields_as_the_interior_or_classically() {
    for (dim, nodes, p) in variants() {
        for target in [SurfaceTarget::Lattice, SurfaceTarget::Classical] {
            position_aware_affine_response(dim, nodes, p, target);
        }
    }
}

fn position_aware_affine_response(dim: usize, nodes: usize, p: LpsParams, target: SurfaceTarget) {
    {
        let g = grid(dim, nodes);
        let plain = LpsModel::new(&g, &p).unwrap();
        let (m, _) = plain.clone().corrected_to(SurfaceCorrection::PositionAware, target).unwrap();
        let r = random_vec(12, 5);
        // diagonal strain + skew part (a rotation stores no energy in the linearized model)
        let mut hm = [0.0; 9];
        for a in 0..3 {
            hm[4 * a] = r[a];
        }
        for (a, b, w) in [(0, 1, r[3]), (1, 2, r[4]), (0, 2, r[5])] {
            hm[3 * a + b] = w;
            hm[3 * b + a] = -w;
        }
        let hm = &hm;
        let u: Vec<f64> = g
            .positions()
            .iter()
            .flat_map(|x| (0..dim).map(move |a| (0..dim).map(|b| hm[3 * a + b] * x[b]).sum::<f64>()))
            .collect();
        let tr: f64 = (0..dim).map(|a| hm[3 * a + a]).sum();
        let theta = m.linearized_theta(&u);
        let w = m.linearized_energy_density(&u);
        // the interior value: a node of a large enough model's centre, uncorrected
        let big = grid(dim, 4 * (p.horizon / H).ceil() as usize + 1);
        let centre = big.len() / 2;
        let ub: Vec<f64> = big
            .positions()
            .iter()
            .flat_map(|x| (0..dim).map(move |a| (0..dim).map(|b| hm[3 * a + b] * x[b]).sum::<f64>()))
            .collect();
        let w_interior = LpsModel::new(&big, &p).unwrap().linearized_energy_density(&ub)[centre];
        let diag: Vec<f64> = (0..dim).map(|a| hm[4 * a]).collect();
        let w_classical = classical_energy(&p, dim, &diag);
        let w0 = if target == SurfaceTarget::Lattice { w_interior } else { w_classical };
        let theta_err = theta.iter().fold(0.0f64, |x, t| x.max((t - tr).abs())) / tr.abs();
        let w_err = w.iter().fold(0.0f64, |x, v| x.max((v - w0).abs())) / w0;
        let w_plain = plain.linearized_energy_density(&u).iter().fold(0.0f64, |x, v| x.max((v - w0).abs())) / w0;
        let anisotropy = (w_interior - w_classical).abs() / w_classical;
        eprintln!(
            "dim {dim} {:?} {}: theta {theta_err:.1e}, W {w_err:.1e} (uncorrected {w_plain:.1e}; \
             interior vs classical {anisotropy:.1e})",
            p.influence,
            target.name()
        );
        assert!(theta_err <= 1e-12 && w_err <= 1e-12, "theta {theta_err:e}, W {w_err:e}");
        assert!(w_plain > 1e-2, "the uncorrected model should miss at the surface: {w_plain:e}");
        // measured 2.4e-4 (2D, partial volumes) .. 0.14 (3D, constant influence)
        assert!(anisotropy > 1e-5, "the lattice interior should miss the classical energy: {anisotropy:e}");
    }
}

/// `max |A r|` over the rigid motions `r` (translations and linearized rotations, unit size).
fn rigid_residual(m: &LpsModel, ad: &[Vec<f64>]) -> f64 {
    let dim = m.dim();
    let x = m.positions();
    let mut modes: Vec<Vec<f64>> = (0..dim).map(|a| (0..ad.len()).map(|k| f64::from(k % dim == a)).collect()).collect();
    let pairs: &[(usize, usize)] = if dim == 3 { &[(0, 1), (1, 2), (0, 2)] } else { &[(0, 1)] };
    for &(a, b) in pairs {
        let mut r = vec![0.0; ad.len()];
        for (i, p) in x.iter().enumerate() {
            r[dim * i + a] = -p[b];
            r[dim * i + b] = p[a];
        }
        modes.push(r);
    }
    modes
        .iter()
        .map(|r| ad.iter().map(|row| row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>().abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max)
}

/// True when `A` restricted to the nodes off the plane `x = 0` (which holds every rigid motion
/// fixed) has a Cholesky factor: then `A` is positive semi-definite with no zero-energy mode
/// besides the rigid motions.
fn definite_without_the_first_layer(m: &LpsModel, ad: &[Vec<f64>]) -> bool {
    let dim = m.dim();
    let keep: Vec<usize> = (0..ad.len()).filter(|&k| m.positions()[k / dim][0] > 0.5 * H).collect();
    let a = faer::Mat::<f64>::from_fn(keep.len(), keep.len(), |r, c| ad[keep[r]][keep[c]]);
    a.llt(faer::Side::Lower).is_ok()
}

/// The moment-matching corrections rescale the weights: a second correction (or undoing one)
/// is a named error, not a silent compounding of the factors.
#[test]
fn corrections_do_not_compose() {
    let (dim, nodes, p) = variants()[3];
    let (m, _) = LpsModel::new(&grid(dim, nodes), &p).unwrap().corrected(SurfaceCorrection::Energy).unwrap();
    for again in [SurfaceCorrection::Energy, SurfaceCorrection::PositionAware, SurfaceCorrection::None] {
        let e = m.clone().corrected(again).unwrap_err().to_string();
        assert!(e.contains("energy"), "{e}");
    }
}
