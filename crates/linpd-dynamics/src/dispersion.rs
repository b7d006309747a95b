//! Dispersion relations of the 1D lattice and of the PD continuum, their long-wave series
//! (4.8)/(4.9), the velocity-Verlet correction, and a measurement from a simulation.
//!
//! # The discrete relation (derived from the operator)
//!
//! With the force form of [`crate::chain`] and masses `M_i = rho V`, row `i` of
//! `M u'' = -A u` divided by `V` reads `rho u_i'' = sum_{0 < |j| <= N} C_j V (u_{i+j} - u_i)`.
//! The plane wave `u_i = exp(i (k x_i - omega t))` turns it into
//! `-rho omega^2 = sum_{0<|j|<=N} C_j V (exp(i k j dx) - 1) = -2 sum_{j=1}^N C_j V (1 - cos(k j dx))`:
//!
//! ```text
//! omega^2(k) = (2/rho) sum_{j=1}^{N} C_j V (1 - cos(k j dx)) = sigma(k) / rho,
//! ```
//!
//! ([`omega`]). For the springs `C_j = K(N)/(j dx^3)`, `V = dx`, `m = rho dx` this is the MD
//! relation of section 4.2, `omega^2 = sum_j 2 K(N)/(m j a) (1 - cos(k j a))`. It is exact for the
//! semi-discrete system, for any kernel.
//!
//! # The continuum relation
//!
//! Substituting the plane wave into (2.1)/(4.3) gives ([`omega_continuum`])
//!
//! ```text
//! omega^2(k) = (2/rho) \int_0^delta C(eps) (1 - cos(k eps)) d eps,
//! ```
//!
//! the paper's `\int_0^delta 2 c/(rho eps) (1 - cos(k eps)) d eps` for `C = c/eps`, `c = 2K_1/delta^2`.
//!
//! # Long waves: (4.8)/(4.9)
//!
//! Expanding `1 - cos` for either relation, with one-sided moments
//! `mu_p = sum_j C_j V (j dx)^p` (lattice) or `\int_0^delta C(eps) eps^p d eps` (continuum),
//!
//! ```text
//! omega^2 = (k^2 mu_2 / rho) [1 - k^2 mu_4/(12 mu_2) + k^4 mu_6/(360 mu_2) - ...],
//! omega   = sqrt(mu_2/rho) k [1 - a_2 k^2 + a_4 k^4 + O(k^6)],
//!           a_2 = mu_4/(24 mu_2),   a_4 = mu_6/(720 mu_2) - mu_4^2/(1152 mu_2^2).
//! ```
//!
//! ([`LongWaveSeries`]). For `C = c/eps` on the continuum, `mu_p = c delta^p / p`, so
//! `sqrt(mu_2/rho) = sqrt(K_1/rho)`, `a_2 = delta^2/48`, `a_4 = 17 delta^4/69120`: (4.9). On the
//! lattice with `N` springs `mu_4/mu_2 = (N dx)^2 (1 + 1/N)/2`, so `a_2 = (N dx)^2 (1 + 1/N)/48`:
//! (4.8) is the `N >> 1` limit of the lattice series (the paper keeps "only the dominant terms"),
//! and the discrete relation differs from (4.8) by `-(k N dx)^2/(48 N)` (relative, in `omega`)
//! plus `O((k N dx)^4 / N)` plus the `O((k delta)^6)` truncation of the series.
//!
//! # Velocity Verlet
//!
//! On a mode of frequency `omega`, Algorithm 1 is the recursion
//! `u^{n+1} - 2 u^n + u^{n-1} = -(omega dt)^2 u^n`, whose solutions are `cos(n theta)`,
//! `sin(n theta)` with `cos theta = 1 - (omega dt)^2/2`, i.e. the numerical frequency
//! `omega_num = theta / dt` satisfies ([`verlet_omega`])
//!
//! ```text
//! sin(omega_num dt / 2) = (dt / 2) omega,      omega_num = omega (1 + (omega dt)^2/24 + ...).
//! ```
//!
//! Starting from `u = cos(k x)`, `v = 0`, the first step gives `u^1 = cos(theta) u^0`, so the
//! modal amplitude is `cos(n theta)` exactly.
//!
//! # Measurement ([`measure_omega`])
//!
//! A ring ([`crate::chain::Ring`]) starts from `u = cos(k x)`, `v = 0`; at every step the
//! displacement is projected on `cos(k x)`, `a_n = (u . phi)/(phi . phi)`, and the frequency
//! is fitted from the samples `a_n` ([`ModalFit`]).

use crate::chain::Chain;
use crate::error::{positive, DynamicsError};
use crate::verlet::{DtLimit, State, Verlet, VerletParams};
use linpd_core::{Kernel, Micromodulus, Normalization};
use std::ops::ControlFlow;

/// Discrete dispersion relation `omega(k) = sqrt(sigma(k)/rho)` of the lattice (exact for the
/// semi-discrete system).
pub fn omega(chain: &Chain, rho: f64, k: f64) -> f64 {
    (chain.symbol(k) / rho).sqrt()
}

/// `\int_0^delta f`, 8-point Gauss-Legendre (linpd-core's) on panels of at most `delta/32`
/// and at most `0.5/k_scale` wide, split at the kinks of tabulated kernels.
fn integrate(f: impl Fn(f64) -> f64, kernel: &Kernel, delta: f64, k_scale: f64) -> f64 {
    let panels = |len: f64| ((32.0 * len / delta).ceil().max((2.0 * k_scale * len).ceil())).max(1.0) as usize;
    linpd_core::kernel::gauss_legendre(f, &kernel.breakpoints(delta), panels)
}

/// The amplitude `c` of `C = c g` normalized on the continuum to the 1D modulus `modulus`
/// (`\int_{-delta}^{delta} C eps^2 = 2K`; `c = 2K/delta^2` for `g = 1/eps`).
pub fn continuum_amplitude(kernel: &Kernel, modulus: f64, horizon: f64) -> Result<f64, DynamicsError> {
    positive("horizon", horizon)?;
    let mm = Micromodulus {
        kernel: kernel.clone(),
        normalization: Normalization::Continuum,
        modulus,
        plane: None,
        partial_volume: false,
    };
    mm.validate(1)?;
    Ok(mm.amplitude(1, horizon, horizon)?)
}

/// Continuum dispersion relation `omega^2 = (2/rho) \int_0^delta c g(eps) (1 - cos(k eps)) d eps`
/// (by Gauss-Legendre quadrature, `1 - cos` as `2 sin^2`; relative accuracy ~1e-15 for smooth `g`).
pub fn omega_continuum(kernel: &Kernel, c: f64, horizon: f64, rho: f64, k: f64) -> f64 {
    let i = integrate(
        |e| {
            let s = (0.5 * k * e).sin();
            c * kernel.shape(e, horizon) * 2.0 * s * s
        },
        kernel,
        horizon,
        k.abs(),
    );
    (2.0 * i / rho).sqrt()
}

/// The series (4.8)/(4.9): `omega = sqrt(K_1/rho) k [1 - (k delta)^2/48 + 17 (k delta)^4/69120]`.
pub fn omega_paper_series(k1: f64, rho: f64, delta: f64, k: f64) -> f64 {
    LongWaveSeries::paper(k1, rho, delta).omega(k)
}

/// `omega ~ c_0 k [1 - a_2 k^2 + a_4 k^4]`, the long-wave expansion to the order of (4.8)/(4.9).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongWaveSeries {
    /// Long-wave speed `c_0 = sqrt(mu_2/rho)`.
    pub speed: f64,
    /// `a_2 = mu_4/(24 mu_2)`.
    pub a2: f64,
    /// `a_4 = mu_6/(720 mu_2) - mu_4^2/(1152 mu_2^2)`.
    pub a4: f64,
}

impl LongWaveSeries {
    fn from_moments(mu2: f64, mu4: f64, mu6: f64, rho: f64) -> Self {
        LongWaveSeries {
            speed: (mu2 / rho).sqrt(),
            a2: mu4 / (24.0 * mu2),
            a4: mu6 / (720.0 * mu2) - mu4 * mu4 / (1152.0 * mu2 * mu2),
        }
    }

    /// The series of the lattice (exact lattice moments, any `N`).
    pub fn from_chain(chain: &Chain, rho: f64) -> Self {
        Self::from_moments(chain.moment(2), chain.moment(4), chain.moment(6), rho)
    }

    /// The series of the continuum kernel `C = c g` on `(0, delta)`.
    pub fn from_continuum(kernel: &Kernel, c: f64, horizon: f64, rho: f64) -> Self {
        let mu = |p: i32| integrate(|e| c * kernel.shape(e, horizon) * e.powi(p), kernel, horizon, 0.0);
        Self::from_moments(mu(2), mu(4), mu(6), rho)
    }

    /// The paper's coefficients (4.8)/(4.9): `c_0 = sqrt(K_1/rho)`, `a_2 = delta^2/48`,
    /// `a_4 = 17 delta^4/69120`.
    pub fn paper(k1: f64, rho: f64, delta: f64) -> Self {
        LongWaveSeries { speed: (k1 / rho).sqrt(), a2: delta * delta / 48.0, a4: 17.0 * delta.powi(4) / 69120.0 }
    }

    /// `c_0 k (1 - a_2 k^2 + a_4 k^4)`.
    pub fn omega(&self, k: f64) -> f64 {
        let k2 = k * k;
        self.speed * k * (1.0 - self.a2 * k2 + self.a4 * k2 * k2)
    }
}

/// Frequency seen by velocity Verlet for a mode of exact frequency `omega`:
/// `omega_num = (2/dt) asin(omega dt / 2)`; `None` when `omega dt > 2` (unstable mode).
pub fn verlet_omega(omega: f64, dt: f64) -> Option<f64> {
    let x = 0.5 * omega * dt;
    (x <= 1.0).then(|| 2.0 * x.asin() / dt)
}

/// How [`measure_omega`] fits the frequency of the modal amplitude `a_n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModalFit {
    /// Least squares for the three-term recurrence `a_{n+1} + a_{n-1} = 2 cos(theta) a_n` that
    /// every sampled sinusoid satisfies: `1 - cos(theta) = sum a_n (2 a_n - a_{n+1} - a_{n-1}) /
    /// (2 sum a_n^2)`, `omega = theta/dt`. Exact for a pure mode; limited by round-off,
    /// amplified by `1/theta^2` for slow modes.
    Recurrence,
    /// Zero crossings located on the cubic through the 4 samples around each sign change; the
    /// half period is the slope of the least-squares line through `(q, t_q)`, `q = 0..m`, and
    /// `omega = pi / half period`. Each crossing carries the cubic's interpolation error, which
    /// grows with `theta` (samples per period); the regression averages it over the crossings.
    ZeroCrossings,
}

/// The single-mode run of [`measure_omega`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeRun {
    /// Ring size (nodes).
    pub nx: usize,
    /// Mode number `m`, `1 <= m <= nx/2`; `k = 2 pi m / (nx dx)` (`m = nx/2`: the edge `pi/dx`).
    pub mode: usize,
    /// Time step (must be below the ring's exact limit).
    pub dt: f64,
    /// Steps.
    pub steps: usize,
}

/// A measured frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OmegaMeasurement {
    /// Wavenumber of the mode.
    pub k: f64,
    /// Fitted frequency (the numerical one, `omega_num`).
    pub omega: f64,
    /// Samples used (`steps + 1`).
    pub samples: usize,
    /// Zero crossings used ([`ModalFit::ZeroCrossings`]; 0 otherwise).
    pub crossings: usize,
    /// `max_n ||u^n - a_n phi|| / ||phi||`: how far the field left the mode (round-off on a ring).
    pub leak: f64,
}

/// Measures `omega_num(k)` from a velocity-Verlet run on a ring that starts in the mode
/// `u = cos(k x)`, `v = 0` (see the module docs).
pub fn measure_omega(chain: &Chain, rho: f64, run: &ModeRun, fit: ModalFit) -> Result<OmegaMeasurement, DynamicsError> {
    let ring = chain.ring(run.nx)?;
    if run.mode == 0 || run.mode > run.nx / 2 {
        return Err(DynamicsError::param("mode", format!("must be in 1..={}, got {}", run.nx / 2, run.mode)));
    }
    let nx = run.nx;
    let k = ring.wavenumber(run.mode);
    // cos(2 pi ((m i) mod nx) / nx): exactly periodic, no loss of digits for large i.
    let phi: Vec<f64> =
        (0..nx).map(|i| (2.0 * std::f64::consts::PI * ((run.mode * i) % nx) as f64 / nx as f64).cos()).collect();
    let phi2: f64 = phi.iter().map(|p| p * p).sum();
    let verlet = Verlet::new(&ring, ring.mass(rho)?);
    let params = VerletParams {
        dt: run.dt,
        steps: run.steps,
        output_every: 1,
        limit: DtLimit::Given(ring.dt_limit(rho)),
        allow_unstable: false,
    };
    let mut amps = Vec::with_capacity(run.steps + 1);
    let mut leak = 0.0f64;
    let mut state = State::at_rest(phi.clone());
    verlet.run(&mut state, &params, None, |s| {
        let a = s.u.iter().zip(&phi).map(|(u, p)| u * p).sum::<f64>() / phi2;
        let r2: f64 = s.u.iter().zip(&phi).map(|(u, p)| (u - a * p).powi(2)).sum();
        leak = leak.max((r2 / phi2).sqrt());
        amps.push(a);
        ControlFlow::Continue(())
    })?;
    let (omega, crossings) = match fit {
        ModalFit::Recurrence => (fit_recurrence(&amps)? / run.dt, 0),
        ModalFit::ZeroCrossings => {
            let (rate, m) = fit_zero_crossings(&amps)?;
            (rate / run.dt, m)
        }
    };
    Ok(OmegaMeasurement { k, omega, samples: amps.len(), crossings, leak })
}

/// `theta` (radians per sample) of `a_n = A cos(n theta + phase)` by the recurrence fit.
pub fn fit_recurrence(a: &[f64]) -> Result<f64, DynamicsError> {
    if a.len() < 3 {
        return Err(DynamicsError::Fit(format!("the recurrence fit needs >= 3 samples, got {}", a.len())));
    }
    let mut num = 0.0;
    let mut den = 0.0;
    for n in 1..a.len() - 1 {
        num += a[n] * (2.0 * a[n] - a[n + 1] - a[n - 1]);
        den += 2.0 * a[n] * a[n];
    }
    if den == 0.0 {
        return Err(DynamicsError::Fit("the amplitude is identically zero".into()));
    }
    let one_minus_cos = (num / den).clamp(0.0, 2.0);
    Ok(2.0 * (0.5 * one_minus_cos).sqrt().asin())
}

/// `(theta, m)`: radians per sample from the `m` zero crossings of `a_n` (cubic interpolation).
pub fn fit_zero_crossings(a: &[f64]) -> Result<(f64, usize), DynamicsError> {
    let mut crossings = Vec::new();
    for n in 1..a.len().saturating_sub(2) {
        if a[n] == 0.0 && a[n - 1] * a[n + 1] < 0.0 {
            crossings.push(n as f64);
        } else if a[n] * a[n + 1] < 0.0 {
            // Lagrange cubic through s = -1, 0, 1, 2 (sample n + s); its root in (0, 1).
            let (p, q, r, s) = (a[n - 1], a[n], a[n + 1], a[n + 2]);
            let cubic = |x: f64| {
                -p * x * (x - 1.0) * (x - 2.0) / 6.0 + q * (x + 1.0) * (x - 1.0) * (x - 2.0) / 2.0
                    - r * (x + 1.0) * x * (x - 2.0) / 2.0
                    + s * (x + 1.0) * x * (x - 1.0) / 6.0
            };
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            let lo_sign = q.signum();
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if cubic(mid).signum() == lo_sign {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            crossings.push(n as f64 + 0.5 * (lo + hi));
        }
    }
    if crossings.len() < 2 {
        return Err(DynamicsError::Fit(format!(
            "need >= 2 interior zero crossings, found {}: run longer",
            crossings.len()
        )));
    }
    // Crossings are half a period apart: least-squares line through (q, t_q), slope = pi/theta.
    // The per-crossing interpolation errors depend on where the crossing falls between samples;
    // the regression averages them instead of keeping those of the first and last crossing.
    let m = crossings.len();
    let mf = m as f64;
    let q_mean = 0.5 * (mf - 1.0);
    let t_mean = crossings.iter().sum::<f64>() / mf;
    let (mut sqt, mut sqq) = (0.0, 0.0);
    for (q, t) in crossings.iter().enumerate() {
        let dq = q as f64 - q_mean;
        sqt += dq * (t - t_mean);
        sqq += dq * dq;
    }
    Ok((std::f64::consts::PI * sqq / sqt, m))
}
