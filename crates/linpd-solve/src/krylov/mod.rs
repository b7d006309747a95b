//! Krylov methods over any [`linpd_core::LinearOperator`], generic over a
//! [`crate::Preconditioner`]: [`cg`] for SPD systems, [`gmres`] for unsymmetric ones.

pub mod cg;
pub mod gmres;
