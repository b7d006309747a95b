//! The 1D lattice of nonlocal springs, and its periodic operator (the ring).
//!
//! # The lattice
//!
//! Nodes `x_i = i dx` carry the volume `V = dx` (unit cross-section). Node `i` is bonded to
//! `i +- j`, `j = 1..N`, `N = floor(delta/dx)`, with micromodulus `C_j = C(j dx)`. In force form
//! (the convention of `linpd-bond`: force, not force density, and `F = -A u`)
//!
//! ```text
//! F_i = sum_{j=1}^{N} w_j (u_{i+j} - u_i) + w_j (u_{i-j} - u_i),    w_j = C_j V^2,
//! ```
//!
//! so `(A u)_i = sum_j w_j (2 u_i - u_{i+j} - u_{i-j})`. Divided by `V`, `rho u'' = -A u / V` is
//! the quadrature (2.3) of the PD equation (2.1) of Seleson, Parks, Gunzburger & Lehoucq (2009),
//! and eq. (A.2) of that paper for `C_j = K(N)/(j dx^3)`.
//!
//! # Nonlocal springs (section 4, Appendix A.1)
//!
//! The MD chain (4.1) has springs `K(N)/|j a|` between an atom and its `j`-th neighbours, with
//! `K(N) = 2 K_1 / (N (N + 1))` (Appendix A.1) so that every `N` stores the nearest-neighbour
//! energy density of a uniform stretch. With `m = rho a` and `a = dx` this is the lattice above
//! with `C_j = K(N) / (j dx^3)`, i.e. the inverse-distance kernel `C(r) = c/r` with the discrete
//! normalization `c = 2 K_1 / (N (N + 1) dx^2)` of `linpd-core` ([`Chain::springs`] builds it
//! directly, [`Chain::new`] through `linpd-core`; they agree to round-off).
//!
//! # The ring
//!
//! [`Ring`] closes the lattice on itself: `nx` nodes, length `L = nx dx`, indices modulo `nx`.
//! Its eigenvectors are `cos(k x)` and `sin(k x)`, `k = 2 pi m / L`, with
//! `A cos(k x) = V sigma(k) cos(k x)` where
//!
//! ```text
//! sigma(k) = 2 sum_{j=1}^{N} C_j V (1 - cos(k j dx))
//! ```
//!
//! is the lattice symbol ([`Chain::symbol`]); hence `M^-1 A` has eigenvalues `sigma(k_m)/rho`
//! (mass `M_i = rho V`), the squared frequencies of the discrete dispersion relation
//! (see [`crate::dispersion`]). A node must not see itself or another node twice, so
//! `nx > 2 N` is required.

use crate::error::{positive, DynamicsError};
use crate::mass::LumpedMass;
use linpd_core::family::lattice_stencil;
use linpd_core::kernel::partial_volume;
use linpd_core::LinearOperator;
use linpd_core::Micromodulus;

/// `K(N) = 2 K_1 / (N (N + 1))`, the spring constant of Appendix A.1 that makes a chain with
/// `N` neighbours per side store the energy of the nearest-neighbour chain with constant `K_1`.
pub fn spring_constant(k1: f64, n: usize) -> f64 {
    2.0 * k1 / (n as f64 * (n as f64 + 1.0))
}

/// A 1D lattice kernel: spacing `dx`, horizon `delta` and micromoduli `C_j`, `j = 1..N`.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    dx: f64,
    horizon: f64,
    /// `C_j` at index `j - 1` (partial-volume fraction included).
    c: Vec<f64>,
}

impl Chain {
    /// The lattice of `micromodulus` (kernel, normalization, partial volumes) with spacing `dx`
    /// and horizon `horizon`, exactly as `linpd-bond` builds it: the bonds of
    /// `linpd_core::family::lattice_stencil`, `C_j = c g(j dx) nu_j` with `c` from
    /// [`Micromodulus::amplitude`].
    pub fn new(dx: f64, horizon: f64, micromodulus: &Micromodulus) -> Result<Self, DynamicsError> {
        positive("dx", dx)?;
        positive("horizon", horizon)?;
        micromodulus.validate(1)?;
        let c = micromodulus.amplitude(1, horizon, dx)?;
        let offsets: Vec<i64> = lattice_stencil(1, horizon / dx).iter().map(|k| k[0]).filter(|&k| k > 0).collect();
        if offsets.is_empty() {
            return Err(DynamicsError::param(
                "horizon",
                format!("horizon/dx = {:e} gives no bonds (need >= 1)", horizon / dx),
            ));
        }
        let micromoduli = offsets
            .iter()
            .map(|&j| {
                let r = j as f64 * dx;
                let nu = if micromodulus.partial_volume { partial_volume(r, horizon, dx) } else { 1.0 };
                c * micromodulus.kernel.shape(r, horizon) * nu
            })
            .collect();
        Chain::from_micromoduli(dx, horizon, micromoduli)
    }

    /// The nonlocal springs of section 4: `N` neighbours per side, `C_j = K(N)/(j dx^3)`,
    /// `K(N) = 2 K_1/(N (N + 1))`, horizon `N dx`.
    pub fn springs(k1: f64, n: usize, dx: f64) -> Result<Self, DynamicsError> {
        positive("K1", k1)?;
        positive("dx", dx)?;
        if n == 0 {
            return Err(DynamicsError::param("N", "must be >= 1, got 0"));
        }
        let kn = spring_constant(k1, n);
        let c = (1..=n).map(|j| kn / (j as f64 * dx.powi(3))).collect();
        Chain::from_micromoduli(dx, n as f64 * dx, c)
    }

    /// A lattice with explicit micromoduli `C_j` (`c[j - 1]`), finite, `>= 0`, not all zero.
    pub fn from_micromoduli(dx: f64, horizon: f64, c: Vec<f64>) -> Result<Self, DynamicsError> {
        positive("dx", dx)?;
        positive("horizon", horizon)?;
        if c.is_empty() || c.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || c.iter().all(|v| *v == 0.0) {
            return Err(DynamicsError::param("micromoduli", "need at least one, all finite and >= 0, not all zero"));
        }
        Ok(Chain { dx, horizon, c })
    }

    /// Lattice spacing `dx` (also the node volume `V`).
    pub fn dx(&self) -> f64 {
        self.dx
    }
    /// Horizon `delta`.
    pub fn horizon(&self) -> f64 {
        self.horizon
    }
    /// Neighbours per side `N`.
    pub fn n(&self) -> usize {
        self.c.len()
    }
    /// Micromoduli `C_j`, `j = 1..N` (index `j - 1`).
    pub fn micromoduli(&self) -> &[f64] {
        &self.c
    }
    /// Bond weight `w_j = C_j V^2` of the force form (`j >= 1`).
    pub fn bond_weight(&self, j: usize) -> f64 {
        self.c[j - 1] * self.dx * self.dx
    }

    /// One-sided lattice moment `mu_p = sum_{j=1}^N C_j V (j dx)^p`. `mu_2` is the modulus the
    /// lattice realizes (`K` for the discrete normalization).
    pub fn moment(&self, p: i32) -> f64 {
        self.c.iter().enumerate().map(|(i, c)| c * self.dx * ((i + 1) as f64 * self.dx).powi(p)).sum()
    }

    /// Lattice symbol `sigma(k) = 2 sum_j C_j V (1 - cos(k j dx))` (eigenvalue of `A / V` on
    /// `cos(k x)`), with `1 - cos t` evaluated as `2 sin^2(t/2)` so long waves keep their digits.
    pub fn symbol(&self, k: f64) -> f64 {
        let v = self.dx;
        2.0 * self
            .c
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let s = (0.5 * k * (i + 1) as f64 * v).sin();
                c * v * 2.0 * s * s
            })
            .sum::<f64>()
    }

    /// The ring of `nx` nodes built on this lattice.
    pub fn ring(&self, nx: usize) -> Result<Ring, DynamicsError> {
        Ring::new(self.clone(), nx)
    }
}

/// The lattice closed on itself: `nx` nodes, periodic ends, `y = A u` in force form.
#[derive(Debug, Clone, PartialEq)]
pub struct Ring {
    chain: Chain,
    nx: usize,
    /// `w_j = C_j V^2`.
    w: Vec<f64>,
    /// `2 sum_j w_j`, the diagonal of `A`.
    diag: f64,
}

impl Ring {
    /// Ring of `nx > 2N` nodes.
    pub fn new(chain: Chain, nx: usize) -> Result<Self, DynamicsError> {
        if nx <= 2 * chain.n() {
            return Err(DynamicsError::param(
                "nx",
                format!(
                    "a ring needs more than 2N = {} nodes so that no node bonds to itself, got {nx}",
                    2 * chain.n()
                ),
            ));
        }
        let w: Vec<f64> = (1..=chain.n()).map(|j| chain.bond_weight(j)).collect();
        let diag = 2.0 * w.iter().sum::<f64>();
        Ok(Ring { chain, nx, w, diag })
    }

    /// The lattice kernel.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }
    /// Number of nodes (= DOFs).
    pub fn nx(&self) -> usize {
        self.nx
    }
    /// Period `L = nx dx`.
    pub fn length(&self) -> f64 {
        self.nx as f64 * self.chain.dx
    }
    /// Node position `x_i = i dx`.
    pub fn position(&self, i: usize) -> f64 {
        i as f64 * self.chain.dx
    }
    /// Wavenumber of mode `m`: `k_m = 2 pi m / L`; `m = nx/2` is the Brillouin edge `pi/dx`.
    pub fn wavenumber(&self, m: usize) -> f64 {
        2.0 * std::f64::consts::PI * m as f64 / self.length()
    }
    /// Lumped masses `M_i = rho dx`.
    pub fn mass(&self, rho: f64) -> Result<LumpedMass, DynamicsError> {
        LumpedMass::uniform(rho, self.chain.dx, self.nx)
    }

    /// Exact `lambda_max(M^-1 A) = max_m sigma(k_m) / rho` over the ring's `nx/2 + 1` distinct
    /// wavenumbers, and the mode `m` attaining it.
    pub fn lambda_max(&self, rho: f64) -> (f64, usize) {
        (0..=self.nx / 2).map(|m| (self.chain.symbol(self.wavenumber(m)) / rho, m)).fold((0.0, 0), |a, b| {
            if b.0 > a.0 {
                b
            } else {
                a
            }
        })
    }

    /// Exact velocity-Verlet limit `2 / sqrt(lambda_max(M^-1 A))` of the ring.
    pub fn dt_limit(&self, rho: f64) -> f64 {
        2.0 / self.lambda_max(rho).0.sqrt()
    }
}

impl LinearOperator for Ring {
    fn n(&self) -> usize {
        self.nx
    }

    fn apply(&self, u: &[f64], y: &mut [f64]) {
        let n = self.nx;
        assert_eq!(u.len(), n, "u has one entry per ring node");
        assert_eq!(y.len(), n, "y has one entry per ring node");
        for i in 0..n {
            let mut s = self.diag * u[i];
            for (jm1, &w) in self.w.iter().enumerate() {
                let j = jm1 + 1;
                let ip = if i + j >= n { i + j - n } else { i + j };
                let im = if i >= j { i - j } else { i + n - j };
                s -= w * (u[ip] + u[im]);
            }
            y[i] = s;
        }
    }

    fn abs_row_sums(&self, keep: &[bool], r: &mut [f64]) -> bool {
        let n = self.nx;
        for i in 0..n {
            let mut s = if keep[i] { self.diag } else { 0.0 };
            for (jm1, &w) in self.w.iter().enumerate() {
                let j = jm1 + 1;
                let ip = if i + j >= n { i + j - n } else { i + j };
                let im = if i >= j { i - j } else { i + n - j };
                s += w * (keep[ip] as u8 as f64 + keep[im] as u8 as f64);
            }
            r[i] = s;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use linpd_core::{Kernel, Normalization};

    #[test]
    fn springs_equal_the_discrete_inverse_distance_kernel() {
        // K(N) = 2 K1/(N(N+1)) (A.1) vs linpd-core's discrete normalization: both are
        // c = 2K/(N(N+1) dx^2); only the rounding of the two formulas differs (rtol 1e-13).
        let mm = Micromodulus {
            kernel: Kernel::InverseDistance,
            normalization: Normalization::Discrete,
            modulus: 1.7,
            plane: None,
            partial_volume: false,
        };
        let a = Chain::new(0.25, 5.0, &mm).unwrap();
        let b = Chain::springs(1.7, 20, 0.25).unwrap();
        assert_eq!(a.n(), 20);
        for (x, y) in a.micromoduli().iter().zip(b.micromoduli()) {
            assert!((x - y).abs() <= 1e-13 * y, "{x} vs {y}");
        }
        // The lattice realizes the modulus: mu_2 = K (moment condition, one side).
        assert!((a.moment(2) - 1.7).abs() < 1e-13);
    }

    #[test]
    fn ring_modes_are_eigenvectors_with_the_symbol() {
        let chain = Chain::springs(1.0, 4, 0.5).unwrap();
        let ring = chain.ring(24).unwrap();
        for m in [0, 1, 5, 12] {
            let k = ring.wavenumber(m);
            let u: Vec<f64> = (0..24).map(|i| (k * ring.position(i)).cos()).collect();
            let mut y = vec![0.0; 24];
            ring.apply(&u, &mut y);
            let lam = chain.dx() * chain.symbol(k);
            for i in 0..24 {
                assert!((y[i] - lam * u[i]).abs() < 1e-13 * ring.diag, "m = {m}, i = {i}");
            }
        }
        assert!(Ring::new(chain, 8).is_err());
    }
}
