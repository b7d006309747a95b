//! The validated scene: [`Problem::from_json`] turns text into typed, checked objects.

use crate::models::registry::Context;
use crate::models::{Capability, Registry, SceneModel};
use crate::raw::*;
use crate::ProblemError;
use linpd_core::{
    BondRule, CoreError, Defect, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel, Point,
    Region,
};
use linpd_solve::{CgParams, PreconditionerKind, SolverSpec};
use std::path::Path;
use std::sync::Arc;

/// An affine displacement `u = value + gradient x` on some components of a node set.
#[derive(Debug, Clone, PartialEq)]
pub struct Constraint {
    /// Where.
    pub(crate) region: Region,
    /// Constant part.
    pub(crate) value: Vec<f64>,
    /// Gradient `H` (row-major `dim x dim`).
    pub(crate) gradient: Vec<f64>,
    /// Constrained components.
    pub(crate) components: Vec<usize>,
}

impl Constraint {
    /// Where.
    pub fn region(&self) -> &Region {
        &self.region
    }
    /// Constant part.
    pub fn value(&self) -> &[f64] {
        &self.value
    }
    /// Gradient `H` (row-major `dim x dim`).
    pub fn gradient(&self) -> &[f64] {
        &self.gradient
    }
    /// Constrained components.
    pub fn components(&self) -> &[usize] {
        &self.components
    }
}

impl Constraint {
    /// Prescribed value of component `a` at `x`.
    pub fn displacement(&self, x: &[f64], a: usize) -> f64 {
        let d = self.value.len();
        self.value[a] + (0..d).map(|b| self.gradient[a * d + b] * x[b]).sum::<f64>()
    }
}

/// A load.
#[derive(Debug, Clone, PartialEq)]
pub enum Load {
    /// Force on one node.
    Point {
        /// The node.
        node: usize,
        /// The force.
        force: Vec<f64>,
    },
    /// Body-force density on a region.
    Body {
        /// Where.
        region: Region,
        /// Force per unit volume.
        density: Vec<f64>,
    },
    /// A total force spread over a region's nodes in proportion to their volumes,
    /// `f_i = F v_i / sum_{j in R} v_j`: the applied total is `F` whatever the spacing.
    Resultant {
        /// Where.
        region: Region,
        /// The total force `F`.
        force: Vec<f64>,
    },
}

/// A validated scene. Its fields are private: every value in it has passed validation, and
/// only the solver may be changed afterwards ([`Problem::set_solver`]).
#[derive(Debug, Clone)]
pub struct Problem {
    /// Name.
    pub(crate) name: String,
    /// The nodes: a lattice, or a coarsened level's nodes.
    pub(crate) nodes: Nodes,
    /// The model ([`crate::models`]).
    pub(crate) model: Arc<dyn SceneModel>,
    /// Volume constraints.
    pub(crate) constraints: Vec<Constraint>,
    /// Loads.
    pub(crate) loads: Vec<Load>,
    /// Solver.
    pub(crate) solver: SolverSpec,
    /// Output directory.
    pub(crate) output_dir: String,
    /// Write plots.
    pub(crate) plot: bool,
    /// 3D maps: the plane `x[axis] = value` (`output.slice`), `None` for the middle z plane.
    pub(crate) slice: Option<(usize, f64)>,
    /// The `dynamics` section (explicit time stepping with `linpd run`), if any.
    pub(crate) dynamics: Option<crate::dynamics::Dynamics>,
}

pub(crate) fn core(path: &str, e: CoreError) -> ProblemError {
    match e {
        CoreError::Parameter { name, reason } => ProblemError::invalid(format!("{path}.{name}"), reason),
        other => ProblemError::invalid(path, other.to_string()),
    }
}

pub(crate) fn check_len(path: &str, v: &[f64], dim: usize) -> Result<(), ProblemError> {
    if v.len() != dim {
        return Err(ProblemError::invalid(
            path,
            format!("expected {dim} components (the scene's dimension), got {}", v.len()),
        ));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(ProblemError::invalid(path, "values must be finite"));
    }
    Ok(())
}

pub(crate) fn region(path: &str, r: &RawRegion, dim: usize) -> Result<Region, ProblemError> {
    let out = match r {
        RawRegion::All => Region::All,
        RawRegion::Box { min, max } => {
            check_len(&format!("{path}.box.min"), min, dim)?;
            check_len(&format!("{path}.box.max"), max, dim)?;
            if let Some(a) = (0..dim).find(|&a| min[a] > max[a]) {
                return Err(ProblemError::invalid(
                    format!("{path}.box"),
                    format!("min[{a}] = {:e} is greater than max[{a}] = {:e}", min[a], max[a]),
                ));
            }
            Region::Box { min: min.clone(), max: max.clone() }
        }
        RawRegion::Ball { center, radius } => {
            check_len(&format!("{path}.ball.center"), center, dim)?;
            Region::Ball { center: center.clone(), radius: *radius }
        }
        RawRegion::Cylinder { center, axis, radius, length } => {
            Region::Cylinder { center: center.clone(), axis: axis.clone(), radius: *radius, length: *length }
        }
        RawRegion::HalfSpace { point, normal } => {
            check_len(&format!("{path}.half_space.point"), point, dim)?;
            check_len(&format!("{path}.half_space.normal"), normal, dim)?;
            Region::HalfSpace { point: point.clone(), normal: normal.clone() }
        }
        RawRegion::Polygon { vertices, extrude } => Region::Polygon { vertices: vertices.clone(), extrude: *extrude },
        RawRegion::Union(parts) => Region::Union(
            parts
                .iter()
                .enumerate()
                .map(|(k, p)| region(&format!("{path}.union[{k}]"), p, dim))
                .collect::<Result<_, _>>()?,
        ),
        RawRegion::Difference(a, b) => Region::Difference(
            Box::new(region(&format!("{path}.difference[0]"), a, dim)?),
            Box::new(region(&format!("{path}.difference[1]"), b, dim)?),
        ),
    };
    if out.is_leaf() {
        // the shape's own checks (radius > 0, 3D-only shapes, polygon vertices), named by the
        // shape's key under `path` (`body.ball.radius: must be > 0, got 0e0`)
        out.validate(dim).map_err(|e| core(path, e))?;
    }
    Ok(out)
}

/// Parses scene text into the serde mirror; syntax and shape errors carry line, column and path.
/// Largest scene or pipeline file read: 16 MiB. A scene is a few hundred bytes of keys (node
/// data lives in the files it names), so anything larger is a wrong file, and the limit keeps
/// `linpd validate /dev/urandom` from reading forever.
pub const MAX_JSON_BYTES: u64 = 16 << 20;

/// Reads a scene or pipeline file: a regular file (not a device, FIFO or directory) of at most
/// [`MAX_JSON_BYTES`], in UTF-8.
pub(crate) fn read_json_file(path: &Path) -> Result<String, ProblemError> {
    use std::io::Read;
    let err = |source| ProblemError::Io { path: path.display().to_string(), source };
    let other = |m: String| err(std::io::Error::new(std::io::ErrorKind::InvalidInput, m));
    let meta = std::fs::metadata(path).map_err(err)?;
    if !meta.is_file() {
        return Err(other("not a regular file (a scene or pipeline is a JSON file)".into()));
    }
    if meta.len() > MAX_JSON_BYTES {
        return Err(other(format!(
            "{} bytes, more than a scene or pipeline file may hold ({MAX_JSON_BYTES})",
            meta.len()
        )));
    }
    // `take`: a file that grows while it is read still stops at the limit
    let mut bytes = Vec::new();
    std::fs::File::open(path).and_then(|f| f.take(MAX_JSON_BYTES + 1).read_to_end(&mut bytes)).map_err(err)?;
    if bytes.len() as u64 > MAX_JSON_BYTES {
        return Err(other(format!("more than {MAX_JSON_BYTES} bytes, more than a scene or pipeline file may hold")));
    }
    String::from_utf8(bytes).map_err(|e| {
        other(format!(
            "not UTF-8 text (invalid byte at offset {}): a scene or pipeline is a JSON file",
            e.utf8_error().valid_up_to()
        ))
    })
}

pub(crate) fn parse_raw(text: &str) -> Result<RawProblem, ProblemError> {
    if is_pipeline(text) {
        return Err(ProblemError::invalid(
            ".",
            "this is a coarsening pipeline (it has \"scene\" and \"levels\"), not a scene: run it with `linpd coarsen FILE`",
        ));
    }
    let mut raw: RawProblem = parse_json(text)?;
    raw.model.locate(text);
    Ok(raw)
}

/// Parses one JSON document (scene or pipeline) into `T`; syntax and shape errors carry line,
/// column and path, and text after the document is an error (not silently ignored).
pub(crate) fn parse_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, ProblemError> {
    parse_json_at(text, "", (1, 1))
}

/// [`parse_json`] of a section of a document: `text` starts at line and column `at` of the
/// document, under the JSON path `prefix` (`model`), and errors say so.
pub(crate) fn parse_json_at<T: serde::de::DeserializeOwned>(
    text: &str,
    prefix: &str,
    at: (usize, usize),
) -> Result<T, ProblemError> {
    // a position in `text` as a position in the document
    let place = |line: usize, column: usize| (at.0 + line - 1, if line == 1 { at.1 + column - 1 } else { column });
    let under = |path: String| match (prefix, path.as_str()) {
        ("", _) => path,
        (p, ".") => p.to_string(),
        (p, _) => format!("{p}.{path}"),
    };
    let de = &mut serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let (line, column) = place(inner.line(), inner.column());
        ProblemError::Parse {
            path: under(known_path(&path)),
            message: strip_position(&inner.to_string()),
            line,
            column,
        }
    })?;
    de.end().map_err(|e| {
        let (line, column) = place(e.line(), e.column());
        ProblemError::Parse {
            path: under(".".into()),
            message: "trailing text after the JSON document".into(),
            line,
            column,
        }
    })?;
    Ok(value)
}

/// The output directory: `output.dir` as given, else `out/<name>`. The name must then be a
/// plain directory name: a name like `../../x` must not write outside `out/`.
pub(crate) fn output_dir(dir: Option<&str>, name: &str) -> Result<String, ProblemError> {
    match dir {
        Some(d) if d.trim().is_empty() => {
            Err(ProblemError::invalid("output.dir", "must not be empty (omit `output.dir` for out/<name>)"))
        }
        Some(d) if d.contains('\0') => Err(ProblemError::invalid("output.dir", "must not contain a NUL character")),
        Some(d) => Ok(d.to_string()),
        None if name.contains(['/', '\\', '\0']) || name == "." || name == ".." => Err(ProblemError::invalid(
            "name",
            format!(
                "{name:?} cannot name the default output directory out/<name> (no '/', '\\', NUL, `.` or `..`): \
                 rename the scene or set `output.dir`"
            ),
        )),
        None => Ok(format!("out/{name}")),
    }
}

/// The lattice of a scene with a `grid` (and optionally a `body`), checked against the
/// horizon and the memory of `path` before anything per node is allocated.
pub(crate) fn lattice(cx: &Context, horizon: f64, path: crate::memory::Path) -> Result<Grid, ProblemError> {
    let (raw, dim) = (cx.raw, cx.dim());
    let Some(raw_grid) = &raw.grid else {
        return Err(ProblemError::invalid("grid", format!("required for model type {}", raw.model.kind())));
    };
    check_len("grid.min", &raw_grid.min, dim)?;
    check_len("grid.max", &raw_grid.max, dim)?;
    let placement = match raw_grid.placement {
        RawPlacement::Vertex => Placement::Vertex,
        RawPlacement::Cell => Placement::Cell,
    };
    let layers = raw_grid.layers(dim).map_err(|(path, reason)| ProblemError::invalid(path, reason))?;
    let grid = Grid::with_layers(&raw_grid.min, &raw_grid.max, raw_grid.spacing, layers, placement)
        .map_err(|e| core("grid", e))?;
    // the body is applied after the memory check below: its site tables cost 5 bytes per
    // lattice site, and the check on the full box is an upper bound for the body
    let body = raw.body.as_ref().map(|b| region("body", b, dim)).transpose()?;
    check_horizon(horizon, grid.spacing(), dim)?;
    // Refuse scenes that cannot fit before anything per node is allocated (the regions below
    // already walk every node).
    crate::memory::check(path, &grid, horizon)?;
    let cut = raw.boundary_volumes == Some(crate::raw::RawBoundaryVolumes::Cut);
    Ok(match &body {
        None if cut => {
            return Err(ProblemError::invalid("boundary_volumes", "\"cut\" needs a \"body\" whose boundary cuts cells"))
        }
        None => grid,
        Some(body) => {
            let tol = linpd_core::GEOMETRY_RTOL * grid.spacing();
            let inside = |x: &Point| body.contains(x, dim, tol);
            let kept = grid.with_body(inside).map_err(|e| core("body", e))?;
            if cut {
                kept.with_cut_volumes(inside)
            } else {
                kept
            }
        }
    })
}

/// A horizon of at least one lattice spacing (`sqrt 2` in 2D and 3D: shorter bonds only along
/// the axes leave zero-energy shear modes).
fn check_horizon(horizon: f64, spacing: f64, dim: usize) -> Result<(), ProblemError> {
    if !(horizon.is_finite() && horizon > 0.0) {
        return Err(ProblemError::invalid("model.horizon", format!("must be > 0, got {horizon:e}")));
    }
    let ratio = horizon / spacing;
    if ratio < 1.0 - linpd_core::GEOMETRY_RTOL {
        return Err(ProblemError::invalid(
            "model.horizon",
            format!("horizon/spacing = {ratio:e} gives no bonds (the horizon must be at least one spacing)"),
        ));
    }
    if dim > 1 && ratio < std::f64::consts::SQRT_2 * (1.0 - linpd_core::GEOMETRY_RTOL) {
        return Err(ProblemError::invalid(
            "model.horizon",
            format!("horizon/spacing = {ratio:e} bonds only along the axes, which leaves zero-energy shear modes; use horizon >= sqrt(2) * spacing"),
        ));
    }
    Ok(())
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
        let dim = raw.dimension;
        if !(1..=3).contains(&dim) {
            return Err(ProblemError::invalid("dimension", format!("must be 1, 2 or 3, got {dim}")));
        }
        if raw.name.trim().is_empty() {
            return Err(ProblemError::invalid("name", "must not be empty"));
        }
        let model_type = registry.resolve(&raw.model)?;
        let v = model_type.validate(&Context { raw: &raw, base_dir })?;
        let mut model = v.model;
        if raw.solver.matrix_free {
            model.require(Capability::MatrixFree)?;
        }
        if raw.dynamics.is_some() {
            model.require(Capability::Dynamics)?;
        }
        let (constraints, loads) = constraints_and_loads(&raw, dim, &v.nodes)?;
        model.bind(&raw, &v.nodes, &constraints, &loads)?;
        let model: Arc<dyn SceneModel> = Arc::from(model);
        let solver = solver_spec(&raw.solver)?;
        let dynamics = match &raw.dynamics {
            None => None,
            Some(d) => {
                let ratio = model.horizon().unwrap_or(f64::NAN) / v.nodes.spacing();
                Some(crate::dynamics::validate(d, dim, v.nodes.len(), ratio)?)
            }
        };
        let slice = match &v.nodes {
            Nodes::Lattice(grid) => output_slice(&raw, grid)?,
            _ => None,
        };
        Ok(Problem {
            dynamics,
            output_dir: output_dir(raw.output.dir.as_deref(), &raw.name)?,
            plot: raw.output.plot.unwrap_or(true),
            slice,
            name: raw.name,
            nodes: v.nodes,
            model,
            constraints,
            loads,
            solver,
        })
    }

    /// Spatial dimension.
    pub fn dim(&self) -> usize {
        self.nodes.dim()
    }
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The lattice (`None` for a coarsened level).
    pub fn grid(&self) -> Option<&Grid> {
        self.nodes.lattice()
    }
    /// The nodes.
    pub fn nodes(&self) -> &Nodes {
        &self.nodes
    }
    /// The lattice, or an error for models without one.
    pub(crate) fn lattice(&self) -> Result<&Grid, ProblemError> {
        self.nodes.lattice().ok_or_else(|| {
            ProblemError::invalid("model.type", format!("{} models have no lattice here", self.model.describe()))
        })
    }
    /// The model.
    pub fn model(&self) -> &dyn SceneModel {
        self.model.as_ref()
    }
    /// Volume constraints.
    pub fn constraints(&self) -> &[Constraint] {
        &self.constraints
    }
    /// Loads.
    pub fn loads(&self) -> &[Load] {
        &self.loads
    }
    /// The solver.
    pub fn solver(&self) -> &SolverSpec {
        &self.solver
    }
    /// Replaces the solver (every [`SolverSpec`] is valid for every model: one a model cannot
    /// run, e.g. matrix-free LPS, fails at solve time with a typed error).
    pub fn set_solver(&mut self, solver: SolverSpec) {
        self.solver = solver;
    }
    /// Output directory (`output.dir`, else `out/<name>`).
    pub fn output_dir(&self) -> &str {
        &self.output_dir
    }
    /// Whether to write plots.
    pub fn plot(&self) -> bool {
        self.plot
    }
    /// 3D maps: `(axis, value)` of the plane to show (`output.slice`), `None` for the middle
    /// z plane.
    pub fn slice(&self) -> Option<(usize, f64)> {
        self.slice
    }
    /// The `dynamics` section, if any.
    pub fn dynamics(&self) -> Option<&crate::dynamics::Dynamics> {
        self.dynamics.as_ref()
    }
}

/// The nodes of a scene.
#[derive(Debug, Clone)]
pub enum Nodes {
    /// A lattice (bond, lps, blend and ce models).
    Lattice(Grid),
    /// The nodes of a coarsened level (positions and volumes from its nodes file).
    Level(LevelNodes),
    /// A point cloud read from a file ([`crate::cloud`]).
    Cloud(LevelNodes),
}

/// The nodes of a coarsened level.
#[derive(Debug, Clone)]
pub struct LevelNodes {
    pub(crate) dim: usize,
    pub(crate) positions: Vec<Point>,
    pub(crate) volumes: Vec<f64>,
    /// The scale of the geometric tolerances: `min_i v_i^(1/d)`, the smallest node spacing,
    /// capped by the nodes' extent (see [`LevelNodes::new`]).
    pub(crate) h: f64,
    /// Layer flags of a point cloud (empty for a level: no layer).
    pub(crate) layer: Vec<bool>,
    /// Phase numbers of a point cloud (empty without a `phase` column).
    pub(crate) phase: Vec<u32>,
    /// What the nodes are, for messages.
    pub(crate) what: &'static str,
}

impl LevelNodes {
    /// Nodes at `positions` with `volumes` in dimension `dim`.
    ///
    /// The tolerance scale `min_i v_i^(1/d)` is capped by the largest side of the nodes'
    /// bounding box: volumes are read from a file and need not match the positions, and
    /// volumes of 1e300 would otherwise give a region tolerance (`1e-9 h`) that swallows every
    /// node ("every DOF is constrained") instead of the overflow they cause.
    pub fn new(dim: usize, positions: Vec<Point>, volumes: Vec<f64>) -> Self {
        let h = volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64)));
        let extent = (0..dim)
            .map(|a| {
                let (lo, hi) = positions
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x[a]), hi.max(x[a])));
                hi - lo
            })
            .fold(0.0f64, f64::max);
        let h = if extent.is_finite() && extent > 0.0 { h.min(extent) } else { h };
        LevelNodes {
            dim,
            positions,
            volumes,
            h: if h.is_finite() { h } else { 1.0 },
            layer: Vec::new(),
            phase: Vec::new(),
            what: "the coarsened level",
        }
    }
}

impl Nodes {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        match self {
            Nodes::Lattice(g) => g.len(),
            Nodes::Level(l) | Nodes::Cloud(l) => l.positions.len(),
        }
    }
    /// True when there is no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Spatial dimension.
    pub fn dim(&self) -> usize {
        match self {
            Nodes::Lattice(g) => g.dim(),
            Nodes::Level(l) | Nodes::Cloud(l) => l.dim,
        }
    }
    /// Position of node `n` (unused coordinates 0).
    pub fn position(&self, n: usize) -> Point {
        match self {
            Nodes::Lattice(g) => g.position(n),
            Nodes::Level(l) | Nodes::Cloud(l) => l.positions[n],
        }
    }
    /// All positions.
    pub fn positions(&self) -> Vec<Point> {
        (0..self.len()).map(|n| self.position(n)).collect()
    }
    /// Volume of node `n`.
    pub fn volume(&self, n: usize) -> f64 {
        match self {
            Nodes::Lattice(g) => g.node_volume(n),
            Nodes::Level(l) | Nodes::Cloud(l) => l.volumes[n],
        }
    }
    /// True for nodes of the lattice's outer layer or a cloud's `layer` column (never for a
    /// level's nodes).
    pub fn is_layer(&self, n: usize) -> bool {
        match self {
            Nodes::Lattice(g) => g.is_layer(n),
            Nodes::Level(l) | Nodes::Cloud(l) => l.layer.get(n).copied().unwrap_or(false),
        }
    }
    /// The point cloud, if the nodes are one.
    pub fn cloud(&self) -> Option<&LevelNodes> {
        match self {
            Nodes::Cloud(c) => Some(c),
            _ => None,
        }
    }
    /// The lattice, if the nodes are one.
    pub fn lattice(&self) -> Option<&Grid> {
        match self {
            Nodes::Lattice(g) => Some(g),
            Nodes::Level(_) | Nodes::Cloud(_) => None,
        }
    }
}

impl NodeSet for Nodes {
    fn what(&self) -> &'static str {
        match self {
            Nodes::Lattice(g) => g.what(),
            Nodes::Level(l) | Nodes::Cloud(l) => l.what(),
        }
    }
    fn spacing(&self) -> f64 {
        match self {
            Nodes::Lattice(g) => NodeSet::spacing(g),
            Nodes::Level(l) | Nodes::Cloud(l) => l.spacing(),
        }
    }
    fn position(&self, n: usize) -> Point {
        Nodes::position(self, n)
    }
    fn nearest(&self, x: &[f64]) -> (usize, f64) {
        match self {
            Nodes::Lattice(g) => g.nearest(x),
            Nodes::Level(l) | Nodes::Cloud(l) => l.nearest(x),
        }
    }
    fn select(&self, r: &Region) -> Vec<usize> {
        match self {
            Nodes::Lattice(g) => g.select(r),
            Nodes::Level(l) | Nodes::Cloud(l) => l.select(r),
        }
    }
    fn body_box(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        self.lattice().and_then(NodeSet::body_box)
    }
}

impl NodeSet for LevelNodes {
    fn what(&self) -> &'static str {
        self.what
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
        let tol = linpd_core::GEOMETRY_RTOL * self.h;
        (0..self.positions.len()).filter(|&n| r.contains(&self.positions[n], self.dim, tol)).collect()
    }
}

/// The nodes a scene's regions and point loads refer to: a lattice, or the nodes of a
/// coarsened level.
/// `output.slice`: one axis key (`x`, `y` or `z`) of a 3D scene and a finite value within
/// the lattice's extent (layers included).
fn output_slice(raw: &RawProblem, grid: &Grid) -> Result<Option<(usize, f64)>, ProblemError> {
    let Some(slice) = &raw.output.slice else { return Ok(None) };
    if raw.dimension != 3 {
        return Err(ProblemError::invalid("output.slice", "is for 3D scenes (2D maps show the whole plate)"));
    }
    let mut entries = slice.iter();
    let (Some((key, &value)), None) = (entries.next(), entries.next()) else {
        return Err(ProblemError::invalid("output.slice", "give exactly one of x, y, z, e.g. {\"z\": 0.05}"));
    };
    let Some(axis) = ["x", "y", "z"].iter().position(|a| a == key) else {
        return Err(ProblemError::invalid(format!("output.slice.{key}"), "not an axis (x, y or z)"));
    };
    let counts = grid.counts();
    let (lo, hi) =
        (grid.site_position([0; 3])[axis], grid.site_position([counts[0] - 1, counts[1] - 1, counts[2] - 1])[axis]);
    let tol = linpd_core::GEOMETRY_RTOL * grid.spacing();
    if !(value.is_finite() && value >= lo - tol && value <= hi + tol) {
        return Err(ProblemError::invalid(
            format!("output.slice.{key}"),
            format!("{value:e} is outside the lattice's extent [{lo:e}, {hi:e}] along {key}"),
        ));
    }
    Ok(Some((axis, value)))
}

/// Two constraints that prescribe one DOF must prescribe the same value (to `1e-12` relative:
/// overlapping regions of one affine field written twice agree to rounding); otherwise the later
/// would silently win. The error names both constraints, the node and the two values.
fn check_constraints_agree(constraints: &[Constraint], dim: usize, nodes: &dyn NodeSet) -> Result<(), ProblemError> {
    let mut first: std::collections::HashMap<(usize, usize), (usize, f64)> = Default::default();
    for (k, c) in constraints.iter().enumerate() {
        for node in nodes.select(&c.region) {
            let x = nodes.position(node);
            for &a in &c.components {
                let u = c.displacement(&x[..dim], a);
                match first.entry((node, a)) {
                    std::collections::hash_map::Entry::Vacant(e) => {
                        e.insert((k, u));
                    }
                    std::collections::hash_map::Entry::Occupied(e) => {
                        let (j, v) = *e.get();
                        if (u - v).abs() > 1e-12 * u.abs().max(v.abs()) {
                            return Err(ProblemError::invalid(
                                format!("constraints[{k}]"),
                                format!(
                                    "prescribes u_{a} = {u:e} at node {node} (x = {:?}), where constraints[{j}] prescribes {v:e}: constraints that share a DOF must agree",
                                    &x[..dim]
                                ),
                            ));
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

pub(crate) trait NodeSet {
    /// `"the grid"`, `"the coarsened level"` (for messages).
    fn what(&self) -> &'static str;
    /// The length scale of the geometric tolerances (the lattice spacing).
    fn spacing(&self) -> f64;
    /// Position of node `n`.
    fn position(&self, n: usize) -> Point;
    /// The node nearest to `x` and its distance.
    fn nearest(&self, x: &[f64]) -> (usize, f64);
    /// The nodes inside `r`, ascending.
    fn select(&self, r: &Region) -> Vec<usize>;
    /// The body box `[min, max]` of a lattice (`None` for scattered nodes).
    fn body_box(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        None
    }
}

impl NodeSet for Grid {
    fn what(&self) -> &'static str {
        "the grid"
    }
    fn spacing(&self) -> f64 {
        Grid::spacing(self)
    }
    fn position(&self, n: usize) -> Point {
        Grid::position(self, n)
    }
    fn nearest(&self, x: &[f64]) -> (usize, f64) {
        self.nearest_node(x)
    }
    fn select(&self, r: &Region) -> Vec<usize> {
        r.nodes(self)
    }
    fn body_box(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        Some((self.min().to_vec(), self.max().to_vec()))
    }
}

/// A traction `t` (force per area) on the face `x+`, `x-`, ... of a lattice's body box, as a
/// body-force density `t / h` on the body's outermost slab of nodes at that face (the nodes
/// within one spacing of it, layers excluded): the applied force is `t sum_i V_i / h`, i.e.
/// `t` times the face's area when the slab is one full row of cells.
fn traction(p: &str, l: &crate::raw::RawLoad, dim: usize, nodes: &dyn NodeSet) -> Result<Load, ProblemError> {
    const FACES: [&str; 6] = ["x-", "x+", "y-", "y+", "z-", "z+"];
    let face = l.face.as_deref().ok_or_else(|| ProblemError::invalid(format!("{p}.face"), "missing"))?;
    let Some(k) = FACES[..2 * dim].iter().position(|f| *f == face) else {
        return Err(ProblemError::invalid(
            format!("{p}.face"),
            format!("{face:?} is not a face of a {dim}D box (one of {})", FACES[..2 * dim].join(", ")),
        ));
    };
    let t = l.traction.clone().ok_or_else(|| ProblemError::invalid(format!("{p}.traction"), "missing"))?;
    check_len(&format!("{p}.traction"), &t, dim)?;
    let Some((min, max)) = nodes.body_box() else {
        return Err(ProblemError::invalid(
            format!("{p}.type"),
            format!("a traction acts on a face of the grid's box; {} has none (use a resultant load)", nodes.what()),
        ));
    };
    let (axis, upper) = (k / 2, k % 2 == 1);
    let h = nodes.spacing();
    // one spacing, less a margin far above the region tolerance (1e-9 h): the next row is out
    let depth = h * (1.0 - 1e-6);
    let (mut lo, mut hi) = (min.clone(), max.clone());
    if upper {
        lo[axis] = max[axis] - depth;
    } else {
        hi[axis] = min[axis] + depth;
    }
    let region = Region::Box { min: lo, max: hi };
    if nodes.select(&region).is_empty() {
        return Err(ProblemError::invalid(
            format!("{p}.face"),
            format!("no node of the body lies within one spacing of the face {face}"),
        ));
    }
    Ok(Load::Body { region, density: t.iter().map(|v| v / h).collect() })
}

/// Validates `constraints` and `loads` against the nodes they refer to.
pub(crate) fn constraints_and_loads(
    raw: &RawProblem,
    dim: usize,
    nodes: &dyn NodeSet,
) -> Result<(Vec<Constraint>, Vec<Load>), ProblemError> {
    let mut constraints = Vec::new();
    for (k, c) in raw.constraints.iter().enumerate() {
        let p = format!("constraints[{k}]");
        let region = region(&format!("{p}.region"), &c.region, dim)?;
        check_len(&format!("{p}.displacement.value"), &c.displacement.value, dim)?;
        let gradient = match &c.displacement.gradient {
            None => vec![0.0; dim * dim],
            Some(rows) => {
                if rows.len() != dim || rows.iter().any(|r| r.len() != dim) {
                    return Err(ProblemError::invalid(
                        format!("{p}.displacement.gradient"),
                        format!("must be a {dim}x{dim} array of rows"),
                    ));
                }
                let g: Vec<f64> = rows.iter().flatten().cloned().collect();
                if g.iter().any(|v| !v.is_finite()) {
                    return Err(ProblemError::invalid(format!("{p}.displacement.gradient"), "values must be finite"));
                }
                g
            }
        };
        let components = match &c.components {
            None => (0..dim).collect(),
            Some(cs) => {
                if cs.is_empty() || cs.iter().any(|&a| a >= dim) {
                    return Err(ProblemError::invalid(
                        format!("{p}.components"),
                        format!("must list components in 0..{dim}, got {cs:?}"),
                    ));
                }
                cs.clone()
            }
        };
        let cons = Constraint { region, value: c.displacement.value.clone(), gradient, components };
        if nodes.select(&cons.region).is_empty() {
            return Err(ProblemError::invalid(format!("{p}.region"), format!("contains no node of {}", nodes.what())));
        }
        constraints.push(cons);
    }
    check_constraints_agree(&constraints, dim, nodes)?;

    let mut loads = Vec::new();
    for (k, l) in raw.loads.iter().enumerate() {
        let p = format!("loads[{k}]");
        let only = |kind: &str, given: &[(&str, bool)]| -> Result<(), ProblemError> {
            match given.iter().find(|(_, present)| *present) {
                Some((key, _)) => {
                    Err(ProblemError::invalid(format!("{p}.{key}"), format!("not a key of a {kind} load")))
                }
                None => Ok(()),
            }
        };
        let need = |key: &str, v: &Option<Vec<f64>>| -> Result<Vec<f64>, ProblemError> {
            let v = v.clone().ok_or_else(|| ProblemError::invalid(format!("{p}.{key}"), "missing"))?;
            check_len(&format!("{p}.{key}"), &v, dim)?;
            Ok(v)
        };
        // the region of a body or resultant load: present, valid, and holding a node
        let load_region = || -> Result<Region, ProblemError> {
            let r = l.region.as_ref().ok_or_else(|| ProblemError::invalid(format!("{p}.region"), "missing"))?;
            let region = region(&format!("{p}.region"), r, dim)?;
            if nodes.select(&region).is_empty() {
                return Err(ProblemError::invalid(
                    format!("{p}.region"),
                    format!("contains no node of {}", nodes.what()),
                ));
            }
            Ok(region)
        };
        loads.push(match l.kind {
            RawLoadKind::Point => {
                only("point", &[("region", l.region.is_some()), ("density", l.density.is_some())])?;
                let at = need("at", &l.at)?;
                let force = need("force", &l.force)?;
                let (node, d) = nodes.nearest(&at);
                let tol = 1e-6 * nodes.spacing();
                if d > tol {
                    return Err(ProblemError::invalid(
                        format!("{p}.at"),
                        format!(
                            "no node at {at:?} (nearest node {node} is at {:?}, {d:e} away); point loads must sit on a node",
                            &nodes.position(node)[..dim]
                        ),
                    ));
                }
                Load::Point { node, force }
            }
            RawLoadKind::Resultant => {
                only("resultant", &[("at", l.at.is_some()), ("density", l.density.is_some())])?;
                Load::Resultant { force: need("force", &l.force)?, region: load_region()? }
            }
            RawLoadKind::Body => {
                only("body", &[("at", l.at.is_some()), ("force", l.force.is_some())])?;
                Load::Body { density: need("density", &l.density)?, region: load_region()? }
            }
            RawLoadKind::Traction => {
                only(
                    "traction",
                    &[
                        ("at", l.at.is_some()),
                        ("force", l.force.is_some()),
                        ("density", l.density.is_some()),
                        ("region", l.region.is_some()),
                    ],
                )?;
                traction(&p, l, dim, nodes)?
            }
        });
    }

    Ok((constraints, loads))
}

/// Validates `solver` into a [`SolverSpec`] (`matrix_free` is checked here against the kind;
/// whether the model supports it is the caller's business).
pub(crate) fn solver_spec(raw: &RawSolver) -> Result<SolverSpec, ProblemError> {
    let cg = CgParams {
        rtol: raw.rtol.unwrap_or(CgParams::default().rtol),
        max_iter: raw.max_iter.unwrap_or(CgParams::default().max_iter),
    };
    if !(cg.rtol.is_finite() && cg.rtol > 0.0 && cg.rtol < 1.0) {
        return Err(ProblemError::invalid("solver.rtol", format!("must be in (0, 1), got {:e}", cg.rtol)));
    }
    if cg.max_iter == 0 {
        return Err(ProblemError::invalid("solver.max_iter", "must be >= 1"));
    }
    let is_cg = raw.kind == RawSolverKind::Cg;
    if raw.matrix_free && !is_cg {
        return Err(ProblemError::invalid(
            "solver.matrix_free",
            "only the cg solver can run matrix-free; set \"type\": \"cg\"",
        ));
    }
    let krylov = is_cg || raw.kind == RawSolverKind::Gmres;
    if (raw.rtol.is_some() || raw.max_iter.is_some()) && !(krylov || raw.kind == RawSolverKind::Auto) {
        return Err(ProblemError::invalid("solver", "rtol and max_iter apply to the cg and gmres solvers only"));
    }
    let preconditioner = match raw.preconditioner {
        None | Some(RawPreconditioner::Jacobi) => PreconditionerKind::Jacobi,
        Some(RawPreconditioner::Multigrid) => PreconditionerKind::Multigrid,
    };
    if raw.preconditioner.is_some() && !krylov {
        return Err(ProblemError::invalid(
            "solver.preconditioner",
            "only the cg and gmres solvers take a preconditioner",
        ));
    }
    Ok(match raw.kind {
        RawSolverKind::Auto => SolverSpec::Auto(cg),
        RawSolverKind::Cholesky => SolverSpec::Cholesky,
        RawSolverKind::Lu => SolverSpec::Lu,
        RawSolverKind::Dense => SolverSpec::Dense,
        RawSolverKind::Cg => SolverSpec::Cg { params: cg, preconditioner, matrix_free: raw.matrix_free },
        RawSolverKind::Gmres => SolverSpec::Gmres { params: cg, preconditioner },
    })
}

/// A JSON object with the top-level keys of a pipeline file (`scene` and `levels`) and none of
/// a scene's (`model`).
fn is_pipeline(text: &str) -> bool {
    match serde_json::from_str::<serde_json::Value>(text) {
        Ok(serde_json::Value::Object(m)) => {
            m.contains_key("scene") && m.contains_key("levels") && !m.contains_key("model")
        }
        _ => false,
    }
}

/// serde_path_to_error writes `?` for a key it has not read yet (a syntax error between two
/// keys); keep the known part of the path (`.` for the document).
fn known_path(path: &str) -> String {
    let p = path.strip_suffix('?').unwrap_or(path).trim_end_matches('.');
    if p.is_empty() {
        ".".into()
    } else {
        p.into()
    }
}

/// serde_json appends " at line L column C" to messages; we print position separately.
fn strip_position(msg: &str) -> String {
    match msg.rfind(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg.to_string(),
    }
}

impl Problem {
    /// The kernel shape of a micromodulus description.
    pub(crate) fn kernel_of(mm: &RawMicromodulus, horizon: f64) -> Result<Kernel, ProblemError> {
        let p = "model.micromodulus";
        Ok(match mm.kernel {
            RawKernel::Constant => Kernel::Constant,
            RawKernel::InverseDistance => Kernel::InverseDistance,
            RawKernel::Tent => Kernel::Tent,
            RawKernel::Gaussian => Kernel::Gaussian { length: mm.length.unwrap_or(0.5 * horizon) },
            RawKernel::Tabulated => {
                let t = mm.table.as_ref().ok_or_else(|| {
                    ProblemError::invalid(
                        format!("{p}.table"),
                        "the tabulated kernel needs a table {\"r_over_delta\": [...], \"g\": [...]}",
                    )
                })?;
                Kernel::Tabulated { s: t.r_over_delta.clone(), g: t.g.clone() }
            }
        })
    }
}

/// The micromodulus of a bond (or blend, ce) model from its keys, validated for `dim`.
pub(crate) fn bond_micromodulus(
    dim: usize,
    horizon: f64,
    mm: Option<&RawMicromodulus>,
    plane: Option<RawPlane>,
    partial_volume: bool,
) -> Result<Micromodulus, ProblemError> {
    let mm =
        mm.ok_or_else(|| ProblemError::invalid("model.micromodulus", "missing: the kernel and its normalization"))?;
    let plane = match (dim, plane) {
        (2, Some(RawPlane::Stress)) => Some(PlaneModel::Stress),
        (2, Some(RawPlane::Strain)) => Some(PlaneModel::Strain),
        (2, None) if mm.normalize != RawNormalize::None => {
            return Err(ProblemError::invalid("model.plane", "2D scenes need \"plane\": \"stress\" or \"strain\""))
        }
        (2, None) => None,
        (_, Some(_)) => {
            return Err(ProblemError::invalid("model.plane", format!("only meaningful in 2D (dimension is {dim})")))
        }
        (_, None) => None,
    };
    let micromodulus = micromodulus(mm, horizon, plane, partial_volume)?;
    micromodulus.validate(dim).map_err(|e| core("model.micromodulus", e))?;
    Ok(micromodulus)
}

fn micromodulus(
    mm: &RawMicromodulus,
    horizon: f64,
    plane: Option<PlaneModel>,
    partial_volume: bool,
) -> Result<Micromodulus, ProblemError> {
    let p = "model.micromodulus";
    let kernel = Problem::kernel_of(mm, horizon)?;
    if mm.length.is_some() && mm.kernel != RawKernel::Gaussian {
        return Err(ProblemError::invalid(format!("{p}.length"), "only the gaussian kernel takes a length"));
    }
    if mm.table.is_some() && mm.kernel != RawKernel::Tabulated {
        return Err(ProblemError::invalid(format!("{p}.table"), "only the tabulated kernel takes a table"));
    }
    let (normalization, modulus) = match (mm.normalize, mm.modulus, mm.amplitude) {
        (RawNormalize::None, None, Some(c)) => (Normalization::Amplitude(c), 1.0),
        (RawNormalize::None, _, None) => {
            return Err(ProblemError::invalid(
                format!("{p}.amplitude"),
                "\"normalize\": \"none\" needs an explicit amplitude",
            ))
        }
        (RawNormalize::None, Some(_), Some(_)) => return Err(ProblemError::invalid(
            format!("{p}.modulus"),
            "give either a modulus (with normalize discrete/continuum) or an amplitude (with normalize none), not both",
        )),
        (_, _, Some(_)) => {
            return Err(ProblemError::invalid(
                format!("{p}.amplitude"),
                "an explicit amplitude needs \"normalize\": \"none\"",
            ))
        }
        (_, None, None) => {
            return Err(ProblemError::invalid(
                format!("{p}.modulus"),
                "missing: the modulus to normalize the kernel to",
            ))
        }
        (RawNormalize::Discrete, Some(k), None) => (Normalization::Discrete, k),
        (RawNormalize::Continuum, Some(k), None) => (Normalization::Continuum, k),
    };
    let m = Micromodulus { kernel, normalization, modulus, plane, partial_volume };
    m.kernel.validate().map_err(|e| core(p, e))?;
    Ok(m)
}

pub(crate) fn material(raw: &RawMaterial, dim: usize) -> Result<Material, ProblemError> {
    material_with_tags(raw, dim, false)
}

/// [`material`]; with `tags`, phases given by a point cloud's phase number (`{"phase": k}`)
/// are validated and left out of the returned phases (the cloud applies them per node, see
/// [`crate::cloud`]), otherwise they are an error.
pub(crate) fn material_with_tags(raw: &RawMaterial, dim: usize, tags: bool) -> Result<Material, ProblemError> {
    let p = "model.material";
    let mut phases = Vec::new();
    for (k, ph) in raw.phases.iter().enumerate() {
        if !(ph.modulus.is_finite() && ph.modulus > 0.0) {
            return Err(ProblemError::invalid(
                format!("{p}.phases[{k}].modulus"),
                format!("must be > 0, got {:e}", ph.modulus),
            ));
        }
        match (&ph.region, ph.phase) {
            (Some(r), None) => phases.push((region(&format!("{p}.phases[{k}].region"), r, dim)?, ph.modulus)),
            (None, Some(_)) if tags => {}
            (None, Some(_)) => {
                return Err(ProblemError::invalid(
                    format!("{p}.phases[{k}].phase"),
                    "phase numbers come from a point cloud's `phase` column; on a grid give a region",
                ))
            }
            _ => {
                return Err(ProblemError::invalid(
                    format!("{p}.phases[{k}]"),
                    "give exactly one of \"region\" or \"phase\"",
                ))
            }
        }
    }
    let rule = match raw.bond_rule {
        None => BondRule::default(),
        Some(RawBondRule::Min) => BondRule::Min,
        Some(RawBondRule::Max) => BondRule::Max,
        Some(RawBondRule::Arithmetic) => BondRule::Arithmetic,
        Some(RawBondRule::Harmonic) => BondRule::Harmonic,
        Some(RawBondRule::Geometric) => BondRule::Geometric,
    };
    let mut defects = Vec::new();
    for (k, d) in raw.defects.iter().enumerate() {
        let dp = format!("{p}.defects[{k}]");
        let given = [d.point.is_some(), d.segment.is_some(), d.plane.is_some()].iter().filter(|&&b| b).count();
        if given != 1 {
            return Err(ProblemError::invalid(
                &dp,
                "give exactly one of \"point\" (1D), \"segment\" (2D) or \"plane\" (3D)",
            ));
        }
        let defect = if let Some(x) = d.point {
            Defect::Point { x, factor: d.factor }
        } else if let Some([a, b]) = d.segment {
            Defect::Segment { a, b, factor: d.factor }
        } else {
            let pl = d.plane.as_ref().unwrap();
            let extent = pl.extent.as_ref().map(|r| region(&format!("{dp}.plane.extent"), r, 3)).transpose()?;
            Defect::Plane { point: pl.point, normal: pl.normal, extent, factor: d.factor }
        };
        defect.validate(dim).map_err(|e| match e {
            // The core names the list ("defects") and the bare "normal"; point at the entry.
            CoreError::Parameter { name, reason } if name == "defects" => ProblemError::invalid(&dp, reason),
            CoreError::Parameter { name, reason } if name == "normal" => {
                ProblemError::invalid(format!("{dp}.plane.normal"), reason)
            }
            e => core(&dp, e),
        })?;
        defects.push(defect);
    }
    Ok(Material { phases, rule, defects })
}
