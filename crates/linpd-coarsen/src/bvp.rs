//! Static boundary-value problems on a level model (verification, the pipeline's per-level
//! solves and the studies).

use crate::{CoarsenError, LevelModel};
use faer::sparse::{SparseColMat, Triplet};
use linpd_solve::{lu_solve, Cholesky};

impl LevelModel {
    /// Solves `f_int + f = 0` for the free DOFs: `K_ff u_f = f_f - K_fc g`, with nodal forces
    /// `f` (`d` per node; a body-force density `b` gives `f_i = b_i v_i`) and prescribed DOFs
    /// `fixed = [(dof, g)]` (`dof = d i + a`). Sparse Cholesky when `C` is symmetric (to 1e-12),
    /// sparse LU otherwise. Loads on prescribed DOFs are reactions and are ignored.
    pub fn solve_dirichlet(&self, f: &[f64], fixed: &[(usize, f64)]) -> Result<Vec<f64>, CoarsenError> {
        let nd = self.dim() * self.len();
        if f.len() != nd {
            return Err(CoarsenError::InvalidInput(format!("load has {} entries, model has {nd} DOFs", f.len())));
        }
        let mut g = vec![None; nd];
        for &(i, v) in fixed {
            if i >= nd || !v.is_finite() {
                return Err(CoarsenError::InvalidInput(format!(
                    "prescribed DOF {i} = {v} out of range (n = {nd}) or not finite"
                )));
            }
            g[i] = Some(v);
        }
        let mut free_index = vec![usize::MAX; nd];
        let mut free = Vec::new();
        for i in 0..nd {
            if g[i].is_none() {
                free_index[i] = free.len();
                free.push(i);
            }
        }
        let k = self.stiffness();
        let mut rhs: Vec<f64> = free.iter().map(|&i| f[i]).collect();
        let mut trip = Vec::new();
        let (cp, ri, val) = (k.col_ptr(), k.row_idx(), k.val());
        for col in 0..nd {
            for p in cp[col]..cp[col + 1] {
                let row = ri[p];
                if free_index[row] == usize::MAX {
                    continue;
                }
                match g[col] {
                    Some(gv) => rhs[free_index[row]] -= val[p] * gv,
                    None => trip.push(Triplet::new(free_index[row], free_index[col], val[p])),
                }
            }
        }
        let n = free.len();
        let kff = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &trip).expect("indices in range");
        let singular = |dof: usize| {
            let dof = free.get(dof).copied().unwrap_or(0);
            CoarsenError::SingularGlobal(format!(
                "zero pivot at DOF {dof} (node {}, component {}): is the body held (enough prescribed displacements)?",
                dof / self.dim(),
                dof % self.dim()
            ))
        };
        let uf = if self.asymmetry() <= 1e-12 {
            let chol = Cholesky::analyze(&kff).map_err(|e| CoarsenError::SingularGlobal(e.to_string()))?;
            match chol.factor(&kff) {
                Ok(fac) => fac.solve(&rhs),
                Err(linpd_solve::SolveError::NotPositiveDefinite { dof }) => return Err(singular(dof)),
                Err(e) => return Err(CoarsenError::SingularGlobal(e.to_string())),
            }
        } else {
            match lu_solve(&kff, &rhs) {
                Ok((u, _, _)) => u,
                Err(linpd_solve::SolveError::Singular { dof }) => return Err(singular(dof)),
                Err(e) => return Err(CoarsenError::SingularGlobal(e.to_string())),
            }
        };
        if uf.iter().any(|t| !t.is_finite()) {
            return Err(CoarsenError::SingularGlobal("the solution is not finite: is the body held?".into()));
        }
        let mut u = vec![0.0; nd];
        for i in 0..nd {
            u[i] = g[i].unwrap_or_else(|| uf[free_index[i]]);
        }
        Ok(u)
    }
}
