//! The LPS tangent of a homogeneous material on the full lattice box, applied from stencils.
//!
//! On the full box with volumes `V = h^d`, one material and no defect or surface correction,
//! every bond with lattice offset `s` has the same `omega nu V` and unit vector `e_s`; only
//! the weighted volumes `m_i` of the nodes within a horizon of the surface differ from the
//! bulk's. With `w_s = V^2 a G omega nu` (the weight of the bond stencil `S`, `K_s = w_s e_s
//! e_s^T`) the pair part of [`crate::tangent`] factors as
//!
//! ```text
//! (A_pair u)_i = sum_s w_s (1/m_i + 1/m_{i+s}) e e^T (u_i - u_{i+s})
//!              = (1/m_i) (S u)_i + (S (u / m))_i + D_i u_i,
//! D_i          = sum_s K_s (1/m_{i+s} - 1/m_i)            (zero in the bulk),
//! ```
//!
//! and with `t_s = omega nu V xi_s` the dilatation `theta = G u` and its transpose are vector
//! stencils:
//!
//! ```text
//! theta_k = (d/m_k) (sum_s t_s . u_{k+s} - T_k . u_k),    T_k = sum_{s in box} t_s,
//! (sum_k C g_k theta_k)_p = -T_p phi_p - sum_s t_s phi_{p+s},   phi_k = C (d/m_k) theta_k,
//! ```
//!
//! (`g_k[p] = (d/m_k) t_{p-k}` for `p != k`, `g_p[p] = -(d/m_p) T_p`). So `A u` costs two bond
//! stencils and two vector stencils and stores per node only `1/m`, `D` and `T`: no per-bond
//! list. Each sum runs lattice row by lattice row, the innermost loop over a contiguous
//! stretch of a neighbouring row (as [`linpd_bond::StencilOperator::apply`]).

use crate::LpsModel;
use linpd_bond::StencilOperator;
use linpd_core::op::LinearOperator;
use rayon::prelude::*;

/// The homogeneous full-box LPS tangent (and its pair part) from stencils (module docs).
#[derive(Debug, Clone)]
pub struct LpsStencil {
    dim: usize,
    counts: [usize; 3],
    /// The bond stencil `S` of `w_s = V^2 a G omega nu`.
    pair: StencilOperator,
    /// `1/m_i` per node.
    inv_m: Vec<f64>,
    /// `D_i` per node, upper triangle (xx, xy, xz, yy, yz, zz; xx, xy, yy in 2D).
    d_blocks: Vec<[f64; 6]>,
    /// `t_s = omega nu V xi_s` per offset (the offsets of `pair`).
    t: Vec<[f64; 3]>,
    /// `T_k = sum_{s in box} t_s` per node (zero in the bulk).
    t_sum: Vec<[f64; 3]>,
    /// `C = V (kappa - a G / d^2)`.
    c: f64,
}

impl LpsStencil {
    /// The stencils of `model`, or `None` when it is not a homogeneous material on the full
    /// lattice box (a point cloud, a body, cut volumes, defects, per-node moduli or a surface
    /// correction): checked by the bond count and by every `m_i` against the stencil's sums.
    pub fn new(model: &LpsModel) -> Option<Self> {
        let grid = model.grid.as_ref()?;
        if !grid.is_full()
            || !grid.has_uniform_volumes()
            || !model.node_constants.is_empty()
            || model.surface != crate::SurfaceCorrection::None
        {
            return None;
        }
        let p = model.params;
        let (dim, h, vol) = (model.dim, grid.spacing(), grid.volume());
        let weight = |r: f64| {
            let nu = if p.partial_volume { linpd_core::kernel::partial_volume(r, p.horizon, h) } else { 1.0 };
            p.influence.omega(r) * nu * vol
        };
        let pair = StencilOperator::from_weight(grid, p.horizon, |r| vol * model.a_g * weight(r)).ok()?;
        if pair.n_bonds() != model.family.n_bonds() {
            return None;
        }
        let t: Vec<[f64; 3]> = pair
            .offsets()
            .iter()
            .map(|k| {
                let xi = [k[0] as f64 * h, k[1] as f64 * h, k[2] as f64 * h];
                let w = weight((xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt());
                [w * xi[0], w * xi[1], w * xi[2]]
            })
            .collect();
        let lengths: Vec<f64> =
            pair.offsets().iter().map(|k| h * ((k[0] * k[0] + k[1] * k[1] + k[2] * k[2]) as f64).sqrt()).collect();
        let n = grid.len();
        // m_i from the stencil must be the model's (a weakened bond changes it)
        let consistent = (0..n).into_par_iter().all(|i| {
            let mut m = 0.0;
            pair.for_each_neighbour(i, &mut |_, s| m += weight(lengths[s]) * lengths[s] * lengths[s]);
            (m - model.m[i]).abs() <= 1e-12 * model.m[i]
        });
        if !consistent {
            return None;
        }
        let inv_m: Vec<f64> = model.m.iter().map(|m| 1.0 / m).collect();
        let (d_blocks, t_sum): (Vec<[f64; 6]>, Vec<[f64; 3]>) = (0..n)
            .into_par_iter()
            .map(|i| {
                let (mut db, mut ts) = ([0.0; 6], [0.0; 3]);
                pair.for_each_neighbour(i, &mut |j, s| {
                    let (b, f) = (pair.block(s), inv_m[j] - inv_m[i]);
                    let mut q = 0;
                    for a in 0..dim {
                        for c in a..dim {
                            db[q] += f * b[a * dim + c];
                            q += 1;
                        }
                    }
                    for a in 0..3 {
                        ts[a] += t[s][a];
                    }
                });
                (db, ts)
            })
            .unzip();
        let c = model.dilatation_coefficient(0);
        Some(LpsStencil { dim, counts: grid.counts(), pair, inv_m, d_blocks, t, t_sum, c })
    }

    /// Number of DOFs.
    pub fn n_dofs(&self) -> usize {
        self.dim * self.inv_m.len()
    }

    /// Block row `i` of `A_pair`: `f(j, -(1/m_i + 1/m_j) K_s)` for every neighbour `j = i + s`
    /// in the box, then `f(i, sum of their negatives)` (the order of
    /// [`crate::PairPart`]'s per-bond block rows).
    pub fn pair_block_row(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) {
        let dd = self.dim * self.dim;
        let mut diag = [0.0; 9];
        self.pair.for_each_neighbour(i, &mut |j, s| {
            let (scale, mut b) = (self.inv_m[i] + self.inv_m[j], self.pair.block(s));
            for (d, v) in diag.iter_mut().zip(b.iter_mut()) {
                *v *= scale;
                *d += *v;
                *v = -*v;
            }
            f(j, &b[..dd]);
        });
        f(i, &diag[..dd]);
    }

    /// The lattice neighbours of node `i` (its bonds).
    pub fn for_each_neighbour(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.pair.for_each_neighbour(i, &mut |j, _| f(j));
    }

    /// `y = A_pair u` (module docs).
    pub fn apply_pair(&self, u: &[f64], y: &mut [f64]) {
        let d = self.dim;
        assert_eq!(u.len(), self.n_dofs());
        assert_eq!(y.len(), self.n_dofs());
        let scaled: Vec<f64> = u.par_iter().enumerate().map(|(q, v)| v * self.inv_m[q / d]).collect();
        let mut second = vec![0.0; u.len()];
        self.pair.apply(u, y);
        self.pair.apply(&scaled, &mut second);
        y.par_chunks_mut(d).zip(second.par_chunks(d)).enumerate().for_each(|(i, (yi, si))| {
            let (im, b, ui) = (self.inv_m[i], &self.d_blocks[i], &u[d * i..d * i + d]);
            let du = sym_times(d, b, ui);
            for a in 0..d {
                yi[a] = im * yi[a] + si[a] + du[a];
            }
        });
    }

    /// `y = A u`: the pair part plus the dilatation part (module docs).
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        self.apply_pair(u, y);
        let d = self.dim;
        let df = d as f64;
        // theta_k (d/m_k) C = phi_k
        let mut phi = self.gather_dot(u);
        phi.par_iter_mut().enumerate().for_each(|(k, v)| {
            let tk = &self.t_sum[k];
            let own: f64 = (0..d).map(|a| tk[a] * u[d * k + a]).sum();
            let im = df * self.inv_m[k];
            *v = self.c * im * im * (*v - own);
        });
        let spread = self.gather_scale(&phi);
        y.par_chunks_mut(d).zip(spread.par_chunks(d)).enumerate().for_each(|(p, (yp, sp))| {
            for a in 0..d {
                yp[a] -= self.t_sum[p][a] * phi[p] + sp[a];
            }
        });
    }

    /// `out_k = sum_s t_s . u_{k+s}` over the in-box offsets of every node `k`.
    fn gather_dot(&self, u: &[f64]) -> Vec<f64> {
        let d = self.dim;
        let [n0, _, _] = self.counts;
        let nodes = self.inv_m.len();
        let soa: Vec<Vec<f64>> = (0..d).map(|a| (0..nodes).map(|i| u[d * i + a]).collect()).collect();
        let mut out = vec![0.0; nodes];
        out.par_chunks_mut(n0).enumerate().for_each(|(row, o)| {
            self.for_each_stretch(row, |s, own, src, len| {
                let t = &self.t[s];
                let o = &mut o[own..own + len];
                for (a, comp) in soa.iter().enumerate() {
                    let c = &comp[src..src + len];
                    for x in 0..len {
                        o[x] += t[a] * c[x];
                    }
                }
            });
        });
        out
    }

    /// `out_p = sum_s t_s phi_{p+s}` over the in-box offsets of every node `p` (`d` per node).
    fn gather_scale(&self, phi: &[f64]) -> Vec<f64> {
        let d = self.dim;
        let [n0, _, _] = self.counts;
        let mut out = vec![0.0; d * phi.len()];
        out.par_chunks_mut(d * n0).enumerate().for_each_init(
            || vec![0.0; 3 * n0],
            |acc, (row, o)| {
                acc.iter_mut().for_each(|v| *v = 0.0);
                self.for_each_stretch(row, |s, own, src, len| {
                    let (t, f) = (&self.t[s], &phi[src..src + len]);
                    for a in 0..d {
                        let acc = &mut acc[a * n0 + own..a * n0 + own + len];
                        for x in 0..len {
                            acc[x] += t[a] * f[x];
                        }
                    }
                });
                for x in 0..n0 {
                    for a in 0..d {
                        o[d * x + a] = acc[a * n0 + x];
                    }
                }
            },
        );
        out
    }

    /// For lattice row `row` (the nodes along the first axis at fixed second and third index)
    /// and every offset `s` reaching into the box: `f(s, own, src, len)`, the row's nodes
    /// `own..own + len` (positions in the row) bonded by `s` to the nodes `src..src + len`
    /// (global numbers).
    fn for_each_stretch(&self, row: usize, mut f: impl FnMut(usize, usize, usize, usize)) {
        let [n0, n1, n2] = self.counts;
        let (j1, j2) = ((row % n1) as i64, (row / n1) as i64);
        for (s, k) in self.pair.offsets().iter().enumerate() {
            let (s1, s2) = (j1 + k[1], j2 + k[2]);
            if s1 < 0 || s1 >= n1 as i64 || s2 < 0 || s2 >= n2 as i64 {
                continue;
            }
            let lo = (-k[0]).max(0) as usize;
            let hi = (n0 as i64 - k[0]).clamp(0, n0 as i64) as usize;
            if lo >= hi {
                continue;
            }
            let src = ((s1 as usize + n1 * s2 as usize) * n0) as i64 + k[0] + lo as i64;
            f(s, lo, src as usize, hi - lo);
        }
    }
}

/// `B x` for a symmetric block stored as its upper triangle.
#[inline]
fn sym_times(d: usize, b: &[f64; 6], x: &[f64]) -> [f64; 3] {
    match d {
        2 => [b[0] * x[0] + b[1] * x[1], b[1] * x[0] + b[2] * x[1], 0.0],
        _ => [
            b[0] * x[0] + b[1] * x[1] + b[2] * x[2],
            b[1] * x[0] + b[3] * x[1] + b[4] * x[2],
            b[2] * x[0] + b[4] * x[1] + b[5] * x[2],
        ],
    }
}

/// The whole tangent `A`.
impl LinearOperator for LpsStencil {
    fn n(&self) -> usize {
        self.n_dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        LpsStencil::apply(self, x, y)
    }
}

/// The pair part `A_pair` alone (the multigrid companion's apply, [`crate::pair`]).
pub struct PairStencil<'a>(pub &'a LpsStencil);

impl LinearOperator for PairStencil<'_> {
    fn n(&self) -> usize {
        self.0.n_dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.apply_pair(x, y)
    }
}
