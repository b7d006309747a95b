//! The graded blend's strain at lattice sites: PD's where the model is nonlocal, the leaves'
//! where it is local ([`GradedBlend::strain_at`]).

use super::GradedBlend;
use linpd_core::strain::{nodal_strain, NodalStrain};
use linpd_core::Grid;
use rayon::prelude::*;

impl GradedBlend {
    /// The small-strain tensor at `sites` of the solution `u_at` (`P u_M` at a lattice site):
    /// PD's ([`nodal_strain`], least squares over the family, from the window's bonds) at the
    /// corners of the mesh's lattice cells and at the extra nodes, whose families the window
    /// holds whole; elsewhere the symmetric part of the mean gradient of the leaves around the
    /// site ([`crate::graded_mesh::GradedMesh::leaf_strain`]).
    pub fn strain_at(
        &self,
        grid: &Grid,
        u_at: &(dyn Fn([usize; 3]) -> [f64; 3] + Sync),
        sites: &[[usize; 3]],
    ) -> NodalStrain {
        let (mesh, d) = (self.mesh(), grid.dim());
        let (window, op) = self.window();
        let u_window: Vec<f64> = (0..window.len())
            .into_par_iter()
            .flat_map_iter(|w| {
                let l = window.lattice_index(w);
                let k = grid.node_at(l).map(|i| grid.site_of(i));
                k.map_or([0.0; 3], u_at)[..d].to_vec()
            })
            .collect();
        let extra = self.extra_nodes();
        let volumes: Vec<f64> = (0..window.len()).map(|w| window.node_volume(w)).collect();
        let pd = nodal_strain(op, &volumes, &u_window);
        let tensor: Vec<[f64; 9]> = sites
            .par_iter()
            .map(|&k| {
                let node = grid.node_at_site(k);
                let on_lattice_cell = mesh.node_at(k).is_some_and(|i| mesh.node_level(i) == 0)
                    || node.is_some_and(|i| extra.binary_search(&i).is_ok());
                let lattice_node = node.map(|i| grid.lattice_index(i));
                match (on_lattice_cell, lattice_node.and_then(|l| window.node_at(l))) {
                    (true, Some(w)) => pd.tensor[w],
                    _ => mesh.leaf_strain(u_at, k),
                }
            })
            .collect();
        NodalStrain { dim: d, tensor, singular: Vec::new() }
    }

    /// Adds the force `force` on lattice node `i` to the masters' forces `f_m` (`d` per master)
    /// as `P^T f`: each master `m` interpolating `i` with weight `w` takes `w force`.
    pub fn add_force(&self, grid: &Grid, i: usize, force: &[f64], f_m: &mut [f64]) {
        let d = grid.dim();
        for (m, w) in self.interpolation(grid, i) {
            (0..d).for_each(|a| f_m[d * m + a] += w * force[a]);
        }
    }
}
