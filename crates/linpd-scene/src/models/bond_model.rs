//! The parameters of a bond model (its keys [`RawBond`], validated into [`BondModel`]) and
//! what the three bond models share: the operator on a lattice or point cloud, the surface
//! correction and the fields of a solution.

use crate::elastic::{BondElastic, PhaseConstants};
use crate::nodes::{NodeSet, Nodes};
use crate::raw::{
    RawBlending, RawMaterial, RawMicromodulus, RawPdRegions, RawPlane, RawSurfaceCorrection, RawSurfaceTarget,
};
use crate::scene::Problem;
use crate::solution::Solution;
use crate::validate::{bond_elastic, bond_micromodulus, material, phase_moduli};
use crate::ProblemError;
use linpd_bond::quadrature::Quadrature;
use linpd_bond::BondOperator;
use linpd_core::surface::{CorrectionSummary, SurfaceTarget};
use linpd_core::{Grid, Material, Micromodulus, Model};
use linpd_lps::SurfaceCorrection;
use linpd_solve::SolveReport;
use serde::Deserialize;

/// The keys of a bond model (`docs/problem-format.md`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBond {
    /// `"bond"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Horizon `delta`.
    pub horizon: f64,
    /// The neighbours' volumes at the horizon: `false` (whole), `true` (the one-sided ramp) or
    /// `"ball"` (point clouds: the fraction of an equivalent ball inside the horizon,
    /// [`linpd_bond::quadrature`]); default `false` on lattices, `"ball"` on point clouds.
    #[serde(default)]
    pub partial_volume: Option<RawPartialVolume>,
    /// 2D assumption: `stress` or `strain`.
    #[serde(default)]
    pub plane: Option<RawPlane>,
    /// Kernel and normalization.
    #[serde(default)]
    pub micromodulus: Option<RawMicromodulus>,
    /// Phases, bond rule, defects.
    #[serde(default)]
    pub material: RawMaterial,
    /// `none` (default) or `energy`.
    #[serde(default)]
    pub surface_correction: Option<RawSurfaceCorrection>,
    /// With a surface correction: `classical` (default) or `lattice`.
    #[serde(default)]
    pub surface_target: Option<RawSurfaceTarget>,
    /// 2D/3D: the regions modelled by PD, or `"auto"` ([`super::lattice_blend`]).
    #[serde(default)]
    pub pd_regions: Option<RawPdRegions>,
    /// With `"pd_regions": "auto"`: the PD zone's radius around each feature, in horizons.
    #[serde(default)]
    pub auto_radius: Option<f64>,
    /// With `pd_regions`: the transition's width (length units, at least the spacing).
    #[serde(default)]
    pub transition: Option<f64>,
    /// With `pd_regions`: `linear` (default), `cubic` or `constant`.
    #[serde(default)]
    pub transition_profile: Option<RawBlending>,
    /// With `pd_regions` and a constant profile: its value (default 0.5).
    #[serde(default)]
    pub transition_value: Option<f64>,
    /// With `pd_regions`: the local zone on a graded mesh ([`super::lattice_blend`]).
    #[serde(default)]
    pub local_mesh: Option<RawLocalMesh>,
}

/// `model.local_mesh`: the graded local mesh of a blended model.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RawLocalMesh {
    /// The largest cell side (a length): cells of side `h 2^l` up to it.
    pub max_cell: f64,
    /// Layers of cells of each size before the next (default 4).
    #[serde(default)]
    pub cells_per_level: Option<usize>,
    /// What the cells at the box's free faces model (default `lattice`).
    #[serde(default)]
    pub free_faces: Option<RawFreeFaces>,
}

/// `model.local_mesh.free_faces`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawFreeFaces {
    /// Level-0 cells with the lattice's softened moduli within a horizon and a spacing.
    Lattice,
    /// Cells graded as in the bulk, coarse ones with the bulk moduli.
    Bulk,
}

/// The validated parameters of a bond model.
#[derive(Debug, Clone, PartialEq)]
pub struct BondModel {
    /// Horizon.
    pub(crate) horizon: f64,
    /// Micromodulus.
    pub(crate) micromodulus: Micromodulus,
    /// Material.
    pub(crate) material: Material,
    /// Per-node moduli of a point cloud whose phases name phase numbers (overrides the
    /// material's region phases; `None` otherwise).
    pub(crate) node_moduli: Option<Vec<f64>>,
    /// `model.surface_correction` (`None` or `Energy`, [`linpd_bond::surface`]) and its target.
    pub(crate) surface: Surface,
    /// The constants the model fixes (`None` with an explicit amplitude) and every phase's
    /// modulus in scene order: `result.json`'s `material`.
    pub(crate) elastic: Option<BondElastic>,
    pub(crate) phase_moduli: Vec<f64>,
    /// A point cloud's weighting of the neighbours at the horizon ([`Quadrature::Full`] on a
    /// lattice, whose ramp is `micromodulus.partial_volume`).
    pub(crate) quadrature: Quadrature,
}

/// `model.partial_volume`: a flag or `"ball"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawPartialVolume {
    /// `true`: the one-sided ramp; `false`: whole volumes.
    Flag(bool),
    /// `"ball"`.
    Named(RawPartialVolumeName),
}

/// The named `model.partial_volume` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawPartialVolumeName {
    /// [`Quadrature::Ball`].
    Ball,
}

impl<'de> Deserialize<'de> for RawPartialVolume {
    /// `true`, `false` or `"ball"`, anything else named (an untagged enum would only say that
    /// no variant matched).
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::Bool(b) => Ok(RawPartialVolume::Flag(b)),
            serde_json::Value::String(s) if s == "ball" => Ok(RawPartialVolume::Named(RawPartialVolumeName::Ball)),
            other => Err(serde::de::Error::custom(format!("expected true, false or \"ball\", got {other}"))),
        }
    }
}

impl RawPartialVolume {
    /// The quadrature `value` names (`None`: the default of the nodes, `on_cloud`).
    pub(crate) fn quadrature(value: Option<Self>, on_cloud: bool) -> Quadrature {
        match value {
            None if on_cloud => Quadrature::Ball,
            None | Some(RawPartialVolume::Flag(false)) => Quadrature::Full,
            Some(RawPartialVolume::Flag(true)) => Quadrature::Ramp,
            Some(RawPartialVolume::Named(RawPartialVolumeName::Ball)) => Quadrature::Ball,
        }
    }
}

/// `model.surface_correction` and `model.surface_target` ([`linpd_core::surface`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Surface {
    /// Which correction.
    pub correction: SurfaceCorrection,
    /// What its moments are matched to (ignored without a correction).
    pub target: SurfaceTarget,
}

impl BondModel {
    /// Validates the keys of a bond model on `grid` (every defect must cut a bond of it).
    pub(crate) fn validate(
        raw: &RawBond,
        micromodulus: Micromodulus,
        grid: &Grid,
        dim: usize,
        presences: &crate::part::Presences,
    ) -> Result<Self, ProblemError> {
        let horizon = raw.horizon;
        let elastic = bond_elastic(dim, &micromodulus);
        let material = material(&raw.material, dim, elastic)?;
        crate::validate::require_defects_cut(&material, grid, horizon, presences)?;
        let surface = surface_of(false, raw.surface_correction, raw.surface_target)?;
        let phase_moduli = phase_moduli(&raw.material, elastic)?;
        let quadrature = Quadrature::Full;
        Ok(BondModel { horizon, micromodulus, material, node_moduli: None, surface, elastic, phase_moduli, quadrature })
    }

    /// The micromodulus of a bond model on a lattice ([`BondModel::validate`] takes it), from
    /// its keys (`micromodulus`, `plane`, `partial_volume`).
    pub(crate) fn lattice_micromodulus(raw: &RawBond, dim: usize) -> Result<Micromodulus, ProblemError> {
        if raw.partial_volume == Some(RawPartialVolume::Named(RawPartialVolumeName::Ball)) {
            return Err(ProblemError::invalid(
                "model.partial_volume",
                "\"ball\" is for point clouds, whose neighbours sit at every distance (a lattice's sit at fixed \
                 ones: true ramps them at the horizon)",
            ));
        }
        let ramp = RawPartialVolume::quadrature(raw.partial_volume, false) == Quadrature::Ramp;
        bond_micromodulus(dim, raw.horizon, raw.micromodulus.as_ref(), raw.plane, ramp)
    }

    /// The parameters of a bond model on a point cloud (its material may name phase numbers,
    /// applied per node by `node_moduli`).
    pub(crate) fn on_cloud(
        raw: &RawBond,
        micromodulus: Micromodulus,
        material: Material,
        node_moduli: Option<Vec<f64>>,
        (elastic, phase_moduli): (Option<BondElastic>, Vec<f64>),
        (surface, quadrature): (Surface, Quadrature),
    ) -> Self {
        BondModel {
            horizon: raw.horizon,
            micromodulus,
            material,
            node_moduli,
            surface,
            elastic,
            phase_moduli,
            quadrature,
        }
    }

    /// `(E, nu)` of the nodes at `x` (their phases' moduli; a cloud's per-node moduli when `x`
    /// are its nodes), `None` with an explicit amplitude.
    pub fn node_elastic(&self, x: &[linpd_core::Point], dim: usize, tol: f64) -> Option<Vec<(f64, Option<f64>)>> {
        let e = self.elastic?;
        let k = match &self.node_moduli {
            Some(m) if m.len() == x.len() => m.clone(),
            _ => self.material.node_moduli_at(x, dim, self.micromodulus.modulus, tol),
        };
        Some(k.iter().map(|&k| (e.e_per_k * k, e.nu)).collect())
    }

    /// `E, nu, K, G` of the reference material and of every phase (none with an explicit
    /// amplitude, whose modulus the scene does not give).
    pub fn elastic_constants(&self) -> Vec<PhaseConstants> {
        self.elastic.map_or_else(Vec::new, |e| e.table(self.micromodulus.modulus, self.phase_moduli.iter().copied()))
    }

    /// Horizon.
    pub fn horizon(&self) -> f64 {
        self.horizon
    }
    /// A point cloud's weighting of the neighbours at the horizon.
    pub fn quadrature(&self) -> Quadrature {
        self.quadrature
    }
    /// Micromodulus.
    pub fn micromodulus(&self) -> &Micromodulus {
        &self.micromodulus
    }
    /// Material.
    pub fn material(&self) -> &Material {
        &self.material
    }
    /// The surface correction and its target.
    pub fn surface(&self) -> Surface {
        self.surface
    }

    /// The bond operator on `nodes` (a lattice, or a point cloud with the nodes' own volumes)
    /// with the surface correction, and what the correction did and cost.
    pub fn operator(&self, nodes: &Nodes) -> Result<(BondOperator, Option<CorrectionSummary>), ProblemError> {
        let op = match nodes {
            Nodes::Cloud(c) => BondOperator::on_points(
                c.dim,
                c.positions.clone(),
                &c.volumes,
                self.horizon,
                &self.micromodulus,
                &self.material,
                self.node_moduli.as_deref(),
                self.quadrature,
                &match self.micromodulus.normalization {
                    linpd_core::Normalization::Discrete => {
                        c.interior(linpd_bond::quadrature::reach(self.quadrature, c.dim, self.horizon, &c.volumes))
                    }
                    _ => Vec::new(),
                },
                c.whole,
            ),
            Nodes::Lattice(grid) => BondOperator::on_grid(grid, self.horizon, &self.micromodulus, &self.material),
            Nodes::Level(_) => unreachable!("a bond model lives on a lattice or a point cloud"),
        }
        .map_err(|e| ProblemError::invalid("model", e.to_string()))?;
        Ok(match (self.surface.correction, nodes) {
            (SurfaceCorrection::Energy, Nodes::Lattice(grid)) => {
                let (op, summary) =
                    op.with_energy_correction(grid, self.horizon, &self.micromodulus, self.surface.target);
                (op, Some(summary))
            }
            (SurfaceCorrection::Energy, Nodes::Cloud(c)) => {
                let m = &self.micromodulus;
                match op.with_cloud_energy_correction(&c.volumes, &c.layer, self.horizon, m, self.quadrature) {
                    Some((op, summary)) => (op, Some(summary)),
                    None => return Err(correction_needs_continuum()),
                }
            }
            _ => (op, None),
        })
    }
}

/// `model.surface_correction` and `model.surface_target`: `position_aware` is LPS only (a
/// bond-based force is pairwise, so a bond must have one stiffness seen from both ends); a
/// target needs a correction.
pub(crate) fn surface_of(
    lps: bool,
    raw: Option<RawSurfaceCorrection>,
    target: Option<RawSurfaceTarget>,
) -> Result<Surface, ProblemError> {
    use RawSurfaceCorrection as R;
    let correction = match raw {
        None | Some(R::None) => SurfaceCorrection::None,
        Some(R::Energy) => SurfaceCorrection::Energy,
        Some(R::PositionAware) if lps => SurfaceCorrection::PositionAware,
        Some(R::PositionAware) => {
            return Err(ProblemError::invalid(
                "model.surface_correction",
                "\"position_aware\" gives each node its own influence function, an LPS (state-based) correction; \
                 bond models take \"none\" or \"energy\"",
            ))
        }
    };
    // any target given (the default included) needs a correction, as on point clouds
    if target.is_some() && correction == SurfaceCorrection::None {
        return Err(ProblemError::invalid(
            "model.surface_target",
            "says what a surface correction matches; set model.surface_correction to \"energy\" or \"position_aware\"",
        ));
    }
    let target = match target {
        None | Some(RawSurfaceTarget::Classical) => SurfaceTarget::Classical,
        Some(RawSurfaceTarget::Lattice) => SurfaceTarget::Lattice,
    };
    Ok(Surface { correction, target })
}

/// The solution of a bond-based model (`n_bonds` bonds, cut ones included): balance, strain
/// and the strain energy density from its blocks ([`crate::stress::energy_and_force_flux`]).
pub(crate) fn solution(p: &Problem, model: &dyn Model, n_bonds: usize, u: Vec<f64>, report: SolveReport) -> Solution {
    let nodes = p.nodes();
    let balance = p.balance(&|u, y| linpd_core::Model::apply(model, u, y), &u);
    let volumes: Vec<f64> = (0..nodes.len()).map(|n| nodes.volume(n)).collect();
    let (strain_energy_density, pd_stress) = match crate::stress::energy_and_force_flux(model, &volumes, &u) {
        Some((e, stress)) => (Some(e.iter().zip(&volumes).map(|(w, v)| w / v).collect()), Some(stress)),
        None => (None, None),
    };
    let strain = Some(crate::nodal_strain(model, &volumes, &u));
    Solution {
        name: p.name().to_string(),
        dim: p.dim(),
        x: (0..model.n_nodes()).map(|i| model.position(i)).collect(),
        u,
        is_layer: (0..nodes.len()).map(|n| nodes.is_layer(n)).collect(),
        volumes,
        n_bonds,
        balance: Some(balance),
        strain_energy_density,
        strain,
        dilatation: None,
        cells: None,
        graded_mesh: None,
        file_node: None,
        material: Vec::new(),
        stress: None,
        pd_stress,
        report,
    }
}

/// The phase line of a bond model being built.
pub(crate) fn building(p: &Problem, horizon: f64) -> String {
    format!("building bonds: {} nodes, horizon/spacing = {:.3}", p.nodes().len(), horizon / p.nodes().spacing())
}

/// The error of a surface correction on a cloud whose micromodulus is not normalized by the
/// continuum (the correction's target is the continuum's moment).
pub(crate) fn correction_needs_continuum() -> ProblemError {
    ProblemError::invalid(
        "model.micromodulus.normalize",
        "the energy correction on a point cloud matches each node to the continuum's moments: use \"continuum\"",
    )
}
