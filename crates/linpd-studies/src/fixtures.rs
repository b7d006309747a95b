//! Paper fixtures of the studies: the level-0 micromoduli of Silling (2010), section 5 (bar
//! [0, 1], spacing `v = 0.005`, `r0 = 0.05`), and the independent dense reference computations
//! built on them (the periodic cell's effective modulus of Example 5.2, by Gaussian elimination
//! as in the paper's section 5). Used by the `coarsen-*` studies and by the paper-example tests
//! (`tests/coarsen_examples.rs`).
//!
//! The reference computations use no coarsening code and no sparse solver: they check
//! linpd-coarsen, so they must not share its code paths.

/// Level-0 spacing = node volume `v = 0.005` (section 5.1: `r0 = 10 v`; bar `[0, 1]`, 201
/// nodes).
pub const H: f64 = 0.005;

/// Level-0 interaction distance `r0`.
pub const R0: f64 = 0.05;

/// `0 < d < r` with the float comparison guarded: bond lengths are differences of `i * H`, so a
/// bond of exactly 10 spacings may come out as 0.04999999999 and must still be excluded.
pub fn inside(d: f64, r: f64) -> bool {
    d > 1e-9 * r && d < r * (1.0 - 1e-9)
}

/// Example 5.1: tent `C0 = 1 - |q - x| / r0` for `0 < |q - x| < r0`.
pub fn tent(x: f64, q: f64) -> f64 {
    let d = (q - x).abs();
    if inside(d, R0) {
        1.0 - d / R0
    } else {
        0.0
    }
}

/// Example 5.2 stripes: stripe `k = [0.05 k, 0.05 (k + 1))`, even `k` hard. A node on a stripe
/// boundary belongs to the stripe on its right (the `1e-9` shift, relative to the stripe width,
/// absorbs the rounding of `i * H / 0.05`).
pub fn hard(x: f64) -> bool {
    ((x / 0.05 + 1e-9).floor() as i64) % 2 == 0
}

/// Example 5.2 micromodulus: 10 if both ends hard, 1 if either end soft.
pub fn composite(x: f64, q: f64) -> f64 {
    if !inside((q - x).abs(), R0) {
        0.0
    } else if hard(x) && hard(q) {
        10.0
    } else {
        1.0
    }
}

/// Example 5.3: defect location.
pub const X_DEFECT: f64 = 0.5;

/// Example 5.3: tent times `mu = 0.1` for bonds with `x <= x_d <= q` or `q <= x_d <= x`. The
/// inequalities are closed as printed, so the node at `x_d = 0.5` has *all* its bonds weakened
/// (followed literally; a half-open rule would weaken only one side of it).
pub fn defect(x: f64, q: f64) -> f64 {
    let t = 1e-9;
    let crosses = (x <= X_DEFECT + t && X_DEFECT - t <= q) || (q <= X_DEFECT + t && X_DEFECT - t <= x);
    tent(x, q) * if crosses { 0.1 } else { 1.0 }
}

/// Dense Gaussian elimination with partial pivoting: solves `a x = b` for a small dense system
/// (the paper's section 5 solves its boundary value problems "using Gaussian elimination").
/// Independent of faer and of linpd-coarsen, so that tests can check the coarsening with it;
/// `O(n^3)`, meant for the 20-40 node periodic cells and small reference systems.
///
/// Panics on a singular system only through a division by zero (a NaN or infinite result).
pub fn gauss(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs())).unwrap();
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    x
}

/// Effective bar modulus of the periodic cell of `n` level-0 nodes (spacing = volume [`H`],
/// period `n H`) with micromodulus `c(x, q)` evaluated on the cell positions and their periodic
/// images: the reference for Example 5.2's claim that the coarse levels keep the composite's
/// bulk stiffness (the global stretch under the load `F` is `F / E_eff`). Independent of the
/// coarsening.
///
/// `u = eps x + w` with `w` periodic and `w_0 = 0`. Cell equilibrium is eq. (3)-(4) of the paper
/// with no body force (5), discretized with the node volume `v = H`:
/// `sum_b C_b (eps d_b + w_j - w_i) v = 0` at every node `i`. Node energy density (the linear
/// pair potential whose force is the integrand of (4)):
/// `W_i = 1/4 sum_b C_b (eps d_b + w_j - w_i)^2 v`, and `E = 2 <W> / eps^2` (energy per unit
/// length = `<W>` since every node has volume `H` and the cell length is `n H`).
pub fn cell_modulus(n: usize, c: impl Fn(f64, f64) -> f64) -> f64 {
    let (period, eps) = (n as f64 * H, 1e-3);
    let y: Vec<f64> = (0..n).map(|i| i as f64 * H).collect();
    // bonds (i, j, d, C) over the images s = -2..=2 (the period exceeds r0, so +-1 suffice)
    let mut bonds = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for s in -2i32..=2 {
                let q = y[j] + s as f64 * period;
                let cij = c(y[i], q);
                if cij != 0.0 {
                    bonds.push((i, j, q - y[i], cij));
                }
            }
        }
    }
    let (mut a, mut b) = (vec![vec![0.0; n]; n], vec![0.0; n]);
    for &(i, j, d, cij) in &bonds {
        a[i][j] += cij * H;
        a[i][i] -= cij * H;
        b[i] -= eps * cij * d * H;
    }
    a[0] = vec![0.0; n];
    a[0][0] = 1.0;
    b[0] = 0.0;
    let w = gauss(a, b);
    let energy: f64 = bonds.iter().map(|&(i, j, d, cij)| 0.25 * cij * (eps * d + w[j] - w[i]).powi(2) * H).sum();
    2.0 * (energy / n as f64) / (eps * eps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_solves_a_system_that_needs_pivoting() {
        // a[0][0] = 0: without the row swap the elimination divides by zero. Exact solution
        // (1, 2, 3); a 3x3 elimination rounds a few times: 1e-14.
        let x = gauss(vec![vec![0.0, 2.0, 1.0], vec![1.0, 1.0, 0.0], vec![2.0, 0.0, 3.0]], vec![7.0, 3.0, 11.0]);
        for (xi, ei) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((xi - ei).abs() < 1e-14, "{x:?}");
        }
    }

    #[test]
    fn cell_modulus_of_a_homogeneous_cell_is_the_bar_modulus() {
        // Constant C = 1 for 0 < |q - x| < r0 = 10 H: w = 0 by symmetry and
        // E = sum over the 18 bonds of a node of C d^2 v / 2 = H^3 sum_{k=1}^{9} k^2 = 285 H^3
        // (`inside` excludes |q - x| = r0). A 20-node solve and a sum of 360 terms: 1e-9
        // relative is far above their round-off and far below any missing bond (1/285).
        let c = |x: f64, q: f64| if inside((q - x).abs(), R0) { 1.0 } else { 0.0 };
        let e = cell_modulus(20, c);
        let expected = 285.0 * H.powi(3);
        assert!((e - expected).abs() < 1e-9 * expected, "{e} vs {expected}");
    }

    #[test]
    fn tent_and_composite_follow_the_printed_definitions() {
        // Example 5.1 at a quarter, half and the full horizon (excluded), and d = 0 (excluded).
        assert_eq!(tent(0.5, 0.5), 0.0);
        assert!((tent(0.5, 0.5 + R0 / 4.0) - 0.75).abs() < 1e-12);
        assert!((tent(0.5, 0.5 - R0 / 2.0) - 0.5).abs() < 1e-12);
        assert_eq!(tent(0.0, 10.0 * H), 0.0, "a bond of exactly r0 = 10 v is not in the family");
        // Example 5.2: stripe [0, 0.05) hard, [0.05, 0.1) soft.
        assert_eq!(composite(0.01, 0.02), 10.0);
        assert_eq!(composite(0.04, 0.06), 1.0);
        assert_eq!(composite(0.06, 0.07), 1.0);
        // Example 5.3: bonds crossing x_d are weakened by mu = 0.1.
        assert!((defect(0.49, 0.51) - 0.1 * tent(0.49, 0.51)).abs() < 1e-15);
        assert_eq!(defect(0.3, 0.31), tent(0.3, 0.31));
    }
}
