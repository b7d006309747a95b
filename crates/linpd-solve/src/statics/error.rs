//! A failed static solve of a model ([`StaticError`]).

use crate::SolveError;
use linpd_core::Unsupported;

/// A failed static solve of a model.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum StaticError {
    /// No free DOF.
    #[error("every DOF is constrained: nothing to solve")]
    NothingFree,
    /// A connected piece can move rigidly.
    #[error("{source} (first positions {positions:?})")]
    Unsupported {
        /// Which piece and how many motions.
        source: Unsupported,
        /// Positions of its first nodes (at most 3).
        positions: Vec<Vec<f64>>,
    },
    /// The model cannot be applied matrix-free.
    #[error("matrix_free is not available for {kind} models: {why}")]
    MatrixFreeUnavailable {
        /// The model kind.
        kind: &'static str,
        /// Why.
        why: &'static str,
    },
    /// CG was asked for an unsymmetric operator.
    #[error("the {kind} operator is unsymmetric (relative asymmetry {asymmetry:.2e}): matrix-free CG needs a symmetric one; use lu")]
    UnsymmetricForCg {
        /// The model kind.
        kind: &'static str,
        /// `max |A - A^T| / max |A|`.
        asymmetry: f64,
    },
    /// The solver failed at a DOF.
    #[error("{source}: {at}; the body is not held there (add constraints) or its couplings are cut around it")]
    AtDof {
        /// The solver's error.
        source: SolveError,
        /// The node and component (from the model's [`linpd_core::Model::describe_node`]).
        at: String,
    },
    /// The solver failed.
    #[error(transparent)]
    Solve(SolveError),
}

impl From<SolveError> for StaticError {
    fn from(e: SolveError) -> Self {
        StaticError::Solve(e)
    }
}
