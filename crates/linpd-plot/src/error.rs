//! The one error type of the crate. Bad input is found while validating, before any file or
//! directory is created, and reported as [`PlotError::InvalidData`] with a message naming the
//! offending series, value or field; plotters' own errors are flattened to their message with
//! the file being drawn, so that the error type does not carry the backends' generic types.

use std::path::PathBuf;

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

/// [`PlotError::InvalidData`] with the message `msg`.
pub(crate) fn invalid(msg: impl Into<String>) -> PlotError {
    PlotError::InvalidData(msg.into())
}
