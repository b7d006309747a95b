//! Paper fixtures used by the studies. The dense reference computations of Silling (2010),
//! section 5 (Gaussian elimination and the periodic cell's effective modulus of Example 5.2) and
//! the level-0 micromoduli live in one place, [`linpd_coarsen::paper`], so that the model
//! crate's own tests (`crates/linpd-coarsen/tests/`) use the same copy; this module re-exports
//! them for the studies.

pub use linpd_coarsen::paper::{cell_modulus, gauss, H};
