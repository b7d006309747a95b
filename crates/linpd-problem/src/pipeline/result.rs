//! What a pipeline run reports: every level's outcome ([`LevelResult`]) and the whole run
//! ([`PipelineResult`]); `run` fills them, `output` writes them.

use super::bvp::LevelBvp;
use linpd_coarsen::{EffectiveModuli, StepReport};
use serde::Serialize;

/// One level's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct LevelResult {
    /// Level number m (0 = the scene's model).
    pub level: usize,
    /// Nodes.
    pub nodes: usize,
    /// Bonds (pairs counted from both ends).
    pub bonds: usize,
    /// The coarsening step's report (absent for level 0).
    pub step: Option<StepReport>,
    /// Files written (names inside the output directory).
    pub files: Vec<String>,
    /// Prescribed DOFs of the level's boundary-value problem.
    pub prescribed_dofs: usize,
    /// Total applied force per component (free DOFs).
    pub force: Vec<f64>,
    /// `|sum F^m - sum F^{m-1}| / |sum F^{m-1}|`, the sums before and after the step's transfer
    /// (before the forces on prescribed DOFs are dropped as reactions): what the transfer changed
    /// in the total force; round-off when every neighbourhood is the whole body (the rows of `S`
    /// sum to the identity, (8)).
    pub force_change: f64,
    /// The level's effective elasticity (interior average of `1/2 sum_j v_j C_ij (x) xi (x) xi`,
    /// [`linpd_coarsen::effective_moduli`]); `None` when no node is a reach inside the body.
    pub effective_moduli: Option<EffectiveModuli>,
    /// What a user should know about this level (default radii that took the whole body,
    /// constraints the level could not keep, ...).
    pub notes: Vec<String>,
    /// BVP: max |u^m - u^0| / max |u^0| at the shared nodes.
    pub error_shared: Option<f64>,
    /// BVP: solve seconds.
    pub solve_seconds: Option<f64>,
    /// BVP: the shared nodes' displacements (`d` per node, coarsest-level order).
    #[serde(skip)]
    pub u_shared: Vec<f64>,
    /// BVP: the displacements of every node of the level (`d` per node).
    #[serde(skip)]
    pub u: Vec<f64>,
    /// The level's boundary-value problem.
    #[serde(skip)]
    pub bvp: LevelBvp,
}

/// The whole run.
#[derive(Debug, Clone, Serialize)]
pub struct PipelineResult {
    /// Name.
    pub name: String,
    /// Dimension.
    pub dimension: usize,
    /// Levels 0..=M.
    pub levels: Vec<LevelResult>,
    /// Positions of the shared nodes (the coarsest level's).
    pub shared_x: Vec<[f64; 3]>,
    /// Seconds for all coarsening steps.
    pub seconds_coarsening: f64,
}
