//! `linpd bench --statics`: whole static solves of scenes (assembly + solver setup + solve), one
//! row per case and solver, the cases of the scalable-solver issue:
//!
//! * `3d-cantilever-N` (N = 20, 30, 40, 50, 70, 100, 150 nodes per side; 150 is 10.6M
//!   unknowns, about 12 GiB): the unit cube, `delta = 3h`,
//!   bond-based, clamped through a `delta`-thick layer at `x <= 0`, a body-force density `-z` on
//!   the nodes of `x >= 1` (the layer beyond the far face);
//! * `3d-cracked-N` and `3d-two-phase-N` (N = 70; 10 with `--quick`): the same cantilever with
//!   a crack (a plane defect normal to x at mid-span through the upper half, bonds cut) or a
//!   ball inclusion of radius 0.3 at the centre with 10^4 times the modulus (harmonic bond
//!   rule): the heterogeneous and cracked lattices of issue #35, matrix-free on the stencil
//!   with their cut and interface bonds as corrections (`linpd_bond::CorrectedStencil`);
//! * `3d-lps-N` (N = 70; 10 with `--quick`): the same cantilever of an LPS solid (Poisson
//!   ratio 0.3: `K = 13/6`, `G = 1`), matrix-free on the stencils of `linpd_lps::stencil` with
//!   the multigrid of its pair part, with a product row (per bond, tangent stencil, pair
//!   stencil); `2d-lps-401-m3` (41 with `--quick`): the 401^2 plate of an LPS solid, plane
//!   stress, `delta = 3h`;
//! * `2d-plate-N-m2` (N = 101, 201, 401, 801): the unit square, `delta = 2h`, plane stress,
//!   clamped through the layer at `x <= 0`, body load `-y` on `x >= 1` (the setting of
//!   PeriLab's published timing table at N = 401: 160,801 points, m = 2).
//!
//! Solvers per case: Jacobi-PCG (matrix-free with the lattice stencil from 10^6 unknowns, where
//! the assembled matrix would not fit), multigrid-PCG where offered, sparse Cholesky where its
//! factor fits (2D all sizes; 3D up to `--direct-max-3d` unknowns), and `auto`. Every run
//! reports iterations, the relative residual and the setup / solve split; times are ratios
//! against Jacobi-PCG measured in the same run.
//!
//! With `--peers`, every case that fits assembled also writes its reduced system `A_ff`,
//! `f_f` and the rigid-body modes of its free DOFs (the near-null space linpd's multigrid
//! uses) beside the other exported cases, and the Python driver runs pyamg's smoothed
//! aggregation (+ CG) on them: the `pyamg` rows of the table, same machine, same run.

use linpd_core::{Model, ModelOperator};
use linpd_problem::Problem;
use linpd_solve::{rigid_body_modes, CgParams, DofGeometry, PreconditionerKind, SolverSpec};
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Unknowns above which Jacobi-PCG runs matrix-free (assembled `A` ~ 1100 entries per 3D row).
const MATRIX_FREE_FROM: usize = 600_000;

/// What a case adds to the homogeneous cantilever (3D only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Variant {
    Homogeneous,
    Cracked,
    TwoPhase,
    Lps,
}

/// The scene of a case: `dim` 2 or 3, `nodes` per side of the unit body, horizon `m h`.
fn scene(name: &str, dim: usize, nodes: usize, m: usize, variant: Variant) -> Problem {
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
    // the crack's plane lies half a spacing off the node planes, so it cuts bonds, not nodes
    let x_crack = ((0.5 / h).floor() + 0.5) * h;
    match variant {
        Variant::Homogeneous => {}
        Variant::Cracked => {
            model["material"] = json!({"defects": [{"plane": {"point": [x_crack, 0.0, 0.0], "normal": [1.0, 0.0, 0.0],
                "extent": {"box": {"min": [-1.0, -1.0, 0.5], "max": [2.0, 2.0, 2.0]}}}, "factor": 0.0}]});
        }
        Variant::Lps => {
            model = json!({"type": "lps", "horizon": delta, "bulk_modulus": 13.0 / 6.0, "shear_modulus": 1.0});
            if dim == 2 {
                model["plane"] = json!("stress");
            }
        }
        Variant::TwoPhase => {
            model["material"] = json!({"phases": [{"region": {"ball": {"center": [0.5, 0.5, 0.5], "radius": 0.3}},
                "modulus": 1e4}], "bond_rule": "harmonic"});
        }
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

/// `(name, dim, nodes per side, m, variant)`.
fn cases(quick: bool) -> Vec<(String, usize, usize, usize, Variant)> {
    let (cubes, plates, hetero): (&[usize], &[usize], usize) =
        if quick { (&[8, 10], &[21, 41], 10) } else { (&[20, 30, 40, 50, 70, 100, 150], &[101, 201, 401, 801], 70) };
    let mut v: Vec<_> = cubes.iter().map(|&n| (format!("3d-cantilever-{n}"), 3, n, 3, Variant::Homogeneous)).collect();
    v.push((format!("3d-cracked-{hetero}"), 3, hetero, 3, Variant::Cracked));
    v.push((format!("3d-two-phase-{hetero}"), 3, hetero, 3, Variant::TwoPhase));
    v.push((format!("3d-lps-{hetero}"), 3, hetero, 3, Variant::Lps));
    v.extend(plates.iter().map(|&n| (format!("2d-plate-{n}-m2"), 2, n, 2, Variant::Homogeneous)));
    // 401^2: its assembled tangent and Cholesky still fit beside the matrix-free rows
    let lps_plate = if quick { plates[plates.len() - 1] } else { 401 };
    v.push((format!("2d-lps-{lps_plate}-m3"), 2, lps_plate, 3, Variant::Lps));
    v
}

/// The solvers run on a case with `n` unknowns.
fn solvers(dim: usize, n: usize, direct_max_3d: usize) -> Vec<(&'static str, SolverSpec)> {
    let params = CgParams { rtol: 1e-8, max_iter: 20_000 };
    let mf = n >= MATRIX_FREE_FROM;
    let mut v = vec![(
        "cg-jacobi",
        SolverSpec::Cg { params: params.clone(), preconditioner: PreconditionerKind::JACOBI, matrix_free: mf },
    )];
    v.extend(crate::multigrid_solver(&params, mf));
    if !mf {
        // The matrix-free finest level beside the assembled one: same iterations, the memory
        // and time of not storing A (what `auto` runs on these lattices).
        let spec =
            SolverSpec::Cg { params: params.clone(), preconditioner: PreconditionerKind::MULTIGRID, matrix_free: true };
        v.push(("cg-multigrid-mf", spec));
    }
    if dim == 2 || n <= direct_max_3d {
        v.push(("cholesky", SolverSpec::Cholesky));
    }
    if !mf {
        v.push(("auto", SolverSpec::Auto(params)));
    }
    v
}

/// Writes the reduced system of case `name` for the Python peers: `A_ff` as triplets
/// (`name.coo.bin`), `f_f` (`name.rhs.bin`), the rigid-body modes of the free DOFs
/// (`name.B.bin`: `n`, `k`, then `k` values per row, little-endian) and `name.json` (asking
/// for pyamg only: CHOLMOD on the 3D cases would not fit).
fn export(dir: &Path, name: &str, p: &Problem) -> std::io::Result<()> {
    let io = |e: linpd_problem::ProblemError| std::io::Error::other(e.to_string());
    let model = p.lattice_model().map_err(io)?;
    let dirichlet = p.dirichlet();
    let dofs = dirichlet.dofs();
    let a = model.assemble_free(dofs);
    let f = dirichlet.reduced_rhs(&ModelOperator(&model), &p.load_vector());
    let geometry = DofGeometry::of(&model, dofs);
    let modes = rigid_body_modes(model.dim(), &geometry.rows, &geometry.positions);
    let n = a.nrows();
    std::fs::create_dir_all(dir)?;
    let file = |ext: &str| -> std::io::Result<std::io::BufWriter<std::fs::File>> {
        Ok(std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{name}.{ext}")))?))
    };
    let (col_ptr, row_idx, val) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    let mut w = file("coo.bin")?;
    for v in [n, n, val.len()] {
        w.write_all(&(v as u64).to_le_bytes())?;
    }
    for &r in row_idx {
        w.write_all(&(r as u64).to_le_bytes())?;
    }
    for j in 0..n {
        for _ in col_ptr[j]..col_ptr[j + 1] {
            w.write_all(&(j as u64).to_le_bytes())?;
        }
    }
    for v in val {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = file("rhs.bin")?;
    w.write_all(&(n as u64).to_le_bytes())?;
    for v in &f {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = file("B.bin")?;
    for v in [n, modes.len()] {
        w.write_all(&(v as u64).to_le_bytes())?;
    }
    for i in 0..n {
        for m in &modes {
            w.write_all(&m[i].to_le_bytes())?;
        }
    }
    w.flush()?;
    let desc = json!({"name": name, "n": n, "nnz": val.len(), "cg_rtol": 1e-8, "cg_maxiter": 20_000,
        "peers": ["pyamg"], "near_null_space": format!("{name}.B.bin")});
    std::fs::write(dir.join(format!("{name}.json")), desc.to_string())
}

/// Runs every case (names containing `filter`, if given) and returns the JSON section; with
/// `export_dir`, also writes each assembled case's reduced system for the peers ([`export`]).
pub fn run(quick: bool, filter: Option<&str>, direct_max_3d: usize, export_dir: Option<&Path>) -> Value {
    let mut out = serde_json::Map::new();
    for (name, dim, nodes, m, variant) in cases(quick) {
        if filter.is_some_and(|f| !name.contains(f)) {
            continue;
        }
        let mut p = scene(&name, dim, nodes, m, variant);
        let n_free = dim * p.nodes().len(); // an upper bound, for the solver list
        let mut rows = Vec::new();
        match variant {
            Variant::Homogeneous => {}
            Variant::Lps => {
                eprintln!("[bench] statics {name}: products, per bond and by the stencils");
                rows.push(lps_matvecs(&p));
            }
            _ => {
                eprintln!("[bench] statics {name}: products, per bond and by the corrected stencil");
                rows.push(matvecs(&p));
            }
        }
        let mut jacobi_total = None;
        for (label, spec) in solvers(dim, n_free, direct_max_3d) {
            eprintln!("[bench] statics {name}: {label}");
            crate::reset_peak_rss();
            p.set_solver(spec);
            let t = Instant::now();
            let row = match p.solve(&linpd_core::NoProgress) {
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
                        "nnz_factor": r.nnz_factor, "auto": r.auto, "preconditioner": r.preconditioner,
                        "peak_rss_gib": r.peak_rss_bytes.map(|b| b as f64 / (1u64 << 30) as f64),
                    })
                }
                Err(e) => json!({"solver": label, "error": e.to_string()}),
            };
            rows.push(row);
        }
        if let Some(dir) = export_dir.filter(|_| n_free < MATRIX_FREE_FROM) {
            eprintln!("[bench] statics {name}: exporting the reduced system for the peers");
            if let Err(e) = export(dir, &name, &p) {
                rows.push(json!({"solver": "export", "error": e.to_string()}));
            }
        }
        out.insert(name, Value::Array(rows));
    }
    Value::Object(out)
}

/// One product `A u` over all DOFs by the per-bond operator (`BondOperator::apply`, 12 bytes
/// a bond) and by the corrected stencil (`linpd_bond::CorrectedStencil`: the stencil and the
/// bonds that differ from it), averaged over >= 0.3 s each, with their ratio and the share of
/// bonds stored as corrections: the row `"solver": "matvec"` of a heterogeneous case.
fn matvecs(p: &Problem) -> Value {
    let model = match p.lattice_model() {
        Ok(m) => m,
        Err(e) => return json!({"solver": "matvec", "error": e.to_string()}),
    };
    let t = Instant::now();
    let Some(corrected) = model.corrected_stencil() else {
        return json!({"solver": "matvec", "error": "no corrected stencil on this lattice"});
    };
    let build = t.elapsed().as_secs_f64();
    let op = model.operator();
    let u: Vec<f64> = (0..op.n_dofs()).map(|k| (k as f64 * 0.1).sin()).collect();
    let mut y = vec![0.0; u.len()];
    let (per_bond, _) = crate::time_avg(|| op.apply(&u, &mut y));
    let (stencil, _) = crate::time_avg(|| corrected.apply(&u, &mut y));
    let bonds = op.family().n_bonds();
    json!({"solver": "matvec", "per_bond_apply": per_bond, "corrected_stencil_apply": stencil,
        "per_bond_over_corrected": per_bond / stencil, "corrected_stencil_build": build,
        "bonds": bonds, "corrections": corrected.n_corrections(),
        "correction_share": corrected.n_corrections() as f64 / bonds as f64})
}

/// One LPS tangent product `A u` per bond (`LpsModel::apply_tangent`: the families' `omega nu
/// V` and `|xi|`), by the stencils (`linpd_lps::LpsStencil::apply`) and the pair part alone by
/// its stencils (the multigrid's finest level), averaged over >= 0.3 s each: the row
/// `"solver": "matvec"` of an LPS case.
fn lps_matvecs(p: &Problem) -> Value {
    let built = p.model().as_any().downcast_ref::<linpd_problem::models::lps::LpsSceneModel>().map(|m| m.build(p));
    let model = match built {
        Some(Ok((m, _))) => m,
        Some(Err(e)) => return json!({"solver": "matvec", "error": e.to_string()}),
        None => return json!({"solver": "matvec", "error": "not an lps scene"}),
    };
    let t = Instant::now();
    let Some(st) = model.stencil() else {
        return json!({"solver": "matvec", "error": "no stencils for this lps model"});
    };
    let build = t.elapsed().as_secs_f64();
    let u: Vec<f64> = (0..model.n_dofs()).map(|k| (k as f64 * 0.1).sin()).collect();
    let mut y = vec![0.0; u.len()];
    let (per_bond, _) = crate::time_avg(|| model.apply_tangent(&u, &mut y));
    let (stencil, _) = crate::time_avg(|| st.apply(&u, &mut y));
    let (pair, _) = crate::time_avg(|| st.apply_pair(&u, &mut y));
    json!({"solver": "matvec", "per_bond_apply": per_bond, "stencil_apply": stencil, "pair_stencil_apply": pair,
        "per_bond_over_stencil": per_bond / stencil, "stencil_build": build, "bonds": model.family().n_bonds()})
}

/// Our multigrid-PCG against pyamg's on the exported cases: iterations of both and the time
/// ratios (setup, solve, setup + solve; ours / pyamg's, so below 1 is faster), from the
/// `peers.json` of the same run.
pub fn ratios(ours: &Value, peers: &Value) -> Value {
    let mut out = serde_json::Map::new();
    let Some(cases) = ours.as_object() else { return Value::Null };
    for (name, rows) in cases {
        let p = &peers["cases"][name];
        if p["pyamg_setup"].is_null() {
            continue;
        }
        let Some(mg) = rows.as_array().into_iter().flatten().find(|r| r["solver"] == "cg-multigrid") else {
            continue;
        };
        let f = |v: &Value| v.as_f64();
        let ratio = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a / b);
        let sum = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a + b);
        out.insert(
            name.clone(),
            json!({
                "iterations": mg["iterations"], "pyamg_iterations": p["pyamg_iterations"],
                "setup_ratio_to_pyamg": ratio(f(&mg["setup"]), f(&p["pyamg_setup"])),
                "solve_ratio_to_pyamg": ratio(f(&mg["solve"]), f(&p["pyamg_solve"])),
                "setup_solve_ratio_to_pyamg": ratio(sum(f(&mg["setup"]), f(&mg["solve"])),
                    sum(f(&p["pyamg_setup"]), f(&p["pyamg_solve"]))),
                "pyamg_rel_residual": p["pyamg_rel_residual"],
            }),
        );
    }
    Value::Object(out)
}

/// Writes the section returned by [`run`] as a table.
pub fn print(section: &Value, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    writeln!(
        w,
        "{:<20} {:<24} {:>9} {:>6} {:>9} {:>8} {:>8} {:>8} {:>8} {:>7} {:>6}",
        "case", "solver", "unknowns", "iters", "residual", "asm s", "setup s", "solve s", "total s", "vs jac", "GiB"
    )?;
    let Some(cases) = section.as_object() else { return Ok(()) };
    for (name, rows) in cases {
        for r in rows.as_array().into_iter().flatten() {
            if let Some(e) = r["error"].as_str() {
                writeln!(w, "{name:<20} {:<24} error: {e}", r["solver"].as_str().unwrap_or("?"))?;
                continue;
            }
            if r["solver"] == "matvec" && !r["stencil_apply"].is_null() {
                let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
                writeln!(
                    w,
                    "{name:<20} A u: per bond {:.1} ms, stencils {:.1} ms ({:.2}x), pair part alone {:.1} ms (built in \
                     {:.2} s)",
                    1e3 * f("per_bond_apply"),
                    1e3 * f("stencil_apply"),
                    f("per_bond_over_stencil"),
                    1e3 * f("pair_stencil_apply"),
                    f("stencil_build")
                )?;
                continue;
            }
            if r["solver"] == "matvec" {
                let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
                writeln!(
                    w,
                    "{name:<20} A u: per bond {:.1} ms, corrected stencil {:.1} ms ({:.2}x; {:.1} % of the bonds \
                     corrected, built in {:.2} s)",
                    1e3 * f("per_bond_apply"),
                    1e3 * f("corrected_stencil_apply"),
                    f("per_bond_over_corrected"),
                    100.0 * f("correction_share"),
                    f("corrected_stencil_build")
                )?;
                continue;
            }
            let f = |k: &str, p: usize| r[k].as_f64().map_or("-".into(), |x| format!("{x:.p$}"));
            let ran = r["ran"].as_str().unwrap_or("?");
            let shown = if r["solver"] == "auto" { format!("auto: {ran}") } else { ran.to_string() };
            writeln!(
                w,
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
            )?;
        }
    }
    Ok(())
}
