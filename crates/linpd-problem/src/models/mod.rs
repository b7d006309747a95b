//! The models of a scene, one module per model: each owns its `model` keys (a serde struct
//! that denies unknown keys), their validation, its memory estimate, the [`linpd_core::Model`]
//! it builds, the fields of its solution and what the commands may do with it (its
//! [`Capability`]s).
//!
//! | module | scene | builds |
//! |---|---|---|
//! | [`bond`] | `"type": "bond"` (keys; picks one of the next three) | |
//! | [`bond_lattice`] | bond on a grid | [`linpd_bond::LatticeBondModel`] |
//! | [`bond_cloud`] | bond on a point cloud (`"nodes"`) | [`linpd_bond::BondOperator`] |
//! | [`lattice_blend`] | bond with `pd_regions` (2D/3D) | [`linpd_blend::LatticeBlend`] |
//! | [`lps`] | `"type": "lps"` on a grid or a point cloud | [`linpd_lps::LpsModel`] |
//! | [`blend_1d`] | `"type": "blend"` and `"ce"` (1D) | [`linpd_blend::BlendOperator`] |
//! | [`coarsened`] | `"type": "coarsened"` | [`linpd_core::AssembledModel`] |
//!
//! [`registry`] is the one place that maps `model.type` to a module. Every command asks the
//! validated model ([`SceneModel`]) for what it needs and, where the model lacks a
//! [`Capability`], refuses by name ([`crate::ProblemError::Unavailable`]); nothing outside the
//! registry matches on the model type. docs/extending.md says what a new model touches.

pub mod blend_1d;
pub mod bond;
pub mod bond_cloud;
pub mod bond_lattice;
pub mod coarsened;
pub mod lattice_blend;
pub mod lps;
pub mod registry;

use crate::{Problem, ProblemError, Solution};
use linpd_core::progress::Progress;
use linpd_core::Model;
use linpd_solve::{Dirichlet, SolveReport};
use std::any::Any;
use std::fmt::Debug;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

pub use registry::{ModelType, Registry};

/// What a command may do with a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Capability {
    /// `linpd solve` ([`Problem::solve`]).
    StaticSolve,
    /// `"solver": {"type": "cg", "matrix_free": true}`: CG without an assembled matrix.
    MatrixFree,
    /// Rows of `A_ff` on demand ([`Problem::row_system`]): the Python package's rows and the
    /// distributed PETSc solve.
    BlockRows,
    /// `linpd export` ([`Problem::reduced_system`]).
    Export,
    /// The level 0 of `linpd coarsen` ([`crate::level0_model`]).
    Coarsen,
    /// `linpd run` (the `dynamics` section).
    Dynamics,
}

impl Capability {
    /// Every capability, in the order of the docs.
    pub const ALL: [Capability; 6] = [
        Capability::StaticSolve,
        Capability::MatrixFree,
        Capability::BlockRows,
        Capability::Export,
        Capability::Coarsen,
        Capability::Dynamics,
    ];

    /// Its name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Capability::StaticSolve => "the static solve",
            Capability::MatrixFree => "the matrix-free solve",
            Capability::BlockRows => "row-block assembly (the distributed path)",
            Capability::Export => "export",
            Capability::Coarsen => "coarsening",
            Capability::Dynamics => "explicit dynamics",
        }
    }

    /// The scene key a refusal points at when the scene asks for it (`None`: a command asks).
    pub fn key(self) -> Option<&'static str> {
        match self {
            Capability::MatrixFree => Some("solver.matrix_free"),
            Capability::Dynamics => Some("dynamics"),
            _ => None,
        }
    }
}

impl std::fmt::Display for Capability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

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
        nodes: &crate::Nodes,
        constraints: &[crate::Constraint],
        loads: &[crate::Load],
    ) -> Result<(), ProblemError> {
        let _ = (raw, nodes, constraints, loads);
        Ok(())
    }
    /// `None` when the model has `capability`, else why not (a sentence for the user).
    fn lacks(&self, capability: Capability) -> Option<String>;
    /// The line `linpd validate` prints after `valid; `.
    fn summary(&self, p: &Problem) -> String {
        let spacing = crate::problem::NodeSet::spacing(p.nodes());
        format!(
            "{} model, dimension {}, {} nodes, horizon/spacing = {:.4}",
            self.name(),
            p.dim(),
            p.nodes().len(),
            self.horizon().unwrap_or(f64::NAN) / spacing
        )
    }
    /// Files besides the scene that the run reads (a coarsened level's moduli file).
    fn inputs(&self) -> Vec<PathBuf> {
        Vec::new()
    }
    /// Builds the static system (with the memory checks of `purpose`); `progress` gets a
    /// line per phase.
    fn system(&self, p: &Problem, purpose: Purpose, progress: &dyn Progress) -> Result<System, ProblemError>;
    /// The [`Solution`] for displacements `u` over all DOFs of `system` (solved here or
    /// elsewhere: [`crate::RowSystem`]).
    fn solution(
        &self,
        p: &Problem,
        system: &System,
        u: Vec<f64>,
        report: SolveReport,
    ) -> Result<Solution, ProblemError>;
    /// A failed static solve of its system as a scene error.
    fn static_error(&self, e: linpd_solve::StaticError) -> ProblemError {
        crate::run::static_error(e)
    }
    /// Solves the scene ([`solve_system`] unless the model has its own solvers).
    fn solve(&self, p: &Problem, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        solve_system(self, p, progress)
    }
    /// The assembled stiffness over all DOFs that level 0 of a coarsening pipeline starts
    /// from ([`Capability::Coarsen`]).
    fn level0_stiffness(&self, p: &Problem) -> Result<linpd_core::Csc, ProblemError> {
        let _ = p;
        Err(refusal(self, Capability::Coarsen))
    }
    /// The bond operator that explicit dynamics steps ([`Capability::Dynamics`]).
    fn dynamics_operator(&self, p: &Problem) -> Result<linpd_bond::BondOperator, ProblemError> {
        let _ = p;
        Err(refusal(self, Capability::Dynamics))
    }
    /// The bond model's parameters, when the model is a bond-based one (dynamics reads its
    /// micromodulus for the chain's stability limit).
    fn bond(&self) -> Option<&bond::BondModel> {
        None
    }
    /// As its concrete type (`p.model().as_any().downcast_ref::<CoarsenedModel>()`).
    fn as_any(&self) -> &dyn Any;
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
    for note in &system.notes {
        crate::run::append_note(&mut report, note.clone());
    }
    model.solution(p, &system, u, report)
}
