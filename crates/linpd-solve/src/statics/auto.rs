//! `auto` as a plan: pure functions from the sizes, the capabilities and the cost estimates of
//! a system to the solver `auto` runs, with its thresholds in [`AutoParams`]. Running the plan
//! (the Cholesky analysis the estimates need, the runners, the fallbacks when a choice fails)
//! is left to [`super::solve_assembled`] and [`super::solve_model`].
//!
//! * [`AutoParams::matrix_free`]: matrix-free multigrid-CG on the model, without assembling;
//! * [`AutoParams::factor_excluded`]: a factorization refused by size before its analysis;
//! * [`plan_symmetric`]: the cheapest of the estimates of [`crate::cost`] for a symmetric `A`;
//! * [`AutoParams::plan_unsymmetric`]: the order of the attempts for an unsymmetric `A` with
//!   an SPD approximation `M`.

use crate::cost::Estimate;
use crate::spec::PreconditionerKind;

/// When CG stalls above `rtol` (rounding), `auto` keeps its iterate if the residual reached is
/// within this factor of the system's rounding floor `u || |A| |x| || / ||b||`
/// (`runners::rounding_residual`): there no solver certifies much less. Measured on a
/// 12-across corrected cantilever (47,520 unknowns, `tests/robust_solver.rs`): floor 8.3e-11,
/// multigrid-CG stalled at 1.17e-10 (1.4x), the sparse Cholesky reached 1.13e-10 (1.4x) in 2.3x
/// the time. A decade leaves room for the CG recurrence's own drift and keeps a stall far
/// above the floor (a CG that is not converging) on the fallback to the Cholesky.
pub const AT_ROUNDING_FLOOR: f64 = 10.0;

/// The thresholds of `auto`; [`Default`] holds the measured values below.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AutoParams {
    /// Unknowns from which `auto` runs matrix-free multigrid-CG where it can
    /// ([`AutoParams::matrix_free`]). Below, the assembled `auto` chooses as before: there a
    /// sparse Cholesky is about as fast and exact to rounding (CG stops at `rtol`), and it is
    /// what the cost model picks for the small scenes (the bench's iterative choices start at
    /// 21k unknowns, the 101^2 plate). Default 20,000.
    pub matrix_free_min_unknowns: usize,
    /// Above this many unknowns in 3D, `auto` does not even run the Cholesky symbolic analysis:
    /// the fill of nested dissection grows as `n^(4/3)` and at 100k unknowns with `delta = 3h`
    /// (a 32^3 cube) it is already ~1e9 entries, past [`crate::cost::CHOLESKY_MEMORY_LIMIT`].
    /// Default 100,000.
    pub cholesky_3d_max_unknowns: usize,
    /// From this many unknowns `auto` solves an unsymmetric 2D or 3D system with an SPD
    /// approximation `M` (the lattice blends) by GMRES + multigrid from `M` before trying the
    /// Cholesky factor of `M`. Measured on the edge-cracked blend of `linpd study blend-2d`
    /// (radius 2; solver seconds, GMRES + multigrid to rtol 1e-10 against the Cholesky of `M` +
    /// GMRES): 20k unknowns 0.073 s against 0.178 s, 80k 0.37 against 0.81, 180k 0.58 against
    /// 1.92, 320k 1.21 against 4.07 (the factor's triangular solves make each of its 14 GMRES
    /// iterations dearer than the 29 of the multigrid). In 3D on a 21^3 blended cube (47,385
    /// unknowns, transition 2 horizons): 33 iterations, 2.8 s against 24.5 s. (With transitions
    /// of one horizon GMRES + multigrid stagnates in 3D, and so does the Cholesky of `M`: the
    /// transition terms `M` leaves out are then `O(1)` of a row; `"pd_regions": "auto"` takes 2
    /// horizons in 3D for that, docs/models.md.) Default 20,000.
    pub gmres_multigrid_2d_min_unknowns: usize,
    /// The preconditioners whose PCG `auto` weighs against the sparse Cholesky on a symmetric
    /// assembled `A` ([`plan_symmetric`], each by its [`PreconditionerKind::auto_estimate`]).
    /// Default: the registry, [`crate::precond::kind::PRECONDITIONERS`].
    pub preconditioners: Vec<PreconditionerKind>,
}

impl Default for AutoParams {
    fn default() -> Self {
        AutoParams {
            matrix_free_min_unknowns: 20_000,
            cholesky_3d_max_unknowns: 100_000,
            gmres_multigrid_2d_min_unknowns: 20_000,
            preconditioners: crate::precond::kind::PRECONDITIONERS.to_vec(),
        }
    }
}

/// What `auto` runs on a symmetric `A` in 2D/3D.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutoChoice {
    /// Sparse Cholesky.
    Cholesky,
    /// PCG with this preconditioner.
    Cg(PreconditionerKind),
}

/// `auto`'s plan for a symmetric `A` in 2D/3D ([`plan_symmetric`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricPlan {
    /// The candidate with the smallest estimate (Jacobi-PCG when every candidate is excluded).
    pub choice: AutoChoice,
    /// The estimates, `; `-separated (the report's `auto` field).
    pub estimates: String,
    /// Whether a PCG choice falls back to the Cholesky when CG stops above `rtol` because
    /// rounding limits its attainable residual: only when the Cholesky estimate kept the
    /// factorization (not past the memory limit).
    pub cholesky_fallback: bool,
}

/// `auto`'s plan for an unsymmetric `A` with an SPD approximation `M`
/// ([`AutoParams::plan_unsymmetric`]): GMRES + multigrid from `M` first when
/// [`UnsymmetricPlan::multigrid_first`]; else, or when that fails (stagnation, `max_iter`),
/// GMRES with the Cholesky factor of `M` unless [`UnsymmetricPlan::factor_excluded`]; then
/// GMRES + multigrid (when [`UnsymmetricPlan::multigrid_fallback`]), GMRES + Jacobi (when
/// [`UnsymmetricPlan::jacobi_before_lu`]) and sparse LU, each when the one before failed or was
/// excluded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnsymmetricPlan {
    /// GMRES + multigrid from `M` before the factor of `M`, and why (`None`: not first).
    pub multigrid_first: Option<String>,
    /// Why the factor of `M` is not even analysed (`None`: it is, and may still be refused by
    /// its size in memory).
    pub factor_excluded: Option<String>,
    /// GMRES + multigrid from `M` when the factor of `M` is excluded, would not fit or failed
    /// (it needs the DOF geometry).
    pub multigrid_fallback: bool,
    /// GMRES + Jacobi before sparse LU (3D, where LU fills badly: see `auto_unsymmetric`).
    pub jacobi_before_lu: bool,
}

impl AutoParams {
    /// Whether `auto` runs matrix-free multigrid-CG on a model with `n_free` unknowns in
    /// dimension `dim`: a `symmetric` operator in 2D/3D, at least
    /// [`AutoParams::matrix_free_min_unknowns`], and `capable()`: the model has a fast apply
    /// (the lattice stencil of a homogeneous bond model) and its block rows (which the
    /// multigrid setup reads instead of a stored matrix); `capable` is only asked when the
    /// sizes qualify. Measured (docs/solvers.md, `linpd bench --statics`): faster than every
    /// assembled solver at every 2D and 3D size from there, 2.3-3.1x faster than the assembled
    /// multigrid in 3D, with a fifth of its memory.
    pub fn matrix_free(&self, dim: usize, n_free: usize, symmetric: bool, capable: impl FnOnce() -> bool) -> bool {
        n_free >= self.matrix_free_min_unknowns && dim >= 2 && symmetric && capable()
    }

    /// Whether `auto` runs GMRES matrix-free on an unsymmetric model of `n_free` unknowns in
    /// dimension `dim`, preconditioned by the multigrid of its SPD companion: where the
    /// assembled plan runs GMRES + multigrid from `M` first ([`AutoParams::plan_unsymmetric`],
    /// 2D and 3D from [`AutoParams::gmres_multigrid_2d_min_unknowns`]) and `capable()`: the
    /// model runs matrix-free and offers a companion with block rows (the graded blend, whose
    /// `A` is never stored whole). The same iterations as assembled, without `A_ff` and
    /// `M_ff`.
    pub fn gmres_matrix_free(&self, dim: usize, n_free: usize, capable: impl FnOnce() -> bool) -> bool {
        dim >= 2 && n_free >= self.gmres_multigrid_2d_min_unknowns && capable()
    }

    /// Why `auto` refuses to factor (sparse Cholesky of `A` or of `M`) a system of `n` unknowns
    /// in dimension `dim` without analysing it: in 3D past
    /// [`AutoParams::cholesky_3d_max_unknowns`] (`None`: it analyses it).
    pub fn factor_excluded(&self, dim: usize, n: usize) -> Option<String> {
        let limit = self.cholesky_3d_max_unknowns;
        (dim == 3 && n > limit).then(|| format!("3D with {n} > {limit} unknowns"))
    }

    /// The plan for an unsymmetric `A` of `n` unknowns in dimension `dim` with an SPD
    /// approximation `M` (see [`UnsymmetricPlan`]): multigrid first in 2D and 3D from
    /// [`AutoParams::gmres_multigrid_2d_min_unknowns`] (measured faster than the Cholesky of
    /// `M`, see the field), the factor of `M` excluded in 3D past
    /// [`AutoParams::cholesky_3d_max_unknowns`] (LU would fill at least as much); both
    /// multigrid paths need the DOF geometry (`has_geometry`).
    pub fn plan_unsymmetric(&self, dim: usize, n: usize, has_geometry: bool) -> UnsymmetricPlan {
        let limit = self.gmres_multigrid_2d_min_unknowns;
        UnsymmetricPlan {
            multigrid_first: (dim >= 2 && n >= limit && has_geometry)
                .then(|| format!("{dim}D, {n} >= {limit} unknowns")),
            factor_excluded: self.factor_excluded(dim, n),
            multigrid_fallback: has_geometry,
            jacobi_before_lu: dim == 3,
        }
    }
}

/// The plan for a symmetric `A` in 2D/3D from the estimates of [`crate::cost`]: the cheapest
/// of the sparse Cholesky and PCG with each preconditioner offered (`pcg`: those of
/// [`AutoParams::preconditioners`] with an estimate, [`PreconditionerKind::auto_estimate`]);
/// the first of equal estimates; Jacobi-PCG when all are excluded.
pub fn plan_symmetric(cholesky: &Estimate, pcg: &[(PreconditionerKind, Estimate)]) -> SymmetricPlan {
    let mut candidates = vec![(cholesky, AutoChoice::Cholesky)];
    candidates.extend(pcg.iter().map(|(k, e)| (e, AutoChoice::Cg(*k))));
    let estimates = candidates.iter().map(|(e, _)| e.to_string()).collect::<Vec<_>>().join("; ");
    let choice = candidates
        .iter()
        .filter_map(|(e, choice)| e.seconds.map(|s| (s, *choice)))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map_or(AutoChoice::Cg(PreconditionerKind::JACOBI), |(_, choice)| choice);
    SymmetricPlan { choice, estimates, cholesky_fallback: cholesky.seconds.is_some() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimate(solver: &str, seconds: Option<f64>) -> Estimate {
        Estimate { solver: solver.into(), seconds, why: "test".into() }
    }

    /// The cheapest candidate wins, the first of equal ones, Jacobi-PCG when all are excluded;
    /// the fallback to the Cholesky only when its estimate kept it.
    #[test]
    fn symmetric_plan_picks_the_cheapest() {
        let chol = estimate("cholesky-nd", Some(2.0));
        let jacobi = estimate("cg-jacobi", Some(3.0));
        let mg = estimate("cg-multigrid", Some(1.0));
        let (j, m) = (PreconditionerKind::JACOBI, PreconditionerKind::MULTIGRID);
        let plan = plan_symmetric(&chol, &[(j, jacobi.clone()), (m, mg.clone())]);
        assert_eq!(plan.choice, AutoChoice::Cg(PreconditionerKind::MULTIGRID));
        assert!(plan.cholesky_fallback);
        assert_eq!(plan.estimates, format!("{chol}; {jacobi}; {mg}"));
        assert_eq!(plan_symmetric(&chol, &[(j, jacobi)]).choice, AutoChoice::Cholesky);
        assert_eq!(plan_symmetric(&chol, &[(j, estimate("cg-jacobi", Some(2.0)))]).choice, AutoChoice::Cholesky);
        let excluded = estimate("cholesky", None);
        let plan = plan_symmetric(&excluded, &[(j, estimate("cg-jacobi", None))]);
        assert_eq!(plan.choice, AutoChoice::Cg(PreconditionerKind::JACOBI));
        assert!(!plan.cholesky_fallback);
    }

    /// The thresholds, at and around their defaults.
    #[test]
    fn size_rules() {
        let p = AutoParams::default();
        assert!(p.matrix_free(2, 20_000, true, || true));
        assert!(!p.matrix_free(2, 19_999, true, || true));
        assert!(!p.matrix_free(1, 50_000, true, || true));
        assert!(!p.matrix_free(3, 50_000, false, || true));
        assert!(!p.matrix_free(3, 50_000, true, || false));
        assert!(!p.matrix_free(3, 10, true, || panic!("capabilities asked for a small system")));
        assert_eq!(p.factor_excluded(3, 100_000), None);
        assert_eq!(p.factor_excluded(3, 100_001).as_deref(), Some("3D with 100001 > 100000 unknowns"));
        assert_eq!(p.factor_excluded(2, 1_000_000), None);
        let plan = p.plan_unsymmetric(2, 20_000, true);
        assert_eq!(plan.multigrid_first.as_deref(), Some("2D, 20000 >= 20000 unknowns"));
        assert_eq!(p.plan_unsymmetric(2, 20_000, false).multigrid_first, None);
        assert_eq!(
            p.plan_unsymmetric(3, 200_000, true).multigrid_first.as_deref(),
            Some("3D, 200000 >= 20000 unknowns")
        );
        assert_eq!(p.plan_unsymmetric(1, 200_000, true).multigrid_first, None);
        assert!(p.plan_unsymmetric(3, 200_000, true).factor_excluded.is_some());
        assert!(p.gmres_matrix_free(3, 20_000, || true));
        assert!(!p.gmres_matrix_free(3, 19_999, || true));
        assert!(!p.gmres_matrix_free(1, 50_000, || true));
        assert!(!p.gmres_matrix_free(2, 50_000, || false));
        assert!(!p.gmres_matrix_free(3, 10, || panic!("capabilities asked for a small system")));
    }
}
