//! The error type of the dynamics crate.

use linpd_core::CoreError;
use thiserror::Error;

/// Where a stability limit came from (named in [`DynamicsError::Unstable`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitMethod {
    /// `lambda_max` of `M^-1 A` by power iteration (sharp, approaches from below).
    PowerIteration,
    /// `lambda_max` bounded by Gershgorin discs (conservative).
    Gershgorin,
    /// A limit supplied by the caller.
    Given,
}

impl std::fmt::Display for LimitMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LimitMethod::PowerIteration => "lambda_max by power iteration",
            LimitMethod::Gershgorin => "lambda_max bounded by Gershgorin discs",
            LimitMethod::Given => "limit given by the caller",
        })
    }
}

/// Invalid input to an integrator, an operator or a measurement, or a run that diverged.
///
/// Variants carry the offending values so that a caller can say which input was wrong.
#[non_exhaustive]
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DynamicsError {
    /// The time step is not a finite positive number.
    #[error("time step dt: must be finite and > 0, got {0:e}")]
    TimeStep(f64),
    /// Zero time steps were requested.
    #[error("steps: must be >= 1, got 0")]
    NoSteps,
    /// The mass density is not a finite positive number.
    #[error("density rho: must be finite and > 0, got {0:e}")]
    Density(f64),
    /// A node volume is not a finite positive number.
    #[error("volume of DOF {dof}: must be finite and > 0, got {value:e}")]
    Volume {
        /// DOF whose volume is wrong.
        dof: usize,
        /// The volume given.
        value: f64,
    },
    /// The time step exceeds the velocity-Verlet stability limit `2 / sqrt(lambda_max(M^-1 A))`.
    #[error(
        "time step dt = {dt:e} exceeds the stability limit dt_max = {limit:e} = 2/sqrt(lambda_max(M^-1 A)) \
         ({method}); use dt <= {limit:e} or set allow_unstable"
    )]
    Unstable {
        /// The time step requested.
        dt: f64,
        /// The stability limit.
        limit: f64,
        /// How the limit was obtained.
        method: LimitMethod,
    },
    /// A vector has the wrong length.
    #[error("{what}: expected {expected} entries, got {got}")]
    Length {
        /// Which vector (`u`, `v`, `volumes`, ...).
        what: &'static str,
        /// Entries required.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// A fixed DOF is out of range or its prescribed value is not finite.
    #[error("fixed DOF {dof} (value {value:e}): the system has {n} DOFs and values must be finite")]
    FixedDof {
        /// The DOF.
        dof: usize,
        /// Its prescribed value.
        value: f64,
        /// Number of DOFs of the system.
        n: usize,
    },
    /// The state (energy) became non-finite: the run blew up.
    #[error("the state became non-finite at step {step} (t = {t:e}): the run diverged")]
    Diverged {
        /// Step at which it was detected.
        step: usize,
        /// Time of that step.
        t: f64,
    },
    /// A Gershgorin bound was asked of an operator that cannot report its entries.
    #[error(
        "the operator does not report its row sums |A_ij|: no Gershgorin bound (use power iteration or a given limit)"
    )]
    NoGershgorin,
    /// A scalar parameter is out of range.
    #[error("{name}: {reason}")]
    Parameter {
        /// Parameter name.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A modal fit could not be made from the samples.
    #[error("modal fit: {0}")]
    Fit(String),
    /// Building a kernel or normalization failed.
    #[error(transparent)]
    Core(#[from] CoreError),
}

impl DynamicsError {
    /// Shorthand for a [`DynamicsError::Parameter`].
    pub fn param(name: &'static str, reason: impl Into<String>) -> Self {
        DynamicsError::Parameter { name, reason: reason.into() }
    }
}

/// `Ok(())` for a finite `x > 0`, else a [`DynamicsError::Parameter`] naming it.
pub(crate) fn positive(name: &'static str, x: f64) -> Result<(), DynamicsError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(DynamicsError::param(name, format!("must be finite and > 0, got {x:e}")))
    }
}
