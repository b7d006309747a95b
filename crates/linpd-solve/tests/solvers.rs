//! The solvers agree on SPD systems, reuse symbolic analyses, and name the failing DOF.

use faer::sparse::{SparseColMat, Triplet};
use linpd_solve::{relative_residual, solve, CgParams, Cholesky, SolveError, SolverKind};

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
    let cg = SolverKind::Cg(CgParams { rtol: 1e-12, max_iter: 5000 });
    let mut sols = Vec::new();
    for kind in [SolverKind::Cholesky, SolverKind::Lu, SolverKind::Dense, cg] {
        let (u, rep) = solve(&a, &b, &kind, 2).unwrap();
        // Backward-stable direct solves: residual ~ eps * kappa; CG stops at 1e-12.
        assert!(rep.rel_residual < 1e-11, "{}: residual {:e}", rep.solver, rep.rel_residual);
        assert!((relative_residual(&a, true, &u, &b) - rep.rel_residual).abs() < 1e-15);
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
        match solve(&a, &vec![1.0; n], &SolverKind::Cholesky, 2) {
            Err(SolveError::NotPositiveDefinite { dof }) => assert_eq!(dof, bad),
            other => panic!("expected a zero pivot at {bad}, got {other:?}"),
        }
        assert!(matches!(
            solve(&a, &vec![1.0; n], &SolverKind::Dense, 2),
            Err(SolveError::NotPositiveDefinite { .. } | SolveError::TooLargeForDense { .. })
        ));
        assert!(matches!(solve(&a, &vec![1.0; n], &SolverKind::Cg(CgParams::default()), 2), Err(SolveError::Cg(_))));
    }
}
