//! What a command may do with a model ([`Capability`]); a model says which it lacks
//! ([`crate::SceneModel::lacks`]) and a command refuses by name
//! ([`crate::ProblemError::Unavailable`]).

/// What a command may do with a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Capability {
    /// `linpd solve` ([`crate::Problem::solve`]).
    StaticSolve,
    /// `"solver": {"type": "cg", "matrix_free": true}`: CG without an assembled matrix.
    MatrixFree,
    /// Rows of `A_ff` on demand (`linpd_problem::Commands::row_system`): the Python package's rows and the
    /// distributed PETSc solve.
    BlockRows,
    /// `linpd export` (`linpd_problem::Commands::reduced_system`).
    Export,
    /// The level 0 of `linpd coarsen` (`linpd_problem::level0_model`).
    Coarsen,
    /// `linpd run` (the `dynamics` section).
    Dynamics,
}

impl Capability {
    /// Every capability, in the order of the docs.
    pub const ALL: [Capability; 6] = [
        Capability::StaticSolve,
        Capability::MatrixFree,
        Capability::BlockRows,
        Capability::Export,
        Capability::Coarsen,
        Capability::Dynamics,
    ];

    /// Its name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Capability::StaticSolve => "the static solve",
            Capability::MatrixFree => "the matrix-free solve",
            Capability::BlockRows => "row-block assembly (the distributed path)",
            Capability::Export => "export",
            Capability::Coarsen => "coarsening",
            Capability::Dynamics => "explicit dynamics",
        }
    }

    /// The scene key a refusal points at when the scene asks for it (`None`: a command asks).
    pub fn key(self) -> Option<&'static str> {
        match self {
            Capability::MatrixFree => Some("solver.matrix_free"),
            Capability::Dynamics => Some("dynamics"),
            _ => None,
        }
    }
}

impl std::fmt::Display for Capability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
