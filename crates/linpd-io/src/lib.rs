//! Every file format of linpd, once: point clouds from CSV ([`cloud`], on the csv crate), VTK
//! ([`vtk`]: reading through vtkio, and the VTU/PVD writer of results and snapshots), Gmsh MSH
//! 4.1 meshes and Peridigm's text discretization ([`mesh`], mshio) and Exodus II meshes
//! ([`exodus`], netcdf3), a mesh as a node per element with its named sets, Matrix Market and the
//! level files of a coarsened model ([`mtx`]), nodal forces and prescribed displacements by node
//! ([`nodal`]), PETSc's binary matrices and vectors ([`petsc`]). Errors are [`IoError`]: the file, and for text
//! formats the line (or the point) and what is wrong there.
#![deny(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

pub mod cloud;
pub mod exodus;
pub mod mesh;
pub mod mtx;
pub mod nodal;
pub mod petsc;
pub mod vtk;

use thiserror::Error;

/// A file that could not be read or written, or whose content is not what its format needs.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum IoError {
    /// The operating system refused (or the content is invalid, where the format has no lines).
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The content is not what the format needs.
    #[error("{path}{}: {reason}", line.map_or(String::new(), |l| format!(" line {l}")))]
    Format {
        /// The file.
        path: String,
        /// 1-based line (text formats), when the error is on one.
        line: Option<u64>,
        /// What is wrong.
        reason: String,
    },
}

impl IoError {
    /// An OS error on `path`.
    pub fn os(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
        move |source| IoError::Io { path: path.display().to_string(), source }
    }
}
