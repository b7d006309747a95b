//! `"type": "lps"` scenes: the linearized LPS tangent (crates/linpd-lps) with the same volume
//! constraints, loads and solvers as the bond-based model.
//!
//! The tangent couples nodes up to two horizons apart (the dilatation of a neighbour), so the
//! nested-dissection separators are `2 delta / h` planes thick. Constraints are eliminated as for
//! the bond model: `A_ff u_f = f_f - (A u_bar)_f`, with `A u_bar` applied matrix-free in factored
//! form.

use crate::{Problem, ProblemError, Solution};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use linpd_bond::{check_support, nested_dissection, BondOperator};
use linpd_core::DofMap;
use linpd_lps::{assemble_tangent, LpsModel, LpsParams};
use linpd_solve::{auto_choice, solve_with_ordering, SolveError, SolverKind};
use std::time::Instant;

/// The rows and columns of `a` at free DOFs (order kept, so sorted columns stay sorted).
pub fn reduce_to_free(a: &SparseColMat<usize, f64>, dofs: &DofMap) -> SparseColMat<usize, f64> {
    reduce(a, dofs)
}

fn reduce(a: &SparseColMat<usize, f64>, dofs: &DofMap) -> SparseColMat<usize, f64> {
    let cp = a.symbolic().col_ptr();
    let ri = a.symbolic().row_idx();
    let (mut col_ptr, mut rows, mut vals) = (vec![0usize], Vec::new(), Vec::new());
    for j in 0..a.ncols() {
        if dofs.is_constrained(j) {
            continue;
        }
        for p in cp[j]..cp[j + 1] {
            if let Some(r) = dofs.free(ri[p]) {
                rows.push(r);
                vals.push(a.val()[p]);
            }
        }
        col_ptr.push(rows.len());
    }
    let n = dofs.n_free();
    SparseColMat::new(SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows), vals)
}

/// Solves an lps scene.
pub(crate) fn solve(p: &Problem, params: &LpsParams, progress: &dyn Fn(&str)) -> Result<Solution, ProblemError> {
    let d = p.dim();
    let t0 = Instant::now();
    progress(&format!(
        "building the LPS model: {} nodes, horizon/spacing = {:.3}",
        p.grid.len(),
        params.horizon / p.grid.spacing()
    ));
    let model = LpsModel::new(&p.grid, params).map_err(|e| ProblemError::invalid("model", e.to_string()))?;
    let (mask, ubar) = p.constrained();
    let dofs = DofMap::new(d, &mask);
    if dofs.n_free() == 0 {
        return Err(ProblemError::invalid("constraints", "every DOF is constrained: nothing to solve"));
    }
    // Rigid-motion check on the bond graph of the family (every LPS bond is active).
    let family = model.family().clone();
    let support = BondOperator::from_parts(d, model.positions().to_vec(), family.clone(), vec![1.0; family.n_bonds()]);
    check_support(&support, &dofs).map_err(|e| ProblemError::Unsupported(e.to_string()))?;
    let f_full = p.load_vector();
    let mut a_ubar = vec![0.0; d * p.grid.len()];
    model.apply_tangent(&ubar, &mut a_ubar);
    let rhs: Vec<f64> = f_full.iter().zip(&a_ubar).map(|(f, a)| f - a).collect();
    let f_free = dofs.gather(&rhs);
    progress("assembling the LPS tangent (reach 2 horizons)");
    let a = reduce(&assemble_tangent(&model), &dofs);
    let t_asm = t0.elapsed().as_secs_f64();
    let reach = (2.0 * params.horizon / p.grid.spacing() * (1.0 + linpd_core::GEOMETRY_RTOL)).floor() as usize;
    let perm = nested_dissection(&p.grid, reach, &dofs);
    let kind = match &p.solver.kind {
        SolverKind::Auto => match auto_choice(d, a.nrows()) {
            SolverKind::Cg(_) => SolverKind::Cg(p.solver.cg.clone()),
            k => k,
        },
        k => k.clone(),
    };
    progress(&format!("solving: {} unknowns, {} stored entries, {kind:?}", a.nrows(), a.val().len()));
    let (u_free, mut report) = solve_with_ordering(&a, &f_free, &kind, d, Some(&perm)).map_err(|e| match e {
        SolveError::NotPositiveDefinite { dof } | SolveError::Singular { dof } => {
            let full = dofs.free_dofs()[dof];
            ProblemError::Solve(format!("{e}: node {} component {}", full / d, full % d))
        }
        other => ProblemError::Solve(other.to_string()),
    })?;
    report.timings.assemble = t_asm;
    let mut u = ubar;
    dofs.scatter(&u_free, &mut u);
    progress(&format!("done in {:.3} s, relative residual {:.2e}", t0.elapsed().as_secs_f64(), report.rel_residual));
    Ok(Solution {
        name: p.name.clone(),
        dim: d,
        x: model.positions().to_vec(),
        u,
        is_layer: (0..p.grid.len()).map(|n| p.grid.is_layer(n)).collect(),
        n_bonds: family.n_bonds(),
        report,
    })
}
