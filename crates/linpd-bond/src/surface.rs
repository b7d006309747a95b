//! The `energy` surface correction of the bond-based operator (issue #14).
//!
//! A node near a free surface has fewer bonds than an interior node and stores too little
//! strain energy for a homogeneous deformation (the model is too soft there). For the affine
//! field `u = eps x` the energy density of node `i` is
//!
//! ```text
//! W_i = (c / 4) sum_{j in F_i} g(|xi|) nu V_j |xi|^2 (n . eps . n)^2,      n = xi / |xi|,
//! ```
//!
//! a contraction of the node's fourth bond moments ([`linpd_core::surface`], eq. (S1), with
//! `beta_ij = g(|xi|) nu V_j |xi|^2`). [`linpd_core::surface::fit_moments`] gives every node the
//! positive factor `phi_i(n) = exp(lambda_i . psi(n))` of the bond direction ((S2)) that makes
//! its even moments equal the interior lattice's, i.e. that gives the node the interior's energy
//! density for the uniaxial strains and simple shears along the lattice axes and every
//! combination of them (the "few affine states" of Le & Bobaru's energy method, 6 in 3D and 3 in
//! 2D, matched at once; states coupling normal strains to shears cannot be matched at edges
//! with positive factors). A bond joins two nodes with different factors; as in the energy
//! method the bond gets the mean of its ends,
//!
//! ```text
//! w_ij  ->  w_ij (phi_i(n_ij) + phi_j(n_ij)) / 2,                                        (S3)
//! ```
//!
//! which keeps `w_ij = w_ji` (so `A` stays symmetric, its block rows sum to zero and the rigid
//! motions stay in its null space) and leaves every bond between two interior nodes exactly
//! unchanged (both factors are exactly 1). The mean makes the node's energy exact only where
//! its partners' factors agree with its own; this is the price of a pairwise (bond-based) force
//! and why LPS also offers a per-node, unaveraged correction (`position_aware`).
//!
//! Nodes of the grid's outer layer keep `phi = 1`: the layer is where volume constraints and
//! loads go, not a free surface, and correcting it would change the rows of the body nodes next
//! to it (an affine field given on a layer all around the body would no longer be the exact
//! solution). A face that should be corrected as a free surface has no layer.
//!
//! The weights `beta` are geometric: the micromodulus shape and partial volume, no phase
//! modulus and no defect factor, so material interfaces and weakened bonds are not "corrected";
//! bonds cut by a defect (weight 0) are left out of the family, so crack faces are corrected
//! like other free surfaces.

use crate::BondOperator;
use linpd_core::family::lattice_stencil;
use linpd_core::kernel::partial_volume;
use linpd_core::surface::{fit_moments, moments, CorrectionSummary, MomentFit};
use linpd_core::{Grid, Micromodulus};
use rayon::prelude::*;
use std::time::Instant;

impl BondOperator {
    /// The operator with the `energy` surface correction (S3) applied to its weights. `grid`,
    /// `horizon` and `micromodulus` must be the ones the operator was built with
    /// ([`BondOperator::on_grid`]); the target moments are those of the full lattice stencil.
    pub fn with_energy_correction(
        mut self,
        grid: &Grid,
        horizon: f64,
        micromodulus: &Micromodulus,
    ) -> (Self, CorrectionSummary) {
        let start = Instant::now();
        let dim = self.dim();
        let h = grid.spacing();
        let nu = |r: f64| if micromodulus.partial_volume { partial_volume(r, horizon, h) } else { 1.0 };
        let beta = |r: f64, v: f64| micromodulus.kernel.shape(r, horizon) * nu(r) * v * r * r;
        let target = moments(
            dim,
            lattice_stencil(dim, horizon / h).into_iter().map(|k| {
                let xi = [k[0] as f64 * h, k[1] as f64 * h, k[2] as f64 * h];
                let r = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                ([xi[0] / r, xi[1] / r, xi[2] / r], beta(r, grid.volume()))
            }),
        );
        let fits: Vec<MomentFit> = (0..self.n_nodes())
            .into_par_iter()
            .map(|i| {
                if grid.is_layer(i) {
                    // the layer holds volume constraints and loads: not a free surface
                    return MomentFit::identity(dim);
                }
                let bonds: Vec<([f64; 3], f64)> = self
                    .family()
                    .neighbors(i)
                    .iter()
                    .zip(self.weights(i))
                    .filter(|(_, &w)| w > 0.0)
                    .map(|(&j, _)| {
                        let j = j as usize;
                        let xi = self.bond_vector(i, j);
                        let r = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                        (self.unit(i, j), beta(r, grid.node_volume(j)))
                    })
                    .collect();
                fit_moments(dim, &bonds, &target)
            })
            .collect();
        let offsets: Vec<usize> = (0..=self.n_nodes()).map(|i| self.family().bond_offset(i)).collect();
        let mut weights = std::mem::take(&mut self.weights);
        let range = weights
            .par_iter_mut()
            .enumerate()
            .fold(
                || [f64::INFINITY, f64::NEG_INFINITY],
                |mut range, (b, w)| {
                    let i = offsets.partition_point(|&o| o <= b) - 1;
                    let j = self.family().neighbors(i)[b - offsets[i]] as usize;
                    if fits[i].is_identity() && fits[j].is_identity() {
                        return range;
                    }
                    let n = self.unit(i, j);
                    let f = 0.5 * (fits[i].factor(dim, &n) + fits[j].factor(dim, &n));
                    *w *= f;
                    range = [range[0].min(f), range[1].max(f)];
                    range
                },
            )
            .reduce(|| [f64::INFINITY, f64::NEG_INFINITY], |a, b| [a[0].min(b[0]), a[1].max(b[1])]);
        self.weights = weights;
        let corrected = fits.iter().filter(|f| !f.is_identity()).count();
        let summary = CorrectionSummary {
            kind: "energy",
            corrected_nodes: corrected,
            factor_range: if corrected == 0 { [1.0, 1.0] } else { range },
            max_mismatch: fits.iter().fold(0.0, |m, f| m.max(f.mismatch)),
            max_iterations: fits.iter().map(|f| f.iterations).max().unwrap_or(0),
            out_of_reach_nodes: fits.iter().filter(|f| f.out_of_reach).count(),
            seconds: start.elapsed().as_secs_f64(),
        };
        (self, summary)
    }
}
