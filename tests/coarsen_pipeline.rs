//! `linpd coarsen PIPELINE.json` end to end: the bundled pipelines run and write readable
//! levels; a whole-body radius reproduces the level-0 solution at the shared nodes to round-off;
//! a coarsened level loaded as a scene (`"model": {"type": "coarsened"}`) solves to the
//! pipeline's own per-level solution; malformed pipelines fail with the cause and no output.

use linpd_problem::ModuliFile;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn linpd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().expect("the linpd binary runs")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-pipeline-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run_ok(pipeline: &Path, out: &Path) -> Value {
    let o = linpd(&["coarsen", pipeline.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}: {stderr}", pipeline.display());
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn bundled_pipelines_run_and_write_readable_levels() {
    for name in ["coarsen-composite-bar", "coarsen-defect-bar", "coarsen-plate-2d", "coarsen-lps-plate-2d"] {
        let out = temp_dir(name);
        let s = run_ok(&root().join(format!("data/{name}.pipeline.json")), &out);
        let levels = s["levels"].as_array().unwrap();
        for l in &levels[1..] {
            let m = l["level"].as_u64().unwrap();
            let file = ModuliFile::read(&out.join(format!("level-{m}.mtx"))).unwrap();
            assert_eq!(file.n_nodes() as u64, l["nodes"].as_u64().unwrap(), "{name} level {m}");
            // symmetrized by default: C_ij = C_ji^T exactly
            assert!(file.asymmetry() < 1e-14, "{name} level {m}: asymmetry {}", file.asymmetry());
            let step = &l["step"];
            assert!(step["radius"].as_f64().unwrap() >= step["horizon_fine"].as_f64().unwrap());
            assert!(out.join(format!("level-{m}.json")).exists());
            println!(
                "{name} level {m}: {} nodes, r = {:.4e}, tail {:.2e}, hit rate {:.3}, error at shared nodes {:.3e}",
                l["nodes"],
                step["radius"].as_f64().unwrap(),
                step["tail"].as_f64().unwrap(),
                step["hit_rate"].as_f64().unwrap(),
                l["error_shared"].as_f64().unwrap()
            );
        }
        assert!(out.join("shared.csv").exists());
    }
}

#[test]
fn whole_body_radius_reproduces_the_fine_solution_through_the_pipeline() {
    // Static condensation: tolerance 1e-10 (eps times the condition number ~1e5 of the bar).
    let dir = temp_dir("exact");
    let p = dir.join("exact.pipeline.json");
    let scene = root().join("data/coarsen-composite-bar.json");
    std::fs::write(
        &p,
        format!(
            r#"{{"name": "exact", "scene": "{}", "levels": [{{"every": 4, "radius": 10.0}}, {{"every": 2, "radius": 10.0}}], "solve": true}}"#,
            scene.display()
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let s = run_ok(&p, &out);
    for l in s["levels"].as_array().unwrap() {
        let e = l["error_shared"].as_f64().unwrap();
        println!("whole-body radius, level {}: error at shared nodes {e:.2e}", l["level"]);
        assert!(e < 1e-10);
    }
}

#[test]
fn a_coarsened_level_solves_as_a_scene_like_in_the_pipeline() {
    // Level 2 of the composite bar is the coarsest level: its nodes are the shared nodes, so a
    // scene on it with the same constraints and a point load is the pipeline's level-2 problem.
    let dir = temp_dir("scene");
    let scene0 = root().join("data/coarsen-composite-bar.json");
    let mut s0: Value = serde_json::from_str(&std::fs::read_to_string(&scene0).unwrap()).unwrap();
    s0["loads"] = serde_json::json!([{"type": "point", "at": [1.0], "force": [1e-5]}]);
    let scene0b = dir.join("scene0.json");
    std::fs::write(&scene0b, s0.to_string()).unwrap();
    let p = dir.join("p.pipeline.json");
    std::fs::write(
        &p,
        r#"{"name": "p", "scene": "scene0.json", "levels": [{"every": 4, "radius": 0.15}, {"every": 2, "radius": 0.3}], "solve": true}"#,
    )
    .unwrap();
    let out = dir.join("out");
    run_ok(&p, &out);
    let scene2 = serde_json::json!({
        "name": "level2", "dimension": 1,
        "model": {"type": "coarsened", "moduli": "out/level-2.mtx"},
        "constraints": s0["constraints"], "loads": s0["loads"]
    });
    let scene2p = dir.join("level2.json");
    std::fs::write(&scene2p, scene2.to_string()).unwrap();
    let o = linpd(&["solve", scene2p.to_str().unwrap(), "--out", dir.join("solved").to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("solved/result.json")).unwrap()).unwrap();
    let u_scene: Vec<f64> = r["u"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let csv = std::fs::read_to_string(out.join("shared.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "ux_level2").unwrap();
    let u_pipe: Vec<f64> = lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect();
    assert_eq!(u_scene.len(), u_pipe.len());
    let umax = u_pipe.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = u_scene.iter().zip(&u_pipe).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
    println!("coarsened scene vs pipeline level 2: rel. difference {err:.2e}");
    // same matrix, two solvers (sparse Cholesky both, different orderings): 1e-10
    assert!(err < 1e-10);
}

#[test]
fn malformed_pipelines_fail_with_the_cause_and_write_nothing() {
    let dir = temp_dir("bad");
    let scene = root().join("data/coarsen-composite-bar.json");
    let sc = scene.display().to_string();
    let cases: Vec<(String, &str)> = vec![
        ("{".into(), "line"),
        (
            format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "radius": 0.1}}], "colour": 1}}"#),
            "unknown field `colour`",
        ),
        (format!(r#"{{"name": "b", "scene": "{sc}", "levels": []}}"#), "levels: must list at least one"),
        (
            format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "nodes": [0], "radius": 0.1}}]}}"#),
            "exactly one of `every`",
        ),
        (format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2}}]}}"#), "exactly one of `radius`"),
        (
            format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 1, "radius": 0.1}}]}}"#),
            "levels[0].every: must be >= 2",
        ),
        (
            format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "radius": 0.01}}]}}"#),
            "smaller than the horizon",
        ),
        (format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"nodes": [], "radius": 0.1}}]}}"#), "empty"),
        (
            format!(r#"{{"name": "b", "scene": "{sc}", "levels": [{{"nodes": [0, 4, 999], "radius": 0.1}}]}}"#),
            "retained node 999",
        ),
        (
            format!(
                r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "tolerance": 1e-12, "radius_max": 0.12}}]}}"#
            ),
            "tail of C^m is still",
        ),
        (
            format!(
                r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "radius": 0.1, "radius_growth": 2.0}}]}}"#
            ),
            "belong to the radius rule",
        ),
        (
            r#"{"name": "b", "scene": "no-such-scene.json", "levels": [{"every": 2, "radius": 0.1}]}"#.into(),
            "no-such-scene.json",
        ),
        (
            format!(
                r#"{{"name": "b", "scene": "{}", "levels": [{{"every": 2, "radius": 0.1}}]}}"#,
                root().join("data/blend-point-load.json").display()
            ),
            "coarsening is not available for blend models",
        ),
        (
            format!(r#"{{"name": "b", "scene": "{}", "levels": [{{"every": 4, "radius": 0.15}}], "solve": true}}"#, {
                // held only at x = 0.005, a node that every 4th drops
                let mut s: Value = serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
                s["constraints"][0]["region"] = serde_json::json!({"box": {"min": [0.004], "max": [0.006]}});
                let held = dir.join("held-on-a-dropped-node.json");
                std::fs::write(&held, s.to_string()).unwrap();
                held.display().to_string()
            }),
            "level 1 keeps no prescribed DOF",
        ),
        (
            format!(
                r#"{{"name": "b", "scene": "{sc}", "levels": [{{"every": 2, "tolerance": 1e-3, "radius_start": 0.5, "radius_max": 0.2}}]}}"#
            ),
            "levels[0].radius_max: 2e-1 is below radius_start 5e-1",
        ),
    ];
    for (k, (text, needle)) in cases.iter().enumerate() {
        let p = dir.join(format!("bad{k}.pipeline.json"));
        std::fs::write(&p, text).unwrap();
        let out = dir.join(format!("out{k}"));
        let o = linpd(&["coarsen", p.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("case {k}: {}", stderr.trim());
        assert!(!o.status.success(), "case {k} succeeded");
        assert!(!stderr.contains("panicked"), "case {k} panicked: {stderr}");
        assert!(stderr.contains(needle), "case {k}: {stderr:?} lacks {needle:?}");
        assert!(!out.join("summary.json").exists() && !out.join("level-1.mtx").exists(), "case {k} wrote output");
    }
}
