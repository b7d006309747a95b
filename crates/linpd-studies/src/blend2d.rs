//! `linpd study blend-2d`: the 2D/3D blended PD / local-elasticity model
//! ([`linpd_blend::lattice`], scenes with `model.pd_regions`) against the pure bond model on the
//! same lattice: error, stored entries and time against the auto-zone radius and the
//! transition profile.
//!
//! * **Edge-cracked plate**: unit square, plane strain, `delta = 3h`, a pre-crack from the left
//!   face to `x = 0.4` at `y = 0.5 + h/4`, the bottom layer held, the top layer pulled by 0.01.
//! * **Plate with a hole**: `1 x 0.5`, plane stress, `delta = 3h`, a hole of radius 0.1 at the
//!   centre, the left layer held in x (and one node row in y), a resultant 0.5 pulling the right
//!   layer (`data/plate-hole-2d.json`).
//! * **Notched block (3D)**: unit cube, `40^3` nodes, `delta = 3h`, a pre-crack plane
//!   `z = 0.5 + h/2` for `x <= 0.3`, bottom layer held, top layer pulled by 0.01.
//!
//! Every case is solved twice in the same run: pure PD by CG + multigrid, the blend by GMRES +
//! multigrid (built from the symmetric part), both to rtol 1e-10; where the symmetric part is
//! indefinite (the AMG setup refuses it: steep constant profiles) the blend runs `auto` and the
//! table shows `auto` instead of its iterations. Error: `max |u_blend - u_PD| /
//! max |u_PD|` and the l2 ratio over all nodes; cost: the blend's stored entries of `A` over all
//! DOFs and its whole solve time (building the blended model included) over the bond model's.

use crate::out::{create_dir, plot, write, Cases};
use crate::StudyError;
use linpd_core::progress::{NoProgress, Progress};
use linpd_plot::{Series, SeriesStyle};
use linpd_problem::Problem;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// The three bodies' scenes at spacing `h` (`n` nodes per unit length), pure PD.
pub(crate) fn body(name: &str, n: usize) -> Value {
    let h = 1.0 / n as f64;
    let d = 3.0 * h;
    let mm = json!({"kernel": "inverse_distance", "modulus": 1.0, "normalize": "continuum"});
    let pd_solver = json!({"type": "cg", "preconditioner": "multigrid", "rtol": 1e-10});
    match name {
        "edge-crack" => json!({
            "name": format!("edge-crack-{n}"), "dimension": 2,
            "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": h, "layer": {"y-": d, "y+": d}},
            "model": {"type": "bond", "horizon": d, "plane": "strain", "micromodulus": mm,
                      "material": {"defects": [{"segment": [[-1.0, 0.5 + h / 4.0], [0.4, 0.5 + h / 4.0]], "factor": 0.0}]}},
            "constraints": [
                {"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}},
                {"region": {"box": {"min": [-1.0, 1.0], "max": [2.0, 2.0]}}, "displacement": {"value": [0.0, 0.01]}}],
            "solver": pd_solver, "output": {"plot": false}
        }),
        "hole" => json!({
            "name": format!("hole-{n}"), "dimension": 2,
            "grid": {"min": [0.0, 0.0], "max": [1.0, 0.5], "spacing": h, "layer": {"x-": d, "x+": d}},
            "body": {"difference": ["all", {"ball": {"center": [0.5, 0.25], "radius": 0.1}}]},
            "model": {"type": "bond", "horizon": d, "plane": "stress", "micromodulus": mm},
            "constraints": [
                {"region": {"box": {"min": [-1.0, -1.0], "max": [0.0, 2.0]}}, "displacement": {"value": [0.0, 0.0]}, "components": [0]},
                {"region": {"box": {"min": [-1.0, 0.25 - h / 2.0], "max": [0.0, 0.25 + h / 2.0]}}, "displacement": {"value": [0.0, 0.0]}, "components": [1]}],
            "loads": [{"type": "resultant", "region": {"box": {"min": [1.0, -1.0], "max": [2.0, 2.0]}}, "force": [0.5, 0.0]}],
            "solver": pd_solver, "output": {"plot": false}
        }),
        _ => json!({
            "name": format!("notched-block-{n}"), "dimension": 3,
            "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": h, "layer": {"z-": d, "z+": d}},
            "model": {"type": "bond", "horizon": d, "micromodulus": mm,
                      "material": {"defects": [{"plane": {"point": [0.0, 0.0, 0.5 + h / 2.0], "normal": [0.0, 0.0, 1.0],
                          "extent": {"box": {"min": [-1.0, -1.0, 0.0], "max": [0.3, 2.0, 1.0]}}}, "factor": 0.0}]}},
            "constraints": [
                {"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0, 0.0]}},
                {"region": {"box": {"min": [-1.0, -1.0, 1.0], "max": [2.0, 2.0, 2.0]}}, "displacement": {"value": [0.0, 0.0, 0.01]}}],
            "solver": pd_solver, "output": {"plot": false}
        }),
    }
}

/// The blended variant of a PD scene: auto zones of radius `k` horizons, a transition of one
/// horizon with `profile`.
fn blended(pd: &Value, k: f64, profile: &str) -> Value {
    let mut s = pd.clone();
    let m = s["model"].as_object_mut().expect("model object");
    m.insert("pd_regions".into(), json!("auto"));
    m.insert("auto_radius".into(), json!(k));
    m.insert("transition_profile".into(), json!(profile));
    s["solver"] = json!({"type": "gmres", "preconditioner": "multigrid", "rtol": 1e-10});
    s
}

/// A solve's displacements, seconds, stored entries and iterations.
struct Solved {
    u: Vec<f64>,
    seconds: f64,
    nnz: usize,
    iterations: usize,
    nodes: usize,
    zones: Option<linpd_blend::Zones>,
}

fn solve(scene: &Value, progress: &dyn Progress) -> Result<Solved, StudyError> {
    let check = |e: linpd_problem::ProblemError| StudyError::Check(format!("{}: {e}", scene["name"]));
    let start = Instant::now();
    let p = Problem::from_json(&scene.to_string()).map_err(check)?;
    let s = p.solve(progress).map_err(check)?;
    let seconds = start.elapsed().as_secs_f64();
    let zones =
        if scene["model"].get("pd_regions").is_some() { Some(p.lattice_blend().map_err(check)?.zones()) } else { None };
    let d = s.dim;
    let nnz = match zones {
        Some(z) => z.nnz,
        None => d * d * (s.x.len() + s.n_bonds),
    };
    Ok(Solved { u: s.u, seconds, nnz, iterations: s.report.iterations.unwrap_or(0), nodes: s.x.len(), zones })
}

/// Runs the study into `dir`.
pub(crate) fn run(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    create_dir(dir)?;
    // (body, sizes, radii with a linear transition, other profiles at radius 2)
    type Body<'a> = (&'a str, &'a [usize], &'a [f64], &'a [&'a str]);
    let bodies: [Body; 3] = [
        ("edge-crack", &[100, 200, 300], &[0.5, 1.0, 2.0, 3.0], &["cubic", "constant"]),
        ("hole", &[100, 200, 300], &[0.5, 1.0, 2.0, 3.0], &["cubic", "constant"]),
        // 3D: a 40^3 lattice (79k nodes with the layers); at radius 2 the zones of the two
        // supports and the crack (radius + transition = 9 lattice steps each side) cover it
        ("notched-block", &[40], &[1.0], &[]),
    ];
    let n_cases: usize = bodies.iter().map(|(_, ns, r, p)| ns.len() * (1 + r.len() + p.len())).sum();
    let cases = Cases::new(progress, "blend-2d", n_cases);
    writeln!(
        report,
        "{:<14} {:>7} {:>6} {:<9} {:>9} {:>9} {:>7} {:>7} {:>6} {:>6} {:>18}",
        "body", "nodes", "radius", "profile", "max err", "l2 err", "nnz x", "time x", "its", "PD its", "PD/trans/local"
    )?;
    let mut rows = Vec::new();
    let mut cost_series = Vec::new();
    for (name, sizes, radii, profiles) in bodies {
        for &n in sizes {
            let pd_scene = body(name, n);
            cases.next(format_args!("{name}, n = {n}, pure PD"));
            let pd = solve(&pd_scene, &NoProgress)?;
            let umax = pd.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let unorm = pd.u.iter().map(|v| v * v).sum::<f64>().sqrt();
            let mut variants: Vec<(f64, &str)> = radii.iter().map(|&k| (k, "linear")).collect();
            variants.extend(profiles.iter().map(|&p| (2.0, p)));
            let (mut xs, mut ys) = (Vec::new(), Vec::new());
            for (k, profile) in variants {
                cases.next(format_args!("{name}, n = {n}, radius {k}, {profile}"));
                // GMRES + multigrid from the symmetric part; where that part is indefinite
                // (steep constant profiles) the AMG setup refuses it, and `auto` runs instead
                // (Cholesky of the symmetric part + GMRES, else LU)
                let scene = blended(&pd_scene, k, profile);
                let (b, solver) = match solve(&scene, &NoProgress) {
                    Ok(b) => (b, "gmres-multigrid"),
                    Err(_) => {
                        let mut scene = scene;
                        scene["solver"] = json!({"type": "auto"});
                        (solve(&scene, &NoProgress)?, "auto")
                    }
                };
                let max_err = b.u.iter().zip(&pd.u).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / umax;
                let l2_err = b.u.iter().zip(&pd.u).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt() / unorm;
                let nnz_ratio = b.nnz as f64 / pd.nnz as f64;
                let time_ratio = b.seconds / pd.seconds;
                let z = b.zones.expect("blended");
                writeln!(
                    report,
                    "{name:<14} {:>7} {k:>6.1} {profile:<9} {max_err:>9.2e} {l2_err:>9.2e} {nnz_ratio:>7.3} {time_ratio:>7.2} {:>6} {:>6} {:>18}",
                    pd.nodes,
                    if solver == "auto" { "auto".to_string() } else { b.iterations.to_string() },
                    pd.iterations,
                    format!("{}/{}/{}", z.pd, z.transition, z.local)
                )?;
                rows.push(json!({"body": name, "n": n, "nodes": pd.nodes, "auto_radius": k, "profile": profile,
                    "max_error": max_err, "l2_error": l2_err, "nnz_ratio": nnz_ratio, "time_ratio": time_ratio,
                    "blend_seconds": b.seconds, "pd_seconds": pd.seconds, "blend_iterations": b.iterations, "blend_solver": solver,
                    "pd_iterations": pd.iterations, "zones": {"pd": z.pd, "transition": z.transition, "local": z.local}}));
                if profile == "linear" {
                    xs.push(nnz_ratio);
                    ys.push(max_err);
                }
            }
            cost_series.push(Series {
                label: format!("{name}, {} nodes", pd.nodes),
                x: xs,
                y: ys,
                style: SeriesStyle::LineMarkers,
                color: None,
            });
        }
    }
    write(dir, &json!({"study": "blend-2d", "rows": rows}))?;
    plot(
        dir,
        "error_vs_entries",
        "Blend vs pure PD: auto zones, radius 0.5..3 horizons",
        "stored entries / pure PD's",
        "max |u_blend - u_PD| / max |u_PD|",
        cost_series,
        true,
    )
}
