//! Blended peridynamic / local models (Seleson, Beneddine and Prudhomme 2013, Algorithm A) in
//! one, two and three dimensions, and the multi-resolution model that puts the local part on a
//! graded mesh. By concern:
//!
//! * [`one_d`]: the 1D model of the paper, Algorithm A with a coarse CE mesh and the
//!   higher-order-gradient generalisation of its section 6 ([`BlendOperator`], [`solve_model`]);
//! * [`lattice`]: Algorithm A's rows on a 2D/3D bond lattice with bilinear / trilinear elements
//!   where the model is local ([`LatticeBlend`]), its zones from a blending field
//!   ([`beta_from_zone`]) and which nodes may take a local share ([`lattice::regular_nodes`]);
//! * [`graded_mesh`]: a quadtree / octree of lattice cells graded away from a fine region, with
//!   its hanging nodes eliminated ([`graded_mesh::GradedMesh`]);
//! * [`graded_blend`]: the 2D/3D blend whose local part lives on that mesh: the unknowns are
//!   its masters, the fine lattice is kept only near the nonlocal region ([`GradedBlend`], its
//!   strain at lattice sites, its loads as `P^T f`);
//! * [`memory`]: the bytes of these structures for a memory guard; [`error`]: [`BlendError`].
//!
//! The equations are in each module's docs. Errors are typed ([`BlendError`]): the callers map
//! them to their own keys (a scene's JSON paths); the 1D model's parameters are named by their
//! fields in [`BlendParams`].
#![deny(missing_docs)]

pub mod error;
pub mod graded_blend;
pub mod graded_mesh;
pub mod lattice;
pub mod memory;
pub mod one_d;

pub use error::BlendError;
pub use graded_blend::GradedBlend;
pub use lattice::{beta_from_zone, LatticeBlend, Profile, Zones};
pub use one_d::blending::{Blending, Regions};
pub use one_d::mesh::Mesh;
pub use one_d::model::{BlendOperator, BlendParams, LocalPart, ModelKind};
pub use one_d::solve::{
    ce_exact_point_load, constraints_and_loads, nodal_forces, solve_model, BlendSolution, BlendSolver, Load,
};
