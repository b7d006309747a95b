//! `"nodes"`: a point cloud read from a file instead of a lattice ([`linpd_io::cloud`] for CSV,
//! [`linpd_io::vtk`] for VTK: the file formats are described there), as the nodes of a scene.
//! Errors start with the JSON path of the file name (`nodes.csv: part.csv line 3: ...`).

use crate::nodes::LevelNodes;
use crate::part::{Bins, CloudWindow, Part, Slab};
use crate::ProblemError;
use linpd_io::cloud::CsvNode;
pub use linpd_io::cloud::{mean_spacing, Cloud, DUPLICATE_RTOL, MAX_CLOUD_BYTES};
use std::path::Path;

/// Reads a CSV point cloud of dimension `dim`; `key` is the JSON path of the file name, which
/// every error starts with.
pub fn read_csv(path: &Path, dim: usize, key: &str) -> Result<Cloud, ProblemError> {
    linpd_io::cloud::read_csv(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string()))
}

/// Reads a VTK point cloud of dimension `dim`; `key` is the JSON path of the file name.
pub fn read_vtk(path: &Path, dim: usize, key: &str) -> Result<Cloud, ProblemError> {
    linpd_io::vtk::read_cloud(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string()))
}

/// Reads a Gmsh (`.msh`, [`linpd_io::mesh`]), Exodus II (`.e`, `.exo`, `.ex2`, `.g`,
/// [`linpd_io::exodus`]) or VTK XML (`.vtu`, [`linpd_io::vtk::read_mesh`]) mesh, a node per element, of dimension `dim`; `key` is the JSON path
/// of the file name. Another extension is refused by name.
pub fn read_mesh(path: &Path, dim: usize, key: &str) -> Result<Cloud, ProblemError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("msh") => linpd_io::mesh::read_gmsh(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string())),
        Some("vtu") => {
            linpd_io::vtk::read_mesh(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string()))
        }
        Some("e" | "exo" | "ex2" | "g") => {
            linpd_io::exodus::read_exodus(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string()))
        }
        _ => Err(ProblemError::invalid(
            key,
            format!(
                "{}: not a mesh linpd reads (Gmsh .msh 4.1, Exodus II .e / .exo, VTK XML .vtu; VTK point clouds go in nodes.vtk)",
                path.display()
            ),
        )),
    }
}

/// Reads Peridigm's text discretization ([`linpd_io::mesh`]) of dimension `dim`; `key` is the
/// JSON path of the file name.
pub fn read_peridigm(path: &Path, dim: usize, key: &str) -> Result<Cloud, ProblemError> {
    linpd_io::mesh::read_peridigm(path, dim).map_err(|e| ProblemError::invalid(key, e.to_string()))
}

/// The cloud as the node set of a scene.
pub(crate) fn into_nodes(cloud: Cloud, dim: usize) -> LevelNodes {
    let mut nodes = LevelNodes::new(dim, cloud.positions, cloud.volumes);
    nodes.layer = cloud.layer;
    nodes.phase = cloud.phase;
    nodes.sets = cloud.sets;
    nodes.boundary = cloud.boundary;
    nodes.what = "the point cloud";
    nodes
}

/// What one pass over a whole cloud learns: the scale of its checks and the box its bins cut.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Summary {
    pub(crate) count: usize,
    /// Nodes with the `layer` flag.
    pub(crate) layers: usize,
    /// `sum_i V_i`, added in file order.
    pub(crate) volume_sum: f64,
    pub(crate) max_volume: f64,
    /// `min_i V_i^(1/d)`.
    pub(crate) min_size: f64,
    /// Lower and upper corners of the nodes' box (unused coordinates 0).
    pub(crate) bounds: [linpd_core::Point; 2],
}

impl Summary {
    pub(crate) fn new() -> Self {
        Summary {
            count: 0,
            layers: 0,
            volume_sum: 0.0,
            max_volume: 0.0,
            min_size: f64::INFINITY,
            bounds: [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]],
        }
    }
    pub(crate) fn add(&mut self, x: &linpd_core::Point, v: f64, layer: bool, dim: usize) {
        self.count += 1;
        self.layers += usize::from(layer);
        self.volume_sum += v;
        self.max_volume = self.max_volume.max(v);
        self.min_size = self.min_size.min(v.powf(1.0 / dim as f64));
        for a in 0..3 {
            let x = if a < dim { x[a] } else { 0.0 };
            self.bounds[0][a] = self.bounds[0][a].min(x);
            self.bounds[1][a] = self.bounds[1][a].max(x);
        }
    }
    pub(crate) fn of(positions: &[linpd_core::Point], volumes: &[f64], layer: &[bool], dim: usize) -> Self {
        let mut s = Summary::new();
        for (k, (x, &v)) in positions.iter().zip(volumes).enumerate() {
            s.add(x, v, layer.get(k).copied().unwrap_or(false), dim);
        }
        s
    }
    /// The scales a window of this cloud keeps.
    pub(crate) fn scales(&self) -> linpd_core::family::CloudScales {
        linpd_core::family::CloudScales { min_size: self.min_size, mean_volume: self.volume_sum / self.count as f64 }
    }
    /// Whether a second pass saw the same cloud (every sum in the same order: bit for bit).
    fn same(&self, other: &Summary) -> bool {
        self.count == other.count
            && self.layers == other.layers
            && self.volume_sum.to_bits() == other.volume_sum.to_bits()
            && self.bounds == other.bounds
    }
    /// [`mean_spacing`] of the cloud.
    pub(crate) fn mean_spacing(&self, dim: usize) -> f64 {
        self.scales().mean_volume.powf(1.0 / dim as f64)
    }
    /// The tolerance scale of [`LevelNodes::new`] for the whole cloud.
    pub(crate) fn tolerance_scale(&self) -> f64 {
        let extent = (0..3).map(|a| self.bounds[1][a] - self.bounds[0][a]).fold(0.0f64, f64::max);
        crate::nodes::tolerance_scale(self.min_size, extent)
    }
}

/// The error of a rank whose window holds no node.
fn empty_window(part: Part, slab: &Slab, bins: &Bins) -> ProblemError {
    ProblemError::invalid(
        "nodes",
        format!(
            "rank {} of {}: its slab of the point cloud (bins {}..{} of {} along axis {}, halo included) holds no \
             node: run on fewer ranks",
            part.rank, part.ranks, slab.window.start, slab.window.end, slab.planes, bins.axis
        ),
    )
}

/// Visits a cloud's nodes in file order: a CSV file streamed, or a cloud read whole.
type Visit<'a> = dyn FnMut(&mut dyn FnMut(&CsvNode)) -> Result<(), ProblemError> + 'a;

/// Rank `part`'s window of the cloud `visit` passes over, whose first pass gave `summary` (a
/// second counts the nodes per bin and sums the cloud again, a third keeps the window's
/// nodes): the cloud's bins along its longest axis ([`Bins::over`], a quarter of `reach`, the
/// bonds' longest length), split into runs of about equal node counts ([`Slab::balanced`]),
/// and the halo's bins holding everything within `reaches * reach` of an owned node. The
/// window's nodes, in bin order then file order, and their numbers in the file; no pass holds
/// more than the window and the bins' counts. `changed()` is the error of a cloud that
/// changed between the passes.
fn cut(
    visit: &mut Visit<'_>,
    dim: usize,
    summary: &Summary,
    part: Part,
    (reaches, reach): (usize, f64),
    changed: &dyn Fn() -> ProblemError,
) -> Result<(Cloud, Slab, CloudWindow), ProblemError> {
    let bins = Bins::over(&summary.bounds, dim, reach);
    let mut counts = vec![0usize; bins.count];
    let mut again = Summary::new();
    visit(&mut |node| {
        counts[bins.of_point(&node.x)] += 1;
        again.add(&node.x, node.volume, node.layer, dim);
    })?;
    if !summary.same(&again) {
        return Err(changed());
    }
    let slab = Slab::balanced(&counts, part, bins.halo(reaches as f64 * reach));
    let mut cloud = Cloud::default();
    let (mut file_node, mut bin) = (Vec::new(), Vec::new());
    let mut next = 0u32;
    visit(&mut |node| {
        let b = bins.of_point(&node.x);
        if slab.window.contains(&b) {
            cloud.positions.push(node.x);
            cloud.volumes.push(node.volume);
            cloud.layer.push(node.layer);
            cloud.phase.extend(node.phase);
            cloud.lines.push(node.line);
            file_node.push(next);
            bin.push(b as u32);
        }
        next += 1;
    })?;
    let expected: usize = counts[slab.window.clone()].iter().sum();
    if next as usize != summary.count || cloud.positions.len() != expected {
        return Err(changed());
    }
    if cloud.positions.is_empty() {
        return Err(empty_window(part, &slab, &bins));
    }
    let mut order: Vec<usize> = (0..file_node.len()).collect();
    order.sort_by_key(|&k| (bin[k], file_node[k]));
    let sorted = Cloud {
        positions: order.iter().map(|&k| cloud.positions[k]).collect(),
        volumes: order.iter().map(|&k| cloud.volumes[k]).collect(),
        layer: order.iter().map(|&k| cloud.layer[k]).collect(),
        phase: if cloud.phase.is_empty() { Vec::new() } else { order.iter().map(|&k| cloud.phase[k]).collect() },
        lines: order.iter().map(|&k| cloud.lines[k]).collect(),
        ..Cloud::default()
    };
    let file_node = order.iter().map(|&k| file_node[k]).collect();
    Ok((sorted, slab, CloudWindow { bins, file_node, bounds: summary.bounds }))
}

/// The window's nodes of [`cut`], with the whole cloud's tolerance scale `h` (so that every
/// rank tests regions as the whole scene does) and scales.
fn window_nodes(cloud: Cloud, dim: usize, summary: &Summary) -> LevelNodes {
    let mut nodes = into_nodes(cloud, dim);
    nodes.h = summary.tolerance_scale();
    nodes.whole = Some(summary.scales());
    nodes
}

/// Rank `part`'s window ([`cut`]) of the cloud `whole` read whole (a mesh, a VTK file: their
/// readers checked the duplicates) and summed in `summary`, with the sets' members among the window's nodes and the
/// boundary points in its bins.
pub(crate) fn window(
    whole: Cloud,
    dim: usize,
    summary: &Summary,
    part: Part,
    reach: (usize, f64),
) -> Result<(LevelNodes, Slab, CloudWindow), ProblemError> {
    let mut visit = |f: &mut dyn FnMut(&CsvNode)| {
        for k in 0..whole.positions.len() {
            f(&CsvNode {
                x: whole.positions[k],
                volume: whole.volumes[k],
                layer: whole.layer.get(k).copied().unwrap_or(false),
                phase: whole.phase.get(k).copied(),
                line: whole.lines.get(k).copied().unwrap_or(k as u64),
            });
        }
        Ok(())
    };
    let changed = || ProblemError::invalid("nodes", "the cloud changed while cut");
    let (mut cloud, slab, window) = cut(&mut visit, dim, summary, part, reach, &changed)?;
    let mut new_of = vec![u32::MAX; whole.positions.len()];
    window.file_node.iter().enumerate().for_each(|(k, &n)| new_of[n as usize] = k as u32);
    cloud.sets = whole
        .sets
        .iter()
        .map(|(name, members)| {
            let mut mine: Vec<u32> = members.iter().map(|&n| new_of[n as usize]).filter(|&k| k != u32::MAX).collect();
            mine.sort_unstable();
            (name.clone(), mine)
        })
        .collect();
    cloud.boundary =
        whole.boundary.iter().filter(|b| slab.window.contains(&window.bins.of_point(b))).copied().collect();
    Ok((window_nodes(cloud, dim, summary), slab, window))
}

/// Rank `part`'s window ([`cut`]) of the CSV node file at `path`, streamed
/// ([`linpd_io::cloud::visit_csv`]) after the caller's first pass `summary` (which checked
/// every line), with the duplicates checked among the window's nodes. `key` is the JSON path
/// of the file name.
pub(crate) fn csv_window(
    path: &Path,
    key: &str,
    dim: usize,
    summary: &Summary,
    part: Part,
    reach: (usize, f64),
) -> Result<(LevelNodes, Slab, CloudWindow), ProblemError> {
    let io = |e: linpd_io::IoError| ProblemError::invalid(key, e.to_string());
    let mut visit = |f: &mut dyn FnMut(&CsvNode)| linpd_io::cloud::visit_csv(path, dim, f).map(|_| ()).map_err(io);
    let changed = || ProblemError::invalid(key, format!("{}: the file changed while read", path.display()));
    let (cloud, slab, window) = cut(&mut visit, dim, summary, part, reach, &changed)?;
    // two coincident nodes share a bin or neighbouring ones: the ranks whose windows hold them
    // find them, at the whole cloud's tolerance (named in file order, as a whole read names them)
    let file_node = &window.file_node;
    linpd_io::cloud::check_duplicates_at(&cloud.positions, dim, summary.min_size).map_err(|(a, b)| {
        let (a, b) = if file_node[a] < file_node[b] { (a, b) } else { (b, a) };
        io(linpd_io::cloud::duplicate(path, &cloud, dim, a, b))
    })?;
    Ok((window_nodes(cloud, dim, summary), slab, window))
}
