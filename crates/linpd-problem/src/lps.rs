//! `"type": "lps"` scenes: the linearized LPS tangent (crates/linpd-lps) with the same volume
//! constraints, loads and solvers as the bond-based model.
//!
//! The model is [`linpd_lps::LpsModel`] as a [`linpd_core::Model`] (its ordering, reach and
//! support graph are documented there); the solve is [`linpd_solve::solve_model`].

use crate::run::append_note;
use crate::{ModelSpec, Problem, ProblemError, Solution};
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_lps::{LpsModel, LpsParams};
use std::time::Instant;

/// From this Poisson ratio on, a CG solve of an LPS scene carries a conditioning warning in
/// its report's `note`: measured on the 3D bar of `data/lps-tension-3d.json` (1701 nodes,
/// delta = 2h) under three loadings, CG with the default rtol 1e-10 against Cholesky
/// (docs/solvers.md, "Near-incompressible LPS"): below 0.499 the error in `u` stays within
/// 4x the residual, at 0.499 it is 12x (a digit lost) and the iterations grow 10x; from 0.4993
/// the true residual stalls above 1e-10 on one loading (an error since CG checks it).
pub const CG_NEAR_INCOMPRESSIBLE_NU: f64 = 0.499;

impl Problem {
    /// The LPS model of an lps scene on its lattice, with the defects of its material and its
    /// surface correction.
    pub fn lps_model(&self) -> Result<LpsModel, ProblemError> {
        self.lps_model_and_correction().map(|(m, _)| m)
    }

    /// [`Problem::lps_model`] and, with a moment-matching surface correction, what it did and
    /// cost (for the solve report).
    pub fn lps_model_and_correction(&self) -> Result<(LpsModel, Option<CorrectionSummary>), ProblemError> {
        let ModelSpec::Lps(params, defects, surface) = &self.model else {
            return Err(ProblemError::invalid(
                "model.type",
                format!("an lps model is needed here, the scene has {}", self.model.name()),
            ));
        };
        let built = match self.nodes.cloud() {
            Some(c) => LpsModel::on_points(c.dim, c.positions.clone(), &c.volumes, params, defects),
            None => LpsModel::with_defects(self.lattice()?, params, defects),
        };
        let model = built.map_err(|e| match e {
            // the usual cause with defects: one passes through the node (the crossing test is
            // closed, so every bond of that node touches it)
            e @ linpd_lps::LpsError::ZeroWeightedVolume { .. } if !defects.is_empty() => ProblemError::invalid(
                "model.material.defects",
                format!(
                    "{e}: a defect through a node cuts all its bonds; place defects between {}",
                    if self.nodes.cloud().is_some() { "nodes" } else { "lattice rows" }
                ),
            ),
            e => ProblemError::invalid("model", e.to_string()),
        })?;
        model
            .corrected_to(surface.correction, surface.target)
            .map_err(|e| ProblemError::invalid("model.surface_correction", e.to_string()))
    }
}

/// Solves an lps scene.
pub(crate) fn solve(p: &Problem, params: &LpsParams, progress: &dyn Progress) -> Result<Solution, ProblemError> {
    let t0 = Instant::now();
    let n = p.nodes.len();
    // a point cloud was checked against memory when the scene was validated
    if let Some(grid) = p.grid() {
        let multigrid = p.solver.uses_multigrid();
        crate::memory::check_solver(crate::memory::Path::LpsAssembled, grid, params.horizon, multigrid)?;
    }
    progress.phase(&format!(
        "building the LPS model: {n} nodes, horizon/spacing = {:.3}",
        params.horizon / crate::problem::NodeSet::spacing(&p.nodes)
    ));
    let (model, correction) = p.lps_model_and_correction()?;
    if let Some(c) = &correction {
        progress.phase(&c.describe());
    }
    progress.phase("the LPS tangent couples nodes up to 2 horizons apart");
    let (u, mut report) = p.timed_solve(&model, t0, progress)?;
    if let Some(c) = correction {
        append_note(&mut report, c.describe());
    }
    let nu = params.poisson_ratio();
    if nu >= CG_NEAR_INCOMPRESSIBLE_NU && matches!(report.solver, linpd_solve::SolverId::Cg { .. }) {
        let note = format!(
            "near-incompressible LPS (nu = {nu}): from nu = {CG_NEAR_INCOMPRESSIBLE_NU} CG was measured to lose a digit \
             against the direct solver at the same residual, to need 10x the iterations and, from nu = 0.4993, to stop \
             above rtol 1e-10 (docs/solvers.md); the cholesky solver is the safer choice"
        );
        progress.phase(&format!("warning: {note}"));
        append_note(&mut report, note);
    }
    Ok(solution(p, &model, u, report))
}

/// The [`Solution`] of an lps scene for displacements `u` over all DOFs (solved here or
/// elsewhere, [`crate::RowSystem`]): balance, strain, dilatation and energy density.
pub(crate) fn solution(p: &Problem, model: &LpsModel, u: Vec<f64>, report: linpd_solve::SolveReport) -> Solution {
    let n = p.nodes.len();
    let balance = p.balance(model, &u);
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
        report,
    }
}
