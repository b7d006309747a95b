//! The colour bar beside a colour map: the viridis scale from the lowest value (bottom) to
//! the highest (top), ticks and labels at round values, and the value's description turned
//! upright along the right edge. plotters has no colour bar, so it is drawn in pixel
//! coordinates: 128 bands, aligned with the map's plotting box (the same top margin, the
//! bottom where the map's x-axis labels begin) so that both read against each other.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{MARGIN, X_LABEL_AREA};
use crate::color::viridis;
use crate::font::FONT;
use crate::range::fraction;
use crate::ticks::{nice_ticks, tick_label};

/// Draws the colour bar of the range `lo < hi` into `bar`, labelled `value_label` (no label
/// when empty).
pub(super) fn draw<DB: DrawingBackend>(
    bar: &DrawingArea<DB, Shift>,
    lo: f64,
    hi: f64,
    value_label: &str,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (bw, bh) = bar.dim_in_pixel();
    let top = MARGIN as i32;
    let bottom = (bh as i32 - (MARGIN + X_LABEL_AREA) as i32).max(top + 10);
    let left = 10i32;
    let right = (left + 28).min(bw as i32 - 1);
    let bands = 128i32;
    for k in 0..bands {
        let ya = bottom - (bottom - top) * k / bands;
        let yb = bottom - (bottom - top) * (k + 1) / bands;
        let t = (k as f64 + 0.5) / bands as f64;
        bar.draw(&Rectangle::new([(left, yb), (right, ya)], viridis(t).filled())).map_err(e)?;
    }
    bar.draw(&Rectangle::new([(left, top), (right, bottom)], BLACK.stroke_width(1))).map_err(e)?;
    let tick_style = TextStyle::from((FONT, 15).into_font()).color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center));
    // Round values (multiples of 1, 2 or 5 x 10^k) where the range allows at least two;
    // otherwise five evenly spaced values with the exact ends.
    let ticks = nice_ticks(lo, hi, 8).filter(|t| t.len() >= 2).unwrap_or_else(|| {
        // halves avoid overflow for huge ranges
        (0..5).map(|k| if k == 4 { hi } else { 2.0 * (lo / 2.0 + k as f64 / 4.0 * (hi / 2.0 - lo / 2.0)) }).collect()
    });
    for v in ticks {
        let f = fraction(v, lo, hi).clamp(0.0, 1.0);
        let y = bottom - ((bottom - top) as f64 * f).round() as i32;
        bar.draw(&PathElement::new(vec![(right, y), (right + 6, y)], BLACK)).map_err(e)?;
        bar.draw(&Text::new(tick_label(v, lo, hi, 40.0), (right + 9, y), tick_style.clone())).map_err(e)?;
    }
    if !value_label.is_empty() {
        let label_style = TextStyle::from((FONT, 18).into_font())
            .color(&BLACK)
            .transform(FontTransform::Rotate90)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let x = (bw as i32 - 22).max(right + 1);
        bar.draw(&Text::new(value_label, (x, (top + bottom) / 2), label_style)).map_err(e)?;
    }
    Ok(())
}
