//! The plain serde mirror of a scene file. Every struct denies unknown keys; meaning and
//! consistency are checked later, in [`crate::Problem::from_raw`] (the `model` section by its
//! model type, [`crate::models`]). Keys are documented in
//! `docs/problem-format.md`.

use serde::Deserialize;

/// A whole scene.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawProblem {
    /// Free-form name (used in outputs).
    pub name: String,
    /// 1, 2 or 3.
    pub dimension: usize,
    /// The lattice (required by every model except `coarsened`, whose nodes come from its
    /// nodes file).
    #[serde(default)]
    pub grid: Option<RawGrid>,
    /// The material model (parsed by its type, [`crate::models`]).
    pub model: RawModelJson,
    /// Volume constraints.
    #[serde(default)]
    pub constraints: Vec<RawConstraint>,
    /// External loads.
    #[serde(default)]
    pub loads: Vec<RawLoad>,
    /// Solver choice.
    #[serde(default)]
    pub solver: RawSolver,
    /// Where results go.
    #[serde(default)]
    pub output: RawOutput,
    /// Explicit dynamics (`linpd run`).
    #[serde(default)]
    pub dynamics: Option<RawDynamics>,
    /// The body: only the grid's nodes inside this region (layer nodes included) are kept.
    #[serde(default)]
    pub body: Option<RawRegion>,
    /// `"full"` (default: every node `h^d`) or `"cut"`: cells cut by the body's boundary get
    /// their inside fraction ([`linpd_core::Grid::with_cut_volumes`]).
    #[serde(default)]
    pub boundary_volumes: Option<RawBoundaryVolumes>,
    /// A point cloud read from a file, instead of `grid` (`{"csv": "file.csv"}`).
    #[serde(default)]
    pub nodes: Option<RawNodes>,
    /// Mass density for `linpd modes` (the lumped mass `rho V_i`).
    #[serde(default)]
    pub density: Option<f64>,
}

/// `boundary_volumes`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawBoundaryVolumes {
    /// Every node `h^d`.
    Full,
    /// Inside fractions of cut cells.
    Cut,
}

/// `nodes`: where a point cloud comes from (exactly one key).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawNodes {
    /// A CSV file: header `x[,y[,z]],volume[,phase][,layer]`, one node per line.
    #[serde(default)]
    pub csv: Option<String>,
    /// A Gmsh MSH 4.1 mesh: a node per element ([`linpd_io::mesh`]).
    #[serde(default)]
    pub mesh: Option<String>,
    /// Peridigm's text discretization `x y z block_id volume` ([`linpd_io::mesh`]).
    #[serde(default)]
    pub peridigm: Option<String>,
    /// A VTK XML UnstructuredGrid file: its points and a `volume` point array.
    #[serde(default)]
    pub vtk: Option<String>,
}

/// `dynamics`: velocity-Verlet time stepping.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDynamics {
    /// Time step (exactly one of `dt`, `dt_safety`).
    #[serde(default)]
    pub dt: Option<f64>,
    /// Time step as a fraction of the stability limit.
    #[serde(default)]
    pub dt_safety: Option<f64>,
    /// Number of steps.
    pub steps: usize,
    /// Snapshot interval in steps (default: `steps / 10`, at least 1).
    #[serde(default)]
    pub output_every: Option<usize>,
    /// Mass density `rho`.
    pub density: f64,
    /// Initial displacement (default: at rest, `u = 0`).
    #[serde(default)]
    pub initial: Option<RawInitial>,
    /// Run even above the stability limit.
    #[serde(default)]
    pub allow_unstable: bool,
}

/// `dynamics.initial.type`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawInitialKind {
    /// `u = 0`.
    Rest,
    /// `u = amplitude` on `[from, to]`.
    SquarePulse,
    /// The smooth pulse of section 4.4.1, centred at `center`, support `width`.
    SmoothPulse,
    /// `u = amplitude cos(wavenumber x)`.
    Mode,
    /// User data: `u` (and optionally `v`), `dimension` values per node in node order.
    Data,
}

/// `dynamics.initial` (a plain struct with a `type` field, as [`RawLoad`]).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInitial {
    /// Which initial condition.
    #[serde(rename = "type")]
    pub kind: RawInitialKind,
    /// Square pulse: left end.
    #[serde(default)]
    pub from: Option<f64>,
    /// Square pulse: right end.
    #[serde(default)]
    pub to: Option<f64>,
    /// Smooth pulse: centre.
    #[serde(default)]
    pub center: Option<f64>,
    /// Smooth pulse: support width.
    #[serde(default)]
    pub width: Option<f64>,
    /// Mode: wavenumber `k`.
    #[serde(default)]
    pub wavenumber: Option<f64>,
    /// Peak displacement (default 1).
    #[serde(default)]
    pub amplitude: Option<f64>,
    /// Data: initial displacements (all DOFs, node-major).
    #[serde(default)]
    pub u: Option<Vec<f64>>,
    /// Data: initial velocities (all DOFs, node-major; default 0).
    #[serde(default)]
    pub v: Option<Vec<f64>>,
}

/// `grid`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawGrid {
    /// Lower corner of the body.
    pub min: Vec<f64>,
    /// Upper corner of the body.
    pub max: Vec<f64>,
    /// Lattice spacing.
    pub spacing: f64,
    /// Thickness of the outer layer (nodes outside `[min, max]`): a number (every side) or an
    /// object of per-side thicknesses `{"x-": 0.06, "x+": 0, ...}` (missing sides 0); read by
    /// [`RawGrid::layers`].
    #[serde(default, deserialize_with = "layer_value")]
    pub layer: Option<serde_json::Value>,
    /// `vertex` (default) or `cell`.
    #[serde(default)]
    pub placement: RawPlacement,
}

impl RawGrid {
    /// The layer thicknesses `[below, above]` per axis (`grid.layer`, see the field), or an
    /// error naming the key (`grid.layer.w-: not a side ...`).
    pub fn layers(&self, dim: usize) -> Result<linpd_core::grid::Layers, (String, String)> {
        const SIDES: [&str; 6] = ["x-", "x+", "y-", "y+", "z-", "z+"];
        let mut out = [[0.0; 2]; 3];
        let number = |path: &str, v: &serde_json::Value| -> Result<f64, (String, String)> {
            let x = v.as_f64().ok_or_else(|| (path.to_string(), format!("expected a number, got {v}")))?;
            if x.is_finite() && x >= 0.0 {
                Ok(x)
            } else {
                Err((path.to_string(), format!("must be >= 0, got {x:e}")))
            }
        };
        match &self.layer {
            None => {}
            Some(serde_json::Value::Object(sides)) => {
                for (key, v) in sides {
                    let Some(k) = SIDES[..2 * dim].iter().position(|s| s == key) else {
                        return Err((
                            format!("grid.layer.{key}"),
                            format!("not a side of a {dim}D grid (sides: {})", SIDES[..2 * dim].join(", ")),
                        ));
                    };
                    out[k / 2][k % 2] = number(&format!("grid.layer.{key}"), v)?;
                }
            }
            Some(v) => {
                let x = number("grid.layer", v).map_err(|(p, r)| {
                    (p, format!("{r} (a thickness for every side, or an object such as {{\"x-\": 0.06}})"))
                })?;
                out = [[x; 2]; 3];
            }
        }
        Ok(out)
    }

    /// True when every side's layer is 0.
    pub fn has_no_layer(&self, dim: usize) -> bool {
        self.layers(dim).is_ok_and(|l| l.iter().take(dim).all(|s| s[0] == 0.0 && s[1] == 0.0))
    }
}

/// `grid.layer` as a JSON value, refusing a side given twice (`{"x-": 0.1, "x-": 0.2}`: a
/// `serde_json::Value` would keep the later one silently); `null` is absent.
fn layer_value<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<serde_json::Value>, D::Error> {
    use serde::de::{Error, MapAccess, SeqAccess, Visitor};
    use serde_json::Value;
    struct V;
    impl<'de> Visitor<'de> for V {
        type Value = Value;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a thickness or an object of per-side thicknesses")
        }
        fn visit_bool<E: Error>(self, v: bool) -> Result<Value, E> {
            Ok(Value::Bool(v))
        }
        fn visit_i64<E: Error>(self, v: i64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_u64<E: Error>(self, v: u64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_f64<E: Error>(self, v: f64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_str<E: Error>(self, v: &str) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_unit<E: Error>(self) -> Result<Value, E> {
            Ok(Value::Null)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
            let mut items = Vec::new();
            while let Some(v) = seq.next_element::<Value>()? {
                items.push(v);
            }
            Ok(Value::Array(items))
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
            let mut sides = serde_json::Map::new();
            while let Some(key) = map.next_key::<String>()? {
                let v: Value = map.next_value()?;
                if sides.contains_key(&key) {
                    return Err(A::Error::custom(format!(
                        "the side `{key}` is given twice (which thickness is meant?): give each side once"
                    )));
                }
                sides.insert(key, v);
            }
            Ok(Value::Object(sides))
        }
    }
    Ok(Some(d.deserialize_any(V)?).filter(|v| !v.is_null()))
}

/// `{"difference": [A, B]}`: exactly two regions (serde's tuple would say "trailing
/// characters" about a third, or "invalid length" about one).
fn two_regions<'de, D: serde::Deserializer<'de>>(d: D) -> Result<(Box<RawRegion>, Box<RawRegion>), D::Error> {
    let regions = Vec::<RawRegion>::deserialize(d)?;
    let n = regions.len();
    let mut it = regions.into_iter();
    match (it.next(), it.next(), n) {
        (Some(a), Some(b), 2) => Ok((Box::new(a), Box::new(b))),
        _ => Err(serde::de::Error::custom(format!(
            "`difference` takes exactly two regions [A, B] (the nodes of A not in B), got {n}; for more, \
             subtract a union: {{\"difference\": [A, {{\"union\": [B, C]}}]}}"
        ))),
    }
}

/// `grid.placement`.
#[derive(Debug, Clone, Copy, Deserialize, Default, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawPlacement {
    /// Nodes at `min + i h`.
    #[default]
    Vertex,
    /// Nodes at cell centres.
    Cell,
}

/// `model`: its JSON text, kept as written (with its position in the scene file) until the
/// model type it names parses it into its own struct ([`crate::models::registry`]): each type
/// owns its keys.
#[derive(Debug, Clone)]
pub struct RawModelJson {
    text: Box<serde_json::value::RawValue>,
    /// 1-based line and column of the section's first byte in the scene file.
    at: (usize, usize),
}

impl<'de> Deserialize<'de> for RawModelJson {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(RawModelJson { text: Deserialize::deserialize(d)?, at: (1, 1) })
    }
}

impl RawModelJson {
    /// The section as `T`: errors carry the JSON path under `model` and the line and column in
    /// the scene file.
    pub fn parse<T: serde::de::DeserializeOwned>(&self) -> Result<T, crate::ProblemError> {
        crate::json::parse_json_at(self.text.get(), "model", self.at)
    }

    /// `model.type` as written (empty when it is not a string).
    pub fn kind(&self) -> String {
        #[derive(Deserialize)]
        struct Kind {
            #[serde(rename = "type")]
            kind: String,
        }
        serde_json::from_str::<Kind>(self.text.get()).map(|k| k.kind).unwrap_or_default()
    }

    /// Records where the section starts in `document`, the text it was parsed from.
    pub(crate) fn locate(&mut self, document: &str) {
        #[derive(Deserialize)]
        struct Locate<'a> {
            #[serde(borrow)]
            model: &'a serde_json::value::RawValue,
        }
        if let Ok(l) = serde_json::from_str::<Locate>(document) {
            let offset = l.model.get().as_ptr() as usize - document.as_ptr() as usize;
            let before = &document.as_bytes()[..offset];
            let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
            let column = offset - before.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1) + 1;
            self.at = (line, column);
        }
    }
}

/// `model.influence`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawInfluence {
    /// `omega = 1 / |xi|`.
    InverseDistance,
    /// `omega = 1`.
    Constant,
}

/// `model.pd_regions`: a list of regions or `"auto"`. Deserialized by hand (a string or a
/// sequence) rather than as an untagged enum, which would lose the JSON path of an error inside
/// a region.
#[derive(Debug, Clone)]
pub enum RawPdRegions {
    /// Around every feature of the scene.
    Auto,
    /// These regions.
    Regions(Vec<RawRegion>),
}

impl<'de> Deserialize<'de> for RawPdRegions {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = RawPdRegions;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "\"auto\" or a list of regions")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                match v {
                    "auto" => Ok(RawPdRegions::Auto),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = Vec::new();
                while let Some(r) = seq.next_element::<RawRegion>()? {
                    out.push(r);
                }
                Ok(RawPdRegions::Regions(out))
            }
        }
        d.deserialize_any(V)
    }
}

/// `model.surface_correction`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawSurfaceCorrection {
    /// No correction.
    None,
    /// Moment matching, bond factor the mean of its ends (bond and LPS).
    Energy,
    /// Moment matching with a per-node influence function (LPS).
    PositionAware,
}

/// `model.surface_target`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawSurfaceTarget {
    /// The isotropic moments of classical elasticity.
    Classical,
    /// The interior lattice's moments.
    Lattice,
}

/// `model.blending`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawBlending {
    /// Constant in the bridges.
    Constant,
    /// Linear ramp.
    Linear,
    /// `3 s^2 - 2 s^3`.
    Cubic,
    /// User table.
    Piecewise,
}

/// `model.blending_table`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBlendingTable {
    /// Bridge coordinates in `[0, 1]`.
    pub s: Vec<f64>,
    /// Values in `[0, 1]`.
    pub beta: Vec<f64>,
}

/// `model.plane`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawPlane {
    /// Plane stress.
    Stress,
    /// Plane strain.
    Strain,
}

/// `model.micromodulus`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMicromodulus {
    /// `constant`, `inverse_distance`, `tent`, `gaussian`, `tabulated`.
    pub kernel: RawKernel,
    /// Gaussian decay length (default `horizon / 2`).
    #[serde(default)]
    pub length: Option<f64>,
    /// Tabulated kernel: `{"r_over_delta": [...], "g": [...]}`.
    #[serde(default)]
    pub table: Option<RawTable>,
    /// Bulk modulus `K` (1D: the bar modulus of eq. (7)).
    #[serde(default)]
    pub modulus: Option<f64>,
    /// Young's modulus `E` instead of `modulus` ([`crate::elastic`]).
    #[serde(default)]
    pub young_modulus: Option<f64>,
    /// With `young_modulus`: Poisson's ratio, which must be the bond model's.
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
    /// `discrete` (default), `continuum` or `none` (then `amplitude` is required).
    #[serde(default)]
    pub normalize: RawNormalize,
    /// Explicit amplitude `c` when `normalize` is `none`.
    #[serde(default)]
    pub amplitude: Option<f64>,
}

/// `model.micromodulus.kernel`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawKernel {
    /// `g = 1`.
    Constant,
    /// `g = 1/r`.
    InverseDistance,
    /// `g = 1 - r/delta`.
    Tent,
    /// `g = exp(-(r/l)^2)`.
    Gaussian,
    /// Piecewise linear.
    Tabulated,
}

/// `model.micromodulus.table`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTable {
    /// `r / delta`, increasing in `[0, 1]`.
    pub r_over_delta: Vec<f64>,
    /// `g` values.
    pub g: Vec<f64>,
}

/// `model.micromodulus.normalize`.
#[derive(Debug, Clone, Copy, Deserialize, Default, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawNormalize {
    /// Lattice sum reproduces the modulus.
    #[default]
    Discrete,
    /// Exact integral reproduces the modulus.
    Continuum,
    /// Explicit amplitude.
    None,
}

/// `model.material`.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RawMaterial {
    /// `[{"region": R, "modulus": K}]`.
    #[serde(default)]
    pub phases: Vec<RawPhase>,
    /// `min`, `max`, `arithmetic`, `harmonic` (default), `geometric`.
    #[serde(default)]
    pub bond_rule: Option<RawBondRule>,
    /// Bond-degrading defects.
    #[serde(default)]
    pub defects: Vec<RawDefect>,
}

/// One phase.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPhase {
    /// Where (exactly one of `region`, `phase`).
    #[serde(default)]
    pub region: Option<RawRegion>,
    /// The nodes of a point cloud whose `phase` column holds this number.
    #[serde(default)]
    pub phase: Option<u32>,
    /// Its modulus `K`.
    #[serde(default)]
    pub modulus: Option<f64>,
    /// Young's modulus `E` instead of `modulus` ([`crate::elastic`]).
    #[serde(default)]
    pub young_modulus: Option<f64>,
    /// With `young_modulus`: Poisson's ratio, which must be the bond model's.
    #[serde(default)]
    pub poisson_ratio: Option<f64>,
}

/// `model.material.bond_rule`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawBondRule {
    /// Softer end.
    Min,
    /// Stiffer end.
    Max,
    /// Mean.
    Arithmetic,
    /// Series springs.
    Harmonic,
    /// Geometric mean.
    Geometric,
}

/// A defect: exactly one of `point` (1D), `segment` (2D), `plane` (3D), and a `factor`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDefect {
    /// 1D location.
    #[serde(default)]
    pub point: Option<f64>,
    /// 2D segment `[[x0, y0], [x1, y1]]`.
    #[serde(default)]
    pub segment: Option<[[f64; 2]; 2]>,
    /// 3D plane.
    #[serde(default)]
    pub plane: Option<RawPlaneDefect>,
    /// Multiplier of crossing bonds (0 cuts them).
    pub factor: f64,
}

/// A 3D planar defect.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlaneDefect {
    /// A point on the plane.
    pub point: [f64; 3],
    /// The normal.
    pub normal: [f64; 3],
    /// Optional region of the plane that is defective.
    #[serde(default)]
    pub extent: Option<RawRegion>,
}

/// A region: `"all"`, `{"box": {...}}`, `{"ball": {...}}`, `{"cylinder": {...}}`,
/// `{"half_space": {...}}`, `{"polygon": {...}}`, `{"union": [...]}`, `{"difference": [A, B]}`.
#[derive(Debug, Clone, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RawRegion {
    /// Everything.
    All,
    /// A closed box.
    Box {
        /// Lower corner.
        min: Vec<f64>,
        /// Upper corner.
        max: Vec<f64>,
    },
    /// A closed ball (disk in 2D).
    Ball {
        /// Centre.
        center: Vec<f64>,
        /// Radius.
        radius: f64,
    },
    /// A closed circular cylinder (3D).
    Cylinder {
        /// A point of the axis (its middle when `length` is given).
        center: Vec<f64>,
        /// Axis direction.
        axis: Vec<f64>,
        /// Radius.
        radius: f64,
        /// Length (infinite when absent).
        #[serde(default)]
        length: Option<f64>,
    },
    /// `(x - point) . normal <= 0`.
    HalfSpace {
        /// A point of the plane.
        point: Vec<f64>,
        /// Outward normal.
        normal: Vec<f64>,
    },
    /// A 2D polygon, extruded along z in 3D.
    Polygon {
        /// Vertices `[x, y]`.
        vertices: Vec<[f64; 2]>,
        /// 3D: `[z0, z1]`.
        #[serde(default)]
        extrude: Option<[f64; 2]>,
    },
    /// A named node set of a mesh (`nodes.mesh`, `nodes.peridigm`).
    Set(String),
    /// Any of.
    Union(Vec<RawRegion>),
    /// First minus second (exactly two regions).
    #[serde(deserialize_with = "two_regions")]
    Difference(Box<RawRegion>, Box<RawRegion>),
}

/// A volume constraint.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConstraint {
    /// Where (with `displacement`; not with `file`).
    #[serde(default)]
    pub region: Option<RawRegion>,
    /// `u = value + gradient x` (with `region`).
    #[serde(default)]
    pub displacement: Option<RawDisplacement>,
    /// Prescribed values per DOF from a CSV file `node,component,value` (instead of `region`
    /// and `displacement`), relative to the scene file.
    #[serde(default)]
    pub file: Option<String>,
    /// Constrained components (default: all).
    #[serde(default)]
    pub components: Option<Vec<usize>>,
}

/// `u = value + gradient x`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDisplacement {
    /// Constant part (one entry per dimension).
    pub value: Vec<f64>,
    /// Displacement gradient `H` (rows), default zero.
    #[serde(default)]
    pub gradient: Option<Vec<Vec<f64>>>,
}

/// `loads[k].type`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawLoadKind {
    /// A force on the node at `at`.
    Point,
    /// A body-force density on every node of a region (force = density * node volume).
    Body,
    /// A total force spread over a region's nodes in proportion to their volumes.
    Resultant,
    /// A force per area on a face of the grid's body box.
    Traction,
    /// Nodal forces per node from a CSV file `node,f_x[,f_y[,f_z]]`.
    Nodal,
}

/// A load: `{"type": "point", "at", "force"}` or `{"type": "body", "region", "density"}`
/// (a plain struct rather than a serde-tagged enum: serde buffers tagged enums before choosing the
/// variant, which loses the JSON path and position of errors inside them; the pairing is checked
/// in validation).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLoad {
    /// Point or body.
    #[serde(rename = "type")]
    pub kind: RawLoadKind,
    /// Point load: location (must coincide with a node).
    #[serde(default)]
    pub at: Option<Vec<f64>>,
    /// Point load: force vector.
    #[serde(default)]
    pub force: Option<Vec<f64>>,
    /// Body load: where.
    #[serde(default)]
    pub region: Option<RawRegion>,
    /// Body load: force per unit volume.
    #[serde(default)]
    pub density: Option<Vec<f64>>,
    /// Traction: the face of the body box (`x-`, `x+`, `y-`, ...).
    #[serde(default)]
    pub face: Option<String>,
    /// Traction: force per unit area.
    #[serde(default)]
    pub traction: Option<Vec<f64>>,
    /// Nodal: the CSV file, relative to the scene file.
    #[serde(default)]
    pub file: Option<String>,
}

/// `solver`.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RawSolver {
    /// `auto` (default), `cholesky`, `lu`, `cg`, `dense`.
    #[serde(rename = "type", default)]
    pub kind: RawSolverKind,
    /// CG relative residual target.
    #[serde(default)]
    pub rtol: Option<f64>,
    /// CG iteration limit.
    #[serde(default)]
    pub max_iter: Option<usize>,
    /// CG without an assembled matrix.
    #[serde(default)]
    pub matrix_free: bool,
    /// CG preconditioner (default `jacobi`).
    #[serde(default)]
    pub preconditioner: Option<RawPreconditioner>,
}

/// `solver.preconditioner`: the name of a registered preconditioner
/// ([`linpd_solve::precond::kind::PRECONDITIONERS`]), checked while the scene is read, so that an
/// unknown name is a read error with its line and column, like any other enumerated key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawPreconditioner(pub linpd_solve::PreconditionerKind);

impl<'de> Deserialize<'de> for RawPreconditioner {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        // serde wants a 'static list: the registry's names, made once
        static NAMES: std::sync::OnceLock<&'static [&'static str]> = std::sync::OnceLock::new();
        let name = String::deserialize(d)?;
        match linpd_solve::PreconditionerKind::named(&name) {
            Some(kind) => Ok(RawPreconditioner(kind)),
            None => {
                let names = NAMES.get_or_init(|| {
                    let names: Vec<&'static str> =
                        linpd_solve::precond::kind::PRECONDITIONERS.iter().map(|k| k.name()).collect();
                    Box::leak(names.into_boxed_slice())
                });
                Err(serde::de::Error::unknown_variant(&name, names))
            }
        }
    }
}

/// `solver.type`.
#[derive(Debug, Clone, Copy, Deserialize, Default, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RawSolverKind {
    /// Pick by size and dimension.
    #[default]
    Auto,
    /// Sparse Cholesky.
    Cholesky,
    /// Sparse LU.
    Lu,
    /// Jacobi-PCG.
    Cg,
    /// Restarted GMRES (any `A`), Jacobi or multigrid preconditioned.
    Gmres,
    /// Dense Cholesky.
    Dense,
}

/// `output`.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RawOutput {
    /// Output directory (default `out/<name>`).
    #[serde(default)]
    pub dir: Option<String>,
    /// Write PNG/SVG plots (default true).
    #[serde(default)]
    pub plot: Option<bool>,
    /// 3D: the lattice plane the map shows, `{"x"|"y"|"z": value}` (default: the middle z plane).
    #[serde(default)]
    pub slice: Option<std::collections::BTreeMap<String, f64>>,
    /// Which nodes result.json and result.vtu hold (default `model`).
    #[serde(default)]
    pub nodes: Option<RawOutputNodes>,
    /// Line probes: u, strain and stress sampled along segments ([`crate::probe`]).
    #[serde(default)]
    pub probes: Vec<RawProbe>,
    /// The stress map's quantity (default `von_mises`; [`crate::stress::StressMap`]).
    #[serde(default)]
    pub stress_map: Option<String>,
    /// The deformed-shape plot's displacement scale (default: chosen so that the largest
    /// displacement is drawn as a tenth of the body's size, rounded to 1, 2 or 5 x 10^k).
    #[serde(default)]
    pub deformed_scale: Option<f64>,
}

/// One of `output.probes`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawProbe {
    /// The file stem (default `probe-<k>`, `k` from 1).
    #[serde(default)]
    pub name: Option<String>,
    /// The segment's start.
    pub from: Vec<f64>,
    /// The segment's end.
    pub to: Vec<f64>,
    /// Sample points, both ends included (default 101).
    #[serde(default)]
    pub points: Option<usize>,
}

/// `output.nodes`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RawOutputNodes {
    /// The model's nodes: the lattice's, or a graded local mesh's (masters and hanging nodes).
    Model,
    /// Every lattice node (a graded local mesh's field interpolated to them).
    Lattice,
}

pub(crate) fn parse_raw(text: &str) -> Result<RawProblem, crate::ProblemError> {
    if crate::json::is_pipeline(text) {
        return Err(crate::ProblemError::invalid(
            ".",
            "this is a coarsening pipeline (it has \"scene\" and \"levels\"), not a scene: run it with `linpd coarsen FILE`",
        ));
    }
    let mut raw: RawProblem = crate::json::parse_json(text)?;
    raw.model.locate(text);
    Ok(raw)
}
