//! A matrix-free finest level: `A_ff` of a model is never stored. Its row blocks (the free
//! components of one node) are computed by [`Model::for_each_block`] when the setup needs
//! them (strength graph, `A T`, `A P`: three passes), and its products with vectors run the
//! model's own matrix-free apply (the lattice stencil for homogeneous bond models). What the
//! hierarchy stores is then `P`, `R` and the coarse levels: on a 3D lattice with
//! `delta = 3h` (123 partners) about a tenth of the assembled `A` (measured in
//! docs/solvers.md).

use super::level::LevelMatrix;
use super::vbr::{galerkin_rows, make_groups, mul_rows, Vbr};
use crate::bc::ReducedOperator;
use linpd_core::{DofMap, LinearOperator, Model};
use rayon::prelude::*;

/// `A_ff` of a model, computed on demand (see the module docs).
pub(crate) struct Streamed<'a> {
    model: &'a dyn Model,
    /// `A_ff x` through the model's apply.
    op: ReducedOperator<'a>,
    /// The model's diagonal on the free DOFs.
    diag: Vec<f64>,
    rptr: Vec<usize>,
    /// The node of each row block and the row block of each node (`u32::MAX`: no free DOF).
    block_node: Vec<usize>,
    node_block: Vec<u32>,
    /// Free components of each row block's node (ascending), when not all `d` are free.
    partial: Vec<Option<Vec<usize>>>,
    groups: Vec<usize>,
    /// Entries of `A_ff`, counted by the first pass over all blocks.
    nnz: std::sync::OnceLock<usize>,
    /// `A x` of [`LevelMatrix::matvec_sub`].
    scratch: std::sync::Mutex<Vec<f64>>,
}

impl<'a> Streamed<'a> {
    /// `A_ff` of `model` on the free DOFs of `dofs`, applied through `full` (the model's
    /// operator over all DOFs, e.g. its fast stencil apply), with its free diagonal `diag`
    /// when the caller has it. `None` when the model does not provide its blocks.
    pub fn new(
        model: &'a dyn Model,
        dofs: &'a DofMap,
        full: &'a dyn LinearOperator,
        diag: Option<Vec<f64>>,
    ) -> Option<Self> {
        let d = model.dim();
        let n_nodes = model.n_nodes();
        let mut rptr = vec![0];
        let mut block_node = Vec::new();
        let mut node_block = vec![u32::MAX; n_nodes];
        let mut partial = Vec::new();
        for (i, nb) in node_block.iter_mut().enumerate() {
            let free: Vec<usize> = (0..d).filter(|&c| !dofs.is_constrained(d * i + c)).collect();
            if free.is_empty() {
                continue;
            }
            *nb = block_node.len() as u32;
            block_node.push(i);
            rptr.push(rptr.last().unwrap() + free.len());
            partial.push((free.len() < d).then_some(free));
        }
        let nb = block_node.len();
        let mut streamed = Streamed {
            model,
            op: ReducedOperator::new(full, dofs),
            diag: diag.unwrap_or_else(|| dofs.gather(&model.diagonal())),
            rptr,
            block_node,
            node_block,
            partial,
            groups: Vec::new(),
            nnz: std::sync::OnceLock::new(),
            scratch: std::sync::Mutex::new(Vec::new()),
        };
        // Whether the model has blocks at all (it has them for every node or for none).
        if nb > 0 {
            streamed.for_each_block(0, &mut |_, _| {})?;
        }
        // The groups by stored-size estimate, like an assembled level's.
        let bptr: Vec<usize> = (0..=nb).collect();
        let voff: Vec<usize> = std::iter::once(0)
            .chain((0..nb).scan(0, |acc, bi| {
                *acc += (streamed.rptr[bi + 1] - streamed.rptr[bi]) * 100;
                Some(*acc)
            }))
            .collect();
        streamed.groups = make_groups(&bptr, &voff);
        Some(streamed)
    }

    /// Calls `f(bj, block)` for every nonzero block of row block `bi` of `A_ff` (blocks of
    /// nodes without free DOFs dropped, partially constrained nodes restricted to their free
    /// components). `None` when the model has no blocks.
    fn for_each_block(&self, bi: usize, f: &mut dyn FnMut(usize, &[f64])) -> Option<()> {
        let d = self.model.dim();
        let i = self.block_node[bi];
        let rows = self.partial[bi].as_deref();
        let mut sub = [0.0; 9];
        let has = self.model.for_each_block(i, &mut |j, block| {
            let bj = self.node_block[j];
            if bj == u32::MAX {
                return;
            }
            let bj = bj as usize;
            match (rows, self.partial[bj].as_deref()) {
                (None, None) => f(bj, block),
                (r, c) => {
                    let all: Vec<usize> = (0..d).collect();
                    let (r, c) = (r.unwrap_or(&all), c.unwrap_or(&all));
                    for (p, &a) in r.iter().enumerate() {
                        for (q, &b) in c.iter().enumerate() {
                            sub[p * c.len() + q] = block[a * d + b];
                        }
                    }
                    f(bj, &sub[..r.len() * c.len()]);
                }
            }
        });
        has.then_some(())
    }

    /// The matrix assembled (for a level small enough to be the coarsest).
    pub fn assemble(&self) -> Vbr {
        let identity = Vbr::identity(&self.rptr);
        self.mul(&identity)
    }
}

impl LevelMatrix for Streamed<'_> {
    fn rptr(&self) -> &[usize] {
        &self.rptr
    }
    /// Counted by the first pass over the blocks ([`LevelMatrix::strong_neighbours`] or
    /// [`LevelMatrix::mul`]; 0 before).
    fn nnz(&self) -> usize {
        self.nnz.get().copied().unwrap_or(0)
    }
    fn bytes(&self) -> usize {
        8 * (self.diag.len() + self.rptr.len() + self.block_node.len()) + 4 * self.node_block.len()
    }
    fn diagonal(&self) -> Vec<f64> {
        self.diag.clone()
    }
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        self.op.apply(x, y)
    }
    /// Through a scratch vector kept between calls (twice per V-cycle on the finest level;
    /// the cycle runs on one thread at a time, like CG's products).
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]) {
        let mut t = self.scratch.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        t.resize(y.len(), 0.0);
        self.op.apply(x, &mut t);
        y.par_iter_mut().zip(t.par_iter()).for_each(|(y, t)| *y -= t);
    }
    /// As [`super::aggregate::strong_neighbours`], from one pass over the blocks (two when
    /// `theta > 0`: the diagonal blocks' norms first); counts the entries of `A_ff`.
    fn strong_neighbours(&self, theta: f64) -> (Vec<usize>, Vec<u32>) {
        let nb = self.n_row_blocks();
        let norm = |b: &[f64]| b.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diag: Vec<f64> = if theta > 0.0 {
            (0..nb)
                .into_par_iter()
                .map(|bi| {
                    let mut s = 0.0;
                    self.for_each_block(bi, &mut |bj, b| {
                        if bj == bi {
                            s = norm(b);
                        }
                    });
                    s
                })
                .collect()
        } else {
            Vec::new()
        };
        let lists: Vec<(Vec<u32>, usize)> = (0..nb)
            .into_par_iter()
            .map(|bi| {
                let mut strong = Vec::new();
                let mut entries = 0;
                self.for_each_block(bi, &mut |bj, b| {
                    entries += b.len();
                    let s = norm(b);
                    if bj != bi && s > 0.0 && (theta == 0.0 || s >= theta * (diag[bi] * diag[bj]).sqrt()) {
                        strong.push(bj as u32);
                    }
                });
                // Ascending, as the stored blocks of an assembled level are.
                strong.sort_unstable();
                (strong, entries)
            })
            .collect();
        let mut ptr = Vec::with_capacity(nb + 1);
        ptr.push(0);
        let mut idx = Vec::new();
        let mut nnz = 0;
        for (l, entries) in lists {
            idx.extend_from_slice(&l);
            ptr.push(idx.len());
            nnz += entries;
        }
        let _ = self.nnz.set(nnz);
        (ptr, idx)
    }
    /// Also counts the entries of `A_ff` the first time (when the strength pass did not), in
    /// the product's symbolic pass.
    fn mul(&self, b: &Vbr) -> Vbr {
        let entries = std::sync::atomic::AtomicUsize::new(0);
        // `new` checked that the model has blocks.
        let pattern = |bi: usize, f: &mut dyn FnMut(usize)| {
            let mut count = 0;
            let _ = self.for_each_block(bi, &mut |bj, block| {
                count += block.len();
                f(bj)
            });
            entries.fetch_add(count, std::sync::atomic::Ordering::Relaxed);
        };
        let row = |bi: usize, f: &mut dyn FnMut(usize, &[f64])| {
            let _ = self.for_each_block(bi, f);
        };
        let c = mul_rows(&self.rptr, &self.groups, &pattern, &row, b);
        let _ = self.nnz.set(entries.into_inner());
        c
    }
    fn for_each_row_block(&self, bi: usize, f: &mut dyn FnMut(usize, &[f64])) {
        let _ = self.for_each_block(bi, f);
    }
    /// From the blocks computed on demand, like [`LevelMatrix::mul`] (after it: the entries
    /// are counted by then).
    fn galerkin(&self, p: &Vbr, r: &Vbr) -> Vbr {
        let pattern = |bi: usize, f: &mut dyn FnMut(usize)| {
            let _ = self.for_each_block(bi, &mut |bj, _| f(bj));
        };
        let row = |bi: usize, f: &mut dyn FnMut(usize, &[f64])| {
            let _ = self.for_each_block(bi, f);
        };
        galerkin_rows(&self.rptr, &self.groups, &pattern, &row, p, r)
    }
}
