//! The commands as methods of a [`Problem`] (`use linpd_problem::Commands`): each delegates to
//! its module, where it is written once against the scene's model interface.

use crate::dynamics_run::{DynamicsRun, StabilityLimit};
use crate::export::ReducedSystem;
use crate::rows::RowSystem;
use linpd_core::progress::Progress;
use linpd_scene::{Problem, ProblemError, Solution};
use linpd_solve::SolveReport;

/// What the commands of linpd do with a validated scene.
pub trait Commands {
    /// The reduced system the static solve factors or iterates ([`crate::export`]).
    fn reduced_system(&self, progress: &dyn Progress) -> Result<ReducedSystem, ProblemError>;
    /// The model and reduced right-hand side for row-block assembly ([`crate::rows`]).
    fn row_system(&self) -> Result<RowSystem, ProblemError>;
    /// The solution `linpd solve` would write for `u` computed elsewhere ([`crate::rows`]).
    fn solution_from(&self, system: &RowSystem, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError>;
    /// Runs the `dynamics` section ([`crate::dynamics_run`]).
    fn run_dynamics(&self, progress: &dyn Progress) -> Result<DynamicsRun, ProblemError>;
    /// The velocity-Verlet stability limit of the scene ([`crate::dynamics_run`]).
    fn stability_limit(&self) -> Result<StabilityLimit, ProblemError>;
}

impl Commands for Problem {
    fn reduced_system(&self, progress: &dyn Progress) -> Result<ReducedSystem, ProblemError> {
        crate::export::reduced_system(self, progress)
    }
    fn row_system(&self) -> Result<RowSystem, ProblemError> {
        crate::rows::row_system(self)
    }
    fn solution_from(&self, system: &RowSystem, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        crate::rows::solution_from(self, system, u, report)
    }
    fn run_dynamics(&self, progress: &dyn Progress) -> Result<DynamicsRun, ProblemError> {
        crate::dynamics_run::run_dynamics(self, progress)
    }
    fn stability_limit(&self) -> Result<StabilityLimit, ProblemError> {
        crate::dynamics_run::stability_limit(self)
    }
}
