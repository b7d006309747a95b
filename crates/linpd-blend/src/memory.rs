//! The bytes of the blended models' structures, for the memory guard of a scene: the lattice
//! blend's `A` and its SPD companion `M` (over all DOFs and restricted to the free ones), and
//! the lattice-wide maps of the blend on a graded local mesh (whose masters' part is checked by
//! [`crate::GradedBlend::new`] once the mesh is known).

/// Per stored entry of the bond model's `A`, the blended model (`A`, `M`, their free-DOF
/// restrictions, 16 bytes each).
pub const BLEND_ENTRY_BYTES: f64 = 64.0;

/// Per lattice node of a graded blend (no bonds: those are built near the fine cells only and
/// checked with the masters, [`crate::GradedBlend::new`]): `beta` and the distance
/// transforms, the per-node flags, the mesh's cell levels and distances (the constraints, the
/// loads and the balance reach the masters without lattice-sized vectors). Measured: 23 bytes
/// a node at the peak of the build on the 15.8M-node penny block of `linpd study penny-sneddon`.
pub const GRADED_NODE_BYTES: f64 = 40.0;
