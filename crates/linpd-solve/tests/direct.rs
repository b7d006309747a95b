//! Sparse Cholesky and LU: symbolic analyses reused for new values, failing pivots named by
//! their original DOF, unsymmetric systems solved backward-stably.

mod common;

use common::{residual_by_entries, spd, unsym};
use faer::sparse::{SparseColMat, Triplet};
use linpd_solve::{solve_assembled, CgParams, Cholesky, Lu, LuOrdering, MatrixHints, SolveError, SolverSpec};

fn solve(
    a: &SparseColMat<usize, f64>,
    b: &[f64],
    spec: &SolverSpec,
) -> Result<(Vec<f64>, linpd_solve::SolveReport), SolveError> {
    solve_assembled(a, b, spec, &MatrixHints::symmetric(2))
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
}

/// The flop count of the symbolic analysis matches the closed forms: a tridiagonal matrix
/// (simplicial: `c_j = 2` but the last column, `4 (n - 1) + 1`) and a dense one (supernodal:
/// `c_j = n - j`, `sum = n (n + 1) (2n + 1) / 6`). Exact integers in f64.
#[test]
fn cholesky_flops_follow_the_column_counts() {
    let n = 50;
    let mut t = Vec::new();
    for i in 0..n {
        t.push(Triplet::new(i, i, 4.0));
        if i + 1 < n {
            t.push(Triplet::new(i, i + 1, -1.0));
            t.push(Triplet::new(i + 1, i, -1.0));
        }
    }
    let tri = SparseColMat::try_new_from_triplets(n, n, &t).unwrap();
    let natural: Vec<usize> = (0..n).collect();
    let chol = Cholesky::analyze_with_ordering(&tri, Some(&natural)).unwrap();
    assert_eq!(chol.flops(), (4 * (n - 1) + 1) as f64);
    let n = 300;
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..n {
            t.push(Triplet::new(i, j, if i == j { n as f64 } else { 1.0 }));
        }
    }
    let dense = SparseColMat::try_new_from_triplets(n, n, &t).unwrap();
    let natural: Vec<usize> = (0..n).collect();
    let chol = Cholesky::analyze_with_ordering(&dense, Some(&natural)).unwrap();
    assert_eq!(chol.flops(), (n * (n + 1) * (2 * n + 1) / 6) as f64);
}
