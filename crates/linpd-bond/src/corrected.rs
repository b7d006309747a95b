//! Matrix-free apply on a lattice whose bonds differ from one homogeneous stencil in few
//! places: phases, defects, surface-corrected factors, bodies (issue #35).
//!
//! On a lattice every bond of node `i` with offset `k` has the weight `w_ik = f_ik w_k`, with
//! `w_k` the reference stencil's weight ([`StencilOperator`]: the micromodulus with volumes
//! `h^d`) and `f_ik` what the material, the defects, a surface correction and the cut volumes
//! make of it (`f_ik = 0` for a bond cut by a defect or to a site a body removed). With
//! `s_i` the most frequent factor of node `i` (its phase's modulus ratio, 1 in a homogeneous
//! bulk),
//!
//! ```text
//! (A u)_i = sum_k f_ik K_k (u_i - u_{i+k})
//!         = s_i (A_0 u)_i + sum_{k in S_i} (f_ik - s_i) K_k (u_i - u_{i+k}),
//! K_k = w_k e_k e_k^T,   S_i = { k : f_ik != s_i },
//! ```
//!
//! where `A_0` is the reference stencil applied over the lattice box (the removed sites carry
//! `u = 0`, so their bonds enter `A_0 u` as `K_k u_i` and leave it through `f_ik = 0`). The
//! stencil part runs at the speed of [`StencilOperator::apply`] (no per-bond data) and only
//! the corrections `S_i` are stored, 10 bytes each (an offset number and `f_ik - s_i`):
//! bonds that cross a crack or an interface and the bonds of the nodes near a body's boundary
//! or a surface correction's layer.
//!
//! Factors equal to `s_i` within a relative `1e-13` count as equal (a phase's weights
//! `c g nu f V^2` and `f (c g nu V^2)` round differently), so the product matches the
//! per-bond one ([`crate::BondOperator::apply`]) to `1e-13 |A| |u|` (tested).
//!
//! Hand-written because no crate applies a lattice stencil with sparse corrections.

use crate::{BondOperator, StencilOperator};
use linpd_core::{CoreError, Grid, LinearOperator, Micromodulus};
use rayon::prelude::*;

/// A node's `s_i` and its corrections `(offset number, f_ik - s_i)`, or the partner of the
/// first bond that is no stencil offset.
type NodeCorrections = Result<(f64, Vec<(u16, f64)>), usize>;

/// Factors within this relative distance of a node's `s_i` are taken as `s_i`.
const SAME_FACTOR_RTOL: f64 = 1e-13;

/// The lowest share of the lattice box's sites that must be nodes: a body that removes more
/// leaves the box's stencil apply mostly on sites without a node.
pub const MIN_FILL: f64 = 0.5;

/// `A` of a [`BondOperator`] on a lattice as the reference stencil plus sparse corrections
/// (see the module docs).
#[derive(Debug, Clone)]
pub struct CorrectedStencil {
    stencil: StencilOperator,
    dim: usize,
    /// Box site of every node; `None` on the full box (node `i` is site `i`).
    sites: Option<Vec<u32>>,
    n_sites: usize,
    /// `s_i` per node.
    scale: Vec<f64>,
    /// Corrections of node `i`: `ptr[i]..ptr[i + 1]` in `offset` and `delta`.
    ptr: Vec<u32>,
    /// The offset's number in the stencil.
    offset: Vec<u16>,
    /// `f_ik - s_i`.
    delta: Vec<f64>,
    /// Site-index shift of every stencil offset.
    shift: Vec<i64>,
}

impl CorrectedStencil {
    /// Whether [`CorrectedStencil::new`] applies on `grid`: at least [`MIN_FILL`] of the box's
    /// sites are nodes.
    pub fn fits(grid: &Grid) -> bool {
        grid.len() as f64 >= MIN_FILL * grid.counts().iter().product::<usize>() as f64
    }

    /// The corrected stencil of `op`, the bond operator built on `grid` with `horizon` and a
    /// material whose reference micromodulus is `micromodulus` (see the module docs). Errors
    /// when `op` is not on `grid`, a bond is not a stencil offset, the box is less than
    /// [`MIN_FILL`] full, or the stencil has more than 65,535 offsets.
    pub fn new(grid: &Grid, horizon: f64, micromodulus: &Micromodulus, op: &BondOperator) -> Result<Self, CoreError> {
        let bad = |why: String| Err(CoreError::param("grid", format!("corrected stencil: {why}")));
        if op.n_nodes() != grid.len() || op.dim() != grid.dim() {
            return bad(format!("the operator has {} nodes, the grid {}", op.n_nodes(), grid.len()));
        }
        if !Self::fits(grid) {
            return bad(format!("{} nodes fill less than {MIN_FILL} of the lattice box", grid.len()));
        }
        let stencil = StencilOperator::on_box(grid, horizon, micromodulus)?;
        let offsets = stencil.offsets();
        if offsets.len() > u16::MAX as usize {
            return bad(format!("{} stencil offsets (at most {})", offsets.len(), u16::MAX));
        }
        let dim = grid.dim();
        let counts = stencil.counts();
        let n_sites: usize = counts.iter().product();
        let reach = offsets.iter().flat_map(|k| k.iter().map(|v| v.unsigned_abs())).max().unwrap_or(0) as i64;
        let side = 2 * reach + 1;
        let lookup_index = |k: [i64; 3]| ((k[0] + reach) + side * ((k[1] + reach) + side * (k[2] + reach))) as usize;
        let mut lookup = vec![u16::MAX; (side * side * side) as usize];
        for (s, k) in offsets.iter().enumerate() {
            lookup[lookup_index(*k)] = s as u16;
        }
        let shift: Vec<i64> =
            offsets.iter().map(|k| k[0] + counts[0] as i64 * (k[1] + counts[1] as i64 * k[2])).collect();
        let w0 = stencil.weights();
        // per node: s_i and its corrections, or the first bond that is no stencil offset
        let per_node: Vec<NodeCorrections> = (0..grid.len())
            .into_par_iter()
            .map_init(
                || vec![f64::NAN; offsets.len()],
                |f, i| {
                    let site = grid.site_of(i);
                    // f = 0 on the offsets inside the box (no bond: a removed site or a cut),
                    // NaN outside it (the stencil skips those)
                    for (s, k) in offsets.iter().enumerate() {
                        let inside = (0..3).all(|a| {
                            let v = site[a] as i64 + k[a];
                            v >= 0 && v < counts[a] as i64
                        });
                        f[s] = if inside { 0.0 } else { f64::NAN };
                    }
                    let li = grid.lattice_index(i);
                    for (&j, &w) in op.family().neighbors(i).iter().zip(op.weights(i)) {
                        let lj = grid.lattice_index(j as usize);
                        let k = [lj[0] - li[0], lj[1] - li[1], lj[2] - li[2]];
                        let s = if k.iter().all(|v| v.abs() <= reach) { lookup[lookup_index(k)] } else { u16::MAX };
                        if s == u16::MAX {
                            return Err(j as usize);
                        }
                        f[s as usize] = w / w0[s as usize];
                    }
                    let scale = most_frequent(f);
                    let same = |v: f64| (v - scale).abs() <= SAME_FACTOR_RTOL * scale.abs().max(v.abs());
                    let corrections = f
                        .iter()
                        .enumerate()
                        .filter(|(_, &v)| !v.is_nan() && !same(v))
                        .map(|(s, &v)| (s as u16, v - scale))
                        .collect();
                    Ok((scale, corrections))
                },
            )
            .collect();
        let total: usize = per_node.iter().map(|r| r.as_ref().map_or(0, |c| c.1.len())).sum();
        if total > u32::MAX as usize {
            return bad(format!("{total} corrections (at most {})", u32::MAX));
        }
        let (mut scale, mut ptr) = (Vec::with_capacity(grid.len()), Vec::with_capacity(grid.len() + 1));
        let (mut offset, mut delta) = (Vec::with_capacity(total), Vec::with_capacity(total));
        ptr.push(0u32);
        for (i, r) in per_node.into_iter().enumerate() {
            let (s, c) = match r {
                Ok(v) => v,
                Err(j) => return bad(format!("the bond from node {i} to node {j} is no stencil offset")),
            };
            scale.push(s);
            for (o, d) in c {
                offset.push(o);
                delta.push(d);
            }
            ptr.push(offset.len() as u32);
        }
        let sites = (!grid.is_full()).then(|| {
            (0..grid.len())
                .map(|i| {
                    let s = grid.site_of(i);
                    (s[0] + counts[0] * (s[1] + counts[1] * s[2])) as u32
                })
                .collect()
        });
        Ok(CorrectedStencil { stencil, dim, sites, n_sites, scale, ptr, offset, delta, shift })
    }

    /// Number of DOFs (`d` per node).
    pub fn n_dofs(&self) -> usize {
        self.dim * self.scale.len()
    }
    /// Number of stored corrections (bonds whose factor is not their node's `s_i`).
    pub fn n_corrections(&self) -> usize {
        self.offset.len()
    }
    /// Bytes held besides the reference stencil.
    pub fn bytes(&self) -> usize {
        self.sites.as_ref().map_or(0, |s| 4 * s.len())
            + 8 * self.scale.len()
            + 4 * self.ptr.len()
            + 10 * self.offset.len()
    }

    /// `y = A u` over all DOFs (see the module docs).
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        assert_eq!(u.len(), self.n_dofs());
        assert_eq!(y.len(), self.n_dofs());
        match self.dim {
            1 => self.apply_dim::<1>(u, y),
            2 => self.apply_dim::<2>(u, y),
            _ => self.apply_dim::<3>(u, y),
        }
    }

    fn apply_dim<const D: usize>(&self, u: &[f64], y: &mut [f64]) {
        // u and A_0 u over the box's sites (on the full box the node vectors themselves)
        let (u_box, mut y_box) = match &self.sites {
            None => (std::borrow::Cow::Borrowed(u), None),
            Some(sites) => {
                let mut ub = vec![0.0; D * self.n_sites];
                for (i, &s) in sites.iter().enumerate() {
                    ub[D * s as usize..D * s as usize + D].copy_from_slice(&u[D * i..D * i + D]);
                }
                (std::borrow::Cow::Owned(ub), Some(vec![0.0; D * self.n_sites]))
            }
        };
        match y_box.as_mut() {
            Some(yb) => self.stencil.apply(&u_box, yb),
            None => self.stencil.apply(&u_box, y),
        }
        let site = |i: usize| self.sites.as_ref().map_or(i, |s| s[i] as usize);
        y.par_chunks_mut(D).enumerate().for_each(|(i, yi)| {
            let si = site(i);
            let a0 = match &y_box {
                Some(yb) => &yb[D * si..D * si + D],
                None => &*yi,
            };
            let mut out = [0.0; 3];
            for a in 0..D {
                out[a] = self.scale[i] * a0[a];
            }
            for p in self.ptr[i] as usize..self.ptr[i + 1] as usize {
                let s = self.offset[p] as usize;
                let sj = (si as i64 + self.shift[s]) as usize;
                let mut du = [0.0; 3];
                for a in 0..D {
                    du[a] = u_box[D * si + a] - u_box[D * sj + a];
                }
                // (f_ik - s_i) K_k (u_i - u_{i+k}), K_k row-major d x d
                let (k, c) = (self.stencil.block(s), self.delta[p]);
                for a in 0..D {
                    out[a] += c * (0..D).map(|b| k[a * D + b] * du[b]).sum::<f64>();
                }
            }
            yi.copy_from_slice(&out[..D]);
        });
    }
}

impl LinearOperator for CorrectedStencil {
    fn n(&self) -> usize {
        self.n_dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        CorrectedStencil::apply(self, x, y)
    }
}

/// The value that occurs most often among the non-NaN entries of `f` (exact ties within
/// [`SAME_FACTOR_RTOL`]; the first of equal counts); 0 when all are NaN. One pass when all
/// are equal, the common case.
fn most_frequent(f: &[f64]) -> f64 {
    let mut it = f.iter().copied().filter(|v| !v.is_nan());
    let Some(first) = it.next() else { return 0.0 };
    let same = |a: f64, b: f64| (a - b).abs() <= SAME_FACTOR_RTOL * a.abs().max(b.abs());
    if it.all(|v| same(v, first)) {
        return first;
    }
    let mut v: Vec<f64> = f.iter().copied().filter(|v| !v.is_nan()).collect();
    v.sort_unstable_by(f64::total_cmp);
    let (mut best, mut best_count) = (v[0], 0);
    let mut start = 0;
    for end in 1..=v.len() {
        if end == v.len() || !same(v[end], v[start]) {
            if end - start > best_count {
                (best, best_count) = (v[start], end - start);
            }
            start = end;
        }
    }
    best
}
