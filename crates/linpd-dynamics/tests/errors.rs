//! Invalid input gives the right error variant, with its data, and never a panic.

use linpd_dynamics::dispersion::{measure_omega, ModalFit, ModeRun};
use linpd_dynamics::stability::gershgorin;
use linpd_dynamics::{Chain, DtLimit, DynamicsError, FnOperator, LimitMethod, LumpedMass, State, Verlet, VerletParams};
use std::ops::ControlFlow;

fn ring() -> linpd_dynamics::Ring {
    Chain::springs(1.0, 4, 0.5).unwrap().ring(40).unwrap()
}

fn run(params: &VerletParams) -> Result<linpd_dynamics::VerletInfo, DynamicsError> {
    let r = ring();
    let v = Verlet::new(&r, r.mass(1.0).unwrap());
    let mut s = State::at_rest((0..40).map(|i| ((i * 7) % 11) as f64 / 11.0).collect());
    v.run(&mut s, params, None, |_| ControlFlow::Continue(()))
}

#[test]
fn bad_time_step_and_step_count() {
    for dt in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        match run(&VerletParams::new(dt, 10)) {
            Err(DynamicsError::TimeStep(x)) => assert!(x.to_bits() == dt.to_bits()),
            other => panic!("dt = {dt}: {other:?}"),
        }
    }
    assert_eq!(run(&VerletParams::new(0.1, 0)).unwrap_err(), DynamicsError::NoSteps);
}

#[test]
fn bad_density_and_volume() {
    for rho in [0.0, -1.0, f64::NAN] {
        match LumpedMass::uniform(rho, 0.5, 3) {
            Err(DynamicsError::Density(x)) => assert!(x.to_bits() == rho.to_bits()),
            other => panic!("rho = {rho}: {other:?}"),
        }
        assert!(matches!(LumpedMass::new(rho, &[1.0]), Err(DynamicsError::Density(_))));
        assert!(matches!(ring().mass(rho), Err(DynamicsError::Density(_))));
    }
    assert_eq!(LumpedMass::new(1.0, &[1.0, 0.0, 2.0]).unwrap_err(), DynamicsError::Volume { dof: 1, value: 0.0 });
}

#[test]
fn unstable_time_step_states_the_limit() {
    let r = ring();
    let exact = r.dt_limit(1.0);
    let dt = 1.05 * exact;
    // Given limit: reported as is.
    let e = run(&VerletParams { limit: DtLimit::Given(exact), ..VerletParams::new(dt, 10) }).unwrap_err();
    assert_eq!(e, DynamicsError::Unstable { dt, limit: exact, method: LimitMethod::Given });
    assert!(e.to_string().contains(&format!("{exact}")), "message states the limit: {e}");
    // Power iteration (the default): at most the exact limit's error above it.
    match run(&VerletParams::new(dt, 10)) {
        Err(DynamicsError::Unstable { limit, method: LimitMethod::PowerIteration, .. }) => {
            assert!(limit >= exact * (1.0 - 1e-12) && limit < 1.01 * exact, "{limit} vs {exact}")
        }
        other => panic!("{other:?}"),
    }
    // Gershgorin: conservative, rejects even some stable steps.
    match run(&VerletParams { limit: DtLimit::Gershgorin, ..VerletParams::new(0.99 * exact, 10) }) {
        Err(DynamicsError::Unstable { limit, method: LimitMethod::Gershgorin, .. }) => assert!(limit < exact),
        other => panic!("{other:?}"),
    }
    // The override runs it; the state then blows up and the run reports it, without panicking.
    let info = run(&VerletParams { allow_unstable: true, ..VerletParams::new(dt, 10) }).unwrap();
    assert_eq!(info.dt_limit, None);
    match run(&VerletParams { allow_unstable: true, ..VerletParams::new(dt, 100_000) }) {
        Err(DynamicsError::Diverged { step, .. }) => assert!(step < 100_000),
        other => panic!("{other:?}"),
    }
}

#[test]
fn shape_and_configuration_errors() {
    let r = ring();
    let v = Verlet::new(&r, r.mass(1.0).unwrap());
    let mut s = State::at_rest(vec![0.0; 39]);
    assert_eq!(
        v.run(&mut s, &VerletParams::new(0.1, 1), None, |_| ControlFlow::Continue(())).unwrap_err(),
        DynamicsError::Length { what: "u", expected: 40, got: 39 }
    );
    // Masses for another size than the operator's.
    let wrong = Verlet::new(&r, LumpedMass::uniform(1.0, 0.5, 41).unwrap());
    let mut s41 = State::at_rest(vec![0.0; 41]);
    assert!(matches!(
        wrong.run(&mut s41, &VerletParams::new(0.1, 1), None, |_| ControlFlow::Continue(())),
        Err(DynamicsError::Length { expected: 40, got: 41, .. })
    ));
    assert_eq!(
        Verlet::new(&r, r.mass(1.0).unwrap()).with_fixed(&[(40, 0.0)]).unwrap_err(),
        DynamicsError::FixedDof { dof: 40, value: 0.0, n: 40 }
    );
    assert!(matches!(
        Verlet::new(&r, r.mass(1.0).unwrap()).with_fixed(&[(3, f64::NAN)]),
        Err(DynamicsError::FixedDof { dof: 3, .. })
    ));
    // A closure does not know its entries.
    let op = FnOperator { n: 3, apply: |u: &[f64], y: &mut [f64]| y.copy_from_slice(u) };
    assert_eq!(
        gershgorin(&op, &LumpedMass::uniform(1.0, 1.0, 3).unwrap(), &[]).unwrap_err(),
        DynamicsError::NoGershgorin
    );
    let closure = Verlet::new(&op, LumpedMass::uniform(1.0, 1.0, 3).unwrap());
    let mut s = State::at_rest(vec![1.0; 3]);
    let p = VerletParams { limit: DtLimit::Gershgorin, ..VerletParams::new(0.1, 1) };
    assert_eq!(closure.run(&mut s, &p, None, |_| ControlFlow::Continue(())).unwrap_err(), DynamicsError::NoGershgorin);
    // Lattice and measurement parameters.
    assert!(matches!(Chain::springs(1.0, 4, 0.5).unwrap().ring(8), Err(DynamicsError::Parameter { name: "nx", .. })));
    assert!(matches!(Chain::springs(0.0, 4, 0.5), Err(DynamicsError::Parameter { name: "K1", .. })));
    assert!(matches!(Chain::springs(1.0, 0, 0.5), Err(DynamicsError::Parameter { name: "N", .. })));
    let chain = Chain::springs(1.0, 4, 0.5).unwrap();
    let bad_mode = ModeRun { nx: 40, mode: 0, dt: 0.1, steps: 10 };
    assert!(matches!(
        measure_omega(&chain, 1.0, &bad_mode, ModalFit::Recurrence),
        Err(DynamicsError::Parameter { name: "mode", .. })
    ));
    let too_short = ModeRun { nx: 40, mode: 1, dt: 0.1, steps: 10 };
    assert!(matches!(measure_omega(&chain, 1.0, &too_short, ModalFit::ZeroCrossings), Err(DynamicsError::Fit(_))));
    let unstable = ModeRun { nx: 40, mode: 20, dt: 1.1 * chain.ring(40).unwrap().dt_limit(1.0), steps: 10 };
    assert!(matches!(measure_omega(&chain, 1.0, &unstable, ModalFit::Recurrence), Err(DynamicsError::Unstable { .. })));
}
