//! Blending functions `beta(x)` on the geometry `Omega_CE^L | Omega_b^L | Omega_PD | Omega_b^R |
//! Omega_CE^R` given by `L1 < L2 < L3 < L4` (section 4, Fig. 2).
//!
//! In the left bridge, with `s = (x - L1)/(L2 - L1)`, and mirrored in the right bridge with
//! `s = (L4 - x)/(L4 - L3)`:
//!
//! * `Linear`: `beta = s`;
//! * `Cubic`: `beta = 3 s^2 - 2 s^3` (the C^1 cubic with zero slope at both bridge ends);
//! * `Constant { value }`: `beta = value` inside the open bridges. The paper does not give the
//!   bridge value of its piecewise-constant function (Fig. 3 shows a single level); the default
//!   is `1/2`, the value that makes the bond shares `(beta_i + beta_j)/2` symmetric between the
//!   two models;
//! * `Piecewise { s, beta }`: piecewise linear through user points, `s` in `[0, 1]` ascending.
//!
//! `beta = 0` for `x <= L1` or `x >= L4`, and `1` for `L2 <= x <= L3`.

use crate::BlendError;

/// `L1 < L2 < L3 < L4`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regions {
    /// Start of the left bridge.
    pub l1: f64,
    /// Start of the PD region.
    pub l2: f64,
    /// End of the PD region.
    pub l3: f64,
    /// End of the right bridge.
    pub l4: f64,
}

/// A blending function shape in the bridges.
#[derive(Debug, Clone, PartialEq)]
pub enum Blending {
    /// Constant `value` in the bridges.
    Constant {
        /// Bridge value in `[0, 1]`.
        value: f64,
    },
    /// Linear ramp.
    Linear,
    /// Cubic `3 s^2 - 2 s^3`.
    Cubic,
    /// User points `(s_k, beta_k)`.
    Piecewise {
        /// Normalized bridge coordinates, ascending in `[0, 1]`.
        s: Vec<f64>,
        /// Values in `[0, 1]`.
        beta: Vec<f64>,
    },
}

impl Blending {
    /// Checks parameters.
    pub fn validate(&self) -> Result<(), BlendError> {
        match self {
            Blending::Constant { value } if !(0.0..=1.0).contains(value) => {
                Err(BlendError::param("blending.value", format!("must be in [0, 1], got {value:e}")))
            }
            Blending::Piecewise { s, beta } => {
                if s.len() < 2 || s.len() != beta.len() {
                    return Err(BlendError::param(
                        "blending",
                        "piecewise needs >= 2 points with equal lengths of s and beta",
                    ));
                }
                if s.windows(2).any(|w| !(w[1] > w[0])) || s[0] < 0.0 || s[s.len() - 1] > 1.0 {
                    return Err(BlendError::param("blending.s", "must increase strictly within [0, 1]"));
                }
                if beta.iter().any(|b| !(0.0..=1.0).contains(b)) {
                    return Err(BlendError::param("blending.beta", "values must be in [0, 1]"));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// The shape on a bridge, `s in (0, 1)` from the CE side to the PD side.
    pub fn shape(&self, s: f64) -> f64 {
        match self {
            Blending::Constant { value } => *value,
            Blending::Linear => s,
            Blending::Cubic => s * s * (3.0 - 2.0 * s),
            Blending::Piecewise { s: ss, beta } => {
                if s <= ss[0] {
                    return beta[0];
                }
                match ss.iter().position(|&v| v >= s) {
                    None => beta[beta.len() - 1],
                    Some(k) => beta[k - 1] + (s - ss[k - 1]) / (ss[k] - ss[k - 1]) * (beta[k] - beta[k - 1]),
                }
            }
        }
    }

    /// `beta(x)`; `tol` decides membership of region ends (a length).
    pub fn beta(&self, x: f64, r: &Regions, tol: f64) -> f64 {
        if x <= r.l1 + tol || x >= r.l4 - tol {
            0.0
        } else if x >= r.l2 - tol && x <= r.l3 + tol {
            1.0
        } else if x < r.l2 {
            self.shape((x - r.l1) / (r.l2 - r.l1))
        } else {
            self.shape((r.l4 - x) / (r.l4 - r.l3))
        }
    }
}
