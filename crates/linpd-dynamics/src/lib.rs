//! Explicit dynamics for linear peridynamics: velocity Verlet, stability limits and dispersion
//! relations, after section 4 of Seleson, Parks, Gunzburger & Lehoucq (2009), "Peridynamics as
//! an upscaling of molecular dynamics" (SIAM MMS 8), and Algorithm 1 of the LAMMPS peridynamics
//! howto.
//!
//! The semi-discrete system is `M u'' = -A u + f(t)` with `A` the symmetric PSD stiffness in
//! force form (the convention of `linpd-bond`: `F = -A u`, node volume `V = h^d`) and the lumped
//! mass `M_i = rho V_i`.
//!
//! * [`verlet`]: velocity Verlet over any [`linpd_core::LinearOperator`] (re-exported here as
//!   [`LinearOperator`]: `linpd-bond`'s operators, the ring, closures wrapped in
//!   [`FnOperator`], trait objects `&dyn LinearOperator`; operators that know their entries
//!   provide [`LinearOperator::abs_row_sums`] for Gershgorin bounds), fixed DOFs, external force, energies, output callback, and a
//!   stability check that refuses `dt > 2/sqrt(lambda_max(M^-1 A))`;
//! * [`mass`]: the lumped masses [`LumpedMass`] (`M_i = rho V_i`);
//! * [`chain`]: the 1D nonlocal-spring lattice (4.1)/(A.2), any `linpd-core` kernel, and its
//!   periodic operator [`Ring`];
//! * [`stability`]: the bound (4.12), the refinement rule (4.13), the exact lattice limit,
//!   Gershgorin and power-iteration estimates of `lambda_max`;
//! * [`dispersion`]: the exact discrete relation, the continuum relation, the series (4.8)/(4.9),
//!   the Verlet correction `sin(omega_num dt/2) = omega dt/2`, and a single-mode measurement;
//! * [`bloch`]: Bloch dispersion of assembled 2D/3D lattice operators (bond-based, LPS) along
//!   any direction, and their long-wave speeds;
//! * [`initial`]: the initial displacements of section 4.4 (smooth pulse, square pulse (4.14)).
//!
//! # Example
//!
//! A standing wave on a periodic chain of nonlocal springs (section 4: `K_1 = 1`, `N = 10`,
//! `dx = 0.5`, `rho = 1`) oscillates at the discrete frequency corrected for Verlet:
//!
//! ```
//! use linpd_dynamics::dispersion::{omega, verlet_omega};
//! use linpd_dynamics::{Chain, DtLimit, State, Verlet, VerletParams};
//! use std::ops::ControlFlow;
//!
//! let chain = Chain::springs(1.0, 10, 0.5)?;
//! let ring = chain.ring(200)?;
//! let (rho, dt) = (1.0, 0.5 * ring.dt_limit(1.0));
//! let k = ring.wavenumber(5);
//! let w = verlet_omega(omega(&chain, rho, k), dt).unwrap();
//! let u0: Vec<f64> = (0..200).map(|i| (k * ring.position(i)).cos()).collect();
//! let verlet = Verlet::new(&ring, ring.mass(rho)?);
//! let params = VerletParams { limit: DtLimit::Given(ring.dt_limit(rho)), ..VerletParams::new(dt, 100) };
//! let mut state = State::at_rest(u0.clone());
//! let info = verlet.run(&mut state, &params, None, |_| ControlFlow::Continue(()))?;
//! // u(t) = cos(w t) u0, to round-off.
//! let amplitude = (w * info.t).cos();
//! assert!(state.u.iter().zip(&u0).all(|(u, p)| (u - amplitude * p).abs() < 1e-10));
//!
//! // Any closure y = A u is an operator too, wrapped with its size in a
//! // `linpd_core::FnOperator` (here a single spring, k = 4, m = 1).
//! let spring = linpd_dynamics::FnOperator { n: 1, apply: |u: &[f64], y: &mut [f64]| y[0] = 4.0 * u[0] };
//! let single = Verlet::new(&spring, linpd_dynamics::LumpedMass::new(1.0, &[1.0])?);
//! let mut s = State::at_rest(vec![1.0]);
//! single.run(&mut s, &VerletParams::new(0.01, 10), None, |_| ControlFlow::Continue(()))?;
//! # Ok::<(), linpd_dynamics::DynamicsError>(())
//! ```
#![deny(missing_docs)]

pub mod bloch;
pub mod chain;
pub mod dispersion;
pub mod error;
pub mod initial;
pub mod mass;
pub mod memory;
pub mod stability;
pub mod verlet;

pub use chain::{spring_constant, Chain, Ring};
pub use error::{DynamicsError, LimitMethod};
pub use linpd_core::{FnOperator, LinearOperator};
pub use mass::LumpedMass;
pub use verlet::{DtLimit, Energy, Force, Snapshot, State, Verlet, VerletInfo, VerletParams};
