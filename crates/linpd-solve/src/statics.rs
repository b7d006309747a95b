//! The one static solve of linpd: a [`Model`], prescribed displacements ([`Dirichlet`]) and
//! nodal forces in, displacements and a [`SolveReport`] out. Scenes of every model type,
//! coarsening pipelines, the studies and the tension bar all come through here.
//!
//! 1. every DOF constrained, or a rigid motion left free ([`linpd_core::check_support`] on the
//!    model's own interaction graph): a typed error before any factorization;
//! 2. `A_ff u_f = f_f - (A u_bar)_f` ([`crate::bc`]);
//! 3. assembled ([`Model::assemble_free`]) and solved by [`solve_assembled`], or matrix-free
//!    CG on the [`ReducedOperator`] of the model's fastest apply;
//! 4. `u = u_bar + u_f`, checked finite.

use crate::bc::{Dirichlet, ReducedOperator};
use crate::cost;
use crate::direct::{dense_lu_solve, dense_solve, Cholesky, Lu, LuOrdering};
use crate::krylov::cg::{pcg_with_progress, CgError, CgParams};
use crate::krylov::gmres::{gmres_with_progress, GmresParams};
use crate::precond::{DofGeometry, FactorPreconditioner};
use crate::report::{peak_rss_bytes, SolveReport};
use crate::spec::{
    CholeskyOrdering, MatrixFree, ModelInput, PreconditionerInput, PreconditionerKind, SolverId, SolverSpec,
};
use crate::SolveError;
use linpd_core::progress::{NoProgress, Progress, Task};
use linpd_core::sparse::{diagonal, relative_residual, Csc, GeneralCsc, SymCsc, SYMMETRY_RTOL};
use linpd_core::{
    check_support, DofMap, LinearOperator, Model, ModelOperator, Ordering, SpdApproximation, Unsupported,
};
use std::time::Instant;

pub use crate::direct::DIRECT_RESIDUAL_LIMIT;

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
/// from `M` (2D from [`AUTO_GMRES_MULTIGRID_2D`] unknowns, and where the factor of `M` would not
/// fit) or by the Cholesky factor of `M`, each falling back to the next (with a note) if it
/// fails: multigrid to the Cholesky of `M`, the Cholesky of `M` to sparse LU.
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
    finite_matrix(a)?;
    finite_vector("the load vector", f)?;
    let n = a.nrows();
    let symmetric = hints.asymmetry <= SYMMETRY_RTOL;
    let resolved = spec.resolve(hints.dim, n);
    let mut note = None;
    let t0 = Instant::now();
    let (u, mut report) = if symmetric {
        match &resolved {
            SolverSpec::Auto(params) => auto(a, f, params, hints, progress)?,
            SolverSpec::Cholesky => cholesky(a, f, analyze_cholesky(a, &hints.ordering)?, progress)?,
            SolverSpec::Lu => lu(a, f, &hints.ordering, progress)?,
            SolverSpec::Dense => {
                let mut report = SolveReport::new(SolverId::Dense, n, a.val().len());
                let t = Instant::now();
                let u = dense_solve(a, f)?;
                report.timings.numeric = t.elapsed().as_secs_f64();
                report.nnz_factor = Some(n * (n + 1) / 2);
                (u, report)
            }
            SolverSpec::Cg { params, preconditioner, matrix_free: _ } => {
                assembled_cg(a, f, params, *preconditioner, hints.geometry.as_ref(), progress)?
            }
            SolverSpec::Gmres { params, preconditioner } => {
                assembled_gmres(a, f, params, *preconditioner, hints.geometry.as_ref(), progress)?
            }
        }
    } else {
        match (&resolved, &hints.spd) {
            (SolverSpec::Dense, _) => {
                let mut report = SolveReport::new(SolverId::DenseLu, n, a.val().len());
                let t = Instant::now();
                let u = dense_lu_solve(a, f)?;
                report.timings.numeric = t.elapsed().as_secs_f64();
                report.nnz_factor = Some(n * n);
                (u, report)
            }
            (SolverSpec::Lu, _) => lu(a, f, &hints.ordering, progress)?,
            (SolverSpec::Gmres { params, preconditioner }, spd) => {
                // the preconditioner from the SPD approximation (the symmetric part by default;
                // borrowed: a 3D blend's M is ~1 GB)
                let m = match spd {
                    Some(spd) => std::borrow::Cow::Borrowed(&spd.matrix),
                    None => std::borrow::Cow::Owned(linpd_core::sparse::symmetric_part(a)),
                };
                assembled_gmres_with(a, &m, f, params, *preconditioner, hints.geometry.as_ref(), progress)?
            }
            // `auto` asked (in 1D it resolves to a direct solver name, hence `spec`, not `resolved`)
            (_, Some(spd)) if matches!(spec, SolverSpec::Auto(_)) => {
                let params = match spec {
                    SolverSpec::Auto(params) => params.clone(),
                    _ => CgParams::default(),
                };
                auto_unsymmetric(a, f, spd, &params, hints, progress, &mut note)?
            }
            (s, _) => {
                note = Some(format!(
                    "{s} asked, sparse LU used: A is unsymmetric (relative asymmetry {:.2e} > {SYMMETRY_RTOL:e})",
                    hints.asymmetry
                ));
                lu(a, f, &hints.ordering, progress)?
            }
        }
    };
    finite_vector("the solution", &u)?;
    // a note of the solver path (auto's fallback) comes first
    report.note = match (report.note.take(), note) {
        (Some(a), Some(b)) => Some(format!("{a}; {b}")),
        (a, b) => a.or(b),
    };
    report.timings.total = t0.elapsed().as_secs_f64();
    report.rel_residual = relative_residual(a, symmetric, &u, f);
    if !report.rel_residual.is_finite() {
        let at = format!("||A u - f|| / ||f|| = {:e}", report.rel_residual);
        return Err(SolveError::NonFinite { what: "the residual of the solution", at });
    }
    report.peak_rss_bytes = peak_rss_bytes();
    let direct = !matches!(report.solver, SolverId::Cg { .. });
    if direct && !(report.rel_residual <= DIRECT_RESIDUAL_LIMIT) {
        return Err(SolveError::NumericallySingular { rel_residual: report.rel_residual, solver: report.solver });
    }
    Ok((u, report))
}

/// `Err` naming the stiffness and its first NaN or infinite stored entry (an overflow of the
/// moduli or volumes: a factorization would call it "not positive definite").
pub fn finite_matrix(a: &Csc) -> Result<(), SolveError> {
    let Some(k) = a.val().iter().position(|v| !v.is_finite()) else { return Ok(()) };
    let col = a.symbolic().col_ptr().partition_point(|&p| p <= k) - 1;
    let row = a.symbolic().row_idx()[k];
    Err(SolveError::NonFinite {
        what: "the stiffness",
        at: format!("first at entry ({row}, {col}) = {:e}", a.val()[k]),
    })
}

/// `Err` naming `what` when an entry is NaN or infinite, or when its squared 2-norm overflows
/// (entries near 1e308: every residual norm would then be `inf / inf = NaN`).
pub fn finite_vector(what: &'static str, v: &[f64]) -> Result<(), SolveError> {
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(SolveError::NonFinite { what, at: format!("first at DOF {k} = {:e}", v[k]) });
    }
    let sq: f64 = v.iter().map(|x| x * x).sum();
    if !sq.is_finite() {
        let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        return Err(SolveError::NonFinite { what, at: format!("its squared norm overflows, entries up to {max:e}") });
    }
    Ok(())
}

/// What the reduced right-hand side is called in messages: finite loads can still overflow
/// in `f_f - (A u_bar)_f` (prescribed displacements of 1e300).
const REDUCED_LOAD: &str = "the load vector f - A u_bar (loads and prescribed displacements)";

/// The symbolic analysis of a sparse Cholesky in the model's ordering, timed.
fn analyze_cholesky(a: &Csc, ordering: &Ordering) -> Result<(Cholesky, CholeskyOrdering, f64), SolveError> {
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
fn cholesky(
    a: &Csc,
    f: &[f64],
    (chol, label, t_symbolic): (Cholesky, CholeskyOrdering, f64),
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    let mut report = SolveReport::new(SolverId::Cholesky(label), a.nrows(), a.val().len());
    report.timings.symbolic = t_symbolic;
    let t = Instant::now();
    let task = Task::start(progress, "Cholesky factorization", None);
    let factor = chol.factor(a)?;
    drop(task);
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(chol.nnz_factor());
    report.factor_flops = Some(chol.flops());
    let t = Instant::now();
    let u = factor.solve(f);
    report.timings.solve = t.elapsed().as_secs_f64();
    Ok((u, report))
}

/// Preconditioned CG on the assembled `A`.
fn assembled_cg(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
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
    let info = pcg_with_progress(&op, &m_inv, f, &mut u, params, progress)?;
    report.timings.solve = t.elapsed().as_secs_f64();
    report.iterations = Some(info.iterations);
    Ok((u, report))
}

/// Restarted GMRES (restart 50) on the assembled `A_ff`, right-preconditioned by Jacobi or by
/// multigrid built from `A_ff` itself.
fn assembled_gmres(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    assembled_gmres_with(a, a, f, params, preconditioner, geometry, progress)
}

/// [`assembled_gmres`] with the preconditioner built from `m` instead of `a`: for an
/// unsymmetric `A` its SPD approximation `M` (the smoothed-aggregation hierarchy, its Chebyshev
/// smoother and its coarsest Cholesky need a symmetric positive definite matrix; the Galerkin
/// coarse levels of the blended `A` itself came out singular on the bundled crack plate).
fn assembled_gmres_with(
    a: &Csc,
    m: &Csc,
    f: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    geometry: Option<&DofGeometry>,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    let mut report = SolveReport::new(SolverId::GmresIterative(preconditioner), a.nrows(), a.val().len());
    let t = Instant::now();
    let diag = diagonal(m);
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

/// Above this many unknowns in 3D, `auto` does not even run the Cholesky symbolic analysis:
/// the fill of nested dissection grows as `n^(4/3)` and at 100k unknowns with `delta = 3h`
/// (a 32^3 cube) it is already ~1e9 entries, past [`cost::CHOLESKY_MEMORY_LIMIT`].
pub const AUTO_3D_CHOLESKY_LIMIT: usize = 100_000;

/// From this many unknowns `auto` solves an unsymmetric 2D system with an SPD approximation `M`
/// (the lattice blends) by GMRES + multigrid from `M` before trying the Cholesky factor of `M`.
/// Measured on the edge-cracked blend of `linpd study blend-2d` (radius 2; solver seconds,
/// GMRES + multigrid to rtol 1e-10 against the Cholesky of `M` + GMRES): 20k unknowns 0.073 s
/// against 0.178 s, 80k 0.37 against 0.81, 180k 0.58 against 1.92, 320k 1.21 against 4.07 (the
/// factor's triangular solves make each of its 14 GMRES iterations dearer than the 29 of the
/// multigrid). Not in 3D, where GMRES + multigrid stagnated on a small notched block (the
/// transition terms `M` leaves out are a large part of the body there: docs/solvers.md).
pub const AUTO_GMRES_MULTIGRID_2D: usize = 20_000;

/// `auto` on a symmetric `A` in 2D/3D: the cheapest of sparse Cholesky, Jacobi-PCG and (when
/// the DOF geometry is known) multigrid-PCG by [`crate::cost`]; the report's `auto` field lists
/// the estimates.
fn auto(
    a: &Csc,
    f: &[f64],
    params: &CgParams,
    hints: &MatrixHints,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    let (n, dim) = (a.nrows(), hints.dim);
    let n_side = hints.n_side.unwrap_or_else(|| (n as f64 / dim as f64).powf(1.0 / dim as f64));
    let cg = cost::jacobi_cg(dim, a.val().len(), n_side, params);
    let mut analyzed = None;
    let chol = if dim == 3 && n > AUTO_3D_CHOLESKY_LIMIT {
        cost::Estimate {
            solver: "cholesky".into(),
            seconds: None,
            why: format!("3D with {n} > {AUTO_3D_CHOLESKY_LIMIT} unknowns"),
        }
    } else {
        let task = Task::start(progress, "Cholesky symbolic analysis (auto's estimate)", None);
        let (c, label, t) = analyze_cholesky(a, &hints.ordering)?;
        drop(task);
        let e = cost::cholesky(&c, SolverId::Cholesky(label).to_string());
        analyzed = Some((c, label, t));
        e
    };
    // Multigrid needs the DOF geometry for its rigid-body modes: offered only with it.
    let mg = hints.geometry.as_ref().map(|_| cost::multigrid_cg(a.val().len(), params));
    let mut candidates = vec![(&chol, None), (&cg, Some(PreconditionerKind::Jacobi))];
    candidates.extend(mg.as_ref().map(|e| (e, Some(PreconditionerKind::Multigrid))));
    let line = candidates.iter().map(|(e, _)| e.to_string()).collect::<Vec<_>>().join("; ");
    // The cheapest estimate: `None` is the Cholesky, `Some(p)` PCG with `p`.
    let best = candidates
        .iter()
        .filter_map(|(e, choice)| e.seconds.map(|s| (s, *choice)))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map_or(Some(PreconditionerKind::Jacobi), |(_, choice)| choice);
    let (u, mut report) = match (best, analyzed) {
        (None, Some(analysis)) => cholesky(a, f, analysis, progress)?,
        (p, analyzed) => match assembled_cg(a, f, params, p.unwrap_or_default(), hints.geometry.as_ref(), progress) {
            // CG stopped above rtol because rounding limits its attainable residual (an
            // ill-conditioned system, e.g. the LPS cantilever of `linpd study surface`, where
            // multigrid-PCG reached 1.12e-10 for rtol 1e-10): auto falls back to the direct
            // solve it has analyzed (and says so) rather than fail where another solver works.
            // (only when the estimate kept the factorization: not past the memory limit)
            Err(SolveError::Cg(e @ CgError::ResidualAboveTarget { .. }))
                if analyzed.is_some() && chol.seconds.is_some() =>
            {
                let (u, mut report) = cholesky(a, f, analyzed.expect("checked"), progress)?;
                report.note = Some(format!("auto: the first choice failed ({e}); fell back to the Cholesky solve"));
                (u, report)
            }
            other => other?,
        },
    };
    report.auto = Some(line);
    Ok((u, report))
}

/// Sparse LU with partial pivoting: COLAMD, or the natural order for a banded model.
fn lu(a: &Csc, f: &[f64], ordering: &Ordering, progress: &dyn Progress) -> Result<(Vec<f64>, SolveReport), SolveError> {
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
    report.timings.solve = t.elapsed().as_secs_f64();
    // faer does not expose the LU fill; the stored entries of A are a lower bound.
    report.nnz_factor = Some(a.val().len());
    Ok((u, report))
}

/// `auto` on an unsymmetric `A` with an SPD approximation `M` (`note` says what ran and why):
/// GMRES + multigrid from `M` in 2D from [`AUTO_GMRES_MULTIGRID_2D`] unknowns (measured faster
/// than the Cholesky of `M`, see the constant); else, or when that fails (stagnation,
/// `max_iter`), GMRES with the Cholesky factor of `M`, GMRES + multigrid where that factor would
/// not fit (or in 3D past [`AUTO_3D_CHOLESKY_LIMIT`]: LU would fill at least as much), sparse LU
/// when the factorization or GMRES fails.
fn auto_unsymmetric(
    a: &Csc,
    f: &[f64],
    spd: &SpdApproximation,
    params: &CgParams,
    hints: &MatrixHints,
    progress: &dyn Progress,
    note: &mut Option<String>,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    let n = a.nrows();
    let multigrid = || {
        assembled_gmres_with(
            a,
            &spd.matrix,
            f,
            params,
            PreconditionerKind::Multigrid,
            hints.geometry.as_ref(),
            progress,
        )
    };
    let mut failed = None;
    if hints.dim == 2 && n >= AUTO_GMRES_MULTIGRID_2D && hints.geometry.is_some() {
        match multigrid() {
            Ok(solved) => {
                *note = Some(format!(
                    "auto: gmres + multigrid from the SPD approximation {:?} (2D, {n} >= {AUTO_GMRES_MULTIGRID_2D} \
                     unknowns)",
                    spd.kind
                ));
                return Ok(solved);
            }
            Err(e) => failed = Some(e.to_string()),
        }
    }
    let factored = if hints.dim == 3 && n > AUTO_3D_CHOLESKY_LIMIT {
        Err(SpdGmres::TooLarge(format!("3D with {n} > {AUTO_3D_CHOLESKY_LIMIT} unknowns")))
    } else {
        spd_gmres(a, f, spd, &hints.ordering, progress)
    };
    let solved = match factored {
        Ok(solved) => solved,
        Err(SpdGmres::TooLarge(why)) if hints.geometry.is_some() => {
            let excluded = format!("auto: {} excluded ({why})", SolverId::Gmres(spd.kind));
            *note = Some(format!("{excluded}: gmres + multigrid instead"));
            multigrid()
                .map_err(|e| SolveError::NoSolverFits(format!("{excluded}, and gmres + multigrid failed: {e}")))?
        }
        Err(SpdGmres::TooLarge(why)) => {
            return Err(SolveError::NoSolverFits(format!(
                "{} excluded ({why}) and no multigrid geometry for an iterative solve",
                SolverId::Gmres(spd.kind)
            )))
        }
        Err(SpdGmres::Failed(why)) => {
            *note = Some(format!("{} failed ({why}): sparse LU used", SolverId::Gmres(spd.kind)));
            lu(a, f, &hints.ordering, progress)?
        }
    };
    if let Some(why) = failed {
        let then = note.take().map(|n| format!("; {n}")).unwrap_or_default();
        *note = Some(format!("auto: gmres + multigrid failed ({why}), the next choice ran{then}"));
    }
    Ok(solved)
}

/// Why [`spd_gmres`] was not used.
enum SpdGmres {
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
fn spd_gmres(
    a: &Csc,
    f: &[f64],
    spd: &SpdApproximation,
    ordering: &Ordering,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SpdGmres> {
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
    if let cost::Estimate { seconds: None, why, .. } = cost::cholesky(&chol, SolverId::Gmres(spd.kind).to_string()) {
        return Err(SpdGmres::TooLarge(why));
    }
    let t = Instant::now();
    let factor = chol.factor(m).map_err(|e| SpdGmres::Failed(e.to_string()))?;
    report.timings.numeric = t.elapsed().as_secs_f64();
    report.nnz_factor = Some(chol.nnz_factor());
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

/// A failed static solve of a model.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum StaticError {
    /// No free DOF.
    #[error("every DOF is constrained: nothing to solve")]
    NothingFree,
    /// A connected piece can move rigidly.
    #[error("{source} (first positions {positions:?})")]
    Unsupported {
        /// Which piece and how many motions.
        source: Unsupported,
        /// Positions of its first nodes (at most 3).
        positions: Vec<Vec<f64>>,
    },
    /// The model cannot be applied matrix-free.
    #[error("matrix_free is not available for {kind} models: {why}")]
    MatrixFreeUnavailable {
        /// The model kind.
        kind: &'static str,
        /// Why.
        why: &'static str,
    },
    /// CG was asked for an unsymmetric operator.
    #[error("the {kind} operator is unsymmetric (relative asymmetry {asymmetry:.2e}): matrix-free CG needs a symmetric one; use lu")]
    UnsymmetricForCg {
        /// The model kind.
        kind: &'static str,
        /// `max |A - A^T| / max |A|`.
        asymmetry: f64,
    },
    /// The solver failed at a DOF.
    #[error("{source}: {at}; the body is not held there (add constraints) or its couplings are cut around it")]
    AtDof {
        /// The solver's error.
        source: SolveError,
        /// The node and component (from the model's [`Model::describe_node`]).
        at: String,
    },
    /// The solver failed.
    #[error(transparent)]
    Solve(SolveError),
}

impl From<SolveError> for StaticError {
    fn from(e: SolveError) -> Self {
        StaticError::Solve(e)
    }
}

/// What [`solve_model`] checks before anything else: a free DOF, no rigid motion left free by
/// the constraints, finite loads.
fn check_static(model: &dyn Model, bc: &Dirichlet, f: &[f64]) -> Result<(), StaticError> {
    let dofs = bc.dofs();
    if dofs.n_free() == 0 {
        return Err(StaticError::NothingFree);
    }
    check_support(model, dofs).map_err(|source| StaticError::Unsupported {
        positions: source.nodes.iter().take(3).map(|&i| model.position(i)[..model.dim()].to_vec()).collect(),
        source,
    })?;
    finite_vector("the load vector", f)?;
    Ok(())
}

/// `A_ff` assembled ([`Model::assemble_free_with_progress`]), checked finite together with the
/// reduced right-hand side `rhs`.
fn assemble_checked(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    progress: &dyn Progress,
) -> Result<Csc, StaticError> {
    let a = model.assemble_free_with_progress(dofs, progress);
    finite_matrix(&a)?;
    finite_vector(REDUCED_LOAD, rhs)?;
    Ok(a)
}

/// The reduced system `A_ff u_f = f_f - (A u_bar)_f` that [`solve_model`] hands an assembled
/// solver, with the same checks and errors, not solved: `(A_ff, rhs)`, rows and columns
/// numbered as the free DOFs of `bc.dofs()` ([`DofMap::free_dofs`]). A matrix-free CG applies
/// the same `A_ff` without assembling it.
pub fn reduced_system(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    progress: &dyn Progress,
) -> Result<(Csc, Vec<f64>), StaticError> {
    check_static(model, bc, f)?;
    let rhs = bc.reduced_rhs(&ModelOperator(model), f);
    progress.phase(&format!("assembling: {} free DOFs", bc.dofs().n_free()));
    let a = assemble_checked(model, bc.dofs(), &rhs, progress)?;
    Ok((a, rhs))
}

/// The reduced right-hand side `f_f - (A u_bar)_f` of [`reduced_system`], with its checks
/// (something free, the support check, finite loads and result) but without assembling
/// `A_ff`: for callers that assemble `A_ff` themselves a block of rows at a time (the
/// distributed path of the Python package), so that the errors are those of a solve.
pub fn reduced_rhs_checked(model: &dyn Model, bc: &Dirichlet, f: &[f64]) -> Result<Vec<f64>, StaticError> {
    check_static(model, bc, f)?;
    let rhs = bc.reduced_rhs(&ModelOperator(model), f);
    finite_vector(REDUCED_LOAD, &rhs)?;
    Ok(rhs)
}

/// Displacements over all DOFs and the report of their solve.
#[derive(Debug, Clone)]
pub struct StaticSolution {
    /// `u` over all DOFs (`d` per node, node-major).
    pub u: Vec<f64>,
    /// Accuracy and cost (`timings.assemble` covers the right-hand side and the assembly).
    pub report: SolveReport,
}

/// Unknowns from which `auto` runs matrix-free multigrid-CG where it can ([`auto_matrix_free`]).
/// Below, the assembled `auto` chooses as before: there a sparse Cholesky is about as fast and
/// exact to rounding (CG stops at `rtol`), and it is what the cost model picks for the small
/// scenes (the bench's iterative choices start at 21k unknowns, the 101^2 plate).
pub const AUTO_MATRIX_FREE_MIN_UNKNOWNS: usize = 20_000;

/// Whether `auto` runs matrix-free multigrid-CG on `model` with `n_free` unknowns: a symmetric
/// operator in 2D/3D, at least [`AUTO_MATRIX_FREE_MIN_UNKNOWNS`], that has a fast apply (the
/// lattice stencil of a homogeneous bond model) and its block rows ([`Model::for_each_block`],
/// which the multigrid setup reads instead of a stored matrix). Measured (docs/solvers.md,
/// `linpd bench --statics`): faster than every assembled solver at every 2D and 3D size from
/// there, 2.3-3.1x faster than the assembled multigrid in 3D, with a fifth of its memory.
fn auto_matrix_free(model: &dyn Model, n_free: usize, asymmetry: f64) -> bool {
    n_free >= AUTO_MATRIX_FREE_MIN_UNKNOWNS
        && model.dim() >= 2
        && asymmetry <= SYMMETRY_RTOL
        && model.matrix_free_unavailable().is_none()
        && model.n_nodes() > 0
        && model.fast_apply().is_some()
        && model.for_each_block(0, &mut |_, _| {})
}

/// PCG on the [`ReducedOperator`] of the model's fastest apply, never assembling `A_ff`.
fn matrix_free_cg(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    params: &CgParams,
    preconditioner: PreconditionerKind,
    progress: &dyn Progress,
) -> Result<(Vec<f64>, SolveReport), SolveError> {
    progress.phase(&format!(
        "solving matrix-free with {}: {} unknowns",
        SolverSpec::Cg { params: params.clone(), preconditioner, matrix_free: true },
        dofs.n_free()
    ));
    let diag = dofs.gather(&model.diagonal());
    finite_vector("the stiffness (its diagonal over the free DOFs)", &diag)?;
    finite_vector(REDUCED_LOAD, rhs)?;
    let t = Instant::now();
    let fast = model.fast_apply();
    let model_op = ModelOperator(model);
    let (full, how): (&dyn LinearOperator, MatrixFree) = match &fast {
        Some(fa) => (&*fa.op, MatrixFree::Fast(fa.label)),
        None => (&model_op, MatrixFree::Model),
    };
    let geometry = (preconditioner != PreconditionerKind::Jacobi).then(|| DofGeometry::of(model, dofs));
    let input = PreconditionerInput {
        diagonal: &diag,
        matrix: None,
        geometry: geometry.as_ref(),
        model: Some(ModelInput { model, dofs, full }),
    };
    let task = Task::start(progress, &format!("{} preconditioner setup", preconditioner.name()), None);
    let m_inv = preconditioner.build(&input)?;
    drop(task);
    let t_setup = t.elapsed().as_secs_f64();
    let mut u = vec![0.0; dofs.n_free()];
    let info = pcg_with_progress(&ReducedOperator::new(full, dofs), &m_inv, rhs, &mut u, params, progress)
        .map_err(SolveError::from)?;
    let id = SolverId::Cg { preconditioner, matrix_free: how };
    let mut report = SolveReport::new(id, dofs.n_free(), 0);
    report.preconditioner = m_inv.summary();
    report.iterations = Some(info.iterations);
    report.rel_residual = info.rel_residual;
    report.timings.setup = t_setup;
    report.timings.total = t.elapsed().as_secs_f64();
    report.timings.solve = report.timings.total - t_setup;
    report.peak_rss_bytes = peak_rss_bytes();
    Ok((u, report))
}

/// Solves `A u = f` for `model` with the prescribed displacements of `bc` (see the module
/// docs). `progress` receives one line per phase and the tasks of the assembly
/// ([`Model::assemble_free_with_progress`]) and of the solver ([`solve_assembled_with_progress`]).
pub fn solve_model(
    model: &dyn Model,
    bc: &Dirichlet,
    f: &[f64],
    spec: &SolverSpec,
    progress: &dyn Progress,
) -> Result<StaticSolution, StaticError> {
    let d = model.dim();
    let dofs = bc.dofs();
    check_static(model, bc, f)?;
    let t0 = Instant::now();
    // Checked once the operator is known to be finite (an infinite A makes it NaN too).
    let rhs = bc.reduced_rhs(&ModelOperator(model), f);
    let asymmetry = model.asymmetry(dofs);
    let at_dof = |e: SolveError| -> StaticError {
        match e {
            SolveError::NotPositiveDefinite { dof } | SolveError::Singular { dof } if dof < dofs.n_free() => {
                let full = dofs.free_dofs()[dof];
                StaticError::AtDof {
                    at: format!("{}, component {}", model.describe_node(full / d), full % d),
                    source: e,
                }
            }
            other => StaticError::Solve(other),
        }
    };
    let (u_free, mut report) = match spec {
        SolverSpec::Cg { params, preconditioner, matrix_free: true } => {
            if let Some(why) = model.matrix_free_unavailable() {
                return Err(StaticError::MatrixFreeUnavailable { kind: model.kind(), why });
            }
            if asymmetry > SYMMETRY_RTOL {
                return Err(StaticError::UnsymmetricForCg { kind: model.kind(), asymmetry });
            }
            matrix_free_cg(model, dofs, &rhs, params, *preconditioner, progress).map_err(at_dof)?
        }
        SolverSpec::Auto(params) if auto_matrix_free(model, dofs.n_free(), asymmetry) => {
            let why = "the model applies A by a stencil and computes its block rows (a homogeneous bond \
                       lattice): matrix-free multigrid-CG, no assembly (the fastest solver at every size of \
                       docs/solvers.md's bench)";
            let t = Instant::now();
            match matrix_free_cg(model, dofs, &rhs, params, PreconditionerKind::Multigrid, progress) {
                Ok((u, mut report)) => {
                    report.auto = Some(why.into());
                    (u, report)
                }
                // As the assembled `auto` does when CG stalls above rtol (rounding): the
                // assembled choice, which can fall back to a direct solve.
                Err(SolveError::Cg(e @ CgError::ResidualAboveTarget { .. })) => {
                    let attempt = t.elapsed().as_secs_f64();
                    let (u, mut report) = assembled_solve(model, dofs, &rhs, spec, asymmetry, progress, &at_dof)?;
                    report.note = Some(format!(
                        "auto: matrix-free multigrid-CG failed ({e}; {attempt:.3} s, counted in the solver's \
                         total); assembled and chose again{}",
                        report.note.take().map(|n| format!("; {n}")).unwrap_or_default()
                    ));
                    // the failed attempt is solver time, not assembly
                    report.timings.total += attempt;
                    (u, report)
                }
                Err(e) => return Err(at_dof(e)),
            }
        }
        _ => assembled_solve(model, dofs, &rhs, spec, asymmetry, progress, &at_dof)?,
    };
    // Everything outside the solver proper: the right-hand side, the assembly, the diagonal.
    report.timings.assemble = t0.elapsed().as_secs_f64() - report.timings.total;
    let u = bc.expand(&u_free);
    finite_vector("the solution", &u)?;
    Ok(StaticSolution { u, report })
}

/// Assembles `A_ff` and solves it with [`solve_assembled_with_progress`] (the DOF geometry,
/// ordering and SPD approximation the spec may use taken from the model).
fn assembled_solve(
    model: &dyn Model,
    dofs: &DofMap,
    rhs: &[f64],
    spec: &SolverSpec,
    asymmetry: f64,
    progress: &dyn Progress,
    at_dof: &dyn Fn(SolveError) -> StaticError,
) -> Result<(Vec<f64>, SolveReport), StaticError> {
    let d = model.dim();
    progress.phase(&format!("assembling: {} free DOFs", dofs.n_free()));
    let t = Instant::now();
    let a = assemble_checked(model, dofs, rhs, progress)?;
    let t_asm = t.elapsed().as_secs_f64();
    let spd = match spec {
        SolverSpec::Auto(_) | SolverSpec::Gmres { .. } if asymmetry > SYMMETRY_RTOL => model.spd_approximation(dofs),
        _ => None,
    };
    let n_side = match spec {
        // The free body's extent: nodes with at least one free DOF.
        SolverSpec::Auto(_) if d >= 2 => Some(cost::nodes_along_longest_side(
            d,
            (0..model.n_nodes())
                .filter(|&i| (0..d).any(|c| !dofs.is_constrained(d * i + c)))
                .map(|i| model.position(i)),
        )),
        _ => None,
    };
    // Only multilevel preconditioners read the geometry: build it when one may run.
    let geometry = match spec {
        SolverSpec::Cg { preconditioner, .. } | SolverSpec::Gmres { preconditioner, .. }
            if *preconditioner != PreconditionerKind::Jacobi =>
        {
            Some(DofGeometry::of(model, dofs))
        }
        SolverSpec::Auto(_) if d >= 2 => Some(DofGeometry::of(model, dofs)),
        _ => None,
    };
    let hints = MatrixHints { dim: d, asymmetry, ordering: model.ordering(dofs), spd, geometry, n_side };
    progress.phase(&format!(
        "solving: {} unknowns, {} stored entries, solver {}",
        a.nrows(),
        a.val().len(),
        spec.resolve(d, a.nrows())
    ));
    let (u, report) = solve_assembled_with_progress(&a, rhs, spec, &hints, progress).map_err(at_dof)?;
    progress.phase(&format!("assembled in {t_asm:.3} s"));
    Ok((u, report))
}
