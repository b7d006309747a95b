//! What the loads and constraints of a solved scene did: per load the nodes it caught and the
//! total force it applied, per constraint the nodes and DOFs it held and its reaction, and the
//! global force balance.
//!
//! The reaction of a constraint is the force its support exerts, summed over the DOFs it holds,
//!
//! ```text
//! R_c = sum_{k in DOFs(c)} (A u - f)_k        (per component),
//! ```
//!
//! where `f` holds every load's nodal forces (a load on a held DOF goes straight into the
//! support). A DOF held by two (agreeing) constraints belongs to the first. For an operator with
//! the translations in its null space and `1^T A = 0` (symmetric bond-based and LPS operators),
//! `sum_c R_c + sum_l F_l = 1^T A u = 0`: the reactions balance the applied loads. `A u` is one
//! product of the model's full operator.
//!
//! 1D blend and CE scenes build theirs in [`crate::models::blend_1d`] from the reactions of
//! [`linpd_blend::BlendSolution`]: the same definition, with the end rows of the blended
//! operator holding the local model's force on the end half cells. CE and pure-PD rows balance
//! to round-off; the transition rows of a blended model balance only when the solution is
//! quadratic on their stencils (the linpd-blend crate docs, "Force balance").

use linpd_core::Model;
use serde::Serialize;

/// One load's effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadBalance {
    /// `point`, `body` or `resultant`.
    pub kind: &'static str,
    /// Nodes it put a force on.
    pub nodes: usize,
    /// The sum of its nodal forces (per component).
    pub force: Vec<f64>,
}

/// One constraint's effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConstraintBalance {
    /// Nodes in its region.
    pub nodes: usize,
    /// DOFs it holds (those another constraint listed earlier holds are not counted).
    pub dofs: usize,
    /// Its reaction `R_c` (per component; see the module docs).
    pub reaction: Vec<f64>,
}

/// The balance of a solved scene (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Balance {
    /// Per load, in scene order.
    pub loads: Vec<LoadBalance>,
    /// Per constraint, in scene order.
    pub constraints: Vec<ConstraintBalance>,
    /// `sum_l F_l`.
    pub applied: Vec<f64>,
    /// `sum_c R_c`.
    pub reaction: Vec<f64>,
    /// `max_a |applied_a + reaction_a|` relative to the largest load or constraint reaction
    /// component (0 when there is no force at all): round-off for the bond-based and LPS
    /// operators.
    pub relative_imbalance: f64,
}

impl Balance {
    /// The totals and the relative imbalance of per-load and per-constraint entries with `d`
    /// components.
    pub(crate) fn from_parts(d: usize, loads: Vec<LoadBalance>, constraints: Vec<ConstraintBalance>) -> Balance {
        let applied: Vec<f64> = (0..d).map(|a| loads.iter().map(|l: &LoadBalance| l.force[a]).sum()).collect();
        let reaction: Vec<f64> =
            (0..d).map(|a| constraints.iter().map(|c: &ConstraintBalance| c.reaction[a]).sum()).collect();
        // the largest force in the balance: a scene driven by prescribed displacements alone
        // has no load, and its constraints' reactions cancel each other
        let scale = applied
            .iter()
            .chain(constraints.iter().flat_map(|c| &c.reaction))
            .chain(loads.iter().flat_map(|l| &l.force))
            .fold(0.0f64, |m, x| m.max(x.abs()));
        let worst = (0..d).map(|a| (applied[a] + reaction[a]).abs()).fold(0.0, f64::max);
        let relative_imbalance = if scale > 0.0 { worst / scale } else { 0.0 };
        Balance { loads, constraints, applied, reaction, relative_imbalance }
    }
}

/// The strain energy of node `i`, `W_i V_i`, for a model that exposes its blocks
/// ([`Model::for_each_block`]; the bond-based models). For a symmetric `A` with zero block-row
/// sums (`A_ii = -sum_{j != i} A_ij`),
///
/// ```text
/// u.A u / 2 = -(1/4) sum_i sum_{j != i} (u_j - u_i)^T A_ij (u_j - u_i),
/// ```
///
/// and node `i` takes its term of the outer sum: half of the energy of each of its bonds (for
/// the bond-based model `A_ij = -w_ij e e^T`, so `W_i V_i = (1/4) sum_j w_ij (e . (u_j -
/// u_i))^2`, never negative, and a rigid motion gives 0). The values sum to `u.A u / 2`.
/// `None` for models without blocks. Used for the bond models; LPS scenes report
/// [`linpd_lps::LpsModel::linearized_energy_density`] and coarsened levels the same split read
/// from the columns of `K` (both have blocks too, for the distributed path's rows).
pub fn nodal_energy(model: &dyn Model, u: &[f64]) -> Option<Vec<f64>> {
    use rayon::prelude::*;
    let d = model.dim();
    let energies: Vec<Option<f64>> = (0..model.n_nodes())
        .into_par_iter()
        .map(|i| {
            let mut w = 0.0;
            let has = model.for_each_block(i, &mut |j, block| {
                if j == i {
                    return;
                }
                // per bond: no allocation (d <= 3)
                let mut du = [0.0; 3];
                (0..d).for_each(|a| du[a] = u[d * j + a] - u[d * i + a]);
                for a in 0..d {
                    for b in 0..d {
                        w -= 0.25 * du[a] * block[a * d + b] * du[b];
                    }
                }
            });
            has.then_some(w)
        })
        .collect();
    energies.into_iter().collect()
}
