//! The level-0 bar of Silling (2010), Example 5.1 (spacing = volume `v = 0.005`, `r0 = 10 v`,
//! tent micromodulus), and a dense Gaussian elimination: test data of the coarsening step and a
//! reference solver that shares no code path with the crate. (linpd-studies' `fixtures` holds
//! all of section 5's fixtures, for the paper-example tests and the studies.)

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

/// Dense Gaussian elimination with partial pivoting: solves `a x = b` for a small dense system
/// (the paper's section 5 solves its boundary value problems "using Gaussian elimination").
/// Independent of faer and of linpd-coarsen, so that the tests can check the crate with it;
/// `O(n^3)`, meant for small reference systems.
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
