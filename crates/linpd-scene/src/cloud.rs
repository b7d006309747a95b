//! `"nodes"`: a point cloud read from a file instead of a lattice ([`linpd_io::cloud`] for CSV,
//! [`linpd_io::vtk`] for VTK: the file formats are described there), as the nodes of a scene.
//! Errors start with the JSON path of the file name (`nodes.csv: part.csv line 3: ...`).

use crate::nodes::LevelNodes;
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
