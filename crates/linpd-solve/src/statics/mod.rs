//! The one static solve of linpd: a [`Model`], prescribed displacements ([`Dirichlet`]) and
//! nodal forces in, displacements and a [`SolveReport`] out. Scenes of every model type,
//! coarsening pipelines, the studies and the tension bar all come through here.
//!
//! 1. every DOF constrained, or a rigid motion left free ([`linpd_core::check_support`] on the
//!    model's own interaction graph): a typed error before any factorization;
//! 2. `A_ff u_f = f_f - (A u_bar)_f` ([`crate::bc`]);
//! 3. assembled ([`Model::assemble_free`]) and solved by [`solve_assembled`], or matrix-free
//!    CG on the [`ReducedOperator`] of the model's fastest apply;
//! 4. `u = u_bar + u_f`, checked finite.
//!
//! By concern, each layer using only the ones below it:
//!
//! * `model`: the orchestration, [`solve_model`] (and [`reduced_system`],
//!   [`reduced_rhs_checked`] for callers that solve the reduced system themselves);
//! * `dispatch`: a model's reduced system to the matrix-free runner or to the assembled
//!   dispatch, with the hints the model provides;
//! * `assembled`: [`solve_assembled`], the solver dispatch on an assembled matrix by
//!   [`SolverSpec`], and the running of `auto`'s plans with their fallbacks;
//! * [`auto`]: `auto` as a pure plan from sizes, capabilities and cost estimates, with its
//!   thresholds in [`AutoParams`];
//! * `runners`: one function per solver (sparse and dense Cholesky and LU, PCG and GMRES on
//!   the assembled matrix, GMRES with the factor of an SPD approximation, matrix-free PCG);
//! * `guards`: the support and finiteness checks, the memory check of a factor, the residual
//!   check of a direct solve ([`DIRECT_RESIDUAL_LIMIT`]);
//! * `error`: [`StaticError`].
//!
//! [`Dirichlet`]: crate::bc::Dirichlet
//! [`ReducedOperator`]: crate::bc::ReducedOperator
//! [`SolveReport`]: crate::report::SolveReport
//! [`SolverSpec`]: crate::spec::SolverSpec
//! [`Model`]: linpd_core::Model
//! [`Model::assemble_free`]: linpd_core::Model::assemble_free

mod assembled;
pub mod auto;
mod dispatch;
mod error;
mod guards;
mod model;
mod runners;

pub use crate::direct::DIRECT_RESIDUAL_LIMIT;
pub use assembled::{solve_assembled, solve_assembled_with_auto, solve_assembled_with_progress, MatrixHints};
pub use auto::AutoParams;
pub use error::StaticError;
pub use guards::{finite_matrix, finite_vector};
pub use model::{reduced_rhs_checked, reduced_rhs_of_rows, reduced_system, solve_model, solve_planned, StaticSolution};
