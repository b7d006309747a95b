//! Preconditioners: `z = M^{-1} r` for an `M` close to `A` and cheap to invert.
//!
//! A Krylov method takes any [`Preconditioner`] (the trait is defined with the Krylov methods,
//! [`crate::krylov::preconditioner`], and re-exported here); a new one is one file here
//! implementing the trait and its [`kind::PreconditionerType`] (its name, its build, `auto`'s
//! estimate, its setup's bytes), plus one line in [`kind::PRECONDITIONERS`]; no caller changes.
//! What a multilevel preconditioner needs to know about the unknowns besides the matrix is a
//! [`DofGeometry`].
//!
//! * [`Identity`]: `M = I`;
//! * [`Jacobi`]: `M = diag(A)`;
//! * [`Amg`]: smoothed-aggregation algebraic multigrid, one symmetric V-cycle;
//! * [`FactorPreconditioner`]: an exact factorization of an SPD `M` (e.g. the divergence-form
//!   or symmetric part of the blended operator of linpd-blend).

pub mod amg;
mod factor;
mod geometry;
mod jacobi;
pub mod kind;

pub use crate::krylov::preconditioner::{Identity, Preconditioner};
pub use amg::{Amg, AmgError, AmgOperator, AmgParams, AmgSmoother, AmgStats, CoarseSpace, LatticeMultigrid};
pub use factor::FactorPreconditioner;
pub use geometry::DofGeometry;
pub use jacobi::Jacobi;

use rayon::prelude::*;

/// A CSR pattern `(ptr, idx)` of `n` rows built in place, in parallel: `count(r)` bounds row
/// `r`'s length, `fill(r, slot)` writes the row into its `count(r)` slots and returns how many
/// it used (ascending, no repeats). Rows shorter than counted are compacted in one copy. One
/// short vector per row instead cost 14.7 s of a 150^3 lattice's 52.8 s multigrid setup (3.4M
/// allocations and a copy of 1.6 GB).
pub(crate) fn csr_in_place(
    n: usize,
    count: impl Fn(usize) -> usize + Sync,
    fill: impl Fn(usize, &mut [u32]) -> usize + Sync,
) -> (Vec<usize>, Vec<u32>) {
    let counts: Vec<usize> = (0..n).into_par_iter().map(&count).collect();
    let mut ptr = Vec::with_capacity(n + 1);
    ptr.push(0usize);
    for c in counts {
        ptr.push(ptr.last().unwrap() + c);
    }
    let mut idx = vec![0u32; ptr[n]];
    let rows = amg::split_at_bounds(&mut idx, ptr.iter().copied());
    let lens: Vec<usize> = rows.into_par_iter().enumerate().map(|(r, row)| fill(r, row)).collect();
    if lens.iter().zip(ptr.windows(2)).all(|(&l, w)| l == w[1] - w[0]) {
        return (ptr, idx);
    }
    let mut compact = Vec::with_capacity(lens.iter().sum());
    let mut cptr = Vec::with_capacity(n + 1);
    cptr.push(0);
    for (r, &l) in lens.iter().enumerate() {
        compact.extend_from_slice(&idx[ptr[r]..ptr[r] + l]);
        cptr.push(compact.len());
    }
    (cptr, compact)
}
