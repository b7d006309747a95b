//! Smoothers (Jacobi-scaled Chebyshev, damped Jacobi) and the spectral radius estimate
//! `rho(D^{-1} A)` they and the prolongator smoothing need.

use super::level::LevelMatrix;
use rayon::prelude::*;

/// What the smoothers and the spectral estimate need of a level's matrix: its products.
pub(crate) trait Product: Sync {
    /// `y = A x`.
    fn matvec(&self, x: &[f64], y: &mut [f64]);
    /// `y -= A x`.
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]);
}

impl<T: LevelMatrix + ?Sized> Product for T {
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        LevelMatrix::matvec(self, x, y)
    }
    fn matvec_sub(&self, x: &[f64], y: &mut [f64]) {
        LevelMatrix::matvec_sub(self, x, y)
    }
}

/// Vector kernels below this length run sequentially (a rayon task costs more).
const PAR_MIN: usize = 4096;

/// The largest eigenvalue of `D^{-1} A` (= that of the symmetric `D^{-1/2} A D^{-1/2}`) by
/// `steps` Lanczos steps from a fixed pseudo-random start: the largest Ritz value, a lower
/// bound that converges fastest at the spectrum's ends (Saad, *Numerical Methods for Large
/// Eigenvalue Problems*, ch. 6). No reorthogonalization: lost orthogonality only duplicates
/// converged Ritz values, it does not move the largest one.
pub(crate) fn spectral_radius<A: Product + ?Sized>(a: &A, dinv: &[f64], steps: usize) -> f64 {
    let n = dinv.len();
    let steps = steps.min(n).max(1);
    let sq: Vec<f64> = dinv.iter().map(|d| d.sqrt()).collect();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut v: Vec<f64> = (0..n)
        .map(|_| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let nv = norm(&v);
    v.iter_mut().for_each(|x| *x /= nv);
    let mut v_prev = vec![0.0; n];
    let (mut alpha, mut beta) = (Vec::new(), Vec::new());
    let mut t = vec![0.0; n];
    let mut w = vec![0.0; n];
    for _ in 0..steps {
        t.iter_mut().zip(&v).zip(&sq).for_each(|((t, v), s)| *t = v * s);
        a.matvec(&t, &mut w);
        let b_prev = beta.last().copied().unwrap_or(0.0);
        w.iter_mut().zip(&sq).zip(&v_prev).for_each(|((w, s), vp)| *w = *w * s - b_prev * vp);
        let al = dot(&w, &v);
        w.iter_mut().zip(&v).for_each(|(w, v)| *w -= al * v);
        alpha.push(al);
        let b = norm(&w);
        if !(b > 1e-12 * al.abs()) {
            break;
        }
        beta.push(b);
        std::mem::swap(&mut v_prev, &mut v);
        v.iter_mut().zip(&w).for_each(|(v, w)| *v = w / b);
    }
    let m = alpha.len();
    let tri = faer::Mat::<f64>::from_fn(m, m, |i, j| {
        if i == j {
            alpha[i]
        } else if i == j + 1 {
            beta[j]
        } else if j == i + 1 {
            beta[i]
        } else {
            0.0
        }
    });
    match tri.self_adjoint_eigenvalues(faer::Side::Lower) {
        Ok(ev) => ev.last().copied().unwrap_or(f64::NAN),
        Err(_) => f64::NAN,
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() < PAR_MIN {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    } else {
        a.par_iter().zip(b).with_min_len(PAR_MIN).map(|(x, y)| x * y).sum()
    }
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// Which smoother the V-cycle runs on each level before and after the coarse correction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum AmgSmoother {
    /// (Default: degree 1, `[rho/30, 1.1 rho]`.) The Chebyshev polynomial of `degree` in
    /// `D^{-1} A` that is smallest on
    /// `[lower rho, upper rho]`, `rho` the Lanczos estimate of `rho(D^{-1} A)` (Adams, Brezina,
    /// Hu & Tuminaro 2003; MueLu/Ifpack2 defaults: eigenvalue ratio 30, boost 1.1).
    Chebyshev {
        /// Polynomial degree = matrix-vector products per application.
        degree: usize,
        /// Lower end of the interval as a fraction of `rho`.
        lower: f64,
        /// Upper end as a multiple of `rho` (above 1: the estimate is a lower bound).
        upper: f64,
    },
    /// `sweeps` steps of `x += (omega / rho) D^{-1} (b - A x)`.
    Jacobi {
        /// Damping relative to `1 / rho`; `4/3` minimizes the amplification of the upper half
        /// of the spectrum.
        omega: f64,
        /// Sweeps per application.
        sweeps: usize,
    },
}

impl Default for AmgSmoother {
    fn default() -> Self {
        AmgSmoother::Chebyshev { degree: 1, lower: 1.0 / 30.0, upper: 1.1 }
    }
}

/// The `D^{-1}` a smoother scales residuals with.
#[derive(Debug)]
pub(crate) enum Scaling {
    /// The inverse of the scalar diagonal, per row.
    Point(Vec<f64>),
    /// The inverses of diagonal blocks of consecutive rows (block `b` covers rows
    /// `rows[b]..rows[b + 1]` and its `k x k` inverse, row-major, starts at `inv[at[b]]`),
    /// processed in parallel by `groups` (block bounds).
    Block {
        /// Row bounds of the blocks.
        rows: Vec<usize>,
        /// Offset of each block's inverse in `inv`.
        at: Vec<usize>,
        /// The inverses, packed.
        inv: Vec<f64>,
        /// Block bounds of the parallel groups.
        groups: Vec<usize>,
    },
}

impl Scaling {
    /// `d_i = f(d_i, (D^{-1} r)_i)` for every row `i`.
    fn apply(&self, d: &mut [f64], r: &[f64], f: impl Fn(f64, f64) -> f64 + Sync) {
        match self {
            Scaling::Point(m) => zip3(d, r, m, |d, r, m| *d = f(*d, m * r)),
            Scaling::Block { rows, at, inv, groups } => {
                let bounds = groups.iter().map(|&g| rows[g]);
                let parts = super::split_at_bounds(d, bounds);
                parts.into_par_iter().zip(groups.par_windows(2)).for_each(|(dg, g)| {
                    let base = rows[g[0]];
                    for b in g[0]..g[1] {
                        let (lo, hi) = (rows[b], rows[b + 1]);
                        let k = hi - lo;
                        let m = &inv[at[b]..at[b] + k * k];
                        let mut t = [0.0; 3];
                        for i in 0..k {
                            t[i] = (0..k).map(|j| m[k * i + j] * r[lo + j]).sum();
                        }
                        for i in 0..k {
                            let di = &mut dg[lo - base + i];
                            *di = f(*di, t[i]);
                        }
                    }
                });
            }
        }
    }
}

/// A smoother set up on one level.
#[derive(Debug)]
pub(crate) struct Smoother {
    kind: AmgSmoother,
    dinv: Scaling,
    rho: f64,
}

impl Smoother {
    /// The smoother `kind` in `D^{-1} A` (`dinv`: the inverse scalar diagonal) with `rho`
    /// the spectral radius of `D^{-1} A` (an estimate).
    pub fn new(kind: AmgSmoother, dinv: Vec<f64>, rho: f64) -> Self {
        Smoother { kind, dinv: Scaling::Point(dinv), rho }
    }

    /// Bytes of the scaling (`D^{-1}` or the inverse blocks with their offsets).
    pub fn scaling_bytes(&self) -> usize {
        match &self.dinv {
            Scaling::Point(m) => 8 * m.len(),
            Scaling::Block { rows, at, inv, groups } => 8 * (rows.len() + at.len() + inv.len() + groups.len()),
        }
    }

    /// The smoother `kind` in `D_b^{-1} A` for a block scaling, with `rho` a bound of the
    /// spectral radius of `D_b^{-1} A`.
    pub fn with_scaling(kind: AmgSmoother, dinv: Scaling, rho: f64) -> Self {
        Smoother { kind, dinv, rho }
    }

    /// Smooths `A x = b`. With `zero_guess` `x` is taken as 0 (and overwritten) and the
    /// initial residual `b` costs no product. On return `r = b - A x` when `want_residual`
    /// (else `r` is scratch). `d` is scratch. The error propagator is a fixed polynomial in
    /// `D^{-1} A` times the error, self-adjoint in the `A` inner product, so running the same
    /// smoother before and after the coarse correction keeps the V-cycle symmetric.
    #[allow(clippy::too_many_arguments)]
    pub fn smooth<A: Product + ?Sized>(
        &self,
        a: &A,
        b: &[f64],
        x: &mut [f64],
        r: &mut [f64],
        d: &mut [f64],
        zero_guess: bool,
        want_residual: bool,
    ) {
        if zero_guess {
            r.copy_from_slice(b);
            x.iter_mut().for_each(|v| *v = 0.0);
        } else {
            r.copy_from_slice(b);
            a.matvec_sub(x, r);
        }
        let dinv = &self.dinv;
        match self.kind {
            AmgSmoother::Jacobi { omega, sweeps } => {
                let w = omega / self.rho;
                for s in 0..sweeps {
                    dinv.apply(d, r, |_, s| w * s);
                    add(x, d, 1.0);
                    if s + 1 < sweeps || want_residual {
                        a.matvec_sub(d, r);
                    }
                }
            }
            AmgSmoother::Chebyshev { degree, lower, upper } => {
                // Chebyshev acceleration (Saad, Iterative Methods for Sparse Linear Systems,
                // 2nd ed., Algorithm 12.1) of Jacobi on [lmin, lmax].
                let (lmin, lmax) = (lower * self.rho, upper * self.rho);
                let theta = 0.5 * (lmax + lmin);
                let delta = 0.5 * (lmax - lmin);
                let sigma = theta / delta;
                let mut rho_k = 1.0 / sigma;
                dinv.apply(d, r, |_, s| s / theta);
                add(x, d, 1.0);
                for _ in 1..degree.max(1) {
                    a.matvec_sub(d, r);
                    let rho_next = 1.0 / (2.0 * sigma - rho_k);
                    let (c1, c2) = (rho_next * rho_k, 2.0 * rho_next / delta);
                    dinv.apply(d, r, |d, s| c1 * d + c2 * s);
                    add(x, d, 1.0);
                    rho_k = rho_next;
                }
                if want_residual {
                    a.matvec_sub(d, r);
                }
            }
        }
    }
}

fn zip3(d: &mut [f64], r: &[f64], m: &[f64], f: impl Fn(&mut f64, f64, f64) + Sync) {
    if d.len() < PAR_MIN {
        d.iter_mut().zip(r).zip(m).for_each(|((d, r), m)| f(d, *r, *m));
    } else {
        d.par_iter_mut().zip(r).zip(m).with_min_len(PAR_MIN).for_each(|((d, r), m)| f(d, *r, *m));
    }
}

/// `x += s d`.
pub(crate) fn add(x: &mut [f64], d: &[f64], s: f64) {
    if x.len() < PAR_MIN {
        x.iter_mut().zip(d).for_each(|(x, d)| *x += s * d);
    } else {
        x.par_iter_mut().zip(d).with_min_len(PAR_MIN).for_each(|(x, d)| *x += s * d);
    }
}
