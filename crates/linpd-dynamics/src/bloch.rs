//! Bloch dispersion of an assembled 2D/3D (or 1D) lattice operator along any direction.
//!
//! # The symbol
//!
//! On an infinite lattice with node volume `V = h^d` and masses `rho V`, the semi-discrete
//! system `rho V u'' = -A u` with a translation-invariant stiffness `A` (force form, the
//! convention of `linpd-bond` and `linpd-lps`) has plane-wave solutions
//! `u_j = p exp(i (k . x_j - omega t))` with
//!
//! ```text
//! rho V omega^2 p = D(k) p,     D(k) = sum_j A_{c,j} exp(i k . (x_j - x_c)),
//! ```
//!
//! `A_{c,j}` the `d x d` block of the centre node `c` and its neighbour `j`. The stencil is
//! point-symmetric (`A_{c,c+o} = A_{c,c-o}^T`, and both operators have symmetric blocks), so
//! `D(k) = sum_j A_{c,j} cos(k . (x_j - x_c))` is real symmetric, and the branches are
//! `omega_n(k) = sqrt(eig_n(D(k)) / (rho V))` ([`BlochStencil::omegas`]). Rigid translations
//! give `sum_j A_{c,j} = 0`, so `D` is evaluated as
//! `sum_j A_{c,j} - 2 sum_j A_{c,j} sin^2(k . o_j / 2)`: long waves keep their digits.
//!
//! As `k -> 0`, `D(k) = k^2 Q(n) + O(k^4)` with `Q(n) = -(1/2) sum_j A_{c,j} (n . o_j)^2`
//! (`k = k n`), whose eigenvalues give the long-wave speeds `c = sqrt(eig(Q)/(rho V))`
//! ([`BlochStencil::long_wave_speeds`]), exactly (no finite-`k` fit).
//!
//! # Extracting the stencil
//!
//! [`BlochStencil::from_matrix`] reads the block row of the node at the grid centre from the
//! assembled matrix (DOFs `d * node + component`, nodes numbered first axis fastest, as
//! `linpd_core::Grid`). The centre's row is that of the infinite lattice only if every node
//! that influences it is in the grid: the grid needs `>= 2 reach + 1` nodes per axis, where
//! `reach` (lattice units) is `floor(delta/h)` for the bond-based operator and `2 floor(delta/h)`
//! for LPS (its dilatation couples nodes `2 delta` apart, and the weighted volumes of the
//! centre's neighbours need their full families).

use crate::error::DynamicsError;
use faer::sparse::SparseColMat;
use linpd_core::eigen::symmetric_eigen;

/// The block row of the centre node of an assembled lattice operator.
#[derive(Debug, Clone, PartialEq)]
pub struct BlochStencil {
    dim: usize,
    h: f64,
    /// `(lattice offset o_j, block A_{c,j} row-major d x d (in a 3 x 3 array))`.
    entries: Vec<([i64; 3], [[f64; 3]; 3])>,
}

/// One branch at one wave vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Branch {
    /// `omega` (or the speed `c` for [`BlochStencil::long_wave_branches`]).
    pub value: f64,
    /// Unit polarization (first `d` entries meaningful).
    pub polarization: [f64; 3],
}

impl Branch {
    /// `|p . n|` for a unit direction `n`: 1 for a longitudinal, 0 for a transverse branch.
    pub fn longitudinality(&self, n: &[f64]) -> f64 {
        let norm = n.iter().map(|v| v * v).sum::<f64>().sqrt();
        (0..n.len()).map(|a| self.polarization[a] * n[a]).sum::<f64>().abs() / norm
    }
}

impl BlochStencil {
    /// Extracts the block row of the centre node (lattice index `(n_a - 1)/2` on each used
    /// axis) of `a` (all DOFs, `dim` per node) on a grid with `counts` nodes per axis (1 on
    /// unused axes) and spacing `h`. `reach` is the operator's reach in lattice units (see the
    /// module docs); errors when a used axis has fewer than `2 reach + 1` nodes, when the
    /// matrix size does not match, or when the centre's row reaches beyond `reach`.
    pub fn from_matrix(
        a: &SparseColMat<usize, f64>,
        dim: usize,
        counts: [usize; 3],
        h: f64,
        reach: usize,
    ) -> Result<Self, DynamicsError> {
        if !(1..=3).contains(&dim) {
            return Err(DynamicsError::param("dim", format!("must be 1, 2 or 3, got {dim}")));
        }
        crate::error::positive("h", h)?;
        for (ax, &n) in counts.iter().enumerate() {
            if ax < dim && n < 2 * reach + 1 {
                return Err(DynamicsError::param(
                    "counts",
                    format!(
                        "axis {ax} has {n} nodes; the centre's stencil is complete only with >= 2 reach + 1 = {}",
                        2 * reach + 1
                    ),
                ));
            }
            if ax >= dim && n != 1 {
                return Err(DynamicsError::param("counts", format!("axis {ax} is unused in {dim}D but has {n} nodes")));
            }
        }
        let n_nodes: usize = counts.iter().product();
        if a.nrows() != dim * n_nodes || a.ncols() != dim * n_nodes {
            return Err(DynamicsError::param(
                "matrix",
                format!(
                    "is {} x {}, expected {} x {} ({n_nodes} nodes x {dim} DOFs)",
                    a.nrows(),
                    a.ncols(),
                    dim * n_nodes,
                    dim * n_nodes
                ),
            ));
        }
        let centre: [i64; 3] = [0, 1, 2].map(|ax| ((counts[ax] - 1) / 2) as i64);
        let c = (centre[0] + counts[0] as i64 * (centre[1] + counts[1] as i64 * centre[2])) as usize;
        let index = |node: usize| {
            let i0 = node % counts[0];
            let i1 = (node / counts[0]) % counts[1];
            let i2 = node / (counts[0] * counts[1]);
            [i0 as i64 - centre[0], i1 as i64 - centre[1], i2 as i64 - centre[2]]
        };
        let cp = a.symbolic().col_ptr();
        let ri = a.symbolic().row_idx();
        let val = a.val();
        let mut entries: Vec<([i64; 3], [[f64; 3]; 3])> = Vec::new();
        let mut slot = std::collections::BTreeMap::new();
        for b in 0..dim {
            // Column (c, b) = row (c, b) by symmetry: A_{(j,r),(c,b)} = A_{(c,b),(j,r)}.
            let col = dim * c + b;
            for p in cp[col]..cp[col + 1] {
                let (j, r) = (ri[p] / dim, ri[p] % dim);
                let o = index(j);
                if o.iter().any(|v| v.unsigned_abs() as usize > reach) && val[p] != 0.0 {
                    return Err(DynamicsError::param(
                        "reach",
                        format!("the centre's row couples the lattice offset {:?}, beyond reach = {reach}", &o[..dim]),
                    ));
                }
                let k = *slot.entry(o).or_insert_with(|| {
                    entries.push((o, [[0.0; 3]; 3]));
                    entries.len() - 1
                });
                entries[k].1[b][r] += val[p];
            }
        }
        Ok(BlochStencil { dim, h, entries })
    }

    /// Spatial dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Number of stencil nodes (the centre included).
    pub fn len(&self) -> usize {
        self.entries.len()
    }
    /// True for an empty stencil (a zero row).
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
    /// Node volume `V = h^d`.
    pub fn volume(&self) -> f64 {
        self.h.powi(self.dim as i32)
    }

    fn dot(&self, k: &[f64], o: &[i64; 3]) -> f64 {
        (0..self.dim).map(|a| k[a] * o[a] as f64 * self.h).sum()
    }

    /// The symbol `D(k)` (`d x d` in the leading block of a 3 x 3 array, symmetrized), `k`
    /// with `dim` components.
    pub fn symbol(&self, k: &[f64]) -> [[f64; 3]; 3] {
        assert_eq!(k.len(), self.dim, "one wave-vector component per axis");
        let d = self.dim;
        let mut sum = [[0.0; 3]; 3];
        let mut osc = [[0.0; 3]; 3];
        for (o, b) in &self.entries {
            let s = (0.5 * self.dot(k, o)).sin();
            let f = 2.0 * s * s;
            for i in 0..d {
                for j in 0..d {
                    sum[i][j] += b[i][j];
                    osc[i][j] += f * b[i][j];
                }
            }
        }
        let mut m = [[0.0; 3]; 3];
        for i in 0..d {
            for j in 0..d {
                m[i][j] = sum[i][j] - osc[i][j];
            }
        }
        symmetrized(&m, d)
    }

    /// `Q(n) = -(1/2) sum_j A_{c,j} (n . o_j h)^2`, `D(k n) = k^2 Q(n) + O(k^4)` (`n` unit;
    /// `d x d` in the leading block of a 3 x 3 array).
    pub fn long_wave_tensor(&self, n: &[f64]) -> [[f64; 3]; 3] {
        assert_eq!(n.len(), self.dim, "one direction component per axis");
        let norm = n.iter().map(|v| v * v).sum::<f64>().sqrt();
        let d = self.dim;
        let mut q = [[0.0; 3]; 3];
        for (o, b) in &self.entries {
            let t = self.dot(n, o) / norm;
            for i in 0..d {
                for j in 0..d {
                    q[i][j] -= 0.5 * t * t * b[i][j];
                }
            }
        }
        symmetrized(&q, d)
    }

    fn branches_of(&self, m: [[f64; 3]; 3], scale: f64) -> Vec<Branch> {
        let d = self.dim;
        let eig = symmetric_eigen(&(0..d * d).map(|ij| m[ij / d][ij % d]).collect::<Vec<_>>(), d);
        let mut out: Vec<Branch> = (0..self.dim)
            .map(|n| {
                let mut p = [0.0; 3];
                for (a, pa) in p.iter_mut().enumerate().take(self.dim) {
                    *pa = eig.vector(a, n);
                }
                // Negative round-off on the acoustic branches at k = 0 clamps to 0.
                Branch { value: (eig.values[n].max(0.0) / scale).sqrt(), polarization: p }
            })
            .collect();
        out.sort_by(|a, b| a.value.total_cmp(&b.value));
        out
    }

    /// Branches `omega_n(k) = sqrt(eig_n(D(k)) / (rho V))` with polarizations, ascending.
    pub fn branches(&self, k: &[f64], rho: f64) -> Vec<Branch> {
        self.branches_of(self.symbol(k), rho * self.volume())
    }

    /// `omega_n(k)`, ascending.
    pub fn omegas(&self, k: &[f64], rho: f64) -> Vec<f64> {
        self.branches(k, rho).iter().map(|b| b.value).collect()
    }

    /// Long-wave speeds `c_n = lim omega_n(k n)/k = sqrt(eig_n(Q(n)) / (rho V))` with
    /// polarizations, ascending.
    pub fn long_wave_branches(&self, n: &[f64], rho: f64) -> Vec<Branch> {
        self.branches_of(self.long_wave_tensor(n), rho * self.volume())
    }

    /// `(longitudinal, transverse...)` long-wave speeds along `n`: the branch whose
    /// polarization is most nearly parallel to `n`, then the others ascending. Along lattice
    /// axes and diagonals of a cubic lattice the modes are pure.
    pub fn long_wave_speeds(&self, n: &[f64], rho: f64) -> (f64, Vec<f64>) {
        let b = self.long_wave_branches(n, rho);
        let il = (0..b.len()).max_by(|&i, &j| b[i].longitudinality(n).total_cmp(&b[j].longitudinality(n))).unwrap();
        (b[il].value, b.iter().enumerate().filter(|(i, _)| *i != il).map(|(_, x)| x.value).collect())
    }
}

/// `(m + m^T) / 2` of the leading `d x d` block, entry by entry.
fn symmetrized(m: &[[f64; 3]; 3], d: usize) -> [[f64; 3]; 3] {
    let mut s = [[0.0; 3]; 3];
    for i in 0..d {
        for j in 0..d {
            s[i][j] = (m[i][j] + m[j][i]) * 0.5;
        }
    }
    s
}

/// `floor(delta/h)` with the geometric tolerance of `linpd-core`: the bond-based reach in
/// lattice units (LPS: twice this).
pub fn lattice_reach(horizon: f64, h: f64) -> usize {
    (horizon / h * (1.0 + linpd_core::GEOMETRY_RTOL)).floor() as usize
}

/// Unit vector of the lattice direction `[a b c]` in `dim` dimensions (`[1, 1, 0]` -> `[110]`).
pub fn lattice_direction(dim: usize, miller: [i32; 3]) -> Vec<f64> {
    let v: Vec<f64> = miller[..dim].iter().map(|&m| m as f64).collect();
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.iter().map(|x| x / n).collect()
}

/// Classical isotropic elastic wave speeds `(c_P, c_S) = (sqrt((lambda + 2 mu)/rho), sqrt(mu/rho))`.
pub fn classical_speeds(lambda: f64, mu: f64, rho: f64) -> (f64, f64) {
    (((lambda + 2.0 * mu) / rho).sqrt(), (mu / rho).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Chain;
    use crate::dispersion::omega;
    use linpd_bond::{assemble, BondOperator};
    use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};
    use linpd_lps::{assemble_tangent, Influence, LpsModel, LpsParams};

    fn grid(dim: usize, h: f64, reach: usize) -> Grid {
        let n = 2.0 * reach as f64 * h;
        Grid::new(&vec![0.0; dim], &vec![n; dim], h, 0.0, Placement::Vertex).unwrap()
    }

    fn bond(dim: usize, m: usize, kernel: Kernel, plane: Option<PlaneModel>) -> BlochStencil {
        let h = 0.1;
        let delta = m as f64 * h;
        let reach = lattice_reach(delta, h);
        let g = grid(dim, h, reach);
        let mm =
            Micromodulus { kernel, normalization: Normalization::Discrete, modulus: 1.0, plane, partial_volume: false };
        let op = BondOperator::on_grid(&g, delta, &mm, &Material::default()).unwrap();
        let a = assemble(&op, &DofMap::all_free(g.len(), dim));
        BlochStencil::from_matrix(&a, dim, g.counts(), h, reach).unwrap()
    }

    fn lps(dim: usize, m: usize, plane: Option<PlaneModel>, shear: f64) -> BlochStencil {
        let h = 0.1;
        let delta = m as f64 * h;
        let reach = 2 * lattice_reach(delta, h);
        let g = grid(dim, h, reach);
        let p = LpsParams {
            K: 1.0,
            G: shear,
            horizon: delta,
            influence: Influence::InverseDistance,
            partial_volume: false,
            plane,
        };
        let a = assemble_tangent(&LpsModel::new(&g, &p).unwrap());
        BlochStencil::from_matrix(&a, dim, g.counts(), h, reach).unwrap()
    }

    #[test]
    fn one_dimensional_case_matches_the_chain() {
        for (m, kernel) in [(1usize, Kernel::InverseDistance), (3, Kernel::InverseDistance), (5, Kernel::Constant)] {
            let h = 0.5;
            let delta = m as f64 * h;
            let mm = Micromodulus {
                kernel,
                normalization: Normalization::Discrete,
                modulus: 1.0,
                plane: None,
                partial_volume: false,
            };
            let chain = Chain::new(h, delta, &mm).unwrap();
            let reach = lattice_reach(delta, h);
            let g = grid(1, h, reach);
            let op = BondOperator::on_grid(&g, delta, &mm, &Material::default()).unwrap();
            let a = assemble(&op, &DofMap::all_free(g.len(), 1));
            let s = BlochStencil::from_matrix(&a, 1, g.counts(), h, reach).unwrap();
            for i in 1..=50 {
                let k = std::f64::consts::PI / h * i as f64 / 50.0;
                let (w, w1) = (s.omegas(&[k], 2.0)[0], omega(&chain, 2.0, k));
                assert!((w - w1).abs() <= 1e-12 * w1, "m = {m}, k = {k}: {w} vs {w1}");
            }
        }
    }

    #[test]
    fn too_small_grid_is_refused() {
        let h = 0.1;
        let g = grid(2, h, 2);
        let mm = Micromodulus {
            kernel: Kernel::Constant,
            normalization: Normalization::Discrete,
            modulus: 1.0,
            plane: Some(PlaneModel::Strain),
            partial_volume: false,
        };
        let op = BondOperator::on_grid(&g, 3.0 * h, &mm, &Material::default()).unwrap();
        let a = assemble(&op, &DofMap::all_free(g.len(), 2));
        assert!(BlochStencil::from_matrix(&a, 2, g.counts(), h, 3).is_err());
        assert!(BlochStencil::from_matrix(&a, 2, g.counts(), h, 1).is_err(), "row reaches beyond 1");
    }

    /// Long-wave speeds along [100] vs classical `(c_P, c_S)`: relative error below `0.15/m`
    /// (`m = delta/h`; measured: 2.9%/4.2% (c_P/c_S) at m = 3 in 3D, 0.5%/0.7% at m = 4,
    /// 0.6%/1.7% at m = 3 in 2D). The slope of `omega(k)` at `k h = 1e-3` agrees with them.
    fn check(s: &BlochStencil, dim: usize, lambda: f64, mu: f64, m: usize, what: &str) {
        let rho = 2.0;
        let n = lattice_direction(dim, [1, 0, 0]);
        let (cl, ct) = s.long_wave_speeds(&n, rho);
        let (cp, cs) = classical_speeds(lambda, mu, rho);
        let tol = 0.15 / m as f64;
        assert!((cl / cp - 1.0).abs() < tol, "{what} m = {m}: c_L = {cl} vs c_P = {cp}");
        assert_eq!(ct.len(), dim - 1);
        for c in &ct {
            assert!((c / cs - 1.0).abs() < tol, "{what} m = {m}: c_T = {c} vs c_S = {cs}");
        }
        let k = 1e-3 / 0.1;
        let mut kv = vec![0.0; dim];
        kv[0] = k;
        let b = s.branches(&kv, rho);
        let l = b.iter().max_by(|x, y| x.longitudinality(&n).total_cmp(&y.longitudinality(&n))).unwrap();
        assert!((l.longitudinality(&n) - 1.0).abs() < 1e-9, "[100] modes are pure");
        assert!((l.value / k / cl - 1.0).abs() < 1e-5, "{what}: slope {} vs {cl}", l.value / k);
    }

    #[test]
    fn long_wave_speeds_are_classical_within_the_lattice_error() {
        // Bond-based: lambda = mu = 3K/5 (3D and plane strain, K = 1).
        for m in [3usize, 4] {
            check(&bond(3, m, Kernel::InverseDistance, None), 3, 0.6, 0.6, m, "bond 3D");
        }
        for m in [3usize, 4, 6] {
            check(&bond(2, m, Kernel::InverseDistance, Some(PlaneModel::Strain)), 2, 0.6, 0.6, m, "bond 2D strain");
        }
        // LPS, K = 1, G = 0.3: lambda = K - 2G/3 (3D and plane strain), mu = G.
        check(&lps(3, 3, None, 0.3), 3, 0.8, 0.3, 3, "LPS 3D");
        for m in [3usize, 4, 6] {
            check(&lps(2, m, Some(PlaneModel::Strain), 0.3), 2, 0.8, 0.3, m, "LPS 2D strain");
        }
        // G = 3K/5 is the Cauchy point where LPS reduces to the bond-based operator.
        let (a, b) =
            (lps(2, 3, Some(PlaneModel::Strain), 0.6), bond(2, 3, Kernel::InverseDistance, Some(PlaneModel::Strain)));
        let n = lattice_direction(2, [1, 1, 0]);
        assert!((a.long_wave_speeds(&n, 1.0).0 / b.long_wave_speeds(&n, 1.0).0 - 1.0).abs() < 1e-12);
    }
}
