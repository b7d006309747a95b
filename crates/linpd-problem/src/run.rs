//! From a validated [`Problem`] to a [`Solution`]: the scene's model ([`crate::models`])
//! builds its system, then the one static solve of linpd-solve ([`linpd_solve::solve_model`]: support check, Dirichlet elimination
//! `A_ff u_f = f_f - (A u_bar)_f`, assembled or matrix-free solve, report).

use crate::models::bond::BondModel;
use crate::models::bond_lattice::BondLatticeModel;
use crate::models::lattice_blend::LatticeBlendModel;
use crate::models::lps::LpsSceneModel;
use crate::models::Capability;
use crate::problem::NodeSet;
use crate::{Problem, ProblemError};
use linpd_blend::LatticeBlend;
use linpd_bond::{BondOperator, LatticeBondModel};
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_core::Point;
use linpd_lps::LpsModel;
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
    /// CE scenes built by [`crate::models::blend_1d`] from the solution's end reactions).
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
    pub(crate) fn bond_model(&self) -> Result<&BondModel, ProblemError> {
        self.model.bond().ok_or_else(|| {
            ProblemError::invalid(
                "model.type",
                format!("a bond model is needed here, the scene has {}", self.model.describe()),
            )
        })
    }

    /// The scene's model as `T` ([`crate::models`]), or an error naming what was needed.
    fn model_as<T: 'static>(&self, what: &str) -> Result<&T, ProblemError> {
        self.model.downcast::<T>().ok_or_else(|| {
            ProblemError::invalid(
                "model.type",
                format!("{what} is needed here, the scene has {}", self.model.describe()),
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
        self.bond_model()?.operator(&self.nodes)
    }

    /// The bond model of the scene on its lattice.
    pub fn lattice_model(&self) -> Result<LatticeBondModel, ProblemError> {
        self.lattice_model_and_correction().map(|(m, _)| m)
    }

    /// [`Problem::lattice_model`] and what its surface correction did and cost.
    pub fn lattice_model_and_correction(&self) -> Result<(LatticeBondModel, Option<CorrectionSummary>), ProblemError> {
        self.model_as::<BondLatticeModel>("a bond model on a grid")?.build(self)
    }

    /// The scene's blended model (a bond model with `pd_regions`).
    pub fn lattice_blend(&self) -> Result<LatticeBlend, ProblemError> {
        self.model_as::<LatticeBlendModel>("a bond model with pd_regions")?.build(self)
    }

    /// The LPS model of an lps scene, with the defects of its material and its surface
    /// correction.
    pub fn lps_model(&self) -> Result<LpsModel, ProblemError> {
        self.lps_model_and_correction().map(|(m, _)| m)
    }

    /// [`Problem::lps_model`] and, with a moment-matching surface correction, what it did and
    /// cost (for the solve report).
    pub fn lps_model_and_correction(&self) -> Result<(LpsModel, Option<CorrectionSummary>), ProblemError> {
        self.model_as::<LpsSceneModel>("an lps model")?.build(self)
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

    /// Solves the static problem ([`crate::models::SceneModel::solve`]). `progress` receives one
    /// line per phase and the tasks of the assembly and the solver.
    pub fn solve(&self, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        self.model.require(Capability::StaticSolve)?;
        // the solver may have changed since validation ([`Problem::set_solver`])
        if let linpd_solve::SolverSpec::Cg { matrix_free: true, .. } = self.solver {
            self.model.require(Capability::MatrixFree)?;
        }
        self.model.solve(self, progress)
    }

    /// The one static solve of `model` built since `t0` with prescribed displacements `bc` and
    /// nodal forces `f`: the building time is counted as assembly in the report, and the end is
    /// announced with the residual.
    pub(crate) fn timed_solve(
        &self,
        model: &dyn linpd_core::Model,
        bc: &Dirichlet,
        f: &[f64],
        t0: Instant,
        progress: &dyn Progress,
    ) -> Result<(Vec<f64>, SolveReport), ProblemError> {
        let t_build = t0.elapsed().as_secs_f64();
        let solved = solve_model(model, bc, f, &self.solver, progress).map_err(|e| self.model.static_error(e))?;
        let mut report = solved.report;
        report.timings.assemble += t_build;
        progress.phase(&format!(
            "done in {:.3} s, relative residual {:.2e}",
            t0.elapsed().as_secs_f64(),
            report.rel_residual
        ));
        Ok((solved.u, report))
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
