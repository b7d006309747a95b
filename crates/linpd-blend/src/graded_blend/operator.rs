//! The graded blend's `A` and its SPD companion `M` over the masters, as applied: each row is
//! its nonlocal shares plus a stored rest,
//!
//! ```text
//! A = N + L_A,    M = N + L_M,    N u|_i = sum_j a_ij w_ij e e^T (u_i - u_j),   a_ij = (beta_i + beta_j) / 2,
//! ```
//!
//! `N` as a list of its shares per row ([`Shares`], 16 bytes a share, one list for `A` and
//! `M`, where a stored block row of Algorithm A's 123 blocks in 3D at `delta = 3h` took
//! 17.7 KB in `A` and again in `M`), and the rests `L_A`, `L_M` as block rows
//! ([`BlockCsr`]): for a master of `R` the transition terms and the `1 - beta_i` elements of
//! `A`, the weighted elements of `M` (at most `3^d` blocks from the cells and the difference
//! stencils' few more); for any other master its row of `K_M`, the same in `A` and `M` and
//! stored once. `N` is symmetric (`a_ij w_ij e e^T` is the same block seen from either end) and
//! positive semi-definite; it reads only masters: a share with `a_ij > 0` has an end with
//! `beta > 0`, so both ends are in `R`, on level-0 cells.

use super::GradedBlend;
use crate::lattice::BlockRow;
use linpd_bond::BondOperator;
use linpd_core::sparse::Csc;
use linpd_core::{DofMap, Model, Ordering, Point};
use rayon::prelude::*;
use std::cell::RefCell;

/// `d x d` block rows (CSR over nodes, `u32` columns, each block's `d * d` values row-major),
/// rows in ascending column order. Rows whose values are equal block for block share one
/// copy of them: the `K_M` rows of masters in the same setting (bulk moduli, the same leaves
/// around) are the same numbers, only their columns differ; on the penny block of
/// `linpd study penny-sneddon` most rows of the rests are such, and their blocks would
/// otherwise be most of the model's memory and of each product's traffic.
#[derive(Debug, Clone)]
pub(crate) struct BlockCsr {
    d: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    /// The first block of each row's values in `val` (a shared copy or its own).
    val_of: Vec<usize>,
    val: Vec<f64>,
    /// The rows' values seen so far, by hash: `(first block, blocks)` in `val`.
    seen: std::collections::HashMap<u64, Vec<(usize, usize)>>,
}

impl BlockCsr {
    /// No rows yet.
    pub(crate) fn new(d: usize) -> Self {
        BlockCsr { d, row_ptr: vec![0], col: Vec::new(), val_of: Vec::new(), val: Vec::new(), seen: Default::default() }
    }

    /// Appends block rows (each sorted by node, blocks in a 3 x 3 array), in order; a row
    /// whose values equal an earlier row's (bit for bit) shares them.
    pub(crate) fn extend(&mut self, rows: &[BlockRow]) {
        use std::hash::{Hash, Hasher};
        let (d, dd) = (self.d, self.d * self.d);
        let hashes: Vec<u64> = rows
            .par_iter()
            .map(|row| {
                let mut hasher = std::collections::hash_map::DefaultHasher::new();
                row.iter().for_each(|(_, b)| {
                    (0..d).for_each(|a| b[a * 3..a * 3 + d].iter().for_each(|v| v.to_bits().hash(&mut hasher)))
                });
                hasher.finish()
            })
            .collect();
        let mut values = Vec::new();
        for (row, &hash) in rows.iter().zip(&hashes) {
            values.clear();
            for (j, b) in row {
                self.col.push(*j as u32);
                for a in 0..d {
                    values.extend_from_slice(&b[a * 3..a * 3 + d]);
                }
            }
            self.row_ptr.push(self.col.len());
            let same = self.seen.entry(hash).or_default();
            let blocks = row.len();
            let found = same.iter().find(|&&(start, n)| {
                n == blocks
                    && self.val[start * dd..(start + n) * dd]
                        .iter()
                        .zip(&values)
                        .all(|(x, y)| x.to_bits() == y.to_bits())
            });
            match found {
                Some(&(start, _)) => self.val_of.push(start),
                None => {
                    let start = self.val.len() / dd;
                    self.val.extend_from_slice(&values);
                    same.push((start, blocks));
                    self.val_of.push(start);
                }
            }
        }
    }

    /// Drops what only [`BlockCsr::extend`] needs.
    pub(crate) fn finish(&mut self) {
        self.seen = Default::default();
        self.val.shrink_to_fit();
    }

    /// Number of rows.
    pub(crate) fn n_rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Bytes held: the columns, the row pointers and the distinct values.
    pub(crate) fn bytes(&self) -> usize {
        4 * self.col.len() + 16 * self.row_ptr.len() + 8 * self.val.len()
    }

    /// Row `i`: `(node, block)`, ascending.
    pub(crate) fn row(&self, i: usize) -> impl Iterator<Item = (usize, &[f64])> + '_ {
        let dd = self.d * self.d;
        let (lo, hi, v) = (self.row_ptr[i], self.row_ptr[i + 1], self.val_of[i]);
        let values = &self.val[v * dd..(v + hi - lo) * dd];
        self.col[lo..hi].iter().zip(values.chunks_exact(dd)).map(|(&j, b)| (j as usize, b))
    }

    /// `acc += (row i) u` in `D = d` dimensions.
    #[inline]
    pub(crate) fn mul_add<const D: usize>(&self, i: usize, u: &[f64], acc: &mut [f64; D]) {
        let (lo, hi, v) = (self.row_ptr[i], self.row_ptr[i + 1], self.val_of[i]);
        let values = &self.val[v * D * D..(v + hi - lo) * D * D];
        for (&j, b) in self.col[lo..hi].iter().zip(values.chunks_exact(D * D)) {
            let uj: &[f64; D] = u[D * j as usize..D * j as usize + D].try_into().expect("D values");
            for a in 0..D {
                let mut s = 0.0;
                for c in 0..D {
                    s += b[a * D + c] * uj[c];
                }
                acc[a] += s;
            }
        }
    }

    /// Block `(i, j)`, if stored.
    fn block(&self, i: usize, j: usize) -> Option<&[f64]> {
        let dd = self.d * self.d;
        let (lo, hi) = (self.row_ptr[i], self.row_ptr[i + 1]);
        let p = self.col[lo..hi].binary_search(&(j as u32)).ok()?;
        let v = self.val_of[i] + p;
        Some(&self.val[v * dd..v * dd + dd])
    }

    /// `max |L - L^T|` over the blocks (a block missing on one side counts as zero).
    pub(crate) fn max_asymmetry(&self) -> f64 {
        let d = self.d;
        (0..self.n_rows())
            .into_par_iter()
            .map(|i| {
                let mut diff = 0.0f64;
                for (j, b) in self.row(i) {
                    let t = self.block(j, i);
                    for a in 0..d {
                        for c in 0..d {
                            let other = t.map_or(0.0, |t| t[c * d + a]);
                            diff = diff.max((b[a * d + c] - other).abs());
                        }
                    }
                }
                diff
            })
            .reduce(|| 0.0, f64::max)
    }
}

/// One share of a row of `N`: `c = a_ij w_ij != 0`, the master `j` at the bond's other end
/// and the unit bond vector, as its index in [`Shares::units`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Share {
    c: f64,
    j: u32,
    e: u32,
}

/// `N`'s data: the window's `beta` and the masters of its nodes, and each row's shares as a
/// list (see the module docs). The list (16 bytes a share) is what a product reads: each
/// share's `a_ij w_ij`, master and unit vector taken from the window's bonds instead cost four
/// scattered reads and a unit-vector lookup a share, most of a product's time on the penny
/// block at 1/250 (docs/models.md).
#[derive(Debug, Clone)]
pub(crate) struct Shares {
    /// The window node of each master whose row is Algorithm A's (`R` and the extra nodes);
    /// `u32::MAX` for the others, which have no shares.
    pub(crate) window_of: Vec<u32>,
    /// The master of each window node (`u32::MAX`: none).
    pub(crate) master_of: Vec<u32>,
    /// `beta` per window node.
    pub(crate) beta: Vec<f64>,
    /// Master `m`'s shares are `list[ptr[m]..ptr[m + 1]]`.
    ptr: Vec<usize>,
    list: Vec<Share>,
    /// The unit vector of each lattice offset `o` with `|o_a| <= reach`, at `sum_a (o_a +
    /// reach) (2 reach + 1)^a`.
    units: Vec<[f64; 3]>,
}

impl Shares {
    /// The shares of the rows of the masters with a window node (`window_of`), from the
    /// window's bond operator `op` (on a lattice; bonds reach `reach` lattice steps at most),
    /// built in chunks of `chunk` masters. `Err((w, j))`: window node `w`'s row has a share
    /// with window node `j`, which is no master.
    pub(crate) fn new(
        op: &BondOperator,
        window_of: Vec<u32>,
        master_of: Vec<u32>,
        beta: Vec<f64>,
        reach: i32,
        chunk: usize,
    ) -> Result<Self, (usize, usize)> {
        let (d, side) = (op.dim(), 2 * reach + 1);
        let offset = |idx: i32| -> [i32; 3] {
            let mut o = [0; 3];
            (0..d).fold(idx, |q, a| {
                o[a] = q % side - reach;
                q / side
            });
            o
        };
        let units: Vec<[f64; 3]> = (0..side.pow(d as u32))
            .map(|idx| op.unit_of_offset(offset(idx)).expect("the window is a lattice"))
            .collect();
        let index = |o: [i32; 3]| -> u32 {
            debug_assert!(o.iter().all(|x| x.abs() <= reach), "offset {o:?} beyond the table's {reach}");
            (0..d).rev().fold(0, |q, a| q * side + o[a] + reach) as u32
        };
        let mut shares = Shares { window_of, master_of, beta, ptr: vec![0], list: Vec::new(), units };
        // (c, j) of window node w's shares, in the family's order
        let of_window = |sh: &Shares, w: usize, f: &mut dyn FnMut(f64, usize)| {
            let bi = sh.beta[w];
            for (&j, &wt) in op.family().neighbors(w).iter().zip(op.weights(w)) {
                let c = 0.5 * (bi + sh.beta[j as usize]) * wt;
                if c != 0.0 {
                    f(c, j as usize);
                }
            }
        };
        let n = shares.window_of.len();
        let counts: Vec<usize> = (0..n)
            .into_par_iter()
            .map(|m| match shares.window_of[m] {
                u32::MAX => 0,
                w => {
                    let mut k = 0;
                    of_window(&shares, w as usize, &mut |_, _| k += 1);
                    k
                }
            })
            .collect();
        let mut list = Vec::with_capacity(counts.iter().sum());
        for first in (0..n).step_by(chunk.max(1)) {
            let rows: Vec<Result<Vec<Share>, (usize, usize)>> = (first..(first + chunk).min(n))
                .into_par_iter()
                .map(|m| {
                    let Some(w) = Some(shares.window_of[m]).filter(|&w| w != u32::MAX) else {
                        return Ok(Vec::new());
                    };
                    let w = w as usize;
                    let mut row = Vec::with_capacity(counts[m]);
                    let mut unkept = None;
                    of_window(&shares, w, &mut |c, j| match shares.master_of[j] {
                        u32::MAX => unkept = unkept.or(Some((w, j))),
                        mj => {
                            let o = op.offset(w, j).expect("the window is a lattice");
                            row.push(Share { c, j: mj, e: index(o) });
                        }
                    });
                    unkept.map_or(Ok(row), Err)
                })
                .collect();
            for row in rows {
                list.extend(row?);
                shares.ptr.push(list.len());
            }
        }
        shares.list = list;
        Ok(shares)
    }

    /// Whether master `m`'s row is Algorithm A's.
    pub(crate) fn is_row_a(&self, m: usize) -> bool {
        self.window_of[m] != u32::MAX
    }

    /// Bytes held by the lists of shares.
    pub(crate) fn list_bytes(&self) -> usize {
        std::mem::size_of::<Share>() * self.list.len() + 8 * self.ptr.len()
    }

    /// `f(j, c, e)` for each share of master `m`'s row: `j` the master at the bond's other
    /// end, `c = a_ij w_ij`, `e` the unit bond vector.
    #[inline]
    pub(crate) fn for_each(&self, m: usize, mut f: impl FnMut(usize, f64, &[f64; 3])) {
        for s in &self.list[self.ptr[m]..self.ptr[m + 1]] {
            f(s.j as usize, s.c, &self.units[s.e as usize]);
        }
    }
}

/// Which of the graded blend's two operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Which {
    /// `A`.
    A,
    /// Its SPD companion `M`.
    M,
}

/// A dense slot per master and the blocks of one row being merged (see `for_each_block_op`).
type Merge = (Vec<u32>, Vec<(usize, [f64; 9])>);

thread_local! {
    static MERGE: RefCell<Merge> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// The position of node `j`'s block in the row being merged, a zero block added if new.
fn merge_slot(slot: &mut [u32], row: &mut Vec<(usize, [f64; 9])>, j: usize) -> usize {
    if slot[j] == u32::MAX {
        slot[j] = row.len() as u32;
        row.push((j, [0.0; 9]));
    }
    slot[j] as usize
}

impl GradedBlend {
    /// The stored rest of master `m`'s row of `which` (see the module docs).
    fn rest(&self, which: Which, m: usize) -> impl Iterator<Item = (usize, &[f64])> + '_ {
        self.rests_of(which, m).row(m)
    }

    /// The rests holding master `m`'s row of `which`: `M`'s own for a row of Algorithm A,
    /// `A`'s (`K_M`'s row, the same in both) for the others.
    fn rests_of(&self, which: Which, m: usize) -> &BlockCsr {
        if which == Which::M && self.shares.is_row_a(m) {
            &self.rest_m
        } else {
            &self.rest_a
        }
    }

    /// `f(j, c, e)` for the shares of master `m` (see [`Shares::for_each`]).
    #[inline]
    fn shares_of(&self, m: usize, f: impl FnMut(usize, f64, &[f64; 3])) {
        self.shares.for_each(m, f)
    }

    fn apply_op(&self, which: Which, u: &[f64], y: &mut [f64]) {
        assert_eq!(u.len(), self.dim() * self.master_node.len(), "one value per master DOF");
        assert_eq!(y.len(), u.len(), "one value per master DOF");
        match self.dim() {
            2 => self.apply_d::<2>(which, u, y),
            _ => self.apply_d::<3>(which, u, y),
        }
    }

    /// [`GradedBlend::apply_op`] in `D` dimensions: each row's rest, then its shares.
    fn apply_d<const D: usize>(&self, which: Which, u: &[f64], y: &mut [f64]) {
        let at = |j: usize| -> &[f64; D] { u[D * j..D * j + D].try_into().expect("D values") };
        y.par_chunks_exact_mut(D).enumerate().for_each(|(m, ym)| {
            let mut acc = [0.0; D];
            self.rests_of(which, m).mul_add::<D>(m, u, &mut acc);
            let um = at(m);
            self.shares_of(m, |j, c, e| {
                let uj = at(j);
                let mut proj = 0.0;
                for k in 0..D {
                    proj += e[k] * (um[k] - uj[k]);
                }
                let cp = c * proj;
                for k in 0..D {
                    acc[k] += cp * e[k];
                }
            });
            ym.copy_from_slice(&acc);
        });
    }

    fn diagonal_op(&self, which: Which) -> Vec<f64> {
        let d = self.dim();
        let mut out = vec![0.0; d * self.master_node.len()];
        out.par_chunks_mut(d).enumerate().for_each(|(m, o)| {
            if let Some((_, b)) = self.rest(which, m).find(|(j, _)| *j == m) {
                (0..d).for_each(|a| o[a] = b[a * d + a]);
            }
            self.shares_of(m, |_, c, e| (0..d).for_each(|a| o[a] += c * e[a] * e[a]));
        });
        out
    }

    /// The blocks of row `m` of `which`: the shares' and the rest's, merged per node.
    fn for_each_block_op(&self, which: Which, m: usize, f: &mut dyn FnMut(usize, &[f64])) {
        let d = self.dim();
        if !self.shares.is_row_a(m) {
            self.rest(which, m).for_each(|(j, b)| f(j, b));
            return;
        }
        // the row is merged in the thread's buffers, which are released before `f` runs (an
        // `f` that merged a row itself would otherwise find them borrowed)
        let mut row = MERGE.with_borrow_mut(|(slot, row)| {
            slot.resize(self.master_node.len(), u32::MAX);
            merge_slot(slot, row, m);
            for (j, b) in self.rest(which, m) {
                let k = merge_slot(slot, row, j);
                row[k].1[..d * d].iter_mut().zip(b).for_each(|(x, y)| *x += y);
            }
            self.shares_of(m, |j, c, e| {
                let (ki, kj) = (merge_slot(slot, row, m), merge_slot(slot, row, j));
                for a in 0..d {
                    for b in 0..d {
                        let v = c * e[a] * e[b];
                        row[ki].1[a * d + b] += v;
                        row[kj].1[a * d + b] -= v;
                    }
                }
            });
            row.iter().for_each(|(j, _)| slot[*j] = u32::MAX);
            std::mem::take(row)
        });
        for (j, b) in &row {
            f(*j, &b[..d * d]);
        }
        row.clear();
        MERGE.with_borrow_mut(|(_, buffer)| *buffer = row);
    }

    fn for_each_partner_op(&self, m: usize, f: &mut dyn FnMut(usize)) {
        self.rest_a.row(m).filter(|&(j, _)| j != m).for_each(|(j, _)| f(j));
        if self.shares.is_row_a(m) {
            self.rest_m.row(m).filter(|&(j, _)| j != m).for_each(|(j, _)| f(j));
        }
        self.shares_of(m, |j, _, _| f(j));
    }

    /// `max |A - A^T| / max |A|` over all DOFs, with `max |A|` the largest entry of `A`'s
    /// merged rows (`max_a`, from [`GradedBlend::count_and_max`]): `N` is symmetric (each
    /// share's block is the same product from either end) and cancels from `A - A^T`, so the
    /// difference is the rest's (up to the rounding of `N`'s sums with it).
    pub(super) fn full_asymmetry(&self, max_a: f64) -> f64 {
        let diff = self.rest_a.max_asymmetry();
        if max_a > 0.0 {
            diff / max_a
        } else {
            0.0
        }
    }

    /// The blocks of `A`'s rows (shares and rest merged per node) and their largest entry.
    pub(super) fn count_and_max(&self) -> (usize, f64) {
        (0..self.master_node.len())
            .into_par_iter()
            .map(|m| {
                let (mut count, mut max) = (0, 0.0f64);
                self.for_each_block_op(Which::A, m, &mut |_, b| {
                    count += 1;
                    max = b.iter().fold(max, |x, v| x.max(v.abs()));
                });
                (count, max)
            })
            .reduce(|| (0, 0.0), |x, y| (x.0 + y.0, x.1.max(y.1)))
    }

    /// `A` over all the masters' DOFs, assembled (for checks and small solves; the solvers
    /// apply it matrix-free).
    pub fn stiffness(&self) -> Csc {
        self.assemble_free(&DofMap::all_free(self.master_node.len(), self.dim()))
    }

    /// The SPD companion `M` over all the masters' DOFs, assembled (see [`Self::stiffness`]).
    pub fn companion(&self) -> Csc {
        Companion(self).assemble_free(&DofMap::all_free(self.master_node.len(), self.dim()))
    }
}

/// `A`: its shares from the window's bonds, its rest stored (see the module docs).
impl Model for GradedBlend {
    fn kind(&self) -> &'static str {
        "blend"
    }
    fn dim(&self) -> usize {
        self.mesh.dim()
    }
    fn n_nodes(&self) -> usize {
        self.master_node.len()
    }
    fn position(&self, i: usize) -> Point {
        self.positions[i]
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.for_each_partner_op(i, f)
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        self.apply_op(Which::A, u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        self.diagonal_op(Which::A)
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        linpd_core::model::assemble_free_from_blocks(self, dofs).expect("the graded blend has block rows")
    }
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        self.for_each_block_op(Which::A, i, f);
        true
    }
    /// That of the full `A`, computed when it was built (a bound for `A_ff`; see
    /// `GradedBlend::asymmetry`).
    fn asymmetry(&self, _dofs: &DofMap) -> f64 {
        self.asymmetry
    }
    /// AMD: the masters are not a lattice.
    fn ordering(&self, _dofs: &DofMap) -> Ordering {
        Ordering::Amd
    }
    fn spd_approximation(&self, dofs: &DofMap) -> Option<linpd_core::SpdApproximation> {
        Some(linpd_core::SpdApproximation {
            matrix: Companion(self).assemble_free(dofs),
            kind: linpd_core::SpdApproximationKind::EnergyForm,
        })
    }
    /// `M` (see the module docs): the multigrid that preconditions GMRES on `A` is built from
    /// its blocks, never stored whole.
    fn multigrid_companion(&self) -> Option<Box<dyn Model + '_>> {
        Some(Box::new(Companion(self)))
    }
    /// The lattice node and position of master `i` (the numbers users see are the lattice's).
    fn describe_node(&self, i: usize) -> String {
        let x = self.positions[i];
        format!("node {} (master {i}) at {:?}", self.master_node[i], &x[..self.dim()])
    }
}

/// The graded blend's SPD companion `M` (see the module docs), as a model whose blocks the
/// multigrid reads.
struct Companion<'a>(&'a GradedBlend);

impl Model for Companion<'_> {
    fn kind(&self) -> &'static str {
        "blend companion"
    }
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn n_nodes(&self) -> usize {
        self.0.n_nodes()
    }
    fn position(&self, i: usize) -> Point {
        self.0.position(i)
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.0.for_each_partner_op(i, f)
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        self.0.apply_op(Which::M, u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        self.0.diagonal_op(Which::M)
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        linpd_core::model::assemble_free_from_blocks(self, dofs).expect("the companion has block rows")
    }
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        self.0.for_each_block_op(Which::M, i, f);
        true
    }
    fn describe_node(&self, i: usize) -> String {
        self.0.describe_node(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows equal value for value share one copy whatever their columns; a row differing in
    /// one bit or in its length keeps its own; every row reads back its own columns and values.
    #[test]
    fn equal_rows_share_their_values() {
        let block = |x: f64| [x, 2.0 * x, 0.0, -x, x, 0.5, 0.0, 0.0, 0.0];
        let row = |cols: &[usize], x: f64| -> BlockRow { cols.iter().map(|&j| (j, block(x))).collect() };
        let rows: Vec<BlockRow> = vec![
            row(&[0, 1, 2], 1.0),
            row(&[3, 4, 5], 1.0),
            row(&[1, 2, 3], f64::from_bits(1.0f64.to_bits() + 1)),
            row(&[7, 9], 1.0),
            Vec::new(),
            row(&[2, 6, 8], 1.0),
        ];
        let mut m = BlockCsr::new(2);
        m.extend(&rows[..3]);
        m.extend(&rows[3..]);
        m.finish();
        // distinct value sets: 1.0 x 3 blocks, 1.0 + ulp x 3, 1.0 x 2, the empty row
        assert_eq!(m.val.len(), 4 * (3 + 3 + 2));
        assert_eq!(m.val_of[0], m.val_of[1]);
        assert_eq!(m.val_of[0], m.val_of[5]);
        assert_ne!(m.val_of[0], m.val_of[2]);
        for (i, r) in rows.iter().enumerate() {
            let got: Vec<(usize, Vec<f64>)> = m.row(i).map(|(j, b)| (j, b.to_vec())).collect();
            let want: Vec<(usize, Vec<f64>)> = r.iter().map(|(j, b)| (*j, vec![b[0], b[1], b[3], b[4]])).collect();
            assert_eq!(got, want, "row {i}");
        }
        assert_eq!(m.block(5, 6), Some(&[1.0, 2.0, -1.0, 1.0][..]));
        assert_eq!(m.block(5, 7), None);
    }
}
