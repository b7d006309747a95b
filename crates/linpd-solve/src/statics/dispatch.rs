//! A model's reduced system to the runner its plan names ([`crate::plan`]): matrix-free CG,
//! `auto`'s matrix-free multigrid-CG (assembled and chosen again if CG stalls) or GMRES, else
//! assembled ([`assemble_checked`]) and solved by [`solve_assembled_with_progress`] with the
//! hints the model provides.

use super::assembled::{solve_assembled_with_progress, MatrixHints};
use super::auto::AutoParams;
use super::error::StaticError;
use super::guards::{finite_matrix, finite_vector, REDUCED_LOAD};
use super::runners::{matrix_free_cg, matrix_free_gmres, Solved};
use crate::cost;
use crate::krylov::cg::{CgError, CgParams};
use crate::plan::{offers_companion_gmres, offers_matrix_free_cg, Route, SolvePlan};
use crate::precond::DofGeometry;
use crate::spec::{PreconditionerKind, SolverSpec};
use crate::SolveError;
use linpd_core::progress::Progress;
use linpd_core::sparse::{Csc, SYMMETRY_RTOL};
use linpd_core::{DofMap, Model};
use std::time::Instant;

/// The reduced system `A_ff u_f = rhs` of a model, before the solver is chosen.
pub(super) struct ModelSystem<'a> {
    /// The model.
    pub model: &'a dyn Model,
    /// Its free DOFs.
    pub dofs: &'a DofMap,
    /// `f_f - (A u_bar)_f`.
    pub rhs: &'a [f64],
    /// `max |A - A^T| / max |A|` of the model's `A_ff`.
    pub asymmetry: f64,
}

impl ModelSystem<'_> {
    /// A solver's error as a [`StaticError`], naming the node and component of the free DOF
    /// where a factorization failed ([`Model::describe_node`]).
    fn at_dof(&self, e: SolveError) -> StaticError {
        at_free_dof(self.model, self.dofs, e)
    }
}

/// A solver's error as a [`StaticError`], naming the node and component of the free DOF where
/// a factorization failed or a diagonal entry is zero ([`Model::describe_node`]).
pub(super) fn at_free_dof(model: &dyn Model, dofs: &DofMap, e: SolveError) -> StaticError {
    let d = model.dim();
    match e {
        SolveError::NotPositiveDefinite { dof }
        | SolveError::Singular { dof }
        | SolveError::ZeroDiagonal { dof, .. }
            if dof < dofs.n_free() =>
        {
            let full = dofs.free_dofs()[dof];
            StaticError::AtDof { at: format!("{}, component {}", model.describe_node(full / d), full % d), source: e }
        }
        other => StaticError::Solve(other),
    }
}

/// Solves `system` by `plan` ([`crate::plan`]): the user's matrix-free CG (refused for a model
/// that cannot run matrix-free or an unsymmetric operator), `auto`'s matrix-free multigrid-CG or
/// GMRES, else assembled. A matrix-free route of `auto` that the built model does not offer
/// (its plan was made from what its scene declared) runs assembled, with a note.
pub(super) fn solve_system(
    system: &ModelSystem,
    plan: &SolvePlan,
    progress: &dyn Progress,
) -> Result<Solved, StaticError> {
    let (model, dofs) = (system.model, system.dofs);
    let spec = &plan.spec;
    Ok(match (plan.route, spec) {
        (Route::MatrixFreeCg(preconditioner), SolverSpec::Cg { params, .. }) => {
            if let Some(why) = model.matrix_free_unavailable() {
                return Err(StaticError::MatrixFreeUnavailable { kind: model.kind(), why });
            }
            if system.asymmetry > SYMMETRY_RTOL {
                return Err(StaticError::UnsymmetricForCg { kind: model.kind(), asymmetry: system.asymmetry });
            }
            matrix_free_cg(model, dofs, system.rhs, params, preconditioner, progress).map_err(|e| system.at_dof(e))?
        }
        // what the scene declared, checked on the built model once
        (Route::AutoMatrixFreeCg, SolverSpec::Auto(params))
            if system.asymmetry <= SYMMETRY_RTOL && offers_matrix_free_cg(model) =>
        {
            auto_matrix_free(system, spec, params, progress)?
        }
        (Route::AutoMatrixFreeGmres, SolverSpec::Auto(params)) if offers_companion_gmres(model) => {
            auto_matrix_free_gmres(system, spec, params, progress)?
        }
        (Route::Assembled, _) => assembled_solve(system, spec, progress)?,
        (route, _) => {
            let (u, mut report) = assembled_solve(system, spec, progress)?;
            report.notes.insert(
                0,
                format!("planned {route}, which the built {} model does not offer: assembled", model.kind()),
            );
            (u, report)
        }
    })
}

/// `auto`'s matrix-free GMRES + multigrid from the companion; when GMRES fails (stagnation,
/// `max_iter`), the assembled plan (the factor of `M`, GMRES + Jacobi, sparse LU) where its
/// assembly is affordable: in 2D, or up to [`AutoParams::cholesky_3d_max_unknowns`] in 3D (the
/// memory was checked for the matrix-free path only; past that the error stands).
fn auto_matrix_free_gmres(
    system: &ModelSystem,
    spec: &SolverSpec,
    params: &CgParams,
    progress: &dyn Progress,
) -> Result<Solved, StaticError> {
    let (model, dofs) = (system.model, system.dofs);
    let auto = AutoParams::default();
    let why = format!(
        "the model is unsymmetric and applies A matrix-free with an SPD companion's block rows ({}D, {} >= {} \
         unknowns): GMRES + multigrid from the companion, neither stored whole",
        model.dim(),
        dofs.n_free(),
        auto.gmres_multigrid_2d_min_unknowns
    );
    let t = Instant::now();
    match matrix_free_gmres(model, dofs, system.rhs, params, progress) {
        Ok((u, mut report)) => {
            report.auto = Some(why);
            Ok((u, report))
        }
        Err(SolveError::Gmres { source, .. }) if model.dim() == 2 || dofs.n_free() <= auto.cholesky_3d_max_unknowns => {
            let attempt = t.elapsed().as_secs_f64();
            let (u, mut report) = assembled_solve(system, spec, progress)?;
            report.notes.insert(
                0,
                format!(
                    "auto: matrix-free GMRES + multigrid failed ({source}; {attempt:.3} s, counted in the solver's \
                     total); assembled and chose again"
                ),
            );
            report.timings.total += attempt;
            Ok((u, report))
        }
        Err(e) => Err(system.at_dof(e)),
    }
}

/// `auto`'s matrix-free multigrid-CG; when CG stalls above `rtol`, the assembled choice.
fn auto_matrix_free(
    system: &ModelSystem,
    spec: &SolverSpec,
    params: &CgParams,
    progress: &dyn Progress,
) -> Result<Solved, StaticError> {
    let why = "the model applies A by a stencil and computes its block rows (a bond or LPS lattice): \
               matrix-free multigrid-CG, no assembly (the fastest solver at every size of \
               docs/solvers.md's bench)";
    let t = Instant::now();
    match matrix_free_cg(system.model, system.dofs, system.rhs, params, PreconditionerKind::MULTIGRID, progress) {
        Ok((u, mut report)) => {
            report.auto = Some(why.into());
            Ok((u, report))
        }
        // As the assembled `auto` does when CG stalls above rtol (rounding): the
        // assembled choice, which can fall back to a direct solve. Not for a model solved on
        // its companion's hierarchy (the LPS tangent): its assembly couples two horizons and
        // was never checked against the memory (the scene checked the matrix-free path), so
        // the error stands.
        Err(SolveError::Cg(e @ CgError::ResidualAboveTarget { .. }))
            if system.model.multigrid_companion().is_none() =>
        {
            let attempt = t.elapsed().as_secs_f64();
            let (u, mut report) = assembled_solve(system, spec, progress)?;
            report.notes.insert(
                0,
                format!(
                    "auto: matrix-free multigrid-CG failed ({e}; {attempt:.3} s, counted in the solver's \
                     total); assembled and chose again"
                ),
            );
            // the failed attempt is solver time, not assembly
            report.timings.total += attempt;
            Ok((u, report))
        }
        Err(e) => Err(system.at_dof(e)),
    }
}

/// `A_ff` assembled ([`Model::assemble_free_with_progress`]), checked finite together with the
/// reduced right-hand side `rhs`.
pub(super) fn assemble_checked(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    progress: &dyn Progress,
) -> Result<Csc, StaticError> {
    let a = model.assemble_free_with_progress(dofs, progress);
    finite_matrix(&a)?;
    finite_vector(REDUCED_LOAD, rhs)?;
    Ok(a)
}

/// Assembles `A_ff` and solves it with [`solve_assembled_with_progress`] (the DOF geometry,
/// ordering and SPD approximation the spec may use taken from the model).
fn assembled_solve(system: &ModelSystem, spec: &SolverSpec, progress: &dyn Progress) -> Result<Solved, StaticError> {
    let (model, dofs, asymmetry) = (system.model, system.dofs, system.asymmetry);
    let d = model.dim();
    progress.phase(&format!("assembling: {} free DOFs", dofs.n_free()));
    let t = Instant::now();
    let a = assemble_checked(model, dofs, system.rhs, progress)?;
    let t_asm = t.elapsed().as_secs_f64();
    let spd = match spec {
        SolverSpec::Auto(_) | SolverSpec::Gmres { .. } if asymmetry > SYMMETRY_RTOL => model.spd_approximation(dofs),
        _ => None,
    };
    let n_side = match spec {
        // The free body's extent: nodes with at least one free DOF.
        SolverSpec::Auto(_) if d >= 2 => Some(cost::nodes_along_longest_side(
            d,
            (0..model.n_nodes())
                .filter(|&i| (0..d).any(|c| !dofs.is_constrained(d * i + c)))
                .map(|i| model.position(i)),
        )),
        _ => None,
    };
    // Only multilevel preconditioners read the geometry: build it when one may run.
    let geometry = match spec {
        SolverSpec::Cg { preconditioner, .. } | SolverSpec::Gmres { preconditioner, .. }
            if preconditioner.multilevel() =>
        {
            Some(DofGeometry::of(model, dofs))
        }
        SolverSpec::Auto(_) if d >= 2 => Some(DofGeometry::of(model, dofs)),
        _ => None,
    };
    let hints = MatrixHints { dim: d, asymmetry, ordering: model.ordering(dofs), spd, geometry, n_side };
    progress.phase(&format!(
        "solving: {} unknowns, {} stored entries, solver {}",
        a.nrows(),
        a.val().len(),
        spec.resolve(d, a.nrows())
    ));
    let (u, report) =
        solve_assembled_with_progress(&a, system.rhs, spec, &hints, progress).map_err(|e| system.at_dof(e))?;
    progress.phase(&format!("assembled in {t_asm:.3} s"));
    Ok((u, report))
}
