//! Exodus II meshes (`"nodes": {"mesh": "part.e"}`, issue #33): classic netCDF files (`CDF\x01`
//! or `CDF\x02`, as Cubit, Peridigm's and PeriLab's test suites write them) read with the
//! pure-Rust `netcdf3` crate, a PD node per element as for Gmsh ([`crate::mesh`]).
//!
//! Read: the coordinates (`coordx`, `coordy`, `coordz`, or the older `coord`), every element
//! block `connect<i>` whose `elem_type` is linear (`TRI`/`TRI3`/`TRIANGLE`, `QUAD`/`QUAD4`/
//! `SHELL4` in 2D; `TETRA`/`TET4`, `HEX`/`HEX8`, `WEDGE`/`WEDGE6` in 3D; quadratic types are
//! refused by name), the block ids `eb_prop1` and names `eb_names`, the node sets `node_ns<i>`
//! (`ns_prop1`, `ns_names`) and the side sets `elem_ss<i>` (`ss_prop1`, `ss_names`).
//!
//! * A node's **phase** is its block's id; each block is also a set named by `eb_names` (or
//!   `block_<id>`).
//! * A **side set** `(element, side)` is the set of its elements' nodes: the elements the
//!   sides bound.
//! * A **node set** (mesh nodes) is the set of the elements one of whose sides (faces in 3D,
//!   edges in 2D) has all its vertices in it: the elements it bounds; a node set that holds no
//!   whole side (a point) takes the elements that contain one of its nodes.
//! * Unnamed sets are named `nodeset_<id>` and `sideset_<id>`.

use crate::cloud::Cloud;
use crate::IoError;
use linpd_core::Point;
use netcdf3::{DataVector, FileReader};
use std::path::Path;

fn format(path: &Path, reason: impl Into<String>) -> IoError {
    IoError::Format { path: path.display().to_string(), line: None, reason: reason.into() }
}

/// The linear element types read, by their Exodus name's prefix: `(names, dimension, nodes,
/// the mesh's element type for the volume, the sides as vertex lists)`.
struct Kind {
    names: &'static [&'static str],
    dim: usize,
    nodes: usize,
    gmsh: mshio::mshfile::ElementType,
    sides: &'static [&'static [usize]],
}

const KINDS: [Kind; 5] = [
    Kind {
        names: &["TRI", "TRI3", "TRIANGLE"],
        dim: 2,
        nodes: 3,
        gmsh: mshio::mshfile::ElementType::Tri3,
        sides: &[&[0, 1], &[1, 2], &[2, 0]],
    },
    Kind {
        names: &["QUAD", "QUAD4", "SHELL", "SHELL4"],
        dim: 2,
        nodes: 4,
        gmsh: mshio::mshfile::ElementType::Qua4,
        sides: &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]],
    },
    Kind {
        names: &["TETRA", "TETRA4", "TET", "TET4"],
        dim: 3,
        nodes: 4,
        gmsh: mshio::mshfile::ElementType::Tet4,
        sides: &[&[0, 1, 3], &[1, 2, 3], &[0, 3, 2], &[0, 2, 1]],
    },
    Kind {
        names: &["HEX", "HEX8", "HEXAHEDRON"],
        dim: 3,
        nodes: 8,
        gmsh: mshio::mshfile::ElementType::Hex8,
        sides: &[&[0, 1, 5, 4], &[1, 2, 6, 5], &[2, 3, 7, 6], &[0, 4, 7, 3], &[0, 3, 2, 1], &[4, 5, 6, 7]],
    },
    Kind {
        names: &["WEDGE", "WEDGE6"],
        dim: 3,
        nodes: 6,
        gmsh: mshio::mshfile::ElementType::Pri6,
        sides: &[&[0, 1, 4, 3], &[1, 2, 5, 4], &[0, 3, 5, 2], &[0, 2, 1], &[3, 4, 5]],
    },
];

/// What the reader needs of the file's header, owned (the reader is borrowed mutably to read
/// the variables).
struct Meta {
    dims: std::collections::HashMap<String, usize>,
    vars: std::collections::HashSet<String>,
    /// `elem_type` of every `connect<i>`.
    elem_types: std::collections::HashMap<String, String>,
}

impl Meta {
    fn of(ds: &netcdf3::DataSet) -> Self {
        let dims = ds.dim_names().into_iter().map(|n| (n.clone(), ds.dim_size(&n).unwrap_or(0))).collect();
        let vars: std::collections::HashSet<String> = ds.get_var_names().into_iter().collect();
        let elem_types = vars
            .iter()
            .filter(|v| v.starts_with("connect"))
            .filter_map(|v| Some((v.clone(), ds.get_var_attr_as_string(v, "elem_type")?)))
            .collect();
        Meta { dims, vars, elem_types }
    }
    fn dim_size(&self, name: &str) -> usize {
        self.dims.get(name).copied().unwrap_or(0)
    }
    fn has_var(&self, name: &str) -> bool {
        self.vars.contains(name)
    }
}

/// A variable as `f64`s (Exodus writes coordinates in single or double precision and
/// integers as 32-bit).
fn read_f64(r: &mut FileReader, path: &Path, name: &str) -> Result<Vec<f64>, IoError> {
    match r.read_var(name).map_err(|e| format(path, format!("variable {name}: {e}")))? {
        DataVector::F64(v) => Ok(v),
        DataVector::F32(v) => Ok(v.into_iter().map(f64::from).collect()),
        DataVector::I32(v) => Ok(v.into_iter().map(f64::from).collect()),
        DataVector::I16(v) => Ok(v.into_iter().map(f64::from).collect()),
        DataVector::I8(v) => Ok(v.into_iter().map(f64::from).collect()),
        DataVector::U8(v) => Ok(v.into_iter().map(f64::from).collect()),
    }
}

fn read_ints(r: &mut FileReader, path: &Path, name: &str) -> Result<Vec<i64>, IoError> {
    let v = read_f64(r, path, name)?;
    v.iter()
        .map(|&x| {
            if x.fract() == 0.0 && x.abs() < 9e15 {
                Ok(x as i64)
            } else {
                Err(format(path, format!("variable {name}: {x} is not an integer")))
            }
        })
        .collect()
}

/// The `count` names of a `char [count][len_name]` variable (`None` where absent or blank).
fn read_names(r: &mut FileReader, name: &str, count: usize) -> Vec<Option<String>> {
    let Ok(DataVector::U8(bytes)) = r.read_var(name) else { return vec![None; count] };
    let len = bytes.len().checked_div(count).unwrap_or(0);
    (0..count)
        .map(|k| {
            let raw = &bytes[k * len..(k + 1) * len];
            let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
            let s = String::from_utf8_lossy(&raw[..end]).trim().to_string();
            (!s.is_empty()).then_some(s)
        })
        .collect()
}

/// Reads an Exodus II mesh for a `dim`-dimensional scene (see the module docs).
pub fn read_exodus(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    crate::mesh::check_size(path)?;
    let mut r =
        FileReader::open(path).map_err(|e| format(path, format!("not a classic netCDF (Exodus II) file: {e}")))?;
    let ds = Meta::of(r.data_set());
    let size = |name: &str| ds.dim_size(name);
    let num_dim = size("num_dim");
    if num_dim < dim || num_dim > 3 {
        return Err(format(path, format!("num_dim = {num_dim}: not a mesh for a {dim}D scene")));
    }
    let num_nodes = size("num_nodes");
    let mut coords = vec![[0.0; 3]; num_nodes];
    for (a, axis) in ["coordx", "coordy", "coordz"].iter().enumerate().take(num_dim) {
        let c = if ds.has_var(axis) {
            read_f64(&mut r, path, axis)?
        } else {
            read_f64(&mut r, path, "coord")?
                .get(a * num_nodes..(a + 1) * num_nodes)
                .map(<[f64]>::to_vec)
                .unwrap_or_default()
        };
        if c.len() != num_nodes {
            return Err(format(path, format!("{axis} has {} values for {num_nodes} nodes", c.len())));
        }
        c.iter().enumerate().for_each(|(n, &v)| coords[n][a] = v);
    }
    if dim == 2 {
        if let Some(n) = coords.iter().position(|p| p[2] != 0.0) {
            return Err(format(
                path,
                format!("node {}: z = {:e}: a 2D scene's mesh lies in z = 0", n + 1, coords[n][2]),
            ));
        }
    }
    let blocks = size("num_el_blk");
    let ids = if ds.has_var("eb_prop1") { read_ints(&mut r, path, "eb_prop1")? } else { (1..=blocks as i64).collect() };
    let block_names = read_names(&mut r, "eb_names", blocks);
    let mut cloud = Cloud::default();
    // per PD node its element's vertices (0-based mesh nodes) and sides
    let mut elements: Vec<(Vec<usize>, &'static [&'static [usize]])> = Vec::new();
    let mut orientation = 0.0f64;
    for b in 0..blocks {
        let var = format!("connect{}", b + 1);
        let elem_type = ds.elem_types.get(&var).cloned().unwrap_or_default().to_uppercase();
        let per = size(&format!("num_nod_per_el{}", b + 1));
        let kind = KINDS.iter().find(|k| k.names.contains(&elem_type.as_str()) && k.nodes == per).ok_or_else(|| {
            format(path, format!("block {} ({var}): elem_type {elem_type:?} with {per} nodes is not read (linear triangles, quadrilaterals, tetrahedra, hexahedra and wedges are)", ids.get(b).copied().unwrap_or(0)))
        })?;
        if kind.dim != dim {
            return Err(format(
                path,
                format!(
                    "block {}: {elem_type} elements are {}D: a {}D mesh for a {dim}D scene",
                    ids[b], kind.dim, kind.dim
                ),
            ));
        }
        let conn = read_ints(&mut r, path, &var)?;
        let name = block_names.get(b).cloned().flatten().unwrap_or_else(|| format!("block_{}", ids[b]));
        for (e, c) in conn.chunks(per).enumerate() {
            let tag = cloud.positions.len() as u64 + 1;
            let vertices: Vec<usize> = c
                .iter()
                .map(|&n| usize::try_from(n - 1).ok().filter(|&n| n < num_nodes))
                .collect::<Option<_>>()
                .ok_or_else(|| {
                    format(
                        path,
                        format!("element {tag} (block {}, {}) names a node outside 1..={num_nodes}", ids[b], e + 1),
                    )
                })?;
            let x: Vec<Point> = vertices.iter().map(|&n| coords[n]).collect();
            let (v, centroid) = crate::mesh::measure(kind.gmsh, &x).unwrap_or((f64::NAN, [0.0; 3]));
            let v = crate::mesh::oriented_volume(dim, &mut orientation, v)
                .map_err(|why| format(path, format!("element {tag} {why}")))?;
            cloud.sets.entry(name.clone()).or_default().push(cloud.positions.len() as u32);
            cloud.positions.push(centroid);
            cloud.volumes.push(v);
            cloud.phase.push(u32::try_from(ids[b]).unwrap_or(0));
            cloud.layer.push(false);
            cloud.lines.push(tag);
            elements.push((vertices, kind.sides));
        }
    }
    if cloud.positions.is_empty() {
        return Err(format(path, format!("has no {dim}D element")));
    }
    node_sets(&mut r, path, &ds, &mut cloud, &elements, num_nodes)?;
    side_sets(&mut r, path, &ds, &mut cloud)?;
    crate::mesh::tidy_sets(&mut cloud);
    let faces =
        elements.iter().flat_map(|(vs, sides)| sides.iter().map(move |f| f.iter().map(|&i| vs[i] as u64).collect()));
    cloud.boundary = crate::mesh::boundary_points(faces, |v| coords[v as usize]);
    Ok(cloud)
}

/// The node sets as sets of PD nodes (module docs).
fn node_sets(
    r: &mut FileReader,
    path: &Path,
    ds: &Meta,
    cloud: &mut Cloud,
    elements: &[(Vec<usize>, &'static [&'static [usize]])],
    num_nodes: usize,
) -> Result<(), IoError> {
    let count = ds.dim_size("num_node_sets");
    let ids = if ds.has_var("ns_prop1") { read_ints(r, path, "ns_prop1")? } else { (1..=count as i64).collect() };
    let names = read_names(r, "ns_names", count);
    for k in 0..count {
        let nodes = read_ints(r, path, &format!("node_ns{}", k + 1))?;
        let mut member = vec![false; num_nodes];
        for &n in &nodes {
            match usize::try_from(n - 1).ok().filter(|&n| n < num_nodes) {
                Some(n) => member[n] = true,
                None => return Err(format(path, format!("node set {}: node {n} outside 1..={num_nodes}", ids[k]))),
            }
        }
        let whole_side = |(v, sides): &(Vec<usize>, &[&[usize]])| sides.iter().any(|s| s.iter().all(|&i| member[v[i]]));
        let mut set: Vec<u32> = (0..elements.len()).filter(|&e| whole_side(&elements[e])).map(|e| e as u32).collect();
        if set.is_empty() {
            set = (0..elements.len()).filter(|&e| elements[e].0.iter().any(|&n| member[n])).map(|e| e as u32).collect();
        }
        let name = names.get(k).cloned().flatten().unwrap_or_else(|| format!("nodeset_{}", ids[k]));
        cloud.sets.entry(name).or_default().extend(set);
    }
    Ok(())
}

/// The side sets as the sets of their elements' PD nodes.
fn side_sets(r: &mut FileReader, path: &Path, ds: &Meta, cloud: &mut Cloud) -> Result<(), IoError> {
    let count = ds.dim_size("num_side_sets");
    let ids = if ds.has_var("ss_prop1") { read_ints(r, path, "ss_prop1")? } else { (1..=count as i64).collect() };
    let names = read_names(r, "ss_names", count);
    let n = cloud.positions.len();
    for k in 0..count {
        let elems = read_ints(r, path, &format!("elem_ss{}", k + 1))?;
        let set: Vec<u32> = elems
            .iter()
            .map(|&e| usize::try_from(e - 1).ok().filter(|&e| e < n).map(|e| e as u32))
            .collect::<Option<_>>()
            .ok_or_else(|| format(path, format!("side set {}: an element outside 1..={n}", ids[k])))?;
        let name = names.get(k).cloned().flatten().unwrap_or_else(|| format!("sideset_{}", ids[k]));
        cloud.sets.entry(name).or_default().extend(set);
    }
    Ok(())
}
