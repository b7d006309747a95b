//! The field of the graded mesh at every lattice node: `u(x_k) = sum_c N_c(t) u_c` in the leaf
//! that covers node `k` (`N_c` the bilinear / trilinear shape functions, `t` the node's
//! reference coordinates in the leaf), each leaf corner `c` expanded into its masters when it
//! hangs. As a matrix `P` (`d n_lattice x d n_masters`), `u = P u_M`: the solution drawn on the
//! lattice, and `P^T f` the consistent nodal forces on the masters of forces `f` given on the
//! lattice (the virtual work of `f` on the interpolated field equals that of `P^T f` on `u_M`).

use super::{Cell, GradedMesh};

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
            match self.master_of(node) {
                Some(m) => row.push((m, n_c)),
                None => {
                    let h = self.hanging.binary_search_by_key(&node, |h| h.node).expect("a non-master node hangs");
                    for &(j, w) in &self.hanging[h].masters {
                        row.push((self.master_of(j).expect("masters are regular"), n_c * w));
                    }
                }
            }
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
