//! The JSON scene: a plain serde mirror ([`raw`]) with unknown keys rejected, validated into a
//! typed [`Problem`] whose errors name the JSON path (`model.horizon: must be > 0`), then built
//! into an operator and solved ([`run`]), and written out ([`output`]) through an [`OutputDir`]
//! ([`atomic`]): all files of a run or none.
//!
//! Coarsened levels (`"model": {"type": "coarsened", "moduli": ...}`) have no grid: their
//! nodes are [`Nodes::Level`] and their model [`ModelSpec::Coarsened`] ([`coarsened`]).
//!
//! The key reference is `docs/problem-format.md`.
#![deny(missing_docs)]

pub mod atomic;
pub mod balance;
pub(crate) mod blend;
pub mod cloud;
pub mod coarsened;
pub mod dynamics;
pub mod error;
pub mod export;
pub mod fields;
pub(crate) mod lps;
pub mod memory;
pub mod output;
pub mod petsc;
pub mod pipeline;
pub mod problem;
pub mod raw;
pub mod rows;
pub mod run;
pub mod vtu;
pub mod zones;

pub use atomic::{OutputDir, RunIdentity};
pub use balance::{Balance, ConstraintBalance, LoadBalance};
pub use coarsened::{CoarsenedModel, ModuliFile};
pub use dynamics::{Dynamics, DynamicsRun, Initial, TimeStep};
pub use error::ProblemError;
pub use export::ReducedSystem;
pub use fields::{nodal_strain, NodalStrain};
pub use linpd_core::sparse::restrict_to_free as reduce_to_free;
pub use lps::CG_NEAR_INCOMPRESSIBLE_NU;
pub use pipeline::{level0_model, Pipeline, PipelineResult};
pub use problem::{
    BlendScene, BondModel, Constraint, LevelNodes, Load, ModelSpec, Nodes, PdRegions, PdZone, Problem, MAX_JSON_BYTES,
};
pub use rows::{RowBlock, RowSystem};
pub use run::Solution;
