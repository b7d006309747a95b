//! The bytes of explicit dynamics' vectors, for the memory guard of a `dynamics` scene.

/// Per DOF, explicit dynamics: displacement, velocity, acceleration, force, load, mass and the
/// operator's scratch (fit of a 1D bar at 1M and 2M nodes: 395-460 bytes a node with 20 bonds
/// and two snapshots, i.e. 43-108 a DOF beyond the bonds).
pub const DYNAMICS_DOF_BYTES: f64 = 96.0;
