//! The assembled blended operator against a literal transcription of Algorithm A (Seleson,
//! Beneddine & Prudhomme 2013, lines 1-52) for the inverse-distance kernel, entry for entry,
//! for the three blending functions; and the limits beta = 1 (eq. (29)) and beta = 0 (eq. (28)).

use linpd_blend::{BlendOperator, BlendParams, Blending, ModelKind};

/// Algorithm A as printed, on the uniform mesh of `op` (density form: rows of `-A / dx`...
/// the paper's `A` is the operator with `A u = -b`, so ours is `-dx` times it).
fn algorithm_a(beta: &[f64], n_side: usize, dx: f64, k: f64, set: &[u8]) -> Vec<Vec<(usize, f64)>> {
    let n = beta.len();
    let f_ce = k / (dx * dx);
    let f_pd = 2.0 * k / ((n_side * (n_side + 1)) as f64 * dx * dx);
    let mut rows = vec![std::collections::BTreeMap::<usize, f64>::new(); n];
    for i in 0..n {
        let mut add = |j: usize, v: f64| *rows[i].entry(j).or_insert(0.0) += v;
        match set[i] {
            // Lines 13-17: pure CE.
            1 => {
                add(i + 1, f_ce);
                add(i, -2.0 * f_ce);
                add(i - 1, f_ce);
            }
            // Lines 20-27: pure PD.
            2 => {
                for j in 1..=n_side {
                    let t = f_pd / j as f64;
                    add(i + j, t);
                    add(i, -2.0 * t);
                    add(i - j, t);
                }
            }
            // Lines 29-52: transition.
            3 => {
                let (mut sum1, mut sum2) = (0.0, 0.0);
                for j in 1..=n_side {
                    let t = f_pd / j as f64;
                    add(i + j, t * (beta[i] + beta[i + j]) / 2.0);
                    add(i, -t * (beta[i + j] + 2.0 * beta[i] + beta[i - j]) / 2.0);
                    add(i - j, t * (beta[i] + beta[i - j]) / 2.0);
                    sum1 += beta[i + j] - beta[i - j];
                    sum2 += (beta[i + j] + beta[i - j]) * j as f64;
                }
                // Line 42 prints f_PD/4; eq. (22) gives (K/(2 dx^2)) (2/(N(N+1))) / 2... both are
                // K/(N(N+1) dx^2) * (1/2) * sum: f_PD/4 = K / (2 N (N+1) dx^2). Consistent.
                let sum1 = f_pd / 4.0 * sum1;
                let sum2 = f_ce * (1.0 - beta[i] / 2.0 - sum2 / (2.0 * (n_side * (n_side + 1)) as f64));
                add(i + 1, -sum1);
                add(i - 1, sum1);
                add(i + 1, sum2);
                add(i, -2.0 * sum2);
                add(i - 1, sum2);
            }
            _ => {}
        }
    }
    rows.into_iter().map(|r| r.into_iter().collect()).collect()
}

fn compare(op: &BlendOperator, reference: &[Vec<(usize, f64)>], dx: f64, rows: impl Iterator<Item = usize>) -> usize {
    let mut checked = 0;
    for i in rows {
        if reference[i].is_empty() {
            continue;
        }
        let scale = reference[i].iter().fold(0.0f64, |a, (_, v)| a.max(v.abs()));
        for &(j, v) in &reference[i] {
            let ours = -op.get(i, j) / dx;
            // Sums of <= 4N terms of size <= scale: 8 N eps relative to the row's largest entry.
            assert!(
                (ours - v).abs() <= 8.0 * op.n_side as f64 * f64::EPSILON * scale,
                "row {i} col {j}: {ours} vs Algorithm A {v}"
            );
        }
        let stored = op.row_ptr[i + 1] - op.row_ptr[i];
        let nonzero = reference[i].iter().filter(|(_, v)| *v != 0.0).count();
        assert!(stored >= nonzero, "row {i}: {stored} stored < {nonzero} entries of Algorithm A");
        checked += 1;
    }
    checked
}

#[test]
fn blended_rows_equal_algorithm_a() {
    for blending in [Blending::Constant { value: 0.5 }, Blending::Linear, Blending::Cubic] {
        let p = BlendParams::table3(blending.clone());
        let op = BlendOperator::assemble(&p, ModelKind::Blended).unwrap();
        let n = p.n_side().unwrap();
        let dx = p.dx;
        let x = &op.mesh.x;
        // Node sets of section 5 (with 0-based indices).
        let r = &p.regions;
        let eps = p.horizon;
        let set: Vec<u8> = (0..x.len())
            .map(|i| {
                if i == 0 || i == x.len() - 1 {
                    0
                } else if x[i] < r.l1 - eps - 1e-12 || x[i] > r.l4 + eps + 1e-12 {
                    1
                } else if x[i] > r.l2 + eps + 1e-12 && x[i] < r.l3 - eps - 1e-12 {
                    2
                } else {
                    3
                }
            })
            .collect();
        let reference = algorithm_a(&op.beta, n, dx, p.modulus, &set);
        let checked = compare(&op, &reference, dx, 0..x.len());
        assert_eq!(checked, x.len() - 2, "{blending:?}");
        // Transition rows are exactly Algorithm A's set III (up to its boundary nodes whose
        // stencil is all-PD or all-CE, where set III's formula reduces to I or II).
        for i in 1..x.len() - 1 {
            if op.transition[i] && op.beta[i] > 0.0 && op.beta[i] < 1.0 {
                assert_eq!(set[i], 3, "bridge node {i} outside set III");
            }
        }
    }
}

#[test]
fn beta_one_is_eq_29_and_beta_zero_is_eq_28() {
    let p = BlendParams::table3(Blending::Cubic);
    let n = p.n_side().unwrap();
    let pd = BlendOperator::assemble(&p, ModelKind::PurePd).unwrap();
    let ce = BlendOperator::assemble(&p, ModelKind::PureCe).unwrap();
    let set_pd: Vec<u8> = (0..pd.len()).map(|i| if i >= n && i + n < pd.len() { 2 } else { 0 }).collect();
    let set_ce: Vec<u8> = (0..ce.len()).map(|i| if i >= 1 && i + 1 < ce.len() { 1 } else { 0 }).collect();
    let r_pd = algorithm_a(&pd.beta, n, p.dx, p.modulus, &set_pd);
    let r_ce = algorithm_a(&ce.beta, n, p.dx, p.modulus, &set_ce);
    assert_eq!(compare(&pd, &r_pd, p.dx, 0..pd.len()), pd.len() - 2 * n);
    assert_eq!(compare(&ce, &r_ce, p.dx, 0..ce.len()), ce.len() - 2);
    // And nothing else is stored in those rows (no stray local terms in pure PD rows).
    for i in n..pd.len() - n {
        assert_eq!(pd.row_ptr[i + 1] - pd.row_ptr[i], 2 * n + 1);
    }
}
