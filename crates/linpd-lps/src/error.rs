//! Errors of the LPS model construction (user input: no panics).

use thiserror::Error;

/// Why an [`crate::LpsModel`] could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LpsError {
    /// `K` is not a positive finite number.
    #[error("bulk modulus K must be a positive finite number, got {0:e}")]
    BulkModulus(f64),
    /// `G` is not a positive finite number.
    #[error("shear modulus G must be a positive finite number, got {0:e}")]
    ShearModulus(f64),
    /// `nu = (3K - 2G) / (2 (3K + G))` is not in the open interval `(-1, 1/2)`.
    ///
    /// For positive finite `K`, `G` this only happens when one modulus is so small relative
    /// to the other that `nu` rounds to a bound.
    #[error("Poisson ratio nu = (3K - 2G) / (2 (3K + G)) = {nu} is outside (-1, 1/2) (K = {bulk:e}, G = {shear:e})")]
    PoissonRatio {
        /// The computed Poisson ratio.
        nu: f64,
        /// `K`.
        bulk: f64,
        /// `G`.
        shear: f64,
    },
    /// A derived constant overflows although `K` and `G` are finite.
    #[error("K = {bulk:e} and G = {shear:e} overflow: the derived constant {what} = {value:e}; use smaller units for the moduli")]
    Overflow {
        /// The formula of the constant.
        what: &'static str,
        /// Its (non-finite) value.
        value: f64,
        /// `K`.
        bulk: f64,
        /// `G`.
        shear: f64,
    },
    /// The horizon is smaller than the lattice spacing (or not a positive finite number).
    #[error(
        "horizon delta = {horizon:e} must be >= the lattice spacing (mean node size of a point cloud) h = {spacing:e}"
    )]
    Horizon {
        /// `delta`.
        horizon: f64,
        /// `h`.
        spacing: f64,
    },
    /// The LPS model is implemented in 2D and 3D only.
    #[error("the LPS model needs dimension 2 or 3, got {0}")]
    Dimension(usize),
    /// A 2D model needs plane stress or plane strain.
    #[error("a 2D LPS model needs a plane model (plane stress or plane strain)")]
    MissingPlane,
    /// A node has weighted volume `m = 0` (an empty family), so `theta = (d/m) ...` is undefined.
    #[error("node {node} at {position:?} has weighted volume m = 0 (no bonds); the dilatation is undefined")]
    ZeroWeightedVolume {
        /// The node number.
        node: usize,
        /// Its reference position.
        position: [f64; 3],
    },
    /// The family does not belong to the grid (wrong length or a bond without its reverse).
    #[error("bond family is inconsistent with the grid: {0}")]
    Family(String),
    /// A surface correction or target that matches a lattice's interior was asked of a
    /// point-cloud model.
    #[error("{0} matches the interior of a lattice; a point-cloud model has none")]
    NeedsLattice(&'static str),
}
