//! The 1D blended peridynamics / classical elasticity (PD/CE) model of Seleson, Beneddine and
//! Prudhomme (2013), assembled as their Algorithm A, with a coarse CE mesh and the
//! higher-order-gradient (HOG) generalisation of their section 6.
//!
//! # The model
//!
//! With a blending function `beta` (1 in `Omega_PD`, 0 in `Omega_CE`), eq. (15) splits every
//! bond `(x, x + xi)` into a nonlocal share `a = (beta(x) + beta(x + xi)) / 2` and a local share
//! `1 - a` that is replaced by its Taylor expansion (12):
//!
//! ```text
//! -b(x) = int a C (u(x+xi) - u(x)) dxi + sum_{n=1}^{M} D_n(x) u^{(n)}(x),
//! D_n(x) = (1/n!) int (1 - a(x, xi)) C(|xi|) xi^n dxi,                          (15), (37)
//! ```
//!
//! `M = 2` is the PD/CE model (15); `M = 4` the PD/HOG model (37)-(38), which for `beta = 0`
//! is `K u'' + kappa u''''` (40) with `kappa = (1/12) int_0^eps C xi^4` (39). The midpoint
//! quadrature on the lattice `x_i = i dx` with `N = eps/dx` neighbours per side gives eq. (22)
//! for the inverse-distance kernel: the nonlocal coefficients `f_PD / j * (beta_i + beta_{i+j})/2`
//! and the local sums `SUM1`, `SUM2` of Algorithm A lines 30-51 are `D_1` and `D_2` here
//! (`crates/linpd-blend/tests/algorithm_a.rs` checks this entry for entry).
//!
//! # One formula for every node
//!
//! Algorithm A treats three node sets (pure CE, pure PD, transition) separately. Here every
//! node's row comes from the formula above: it reduces to eq. (28) where `a = 0` on the whole
//! stencil and to eq. (29) where `a = 1`, so each row is assembled exactly once whatever the
//! geometry (transition regions that touch the domain ends or overlap each other). A bond whose
//! far end lies outside the domain has no node to couple to: its whole weight is local
//! (`a = 0`), which keeps the row exact for quadratic fields.
//!
//! # Force form
//!
//! Rows are multiplied by the node's dual cell length `V_i = (x_{i+1} - x_{i-1}) / 2`, so the
//! right-hand side is a force (`f_i = b_i V_i`; a point load `b_i = delta_ip / dx` is `f_p = 1`)
//! and both the PD part and the (non-uniform) CE part are symmetric. The only asymmetry left is
//! in the local terms of transition rows (`tests/properties.rs`).
//!
//! # Phases and defects
//!
//! [`crate::BlendParams::material`] takes the bond model's phases, bond rule and defects: PD bonds get
//! the bond model's factors, pure CE rows the divergence form `-(K(x) u')'` with the phase
//! modulus, transition rows the Taylor expansion of the local share of the heterogeneous bonds;
//! defects only where every row that sees them is pure PD ([`material`] has the equations and
//! the reasons).
//!
//! # Force balance
//!
//! End rows hold the force of the local model on the end node's half cell, so `A u - f` at a
//! Dirichlet node is its support's reaction ([`crate::BlendSolution::reactions`]). The PD and CE parts
//! have zero column sums; the transition rows do not (their local terms are not in divergence
//! form), so `sum of reactions + sum of loads = 1^T A u` is not zero in general. It vanishes
//! when `u` is quadratic on the stencils of the transition rows (then every blended row is the
//! PD row, and Algorithm A makes no approximation, section 3.2): the imbalance measures the
//! Taylor remainder (12) of the solution in the transition zones (`tests/balance.rs`).

pub mod blending;
pub mod material;
pub mod mesh;
pub mod model;
pub mod solve;
mod static_model;
