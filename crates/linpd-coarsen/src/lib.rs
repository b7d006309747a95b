//! Coarsening of 1D scalar linear peridynamic models after S. A. Silling, *A coarsening method
//! for linear peridynamics* (2010); equation numbers below refer to that paper.
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
//! 3. `S` = the `R` leftmost columns of `A^{-1}` (14), obtained by solving `A S = [I_R; 0]` with a
//!    dense partial-pivoting LU (`Par::Seq`; the retained nodes are distributed over rayon).
//!    `S` is dimensionless, `u^{m-1}_p = sum_q S_pq u^m_q` (14), and its rows sum to one, the
//!    discrete form of (8) (checked in the tests).
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
//! # Measured (tests/coarsen.rs, tent kernel of Example 5.1, h = v = 0.005, r0 = 0.05)
//!
//! * (9) on random `u^m`, both conventions, uniform and jittered grids: ≤ 1.5e-15 relative.
//! * Whole-body `N_x`, 201 -> 51 -> 26 nodes, Dirichlet ends, load on retained nodes: coarse
//!   solution = fine solution to 1.1e-13 relative; TotalForce `C^1`, `C^2` symmetric to 4e-16.
//! * Example 5.1 (length 1, every 4th then every 2nd, r^1 = 0.1, r^2 = 0.2): interior `C^m`
//!   symmetric to 3e-16 (1.8e-2 / 2.8e-2 relative near the ends); interior second moment
//!   -17.3 % (C^1) and -19.1 % (C^2) vs level 0 — the cost of cutting the bonds at the edge of
//!   `N_x`. Centre of a length-4 bar: r^1 = 0.15/0.2/0.3 (r^2 = 2 r^1) give -4.8/-0.84/-0.030 %
//!   (C^1) and -5.2/-0.90/-0.031 % (C^2); whole body -1e-15.

pub mod io;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::{Conj, Mat, Par};
use rayon::prelude::*;

/// Errors of model construction, coarsening and solving.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CoarsenError {
    /// Inconsistent input (lengths, indices, non-finite values, ...).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The local problem (13) of a retained node is singular.
    #[error(
        "singular local problem (13) for retained node {retained} (x = {x_retained}, r = {radius}): \
         excluded node {excluded} (x = {x_excluded}) {reason}; increase the coarsening radius r^m, \
         retain node {excluded} in B^m, or give it bonds"
    )]
    SingularLocal {
        /// Level-(m-1) index of the retained node whose neighbourhood failed.
        retained: usize,
        /// Its position.
        x_retained: f64,
        /// Coarsening radius used.
        radius: f64,
        /// Level-(m-1) index of the offending excluded node.
        excluded: usize,
        /// Its position.
        x_excluded: f64,
        /// What is wrong with it.
        reason: String,
    },
    /// A global dense solve hit a (numerically) zero pivot.
    #[error("singular global system: zero pivot at elimination step {0} (missing Dirichlet data or a disconnected node?)")]
    SingularGlobal(usize),
}

/// A level-m model: positions, volumes and sparse pointwise micromodulus `C(x_i, x_j)`.
#[derive(Debug, Clone)]
pub struct LevelModel {
    x: Vec<f64>,
    v: Vec<f64>,
    bonds: Vec<Vec<(usize, f64)>>,
}

impl LevelModel {
    /// Build from explicit bonds: `bonds[i]` lists `(j, C(x_i, x_j))`, `j != i`, each `j` once.
    pub fn new(x: Vec<f64>, v: Vec<f64>, bonds: Vec<Vec<(usize, f64)>>) -> Result<Self, CoarsenError> {
        let n = x.len();
        if v.len() != n || bonds.len() != n {
            return Err(CoarsenError::InvalidInput(format!(
                "lengths differ: {} positions, {} volumes, {} bond lists",
                n,
                v.len(),
                bonds.len()
            )));
        }
        for i in 0..n {
            if !x[i].is_finite() || !v[i].is_finite() || v[i] <= 0.0 {
                return Err(CoarsenError::InvalidInput(format!(
                    "node {i}: position {} / volume {} must be finite, volume > 0",
                    x[i], v[i]
                )));
            }
            for &(j, c) in &bonds[i] {
                if j >= n || j == i || !c.is_finite() {
                    return Err(CoarsenError::InvalidInput(format!(
                        "node {i}: bond to {j} with C = {c} (index out of range, self-bond or non-finite)"
                    )));
                }
            }
        }
        Ok(Self { x, v, bonds })
    }

    /// Level-0 model from a pointwise micromodulus `c(x, q)` evaluated for `0 < |q - x| <= horizon`
    /// (zero values are not stored). `c` should be symmetric.
    pub fn from_kernel(
        x: Vec<f64>,
        v: Vec<f64>,
        horizon: f64,
        c: impl Fn(f64, f64) -> f64 + Sync,
    ) -> Result<Self, CoarsenError> {
        let n = x.len();
        let order = sorted_order(&x);
        let bonds = (0..n)
            .into_par_iter()
            .map(|i| {
                within(&x, &order, x[i], horizon)
                    .into_iter()
                    .filter(|&j| j != i)
                    .filter_map(|j| {
                        let cij = c(x[i], x[j]);
                        (cij != 0.0).then_some((j, cij))
                    })
                    .collect()
            })
            .collect();
        Self::new(x, v, bonds)
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// True when there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// Node positions.
    pub fn positions(&self) -> &[f64] {
        &self.x
    }
    /// Node volumes.
    pub fn volumes(&self) -> &[f64] {
        &self.v
    }
    /// Bonds `(j, C(x_i, x_j))` of node `i`.
    pub fn bonds(&self, i: usize) -> &[(usize, f64)] {
        &self.bonds[i]
    }
    /// Pointwise micromodulus `C(x_i, x_j)` (0 if there is no bond).
    pub fn micromodulus(&self, i: usize, j: usize) -> f64 {
        self.bonds[i].iter().find(|b| b.0 == j).map_or(0.0, |b| b.1)
    }
    /// Largest bond length of node `i`.
    pub fn horizon_of(&self, i: usize) -> f64 {
        self.bonds[i].iter().map(|&(j, _)| (self.x[j] - self.x[i]).abs()).fold(0.0, f64::max)
    }

    /// Force density `L u_i = sum_j C_ij (u_j - u_i) v_j`, eq. (4)/(10) discretised.
    pub fn force_density(&self, u: &[f64]) -> Vec<f64> {
        assert_eq!(u.len(), self.len(), "displacement length");
        (0..self.len()).map(|i| self.force_density_at(i, u)).collect()
    }

    /// Force density at one node.
    pub fn force_density_at(&self, i: usize, u: &[f64]) -> f64 {
        self.bonds[i].iter().map(|&(j, c)| c * (u[j] - u[i]) * self.v[j]).sum()
    }

    /// Second moment `sum_q C(x,q) (q-x)^2 v_q` at node `i`; in 1D the bulk (bar) modulus is
    /// half of it, so coarsening should preserve it.
    pub fn second_moment(&self, i: usize) -> f64 {
        self.bonds[i].iter().map(|&(j, c)| c * (self.x[j] - self.x[i]).powi(2) * self.v[j]).sum()
    }

    /// `max_{i,j} |C_ij - C_ji| / max |C|` (a missing reverse bond counts as 0).
    pub fn asymmetry(&self) -> f64 {
        let mut num: f64 = 0.0;
        let mut den: f64 = 0.0;
        for i in 0..self.len() {
            for &(j, c) in &self.bonds[i] {
                den = den.max(c.abs());
                num = num.max((c - self.micromodulus(j, i)).abs());
            }
        }
        if den == 0.0 { 0.0 } else { num / den }
    }

    /// Copy with `C_ij <- (C_ij + C_ji)/2` (bond lists become symmetric).
    pub fn symmetrized(&self) -> Self {
        let n = self.len();
        let mut bonds: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for i in 0..n {
            for &(j, c) in &self.bonds[i] {
                let avg = 0.5 * (c + self.micromodulus(j, i));
                bonds[i].push((j, avg));
                if self.micromodulus(j, i) == 0.0 && !self.bonds[j].iter().any(|b| b.0 == i) {
                    bonds[j].push((i, avg));
                }
            }
        }
        Self { x: self.x.clone(), v: self.v.clone(), bonds }
    }

    /// Solve the static problem `L u_i + b_i = 0` for free nodes, `u_i = g` for `fixed = [(i, g)]`
    /// (dense LU, `Par::Seq`; for small verification problems).
    pub fn solve_dirichlet(&self, b: &[f64], fixed: &[(usize, f64)]) -> Result<Vec<f64>, CoarsenError> {
        let n = self.len();
        if b.len() != n {
            return Err(CoarsenError::InvalidInput(format!("body force has {} entries, model has {n} nodes", b.len())));
        }
        let mut is_fixed = vec![None; n];
        for &(i, g) in fixed {
            if i >= n {
                return Err(CoarsenError::InvalidInput(format!("fixed node {i} out of range (n = {n})")));
            }
            is_fixed[i] = Some(g);
        }
        let mut a = Mat::<f64>::zeros(n, n);
        let mut rhs = Mat::<f64>::zeros(n, 1);
        for i in 0..n {
            if let Some(g) = is_fixed[i] {
                a[(i, i)] = 1.0;
                rhs[(i, 0)] = g;
            } else {
                for &(j, c) in &self.bonds[i] {
                    a[(i, j)] += c * self.v[j];
                    a[(i, i)] -= c * self.v[j];
                }
                rhs[(i, 0)] = -b[i];
            }
        }
        let x = dense_lu_solve(a, rhs).map_err(CoarsenError::SingularGlobal)?;
        Ok((0..n).map(|i| x[(i, 0)]).collect())
    }
}

/// Result of one coarsening step.
#[derive(Debug, Clone)]
pub struct Coarsened {
    /// The level-m model (node `k` is level-(m-1) node `parent[k]`).
    pub model: LevelModel,
    /// Level-(m-1) index of each level-m node.
    pub parent: Vec<usize>,
}

/// The local problem (13)-(14) of one retained node.
#[derive(Debug, Clone)]
pub struct LocalResolvent {
    /// Level-(m-1) indices of `N_x`, retained nodes (`R_x`) first, in increasing index order.
    pub nodes: Vec<usize>,
    /// Number of retained nodes `R` (the first `R` entries of `nodes`).
    pub n_retained: usize,
    /// `S` (N x R): the leftmost R columns of `A^{-1}`, eq. (14).
    pub s: Mat<f64>,
}

/// Every `k`-th index of `0..n` starting at 0 (the last node is added if `(n-1) % k != 0`).
pub fn every_kth(n: usize, k: usize) -> Vec<usize> {
    assert!(k >= 1 && n >= 1);
    let mut r: Vec<usize> = (0..n).step_by(k).collect();
    if *r.last().unwrap() != n - 1 {
        r.push(n - 1);
    }
    r
}

/// Lumped coarse volumes: every level-(m-1) node gives its volume to the nearest retained node
/// (by position; split equally on a tie). Total volume is conserved and interior nodes of a
/// uniform every-k-th coarsening get exactly `k v`. (A volume-proportional rule, `v^m ∝ v^{m-1}`,
/// was tried first: it gives `Σv/Σ_R v = 201/51 ≈ 3.94 v` instead of `4 v` in Example 5.1 and so
/// a 1.5 % bulk-modulus error even for exact condensation.)
pub fn coarse_volumes(fine: &LevelModel, retained: &[usize]) -> Vec<f64> {
    let mut by_x: Vec<usize> = (0..retained.len()).collect();
    by_x.sort_by(|&a, &b| fine.x[retained[a]].total_cmp(&fine.x[retained[b]]));
    let xs: Vec<f64> = by_x.iter().map(|&k| fine.x[retained[k]]).collect();
    let mut vm = vec![0.0; retained.len()];
    let span = xs.last().unwrap() - xs[0];
    for p in 0..fine.len() {
        let xp = fine.x[p];
        let hi = xs.partition_point(|&x| x < xp);
        if hi == 0 {
            vm[by_x[0]] += fine.v[p];
        } else if hi == xs.len() {
            vm[by_x[hi - 1]] += fine.v[p];
        } else {
            let (dl, dr) = (xp - xs[hi - 1], xs[hi] - xp);
            if (dl - dr).abs() <= 1e-12 * span.max(f64::MIN_POSITIVE) {
                vm[by_x[hi - 1]] += 0.5 * fine.v[p];
                vm[by_x[hi]] += 0.5 * fine.v[p];
            } else if dl < dr {
                vm[by_x[hi - 1]] += fine.v[p];
            } else {
                vm[by_x[hi]] += fine.v[p];
            }
        }
    }
    vm
}

fn sorted_order(x: &[f64]) -> Vec<usize> {
    let mut o: Vec<usize> = (0..x.len()).collect();
    o.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    o
}

/// Indices with `|x_j - c| <= r` (closed ball, relative slack 1e-12), increasing index order.
fn within(x: &[f64], order: &[usize], c: f64, r: f64) -> Vec<usize> {
    let r = r * (1.0 + 1e-12);
    let lo = order.partition_point(|&j| x[j] < c - r);
    let mut out: Vec<usize> = order[lo..].iter().copied().take_while(|&j| x[j] <= c + r).collect();
    out.sort_unstable();
    out
}

/// Dense LU solve (partial pivoting, `Par::Seq`); `Err(k)` on a zero pivot at step `k`.
fn dense_lu_solve(mut a: Mat<f64>, mut rhs: Mat<f64>) -> Result<Mat<f64>, usize> {
    let n = a.nrows();
    let scale = (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs()));
    let mut fwd = vec![0usize; n];
    let mut bwd = vec![0usize; n];
    let par = Par::Seq;
    let mut mem = MemBuffer::new(
        factor::lu_in_place_scratch::<usize, f64>(n, n, par, Default::default())
            .or(solve::solve_in_place_scratch::<usize, f64>(n, rhs.ncols(), par)),
    );
    let (_, perm) = factor::lu_in_place(a.as_mut(), &mut fwd, &mut bwd, par, MemStack::new(&mut mem), Default::default());
    let tol = scale * n as f64 * f64::EPSILON;
    for k in 0..n {
        if a[(k, k)].is_nan() || a[(k, k)].abs() <= tol {
            return Err(k);
        }
    }
    solve::solve_in_place_with_conj(a.as_ref(), a.as_ref(), perm, Conj::No, rhs.as_mut(), par, MemStack::new(&mut mem));
    Ok(rhs)
}

/// Build and solve the local problem (13)-(14) of retained level-(m-1) node `xi` with
/// neighbourhood radius `radius`; `is_retained[p]` marks `B^m`.
///
/// Before factorising, the excluded nodes of `N_x` are checked structurally: every connected
/// component (through bonds inside `N_x`) must reach a retained node, otherwise (13) is singular
/// and [`CoarsenError::SingularLocal`] names the node.
pub fn local_resolvent(
    fine: &LevelModel,
    is_retained: &[bool],
    xi: usize,
    radius: f64,
) -> Result<LocalResolvent, CoarsenError> {
    let order = sorted_order(&fine.x);
    local_resolvent_sorted(fine, &order, is_retained, xi, radius)
}

fn local_resolvent_sorted(
    fine: &LevelModel,
    order: &[usize],
    is_retained: &[bool],
    xi: usize,
    radius: f64,
) -> Result<LocalResolvent, CoarsenError> {
    let hood = within(&fine.x, order, fine.x[xi], radius);
    let mut nodes: Vec<usize> = hood.iter().copied().filter(|&p| is_retained[p]).collect();
    let r = nodes.len();
    nodes.extend(hood.iter().copied().filter(|&p| !is_retained[p]));
    let nn = nodes.len();
    // local index of each level-(m-1) node in N_x
    // local index of a level-(m-1) node in N_x (both blocks are sorted)
    let local = |p: usize| {
        nodes[..r].binary_search(&p).ok().or_else(|| nodes[r..].binary_search(&p).ok().map(|k| k + r))
    };
    let singular = |p: usize, reason: &str| CoarsenError::SingularLocal {
        retained: xi,
        x_retained: fine.x[xi],
        radius,
        excluded: p,
        x_excluded: fine.x[p],
        reason: reason.to_string(),
    };
    // structural check: BFS from the retained block through excluded nodes
    let mut reached = vec![false; nn];
    let mut queue: Vec<usize> = (0..r).collect();
    reached[..r].iter_mut().for_each(|b| *b = true);
    // excluded node z is reached if it has a nonzero bond inside N_x to a reached node
    // (directed edge z -> p for each nonzero of the equilibrium row of z; search reversed)
    let mut rev: Vec<Vec<usize>> = vec![Vec::new(); nn];
    let mut own = vec![0usize; nn];
    for a in r..nn {
        for &(q, c) in &fine.bonds[nodes[a]] {
            if c != 0.0 {
                if let Some(b) = local(q) {
                    rev[b].push(a);
                    own[a] += 1;
                }
            }
        }
    }
    while let Some(a) = queue.pop() {
        for &b in &rev[a] {
            if !reached[b] {
                reached[b] = true;
                queue.push(b);
            }
        }
    }
    for a in r..nn {
        if own[a] == 0 {
            return Err(singular(nodes[a], "has no bond inside N_x"));
        }
        if !reached[a] {
            return Err(singular(nodes[a], "is not connected through bonds inside N_x to any retained node"));
        }
    }
    // eq. (13): identity rows for R_x, equilibrium rows (3)-(5) for N_x \ R_x
    let mut a = Mat::<f64>::zeros(nn, nn);
    for k in 0..r {
        a[(k, k)] = 1.0;
    }
    for row in r..nn {
        let z = nodes[row];
        let mut p_z = 0.0;
        for &(p, c) in &fine.bonds[z] {
            if let Some(col) = local(p) {
                let w = c * fine.v[p]; // C^{m-1}_{z,p} = v_p C(z,p)
                a[(row, col)] += w;
                p_z += w;
            }
        }
        a[(row, row)] -= p_z; // -P_z
    }
    let rhs = Mat::<f64>::from_fn(nn, r, |i, j| if i == j { 1.0 } else { 0.0 });
    let s = dense_lu_solve(a, rhs).map_err(|k| singular(nodes[k.max(r).min(nn - 1)], "gives a numerically zero pivot"))?;
    if s.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return Err(singular(nodes[r.min(nn - 1)], "makes the solve non-finite"));
    }
    Ok(LocalResolvent { nodes, n_retained: r, s })
}

/// One coarsening step (8)-(14): level `m-1` model `fine`, retained level-(m-1) indices
/// `retained` (B^m, any order, no duplicates), neighbourhood radius `radius` = r^m.
/// Level-m node `k` is `retained[k]` after sorting.
pub fn coarsen(fine: &LevelModel, retained: &[usize], radius: f64) -> Result<Coarsened, CoarsenError> {
    coarsen_with(fine, retained, radius, Matching::TotalForce)
}

/// What "the level-m force equals the level-(m-1) force" (9) is applied to; see the crate docs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Matching {
    /// `v^m_x L^m(x) = v^{m-1}_x L^{m-1}(x)`: the nodal *force* matches. Preserves the bulk
    /// modulus (second moment) and gives a symmetric `C^m` for any coarse volumes when `N_x` is
    /// the whole body. Body force densities must be lumped: `b^m_x = b_x v^{m-1}_x / v^m_x`.
    TotalForce,
    /// `L^m(x) = L^{m-1}(x)`: the force *density* matches, literally as printed in (9); body force
    /// densities carry over unchanged, but the second moment grows by `v^m_x / v^{m-1}_x`.
    ForceDensity,
}

/// [`coarsen`] with an explicit [`Matching`] convention.
pub fn coarsen_with(
    fine: &LevelModel,
    retained: &[usize],
    radius: f64,
    matching: Matching,
) -> Result<Coarsened, CoarsenError> {
    let n = fine.len();
    if !radius.is_finite() || radius <= 0.0 {
        return Err(CoarsenError::InvalidInput(format!("coarsening radius must be > 0, got {radius}")));
    }
    let mut parent = retained.to_vec();
    parent.sort_unstable();
    parent.dedup();
    if parent.len() != retained.len() || parent.last().is_some_and(|&p| p >= n) || parent.is_empty() {
        return Err(CoarsenError::InvalidInput(format!(
            "retained set must be non-empty, duplicate-free indices < {n}"
        )));
    }
    let mut is_retained = vec![false; n];
    let mut coarse_index = vec![usize::MAX; n];
    for (k, &p) in parent.iter().enumerate() {
        is_retained[p] = true;
        coarse_index[p] = k;
    }
    let vm = coarse_volumes(fine, &parent);
    let order = sorted_order(&fine.x);
    let rows: Result<Vec<Vec<(usize, f64)>>, CoarsenError> = parent
        .par_iter()
        .map(|&xi| {
            let loc = local_resolvent_sorted(fine, &order, &is_retained, xi, radius)?;
            // coefficients of the fine force at x on u^{m-1}_p: C^{m-1}(x,p) v^{m-1}_p, p ∈ N_x
            let mut row = Vec::with_capacity(loc.n_retained);
            for q_loc in 0..loc.n_retained {
                let q = loc.nodes[q_loc];
                if q == xi {
                    continue;
                }
                let mut acc = 0.0;
                for &(p, c) in &fine.bonds[xi] {
                    if let Some(p_loc) = find_local(&loc, p) {
                        acc += c * fine.v[p] * loc.s[(p_loc, q_loc)];
                    }
                }
                // (11'): C^m(x,q) v^m_q = f_x sum_p C^{m-1}(x,p) v^{m-1}_p S_pq,
                // f_x = v^{m-1}_x / v^m_x (TotalForce) or 1 (ForceDensity)
                let f_x = match matching {
                    Matching::TotalForce => fine.v[xi] / vm[coarse_index[xi]],
                    Matching::ForceDensity => 1.0,
                };
                let cq = f_x * acc / vm[coarse_index[q]];
                if cq != 0.0 {
                    row.push((coarse_index[q], cq));
                }
            }
            Ok(row)
        })
        .collect();
    let x = parent.iter().map(|&p| fine.x[p]).collect();
    Ok(Coarsened { model: LevelModel::new(x, vm, rows?)?, parent })
}

fn find_local(loc: &LocalResolvent, p: usize) -> Option<usize> {
    let r = loc.n_retained;
    loc.nodes[..r].binary_search(&p).ok().or_else(|| loc.nodes[r..].binary_search(&p).ok().map(|k| k + r))
}
