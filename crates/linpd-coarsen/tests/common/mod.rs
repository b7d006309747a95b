//! Helpers shared by the coarsening test files: the level-0 bar of Silling (2010), Example 5.1
//! with a dense reference solver ([`paper`]), and the static solve of a level.
#![allow(dead_code)]

pub mod paper;

use linpd_coarsen::LevelModel;
use linpd_core::progress::NoProgress;
use linpd_solve::{solve_model, Dirichlet, SolverSpec};

/// Solves `f_int + f = 0` on `model` for the free DOFs, with nodal forces `f` (`d` per node) and
/// prescribed DOFs `fixed = [(dof, g)]` (`dof = d i + a`); returns `u` over all DOFs. Sparse
/// Cholesky when the stiffness is symmetric, sparse LU otherwise (linpd-solve's `solve_model`
/// on [`LevelModel::as_model`]), the solve of `linpd_problem::level_solve::solve_level`.
pub fn solve_dirichlet(model: &LevelModel, f: &[f64], fixed: &[(usize, f64)]) -> Result<Vec<f64>, String> {
    let bc = Dirichlet::from_fixed(model.dim(), model.dim() * model.len(), fixed).map_err(|e| e.to_string())?;
    let solved =
        solve_model(&model.as_model(), &bc, f, &SolverSpec::Cholesky, &NoProgress).map_err(|e| e.to_string())?;
    Ok(solved.u)
}
