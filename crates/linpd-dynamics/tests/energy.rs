//! Energy conservation of velocity Verlet on the fixed-end bar with the smooth pulse of
//! section 4.4.1.
//!
//! For a linear system the shadow energy `E~ = E_k + E_p - (dt^2/8) r . M^-1 r`, `r = -A u`, is
//! an exact invariant of velocity Verlet, so
//!
//! ```text
//! E_n - E_0 = (dt^2/8) (||A u_n||^2_{M^-1} - ||A u_0||^2_{M^-1}),
//! ```
//!
//! bounded, without secular drift, and `O(dt^2)`. Rigorous constant: per mode
//! `||A u||^2_{M^-1} = omega^4 u^2 <= 2 omega_max^2 E_p`, and `E_n <= E_0 / (1 - s)`,
//! `s = (omega_max dt/2)^2`, give `|E_n - E_0| / E_0 <= (omega_max^2 / 4) dt^2 / (1 - s) = C dt^2`.
//! Measured over the same physical time (`10^4` steps at `dt`, `2 10^4` at `dt/2`), the drift
//! must shrink by 4 (to within 10%: the maxima of `||A u_n||` over the run move by `O(dt^2)`).

use linpd_bond::BondOperator;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_dynamics::initial::smooth_pulse;
use linpd_dynamics::stability::lattice_limit;
use linpd_dynamics::{Chain, DtLimit, LumpedMass, State, Verlet, VerletParams};
use std::ops::ControlFlow;

/// Max relative deviation of `E_k + E_p` and of the shadow energy over `steps` steps of `dt`.
fn drift(verlet: &Verlet<'_, BondOperator>, u0: &[f64], dt: f64, steps: usize, limit: f64) -> (f64, f64) {
    let params = VerletParams { output_every: 1, limit: DtLimit::Given(limit), ..VerletParams::new(dt, steps) };
    let mut state = State::at_rest(u0.to_vec());
    let (mut e0, mut s0, mut de, mut ds) = (0.0, 0.0, 0.0f64, 0.0f64);
    verlet
        .run(&mut state, &params, None, |s| {
            if s.step == 0 {
                e0 = s.energy.total();
                s0 = s.energy.shadow;
            }
            de = de.max((s.energy.total() - e0).abs() / e0);
            ds = ds.max((s.energy.shadow - s0).abs() / s0);
            ControlFlow::Continue(())
        })
        .unwrap();
    (de, ds)
}

#[test]
fn energy_drift_is_order_dt_squared() {
    // Section 4.4.1's coarse PD restricted to [400, 600] (the pulse sits at [490, 510]; waves
    // reach the fixed layers and reflect well within the run): dx = 0.5, N = 10, rho = K_1 = 1.
    let (dx, delta) = (0.5, 5.0);
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane: None,
        partial_volume: false,
    };
    let g = Grid::new(&[400.0], &[600.0], dx, delta, Placement::Vertex).unwrap();
    let op = BondOperator::on_grid(&g, delta, &mm, &Material::default()).unwrap();
    let fixed: Vec<(usize, f64)> = (0..g.len()).filter(|&i| g.is_layer(i)).map(|i| (i, 0.0)).collect();
    let verlet = Verlet::new(&op, LumpedMass::uniform(1.0, dx, g.len()).unwrap()).with_fixed(&fixed).unwrap();
    let u0: Vec<f64> = (0..g.len()).map(|i| smooth_pulse(g.position(i)[0])).collect();
    // Lattice limit: a lower bound of this bar's limit (finite Toeplitz section).
    let lat = lattice_limit(&Chain::new(dx, delta, &mm).unwrap(), 1.0);
    let dt1 = 0.5 * lat.dt;
    let mut prev: Option<f64> = None;
    println!("dt          steps   max|E-E0|/E0   bound C dt^2   shadow drift   ratio");
    for (dt, steps) in [(dt1, 10_000usize), (dt1 / 2.0, 20_000)] {
        let (de, ds) = drift(&verlet, &u0, dt, steps, lat.dt);
        let s = (lat.omega_max * dt / 2.0).powi(2);
        let bound = lat.omega_max.powi(2) / 4.0 * dt * dt / (1.0 - s);
        println!(
            "{dt:.6}  {steps:6}   {de:.4e}     {bound:.4e}     {ds:.2e}     {}",
            prev.map_or(String::new(), |p| format!("{:.3}", p / de))
        );
        assert!(de <= bound, "drift {de:e} above C dt^2 = {bound:e}");
        // Round-off: ~1e-16 per step and term, random walk over <= 2e4 steps.
        assert!(ds < 1e-11, "shadow energy drift {ds:e}");
        if let Some(p) = prev {
            assert!((p / de / 4.0 - 1.0).abs() < 0.1, "halving dt divided the drift by {}", p / de);
        }
        prev = Some(de);
    }
}
