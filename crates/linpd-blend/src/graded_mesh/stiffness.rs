//! The stiffness over the master DOFs, `K_M = T^T (sum_e K_e) T`, and the prolongation `T`.

use super::element::{add_element_row, element_matrix, ElementBlocks};
use super::{Cell, GradedMesh};
use faer::sparse::{SparseColMat, Triplet};
use linpd_core::sparse::Csc;

impl GradedMesh {
    /// Row `i` of `T` per node: `(master, w)`; a master node is itself with weight 1.
    fn expansion(&self) -> Vec<Vec<(usize, f64)>> {
        let mut t: Vec<Vec<(usize, f64)>> =
            (0..self.nodes.len()).map(|i| self.master_of(i).map(|m| vec![(m, 1.0)]).unwrap_or_default()).collect();
        for h in &self.hanging {
            t[h.node] = h.masters.iter().map(|&(j, w)| (self.master_of(j).expect("masters are regular"), w)).collect();
        }
        t
    }

    /// `T` (`d n_nodes x d n_masters`): `u = T u_M` over all nodes, hanging ones included.
    pub fn prolongation(&self) -> Csc {
        let d = self.dim();
        let mut trip = Vec::new();
        for (i, row) in self.expansion().iter().enumerate() {
            for &(m, w) in row {
                for a in 0..d {
                    trip.push(Triplet::new(d * i + a, d * m + a, w));
                }
            }
        }
        SparseColMat::try_new_from_triplets(d * self.nodes.len(), d * self.n_masters, &trip).expect("indices in range")
    }

    /// `u = T u_M`: the displacement of every node (hanging ones interpolated) from the
    /// masters' (`d` values per master).
    pub fn expand(&self, u_master: &[f64]) -> Vec<f64> {
        let d = self.dim();
        assert_eq!(u_master.len(), d * self.n_masters, "one value per master DOF");
        let mut u = vec![0.0; d * self.nodes.len()];
        for (i, row) in self.expansion().iter().enumerate() {
            for &(m, w) in row {
                for a in 0..d {
                    u[d * i + a] += w * u_master[d * m + a];
                }
            }
        }
        u
    }

    /// The triplets [`GradedMesh::stiffness`] assembles: per leaf `(d sum_corners |T_c|)^2`,
    /// `|T_c|` the masters of corner `c` (1, or 2-4 for a hanging one).
    pub fn stiffness_triplets(&self) -> usize {
        let d = self.dim();
        let t = self.expansion();
        self.cells
            .iter()
            .map(|e| {
                let s: usize = self.cell_nodes(e).iter().map(|&c| t[c].len()).sum();
                (d * s).pow(2)
            })
            .sum()
    }

    /// `K_M = T^T K T` over the master DOFs (`d m + a`, see [`GradedMesh::master_of`]): each
    /// leaf's element matrix (module `element`, `E = C vol_e` with `C =
    /// c_of_cell(cell)` as a `3 x 3 x 3 x 3` tensor, see the module docs) scattered through the
    /// rows of `T` of its corners: `K_M[(m,a),(m',b)] += w_r w_l K_e[(r,a),(l,b)]`.
    pub fn stiffness(&self, c_of_cell: &dyn Fn(&Cell) -> [f64; 81]) -> Csc {
        let d = self.dim();
        let nc = 1usize << d;
        let t = self.expansion();
        let mut trip = Vec::with_capacity(self.stiffness_triplets());
        for e in &self.cells {
            let s = self.lattice.h * e.side() as f64;
            let vol = s.powi(d as i32);
            let ce = c_of_cell(e).map(|c| c * vol);
            let k = element_matrix(d, s, &ce);
            let corners = self.cell_nodes(e);
            for (r, &nr) in corners.iter().enumerate() {
                for (l, &nl) in corners.iter().enumerate() {
                    for &(mr, wr) in &t[nr] {
                        for &(ml, wl) in &t[nl] {
                            let w = wr * wl;
                            for a in 0..d {
                                for b in 0..d {
                                    let v = k[(d * r + a) * d * nc + d * l + b];
                                    trip.push(Triplet::new(d * mr + a, d * ml + b, w * v));
                                }
                            }
                        }
                    }
                }
            }
        }
        let n = d * self.n_masters;
        SparseColMat::try_new_from_triplets(n, n, &trip).expect("indices in range")
    }
}

/// The masters' rows of `K_M` one at a time ([`RowAssembler::stiffness_row`]): per master the
/// nodes whose rows of `T` hold it (its own node with weight 1, the hanging nodes it masters).
pub struct RowAssembler<'a> {
    mesh: &'a GradedMesh,
    t: Vec<Vec<(usize, f64)>>,
    dependents: Vec<Vec<(usize, f64)>>,
}

impl GradedMesh {
    /// What [`RowAssembler::stiffness_row`] reads: `T` by node and by master.
    pub fn row_assembler(&self) -> RowAssembler<'_> {
        let t = self.expansion();
        let mut dependents: Vec<Vec<(usize, f64)>> = vec![Vec::new(); self.n_masters];
        for (n, row) in t.iter().enumerate() {
            for &(m, w) in row {
                dependents[m].push((n, w));
            }
        }
        RowAssembler { mesh: self, t, dependents }
    }

    /// The leaves with node `i` as a corner: those of [`GradedMesh::leaves_around`] its site
    /// (a hanging node lies inside an edge or face of a coarser leaf, which is not among them).
    pub fn leaves_at_node(&self, i: usize) -> Vec<Cell> {
        let (d, k) = (self.dim(), self.nodes[i]);
        let mut out = self.leaves_around(k);
        out.retain(|e| (0..1usize << d).any(|c| e.corner(d, c) == k));
        out
    }
}

impl RowAssembler<'_> {
    /// Block row of master `m` of `K_M = T^T K T` (as [`GradedMesh::stiffness`], `d x d`
    /// blocks row-major in `3 x 3` arrays, sorted by master): `sum_n T_nm K[n, :] T` over the
    /// nodes `n` of `m`, each `K[n, :]` the rows of `n` in the elements of its leaves. Built
    /// directly (no triplets), so that only the rows a caller needs are made, in parallel.
    pub fn stiffness_row(&self, m: usize, c_of_cell: &dyn Fn(&Cell) -> [f64; 81]) -> Vec<(usize, [f64; 9])> {
        struct Dense([[f64; 9]; 8]);
        impl ElementBlocks for Dense {
            fn block(&mut self, l: usize) -> &mut [f64; 9] {
                &mut self.0[l]
            }
        }
        let mesh = self.mesh;
        let d = mesh.dim();
        let mut row: Vec<(usize, [f64; 9])> = Vec::new();
        for &(n, w_n) in &self.dependents[m] {
            for e in mesh.leaves_at_node(n) {
                let s = mesh.lattice.h * e.side() as f64;
                let ce = c_of_cell(&e).map(|c| c * s.powi(d as i32));
                let corners = mesh.cell_nodes(&e);
                let r = corners.iter().position(|&c| c == n).expect("a leaf at the node has it as a corner");
                let mut blocks = Dense([[0.0; 9]; 8]);
                add_element_row(d, s, &ce, r, w_n, &mut blocks);
                for (l, &nl) in corners.iter().enumerate() {
                    for &(ml, wl) in &self.t[nl] {
                        let at = match row.iter().position(|x| x.0 == ml) {
                            Some(p) => p,
                            None => {
                                row.push((ml, [0.0; 9]));
                                row.len() - 1
                            }
                        };
                        for (x, y) in row[at].1.iter_mut().zip(&blocks.0[l]) {
                            *x += wl * y;
                        }
                    }
                }
            }
        }
        row.sort_unstable_by_key(|x| x.0);
        row
    }
}
