//! `"type": "lps"` scenes: the linearized LPS tangent (crates/linpd-lps) with the same volume
//! constraints, loads and solvers as the bond-based model.
//!
//! The model is [`linpd_lps::LpsModel`] as a [`linpd_core::Model`] (its ordering, reach and
//! support graph are documented there); the solve is [`linpd_solve::solve_model`].

use crate::run::static_error;
use crate::{Problem, ProblemError, Solution};
use linpd_lps::{LpsModel, LpsParams};
use linpd_solve::solve_model;
use std::time::Instant;

/// Solves an lps scene.
pub(crate) fn solve(p: &Problem, params: &LpsParams, progress: &dyn Fn(&str)) -> Result<Solution, ProblemError> {
    let t0 = Instant::now();
    let grid = p.lattice()?;
    progress(&format!(
        "building the LPS model: {} nodes, horizon/spacing = {:.3}",
        grid.len(),
        params.horizon / grid.spacing()
    ));
    let model = LpsModel::new(grid, params).map_err(|e| ProblemError::invalid("model", e.to_string()))?;
    let t_build = t0.elapsed().as_secs_f64();
    progress("the LPS tangent couples nodes up to 2 horizons apart");
    let solved = solve_model(&model, &p.dirichlet(), &p.load_vector(), &p.solver, progress).map_err(static_error)?;
    let mut report = solved.report;
    report.timings.assemble += t_build;
    progress(&format!("done in {:.3} s, relative residual {:.2e}", t0.elapsed().as_secs_f64(), report.rel_residual));
    Ok(Solution {
        name: p.name.clone(),
        dim: p.dim(),
        x: model.positions(),
        u: solved.u,
        is_layer: (0..grid.len()).map(|n| grid.is_layer(n)).collect(),
        n_bonds: model.family().n_bonds(),
        report,
    })
}
