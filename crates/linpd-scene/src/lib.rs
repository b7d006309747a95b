//! The JSON scene: a plain serde mirror ([`raw`]) with unknown keys rejected, validated into a
//! typed [`Problem`] whose errors name the JSON path (`model.horizon: must be > 0`), built into
//! an operator and solved ([`run`]), with its typed result ([`solution`], [`output`]).
//!
//! Each model type is one module of [`models`] (its keys, validation, build, fields and
//! capabilities); the commands (crate linpd-problem) ask the scene's model
//! ([`models::SceneModel`]) and never match on its type. Coarsened levels (`"model": {"type":
//! "coarsened", "moduli": ...}`) have no grid: their nodes are [`Nodes::Level`]
//! ([`models::coarsened`]).
//!
//! The key reference is `docs/problem-format.md`.
#![deny(missing_docs)]
// Invariants become errors with a reason, not panics: a scene is user input.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

// In layers, each using only those above it (no module cycle): files and formats; the
// scene's parts; the scene and its model's interface; the models; the static solve.
pub mod capability;
pub mod error;
pub mod json;
pub mod memory;
pub mod modes;
pub mod raw;

pub mod balance;
pub mod cloud;
pub mod dynamics;
pub mod elastic;
pub mod nodes;
pub mod part;
pub mod solution;
pub mod stress;
pub mod validate;

pub mod output;
pub mod probe;
pub mod scene;

pub mod models;

pub mod run;

pub use balance::{Balance, ConstraintBalance, LoadBalance};
pub use capability::Capability;
pub use dynamics::{Dynamics, Initial, TimeStep};
pub use error::ProblemError;
pub use json::MAX_JSON_BYTES;
pub use linpd_core::sparse::restrict_to_free as reduce_to_free;
/// The nodal strain of a solution (least squares over each node's partners), from linpd-core.
pub use linpd_core::strain as fields;
pub use linpd_core::strain::{nodal_strain, NodalStrain};
pub use models::bond_model::{BondModel, Surface};
pub use models::coarsened::{CoarsenedModel, ModuliFile};
pub use models::lattice_blend::{PdRegions, PdZone};
pub use models::lps::CG_NEAR_INCOMPRESSIBLE_NU;
pub use models::{ModelType, Registry};
pub use nodes::{LevelNodes, Nodes};
pub use part::{Part, Presence, Slab};
pub use probe::{Probe, ProbeSamples};
pub use scene::{Constraint, Load, Problem, SceneModel};
pub use solution::Solution;
pub use stress::StressMap;
