//! The linearized LPS solid as a [`Model`]: the tangent `A` of [`crate::tangent`] at `u = 0`.
//!
//! The tangent couples nodes up to two horizons apart (the dilatation of a neighbour): the
//! nested dissection runs over the two-hop stencil of the bond family
//! ([`linpd_core::two_hop_stencil`]), whose separators are `2 floor(delta / h)` planes thick. The interaction graph for the
//! rigid-motion check is the bond family: two nodes two horizons apart are coupled only
//! through a common neighbour, so the connected pieces are the same.

use crate::{assemble_tangent, LpsModel};
use linpd_core::family::grid_stencil;
use linpd_core::sparse::{restrict_to_free, Csc};
use linpd_core::{nested_dissection, two_hop_stencil, DofMap, FastApply, Model, Ordering, Point};

impl Model for LpsModel {
    fn kind(&self) -> &'static str {
        "lps"
    }
    fn dim(&self) -> usize {
        LpsModel::dim(self)
    }
    fn n_nodes(&self) -> usize {
        LpsModel::n_nodes(self)
    }
    fn position(&self, i: usize) -> Point {
        self.positions[i]
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.family().neighbors(i).iter().for_each(|&j| f(j as usize));
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        self.apply_tangent(u, y)
    }
    /// [`LpsModel::tangent_diagonal`]: `O(|F|)` per node, nothing assembled.
    fn diagonal(&self) -> Vec<f64> {
        self.tangent_diagonal()
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        restrict_to_free(&assemble_tangent(self), dofs)
    }
    /// On a lattice nested dissection over the two-hop stencil; on a point cloud AMD.
    fn ordering(&self, dofs: &DofMap) -> Ordering {
        let Some(grid) = self.grid() else {
            return Ordering::Amd;
        };
        let stencil = two_hop_stencil(&grid_stencil(grid, self.params().horizon / grid.spacing()));
        Ordering::NestedDissection(nested_dissection(grid, &stencil, dofs))
    }
    /// [`LpsModel::tangent_block_row`]: every node within two hops, from the families of `i`
    /// and of its partners.
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        self.tangent_block_row(i, f);
        true
    }
    /// [`LpsModel::two_hop_nodes`]: the pattern without the `O(|F|^2 d^2)` terms.
    fn for_each_coupled(&self, i: usize, f: &mut dyn FnMut(usize)) -> bool {
        self.two_hop_nodes(i).into_iter().for_each(f);
        true
    }
    /// The stencils of a homogeneous material on the full box ([`crate::stencil`]).
    fn fast_apply(&self) -> Option<FastApply<'_>> {
        let st = self.stencil()?;
        Some(FastApply { op: Box::new(st), label: "lps-stencil" })
    }
    /// The pair part `A_pair` ([`crate::pair`]): one-horizon block rows, spectrally equivalent
    /// to `A` with the constants of its module docs.
    fn multigrid_companion(&self) -> Option<Box<dyn Model + '_>> {
        Some(Box::new(crate::PairPart(self)))
    }
}
