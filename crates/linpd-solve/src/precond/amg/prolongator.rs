//! The near-null space (rigid-body modes), the tentative prolongator `T` and its Jacobi
//! smoothing `P = (I - omega D^{-1} A) T`.

use super::level::LevelMatrix;
use super::vbr::{split_at_bounds, Vbr};
use linpd_core::Point;
use rayon::prelude::*;

/// A column of an aggregate's near-null-space rows is dropped as dependent when
/// orthogonalization against the kept ones leaves less than this fraction of its norm. The
/// rigid modes of an aggregate of lattice nodes are independent by O(1) fractions (extent /
/// distance to the origin), or dependent to round-off, `~1e-15` (a single node has only its
/// translations; collinear nodes lose the rotation about their line): 1e-10 sits between.
pub(crate) const DEPENDENT_RTOL: f64 = 1e-10;

/// The rigid-body modes of linear elasticity, evaluated at the rows `(node, component)` of a
/// reduced system (see [`super::Amg::new`]): `d` translations `e_c`, then the infinitesimal
/// rotations about the origin, `(-y, x)` in 2D and, in 3D, `(-y, x, 0)`, `(0, -z, y)`,
/// `(z, 0, -x)`. 1, 3 and 6 modes in 1D, 2D and 3D, each a vector over the rows.
///
/// The bond-based (and LPS) stiffness annihilates each of them over all DOFs of a free
/// body: the force of bond `ij` is along `xi_ij` and `(omega x xi) . xi = 0`.
pub fn rigid_body_modes(dim: usize, rows: &[(usize, usize)], positions: &[Point]) -> Vec<Vec<f64>> {
    assert!((1..=3).contains(&dim), "dimension {dim}");
    let mut modes: Vec<Vec<f64>> =
        (0..dim).map(|t| rows.iter().map(|&(_, c)| if c == t { 1.0 } else { 0.0 }).collect()).collect();
    let pairs: &[(usize, usize)] = match dim {
        1 => &[],
        2 => &[(0, 1)],
        _ => &[(0, 1), (1, 2), (2, 0)],
    };
    for &(p, q) in pairs {
        modes.push(
            rows.iter()
                .map(|&(node, c)| {
                    let x = positions[node];
                    if c == p {
                        -x[q]
                    } else if c == q {
                        x[p]
                    } else {
                        0.0
                    }
                })
                .collect(),
        );
    }
    modes
}

/// Tentative prolongator by aggregate-wise QR (Vanek, Mandel & Brezina 1996, eq. (3.3)-(3.4);
/// pyamg `fit_candidates`): for the rows `B_a` of the near-null space `B` (row-major `n x k`)
/// on aggregate `a`, `B_a = Q_a R_a` with orthonormal `Q_a` (`|a| x k_a`, dependent columns
/// dropped so `k_a <= k`); `T` holds `Q_a` in the block column of `a`, and `B_c`, the rows
/// `R_a` (`k_a x k`), is the near-null space of the next level, so `T B_c = B` exactly on the
/// kept span.
///
/// Returns `T` (row blocks: the nodes of `a`; column blocks: the aggregates) and `B_c`.
pub(crate) fn tentative(a: &dyn LevelMatrix, agg: &[u32], n_agg: usize, b: &[f64], k: usize) -> (Vbr, Vec<f64>) {
    let nb = a.n_row_blocks();
    // Nodes of each aggregate (counting sort, ascending node order).
    let mut aptr = vec![0usize; n_agg + 1];
    for &g in agg {
        aptr[g as usize + 1] += 1;
    }
    for g in 0..n_agg {
        aptr[g + 1] += aptr[g];
    }
    let mut next = aptr.clone();
    let mut nodes = vec![0usize; nb];
    for (i, &g) in agg.iter().enumerate() {
        nodes[next[g as usize]] = i;
        next[g as usize] += 1;
    }
    let rptr = a.rptr();
    // Per aggregate: Q (rows of its nodes in order, row-major m x k_a) and R (k_a x k).
    let qr: Vec<(Vec<f64>, Vec<f64>, usize)> = (0..n_agg)
        .into_par_iter()
        .map(|g| {
            let rows: Vec<usize> = nodes[aptr[g]..aptr[g + 1]].iter().flat_map(|&i| rptr[i]..rptr[i + 1]).collect();
            let m = rows.len();
            // Columns of B_a.
            let cols: Vec<Vec<f64>> = (0..k).map(|c| rows.iter().map(|&r| b[r * k + c]).collect()).collect();
            let mut q: Vec<Vec<f64>> = Vec::new();
            let mut rmat: Vec<Vec<f64>> = Vec::new(); // rows of R, each of length k
            for (c, col) in cols.iter().enumerate() {
                let mut v = col.clone();
                let norm0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let mut coef = vec![0.0; q.len()];
                // Modified Gram-Schmidt, twice ("twice is enough", Giraud et al. 2005): one
                // pass loses orthogonality in proportion to the columns' condition.
                for _ in 0..2 {
                    for (j, qj) in q.iter().enumerate() {
                        let s: f64 = qj.iter().zip(&v).map(|(a, b)| a * b).sum();
                        v.iter_mut().zip(qj).for_each(|(x, y)| *x -= s * y);
                        coef[j] += s;
                    }
                }
                for (j, s) in coef.into_iter().enumerate() {
                    rmat[j][c] = s;
                }
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                if norm0 > 0.0 && norm > DEPENDENT_RTOL * norm0 && q.len() < m {
                    v.iter_mut().for_each(|x| *x /= norm);
                    q.push(v);
                    let mut row = vec![0.0; k];
                    row[c] = norm;
                    rmat.push(row);
                }
            }
            let ka = q.len();
            let mut qm = vec![0.0; m * ka];
            for (j, qj) in q.iter().enumerate() {
                for (r, &x) in qj.iter().enumerate() {
                    qm[r * ka + j] = x;
                }
            }
            (qm, rmat.concat(), ka)
        })
        .collect();
    let mut cptr = vec![0usize; n_agg + 1];
    for g in 0..n_agg {
        cptr[g + 1] = cptr[g] + qr[g].2;
    }
    let bc: Vec<f64> = qr.iter().flat_map(|(_, r, _)| r.iter().copied()).collect();
    // T: one block per node, in the column block of its aggregate.
    let bptr: Vec<usize> = (0..=nb).collect();
    let bidx: Vec<u32> = agg.to_vec();
    let mut voff = Vec::with_capacity(nb + 1);
    voff.push(0);
    for i in 0..nb {
        let ka = qr[agg[i] as usize].2;
        voff.push(voff.last().unwrap() + (rptr[i + 1] - rptr[i]) * ka);
    }
    let mut val = vec![0.0; *voff.last().unwrap()];
    for g in 0..n_agg {
        let (qm, _, ka) = &qr[g];
        let mut row = 0;
        for &i in &nodes[aptr[g]..aptr[g + 1]] {
            let len = (rptr[i + 1] - rptr[i]) * ka;
            val[voff[i]..voff[i] + len].copy_from_slice(&qm[row * ka..row * ka + len]);
            row += rptr[i + 1] - rptr[i];
        }
    }
    (Vbr::new(rptr.to_vec(), cptr, bptr, bidx, voff, val), bc)
}

/// `P = T - omega D^{-1} (A T)` (Vanek, Mandel & Brezina 1996, eq. (3.6) with the diagonal
/// `D` of `A` in place of their filtered matrix; pyamg's `jacobi_prolongation_smoother`
/// with `filter = False`). `A T` contains the pattern of `T` (the diagonal blocks of `A` are
/// stored), so `T` is added into the blocks of the product.
pub(crate) fn smooth(a: &dyn LevelMatrix, t: &Vbr, dinv: &[f64], omega: f64) -> Vbr {
    let mut w = a.mul(t);
    let rptr = w.rptr.clone();
    let cptr = w.cptr.clone();
    let (bptr, bidx, voff) = (&w.bptr, &w.bidx, &w.voff);
    let bounds: Vec<usize> = bptr.iter().map(|&b| voff[b]).collect();
    let mut rows: Vec<&mut [f64]> = split_at_bounds(&mut w.val, bounds.into_iter());
    rows.par_iter_mut().with_min_len(64).enumerate().for_each(|(i, vals)| {
        let base = voff[bptr[i]];
        let r0 = rptr[i];
        let r = rptr[i + 1] - r0;
        for b in bptr[i]..bptr[i + 1] {
            let j = bidx[b] as usize;
            let c = cptr[j + 1] - cptr[j];
            let blk = &mut vals[voff[b] - base..voff[b + 1] - base];
            for ii in 0..r {
                let s = -omega * dinv[r0 + ii];
                blk[ii * c..(ii + 1) * c].iter_mut().for_each(|x| *x *= s);
            }
        }
        // + T: the block (i, agg(i)).
        let j = t.bidx[i];
        let pos = bidx[bptr[i]..bptr[i + 1]].binary_search(&j).expect("A T holds the pattern of T");
        let b = bptr[i] + pos;
        let tv = &t.val[t.voff[i]..t.voff[i + 1]];
        vals[voff[b] - base..voff[b + 1] - base].iter_mut().zip(tv).for_each(|(x, y)| *x += y);
    });
    w
}
