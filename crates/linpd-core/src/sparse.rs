//! Sparse helpers shared by the models and the solvers (faer CSC matrices, `usize` indices):
//! products, the diagonal, the restriction to free DOFs, the relative asymmetry.
//!
//! faer's own CSC product is sequential (shared/notes pitfall 3); [`sym_matvec`] uses the
//! symmetry to compute each output entry as one independent dot product, in parallel.

use crate::op::LinearOperator;
use crate::DofMap;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rayon::prelude::*;

/// A CSC matrix with `usize` indices, the storage of every assembled linpd operator.
pub type Csc = SparseColMat<usize, f64>;

/// `A` counts as symmetric when `max |A - A^T| <= SYMMETRY_RTOL max |A|` ([`relative_asymmetry`]).
pub const SYMMETRY_RTOL: f64 = 1e-12;

/// `y = A x` for a symmetric CSC matrix, parallel over columns (column j of a symmetric
/// matrix is row j, so each output entry is one independent dot product).
pub fn sym_matvec(a: &Csc, x: &[f64], y: &mut [f64]) {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let v = a.val();
    y.par_iter_mut().enumerate().with_min_len(256).for_each(|(j, yj)| {
        let mut s = 0.0;
        for p in cp[j]..cp[j + 1] {
            s += v[p] * x[ri[p]];
        }
        *yj = s;
    });
}

/// Below this many entries [`matvec`] runs on one thread (the partial vectors and their sum
/// cost more than they save).
const PARALLEL_MATVEC_NNZ: usize = 1 << 16;

/// `y = A x` for a general CSC matrix.
///
/// A CSC product scatters into `y`, so threads cannot share one output: the columns are cut
/// into one range per thread with equal entries, each range scatters into its own partial
/// vector, and `y` is their sum in range order (deterministic for a given thread count; the
/// sum differs from the one-thread order by rounding only). One extra vector per thread, no
/// copy of the matrix (a CSR copy would double the blend's two stored operators).
pub fn matvec(a: &Csc, x: &[f64], y: &mut [f64]) {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let v = a.val();
    let scatter = |cols: std::ops::Range<usize>, out: &mut [f64]| {
        for j in cols {
            let xj = x[j];
            for p in cp[j]..cp[j + 1] {
                out[ri[p]] += v[p] * xj;
            }
        }
    };
    let threads = rayon::current_num_threads();
    let nnz = cp[a.ncols()];
    if threads < 2 || nnz < PARALLEL_MATVEC_NNZ {
        y.iter_mut().for_each(|v| *v = 0.0);
        scatter(0..a.ncols(), y);
        return;
    }
    // column ranges with ~nnz / threads entries each
    let mut cuts = vec![0usize];
    for t in 1..threads {
        let target = nnz * t / threads;
        cuts.push(cp.partition_point(|&p| p < target).min(a.ncols()).max(*cuts.last().unwrap()));
    }
    cuts.push(a.ncols());
    let partials: Vec<Vec<f64>> = cuts
        .par_windows(2)
        .map(|w| {
            let mut out = vec![0.0; y.len()];
            scatter(w[0]..w[1], &mut out);
            out
        })
        .collect();
    y.par_iter_mut().enumerate().with_min_len(4096).for_each(|(i, yi)| {
        *yi = partials.iter().map(|p| p[i]).sum();
    });
}

/// Diagonal of a CSC matrix (duplicate entries summed).
pub fn diagonal(a: &Csc) -> Vec<f64> {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    (0..a.ncols()).map(|j| (cp[j]..cp[j + 1]).filter(|&p| ri[p] == j).map(|p| a.val()[p]).sum()).collect()
}

/// `||A x - b|| / ||b||` (or `||A x||` when `b = 0`), with the symmetric (parallel) product
/// when `symmetric`, else the general one.
pub fn relative_residual(a: &Csc, symmetric: bool, x: &[f64], b: &[f64]) -> f64 {
    let mut r = vec![0.0; b.len()];
    if symmetric {
        sym_matvec(a, x, &mut r);
    } else {
        matvec(a, x, &mut r);
    }
    let num: f64 = r.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    if den > 0.0 {
        num / den
    } else {
        num
    }
}

/// The rows and columns of `a` at free DOFs (order kept, so sorted columns stay sorted).
///
/// Sized exactly (a counting pass: growing by doubling would hold up to 3x the copy at a
/// reallocation, the peak of an LPS solve, and the memory estimate counts one copy) and filled
/// in parallel, column ranges of about equal entries per thread: the copy of a 3D blend or LPS
/// matrix is ~1 GB, which one thread wrote at well under 1 GB/s (first-touch page faults).
pub fn restrict_to_free(a: &Csc, dofs: &DofMap) -> Csc {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let free_cols: Vec<usize> = (0..a.ncols()).filter(|&j| !dofs.is_constrained(j)).collect();
    let kept_in = |j: usize| ri[cp[j]..cp[j + 1]].iter().filter(|&&r| !dofs.is_constrained(r)).count();
    let counts: Vec<usize> = free_cols.par_iter().map(|&j| kept_in(j)).collect();
    let mut col_ptr = Vec::with_capacity(free_cols.len() + 1);
    col_ptr.push(0usize);
    for c in &counts {
        col_ptr.push(col_ptr.last().unwrap() + c);
    }
    let kept = *col_ptr.last().unwrap();
    let (mut rows, mut vals) = (vec![0usize; kept], vec![0.0; kept]);
    // column ranges with about equal entries (64 tasks: load balance on any core count)
    let tasks = 64.min(free_cols.len()).max(1);
    let mut cuts = vec![0usize];
    for t in 1..tasks {
        let at = col_ptr.partition_point(|&p| p < kept * t / tasks).min(free_cols.len());
        cuts.push(at.max(*cuts.last().unwrap()));
    }
    cuts.push(free_cols.len());
    let (mut row_parts, mut val_parts) = (Vec::new(), Vec::new());
    let (mut rest_r, mut rest_v) = (rows.as_mut_slice(), vals.as_mut_slice());
    for w in cuts.windows(2) {
        let len = col_ptr[w[1]] - col_ptr[w[0]];
        let (r, tail_r) = std::mem::take(&mut rest_r).split_at_mut(len);
        let (v, tail_v) = std::mem::take(&mut rest_v).split_at_mut(len);
        row_parts.push(r);
        val_parts.push(v);
        rest_r = tail_r;
        rest_v = tail_v;
    }
    cuts.par_windows(2).zip(row_parts).zip(val_parts).for_each(|((w, rows), vals)| {
        let mut q = 0;
        for &j in &free_cols[w[0]..w[1]] {
            for p in cp[j]..cp[j + 1] {
                if let Some(r) = dofs.free(ri[p]) {
                    rows[q] = r;
                    vals[q] = a.val()[p];
                    q += 1;
                }
            }
        }
    });
    let n = dofs.n_free();
    SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals)
}

/// The CSC matrix of `n x n` CSR arrays `(row_ptr, col, val)` (a counting-sort transpose;
/// columns come out sorted in each CSC column's rows when `col` is sorted in each row).
pub fn csr_to_csc(n: usize, row_ptr: &[usize], col: &[usize], val: &[f64]) -> Csc {
    let mut col_ptr = vec![0usize; n + 1];
    for &c in col {
        col_ptr[c + 1] += 1;
    }
    for i in 0..n {
        col_ptr[i + 1] += col_ptr[i];
    }
    let mut next = col_ptr.clone();
    let (mut rows, mut vals) = (vec![0usize; col.len()], vec![0.0; col.len()]);
    for i in 0..n {
        for p in row_ptr[i]..row_ptr[i + 1] {
            let q = next[col[p]];
            rows[q] = i;
            vals[q] = val[p];
            next[col[p]] += 1;
        }
    }
    SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals)
}

/// `(A + A^T) / 2` of a square CSC matrix with sorted row indices in each column.
pub fn symmetric_part(a: &Csc) -> Csc {
    let n = a.ncols();
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    // The CSC arrays of A^T are the CSR arrays of A: transpose once, then merge column by column.
    let t = csr_to_csc(n, cp, ri, v);
    let (tp, ti, tv) = (t.symbolic().col_ptr(), t.symbolic().row_idx(), t.val());
    let (mut col_ptr, mut rows, mut vals) = (vec![0usize], Vec::new(), Vec::new());
    for j in 0..n {
        let (mut p, mut q) = (cp[j], tp[j]);
        while p < cp[j + 1] || q < tp[j + 1] {
            let rp = if p < cp[j + 1] { ri[p] } else { usize::MAX };
            let rq = if q < tp[j + 1] { ti[q] } else { usize::MAX };
            let (r, x) = match rp.cmp(&rq) {
                std::cmp::Ordering::Equal => {
                    p += 1;
                    q += 1;
                    (rp, 0.5 * (v[p - 1] + tv[q - 1]))
                }
                std::cmp::Ordering::Less => {
                    p += 1;
                    (rp, 0.5 * v[p - 1])
                }
                std::cmp::Ordering::Greater => {
                    q += 1;
                    (rq, 0.5 * tv[q - 1])
                }
            };
            rows.push(r);
            vals.push(x);
        }
        col_ptr.push(rows.len());
    }
    SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals)
}

/// `max |A - A^T| / max |A|` of a square CSC matrix, duplicates summed (0 when `A = 0`).
///
/// Each entry `a_ij` is compared with `a_ji`, found by a binary search in column `i`, in
/// parallel over the columns and without a copy. That needs the rows of every column strictly
/// ascending, as faer's checked constructor makes them (every matrix linpd assembles); a matrix
/// built unsorted (with repeated rows) is first rebuilt from its triplets, which sorts the rows
/// and sums the repeats.
pub fn relative_asymmetry(a: &Csc) -> f64 {
    let n = a.ncols();
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    let strictly_sorted = (0..n).into_par_iter().all(|j| ri[cp[j]..cp[j + 1]].windows(2).all(|w| w[0] < w[1]));
    if !strictly_sorted {
        let triplets: Vec<faer::sparse::Triplet<usize, usize, f64>> =
            (0..n).flat_map(|j| (cp[j]..cp[j + 1]).map(move |p| faer::sparse::Triplet::new(ri[p], j, v[p]))).collect();
        let sorted = Csc::try_new_from_triplets(n, n, &triplets).expect("the entries of a valid CSC matrix");
        return relative_asymmetry(&sorted);
    }
    let (max, diff) = (0..n)
        .into_par_iter()
        .map(|j| {
            let (mut max, mut diff) = (0.0f64, 0.0f64);
            for p in cp[j]..cp[j + 1] {
                let i = ri[p];
                let a_ji = match ri[cp[i]..cp[i + 1]].binary_search(&j) {
                    Ok(q) => v[cp[i] + q],
                    Err(_) => 0.0,
                };
                max = max.max(v[p].abs());
                diff = diff.max((v[p] - a_ji).abs());
            }
            (max, diff)
        })
        .reduce(|| (0.0, 0.0), |x, y| (x.0.max(y.0), x.1.max(y.1)));
    if max == 0.0 {
        0.0
    } else {
        diff / max
    }
}

/// A symmetric CSC matrix as a [`LinearOperator`] (parallel [`sym_matvec`]).
pub struct SymCsc<'a>(pub &'a Csc);

impl LinearOperator for SymCsc<'_> {
    fn n(&self) -> usize {
        self.0.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        sym_matvec(self.0, x, y)
    }
}

/// A general CSC matrix as a [`LinearOperator`] (sequential [`matvec`]).
pub struct GeneralCsc<'a>(pub &'a Csc);

impl LinearOperator for GeneralCsc<'_> {
    fn n(&self) -> usize {
        self.0.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        matvec(self.0, x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The threaded general product (on a 2-thread pool, so the column ranges are used even
    /// on a one-core machine) against a plain row-by-row sum, on an unsymmetric banded matrix
    /// with 200,000 entries (above [`PARALLEL_MATVEC_NNZ`]): equal to 1e-14 of max |y| (the
    /// two differ in summation order only; every row sums ~10 terms of size <= 1).
    #[test]
    fn the_threaded_general_product_is_the_product() {
        let (n, band) = (20_000usize, 5i64);
        let mut col_ptr = vec![0usize];
        let (mut rows, mut vals) = (Vec::new(), Vec::new());
        for c in 0..n {
            for r in (c as i64 - band).max(0)..(c as i64 + band).min(n as i64) {
                rows.push(r as usize);
                vals.push(((r * 31 + c as i64 * 17) % 97) as f64 / 97.0 - 0.4);
            }
            col_ptr.push(rows.len());
        }
        let a = SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals);
        assert!(a.compute_nnz() > PARALLEL_MATVEC_NNZ);
        let x: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 / 13.0 - 0.5).collect();
        let mut expected = vec![0.0; n];
        for c in 0..n {
            for p in a.symbolic().col_ptr()[c]..a.symbolic().col_ptr()[c + 1] {
                expected[a.symbolic().row_idx()[p]] += a.val()[p] * x[c];
            }
        }
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut y = vec![f64::NAN; n];
        pool.install(|| matvec(&a, &x, &mut y));
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = y.iter().zip(&expected).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(diff <= 1e-14 * scale.max(1.0), "threaded product off by {diff:e}");
    }

    /// Against the dense `max |A - A^T| / max |A|`, with an entry without a transposed partner
    /// (faer's CSC has sorted, unique rows in each column).
    #[test]
    fn relative_asymmetry_matches_the_dense_definition() {
        let n = 4;
        // (row, col, value) column by column; (3, 2) has no (2, 3)
        let entries =
            [(0, 0, 4.0), (1, 0, 1.5), (0, 1, 1.5), (1, 1, 3.0), (2, 1, -2.0), (1, 2, -2.5), (3, 2, 0.25), (3, 3, 5.0)];
        let mut dense = [[0.0f64; 4]; 4];
        for &(r, c, v) in &entries {
            dense[r][c] += v;
        }
        let mut col_ptr = vec![0usize; n + 1];
        let (mut rows, mut vals) = (Vec::new(), Vec::new());
        for c in 0..n {
            for &(r, cc, v) in &entries {
                if cc == c {
                    rows.push(r);
                    vals.push(v);
                }
            }
            col_ptr[c + 1] = rows.len();
        }
        let a = SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals);
        let max = dense.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut diff = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                diff = diff.max((dense[i][j] - dense[j][i]).abs());
            }
        }
        assert_eq!(relative_asymmetry(&a), diff / max);
        assert_eq!(diff / max, 0.5 / 5.0, "|(2,1) - (1,2)| = 0.5 against max 5");
        // The same matrix with column 1 unsorted and (2, 1) stored as two repeats (the
        // triplet path, repeats summed) gives the same value.
        let col_ptr = vec![0, 2, 6, 8, 9];
        let rows = vec![0, 1, 2, 1, 0, 2, 1, 3, 3];
        let vals = vec![4.0, 1.5, -1.0, 3.0, 1.5, -1.0, -2.5, 0.25, 5.0];
        let b = SparseColMat::new(SymbolicSparseColMat::new_unsorted_checked(n, n, col_ptr, None, rows), vals);
        assert_eq!(relative_asymmetry(&b), diff / max);
    }
}
