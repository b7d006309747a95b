//! Output directories (issue #15, items 1 and 6), through the `linpd` binary: a run writes all
//! its files or none, never mixes with another run, never leaves an earlier run's files beside
//! its own, survives SIGKILL at any instant with the old or the new complete results, carries
//! its identity; output paths stay where the user named them; trailing text after a JSON
//! document is an error; a closed stdout is not a panic.

use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_linpd"))
}

fn linpd(args: &[&str], cwd: &Path) -> Output {
    bin().args(args).current_dir(cwd).output().expect("the linpd binary runs")
}

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name).display().to_string()
}

/// A fresh directory under the system temp dir, unique to this process and `tag`.
fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-outputs-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A 1D bar of `nodes` nodes under a body load `load`, clamped at both ends: quick to solve
/// (banded), slow to write (u.csv, result.json and the plots grow with `nodes`).
fn bar_scene(name: &str, nodes: usize, load: f64) -> Value {
    let h = 1.0 / nodes as f64;
    json!({
        "name": name, "dimension": 1,
        "grid": {"min": [0.0], "max": [1.0], "spacing": h, "layer": 3.0 * h},
        "model": {"type": "bond", "horizon": 3.0 * h, "partial_volume": false,
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                        {"region": {"box": {"min": [1.0], "max": [2.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "body", "region": {"box": {"min": [-1.0], "max": [2.0]}}, "density": [load]}]
    })
}

fn write_json(path: &Path, v: &Value) -> String {
    std::fs::write(path, serde_json::to_string_pretty(v).unwrap()).unwrap();
    path.display().to_string()
}

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// Checks that `dir` holds exactly one complete run: a main document whose `run.files` lists
/// every other file with its size, and (for `solve`) a u.csv of the nodes in result.json with
/// the same displacements. Returns the main document.
fn complete_run(dir: &Path) -> Result<Value, String> {
    let main = ["result.json", "history.json", "summary.json", "data.json"]
        .into_iter()
        .find(|m| dir.join(m).exists())
        .ok_or_else(|| format!("{}: no main document in {:?}", dir.display(), names(dir)))?;
    let text = std::fs::read_to_string(dir.join(main)).map_err(|e| format!("{main}: {e}"))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| format!("{main} does not parse: {e}"))?;
    let listed = doc["run"]["files"].as_array().ok_or(format!("{main}: no run.files"))?;
    let mut expected: Vec<String> = listed.iter().map(|f| f["name"].as_str().unwrap_or("?").to_string()).collect();
    expected.push(main.to_string());
    expected.sort();
    if expected != names(dir) {
        return Err(format!("{main} lists {expected:?}, the directory holds {:?}", names(dir)));
    }
    for f in listed {
        let name = f["name"].as_str().unwrap_or("?");
        let size = std::fs::metadata(dir.join(name)).map_err(|e| format!("{name}: {e}"))?.len();
        if Some(size) != f["bytes"].as_u64() {
            return Err(format!("{name}: {size} bytes, {main} says {}", f["bytes"]));
        }
    }
    if main == "result.json" {
        let csv = std::fs::read_to_string(dir.join("u.csv")).map_err(|e| format!("u.csv: {e}"))?;
        let u = doc["u"].as_array().ok_or("result.json: no u")?;
        let rows: Vec<&str> = csv.lines().skip(1).collect();
        if rows.len() != u.len() {
            return Err(format!("u.csv has {} rows, result.json {} nodes", rows.len(), u.len()));
        }
        for k in [0, u.len() / 3, u.len() / 2, u.len() - 1] {
            let in_csv: f64 = rows[k].split(',').nth(1).and_then(|t| t.parse().ok()).ok_or("u.csv: bad row")?;
            // serde_json's default float parsing may be 1 ulp off
            if u[k].as_f64().is_none_or(|v| (v - in_csv).abs() > 1e-14 * v.abs()) {
                return Err(format!("node {k}: u.csv says {in_csv}, result.json {}", u[k]));
            }
        }
    }
    Ok(doc)
}

/// What is left beside `dir` in its parent apart from `dir` and `keep`: staging or old
/// directories, lock files.
fn leftovers(dir: &Path, keep: &[&str]) -> Vec<String> {
    let own = dir.file_name().unwrap().to_string_lossy().into_owned();
    names(dir.parent().unwrap()).into_iter().filter(|n| *n != own && !keep.contains(&n.as_str())).collect()
}

fn spawn_solve(scene: &str, out: &Path) -> Child {
    bin()
        .args(["solve", scene, "--out", out.to_str().unwrap(), "-q"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("linpd starts")
}

#[test]
fn item_1_outputs_atomic_on_failure() {
    let root = temp_dir("failure");
    let out = root.join("out");
    let o = linpd(&["solve", &data("bar-point-load.json"), "--out", "out", "-q"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    let old = std::fs::read(out.join("result.json")).unwrap();

    // A solve that fails after the output directory was taken: no constraint holds the bar.
    let mut free = bar_scene("free", 100, 1.0);
    free["constraints"] = json!([]);
    let scene = write_json(&root.join("free.json"), &free);
    let o = linpd(&["solve", &scene, "--out", "out", "-q"], &root);
    assert!(!o.status.success(), "a bar without constraints solved");
    assert!(stderr(&o).contains("constraints"), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("result.json")).unwrap(), old, "the old result changed");
    complete_run(&out).unwrap();
    assert!(leftovers(&out, &["free.json"]).is_empty(), "left: {:?}", leftovers(&out, &["free.json"]));
    // ... into a new directory: not even its parents are created.
    let o = linpd(&["solve", &scene, "--out", "new/deeper/out", "-q"], &root);
    assert!(!o.status.success());
    assert!(!root.join("new").exists(), "a failed run created directories");

    // A file appears in the output directory while the run writes: the run must not delete
    // it, so it fails as a whole and leaves the directory as it was.
    let big = write_json(&root.join("big.json"), &bar_scene("big", 150_000, 1.0));
    let child = spawn_solve(&big, &out);
    std::thread::sleep(Duration::from_millis(150));
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(!o.status.success(), "the run replaced a directory holding a file it did not write");
    assert!(stderr(&o).contains("notes.txt"), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("result.json")).unwrap(), old, "the old result changed");
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    let keep = ["free.json", "big.json"];
    assert!(leftovers(&out, &keep).is_empty(), "left: {:?}", leftovers(&out, &keep));

    // A directory linpd did not write is never replaced.
    let mine = root.join("thesis");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("chapter1.tex"), "x").unwrap();
    let o = linpd(&["solve", &data("bar-point-load.json"), "--out", "thesis", "-q"], &root);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("not a linpd output directory"), "{}", stderr(&o));
    assert_eq!(names(&mine), ["chapter1.tex"]);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn item_1_concurrent_runs_do_not_interleave() {
    let root = temp_dir("concurrent");
    let out = root.join("out");
    let a = write_json(&root.join("a.json"), &bar_scene("a", 100_000, 1.0));
    let b = write_json(&root.join("b.json"), &bar_scene("b", 100_000, -2.0));
    for delay_ms in [0, 100] {
        let first = spawn_solve(&a, &out);
        std::thread::sleep(Duration::from_millis(delay_ms));
        let second = spawn_solve(&b, &out);
        let mut winners = Vec::new();
        for (name, child) in [("a", first), ("b", second)] {
            let o = child.wait_with_output().unwrap();
            if o.status.success() {
                winners.push(name);
            } else {
                assert!(stderr(&o).contains("another linpd run"), "{name}: {}", stderr(&o));
            }
        }
        assert!(!winners.is_empty(), "both runs failed");
        let doc = complete_run(&out).unwrap_or_else(|e| panic!("delay {delay_ms} ms: {e}"));
        let name = doc["name"].as_str().unwrap();
        assert!(winners.contains(&name), "the directory holds run {name}, the winners were {winners:?}");
        assert!(leftovers(&out, &["a.json", "b.json"]).is_empty(), "{:?}", leftovers(&out, &["a.json", "b.json"]));
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn item_1_killed_run_leaves_old_results() {
    let root = temp_dir("killed");
    let out = root.join("out");
    let o = linpd(&["solve", &data("bar-point-load.json"), "--out", "out", "-q"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    let big = write_json(&root.join("big.json"), &bar_scene("big", 150_000, 1.0));
    // How long a whole run takes here, to spread the kills over it.
    let t = Instant::now();
    let o = spawn_solve(&big, &root.join("timing")).wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let whole = t.elapsed();
    for fraction in [0.25, 0.5, 0.7, 0.85, 0.95] {
        let mut child = spawn_solve(&big, &out);
        std::thread::sleep(whole.mul_f64(fraction));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        if out.exists() {
            let doc = complete_run(&out).unwrap_or_else(|e| panic!("killed at {fraction} of {whole:?}: {e}"));
            println!("killed at {fraction} of {whole:?}: {} complete", doc["name"]);
        } else {
            println!("killed at {fraction} of {whole:?}: out/ missing (between the two renames)");
        }
    }
    // The next run takes over the dead run's lock and cleans up after it.
    let o = spawn_solve(&data("bar-point-load.json"), &out).wait_with_output().unwrap();
    assert!(o.status.success(), "after the kills: {}", stderr(&o));
    assert_eq!(complete_run(&out).unwrap()["name"], "bar-point-load");
    let keep = ["big.json", "timing"];
    assert!(leftovers(&out, &keep).is_empty(), "left: {:?}", leftovers(&out, &keep));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn item_1_stale_files_removed() {
    let root = temp_dir("stale");
    // solve: plots, then none.
    let mut scene: Value =
        serde_json::from_str(&std::fs::read_to_string(data("bar-point-load.json")).unwrap()).unwrap();
    let with_plots = write_json(&root.join("plots.json"), &scene);
    scene["output"] = json!({"plot": false, "dir": "out"});
    let without = write_json(&root.join("no-plots.json"), &scene);
    for s in [&with_plots, &without] {
        let o = linpd(&["solve", s, "--out", "out", "-q"], &root);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    complete_run(&root.join("out")).unwrap();
    assert_eq!(names(&root.join("out")), ["result.json", "result.vtu", "u.csv"]);

    // run: 11 snapshots, then 3.
    let mut wave: Value =
        serde_json::from_str(&std::fs::read_to_string(data("wave-square-pulse-1d.json")).unwrap()).unwrap();
    wave["dynamics"]["steps"] = json!(20);
    wave["dynamics"]["output_every"] = json!(2);
    let many = write_json(&root.join("many.json"), &wave);
    wave["dynamics"]["output_every"] = json!(10);
    let few = write_json(&root.join("few.json"), &wave);
    for s in [&many, &few] {
        let o = linpd(&["run", s, "--out", "wave", "-q"], &root);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    complete_run(&root.join("wave")).unwrap();
    let csv: Vec<String> = names(&root.join("wave")).into_iter().filter(|n| n.ends_with(".csv")).collect();
    assert_eq!(csv, ["u_00.csv", "u_10.csv", "u_20.csv"]);

    // coarsen: two levels, then one.
    let pipeline: Value =
        serde_json::from_str(&std::fs::read_to_string(data("coarsen-composite-bar.pipeline.json")).unwrap()).unwrap();
    let mut p = pipeline.clone();
    p["scene"] = json!(data("coarsen-composite-bar.json"));
    assert!(p["levels"].as_array().unwrap().len() >= 2, "test bug: the bundled pipeline has one level");
    let two = write_json(&root.join("two.pipeline.json"), &p);
    p["levels"] = json!([p["levels"][0]]);
    let one = write_json(&root.join("one.pipeline.json"), &p);
    for s in [&two, &one] {
        let o = linpd(&["coarsen", s, "--out", "levels", "-q"], &root);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    complete_run(&root.join("levels")).unwrap();
    assert!(!root.join("levels/level-2.mtx").exists(), "level-2.mtx of the earlier run survived");
    assert!(root.join("levels/level-1.mtx").exists());
    let _ = std::fs::remove_dir_all(&root);
}

/// FNV-1a 64, as documented for `run.inputs[].fnv1a64`.
fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h = (h ^ b as u64).wrapping_mul(0x100000001b3);
    }
    h
}

#[test]
fn item_1_result_json_carries_run_identity() {
    let root = temp_dir("identity");
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_secs();
    let cases = [
        (vec!["solve", "bar-point-load.json"], "result.json"),
        (vec!["run", "wave-square-pulse-1d.json"], "history.json"),
        (vec!["coarsen", "coarsen-composite-bar.pipeline.json"], "summary.json"),
    ];
    for (k, (args, main)) in cases.iter().enumerate() {
        let (cmd, file) = (args[0], data(args[1]));
        let out = format!("out{k}");
        let o = linpd(&[cmd, &file, "--out", &out, "-q"], &root);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        let doc = complete_run(&root.join(&out)).unwrap();
        assert!(root.join(&out).join(main).exists());
        let run = &doc["run"];
        assert_eq!(run["linpd_version"], env!("CARGO_PKG_VERSION"));
        let input = &run["inputs"][0];
        assert_eq!(input["path"], file.as_str());
        let bytes = std::fs::read(&file).unwrap();
        assert_eq!(input["bytes"], bytes.len());
        assert_eq!(input["fnv1a64"], format!("{:016x}", fnv1a64(&bytes)), "{cmd}");
        let t = run["time_unix"].as_u64().unwrap();
        assert!(t >= now && t < now + 600, "time_unix {t}, now {now}");
        assert!(run["time_utc"].as_str().unwrap().ends_with('Z'));
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn item_6_trailing_garbage_rejected() {
    let root = temp_dir("trailing");
    let scene = std::fs::read_to_string(data("bar-point-load.json")).unwrap();
    let lines = scene.trim_end().lines().count();
    let bad = root.join("bad.json");
    std::fs::write(&bad, format!("{}\n{{\"name\": \"second\"}}\n", scene.trim_end())).unwrap();
    for cmd in ["solve", "validate"] {
        let mut args = vec![cmd, bad.to_str().unwrap()];
        if cmd == "solve" {
            args.extend(["--out", "out"]);
        }
        let o = linpd(&args, &root);
        assert!(!o.status.success(), "{cmd}: trailing text accepted");
        let e = stderr(&o);
        assert!(e.contains("trailing text") && e.contains(&format!("(line {}, column 1)", lines + 1)), "{cmd}: {e}");
    }
    let pipeline = std::fs::read_to_string(data("coarsen-composite-bar.pipeline.json")).unwrap();
    let pipeline = pipeline.replace("coarsen-composite-bar.json", &data("coarsen-composite-bar.json"));
    let bad = root.join("bad.pipeline.json");
    std::fs::write(&bad, format!("{pipeline} garbage")).unwrap();
    let o = linpd(&["coarsen", bad.to_str().unwrap(), "--out", "out"], &root);
    assert!(!o.status.success(), "coarsen: trailing text accepted");
    assert!(stderr(&o).contains("trailing text"), "{}", stderr(&o));
    assert_eq!(names(&root), ["bad.json", "bad.pipeline.json"], "a failed run wrote something");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn item_6_output_name_confined() {
    let root = temp_dir("confined");
    let work = root.join("a/b/work");
    std::fs::create_dir_all(&work).unwrap();
    let mut scene: Value =
        serde_json::from_str(&std::fs::read_to_string(data("bar-point-load.json")).unwrap()).unwrap();
    scene.as_object_mut().unwrap().remove("output");
    for name in ["../../x", "a/b", "..", "a\\b", "nul\u{0}byte"] {
        scene["name"] = json!(name);
        let path = write_json(&work.join("scene.json"), &scene);
        let o = linpd(&["solve", &path, "-q"], &work);
        assert!(!o.status.success(), "name {name:?} accepted");
        assert!(stderr(&o).contains("name: "), "{name:?}: {}", stderr(&o));
    }
    assert_eq!(names(&work), ["scene.json"], "something was written");
    assert_eq!(names(&root.join("a")), ["b"], "something was written outside out/");

    scene["name"] = json!("plate / fine");
    scene["output"] = json!({"dir": ""});
    let path = write_json(&work.join("scene.json"), &scene);
    let o = linpd(&["solve", &path, "-q"], &work);
    assert!(!o.status.success() && stderr(&o).contains("output.dir: must not be empty"), "{}", stderr(&o));
    // With an explicit output directory, any name is fine.
    scene["output"] = json!({"dir": "out/fine"});
    let path = write_json(&work.join("scene.json"), &scene);
    let o = linpd(&["solve", &path, "-q"], &work);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(complete_run(&work.join("out/fine")).unwrap()["name"], "plate / fine");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn broken_pipe_no_panic() {
    let root = temp_dir("pipe");
    let mut child = bin()
        .args(["solve", &data("bar-point-load.json"), "--out", "out"])
        .current_dir(&root)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone before linpd prints anything
    let o = child.wait_with_output().unwrap();
    let e = stderr(&o);
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(o.status.code(), Some(0), "{e}");
    complete_run(&root.join("out")).unwrap();
    // A study whose table reader is gone still writes all its files.
    let mut child = bin()
        .args(["study", "coarsen-tent", "--out", "study"])
        .current_dir(&root)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{e}");
    for f in ["data.json", "fig3_micromodulus.png", "fig3_micromodulus.svg"] {
        assert!(root.join("study").join(f).is_file(), "study: no {f}");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Studies write all of their files or none, like the other commands: `data.json` is the main
/// document (its `run.files` lists every figure), a second run replaces the first as a whole
/// (a figure the first run wrote and the second did not does not survive), and a directory
/// holding a file linpd did not write is refused with nothing written.
#[test]
fn item_1_study_outputs_atomic() {
    let root = temp_dir("study-atomic");
    let o = linpd(&["study", "coarsen-tent", "--out", "s"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = complete_run(&root.join("s")).unwrap();
    assert!(doc["run"]["linpd_version"].is_string());
    // a stale figure listed as ours (as an earlier run with more figures would have left it)
    let mut doc = doc;
    std::fs::write(root.join("s").join("old_figure.png"), b"old").unwrap();
    doc["run"]["files"].as_array_mut().unwrap().push(serde_json::json!({"name": "old_figure.png", "bytes": 3}));
    std::fs::write(root.join("s").join("data.json"), doc.to_string()).unwrap();
    let o = linpd(&["study", "coarsen-tent", "--out", "s"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    complete_run(&root.join("s")).unwrap();
    assert!(!root.join("s").join("old_figure.png").exists(), "stale figure survived");
    assert!(leftovers(&root.join("s"), &[]).is_empty(), "{:?}", leftovers(&root.join("s"), &[]));
    // a foreign file: refused, nothing written or removed
    std::fs::write(root.join("s").join("notes.txt"), b"mine").unwrap();
    let before = names(&root.join("s"));
    let o = linpd(&["study", "coarsen-tent", "--out", "s"], &root);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("notes.txt"), "{}", stderr(&o));
    assert_eq!(names(&root.join("s")), before);
    assert!(leftovers(&root.join("s"), &[]).is_empty(), "{:?}", leftovers(&root.join("s"), &[]));
    let _ = std::fs::remove_dir_all(&root);
}
