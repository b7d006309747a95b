//! Per-node output fields of the linearized LPS solid: the dilatation `theta_i` and the strain
//! energy density `W_i` of the tangent `A` (what `result.json` and `result.vtu` report).
//!
//! # The linearized energy density
//!
//! With the linearized extension `e_ij = n_ij . (u_j - u_i)`, `n_ij = xi / |xi|`, and the
//! linearized dilatation `theta_i = (d / m_i) sum_j omega |xi| e_ij nu V_j`
//! ([`LpsModel::linearized_theta`]), node `i` stores
//!
//! ```text
//! W_i = kappa theta_i^2 / 2 + (a G / (2 m_i)) sum_j omega (e_ij - theta_i |xi| / d)^2 nu V_j
//!       + a G theta_i^2 (m_i - m_i^lat) / (2 m_i d^2),
//! ```
//!
//! the energy density of [`crate::force`] with `e` linearized (the last term is zero, bit for
//! bit, unless a surface correction replaced `m_i` by `m_0`; [`crate::surface`]). Expanding the
//! square with `sum_j omega |xi| e nu V_j = m_i theta_i / d` and `sum_j omega |xi|^2 nu V_j =
//! m_i^lat` gives
//!
//! ```text
//! W_i = (kappa - a G / d^2) theta_i^2 / 2 + (a G / (2 m_i)) sum_j omega e_ij^2 nu V_j,
//! ```
//!
//! whose Hessian, summed with the weights `V_i`, is the tangent of [`crate::tangent`] term by
//! term (`C_k g_k g_k^T` and the pair part `s_ij n n^T`). So, in exact arithmetic,
//!
//! ```text
//! sum_i W_i V_i = u . A u / 2
//! ```
//!
//! for every `u`, in 2D (plane stress and plane strain only change `kappa`) and 3D, with or
//! without the surface correction; no term is missing. We store the first (sum of squares)
//! form: every term is `>= 0` (`m_0 >= m_i^lat`), so `W_i >= 0` node by node, and a rigid
//! motion gives `e_ij = 0`, `theta_i = 0`, `W_i = 0` up to round-off.

use crate::LpsModel;
use rayon::prelude::*;

impl LpsModel {
    /// Volume `V_j` of node `j` (the weights of the energy sum `E = sum_i V_i W_i`). Read
    /// volumes through this accessor: node volumes may become per-node.
    pub fn node_volume(&self, j: usize) -> f64 {
        self.volumes[j]
    }

    /// Linearized strain energy density `W_i` of every node (see the module docs):
    /// `sum_i W_i V_i = u . A u / 2` with `A` the tangent and `V_i` [`LpsModel::node_volume`].
    pub fn linearized_energy_density(&self, u: &[f64]) -> Vec<f64> {
        let theta = self.linearized_theta(u);
        let d = self.dim;
        let df = d as f64;
        (0..self.n_nodes())
            .into_par_iter()
            .map(|i| {
                let (mut dev, mut m_lattice) = (0.0, 0.0);
                for (j, w, r) in self.bonds(i) {
                    let xi = self.bond_vector(i, j);
                    let mut e = 0.0;
                    for a in 0..d {
                        e += xi[a] * (u[d * j + a] - u[d * i + a]);
                    }
                    let ed = e / r - theta[i] * r / df;
                    dev += w * ed * ed;
                    m_lattice += w * r * r;
                }
                let (kappa, a_g) = (self.kappa_at(i), self.a_g_at(i));
                let surface = 0.5 * a_g * theta[i] * theta[i] * (self.m[i] - m_lattice) / (self.m[i] * df * df);
                0.5 * kappa * theta[i] * theta[i] + 0.5 * a_g / self.m[i] * dev + surface
            })
            .collect()
    }
}
