//! Stability of velocity Verlet on the nonlocal-spring bar of section 4.4.
//!
//! * (4.12) is a sufficient condition: it lies below the exact limit `2/omega_max` for every
//!   `N >= 2` (equal for `N = 1`), and the headroom is the 20-30% the paper measured (Fig. 4.2).
//! * On a bar, Gershgorin equals (4.12), power iteration converges to the exact limit from
//!   above, and both bracket the dense eigenvalue.
//! * The square pulse (4.14) on a fixed-end bar stays bounded at `0.99 dt_max` and blows up
//!   at `1.05 dt_max`.

use linpd_bond::BondOperator;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_dynamics::initial::square_pulse;
use linpd_dynamics::stability::{
    chain_bound, gershgorin, lattice_limit, paper_bound, power_iteration, verlet_limit, PowerParams,
};
use linpd_dynamics::{spring_constant, Chain, LinearOperator, LumpedMass, State, Verlet, VerletParams};
use std::ops::ControlFlow;

fn springs(k1: f64) -> Micromodulus {
    // Discrete normalization of the inverse-distance kernel: K(N) = 2K_1/(N(N+1)) (A.1).
    Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: k1,
        plane: None,
        partial_volume: false,
    }
}

/// The bar `[0, length]` with spacing `dx`, horizon `delta`, and fixed layers of width `delta`
/// (every free node has its full family, so `A_ff` is a finite section of the lattice).
fn bar(length: f64, dx: f64, delta: f64) -> (Grid, BondOperator, Vec<usize>, LumpedMass) {
    let g = Grid::new(&[0.0], &[length], dx, delta, Placement::Vertex).unwrap();
    let op = BondOperator::on_grid(&g, delta, &springs(1.0), &Material::default()).unwrap();
    let fixed: Vec<usize> = (0..g.len()).filter(|&i| g.is_layer(i)).collect();
    let mass = LumpedMass::uniform(1.0, dx, g.len()).unwrap();
    (g, op, fixed, mass)
}

#[test]
fn paper_bound_4_12_is_below_the_exact_limit() {
    // delta = 5, rho = K_1 = 1 (Fig. 4.2), N = delta/dx.
    println!("   N   dt(4.12)/dt_max   headroom dt_max/dt(4.12) - 1");
    let mut prev = 1.0 + 1e-12;
    for n in [1usize, 2, 3, 5, 10, 20, 50, 100, 500] {
        let dx = 5.0 / n as f64;
        let chain = Chain::springs(1.0, n, dx).unwrap();
        let exact = lattice_limit(&chain, 1.0).dt;
        let b412 = paper_bound(1.0, spring_constant(1.0, n), n, dx);
        assert!((b412 - chain_bound(&chain, 1.0)).abs() < 1e-13 * b412);
        let ratio = b412 / exact;
        println!("{n:4}   {ratio:.5}           {:5.1}%", 100.0 * (1.0 / ratio - 1.0));
        if n == 1 {
            assert!((ratio - 1.0).abs() < 1e-13, "N = 1: (4.12) is exact");
        } else {
            // Sufficient, not necessary; the ratio decreases with N towards 1/sqrt(2).
            assert!(ratio < prev && ratio > std::f64::consts::FRAC_1_SQRT_2, "N = {n}: ratio {ratio}");
        }
        if n == 10 || n == 20 {
            // Fig. 4.2: "we are allowed to increase the time step by about 20-30%".
            assert!((1.2..=1.3).contains(&(1.0 / ratio)), "N = {n}: headroom {}", 1.0 / ratio);
        }
        prev = ratio;
    }
}

#[test]
fn gershgorin_and_power_iteration_bracket_the_dense_eigenvalue() {
    // A short bar, so that the dense eigenvalue problem is cheap: 101 free nodes, N = 10.
    let (g, op, fixed, mass) = bar(50.0, 0.5, 5.0);
    let n = g.len();
    let free: Vec<usize> = (0..n).filter(|i| !fixed.contains(i)).collect();
    let mut a = faer::Mat::<f64>::zeros(free.len(), free.len());
    let (mut e, mut y) = (vec![0.0; n], vec![0.0; n]);
    for (c, &j) in free.iter().enumerate() {
        e[j] = 1.0;
        LinearOperator::apply(&op, &e, &mut y);
        e[j] = 0.0;
        for (r, &i) in free.iter().enumerate() {
            a[(r, c)] = y[i] / mass.masses()[i]; // M^-1 A with uniform M: symmetric
        }
    }
    let exact = a.self_adjoint_eigenvalues(faer::Side::Lower).unwrap().into_iter().fold(f64::NEG_INFINITY, f64::max);
    let lg = gershgorin(&op, &mass, &fixed).unwrap();
    let p = power_iteration(&op, &mass, &fixed, &PowerParams { max_iter: 20_000, rtol: 1e-14, ..Default::default() })
        .unwrap();
    let lattice = lattice_limit(&Chain::new(0.5, 5.0, &springs(1.0)).unwrap(), 1.0);
    println!(
        "lambda_max: dense {exact:.12}, power {:.12} ({} it), Gershgorin {lg:.12}, lattice {:.12}",
        p.lambda,
        p.iterations,
        lattice.omega_max.powi(2)
    );
    // Rayleigh quotients never exceed lambda_max; eps-level slack for the dense solver.
    assert!(p.lambda <= exact * (1.0 + 1e-12));
    // The top of the spectrum is a cluster (the symbol is flat at its maximum), so convergence is
    // slow: 7e-8 relative after 20000 iterations on this bar; 1e-6 leaves a margin.
    assert!((p.lambda - exact).abs() <= 1e-6 * exact, "power iteration: {} vs {exact}", p.lambda);
    assert!(lg >= exact, "Gershgorin is an upper bound");
    // Gershgorin on the bar is the interior-row bound, i.e. (4.12).
    let b412 = paper_bound(1.0, spring_constant(1.0, 10), 10, 0.5);
    assert!((verlet_limit(lg) - b412).abs() <= 1e-12 * b412);
    // Finite Toeplitz section: lambda_max(A_ff) <= max of the lattice symbol.
    assert!(lattice.omega_max.powi(2) >= exact * (1.0 - 1e-12));
}

/// Runs the square pulse on the bar; returns (steps taken, max E/E0, max |shadow/shadow0 - 1|).
fn run_pulse(dt: f64, steps: usize, allow_unstable: bool) -> (usize, f64, f64) {
    let (g, op, fixed, mass) = bar(1000.0, 0.5, 5.0);
    let u0: Vec<f64> = (0..g.len()).map(|i| square_pulse(g.position(i)[0])).collect();
    let fixed_values: Vec<(usize, f64)> = fixed.iter().map(|&d| (d, 0.0)).collect();
    let verlet = Verlet::new(&op, mass).with_fixed(&fixed_values).unwrap();
    let params = VerletParams { output_every: 1, allow_unstable, ..VerletParams::new(dt, steps) };
    let mut state = State::at_rest(u0);
    let (mut e0, mut s0, mut emax, mut sdev) = (f64::NAN, f64::NAN, 0.0f64, 0.0f64);
    let info = verlet
        .run(&mut state, &params, None, |s| {
            if s.step == 0 {
                e0 = s.energy.total();
                s0 = s.energy.shadow;
            }
            emax = emax.max(s.energy.total() / e0);
            sdev = sdev.max((s.energy.shadow / s0 - 1.0).abs());
            if emax > 1e6 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    (info.steps, emax, sdev)
}

#[test]
fn square_pulse_is_bounded_below_the_limit_and_blows_up_above() {
    // The coarse PD of section 4.4.1: [0, 1000], dx = 0.5, N = 10, delta = 5, rho = K_1 = 1.
    let (_, op, fixed, mass) = bar(1000.0, 0.5, 5.0);
    // The bar's exact limit is bracketed by the lattice limit (finite Toeplitz section, below)
    // and power iteration (Rayleigh quotient, above).
    let lattice = lattice_limit(&Chain::new(0.5, 5.0, &springs(1.0)).unwrap(), 1.0).dt;
    let p = power_iteration(&op, &mass, &fixed, &PowerParams::default()).unwrap();
    let power = verlet_limit(p.lambda);
    let gersh = verlet_limit(gershgorin(&op, &mass, &fixed).unwrap());
    println!(
        "dt_max: lattice {lattice:.8} <= bar <= power ({} it) {power:.8}; Gershgorin = (4.12) {gersh:.8} = {:.4} dt_max",
        p.iterations,
        gersh / lattice
    );
    assert!(lattice <= power && power / lattice - 1.0 < 1e-3, "bracket [{lattice}, {power}] too wide");
    let dt_max = lattice;

    // 0.99 dt_max: per mode E <= E~/(1 - (omega dt/2)^2) and E~ = E~_0 <= E_0, so
    // E(t)/E_0 <= 1/(1 - 0.99^2) = 50.25 for ever (a rigorous bound, not a fitted one).
    // The default stability check (power iteration) accepts this dt.
    let (steps, emax, sdev) = run_pulse(0.99 * dt_max, 5000, false);
    println!("0.99 dt_max: {steps} steps, max E/E0 = {emax:.4}, shadow energy drift {sdev:.2e}");
    assert_eq!(steps, 5000);
    assert!(emax <= 1.0 / (1.0 - 0.99f64.powi(2)), "bounded: max E/E0 = {emax}");
    // The shadow energy is conserved to round-off (5000 steps, ~1e-16 per step and per term).
    assert!(sdev < 1e-10, "shadow energy drift {sdev:e}");

    // 1.05 dt_max: the top mode grows by |zeta| = 1.88 per step; seeded by the pulse (or by
    // round-off) the energy passes 1e6 E0 within a few hundred steps.
    let (steps, emax, _) = run_pulse(1.05 * dt_max, 5000, true);
    println!("1.05 dt_max: energy passed 1e6 E0 after {steps} steps (max E/E0 = {emax:.3e})");
    assert!(emax > 1e6 && steps < 5000, "no blow-up at 1.05 dt_max");
}
