//! Sparse assembly of the stiffness `A` restricted to the free DOFs, pattern first and values
//! second ("symbolic once, numeric many").
//!
//! The column of free DOF `(i, a)` holds the rows `(k, c)` for `k` in `{i} U F_i` (ascending)
//! and every free component `c`. Because `A` is symmetric, the column of `(i, a)` is also its
//! row, so the CSC arrays are filled column by column, in parallel over nodes, with no triplet
//! sort. Values:
//!
//! ```text
//! A[(i,a),(i,c)] = sum_j w_ij e_a e_c,       A[(i,a),(k,c)] = -w_ik e_a e_c   (k in F_i).
//! ```
//!
//! Structurally zero entries of `e (x) e` (e.g. axis bonds) are kept so that the pattern does
//! not depend on values and can be refilled for any material on the same family.

use crate::BondOperator;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use linpd_core::par::for_each_node_slice;
use linpd_core::progress::{Progress, Task};
use linpd_core::sparse::Csc;
use linpd_core::DofMap;
use rayon::prelude::*;

/// The CSC pattern of the reduced stiffness, with the split of the value array per node.
#[derive(Debug, Clone)]
pub struct Pattern {
    symbolic: SymbolicSparseColMat<usize>,
    /// `node_start[i]..node_start[i + 1]` is the range of values in node `i`'s columns.
    node_start: Vec<usize>,
}

impl Pattern {
    /// Builds the pattern of `op` over the free DOFs of `dofs`.
    pub fn new(op: &BondOperator, dofs: &DofMap) -> Self {
        Self::new_counted(op, dofs, None)
    }

    /// [`Pattern::new`] counting the nodes done on `task` (by chunks of [`CHUNK`] nodes).
    fn new_counted(op: &BondOperator, dofs: &DofMap, task: Option<&Task<'_>>) -> Self {
        let d = op.dim();
        assert_eq!(dofs.n_dofs(), op.n_dofs(), "DOF map and operator disagree");
        let n = op.n_nodes();
        let free_comps = |k: usize| (0..d).filter(|&c| !dofs.is_constrained(d * k + c)).count();
        // Rows per column of node i (the same for each of its free components).
        let per_col: Vec<usize> = (0..n)
            .into_par_iter()
            .map(|i| free_comps(i) + op.family().neighbors(i).iter().map(|&k| free_comps(k as usize)).sum::<usize>())
            .collect();
        let mut col_ptr = Vec::with_capacity(dofs.n_free() + 1);
        let mut node_start = Vec::with_capacity(n + 1);
        col_ptr.push(0usize);
        node_start.push(0usize);
        for i in 0..n {
            for _ in 0..free_comps(i) {
                col_ptr.push(col_ptr.last().unwrap() + per_col[i]);
            }
            node_start.push(*col_ptr.last().unwrap());
        }
        let nnz = *col_ptr.last().unwrap();
        let mut row_idx = vec![0usize; nnz];
        for_each_node_slice(&mut row_idx, &node_start, |i, rows| {
            count(task, i);
            let mut pos = 0;
            let nf = free_comps(i);
            let len = per_col[i];
            for_merged(op, i, |k| {
                for c in 0..d {
                    if let Some(f) = dofs.free(d * k + c) {
                        for col in 0..nf {
                            rows[col * len + pos] = f;
                        }
                        pos += 1;
                    }
                }
            });
        });
        // SAFETY-free: the checked constructor validates sortedness and bounds.
        let symbolic = SymbolicSparseColMat::new_checked(dofs.n_free(), dofs.n_free(), col_ptr, None, row_idx);
        Pattern { symbolic, node_start }
    }

    /// The symbolic CSC structure.
    pub fn symbolic(&self) -> &SymbolicSparseColMat<usize> {
        &self.symbolic
    }
    /// Stored entries (both triangles).
    pub fn nnz(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Fills `values` (length [`Pattern::nnz`]) with the entries of `op`.
    ///
    /// One pass over `{i} U F_i` per node: each bond's `w e (x) e` is computed once, written
    /// negated into the off-diagonal block and accumulated into the diagonal block, which is
    /// written last at the position remembered for `k = i`.
    pub fn fill(&self, op: &BondOperator, dofs: &DofMap, values: &mut [f64]) {
        self.fill_counted(op, dofs, values, None)
    }

    /// [`Pattern::fill`] counting the nodes done on `task` (by chunks of [`CHUNK`] nodes).
    fn fill_counted(&self, op: &BondOperator, dofs: &DofMap, values: &mut [f64], task: Option<&Task<'_>>) {
        let d = op.dim();
        assert_eq!(values.len(), self.nnz());
        for_each_node_slice(values, &self.node_start, |i, vals| {
            count(task, i);
            let mut free_a = [0usize; 3];
            let mut nf = 0;
            for a in 0..d {
                if !dofs.is_constrained(d * i + a) {
                    free_a[nf] = a;
                    nf += 1;
                }
            }
            if nf == 0 {
                return;
            }
            let len = vals.len() / nf;
            let ws = op.weights(i);
            let mut diag = [[0.0; 3]; 3];
            let mut diag_pos = 0;
            let mut pos = 0;
            let mut bond = 0;
            for_merged(op, i, |k| {
                if k == i {
                    diag_pos = pos;
                    pos += (0..d).filter(|&c| !dofs.is_constrained(d * k + c)).count();
                    return;
                }
                let w = ws[bond];
                bond += 1;
                // In 1D e (x) e = 1: no unit vector needed.
                let e = if d == 1 { [1.0, 0.0, 0.0] } else { op.unit(i, k) };
                let mut block = [[0.0; 3]; 3];
                for a in 0..d {
                    for c in 0..d {
                        block[a][c] = w * e[a] * e[c];
                        diag[a][c] += block[a][c];
                    }
                }
                for c in 0..d {
                    if dofs.is_constrained(d * k + c) {
                        continue;
                    }
                    for (col, &a) in free_a[..nf].iter().enumerate() {
                        vals[col * len + pos] = -block[a][c];
                    }
                    pos += 1;
                }
            });
            let mut p = diag_pos;
            for c in 0..d {
                if dofs.is_constrained(d * i + c) {
                    continue;
                }
                for (col, &a) in free_a[..nf].iter().enumerate() {
                    vals[col * len + p] = diag[a][c];
                }
                p += 1;
            }
        });
    }
}

/// Nodes per step of the assembly's task: one atomic add per chunk, not per node.
const CHUNK: usize = 1024;
const _: () = assert!(CHUNK.is_power_of_two());

/// Counts a chunk of nodes on `task` at every [`CHUNK`]-th node (the nodes run in any order on
/// the rayon workers: the count is that of the chunks begun).
#[inline]
fn count(task: Option<&Task<'_>>, i: usize) {
    if let Some(t) = task {
        // `i % CHUNK == 0` (a power of two; `is_multiple_of` is newer than the MSRV 1.85).
        if i & (CHUNK - 1) == 0 {
            t.advance(CHUNK as u64);
        }
    }
}

/// `A_ff` of `op` on the free DOFs of `dofs` ([`Pattern::new`] then [`Pattern::fill`]) with a
/// task `"assembling"` on `progress` counting nodes: `2 n` steps, the pattern and the values.
pub fn assemble_free_with_progress(op: &BondOperator, dofs: &DofMap, progress: &dyn Progress) -> Csc {
    let n = op.n_nodes() as u64;
    let task = Task::start(progress, "assembling", Some(2 * n));
    let on = task.is_on().then_some(&task);
    let pattern = Pattern::new_counted(op, dofs, on);
    task.set(n, "");
    let mut values = vec![0.0; pattern.nnz()];
    pattern.fill_counted(op, dofs, &mut values, on);
    task.set(2 * n, "");
    Csc::new(pattern.symbolic().clone(), values)
}

/// Calls `f(k)` for `k` in `{i} U F_i`, ascending.
#[inline]
fn for_merged(op: &BondOperator, i: usize, mut f: impl FnMut(usize)) {
    let mut self_done = false;
    for &k in op.family().neighbors(i) {
        let k = k as usize;
        if !self_done && k > i {
            f(i);
            self_done = true;
        }
        f(k);
    }
    if !self_done {
        f(i);
    }
}

/// Assembles the reduced stiffness over the free DOFs of `dofs` (pattern and values).
pub fn assemble(op: &BondOperator, dofs: &DofMap) -> SparseColMat<usize, f64> {
    let pattern = Pattern::new(op, dofs);
    let mut values = vec![0.0; pattern.nnz()];
    pattern.fill(op, dofs, &mut values);
    SparseColMat::new(pattern.symbolic, values)
}
