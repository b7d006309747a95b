//! Matrix Market: the writer of `coordinate real general` files ([`write_matrix_market`], for
//! `linpd export` and the levels of `linpd coarsen`) and the level files of a coarsened model
//! ([`ModuliFile`]): a Matrix Market file of the pointwise micromodulus tensor plus a CSV node
//! list, read in one pass with the file and line in every error.
//!
//! # The model a file holds
//!
//! A level-`m` model in dimension `d` has `n` nodes with positions `x_i`, volumes `v_i > 0`, the
//! index `level0[i]` of the node in the level-0 model, and a sparse pointwise micromodulus
//! tensor: a `d x d` block `C_ij = C(x_i, x_j)` for every bonded pair `i != j`. The force density
//! is eq. (4)/(10) discretised,
//!
//! ```text
//! L u_i = sum_{j != i} C_ij (u_j - u_i) v_j,
//! ```
//!
//! and the nodal stiffness `K = -dF/du` of the nodal forces `F_i = v_i L u_i` is
//!
//! ```text
//! K_ij = -v_i v_j C_ij   (i != j),      K_ii = -sum_{j != i} K_ij,
//! ```
//!
//! so every block row of `K` sums to zero (rigid translations cost nothing). `K` is symmetric
//! exactly when `C_ij = C_ji^T` ([`ModuliFile::asymmetry`] measures the departure).
//!
//! # Files, for a stem such as `out/level-1`
//!
//! `out/level-1.mtx`:
//!
//! ```text
//! %%MatrixMarket matrix coordinate real general
//! % linpd coarsened moduli
//! % level 1
//! % dim 2
//! % nodes level-1.nodes.csv
//! % entry (d*i+a+1, d*j+b+1) = C(x_i, x_j)[a][b], pointwise micromodulus tensor; L u_i = sum_j C_ij (u_j - u_i) v_j
//! % written by sprs
//! 2n 2n nnz
//! 1 3 81628.68683476918
//! ...
//! ```
//!
//! Entries are 1-based, values printed by sprs with `{}`, Rust's shortest decimal that reads
//! back to the same bits (positional, no exponent: `1e-300` takes 300 characters, still within
//! the format's 1024 per line); only blocks with `i != j` are stored (the diagonal block follows
//! from the zero row sums), and exact zeros are omitted.
//!
//! # What sprs does and what is done here
//!
//! The matrix is written by `sprs::io::write_matrix_market_to_bufwrite`; sprs takes no comments
//! of ours, so [`write_matrix_market`] inserts the `% level`, `% dim` and `% nodes` lines after
//! the banner as sprs writes it.
//!
//! It is read here, in one pass over the text, not by sprs: sprs skips comments (we need
//! `% dim`, `% level`, `% nodes`), takes any banner containing `real` and `general` (or
//! `symmetric`, which it would mirror), takes a blank line before the size line for the size
//! line, names no line in its errors (`Bad matrix market file.`), asserts (panics) in
//! `TriMat::from_triplets` on an index beyond the size line, allocates the declared entry count
//! before reading one, and ignores lines after the declared count. Every entry line is parsed
//! and checked once (three fields, 1-based indices in range, not in a diagonal block, a finite
//! value: Rust's `f64` parser, correctly rounded, reads sprs's `{}` values back bit for bit),
//! with the file and line in the message; the declared count is checked against the file's
//! size (never an allocation sized by the header) and against the lines found.
//!
//! Comment lines are allowed before the size line only, as the Matrix Market format says.
//!
//! `out/level-1.nodes.csv`: header `x,y,z,volume,level0`, one row per node in level order, unused
//! coordinates 0, floats `{:.17e}`; read with the csv crate, as the point clouds of [`crate::cloud`].

use faer::sparse::{SparseColMat, Triplet};
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The CSV header of a nodes file.
pub const NODES_HEADER: &str = "x,y,z,volume,level0";

const BANNER: &str = "%%MatrixMarket matrix coordinate real general";

/// A problem with a moduli file. Every message starts with the file; syntax errors add the
/// 1-based line and say what was expected.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum MtxError {
    /// The file is missing or unreadable.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A line does not have the expected form.
    #[error("{path}, line {line}: expected {expected}, found `{found}`")]
    Syntax {
        /// The file.
        path: String,
        /// 1-based line (0 when the file ended early).
        line: usize,
        /// What the line should hold.
        expected: String,
        /// The offending text.
        found: String,
    },
    /// A well-formed value that is not allowed (dimension, sizes, indices, values, volumes).
    #[error("{path}, line {line}: {reason}")]
    Invalid {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The number of entry lines differs from the size line.
    #[error("{path}: the size line declares {declared} entries but the file has {found}")]
    EntryCount {
        /// The file.
        path: String,
        /// From the size line.
        declared: usize,
        /// Entry lines read.
        found: usize,
    },
    /// The in-memory model is inconsistent (caught before writing).
    #[error("moduli model: {0}")]
    Model(String),
}

/// A coarsened level model as stored on disk (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ModuliFile {
    /// Coarsening level `m` (0 = the original model).
    pub level: usize,
    /// Dimension `d` in 1..=3.
    pub dim: usize,
    /// Node positions (unused coordinates 0).
    pub positions: Vec<[f64; 3]>,
    /// Node volumes `v_i > 0`.
    pub volumes: Vec<f64>,
    /// Index of each node in the level-0 model.
    pub level0: Vec<usize>,
    /// 0-based scalar entries `(d*i + a, d*j + b, C(x_i, x_j)[a][b])`, `i != j`.
    pub entries: Vec<(usize, usize, f64)>,
}

fn show(p: &Path) -> String {
    p.display().to_string()
}

/// `stem` + `suffix` (appended, so `level-1.5` keeps its dot).
fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Writes a `rows x cols` matrix given by 0-based `(row, col, value)` entries (in range: a
/// contract, sprs asserts it) as Matrix Market `coordinate real general` through sprs, with
/// `comments` (each a `% ` line) right after the banner. sprs prints values with `{}`, the
/// shortest decimal that reads back to the same `f64` bits.
pub fn write_matrix_market(
    path: &Path,
    (rows, cols): (usize, usize),
    entries: impl IntoIterator<Item = (usize, usize, f64)>,
    comments: &[String],
) -> Result<(), MtxError> {
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for (i, j, x) in entries {
        r.push(i);
        c.push(j);
        v.push(x);
    }
    let m = sprs::TriMat::from_triplets((rows, cols), r, c, v);
    let werr = |source| MtxError::Write { path: show(path), source };
    let comments: String = comments.iter().map(|l| format!("% {l}\n")).collect();
    let file = std::fs::File::create(path).map_err(werr)?;
    let mut w = AfterBanner { inner: std::io::BufWriter::new(file), comments: Some(comments) };
    sprs::io::write_matrix_market_to_bufwrite(&mut w, &m).map_err(werr)?;
    w.flush().map_err(werr)
}

/// A writer that inserts `comments` after the first line written through it (sprs writes its
/// banner and then `% written by sprs`; it takes no comments of ours).
struct AfterBanner<W> {
    inner: W,
    comments: Option<String>,
}

impl<W: Write> Write for AfterBanner<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if let (Some(c), Some(k)) = (&self.comments, buf.iter().position(|&b| b == b'\n')) {
            self.inner.write_all(&buf[..=k])?;
            self.inner.write_all(c.as_bytes())?;
            self.comments = None;
            return Ok(k + 1);
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Reads a whole file; devices and pipes (`/dev/urandom`) are refused before reading, since
/// they may never end.
fn read_text(path: &Path) -> Result<String, MtxError> {
    let read = |source| MtxError::Read { path: show(path), source };
    let meta = std::fs::metadata(path).map_err(read)?;
    if !meta.is_file() {
        return Err(read(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file")));
    }
    std::fs::read_to_string(path).map_err(read)
}

/// Longest excerpt of a file's text an error message quotes.
pub const EXCERPT_CHARS: usize = 60;

/// At most [`EXCERPT_CHARS`] characters of `text` for an error message, control characters
/// escaped (`\t`, `\u{1b}`) so that a binary file cannot drive the terminal, `...` when cut.
pub fn excerpt(text: &str) -> String {
    let mut out = String::new();
    for (k, c) in text.chars().enumerate() {
        if k == EXCERPT_CHARS {
            out.push_str("...");
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// Shortest entry line, `1 2 3\n`: a file of `b` bytes has room for at most `b / 6` entries,
/// whatever its size line declares (so the declared count never sizes an allocation).
const MIN_ENTRY_BYTES: usize = 6;

/// The nodes file named by a `% nodes <name>` comment: only a bare file name beside the
/// matrix is followed (no directories, no `..`), so a data file cannot make linpd read, and
/// quote, a file elsewhere (`% nodes /etc/passwd`). `Err`: why the name is refused.
fn companion(dir: &Path, name: &str) -> Result<PathBuf, String> {
    let bare = !name.contains(['/', '\\']) && name != "." && name != ".." && !Path::new(name).has_root();
    if bare {
        Ok(dir.join(name))
    } else {
        Err(format!(
            "`% nodes` must name a file beside the matrix (a bare file name, no directories), got `{}`",
            excerpt(name)
        ))
    }
}

/// `<stem>.nodes.csv` for `<stem>.mtx`.
fn default_nodes_path(mtx_path: &Path) -> PathBuf {
    let s = mtx_path.as_os_str().to_string_lossy();
    PathBuf::from(format!("{}.nodes.csv", s.strip_suffix(".mtx").unwrap_or(&s)))
}

/// The nodes file [`ModuliFile::read`] uses for `mtx_path`: the `% nodes` file beside the
/// matrix when it exists, else `<stem>.nodes.csv` (for messages: an unreadable matrix or a
/// refused name gives the default).
pub fn nodes_path(mtx_path: &Path) -> PathBuf {
    let default = default_nodes_path(mtx_path);
    let dir = mtx_path.parent().unwrap_or(Path::new(""));
    let named = read_text(mtx_path).ok().and_then(|t| {
        t.lines().take_while(|l| l.starts_with('%') || l.trim().is_empty()).find_map(|l| {
            l.strip_prefix('%').map(str::trim).and_then(|c| c.strip_prefix("nodes ")).map(|n| n.trim().to_string())
        })
    });
    match named.and_then(|n| companion(dir, &n).ok()) {
        Some(p) if p.is_file() || !default.is_file() => p,
        _ => default,
    }
}

impl ModuliFile {
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.volumes.len()
    }

    /// Checks the in-memory model: the rules [`ModuliFile::read`] enforces on a file.
    pub fn validate(&self) -> Result<(), MtxError> {
        let d = self.dim;
        let n = self.n_nodes();
        if !(1..=3).contains(&d) {
            return Err(MtxError::Model(format!("dim must be 1, 2 or 3, got {d}")));
        }
        if self.positions.len() != n || self.level0.len() != n {
            return Err(MtxError::Model(format!(
                "{} positions, {} volumes and {} level0 indices: need one of each per node",
                self.positions.len(),
                n,
                self.level0.len()
            )));
        }
        if let Some(i) = self.volumes.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(MtxError::Model(format!("node {i}: volume must be finite and > 0, got {:e}", self.volumes[i])));
        }
        if let Some(i) = self.positions.iter().position(|x| x.iter().any(|c| !c.is_finite())) {
            return Err(MtxError::Model(format!("node {i}: position {:?} is not finite", self.positions[i])));
        }
        for &(r, c, v) in &self.entries {
            if r >= d * n || c >= d * n {
                return Err(MtxError::Model(format!("entry ({r}, {c}) is outside the {0}x{0} matrix", d * n)));
            }
            if r / d == c / d {
                return Err(MtxError::Model(format!("entry ({r}, {c}) lies in the diagonal block of node {}", r / d)));
            }
            if !v.is_finite() {
                return Err(MtxError::Model(format!("entry ({r}, {c}) = {v:e} is not finite")));
            }
        }
        Ok(())
    }

    /// Writes `<stem>.mtx` and `<stem>.nodes.csv` (creating the directory); returns both paths.
    pub fn write(&self, stem: &Path) -> Result<Vec<PathBuf>, MtxError> {
        self.validate()?;
        let mtx = with_suffix(stem, ".mtx");
        let csv = with_suffix(stem, ".nodes.csv");
        let werr = |p: &Path| {
            let p = show(p);
            move |source| MtxError::Write { path: p, source }
        };
        if let Some(dir) = mtx.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(werr(dir))?;
        }
        let d = self.dim;
        let n = self.n_nodes();
        let csv_name = csv.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let comments = [
            "linpd coarsened moduli".to_string(),
            format!("level {}", self.level),
            format!("dim {d}"),
            format!("nodes {csv_name}"),
            "entry (d*i+a+1, d*j+b+1) = C(x_i, x_j)[a][b], pointwise micromodulus tensor; L u_i = sum_j C_ij (u_j - u_i) v_j"
                .to_string(),
        ];
        let kept = self.entries.iter().copied().filter(|e| e.2 != 0.0);
        write_matrix_market(&mtx, (d * n, d * n), kept, &comments)?;
        let mut s = String::new();
        let _ = writeln!(s, "{NODES_HEADER}");
        for i in 0..n {
            let x = self.positions[i];
            let _ =
                writeln!(s, "{:.17e},{:.17e},{:.17e},{:.17e},{}", x[0], x[1], x[2], self.volumes[i], self.level0[i]);
        }
        std::fs::write(&csv, s).map_err(werr(&csv))?;
        Ok(vec![mtx, csv])
    }

    /// Reads `<stem>.mtx` and its nodes file: the name in the `% nodes` comment (beside the
    /// matrix) when that file exists, else `<stem>.nodes.csv`.
    pub fn read(mtx_path: &Path) -> Result<ModuliFile, MtxError> {
        let path = show(mtx_path);
        let text = read_text(mtx_path)?;
        let err = MtxErrors { path: path.clone() };
        // (1-based line, trimmed text)
        let mut lines = text.split_inclusive('\n').enumerate().map(|(k, raw)| (k + 1, raw.trim()));
        let header = read_header(&mut lines, text.len(), &err)?;
        let d = header.dim;
        let csv_path = header.nodes_file(mtx_path, &err)?;
        let (positions, volumes, level0) = read_nodes(&csv_path)?;
        let n = volumes.len();
        if header.rows != d * n {
            return Err(err.invalid(
                header.size_ln,
                format!(
                    "the matrix has {} rows but dim {d} x {n} nodes (in {}) = {} are needed",
                    header.rows,
                    show(&csv_path),
                    d * n
                ),
            ));
        }
        let entries = read_entries(lines, &header, &err)?;
        if entries.len() != header.nnz {
            return Err(MtxError::EntryCount { path, declared: header.nnz, found: entries.len() });
        }
        Ok(ModuliFile { level: header.level, dim: d, positions, volumes, level0, entries })
    }

    /// The nodal stiffness `K` (`d n x d n`, CSC, duplicates summed): `K_ij = -v_i v_j C_ij`
    /// (`i != j`), `K_ii = -sum_{j != i} K_ij`; an error when the model is inconsistent
    /// ([`ModuliFile::validate`]: a file read by [`ModuliFile::read`] never is).
    pub fn stiffness(&self) -> Result<SparseColMat<usize, f64>, MtxError> {
        self.validate()?;
        let d = self.dim;
        let n_dofs = d * self.n_nodes();
        let mut t = Vec::with_capacity(2 * self.entries.len());
        for &(r, c, v) in &self.entries {
            let (i, j, b) = (r / d, c / d, c % d);
            let k = self.volumes[i] * self.volumes[j] * v;
            t.push(Triplet::new(r, c, -k));
            t.push(Triplet::new(r, d * i + b, k));
        }
        SparseColMat::try_new_from_triplets(n_dofs, n_dofs, &t).map_err(|e| MtxError::Model(format!("{e:?}")))
    }

    /// `max |C_ij[a][b] - C_ji[b][a]| / max |C|` (0 for an empty model): the relative departure
    /// from the symmetry `C(x, q) = C(q, x)^T` that makes `K` symmetric.
    pub fn asymmetry(&self) -> f64 {
        let mut m: std::collections::HashMap<(usize, usize), f64> = Default::default();
        for &(r, c, v) in &self.entries {
            *m.entry((r, c)).or_default() += v;
        }
        let max = m.values().fold(0.0f64, |a, v| a.max(v.abs()));
        if max == 0.0 {
            return 0.0;
        }
        let diff = m.iter().fold(0.0f64, |a, (&(r, c), &v)| a.max((v - m.get(&(c, r)).copied().unwrap_or(0.0)).abs()));
        diff / max
    }
}

/// A line of a `.mtx` file: 1-based number, trimmed text.
type Line<'t> = (usize, &'t str);

/// The errors of one `.mtx` file, each naming the file and the line.
struct MtxErrors {
    path: String,
}

impl MtxErrors {
    /// The line does not have the `expected` form.
    fn syntax(&self, line: usize, expected: &str, found: &str) -> MtxError {
        MtxError::Syntax { path: self.path.clone(), line, expected: expected.into(), found: excerpt(found) }
    }
    /// A well-formed line with a value that is not allowed.
    fn invalid(&self, line: usize, reason: String) -> MtxError {
        MtxError::Invalid { path: self.path.clone(), line, reason }
    }
}

/// What a moduli file says before its entries: the banner (checked), the comments we read and
/// the size line.
struct MtxHeader {
    /// `% level <m>` (0 without it).
    level: usize,
    /// `% dim <d>`.
    dim: usize,
    /// `% nodes <name>` and its line.
    nodes_name: Option<(String, usize)>,
    /// Line of the size line.
    size_ln: usize,
    /// The size line: `rows cols entries`.
    rows: usize,
    cols: usize,
    nnz: usize,
}

impl MtxHeader {
    /// The nodes file: the `% nodes` file beside the matrix when it exists (or when the default
    /// does not), else `<stem>.nodes.csv`; a refused name is an error at its line.
    fn nodes_file(&self, mtx_path: &Path, err: &MtxErrors) -> Result<PathBuf, MtxError> {
        let dir = mtx_path.parent().unwrap_or(Path::new(""));
        let default_csv = default_nodes_path(mtx_path);
        Ok(match &self.nodes_name {
            Some((name, ln)) => match companion(dir, name) {
                Ok(p) if p.is_file() || !default_csv.is_file() => p,
                Ok(_) => default_csv,
                Err(why) => return Err(err.invalid(*ln, why)),
            },
            None => default_csv,
        })
    }
}

/// Reads the banner, the comments and the size line from `lines` (left at the first entry
/// line) of a file of `text_len` bytes; checks that the matrix is square and that the declared
/// entry count fits in the file.
fn read_header<'t>(
    lines: &mut impl Iterator<Item = Line<'t>>,
    text_len: usize,
    err: &MtxErrors,
) -> Result<MtxHeader, MtxError> {
    let (ln, banner) = lines.next().unwrap_or((1, ""));
    let toks: Vec<String> = banner.split_whitespace().map(|t| t.to_ascii_lowercase()).collect();
    if toks.len() != 5 || toks[0] != "%%matrixmarket" || toks[1..] != ["matrix", "coordinate", "real", "general"] {
        return Err(err.syntax(ln, &format!("the banner `{BANNER}`"), banner));
    }
    let (level, dim, nodes_name, (size_ln, size_line)) = read_comments(lines, err)?;
    let Some((d, _)) = dim else {
        return Err(err.syntax(size_ln, "a `% dim <d>` comment before the size line", size_line));
    };
    let size: Vec<usize> =
        size_line.split_whitespace().map(|t| t.parse::<usize>()).collect::<Result<_, _>>().unwrap_or_default();
    if size.len() != 3 {
        return Err(err.syntax(size_ln, "a size line `rows cols entries` (three non-negative integers)", size_line));
    }
    let (rows, cols, nnz) = (size[0], size[1], size[2]);
    if rows != cols {
        return Err(err.invalid(size_ln, format!("the matrix must be square, got {rows} rows and {cols} columns")));
    }
    let room = text_len / MIN_ENTRY_BYTES;
    if nnz > room {
        return Err(err.invalid(
            size_ln,
            format!(
                "the size line declares {nnz} entries but the file ({text_len} bytes) has room for at most {room} \
                 (an entry line takes at least {MIN_ENTRY_BYTES} bytes)"
            ),
        ));
    }
    Ok(MtxHeader { level, dim: d, nodes_name, size_ln, rows, cols, nnz })
}

/// `% level`, `% dim` (with its line) and `% nodes` (with its line), and the size line.
type Comments<'t> = (usize, Option<(usize, usize)>, Option<(String, usize)>, Line<'t>);

/// Reads the comment lines after the banner (`% level`, `% dim`, `% nodes`; others and blank
/// lines are skipped) up to the first other line, the size line.
fn read_comments<'t>(lines: &mut impl Iterator<Item = Line<'t>>, err: &MtxErrors) -> Result<Comments<'t>, MtxError> {
    let (mut level, mut dim, mut nodes_name) = (0usize, None::<(usize, usize)>, None::<(String, usize)>);
    let size = loop {
        let Some((ln, l)) = lines.next() else {
            return Err(err.syntax(0, "a size line `rows cols entries`", "end of file"));
        };
        if l.is_empty() {
            continue;
        }
        let Some(c) = l.strip_prefix('%') else { break (ln, l) };
        let mut it = c.split_whitespace();
        match it.next() {
            Some("level") => {
                let v = it.next().unwrap_or("");
                level = v.parse().map_err(|_| err.syntax(ln, "`% level <m>` with a non-negative integer m", l))?;
            }
            Some("dim") => {
                let v = it.next().unwrap_or("");
                let d: usize = v.parse().map_err(|_| err.syntax(ln, "`% dim <d>` with d = 1, 2 or 3", l))?;
                if !(1..=3).contains(&d) {
                    return Err(err.invalid(ln, format!("dim must be 1, 2 or 3, got {d}")));
                }
                dim = Some((d, ln));
            }
            Some("nodes") => {
                let v = c.trim_start().strip_prefix("nodes").unwrap_or("").trim();
                if !v.is_empty() {
                    nodes_name = Some((v.to_string(), ln));
                }
            }
            _ => {}
        }
    };
    Ok((level, dim, nodes_name, size))
}

/// Reads and checks the entry lines (0-based `(row, col, value)`): three fields, 1-based indices
/// in range, not in a diagonal block, a finite value; the file and line in every error.
fn read_entries<'t>(
    lines: impl Iterator<Item = Line<'t>>,
    header: &MtxHeader,
    err: &MtxErrors,
) -> Result<Vec<(usize, usize, f64)>, MtxError> {
    let (d, rows, cols) = (header.dim, header.rows, header.cols);
    let mut entries = Vec::new();
    for (ln, l) in lines {
        if l.is_empty() {
            continue;
        }
        let t: Vec<&str> = l.split_whitespace().collect();
        let parsed = (t.len() == 3).then(|| (t[0].parse::<usize>(), t[1].parse::<usize>(), t[2].parse::<f64>()));
        let Some((Ok(r), Ok(c), Ok(v))) = parsed else {
            return Err(err.syntax(
                ln,
                "an entry `row col value` (1-based integer indices, a real value; comments only before the size line)",
                l,
            ));
        };
        if r == 0 || c == 0 || r > rows || c > cols {
            return Err(
                err.invalid(ln, format!("entry ({r}, {c}) is out of range: indices are 1-based and at most {rows}"))
            );
        }
        if (r - 1) / d == (c - 1) / d {
            return Err(err.invalid(
                ln,
                format!(
                    "entry ({r}, {c}) lies inside the diagonal block of node {}; only bonded pairs i != j are stored \
                     (the diagonal block follows from the zero row sums)",
                    (r - 1) / d
                ),
            ));
        }
        if !v.is_finite() {
            return Err(err.invalid(ln, format!("entry ({r}, {c}) has the non-finite value {}", excerpt(t[2]))));
        }
        entries.push((r - 1, c - 1, v));
    }
    Ok(entries)
}

type Nodes = (Vec<[f64; 3]>, Vec<f64>, Vec<usize>);

/// Reads a level's nodes file (on the csv crate, as the point clouds): the header
/// [`NODES_HEADER`], then `x,y,z,volume,level0` per node; errors name the file and the line.
fn read_nodes(path: &Path) -> Result<Nodes, MtxError> {
    let p = show(path);
    let text = read_text(path)?;
    let syntax = |line: usize, expected: String, found: &str| MtxError::Syntax {
        path: p.clone(),
        line,
        expected,
        found: excerpt(found),
    };
    let mut reader =
        csv::ReaderBuilder::new().has_headers(false).trim(csv::Trim::All).flexible(true).from_reader(text.as_bytes());
    let mut records = reader.records();
    // a record's 1-based line and its text as written (fields joined back), for messages
    let line_of = |r: &csv::StringRecord| r.position().map_or(0, |q| q.line() as usize);
    let joined = |r: &csv::StringRecord| r.iter().collect::<Vec<_>>().join(",");
    let header =
        records.next().transpose().map_err(|e| syntax(1, format!("the header `{NODES_HEADER}`"), &e.to_string()))?;
    let found = header.as_ref().map(joined).unwrap_or_default();
    let norm: String = found.chars().filter(|c| !c.is_whitespace()).collect();
    if norm != NODES_HEADER {
        return Err(syntax(1, format!("the header `{NODES_HEADER}`"), &found));
    }
    let (mut x, mut v, mut l0) = (Vec::new(), Vec::new(), Vec::new());
    for record in records {
        let row = "a row `x,y,z,volume,level0` (four reals and a non-negative integer)".to_string();
        let r = record.map_err(|e| {
            let line = e.position().map_or(0, |q| q.line() as usize);
            syntax(line, row.clone(), &e.to_string())
        })?;
        let (ln, l) = (line_of(&r), joined(&r));
        let nums: Option<Vec<f64>> =
            (r.len() == 5).then(|| r.iter().take(4).map(|s| s.parse::<f64>().ok()).collect()).flatten();
        let idx = (r.len() == 5).then(|| r[4].parse::<usize>().ok()).flatten();
        let (Some(nums), Some(idx)) = (nums, idx) else {
            return Err(syntax(ln, row, &l));
        };
        let node = v.len();
        if nums[..3].iter().any(|c| !c.is_finite()) {
            return Err(MtxError::Invalid {
                path: p,
                line: ln,
                reason: format!("node {node}: the position must be finite, got {:?}", &nums[..3]),
            });
        }
        if !(nums[3].is_finite() && nums[3] > 0.0) {
            return Err(MtxError::Invalid {
                path: p,
                line: ln,
                reason: format!("node {node}: the volume must be finite and > 0, got {}", excerpt(&r[3])),
            });
        }
        x.push([nums[0], nums[1], nums[2]]);
        v.push(nums[3]);
        l0.push(idx);
    }
    Ok((x, v, l0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory under the system temp dir, unique to this process and `tag`.
    fn temp_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("linpd-coarsen-io-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A 2D model on a 3x2 lattice with irrational-looking values (every bit matters) and the
    /// symmetric tensor `C_ij = c_ij n n^T` (n the unit bond vector) within radius 1.5.
    fn sample_2d() -> ModuliFile {
        let mut positions = Vec::new();
        for k in 0..2 {
            for i in 0..3 {
                positions.push([i as f64 * 0.1 + 1.0 / 3.0, k as f64 * 0.1 - 0.7, 0.0]);
            }
        }
        let n = positions.len();
        let volumes: Vec<f64> = (0..n).map(|i| 0.01 * (1.0 + i as f64 / 7.0)).collect();
        let mut entries = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let dx = [positions[j][0] - positions[i][0], positions[j][1] - positions[i][1]];
                let r = dx[0].hypot(dx[1]);
                if i == j || r > 0.15 {
                    continue;
                }
                let e = [dx[0] / r, dx[1] / r];
                let c = (1.0 - r / 0.15) * std::f64::consts::PI;
                for a in 0..2 {
                    for b in 0..2 {
                        entries.push((2 * i + a, 2 * j + b, c * e[a] * e[b]));
                    }
                }
            }
        }
        ModuliFile { level: 2, dim: 2, positions, volumes, level0: (0..n).map(|i| 4 * i + 1).collect(), entries }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let dir = temp_dir("round-trip");
        let mut m = sample_2d();
        m.entries.retain(|e| e.2 != 0.0); // exact zeros are not written
        m.entries.push((0, 3, -1.234_567_890_123_456_7e-300));
        let files = m.write(&dir.join("level-2")).unwrap();
        assert_eq!(files, vec![dir.join("level-2.mtx"), dir.join("level-2.nodes.csv")]);
        let back = ModuliFile::read(&files[0]).unwrap();
        assert_eq!(back.level, 2);
        assert_eq!(back.dim, 2);
        assert_eq!(back.level0, m.level0);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.volumes), bits(&m.volumes));
        for (p, q) in back.positions.iter().zip(&m.positions) {
            assert_eq!(bits(p), bits(q));
        }
        assert_eq!(back.entries.len(), m.entries.len());
        for (p, q) in back.entries.iter().zip(&m.entries) {
            assert_eq!((p.0, p.1, p.2.to_bits()), (q.0, q.1, q.2.to_bits()));
        }
        let text = std::fs::read_to_string(&files[0]).unwrap();
        assert!(text.contains("% nodes level-2.nodes.csv\n"), "{text}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn zeros_are_omitted() {
        let dir = temp_dir("zeros");
        let mut m = sample_2d();
        let with_zeros = m.entries.iter().filter(|e| e.2 == 0.0).count();
        assert!(with_zeros > 0, "the axis-aligned bonds give n n^T zeros");
        m.write(&dir.join("z")).unwrap();
        let back = ModuliFile::read(&dir.join("z.mtx")).unwrap();
        m.entries.retain(|e| e.2 != 0.0);
        assert_eq!(back.entries, m.entries);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn stiffness_has_zero_row_sums_and_is_symmetric() {
        let m = sample_2d();
        assert_eq!(m.asymmetry(), 0.0);
        let k = m.stiffness().unwrap();
        let nd = 2 * m.n_nodes();
        assert_eq!((k.nrows(), k.ncols()), (nd, nd));
        let mut dense = vec![vec![0.0; nd]; nd];
        let (cp, ri) = (k.symbolic().col_ptr(), k.symbolic().row_idx());
        for j in 0..nd {
            for p in cp[j]..cp[j + 1] {
                dense[ri[p]][j] += k.val()[p];
            }
        }
        let scale = dense.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(scale > 0.0);
        // Translations: sum over block columns of K (each component separately) vanishes.
        for r in 0..nd {
            for b in 0..2 {
                let s: f64 = (0..m.n_nodes()).map(|j| dense[r][2 * j + b]).sum();
                assert!(s.abs() <= 1e-15 * scale * nd as f64, "row {r} comp {b}: {s}");
            }
        }
        for r in 0..nd {
            for c in 0..nd {
                assert!((dense[r][c] - dense[c][r]).abs() <= 1e-15 * scale, "K[{r}][{c}]");
            }
        }
        // K = -dF/du: K_ij = -v_i v_j C_ij for one stored entry.
        for &(r, c, v) in &m.entries {
            assert_eq!(dense[r][c], -m.volumes[r / 2] * m.volumes[c / 2] * v, "K[{r}][{c}]");
        }
    }

    #[test]
    fn asymmetry_is_relative() {
        let m = ModuliFile {
            level: 1,
            dim: 1,
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0]],
            volumes: vec![1.0, 1.0],
            level0: vec![0, 2],
            entries: vec![(0, 1, 4.0), (1, 0, 3.0)],
        };
        assert_eq!(m.asymmetry(), 0.25);
    }

    /// Writes a hand-made `.mtx` with the standard nodes file (three 1D nodes) beside it and
    /// returns the read error.
    fn bad(tag: &str, mtx: &str, nodes: Option<&str>) -> String {
        let dir = temp_dir(tag);
        let nodes = nodes.unwrap_or("x,y,z,volume,level0\n0,0,0,0.5,0\n1,0,0,0.5,2\n2,0,0,0.5,4\n");
        std::fs::write(dir.join("m.nodes.csv"), nodes).unwrap();
        std::fs::write(dir.join("m.mtx"), mtx).unwrap();
        let e = ModuliFile::read(&dir.join("m.mtx")).expect_err("the file must be rejected").to_string();
        let _ = std::fs::remove_dir_all(&dir);
        e
    }

    const HEAD: &str = "%%MatrixMarket matrix coordinate real general\n% level 1\n% dim 1\n";

    fn check(e: &str, needles: &[&str]) {
        for n in needles {
            assert!(e.contains(n), "`{n}` not in: {e}");
        }
    }

    #[test]
    fn good_hand_written_file_reads() {
        let dir = temp_dir("good");
        std::fs::write(dir.join("m.nodes.csv"), "x,y,z,volume,level0\n0,0,0,0.5,0\n1,0,0,0.5,2\n").unwrap();
        std::fs::write(dir.join("m.mtx"), format!("{HEAD}% a comment\n2 2 2\n1 2 1.5\n\n2 1 1.5\n")).unwrap();
        let m = ModuliFile::read(&dir.join("m.mtx")).unwrap();
        assert_eq!(m.entries, vec![(0, 1, 1.5), (1, 0, 1.5)]);
        assert_eq!(m.level0, vec![0, 2]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn nodes_comment_names_the_csv() {
        let dir = temp_dir("nodes-comment");
        std::fs::write(dir.join("other.csv"), "x,y,z,volume,level0\n0,0,0,0.5,0\n1,0,0,0.5,2\n").unwrap();
        std::fs::write(dir.join("m.mtx"), format!("{HEAD}% nodes other.csv\n2 2 1\n1 2 1.5\n")).unwrap();
        let m = ModuliFile::read(&dir.join("m.mtx")).unwrap();
        assert_eq!(m.n_nodes(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn missing_files_are_named() {
        let dir = temp_dir("missing");
        let e = ModuliFile::read(&dir.join("none.mtx")).unwrap_err().to_string();
        check(&e, &["none.mtx", "cannot read"]);
        std::fs::write(dir.join("m.mtx"), format!("{HEAD}3 3 0\n")).unwrap();
        let e = ModuliFile::read(&dir.join("m.mtx")).unwrap_err().to_string();
        check(&e, &["m.nodes.csv", "cannot read"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_banner() {
        let e = bad("banner", "%%MatrixMarket matrix array real general\n% dim 1\n3 3\n", None);
        check(&e, &["m.mtx", "line 1", "expected the banner `%%MatrixMarket matrix coordinate real general`", "array"]);
        let e = bad("banner-sym", "%%MatrixMarket matrix coordinate real symmetric\n% dim 1\n3 3 0\n", None);
        check(&e, &["line 1", "symmetric"]);
        let e = bad("banner-empty", "", None);
        check(&e, &["line 1", "expected the banner"]);
    }

    #[test]
    fn missing_dim() {
        let e = bad("no-dim", "%%MatrixMarket matrix coordinate real general\n% level 1\n3 3 0\n", None);
        check(&e, &["m.mtx", "line 3", "expected a `% dim <d>` comment before the size line"]);
    }

    #[test]
    fn dim_out_of_range() {
        let e = bad("dim4", "%%MatrixMarket matrix coordinate real general\n% dim 4\n3 3 0\n", None);
        check(&e, &["m.mtx", "line 2", "dim must be 1, 2 or 3, got 4"]);
        let e = bad("dim-x", "%%MatrixMarket matrix coordinate real general\n% dim two\n3 3 0\n", None);
        check(&e, &["line 2", "expected `% dim <d>`"]);
    }

    #[test]
    fn rows_differ_from_cols() {
        let e = bad("rect", &format!("{HEAD}3 4 0\n"), None);
        check(&e, &["line 4", "must be square, got 3 rows and 4 columns"]);
    }

    #[test]
    fn rows_differ_from_dim_times_nodes() {
        let e = bad("size", &format!("{HEAD}4 4 0\n"), None);
        check(&e, &["line 4", "4 rows", "dim 1 x 3 nodes", "m.nodes.csv", "= 3"]);
    }

    #[test]
    fn bad_size_line() {
        let e = bad("size-line", &format!("{HEAD}3 3\n"), None);
        check(&e, &["line 4", "expected a size line `rows cols entries`", "`3 3`"]);
    }

    #[test]
    fn index_out_of_range() {
        let e = bad("range", &format!("{HEAD}3 3 1\n1 4 1.0\n"), None);
        check(&e, &["line 5", "entry (1, 4) is out of range", "at most 3"]);
        let e = bad("zero-index", &format!("{HEAD}3 3 1\n0 2 1.0\n"), None);
        check(&e, &["line 5", "entry (0, 2) is out of range", "1-based"]);
    }

    #[test]
    fn entry_in_diagonal_block() {
        let e = bad("diag", &format!("{HEAD}3 3 1\n2 2 1.0\n"), None);
        check(&e, &["line 5", "entry (2, 2) lies inside the diagonal block of node 1"]);
        // 2D: (1, 2) is node 0 component 0 against node 0 component 1.
        let nodes = "x,y,z,volume,level0\n0,0,0,0.5,0\n1,0,0,0.5,1\n";
        let e = bad("diag-2d", "%%MatrixMarket matrix coordinate real general\n% dim 2\n4 4 1\n1 2 1.0\n", Some(nodes));
        check(&e, &["line 4", "entry (1, 2) lies inside the diagonal block of node 0"]);
    }

    #[test]
    fn non_finite_value() {
        let e = bad("nan", &format!("{HEAD}3 3 1\n1 2 NaN\n"), None);
        check(&e, &["line 5", "non-finite value NaN"]);
        let e = bad("inf", &format!("{HEAD}3 3 1\n1 2 inf\n"), None);
        check(&e, &["line 5", "non-finite value inf"]);
    }

    #[test]
    fn bad_entry_line() {
        let e = bad("entry", &format!("{HEAD}3 3 1\n1 2\n"), None);
        check(&e, &["line 5", "expected an entry `row col value`", "`1 2`"]);
        let e = bad("entry-x", &format!("{HEAD}3 3 1\n1 2 x\n"), None);
        check(&e, &["line 5", "expected an entry"]);
    }

    #[test]
    fn wrong_entry_count() {
        let e = bad("count", &format!("{HEAD}3 3 3\n1 2 1.0\n2 1 1.0\n"), None);
        check(&e, &["m.mtx", "declares 3 entries but the file has 2"]);
    }

    #[test]
    fn csv_header_wrong() {
        let e = bad("header", &format!("{HEAD}3 3 0\n"), Some("x,y,z,vol,level0\n0,0,0,1,0\n"));
        check(&e, &["m.nodes.csv", "line 1", "expected the header `x,y,z,volume,level0`", "x,y,z,vol,level0"]);
    }

    #[test]
    fn csv_row_malformed() {
        let e = bad("row", &format!("{HEAD}3 3 0\n"), Some("x,y,z,volume,level0\n0,0,0,1\n"));
        check(&e, &["m.nodes.csv", "line 2", "expected a row `x,y,z,volume,level0`"]);
        let e = bad("row-level0", &format!("{HEAD}3 3 0\n"), Some("x,y,z,volume,level0\n0,0,0,1,-1\n"));
        check(&e, &["line 2", "non-negative integer"]);
    }

    #[test]
    fn bad_volumes() {
        let e = bad("vol0", &format!("{HEAD}3 3 0\n"), Some("x,y,z,volume,level0\n0,0,0,1,0\n1,0,0,0,1\n"));
        check(&e, &["m.nodes.csv", "line 3", "node 1: the volume must be finite and > 0, got 0"]);
        let e = bad("vol-neg", &format!("{HEAD}3 3 0\n"), Some("x,y,z,volume,level0\n0,0,0,-2,0\n"));
        check(&e, &["line 2", "node 0", "got -2"]);
        let e = bad("vol-nan", &format!("{HEAD}3 3 0\n"), Some("x,y,z,volume,level0\n0,0,0,NaN,0\n"));
        check(&e, &["line 2", "got NaN"]);
    }

    /// A size line declaring more entries than the file can hold is an error naming the file
    /// and line, not a capacity-overflow panic or an allocation abort.
    #[test]
    fn item_2_mtx_huge_count_is_an_error() {
        for nnz in ["18446744073709551615", "1000000000000000"] {
            let e = bad("huge", &format!("{HEAD}3 3 {nnz}\n1 2 1.0\n"), None);
            check(&e, &["m.mtx", "line 4", &format!("declares {nnz} entries"), "room for at most"]);
        }
    }

    /// `% nodes` follows a bare file name beside the matrix only: absolute paths and `..` are
    /// refused before anything is read, and nothing of the named file is quoted.
    #[test]
    fn item_2_mtx_no_path_following() {
        let dir = temp_dir("no-follow");
        let secret = dir.join("secret.csv");
        std::fs::write(&secret, "TOP-SECRET first line\n").unwrap();
        let sub = dir.join("sub");
        std::fs::create_dir_all(&sub).unwrap();
        for name in [secret.display().to_string(), "../secret.csv".into(), "/etc/passwd".into(), "..".into()] {
            std::fs::write(sub.join("m.mtx"), format!("{HEAD}% nodes {name}\n3 3 0\n")).unwrap();
            let e = ModuliFile::read(&sub.join("m.mtx")).unwrap_err().to_string();
            check(&e, &["m.mtx", "line 4", "`% nodes` must name a file beside the matrix"]);
            assert!(!e.contains("TOP-SECRET") && !e.contains("root:"), "{e}");
        }
        // The message helper agrees: a refused name falls back to `<stem>.nodes.csv`.
        assert_eq!(nodes_path(&sub.join("m.mtx")), sub.join("m.nodes.csv"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Quoted file text is short and escaped: a binary line cannot reach the terminal raw.
    #[test]
    fn item_2_mtx_excerpts_are_short_and_escaped() {
        let line = format!("\u{1b}[2J\u{7}{}", "x".repeat(500));
        let e = bad("escape", &format!("{HEAD}3 3 1\n{line}\n"), None);
        check(&e, &["line 5", "\\u{1b}[2J\\u{7}", "..."]);
        assert!(!e.chars().any(|c| c.is_control()), "{e:?}");
        assert!(e.len() < 300, "{} chars: {e}", e.len());
        if Path::new("/dev/zero").exists() {
            let e = ModuliFile::read(Path::new("/dev/zero")).unwrap_err().to_string();
            check(&e, &["/dev/zero", "not a regular file"]);
        }
    }

    /// Comment lines after the size line: Matrix Market allows them in the header only (and sprs
    /// reads none there); the message names the line.
    #[test]
    fn comment_among_entries_is_refused_with_its_line() {
        let e = bad("comment-entry", &format!("{HEAD}3 3 1\n% late\n1 2 1.0\n"), None);
        check(&e, &["m.mtx", "line 5", "expected an entry", "comments only before the size line", "`% late`"]);
    }

    /// Blank lines between the comments and the size line, and trailing blank lines: sprs's
    /// own header parser would take the blank line for the size line; ours skips it.
    #[test]
    fn blank_lines_around_the_size_line_read() {
        let dir = temp_dir("blank-size");
        std::fs::write(dir.join("m.nodes.csv"), "x,y,z,volume,level0\n0,0,0,0.5,0\n1,0,0,0.5,2\n").unwrap();
        std::fs::write(dir.join("m.mtx"), format!("{HEAD}\n\r\n2 2 2\r\n1 2 1.5\r\n2 1 -0.25\n\n")).unwrap();
        let m = ModuliFile::read(&dir.join("m.mtx")).unwrap();
        assert_eq!(m.entries, vec![(0, 1, 1.5), (1, 0, -0.25)]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// What `write` produces is plain Matrix Market: sprs's own reader gives back the entries,
    /// bit for bit, and our comments sit between the banner and the size line.
    #[test]
    fn written_file_is_plain_matrix_market() {
        let dir = temp_dir("plain-mm");
        let mut m = sample_2d();
        m.entries.retain(|e| e.2 != 0.0);
        m.write(&dir.join("p")).unwrap();
        let t: sprs::TriMat<f64> = sprs::io::read_matrix_market(dir.join("p.mtx")).unwrap();
        assert_eq!((t.rows(), t.cols()), (12, 12));
        let back: Vec<(usize, usize, u64)> =
            t.row_inds().iter().zip(t.col_inds()).zip(t.data()).map(|((&r, &c), v)| (r, c, v.to_bits())).collect();
        let want: Vec<(usize, usize, u64)> = m.entries.iter().map(|&(r, c, v)| (r, c, v.to_bits())).collect();
        assert_eq!(back, want);
        let text = std::fs::read_to_string(dir.join("p.mtx")).unwrap();
        let head: Vec<&str> = text.lines().take(8).collect();
        assert_eq!(head[0], BANNER);
        assert_eq!(&head[1..5], ["% linpd coarsened moduli", "% level 2", "% dim 2", "% nodes p.nodes.csv"]);
        assert_eq!(head[6], "% written by sprs");
        assert_eq!(head[7], format!("12 12 {}", m.entries.len()));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn write_refuses_inconsistent_models() {
        let dir = temp_dir("write-bad");
        let mut m = sample_2d();
        m.entries.push((0, 1, 1.0));
        let e = m.write(&dir.join("w")).unwrap_err().to_string();
        check(&e, &["diagonal block of node 0"]);
        let mut m = sample_2d();
        m.volumes[3] = 0.0;
        check(&m.write(&dir.join("w")).unwrap_err().to_string(), &["node 3", "volume"]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
