//! Line and scatter charts: curves `y(x)` (displacement profiles, energies over time,
//! convergence on log-log axes), each series as a line, markers or both, in its own colour,
//! with a legend of the labelled series (placed by [`legend`]).
//!
//! The data are validated and the axis ranges fixed before anything is drawn, so that bad
//! input leaves no file behind. plotters gives a linear and a logarithmic axis different
//! coordinate types: the four combinations of `log_x`, `log_y` are dispatched once, in
//! [`LineFigure::draw`], to one generic [`draw_line_plot`]. Tick labels come from
//! [`crate::ticks`] on both kinds of axis (plotters' own labels print every digit of an f64).

mod legend;

use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::color::series_color;
use crate::error::{invalid, PlotError};
use crate::font::FONT;
use crate::range::{linear_range, log_range};
use crate::render::{check_size, render, Figure, DEFAULT_SIZE};
use crate::ticks::{log_tick_label, log_ticks, tick_label, AXIS_TICKS};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeriesStyle {
    /// A polyline through the points, in the given order.
    #[default]
    Line,
    /// A filled circle at each point, no connecting line.
    Markers,
    /// A polyline with a filled circle at each point.
    LineMarkers,
}

/// One curve.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend label; an empty label leaves the series out of the legend.
    pub label: String,
    /// Abscissae; same length as `y`.
    pub x: Vec<f64>,
    /// Ordinates; same length as `x`.
    pub y: Vec<f64>,
    /// How the series is drawn.
    pub style: SeriesStyle,
    /// The colour's index in the palette (`7`: grey); `None`: the series' own index, so
    /// that every series gets its own colour. Series sharing a colour draw one family of
    /// curves (a deformed grid), labelled once.
    pub color: Option<usize>,
}

impl Series {
    /// A series drawn as a line ([`SeriesStyle::Line`]).
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self { label: label.into(), x, y, style: SeriesStyle::Line, color: None }
    }

    /// The same series in the colour of palette index `color` (`7`: grey).
    pub fn with_color(mut self, color: usize) -> Self {
        self.color = Some(color);
        self
    }

    /// The colour of this series drawn as series `i` of its chart.
    pub(crate) fn rgb(&self, i: usize) -> RGBColor {
        series_color(self.color.unwrap_or(i))
    }

    /// The same series with another drawing style.
    pub fn with_style(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }
}

/// A 2D line/scatter chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinePlot {
    /// Chart title (caption).
    pub title: String,
    /// Description of the horizontal axis.
    pub x_label: String,
    /// Description of the vertical axis.
    pub y_label: String,
    /// The curves, drawn in order with distinct colours.
    pub series: Vec<Series>,
    /// Logarithmic (base 10) horizontal axis; all x values must then be positive.
    pub log_x: bool,
    /// Logarithmic (base 10) vertical axis; all y values must then be positive.
    pub log_y: bool,
    /// Draw one unit of x as long as one unit of y (a deformed body keeps its shape), padding
    /// the plotting box as a [`crate::ScalarMap`] does; linear axes only (ignored with a
    /// logarithmic one).
    pub equal_aspect: bool,
}

impl LinePlot {
    /// An empty linear-axes chart with the given title and axis labels.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), ..Self::default() }
    }

    /// The same chart with one more series.
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }
}

/// Writes `<stem>.png` (1000x700, [`DEFAULT_SIZE`]) and `<stem>.svg`; returns both paths
/// (PNG first). Creates the parent directory if missing.
///
/// The extensions are appended to `stem` (so `out/fig.v2` gives `out/fig.v2.png`).
pub fn line_plot(plot: &LinePlot, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    line_plot_with_size(plot, stem, DEFAULT_SIZE)
}

/// Like [`line_plot`] with an explicit image size `(width, height)` in pixels (at least
/// [`MIN_SIZE`](crate::MIN_SIZE)); the SVG uses the same nominal size.
pub fn line_plot_with_size(plot: &LinePlot, stem: &Path, size: (u32, u32)) -> Result<Vec<PathBuf>, PlotError> {
    check_size(size)?;
    let (xr, yr) = line_plot_ranges(plot)?;
    render(stem, size, &LineFigure { plot, xr, yr }, true)
}

/// Validates the series and returns the padded axis ranges.
fn line_plot_ranges(plot: &LinePlot) -> Result<(Range<f64>, Range<f64>), PlotError> {
    if plot.series.is_empty() {
        return Err(invalid("line plot has no series"));
    }
    let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, s) in plot.series.iter().enumerate() {
        let name = format!("series {i} ({:?})", s.label);
        if s.x.is_empty() {
            return Err(invalid(format!("{name} is empty")));
        }
        if s.x.len() != s.y.len() {
            return Err(invalid(format!("{name}: x has {} values but y has {}", s.x.len(), s.y.len())));
        }
        for (axis, data, log) in [("x", &s.x, plot.log_x), ("y", &s.y, plot.log_y)] {
            if let Some(k) = data.iter().position(|v| !v.is_finite()) {
                return Err(invalid(format!("{name}: {axis}[{k}] = {:e} is not finite", data[k])));
            }
            if log {
                if let Some(k) = data.iter().position(|&v| v <= 0.0) {
                    return Err(invalid(format!(
                        "{name}: {axis}[{k}] = {} is not positive, but the {axis} axis is logarithmic",
                        data[k]
                    )));
                }
            }
        }
        for (&x, &y) in s.x.iter().zip(&s.y) {
            xmin = xmin.min(x);
            xmax = xmax.max(x);
            ymin = ymin.min(y);
            ymax = ymax.max(y);
        }
    }
    let xr = if plot.log_x { log_range(xmin, xmax) } else { linear_range(xmin, xmax) };
    let yr = if plot.log_y { log_range(ymin, ymax) } else { linear_range(ymin, ymax) };
    Ok((xr, yr))
}

/// A validated line chart with its axis ranges.
struct LineFigure<'a> {
    plot: &'a LinePlot,
    xr: Range<f64>,
    yr: Range<f64>,
}

impl Figure for LineFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let LineFigure { plot, xr, yr } = self;
        let r = (xr, yr);
        let log = |range: &Range<f64>| {
            let (bold, light) = log_ticks(range.start, range.end);
            range.clone().log_scale().with_key_points(bold).with_light_points(light)
        };
        let (lx, ly) = (xr.clone(), yr.clone());
        match (plot.log_x, plot.log_y) {
            (false, false) => draw_line_plot(root, plot, lx, ly, r),
            (true, false) => draw_line_plot(root, plot, log(xr), ly, r),
            (false, true) => draw_line_plot(root, plot, lx, log(yr), r),
            (true, true) => draw_line_plot(root, plot, log(xr), log(yr), r),
        }
    }
}

/// Draws `plot` on `root` with the axes `xs`, `ys` (linear or logarithmic) spanning
/// `xs_range`, `ys_range`: background, axes, curves, legend.
fn draw_line_plot<DB, XS, YS>(
    root: &DrawingArea<DB, Shift>,
    plot: &LinePlot,
    xs: XS,
    ys: YS,
    (xs_range, ys_range): (&Range<f64>, &Range<f64>),
) -> Result<(), String>
where
    DB: DrawingBackend,
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let place = legend::place(plot, xs_range, ys_range);
    let (chart_area, column) = legend::split_off_column(root, plot, &place);
    let mut chart = axes(&chart_area, plot, xs, ys, (xs_range, ys_range))?;
    draw_curves(&mut chart, plot)?;
    legend::draw(&mut chart, column, place, plot)
}

/// Margin in pixels around the chart.
const MARGIN: u32 = 20;
/// Height in pixels of the x-axis labels.
const X_LABEL_AREA: u32 = 60;
/// Width in pixels of the y-axis labels.
const Y_LABEL_AREA: u32 = 90;
/// Height in pixels of the caption (28-pixel text and its spacing).
const CAPTION: u32 = 40;

/// A chart with the axes `X`, `Y` (linear or logarithmic).
type Chart<'a, DB, X, Y> = ChartContext<'a, DB, Cartesian2d<X, Y>>;

/// The chart on `area` with its title, axes, grid and tick labels drawn.
fn axes<'a, DB, XS, YS>(
    area: &DrawingArea<DB, Shift>,
    plot: &LinePlot,
    xs: XS,
    ys: YS,
    (xs_range, ys_range): (&Range<f64>, &Range<f64>),
) -> Result<Chart<'a, DB, XS::CoordDescType, YS::CoordDescType>, String>
where
    DB: DrawingBackend,
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (xr, yr) = (xs_range.clone(), ys_range.clone());
    let (log_x, log_y) = (plot.log_x, plot.log_y);
    let x_fmt = move |v: &f64| {
        if log_x {
            log_tick_label(*v)
        } else {
            tick_label(*v, xr.start, xr.end, AXIS_TICKS)
        }
    };
    let y_fmt = move |v: &f64| {
        if log_y {
            log_tick_label(*v)
        } else {
            tick_label(*v, yr.start, yr.end, AXIS_TICKS)
        }
    };
    let (pad_x, pad_y) = if plot.equal_aspect && !log_x && !log_y {
        let (w, h) = area.dim_in_pixel();
        let avail_w = w as f64 - (2 * MARGIN + Y_LABEL_AREA) as f64;
        let avail_h = h as f64 - (2 * MARGIN + X_LABEL_AREA + CAPTION) as f64;
        crate::map::equal_aspect_pads(avail_w, avail_h, xs_range.end - xs_range.start, ys_range.end - ys_range.start)
    } else {
        (0, 0)
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&plot.title, (FONT, 28))
        .margin_left(MARGIN + pad_x)
        .margin_right(MARGIN + pad_x)
        .margin_top(MARGIN + pad_y)
        .margin_bottom(MARGIN + pad_y)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(xs, ys)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    Ok(chart)
}

/// Draws every series of `plot` in its style and colour, registering the labelled ones for
/// the legend.
fn draw_curves<'a, DB, X, Y>(chart: &mut Chart<'a, DB, X, Y>, plot: &LinePlot) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    for (i, s) in plot.series.iter().enumerate() {
        let color = s.rgb(i);
        let line = color.stroke_width(2);
        let fill = color.filled();
        let pts = s.x.iter().copied().zip(s.y.iter().copied());
        let anno = match s.style {
            SeriesStyle::Line => chart.draw_series(LineSeries::new(pts, line)).map_err(e)?,
            SeriesStyle::Markers => chart.draw_series(pts.map(|p| Circle::new(p, 4, fill))).map_err(e)?,
            SeriesStyle::LineMarkers => {
                chart.draw_series(LineSeries::new(pts.clone(), line)).map_err(e)?;
                chart.draw_series(pts.map(|p| Circle::new(p, 4, fill))).map_err(e)?
            }
        };
        if !s.label.is_empty() {
            let style = s.style;
            anno.label(s.label.as_str()).legend(move |at| legend::sample(style, color, at));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{assert_invalid, check_outputs, cleanup, sample_plot, temp_dir};

    #[test]
    fn line_plot_writes_png_and_svg() {
        let dir = temp_dir("line");
        // Nested, non-existing parent directory must be created.
        let stem = dir.join("nested").join("fig.v1");
        let files = line_plot(&sample_plot(), &stem).unwrap();
        check_outputs(
            &files,
            &stem,
            DEFAULT_SIZE,
            &["Test title alpha", "position x", "displacement u", "sine", "cubic"],
        );
        assert!(files[0].ends_with("fig.v1.png"));
        cleanup(&dir);
    }

    #[test]
    fn line_plot_custom_size_log_axes_and_constant_series() {
        let dir = temp_dir("log");
        let stem = dir.join("loglog");
        let h: Vec<f64> = [0.1, 0.05, 0.025, 0.0125].to_vec();
        let plot = LinePlot { log_x: true, log_y: true, ..LinePlot::new("Convergence", "h", "error") }
            .with_series(Series::new("err", h.clone(), h.iter().map(|v| 3.0 * v * v).collect()))
            // Constant series at an exact power of ten on a log axis.
            .with_series(Series::new("flat", h.clone(), vec![1e-2; 4]));
        let files = line_plot_with_size(&plot, &stem, (640, 480)).unwrap();
        check_outputs(&files, &stem, (640, 480), &["Convergence"]);

        // Linear axes, a single point and a constant series, some unlabelled.
        let stem2 = dir.join("const");
        let plot = LinePlot::new("Constant", "", "")
            .with_series(Series::new("", vec![1.0, 2.0, 3.0], vec![5.0; 3]))
            .with_series(Series::new("", vec![2.0], vec![0.0]).with_style(SeriesStyle::Markers));
        let files = line_plot(&plot, &stem2).unwrap();
        check_outputs(&files, &stem2, DEFAULT_SIZE, &["Constant"]);

        // Only log_x, with one x and zero range in x.
        let stem3 = dir.join("semilog");
        let plot = LinePlot { log_x: true, ..LinePlot::new("Semilog", "n", "t") }.with_series(Series::new(
            "pt",
            vec![7.0, 7.0],
            vec![-1.0, 1.0],
        ));
        let files = line_plot(&plot, &stem3).unwrap();
        check_outputs(&files, &stem3, DEFAULT_SIZE, &["Semilog"]);

        // Tiny magnitudes get scientific tick labels instead of rows of "0.0".
        let stem4 = dir.join("tiny");
        let plot =
            LinePlot::new("Tiny", "x", "u").with_series(Series::new("u", vec![0.0, 1.0, 2.0], vec![0.0, 1e-7, 3e-7]));
        let files = line_plot(&plot, &stem4).unwrap();
        check_outputs(&files, &stem4, DEFAULT_SIZE, &["Tiny", "1.5e-7", "2.5e-7"]);
        cleanup(&dir);
    }

    /// With `equal_aspect` a unit square is drawn square (its pixel spans within 3 %, the
    /// caption's estimated height), and a series `with_color(7)` takes the grey of palette
    /// index 7 whatever its position.
    #[test]
    fn equal_aspect_keeps_a_square_square_and_colors_are_shared() {
        let dir = temp_dir("aspect");
        let stem = dir.join("square");
        let square = Series::new("", vec![0.0, 1.0, 1.0, 0.0, 0.0], vec![0.0, 0.0, 1.0, 1.0, 0.0]).with_color(7);
        let plot = LinePlot { equal_aspect: true, ..LinePlot::new("Square", "x", "y") }
            .with_series(Series::new("first", vec![0.5], vec![0.5]).with_style(SeriesStyle::Markers))
            .with_series(square);
        let files = line_plot(&plot, &stem).unwrap();
        let svg = std::fs::read_to_string(&files[1]).unwrap();
        let grey = svg.find("stroke=\"#7F7F7F\"").expect("a grey polyline");
        let start = svg[..grey].rfind("<polyline").unwrap();
        let points = &svg[start..][svg[start..].find("points=\"").unwrap() + 8..];
        let points = &points[..points.find('"').unwrap()];
        let xy: Vec<(f64, f64)> = points
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect();
        let span = |f: &dyn Fn(&(f64, f64)) -> f64| {
            xy.iter().map(f).fold(f64::NEG_INFINITY, f64::max) - xy.iter().map(f).fold(f64::INFINITY, f64::min)
        };
        let (w, h) = (span(&|p| p.0), span(&|p| p.1));
        assert!((w / h - 1.0).abs() <= 0.03, "square drawn {w} x {h} pixels");
        cleanup(&dir);
    }

    #[test]
    fn invalid_line_data_is_rejected() {
        let dir = temp_dir("bad-line");
        let stem = dir.join("bad");

        let mut p = sample_plot();
        p.series[1].y.pop();
        assert_invalid(line_plot(&p, &stem), "\"square\"");

        let mut p = sample_plot();
        p.series[2].y[3] = f64::NAN;
        assert_invalid(line_plot(&p, &stem), "\"cubic\"");

        let mut p = sample_plot();
        p.series[0].x[0] = f64::INFINITY;
        assert_invalid(line_plot(&p, &stem), "not finite");

        let mut p = sample_plot();
        p.log_y = true; // sine and x^2 include y <= 0
        assert_invalid(line_plot(&p, &stem), "logarithmic");

        let mut p = sample_plot();
        p.log_x = true; // x starts at 0
        assert_invalid(line_plot(&p, &stem), "logarithmic");

        let mut p = sample_plot();
        p.series[1].x.clear();
        p.series[1].y.clear();
        assert_invalid(line_plot(&p, &stem), "empty");

        assert_invalid(line_plot(&LinePlot::default(), &stem), "no series");
        assert_invalid(line_plot_with_size(&sample_plot(), &stem, (10, 10)), "size");

        // Nothing was written for invalid input.
        assert!(!dir.exists());
    }
}
