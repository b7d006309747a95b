//! The models of a scene, one module per model: each owns its `model` keys (a serde struct
//! that denies unknown keys), their validation, its memory estimate, the [`linpd_core::Model`]
//! it builds, the fields of its solution and what the commands may do with it (its
//! [`Capability`]s).
//!
//! | module | scene | builds |
//! |---|---|---|
//! | [`bond`] | `"type": "bond"` (keys; picks one of the next three) | |
//! | [`bond_lattice`] | bond on a grid | [`linpd_bond::LatticeBondModel`] |
//! | [`bond_cloud`] | bond on a point cloud (`"nodes"`) | [`linpd_bond::BondOperator`] |
//! | [`lattice_blend`] | bond with `pd_regions` (2D/3D) | [`linpd_blend::LatticeBlend`] |
//! | [`lps`] | `"type": "lps"` on a grid or a point cloud | [`linpd_lps::LpsModel`] |
//! | [`blend_1d`] | `"type": "blend"` and `"ce"` (1D) | [`linpd_blend::BlendOperator`] |
//! | [`coarsened`] | `"type": "coarsened"` | [`linpd_core::AssembledModel`] |
//!
//! [`registry`] is the one place that maps `model.type` to a module. Every command asks the
//! validated model ([`SceneModel`]) for what it needs and, where the model lacks a
//! [`Capability`], refuses by name ([`crate::ProblemError::Unavailable`]); nothing outside the
//! registry matches on the model type. docs/extending.md says what a new model touches.

pub mod blend_1d;
pub mod bond;
pub mod bond_cloud;
pub mod bond_lattice;
pub mod bond_model;
pub mod coarsened;
pub mod lattice_blend;
pub mod lps;
pub mod model_type;
pub mod registry;

pub use crate::capability::Capability;
pub use crate::scene::{foreign_system, refusal, solve_system, Built, DynamicsOperator, Purpose, SceneModel, System};
pub use model_type::ModelType;
pub use registry::Registry;
