//! Variable-block-row (VBR) sparse matrices: the storage of every AMG level.
//!
//! Rows are cut into row blocks (level 0: the free components of one node, 1..d rows; coarse
//! levels: the `k_a <= k` coarse unknowns of one aggregate) and columns into column blocks;
//! each stored block is a dense row-major `r_I x c_J` array. One index per block instead of
//! one per entry, and products as small dense kernels: the Galerkin product `P^T A P` of a
//! 3D lattice with 123 partners is `~4e9` multiply-adds, and the dense 3x3 times 3x6 block
//! products run them without a column index per scalar.

use rayon::prelude::*;

/// Split matrices into groups of row blocks holding about this many stored values each: a
/// rayon task per group (smaller groups cost more in scheduling than they gain on 2 cores).
const GROUP_VALUES: usize = 1 << 15;

/// A sparse matrix of dense blocks (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Vbr {
    /// Scalar row offset of each row block (`n_row_blocks + 1`).
    pub rptr: Vec<usize>,
    /// Scalar column offset of each column block (`n_col_blocks + 1`).
    pub cptr: Vec<usize>,
    /// Block-row pointer into `bidx` / `voff`.
    pub bptr: Vec<usize>,
    /// Column block of each stored block, ascending within a block row.
    pub bidx: Vec<u32>,
    /// Offset of each stored block in `val` (`n_blocks + 1`).
    pub voff: Vec<usize>,
    /// Block values, each row-major.
    pub val: Vec<f64>,
    /// Row-block boundaries of the parallel groups.
    groups: Vec<usize>,
    /// `Some(s)` when every row and column block has `s` rows/columns (a lattice without
    /// partially constrained nodes): the products then index blocks as `s*s*b` and run a
    /// fixed-size kernel, which halves the time of a level-0 product in 3D.
    uniform: Option<usize>,
}

pub(crate) fn make_groups(bptr: &[usize], voff: &[usize]) -> Vec<usize> {
    let nb = bptr.len() - 1;
    let mut g = vec![0];
    let mut start = 0;
    for i in 0..nb {
        if voff[bptr[i + 1]] - voff[bptr[start]] >= GROUP_VALUES {
            g.push(i + 1);
            start = i + 1;
        }
    }
    if *g.last().unwrap() != nb {
        g.push(nb);
    }
    g
}

/// Splits `y` at the scalar rows `bounds[k]` (ascending, `bounds[0] = 0`, last = `y.len()`).
pub(crate) fn split_at_bounds<T>(mut y: &mut [T], bounds: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    let mut at = 0;
    for b in bounds.skip(1) {
        let (head, tail) = std::mem::take(&mut y).split_at_mut(b - at);
        out.push(head);
        y = tail;
        at = b;
    }
    out
}

impl Vbr {
    /// From the parts; computes the parallel groups.
    pub fn new(
        rptr: Vec<usize>,
        cptr: Vec<usize>,
        bptr: Vec<usize>,
        bidx: Vec<u32>,
        voff: Vec<usize>,
        val: Vec<f64>,
    ) -> Self {
        debug_assert_eq!(bptr.len(), rptr.len());
        debug_assert_eq!(voff.len(), bidx.len() + 1);
        let groups = make_groups(&bptr, &voff);
        let s = rptr.get(1).copied().unwrap_or(0);
        let same = |p: &[usize]| p.windows(2).all(|w| w[1] - w[0] == s);
        let uniform = (s > 0 && same(&rptr) && same(&cptr)).then_some(s);
        Vbr { rptr, cptr, bptr, bidx, voff, val, groups, uniform }
    }

    /// The identity in row and column blocks `rptr`.
    pub fn identity(rptr: &[usize]) -> Self {
        let nb = rptr.len() - 1;
        let mut voff = vec![0];
        let mut val = Vec::new();
        for b in 0..nb {
            let r = rptr[b + 1] - rptr[b];
            val.extend((0..r * r).map(|p| if p / r == p % r { 1.0 } else { 0.0 }));
            voff.push(val.len());
        }
        Vbr::new(rptr.to_vec(), rptr.to_vec(), (0..=nb).collect(), (0..nb as u32).collect(), voff, val)
    }

    /// Scalar rows.
    pub fn nrows(&self) -> usize {
        *self.rptr.last().unwrap()
    }
    /// Scalar columns.
    pub fn ncols(&self) -> usize {
        *self.cptr.last().unwrap()
    }
    /// Row blocks.
    pub fn n_row_blocks(&self) -> usize {
        self.rptr.len() - 1
    }
    /// Column blocks.
    pub fn n_col_blocks(&self) -> usize {
        self.cptr.len() - 1
    }
    /// Stored scalar entries.
    pub fn nnz(&self) -> usize {
        self.val.len()
    }

    /// Bytes held (values, block indices and offsets, pointers).
    pub fn bytes(&self) -> usize {
        8 * (self.val.len() + self.voff.len() + self.bptr.len() + self.rptr.len() + self.cptr.len() + self.groups.len())
            + 4 * self.bidx.len()
    }

    /// The square symmetric CSC matrix `a` (both triangles) in blocks of the consecutive rows
    /// `rptr` (the same blocks for rows and columns). Column `i` of a symmetric matrix is its
    /// row `i`, so each block row is read from the CSC columns of its rows.
    pub fn from_symmetric_csc(a: &linpd_core::sparse::Csc, rptr: &[usize]) -> Self {
        let n = a.nrows();
        let nb = rptr.len() - 1;
        let mut block_of = vec![0u32; n];
        for b in 0..nb {
            block_of[rptr[b]..rptr[b + 1]].iter_mut().for_each(|v| *v = b as u32);
        }
        let cp = a.symbolic().col_ptr();
        let ri = a.symbolic().row_idx();
        let av = a.val();
        // Pattern per block row, in parallel chunks of block rows.
        let chunk = 512;
        let parts: Vec<(Vec<usize>, Vec<u32>)> = (0..nb.div_ceil(chunk))
            .into_par_iter()
            .map_init(
                // One marker per thread (stamped with the block row), not per chunk.
                || vec![u32::MAX; nb],
                |marker, c| {
                    let mut counts = Vec::new();
                    let mut cols = Vec::new();
                    let mut touched: Vec<u32> = Vec::new();
                    for bi in c * chunk..((c + 1) * chunk).min(nb) {
                        touched.clear();
                        for i in rptr[bi]..rptr[bi + 1] {
                            // Rows are sorted in a column and blocks are runs of rows: look
                            // up the block once per run, not once per entry.
                            let (mut p, end) = (cp[i], cp[i + 1]);
                            while p < end {
                                let bj = block_of[ri[p]];
                                if marker[bj as usize] != bi as u32 {
                                    marker[bj as usize] = bi as u32;
                                    touched.push(bj);
                                }
                                let stop = rptr[bj as usize + 1];
                                while p < end && ri[p] < stop {
                                    p += 1;
                                }
                            }
                        }
                        touched.sort_unstable();
                        counts.push(touched.len());
                        cols.extend_from_slice(&touched);
                    }
                    (counts, cols)
                },
            )
            .collect();
        let mut bptr = vec![0usize];
        let mut bidx = Vec::new();
        for (counts, cols) in parts {
            for c in counts {
                bptr.push(bptr.last().unwrap() + c);
            }
            bidx.extend(cols);
        }
        let mut voff = Vec::with_capacity(bidx.len() + 1);
        voff.push(0);
        for bi in 0..nb {
            let r = rptr[bi + 1] - rptr[bi];
            for &bj in &bidx[bptr[bi]..bptr[bi + 1]] {
                let c = rptr[bj as usize + 1] - rptr[bj as usize];
                voff.push(voff.last().unwrap() + r * c);
            }
        }
        let mut val = vec![0.0; *voff.last().unwrap()];
        // Fill: split val at block-row boundaries, one task per block row chunk.
        let row_bounds = (0..=nb).map(|b| voff[bptr[b]]);
        let mut rows: Vec<&mut [f64]> = split_at_bounds(&mut val, row_bounds);
        rows.par_iter_mut().enumerate().with_min_len(256).for_each(|(bi, vals)| {
            let base = voff[bptr[bi]];
            let r0 = rptr[bi];
            let blocks = &bidx[bptr[bi]..bptr[bi + 1]];
            for i in rptr[bi]..rptr[bi + 1] {
                let mut pos = 0;
                let (mut p, end) = (cp[i], cp[i + 1]);
                while p < end {
                    let bj = block_of[ri[p]];
                    // Blocks come in ascending order along the sorted rows.
                    while blocks[pos] != bj {
                        pos += 1;
                    }
                    let b = bptr[bi] + pos;
                    let c0 = rptr[bj as usize];
                    let cw = rptr[bj as usize + 1] - c0;
                    let o = voff[b] - base + (i - r0) * cw;
                    let dst = &mut vals[o..o + cw];
                    while p < end && ri[p] < c0 + cw {
                        dst[ri[p] - c0] += av[p];
                        p += 1;
                    }
                }
            }
        });
        Vbr::new(rptr.to_vec(), rptr.to_vec(), bptr, bidx, voff, val)
    }

    /// The matrix as a CSC with `usize` indices, assuming it is symmetric: column `j` is
    /// written from row `j`, which keeps the rows of each column sorted.
    pub fn to_symmetric_csc(&self) -> linpd_core::sparse::Csc {
        let n = self.nrows();
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0usize);
        let mut rows = Vec::with_capacity(self.nnz());
        let mut vals = Vec::with_capacity(self.nnz());
        for bi in 0..self.n_row_blocks() {
            let (r0, r1) = (self.rptr[bi], self.rptr[bi + 1]);
            for i in 0..r1 - r0 {
                for b in self.bptr[bi]..self.bptr[bi + 1] {
                    let bj = self.bidx[b] as usize;
                    let (c0, c1) = (self.cptr[bj], self.cptr[bj + 1]);
                    let cw = c1 - c0;
                    let v = &self.val[self.voff[b] + i * cw..self.voff[b] + (i + 1) * cw];
                    for (t, &x) in v.iter().enumerate() {
                        rows.push(c0 + t);
                        vals.push(x);
                    }
                }
                col_ptr.push(rows.len());
            }
        }
        faer::sparse::SparseColMat::new(
            faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows),
            vals,
        )
    }

    /// The scalar diagonal (square matrices with equal row and column blocks).
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.nrows()];
        for bi in 0..self.n_row_blocks() {
            let r0 = self.rptr[bi];
            let r = self.rptr[bi + 1] - r0;
            if let Some(b) = self.find(bi, bi) {
                for i in 0..r {
                    d[r0 + i] = self.val[self.voff[b] + i * r + i];
                }
            }
        }
        d
    }

    /// Index of the stored block `(bi, bj)`.
    pub fn find(&self, bi: usize, bj: usize) -> Option<usize> {
        let s = &self.bidx[self.bptr[bi]..self.bptr[bi + 1]];
        s.binary_search(&(bj as u32)).ok().map(|p| self.bptr[bi] + p)
    }

    fn par_rows<F>(&self, y: &mut [f64], f: F)
    where
        F: Fn(usize, &mut [f64]) + Sync,
    {
        debug_assert_eq!(y.len(), self.nrows());
        let g = &self.groups;
        if g.len() <= 2 {
            for bi in 0..self.n_row_blocks() {
                f(bi, &mut y[self.rptr[bi]..self.rptr[bi + 1]]);
            }
            return;
        }
        let mut parts = split_at_bounds(y, g.iter().map(|&b| self.rptr[b]));
        parts.par_iter_mut().enumerate().for_each(|(k, ys)| {
            let base = self.rptr[g[k]];
            for bi in g[k]..g[k + 1] {
                f(bi, &mut ys[self.rptr[bi] - base..self.rptr[bi + 1] - base]);
            }
        });
    }

    /// `y_I = sum_J A_IJ x_J` for block row `bi`, added to `y` with sign `s`.
    #[inline]
    fn row_apply(&self, bi: usize, x: &[f64], yi: &mut [f64], s: f64) {
        let r = yi.len();
        for b in self.bptr[bi]..self.bptr[bi + 1] {
            let bj = self.bidx[b] as usize;
            let (c0, c1) = (self.cptr[bj], self.cptr[bj + 1]);
            let xs = &x[c0..c1];
            let v = &self.val[self.voff[b]..self.voff[b + 1]];
            match (r, xs.len()) {
                // The level-0 blocks of 3D and 2D lattices: fixed sizes let the compiler unroll.
                (3, 3) => block_apply::<3, 3>(v, xs, yi, s),
                (2, 2) => block_apply::<2, 2>(v, xs, yi, s),
                (6, 6) => block_apply::<6, 6>(v, xs, yi, s),
                (3, 6) => block_apply::<3, 6>(v, xs, yi, s),
                (6, 3) => block_apply::<6, 3>(v, xs, yi, s),
                _ => {
                    for (i, row) in v.chunks_exact(xs.len()).enumerate() {
                        yi[i] += s * row.iter().zip(xs).map(|(a, b)| a * b).sum::<f64>();
                    }
                }
            }
        }
    }

    /// `y = keep * y + s * A x` (`keep` 0 or 1).
    fn apply_into(&self, x: &[f64], y: &mut [f64], keep: f64, s: f64) {
        debug_assert_eq!(x.len(), self.ncols());
        match self.uniform {
            Some(1) => self.par_rows(y, |bi, yi| self.row_apply_uniform::<1>(bi, x, yi, keep, s)),
            Some(2) => self.par_rows(y, |bi, yi| self.row_apply_uniform::<2>(bi, x, yi, keep, s)),
            Some(3) => self.par_rows(y, |bi, yi| self.row_apply_uniform::<3>(bi, x, yi, keep, s)),
            Some(6) => self.par_rows(y, |bi, yi| self.row_apply_uniform::<6>(bi, x, yi, keep, s)),
            _ => self.par_rows(y, |bi, yi| {
                if keep == 0.0 {
                    yi.iter_mut().for_each(|v| *v = 0.0);
                }
                self.row_apply(bi, x, yi, s);
            }),
        }
    }

    /// [`Vbr::row_apply`] for uniform `S x S` blocks, accumulated in registers.
    #[inline]
    fn row_apply_uniform<const S: usize>(&self, bi: usize, x: &[f64], yi: &mut [f64], keep: f64, s: f64) {
        let mut acc = [0.0f64; S];
        let (b0, b1) = (self.bptr[bi], self.bptr[bi + 1]);
        let vals = &self.val[b0 * S * S..b1 * S * S];
        for (v, &j) in vals.chunks_exact(S * S).zip(&self.bidx[b0..b1]) {
            let xs: &[f64; S] = x[j as usize * S..j as usize * S + S].try_into().unwrap();
            for i in 0..S {
                for k in 0..S {
                    acc[i] += v[i * S + k] * xs[k];
                }
            }
        }
        for i in 0..S {
            yi[i] = keep * yi[i] + s * acc[i];
        }
    }

    /// `y = A x`.
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        self.apply_into(x, y, 0.0, 1.0);
    }

    /// `y += A x`.
    pub fn matvec_add(&self, x: &[f64], y: &mut [f64]) {
        self.apply_into(x, y, 1.0, 1.0);
    }

    /// `y -= A x`.
    pub fn matvec_sub(&self, x: &[f64], y: &mut [f64]) {
        self.apply_into(x, y, 1.0, -1.0);
    }

    /// `A^T`, blocks transposed.
    pub fn transpose(&self) -> Vbr {
        let nbr = self.n_row_blocks();
        let nbc = self.n_col_blocks();
        let mut count = vec![0usize; nbc + 1];
        for &bj in &self.bidx {
            count[bj as usize + 1] += 1;
        }
        for j in 0..nbc {
            count[j + 1] += count[j];
        }
        let bptr = count.clone();
        let mut next = count;
        let mut bidx = vec![0u32; self.bidx.len()];
        let mut src = vec![0usize; self.bidx.len()];
        for bi in 0..nbr {
            for b in self.bptr[bi]..self.bptr[bi + 1] {
                let bj = self.bidx[b] as usize;
                bidx[next[bj]] = bi as u32;
                src[next[bj]] = b;
                next[bj] += 1;
            }
        }
        let mut voff = Vec::with_capacity(bidx.len() + 1);
        voff.push(0);
        for &b in &src {
            voff.push(voff.last().unwrap() + (self.voff[b + 1] - self.voff[b]));
        }
        let mut val = vec![0.0; self.val.len()];
        let mut blocks: Vec<&mut [f64]> = split_at_bounds(&mut val, voff.iter().copied());
        let rptr = &self.rptr;
        blocks.par_iter_mut().with_min_len(1024).enumerate().for_each(|(t, out)| {
            let b = src[t];
            let bi = bidx[t] as usize;
            let r = rptr[bi + 1] - rptr[bi];
            let c = out.len() / r.max(1);
            let v = &self.val[self.voff[b]..self.voff[b + 1]];
            // v is r x c row-major; out is c x r row-major.
            for i in 0..r {
                for j in 0..c {
                    out[j * r + i] = v[i * c + j];
                }
            }
        });
        Vbr::new(self.cptr.clone(), self.rptr.clone(), bptr, bidx, voff, val)
    }

    /// The stored block rows as the `pattern` and `row` descriptions of [`mul_rows`] and
    /// [`galerkin_rows`].
    #[allow(clippy::type_complexity)]
    fn block_rows(
        &self,
    ) -> (impl Fn(usize, &mut dyn FnMut(usize)) + Sync + '_, impl Fn(usize, &mut dyn FnMut(usize, &[f64])) + Sync + '_)
    {
        let pattern = |bi: usize, f: &mut dyn FnMut(usize)| {
            for &bj in &self.bidx[self.bptr[bi]..self.bptr[bi + 1]] {
                f(bj as usize);
            }
        };
        let row = |bi: usize, f: &mut dyn FnMut(usize, &[f64])| {
            for a in self.bptr[bi]..self.bptr[bi + 1] {
                f(self.bidx[a] as usize, &self.val[self.voff[a]..self.voff[a + 1]]);
            }
        };
        (pattern, row)
    }

    /// `C = A B` (the column blocks of `A` are the row blocks of `B`): [`mul_rows`] over the
    /// stored block rows.
    pub fn mul(&self, bm: &Vbr) -> Vbr {
        debug_assert_eq!(self.cptr, bm.rptr);
        let (pattern, row) = self.block_rows();
        mul_rows(&self.rptr, &self.groups, &pattern, &row, bm)
    }

    /// `R A P` with `R = P^T` ([`galerkin_rows`] over the stored block rows).
    pub fn galerkin(&self, p: &Vbr, r: &Vbr) -> Vbr {
        debug_assert_eq!(self.cptr, p.rptr);
        let (pattern, row) = self.block_rows();
        galerkin_rows(&self.rptr, &self.groups, &pattern, &row, p, r)
    }
}

/// `C = A B` block row by block row (Gustavson's algorithm on blocks) in the two passes of
/// sparse matrix products: a symbolic pass finds the column blocks of each block row of `C`,
/// its arrays are allocated once, and a numeric pass accumulates every block row in place.
/// Block row `bi` of `A` (scalar rows `rptr[bi]..rptr[bi + 1]`) is what `row(bi, f)` passes to
/// `f(bj, A_{bi bj})` (row-major blocks, each `bj` once): stored blocks, or blocks computed on
/// demand for a finest level that is never stored; `pattern(bi, f)` passes the same `bj`
/// without the values. The row blocks are split into the parallel `groups` (boundaries).
///
/// Why two passes: `C` is large (`A P` of a 3D lattice with 123 partners: 1.1 GB at 10^6
/// unknowns). Built per group and then concatenated, it was written twice and its pages were
/// first touched by one thread, which on this project's virtual machine cost 3 of the 6 s of
/// that product and 1 GB of extra peak memory (docs/solvers.md). The symbolic pass costs one
/// more reading of `A`'s blocks (computing them again on a matrix-free level) and no flops.
pub(crate) fn mul_rows<P, R>(rptr: &[usize], groups: &[usize], pattern: &P, row: &R, bm: &Vbr) -> Vbr
where
    P: Fn(usize, &mut dyn FnMut(usize)) + Sync,
    R: Fn(usize, &mut dyn FnMut(usize, &[f64])) + Sync,
{
    let nbc = bm.n_col_blocks();
    let g = groups;
    let block_cols = |j: usize| &bm.bidx[bm.bptr[j]..bm.bptr[j + 1]];
    let (bptr, bidx) = product_pattern(rptr.len() - 1, groups, pattern, nbc, &block_cols);
    let nbr = rptr.len() - 1;
    let mut voff = Vec::with_capacity(bidx.len() + 1);
    voff.push(0);
    for bi in 0..nbr {
        let r = rptr[bi + 1] - rptr[bi];
        for &bk in &bidx[bptr[bi]..bptr[bi + 1]] {
            let ck = bm.cptr[bk as usize + 1] - bm.cptr[bk as usize];
            voff.push(voff.last().unwrap() + r * ck);
        }
    }
    // Numeric pass, each group into its own range of the values. Each block row is zeroed
    // before it is accumulated: `vec!` maps the zero page lazily, and a page first read
    // (`+=`) and then written faults twice and flushes the other cores' TLBs, which doubled
    // the system time of a 10^6-unknown setup (a write-first page faults once).
    let mut val = vec![0.0; *voff.last().unwrap()];
    let ranges = split_at_bounds(&mut val, g.iter().map(|&b| voff[bptr[b]]));
    ranges.into_par_iter().enumerate().for_each_init(
        || vec![0usize; nbc],
        |slot, (k, vals)| {
            let base = voff[bptr[g[k]]];
            for bi in g[k]..g[k + 1] {
                // Where each column block of this row sits in `vals`.
                for b in bptr[bi]..bptr[bi + 1] {
                    slot[bidx[b] as usize] = voff[b] - base;
                }
                vals[voff[bptr[bi]] - base..voff[bptr[bi + 1]] - base].fill(0.0);
                let r = rptr[bi + 1] - rptr[bi];
                row(bi, &mut |bj, av| mul_block_row(r, bj, av, bm, slot, vals));
            }
        },
    );
    Vbr::new(rptr.to_vec(), bm.cptr.clone(), bptr, bidx, voff, val)
}

/// The symbolic pass of [`mul_rows`] and [`galerkin_rows`]: the column blocks of every block
/// row of `A B` (`nbr` block rows of `A`, each described by `pattern`, split into the parallel
/// `groups`), ascending, as a block row pointer and the column blocks; `block_cols(j)` lists the
/// column blocks of row `j` of `B` (of `n_col_blocks`), ascending.
fn product_pattern<'b, P, B>(
    nbr: usize,
    groups: &[usize],
    pattern: &P,
    n_col_blocks: usize,
    block_cols: &B,
) -> (Vec<usize>, Vec<u32>)
where
    P: Fn(usize, &mut dyn FnMut(usize)) + Sync,
    B: Fn(usize) -> &'b [u32] + Sync,
{
    let g = groups;
    let patterns: Vec<(Vec<usize>, Vec<u32>)> = (0..g.len() - 1)
        .into_par_iter()
        .map_init(
            || vec![false; n_col_blocks],
            |seen, k| {
                let mut counts = Vec::with_capacity(g[k + 1] - g[k]);
                let mut cols = Vec::new();
                for bi in g[k]..g[k + 1] {
                    let start = cols.len();
                    pattern(bi, &mut |bj| {
                        for &bk in block_cols(bj) {
                            if !seen[bk as usize] {
                                seen[bk as usize] = true;
                                cols.push(bk);
                            }
                        }
                    });
                    let row_cols = &mut cols[start..];
                    row_cols.sort_unstable();
                    for &bk in row_cols.iter() {
                        seen[bk as usize] = false;
                    }
                    counts.push(row_cols.len());
                }
                (counts, cols)
            },
        )
        .collect();
    let mut bptr = Vec::with_capacity(nbr + 1);
    bptr.push(0);
    let mut bidx = Vec::with_capacity(patterns.iter().map(|p| p.1.len()).sum());
    for (counts, cols) in &patterns {
        for c in counts {
            bptr.push(bptr.last().unwrap() + c);
        }
        bidx.extend_from_slice(cols);
    }
    (bptr, bidx)
}

/// The Galerkin product `A_c = R (A P)` with `R = P^T` (`r`), without storing `A P`: the
/// rows of `A` (described as in [`mul_rows`]) are cut into one contiguous range per thread;
/// each thread computes the block rows of `A P` of its range one at a time into a buffer it
/// reuses and adds `P_{iI}^T (A P)_{iJ}` for every block `P_{iI}` of row `i` of `P` into its
/// own copy of `A_c` (pattern known beforehand: the block rows of `R` times the pattern of
/// `A P`), and the copies are summed.
///
/// Why: `A P` is the setup's largest array (1.1 GB for a 3D lattice with 123 partners at 10^6
/// unknowns, 18x the 60 MB of `A_c`), and on this project's virtual machine writing fresh
/// memory costs more than the flops (docs/solvers.md). Same flops as `R.mul(&A.mul(P))`; the
/// sums run in another order (equal to round-off, tested).
pub(crate) fn galerkin_rows<P, R>(rptr: &[usize], groups: &[usize], pattern: &P, row: &R, p: &Vbr, r: &Vbr) -> Vbr
where
    P: Fn(usize, &mut dyn FnMut(usize)) + Sync,
    R: Fn(usize, &mut dyn FnMut(usize, &[f64])) + Sync,
{
    let nbr = rptr.len() - 1;
    let ncb = p.n_col_blocks();
    // The pattern of A P, then that of A_c: row I is the union of the rows i of A P with
    // R_{Ii} != 0.
    let p_cols = |j: usize| &p.bidx[p.bptr[j]..p.bptr[j + 1]];
    let (ap_ptr, ap_idx) = product_pattern(nbr, groups, pattern, ncb, &p_cols);
    let ap_cols = |i: usize| &ap_idx[ap_ptr[i]..ap_ptr[i + 1]];
    let r_rows = |bi: usize, f: &mut dyn FnMut(usize)| {
        r.bidx[r.bptr[bi]..r.bptr[bi + 1]].iter().for_each(|&i| f(i as usize));
    };
    let (c_ptr, c_idx) = product_pattern(ncb, &r.groups, &r_rows, ncb, &ap_cols);
    let size = |bk: usize| p.cptr[bk + 1] - p.cptr[bk];
    let mut c_off = Vec::with_capacity(c_idx.len() + 1);
    c_off.push(0usize);
    for bi in 0..ncb {
        for &bj in &c_idx[c_ptr[bi]..c_ptr[bi + 1]] {
            c_off.push(c_off.last().unwrap() + size(bi) * size(bj as usize));
        }
    }
    let nnz_c = *c_off.last().unwrap();
    // One range of fine rows per thread, each into its own copy of A_c (at most 8 copies:
    // the copies, not A P, then bound the memory).
    debug_assert_eq!(r.bptr.len(), ncb + 1, "r is P^T");
    let threads = rayon::current_num_threads().clamp(1, 8);
    let copies: Vec<Vec<f64>> = (0..threads)
        .into_par_iter()
        .map(|t| {
            let mut acc = vec![0.0; nnz_c];
            // write first (see `mul_rows`): the copy's pages fault once
            acc.fill(0.0);
            let mut slot = vec![0usize; ncb];
            let mut ap = Vec::new();
            for i in nbr * t / threads..nbr * (t + 1) / threads {
                // (A P)_i into `ap`, its blocks in the order of `ap_cols(i)`
                let ri = rptr[i + 1] - rptr[i];
                let mut len = 0;
                for &bk in ap_cols(i) {
                    slot[bk as usize] = len;
                    len += ri * size(bk as usize);
                }
                ap.clear();
                ap.resize(len, 0.0);
                row(i, &mut |bj, av| mul_block_row(ri, bj, av, p, &slot, &mut ap));
                // A_c[I, J] += P_{iI}^T (A P)_{iJ}: both column lists ascend, and those of
                // (A P)_i are in row I of A_c, so one merge walk finds them
                for b in p.bptr[i]..p.bptr[i + 1] {
                    let bi = p.bidx[b] as usize;
                    let pv = &p.val[p.voff[b]..p.voff[b + 1]];
                    let ki = size(bi);
                    let mut q = c_ptr[bi];
                    let mut at = 0;
                    for &bj in ap_cols(i) {
                        while c_idx[q] != bj {
                            q += 1;
                            debug_assert!(q < c_ptr[bi + 1], "(A P)_i has a column outside row I of A_c");
                        }
                        let kj = size(bj as usize);
                        let out = &mut acc[c_off[q]..c_off[q] + ki * kj];
                        let apv = &ap[at..at + ri * kj];
                        at += ri * kj;
                        match (ri, ki, kj) {
                            (3, 6, 6) => block_tmul::<3, 6, 6>(pv, apv, out),
                            (2, 3, 3) => block_tmul::<2, 3, 3>(pv, apv, out),
                            (6, 6, 6) => block_tmul::<6, 6, 6>(pv, apv, out),
                            (3, 3, 3) => block_tmul::<3, 3, 3>(pv, apv, out),
                            _ => {
                                for s in 0..ri {
                                    for a in 0..ki {
                                        let x = pv[s * ki + a];
                                        for (o, &y) in
                                            out[a * kj..(a + 1) * kj].iter_mut().zip(&apv[s * kj..(s + 1) * kj])
                                        {
                                            *o += x * y;
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
            acc
        })
        .collect();
    // the sum, into the first copy
    let mut copies = copies.into_iter();
    let mut val = copies.next().unwrap_or_default();
    let rest: Vec<Vec<f64>> = copies.collect();
    val.par_chunks_mut(1 << 14).enumerate().for_each(|(k, out)| {
        let at = k << 14;
        for (o, v) in out.iter_mut().enumerate() {
            *v += rest.iter().map(|c| c[at + o]).sum::<f64>();
        }
    });
    Vbr::new(p.cptr.clone(), p.cptr.clone(), c_ptr, c_idx, c_off, val)
}

/// `out += A^T B` for row-major `S x R` `A` and `S x K` `B` (`out` is `R x K`).
#[inline(always)]
fn block_tmul<const S: usize, const R: usize, const K: usize>(a: &[f64], b: &[f64], out: &mut [f64]) {
    let a: &[f64] = &a[..S * R];
    let b: &[f64] = &b[..S * K];
    let out: &mut [f64] = &mut out[..R * K];
    for s in 0..S {
        for i in 0..R {
            let x = a[s * R + i];
            for k in 0..K {
                out[i * K + k] += x * b[s * K + k];
            }
        }
    }
}

/// `C_{bi K} += A_{bi bj} B_{bj K}` for the blocks `K` of block row `bj` of `B`: `A_{bi bj}`
/// is `av` (`r` rows), and `C_{bi K}` starts at `vals[slot[K]]`.
#[inline]
fn mul_block_row(r: usize, bj: usize, av: &[f64], bm: &Vbr, slot: &[usize], vals: &mut [f64]) {
    let cj = bm.rptr[bj + 1] - bm.rptr[bj];
    for b in bm.bptr[bj]..bm.bptr[bj + 1] {
        let bk = bm.bidx[b] as usize;
        let ck = bm.cptr[bk + 1] - bm.cptr[bk];
        let o = slot[bk];
        let out = &mut vals[o..o + r * ck];
        let bv = &bm.val[bm.voff[b]..bm.voff[b + 1]];
        match (r, cj, ck) {
            (3, 3, 6) => block_mul::<3, 3, 6>(av, bv, out),
            (3, 3, 3) => block_mul::<3, 3, 3>(av, bv, out),
            (2, 2, 3) => block_mul::<2, 2, 3>(av, bv, out),
            (6, 3, 6) => block_mul::<6, 3, 6>(av, bv, out),
            (6, 6, 6) => block_mul::<6, 6, 6>(av, bv, out),
            (3, 2, 3) => block_mul::<3, 2, 3>(av, bv, out),
            _ => {
                for i in 0..r {
                    for s in 0..cj {
                        let x = av[i * cj + s];
                        let brow = &bv[s * ck..(s + 1) * ck];
                        for (o, &y) in out[i * ck..(i + 1) * ck].iter_mut().zip(brow) {
                            *o += x * y;
                        }
                    }
                }
            }
        }
    }
}

/// `y += s * V x` for a row-major `R x C` block `V`.
#[inline(always)]
fn block_apply<const R: usize, const C: usize>(v: &[f64], x: &[f64], y: &mut [f64], s: f64) {
    let v: &[f64] = &v[..R * C];
    let x: &[f64] = &x[..C];
    for i in 0..R {
        let mut t = 0.0;
        for j in 0..C {
            t += v[i * C + j] * x[j];
        }
        y[i] += s * t;
    }
}

/// `out += A B` for row-major `R x S` `A` and `S x K` `B`.
#[inline(always)]
fn block_mul<const R: usize, const S: usize, const K: usize>(a: &[f64], b: &[f64], out: &mut [f64]) {
    let a: &[f64] = &a[..R * S];
    let b: &[f64] = &b[..S * K];
    let out: &mut [f64] = &mut out[..R * K];
    for i in 0..R {
        for s in 0..S {
            let x = a[i * S + s];
            for k in 0..K {
                out[i * K + k] += x * b[s * K + k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random block matrix: row blocks of `rsz`, column blocks of `csz`, block
    /// `(I, J)` stored when `(I * 7 + J * 3) % 5 < 2` (and on the diagonal when square).
    fn random(rsz: &[usize], csz: &[usize], seed: usize) -> Vbr {
        let ptr = |sz: &[usize]| {
            std::iter::once(0).chain(sz.iter().scan(0, |a, s| Some(*a + s).inspect(|v| *a = *v))).collect::<Vec<_>>()
        };
        let (rptr, cptr) = (ptr(rsz), ptr(csz));
        let (mut bptr, mut bidx, mut voff, mut val) = (vec![0], Vec::new(), vec![0], Vec::new());
        for (i, &r) in rsz.iter().enumerate() {
            for (j, &c) in csz.iter().enumerate() {
                if (i * 7 + j * 3 + seed) % 5 < 2 || (rsz.len() == csz.len() && i == j) {
                    bidx.push(j as u32);
                    val.extend((0..r * c).map(|k| (((i + 1) * (j + 2) * (k + 3) + seed) % 17) as f64 / 17.0 - 0.4));
                    voff.push(val.len());
                }
            }
            bptr.push(bidx.len());
        }
        Vbr::new(rptr, cptr, bptr, bidx, voff, val)
    }

    /// The fused Galerkin product equals `R (A P)` (same pattern, values to round-off: the
    /// same products summed in another order), on 1 and 2 threads, with mixed block sizes
    /// (the generic kernels) and the `3 x 3` / `3 x 6` lattice sizes (the fixed ones). Tolerance
    /// 1e-14 of the largest entry: sums of a few dozen products of entries below 1, eps 1.1e-16.
    #[test]
    fn galerkin_is_r_times_a_times_p() {
        let mixed: Vec<usize> = (0..23).map(|i| [3, 2, 3, 1][i % 4]).collect();
        for (rows, coarse) in [(vec![3; 40], vec![6; 9]), (mixed, (0..7).map(|i| [6, 3, 5][i % 3]).collect())] {
            let a = random(&rows, &rows, 1);
            let p = random(&rows, &coarse, 2);
            let r = p.transpose();
            let expected = r.mul(&a.mul(&p));
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let got = pool.install(|| a.galerkin(&p, &r));
                assert_eq!((&got.bptr, &got.bidx, &got.voff), (&expected.bptr, &expected.bidx, &expected.voff));
                let scale = expected.val.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let diff = got.val.iter().zip(&expected.val).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                assert!(diff <= 1e-14 * scale, "{threads} threads: {diff:e} of {scale:e}");
                assert!(scale > 0.0);
            }
        }
    }
}
