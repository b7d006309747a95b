//! The bond model on a grid ([`linpd_bond::LatticeBondModel`]): assembled or matrix-free
//! (the lattice stencil), block rows, export, coarsening and explicit dynamics.

use super::bond_model::{self as bond, BondModel};
use super::{Capability, DynamicsOperator, Purpose, SceneModel, System};
use crate::memory::Path;
use crate::scene::Problem;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_bond::BondOperator;
use linpd_bond::LatticeBondModel;
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_core::DofMap;
use linpd_dynamics::Chain;
use linpd_lps::SurfaceCorrection;
use linpd_solve::{Apply, Offers, PreconditionerKind, SolvePlan, SolveReport};
use std::any::Any;
use std::sync::Arc;

/// A bond scene on a grid.
#[derive(Debug, Clone)]
pub struct BondLatticeModel {
    /// Its parameters.
    pub bond: BondModel,
}

impl BondLatticeModel {
    /// The model on the scene's lattice and what its surface correction did and cost.
    pub fn build(&self, p: &Problem) -> Result<(LatticeBondModel, Option<CorrectionSummary>), ProblemError> {
        let b = &self.bond;
        let grid = p.lattice()?.clone();
        // one material on the full box without a surface correction: the stencil alone, no
        // per-bond data; anything else is the stencil with the bonds that differ from it
        if plain_stencil(b, &grid) {
            let model = LatticeBondModel::stencil(grid, b.horizon, b.micromodulus.clone())
                .map_err(|e| ProblemError::invalid("model", e.to_string()))?;
            return Ok((model, None));
        }
        let (op, summary) = b.operator(p.nodes())?;
        Ok((LatticeBondModel::corrected(op, grid, b.horizon, b.micromodulus.clone()), summary))
    }
}

/// Whether the bond model `b` on `grid` is the homogeneous stencil alone (one material, no
/// surface correction, the full box with volumes `h^d`): then it holds no per-bond data
/// ([`LatticeBondModel::stencil`]).
pub(crate) fn plain_stencil(b: &BondModel, grid: &linpd_core::Grid) -> bool {
    b.material.is_homogeneous()
        && b.surface.correction == SurfaceCorrection::None
        && grid.is_full()
        && grid.has_uniform_volumes()
}

/// What a bond model on `grid` offers the solvers with `unknowns` free DOFs: a symmetric `A`
/// and, where the lattice's stencil applies ([`linpd_bond::CorrectedStencil::fits`]: the
/// stencil of a homogeneous full box, or the stencil with the bonds that differ from it:
/// phases, defects, a surface correction, a body that leaves at least half the box's sites), a
/// fast apply with block rows: `auto` then solves it matrix-free (multigrid-CG on the stencil),
/// and the memory estimate follows (the assembled estimate of a 101^3 cube, 33 GiB, refused a
/// scene that `auto` solves matrix-free in a fraction of it). When matrix-free CG stalls,
/// `auto` assembles after all; that fallback is not estimated.
pub(crate) fn offers(grid: &linpd_core::Grid, unknowns: usize) -> Offers {
    Offers {
        dim: grid.dim(),
        unknowns,
        symmetric: true,
        fast_apply: linpd_bond::CorrectedStencil::fits(grid),
        companion_gmres: false,
    }
}

/// The memory path of a bond model on a lattice solved by `plan`, and the preconditioners whose
/// setup the estimate counts: the plan's, `auto`'s possible ones on the assembled matrix
/// included (a cracked 801^2 plate measured 3.0 GiB, 1.8 GiB estimated without its multigrid).
/// `stencil`: the path of the homogeneous stencil alone when the model is one ([`plain_stencil`],
/// [`crate::memory::stencil_path`]), whose matrix-free paths hold no bonds.
pub(crate) fn memory_path(plan: &SolvePlan, stencil: Option<Path>) -> (Path, Vec<PreconditionerKind>) {
    let setup = plan.preconditioners.clone();
    match plan.apply() {
        Apply::MatrixFree => (stencil.unwrap_or(Path::BondMatrixFree), setup),
        Apply::Assembled => (Path::BondAssembled, setup),
    }
}

/// The memory check of a bond model on a lattice before it is built for `purpose`, on the
/// scene's plan ([`Problem::plan`]); `Ok` holds the estimate in bytes (`None` for rows, which
/// assemble nothing whole).
pub(crate) fn check_memory(
    p: &Problem,
    horizon: f64,
    purpose: Purpose,
    stencil: Option<Path>,
) -> Result<Option<f64>, ProblemError> {
    let (path, setup) = match purpose {
        Purpose::Rows => return Ok(None),
        Purpose::Assembled => (Path::BondAssembled, Vec::new()),
        Purpose::Solve => memory_path(p.planned()?, stencil),
    };
    crate::memory::check_solver(path, p.lattice()?, horizon, &setup).map(Some)
}

impl SceneModel for BondLatticeModel {
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
    fn horizon(&self) -> Option<f64> {
        Some(self.bond.horizon)
    }
    fn lacks(&self, _: Capability) -> Option<String> {
        None
    }
    fn offers(&self, p: &Problem, unknowns: usize) -> Option<Offers> {
        Some(offers(p.lattice().ok()?, unknowns))
    }
    fn system(&self, p: &Problem, purpose: Purpose, progress: &dyn Progress) -> Result<System, ProblemError> {
        let grid = p.lattice()?;
        let stencil = plain_stencil(&self.bond, grid)
            .then(|| crate::memory::stencil_path(grid, self.bond.horizon, &self.bond.micromodulus));
        let memory_estimate = check_memory(p, self.bond.horizon, purpose, stencil)?;
        progress.phase(&bond::building(p, self.bond.horizon));
        let (model, correction) = self.build(p)?;
        Ok(System {
            n_bonds: model.n_bonds(),
            model: Arc::new(model),
            bc: p.dirichlet(),
            f: p.load_vector(),
            notes: correction.map(|c| c.describe()).into_iter().collect(),
            built_before: 0.0,
            memory_estimate,
        })
    }
    fn solution(&self, p: &Problem, s: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        Ok(bond::solution(p, s.model(), s.n_bonds, u, report))
    }
    fn level0_stiffness(&self, p: &Problem) -> Result<linpd_core::Csc, ProblemError> {
        let (op, _) = self.bond.operator(p.nodes())?;
        Ok(linpd_bond::assemble(&op, &DofMap::all_free(p.nodes().len(), p.dim())))
    }
    /// On a 1D bar of one material without a surface correction, the infinite chain's
    /// limit: the correction stiffens the bonds at free ends (measured 27-45 % above the chain's
    /// `omega_max^2`), so the chain holds for the uncorrected bar only.
    fn dynamics_operator(&self, p: &Problem) -> Result<DynamicsOperator, ProblemError> {
        let b = &self.bond;
        let (op, correction) = b.operator(p.nodes())?;
        let chain = if p.dim() == 1 && b.material.is_homogeneous() && correction.is_none() {
            let chain = Chain::new(p.lattice()?.spacing(), b.horizon, &b.micromodulus)
                .map_err(|e| ProblemError::invalid("model", e.to_string()))?;
            Some(chain)
        } else {
            None
        };
        Ok(DynamicsOperator { op, chain })
    }
    fn bond_operator(&self, p: &Problem) -> Result<(BondOperator, Option<CorrectionSummary>), ProblemError> {
        self.bond.operator(p.nodes())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}
