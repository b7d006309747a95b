//! Issue #30: secondary entry points that skipped `linpd solve`'s checks, and messages that
//! blamed the wrong cause. Each case runs the `linpd` binary (or the library entry point the
//! Python package and the PETSc driver call) on a broken input and checks the error names the
//! real cause (JSON path, file line), the exit is non-zero and nothing is written.

use linpd::problem::{Commands, Pipeline, Problem};
use linpd::solve::{solve_assembled, MatrixHints, SolveReport, SolverId, SolverSpec};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-robust-entry-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `linpd <cmd> scene.json` (solve: `-q`) in `dir`.
fn run(cmd: &str, dir: &Path, scene: &str) -> Output {
    let mut args = vec![cmd, scene];
    if cmd == "solve" {
        args.push("-q");
    }
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).current_dir(dir).output().expect("the linpd binary runs")
}

/// Writes `text` as `dir/scene.json`, runs `linpd cmd` on it and checks the refusal: non-zero
/// exit, no panic, every needle in stderr, none of `absent`, and no output directory `out`.
fn refused(cmd: &str, tag: &str, text: &[u8], needles: &[&str], absent: &[&str]) -> String {
    let dir = temp_dir(tag);
    std::fs::write(dir.join("scene.json"), text).unwrap();
    let out = run(cmd, &dir, "scene.json");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "{tag}: accepted\n{stderr}");
    assert_eq!(out.status.code(), Some(1), "{tag}: exit {:?} (a panic?)\n{stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{tag}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{tag}: `{n}` not in: {stderr}");
    }
    for n in absent {
        assert!(!stderr.contains(n), "{tag}: `{n}` in: {stderr}");
    }
    assert!(!dir.join("out").exists(), "{tag}: wrote an output directory");
    stderr
}

/// A plate one node thick in 3D (z = 0 only, all bonds in-plane): the out-of-plane motion of
/// every free node is a mechanism (zero stiffness), though the clamp holds every rigid motion.
fn flat_plate(force: [f64; 3], solver: Value) -> Value {
    json!({
        "name": "flat-plate",
        "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 0.5, 0.1], "spacing": 0.1, "layer": {"x-": 0.3}},
        "body": {"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.01]}},
        "model": {"type": "bond", "horizon": 0.3,
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [0.0, 1.0, 1.0]}},
                         "displacement": {"value": [0.0, 0.0, 0.0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [1.0, -1.0, -1.0], "max": [2.0, 1.0, 1.0]}},
                   "force": force}],
        "solver": solver,
        "output": {"dir": "out"}
    })
}

/// Item 1: the row system of the PETSc driver (`Scene.row_info`, `assemble_rows`) refuses the
/// flat plate at setup, naming the node and component, with an in-plane load too (on which a
/// KSP converges and the driver used to exit 0) and with the out-of-plane load (reason -4).
#[test]
fn item_1_row_system_refuses_a_mechanism() {
    for force in [[1e-4, 0.0, 0.0], [0.0, 0.0, -1e-4]] {
        let p = Problem::from_json(&flat_plate(force, json!({"type": "auto"})).to_string()).unwrap();
        let e = p.row_system().err().expect("the row system of a mechanism is refused").to_string();
        for n in ["the row system", "diagonal entry at free DOF", "is 0e0", "singular", "node ", "component 2"] {
            assert!(e.contains(n), "`{n}` not in: {e}");
        }
        // linpd solve refuses it too (Cholesky names a node of the same mechanism)
        let s = p.solve(&linpd::core::NoProgress).expect_err("linpd solve refuses it").to_string();
        assert!(s.contains("component 2") && s.contains("not held there"), "{s}");
    }
    // a supported plate still builds its rows
    let mut ok = flat_plate([1e-4, 0.0, 0.0], json!({"type": "auto"}));
    ok["body"] = json!("all");
    let p = Problem::from_json(&ok.to_string()).unwrap();
    assert!(p.row_system().is_ok());
}

/// Item 2: displacements solved elsewhere must be finite: `solution_from` (what
/// `Scene.write_result` calls before anything is created) refuses a NaN by its index.
#[test]
fn item_2_solution_from_refuses_non_finite_displacements() {
    let p = Problem::from_path(&Path::new(ROOT).join("data/bar-point-load.json")).unwrap();
    let rows = p.row_system().unwrap();
    let report = || SolveReport::new(SolverId::Lu, rows.n(), 0);
    let good = rows.expand(&vec![0.0; rows.n()]).unwrap();
    assert!(p.solution_from(&rows, good.clone(), report()).is_ok());
    for bad in [f64::NAN, f64::INFINITY] {
        let mut u = good.clone();
        u[7] = bad;
        let e = p.solution_from(&rows, u, report()).expect_err("non-finite u refused").to_string();
        assert!(e.starts_with("u: ") && e.contains("not finite") && e.contains("u[7]"), "{e}");
    }
}

/// Item 5: LU on a singular matrix names the singularity (and the node when a diagonal entry
/// is zero), not an overflow.
#[test]
fn item_5_lu_reports_singularity() {
    let text = flat_plate([0.0, 0.0, -1e-4], json!({"type": "lu"})).to_string();
    refused(
        "solve",
        "lu",
        text.as_bytes(),
        &["lu: the stiffness's diagonal entry at free DOF", "singular", "component 2", "not held there"],
        &["overflow", "smaller units"],
    );
    // no zero diagonal: [[1, 1], [1, 1]] (singular, every pivot candidate nonzero)
    let a = linpd::core::sparse::Csc::try_new_from_triplets(
        2,
        2,
        &[(0, 0, 1.0), (0, 1, 1.0), (1, 0, 1.0), (1, 1, 1.0)].map(|(i, j, v)| faer::sparse::Triplet::new(i, j, v)),
    )
    .unwrap();
    let mut hints = MatrixHints::symmetric(1);
    hints.asymmetry = 1.0; // as an unsymmetric matrix: LU
    let e = solve_assembled(&a, &[1.0, 2.0], &SolverSpec::Lu, &hints).expect_err("singular").to_string();
    assert!(e.contains("singular matrix (a pivot is zero)") && !e.contains("overflow"), "{e}");
}

/// Item 6: GMRES with Jacobi on a zero diagonal names GMRES, not CG.
#[test]
fn item_6_gmres_failure_names_gmres() {
    let text = flat_plate([0.0, 0.0, -1e-4], json!({"type": "gmres"})).to_string();
    refused("solve", "gmres", text.as_bytes(), &["gmres (jacobi)", "singular", "component 2"], &["CG"]);
}

/// Item 7: an initial velocity whose kinetic energy overflows is named, not "the run diverged".
#[test]
fn item_7_initial_velocity_overflow_is_named() {
    let mut s: Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(ROOT).join("data/wave-square-pulse-1d.json")).unwrap())
            .unwrap();
    s["output"]["dir"] = json!("out");
    let n = Problem::from_json(&s.to_string()).unwrap().nodes().len();
    let mut v = vec![0.0; n];
    v[n / 2] = 1e308;
    s["dynamics"]["initial"] = json!({"type": "data", "u": vec![0.0; n], "v": v});
    let text = s.to_string();
    let e = refused("run", "initial-v", text.as_bytes(), &["dynamics.initial.v", "1e308", "overflow"], &["diverged"]);
    assert!(e.contains("kinetic"), "{e}");
}

/// A square pulse of amplitude 1e308 (finite, but its forces `K u` overflow) is named at
/// `dynamics.initial`, not "the run diverged"; 1e150 runs.
#[test]
fn item_7_initial_amplitude_overflow_is_named() {
    let mut s: Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(ROOT).join("data/wave-square-pulse-1d.json")).unwrap())
            .unwrap();
    s["output"]["dir"] = json!("out");
    s["dynamics"]["initial"]["amplitude"] = json!(1e308);
    let text = s.to_string();
    let e = refused("run", "amplitude", text.as_bytes(), &["dynamics.initial", "overflow", "amplitude"], &["diverged"]);
    assert!(e.contains("smaller units"), "{e}");
    s["dynamics"]["initial"]["amplitude"] = json!(1e150);
    let dir = temp_dir("amplitude-ok");
    std::fs::write(dir.join("scene.json"), s.to_string()).unwrap();
    let out = run("run", &dir, "scene.json");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

const GOOD_VTK: &str = "# vtk DataFile Version 4.2\ncloud\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n\
0 0 0\n1 0 0\n0 1 0\n1 1 0\nCELLS 0 0\nCELL_TYPES 0\nPOINT_DATA 4\nSCALARS volume double 1\nLOOKUP_TABLE default\n1 1 1 1\n";

fn cloud_scene(file: &str) -> String {
    json!({"name": "cloud", "dimension": 2, "nodes": {"vtk": file},
           "model": {"type": "bond", "horizon": 1.5, "plane": "stress",
                     "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"}},
           "constraints": [{"region": "all", "displacement": {"value": [0.0, 0.0]}}],
           "output": {"dir": "out"}})
    .to_string()
}

/// Item 8: a legacy VTK file whose POINTS count does not match its data names the count and
/// the line (vtkio said "Parse error: Digit").
#[test]
fn item_8_vtk_points_count_mismatch() {
    let dir = temp_dir("vtk-good");
    std::fs::write(dir.join("c.vtk"), GOOD_VTK).unwrap();
    std::fs::write(dir.join("scene.json"), cloud_scene("c.vtk")).unwrap();
    let out = run("validate", &dir, "scene.json");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for (n, tag) in [(5, "more"), (3, "fewer")] {
        let dir = temp_dir(&format!("vtk-{tag}"));
        std::fs::write(dir.join("c.vtk"), GOOD_VTK.replace("POINTS 4", &format!("POINTS {n}"))).unwrap();
        std::fs::write(dir.join("scene.json"), cloud_scene("c.vtk")).unwrap();
        let out = run("validate", &dir, "scene.json");
        let e = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{e}");
        for needle in ["nodes.vtk", "c.vtk line 5", "POINTS count does not match", "12 numbers follow", "line 10"] {
            assert!(e.contains(needle), "`{needle}` not in: {e}");
        }
        assert!(!e.contains("Digit") && !e.contains("Tag"), "{e}");
    }
}

/// Item 9: a UTF-8 byte order mark before a scene or a pipeline is skipped.
#[test]
fn item_9_utf8_bom_is_skipped() {
    let dir = temp_dir("bom");
    let mut text = b"\xEF\xBB\xBF".to_vec();
    text.extend(std::fs::read(Path::new(ROOT).join("data/plate-tension-2d.json")).unwrap());
    std::fs::write(dir.join("scene.json"), &text).unwrap();
    let out = run("validate", &dir, "scene.json");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // a pipeline with a BOM (its scene path made absolute)
    let pipe = Path::new(ROOT).join("data/coarsen-plate-2d.pipeline.json");
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&pipe).unwrap()).unwrap();
    doc["scene"] = json!(Path::new(ROOT).join("data").join(doc["scene"].as_str().unwrap()));
    let mut text = b"\xEF\xBB\xBF".to_vec();
    text.extend(doc.to_string().bytes());
    let path = dir.join("pipe.json");
    std::fs::write(&path, &text).unwrap();
    Pipeline::from_path(&path).unwrap();
}

fn plate_2d() -> Value {
    serde_json::from_str(&std::fs::read_to_string(Path::new(ROOT).join("data/plate-tension-2d.json")).unwrap()).unwrap()
}

/// Item 10: `difference` of three (or one) regions says it takes exactly two, at its path.
#[test]
fn item_10_difference_takes_two_regions() {
    let ball = |x: f64| json!({"ball": {"center": [x, 0.0], "radius": 0.1}});
    for (regions, tag) in [(json!(["all", ball(0.0), ball(1.0)]), "3"), (json!(["all"]), "1")] {
        let mut s = plate_2d();
        s["constraints"][0]["region"] = json!({ "difference": regions });
        refused(
            "validate",
            &format!("difference-{tag}"),
            s.to_string().as_bytes(),
            &["constraints[0].region.difference", "takes exactly two regions", &format!("got {tag}")],
            &["trailing characters", "invalid length"],
        );
    }
}

/// Item 11: a side given twice in `grid.layer` is refused (the later value was taken).
#[test]
fn item_11_grid_layer_duplicate_side() {
    let text = plate_2d().to_string().replace("\"layer\":0.06", "\"layer\":{\"x-\":0.06,\"x-\":0.1}");
    assert!(text.contains("\"x-\":0.06,\"x-\""), "the replacement happened");
    refused("validate", "layer-dup", text.as_bytes(), &["grid.layer", "`x-` is given twice"], &[]);
}

/// Item 12: `linpd validate` on a point cloud prints the horizon over the cloud's mean spacing
/// (every model, LPS included), never NaN.
#[test]
fn item_12_validate_prints_ratio_to_mean_spacing() {
    for scene in ["data/bracket-cloud-2d.json", "data/bracket-cloud-lps-2d.json"] {
        let out = run("validate", Path::new(ROOT), scene);
        let s = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{scene}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(s.contains("horizon/mean spacing = 4.2426") && !s.contains("NaN"), "{scene}: {s}");
    }
}

/// Item 13: error paths are the scene's keys: `body` (not `body.body`), `model.pd_regions`
/// (not `model.blend.pd_regions`, nor behind `model: `).
#[test]
fn item_13_error_paths_exist_in_the_scene() {
    let mut s = plate_2d();
    s["body"] = json!({"ball": {"center": [5.0, 5.0], "radius": 0.1}});
    s["output"] = json!({"dir": "out"});
    refused("validate", "body", s.to_string().as_bytes(), &["error: scene.json: body: keeps none"], &["body.body"]);
    let mut s: Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(ROOT).join("data/plate-crack-blend-2d.json")).unwrap())
            .unwrap();
    s["output"] = json!({"dir": "out"});
    s["model"]["pd_regions"].as_array_mut().unwrap().remove(0);
    refused("solve", "pd-regions", s.to_string().as_bytes(), &["scene.json: model.pd_regions: node"], &["blend"]);
}

/// Item 4: re-solving into a read-only output directory is refused before the run, naming the
/// directory, and leaves no `<dir>.old-*` copy (the removal of the set-aside copy failing after
/// the swap is an error too: the unit test `a_failed_removal_of_the_old_directory_is_an_error`
/// of `linpd_problem::atomic` injects it, as root cannot be denied here).
#[cfg(unix)]
#[test]
fn item_4_read_only_output_directory() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("read-only");
    let mut s: Value =
        serde_json::from_str(&std::fs::read_to_string(Path::new(ROOT).join("data/bar-point-load.json")).unwrap())
            .unwrap();
    s["output"] = json!({"dir": "out", "plot": false});
    std::fs::write(dir.join("scene.json"), s.to_string()).unwrap();
    let out = run("solve", &dir, "scene.json");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let before = std::fs::read(dir.join("out/result.json")).unwrap();
    std::fs::set_permissions(dir.join("out"), std::fs::Permissions::from_mode(0o555)).unwrap();
    let out = run("solve", &dir, "scene.json");
    std::fs::set_permissions(dir.join("out"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("out") && e.contains("is read-only (mode 555)"), "{e}");
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["out", "scene.json"], "a copy or a lock left behind");
    assert_eq!(std::fs::read(dir.join("out/result.json")).unwrap(), before, "the old results changed");
}
