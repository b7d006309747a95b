//! `linpd study meshes`: bodies from Gmsh meshes against a converged finite-element solution
//! of the same geometry (issue #33, item 4).
//!
//! * **Bodies** (the bundled `data/plate-hole-mesh-2d.json` and `data/bracket-mesh-3d.json`):
//!   - `plate`: the 1 x 0.5 plate with a hole of radius 0.1, plane stress, bond-based
//!     (`E = 1`, so `nu = 1/3`); the elements on `x = 0` held in `x`, one node near
//!     `(0, 0.25)` in `y`, a resultant `(0.5, 0)` spread by volume over the elements on
//!     `x = 1` (the set `right`). Triangles of size `s` = 0.02, 0.01, 0.005, 0.0025 (2.8k to
//!     174k nodes).
//!   - `bracket`: the L-bracket (a 0.1 x 0.3 x 0.1 leg on `y = 0`, a 0.4 x 0.1 x 0.1 arm along
//!     `x` at its top), 3D bond-based (`E = 1`, `nu = 1/4`); the elements on `y = 0` held (the
//!     set `clamp`), a resultant `(0, -1e-4, 0)` over the elements on `x = 0.4` (`load`).
//!     Tetrahedra of size `s` = 0.02, 0.014, 0.0095, 0.007 (4k, 11k, 35k and 84k nodes).
//!
//!   Meshes by `examples/make_meshes.py` (gmsh), a PD node per element (centroid, volume),
//!   the ball quadrature, inverse-distance micromodulus with the continuum normalization,
//!   `delta = 2 s`; each with the `energy` surface correction and without any.
//! * **Reference**: `examples/fe_reference.py`, quadratic elements (scikit-fem) on a fresh gmsh
//!   mesh of the same geometry (the true circle, as an inscribed polygon), the supports as
//!   faces (`x = 0`, `y = 0`) and the loads as uniform tractions on them, evaluated at every
//!   PD node. Plate: size 0.005 (its edge's mean `u_x` converges as `h^2`, the polygon's rate:
//!   0.009 % from the extrapolated limit). Bracket: size 0.01 graded to 0.00025 at the
//!   re-entrant edge and the clamped face's edges (the singular edges: uniform meshes converge
//!   as `h^1.1` there and stay 0.3 % off at 570k DOFs), 573k DOFs, CG with smoothed-aggregation
//!   AMG (pyamg, the rigid-body modes as near-null space): the loaded face's mean `u_y` within
//!   about 0.03 % of the extrapolated -0.5025. With `--max-nodes` (a partial run) the cheaper
//!   references of the constants below (0.1 %, 0.15 %).
//! * **Measures**: `tip` is the mean of the loaded set's `u_x` (plate) or `u_y` (bracket)
//!   against the FE field's mean at the same nodes (relative difference); `max` is
//!   `max_i |u_i - u_FE(x_i)| / max_i |u_FE(x_i)|` over every node; `share` is the part of
//!   the support's reaction that statics does not fix: the held edge's x-reaction on
//!   `y > 0.375` (plate) and the clamp's y-reaction on `x > 0.05` (bracket: the couple that
//!   holds the arm's moment, 5.65 times the total), over the total, against the FE's
//!   consistent nodal reactions' (the totals equal the loads in both).
//!
//! Needs Python with gmsh, meshio, scikit-fem and pyamg (`linpd study meshes --python PY`;
//! the test script installs them). `--max-nodes N` skips the meshes of more than `N` elements
//! (estimated from the size).

use crate::out::{create_dir, write, write_text, Cases};
use crate::StudyError;
use linpd_core::progress::{NoProgress, Progress};
use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
use linpd_problem::Problem;
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One body of the study.
struct Body {
    name: &'static str,
    dim: usize,
    /// Element sizes of the PD meshes, coarse to fine.
    sizes: &'static [f64],
    /// Elements of a mesh of size `s`: about `elements_at_unit_size / s^dim` (for
    /// `--max-nodes`; measured on gmsh's meshes).
    elements_at_unit_size: f64,
    /// The loaded set and the displacement component its mean is taken of.
    tip: (&'static str, usize),
    /// The support's statically indeterminate reaction share: the reaction component `.1` of
    /// the held nodes with coordinate `.0` above `.2`, over the whole reaction's (as
    /// `examples/fe_reference.py` reports it).
    share: (usize, usize, f64),
    /// `examples/fe_reference.py`'s mesh arguments for the converged reference, and for the
    /// cheaper one of a partial run (`--max-nodes`).
    reference: [&'static [&'static str]; 2],
}

const BODIES: [Body; 2] = [
    Body {
        name: "plate",
        dim: 2,
        sizes: &[0.02, 0.01, 0.005, 0.0025],
        elements_at_unit_size: 1.08,
        tip: ("right", 0),
        share: (1, 0, 0.375),
        // tip converged to 0.009 % (h^2, the polygonal hole's rate); 0.1 % at 0.01
        reference: [&["--size", "0.005"], &["--size", "0.01"]],
    },
    Body {
        name: "bracket",
        dim: 3,
        sizes: &[0.02, 0.014, 0.0095, 0.007],
        elements_at_unit_size: 0.0301,
        tip: ("load", 1),
        share: (0, 1, 0.05),
        // graded towards the singular edges: tip to about 0.03 % (0.15 % for the cheaper one)
        reference: [&["--size", "0.01", "--edge-size", "0.00025"], &["--size", "0.02", "--edge-size", "0.001"]],
    },
];

/// The surface corrections compared.
const CORRECTIONS: [&str; 2] = ["energy", "none"];

/// The PD scene of `body` on the mesh `mesh` (element size `s`) with `correction`.
fn scene(body: &Body, mesh: &Path, s: f64, correction: &str) -> Value {
    let micromodulus = json!({"kernel": "inverse_distance", "young_modulus": 1.0, "normalize": "continuum"});
    let mut model = json!({"type": "bond", "horizon": 2.0 * s, "micromodulus": micromodulus,
                           "surface_correction": correction});
    let (constraints, loads) = match body.name {
        "plate" => {
            model["plane"] = json!("stress");
            (
                json!([{"region": {"set": "left"}, "displacement": {"value": [0.0, 0.0]}, "components": [0]},
                       {"region": {"ball": {"center": [0.0, 0.25], "radius": 0.6 * s}},
                        "displacement": {"value": [0.0, 0.0]}, "components": [1]}]),
                json!([{"type": "resultant", "region": {"set": "right"}, "force": [0.5, 0.0]}]),
            )
        }
        _ => (
            json!([{"region": {"set": "clamp"}, "displacement": {"value": [0.0, 0.0, 0.0]}}]),
            json!([{"type": "resultant", "region": {"set": "load"}, "force": [0.0, -1e-4, 0.0]}]),
        ),
    };
    json!({"name": format!("{}-{s}-{correction}", body.name), "dimension": body.dim,
           "nodes": {"mesh": mesh.to_str()}, "model": model, "constraints": constraints, "loads": loads,
           "solver": {"type": "auto", "rtol": 1e-10}, "output": {"plot": false}})
}

/// One PD solve: its nodes, displacements, loaded set and cost.
struct Solved {
    size: f64,
    correction: &'static str,
    x: Vec<[f64; 3]>,
    u: Vec<f64>,
    tip_set: Vec<u32>,
    /// [`Body::share`] of the solve's nodal reactions.
    share: f64,
    unknowns: usize,
    seconds: f64,
}

/// A scratch directory under the system's temporary one, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Self, StudyError> {
        let path = std::env::temp_dir().join(format!("linpd-study-meshes-{}", std::process::id()));
        create_dir(&path)?;
        Ok(Scratch(path))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The repository's `examples/` (the scripts the study runs).
fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Runs `python script args`, its failure an error naming the command.
fn python(python: &str, script: &str, args: &[&str]) -> Result<String, StudyError> {
    let script = examples().join(script);
    let shown = format!("{python} {} {}", script.display(), args.join(" "));
    let out = std::process::Command::new(python)
        .arg(&script)
        .args(args)
        .output()
        .map_err(|e| StudyError::Check(format!("{shown}: {e}")))?;
    if !out.status.success() {
        return Err(StudyError::Check(format!(
            "{shown} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Solves `body` at size `s` with `correction` on the mesh `mesh`.
fn solve(body: &Body, mesh: &Path, s: f64, correction: &'static str) -> Result<Solved, StudyError> {
    let v = scene(body, mesh, s, correction);
    let check = |e: linpd_problem::ProblemError| StudyError::Check(format!("{}: {e}", v["name"]));
    let start = Instant::now();
    let p = Problem::from_json_in(&v.to_string(), Path::new(".")).map_err(check)?;
    let sol = p.solve(&NoProgress).map_err(check)?;
    let seconds = start.elapsed().as_secs_f64();
    let tip_set = p
        .nodes()
        .set(body.tip.0)
        .ok_or_else(|| StudyError::Check(format!("{}: no set {:?}", v["name"], body.tip.0)))?
        .to_vec();
    let (axis, c, cut) = body.share;
    let reaction = sol.balance.as_ref().map(|b| b.nodal_reaction.as_slice()).unwrap_or_default();
    let part = |weight: &dyn Fn(f64) -> f64| -> f64 {
        sol.x.iter().enumerate().map(|(i, x)| weight(x[axis]) * reaction.get(body.dim * i + c).unwrap_or(&0.0)).sum()
    };
    let above = |x: f64| if (x - cut).abs() <= 1e-12 { 0.5 } else { f64::from(u8::from(x > cut)) };
    let share = part(&above) / part(&|_| 1.0);
    Ok(Solved { size: s, correction, x: sol.x, u: sol.u, tip_set, share, unknowns: sol.report.n, seconds })
}

/// The FE displacements at one mesh's PD nodes, keyed by its size's bits.
type FeAtNodes = (u64, Vec<f64>);

/// The FE reference of `body` at every PD node of `solved` (their meshes share nothing, the
/// corrections share nodes: the first correction's nodes are sent), one FE solve: the
/// script's JSON line and per solved size its nodes' FE displacements.
fn reference(
    body: &Body,
    solved: &[Solved],
    work: &Path,
    python_exe: &str,
    partial: bool,
) -> Result<(Value, Vec<FeAtNodes>), StudyError> {
    let d = body.dim;
    let firsts: Vec<&Solved> = solved.iter().filter(|sv| sv.correction == CORRECTIONS[0]).collect();
    let mut points = ["x", "y", "z"][..d].join(",");
    points.push('\n');
    for x in firsts.iter().flat_map(|sv| &sv.x) {
        let row: Vec<String> = x[..d].iter().map(|c| format!("{c:.17e}")).collect();
        points.push_str(&row.join(","));
        points.push('\n');
    }
    let (points_path, fe_path) =
        (work.join(format!("{}-points.csv", body.name)), work.join(format!("{}-fe.csv", body.name)));
    write_text(&points_path, &points)?;
    let path = |p: &Path| p.to_str().unwrap_or_default().to_string();
    let mut args = vec![body.name.to_string()];
    args.extend(body.reference[usize::from(partial)].iter().map(ToString::to_string));
    args.extend(["--points".to_string(), path(&points_path), "--out".to_string(), path(&fe_path)]);
    let line = python(python_exe, "fe_reference.py", &args.iter().map(String::as_str).collect::<Vec<_>>())?;
    let info: Value = line
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok())
        .ok_or_else(|| StudyError::Check(format!("fe_reference.py printed no JSON line: {line:?}")))?;
    let text =
        std::fs::read_to_string(&fe_path).map_err(|source| StudyError::File { path: fe_path.clone(), source })?;
    let fe: Vec<f64> = text
        .lines()
        .skip(1)
        .flat_map(|l| l.split(',').map(|t| t.trim().parse::<f64>().unwrap_or(f64::NAN)).collect::<Vec<_>>())
        .collect();
    let expected: usize = firsts.iter().map(|sv| sv.x.len() * d).sum();
    if fe.len() != expected || fe.iter().any(|v| !v.is_finite()) {
        return Err(StudyError::Check(format!(
            "{}: {expected} finite values expected, {} read (or some not finite)",
            fe_path.display(),
            fe.len()
        )));
    }
    let mut offset = 0;
    let mut per_size = Vec::new();
    for sv in firsts {
        per_size.push((sv.size.to_bits(), fe[offset..offset + sv.x.len() * d].to_vec()));
        offset += sv.x.len() * d;
    }
    Ok((info, per_size))
}

/// One row of the study: a solve against the FE field at its nodes.
struct Row {
    unknowns: f64,
    tip_error: f64,
    max_error: f64,
}

/// Compares `sv` with the FE displacements `ufe` at its nodes: a table line and a JSON row.
fn compare(
    body: &Body,
    sv: &Solved,
    ufe: &[f64],
    share_fe: f64,
    report: &mut dyn Write,
) -> Result<(Row, Value), StudyError> {
    let (d, c) = (body.dim, body.tip.1);
    let mean = |u: &[f64]| sv.tip_set.iter().map(|&i| u[d * i as usize + c]).sum::<f64>() / sv.tip_set.len() as f64;
    let (tip, tip_fe) = (mean(&sv.u), mean(ufe));
    let norm = |v: &[f64]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
    let scale = ufe.chunks(d).map(norm).fold(0.0, f64::max);
    let diff = |(a, b): (&[f64], &[f64])| a.iter().zip(b).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    let max_error = sv.u.chunks(d).zip(ufe.chunks(d)).map(diff).fold(0.0, f64::max) / scale;
    let tip_error = tip / tip_fe - 1.0;
    writeln!(
        report,
        "{:<8} {:>7} {:<7} {:>7} {:>9} {:>8.2} {:>11.5e} {:>11.5e} {:>8.2}% {:>7.2}% {:>7.4} {:>7.4}",
        body.name,
        sv.size,
        sv.correction,
        sv.x.len(),
        sv.unknowns,
        sv.seconds,
        tip,
        tip_fe,
        100.0 * tip_error,
        100.0 * max_error,
        sv.share,
        share_fe
    )?;
    let row = json!({"body": body.name, "size": sv.size, "horizon": 2.0 * sv.size, "correction": sv.correction,
        "nodes": sv.x.len(), "unknowns": sv.unknowns, "seconds": sv.seconds, "tip": tip, "tip_fe": tip_fe,
        "tip_error": tip_error, "max_error": max_error, "reaction_share": sv.share, "reaction_share_fe": share_fe});
    Ok((Row { unknowns: sv.unknowns as f64, tip_error, max_error }, row))
}

/// The two log-log plots: `|tip error|` and the largest nodal error against unknowns, a line
/// per body and correction.
fn plots(dir: &Path, lines: &[(String, Vec<Row>)]) -> Result<(), StudyError> {
    type Pick = fn(&Row) -> f64;
    let figures: [(&str, &str, &str, Pick); 2] = [
        ("tip_error", "Meshed bodies against FE: loaded set's mean displacement", "|tip / tip_FE - 1|", |r| {
            r.tip_error.abs()
        }),
        ("max_error", "Meshed bodies against FE: largest nodal difference", "max |u - u_FE| / max |u_FE|", |r| {
            r.max_error
        }),
    ];
    for (name, title, y_label, pick) in figures {
        let series = lines
            .iter()
            .map(|(label, rows)| Series {
                label: label.clone(),
                x: rows.iter().map(|r| r.unknowns).collect(),
                y: rows.iter().map(pick).collect(),
                style: SeriesStyle::LineMarkers,
                color: None,
            })
            .collect();
        let plot = LinePlot {
            title: title.into(),
            x_label: "unknowns".into(),
            y_label: y_label.into(),
            series,
            log_x: true,
            log_y: true,
            equal_aspect: false,
        };
        line_plot(&plot, &dir.join(name))?;
    }
    Ok(())
}

/// Runs the study into `dir`: the meshes of at most `max_nodes` elements, Python `python`.
pub(crate) fn run(
    dir: &Path,
    max_nodes: Option<usize>,
    python_exe: &str,
    report: &mut dyn Write,
    progress: &dyn Progress,
) -> Result<(), StudyError> {
    create_dir(dir)?;
    // meshes, points and FE values (tens of MB) stay out of the study's directory
    let work = Scratch::new()?;
    let work = work.0.as_path();
    let sizes = |b: &Body| -> Vec<f64> {
        let fits = |s: f64| max_nodes.is_none_or(|m| b.elements_at_unit_size / s.powi(b.dim as i32) <= m as f64);
        b.sizes.iter().copied().filter(|&s| fits(s)).collect()
    };
    let total: usize = BODIES.iter().map(|b| sizes(b).len() * CORRECTIONS.len() + 1).sum();
    if BODIES.iter().all(|b| sizes(b).is_empty()) {
        return Err(StudyError::Check(format!("--max-nodes {} leaves no mesh to solve", max_nodes.unwrap_or(0))));
    }
    let cases = Cases::new(progress, "meshes", total);
    let (mut rows, mut lines) = (Vec::new(), Vec::new());
    writeln!(
        report,
        "{:<8} {:>7} {:<7} {:>7} {:>9} {:>8} {:>11} {:>11} {:>9} {:>8} {:>7} {:>7}",
        "body",
        "size",
        "corr.",
        "nodes",
        "unknowns",
        "seconds",
        "tip",
        "tip (FE)",
        "tip err",
        "max err",
        "share",
        "(FE)"
    )?;
    for body in BODIES.iter().filter(|b| !sizes(b).is_empty()) {
        let mut solved = Vec::new();
        for s in sizes(body) {
            let mesh = work.join(format!("{}-{s}.msh", body.name));
            python(python_exe, "make_meshes.py", &[body.name, &s.to_string(), mesh.to_str().unwrap_or_default()])?;
            for correction in CORRECTIONS {
                cases.next(format_args!("{} at size {s}, correction {correction}", body.name));
                solved.push(solve(body, &mesh, s, correction)?);
            }
        }
        cases.next(format_args!("{}: the finite-element reference", body.name));
        let (info, fe) = reference(body, &solved, work, python_exe, max_nodes.is_some())?;
        for correction in CORRECTIONS {
            let mut line = Vec::new();
            for sv in solved.iter().filter(|sv| sv.correction == correction) {
                let ufe = fe.iter().find(|(bits, _)| *bits == sv.size.to_bits()).map(|(_, u)| u.as_slice());
                let share_fe = info["reaction_share"].as_f64().unwrap_or(f64::NAN);
                let (row, json_row) = compare(body, sv, ufe.unwrap_or_default(), share_fe, report)?;
                line.push(row);
                rows.push(json_row);
            }
            lines.push((format!("{}, {correction}", body.name), line));
        }
        rows.push(json!({"body": body.name, "reference": info}));
    }
    write(dir, &json!({"study": "meshes", "rows": rows}))?;
    plots(dir, &lines)
}
