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
//! its even moments equal the target's (the classical isotropic moments (S4) by default, or the
//! interior lattice's), i.e. that gives the node the classical (or the interior's) energy
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
//! motions stay in its null space) and gives every bond between two interior nodes the same
//! factor (`phi_0`; exactly 1 for the lattice target). The mean makes the node's energy exact
//! only where its partners' factors agree with its own: a node on a face, whose partners lie
//! deeper and have smaller factors, keeps too little. LPS restores each node's scale by dividing
//! by its own weighted volume `m_i`; a bond model has none, so the correction does it explicitly
//! ((S5), [`linpd_core::surface::FactorRule::MeanOfEndsScaled`]):
//!
//! ```text
//! r_i = tr T* / sum_j beta_ij f_ij,     f_ij = (phi_i(n_ij) + phi_j(n_ij)) / 2,
//! w_ij  ->  w_ij f_ij (r_i + r_j) / 2,                                                     (S5)
//! ```
//!
//! still symmetric in the pair, `r_i = 1` (exactly) for nodes whose partners all carry the
//! full family's factor. Measured (`linpd study surface`, docs/models.md): on a 1 x 0.1 x 0.1
//! cantilever at `h = 0.01` the bond model with (S3) alone is 9.7 % too soft, with (S5) 2.5 %;
//! on the tension bar +0.7 % and -0.3 %. (S5) raises the bonds between two face nodes most,
//! whose midpoints lie on the face, where bending strains are largest.
//!
//! Nodes of the grid's outer layer keep the full family's factor (`phi_0`, exactly 1 for the
//! lattice target): the layer is where volume constraints and loads go, not a free surface, and
//! correcting it as one would change the rows of the body nodes next
//! to it (an affine field given on a layer all around the body would no longer be the exact
//! solution). A face that should be corrected as a free surface has no layer.
//!
//! The weights `beta` are geometric: the micromodulus shape and partial volume, no phase
//! modulus and no defect factor, so material interfaces and weakened bonds are not "corrected";
//! bonds cut by a defect (weight 0) are left out of the family, so crack faces are corrected
//! like other free surfaces.

use crate::BondOperator;
use linpd_core::kernel::partial_volume;
use linpd_core::surface::{family_factors, CorrectionSummary, FactorRule::MeanOfEndsScaled, SurfaceTarget};
use linpd_core::{Grid, Micromodulus, Normalization};

impl BondOperator {
    /// The operator with the `energy` surface correction (S3) applied to its weights. `grid`,
    /// `horizon` and `micromodulus` must be the ones the operator was built with
    /// ([`BondOperator::on_grid`]). With [`SurfaceTarget::Classical`] the target is the isotropic
    /// tensor (S4) whose trace is the moment the micromodulus was normalized with (the exact
    /// integral for [`Normalization::Continuum`], the lattice sum otherwise), so every node
    /// stores the classical energy of the scene's modulus; with [`SurfaceTarget::Lattice`] the
    /// full lattice stencil's moments.
    pub fn with_energy_correction(
        mut self,
        grid: &Grid,
        horizon: f64,
        micromodulus: &Micromodulus,
        target: SurfaceTarget,
    ) -> (Self, CorrectionSummary) {
        let h = grid.spacing();
        let nu = |r: f64| if micromodulus.partial_volume { partial_volume(r, horizon, h) } else { 1.0 };
        let beta = |r: f64, v: f64| micromodulus.kernel.shape(r, horizon) * nu(r) * v * r * r;
        let bond = |i: usize, b: usize| {
            // a bond cut by a defect (weight 0) is not part of the family's geometry
            let j = self.family().neighbors(i)[b] as usize;
            (self.weights(i)[b] > 0.0).then(|| {
                let xi = self.bond_vector(i, j);
                (self.unit(i, j), (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt())
            })
        };
        let trace = match micromodulus.normalization {
            Normalization::Continuum => Some(micromodulus.continuum_moment(self.dim(), horizon)),
            _ => None,
        };
        let (factors, summary) = family_factors(
            self.dim(),
            grid,
            self.family(),
            horizon,
            beta,
            bond,
            MeanOfEndsScaled,
            "energy",
            target,
            trace,
        );
        self.weights.iter_mut().zip(&factors).for_each(|(w, f)| *w *= f);
        (self, summary)
    }

    /// The operator on a point cloud with the `energy` correction (S3), (S5) towards the
    /// classical target ([`linpd_core::surface::cloud_factors`]): every node's bond moments,
    /// `beta_ij = g(|xi|) nu_ij V_j |xi|^2` with the cloud's `quadrature`, matched to the
    /// isotropic moments of the continuum normalization's trace, so that each node stores the
    /// classical energy of the scene's modulus under the affine states; `layer` nodes keep
    /// their bonds (constraints and loads go there). `volumes`, `horizon`, `micromodulus` and
    /// `quadrature` must be those the operator was built with ([`BondOperator::on_points`]).
    /// `None` when the micromodulus is not normalized by the continuum (the target's trace is
    /// the continuum integral; a cloud has no lattice sum).
    pub fn with_cloud_energy_correction(
        mut self,
        volumes: &[f64],
        layer: &[bool],
        horizon: f64,
        micromodulus: &Micromodulus,
        quadrature: crate::quadrature::Quadrature,
    ) -> Option<(Self, CorrectionSummary)> {
        if micromodulus.normalization != Normalization::Continuum {
            return None;
        }
        let dim = self.dim();
        let trace = micromodulus.continuum_moment(dim, horizon);
        let scale: Vec<f64> = volumes.iter().map(|&v| quadrature.node_scale(dim, v)).collect();
        let bond = |i: usize, b: usize| {
            let j = self.family().neighbors(i)[b] as usize;
            (self.weights(i)[b] > 0.0).then(|| {
                let xi = self.bond_vector(i, j);
                let r = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                let nu = crate::quadrature::volume_factor(quadrature, dim, r, horizon, scale[i], scale[j]);
                (self.unit(i, j), micromodulus.kernel.shape(r, horizon) * nu * volumes[j] * r * r)
            })
        };
        let (factors, summary) =
            linpd_core::surface::cloud_factors(dim, self.family(), bond, layer, MeanOfEndsScaled, "energy", trace);
        self.weights.iter_mut().zip(&factors).for_each(|(w, f)| *w *= f);
        Some((self, summary))
    }
}
