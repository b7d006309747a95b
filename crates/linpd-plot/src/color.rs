//! The colours: one per series of a line chart, and the viridis map of a colour map. Series
//! take matplotlib's "tab10" colours, familiar and distinct, then golden-angle hues, which
//! stay apart for any number of series. Viridis is perceptually uniform and readable in grey
//! and by colour-blind readers; it is interpolated from nine stops, as a table is all the
//! figures need.

use plotters::style::RGBColor;

/// Colour of series `i`: the ten "tab10" colours, then golden-angle hues.
pub(crate) fn series_color(i: usize) -> RGBColor {
    const TAB10: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    if let Some(&(r, g, b)) = TAB10.get(i) {
        return RGBColor(r, g, b);
    }
    let h = ((i - TAB10.len()) as f64 * 0.618_033_988_749_895).fract();
    hsl_to_rgb(h, 0.65, 0.45)
}

/// The colour of hue `h`, saturation `s` and lightness `l`, all in `[0, 1]`.
fn hsl_to_rgb(h: f64, s: f64, l: f64) -> RGBColor {
    let c = (1.0 - (2.0 * l - 1.0).abs()) * s;
    let hp = h * 6.0;
    let x = c * (1.0 - (hp % 2.0 - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = l - c / 2.0;
    let to = |v: f64| ((v + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    RGBColor(to(r), to(g), to(b))
}

/// Viridis colour map (matplotlib), linearly interpolated; `t` is clamped to `[0, 1]` and NaN
/// maps to the middle colour.
pub(crate) fn viridis(t: f64) -> RGBColor {
    const TABLE: [(f64, f64, f64); 9] = [
        (68.0, 1.0, 84.0),
        (71.0, 44.0, 122.0),
        (59.0, 81.0, 139.0),
        (44.0, 113.0, 142.0),
        (33.0, 144.0, 141.0),
        (39.0, 173.0, 129.0),
        (92.0, 200.0, 99.0),
        (170.0, 220.0, 50.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_nan() { 0.5 } else { t.clamp(0.0, 1.0) };
    let s = t * (TABLE.len() - 1) as f64;
    let k = (s.floor() as usize).min(TABLE.len() - 2);
    let f = s - k as f64;
    let (a, b) = (TABLE[k], TABLE[k + 1]);
    let mix = |p: f64, q: f64| (p + f * (q - p)).round().clamp(0.0, 255.0) as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_sane() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), viridis(0.5));
        assert_ne!(series_color(3), series_color(13));
    }
}
