//! From a validated [`Problem`] to a [`Solution`]: the scene's model ([`crate::models`])
//! builds its system, then the one static solve of linpd-solve ([`linpd_solve::solve_model`]: support check, Dirichlet elimination
//! `A_ff u_f = f_f - (A u_bar)_f`, assembled or matrix-free solve, report).

use crate::capability::Capability;
use crate::models::bond_lattice::BondLatticeModel;
use crate::models::lattice_blend::{GradedSystem, LatticeBlendModel};
use crate::models::lps::LpsSceneModel;
use crate::scene::Problem;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_blend::LatticeBlend;
use linpd_bond::{BondOperator, LatticeBondModel};
use linpd_core::progress::Progress;
use linpd_core::surface::CorrectionSummary;
use linpd_lps::LpsModel;

impl Problem {
    /// The scene's model as `T` ([`crate::models`]), or an error naming what was needed.
    pub(crate) fn model_as<T: 'static>(&self, what: &str) -> Result<&T, ProblemError> {
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
        self.model.bond_operator(self)
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

    /// The scene's blended model on its graded local mesh (a bond model with `pd_regions` and
    /// `local_mesh`).
    pub fn graded_blend(&self) -> Result<GradedSystem, ProblemError> {
        let m = self.model_as::<LatticeBlendModel>("a bond model with pd_regions")?;
        let local = m.zone.local_mesh.ok_or_else(|| {
            ProblemError::invalid("model.local_mesh", "is needed here (the scene's blend is on the lattice)")
        })?;
        m.build_graded(self, local)
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

    /// Solves the static problem ([`crate::models::SceneModel::solve`]). `progress` receives one
    /// line per phase and the tasks of the assembly and the solver.
    pub fn solve(&self, progress: &dyn Progress) -> Result<Solution, ProblemError> {
        if self.part.is_some() {
            // its window's ends are not the body's: linpd_problem::part_rows is its row system
            return Err(ProblemError::invalid("ranks", "this is one rank's part of the scene: it is not solved alone"));
        }
        self.model.require(Capability::StaticSolve)?;
        // the solver may have changed since validation ([`Problem::set_solver`])
        if let linpd_solve::SolverSpec::Cg { matrix_free: true, .. } = self.solver {
            self.model.require(Capability::MatrixFree)?;
        }
        Ok(self.with_material(self.model.solve(self, progress)?))
    }

    /// `solution` with what every model's solution gets from the scene: its materials' constants
    /// and the Hooke stress of its strain ([`Problem::hooke_stress`]).
    pub fn with_material(&self, mut solution: Solution) -> Solution {
        solution.material = self.model.elastic_constants();
        solution.stress = self.hooke_stress(&solution);
        solution
    }

    /// The Hooke stress of a solution of this scene (its strain and the model's constants).
    pub fn hooke_stress(&self, s: &Solution) -> Option<crate::stress::NodalStress> {
        let strain = s.strain.as_ref()?;
        let (plane, constants) = self.model.node_elastic(self, &s.x)?;
        Some(crate::stress::hooke(strain, plane, &|n| constants[n]))
    }
}
