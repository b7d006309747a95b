//! `"type": "bond"`: bond-based linear PD ([`linpd_bond`]). Its keys ([`RawBond`]) and their
//! validation ([`BondModel`]); the scene is then one of three models:
//!
//! * on a grid: [`super::bond_lattice`];
//! * on a point cloud (`"nodes"`): [`super::bond_cloud`];
//! * on a 2D/3D grid with `pd_regions`: the blended PD / local model, [`super::lattice_blend`].

use super::bond_model::{BondModel, RawBond};
use super::model_type::{struct_fields, ModelType, Validated};
use super::{bond_cloud, bond_lattice, lattice_blend, SceneModel};
use crate::memory::Path;
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
        // the homogeneous stencil alone holds no bonds (bond_lattice::plain_stencil)
        let plain = raw.material.phases.is_empty()
            && raw.material.defects.is_empty()
            && matches!(raw.surface_correction, None | Some(crate::raw::RawSurfaceCorrection::None));
        // built once; its error is reported after the lattice's, as the model's other keys
        let micromodulus = BondModel::lattice_micromodulus(&raw, dim);
        // the memory checked before anything per node is allocated: the plan of the box's
        // every DOF (the constraints are not known yet)
        let path_of = |grid: &linpd_core::Grid| {
            let plan = || linpd_solve::plan(&cx.solver, &self::offers(&raw, grid), &Default::default());
            match (cx.raw.dynamics.is_some(), &raw.pd_regions) {
                (_, Some(_)) if raw.local_mesh.is_some() => (Path::GradedBlendLattice, Vec::new()),
                (_, Some(_)) => (Path::BlendAssembled, plan().preconditioners),
                (true, None) => (Path::BondDynamics, Vec::new()),
                (false, None) => {
                    let stencil = match &micromodulus {
                        Ok(mm) if plain && grid.is_full() && grid.has_uniform_volumes() => {
                            Some(crate::memory::stencil_path(grid, raw.horizon, mm))
                        }
                        Err(_) if plain && grid.is_full() && grid.has_uniform_volumes() => Some(Path::BondStencil),
                        _ => None,
                    };
                    bond_lattice::memory_path(&plan(), stencil)
                }
            }
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
        let bond = BondModel::validate(&raw, micromodulus?, &grid, dim, &cx.presences)?;
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

/// What a bond scene on `grid` offers the solvers before its model is built, with every DOF
/// unknown: a lattice's ([`bond_lattice::offers`]) or a blend's (an unsymmetric `A`; on a
/// graded mesh applied matrix-free with its companion's block rows).
fn offers(raw: &RawBond, grid: &linpd_core::Grid) -> linpd_solve::Offers {
    let unknowns = grid.len() * grid.dim();
    match &raw.pd_regions {
        None => bond_lattice::offers(grid, unknowns),
        Some(_) => lattice_blend::offers(grid.dim(), unknowns, raw.local_mesh.is_some()),
    }
}
