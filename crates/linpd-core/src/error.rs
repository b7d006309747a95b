//! Errors raised while building grids, families and materials from user input.

use thiserror::Error;

/// A geometric or material description that cannot produce an operator.
///
/// Each variant carries the offending values so that callers (the scene parser, the CLI)
/// can point at the input that caused it.
#[non_exhaustive]
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// The spatial dimension is not 1, 2 or 3.
    #[error("dimension must be 1, 2 or 3, got {0}")]
    Dimension(usize),
    /// A vector has the wrong number of components for the dimension.
    #[error("expected {expected} components, got {got}")]
    Components {
        /// Components required (the dimension, or dimension squared for a gradient).
        expected: usize,
        /// Components given.
        got: usize,
    },
    /// A scalar parameter is out of its admissible range.
    #[error("{name}: {reason}")]
    Parameter {
        /// Parameter name, e.g. `spacing`.
        name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A node has no bond at all: it cannot carry load and makes the operator singular.
    #[error("node {node} at {position:?} has no bonds within the horizon")]
    Isolated {
        /// Node index.
        node: usize,
        /// Its position.
        position: Vec<f64>,
    },
}

impl CoreError {
    /// Shorthand for a [`CoreError::Parameter`].
    pub fn param(name: impl Into<String>, reason: impl Into<String>) -> Self {
        CoreError::Parameter { name: name.into(), reason: reason.into() }
    }
}
