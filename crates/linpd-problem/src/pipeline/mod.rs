//! `linpd coarsen PIPELINE.json`: Silling's multi-level coarsening of a scene's model
//! (bond-based or LPS), writing the coarsened moduli of every level with the level's transferred
//! boundary-value problem and effective moduli, and, optionally, solving that problem at every
//! level and comparing at the shared nodes.
//!
//! * [`bvp`]: level 0 is the scene (`linpd solve`'s constraints and nodal forces, bit for bit);
//!   loads reach level m by the step's transfer `F^m = S^T F^{m-1}`.
//! * `run`: the steps, the solves, the report ([`PipelineResult`]).
//! * `output`: the level files.
//! * `result`: the report's types.

use crate::models::Capability;
use crate::scene::Problem;
use crate::ProblemError;
use linpd_coarsen::{LevelModel, Radius};
use serde::Deserialize;
use std::path::{Path, PathBuf};

pub mod bvp;
mod output;
mod result;
mod run;

pub use bvp::LevelBvp;
pub use result::{LevelResult, PipelineResult};

/// The pipeline file (serde mirror; unknown keys are errors).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPipeline {
    /// Name used in outputs.
    pub name: String,
    /// The level-0 scene, relative to the pipeline file's directory.
    pub scene: String,
    /// One entry per coarsening step.
    pub levels: Vec<RawLevel>,
    /// Average `C_ij` and `C_ji^T` of every level before writing and using it (default true).
    #[serde(default)]
    pub symmetrize: Option<bool>,
    /// Share local solves between translated neighbourhoods (default true).
    #[serde(default)]
    pub cache: Option<bool>,
    /// Solve the scene's boundary-value problem at every level (default false).
    #[serde(default)]
    pub solve: bool,
    /// Output directory (default `out/<name>`).
    #[serde(default)]
    pub output: Option<RawPipelineOutput>,
}

/// `output`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPipelineOutput {
    /// Directory.
    pub dir: String,
}

/// `levels[m-1]`: how level m is made from level m-1.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLevel {
    /// Keep every k-th node per axis (exactly one of `every`, `nodes`).
    #[serde(default)]
    pub every: Option<usize>,
    /// Keep these level-(m-1) node indices.
    #[serde(default)]
    pub nodes: Option<Vec<usize>>,
    /// Fixed radius `r^m` (exactly one of `radius`, `tolerance`).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Radius rule: grow `r^m` until the tail is below this.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Radius rule: first radius (default 2 x the level's horizon).
    #[serde(default)]
    pub radius_start: Option<f64>,
    /// Radius rule: growth factor (default 1.25).
    #[serde(default)]
    pub radius_growth: Option<f64>,
    /// Radius rule: largest radius (default the body's diameter).
    #[serde(default)]
    pub radius_max: Option<f64>,
}

/// How a level is retained.
#[derive(Debug, Clone, PartialEq)]
pub enum Retain {
    /// Every k-th node per axis.
    Every(usize),
    /// Explicit level-(m-1) indices.
    Nodes(Vec<usize>),
}

/// One validated step.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelSpec {
    /// Retained set.
    pub retain: Retain,
    /// Radius choice.
    pub radius: Radius,
}

/// A validated pipeline.
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// Name.
    pub name: String,
    /// The level-0 scene.
    pub scene: Problem,
    /// Where the scene was read from.
    pub scene_path: PathBuf,
    /// Steps.
    pub levels: Vec<LevelSpec>,
    /// Symmetrize every level.
    pub symmetrize: bool,
    /// Neighbourhood cache.
    pub cache: bool,
    /// Solve the BVP per level.
    pub solve: bool,
    /// Output directory.
    pub output_dir: PathBuf,
}

pub(crate) fn inv(path: impl Into<String>, reason: impl Into<String>) -> ProblemError {
    ProblemError::invalid(path, reason)
}

impl Pipeline {
    /// Reads and validates a pipeline file (and its scene).
    pub fn from_path(path: &Path) -> Result<Self, ProblemError> {
        let text = crate::json::read_json_file(path)?;
        let raw: RawPipeline = crate::json::parse_json(&text)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::from_raw(raw, base)
    }

    /// Parses and validates pipeline text (e.g. a Python dict as JSON); relative paths in it
    /// (the scene) are resolved against `base`.
    pub fn from_json_in(text: &str, base: &Path) -> Result<Self, ProblemError> {
        let raw: RawPipeline = crate::json::parse_json(text)?;
        Self::from_raw(raw, base)
    }

    /// Validates the mirror; relative paths are resolved against `base`.
    pub fn from_raw(raw: RawPipeline, base: &Path) -> Result<Self, ProblemError> {
        if raw.name.trim().is_empty() {
            return Err(inv("name", "must not be empty"));
        }
        if raw.levels.is_empty() {
            return Err(inv("levels", "must list at least one coarsening step"));
        }
        let scene_path = base.join(&raw.scene);
        let scene =
            Problem::from_path(&scene_path).map_err(|e| inv("scene", format!("{}: {e}", scene_path.display())))?;
        // a model without level-0 stiffness is refused by name now, not after the first level
        scene
            .model()
            .require(Capability::Coarsen)
            .map_err(|e| inv("scene", format!("{}: {e}", scene_path.display())))?;
        let mut levels = Vec::new();
        for (i, l) in raw.levels.iter().enumerate() {
            let p = |k: &str| format!("levels[{i}].{k}");
            let retain = match (l.every, &l.nodes) {
                (Some(k), None) if k >= 2 => Retain::Every(k),
                (Some(k), None) => {
                    return Err(inv(p("every"), format!("must be >= 2 (every k-th node per axis), got {k}")))
                }
                (None, Some(n)) => Retain::Nodes(n.clone()),
                _ => {
                    return Err(inv(
                        format!("levels[{i}]"),
                        "give exactly one of `every` (every k-th node per axis) and `nodes` (level-(m-1) indices)",
                    ))
                }
            };
            let rule_keys = l.radius_start.is_some() || l.radius_growth.is_some() || l.radius_max.is_some();
            let radius = match (l.radius, l.tolerance) {
                (Some(r), None) => {
                    if rule_keys {
                        return Err(inv(format!("levels[{i}]"), "radius_start/radius_growth/radius_max belong to the radius rule (`tolerance`), not to a fixed `radius`"));
                    }
                    if !(r.is_finite() && r > 0.0) {
                        return Err(inv(p("radius"), format!("must be > 0, got {r:e}")));
                    }
                    Radius::Fixed(r)
                }
                (None, Some(tol)) => {
                    if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
                        return Err(inv(p("tolerance"), format!("must be in (0, 1), got {tol:e}")));
                    }
                    let growth = l.radius_growth.unwrap_or(1.25);
                    if !(growth.is_finite() && growth > 1.0) {
                        return Err(inv(p("radius_growth"), format!("must be > 1, got {growth:e}")));
                    }
                    for (k, v) in [("radius_start", l.radius_start), ("radius_max", l.radius_max)] {
                        if let Some(v) = v {
                            if !(v.is_finite() && v > 0.0) {
                                return Err(inv(p(k), format!("must be > 0, got {v:e}")));
                            }
                        }
                    }
                    if let (Some(start), Some(max)) = (l.radius_start, l.radius_max) {
                        if max < start {
                            return Err(inv(p("radius_max"), format!("{max:e} is below radius_start {start:e}")));
                        }
                    }
                    Radius::Auto { tol, start: l.radius_start, growth, max: l.radius_max }
                }
                _ => return Err(inv(
                    format!("levels[{i}]"),
                    "give exactly one of `radius` (fixed r^m) and `tolerance` (grow r^m until the tail is below it)",
                )),
            };
            levels.push(LevelSpec { retain, radius });
        }
        let output_dir =
            PathBuf::from(crate::validate::output_dir(raw.output.as_ref().map(|o| o.dir.as_str()), &raw.name)?);
        Ok(Self {
            name: raw.name,
            scene,
            scene_path,
            levels,
            symmetrize: raw.symmetrize.unwrap_or(true),
            cache: raw.cache.unwrap_or(true),
            solve: raw.solve,
            output_dir,
        })
    }
}

/// The level-0 model of a scene: the stiffness its model assembles over all DOFs
/// ([`crate::models::SceneModel::level0_stiffness`]: the bond operator, the LPS tangent), on
/// the scene's lattice. A model without [`Capability::Coarsen`] (the blended model of
/// `pd_regions`, point clouds, 1D blends, levels) is refused by name.
pub fn level0_model(p: &Problem) -> Result<LevelModel, ProblemError> {
    p.model().require(Capability::Coarsen)?;
    let k = p.model().level0_stiffness(p)?;
    let grid = p.lattice()?;
    let n = grid.len();
    LevelModel::from_stiffness(p.dim(), grid.positions(), (0..n).map(|i| grid.node_volume(i)).collect(), &k)
        .map_err(|e| inv("model", e.to_string()))
}
