//! `linpd study penny-sneddon`: the penny-shaped crack of issue #31 on the blend with a graded
//! local mesh, its opening against Sneddon's closed form.
//!
//! * **Body**: a cube of side `B = 1` (vertex lattice, `h = 1/n`), bond-based (inverse-distance
//!   micromodulus, discrete normalization to `K = 1`: `E = 3K(1 - 2 nu) = 1.5`, `nu = 1/4`),
//!   `delta = 3h`; a penny crack of radius `a = 0.1` (a planar disc cutting bonds) at the
//!   centre, normal to z, half a spacing above the middle node plane; a traction `sigma = 1`
//!   pulling each z face (`"traction"` loads); three balls of `1.5h` at face centres remove
//!   the rigid motions (their reactions vanish to the solver's tolerance: the loads balance).
//! * **Model**: PD in a flat box around the crack (the disc and two horizons: every node a
//!   cut bond's family reaches is pure PD), a transition of two horizons, cells up to `32h`,
//!   4 per level, `free_faces: "bulk"` (the faces are 4.5 radii away: their PD skin is not the
//!   question, and their level-0 bands would be most of the unknowns).
//! * **Opening**: `w = u_z(top) - u_z(bottom)` at the two lattice nodes beside the crack's
//!   centre (half a spacing from its plane).
//! * **Sneddon (1946)**: a penny crack of radius `a` in an infinite body under remote
//!   normal stress `sigma` opens to `w(r) = 8 (1 - nu^2) sigma / (pi E) sqrt(a^2 - r^2)`:
//!   `w_max = 8 (1 - nu^2) sigma a / (pi E) = 0.159155` here.
//! * **Finite size**: the same model at `n = 80` on a cube of side `2B` (same crack, same
//!   spacing) gives `r = w(B) / w(2B)`; the crack's far field is a dipole's, decaying as
//!   `(a/R)^3`, so `w(B) = w_inf (1 + c (a/B)^3)` and the cube's factor is
//!   `1 + c (a/B)^3 = 8 (r - 1) / (8 - r) + 1` (measured 1.0088, the smaller box's 0.8 % on top
//!   of Sneddon's infinite body). The table gives `w / w_Sneddon` with and without it.
//!
//! `--max-nodes N` skips the lattices of more than `N` nodes (the finite-size case has 4.2M,
//! `n = 250` 15.8M, `n = 500`, the 1/500, 125.8M).

use crate::out::{create_dir, plot, write, Cases};
use crate::StudyError;
use linpd_core::progress::{NoProgress, Progress};
use linpd_plot::{Series, SeriesStyle};
use linpd_problem::Problem;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Lattice sizes (cells per unit length) on the unit cube.
const SIZES: [usize; 6] = [40, 80, 120, 160, 250, 500];
/// The size of the finite-size case (on a cube of side 2).
const FINITE_SIZE_N: usize = 80;
/// Crack radius.
const RADIUS: f64 = 0.1;
/// `nu` and `E` of the bond model with `K = 1` (3D bond-based: `nu = 1/4`, `E = 3K(1 - 2nu)`).
const NU: f64 = 0.25;
const YOUNG: f64 = 1.5;
/// The remote traction.
const SIGMA: f64 = 1.0;

/// Sneddon's maximum opening of a penny crack of radius `a` in an infinite body.
pub(crate) fn sneddon_max_opening(a: f64) -> f64 {
    8.0 * (1.0 - NU * NU) * SIGMA * a / (std::f64::consts::PI * YOUNG)
}

/// The scene at `n` cells per unit length on a cube of side `side` (see the module docs).
pub(crate) fn scene(n: usize, side: f64) -> Value {
    let h = 1.0 / n as f64;
    let (d, c) = (3.0 * h, side / 2.0);
    let zc = c + h / 2.0;
    let (w, t) = (RADIUS + 2.0 * d + h, 2.0 * d + h);
    let r = 1.5 * h;
    json!({
        "name": format!("penny-{n}-side-{side}"), "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [side, side, side], "spacing": h},
        "model": {"type": "bond", "horizon": d,
            "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0},
            "material": {"defects": [{"plane": {"point": [c, c, zc], "normal": [0.0, 0.0, 1.0],
                "extent": {"ball": {"center": [c, c, zc], "radius": RADIUS}}}, "factor": 0.0}]},
            "pd_regions": [{"box": {"min": [c - w, c - w, zc - t], "max": [c + w, c + w, zc + t]}}],
            "transition": 2.0 * d,
            "local_mesh": {"max_cell": 32.0 * h, "cells_per_level": 4, "free_faces": "bulk"}},
        "constraints": [
            {"region": {"ball": {"center": [c, c, 0.0], "radius": r}}, "displacement": {"value": [0.0, 0.0, 0.0]}},
            {"region": {"ball": {"center": [c, c, side], "radius": r}}, "displacement": {"value": [0.0, 0.0, 0.0]},
             "components": [0, 1]},
            {"region": {"ball": {"center": [side, c, 0.0], "radius": r}}, "displacement": {"value": [0.0, 0.0, 0.0]},
             "components": [1]}],
        "loads": [{"type": "traction", "face": "z+", "traction": [0.0, 0.0, SIGMA]},
                  {"type": "traction", "face": "z-", "traction": [0.0, 0.0, -SIGMA]}],
        "solver": {"type": "auto", "rtol": 1e-10},
        "output": {"plot": false}
    })
}

/// One solve of [`scene`]: the opening at the crack's centre and the cost.
pub(crate) struct Opening {
    pub nodes: usize,
    pub opening: f64,
    pub unknowns: usize,
    pub seconds: f64,
    pub memory: f64,
    /// The process's peak resident memory so far (bytes; NaN where unknown).
    pub peak: f64,
    pub iterations: usize,
}

/// Solves the scene at `n` on a cube of side `side` and reads the opening.
pub(crate) fn opening(n: usize, side: f64) -> Result<Opening, StudyError> {
    let s = scene(n, side);
    let check = |e: linpd_problem::ProblemError| StudyError::Check(format!("{}: {e}", s["name"]));
    let start = Instant::now();
    let p = Problem::from_json(&s.to_string()).map_err(check)?;
    let sol = p.solve(&NoProgress).map_err(check)?;
    let seconds = start.elapsed().as_secs_f64();
    let grid = p.nodes().lattice().ok_or_else(|| StudyError::Check("the penny scene is a lattice".into()))?;
    let (h, c) = (grid.spacing(), side / 2.0);
    // the output's nodes (the mesh's) on the node planes half a spacing below and above the
    // crack's plane c + h/2: masters of the PD zone
    let at =
        |z: f64| sol.x.iter().position(|x| (x[0] - c).abs().max((x[1] - c).abs()).max((x[2] - z).abs()) <= 1e-9 * h);
    let (Some(below), Some(above)) = (at(c), at(c + h)) else {
        return Err(StudyError::Check(format!("{}: no model nodes beside the crack's centre", s["name"])));
    };
    let r = sol.report;
    Ok(Opening {
        nodes: grid.len(),
        opening: sol.u[3 * above + 2] - sol.u[3 * below + 2],
        unknowns: r.n,
        seconds,
        memory: r.memory_estimate_bytes.unwrap_or(f64::NAN),
        peak: r.peak_rss_bytes.map_or(f64::NAN, |b| b as f64),
        iterations: r.iterations.unwrap_or(0),
    })
}

/// The nodes of the lattice at `n` on a cube of side `side`.
fn nodes(n: usize, side: f64) -> usize {
    ((side * n as f64).round() as usize + 1).pow(3)
}

/// Runs the study into `dir`, the lattices of at most `max_nodes` nodes.
pub(crate) fn run(
    dir: &Path,
    max_nodes: Option<usize>,
    report: &mut dyn Write,
    progress: &dyn Progress,
) -> Result<(), StudyError> {
    create_dir(dir)?;
    let fits = |n: usize, side: f64| max_nodes.is_none_or(|m| nodes(n, side) <= m);
    let sizes: Vec<usize> = SIZES.into_iter().filter(|&n| fits(n, 1.0)).collect();
    if sizes.is_empty() {
        return Err(StudyError::Check(format!("--max-nodes {} leaves no lattice to solve", max_nodes.unwrap_or(0))));
    }
    let finite = fits(FINITE_SIZE_N, 2.0) && sizes.contains(&FINITE_SIZE_N);
    let cases = Cases::new(progress, "penny-sneddon", sizes.len() + usize::from(finite));
    let w_s = sneddon_max_opening(RADIUS);
    let mut solved = Vec::new();
    for &n in &sizes {
        cases.next(format_args!("n = {n}"));
        solved.push((n, opening(n, 1.0)?));
    }
    // the cube's finite-size factor 1 + c (a/B)^3 from the doubled cube (see the module docs)
    let factor = if finite {
        cases.next(format_args!("n = {FINITE_SIZE_N}, a cube of side 2"));
        let big = opening(FINITE_SIZE_N, 2.0)?;
        let small = solved.iter().find(|(n, _)| *n == FINITE_SIZE_N).map(|(_, o)| o.opening).unwrap_or(f64::NAN);
        let r = small / big.opening;
        writeln!(
            report,
            "finite size: w = {small:.6} on the unit cube, {:.6} on the cube of side 2 (n = {FINITE_SIZE_N}, {} \
             nodes, {:.1} s): factor 1 + c (a/B)^3 = {:.4}",
            big.opening,
            big.nodes,
            big.seconds,
            1.0 + 8.0 * (r - 1.0) / (8.0 - r)
        )?;
        Some(1.0 + 8.0 * (r - 1.0) / (8.0 - r))
    } else {
        None
    };
    writeln!(report, "Sneddon: w_max = 8 (1 - nu^2) sigma a / (pi E) = {w_s:.6}")?;
    writeln!(
        report,
        "{:>5} {:>10} {:>7} {:>9} {:>10} {:>8} {:>10} {:>8} {:>9} {:>9} {:>4}",
        "n", "nodes", "delta/a", "unknowns", "w", "w/w_S", "w/(F w_S)", "seconds", "est. MiB", "peak MiB", "its"
    )?;
    let mut rows = Vec::new();
    let (mut xs, mut raw, mut corrected) = (Vec::new(), Vec::new(), Vec::new());
    for (n, o) in &solved {
        let delta_over_a = 3.0 / (*n as f64 * RADIUS);
        let ratio = o.opening / w_s;
        let ratio_f = factor.map(|f| ratio / f);
        writeln!(
            report,
            "{n:>5} {:>10} {delta_over_a:>7.4} {:>9} {:>10.6} {ratio:>8.4} {:>10} {:>8.2} {:>9.0} {:>9.0} {:>4}",
            o.nodes,
            o.unknowns,
            o.opening,
            ratio_f.map_or("-".to_string(), |r| format!("{r:.4}")),
            o.seconds,
            o.memory / (1u64 << 20) as f64,
            o.peak / (1u64 << 20) as f64,
            o.iterations
        )?;
        rows.push(json!({"n": n, "nodes": o.nodes, "delta_over_a": delta_over_a, "unknowns": o.unknowns,
            "opening": o.opening, "ratio_to_sneddon": ratio, "ratio_to_sneddon_finite_size": ratio_f,
            "seconds": o.seconds, "memory_estimate_bytes": o.memory, "peak_rss_bytes": o.peak,
            "iterations": o.iterations}));
        xs.push(delta_over_a);
        raw.push(ratio);
        corrected.extend(ratio_f);
    }
    write(
        dir,
        &json!({"study": "penny-sneddon", "radius": RADIUS, "sigma": SIGMA, "young": YOUNG, "nu": NU,
            "sneddon_max_opening": w_s, "finite_size_factor": factor, "rows": rows}),
    )?;
    let mut series = vec![Series {
        label: "w / w_Sneddon (unit cube)".into(),
        x: xs.clone(),
        y: raw,
        style: SeriesStyle::LineMarkers,
        color: None,
    }];
    if corrected.len() == xs.len() {
        series.push(Series {
            label: "w / (F w_Sneddon), F the cube's finite-size factor".into(),
            x: xs,
            y: corrected,
            style: SeriesStyle::LineMarkers,
            color: None,
        });
    }
    plot(dir, "opening", "Penny crack: maximum opening against Sneddon", "delta / a", "w / w_Sneddon", series, false)
}
