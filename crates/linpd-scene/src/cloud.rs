//! `"nodes"`: a point cloud read from a file instead of a lattice ([`linpd_io::cloud`] for CSV,
//! [`linpd_io::vtk`] for VTK: the file formats are described there), as the nodes of a scene.
//! Errors start with the JSON path of the file name (`nodes.csv: part.csv line 3: ...`).

use crate::nodes::LevelNodes;
use crate::part::{Bins, CloudWindow, Part, Slab};
use crate::ProblemError;
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

/// Rank `part`'s window of the whole cloud `whole` ([`crate::part`]): the cloud's bins along
/// its longest axis ([`Bins::of`], a quarter of `reach`, the bonds' longest length), split
/// into runs of about equal node counts ([`Slab::balanced`]), and the halo's bins holding
/// everything within `reaches * reach` of an owned node. The window's nodes are in bin order,
/// then in file order; they keep the whole cloud's tolerance scale `h` (so that every rank
/// tests regions as the whole scene does), phases, layers, the sets' members among them and
/// the boundary points in the window's bins.
pub(crate) fn window(
    whole: LevelNodes,
    part: Part,
    reaches: usize,
    reach: f64,
) -> Result<(LevelNodes, Slab, CloudWindow), ProblemError> {
    let bins = Bins::of(&whole.positions, whole.dim, reach);
    let mut bounds = [[0.0; 3]; 2];
    for a in 0..whole.dim {
        bounds[0][a] = whole.positions.iter().map(|x| x[a]).fold(f64::INFINITY, f64::min);
        bounds[1][a] = whole.positions.iter().map(|x| x[a]).fold(f64::NEG_INFINITY, f64::max);
    }
    let bin: Vec<u32> = whole.positions.iter().map(|x| bins.of_point(x) as u32).collect();
    let mut counts = vec![0usize; bins.count];
    bin.iter().for_each(|&b| counts[b as usize] += 1);
    let slab = Slab::balanced(&counts, part, bins.halo(reaches as f64 * reach));
    let mut kept: Vec<u32> =
        (0..bin.len() as u32).filter(|&n| slab.window.contains(&(bin[n as usize] as usize))).collect();
    kept.sort_by_key(|&n| (bin[n as usize], n));
    if kept.is_empty() {
        return Err(ProblemError::invalid(
            "nodes",
            format!(
                "rank {} of {}: its slab of the point cloud (bins {}..{} of {} along axis {}, halo included) holds \
                 no node: run on fewer ranks",
                part.rank, part.ranks, slab.window.start, slab.window.end, slab.planes, bins.axis
            ),
        ));
    }
    let pick = |v: &[u32]| -> Vec<u32> {
        if v.is_empty() {
            Vec::new()
        } else {
            kept.iter().map(|&n| v[n as usize]).collect()
        }
    };
    let mut new_of = vec![u32::MAX; bin.len()];
    kept.iter().enumerate().for_each(|(k, &n)| new_of[n as usize] = k as u32);
    let sets = whole
        .sets
        .iter()
        .map(|(name, members)| {
            let mut mine: Vec<u32> = members.iter().map(|&n| new_of[n as usize]).filter(|&k| k != u32::MAX).collect();
            mine.sort_unstable();
            (name.clone(), mine)
        })
        .collect();
    let boundary = whole.boundary.iter().filter(|b| slab.window.contains(&bins.of_point(b))).copied().collect();
    let nodes = LevelNodes {
        dim: whole.dim,
        positions: kept.iter().map(|&n| whole.positions[n as usize]).collect(),
        volumes: kept.iter().map(|&n| whole.volumes[n as usize]).collect(),
        h: whole.h,
        layer: if whole.layer.is_empty() {
            Vec::new()
        } else {
            kept.iter().map(|&n| whole.layer[n as usize]).collect()
        },
        phase: pick(&whole.phase),
        what: whole.what,
        sets,
        boundary,
    };
    Ok((nodes, slab, CloudWindow { bins, file_node: kept, bounds }))
}
