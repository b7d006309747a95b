//! Errors of the blended model's set-up and solve.

/// What is wrong with a blended-model description or solve.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum BlendError {
    /// A parameter of the 1D model ([`crate::BlendParams`], [`crate::Blending`],
    /// [`crate::one_d::material`], [`crate::one_d::solve`]) is invalid; `name` is its field (`dx`, `horizon`,
    /// `kernel`, `blending.s`, ...), which a caller maps to its own keys.
    #[error("{name}: {reason}")]
    Parameter {
        /// The parameter, e.g. `dx`.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A 2D/3D blend on a lattice of another dimension.
    #[error("2D and 3D only, got dimension {0} (1D blends are the 1D model, crate::BlendOperator)")]
    Dimension(usize),
    /// The caller's per-node inputs do not match the lattice (`beta`, the mirrored, kept or
    /// regular flags: their lengths, `beta` outside `[0, 1]`) or the lattice box is invalid.
    #[error("{0}")]
    Inputs(String),
    /// A node whose row has a local share cannot take it: a defect or a material interface is
    /// within its family or its cells, or it is the corner of no complete cell. The region of
    /// the nonlocal model must cover it.
    #[error("{node}: {reason}")]
    NotLocal {
        /// The node, described (`node 17 at (0.5, 0.25)`).
        node: String,
        /// Why, and what to do.
        reason: String,
    },
    /// `FreeFaces::Bulk` with phases: a coarse cell over several phases averages its lattice
    /// cells' moduli, the faces' softened ones too.
    #[error("\"bulk\" free faces need a material without phases (a coarse cell over several phases averages its lattice cells' moduli, the faces' softened ones too)")]
    BulkFacesWithPhases,
    /// The graded blend would not fit in the available memory.
    #[error(transparent)]
    Memory(#[from] linpd_core::memory::OutOfMemory),
    /// A lattice, operator or material could not be built.
    #[error(transparent)]
    Core(#[from] linpd_core::CoreError),
    /// An internal invariant does not hold (a bug, reported instead of a panic).
    #[error("{0}")]
    Invalid(String),
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
