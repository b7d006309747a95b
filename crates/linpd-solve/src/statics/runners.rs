//! The runners: each solves `A u = f` (or `A_ff u_f = rhs`) with one solver and fills the
//! [`SolveReport`] of what it did (timings, factor size, iterations). On an assembled matrix:
//! sparse Cholesky ([`analyze_cholesky`], [`cholesky`]), sparse LU ([`lu`]), dense Cholesky and
//! LU ([`dense`], [`dense_lu`]), PCG ([`assembled_cg`]), GMRES with an iterative preconditioner
//! ([`assembled_gmres`], [`assembled_gmres_with`]) or with the Cholesky factor of an SPD
//! approximation ([`spd_gmres`]); without assembling: PCG on the model's apply
//! ([`matrix_free_cg`]). Which one runs is [`super::assembled`]'s and [`super::dispatch`]'s.

use super::guards::{factor_fits, finite_vector, nonzero_diagonal, REDUCED_LOAD};
use crate::bc::ReducedOperator;
use crate::direct::{dense_lu_solve, dense_solve, Cholesky, Lu, LuOrdering};
use crate::krylov::cg::{pcg_with_progress, CgError, CgParams};
use crate::krylov::gmres::{gmres_with_progress, GmresParams};
use crate::precond::kind::{ModelInput, PreconditionerInput};
use crate::precond::{AmgParams, CoarseSpace, DofGeometry, FactorPreconditioner, LatticeMultigrid, Preconditioner};
use crate::report::{peak_rss_bytes, SolveReport};
use crate::spec::{CholeskyOrdering, MatrixFree, PreconditionerKind, SolverId, SolverSpec};
use crate::SolveError;
use linpd_core::progress::{Progress, Task};
use linpd_core::sparse::{diagonal, Csc, GeneralCsc, SymCsc};
use linpd_core::{DofMap, LinearOperator, Model, ModelOperator, Ordering, SpdApproximation};
use std::time::Instant;

/// A solution and the report of its solve.
pub(super) type Solved = (Vec<f64>, SolveReport);

/// The symbolic analysis of a sparse Cholesky in the model's ordering, timed.
pub(super) fn analyze_cholesky(a: &Csc, ordering: &Ordering) -> Result<(Cholesky, CholeskyOrdering, f64), SolveError> {
    let n = a.nrows();
    let natural: Vec<usize>;
    let (perm, label) = match ordering {
        Ordering::Amd => (None, CholeskyOrdering::Amd),
        Ordering::Natural | Ordering::Band => {
            natural = (0..n).collect();
            let label = if *ordering == Ordering::Band { CholeskyOrdering::Band } else { CholeskyOrdering::Natural };
            (Some(natural.as_slice()), label)
        }
        Ordering::NestedDissection(p) => (Some(p.as_slice()), CholeskyOrdering::NestedDissection),
    };
    let t = Instant::now();
    let chol = Cholesky::analyze_with_ordering(a, perm)?;
    Ok((chol, label, t.elapsed().as_secs_f64()))
}

/// Sparse Cholesky from its symbolic analysis ([`analyze_cholesky`]).
pub(super) fn cholesky(
    a: &Csc,
    f: &[f64],
    (chol, label, t_symbolic): (Cholesky, CholeskyOrdering, f64),
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let mut report = SolveReport::new(SolverId::Cholesky(label), a.nrows(), a.val().len());
    report.timings.symbolic = t_symbolic;
    let t = Instant::now();
    let task = Task::start(progress, "Cholesky factorization", None);
    let factor = chol.factor(a)?;
    drop(task);
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(chol.nnz_factor());
    report.factor_flops = Some(chol.flops());
    report.factor_bytes = Some(chol.factor_bytes());
    let t = Instant::now();
    let u = factor.solve(f);
    report.timings.solve = t.elapsed().as_secs_f64();
    Ok((u, report))
}

/// Dense Cholesky (small systems).
pub(super) fn dense(a: &Csc, f: &[f64]) -> Result<Solved, SolveError> {
    let n = a.nrows();
    let mut report = SolveReport::new(SolverId::Dense, n, a.val().len());
    let t = Instant::now();
    let u = dense_solve(a, f)?;
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(n * (n + 1) / 2);
    Ok((u, report))
}

/// Dense LU with partial pivoting (small unsymmetric systems).
pub(super) fn dense_lu(a: &Csc, f: &[f64]) -> Result<Solved, SolveError> {
    let n = a.nrows();
    let mut report = SolveReport::new(SolverId::DenseLu, n, a.val().len());
    let t = Instant::now();
    let u = dense_lu_solve(a, f)?;
    lu_finite(a, &u, SolverId::DenseLu)?;
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(n * n);
    Ok((u, report))
}

/// Sparse LU with partial pivoting: COLAMD, or the natural order for a banded model.
pub(super) fn lu(a: &Csc, f: &[f64], ordering: &Ordering, progress: &dyn Progress) -> Result<Solved, SolveError> {
    let (how, id) = match ordering {
        Ordering::Band => (LuOrdering::Band, SolverId::LuBand),
        _ => (LuOrdering::Colamd, SolverId::Lu),
    };
    let mut report = SolveReport::new(id, a.nrows(), a.val().len());
    let t = Instant::now();
    let lu = Lu::analyze(a, how)?;
    report.timings.symbolic = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let task = Task::start(progress, "LU factorization", None);
    let factor = lu.factor(a)?;
    drop(task);
    report.timings.numeric = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let u = factor.solve(f);
    lu_finite(a, &u, id)?;
    report.timings.solve = t.elapsed().as_secs_f64();
    // faer does not expose the LU fill: the bound of the analysis (L and U)
    report.nnz_factor = Some(2 * lu.fill_bound());
    report.factor_bytes = Some(lu.factor_bytes());
    Ok((u, report))
}

/// `Ok` when the LU solution `u` is finite; else (the callers checked `A` and `f` finite: a
/// zero pivot, not an overflow) the singularity, at the first zero diagonal entry if any.
fn lu_finite(a: &Csc, u: &[f64], solver: SolverId) -> Result<(), SolveError> {
    if u.iter().all(|x| x.is_finite()) {
        return Ok(());
    }
    nonzero_diagonal(&solver.to_string(), &diagonal(a), false)?;
    Err(SolveError::ZeroPivot { solver })
}

/// Preconditioned CG on the assembled `A`.
pub(super) fn assembled_cg(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let (u, report, outcome) = assembled_cg_iterate(a, f, params, preconditioner, geometry, progress)?;
    outcome?;
    Ok((u, report))
}

/// The last CG iterate, its report and how CG ended ([`assembled_cg_iterate`]).
pub(super) type CgIterate = (Vec<f64>, SolveReport, Result<(), CgError>);

/// [`assembled_cg`] that keeps the last iterate when CG fails: `(u, report, outcome)`, the
/// report's iterations and timings filled either way. `auto` reads a stalled iterate with
/// [`rounding_residual`].
pub(super) fn assembled_cg_iterate(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<CgIterate, SolveError> {
    let id = SolverId::Cg { preconditioner, matrix_free: MatrixFree::No };
    let mut report = SolveReport::new(id, a.nrows(), a.val().len());
    let t = Instant::now();
    let diag = diagonal(a);
    let task = Task::start(progress, &format!("{} preconditioner setup", preconditioner.name()), None);
    let m_inv =
        preconditioner.build(&PreconditionerInput { diagonal: &diag, matrix: Some(a), geometry, model: None })?;
    drop(task);
    report.timings.setup = t.elapsed().as_secs_f64();
    report.preconditioner = m_inv.summary();
    let t = Instant::now();
    let mut u = vec![0.0; a.nrows()];
    // The preconditioner's copy of `A` when it has a cheaper product (multigrid: ~20 % faster
    // iterations on the bench cases).
    let sym = SymCsc(a);
    let op: &dyn LinearOperator = m_inv.operator_copy().unwrap_or(&sym);
    let outcome = pcg_with_progress(&op, &m_inv, f, &mut u, params, progress);
    report.timings.solve = t.elapsed().as_secs_f64();
    let outcome = outcome.map(|info| report.iterations = Some(info.iterations));
    if let Err(CgError::ResidualAboveTarget { iterations, .. } | CgError::NotConverged { iterations, .. }) = &outcome {
        report.iterations = Some(*iterations);
    }
    Ok((u, report, outcome))
}

/// `u || |A| |x| ||_2 / ||b||_2` (`u` the unit roundoff, `A` symmetric): the relative residual
/// that rounding alone leaves in a computed `b - A x` (each entry of `A x` is a sum whose
/// rounding error is about `u` times the sum of its terms' magnitudes). A solve cannot certify a
/// residual much below it, whatever the solver.
pub(super) fn rounding_residual(a: &Csc, x: &[f64], b: &[f64]) -> f64 {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let v = a.val();
    let mut s = 0.0;
    for j in 0..a.ncols() {
        let t: f64 = (cp[j]..cp[j + 1]).map(|p| v[p].abs() * x[ri[p]].abs()).sum();
        s += t * t;
    }
    let bn = b.iter().map(|t| t * t).sum::<f64>().sqrt();
    0.5 * f64::EPSILON * s.sqrt() / bn
}

/// Restarted GMRES (restart 50) on the assembled `A_ff`, right-preconditioned by Jacobi or by
/// multigrid built from `A_ff` itself.
pub(super) fn assembled_gmres(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    assembled_gmres_with(a, a, f, params, preconditioner, geometry, progress)
}

/// [`assembled_gmres`] with the preconditioner built from `m` instead of `a`: for an
/// unsymmetric `A` its SPD approximation `M` (the smoothed-aggregation hierarchy, its Chebyshev
/// smoother and its coarsest Cholesky need a symmetric positive definite matrix; the Galerkin
/// coarse levels of the blended `A` itself came out singular on the bundled crack plate).
pub(super) fn assembled_gmres_with(
    a: &Csc,
    m: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let mut report = SolveReport::new(SolverId::GmresIterative(preconditioner), a.nrows(), a.val().len());
    let t = Instant::now();
    let diag = diagonal(m);
    if preconditioner == PreconditionerKind::JACOBI {
        // Jacobi divides by the diagonal: a zero one is GMRES's singular matrix, not CG's breakdown
        nonzero_diagonal(&format!("gmres ({})", preconditioner.name()), &diag, true)?;
    }
    let task = Task::start(progress, &format!("{} preconditioner setup", preconditioner.name()), None);
    let m_inv =
        preconditioner.build(&PreconditionerInput { diagonal: &diag, matrix: Some(m), geometry, model: None })?;
    drop(task);
    report.timings.setup = t.elapsed().as_secs_f64();
    report.preconditioner = m_inv.summary();
    let t = Instant::now();
    let mut u = vec![0.0; a.nrows()];
    let gp = GmresParams { rtol: params.rtol, restart: 50, max_iter: params.max_iter };
    let info = gmres_with_progress(&GeneralCsc(a), &m_inv, f, &mut u, &gp, progress)
        .map_err(|source| SolveError::Gmres { preconditioner: preconditioner.name(), source })?;
    report.timings.solve = t.elapsed().as_secs_f64();
    report.iterations = Some(info.iterations);
    Ok((u, report))
}

/// Why [`spd_gmres`] was not used.
pub(super) enum SpdGmres {
    /// The factor of `M` would not fit in memory ([`cost::cholesky`]), or the system is past
    /// the 3D limit: no factorization is tried.
    TooLarge(String),
    /// The factorization or GMRES failed.
    Failed(String),
}

/// GMRES on the unsymmetric `A` preconditioned by the Cholesky factor of the SPD `M`
/// (`Err`: why it could not be used).
///
/// GMRES stops at a normwise backward error of 16 eps, `||r|| <= 16 eps ||A|| ||x||`, what a
/// backward-stable direct solve achieves (a fixed relative residual such as 1e-13 is out of
/// reach when kappa ~ 1e8, as for 10^4 nodes of a 1D model), with `||A||_2` bounded by
/// `sqrt(||A||_1 ||A||_inf)` and `x` the preconditioner's solution.
pub(super) fn spd_gmres(
    a: &Csc,
    f: &[f64],
    spd: &SpdApproximation,
    ordering: &Ordering,
    progress: &dyn Progress,
) -> Result<Solved, SpdGmres> {
    let n = a.nrows();
    let mut report = SolveReport::new(SolverId::Gmres(spd.kind), n, a.val().len());
    let m = &spd.matrix;
    let natural: Vec<usize>;
    let perm = match ordering {
        Ordering::Amd => None,
        Ordering::Natural | Ordering::Band => {
            natural = (0..n).collect();
            Some(natural.as_slice())
        }
        Ordering::NestedDissection(p) => Some(p.as_slice()),
    };
    let t = Instant::now();
    let chol = Cholesky::analyze_with_ordering(m, perm).map_err(|e| SpdGmres::Failed(e.to_string()))?;
    report.timings.symbolic = t.elapsed().as_secs_f64();
    // the symbolic analysis knows the factor's size: refuse what would not fit in memory
    factor_fits(&chol, SolverId::Gmres(spd.kind).to_string()).map_err(SpdGmres::TooLarge)?;
    let t = Instant::now();
    let factor = chol.factor(m).map_err(|e| SpdGmres::Failed(e.to_string()))?;
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(chol.nnz_factor());
    report.factor_bytes = Some(chol.factor_bytes());
    let t = Instant::now();
    let mut x = factor.solve(f);
    let norm_a = (norm_1(a) * norm_inf(a)).sqrt();
    let norm = |v: &[f64]| v.iter().map(|v| v * v).sum::<f64>().sqrt();
    let rtol = (16.0 * f64::EPSILON * norm_a * norm(&x) / norm(f).max(f64::MIN_POSITIVE)).clamp(1e-15, 1e-8);
    let params = GmresParams { rtol, restart: 40, max_iter: 200 };
    let info = gmres_with_progress(&GeneralCsc(a), &FactorPreconditioner(factor), f, &mut x, &params, progress)
        .map_err(|e| SpdGmres::Failed(e.to_string()))?;
    report.iterations = Some(info.iterations);
    report.timings.solve = t.elapsed().as_secs_f64();
    Ok((x, report))
}

/// `max_j sum_i |a_ij|`.
fn norm_1(a: &Csc) -> f64 {
    let cp = a.symbolic().col_ptr();
    (0..a.ncols()).map(|j| a.val()[cp[j]..cp[j + 1]].iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max)
}

/// `max_i sum_j |a_ij|`.
fn norm_inf(a: &Csc) -> f64 {
    let mut rows = vec![0.0; a.nrows()];
    for (&i, v) in a.symbolic().row_idx().iter().zip(a.val()) {
        rows[i] += v.abs();
    }
    rows.into_iter().fold(0.0, f64::max)
}

/// PCG on the [`ReducedOperator`] of the model's fastest apply, never assembling `A_ff`.
pub(super) fn matrix_free_cg(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    progress.phase(&format!(
        "solving matrix-free with {}: {} unknowns",
        SolverSpec::Cg { params: params.clone(), preconditioner, matrix_free: true },
        dofs.n_free()
    ));
    // The multigrid's hierarchy (and the diagonal its smoothers read) come from the model's
    // companion when it offers one (`Model::multigrid_companion`); CG runs on the model.
    let companion = if preconditioner.multilevel() { model.multigrid_companion() } else { None };
    let source: &dyn Model = companion.as_deref().unwrap_or(model);
    let full_diag = source.diagonal();
    let diag = dofs.gather(&full_diag);
    finite_vector("the stiffness (its diagonal over the free DOFs)", &diag)?;
    finite_vector(REDUCED_LOAD, rhs)?;
    let t = Instant::now();
    let fast = model.fast_apply();
    let model_op = ModelOperator(model);
    let (full, how): (&dyn LinearOperator, MatrixFree) = match &fast {
        Some(fa) => (&*fa.op, MatrixFree::Fast(fa.label)),
        None => (&model_op, MatrixFree::Model),
    };
    let source_fast = companion.as_deref().and_then(|c| c.fast_apply());
    let source_op = ModelOperator(source);
    let source_full: &dyn LinearOperator = match (&companion, &source_fast) {
        (None, _) => full,
        (Some(_), Some(fa)) => &*fa.op,
        (Some(_), None) => &source_op,
    };
    // A lattice model with a coarse lattice gets the geometric top level
    // (`LatticeMultigrid`); the others the SA hierarchy of the model (or its companion).
    let space = match &companion {
        None if preconditioner == PreconditionerKind::MULTIGRID => CoarseSpace::new(model, dofs, &full_diag),
        _ => None,
    };
    let coarse_fast = space.as_ref().map(|s| (s.model().fast_apply(), ModelOperator(s.model())));
    let task = Task::start(progress, &format!("{} preconditioner setup", preconditioner.name()), None);
    // The geometric level, or why it failed (its coarse SA setup: a smoothed aggregation of the
    // fine level may still work, so that runs instead and the report says why).
    let mut fallback = None;
    let geometric = match (&space, &coarse_fast) {
        (Some(space), Some((cfast, cmodel))) => {
            let cfull: &dyn LinearOperator = match cfast {
                Some(fa) => &*fa.op,
                None => cmodel,
            };
            LatticeMultigrid::new(full, dofs, space, cfull, &AmgParams::default())
                .map_err(|e| fallback = Some(e.to_string()))
                .ok()
        }
        _ => None,
    };
    let geometry = (preconditioner.multilevel() && geometric.is_none()).then(|| DofGeometry::of(source, dofs));
    let m_inv: Box<dyn Preconditioner> = match geometric {
        Some(m) => Box::new(m),
        None => {
            let input = PreconditionerInput {
                diagonal: &diag,
                matrix: None,
                geometry: geometry.as_ref(),
                model: Some(ModelInput { model: source, dofs, full: source_full }),
            };
            preconditioner.build(&input)?
        }
    };
    drop(task);
    let t_setup = t.elapsed().as_secs_f64();
    let mut u = vec![0.0; dofs.n_free()];
    let info = pcg_with_progress(&ReducedOperator::new(full, dofs), &m_inv, rhs, &mut u, params, progress)
        .map_err(SolveError::from)?;
    let id = SolverId::Cg { preconditioner, matrix_free: how };
    let mut report = SolveReport::new(id, dofs.n_free(), 0);
    report.preconditioner = m_inv.summary();
    if let Some(e) = fallback {
        report.notes.push(format!("the geometric multigrid level failed ({e}): smoothed aggregation ran instead"));
    }
    if let Some(c) = &companion {
        report.notes.push(companion_note(&**c, model, "CG"));
    }
    finish_iterative(&mut report, info.iterations, info.rel_residual, t_setup, t);
    Ok((u, report))
}

/// The report's note that `krylov` ran on `model` with the multigrid of its `companion`.
fn companion_note(companion: &dyn Model, model: &dyn Model, krylov: &str) -> String {
    format!(
        "the multigrid hierarchy is built from the model's SPD companion ({}), {krylov} runs on the {} model",
        companion.kind(),
        model.kind()
    )
}

/// Fills a matrix-free iterative solve's iterations, residual, timings (setup `t_setup` of
/// the total since `start`) and peak memory.
fn finish_iterative(report: &mut SolveReport, iterations: usize, rel_residual: f64, t_setup: f64, start: Instant) {
    report.iterations = Some(iterations);
    report.rel_residual = rel_residual;
    report.timings.setup = t_setup;
    report.timings.total = start.elapsed().as_secs_f64();
    report.timings.solve = report.timings.total - t_setup;
    report.peak_rss_bytes = peak_rss_bytes();
}

/// GMRES on the [`ReducedOperator`] of the model's apply, preconditioned by the multigrid
/// built from the block rows of its SPD companion ([`Model::multigrid_companion`], required),
/// never assembling `A_ff` or `M_ff` (restart 50, as the assembled GMRES + multigrid).
pub(super) fn matrix_free_gmres(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    params: &CgParams,
    progress: &dyn Progress,
) -> Result<Solved, SolveError> {
    let preconditioner = PreconditionerKind::MULTIGRID;
    progress.phase(&format!(
        "solving matrix-free with GMRES + multigrid from the model's SPD companion: {} unknowns",
        dofs.n_free()
    ));
    let companion = model.multigrid_companion().expect("the caller checked the model offers a companion");
    let full_diag = companion.diagonal();
    let diag = dofs.gather(&full_diag);
    finite_vector("the companion's diagonal over the free DOFs", &diag)?;
    finite_vector(REDUCED_LOAD, rhs)?;
    let t = Instant::now();
    let task = Task::start(progress, "multigrid preconditioner setup", None);
    let geometry = DofGeometry::of(&*companion, dofs);
    let companion_op = ModelOperator(&*companion);
    let input = PreconditionerInput {
        diagonal: &diag,
        matrix: None,
        geometry: Some(&geometry),
        model: Some(ModelInput { model: &*companion, dofs, full: &companion_op }),
    };
    let m_inv = preconditioner.build(&input)?;
    drop(task);
    let t_setup = t.elapsed().as_secs_f64();
    let model_op = ModelOperator(model);
    let mut u = vec![0.0; dofs.n_free()];
    let gp = GmresParams { rtol: params.rtol, restart: 50, max_iter: params.max_iter };
    let info = gmres_with_progress(&ReducedOperator::new(&model_op, dofs), &m_inv, rhs, &mut u, &gp, progress)
        .map_err(|source| SolveError::Gmres { preconditioner: preconditioner.name(), source })?;
    let mut report = SolveReport::new(SolverId::GmresMatrixFree(preconditioner), dofs.n_free(), 0);
    report.preconditioner = m_inv.summary();
    report.notes.push(companion_note(&*companion, model, "GMRES"));
    finish_iterative(&mut report, info.iterations, info.rel_residual, t_setup, t);
    Ok((u, report))
}
