//! The finite-difference tangent: the benchmark baseline for the analytic assembly.
//!
//! Peridigm's default implicit tangent is built by finite differences of the internal force,
//! one perturbed degree of freedom at a time, evaluating the force only where it can change.
//! [`fd_tangent`] does the same with this crate's force: for every node `p` and component
//! `a`, the displacement `+-eps e_a` of node `p` alone changes `theta_k` only for
//! `k in {p} U F_p` and the force only on nodes within `2 delta` of `p` (the rows of the
//! analytic pattern, [`crate::TangentPattern`]); those rows get
//!
//! ```text
//! A[(q, c), (p, a)] = -(F_qc(+eps e_pa) - F_qc(-eps e_pa)) / (2 eps)
//! ```
//!
//! evaluated with the very per-node sums of [`crate::LpsModel::internal_force`] and
//! [`crate::LpsModel::theta`] (not a re-derivation), so it is the central-difference Jacobian
//! of `internal_force` restricted to the analytic pattern. The linearization point is the
//! reference configuration `u = 0`, like [`crate::assemble_tangent`]. Cost per node:
//! `2 d` force evaluations over the `2 delta` neighbourhood, `O(n |F|^2 2^d d)` overall,
//! parallel over column nodes. The truncation error is `O((eps / h)^2)` relative (the
//! geometric nonlinearity of `|Y|`), the round-off `O(1e-16 h / eps)`; `eps = 1e-6 h` gives
//! about `1e-9` relative agreement with the analytic tangent.

use crate::{LpsModel, TangentPattern};
use faer::sparse::SparseColMat;
use rayon::prelude::*;

/// The central-difference tangent `A = -dF/du` at `u = 0` of `model`'s internal force, on the
/// same pattern as [`crate::assemble_tangent`] (both triangles, structural zeros kept);
/// `eps` is the displacement perturbation (e.g. `1e-6 h`).
pub fn fd_tangent(model: &LpsModel, eps: f64) -> SparseColMat<usize, f64> {
    assert!(eps.is_finite() && eps > 0.0, "eps must be a positive number, got {eps}");
    let pattern = TangentPattern::new(model);
    let symbolic = pattern.symbolic().clone();
    let d = model.dim;
    let n = model.n_nodes();
    let col_ptr = symbolic.col_ptr();
    let row_idx = symbolic.row_idx();
    let mut values = vec![0.0; row_idx.len()];
    // Split the values into the d columns of every node.
    let mut slices = Vec::with_capacity(n);
    let mut rest: &mut [f64] = &mut values;
    for p in 0..n {
        let (head, tail) = rest.split_at_mut(col_ptr[d * p + d] - col_ptr[d * p]);
        slices.push(head);
        rest = tail;
    }
    slices.into_par_iter().enumerate().for_each_init(
        || vec![0.0f64; n],
        |theta, (p, vals)| {
            let base = col_ptr[d * p];
            // Rows of column (p, 0): the nodes within 2 delta (same for every component).
            let rows: Vec<usize> =
                row_idx[col_ptr[d * p]..col_ptr[d * p + 1]].iter().step_by(d).map(|&r| r / d).collect();
            let affected: Vec<usize> = std::iter::once(p).chain(model.bonds(p).map(|(k, _, _)| k)).collect();
            let mut forces = [vec![[0.0; 3]; rows.len()], vec![[0.0; 3]; rows.len()]];
            for a in 0..d {
                for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
                    let disp = |j: usize| {
                        let mut u = [0.0; 3];
                        if j == p {
                            u[a] = sign * eps;
                        }
                        u
                    };
                    for &k in &affected {
                        theta[k] = model.theta_at(k, disp);
                    }
                    let th = &*theta;
                    for (r, &q) in rows.iter().enumerate() {
                        forces[s][r] = model.force_at(q, disp, |j| th[j]);
                    }
                    for &k in &affected {
                        theta[k] = 0.0;
                    }
                }
                let col = &mut vals[col_ptr[d * p + a] - base..col_ptr[d * p + a + 1] - base];
                for (r, _) in rows.iter().enumerate() {
                    for c in 0..d {
                        col[d * r + c] = -(forces[0][r][c] - forces[1][r][c]) / (2.0 * eps);
                    }
                }
            }
        },
    );
    SparseColMat::new(symbolic, values)
}
