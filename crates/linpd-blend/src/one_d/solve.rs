//! Loads and Dirichlet conditions of the 1D models; the solve is linpd-solve's one static solve
//! ([`linpd_solve::solve_model`]) on the operator as a [`linpd_core::Model`]
//! (`crate::one_d::static_model`).
//!
//! The blended matrix is not symmetric, but its skew part sits only in the local terms of the
//! transition rows and is small: for a linear `beta` the local part `D1 u' + D2 u''` is in
//! divergence form in the continuum (`D1 = dD2/dx`). `auto` therefore factors the SPD
//! divergence form `P` ([`BlendOperator::divergence_preconditioner`]; the symmetric part
//! `(A + A^T)/2` with HOG), which keeps the band, by sparse Cholesky in the natural (band) order
//! and solves `A u = f` by GMRES preconditioned with `P^{-1}`: a handful of iterations, so the
//! cost is one Cholesky of the band, like pure PD. If `P` is not positive definite or GMRES
//! stalls, it falls back to sparse LU with partial pivoting in the band order.

use crate::one_d::model::{BlendOperator, BlendParams, ModelKind};
use crate::BlendError;
use linpd_solve::{Dirichlet, SolveReport, SolverSpec};
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

impl Load {
    /// The nodes of `x` (ascending) this load puts a force on; `None` for a point load that
    /// sits on no node (farther than `tol` from every one).
    pub fn nodes(&self, x: &[f64], tol: f64) -> Option<Vec<usize>> {
        match self {
            Load::Point { x: xp, .. } => {
                let i = x.partition_point(|&p| p < xp - tol);
                (i < x.len() && (x[i] - xp).abs() <= tol).then(|| vec![i])
            }
            Load::Body { from, to, .. } => {
                Some((0..x.len()).filter(|&i| x[i] >= from - tol && x[i] <= to + tol).collect())
            }
        }
    }
}

/// Solver choice for the 1D models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BlendSolver {
    /// Symmetric models: Cholesky (band order). Blended: Cholesky of the divergence form +
    /// GMRES, falling back to LU.
    #[default]
    Auto,
    /// Sparse LU with partial pivoting (band-preserving analysis).
    Lu,
    /// Dense Cholesky for the symmetric models, dense LU for the blended one (the paper's
    /// MATLAB-style baseline: what `\` does with a full matrix; small systems only).
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
    /// The reactions of the supports at `x <= 0` and `x >= L`: `sum (A u - f)` over their
    /// Dirichlet nodes (the end rows of the blended and CE operators are the force on the end
    /// node's half cell; see the crate docs on force balance).
    pub reactions: [f64; 2],
    /// The total applied force `sum_i f_i`.
    pub applied: f64,
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

impl BlendSolver {
    /// The solver of linpd-solve it stands for.
    pub fn spec(self) -> SolverSpec {
        match self {
            BlendSolver::Auto => SolverSpec::default(),
            BlendSolver::Lu => SolverSpec::Lu,
            BlendSolver::Dense => SolverSpec::Dense,
        }
    }
}

/// The nodal forces of `loads` on the nodes `x` (ascending; a node's share of a body load is
/// `density` times its dual cell length `(x_{i+1} - x_{i-1}) / 2`); `tol` is how far from a
/// node a point load may sit.
pub fn nodal_forces(x: &[f64], loads: &[Load], tol: f64) -> Result<Vec<f64>, BlendError> {
    let n = x.len();
    let mut f = vec![0.0; n];
    let dual = |i: usize| {
        let left = if i > 0 { x[i] - x[i - 1] } else { 0.0 };
        let right = if i + 1 < n { x[i + 1] - x[i] } else { 0.0 };
        0.5 * (left + right)
    };
    for (k, l) in loads.iter().enumerate() {
        let Some(nodes) = l.nodes(x, tol) else {
            let xp = if let Load::Point { x, .. } = l { *x } else { f64::NAN };
            return Err(BlendError::param(
                format!("loads[{k}].at"),
                format!("no node at x = {xp}: point loads must sit on a node"),
            ));
        };
        for i in nodes {
            f[i] += match l {
                Load::Point { force, .. } => *force,
                Load::Body { density, .. } => density * dual(i),
            };
        }
    }
    Ok(f)
}

/// The prescribed displacements and nodal forces [`solve_model`] solves `op` (assembled for
/// `params` and `kind`) with: `u(0) = u_left`, `u(L) = u_right` (pure PD: on the whole nonlocal
/// boundary layer, from the CE solution of the same problem, as in section 5).
pub fn constraints_and_loads(
    op: &BlendOperator,
    params: &BlendParams,
    kind: ModelKind,
    u_left: f64,
    u_right: f64,
    loads: &[Load],
) -> Result<(Dirichlet, Vec<f64>), BlendError> {
    let n = op.len();
    let x = &op.mesh.x;
    let tol = 1e-9 * params.dx;
    let f = nodal_forces(x, loads, tol)?;
    // Dirichlet nodes and values.
    let mut fixed = Vec::new();
    if kind == ModelKind::PurePd {
        if !params.material.defects.is_empty() {
            // The boundary values come from the CE solution, which cannot hold a defect.
            return Err(BlendError::param(
                "material.defects",
                "the pure PD reference takes its boundary values from the CE solution, which has no defects",
            ));
        }
        let ce = solve_model(params, ModelKind::PureCe, u_left, u_right, loads, BlendSolver::Auto)?;
        let m = ce.x.len();
        let slope_l = (ce.u[1] - ce.u[0]) / (ce.x[1] - ce.x[0]);
        let slope_r = (ce.u[m - 1] - ce.u[m - 2]) / (ce.x[m - 1] - ce.x[m - 2]);
        for i in 0..n {
            if x[i] <= tol {
                fixed.push((i, ce.u[0] + slope_l * x[i]));
            } else if x[i] >= params.length - tol {
                fixed.push((i, ce.u[m - 1] + slope_r * (x[i] - params.length)));
            }
        }
    } else {
        fixed.push((0, u_left));
        fixed.push((n - 1, u_right));
    }
    let bc = Dirichlet::from_fixed(1, n, &fixed).map_err(|e| BlendError::param("constraints", e.to_string()))?;
    Ok((bc, f))
}

/// Assembles `kind` for `params`, applies `u(0) = u_left`, `u(L) = u_right` (pure PD: on the
/// whole nonlocal boundary layer, from the CE solution of the same problem, as in section 5),
/// and solves with [`linpd_solve::solve_model`].
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
    let (bc, f) = constraints_and_loads(&op, params, kind, u_left, u_right, loads)?;
    let solved = linpd_solve::solve_model(&op, &bc, &f, &solver.spec(), &linpd_core::NoProgress)?;
    let mut report = solved.report;
    report.timings.assemble += t_asm;
    // Reactions: A u - f at the Dirichlet nodes of each end (see the crate docs).
    let mut au = vec![0.0; op.len()];
    op.apply(&solved.u, &mut au);
    let mut reactions = [0.0; 2];
    for (i, &x) in op.mesh.x.iter().enumerate() {
        if bc.dofs().is_constrained(i) {
            reactions[usize::from(x > 0.5 * params.length)] += au[i] - f[i];
        }
    }
    Ok(BlendSolution {
        kind,
        x: op.mesh.x.clone(),
        u: solved.u,
        beta: op.beta.clone(),
        transition: op.transition.clone(),
        report,
        reactions,
        applied: f.iter().sum(),
    })
}
