//! The validators every model type shares: regions, materials, micromoduli, the lattice and
//! the point cloud of a scene, constraints and loads, the solver and the output sections. Each
//! error names the JSON path of what is wrong.

use crate::cloud::read_csv;
use crate::elastic::BondElastic;
use crate::nodes::{LevelNodes, NodeSet};
use crate::part::{halo_reaches, Part, Presences, Slab};
use crate::raw::*;
use crate::scene::{Constraint, Load};
use crate::ProblemError;
use linpd_core::{
    BondFamily, BondRule, CoreError, Defect, Grid, Kernel, Material, Micromodulus, Normalization, Placement,
    PlaneModel, Point, Region,
};
use linpd_solve::{CgParams, PreconditionerKind, SolverSpec};
use std::path::{Path, PathBuf};

/// A scene being validated: the parsed mirror and the directory its file names start at.
pub struct Context<'a> {
    /// The serde mirror.
    pub raw: &'a RawProblem,
    /// Relative file names in the scene start here (the scene file's directory).
    pub base_dir: &'a Path,
    /// The rank's part of a distributed scene ([`crate::part`]); `None`: the whole scene.
    pub(crate) part: Option<Part>,
    /// The part's slab, once [`lattice_for`] cut the window.
    pub(crate) slab: std::cell::RefCell<Option<Slab>>,
    /// The part's whole lattice box (no body: nothing per node), for what is checked against
    /// the whole lattice (`output.slice`).
    pub(crate) whole: std::cell::RefCell<Option<Grid>>,
    /// The checks a part records rather than decides.
    pub(crate) presences: Presences,
    /// The part's window of a point cloud, once [`cloud_nodes`] cut it.
    pub(crate) cloud: std::cell::RefCell<Option<crate::part::CloudWindow>>,
    /// The `solver` section, validated once before the model: the scene's spec, or `auto`'s
    /// default where the section is invalid (for the estimates made while the model is
    /// validated; the section's error is reported after the model's).
    pub solver: SolverSpec,
    solver_checked: Option<Result<SolverSpec, ProblemError>>,
}

impl<'a> Context<'a> {
    /// The context of a whole scene (`part: None`) or of one rank's part.
    pub(crate) fn new(raw: &'a RawProblem, base_dir: &'a Path, part: Option<Part>) -> Self {
        let presences = Presences::new(part.is_some());
        let checked = solver_spec(&raw.solver);
        Context {
            solver: checked.as_ref().map_or_else(|_| SolverSpec::default(), Clone::clone),
            solver_checked: Some(checked),
            raw,
            base_dir,
            part,
            slab: Default::default(),
            whole: Default::default(),
            presences,
            cloud: Default::default(),
        }
    }

    /// The validated `solver` section, or its error (once).
    pub(crate) fn take_solver(&mut self) -> Result<SolverSpec, ProblemError> {
        self.solver_checked.take().unwrap_or_else(|| Ok(self.solver.clone()))
    }
}

pub(crate) fn core(path: &str, e: CoreError) -> ProblemError {
    match e {
        // a parameter named as the key itself (`body` of `body`) is that key, not `body.body`
        CoreError::Parameter { name, reason } if path == name || path.ends_with(&format!(".{name}")) => {
            ProblemError::invalid(path, reason)
        }
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
        RawRegion::Set(name) => {
            let phase = path.starts_with("model.material.phases[");
            if !(path.starts_with("constraints[") || path.starts_with("loads[") || phase) {
                return Err(ProblemError::invalid(
                    format!("{path}.set"),
                    "a mesh's named sets select the nodes of constraints, loads and a mesh's phases only \
                     (not bodies, defects or pd_regions, which are lattice features)",
                ));
            }
            Region::Set(name.clone())
        }
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

/// The output directory: `output.dir` as given, else `out/<name>`. The name must then be a
/// plain directory name: a name like `../../x` must not write outside `out/`.
pub fn output_dir(dir: Option<&str>, name: &str) -> Result<String, ProblemError> {
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
    lattice_for(cx, horizon, None, &|_| (path, Vec::new()))
}

/// [`lattice`] with the memory path and whether it builds a multigrid hierarchy decided on the
/// grid (`auto` solves large homogeneous lattices matrix-free).
///
/// On a rank's part ([`Context::part`]) the grid is the rank's window ([`crate::part`]), whose
/// halo holds `reaches` reaches of the horizon; `reaches: None` (a model without per-rank
/// geometry) refuses a part by name.
pub(crate) fn lattice_for(
    cx: &Context,
    horizon: f64,
    reaches: Option<usize>,
    path_of: &dyn Fn(&Grid) -> (crate::memory::Path, Vec<linpd_solve::PreconditionerKind>),
) -> Result<Grid, ProblemError> {
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
    let cut = raw.boundary_volumes == Some(crate::raw::RawBoundaryVolumes::Cut);
    let grid = match cx.part {
        None => grid,
        Some(part) => {
            *cx.whole.borrow_mut() = Some(grid.clone());
            window(cx, grid, part, horizon, reaches, cut)?
        }
    };
    // Refuse scenes that cannot fit before anything per node is allocated (the regions below
    // already walk every node).
    let (path, setup) = path_of(&grid);
    let _ = crate::memory::check_solver(path, &grid, horizon, &setup)?;
    Ok(match &body {
        None if cut => {
            return Err(ProblemError::invalid("boundary_volumes", "\"cut\" needs a \"body\" whose boundary cuts cells"))
        }
        None => grid,
        Some(body) => {
            let tol = linpd_core::GEOMETRY_RTOL * grid.spacing();
            let body = linpd_core::polygon_index::PreparedRegion::new(body);
            let inside = |x: &Point| body.contains(x, dim, tol);
            let kept = grid.with_body(inside).map_err(|e| match (cx.part, cx.slab.borrow().as_ref()) {
                // the rank's window is a slab of the grid's box: it may miss a body that does
                // not fill the box
                (Some(part), Some(slab)) => ProblemError::invalid(
                    "body",
                    format!(
                        "rank {} of {}: its slab of the lattice (planes {}..{} of {}, halo included) holds no node of \
                         the body: run on fewer ranks, or with a grid box the body fills",
                        part.rank, part.ranks, slab.window.start, slab.window.end, slab.planes
                    ),
                ),
                _ => core("body", e),
            })?;
            if cut {
                let (cut, dropped) = kept.with_cut_volumes_dropping(inside);
                if !dropped.is_empty() {
                    return Err(dropped_body_part(raw.body.as_ref(), &dropped, dim, tol));
                }
                cut
            } else {
                kept
            }
        }
    })
}

/// The end of the refusal of a scene without per-rank geometry (the PETSc driver falls back
/// to the whole scene on every rank when it reads it).
pub(crate) const NO_PER_RANK_GEOMETRY: &str =
    "has no per-rank geometry yet: every rank of the distributed solve builds the whole scene (--gather)";

/// The rank's window of the whole lattice `whole` (see [`crate::part`]), its slab recorded in
/// `cx`.
fn window(
    cx: &Context,
    whole: Grid,
    part: Part,
    horizon: f64,
    reaches: Option<usize>,
    cut: bool,
) -> Result<Grid, ProblemError> {
    let refuse = |what: &str| Err(ProblemError::invalid("model.type", format!("{what} {NO_PER_RANK_GEOMETRY}")));
    let Some(reaches) = reaches else {
        return refuse(&format!("the {} model", cx.raw.model.kind()));
    };
    if cut {
        return refuse("a body with \"boundary_volumes\": \"cut\"");
    }
    if whole.dim() < 2 {
        return refuse("a 1D lattice");
    }
    let slab = Slab::of(&whole, part, halo_reaches(reaches, horizon / whole.spacing()));
    let grid = whole
        .window(slab.window.start, slab.window.end)
        .ok_or_else(|| ProblemError::invalid("grid", format!("no window {:?} of the lattice", slab.window)))?;
    *cx.slab.borrow_mut() = Some(slab);
    Ok(grid)
}

/// The error of a body with cut-cell volumes whose part holds no node and borders no kept
/// node's cell: its volume would drop out of the volume total. Names the first such top-level
/// union part (`body.union[k]`, the first containing a dropped part's centroid), else `body`.
fn dropped_body_part(body: Option<&RawRegion>, dropped: &[(Point, f64)], dim: usize, tol: f64) -> ProblemError {
    let (c, _) = dropped[0];
    let total: f64 = dropped.iter().map(|(_, v)| v).sum();
    let path = match body {
        Some(RawRegion::Union(parts)) => parts
            .iter()
            .enumerate()
            .map(|(k, r)| (format!("body.union[{k}]"), r))
            .find(|(p, r)| region(p, r, dim).is_ok_and(|r| r.contains(&c, dim, tol)))
            .map_or("body".to_string(), |(p, _)| p),
        _ => "body".to_string(),
    };
    ProblemError::invalid(
        path,
        format!(
            "a part of the body around {:?} holds no node and borders no node's cell: its volume {total:e} \
             would drop out of the cut-cell volumes (\"boundary_volumes\": \"cut\"); refine the spacing, \
             join the part to the body or remove it",
            &c[..dim]
        ),
    )
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

/// The nodes a scene's regions and point loads refer to: a lattice, or the nodes of a
/// coarsened level.
/// `output.slice`: one axis key (`x`, `y` or `z`) of a 3D scene and a finite value within
/// the lattice's extent (layers included).
pub(crate) fn output_slice(raw: &RawProblem, grid: &Grid) -> Result<Option<(usize, f64)>, ProblemError> {
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
        for (node, a, u) in c.prescribed(nodes, dim) {
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
                                &nodes.position(node)[..dim]
                            ),
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// A file named in the scene: relative names start at the scene file's directory.
fn scene_file(base_dir: &Path, name: &str) -> PathBuf {
    if Path::new(name).is_absolute() {
        PathBuf::from(name)
    } else {
        base_dir.join(name)
    }
}

/// `constraints[k]` with `file`: the prescribed DOFs of a CSV file ([`linpd_io::nodal`]).
fn nodal_constraint(
    p: &str,
    c: &crate::raw::RawConstraint,
    file: &str,
    dim: usize,
    nodes: &dyn NodeSet,
    base_dir: &Path,
) -> Result<Constraint, ProblemError> {
    for (key, given) in [
        ("region", c.region.is_some()),
        ("displacement", c.displacement.is_some()),
        ("components", c.components.is_some()),
    ] {
        if given {
            return Err(ProblemError::invalid(
                format!("{p}.{key}"),
                "a constraint from a `file` takes its DOFs and values from the file; give either `file` or `region` with `displacement`",
            ));
        }
    }
    let rows = linpd_io::nodal::read_prescribed(&scene_file(base_dir, file), dim, nodes.count())
        .map_err(|e| ProblemError::invalid(format!("{p}.file"), e.to_string()))?;
    if rows.is_empty() {
        return Err(ProblemError::invalid(format!("{p}.file"), "prescribes no DOF"));
    }
    Ok(Constraint::Nodal { file: file.to_string(), values: rows.into_iter().map(|(n, a, v, _)| (n, a, v)).collect() })
}

/// `loads[k]` of type `nodal`: the forces of a CSV file ([`linpd_io::nodal`]).
fn nodal_load(
    p: &str,
    l: &crate::raw::RawLoad,
    dim: usize,
    nodes: &dyn NodeSet,
    base_dir: &Path,
) -> Result<Load, ProblemError> {
    let file = l.file.as_deref().ok_or_else(|| ProblemError::invalid(format!("{p}.file"), "missing"))?;
    let rows = linpd_io::nodal::read_forces(&scene_file(base_dir, file), dim, nodes.count())
        .map_err(|e| ProblemError::invalid(format!("{p}.file"), e.to_string()))?;
    Ok(Load::Nodal { file: file.to_string(), forces: rows.into_iter().map(|(n, f, _)| (n, f)).collect() })
}

/// A traction `t` (force per area) on the face `x+`, `x-`, ... of a lattice's body box, as a
/// body-force density `t / h` on the body's outermost slab of nodes at that face (the nodes
/// within one spacing of it, layers excluded): the applied force is `t sum_i V_i / h`, i.e.
/// `t` times the face's area when the slab is one full row of cells.
fn traction(
    p: &str,
    l: &crate::raw::RawLoad,
    dim: usize,
    nodes: &dyn NodeSet,
    presences: &Presences,
) -> Result<Load, ProblemError> {
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
    presences.require(!nodes.select(&region).is_empty(), || {
        ProblemError::invalid(
            format!("{p}.face"),
            format!("no node of the body lies within one spacing of the face {face}"),
        )
    })?;
    Ok(Load::Body { region, density: t.iter().map(|v| v / h).collect() })
}

/// Validates `constraints` and `loads` against the nodes they refer to.
/// `constraints[k]` with `region` and `displacement`: an affine field on a region's nodes.
fn affine_constraint(
    p: &str,
    c: &crate::raw::RawConstraint,
    dim: usize,
    nodes: &dyn NodeSet,
    presences: &Presences,
) -> Result<Constraint, ProblemError> {
    let (Some(raw_region), Some(displacement)) = (&c.region, &c.displacement) else {
        let key = if c.region.is_none() { "region" } else { "displacement" };
        return Err(ProblemError::invalid(
            format!("{p}.{key}"),
            "missing (a constraint is `region` with `displacement`, or a `file`)",
        ));
    };
    let region = region(&format!("{p}.region"), raw_region, dim)?;
    nodes.check_sets(&region, &format!("{p}.region"))?;
    check_len(&format!("{p}.displacement.value"), &displacement.value, dim)?;
    let gradient = match &displacement.gradient {
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
    presences.require(!nodes.select(&region).is_empty(), || {
        ProblemError::invalid(format!("{p}.region"), format!("contains no node of {}", nodes.what()))
    })?;
    Ok(Constraint::Affine { region, value: displacement.value.clone(), gradient, components })
}

/// On a rank's part (`presences.is_part()`) the nodes are the rank's window: the checks that a
/// region holds a node are recorded ([`crate::part`]), a point load off the window loads
/// nothing here, and node-numbered files (whose numbers are the whole lattice's) are refused.
pub(crate) fn constraints_and_loads(
    raw: &RawProblem,
    dim: usize,
    nodes: &dyn NodeSet,
    base_dir: &Path,
    presences: &Presences,
) -> Result<(Vec<Constraint>, Vec<Load>), ProblemError> {
    let per_node_file = |p: &str| {
        Err(ProblemError::invalid(format!("{p}.file"), format!("a node-numbered file {NO_PER_RANK_GEOMETRY}")))
    };
    let mut constraints = Vec::new();
    for (k, c) in raw.constraints.iter().enumerate() {
        let p = format!("constraints[{k}]");
        constraints.push(match &c.file {
            Some(_) if presences.is_part() => return per_node_file(&p),
            Some(file) => nodal_constraint(&p, c, file, dim, nodes, base_dir)?,
            None => affine_constraint(&p, c, dim, nodes, presences)?,
        });
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
            nodes.check_sets(&region, &format!("{p}.region"))?;
            presences.require(!nodes.select(&region).is_empty(), || {
                ProblemError::invalid(format!("{p}.region"), format!("contains no node of {}", nodes.what()))
            })?;
            Ok(region)
        };
        loads.push(match l.kind {
            RawLoadKind::Nodal => {
                only(
                    "nodal",
                    &[
                        ("at", l.at.is_some()),
                        ("force", l.force.is_some()),
                        ("density", l.density.is_some()),
                        ("region", l.region.is_some()),
                        ("face", l.face.is_some()),
                        ("traction", l.traction.is_some()),
                    ],
                )?;
                if presences.is_part() {
                    return per_node_file(&p);
                }
                nodal_load(&p, l, dim, nodes, base_dir)?
            }
            RawLoadKind::Point => {
                only("point", &[("region", l.region.is_some()), ("density", l.density.is_some())])?;
                let at = need("at", &l.at)?;
                let force = need("force", &l.force)?;
                let (node, d) = nodes.nearest(&at);
                let tol = 1e-6 * nodes.spacing();
                presences.require(d <= tol, || {
                    let nearest = match presences.is_part() {
                        true => String::new(),
                        false => format!(" (nearest node {node} is at {:?}, {d:e} away)", &nodes.position(node)[..dim]),
                    };
                    ProblemError::invalid(
                        format!("{p}.at"),
                        format!("no node at {at:?}{nearest}; point loads must sit on a node"),
                    )
                })?;
                // off a rank's window the load acts on another rank's node: nothing here
                let force = if d <= tol { force } else { vec![0.0; dim] };
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
                traction(&p, l, dim, nodes, presences)?
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
    let preconditioner = raw.preconditioner.map_or_else(PreconditionerKind::default, |p| p.0);
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
    let micromodulus = micromodulus(mm, horizon, plane, partial_volume, BondElastic::of(dim, plane))?;
    micromodulus.validate(dim).map_err(|e| core("model.micromodulus", e))?;
    Ok(micromodulus)
}

fn micromodulus(
    mm: &RawMicromodulus,
    horizon: f64,
    plane: Option<PlaneModel>,
    partial_volume: bool,
    elastic: BondElastic,
) -> Result<Micromodulus, ProblemError> {
    let p = "model.micromodulus";
    let given = elastic.modulus(p, mm.modulus, mm.young_modulus, mm.poisson_ratio)?;
    let key = if mm.young_modulus.is_some() { "young_modulus" } else { "modulus" };
    let kernel = kernel_of(mm, horizon)?;
    if mm.length.is_some() && mm.kernel != RawKernel::Gaussian {
        return Err(ProblemError::invalid(format!("{p}.length"), "only the gaussian kernel takes a length"));
    }
    if mm.table.is_some() && mm.kernel != RawKernel::Tabulated {
        return Err(ProblemError::invalid(format!("{p}.table"), "only the tabulated kernel takes a table"));
    }
    let (normalization, modulus) = match (mm.normalize, given, mm.amplitude) {
        (RawNormalize::None, None, Some(c)) => (Normalization::Amplitude(c), 1.0),
        (RawNormalize::None, _, None) => {
            return Err(ProblemError::invalid(
                format!("{p}.amplitude"),
                "\"normalize\": \"none\" needs an explicit amplitude",
            ))
        }
        (RawNormalize::None, Some(_), Some(_)) => return Err(ProblemError::invalid(
            format!("{p}.{key}"),
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
                "missing: the modulus to normalize the kernel to (or young_modulus)",
            ))
        }
        (RawNormalize::Discrete, Some(k), None) => (Normalization::Discrete, k),
        (RawNormalize::Continuum, Some(k), None) => (Normalization::Continuum, k),
    };
    let m = Micromodulus { kernel, normalization, modulus, plane, partial_volume };
    m.kernel.validate().map_err(|e| core(p, e))?;
    Ok(m)
}

/// The constants of a bond model with `micromodulus` in dimension `dim` (`None` with an
/// explicit amplitude: its phases' moduli are multipliers).
pub(crate) fn bond_elastic(dim: usize, micromodulus: &Micromodulus) -> Option<BondElastic> {
    match micromodulus.normalization {
        linpd_core::Normalization::Amplitude(_) => None,
        _ => Some(BondElastic::of(dim, micromodulus.plane)),
    }
}

/// The material of a model; `elastic`: the bond model's constants, for phases given by
/// `young_modulus` (`None`: phases give `modulus` only, a multiplier of an explicit amplitude).
pub(crate) fn material(raw: &RawMaterial, dim: usize, elastic: Option<BondElastic>) -> Result<Material, ProblemError> {
    material_with_tags(raw, dim, false, elastic)
}

/// Each phase's modulus `K`: its `modulus`, or its `young_modulus` through the bond model's
/// constants ([`crate::elastic`]).
pub(crate) fn phase_moduli(raw: &RawMaterial, elastic: Option<BondElastic>) -> Result<Vec<f64>, ProblemError> {
    raw.phases
        .iter()
        .enumerate()
        .map(|(k, ph)| {
            let p = format!("model.material.phases[{k}]");
            let given = match elastic {
                Some(e) => e.modulus(&p, ph.modulus, ph.young_modulus, ph.poisson_ratio)?,
                None if ph.young_modulus.is_some() || ph.poisson_ratio.is_some() => {
                    return Err(ProblemError::invalid(
                        format!("{p}.young_modulus"),
                        "with \"normalize\": \"none\" a phase's modulus multiplies the amplitude: give modulus",
                    ))
                }
                None => ph.modulus,
            };
            let m = given.ok_or_else(|| ProblemError::invalid(format!("{p}.modulus"), "missing (or young_modulus)"))?;
            if !(m.is_finite() && m > 0.0) {
                return Err(ProblemError::invalid(format!("{p}.modulus"), format!("must be > 0, got {m:e}")));
            }
            Ok(m)
        })
        .collect()
}

/// [`material`]; with `tags`, phases given by a point cloud's phase number (`{"phase": k}`)
/// are validated and left out of the returned phases (the cloud applies them per node, see
/// [`crate::cloud`]), otherwise they are an error.
pub(crate) fn material_with_tags(
    raw: &RawMaterial,
    dim: usize,
    tags: bool,
    elastic: Option<BondElastic>,
) -> Result<Material, ProblemError> {
    let p = "model.material";
    let moduli = phase_moduli(raw, elastic)?;
    let mut phases = Vec::new();
    for (k, ph) in raw.phases.iter().enumerate() {
        match (&ph.region, ph.phase) {
            (Some(r), None) => {
                let path = format!("{p}.phases[{k}].region");
                let r = region(&path, r, dim)?;
                match (r.set_names().first(), tags) {
                    // a mesh's set is applied per node, with the phase numbers ([`crate::cloud`])
                    (Some(_), true) => {}
                    (Some(name), false) => {
                        return Err(ProblemError::invalid(
                            format!("{path}.set"),
                            format!("no set {name:?}: named sets come with a mesh (nodes.mesh, nodes.peridigm)"),
                        ))
                    }
                    (None, _) => phases.push((r, moduli[k])),
                }
            }
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
        let defect = match (d.point, d.segment, &d.plane) {
            (Some(x), _, _) => Defect::Point { x, factor: d.factor },
            (_, Some([a, b]), _) => Defect::Segment { a, b, factor: d.factor },
            (_, _, Some(pl)) => {
                let extent = pl.extent.as_ref().map(|r| region(&format!("{dp}.plane.extent"), r, 3)).transpose()?;
                Defect::Plane { point: pl.point, normal: pl.normal, extent, factor: d.factor }
            }
            (None, None, None) => unreachable!("exactly one is given (checked above)"),
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

/// The nodes of a scene whose nodes come from a file (`"nodes"` instead of `"grid"`), checked
/// against the horizon and the memory of `path` (with the setup of the preconditioners
/// `setup` of the node count names; with `ball`, the bonds of a ball quadrature,
/// which reach `delta + max R`: [`linpd_bond::quadrature`]); and their mean spacing
/// ([`mean_spacing`]).
///
/// On a rank's part ([`Context::part`]) every rank reads the whole file and keeps its window
/// ([`crate::cloud::window`]), whose halo holds `reaches` reaches of the bonds; `reaches: None`,
/// and a surface correction (`corrected`) on a cloud with layer nodes, refuse a part by name.
/// The mean spacing returned is the whole cloud's.
pub(crate) fn cloud_nodes(
    cx: &Context,
    spec: &RawNodes,
    horizon: f64,
    (reaches, corrected): (Option<usize>, bool),
    (path, setup): (crate::memory::Path, &dyn Fn(usize) -> Vec<linpd_solve::PreconditionerKind>),
    ball: bool,
) -> Result<(LevelNodes, f64), ProblemError> {
    let raw = cx.raw;
    let dim = raw.dimension;
    if raw.grid.is_some() {
        return Err(ProblemError::invalid("grid", "give either \"grid\" or \"nodes\", not both"));
    }
    if raw.body.is_some() {
        return Err(ProblemError::invalid("body", "not used with \"nodes\" (the point cloud is the body)"));
    }
    if raw.output.slice.is_some() {
        return Err(ProblemError::invalid(
            "output.slice",
            "point clouds get no map (their nodes are not on a lattice)",
        ));
    }
    // a rank's part streams a CSV file (crate::cloud::csv_window): this first pass checks every
    // line and sums what the checks below need; other formats are read whole, then cut
    let streamed = match (&spec.csv, &spec.vtk, &spec.mesh, &spec.peridigm, cx.part, reaches) {
        (Some(f), None, None, None, Some(_), Some(_)) if dim >= 2 => Some(cx.base_dir.join(f)),
        _ => None,
    };
    let (cloud, summary) = match &streamed {
        Some(file) => {
            let mut summary = crate::cloud::Summary::new();
            linpd_io::cloud::visit_csv(file, dim, &mut |node| summary.add(&node.x, node.volume, node.layer, dim))
                .map_err(|e| ProblemError::invalid("nodes.csv", e.to_string()))?;
            (None, summary)
        }
        None => {
            let cloud = match (&spec.csv, &spec.vtk, &spec.mesh, &spec.peridigm) {
                (Some(f), None, None, None) => read_csv(&cx.base_dir.join(f), dim, "nodes.csv")?,
                (None, Some(f), None, None) => crate::cloud::read_vtk(&cx.base_dir.join(f), dim, "nodes.vtk")?,
                (None, None, Some(f), None) => crate::cloud::read_mesh(&cx.base_dir.join(f), dim, "nodes.mesh")?,
                (None, None, None, Some(f)) => {
                    crate::cloud::read_peridigm(&cx.base_dir.join(f), dim, "nodes.peridigm")?
                }
                _ => {
                    return Err(ProblemError::invalid(
                        "nodes",
                        "give exactly one of \"csv\", \"vtk\", \"mesh\" or \"peridigm\"",
                    ))
                }
            };
            let summary = crate::cloud::Summary::of(&cloud.positions, &cloud.volumes, &cloud.layer, dim);
            (Some(cloud), summary)
        }
    };
    if !(horizon.is_finite() && horizon > 0.0) {
        return Err(ProblemError::invalid("model.horizon", format!("must be > 0, got {horizon:e}")));
    }
    // A mesh in another unit than the horizon (mm against m) gives a horizon below one
    // spacing or above the whole body; a plain point cloud may hold a whole small body in one
    // family on purpose (test clouds), a mesh does not.
    let mesh = spec.mesh.as_ref().map(|f| ("nodes.mesh", f)).or(spec.peridigm.as_ref().map(|f| ("nodes.peridigm", f)));
    let unit_hint = match mesh {
        Some((key, file)) => format!(" (is {key} {file:?} in another unit than the horizon?)"),
        None => String::new(),
    };
    let h = summary.mean_spacing(dim);
    let ratio = horizon / h;
    if ratio < 1.0 {
        return Err(ProblemError::invalid(
            "model.horizon",
            format!(
                "horizon / mean node spacing (V^(1/d)) = {ratio:e}: the horizon must be at least one spacing{unit_hint}"
            ),
        ));
    }
    let extent = (0..dim).map(|a| summary.bounds[1][a] - summary.bounds[0][a]).fold(0.0f64, f64::max);
    if mesh.is_some() && horizon >= extent {
        return Err(ProblemError::invalid(
            "model.horizon",
            format!("{horizon:e} is not shorter than the body, whose nodes span {extent:e}{unit_hint}"),
        ));
    }
    // a ball quadrature bonds to delta + the largest equivalent radius
    let q = if ball { linpd_bond::quadrature::Quadrature::Ball } else { linpd_bond::quadrature::Quadrature::Full };
    let reach = linpd_bond::quadrature::reach(q, dim, horizon, &[summary.max_volume]);
    let nodes = match (cx.part, reaches, cloud, &streamed) {
        (None, _, Some(cloud), _) => crate::cloud::into_nodes(cloud, dim),
        (Some(_), None, _, _) => {
            return Err(ProblemError::invalid(
                "model.type",
                format!("the {} model on a point cloud {NO_PER_RANK_GEOMETRY}", raw.model.kind()),
            ))
        }
        (Some(_), Some(_), _, _) if dim < 2 => {
            return Err(ProblemError::invalid("nodes", format!("a 1D point cloud {NO_PER_RANK_GEOMETRY}")))
        }
        // the layer's nodes take the fit of the whole cloud's fullest family
        // (linpd_core::surface), which no window knows
        (Some(_), Some(_), _, _) if corrected && summary.layers > 0 => {
            return Err(ProblemError::invalid(
                "model.surface_correction",
                format!("a surface correction on a point cloud with `layer` nodes {NO_PER_RANK_GEOMETRY}"),
            ))
        }
        (Some(part), Some(reaches), Some(cloud), None) => {
            let (window, slab, cloud) = crate::cloud::window(cloud, dim, &summary, part, (reaches, reach))?;
            *cx.slab.borrow_mut() = Some(slab);
            *cx.cloud.borrow_mut() = Some(cloud);
            window
        }
        (Some(part), Some(reaches), None, Some(file)) => {
            let (window, slab, cloud) =
                crate::cloud::csv_window(file, "nodes.csv", dim, &summary, part, (reaches, reach))?;
            *cx.slab.borrow_mut() = Some(slab);
            *cx.cloud.borrow_mut() = Some(cloud);
            window
        }
        _ => return Err(ProblemError::invalid("nodes", "a cloud neither read nor streamed")),
    };
    let _ = crate::memory::check_cloud(path, dim, &nodes.positions, reach, &setup(nodes.positions.len()))?;
    Ok((nodes, h))
}

/// Why a model on a point cloud lacks [`crate::Capability::Coarsen`].
pub(crate) const NOT_COARSENED: &str =
    "coarsening retains every k-th node of a lattice (levels[].every); point clouds are not coarsened yet";

/// The lattice target of a surface correction refused on a point cloud.
pub(crate) fn refuse_lattice_target(target: Option<crate::raw::RawSurfaceTarget>) -> Result<(), ProblemError> {
    if target == Some(crate::raw::RawSurfaceTarget::Lattice) {
        return Err(ProblemError::invalid(
            "model.surface_target",
            "\"lattice\" matches an interior lattice's moments, and a point cloud has none: use \"classical\"",
        ));
    }
    Ok(())
}

/// The nodes phase `k` of a cloud's material selects: its `region`'s (a mesh's sets included)
/// or those whose phase number (`column`, a cloud's `phase` column or a mesh's groups) is
/// `tag`. A set or number that selects no node, and a number without a column, are named
/// errors (a typo would otherwise leave the material silently homogeneous); on a rank's part
/// the selections are recorded in `presences`.
pub(crate) fn phase_nodes<N: crate::nodes::NodeSet + ?Sized>(
    nodes: &N,
    column: &[u32],
    k: usize,
    (region, tag): (Option<&Region>, Option<u32>),
    presences: &Presences,
) -> Result<Vec<usize>, ProblemError> {
    let p = format!("model.material.phases[{k}]");
    match (region, tag) {
        (Some(r), _) => {
            let path = format!("{p}.region");
            nodes.check_sets(r, &path)?;
            let selected = nodes.select(r);
            presences.require(!selected.is_empty() || r.set_names().is_empty(), || {
                ProblemError::invalid(path, "selects no node of the mesh")
            })?;
            Ok(selected)
        }
        (None, Some(_)) if column.is_empty() => Err(ProblemError::invalid(
            format!("{p}.phase"),
            format!(
                "phase numbers come from a point cloud's `phase` column or a mesh's groups, and {} has none (give a \
                 region)",
                nodes.what()
            ),
        )),
        (None, Some(tag)) => {
            let selected: Vec<usize> = (0..column.len()).filter(|&n| column[n] == tag).collect();
            presences.require(!selected.is_empty(), || {
                ProblemError::invalid(format!("{p}.phase"), format!("no node of the cloud has phase {tag}"))
            })?;
            Ok(selected)
        }
        (None, None) => Err(ProblemError::invalid(&p, "give exactly one of \"region\" or \"phase\"")),
    }
}

/// Every defect of a cloud scene must cut a bond of the cloud.
pub(crate) fn check_defects(
    material: &linpd_core::Material,
    nodes: &LevelNodes,
    horizon: f64,
    presences: &Presences,
) -> Result<(), ProblemError> {
    if !material.defects.is_empty() {
        let family = BondFamily::from_points(&nodes.positions, nodes.dim, horizon);
        let tol = linpd_core::GEOMETRY_RTOL * nodes.h;
        for (k, cuts) in material.defects_cutting_in(&family, &nodes.positions, tol).into_iter().enumerate() {
            presences.require(cuts, || defect_cuts_nothing(k))?;
        }
    }
    Ok(())
}

/// Every defect of `material` crosses a bond of `grid` (on a rank's part: recorded, see
/// [`crate::part`]).
pub(crate) fn require_defects_cut(
    material: &Material,
    grid: &Grid,
    horizon: f64,
    presences: &Presences,
) -> Result<(), ProblemError> {
    for (k, cuts) in material.defects_cutting(grid, horizon).into_iter().enumerate() {
        presences.require(cuts, || defect_cuts_nothing(k))?;
    }
    Ok(())
}

/// The error of a defect that crosses no bond.
pub(crate) fn defect_cuts_nothing(k: usize) -> ProblemError {
    ProblemError::invalid(
        format!("model.material.defects[{k}]"),
        "crosses no bond of the body (it lies outside the body, in a hole, or where no bond spans it)",
    )
}
