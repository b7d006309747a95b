//! Loads, Dirichlet conditions and the solvers of the 1D models.
//!
//! The blended matrix is not symmetric, but its skew part sits only in the local terms of the
//! transition rows and is small: for a linear `beta` the local part `D1 u' + D2 u''` is in
//! divergence form in the continuum (`D1 = dD2/dx`). The default solver therefore factors the
//! symmetric part `S = (A + A^T)/2`, which keeps the band (`D2 >= 0` makes it SPD), by sparse
//! Cholesky in the natural (band) order and solves `A u = f` by GMRES preconditioned with
//! `S^{-1}`: a handful of iterations, so the cost is one Cholesky of the band, like pure PD.
//! If `S` is not positive definite or GMRES stalls, it falls back to sparse LU with partial
//! pivoting ([`linpd_solve::Lu`] with [`LuOrdering::Band`]).

use crate::model::{BlendOperator, BlendParams, ModelKind};
use crate::BlendError;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use linpd_solve::{
    gmres, peak_rss_bytes, Cholesky, CholeskyOrdering, FactorPreconditioner, GmresParams, GmresPreconditioner,
    LinearOperator, Lu, LuOrdering, SolveError, SolveReport, SolverId,
};
use std::time::Instant;

/// A load on the bar.
#[derive(Debug, Clone, PartialEq)]
pub enum Load {
    /// Force `force` on the node at `x` (the paper's `b_i = delta_ip / dx` is `force = 1`).
    Point {
        /// Location (must be a node).
        x: f64,
        /// Force.
        force: f64,
    },
    /// Body-force density on `[from, to]` (force `density * V_i` per node).
    Body {
        /// Start.
        from: f64,
        /// End.
        to: f64,
        /// Force per length.
        density: f64,
    },
}

/// Solver choice for the 1D models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BlendSolver {
    /// Symmetric models: Cholesky (band order). Blended: Cholesky of the symmetric part +
    /// GMRES, falling back to LU.
    #[default]
    Auto,
    /// Sparse LU with partial pivoting (band-preserving analysis).
    Lu,
    /// Dense LU (the paper's MATLAB-style baseline; small systems only).
    Dense,
}

/// A solved 1D model.
#[derive(Debug, Clone)]
pub struct BlendSolution {
    /// Model.
    pub kind: ModelKind,
    /// Node positions.
    pub x: Vec<f64>,
    /// Displacements.
    pub u: Vec<f64>,
    /// Blending values.
    pub beta: Vec<f64>,
    /// Transition rows.
    pub transition: Vec<bool>,
    /// Accuracy and cost.
    pub report: SolveReport,
}

impl BlendSolution {
    /// Displacement at `x` by linear interpolation between nodes.
    pub fn at(&self, x: f64) -> f64 {
        let k = self.x.partition_point(|&p| p < x).clamp(1, self.x.len() - 1);
        let (x0, x1) = (self.x[k - 1], self.x[k]);
        let t = ((x - x0) / (x1 - x0)).clamp(0.0, 1.0);
        self.u[k - 1] + t * (self.u[k] - self.u[k - 1])
    }
}

/// The exact CE solution for a point load `F` at `x_p` on `(x0, xl)` with end values (section 5.2).
/// (The eight arguments are the symbols of the closed form.)
#[allow(clippy::too_many_arguments)]
pub fn ce_exact_point_load(x: f64, x0: f64, xl: f64, u0: f64, ul: f64, xp: f64, k: f64, force: f64) -> f64 {
    let d0 = (ul - u0) / (xl - x0) + force / k * (xl - xp) / (xl - x0);
    let dl = d0 - force / k;
    if x <= xp {
        u0 + d0 * (x - x0)
    } else {
        ul - dl * (xl - x)
    }
}

/// Sparse LU keeping the band ([`LuOrdering::Band`]); the solution and the
/// `[symbolic, numeric, solve]` seconds.
fn lu_band(a: &faer::sparse::SparseColMat<usize, f64>, b: &[f64]) -> Result<(Vec<f64>, [f64; 3]), SolveError> {
    let t = Instant::now();
    let lu = Lu::analyze(a, LuOrdering::Band)?;
    let ts = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let factor = lu.factor(a)?;
    let tn = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let u = factor.solve(b);
    Ok((u, [ts, tn, t.elapsed().as_secs_f64()]))
}

/// CSR transpose (counting sort by column).
fn transpose(n: usize, rp: &[usize], col: &[usize], val: &[f64]) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let mut cnt = vec![0usize; n + 1];
    for &c in col {
        cnt[c + 1] += 1;
    }
    for i in 0..n {
        cnt[i + 1] += cnt[i];
    }
    let mut next = cnt.clone();
    let (mut tc, mut tv) = (vec![0usize; col.len()], vec![0.0; col.len()]);
    for i in 0..n {
        for p in rp[i]..rp[i + 1] {
            let q = next[col[p]];
            tc[q] = i;
            tv[q] = val[p];
            next[col[p]] += 1;
        }
    }
    (cnt, tc, tv)
}

/// A square sparse matrix in CSR, as the solvers need it.
struct Csr {
    n: usize,
    rp: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
}

impl LinearOperator for Csr {
    fn n(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            y[i] = (self.rp[i]..self.rp[i + 1]).map(|p| self.val[p] * x[self.col[p]]).sum();
        }
    }
}

impl Csr {
    /// `sqrt(||A||_1 ||A||_inf)`, an upper bound of `||A||_2`.
    fn norm_inf_estimate(&self) -> f64 {
        let mut colsum = vec![0.0; self.n];
        let mut rowmax = 0.0f64;
        for i in 0..self.n {
            let mut r = 0.0;
            for p in self.rp[i]..self.rp[i + 1] {
                r += self.val[p].abs();
                colsum[self.col[p]] += self.val[p].abs();
            }
            rowmax = rowmax.max(r);
        }
        (rowmax * colsum.iter().cloned().fold(0.0, f64::max)).sqrt()
    }

    /// The CSC form (for faer): the CSR arrays of the transpose.
    fn to_csc(&self) -> SparseColMat<usize, f64> {
        let (cp, ri, v) = transpose(self.n, &self.rp, &self.col, &self.val);
        SparseColMat::new(SymbolicSparseColMat::new_checked(self.n, self.n, cp, None, ri), v)
    }
    /// A symmetric matrix's CSR arrays reused as its CSC arrays.
    fn into_csc_symmetric(self) -> SparseColMat<usize, f64> {
        SparseColMat::new(SymbolicSparseColMat::new_checked(self.n, self.n, self.rp, None, self.col), self.val)
    }

    /// `(A + A^T) / 2` as CSC (symmetric, so CSR = CSC).
    fn symmetric_part(&self) -> SparseColMat<usize, f64> {
        let (tp, tc, tv) = transpose(self.n, &self.rp, &self.col, &self.val);
        let (mut rp, mut col, mut val) = (vec![0usize], Vec::new(), Vec::new());
        for i in 0..self.n {
            let (mut p, mut q) = (self.rp[i], tp[i]);
            while p < self.rp[i + 1] || q < tp[i + 1] {
                let cp = if p < self.rp[i + 1] { self.col[p] } else { usize::MAX };
                let cq = if q < tp[i + 1] { tc[q] } else { usize::MAX };
                let (c, v) = if cp == cq {
                    p += 1;
                    q += 1;
                    (cp, 0.5 * (self.val[p - 1] + tv[q - 1]))
                } else if cp < cq {
                    p += 1;
                    (cp, 0.5 * self.val[p - 1])
                } else {
                    q += 1;
                    (cq, 0.5 * tv[q - 1])
                };
                col.push(c);
                val.push(v);
            }
            rp.push(col.len());
        }
        SparseColMat::new(SymbolicSparseColMat::new_checked(self.n, self.n, rp, None, col), val)
    }
}

/// Assembles `kind` for `params`, applies `u(0) = u_left`, `u(L) = u_right` (pure PD: on the
/// whole nonlocal boundary layer, from the CE solution of the same problem, as in section 5),
/// and solves.
pub fn solve_model(
    params: &BlendParams,
    kind: ModelKind,
    u_left: f64,
    u_right: f64,
    loads: &[Load],
    solver: BlendSolver,
) -> Result<BlendSolution, BlendError> {
    let t0 = Instant::now();
    let op = BlendOperator::assemble(params, kind)?;
    let t_asm = t0.elapsed().as_secs_f64();
    let n = op.len();
    let x = &op.mesh.x;
    let tol = 1e-9 * params.dx;
    let mut f = vec![0.0; n];
    for (k, l) in loads.iter().enumerate() {
        match l {
            Load::Point { x: xp, force } => {
                let i = x.partition_point(|&p| p < xp - tol);
                if i >= n || (x[i] - xp).abs() > tol {
                    return Err(BlendError::param(
                        format!("loads[{k}].at"),
                        format!("no node at x = {xp}: point loads must sit on a node"),
                    ));
                }
                f[i] += force;
            }
            Load::Body { from, to, density } => {
                for i in 0..n {
                    if x[i] >= from - tol && x[i] <= to + tol {
                        f[i] += density * op.mesh.dual_length(i);
                    }
                }
            }
        }
    }
    // Dirichlet nodes and values.
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    if kind == ModelKind::PurePd {
        let ce = solve_model(params, ModelKind::PureCe, u_left, u_right, loads, BlendSolver::Auto)?;
        let m = ce.x.len();
        let slope_l = (ce.u[1] - ce.u[0]) / (ce.x[1] - ce.x[0]);
        let slope_r = (ce.u[m - 1] - ce.u[m - 2]) / (ce.x[m - 1] - ce.x[m - 2]);
        for i in 0..n {
            if x[i] <= tol {
                fixed[i] = Some(ce.u[0] + slope_l * x[i]);
            } else if x[i] >= params.length - tol {
                fixed[i] = Some(ce.u[m - 1] + slope_r * (x[i] - params.length));
            }
        }
    } else {
        fixed[0] = Some(u_left);
        fixed[n - 1] = Some(u_right);
    }
    // Reduce: free rows, free columns; constrained columns move to the right-hand side.
    let mut free_index = vec![usize::MAX; n];
    let mut nf = 0;
    for i in 0..n {
        if fixed[i].is_none() {
            free_index[i] = nf;
            nf += 1;
        }
    }
    let (mut rp, mut col, mut val, mut rhs) = (vec![0usize], Vec::new(), Vec::new(), Vec::with_capacity(nf));
    for i in 0..n {
        if fixed[i].is_some() {
            continue;
        }
        let mut r = f[i];
        for p in op.row_ptr[i]..op.row_ptr[i + 1] {
            let c = op.col[p];
            match fixed[c] {
                Some(ub) => r -= op.val[p] * ub,
                None => {
                    col.push(free_index[c]);
                    val.push(op.val[p]);
                }
            }
        }
        rp.push(col.len());
        rhs.push(r);
    }
    let a = Csr { n: nf, rp, col, val };
    let reduce = |rp0: &[usize], col0: &[usize], val0: &[f64]| -> Csr {
        let (mut rp, mut col, mut val) = (vec![0usize], Vec::new(), Vec::new());
        for i in 0..n {
            if fixed[i].is_some() {
                continue;
            }
            for p in rp0[i]..rp0[i + 1] {
                if fixed[col0[p]].is_none() {
                    col.push(free_index[col0[p]]);
                    val.push(val0[p]);
                }
            }
            rp.push(col.len());
        }
        Csr { n: nf, rp, col, val }
    };
    let t_asm = t_asm + t0.elapsed().as_secs_f64() - t_asm;
    let mut report = SolveReport::new(SolverId::LuBand, nf, a.val.len());
    report.timings.assemble = t_asm;
    let natural: Vec<usize> = (0..nf).collect();
    let t1 = Instant::now();
    let u_free = match (kind, solver) {
        (_, BlendSolver::Dense) => {
            report.solver = SolverId::DenseLu;
            if nf > 20_000 {
                return Err(BlendError::Solve(format!("dense LU refused for {nf} unknowns (limit 20000)")));
            }
            let mut m = faer::Mat::<f64>::zeros(nf, nf);
            for i in 0..nf {
                for p in a.rp[i]..a.rp[i + 1] {
                    m[(i, a.col[p])] = a.val[p];
                }
            }
            let t = Instant::now();
            let lu = m.partial_piv_lu();
            report.timings.numeric = t.elapsed().as_secs_f64();
            use faer::prelude::Solve;
            let rhs_m = faer::Mat::<f64>::from_fn(nf, 1, |i, _| rhs[i]);
            let x = lu.solve(&rhs_m);
            (0..nf).map(|i| x[(i, 0)]).collect()
        }
        (ModelKind::Blended, BlendSolver::Lu) | (ModelKind::Blended, BlendSolver::Auto) => {
            let mut u = None;
            if solver == BlendSolver::Auto {
                let t = Instant::now();
                // The divergence-form preconditioner is SPD by construction; HOG rows have no
                // 3-point local part to rewrite, so they use the symmetric part instead.
                let (s, label) = match op.divergence_preconditioner() {
                    // P is symmetric: its CSR arrays are its CSC arrays (no transpose). Rounding
                    // of the dual lengths can leave ~1e-16 relative asymmetry; Cholesky reads one
                    // triangle, which is harmless for a preconditioner.
                    Some((rp0, col0, val0)) => {
                        (reduce(&rp0, &col0, &val0).into_csc_symmetric(), GmresPreconditioner::DivergenceForm)
                    }
                    None => (a.symmetric_part(), GmresPreconditioner::SymmetricPart),
                };
                let chol = Cholesky::analyze_with_ordering(&s, Some(&natural))
                    .map_err(|e| BlendError::Solve(e.to_string()))?;
                report.timings.symbolic = t.elapsed().as_secs_f64();
                let t = Instant::now();
                if let Ok(fac) = chol.factor(&s) {
                    report.timings.numeric = t.elapsed().as_secs_f64();
                    report.nnz_factor = Some(chol.nnz_factor());
                    let t = Instant::now();
                    let x = fac.solve(&rhs);
                    let mut x = x;
                    // Stop at a normwise backward error of 16 eps: ||r|| <= 16 eps ||A|| ||x||,
                    // what a backward-stable direct solve achieves. (A fixed relative residual
                    // such as 1e-13 is out of reach when kappa ~ 1e8, as for 10^4 nodes.)
                    let norm_a = a.norm_inf_estimate();
                    let xn = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                    let fnorm = rhs.iter().map(|v| v * v).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
                    let rtol = (16.0 * f64::EPSILON * norm_a * xn / fnorm).clamp(1e-15, 1e-8);
                    let params = GmresParams { rtol, restart: 40, max_iter: 200 };
                    if let Ok(info) = gmres(&a, &FactorPreconditioner(fac), &rhs, &mut x, &params) {
                        report.iterations = Some(info.iterations);
                        report.timings.solve = t.elapsed().as_secs_f64();
                        report.solver = SolverId::Gmres(label);
                        u = Some(x);
                    }
                }
            }
            match u {
                Some(u) => u,
                None => {
                    let (u, ts) = lu_band(&a.to_csc(), &rhs).map_err(|e| BlendError::Solve(e.to_string()))?;
                    report.solver = SolverId::LuBand;
                    report.timings.symbolic += ts[0];
                    report.timings.numeric += ts[1];
                    report.timings.solve += ts[2];
                    u
                }
            }
        }
        (_, BlendSolver::Lu) => {
            let (u, ts) = lu_band(&a.to_csc(), &rhs).map_err(|e| BlendError::Solve(e.to_string()))?;
            report.solver = SolverId::LuBand;
            report.timings.symbolic = ts[0];
            report.timings.numeric = ts[1];
            report.timings.solve = ts[2];
            u
        }
        (_, BlendSolver::Auto) => {
            // Pure CE and pure PD are symmetric: their CSR arrays are their CSC arrays; Cholesky
            // in the band order (the copy is counted in the symbolic phase, as for the blended
            // model's preconditioner).
            let t = Instant::now();
            let s = Csr { n: a.n, rp: a.rp.clone(), col: a.col.clone(), val: a.val.clone() }.into_csc_symmetric();
            let chol =
                Cholesky::analyze_with_ordering(&s, Some(&natural)).map_err(|e| BlendError::Solve(e.to_string()))?;
            report.timings.symbolic = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let fac = chol.factor(&s).map_err(|e| BlendError::Solve(e.to_string()))?;
            report.timings.numeric = t.elapsed().as_secs_f64();
            report.nnz_factor = Some(chol.nnz_factor());
            let t = Instant::now();
            let u = fac.solve(&rhs);
            report.timings.solve = t.elapsed().as_secs_f64();
            report.solver = SolverId::Cholesky(CholeskyOrdering::Band);
            u
        }
    };
    report.timings.total = t1.elapsed().as_secs_f64();
    let mut r = vec![0.0; nf];
    a.apply(&u_free, &mut r);
    let num: f64 = r.iter().zip(&rhs).map(|(p, q)| (p - q) * (p - q)).sum::<f64>().sqrt();
    let den: f64 = rhs.iter().map(|v| v * v).sum::<f64>().sqrt();
    report.rel_residual = if den > 0.0 { num / den } else { num };
    report.peak_rss_bytes = peak_rss_bytes();
    if u_free.iter().any(|v| !v.is_finite()) {
        return Err(BlendError::Solve("the solution has non-finite values".into()));
    }
    let u: Vec<f64> = (0..n).map(|i| fixed[i].unwrap_or_else(|| u_free[free_index[i]])).collect();
    Ok(BlendSolution {
        kind,
        x: op.mesh.x.clone(),
        u,
        beta: op.beta.clone(),
        transition: op.transition.clone(),
        report,
    })
}
