//! From a validated [`Problem`] to a [`Solution`]: build the model, then the one static solve
//! of linpd-solve ([`linpd_solve::solve_model`]: support check, Dirichlet elimination
//! `A_ff u_f = f_f - (A u_bar)_f`, assembled or matrix-free solve, report).

use crate::problem::NodeSet;
use crate::{ModelSpec, Problem, ProblemError};
use linpd_bond::{BondOperator, LatticeBondModel};
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_core::Point;
use linpd_lps::SurfaceCorrection;
use linpd_solve::{solve_model, Dirichlet, SolveReport, StaticError};
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
    /// Node volumes `V_i` (empty for blend scenes, whose CE nodes carry none).
    pub volumes: Vec<f64>,
    /// Number of bonds (each pair counted from both ends).
    pub n_bonds: usize,
    /// Accuracy and cost.
    pub report: SolveReport,
    /// Loads, constraints, reactions and the force balance (every static scene; for blend and
    /// CE scenes built by `crate::blend` from the solution's end reactions).
    pub balance: Option<crate::Balance>,
    /// Strain energy density `W_i` per node (energy per volume; `sum_i W_i V_i = u.A u / 2`,
    /// [`crate::balance::nodal_energy`] for bond-based models,
    /// [`linpd_lps::LpsModel::linearized_energy_density`] for LPS, the same split of `K`'s
    /// blocks for symmetric coarsened levels): not for blend scenes and unsymmetric levels.
    pub strain_energy_density: Option<Vec<f64>>,
    /// Small-strain tensor per node, least squares over the node's partners
    /// ([`crate::fields`]): not for blend scenes.
    pub strain: Option<crate::NodalStrain>,
    /// Linearized dilatation `theta_i` per node: LPS scenes only.
    pub dilatation: Option<Vec<f64>>,
}

impl Problem {
    /// The bond model of the scene, or an error naming the scene's model type.
    pub(crate) fn bond_model(&self) -> Result<&crate::BondModel, ProblemError> {
        self.model.bond().ok_or_else(|| {
            ProblemError::invalid(
                "model.type",
                format!("a bond model is needed here, the scene has {}", self.model.name()),
            )
        })
    }

    /// Builds the bond operator of the scene (bond models only): on its lattice, or on its
    /// point cloud with the nodes' own volumes; with the scene's surface correction.
    pub fn operator(&self) -> Result<BondOperator, ProblemError> {
        self.operator_and_correction().map(|(op, _)| op)
    }

    /// [`Problem::operator`] and, when the scene has a surface correction, what it did and
    /// cost (for the solve report).
    pub fn operator_and_correction(&self) -> Result<(BondOperator, Option<CorrectionSummary>), ProblemError> {
        let op = self.uncorrected_operator()?;
        let b = self.bond_model()?;
        Ok(match b.surface.correction {
            SurfaceCorrection::Energy => {
                let (op, summary) =
                    op.with_energy_correction(self.lattice()?, b.horizon, &b.micromodulus, b.surface.target);
                (op, Some(summary))
            }
            _ => (op, None),
        })
    }

    fn uncorrected_operator(&self) -> Result<BondOperator, ProblemError> {
        let b = self.bond_model()?;
        let op = match self.nodes.cloud() {
            Some(c) => BondOperator::on_points(
                c.dim,
                c.positions.clone(),
                &c.volumes,
                b.horizon,
                &b.micromodulus,
                &b.material,
                b.node_moduli.as_deref(),
            ),
            None => BondOperator::on_grid(self.lattice()?, b.horizon, &b.micromodulus, &b.material),
        };
        op.map_err(|e| ProblemError::invalid("model", e.to_string()))
    }

    /// Constrained-DOF mask and the prescribed full displacement `u_bar`.
    pub fn constrained(&self) -> (Vec<bool>, Vec<f64>) {
        let d = self.dim();
        let n = self.nodes.len();
        let mut mask = vec![false; d * n];
        let mut ubar = vec![0.0; d * n];
        for c in &self.constraints {
            for node in self.nodes.select(&c.region) {
                let x = self.nodes.position(node);
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
        let mut f = vec![0.0; self.dim() * self.nodes.len()];
        for l in &self.loads {
            self.add_load(l, &mut f);
        }
        f
    }

    /// The prescribed displacements of the constraints.
    pub fn dirichlet(&self) -> Dirichlet {
        let (mask, ubar) = self.constrained();
        Dirichlet::new(self.dim(), &mask, ubar)
    }

    /// The bond model of the scene on its lattice.
    pub fn lattice_model(&self) -> Result<LatticeBondModel, ProblemError> {
        self.lattice_model_and_correction().map(|(m, _)| m)
    }

    /// [`Problem::lattice_model`] and what its surface correction did and cost.
    pub fn lattice_model_and_correction(&self) -> Result<(LatticeBondModel, Option<CorrectionSummary>), ProblemError> {
        let b = self.bond_model()?;
        let (op, summary) = self.operator_and_correction()?;
        // the stencil applies the uncorrected lattice operator only
        let homogeneous = (b.material.is_homogeneous() && summary.is_none()).then(|| b.micromodulus.clone());
        Ok((LatticeBondModel::new(op, self.lattice()?.clone(), b.horizon, homogeneous), summary))
    }

    /// Solves the static problem. `progress` receives one line per phase and the tasks of the assembly and the solver.
    pub fn solve(&self, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        // One arm per model type: a new model adds its variant here.
        match &self.model {
            ModelSpec::Blend(b) => return crate::blend::solve(&self.name, b, progress),
            ModelSpec::Lps(params, ..) => return crate::lps::solve(self, params, progress),
            ModelSpec::Coarsened(c) => return crate::coarsened::solve(self, c, progress),
            ModelSpec::Bond(_) => {}
        }
        if self.nodes.cloud().is_some() {
            return self.solve_cloud(progress);
        }
        // Checked again here: the solver may have changed since validation (`set_solver`).
        let path = match self.solver {
            linpd_solve::SolverSpec::Cg { matrix_free: true, .. } => crate::memory::Path::BondMatrixFree,
            _ => crate::memory::Path::BondAssembled,
        };
        let multigrid = self.solver.uses_multigrid();
        crate::memory::check_solver(path, self.lattice()?, self.bond_model()?.horizon, multigrid)?;
        let t0 = Instant::now();
        progress.phase(&format!(
            "building bonds: {} nodes, horizon/spacing = {:.3}",
            self.nodes.len(),
            self.model.horizon().unwrap_or(f64::NAN) / self.lattice()?.spacing()
        ));
        if self.bond_model()?.zone.is_some() {
            return crate::zones::solve(self, t0, progress);
        }
        let (model, correction) = self.lattice_model_and_correction()?;
        if let Some(c) = &correction {
            progress.phase(&c.describe());
        }
        let (u, mut report) = self.timed_solve(&model, t0, progress)?;
        if let Some(c) = correction {
            append_note(&mut report, c.describe());
        }
        let n_bonds = model.operator().family().n_bonds();
        self.bond_solution(&model, n_bonds, u, report)
    }
}

impl Problem {
    /// The bond model on a point cloud: the operator with its AMD ordering
    /// ([`linpd_core::Model`] for [`BondOperator`]), always assembled.
    fn solve_cloud(&self, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        let t0 = Instant::now();
        progress.phase(&format!("building bonds: {} nodes of the point cloud", self.nodes.len()));
        let model = self.operator()?;
        let (u, report) = self.timed_solve(&model, t0, progress)?;
        let n_bonds = model.family().n_bonds();
        self.bond_solution(&model, n_bonds, u, report)
    }

    /// The one static solve of a model built since `t0`: the building time is counted as
    /// assembly in the report, and the end is announced with the residual.
    pub(crate) fn timed_solve(
        &self,
        model: &dyn linpd_core::Model,
        t0: Instant,
        progress: &dyn Progress,
    ) -> Result<(Vec<f64>, SolveReport), ProblemError> {
        let t_build = t0.elapsed().as_secs_f64();
        let solved =
            solve_model(model, &self.dirichlet(), &self.load_vector(), &self.solver, progress).map_err(static_error)?;
        let mut report = solved.report;
        report.timings.assemble += t_build;
        progress.phase(&format!(
            "done in {:.3} s, relative residual {:.2e}",
            t0.elapsed().as_secs_f64(),
            report.rel_residual
        ));
        Ok((solved.u, report))
    }

    /// The solution of a bond model (`n_bonds` bonds, cut ones included): balance and strain
    /// energy density from its blocks.
    pub(crate) fn bond_solution(
        &self,
        model: &dyn linpd_core::Model,
        n_bonds: usize,
        u: Vec<f64>,
        report: SolveReport,
    ) -> Result<Solution, ProblemError> {
        let balance = self.balance(model, &u);
        let volumes: Vec<f64> = (0..self.nodes.len()).map(|n| self.nodes.volume(n)).collect();
        let strain_energy_density =
            crate::balance::nodal_energy(model, &u).map(|e| e.iter().zip(&volumes).map(|(w, v)| w / v).collect());
        let strain = Some(crate::nodal_strain(model, &volumes, &u));
        Ok(Solution {
            name: self.name.clone(),
            dim: self.dim(),
            x: (0..model.n_nodes()).map(|i| model.position(i)).collect(),
            u,
            is_layer: (0..self.nodes.len()).map(|n| self.nodes.is_layer(n)).collect(),
            volumes,
            n_bonds,
            balance: Some(balance),
            strain_energy_density,
            strain,
            dilatation: None,
            report,
        })
    }
}

/// Adds `note` to the report's note (after the solver's own, `; `-separated).
pub(crate) fn append_note(report: &mut SolveReport, note: String) {
    report.note = Some(match report.note.take() {
        Some(n) => format!("{n}; {note}"),
        None => note,
    });
}

/// A failed static solve as a scene error.
pub(crate) fn static_error(e: StaticError) -> ProblemError {
    match e {
        StaticError::NothingFree => ProblemError::invalid("constraints", "every DOF is constrained: nothing to solve"),
        e @ StaticError::Unsupported { .. } => ProblemError::Unsupported(e),
        e @ StaticError::MatrixFreeUnavailable { .. } => ProblemError::invalid("solver.matrix_free", e.to_string()),
        other => ProblemError::Static(other),
    }
}
