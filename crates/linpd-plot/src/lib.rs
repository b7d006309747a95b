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
//!         color: None,
//!     }],
//!     log_x: false,
//!     log_y: false,
//!     equal_aspect: false,
//! };
//! let files = line_plot(&plot, Path::new("out/displacement")).unwrap();
//! assert_eq!(files.len(), 2);
//! ```
//!
//! The crate is laid out by what each part draws; the modules are private and everything
//! public is re-exported here:
//!
//! * `line` — line/scatter charts ([`LinePlot`], [`line_plot`]), with `line::legend`, the
//!   legend that avoids the data;
//! * `map` — colour maps of a scalar on a regular grid ([`ScalarMap`], [`scalar_map`]), with
//!   `map::colorbar`, the colour bar beside them;
//! * `ticks` — axis tick positions and their labels; `range` — axis ranges from data;
//!   `color` — series colours and the viridis map;
//! * `render` — the output files (PNG through the png crate, SVG) and image sizes; `font` —
//!   the embedded font; `error` — [`PlotError`];
#![deny(missing_docs)]

mod color;
mod error;
mod font;
mod line;
mod map;
mod range;
mod render;
#[cfg(test)]
mod testutil;
mod ticks;

pub use error::PlotError;
pub use line::{line_plot, line_plot_with_size, LinePlot, Series, SeriesStyle};
pub use map::{scalar_map, scalar_map_png, scalar_map_with_size, ScalarMap, MAX_SVG_CELLS};
pub use render::{DEFAULT_SIZE, MIN_SIZE};
