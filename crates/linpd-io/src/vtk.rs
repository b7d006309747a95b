//! VTK: a point cloud read from a VTK file by `vtkio` ([`read_cloud`], `"nodes": {"vtk": ...}`),
//! and the VTU / PVD writer of results and snapshots ([`write_vtu`], [`write_pvd`]).
//!
//! Reading:
//!
//! XML files (`.vtu` unstructured grids, `.vtp` poly data; ascii, base64 binary, zlib
//! compressed, as ParaView, meshio and linpd's own `result.vtu` write them) and legacy `.vtk`
//! files. The nodes are the file's points (every piece, in order; cells are ignored), their
//! volumes the point array `volume` (required; in a legacy file also an array of a `FIELD`, as
//! meshio writes them), and the optional point arrays `layer` (0/1)
//! and `phase` (integers >= 0) play the roles of the CSV columns ([`crate::cloud`]). In 1D and
//! 2D the unused coordinates must be 0. Pieces stored in other files (parallel formats) are
//! not followed: a data file names no other file linpd reads. Errors name the file and the
//! point (0-based, as in the file).

use crate::cloud::{Cloud, MAX_CLOUD_BYTES};
use crate::IoError;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;
use vtkio::model::{Attribute, Attributes, DataSet, IOBuffer, Piece};

/// Nodes a task of [`write_vtu_cells`] formats at once.
const FORMAT_CHUNK: usize = 8192;

/// Reads a VTK point cloud of dimension `dim`; errors name the file and the point.
pub fn read_cloud(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    let shown = path.display().to_string();
    let fail = |reason: String| IoError::Format { path: shown.clone(), line: None, reason };
    let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".into()));
    }
    if meta.len() > MAX_CLOUD_BYTES {
        return Err(fail(format!("{} bytes, more than a node file may hold ({MAX_CLOUD_BYTES})", meta.len())));
    }
    let vtk = vtkio::Vtk::import(path).map_err(|e| {
        // vtkio's legacy parser says only "Parse error: Digit" about a wrong POINTS count
        let text = std::fs::read(path).unwrap_or_default();
        match legacy_points_mismatch(&String::from_utf8_lossy(&text)) {
            Some((line, reason)) => IoError::Format { path: shown.clone(), line: Some(line), reason },
            None => fail(format!("not a readable VTK file ({e})")),
        }
    })?;
    let parts = match vtk.data {
        DataSet::UnstructuredGrid { pieces, .. } => inline(pieces, |p| (p.points, p.data)),
        DataSet::PolyData { pieces, .. } => inline(pieces, |p| (p.points, p.data)),
        _ => Err("holds no unstructured grid or poly data (point sets are read from those)".into()),
    }
    .map_err(fail)?;
    let mut cloud = Cloud::default();
    let (mut has_layer, mut has_phase) = (None, None);
    for (points, data) in &parts {
        let x: Vec<f64> = points.cast_into().ok_or_else(|| fail("points are not numbers".into()))?;
        let n = x.len() / 3;
        let first = cloud.positions.len();
        // a data array of that name, or an array of a legacy FIELD (as meshio writes .vtk)
        let array = |name: &str| -> Result<Option<Vec<f64>>, IoError> {
            let buffer = data.point.iter().find_map(|a| match a {
                Attribute::DataArray(a) if a.name == name => Some(&a.data),
                Attribute::Field { data_array, .. } => data_array.iter().find(|f| f.name == name).map(|f| &f.data),
                _ => None,
            });
            let Some(buffer) = buffer else { return Ok(None) };
            let v: Vec<f64> = buffer.cast_into().ok_or_else(|| fail(format!("point array {name:?} is not numeric")))?;
            if v.len() != n {
                return Err(fail(format!(
                    "point array {name:?} has {} values for {n} points (one per point)",
                    v.len()
                )));
            }
            Ok(Some(v))
        };
        let volume = array("volume")?.ok_or_else(|| fail("no point array \"volume\" (the node volumes)".into()))?;
        let layer = array("layer")?;
        let phase = array("phase")?;
        // every piece has the optional arrays or none does
        for (seen, now, name) in
            [(&mut has_layer, layer.is_some(), "layer"), (&mut has_phase, phase.is_some(), "phase")]
        {
            if *seen.get_or_insert(now) != now {
                return Err(fail(format!("point array {name:?} is in some pieces only")));
            }
        }
        for k in 0..n {
            let g = first + k;
            let p = [x[3 * k], x[3 * k + 1], x[3 * k + 2]];
            if let Some(a) = (0..3).find(|&a| !p[a].is_finite()) {
                return Err(fail(format!("point {g}: coordinate {a} = {} is not finite", p[a])));
            }
            if let Some(a) = (dim..3).find(|&a| p[a] != 0.0) {
                return Err(fail(format!("point {g}: coordinate {a} = {:e} in a {dim}D scene (must be 0)", p[a])));
            }
            let v = volume[k];
            if !(v.is_finite() && v > 0.0) {
                return Err(fail(format!("point {g}: volume = {v:e} must be > 0")));
            }
            if let Some(l) = &layer {
                cloud.layer.push(match l[k] {
                    0.0 => false,
                    1.0 => true,
                    other => return Err(fail(format!("point {g}: layer = {other} must be 0 or 1"))),
                });
            }
            if let Some(ph) = &phase {
                let t = ph[k];
                if !(t >= 0.0 && t.fract() == 0.0 && t <= u32::MAX as f64) {
                    return Err(fail(format!("point {g}: phase = {t} must be an integer >= 0")));
                }
                cloud.phase.push(t as u32);
            }
            cloud.positions.push(p);
            cloud.volumes.push(v);
            cloud.lines.push(g as u64);
        }
    }
    if cloud.positions.is_empty() {
        return Err(fail("no points".into()));
    }
    if cloud.positions.len() > u32::MAX as usize {
        return Err(fail("more than 2^32 - 1 points".into()));
    }
    if cloud.layer.is_empty() {
        cloud.layer = vec![false; cloud.positions.len()];
    }
    crate::cloud::check_duplicates(&cloud, dim).map_err(|(a, b)| {
        fail(format!(
            "point {b} at {:?} coincides with point {a} (closer than {:e} node sizes)",
            &cloud.positions[b][..dim],
            crate::cloud::DUPLICATE_RTOL
        ))
    })?;
    Ok(cloud)
}

/// Reads the cells of a VTK XML unstructured grid (`.vtu`) as a mesh of
/// dimension `dim`, a PD node per cell (`"nodes": {"mesh": "part.vtu"}`): see
/// [`crate::mesh`] for what a node per element is. Read: linear triangles, quads and pixels in
/// 2D, tetrahedra, hexahedra, voxels and wedges in 3D (VTK's corner orders mapped to Gmsh's:
/// a wedge's triangles are reversed, a pixel's and voxel's corners are lexicographic).
///
/// * **Phases and sets**: the integer cell array `phase`, or meshio's `gmsh:physical` (what
///   `meshio convert part.msh part.vtu` writes), gives each cell of the scene's dimension its
///   phase, and every value `k >= 1` a set named `"k"` (VTK files carry no group names). A
///   lower-dimensional cell with value `k` (a face, edge or vertex) adds to set `"k"` the
///   cells that contain all its vertices (the cells it bounds). Without such an array there
///   are no sets and every phase is 0.
/// * Errors name the file and the cell (0-based, as in the file): inverted and degenerate
///   cells, cells of a higher dimension than the scene's, cell types not read, points out of
///   range.
pub fn read_mesh(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    use linpd_core::Point;
    let shown = path.display().to_string();
    let fail = |reason: String| IoError::Format { path: shown.clone(), line: None, reason };
    crate::mesh::check_size(path)?;
    let vtk = vtkio::Vtk::import(path).map_err(|e| fail(format!("not a readable VTK file ({e})")))?;
    let pieces = match vtk.data {
        DataSet::UnstructuredGrid { pieces, .. } => pieces,
        _ => return Err(fail("holds no unstructured grid (a mesh's cells are read from one)".into())),
    };
    let mut cloud = Cloud::default();
    let mut orientation = 0.0f64;
    // per PD node its cell's vertices (global point numbers); lower cells: (vertices, tag)
    let mut vertices: Vec<Vec<u64>> = Vec::new();
    let mut lower: Vec<(Vec<u64>, u32)> = Vec::new();
    let (mut kinds, mut all_points) = (Vec::new(), Vec::new());
    let (mut first_point, mut cell_number) = (0u64, 0usize);
    for piece in pieces {
        let piece = match piece {
            Piece::Inline(p) => *p,
            Piece::Source(file, _) => {
                return Err(fail(format!("a piece is stored in {file:?}: pieces in other files are not followed")))
            }
            Piece::Loaded(_) => return Err(fail("a piece loaded from another file".into())),
        };
        let x: Vec<f64> = piece.points.cast_into().ok_or_else(|| fail("points are not numbers".into()))?;
        let points: Vec<Point> = x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let (connectivity, offsets) = piece.cells.cell_verts.into_xml();
        // legacy files version >= 5 give the offsets a leading zero
        let offsets: Vec<u64> = match offsets.first() {
            Some(0) if offsets.len() == piece.cells.types.len() + 1 => offsets[1..].to_vec(),
            _ => offsets,
        };
        if offsets.len() != piece.cells.types.len() {
            return Err(fail(format!("{} cell types for {} cells", piece.cells.types.len(), offsets.len())));
        }
        let tags: Option<Vec<f64>> = ["phase", "gmsh:physical"].iter().find_map(|name| {
            piece.data.cell.iter().find_map(|a| match a {
                Attribute::DataArray(a) if a.name == *name => a.data.clone().cast_into::<f64>(),
                _ => None,
            })
        });
        if tags.as_ref().is_some_and(|t| t.len() != offsets.len()) {
            return Err(fail("the cell array \"phase\" (or \"gmsh:physical\") has not one value per cell".into()));
        }
        let mut start = 0usize;
        for (k, (&end, &kind)) in offsets.iter().zip(&piece.cells.types).enumerate() {
            let c = cell_number + k;
            let end = end as usize;
            if end < start || end > connectivity.len() {
                return Err(fail(format!("cell {c}: offsets out of order or past the connectivity")));
            }
            let local = &connectivity[start..end];
            start = end;
            if let Some(&p) = local.iter().find(|&&p| p as usize >= points.len()) {
                return Err(fail(format!("cell {c}: point {p} is not in the piece's {} points", points.len())));
            }
            let tag = match &tags {
                Some(t) if !(t[k] >= 0.0 && t[k].fract() == 0.0 && t[k] <= u32::MAX as f64) => {
                    return Err(fail(format!("cell {c}: phase {} is not an integer >= 0", t[k])))
                }
                Some(t) => t[k] as u32,
                None => 0,
            };
            let (edim, gmsh, order) = vtk_cell(kind).ok_or_else(|| {
                fail(format!(
                    "cell {c}: {kind:?} cells are not read (linear triangles, quads, pixels, tetrahedra, \
                     hexahedra, voxels and wedges are)"
                ))
            })?;
            if local.len() != order.len() {
                return Err(fail(format!("cell {c}: {kind:?} with {} points, not {}", local.len(), order.len())));
            }
            // the corners in Gmsh's order (sets test membership only; faces need the order)
            let global: Vec<u64> = order.iter().map(|&i| first_point + local[i]).collect();
            if edim > dim {
                return Err(fail(format!("cell {c}: a {edim}D {kind:?} in a mesh for a {dim}D scene")));
            }
            if edim < dim {
                if tag > 0 {
                    lower.push((global, tag));
                }
                continue;
            }
            let corners: Vec<Point> = order.iter().map(|&i| points[local[i] as usize]).collect();
            if dim == 2 {
                if let Some(p) = corners.iter().find(|p| p[2] != 0.0) {
                    return Err(fail(format!("cell {c}: z = {:e}: a 2D scene's mesh lies in z = 0", p[2])));
                }
            }
            let (v, centroid) = gmsh
                .and_then(|t| crate::mesh::measure(t, &corners))
                .ok_or_else(|| fail(format!("cell {c}: {kind:?} cells make no {dim}D node")))?;
            let v = crate::mesh::oriented_volume(dim, &mut orientation, v)
                .map_err(|why| fail(format!("cell {c} {why}")))?;
            let n = cloud.positions.len() as u32;
            cloud.positions.push(centroid);
            cloud.volumes.push(v);
            cloud.layer.push(false);
            cloud.phase.push(tag);
            cloud.lines.push(c as u64);
            if tag > 0 {
                cloud.sets.entry(tag.to_string()).or_default().push(n);
            }
            kinds.push(gmsh);
            vertices.push(global);
        }
        cell_number += offsets.len();
        first_point += points.len() as u64;
        all_points.extend(points);
    }
    if cloud.positions.is_empty() {
        return Err(fail(format!("has no {dim}D cell")));
    }
    bounded_sets(&mut cloud, &vertices, &lower);
    let faces = vertices.iter().zip(&kinds).flat_map(|(vs, k)| {
        k.map_or(&[][..], crate::mesh::faces).iter().map(move |f| f.iter().map(|&i| vs[i]).collect())
    });
    cloud.boundary = crate::mesh::boundary_points(faces, |v| all_points[v as usize]);
    crate::mesh::tidy_sets(&mut cloud);
    Ok(cloud)
}

/// A VTK cell type read as a mesh element: its dimension, Gmsh's element type (for
/// [`crate::mesh::measure`]; `None` for vertices and lines, which only bound) and VTK's corners
/// in Gmsh's order (a wedge's triangles turn the other way, pixels and voxels are
/// lexicographic).
fn vtk_cell(kind: vtkio::model::CellType) -> Option<(usize, Option<mshio::mshfile::ElementType>, &'static [usize])> {
    use mshio::mshfile::ElementType;
    use vtkio::model::CellType;
    Some(match kind {
        CellType::Vertex => (0, None, &[0]),
        CellType::Line => (1, None, &[0, 1]),
        CellType::Triangle => (2, Some(ElementType::Tri3), &[0, 1, 2]),
        CellType::Quad => (2, Some(ElementType::Qua4), &[0, 1, 2, 3]),
        CellType::Pixel => (2, Some(ElementType::Qua4), &[0, 1, 3, 2]),
        CellType::Tetra => (3, Some(ElementType::Tet4), &[0, 1, 2, 3]),
        CellType::Hexahedron => (3, Some(ElementType::Hex8), &[0, 1, 2, 3, 4, 5, 6, 7]),
        CellType::Voxel => (3, Some(ElementType::Hex8), &[0, 1, 3, 2, 4, 5, 7, 6]),
        CellType::Wedge => (3, Some(ElementType::Pri6), &[0, 2, 1, 3, 5, 4]),
        _ => return None,
    })
}

/// Adds to set `"k"` the nodes whose cell contains every vertex of a lower-dimensional cell
/// tagged `k` (`lower`: its vertices and tag; `vertices`: each node's cell's).
fn bounded_sets(cloud: &mut Cloud, vertices: &[Vec<u64>], lower: &[(Vec<u64>, u32)]) {
    let mut by_vertex: std::collections::HashMap<u64, Vec<u32>> = std::collections::HashMap::new();
    for (n, vs) in vertices.iter().enumerate() {
        for &p in vs {
            by_vertex.entry(p).or_default().push(n as u32);
        }
    }
    for (side, tag) in lower {
        // the set exists even when its cells bound nothing (a constraint on it is then named)
        let set = cloud.sets.entry(tag.to_string()).or_default();
        let Some(candidates) = side.first().and_then(|p| by_vertex.get(p)) else { continue };
        set.extend(candidates.iter().copied().filter(|&n| side.iter().all(|p| vertices[n as usize].contains(p))));
    }
}

/// In an ASCII legacy VTK file, `(line, why)` when the count of a `POINTS n type` line (1-based
/// `line`) does not match the numbers that follow it before the next keyword (`3 n` of them).
fn legacy_points_mismatch(text: &str) -> Option<(u64, String)> {
    let mut lines = text.lines().enumerate();
    if !lines.next()?.1.trim_start().starts_with("# vtk DataFile")
        || !text.lines().nth(2)?.trim().eq_ignore_ascii_case("ascii")
    {
        return None;
    }
    let (at, head) =
        lines.find(|(_, l)| l.split_whitespace().next().is_some_and(|w| w.eq_ignore_ascii_case("POINTS")))?;
    let n: usize = head.split_whitespace().nth(1)?.parse().ok()?;
    let mut count = 0usize;
    let mut next = None;
    'scan: for (k, line) in lines {
        for w in line.split_whitespace() {
            if w.parse::<f64>().is_err() {
                next = Some((k, w.to_string()));
                break 'scan;
            }
            count += 1;
        }
    }
    if count == 3 * n {
        return None;
    }
    let end = match next {
        Some((k, w)) => format!("before `{w}` on line {}", k + 1),
        None => "before the end of the file".into(),
    };
    Some((
        at as u64 + 1,
        format!(
            "the POINTS count does not match the data: `POINTS {n}` declares {n} points ({} coordinates), but {count} \
             numbers follow ({end}); set the count to the number of points",
            3 * n
        ),
    ))
}

/// The points and point data of every piece stored in the file itself.
fn inline<P>(
    pieces: Vec<Piece<P>>,
    split: impl Fn(P) -> (IOBuffer, Attributes),
) -> Result<Vec<(IOBuffer, Attributes)>, String> {
    pieces
        .into_iter()
        .map(|p| match p {
            Piece::Inline(p) => Ok(split(*p)),
            Piece::Source(file, _) => {
                Err(format!("a piece is stored in {file:?}: pieces in other files are not followed"))
            }
            Piece::Loaded(_) => Err("a piece loaded from another file".into()),
        })
        .collect()
}

/// The values of a [`PointArray`], computed per node on demand.
pub enum PointValues<'a> {
    /// `components` `Float64` numbers per node: `value(node, component)`.
    Float64 {
        /// Components per node (VTK's `NumberOfComponents`: 3 for vectors, 9 for tensors).
        components: usize,
        /// `value(node, component)`.
        value: &'a (dyn Fn(usize, usize) -> f64 + Sync),
    },
    /// One `UInt8` per node (flags).
    UInt8(&'a dyn Fn(usize) -> u8),
    /// One `UInt32` per node (node numbers).
    UInt32(&'a dyn Fn(usize) -> u32),
}

/// One point-data array of a VTU file.
pub struct PointArray<'a> {
    /// Its name (`u`, `layer`, `strain`, ...).
    pub name: &'a str,
    /// Its values.
    pub values: PointValues<'a>,
}

/// Writes nodes as VTK XML `UnstructuredGrid` (ParaView, VisIt, meshio, pyvista): the points
/// `x` (3 coordinates, 0-padded beyond `dim`), one vertex cell per node and the point data
/// `arrays`. ASCII with the shortest numbers that read back bit for bit (`ryu`, formatted in
/// parallel: 4-5x faster than `{:.16e}` and a third shorter).
/// Written by hand: the format is a fixed XML skeleton around number lists, and the Rust VTK
/// crates (`vtkio`) pull in a large dependency tree for it. Used by `linpd solve`
/// (`result.vtu`) and `linpd run` (`u_<step>.vtu`).
pub fn write_vtu(path: &Path, dim: usize, x: &[[f64; 3]], arrays: &[PointArray]) -> Result<(), IoError> {
    write_vtu_cells(path, dim, x, arrays, None)
}

/// Cells of one VTK type over the points of a VTU file: `connectivity` holds `per_cell` point
/// indices per cell, in VTK's order for `vtk_type` (9 = `VTK_QUAD`, 12 = `VTK_HEXAHEDRON`).
#[derive(Debug, Clone, PartialEq)]
pub struct Cells {
    /// The VTK cell type.
    pub vtk_type: u8,
    /// Points per cell.
    pub per_cell: usize,
    /// Point indices, `per_cell` per cell.
    pub connectivity: Vec<usize>,
}

/// [`write_vtu`] with `cells` instead of one vertex cell per point (`None`: vertices), so that
/// a reader draws the field over the cells (a blended model's graded element mesh).
pub fn write_vtu_cells(
    path: &Path,
    dim: usize,
    x: &[[f64; 3]],
    arrays: &[PointArray],
    cells: Option<&Cells>,
) -> Result<(), IoError> {
    let n = x.len();
    let n_cells = cells.map_or(n, |c| c.connectivity.len() / c.per_cell.max(1));
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(IoError::os(path))?);
    let mut body = || -> std::io::Result<()> {
        writeln!(w, r#"<?xml version="1.0"?>"#)?;
        writeln!(
            w,
            r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
        )?;
        writeln!(w, "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n_cells}\">")?;
        let floats = |w: &mut dyn Write,
                      name: &str,
                      components: usize,
                      v: &(dyn Fn(usize, usize) -> f64 + Sync)|
         -> std::io::Result<()> {
            // a scalar without NumberOfComponents: readers give it shape (n,), not (n, 1)
            let nc = if components == 1 { String::new() } else { format!(r#" NumberOfComponents="{components}""#) };
            writeln!(w, r#"        <DataArray type="Float64" Name="{name}"{nc} format="ascii">"#)?;
            // formatted in parallel, chunk by chunk, then written in order
            for start in (0..n).step_by(FORMAT_CHUNK * rayon::current_num_threads().max(1)) {
                let end = (start + FORMAT_CHUNK * rayon::current_num_threads().max(1)).min(n);
                let parts: Vec<Vec<u8>> = (start..end)
                    .into_par_iter()
                    .chunks(FORMAT_CHUNK)
                    .map(|nodes| {
                        let (mut out, mut buf) =
                            (Vec::with_capacity(nodes.len() * (10 + 25 * components)), ryu::Buffer::new());
                        for k in nodes {
                            out.extend_from_slice(b"         ");
                            for c in 0..components {
                                out.push(b' ');
                                out.extend_from_slice(buf.format(v(k, c)).as_bytes());
                            }
                            out.push(b'\n');
                        }
                        out
                    })
                    .collect();
                for p in parts {
                    w.write_all(&p)?;
                }
            }
            writeln!(w, "        </DataArray>")
        };
        let ints_of = |w: &mut dyn Write,
                       name: &str,
                       ty: &str,
                       count: usize,
                       v: &dyn Fn(usize) -> String|
         -> std::io::Result<()> {
            writeln!(w, r#"        <DataArray type="{ty}" Name="{name}" format="ascii">"#)?;
            for k in 0..count {
                writeln!(w, "          {}", v(k))?;
            }
            writeln!(w, "        </DataArray>")
        };
        let ints = |w: &mut dyn Write, name: &str, ty: &str, v: &dyn Fn(usize) -> String| ints_of(w, name, ty, n, v);
        writeln!(w, "      <PointData>")?;
        for a in arrays {
            match &a.values {
                PointValues::Float64 { components, value } => floats(&mut w, a.name, *components, value)?,
                PointValues::UInt8(value) => ints(&mut w, a.name, "UInt8", &|k| value(k).to_string())?,
                PointValues::UInt32(value) => ints(&mut w, a.name, "UInt32", &|k| value(k).to_string())?,
            }
        }
        writeln!(w, "      </PointData>\n      <Points>")?;
        floats(&mut w, "points", 3, &|k, a| if a < dim { x[k][a] } else { 0.0 })?;
        writeln!(w, "      </Points>\n      <Cells>")?;
        match cells {
            None => {
                ints(&mut w, "connectivity", "Int64", &|k| k.to_string())?;
                ints(&mut w, "offsets", "Int64", &|k| (k + 1).to_string())?;
                // VTK_VERTEX = 1
                ints(&mut w, "types", "UInt8", &|_| "1".to_string())?;
            }
            Some(c) => {
                let m = c.per_cell;
                let conn = |k: usize| {
                    c.connectivity[m * k..m * k + m].iter().map(|p| p.to_string()).collect::<Vec<_>>().join(" ")
                };
                ints_of(&mut w, "connectivity", "Int64", n_cells, &conn)?;
                ints_of(&mut w, "offsets", "Int64", n_cells, &|k| (m * (k + 1)).to_string())?;
                ints_of(&mut w, "types", "UInt8", n_cells, &|_| c.vtk_type.to_string())?;
            }
        }
        writeln!(w, "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>")?;
        w.flush()
    };
    body().map_err(IoError::os(path))
}

/// Writes a parallel VTU index (`.pvtu`): the point arrays' names, types and components (the
/// values of `arrays` are not read) and one `<Piece Source=".."/>` per file of `pieces`
/// (relative to the index's directory), each written by [`write_vtu`] with the same arrays:
/// ParaView opens the pieces as one dataset.
pub fn write_pvtu(path: &Path, arrays: &[PointArray], pieces: &[String]) -> Result<(), IoError> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(IoError::os(path))?);
    let mut body = || -> std::io::Result<()> {
        writeln!(w, r#"<?xml version="1.0"?>"#)?;
        writeln!(
            w,
            r#"<VTKFile type="PUnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
        )?;
        writeln!(w, "  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>")?;
        for a in arrays {
            let (ty, components) = match &a.values {
                PointValues::Float64 { components, .. } => ("Float64", *components),
                PointValues::UInt8(_) => ("UInt8", 1),
                PointValues::UInt32(_) => ("UInt32", 1),
            };
            let nc = if components == 1 { String::new() } else { format!(r#" NumberOfComponents="{components}""#) };
            writeln!(w, r#"      <PDataArray type="{ty}" Name="{}"{nc}/>"#, a.name)?;
        }
        writeln!(w, "    </PPointData>\n    <PPoints>")?;
        writeln!(w, r#"      <PDataArray type="Float64" Name="points" NumberOfComponents="3"/>"#)?;
        writeln!(w, "    </PPoints>")?;
        for piece in pieces {
            writeln!(w, r#"    <Piece Source="{piece}"/>"#)?;
        }
        writeln!(w, "  </PUnstructuredGrid>\n</VTKFile>")?;
        w.flush()
    };
    body().map_err(IoError::os(path))
}

/// Writes a ParaView collection (`.pvd`): one `<DataSet timestep=".." file=".."/>` per
/// `(time, file)`, the file names relative to the collection's directory; ParaView opens it
/// as a time series.
pub fn write_pvd(path: &Path, datasets: &[(f64, String)]) -> Result<(), IoError> {
    let mut s = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n");
    for (t, file) in datasets {
        let file = file.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;");
        s.push_str(&format!("    <DataSet timestep=\"{t:.16e}\" group=\"\" part=\"0\" file=\"{file}\"/>\n"));
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    std::fs::write(path, s).map_err(IoError::os(path))
}
