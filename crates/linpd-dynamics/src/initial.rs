//! Initial displacements of section 4.4 (domain `Omega = [0, 1000]`).
//!
//! * [`smooth_pulse`] (section 4.4.1): `p(x)`, a "smooth 21st order polynomial" with `p = 0` on
//!   `[0, 490] U [510, 1000]`, `p(500) = 1` and `p' = ... = p^(10) = 0` at 490, 500, 510. On
//!   each half it is the degree-21 smoothstep `S(s) = s^11 sum_{j=0}^{10} binom(10+j, j) (1-s)^j`
//!   (the unique degree-21 polynomial with those 22 conditions), `s = (x - 490)/10` on
//!   `[490, 500]` and `s = (510 - x)/10` on `[500, 510]`.
//! * [`square_pulse`] (4.14): `u = 1` on `[490, 510]`, `0` elsewhere. (4.14) puts `x = 490` in
//!   both cases (`[0, 490]` and `[490, 510]`); the closed interval `[490, 510]` is used here.

/// The smoothstep of degree 21, `S(0) = 0`, `S(1) = 1`, ten derivatives zero at both ends.
fn smoothstep21(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    let mut sum = 0.0;
    let mut binom = 1.0; // binom(10 + j, j)
    let mut pow = 1.0; // (1 - s)^j
    for j in 0..=10 {
        sum += binom * pow;
        binom *= (11 + j) as f64 / (j + 1) as f64;
        pow *= 1.0 - s;
    }
    s.powi(11) * sum
}

/// `p(x)` of section 4.4.1 (peak 1 at `x = 500`, support `[490, 510]`).
pub fn smooth_pulse(x: f64) -> f64 {
    if (490.0..=500.0).contains(&x) {
        smoothstep21((x - 490.0) / 10.0)
    } else if (500.0..=510.0).contains(&x) {
        smoothstep21((510.0 - x) / 10.0)
    } else {
        0.0
    }
}

/// The square pulse (4.14): 1 on `[490, 510]`, 0 elsewhere.
pub fn square_pulse(x: f64) -> f64 {
    if (490.0..=510.0).contains(&x) {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_pulse_meets_its_conditions() {
        assert_eq!(smooth_pulse(490.0), 0.0);
        assert!((smooth_pulse(500.0) - 1.0).abs() < 1e-15);
        assert_eq!(smooth_pulse(520.0), 0.0);
        // Independent form: S(s) is the binomial tail P(Bin(21, s) >= 11) (regularized incomplete
        // beta I_s(11, 11)); the two agree to round-off (rtol 1e-13).
        for s in [0.05f64, 0.1, 0.3, 0.5, 0.77, 0.95] {
            let mut tail = 0.0;
            for i in 11..=21 {
                let binom: f64 = (0..i).map(|q| (21 - q) as f64 / (q + 1) as f64).product();
                tail += binom * s.powi(i) * (1.0 - s).powi(21 - i);
            }
            let p = smooth_pulse(490.0 + 10.0 * s);
            assert!((p - tail).abs() <= 1e-13 * tail, "s = {s}: {p} vs {tail}");
            assert!((smooth_pulse(510.0 - 10.0 * s) - p).abs() <= 1e-13 * p, "symmetric about 500");
        }
        assert_eq!(square_pulse(490.0), 1.0);
        assert_eq!(square_pulse(510.0), 1.0);
        assert_eq!(square_pulse(510.5), 0.0);
    }
}
