//! `"type": "coarsened"` scenes: a coarsened level model read from a moduli file
//! ([`linpd_coarsen::io`]), with the same constraints, loads, solvers and outputs as the lattice
//! models.
//!
//! The level's nodes (positions `x_i`, volumes `v_i`) come from the nodes file beside the
//! Matrix Market file, so a coarsened scene has no `grid` and no `horizon`. The nodal stiffness
//! is [`ModuliFile::stiffness`]:
//!
//! ```text
//! K_ij = -v_i v_j C(x_i, x_j)   (i != j),      K_ii = -sum_{j != i} K_ij,
//! ```
//!
//! and equilibrium is `K u = f` with `f_i` the point forces plus `b v_i` for a body-force density
//! `b`. Constraints are eliminated as in [`crate::run`]: `u = u_bar + u_f`,
//! `K_ff u_f = f_f - (K u_bar)_f`. Before factorizing, the bonded-pair graph is checked for
//! rigid motions the constraints leave free ([`linpd_core::check_support`]), so a floating body
//! is reported by its nodes rather than as a zero pivot. `K` is symmetric when
//! `C(x, q) = C(q, x)^T`; then the solve is a sparse Cholesky (or the scene's solver), otherwise
//! a sparse LU, and the report's `solver` says why.

use crate::problem::{constraints_and_loads, solver_spec, NodeSet};
use crate::raw::{RawModelKind, RawProblem};
use crate::run::static_error;
use crate::{Constraint, Load, ProblemError, Solution};
use linpd_core::{AssembledModel, Model, Point, Region, GEOMETRY_RTOL};
use linpd_solve::{solve_model, Dirichlet, SolverSpec};
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use linpd_coarsen::io::{IoError, ModuliFile};

pub use linpd_core::sparse::SYMMETRY_RTOL;

/// A validated coarsened scene.
#[derive(Debug, Clone)]
pub struct CoarsenedScene {
    /// Name.
    pub name: String,
    /// Dimension (the moduli file's).
    pub dim: usize,
    /// Coarsening level of the file.
    pub level: usize,
    /// The moduli file (resolved against the scene's directory).
    pub moduli_path: PathBuf,
    /// Node positions (unused coordinates 0).
    pub positions: Vec<Point>,
    /// Node volumes.
    pub volumes: Vec<f64>,
    /// Index of each node in the level-0 model.
    pub level0: Vec<usize>,
    /// The level as a model: its nodal stiffness `K` (`dim * n` square, CSC).
    pub model: AssembledModel,
    /// Bonded pairs: nonzero off-diagonal blocks of `K` (each pair counted from both ends when
    /// both directions are stored).
    pub n_bonds: usize,
    /// `max |K - K^T| / max |K|`.
    pub asymmetry: f64,
    /// Volume constraints.
    pub constraints: Vec<Constraint>,
    /// Loads.
    pub loads: Vec<Load>,
    /// Solver.
    pub solver: SolverSpec,
    /// Output directory.
    pub output_dir: String,
    /// Write plots.
    pub plot: bool,
    /// Seconds spent reading the files and building `K`.
    pub build_seconds: f64,
}

/// The nodes of a level as a [`NodeSet`] (regions and point loads).
struct LevelNodes<'a> {
    dim: usize,
    positions: &'a [Point],
    /// `min_i v_i^(1/d)`: the smallest node spacing, the scale of the geometric tolerances.
    h: f64,
}

impl NodeSet for LevelNodes<'_> {
    fn what(&self) -> &'static str {
        "the coarsened level"
    }
    fn spacing(&self) -> f64 {
        self.h
    }
    fn position(&self, n: usize) -> Point {
        self.positions[n]
    }
    fn nearest(&self, x: &[f64]) -> (usize, f64) {
        let d = self.dim;
        self.positions
            .iter()
            .enumerate()
            .map(|(k, p)| (k, (0..d).map(|a| (p[a] - x[a]).powi(2)).sum::<f64>().sqrt()))
            .fold((0, f64::INFINITY), |best, c| if c.1 < best.1 { c } else { best })
    }
    fn select(&self, r: &Region) -> Vec<usize> {
        let tol = GEOMETRY_RTOL * self.h;
        (0..self.positions.len()).filter(|&n| r.contains(&self.positions[n], self.dim, tol)).collect()
    }
}

/// The nodes file a moduli file uses: the `% nodes` name when that file exists, else
/// `<stem>.nodes.csv` (for messages only; [`ModuliFile::read`] does the real lookup).
fn nodes_file(mtx: &Path) -> PathBuf {
    let s = mtx.as_os_str().to_string_lossy();
    let default = PathBuf::from(format!("{}.nodes.csv", s.strip_suffix(".mtx").unwrap_or(&s)));
    let named = std::fs::read_to_string(mtx).ok().and_then(|t| {
        t.lines().take_while(|l| l.starts_with('%') || l.trim().is_empty()).find_map(|l| {
            l.strip_prefix('%').map(str::trim).and_then(|c| c.strip_prefix("nodes ")).map(|n| n.trim().to_string())
        })
    });
    match named.map(|n| mtx.parent().unwrap_or(Path::new("")).join(n)) {
        Some(p) if p.is_file() || !default.is_file() => p,
        _ => default,
    }
}

pub use linpd_core::sparse::relative_asymmetry;

impl CoarsenedScene {
    /// Validates a parsed scene whose `model.type` is `coarsened`; relative moduli paths start
    /// at `base_dir` (the scene file's directory).
    pub fn from_raw(raw: RawProblem, base_dir: &Path) -> Result<Self, ProblemError> {
        let t0 = Instant::now();
        let dim = raw.dimension;
        if !(1..=3).contains(&dim) {
            return Err(ProblemError::invalid("dimension", format!("must be 1, 2 or 3, got {dim}")));
        }
        if raw.name.trim().is_empty() {
            return Err(ProblemError::invalid("name", "must not be empty"));
        }
        if raw.model.kind != RawModelKind::Coarsened {
            return Err(ProblemError::invalid(
                "model.type",
                format!("expected \"coarsened\", got \"{}\"", raw.model.kind.name()),
            ));
        }
        crate::problem::check_model_keys(&raw.model)?;
        let moduli = &raw.model.moduli;
        let moduli = moduli.as_ref().ok_or_else(|| {
            ProblemError::invalid(
                "model.moduli",
                "missing: the Matrix Market file of the coarsened moduli (e.g. \"out/level-1.mtx\")",
            )
        })?;
        let moduli_path = if Path::new(moduli).is_absolute() { PathBuf::from(moduli) } else { base_dir.join(moduli) };
        if raw.grid.is_some() {
            return Err(ProblemError::invalid(
                "grid",
                format!("not used by a coarsened model (its nodes come from {})", nodes_file(&moduli_path).display()),
            ));
        }
        if raw.dynamics.is_some() {
            return Err(ProblemError::invalid(
                "dynamics",
                "explicit dynamics is not available for coarsened models (bond models only)",
            ));
        }
        if raw.solver.matrix_free {
            return Err(ProblemError::invalid(
                "solver.matrix_free",
                "not available for coarsened models (K is read assembled)",
            ));
        }
        let file = ModuliFile::read(&moduli_path).map_err(|e| ProblemError::invalid("model.moduli", e.to_string()))?;
        if file.dim != dim {
            return Err(ProblemError::invalid(
                "dimension",
                format!(
                    "the scene has dimension {dim} but the moduli file {} holds a {}D model (% dim {})",
                    moduli_path.display(),
                    file.dim,
                    file.dim
                ),
            ));
        }
        let h = file.volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64)));
        let nodes = LevelNodes { dim, positions: &file.positions, h: if h.is_finite() { h } else { 1.0 } };
        if file.n_nodes() == 0 {
            return Err(ProblemError::invalid(
                "model.moduli",
                format!("{}: the level has no nodes", moduli_path.display()),
            ));
        }
        let (constraints, loads) = constraints_and_loads(&raw, dim, &nodes)?;
        let solver = solver_spec(&raw.solver)?;
        let model = AssembledModel::new("coarsened", dim, file.positions.clone(), file.stiffness())
            .with_labels("level-0 node", file.level0.clone());
        let asymmetry = model.asymmetry();
        let mut pairs: Vec<(usize, usize)> =
            file.entries.iter().filter(|e| e.2 != 0.0).map(|e| (e.0 / dim, e.1 / dim)).collect();
        pairs.sort_unstable();
        pairs.dedup();
        Ok(CoarsenedScene {
            output_dir: raw.output.dir.clone().unwrap_or_else(|| format!("out/{}", raw.name)),
            plot: raw.output.plot.unwrap_or(true),
            name: raw.name,
            dim,
            level: file.level,
            moduli_path,
            positions: file.positions,
            volumes: file.volumes,
            level0: file.level0,
            model,
            n_bonds: pairs.len(),
            asymmetry,
            constraints,
            loads,
            solver,
            build_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.volumes.len()
    }

    /// True when `K` is symmetric to [`SYMMETRY_RTOL`].
    pub fn is_symmetric(&self) -> bool {
        self.asymmetry <= SYMMETRY_RTOL
    }

    fn nodes(&self) -> LevelNodes<'_> {
        let h = self.volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / self.dim as f64)));
        LevelNodes { dim: self.dim, positions: &self.positions, h }
    }

    /// Constrained-DOF mask and the prescribed full displacement `u_bar`.
    pub fn constrained(&self) -> (Vec<bool>, Vec<f64>) {
        let d = self.dim;
        let nodes = self.nodes();
        let mut mask = vec![false; d * self.n_nodes()];
        let mut ubar = vec![0.0; d * self.n_nodes()];
        for c in &self.constraints {
            for node in nodes.select(&c.region) {
                let x = self.positions[node];
                for &a in &c.components {
                    mask[d * node + a] = true;
                    ubar[d * node + a] = c.displacement(&x[..d], a);
                }
            }
        }
        (mask, ubar)
    }

    /// External force per DOF: point forces plus body-force density times the node's volume.
    pub fn load_vector(&self) -> Vec<f64> {
        let d = self.dim;
        let nodes = self.nodes();
        let mut f = vec![0.0; d * self.n_nodes()];
        for l in &self.loads {
            match l {
                Load::Point { node, force } => (0..d).for_each(|a| f[d * node + a] += force[a]),
                Load::Body { region, density } => {
                    for node in nodes.select(region) {
                        (0..d).for_each(|a| f[d * node + a] += density[a] * self.volumes[node]);
                    }
                }
            }
        }
        f
    }

    /// Solves `K u = f` with the constraints eliminated ([`linpd_solve::solve_model`]: sparse
    /// LU when `K` is unsymmetric, whatever the scene asked). `progress` receives one line per
    /// phase.
    pub fn solve(&self, progress: &dyn Fn(&str)) -> Result<Solution, ProblemError> {
        let t0 = Instant::now();
        let (mask, ubar) = self.constrained();
        let bc = Dirichlet::new(self.dim, &mask, ubar);
        let solved =
            solve_model(&self.model, &bc, &self.load_vector(), &self.solver, progress).map_err(static_error)?;
        let mut report = solved.report;
        report.timings.assemble += self.build_seconds;
        progress(&format!(
            "done in {:.3} s, relative residual {:.2e}",
            t0.elapsed().as_secs_f64(),
            report.rel_residual
        ));
        Ok(Solution {
            name: self.name.clone(),
            dim: self.dim,
            x: self.positions.clone(),
            u: solved.u,
            is_layer: vec![false; self.n_nodes()],
            n_bonds: self.n_bonds,
            report,
        })
    }
}

/// A scene of any model: a lattice [`crate::Problem`] or a [`CoarsenedScene`].
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
pub enum Scene {
    /// Bond, lps, blend and ce models on a grid.
    Grid(crate::Problem),
    /// A coarsened level read from a moduli file.
    Coarsened(CoarsenedScene),
}

impl Scene {
    /// Parses and validates scene text; relative moduli paths start at `base_dir`.
    pub fn from_json(text: &str, base_dir: &Path) -> Result<Self, ProblemError> {
        let raw = crate::problem::parse_raw(text)?;
        if raw.model.kind == RawModelKind::Coarsened {
            CoarsenedScene::from_raw(raw, base_dir).map(Scene::Coarsened)
        } else {
            crate::Problem::from_raw(raw).map(Scene::Grid)
        }
    }

    /// Reads and validates a scene file (relative moduli paths start at its directory).
    pub fn from_path(path: &Path) -> Result<Self, ProblemError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| ProblemError::Io { path: path.display().to_string(), source })?;
        Self::from_json(&text, path.parent().unwrap_or(Path::new("")))
    }

    /// Scene name.
    pub fn name(&self) -> &str {
        match self {
            Scene::Grid(p) => &p.name,
            Scene::Coarsened(c) => &c.name,
        }
    }

    /// Output directory.
    pub fn output_dir(&self) -> &str {
        match self {
            Scene::Grid(p) => &p.output_dir,
            Scene::Coarsened(c) => &c.output_dir,
        }
    }

    /// Solves the static problem.
    pub fn solve(&self, progress: &dyn Fn(&str)) -> Result<Solution, ProblemError> {
        match self {
            Scene::Grid(p) => p.solve(progress),
            Scene::Coarsened(c) => c.solve(progress),
        }
    }
}
