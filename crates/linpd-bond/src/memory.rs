//! The bytes of the bond model's structures, for the memory guard of a scene (which sums what
//! its solver plan names): the family and its weights while they are built, and the assembled
//! stiffness. Each figure is a fit of measured peaks (`/usr/bin/time`, the process baseline
//! cancelled) at two sizes; docs/robustness.md has the sweep that checks them.

/// Per bond while the family and its weights are built (fits of two sizes each, the process
/// baseline cancelled: 10.6-11.7 in 3D matrix-free runs, 15.4 in 2D; docs/robustness.md).
pub const BOND_BYTES: f64 = 12.0;

/// Per stored entry of the assembled bond stiffness (fits: 18.6-19.1 in 3D, 19.8-21.6 in 2D).
pub const ENTRY_BYTES: f64 = 20.0;

/// Per stored entry of the assembled bond stiffness on a point cloud (fit: ~28 with the exact
/// bond counts; its families are built by a cell list, not a stencil).
pub const CLOUD_ENTRY_BYTES: f64 = 28.0;
