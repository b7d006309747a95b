//! A level-`m` model: nodes, volumes and a sparse pointwise micromodulus tensor `C(x_i, x_j)`.

use crate::CoarsenError;
use faer::sparse::{SparseColMat, Triplet};
use linpd_core::{AssembledModel, Point};
use rayon::prelude::*;

/// A level-`m` model (eq. (1) discretised, with a `d x d` tensor micromodulus):
///
/// ```text
/// L u_i = sum_{j != i} C(x_i, x_j) (u_j - u_i) v_j          force density, (4)/(10) discretised
/// f_i   = v_i L u_i = -sum_j K_ij u_j,   K_ij = -v_i v_j C_ij (i != j),  K_ii = -sum_{j != i} K_ij
/// ```
///
/// Any linear model with translation invariance (zero block-row sums of its stiffness) has this
/// form, state-based ones included (Silling 2010, Sec. 2: the LPS tangent is a longer-range
/// tensor micromodulus). Bonds are stored per node in compressed rows sorted by column; each
/// bond carries a row-major `d x d` block.
#[derive(Debug, Clone)]
pub struct LevelModel {
    dim: usize,
    x: Vec<Point>,
    v: Vec<f64>,
    level0: Vec<usize>,
    offsets: Vec<usize>,
    cols: Vec<usize>,
    c: Vec<f64>,
}

impl LevelModel {
    /// Build from compressed rows: bonds of node `i` are `cols[offsets[i]..offsets[i+1]]` with
    /// blocks `c[k*d*d..(k+1)*d*d]` (row-major `C(x_i, x_j)[a][b]`). Rows are sorted here.
    /// `level0[i]` is the node's index in the level-0 model.
    pub fn from_csr(
        dim: usize,
        x: Vec<Point>,
        v: Vec<f64>,
        level0: Vec<usize>,
        offsets: Vec<usize>,
        cols: Vec<usize>,
        c: Vec<f64>,
    ) -> Result<Self, CoarsenError> {
        let n = x.len();
        let bad = |m: String| Err(CoarsenError::InvalidInput(m));
        if !(1..=3).contains(&dim) {
            return bad(format!("dimension must be 1, 2 or 3, got {dim}"));
        }
        if v.len() != n || level0.len() != n || offsets.len() != n + 1 {
            return bad(format!(
                "lengths differ: {n} positions, {} volumes, {} level-0 indices, {} row offsets (want n + 1)",
                v.len(),
                level0.len(),
                offsets.len()
            ));
        }
        if offsets[0] != 0 || offsets.windows(2).any(|w| w[1] < w[0]) || offsets[n] != cols.len() {
            return bad("row offsets must start at 0, not decrease, and end at the number of bonds".into());
        }
        if c.len() != cols.len() * dim * dim {
            return bad(format!("{} bond values for {} bonds of {dim}x{dim} blocks", c.len(), cols.len()));
        }
        for i in 0..n {
            if x[i].iter().any(|t| !t.is_finite()) || !v[i].is_finite() || v[i] <= 0.0 {
                return bad(format!(
                    "node {i}: position {:?} / volume {} must be finite, volume > 0",
                    &x[i][..dim],
                    v[i]
                ));
            }
        }
        let mut model = Self { dim, x, v, level0, offsets, cols, c };
        // sort each row by column, then check
        let dd = dim * dim;
        for i in 0..n {
            let (lo, hi) = (model.offsets[i], model.offsets[i + 1]);
            if model.cols[lo..hi].windows(2).any(|w| w[1] <= w[0]) {
                let mut perm: Vec<usize> = (lo..hi).collect();
                perm.sort_by_key(|&k| model.cols[k]);
                let cols: Vec<usize> = perm.iter().map(|&k| model.cols[k]).collect();
                let vals: Vec<f64> = perm.iter().flat_map(|&k| model.c[k * dd..(k + 1) * dd].to_vec()).collect();
                model.cols[lo..hi].copy_from_slice(&cols);
                model.c[lo * dd..hi * dd].copy_from_slice(&vals);
            }
            for k in lo..hi {
                let j = model.cols[k];
                if j >= n || j == i || (k > lo && model.cols[k - 1] == j) {
                    return bad(format!("node {i}: bond to {j} (index out of range, self-bond or duplicate)"));
                }
                if model.c[k * dd..(k + 1) * dd].iter().any(|t| !t.is_finite()) {
                    return bad(format!("node {i}: bond to {j} has a non-finite micromodulus"));
                }
            }
        }
        Ok(model)
    }

    /// 1D model from explicit bonds: `bonds[i]` lists `(j, C(x_i, x_j))`.
    pub fn from_bonds_1d(x: Vec<f64>, v: Vec<f64>, bonds: Vec<Vec<(usize, f64)>>) -> Result<Self, CoarsenError> {
        let n = x.len();
        if bonds.len() != n {
            return Err(CoarsenError::InvalidInput(format!("{n} positions but {} bond lists", bonds.len())));
        }
        let mut offsets = vec![0];
        let (mut cols, mut c) = (Vec::new(), Vec::new());
        for row in &bonds {
            for &(j, cij) in row {
                cols.push(j);
                c.push(cij);
            }
            offsets.push(cols.len());
        }
        Self::from_csr(1, x.iter().map(|&t| [t, 0.0, 0.0]).collect(), v, (0..n).collect(), offsets, cols, c)
    }

    /// 1D level-0 model from a pointwise micromodulus `c(x, q)` evaluated for
    /// `0 < |q - x| <= horizon` (zero values are not stored). `c` should be symmetric.
    pub fn from_kernel(
        x: Vec<f64>,
        v: Vec<f64>,
        horizon: f64,
        c: impl Fn(f64, f64) -> f64 + Sync,
    ) -> Result<Self, CoarsenError> {
        let mut order: Vec<usize> = (0..x.len()).collect();
        order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
        let r = horizon * (1.0 + 1e-12);
        let bonds = (0..x.len())
            .into_par_iter()
            .map(|i| {
                let lo = order.partition_point(|&j| x[j] < x[i] - r);
                let mut row: Vec<(usize, f64)> = order[lo..]
                    .iter()
                    .take_while(|&&j| x[j] <= x[i] + r)
                    .filter(|&&j| j != i)
                    .filter_map(|&j| {
                        let cij = c(x[i], x[j]);
                        (cij != 0.0).then_some((j, cij))
                    })
                    .collect();
                row.sort_unstable_by_key(|b| b.0);
                row
            })
            .collect();
        Self::from_bonds_1d(x, v, bonds)
    }

    /// Level-0 model from a nodal stiffness `K = -dF/du` (`d n x d n`, DOF `d i + a`, zero
    /// block-row sums), e.g. an assembled bond-based operator or the LPS tangent:
    /// `C(x_i, x_j) = -K_ij / (v_i v_j)` for `i != j`; the diagonal blocks are implied.
    pub fn from_stiffness(
        dim: usize,
        x: Vec<Point>,
        v: Vec<f64>,
        k: &SparseColMat<usize, f64>,
    ) -> Result<Self, CoarsenError> {
        let n = x.len();
        if !(1..=3).contains(&dim) || k.nrows() != dim * n || k.ncols() != dim * n || v.len() != n {
            return Err(CoarsenError::InvalidInput(format!(
                "stiffness is {}x{}, expected {}x{} for {n} nodes in {dim}D ({} volumes)",
                k.nrows(),
                k.ncols(),
                dim * n,
                dim * n,
                v.len()
            )));
        }
        let dd = dim * dim;
        // gather blocks per row node: (j, a, b, value) from the CSC columns
        let mut rows: Vec<Vec<(usize, usize, usize, f64)>> = vec![Vec::new(); n];
        let (cp, ri, vals) = (k.col_ptr(), k.row_idx(), k.val());
        for col in 0..dim * n {
            let (j, b) = (col / dim, col % dim);
            for p in cp[col]..cp[col + 1] {
                let (i, a) = (ri[p] / dim, ri[p] % dim);
                if i != j && vals[p] != 0.0 {
                    rows[i].push((j, a, b, vals[p]));
                }
            }
        }
        let mut offsets = vec![0];
        let (mut cols, mut c) = (Vec::new(), Vec::new());
        for (i, mut row) in rows.into_iter().enumerate() {
            row.sort_by_key(|e| e.0);
            let mut k0 = 0;
            while k0 < row.len() {
                let j = row[k0].0;
                let mut block = vec![0.0; dd];
                while k0 < row.len() && row[k0].0 == j {
                    let (_, a, b, val) = row[k0];
                    block[a * dim + b] += -val / (v[i] * v[j]);
                    k0 += 1;
                }
                cols.push(j);
                c.extend(block);
            }
            offsets.push(cols.len());
        }
        Self::from_csr(dim, x, v, (0..n).collect(), offsets, cols, c)
    }

    /// Dimension `d`.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// True when there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// Node positions.
    pub fn positions(&self) -> &[Point] {
        &self.x
    }
    /// Node volumes.
    pub fn volumes(&self) -> &[f64] {
        &self.v
    }
    /// Level-0 index of each node.
    pub fn level0(&self) -> &[usize] {
        &self.level0
    }
    /// Number of stored bonds (each pair counted from both ends).
    pub fn n_bonds(&self) -> usize {
        self.cols.len()
    }
    /// Partners of node `i` (sorted).
    pub fn partners(&self, i: usize) -> &[usize] {
        &self.cols[self.offsets[i]..self.offsets[i + 1]]
    }
    /// Blocks of node `i`, `d*d` per partner, row-major.
    pub fn blocks(&self, i: usize) -> &[f64] {
        let dd = self.dim * self.dim;
        &self.c[self.offsets[i] * dd..self.offsets[i + 1] * dd]
    }
    /// Bonds `(j, C(x_i, x_j)[0][0])` of node `i` (the scalar micromodulus in 1D).
    pub fn bonds_1d(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let dd = self.dim * self.dim;
        self.partners(i).iter().zip(self.blocks(i).chunks(dd)).map(|(&j, b)| (j, b[0]))
    }
    /// The block `C(x_i, x_j)` (zeros if there is no bond).
    pub fn micromodulus(&self, i: usize, j: usize) -> Vec<f64> {
        let dd = self.dim * self.dim;
        match self.partners(i).binary_search(&j) {
            Ok(k) => self.blocks(i)[k * dd..(k + 1) * dd].to_vec(),
            Err(_) => vec![0.0; dd],
        }
    }
    /// Largest bond length over all nodes (the level's horizon).
    pub fn horizon(&self) -> f64 {
        (0..self.len()).into_par_iter().map(|i| self.horizon_of(i)).reduce(|| 0.0, f64::max)
    }
    /// Largest bond length of node `i`.
    pub fn horizon_of(&self, i: usize) -> f64 {
        self.partners(i).iter().map(|&j| dist(&self.x[i], &self.x[j])).fold(0.0, f64::max)
    }
    /// Largest `|C|` entry.
    pub fn max_abs(&self) -> f64 {
        self.c.par_iter().map(|t| t.abs()).reduce(|| 0.0, f64::max)
    }

    /// Force density `L u_i`, eq. (4)/(10) discretised (`d` values per node).
    pub fn force_density(&self, u: &[f64]) -> Vec<f64> {
        let d = self.dim;
        assert_eq!(u.len(), d * self.len(), "displacement length");
        let mut out = vec![0.0; u.len()];
        out.par_chunks_mut(d).enumerate().for_each(|(i, o)| self.force_density_into(i, u, o));
        out
    }

    /// Force density at one node (`d` values).
    pub fn force_density_at(&self, i: usize, u: &[f64]) -> Vec<f64> {
        let mut o = vec![0.0; self.dim];
        self.force_density_into(i, u, &mut o);
        o
    }

    fn force_density_into(&self, i: usize, u: &[f64], o: &mut [f64]) {
        let d = self.dim;
        o.iter_mut().for_each(|t| *t = 0.0);
        for (&j, b) in self.partners(i).iter().zip(self.blocks(i).chunks(d * d)) {
            for a in 0..d {
                for c in 0..d {
                    o[a] += b[a * d + c] * (u[d * j + c] - u[d * i + c]) * self.v[j];
                }
            }
        }
    }

    /// Energy density at node `i`: `w_i = 1/4 sum_j (u_j - u_i) . C_ij (u_j - u_i) v_j`
    /// (half of each bond's energy to each end), so `sum_i w_i v_i = u.K u / 2` for symmetric `C`.
    pub fn energy_density_at(&self, i: usize, u: &[f64]) -> f64 {
        let d = self.dim;
        let mut w = 0.0;
        for (&j, b) in self.partners(i).iter().zip(self.blocks(i).chunks(d * d)) {
            for a in 0..d {
                for c in 0..d {
                    w += (u[d * j + a] - u[d * i + a]) * b[a * d + c] * (u[d * j + c] - u[d * i + c]) * self.v[j];
                }
            }
        }
        0.25 * w
    }

    /// 1D second moment `sum_q C(x,q) (q-x)^2 v_q` at node `i` (twice the bar modulus).
    pub fn second_moment(&self, i: usize) -> f64 {
        self.bonds_1d(i).map(|(j, c)| c * (self.x[j][0] - self.x[i][0]).powi(2) * self.v[j]).sum()
    }

    /// `max_{i,j,a,b} |C_ij[a][b] - C_ji[b][a]| / max |C|` (a missing reverse bond counts as 0).
    pub fn asymmetry(&self) -> f64 {
        let d = self.dim;
        let den = self.max_abs();
        if den == 0.0 {
            return 0.0;
        }
        let num = (0..self.len())
            .into_par_iter()
            .map(|i| {
                let mut m: f64 = 0.0;
                for (&j, b) in self.partners(i).iter().zip(self.blocks(i).chunks(d * d)) {
                    let t = self.micromodulus(j, i);
                    for a in 0..d {
                        for c in 0..d {
                            m = m.max((b[a * d + c] - t[c * d + a]).abs());
                        }
                    }
                }
                m
            })
            .reduce(|| 0.0, f64::max);
        num / den
    }

    /// Copy with `C_ij <- (C_ij + C_ji^T)/2`; bond lists become symmetric (a missing reverse
    /// bond counts as zero).
    pub fn symmetrized(&self) -> Self {
        let (d, n) = (self.dim, self.len());
        let dd = d * d;
        // reverse-only bonds: j lists i but i does not list j
        let mut extra: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            for &j in self.partners(i) {
                if self.partners(j).binary_search(&i).is_err() {
                    extra[j].push(i);
                }
            }
        }
        let mut offsets = vec![0];
        let (mut cols, mut c) = (Vec::new(), Vec::new());
        for (i, extra_i) in extra.iter().enumerate() {
            let mut js: Vec<usize> = self.partners(i).to_vec();
            js.extend(extra_i.iter().copied());
            js.sort_unstable();
            js.dedup();
            for &j in &js {
                let f = self.micromodulus(i, j);
                let t = self.micromodulus(j, i);
                cols.push(j);
                for a in 0..d {
                    for b in 0..d {
                        c.push(0.5 * (f[a * d + b] + t[b * d + a]));
                    }
                }
            }
            offsets.push(cols.len());
        }
        debug_assert_eq!(c.len(), cols.len() * dd);
        Self { dim: d, x: self.x.clone(), v: self.v.clone(), level0: self.level0.clone(), offsets, cols, c }
    }

    /// The nodal stiffness `K` (`d n x d n`, CSC): `K_ij = -v_i v_j C_ij`, `K_ii = -sum K_ij`.
    pub fn stiffness(&self) -> SparseColMat<usize, f64> {
        let (d, n) = (self.dim, self.len());
        let mut t = Vec::with_capacity((self.cols.len() + n) * d * d);
        for i in 0..n {
            let mut diag = vec![0.0; d * d];
            for (&j, b) in self.partners(i).iter().zip(self.blocks(i).chunks(d * d)) {
                let w = self.v[i] * self.v[j];
                for a in 0..d {
                    for c in 0..d {
                        let k = -w * b[a * d + c];
                        if k != 0.0 {
                            t.push(Triplet::new(d * i + a, d * j + c, k));
                        }
                        diag[a * d + c] -= k;
                    }
                }
            }
            for a in 0..d {
                for c in 0..d {
                    t.push(Triplet::new(d * i + a, d * i + c, diag[a * d + c]));
                }
            }
        }
        SparseColMat::try_new_from_triplets(d * n, d * n, &t).expect("indices are in range")
    }

    /// The level as a [`linpd_core::Model`]: its nodal stiffness `K` over all DOFs, the input of
    /// a static solve (`linpd_problem::level_solve`).
    ///
    /// Symmetry is judged on `K` itself, not on `C` ([`LevelModel::asymmetry`]): with
    /// `C_ij = C_ji^T` the off-diagonal blocks of `K` are symmetric, but the diagonal block
    /// `K_ii = sum_j v_i v_j C_ij` is not unless every `C_ij` is (the 2D plate's level 1 after
    /// symmetrization: relative asymmetry of `K` 1.5e-4 with `C` exactly symmetric).
    pub fn as_model(&self) -> AssembledModel {
        AssembledModel::new("coarsened", self.dim(), self.positions().to_vec(), self.stiffness())
            .with_labels("level-0 node", self.level0().to_vec())
    }

    /// Raw compressed rows `(offsets, cols, blocks)`.
    pub fn csr(&self) -> (&[usize], &[usize], &[f64]) {
        (&self.offsets, &self.cols, &self.c)
    }
}

/// Euclidean distance.
pub(crate) fn dist(a: &Point, b: &Point) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
