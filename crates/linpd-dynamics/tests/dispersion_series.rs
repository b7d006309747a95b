//! The discrete dispersion relation tends to the series (4.8) for `k N dx << 1`, and the series
//! truncation error scales like `(k delta)^6`.
//!
//! Relative errors `e(k) = omega_relation(k) / omega_series(k) - 1` of the omega series
//! `c_0 k [1 - a_2 k^2 + a_4 k^4]`:
//!
//! * continuum relation vs (4.9): `e = C_6 (k delta)^6 + O((k delta)^8)`, with
//!   `C_6 = -5/4644864` (the `x^3` coefficient of `sqrt(1 - x/24 + x^2/1080 - x^3/80640)`,
//!   `x = (k delta)^2`, worked out by hand from the paper's omega^2 series);
//! * lattice relation vs the lattice series with its exact-`N` moments
//!   ([`LongWaveSeries::from_chain`]): `e = C_6(N) (k delta)^6 + ...`, so halving `k` divides
//!   `e` by 64;
//! * lattice relation vs (4.8): (4.8) keeps only the `N >> 1` part of the coefficients; the
//!   exact one is `a_2 = delta^2 (1 + 1/N)/48`, so `e -> -(k delta)^2/(48 N)` as `k -> 0`.
//!
//! Tolerances: the relations are evaluated to ~1e-15 relative (sums and Gauss-Legendre of
//! `2 sin^2`, no cancellation), so at `k delta = 0.1` (`e ~ 1e-12`) the ratios below are known to
//! ~1e-3; the `O((k delta)^2)` corrections to the ratios are below 1% at `k delta <= 0.2`.

use linpd_core::Kernel;
use linpd_dynamics::dispersion::{continuum_amplitude, omega, omega_continuum, omega_paper_series, LongWaveSeries};
use linpd_dynamics::Chain;

const C6: f64 = -5.0 / 4_644_864.0;

#[test]
fn continuum_relation_minus_series_4_9_scales_like_k_delta_to_the_6() {
    let (k1, rho, delta) = (1.0, 1.0, 5.0);
    let c = continuum_amplitude(&Kernel::InverseDistance, k1, delta).unwrap();
    assert!((c - 2.0 * k1 / (delta * delta)).abs() < 1e-14, "c = 2K_1/delta^2 (A.1)");
    let mut prev: Option<f64> = None;
    println!("k delta    e(continuum vs 4.9)   e/(k delta)^6 / C6   e(k)/e(k/2)");
    for kd in [0.8, 0.4, 0.2, 0.1] {
        let k = kd / delta;
        let e =
            omega_continuum(&Kernel::InverseDistance, c, delta, rho, k) / omega_paper_series(k1, rho, delta, k) - 1.0;
        let ratio = e / kd.powi(6) / C6;
        println!(
            "{kd:6.2}   {e:14.6e}        {ratio:10.6}       {}",
            prev.map_or(String::new(), |p| format!("{:.3}", p / e))
        );
        if kd <= 0.2 {
            assert!((ratio - 1.0).abs() < 1e-2, "k delta = {kd}: e/(C6 (k delta)^6) = {ratio}");
        }
        if let Some(p) = prev {
            assert!((p / e / 64.0 - 1.0).abs() < 0.05, "k delta = {kd}: halving k divides e by {}", p / e);
        }
        prev = Some(e);
    }
}

#[test]
fn discrete_relation_tends_to_series_4_8() {
    let (k1, rho, delta) = (1.0, 1.0, 5.0);
    // The MD chain of section 4.4.1 (N = 20, a = 0.25) and the coarse PD (N = 10, dx = 0.5).
    for n in [10usize, 20] {
        let chain = Chain::springs(k1, n, delta / n as f64).unwrap();
        let lattice = LongWaveSeries::from_chain(&chain, rho);
        // Exact-N coefficients vs the paper's N >> 1 ones.
        assert!((lattice.speed - (k1 / rho).sqrt()).abs() < 1e-14, "c_0 = sqrt(K_1/rho): K(N) normalization");
        let a2_ratio = lattice.a2 / (delta * delta / 48.0);
        assert!((a2_ratio - (1.0 + 1.0 / n as f64)).abs() < 1e-13, "a_2 = delta^2 (1 + 1/N)/48, got ratio {a2_ratio}");
        println!(
            "N = {n}: a_2 = (1 + 1/N) delta^2/48, a_4/(17 delta^4/69120) = {:.6}",
            lattice.a4 / (17.0 * delta.powi(4) / 69120.0)
        );
        println!("k delta   e(lattice vs own series)  e(k)/e(k/2)   e(lattice vs 4.8)  e/(-(k delta)^2/(48N))");
        let mut prev: Option<f64> = None;
        for kd in [0.8, 0.4, 0.2, 0.1] {
            let k = kd / delta;
            let w = omega(&chain, rho, k);
            let e_own = w / lattice.omega(k) - 1.0;
            let e_paper = w / omega_paper_series(k1, rho, delta, k) - 1.0;
            let lead = -kd * kd / (48.0 * n as f64);
            println!(
                "{kd:6.2}   {e_own:14.6e}          {}   {e_paper:14.6e}      {:.6}",
                prev.map_or("      ".into(), |p| format!("{:6.2}", p / e_own)),
                e_paper / lead
            );
            if let Some(p) = prev {
                assert!((p / e_own / 64.0 - 1.0).abs() < 0.05, "N = {n}, k delta = {kd}: ratio {}", p / e_own);
            }
            if kd <= 0.2 {
                assert!((e_paper / lead - 1.0).abs() < 0.01, "N = {n}, k delta = {kd}: {e_paper:e} vs {lead:e}");
            }
            prev = Some(e_own);
        }
    }
    // N -> infinity at fixed delta: the lattice coefficients become the paper's (error O(1/N)).
    let big = LongWaveSeries::from_chain(&Chain::springs(k1, 2000, delta / 2000.0).unwrap(), rho);
    assert!((big.a4 / (17.0 * delta.powi(4) / 69120.0) - 1.0).abs() < 2e-3);
    assert!((big.a2 / (delta * delta / 48.0) - 1.0 - 1.0 / 2000.0).abs() < 1e-12);
}

#[test]
fn continuum_series_from_moments_is_4_9() {
    // The moment formulas reproduce the paper's coefficients for C = c/eps (quadrature ~1e-15).
    let delta = 5.0;
    let c = continuum_amplitude(&Kernel::InverseDistance, 1.0, delta).unwrap();
    let s = LongWaveSeries::from_continuum(&Kernel::InverseDistance, c, delta, 1.0);
    let p = LongWaveSeries::paper(1.0, 1.0, delta);
    assert!((s.speed - p.speed).abs() < 1e-14);
    assert!((s.a2 / p.a2 - 1.0).abs() < 1e-13);
    assert!((s.a4 / p.a4 - 1.0).abs() < 1e-12);
}
