//! Stability limits of velocity Verlet for linear PD: the paper's bound (4.12), the refinement
//! rule (4.13), and the exact limit `2 / sqrt(lambda_max(M^-1 A))` from Gershgorin discs
//! (cheap, conservative) or power iteration (sharp).
//!
//! # The paper's analysis (section 4.3)
//!
//! Velocity Verlet is equivalent to the Stormer scheme (4.10),
//! `m (y^{n+1} - 2 y^n + y^{n-1}) / dt^2 = sum_p F_{p,j}`. With `m = rho dx`, the springs
//! `K(N)/|x_p - x_j|` and the mode `y_j^n = x_j + zeta^n exp(i k j dx)` it gives the quadratic
//!
//! ```text
//! (4.11)  zeta^2 - 2 (1 - M_k dt^2 / rho) zeta + 1 = 0,   M_k = sum_{q=1}^N K(N)/(q dx^2) (1 - cos(k q dx)),
//! ```
//!
//! whose roots satisfy `|zeta| <= 1` iff `dt <= sqrt(2 rho / M_k)`. Replacing `1 - cos` by its
//! maximum 2 makes the condition hold for every `k`:
//!
//! ```text
//! (4.12)  dt < sqrt(rho / (K(N) H_N)) dx,     H_N = sum_{q=1}^N 1/q,
//!       = delta sqrt(rho/(2 K_1)) sqrt((1 + 1/N) / H_N)          (K(N) = 2K_1/(N(N+1)), N dx = delta)
//! ```
//!
//! and the refinement path of the experiments is
//!
//! ```text
//! (4.13)  dt = dt_0 sqrt(rho / (K(N) H_N)) dx,    dt_0 = 0.85 ("safety factor").
//! ```
//!
//! # (4.12) is a Gershgorin bound
//!
//! In the notation of [`crate::chain`], `2 M_k / rho = sigma(k)/rho = omega^2(k)`, the
//! eigenvalue of `M^-1 A` on the mode `k`, and Verlet is stable iff `omega dt <= 2`. The exact
//! limit on the infinite lattice is therefore `dt_max = 2 / omega_max`,
//! `omega_max^2 = max_k sigma(k)/rho` ([`lattice_limit`]). (4.12) bounds `sigma(k)` by
//! `4 sum_j C_j V`, which is exactly the Gershgorin bound of an interior row of `M^-1 A`
//! (diagonal `2 sum_j w_j / (rho V)` plus the same off the diagonal); for any kernel
//! ([`chain_bound`]) it reads `dt < sqrt(rho / sum_j C_j V)`. It is a *sufficient* condition:
//! `1 - cos(k j dx) = 2` cannot hold for `j = 1` and `j = 2` at once, so `dt_(4.12) < dt_max`
//! whenever `N >= 2`. For the inverse-distance kernel `sigma` peaks at (or next to) the
//! Brillouin edge, where `sigma(pi/dx) / (4 sum C_j V) = (sum_{j odd} 1/j) / H_N -> 1/2` as
//! `N -> infinity`; so `dt_(4.12) / dt_max` falls from 1 (`N = 1`) towards `1/sqrt(2)`:
//! 0.866, 0.819, 0.790, 0.774, 0.753, 0.742 for `N = 2, 5, 10, 20, 100, 500`, i.e. a headroom
//! `dt_max/dt_(4.12) - 1` of 15%, 22%, 26%, 29%, 33%, 35%. The paper's "20-30%" (Fig. 4.2,
//! measured with the square pulse) is the range `N = 5..20` (`tests/stability_bar.rs`).
//!
//! # Bounded domains
//!
//! On a bar the limit is `2 / sqrt(lambda_max(M_f^-1 A_ff))` over the free DOFs:
//!
//! * [`gershgorin`]: `lambda_max <= max_i sum_j |A_ij| / M_i` over free rows and columns
//!   (conservative, one pass over the entries);
//! * [`power_iteration`] on `M^-1/2 A M^-1/2`: the Rayleigh quotient rises to `lambda_max` from
//!   below (sharp, but the limit it gives is an upper estimate of the true one, by its
//!   convergence error; when the top of the spectrum is a dense band, as on long lattices, that
//!   error decays only like `1/iterations`: on the 2001-node bar of section 4.4.1 (`N = 10`)
//!   the limit is 1.2e-4 (relative) too high after 1000 iterations, 1.5e-5 after 10^4).
//!
//! For a bar whose free nodes all have complete families (fixed layers of width `delta`), `A_ff`
//! is a finite section of the lattice's Toeplitz matrix, so `lambda_max(A_ff) <= max sigma`:
//! the lattice limit is a lower bound of the bar's limit, and the two meet as the bar grows.

use crate::chain::{spring_constant, Chain};
use crate::error::DynamicsError;
use crate::mass::{check_size, LumpedMass};
use linpd_core::progress::{NoProgress, Progress, Task};
use linpd_core::LinearOperator;

/// Harmonic number `H_N = sum_{q=1}^N 1/q`.
pub fn harmonic_number(n: usize) -> f64 {
    (1..=n).rev().map(|q| 1.0 / q as f64).sum()
}

/// The paper's bound (4.12): `dt < sqrt(rho / (K(N) H_N)) dx` for the springs `K(N)/|x_p - x_j|`.
pub fn paper_bound(rho: f64, k_n: f64, n: usize, dx: f64) -> f64 {
    (rho / (k_n * harmonic_number(n))).sqrt() * dx
}

/// (4.12) in terms of the horizon: `delta sqrt(rho/(2 K_1)) sqrt((1 + 1/N) / H_N)`.
pub fn paper_bound_horizon(rho: f64, k1: f64, n: usize, delta: f64) -> f64 {
    delta * (rho / (2.0 * k1)).sqrt() * ((1.0 + 1.0 / n as f64) / harmonic_number(n)).sqrt()
}

/// The refinement rule (4.13): `dt = dt_0 sqrt(rho / (K(N) H_N)) dx` with `K(N) = 2K_1/(N(N+1))`
/// (the paper uses `dt_0 = 0.85`).
pub fn refinement_dt(dt0: f64, rho: f64, k1: f64, n: usize, dx: f64) -> f64 {
    dt0 * paper_bound(rho, spring_constant(k1, n), n, dx)
}

/// (4.12) for any lattice kernel: `sqrt(rho / sum_j C_j V)` (the interior Gershgorin bound).
pub fn chain_bound(chain: &Chain, rho: f64) -> f64 {
    let s: f64 = chain.micromoduli().iter().sum::<f64>() * chain.dx();
    (rho / s).sqrt()
}

/// `2 / sqrt(lambda)`, the velocity-Verlet limit for `lambda_max(M^-1 A) = lambda` (infinite
/// for `lambda = 0`).
pub fn verlet_limit(lambda: f64) -> f64 {
    if lambda > 0.0 {
        2.0 / lambda.sqrt()
    } else {
        f64::INFINITY
    }
}

/// The exact limit of the infinite lattice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatticeLimit {
    /// `omega_max = max_k sqrt(sigma(k)/rho)`.
    pub omega_max: f64,
    /// The wavenumber attaining it, in `(0, pi/dx]`.
    pub k_max: f64,
    /// `dt_max = 2 / omega_max`.
    pub dt: f64,
}

/// Maximizes `sigma(k)` over `k dx = theta in [0, pi]`: a scan of `64 (N + 1)` points, then
/// Newton on `sigma'(theta) = 0` from the best one (`sigma` is a trigonometric polynomial of
/// degree `N`, so the scan resolves every local maximum).
pub fn lattice_limit(chain: &Chain, rho: f64) -> LatticeLimit {
    let dx = chain.dx();
    let c = chain.micromoduli();
    let f = |th: f64| chain.symbol(th / dx);
    let samples = 64 * (chain.n() + 1);
    let mut best = (f(std::f64::consts::PI), std::f64::consts::PI);
    for s in 1..samples {
        let th = std::f64::consts::PI * s as f64 / samples as f64;
        let v = f(th);
        if v > best.0 {
            best = (v, th);
        }
    }
    let mut th = best.1;
    for _ in 0..30 {
        let (mut d1, mut d2) = (0.0, 0.0);
        for (i, cj) in c.iter().enumerate() {
            let j = (i + 1) as f64;
            d1 += cj * j * (j * th).sin();
            d2 += cj * j * j * (j * th).cos();
        }
        if d2 >= 0.0 {
            break;
        }
        let next = (th - d1 / d2).clamp(0.0, std::f64::consts::PI);
        if (next - th).abs() <= 1e-15 {
            th = next;
            break;
        }
        th = next;
    }
    if f(th) < best.0 {
        th = best.1;
    }
    let omega_max = (f(th) / rho).sqrt();
    LatticeLimit { omega_max, k_max: th / dx, dt: 2.0 / omega_max }
}

fn free_mask(n: usize, fixed: &[usize]) -> Result<Vec<bool>, DynamicsError> {
    let mut keep = vec![true; n];
    for &d in fixed {
        if d >= n {
            return Err(DynamicsError::FixedDof { dof: d, value: 0.0, n });
        }
        keep[d] = false;
    }
    Ok(keep)
}

/// Gershgorin bound `lambda_max(M_f^-1 A_ff) <= max_{i free} sum_{j free} |A_ij| / M_i`.
///
/// Errors with [`DynamicsError::NoGershgorin`] when the operator does not report its entries.
pub fn gershgorin<A: LinearOperator + ?Sized>(
    op: &A,
    mass: &LumpedMass,
    fixed: &[usize],
) -> Result<f64, DynamicsError> {
    let n = mass.len();
    check_size(op, n)?;
    let keep = free_mask(n, fixed)?;
    let mut r = vec![0.0; n];
    if !op.abs_row_sums(&keep, &mut r) {
        return Err(DynamicsError::NoGershgorin);
    }
    Ok((0..n).filter(|&i| keep[i]).map(|i| r[i] / mass.masses()[i]).fold(0.0, f64::max))
}

/// Power-iteration parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct PowerParams {
    /// Iteration limit (one operator apply each).
    pub max_iter: usize,
    /// Stop when the Rayleigh quotient changes by at most `rtol` (relative) in one iteration.
    pub rtol: f64,
    /// Seed of the pseudo-random start vector.
    pub seed: u64,
}

impl Default for PowerParams {
    fn default() -> Self {
        PowerParams { max_iter: 1000, rtol: 1e-9, seed: 0x2545_F491_4F6C_DD1D }
    }
}

/// Result of [`power_iteration`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerInfo {
    /// Rayleigh quotient, a lower bound of `lambda_max(M_f^-1 A_ff)`.
    pub lambda: f64,
    /// Iterations done.
    pub iterations: usize,
    /// True when the `rtol` test passed before `max_iter`.
    pub converged: bool,
    /// `||B x - lambda x||` for the unit iterate `x` (`B = M^-1/2 A M^-1/2` on free DOFs): some
    /// eigenvalue lies within this distance of `lambda` (not necessarily the largest).
    pub residual: f64,
}

/// Power iteration for `lambda_max(M_f^-1 A_ff)` on the symmetric form `M^-1/2 A M^-1/2`.
pub fn power_iteration<A: LinearOperator + ?Sized>(
    op: &A,
    mass: &LumpedMass,
    fixed: &[usize],
    params: &PowerParams,
) -> Result<PowerInfo, DynamicsError> {
    power_iteration_with_progress(op, mass, fixed, params, &NoProgress)
}

/// [`power_iteration`] reporting to `progress`: a task `"stable time step (power iteration)"`
/// with no total whose updates carry the iteration and the relative change of the Rayleigh
/// quotient (the quantity compared with `rtol`).
pub fn power_iteration_with_progress<A: LinearOperator + ?Sized>(
    op: &A,
    mass: &LumpedMass,
    fixed: &[usize],
    params: &PowerParams,
    progress: &dyn Progress,
) -> Result<PowerInfo, DynamicsError> {
    if params.max_iter == 0 {
        return Err(DynamicsError::param("max_iter", "must be >= 1, got 0"));
    }
    if !(params.rtol.is_finite() && params.rtol >= 0.0) {
        return Err(DynamicsError::param("rtol", format!("must be finite and >= 0, got {:e}", params.rtol)));
    }
    let n = mass.len();
    check_size(op, n)?;
    let keep = free_mask(n, fixed)?;
    let s: Vec<f64> = (0..n).map(|i| if keep[i] { 1.0 / mass.masses()[i].sqrt() } else { 0.0 }).collect();
    // xorshift64*: a start vector with every eigencomponent present (almost surely).
    let mut state = params.seed | 1;
    let mut x: Vec<f64> = (0..n)
        .map(|i| {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            let r = (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
            if keep[i] {
                2.0 * r - 1.0
            } else {
                0.0
            }
        })
        .collect();
    let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    let nx = norm(&x);
    if nx == 0.0 {
        return Ok(PowerInfo { lambda: 0.0, iterations: 0, converged: true, residual: 0.0 });
    }
    x.iter_mut().for_each(|a| *a /= nx);
    let mut z = vec![0.0; n];
    let mut y = vec![0.0; n];
    let mut q_prev = f64::NAN;
    let mut info = PowerInfo { lambda: 0.0, iterations: 0, converged: false, residual: f64::INFINITY };
    let task = Task::start(progress, "stable time step (power iteration)", None);
    for it in 1..=params.max_iter {
        for i in 0..n {
            z[i] = s[i] * x[i];
        }
        op.apply(&z, &mut y);
        for i in 0..n {
            y[i] *= s[i];
        }
        let q: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        let ny = norm(&y);
        let residual = x.iter().zip(&y).map(|(a, b)| (b - q * a).powi(2)).sum::<f64>().sqrt();
        info = PowerInfo { lambda: q, iterations: it, converged: false, residual };
        if ny == 0.0 {
            info.converged = true;
            break;
        }
        for i in 0..n {
            x[i] = y[i] / ny;
        }
        if task.due() {
            task.set(it as u64, &format!("iteration {it}, relative change {:.2e}", (q - q_prev).abs() / q.abs()));
        }
        if (q - q_prev).abs() <= params.rtol * q.abs() {
            info.converged = true;
            break;
        }
        q_prev = q;
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_bound_forms_agree() {
        // (4.12) in dx form and in delta form are the same expression (rtol: round-off).
        for n in [1usize, 2, 10, 20, 500] {
            let dx = 5.0 / n as f64;
            let a = paper_bound(1.3, spring_constant(0.7, n), n, dx);
            let b = paper_bound_horizon(1.3, 0.7, n, 5.0);
            assert!((a - b).abs() <= 1e-14 * a, "N = {n}: {a} vs {b}");
            // The generalized bound of a spring chain is (4.12).
            let c = chain_bound(&Chain::springs(0.7, n, dx).unwrap(), 1.3);
            assert!((a - c).abs() <= 1e-13 * a, "N = {n}: {a} vs {c}");
        }
    }

    #[test]
    fn nearest_neighbour_limit_is_2_over_omega_edge() {
        // N = 1: sigma(k) = 4 C_1 V sin^2(k dx/2); max at the edge = 4 K/dx^2 (C_1 = K/dx^3),
        // so dt_max = dx sqrt(rho/K), and (4.12) is exact.
        let chain = Chain::springs(2.0, 1, 0.1).unwrap();
        let l = lattice_limit(&chain, 3.0);
        let exact = 0.1 * (3.0f64 / 2.0).sqrt();
        assert!((l.dt - exact).abs() < 1e-14 * exact);
        assert!((chain_bound(&chain, 3.0) - exact).abs() < 1e-14 * exact);
    }
}
