//! The geometric top level of the lattice multigrid ([`LatticeMultigrid`]): the interpolation
//! reproduces affine fields and `R = P^T`, PCG with it agrees with sparse Cholesky on clamped
//! and roller-supported 3D lattices in few iterations that stay flat in the size, its V-cycle
//! is symmetric positive definite, and only the models it suits offer a coarse lattice.

use linpd_bond::{BondOperator, LatticeBondModel};
use linpd_core::{
    BondRule, DofMap, Grid, Kernel, Material, Micromodulus, Model, Normalization, Placement, PlaneModel, Region,
};
use linpd_solve::{pcg, AmgParams, CgParams, Cholesky, CoarseSpace, LatticeMultigrid, Preconditioner, ReducedOperator};

fn micromodulus(dim: usize) -> Micromodulus {
    Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane: (dim == 2).then_some(PlaneModel::Stress),
        partial_volume: false,
    }
}

/// The homogeneous stencil model on `nodes^dim` sites, spacing 1, horizon `m`.
fn model(dim: usize, nodes: usize, m: f64) -> LatticeBondModel {
    let max = vec![(nodes - 1) as f64; dim];
    let grid = Grid::new(&vec![0.0; dim], &max, 1.0, 0.0, Placement::Vertex).unwrap();
    LatticeBondModel::stencil(grid, m, micromodulus(dim)).unwrap()
}

/// The free DOFs of `model`: component `c` of the node at lattice index `k` is held when
/// `fixed(k, c)`.
fn dofs(model: &LatticeBondModel, fixed: impl Fn([i64; 3], usize) -> bool) -> DofMap {
    let d = model.dim();
    let g = model.grid();
    let mask: Vec<bool> = (0..d * g.len()).map(|dof| fixed(g.lattice_index(dof / d), dof % d)).collect();
    DofMap::new(d, &mask)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// An affine field `u(x) = G x + c` on the coarse sites becomes the same field on the fine
/// sites, to round-off (`1e-14` relative: each fine value is a sum of at most 8 weighted
/// values, the weights exact), for odd and even site counts (the even ones extend the coarse
/// lattice one spacing beyond the fine box). `R = P^T`: `y . (P x) = x . (R y)` to `1e-13`.
#[test]
fn interpolation_reproduces_affine_fields_and_restriction_is_its_transpose() {
    let g = [[0.3, -0.2, 0.5], [0.1, 0.7, -0.4], [-0.6, 0.2, 0.25]];
    let c = [1.0, -2.0, 0.5];
    let affine = |x: linpd_core::Point, q: usize| c[q] + (0..3).map(|a| g[q][a] * x[a]).sum::<f64>();
    for nodes in [9, 10] {
        let fine = model(3, nodes, 3.0);
        let free = DofMap::all_free(fine.n_nodes(), 3);
        let space = CoarseSpace::new(&fine, &free, &fine.diagonal())
            .expect("a 3D stencil with delta = 3h has a coarse lattice");
        let coarse = space.model();
        assert_eq!(space.dofs().n_free(), 3 * coarse.n_nodes());
        let xc: Vec<f64> = (0..3 * coarse.n_nodes()).map(|dof| affine(coarse.position(dof / 3), dof % 3)).collect();
        let mut x = vec![0.0; 3 * fine.n_nodes()];
        space.interpolate_add(&xc, &mut x);
        let want: Vec<f64> = (0..x.len()).map(|dof| affine(fine.position(dof / 3), dof % 3)).collect();
        let err: Vec<f64> = x.iter().zip(&want).map(|(a, b)| a - b).collect();
        assert!(max_abs(&err) <= 1e-14 * max_abs(&want), "{nodes}^3: affine field off by {:e}", max_abs(&err));
        let y: Vec<f64> = (0..x.len()).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
        let mut ry = vec![0.0; xc.len()];
        space.restrict(&y, &mut ry);
        let dot = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(a, b)| a * b).sum::<f64>();
        let (a, b) = (dot(&y, &x), dot(&xc, &ry));
        assert!((a - b).abs() <= 1e-13 * a.abs().max(b.abs()), "{nodes}^3: y.Px = {a}, x.Ry = {b}");
    }
}

/// Coarse components are unknowns exactly where a free fine DOF of the same component
/// interpolates from them: clamping the planes `x <= 2` holds the coarse sites `x <= 1` (whose
/// fine sites are all held) and frees the one at `x = 2` (it reaches the free `x = 3`).
#[test]
fn coarse_unknowns_follow_the_fine_constraints() {
    let fine = model(3, 9, 3.0);
    let free = dofs(&fine, |k, _| k[0] <= 2);
    let space = CoarseSpace::new(&fine, &free, &fine.diagonal()).unwrap();
    let coarse = space.model();
    for n in 0..coarse.n_nodes() {
        let x = coarse.position(n)[0];
        for q in 0..3 {
            assert_eq!(space.dofs().is_constrained(3 * n + q), x < 2.0, "coarse node at x = {x}");
        }
    }
}

/// Multigrid-PCG with the geometric top level, to rtol 1e-12: the solution, the iterations.
fn solve(model: &LatticeBondModel, dofs: &DofMap, load: [f64; 3]) -> (Vec<f64>, usize, String) {
    let space = CoarseSpace::new(model, dofs, &model.diagonal()).unwrap();
    let fast = model.fast_apply().unwrap();
    let cfast = space.model().fast_apply().unwrap();
    let m = LatticeMultigrid::new(&*fast.op, dofs, &space, &*cfast.op, &AmgParams::default()).unwrap();
    let f: Vec<f64> = (0..dofs.n_dofs()).map(|dof| load[dof % 3]).collect();
    let b = dofs.gather(&f);
    let mut x = vec![0.0; b.len()];
    let info =
        pcg(&ReducedOperator::new(&*fast.op, dofs), &m, &b, &mut x, &CgParams { rtol: 1e-12, max_iter: 500 }).unwrap();
    (x, info.iterations, m.summary().unwrap())
}

/// Against sparse Cholesky of the assembled `A_ff`: a cantilever clamped on `x < 3` and a
/// block on rollers (each face plane holds its normal component, plus the two components
/// that stop the rigid rotations about the x axis at one node). CG stops at a relative
/// residual of 1e-12 and `kappa(A_ff) <~ 1e4` here, so the solutions agree to ~1e-8.
/// Iteration caps 30 (measured 21 and 21; SA-AMG takes 18-19 on the same systems).
#[test]
fn agrees_with_cholesky_clamped_and_on_rollers() {
    let fine = model(3, 14, 3.0);
    let clamped = dofs(&fine, |k, _| k[0] < 3);
    let rollers = dofs(&fine, |k, c| k[c] == 0 || (k == [13, 0, 0] && c != 0) || (k == [0, 13, 0] && c == 2));
    for (what, dofs, load) in [("clamped", clamped, [0.0, 0.0, -1e-3]), ("rollers", rollers, [1e-3, 2e-3, -1e-3])] {
        let a = fine.assemble_free(&dofs);
        let f: Vec<f64> = (0..dofs.n_dofs()).map(|dof| load[dof % 3]).collect();
        let xc = Cholesky::analyze(&a).unwrap().factor(&a).unwrap().solve(&dofs.gather(&f));
        let (x, its, summary) = solve(&fine, &dofs, load);
        let err: Vec<f64> = x.iter().zip(&xc).map(|(p, q)| p - q).collect();
        eprintln!("{what}: {its} iterations, difference {:.1e}; {summary}", max_abs(&err) / max_abs(&xc));
        assert!(max_abs(&err) <= 1e-8 * max_abs(&xc), "{what}: differs from Cholesky by {:e}", max_abs(&err));
        assert!(its <= 30, "{what}: {its} iterations");
        assert!(summary.starts_with("geometric multigrid"), "{summary}");
    }
}

/// The iterations to rtol 1e-8 stay flat from 12^3 to 28^3 (max/min <= 1.3, the SA levels'
/// criterion of issue #12) under the cap 25 (measured 14-16).
#[test]
fn iterations_are_flat_in_the_size() {
    let its: Vec<usize> = [12, 20, 28]
        .iter()
        .map(|&n| {
            let fine = model(3, n, 3.0);
            let dofs = dofs(&fine, |k, _| k[0] < 3);
            let space = CoarseSpace::new(&fine, &dofs, &fine.diagonal()).unwrap();
            let fast = fine.fast_apply().unwrap();
            let cfast = space.model().fast_apply().unwrap();
            let m = LatticeMultigrid::new(&*fast.op, &dofs, &space, &*cfast.op, &AmgParams::default()).unwrap();
            let f: Vec<f64> = (0..dofs.n_dofs()).map(|dof| if dof % 3 == 2 { -1e-3 } else { 0.0 }).collect();
            let b = dofs.gather(&f);
            let mut x = vec![0.0; b.len()];
            let a = ReducedOperator::new(&*fast.op, &dofs);
            let info = pcg(&a, &m, &b, &mut x, &CgParams { rtol: 1e-8, max_iter: 500 }).unwrap();
            eprintln!("{n}^3: {} iterations", info.iterations);
            info.iterations
        })
        .collect();
    assert!(its.iter().all(|&i| i <= 25), "{its:?}");
    let (lo, hi) = (*its.iter().min().unwrap() as f64, *its.iter().max().unwrap() as f64);
    assert!(hi / lo <= 1.3, "iterations {its:?} grow with the size");
}

/// `M^{-1}` is symmetric positive definite, as CG needs: `u . M^{-1} v = v . M^{-1} u` to
/// `1e-12` relative and `u . M^{-1} u > 0`.
#[test]
fn v_cycle_is_symmetric_positive_definite() {
    let fine = model(3, 12, 3.0);
    let dofs = dofs(&fine, |k, _| k[0] < 3);
    let space = CoarseSpace::new(&fine, &dofs, &fine.diagonal()).unwrap();
    let fast = fine.fast_apply().unwrap();
    let cfast = space.model().fast_apply().unwrap();
    let params = AmgParams { max_coarse: 100, ..AmgParams::default() };
    let m = LatticeMultigrid::new(&*fast.op, &dofs, &space, &*cfast.op, &params).unwrap();
    assert!(m.coarse().stats().levels.len() >= 2, "want SA levels below the geometric one");
    let n = dofs.n_free();
    let u: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
    let v: Vec<f64> = (0..n).map(|i| ((i * 104729) % 89) as f64 / 89.0 - 0.3).collect();
    let (mut mu, mut mv) = (vec![0.0; n], vec![0.0; n]);
    m.apply(&u, &mut mu);
    m.apply(&v, &mut mv);
    let dot = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(x, y)| x * y).sum::<f64>();
    let (a, b) = (dot(&u, &mv), dot(&v, &mu));
    let norm = |p: &[f64]| dot(p, p).sqrt();
    assert!((a - b).abs() <= 1e-12 * norm(&u) * norm(&mv), "{a} vs {b}");
    assert!(dot(&u, &mu) > 0.0 && dot(&v, &mv) > 0.0);
}

/// Only 3D homogeneous stencils on the full box with `delta >= 3h` offer the coarse lattice:
/// 2D (measured worse than SA), `delta = 2h` (the coarse lattice would keep only the 6 axis
/// bonds), and a two-phase material keep the algebraic levels.
#[test]
fn only_homogeneous_3d_stencils_with_wide_horizons_have_a_coarse_lattice() {
    assert!(model(3, 10, 3.0).coarse_lattice().is_some());
    assert!(model(3, 10, 4.0).coarse_lattice().is_some());
    assert!(model(3, 10, 2.0).coarse_lattice().is_none());
    assert!(model(2, 20, 3.0).coarse_lattice().is_none());
    let grid = Grid::new(&[0.0; 3], &[9.0; 3], 1.0, 0.0, Placement::Vertex).unwrap();
    let material = Material {
        phases: vec![(Region::Box { min: vec![4.5; 3], max: vec![20.0; 3] }, 10.0)],
        rule: BondRule::Harmonic,
        defects: vec![],
    };
    let op = BondOperator::on_grid(&grid, 3.0, &micromodulus(3), &material).unwrap();
    let two_phase = LatticeBondModel::corrected(op, grid.clone(), 3.0, micromodulus(3));
    assert!(two_phase.coarse_lattice().is_none());
    // a kernel that vanishes beyond 0.6 delta: the fine lattice keeps its bonds up to sqrt(3) h
    // = 0.58 delta and is SPD, the coarse one (2h = 0.67 delta and up) would have none
    let short = Micromodulus {
        kernel: Kernel::Tabulated { s: vec![0.0, 0.55, 0.6, 1.0], g: vec![1.0, 1.0, 0.0, 0.0] },
        normalization: Normalization::Continuum,
        ..micromodulus(3)
    };
    assert!(!linpd_bond::offers_coarse_lattice(&grid, 3.0, &short));
    assert!(LatticeBondModel::stencil(grid.clone(), 3.0, short).unwrap().coarse_lattice().is_none());
    assert!(linpd_bond::offers_coarse_lattice(&grid, 3.0, &micromodulus(3)));
    // fewer than 3 sites along an axis
    let thin = Grid::new(&[0.0; 3], &[9.0, 9.0, 1.0], 1.0, 0.0, Placement::Vertex).unwrap();
    assert!(!linpd_bond::offers_coarse_lattice(&thin, 3.0, &micromodulus(3)));
}
