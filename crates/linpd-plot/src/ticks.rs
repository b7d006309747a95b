//! Axis ticks and their labels. plotters places the ticks of a linear axis itself, but formats
//! them with as many digits as an `f64` prints (`0.30000000000000004`) and has no idea of
//! scientific notation; the labels here carry just enough digits to tell neighbouring ticks
//! apart, switch to `1.5e-7` for very small or large magnitudes and never print `-0`.
//! Logarithmic axes get their ticks from here (powers of ten, thinned out over many decades,
//! with 2x and 5x on short axes), and so does the colour bar (round values: multiples of 1, 2
//! or 5 x 10^k), which plotters does not draw at all.

/// Approximate number of ticks plotters puts on an axis (used to choose label precision).
pub(crate) const AXIS_TICKS: f64 = 20.0;

/// At most `max` round tick values in `[lo, hi]`: the multiples of the smallest step
/// `s = m 10^k` (`m` in 1, 2, 5) with at most `max` multiples in the range. `None` for a
/// non-finite or empty range.
pub(crate) fn nice_ticks(lo: f64, hi: f64, max: usize) -> Option<Vec<f64>> {
    let span = hi / 2.0 - lo / 2.0; // half span: no overflow for huge ranges
    if !(lo.is_finite() && hi.is_finite() && span > 0.0 && max >= 2) {
        return None;
    }
    let raw = 2.0 * span / (max - 1) as f64;
    let k = raw.log10().floor();
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * 10f64.powf(k)).find(|s| *s >= raw * (1.0 - 1e-12))?;
    let first = (lo / step - 1e-9).ceil();
    let last = (hi / step + 1e-9).floor();
    if !(first.is_finite() && last.is_finite()) || last - first > 100.0 {
        return None;
    }
    Some((first as i64..=last as i64).map(|i| i as f64 * step).map(|v| if v == 0.0 { 0.0 } else { v }).collect())
}

/// Label for a tick value `v` on a linear scale spanning `[lo, hi]` with about `n` ticks:
/// enough digits to tell neighbouring ticks apart, scientific notation for very large or
/// small magnitudes, no "-0".
pub(crate) fn tick_label(v: f64, lo: f64, hi: f64, n: f64) -> String {
    let half_span = hi / 2.0 - lo / 2.0;
    if !(v.is_finite() && half_span.is_finite() && half_span > 0.0) {
        return format!("{v}");
    }
    if v.abs() <= half_span * 1e-9 {
        return "0".to_string();
    }
    let step_exp = (2.0 * half_span / n).log10().floor();
    let m = lo.abs().max(hi.abs());
    let m_exp = m.log10().floor();
    if !(1e-3..1e5).contains(&m) {
        let digits = (m_exp - step_exp).clamp(0.0, 12.0) as usize;
        let s = format!("{v:.digits$e}");
        match s.split_once('e') {
            Some((mant, exp)) if mant.contains('.') => {
                format!("{}e{exp}", mant.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    } else {
        let decimals = (-step_exp).clamp(0.0, 15.0) as usize;
        let s = format!("{v:.decimals$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        if s == "-0" {
            "0".to_string()
        } else {
            s
        }
    }
}

/// Labelled (bold) and unlabelled (light) ticks for a base-10 logarithmic axis on `[lo, hi]`:
/// powers of ten (thinned out beyond 12 decades), plus 2x and 5x when the axis spans less than
/// two decades; light ticks at 2..9 x 10^k when the axis spans at most 8 decades.
pub(crate) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let pow10 = |k: i32| format!("1e{k}").parse::<f64>().unwrap_or(f64::NAN);
    let inside = |v: f64| v.is_finite() && v >= lo && v <= hi;
    let k0 = lo.log10().floor() as i32;
    let k1 = hi.log10().ceil() as i32;
    let span = hi.log10() - lo.log10();
    let stride = ((span / 12.0).ceil() as i32).max(1);
    let mut bold = Vec::new();
    let mut light = Vec::new();
    for k in k0..=k1 {
        let d = pow10(k);
        if inside(d) && k.rem_euclid(stride) == 0 {
            bold.push(d);
        }
        for j in 2..=9 {
            let v = d * j as f64;
            if !inside(v) {
                continue;
            }
            if span <= 2.01 && (j == 2 || j == 5) {
                bold.push(v);
            } else if span <= 8.01 {
                light.push(v);
            }
        }
    }
    (bold, light)
}

/// Label for a tick on a base-10 logarithmic axis.
pub(crate) fn log_tick_label(v: f64) -> String {
    // Strip round-off (ticks are 1, 2 or 5 times a power of ten).
    let v = format!("{v:.11e}").parse::<f64>().unwrap_or(v);
    if (1e-3..1e5).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colour-bar ticks are round: the issue's `0.00078, 0.00157` become multiples of 5e-4,
    /// every tick is a whole multiple of its step (1, 2 or 5 x 10^k), inside the range, at
    /// most the number asked, and at least two for any non-empty range.
    #[test]
    fn colour_bar_ticks_are_round() {
        let t = nice_ticks(0.0, 0.00195, 6).unwrap();
        assert_eq!(
            t.iter().map(|v| tick_label(*v, 0.0, 0.00195, 40.0)).collect::<Vec<_>>(),
            ["0", "0.0005", "0.001", "0.0015"]
        );
        for (lo, hi) in [(0.0, 1.19), (-3.7, 12.1), (1e-9, 3e-9), (0.5, 0.5000001), (-1e300, 1e300), (123.4, 5678.9)] {
            let t = nice_ticks(lo, hi, 6).unwrap();
            assert!((2..=6).contains(&t.len()), "{lo}..{hi}: {t:?}");
            // the step from the difference (which loses digits when the ticks are far from 0),
            // then snapped to the round value it must be
            let diff = t[1] - t[0];
            let decade = 10f64.powf(diff.log10().floor());
            let m = [1.0, 2.0, 5.0, 10.0].into_iter().find(|c| (diff / decade - c).abs() < 1e-6);
            let step = m.unwrap_or_else(|| panic!("{lo}..{hi}: step {diff} is not 1, 2 or 5 x 10^k")) * decade;
            for v in &t {
                assert!(*v >= lo - 1e-9 * step && *v <= hi + 1e-9 * step, "{v} outside {lo}..{hi}");
                assert!(((v / step).round() - v / step).abs() < 1e-6, "{v} not a multiple of {step}");
            }
        }
        assert!(nice_ticks(1.0, 1.0, 6).is_none() && nice_ticks(0.0, f64::INFINITY, 6).is_none());
    }

    #[test]
    fn tick_labels_are_sane() {
        assert_eq!(tick_label(0.25, 0.0, 1.0, 20.0), "0.25");
        assert_eq!(tick_label(-1e-17, -1.0, 1.0, 20.0), "0");
        assert_eq!(tick_label(0.30000000000000004, 0.0, 1.0, 20.0), "0.3");
        assert_eq!(tick_label(1.5e-7, 0.0, 2e-7, 20.0), "1.5e-7");
        assert_eq!(tick_label(2.5e6, 0.0, 1e7, 20.0), "2.5e6");
        assert_eq!(tick_label(1500.0, 0.0, 2000.0, 20.0), "1500");
        assert_ne!(tick_label(1.00001, 1.00001, 1.00002, 20.0), tick_label(1.000015, 1.00001, 1.00002, 20.0));
        assert_eq!(log_tick_label(0.1 * 10.0 * 10.0 * 10.0), "100");
        assert_eq!(log_tick_label(1e-7), "1e-7");
        assert_eq!(log_tick_label(0.001), "0.001");
        let (bold, light) = log_ticks(0.999e-3, 1.001);
        assert_eq!(bold, vec![1e-3, 1e-2, 1e-1, 1.0]);
        assert_eq!(light.len(), 3 * 8);
        let (bold, _) = log_ticks(0.999e-2, 0.1001);
        assert_eq!(bold, vec![1e-2, 2e-2, 5e-2, 1e-1]);
        let (bold, light) = log_ticks(1e-300, 1e300);
        assert!(bold.len() >= 2 && bold.len() <= 13 && light.is_empty());
    }
}
