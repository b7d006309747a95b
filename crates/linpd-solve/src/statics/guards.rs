//! The checks around a static solve: something free and no rigid motion left free
//! ([`check_static`]), finite inputs and outputs ([`finite_matrix`], [`finite_vector`]), a
//! factor that fits in memory ([`factor_fits`]), and the residual of a finished solve
//! ([`check_residual`]: finite, and below [`DIRECT_RESIDUAL_LIMIT`] for a direct solver).

use super::error::StaticError;
use crate::bc::Dirichlet;
use crate::cost;
use crate::direct::{Cholesky, DIRECT_RESIDUAL_LIMIT};
use crate::report::SolveReport;
use crate::spec::SolverId;
use crate::SolveError;
use linpd_core::sparse::Csc;
use linpd_core::{check_support, Model};

/// What the reduced right-hand side is called in messages: finite loads can still overflow
/// in `f_f - (A u_bar)_f` (prescribed displacements of 1e300).
pub(super) const REDUCED_LOAD: &str = "the load vector f - A u_bar (loads and prescribed displacements)";

/// `Err` naming the stiffness and its first NaN or infinite stored entry (an overflow of the
/// moduli or volumes: a factorization would call it "not positive definite").
pub fn finite_matrix(a: &Csc) -> Result<(), SolveError> {
    let Some(k) = a.val().iter().position(|v| !v.is_finite()) else { return Ok(()) };
    let col = a.symbolic().col_ptr().partition_point(|&p| p <= k) - 1;
    let row = a.symbolic().row_idx()[k];
    Err(SolveError::NonFinite {
        what: "the stiffness",
        at: format!("first at entry ({row}, {col}) = {:e}", a.val()[k]),
    })
}

/// `Err` naming `what` when an entry is NaN or infinite, or when its squared 2-norm overflows
/// (entries near 1e308: every residual norm would then be `inf / inf = NaN`).
pub fn finite_vector(what: &'static str, v: &[f64]) -> Result<(), SolveError> {
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(SolveError::NonFinite { what, at: format!("first at DOF {k} = {:e}", v[k]) });
    }
    let sq: f64 = v.iter().map(|x| x * x).sum();
    if !sq.is_finite() {
        let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        return Err(SolveError::NonFinite { what, at: format!("its squared norm overflows, entries up to {max:e}") });
    }
    Ok(())
}

/// `Err(SolveError::ZeroDiagonal)` at the first free DOF whose diagonal entry `diag[k]` is zero
/// relative to the largest (`|a_kk| <= 1e-14 max |a_ii|`), or negative or NaN when `spd` (a
/// symmetric operator): nothing holds that DOF (a mechanism, e.g. the out-of-plane motion of a
/// plate one node thick), so the stiffness is singular whatever the solver.
pub(super) fn nonzero_diagonal(solver: &str, diag: &[f64], spd: bool) -> Result<(), SolveError> {
    let max = diag.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let bad = |d: f64| d.is_nan() || d.abs() <= 1e-14 * max || (spd && d < 0.0);
    match diag.iter().position(|&d| bad(d)) {
        Some(dof) => Err(SolveError::ZeroDiagonal { solver: solver.to_string(), dof, value: diag[dof] }),
        None => Ok(()),
    }
}

/// What [`super::solve_model`] checks before anything else: a free DOF, no rigid motion left
/// free by the constraints, finite loads.
pub(super) fn check_static(model: &dyn Model, bc: &Dirichlet, f: &[f64]) -> Result<(), StaticError> {
    let dofs = bc.dofs();
    if dofs.n_free() == 0 {
        return Err(StaticError::NothingFree);
    }
    check_support(model, dofs).map_err(|source| StaticError::Unsupported {
        positions: source.nodes.iter().take(3).map(|&i| model.position(i)[..model.dim()].to_vec()).collect(),
        source,
    })?;
    finite_vector("the load vector", f)?;
    Ok(())
}

/// `Err(why)` when the factor of `chol` (the solver `name`) would not fit in memory: the
/// symbolic analysis knows the factor's size ([`cost::cholesky`]'s limit).
pub(super) fn factor_fits(chol: &Cholesky, name: String) -> Result<(), String> {
    match cost::cholesky(chol, name) {
        cost::Estimate { seconds: None, why, .. } => Err(why),
        _ => Ok(()),
    }
}

/// The residual `report.rel_residual` of a finished solve: finite, and for a direct solver (not
/// CG) at most [`DIRECT_RESIDUAL_LIMIT`] (above, the system is numerically singular).
pub(super) fn check_residual(report: &SolveReport) -> Result<(), SolveError> {
    if !report.rel_residual.is_finite() {
        let at = format!("||A u - f|| / ||f|| = {:e}", report.rel_residual);
        return Err(SolveError::NonFinite { what: "the residual of the solution", at });
    }
    let direct = !matches!(report.solver, SolverId::Cg { .. });
    if direct && !(report.rel_residual <= DIRECT_RESIDUAL_LIMIT) {
        return Err(SolveError::NumericallySingular { rel_residual: report.rel_residual, solver: report.solver });
    }
    Ok(())
}
