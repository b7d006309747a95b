//! The orchestration of a static solve of a model ([`solve_model`], see [`super`]) and the
//! reduced system it hands a solver, for callers that solve it themselves ([`reduced_system`],
//! [`reduced_rhs_checked`]).

use super::auto::AutoParams;
use super::dispatch::at_free_dof;
use super::dispatch::{assemble_checked, solve_system, ModelSystem};
use super::error::StaticError;
use super::guards::{check_static, finite_vector, nonzero_diagonal, REDUCED_LOAD};
use crate::bc::Dirichlet;
use crate::plan::{Offers, SolvePlan};
use crate::report::SolveReport;
use crate::spec::SolverSpec;
use linpd_core::progress::Progress;
use linpd_core::sparse::Csc;
use linpd_core::{Model, ModelOperator};
use std::time::Instant;

/// Displacements over all DOFs and the report of their solve.
#[derive(Debug, Clone)]
pub struct StaticSolution {
    /// `u` over all DOFs (`d` per node, node-major).
    pub u: Vec<f64>,
    /// Accuracy and cost (`timings.assemble` covers the right-hand side and the assembly).
    pub report: SolveReport,
}

/// Solves `A u = f` for `model` with the prescribed displacements of `bc` (see the module
/// docs). `progress` receives one line per phase and the tasks of the assembly
/// ([`Model::assemble_free_with_progress`]) and of the solver
/// ([`super::solve_assembled_with_progress`]).
pub fn solve_model(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    spec: &SolverSpec,
    progress: &dyn Progress,
) -> Result<StaticSolution, StaticError> {
    solve_with(model, bc, f, Plan::FromModel(spec), progress)
}

/// [`solve_model`] by a plan made before the model was built ([`crate::plan::plan`], from the
/// offers a scene's model declared): the solve runs what the plan names and what the memory
/// guard counted.
pub fn solve_planned(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    plan: &SolvePlan,
    progress: &dyn Progress,
) -> Result<StaticSolution, StaticError> {
    solve_with(model, bc, f, Plan::Given(plan), progress)
}

/// What the built `model` offers, read off it only where `spec` may use it: `auto` at a size
/// where a matrix-free route can be taken (building a fast apply, an LPS stencil say, costs a
/// pass over the model); otherwise an assembled-only model of the same size and symmetry, which
/// plans the same.
fn offers_for(
    spec: &SolverSpec,
    auto: &AutoParams,
    model: &dyn Model,
    dofs: &linpd_core::DofMap,
    asymmetry: f64,
) -> Offers {
    let threshold = auto.matrix_free_min_unknowns.min(auto.gmres_multigrid_2d_min_unknowns);
    if matches!(spec, SolverSpec::Auto(_)) && model.dim() >= 2 && dofs.n_free() >= threshold {
        return Offers::of_model(model, dofs, asymmetry);
    }
    let symmetric = asymmetry <= linpd_core::sparse::SYMMETRY_RTOL;
    Offers { dim: model.dim(), unknowns: dofs.n_free(), symmetric, fast_apply: false, companion_gmres: false }
}

/// A given plan, or one to make from the built model.
enum Plan<'a> {
    Given(&'a SolvePlan),
    FromModel(&'a SolverSpec),
}

fn solve_with(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    plan: Plan,
    progress: &dyn Progress,
) -> Result<StaticSolution, StaticError> {
    let dofs = bc.dofs();
    check_static(model, bc, f)?;
    let t0 = Instant::now();
    // Checked once the operator is known to be finite (an infinite A makes it NaN too).
    let rhs = bc.reduced_rhs(&ModelOperator(model), f);
    let system = ModelSystem { model, dofs, rhs: &rhs, asymmetry: model.asymmetry(dofs) };
    let made;
    let plan = match plan {
        Plan::Given(p) => p,
        Plan::FromModel(spec) => {
            let auto = AutoParams::default();
            made = crate::plan::plan(spec, &offers_for(spec, &auto, model, dofs, system.asymmetry), &auto);
            &made
        }
    };
    let (u_free, mut report) = solve_system(&system, plan, progress)?;
    // Everything outside the solver proper: the right-hand side, the assembly, the diagonal.
    report.timings.assemble = t0.elapsed().as_secs_f64() - report.timings.total;
    let u = bc.expand(&u_free);
    finite_vector("the solution", &u)?;
    Ok(StaticSolution { u, report })
}

/// The reduced system `A_ff u_f = f_f - (A u_bar)_f` that [`solve_model`] hands an assembled
/// solver, with the same checks and errors, not solved: `(A_ff, rhs)`, rows and columns
/// numbered as the free DOFs of `bc.dofs()` ([`linpd_core::DofMap::free_dofs`]). A
/// matrix-free CG applies the same `A_ff` without assembling it.
pub fn reduced_system(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    progress: &dyn Progress,
) -> Result<(Csc, Vec<f64>), StaticError> {
    check_static(model, bc, f)?;
    let rhs = bc.reduced_rhs(&ModelOperator(model), f);
    progress.phase(&format!("assembling: {} free DOFs", bc.dofs().n_free()));
    let a = assemble_checked(model, bc.dofs(), &rhs, progress)?;
    Ok((a, rhs))
}

/// The reduced right-hand side `f_f - (A u_bar)_f` of [`reduced_system`], with its checks
/// (something free, the support check, finite loads and result) but without assembling
/// `A_ff`: for callers that assemble `A_ff` themselves a block of rows at a time (the
/// distributed path of the Python package), so that the errors are those of a solve.
///
/// It also refuses a free DOF whose diagonal entry of `A_ff` is zero (nothing holds it: the
/// out-of-plane motion of a plate one node thick), which [`solve_model`] finds when it
/// factorizes but an iterative solver on the rows (PETSc's CG) may not: it would converge on a
/// load orthogonal to that motion, or report a residual of 1e17.
pub fn reduced_rhs_checked(model: &dyn Model, bc: &Dirichlet, f: &[f64]) -> Result<Vec<f64>, StaticError> {
    check_static(model, bc, f)?;
    rhs_of_rows(model, bc, f, 0..bc.dofs().n_free())
}

/// [`reduced_rhs_checked`] of the free DOFs `rows` (in the free numbering) only, for one rank's
/// window of a distributed scene: the diagonal and the right-hand side of those rows, without
/// the support check (a window's own constraints need not hold it; the ranks check the support
/// together).
pub fn reduced_rhs_of_rows(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    rows: std::ops::Range<usize>,
) -> Result<Vec<f64>, StaticError> {
    finite_vector("the load vector", f)?;
    rhs_of_rows(model, bc, f, rows)
}

fn rhs_of_rows(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    rows: std::ops::Range<usize>,
) -> Result<Vec<f64>, StaticError> {
    let dofs = bc.dofs();
    let diag = &dofs.gather(&model.diagonal())[rows.clone()];
    finite_vector("the stiffness (its diagonal over the free DOFs)", diag)?;
    let spd = model.asymmetry(dofs) <= linpd_core::sparse::SYMMETRY_RTOL;
    nonzero_diagonal("the row system", diag, spd).map_err(|e| match e {
        crate::SolveError::ZeroDiagonal { solver, dof, value } => {
            at_free_dof(model, dofs, crate::SolveError::ZeroDiagonal { solver, dof: dof + rows.start, value })
        }
        other => StaticError::Solve(other),
    })?;
    let rhs = bc.reduced_rhs(&ModelOperator(model), f)[rows].to_vec();
    finite_vector(REDUCED_LOAD, &rhs)?;
    Ok(rhs)
}
