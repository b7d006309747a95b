//! Axis ranges from data. A chart's axes span the data with a margin: 5 % on each side of a
//! linear axis, whole decades on a logarithmic one (so that it always has labelled ticks). A
//! constant (or nearly constant) range is widened, since plotters cannot draw an empty axis.
//!
//! The arithmetic works on halves (`hi / 2 - lo / 2` rather than `hi - lo`), so that a range
//! spanning most of `f64` (`-f64::MAX..f64::MAX`) neither overflows to infinity nor makes the
//! padding NaN: the functions here never fail on finite input.

use std::ops::Range;

/// True when `[lo, hi]` is empty or too narrow to be resolved in f64 ticks.
pub(crate) fn is_degenerate(lo: f64, hi: f64) -> bool {
    let half_span = hi / 2.0 - lo / 2.0;
    half_span <= 1e-12 * lo.abs().max(hi.abs()) || half_span <= f64::MIN_POSITIVE
}

/// Range of finite `[lo, hi]` (lo <= hi) with a 5% margin; a (nearly) constant range is
/// widened around its centre. Never overflows to infinity.
pub(crate) fn linear_range(lo: f64, hi: f64) -> Range<f64> {
    let (lo, hi) = if is_degenerate(lo, hi) {
        let c = lo / 2.0 + hi / 2.0;
        let d = if c == 0.0 { 1.0 } else { 0.1 * c.abs() };
        (c - d, c + d)
    } else {
        let pad = 0.1 * (hi / 2.0 - lo / 2.0);
        (lo - pad, hi + pad)
    };
    let lo = if lo.is_finite() { lo } else { f64::MIN };
    let hi = if hi.is_finite() { hi } else { f64::MAX };
    lo..hi
}

/// Range of positive finite `[lo, hi]` (lo <= hi) widened to whole decades, so that the
/// logarithmic axis always has labelled ticks.
pub(crate) fn log_range(lo: f64, hi: f64) -> Range<f64> {
    let mut a = 10f64.powf(lo.log10().floor());
    let mut b = 10f64.powf(hi.log10().ceil());
    if !(a > 0.0 && a <= lo) {
        a = lo;
    }
    if !(b.is_finite() && b >= hi) {
        b = hi;
    }
    if b <= a * (1.0 + 1e-9) {
        // Constant data at an exact power of ten (or at the extremes of f64).
        if (a / 10.0) > 0.0 {
            a /= 10.0;
        }
        if (b * 10.0).is_finite() {
            b *= 10.0;
        }
    }
    // Nudge outwards so that round-off in plotters' log tick generation keeps the end decades.
    let (a2, b2) = (a * (1.0 - 1e-9), b * (1.0 + 1e-9));
    (if a2 > 0.0 { a2 } else { a })..(if b2.is_finite() { b2 } else { b })
}

/// Position of `v` in `[lo, hi]` as a fraction, without overflow for huge ranges.
pub(crate) fn fraction(v: f64, lo: f64, hi: f64) -> f64 {
    (v / 2.0 - lo / 2.0) / (hi / 2.0 - lo / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_sane() {
        let r = linear_range(5.0, 5.0);
        assert!(r.start < 5.0 && r.end > 5.0);
        let r = linear_range(0.0, 0.0);
        assert_eq!(r, -1.0..1.0);
        let r = linear_range(0.0, 10.0);
        assert!((r.start + 0.5).abs() < 1e-12 && (r.end - 10.5).abs() < 1e-12);
        let r = linear_range(-f64::MAX, f64::MAX);
        assert!(r.start.is_finite() && r.end.is_finite() && r.start < r.end);

        let r = log_range(2.0, 30.0);
        assert!((r.start - 1.0).abs() < 1e-6 && r.start <= 1.0);
        assert!((r.end - 100.0).abs() < 1e-6 && r.end >= 100.0);
        let r = log_range(1e-2, 1e-2);
        assert!((r.start / 1e-3 - 1.0).abs() < 1e-6 && (r.end / 1e-1 - 1.0).abs() < 1e-6);
        let r = log_range(f64::MAX, f64::MAX);
        assert!(r.start.is_finite() && r.end.is_finite() && r.start < r.end);
        let r = log_range(f64::MIN_POSITIVE, 1.0);
        assert!(r.start > 0.0 && r.start <= f64::MIN_POSITIVE);
    }
}
