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
    /// A rank's piece of a point cloud: each node's number in the cloud's file (0-based), the
    /// VTU array `file_node` (the pieces are in the distributed order, bin by bin).
    pub file_node: Option<Vec<u32>>,
}

/// `result.json`'s `stats.graded_mesh`: the graded local mesh (`model.local_mesh`) of a blended
/// scene against pure PD on the same lattice.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GradedMeshSummary {
    /// The lattice's nodes (pure PD's).
    pub lattice_nodes: usize,
    /// Leaves, masters and hanging nodes per level (cells of side `h 2^level`).
    pub levels: Vec<linpd_blend::graded_mesh::LevelCounts>,
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
    /// nodes of its window, for its piece of a distributed result. Takes the solution, so no
    /// array is copied whole. The balance keeps its totals (the window's) and only the nodal
    /// reactions of `nodes`.
    pub fn restricted(mut self, nodes: &[usize]) -> Solution {
        let (d, n) = (self.dim, self.x.len());
        let pick = |v: &[f64], per: usize| -> Vec<f64> {
            nodes.iter().flat_map(|&k| v[per * k..per * k + per].iter().copied()).collect()
        };
        let tensors = |t: &[[f64; 9]]| nodes.iter().map(|&k| t[k]).collect::<Vec<_>>();
        self.x = nodes.iter().map(|&k| self.x[k]).collect();
        self.u = pick(&self.u, d);
        self.is_layer = nodes.iter().map(|&k| self.is_layer[k]).collect();
        if self.volumes.len() == n {
            self.volumes = pick(&self.volumes, 1);
        }
        self.strain_energy_density = self.strain_energy_density.as_deref().map(|e| pick(e, 1));
        self.dilatation = self.dilatation.as_deref().map(|t| pick(t, 1));
        if let Some(s) = &mut self.strain {
            s.tensor = tensors(&s.tensor);
            s.singular =
                nodes.iter().enumerate().filter(|(_, k)| s.singular.binary_search(k).is_ok()).map(|(r, _)| r).collect();
        }
        for s in [&mut self.stress, &mut self.pd_stress].into_iter().flatten() {
            s.tensor = tensors(&s.tensor);
        }
        if let Some(b) = &mut self.balance {
            if b.nodal_reaction.len() == d * n {
                b.nodal_reaction = pick(&b.nodal_reaction, d);
            }
        }
        self.cells = None;
        self
    }
}
