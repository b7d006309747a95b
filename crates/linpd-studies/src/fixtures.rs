//! Paper fixtures shared by the studies: the dense reference computations of Silling (2010),
//! section 5 (Example 5.2, the striped composite of Fig. 5) that do not belong in a model crate.
//!
//! The level-0 micromoduli themselves (tent, composite, defect, `r0`) are in
//! [`linpd_coarsen::paper`]; this module adds the independent checks built on them.
//!
//! (`crates/linpd-coarsen/tests/examples.rs` and `tests/coarsen.rs` still hold their own copies
//! of [`gauss`] and [`cell_modulus`]: a model crate's tests cannot depend on this crate, which
//! depends on the model crate.)

/// Level-0 spacing = node volume `v = 0.005` of Silling (2010), section 5 (bar `[0, 1]`, 201
/// nodes).
pub const H: f64 = 0.005;

/// Dense Gaussian elimination with partial pivoting (independent of faer and of the model
/// crates): solves `a x = b` for a small dense system, e.g. the 20-node periodic cell.
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

/// Effective bar modulus of the periodic cell of `n` nodes (spacing = volume [`H`], period
/// `n H`) with micromodulus `c` evaluated on the cell positions and their periodic images
/// (independent of the coarsening).
///
/// `u = eps x + w`, `w` periodic with `w_0 = 0`; cell equilibrium
/// `sum_b C_b (eps d_b + w_j - w_i) v = 0` at every node; node energy density
/// `W_i = 1/4 sum_b C_b (eps d_b + w_j - w_i)^2 v`; `E = 2 <W> / eps^2` (energy per unit length
/// = `<W>` since every node has volume `H` and the cell length is `n H`).
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
        // a[0][0] = 0: without the row swap the elimination divides by zero.
        let x = gauss(vec![vec![0.0, 2.0, 1.0], vec![1.0, 1.0, 0.0], vec![2.0, 0.0, 3.0]], vec![7.0, 3.0, 11.0]);
        for (xi, ei) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((xi - ei).abs() < 1e-14, "{x:?}");
        }
    }

    #[test]
    fn cell_modulus_of_a_homogeneous_cell_is_the_bar_modulus() {
        // Constant C = 1 for 0 < |q - x| < r0 = 10 H: w = 0 by symmetry and
        // E = sum over the 18 bonds of a node of C d^2 v / 2 = H^3 sum_{k=1}^{9} k^2 = 285 H^3 (`inside`
        // excludes |q - x| = r0).
        let c = |x: f64, q: f64| {
            if linpd_coarsen::paper::inside((q - x).abs(), linpd_coarsen::paper::R0) {
                1.0
            } else {
                0.0
            }
        };
        let e = cell_modulus(20, c);
        let expected = 285.0 * H.powi(3);
        assert!((e - expected).abs() < 1e-9 * expected, "{e} vs {expected}");
    }
}
