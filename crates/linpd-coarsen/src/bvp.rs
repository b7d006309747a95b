//! Static boundary-value problems on a level model (verification, the pipeline's per-level
//! solves and the studies), through the one static solve of linpd-solve.

use crate::{CoarsenError, LevelModel};
use linpd_core::progress::{NoProgress, Progress};
use linpd_core::AssembledModel;
use linpd_solve::{solve_model, Dirichlet, SolverSpec};

impl LevelModel {
    /// The level as a [`linpd_core::Model`]: its nodal stiffness `K` over all DOFs.
    ///
    /// Symmetry is judged on `K` itself, not on `C` ([`LevelModel::asymmetry`]): with
    /// `C_ij = C_ji^T` the off-diagonal blocks of `K` are symmetric, but the diagonal block
    /// `K_ii = sum_j v_i v_j C_ij` is not unless every `C_ij` is (the 2D plate's level 1 after
    /// symmetrization: relative asymmetry of `K` 1.5e-4 with `C` exactly symmetric).
    pub fn as_model(&self) -> AssembledModel {
        AssembledModel::new("coarsened", self.dim(), self.positions().to_vec(), self.stiffness())
            .with_labels("level-0 node", self.level0().to_vec())
    }

    /// Solves `f_int + f = 0` for the free DOFs: `K_ff u_f = f_f - K_fc g`, with nodal forces
    /// `f` (`d` per node; a body-force density `b` gives `f_i = b_i v_i`) and prescribed DOFs
    /// `fixed = [(dof, g)]` (`dof = d i + a`). Sparse Cholesky when `C` is symmetric (to 1e-12),
    /// sparse LU otherwise ([`linpd_solve::solve_model`]). Loads on prescribed DOFs are
    /// reactions and are ignored.
    pub fn solve_dirichlet(&self, f: &[f64], fixed: &[(usize, f64)]) -> Result<Vec<f64>, CoarsenError> {
        self.solve_dirichlet_with_progress(f, fixed, &NoProgress)
    }

    /// [`LevelModel::solve_dirichlet`] reporting the tasks of the solve to `progress` (its
    /// phase lines are dropped: the caller names the level).
    pub fn solve_dirichlet_with_progress(
        &self,
        f: &[f64],
        fixed: &[(usize, f64)],
        progress: &dyn Progress,
    ) -> Result<Vec<f64>, CoarsenError> {
        let nd = self.dim() * self.len();
        if f.len() != nd {
            return Err(CoarsenError::InvalidInput(format!("load has {} entries, model has {nd} DOFs", f.len())));
        }
        let bc = Dirichlet::from_fixed(self.dim(), nd, fixed).map_err(|e| CoarsenError::InvalidInput(e.to_string()))?;
        let solved = solve_model(&self.as_model(), &bc, f, &SolverSpec::Cholesky, &TasksOnly(progress))
            .map_err(|e| CoarsenError::SingularGlobal(e.to_string()))?;
        Ok(solved.u)
    }
}

/// Passes the tasks of `0` on and drops its phase lines.
struct TasksOnly<'a>(&'a dyn Progress);

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
