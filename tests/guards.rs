//! Guards of issue 15 (items 3-5), each a regression test named after what it guards: memory
//! estimates checked before allocating, CG that never reports success above its tolerance,
//! non-finite values named by their source, overflow named as overflow.
//!
//! The memory cases run the `linpd` binary with `LINPD_MEMORY_GIB=8` (an 8 GiB machine), so
//! they reject the same scenes on every machine; each must fail within 2 s, i.e. before any
//! per-node allocation.

use linpd::problem::{ModuliFile, Problem};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-guards-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `linpd <cmd> <scene>` on `scene` written to a temp file, with `LINPD_MEMORY_GIB=8`.
fn linpd(cmd: &str, tag: &str, scene: &Value) -> (Output, Duration) {
    let dir = temp_dir(tag);
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let t = Instant::now();
    let mut args = vec![cmd, path.to_str().unwrap()];
    if cmd == "solve" {
        args.push("-q");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(args)
        .env("LINPD_MEMORY_GIB", "8")
        .current_dir(&dir)
        .output()
        .expect("the linpd binary runs");
    (out, t.elapsed())
}

/// A scene on the box `[0, 1]^dim` with spacing `h`, clamped at `x <= 0`, pulled by a body load.
fn scene(dim: usize, h: f64, model: Value, solver: Value) -> Value {
    let lo = vec![-1.0; dim];
    let mut hi = vec![2.0; dim];
    hi[0] = 0.0;
    let mut density = vec![0.0; dim];
    density[0] = 1.0;
    json!({
        "name": "guard",
        "dimension": dim,
        "grid": {"min": vec![0.0; dim], "max": vec![1.0; dim], "spacing": h},
        "model": model,
        "constraints": [{"region": {"box": {"min": lo, "max": hi}}, "displacement": {"value": vec![0.0; dim]}}],
        "loads": [{"type": "body", "region": "all", "density": density}],
        "solver": solver,
        "output": {"dir": "out", "plot": false}
    })
}

fn bond(horizon: f64, modulus: f64) -> Value {
    json!({"type": "bond", "horizon": horizon,
           "micromodulus": {"kernel": "constant", "modulus": modulus, "normalize": "discrete"}})
}

fn assert_rejected(what: &str, out: &Output, took: Duration, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{what}: accepted\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{what}: `{n}` not in: {stderr}");
    }
    assert!(took < Duration::from_secs(2), "{what}: rejected after {took:?}, not before allocating");
}

/// LPS 3D 60^3 with delta = 2h: the tangent's reach is 2 delta (~185 coupled nodes per node,
/// 11.8 GiB), not the bond neighbourhood (~32, 1.5 GiB, which an 8 GiB machine would accept).
#[test]
fn lps_memory_guard_counts_two_delta() {
    let h = 1.0 / 60.0;
    let lps = json!({"type": "lps", "horizon": 2.0 * h, "bulk_modulus": 2.0, "shear_modulus": 0.5});
    let (out, took) = linpd("validate", "lps60", &scene(3, h, lps, json!({"type": "cg"})));
    assert_rejected(
        "LPS 60^3",
        &out,
        took,
        &["model.horizon", "LPS tangent of 226981 nodes (reach 2 delta", "11.8 GiB", "8.0 GiB available"],
    );
}

/// Matrix-free 3D 130^3 (delta = 4h, 256 bonds a node) and a 1D matrix-free bar of 6e8 nodes:
/// bonds, weights and the CG vectors are counted (the old guard counted 12 bytes a bond).
#[test]
fn matrix_free_memory_guard_counts_vectors() {
    let h = 1.0 / 130.0;
    let mf = json!({"type": "cg", "matrix_free": true});
    let (out, took) = linpd("validate", "mf130", &scene(3, h, bond(4.0 * h, 1.0), mf.clone()));
    assert_rejected("matrix-free 130^3", &out, took, &["2248091 nodes", "9.9 GiB", "8.0 GiB available"]);
    let h = 1.0 / 6e8;
    let (out, took) = linpd("solve", "bar6e8", &scene(1, h, bond(h, 1.0), mf));
    assert_rejected("1D bar of 6e8 nodes", &out, took, &["600000001 nodes", "GiB, more than the 8.0 GiB available"]);
}

/// Multigrid counts its hierarchy (`P`, `R`, coarse levels, the setup's transient `A P`: 3.5 kB
/// per DOF in 3D) on top of the matrix-free operator: a 110^3 cube at delta = 3h fits an 8 GiB
/// machine with matrix-free Jacobi-PCG (validation passes) but not with matrix-free multigrid,
/// which is refused at solve time before the bonds are built.
#[test]
fn multigrid_memory_guard_counts_the_hierarchy() {
    let h = 1.0 / 110.0;
    let mg = json!({"type": "cg", "matrix_free": true, "preconditioner": "multigrid"});
    let s = scene(3, h, bond(3.0 * h, 1.0), mg);
    let (out, _) = linpd("validate", "mg110-validate", &s);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (out, took) = linpd("solve", "mg110", &s);
    assert_rejected("multigrid 110^3", &out, took, &["multigrid hierarchy", "8.0 GiB available"]);
}

/// CG whose recursive residual meets rtol but whose true residual cannot (1D bar of 1000
/// nodes, rtol 1e-13): a named error and a non-zero exit, not success at 1e-10.
#[test]
fn cg_true_residual_checked() {
    let h = 0.001;
    let cg = json!({"type": "cg", "rtol": 1e-13});
    let (out, _) = linpd("solve", "cg-tight", &scene(1, h, bond(3.0 * h, 1.0), cg));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "exit 0:\n{stderr}");
    assert!(stderr.contains("above the requested 1e-13"), "{stderr}");
    // The same scene at a reachable tolerance solves, and reports a true residual below it.
    let cg = json!({"type": "cg", "rtol": 1e-8});
    let (out, _) = linpd("solve", "cg-ok", &scene(1, h, bond(3.0 * h, 1.0), cg));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// A point force of 1e308 with prescribed displacements of 1e300 (and variants): the source of
/// the non-finite value is named, never a NaN residual with exit 0.
#[test]
fn nan_load_is_an_error() {
    let base = |modulus: f64, force: f64, prescribed: f64| {
        let mut s = scene(1, 0.1, bond(0.2, modulus), json!({"type": "auto"}));
        s["constraints"][0]["displacement"]["value"] = json!([prescribed]);
        s["loads"] = json!([{"type": "point", "at": [0.5], "force": [force]}]);
        s
    };
    let solve = |s: &Value| {
        Problem::from_json(&s.to_string()).unwrap().solve(&linpd::core::NoProgress).unwrap_err().to_string()
    };
    // ||f||^2 overflows: every residual would be inf / inf.
    let e = solve(&base(1.0, 1e308, 1e300));
    assert!(e.contains("the load vector has non-finite values") && e.contains("squared norm overflows"), "{e}");
    // Finite loads, but A u_bar overflows.
    let e = solve(&base(1e10, 1.0, 1e300));
    assert!(e.contains("the load vector f - A u_bar (loads and prescribed displacements) has non-finite"), "{e}");
    // Through the binary: a non-zero exit and no result.
    let (out, _) = linpd("solve", "nan-load", &base(1.0, 1e308, 1e300));
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("the load vector"));
}

/// Moduli that overflow are named as overflow: a bond modulus of 1e308, an LPS shear modulus
/// of 1e308 (was "Poisson ratio = NaN"), and a coarsened level with node volumes of 1e300
/// (was "every DOF is constrained": the region tolerance grew with the volumes).
#[test]
fn modulus_overflow_named() {
    let s = scene(1, 0.1, bond(0.2, 1e308), json!({"type": "auto"}));
    let e = Problem::from_json(&s.to_string()).unwrap_err().to_string();
    assert!(e.contains("model.micromodulus") && e.contains("modulus 1e308 overflows"), "{e}");
    assert!(!e.contains("positive definite"), "{e}");

    let lps = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 2.0, "shear_modulus": 1e308});
    let e = Problem::from_json(&scene(2, 0.25, lps, json!({"type": "auto"})).to_string()).unwrap_err().to_string();
    assert!(e.contains("model.shear_modulus") && e.contains("overflow") && e.contains("G = 1e308"), "{e}");
    assert!(!e.contains("NaN"), "{e}");

    let dir = temp_dir("big-volumes");
    let n = 11;
    let entries = (0..n)
        .flat_map(|i: usize| {
            (0..n).filter(move |&j: &usize| (1..=2).contains(&i.abs_diff(j))).map(move |j| (i, j, 1.0))
        })
        .collect();
    ModuliFile {
        level: 1,
        dim: 1,
        positions: (0..n).map(|i| [0.1 * i as f64, 0.0, 0.0]).collect(),
        volumes: vec![1e300; n],
        level0: (0..n).collect(),
        entries,
    }
    .write(&dir.join("level-1"))
    .unwrap();
    let s = json!({
        "name": "big-volumes", "dimension": 1,
        "model": {"type": "coarsened", "moduli": "level-1.mtx"},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "point", "at": [1.0], "force": [1.0]}]
    });
    let p = Problem::from_json_in(&s.to_string(), &dir).unwrap();
    let e = p.solve(&linpd::core::NoProgress).unwrap_err().to_string();
    assert!(e.contains("the stiffness has non-finite values") && e.contains("overflow"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `grid.layer: 1e300` is an error naming the layer, not a wrapped count of "99 nodes".
#[test]
fn grid_layer_overflow_is_an_error() {
    let mut s = scene(1, 0.1, bond(0.2, 1.0), json!({"type": "auto"}));
    s["grid"]["layer"] = json!(1e300);
    let e = Problem::from_json(&s.to_string()).unwrap_err().to_string();
    assert!(
        e.contains("grid.layer") && e.contains("layer 1e300 with spacing 1e-1 gives more than usize::MAX nodes"),
        "{e}"
    );
}
