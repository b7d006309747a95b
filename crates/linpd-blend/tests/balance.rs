//! Force balance of the blended operator (crate docs, "Force balance").
//!
//! With the end rows holding the half-cell forces, `sum of reactions + sum of loads =
//! 1^T (A u - f) + 1^T f = c . u` with the column sums `c = A^T 1` (the free rows' residuals are
//! zero up to the solve's round-off). What holds, to round-off:
//! * `c` vanishes on every column out of reach of a transition row (PD and CE parts are
//!   symmetric with zero row sums);
//! * `c . q = 0` for every quadratic `q`: on quadratics each blended row is the PD row (section
//!   3.2), `-K q'' V_i`, and these sum with the end rows to `K (q'(L) - q'(0)) - K q'' L = 0`;
//! * so the imbalance of a solution is `c . (u - q)` for any quadratic `q`: it measures how far
//!   `u` is from a quadratic on the transition stencils, the Taylor remainder of eq. (12);
//! * and `c` is not zero: Algorithm A is not conservative for general fields (the paper's
//!   Newton's-third-law argument holds for fields cubic on the stencil, section 3.2).

use linpd_blend::{solve_model, BlendOperator, BlendParams, BlendSolver, Blending, Load, ModelKind};

fn column_sums(op: &BlendOperator) -> (Vec<f64>, Vec<f64>) {
    let mut c = vec![0.0; op.len()];
    let mut abs = vec![0.0; op.len()];
    for i in 0..op.len() {
        for q in op.row_ptr[i]..op.row_ptr[i + 1] {
            c[op.col[q]] += op.val[q];
            abs[op.col[q]] += op.val[q].abs();
        }
    }
    (c, abs)
}

/// Tolerances: a sum of `m` terms is exact to `m eps` of the sum of their absolute values
/// (`m` = the entries of a column, or all entries for `c . q`).
#[test]
fn column_sums_vanish_outside_transitions_and_on_quadratics() {
    for blending in [Blending::Constant { value: 0.5 }, Blending::Linear, Blending::Cubic] {
        for coarse in [None, Some(8.0 / 300.0)] {
            let mut p = BlendParams::table3(blending.clone());
            p.ce_spacing = coarse;
            let op = BlendOperator::assemble(&p, ModelKind::Blended).unwrap();
            let (c, abs) = column_sums(&op);
            let reach = op.n_side + 1;
            let near = |k: usize| (k.saturating_sub(reach)..=(k + reach).min(op.len() - 1)).any(|i| op.transition[i]);
            let m = (2 * op.n_side + 5) as f64;
            let mut biggest = 0.0f64;
            for k in 0..op.len() {
                if near(k) {
                    biggest = biggest.max(c[k].abs() / abs[k]);
                } else {
                    assert!(c[k].abs() <= m * f64::EPSILON * abs[k], "{blending:?} column {k}: {:e}", c[k]);
                }
            }
            assert!(biggest > 1e-6, "{blending:?}: the blended operator balanced exactly ({biggest:e})");
            let x = &op.mesh.x;
            for q in [|_: f64| 1.0, |x: f64| x, |x: f64| 0.3 - x + 2.0 * x * x] {
                let dot: f64 = (0..op.len()).map(|k| c[k] * q(x[k])).sum();
                let scale: f64 = (0..op.len()).map(|k| abs[k] * q(x[k]).abs()).sum();
                assert!(dot.abs() <= op.nnz() as f64 * f64::EPSILON * scale, "{blending:?} {coarse:?}: c.q = {dot:e}");
            }
        }
    }
}

/// The solved Table 3 problem: reactions + loads = `c . u` (to the solve's round-off:
/// `n eps ||A|| ||u||`, with ||A|| ~ 4/dx), and it is small (8.1e-11 of the load) because the
/// point load is 5 horizons from the transitions; a load inside a bridge is not.
#[test]
fn the_imbalance_is_the_column_sum_functional() {
    let p = BlendParams::table3(Blending::Cubic);
    let op = BlendOperator::assemble(&p, ModelKind::Blended).unwrap();
    let (c, _) = column_sums(&op);
    let bound = op.len() as f64 * f64::EPSILON * 4.0 / p.dx;
    for (xp, small) in [(0.5, true), (0.2, false)] {
        let s = solve_model(&p, ModelKind::Blended, 0.0, 0.0, &[Load::Point { x: xp, force: 1.0 }], BlendSolver::Auto)
            .unwrap();
        let imbalance = s.reactions[0] + s.reactions[1] + s.applied;
        let cu: f64 = c.iter().zip(&s.u).map(|(c, u)| c * u).sum();
        let umax = s.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        eprintln!("load at {xp}: imbalance {imbalance:e}, c.u {cu:e}");
        assert!((imbalance - cu).abs() <= bound * umax, "load at {xp}: {imbalance:e} vs c.u = {cu:e}");
        assert_eq!(imbalance.abs() < 1e-10, small, "load at {xp}: imbalance {imbalance:e}");
    }
}
