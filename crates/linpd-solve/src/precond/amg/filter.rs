//! The filtered matrix `A_F` that smooths the finest level's prolongator (Vanek, Mandel &
//! Brezina 1996, section 3: `P = (I - omega D_F^{-1} A_F) T` with the filtered `A^F`).
//!
//! `A_F` keeps the blocks `(i, j)` with `|x_j - x_i| <= ratio * max(r_i, r_j)`, `r_i` the
//! distance from row block `i` to its nearest coupled block, and adds every dropped block of a
//! row to its diagonal block when both have as many free components (the lumping keeps the
//! row sums, so the rigid motions stay in the null space of `A_F` where they are in `A`'s). On
//! a bond lattice with `delta = 3h` and `ratio = 1.5` it keeps the 18 partners at `h` and
//! `sqrt(2) h` of 122: the smoothed basis functions reach a spacing and a half beyond their
//! aggregate instead of a horizon, so `P` holds half the entries and the Galerkin product
//! `P^T A P` (with the whole `A`) costs half (measured in docs/solvers.md). The coarse
//! operator stays Galerkin's, so the V-cycle stays symmetric positive definite whatever `A_F`.

use super::level::LevelMatrix;
use super::vbr::Vbr;
use super::{prolongator, smoother, AmgParams};
use linpd_core::Point;
use rayon::prelude::*;

/// `A_F` of level matrix `a` whose row block `bi` sits at `pos[bi]` and couples to the row
/// blocks `graph` lists (CSR, a superset of its nonzero blocks: the model's bonds) (see the
/// module docs), and the scalar entries of `a` (counted in the pass: a matrix-free level
/// has no other pass over its blocks before the Galerkin product). The pattern comes from the
/// graph and the positions; one parallel pass over the blocks writes the values in place.
pub(crate) fn filtered(a: &dyn LevelMatrix, pos: &[Point], ratio: f64, graph: &(Vec<usize>, Vec<u32>)) -> (Vbr, usize) {
    let rptr = a.rptr();
    let nb = a.n_row_blocks();
    let (gptr, gidx) = graph;
    assert_eq!(pos.len(), nb, "one position per row block");
    assert_eq!(gptr.len(), nb + 1, "one graph row per row block");
    let d2 = |i: usize, j: usize| (0..3).map(|k| (pos[i][k] - pos[j][k]).powi(2)).sum::<f64>();
    let size = |i: usize| rptr[i + 1] - rptr[i];
    let reach = ratio * ratio * (1.0 + 1e-9);
    // r_i^2: ratio^2 times the squared distance to the nearest partner
    let r2: Vec<f64> = (0..nb)
        .into_par_iter()
        .map(|bi| {
            gidx[gptr[bi]..gptr[bi + 1]].iter().map(|&bj| d2(bi, bj as usize)).fold(f64::INFINITY, f64::min) * reach
        })
        .collect();
    // the pattern: the diagonal and the partners within reach, ascending
    let kept = |bi: usize, bj: u32| bj as usize != bi && d2(bi, bj as usize) <= r2[bi].max(r2[bj as usize]);
    let (bptr, bidx) = super::super::csr_in_place(
        nb,
        |bi| 1 + gidx[gptr[bi]..gptr[bi + 1]].iter().filter(|&&bj| kept(bi, bj)).count(),
        |bi, row| {
            let mut k = 0;
            for &bj in gidx[gptr[bi]..gptr[bi + 1]].iter().filter(|&&bj| kept(bi, bj)).chain([&(bi as u32)]) {
                row[k] = bj;
                k += 1;
            }
            row.sort_unstable();
            k
        },
    );
    let mut voff = Vec::with_capacity(bidx.len() + 1);
    voff.push(0usize);
    for bi in 0..nb {
        for &bj in &bidx[bptr[bi]..bptr[bi + 1]] {
            voff.push(voff.last().unwrap() + size(bi) * size(bj as usize));
        }
    }
    // the values, row by row in place (written first: fresh pages fault once)
    let mut val = vec![0.0; *voff.last().unwrap()];
    let row_vals = super::vbr::split_at_bounds(&mut val, bptr.iter().map(|&b| voff[b]));
    let entries: usize = row_vals
        .into_par_iter()
        .enumerate()
        .map(|(bi, out)| {
            out.fill(0.0);
            let mut entries = 0;
            let cols = &bidx[bptr[bi]..bptr[bi + 1]];
            let base = voff[bptr[bi]];
            let si = size(bi);
            let diag = cols.binary_search(&(bi as u32)).expect("the diagonal is kept");
            let diag_at = voff[bptr[bi] + diag] - base;
            a.for_each_row_block(bi, &mut |bj, b| {
                entries += b.len();
                match cols.binary_search(&(bj as u32)) {
                    Ok(k) => {
                        let at = voff[bptr[bi] + k] - base;
                        out[at..at + b.len()].iter_mut().zip(b).for_each(|(o, v)| *o += v);
                    }
                    // dropped: lumped into the diagonal when the shapes agree
                    Err(_) if b.len() == si * si => {
                        out[diag_at..diag_at + b.len()].iter_mut().zip(b).for_each(|(o, v)| *o += v);
                    }
                    Err(_) => {}
                }
            });
            entries
        })
        .sum();
    (Vbr::new(rptr.to_vec(), rptr.to_vec(), bptr, bidx, voff, val), entries)
}

/// The tentative prolongator `tent` smoothed with `A_F` of [`filtered`]: `P = (I - omega /
/// rho_F D_F^{-1} A_F) T`, and the scalar entries of `a`. `None` when the lumped diagonal
/// `D_F` is not positive: bond operators' dropped blocks are negative semi-definite, so
/// lumping them only adds to it, but a tangent with positive off-diagonal blocks (LPS near
/// incompressibility, Poisson ratio 0.45 with `delta = 3h`) can take it to zero; the caller
/// then smooths with `A`.
pub(crate) fn smooth_filtered(
    a: &dyn LevelMatrix,
    tent: &Vbr,
    pos: &[Point],
    ratio: f64,
    graph: &(Vec<usize>, Vec<u32>),
    params: &AmgParams,
) -> Option<(Vbr, usize)> {
    let (af, entries) = filtered(a, pos, ratio, graph);
    let diag = af.diagonal();
    if !diag.iter().all(|d| *d > 0.0 && d.is_finite()) {
        return None;
    }
    let dinv: Vec<f64> = diag.iter().map(|d| 1.0 / d).collect();
    let rho = smoother::spectral_radius(&af, &dinv, params.lanczos_steps);
    (rho > 0.0 && rho.is_finite())
        .then(|| (prolongator::smooth(&af, tent, &dinv, params.prolongation_omega / rho), entries))
}
