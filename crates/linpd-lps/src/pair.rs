//! The pair part `A_pair` of the LPS tangent as a model of its own: the SPD companion on whose
//! hierarchy the matrix-free multigrid preconditions the whole tangent.
//!
//! [`crate::tangent`] splits the tangent as `A = A_pair + sum_k C_k g_k g_k^T`. `A_pair` is a
//! bond-based operator (bond stiffness `s_ij = V_i V_j a G omega nu (1/m_i + 1/m_j)`, one
//! horizon, positive), while the rank-one dilatation terms couple nodes two horizons apart.
//! A Galerkin hierarchy of `A` reads those two-horizon block rows: `O(|F|^2 d^2)` work per row
//! (14,884 blocks a node at `delta = 3h` in 3D) and about 6x the bond graph's `A P` entries.
//! The hierarchy is built from `A_pair` instead, whose block rows cost `O(|F|)`; CG still runs
//! on `A`.
//!
//! Why that preconditions `A`: with `sum_j omega |xi| e nu V_j = m theta / d` and `sum_j
//! omega |xi|^2 nu V_j = m` (no surface correction), node `i`'s pair energy splits into its
//! deviatoric energy and a dilatation term,
//!
//! ```text
//! (a G / (2 m_i)) sum_j omega e^2 nu V_j = W_i^dev + kappa_pair theta_i^2 / 2,   kappa_pair = a G / d^2,
//! W_i = W_i^dev + kappa theta_i^2 / 2                              (the LPS energy, W_i^dev >= 0),
//! ```
//!
//! so node by node, and therefore for every `u`,
//!
//! ```text
//! min(1, kappa / kappa_pair) u . A_pair u  <=  u . A u  <=  max(1, kappa / kappa_pair) u . A_pair u.
//! ```
//!
//! `kappa_pair` is the dilatational modulus at which `C_k = 0` (3D: `5G/3`, a Poisson ratio of
//! 1/4, where `A = A_pair` exactly). CG preconditioned by a (multigrid) inverse of `A_pair`
//! needs at most `sqrt(max(kappa/kappa_pair, kappa_pair/kappa))` times the iterations it
//! needs on `A_pair`: in 3D 1.14x at a Poisson ratio of 0.3, 1.34x at 0.35, 2.4x at 0.45 (near
//! incompressibility the bound degrades, as for every displacement-only solver:
//! docs/solvers.md, "Near-incompressible LPS through CG"). Per-node moduli take the extreme
//! ratios over the nodes. With `bulk_weighted_volume` the surface nodes' `m_i` is no longer
//! their lattice sum, which changes their effective `kappa_pair` (up to 2x); the bound then
//! holds with the extreme ratios over the nodes (the moment-matching corrections recompute `m`
//! from their rescaled weights and keep it as stated).

use crate::stencil::PairStencil;
use crate::LpsModel;
use linpd_core::sparse::Csc;
use linpd_core::{DofMap, FastApply, Model, Point};
use rayon::prelude::*;

/// `A_pair` of an [`LpsModel`] (module docs).
pub struct PairPart<'a>(pub &'a LpsModel);

impl Model for PairPart<'_> {
    fn kind(&self) -> &'static str {
        "lps-pair"
    }
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn n_nodes(&self) -> usize {
        self.0.n_nodes()
    }
    fn position(&self, i: usize) -> Point {
        self.0.positions[i]
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        match self.0.stencil() {
            Some(st) => st.for_each_neighbour(i, f),
            None => self.0.family().neighbors(i).iter().for_each(|&j| f(j as usize)),
        }
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        let d = self.dim();
        assert_eq!(u.len(), self.0.n_dofs());
        assert_eq!(y.len(), self.0.n_dofs());
        y.par_chunks_mut(d).enumerate().for_each(|(i, yi)| {
            yi.iter_mut().for_each(|v| *v = 0.0);
            self.0.for_each_pair_bond(i, |j, s, _, xi| {
                let proj: f64 = (0..d).map(|a| xi[a] * (u[d * i + a] - u[d * j + a])).sum();
                for a in 0..d {
                    yi[a] += s * proj * xi[a];
                }
            });
        });
    }
    fn diagonal(&self) -> Vec<f64> {
        let d = self.dim();
        let mut out = vec![0.0; self.0.n_dofs()];
        let stencil = self.0.stencil();
        out.par_chunks_mut(d).enumerate().for_each(|(i, o)| match stencil {
            // the last block of the row is the diagonal one
            Some(st) => st.pair_block_row(i, &mut |j, b| {
                if j == i {
                    (0..d).for_each(|a| o[a] = b[a * d + a]);
                }
            }),
            None => self.0.for_each_pair_bond(i, |_, s, _, xi| (0..d).for_each(|a| o[a] += s * xi[a] * xi[a])),
        });
        out
    }
    /// From the block rows (a check and a fallback; the multigrid reads block rows).
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        linpd_core::model::assemble_free_from_blocks(self, dofs).expect("the pair part has block rows")
    }
    /// `A_ij = -s_ij xi xi^T` per bond, then `A_ii = sum_j s_ij xi xi^T` (from the stencils of a
    /// homogeneous full box: [`crate::LpsStencil::pair_block_row`]).
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        if let Some(st) = self.0.stencil() {
            st.pair_block_row(i, f);
            return true;
        }
        let d = self.dim();
        let mut diag = [0.0; 9];
        self.0.for_each_pair_bond(i, |j, s, _, xi| {
            let mut b = [0.0; 9];
            for a in 0..d {
                for c in 0..d {
                    b[a * d + c] = -s * xi[a] * xi[c];
                    diag[a * d + c] -= b[a * d + c];
                }
            }
            f(j, &b[..d * d]);
        });
        f(i, &diag[..d * d]);
        true
    }
    /// The stencils of a homogeneous material on the full box ([`crate::stencil`]).
    fn fast_apply(&self) -> Option<FastApply<'_>> {
        let st = self.0.stencil()?;
        Some(FastApply { op: Box::new(PairStencil(st)), label: "lps-pair-stencil" })
    }
    fn describe_node(&self, i: usize) -> String {
        self.0.describe_node(i)
    }
}
