//! The interface every model of a scene implements ([`SceneModel`]) and the static system it
//! builds for a command ([`System`]). The models themselves are in [`crate::models`].

use super::Problem;
use crate::capability::Capability;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_bond::BondOperator;
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_core::Model;
use linpd_solve::{Dirichlet, SolveReport, StaticError};
use std::any::Any;
use std::fmt::Debug;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// The static system a model builds for a command: the operator `A` over all DOFs, the
/// prescribed displacements and the nodal forces, `A u = f` with `u = u_bar` on the held DOFs.
pub struct System {
    /// The operator (and, for the model's own use, its concrete type: [`Built::as_any`]).
    pub model: Arc<dyn Built>,
    /// Held DOFs and their values.
    pub bc: Dirichlet,
    /// Nodal forces over all DOFs.
    pub f: Vec<f64>,
    /// Bonds as `linpd solve` reports them (each pair from both ends, cut ones included).
    pub n_bonds: usize,
    /// What the solve report's note adds (a surface correction, the blend's zones, ...).
    pub notes: Vec<String>,
    /// Seconds spent building the model before [`SceneModel::system`] was called (a level
    /// read at validation): counted as assembly.
    pub built_before: f64,
    /// The memory guard's estimate of the peak bytes of this model's path (`None` where no
    /// estimate is made: 1D blends, coarsened levels, rows); reported next to the measured peak.
    pub memory_estimate: Option<f64>,
}

impl System {
    /// The operator.
    pub fn model(&self) -> &dyn Model {
        self.model.model()
    }
}

/// A [`Model`] that can be handed back to the scene model that built it (by its concrete type).
pub trait Built: Send + Sync {
    /// As a model.
    fn model(&self) -> &dyn Model;
    /// As its concrete type.
    fn as_any(&self) -> &dyn Any;
}

impl<T: Model + Send + Sync + 'static> Built for T {
    fn model(&self) -> &dyn Model {
        self
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// What explicit dynamics steps: the bond operator and, where its stability limit is known
/// exactly, the infinite chain of the same bonds.
pub struct DynamicsOperator {
    /// The operator `A` of `M u'' = -A u + f`.
    pub op: BondOperator,
    /// The infinite 1D chain whose `2 / omega_max` is the stable time step (a homogeneous,
    /// uncorrected bar); `None`: the limit is found by power iteration on `op`.
    pub chain: Option<linpd_dynamics::Chain>,
}

/// What the system is built for: the memory a model checks before building it depends on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// A static solve with the scene's solver.
    Solve,
    /// The assembled reduced system (`linpd export`, the level 0 of `linpd coarsen`).
    Assembled,
    /// Rows on demand (nothing is assembled whole).
    Rows,
}

/// A validated model of a scene (see the module docs).
pub trait SceneModel: Debug + Send + Sync {
    /// `model.type` as written in the scene (`"bond"`, `"ce"`, ...).
    fn name(&self) -> &'static str;
    /// What it is, in messages: the type and, where the type has several, which
    /// (`"bond (point cloud)"`).
    fn describe(&self) -> String {
        self.name().to_string()
    }
    /// The horizon `delta` (`None`: a coarsened level, whose reach varies per node).
    fn horizon(&self) -> Option<f64>;
    /// Takes the scene's validated constraints and loads on its `nodes` (a model that
    /// translates them and the solver into its own terms, the 1D blend, checks them here; `raw`
    /// is the scene).
    fn bind(
        &mut self,
        raw: &crate::raw::RawProblem,
        nodes: &crate::nodes::Nodes,
        constraints: &[super::Constraint],
        loads: &[super::Load],
    ) -> Result<(), ProblemError> {
        let _ = (raw, nodes, constraints, loads);
        Ok(())
    }
    /// `None` when the model has `capability`, else why not (a sentence for the user).
    fn lacks(&self, capability: Capability) -> Option<String>;
    /// What the model offers the solvers on the scene's nodes (`p`'s constraints and loads may
    /// not be evaluated yet) when the solve has `unknowns` free DOFs: the scene's solver plan is
    /// made from it once ([`Problem::plan`], [`linpd_solve::plan()`]) and the memory guard and the
    /// solve read that plan. `None` (the default): the model's unknowns are known only once it
    /// is built (the masters of a graded mesh) or it has its own solvers (the 1D blend), or it
    /// offers nothing beyond an assembled `A` (a coarsened level); its solve plans from the built
    /// model ([`linpd_solve::solve_model`]).
    fn offers(&self, p: &Problem, unknowns: usize) -> Option<linpd_solve::Offers> {
        let _ = (p, unknowns);
        None
    }
    /// The line `linpd validate` prints after `valid; `.
    fn summary(&self, p: &Problem) -> String {
        let head = format!("{} model, dimension {}, {} nodes", self.name(), p.dim(), p.nodes().len());
        let Some(horizon) = self.horizon() else { return head };
        // a point cloud's ratio is to its mean spacing (its node spacing is the smallest one)
        match p.nodes().cloud() {
            Some(c) => {
                let h = crate::cloud::mean_spacing(&c.volumes, c.dim);
                format!("{head}, horizon/mean spacing = {:.4}", horizon / h)
            }
            None => format!("{head}, horizon/spacing = {:.4}", horizon / crate::nodes::NodeSet::spacing(p.nodes())),
        }
    }
    /// Files besides the scene that the run reads (a coarsened level's moduli file).
    fn inputs(&self) -> Vec<PathBuf> {
        Vec::new()
    }
    /// Builds the static system (with the memory checks of `purpose`); `progress` gets a
    /// line per phase.
    fn system(&self, p: &Problem, purpose: Purpose, progress: &dyn Progress) -> Result<System, ProblemError>;
    /// The [`Solution`] for displacements `u` over all DOFs of `system` (solved here or
    /// elsewhere: `linpd_problem::RowSystem`).
    fn solution(
        &self,
        p: &Problem,
        system: &System,
        u: Vec<f64>,
        report: SolveReport,
    ) -> Result<Solution, ProblemError>;
    /// A failed static solve of its system as a scene error.
    fn static_error(&self, e: linpd_solve::StaticError) -> ProblemError {
        static_error(e)
    }
    /// `E, nu, K, G` of its materials (`result.json`'s `material`, [`crate::elastic`]); none
    /// for a model whose moduli are not isotropic constants (a coarsened level).
    fn elastic_constants(&self) -> Vec<crate::elastic::PhaseConstants> {
        Vec::new()
    }
    /// The plane model and `(E, nu)` of the nodes at `x` (`nu` `None` in 1D) for the Hooke
    /// stress ([`crate::stress::hooke`]); `None`: no stress (the default).
    fn node_elastic(&self, p: &Problem, x: &[linpd_core::Point]) -> Option<NodeElastic> {
        let _ = (p, x);
        None
    }
    /// Solves the scene ([`super::solve_system`] unless the model has its own solvers).
    fn solve(&self, p: &Problem, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        solve_system(self, p, progress)
    }
    /// The assembled stiffness over all DOFs that level 0 of a coarsening pipeline starts
    /// from ([`Capability::Coarsen`]).
    fn level0_stiffness(&self, p: &Problem) -> Result<linpd_core::Csc, ProblemError> {
        let _ = p;
        Err(refusal(self, Capability::Coarsen))
    }
    /// What explicit dynamics steps ([`Capability::Dynamics`]).
    fn dynamics_operator(&self, p: &Problem) -> Result<DynamicsOperator, ProblemError> {
        let _ = p;
        Err(refusal(self, Capability::Dynamics))
    }
    /// The bond operator of a bond-based model on the scene's nodes, with its surface
    /// correction, and what the correction did and cost ([`Problem::operator`]).
    fn bond_operator(&self, p: &Problem) -> Result<(BondOperator, Option<CorrectionSummary>), ProblemError> {
        let _ = p;
        Err(ProblemError::invalid(
            "model.type",
            format!("a bond model is needed here, the scene has {}", self.describe()),
        ))
    }
    /// As its concrete type (`p.model().as_any().downcast_ref::<CoarsenedModel>()`).
    fn as_any(&self) -> &dyn Any;
}

/// The plane model (2D) and `(E, nu)` per node ([`SceneModel::node_elastic`]).
pub type NodeElastic = (Option<linpd_core::PlaneModel>, Vec<(f64, Option<f64>)>);

/// The error of a [`SceneModel::solution`] handed a system another model built (a
/// `linpd_problem::RowSystem` of another scene).
pub fn foreign_system(model: &str) -> ProblemError {
    ProblemError::invalid("rows", format!("the system was not built by this scene's {model} model"))
}

/// The typed refusal of `capability` by `model` (the scene key it points at, the model, the
/// capability and why).
pub fn refusal(model: &(impl SceneModel + ?Sized), capability: Capability) -> ProblemError {
    ProblemError::Unavailable {
        path: capability.key().unwrap_or("model.type").to_string(),
        model: model.describe(),
        capability,
        reason: model.lacks(capability).unwrap_or_else(|| "not implemented".into()),
    }
}

impl dyn SceneModel + '_ {
    /// `Ok` when the model has `capability`, else its typed refusal.
    pub fn require(&self, capability: Capability) -> Result<(), ProblemError> {
        match self.lacks(capability) {
            None => Ok(()),
            Some(_) => Err(refusal(self, capability)),
        }
    }

    /// Whether the model has `capability`.
    pub fn can(&self, capability: Capability) -> bool {
        self.lacks(capability).is_none()
    }

    /// The model as `T`, if it is one.
    pub fn downcast<T: 'static>(&self) -> Option<&T> {
        self.as_any().downcast_ref()
    }
}

/// The static solve every model shares: build the system, solve it with the scene's solver
/// ([`linpd_solve::solve_model`]: support check, Dirichlet elimination, report), count the
/// building time as assembly, add the model's notes, and make the solution.
pub fn solve_system(
    model: &(impl SceneModel + ?Sized),
    p: &Problem,
    progress: &dyn Progress,
) -> Result<Solution, ProblemError> {
    let t0 = Instant::now();
    let system = model.system(p, Purpose::Solve, progress)?;
    for note in &system.notes {
        progress.phase(note);
    }
    let (u, mut report) = p.timed_solve(system.model(), &system.bc, &system.f, t0, progress)?;
    report.timings.assemble += system.built_before;
    report.memory_estimate_bytes = system.memory_estimate.map(|e| e + report.factor_bytes.unwrap_or(0.0));
    for note in &system.notes {
        report.notes.push(note.clone());
    }
    model.solution(p, &system, u, report)
}

/// A failed static solve as a scene error.
pub(crate) fn static_error(e: StaticError) -> ProblemError {
    match e {
        StaticError::NothingFree => ProblemError::invalid("constraints", "every DOF is constrained: nothing to solve"),
        e @ StaticError::Unsupported { .. } => ProblemError::Unsupported(e),
        e @ StaticError::MatrixFreeUnavailable { .. } => ProblemError::invalid("solver.matrix_free", e.to_string()),
        other => ProblemError::Static(other),
    }
}
