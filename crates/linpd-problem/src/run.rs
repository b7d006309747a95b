//! From a validated [`Problem`] to a [`Solution`]: build the operator, eliminate the volume
//! constraints, assemble (or not), solve, and report.
//!
//! Constraint elimination keeps the reduced system SPD: with `u = u_bar + u_f` (`u_bar` the
//! prescribed values at constrained DOFs, zero elsewhere), the free equations are
//! `A_ff u_f = f_f - (A u_bar)_f`, where `A u_bar` is applied matrix-free. Loads on constrained
//! DOFs are reactions and do not enter the reduced system.

use crate::{Load, Problem, ProblemError};
use linpd_bond::{check_support, nested_dissection, BondOperator, Pattern, StencilOperator};
use linpd_core::{DofMap, Point};
use linpd_solve::{
    auto_choice, pcg, peak_rss_bytes, relative_residual, solve_with_ordering, LinearOperator, SolveError, SolveReport,
    SolverKind,
};
use std::time::Instant;

/// The result of a static solve.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Scene name.
    pub name: String,
    /// Dimension.
    pub dim: usize,
    /// Node positions.
    pub x: Vec<Point>,
    /// Displacements, `dim` per node (node-major).
    pub u: Vec<f64>,
    /// True for nodes of the outer layer.
    pub is_layer: Vec<bool>,
    /// Number of bonds (each pair counted from both ends).
    pub n_bonds: usize,
    /// Accuracy and cost.
    pub report: SolveReport,
}

/// The reduced operator `A_ff`, applied through an apply over all DOFs (constrained entries
/// zeroed on input, dropped on output): matrix-free CG on a constrained body.
pub struct Reduced<'a, F: Fn(&[f64], &mut [f64]) + Sync> {
    /// The free/constrained split.
    pub dofs: &'a DofMap,
    /// `y = A x` over all DOFs.
    pub apply_full: F,
}

impl<F: Fn(&[f64], &mut [f64]) + Sync> LinearOperator for Reduced<'_, F> {
    fn n(&self) -> usize {
        self.dofs.n_free()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let mut full = vec![0.0; self.dofs.n_dofs()];
        self.dofs.scatter(x, &mut full);
        let mut out = vec![0.0; self.dofs.n_dofs()];
        (self.apply_full)(&full, &mut out);
        y.copy_from_slice(&self.dofs.gather(&out));
    }
}

impl Problem {
    /// Builds the bond operator of the scene.
    pub fn operator(&self) -> Result<BondOperator, ProblemError> {
        BondOperator::on_grid(&self.grid, self.model.horizon, &self.model.micromodulus, &self.model.material)
            .map_err(|e| ProblemError::invalid("model", e.to_string()))
    }

    /// Constrained-DOF mask and the prescribed full displacement `u_bar`.
    pub fn constrained(&self) -> (Vec<bool>, Vec<f64>) {
        let d = self.dim();
        let n = self.grid.len();
        let mut mask = vec![false; d * n];
        let mut ubar = vec![0.0; d * n];
        for c in &self.constraints {
            for node in c.region.nodes(&self.grid) {
                let x = self.grid.position(node);
                for &a in &c.components {
                    mask[d * node + a] = true;
                    ubar[d * node + a] = c.displacement(&x[..d], a);
                }
            }
        }
        (mask, ubar)
    }

    /// External force per full DOF (point forces plus density times node volume).
    pub fn load_vector(&self) -> Vec<f64> {
        let d = self.dim();
        let mut f = vec![0.0; d * self.grid.len()];
        for l in &self.loads {
            match l {
                Load::Point { node, force } => (0..d).for_each(|a| f[d * node + a] += force[a]),
                Load::Body { region, density } => {
                    let v = self.grid.volume();
                    for node in region.nodes(&self.grid) {
                        (0..d).for_each(|a| f[d * node + a] += density[a] * v);
                    }
                }
            }
        }
        f
    }

    /// Solves the static problem. `progress` receives one line per phase.
    pub fn solve(&self, progress: &dyn Fn(&str)) -> Result<Solution, ProblemError> {
        if let Some(b) = &self.blend {
            return crate::blend::solve(&self.name, b, progress);
        }
        if let Some(params) = &self.lps {
            return crate::lps::solve(self, params, progress);
        }
        let d = self.dim();
        let t0 = Instant::now();
        progress(&format!(
            "building bonds: {} nodes, horizon/spacing = {:.3}",
            self.grid.len(),
            self.model.horizon / self.grid.spacing()
        ));
        let op = self.operator()?;
        let (mask, ubar) = self.constrained();
        let dofs = DofMap::new(d, &mask);
        if dofs.n_free() == 0 {
            return Err(ProblemError::invalid("constraints", "every DOF is constrained: nothing to solve"));
        }
        check_support(&op, &dofs).map_err(|e| {
            let at: Vec<Vec<f64>> = e.nodes.iter().take(3).map(|&n| op.positions()[n][..d].to_vec()).collect();
            ProblemError::Unsupported(format!("{e} (first positions {at:?})"))
        })?;
        let f_full = self.load_vector();
        let mut a_ubar = vec![0.0; d * self.grid.len()];
        op.apply(&ubar, &mut a_ubar);
        let rhs: Vec<f64> = f_full.iter().zip(&a_ubar).map(|(f, a)| f - a).collect();
        let f_free = dofs.gather(&rhs);
        let t_build = t0.elapsed().as_secs_f64();

        let name_dof = |free: usize| -> String {
            let full = dofs.free_dofs()[free];
            let node = full / d;
            format!("node {node} at {:?}, component {}", &op.positions()[node][..d], full % d)
        };
        let map_err = |e: SolveError| -> ProblemError {
            match e {
                SolveError::NotPositiveDefinite { dof } | SolveError::Singular { dof } => ProblemError::Solve(format!(
                    "{e}: {}; the body is not held there (add constraints) or bonds are cut around it",
                    name_dof(dof)
                )),
                other => ProblemError::Solve(other.to_string()),
            }
        };

        let (u_free, mut report) = if self.solver.matrix_free {
            let SolverKind::Cg(params) = &self.solver.kind else { unreachable!("validated") };
            progress(&format!("solving matrix-free with Jacobi-PCG: {} unknowns", dofs.n_free()));
            let diag = dofs.gather(&full_diagonal(&op));
            let t = Instant::now();
            let mut u = vec![0.0; dofs.n_free()];
            let stencil = if self.model.material.is_homogeneous() {
                StencilOperator::new(&self.grid, self.model.horizon, &self.model.micromodulus).ok()
            } else {
                None
            };
            let info = match &stencil {
                Some(s) => pcg(
                    &Reduced { dofs: &dofs, apply_full: |x: &[f64], y: &mut [f64]| s.apply(x, y) },
                    &diag,
                    &f_free,
                    &mut u,
                    params,
                ),
                None => pcg(
                    &Reduced { dofs: &dofs, apply_full: |x: &[f64], y: &mut [f64]| op.apply(x, y) },
                    &diag,
                    &f_free,
                    &mut u,
                    params,
                ),
            }
            .map_err(|e| map_err(SolveError::Cg(e)))?;
            let mut rep = SolveReport::new(dofs.n_free(), 0);
            rep.solver =
                if stencil.is_some() { "cg-jacobi-matrix-free-stencil" } else { "cg-jacobi-matrix-free" }.into();
            rep.iterations = Some(info.iterations);
            rep.rel_residual = info.rel_residual;
            rep.timings.solve = t.elapsed().as_secs_f64();
            rep.timings.total = rep.timings.solve;
            rep.peak_rss_bytes = peak_rss_bytes();
            (u, rep)
        } else {
            progress(&format!("assembling: {} free DOFs", dofs.n_free()));
            let t = Instant::now();
            let pattern = Pattern::new(&op, &dofs);
            let mut values = vec![0.0; pattern.nnz()];
            pattern.fill(&op, &dofs, &mut values);
            let a = faer::sparse::SparseColMat::new(pattern.symbolic().clone(), values);
            let t_asm = t.elapsed().as_secs_f64();
            progress(&format!(
                "solving: {} unknowns, {} stored entries, solver {:?}",
                a.nrows(),
                a.val().len(),
                self.solver.kind
            ));
            // 1D: the natural order is a band, already fill-optimal (AMD's analysis of a 10^5-node
            // band costs ~1 s for nothing). 2D/3D: nested dissection on the lattice beats AMD.
            let perm = if d == 1 {
                (0..dofs.n_free()).collect()
            } else {
                let reach =
                    (self.model.horizon / self.grid.spacing() * (1.0 + linpd_core::GEOMETRY_RTOL)).floor() as usize;
                nested_dissection(&self.grid, reach, &dofs)
            };
            let perm = Some(perm);
            // `auto` picks by size; when it picks CG it uses the scene's rtol and max_iter.
            let kind = match &self.solver.kind {
                SolverKind::Auto => match auto_choice(d, a.nrows()) {
                    SolverKind::Cg(_) => SolverKind::Cg(self.solver.cg.clone()),
                    k => k,
                },
                k => k.clone(),
            };
            let (u, mut rep) = solve_with_ordering(&a, &f_free, &kind, d, perm.as_deref()).map_err(map_err)?;
            if d == 1 && rep.solver == "cholesky-nd" {
                rep.solver = "cholesky-natural".into();
            }
            rep.timings.assemble = t_asm;
            debug_assert!((relative_residual(&a, true, &u, &f_free) - rep.rel_residual).abs() < 1e-12);
            (u, rep)
        };
        report.timings.assemble += t_build;
        let mut u = ubar;
        dofs.scatter(&u_free, &mut u);
        if u.iter().any(|v| !v.is_finite()) {
            return Err(ProblemError::Solve("the solution has non-finite values".into()));
        }
        progress(&format!(
            "done in {:.3} s, relative residual {:.2e}",
            t0.elapsed().as_secs_f64(),
            report.rel_residual
        ));
        Ok(Solution {
            name: self.name.clone(),
            dim: d,
            x: op.positions().to_vec(),
            u,
            is_layer: (0..self.grid.len()).map(|n| self.grid.is_layer(n)).collect(),
            n_bonds: op.family().n_bonds(),
            report,
        })
    }
}

/// Diagonal of `A` over all DOFs: `A[(i,a),(i,a)] = sum_j w_ij e_a^2`.
pub fn full_diagonal(op: &BondOperator) -> Vec<f64> {
    let d = op.dim();
    let mut diag = vec![0.0; op.n_dofs()];
    for i in 0..op.n_nodes() {
        for (&j, &w) in op.family().neighbors(i).iter().zip(op.weights(i)) {
            let e = op.unit(i, j as usize);
            for a in 0..d {
                diag[d * i + a] += w * e[a] * e[a];
            }
        }
    }
    diag
}
