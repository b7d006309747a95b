//! Micromodulus kernels `lambda(|xi|) = c g(|xi|)` and their normalization.
//!
//! The linear bond-based force density (the linearization of the PMB force of the LAMMPS
//! howto, eq. (5)-(7), about the reference configuration) is
//!
//! ```text
//! L u (x) = \int_{H_x} lambda(|xi|) (xi (x) xi) / |xi|^2 (u(x + xi) - u(x)) dV_xi,
//! ```
//!
//! and in 1D `(xi (x) xi)/|xi|^2 = 1`, which is eq. (6) of Seleson, Beneddine & Prudhomme (2013).
//!
//! # Normalization to an elastic modulus
//!
//! For the affine field `u = H x` the strain-energy density is
//! `W = (1/4) \int lambda(|xi|) (e . H xi)^2 dV`, `e = xi/|xi|`. Isotropic extension `H = eps I`
//! gives `W = (eps^2/4) \int lambda |xi|^2 dV`; equating it with the classical
//! `W = (d^2/2) K_d eps^2` gives the moment condition
//!
//! ```text
//! \int_{H_0} lambda(|xi|) |xi|^2 dV = 2 d^2 K_d,                                   (M)
//! ```
//!
//! with `K_d` the bulk modulus of the `d`-dimensional theory:
//!
//! * 1D: `K_1 = K` (eq. (7) of the 2013 blending paper: `(1/2) \int C xi^2 = K`);
//! * 2D plane strain (bond-based PD has Poisson ratio 1/4): `K_2 = lambda_L + mu = 6K/5`;
//! * 2D plane stress (Poisson ratio 1/3, `E = 3K(1 - 2 nu) = K`): `K_2 = E / (2(1 - nu)) = 3K/4`;
//! * 3D (Poisson ratio 1/4): `K_3 = K`.
//!
//! Here `K` is always the three-dimensional bulk modulus of the material. For
//! `g = 1/|xi|` condition (M) gives `c = 2K/delta^2` in 1D (eq. (17) of the blending paper),
//! `c = 12 K_2 / (pi delta^3)` in 2D (`9E/(pi delta^3)` in plane stress, `48E/(5 pi delta^3)` in
//! plane strain: Ha & Bobaru's constants) and `c = 18K/(pi delta^4)` in 3D (LAMMPS howto eq. (6)).
//!
//! *Continuum* normalization evaluates the integral in (M) exactly (Gauss-Legendre, exact
//! for the polynomial kernels); *discrete* normalization replaces it by the lattice sum
//! `sum_k lambda(|k h|) nu_k h^d |k h|^2` so the discrete operator reproduces the modulus
//! exactly for isotropic extension. In 1D with `g = 1/|xi|` the discrete rule is
//! `c = 2K/(N(N+1) h^2)`, the `eps^2 -> N(N+1) dx^2` replacement of the blending paper, eq. (19).
//!
//! # Partial volumes
//!
//! With partial volumes on, a bond of length `r` sees the fraction (LAMMPS howto, "Modification
//! to the particle volume", with node radius `r_i = h/2`)
//! `nu(r) = 1` for `r <= delta - h/2`, `nu(r) = (delta - r)/h + 1/2` for `delta - h/2 < r <= delta`.

use crate::family::lattice_stencil;
use crate::CoreError;

/// Most lattice offsets the discrete normalization enumerates (a box of `(2 delta/h + 1)^d`;
/// 1e8 is a 3D ratio of 232, far beyond any modelling use): a mutated horizon of 1e18 spacings
/// tried to allocate 6 GB of offsets.
pub const MAX_DISCRETE_OFFSETS: f64 = 1e8;
/// The shape `g(r)` of a micromodulus on `0 < r <= delta`.
#[derive(Debug, Clone, PartialEq)]
pub enum Kernel {
    /// `g = 1`.
    Constant,
    /// `g = 1/r` (the PMB kernel; eq. (17) of the blending paper).
    InverseDistance,
    /// `g = 1 - r/delta` (Silling 2010, Example 5.1).
    Tent,
    /// `g = exp(-(r/l)^2)`.
    Gaussian {
        /// Decay length `l`.
        length: f64,
    },
    /// Piecewise-linear `g` through `(s_k, g_k)` with `s = r/delta` ascending in `[0, 1]`;
    /// constant beyond the last point up to `s = 1`.
    Tabulated {
        /// Normalized radii `r/delta`.
        s: Vec<f64>,
        /// Values of `g`.
        g: Vec<f64>,
    },
}

impl Kernel {
    /// Checks parameters (positive Gaussian length, a well-formed table).
    pub fn validate(&self) -> Result<(), CoreError> {
        match self {
            Kernel::Gaussian { length } if !(length.is_finite() && *length > 0.0) => {
                Err(CoreError::param("length", format!("must be > 0, got {length:e}")))
            }
            Kernel::Tabulated { s, g } => {
                if s.len() < 2 || s.len() != g.len() {
                    return Err(CoreError::param(
                        "table",
                        format!("needs >= 2 points and equal lengths, got {} radii and {} values", s.len(), g.len()),
                    ));
                }
                if s.windows(2).any(|w| !(w[1] > w[0])) || s[0] < 0.0 || s[s.len() - 1] > 1.0 {
                    return Err(CoreError::param("table", "radii r/delta must increase strictly within [0, 1]"));
                }
                if g.iter().any(|v| !v.is_finite() || *v < 0.0) {
                    return Err(CoreError::param("table", "values must be finite and >= 0"));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// `g(r)` for `0 < r <= delta`.
    pub fn shape(&self, r: f64, delta: f64) -> f64 {
        match self {
            Kernel::Constant => 1.0,
            Kernel::InverseDistance => 1.0 / r,
            Kernel::Tent => (1.0 - r / delta).max(0.0),
            Kernel::Gaussian { length } => (-(r / length).powi(2)).exp(),
            Kernel::Tabulated { s, g } => {
                let x = r / delta;
                if x <= s[0] {
                    return g[0];
                }
                match s.iter().position(|&v| v >= x) {
                    None => g[g.len() - 1],
                    Some(k) => {
                        let t = (x - s[k - 1]) / (s[k] - s[k - 1]);
                        g[k - 1] + t * (g[k] - g[k - 1])
                    }
                }
            }
        }
    }

    /// Breakpoints in `[0, delta]` where `g` is not smooth (for exact quadrature).
    pub fn breakpoints(&self, delta: f64) -> Vec<f64> {
        let mut b = vec![0.0];
        if let Kernel::Tabulated { s, .. } = self {
            b.extend(s.iter().filter(|&&v| v > 0.0 && v < 1.0).map(|v| v * delta));
        }
        b.push(delta);
        b
    }
}

/// The 2D constitutive assumption.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlaneModel {
    /// Plane stress: Poisson ratio 1/3, `K_2 = 3K/4`.
    Stress,
    /// Plane strain: Poisson ratio 1/4, `K_2 = 6K/5`.
    Strain,
}

/// How the amplitude `c` of `lambda = c g` is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalization {
    /// `c` given explicitly; material moduli are then multipliers of it.
    Amplitude(f64),
    /// Moment condition (M) with the exact integral.
    Continuum,
    /// Moment condition (M) with the lattice sum (exact on the lattice).
    Discrete,
}

/// A micromodulus: kernel, normalization, reference modulus and partial-volume flag.
#[derive(Debug, Clone, PartialEq)]
pub struct Micromodulus {
    /// Shape `g`.
    pub kernel: Kernel,
    /// How to pick `c`.
    pub normalization: Normalization,
    /// Reference bulk modulus `K` (the 1D modulus in 1D). Ignored for [`Normalization::Amplitude`].
    pub modulus: f64,
    /// 2D assumption; required in 2D, ignored otherwise.
    pub plane: Option<PlaneModel>,
    /// Partial-volume scaling at the horizon edge.
    pub partial_volume: bool,
}

/// Partial-volume fraction `nu(r)` for node radius `h/2` (LAMMPS howto).
pub fn partial_volume(r: f64, delta: f64, h: f64) -> f64 {
    if r <= delta - 0.5 * h {
        1.0
    } else {
        // Bonds come from a closed-ball test with a relative tolerance; clamp to the linear ramp.
        ((delta - r) / h + 0.5).clamp(0.0, 1.0)
    }
}

/// `K_d` of the moment condition (M).
pub fn dimensional_bulk_modulus(dim: usize, k: f64, plane: Option<PlaneModel>) -> f64 {
    match (dim, plane) {
        (2, Some(PlaneModel::Stress)) => 0.75 * k,
        (2, _) => 1.2 * k,
        _ => k,
    }
}

/// `\int f` over `[breaks[0], breaks[last]]` by 8-point Gauss-Legendre, each interval between
/// breaks cut into `panels(length)` equal panels; exact for polynomials of degree <= 15 on each.
pub fn gauss_legendre(f: impl Fn(f64) -> f64, breaks: &[f64], panels: impl Fn(f64) -> usize) -> f64 {
    const X: [f64; 4] =
        [0.183_434_642_495_649_8, 0.525_532_409_916_329, 0.796_666_477_413_626_7, 0.960_289_856_497_536_3];
    const W: [f64; 4] =
        [0.362_683_783_378_362, 0.313_706_645_877_887_3, 0.222_381_034_453_374_5, 0.101_228_536_290_376_3];
    let mut total = 0.0;
    for seg in breaks.windows(2) {
        let panels = panels(seg[1] - seg[0]).max(1);
        let w = (seg[1] - seg[0]) / panels as f64;
        for p in 0..panels {
            let mid = seg[0] + (p as f64 + 0.5) * w;
            for k in 0..4 {
                let dx = 0.5 * w * X[k];
                total += 0.5 * w * W[k] * (f(mid - dx) + f(mid + dx));
            }
        }
    }
    total
}

impl Micromodulus {
    /// Checks the kernel, modulus and 2D assumption.
    pub fn validate(&self, dim: usize) -> Result<(), CoreError> {
        self.kernel.validate()?;
        match self.normalization {
            Normalization::Amplitude(c) if !(c.is_finite() && c > 0.0) => {
                return Err(CoreError::param("amplitude", format!("must be > 0, got {c:e}")))
            }
            Normalization::Amplitude(_) => {}
            _ if !(self.modulus.is_finite() && self.modulus > 0.0) => {
                return Err(CoreError::param("modulus", format!("must be > 0, got {:e}", self.modulus)))
            }
            _ => {}
        }
        if dim == 2 && self.plane.is_none() && !matches!(self.normalization, Normalization::Amplitude(_)) {
            return Err(CoreError::param("plane", "2D needs \"stress\" or \"strain\""));
        }
        Ok(())
    }

    /// Reference modulus that material moduli are measured against (1 for an explicit amplitude).
    pub fn reference_modulus(&self) -> f64 {
        match self.normalization {
            Normalization::Amplitude(_) => 1.0,
            _ => self.modulus,
        }
    }

    /// The exact integral `\int_{H_0} g(|xi|) |xi|^2 dV` (continuum moment of the shape).
    pub fn continuum_moment(&self, dim: usize, delta: f64) -> f64 {
        let (omega, p) = match dim {
            1 => (2.0, 2),
            2 => (2.0 * std::f64::consts::PI, 3),
            _ => (4.0 * std::f64::consts::PI, 4),
        };
        let f = |r: f64| if r > 0.0 { self.kernel.shape(r, delta) * r.powi(p) } else { 0.0 };
        omega * gauss_legendre(f, &self.kernel.breakpoints(delta), |_| 64)
    }

    /// The lattice sum `sum_k g(|kh|) nu_k h^d |kh|^2` over the interior stencil (of the infinite
    /// lattice: [`Micromodulus::amplitude`] refuses more than [`MAX_DISCRETE_OFFSETS`] offsets).
    pub fn discrete_moment(&self, dim: usize, delta: f64, h: f64) -> f64 {
        let vol = h.powi(dim as i32);
        lattice_stencil(dim, delta / h)
            .iter()
            .map(|k| {
                let r = h * ((k[0] * k[0] + k[1] * k[1] + k[2] * k[2]) as f64).sqrt();
                let nu = if self.partial_volume { partial_volume(r, delta, h) } else { 1.0 };
                self.kernel.shape(r, delta) * nu * vol * r * r
            })
            .sum()
    }

    /// The moment condition's right-hand side `2 d^2 K_d` (M): the amplitude is it over the
    /// kernel's moment.
    pub fn moment_target(&self, dim: usize) -> f64 {
        2.0 * (dim * dim) as f64 * dimensional_bulk_modulus(dim, self.modulus, self.plane)
    }

    /// The amplitude `c` with `lambda = c g` for the reference modulus.
    pub fn amplitude(&self, dim: usize, delta: f64, h: f64) -> Result<f64, CoreError> {
        let target = self.moment_target(dim);
        let moment = match self.normalization {
            Normalization::Amplitude(c) => return Ok(c),
            Normalization::Continuum => self.continuum_moment(dim, delta),
            Normalization::Discrete => {
                // the sum runs over the infinite lattice's stencil, not the grid's: bound it
                let offsets = (2.0 * delta / h + 1.0).powi(dim as i32);
                if !(offsets <= MAX_DISCRETE_OFFSETS) {
                    return Err(CoreError::param(
                        "horizon",
                        format!(
                            "horizon/spacing {:e}: the discrete normalization sums the kernel over ~{offsets:.1e} lattice \
                             offsets, more than {MAX_DISCRETE_OFFSETS:e}; use \"normalize\": \"continuum\" or a smaller horizon",
                            delta / h
                        ),
                    ));
                }
                self.discrete_moment(dim, delta, h)
            }
        };
        if !(moment.is_finite() && moment > 0.0) {
            return Err(CoreError::param(
                "micromodulus",
                format!("the kernel's moment over the horizon is {moment:e}: it cannot be normalized to a modulus"),
            ));
        }
        let c = target / moment;
        if !c.is_finite() {
            return Err(CoreError::param(
                "micromodulus",
                format!(
                    "modulus {:e} overflows: the amplitude 2 d^2 K / moment = {target:e} / {moment:e} is not finite; \
                     use smaller units for the modulus",
                    self.modulus
                ),
            ));
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use std::f64::consts::PI;

    fn mm(kernel: Kernel, normalization: Normalization, plane: Option<PlaneModel>) -> Micromodulus {
        Micromodulus { kernel, normalization, modulus: 2.0, plane, partial_volume: false }
    }

    #[test]
    fn continuum_amplitudes_match_closed_forms() {
        // Closed forms quoted in the module docs; quadrature is exact for these polynomials,
        // so the only error is round-off (rtol 1e-13).
        let d = 0.3;
        let k = 2.0;
        let c1 = mm(Kernel::InverseDistance, Normalization::Continuum, None).amplitude(1, d, 0.01).unwrap();
        assert_relative_eq!(c1, 2.0 * k / (d * d), max_relative = 1e-13);
        let c3 = mm(Kernel::InverseDistance, Normalization::Continuum, None).amplitude(3, d, 0.01).unwrap();
        assert_relative_eq!(c3, 18.0 * k / (PI * d.powi(4)), max_relative = 1e-13);
        // Plane stress with E = K (nu = 1/3): c = 9E/(pi delta^3).
        let cs = mm(Kernel::InverseDistance, Normalization::Continuum, Some(PlaneModel::Stress))
            .amplitude(2, d, 0.01)
            .unwrap();
        assert_relative_eq!(cs, 9.0 * k / (PI * d.powi(3)), max_relative = 1e-13);
        // Plane strain with E = 3K(1 - 2/4) = 1.5K: c = 48E/(5 pi delta^3).
        let ce = mm(Kernel::InverseDistance, Normalization::Continuum, Some(PlaneModel::Strain))
            .amplitude(2, d, 0.01)
            .unwrap();
        assert_relative_eq!(ce, 48.0 * 1.5 * k / (5.0 * PI * d.powi(3)), max_relative = 1e-13);
        // Tent in 1D: int_0^d (1 - r/d) r^2 dr = d^3/12, so c = 12K/d^3.
        let ct = mm(Kernel::Tent, Normalization::Continuum, None).amplitude(1, d, 0.01).unwrap();
        assert_relative_eq!(ct, 12.0 * k / d.powi(3), max_relative = 1e-13);
    }

    #[test]
    fn discrete_amplitude_is_the_papers_n_n_plus_1_rule() {
        // Eq. (19) of the blending paper: c = 2K / (N (N + 1) dx^2).
        let h = 1.0 / 300.0;
        let n = 15.0;
        let c = mm(Kernel::InverseDistance, Normalization::Discrete, None).amplitude(1, 0.05, h).unwrap();
        assert_relative_eq!(c, 2.0 * 2.0 / (n * (n + 1.0) * h * h), max_relative = 1e-12);
    }

    #[test]
    fn tabulated_tent_equals_tent() {
        let tab = Kernel::Tabulated { s: vec![0.0, 1.0], g: vec![1.0, 0.0] };
        for r in [0.01, 0.1, 0.25] {
            assert_relative_eq!(tab.shape(r, 0.3), Kernel::Tent.shape(r, 0.3), max_relative = 1e-14);
        }
        assert!(Kernel::Tabulated { s: vec![0.5, 0.2], g: vec![1.0, 1.0] }.validate().is_err());
    }

    #[test]
    fn partial_volume_ramp() {
        assert_eq!(partial_volume(0.2, 0.3, 0.1), 1.0);
        assert_relative_eq!(partial_volume(0.3, 0.3, 0.1), 0.5, max_relative = 1e-14);
        assert_relative_eq!(partial_volume(0.275, 0.3, 0.1), 0.75, max_relative = 1e-12);
    }
}
