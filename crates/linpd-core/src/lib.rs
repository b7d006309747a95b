//! Core geometry and material description for linear peridynamics (PD).
//!
//! This crate owns everything a PD operator needs before any matrix exists:
//!
//! * [`grid`]: uniform lattices in 1D/2D/3D with optional boundary layers;
//! * [`region`]: boxes, unions and differences that name node sets;
//! * [`family`]: bond families within the horizon (lattice stencil and cell list);
//! * [`kernel`]: micromodulus shapes and their normalization to an elastic modulus;
//! * [`material`]: heterogeneous moduli, bond rules and defects that degrade bonds;
//! * [`par`]: the parallel per-node slice fill used by the assemblers;
//! * [`eigen`]: eigen-decomposition of small dense symmetric matrices (cyclic Jacobi);
//! * [`dof`]: DOF numbering and the free/constrained split;
//! * [`op`]: the one operator trait ([`LinearOperator`]) of solvers and dynamics;
//! * [`sparse`]: CSC products, diagonal, restriction to free DOFs, asymmetry;
//! * [`memory`]: the available memory and the guard that compares an estimate with it;
//! * [`model`]: the [`Model`] interface every static model implements;
//! * [`ordering`]: nested dissection on the lattice, a fill-reducing ordering for Cholesky;
//! * [`progress`]: the progress interface of long computations ([`Progress`], [`NoProgress`]);
//! * [`support`]: do the constraints remove every rigid motion of a model?
//! * [`surface`]: surface corrections by matching each node's fourth bond moments to the bulk;
//! * [`error`]: the error type shared by these modules.
//!
//! Indices into node arrays are `usize`; bond offsets are `usize` as well so that a family
//! with more than 2^31 bonds (and operators with more than 2^31 nonzeros) does not overflow.
#![deny(missing_docs)]

pub mod dof;
pub mod eigen;
pub mod error;
pub mod family;
pub mod grid;
pub mod kernel;
pub mod material;
pub mod memory;
pub mod model;
pub mod op;
pub mod ordering;
pub mod par;
pub mod polygon_index;
pub mod progress;
pub mod region;
pub mod sparse;
pub mod strain;
pub mod support;
pub mod surface;

pub use dof::DofMap;
pub use error::CoreError;
pub use family::BondFamily;
pub use grid::{box_node, box_site, for_each_box_offset, Grid, Placement};
pub use kernel::{Kernel, Micromodulus, Normalization, PlaneModel};
pub use material::{BondRule, Defect, Material};
pub use model::{
    AssembledModel, CoarseLattice, FastApply, LatticeStencil, Model, ModelOperator, Ordering, SpdApproximation,
    SpdApproximationKind,
};
pub use op::{FnOperator, LinearOperator};
pub use ordering::{nested_dissection, planar_nested_dissection, two_hop_stencil};
pub use progress::{NoProgress, Progress};
pub use region::Region;
pub use sparse::Csc;
pub use support::{check_support, RigidGram, Unsupported};

/// Points are stored with three coordinates; in 1D and 2D the unused ones are zero.
pub type Point = [f64; 3];

/// Relative tolerance used when deciding whether a lattice point lies on a region boundary
/// or whether a bond length equals the horizon. Lattice coordinates are multiples of the
/// spacing computed in floating point, so exact comparisons would flip on round-off
/// (the LAMMPS howto warns about nodes at exactly 3h when delta = 3h).
pub const GEOMETRY_RTOL: f64 = 1e-9;
