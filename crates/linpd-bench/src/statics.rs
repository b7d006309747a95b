//! `linpd bench --statics`: whole static solves of scenes (assembly + solver setup + solve), one
//! row per case and solver, the cases of the scalable-solver issue:
//!
//! * `3d-cantilever-N` (N = 20, 30, 40, 50, 70 nodes per side): the unit cube, `delta = 3h`,
//!   bond-based, clamped through a `delta`-thick layer at `x <= 0`, a body-force density `-z` on
//!   the nodes of `x >= 1` (the layer beyond the far face);
//! * `2d-plate-N-m2` (N = 101, 201, 401, 801): the unit square, `delta = 2h`, plane stress,
//!   clamped through the layer at `x <= 0`, body load `-y` on `x >= 1` (the setting of
//!   PeriLab's published timing table at N = 401: 160,801 points, m = 2).
//!
//! Solvers per case: Jacobi-PCG (matrix-free with the lattice stencil from 10^6 unknowns, where
//! the assembled matrix would not fit), multigrid-PCG where offered, sparse Cholesky where its
//! factor fits (2D all sizes; 3D up to `--direct-max-3d` unknowns), and `auto`. Every run
//! reports iterations, the relative residual and the setup / solve split; times are ratios
//! against Jacobi-PCG measured in the same run.

use linpd_problem::Problem;
use linpd_solve::{CgParams, PreconditionerKind, SolverSpec};
use serde_json::{json, Value};
use std::time::Instant;

/// Unknowns above which Jacobi-PCG runs matrix-free (assembled `A` ~ 1100 entries per 3D row).
const MATRIX_FREE_FROM: usize = 600_000;

/// The scene of a case: `dim` 2 or 3, `nodes` per side of the unit body, horizon `m h`.
fn scene(name: &str, dim: usize, nodes: usize, m: usize) -> Problem {
    let h = 1.0 / (nodes - 1) as f64;
    let delta = m as f64 * h;
    let z = vec![0.0; dim];
    let one = vec![1.0; dim];
    let (lo, hi) = (vec![-1.0; dim], vec![2.0; dim]);
    let mut clamp_hi = hi.clone();
    clamp_hi[0] = 0.0;
    let mut load_lo = lo.clone();
    load_lo[0] = 1.0;
    let mut density = vec![0.0; dim];
    density[dim - 1] = -1.0;
    let mut model = json!({"type": "bond", "horizon": delta,
        "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}});
    if dim == 2 {
        model["plane"] = json!("stress");
    }
    let text = json!({
        "name": name, "dimension": dim,
        "grid": {"min": z, "max": one, "spacing": h, "layer": delta},
        "model": model,
        "constraints": [{"region": {"box": {"min": lo, "max": clamp_hi}}, "displacement": {"value": vec![0.0; dim]}}],
        "loads": [{"type": "body", "region": {"box": {"min": load_lo, "max": hi}}, "density": density}],
        "output": {"plot": false}
    })
    .to_string();
    Problem::from_json(&text).expect("bench scene")
}

/// `(name, dim, nodes per side, m)`.
fn cases(quick: bool) -> Vec<(String, usize, usize, usize)> {
    let (cubes, plates): (&[usize], &[usize]) =
        if quick { (&[8, 10], &[21, 41]) } else { (&[20, 30, 40, 50, 70], &[101, 201, 401, 801]) };
    let mut v: Vec<_> = cubes.iter().map(|&n| (format!("3d-cantilever-{n}"), 3, n, 3)).collect();
    v.extend(plates.iter().map(|&n| (format!("2d-plate-{n}-m2"), 2, n, 2)));
    v
}

/// The solvers run on a case with `n` unknowns.
fn solvers(dim: usize, n: usize, direct_max_3d: usize) -> Vec<(&'static str, SolverSpec)> {
    let params = CgParams { rtol: 1e-8, max_iter: 20_000 };
    let mf = n >= MATRIX_FREE_FROM;
    let mut v = vec![(
        "cg-jacobi",
        SolverSpec::Cg { params: params.clone(), preconditioner: PreconditionerKind::Jacobi, matrix_free: mf },
    )];
    v.extend(crate::multigrid_solver(&params, mf));
    if dim == 2 || n <= direct_max_3d {
        v.push(("cholesky", SolverSpec::Cholesky));
    }
    if !mf {
        v.push(("auto", SolverSpec::Auto(params)));
    }
    v
}

/// Runs every case (names containing `filter`, if given) and returns the JSON section.
pub fn run(quick: bool, filter: Option<&str>, direct_max_3d: usize) -> Value {
    let mut out = serde_json::Map::new();
    for (name, dim, nodes, m) in cases(quick) {
        if filter.is_some_and(|f| !name.contains(f)) {
            continue;
        }
        let mut p = scene(&name, dim, nodes, m);
        let n_free = dim * p.nodes().len(); // an upper bound, for the solver list
        let mut rows = Vec::new();
        let mut jacobi_total = None;
        for (label, spec) in solvers(dim, n_free, direct_max_3d) {
            eprintln!("[bench] statics {name}: {label}");
            crate::reset_peak_rss();
            p.set_solver(spec);
            let t = Instant::now();
            let row = match p.solve(&|_| {}) {
                Ok(s) => {
                    let wall = t.elapsed().as_secs_f64();
                    let r = &s.report;
                    if label == "cg-jacobi" {
                        jacobi_total = Some(wall);
                    }
                    json!({
                        "solver": label, "ran": r.solver, "n": r.n, "nnz_a": r.nnz_a,
                        "iterations": r.iterations, "rel_residual": r.rel_residual,
                        "assemble": r.timings.assemble, "setup": r.timings.setup + r.timings.symbolic + r.timings.numeric,
                        "solve": r.timings.solve, "total": wall,
                        "speedup_vs_jacobi": jacobi_total.map(|j| j / wall),
                        "nnz_factor": r.nnz_factor, "auto": r.auto,
                        "peak_rss_gib": r.peak_rss_bytes.map(|b| b as f64 / (1u64 << 30) as f64),
                    })
                }
                Err(e) => json!({"solver": label, "error": e.to_string()}),
            };
            rows.push(row);
        }
        out.insert(name, Value::Array(rows));
    }
    Value::Object(out)
}

/// Prints the section returned by [`run`].
pub fn print(section: &Value) {
    println!(
        "{:<20} {:<24} {:>9} {:>6} {:>9} {:>8} {:>8} {:>8} {:>8} {:>7} {:>6}",
        "case", "solver", "unknowns", "iters", "residual", "asm s", "setup s", "solve s", "total s", "vs jac", "GiB"
    );
    let Some(cases) = section.as_object() else { return };
    for (name, rows) in cases {
        for r in rows.as_array().into_iter().flatten() {
            if let Some(e) = r["error"].as_str() {
                println!("{name:<20} {:<24} error: {e}", r["solver"].as_str().unwrap_or("?"));
                continue;
            }
            let f = |k: &str, p: usize| r[k].as_f64().map_or("-".into(), |x| format!("{x:.p$}"));
            let ran = r["ran"].as_str().unwrap_or("?");
            let shown = if r["solver"] == "auto" { format!("auto: {ran}") } else { ran.to_string() };
            println!(
                "{name:<20} {shown:<24} {:>9} {:>6} {:>9} {:>8} {:>8} {:>8} {:>8} {:>7} {:>6}",
                r["n"],
                r["iterations"].as_u64().map_or("-".into(), |i| i.to_string()),
                r["rel_residual"].as_f64().map_or("-".into(), |x| format!("{x:.1e}")),
                f("assemble", 2),
                f("setup", 2),
                f("solve", 2),
                f("total", 2),
                f("speedup_vs_jacobi", 2),
                f("peak_rss_gib", 2),
            );
        }
    }
}
