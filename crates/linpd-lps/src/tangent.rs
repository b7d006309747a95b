//! The analytic tangent stiffness `A = -dF/du` of the LPS force at the reference
//! configuration, assembled sparse (CSC, force form, symmetric) or applied matrix-free.
//!
//! # Derivation
//!
//! At `u = 0` every `e` and `theta` vanish, so the geometric (second-derivative-of-`e`)
//! terms drop out and `A` is the Hessian of the energy with the linearized extension
//! `e_ij ~ b_ij . u = n_ij . (u_j - u_i)`, `n_ij = xi / |xi|`. With
//!
//! ```text
//! g_k = d theta_k / du:  g_k[q] = (d/m_k) omega nu V_q xi_kq  (q in F_k),
//!                        g_k[k] = -sum_{q in F_k} g_k[q],
//! ```
//!
//! and `sum_j omega |xi| nu V_j b_kj = (m_k / d) g_k`, the Hessian of
//! `sum_k V_k [kappa theta_k^2/2 + (aG/(2 m_k)) sum_j omega (e - theta_k |xi|/d)^2 nu V_j]`
//! collapses to a bond part plus one rank-one term per node:
//!
//! ```text
//! A = A_pair + sum_k C_k g_k g_k^T,       C_k = V_k (kappa_k - a G_k / d^2),
//! A_pair = sum_{bonds i-j} s_ij (n n^T) on (i,i), (j,j) and -s_ij (n n^T) on (i,j), (j,i),
//! s_ij   = V_i V_j a G omega nu (1/m_i + 1/m_j).
//! ```
//!
//! In 3D `C_k = V_k (K - 5G/3)` (the `(3K - 5G)` term of Algorithm 2) and `aG = 15 G`. `C_k`
//! may be negative (`G > 3K/5`), but `A` is positive semi-definite because it is the Hessian
//! of a sum of squares; the rigid motions are in its null space (`b . u = 0` for them).
//!
//! # Assembly without dense products
//!
//! `g_k` is supported on `{k} U F_k`, so `g_k g_k^T` couples nodes up to `2 delta` apart. The
//! pattern of column node `p` is the Minkowski difference `O - O` of the family's lattice
//! offsets `O` (with `0`), clipped to the lattice; it is built once ([`TangentPattern`]) in
//! lattice units, rows ascending, with structural zeros kept so that it does not depend on
//! values. Values are filled in parallel over column nodes: for column `p`, the bonds of `p`
//! give the pair blocks and every `k in {p} U F_p` adds `C_k g_k[q] g_k[p]^T` to rows
//! `q in {k} U F_k`. Cost `O(n |F|^2 d^2)`; no matrix product is formed. The terms of one
//! column are [`LpsModel::column_terms`]'s, the one copy of these formulas.
//!
//! # Block rows on demand
//!
//! A rank of a distributed solve needs block rows, not columns: `A` is symmetric, so block row
//! `i` is column `i`'s terms transposed ([`LpsModel::tangent_block_row`], the model's
//! [`linpd_core::Model::for_each_block`]), computed from the families of `i` and of its
//! partners: `O(|F|^2 d^2)` per node and nothing else held.
//!
//! The matrix-free apply uses the factored form: first `theta_k = g_k . u` for all `k`
//! (the linearized dilatation), then `y_p = (A_pair u)_p + sum_{k in {p} U F_p} C_k theta_k
//! g_k[p]`, the scatter `sum_k C_k g_k theta_k` written as a gather so that it runs in
//! parallel over nodes without write conflicts.

use crate::model::far;
use crate::LpsModel;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use linpd_core::par::for_each_node_slice;
use rayon::prelude::*;
use std::collections::BTreeSet;

impl LpsModel {
    /// `C_k = V_k (kappa - a G / d^2)`, the coefficient of `g_k g_k^T`.
    pub fn dilatation_coefficient(&self, k: usize) -> f64 {
        let d = self.dim as f64;
        self.volumes[k] * (self.kappa_at(k) - self.a_g_at(k) / (d * d))
    }

    /// `g_k[k] = -(d/m_k) sum_q omega nu V_q xi_kq` for every node (zero for full families).
    fn g_self(&self) -> Vec<[f64; 3]> {
        (0..self.n_nodes()).into_par_iter().map(|k| self.g_self_at(k)).collect()
    }

    /// `g_k[k]` of one node, from its family alone.
    fn g_self_at(&self, k: usize) -> [f64; 3] {
        let d = self.dim as f64;
        let mut s = [0.0; 3];
        for (q, w, _) in self.bonds(k) {
            let xi = self.bond_vector(k, q);
            for a in 0..3 {
                s[a] -= d / self.m[k] * w * xi[a];
            }
        }
        s
    }

    /// The pair part's bonds of node `i`: `f(j, s_ij, w_ji, xi_ij)` for every bond, with
    /// `s_ij = V_i (a G_i w_ij / m_i + a G_j w_ji^far / m_j) / |xi|^2` (`A_pair`'s block is
    /// `s_ij xi xi^T`) and `w_ji` the weight node `j` gives its bond to `i`. The one copy of the
    /// pair stiffness: the column terms, the apply, the diagonal and [`crate::PairPart`] read it.
    pub(crate) fn for_each_pair_bond(&self, i: usize, mut f: impl FnMut(usize, f64, f64, &[f64; 3])) {
        let v = self.volumes[i];
        for (j, w, w_ji, r) in self.bond_pairs(i) {
            let xi = self.bond_vector(i, j);
            let w_far = far(w_ji, v, self.volumes[j]);
            let s = v * (self.a_g_at(i) * w / self.m[i] + self.a_g_at(j) * w_far / self.m[j]) / (r * r);
            f(j, s, w_ji, &xi);
        }
    }

    /// The terms of block column `p` of the tangent, from the families of `p` and of its
    /// partners only: `add(q, s, x, y)` for every term `A[(q, c), (p, a)] += s x[c] y[a]`, `q`
    /// in the two-hop neighbourhood `U_{k in {p} U F_p} ({k} U F_k)`. `g_self(k)` is `g_k[k]`
    /// (precomputed for all nodes by the assembly, computed on demand by the block rows). The
    /// one copy of the per-node formulas of the module docs: the assembly
    /// ([`TangentPattern::fill`]) and the block rows ([`linpd_core::Model::for_each_block`],
    /// through the symmetry of `A`) both sum these terms.
    pub fn column_terms(
        &self,
        p: usize,
        g_self: impl Fn(usize) -> [f64; 3],
        mut add: impl FnMut(usize, f64, &[f64; 3], &[f64; 3]),
    ) {
        let df = self.dim as f64;
        let c = |k: usize| self.dilatation_coefficient(k);
        // Pair part.
        self.for_each_pair_bond(p, |j, s, _, xi| {
            add(p, s, xi, xi);
            add(j, -s, xi, xi);
        });
        // Dilatation part: k = p, then k in F_p.
        let gp = g_self(p);
        add(p, c(p), &gp, &gp);
        for (q, w, _) in self.bonds(p) {
            let xi = self.bond_vector(p, q);
            let g = df / self.m[p] * w;
            add(q, c(p) * g, &xi, &gp);
        }
        for (k, _, w_kp, _) in self.bond_pairs(p) {
            // g_k[p] = (d/m_k) w_kp xi_kp = -(d/m_k) w_kp xi_pk, w_kp = omega_k nu V_p.
            let xi_pk = self.bond_vector(p, k);
            let gkp_s = -df / self.m[k] * w_kp;
            let gkp = [gkp_s * xi_pk[0], gkp_s * xi_pk[1], gkp_s * xi_pk[2]];
            add(k, c(k), &g_self(k), &gkp);
            for (q, w, _) in self.bonds(k) {
                let xi = self.bond_vector(k, q);
                let g = df / self.m[k] * w;
                add(q, c(k) * g, &xi, &gkp);
            }
        }
    }

    /// Block row `i` of the tangent, `f(j, A_ij)` (row-major `d x d`) for every node `j` of the
    /// two-hop neighbourhood `{i} U F_i U_{k in F_i} F_k` (ascending, `j = i` included, each
    /// once), from the families of `i` and of its partners only: `O(|F|^2 d^2)` operations and
    /// `O(|F|^2)` memory, nothing assembled. `A` is symmetric (the Hessian of an energy), so
    /// block row `i` is block column `i` transposed: the terms of column `i`
    /// ([`LpsModel::column_terms`], the assembly's own formulas) give `A[(j, c), (i, a)]`,
    /// stored here as `A[(i, a), (j, c)]`. The entries equal the assembled tangent's up to the
    /// rounding of the same sums taken from the other end (`A_ij` is summed in column `i` here,
    /// in column `j` by the assembly).
    pub fn tangent_block_row(&self, i: usize, mut f: impl FnMut(usize, &[f64])) {
        let d = self.dim;
        let fam_i = self.family.neighbors(i);
        let nodes = self.two_hop_nodes(i);
        // g_k[k] of i and of its partners (the only k the terms of column i read), once each
        let g: Vec<[f64; 3]> =
            std::iter::once(i).chain(fam_i.iter().map(|&k| k as usize)).map(|k| self.g_self_at(k)).collect();
        let g_of = |k: usize| -> [f64; 3] {
            if k == i {
                return g[0];
            }
            // every k asked for is a partner of i (families are sorted)
            g[1 + fam_i.binary_search(&(k as u32)).unwrap_or_else(|_| unreachable!("{k} is not a partner of {i}"))]
        };
        let mut blocks = vec![[0.0f64; 9]; nodes.len()];
        self.column_terms(i, g_of, |q, s, x, y| {
            let r = nodes.binary_search(&q).unwrap_or_else(|_| unreachable!("{q} is not within two hops of {i}"));
            for a in 0..d {
                for c in 0..d {
                    blocks[r][a * d + c] += s * x[c] * y[a];
                }
            }
        });
        for (j, b) in nodes.iter().zip(&blocks) {
            f(*j, &b[..d * d]);
        }
    }

    /// The nodes of block row `i` of the tangent, ascending: `i`, its partners and theirs.
    pub fn two_hop_nodes(&self, i: usize) -> Vec<usize> {
        let family = &self.family;
        let mut nodes: Vec<usize> = vec![i];
        for &k in family.neighbors(i) {
            nodes.push(k as usize);
            nodes.extend(family.neighbors(k as usize).iter().map(|&q| q as usize));
        }
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }

    /// The diagonal of `A` over all DOFs without assembling it, `O(|F|)` per node: the
    /// diagonal of the block
    ///
    /// ```text
    /// A_pp = sum_{j in F_p} s_pj xi xi^T + sum_{k in {p} U F_p} C_k g_k[p] g_k[p]^T,
    /// g_k[p] = (d/m_k) w_kp xi_kp (k != p),   g_p[p] = -(d/m_p) sum_q w_pq xi_pq,
    /// ```
    ///
    /// the terms of [`LpsModel::column_terms`] whose row and column node are both `p`.
    pub fn tangent_diagonal(&self) -> Vec<f64> {
        let d = self.dim;
        let df = d as f64;
        let c = |k: usize| self.dilatation_coefficient(k);
        let mut out = vec![0.0; self.n_dofs()];
        out.par_chunks_mut(d).enumerate().for_each(|(p, o)| {
            let gp = self.g_self_at(p);
            for a in 0..d {
                o[a] = c(p) * gp[a] * gp[a];
            }
            self.for_each_pair_bond(p, |j, s, w_jp, xi| {
                let g = df / self.m[j] * w_jp;
                for a in 0..d {
                    o[a] += (s + c(j) * g * g) * xi[a] * xi[a];
                }
            });
        });
        out
    }

    /// Linearized dilatation `theta_k = g_k . u` of every node.
    pub fn linearized_theta(&self, u: &[f64]) -> Vec<f64> {
        assert_eq!(u.len(), self.n_dofs(), "displacement length");
        let d = self.dim;
        (0..self.n_nodes())
            .into_par_iter()
            .map(|k| {
                let mut s = 0.0;
                for (q, w, _) in self.bonds(k) {
                    let xi = self.bond_vector(k, q);
                    for a in 0..d {
                        s += w * xi[a] * (u[d * q + a] - u[d * k + a]);
                    }
                }
                d as f64 / self.m[k] * s
            })
            .collect()
    }

    /// `y = A u` without storing `A`, in the factored form `A_pair u + sum_k C_k g_k (g_k . u)`.
    pub fn apply_tangent(&self, u: &[f64], y: &mut [f64]) {
        assert_eq!(y.len(), self.n_dofs(), "output length");
        let theta = self.linearized_theta(u);
        let g_self = self.g_self();
        let d = self.dim;
        let df = d as f64;
        let c = |k: usize| self.dilatation_coefficient(k);
        y.par_chunks_mut(d).enumerate().for_each(|(p, yp)| {
            yp.iter_mut().for_each(|x| *x = 0.0);
            // k = p.
            for a in 0..d {
                yp[a] += c(p) * theta[p] * g_self[p][a];
            }
            self.for_each_pair_bond(p, |j, s, w_jp, xi| {
                // Pair: s (xi . (u_p - u_j)) xi.
                let mut proj = 0.0;
                for a in 0..d {
                    proj += xi[a] * (u[d * p + a] - u[d * j + a]);
                }
                // k = j: g_j[p] = (d/m_j) w_jp xi_jp = -(d/m_j) w_jp xi_pj, with w_jp the
                // weight j gives its bond to p (omega_j nu V_p).
                let gk = -df / self.m[j] * w_jp;
                for a in 0..d {
                    yp[a] += s * proj * xi[a] + c(j) * theta[j] * gk * xi[a];
                }
            });
        });
    }
}

/// The CSC pattern of the LPS tangent over all DOFs (both triangles): on a lattice built in
/// lattice units (the offsets `O - O`), on a point cloud from the family (the two-hop
/// neighbourhood `U_{k in {p} U F_p} ({k} U F_k)` of every column node `p`).
#[derive(Debug, Clone)]
pub struct TangentPattern {
    symbolic: SymbolicSparseColMat<usize>,
    /// `node_start[p]..node_start[p + 1]`: the values of node `p`'s `d` columns.
    node_start: Vec<usize>,
    /// Lattice models: offsets `O - O` sorted by node-number order (last axis slowest), a
    /// dense table from an offset in `[-2R, 2R]^3` to its index in `offsets` (or `usize::MAX`),
    /// and `R`. `None` for point clouds (rows are found by binary search in the column).
    lattice: Option<LatticeRows>,
}

#[derive(Debug, Clone)]
struct LatticeRows {
    offsets: Vec<[i64; 3]>,
    table: Vec<usize>,
    reach: i64,
}

impl TangentPattern {
    /// Builds the pattern of `model`'s tangent.
    pub fn new(model: &LpsModel) -> Self {
        let n = model.n_nodes();
        let Some(grid) = model.grid.as_ref() else {
            return Self::from_per_node(model, two_hop_rows(model), None);
        };
        let lat = &model.lattice;
        let mut family_offsets: BTreeSet<[i64; 3]> = BTreeSet::new();
        family_offsets.insert([0, 0, 0]);
        for i in 0..n {
            for &j in model.family.neighbors(i) {
                let (a, b) = (lat[i], lat[j as usize]);
                family_offsets.insert([b[0] - a[0], b[1] - a[1], b[2] - a[2]]);
            }
        }
        let reach = family_offsets.iter().flatten().fold(0i64, |r, &x| r.max(x.abs()));
        let mut set: BTreeSet<[i64; 3]> = BTreeSet::new();
        for s in &family_offsets {
            for t in &family_offsets {
                // Keyed (z, y, x) so that BTreeSet order is node-number order.
                set.insert([s[2] - t[2], s[1] - t[1], s[0] - t[0]]);
            }
        }
        let offsets: Vec<[i64; 3]> = set.into_iter().map(|k| [k[2], k[1], k[0]]).collect();
        let w = (4 * reach + 1) as usize;
        let mut table = vec![usize::MAX; w * w * w];
        for (idx, o) in offsets.iter().enumerate() {
            table[table_index(o, reach)] = idx;
        }
        let rows_of = |p: usize| -> Vec<usize> {
            let l = lat[p];
            offsets.iter().filter_map(|o| grid.node_at([l[0] + o[0], l[1] + o[1], l[2] + o[2]])).collect()
        };
        let per_node: Vec<Vec<usize>> = (0..n).into_par_iter().map(rows_of).collect();
        Self::from_per_node(model, per_node, Some(LatticeRows { offsets, table, reach }))
    }

    /// The CSC structure from the row nodes of every column node (ascending).
    fn from_per_node(model: &LpsModel, per_node: Vec<Vec<usize>>, lattice: Option<LatticeRows>) -> Self {
        let (n, d) = (model.n_nodes(), model.dim);
        let mut col_ptr = Vec::with_capacity(d * n + 1);
        let mut node_start = Vec::with_capacity(n + 1);
        col_ptr.push(0usize);
        node_start.push(0usize);
        for rows in &per_node {
            for _ in 0..d {
                col_ptr.push(col_ptr.last().unwrap() + d * rows.len());
            }
            node_start.push(*col_ptr.last().unwrap());
        }
        let mut row_idx = Vec::with_capacity(*col_ptr.last().unwrap());
        for rows in &per_node {
            for _ in 0..d {
                for &q in rows {
                    for c in 0..d {
                        row_idx.push(d * q + c);
                    }
                }
            }
        }
        let symbolic = SymbolicSparseColMat::new_checked(d * n, d * n, col_ptr, None, row_idx);
        TangentPattern { symbolic, node_start, lattice }
    }

    /// The row nodes of column node `p` (ascending): every `d`-th row of its first column.
    fn row_nodes(&self, p: usize, d: usize) -> impl Iterator<Item = usize> + '_ {
        let col = self.symbolic.col_ptr()[d * p]..self.symbolic.col_ptr()[d * p + 1];
        self.symbolic.row_idx()[col].iter().step_by(d).map(move |&r| r / d)
    }

    /// The symbolic CSC structure.
    pub fn symbolic(&self) -> &SymbolicSparseColMat<usize> {
        &self.symbolic
    }
    /// Stored entries (both triangles, structural zeros included).
    pub fn nnz(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Fills `values` (length [`TangentPattern::nnz`]) with the tangent of `model`, which
    /// must be the model (or one with the same family) the pattern was built for.
    pub fn fill(&self, model: &LpsModel, values: &mut [f64]) {
        assert_eq!(values.len(), self.nnz(), "values length");
        let d = model.dim;
        let lat = &model.lattice;
        let g_self = model.g_self();
        for_each_node_slice(values, &self.node_start, |p, vals| {
            let nrows = vals.len() / (d * d);
            // The slot of row node q in this column: on a lattice through the offset table, on a
            // point cloud by binary search in the column's sorted row nodes.
            let (slot, cloud_rows) = match (&self.lattice, model.grid.as_ref()) {
                (Some(l), Some(grid)) => {
                    let lp = lat[p];
                    let mut slot = vec![usize::MAX; l.offsets.len()];
                    let mut k = 0;
                    for (idx, o) in l.offsets.iter().enumerate() {
                        if grid.node_at([lp[0] + o[0], lp[1] + o[1], lp[2] + o[2]]).is_some() {
                            slot[idx] = k;
                            k += 1;
                        }
                    }
                    debug_assert_eq!(k, nrows);
                    (slot, Vec::new())
                }
                _ => (Vec::new(), self.row_nodes(p, d).collect::<Vec<usize>>()),
            };
            let pos = |q: usize| -> usize {
                match &self.lattice {
                    Some(l) => {
                        let (lq, lp) = (lat[q], lat[p]);
                        let o = [lq[0] - lp[0], lq[1] - lp[1], lq[2] - lp[2]];
                        slot[l.table[table_index(&o, l.reach)]]
                    }
                    // every q reached below is in the two-hop neighbourhood the pattern holds
                    None => cloud_rows.binary_search(&q).unwrap_or_else(|_| unreachable!("row {q} not in column {p}")),
                }
            };
            // blocks[row][c][a] = A[(q, c), (p, a)].
            let mut blocks = vec![[[0.0f64; 3]; 3]; nrows];
            model.column_terms(
                p,
                |k| g_self[k],
                |q, s, x, y| {
                    let r = pos(q);
                    for cc in 0..d {
                        for a in 0..d {
                            blocks[r][cc][a] += s * x[cc] * y[a];
                        }
                    }
                },
            );
            let len = d * nrows;
            for (r, b) in blocks.iter().enumerate() {
                for a in 0..d {
                    for cc in 0..d {
                        vals[a * len + d * r + cc] = b[cc][a];
                    }
                }
            }
        });
    }
}

#[inline]
fn table_index(o: &[i64; 3], reach: i64) -> usize {
    let w = 4 * reach + 1;
    let s = |x: i64| (x + 2 * reach) as usize;
    s(o[0]) + w as usize * (s(o[1]) + w as usize * s(o[2]))
}

/// Assembles the tangent `A` (all DOFs, force form `F ~ -A u`) of `model`.
pub fn assemble_tangent(model: &LpsModel) -> SparseColMat<usize, f64> {
    let pattern = TangentPattern::new(model);
    let mut values = vec![0.0; pattern.nnz()];
    pattern.fill(model, &mut values);
    SparseColMat::new(pattern.symbolic, values)
}

/// The two-hop row nodes of every column node of a point-cloud model: `p`, its family, and the
/// families of its family members (ascending, unique).
fn two_hop_rows(model: &LpsModel) -> Vec<Vec<usize>> {
    (0..model.n_nodes())
        .into_par_iter()
        .map(|p| {
            let mut rows: Vec<usize> = vec![p];
            for &k in model.family.neighbors(p) {
                rows.push(k as usize);
                rows.extend(model.family.neighbors(k as usize).iter().map(|&q| q as usize));
            }
            rows.sort_unstable();
            rows.dedup();
            rows
        })
        .collect()
}
