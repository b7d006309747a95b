//! Matrix-free apply on a homogeneous full-box lattice from the stencil alone.
//!
//! On a uniform lattice with one material every bond with lattice offset `k` has the same
//! weight `w_k = c g(|k h|) nu_k V^2` and direction `e_k`, so `A u` needs only the stencil
//! (122 entries for `delta = 3h` in 3D) instead of per-bond storage (122 weights per node).
//! The product runs lattice row by lattice row so that its innermost loop is contiguous and
//! vectorizes ([`StencilOperator::apply`]).

use linpd_core::family::grid_stencil;
use linpd_core::kernel::partial_volume;
use linpd_core::{CoreError, Grid, Micromodulus};
use rayon::prelude::*;

/// The stiffness `A` of a homogeneous lattice, applied from its stencil.
#[derive(Debug, Clone)]
pub struct StencilOperator {
    dim: usize,
    counts: [usize; 3],
    offsets: Vec<[i64; 3]>,
    /// `K_s = w_s e_s e_s^T` per offset, upper triangle row by row (xx, xy, xz, yy, yz, zz in
    /// 3D; xx, xy, yy in 2D; x in 1D).
    blocks: Vec<[f64; 6]>,
    /// `K_s` row-major `d x d` (the first `d * d` entries), for the block rows: expanding the
    /// upper triangle per request was 6.6 % of a 70^3 solve's CPU time.
    full_blocks: Vec<[f64; 9]>,
    /// `w_s` per offset.
    weights: Vec<f64>,
    /// The structure-of-arrays copy of `u` of [`StencilOperator::apply`], kept between calls
    /// (fresh each time it was 270 MB of new pages a product at 11M unknowns).
    soa: Scratch,
    /// The diagonal blocks by boundary class ([`StencilOperator::diagonal_block`]), built on
    /// the first request.
    diag_table: std::sync::OnceLock<DiagTable>,
}

/// The diagonal blocks of a stencil by boundary class: a node's block `sum K_s` over the
/// offsets that stay in the box depends only on its distances to the faces, capped at the
/// stencil's reach `R`, so along an axis of `n` sites there are at most `min(n, 2R + 1)`
/// classes.
#[derive(Debug, Clone)]
struct DiagTable {
    /// Per axis, the class of each site.
    class: [Vec<u32>; 3],
    /// Classes per axis.
    n: [usize; 3],
    /// The block of each class triple `c_0 + n_0 (c_1 + n_1 c_2)`, row-major `d x d`.
    blocks: Vec<[f64; 9]>,
}

/// A buffer reused between calls when no other call holds it; cloned empty.
#[derive(Debug, Default)]
struct Scratch(std::sync::Mutex<Vec<f64>>);

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

impl StencilOperator {
    /// The stencil of `micromodulus` on `grid` with horizon `horizon` (homogeneous material).
    pub fn new(grid: &Grid, horizon: f64, micromodulus: &Micromodulus) -> Result<Self, CoreError> {
        if !grid.is_full() || !grid.has_uniform_volumes() {
            // the row-wise apply indexes every lattice site
            return Err(CoreError::param(
                "grid",
                "the stencil operator needs the full lattice box with volumes h^d; a body removed nodes or cut their cells",
            ));
        }
        Self::on_box(grid, horizon, micromodulus)
    }

    /// The stencil of `micromodulus` with volumes `h^d` on every site of `grid`'s lattice box,
    /// whatever a body removed or cut (the reference operator of
    /// [`crate::corrected::CorrectedStencil`], which applies it over the box's sites).
    pub(crate) fn on_box(grid: &Grid, horizon: f64, micromodulus: &Micromodulus) -> Result<Self, CoreError> {
        let (dim, h) = (grid.dim(), grid.spacing());
        micromodulus.validate(dim)?;
        let c = micromodulus.amplitude(dim, horizon, h)?;
        let vol = grid.volume();
        // the arithmetic of `BondOperator::on_grid`'s weights, so that equal bonds are equal
        // to the bit
        Self::from_weight(grid, horizon, |r| {
            let nu = if micromodulus.partial_volume { partial_volume(r, horizon, h) } else { 1.0 };
            c * micromodulus.kernel.shape(r, horizon) * nu * 1.0 * vol * vol
        })
    }

    /// The stencil of bonds with weight `w_s = weight(|k_s| h)` on every site of `grid`'s
    /// lattice box (the offsets of [`grid_stencil`] within `horizon`): the pair part of another
    /// model on a lattice (the LPS tangent's, `linpd-lps`).
    pub fn from_weight(grid: &Grid, horizon: f64, weight: impl Fn(f64) -> f64) -> Result<Self, CoreError> {
        let dim = grid.dim();
        let h = grid.spacing();
        let counts = grid.counts();
        let offsets = grid_stencil(grid, horizon / h);
        if offsets.is_empty() {
            return Err(CoreError::param("horizon", "gives no bonds"));
        }
        let length = |k: &[i64; 3]| h * ((k[0] * k[0] + k[1] * k[1] + k[2] * k[2]) as f64).sqrt();
        let weights: Vec<f64> = offsets.iter().map(|k| weight(length(k))).collect();
        let blocks: Vec<[f64; 6]> = offsets
            .iter()
            .zip(&weights)
            .map(|(k, &w)| {
                let r = length(k);
                let e = [k[0] as f64 * h / r, k[1] as f64 * h / r, k[2] as f64 * h / r];
                let mut block = [0.0; 6];
                let mut p = 0;
                for a in 0..dim {
                    for b in a..dim {
                        block[p] = w * e[a] * e[b];
                        p += 1;
                    }
                }
                block
            })
            .collect();
        let full_blocks = blocks
            .iter()
            .map(|k: &[f64; 6]| {
                let mut out = [0.0; 9];
                let mut p = 0;
                for a in 0..dim {
                    for b in a..dim {
                        out[a * dim + b] = k[p];
                        out[b * dim + a] = k[p];
                        p += 1;
                    }
                }
                out
            })
            .collect();
        Ok(StencilOperator {
            dim,
            counts,
            offsets,
            blocks,
            full_blocks,
            weights,
            soa: Scratch::default(),
            diag_table: std::sync::OnceLock::new(),
        })
    }

    /// The lattice offsets `s` (those of [`grid_stencil`]).
    pub fn offsets(&self) -> &[[i64; 3]] {
        &self.offsets
    }
    /// `w_s` per offset.
    pub(crate) fn weights(&self) -> &[f64] {
        &self.weights
    }
    /// Sites per axis of the box (1 on unused axes).
    pub fn counts(&self) -> [usize; 3] {
        self.counts
    }

    /// Calls `f(j, s)` for the node `j = i + offset s` of every offset `s` whose site lies in
    /// the box (the bonds of node `i`: the family of `BondFamily::from_grid`).
    pub fn for_each_neighbour(&self, i: usize, f: &mut dyn FnMut(usize, usize)) {
        linpd_core::for_each_box_offset(i, self.counts, &self.offsets, f)
    }

    /// `K_s` of every offset, row-major `d x d` in the first `d * d` entries.
    pub fn blocks(&self) -> &[[f64; 9]] {
        &self.full_blocks
    }
    /// `K_s` of offset `s` as a row-major `d x d` block.
    pub fn block(&self, s: usize) -> [f64; 9] {
        self.full_blocks[s]
    }

    /// Block row `i` of `A`: `A_ij = -K_s` for every neighbour `j = i + s`, then `A_ii = sum
    /// K_s` (the order and blocks of `BondOperator`'s `for_each_block` on the same lattice).
    pub fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) {
        let dd = self.dim * self.dim;
        let mut diag = [0.0; 9];
        self.for_each_neighbour(i, &mut |j, s| {
            let mut b = self.block(s);
            for (d, v) in diag.iter_mut().zip(b.iter_mut()) {
                *d += *v;
                *v = -*v;
            }
            f(j, &b[..dd]);
        });
        f(i, &diag[..dd]);
    }

    /// The diagonal block `A_ii = sum K_s` of node `i` (row-major `d x d` into `out`), from a
    /// table of the boundary classes (the nodes with the same distances to the faces, capped
    /// at the stencil's reach), built on the first call: one pass over the offsets per class
    /// instead of per node.
    pub fn diagonal_block(&self, i: usize, out: &mut [f64]) {
        let t = self.diag_table.get_or_init(|| self.diag_table());
        let site = linpd_core::box_site(i, self.counts);
        let k = t.class[0][site[0]] as usize
            + t.n[0] * (t.class[1][site[1]] as usize + t.n[1] * t.class[2][site[2]] as usize);
        let dd = self.dim * self.dim;
        out[..dd].copy_from_slice(&t.blocks[k][..dd]);
    }

    fn diag_table(&self) -> DiagTable {
        let reach: [usize; 3] =
            [0, 1, 2].map(|a| self.offsets.iter().map(|k| k[a].unsigned_abs() as usize).max().unwrap_or(0));
        let mut class: [Vec<u32>; 3] = Default::default();
        let mut rep: [Vec<usize>; 3] = Default::default();
        for a in 0..3 {
            let (n, r) = (self.counts[a], reach[a]);
            let mut seen: Vec<(usize, usize)> = Vec::new();
            class[a] = (0..n)
                .map(|s| {
                    let key = (s.min(r), (n - 1 - s).min(r));
                    match seen.iter().position(|k| *k == key) {
                        Some(p) => p as u32,
                        None => {
                            seen.push(key);
                            rep[a].push(s);
                            (seen.len() - 1) as u32
                        }
                    }
                })
                .collect();
        }
        let n = [rep[0].len(), rep[1].len(), rep[2].len()];
        let c = self.counts;
        let blocks = (0..n[0] * n[1] * n[2])
            .into_par_iter()
            .map(|k| {
                let site = [rep[0][k % n[0]], rep[1][(k / n[0]) % n[1]], rep[2][k / (n[0] * n[1])]];
                let node = linpd_core::box_node(site, c);
                let mut b = [0.0; 9];
                self.for_each_neighbour(node, &mut |_, s| {
                    b.iter_mut().zip(self.full_blocks[s].iter()).for_each(|(b, k)| *b += k);
                });
                b
            })
            .collect();
        DiagTable { class, n, blocks }
    }

    /// The diagonal of `A` over all DOFs, from the diagonal blocks' table
    /// ([`StencilOperator::diagonal_block`]: the same sums).
    pub fn diagonal(&self) -> Vec<f64> {
        let d = self.dim;
        let n: usize = self.counts.iter().product();
        let mut out = vec![0.0; d * n];
        out.par_chunks_mut(d).enumerate().for_each(|(i, o)| {
            let mut b = [0.0; 9];
            self.diagonal_block(i, &mut b);
            for a in 0..d {
                o[a] = b[a * d + a];
            }
        });
        out
    }

    /// The number of bonds counted from both ends (`BondFamily::n_bonds` of the lattice):
    /// `sum_s prod_a (n_a - |s_a|)`.
    pub fn n_bonds(&self) -> usize {
        self.offsets
            .iter()
            .map(|k| (0..3).map(|a| self.counts[a].saturating_sub(k[a].unsigned_abs() as usize)).product::<usize>())
            .sum()
    }

    /// Number of DOFs.
    pub fn n_dofs(&self) -> usize {
        self.dim * self.counts.iter().product::<usize>()
    }
    /// Stencil size (bonds per interior node).
    pub fn stencil_len(&self) -> usize {
        self.offsets.len()
    }

    /// `y = A u` over all DOFs.
    ///
    /// Written as `y_i = sum_s K_s (u_i - u_{i + s})` with the `d x d` blocks `K_s = w_s e_s
    /// e_s^T`, lattice row by lattice row (the lines along the first axis): for each offset the
    /// row's nodes read a contiguous stretch of a neighbouring row, so the innermost loop runs
    /// over contiguous memory in structure-of-arrays copies of `u` and vectorizes (AVX2 when the
    /// CPU has it, chosen at run time; the results are the same either way). Measured on a 70^3
    /// lattice with `delta = 3h` (122 bonds a node, 2 cores): see docs/solvers.md.
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        assert_eq!(u.len(), self.n_dofs());
        assert_eq!(y.len(), self.n_dofs());
        match self.dim {
            1 => self.apply_rows::<1>(u, y),
            2 => self.apply_rows::<2>(u, y),
            _ => self.apply_rows::<3>(u, y),
        }
    }

    fn apply_rows<const D: usize>(&self, u: &[f64], y: &mut [f64]) {
        let [n0, n1, n2] = self.counts;
        let nodes = n0 * n1 * n2;
        // structure of arrays: component a of node i at soa[a * nodes + i]; the kept buffer
        // unless another product holds it
        let mut own = Vec::new();
        let mut kept = self.soa.0.try_lock().ok();
        let soa: &mut Vec<f64> = kept.as_deref_mut().unwrap_or(&mut own);
        soa.resize(D * nodes, 0.0);
        soa.par_chunks_mut(nodes).enumerate().for_each(|(a, c)| {
            for (i, v) in c.iter_mut().enumerate() {
                *v = u[D * i + a];
            }
        });
        #[cfg(target_arch = "x86_64")]
        let wide = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let wide = false;
        // rows in parallel, and long rows (1D bars) cut into segments of at most SEGMENT nodes
        y.par_chunks_mut(D * n0).enumerate().for_each(|(row, yr)| {
            let (j1, j2) = ((row % n1) as i64, (row / n1) as i64);
            yr.par_chunks_mut(D * SEGMENT).enumerate().for_each_init(
                || vec![0.0; D * SEGMENT],
                |acc, (segment, ys)| {
                    let (x0, len) = (segment * SEGMENT, ys.len() / D);
                    acc.iter_mut().for_each(|v| *v = 0.0);
                    for (k, block) in self.offsets.iter().zip(&self.blocks) {
                        let (s1, s2) = (j1 + k[1], j2 + k[2]);
                        if s1 < 0 || s1 >= n1 as i64 || s2 < 0 || s2 >= n2 as i64 {
                            continue;
                        }
                        // nodes x of this segment with x + k0 inside the source row
                        let lo = ((-k[0]).max(0) as usize).max(x0);
                        let hi = ((n0 as i64 - k[0]).min(n0 as i64).max(0) as usize).min(x0 + len);
                        if lo >= hi {
                            continue;
                        }
                        let own = row * n0;
                        let src = (s1 as usize + n1 * s2 as usize) * n0;
                        // lo >= -k[0], so the source start is never below 0 (src + k[0] alone may be)
                        let start = (src as i64 + k[0] + lo as i64) as usize;
                        let rows = RowPair { soa, nodes, own: own + lo, src: start, len: hi - lo };
                        #[cfg(target_arch = "x86_64")]
                        if wide {
                            // SAFETY: AVX2 was detected at run time just above.
                            unsafe { accumulate_avx2::<D>(&rows, block, acc, lo - x0, SEGMENT) };
                            continue;
                        }
                        let _ = wide;
                        accumulate::<D>(&rows, block, acc, lo - x0, SEGMENT);
                    }
                    for x in 0..len {
                        for a in 0..D {
                            ys[D * x + a] = acc[a * SEGMENT + x];
                        }
                    }
                },
            );
        });
    }
}

/// Longest stretch of a lattice row one task of [`StencilOperator::apply`] computes (rows of 2D
/// and 3D lattices are shorter; a 1D bar is one row and is cut into such segments).
const SEGMENT: usize = 1024;

/// The stretch `own..own + len` of a row and the stretch `src..src + len` of the row it is
/// bonded to by one offset, in the structure-of-arrays copy of `u`.
struct RowPair<'a> {
    soa: &'a [f64],
    nodes: usize,
    own: usize,
    src: usize,
    len: usize,
}

/// `acc[a * stride + lo + x] += sum_b K[a][b] (u_b[own + x] - u_b[src + x])` for `x < len`:
/// the innermost loop of [`StencilOperator::apply`], over contiguous memory (vectorizes).
#[inline(always)]
fn accumulate<const D: usize>(rows: &RowPair, k: &[f64; 6], acc: &mut [f64], lo: usize, stride: usize) {
    let len = rows.len;
    let comp = |a: usize, start: usize| &rows.soa[a * rows.nodes + start..a * rows.nodes + start + len];
    match D {
        1 => {
            let (ui, uj) = (comp(0, rows.own), comp(0, rows.src));
            let ax = &mut acc[lo..lo + len];
            for x in 0..len {
                ax[x] += k[0] * (ui[x] - uj[x]);
            }
        }
        2 => {
            let (xi, xj, yi, yj) = (comp(0, rows.own), comp(0, rows.src), comp(1, rows.own), comp(1, rows.src));
            let (ax, rest) = acc.split_at_mut(stride);
            let (ax, ay) = (&mut ax[lo..lo + len], &mut rest[lo..lo + len]);
            for x in 0..len {
                let (dx, dy) = (xi[x] - xj[x], yi[x] - yj[x]);
                ax[x] += k[0] * dx + k[1] * dy;
                ay[x] += k[1] * dx + k[2] * dy;
            }
        }
        _ => {
            let (xi, xj) = (comp(0, rows.own), comp(0, rows.src));
            let (yi, yj) = (comp(1, rows.own), comp(1, rows.src));
            let (zi, zj) = (comp(2, rows.own), comp(2, rows.src));
            let (ax, rest) = acc.split_at_mut(stride);
            let (ay, az) = rest.split_at_mut(stride);
            let (ax, ay, az) = (&mut ax[lo..lo + len], &mut ay[lo..lo + len], &mut az[lo..lo + len]);
            for x in 0..len {
                let (dx, dy, dz) = (xi[x] - xj[x], yi[x] - yj[x], zi[x] - zj[x]);
                ax[x] += k[0] * dx + k[1] * dy + k[2] * dz;
                ay[x] += k[1] * dx + k[3] * dy + k[4] * dz;
                az[x] += k[2] * dx + k[4] * dy + k[5] * dz;
            }
        }
    }
}

/// [`accumulate`] compiled for AVX2 (same arithmetic, wider vectors).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn accumulate_avx2<const D: usize>(rows: &RowPair, k: &[f64; 6], acc: &mut [f64], lo: usize, stride: usize) {
    accumulate::<D>(rows, k, acc, lo, stride)
}
