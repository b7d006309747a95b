//! `"type": "bond"`: bond-based linear PD ([`linpd_bond`]). Its keys ([`RawBond`]) and their
//! validation ([`BondModel`]); the scene is then one of three models:
//!
//! * on a grid: [`super::bond_lattice`];
//! * on a point cloud (`"nodes"`): [`super::bond_cloud`];
//! * on a 2D/3D grid with `pd_regions`: the blended PD / local model, [`super::lattice_blend`].

use super::bond_model::{BondModel, RawBond};
use super::registry::{struct_fields, ModelType, Validated};
use super::{bond_cloud, bond_lattice, lattice_blend, SceneModel};
use crate::nodes::Nodes;
use crate::validate::{core, Context};
use crate::ProblemError;

/// The bond model type.
pub struct BondType;

/// The registry entry.
pub static BOND: BondType = BondType;

impl ModelType for BondType {
    fn name(&self) -> &'static str {
        "bond"
    }
    fn fields(&self) -> &'static [&'static str] {
        struct_fields::<RawBond>()
    }
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError> {
        let raw: RawBond = cx.model_keys()?;
        if let Some(spec) = &cx.raw.nodes {
            return bond_cloud::validate(cx, spec, &raw);
        }
        let dim = cx.dim();
        let matrix_free = cx.raw.solver.matrix_free || cx.raw.dynamics.is_some();
        let dynamics = cx.raw.dynamics.is_some();
        let uses_multigrid = cx.raw.solver.preconditioner == Some(crate::raw::RawPreconditioner::Multigrid);
        let auto = cx.raw.solver.kind == crate::raw::RawSolverKind::Auto && cx.raw.dynamics.is_none();
        // the homogeneous stencil alone holds no bonds (bond_lattice::plain_stencil)
        let plain = raw.material.phases.is_empty()
            && raw.material.defects.is_empty()
            && matches!(raw.surface_correction, None | Some(crate::raw::RawSurfaceCorrection::None));
        // for the memory estimate only: BondModel::validate below reports a bad micromodulus
        let ramp = crate::models::bond_model::RawPartialVolume::quadrature(raw.partial_volume, false)
            == linpd_bond::quadrature::Quadrature::Ramp;
        let mm = crate::validate::bond_micromodulus(dim, raw.horizon, raw.micromodulus.as_ref(), raw.plane, ramp).ok();
        let matrix_free_path = |grid: &linpd_core::Grid| {
            if plain && grid.is_full() && grid.has_uniform_volumes() {
                match &mm {
                    Some(mm) => crate::memory::stencil_path(grid, raw.horizon, mm),
                    None => crate::memory::Path::BondStencil,
                }
            } else {
                crate::memory::Path::BondMatrixFree
            }
        };
        let path_of = |grid: &linpd_core::Grid| match (matrix_free, raw.pd_regions.is_some()) {
            (_, true) if raw.local_mesh.is_some() => (crate::memory::Path::GradedBlendLattice, false),
            (_, true) => (crate::memory::Path::BlendAssembled, uses_multigrid || auto),
            (true, false) if dynamics => (crate::memory::Path::BondDynamics, false),
            (true, false) => (matrix_free_path(grid), uses_multigrid),
            (false, false) if auto && bond_lattice::auto_runs_matrix_free(grid, None) => (matrix_free_path(grid), true),
            (false, false) => (crate::memory::Path::BondAssembled, uses_multigrid || (auto && dim >= 2)),
        };
        // the halo of a rank's part (crate::part): one reach of the bonds; with the energy
        // correction two more, as a bond's factor reads its ends' trace ratios, each made of
        // the factors of that end's bonds, each the mean of two nodes' fits over their families
        let corrected = !matches!(raw.surface_correction, None | Some(crate::raw::RawSurfaceCorrection::None));
        if cx.part.is_some() && raw.pd_regions.is_some() {
            return Err(ProblemError::invalid(
                "model.pd_regions",
                format!("the blended model {}", crate::validate::NO_PER_RANK_GEOMETRY),
            ));
        }
        let reaches = Some(if corrected { 3 } else { 1 });
        let grid = crate::validate::lattice_for(cx, raw.horizon, reaches, &path_of)?;
        let bond = BondModel::validate(&raw, &grid, dim, &cx.presences)?;
        // The amplitude now, not at the first solve: a modulus that overflows it (1e308) is a
        // validation error naming the overflow.
        bond.micromodulus.amplitude(dim, bond.horizon, grid.spacing()).map_err(|e| core("model", e))?;
        let model: Box<dyn SceneModel> = match lattice_blend::zone(&grid, &raw, bond.surface)? {
            Some(zone) => Box::new(lattice_blend::LatticeBlendModel { bond, zone }),
            None => Box::new(bond_lattice::BondLatticeModel { bond }),
        };
        Ok(Validated { nodes: Nodes::Lattice(grid), model })
    }
}
