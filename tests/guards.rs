//! Guards of issue 15 (items 3-6), each a regression test named after what it guards: memory
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
fn item_3_lps_memory_guard_counts_two_delta() {
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

/// Matrix-free LPS (issue #35): the estimate counts the model's bonds (20 bytes each), the CG
/// vectors and, with multigrid, the pair part's hierarchy and bond graph, not the tangent. The
/// 60^3 cube at `delta = 2h` that the assembled estimate refuses (11.8 GiB, above) is accepted
/// under `auto`, which solves it matrix-free (with a body it assembles and is refused); at 120^3 and `delta = 3h` Jacobi-CG fits in 8 GiB
/// and multigrid-CG does not.
#[test]
fn item_3_lps_matrix_free_memory_guard_counts_bonds_and_hierarchy() {
    let h = 1.0 / 60.0;
    let lps = |delta: f64| json!({"type": "lps", "horizon": delta, "bulk_modulus": 2.0, "shear_modulus": 0.5});
    let (out, _) = linpd("validate", "lps60-auto", &scene(3, h, lps(2.0 * h), json!({"type": "auto"})));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // with a body the stencils do not apply and `auto` assembles: refused as before
    let mut with_body = scene(3, h, lps(2.0 * h), json!({"type": "auto"}));
    with_body["body"] = json!({"difference": ["all", {"ball": {"center": [0.5, 0.5, 0.5], "radius": 0.1}}]});
    let (out, took) = linpd("validate", "lps60-body", &with_body);
    assert_rejected("LPS 60^3 with a body", &out, took, &["model.horizon", "LPS tangent of 226981 nodes"]);
    let h = 1.0 / 120.0;
    let jacobi = json!({"type": "cg", "matrix_free": true});
    let (out, _) = linpd("validate", "lps120-jacobi", &scene(3, h, lps(3.0 * h), jacobi));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let multigrid = json!({"type": "cg", "matrix_free": true, "preconditioner": "multigrid"});
    let (out, took) = linpd("validate", "lps120-mg", &scene(3, h, lps(3.0 * h), multigrid));
    assert_rejected(
        "LPS 120^3 multigrid",
        &out,
        took,
        &["model.horizon", "matrix-free LPS tangent", "1771561 nodes", "multigrid hierarchy", "8.0 GiB available"],
    );
}

/// A bond model with a weakened plane (`factor` 0.5 across `z = 0.5`): its bonds are stored
/// (the corrected stencil reads them), unlike the homogeneous stencil's.
fn bond_with_bonds(horizon: f64, modulus: f64) -> Value {
    let mut b = bond(horizon, modulus);
    b["material"] =
        json!({"defects": [{"plane": {"point": [0.0, 0.0, 0.5013], "normal": [0.0, 0.0, 1.0]}, "factor": 0.5}]});
    b
}

/// Matrix-free 3D 140^3 (delta = 4h, 256 bonds a node, stored: a weakened plane) and a 1D
/// matrix-free bar of 6e8 nodes: bonds, weights and the CG vectors are counted (the old guard
/// counted 12 bytes a bond and no vectors). The homogeneous 140^3 stores no bonds (the stencil
/// alone): its estimate is the solve's vectors and the outputs, 7.7 GiB, and it is accepted.
#[test]
fn item_3_matrix_free_memory_guard_counts_vectors() {
    let h = 1.0 / 140.0;
    let mf = json!({"type": "cg", "matrix_free": true});
    let (out, _) = linpd("validate", "mf140-stencil", &scene(3, h, bond(4.0 * h, 1.0), mf.clone()));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (out, took) = linpd("validate", "mf140", &scene(3, h, bond_with_bonds(4.0 * h, 1.0), mf.clone()));
    assert_rejected("matrix-free 140^3", &out, took, &["2803221 nodes", "9.6 GiB", "8.0 GiB available"]);
    let h = 1.0 / 6e8;
    let (out, took) = linpd("solve", "bar6e8", &scene(1, h, bond(h, 1.0), mf));
    assert_rejected("1D bar of 6e8 nodes", &out, took, &["600000001 nodes", "GiB, more than the 8.0 GiB available"]);
}

/// Multigrid counts its hierarchy (`P`, `R`, coarse levels, the setup's transient `A P`) on
/// top of the matrix-free operator: a 120^3 cube at delta = 3h with stored bonds (a weakened
/// plane) fits an 8 GiB machine with matrix-free Jacobi-PCG but not with matrix-free multigrid
/// (1250 bytes a DOF), which is refused at validation (the scene names its solver) before
/// anything per node is built. A homogeneous 120^3 cube stores no bonds and fits with
/// multigrid too, at `delta = 10h` as well: its multigrid is the geometric one
/// (`linpd_solve::LatticeMultigrid`), which aggregates no fine bond graph (4 bytes a bond,
/// 4,168 a node: 28 GiB). A 2D plate keeps smoothed aggregation, and at `delta = 20h`
/// (1,256 bonds a node) its graph is what does not fit.
#[test]
fn item_3_multigrid_memory_guard_counts_the_hierarchy() {
    let h = 1.0 / 120.0;
    let jacobi = json!({"type": "cg", "matrix_free": true});
    let (out, _) = linpd("validate", "jacobi120-validate", &scene(3, h, bond_with_bonds(3.0 * h, 1.0), jacobi));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mg = json!({"type": "cg", "matrix_free": true, "preconditioner": "multigrid"});
    let (out, _) = linpd("validate", "mg120-stencil", &scene(3, h, bond(3.0 * h, 1.0), mg.clone()));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (out, _) = linpd("validate", "mg120-wide", &scene(3, h, bond(10.0 * h, 1.0), mg.clone()));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let h2 = 1.0 / 1500.0;
    let mut plate = bond(20.0 * h2, 1.0);
    plate["plane"] = json!("stress");
    let (out, took) = linpd("validate", "mg1500-wide", &scene(2, h2, plate.clone(), mg.clone()));
    assert_rejected("multigrid 1501^2, delta = 20h", &out, took, &["multigrid hierarchy", "8.0 GiB available"]);
    let jacobi = json!({"type": "cg", "matrix_free": true});
    let (out, _) = linpd("validate", "jacobi1500-wide", &scene(2, h2, plate, jacobi));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (out, took) = linpd("validate", "mg120", &scene(3, h, bond_with_bonds(3.0 * h, 1.0), mg));
    assert_rejected("multigrid 120^3", &out, took, &["multigrid hierarchy", "9.6 GiB", "8.0 GiB available"]);
}

/// CG whose recursive residual meets rtol but whose true residual cannot (1D bar of 1000
/// nodes, rtol 1e-13): a named error and a non-zero exit, not success at 1e-10.
#[test]
fn item_4_cg_true_residual_checked() {
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
fn item_4_nan_load_is_an_error() {
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
fn item_5_modulus_overflow_named() {
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
fn item_5_grid_layer_overflow_is_an_error() {
    let mut s = scene(1, 0.1, bond(0.2, 1.0), json!({"type": "auto"}));
    s["grid"]["layer"] = json!(1e300);
    let e = Problem::from_json(&s.to_string()).unwrap_err().to_string();
    assert!(
        e.contains("grid.layer") && e.contains("layer 1e300 with spacing 1e-1 gives more than usize::MAX nodes"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Item 6: runaway loops and contradictions, refused before they start
// ---------------------------------------------------------------------------------------------

/// A pipeline whose `levels[0]` is `level` (on the bundled 2D plate scene, copied beside it).
fn pipeline(tag: &str, level: Value) -> (PathBuf, PathBuf) {
    let dir = temp_dir(tag);
    std::fs::copy("data/coarsen-plate-2d.json", dir.join("coarsen-plate-2d.json")).unwrap();
    let p = json!({"name": tag, "scene": "coarsen-plate-2d.json", "levels": [level], "solve": false});
    let path = dir.join("p.json");
    std::fs::write(&path, p.to_string()).unwrap();
    (dir, path)
}

fn coarsen(dir: &std::path::Path, path: &std::path::Path) -> (Output, Duration) {
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["coarsen", path.to_str().unwrap(), "-q", "--out", "o"])
        .current_dir(dir)
        .output()
        .unwrap();
    (out, t.elapsed())
}

/// `radius_growth: 1.000000001` would try ~3e9 radii, each a full coarsening step: refused
/// before the first (until 2026-11 it ran for days). `radius_max < radius_start` is refused by
/// name (it used to be raised silently to the start).
#[test]
fn item_6_radius_growth_and_radius_max_guarded() {
    let (dir, path) = pipeline("growth", json!({"every": 2, "tolerance": 1e-9, "radius_growth": 1.000000001}));
    let (out, took) = coarsen(&dir, &path);
    assert_rejected(
        "growth 1.000000001",
        &out,
        took,
        &["levels[0]", "radius rule: growth 1.000000001e0", "more than 40", "raise radius_growth"],
    );
    assert!(!dir.join("o").exists(), "an error writes nothing");
    let (dir, path) = pipeline("rmax", json!({"every": 2, "tolerance": 1e-2, "radius_start": 0.3, "radius_max": 0.2}));
    let (out, took) = coarsen(&dir, &path);
    assert_rejected(
        "radius_max < radius_start",
        &out,
        took,
        &["levels[0].radius_max", "2e-1 is below radius_start 3e-1"],
    );
    // radius_max below the default start (2 x horizon = 0.125): the default start yields to the
    // user's maximum (defaults never contradict a value the user gave), and 0.1 misses the
    // tolerance
    let (dir, path) = pipeline("rmax-default", json!({"every": 2, "tolerance": 1e-2, "radius_max": 0.1}));
    let (out, took) = coarsen(&dir, &path);
    assert_rejected(
        "radius_max < 2 horizon",
        &out,
        took,
        &["tail of C^m is still", "tried: [(0.1, ", "raise the maximum radius"],
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// A 1D wave scene (401 nodes, horizon 2h) with `steps` and `output_every`.
fn wave(steps: u64, output_every: u64) -> Value {
    json!({
        "name": "wave", "dimension": 1,
        "grid": {"min": [0.0], "max": [1.0], "spacing": 0.0025},
        "model": {"type": "bond", "horizon": 0.005,
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}}],
        "dynamics": {"dt_safety": 0.5, "steps": steps, "output_every": output_every, "density": 1.0,
                     "initial": {"type": "square_pulse", "from": 0.4, "to": 0.6, "amplitude": 1.0}},
        "output": {"dir": "out", "plot": false}
    })
}

/// `dynamics.steps: 1e18` (1e18 x 401 x 4 bond updates, 1.6e21) is refused before the first
/// step, naming the work and the limit; `steps: 5e6, output_every: 1` (5e6 snapshots kept in
/// memory and written as 1e7 files) is refused at `output_every`, naming the smallest interval
/// that passes, which then runs.
#[test]
fn item_6_dynamics_steps_and_snapshots_guarded() {
    let (out, took) = linpd("run", "steps", &wave(1_000_000_000_000_000_000, 1_000_000_000_000_000));
    assert_rejected("steps 1e18", &out, took, &["dynamics.steps", "1e18 steps", "more than 1e14"]);
    let (out, took) = linpd("run", "snapshots", &wave(5_000_000, 1));
    assert_rejected(
        "5e6 snapshots",
        &out,
        took,
        &["dynamics.output_every", "5000001 snapshots", "more than 10000", "use output_every >= 501"],
    );
    // the limit itself is accepted: 5000 steps every 1 = 5001 snapshots
    let p = Problem::from_json(&wave(5000, 1).to_string()).unwrap();
    assert_eq!(p.dynamics().unwrap().output_every(), 1);
}

/// Two constraints prescribing different values on one DOF: an error naming both (until
/// 2026-11 the later silently won); the same value twice (overlapping regions of one field) is
/// fine.
#[test]
fn item_6_contradictory_constraints_refused() {
    let mut s = scene(1, 0.1, bond(0.2, 1.0), json!({"type": "auto"}));
    let c = |lo: f64, hi: f64, u: f64| json!({"region": {"box": {"min": [lo], "max": [hi]}}, "displacement": {"value": [u]}});
    s["constraints"] = json!([c(-1.0, 0.0, 0.0), c(-0.05, 0.15, 0.0)]);
    Problem::from_json(&s.to_string()).expect("agreeing constraints overlap");
    s["constraints"] = json!([c(-1.0, 0.0, 0.0), c(-0.05, 0.15, 1e-3)]);
    let e = Problem::from_json(&s.to_string()).unwrap_err().to_string();
    assert!(
        e.contains("constraints[1]") && e.contains("u_0 = 1e-3 at node") && e.contains("constraints[0] prescribes 0e0"),
        "{e}"
    );
}

/// `linpd validate /dev/urandom` (an endless device) and a FIFO are refused at once instead of
/// read forever; an oversized file is refused by its size.
#[test]
fn item_6_scene_file_must_be_a_regular_bounded_file() {
    let (out, took) = {
        let t = Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_linpd")).args(["validate", "/dev/urandom"]).output().unwrap();
        (o, t.elapsed())
    };
    assert_rejected("/dev/urandom", &out, took, &["/dev/urandom", "not a regular file"]);
    let dir = temp_dir("big-file");
    let big = dir.join("big.json");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(linpd::problem::MAX_JSON_BYTES + 1).unwrap();
    let t = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_linpd")).args(["validate", big.to_str().unwrap()]).output().unwrap();
    assert_rejected("17 MiB scene", &o, t.elapsed(), &["big.json", "16777217 bytes, more than"]);
    let _ = std::fs::remove_dir_all(dir);
}
