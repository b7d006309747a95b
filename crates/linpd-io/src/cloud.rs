//! `"nodes"`: a point cloud read from a file instead of a lattice.
//!
//! A CSV file (`"nodes": {"csv": "file.csv"}`) has a header naming its columns and one node per
//! line:
//!
//! ```text
//! x,y,volume,phase,layer
//! 0.0,0.0,1e-4,0,1
//! ```
//!
//! `x`, `y` (2D and 3D), `z` (3D) and `volume` are required, `phase` (an integer >= 0, for
//! `model.material.phases` entries that name a phase instead of a region) and `layer` (0 or 1:
//! the node belongs to a constraint layer outside the body; only reported, as for grids) are
//! optional; the order of the columns is free, lines starting with `#` are comments. Every
//! value is checked: finite coordinates, volumes > 0, no two nodes closer than
//! [`DUPLICATE_RTOL`] times the smallest node size `min_i V_i^(1/d)`. An error names the file
//! and its line.
//!
//! The file is read in a stream (its size is capped at [`MAX_CLOUD_BYTES`]), so no count in it
//! decides an allocation.

use crate::IoError;
use linpd_core::Point;
use std::path::Path;

/// The largest point-cloud file read (1 GiB: ~15 million 3D nodes at 70 bytes a line).
pub const MAX_CLOUD_BYTES: u64 = 1 << 30;

/// Two nodes closer than this times the smallest node size `min_i V_i^(1/d)` are duplicates
/// (the same relative tolerance as the lattice's geometry tests).
pub const DUPLICATE_RTOL: f64 = linpd_core::GEOMETRY_RTOL;

/// Named node sets: per name the nodes (ascending, no repeats).
pub type Sets = std::collections::BTreeMap<String, Vec<u32>>;

/// The columns of a node file.
#[derive(Debug, Default)]
struct Columns {
    coord: [Option<usize>; 3],
    volume: Option<usize>,
    phase: Option<usize>,
    layer: Option<usize>,
}

/// A node file's nodes: positions, volumes, layer flags and phase numbers (empty when the
/// file has no `phase` column), and a mesh's named node sets.
#[derive(Debug, Clone, Default)]
pub struct Cloud {
    /// Positions (unused coordinates 0).
    pub positions: Vec<Point>,
    /// Volumes `V_i > 0`.
    pub volumes: Vec<f64>,
    /// Layer flags (all false without a `layer` column).
    pub layer: Vec<bool>,
    /// Phase numbers (empty without a `phase` column).
    pub phase: Vec<u32>,
    /// 1-based file line of each node (a VTK file: its 0-based point number; a Gmsh mesh: its
    /// element's tag), for messages.
    pub lines: Vec<u64>,
    /// Named node sets of a mesh (read by `crate::mesh`; empty for CSV and VTK files).
    pub sets: Sets,
    /// Points on a mesh's boundary: the centroid and corners of every face (edge in 2D) that
    /// one element only has (the Gmsh, Exodus and VTU readers); empty for CSV, VTK point and
    /// Peridigm files, which carry no topology.
    pub boundary: Vec<Point>,
}

/// Reads a CSV point cloud of dimension `dim`; errors name the file and the line.
pub fn read_csv(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    let mut cloud = Cloud::default();
    let columns = visit_csv(path, dim, &mut |node| {
        cloud.positions.push(node.x);
        cloud.volumes.push(node.volume);
        cloud.layer.push(node.layer);
        if let Some(p) = node.phase {
            cloud.phase.push(p);
        }
        cloud.lines.push(node.line);
    })?;
    debug_assert!(columns.phase || cloud.phase.is_empty());
    let size = cloud.volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64)));
    check_duplicates_at(&cloud.positions, dim, size).map_err(|(a, b)| duplicate(path, &cloud, dim, a, b))?;
    Ok(cloud)
}

/// The error of node `b` coinciding with node `a` of a CSV file's `cloud`.
pub fn duplicate(path: &Path, cloud: &Cloud, dim: usize, a: usize, b: usize) -> IoError {
    CsvErrors { path: path.display().to_string() }.at(
        cloud.lines[b],
        format!(
            "the node at {:?} coincides with the node of line {} (closer than {DUPLICATE_RTOL:e} node sizes)",
            &cloud.positions[b][..dim],
            cloud.lines[a]
        ),
    )
}

/// One data line of a CSV node file.
#[derive(Debug, Clone, Copy)]
pub struct CsvNode {
    /// Position (unused coordinates 0).
    pub x: Point,
    /// Volume, `> 0`.
    pub volume: f64,
    /// Layer flag (false without a `layer` column).
    pub layer: bool,
    /// Phase number (`None` without a `phase` column).
    pub phase: Option<u32>,
    /// 1-based line in the file.
    pub line: u64,
}

/// The optional columns a CSV node file has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CsvColumns {
    /// Whether it has a `phase` column.
    pub phase: bool,
}

/// Visits every node of the CSV file at `path` in file order, each line checked as
/// [`read_csv`] checks it (every check but the duplicates', which needs the nodes), holding
/// one line at a time: a distributed solve's ranks stream the file to keep their part of it.
pub fn visit_csv(path: &Path, dim: usize, visit: &mut dyn FnMut(&CsvNode)) -> Result<CsvColumns, IoError> {
    let err = CsvErrors { path: path.display().to_string() };
    let mut reader = open_csv(path, &err)?;
    let headers = reader.headers().map_err(|e| err.at(1, format!("unreadable header ({e})")))?.clone();
    // the reader now stands at the start of the line after the header
    let hline = reader.position().line().saturating_sub(1).max(1);
    let cols = Columns::of_header(&headers, dim).map_err(|reason| err.at(hline, reason))?;
    let Some(volume_col) = cols.volume else {
        return Err(err.at(hline, "missing column \"volume\"".into()));
    };
    // every coordinate column of the dimension is present (checked by of_header)
    let coord_cols: Vec<usize> = cols.coord[..dim].iter().flatten().copied().collect();
    let mut record = csv::StringRecord::new();
    let mut count = 0u64;
    loop {
        let more = reader.read_record(&mut record).map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            err.at(line, format!("unreadable ({e})"))
        })?;
        if !more {
            break;
        }
        let line = record.position().map_or(0, |p| p.line());
        if record.len() != headers.len() {
            return Err(err.at(line, format!("{} fields, the header has {}", record.len(), headers.len())));
        }
        let node = Node { record: &record, line, err: &err };
        let x = node.position(&coord_cols)?;
        let volume = node.volume(volume_col)?;
        let layer = cols.layer.map(|k| node.layer(k)).transpose()?.unwrap_or(false);
        let phase = cols.phase.map(|k| node.phase(k)).transpose()?;
        if count == u32::MAX as u64 {
            return Err(err.at(line, "more than 2^32 - 1 nodes".into()));
        }
        count += 1;
        visit(&CsvNode { x, volume, layer, phase, line });
    }
    if reader.position().byte() > MAX_CLOUD_BYTES {
        return Err(err.whole(format!("grew beyond {MAX_CLOUD_BYTES} bytes while read")));
    }
    if count == 0 {
        return Err(err.at(hline, "no nodes (a header and no data lines)".into()));
    }
    Ok(CsvColumns { phase: cols.phase.is_some() })
}

/// The errors of one node file: at a line, or of the whole file.
pub(crate) struct CsvErrors {
    pub(crate) path: String,
}

impl CsvErrors {
    pub(crate) fn at(&self, line: u64, reason: String) -> IoError {
        IoError::Format { path: self.path.clone(), line: Some(line), reason }
    }
    pub(crate) fn whole(&self, reason: String) -> IoError {
        IoError::Format { path: self.path.clone(), line: None, reason }
    }
}

/// A CSV reader of the node file at `path` (a regular file of at most [`MAX_CLOUD_BYTES`],
/// read through a cap one byte beyond, so a file that grows while read is noticed).
pub(crate) fn open_csv(path: &Path, err: &CsvErrors) -> Result<csv::Reader<std::io::Take<std::fs::File>>, IoError> {
    let meta = std::fs::metadata(path).map_err(|e| err.whole(e.to_string()))?;
    if !meta.is_file() {
        return Err(err.whole("not a regular file".into()));
    }
    if meta.len() > MAX_CLOUD_BYTES {
        return Err(err.whole(format!("{} bytes, more than a node file may hold ({MAX_CLOUD_BYTES})", meta.len())));
    }
    let file = std::fs::File::open(path).map_err(|e| err.whole(e.to_string()))?;
    use std::io::Read;
    Ok(csv::ReaderBuilder::new()
        .has_headers(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(file.take(MAX_CLOUD_BYTES + 1)))
}

/// The coordinate names, by axis.
const NAMES: [&str; 3] = ["x", "y", "z"];

impl Columns {
    /// The columns named by `headers`: each known at most once, the coordinates of a
    /// `dim`-dimensional cloud and no others. `Err`: why the header is refused.
    fn of_header(headers: &csv::StringRecord, dim: usize) -> Result<Columns, String> {
        let mut cols = Columns::default();
        for (k, name) in headers.iter().enumerate() {
            let slot = match name {
                "x" => &mut cols.coord[0],
                "y" => &mut cols.coord[1],
                "z" => &mut cols.coord[2],
                "volume" => &mut cols.volume,
                "phase" => &mut cols.phase,
                "layer" => &mut cols.layer,
                other => {
                    return Err(format!("unknown column {other:?} (the columns are x, y, z, volume, phase and layer)"))
                }
            };
            if slot.is_some() {
                return Err(format!("column {name:?} appears twice"));
            }
            *slot = Some(k);
        }
        for (a, name) in NAMES.iter().enumerate() {
            match (a < dim, cols.coord[a].is_some()) {
                (true, false) => {
                    return Err(format!("missing column {name:?} (a {dim}D cloud needs {})", NAMES[..dim].join(", ")))
                }
                (false, true) => return Err(format!("column {name:?} in a {dim}D scene")),
                _ => {}
            }
        }
        Ok(cols)
    }
}

/// One data line of a node file, read field by field.
struct Node<'a> {
    record: &'a csv::StringRecord,
    line: u64,
    err: &'a CsvErrors,
}

impl Node<'_> {
    /// The finite number in column `k` (`name` for messages).
    fn number(&self, k: usize, name: &str) -> Result<f64, IoError> {
        let s = &self.record[k];
        let v: f64 = s.parse().map_err(|_| self.err.at(self.line, format!("{name} = {s:?} is not a number")))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err.at(self.line, format!("{name} = {s} is not finite")))
        }
    }
    /// The position from the coordinate columns `coord_cols` (unused coordinates 0).
    fn position(&self, coord_cols: &[usize]) -> Result<Point, IoError> {
        let mut x = [0.0; 3];
        for a in 0..coord_cols.len() {
            x[a] = self.number(coord_cols[a], NAMES[a])?;
        }
        Ok(x)
    }
    /// The volume in column `k`, > 0.
    fn volume(&self, k: usize) -> Result<f64, IoError> {
        let v = self.number(k, "volume")?;
        if v <= 0.0 {
            return Err(self.err.at(self.line, format!("volume = {v:e} must be > 0")));
        }
        Ok(v)
    }
    /// The layer flag in column `k`: 0 or 1.
    fn layer(&self, k: usize) -> Result<bool, IoError> {
        match &self.record[k] {
            "0" => Ok(false),
            "1" => Ok(true),
            s => Err(self.err.at(self.line, format!("layer = {s:?} must be 0 or 1"))),
        }
    }
    /// The phase number in column `k`: an integer >= 0.
    fn phase(&self, k: usize) -> Result<u32, IoError> {
        let s = &self.record[k];
        s.parse().map_err(|_| self.err.at(self.line, format!("phase = {s:?} must be an integer >= 0")))
    }
}

/// The first pair of nodes closer than [`DUPLICATE_RTOL`] `min_i V_i^(1/d)`, in O(n): the
/// positions are hashed into cells of that size, and each node is compared only with the
/// earlier nodes of its `3^d` neighbouring cells, stopping at the first close pair. A cell
/// holds at most a few nodes before a pair is found (nodes farther apart than the cell size),
/// so even a file of identical points costs one comparison per node (a full family at the
/// tolerance, the previous check, was O(n^2) on coincident points: 7 s and 1.6 GB for 20,000).
///
/// `Ok` or `Err((a, b))` with `a < b`: node `b` is the first node (in file order) that
/// coincides with an earlier one, `a`.
pub fn check_duplicates(cloud: &Cloud, dim: usize) -> Result<(), (usize, usize)> {
    let size = cloud.volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64)));
    check_duplicates_at(&cloud.positions, dim, size)
}

/// [`check_duplicates`] of `positions` for the smallest node size `size` (a rank's part of a
/// cloud checks its nodes against the whole cloud's).
pub fn check_duplicates_at(positions: &[Point], dim: usize, size: f64) -> Result<(), (usize, usize)> {
    let tol = DUPLICATE_RTOL * size;
    if !(tol > 0.0 && tol.is_finite()) {
        return Ok(());
    }
    // The same criterion as a family at the tolerance (BondFamily::from_points): within
    // `tol^2 (1 + GEOMETRY_RTOL)`, cells slightly larger than `tol` so that rounding of
    // `x / cell` never separates such a pair by more than one cell.
    let cell_size = tol * (1.0 + 1e-6);
    let r2 = tol * tol * (1.0 + linpd_core::GEOMETRY_RTOL);
    let cell = |x: &Point| -> [i64; 3] {
        let mut c = [0i64; 3];
        for a in 0..dim {
            // saturating: a cloud spanning more than 2^63 tolerances shares its outermost cells
            c[a] = (x[a] / cell_size).floor() as i64;
        }
        c
    };
    let span = |a: usize| if a < dim { -1i64..=1 } else { 0..=0 };
    let mut cells: std::collections::HashMap<[i64; 3], Vec<u32>> = std::collections::HashMap::new();
    for (i, x) in positions.iter().enumerate() {
        let c = cell(x);
        for d2 in span(2) {
            for d1 in span(1) {
                for d0 in span(0) {
                    let key = [c[0].saturating_add(d0), c[1].saturating_add(d1), c[2].saturating_add(d2)];
                    for &j in cells.get(&key).map_or(&[][..], |v| v.as_slice()) {
                        let y = &positions[j as usize];
                        let d: f64 = (0..dim).map(|a| (y[a] - x[a]).powi(2)).sum();
                        if d <= r2 {
                            return Err((j as usize, i));
                        }
                    }
                }
            }
        }
        cells.entry(c).or_default().push(i as u32);
    }
    Ok(())
}

/// The mean node spacing `(sum_i V_i / n)^(1/d)` of a cloud: the scale of its horizon checks
/// and memory estimate (a lattice's spacing `h` when the cloud is one).
pub fn mean_spacing(volumes: &[f64], dim: usize) -> f64 {
    (volumes.iter().sum::<f64>() / volumes.len() as f64).powf(1.0 / dim as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("linpd-cloud-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn error(name: &str, text: &str, dim: usize) -> String {
        read_csv(&write(name, text), dim).unwrap_err().to_string()
    }

    #[test]
    fn reads_columns_in_any_order_with_comments() {
        let p = write("ok.csv", "# a cloud\nvolume,y,x,layer,phase\n0.25,0,0,1,2\n0.25,0,0.5,0,0\n");
        let c = read_csv(&p, 2).unwrap();
        assert_eq!(c.positions, vec![[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]);
        assert_eq!(c.volumes, vec![0.25, 0.25]);
        assert_eq!(c.layer, vec![true, false]);
        assert_eq!(c.phase, vec![2, 0]);
        assert_eq!(c.lines, vec![3, 4]);
    }

    /// Each bad file names the file, the line and the cause.
    #[test]
    fn bad_files_name_the_line() {
        let e = error("m.csv", "x,volume\n0,1\n", 2);
        assert!(e.ends_with("m.csv line 1: missing column \"y\" (a 2D cloud needs x, y)"), "{e}");
        let e = error("v.csv", "x,y\n0,1\n", 2);
        assert!(e.contains("line 1: missing column \"volume\""), "{e}");
        let e = error("n.csv", "x,y,volume\n0,0,1\n0,1,-1\n", 2);
        assert!(e.contains("n.csv line 3: volume = -1e0 must be > 0"), "{e}");
        let e = error("nan.csv", "x,y,volume\n0,0,1\nNaN,1,1\n", 2);
        assert!(e.contains("line 3: x = NaN is not finite"), "{e}");
        let e = error("d.csv", "x,y,volume\n0,0,1\n1,0,1\n0,0,1\n", 2);
        assert!(e.contains("d.csv line 4: the node at [0.0, 0.0] coincides with the node of line 2"), "{e}");
        let e = error("f.csv", "x,y,volume\n0,0,1\n1,0\n", 2);
        assert!(e.contains("line 3: 2 fields, the header has 3"), "{e}");
        let e = error("u.csv", "x,y,volume,colour\n0,0,1,3\n", 2);
        assert!(e.contains("line 1: unknown column \"colour\""), "{e}");
        let e = error("z.csv", "x,y,z,volume\n0,0,0,1\n", 2);
        assert!(e.contains("column \"z\" in a 2D scene"), "{e}");
        let e = error("l.csv", "x,volume,layer\n0,1,2\n", 1);
        assert!(e.contains("line 2: layer = \"2\" must be 0 or 1"), "{e}");
        let e = error("p.csv", "x,volume,phase\n0,1,-1\n", 1);
        assert!(e.contains("line 2: phase = \"-1\" must be an integer >= 0"), "{e}");
        let e = error("e.csv", "x,volume\n", 1);
        assert!(e.contains("no nodes"), "{e}");
        let e = error("t.csv", "x,volume\n0,abc\n", 1);
        assert!(e.contains("line 2: volume = \"abc\" is not a number"), "{e}");
        let e = read_csv(Path::new("/nonexistent/c.csv"), 1).unwrap_err().to_string();
        assert!(e.starts_with("/nonexistent/c.csv: "), "{e}");
    }
}
