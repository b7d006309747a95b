//! linpd: linear peridynamics — sparse operators, solvers and studies.
//!
//! This facade re-exports the workspace crates:
//! [`core`] (grids, families, kernels, materials, the `Model` trait, nodal strain, memory
//! guards), [`io`] (every file format), [`bond`] (bond-based operator), [`lps`] (linearized
//! LPS), [`blend`] (blended PD / local models in 1D, 2D and 3D, the graded mesh and the graded
//! blend), [`coarsen`] (Silling 2010 coarsening), [`dynamics`] (velocity Verlet, dispersion,
//! stability), [`solve`] (the solver plan, direct and Krylov solvers, preconditioners, the one
//! static solve), [`scene`] (JSON scenes: schema, validation, one module per model type, the
//! solve and its result) and [`problem`] (the commands on a scene: export, rows, pipelines,
//! dynamics runs, atomic outputs; it re-exports [`scene`]); with the features of the same names (all on by
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
