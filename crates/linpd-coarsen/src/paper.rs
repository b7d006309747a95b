//! The level-0 micromoduli of Silling (2010), section 5: bar [0, 1], spacing `v = 0.005`,
//! `r0 = 0.05` (shared by the paper-example tests, the `coarsen-*` studies and the benchmark).

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
