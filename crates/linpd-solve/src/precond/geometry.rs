//! Where the unknowns of a reduced system sit ([`DofGeometry`]): what the multilevel
//! preconditioner ([`super::Amg`]) builds its near-null space and its finest aggregates from.

use linpd_core::{DofMap, Model, Point};

/// Where the unknowns of a reduced system sit: for a multilevel preconditioner's near-null
/// space (rigid-body modes) and aggregation.
#[derive(Debug, Clone, PartialEq)]
pub struct DofGeometry {
    /// Spatial dimension.
    pub dim: usize,
    /// `(node, component)` of every free DOF, in the free numbering.
    pub rows: Vec<(usize, usize)>,
    /// Position of every node of the model.
    pub positions: Vec<Point>,
    /// The model's interaction graph ([`Model::for_each_partner`]: bonds) between the nodes
    /// with free DOFs, numbered in their order in `rows`, as CSR `(ptr, idx)` with sorted rows;
    /// `None` for a bare matrix. Multigrid aggregates its finest level on it: for bond models
    /// it is the graph of `A`'s nonzero blocks, for LPS the one-horizon bonds, not the tangent's
    /// two-horizon couplings, whose aggregates would be eight times too large in 3D.
    pub partners: Option<(Vec<usize>, Vec<u32>)>,
}

impl DofGeometry {
    /// The free DOFs of `dofs` on the nodes of `model`.
    pub fn of(model: &dyn Model, dofs: &DofMap) -> Self {
        let d = model.dim();
        let rows: Vec<(usize, usize)> = dofs.free_dofs().into_iter().map(|f| (f / d, f % d)).collect();
        let mut block_of = vec![u32::MAX; model.n_nodes()];
        let mut nodes = Vec::new();
        for &(node, _) in &rows {
            if block_of[node] == u32::MAX {
                block_of[node] = nodes.len() as u32;
                nodes.push(node);
            }
        }
        let keep = |i: usize, j: usize| block_of[j] != u32::MAX && j != i;
        let (ptr, idx) = super::csr_in_place(
            nodes.len(),
            |r| {
                let mut c = 0;
                model.for_each_partner(nodes[r], &mut |j| c += usize::from(keep(nodes[r], j)));
                c
            },
            |r, row| {
                let mut k = 0;
                model.for_each_partner(nodes[r], &mut |j| {
                    if keep(nodes[r], j) {
                        row[k] = block_of[j];
                        k += 1;
                    }
                });
                row.sort_unstable();
                // a model may report a partner twice: the repeats are dropped
                let mut len = 0;
                for t in 0..row.len() {
                    if t == 0 || row[t] != row[len - 1] {
                        row[len] = row[t];
                        len += 1;
                    }
                }
                len
            },
        );
        DofGeometry {
            dim: d,
            rows,
            positions: (0..model.n_nodes()).map(|i| model.position(i)).collect(),
            partners: Some((ptr, idx)),
        }
    }
}
