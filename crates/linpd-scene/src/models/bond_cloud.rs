//! The bond model on a point cloud (`"nodes"`): [`linpd_bond::BondOperator::on_points`], the
//! bond weights from the nodes' own volumes, always assembled (AMD ordering).

use super::bond_model::{self, BondModel, RawBond};
use super::model_type::Validated;
use super::{Capability, Purpose, SceneModel, System};
use crate::nodes::{LevelNodes, Nodes};
use crate::scene::Problem;
use crate::solution::Solution;
use crate::validate::{
    bond_micromodulus, check_defects, cloud_nodes, material_with_tags, region, Context, NOT_COARSENED,
};
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_solve::SolveReport;
use std::any::Any;
use std::sync::Arc;

/// A bond scene on a point cloud.
#[derive(Debug, Clone)]
pub struct BondCloudModel {
    /// Its parameters.
    pub bond: BondModel,
}

/// Validates a bond scene whose nodes come from a file.
pub(crate) fn validate(cx: &Context, spec: &crate::raw::RawNodes, raw: &RawBond) -> Result<Validated, ProblemError> {
    let dim = cx.dim();
    refuse_lattice_keys(raw)?;
    let quadrature = super::bond_model::RawPartialVolume::quadrature(raw.partial_volume, true);
    let ball = quadrature == linpd_bond::quadrature::Quadrature::Ball;
    // a rank's halo (crate::part): as on a lattice, one reach, three with the energy correction
    let corrected = !matches!(raw.surface_correction, None | Some(crate::raw::RawSurfaceCorrection::None));
    let reaches = Some(if corrected { 3 } else { 1 });
    // `auto` and multigrid build a hierarchy on a bond cloud: counted as the plan says
    let setup = |n: usize| linpd_solve::plan(&cx.solver, &offers(dim, n * dim), &Default::default()).preconditioners;
    let path = (crate::memory::Path::BondAssembled, &setup as &dyn Fn(usize) -> Vec<linpd_solve::PreconditionerKind>);
    let (nodes, h) = cloud_nodes(cx, spec, raw.horizon, (reaches, corrected), path, ball)?;
    let ramp = quadrature == linpd_bond::quadrature::Quadrature::Ramp;
    let micromodulus = bond_micromodulus(dim, raw.horizon, raw.micromodulus.as_ref(), raw.plane, ramp)?;
    if micromodulus.normalization == linpd_core::Normalization::Discrete && cx.part.is_some() {
        return Err(ProblemError::invalid(
            "model.micromodulus.normalize",
            format!(
                "\"discrete\" on a point cloud (a mean over the whole body's interior nodes) {}",
                crate::validate::NO_PER_RANK_GEOMETRY
            ),
        ));
    }
    if micromodulus.normalization == linpd_core::Normalization::Discrete {
        // the interior nodes' own sums: a mesh's boundary says which nodes are interior
        let reach = linpd_bond::quadrature::reach(quadrature, dim, raw.horizon, &nodes.volumes);
        if nodes.boundary.is_empty() || !nodes.interior(reach).contains(&true) {
            return Err(ProblemError::invalid(
                "model.micromodulus.normalize",
                match nodes.boundary.is_empty() {
                    true => {
                        "\"discrete\" on a point cloud averages the sums of the nodes a horizon inside the body, \
                             which only a mesh's boundary (nodes.mesh) tells; use \"continuum\""
                    }
                    false => {
                        "\"discrete\" averages the sums of the nodes a horizon inside the body, and this mesh \
                              has none (a body thinner than two horizons); use \"continuum\""
                    }
                },
            ));
        }
    } else {
        micromodulus.amplitude(dim, raw.horizon, h).map_err(|e| ProblemError::invalid("model", e.to_string()))?;
    }
    let elastic = crate::validate::bond_elastic(dim, &micromodulus);
    let material = material_with_tags(&raw.material, dim, true, elastic)?;
    let moduli = crate::validate::phase_moduli(&raw.material, elastic)?;
    let node_moduli = tagged_moduli(&raw.material, &moduli, &nodes, micromodulus.reference_modulus(), &cx.presences)?;
    check_defects(&material, &nodes, raw.horizon, &cx.presences)?;
    let surface = bond_model::surface_of(false, raw.surface_correction, raw.surface_target)?;
    if surface.correction != linpd_lps::SurfaceCorrection::None
        && micromodulus.normalization != linpd_core::Normalization::Continuum
    {
        return Err(bond_model::correction_needs_continuum());
    }
    let bond = BondModel::on_cloud(raw, micromodulus, material, node_moduli, (elastic, moduli), (surface, quadrature));
    Ok(Validated { nodes: Nodes::Cloud(nodes), model: Box::new(BondCloudModel { bond }) })
}

/// What a bond model on a point cloud offers the solvers with `unknowns` free DOFs: a
/// symmetric `A`, assembled (no stencil applies off a lattice).
fn offers(dim: usize, unknowns: usize) -> linpd_solve::Offers {
    linpd_solve::Offers { dim, unknowns, symmetric: true, fast_apply: false, companion_gmres: false }
}

/// The keys that need a lattice: the lattice target of a surface correction and `pd_regions`.
fn refuse_lattice_keys(raw: &RawBond) -> Result<(), ProblemError> {
    crate::validate::refuse_lattice_target(raw.surface_target)?;
    if raw.pd_regions.is_some() {
        return Err(ProblemError::invalid(
            "model.pd_regions",
            "not available on point clouds: the local model is built from the lattice's cells (use a grid)",
        ));
    }
    Ok(())
}

impl SceneModel for BondCloudModel {
    fn node_elastic(&self, p: &Problem, x: &[linpd_core::Point]) -> Option<crate::scene::NodeElastic> {
        let tol = linpd_core::GEOMETRY_RTOL * crate::nodes::NodeSet::spacing(p.nodes());
        Some((self.bond.micromodulus.plane, self.bond.node_elastic(x, p.dim(), tol)?))
    }
    fn elastic_constants(&self) -> Vec<crate::elastic::PhaseConstants> {
        self.bond.elastic_constants()
    }
    fn name(&self) -> &'static str {
        "bond"
    }
    fn describe(&self) -> String {
        "bond (point cloud)".into()
    }
    fn horizon(&self) -> Option<f64> {
        Some(self.bond.horizon)
    }
    fn offers(&self, p: &Problem, unknowns: usize) -> Option<linpd_solve::Offers> {
        Some(offers(p.dim(), unknowns))
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        match capability {
            Capability::MatrixFree => {
                Some("the matrix-free stencil operator needs a grid; point clouds are solved assembled".into())
            }
            Capability::Dynamics => Some("explicit dynamics needs a grid (not available on point clouds yet)".into()),
            Capability::Coarsen => Some(NOT_COARSENED.into()),
            _ => None,
        }
    }
    fn summary(&self, p: &Problem) -> String {
        let h = p.nodes().cloud().map_or(f64::NAN, |c| crate::cloud::mean_spacing(&c.volumes, c.dim));
        format!(
            "bond model on a point cloud, dimension {}, {} nodes, horizon/mean spacing = {:.4}",
            p.dim(),
            p.nodes().len(),
            self.bond.horizon / h
        )
    }
    /// A point cloud was checked against memory when the scene was validated.
    fn system(&self, p: &Problem, _: Purpose, progress: &dyn Progress) -> Result<System, ProblemError> {
        progress.phase(&format!("building bonds: {} nodes of the point cloud", p.nodes().len()));
        let (op, correction) = self.bond.operator(p.nodes())?;
        let (n, bonds) = (p.nodes().len(), op.family().n_bonds());
        let (_, mut bytes) = crate::memory::estimate_counts(
            crate::memory::Path::BondAssembled,
            p.dim(),
            n,
            bonds as f64 / n as f64,
            1.0,
        );
        let nb = bonds as f64 / n as f64;
        bytes += crate::memory::cloud_extra(crate::memory::Path::BondAssembled, p.dim(), n, nb, 1.0);
        // `auto` and multigrid build a hierarchy on top (see `crate::validate::cloud_nodes`)
        let operator = linpd_solve::precond::kind::Operator::Assembled;
        let on = linpd_solve::precond::kind::SetupOn { dim: p.dim(), nodes: n, dofs: n * p.dim(), operator };
        bytes += p.planned()?.setup_bytes(&on);
        Ok(System {
            n_bonds: bonds,
            model: Arc::new(op),
            bc: p.dirichlet(),
            f: p.load_vector(),
            notes: correction.map(|c| c.describe()).into_iter().collect(),
            built_before: 0.0,
            memory_estimate: Some(bytes),
        })
    }
    fn solution(&self, p: &Problem, s: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        Ok(bond_model::solution(p, s.model(), s.n_bonds, u, report))
    }
    fn bond_operator(
        &self,
        p: &Problem,
    ) -> Result<(linpd_bond::BondOperator, Option<linpd_core::surface::CorrectionSummary>), ProblemError> {
        self.bond.operator(p.nodes())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The modulus of every node when some phase names a phase number (`{"phase": k, "modulus":
/// K}`): the phases in order, a later one overriding an earlier one where both apply (as for
/// regions), `reference` where none does. `None` when every phase is a region (the material
/// then applies them). A phase number that no node carries is an error (a typo would
/// otherwise leave the material silently homogeneous).
pub(crate) fn tagged_moduli(
    raw: &crate::raw::RawMaterial,
    phase_moduli: &[f64],
    nodes: &LevelNodes,
    reference: f64,
    presences: &crate::part::Presences,
) -> Result<Option<Vec<f64>>, ProblemError> {
    let dim = nodes.dim;
    let regions = raw
        .phases
        .iter()
        .enumerate()
        .map(|(k, ph)| ph.region.as_ref().map(|r| region(&format!("model.material.phases[{k}].region"), r, dim)))
        .map(Option::transpose)
        .collect::<Result<Vec<_>, _>>()?;
    let per_node =
        |k: usize| raw.phases[k].phase.is_some() || regions[k].as_ref().is_some_and(|r| !r.set_names().is_empty());
    if !(0..raw.phases.len()).any(per_node) {
        return Ok(None);
    }
    let mut moduli = vec![reference; nodes.positions.len()];
    for (k, ph) in raw.phases.iter().enumerate() {
        for n in crate::validate::phase_nodes(nodes, &nodes.phase, k, (regions[k].as_ref(), ph.phase), presences)? {
            moduli[n] = phase_moduli[k];
        }
    }
    Ok(Some(moduli))
}
