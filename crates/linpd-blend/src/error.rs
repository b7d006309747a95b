//! Errors of the blended model's set-up and solve.

/// What is wrong with a blended-model description or solve.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum BlendError {
    /// A parameter is invalid; `name` is the scene key it comes from.
    #[error("{name}: {reason}")]
    Parameter {
        /// Key, e.g. `regions`.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// The linear solve failed.
    #[error("solver: {0}")]
    Solve(#[from] linpd_solve::StaticError),
}

impl BlendError {
    /// Shorthand for [`BlendError::Parameter`].
    pub fn param(name: impl Into<String>, reason: impl Into<String>) -> Self {
        BlendError::Parameter { name: name.into(), reason: reason.into() }
    }
}
