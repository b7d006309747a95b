//! `"nodes": {"vtk": "file.vtu"}`: a point cloud from a VTK file, read by `vtkio`.
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
use crate::ProblemError;
use std::path::Path;
use vtkio::model::{Attribute, Attributes, DataSet, IOBuffer, Piece};

/// Reads a VTK point cloud of dimension `dim`; `key` is the JSON path of the file name.
pub fn read_cloud(path: &Path, dim: usize, key: &str) -> Result<Cloud, ProblemError> {
    let shown = path.display().to_string();
    let fail = |reason: String| ProblemError::invalid(key, format!("{shown}: {reason}"));
    let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".into()));
    }
    if meta.len() > MAX_CLOUD_BYTES {
        return Err(fail(format!("{} bytes, more than a node file may hold ({MAX_CLOUD_BYTES})", meta.len())));
    }
    let vtk = vtkio::Vtk::import(path).map_err(|e| fail(format!("not a readable VTK file ({e})")))?;
    let parts = match vtk.data {
        DataSet::UnstructuredGrid { pieces, .. } => inline(pieces, |p| (p.points, p.data)),
        DataSet::PolyData { pieces, .. } => inline(pieces, |p| (p.points, p.data)),
        _ => Err("holds no unstructured grid or poly data (point sets are read from those)".into()),
    }
    .map_err(fail)?;
    let mut cloud =
        Cloud { positions: Vec::new(), volumes: Vec::new(), layer: Vec::new(), phase: Vec::new(), lines: Vec::new() };
    let (mut has_layer, mut has_phase) = (None, None);
    for (points, data) in &parts {
        let x: Vec<f64> = points.cast_into().ok_or_else(|| fail("points are not numbers".into()))?;
        let n = x.len() / 3;
        let first = cloud.positions.len();
        // a data array of that name, or an array of a legacy FIELD (as meshio writes .vtk)
        let array = |name: &str| -> Result<Option<Vec<f64>>, ProblemError> {
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
