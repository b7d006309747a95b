//! The solver dispatch on an assembled matrix ([`solve_assembled`]): `spec` (or, for an
//! unsymmetric `A`, sparse LU whatever was asked, with the exceptions listed there) to the
//! runners of [`super::runners`], `auto` by the plans of [`super::auto`] with their fallbacks,
//! then the checks of the solution and its residual ([`super::guards`]).

use super::auto::{plan_symmetric, AutoChoice, AutoParams, AT_ROUNDING_FLOOR};
use super::guards::{check_residual, finite_matrix, finite_vector};
use super::runners::{
    analyze_cholesky, assembled_cg, assembled_cg_iterate, assembled_gmres, assembled_gmres_with, cholesky, dense,
    dense_lu, lu, rounding_residual, spd_gmres, Solved, SpdGmres,
};
use crate::cost;
use crate::krylov::cg::{CgError, CgParams};
use crate::precond::kind::AutoInput;
use crate::precond::DofGeometry;
use crate::report::{peak_rss_bytes, SolveReport};
use crate::spec::{PreconditionerKind, SolverId, SolverSpec};
use crate::SolveError;
use linpd_core::progress::{NoProgress, Progress, Task};
use linpd_core::sparse::{relative_residual, Csc, SYMMETRY_RTOL};
use linpd_core::{Ordering, SpdApproximation};
use std::time::Instant;

/// What [`solve_assembled`] needs to know about the matrix besides its entries.
#[derive(Debug, Clone)]
pub struct MatrixHints {
    /// Spatial dimension (for `auto`).
    pub dim: usize,
    /// `max |A - A^T| / max |A|`: above [`SYMMETRY_RTOL`] the solve is a sparse LU (or, under
    /// `auto` with [`MatrixHints::spd`], GMRES) whatever was asked.
    pub asymmetry: f64,
    /// Fill-reducing ordering for a sparse Cholesky ([`Ordering::Band`] also keeps the band in LU).
    pub ordering: Ordering,
    /// For an unsymmetric `A`: an SPD approximation whose Cholesky factor preconditions GMRES
    /// under `auto`.
    pub spd: Option<SpdApproximation>,
    /// Where the unknowns sit (for multilevel preconditioners; `None`: a bare matrix).
    pub geometry: Option<DofGeometry>,
    /// Nodes along the body's longest side ([`crate::cost::nodes_along_longest_side`]), for
    /// `auto`'s iteration estimates (`None`: `(n / dim)^(1/dim)`, a cube).
    pub n_side: Option<f64>,
}

impl MatrixHints {
    /// A symmetric matrix in dimension `dim`, AMD ordering.
    pub fn symmetric(dim: usize) -> Self {
        MatrixHints { dim, asymmetry: 0.0, ordering: Ordering::Amd, spd: None, geometry: None, n_side: None }
    }
}

/// Solves the assembled system `A u = f` with `spec` and reports what it cost; the residual
/// is recomputed with the symmetric product for symmetric `A`, the general one otherwise.
///
/// An unsymmetric `A` is solved by sparse LU whatever was asked (with a `note` in the report
/// when something else was), except: `dense` runs a dense LU, `gmres` runs GMRES, and `auto`
/// with an SPD approximation `M` ([`MatrixHints::spd`]) runs GMRES preconditioned by multigrid
/// from `M` (2D from [`AutoParams::gmres_multigrid_2d_min_unknowns`] unknowns, and where the
/// factor of `M` would not fit) or by the Cholesky factor of `M`, each falling back to the next
/// (with a note) if it fails: multigrid to the Cholesky of `M`, the Cholesky of `M` to sparse LU.
pub fn solve_assembled(
    a: &Csc,
    f: &[f64],
    spec: &SolverSpec,
    hints: &MatrixHints,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    solve_assembled_with_progress(a, f, spec, hints, &NoProgress)
}

/// [`solve_assembled`] reporting to `progress`: the iterations of CG and GMRES
/// ([`crate::pcg_with_progress`]) and a task with no steps around each factorization.
pub fn solve_assembled_with_progress(
    a: &Csc,
    f: &[f64],
    spec: &SolverSpec,
    hints: &MatrixHints,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    solve_assembled_with_auto(a, f, spec, hints, &AutoParams::default(), progress)
}

/// [`solve_assembled_with_progress`] with `auto`'s thresholds and candidate preconditioners
/// `auto` (e.g. the registry's and one more).
pub fn solve_assembled_with_auto(
    a: &Csc,
    f: &[f64],
    spec: &SolverSpec,
    hints: &MatrixHints,
    auto: &AutoParams,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    finite_matrix(a)?;
    finite_vector("the load vector", f)?;
    let symmetric = hints.asymmetry <= SYMMETRY_RTOL;
    let resolved = spec.resolve(hints.dim, a.nrows());
    let t0 = Instant::now();
    let ((u, mut report), notes) = if symmetric {
        (symmetric_solve(a, f, &resolved, hints, auto, progress)?, Vec::new())
    } else {
        unsymmetric_solve(a, f, spec, &resolved, hints, auto, progress)?
    };
    finite_vector("the solution", &u)?;
    // a note of the solver path (auto's fallback) comes first
    report.notes.extend(notes);
    report.timings.total = t0.elapsed().as_secs_f64();
    report.rel_residual = relative_residual(a, symmetric, &u, f);
    report.peak_rss_bytes = peak_rss_bytes();
    check_residual(&report)?;
    Ok((u, report))
}

/// A symmetric `A`: the solver `resolved` names.
fn symmetric_solve(
    a: &Csc,
    f: &[f64],
    resolved: &SolverSpec,
    hints: &MatrixHints,
    auto: &AutoParams,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let geometry = hints.geometry.as_ref();
    match resolved {
        SolverSpec::Auto(params) => auto_symmetric(a, f, params, hints, auto, progress),
        SolverSpec::Cholesky => cholesky(a, f, analyze_cholesky(a, &hints.ordering)?, progress),
        SolverSpec::Lu => lu(a, f, &hints.ordering, progress),
        SolverSpec::Dense => dense(a, f),
        SolverSpec::Cg { params, preconditioner, matrix_free: _ } => {
            assembled_cg(a, f, params, *preconditioner, geometry, progress)
        }
        SolverSpec::Gmres { params, preconditioner } => {
            assembled_gmres(a, f, params, *preconditioner, geometry, progress)
        }
    }
}

/// An unsymmetric `A`: dense LU, sparse LU or GMRES when asked, `auto` with an SPD
/// approximation by its plan, sparse LU otherwise; with the note of what ran instead of what
/// was asked, if anything.
fn unsymmetric_solve(
    a: &Csc,
    f: &[f64],
    spec: &SolverSpec,
    resolved: &SolverSpec,
    hints: &MatrixHints,
    auto: &AutoParams,
    progress: &dyn Progress,
) -> Result<(Solved, Vec<String>), SolveError> {
    Ok(match (resolved, &hints.spd) {
        (SolverSpec::Dense, _) => (dense_lu(a, f)?, Vec::new()),
        (SolverSpec::Lu, _) => (lu(a, f, &hints.ordering, progress)?, Vec::new()),
        (SolverSpec::Gmres { params, preconditioner }, spd) => {
            // the preconditioner from the SPD approximation (the symmetric part by default;
            // borrowed: a 3D blend's M is ~1 GB)
            let m = match spd {
                Some(spd) => std::borrow::Cow::Borrowed(&spd.matrix),
                None => std::borrow::Cow::Owned(linpd_core::sparse::symmetric_part(a)),
            };
            let geometry = hints.geometry.as_ref();
            (assembled_gmres_with(a, &m, f, params, *preconditioner, geometry, progress)?, Vec::new())
        }
        // `auto` asked (in 1D it resolves to a direct solver name, hence `spec`, not `resolved`)
        (_, Some(spd)) if matches!(spec, SolverSpec::Auto(_)) => {
            let params = match spec {
                SolverSpec::Auto(params) => params.clone(),
                _ => CgParams::default(),
            };
            auto_unsymmetric(a, f, spd, &params, hints, auto, progress)?
        }
        (s, _) => {
            let note = format!(
                "{s} asked, sparse LU used: A is unsymmetric (relative asymmetry {:.2e} > {SYMMETRY_RTOL:e})",
                hints.asymmetry
            );
            (lu(a, f, &hints.ordering, progress)?, vec![note])
        }
    })
}

/// `auto` on a symmetric `A` in 2D/3D: the cheapest of sparse Cholesky, Jacobi-PCG and (when
/// the DOF geometry is known) multigrid-PCG by [`crate::cost`] ([`plan_symmetric`], after the
/// Cholesky analysis its estimate needs unless [`AutoParams::factor_excluded`]); the report's
/// `auto` field lists the estimates.
fn auto_symmetric(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    hints: &MatrixHints,
    auto: &AutoParams,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let (n, dim) = (a.nrows(), hints.dim);
    let n_side = hints.n_side.unwrap_or_else(|| (n as f64 / dim as f64).powf(1.0 / dim as f64));
    let mut analyzed = None;
    let chol = match auto.factor_excluded(dim, n) {
        Some(why) => cost::Estimate { solver: "cholesky".into(), seconds: None, why },
        None => {
            let task = Task::start(progress, "Cholesky symbolic analysis (auto's estimate)", None);
            let (c, label, t) = analyze_cholesky(a, &hints.ordering)?;
            drop(task);
            let e = cost::cholesky(&c, SolverId::Cholesky(label).to_string());
            analyzed = Some((c, label, t));
            e
        }
    };
    // each registered preconditioner's estimate (multigrid's only with the DOF geometry, its
    // rigid-body modes)
    let input = AutoInput { dim, nnz: a.val().len(), n_side, params, geometry: hints.geometry.is_some() };
    let pcg: Vec<_> = auto.preconditioners.iter().filter_map(|k| k.auto_estimate(&input).map(|e| (*k, e))).collect();
    let plan = plan_symmetric(&chol, &pcg);
    let (u, mut report) = match (plan.choice, analyzed) {
        (AutoChoice::Cholesky, Some(analysis)) => cholesky(a, f, analysis, progress)?,
        (choice, analyzed) => {
            let p = match choice {
                AutoChoice::Cg(p) => p,
                AutoChoice::Cholesky => PreconditionerKind::default(),
            };
            let (u, mut report, outcome) = assembled_cg_iterate(a, f, params, p, hints.geometry.as_ref(), progress)?;
            match outcome {
                Ok(()) => (u, report),
                // CG stopped above rtol because rounding limits its attainable residual. At the
                // system's rounding floor no solver does much better (a direct solve included):
                // keep the iterate and say so. Above it, fall back to the direct solve auto has
                // analyzed (when the estimate kept the factorization: not past the memory limit)
                // rather than fail where another solver works.
                Err(e @ CgError::ResidualAboveTarget { rel_residual, .. }) => {
                    let floor = rounding_residual(a, &u, f);
                    let stall = format!(
                        "CG stalled at a relative residual of {rel_residual:.3e} (rtol {:e}); the rounding floor \
                         u |||A| |u||| / ||f|| of this system is {floor:.2e}",
                        params.rtol
                    );
                    if rel_residual <= AT_ROUNDING_FLOOR * floor {
                        report.notes.insert(0, format!("auto: {stall}: within {AT_ROUNDING_FLOOR} x the floor, where no solver certifies much less; kept the CG solution (solver.type cholesky for a direct solve)"));
                        (u, report)
                    } else if analyzed.is_some() && plan.cholesky_fallback {
                        let (u, mut report) = cholesky(a, f, analyzed.expect("checked"), progress)?;
                        report.notes.insert(0, format!("auto: {stall}; fell back to the Cholesky solve"));
                        (u, report)
                    } else {
                        return Err(e.into());
                    }
                }
                Err(e) => return Err(e.into()),
            }
        }
    };
    report.auto = Some(plan.estimates);
    Ok((u, report))
}

/// `auto` on an unsymmetric `A` with an SPD approximation `M`, by the plan of
/// [`AutoParams::plan_unsymmetric`], each next choice running when the one before failed or
/// was excluded:
/// 1. GMRES + multigrid from `M`, first only in 2D from
///    [`AutoParams::gmres_multigrid_2d_min_unknowns`] unknowns (measured faster than the
///    Cholesky of `M`, see the field);
/// 2. GMRES with the Cholesky factor of `M`, unless it would not fit or the system is 3D past
///    [`AutoParams::cholesky_3d_max_unknowns`];
/// 3. GMRES + multigrid (when it was not first and the DOF geometry is known);
/// 4. in 3D, GMRES + Jacobi (the diagonal of `M`);
/// 5. sparse LU, refused before its numeric factorization when its fill bound does not fit
///    ([`crate::Lu::factor_bytes`]).
///
/// Jacobi comes before LU in 3D because LU fills badly there: on a 21^3 blended cube (47,385
/// unknowns, `delta = 3h`) the factor of `M` + GMRES stagnated at 7.8e-8, and LU then took
/// 157 s and 12.0 GiB where GMRES + Jacobi took 21 s and 1.4 GiB (docs/solvers.md).
/// Returns the notes that say what ran and why.
fn auto_unsymmetric(
    a: &Csc,
    f: &[f64],
    spd: &SpdApproximation,
    params: &CgParams,
    hints: &MatrixHints,
    auto: &AutoParams,
    progress: &dyn Progress,
) -> Result<(Solved, Vec<String>), SolveError> {
    let plan = auto.plan_unsymmetric(hints.dim, a.nrows(), hints.geometry.is_some());
    let iterative = |kind: PreconditionerKind| {
        assembled_gmres_with(a, &spd.matrix, f, params, kind, hints.geometry.as_ref(), progress)
    };
    let mut notes = Vec::new();
    if let Some(why) = &plan.multigrid_first {
        match iterative(PreconditionerKind::MULTIGRID) {
            Ok(solved) => {
                let note = format!("auto: gmres + multigrid from the SPD approximation {:?} ({why})", spd.kind);
                return Ok((solved, vec![note]));
            }
            Err(e) => notes.push(format!("auto: gmres + multigrid failed ({e})")),
        }
    }
    let factored = match plan.factor_excluded {
        Some(why) => Err(SpdGmres::TooLarge(why)),
        None => spd_gmres(a, f, spd, &hints.ordering, progress),
    };
    match factored {
        Ok(solved) => return Ok((solved, notes)),
        Err(SpdGmres::TooLarge(why)) => notes.push(format!("auto: {} excluded ({why})", SolverId::Gmres(spd.kind))),
        Err(SpdGmres::Failed(why)) => notes.push(format!("auto: {} failed ({why})", SolverId::Gmres(spd.kind))),
    }
    let mut kinds = Vec::new();
    if plan.multigrid_first.is_none() && plan.multigrid_fallback {
        kinds.push(PreconditionerKind::MULTIGRID);
    }
    if plan.jacobi_before_lu {
        kinds.push(PreconditionerKind::JACOBI);
    }
    for kind in kinds {
        match iterative(kind) {
            Ok(solved) => {
                notes.push(format!("auto: gmres + {} ran", kind.name()));
                return Ok((solved, notes));
            }
            Err(e) => notes.push(format!("auto: gmres + {} failed ({e})", kind.name())),
        }
    }
    match lu(a, f, &hints.ordering, progress) {
        Ok(solved) => {
            notes.push("auto: sparse LU used".into());
            Ok((solved, notes))
        }
        Err(e) => Err(SolveError::NoSolverFits(format!("{}; and sparse LU: {e}", notes.join("; ")))),
    }
}
