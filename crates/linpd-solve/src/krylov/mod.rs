//! Krylov methods over any [`linpd_core::LinearOperator`], generic over a [`Preconditioner`]:
//! [`cg`] for SPD systems, [`gmres`] for unsymmetric ones. The trait is defined here
//! ([`preconditioner`]); its implementations live in [`crate::precond`].

pub mod cg;
pub mod gmres;
pub mod preconditioner;

pub use preconditioner::{Identity, Preconditioner};
