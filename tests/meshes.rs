//! Bodies from meshes (issue #33 item 1; crates/linpd-io/src/mesh.rs): a Gmsh mesh read as a
//! node per element agrees with meshio's reading of the same file (volumes, centroids, the
//! physical groups' sets), Peridigm's text discretization solves like the lattice it was
//! written from, named sets select constraints and loads, and bad meshes and sets are named
//! errors.

use linpd::core::NoProgress;
use linpd::io::exodus::read_exodus;
use linpd::io::mesh::{read_gmsh, read_peridigm};
use linpd::io::vtk::read_mesh as read_vtu;
use linpd::problem::Problem;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn scene(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-meshes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// meshio's reading of a Gmsh file, as JSON: per element of dimension `d` (file order) its
/// volume (area) and centroid from meshio's points and cells, computed here in numpy (triangle
/// and tetrahedron determinants), and per physical group (its `$PhysicalNames` name) the
/// elements it holds or whose vertices include one of its elements' vertices all.
const MESHIO: &str = r#"
import json, sys
import numpy as np
import meshio
path, d = sys.argv[1], int(sys.argv[2])
m = meshio.read(path)
kinds = {2: ("triangle",), 3: ("tetra",)}[d]
vol, cen, verts = [], [], []
for block in m.cells:
    if block.type not in kinds:
        continue
    x = m.points[block.data]
    e = x[:, 1:, :d] - x[:, :1, :d]
    v = np.linalg.det(e) / (2.0 if d == 2 else 6.0)
    vol += list(np.abs(v))
    cen += x.mean(axis=1).tolist()
    verts += [set(c) for c in block.data.tolist()]
sets = {}
names = {(int(dim), int(tag)): name for name, (tag, dim) in m.field_data.items()}
by_vertex = {}
for k, vs in enumerate(verts):
    for t in vs:
        by_vertex.setdefault(t, []).append(k)
for block, phys in zip(m.cells, m.cell_data["gmsh:physical"]):
    dim = {"vertex": 0, "line": 1, "triangle": 2, "tetra": 3}[block.type]
    for cell, tag in zip(block.data.tolist(), phys.tolist()):
        name = names[(dim, int(tag))]
        s = sets.setdefault(name, set())
        s.update(k for k in by_vertex.get(cell[0], []) if set(cell) <= verts[k])
print(json.dumps({"volume": vol, "centroid": cen, "sets": {k: sorted(v) for k, v in sets.items()}}))
"#;

/// The bundled 2D (triangles) and 3D (tetrahedra) meshes written by gmsh
/// (examples/make_meshes.py): linpd's nodes are meshio's elements, volumes and centroids to
/// 1e-12 relative (the same determinants summed in another order), the sets equal.
#[test]
fn gmsh_meshes_read_as_meshio_reads_them() {
    for (file, d) in [("plate-hole-mesh-2d.msh", 2), ("bracket-mesh-3d.msh", 3)] {
        let path = data(file);
        let o = Command::new("python3").args(["-c", MESHIO, path.to_str().unwrap(), &d.to_string()]).output().unwrap();
        assert!(o.status.success(), "meshio: {}", String::from_utf8_lossy(&o.stderr));
        let want: Value = serde_json::from_slice(&o.stdout).unwrap();
        let got = read_gmsh(&path, d).unwrap();
        let volume = want["volume"].as_array().unwrap();
        assert_eq!(got.volumes.len(), volume.len(), "{file}: elements");
        let total: f64 = got.volumes.iter().sum();
        for (k, v) in volume.iter().enumerate() {
            let v = v.as_f64().unwrap();
            assert!((got.volumes[k] - v).abs() <= 1e-12 * v, "{file} element {k}: {} vs {v}", got.volumes[k]);
            let c = want["centroid"][k].as_array().unwrap();
            for a in 0..d {
                let ca = c[a].as_f64().unwrap();
                assert!((got.positions[k][a] - ca).abs() <= 1e-12, "{file} element {k}: centroid");
            }
        }
        let exact = if d == 2 { 0.5 - std::f64::consts::PI * 0.01 } else { 0.1 * 0.3 * 0.1 + 0.3 * 0.1 * 0.1 };
        // the polygonal hole's area is below the disk's by O(h^2 / r^2)
        assert!((total - exact).abs() <= 2e-3 * exact, "{file}: volume {total} vs {exact}");
        let sets = want["sets"].as_object().unwrap();
        assert_eq!(got.sets.len(), sets.len(), "{file}: sets {:?}", got.sets.keys().collect::<Vec<_>>());
        for (name, members) in sets {
            let members: Vec<u32> = members.as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as u32).collect();
            assert!(!members.is_empty(), "{file}: set {name} empty");
            assert_eq!(got.sets[name], members, "{file}: set {name}");
        }
    }
}

/// The bundled Gmsh meshes converted to VTU by meshio (`meshio.write`, zlib-compressed binary
/// arrays, the physical tags as the cell array `gmsh:physical`) read as the Gmsh files: the
/// same nodes and volumes (the same vertices in the same order: 0 difference), phases, and
/// the sets named by their tags equal to the physical groups'.
#[test]
fn vtu_meshes_written_by_meshio_read_as_gmsh() {
    let dir = scratch("vtu");
    for (file, d, groups) in [
        ("plate-hole-mesh-2d.msh", 2, ["plate", "left", "right"]),
        ("bracket-mesh-3d.msh", 3, ["bracket", "clamp", "load"]),
    ] {
        let vtu = dir.join(file.replace(".msh", ".vtu"));
        let convert = "import sys, meshio; m = meshio.read(sys.argv[1]); meshio.write(sys.argv[2], m)";
        let o = Command::new("python3")
            .args(["-c", convert, data(file).to_str().unwrap(), vtu.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "meshio: {}", String::from_utf8_lossy(&o.stderr));
        let (v, g) = (read_vtu(&vtu, d).unwrap(), read_gmsh(&data(file), d).unwrap());
        assert_eq!(v.positions, g.positions, "{file}");
        assert_eq!(v.volumes, g.volumes, "{file}");
        assert_eq!(v.phase, g.phase, "{file}");
        for (tag, name) in groups.iter().enumerate() {
            assert_eq!(v.sets[&(tag + 1).to_string()], g.sets[*name], "{file}: set {name}");
        }
        assert_eq!(v.sets.len(), 3, "{file}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An ASCII VTK XML unstructured grid of `points` and `cells` (`(VTK cell type, corners)`).
fn ascii_vtu(cells: &[(u8, Vec<u32>)], points: &[[f64; 3]]) -> String {
    let pts: Vec<String> = points.iter().map(|p| format!("{} {} {}", p[0], p[1], p[2])).collect();
    let conn: Vec<String> = cells.iter().flat_map(|(_, c)| c.iter().map(u32::to_string)).collect();
    let mut end = 0;
    let offs: Vec<String> = cells
        .iter()
        .map(|(_, c)| {
            end += c.len();
            end.to_string()
        })
        .collect();
    let types: Vec<String> = cells.iter().map(|(t, _)| t.to_string()).collect();
    format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="{}" NumberOfCells="{}">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{}</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">{}</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">{}</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">{}</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>
"#,
        points.len(),
        cells.len(),
        pts.join(" "),
        conn.join(" "),
        offs.join(" "),
        types.join(" ")
    )
}

/// An ASCII VTU written here: a unit cube as a hexahedron, as a voxel (VTK's lexicographic
/// corners) and as two wedges (VTK's triangles turn the other way from Gmsh's) reads as three
/// (four) elements of the exact volumes and centroids; an inverted tetrahedron is named.
#[test]
fn vtu_cell_types_and_inverted_cells() {
    let dir = scratch("vtu-cells");
    // the unit cube's corners in VTK's hexahedron order, then shifted copies along x
    let cube = |x0: f64| -> Vec<[f64; 3]> {
        [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]]
            .map(|p| [p[0] + x0, p[1], p[2]])
            .to_vec()
    };
    let mut points = cube(0.0);
    points.extend(cube(2.0));
    points.extend(cube(4.0));
    let cells = vec![
        (12u8, (0..8).collect()),
        (11, vec![8, 9, 11, 10, 12, 13, 15, 14]),
        // the third cube cut along its diagonal plane x - x0 = y: two wedges along z, each
        // bottom triangle clockwise seen from its top (VTK's order)
        (13, vec![16, 18, 17, 20, 22, 21]),
        (13, vec![16, 19, 18, 20, 23, 22]),
    ];
    let path = dir.join("cells.vtu");
    std::fs::write(&path, ascii_vtu(&cells, &points)).unwrap();
    let m = read_vtu(&path, 3).unwrap();
    let want = [
        (1.0, [0.5, 0.5, 0.5]),
        (1.0, [2.5, 0.5, 0.5]),
        (0.5, [4.0 + 2.0 / 3.0, 1.0 / 3.0, 0.5]),
        (0.5, [4.0 + 1.0 / 3.0, 2.0 / 3.0, 0.5]),
    ];
    assert_eq!(m.volumes.len(), 4);
    for (k, (v, c)) in want.iter().enumerate() {
        assert!((m.volumes[k] - v).abs() < 1e-14, "cell {k}: volume {}", m.volumes[k]);
        (0..3)
            .for_each(|a| assert!((m.positions[k][a] - c[a]).abs() < 1e-14, "cell {k}: centroid {:?}", m.positions[k]));
    }
    let bad = dir.join("inverted.vtu");
    std::fs::write(&bad, ascii_vtu(&[(10, vec![0, 2, 1, 4])], &cube(0.0))).unwrap();
    let e = read_vtu(&bad, 3).unwrap_err().to_string();
    assert!(e.contains("inverted.vtu") && e.contains("cell 0 is inverted"), "{e}");
    let e = read_vtu(&path, 2).unwrap_err().to_string();
    assert!(e.contains("cell 0: a 3D Hexahedron in a mesh for a 2D scene"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A set that a mesh names but that holds no node (a VTU vertex tagged 5 at a point no cell
/// uses) selects nothing: a constraint on it is a named error.
#[test]
fn an_empty_set_is_named() {
    let dir = scratch("empty-set");
    // 4 x 4 x 4 unit voxels (tag 1) on a 5 x 5 x 5 grid of points, and a vertex (tag 5) at a
    // point of its own
    let index = |i: usize, j: usize, k: usize| i + 5 * j + 25 * k;
    let mut points: Vec<String> = (0..125).map(|n| format!("{} {} {}", n % 5, (n / 5) % 5, n / 25)).collect();
    points.push("9 9 9".into());
    let mut conn = Vec::new();
    for (i, j, k) in (0..64).map(|c| (c % 4, (c / 4) % 4, c / 16)) {
        for (a, b, c) in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)] {
            conn.push(index(i + a, j + b, k + c).to_string());
        }
    }
    conn.push("125".into());
    let offsets: Vec<String> = (1..=64).map(|c| (8 * c).to_string()).chain(["513".to_string()]).collect();
    let types = format!("{} 1", vec!["11"; 64].join(" "));
    let tags = format!("{} 5", vec!["1"; 64].join(" "));
    let vtu = format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="126" NumberOfCells="65">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{}</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">{}</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">{}</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">{types}</DataArray></Cells>
<CellData><DataArray type="Int32" Name="phase" format="ascii">{tags}</DataArray></CellData>
</Piece></UnstructuredGrid></VTKFile>
"#,
        points.join(" "),
        conn.join(" "),
        offsets.join(" ")
    );
    std::fs::write(dir.join("cube.vtu"), vtu).unwrap();
    let m = read_vtu(&dir.join("cube.vtu"), 3).unwrap();
    assert_eq!(m.sets["1"].len(), 64);
    assert!(m.volumes.iter().all(|&v| (v - 1.0).abs() < 1e-14));
    assert!(m.sets["5"].is_empty());
    let v = json!({"name": "empty", "dimension": 3, "nodes": {"mesh": "cube.vtu"},
        "model": {"type": "bond", "horizon": 1.5, "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"}},
        "constraints": [{"region": {"set": "5"}, "displacement": {"value": [0.0, 0.0, 0.0]}}]});
    let e = error_of(&v, &dir);
    assert!(e.contains("constraints[0].region: contains no node"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `"normalize": "discrete"` on a mesh averages the sums `M_i = sum_j g nu_ij V_j r^2` of the
/// nodes a horizon (plus the largest element) inside the mesh's boundary faces: on a VTU of
/// 12^3 voxels, whose centroids and volumes are a cell-placed lattice's, it is the lattice's
/// stencil sum, and the mesh solves to the lattice scene's displacements (1e-10: the two
/// Cholesky orderings). A point cloud without a boundary, and a mesh too thin for an interior
/// node, are named errors.
#[test]
fn discrete_normalization_on_a_mesh_is_the_lattice_one() {
    let dir = scratch("discrete");
    let n = 12;
    let h = 1.0 / n as f64;
    let m = n + 1;
    let index = |i: usize, j: usize, k: usize| i + m * (j + m * k);
    let points: Vec<[f64; 3]> =
        (0..m * m * m).map(|p| [(p % m) as f64 * h, ((p / m) % m) as f64 * h, (p / (m * m)) as f64 * h]).collect();
    // voxels (VTK type 11): lexicographic corners
    let cells: Vec<(u8, Vec<u32>)> = (0..n * n * n)
        .map(|c| {
            let (i, j, k) = (c % n, (c / n) % n, c / (n * n));
            let corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)];
            (11, corners.iter().map(|&(a, b, d)| index(i + a, j + b, k + d) as u32).collect())
        })
        .collect();
    let vtu = ascii_vtu(&cells, &points);
    std::fs::write(dir.join("cube.vtu"), vtu).unwrap();
    let model = json!({"type": "bond", "horizon": 2.5 * h, "partial_volume": false,
        "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}});
    let lattice = json!({"name": "lattice", "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": h, "placement": "cell"},
        "model": model,
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [0.1, 2.0, 2.0]}}, "displacement": {"value": [0.0, 0.0, 0.0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [0.9, -1.0, -1.0], "max": [2.0, 2.0, 2.0]}}, "force": [0.01, 0.002, 0.0]}],
        "solver": {"type": "cholesky"}});
    let mut mesh = lattice.clone();
    let o = mesh.as_object_mut().unwrap();
    o.remove("grid");
    o.insert("nodes".into(), json!({"mesh": "cube.vtu"}));
    let solve = |v: &Value| Problem::from_json_in(&v.to_string(), &dir).unwrap().solve(&NoProgress).unwrap().u;
    let (a, b) = (solve(&lattice), solve(&mesh));
    let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let diff = a.iter().zip(&b).fold(0.0f64, |s, (x, y)| s.max((x - y).abs()));
    assert!(diff <= 1e-10 * scale, "mesh vs lattice: {:e}", diff / scale);
    // the continuum normalization differs (the lattice sum is not the integral at 2.5 h)
    mesh["model"]["micromodulus"]["normalize"] = json!("continuum");
    let c = solve(&mesh);
    let off = a.iter().zip(&c).fold(0.0f64, |s, (x, y)| s.max((x - y).abs())) / scale;
    assert!(off > 1e-3, "continuum equals discrete to {off:e}");
    // no boundary (a CSV cloud) and no interior node (a horizon of 0.45) are named
    std::fs::write(dir.join("nodes.csv"), "x,y,z,volume\n0,0,0,1\n1,0,0,1\n0,1,0,1\n0,0,1,1\n").unwrap();
    let mut csv = mesh.clone();
    csv["nodes"] = json!({"csv": "nodes.csv"});
    csv["model"] = json!({"type": "bond", "horizon": 1.5,
        "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "discrete"}});
    let e = error_of(&csv, &dir);
    assert!(e.contains("model.micromodulus.normalize") && e.contains("only a mesh's boundary"), "{e}");
    let mut thick = mesh.clone();
    thick["model"] = json!({"type": "bond", "horizon": 0.45, "partial_volume": false,
        "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "discrete"}});
    let e = error_of(&thick, &dir);
    assert!(e.contains("model.micromodulus.normalize") && e.contains("has none"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes the nodes of a grid scene as Peridigm's text discretization (block 1 the body, 2
/// the layer) and returns the scene reading it, constrained by the sets `block_2`.
fn as_peridigm(grid_scene: &Value, dir: &Path) -> Value {
    let p = Problem::from_json(&grid_scene.to_string()).unwrap();
    let nodes = p.nodes();
    let mut text = String::from("# x y z block_id volume\n");
    for n in 0..nodes.len() {
        let x = nodes.position(n);
        let block = if nodes.is_layer(n) { 2 } else { 1 };
        text += &format!("{:?} {:?} {:?} {block} {:?}\n", x[0], x[1], x[2], nodes.volume(n));
    }
    std::fs::write(dir.join("nodes.txt"), text).unwrap();
    let mut s = grid_scene.clone();
    let o = s.as_object_mut().unwrap();
    o.remove("grid");
    o.remove("body");
    o.insert("nodes".into(), json!({"peridigm": dir.join("nodes.txt").to_str().unwrap()}));
    s
}

/// The plate with a hole of data/plate-hole-2d.json (Cholesky) as Peridigm text (z = 0) solves to the lattice's solution to 1e-10 relative (the cloud's AMD-ordered
/// factorization against the lattice's nested dissection, tests/point_cloud.rs); its blocks
/// are the sets `block_1` and `block_2`, which partition the nodes.
#[test]
fn peridigm_text_solves_like_its_lattice() {
    let dir = scratch("peridigm");
    let mut grid_scene = scene("plate-hole-2d.json");
    grid_scene["solver"] = json!({"type": "cholesky"});
    // the lattice's quadrature (a cloud's default is the ball fraction)
    grid_scene["model"]["partial_volume"] = json!(false);
    grid_scene["output"] = json!({});
    let p = Problem::from_json_in(&grid_scene.to_string(), &data("")).unwrap();
    let reference = p.solve(&NoProgress).unwrap();
    let cloud = as_peridigm(&grid_scene, &dir);
    let s = Problem::from_json(&cloud.to_string()).unwrap().solve(&NoProgress).unwrap();
    let scale = reference.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = reference.u.iter().zip(&s.u).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= 1e-10 * scale, "Peridigm text vs lattice: {:e}", diff / scale);
    let read = read_peridigm(&dir.join("nodes.txt"), 2).unwrap();
    assert_eq!(read.sets.len(), 2);
    assert_eq!(read.sets["block_1"].len() + read.sets["block_2"].len(), read.volumes.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The bundled mesh scenes solve with their supports and loads on named sets, and balance:
/// every load on the set "right" / "load", the reactions on "left" / "clamp".
#[test]
fn mesh_scenes_solve_on_their_sets() {
    for (name, loaded) in [("plate-hole-mesh-2d.json", "right"), ("bracket-mesh-3d.json", "load")] {
        let p = Problem::from_json_in(&scene(name).to_string(), &data("")).unwrap();
        let s = p.solve(&NoProgress).unwrap();
        let b = s.balance.as_ref().unwrap();
        assert!(b.relative_imbalance <= 1e-9, "{name}: imbalance {:e}", b.relative_imbalance);
        let set = read_gmsh(&data(&name.replace(".json", ".msh")), s.dim).unwrap().sets[loaded].len();
        assert_eq!(b.loads[0].nodes, set, "{name}: the load's nodes are the set {loaded:?}");
    }
}

fn msh(elements: &str, z4: f64) -> String {
    format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 {z4}\n$EndNodes\n\
         $Elements\n1 1 1 1\n3 1 4 1\n{elements}\n$EndElements\n"
    )
}

fn error_of(v: &Value, dir: &Path) -> String {
    match Problem::from_json_in(&v.to_string(), dir) {
        Ok(_) => "no error".into(),
        Err(e) => e.to_string(),
    }
}

/// Bad meshes and sets: named errors naming the file, the element or the set.
#[test]
fn bad_meshes_and_sets_are_named() {
    let dir = scratch("bad");
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    write("inverted.msh", &msh("1 1 3 2 4", 1.0));
    write("flat.msh", &msh("1 1 2 3 4", 0.0));
    write("part.e", "CDF\x01");
    write("short.txt", "0 0 0 1\n");
    write("block.txt", "0 0 0 0 1e-3\n");
    let tet = |file: &str| {
        json!({"name": "bad", "dimension": 3, "nodes": {"mesh": file},
               "model": {"type": "bond", "horizon": 2.0, "micromodulus": {"kernel": "constant", "modulus": 1.0}}})
    };
    let peridigm = |file: &str| {
        json!({"name": "bad", "dimension": 3, "nodes": {"peridigm": file},
               "model": {"type": "bond", "horizon": 2.0, "micromodulus": {"kernel": "constant", "modulus": 1.0}}})
    };
    let mut plate = scene("plate-hole-mesh-2d.json");
    plate["nodes"]["mesh"] = json!(data("plate-hole-mesh-2d.msh").to_str().unwrap());
    let with = |edit: &dyn Fn(&mut Value)| {
        let mut v = plate.clone();
        edit(&mut v);
        v
    };
    let mut lattice = scene("plate-hole-2d.json");
    lattice["constraints"][0]["region"] = json!({"set": "left"});
    let mut in_2d = scene("bracket-mesh-3d.json");
    in_2d["dimension"] = json!(2);
    in_2d["nodes"]["mesh"] = json!(data("bracket-mesh-3d.msh").to_str().unwrap());
    in_2d["model"]["plane"] = json!("stress");
    let cases: Vec<(Value, &str)> = vec![
        (tet("inverted.msh"), "inverted.msh: element 1 is inverted (negative volume)"),
        (tet("flat.msh"), "flat.msh: element 1 is degenerate (zero volume)"),
        (tet("part.e"), "nodes.mesh: "),
        (peridigm("short.txt"), "short.txt line 1: expected 5 numbers `x y z block_id volume`, got 4"),
        (peridigm("block.txt"), "block.txt line 1: block_id 0 is not an integer >= 1"),
        (
            with(&|v| v["constraints"][0]["region"] = json!({"set": "clamp"})),
            "constraints[0].region.set: no set \"clamp\" in the point cloud (its sets: left, plate, right)",
        ),
        (
            with(&|v| v["loads"][0]["region"] = json!({"union": [{"set": "right"}, {"set": "top"}]})),
            "loads[0].region.set: no set \"top\"",
        ),
        (
            with(&|v| {
                v["model"]["material"] = json!({"defects": [{"segment": [[0.2, 0.0], [0.2, 0.1]], "factor": 0.0}],
                                                "phases": [{"region": {"set": "hole"}, "modulus": 2.0}]})
            }),
            "model.material.phases[0].region.set: no set \"hole\" in the point cloud",
        ),
        (
            {
                let mut v = scene("plate-hole-2d.json");
                v["model"]["material"] = json!({"phases": [{"region": {"set": "plate"}, "modulus": 2.0}]});
                v
            },
            "model.material.phases[0].region.set: no set \"plate\": named sets come with a mesh",
        ),
        (
            {
                let mut v = scene("plate-hole-2d.json");
                v["model"]["pd_regions"] = json!([{"set": "plate"}]);
                v["model"]["transition"] = json!(0.03);
                v
            },
            "pd_regions[0].set: a mesh's named sets select the nodes of constraints, loads and a mesh's phases",
        ),
        (lattice, "constraints[0].region.set: no set \"left\": named sets come with a mesh"),
        (
            {
                let mut v = scene("plate-hole-2d.json");
                v["model"]["partial_volume"] = json!("ball");
                v
            },
            "model.partial_volume: \"ball\" is for point clouds",
        ),
        (in_2d, "bracket-mesh-3d.msh: has 3D elements"),
        (
            with(&|v| v["model"]["horizon"] = json!(20.0)),
            "model.horizon: 2e1 is not shorter than the body, whose nodes span 9.9",
        ),
        (with(&|v| v["model"]["horizon"] = json!(2e-5)), "the horizon must be at least one spacing (is nodes.mesh"),
        (
            with(&|v| {
                v["model"]["surface_correction"] = json!("energy");
                v["model"]["micromodulus"] = json!({"kernel": "constant", "amplitude": 1.0, "normalize": "none"});
            }),
            "model.micromodulus.normalize: the energy correction on a point cloud matches each node to the continuum's moments",
        ),
        (
            with(&|v| {
                v["model"]["surface_correction"] = json!("energy");
                v["model"]["surface_target"] = json!("lattice");
            }),
            "model.surface_target: \"lattice\" matches an interior lattice's moments, and a point cloud has none",
        ),
    ];
    let mut failures = Vec::new();
    for (v, want) in cases {
        let e = error_of(&v, &dir);
        if !e.contains(want) {
            failures.push(format!("expected {want:?} in {e:?}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let e = error_of(&tet("part.e"), &dir);
    assert!(e.contains("part.e: not a classic netCDF (Exodus II) file"), "{e}");
    let e = error_of(&tet("part.stl"), &dir);
    assert!(e.contains("not a mesh linpd reads (Gmsh .msh 4.1, Exodus II .e / .exo, VTK XML .vtu"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A phase given by a mesh's named set (`{"region": {"set": "plate"}}`) is the phase given by
/// its physical tag (`{"phase": 1}`): the same moduli, the same solution bit for bit; and a
/// set phase over part of the body (a union with a box) stiffens it.
#[test]
fn phases_by_named_sets() {
    let mut base = scene("plate-hole-mesh-2d.json");
    base["nodes"]["mesh"] = json!(data("plate-hole-mesh-2d.msh").to_str().unwrap());
    let solve = |material: Value| {
        let mut v = base.clone();
        v["model"]["material"] = material;
        Problem::from_json_in(&v.to_string(), &data("")).unwrap().solve(&NoProgress).unwrap()
    };
    let by_set = solve(json!({"phases": [{"region": {"set": "plate"}, "young_modulus": 2.0}]}));
    let by_tag = solve(json!({"phases": [{"phase": 1, "young_modulus": 2.0}]}));
    assert_eq!(by_set.u, by_tag.u);
    let plain = solve(json!({}));
    // the whole plate twice as stiff: half the displacement (the correction is linear in E)
    let ratio = by_set.u.iter().zip(&plain.u).map(|(a, b)| (2.0 * a - b).abs()).fold(0.0, f64::max);
    assert!(ratio <= 1e-9 * plain.u.iter().fold(0.0f64, |m, v| m.max(v.abs())), "{ratio}");
    let right_half = solve(json!({"phases": [{"region": {"difference": [{"set": "plate"},
        {"box": {"min": [-1.0, -1.0], "max": [0.5, 2.0]}}]}, "young_modulus": 2.0}]}));
    let tip = |u: &[f64]| u.chunks(2).map(|c| c[0]).fold(f64::NEG_INFINITY, f64::max);
    assert!(tip(&right_half.u) < tip(&plain.u) && tip(&right_half.u) > tip(&by_set.u));
}

/// The ball quadrature makes the solution a smooth function of the horizon: on the bundled
/// bracket (4,057 tetrahedra, `delta` = 0.024, about 2.1 mean spacings) the loaded end's mean
/// deflection moves by at most 1e-3 relative (the issue's target; measured 1.8e-7) for a 1e-4
/// relative change of `delta`, and 10 times less for a 1e-5 change (between 5 and 20 times:
/// a derivative, not a neighbour gained or lost).
#[test]
fn ball_quadrature_is_smooth_in_the_horizon() {
    let tip = |delta: f64| -> f64 {
        let mut v = scene("bracket-mesh-3d.json");
        v["model"]["horizon"] = json!(delta);
        v["solver"] = json!({"type": "cholesky"});
        let s = Problem::from_json_in(&v.to_string(), &data("")).unwrap().solve(&NoProgress).unwrap();
        let end: Vec<usize> = (0..s.x.len()).filter(|&n| s.x[n][0] > 0.39).collect();
        end.iter().map(|&n| s.u[3 * n + 1]).sum::<f64>() / end.len() as f64
    };
    let delta = 0.024;
    let (t0, t4, t5) = (tip(delta), tip(delta * (1.0 + 1e-4)), tip(delta * (1.0 + 1e-5)));
    let (d4, d5) = ((t4 - t0).abs() / t0.abs(), (t5 - t0).abs() / t0.abs());
    assert!(d4 <= 1e-3, "1e-4 change of delta: {d4:e}");
    assert!((5.0..=20.0).contains(&(d4 / d5)), "changes {d4:e} (1e-4) and {d5:e} (1e-5)");
}

/// The bundled Exodus II bracket (written by scipy's netCDF writer from the Gmsh mesh's
/// tetrahedra, examples/make_meshes.py, with a node set "clamp" of the mesh nodes on y = 0 and
/// a side set "load" of the faces on x = 0.4) reads as the Gmsh mesh: the same nodes and
/// volumes (the same vertices, 0 difference), the node set's elements (those with a face in it)
/// and the side set's equal to the Gmsh physical groups' of the same faces; the scenes solve to
/// the same displacements, as does the bundled VTU of the mesh (data/bracket-vtu-3d.json).
#[test]
fn exodus_bracket_reads_and_solves_as_the_gmsh_one() {
    let (e, g) =
        (read_exodus(&data("bracket-mesh-3d.e"), 3).unwrap(), read_gmsh(&data("bracket-mesh-3d.msh"), 3).unwrap());
    assert_eq!(e.positions, g.positions);
    assert_eq!(e.volumes, g.volumes);
    for set in ["clamp", "load", "bracket"] {
        assert_eq!(e.sets[set], g.sets[set], "set {set}");
    }
    assert_eq!(e.phase.iter().filter(|&&p| p == 1).count(), e.phase.len(), "one block, id 1");
    let solve =
        |name: &str| Problem::from_json_in(&scene(name).to_string(), &data("")).unwrap().solve(&NoProgress).unwrap();
    let (a, b) = (solve("bracket-exodus-3d.json"), solve("bracket-mesh-3d.json"));
    assert_eq!(a.u, b.u);
    // the bundled VTU of the same mesh (meshio), its sets by tag
    assert_eq!(solve("bracket-vtu-3d.json").u, b.u);
}

/// A quadratic Exodus block (TETRA10) is refused by name; written by scipy like the bundled
/// file.
#[test]
fn quadratic_exodus_blocks_are_named() {
    let dir = scratch("exodus");
    let script = r#"
import sys, numpy as np
from scipy.io import netcdf_file
f = netcdf_file(sys.argv[1], "w", version=2)
f.createDimension("num_dim", 3)
f.createDimension("num_nodes", 10)
f.createDimension("num_elem", 1)
f.createDimension("num_el_blk", 1)
f.createDimension("num_el_in_blk1", 1)
f.createDimension("num_nod_per_el1", 10)
for a in "xyz":
    v = f.createVariable("coord" + a, "d", ("num_nodes",))
    v[:] = np.random.default_rng(1).random(10)
v = f.createVariable("connect1", "i", ("num_el_in_blk1", "num_nod_per_el1"))
v[:] = np.arange(1, 11).reshape(1, 10)
v.elem_type = "TETRA10"
f.close()
"#;
    let path = dir.join("quadratic.e");
    let o = Command::new("python3").args(["-c", script, path.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = read_exodus(&path, 3).unwrap_err().to_string();
    assert!(e.contains("quadratic.e: block 1 (connect1): elem_type \"TETRA10\" with 10 nodes is not read"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The meshed plate with a hole against finite elements (examples/fe_plate_hole.py:
/// scikit-fem, P2 triangles on the same mesh refined once, converged to 1e-5 at the PD nodes):
/// with the `energy` correction (the bundled scene) the right edge's mean `u_x` within 0.5 %
/// of the FE's (measured +0.26 %; the issue's target is 2 %) and the largest nodal difference
/// within 5 % of max |u| (measured 3.9 %, at the pinned point and the hole's edge, where the
/// nonlocal model differs from the local one by its horizon); without it the edge is further
/// off (measured +0.83 %): the correction is what brings it there. LPS with the same
/// correction: see the bounds below.
#[test]
fn meshed_plate_matches_finite_elements() {
    let dir = scratch("fe");
    let compare = |scene: &Value, name: &str| -> (f64, f64) {
        let path = dir.join(format!("{name}.json"));
        let out = dir.join(name);
        std::fs::write(&path, scene.to_string()).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
            .args(["solve", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join("fe_plate_hole.py");
        let mesh = data("plate-hole-mesh-2d.msh");
        let result = out.join("result.json");
        let o = Command::new("python3")
            .args([script.to_str().unwrap(), mesh.to_str().unwrap(), "1", result.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "fe_plate_hole.py: {}", String::from_utf8_lossy(&o.stderr));
        let line = String::from_utf8_lossy(&o.stdout).lines().rfind(|l| l.starts_with('{')).unwrap().to_string();
        let r: Value = serde_json::from_str(&line).unwrap();
        let edge = r["edge_u_x"].as_f64().unwrap() / r["edge_u_x_fe"].as_f64().unwrap() - 1.0;
        (edge, r["max_error"].as_f64().unwrap())
    };
    let mut scene_v = scene("plate-hole-mesh-2d.json");
    scene_v["nodes"]["mesh"] = json!(data("plate-hole-mesh-2d.msh").to_str().unwrap());
    let (edge, max) = compare(&scene_v, "corrected");
    eprintln!("corrected: edge {edge:+.4e}, max {max:.4e}");
    assert!(edge.abs() <= 5e-3 && max <= 0.05, "corrected: edge {edge:e}, max {max:e}");
    scene_v["model"].as_object_mut().unwrap().remove("surface_correction");
    let (plain, _) = compare(&scene_v, "plain");
    eprintln!("uncorrected: edge {plain:+.4e}");
    assert!(plain.abs() > 2.0 * edge.abs(), "uncorrected {plain:e} against corrected {edge:e}");
    // LPS at the FE's E and nu with the cloud `energy` correction (classical target): right
    // edge within 2 % (measured +1.57 %; uncorrected -0.46 %), largest difference within 5 %
    // (measured 4.3 %; uncorrected 4.9 %)
    scene_v["model"] = json!({"type": "lps", "horizon": 0.02, "plane": "stress", "young_modulus": 1.0,
                              "poisson_ratio": 1.0 / 3.0, "surface_correction": "energy"});
    let (edge, max) = compare(&scene_v, "lps");
    eprintln!("lps, energy: edge {edge:+.4e}, max {max:.4e}");
    assert!(edge.abs() <= 2e-2 && max <= 0.05, "lps: edge {edge:e}, max {max:e}");
    let _ = std::fs::remove_dir_all(&dir);
}
