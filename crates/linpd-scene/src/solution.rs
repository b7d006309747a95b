//! The result of a static solve ([`Solution`]): displacements, the force balance and the
//! fields of the model; written by [`crate::output`].

use crate::balance::Balance;
use crate::fields::NodalStrain;
use linpd_core::Point;
use linpd_solve::SolveReport;

/// The result of a static solve.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Scene name.
    pub name: String,
    /// Dimension.
    pub dim: usize,
    /// Node positions.
    pub x: Vec<Point>,
    /// Displacements, `dim` per node (node-major).
    pub u: Vec<f64>,
    /// True for nodes of the outer layer.
    pub is_layer: Vec<bool>,
    /// Node volumes `V_i` (empty for blend scenes, whose CE nodes carry none).
    pub volumes: Vec<f64>,
    /// Number of bonds (each pair counted from both ends).
    pub n_bonds: usize,
    /// Accuracy and cost.
    pub report: SolveReport,
    /// Loads, constraints, reactions and the force balance (every static scene; for blend and
    /// CE scenes built by [`crate::models::blend_1d`] from the solution's end reactions).
    pub balance: Option<Balance>,
    /// Strain energy density `W_i` per node (energy per volume; `sum_i W_i V_i = u.A u / 2`,
    /// [`crate::stress::energy_and_force_flux`] for bond-based models,
    /// [`linpd_lps::LpsModel::linearized_energy_density`] for LPS, the same split of `K`'s
    /// blocks for symmetric coarsened levels): not for blend scenes and unsymmetric levels.
    pub strain_energy_density: Option<Vec<f64>>,
    /// Small-strain tensor per node, least squares over the node's partners
    /// ([`crate::fields`]): not for blend scenes.
    pub strain: Option<NodalStrain>,
    /// Linearized dilatation `theta_i` per node: LPS scenes only.
    pub dilatation: Option<Vec<f64>>,
    /// Cells over the nodes for result.vtu (the graded local mesh of a blended scene: quads or
    /// hexahedra over lattice nodes); `None`: one vertex per node.
    pub cells: Option<linpd_io::vtk::Cells>,
    /// Cauchy stress per node from the model's elastic constants and `strain`
    /// ([`crate::stress::hooke`]; set by [`crate::scene::Problem::solve`]).
    pub stress: Option<crate::stress::NodalStress>,
    /// The force-flux (peridynamic) stress per node: bond-based models
    /// ([`crate::stress::force_flux`]).
    pub pd_stress: Option<crate::stress::NodalStress>,
    /// `E, nu, K, G` of the model's materials (`result.json`'s `material`; set by
    /// [`crate::scene::Problem::solve`] from [`crate::scene::SceneModel::elastic_constants`]).
    pub material: Vec<crate::elastic::PhaseConstants>,
    /// The graded local mesh of a blended scene against its lattice (`stats.graded_mesh`).
    pub graded_mesh: Option<GradedMeshSummary>,
}

/// `result.json`'s `stats.graded_mesh`: the graded local mesh (`model.local_mesh`) of a blended
/// scene against pure PD on the same lattice.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GradedMeshSummary {
    /// The lattice's nodes (pure PD's).
    pub lattice_nodes: usize,
    /// Leaves, masters and hanging nodes per level (cells of side `h 2^level`).
    pub levels: Vec<linpd_blend::graded::LevelCounts>,
    /// The mesh's masters (its regular nodes, unknowns).
    pub masters: usize,
    /// Nodes of no leaf (all their cells outside the body): unknowns of their own.
    pub extra_nodes: usize,
    /// Lattice nodes whose bonds were built (the level-0 cells and a horizon around them).
    pub window_nodes: usize,
    /// Stored entries of the blend's `A` over the masters.
    pub nnz: usize,
    /// Stored entries of the bond model's `A` on the whole lattice.
    pub nnz_pd: usize,
}

impl Solution {
    /// The solution on `nodes` only (ascending), renumbered `0..nodes.len()`: a rank's owned
    /// nodes of its window, for its piece of a distributed result. The balance keeps its
    /// totals (the window's) and only the nodal reactions of `nodes`.
    pub fn restricted(&self, nodes: &[usize]) -> Solution {
        let d = self.dim;
        let pick = |v: &[f64], per: usize| -> Vec<f64> {
            nodes.iter().flat_map(|&n| v[per * n..per * n + per].iter().copied()).collect()
        };
        let tensors = |t: &[[f64; 9]]| nodes.iter().map(|&n| t[n]).collect::<Vec<_>>();
        let mut out = self.clone();
        out.x = nodes.iter().map(|&n| self.x[n]).collect();
        out.u = pick(&self.u, d);
        out.is_layer = nodes.iter().map(|&n| self.is_layer[n]).collect();
        if self.volumes.len() == self.x.len() {
            out.volumes = pick(&self.volumes, 1);
        }
        out.strain_energy_density = self.strain_energy_density.as_ref().map(|e| pick(e, 1));
        out.dilatation = self.dilatation.as_ref().map(|t| pick(t, 1));
        if let (Some(s), Some(o)) = (&self.strain, &mut out.strain) {
            o.tensor = tensors(&s.tensor);
            o.singular =
                nodes.iter().enumerate().filter(|(_, n)| s.singular.binary_search(n).is_ok()).map(|(k, _)| k).collect();
        }
        if let (Some(s), Some(o)) = (&self.stress, &mut out.stress) {
            o.tensor = tensors(&s.tensor);
        }
        if let (Some(s), Some(o)) = (&self.pd_stress, &mut out.pd_stress) {
            o.tensor = tensors(&s.tensor);
        }
        if let Some(b) = &mut out.balance {
            if b.nodal_reaction.len() == d * self.x.len() {
                b.nodal_reaction = pick(&b.nodal_reaction, d);
            }
        }
        out.cells = None;
        out
    }
}
