//! Colour maps of a scalar on a regular 2D grid: a field over a body (a 3D body is shown on
//! one lattice plane, chosen in [`crate::solution`]) or over space and time, each cell a
//! filled rectangle in the viridis colour of its value, with the [`colorbar`] to the right.
//!
//! Cells flagged empty (a hole in a body) are left white and out of the colour range, so a
//! hole does not squash the scale. With `equal_aspect` the map keeps the body's shape by
//! padding the plotting box, which plotters cannot do by itself. Every cell is one SVG
//! rectangle, so a dense map would make a huge SVG: above [`MAX_SVG_CELLS`] only the PNG is
//! written.

mod colorbar;

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::color::viridis;
use crate::error::{invalid, PlotError};
use crate::font::FONT;
use crate::range::{fraction, is_degenerate, linear_range};
use crate::render::{check_size, render, Figure, DEFAULT_SIZE};
use crate::ticks::{tick_label, AXIS_TICKS};

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

/// Most cells of a colour map that also get an SVG (a 200 x 200 map): every cell is an SVG
/// rectangle of ~150 bytes, so the SVG of an 84k-node plate was 7.3 MB; above this only the
/// PNG (whose size does not grow with the cells) is written.
pub const MAX_SVG_CELLS: usize = 40_000;

/// Margin in pixels around the map's chart; the colour bar has the same at its top.
const MARGIN: u32 = 20;
/// Height in pixels of the x-axis labels under the map; the colour bar ends as high.
const X_LABEL_AREA: u32 = 60;
/// Width in pixels of the y-axis labels left of the map.
const Y_LABEL_AREA: u32 = 90;

/// Writes a colour map of `map` with a colour bar as `<stem>.png` (1000x700,
/// [`DEFAULT_SIZE`]) and `<stem>.svg` (only up to [`MAX_SVG_CELLS`] cells); returns the paths
/// written (PNG first). Creates the parent
/// directory if missing. A constant field is drawn in the middle colour of the map.
pub fn scalar_map(map: &ScalarMap, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    scalar_map_with_size(map, stem, DEFAULT_SIZE)
}

/// Like [`scalar_map`] with an explicit image size `(width, height)` in pixels (at least
/// [`MIN_SIZE`](crate::MIN_SIZE)); the SVG uses the same nominal size.
pub fn scalar_map_with_size(map: &ScalarMap, stem: &Path, size: (u32, u32)) -> Result<Vec<PathBuf>, PlotError> {
    check_size(size)?;
    let (lo, hi) = scalar_map_value_range(map)?;
    render(stem, size, &MapFigure { map, lo, hi }, map.nx * map.ny <= MAX_SVG_CELLS)
}

/// [`scalar_map`] as `<stem>.png` only, whatever the number of cells (a study's dense maps);
/// returns its path.
pub fn scalar_map_png(map: &ScalarMap, stem: &Path) -> Result<PathBuf, PlotError> {
    check_size(DEFAULT_SIZE)?;
    let (lo, hi) = scalar_map_value_range(map)?;
    let mut files = render(stem, DEFAULT_SIZE, &MapFigure { map, lo, hi }, false)?;
    Ok(files.remove(0))
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

/// A validated map with its colour range `lo < hi`.
struct MapFigure<'a> {
    map: &'a ScalarMap,
    lo: f64,
    hi: f64,
}

impl Figure for MapFigure<'_> {
    /// Title over both, the map left, its colour bar (at most 190 pixels, a third of the width)
    /// right.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let MapFigure { map, lo, hi } = *self;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(e)?;
        let area = root.titled(&map.title, (FONT, 28)).map_err(e)?;
        let (w, _) = area.dim_in_pixel();
        let bar_width = 190u32.min(w / 3);
        let (main, bar) = area.split_horizontally(w - bar_width);
        draw_map(&main, map, lo, hi)?;
        colorbar::draw(&bar, lo, hi, &map.value_label)
    }
}

/// Extra margins `(left = right, top = bottom)` in pixels that leave a plotting box of
/// `avail_w x avail_h` pixels with the aspect ratio `dx : dy` of the data, centred.
pub(crate) fn equal_aspect_pads(avail_w: f64, avail_h: f64, dx: f64, dy: f64) -> (u32, u32) {
    let scale = (avail_w / dx).min(avail_h / dy);
    let pad = |avail: f64, len: f64| ((avail - scale * len) / 2.0).max(0.0).floor() as u32;
    (pad(avail_w, dx), pad(avail_h, dy))
}

/// The map itself on `main`: axes, the cells coloured over `[lo, hi]`, a frame.
fn draw_map<DB: DrawingBackend>(
    main: &DrawingArea<DB, Shift>,
    map: &ScalarMap,
    lo: f64,
    hi: f64,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (x0, x1) = map.x_range;
    let (y0, y1) = map.y_range;
    // With equal aspect, the data-to-pixel scale is the smaller of the two axes' and the
    // other axis gets the rest of its pixels as extra margin on both sides.
    let (pad_x, pad_y) = if map.equal_aspect {
        let (mw, mh) = main.dim_in_pixel();
        let avail_w = mw as f64 - (2 * MARGIN + Y_LABEL_AREA) as f64;
        let avail_h = mh as f64 - (2 * MARGIN + X_LABEL_AREA) as f64;
        equal_aspect_pads(avail_w, avail_h, x1 - x0, y1 - y0)
    } else {
        (0, 0)
    };
    let mut chart = ChartBuilder::on(main)
        .margin_left(MARGIN + pad_x)
        .margin_right(MARGIN + pad_x)
        .margin_top(MARGIN + pad_y)
        .margin_bottom(MARGIN + pad_y)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
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
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::with_ext;
    use crate::testutil::{assert_invalid, check_outputs, cleanup, sample_map, temp_dir};

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
}
