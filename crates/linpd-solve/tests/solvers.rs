//! The solvers agree on SPD systems, reuse symbolic analyses, and name the failing DOF.

use faer::sparse::{SparseColMat, Triplet};
use linpd_solve::{
    gmres, solve_assembled, CgParams, Cholesky, FactorPreconditioner, GmresParams, Identity, Lu, LuOrdering,
    MatrixHints, SolveError, SolverSpec,
};

fn solve(
    a: &SparseColMat<usize, f64>,
    b: &[f64],
    spec: &SolverSpec,
) -> Result<(Vec<f64>, linpd_solve::SolveReport), SolveError> {
    solve_assembled(a, b, spec, &MatrixHints::symmetric(2))
}

/// `||A u - b|| / ||b||` from the entries of `A`, without the library's products.
fn residual_by_entries(a: &SparseColMat<usize, f64>, u: &[f64], b: &[f64]) -> f64 {
    let mut r: Vec<f64> = b.iter().map(|v| -v).collect();
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            r[i] += v * u[j];
        }
    }
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    norm(&r) / norm(b)
}

/// A convection-diffusion matrix on an `nx` x `nx` grid: `spd(nx)` plus a skew first-order
/// term of strength `c` (unsymmetric, nonsingular: its symmetric part is `spd`).
fn unsym(nx: usize, c: f64) -> SparseColMat<usize, f64> {
    let a = spd(nx);
    let mut t = Vec::new();
    for j in 0..a.ncols() {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            t.push(Triplet::new(i, j, *v));
        }
    }
    for k in 0..nx * nx {
        if (k + 1) % nx != 0 {
            t.push(Triplet::new(k, k + 1, c));
            t.push(Triplet::new(k + 1, k, -c));
        }
    }
    SparseColMat::try_new_from_triplets(nx * nx, nx * nx, &t).unwrap()
}

/// A shifted 2D grid Laplacian with a seeded pseudo-random diagonal: SPD, kappa ~ 1e3.
fn spd(nx: usize) -> SparseColMat<usize, f64> {
    let n = nx * nx;
    let mut t = Vec::new();
    let mut seed = 12345u64;
    for i in 0..nx {
        for j in 0..nx {
            let k = i * nx + j;
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let shift = 1e-2 * ((seed >> 11) as f64 / (1u64 << 53) as f64);
            t.push(Triplet::new(k, k, 4.0 + shift));
            if i + 1 < nx {
                t.push(Triplet::new(k, k + nx, -1.0));
                t.push(Triplet::new(k + nx, k, -1.0));
            }
            if j + 1 < nx {
                t.push(Triplet::new(k, k + 1, -1.0));
                t.push(Triplet::new(k + 1, k, -1.0));
            }
        }
    }
    SparseColMat::try_new_from_triplets(n, n, &t).unwrap()
}

#[test]
fn direct_iterative_and_dense_solvers_agree() {
    let a = spd(30);
    let n = a.nrows();
    let b: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let cg = SolverSpec::cg(CgParams { rtol: 1e-12, max_iter: 5000 });
    let mut sols = Vec::new();
    for spec in [SolverSpec::Cholesky, SolverSpec::Lu, SolverSpec::Dense, cg] {
        let (u, rep) = solve(&a, &b, &spec).unwrap();
        // Backward-stable direct solves: residual ~ eps * kappa; CG stops at 1e-12.
        assert!(rep.rel_residual < 1e-11, "{}: residual {:e}", rep.solver, rep.rel_residual);
        // The reported residual is the true one: recomputed here from the entries (the two
        // sums differ in order only: n * eps relative to ||A|| ||u|| / ||b|| ~ 1e3).
        let independent = residual_by_entries(&a, &u, &b);
        assert!(
            (independent - rep.rel_residual).abs() <= 1e-13,
            "{}: {independent:e} vs {:e}",
            rep.solver,
            rep.rel_residual
        );
        sols.push(u);
    }
    // kappa(A) <= 8/0.0 ... ~ (4+4)/(4-4 cos(pi/31)*2 ...) < 1e3, so solutions agree to ~1e-9.
    for s in &sols[1..] {
        let d = s.iter().zip(&sols[0]).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        let m = sols[0].iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(d <= 1e-9 * m, "solutions differ by {d:e}");
    }
}

#[test]
fn symbolic_analysis_is_reused_for_new_values() {
    let a = spd(20);
    let chol = Cholesky::analyze(&a).unwrap();
    // Same pattern, doubled values: the solution halves.
    let a2 = SparseColMat::new(a.symbolic().to_owned().unwrap(), a.val().iter().map(|v| 2.0 * v).collect());
    let b = vec![1.0; a.nrows()];
    let f1 = chol.factor(&a).unwrap();
    let f2 = chol.factor(&a2).unwrap();
    let (u1, u2) = (f1.solve(&b), f2.solve(&b));
    for (p, q) in u1.iter().zip(&u2) {
        assert!((p - 2.0 * q).abs() <= 1e-12 * p.abs().max(1.0));
    }
    // Both factors hold the one analysis.
    assert_eq!(chol.share_count(), 3);
}

#[test]
fn zero_pivot_names_the_original_dof() {
    // Decouple DOF 137 entirely and zero its diagonal: whatever the AMD permutation, the
    // error must point at 137.
    // 20x20 is factored simplicially, 150x150 supernodally: both index conventions are checked.
    for (nx, bad) in [(20, 137), (150, 11_111)] {
        let a = spd(nx);
        let n = a.nrows();
        let mut t = Vec::new();
        for j in 0..n {
            for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                let v = if i == bad || j == bad { 0.0 } else { *v };
                t.push(Triplet::new(i, j, v));
            }
        }
        let a = SparseColMat::try_new_from_triplets(n, n, &t).unwrap();
        match solve(&a, &vec![1.0; n], &SolverSpec::Cholesky) {
            Err(SolveError::NotPositiveDefinite { dof }) => assert_eq!(dof, bad),
            other => panic!("expected a zero pivot at {bad}, got {other:?}"),
        }
        // Dense Cholesky in the natural order meets the zero pivot at `bad` itself (every
        // earlier pivot is that of an SPD matrix); 150^2 unknowns exceed its limit.
        match solve(&a, &vec![1.0; n], &SolverSpec::Dense) {
            Err(SolveError::NotPositiveDefinite { dof }) if nx == 20 => assert_eq!(dof, bad),
            Err(SolveError::TooLargeForDense { n: m, limit }) if nx == 150 => assert!(m > limit),
            other => panic!("nx = {nx}: unexpected {other:?}"),
        }
        // Jacobi sees the zero diagonal before the first iteration.
        match solve(&a, &vec![1.0; n], &SolverSpec::cg(CgParams::default())) {
            Err(SolveError::Cg(linpd_solve::CgError::Breakdown { iteration: 0, curvature })) => {
                assert_eq!(curvature, 0.0)
            }
            other => panic!("expected a Jacobi breakdown, got {other:?}"),
        }
    }
}

#[test]
fn lu_solves_unsymmetric_systems_and_reuses_its_analysis() {
    let a = unsym(20, 0.7);
    let n = a.nrows();
    let b: Vec<f64> = (0..n).map(|i| ((i * 13) % 7) as f64 - 3.0).collect();
    for ordering in [LuOrdering::Colamd, LuOrdering::Band] {
        let lu = Lu::analyze(&a, ordering).unwrap();
        let u = lu.factor(&a).unwrap().solve(&b);
        // Partial pivoting is backward stable: residual ~ eps * kappa (kappa < 1e3 here).
        let r = residual_by_entries(&a, &u, &b);
        assert!(r < 1e-13, "{ordering:?}: residual {r:e}");
        // Same pattern, values doubled: the same analysis factors it, the solution halves.
        let a2 = SparseColMat::new(a.symbolic().to_owned().unwrap(), a.val().iter().map(|v| 2.0 * v).collect());
        let u2 = lu.factor(&a2).unwrap().solve(&b);
        let worst = u.iter().zip(&u2).map(|(p, q)| (p - 2.0 * q).abs()).fold(0.0, f64::max);
        assert!(worst <= 1e-12 * u.iter().fold(0.0f64, |m, v| m.max(v.abs())), "{ordering:?}: {worst:e}");
    }
    // The dispatch sends an unsymmetric matrix to LU whatever was asked, and says so; the
    // reported residual uses the unsymmetric product.
    let hints = MatrixHints { asymmetry: 0.1, ..MatrixHints::symmetric(2) };
    let (u, rep) = solve_assembled(&a, &b, &SolverSpec::Cholesky, &hints).unwrap();
    assert_eq!(rep.solver, linpd_solve::SolverId::Lu);
    assert!(rep.note.as_deref().unwrap_or_default().contains("unsymmetric"));
    assert!((rep.rel_residual - residual_by_entries(&a, &u, &b)).abs() <= 1e-14);
}

#[test]
fn gmres_converges_and_a_good_preconditioner_cuts_iterations() {
    let a = unsym(24, 0.5);
    let n = a.nrows();
    let b: Vec<f64> = (0..n).map(|i| ((i * 29) % 13) as f64 - 6.0).collect();
    let params = GmresParams { rtol: 1e-10, restart: 40, max_iter: 2000 };
    let mut x0 = vec![0.0; n];
    let plain = gmres(&linpd_solve::GeneralCsc(&a), &Identity, &b, &mut x0, &params).unwrap();
    assert!(residual_by_entries(&a, &x0, &b) <= 1e-10, "unpreconditioned residual");
    // M = the symmetric part, factored: A M^{-1} = I + (skew) M^{-1}, a small perturbation.
    let m = spd(24);
    let fac = Cholesky::analyze(&m).unwrap().factor(&m).unwrap();
    let mut x1 = vec![0.0; n];
    let pre = gmres(&linpd_solve::GeneralCsc(&a), &FactorPreconditioner(fac), &b, &mut x1, &params).unwrap();
    assert!(residual_by_entries(&a, &x1, &b) <= 1e-10, "preconditioned residual");
    assert!((pre.rel_residual - residual_by_entries(&a, &x1, &b)).abs() <= 1e-14);
    assert!(
        pre.iterations * 3 <= plain.iterations,
        "preconditioned {} vs plain {} iterations",
        pre.iterations,
        plain.iterations
    );
}
