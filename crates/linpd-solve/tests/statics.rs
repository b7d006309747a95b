//! The one assembled-solve dispatch (`solve_assembled`): every solver agrees on SPD systems
//! and reports the true residual; unsymmetric systems go to LU (saying so), to dense LU, or
//! under `auto` with an SPD approximation to preconditioned GMRES with an LU fallback.

mod common;

use common::{residual_by_entries, spd, unsym};
use linpd_core::{Ordering, SpdApproximation, SpdApproximationKind};
use linpd_solve::{solve_assembled, CgParams, MatrixHints, SolveError, SolverId, SolverSpec};

fn solve(
    a: &linpd_core::Csc,
    b: &[f64],
    spec: &SolverSpec,
) -> Result<(Vec<f64>, linpd_solve::SolveReport), SolveError> {
    solve_assembled(a, b, spec, &MatrixHints::symmetric(2))
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
fn unsymmetric_dispatch() {
    // Skew part 0.2 against a symmetric part with off-diagonals -1: `A M^{-1}` is a modest
    // perturbation of I, as for the blended model (whose skew part is local to transition rows).
    let a = unsym(20, 0.2);
    let n = a.nrows();
    let b: Vec<f64> = (0..n).map(|i| ((i * 13) % 7) as f64 - 3.0).collect();
    let hints = MatrixHints { asymmetry: 0.1, ..MatrixHints::symmetric(2) };
    // The dispatch sends an unsymmetric matrix to LU whatever was asked, and says so; the
    // reported residual uses the unsymmetric product.
    let (u, rep) = solve_assembled(&a, &b, &SolverSpec::Cholesky, &hints).unwrap();
    assert_eq!(rep.solver, SolverId::Lu);
    assert!(rep.notes.join("; ").contains("unsymmetric"));
    assert!((rep.rel_residual - residual_by_entries(&a, &u, &b)).abs() <= 1e-14);
    // Dense asked: dense LU with partial pivoting, same solution.
    let (ud, rep) = solve_assembled(&a, &b, &SolverSpec::Dense, &hints).unwrap();
    assert_eq!(rep.solver, SolverId::DenseLu);
    let scale = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // kappa < 1e3: backward-stable solves agree to ~kappa eps; 1e-12 relative.
    assert!(ud.iter().zip(&u).all(|(p, q)| (p - q).abs() <= 1e-12 * scale), "dense LU vs sparse LU");
    // Auto with an SPD approximation (the symmetric part, here `spd(20)`): GMRES
    // preconditioned by its Cholesky factor, band order kept, a few iterations, same solution.
    let spd_hints = MatrixHints {
        ordering: Ordering::Band,
        spd: Some(SpdApproximation { matrix: spd(20), kind: SpdApproximationKind::SymmetricPart }),
        ..hints.clone()
    };
    let (ug, rep) = solve_assembled(&a, &b, &SolverSpec::default(), &spd_hints).unwrap();
    assert_eq!(rep.solver, SolverId::Gmres(SpdApproximationKind::SymmetricPart), "{:?}", rep.notes);
    // Measured 22 (to the backward-error stop, ~1e-15 relative); counts are deterministic.
    let it = rep.iterations.unwrap();
    assert!(it <= 25, "{it} GMRES iterations");
    assert!(rep.rel_residual <= 1e-12, "GMRES residual {:e}", rep.rel_residual);
    assert!(ug.iter().zip(&u).all(|(p, q)| (p - q).abs() <= 1e-11 * scale), "GMRES vs LU");
    // An indefinite "SPD approximation": Cholesky fails, band LU runs, the note says why.
    let bad = faer::sparse::SparseColMat::new(
        spd(20).symbolic().to_owned().unwrap(),
        spd(20).val().iter().map(|v| -v).collect(),
    );
    let bad_hints = MatrixHints {
        spd: Some(SpdApproximation { matrix: bad, kind: SpdApproximationKind::DivergenceForm }),
        ..spd_hints
    };
    let (ul, rep) = solve_assembled(&a, &b, &SolverSpec::default(), &bad_hints).unwrap();
    assert_eq!(rep.solver, SolverId::LuBand);
    let note = rep.notes.join("; ");
    assert!(note.contains("not positive definite") && note.contains("sparse LU used"), "{note}");
    assert!(ul.iter().zip(&u).all(|(p, q)| (p - q).abs() <= 1e-12 * scale), "band LU vs LU");
}

/// NaN or infinity in the load, the stiffness or the result is an error naming its source,
/// never a "not positive definite" pivot or a NaN residual with success.
#[test]
fn nan_load_is_an_error() {
    let a = spd(10);
    let n = a.nrows();
    let b = vec![1.0; n];
    let cg = SolverSpec::cg(CgParams::default());
    for spec in [SolverSpec::Cholesky, cg.clone(), SolverSpec::Lu] {
        let mut bad = b.clone();
        bad[3] = f64::NAN;
        let e = solve(&a, &bad, &spec).unwrap_err().to_string();
        assert!(e.contains("the load vector has non-finite values (first at DOF 3 = NaN)"), "{spec}: {e}");
        // Finite entries whose squared norm overflows: every residual would be inf / inf.
        let e = solve(&a, &vec![1e300; n], &spec).unwrap_err().to_string();
        assert!(e.contains("the load vector") && e.contains("squared norm overflows"), "{spec}: {e}");
    }
    // An overflowed stiffness (modulus 1e308 times the geometry) is named, not "not positive
    // definite".
    let inf = faer::sparse::SparseColMat::new(
        a.symbolic().to_owned().unwrap(),
        a.val().iter().map(|v| v * 1e308 * 10.0).collect(),
    );
    for spec in [SolverSpec::Cholesky, cg] {
        let e = solve(&inf, &b, &spec).unwrap_err().to_string();
        assert!(e.contains("the stiffness has non-finite values (first at entry") && e.contains("overflow"), "{e}");
    }
    // Finite inputs whose solution overflows: named too.
    let tiny =
        faer::sparse::SparseColMat::new(a.symbolic().to_owned().unwrap(), a.val().iter().map(|v| v * 1e-300).collect());
    let e = solve(&tiny, &vec![1e10; n], &SolverSpec::Cholesky).unwrap_err().to_string();
    assert!(e.contains("the solution has non-finite values"), "{e}");
}
