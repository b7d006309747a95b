//! GMRES converges to its tolerance, reports the true residual, and a good preconditioner
//! cuts its iterations.

mod common;

use common::{residual_by_entries, spd, unsym};
use linpd_solve::{gmres, Cholesky, FactorPreconditioner, GmresParams, Identity};

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
