//! A new preconditioner is its module and one registry line (issue #51): symmetric
//! Gauss-Seidel, defined whole in this file (its `Preconditioner` and its `PreconditionerType`),
//! is selected by a solver spec, weighed by `auto` once it is among the candidates
//! (`AutoParams::preconditioners`, whose default is the registry
//! `linpd_solve::precond::kind::PRECONDITIONERS`), and counted by the memory guard through the
//! solver plan, without a change anywhere else in linpd. The files this took: this one.

mod common;

use common::{residual_by_entries, spd};
use linpd_core::Csc;
use linpd_solve::cost::Estimate;
use linpd_solve::precond::kind::{AutoInput, Operator, PreconditionerType, SetupOn};
use linpd_solve::statics::{solve_assembled_with_auto, AutoParams};
use linpd_solve::{
    plan, CgParams, MatrixHints, Offers, Preconditioner, PreconditionerInput, PreconditionerKind, SolveError, SolverId,
    SolverSpec,
};

/// `M = (D + L) D^-1 (D + U)` of a symmetric `A` (both triangles stored): a forward and a
/// backward Gauss-Seidel sweep.
struct Sgs<'a> {
    a: &'a Csc,
    diagonal: Vec<f64>,
}

impl Preconditioner for Sgs<'_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = r.len();
        // (D + L) y = r: column i of a symmetric A is its row i
        let mut y = vec![0.0; n];
        for i in 0..n {
            let lower: f64 =
                self.a.row_idx_of_col(i).zip(self.a.val_of_col(i)).filter(|(j, _)| *j < i).map(|(j, v)| v * y[j]).sum();
            y[i] = (r[i] - lower) / self.diagonal[i];
        }
        // (D + U) z = D y
        for i in (0..n).rev() {
            let upper: f64 =
                self.a.row_idx_of_col(i).zip(self.a.val_of_col(i)).filter(|(j, _)| *j > i).map(|(j, v)| v * z[j]).sum();
            z[i] = y[i] - upper / self.diagonal[i];
        }
    }
}

/// Its registry entry.
struct SgsType;

/// Bytes a DOF its setup is declared to add (its copy of the diagonal): what the plan's memory
/// estimate must count.
const SGS_DOF_BYTES: f64 = 8.0;

impl PreconditionerType for SgsType {
    fn name(&self) -> &'static str {
        "sgs"
    }
    fn build<'a>(&self, input: &PreconditionerInput<'a>) -> Result<Box<dyn Preconditioner + 'a>, SolveError> {
        let a = input.matrix.ok_or_else(|| SolveError::NoSolverFits("sgs needs the assembled matrix".into()))?;
        Ok(Box::new(Sgs { a, diagonal: input.diagonal.to_vec() }))
    }
    /// Declared the cheapest PCG, so that `auto` takes it when offered it.
    fn auto_estimate(&self, input: &AutoInput) -> Option<Estimate> {
        Some(Estimate { solver: "cg-sgs".into(), seconds: Some(1e-9), why: format!("{} entries", input.nnz) })
    }
    fn hierarchy_bytes(&self, on: &SetupOn) -> f64 {
        SGS_DOF_BYTES * on.dofs as f64
    }
}

static SGS: SgsType = SgsType;

fn sgs() -> PreconditionerKind {
    PreconditionerKind::new(&SGS)
}

fn system() -> (Csc, Vec<f64>) {
    let a = spd(30);
    let b = (0..a.nrows()).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    (a, b)
}

/// Selected by name in a spec, PCG with it converges to the tolerance, in fewer iterations than
/// Jacobi (Gauss-Seidel smooths an M-matrix better than the diagonal; both are SPD here).
#[test]
fn selected_it_solves_and_beats_jacobi() {
    let (a, b) = system();
    let params = CgParams { rtol: 1e-10, max_iter: 2000 };
    let hints = MatrixHints::symmetric(2);
    let run = |k| {
        let spec = SolverSpec::Cg { params: params.clone(), preconditioner: k, matrix_free: false };
        solve_assembled_with_auto(&a, &b, &spec, &hints, &AutoParams::default(), &linpd_core::NoProgress).unwrap()
    };
    let (u, sgs_report) = run(sgs());
    assert_eq!(sgs_report.solver.to_string(), "cg-sgs");
    // CG stops at rtol 1e-10 of the recursive residual; the true one within 10x of it
    assert!(residual_by_entries(&a, &u, &b) < 1e-9, "{:e}", residual_by_entries(&a, &u, &b));
    let (_, jacobi_report) = run(PreconditionerKind::JACOBI);
    let (ks, kj) = (sgs_report.iterations.unwrap(), jacobi_report.iterations.unwrap());
    assert!(ks < kj, "sgs {ks} iterations, jacobi {kj}");
}

/// `auto` weighs it once it is a candidate: declared cheapest, it runs; with the registry's
/// candidates alone it does not.
#[test]
fn auto_weighs_it_among_the_candidates() {
    let (a, b) = system();
    let hints = MatrixHints::symmetric(2);
    let spec = SolverSpec::Auto(CgParams { rtol: 1e-10, max_iter: 2000 });
    let mut auto = AutoParams::default();
    let (_, default) = solve_assembled_with_auto(&a, &b, &spec, &hints, &auto, &linpd_core::NoProgress).unwrap();
    assert_ne!(default.solver, SolverId::Cg { preconditioner: sgs(), matrix_free: linpd_solve::MatrixFree::No });
    auto.preconditioners.push(sgs());
    let (u, report) = solve_assembled_with_auto(&a, &b, &spec, &hints, &auto, &linpd_core::NoProgress).unwrap();
    assert_eq!(report.solver.to_string(), "cg-sgs");
    assert!(report.auto.as_deref().unwrap_or_default().contains("cg-sgs est."), "{:?}", report.auto);
    assert!(residual_by_entries(&a, &u, &b) < 1e-9);
}

/// The plan of a solve with it names it, and the memory guard's setup bytes are its own.
#[test]
fn the_plan_counts_its_setup() {
    let offers = Offers { dim: 2, unknowns: 900, symmetric: true, fast_apply: false, companion_gmres: false };
    let spec = SolverSpec::Cg { params: CgParams::default(), preconditioner: sgs(), matrix_free: false };
    let p = plan(&spec, &offers, &AutoParams::default());
    assert_eq!(p.preconditioners, vec![sgs()]);
    let on = SetupOn { dim: 2, nodes: 450, dofs: 900, operator: Operator::Assembled };
    assert_eq!(p.setup_bytes(&on), SGS_DOF_BYTES * 900.0);
    // auto on the assembled matrix may take any candidate: the largest setup is counted
    let mut auto = AutoParams::default();
    auto.preconditioners.push(sgs());
    let p = plan(&SolverSpec::Auto(CgParams::default()), &offers, &auto);
    let multigrid = PreconditionerKind::MULTIGRID.hierarchy_bytes(&on);
    assert_eq!(p.setup_bytes(&on), multigrid.max(SGS_DOF_BYTES * 900.0));
}
