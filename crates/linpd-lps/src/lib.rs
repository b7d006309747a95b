//! The linear peridynamic solid (LPS, ordinary state-based) on a lattice: the nonlinear
//! internal force of the LAMMPS howto (Algorithms 2-4) and its analytic tangent stiffness at
//! the reference configuration, assembled as a sparse symmetric matrix or applied matrix-free.
//!
//! # The model (LAMMPS howto eqs. (3)-(4), Silling et al. 2007)
//!
//! For node `i` with family `F_i`, bond `xi = x_j - x_i` (the exact lattice vector
//! `(k_j - k_i) h`), current bond `Y = xi + u_j - u_i`, extension `e = |Y| - |xi|`,
//! influence function `omega(|xi|)` ([`Influence`]) and partial-volume fraction `nu(|xi|)`:
//!
//! ```text
//! m_i     = sum_j omega |xi|^2 nu V_j                       (eq. (4), Algorithm 3)
//! theta_i = (d / m_i) sum_j omega |xi| e nu V_j             (Algorithm 4; d = 3, or 2 in 2D)
//! W_i     = kappa theta_i^2 / 2 + (a G / (2 m_i)) sum_j omega (e - theta_i |xi| / d)^2 nu V_j
//! ```
//!
//! with `(d, kappa, a) = (3, K, 15)` in 3D (eq. (3): `alpha = 15 G / m`) and `(2, kappa', 8)`
//! in 2D (see [`model`] for the 2D constants). The force on node `i` (force, not force
//! density: `F_i = V_i f_i`, `F = -dE/du`, `E = sum_i V_i W_i`) is Algorithm 2 without damage,
//! contact or short-range forces:
//!
//! ```text
//! F_i = V_i sum_j [ (d kappa - a G / d) (theta_i / m_i + theta_j / m_j) omega |xi|
//!                   + a G (omega / m_i + omega / m_j) e ] nu V_j  Y / |Y|
//! ```
//!
//! which in 3D is the howto's `(3K - 5G)` / `15G` formula. The tangent `A = -dF/du` at `u = 0`
//! is symmetric positive semi-definite with the rigid motions in its null space; see
//! [`tangent`].
//!
//! * [`LpsModel`] owns the lattice family, `omega`, `nu`, `|xi|` per bond and `m` per node;
//! * [`force`]: `theta`, energy and the nonlinear internal force;
//! * [`fields`]: the per-node output fields of the linearized model (dilatation, energy
//!   density summing to `u . A u / 2`) and the node volume accessor;
//! * [`tangent`]: the sparse tangent ([`tangent::assemble_tangent`]) and the matrix-free
//!   apply in factored form ([`LpsModel::apply_tangent`]);
//! * [`surface`]: the optional bulk weighted-volume surface correction
//!   ([`LpsModel::with_surface_correction`]);
//! * [`stencil`]: the tangent of a homogeneous material on the full box applied from stencils
//!   (no per-bond lists read);
//! * [`pair`]: the pair part `A_pair` of the tangent as a model, the SPD companion the
//!   matrix-free multigrid is built from;
//! * [`fd`]: the finite-difference tangent ([`fd_tangent`]), the Peridigm-style baseline.
#![deny(missing_docs)]

pub mod error;
pub mod fd;
pub mod fields;
pub mod force;
pub mod memory;
pub mod model;
pub mod pair;
pub mod static_model;
pub mod stencil;
pub mod surface;
pub mod tangent;

pub use error::LpsError;
pub use fd::fd_tangent;
pub use linpd_core::surface::SurfaceTarget;
pub use linpd_core::PlaneModel;
pub use model::{Influence, LpsModel, LpsParams};
pub use pair::PairPart;
pub use stencil::LpsStencil;
pub use surface::SurfaceCorrection;
pub use tangent::{assemble_tangent, TangentPattern};
