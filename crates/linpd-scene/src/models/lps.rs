//! `"type": "lps"`: the linearized state-based LPS solid ([`linpd_lps::LpsModel`], crates/linpd-lps)
//! on a grid or a point cloud, with the same volume constraints, loads and solvers as the
//! bond-based model: pre-cracks (defects), phases, `energy` and `position_aware` surface
//! corrections (on clouds towards the classical target only). Its ordering, reach and
//! support graph are documented in linpd-lps.

use super::bond_model::{surface_of, Surface};
use super::model_type::{struct_fields, ModelType, Validated};
use super::{foreign_system, solve_system, Capability, Purpose, SceneModel, System};
use crate::nodes::{NodeSet, Nodes};
use crate::raw::{RawInfluence, RawMaterial, RawPlane, RawSurfaceCorrection, RawSurfaceTarget};
use crate::scene::Problem;
use crate::solution::Solution;
use crate::validate::{check_defects, cloud_nodes, material, Context, NOT_COARSENED};
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_core::{Defect, PlaneModel};
use linpd_lps::{LpsModel, LpsParams, SurfaceCorrection};
use linpd_solve::{Apply, Hierarchy, Offers, SolvePlan, SolveReport};
use serde::Deserialize;
use std::any::Any;
use std::sync::Arc;

/// From this Poisson ratio on, a CG solve of an LPS scene carries a conditioning warning in
/// its report's `note`: measured on the 3D bar of `data/lps-tension-3d.json` (1701 nodes,
/// delta = 2h) under three loadings, CG with the default rtol 1e-10 against Cholesky
/// (docs/solvers.md, "Near-incompressible LPS"): below 0.499 the error in `u` stays within
/// 4x the residual, at 0.499 it is 12x (a digit lost) and the iterations grow 10x; from 0.4993
/// the true residual stalls above 1e-10 on one loading (an error since CG checks it).
pub const CG_NEAR_INCOMPRESSIBLE_NU: f64 = 0.499;

/// The keys of an lps model (`docs/problem-format.md`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLps {
    /// `"lps"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Horizon `delta`.
    pub horizon: f64,
    /// Partial-volume scaling at the horizon edge.
    #[serde(default)]
    pub partial_volume: bool,
    /// 2D assumption: `stress` or `strain`.
    #[serde(default)]
    pub plane: Option<RawPlane>,
    /// Bulk modulus `K`.
    #[serde(default)]
    pub bulk_modulus: Option<f64>,
    /// Shear modulus `G`.
    #[serde(default)]
    pub shear_modulus: Option<f64>,
    /// Young's modulus `E` (with `poisson_ratio`, instead of `K` and `G`).
    #[serde(default)]
    pub young_modulus: Option<f64>,
    /// Poisson's ratio `nu` (with `young_modulus`).
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
    /// Influence function, `inverse_distance` (default) or `constant`.
    #[serde(default)]
    pub influence: Option<RawInfluence>,
    /// Defects (pre-cracks) and phases (`young_modulus` and `poisson_ratio` each).
    #[serde(default)]
    pub material: RawMaterial,
    /// `none` (default), `energy` or `position_aware`.
    #[serde(default)]
    pub surface_correction: Option<RawSurfaceCorrection>,
    /// With a surface correction: `classical` (default) or `lattice`.
    #[serde(default)]
    pub surface_target: Option<RawSurfaceTarget>,
}

/// The lps model type.
pub struct LpsType;

/// The registry entry.
pub static LPS: LpsType = LpsType;

impl ModelType for LpsType {
    fn name(&self) -> &'static str {
        "lps"
    }
    fn fields(&self) -> &'static [&'static str] {
        struct_fields::<RawLps>()
    }
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError> {
        let raw: RawLps = cx.model_keys()?;
        let dim = cx.dim();
        if let Some(spec) = &cx.raw.nodes {
            crate::validate::refuse_lattice_target(raw.surface_target)?;
            let surface = surface_of(true, raw.surface_correction, raw.surface_target)?;
            // a rank's halo: as on a lattice (below)
            let mean_of_ends = surface.correction == SurfaceCorrection::Energy;
            let reaches = Some(2 + usize::from(mean_of_ends));
            let corrected = surface.correction != SurfaceCorrection::None;
            let path = crate::memory::Path::LpsAssembled;
            // an LPS cloud's hierarchy is negligible against its tangent (the same peaks with
            // Jacobi and multigrid, docs/robustness.md)
            let (nodes, _) = cloud_nodes(cx, spec, raw.horizon, (reaches, corrected), (path, &|_| Vec::new()), false)?;
            let ratio = raw.horizon / crate::nodes::NodeSet::spacing(&nodes);
            let n = crate::nodes::NodeSet::count(&nodes);
            crate::memory::check_lps_work(n, crate::memory::neighbours(dim, ratio), ratio)?;
            let params = params(dim, &raw)?;
            let material = material(&defects_only(&raw.material), dim, None)?;
            check_defects(&material, &nodes, raw.horizon, &cx.presences)?;
            let nodes = Nodes::Cloud(nodes);
            let (phases, node_moduli) = phases(&raw.material, dim, &nodes, &params, &cx.presences)?;
            let model = LpsSceneModel { params, defects: material.defects, surface, cloud: true, phases, node_moduli };
            return Ok(Validated { nodes, model: Box::new(model) });
        }
        // a body (and its cut volumes) is applied after the memory check, on the full box: the
        // stencils need the full box, so such a scene assembles
        let plain = cx.raw.body.is_none()
            && raw.material.phases.is_empty()
            && raw.material.defects.is_empty()
            && surface_of(true, raw.surface_correction, raw.surface_target)?.correction == SurfaceCorrection::None;
        // the halo of a rank's part (crate::part): two reaches (the dilatation of a common
        // partner); one more with the energy correction, whose bond factors in a partner's
        // dilatation are the mean of two nodes' fits over their families (position_aware's are
        // the partner's own)
        let mean_of_ends =
            surface_of(true, raw.surface_correction, raw.surface_target)?.correction == SurfaceCorrection::Energy;
        let reaches = Some(2 + usize::from(mean_of_ends));
        // the plan of the box's every DOF (the constraints are not known yet)
        let plan = |grid: &linpd_core::Grid| {
            let offers = lattice_offers(grid, plain, grid.len() * dim);
            linpd_solve::plan(&cx.solver, &offers, &Default::default())
        };
        let grid = crate::validate::lattice_for(cx, raw.horizon, reaches, &|grid| memory_path(&plan(grid)))?;
        let ratio = raw.horizon / grid.spacing();
        // the tangent's assembly work, where the solve assembles it
        if memory_path(&plan(&grid)).0 == crate::memory::Path::LpsAssembled {
            crate::memory::check_lps_work(grid.len(), crate::memory::neighbours(dim, ratio), ratio)?;
        }
        let params = params(dim, &raw)?;
        let material = material(&defects_only(&raw.material), dim, None)?;
        crate::validate::require_defects_cut(&material, &grid, raw.horizon, &cx.presences)?;
        let surface = surface_of(true, raw.surface_correction, raw.surface_target)?;
        let nodes = Nodes::Lattice(grid);
        let (phases, node_moduli) = phases(&raw.material, dim, &nodes, &params, &cx.presences)?;
        let model = LpsSceneModel { params, defects: material.defects, surface, cloud: false, phases, node_moduli };
        Ok(Validated { nodes, model: Box::new(model) })
    }
}

/// Validates the lps keys (the model itself checks `m > 0` when it is built).
fn params(dim: usize, raw: &RawLps) -> Result<LpsParams, ProblemError> {
    let (horizon, partial_volume, plane, material) = (raw.horizon, raw.partial_volume, raw.plane, &raw.material);
    let (bulk, shear, influence) = (raw.bulk_modulus, raw.shear_modulus, raw.influence);
    if dim == 1 {
        return Err(ProblemError::invalid("dimension", "lps models are 2D or 3D"));
    }
    if material.bond_rule.is_some() {
        return Err(ProblemError::invalid(
            "model.material.bond_rule",
            "lps models have no bond rule: each node's energy uses its own phase's K and G, nothing is averaged \
             over a bond",
        ));
    }
    let (k, g) = crate::elastic::lps_moduli("model", bulk, shear, raw.young_modulus, raw.poisson_ratio)?;
    if !(k.is_finite() && k > 0.0) {
        return Err(ProblemError::invalid("model.bulk_modulus", format!("must be > 0, got {k:e}")));
    }
    if !(g.is_finite() && g > 0.0) {
        return Err(ProblemError::invalid("model.shear_modulus", format!("must be > 0, got {g:e}")));
    }
    let plane = match (dim, plane) {
        (2, Some(RawPlane::Stress)) => Some(PlaneModel::Stress),
        (2, Some(RawPlane::Strain)) => Some(PlaneModel::Strain),
        (2, None) => {
            return Err(ProblemError::invalid("model.plane", "2D lps scenes need \"plane\": \"stress\" or \"strain\""))
        }
        (_, Some(_)) => return Err(ProblemError::invalid("model.plane", "only meaningful in 2D")),
        (_, None) => None,
    };
    let influence = match influence {
        None | Some(RawInfluence::InverseDistance) => linpd_lps::Influence::InverseDistance,
        Some(RawInfluence::Constant) => linpd_lps::Influence::Constant,
    };
    let params = linpd_lps::LpsParams { K: k, G: g, horizon, influence, partial_volume, plane };
    // Overflow first: `G = 1e308` would otherwise read as "Poisson ratio = NaN".
    if let Some((what, value)) = params.overflow(dim) {
        let key = if g >= k { "model.shear_modulus" } else { "model.bulk_modulus" };
        return Err(ProblemError::invalid(
            key,
            format!("K = {k:e} and G = {g:e} overflow: the derived constant {what} = {value:e}; use smaller units for the moduli"),
        ));
    }
    let nu = params.poisson_ratio();
    if !(nu > -1.0 && nu < 0.5) {
        return Err(ProblemError::invalid(
            "model.shear_modulus",
            format!("Poisson ratio (3K - 2G)/(2(3K + G)) = {nu} is outside (-1, 1/2)"),
        ));
    }
    Ok(params)
}

/// An lps scene: the LPS parameters, the defects (pre-cracks) of its material and its surface
/// correction.
#[derive(Debug, Clone)]
pub struct LpsSceneModel {
    /// `K`, `G`, the horizon, the influence function, ...
    pub params: LpsParams,
    /// Pre-cracks.
    pub defects: Vec<Defect>,
    /// The surface correction and its target.
    pub surface: Surface,
    /// On a point cloud.
    cloud: bool,
    /// `(K, G)` of every phase, in scene order.
    phases: Vec<(f64, f64)>,
    /// `(K_i, G_i)` of every node when the material has phases (the last phase that selects a
    /// node wins, the model's `K`, `G` where none does).
    node_moduli: Option<(Vec<f64>, Vec<f64>)>,
}

/// The material without its phases (the lps phases are validated by [`phases`]).
fn defects_only(raw: &RawMaterial) -> RawMaterial {
    RawMaterial { phases: Vec::new(), ..raw.clone() }
}

/// The phases of an lps material and the moduli of every node: each phase gives
/// `young_modulus` and `poisson_ratio` (its `K` and `G`), and where: a `region` (a mesh's sets
/// included) or a cloud's `phase` number ([`crate::validate::phase_nodes`]).
type Phases = (Vec<(f64, f64)>, Option<(Vec<f64>, Vec<f64>)>);
fn phases(
    raw: &RawMaterial,
    dim: usize,
    nodes: &Nodes,
    params: &LpsParams,
    presences: &crate::part::Presences,
) -> Result<Phases, ProblemError> {
    if raw.phases.is_empty() {
        return Ok((Vec::new(), None));
    }
    let column = nodes.cloud().map_or(&[][..], |c| &c.phase[..]);
    let (mut bulk, mut shear) = (vec![params.K; nodes.len()], vec![params.G; nodes.len()]);
    let mut out = Vec::new();
    for (k, ph) in raw.phases.iter().enumerate() {
        let p = format!("model.material.phases[{k}]");
        if ph.modulus.is_some() {
            return Err(ProblemError::invalid(
                format!("{p}.modulus"),
                "an lps phase gives young_modulus and poisson_ratio (its K and G), not a bond modulus",
            ));
        }
        let (k_phase, g_phase) = crate::elastic::lps_moduli(&p, None, None, ph.young_modulus, ph.poisson_ratio)?;
        let own = LpsParams { K: k_phase, G: g_phase, ..*params };
        if let Some((what, value)) = own.overflow(dim) {
            return Err(ProblemError::invalid(
                format!("{p}.young_modulus"),
                format!("overflows: the derived constant {what} = {value:e}; use smaller units for the moduli"),
            ));
        }
        let region = ph.region.as_ref().map(|r| crate::validate::region(&format!("{p}.region"), r, dim)).transpose()?;
        for n in crate::validate::phase_nodes(nodes, column, k, (region.as_ref(), ph.phase), presences)? {
            (bulk[n], shear[n]) = (k_phase, g_phase);
        }
        out.push((k_phase, g_phase));
    }
    Ok((out, Some((bulk, shear))))
}

/// The memory path of an lps lattice scene solved by `plan` and the preconditioners whose setup
/// the estimate counts: the matrix-free tangent (with the pair part's hierarchy when one is
/// built), or the assembled tangent (with a hierarchy only when asked for: the one `auto`'s
/// cost model may build is negligible against the tangent, the same peaks measured with Jacobi
/// and multigrid, docs/robustness.md).
fn memory_path(plan: &SolvePlan) -> (crate::memory::Path, Vec<linpd_solve::PreconditionerKind>) {
    match plan.apply() {
        Apply::MatrixFree => (crate::memory::Path::LpsMatrixFree, plan.preconditioners.clone()),
        Apply::Assembled if plan.hierarchy == Hierarchy::Built => {
            (crate::memory::Path::LpsAssembled, plan.preconditioners.clone())
        }
        Apply::Assembled => (crate::memory::Path::LpsAssembled, Vec::new()),
    }
}

/// What an lps model on `grid` offers the solvers with `unknowns` free DOFs: a symmetric
/// tangent and, for a homogeneous material (`plain`: no phases, defects or surface correction)
/// on the full box, the stencils of `linpd_lps::stencil` with the pair part's block rows:
/// `auto` then solves it matrix-free (multigrid-CG on the pair part's hierarchy).
fn lattice_offers(grid: &linpd_core::Grid, plain: bool, unknowns: usize) -> Offers {
    Offers {
        dim: grid.dim(),
        unknowns,
        symmetric: true,
        fast_apply: plain && grid.is_full() && grid.has_uniform_volumes(),
        companion_gmres: false,
    }
}

impl LpsSceneModel {
    /// A homogeneous material without surface correction (on the full box it has stencils).
    fn plain(&self) -> bool {
        self.defects.is_empty() && self.node_moduli.is_none() && self.surface.correction == SurfaceCorrection::None
    }

    /// The LPS model on the scene's nodes and, with a moment-matching surface correction, what it
    /// did and cost (for the solve report).
    pub fn build(&self, p: &Problem) -> Result<(LpsModel, Option<CorrectionSummary>), ProblemError> {
        let (params, defects, surface) = (&self.params, &self.defects, &self.surface);
        let built = match p.nodes().cloud() {
            Some(c) => match c.whole {
                None => LpsModel::on_points(c.dim, c.positions.clone(), &c.volumes, params, defects),
                Some(scales) => {
                    let owned = |i: usize| p.owns(i);
                    LpsModel::on_part_of_points(
                        c.dim,
                        c.positions.clone(),
                        &c.volumes,
                        (params, defects),
                        scales,
                        &owned,
                    )
                }
            },
            None => LpsModel::with_defects(p.lattice()?, params, defects),
        };
        let model = built.map_err(|e| match e {
            // the usual cause with defects: one passes through the node (the crossing test is
            // closed, so every bond of that node touches it)
            e @ linpd_lps::LpsError::ZeroWeightedVolume { .. } if !defects.is_empty() => ProblemError::invalid(
                "model.material.defects",
                format!(
                    "{e}: a defect through a node cuts all its bonds; place defects between {}",
                    if p.nodes().cloud().is_some() { "nodes" } else { "lattice rows" }
                ),
            ),
            e => ProblemError::invalid("model", e.to_string()),
        })?;
        let layer = p.nodes().cloud().map_or(&[][..], |c| &c.layer[..]);
        let (model, summary) = model
            .corrected_with_layer(surface.correction, surface.target, layer)
            .map_err(|e| ProblemError::invalid("model.surface_correction", e.to_string()))?;
        let model = match &self.node_moduli {
            Some((bulk, shear)) => model
                .with_node_moduli(bulk, shear)
                .map_err(|e| ProblemError::invalid("model.material", e.to_string()))?,
            None => model,
        };
        Ok((model, summary))
    }
}

impl SceneModel for LpsSceneModel {
    fn node_elastic(&self, _: &Problem, x: &[linpd_core::Point]) -> Option<crate::scene::NodeElastic> {
        let of = |k: f64, g: f64| {
            let c = crate::elastic::lps_constants(k, g);
            (c.young_modulus, c.poisson_ratio)
        };
        // a solution's nodes are the scene's (LPS has no graded mesh): per node, or none
        let constants = match &self.node_moduli {
            Some((bulk, shear)) if bulk.len() == x.len() => bulk.iter().zip(shear).map(|(&k, &g)| of(k, g)).collect(),
            Some(_) => return None,
            None => vec![of(self.params.K, self.params.G); x.len()],
        };
        Some((self.params.plane, constants))
    }
    fn elastic_constants(&self) -> Vec<crate::elastic::PhaseConstants> {
        let mut out = vec![crate::elastic::lps_constants(self.params.K, self.params.G)];
        for (k, &(bulk, shear)) in self.phases.iter().enumerate() {
            out.push(crate::elastic::PhaseConstants {
                phase: format!("phases[{k}]"),
                ..crate::elastic::lps_constants(bulk, shear)
            });
        }
        out
    }
    fn name(&self) -> &'static str {
        "lps"
    }
    fn describe(&self) -> String {
        if self.cloud {
            "lps (point cloud)".into()
        } else {
            "lps".into()
        }
    }
    fn horizon(&self) -> Option<f64> {
        Some(self.params.horizon)
    }
    /// A point cloud's tangent is assembled; a lattice's has the stencils where it is homogeneous.
    fn offers(&self, p: &Problem, unknowns: usize) -> Option<Offers> {
        Some(match p.grid() {
            Some(grid) => lattice_offers(grid, self.plain(), unknowns),
            None => Offers { dim: p.dim(), unknowns, symmetric: true, fast_apply: false, companion_gmres: false },
        })
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        match capability {
            Capability::Dynamics => {
                Some("explicit dynamics steps the bond operator (linpd-dynamics); lps models are static here".into())
            }
            Capability::Coarsen if self.cloud => Some(NOT_COARSENED.into()),
            _ => None,
        }
    }
    fn system(&self, p: &Problem, purpose: Purpose, progress: &dyn Progress) -> Result<System, ProblemError> {
        // a point cloud was checked against memory when the scene was validated; rows assemble
        // nothing whole
        let memory_estimate = match (p.grid(), purpose) {
            (Some(grid), Purpose::Assembled) => {
                Some(crate::memory::check_solver(crate::memory::Path::LpsAssembled, grid, self.params.horizon, &[])?)
            }
            (Some(grid), Purpose::Solve) => {
                let (path, setup) = memory_path(p.planned()?);
                if path == crate::memory::Path::LpsAssembled {
                    let ratio = self.params.horizon / grid.spacing();
                    crate::memory::check_lps_work(grid.len(), crate::memory::neighbours(p.dim(), ratio), ratio)?;
                }
                Some(crate::memory::check_solver(path, grid, self.params.horizon, &setup)?)
            }
            (None, Purpose::Solve | Purpose::Assembled) => Some(crate::memory::check_cloud(
                crate::memory::Path::LpsAssembled,
                p.dim(),
                &p.nodes().positions(),
                self.params.horizon,
                &[],
            )?),
            _ => None,
        };
        progress.phase(&format!(
            "building the LPS model: {} nodes, horizon/spacing = {:.3}",
            p.nodes().len(),
            self.params.horizon / p.nodes().spacing()
        ));
        let (model, correction) = self.build(p)?;
        let notes: Vec<String> = correction.map(|c| c.describe()).into_iter().collect();
        if purpose == Purpose::Solve {
            progress.phase("the LPS tangent couples nodes up to 2 horizons apart");
        }
        Ok(System {
            n_bonds: model.family().n_bonds(),
            model: Arc::new(model),
            bc: p.dirichlet(),
            f: p.load_vector(),
            notes,
            built_before: 0.0,
            memory_estimate,
        })
    }
    fn solution(&self, p: &Problem, s: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        let model = s.model.as_any().downcast_ref::<LpsModel>().ok_or_else(|| foreign_system("lps"))?;
        Ok(solution(p, model, u, report))
    }
    /// The static solve, with a warning in the report when CG solved a near-incompressible solid.
    fn solve(&self, p: &Problem, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        let mut s = solve_system(self, p, progress)?;
        let nu = self.params.poisson_ratio();
        if nu >= CG_NEAR_INCOMPRESSIBLE_NU && matches!(s.report.solver, linpd_solve::SolverId::Cg { .. }) {
            let note = format!(
                "near-incompressible LPS (nu = {nu}): from nu = {CG_NEAR_INCOMPRESSIBLE_NU} CG was measured to lose a digit \
                 against the direct solver at the same residual, to need 10x the iterations and, from nu = 0.4993, to stop \
                 above rtol 1e-10 (docs/solvers.md); the cholesky solver is the safer choice"
            );
            progress.phase(&format!("warning: {note}"));
            s.report.notes.push(note);
        }
        Ok(s)
    }
    fn level0_stiffness(&self, p: &Problem) -> Result<linpd_core::Csc, ProblemError> {
        Ok(linpd_lps::assemble_tangent(&self.build(p)?.0))
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The [`Solution`] of an lps scene for displacements `u` over all DOFs (solved here or
/// elsewhere, `linpd_problem::RowSystem`): balance, strain, dilatation and energy density.
pub(crate) fn solution(p: &Problem, model: &LpsModel, u: Vec<f64>, report: SolveReport) -> Solution {
    let n = p.nodes.len();
    let balance = p.balance(&|u, y| linpd_core::Model::apply(model, u, y), &u);
    let volumes: Vec<f64> = (0..n).map(|i| model.node_volume(i)).collect();
    let strain = Some(crate::nodal_strain(model, &volumes, &u));
    let dilatation = Some(model.linearized_theta(&u));
    let strain_energy_density = Some(model.linearized_energy_density(&u));
    Solution {
        name: p.name.clone(),
        dim: p.dim(),
        x: model.positions(),
        u,
        is_layer: (0..n).map(|i| p.nodes.is_layer(i)).collect(),
        volumes,
        n_bonds: model.family().n_bonds(),
        balance: Some(balance),
        strain_energy_density,
        strain,
        dilatation,
        cells: None,
        graded_mesh: None,
        file_node: None,
        material: Vec::new(),
        stress: None,
        pd_stress: None,
        report,
    }
}
