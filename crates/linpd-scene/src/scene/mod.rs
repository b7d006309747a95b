//! The validated scene and the interface of its model: [`Problem`] (nodes, model, constraints,
//! loads, solver, outputs), [`SceneModel`] (what every model of [`crate::models`] implements),
//! and the static solve they share ([`solve_system`]). The scene's type and its model's refer to
//! each other (a problem holds a model; a model builds from a problem), so they share this
//! module; everything else builds on it.

mod model;
mod problem;
mod solve;

pub use model::{
    foreign_system, refusal, solve_system, Built, DynamicsOperator, NodeElastic, Purpose, SceneModel, System,
};
pub(crate) use problem::BalanceNodes;
pub use problem::{Constraint, Load, PartBalance, PartScene, Problem};
