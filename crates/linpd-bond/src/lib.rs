//! The linear bond-based peridynamic operator in 1D, 2D and 3D.
//!
//! For a node `i` with family `F_i`, the force (not force density) on `i` is
//!
//! ```text
//! F_i = sum_{j in F_i} w_ij (e_ij (x) e_ij) (u_j - u_i),   w_ij = lambda_ij nu_ij V_i V_j,
//! ```
//!
//! with `e_ij = (x_j - x_i)/|x_j - x_i|`, `lambda_ij` the bond micromodulus, `nu_ij` the
//! partial-volume fraction and `V` the node volumes. In 1D `e (x) e = 1` and this is
//! `V_i (L u)_i` with `(L u)_i = sum_j C_ij (u_j - u_i) V_j`, eq. (29) of Seleson et al. (2013)
//! once `C` is the discrete inverse-distance kernel. In 2D/3D it is the linearization of the
//! PMB force (LAMMPS howto eq. (5)-(7)) about the reference configuration, see [`pmb_force`].
//!
//! The stiffness matrix `A` is defined by `F = -A u`. Multiplying the force density by `V_i`
//! makes `A` symmetric for any volumes (`w_ij = w_ji`); it is positive semi-definite with the
//! rigid motions (1, 3 and 6 in 1D/2D/3D) in its null space, and each block row sums to zero.
//!
//! * [`BondOperator`] holds the family and the per-bond weights; it applies `A` without
//!   storing it ([`BondOperator::apply`]) and assembles it ([`assemble()`]);
//! * [`LatticeBondModel`]: the operator on a lattice as a [`linpd_core::Model`] (nested
//!   dissection ordering, stencil apply when homogeneous);
//! * [`stencil::StencilOperator`] applies `A` on a homogeneous full-box lattice from the
//!   stencil alone (no per-bond storage);
//! * [`corrected::CorrectedStencil`] applies `A` of any lattice operator (phases, defects,
//!   corrections, bodies) as the stencil plus the bonds that differ from it;
//! * [`surface`]: the `energy` surface correction (per-node moment matching, bond factor the
//!   mean of its ends);
#![deny(missing_docs)]

pub mod assemble;
pub mod corrected;
pub mod memory;
pub mod model;
pub mod operator;
pub mod quadrature;
pub mod stencil;
pub mod surface;

pub use assemble::{assemble, Pattern};
pub use corrected::CorrectedStencil;
pub use linpd_core::{nested_dissection, planar_nested_dissection};
pub use model::{offers_coarse_lattice, LatticeBondModel};
pub use operator::{pmb_force, BondOperator};
pub use stencil::StencilOperator;
