//! PETSc's binary format for matrices and vectors (`linpd export --format petsc`), which `MatLoad`/`VecLoad` (and petsc4py's `Mat().load(Viewer.BINARY(...))`) read on
//! any number of ranks.
//!
//! # The format (PETSc's `MatView`/`VecView` on a binary viewer)
//!
//! Big-endian throughout; integers are PETSc's `PetscInt`: 32-bit in a default PETSc build
//! ([`PetscInt::I32`]; the writer refuses matrices past `2^31 - 1` rows or entries by name), 64-bit
//! in one configured `--with-64-bit-indices` ([`PetscInt::I64`], e.g. Debian's
//! `python3-petsc4py-64-real`). The class id is a `PetscInt` too, so the readers tell the two
//! apart by it:
//!
//! * Mat (`K.petsc`): `1211216` (`MAT_FILE_CLASSID`), `M`, `N`, `nnz`; then `M` row lengths;
//!   then `nnz` column indices (0-based, row by row, ascending in a row); then `nnz` `float64`
//!   values in the same order. Rows, not columns: the CSC `A_ff` is transposed on the way out.
//! * Vec (`f.petsc`, `coords.petsc`): `1211214` (`VEC_FILE_CLASSID`), `n`, then `n` `float64`.
//! * `K.petsc.info`: options PETSc reads at `MatLoad`: `-matload_block_size d` when the free
//!   DOFs come in whole nodes (every node has all `d` or none of its components free), so that
//!   block row `k` is node `k`'s `d` unknowns; otherwise block size 1 (then the rigid-body modes
//!   cannot be built per block, see `docs/scale-out.md`).
//! * `coords.petsc`: per unknown, the coordinate along its own component of its node's
//!   position: with whole nodes, `x_0, y_0, z_0, x_1, ...`, the interleaved coordinates
//!   `MatNullSpaceCreateRigidBody` reads (block size `d`).
//! * `dofs.csv` as in the Matrix Market export.
//!
//! Written by hand: no Rust crate writes or reads PETSc's binary format (petsc-rs, the only
//! binding, is not on crates.io), and the format is the few lines above. [`read_mat`] and
//! [`read_vec`] read it back, checking the class ids, the sizes and the file length.

use crate::IoError;
use std::io::Write;
use std::path::Path;

/// PETSc's `MAT_FILE_CLASSID`.
pub const MAT_FILE_CLASSID: i32 = 1_211_216;

/// PETSc's `VEC_FILE_CLASSID`.
pub const VEC_FILE_CLASSID: i32 = 1_211_214;

/// A matrix read from a PETSc binary file, in CSR form.
#[derive(Debug, Clone, PartialEq)]
pub struct PetscMat {
    /// Rows `M`.
    pub nrows: usize,
    /// Columns `N`.
    pub ncols: usize,
    /// Row pointers (`M + 1`, from the row lengths).
    pub row_ptr: Vec<usize>,
    /// Column indices (0-based).
    pub col: Vec<usize>,
    /// Values.
    pub val: Vec<f64>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> IoError + '_ {
    move |source| IoError::Io { path: path.display().to_string(), source }
}

fn bad(path: &Path, what: String) -> IoError {
    IoError::Io { path: path.display().to_string(), source: std::io::Error::new(std::io::ErrorKind::InvalidData, what) }
}

/// The width of PETSc's integers (`PetscInt`) in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PetscInt {
    /// 32-bit: a default PETSc build.
    I32,
    /// 64-bit: a PETSc configured `--with-64-bit-indices`.
    I64,
}

impl PetscInt {
    /// Writes `v` as this width's big-endian integer, or an error naming what overflowed.
    fn write(self, w: &mut impl Write, path: &Path, what: &str, v: usize) -> Result<(), IoError> {
        let bytes = match self {
            PetscInt::I32 => match i32::try_from(v) {
                Ok(x) => w.write_all(&x.to_be_bytes()),
                Err(_) => {
                    return Err(bad(
                        path,
                        format!(
                            "{what} = {v} does not fit PETSc's 32-bit indices (at most {}): export with --format \
                             petsc64 for a PETSc built with 64-bit indices (docs/scale-out.md)",
                            i32::MAX
                        ),
                    ))
                }
            },
            PetscInt::I64 => w.write_all(&(v as i64).to_be_bytes()),
        };
        bytes.map_err(io(path))
    }
    /// Bytes per integer.
    pub fn width(self) -> usize {
        match self {
            PetscInt::I32 => 4,
            PetscInt::I64 => 8,
        }
    }
}

/// `d` when the free DOFs (ascending, `d` per node) come in whole nodes, else 1.
pub fn whole_nodes_block_size(dim: usize, free_dofs: &[usize]) -> usize {
    let chunks = free_dofs.chunks_exact(dim);
    let whole = chunks.remainder().is_empty()
        && chunks.into_iter().all(|c| c[0] / dim * dim == c[0] && c.iter().enumerate().all(|(a, &g)| g == c[0] + a));
    if whole {
        dim
    } else {
        1
    }
}

/// Writes a CSR matrix as a PETSc binary Mat with integers of width `int`.
pub fn write_mat(
    path: &Path,
    int: PetscInt,
    nrows: usize,
    ncols: usize,
    row_ptr: &[usize],
    col: &[usize],
    val: &[f64],
) -> Result<(), IoError> {
    // the sizes first, so that an overflow creates no file
    for (what, v) in [("rows", nrows), ("columns", ncols), ("stored entries", val.len())] {
        int.write(&mut std::io::sink(), path, what, v)?;
    }
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io(path))?);
    let e = io(path);
    let header = [MAT_FILE_CLASSID as usize, nrows, ncols, val.len()];
    for (what, v) in ["the class id", "rows", "columns", "stored entries"].into_iter().zip(header) {
        int.write(&mut w, path, what, v)?;
    }
    // every row length and column is at most the sizes checked above
    for r in 0..nrows {
        int.write(&mut w, path, "a row length", row_ptr[r + 1] - row_ptr[r])?;
    }
    for &c in col {
        int.write(&mut w, path, "a column", c)?;
    }
    for &x in val {
        w.write_all(&x.to_be_bytes()).map_err(&e)?;
    }
    w.flush().map_err(&e)
}

/// Writes a vector as a PETSc binary Vec with integers of width `int`.
pub fn write_vec(path: &Path, int: PetscInt, v: &[f64]) -> Result<(), IoError> {
    int.write(&mut std::io::sink(), path, "length", v.len())?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io(path))?);
    let e = io(path);
    int.write(&mut w, path, "the class id", VEC_FILE_CLASSID as usize)?;
    int.write(&mut w, path, "length", v.len())?;
    for &x in v {
        w.write_all(&x.to_be_bytes()).map_err(&e)?;
    }
    w.flush().map_err(&e)
}

/// Big-endian reader over a file's bytes with errors naming the file and the offset.
struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    at: usize,
    int: PetscInt,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], IoError> {
        let end = self.at + N;
        let b = self.bytes.get(self.at..end).ok_or_else(|| {
            bad(self.path, format!("ends at byte {} while reading {what} (at byte {})", self.bytes.len(), self.at))
        })?;
        self.at = end;
        let mut out = [0u8; N];
        out.copy_from_slice(b);
        Ok(out)
    }
    fn int(&mut self, what: &str) -> Result<i64, IoError> {
        Ok(match self.int {
            PetscInt::I32 => i32::from_be_bytes(self.take::<4>(what)?) as i64,
            PetscInt::I64 => i64::from_be_bytes(self.take::<8>(what)?),
        })
    }
    fn size(&mut self, what: &str) -> Result<usize, IoError> {
        let v = self.int(what)?;
        usize::try_from(v).map_err(|_| bad(self.path, format!("{what} = {v} is negative")))
    }
    fn real(&mut self, what: &str) -> Result<f64, IoError> {
        Ok(f64::from_be_bytes(self.take::<8>(what)?))
    }
    fn end(&self) -> Result<(), IoError> {
        if self.at != self.bytes.len() {
            return Err(bad(self.path, format!("{} bytes after the object's end", self.bytes.len() - self.at)));
        }
        Ok(())
    }
    /// Checks that `count` items of `width` bytes remain, before allocating for them.
    fn room(&self, count: usize, width: usize, what: &str) -> Result<(), IoError> {
        if count.saturating_mul(width) > self.bytes.len() - self.at {
            return Err(bad(self.path, format!("too short for {count} {what}")));
        }
        Ok(())
    }
}

/// Reads the class id, and from it the integers' width: a 64-bit id starts with four zero
/// bytes, which no 32-bit id does.
fn classid(r: &mut Reader, want: i32, what: &str) -> Result<(), IoError> {
    if r.bytes.get(..4) == Some(&[0, 0, 0, 0]) {
        r.int = PetscInt::I64;
    }
    let id = r.int("the class id")?;
    if id != want as i64 {
        return Err(bad(r.path, format!("class id {id}, not {want} ({what}): not a PETSc binary {what}")));
    }
    Ok(())
}

/// Reads a PETSc binary Mat (one object, 32- or 64-bit indices) into CSR.
pub fn read_mat(path: &Path) -> Result<PetscMat, IoError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    let r = &mut Reader { path, bytes: &bytes, at: 0, int: PetscInt::I32 };
    classid(r, MAT_FILE_CLASSID, "Mat")?;
    let (nrows, ncols, nnz) = (r.size("M")?, r.size("N")?, r.size("nnz")?);
    r.room(nrows, r.int.width(), "row lengths")?;
    let mut row_ptr = Vec::with_capacity(nrows + 1);
    row_ptr.push(0usize);
    for k in 0..nrows {
        let len = r.size(&format!("the length of row {k}"))?;
        row_ptr.push(row_ptr[k] + len);
    }
    if row_ptr[nrows] != nnz {
        return Err(bad(path, format!("row lengths sum to {}, the header says nnz = {nnz}", row_ptr[nrows])));
    }
    r.room(nnz, r.int.width() + 8, "entries")?;
    let mut col = Vec::with_capacity(nnz);
    for k in 0..nnz {
        let c = r.size("a column index")?;
        if c >= ncols {
            return Err(bad(path, format!("column index {c} of entry {k} is out of range (N = {ncols})")));
        }
        col.push(c);
    }
    let val = (0..nnz).map(|_| r.real("a value")).collect::<Result<Vec<_>, _>>()?;
    r.end()?;
    Ok(PetscMat { nrows, ncols, row_ptr, col, val })
}

/// Reads a PETSc binary Vec (one object).
pub fn read_vec(path: &Path) -> Result<Vec<f64>, IoError> {
    let bytes = std::fs::read(path).map_err(io(path))?;
    let r = &mut Reader { path, bytes: &bytes, at: 0, int: PetscInt::I32 };
    classid(r, VEC_FILE_CLASSID, "Vec")?;
    let n = r.size("n")?;
    r.room(n, 8, "values")?;
    let v = (0..n).map(|_| r.real("a value")).collect::<Result<Vec<_>, _>>()?;
    r.end()?;
    Ok(v)
}
