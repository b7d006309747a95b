//! Surface correction of the weighted volume: near-surface stiffening of the LPS model.
//!
//! # The problem
//!
//! A node within one horizon of a free surface has a truncated family, so its lattice sum
//! `m_i = sum_j omega |xi|^2 nu V_j` is smaller than the interior value `m_0`. The LPS
//! coefficients `d kappa / m_i` (dilatation) and `a G / m_i` (deviatoric, `alpha = 15 G / m`
//! in 3D) therefore grow near the surface, and bonds between two near-surface nodes carry
//! `1/m_i + 1/m_j` with both terms enlarged: the classical "surface effect" of
//! peridynamics. Whether a truncated node ends up stiffer or softer than the bulk depends on
//! the loading (the family is missing bonds, but the remaining ones are stiffer), and the
//! two-horizon-wide stencil of the `theta_i theta_j` coupling spreads it.
//!
//! # The correction offered
//!
//! [`SurfaceCorrection::BulkWeightedVolume`] replaces every node's `m_i` by the interior
//! lattice value `m_0 = sum_{k in stencil} omega(|k| h) nu(|k| h) V |k|^2 h^2` (the full
//! lattice stencil of [`linpd_core::family::lattice_stencil`], so it exists even when the body
//! is too thin to hold an interior node), everywhere: in `theta`, the force, the energy and
//! both tangents. The bond coefficients then no longer grow at the surface: a truncated node
//! simply has fewer bonds of bulk stiffness, as in bond-based models with a bulk-calibrated
//! micromodulus. Use [`LpsModel::with_surface_correction`]; [`crate::LpsParams`] is unchanged.
//!
//! # Consistency
//!
//! The force (LAMMPS Algorithm 2 with the replaced `m`), the assembled tangent and the
//! matrix-free tangent all read the same `m`, and the tangent derivation
//! ([`crate::tangent`]) never uses `m_i = sum omega |xi|^2 nu V` (only `theta = g . u` with
//! `g` built from the model's `m`), so `A = -dF/du` still holds exactly (tested with central
//! differences). The energy gains the term `a G theta^2 (m_i - m_i^lat) / (2 m_i d^2)` (see
//! [`crate::force`]) so that `F = -dE/du` also still holds; it is `>= 0` because `m_0 >=
//! m_i^lat`, so `A` stays positive semi-definite with the rigid motions in its null space.
//!
//! # Known drawback
//!
//! The lattice dilatation is no longer exact for affine fields at surface nodes: for
//! `u = epsilon x` (`epsilon` a scalar) `theta_i = d epsilon m_i^lat / m_0 < d epsilon`
//! wherever the family is truncated (exact in the interior). Affine fields therefore no
//! longer give zero force one to two horizons from the surface (they never did at the surface
//! itself, where the force balances the missing traction), and the surface layer is softer in
//! dilatation than the bulk instead of stiffer: the patch test degrades near surfaces. The
//! correction trades local exactness of `theta` for a smaller global stiffening; see the
//! tension-bar numbers in linpd-studies (`lps_tension`, `tests/lps_tension.rs`).

use crate::model::norm;
use crate::{LpsError, LpsModel};
use linpd_core::family::lattice_stencil;
use linpd_core::kernel::partial_volume;
use linpd_core::surface::{cloud_factors, family_factors, CorrectionSummary, FactorRule, SurfaceTarget};

/// The surface correction of an LPS model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurfaceCorrection {
    /// `m_i` is the (truncated near surfaces) lattice sum of node `i`'s family.
    #[default]
    None,
    /// Every node uses the interior lattice value `m_0` (see the module documentation).
    BulkWeightedVolume,
    /// `omega_ij -> omega_ij (phi_i(n) + phi_j(n)) / 2` with the moment-matching factors of
    /// [`linpd_core::surface`]: a spherical (symmetric) influence function per bond, as the
    /// bond-based `energy` correction ([`linpd_core::surface`]).
    Energy,
    /// `omega_i(xi) = phi_i(n) omega(|xi|)`: a per-node influence function whose fourth moments
    /// equal the target's, so that every node's dilatation and energy are exact (classical, or
    /// the interior's with the lattice target) for every affine deformation whose strain is
    /// diagonal in the lattice axes ([`linpd_core::surface`]).
    PositionAware,
}

impl SurfaceCorrection {
    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            SurfaceCorrection::None => "none",
            SurfaceCorrection::BulkWeightedVolume => "bulk_weighted_volume",
            SurfaceCorrection::Energy => "energy",
            SurfaceCorrection::PositionAware => "position_aware",
        }
    }
}

impl LpsModel {
    /// The weighted volume `m_0` of a full (interior) lattice family with this model's
    /// horizon, influence function and partial volumes.
    pub fn bulk_weighted_volume(&self) -> f64 {
        // the lattice spacing (or a point cloud's mean node size, `volume = h^d`)
        let h = self.grid.as_ref().map_or_else(|| self.volume.powf(1.0 / self.dim as f64), |g| g.spacing());
        let delta = self.params.horizon;
        let mut m0 = 0.0;
        for k in lattice_stencil(self.dim, delta / h) {
            let xi = [k[0] as f64 * h, k[1] as f64 * h, k[2] as f64 * h];
            let r = norm(&xi);
            let nu = if self.params.partial_volume { partial_volume(r, delta, h) } else { 1.0 };
            let w = self.params.influence.omega(r) * nu * self.volume;
            m0 += w * r * r;
        }
        m0
    }

    /// The model with `correction` applied ([`LpsModel::corrected`] without its summary).
    ///
    /// # Panics
    /// On a point-cloud model with [`SurfaceCorrection::BulkWeightedVolume`] (use
    /// [`LpsModel::corrected`] for the error).
    pub fn with_surface_correction(self, correction: SurfaceCorrection) -> Self {
        match self.corrected(correction) {
            Ok((model, _)) => model,
            Err(e) => panic!("{e}"),
        }
    }

    /// The model with `correction` applied, and for the moment-matching corrections what it
    /// cost and changed. [`SurfaceCorrection::None`] and [`SurfaceCorrection::BulkWeightedVolume`]
    /// rewrite the weighted volumes `m` only ([`SurfaceCorrection::None`] restores the lattice
    /// sums of the model's current weights); [`SurfaceCorrection::Energy`] and
    /// [`SurfaceCorrection::PositionAware`] rescale the bond weights and must be applied to an
    /// uncorrected model (built by [`LpsModel::new`], [`LpsModel::with_family`] or
    /// [`LpsModel::with_defects`]), once. On a point-cloud model `BulkWeightedVolume` and the
    /// lattice target are [`LpsError::NeedsLattice`] ([`LpsModel::corrected_with_layer`]).
    pub fn corrected(self, correction: SurfaceCorrection) -> Result<(Self, Option<CorrectionSummary>), LpsError> {
        self.corrected_to(correction, SurfaceTarget::default())
    }

    /// [`LpsModel::corrected`] with the moments of [`SurfaceCorrection::Energy`] and
    /// [`SurfaceCorrection::PositionAware`] matched to `target` ([`linpd_core::surface`]: the
    /// isotropic classical moments, or the interior lattice's, which leaves interior nodes
    /// exactly unchanged). LPS divides by each node's own `m_i`, so only the moments' shape
    /// matters, not their trace. The other corrections ignore `target`.
    pub fn corrected_to(
        self,
        correction: SurfaceCorrection,
        target: SurfaceTarget,
    ) -> Result<(Self, Option<CorrectionSummary>), LpsError> {
        self.corrected_with_layer(correction, target, &[])
    }

    /// [`LpsModel::corrected_to`] with a point cloud's `layer` flags: on a cloud the
    /// moment-matching corrections take the classical target only (a cloud has no interior
    /// lattice), every node not in `layer` fitted on its own and the `layer` nodes taking the
    /// fullest family's fit ([`linpd_core::surface::cloud_factors`]); the trace of the target
    /// is the continuum weighted volume `m_c = int_{H} omega |xi|^2 dV`, which LPS divides out.
    /// `layer` is ignored on a lattice (the lattice's own layer counts).
    pub fn corrected_with_layer(
        mut self,
        correction: SurfaceCorrection,
        target: SurfaceTarget,
        layer: &[bool],
    ) -> Result<(Self, Option<CorrectionSummary>), LpsError> {
        let cloud = self.grid.is_none();
        if cloud
            && (correction == SurfaceCorrection::BulkWeightedVolume || target == SurfaceTarget::Lattice)
            && correction != SurfaceCorrection::None
        {
            return Err(LpsError::NeedsLattice(match correction {
                SurfaceCorrection::BulkWeightedVolume => "the bulk_weighted_volume surface correction",
                _ => "the lattice surface target",
            }));
        }
        let mut summary = None;
        match correction {
            SurfaceCorrection::None | SurfaceCorrection::BulkWeightedVolume
                if matches!(self.surface, SurfaceCorrection::Energy | SurfaceCorrection::PositionAware) =>
            {
                return Err(LpsError::Family(format!(
                    "the {} surface correction rescaled the bond weights and cannot be undone or replaced; \
                     build the model again",
                    self.surface.name()
                )));
            }
            SurfaceCorrection::None => self.lattice_sums(),
            SurfaceCorrection::BulkWeightedVolume => {
                let m0 = self.bulk_weighted_volume();
                self.m.iter_mut().for_each(|m| *m = m0);
            }
            SurfaceCorrection::Energy | SurfaceCorrection::PositionAware => {
                // the factors rescale the current weights: a second correction would compound them
                if self.surface != SurfaceCorrection::None {
                    return Err(LpsError::Family(format!(
                        "the {} surface correction asked of a model that already has {} (corrections do not compose)",
                        correction.name(),
                        self.surface.name()
                    )));
                }
                let per_node = correction == SurfaceCorrection::PositionAware;
                summary = Some(match cloud {
                    true => self.match_moments_on_cloud(per_node, layer),
                    false => self.match_moments(per_node, target),
                });
            }
        }
        self.surface = correction;
        self.stencil = std::sync::OnceLock::new();
        Ok((self, summary))
    }

    /// The moment-matching corrections: the factors `phi_i` of every node from its geometric
    /// weights `beta_ij = omega nu V_j |xi|^2` against `target` ([`linpd_core::surface`]), then
    /// `w_ij *= phi_i(n_ij)` (`per_node`) or `w_ij *= (phi_i(n_ij) + phi_j(n_ij)) / 2`, and `m`
    /// recomputed from the new weights.
    fn match_moments(&mut self, per_node: bool, target: SurfaceTarget) -> CorrectionSummary {
        let grid = self.grid.clone().expect("checked in `corrected`");
        let (h, delta) = (grid.spacing(), self.params.horizon);
        let p = self.params;
        let beta = |r: f64, v: f64| {
            p.influence.omega(r) * if p.partial_volume { partial_volume(r, delta, h) } else { 1.0 } * v * r * r
        };
        let bond = |i: usize, b: usize| {
            let j = self.family.neighbors(i)[b] as usize;
            let r = self.len[self.family.bond_offset(i) + b];
            let xi = self.bond_vector(i, j);
            Some(([xi[0] / r, xi[1] / r, xi[2] / r], r))
        };
        let (kind, rule) = factor_rule(per_node);
        let (factors, summary) =
            family_factors(self.dim, &grid, &self.family, delta, beta, bond, rule, kind, target, None);
        self.rescale_weights(&factors, per_node);
        summary
    }

    /// [`LpsModel::match_moments`] on a point cloud: `beta_ij = omega nu_ij V_j |xi|^2` with
    /// the cloud's partial volumes (node sizes `V^(1/d)`), the classical target of trace
    /// [`LpsModel::continuum_weighted_volume`].
    fn match_moments_on_cloud(&mut self, per_node: bool, layer: &[bool]) -> CorrectionSummary {
        let (dim, delta, p) = (self.dim, self.params.horizon, self.params);
        let size: Vec<f64> = self.volumes.iter().map(|v| v.powf(1.0 / dim as f64)).collect();
        let bond = |i: usize, b: usize| {
            let j = self.family.neighbors(i)[b] as usize;
            let r = self.len[self.family.bond_offset(i) + b];
            let xi = self.bond_vector(i, j);
            let nu = if p.partial_volume { partial_volume(r, delta, 0.5 * (size[i] + size[j])) } else { 1.0 };
            Some(([xi[0] / r, xi[1] / r, xi[2] / r], p.influence.omega(r) * nu * self.volumes[j] * r * r))
        };
        let (kind, rule) = factor_rule(per_node);
        let trace = self.continuum_weighted_volume();
        let (factors, summary) = cloud_factors(dim, &self.family, bond, layer, rule, kind, trace);
        self.rescale_weights(&factors, per_node);
        summary
    }

    /// The continuum weighted volume `m_c = int_{|xi| <= delta} omega(|xi|) |xi|^2 dV`:
    /// `(2 pi, 4 pi) delta^(d+1) / (d+1)` for `omega = 1/|xi|`, `delta^(d+2) / (d+2)` times the
    /// same for `omega = 1`.
    pub fn continuum_weighted_volume(&self) -> f64 {
        let d = self.dim as i32;
        let sphere = if d == 2 { 2.0 * std::f64::consts::PI } else { 4.0 * std::f64::consts::PI };
        let delta = self.params.horizon;
        match self.params.influence {
            crate::Influence::InverseDistance => sphere * delta.powi(d + 1) / (d + 1) as f64,
            crate::Influence::Constant => sphere * delta.powi(d + 2) / (d + 2) as f64,
        }
    }

    /// `w_ij *= factors` (family order), then `m` from the new weights and, for per-node
    /// factors, the reverse-bond index.
    fn rescale_weights(&mut self, factors: &[f64], per_node: bool) {
        self.wv.iter_mut().zip(factors).for_each(|(w, f)| *w *= f);
        self.lattice_sums();
        if per_node {
            self.index_reverse_bonds();
        }
    }

    /// Algorithm 3 with the current weights: `m_i = sum_j w_ij |xi|^2`.
    fn lattice_sums(&mut self) {
        for i in 0..self.n_nodes() {
            let o = self.family.bond_offset(i);
            let nb = self.family.neighbors(i).len();
            self.m[i] = (o..o + nb).map(|b| self.wv[b] * self.len[b] * self.len[b]).sum();
        }
    }

    /// The surface correction in effect.
    pub fn surface_correction(&self) -> SurfaceCorrection {
        self.surface
    }
}

/// The correction's name and factor rule: per node (`position_aware`) or the mean of the ends.
fn factor_rule(per_node: bool) -> (&'static str, FactorRule) {
    if per_node {
        ("position_aware", FactorRule::OwnEnd)
    } else {
        ("energy", FactorRule::MeanOfEnds)
    }
}
