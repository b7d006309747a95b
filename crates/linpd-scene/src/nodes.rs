//! The nodes of a scene: a lattice ([`Grid`]), a point cloud read from a file, or a coarsened
//! level's nodes; and `NodeSet`, what regions, point loads and constraints select them by.

use linpd_core::{Grid, Point, Region};

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
    /// A mesh's named node sets (`{"set": name}` regions).
    pub(crate) sets: linpd_io::mesh::Sets,
    /// Points on a mesh's boundary faces ([`linpd_io::cloud::Cloud::boundary`]; empty without
    /// a mesh's topology).
    pub(crate) boundary: Vec<Point>,
    /// A rank's window of a point cloud: the whole cloud's scales (`None`: the nodes are whole).
    pub(crate) whole: Option<linpd_core::family::CloudScales>,
}

impl LevelNodes {
    /// Nodes at `positions` with `volumes` in dimension `dim`.
    ///
    /// The tolerance scale `min_i v_i^(1/d)` is capped by the largest side of the nodes'
    /// bounding box: volumes are read from a file and need not match the positions, and
    /// volumes of 1e300 would otherwise give a region tolerance (`1e-9 h`) that swallows every
    /// node ("every DOF is constrained") instead of the overflow they cause.
    pub fn new(dim: usize, positions: Vec<Point>, volumes: Vec<f64>) -> Self {
        let min_size = volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64)));
        let h = tolerance_scale(min_size, extent(&positions, dim));
        LevelNodes {
            dim,
            positions,
            volumes,
            h,
            layer: Vec::new(),
            phase: Vec::new(),
            what: "the coarsened level",
            sets: Default::default(),
            boundary: Vec::new(),
            whole: None,
        }
    }
}

/// The scale of the geometric tolerances of nodes whose smallest size is `min_size` and whose
/// bounding box's largest side is `extent` (see [`LevelNodes::new`]).
pub(crate) fn tolerance_scale(min_size: f64, extent: f64) -> f64 {
    let h = if extent.is_finite() && extent > 0.0 { min_size.min(extent) } else { min_size };
    if h.is_finite() {
        h
    } else {
        1.0
    }
}

/// The largest side of the bounding box of `positions` (0 for none or one).
pub(crate) fn extent(positions: &[Point], dim: usize) -> f64 {
    (0..dim)
        .map(|a| {
            let (lo, hi) =
                positions.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x[a]), hi.max(x[a])));
            hi - lo
        })
        .fold(0.0f64, f64::max)
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
    /// The nodes of the named set `name` of a mesh (ascending), if the nodes have one.
    pub fn set(&self, name: &str) -> Option<&[u32]> {
        match self {
            Nodes::Cloud(c) => c.sets.get(name).map(Vec::as_slice),
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
    fn count(&self) -> usize {
        self.len()
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
    fn check_sets(&self, r: &Region, path: &str) -> Result<(), crate::ProblemError> {
        match self {
            Nodes::Lattice(g) => g.check_sets(r, path),
            Nodes::Level(l) | Nodes::Cloud(l) => l.check_sets(r, path),
        }
    }
    fn body_box(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        self.lattice().and_then(NodeSet::body_box)
    }
}

impl LevelNodes {
    /// The nodes whose horizon lies inside the body: no point of the mesh's boundary faces
    /// within `reach` (the horizon plus the quadrature's largest radius) plus the largest
    /// boundary face's size (its centroid and corners sample it that finely). All false without
    /// a mesh's boundary.
    pub(crate) fn interior(&self, reach: f64) -> Vec<bool> {
        let n = self.positions.len();
        if self.boundary.is_empty() {
            return vec![false; n];
        }
        let d = self.dim;
        // the boundary's sampling: no point of a face is farther than the largest distance
        // between neighbouring samples; bounded by the largest element size
        let size = self.volumes.iter().fold(0.0f64, |m, &v| m.max(v.powf(1.0 / d as f64)));
        let radius = reach + 2.0 * size;
        let cell =
            |x: &Point| -> [i64; 3] { std::array::from_fn(|a| if a < d { (x[a] / radius).floor() as i64 } else { 0 }) };
        let mut grid: std::collections::HashMap<[i64; 3], Vec<usize>> = std::collections::HashMap::new();
        for (k, b) in self.boundary.iter().enumerate() {
            grid.entry(cell(b)).or_default().push(k);
        }
        let near = |x: &Point| -> bool {
            let c = cell(x);
            let span = |a: usize| if a < d { -1..=1 } else { 0..=0 };
            span(0).any(|i| {
                span(1).any(|j| {
                    span(2).any(|k| {
                        grid.get(&[c[0] + i, c[1] + j, c[2] + k]).is_some_and(|list| {
                            list.iter().any(|&b| {
                                let p = &self.boundary[b];
                                (0..d).map(|a| (p[a] - x[a]).powi(2)).sum::<f64>() < radius * radius
                            })
                        })
                    })
                })
            })
        };
        self.positions.iter().map(|x| !near(x)).collect()
    }
}

impl NodeSet for LevelNodes {
    fn what(&self) -> &'static str {
        self.what
    }
    fn spacing(&self) -> f64 {
        self.h
    }
    fn count(&self) -> usize {
        self.positions.len()
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
        let member = |n: usize, name: &str| self.sets.get(name).is_some_and(|s| s.binary_search(&(n as u32)).is_ok());
        (0..self.positions.len())
            .filter(|&n| r.contains_with(&self.positions[n], self.dim, tol, &|name| member(n, name)))
            .collect()
    }
    fn check_sets(&self, r: &Region, path: &str) -> Result<(), crate::ProblemError> {
        for name in r.set_names() {
            if !self.sets.contains_key(name) {
                let known: Vec<&str> = self.sets.keys().map(String::as_str).collect();
                return Err(crate::ProblemError::invalid(
                    format!("{path}.set"),
                    match known.is_empty() {
                        true => format!("no set {name:?}: {} has no named sets", self.what),
                        false => format!("no set {name:?} in {} (its sets: {})", self.what, known.join(", ")),
                    },
                ));
            }
        }
        Ok(())
    }
}

pub(crate) trait NodeSet {
    /// `"the grid"`, `"the coarsened level"` (for messages).
    fn what(&self) -> &'static str;
    /// The length scale of the geometric tolerances (the lattice spacing).
    fn spacing(&self) -> f64;
    /// Number of nodes.
    fn count(&self) -> usize;
    /// Position of node `n`.
    fn position(&self, n: usize) -> Point;
    /// The node nearest to `x` and its distance.
    fn nearest(&self, x: &[f64]) -> (usize, f64);
    /// The nodes inside `r`, ascending.
    fn select(&self, r: &Region) -> Vec<usize>;
    /// Every named set `r` refers to exists (`path`: the region's JSON path).
    fn check_sets(&self, r: &Region, path: &str) -> Result<(), crate::ProblemError> {
        match r.set_names().first() {
            None => Ok(()),
            Some(name) => Err(crate::ProblemError::invalid(
                format!("{path}.set"),
                format!(
                    "no set {name:?}: named sets come with a mesh (nodes.mesh, nodes.peridigm), and these nodes are {}",
                    self.what()
                ),
            )),
        }
    }
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
    fn count(&self) -> usize {
        self.len()
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
