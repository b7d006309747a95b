//! The one static solve of a built system with the scene's solver ([`Problem::timed_solve`],
//! [`linpd_solve::solve_model`]); [`super::solve_system`] builds the system and makes the
//! solution around it.

use super::Problem;
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_solve::{solve_model, solve_planned, Dirichlet, SolveReport};
use std::time::Instant;

impl Problem {
    /// The one static solve of `model` built since `t0` with prescribed displacements `bc` and
    /// nodal forces `f`: the building time is counted as assembly in the report, and the end is
    /// announced with the residual.
    pub(crate) fn timed_solve(
        &self,
        model: &dyn linpd_core::Model,
        bc: &Dirichlet,
        f: &[f64],
        t0: Instant,
        progress: &dyn Progress,
    ) -> Result<(Vec<f64>, SolveReport), ProblemError> {
        let t_build = t0.elapsed().as_secs_f64();
        let solved = match &self.plan {
            Some(plan) => solve_planned(model, bc, f, plan, progress),
            None => solve_model(model, bc, f, &self.solver, progress),
        };
        let solved = solved.map_err(|e| self.model.static_error(e))?;
        let mut report = solved.report;
        report.timings.assemble += t_build;
        progress.phase(&format!(
            "done in {:.3} s, relative residual {:.2e}",
            t0.elapsed().as_secs_f64(),
            report.rel_residual
        ));
        Ok((solved.u, report))
    }
}
