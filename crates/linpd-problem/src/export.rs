//! `linpd export`: the reduced linear system of a static scene, for another solver.
//!
//! A static solve eliminates the prescribed displacements ([`linpd_solve::bc`]): with
//! `u = u_bar + u_f`, the free equations are
//!
//! ```text
//! A_ff u_f = f_f - (A u_bar)_f.
//! ```
//!
//! [`reduced_system`] (`Commands::reduced_system`) builds the scene's model as [`Problem::solve`] does and returns
//! `A_ff` and the right-hand side from [`linpd_solve::reduced_system`], the function the static
//! solve's assembled path calls: the same matrix (every stored entry, explicit zeros included:
//! the pattern a factorization sees), the same checks and the same error messages. A scene
//! whose solver is matrix-free CG gets `A_ff` assembled by [`linpd_core::Model::assemble_free`],
//! the operator that CG applies without storing it. Every model builds the system as for its
//! solve ([`crate::models::SceneModel::system`]; 1D blend and CE scenes: the operator of their
//! own solve, [`linpd_blend::constraints_and_loads`]); dynamics scenes export their static
//! problem (what `linpd solve` solves). A model without [`Capability::Export`] is refused.
//!
//! # Files ([`ReducedSystem::write`])
//!
//! * `K.mtx`: `A_ff`, Matrix Market `coordinate real general`, 1-based indices, every stored
//!   entry, values as sprs prints them (the shortest decimal that reads back to the same bits).
//!   General rather than symmetric storage: half the file for a symmetric `A_ff`, but blend,
//!   CE-blend and coarsened levels are unsymmetric, and one layout for all is simpler to read.
//! * `f.mtx`: the right-hand side, an `n x 1` coordinate matrix with all `n` entries (zeros
//!   included), same format.
//! * `dofs.csv`: `row,node,component` (0-based), one line per unknown: row `r` of `K.mtx` (line
//!   `r + 1` in its 1-based indices) is component `component` of node `node`, the DOF
//!   `dim * node + component` of `result.json`'s `u`.
//!
//! `export.json` (written last by [`crate::OutputDir::commit`]) holds the sizes, the symmetry
//! and the run's identity (the scene's hash, the files and their sizes).

use crate::models::{Capability, Purpose};
use crate::scene::Problem;
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_core::sparse::{relative_asymmetry, Csc};
use linpd_core::DofMap;
use linpd_io::mtx::{write_matrix_market, MtxError};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// File names of an export, besides `export.json`.
pub const EXPORT_FILES: [&str; 3] = ["K.mtx", "f.mtx", "dofs.csv"];

/// The reduced system `A_ff u_f = f_f - (A u_bar)_f` of a scene (see the module docs).
#[derive(Debug, Clone)]
pub struct ReducedSystem {
    /// Scene name.
    pub name: String,
    /// The model kind (`"bond"`, `"lps"`, `"coarsened"`, `"blend"`, `"ce"`).
    pub model: &'static str,
    /// Dimension `d` (DOFs per node).
    pub dim: usize,
    /// Number of nodes.
    pub n_nodes: usize,
    /// `A_ff` (CSC, both triangles, sorted rows in each column).
    pub k: Csc,
    /// `f_f - (A u_bar)_f`.
    pub f: Vec<f64>,
    /// The full DOF (`d * node + component`) of every row of `A_ff`.
    pub free_dofs: Vec<usize>,
}

/// The reduced system the static solve of this scene factors or iterates (see the module
/// docs); the errors are those of [`Problem::solve`] before its solver runs.
pub fn reduced_system(p: &Problem, progress: &dyn Progress) -> Result<ReducedSystem, ProblemError> {
    p.model().require(Capability::Export)?;
    let s = p.model().system(p, Purpose::Assembled, progress)?;
    let model = s.model();
    let (k, f) = linpd_solve::reduced_system(model, &s.bc, &s.f, progress).map_err(|e| p.model().static_error(e))?;
    Ok(ReducedSystem {
        name: p.name().to_string(),
        model: model.kind(),
        dim: model.dim(),
        n_nodes: model.n_nodes(),
        k,
        f,
        free_dofs: s.bc.dofs().free_dofs(),
    })
}

impl ReducedSystem {
    /// Number of unknowns (rows of `A_ff`).
    pub fn n(&self) -> usize {
        self.k.nrows()
    }

    /// Stored entries of `A_ff`.
    pub fn nnz(&self) -> usize {
        self.k.val().len()
    }

    /// The free/constrained split of the scene's DOFs.
    pub fn dof_map(&self) -> DofMap {
        let mut constrained = vec![true; self.dim * self.n_nodes];
        self.free_dofs.iter().for_each(|&g| constrained[g] = false);
        DofMap::new(self.dim, &constrained)
    }

    /// Writes `K.mtx`, `f.mtx` and `dofs.csv` into `dir` (which must exist); returns their paths.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ProblemError> {
        let n = self.n();
        let paths: Vec<PathBuf> = EXPORT_FILES.iter().map(|f| dir.join(f)).collect();
        let written = |e: MtxError| match e {
            MtxError::Write { path, source } => ProblemError::Io { path, source },
            other => {
                ProblemError::Io { path: dir.display().to_string(), source: std::io::Error::other(other.to_string()) }
            }
        };
        let (cp, ri, val) = (self.k.symbolic().col_ptr(), self.k.symbolic().row_idx(), self.k.val());
        let entries = (0..n).flat_map(|j| (cp[j]..cp[j + 1]).map(move |p| (ri[p], j, val[p])));
        let about = |what: &str| {
            vec![
                format!("linpd {what} of the reduced system A_ff u_f = f_f - (A u_bar)_f"),
                format!("model {}, dim {}, {} nodes", self.model, self.dim, self.n_nodes),
                "row r (1-based) is the unknown `row = r - 1` of dofs.csv (0-based)".to_string(),
            ]
        };
        write_matrix_market(&paths[0], (n, n), entries, &about("stiffness A_ff")).map_err(written)?;
        let rhs = self.f.iter().enumerate().map(|(r, &v)| (r, 0, v));
        write_matrix_market(&paths[1], (n, 1), rhs, &about("right-hand side f_f - (A u_bar)_f")).map_err(written)?;
        self.write_dofs_csv(dir)?;
        Ok(paths)
    }

    /// Writes `dofs.csv` (`row,node,component`, 0-based) into `dir`; returns its path.
    pub fn write_dofs_csv(&self, dir: &Path) -> Result<PathBuf, ProblemError> {
        let path = dir.join(EXPORT_FILES[2]);
        let mut s = String::from("row,node,component\n");
        for (r, &g) in self.free_dofs.iter().enumerate() {
            let _ = writeln!(s, "{r},{},{}", g / self.dim, g % self.dim);
        }
        std::fs::write(&path, s).map_err(|source| ProblemError::Io { path: path.display().to_string(), source })?;
        Ok(path)
    }

    /// The main document `export.json` (without the `"run"` member [`crate::OutputDir::commit`]
    /// adds).
    pub fn to_json(&self) -> serde_json::Value {
        let asymmetry = relative_asymmetry(&self.k);
        json!({
            "name": self.name,
            "model": self.model,
            "dimension": self.dim,
            "nodes": self.n_nodes,
            "dofs": self.dim * self.n_nodes,
            "n": self.n(),
            "nnz": self.nnz(),
            "asymmetry": asymmetry,
            "symmetric": asymmetry <= linpd_core::sparse::SYMMETRY_RTOL,
            "format": {
                "K.mtx": "A_ff: Matrix Market coordinate real general, 1-based, every stored entry",
                "f.mtx": "f_f - (A u_bar)_f: Matrix Market coordinate real general, n x 1, every entry",
                "dofs.csv": "row,node,component (0-based): the DOF dim * node + component of each row",
            },
        })
    }
}
