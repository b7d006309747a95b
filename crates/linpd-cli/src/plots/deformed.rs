//! The deformed-shape plot (`deformed.png` / `.svg`): the body drawn at `x + s u` over its
//! undeformed shape (grey), with the displacement scale `s` in the legend. On a lattice the
//! shape is a grid of lattice lines (about [`LINES`] per axis, every `m`-th line), broken where
//! a body removed sites; on scattered nodes each node is a marker (at most [`MAX_MARKERS`]).
//! In 3D the plane's in-plane components `(u_a, u_b)` are drawn.

use super::{Plane, Scatter, AXES};
use linpd_core::Grid;
use linpd_plot::{line_plot_with_size, LinePlot, PlotError, Series, SeriesStyle, DEFAULT_SIZE, MIN_SIZE};
use linpd_problem::Solution;
use std::path::{Path, PathBuf};

/// About this many lattice lines per axis.
pub const LINES: usize = 20;
/// At most this many points along a lattice line (every `k`-th site).
const POINTS_PER_LINE: usize = 400;
/// At most this many markers for scattered nodes (every `k`-th node).
pub const MAX_MARKERS: usize = 20_000;
/// The palette index of the undeformed shape (grey).
const GREY: usize = 7;

/// The displacement scale that draws the largest in-plane displacement `u_max` as a tenth of
/// the body's size `extent`, rounded down to 1, 2 or 5 x 10^k; `None` for a body that does not
/// move.
pub fn auto_scale(extent: f64, u_max: f64) -> Option<f64> {
    if !(u_max > 0.0 && u_max.is_finite() && extent > 0.0) {
        return None;
    }
    let raw = 0.1 * extent / u_max;
    let decade = 10f64.powf(raw.log10().floor());
    let mantissa = [5.0, 2.0, 1.0].into_iter().find(|&m| m * decade <= raw * (1.0 + 1e-12)).unwrap_or(1.0);
    Some(mantissa * decade)
}

/// The legend label of the deformed shape at `scale`.
fn label(scale: f64) -> String {
    let decade = scale.log10().floor();
    let text = match decade {
        // one significant digit: the scales are 1, 2 or 5 x 10^k
        -3.0..=4.0 => format!("{scale:.*}", (-decade).max(0.0) as usize),
        _ => format!("{scale:.0e}"),
    };
    format!("deformed (u x {text})")
}

/// The deformed lattice lines of `plane` (`u`: `d` per lattice node).
pub(super) fn on_plane(
    grid: &Grid,
    plane: &Plane,
    s: &Solution,
    u: &[f64],
    scale: Option<f64>,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let (d, a, b, nx, ny) = (s.dim, plane.a, plane.b, plane.nx, plane.ny);
    let x0 = grid.site_position(plane.site(0, 0));
    let x1 = grid.site_position(plane.site(nx - 1, ny - 1));
    let extent = (x1[a] - x0[a]).max(x1[b] - x0[b]);
    let u_max = plane.nodes.iter().flatten().map(|&n| u[d * n + a].hypot(u[d * n + b])).fold(0.0, f64::max);
    let Some(scale) = scale.or_else(|| auto_scale(extent, u_max)) else { return Ok(Vec::new()) };
    // every m-th line and the last; every k-th site along a line and the last
    let picks = |n: usize, every: usize| (0..n).step_by(every.max(1)).chain(std::iter::once(n - 1));
    let lines: Vec<Vec<Option<usize>>> = {
        let along_a = picks(ny, ny.div_ceil(LINES))
            .map(|j| picks(nx, nx.div_ceil(POINTS_PER_LINE)).map(|i| plane.nodes[i + nx * j]).collect());
        let along_b = picks(nx, nx.div_ceil(LINES))
            .map(|i| picks(ny, ny.div_ceil(POINTS_PER_LINE)).map(|j| plane.nodes[i + nx * j]).collect());
        along_a.chain(along_b).collect()
    };
    let position = |n: usize, k: f64| {
        let x = grid.position(n);
        (x[a] + k * u[d * n + a], x[b] + k * u[d * n + b])
    };
    let mut undeformed = Vec::new();
    let mut deformed = Vec::new();
    for line in &lines {
        // runs of consecutive nodes (a removed site breaks the line)
        for run in line.split(|n| n.is_none()).filter(|r| r.len() >= 2) {
            let nodes: Vec<usize> = run.iter().flatten().copied().collect();
            for (k, out) in [(0.0, &mut undeformed), (scale, &mut deformed)] {
                let (xs, ys) = nodes.iter().map(|&n| position(n, k)).unzip();
                out.push(Series::new("", xs, ys));
            }
        }
    }
    let title = plane.title(grid, d, &s.name, "deformed shape");
    draw(title, (AXES[a], AXES[b]), undeformed, deformed, SeriesStyle::Line, scale, dir)
}

/// The deformed scattered nodes of `plane` as markers.
pub(super) fn scattered(
    s: &Solution,
    plane: &Scatter,
    scale: Option<f64>,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let (d, a, b) = (s.dim, plane.a, plane.b);
    let span = |axis: usize| {
        let (lo, hi) = plane
            .nodes
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &n| (lo.min(s.x[n][axis]), hi.max(s.x[n][axis])));
        hi - lo
    };
    let u_max = plane.nodes.iter().map(|&n| s.u[d * n + a].hypot(s.u[d * n + b])).fold(0.0, f64::max);
    let Some(scale) = scale.or_else(|| auto_scale(span(a).max(span(b)), u_max)) else { return Ok(Vec::new()) };
    let every = plane.nodes.len().div_ceil(MAX_MARKERS).max(1);
    let shown: Vec<usize> = plane.nodes.iter().step_by(every).copied().collect();
    let series = |k: f64| {
        let (xs, ys) = shown.iter().map(|&n| (s.x[n][a] + k * s.u[d * n + a], s.x[n][b] + k * s.u[d * n + b])).unzip();
        vec![Series::new("", xs, ys)]
    };
    let title = plane.title(s, "deformed shape");
    draw(title, (AXES[a], AXES[b]), series(0.0), series(scale), SeriesStyle::Markers, scale, dir)
}

/// A 1000-pixel wide figure about as high as the data's shape needs beside the legend's
/// column (a 1 x 0.5 plate gets 460 pixels, not 700 of white bands): the plotting area is
/// about 500 pixels wide, 140 pixels go to the title and the axes.
fn figure_size(plot: &LinePlot) -> (u32, u32) {
    let span = |f: &dyn Fn(&Series) -> &Vec<f64>| {
        let (lo, hi) = plot
            .series
            .iter()
            .flat_map(|s| f(s).iter())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        (hi - lo).max(f64::MIN_POSITIVE)
    };
    let aspect = span(&|s| &s.y) / span(&|s| &s.x);
    let height = (500.0 * aspect + 140.0).clamp(MIN_SIZE.1 as f64, DEFAULT_SIZE.1 as f64);
    (DEFAULT_SIZE.0, height as u32)
}

/// Draws the undeformed series in grey and the deformed ones in the first colour, each family
/// labelled once.
fn draw(
    title: String,
    (x_label, y_label): (&str, &str),
    mut undeformed: Vec<Series>,
    mut deformed: Vec<Series>,
    style: SeriesStyle,
    scale: f64,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    if deformed.is_empty() {
        return Ok(Vec::new());
    }
    undeformed[0].label = "undeformed".into();
    deformed[0].label = label(scale);
    let series = undeformed
        .into_iter()
        .map(|s| s.with_color(GREY).with_style(style))
        .chain(deformed.into_iter().map(|s| s.with_color(0).with_style(style)))
        .collect();
    let plot = LinePlot { series, equal_aspect: true, ..LinePlot::new(title, x_label, y_label) };
    line_plot_with_size(&plot, &dir.join("deformed"), figure_size(&plot))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest displacement is drawn as at most a tenth of the body, and at least a
    /// twentieth (the rounding down to 1, 2, 5 loses at most a factor 2.5 between 2 and 5).
    #[test]
    fn auto_scale_rounds_down_to_one_two_five() {
        assert_eq!(auto_scale(1.0, 1e-3), Some(100.0));
        assert_eq!(auto_scale(1.0, 4e-4), Some(200.0));
        assert_eq!(auto_scale(2.0, 3e-5), Some(5000.0));
        assert_eq!(auto_scale(1.0, 0.0), None);
        assert_eq!(label(200.0), "deformed (u x 200)");
        assert_eq!(label(0.05), "deformed (u x 0.05)");
        assert_eq!(label(2e6), "deformed (u x 2e6)");
        for u in [1.3e-7, 2.9e-4, 7.7e-2, 0.5] {
            let k = auto_scale(1.0, u).unwrap();
            assert!(k * u <= 0.1 * (1.0 + 1e-12) && k * u >= 0.04, "u {u}: scale {k}");
        }
    }
}
