//! The boundary-value problem of every level of a pipeline ([`LevelBvp`]).
//!
//! * **Level 0 is the scene**: its prescribed DOFs and nodal forces are exactly those
//!   `linpd solve` builds ([`Problem::constrained`], [`Problem::load_vector`]: every load type,
//!   the scene's volumes), and the pipeline solves it with the scene's own solve.
//! * **Loads reach level m by transfer**, `F^m = S^T F^{m-1}` ([`linpd_coarsen::Transfer`]: each
//!   coarse node collects from its own neighbourhood's resolvent), never by re-evaluating the
//!   scene's loads on coarse volumes. Forces on prescribed DOFs are reactions, not loads: they
//!   are dropped before the transfer (as the solve of their level ignores them).
//! * **Constraints**: a level-m node keeps the scene's prescribed values of its level-0 node. A
//!   constraint on a node that level m drops cannot be carried (the coarse stiffness is
//!   condensed with that node free), so a scene that holds excluded nodes poses a softer problem
//!   at level m; the level reports how many prescribed DOFs it kept.

use crate::scene::Problem;
use linpd_coarsen::{LevelModel, Transfer};

/// Prescribed DOFs and nodal forces of one level, `d` per node in the level's node order.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelBvp {
    /// Prescribed DOFs.
    pub mask: Vec<bool>,
    /// Prescribed values (0 where free).
    pub ubar: Vec<f64>,
    /// Nodal forces, 0 on prescribed DOFs.
    pub f: Vec<f64>,
    /// Total force per component that reached the level, before the forces on its prescribed
    /// DOFs were dropped (level 0: the scene's loads, all DOFs).
    pub arrived: Vec<f64>,
}

impl LevelBvp {
    /// Level 0: the scene's own prescribed DOFs and nodal forces.
    pub fn of_scene(scene: &Problem) -> Self {
        let (mask, ubar) = scene.constrained();
        let mut f = scene.load_vector();
        let arrived = totals(&f, scene.dim());
        f.iter_mut().zip(&mask).filter(|(_, &m)| m).for_each(|(t, _)| *t = 0.0);
        Self { mask, ubar, f, arrived }
    }

    /// Level m from level m-1 (this) by the step's `transfer`; `coarse` is the level-m model
    /// and `level0` the level-0 BVP (its prescribed values are kept by every level's nodes).
    pub fn transferred(&self, transfer: &Transfer, coarse: &LevelModel, level0: &LevelBvp) -> Self {
        let d = coarse.dim();
        let mut mask = vec![false; d * coarse.len()];
        let mut ubar = vec![0.0; d * coarse.len()];
        for (k, &p) in coarse.level0().iter().enumerate() {
            for a in 0..d {
                mask[d * k + a] = level0.mask[d * p + a];
                ubar[d * k + a] = level0.ubar[d * p + a];
            }
        }
        let mut f = transfer.restrict(&self.f);
        let arrived = totals(&f, d);
        f.iter_mut().zip(&mask).filter(|(_, &m)| m).for_each(|(t, _)| *t = 0.0);
        Self { mask, ubar, f, arrived }
    }

    /// Prescribed DOFs as `(dof, value)`.
    pub fn fixed(&self) -> Vec<(usize, f64)> {
        self.mask.iter().enumerate().filter(|(_, &m)| m).map(|(k, _)| (k, self.ubar[k])).collect()
    }

    /// Number of prescribed DOFs.
    pub fn n_prescribed(&self) -> usize {
        self.mask.iter().filter(|&&m| m).count()
    }

    /// Total applied force per component (on free DOFs).
    pub fn total_force(&self, d: usize) -> Vec<f64> {
        totals(&self.f, d)
    }
}

/// Sum per component of `d`-component nodal vectors.
fn totals(f: &[f64], d: usize) -> Vec<f64> {
    (0..d).map(|a| f.iter().skip(a).step_by(d).sum()).collect()
}
