//! `linpd export --format petsc`: the reduced system of [`crate::export`] in PETSc's binary
//! format ([`linpd_io::petsc`], where the format is described), which `MatLoad`/`VecLoad` (and
//! petsc4py's `Mat().load(Viewer.BINARY(...))`) read on any number of ranks:
//!
//! * `K.petsc`: `A_ff`, row by row (the CSC `A_ff` is transposed on the way out);
//! * `K.petsc.info`: `-matload_block_size d` when the free DOFs come in whole nodes;
//! * `f.petsc`, and `coords.petsc` (per unknown, the coordinate along its own component of its
//!   node's position: the interleaved coordinates `MatNullSpaceCreateRigidBody` reads);
//! * `dofs.csv` as in the Matrix Market export.

use crate::export::ReducedSystem;
use crate::ProblemError;
use linpd_core::Point;
pub use linpd_io::petsc::{
    read_mat, read_vec, whole_nodes_block_size, write_mat, write_vec, PetscInt, PetscMat, MAT_FILE_CLASSID,
    VEC_FILE_CLASSID,
};
use std::path::{Path, PathBuf};

/// File names of a PETSc export, besides `export.json` (`coords.petsc` only when the nodes'
/// positions are known, see [`ReducedSystem::write_petsc`]).
pub const PETSC_FILES: [&str; 5] = ["K.petsc", "K.petsc.info", "f.petsc", "coords.petsc", "dofs.csv"];

impl ReducedSystem {
    /// `d` when every node has all or none of its components free (block rows are nodes),
    /// else 1.
    pub fn block_size(&self) -> usize {
        whole_nodes_block_size(self.dim, &self.free_dofs)
    }

    /// Writes `K.petsc`, `K.petsc.info`, `f.petsc`, `dofs.csv` and, when `positions` has one
    /// point per node, `coords.petsc` into `dir` (which must exist), with PETSc integers of
    /// width `int`; returns their paths.
    pub fn write_petsc(
        &self,
        dir: &Path,
        positions: Option<&[Point]>,
        int: PetscInt,
    ) -> Result<Vec<PathBuf>, ProblemError> {
        let n = self.n();
        let mut paths = Vec::new();

        // A_ff by rows: the CSC of its transpose
        let (cp, ri, val) = (self.k.symbolic().col_ptr(), self.k.symbolic().row_idx(), self.k.val());
        let mut row_len = vec![0usize; n];
        ri.iter().for_each(|&r| row_len[r] += 1);
        let mut row_ptr = vec![0usize; n + 1];
        for r in 0..n {
            row_ptr[r + 1] = row_ptr[r] + row_len[r];
        }
        let mut next = row_ptr.clone();
        let (mut col, mut v) = (vec![0usize; val.len()], vec![0.0; val.len()]);
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                let r = ri[p];
                col[next[r]] = j;
                v[next[r]] = val[p];
                next[r] += 1;
            }
        }
        let k_path = dir.join(PETSC_FILES[0]);
        write_mat(&k_path, int, n, n, &row_ptr, &col, &v)?;
        paths.push(k_path);

        let info = dir.join(PETSC_FILES[1]);
        std::fs::write(&info, format!("-matload_block_size {}\n", self.block_size()))
            .map_err(linpd_io::IoError::os(&info))?;
        paths.push(info);

        let f_path = dir.join(PETSC_FILES[2]);
        write_vec(&f_path, int, &self.f)?;
        paths.push(f_path);

        if let Some(x) = positions.filter(|x| x.len() == self.n_nodes) {
            let coords: Vec<f64> = self.free_dofs.iter().map(|&g| x[g / self.dim][g % self.dim]).collect();
            let c_path = dir.join(PETSC_FILES[3]);
            write_vec(&c_path, int, &coords)?;
            paths.push(c_path);
        }

        // dofs.csv as the Matrix Market export writes it
        let mm = self.write_dofs_csv(dir)?;
        paths.push(mm);
        Ok(paths)
    }

    /// `export.json`'s `format` member for a PETSc export.
    pub fn petsc_format_json(&self, with_coords: bool, int: PetscInt) -> serde_json::Value {
        let bits = 8 * int.width();
        let mut f = serde_json::json!({
            "K.petsc": format!("A_ff: PETSc binary Mat (big-endian, int{bits} indices, CSR rows, 0-based, float64)"),
            "K.petsc.info": format!("-matload_block_size {}", self.block_size()),
            "f.petsc": "f_f - (A u_bar)_f: PETSc binary Vec (big-endian, float64)",
            "dofs.csv": "row,node,component (0-based): the DOF dim * node + component of each row",
        });
        if with_coords {
            f["coords.petsc"] =
                "per row, its node's coordinate along its component: PETSc binary Vec (rigid-body modes)".into();
        }
        f
    }
}
