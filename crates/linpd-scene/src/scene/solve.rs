//! The static solve every model shares ([`solve_system`]): build the system, solve it with the
//! scene's solver ([`linpd_solve::solve_model`]), make the solution.

use super::model::{Purpose, SceneModel};
use super::Problem;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_solve::{solve_model, Dirichlet, SolveReport, StaticError};
use std::time::Instant;

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
        let solved = solve_model(model, bc, f, &self.solver, progress).map_err(|e| self.model.static_error(e))?;
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

/// A failed static solve as a scene error.
pub(crate) fn static_error(e: StaticError) -> ProblemError {
    match e {
        StaticError::NothingFree => ProblemError::invalid("constraints", "every DOF is constrained: nothing to solve"),
        e @ StaticError::Unsupported { .. } => ProblemError::Unsupported(e),
        e @ StaticError::MatrixFreeUnavailable { .. } => ProblemError::invalid("solver.matrix_free", e.to_string()),
        other => ProblemError::Static(other),
    }
}
