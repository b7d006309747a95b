//! `"type": "blend"` and `"type": "ce"`: the 1D blended PD/CE model of Seleson,
//! Beneddine & Prudhomme (2013) and its pure-CE limit, eq. (28).
//!
//! The generic scene keys keep their meaning: `grid` gives the domain `(0, L)` (`min` must be
//! 0, no layer: the blended model has local Dirichlet conditions at both ends) and `dx`;
//! `model.horizon` and `model.micromodulus` give `eps` (a multiple of `dx`), the kernel and `K`
//! (discrete normalization, the paper's `eps^2 -> N(N+1) dx^2`); constraints must fix exactly the
//! end nodes `x = 0` and `x = L`; loads are point loads on nodes (`b_i = delta_ip / dx` is a
//! unit force) or body-force densities on boxes; `model.material` (phases, bond rule, defects)
//! is the bond model's, entering the blended rows as [`linpd_blend::one_d::material`] derives.
//! Solutions carry the force balance: per load its nodes and force, per constraint its
//! reaction ([`linpd_blend::BlendSolution::reactions`]).

//!
//! The model has its own solvers ([`linpd_blend::solve_model`]: `auto`, `lu`, `dense`): no CG,
//! no matrix-free solve, no coarsening, no explicit dynamics, no point clouds.

use super::model_type::{struct_fields, ModelType, Validated};
use super::{foreign_system, Capability, Purpose, SceneModel, System};
use crate::balance::Balance;
use crate::balance::ConstraintBalance;
use crate::balance::LoadBalance;
use crate::nodes::Nodes;
use crate::raw::{RawBlending, RawBlendingTable, RawMaterial, RawMicromodulus, RawNormalize, RawSolverKind};
use crate::scene::Constraint;
use crate::scene::Load;
use crate::scene::Problem;
use crate::solution::Solution;
use crate::validate::{bond_elastic, bond_micromodulus, defect_cuts_nothing, kernel_of, material, Context};
use crate::ProblemError;
use linpd_blend::{solve_model, BlendOperator, BlendParams, BlendSolver, Blending, ModelKind, Regions};
use linpd_core::progress::Progress;
use linpd_core::{Grid, Material, Region};
use linpd_solve::{Dirichlet, SolveReport, StaticError};
use serde::Deserialize;
use std::any::Any;
use std::sync::Arc;

/// The keys of a blend model (`docs/problem-format.md`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBlend1d {
    /// `"blend"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Horizon `eps`, a multiple of `dx`.
    pub horizon: f64,
    /// Kernel and modulus (discrete normalization).
    #[serde(default)]
    pub micromodulus: Option<RawMicromodulus>,
    /// `[L1, L2, L3, L4]`.
    #[serde(default)]
    pub regions: Option<[f64; 4]>,
    /// `constant`, `linear`, `cubic` or `piecewise`.
    #[serde(default)]
    pub blending: Option<RawBlending>,
    /// With constant blending: the bridge value (default 0.5).
    #[serde(default)]
    pub blending_value: Option<f64>,
    /// With piecewise blending: `{"s": [...], "beta": [...]}`.
    #[serde(default)]
    pub blending_table: Option<RawBlendingTable>,
    /// Coarse CE spacing (a power-of-two multiple of the grid spacing).
    #[serde(default)]
    pub ce_spacing: Option<f64>,
    /// The PD / higher-order-gradient model (M = 4) instead of PD / CE.
    #[serde(default)]
    pub hog: Option<bool>,
    /// Phases, bond rule, defects.
    #[serde(default)]
    pub material: RawMaterial,
}

/// The keys of a ce model: the blend's without the blending.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCe {
    /// `"ce"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Horizon (the micromodulus's normalization length).
    pub horizon: f64,
    /// Kernel and modulus.
    #[serde(default)]
    pub micromodulus: Option<RawMicromodulus>,
    /// Phases, bond rule, defects.
    #[serde(default)]
    pub material: RawMaterial,
}

impl From<RawCe> for RawBlend1d {
    fn from(c: RawCe) -> Self {
        RawBlend1d {
            kind: c.kind,
            horizon: c.horizon,
            micromodulus: c.micromodulus,
            regions: None,
            blending: None,
            blending_value: None,
            blending_table: None,
            ce_spacing: None,
            hog: None,
            material: c.material,
        }
    }
}

/// The blend and ce model types.
pub struct Blend1dType {
    kind: ModelKind,
}

/// The registry entry of `"type": "blend"`.
pub static BLEND: Blend1dType = Blend1dType { kind: ModelKind::Blended };
/// The registry entry of `"type": "ce"`.
pub static CE: Blend1dType = Blend1dType { kind: ModelKind::PureCe };

impl Blend1dType {
    fn name_of(kind: ModelKind) -> &'static str {
        if kind == ModelKind::PureCe {
            "ce"
        } else {
            "blend"
        }
    }
}

impl ModelType for Blend1dType {
    fn name(&self) -> &'static str {
        Self::name_of(self.kind)
    }
    fn fields(&self) -> &'static [&'static str] {
        match self.kind {
            ModelKind::PureCe => struct_fields::<RawCe>(),
            _ => struct_fields::<RawBlend1d>(),
        }
    }
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError> {
        let raw: RawBlend1d = match self.kind {
            ModelKind::PureCe => cx.model_keys::<RawCe>()?.into(),
            _ => cx.model_keys()?,
        };
        let name = self.name();
        let dim = cx.dim();
        if cx.raw.nodes.is_some() {
            return Err(ProblemError::invalid(
                "nodes",
                format!("point clouds take bond and lps models, the scene has {name} (blend and ce are 1D grids)"),
            ));
        }
        if cx.raw.body.is_some() {
            return Err(ProblemError::invalid(
                "body",
                format!("{name} models live on the whole interval (0, L) of the grid: no body"),
            ));
        }
        if dim != 1 {
            return Err(ProblemError::invalid(
                "dimension",
                format!(
                    "{name} models are 1D, got dimension {dim}; in 2D and 3D a bond model blends PD with local \
                     elasticity through \"pd_regions\" and \"transition\""
                ),
            ));
        }
        let grid = crate::validate::lattice(cx, raw.horizon, crate::memory::Path::BondAssembled)?;
        let micromodulus = bond_micromodulus(dim, raw.horizon, raw.micromodulus.as_ref(), None, false)?;
        let material = material(&raw.material, dim, bond_elastic(dim, &micromodulus))?;
        if let Some(k) = material.defect_cutting_nothing(&grid, raw.horizon) {
            return Err(defect_cuts_nothing(k));
        }
        let scene = BlendScene::new(self.kind, cx, &raw, material)?;
        Ok(Validated { nodes: Nodes::Lattice(grid), model: Box::new(scene) })
    }
}

/// A 1D blended (or pure CE) problem: Seleson, Beneddine & Prudhomme (2013).
#[derive(Debug, Clone)]
pub struct BlendScene {
    /// Operator parameters.
    pub(crate) params: BlendParams,
    /// Blended or pure CE.
    pub(crate) kind: ModelKind,
    /// `u(0)`.
    pub(crate) u_left: f64,
    /// `u(L)`.
    pub(crate) u_right: f64,
    /// Loads.
    pub(crate) loads: Vec<linpd_blend::Load>,
    /// The scene load (`loads[k]`) each entry of `loads` comes from (a union of boxes gives
    /// one body load per merged interval).
    pub(crate) load_of: Vec<usize>,
    /// Per scene load, its kind for the balance (`point`, `body`).
    pub(crate) load_kinds: Vec<&'static str>,
    /// Per constraint, whether it holds `x = 0` and `x = L`.
    pub(crate) constraint_ends: Vec<[bool; 2]>,
    /// Solver.
    pub(crate) solver: BlendSolver,
}

/// The translated loads of a blend scene: the blend loads, the scene load each comes from, and
/// each scene load's kind.
type BlendLoads = (Vec<linpd_blend::Load>, Vec<usize>, Vec<&'static str>);

impl BlendScene {
    /// Validates the blend keys (the constraints, loads and solver are translated by
    /// [`SceneModel::bind`]).
    fn new(kind: ModelKind, cx: &Context, m: &RawBlend1d, material: Material) -> Result<Self, ProblemError> {
        let params = Self::validate_params(kind, cx, m, material)?;
        Ok(BlendScene {
            params,
            kind,
            u_left: 0.0,
            u_right: 0.0,
            loads: Vec::new(),
            load_of: Vec::new(),
            load_kinds: Vec::new(),
            constraint_ends: Vec::new(),
            solver: BlendSolver::Auto,
        })
    }

    /// The operator parameters from the grid and the model keys.
    fn validate_params(
        kind: ModelKind,
        cx: &Context,
        m: &RawBlend1d,
        material: Material,
    ) -> Result<BlendParams, ProblemError> {
        let name = Blend1dType::name_of(kind);
        let grid_raw = cx.raw.grid.as_ref().ok_or_else(|| ProblemError::invalid("grid", "missing"))?;
        let mm = m.micromodulus.as_ref().ok_or_else(|| ProblemError::invalid("model.micromodulus", "missing"))?;
        let horizon = m.horizon;
        if grid_raw.min[0] != 0.0 {
            return Err(ProblemError::invalid("grid.min", format!("{name} models live on (0, L): min must be [0.0]")));
        }
        if !grid_raw.has_no_layer(1) {
            return Err(ProblemError::invalid(
                "grid.layer",
                format!("{name} models have local Dirichlet conditions at both ends: no layer"),
            ));
        }
        if mm.normalize != RawNormalize::Discrete {
            return Err(ProblemError::invalid(
                "model.micromodulus.normalize",
                format!("{name} models use the discrete normalization (eq. (19)): set \"discrete\""),
            ));
        }
        let blended = kind == ModelKind::Blended;
        let (regions, blending) = if blended {
            let r = m.regions.ok_or_else(|| {
                ProblemError::invalid("model.regions", "missing: [L1, L2, L3, L4] with 0 < L1 < L2 < L3 < L4 < L")
            })?;
            let b = match m.blending {
                None => {
                    return Err(ProblemError::invalid(
                        "model.blending",
                        "missing: constant, linear, cubic or piecewise",
                    ))
                }
                Some(RawBlending::Constant) => Blending::Constant { value: m.blending_value.unwrap_or(0.5) },
                Some(RawBlending::Linear) => Blending::Linear,
                Some(RawBlending::Cubic) => Blending::Cubic,
                Some(RawBlending::Piecewise) => {
                    let t = m.blending_table.as_ref().ok_or_else(|| {
                        ProblemError::invalid(
                            "model.blending_table",
                            "piecewise blending needs {\"s\": [...], \"beta\": [...]}",
                        )
                    })?;
                    Blending::Piecewise { s: t.s.clone(), beta: t.beta.clone() }
                }
            };
            if m.blending_value.is_some() && m.blending != Some(RawBlending::Constant) {
                return Err(ProblemError::invalid("model.blending_value", "only constant blending takes a value"));
            }
            if m.blending_table.is_some() && m.blending != Some(RawBlending::Piecewise) {
                return Err(ProblemError::invalid("model.blending_table", "only piecewise blending takes a table"));
            }
            (Regions { l1: r[0], l2: r[1], l3: r[2], l4: r[3] }, b)
        } else {
            // Pure CE: any admissible geometry, beta = 0 everywhere.
            let l = grid_raw.max[0];
            (Regions { l1: 0.25 * l, l2: 0.4 * l, l3: 0.6 * l, l4: 0.75 * l }, Blending::Linear)
        };
        let length = grid_raw.max[0];
        let params = BlendParams {
            length,
            dx: grid_raw.spacing,
            horizon,
            modulus: crate::elastic::BondElastic::of(1, None)
                .modulus("model.micromodulus", mm.modulus, mm.young_modulus, mm.poisson_ratio)?
                .unwrap_or(1.0),
            kernel: kernel_of(mm, horizon)?,
            regions,
            blending,
            ce_spacing: m.ce_spacing,
            hog: m.hog.unwrap_or(false),
            material,
        };
        let kind = if blended { ModelKind::Blended } else { ModelKind::PureCe };
        params.validate().and_then(|()| params.check_material(kind)).map_err(|e| match e {
            linpd_blend::BlendError::Parameter { name, reason } if name == "horizon" => {
                ProblemError::invalid("model.horizon", reason)
            }
            linpd_blend::BlendError::Parameter { name, reason } if name == "dx" => {
                ProblemError::invalid("grid.spacing", reason)
            }
            linpd_blend::BlendError::Parameter { name, reason } if name == "length" => {
                ProblemError::invalid("grid.max", reason)
            }
            linpd_blend::BlendError::Parameter { name, reason } => {
                ProblemError::invalid(format!("model.{name}"), reason)
            }
            other => ProblemError::invalid("model", other.to_string()),
        })?;
        Ok(params)
    }

    /// The end values `u(0)`, `u(L)` from the constraints, which must hold exactly the two end
    /// nodes; and per constraint which ends it holds.
    fn ends(name: &str, grid: &Grid, constraints: &[Constraint]) -> Result<(f64, f64, Vec<[bool; 2]>), ProblemError> {
        // Dirichlet conditions: exactly the two end nodes.
        let n = grid.len();
        let (mut left, mut right) = (None, None);
        let mut constraint_ends = vec![[false; 2]; constraints.len()];
        for (k, c) in constraints.iter().enumerate() {
            for (node, _, v) in c.prescribed(grid, 1) {
                let x = grid.position(node)[0];
                if node == 0 {
                    left = Some(v);
                    constraint_ends[k][0] = true;
                } else if node == n - 1 {
                    right = Some(v);
                    constraint_ends[k][1] = true;
                } else {
                    return Err(ProblemError::invalid(
                        format!("constraints[{k}].region"),
                        format!(
                        "{name} models take Dirichlet conditions at x = 0 and x = L only; the region contains x = {x}"
                    ),
                    ));
                }
            }
        }
        let (u_left, u_right) = match (left, right) {
            (Some(a), Some(b)) => (a, b),
            _ => {
                return Err(ProblemError::invalid(
                    "constraints",
                    format!(
                        "{name} models need u fixed at both x = 0 and x = L ({} given)",
                        left.is_some() as u8 + right.is_some() as u8
                    ),
                ))
            }
        };
        Ok((u_left, u_right, constraint_ends))
    }

    /// The scene's loads as blend loads: point loads on nodes, body loads on boxes (a union of
    /// boxes gives one load per merged interval).
    fn translate_loads(name: &str, grid: &Grid, loads: &[Load]) -> Result<BlendLoads, ProblemError> {
        let mut out = Vec::new();
        let mut load_of = Vec::new();
        let mut load_kinds = Vec::new();
        for (k, l) in loads.iter().enumerate() {
            load_kinds.push(if matches!(l, Load::Point { .. }) { "point" } else { "body" });
            match l {
                Load::Point { node, force } => {
                    out.push(linpd_blend::Load::Point { x: grid.position(*node)[0], force: force[0] });
                    load_of.push(k);
                }
                Load::Body { region, density } => {
                    let boxes = match region {
                        Region::Box { min, max } => vec![(min[0], max[0])],
                        Region::Union(parts) => parts
                            .iter()
                            .map(|r| match r {
                                Region::Box { min, max } => Ok((min[0], max[0])),
                                _ => Err(ProblemError::invalid(
                                    format!("loads[{k}].region"),
                                    "blend body loads take boxes or unions of boxes",
                                )),
                            })
                            .collect::<Result<_, _>>()?,
                        _ => {
                            return Err(ProblemError::invalid(
                                format!("loads[{k}].region"),
                                "blend body loads take boxes or unions of boxes",
                            ))
                        }
                    };
                    // A node in two boxes of a union is loaded once, as for lattice scenes: merge
                    // boxes that overlap or touch (closed intervals sharing a node).
                    let mut boxes: Vec<(f64, f64)> = boxes;
                    boxes.sort_by(|p, q| p.0.total_cmp(&q.0));
                    let tol = linpd_core::GEOMETRY_RTOL * grid.spacing();
                    let mut merged: Vec<(f64, f64)> = Vec::new();
                    for (a, b) in boxes {
                        match merged.last_mut() {
                            Some(last) if a <= last.1 + tol => last.1 = last.1.max(b),
                            _ => merged.push((a, b)),
                        }
                    }
                    for (a, b) in merged {
                        out.push(linpd_blend::Load::Body { from: a, to: b, density: density[0] });
                        load_of.push(k);
                    }
                }
                Load::Resultant { .. } | Load::Nodal { .. } => {
                    return Err(ProblemError::invalid(
                        format!("loads[{k}]"),
                        format!("{name} models take point and body loads (resultant and nodal loads need the model's nodes and volumes)"),
                    ))
                }
            }
        }
        Ok((out, load_of, load_kinds))
    }

    /// The operator, prescribed displacements and nodal forces, as the solve builds them
    /// ([`linpd_blend::constraints_and_loads`]).
    fn system_parts(&self) -> Result<(BlendOperator, Dirichlet, Vec<f64>), ProblemError> {
        let op = BlendOperator::assemble(&self.params, self.kind).map_err(blend_error)?;
        let (bc, f) =
            linpd_blend::constraints_and_loads(&op, &self.params, self.kind, self.u_left, self.u_right, &self.loads)
                .map_err(blend_error)?;
        Ok((op, bc, f))
    }

    /// Operator parameters.
    pub fn params(&self) -> &BlendParams {
        &self.params
    }
    /// Blended or pure CE.
    pub fn kind(&self) -> ModelKind {
        self.kind
    }
    /// `u(0)`.
    pub fn u_left(&self) -> f64 {
        self.u_left
    }
    /// `u(L)`.
    pub fn u_right(&self) -> f64 {
        self.u_right
    }
    /// Loads.
    pub fn loads(&self) -> &[linpd_blend::Load] {
        &self.loads
    }
    /// Solver.
    pub fn solver(&self) -> BlendSolver {
        self.solver
    }
}

/// A blend error as a scene error (a parameter's name is its JSON path).
fn blend_error(e: linpd_blend::BlendError) -> ProblemError {
    match e {
        linpd_blend::BlendError::Parameter { name, reason } => ProblemError::invalid(name, reason),
        other => ProblemError::Blend(other),
    }
}

impl SceneModel for BlendScene {
    fn elastic_constants(&self) -> Vec<crate::elastic::PhaseConstants> {
        let phases = self.params.material.phases.iter().map(|(_, m)| *m);
        crate::elastic::BondElastic::of(1, None).table(self.params.modulus, phases)
    }
    fn name(&self) -> &'static str {
        Blend1dType::name_of(self.kind)
    }
    fn horizon(&self) -> Option<f64> {
        Some(self.params.horizon)
    }
    /// The end values from the constraints, which must hold exactly the end nodes; the loads as
    /// blend loads.
    fn bind(
        &mut self,
        raw: &crate::raw::RawProblem,
        nodes: &Nodes,
        constraints: &[Constraint],
        loads: &[Load],
    ) -> Result<(), ProblemError> {
        let grid = nodes.lattice().ok_or_else(|| ProblemError::invalid("grid", "a blend scene is on a grid"))?;
        let name = self.name();
        (self.u_left, self.u_right, self.constraint_ends) = Self::ends(name, grid, constraints)?;
        (self.loads, self.load_of, self.load_kinds) = Self::translate_loads(name, grid, loads)?;
        // the scene's solver as one of the blend's own (here, after the capability checks: a
        // matrix-free cg is refused by name first)
        self.solver = match raw.solver.kind {
            RawSolverKind::Auto => BlendSolver::Auto,
            RawSolverKind::Lu => BlendSolver::Lu,
            RawSolverKind::Dense => BlendSolver::Dense,
            other => {
                return Err(ProblemError::invalid(
                    "solver.type",
                    format!("{other:?} is not available for {name} models (the blended matrix is unsymmetric): use auto, lu or dense").to_lowercase(),
                ))
            }
        };
        Ok(())
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        let name = self.name();
        match capability {
            Capability::MatrixFree => {
                Some(format!("{name} models are solved by their own direct solvers (auto, lu or dense)"))
            }
            Capability::Coarsen => {
                Some(format!("{name} models have local (CE) rows; coarsening condenses a bond or LPS model"))
            }
            Capability::Dynamics => {
                Some(format!("only \"type\": \"bond\" models have explicit dynamics (model.type is {name})"))
            }
            _ => None,
        }
    }
    fn system(&self, _: &Problem, _: Purpose, _: &dyn Progress) -> Result<System, ProblemError> {
        let (op, bc, f) = self.system_parts()?;
        Ok(System {
            model: Arc::new(op),
            bc,
            f,
            n_bonds: 0,
            notes: Vec::new(),
            built_before: 0.0,
            memory_estimate: None,
        })
    }
    fn static_error(&self, e: StaticError) -> ProblemError {
        blend_error(e.into())
    }
    /// The solution for `u` from the end reactions of the operator `s` holds.
    fn solution(&self, p: &Problem, s: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        let op = s.model.as_any().downcast_ref::<BlendOperator>().ok_or_else(|| foreign_system(self.name()))?;
        let s = linpd_blend::BlendSolution {
            kind: self.kind,
            x: op.mesh.x.clone(),
            reactions: op.end_reactions(s.bc.dofs(), &s.f, &u, self.params.length),
            applied: s.f.iter().sum(),
            u,
            beta: op.beta.clone(),
            transition: op.transition.clone(),
            report,
        };
        Ok(solution(p.name(), self, s))
    }
    fn solve(&self, p: &Problem, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        solve(p.name(), self, progress)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// Solves a blend scene.
pub(crate) fn solve(name: &str, b: &BlendScene, progress: &dyn Progress) -> Result<Solution, ProblemError> {
    progress.phase(&format!(
        "assembling the 1D {:?} model: dx = {}, N = {}",
        b.kind,
        b.params.dx,
        b.params.n_side().unwrap_or(0)
    ));
    let s = solve_model(&b.params, b.kind, b.u_left, b.u_right, &b.loads, b.solver).map_err(|e| match e {
        // Point loads are checked against the mesh here (a coarse CE mesh has fewer nodes than
        // the grid): name the scene's load, not the blend load it became.
        linpd_blend::BlendError::Parameter { name, reason } => match name
            .strip_prefix("loads[")
            .and_then(|r| r.split_once(']'))
            .and_then(|(k, rest)| Some((b.load_of.get(k.parse::<usize>().ok()?)?, rest)))
        {
            Some((k, rest)) => ProblemError::invalid(format!("loads[{k}]{rest}"), reason),
            None => ProblemError::invalid(name, reason),
        },
        other => ProblemError::Blend(other),
    })?;
    progress.phase(&format!(
        "done: {} unknowns, solver {}, relative residual {:.2e}",
        s.report.n, s.report.solver, s.report.rel_residual
    ));
    Ok(solution(name, b, s))
}

/// The [`Solution`] of a solved blend scene (here or elsewhere, `linpd_problem::RowSystem`).
pub(crate) fn solution(name: &str, b: &BlendScene, s: linpd_blend::BlendSolution) -> Solution {
    let balance = balance(b, &s);
    Solution {
        name: name.to_string(),
        dim: 1,
        x: s.x.iter().map(|&x| [x, 0.0, 0.0]).collect(),
        u: s.u,
        is_layer: vec![false; s.x.len()],
        volumes: Vec::new(),
        n_bonds: 0,
        report: s.report,
        balance: Some(balance),
        strain_energy_density: None,
        strain: None,
        dilatation: None,
        cells: None,
        graded_mesh: None,
        file_node: None,
        material: Vec::new(),
        stress: None,
        pd_stress: None,
    }
}

/// The balance of a solved blend scene (the definitions of [`crate::balance`]): per scene load
/// the mesh nodes it caught and its total force, per constraint the end nodes it holds (an end
/// two constraints hold belongs to the first) and their reactions `A u - f`.
fn balance(b: &BlendScene, s: &linpd_blend::BlendSolution) -> Balance {
    let tol = 1e-9 * b.params.dx;
    let mut loads: Vec<LoadBalance> =
        b.load_kinds.iter().map(|&kind| LoadBalance { kind, nodes: 0, force: vec![0.0], moment: Vec::new() }).collect();
    for (l, &k) in b.loads.iter().zip(&b.load_of) {
        // The loads were applied in the solve, so each one's nodes exist.
        let nodes = l.nodes(&s.x, tol).unwrap_or_default();
        let f = linpd_blend::nodal_forces(&s.x, std::slice::from_ref(l), tol).unwrap_or_default();
        loads[k].nodes += nodes.len();
        loads[k].force[0] += f.iter().sum::<f64>();
    }
    let mut owned = [false; 2];
    let constraints = b
        .constraint_ends
        .iter()
        .map(|ends| {
            let mut reaction = 0.0;
            let mut dofs = 0;
            for e in 0..2 {
                if ends[e] && !owned[e] {
                    owned[e] = true;
                    dofs += 1;
                    reaction += s.reactions[e];
                }
            }
            let held: Vec<f64> = (0..2).filter(|&e| ends[e]).map(|e| [0.0, b.params.length][e]).collect();
            let centroid = vec![held.iter().sum::<f64>() / held.len().max(1) as f64];
            ConstraintBalance { nodes: held.len(), dofs, reaction: vec![reaction], centroid, moment: Vec::new() }
        })
        .collect();
    Balance::from_parts(1, loads, constraints, crate::balance::MomentFrame::default(), Vec::new())
}
