//! Lumped masses `M_i = rho V_i` and the check that an operator has one mass per DOF (used by
//! [`crate::verlet`], [`crate::stability`] and [`crate::chain`]).

use crate::error::DynamicsError;
use linpd_core::LinearOperator;

/// `Ok` when `op` has `n` DOFs (one mass per operator DOF).
pub(crate) fn check_size<A: LinearOperator + ?Sized>(op: &A, n: usize) -> Result<(), DynamicsError> {
    let m = op.n();
    if m != n {
        return Err(DynamicsError::Length { what: "masses (one per operator DOF)", expected: m, got: n });
    }
    Ok(())
}

/// Lumped masses `M_i = rho V_i`, one per DOF.
#[derive(Debug, Clone, PartialEq)]
pub struct LumpedMass {
    rho: f64,
    m: Vec<f64>,
}

impl LumpedMass {
    /// `n` DOFs of volume `volume` (`V = h^d`; `dx` in 1D).
    pub fn uniform(rho: f64, volume: f64, n: usize) -> Result<Self, DynamicsError> {
        Self::check_rho(rho)?;
        if !(volume.is_finite() && volume > 0.0) {
            return Err(DynamicsError::Volume { dof: 0, value: volume });
        }
        Ok(LumpedMass { rho, m: vec![rho * volume; n] })
    }

    /// One volume per DOF (repeat a node's volume for each of its components).
    pub fn new(rho: f64, volumes: &[f64]) -> Result<Self, DynamicsError> {
        Self::check_rho(rho)?;
        if let Some((dof, &value)) = volumes.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v > 0.0)) {
            return Err(DynamicsError::Volume { dof, value });
        }
        Ok(LumpedMass { rho, m: volumes.iter().map(|v| rho * v).collect() })
    }

    fn check_rho(rho: f64) -> Result<(), DynamicsError> {
        if rho.is_finite() && rho > 0.0 {
            Ok(())
        } else {
            Err(DynamicsError::Density(rho))
        }
    }

    /// Density `rho`.
    pub fn rho(&self) -> f64 {
        self.rho
    }
    /// Number of DOFs.
    pub fn len(&self) -> usize {
        self.m.len()
    }
    /// True for a system without DOFs.
    pub fn is_empty(&self) -> bool {
        self.m.is_empty()
    }
    /// Masses `M_i`.
    pub fn masses(&self) -> &[f64] {
        &self.m
    }
}
