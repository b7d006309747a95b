//! Errors of the scene layer: every message names where in the scene the problem is.

use thiserror::Error;

/// What went wrong with a scene, from reading the file to solving it.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum ProblemError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A file whose content is not what its format needs (the file, the line, what is wrong).
    #[error("{0}")]
    File(linpd_io::IoError),
    /// Not JSON, or JSON of the wrong shape (unknown key, wrong type, missing key).
    #[error("{path}: {message} (line {line}, column {column})")]
    Parse {
        /// JSON path of the failing element (`.` for the document).
        path: String,
        /// The parser's message.
        message: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
    },
    /// An output directory that may not be written now (locked by another run) or replaced
    /// (not a linpd output directory); see linpd-problem's `atomic`.
    #[error("{dir}: {reason}")]
    Output {
        /// The output directory.
        dir: String,
        /// Why, and what to do.
        reason: String,
    },
    /// Well-formed JSON whose values are inconsistent.
    #[error("{path}: {reason}")]
    Invalid {
        /// JSON path, e.g. `model.horizon`.
        path: String,
        /// What is wrong and, where possible, what to change.
        reason: String,
    },
    /// The constraints leave part of the body free to move (a
    /// [`linpd_solve::StaticError::Unsupported`]).
    #[error("constraints: {0}")]
    Unsupported(linpd_solve::StaticError),
    /// The static solve failed (singular system, no convergence, ...).
    #[error("solver: {0}")]
    Static(linpd_solve::StaticError),
    /// The 1D blended / CE solve failed.
    #[error("solver: {0}")]
    Blend(linpd_blend::BlendError),
    /// The boundary-value solve on a coarsening level failed.
    #[error("solver: level {level}: {source}")]
    Level {
        /// The level (0 = the scene's model).
        level: usize,
        /// Why.
        source: linpd_coarsen::CoarsenError,
    },
    /// The explicit dynamics failed (diverged, ...).
    #[error("solver: dynamics: {0}")]
    Dynamics(linpd_dynamics::DynamicsError),
    /// The scene asks its model for what the model does not offer (a command, a solver or a
    /// section): which model, which capability and why ([`crate::capability::Capability`]).
    #[error("{path}: {capability} is not available for {model} models: {reason}")]
    Unavailable {
        /// The scene key that asks for it (`model.type` when a command does).
        path: String,
        /// The model, as [`crate::models::SceneModel::describe`] names it.
        model: String,
        /// What it lacks.
        capability: crate::capability::Capability,
        /// Why, and what to do instead.
        reason: String,
    },
}

impl ProblemError {
    /// Shorthand for [`ProblemError::Invalid`].
    pub fn invalid(path: impl Into<String>, reason: impl Into<String>) -> Self {
        ProblemError::Invalid { path: path.into(), reason: reason.into() }
    }
}

impl From<linpd_io::IoError> for ProblemError {
    /// An OS error keeps its variant ([`ProblemError::Io`]); a malformed file is
    /// [`ProblemError::File`].
    fn from(e: linpd_io::IoError) -> Self {
        match e {
            linpd_io::IoError::Io { path, source } => ProblemError::Io { path, source },
            other => ProblemError::File(other),
        }
    }
}
