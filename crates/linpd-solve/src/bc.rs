//! The one Dirichlet elimination of linpd.
//!
//! Volume constraints prescribe `u = u_bar` at constrained DOFs. Writing `u = u_bar + u_f`
//! (`u_bar` zero at free DOFs, `u_f` zero at constrained ones), the free equations of
//! `A u = f` are
//!
//! ```text
//! A_ff u_f = f_f - (A u_bar)_f,
//! ```
//!
//! which keeps `A_ff` symmetric positive definite when `A` is SPD on the constrained body.
//! `A u_bar` is applied matrix-free over all DOFs, so the full matrix is never assembled. Loads
//! on constrained DOFs are reactions and do not enter the reduced system.

use linpd_core::{DofMap, LinearOperator};
use std::sync::Mutex;

/// Prescribed displacements: which DOFs are constrained and their values.
#[derive(Debug, Clone, PartialEq)]
pub struct Dirichlet {
    dofs: DofMap,
    u_bar: Vec<f64>,
}

/// A prescribed DOF out of range or not finite.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("prescribed DOF {dof} = {value:e} is out of range (the model has {n_dofs} DOFs) or not finite")]
pub struct BadPrescribed {
    /// The DOF.
    pub dof: usize,
    /// The value.
    pub value: f64,
    /// DOFs of the model.
    pub n_dofs: usize,
}

impl Dirichlet {
    /// From a mask over full DOFs (`d` per node, node-major) and the full vector `u_bar`
    /// (read at constrained DOFs only; it is zeroed elsewhere).
    pub fn new(dim: usize, constrained: &[bool], mut u_bar: Vec<f64>) -> Self {
        assert_eq!(constrained.len(), u_bar.len(), "mask and u_bar lengths");
        u_bar.iter_mut().zip(constrained).filter(|(_, &c)| !c).for_each(|(u, _)| *u = 0.0);
        Dirichlet { dofs: DofMap::new(dim, constrained), u_bar }
    }

    /// From a list of `(dof, value)` pairs over `n_dofs` DOFs (a later pair for the same DOF
    /// wins).
    pub fn from_fixed(dim: usize, n_dofs: usize, fixed: &[(usize, f64)]) -> Result<Self, BadPrescribed> {
        let mut mask = vec![false; n_dofs];
        let mut u_bar = vec![0.0; n_dofs];
        for &(dof, value) in fixed {
            if dof >= n_dofs || !value.is_finite() {
                return Err(BadPrescribed { dof, value, n_dofs });
            }
            mask[dof] = true;
            u_bar[dof] = value;
        }
        Ok(Dirichlet::new(dim, &mask, u_bar))
    }

    /// The free/constrained split.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The prescribed values over all DOFs (zero at free ones).
    pub fn u_bar(&self) -> &[f64] {
        &self.u_bar
    }

    /// The reduced right-hand side `f_f - (A u_bar)_f`, with `a` applied over all DOFs.
    pub fn reduced_rhs(&self, a: &dyn LinearOperator, f: &[f64]) -> Vec<f64> {
        let mut a_ubar = vec![0.0; self.u_bar.len()];
        a.apply(&self.u_bar, &mut a_ubar);
        let rhs: Vec<f64> = f.iter().zip(&a_ubar).map(|(f, a)| f - a).collect();
        self.dofs.gather(&rhs)
    }

    /// `u = u_bar + u_f` over all DOFs.
    pub fn expand(&self, u_free: &[f64]) -> Vec<f64> {
        let mut u = self.u_bar.clone();
        self.dofs.scatter(u_free, &mut u);
        u
    }
}

/// `A_ff` applied through an operator over all DOFs: scatter the free vector (constrained
/// entries zero), apply, gather. The two full-size work vectors are allocated once, not per
/// application (CG applies the operator once per iteration, from one thread).
pub struct ReducedOperator<'a> {
    full: &'a dyn LinearOperator,
    dofs: &'a DofMap,
    work: Mutex<(Vec<f64>, Vec<f64>)>,
}

impl<'a> ReducedOperator<'a> {
    /// `A_ff` of `full` (size `dofs.n_dofs()`).
    pub fn new(full: &'a dyn LinearOperator, dofs: &'a DofMap) -> Self {
        assert_eq!(full.n(), dofs.n_dofs(), "operator size");
        let n = dofs.n_dofs();
        ReducedOperator { full, dofs, work: Mutex::new((vec![0.0; n], vec![0.0; n])) }
    }
}

impl LinearOperator for ReducedOperator<'_> {
    fn n(&self) -> usize {
        self.dofs.n_free()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let mut work = self.work.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let (x_full, y_full) = &mut *work;
        // Constrained entries of x_full are zero from the start and never written.
        self.dofs.scatter(x, x_full);
        self.full.apply(x_full, y_full);
        self.dofs.gather_into(y_full, y);
    }
}
