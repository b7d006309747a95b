//! Bodies of any shape, per-side layers, resultant loads and the force balance in result.json
//! (issue #13, items 1 and 4, and the reactions of item 5), on the bundled scenes
//! `data/plate-hole-2d.json` (a plate with a circular hole pulled by a resultant force) and
//! `data/cantilever-3d.json` (a layer at the clamped end only, a resultant tip load).

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

fn error_of(v: &Value) -> String {
    match Problem::from_json(&v.to_string()) {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    }
}

/// Lattice points `(i, j)` with `i^2 + j^2 <= r^2` (Gauss's circle problem), by counting.
fn gauss(r: i64) -> usize {
    (-r..=r).flat_map(|i| (-r..=r).map(move |j| i * i + j * j)).filter(|s| *s <= r * r).count()
}

/// The plate with a hole keeps the grid's nodes outside the closed disk: (101 + 2 x 3) x 51
/// lattice sites (layers at x- and x+ only) less the 317 sites of the disk of radius 10 h
/// centred on a node (boundary nodes belong to the disk, so they are removed with it).
#[test]
fn body_node_count_matches_an_independent_count() {
    let p = Problem::from_path(&data("plate-hole-2d.json")).unwrap();
    let sites = (101 + 6) * 51;
    assert_eq!(gauss(10), 317);
    assert_eq!(p.nodes().len(), sites - gauss(10));
    let grid = p.grid().unwrap();
    assert_eq!(grid.n_sites(), sites);
    // no node inside the open disk, every node outside it kept
    for n in 0..p.nodes().len() {
        let x = p.nodes().position(n);
        assert!((x[0] - 0.5).hypot(x[1] - 0.25) > 0.1 + 1e-9, "node {n} at {x:?} is in the hole");
    }
    // the layer is on the x sides only: 3 columns of 51 at each end
    let layer = (0..p.nodes().len()).filter(|&n| p.nodes().is_layer(n)).count();
    assert_eq!(layer, 2 * 3 * 51);
}

/// The cantilever's layer (0.075 = 3h) is at x- only: 3 planes of 5 x 5 nodes behind x = 0;
/// the beam keeps its 0.1 x 0.1 section (41 x 5 x 5 nodes).
#[test]
fn per_side_layer_only_where_asked() {
    let p = Problem::from_path(&data("cantilever-3d.json")).unwrap();
    assert_eq!(p.nodes().len(), 41 * 25 + 3 * 25);
    for n in 0..p.nodes().len() {
        let x = p.nodes().position(n);
        assert_eq!(p.nodes().is_layer(n), x[0] < 0.0, "node {n} at {x:?}");
        assert!(x[1] >= -1e-12 && x[1] <= 0.1 + 1e-12 && x[2] >= -1e-12 && x[2] <= 0.1 + 1e-12);
    }
}

/// A resultant load applies its total whatever the spacing: the plate at h and h/2 (its
/// load region catches 4 x 51 and 7 x 101 nodes) gets exactly `F` (to `eps` times the number
/// of nodes summed), where a body load on the same region applies `density x` the caught
/// volume, which moves with the layer columns the region catches.
#[test]
fn resultant_total_is_the_same_at_h_and_h_over_2() {
    for h in [0.01, 0.005] {
        let mut s = scene("plate-hole-2d.json");
        s["grid"]["spacing"] = json!(h);
        let p = Problem::from_json(&s.to_string()).unwrap();
        let f = p.load_vector();
        let (fx, fy): (f64, f64) = (f.iter().step_by(2).sum(), f.iter().skip(1).step_by(2).sum());
        assert!((fx - 0.5).abs() < 1e-13 && fy == 0.0, "h = {h}: total ({fx}, {fy})");
        let loaded = f.iter().step_by(2).filter(|v| **v != 0.0).count();
        // the region x >= 1 catches the body's last column and the layer's 3 (6 at h/2)
        assert_eq!(loaded, if h == 0.01 { 4 * 51 } else { 7 * 101 }, "h = {h}");
    }
}

/// The reactions of the constraints balance the applied loads (`1^T A = 0` for the symmetric
/// bond-based and LPS operators; the solves stop at a relative residual of ~1e-13, so 1e-10
/// is a wide bound), in result.json through the binary and in the library for an LPS scene.
#[test]
fn reactions_balance_the_applied_loads() {
    for name in ["plate-hole-2d.json", "cantilever-3d.json"] {
        let out = std::env::temp_dir().join(format!("linpd-balance-{}-{name}", std::process::id()));
        let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
            .args(["solve", data(name).to_str().unwrap(), "-q", "--out", out.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("applied force") && stdout.contains("reactions"), "{stdout}");
        let r: Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
        let b = &r["balance"];
        let v = |x: &Value| x.as_array().unwrap().iter().map(|c| c.as_f64().unwrap()).collect::<Vec<f64>>();
        let (applied, reaction) = (v(&b["applied"]), v(&b["reaction"]));
        let scale = applied.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for a in 0..applied.len() {
            assert!((applied[a] + reaction[a]).abs() <= 1e-10 * scale, "{name}: {applied:?} vs {reaction:?}");
        }
        assert!(b["relative_imbalance"].as_f64().unwrap() <= 1e-10);
        assert_eq!(b["loads"][0]["kind"], "resultant");
        let _ = std::fs::remove_dir_all(&out);
    }
    let p = Problem::from_path(&data("lps-plate-2d.json")).unwrap();
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    let b = s.balance.expect("an lps solve reports its balance");
    assert!(b.relative_imbalance <= 1e-10, "lps: {b:?}");
    assert!(b.constraints.iter().all(|c| c.nodes > 0 && c.dofs > 0));
}

/// With a body the matrix-free solve runs on the stencil of the lattice box with the bonds
/// that the hole removes as corrections (`linpd_bond::CorrectedStencil`) and agrees with the
/// direct solve. CG stops at a true relative residual of
/// 1e-12; measured agreement 6.1e-14 (108 iterations). The bound 1e-10 leaves a factor 1000
/// for the conditioning while any operator that treated the hole differently would move `u`
/// by O(1).
#[test]
fn matrix_free_cg_with_a_body_agrees_with_cholesky() {
    let mut s = scene("plate-hole-2d.json");
    s["grid"]["spacing"] = json!(0.025);
    s["model"]["horizon"] = json!(0.075);
    s["grid"]["layer"] = json!({"x-": 0.075, "x+": 0.075});
    let direct = Problem::from_json(&s.to_string()).unwrap().solve(&linpd::core::NoProgress).unwrap();
    s["solver"] = json!({"type": "cg", "matrix_free": true, "rtol": 1e-12});
    let cg = Problem::from_json(&s.to_string()).unwrap().solve(&linpd::core::NoProgress).unwrap();
    let scale = direct.u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let e = direct.u.iter().zip(&cg.u).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / scale;
    println!("matrix-free CG vs Cholesky: {e:e}, {:?} CG iterations", cg.report.iterations);
    assert_eq!(cg.report.solver.to_string(), "cg-jacobi-matrix-free-corrected-stencil");
    assert!(e < 1e-10, "matrix-free CG vs Cholesky: {e:e}");
}

/// Bad bodies, layers and resultants: each an error naming the key.
#[test]
fn bad_bodies_layers_and_resultants_are_named() {
    let base = scene("plate-hole-2d.json");
    let with = |path: &[&str], v: Value| {
        let mut s = base.clone();
        let mut t = &mut s;
        for k in &path[..path.len() - 1] {
            t = &mut t[*k];
        }
        t[path[path.len() - 1]] = v;
        s
    };
    let cases = [
        (with(&["body"], json!({"ball": {"center": [5.0, 5.0], "radius": 0.1}})), "body: keeps none of the"),
        (with(&["body"], json!({"ball": {"center": [0.5, 0.25], "radius": 0.0}})), "body.ball.radius: must be > 0"),
        (
            with(&["body"], json!({"polygon": {"vertices": [[0.0, 0.0], [1.0, 0.0]]}})),
            "body.polygon.vertices: needs at least 3",
        ),
        (
            with(&["body"], json!({"cylinder": {"center": [0.0, 0.0], "axis": [1.0, 0.0], "radius": 1.0}})),
            "body.cylinder: is a 3D region",
        ),
        (with(&["body"], json!({"ball": {"center": [0.5], "radius": 0.1}})), "body.ball.center"),
        (with(&["grid", "layer"], json!({"w-": 0.03})), "grid.layer.w-: not a side of a 2D grid"),
        (with(&["grid", "layer"], json!({"z-": 0.03})), "grid.layer.z-: not a side of a 2D grid"),
        (with(&["grid", "layer"], json!({"x-": -0.03})), "grid.layer.x-: must be >= 0"),
        (with(&["grid", "layer"], json!("thick")), "grid.layer: expected a number"),
        (
            with(
                &["loads"],
                json!([{"type": "resultant", "region": {"box": {"min": [5.0, 5.0], "max": [6.0, 6.0]}}, "force": [1.0, 0.0]}]),
            ),
            "loads[0].region: contains no node of the grid",
        ),
        (
            with(&["loads"], json!([{"type": "resultant", "region": "all", "density": [1.0, 0.0]}])),
            "loads[0].density: not a key of a resultant load",
        ),
        (with(&["loads"], json!([{"type": "resultant", "region": "all"}])), "loads[0].force: missing"),
    ];
    for (s, needle) in cases {
        let e = error_of(&s);
        assert!(e.contains(needle), "expected `{needle}` in: {e}");
    }
    // a body removes the nodes a point load named: the nearest kept node is named
    let s = with(&["loads"], json!([{"type": "point", "at": [0.5, 0.25], "force": [1.0, 0.0]}]));
    assert!(error_of(&s).contains("no node at [0.5, 0.25]"), "{}", error_of(&s));
    // blend scenes take no body
    let blend = scene("blend-point-load.json");
    let mut b = blend.clone();
    b["body"] = json!({"box": {"min": [0.0], "max": [0.5]}});
    assert!(error_of(&b).contains("body: blend models live on the whole interval"), "{}", error_of(&b));
    // through the binary: exit code 1, nothing written
    let dir = std::env::temp_dir().join(format!("linpd-bad-body-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.json");
    std::fs::write(&path, with(&["body"], json!({"ball": {"center": [5.0, 5.0], "radius": 0.1}})).to_string()).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["solve", path.to_str().unwrap(), "--out", dir.join("out").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(!dir.join("out").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `result.vtu` opens in a real VTK reader (meshio, installed by `.ci/run`) with the values of
/// result.json (both written with 17 significant digits: equal to the last bit, compared at
/// 1e-15 relative for the text round trip of a different parser), and the strain energy
/// density sums to the stored energy, `sum_i W_i V_i = u.A u / 2` (to 1e-12: one sum of 5140
/// positive terms against one dot product).
#[test]
fn vtu_round_trips_through_meshio_and_energy_density_sums_to_the_energy() {
    let out = std::env::temp_dir().join(format!("linpd-vtu-{}", std::process::id()));
    let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["solve", data("plate-hole-2d.json").to_str().unwrap(), "-q", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let script = r#"
import json, sys, meshio
m = meshio.read(sys.argv[1])
assert len(m.cells) == 1 and m.cells[0].type == "vertex", m.cells
print(json.dumps({"points": m.points.tolist(), "u": m.point_data["u"].tolist(),
                  "layer": m.point_data["layer"].tolist(), "volume": m.point_data["volume"].tolist(),
                  "w": m.point_data["strain_energy_density"].tolist()}))
"#;
    let py = Command::new("python3").arg("-c").arg(script).arg(out.join("result.vtu")).output().expect("python3 runs");
    assert!(py.status.success(), "meshio could not read result.vtu: {}", String::from_utf8_lossy(&py.stderr));
    let vtu: Value = serde_json::from_slice(&py.stdout).unwrap();
    let r: Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let num = |v: &Value| v.as_f64().unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * a.abs().max(b.abs());
    let n = r["x"].as_array().unwrap().len();
    assert_eq!(vtu["points"].as_array().unwrap().len(), n);
    for k in 0..n {
        for a in 0..2 {
            assert!(close(num(&vtu["points"][k][a]), num(&r["x"][k][a])), "x[{k}][{a}]");
            assert!(close(num(&vtu["u"][k][a]), num(&r["u"][k][a])), "u[{k}][{a}]");
        }
        assert_eq!(num(&vtu["points"][k][2]), 0.0);
        assert_eq!(num(&vtu["layer"][k]) == 1.0, r["layer"][k].as_bool().unwrap());
        assert!(close(num(&vtu["w"][k]), num(&r["strain_energy_density"][k])), "W[{k}]");
    }
    // sum W_i V_i against u.A u / 2 from the library's operator
    let p = Problem::from_path(&data("plate-hole-2d.json")).unwrap();
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    let model = p.lattice_model().unwrap();
    let mut au = vec![0.0; s.u.len()];
    linpd::core::Model::apply(&model, &s.u, &mut au);
    let energy = 0.5 * s.u.iter().zip(&au).map(|(a, b)| a * b).sum::<f64>();
    let w = s.strain_energy_density.as_ref().unwrap();
    let summed: f64 = w.iter().zip(&s.volumes).map(|(w, v)| w * v).sum();
    assert!(w.iter().all(|x| *x >= 0.0), "bond energy density is >= 0");
    assert!((summed / energy - 1.0).abs() < 1e-12, "sum W V = {summed:e}, u.Au/2 = {energy:e}");
    let volumes: Vec<f64> = (0..n).map(|k| num(&vtu["volume"][k])).collect();
    assert!(volumes.iter().all(|v| close(*v, 1e-4)), "volumes h^2");
    let _ = std::fs::remove_dir_all(&out);
}

/// A pre-crack (a defect segment that cuts the bonds it crosses) outside the body, or inside
/// its hole, cuts nothing: an error naming the defect; the bundled notched plate's crack cuts.
#[test]
fn a_crack_that_cuts_nothing_is_an_error() {
    let mut s = scene("plate-hole-2d.json");
    for (segment, ok) in [
        (json!([[0.3, 0.35], [0.45, 0.35]]), true),
        (json!([[2.0, 0.2], [2.5, 0.2]]), false),
        (json!([[0.47, 0.25], [0.53, 0.25]]), false),
    ] {
        s["model"]["material"] = json!({"defects": [{"segment": segment, "factor": 0.0}]});
        match Problem::from_json(&s.to_string()) {
            Ok(_) => assert!(ok, "{segment} accepted"),
            Err(e) => {
                assert!(!ok, "{segment}: {e}");
                assert!(e.to_string().contains("model.material.defects[0]: crosses no bond"), "{e}");
            }
        }
    }
    Problem::from_path(&data("plate-crack-2d.json")).expect("the bundled crack cuts bonds");
}

/// `output.slice` picks the 3D map's plane (the cantilever's x-z mid-plane `y = 0.05`); a key
/// that is not an axis, a value outside the lattice, two keys and a 2D scene are refused.
#[test]
fn output_slice_picks_the_plane_of_a_3d_map() {
    let out = std::env::temp_dir().join(format!("linpd-slice-{}", std::process::id()));
    let mut s = scene("cantilever-3d.json");
    s["output"] = json!({"dir": out.to_string_lossy(), "slice": {"y": 0.05}});
    let path = out.with_extension("json");
    std::fs::write(&path, s.to_string()).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_linpd")).args(["solve", path.to_str().unwrap(), "-q"]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(out.join("u_magnitude.svg")).unwrap();
    assert!(svg.contains("cantilever-3d: |u| on y = 0.0500"), "the title names the plane");
    assert!(svg.contains(">\nz\n</text>") && !svg.contains(">\ny\n</text>"), "the vertical axis is z, not y");
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_file(&path);
    for (slice, needle) in [
        (json!({"w": 0.05}), "output.slice.w: not an axis"),
        (json!({"y": 5.0}), "output.slice.y: 5e0 is outside the lattice's extent [0e0, 1e-1]"),
        (json!({"y": 0.05, "z": 0.05}), "output.slice: give exactly one of x, y, z"),
    ] {
        let mut t = scene("cantilever-3d.json");
        t["output"]["slice"] = slice;
        assert!(error_of(&t).contains(needle), "{}", error_of(&t));
    }
    let mut t = scene("plate-hole-2d.json");
    t["output"]["slice"] = json!({"z": 0.0});
    assert!(error_of(&t).contains("output.slice: is for 3D scenes"), "{}", error_of(&t));
}

/// `"boundary_volumes": "cut"` on the plate with a hole: the hole the volumes leave, the
/// 101 x 51 vertex cells' area `101 x 51 h^2` less the body nodes' volumes, is the disk's area
/// `pi 0.1^2` within 1e-3 relative where full volumes `h^2` miss by 0.9 % (the 317 removed
/// lattice points; measured values in the message; the box's own edges are not cut: the
/// body region `all` extends beyond them), the force balance still holds (1e-10), and the same nodes as
/// a point cloud with these volumes give the same solution (1e-11, the bound of
/// tests/point_cloud.rs), so the bond weights use `V_i V_j`.
#[test]
fn cut_volumes_recover_the_area_and_weigh_the_bonds() {
    let mut s = scene("plate-hole-2d.json");
    s["solver"] = json!({"type": "cholesky"});
    let full = Problem::from_json(&s.to_string()).unwrap();
    s["boundary_volumes"] = json!("cut");
    let cut = Problem::from_json(&s.to_string()).unwrap();
    let disk = std::f64::consts::PI * 0.01;
    let hole = |p: &Problem| -> f64 {
        let body: f64 = (0..p.nodes().len()).filter(|&n| !p.nodes().is_layer(n)).map(|n| p.nodes().volume(n)).sum();
        101.0 * 51.0 * 1e-4 - body
    };
    let (e_full, e_cut) = ((hole(&full) - disk).abs() / disk, (hole(&cut) - disk).abs() / disk);
    eprintln!("hole area error: full volumes {e_full:e}, cut volumes {e_cut:e}");
    assert!(e_cut < 1e-3 && e_cut < e_full / 5.0, "full {e_full:e}, cut {e_cut:e}");
    let sol = cut.solve(&NoProgress).unwrap();
    assert!(sol.balance.as_ref().unwrap().relative_imbalance < 1e-10);
    assert_ne!(sol.u, full.solve(&NoProgress).unwrap().u);
    // the same nodes and volumes as a cloud
    let dir = std::env::temp_dir().join(format!("linpd-cut-cloud-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut csv = String::from("x,y,volume,layer\n");
    for n in 0..cut.nodes().len() {
        let x = cut.nodes().position(n);
        csv += &format!("{:?},{:?},{:?},{}\n", x[0], x[1], cut.nodes().volume(n), cut.nodes().is_layer(n) as u8);
    }
    std::fs::write(dir.join("cut.csv"), csv).unwrap();
    let mut c = s.clone();
    let o = c.as_object_mut().unwrap();
    for k in ["grid", "body", "boundary_volumes"] {
        o.remove(k);
    }
    c["nodes"] = json!({"csv": dir.join("cut.csv").to_str().unwrap()});
    // the lattice's whole volumes (a cloud's default is the ball fraction)
    c["model"]["partial_volume"] = json!(false);
    let on_cloud = Problem::from_json(&c.to_string()).unwrap().solve(&NoProgress).unwrap();
    let scale = sol.u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = sol.u.iter().zip(&on_cloud.u).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / scale;
    assert!(diff < 1e-11, "cloud vs cut grid: {diff:e}");
    s.as_object_mut().unwrap().remove("body");
    let e = error_of(&s);
    assert!(e.starts_with("boundary_volumes: \"cut\" needs a \"body\""), "{e}");
}

/// A traction on the face `x+` of the plate: a body-force density `t / h` on the body's last
/// column (51 nodes, layer nodes beyond the face excluded), so the applied force is
/// `t x 51 h` = `t x 0.51` (the 51 vertex cells of the face, the face's length 0.5 plus the
/// half cells at its ends) whatever the spacing up to that half-cell term: `t x 0.505` at
/// h/2 (eps-level sums). A face of another dimension, a cloud, and a key of another load type
/// are errors.
#[test]
fn traction_acts_on_the_outermost_slab() {
    for (h, nodes, length) in [(0.01, 51, 0.51), (0.005, 101, 0.505)] {
        let mut s = scene("plate-hole-2d.json");
        s["grid"]["spacing"] = json!(h);
        s["loads"] = json!([{"type": "traction", "face": "x+", "traction": [2.0, 0.5]}]);
        let p = Problem::from_json(&s.to_string()).unwrap();
        let f = p.load_vector();
        let (fx, fy): (f64, f64) = (f.iter().step_by(2).sum(), f.iter().skip(1).step_by(2).sum());
        assert!((fx - 2.0 * length).abs() < 1e-13 && (fy - 0.5 * length).abs() < 1e-13, "h = {h}: ({fx}, {fy})");
        let loaded: Vec<usize> = (0..p.nodes().len()).filter(|&n| f[2 * n] != 0.0).collect();
        assert_eq!(loaded.len(), nodes, "h = {h}");
        assert!(loaded.iter().all(|&n| (p.nodes().position(n)[0] - 1.0).abs() < 1e-12 && !p.nodes().is_layer(n)));
    }
    let mut s = scene("plate-hole-2d.json");
    s["loads"] = json!([{"type": "traction", "face": "z+", "traction": [1.0, 0.0]}]);
    assert!(error_of(&s).starts_with("loads[0].face: \"z+\" is not a face of a 2D box (one of x-, x+, y-, y+)"));
    s["loads"] = json!([{"type": "traction", "face": "x+", "traction": [1.0, 0.0], "force": [1.0, 0.0]}]);
    assert!(error_of(&s).starts_with("loads[0].force: not a key of a traction load"));
    s["loads"] = json!([{"type": "traction", "face": "x+"}]);
    assert!(error_of(&s).starts_with("loads[0].traction: missing"));
}

/// Cut-cell volumes in an LPS scene (the LPS plate with a hole of radius 0.1): the volumes
/// differ from `h^2` next to the hole, the solve balances (1e-10), the stored energy is
/// positive and the solution differs from the full-volume one. (The LPS model's consistency
/// with per-node volumes, FD Jacobian, symmetry and the energy identity, is tested in
/// crates/linpd-lps/tests/extensions.rs.)
#[test]
fn cut_volumes_in_an_lps_scene() {
    let mut s = scene("lps-plate-2d.json");
    s["body"] = json!({"difference": ["all", {"ball": {"center": [0.5, 0.25], "radius": 0.1}}]});
    s["solver"] = json!({"type": "cholesky"});
    let full = Problem::from_json(&s.to_string()).unwrap().solve(&NoProgress).unwrap();
    s["boundary_volumes"] = json!("cut");
    let p = Problem::from_json(&s.to_string()).unwrap();
    let h2 = 0.025f64 * 0.025;
    assert!((0..p.nodes().len()).any(|n| (p.nodes().volume(n) - h2).abs() > 1e-3 * h2));
    let sol = p.solve(&NoProgress).unwrap();
    assert!(sol.balance.as_ref().unwrap().relative_imbalance < 1e-10);
    let w: f64 = sol.strain_energy_density.as_ref().unwrap().iter().zip(&sol.volumes).map(|(w, v)| w * v).sum();
    assert!(w > 0.0);
    assert_ne!(sol.u, full.u, "the volumes change the solution");
}

/// Moments (issue #32): the cantilever's clamp (the root layer) reacts to the tip load with the
/// couple of statics, `M = -(x_F - c) x F` about its centroid `c` (`x_F` the load's point of
/// application, the mean of its nodes, the plane `x = 1`: a resultant puts equal forces on
/// equal volumes), to the solve's round-off (1e-10 of `|F| L`, `L = 1`); the moments balance
/// about the reference point in 3D (the cantilever), 2D (the plate with a hole) and for LPS;
/// the clamp's nodal reactions sum to its reaction (1e-12) and are `result.vtu`'s `reaction`.
#[test]
fn moments_balance_and_the_clamp_carries_the_couple_of_statics() {
    let p = Problem::from_path(&data("cantilever-3d.json")).unwrap();
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    let b = s.balance.as_ref().unwrap();
    assert_eq!(b.applied_moment.len(), 3);
    assert!(b.relative_moment_imbalance <= 1e-10, "{:e}", b.relative_moment_imbalance);
    let (load, clamp) = (&b.loads[0], &b.constraints[0]);
    let nodes = p.nodes();
    let loaded: Vec<usize> = (0..nodes.len()).filter(|&i| nodes.position(i)[0] >= 1.0 - 1e-9).collect();
    assert_eq!(loaded.len(), load.nodes, "the load's nodes");
    let mean = |set: &[usize], a: usize| set.iter().map(|&i| nodes.position(i)[a]).sum::<f64>() / set.len() as f64;
    let arm: Vec<f64> = (0..3).map(|a| mean(&loaded, a) - clamp.centroid[a]).collect();
    let f = &load.force;
    let statics =
        [-(arm[1] * f[2] - arm[2] * f[1]), -(arm[2] * f[0] - arm[0] * f[2]), -(arm[0] * f[1] - arm[1] * f[0])];
    let scale = f.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for a in 0..3 {
        assert!((clamp.moment[a] - statics[a]).abs() <= 1e-10 * scale, "{:?} vs {statics:?}", clamp.moment);
    }
    assert!(statics[1].abs() > 0.5 * scale, "a bending couple: {statics:?}");
    let total: Vec<f64> = (0..3).map(|a| b.nodal_reaction.iter().skip(a).step_by(3).sum()).collect();
    for a in 0..3 {
        assert!((total[a] - clamp.reaction[a]).abs() <= 1e-12 * scale, "{total:?} vs {:?}", clamp.reaction);
    }
    let dir = std::env::temp_dir().join(format!("linpd-moments-{}", std::process::id()));
    s.write(&dir).unwrap();
    let vtu = std::fs::read_to_string(dir.join("result.vtu")).unwrap();
    assert!(vtu.contains("Name=\"reaction\""), "result.vtu has no reaction field");
    let _ = std::fs::remove_dir_all(&dir);
    for name in ["plate-hole-2d.json", "lps-plate-2d.json"] {
        let s = Problem::from_path(&data(name)).unwrap().solve(&linpd::core::NoProgress).unwrap();
        let b = s.balance.unwrap();
        assert_eq!(b.applied_moment.len(), 1, "{name}: a 2D moment is its z component");
        assert!(b.relative_moment_imbalance <= 1e-10, "{name}: {:e}", b.relative_moment_imbalance);
    }
}
