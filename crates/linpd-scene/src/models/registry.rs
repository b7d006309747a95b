//! The registry of model types: the one place that maps `model.type` to the module that owns
//! it ([`ModelType`], [`super::model_type`]), and the scene's validation entry points
//! ([`Problem::from_json`] and the others), which resolve the type and let it validate.
//!
//! A key of `model` that the scene's type does not take is an error naming the key, the type
//! and the types that do take it; an unknown type is an error listing the registered ones.

use super::model_type::ModelType;
pub use super::model_type::{struct_fields, Context, Validated};
use super::{blend_1d, bond, coarsened, lps, SceneModel};
use crate::capability::Capability;
use crate::json::read_json_file;
use crate::nodes::{NodeSet, Nodes};
use crate::raw::{parse_raw, RawModelJson, RawProblem};
use crate::scene::Problem;
use crate::validate::{constraints_and_loads, output_dir, output_slice};
use crate::ProblemError;
use serde::de;
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// The model types a scene may name.
pub struct Registry {
    types: Vec<&'static dyn ModelType>,
}

/// linpd's model types, one line each: a new built-in type is its module and a line here.
static BUILTIN: &[&dyn ModelType] = &[&bond::BOND, &blend_1d::BLEND, &blend_1d::CE, &lps::LPS, &coarsened::COARSENED];

impl Default for Registry {
    /// linpd's model types.
    fn default() -> Self {
        Registry { types: BUILTIN.to_vec() }
    }
}

impl Registry {
    /// This registry and `t` (a model type defined outside linpd, e.g. in a test).
    pub fn with(mut self, t: &'static dyn ModelType) -> Self {
        self.types.push(t);
        self
    }

    /// The registered names, in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.types.iter().map(|t| t.name()).collect()
    }

    /// The type named `name`.
    pub fn get(&self, name: &str) -> Option<&'static dyn ModelType> {
        self.types.iter().copied().find(|t| t.name() == name)
    }

    /// The keys `t` takes besides `type`.
    fn keys(t: &dyn ModelType) -> impl Iterator<Item = &'static str> {
        t.fields().iter().copied().filter(|&k| k != "type")
    }

    /// The type of a `model` section, after checking that every key given is one it takes.
    pub(crate) fn resolve(&self, model: &RawModelJson) -> Result<&'static dyn ModelType, ProblemError> {
        let head: ModelHead = model.parse()?;
        let Some(t) = self.get(&head.kind) else {
            let expected: Vec<String> = self.names().iter().map(|n| format!("`{n}`")).collect();
            return Err(ProblemError::invalid(
                "model.type",
                format!("unknown variant `{}`, expected one of {}", head.kind, expected.join(", ")),
            ));
        };
        for key in head.keys.keys() {
            if key == "type" || Self::keys(t).any(|k| k == key) {
                continue;
            }
            let takers: Vec<&str> =
                self.types.iter().filter(|u| Self::keys(**u).any(|k| k == key)).map(|u| u.name()).collect();
            if takers.is_empty() {
                let expected: Vec<String> = Self::keys(t).map(|k| format!("`{k}`")).collect();
                return Err(ProblemError::invalid(
                    format!("model.{key}"),
                    format!("unknown field `{key}`, expected one of `type`, {}", expected.join(", ")),
                ));
            }
            let takers = match takers.as_slice() {
                [] => unreachable!("checked above"),
                [one] => format!("only {one} models take it"),
                [init @ .., last] => format!("only {} and {last} models take it", init.join(", ")),
            };
            return Err(ProblemError::invalid(
                format!("model.{key}"),
                format!("not a key of {} models ({takers}); remove it", t.name()),
            ));
        }
        Ok(t)
    }
}

/// The `type` of a `model` section and the keys given with it.
#[derive(Deserialize)]
struct ModelHead {
    #[serde(rename = "type")]
    kind: String,
    #[serde(flatten)]
    keys: std::collections::BTreeMap<String, de::IgnoredAny>,
}

impl Problem {
    /// Parses and validates scene text. Syntax and shape errors carry line, column and path.
    pub fn from_json(text: &str) -> Result<Self, ProblemError> {
        Self::from_raw(parse_raw(text)?)
    }

    /// Parses and validates scene text whose relative file names (a coarsened model's
    /// `moduli`) start at `base_dir`.
    pub fn from_json_in(text: &str, base_dir: &Path) -> Result<Self, ProblemError> {
        Self::from_raw_in(parse_raw(text)?, base_dir)
    }

    /// Reads and validates a scene file (relative file names in it start at its directory).
    pub fn from_path(path: &Path) -> Result<Self, ProblemError> {
        let text = read_json_file(path)?;
        Self::from_json_in(&text, path.parent().unwrap_or(Path::new("")))
    }

    /// Validates the serde mirror (relative file names start at the working directory).
    pub fn from_raw(raw: RawProblem) -> Result<Self, ProblemError> {
        Self::from_raw_in(raw, Path::new("."))
    }

    /// Validates the serde mirror; relative file names in it (a coarsened model's `moduli`)
    /// start at `base_dir`, the scene file's directory.
    pub fn from_raw_in(raw: RawProblem, base_dir: &Path) -> Result<Self, ProblemError> {
        Self::from_raw_with(raw, base_dir, &Registry::default())
    }

    /// Parses and validates scene text with the model types of `registry` (linpd's and, e.g.,
    /// a test's own); relative file names start at `base_dir`.
    pub fn from_json_with(text: &str, base_dir: &Path, registry: &Registry) -> Result<Self, ProblemError> {
        Self::from_raw_with(parse_raw(text)?, base_dir, registry)
    }

    /// [`Problem::from_raw_in`] with the model types of `registry`: the sections every scene
    /// has (name, dimension, solver, output, dynamics) here, the nodes, model, constraints and
    /// loads by the model type ([`crate::models::ModelType::validate`]); a scene that asks a
    /// model for what it lacks (`solver.matrix_free`, `dynamics`) is refused by name.
    pub fn from_raw_with(raw: RawProblem, base_dir: &Path, registry: &Registry) -> Result<Self, ProblemError> {
        Self::validate_part(raw, base_dir, registry, None)
    }

    /// Reads and validates rank `part.rank`'s part of a scene file for a distributed solve:
    /// the nodes are the rank's window of the lattice ([`crate::part`]); bond and LPS models
    /// on a grid only, others are refused by name. The checks a window cannot decide alone are
    /// in [`Problem::part`] for the caller to settle over the ranks.
    pub fn from_path_part(path: &Path, part: crate::part::Part) -> Result<Self, ProblemError> {
        if part.ranks == 0 || part.rank >= part.ranks {
            return Err(ProblemError::invalid("ranks", format!("rank {} of {} ranks", part.rank, part.ranks)));
        }
        let text = read_json_file(path)?;
        let raw = parse_raw(&text)?;
        Self::validate_part(raw, path.parent().unwrap_or(Path::new("")), &Registry::default(), Some(part))
    }

    fn validate_part(
        raw: RawProblem,
        base_dir: &Path,
        registry: &Registry,
        part: Option<crate::part::Part>,
    ) -> Result<Self, ProblemError> {
        let dim = raw.dimension;
        if !(1..=3).contains(&dim) {
            return Err(ProblemError::invalid("dimension", format!("must be 1, 2 or 3, got {dim}")));
        }
        if raw.name.trim().is_empty() {
            return Err(ProblemError::invalid("name", "must not be empty"));
        }
        let model_type = registry.resolve(&raw.model)?;
        let mut cx = Context::new(&raw, base_dir, part);
        let v = model_type.validate(&cx)?;
        let mut model = v.model;
        if raw.solver.matrix_free {
            model.require(Capability::MatrixFree)?;
        }
        if raw.dynamics.is_some() {
            model.require(Capability::Dynamics)?;
        }
        let (constraints, loads) = constraints_and_loads(&raw, dim, &v.nodes, base_dir, &cx.presences)?;
        let part = match (part, cx.slab.take()) {
            (None, _) => None,
            (Some(_), Some(slab)) => {
                let cloud = cx.cloud.take();
                let planes = match (&cloud, v.nodes.lattice()) {
                    (Some(c), _) => (0..v.nodes.len()).map(|n| c.bins.of_point(&v.nodes.position(n)) as u32).collect(),
                    (None, Some(grid)) => {
                        (0..grid.len()).map(|n| slab.plane(grid.lattice_index(n), dim) as u32).collect()
                    }
                    (None, None) => Vec::new(),
                };
                let presences = cx.presences.take();
                Some(crate::scene::PartScene { slab, planes, cloud, presences, resultant_volumes: None })
            }
            (Some(_), None) => {
                return Err(ProblemError::invalid(
                    "model.type",
                    format!("the {} model {}", raw.model.kind(), crate::validate::NO_PER_RANK_GEOMETRY),
                ))
            }
        };
        model.bind(&raw, &v.nodes, &constraints, &loads)?;
        let model: Arc<dyn SceneModel> = Arc::from(model);
        let solver = cx.take_solver()?;
        let dynamics = match &raw.dynamics {
            None => None,
            Some(d) => {
                let ratio = model.horizon().unwrap_or(f64::NAN) / v.nodes.spacing();
                Some(crate::dynamics::validate(d, dim, v.nodes.len(), ratio)?)
            }
        };
        // a part checks it against the whole lattice, not its window
        let slice = match (&v.nodes, cx.whole.take()) {
            (Nodes::Lattice(_), Some(whole)) => output_slice(&raw, &whole)?,
            (Nodes::Lattice(grid), None) => output_slice(&raw, grid)?,
            _ => None,
        };
        let lattice_output = raw.output.nodes == Some(crate::raw::RawOutputNodes::Lattice);
        if lattice_output && v.nodes.lattice().is_none() {
            return Err(ProblemError::invalid("output.nodes", "\"lattice\" needs a scene on a lattice (\"grid\")"));
        }
        if let Some(rho) = raw.density {
            if !(rho.is_finite() && rho > 0.0) {
                return Err(ProblemError::invalid("density", format!("must be > 0, got {rho:e}")));
            }
        }
        let deformed_scale = match raw.output.deformed_scale {
            Some(f) if !(f.is_finite() && f > 0.0) => {
                return Err(ProblemError::invalid("output.deformed_scale", format!("must be > 0, got {f:e}")))
            }
            f => f,
        };
        let mut problem = Problem {
            probes: crate::probe::validate(&raw.output.probes, dim)?,
            stress_map: crate::stress::StressMap::parse(raw.output.stress_map.as_deref(), dim)?,
            deformed_scale,
            density: raw.density,
            dynamics,
            output_dir: output_dir(raw.output.dir.as_deref(), &raw.name)?,
            plot: raw.output.plot.unwrap_or(true),
            slice,
            lattice_output,
            name: raw.name,
            nodes: v.nodes,
            model,
            constraints,
            loads,
            solver,
            part,
            plan: None,
        };
        problem.make_plan();
        Ok(problem)
    }
}
