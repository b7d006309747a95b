//! The JSON scene: a plain serde mirror ([`raw`]) with unknown keys rejected, validated into a
//! typed [`Problem`] whose errors name the JSON path (`model.horizon: must be > 0`), then built
//! into an operator and solved ([`run`]), and written out ([`output`]) through an [`OutputDir`]
//! ([`atomic`]): all files of a run or none.
//!
//! Each model type is one module of [`models`] (its keys, validation, build, fields and
//! capabilities); the commands ask the scene's model ([`models::SceneModel`]) and never match on
//! its type. Coarsened levels (`"model": {"type": "coarsened", "moduli": ...}`) have no grid:
//! their nodes are [`Nodes::Level`] ([`models::coarsened`]).
//!
//! The key reference is `docs/problem-format.md`.
#![deny(missing_docs)]

pub mod atomic;
pub mod balance;
pub mod cloud;
pub mod dynamics;
pub mod error;
pub mod export;
pub mod fields;
pub mod memory;
pub mod models;
pub mod output;
pub mod petsc;
pub mod pipeline;
pub mod problem;
pub mod raw;
pub mod rows;
pub mod run;
pub mod vtu;

pub use atomic::{OutputDir, RunIdentity};
pub use balance::{Balance, ConstraintBalance, LoadBalance};
pub use dynamics::{Dynamics, DynamicsRun, Initial, TimeStep};
pub use error::ProblemError;
pub use export::ReducedSystem;
pub use fields::{nodal_strain, NodalStrain};
pub use linpd_core::sparse::restrict_to_free as reduce_to_free;
pub use models::bond::{BondModel, Surface};
pub use models::coarsened::{CoarsenedModel, ModuliFile};
pub use models::lattice_blend::{PdRegions, PdZone};
pub use models::lps::CG_NEAR_INCOMPRESSIBLE_NU;
pub use models::{Capability, ModelType, Registry, SceneModel};
pub use pipeline::{level0_model, Pipeline, PipelineResult};
pub use problem::{Constraint, LevelNodes, Load, Nodes, Problem, MAX_JSON_BYTES};
pub use rows::{RowBlock, RowSystem};
pub use run::Solution;
