//! A geometric top level for lattice models: the model re-discretized on the lattice of twice
//! its spacing ([`Model::coarse_lattice`]) is the first coarse level, reached by trilinear
//! interpolation; smoothed aggregation ([`Amg`]) takes over from there.
//!
//! # The cycle
//!
//! With `A = A_ff` on the fine lattice, `A_c` the coarse model's `A_ff` on the coarse free
//! DOFs, `P` the interpolation and `R = P^T`, one application `x = M^{-1} b` is
//!
//! ```text
//! x = S(0, b)                 Chebyshev smoothing in D_b^{-1} A on [2/30, 2] (below)
//! x = x + P B_c R (b - A x)   B_c: one SA-AMG V-cycle for A_c
//! x = S(x, b)
//! ```
//!
//! # The smoother: block Jacobi with a bound instead of an estimate
//!
//! `D_b` is the block diagonal of `A` (the free components of each node). A model that offers
//! a coarse lattice is bond-based: `u^T A u = sum_bonds (u_i - u_j)^T K_ij (u_i - u_j)` with
//! positive semi-definite `K_ij` (`c e e^T`, `c >= 0`), and `(a - b)^T K (a - b) <= 2 (a^T K
//! a + b^T K b)`, so
//!
//! ```text
//! u^T A u <= 2 u^T D_b u,    rho(D_b^{-1} A) <= 2,
//! ```
//!
//! also for `A_ff` (held neighbours only drop terms). The Chebyshev interval's upper end is
//! then this bound, not a Lanczos estimate (a lower bound, 15 products, 0.42 s of a 0.85 s
//! setup at 70^3; with 6 steps the 70^3 cantilever took 68 iterations instead of 21, the
//! estimate being too low). The smoother's error propagator is then self-adjoint in the `A`
//! inner product with norm below 1 whatever the lattice, `B_c` is symmetric positive
//! definite, and so is `M^{-1}`, as CG requires: the coarse correction need not be Galerkin
//! (`A_c != R A P`) for that. In the interior of a lattice `D_b` is a multiple of the
//! identity (cubic symmetry), the scalar Jacobi of the SA levels; at faces, edges and corners
//! it couples the components the missing bonds leave coupled.
//!
//! # Why re-discretize rather than `R A P`
//!
//! The Galerkin product of a `delta = 3h` stencil (123 sites) with trilinear `P` couples a
//! coarse site with 117 others (up to 3 coarse spacings apart), and computing it means forming
//! `A P`, 33-56 blocks a fine row: about the flops of SA's Galerkin product, which is what the
//! setup should lose. The PD operator on the coarse lattice
//! with the same horizon (`delta = 1.5 (2h)`, 18 partners) is a stencil, applied without
//! storage, and is the same continuum operator at the wavelengths the coarse level has to
//! correct: smooth errors see the same elastic moduli (the micromodulus is normalized on each
//! lattice). Where the two differ (the surface skin, the clamp one fine spacing off) the
//! smoother and CG absorb it: on the `linpd bench` cantilevers CG takes 16-19 iterations from
//! 20^3 to 150^3 against SA-AMG's 14-19, with a setup of one pass over the diagonal blocks
//! and an SA hierarchy of an 8x smaller stencil (docs/solvers.md).
//!
//! # Interpolation
//!
//! Along each axis a fine site `s` takes the coarse site `s / 2` with weight 1 when `s` is
//! even, the coarse sites `(s - 1) / 2` and `(s + 1) / 2` with weight 1/2 each when odd; the
//! weights of a 3D site are the products (1, 1/2, 1/4 or 1/8, exact in `f32`). This
//! reproduces every affine displacement field, the rigid motions among them. Component `q` of
//! a coarse site is a coarse unknown when some free fine DOF of component `q` interpolates
//! from it; the others are held at zero, like the fine constrained DOFs they cover.
//!
//! # Supports the coarse lattice does not see
//!
//! A coarse unknown stays free while one of its fine DOFs is free, so a support narrower than
//! two spacings (a held node, a roller line) does not reach the coarse model, which can then
//! move rigidly: on a block held by rollers and two point supports the coarse matrix was
//! singular. The coarse model therefore carries springs where the fine one is held: each held
//! fine DOF `(n, q)` adds `a_nn w_c` to the diagonal of every free coarse DOF `(c, q)` it
//! interpolates from with weight `w_c`, `a_nn` its fine diagonal entry (the lumped form of
//! the Galerkin penalty `a_nn p p^T` that a stiff spring at the held DOF gives). On a clamped
//! face the springs sit on the coarse sites beside the face and move the coarse clamp onto the
//! fine one.

use super::smoother::{self, AmgSmoother, Product, Scaling, Smoother};
use super::{split_at_bounds, Amg, AmgError, AmgParams};
use crate::bc::ReducedOperator;
use crate::krylov::preconditioner::Preconditioner;
use linpd_core::{box_node, box_site, CoarseLattice, DofMap, LinearOperator, Model};
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Instant;

/// The coarse lattice of a model: the coarse model, its free DOFs and the interpolation from
/// them to the fine free DOFs (see the module docs).
pub struct CoarseSpace<'m> {
    /// The fine model.
    fine: &'m dyn Model,
    model: Held<'m>,
    dofs: DofMap,
    /// `P`: a row per fine free DOF.
    p: Csr,
    /// `R = P^T`: a row per coarse free DOF.
    r: Csr,
    /// Seconds to build it.
    seconds: f64,
}

/// A compressed sparse row matrix of interpolation weights.
struct Csr {
    ptr: Vec<usize>,
    idx: Vec<u32>,
    val: Vec<f32>,
}

impl Csr {
    /// Row `i`'s entries from `row(i, push)`, in parallel.
    fn build(n: usize, max_row: usize, row: impl Fn(usize, &mut dyn FnMut(u32, f32)) + Sync) -> Csr {
        let counts: Vec<usize> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut c = 0;
                row(i, &mut |_, _| c += 1);
                c
            })
            .collect();
        let mut ptr = Vec::with_capacity(n + 1);
        ptr.push(0);
        for c in counts {
            ptr.push(ptr.last().unwrap() + c);
        }
        debug_assert!(ptr.windows(2).all(|w| w[1] - w[0] <= max_row));
        let mut idx = vec![0u32; ptr[n]];
        let mut val = vec![0f32; ptr[n]];
        let rows_i = split_at_bounds(&mut idx, ptr.iter().copied());
        let rows_v = split_at_bounds(&mut val, ptr.iter().copied());
        rows_i.into_par_iter().zip(rows_v).enumerate().for_each(|(i, (ri, rv))| {
            let mut k = 0;
            row(i, &mut |j, w| {
                ri[k] = j;
                rv[k] = w;
                k += 1;
            });
        });
        Csr { ptr, idx, val }
    }

    /// `y = A x` (`add`: `y += A x`).
    fn matvec(&self, x: &[f64], y: &mut [f64], add: bool) {
        y.par_iter_mut().with_min_len(1024).enumerate().for_each(|(i, y)| {
            let s: f64 = (self.ptr[i]..self.ptr[i + 1]).map(|e| self.val[e] as f64 * x[self.idx[e] as usize]).sum();
            *y = if add { *y + s } else { s };
        });
    }

    fn bytes(&self) -> usize {
        8 * self.ptr.len() + 8 * self.idx.len()
    }
}

/// Per axis, the coarse sites of fine site `s` and their weights (module docs).
fn axis_weights(s: usize) -> ([usize; 2], [f32; 2], usize) {
    if s.is_multiple_of(2) {
        ([s / 2, 0], [1.0, 0.0], 1)
    } else {
        ([s / 2, s.div_ceil(2)], [0.5, 0.5], 2)
    }
}

/// Calls `f(coarse site, weight)` for the (up to 8) coarse sites of fine site `s`.
fn for_each_coarse(s: [usize; 3], f: &mut dyn FnMut([usize; 3], f32)) {
    let w = s.map(axis_weights);
    for a in 0..w[0].2 {
        for b in 0..w[1].2 {
            for c in 0..w[2].2 {
                f([w[0].0[a], w[1].0[b], w[2].0[c]], w[0].1[a] * w[1].1[b] * w[2].1[c]);
            }
        }
    }
}

/// Calls `f(fine site, weight)` for the (up to 27) fine sites that coarse site `c` reaches.
fn for_each_fine(c: [usize; 3], counts: [usize; 3], f: &mut dyn FnMut([usize; 3], f32)) {
    let range = |a: usize| {
        let centre = 2 * c[a];
        let lo = centre.saturating_sub(1);
        let hi = (centre + 1).min(counts[a] - 1);
        (lo..=hi).map(move |s| (s, if s == centre { 1.0f32 } else { 0.5 }))
    };
    for (k, wk) in range(2) {
        for (j, wj) in range(1) {
            for (i, wi) in range(0) {
                f([i, j, k], wi * wj * wk);
            }
        }
    }
}

impl<'m> CoarseSpace<'m> {
    /// The coarse space of `model` for the free DOFs `dofs`, when the model offers a coarse
    /// lattice ([`Model::coarse_lattice`]) and it keeps some free DOF; `diag` is the model's
    /// diagonal over all DOFs ([`Model::diagonal`]: the springs read its held entries).
    pub fn new(model: &'m dyn Model, dofs: &DofMap, diag: &[f64]) -> Option<Self> {
        let t = Instant::now();
        let CoarseLattice { model: coarse, counts } = model.coarse_lattice()?;
        let d = model.dim();
        let nc = CoarseLattice::coarse_counts(counts);
        if box_node([0, 0, counts[2]], counts) != model.n_nodes()
            || box_node([0, 0, nc[2]], nc) != coarse.n_nodes()
            || coarse.dim() != d
            || dofs.n_dofs() > u32::MAX as usize
            || diag.len() != dofs.n_dofs()
        {
            return None;
        }
        let fine_free = |n: usize, q: usize| dofs.free(d * n + q);
        // A coarse component is free when a free fine DOF of that component interpolates from it.
        let mask: Vec<bool> = (0..coarse.n_nodes() * d)
            .into_par_iter()
            .map(|dof| {
                let (c, q) = (dof / d, dof % d);
                let mut free = false;
                for_each_fine(box_site(c, nc), counts, &mut |s, _| {
                    free |= fine_free(box_node(s, counts), q).is_some();
                });
                !free
            })
            .collect();
        let cdofs = DofMap::new(d, &mask);
        if cdofs.n_free() == 0 {
            return None;
        }
        let springs: Vec<f64> = (0..coarse.n_nodes() * d)
            .into_par_iter()
            .map(|dof| {
                let (c, q) = (dof / d, dof % d);
                let mut k = 0.0;
                if !mask[dof] {
                    for_each_fine(box_site(c, nc), counts, &mut |s, w| {
                        let fine = d * box_node(s, counts) + q;
                        if dofs.is_constrained(fine) {
                            k += diag[fine] * w as f64;
                        }
                    });
                }
                k
            })
            .collect();
        let fine_rows = dofs.free_dofs();
        let coarse_rows = cdofs.free_dofs();
        let p = Csr::build(fine_rows.len(), 8, |i, push| {
            let (n, q) = (fine_rows[i] / d, fine_rows[i] % d);
            for_each_coarse(box_site(n, counts), &mut |c, w| {
                if let Some(j) = cdofs.free(d * box_node(c, nc) + q) {
                    push(j as u32, w);
                }
            });
        });
        let r = Csr::build(coarse_rows.len(), 27, |j, push| {
            let (c, q) = (coarse_rows[j] / d, coarse_rows[j] % d);
            for_each_fine(box_site(c, nc), counts, &mut |s, w| {
                if let Some(i) = fine_free(box_node(s, counts), q) {
                    push(i as u32, w);
                }
            });
        });
        Some(CoarseSpace {
            fine: model,
            model: Held { inner: coarse, springs },
            dofs: cdofs,
            p,
            r,
            seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// The coarse model, with the springs of the fine supports (module docs).
    pub fn model(&self) -> &dyn Model {
        &self.model
    }

    /// The coarse free DOFs.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// `x += P x_c`: the coarse free values `x_c` interpolated to the fine free DOFs.
    pub fn interpolate_add(&self, xc: &[f64], x: &mut [f64]) {
        assert_eq!((xc.len(), x.len()), (self.dofs.n_free(), self.p.ptr.len() - 1), "vector sizes");
        self.p.matvec(xc, x, true);
    }

    /// `y_c = R y = P^T y`: fine free values restricted to the coarse free DOFs.
    pub fn restrict(&self, y: &[f64], yc: &mut [f64]) {
        assert_eq!((y.len(), yc.len()), (self.p.ptr.len() - 1, self.dofs.n_free()), "vector sizes");
        self.r.matvec(y, yc, false);
    }
}

/// The coarse model plus diagonal springs (module docs, "Supports the coarse lattice does not
/// see").
struct Held<'m> {
    inner: Box<dyn Model + 'm>,
    /// Spring stiffness per coarse DOF (0 on most).
    springs: Vec<f64>,
}

/// `y = A x + K x` of the inner operator `A` and the springs `K`.
struct WithSprings<'s> {
    inner: Box<dyn LinearOperator + 's>,
    springs: &'s [f64],
}

impl LinearOperator for WithSprings<'_> {
    fn n(&self) -> usize {
        self.inner.n()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.inner.apply(x, y);
        y.par_iter_mut().with_min_len(4096).zip(x).zip(self.springs).for_each(|((y, x), k)| *y += k * x);
    }
}

impl Model for Held<'_> {
    fn kind(&self) -> &'static str {
        self.inner.kind()
    }
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn n_nodes(&self) -> usize {
        self.inner.n_nodes()
    }
    fn position(&self, i: usize) -> linpd_core::Point {
        self.inner.position(i)
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.inner.for_each_partner(i, f)
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        WithSprings { inner: Box::new(linpd_core::ModelOperator(&*self.inner)), springs: &self.springs }.apply(u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        self.inner.diagonal().iter().zip(&self.springs).map(|(a, k)| a + k).collect()
    }
    fn assemble_free(&self, dofs: &DofMap) -> linpd_core::sparse::Csc {
        let a = self.inner.assemble_free(dofs);
        let (n, mut triplets) = (a.nrows(), Vec::new());
        let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
        for j in 0..n {
            for e in cp[j]..cp[j + 1] {
                triplets.push(faer::sparse::Triplet::new(ri[e], j, v[e]));
            }
        }
        for (dof, &k) in self.springs.iter().enumerate() {
            if let Some(i) = dofs.free(dof).filter(|_| k != 0.0) {
                triplets.push(faer::sparse::Triplet::new(i, i, k));
            }
        }
        linpd_core::sparse::Csc::try_new_from_triplets(n, n, &triplets).expect("the inner matrix's pattern")
    }
    fn fast_apply(&self) -> Option<linpd_core::FastApply<'_>> {
        let inner = self.inner.fast_apply()?;
        Some(linpd_core::FastApply {
            op: Box::new(WithSprings { inner: inner.op, springs: &self.springs }),
            label: inner.label,
        })
    }
    fn diagonal_block(&self, i: usize, out: &mut [f64]) -> bool {
        let d = self.inner.dim();
        let has = self.inner.diagonal_block(i, out);
        (0..d).for_each(|q| out[q * d + q] += self.springs[d * i + q]);
        has
    }
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        let d = self.inner.dim();
        self.inner.for_each_block(i, &mut |j, block| {
            if j == i {
                let mut b = [0.0; 9];
                b[..d * d].copy_from_slice(&block[..d * d]);
                (0..d).for_each(|q| b[q * d + q] += self.springs[d * i + q]);
                f(j, &b[..d * d]);
            } else {
                f(j, block);
            }
        })
    }
}

/// The inverses of the diagonal blocks of `A_ff` (the free components of each node, rows
/// consecutive in the node-major free numbering), by Cholesky: a block that is not positive
/// definite is an error naming its first row.
fn block_scaling(model: &dyn Model, dofs: &DofMap) -> Result<Scaling, AmgError> {
    let d = model.dim();
    let per_node: Vec<Option<(usize, [f64; 9])>> = (0..model.n_nodes())
        .into_par_iter()
        .map(|i| {
            let free: Vec<usize> = (0..d).filter(|&c| !dofs.is_constrained(d * i + c)).collect();
            if free.is_empty() {
                return None;
            }
            let mut full = [0.0; 9];
            model.diagonal_block(i, &mut full);
            let k = free.len();
            let mut m = [0.0; 9];
            for (a, &p) in free.iter().enumerate() {
                for (c, &q) in free.iter().enumerate() {
                    m[k * a + c] = full[d * p + q];
                }
            }
            Some((k, m))
        })
        .collect();
    let (mut rows, mut at, mut inv) = (vec![0usize], Vec::new(), Vec::new());
    for (k, m) in per_node.into_iter().flatten() {
        let row = *rows.last().expect("starts with 0");
        let Some(mi) = spd_inverse(k, &m) else {
            let value = (0..k).map(|a| m[k * a + a]).fold(f64::INFINITY, f64::min);
            return Err(AmgError::NonPositiveDiagonal { level: 0, row, value });
        };
        at.push(inv.len());
        inv.extend_from_slice(&mi[..k * k]);
        rows.push(row + k);
    }
    if *rows.last().expect("starts with 0") != dofs.n_free() {
        return Err(AmgError::Input(format!(
            "the model's blocks cover {} of the {} free DOFs",
            rows.last().unwrap_or(&0),
            dofs.n_free()
        )));
    }
    let n_blocks = at.len();
    let groups: Vec<usize> = (0..n_blocks).step_by(4096).chain(std::iter::once(n_blocks)).collect();
    Ok(Scaling::Block { rows, at, inv, groups })
}

/// The inverse of the symmetric positive definite `k x k` matrix `m` (row-major, `k <= 3`) by
/// Cholesky, `None` when a pivot is not positive.
fn spd_inverse(k: usize, m: &[f64; 9]) -> Option<[f64; 9]> {
    let mut l = [0.0; 9];
    for i in 0..k {
        for j in 0..=i {
            let s = m[k * i + j] - (0..j).map(|p| l[k * i + p] * l[k * j + p]).sum::<f64>();
            if i == j {
                if !(s > 0.0) {
                    return None;
                }
                l[k * i + i] = s.sqrt();
            } else {
                l[k * i + j] = s / l[k * j + j];
            }
        }
    }
    // columns of the inverse: solve L L^T x = e_c
    let mut inv = [0.0; 9];
    for c in 0..k {
        let mut y = [0.0; 3];
        for i in 0..k {
            let e = if i == c { 1.0 } else { 0.0 };
            y[i] = (e - (0..i).map(|p| l[k * i + p] * y[p]).sum::<f64>()) / l[k * i + i];
        }
        for i in (0..k).rev() {
            let x = (y[i] - (i + 1..k).map(|p| l[k * p + i] * inv[k * p + c]).sum::<f64>()) / l[k * i + i];
            inv[k * i + c] = x;
        }
    }
    Some(inv)
}

/// `A_ff` through the model's apply, with the `y -= A x` the smoother needs.
struct Fine<'a> {
    op: ReducedOperator<'a>,
    scratch: Mutex<Vec<f64>>,
}

impl Product for Fine<'_> {
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        self.op.apply(x, y);
    }
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]) {
        let mut t = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        t.resize(y.len(), 0.0);
        self.op.apply(x, &mut t);
        smoother::add(y, &t, -1.0);
    }
}

/// Multigrid-CG's preconditioner on a lattice model with a coarse lattice: the geometric
/// top level over SA-AMG (see the module docs).
pub struct LatticeMultigrid<'a> {
    fine: Fine<'a>,
    smoother: Smoother,
    space: &'a CoarseSpace<'a>,
    coarse: Amg<'a>,
    /// `[r, d, b_c, x_c]` of the cycle, kept between applications.
    work: Mutex<[Vec<f64>; 4]>,
    /// DOFs of the fine model (free and held).
    fine_dofs: usize,
    /// Seconds of the diagonal blocks' inverses and of the SA hierarchy.
    times: [f64; 2],
}

impl std::fmt::Debug for LatticeMultigrid<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "LatticeMultigrid({:?})", self.summary())
    }
}

impl<'a> LatticeMultigrid<'a> {
    /// The preconditioner for `A_ff` of the model applied by `full` (over all DOFs) on `dofs`;
    /// `space` is the model's [`CoarseSpace`] (whose fine model gives the diagonal blocks) and
    /// `coarse_full` the coarse model's apply over all its DOFs (its stencil).
    pub fn new(
        full: &'a dyn LinearOperator,
        dofs: &'a DofMap,
        space: &'a CoarseSpace<'a>,
        coarse_full: &'a dyn LinearOperator,
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        let t = Instant::now();
        params.validate()?;
        let n = dofs.n_free();
        if space.p.ptr.len() != n + 1 || full.n() != dofs.n_dofs() {
            return Err(AmgError::Input(format!(
                "the interpolation's rows ({}) or the operator ({}) do not match the {n} free of {} DOFs",
                space.p.ptr.len() - 1,
                full.n(),
                dofs.n_dofs()
            )));
        }
        if coarse_full.n() != space.dofs.n_dofs() {
            return Err(AmgError::Input(format!(
                "the coarse operator has {} DOFs, the coarse model {}",
                coarse_full.n(),
                space.dofs.n_dofs()
            )));
        }
        let fine = Fine { op: ReducedOperator::new(full, dofs), scratch: Mutex::new(Vec::new()) };
        let scaling = block_scaling(space.fine, dofs)?;
        // rho(D_b^{-1} A) <= 2 (module docs): the interval's upper end is the bound itself
        let rho = match params.smoother {
            AmgSmoother::Chebyshev { upper, .. } => 2.0 / upper,
            AmgSmoother::Jacobi { .. } => 2.0,
        };
        let t_blocks = t.elapsed().as_secs_f64();
        let coarse = Amg::matrix_free(space.model(), space.dofs(), coarse_full, params)?;
        Ok(LatticeMultigrid {
            fine,
            smoother: Smoother::with_scaling(params.smoother, scaling, rho),
            space,
            coarse,
            work: Mutex::new(Default::default()),
            fine_dofs: dofs.n_dofs(),
            times: [t_blocks, t.elapsed().as_secs_f64() - t_blocks],
        })
    }

    /// Bytes the preconditioner holds besides the model: `P`, `R`, the smoother's inverse
    /// diagonal blocks, the fine level's work vectors (the reduced operator's two over all DOFs,
    /// three over the free ones) and the coarse hierarchy with its two vectors.
    pub fn memory_bytes(&self) -> usize {
        let (n, nc) = (self.space.p.ptr.len() - 1, self.space.dofs.n_free());
        self.space.p.bytes()
            + self.space.r.bytes()
            + self.smoother.scaling_bytes()
            + 8 * (2 * self.fine_dofs + 3 * n + 2 * nc)
            + self.coarse.stats().memory_bytes
    }

    /// The SA-AMG hierarchy below the geometric level.
    pub fn coarse(&self) -> &Amg<'a> {
        &self.coarse
    }
}

impl Preconditioner for LatticeMultigrid<'_> {
    fn apply(&self, b: &[f64], x: &mut [f64]) {
        let nc = self.space.dofs.n_free();
        let mut fresh: [Vec<f64>; 4] = Default::default();
        let mut kept = self.work.try_lock().ok();
        let [r, d, bc, xc] = kept.as_deref_mut().unwrap_or(&mut fresh);
        r.resize(b.len(), 0.0);
        d.resize(b.len(), 0.0);
        bc.resize(nc, 0.0);
        xc.resize(nc, 0.0);
        self.smoother.smooth(&self.fine, b, x, r, d, true, true);
        self.space.restrict(r, bc);
        xc.iter_mut().for_each(|v| *v = 0.0);
        self.coarse.apply(bc, xc);
        self.space.interpolate_add(xc, x);
        self.smoother.smooth(&self.fine, b, x, r, d, false, false);
    }
    fn summary(&self) -> Option<String> {
        let rows: Vec<String> = self.coarse.stats().levels.iter().map(|l| l.rows.to_string()).collect();
        Some(format!(
            "geometric multigrid: {} rows > lattice 2h re-discretized > SA-AMG, {} levels ({} rows), \
             block Jacobi-Chebyshev on [2/30, 2], finest level matrix-free, {:.1} MiB, setup {:.2} s \
             (interpolation {:.2}, diagonal blocks {:.2}, SA levels {:.2})",
            self.space.p.ptr.len() - 1,
            rows.len(),
            rows.join(" > "),
            self.memory_bytes() as f64 / 1048576.0,
            self.space.seconds + self.times[0] + self.times[1],
            self.space.seconds,
            self.times[0],
            self.times[1]
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `spd_inverse` inverts 1x1, 2x2 and 3x3 SPD blocks to round-off and refuses indefinite
    /// ones.
    #[test]
    fn small_spd_inverses() {
        let cases: [(usize, [f64; 9]); 3] = [
            (1, [4.0, 0., 0., 0., 0., 0., 0., 0., 0.]),
            (2, [2.0, 0.5, 0.5, 1.0, 0., 0., 0., 0., 0.]),
            (3, [4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0]),
        ];
        for (k, m) in cases {
            let inv = spd_inverse(k, &m).unwrap();
            for i in 0..k {
                for j in 0..k {
                    let p: f64 = (0..k).map(|q| m[k * i + q] * inv[k * q + j]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((p - want).abs() <= 1e-14, "{k}x{k}: (M M^-1)_{i}{j} = {p}");
                }
            }
        }
        assert!(spd_inverse(2, &[1.0, 2.0, 2.0, 1.0, 0., 0., 0., 0., 0.]).is_none());
        assert!(spd_inverse(1, &[0.0; 9]).is_none());
    }

    /// The coarse model with springs is one operator four ways: its apply, fast apply, blocks,
    /// diagonal and assembled `A_ff` agree to round-off (`1e-12` relative to the largest
    /// entry: sums of ~20 terms).
    #[test]
    fn springs_are_one_operator_every_way() {
        let mm = linpd_core::Micromodulus {
            kernel: linpd_core::Kernel::InverseDistance,
            normalization: linpd_core::Normalization::Discrete,
            modulus: 1.0,
            plane: None,
            partial_volume: false,
        };
        let grid = linpd_core::Grid::new(&[0.0; 3], &[8.0; 3], 1.0, 0.0, linpd_core::Placement::Vertex).unwrap();
        let fine = linpd_bond::LatticeBondModel::stencil(grid, 3.0, mm).unwrap();
        let mask: Vec<bool> = (0..3 * fine.n_nodes()).map(|dof| dof / 3 % 9 == 0 || dof == 3 * 40 + 2).collect();
        let dofs = DofMap::new(3, &mask);
        let space = CoarseSpace::new(&fine, &dofs, &fine.diagonal()).unwrap();
        let held = &space.model;
        assert!(held.springs.iter().any(|&k| k > 0.0));
        let n = 3 * held.n_nodes();
        let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
        let (mut y_model, mut y_fast, mut y_blocks) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        held.apply(&x, &mut y_model);
        held.fast_apply().unwrap().op.apply(&x, &mut y_fast);
        let mut diag = vec![0.0; n];
        for i in 0..held.n_nodes() {
            assert!(held.for_each_block(i, &mut |j, b| {
                for a in 0..3 {
                    for c in 0..3 {
                        y_blocks[3 * i + a] += b[3 * a + c] * x[3 * j + c];
                    }
                    if j == i {
                        diag[3 * i + a] = b[3 * a + a];
                    }
                }
            }));
        }
        let scale = held.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(p, q)| (p - q).abs() <= 1e-12 * scale);
        assert!(close(&y_model, &y_fast) && close(&y_model, &y_blocks));
        assert!(close(&diag, &held.diagonal()));
        let cd = space.dofs();
        let a = held.assemble_free(cd);
        let xf = cd.gather(&x);
        let mut yf = vec![0.0; cd.n_free()];
        linpd_core::sparse::matvec(&a, &xf, &mut yf);
        let mut x_zero = vec![0.0; n];
        cd.scatter(&xf, &mut x_zero);
        let mut y_full = vec![0.0; n];
        held.apply(&x_zero, &mut y_full);
        assert!(close(&yf, &cd.gather(&y_full)));
    }
}
