//! linpd: linear peridynamics — sparse operators, solvers and studies.
//!
//! This facade re-exports the workspace crates:
//! [`core`] (grids, families, kernels, materials), [`bond`] (bond-based operator),
//! [`solve`] (solvers), [`problem`] (JSON scenes), [`blend`] (1D blended PD/CE),
//! [`lps`] (linearized LPS), [`coarsen`] (Silling 2010 coarsening) and [`dynamics`]
//! (velocity Verlet, dispersion, stability); with the features of the same names (all on by
//! default, through `cli`) also `plot` (figures), `studies` (`linpd study`, the paper studies)
//! and `bench` (`linpd bench`). Without default features the library needs neither clap nor
//! plotters.
#![deny(missing_docs)]

pub use linpd_blend as blend;
pub use linpd_bond as bond;
pub use linpd_coarsen as coarsen;
pub use linpd_core as core;
pub use linpd_dynamics as dynamics;
pub use linpd_io as io;
pub use linpd_lps as lps;
pub use linpd_problem as problem;
pub use linpd_scene as scene;
pub use linpd_solve as solve;

#[cfg(feature = "bench")]
pub use linpd_bench as bench;
#[cfg(feature = "plot")]
pub use linpd_plot as plot;
#[cfg(feature = "studies")]
pub use linpd_studies as studies;
