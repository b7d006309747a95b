//! What every study writes: `data.json` and line plots (PNG + SVG), with errors as strings for
//! the CLI.

use linpd_plot::{line_plot, LinePlot, Series};
use serde_json::Value;
use std::path::Path;

/// An error as the message the CLI prints.
pub(crate) fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Writes `dir/data.json` (creating `dir`).
pub(crate) fn write(dir: &Path, data: &Value) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(err)?;
    // A serde_json Value always serializes (its map keys are strings).
    let text = serde_json::to_string_pretty(data).map_err(err)?;
    std::fs::write(dir.join("data.json"), text).map_err(err)
}

/// A line plot `dir/name.{png,svg}` with a linear x axis.
pub(crate) fn plot(
    dir: &Path,
    name: &str,
    title: &str,
    xl: &str,
    yl: &str,
    series: Vec<Series>,
    log_y: bool,
) -> Result<(), String> {
    let p = LinePlot { title: title.into(), x_label: xl.into(), y_label: yl.into(), series, log_x: false, log_y };
    line_plot(&p, &dir.join(name)).map(|_| ()).map_err(err)
}
