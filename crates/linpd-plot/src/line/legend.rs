//! The legend of a line chart: one entry per labelled series, a short sample of its line
//! and/or marker next to the label. It goes into a corner of the plotting area that holds no
//! data ([`place`]); plotters would put it in a fixed corner, over the curves as often as not.
//! When every corner holds data the chart is narrowed and the legend drawn by hand in a column
//! of its own to the right ([`split_off_column`], [`draw`]), since plotters draws its legend
//! only inside the plotting area; its entries repeat the geometry of [`sample`], the series
//! sample plotters draws in the inside legend.

use std::ops::Range;

use plotters::coord::Shift;
use plotters::element::ComposedElement;
use plotters::prelude::*;

use super::{LinePlot, Series, SeriesStyle};
use crate::font::FONT;

/// Where a line plot's legend goes.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum LegendPlace {
    /// In this corner of the plotting area, which holds no data.
    Inside(SeriesLabelPosition),
    /// In a column right of the plotting area: every corner holds data.
    Outside,
}

/// The corner of the plotting area where the legend covers no data, or [`LegendPlace::Outside`]
/// when every corner's box (35 % of the width, 8 % of the height per labelled series plus
/// 4 %) holds points of the series (lines sampled 16 times per segment); ties go to upper
/// right, upper left, lower right, lower left, in that order.
pub(super) fn place(plot: &LinePlot, xr: &Range<f64>, yr: &Range<f64>) -> LegendPlace {
    let unit = |v: f64, r: &Range<f64>, log: bool| {
        if log {
            (v.log10() - r.start.log10()) / (r.end.log10() - r.start.log10())
        } else {
            (v - r.start) / (r.end - r.start)
        }
    };
    let labelled = plot.series.iter().filter(|s| !s.label.is_empty()).count() as f64;
    let (w, h) = (0.35, (0.04 + 0.08 * labelled).min(0.9));
    // (x in [x0, x1], y in [y0, y1]) boxes in unit coordinates
    let corners = [
        (SeriesLabelPosition::UpperRight, 1.0 - w, 1.0, 1.0 - h, 1.0),
        (SeriesLabelPosition::UpperLeft, 0.0, w, 1.0 - h, 1.0),
        (SeriesLabelPosition::LowerRight, 1.0 - w, 1.0, 0.0, h),
        (SeriesLabelPosition::LowerLeft, 0.0, w, 0.0, h),
    ];
    let mut counts = [0usize; 4];
    for s in &plot.series {
        let pts: Vec<(f64, f64)> =
            s.x.iter().zip(&s.y).map(|(x, y)| (unit(*x, xr, plot.log_x), unit(*y, yr, plot.log_y))).collect();
        let samples = if s.style == SeriesStyle::Markers { 1 } else { 16 };
        for (k, p) in pts.iter().enumerate() {
            let q = pts.get(k + 1).copied().unwrap_or(*p);
            for t in 0..samples {
                let f = t as f64 / samples as f64;
                let (x, y) = (p.0 + f * (q.0 - p.0), p.1 + f * (q.1 - p.1));
                for (c, (_, x0, x1, y0, y1)) in corners.iter().enumerate() {
                    if x >= *x0 && x <= *x1 && y >= *y0 && y <= *y1 {
                        counts[c] += 1;
                    }
                }
            }
        }
    }
    let best = (0..4).min_by_key(|&c| (counts[c], c)).unwrap_or(0);
    if counts[best] == 0 {
        LegendPlace::Inside(corners[best].0.clone())
    } else {
        LegendPlace::Outside
    }
}

/// The labelled series of `plot` with their indices (which give their colours).
fn labelled(plot: &LinePlot) -> Vec<(usize, &Series)> {
    plot.series.iter().enumerate().filter(|(_, s)| !s.label.is_empty()).collect()
}

/// `(chart area, legend column)`: the legend's column split off the right of `root`, wide
/// enough for the longest label (at most 2/5 of the width), when the legend goes
/// [`LegendPlace::Outside`] and has entries; otherwise all of `root` and no column.
pub(super) fn split_off_column<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &LinePlot,
    place: &LegendPlace,
) -> (DrawingArea<DB, Shift>, Option<DrawingArea<DB, Shift>>) {
    let labelled = labelled(plot);
    // every corner holds data: the legend gets a column of its own right of the chart
    if *place == LegendPlace::Outside && !labelled.is_empty() {
        let w = root.dim_in_pixel().0;
        let longest = labelled.iter().map(|(_, s)| s.label.chars().count()).max().unwrap_or(0) as u32;
        let lw = (longest * 9 + 60).min(2 * w / 5);
        let (a, b) = root.split_horizontally(w - lw);
        (a, Some(b))
    } else {
        (root.clone(), None)
    }
}

/// A legend entry's sample: a line and a marker, in pixels relative to the entry.
pub(super) type Sample<DB> = ComposedElement<(i32, i32), DB, PathElement<(i32, i32)>, Circle<(i32, i32), i32>>;

/// A legend entry's sample of a series drawn in `style` and `color`, its left end at `at`: a
/// 24-pixel line unless the series has markers only, a marker in the middle unless it is a
/// line only.
pub(super) fn sample<DB: DrawingBackend>(style: SeriesStyle, color: RGBColor, at: (i32, i32)) -> Sample<DB> {
    let base = EmptyElement::at(at);
    let path = PathElement::new(
        if style == SeriesStyle::Markers { vec![] } else { vec![(0, 0), (24, 0)] },
        color.stroke_width(2),
    );
    let dot = Circle::new((12, 0), if style == SeriesStyle::Line { 0 } else { 4 }, color.filled());
    base + path + dot
}

/// Draws the legend of `plot`: into `column` when there is one, else in the corner `place`
/// of the chart (the series samples were registered with the chart when it was drawn); no
/// legend when no series is labelled.
pub(super) fn draw<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    column: Option<DrawingArea<DB, Shift>>,
    place: LegendPlace,
    plot: &LinePlot,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let labelled = labelled(plot);
    if let Some(area) = column {
        draw_column(&area, &labelled)
    } else if let (LegendPlace::Inside(corner), false) = (place, labelled.is_empty()) {
        chart
            .configure_series_labels()
            .position(corner)
            .label_font((FONT, 16))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .legend_area_size(30)
            .draw()
            .map_err(e)
    } else {
        Ok(())
    }
}

/// The legend drawn by hand into `area`, one entry per labelled series, top down.
fn draw_column<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, labelled: &[(usize, &Series)]) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    // drawn by hand: plotters places its legend inside the plotting area only
    for (k, (i, s)) in labelled.iter().enumerate() {
        let y = 80 + 26 * k as i32;
        let color = s.rgb(*i);
        if s.style != SeriesStyle::Markers {
            area.draw(&PathElement::new(vec![(8, y), (32, y)], color.stroke_width(2))).map_err(e)?;
        }
        if s.style != SeriesStyle::Line {
            area.draw(&Circle::new((20, y), 4, color.filled())).map_err(e)?;
        }
        area.draw(&Text::new(s.label.as_str(), (40, y - 8), (FONT, 16))).map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line_plot;

    /// The legend goes to a corner without data: a curve rising to the upper right puts it
    /// upper left; one falling from the upper left leaves the upper right free; a line along
    /// the top sends it to the lower right; a flat line through the middle keeps the default,
    /// upper right; data in every corner (an X and a frame) send it outside the plotting
    /// area, and such a plot still draws.
    #[test]
    fn legend_avoids_the_data() {
        let plot = |y: Vec<f64>| LinePlot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series::new("a", (0..=10).map(|k| k as f64).collect(), y)],
            log_x: false,
            log_y: false,
            equal_aspect: false,
        };
        let (xr, yr) = (0.0..10.0, 0.0..10.0);
        let inside = |c| LegendPlace::Inside(c);
        let rising = plot((0..=10).map(|k| k as f64).collect());
        assert_eq!(place(&rising, &xr, &yr), inside(SeriesLabelPosition::UpperLeft));
        let falling = plot((0..=10).map(|k| 10.0 - k as f64).collect());
        assert_eq!(place(&falling, &xr, &yr), inside(SeriesLabelPosition::UpperRight));
        let high = plot(vec![9.5; 11]);
        assert_eq!(place(&high, &xr, &yr), inside(SeriesLabelPosition::LowerRight));
        let flat = plot(vec![5.0; 11]);
        assert_eq!(place(&flat, &xr, &yr), inside(SeriesLabelPosition::UpperRight));
        let mut x = rising.clone();
        x.series.push(Series::new(
            "b",
            (0..=10).map(|k| k as f64).collect(),
            (0..=10).map(|k| 10.0 - k as f64).collect(),
        ));
        assert_eq!(place(&x, &xr, &yr), LegendPlace::Outside);
        let dir = std::env::temp_dir().join(format!("linpd-legend-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files = line_plot(&x, &dir.join("x")).unwrap();
        assert!(files.iter().all(|f| std::fs::metadata(f).unwrap().len() > 1000), "{files:?}");
    }
}
