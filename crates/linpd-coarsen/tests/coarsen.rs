//! Tests of the coarsening step against the defining properties (8), (9) and static
//! condensation, on the level-0 bar of Silling (2010), Example 5.1 (the paper's examples
//! themselves are tests of linpd-studies, `tests/coarsen_examples.rs`).
#![allow(clippy::needless_range_loop)]

mod common;
// Example 5.1's level 0 (spacing = volume H = v, r0 = 10 v, tent C^0) and the dense Gaussian
// elimination, independent of the crate.
use common::paper::{gauss, tent, H, R0};
use common::solve_dirichlet;
use linpd_coarsen::{coarsen, coarsen_with, every_kth, local_resolvent, CoarsenError, LevelModel, Matching, Options};

fn opts(radius: f64, matching: Matching) -> Options {
    Options { matching, ..Options::fixed(radius) }
}

/// 1D positions.
fn xs(m: &LevelModel) -> Vec<f64> {
    m.positions().iter().map(|p| p[0]).collect()
}

const N: usize = 201; // bar [0, 1]

fn level0() -> LevelModel {
    bar(N)
}

fn bar(n: usize) -> LevelModel {
    let x: Vec<f64> = (0..n).map(|i| i as f64 * H).collect();
    LevelModel::from_kernel(x, vec![H; n], R0, tent).unwrap()
}

/// Deterministic pseudo-random numbers in [-1, 1].
fn lcg(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
        .collect()
}

/// Checks property (9) for every retained node: with the excluded nodes of N_x in equilibrium
/// (3)-(5) (solved here independently by block elimination), the level-(m-1) force density at x
/// equals the level-m force density. Returns the worst relative mismatch.
fn check_property_9(
    fine: &LevelModel,
    parent: &[usize],
    coarse: &LevelModel,
    radius: f64,
    seed: u64,
    matching: Matching,
) -> f64 {
    let um = lcg(coarse.len(), seed);
    let mut is_ret = vec![false; fine.len()];
    let mut cidx = vec![usize::MAX; fine.len()];
    for (k, &p) in parent.iter().enumerate() {
        is_ret[p] = true;
        cidx[p] = k;
    }
    let x = xs(fine);
    let mut worst: f64 = 0.0;
    for (k, &xi) in parent.iter().enumerate() {
        assert!(fine.horizon_of(xi) <= radius + 1e-12, "r^m must cover the level-(m-1) bonds of x");
        let hood: Vec<usize> = (0..fine.len()).filter(|&p| (x[p] - x[xi]).abs() <= radius * (1.0 + 1e-12)).collect();
        let excl: Vec<usize> = hood.iter().copied().filter(|&p| !is_ret[p]).collect();
        let pos = |p: usize| excl.iter().position(|&z| z == p);
        // u^{m-1} = u^m on R_x (2); equilibrium (3) on excluded, interactions inside N_x (4)
        let mut a = vec![vec![0.0; excl.len()]; excl.len()];
        let mut b = vec![0.0; excl.len()];
        for (row, &z) in excl.iter().enumerate() {
            for (p, c) in fine.bonds_1d(z) {
                if (x[p] - x[xi]).abs() > radius * (1.0 + 1e-12) {
                    continue;
                }
                let w = c * fine.volumes()[p];
                a[row][row] -= w;
                match pos(p) {
                    Some(col) => a[row][col] += w,
                    None => b[row] -= w * um[cidx[p]],
                }
            }
        }
        let ue = gauss(a, b);
        let mut u0 = vec![f64::NAN; fine.len()];
        for &p in &hood {
            u0[p] = if is_ret[p] { um[cidx[p]] } else { ue[pos(p).unwrap()] };
        }
        // (9): force density (as printed) or nodal force = density x node volume
        let (wf, wc) = match matching {
            Matching::ForceDensity => (1.0, 1.0),
            Matching::TotalForce => (fine.volumes()[xi], coarse.volumes()[k]),
        };
        let l_fine = wf * fine.force_density_at(xi, &u0)[0];
        let l_coarse = wc * coarse.force_density_at(k, &um)[0];
        let scale: f64 =
            wf * fine.bonds_1d(xi).map(|(p, c)| (c * fine.volumes()[p] * (u0[p] - u0[xi])).abs()).sum::<f64>();
        worst = worst.max((l_fine - l_coarse).abs() / scale);
    }
    worst
}

#[test]
fn resolvent_rows_sum_to_one_eq8_and_retained_rows_are_identity_eq7() {
    let m0 = level0();
    let ret = every_kth(N, 4);
    let mut is_ret = vec![false; N];
    ret.iter().for_each(|&p| is_ret[p] = true);
    for &xi in &[0usize, 100, 200] {
        let loc = local_resolvent(&m0, &is_ret, xi, 0.1).unwrap();
        for p in 0..loc.nodes.len() {
            let row: f64 = (0..loc.n_retained).map(|q| loc.s[(p, q)]).sum();
            assert!((row - 1.0).abs() < 1e-12, "row {p} sums to {row}");
            if p < loc.n_retained {
                for q in 0..loc.n_retained {
                    let e = if p == q { 1.0 } else { 0.0 };
                    assert!((loc.s[(p, q)] - e).abs() < 1e-14);
                }
            }
        }
    }
}

#[test]
fn force_equality_property_eq9_two_levels() {
    let m0 = level0();
    for matching in [Matching::TotalForce, Matching::ForceDensity] {
        let c1 = coarsen_with(&m0, &every_kth(N, 4), &opts(0.1, matching)).unwrap();
        let e1 = check_property_9(&m0, &c1.parent, &c1.model, 0.1, 7, matching);
        let c2 = coarsen_with(&c1.model, &every_kth(c1.model.len(), 2), &opts(0.2, matching)).unwrap();
        let e2 = check_property_9(&c1.model, &c2.parent, &c2.model, 0.2, 11, matching);
        println!("property (9) {matching:?}: max rel. mismatch level 1 = {e1:.2e}, level 2 = {e2:.2e}");
        assert!(e1 < 1e-11 && e2 < 1e-11);
    }
}

#[test]
fn force_equality_property_eq9_nonuniform_volumes() {
    // irregular spacing and volumes: the v factors must still be right
    let jit = lcg(N, 3);
    let x: Vec<f64> = (0..N).map(|i| i as f64 * H + 0.3 * H * jit[i]).collect();
    let v: Vec<f64> = (0..N).map(|i| H * (1.0 + 0.5 * jit[(i * 7) % N])).collect();
    let m0 = LevelModel::from_kernel(x, v, R0, tent).unwrap();
    for matching in [Matching::TotalForce, Matching::ForceDensity] {
        let c1 = coarsen_with(&m0, &every_kth(N, 3), &opts(0.1, matching)).unwrap();
        let e = check_property_9(&m0, &c1.parent, &c1.model, 0.1, 5, matching);
        println!("property (9) {matching:?}, non-uniform grid: max rel. mismatch = {e:.2e}");
        assert!(e < 1e-11);
    }
}

#[test]
fn printed_formula_is_off_by_v() {
    // Printed: C^1_ij = v sum_k C^0_ik S_kj with C^0_ik = v C^0(x_i,x_k) (volume-weighted entries)
    // and S = columns of A^{-1}. The force it gives, sum_j C^1_ij (u_j - u_i), versus L^0(x).
    let m0 = level0();
    let ret = every_kth(N, 4);
    let mut is_ret = vec![false; N];
    ret.iter().for_each(|&p| is_ret[p] = true);
    let xi = 100;
    let loc = local_resolvent(&m0, &is_ret, xi, 0.1).unwrap();
    let u = lcg(loc.n_retained, 9);
    let mut printed = 0.0;
    let mut derived = 0.0;
    let ux = u[loc.nodes[..loc.n_retained].iter().position(|&p| p == xi).unwrap()];
    for q in 0..loc.n_retained {
        let mut sum = 0.0;
        for (k, &p) in loc.nodes.iter().enumerate() {
            sum += H * m0.micromodulus(xi, p)[0] * loc.s[(k, q)]; // C^0_ik S_kj
        }
        printed += H * sum * (u[q] - ux);
        derived += sum * (u[q] - ux);
    }
    let ratio = printed / derived;
    println!("printed / property-derived coarse force = {ratio:.6e} (v = {H})");
    assert!((ratio - H).abs() < 1e-12);
}

#[test]
fn whole_body_neighbourhood_is_static_condensation() {
    let m0 = level0();
    let ret1 = every_kth(N, 4);
    // body force density on retained nodes only (eq. (5)), Dirichlet ends
    let mut b0 = vec![0.0; N];
    for (k, &p) in ret1.iter().enumerate() {
        if k % 2 == 0 {
            b0[p] = 1.0 + (p as f64 * H);
        }
    }
    let f0: Vec<f64> = (0..N).map(|p| b0[p] * m0.volumes()[p]).collect();
    let u0 = solve_dirichlet(&m0, &f0, &[(0, 0.0), (N - 1, 0.0)]).unwrap();
    let umax = u0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for matching in [Matching::TotalForce, Matching::ForceDensity] {
        // coarse body force: the nodal force is conserved (TotalForce) or the density (ForceDensity)
        let lump = |fine: &LevelModel, coarse: &LevelModel, parent: &[usize], b: &[f64]| -> Vec<f64> {
            parent
                .iter()
                .enumerate()
                .map(|(k, &p)| match matching {
                    Matching::TotalForce => b[p] * fine.volumes()[p] / coarse.volumes()[k],
                    Matching::ForceDensity => b[p],
                })
                .collect()
        };
        let c1 = coarsen_with(&m0, &ret1, &opts(10.0, matching)).unwrap();
        let b1 = lump(&m0, &c1.model, &c1.parent, &b0);
        let n1 = c1.model.len();
        let f1: Vec<f64> = (0..n1).map(|k| b1[k] * c1.model.volumes()[k]).collect();
        let u1 = solve_dirichlet(&c1.model, &f1, &[(0, 0.0), (n1 - 1, 0.0)]).unwrap();
        let err1 = c1.parent.iter().zip(&u1).map(|(&p, &u)| (u - u0[p]).abs()).fold(0.0, f64::max) / umax;

        let c2 = coarsen_with(&c1.model, &every_kth(n1, 2), &opts(10.0, matching)).unwrap();
        let b2 = lump(&c1.model, &c2.model, &c2.parent, &b1);
        let n2 = c2.model.len();
        let f2: Vec<f64> = (0..n2).map(|k| b2[k] * c2.model.volumes()[k]).collect();
        let u2 = solve_dirichlet(&c2.model, &f2, &[(0, 0.0), (n2 - 1, 0.0)]).unwrap();
        let err2 = c2.parent.iter().zip(&u2).map(|(&p, &u)| (u - u0[c1.parent[p]]).abs()).fold(0.0, f64::max) / umax;
        println!(
            "static condensation {matching:?}: {N} -> {n1} -> {n2} nodes, max|u| = {umax:.4e}, rel. error level 1 = {err1:.2e}, level 2 = {err2:.2e}, asym C1 = {:.1e}, C2 = {:.1e}",
            c1.model.asymmetry(),
            c2.model.asymmetry()
        );
        assert!(err1 < 1e-10 && err2 < 1e-10);
        if matching == Matching::TotalForce {
            // condensed nodal stiffness / (v_x v_q): symmetric for any coarse volumes
            assert!(c1.model.asymmetry() < 1e-12 && c2.model.asymmetry() < 1e-12);
        }
    }
}

#[test]
fn isolated_excluded_node_is_an_error_not_a_panic() {
    let m0 = level0();
    // node 5 (excluded by every-4th) loses all its bonds
    let bonds: Vec<Vec<(usize, f64)>> =
        (0..N).map(|i| if i == 5 { vec![] } else { m0.bonds_1d(i).filter(|b| b.0 != 5).collect() }).collect();
    let m = LevelModel::from_bonds_1d(xs(&m0), m0.volumes().to_vec(), bonds).unwrap();
    let err = coarsen(&m, &every_kth(N, 4), 0.1).unwrap_err();
    println!("{err}");
    match &err {
        CoarsenError::SingularLocal { excluded, .. } => assert_eq!(*excluded, 5),
        e => panic!("unexpected {e:?}"),
    }
    assert!(err.to_string().contains("increase the coarsening radius"));
}

#[test]
fn bad_radius_and_retained_sets_are_clear_errors() {
    let m0 = level0();
    let ret = every_kth(N, 4);
    // r^m below the level's horizon (0.05): bonds of x would be cut
    let err = coarsen(&m0, &ret, 0.03).unwrap_err();
    println!("{err}");
    assert!(matches!(err, CoarsenError::RadiusBelowHorizon { .. }), "{err:?}");
    assert!(err.to_string().contains("smaller than the horizon"));
    // empty, foreign (not a subset of B^(m-1)) and duplicated retained sets
    let e = coarsen(&m0, &[], 0.1).unwrap_err().to_string();
    assert!(e.contains("empty"), "{e}");
    let e = coarsen(&m0, &[0, 4, N + 3], 0.1).unwrap_err().to_string();
    assert!(e.contains(&format!("retained node {}", N + 3)) && e.contains("subset"), "{e}");
    let e = coarsen(&m0, &[0, 4, 4], 0.1).unwrap_err().to_string();
    assert!(e.contains("listed twice"), "{e}");
    // non-finite radius
    assert!(coarsen(&m0, &ret, f64::NAN).is_err());
}

/// The load transfer `F^m = S^T F^{m-1}` ([`linpd_coarsen::Transfer`]), loads on *every* node:
/// with whole-body neighbourhoods the coarse solution equals the fine one at the retained nodes
/// for both matchings (the transfer is the Schur complement's right-hand side; 1e-10, the
/// bound of the static-condensation test above); with a finite radius, the transfer row of `x`
/// is the transpose of column `x` of its own resolvent `S^x` (eq. (14), from the independent
/// full solve of [`local_resolvent`]; the local problems are symmetric: 1e-12 relative).
#[test]
fn load_transfer_is_the_schur_right_hand_side_and_the_transpose_of_s() {
    let m0 = level0();
    let ret1 = every_kth(N, 4);
    let f0: Vec<f64> = lcg(N, 7).iter().map(|t| t * H).collect();
    let fixed0 = [(0, 0.0), (N - 1, 0.0)];
    // the fine solution's loads on the held ends are reactions: drop them before transferring
    let mut f0_free = f0.clone();
    f0_free[0] = 0.0;
    f0_free[N - 1] = 0.0;
    let u0 = solve_dirichlet(&m0, &f0_free, &fixed0).unwrap();
    let umax = u0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for matching in [Matching::TotalForce, Matching::ForceDensity] {
        let c1 = coarsen_with(&m0, &ret1, &opts(10.0, matching)).unwrap();
        let f1 = c1.transfer.restrict(&f0_free);
        let n1 = c1.model.len();
        let u1 = solve_dirichlet(&c1.model, &f1, &[(0, 0.0), (n1 - 1, 0.0)]).unwrap();
        let err = c1.parent.iter().zip(&u1).map(|(&p, &u)| (u - u0[p]).abs()).fold(0.0, f64::max) / umax;
        let total =
            (f1.iter().sum::<f64>() - f0_free.iter().sum::<f64>()).abs() / f0_free.iter().map(|t| t.abs()).sum::<f64>();
        println!("transfer, whole body, {matching:?}: rel. error at retained nodes {err:.2e}, total force change {total:.1e}");
        assert!(err < 1e-10, "{matching:?}: {err:e}");
        if matching == Matching::TotalForce {
            assert!(total < 1e-13, "{total:e}");
        }
    }
    // finite radius: T_x = (S^x_{E,x})^T, checked on a node near the end and one inside
    let r = 0.12;
    let c1 = coarsen(&m0, &ret1, r).unwrap();
    let mut is_ret = vec![false; N];
    ret1.iter().for_each(|&p| is_ret[p] = true);
    for k in [1usize, 25] {
        let x = c1.parent[k];
        let s = local_resolvent(&m0, &is_ret, x, r).unwrap();
        let xl = s.nodes[..s.n_retained].iter().position(|&p| p == x).unwrap();
        // transfer of a unit force on each excluded node p of N_x, read at x
        let mut worst: f64 = 0.0;
        for e in s.n_retained..s.nodes.len() {
            let mut f = vec![0.0; N];
            f[s.nodes[e]] = 1.0;
            let got = c1.transfer.restrict(&f)[k];
            worst = worst.max((got - s.s[(e, xl)]).abs());
        }
        println!("transfer row of retained node {x} vs column of S^x: max difference {worst:.1e}");
        assert!(worst < 1e-12, "node {x}: {worst:e}");
    }
}
