//! Static boundary-value problems on a coarsened level ([`LevelModel`]): the per-level solves
//! of `linpd coarsen` ([`crate::pipeline`]), of the `coarsen-*` studies and of the coarsening
//! benchmark, through the one static solve of linpd-solve.

use linpd_coarsen::{CoarsenError, LevelModel};
use linpd_core::progress::Progress;
use linpd_solve::{solve_model, Dirichlet, SolverSpec};

/// Solves `f_int + f = 0` on `model` for the free DOFs: `K_ff u_f = f_f - K_fc g`, with nodal
/// forces `f` (`d` per node; a body-force density `b` gives `f_i = b_i v_i`) and prescribed DOFs
/// `fixed = [(dof, g)]` (`dof = d i + a`); returns `u` over all DOFs. Sparse Cholesky when the
/// stiffness is symmetric, sparse LU otherwise ([`linpd_solve::solve_model`] on
/// [`LevelModel::as_model`]). Loads on prescribed DOFs are reactions and are ignored.
///
/// The tasks of the solve go to `progress`, its phase lines are dropped (the caller names the
/// level). Errors: [`CoarsenError::InvalidInput`] for a load of the wrong length or a
/// prescribed DOF out of range or not finite, [`CoarsenError::SingularGlobal`] when the solve
/// fails (body not held, singular stiffness).
pub fn solve_level(
    model: &LevelModel,
    f: &[f64],
    fixed: &[(usize, f64)],
    progress: &dyn Progress,
) -> Result<Vec<f64>, CoarsenError> {
    let nd = model.dim() * model.len();
    if f.len() != nd {
        return Err(CoarsenError::InvalidInput(format!("load has {} entries, model has {nd} DOFs", f.len())));
    }
    let bc = Dirichlet::from_fixed(model.dim(), nd, fixed).map_err(|e| CoarsenError::InvalidInput(e.to_string()))?;
    let solved = solve_model(&model.as_model(), &bc, f, &SolverSpec::Cholesky, &TasksOnly(progress))
        .map_err(|e| CoarsenError::SingularGlobal(e.to_string()))?;
    Ok(solved.u)
}

/// Passes the tasks of `0` on and drops its phase lines.
pub(crate) struct TasksOnly<'a>(pub(crate) &'a dyn Progress);

impl Progress for TasksOnly<'_> {
    fn tracks_tasks(&self) -> bool {
        self.0.tracks_tasks()
    }
    fn start(&self, task: &str, total: Option<u64>) {
        self.0.start(task, total)
    }
    fn set(&self, done: u64, message: &str) {
        self.0.set(done, message)
    }
    fn finish(&self) {
        self.0.finish()
    }
}
