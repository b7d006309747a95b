//! The field of the graded mesh at every lattice node: `u(x_k) = sum_c N_c(t) u_c` in the leaf
//! that covers node `k` (`N_c` the bilinear / trilinear shape functions, `t` the node's
//! reference coordinates in the leaf), each leaf corner `c` expanded into its masters when it
//! hangs. As a matrix `P` (`d n_lattice x d n_masters`), `u = P u_M`: the solution drawn on the
//! lattice, and `P^T f` the consistent nodal forces on the masters of forces `f` given on the
//! lattice (the virtual work of `f` on the interpolated field equals that of `P^T f` on `u_M`).

use super::{Cell, GradedMesh};
use rayon::prelude::*;

impl GradedMesh {
    /// The leaf covering lattice node `k`: the leaf of the level-0 cell whose lowest corner is
    /// `min(k, n - 2)` per axis (a node on a far face belongs to the last cell); `None` when
    /// that cell is void ([`GradedMesh::with_voids`]).
    pub fn leaf_at(&self, k: [usize; 3]) -> Option<Cell> {
        let d = self.dim();
        let b = self.lattice.cells();
        let c = [0, 1, 2].map(|a| if a < d { k[a].min(self.lattice.n[a] - 2) } else { 0 });
        let i = b.index(c);
        if self.void.get(i).copied().unwrap_or(false) {
            return None;
        }
        let level = self.leaf_level[i];
        let side = 1usize << level;
        Some(Cell { level, origin: [0, 1, 2].map(|a| c[a] / side * side) })
    }

    /// The distinct leaves covering the lattice cells with corner `k` (up to `2^d`, fewer at
    /// the box's faces, none of a void cell).
    pub fn leaves_around(&self, k: [usize; 3]) -> Vec<Cell> {
        let (d, n) = (self.dim(), self.lattice.n);
        let mut out: Vec<Cell> = Vec::new();
        for bits in 0..1usize << d {
            // the lattice cell with corner k on the side of `bits` (lower along the set axes)
            let cell = [0, 1, 2].map(|a| {
                if a >= d {
                    Some(0)
                } else if bits >> a & 1 == 1 {
                    k[a].checked_sub(1)
                } else {
                    (k[a] + 1 < n[a]).then_some(k[a])
                }
            });
            if let [Some(c0), Some(c1), Some(c2)] = cell {
                if let Some(e) = self.leaf_at([c0, c1, c2]) {
                    if !out.contains(&e) {
                        out.push(e);
                    }
                }
            }
        }
        out
    }

    /// `(P^T v)_m` per master for one value `value(k)` per lattice node `k`, leaf by leaf: each
    /// leaf's corners are expanded into their masters once, then every node the leaf covers
    /// (those [`GradedMesh::leaf_at`] gives it) adds `value(k) N_c(t)` through them. The same
    /// sums as [`GradedMesh::interpolation_row`] node by node (a master node is a corner of its
    /// leaf, where `N_c = 1`; a master whose own cell is void adds its value alone), in
    /// another order, without a search per node.
    pub fn restrict_values(&self, value: &(dyn Fn([usize; 3]) -> f64 + Sync)) -> Vec<f64> {
        let (d, n, n_m) = (self.dim(), self.lattice.n, self.n_masters);
        // at most a few accumulators of the masters' size per thread
        let chunk = self.cells.len().div_ceil(4 * rayon::current_num_threads()).max(1);
        let mut sums = self
            .cells
            .par_iter()
            .with_min_len(chunk)
            .fold(
                || vec![0.0; n_m],
                |mut out, e| {
                    let side = e.side();
                    let corners: Vec<Vec<(usize, f64)>> =
                        self.cell_nodes(e).into_iter().map(|node| self.masters_of_node(node)).collect();
                    // the nodes the leaf covers: its lower faces in, its upper ones out, but for
                    // the box's far faces (leaf_at: a node there belongs to the last cell)
                    let hi = [0, 1, 2].map(|a| {
                        if a >= d {
                            1
                        } else if e.origin[a] + side == n[a] - 1 {
                            n[a]
                        } else {
                            e.origin[a] + side
                        }
                    });
                    let lo = [0, 1, 2].map(|a| if a < d { e.origin[a] } else { 0 });
                    for k2 in lo[2]..hi[2] {
                        for k1 in lo[1]..hi[1] {
                            for k0 in lo[0]..hi[0] {
                                let k = [k0, k1, k2];
                                let v = value(k);
                                if v == 0.0 {
                                    continue;
                                }
                                let t = [0, 1, 2].map(|a| (k[a] as f64 - e.origin[a] as f64) / side as f64);
                                for (c, masters) in corners.iter().enumerate() {
                                    let n_c: f64 =
                                        (0..d).map(|a| if c >> a & 1 == 1 { t[a] } else { 1.0 - t[a] }).product();
                                    if n_c != 0.0 {
                                        masters.iter().for_each(|&(m, w)| out[m] += v * n_c * w);
                                    }
                                }
                            }
                        }
                    }
                    out
                },
            )
            .reduce(|| vec![0.0; n_m], |a, b| a.into_iter().zip(b).map(|(x, y)| x + y).collect());
        // a master whose own cell is void (a corner of a leaf beside a hole) is covered by no
        // leaf but is itself in P
        for (i, &k) in self.nodes.iter().enumerate() {
            if let (Some(m), None) = (self.master_of(i), self.leaf_at(k)) {
                sums[m] += value(k);
            }
        }
        sums
    }

    /// Node `node` as masters: itself with weight 1, or a hanging node's masters and weights.
    fn masters_of_node(&self, node: usize) -> Vec<(usize, f64)> {
        match self.master_of(node) {
            Some(m) => vec![(m, 1.0)],
            None => {
                let h = self.hanging.binary_search_by_key(&node, |h| h.node).expect("a non-master node hangs");
                self.hanging[h]
                    .masters
                    .iter()
                    .map(|&(j, w)| (self.master_of(j).expect("masters are regular"), w))
                    .collect()
            }
        }
    }

    /// Row `k` of `P` (see the module docs): `(master, weight)` for lattice node `k`, the
    /// weights summing to 1; a master node is itself with weight 1; empty for a node of no
    /// leaf (one whose cells are all void, [`GradedMesh::with_voids`]).
    pub fn interpolation_row(&self, k: [usize; 3]) -> Vec<(usize, f64)> {
        let d = self.dim();
        if let Some(i) = self.node_at(k) {
            if let Some(m) = self.master_of(i) {
                return vec![(m, 1.0)];
            }
        }
        let Some(e) = self.leaf_at(k) else { return Vec::new() };
        let s = e.side() as f64;
        let t = [0, 1, 2].map(|a| (k[a] as f64 - e.origin[a] as f64) / s);
        let mut row: Vec<(usize, f64)> = Vec::new();
        for (c, node) in self.cell_nodes(&e).into_iter().enumerate() {
            let n_c: f64 = (0..d).map(|a| if c >> a & 1 == 1 { t[a] } else { 1.0 - t[a] }).product();
            if n_c == 0.0 {
                continue;
            }
            row.extend(self.masters_of_node(node).into_iter().map(|(m, w)| (m, n_c * w)));
        }
        row.sort_unstable_by_key(|e| e.0);
        row.dedup_by(|b, a| {
            if a.0 == b.0 {
                a.1 += b.1;
                true
            } else {
                false
            }
        });
        row
    }
}
