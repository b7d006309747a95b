//! Plotting helpers for linpd: line/scatter charts and scalar colour maps.
//!
//! Every plot is written twice, as `<stem>.png` (bitmap) and `<stem>.svg` (vector), using
//! [`plotters`] without any system font dependency: the DejaVu Sans font embedded by the
//! [`dejavu`] crate is registered with plotters' `ab_glyph` text renderer on first use, so no
//! fontconfig or freetype is needed.
//!
//! All input problems (empty or mismatched data, non-finite values, nonpositive values on a
//! logarithmic axis, a wrong number of grid values) are reported as
//! [`PlotError::InvalidData`] before any file is created; the functions do not panic on user
//! data.
//!
//! ```no_run
//! use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
//! use std::path::Path;
//!
//! let plot = LinePlot {
//!     title: "Displacement".into(),
//!     x_label: "x [m]".into(),
//!     y_label: "u [m]".into(),
//!     series: vec![Series {
//!         label: "PD".into(),
//!         x: vec![0.0, 0.5, 1.0],
//!         y: vec![0.0, 0.25, 1.0],
//!         style: SeriesStyle::LineMarkers,
//!     }],
//!     log_x: false,
//!     log_y: false,
//! };
//! let files = line_plot(&plot, Path::new("out/displacement")).unwrap();
//! assert_eq!(files.len(), 2);
//! ```
#![deny(missing_docs)]
pub mod solution;

use std::ffi::OsString;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontTransform;

/// Default image size in pixels (width, height) used by [`line_plot`] and [`scalar_map`].
pub const DEFAULT_SIZE: (u32, u32) = (1000, 700);

/// Smallest accepted image size in pixels (width, height).
pub const MIN_SIZE: (u32, u32) = (320, 240);

/// Approximate number of ticks plotters puts on an axis (used to choose label precision).
const AXIS_TICKS: f64 = 20.0;

/// Font family name under which the embedded DejaVu Sans font is registered.
const FONT: &str = "sans-serif";

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
}

impl Series {
    /// A series drawn as a line ([`SeriesStyle::Line`]).
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self { label: label.into(), x, y, style: SeriesStyle::Line }
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

/// A scalar field on a regular grid, drawn as a colour map with a colour bar.
///
/// Cell `(ix, iy)` covers `[x0 + ix*dx, x0 + (ix+1)*dx] x [y0 + iy*dy, y0 + (iy+1)*dy]` with
/// `dx = (x1 - x0)/nx`, `dy = (y1 - y0)/ny`, where `x_range = (x0, x1)`, `y_range = (y0, y1)`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScalarMap {
    /// Chart title.
    pub title: String,
    /// Description of the horizontal axis.
    pub x_label: String,
    /// Description of the vertical axis.
    pub y_label: String,
    /// Number of cells along x (> 0).
    pub nx: usize,
    /// Number of cells along y (> 0).
    pub ny: usize,
    /// Extent along x, `(min, max)` with `min < max`, both finite.
    pub x_range: (f64, f64),
    /// Extent along y, `(min, max)` with `min < max`, both finite.
    pub y_range: (f64, f64),
    /// values[ix + nx*iy]; length `nx*ny`, all finite.
    pub values: Vec<f64>,
    /// Description of the value, shown next to the colour bar.
    pub value_label: String,
    /// Cells without data (a hole in a body), drawn white and left out of the colour range:
    /// empty, or one flag per cell (`nx*ny`). Their `values` are ignored.
    pub empty: Vec<bool>,
    /// Draw one unit of x as long as one unit of y (a body's map keeps its shape: a 1 x 0.1
    /// beam is drawn 10 times wider than tall), centring the map in the space left; `false`
    /// (default) stretches the map over the plotting area, for axes in different units.
    pub equal_aspect: bool,
}

/// Errors from the plotting functions.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The input cannot be plotted: e.g. empty series, x/y length mismatch, non-finite data,
    /// nonpositive data on a log axis, `values.len() != nx*ny`.
    #[error("invalid plot data: {0}")]
    InvalidData(String),
    /// Drawing backend failure (font, rendering or encoding); `path` is the file being written.
    #[error("drawing {} failed: {message}", path.display())]
    Backend {
        /// The output file being drawn.
        path: PathBuf,
        /// The backend's error message.
        message: String,
    },
    /// File-system failure (e.g. creating the output directory).
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

/// Writes `<stem>.png` (1000x700, [`DEFAULT_SIZE`]) and `<stem>.svg`; returns both paths
/// (PNG first). Creates the parent directory if missing.
///
/// The extensions are appended to `stem` (so `out/fig.v2` gives `out/fig.v2.png`).
pub fn line_plot(plot: &LinePlot, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    line_plot_with_size(plot, stem, DEFAULT_SIZE)
}

/// Like [`line_plot`] with an explicit image size `(width, height)` in pixels (at least
/// [`MIN_SIZE`]); the SVG uses the same nominal size.
pub fn line_plot_with_size(plot: &LinePlot, stem: &Path, size: (u32, u32)) -> Result<Vec<PathBuf>, PlotError> {
    check_size(size)?;
    let (xr, yr) = line_plot_ranges(plot)?;
    render(stem, size, &Job::Line { plot, xr, yr }, true)
}

/// Writes a colour map of `map` with a colour bar as `<stem>.png` (1000x700,
/// [`DEFAULT_SIZE`]) and `<stem>.svg` (only up to [`MAX_SVG_CELLS`] cells); returns the paths
/// written (PNG first). Creates the parent
/// directory if missing. A constant field is drawn in the middle colour of the map.
pub fn scalar_map(map: &ScalarMap, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    scalar_map_with_size(map, stem, DEFAULT_SIZE)
}

/// Like [`scalar_map`] with an explicit image size `(width, height)` in pixels (at least
/// [`MIN_SIZE`]); the SVG uses the same nominal size.
pub fn scalar_map_with_size(map: &ScalarMap, stem: &Path, size: (u32, u32)) -> Result<Vec<PathBuf>, PlotError> {
    check_size(size)?;
    let (lo, hi) = scalar_map_value_range(map)?;
    render(stem, size, &Job::Map { map, lo, hi }, map.nx * map.ny <= MAX_SVG_CELLS)
}

/// [`scalar_map`] as `<stem>.png` only, whatever the number of cells (a study's dense maps);
/// returns its path.
pub fn scalar_map_png(map: &ScalarMap, stem: &Path) -> Result<PathBuf, PlotError> {
    check_size(DEFAULT_SIZE)?;
    let (lo, hi) = scalar_map_value_range(map)?;
    let mut files = render(stem, DEFAULT_SIZE, &Job::Map { map, lo, hi }, false)?;
    Ok(files.remove(0))
}

// ---------------------------------------------------------------------------------------------
// Validation and ranges
// ---------------------------------------------------------------------------------------------

fn invalid(msg: impl Into<String>) -> PlotError {
    PlotError::InvalidData(msg.into())
}

fn check_size((w, h): (u32, u32)) -> Result<(), PlotError> {
    if w < MIN_SIZE.0 || h < MIN_SIZE.1 {
        return Err(invalid(format!("image size {w}x{h} is below the minimum {}x{}", MIN_SIZE.0, MIN_SIZE.1)));
    }
    Ok(())
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

/// True when `[lo, hi]` is empty or too narrow to be resolved in f64 ticks.
fn is_degenerate(lo: f64, hi: f64) -> bool {
    let half_span = hi / 2.0 - lo / 2.0;
    half_span <= 1e-12 * lo.abs().max(hi.abs()) || half_span <= f64::MIN_POSITIVE
}

/// Range of finite `[lo, hi]` (lo <= hi) with a 5% margin; a (nearly) constant range is
/// widened around its centre. Never overflows to infinity.
fn linear_range(lo: f64, hi: f64) -> Range<f64> {
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
fn log_range(lo: f64, hi: f64) -> Range<f64> {
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

/// Validates the grid and returns the colour-scale range `(lo, hi)`, `lo < hi`.
fn scalar_map_value_range(map: &ScalarMap) -> Result<(f64, f64), PlotError> {
    if map.nx == 0 || map.ny == 0 {
        return Err(invalid(format!("grid must have at least one cell, got nx = {}, ny = {}", map.nx, map.ny)));
    }
    let n = map.nx.checked_mul(map.ny).ok_or_else(|| invalid(format!("nx*ny overflows ({} x {})", map.nx, map.ny)))?;
    if map.values.len() != n {
        return Err(invalid(format!(
            "values has {} entries, expected nx*ny = {}*{} = {n}",
            map.values.len(),
            map.nx,
            map.ny
        )));
    }
    for (axis, (a, b)) in [("x_range", map.x_range), ("y_range", map.y_range)] {
        if !(a.is_finite() && b.is_finite() && a < b) || is_degenerate(a, b) {
            return Err(invalid(format!("{axis} = ({a}, {b}) must be finite with min < max")));
        }
    }
    if !map.empty.is_empty() && map.empty.len() != n {
        return Err(invalid(format!("empty has {} flags, expected none or nx*ny = {n}", map.empty.len())));
    }
    let has_data = |k: usize| map.empty.get(k).is_none_or(|e| !e);
    if let Some(k) = (0..n).find(|&k| has_data(k) && !map.values[k].is_finite()) {
        let (ix, iy) = (k % map.nx, k / map.nx);
        return Err(invalid(format!("values[{k}] (ix = {ix}, iy = {iy}) = {:e} is not finite", map.values[k])));
    }
    if !(0..n).any(has_data) {
        return Err(invalid("every cell is empty"));
    }
    let lo = (0..n).filter(|&k| has_data(k)).map(|k| map.values[k]).fold(f64::INFINITY, f64::min);
    let hi = (0..n).filter(|&k| has_data(k)).map(|k| map.values[k]).fold(f64::NEG_INFINITY, f64::max);
    if is_degenerate(lo, hi) {
        let r = linear_range(lo, hi);
        Ok((r.start, r.end))
    } else {
        Ok((lo, hi))
    }
}

// ---------------------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------------------

/// Registers the embedded DejaVu Sans font once; returns the registration error, if any.
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_string())
        })
        .clone()
}

/// `stem` with `ext` appended as an extension.
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A validated drawing job, drawable on any backend.
enum Job<'a> {
    Line { plot: &'a LinePlot, xr: Range<f64>, yr: Range<f64> },
    Map { map: &'a ScalarMap, lo: f64, hi: f64 },
}

impl Job<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        match self {
            Job::Line { plot, xr, yr } => {
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
            Job::Map { map, lo, hi } => draw_scalar_map(root, map, *lo, *hi),
        }
    }
}

/// Draws `job` onto a PNG and an SVG backend and writes both files.
/// Most cells of a colour map that also get an SVG (a 200 x 200 map): every cell is an SVG
/// rectangle of ~150 bytes, so the SVG of an 84k-node plate was 7.3 MB; above this only the
/// PNG (whose size does not grow with the cells) is written.
pub const MAX_SVG_CELLS: usize = 40_000;

/// Draws `job` into `<stem>.png` and, when `svg`, `<stem>.svg`; returns the paths written.
fn render(stem: &Path, size: (u32, u32), job: &Job<'_>, svg_too: bool) -> Result<Vec<PathBuf>, PlotError> {
    if stem.file_name().is_none() {
        return Err(invalid(format!("output stem {} has no file name", stem.display())));
    }
    let png = with_ext(stem, "png");
    let svg = with_ext(stem, "svg");
    ensure_font().map_err(|message| PlotError::Backend { path: png.clone(), message })?;
    if let Some(parent) = stem.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent)?;
        }
    }
    let backend_err = |path: &Path| {
        let path = path.to_path_buf();
        move |message: String| PlotError::Backend { path, message }
    };

    {
        // Drawn into an RGB buffer and encoded here (see `write_png`), so plotters does not
        // need its image-crate encoder.
        let mut rgb = vec![0u8; 3 * size.0 as usize * size.1 as usize];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
            job.draw(&root).map_err(backend_err(&png))?;
            root.present().map_err(|e| e.to_string()).map_err(backend_err(&png))?;
        }
        write_png(&png, size, &rgb).map_err(backend_err(&png))?;
    }
    if !svg_too {
        return Ok(vec![png]);
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        job.draw(&root).map_err(backend_err(&svg))?;
        root.present().map_err(|e| e.to_string()).map_err(backend_err(&svg))?;
    }
    Ok(vec![png, svg])
}

/// Encodes an 8-bit RGB buffer as a PNG file.
fn write_png(path: &Path, size: (u32, u32), rgb: &[u8]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Adaptive per-row filtering, as the image crate did: plots are mostly flat colour, where
    // it shrinks the files ~3x against no filtering.
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    encoder.set_compression(png::Compression::Best);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())
}

/// Colour of series `i`: the ten "tab10" colours, then golden-angle hues.
fn series_color(i: usize) -> RGBColor {
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
fn viridis(t: f64) -> RGBColor {
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

/// Position of `v` in `[lo, hi]` as a fraction, without overflow for huge ranges.
fn fraction(v: f64, lo: f64, hi: f64) -> f64 {
    (v / 2.0 - lo / 2.0) / (hi / 2.0 - lo / 2.0)
}

/// Label for a tick value `v` on a linear scale spanning `[lo, hi]` with about `n` ticks:
/// enough digits to tell neighbouring ticks apart, scientific notation for very large or
/// small magnitudes, no "-0".
/// At most `max` round tick values in `[lo, hi]`: the multiples of the smallest step
/// `s = m 10^k` (`m` in 1, 2, 5) with at most `max` multiples in the range. `None` for a
/// non-finite or empty range.
fn nice_ticks(lo: f64, hi: f64, max: usize) -> Option<Vec<f64>> {
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

fn tick_label(v: f64, lo: f64, hi: f64, n: f64) -> String {
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
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
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
fn log_tick_label(v: f64) -> String {
    // Strip round-off (ticks are 1, 2 or 5 times a power of ten).
    let v = format!("{v:.11e}").parse::<f64>().unwrap_or(v);
    if (1e-3..1e5).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Where a line plot's legend goes.
#[derive(Debug, Clone, PartialEq)]
enum LegendPlace {
    /// In this corner of the plotting area, which holds no data.
    Inside(SeriesLabelPosition),
    /// In a column right of the plotting area: every corner holds data.
    Outside,
}

/// The corner of the plotting area where the legend covers no data, or [`LegendPlace::Outside`]
/// when every corner's box (35 % of the width, 8 % of the height per labelled series plus
/// 4 %) holds points of the series (lines sampled 16 times per segment); ties go to upper
/// right, upper left, lower right, lower left, in that order.
fn legend_place(plot: &LinePlot, xr: &Range<f64>, yr: &Range<f64>) -> LegendPlace {
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
    let labelled: Vec<(usize, &Series)> = plot.series.iter().enumerate().filter(|(_, s)| !s.label.is_empty()).collect();
    let place = legend_place(plot, xs_range, ys_range);
    // every corner holds data: the legend gets a column of its own right of the chart
    let (chart_area, legend_area) = if place == LegendPlace::Outside && !labelled.is_empty() {
        let w = root.dim_in_pixel().0;
        let longest = labelled.iter().map(|(_, s)| s.label.chars().count()).max().unwrap_or(0) as u32;
        let lw = (longest * 9 + 60).min(2 * w / 5);
        let (a, b) = root.split_horizontally(w - lw);
        (a, Some(b))
    } else {
        (root.clone(), None)
    };
    let root = &chart_area;
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
    let mut chart = ChartBuilder::on(root)
        .caption(&plot.title, (FONT, 28))
        .margin(20)
        .x_label_area_size(60)
        .y_label_area_size(90)
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

    for (i, s) in plot.series.iter().enumerate() {
        let color = series_color(i);
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
            anno.label(s.label.as_str()).legend(move |(x, y)| {
                let base = EmptyElement::at((x, y));
                let path =
                    PathElement::new(if style == SeriesStyle::Markers { vec![] } else { vec![(0, 0), (24, 0)] }, line);
                let dot = Circle::new((12, 0), if style == SeriesStyle::Line { 0 } else { 4 }, fill);
                base + path + dot
            });
        }
    }
    if let Some(area) = legend_area {
        // drawn by hand: plotters places its legend inside the plotting area only
        for (k, (i, s)) in labelled.iter().enumerate() {
            let y = 80 + 26 * k as i32;
            let color = series_color(*i);
            if s.style != SeriesStyle::Markers {
                area.draw(&PathElement::new(vec![(8, y), (32, y)], color.stroke_width(2))).map_err(e)?;
            }
            if s.style != SeriesStyle::Line {
                area.draw(&Circle::new((20, y), 4, color.filled())).map_err(e)?;
            }
            area.draw(&Text::new(s.label.as_str(), (40, y - 8), (FONT, 16))).map_err(e)?;
        }
    } else if let (LegendPlace::Inside(corner), false) = (place, labelled.is_empty()) {
        chart
            .configure_series_labels()
            .position(corner)
            .label_font((FONT, 16))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .legend_area_size(30)
            .draw()
            .map_err(e)?;
    }
    Ok(())
}

/// Extra margins `(left = right, top = bottom)` in pixels that leave a plotting box of
/// `avail_w x avail_h` pixels with the aspect ratio `dx : dy` of the data, centred.
fn equal_aspect_pads(avail_w: f64, avail_h: f64, dx: f64, dy: f64) -> (u32, u32) {
    let scale = (avail_w / dx).min(avail_h / dy);
    let pad = |avail: f64, len: f64| ((avail - scale * len) / 2.0).max(0.0).floor() as u32;
    (pad(avail_w, dx), pad(avail_h, dy))
}

fn draw_scalar_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &ScalarMap,
    lo: f64,
    hi: f64,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let area = root.titled(&map.title, (FONT, 28)).map_err(e)?;
    let (w, _) = area.dim_in_pixel();
    let bar_width = 190u32.min(w / 3);
    let (main, bar) = area.split_horizontally(w - bar_width);

    // Geometry shared by the map and the colour bar so that they line up.
    let (margin, x_label_area, y_label_area) = (20u32, 60u32, 90u32);

    let (x0, x1) = map.x_range;
    let (y0, y1) = map.y_range;
    // With equal aspect, the data-to-pixel scale is the smaller of the two axes' and the
    // other axis gets the rest of its pixels as extra margin on both sides.
    let (pad_x, pad_y) = if map.equal_aspect {
        let (mw, mh) = main.dim_in_pixel();
        let avail_w = mw as f64 - (2 * margin + y_label_area) as f64;
        let avail_h = mh as f64 - (2 * margin + x_label_area) as f64;
        equal_aspect_pads(avail_w, avail_h, x1 - x0, y1 - y0)
    } else {
        (0, 0)
    };
    let mut chart = ChartBuilder::on(&main)
        .margin_left(margin + pad_x)
        .margin_right(margin + pad_x)
        .margin_top(margin + pad_y)
        .margin_bottom(margin + pad_y)
        .x_label_area_size(x_label_area)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(map.x_label.as_str())
        .y_desc(map.y_label.as_str())
        .x_label_formatter(&|v: &f64| tick_label(*v, x0, x1, AXIS_TICKS))
        .y_label_formatter(&|v: &f64| tick_label(*v, y0, y1, AXIS_TICKS))
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(e)?;

    let (nx, ny) = (map.nx, map.ny);
    let cx = |ix: usize| x0 + (x1 - x0) * (ix as f64 / nx as f64);
    let cy = |iy: usize| y0 + (y1 - y0) * (iy as f64 / ny as f64);
    chart
        .draw_series((0..ny).flat_map(|iy| {
            (0..nx).filter(move |ix| !map.empty.get(ix + nx * iy).is_some_and(|e| *e)).map(move |ix| {
                let v = map.values[ix + nx * iy];
                Rectangle::new([(cx(ix), cy(iy)), (cx(ix + 1), cy(iy + 1))], viridis(fraction(v, lo, hi)).filled())
            })
        }))
        .map_err(e)?;
    // Frame the plotting area.
    chart.draw_series(std::iter::once(Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))).map_err(e)?;

    // Colour bar, drawn in pixel coordinates of `bar`.
    let (bw, bh) = bar.dim_in_pixel();
    let top = margin as i32;
    let bottom = (bh as i32 - (margin + x_label_area) as i32).max(top + 10);
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
        let f = ((v / 2.0 - lo / 2.0) / (hi / 2.0 - lo / 2.0)).clamp(0.0, 1.0);
        let y = bottom - ((bottom - top) as f64 * f).round() as i32;
        bar.draw(&PathElement::new(vec![(right, y), (right + 6, y)], BLACK)).map_err(e)?;
        bar.draw(&Text::new(tick_label(v, lo, hi, 40.0), (right + 9, y), tick_style.clone())).map_err(e)?;
    }
    if !map.value_label.is_empty() {
        let label_style = TextStyle::from((FONT, 18).into_font())
            .color(&BLACK)
            .transform(FontTransform::Rotate90)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let x = (bw as i32 - 22).max(right + 1);
        bar.draw(&Text::new(map.value_label.as_str(), (x, (top + bottom) / 2), label_style)).map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A fresh, unique temporary directory for one test.
    fn temp_dir(name: &str) -> PathBuf {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let nanos =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
        let dir = std::env::temp_dir().join(format!(
            "linpd-plot-test-{}-{}-{}-{}",
            std::process::id(),
            name,
            COUNTER.fetch_add(1, Ordering::Relaxed),
            nanos
        ));
        assert!(!dir.exists());
        dir
    }

    /// Removes a test directory unless `LINPD_PLOT_KEEP_TEST_OUTPUT` is set (for inspection).
    fn cleanup(dir: &Path) {
        if std::env::var_os("LINPD_PLOT_KEEP_TEST_OUTPUT").is_some() {
            eprintln!("kept {}", dir.display());
        } else {
            std::fs::remove_dir_all(dir).unwrap();
        }
    }

    /// Width and height from a PNG's IHDR chunk, after checking the signature.
    fn png_size(path: &Path) -> (u32, u32) {
        let bytes = std::fs::read(path).unwrap();
        assert!(bytes.len() > 24, "PNG too short");
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG signature");
        assert_eq!(&bytes[12..16], b"IHDR");
        let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        (w, h)
    }

    fn check_outputs(files: &[PathBuf], stem: &Path, size: (u32, u32), texts: &[&str]) {
        assert_eq!(files, &[with_ext(stem, "png"), with_ext(stem, "svg")]);
        for f in files {
            assert!(f.is_file(), "{} missing", f.display());
        }
        assert_eq!(png_size(&files[0]), size);
        let svg = std::fs::read_to_string(&files[1]).unwrap();
        assert!(svg.contains("<svg"), "no <svg element");
        for t in texts {
            assert!(svg.contains(t), "SVG lacks text {t:?}");
        }
    }

    fn sample_plot() -> LinePlot {
        let x: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
        LinePlot::new("Test title alpha", "position x", "displacement u")
            .with_series(Series::new("sine", x.clone(), x.iter().map(|v| (6.0 * v).sin()).collect()))
            .with_series(
                Series::new("square", x.clone(), x.iter().map(|v| v * v).collect()).with_style(SeriesStyle::Markers),
            )
            .with_series(
                Series::new("cubic", x.clone(), x.iter().map(|v| v * v * v).collect())
                    .with_style(SeriesStyle::LineMarkers),
            )
    }

    fn sample_map(nx: usize, ny: usize) -> ScalarMap {
        let values = (0..nx * ny)
            .map(|k| {
                let (ix, iy) = (k % nx, k / nx);
                (ix as f64 * 0.3).sin() + iy as f64 * 0.1
            })
            .collect();
        ScalarMap {
            title: "Map title beta".into(),
            x_label: "x coord".into(),
            y_label: "y coord".into(),
            nx,
            ny,
            x_range: (0.0, 2.0),
            y_range: (-1.0, 1.0),
            values,
            value_label: "strain energy".into(),
            empty: Vec::new(),
            equal_aspect: false,
        }
    }

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

    #[test]
    fn scalar_map_writes_png_and_svg() {
        let dir = temp_dir("map");
        let stem = dir.join("field");
        let files = scalar_map(&sample_map(40, 20), &stem).unwrap();
        check_outputs(&files, &stem, DEFAULT_SIZE, &["Map title beta", "x coord", "y coord", "strain energy"]);
        // A constant field must not panic and still draws.
        let mut map = sample_map(3, 2);
        map.values = vec![0.0; 6];
        let stem2 = dir.join("constant");
        let files = scalar_map_with_size(&map, &stem2, (800, 600)).unwrap();
        check_outputs(&files, &stem2, (800, 600), &["Map title beta"]);
        cleanup(&dir);
    }

    fn assert_invalid(r: Result<Vec<PathBuf>, PlotError>, needle: &str) {
        match r {
            Err(PlotError::InvalidData(msg)) => {
                assert!(msg.contains(needle), "message {msg:?} lacks {needle:?}")
            }
            other => panic!("expected InvalidData, got {other:?}"),
        }
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
        };
        let (xr, yr) = (0.0..10.0, 0.0..10.0);
        let inside = |c| LegendPlace::Inside(c);
        let rising = plot((0..=10).map(|k| k as f64).collect());
        assert_eq!(legend_place(&rising, &xr, &yr), inside(SeriesLabelPosition::UpperLeft));
        let falling = plot((0..=10).map(|k| 10.0 - k as f64).collect());
        assert_eq!(legend_place(&falling, &xr, &yr), inside(SeriesLabelPosition::UpperRight));
        let high = plot(vec![9.5; 11]);
        assert_eq!(legend_place(&high, &xr, &yr), inside(SeriesLabelPosition::LowerRight));
        let flat = plot(vec![5.0; 11]);
        assert_eq!(legend_place(&flat, &xr, &yr), inside(SeriesLabelPosition::UpperRight));
        let mut x = rising.clone();
        x.series.push(Series::new(
            "b",
            (0..=10).map(|k| k as f64).collect(),
            (0..=10).map(|k| 10.0 - k as f64).collect(),
        ));
        assert_eq!(legend_place(&x, &xr, &yr), LegendPlace::Outside);
        let dir = std::env::temp_dir().join(format!("linpd-legend-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files = line_plot(&x, &dir.join("x")).unwrap();
        assert!(files.iter().all(|f| std::fs::metadata(f).unwrap().len() > 1000), "{files:?}");
    }

    /// A map above [`MAX_SVG_CELLS`] cells writes the PNG only; one at the limit both.
    #[test]
    fn dense_maps_skip_the_svg() {
        let dir = temp_dir("dense-map");
        for (n, files) in [(200, 2), (201, 1)] {
            let m = sample_map(n, 200);
            let stem = dir.join(format!("m{n}"));
            let written = scalar_map(&m, &stem).unwrap();
            assert_eq!(written.len(), files, "{n} x 200 cells: {written:?}");
            assert!(written[0].extension().is_some_and(|e| e == "png") && written[0].is_file());
            assert_eq!(with_ext(&stem, "svg").exists(), files == 2);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

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

    /// The plotting box left by the pads has the data's aspect ratio to within the 2 pixels
    /// that flooring the pads can cost, and one axis keeps all its pixels.
    #[test]
    fn equal_aspect_pads_keep_the_data_shape() {
        for (w, h, dx, dy) in
            [(700.0, 600.0, 1.0, 0.1), (700.0, 600.0, 1.0, 0.5), (700.0, 600.0, 0.2, 1.0), (500.0, 500.0, 1.0, 1.0)]
        {
            let (px, py) = equal_aspect_pads(w, h, dx, dy);
            let (bw, bh) = (w - 2.0 * px as f64, h - 2.0 * py as f64);
            assert!(px == 0 || py == 0, "one axis keeps its pixels: {px}, {py}");
            assert!((bw - bh * dx / dy).abs() <= 2.0 * (1.0 + dx / dy), "{w}x{h}, {dx}:{dy}: box {bw}x{bh}");
        }
    }

    #[test]
    fn invalid_map_data_is_rejected() {
        let dir = temp_dir("bad-map");
        let stem = dir.join("bad");

        let mut m = sample_map(4, 3);
        m.values.pop();
        assert_invalid(scalar_map(&m, &stem), "nx*ny");

        let mut m = sample_map(4, 3);
        m.values[5] = f64::NAN;
        assert_invalid(scalar_map(&m, &stem), "values[5]");

        let mut m = sample_map(4, 3);
        m.nx = 0;
        m.values.clear();
        assert_invalid(scalar_map(&m, &stem), "at least one cell");

        let mut m = sample_map(4, 3);
        m.x_range = (1.0, 1.0);
        assert_invalid(scalar_map(&m, &stem), "x_range");

        let mut m = sample_map(4, 3);
        m.y_range = (0.0, f64::INFINITY);
        assert_invalid(scalar_map(&m, &stem), "y_range");

        let mut m = sample_map(4, 3);
        m.nx = usize::MAX;
        m.ny = 2;
        assert_invalid(scalar_map(&m, &stem), "overflows");

        assert!(!dir.exists());
    }

    #[test]
    fn unwritable_output_is_an_error_not_a_panic() {
        let dir = temp_dir("unwritable");
        std::fs::create_dir_all(&dir).unwrap();
        let blocker = dir.join("file");
        std::fs::write(&blocker, b"x").unwrap();
        // The "parent directory" is a regular file: creating it must fail cleanly.
        let r = line_plot(&sample_plot(), &blocker.join("sub").join("fig"));
        assert!(matches!(r, Err(PlotError::Io(_))), "{r:?}");
        let r = scalar_map(&sample_map(2, 2), &blocker.join("map"));
        assert!(matches!(r, Err(PlotError::Io(_) | PlotError::Backend { .. })), "{r:?}");
        cleanup(&dir);
    }

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

        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), viridis(0.5));
        assert_ne!(series_color(3), series_color(13));
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
