//! The frequency measured from a single-mode simulation equals the discrete dispersion relation
//! with the velocity-Verlet correction, `sin(omega_num dt/2) = (dt/2) omega(k)`.
//!
//! Setting: the coarse PD of section 4.4.1 (springs with `K_1 = 1`, `N = 10`, `dx = 0.5`,
//! `delta = 5`, `rho = 1`) on a ring of 200 nodes (`L = 100`), `dt = dt_max/2`, modes from the
//! longest wave (`m = 1`, `k delta = 0.31`) to the Brillouin edge (`m = 100`, `k = pi/dx`).
//!
//! Tolerance 1e-6 relative (the brief's). What limits the agreement:
//! * recurrence fit: round-off only. The modal amplitude is `cos(n theta)` to round-off (the
//!   ring's eigenvectors are exactly `cos(k x)`), and `theta` comes from `1 - cos(theta)`,
//!   whose relative error is `~eps / theta^2`: 1e-13 for `theta = 0.06`;
//! * zero crossings: the cubic interpolation error of each crossing (`O(theta^5)`, largest near
//!   the edge where `theta ~ 1`), divided by the number of half periods.
//!
//! Without the Verlet correction the mismatch is `(omega dt)^2/24 + ...` (4% at the edge): the
//! test asserts that too, so it can tell the two relations apart.

use linpd_dynamics::dispersion::{measure_omega, omega, verlet_omega, ModalFit, ModeRun};
use linpd_dynamics::Chain;

#[test]
fn measured_omega_matches_discrete_relation_with_verlet_correction() {
    let rho = 1.0;
    let chain = Chain::springs(1.0, 10, 0.5).unwrap();
    let nx = 200;
    let ring = chain.ring(nx).unwrap();
    let dt = 0.5 * ring.dt_limit(rho);
    let mut largest_uncorrected = 0.0f64;
    println!(
        "  m   k delta    omega_exact     omega_num    rel.err(recurrence) rel.err(crossings) crossings  uncorrected"
    );
    for m in [1usize, 3, 10, 37, 60, 99, 100] {
        let k = ring.wavenumber(m);
        let exact = omega(&chain, rho, k);
        let expected = verlet_omega(exact, dt).expect("dt is below the limit");
        let run = ModeRun { nx, mode: m, dt, steps: 4000 };
        let rec = measure_omega(&chain, rho, &run, ModalFit::Recurrence).unwrap();
        let zc = measure_omega(&chain, rho, &run, ModalFit::ZeroCrossings).unwrap();
        let e_rec = (rec.omega - expected).abs() / expected;
        let e_zc = (zc.omega - expected).abs() / expected;
        let uncorrected = (rec.omega - exact).abs() / exact;
        largest_uncorrected = largest_uncorrected.max(uncorrected);
        println!(
            "{m:3} {:9.4} {exact:14.10} {expected:14.10}   {e_rec:10.2e}          {e_zc:10.2e}      {:5}   {uncorrected:9.2e}",
            k * chain.horizon(),
            zc.crossings
        );
        assert!(
            rec.leak < 1e-10,
            "the ring keeps the mode (round-off accumulates to ~1e-12 in 4000 steps): leak {:e}",
            rec.leak
        );
        assert!(e_rec <= 1e-6, "m = {m}: recurrence fit off by {e_rec:e}");
        assert!(e_zc <= 1e-6, "m = {m}: zero-crossing fit off by {e_zc:e}");
        // asin(x)/x = 1 + x^2/6 + 3x^4/40 + ... (all terms positive), x = omega dt/2: the
        // uncorrected mismatch is at least (omega dt)^2/24, and within 3% of it for omega dt <= 1/2.
        let predicted = (exact * dt).powi(2) / 24.0;
        assert!(uncorrected >= predicted * (1.0 - 1e-9), "m = {m}: {uncorrected:e} < {predicted:e}");
        if exact * dt <= 0.5 {
            assert!(uncorrected <= 1.03 * predicted, "m = {m}: {uncorrected:e} vs {predicted:e}");
        }
    }
    assert!(largest_uncorrected > 1e-2, "the Verlet correction must matter near the edge");
}
