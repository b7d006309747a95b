//! What every study writes: `data.json`, tables and line plots (PNG + SVG), with file errors
//! that name the file.

use crate::StudyError;
use linpd_core::progress::{Progress, Task};
use linpd_plot::{line_plot, LinePlot, Series};
use serde_json::Value;
use std::path::Path;

/// Creates `dir` and its parents.
pub(crate) fn create_dir(dir: &Path) -> Result<(), StudyError> {
    std::fs::create_dir_all(dir).map_err(|source| StudyError::File { path: dir.to_path_buf(), source })
}

/// Writes `text` to `path`.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), StudyError> {
    std::fs::write(path, text).map_err(|source| StudyError::File { path: path.to_path_buf(), source })
}

/// Writes `dir/data.json` (creating `dir`).
pub(crate) fn write(dir: &Path, data: &Value) -> Result<(), StudyError> {
    create_dir(dir)?;
    // A serde_json Value always serializes (its map keys are strings): `Value`'s Display is
    // infallible, unlike `to_string_pretty`'s signature suggests.
    write_text(&dir.join("data.json"), &format!("{data:#}"))
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
) -> Result<(), StudyError> {
    let p = LinePlot {
        title: title.into(),
        x_label: xl.into(),
        y_label: yl.into(),
        series,
        log_x: false,
        log_y,
        equal_aspect: false,
    };
    line_plot(&p, &dir.join(name))?;
    Ok(())
}

/// The cases of a study as a task `"<study>: cases"` of `n` steps: [`Cases::next`] at the start
/// of each case reports "case i of n: <label>"; the task finishes when dropped.
pub(crate) struct Cases<'a> {
    task: Task<'a>,
    n: usize,
    done: std::cell::Cell<usize>,
}

impl<'a> Cases<'a> {
    pub(crate) fn new(progress: &'a dyn Progress, study: &str, n: usize) -> Self {
        Cases { task: Task::start(progress, &format!("{study}: cases"), Some(n as u64)), n, done: 0.into() }
    }

    /// Case `i + 1` (of `n`) begins; `i` cases are done.
    pub(crate) fn next(&self, label: impl std::fmt::Display) {
        let i = self.done.get();
        if self.task.is_on() {
            self.task.set(i as u64, &format!("case {} of {}: {label}", i + 1, self.n));
        }
        self.done.set(i + 1);
    }
}

impl Drop for Cases<'_> {
    fn drop(&mut self) {
        self.task.set(self.done.get() as u64, "");
    }
}
