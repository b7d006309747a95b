//! `linpd study multires`: the blended model with a graded local mesh (`model.local_mesh`,
//! [`linpd_blend::GradedBlend`]) against pure PD on the same lattice, in the same run: error,
//! unknowns and time for several gradings and lattice sizes (issue #31).
//!
//! * **Bodies**: the edge-cracked plate of `linpd study blend-2d` (unit square, plane strain,
//!   `delta = 3h`, a pre-crack from the left face to `x = 0.4`, the bottom layer held, the top
//!   layer pulled by 0.01) and its plate with a hole (`1 x 0.5`, plane stress, a hole of radius
//!   0.1, the left layer held, a resultant pulling the right one), `n` = 250, 500, 1000 cells
//!   per unit length (65k to 4.0M lattice nodes for the plate, half as many with the hole);
//!   the 48^3 block with a penny crack of `data/penny-graded-3d.json` (3D, a given ball
//!   of PD: the auto zones of a block with held faces cover it); and the notched block of
//!   `linpd study blend-2d` at the 100^3 (3D, auto zones of half a horizon: one
//!   around the notch, the held faces' whole layers).
//! * **Pure PD**: `auto` (the cost model's fastest solver: CG + multigrid on the assembled
//!   operator here, the crack leaving the stencil path), rtol 1e-10.
//! * **Graded**: `"pd_regions": "auto"` (2 horizons around the crack and the supports' faces, a
//!   1-horizon linear transition), cells up to `L = 64h`, `m` = 2, 4, 8 cells per level, `auto`
//!   (GMRES + multigrid from the SPD companion), rtol 1e-10; its field is drawn on every lattice
//!   node (`"output": {"nodes": "lattice"}`) for the error.
//!
//! Error: `max |u_graded - u_PD| / max |u_PD|` over the lattice nodes; unknowns: the free DOFs
//! of each solve; time: wall seconds of reading the scene, building and solving it in this
//! process (each case once; the ratio to pure PD of the same size), without the solution's
//! fields (strain, reactions, volumes: the graded model draws them here on every lattice node
//! for the error, which its own output, on its mesh's nodes, does not; `seconds_with_fields`
//! in data.json has them) and without the checks before the solver's clock (the supports'
//! connectivity over every partner: more of pure PD's time than of the graded model's);
//! memory: the estimate the
//! memory guard checks (within 0.8-1.2 of the measured peaks, docs/robustness.md: a process's
//! peak is monotone, so per-case peaks in one process would be the largest so far).
//! `--max-nodes N` skips the lattices of more than `N` nodes.

use crate::blend2d::body;
use crate::out::{create_dir, plot, write, Cases};
use crate::StudyError;
use linpd_core::progress::{NoProgress, Progress};
use linpd_plot::{Series, SeriesStyle};
use linpd_problem::Problem;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Lattice sizes (cells per unit length).
const SIZES: [usize; 4] = [250, 500, 1000, 2000];
/// The bodies ([`scene`]).
const BODIES: [&str; 4] = ["edge-crack", "hole", "penny", "notched-block"];
/// The penny block's lattice (cells a side) and crack radius.
const PENNY: (usize, f64) = (48, 0.06);
/// The notched block's lattice (cells a side): the issue's.
const NOTCHED: usize = 100;

/// The lattice sizes of a body.
fn sizes_of(name: &str) -> &'static [usize] {
    if name == "penny" {
        std::slice::from_ref(&PENNY.0)
    } else if name == "notched-block" {
        std::slice::from_ref(&NOTCHED)
    } else {
        &SIZES
    }
}

/// The pure-PD scene of a body at `n` cells per unit length: `linpd study blend-2d`'s plates,
/// or the block of `data/penny-graded-3d.json` (a unit cube, `delta = 2h`, a penny crack of
/// radius 0.06 at mid-height, the bottom layer held, the top one pulled by 0.01).
fn scene(name: &str, n: usize) -> Value {
    if name != "penny" {
        return body(name, n);
    }
    let h = 1.0 / n as f64;
    let (d, z, r) = (2.0 * h, 0.5 + h / 2.0, PENNY.1);
    json!({
        "name": format!("penny-{n}"), "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": h, "layer": {"z-": d, "z+": d}},
        "model": {"type": "bond", "horizon": d,
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "continuum"},
                  "material": {"defects": [{"plane": {"point": [0.5, 0.5, z], "normal": [0.0, 0.0, 1.0],
                      "extent": {"ball": {"center": [0.5, 0.5, z], "radius": r}}}, "factor": 0.0}]}},
        "constraints": [
            {"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0, 0.0]}},
            {"region": {"box": {"min": [-1.0, -1.0, 1.0], "max": [2.0, 2.0, 2.0]}}, "displacement": {"value": [0.0, 0.0, 0.01]}}],
        "output": {"plot": false}
    })
}
/// [`scene`] with pure PD's solver: `auto` (its fastest), rtol 1e-10.
fn pd_scene(name: &str, n: usize) -> Value {
    let mut s = scene(name, n);
    s["solver"] = json!({"type": "auto", "rtol": 1e-10});
    s
}

/// Cells per level of the graded variants.
const CELLS_PER_LEVEL: [usize; 3] = [2, 4, 8];
/// The coarsest cell, in spacings.
const MAX_CELL: f64 = 64.0;

/// One solve: `u` on the lattice nodes, seconds (reading, building and solving; and with the
/// solution's fields), free DOFs, the memory estimate and the notes.
struct Solved {
    u: Vec<f64>,
    seconds: f64,
    with_fields: f64,
    unknowns: usize,
    memory: f64,
    iterations: usize,
    solver: String,
    notes: Vec<String>,
}

fn solve(scene: &Value) -> Result<Solved, StudyError> {
    let check = |e: linpd_problem::ProblemError| StudyError::Check(format!("{}: {e}", scene["name"]));
    let start = Instant::now();
    let p = Problem::from_json(&scene.to_string()).map_err(check)?;
    let read = start.elapsed().as_secs_f64();
    let s = p.solve(&NoProgress).map_err(check)?;
    let with_fields = start.elapsed().as_secs_f64();
    let r = s.report;
    Ok(Solved {
        u: s.u,
        seconds: read + r.timings.assemble + r.timings.total,
        with_fields,
        unknowns: r.n,
        memory: r.memory_estimate_bytes.unwrap_or(f64::NAN),
        iterations: r.iterations.unwrap_or(0),
        solver: r.solver.to_string(),
        notes: r.notes.clone(),
    })
}

/// The graded variant of the pure-PD scene `pd` of body `name` at `n` cells per unit length:
/// `"auto"` zones and cells up to [`MAX_CELL`] on the plates; on the penny block a ball of PD
/// around the crack (its radius plus two horizons), a transition of two horizons and cells up
/// to `8h` (the auto zones of a block with held faces cover it, docs/models.md); on the
/// notched block auto zones of half a horizon (the notch keeps one) and cells up to `8h`.
fn graded(pd: &Value, name: &str, n: usize, m: usize) -> Value {
    let mut s = pd.clone();
    let h = 1.0 / n as f64;
    let model = &mut s["model"];
    if name == "penny" {
        let (d, z) = (2.0 * h, 0.5 + h / 2.0);
        model["pd_regions"] = json!([{"ball": {"center": [0.5, 0.5, z], "radius": PENNY.1 + 2.0 * d}}]);
        model["transition"] = json!(2.0 * d);
        model["local_mesh"] = json!({"max_cell": 8.0 * h, "cells_per_level": m});
    } else if name == "notched-block" {
        model["pd_regions"] = json!("auto");
        model["auto_radius"] = json!(0.5);
        model["local_mesh"] = json!({"max_cell": 8.0 * h, "cells_per_level": m});
    } else {
        model["pd_regions"] = json!("auto");
        model["local_mesh"] = json!({"max_cell": MAX_CELL * h, "cells_per_level": m});
    }
    s["solver"] = json!({"type": "auto", "rtol": 1e-10});
    s["output"]["nodes"] = json!("lattice");
    s
}

/// Runs the study into `dir`, the lattices of at most `max_nodes` nodes.
pub(crate) fn run(
    dir: &Path,
    max_nodes: Option<usize>,
    report: &mut dyn Write,
    progress: &dyn Progress,
) -> Result<(), StudyError> {
    create_dir(dir)?;
    let check = |e: linpd_problem::ProblemError| StudyError::Check(e.to_string());
    // (body, n, lattice nodes) of the lattices within max_nodes
    let mut sizes = Vec::new();
    for name in BODIES {
        for &n in sizes_of(name) {
            let nodes = Problem::from_json(&pd_scene(name, n).to_string()).map_err(check)?.nodes().len();
            if max_nodes.is_none_or(|m| nodes <= m) {
                sizes.push((name, n, nodes));
            }
        }
    }
    if sizes.is_empty() {
        return Err(StudyError::Check(format!("--max-nodes {} leaves no lattice to solve", max_nodes.unwrap_or(0))));
    }
    let cases = Cases::new(progress, "multires", sizes.len() * (1 + CELLS_PER_LEVEL.len()));
    writeln!(
        report,
        "{:<11} {:>5} {:>8} {:<12} {:>9} {:>6} {:>8} {:>7} {:>6} {:>8} {:>4}",
        "body", "n", "nodes", "model", "unknowns", "x PD", "error", "seconds", "x PD", "est. MiB", "its"
    )?;
    let mut rows = Vec::new();
    let (mut err_unknowns, mut err_time) = (Vec::new(), Vec::new());
    for &(name, n, nodes) in &sizes {
        let pd_scene = pd_scene(name, n);
        cases.next(format_args!("{name}, n = {n}, pure PD"));
        let pd = solve(&pd_scene)?;
        let umax = pd.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let line = |r: &mut dyn Write, model: &str, s: &Solved, err: Option<f64>| -> std::io::Result<()> {
            writeln!(
                r,
                "{name:<11} {n:>5} {nodes:>8} {model:<12} {:>9} {:>6.3} {:>8} {:>7.2} {:>6.3} {:>8.0} {:>4}",
                s.unknowns,
                s.unknowns as f64 / pd.unknowns as f64,
                err.map_or("-".to_string(), |e| format!("{e:.2e}")),
                s.seconds,
                s.seconds / pd.seconds,
                s.memory / (1u64 << 20) as f64,
                s.iterations
            )
        };
        line(report, "pure PD", &pd, None)?;
        rows.push(json!({"body": name, "n": n, "nodes": nodes, "model": "pd", "solver": pd.solver,
            "unknowns": pd.unknowns, "seconds": pd.seconds, "seconds_with_fields": pd.with_fields,
            "memory_estimate_bytes": pd.memory,
            "iterations": pd.iterations}));
        let (mut xs, mut ys, mut ts) = (Vec::new(), Vec::new(), Vec::new());
        for m in CELLS_PER_LEVEL {
            cases.next(format_args!("{name}, n = {n}, graded, m = {m}"));
            let g = solve(&graded(&pd_scene, name, n, m))?;
            if g.u.len() != pd.u.len() {
                return Err(StudyError::Check(format!(
                    "{name}, n = {n}: {} values against pure PD's {}",
                    g.u.len(),
                    pd.u.len()
                )));
            }
            let err = g.u.iter().zip(&pd.u).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
            line(report, &format!("graded m={m}"), &g, Some(err))?;
            let (ru, rt) = (g.unknowns as f64 / pd.unknowns as f64, g.seconds / pd.seconds);
            rows.push(json!({"body": name, "n": n, "nodes": nodes, "model": "graded", "cells_per_level": m,
                "max_cell": MAX_CELL, "solver": g.solver, "unknowns": g.unknowns, "unknowns_ratio": ru,
                "max_error": err, "seconds": g.seconds, "seconds_with_fields": g.with_fields, "time_ratio": rt, "memory_estimate_bytes": g.memory,
                "memory_ratio": g.memory / pd.memory, "iterations": g.iterations, "notes": g.notes}));
            xs.push(ru);
            ys.push(err);
            ts.push(rt);
        }
        let label = format!("{name}, {nodes} nodes, m = 2, 4, 8");
        err_unknowns.push(Series {
            label: label.clone(),
            x: xs,
            y: ys.clone(),
            style: SeriesStyle::LineMarkers,
            color: None,
        });
        err_time.push(Series { label, x: ts, y: ys, style: SeriesStyle::LineMarkers, color: None });
    }
    write(dir, &json!({"study": "multires", "max_cell_spacings": MAX_CELL, "rows": rows}))?;
    plot(
        dir,
        "error_vs_unknowns",
        "Graded local mesh vs pure PD",
        "unknowns / pure PD's",
        "max |u - u_PD| / max |u_PD|",
        err_unknowns,
        true,
    )?;
    plot(
        dir,
        "error_vs_time",
        "Graded local mesh vs pure PD",
        "time / pure PD's (same run)",
        "max |u - u_PD| / max |u_PD|",
        err_time,
        true,
    )
}
