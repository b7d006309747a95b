//! The solver plan: what a static solve will run, decided once ([`plan`]) from what the model
//! offers ([`Offers`]) and the solver asked for ([`SolverSpec`]), with `auto`'s thresholds
//! ([`AutoParams`]).
//!
//! A scene decides its plan when it is validated, from the offers its model declares, and keeps
//! it: the memory guard counts what the plan names ([`SolvePlan::apply`],
//! [`SolvePlan::hierarchy`]) and the solve runs it ([`crate::statics::solve_planned`]). A
//! caller with a built model and no scene ([`crate::solve_model`]) plans from the model itself
//! ([`Offers::of_model`]); both go through [`plan`], so `auto` has one set of rules.
//!
//! What is left to the solve: `auto` on an assembled matrix chooses between the sparse
//! Cholesky and PCG by the cost model of [`crate::cost`], which needs the matrix's symbolic
//! analysis ([`crate::statics::auto`]), and the fallbacks when a choice fails at run time.

use crate::precond::kind::{largest_setup, SetupOn};
use crate::spec::{PreconditionerKind, SolverSpec};
use crate::statics::AutoParams;
use linpd_core::sparse::SYMMETRY_RTOL;
use linpd_core::{DofMap, Model};

/// What a model offers the solvers, known before it is built (a scene model declares it) or
/// read off a built one ([`Offers::of_model`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Offers {
    /// Spatial dimension.
    pub dim: usize,
    /// Unknowns of the solve: the free DOFs (all DOFs where the constraints are not known yet,
    /// an upper bound).
    pub unknowns: usize,
    /// `A` is symmetric (to [`SYMMETRY_RTOL`]).
    pub symmetric: bool,
    /// A fast apply of `A` (a lattice stencil) and block rows the multigrid setup reads
    /// instead of a stored matrix, its own or its SPD companion's: `auto`'s matrix-free
    /// multigrid-CG ([`AutoParams::matrix_free`]).
    pub fast_apply: bool,
    /// An unsymmetric `A` applied matrix-free with an SPD companion that has block rows:
    /// `auto`'s matrix-free GMRES ([`AutoParams::gmres_matrix_free`]).
    pub companion_gmres: bool,
}

impl Offers {
    /// What the built `model` offers on the free DOFs `dofs`, `asymmetry` being
    /// `max |A - A^T| / max |A|` of its `A_ff` ([`Model::asymmetry`]).
    pub fn of_model(model: &dyn Model, dofs: &DofMap, asymmetry: f64) -> Offers {
        let symmetric = asymmetry <= SYMMETRY_RTOL;
        Offers {
            dim: model.dim(),
            unknowns: dofs.n_free(),
            symmetric,
            fast_apply: offers_matrix_free_cg(model),
            // a symmetric model's companion serves its multigrid, not GMRES (the LPS pair part)
            companion_gmres: !symmetric && offers_companion_gmres(model),
        }
    }
}

/// Whether `model` can run `auto`'s matrix-free multigrid-CG: it runs matrix-free, has a fast
/// apply (a lattice stencil) and block rows ([`Model::for_each_block`], which the multigrid
/// setup reads instead of a stored matrix), its own or its companion's
/// ([`Model::multigrid_companion`]).
pub(crate) fn offers_matrix_free_cg(model: &dyn Model) -> bool {
    let has_blocks = |m: &dyn Model| m.for_each_block(0, &mut |_, _| {});
    model.matrix_free_unavailable().is_none()
        && model.n_nodes() > 0
        && model.fast_apply().is_some()
        && model.multigrid_companion().map_or_else(|| has_blocks(model), |c| has_blocks(&*c))
}

/// Whether `model` can run `auto`'s matrix-free GMRES: it runs matrix-free and offers an SPD
/// companion with block rows ([`Model::multigrid_companion`], [`Model::for_each_block`]); of
/// linpd's models, the blend on a graded local mesh.
pub(crate) fn offers_companion_gmres(model: &dyn Model) -> bool {
    model.matrix_free_unavailable().is_none()
        && model.n_nodes() > 0
        && model.multigrid_companion().is_some_and(|c| c.for_each_block(0, &mut |_, _| {}))
}

/// How the solve applies `A`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Apply {
    /// `A_ff` is assembled and stored.
    Assembled,
    /// `A` is applied without a stored matrix.
    MatrixFree,
}

/// What runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// The user's matrix-free PCG with this preconditioner.
    MatrixFreeCg(PreconditionerKind),
    /// `auto`'s matrix-free multigrid-CG; assembled and chosen again when CG stalls above its
    /// tolerance (rounding), except on a companion's hierarchy.
    AutoMatrixFreeCg,
    /// `auto`'s matrix-free GMRES preconditioned by the multigrid of the SPD companion;
    /// assembled and chosen again when GMRES fails, where the assembly is affordable.
    AutoMatrixFreeGmres,
    /// `A_ff` assembled and solved by the spec (`auto`: by the cost model on the matrix).
    Assembled,
}

impl std::fmt::Display for Route {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Route::MatrixFreeCg(k) => write!(f, "matrix-free {}-CG", k.name()),
            Route::AutoMatrixFreeCg => write!(f, "auto's matrix-free multigrid-CG"),
            Route::AutoMatrixFreeGmres => write!(f, "auto's matrix-free GMRES + multigrid"),
            Route::Assembled => write!(f, "the assembled solve"),
        }
    }
}

/// Whether the solve builds a multigrid hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hierarchy {
    /// No hierarchy.
    None,
    /// A hierarchy is built (asked for, or `auto`'s matrix-free plan).
    Built,
    /// `auto` on the assembled matrix may build one: its cost model decides on the matrix.
    Possible,
}

/// The plan of a static solve ([`plan`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SolvePlan {
    /// The solver asked for.
    pub spec: SolverSpec,
    /// What runs.
    pub route: Route,
    /// The multigrid hierarchy it builds.
    pub hierarchy: Hierarchy,
    /// The preconditioners it sets up: the one asked for, `auto`'s matrix-free multigrid, or
    /// (`auto` on an assembled matrix, [`Hierarchy::Possible`]) each `auto` may choose; empty
    /// for a direct solve. The memory guard counts the largest setup
    /// ([`SolvePlan::setup_bytes`]).
    pub preconditioners: Vec<PreconditionerKind>,
    /// The offers it was planned from.
    pub offers: Offers,
}

impl SolvePlan {
    /// How `A` is applied.
    pub fn apply(&self) -> Apply {
        match self.route {
            Route::Assembled => Apply::Assembled,
            _ => Apply::MatrixFree,
        }
    }

    /// The bytes the preconditioner's setup adds on `on`: the largest of
    /// [`SolvePlan::preconditioners`]' ([`PreconditionerKind::hierarchy_bytes`]), 0 for none.
    pub fn setup_bytes(&self, on: &SetupOn) -> f64 {
        largest_setup(&self.preconditioners, on).map_or(0.0, |(bytes, _)| bytes)
    }
}

/// The plan of a solve of a model offering `offers` with `spec` (see the module docs):
///
/// * matrix-free CG when the spec asks for it;
/// * `auto`'s matrix-free multigrid-CG where [`AutoParams::matrix_free`] takes the model (a
///   symmetric `A` with a fast apply, from [`AutoParams::matrix_free_min_unknowns`] in 2D/3D);
/// * `auto`'s matrix-free GMRES for an unsymmetric `A` with a companion with block rows
///   ([`AutoParams::gmres_matrix_free`]);
/// * else the assembled `A_ff`, solved by the spec; `auto` there may build a multigrid
///   hierarchy in 2D and 3D ([`Hierarchy::Possible`]).
pub fn plan(spec: &SolverSpec, offers: &Offers, auto: &AutoParams) -> SolvePlan {
    let (dim, n) = (offers.dim, offers.unknowns);
    let multigrid = vec![PreconditionerKind::MULTIGRID];
    let (route, hierarchy, preconditioners) = match spec {
        SolverSpec::Cg { preconditioner, matrix_free: true, .. } => {
            (Route::MatrixFreeCg(*preconditioner), built_if(preconditioner.multilevel()), vec![*preconditioner])
        }
        SolverSpec::Auto(_) if auto.matrix_free(dim, n, offers.symmetric, || offers.fast_apply) => {
            (Route::AutoMatrixFreeCg, Hierarchy::Built, multigrid)
        }
        SolverSpec::Auto(_) if !offers.symmetric && auto.gmres_matrix_free(dim, n, || offers.companion_gmres) => {
            (Route::AutoMatrixFreeGmres, Hierarchy::Built, multigrid)
        }
        SolverSpec::Auto(_) if dim >= 2 => (Route::Assembled, Hierarchy::Possible, possible(offers, auto)),
        SolverSpec::Cg { preconditioner, .. } | SolverSpec::Gmres { preconditioner, .. } => {
            (Route::Assembled, built_if(preconditioner.multilevel()), vec![*preconditioner])
        }
        _ => (Route::Assembled, Hierarchy::None, Vec::new()),
    };
    SolvePlan { spec: spec.clone(), route, hierarchy, preconditioners, offers: *offers }
}

/// The preconditioners `auto` may set up on an assembled `A`: its candidates for a symmetric
/// one ([`AutoParams::preconditioners`]), multigrid and Jacobi for GMRES on an unsymmetric one
/// ([`AutoParams::plan_unsymmetric`]).
fn possible(offers: &Offers, auto: &AutoParams) -> Vec<PreconditionerKind> {
    if offers.symmetric {
        auto.preconditioners.clone()
    } else {
        vec![PreconditionerKind::MULTIGRID, PreconditionerKind::JACOBI]
    }
}

fn built_if(multigrid: bool) -> Hierarchy {
    if multigrid {
        Hierarchy::Built
    } else {
        Hierarchy::None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::krylov::cg::CgParams;

    fn offers(dim: usize, unknowns: usize, symmetric: bool, fast_apply: bool, companion_gmres: bool) -> Offers {
        Offers { dim, unknowns, symmetric, fast_apply, companion_gmres }
    }

    /// Every route, at and around `auto`'s thresholds, with the hierarchy each builds.
    #[test]
    fn routes_and_hierarchies() {
        let auto = AutoParams::default();
        let a = SolverSpec::Auto(CgParams::default());
        let n = auto.matrix_free_min_unknowns;
        let p = plan(&a, &offers(3, n, true, true, false), &auto);
        assert_eq!((p.route, p.hierarchy, p.apply()), (Route::AutoMatrixFreeCg, Hierarchy::Built, Apply::MatrixFree));
        let p = plan(&a, &offers(3, n - 1, true, true, false), &auto);
        assert_eq!((p.route, p.hierarchy), (Route::Assembled, Hierarchy::Possible));
        assert_eq!(plan(&a, &offers(3, n, true, false, false), &auto).route, Route::Assembled);
        // an unsymmetric model never takes matrix-free CG, a companion's GMRES from its size
        let g = auto.gmres_multigrid_2d_min_unknowns;
        assert_eq!(plan(&a, &offers(2, g, false, true, true), &auto).route, Route::AutoMatrixFreeGmres);
        assert_eq!(plan(&a, &offers(2, g - 1, false, true, true), &auto).route, Route::Assembled);
        assert_eq!(plan(&a, &offers(2, g, false, false, false), &auto).route, Route::Assembled);
        // 1D: auto is the Cholesky, no hierarchy
        let p = plan(&a, &offers(1, 10 * n, true, true, false), &auto);
        assert_eq!((p.route, p.hierarchy), (Route::Assembled, Hierarchy::None));
        // the user's solvers
        let cg =
            |preconditioner, matrix_free| SolverSpec::Cg { params: CgParams::default(), preconditioner, matrix_free };
        let p = plan(&cg(PreconditionerKind::MULTIGRID, true), &offers(2, 10, true, false, false), &auto);
        assert_eq!((p.route, p.hierarchy), (Route::MatrixFreeCg(PreconditionerKind::MULTIGRID), Hierarchy::Built));
        let p = plan(&cg(PreconditionerKind::JACOBI, false), &offers(3, 10 * n, true, true, false), &auto);
        assert_eq!((p.route, p.hierarchy), (Route::Assembled, Hierarchy::None));
        let p = plan(&SolverSpec::Cholesky, &offers(3, 10 * n, true, true, false), &auto);
        assert_eq!((p.route, p.hierarchy), (Route::Assembled, Hierarchy::None));
    }
}
