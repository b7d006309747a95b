//! Coarsening of linear peridynamic models (1D scalar, 2D/3D tensor; bond-based or the LPS
//! tangent) after S. A. Silling, *A coarsening method for linear peridynamics* (2010); equation
//! numbers below refer to that paper. The formulas are written for the scalar case; in 2D/3D
//! every `C` is a `d x d` block and every product a block product.
//!
//! # Level model
//!
//! A level-`m` model ([`LevelModel`]) is a set of nodes with positions `x_i`, volumes `v_i` and a
//! symmetric (pointwise) micromodulus `C(x_i, x_j)` stored sparsely as bonds `(j, C_ij)` per node.
//! Its force density is the discretised form of (4)/(10):
//!
//! ```text
//! L u_i = sum_j C_ij (u_j - u_i) v_j                                  (4), (10) discretised
//! ```
//!
//! Equilibrium is `L u_i + b_i = 0` with `b` a body force *density*.
//!
//! # One coarsening step, eqs. (8)-(14)
//!
//! Given level `m-1` and the retained subset `B^m`, for every retained node `x`
//! ([`coarsen`]):
//!
//! 1. `N_x` = level-(m-1) nodes with `|p - x| <= r^m`, `R_x = N_x ∩ B^m` (Sec. 2/3).
//! 2. Local system (13), `[A]{u} = {b}`, unknowns ordered retained-first: identity rows for
//!    `p ∈ R_x` (compatibility (2)); for excluded `z ∈ N_x \ R_x` the equilibrium row (3)-(5)
//!    with interactions restricted to `N_x` (eq. (4)):
//!    `A_zp = C(z,p) v_p` (p ≠ z), `A_zz = -P_z = -sum_{p∈N_x, p≠z} C(z,p) v_p`.
//!    In the paper's notation `C^{m-1}_{z,p} = v_p C(z,p)` is the *volume-weighted* matrix entry.
//! 3. `S` = the `R` leftmost columns of `A^{-1}` (14). With `A = [I 0; B M]` (`M` the
//!    excluded-excluded block, `B` excluded-retained), `S = [I; -M^{-1} B]`. The coarse row needs
//!    only `W_{x,N} S = W_{x,R} - (W_{x,E} M^{-1}) B`, so one *transposed* solve
//!    `M^T Z^T = W_{x,E}^T` with `d` right-hand sides replaces the `d R` solves for `S`; no inverse
//!    is formed. [`local_resolvent`] still computes the whole `S` (tests of (8), reconstruction).
//!    `-M` is SPD for bond-based models (dense Cholesky; LU if `M` is not symmetric, sparse LU
//!    above [`Options::dense_limit`] unknowns). `S` is dimensionless, `u^{m-1}_p = sum_q S_pq
//!    u^m_q` (14), and its block rows sum to the identity, the discrete form of (8).
//! 4. Coarse micromodulus, (11) discretised (see "volume factors" below; the default
//!    [`Matching::TotalForce`] adds the factor `v^{m-1}_x / v^m_x`, eq. (11'')):
//!
//! ```text
//! C^m(x, q) v^m_q = sum_{p ∈ N_x} C^{m-1}(x, p) v^{m-1}_p S_pq      q ∈ R_x, q ≠ x     (11')
//! ```
//!
//! # Volume factors (derived from the property (9), not copied from the printed formula)
//!
//! Requirement (9): for any level-m displacement `u^m` and `u^{m-1} = S u^m` on `N_x` (excluded
//! nodes in equilibrium), `L^m(x) = L^{m-1}(x)`. With the discrete (4):
//!
//! ```text
//! L^{m-1}(x) = sum_p C^{m-1}(x,p) v^{m-1}_p (u^{m-1}_p - u^{m-1}_x)
//!            = sum_p C^{m-1}(x,p) v^{m-1}_p sum_q S_pq (u^m_q - u^m_x)         [rows of S sum to 1, (8)]
//!            = sum_q [ sum_p C^{m-1}(x,p) v^{m-1}_p S_pq ] (u^m_q - u^m_x)
//! L^m(x)     = sum_q C^m(x,q) v^m_q (u^m_q - u^m_x)                            [(10) discretised]
//! ```
//!
//! so (11') holds: the fine volume `v^{m-1}_p` of the *summed* node multiplies `C^{m-1}`, and the
//! coarse volume `v^m_q` of the *target* node divides. In the paper's volume-weighted entries
//! (`C^m_ij := v^m_j C^m(x_i,x_j)`, as `C^0_ij = v C^0(x_i,x_j)`) this is
//! `C^m_ij = sum_k C^{m-1}_ik S_kj` **without** a leading factor. The printed formula
//! `C^m_ij = v sum_k C^{m-1}_ik S_kj` (Sec. 4) carries one extra factor `v` when `S` is, as the
//! text defines it, the block of `A^{-1}`; it is only consistent if `S_kj` is read as the
//! resolvent *density* `S(x_k, x_j) ≈ [A^{-1}]_kj / v`. Taken literally it scales every coarse
//! force by `v` (0.005 in Example 5.1); the test `printed_formula_is_off_by_v` measures that.
//!
//! # Which "force" (9) matches: density vs nodal force ([`Matching`])
//!
//! Read literally, (9) equates force *densities*. Then only the product `C^m(x,q) v^m_q` is
//! fixed, body-force densities carry over unchanged, and the bulk modulus is **not** reproduced:
//! for exact condensation the second moment `Σ_q C^m(x,q)(q-x)^2 v^m_q` grows by
//! `v^m_x / v^{m-1}_x` (≈ 4 after the first step of Example 5.1; measured 3.3x with r^1 = 0.1),
//! because the coarse node stands for `v^m_x` of material but the density equation is that of the
//! single fine node. Matching the nodal force, `v^m_x L^m(x) = v^{m-1}_x L^{m-1}(x)`
//! ([`Matching::TotalForce`], the default), multiplies (11') by `f_x = v^{m-1}_x / v^m_x`:
//!
//! ```text
//! C^m(x,q) = v^{m-1}_x / (v^m_x v^m_q) · sum_{p∈N_x} C^{m-1}(x,p) v^{m-1}_p S_pq          (11'')
//! ```
//!
//! i.e. `C^m = W^S_xq / (v^m_x v^m_q)` with `W^S` the condensed nodal stiffness, which is
//! symmetric for *any* coarse volumes when `N_x` is the whole body, and reproduces the second
//! moment (bulk modulus). Body forces must then be lumped as nodal forces,
//! `b^m_x v^m_x = b^{m-1}_x v^{m-1}_x` (with (5): no load on excluded nodes). Both conventions
//! are exact static condensations (tests); they differ only in what the coarse node's
//! "density" refers to. Coarse volumes: [`coarse_volumes`] (nearest-retained-node lumping).
//! Neither convention reproduces the printed factor `v`.
//!
//! Each row uses its own `N_x`, so with finite `r^m` the coarse `C^m` is symmetric only where
//! the neighbourhoods are translation-invariant (interior of a homogeneous bar, to round-off);
//! near ends/defects [`LevelModel::asymmetry`] measures the defect and
//! [`LevelModel::symmetrized`] averages it away.
//!
//! Bonds of `x` that leave `N_x` are dropped (eq. (4) integrates over `N_x` only), so `r^m`
//! should be at least the level-(m-1) horizon; the body force on excluded nodes is assumed zero
//! (5). With `N_x` = whole body the step is exact static condensation.
//!
//! # Measured (tent kernel of Example 5.1, h = v = 0.005, r0 = 0.05)
//!
//! tests/coarsen.rs, and for Example 5.1 linpd-studies' tests/coarsen_examples.rs:
//!
//! * (9) on random `u^m`, both conventions, uniform and jittered grids: ≤ 1.5e-15 relative.
//! * Whole-body `N_x`, 201 -> 51 -> 26 nodes, Dirichlet ends, load on retained nodes: coarse
//!   solution = fine solution to 1.1e-13 relative; TotalForce `C^1`, `C^2` symmetric to 4e-16.
//! * Example 5.1 (length 1, every 4th then every 2nd, r^1 = 0.1, r^2 = 0.2): interior `C^m`
//!   symmetric to 3e-16 (1.8e-2 / 2.8e-2 relative near the ends); interior second moment
//!   -17.3 % (C^1) and -19.1 % (C^2) vs level 0 — the cost of cutting the bonds at the edge of
//!   `N_x`. Centre of a length-4 bar: r^1 = 0.15/0.2/0.3 (r^2 = 2 r^1) give -4.8/-0.84/-0.030 %
//!   (C^1) and -5.2/-0.90/-0.031 % (C^2); whole body -1e-15.

//!
//! # Radius rule, tail and cache ([`Radius`], [`StepReport`])
//!
//! Sec. 3: "the procedure can be repeated with increasing choices of r^1 \[until\] C^1(x,q)
//! become negligible for all q with |q - x| > r^1". Made precise: the *tail* of a step with
//! radius `r` is the largest `|C^m(x,q)|_F` over the outer shell `r - w < |q - x| <= r`
//! (the coarse bonds that the truncation of `N_x` can reach), relative to the row's largest
//! `|C^m(x,q)|_F`, maximised over the retained nodes; [`Radius::Auto`] grows `r` geometrically
//! from `2 delta^{m-1}` (footnote 1) until the tail is below `tol`. Radii below the level's
//! horizon are refused (bonds of `x` would be cut). The shell is `w = max(delta^{m-1}, h^m)`
//! wide, `h^m = max_x (v^m_x)^{1/d}` the coarse spacing: a shell one fine horizon wide can fall
//! between two rings of coarse nodes when the coarse spacing exceeds the fine horizon (every 4th
//! node of a `delta = 2h` lattice), read 0 and stop the rule at a radius that cuts the coarse
//! rows; until 2026-11 it did (a laminate's level 2 at `r < h^2` had nodes without bonds).
//!
//! The load transfer of a step ([`Transfer`]) and the effective elasticity of a level
//! ([`effective_moduli`]) are documented in their modules.
//!
//! Nodes whose neighbourhoods are equal up to translation share one local solve: each `N_x` is
//! ordered canonically (retained first, then by offset from `x`) and hashed (128 bits) with
//! everything the local solve reads: offsets (quantum `1e-9 r`), retained flags, volumes and
//! the bonds inside `N_x` of `x` and of the excluded nodes (quantum `1e-12` of the largest
//! value). The hit rate is reported.

mod cells;
mod homogenize;
mod level;
mod retain;
mod step;
mod transfer;

pub use homogenize::{effective_moduli, nodal_moduli, EffectiveModuli};
pub use level::LevelModel;
pub use retain::{check_retained, coarse_volumes, every_kth, retain_every};
pub use step::{
    coarsen, coarsen_with, coarsen_with_progress, local_resolvent, Coarsened, LocalResolvent, Matching, Options,
    Radius, StepReport, MAX_RADII,
};
pub use transfer::Transfer;

/// Errors of model construction and coarsening.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CoarsenError {
    /// Inconsistent input (lengths, indices, non-finite values, empty or foreign retained sets).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The radius is below the level's horizon.
    #[error(
        "coarsening radius r^m = {radius:.6e} is smaller than the horizon of the level being coarsened ({horizon:.6e}): \
         bonds of retained nodes would leave N_x; use r^m >= {horizon:.6e} (the paper's default is 2 x horizon)"
    )]
    RadiusBelowHorizon {
        /// The radius asked for.
        radius: f64,
        /// The level's horizon.
        horizon: f64,
    },
    /// The radius rule did not reach its tolerance.
    #[error(
        "the tail of C^m is still {tail:.3e} (> tol {tol:.1e}) at the largest radius tried, r^m = {radius:e}; \
         raise the maximum radius or the tolerance (tried: {tried:?})"
    )]
    TailNotReached {
        /// Tolerance.
        tol: f64,
        /// Last radius.
        radius: f64,
        /// Its tail.
        tail: f64,
        /// All `(radius, tail)` pairs.
        tried: Vec<(f64, f64)>,
    },
    /// A static solve of a whole level failed (body not held, singular stiffness).
    #[error("singular global system: {0}")]
    SingularGlobal(String),
    /// The local problem (13) of a retained node is singular.
    #[error(
        "singular local problem (13) for retained node {retained} (x = {x_retained:?}, r = {radius:e}): \
         excluded node {excluded} (x = {x_excluded:?}) {reason}; increase the coarsening radius r^m, \
         retain node {excluded} in B^m, or give it bonds"
    )]
    SingularLocal {
        /// Level-(m-1) index of the retained node whose neighbourhood failed.
        retained: usize,
        /// Its position.
        x_retained: Vec<f64>,
        /// Coarsening radius used.
        radius: f64,
        /// Level-(m-1) index of the offending excluded node.
        excluded: usize,
        /// Its position.
        x_excluded: Vec<f64>,
        /// What is wrong with it.
        reason: String,
    },
}

impl CoarsenError {
    pub(crate) fn singular(fine: &LevelModel, xi: usize, r: f64, z: usize, reason: &str) -> Self {
        let d = fine.dim();
        CoarsenError::SingularLocal {
            retained: xi,
            x_retained: fine.positions()[xi][..d].to_vec(),
            radius: r,
            excluded: z,
            x_excluded: fine.positions()[z][..d].to_vec(),
            reason: reason.to_string(),
        }
    }
}
