//! The nonlinear LPS internal force (LAMMPS howto Algorithms 2-4; no damage, no contact, no
//! short-range forces), its energy and the dilatation.
//!
//! ```text
//! e_ij    = |Y_ij| - |xi_ij|,  Y_ij = xi_ij + u_j - u_i
//! theta_i = (d / m_i) sum_j omega |xi| e_ij nu V_j                        (Algorithm 4)
//! F_i     = V_i sum_j [ (d kappa - a G / d) (theta_i / m_i + theta_j / m_j) omega |xi|
//!                       + a G (omega / m_i + omega / m_j) e_ij ] nu V_j Y_ij / |Y_ij|
//!                                                                       (Algorithm 2)
//! E       = sum_i V_i W_i,
//! W_i     = kappa theta_i^2 / 2 + (a G / (2 m_i)) sum_j omega (e_ij - theta_i |xi| / d)^2 nu V_j
//! ```
//!
//! In 3D `d kappa - a G / d = 3K - 5G` and `a G = 15 G`, the howto's formula; `F_i` is the
//! howto's force density times `V_i`. `F = -dE/du` exactly (also on the lattice), because
//! `sum_j omega e^d |xi| nu V_j = m theta / d - theta m / d = 0` removes the derivative of
//! `theta` in the deviatoric term. `omega` is spherical, so `omega_+ = omega_-`, except with the
//! `position_aware` correction ([`crate::surface`]): then each node has its own influence
//! `omega_i(xi)`, the far end's term reads `omega_j` (the weight `w_ji` of the far end's family,
//! read through the reverse-bond index) and `F = -dE/du` still holds term by term (each node's energy uses
//! only its own `omega_i`).
//!
//! With a surface correction ([`crate::surface`]) `m_i` is no longer the lattice sum
//! `m_i^lat = sum_j omega |xi|^2 nu V_j`, that cross term becomes `theta (m_i - m_i^lat) / d`,
//! and `W_i` gets the extra term `a G theta_i^2 (m_i - m_i^lat) / (2 m_i d^2)` (zero without
//! correction) so that `F = -dE/du` still holds: the force is always the gradient of
//! `sum_i V_i [(kappa - a G / d^2) theta_i^2 / 2 + (a G / (2 m_i)) sum_j omega e^2 nu V_j]`.

use crate::model::{far, norm};
use crate::LpsModel;
use rayon::prelude::*;

impl LpsModel {
    /// Current bond `Y = xi + u_j - u_i`, its length and the extension `e = |Y| - |xi|`.
    #[inline]
    fn deformed(&self, u: &[f64], i: usize, j: usize, r: f64) -> ([f64; 3], f64, f64) {
        let d = self.dim;
        let mut y = self.bond_vector(i, j);
        for a in 0..d {
            y[a] += u[d * j + a] - u[d * i + a];
        }
        let ry = norm(&y);
        (y, ry, ry - r)
    }

    /// Nonlinear dilatation `theta_i` of every node (Algorithm 4).
    pub fn theta(&self, u: &[f64]) -> Vec<f64> {
        assert_eq!(u.len(), self.n_dofs(), "displacement length");
        let d = self.dim as f64;
        (0..self.n_nodes())
            .into_par_iter()
            .map(|i| {
                let s: f64 = self.bonds(i).map(|(j, w, r)| w * r * self.deformed(u, i, j, r).2).sum();
                d / self.m[i] * s
            })
            .collect()
    }

    /// `theta_k` of one node for a displacement given node by node (used by the local
    /// finite-difference tangent, [`crate::fd`]); the same sum as [`LpsModel::theta`].
    pub(crate) fn theta_at(&self, k: usize, disp: impl Fn(usize) -> [f64; 3]) -> f64 {
        let d = self.dim;
        let uk = disp(k);
        let s: f64 = self
            .bonds(k)
            .map(|(j, w, r)| {
                let uj = disp(j);
                let mut y = self.bond_vector(k, j);
                for a in 0..d {
                    y[a] += uj[a] - uk[a];
                }
                w * r * (norm(&y) - r)
            })
            .sum();
        d as f64 / self.m[k] * s
    }

    /// The internal force on one node (the Algorithm 2 sum of [`LpsModel::internal_force`])
    /// for a displacement and dilatation given node by node.
    pub(crate) fn force_at(
        &self,
        i: usize,
        disp: impl Fn(usize) -> [f64; 3],
        theta: impl Fn(usize) -> f64,
    ) -> [f64; 3] {
        let d = self.dim;
        let vi = self.volumes[i];
        let ui = disp(i);
        let (ti, mi) = (theta(i), self.m[i]);
        let mut fi = [0.0; 3];
        for (j, w, w_far, r) in self.bond_pairs(i) {
            let uj = disp(j);
            let mut y = self.bond_vector(i, j);
            for a in 0..d {
                y[a] += uj[a] - ui[a];
            }
            let ry = norm(&y);
            let e = ry - r;
            let (tj, mj) = (theta(j), self.m[j]);
            let fhat = self.bond_force(i, j, [ti, tj], [w / mi, far(w_far, vi, self.volumes[j]) / mj], r, e);
            for a in 0..d {
                fi[a] += vi * fhat * y[a] / ry;
            }
        }
        fi
    }

    /// Strain-energy density `W_i` of every node.
    pub fn energy_density(&self, u: &[f64]) -> Vec<f64> {
        let theta = self.theta(u);
        let d = self.dim as f64;
        (0..self.n_nodes())
            .into_par_iter()
            .map(|i| {
                let (mut dev, mut m_lattice) = (0.0, 0.0);
                for (j, w, r) in self.bonds(i) {
                    let ed = self.deformed(u, i, j, r).2 - theta[i] * r / d;
                    dev += w * ed * ed;
                    m_lattice += w * r * r;
                }
                // Zero (bit for bit) unless a surface correction replaced m_i by m_0; then it
                // is the term that keeps F = -dE/du (see `crate::surface`).
                let (kappa, a_g) = (self.kappa_at(i), self.a_g_at(i));
                let surface = 0.5 * a_g * theta[i] * theta[i] * (self.m[i] - m_lattice) / (self.m[i] * d * d);
                0.5 * kappa * theta[i] * theta[i] + 0.5 * a_g / self.m[i] * dev + surface
            })
            .collect()
    }

    /// Total strain energy `E = sum_i V_i W_i`.
    pub fn energy(&self, u: &[f64]) -> f64 {
        self.energy_density(u).iter().zip(&self.volumes).map(|(w, v)| w * v).sum::<f64>()
    }

    /// Nonlinear internal force `F(u) = -dE/du` (force on each node, `V_i` times the force
    /// density of Algorithm 2), written into `f`.
    pub fn internal_force(&self, u: &[f64], f: &mut [f64]) {
        assert_eq!(f.len(), self.n_dofs(), "force length");
        let theta = self.theta(u);
        let d = self.dim;
        f.par_chunks_mut(d).enumerate().for_each(|(i, fi)| {
            let vi = self.volumes[i];
            fi.iter_mut().for_each(|v| *v = 0.0);
            let (ti, mi) = (theta[i], self.m[i]);
            for (j, w, w_far, r) in self.bond_pairs(i) {
                // w = omega_i nu V_j, and the far end's omega_j nu V_j from its weight w_far.
                let (y, ry, e) = self.deformed(u, i, j, r);
                let (tj, mj) = (theta[j], self.m[j]);
                let fhat = self.bond_force(i, j, [ti, tj], [w / mi, far(w_far, vi, self.volumes[j]) / mj], r, e);
                for a in 0..d {
                    fi[a] += vi * fhat * y[a] / ry;
                }
            }
        });
    }
}

impl LpsModel {
    /// The scalar bond force of Algorithm 2 with per-end influence weights
    /// `w_i = omega_i nu V_j`, `w_j = omega_j nu V_j` (equal for a spherical influence function)
    /// and per-end constants `c_k = d kappa_k - a G_k / d`:
    /// `(c_i theta_i w_i / m_i + c_j theta_j w_j / m_j) |xi| + (a G_i w_i / m_i + a G_j w_j / m_j) e`,
    /// given `[theta_i, theta_j]` and `[w_i / m_i, w_j / m_j]`.
    #[inline]
    fn bond_force(&self, i: usize, j: usize, theta: [f64; 2], w_over_m: [f64; 2], r: f64, e: f64) -> f64 {
        let d = self.dim as f64;
        let [ti, tj] = theta;
        let [wi, wj] = w_over_m;
        let (ai, aj) = (self.a_g_at(i), self.a_g_at(j));
        let (ci, cj) = (d * self.kappa_at(i) - ai / d, d * self.kappa_at(j) - aj / d);
        (ci * ti * wi + cj * tj * wj) * r + (ai * wi + aj * wj) * e
    }
}
