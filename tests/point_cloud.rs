//! Point clouds (`"nodes": {"csv": ...}`, issue #13 item 2): a cloud written from a grid
//! scene's nodes solves to the grid scene's displacements, and bad node files are refused
//! with the file and line named, nothing written.

use linpd::core::NoProgress;
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
    let dir = std::env::temp_dir().join(format!("linpd-point-cloud-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes the nodes of a grid scene as a CSV cloud (positions in Rust's shortest round-trip
/// form, so they read back bit for bit) and returns the cloud scene that reads it.
fn as_cloud(grid_scene: &Value, dir: &Path) -> Value {
    let p = Problem::from_json(&grid_scene.to_string()).unwrap();
    let nodes = p.nodes();
    let d = p.dim();
    let names = ["x", "y", "z"];
    let mut csv = format!("# written from the grid of {}\n{},volume,layer\n", p.name(), names[..d].join(","));
    for n in 0..nodes.len() {
        let x = nodes.position(n);
        let coords: Vec<String> = (0..d).map(|a| format!("{:?}", x[a])).collect();
        csv += &format!("{},{:?},{}\n", coords.join(","), nodes.volume(n), nodes.is_layer(n) as u8);
    }
    std::fs::write(dir.join("nodes.csv"), csv).unwrap();
    let mut s = grid_scene.clone();
    let o = s.as_object_mut().unwrap();
    o.remove("grid");
    o.remove("body");
    o.insert("nodes".into(), json!({"csv": dir.join("nodes.csv").to_str().unwrap()}));
    s
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

/// The bundled plate with a hole (a body, partial volumes, a resultant load) and the 3D
/// cantilever, solved on the grid and as a point cloud of the same nodes.
///
/// The operators agree to 1e-14 (applied to the same vector): the cloud's bond vectors are
/// `x_j - x_i` of the rounded positions where the lattice uses the exact `(k_j - k_i) h`, a
/// few ulps apart. The solutions then differ by the solver's rounding: the lattice's Cholesky
/// orders by nested dissection, the cloud's by AMD, and each has a backward error of a few
/// eps, which `cond(K_ff)` amplifies. Measured max |u_cloud - u_grid| / max |u|: plate 6.6e-13,
/// cantilever 7.4e-12, cantilever at a binary spacing (h = 1/32: positions and bond vectors
/// exact) 1.0e-12, so the positions are not the cause; bound 1e-11. Layer flags, volumes,
/// reactions and energy densities carry over.
#[test]
fn cloud_of_grid_nodes_gives_the_grid_solution() {
    let binary = |mut s: Value| {
        s["grid"] =
            json!({"min": [0.0, 0.0, 0.0], "max": [1.0, 0.125, 0.125], "spacing": 0.03125, "layer": {"x-": 0.09375}});
        s["model"]["horizon"] = json!(0.09375);
        s
    };
    let cases = [
        ("plate-hole-2d", scene("plate-hole-2d.json"), true),
        ("cantilever-3d", scene("cantilever-3d.json"), false),
        ("cantilever-3d at h = 1/32", binary(scene("cantilever-3d.json")), false),
    ];
    for (name, mut grid_scene, partial_volume) in cases {
        let dir = scratch(&name.replace([' ', '/'], "_"));
        grid_scene["model"]["partial_volume"] = json!(partial_volume);
        grid_scene["solver"] = json!({"type": "cholesky"});
        let cloud_scene = as_cloud(&grid_scene, &dir);
        let grid = Problem::from_json(&grid_scene.to_string()).unwrap();
        let cloud = Problem::from_json(&cloud_scene.to_string()).unwrap();
        assert!(cloud.grid().is_none() && cloud.nodes().cloud().is_some());
        // the same operator: K u on a fixed pseudo-random u
        let (kg, kc) = (grid.operator().unwrap(), cloud.operator().unwrap());
        let u: Vec<f64> = (0..kg.n_dofs()).map(|k| ((k * 7919 % 1000) as f64 / 500.0) - 1.0).collect();
        let (mut yg, mut yc) = (vec![0.0; u.len()], vec![0.0; u.len()]);
        kg.apply(&u, &mut yg);
        kc.apply(&u, &mut yc);
        let op_diff = max_rel_diff(&yg, &yc);
        assert!(op_diff < 1e-14, "{name}: max |K_cloud u - K_grid u| / max |K u| = {op_diff:e}");
        let on_grid = grid.solve(&NoProgress).unwrap();
        let on_cloud = cloud.solve(&NoProgress).unwrap();
        assert_eq!(on_cloud.u.len(), on_grid.u.len());
        assert_eq!(on_cloud.n_bonds, on_grid.n_bonds, "{name}: the cell-list families equal the stencil's");
        let diff = max_rel_diff(&on_grid.u, &on_cloud.u);
        eprintln!("{name}: max |u_cloud - u_grid| / max |u| = {diff:e}");
        assert!(diff < 1e-11, "{name}: max |u_cloud - u_grid| / max |u| = {diff:e}");
        assert_eq!(on_cloud.is_layer, on_grid.is_layer);
        assert_eq!(on_cloud.volumes, on_grid.volumes);
        let (bg, bc) = (on_grid.balance.unwrap(), on_cloud.balance.unwrap());
        assert!(bc.relative_imbalance < 1e-10, "{name}: imbalance {:e}", bc.relative_imbalance);
        assert!(max_rel_diff(&bg.reaction, &bc.reaction) < 1e-10, "{name}");
        let (wg, wc) = (on_grid.strain_energy_density.unwrap(), on_cloud.strain_energy_density.unwrap());
        assert!(max_rel_diff(&wg, &wc) < 1e-10, "{name}");
    }
}

/// LPS on a point cloud (`LpsModel::on_points`: bond vectors from positions, two-hop tangent
/// pattern from the family, AMD ordering): the cloud of a grid scene's nodes gives the grid
/// solution, for the bundled 2D LPS plate (with partial volumes; with two phases; with the
/// `energy` and `position_aware` corrections), the notched plate (a pre-crack) and a 3D LPS
/// bar. Tangents applied to the same vector agree to 1e-13 (bond vectors
/// of rounded positions, a few ulps from the lattice's exact ones, in every dilatation and pair
/// term; measured 0..1.8e-15); solutions to 1e-12 (measured 1.8e-14, 2.4e-13, 1.5e-14: the two
/// Cholesky orderings' rounding times `cond(K_ff)`).
#[test]
fn lps_on_a_cloud_of_grid_nodes_gives_the_grid_solution() {
    let mut plate = scene("lps-plate-2d.json");
    plate["model"]["partial_volume"] = json!(true);
    // two phases (issue #33): the right half stiffer, with another Poisson ratio
    let mut phases = scene("lps-plate-2d.json");
    phases["model"]["material"] = json!({"phases": [{"region": {"half_space": {"point": [0.5, 0.0], "normal": [1.0, 0.0]}},
                                                      "young_modulus": 4.0, "poisson_ratio": 0.3}]});
    // the moment-matching corrections towards the classical target (issue #33): the cloud
    // fits each node's family on its own, the lattice its surface families and one interior
    let corrected = |c: &str| {
        let mut v = scene("lps-plate-2d.json");
        v["model"]["surface_correction"] = json!(c);
        v
    };
    let cases = [
        ("lps-plate-2d", plate),
        ("lps-plate-2d-phases", phases),
        ("lps-plate-2d-energy", corrected("energy")),
        ("lps-plate-2d-position-aware", corrected("position_aware")),
        ("plate-notch-2d", scene("plate-notch-2d.json")),
        ("lps-tension-3d", scene("lps-tension-3d.json")),
    ];
    for (name, mut grid_scene) in cases {
        let dir = scratch(&format!("lps-{name}"));
        grid_scene["solver"] = json!({"type": "cholesky"});
        let cloud_scene = as_cloud(&grid_scene, &dir);
        let grid = Problem::from_json(&grid_scene.to_string()).unwrap();
        let cloud = Problem::from_json(&cloud_scene.to_string()).unwrap();
        assert!(cloud.grid().is_none());
        let (mg, mc) = (grid.lps_model().unwrap(), cloud.lps_model().unwrap());
        assert!(mc.grid().is_none());
        let u: Vec<f64> = (0..mg.n_dofs()).map(|k| ((k * 7919 % 1000) as f64 / 500.0) - 1.0).collect();
        let (mut yg, mut yc) = (vec![0.0; u.len()], vec![0.0; u.len()]);
        mg.apply_tangent(&u, &mut yg);
        mc.apply_tangent(&u, &mut yc);
        let op_diff = max_rel_diff(&yg, &yc);
        let (ag, ac) = (linpd::lps::assemble_tangent(&mg), linpd::lps::assemble_tangent(&mc));
        // the lattice pattern keeps every stencil offset (structural zeros included), the cloud's
        // two-hop pattern only the family's: equal without defects, smaller across a cut
        let (ng, nc) = (ag.val().len(), ac.val().len());
        assert!(nc <= ng && (name == "plate-notch-2d" || nc == ng), "{name}: pattern {nc} vs {ng}");
        let on_grid = grid.solve(&NoProgress).unwrap();
        let on_cloud = cloud.solve(&NoProgress).unwrap();
        let diff = max_rel_diff(&on_grid.u, &on_cloud.u);
        eprintln!("{name}: tangent apply {op_diff:e}, u {diff:e}");
        assert!(op_diff < 1e-13, "{name}: max |A_cloud u - A_grid u| / max |A u| = {op_diff:e}");
        assert!(diff < 1e-12, "{name}: max |u_cloud - u_grid| / max |u| = {diff:e}");
        let (tg, tc) = (on_grid.dilatation.unwrap(), on_cloud.dilatation.unwrap());
        assert!(max_rel_diff(&tg, &tc) < 1e-9, "{name}: dilatation");
        assert!(on_cloud.balance.unwrap().relative_imbalance < 1e-10, "{name}");
        if name.contains("energy") || name.contains("position") {
            // the correction acts: the uncorrected plate differs by more than 0.1 % (measured
            // 0.43 % with energy; the solutions above agree to 1e-12)
            let plain =
                Problem::from_json(&scene("lps-plate-2d.json").to_string()).unwrap().solve(&NoProgress).unwrap();
            let change = max_rel_diff(&plain.u, &on_cloud.u);
            assert!(change > 1e-3, "{name}: the correction changed u by {change:e} only");
        }
    }
}

/// Phases (by region) and a cut along a segment act on the cloud as on the grid.
#[test]
fn cloud_with_phases_and_a_crack_matches_the_grid() {
    let dir = scratch("material");
    let mut s = scene("plate-hole-2d.json");
    s["solver"] = json!({"type": "cholesky"});
    // the lattice's quadrature (a cloud's default is the ball fraction)
    s["model"]["partial_volume"] = json!(false);
    s["model"]["material"] = json!({
        "phases": [{"region": {"box": {"min": [0.7, 0.0], "max": [1.0, 0.5]}}, "modulus": 3.0}],
        "defects": [{"segment": [[0.305, 0.0], [0.305, 0.12]], "factor": 0.0}]
    });
    let cloud_scene = as_cloud(&s, &dir);
    let a = Problem::from_json(&s.to_string()).unwrap().solve(&NoProgress).unwrap();
    let b = Problem::from_json(&cloud_scene.to_string()).unwrap().solve(&NoProgress).unwrap();
    let diff = max_rel_diff(&a.u, &b.u);
    // measured 1.6e-12; the bound of the test above
    assert!(diff < 1e-11, "max |u_cloud - u_grid| / max |u| = {diff:e}");
    // the crack and the stiff phase change the solution (the comparison is not vacuous)
    let plain = Problem::from_json(&scene("plate-hole-2d.json").to_string()).unwrap().solve(&NoProgress).unwrap();
    assert!(max_rel_diff(&plain.u, &b.u) > 1e-3);
}

fn cloud_error(csv: &str, edit: impl Fn(&mut Value)) -> String {
    let dir = scratch("bad");
    std::fs::write(dir.join("bad.csv"), csv).unwrap();
    let mut s = scene("plate-hole-2d.json");
    let o = s.as_object_mut().unwrap();
    o.remove("grid");
    o.remove("body");
    s["nodes"] = json!({"csv": dir.join("bad.csv").to_str().unwrap()});
    edit(&mut s);
    match Problem::from_json(&s.to_string()) {
        Ok(_) => panic!("accepted {csv:?}"),
        Err(e) => e.to_string(),
    }
}

/// Missing column, negative volume, NaN, duplicate points, and scene keys that need a grid:
/// each a clear error naming the key and, for the file, its line.
#[test]
fn bad_clouds_are_refused_with_the_line() {
    let e = cloud_error("x,volume\n0,1\n", |_| {});
    assert!(e.contains("nodes.csv: ") && e.contains("bad.csv line 1: missing column \"y\""), "{e}");
    let e = cloud_error("x,y,volume\n0,0,1e-4\n0.01,0,-1e-4\n", |_| {});
    assert!(e.contains("bad.csv line 3: volume = -1e-4 must be > 0"), "{e}");
    let e = cloud_error("x,y,volume\n0,0,1e-4\n0.01,nan,1e-4\n", |_| {});
    assert!(e.contains("bad.csv line 3: y = nan is not finite"), "{e}");
    let e = cloud_error("x,y,volume\n0,0,1e-4\n0.01,0,1e-4\n0,0,1e-4\n", |_| {});
    assert!(e.contains("bad.csv line 4: the node at [0.0, 0.0] coincides with the node of line 2"), "{e}");
    let ok = "x,y,volume\n0,0,1e-4\n0.01,0,1e-4\n";
    let e = cloud_error(ok, |s| s["grid"] = json!({"min": [0, 0], "max": [1, 1], "spacing": 0.1}));
    assert!(e.starts_with("grid: give either \"grid\" or \"nodes\""), "{e}");
    let e = cloud_error(ok, |s| s["solver"] = json!({"type": "cg", "matrix_free": true}));
    assert!(
        e.starts_with("solver.matrix_free: ") && e.contains("the matrix-free stencil operator needs a grid"),
        "{e}"
    );
    let e = cloud_error(ok, |s| s["model"]["micromodulus"]["normalize"] = json!("discrete"));
    assert!(e.starts_with("model.micromodulus.normalize: \"discrete\" on a point cloud averages"), "{e}");
    let e = cloud_error(ok, |s| {
        s["constraints"] = json!([]);
        s["loads"] = json!([{"type": "traction", "face": "x+", "traction": [1.0, 0.0]}]);
    });
    assert!(
        e.starts_with("loads[0].type: a traction acts on a face of the grid's box; the point cloud has none"),
        "{e}"
    );
    let e = cloud_error(ok, |s| s["nodes"] = json!({}));
    assert!(e.starts_with("nodes: give exactly one of"), "{e}");
}

/// From the CLI: a bad cloud exits non-zero with the file line and writes nothing.
#[test]
fn cli_refuses_a_bad_cloud_and_writes_nothing() {
    let dir = scratch("cli");
    std::fs::write(dir.join("c.csv"), "x,y,volume\n0,0,1e-4\n1,1,NaN\n").unwrap();
    let mut s = scene("plate-hole-2d.json");
    let o = s.as_object_mut().unwrap();
    o.remove("grid");
    o.remove("body");
    s["nodes"] = json!({"csv": "c.csv"});
    s["output"] = json!({"dir": dir.join("out").to_str().unwrap()});
    std::fs::write(dir.join("scene.json"), s.to_string()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_linpd")).arg("solve").arg(dir.join("scene.json")).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("c.csv line 3: volume = NaN is not finite"), "{err}");
    assert!(!dir.join("out").exists(), "nothing written");
}

/// A phase given by the cloud's `phase` column acts as the same phase given by region: the
/// solutions are identical (the same moduli reach the same bond weights). A phase number no
/// node carries, and a phase number on a grid, are errors.
#[test]
fn phase_column_selects_the_phase() {
    let dir = scratch("phase");
    let mut s = scene("plate-hole-2d.json");
    s["solver"] = json!({"type": "cholesky"});
    let stiff = json!({"box": {"min": [0.7, -1.0], "max": [2.0, 2.0]}});
    s["model"]["material"] = json!({"phases": [{"region": stiff, "modulus": 3.0}]});
    let by_region = as_cloud(&s, &dir);
    // the same cloud with a phase column: 1 inside the stiff box, 0 elsewhere
    let text = std::fs::read_to_string(dir.join("nodes.csv")).unwrap();
    let mut tagged = String::new();
    for (k, line) in text.lines().enumerate() {
        match k {
            0 => tagged += &format!("{line}\n"),
            1 => tagged += &format!("{line},phase\n"),
            _ => {
                let x: f64 = line.split(',').next().unwrap().parse().unwrap();
                tagged += &format!("{line},{}\n", (x >= 0.7 - 1e-12) as u8);
            }
        }
    }
    std::fs::write(dir.join("tagged.csv"), tagged).unwrap();
    let mut by_tag = by_region.clone();
    by_tag["nodes"]["csv"] = json!(dir.join("tagged.csv").to_str().unwrap());
    by_tag["model"]["material"] = json!({"phases": [{"phase": 1, "modulus": 3.0}]});
    let a = Problem::from_json(&by_region.to_string()).unwrap().solve(&NoProgress).unwrap();
    let b = Problem::from_json(&by_tag.to_string()).unwrap().solve(&NoProgress).unwrap();
    assert_eq!(a.u, b.u);
    let plain = Problem::from_json(&as_cloud(&scene("plate-hole-2d.json"), &scratch("phase-plain")).to_string())
        .unwrap()
        .solve(&NoProgress)
        .unwrap();
    assert!(max_rel_diff(&plain.u, &b.u) > 1e-3, "the phase changes the solution");
    let mut missing = by_tag.clone();
    missing["model"]["material"]["phases"][0]["phase"] = json!(7);
    let e = Problem::from_json(&missing.to_string()).unwrap_err().to_string();
    assert!(e.starts_with("model.material.phases[0].phase: no node of the cloud has phase 7"), "{e}");
    let mut on_grid = scene("plate-hole-2d.json");
    on_grid["model"]["material"] = json!({"phases": [{"phase": 1, "modulus": 3.0}]});
    let e = Problem::from_json(&on_grid.to_string()).unwrap_err().to_string();
    assert!(e.starts_with("model.material.phases[0].phase: phase numbers come from a point cloud"), "{e}");
}

/// Writes VTK files from a CSV cloud with meshio (the VTK reader of .ci/run): `.vtu` zlib
/// (meshio's default), `.vtu` raw binary, `.vtu` ascii, legacy binary `.vtk`, plus bad files.
fn meshio_files(csv: &Path, dir: &Path) {
    let script = r#"
import sys, numpy as np, meshio
csv, out = sys.argv[1], sys.argv[2]
a = np.loadtxt(csv, delimiter=",", skiprows=2)
pts = np.zeros((len(a), 3)); pts[:, :2] = a[:, :2]
vol, layer = a[:, 2], a[:, 3]
cells = [("vertex", np.arange(len(a)).reshape(-1, 1))]
def mesh(p=pts, **data):
    return meshio.Mesh(p, cells, point_data=data)
meshio.write(out + "/zlib.vtu", mesh(volume=vol, layer=layer))
meshio.write(out + "/raw.vtu", mesh(volume=vol, layer=layer), compression=None)
meshio.write(out + "/ascii.vtu", mesh(volume=vol, layer=layer), binary=False)
meshio.write(out + "/legacy.vtk", mesh(volume=vol, layer=layer))
meshio.write(out + "/no-volume.vtu", mesh(layer=layer))
bad = vol.copy(); bad[7] = -1.0
meshio.write(out + "/negative.vtu", mesh(volume=bad))
z = pts.copy(); z[3, 2] = 0.5
meshio.write(out + "/z.vtu", mesh(p=z, volume=vol))
"#;
    let py = Command::new("python3").arg("-c").arg(script).arg(csv).arg(dir).output().expect("python3 runs");
    assert!(py.status.success(), "meshio: {}", String::from_utf8_lossy(&py.stderr));
}

/// `"nodes": {"vtk": ...}`: the plate's nodes written by meshio as .vtu (zlib, raw binary,
/// ascii) and legacy .vtk, and linpd's own result.vtu of the grid solve (17 digits), all solve
/// to the CSV cloud's displacements: bit for bit, as they carry the float64 values exactly,
/// except meshio's ascii, which prints fewer digits (measured 2.8e-14, bound 1e-12).
/// Files without the
/// volume array, with a negative volume or a nonzero z in 2D are refused naming the point.
#[test]
fn vtk_clouds_read_like_csv() {
    let dir = scratch("vtk");
    let mut s = scene("plate-hole-2d.json");
    s["solver"] = json!({"type": "cholesky"});
    let csv_scene = as_cloud(&s, &dir);
    let want = Problem::from_json(&csv_scene.to_string()).unwrap().solve(&NoProgress).unwrap();
    meshio_files(&dir.join("nodes.csv"), &dir);
    // linpd's own output as input: the grid scene's result.vtu carries volume and layer
    let out = dir.join("grid-out");
    Problem::from_json(&s.to_string()).unwrap().solve(&NoProgress).unwrap().write(&out).unwrap();
    let with = |file: &Path| {
        let mut v = csv_scene.clone();
        v["nodes"] = json!({"vtk": file.to_str().unwrap()});
        v
    };
    for (name, bound) in
        [("zlib.vtu", 0.0), ("raw.vtu", 0.0), ("ascii.vtu", 1e-12), ("legacy.vtk", 0.0), ("grid-out/result.vtu", 0.0)]
    {
        let p = Problem::from_json(&with(&dir.join(name)).to_string()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(p.nodes().len(), want.x.len(), "{name}");
        let got = p.solve(&NoProgress).unwrap();
        assert_eq!(got.is_layer, want.is_layer, "{name}");
        let diff = max_rel_diff(&want.u, &got.u);
        eprintln!("{name}: max |u - u_csv| / max |u| = {diff:e}");
        assert!(diff <= bound, "{name}: {diff:e}");
    }
    let error = |name: &str| Problem::from_json(&with(&dir.join(name)).to_string()).unwrap_err().to_string();
    let e = error("no-volume.vtu");
    assert!(e.starts_with("nodes.vtk: ") && e.contains("no-volume.vtu: no point array \"volume\""), "{e}");
    let e = error("negative.vtu");
    assert!(e.contains("negative.vtu: point 7: volume = -1e0 must be > 0"), "{e}");
    let e = error("z.vtu");
    assert!(e.contains("z.vtu: point 3: coordinate 2 = 5e-1 in a 2D scene (must be 0)"), "{e}");
    std::fs::write(dir.join("junk.vtu"), "<VTKFile type=\"UnstructuredGrid\"><oops").unwrap();
    let e = error("junk.vtu");
    assert!(e.contains("junk.vtu: not a readable VTK file"), "{e}");
}

/// The `energy` surface correction on a cloud (classical target, every node fitted on its own)
/// equals the corrected lattice when the cloud is the lattice's nodes: the bundled
/// 8-cells-across cantilever with cell placement, continuum normalization and whole volumes,
/// solved on both to 1e-10 relative (each interior node's fit reproduces the lattice's shared
/// bulk fit to the Newton solve's round-off, the rest is the two Cholesky orderings). The
/// correction changes the cloud's solution (by more than 10 %: the thin beam's soft surface).
#[test]
fn corrected_cloud_of_a_grid_equals_the_corrected_grid() {
    let dir = scratch("corrected");
    let mut s = scene("cantilever-cell-3d.json");
    s["model"]["micromodulus"]["normalize"] = json!("continuum");
    s["model"]["partial_volume"] = json!(false);
    s["model"]["surface_target"] = json!("classical");
    s["solver"] = json!({"type": "cholesky"});
    let cloud_scene = as_cloud(&s, &dir);
    let a = Problem::from_json(&s.to_string()).unwrap().solve(&NoProgress).unwrap();
    let b = Problem::from_json(&cloud_scene.to_string()).unwrap().solve(&NoProgress).unwrap();
    let diff = max_rel_diff(&a.u, &b.u);
    eprintln!("corrected cantilever: max |u_cloud - u_grid| / max |u| = {diff:e}");
    assert!(diff < 1e-10, "max |u_cloud - u_grid| / max |u| = {diff:e}");
    let mut plain = cloud_scene.clone();
    plain["model"].as_object_mut().unwrap().remove("surface_correction");
    plain["model"].as_object_mut().unwrap().remove("surface_target");
    let c = Problem::from_json(&plain.to_string()).unwrap().solve(&NoProgress).unwrap();
    assert!(max_rel_diff(&b.u, &c.u) > 0.1, "the correction changed the cloud by {:e}", max_rel_diff(&b.u, &c.u));
    let _ = std::fs::remove_dir_all(&dir);
}
