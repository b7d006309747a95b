//! The preconditioners a solve may name, as a registry ([`PRECONDITIONERS`]): each is a
//! [`PreconditionerType`] that builds itself from what the reduced operator offers, estimates
//! its cost for `auto` and its memory for the guard. A solver spec holds a [`PreconditionerKind`],
//! a handle to one.
//!
//! A new preconditioner is its module (a [`Preconditioner`] and its [`PreconditionerType`]) and
//! one line in [`PRECONDITIONERS`]: the scene's `solver.preconditioner` takes its name, `auto`
//! weighs its estimate against the others ([`crate::statics::auto::plan_symmetric`]) and the
//! memory guard counts its bytes ([`PreconditionerType::hierarchy_bytes`]); all three are
//! required methods or have a stated default. A preconditioner defined outside linpd is a
//! `static` of a type implementing the trait, passed as `PreconditionerKind::new(&MINE)`.

use super::DofGeometry;
use super::{Amg, AmgError, AmgParams, Jacobi, Preconditioner};
use crate::cost::{self, Estimate};
use crate::krylov::cg::CgParams;
use crate::SolveError;
use linpd_core::sparse::Csc;
use linpd_core::{DofMap, Model};
use std::fmt;

/// What a preconditioner may be built from: the reduced operator `A_ff`'s diagonal, its
/// assembled matrix when the solve assembled it, and where its unknowns sit.
#[derive(Debug, Clone, Copy)]
pub struct PreconditionerInput<'a> {
    /// `diag(A_ff)`.
    pub diagonal: &'a [f64],
    /// `A_ff` (both triangles), `None` when the solve runs matrix-free.
    pub matrix: Option<&'a Csc>,
    /// Node and component of every unknown and the node positions (`None`: a bare matrix).
    pub geometry: Option<&'a DofGeometry>,
    /// The model itself, for a preconditioner that reads it on demand instead of the
    /// assembled matrix (matrix-free multigrid).
    pub model: Option<ModelInput<'a>>,
}

/// A model's `A_ff` without assembling it: the model, its free DOFs and its apply over all DOFs
/// (e.g. the fast stencil).
#[derive(Clone, Copy)]
pub struct ModelInput<'a> {
    /// The model.
    pub model: &'a dyn Model,
    /// Its free DOFs.
    pub dofs: &'a DofMap,
    /// `y = A x` over all DOFs.
    pub full: &'a dyn linpd_core::LinearOperator,
}

impl fmt::Debug for ModelInput<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ModelInput({} model, {} free DOFs)", self.model.kind(), self.dofs.n_free())
    }
}

/// What `auto` knows of an assembled `A_ff` when it weighs the preconditioners of PCG.
#[derive(Debug, Clone, Copy)]
pub struct AutoInput<'a> {
    /// Spatial dimension.
    pub dim: usize,
    /// Stored entries of `A_ff`.
    pub nnz: usize,
    /// Nodes along the body's longest side.
    pub n_side: f64,
    /// The CG tolerance and iteration limit.
    pub params: &'a CgParams,
    /// Whether the DOF geometry (node and component of every unknown, the positions) is known.
    pub geometry: bool,
}

/// The operator a preconditioner's setup works on, for its memory estimate: the sizes and
/// how the operator is held (a multigrid's hierarchy costs differ: its finest level is not
/// stored when the operator is matrix-free, a lattice stencil aggregates on its bond graph, the
/// geometric level coarsens the lattice itself).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetupOn {
    /// Spatial dimension.
    pub dim: usize,
    /// Nodes (of the operator's lattice or cloud).
    pub nodes: usize,
    /// Unknowns.
    pub dofs: usize,
    /// How the operator is held.
    pub operator: Operator,
}

/// How the operator a preconditioner is set up on is held ([`SetupOn`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Operator {
    /// An assembled `A_ff`.
    Assembled,
    /// Applied matrix-free with per-bond data; block rows on demand.
    MatrixFree,
    /// A lattice stencil with `bonds` bonds a node and no per-bond data: the multigrid
    /// aggregates on the bond graph.
    Stencil {
        /// Bonds a node.
        bonds: f64,
    },
    /// A 3D lattice stencil whose coarse lattice the geometric level takes
    /// ([`crate::LatticeMultigrid`]), `ratio = delta / h`.
    GeometricStencil {
        /// `delta / h`.
        ratio: f64,
    },
    /// An SPD companion's block rows (the LPS tangent's pair part) with `bonds` bonds a node.
    Companion {
        /// Bonds a node.
        bonds: f64,
    },
}

/// One preconditioner of the registry (see the module docs).
pub trait PreconditionerType: Sync + Send {
    /// Its name: the scene's `solver.preconditioner`, the reports' `cg-<name>`.
    fn name(&self) -> &'static str;
    /// Builds it from what the reduced operator offers.
    fn build<'a>(&self, input: &PreconditionerInput<'a>) -> Result<Box<dyn Preconditioner + 'a>, SolveError>;
    /// A multigrid hierarchy: it reads the DOF geometry (rigid-body modes), a model's block
    /// rows or its companion, and the solvers build those for it.
    fn multilevel(&self) -> bool {
        false
    }
    /// `auto`'s estimate of PCG with it on an assembled `A_ff`; `None`: not a candidate there.
    fn auto_estimate(&self, input: &AutoInput) -> Option<Estimate>;
    /// The bytes its setup adds to the solve's vectors on `on` (the memory guard).
    fn hierarchy_bytes(&self, on: &SetupOn) -> f64;
}

/// A handle to a registered preconditioner: what a solver spec holds. Two handles are the same
/// preconditioner when their names are ([`PartialEq`]): a name is unique among the
/// preconditioners a solve may see, and the solvers' multigrid-specific paths (the lattice's
/// geometric level, a companion's hierarchy) key on [`PreconditionerKind::MULTIGRID`].
#[derive(Clone, Copy)]
pub struct PreconditionerKind(&'static dyn PreconditionerType);

impl PreconditionerKind {
    /// `M = diag(A)` ([`Jacobi`]).
    pub const JACOBI: PreconditionerKind = PreconditionerKind(&JacobiType);
    /// One V-cycle of smoothed-aggregation AMG with the rigid-body modes as near-null space
    /// ([`Amg`]), or of the lattice hierarchy / a companion's on the matrix-free paths.
    pub const MULTIGRID: PreconditionerKind = PreconditionerKind(&MultigridType);

    /// The handle of `t` (a preconditioner defined outside linpd; its name must not be one of
    /// [`PRECONDITIONERS`]'s, which would make it that one).
    pub const fn new(t: &'static dyn PreconditionerType) -> Self {
        PreconditionerKind(t)
    }

    /// The registered preconditioner named `name` ([`PRECONDITIONERS`]).
    pub fn named(name: &str) -> Option<Self> {
        PRECONDITIONERS.iter().copied().find(|k| k.name() == name)
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        self.0.name()
    }

    /// Builds the preconditioner from what the reduced operator offers.
    pub fn build<'a>(self, input: &PreconditionerInput<'a>) -> Result<Box<dyn Preconditioner + 'a>, SolveError> {
        self.0.build(input)
    }

    /// See [`PreconditionerType::multilevel`].
    pub fn multilevel(self) -> bool {
        self.0.multilevel()
    }

    /// See [`PreconditionerType::auto_estimate`].
    pub fn auto_estimate(self, input: &AutoInput) -> Option<Estimate> {
        self.0.auto_estimate(input)
    }

    /// See [`PreconditionerType::hierarchy_bytes`].
    pub fn hierarchy_bytes(self, on: &SetupOn) -> f64 {
        self.0.hierarchy_bytes(on)
    }
}

impl Default for PreconditionerKind {
    fn default() -> Self {
        PreconditionerKind::JACOBI
    }
}

impl PartialEq for PreconditionerKind {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

impl Eq for PreconditionerKind {}

impl fmt::Debug for PreconditionerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The largest setup of the preconditioners `kinds` on `on` (bytes, and whose); `None` for none.
pub fn largest_setup(kinds: &[PreconditionerKind], on: &SetupOn) -> Option<(f64, PreconditionerKind)> {
    kinds.iter().map(|k| (k.hierarchy_bytes(on), *k)).max_by(|x, y| x.0.total_cmp(&y.0))
}

/// linpd's preconditioners, in the order `auto` lists their estimates.
pub static PRECONDITIONERS: &[PreconditionerKind] = &[PreconditionerKind::JACOBI, PreconditionerKind::MULTIGRID];

/// [`PreconditionerKind::JACOBI`].
struct JacobiType;

impl PreconditionerType for JacobiType {
    fn name(&self) -> &'static str {
        "jacobi"
    }
    fn build<'a>(&self, input: &PreconditionerInput<'a>) -> Result<Box<dyn Preconditioner + 'a>, SolveError> {
        Ok(Box::new(Jacobi::new(input.diagonal)?))
    }
    fn auto_estimate(&self, input: &AutoInput) -> Option<Estimate> {
        Some(cost::jacobi_cg(input.dim, input.nnz, input.n_side, input.params))
    }
    /// Its diagonal is among the solve's vectors.
    fn hierarchy_bytes(&self, _: &SetupOn) -> f64 {
        0.0
    }
}

/// [`PreconditionerKind::MULTIGRID`].
struct MultigridType;

impl PreconditionerType for MultigridType {
    fn name(&self) -> &'static str {
        "multigrid"
    }
    fn build<'a>(&self, input: &PreconditionerInput<'a>) -> Result<Box<dyn Preconditioner + 'a>, SolveError> {
        let Some(a) = input.matrix else {
            let m = input
                .model
                .ok_or_else(|| AmgError::Input("multigrid needs the assembled matrix or the model's blocks".into()))?;
            let known = input.geometry.map(|g| (g, input.diagonal));
            return Ok(Box::new(Amg::matrix_free_with(m.model, m.dofs, m.full, known, &AmgParams::default())?));
        };
        let amg = match input.geometry {
            Some(g) => Amg::from_geometry(a, g, &AmgParams::default())?,
            // A bare matrix: one unknown per node, constants as near-null space.
            None => {
                let rows: Vec<usize> = (0..a.nrows()).collect();
                Amg::with_near_null_space(a, &rows, &[vec![1.0; a.nrows()]], &AmgParams::default())?
            }
        };
        Ok(Box::new(amg))
    }
    fn multilevel(&self) -> bool {
        true
    }
    /// Offered with the DOF geometry only: its near-null space is the rigid-body modes.
    fn auto_estimate(&self, input: &AutoInput) -> Option<Estimate> {
        input.geometry.then(|| cost::multigrid_cg(input.nnz, input.params))
    }
    fn hierarchy_bytes(&self, on: &SetupOn) -> f64 {
        use crate::memory::{
            companion_multigrid_dof_bytes, geometric_multigrid_bytes, multigrid_dof_bytes, stencil_multigrid_dof_bytes,
            GRAPH_BOND_BYTES,
        };
        let (dofs, nodes) = (on.dofs as f64, on.nodes as f64);
        match on.operator {
            Operator::Assembled => dofs * multigrid_dof_bytes(on.dim, false),
            Operator::MatrixFree => dofs * multigrid_dof_bytes(on.dim, true),
            Operator::Stencil { bonds } => {
                dofs * stencil_multigrid_dof_bytes(on.dim) + nodes * bonds * GRAPH_BOND_BYTES
            }
            Operator::GeometricStencil { ratio } => geometric_multigrid_bytes(on.nodes, ratio),
            Operator::Companion { bonds } => {
                dofs * companion_multigrid_dof_bytes(on.dim) + nodes * bonds * GRAPH_BOND_BYTES
            }
        }
    }
}
