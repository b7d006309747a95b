//! linpd: linear peridynamics — sparse operators, solvers and studies.
//!
//! This facade re-exports the workspace crates:
//! [`core`] (grids, families, kernels, materials), [`bond`] (bond-based operator),
//! [`solve`] (solvers) and [`problem`] (JSON scenes).
#![deny(missing_docs)]

pub use linpd_bond as bond;
pub use linpd_core as core;
pub use linpd_problem as problem;
pub use linpd_solve as solve;
