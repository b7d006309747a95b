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
//! Moments (2D: the z component, a number; 3D: a vector; none in 1D) are taken about a
//! reference point `O`, the mean position of the scene's nodes: a load's `M_l = sum_i (x_i - O)
//! x f_i`, and the reactions' `sum_i (x_i - O) x (A u - f)_i` over the held DOFs. Each constraint
//! also reports its moment about the centroid of its nodes, the support's own resultant couple.
//! When `A` also has the rigid rotations in its null space and is symmetric (pairwise central
//! bond forces; LPS), `sum_i x_i x (A u)_i = 0` and the moments balance too:
//! `relative_moment_imbalance` is `max_a |M_applied + M_reaction|_a` relative to the largest
//! force in the balance times the diagonal of the nodes' bounding box.
//!
//! 1D blend and CE scenes build theirs in [`crate::models::blend_1d`] from the reactions of
//! [`linpd_blend::BlendSolution`]: the same definition, with the end rows of the blended
//! operator holding the local model's force on the end half cells. CE and pure-PD rows balance
//! to round-off; the transition rows of a blended model balance only when the solution is
//! quadratic on their stencils (the linpd-blend crate docs, "Force balance").

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
    /// Its moment about the balance's `reference` point (see the module docs).
    pub moment: Vec<f64>,
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
    /// The mean position of its nodes.
    pub centroid: Vec<f64>,
    /// The moment of its reactions about `centroid`.
    pub moment: Vec<f64>,
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
    /// The point the totals' moments are about: the mean position of the nodes (none in 1D).
    pub reference: Vec<f64>,
    /// `sum_l M_l` about `reference`.
    pub applied_moment: Vec<f64>,
    /// The reactions' moment about `reference`.
    pub reaction_moment: Vec<f64>,
    /// See the module docs (0 in 1D and without forces).
    pub relative_moment_imbalance: f64,
    /// `(A u - f)` on every held DOF, 0 elsewhere (`d` per node): `result.vtu`'s `reaction`.
    #[serde(skip)]
    pub nodal_reaction: Vec<f64>,
}

/// `r x f` as linpd reports moments: none in 1D, the z component in 2D, the vector in 3D.
pub(crate) fn moment(d: usize, r: &[f64], f: &[f64]) -> Vec<f64> {
    match d {
        2 => vec![r[0] * f[1] - r[1] * f[0]],
        3 => vec![r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]],
        _ => Vec::new(),
    }
}

/// Where the moments are taken and how large they may be: the reference point `O` and the
/// diagonal of the nodes' bounding box (the scale of the moment imbalance).
#[derive(Debug, Clone, Default)]
pub(crate) struct MomentFrame {
    pub reference: Vec<f64>,
    pub diagonal: f64,
}

impl Balance {
    /// The totals and the relative imbalance of per-load and per-constraint entries with `d`
    /// components.
    pub(crate) fn from_parts(
        d: usize,
        loads: Vec<LoadBalance>,
        constraints: Vec<ConstraintBalance>,
        frame: MomentFrame,
        nodal_reaction: Vec<f64>,
    ) -> Balance {
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
        let m = moment(d, &[0.0; 3], &[0.0; 3]).len();
        let sum = |v: &mut dyn Iterator<Item = Vec<f64>>| {
            v.fold(vec![0.0; m], |t, x| t.iter().zip(&x).map(|(a, b)| a + b).collect())
        };
        let applied_moment = sum(&mut loads.iter().map(|l| l.moment.clone()));
        // a constraint's moment about O: its own couple plus its resultant at its centroid
        let reaction_moment = sum(&mut constraints.iter().filter(|_| m > 0).map(|c| {
            let r: Vec<f64> = (0..d).map(|a| c.centroid[a] - frame.reference[a]).collect();
            c.moment.iter().zip(moment(d, &r, &c.reaction)).map(|(a, b)| a + b).collect()
        }));
        let worst_moment = (0..m).map(|a| (applied_moment[a] + reaction_moment[a]).abs()).fold(0.0, f64::max);
        let moment_scale = scale * frame.diagonal;
        let relative_moment_imbalance = if moment_scale > 0.0 { worst_moment / moment_scale } else { 0.0 };
        Balance {
            loads,
            constraints,
            applied,
            reaction,
            relative_imbalance,
            reference: frame.reference,
            applied_moment,
            reaction_moment,
            relative_moment_imbalance,
            nodal_reaction,
        }
    }
}
