//! What a solve cost and how accurate it is.

use crate::spec::SolverId;
use serde::Serialize;

/// Wall-clock seconds per phase.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct Timings {
    /// Operator construction and assembly (filled by the caller).
    pub assemble: f64,
    /// Symbolic analysis (ordering, elimination tree).
    pub symbolic: f64,
    /// Numeric factorization.
    pub numeric: f64,
    /// Preconditioner setup (Krylov solvers: e.g. the multigrid hierarchy).
    pub setup: f64,
    /// Triangular solves or Krylov iterations.
    pub solve: f64,
    /// Solver total (symbolic + numeric + setup + solve, and dispatch overhead).
    pub total: f64,
}

/// The accuracy and cost of one solve.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SolveReport {
    /// Solver that ran (serialized as its short name: `cholesky-nd`, `lu`, `cg-jacobi`, ...).
    pub solver: SolverId,
    /// What the reader should know, in order: why this solver ran when the scene asked for
    /// another (e.g. `K` unsymmetric), `auto`'s fallbacks, and what the model adds (a surface
    /// correction, the blend's zones, a warning).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// How `auto` chose: each candidate's estimated time and what it rests on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto: Option<String>,
    /// What the preconditioner built (e.g. the multigrid levels), when it says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preconditioner: Option<String>,
    /// Unknowns (free DOFs).
    pub n: usize,
    /// Stored entries of the reduced stiffness (both triangles; 0 when matrix-free).
    pub nnz_a: usize,
    /// Stored entries of the factor (direct solvers).
    pub nnz_factor: Option<usize>,
    /// Floating-point operations of the factorization (sparse Cholesky: from its symbolic
    /// analysis, [`crate::Cholesky::flops`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub factor_flops: Option<f64>,
    /// Krylov iterations (iterative solvers).
    pub iterations: Option<usize>,
    /// `||A u - f|| / ||f||` recomputed after the solve.
    pub rel_residual: f64,
    /// Phase timings in seconds.
    pub timings: Timings,
    /// Peak resident memory of the process (bytes), where the OS reports it.
    pub peak_rss_bytes: Option<u64>,
    /// The memory guard's estimate of the peak: the caller's estimate of its model and solver
    /// path plus [`SolveReport::factor_bytes`] (filled by the caller that made it).
    pub memory_estimate_bytes: Option<f64>,
    /// The bytes a sparse factorization held at its peak, from its symbolic analysis (checked
    /// against the available memory before it ran).
    pub factor_bytes: Option<f64>,
}

impl SolveReport {
    /// An empty report of `solver` for `n` unknowns and `nnz_a` stored entries.
    pub fn new(solver: SolverId, n: usize, nnz_a: usize) -> Self {
        SolveReport {
            solver,
            notes: Vec::new(),
            auto: None,
            preconditioner: None,
            n,
            nnz_a,
            nnz_factor: None,
            factor_flops: None,
            iterations: None,
            rel_residual: f64::NAN,
            timings: Timings::default(),
            peak_rss_bytes: None,
            memory_estimate_bytes: None,
            factor_bytes: None,
        }
    }
}

/// Peak resident set size of this process (`VmHWM` of `/proc/self/status`), if available.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
