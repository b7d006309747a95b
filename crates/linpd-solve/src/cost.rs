//! `auto` by a cost model: estimate what each offered solver would cost on this system and
//! run the cheapest.
//!
//! * **Sparse Cholesky**: its symbolic analysis (in the model's ordering) is cheap and is run
//!   anyway, so its cost is known before any numeric work: `F = sum_j c_j^2` flops and
//!   `nnz(L)` entries ([`crate::Cholesky::flops`]). Time `F / R_F + nnz(L) t_L` (the second
//!   term: memory traffic of the factor and the triangular solves, which dominates in 2D where
//!   the supernodes are small). Excluded when `L` would not fit in [`CHOLESKY_MEMORY_LIMIT`].
//! * **Jacobi-PCG**: `k` iterations of one product with `A` (`nnz(A) t_A` each) and a few
//!   vector updates. Jacobi leaves `kappa ~ (L/h)^2`, so `k ~ sqrt(kappa) ~ c_d n_side`, with
//!   `n_side` the nodes along the body's longest side; scaled by `log(rtol) / log(1e-8)`.
//! * **Multigrid-PCG** (SA-AMG, [`crate::Amg`]): a setup of `S` matrix-entry costs per stored
//!   entry of `A` (aggregation, prolongator smoothing, Galerkin products) and `k` iterations of
//!   `c` entry costs each (the V-cycle's smoothing and residuals on all levels, plus CG's
//!   product), with `k` nearly independent of the size: `S = 65`, `c = 4`, `k = 17` at rtol
//!   1e-8 (measured with `linpd bench --statics`: setup 1.7-3.4e-7 s per entry and one
//!   iteration 3.4-4x a Jacobi-PCG iteration, 14-17 iterations on 2D plates 101^2..401^2 and
//!   3D cantilevers 20^3..40^3).
//!
//! The rates were fitted on the 2-core reference machine (measured 2026-11-23, bond-based
//! lattices, 2D plates 101^2 and 201^2 with `delta = 2h`, 3D cubes 12^3..20^3 with
//! `delta = 3h`, clamped on one side, body load on the other): `R_F = 12 GFlop/s`,
//! `t_L = 37 ns`, `t_A = 2.0 ns` per stored entry and iteration, `c_2 = 4.5`, `c_3 = 4.0`
//! iterations per node along the free body's longest side (layers included) at rtol 1e-8
//! (measured 3.8..4.0 in 3D, 4.5..4.55 in 2D). Cholesky estimates within 10 % of the measured
//! times on those cases; the choice only needs the ratio between candidates, which is less
//! machine-dependent than the rates themselves.

use crate::direct::Cholesky;
use crate::krylov::cg::CgParams;
use std::fmt;

/// Cholesky flop rate (flop/s), fitted (module docs).
const CHOLESKY_FLOP_RATE: f64 = 12e9;
/// Seconds per stored entry of `L` beyond the flops (module docs).
const CHOLESKY_ENTRY_SECONDS: f64 = 37e-9;
/// Seconds per stored entry of `A` per CG iteration (module docs).
const MATVEC_ENTRY_SECONDS: f64 = 2.0e-9;
/// Multigrid setup cost, in products-with-`A` entry costs per stored entry (module docs).
const MULTIGRID_SETUP_ENTRIES: f64 = 65.0;
/// Multigrid-PCG iteration cost, in entry costs per stored entry (module docs).
const MULTIGRID_ITERATION_ENTRIES: f64 = 4.0;
/// Multigrid-PCG iterations at rtol 1e-8 (module docs).
const MULTIGRID_ITERATIONS: f64 = 17.0;
/// Jacobi-PCG iterations per node along the longest side at rtol 1e-8, by dimension.
const JACOBI_ITERATIONS_PER_SIDE: [f64; 4] = [0.0, 4.5, 4.5, 4.0];

/// The factor of a sparse Cholesky must fit in this many bytes (a third of the 24 GiB machines,
/// leaving room for `A`, the symbolic structure and the factorization's workspace).
pub const CHOLESKY_MEMORY_LIMIT: f64 = 8.0 * (1u64 << 30) as f64;

/// What `auto` estimated for one candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The candidate's short name (`cholesky-nd`, `cg-jacobi`).
    pub solver: String,
    /// Estimated seconds (`None`: excluded, see `why`).
    pub seconds: Option<f64>,
    /// The quantity the estimate rests on (fill, iterations), or why it was excluded.
    pub why: String,
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.seconds {
            Some(s) => write!(f, "{} est. {s:.2} s ({})", self.solver, self.why),
            None => write!(f, "{} excluded ({})", self.solver, self.why),
        }
    }
}

/// The estimate of a sparse Cholesky from its symbolic analysis: excluded when the factor's
/// values exceed [`CHOLESKY_MEMORY_LIMIT`] or the machine's available memory, whichever is
/// smaller.
pub fn cholesky(chol: &Cholesky, name: String) -> Estimate {
    let nnz_l = chol.nnz_factor() as f64;
    let limit = CHOLESKY_MEMORY_LIMIT.min(linpd_core::memory::available_bytes().0);
    if nnz_l * 8.0 > limit {
        return Estimate {
            solver: name,
            seconds: None,
            why: format!(
                "nnz(L) {nnz_l:.2e}: {:.1} GiB > {:.1} GiB",
                nnz_l * 8.0 / (1u64 << 30) as f64,
                limit / (1u64 << 30) as f64
            ),
        };
    }
    let seconds = chol.flops() / CHOLESKY_FLOP_RATE + nnz_l * CHOLESKY_ENTRY_SECONDS;
    Estimate { solver: name, seconds: Some(seconds), why: format!("nnz(L) {nnz_l:.2e}, {:.2e} flops", chol.flops()) }
}

/// The estimate of Jacobi-PCG on `nnz_a` stored entries, `n_side` nodes along the longest side
/// in dimension `dim`.
pub fn jacobi_cg(dim: usize, nnz_a: usize, n_side: f64, params: &CgParams) -> Estimate {
    let k = (JACOBI_ITERATIONS_PER_SIDE[dim.min(3)] * n_side * tolerance_scale(params.rtol)).max(1.0);
    Estimate {
        solver: "cg-jacobi".into(),
        seconds: Some(k * nnz_a as f64 * MATVEC_ENTRY_SECONDS),
        why: format!("~{k:.0} iterations"),
    }
}

/// The estimate of multigrid-PCG on `nnz_a` stored entries.
pub fn multigrid_cg(nnz_a: usize, params: &CgParams) -> Estimate {
    let k = (MULTIGRID_ITERATIONS * tolerance_scale(params.rtol)).max(1.0);
    let entries = nnz_a as f64 * (MULTIGRID_SETUP_ENTRIES + k * MULTIGRID_ITERATION_ENTRIES);
    Estimate {
        solver: "cg-multigrid".into(),
        seconds: Some(entries * MATVEC_ENTRY_SECONDS),
        why: format!("setup + ~{k:.0} iterations"),
    }
}

/// Iterations to `rtol` relative to iterations to 1e-8: CG's error contracts geometrically.
fn tolerance_scale(rtol: f64) -> f64 {
    (rtol.max(1e-16).ln() / 1e-8f64.ln()).max(0.1)
}

/// Nodes along the longest side of the bounding box of `positions` (`dim` coordinates each),
/// taking the spacing as the edge of the cube of the box's volume per node: exact for a full
/// box lattice, an estimate for other bodies.
pub fn nodes_along_longest_side(dim: usize, positions: impl Iterator<Item = [f64; 3]>) -> f64 {
    let (mut lo, mut hi, mut n) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0usize);
    for p in positions {
        for a in 0..dim {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
        n += 1;
    }
    if n < 2 {
        return n as f64;
    }
    let sides: Vec<f64> = (0..dim).map(|a| (hi[a] - lo[a]).max(0.0)).collect();
    let longest = sides.iter().cloned().fold(0.0, f64::max);
    // Nodes per side of a box lattice with `n` nodes: prod (L_a / h + 1) = n, solved for h by
    // bisection (monotone in h).
    let count = |h: f64| sides.iter().map(|l| l / h + 1.0).product::<f64>();
    let (mut a, mut b) = (longest * 1e-9, longest.max(f64::MIN_POSITIVE));
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if count(m) > n as f64 {
            a = m;
        } else {
            b = m;
        }
    }
    longest / b + 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A full box lattice gives its exact count along the longest side (the bisection converges
    /// to round-off: 1e-9 relative).
    #[test]
    fn box_lattice_counts_are_exact() {
        let mut p = Vec::new();
        for k in 0..3 {
            for j in 0..6 {
                for i in 0..11 {
                    p.push([0.1 * i as f64, 0.1 * j as f64, 0.1 * k as f64]);
                }
            }
        }
        let n = nodes_along_longest_side(3, p.iter().copied());
        assert!((n - 11.0).abs() <= 1e-9 * 11.0, "{n}");
        let n2 = nodes_along_longest_side(2, p.iter().filter(|x| x[2] == 0.0).copied());
        assert!((n2 - 11.0).abs() <= 1e-9 * 11.0, "{n2}");
    }

    /// Iteration estimates scale with the side and with log(rtol).
    #[test]
    fn jacobi_estimate_scales_with_side_and_tolerance() {
        let p8 = CgParams { rtol: 1e-8, max_iter: 10 };
        let p16 = CgParams { rtol: 1e-16, max_iter: 10 };
        let t = |n_side: f64, p: &CgParams| jacobi_cg(3, 1000, n_side, p).seconds.unwrap();
        assert!((t(40.0, &p8) / t(20.0, &p8) - 2.0).abs() < 1e-12);
        assert!((t(20.0, &p16) / t(20.0, &p8) - 2.0).abs() < 1e-12);
    }
}
