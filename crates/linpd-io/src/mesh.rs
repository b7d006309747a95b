//! Bodies from meshes (issue #33): a PD node per element of a Gmsh mesh, and Peridigm's text
//! discretization, read into a [`Cloud`] with named node sets.
//!
//! # Gmsh (`"nodes": {"mesh": "part.msh"}`)
//!
//! MSH 4.1, ASCII or binary, parsed by the `mshio` crate (which keeps no node tags of a dense
//! numbering: the k-th node of `$Nodes` is then tag `min + k`, the order Gmsh writes). Every element of the scene's
//! dimension `d` becomes a node at its centroid with its volume (area in 2D): linear triangles
//! and quadrilaterals in 2D, linear tetrahedra, hexahedra and prisms (wedges) in 3D. Volumes
//! and centroids are exact: closed forms for simplices, for quadrilaterals and hexahedra the
//! 2 x 2 (x 2) Gauss rule of `det J` and `x det J` of the bilinear / trilinear map (of degree
//! at most 2 and 3 in each variable, which the rule integrates exactly), for prisms their three
//! tetrahedra.
//!
//! * An element of the scene's dimension whose volume is not positive is **inverted** (3D:
//!   `det J <= 0` at a Gauss point or a negative tetrahedron; 2D: an orientation against the
//!   mesh's first element) or **degenerate** (zero volume): an error names its tag.
//! * Elements of lower dimension (faces, edges, points) make no node; elements of a higher one
//!   (a 3D mesh for a 2D scene) are an error. A 2D scene's mesh must lie in `z = 0`.
//! * **Phases**: a node's phase is the first physical tag of its element's entity (0 without
//!   one), so that `model.material.phases` entries with `"phase": k` address physical group `k`.
//! * **Named sets**: every physical group is a set of nodes, named by its `$PhysicalNames`
//!   entry (or its tag, as a string, without one): a group of dimension `d` holds its
//!   elements' nodes; one of a lower dimension (a side: faces, edges or points) the nodes of the
//!   elements that contain all the vertices of one of its elements (the elements a face, edge
//!   or point bounds). `mshio` does not read `$PhysicalNames`; its lines (`dim tag "name"`) are
//!   read here.
//!
//! # Peridigm's text discretization (`"nodes": {"peridigm": "part.txt"}`)
//!
//! One node per line, exactly five numbers `x y z block_id volume` (the order of Peridigm's
//! `TextFileDiscretization` reader); lines starting with `#`, `/` or `*` and blank lines are
//! comments. `block_id` (an integer >= 1) is the node's phase and names a set `block_<id>`.
//! A 2D scene's nodes must have `z = 0`.

pub use crate::cloud::Sets;
use crate::cloud::{Cloud, MAX_CLOUD_BYTES};
use crate::IoError;
use linpd_core::Point;
use mshio::mshfile::ElementType;
use std::collections::HashMap;
use std::path::Path;

fn format(path: &Path, line: Option<u64>, reason: impl Into<String>) -> IoError {
    IoError::Format { path: path.display().to_string(), line, reason: reason.into() }
}

/// Refuses a mesh file larger than [`MAX_CLOUD_BYTES`] before anything reads it.
pub(crate) fn check_size(path: &Path) -> Result<(), IoError> {
    let len = std::fs::metadata(path).map_err(IoError::os(path))?.len();
    if len > MAX_CLOUD_BYTES {
        return Err(format(path, None, format!("{len} bytes is more than the {MAX_CLOUD_BYTES} a mesh may have")));
    }
    Ok(())
}

fn read_capped(path: &Path) -> Result<Vec<u8>, IoError> {
    check_size(path)?;
    std::fs::read(path).map_err(IoError::os(path))
}

/// An element's volume `v` (signed: [`measure`]) checked: positive in 3D; in 2D, where the
/// sign is the element's orientation, taken against the mesh's first element's (`orientation`,
/// 0 until set). `Err` says why it is refused.
pub(crate) fn oriented_volume(dim: usize, orientation: &mut f64, v: f64) -> Result<f64, String> {
    if dim == 2 && *orientation == 0.0 {
        *orientation = v.signum();
    }
    let v = if dim == 2 { v * *orientation } else { v };
    match v {
        v if v > 0.0 => Ok(v),
        v if v == 0.0 || v.is_nan() => Err(format!("is degenerate (zero volume): volume {v:e}")),
        v => Err(format!("is inverted (negative volume): volume {v:e}")),
    }
}

/// Sorts every set and drops repeats (a node reached through several faces of a side set).
pub(crate) fn tidy_sets(cloud: &mut Cloud) {
    for set in cloud.sets.values_mut() {
        set.sort_unstable();
        set.dedup();
    }
}

/// Reads Peridigm's text discretization for a `dim`-dimensional scene (see the module docs).
pub fn read_peridigm(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    let bytes = read_capped(path)?;
    let text = String::from_utf8(bytes).map_err(|_| format(path, None, "is not UTF-8 text"))?;
    let mut cloud = Cloud::default();
    for (k, raw) in text.lines().enumerate() {
        let line = (k + 1) as u64;
        let t = raw.trim();
        if t.is_empty() || t.starts_with(['#', '/', '*']) {
            continue;
        }
        let fields: Vec<&str> = t.split_whitespace().collect();
        if fields.len() != 5 {
            return Err(format(
                path,
                Some(line),
                format!("expected 5 numbers `x y z block_id volume`, got {}", fields.len()),
            ));
        }
        let mut v = [0.0; 5];
        for (c, f) in fields.iter().enumerate() {
            v[c] =
                f.parse().ok().filter(|x: &f64| x.is_finite()).ok_or_else(|| {
                    format(path, Some(line), format!("column {} ({f:?}) is not a finite number", c + 1))
                })?;
        }
        let block = v[3];
        if !(block >= 1.0 && block.fract() == 0.0 && block <= u32::MAX as f64) {
            return Err(format(path, Some(line), format!("block_id {block} is not an integer >= 1")));
        }
        if !(v[4] > 0.0) {
            return Err(format(path, Some(line), format!("volume {:e} is not positive", v[4])));
        }
        if dim == 2 && v[2] != 0.0 {
            return Err(format(path, Some(line), format!("z = {:e}: a 2D scene's nodes lie in z = 0", v[2])));
        }
        let n = cloud.positions.len() as u32;
        cloud.positions.push([v[0], v[1], if dim == 3 { v[2] } else { 0.0 }]);
        cloud.volumes.push(v[4]);
        cloud.phase.push(block as u32);
        cloud.layer.push(false);
        cloud.lines.push(line);
        cloud.sets.entry(format!("block_{}", block as u32)).or_default().push(n);
    }
    if cloud.positions.is_empty() {
        return Err(format(path, None, "has no node"));
    }
    Ok(cloud)
}

/// Reads a Gmsh MSH 4.1 mesh for a `dim`-dimensional scene (see the module docs).
pub fn read_gmsh(path: &Path, dim: usize) -> Result<Cloud, IoError> {
    let bytes = read_capped(path)?;
    let msh =
        mshio::parse_msh_bytes(&bytes).map_err(|e| format(path, None, format!("not a Gmsh MSH 4.1 mesh: {e}")))?;
    let data = &msh.data;
    let mut coords: HashMap<u64, Point> = HashMap::new();
    if let Some(nodes) = &data.nodes {
        // mshio keeps the tags of a sparse numbering only; in a dense one (tags `min..=max`
        // without gaps) the k-th node of the section is tag `min + k`, the order Gmsh writes
        let mut next = nodes.min_node_tag;
        for block in &nodes.node_blocks {
            let mut tags: Vec<u64> = (next..next + block.nodes.len() as u64).collect();
            if let Some(map) = &block.node_tags {
                map.iter().for_each(|(&tag, &i)| tags[i] = tag);
            }
            next += block.nodes.len() as u64;
            for (tag, n) in tags.into_iter().zip(&block.nodes) {
                coords.insert(tag, [n.x, n.y, n.z]);
            }
        }
    }
    let names = physical_names(&bytes);
    let physical = entity_groups(data);
    let mut cloud = Cloud::default();
    // (node tags of each PD node's element) for the sets of lower-dimensional groups
    let mut vertices: Vec<Vec<u64>> = Vec::new();
    let mut kinds: Vec<ElementType> = Vec::new();
    let mut orientation = 0.0f64;
    let mut lower: Vec<(i32, &mshio::mshfile::ElementBlock<u64, i32>)> = Vec::new();
    let blocks: Vec<_> = data.elements.iter().flat_map(|e| &e.element_blocks).collect();
    if let Some(b) = blocks.iter().find(|b| b.entity_dim as usize > dim) {
        let edim = b.entity_dim;
        return Err(format(
            path,
            None,
            format!("has {edim}D elements ({:?}): a {edim}D mesh for a {dim}D scene", b.element_type),
        ));
    }
    for block in blocks {
        let edim = block.entity_dim as usize;
        if edim < dim {
            lower.push((block.entity_dim, block));
            continue;
        }
        let groups = physical.get(&(block.entity_dim, block.entity_tag)).cloned().unwrap_or_default();
        for e in &block.elements {
            let x: Vec<Point> =
                e.nodes.iter().map(|t| coords.get(t).copied()).collect::<Option<_>>().ok_or_else(|| {
                    format(path, None, format!("element {} names a node that is not in $Nodes", e.element_tag))
                })?;
            if dim == 2 {
                if let Some(p) = x.iter().find(|p| p[2] != 0.0) {
                    return Err(format(
                        path,
                        None,
                        format!("element {}: z = {:e}: a 2D scene's mesh lies in z = 0", e.element_tag, p[2]),
                    ));
                }
            }
            let (v, c) = measure(block.element_type, &x).ok_or_else(|| {
                format(path, None, format!("element {}: {:?} elements are not read (linear triangles, quadrilaterals, tetrahedra, hexahedra and prisms are)", e.element_tag, block.element_type))
            })?;
            let v = oriented_volume(dim, &mut orientation, v)
                .map_err(|why| format(path, None, format!("element {} {why}", e.element_tag)))?;
            let n = cloud.positions.len() as u32;
            cloud.positions.push(c);
            cloud.volumes.push(v);
            cloud.phase.push(groups.first().map_or(0, |&g| g.unsigned_abs()));
            cloud.layer.push(false);
            cloud.lines.push(e.element_tag);
            vertices.push(e.nodes.clone());
            kinds.push(block.element_type);
            for &g in &groups {
                cloud.sets.entry(group_name(&names, block.entity_dim, g)).or_default().push(n);
            }
        }
    }
    if cloud.positions.is_empty() {
        return Err(format(path, None, format!("has no {dim}D element")));
    }
    side_sets(&mut cloud, &vertices, &lower, &physical, &names);
    tidy_sets(&mut cloud);
    let faces = vertices
        .iter()
        .zip(&kinds)
        .flat_map(|(vs, &k)| faces(k).iter().map(move |f| f.iter().map(|&i| vs[i]).collect()));
    cloud.boundary = boundary_points(faces, |t| coords[&t]);
    Ok(cloud)
}

/// The sets of the physical groups of dimension below the scene's: the nodes whose element
/// contains every vertex of one of the group's elements.
fn side_sets(
    cloud: &mut Cloud,
    vertices: &[Vec<u64>],
    lower: &[(i32, &mshio::mshfile::ElementBlock<u64, i32>)],
    physical: &HashMap<(i32, i32), Vec<i32>>,
    names: &HashMap<(i32, i32), String>,
) {
    let mut by_vertex: HashMap<u64, Vec<u32>> = HashMap::new();
    for (n, vs) in vertices.iter().enumerate() {
        for &t in vs {
            by_vertex.entry(t).or_default().push(n as u32);
        }
    }
    for (edim, block) in lower {
        let Some(groups) = physical.get(&(*edim, block.entity_tag)) else { continue };
        let mut members: Vec<u32> = Vec::new();
        for e in &block.elements {
            let Some(first) = e.nodes.first().and_then(|t| by_vertex.get(t)) else { continue };
            members.extend(first.iter().copied().filter(|&n| e.nodes.iter().all(|t| vertices[n as usize].contains(t))));
        }
        for &g in groups {
            cloud.sets.entry(group_name(names, *edim, g)).or_default().extend(&members);
        }
    }
}

/// A physical group's name: its `$PhysicalNames` entry, else its tag.
fn group_name(names: &HashMap<(i32, i32), String>, dim: i32, tag: i32) -> String {
    names.get(&(dim, tag.abs())).cloned().unwrap_or_else(|| tag.abs().to_string())
}

/// `(entity dimension, entity tag) -> physical tags` from `$Entities`.
fn entity_groups(data: &mshio::mshfile::MshData<u64, i32, f64>) -> HashMap<(i32, i32), Vec<i32>> {
    let mut out = HashMap::new();
    if let Some(e) = &data.entities {
        e.points.iter().for_each(|p| drop(out.insert((0, p.tag), p.physical_tags.clone())));
        e.curves.iter().for_each(|p| drop(out.insert((1, p.tag), p.physical_tags.clone())));
        e.surfaces.iter().for_each(|p| drop(out.insert((2, p.tag), p.physical_tags.clone())));
        e.volumes.iter().for_each(|p| drop(out.insert((3, p.tag), p.physical_tags.clone())));
    }
    out
}

/// `(dimension, tag) -> name` from the `$PhysicalNames` section (ASCII in ASCII and binary
/// files alike), whose lines after the count are `dim tag "name"`.
fn physical_names(bytes: &[u8]) -> HashMap<(i32, i32), String> {
    let mut out = HashMap::new();
    let find = |needle: &[u8]| bytes.windows(needle.len()).position(|w| w == needle);
    let (Some(start), Some(end)) = (find(b"$PhysicalNames"), find(b"$EndPhysicalNames")) else { return out };
    let Ok(text) = std::str::from_utf8(&bytes[start..end.max(start)]) else { return out };
    for line in text.lines().skip(2) {
        let mut parts = line.trim().splitn(3, char::is_whitespace);
        let (Some(d), Some(t), Some(name)) = (parts.next(), parts.next(), parts.next()) else { continue };
        if let (Ok(d), Ok(t)) = (d.parse(), t.parse()) {
            out.insert((d, t), name.trim().trim_matches('"').to_string());
        }
    }
    out
}

/// The faces (edges in 2D) of a linear element as corner lists in Gmsh's order (none for
/// lower-dimensional types).
pub(crate) fn faces(kind: ElementType) -> &'static [&'static [usize]] {
    match kind {
        ElementType::Tri3 => &[&[0, 1], &[1, 2], &[2, 0]],
        ElementType::Qua4 => &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]],
        ElementType::Tet4 => &[&[0, 1, 2], &[0, 1, 3], &[0, 2, 3], &[1, 2, 3]],
        ElementType::Hex8 => {
            &[&[0, 1, 2, 3], &[4, 5, 6, 7], &[0, 1, 5, 4], &[1, 2, 6, 5], &[2, 3, 7, 6], &[3, 0, 4, 7]]
        }
        ElementType::Pri6 => &[&[0, 1, 2], &[3, 4, 5], &[0, 1, 4, 3], &[1, 2, 5, 4], &[2, 0, 3, 5]],
        _ => &[],
    }
}

/// Points on a mesh's boundary: the centroid and the corners of every face (a corner list of
/// vertex ids, `faces`) that occurs once, i.e. that one element only has.
pub(crate) fn boundary_points(faces: impl Iterator<Item = Vec<u64>>, coord: impl Fn(u64) -> Point) -> Vec<Point> {
    let mut count: HashMap<Vec<u64>, (u32, Vec<u64>)> = HashMap::new();
    for f in faces {
        let mut key = f.clone();
        key.sort_unstable();
        count.entry(key).or_insert((0, f)).0 += 1;
    }
    let mut out = Vec::new();
    for (_, (n, f)) in count {
        if n == 1 {
            let corners: Vec<Point> = f.iter().map(|&v| coord(v)).collect();
            out.push(mean(&corners));
            out.extend(corners);
        }
    }
    out
}

/// The signed volume and the centroid of a linear element with vertices `x` (Gmsh's order),
/// `None` for a type not read.
pub(crate) fn measure(kind: ElementType, x: &[Point]) -> Option<(f64, Point)> {
    match (kind, x.len()) {
        (ElementType::Tri3, 3) => {
            let a = 0.5 * cross2(sub(x[1], x[0]), sub(x[2], x[0]));
            Some((a, mean(x)))
        }
        (ElementType::Tet4, 4) => Some((tet_volume(x[0], x[1], x[2], x[3]), mean(x))),
        (ElementType::Qua4, 4) => Some(gauss(2, x)),
        (ElementType::Hex8, 8) => Some(gauss(3, x)),
        (ElementType::Pri6, 6) => {
            // three tetrahedra of the wedge (0 1 2 / 3 4 5)
            let tets = [[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]];
            let (mut v, mut m) = (0.0, [0.0; 3]);
            for t in tets {
                let p = t.map(|i| x[i]);
                let vt = tet_volume(p[0], p[1], p[2], p[3]);
                let c = mean(&p);
                v += vt;
                (0..3).for_each(|a| m[a] += vt * c[a]);
            }
            Some((v, m.map(|c| c / v)))
        }
        _ => None,
    }
}

/// Volume and centroid of a bilinear quadrilateral (`d = 2`) or trilinear hexahedron (`d = 3`)
/// by the 2-point Gauss rule per axis; in 3D a volume `-|V|` when `det J <= 0` at a Gauss point.
fn gauss(d: usize, x: &[Point]) -> (f64, Point) {
    // Gmsh's corner order as (xi, eta, zeta) signs
    const Q: [[f64; 3]; 8] = [
        [-1., -1., -1.],
        [1., -1., -1.],
        [1., 1., -1.],
        [-1., 1., -1.],
        [-1., -1., 1.],
        [1., -1., 1.],
        [1., 1., 1.],
        [-1., 1., 1.],
    ];
    let g = 1.0 / 3f64.sqrt();
    let corners = 1 << d;
    let (mut v, mut m) = (0.0, [0.0; 3]);
    let mut inverted = false;
    for q in 0..corners {
        let xi: [f64; 3] = std::array::from_fn(|a| if a < d { Q[q][a] * g } else { 0.0 });
        // J[a][b] = d x_a / d xi_b; N_c = prod (1 + s xi) / 2^d
        let mut jac = [[0.0; 3]; 3];
        let mut pos = [0.0; 3];
        for (c, p) in x.iter().enumerate().take(corners) {
            let s = Q[c];
            let f: [f64; 3] = std::array::from_fn(|a| if a < d { 0.5 * (1.0 + s[a] * xi[a]) } else { 1.0 });
            let n: f64 = f.iter().product();
            for b in 0..d {
                let dn = 0.5 * s[b] * (0..d).filter(|&k| k != b).map(|k| f[k]).product::<f64>();
                for a in 0..d {
                    jac[a][b] += p[a] * dn;
                }
            }
            (0..3).for_each(|a| pos[a] += n * p[a]);
        }
        let det = if d == 2 {
            jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0]
        } else {
            jac[0][0] * (jac[1][1] * jac[2][2] - jac[1][2] * jac[2][1])
                - jac[0][1] * (jac[1][0] * jac[2][2] - jac[1][2] * jac[2][0])
                + jac[0][2] * (jac[1][0] * jac[2][1] - jac[1][1] * jac[2][0])
        };
        inverted |= d == 3 && det <= 0.0;
        v += det;
        (0..3).for_each(|a| m[a] += det * pos[a]);
    }
    let centroid = m.map(|c| c / v);
    (if inverted { -v.abs() } else { v }, centroid)
}

fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross2(a: Point, b: Point) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn tet_volume(a: Point, b: Point, c: Point, d: Point) -> f64 {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.0
}

fn mean(x: &[Point]) -> Point {
    let n = x.len() as f64;
    std::array::from_fn(|a| x.iter().map(|p| p[a]).sum::<f64>() / n)
}
