//! Boundary conditions, forcing, outputs and operator kinds of the integrator.

use linpd_bond::BondOperator;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_dynamics::{Chain, DtLimit, FnOperator, LinearOperator, LumpedMass, State, Verlet, VerletParams};
use std::ops::ControlFlow;

fn bar(fixed_layers: bool) -> (Grid, BondOperator) {
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane: None,
        partial_volume: false,
    };
    let layer = if fixed_layers { 1.0 } else { 0.0 };
    let g = Grid::new(&[0.0], &[20.0], 0.25, layer, Placement::Vertex).unwrap();
    let op = BondOperator::on_grid(&g, 1.0, &mm, &Material::default()).unwrap();
    (g, op)
}

fn pseudo_random(n: usize, salt: usize) -> Vec<f64> {
    (0..n).map(|i| (((i + salt) * 7919) % 101) as f64 / 101.0 - 0.5).collect()
}

#[test]
fn free_ends_conserve_linear_momentum() {
    // No constraint: A has zero column sums (rigid translation in its null space), so
    // sum_i M_i a_i = 0 and the momentum P = sum M v is conserved; the centre of mass moves
    // at P / sum M. Round-off: each step adds ~eps sum |M v|.
    let (g, op) = bar(false);
    let n = g.len();
    let verlet = Verlet::new(&op, LumpedMass::uniform(2.0, 0.25, n).unwrap());
    let mut s = State::new(pseudo_random(n, 0), pseudo_random(n, 5));
    let m = 2.0 * 0.25;
    let p0: f64 = s.v.iter().map(|v| m * v).sum();
    let x0: f64 = s.u.iter().map(|u| m * u).sum();
    let scale: f64 = s.v.iter().map(|v| m * v.abs()).sum();
    let dt = 0.5 * verlet.dt_limit(&DtLimit::default()).unwrap().0;
    let info = verlet.run(&mut s, &VerletParams::new(dt, 2000), None, |_| ControlFlow::Continue(())).unwrap();
    let p: f64 = s.v.iter().map(|v| m * v).sum();
    let x: f64 = s.u.iter().map(|u| m * u).sum();
    assert!((p - p0).abs() < 1e-12 * scale, "momentum {p0} -> {p}");
    assert!((x - x0 - info.t * p0).abs() < 1e-10 * scale * info.t, "centre of mass");
}

#[test]
fn fixed_dofs_hold_their_values_and_energy_is_conserved() {
    // Layers fixed at different values: a constant load through A; the shadow energy stays
    // an invariant (rtol 1e-12 over 3000 steps of round-off).
    let (g, op) = bar(true);
    let n = g.len();
    let fixed: Vec<(usize, f64)> =
        (0..g.len()).filter(|&i| g.is_layer(i)).map(|i| (i, if g.position(i)[0] < 0.0 { -0.2 } else { 0.3 })).collect();
    let verlet = Verlet::new(&op, LumpedMass::uniform(1.0, 0.25, n).unwrap()).with_fixed(&fixed).unwrap();
    let mut s = State::new(vec![0.0; n], pseudo_random(n, 1));
    let dt = 0.9 * verlet.dt_limit(&DtLimit::default()).unwrap().0;
    let mut shadow = (f64::NAN, 0.0f64);
    let params = VerletParams { output_every: 7, ..VerletParams::new(dt, 3000) };
    verlet
        .run(&mut s, &params, None, |snap| {
            for &(d, val) in &fixed {
                assert_eq!((snap.u[d], snap.v[d]), (val, 0.0), "fixed DOF {d} moved");
            }
            if snap.step == 0 {
                shadow.0 = snap.energy.shadow;
            }
            shadow.1 = shadow.1.max((snap.energy.shadow - shadow.0).abs() / snap.energy.shadow.abs());
            ControlFlow::Continue(())
        })
        .unwrap();
    assert!(shadow.1 < 1e-12, "shadow energy drift {:e}", shadow.1);
}

#[test]
fn forced_oscillator_through_a_closure_is_second_order() {
    // m u'' = -k u + F cos(W t), u(0) = u'(0) = 0: u = F/(m (w^2 - W^2)) (cos W t - cos w t).
    // Global error of velocity Verlet: O(dt^2); halving dt divides it by 4 (within 5%).
    let (m, k, force_amp, big_w) = (2.0f64, 8.0f64, 1.5f64, 1.3f64);
    let w = (k / m).sqrt();
    let op = FnOperator { n: 1, apply: move |u: &[f64], y: &mut [f64]| y[0] = k * u[0] };
    let dyn_op: &dyn LinearOperator = &op;
    let verlet = Verlet::new(dyn_op, LumpedMass::new(m, &[1.0]).unwrap());
    let t_end = 10.0;
    let exact = force_amp / (m * (w * w - big_w * big_w)) * ((big_w * t_end).cos() - (w * t_end).cos());
    let mut errs = Vec::new();
    for steps in [1000usize, 2000, 4000] {
        let dt = t_end / steps as f64;
        let mut s = State::at_rest(vec![0.0]);
        let mut force = |t: f64, f: &mut [f64]| f[0] = force_amp * (big_w * t).cos();
        let info =
            verlet.run(&mut s, &VerletParams::new(dt, steps), Some(&mut force), |_| ControlFlow::Continue(())).unwrap();
        assert!((info.t - t_end).abs() < 1e-12);
        errs.push((s.u[0] - exact).abs());
    }
    println!("forced oscillator errors: {errs:?}");
    for p in errs.windows(2) {
        assert!((p[0] / p[1] / 4.0 - 1.0).abs() < 0.05, "order: {}", p[0] / p[1]);
    }
}

#[test]
fn outputs_trait_objects_and_early_stop() {
    let ring = Chain::springs(1.0, 3, 0.5).unwrap().ring(30).unwrap();
    let u0 = pseudo_random(30, 3);
    let dt = 0.5 * ring.dt_limit(1.0);
    let direct = Verlet::new(&ring, ring.mass(1.0).unwrap());
    let object: &dyn LinearOperator = &ring;
    let boxed = Verlet::new(object, ring.mass(1.0).unwrap());
    let mut seen = Vec::new();
    let params =
        VerletParams { output_every: 3, limit: DtLimit::Given(ring.dt_limit(1.0)), ..VerletParams::new(dt, 10) };
    let mut a = State::at_rest(u0.clone());
    direct
        .run(&mut a, &params, None, |s| {
            seen.push(s.step);
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(seen, [0, 3, 6, 9, 10]);
    let mut b = State::at_rest(u0.clone());
    boxed.run(&mut b, &params, None, |_| ControlFlow::Continue(())).unwrap();
    assert_eq!(a, b, "trait object and concrete operator step identically");
    // output_every = 0: first and last only; Break stops the run.
    let mut seen = Vec::new();
    let mut c = State::at_rest(u0);
    let info = direct
        .run(&mut c, &VerletParams { output_every: 0, ..params.clone() }, None, |s| {
            seen.push(s.step);
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!((seen, info.stopped), (vec![0, 10], false));
    let mut d = State::at_rest(pseudo_random(30, 3));
    let info = direct.run(&mut d, &VerletParams { output_every: 1, ..params }, None, |s| {
        if s.step == 4 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let info = info.unwrap();
    assert_eq!((info.steps, info.stopped), (4, true));
    assert!((d.t - 4.0 * dt).abs() < 1e-12);
}
