//! The application over the scene (crate linpd-scene, re-exported here whole): the commands
//! that take a validated [`Problem`] further. Each is written once against the scene's model
//! interface ([`SceneModel`]), asking its capabilities, never its type:
//!
//! * [`export`]: the reduced system `A_ff u_f = f_f - (A u_bar)_f` for another solver
//!   (Matrix Market, [`petsc`] binary);
//! * [`rows`]: rows of `A_ff` on demand (the Python package, the distributed PETSc solve);
//! * [`pipeline`]: Silling's multi-level coarsening of a scene, with [`level_solve`];
//! * [`dynamics_run`]: the explicit dynamics of a scene's `dynamics` section;
//! * [`atomic`]: all files of a run or none ([`OutputDir`]).
//!
//! [`Commands`] gives a [`Problem`] the methods of these commands (`p.reduced_system(..)`,
//! `p.row_system()`, `p.run_dynamics(..)`, ...).
#![deny(missing_docs)]
// Invariants become errors with a reason, not panics: a scene is user input.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

pub use linpd_scene::*;

pub mod atomic;
pub mod commands;
pub mod dynamics_run;
pub mod export;
pub mod level_solve;
pub mod petsc;
pub mod pipeline;
pub mod rows;

pub use atomic::{OutputDir, RunIdentity};
pub use commands::Commands;
pub use dynamics_run::{DynamicsRun, StabilityLimit};
pub use export::ReducedSystem;
pub use pipeline::{level0_model, Pipeline, PipelineResult};
pub use rows::{part_rows, PartRows, RowBlock, RowSystem};
