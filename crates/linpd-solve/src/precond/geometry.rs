//! Where the unknowns of a reduced system sit ([`DofGeometry`]): what the multilevel
//! preconditioner ([`super::Amg`]) builds its near-null space and its finest aggregates from.

use linpd_core::{DofMap, Model, Point};
use rayon::prelude::*;

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
        // Two passes straight into the CSR arrays (count, then fill each row's slice in place
        // and sort it): one short vector per node made this the largest part of a 150^3
        // lattice's multigrid setup (14.7 s of 52.8 s, 3.4M allocations and a copy of 1.6 GB).
        let counts: Vec<usize> = nodes
            .par_iter()
            .map(|&i| {
                let mut c = 0;
                model.for_each_partner(i, &mut |j| c += usize::from(block_of[j] != u32::MAX && j != i));
                c
            })
            .collect();
        let mut ptr = Vec::with_capacity(nodes.len() + 1);
        ptr.push(0usize);
        for c in &counts {
            ptr.push(ptr.last().unwrap() + c);
        }
        drop(counts);
        let mut idx = vec![0u32; *ptr.last().unwrap()];
        let mut slices: Vec<&mut [u32]> = Vec::with_capacity(nodes.len());
        let mut rest = idx.as_mut_slice();
        for w in ptr.windows(2) {
            let (row, tail) = std::mem::take(&mut rest).split_at_mut(w[1] - w[0]);
            slices.push(row);
            rest = tail;
        }
        let lens: Vec<usize> = slices
            .into_par_iter()
            .zip(nodes.par_iter())
            .map(|(row, &i)| {
                let mut k = 0;
                model.for_each_partner(i, &mut |j| {
                    if block_of[j] != u32::MAX && j != i {
                        row[k] = block_of[j];
                        k += 1;
                    }
                });
                row.sort_unstable();
                // repeats (a model may report a partner twice) move to the end
                let mut len = 0;
                for t in 0..row.len() {
                    if t == 0 || row[t] != row[len - 1] {
                        row[len] = row[t];
                        len += 1;
                    }
                }
                len
            })
            .collect();
        // drop the repeats' slots (none on lattices and clouds: one pass that only copies)
        if lens.iter().zip(ptr.windows(2)).any(|(&l, w)| l != w[1] - w[0]) {
            let mut compact = Vec::with_capacity(lens.iter().sum());
            let mut cptr = Vec::with_capacity(ptr.len());
            cptr.push(0);
            for (r, &l) in lens.iter().enumerate() {
                compact.extend_from_slice(&idx[ptr[r]..ptr[r] + l]);
                cptr.push(compact.len());
            }
            idx = compact;
            ptr = cptr;
        }
        DofGeometry {
            dim: d,
            rows,
            positions: (0..model.n_nodes()).map(|i| model.position(i)).collect(),
            partners: Some((ptr, idx)),
        }
    }
}
