//! `linpd coarsen PIPELINE.json`: Silling's multi-level coarsening of a scene's model
//! (bond-based or LPS), writing the coarsened moduli of every level and, optionally, solving the
//! scene's boundary-value problem at every level and comparing at the shared nodes.
//!
//! Boundary conditions in a pipeline act on the nodes of the coarsest level only (they exist at
//! every level), identically at every level, as in Silling's Examples 5.2 and 5.3: constrained
//! DOFs are the scene's constraints at those nodes; a body load gives each of them the nodal
//! force `density x v^M` (its volume at the coarsest level M), the same nodal force at every
//! level (the default force matching of `linpd_coarsen` conserves nodal forces, so every level
//! solves the same problem); a point load must sit on such a node. Loads on excluded nodes would
//! violate the assumption (5) of the coarsening step.
//!
//! One load convention for pipelines and scenes: a scene on a coarsened level gives a body load
//! `density x v^m` with the volumes of its own level, so the coarsest level's `level-M.mtx`
//! loaded back as a scene with the pipeline scene's constraints and loads solves exactly the
//! pipeline's problem (tests/coarsened_scene.rs). Why `v^M` and not `v^0` (used until 2026-11):
//! the coarsest nodes stand for `v^M` of the body, so the total force is `density` times the
//! loaded volume at every level, as a user loading a coarse model expects.

use crate::level_solve::solve_level;
use crate::models::Capability;
use crate::scene::Load;
use crate::scene::Problem;
use crate::ProblemError;
use linpd_coarsen::{check_retained, coarsen_with_progress, retain_every, LevelModel, Options, Radius, StepReport};
use linpd_core::progress::{Progress, Task};
use linpd_io::mtx::ModuliFile;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

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

fn inv(path: impl Into<String>, reason: impl Into<String>) -> ProblemError {
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

/// One level's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct LevelResult {
    /// Level number m (0 = the scene's model).
    pub level: usize,
    /// Nodes.
    pub nodes: usize,
    /// Bonds (pairs counted from both ends).
    pub bonds: usize,
    /// The coarsening step's report (absent for level 0).
    pub step: Option<StepReport>,
    /// Files written (names inside the output directory).
    pub files: Vec<String>,
    /// BVP: max |u^m - u^0| / max |u^0| at the shared nodes.
    pub error_shared: Option<f64>,
    /// BVP: solve seconds.
    pub solve_seconds: Option<f64>,
    /// BVP: the shared nodes' displacements (`d` per node, coarsest-level order).
    #[serde(skip)]
    pub u_shared: Vec<f64>,
}

/// The whole run.
#[derive(Debug, Clone, Serialize)]
pub struct PipelineResult {
    /// Name.
    pub name: String,
    /// Dimension.
    pub dimension: usize,
    /// Levels 0..=M.
    pub levels: Vec<LevelResult>,
    /// Positions of the shared nodes (the coarsest level's).
    pub shared_x: Vec<[f64; 3]>,
    /// Seconds for all coarsening steps.
    pub seconds_coarsening: f64,
}

impl Pipeline {
    /// Runs every step, writes the levels into `dir` ([`PipelineResult::write`]), and (if asked)
    /// solves and compares; `progress` receives one line per level and the tasks of the run (the
    /// levels, each level's local solves, the BVP solves). `summary.json`
    /// ([`PipelineResult::summary_json`]) is written by [`crate::OutputDir::commit`].
    pub fn run(&self, dir: &Path, progress: &dyn Progress) -> Result<PipelineResult, ProblemError> {
        let d = self.scene.dim();
        let t = Instant::now();
        let m0 = level0_model(&self.scene)?;
        progress.phase(&format!(
            "level 0: {} nodes, {} bonds, horizon {:.4e} ({:.2} s)",
            m0.len(),
            m0.n_bonds(),
            m0.horizon(),
            t.elapsed().as_secs_f64()
        ));
        let mut models = vec![m0];
        let mut results = vec![LevelResult {
            level: 0,
            nodes: models[0].len(),
            bonds: models[0].n_bonds(),
            step: None,
            files: Vec::new(),
            error_shared: None,
            solve_seconds: None,
            u_shared: Vec::new(),
        }];
        let t_all = Instant::now();
        let n_levels = self.levels.len();
        let levels_task = Task::start(progress, "coarsening levels", Some(n_levels as u64));
        for (i, spec) in self.levels.iter().enumerate() {
            let m = i + 1;
            levels_task.set(i as u64, &format!("level {m} of {n_levels}"));
            let fine = &models[i];
            let path = format!("levels[{i}]");
            let retained = match &spec.retain {
                Retain::Every(k) => retain_every(fine, *k).map_err(|e| inv(&path, e.to_string()))?,
                Retain::Nodes(n) => {
                    check_retained(n, fine.len()).map_err(|e| inv(format!("{path}.nodes"), e.to_string()))?
                }
            };
            if retained.len() == fine.len() {
                return Err(inv(&path, format!("retains all {} nodes of level {i}: nothing to coarsen", fine.len())));
            }
            let opts = Options { radius: spec.radius, cache: self.cache, ..Options::fixed(1.0) };
            let c = coarsen_with_progress(fine, &retained, &opts, progress)
                .map_err(|e| inv(&path, format!("level {m}: {e}")))?;
            let rep = c.report.clone();
            progress.phase(&format!(
                "level {m}: {} -> {} nodes, r = {:.4e} (horizon {:.4e}), tail {:.2e}, {} classes (hit rate {:.4}), asymmetry {:.1e}, {:.2} s",
                rep.n_fine, rep.n_coarse, rep.radius, rep.horizon_fine, rep.tail, rep.classes, rep.hit_rate, rep.asymmetry, rep.seconds_total
            ));
            let model = if self.symmetrize { c.model.symmetrized() } else { c.model };
            results.push(LevelResult {
                level: m,
                nodes: model.len(),
                bonds: model.n_bonds(),
                step: Some(rep),
                files: Vec::new(),
                error_shared: None,
                solve_seconds: None,
                u_shared: Vec::new(),
            });
            models.push(model);
        }
        levels_task.set(n_levels as u64, "");
        drop(levels_task);
        let seconds_coarsening = t_all.elapsed().as_secs_f64();
        let coarsest = &models[n_levels];
        let shared_x: Vec<[f64; 3]> = coarsest.positions().to_vec();
        if self.solve {
            let shared0: Vec<usize> = coarsest.level0().to_vec();
            let (fixed0, f0) = self.shared_bvp(coarsest)?;
            let bvp_task = Task::start(progress, "BVP solves", Some(models.len() as u64));
            for (lvl, model) in models.iter().enumerate() {
                bvp_task.set(lvl as u64, &format!("level {lvl} of {}", models.len() - 1));
                // level-0 index -> this level's index
                let mut at = std::collections::HashMap::new();
                for (k, &p) in model.level0().iter().enumerate() {
                    at.insert(p, k);
                }
                let fixed: Vec<(usize, f64)> = fixed0.iter().map(|&(p, a, g)| (d * at[&p] + a, g)).collect();
                let mut f = vec![0.0; d * model.len()];
                for &(p, a, val) in &f0 {
                    f[d * at[&p] + a] += val;
                }
                let t = Instant::now();
                let u = solve_level(model, &f, &fixed, progress)
                    .map_err(|source| ProblemError::Level { level: lvl, source })?;
                let secs = t.elapsed().as_secs_f64();
                let us: Vec<f64> =
                    shared0.iter().flat_map(|p| (0..d).map(move |a| (p, a))).map(|(p, a)| u[d * at[p] + a]).collect();
                results[lvl].solve_seconds = Some(secs);
                results[lvl].u_shared = us;
            }
            bvp_task.set(models.len() as u64, "");
            drop(bvp_task);
            let u0 = results[0].u_shared.clone();
            let umax = u0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for r in results.iter_mut() {
                let e = r.u_shared.iter().zip(&u0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                r.error_shared = Some(if umax > 0.0 { e / umax } else { e });
            }
            for r in &results {
                progress.phase(&format!(
                    "BVP level {}: {} nodes, solve {:.3} s, error at the {} shared nodes {:.3e}",
                    r.level,
                    r.nodes,
                    r.solve_seconds.unwrap_or(0.0),
                    shared0.len(),
                    r.error_shared.unwrap_or(0.0)
                ));
            }
        }
        // nothing is written before every level (and every solve) has succeeded
        std::fs::create_dir_all(dir).map_err(|source| ProblemError::Io { path: dir.display().to_string(), source })?;
        for (m, model) in models.iter().enumerate().skip(1) {
            results[m].files = write_level(model, m, dir)?;
        }
        let result =
            PipelineResult { name: self.name.clone(), dimension: d, levels: results, shared_x, seconds_coarsening };
        result.write(dir)?;
        Ok(result)
    }

    /// Constrained DOFs `(level-0 node, component, value)` and nodal forces `(level-0 node,
    /// component, f)` on the nodes of the `coarsest` level, which every level shares (see the
    /// module docs): a body load gives node `i` the force `density x v^M_i`, its volume at the
    /// coarsest level, as a scene on that level does.
    #[allow(clippy::type_complexity)]
    fn shared_bvp(
        &self,
        coarsest: &LevelModel,
    ) -> Result<(Vec<(usize, usize, f64)>, Vec<(usize, usize, f64)>), ProblemError> {
        let p = &self.scene;
        let d = p.dim();
        let (mask, ubar) = p.constrained();
        let grid = p.lattice()?;
        let shared0 = coarsest.level0();
        // level-0 node -> its volume at the coarsest level (NaN: not shared)
        let mut v_coarsest = vec![f64::NAN; grid.len()];
        shared0.iter().zip(coarsest.volumes()).for_each(|(&i, &v)| v_coarsest[i] = v);
        let is_shared = |i: usize| !v_coarsest[i].is_nan();
        let mut fixed = Vec::new();
        for &i in shared0 {
            for a in 0..d {
                if mask[d * i + a] {
                    fixed.push((i, a, ubar[d * i + a]));
                }
            }
        }
        if fixed.is_empty() {
            return Err(inv("constraints", "no constraint selects a node of the coarsest level; in a pipeline, constraints act on the nodes shared by every level"));
        }
        let mut f = Vec::new();
        for (li, l) in p.loads().iter().enumerate() {
            // a body load gives node i the force v_i density; a resultant is spread over the
            // coarsest nodes of its region by their coarsest volumes, as a scene on that level
            // spreads it
            let (region, vector, resultant) = match l {
                Load::Point { node, force } => {
                    if !is_shared(*node) {
                        let x = grid.position(*node);
                        return Err(inv(
                            format!("loads[{li}]"),
                            format!("the point load's node {node} (x = {:?}) is not kept at the coarsest level; in a pipeline, loads must sit on nodes shared by every level", &x[..d]),
                        ));
                    }
                    (0..d).for_each(|a| f.push((*node, a, force[a])));
                    continue;
                }
                Load::Body { region, density } => (region, density, false),
                Load::Resultant { region, force } => (region, force, true),
            };
            let nodes: Vec<usize> = region.nodes(grid).into_iter().filter(|&i| is_shared(i)).collect();
            if nodes.is_empty() {
                return Err(inv(format!("loads[{li}]"), "the load's region contains no node of the coarsest level"));
            }
            let per_volume = if resultant { 1.0 / nodes.iter().map(|&i| v_coarsest[i]).sum::<f64>() } else { 1.0 };
            for i in nodes {
                (0..d).for_each(|a| f.push((i, a, vector[a] * v_coarsest[i] * per_volume)));
            }
        }
        Ok((fixed, f))
    }
}

/// Writes `level-<m>.mtx` and `level-<m>.nodes.csv`; returns their names.
fn write_level(model: &LevelModel, m: usize, dir: &Path) -> Result<Vec<String>, ProblemError> {
    let d = model.dim();
    let (offsets, cols, c) = model.csr();
    let mut entries = Vec::with_capacity(c.len());
    for i in 0..model.len() {
        for k in offsets[i]..offsets[i + 1] {
            let j = cols[k];
            for a in 0..d {
                for b in 0..d {
                    let v = c[k * d * d + a * d + b];
                    if v != 0.0 {
                        entries.push((d * i + a, d * j + b, v));
                    }
                }
            }
        }
    }
    let file = ModuliFile {
        level: m,
        dim: d,
        positions: model.positions().to_vec(),
        volumes: model.volumes().to_vec(),
        level0: model.level0().to_vec(),
        entries,
    };
    let stem = dir.join(format!("level-{m}"));
    let files = file.write(&stem).map_err(|e| inv("output", e.to_string()))?;
    Ok(files.iter().filter_map(|f| f.file_name()).map(|n| n.to_string_lossy().into_owned()).collect())
}

impl PipelineResult {
    /// The `summary.json` document: all levels.
    pub fn summary_json(&self) -> serde_json::Value {
        json!(self)
    }

    /// Writes `level-<m>.json` (one per coarsened level), plus `shared.csv` with the BVP
    /// displacements at the shared nodes per level when solved.
    pub fn write(&self, dir: &Path) -> Result<(), ProblemError> {
        let io = |p: &Path| {
            let p = p.display().to_string();
            move |source| ProblemError::Io { path: p, source }
        };
        for l in self.levels.iter().filter(|l| l.level > 0) {
            let path = dir.join(format!("level-{}.json", l.level));
            let text = serde_json::to_string_pretty(l).map_err(|e| io(&path)(std::io::Error::other(e)))?;
            std::fs::write(&path, text).map_err(io(&path))?;
        }
        if self.levels[0].solve_seconds.is_some() {
            let d = self.dimension;
            let mut s = String::new();
            let names = ["x", "y", "z"];
            let mut header: Vec<String> = names[..d].iter().map(|t| t.to_string()).collect();
            for l in &self.levels {
                for a in 0..d {
                    header.push(format!("u{}_level{}", ["x", "y", "z"][a], l.level));
                }
            }
            s.push_str(&header.join(","));
            s.push('\n');
            for (k, x) in self.shared_x.iter().enumerate() {
                let mut row: Vec<String> = x[..d].iter().map(|t| format!("{t:.17e}")).collect();
                for l in &self.levels {
                    for a in 0..d {
                        row.push(format!("{:.17e}", l.u_shared[d * k + a]));
                    }
                }
                s.push_str(&row.join(","));
                s.push('\n');
            }
            let path = dir.join("shared.csv");
            std::fs::write(&path, s).map_err(io(&path))?;
        }
        Ok(())
    }
}
