//! The `linpd` binary end to end: every bundled scene solves and writes its outputs, `validate`
//! says "valid", a malformed scene fails cleanly with the JSON path on stderr, `--help` works.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn linpd(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().expect("the linpd binary runs")
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// A fresh directory under the system temp dir, unique to this process and `tag`.
fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-cli-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data_dir())
        .expect("data/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        // coarsening pipelines (`linpd coarsen`) are tested in tests/coarsen_pipeline.rs
        .filter(|p| !p.to_string_lossy().ends_with(".pipeline.json"))
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no scenes in data/");
    v
}

/// Checks the outputs of one solved scene whose 2D map has `map_cells` cells (the lattice's
/// sites for a scene on a grid), and the moment balance of 2D and 3D scenes; `Err` says what is
/// wrong.
fn check_outputs(dir: &Path, map_cells: usize) -> Result<(), String> {
    let text = std::fs::read_to_string(dir.join("result.json")).map_err(|e| format!("result.json: {e}"))?;
    let r: Value = serde_json::from_str(&text).map_err(|e| format!("result.json does not parse: {e}"))?;
    let d = r["dimension"].as_u64().ok_or("result.json: no \"dimension\"")? as usize;
    let x = r["x"].as_array().ok_or("result.json: \"x\" is not an array")?;
    let u = r["u"].as_array().ok_or("result.json: \"u\" is not an array")?;
    if x.is_empty() || x.len() != u.len() {
        return Err(format!("result.json: {} positions and {} displacements", x.len(), u.len()));
    }
    if r["stats"]["nodes"].as_u64() != Some(x.len() as u64) {
        return Err(format!("stats.nodes = {} but {} positions", r["stats"]["nodes"], x.len()));
    }
    for (name, values) in [("x", x), ("u", u)] {
        for (k, v) in values.iter().enumerate() {
            let ok = if d == 1 {
                v.as_f64().is_some_and(f64::is_finite)
            } else {
                v.as_array().is_some_and(|a| a.len() == d && a.iter().all(|c| c.as_f64().is_some_and(f64::is_finite)))
            };
            if !ok {
                return Err(format!(
                    "{name}[{k}] = {v} is not {}",
                    if d == 1 { "a number" } else { "an array of numbers" }
                ));
            }
        }
    }
    // moments balance to round-off (central bond forces, rotations in A's null space), or for a
    // blend's ghost forces no worse than its forces do (measured: 8.3e-13 and 4.0e-10 against
    // force imbalances of 1.5e-6 and 3.8e-7)
    if d > 1 {
        let b = &r["balance"];
        let (m, f) = (b["relative_moment_imbalance"].as_f64(), b["relative_imbalance"].as_f64());
        let (m, f) = m.zip(f).ok_or("balance.relative_moment_imbalance or relative_imbalance missing")?;
        if !(m <= 1e-10 || (f > 1e-8 && m <= f)) {
            return Err(format!("balance.relative_moment_imbalance = {m:e} (forces {f:e})"));
        }
    }
    let res = r["stats"]["solve"]["rel_residual"].as_f64().ok_or("stats.solve.rel_residual is not a number")?;
    if !(res < 1e-8) {
        return Err(format!("stats.solve.rel_residual = {res:e} >= 1e-8"));
    }
    let csv = std::fs::read_to_string(dir.join("u.csv")).map_err(|e| format!("u.csv: {e}"))?;
    let header = ["x,u,layer", "x,y,u,v,layer", "x,y,z,u,v,w,layer"][d - 1];
    if csv.lines().next() != Some(header) {
        return Err(format!("u.csv header {:?}, expected {header:?}", csv.lines().next()));
    }
    if csv.lines().count() != x.len() + 1 {
        return Err(format!("u.csv has {} lines for {} nodes", csv.lines().count(), x.len()));
    }
    let stem = if d == 1 { "u" } else { "u_magnitude" };
    // a 2D map of more cells than the SVG limit is written as PNG only (linpd_plot's docs)
    // (a lattice scene's map has a cell per lattice site, whatever nodes the output holds)
    let exts: &[&str] = if d == 2 && map_cells > linpd::plot::MAX_SVG_CELLS { &["png"] } else { &["png", "svg"] };
    let mut plots = vec![stem];
    if d > 1 {
        // every bundled scene is loaded, so it has a deformed shape; a stress map with stresses
        plots.push("deformed");
        if r.get("stress").is_some() {
            plots.push("stress_von_mises");
        }
    }
    for stem in plots {
        let f = dir.join(format!("{stem}.png"));
        match std::fs::metadata(&f) {
            Ok(m) if m.len() > 0 => {}
            _ => return Err(format!("{} missing or empty", f.display())),
        }
    }
    for ext in exts {
        let f = dir.join(format!("{stem}.{ext}"));
        match std::fs::metadata(&f) {
            Ok(m) if m.len() > 0 => {}
            _ => return Err(format!("{} missing or empty", f.display())),
        }
    }
    Ok(())
}

#[test]
fn solve_every_bundled_scene() {
    let root = temp_dir("solve");
    let mut failures = Vec::new();
    for scene in scenes() {
        let name = scene.file_stem().unwrap().to_string_lossy().to_string();
        let out = root.join(&name);
        let o = linpd(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str()]);
        if !o.status.success() {
            failures.push(format!(
                "{name}: exit {:?}, stderr: {}",
                o.status.code(),
                String::from_utf8_lossy(&o.stderr)
            ));
            continue;
        }
        let problem =
            linpd::problem::Problem::from_json_in(&std::fs::read_to_string(&scene).unwrap(), scene.parent().unwrap())
                .unwrap();
        let map_cells = problem.grid().map_or(problem.nodes().len(), |g| g.n_sites());
        if let Err(why) = check_outputs(&out, map_cells) {
            failures.push(format!("{name}: {why}"));
        }
    }
    assert!(failures.is_empty(), "{} scene(s) failed:\n  {}", failures.len(), failures.join("\n  "));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn validate_prints_valid() {
    let scene = data_dir().join("bar-point-load.json");
    let o = linpd(&["validate".as_ref(), scene.as_os_str()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "exit {:?}, stderr: {}", o.status.code(), String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("bar-point-load: valid"), "stdout: {stdout}");
}

#[test]
fn malformed_scene_fails_with_the_path_and_writes_nothing() {
    let dir = temp_dir("malformed");
    let text = std::fs::read_to_string(data_dir().join("bar-point-load.json")).unwrap();
    let bad = text.replace("\"horizon\": 0.05", "\"horizon\": -1.0");
    assert_ne!(bad, text, "test bug: the horizon was not replaced");
    let scene = dir.join("bad.json");
    std::fs::write(&scene, bad).unwrap();
    let out = dir.join("out");
    for cmd in ["solve", "validate"] {
        let mut args: Vec<&std::ffi::OsStr> = vec![cmd.as_ref(), scene.as_os_str()];
        if cmd == "solve" {
            args.extend([std::ffi::OsStr::new("--out"), out.as_os_str()]);
        }
        let o = linpd(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{cmd}: a malformed scene exited 0");
        assert!(stderr.contains("error:"), "{cmd} stderr: {stderr}");
        assert!(stderr.contains("model.horizon: must be > 0, got -1e0"), "{cmd} stderr: {stderr}");
        assert!(stderr.contains("bad.json"), "{cmd}: stderr does not name the file: {stderr}");
    }
    assert!(!out.join("result.json").exists(), "result.json written for a malformed scene");

    // A syntax error names the line and column.
    std::fs::write(&scene, "{\"name\": \"x\",\n \"dimension\": 1\n \"grid\": {}}").unwrap();
    let o = linpd(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("error:") && stderr.contains("(line 3, column 2)"), "stderr: {stderr}");
    assert!(!out.join("result.json").exists(), "result.json written for a malformed scene");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn help_mentions_solve() {
    let o = linpd(&["--help".as_ref()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "exit {:?}", o.status.code());
    assert!(stdout.contains("solve"), "stdout: {stdout}");
}

/// `data/blend-bar-crack.json` (issue #17 item 1): a blended bar with a pre-crack at 0.501 and
/// a soft phase in its PD zone, a stiff phase in its left CE zone, and a point load on each
/// side of the crack. From the CLI: each half's support carries its own load (reactions -1 and
/// +1, balance to 1e-10: the loads are 6 horizons from the transitions, where the blended
/// rows make no approximation), the stiff CE phase (K = 2) halves the slope on [0, 0.05]
/// (u(0.05) = 0.025, exact CE), and the crack opens (> 0.7, the CE estimate 0.725). With the
/// crack moved into a bridge the scene is refused, naming the defect, and nothing is written.
#[test]
fn blend_bar_crack_solves_and_a_misplaced_crack_is_refused() {
    let dir = temp_dir("blend-crack");
    let scene = data_dir().join("blend-bar-crack.json");
    let out = dir.join("out");
    let o = linpd(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str(), "-q".as_ref()]);
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let r: Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let b = &r["balance"];
    assert!(b["relative_imbalance"].as_f64().unwrap() < 1e-10, "{b}");
    let reaction = |k: usize| b["constraints"][k]["reaction"][0].as_f64().unwrap();
    assert!((reaction(0) + 1.0).abs() < 1e-10 && (reaction(1) - 1.0).abs() < 1e-10, "{b}");
    let x: Vec<f64> = r["x"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let u: Vec<f64> = r["u"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let at = |p: f64| u[x.iter().position(|&v| (v - p).abs() < 1e-9).unwrap()];
    assert!((at(0.05) - 0.025).abs() < 1e-10, "u(0.05) = {}", at(0.05));
    let opening = at(0.5) - at(0.502);
    assert!(opening > 0.7, "crack opening {opening}");

    let text = std::fs::read_to_string(&scene).unwrap();
    let bad = text.replace("\"point\": 0.501", "\"point\": 0.15");
    assert_ne!(bad, text, "test bug: the defect was not moved");
    let bad_scene = dir.join("bad.json");
    std::fs::write(&bad_scene, bad).unwrap();
    let bad_out = dir.join("bad-out");
    let o = linpd(&["solve".as_ref(), bad_scene.as_os_str(), "--out".as_ref(), bad_out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("model.material.defects[0]: x = 0.15 is not in the pure PD zone"), "stderr: {stderr}");
    assert!(!bad_out.exists(), "output written for a refused scene");
    let _ = std::fs::remove_dir_all(&dir);
}
