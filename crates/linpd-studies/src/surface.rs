//! `linpd study surface`: the surface corrections of issue #14 (`model.surface_correction`,
//! [`linpd_core::surface`]) on two thin bodies, for the bond-based and LPS models, against grid
//! refinement and `delta / h`, with the setup cost of each correction.
//!
//! * **Tension bar** (Peridynamics.jl's verification bar, `data/surface-bar-3d.json`): length 1,
//!   cross-section 0.1 x 0.1, `n` cell-centred points across (`h = 0.1 / n`), three (`floor(delta
//!   / h)`) held layers at `x < -1/2`, `E = 200e9`, `nu = 1/4`, the last layer of points loaded
//!   with `F = 2e6` in total; error of the mean x-displacement of the loaded points against
//!   `F l / (E A)` (the peer's measure, `l = 1`).
//! * **Cantilever**: `1 x 0.1 x 0.1`, clamped through three held layers at `x < 0`, the tip
//!   plane loaded with `P` in -z; error of the tip plane's mean deflection against Timoshenko's
//!   `P L^3 / (3 E I) + P L / (kappa G A)` at the tip plane's `x = L`, with Cowper's shear
//!   coefficient `kappa = 10 (1 + nu) / (12 + 11 nu)` for a square section (0.8475 at
//!   `nu = 1/4`; shear is 0.7 % of the deflection).
//!
//! Bond-based: inverse-distance micromodulus with the continuum normalization (as Peridynamics.jl);
//! LPS: `omega = 1/|xi|`, `K, G` from `E, nu`; `nu = 1/4` for both (the bond model's only value).
//! Each correction is matched to the classical target (the default) and to the lattice's
//! ([`linpd_core::surface::SurfaceTarget`]). The bar's error is also given against the exact
//! classical bar under the same loading (a body force on the last cell, measured at the cell's
//! centre: `F (l - 5h/8) / (E A)`), which the measure `F l / (E A)` offsets by `-5h/8`.

use crate::out::{create_dir, plot, write, Cases};
use crate::StudyError;
use linpd_core::progress::{NoProgress, Progress};
use linpd_plot::{Series, SeriesStyle};
use linpd_problem::Problem;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// `(model, correction, target)` of the study: the corrections with the classical target (the
/// default), then with the lattice target, whose corrected models converge to the lattice's
/// cubic anisotropy.
const VARIANTS: [(&str, &str, &str); 8] = [
    ("bond", "none", "-"),
    ("bond", "energy", "classical"),
    ("lps", "none", "-"),
    ("lps", "energy", "classical"),
    ("lps", "position_aware", "classical"),
    ("bond", "energy", "lattice"),
    ("lps", "energy", "lattice"),
    ("lps", "position_aware", "lattice"),
];

/// The model object of a scene: bond (continuum-normalized inverse distance) or LPS, for
/// Young's modulus `e` and `nu = 1/4`.
fn model(kind: &str, correction: &str, target: &str, horizon: f64, e: f64) -> Value {
    let k = e / (3.0 * (1.0 - 2.0 * 0.25));
    let g = e / (2.0 * 1.25);
    let mut m = match kind {
        "lps" => json!({"type": "lps", "horizon": horizon, "bulk_modulus": k, "shear_modulus": g,
                        "surface_correction": correction}),
        _ => json!({"type": "bond", "horizon": horizon, "surface_correction": correction,
                    "micromodulus": {"kernel": "inverse_distance", "modulus": k, "normalize": "continuum"}}),
    };
    if correction != "none" {
        m["surface_target"] = json!(target);
    }
    m
}

/// A beam-like scene on `[x0, x0 + length] x [-w/2, w/2]^2` with `n` cell-centred points across,
/// `floor(ratio)` held layers behind `x0`, and a resultant `force` on the last point plane.
fn beam(name: &str, x0: f64, n: usize, ratio: f64, model_of: impl Fn(f64) -> Value, force: [f64; 3]) -> Value {
    let (w, length) = (0.1, 1.0);
    let h = w / n as f64;
    let layers = (ratio * (1.0 + 1e-9)).floor();
    let solver = if name.starts_with("cantilever-lps") {
        // auto picks multigrid CG, whose attainable residual on the LPS cantilever is ~1e-10
        json!({"type": "cg", "preconditioner": "multigrid", "rtol": 1e-9})
    } else {
        json!({"type": "cholesky"})
    };
    json!({
        "name": name,
        "dimension": 3,
        "grid": {"min": [x0, -w / 2.0, -w / 2.0], "max": [x0 + length, w / 2.0, w / 2.0], "spacing": h,
                 "placement": "cell", "layer": {"x-": layers * h}},
        "model": model_of(ratio * h),
        "constraints": [{"region": {"box": {"min": [x0 - 1.0, -1.0, -1.0], "max": [x0, 1.0, 1.0]}},
                         "displacement": {"value": [0.0, 0.0, 0.0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [x0 + length - h, -1.0, -1.0], "max": [x0 + 2.0, 1.0, 1.0]}},
                   "force": force}],
        "solver": solver,
        "output": {"plot": false}
    })
}

/// One case's measurement: the mean displacement component `c` of the loaded plane, the
/// plane's `x`, the correction's setup seconds and the total seconds.
struct Measured {
    mean: f64,
    x_load: f64,
    correction_seconds: f64,
    seconds: f64,
    unknowns: usize,
}

fn solve(scene: &Value, c: usize, progress: &dyn Progress) -> Result<Measured, StudyError> {
    let check = |e: linpd_problem::ProblemError| StudyError::Check(format!("{}: {e}", scene["name"]));
    let p = Problem::from_json(&scene.to_string()).map_err(check)?;
    // the correction alone, for its setup cost (the solve builds the model again)
    let summary = if scene["model"]["type"] == "lps" {
        p.lps_model_and_correction().map_err(check)?.1
    } else {
        p.operator_and_correction().map_err(check)?.1
    };
    let start = Instant::now();
    let s = p.solve(progress).map_err(check)?;
    let seconds = start.elapsed().as_secs_f64();
    let x_max = s.x.iter().fold(f64::NEG_INFINITY, |m, x| m.max(x[0]));
    let loaded: Vec<usize> = (0..s.x.len()).filter(|&i| s.x[i][0] > x_max - 1e-9).collect();
    let mean = loaded.iter().map(|&i| s.u[3 * i + c]).sum::<f64>() / loaded.len() as f64;
    Ok(Measured {
        mean,
        x_load: x_max,
        correction_seconds: summary.map_or(0.0, |s| s.seconds),
        seconds,
        unknowns: s.report.n,
    })
}

/// Runs the study into `dir`.
pub(crate) fn run(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    create_dir(dir)?;
    let refinements = [3usize, 4, 5, 6];
    let ratios = [2.015, 3.015, 4.015];
    let cantilever_n = [4usize, 5, 8, 10];
    let n_cases = VARIANTS.len() * (refinements.len() + ratios.len() - 1 + cantilever_n.len() + ratios.len() - 1);
    let cases = Cases::new(progress, "surface", n_cases);
    let mut rows = Vec::new();
    writeln!(
        report,
        "{:<11} {:<6} {:<15} {:<9} {:>3} {:>6} {:>8} {:>10} {:>10} {:>10} {:>8}",
        "body", "model", "correction", "target", "n", "d/h", "unknowns", "error %", "vs exact %", "corr. s", "solve s"
    )?;
    // `exact`: the classical solution of the same discrete loading at the same points (the bar:
    // F (l - 5h/8) / (E A), see `run`; the cantilever: Timoshenko, the same as the reference)
    #[allow(clippy::too_many_arguments)]
    let mut record = |body: &str,
                      (kind, corr, target): (&str, &str, &str),
                      n: usize,
                      ratio: f64,
                      m: &Measured,
                      err: f64,
                      err_exact: f64| {
        rows.push(json!({"body": body, "model": kind, "correction": corr, "target": target, "n_across": n,
            "spacing": 0.1 / n as f64, "horizon_ratio": ratio, "unknowns": m.unknowns, "relative_error": err,
            "error_vs_exact": err_exact, "correction_seconds": m.correction_seconds, "solve_seconds": m.seconds}));
        writeln!(
            report,
            "{body:<11} {kind:<6} {corr:<15} {target:<9} {n:>3} {ratio:>6.3} {:>8} {:>+10.2} {:>+10.2} {:>10.3} {:>8.2}",
            m.unknowns,
            100.0 * err,
            100.0 * err_exact,
            m.correction_seconds,
            m.seconds
        )
    };
    let (e_bar, f_bar) = (200e9, 2e6);
    let (e_beam, p_beam, nu) = (1.0, 1e-5, 0.25);
    let mut bar_series = Vec::new();
    let mut beam_series = Vec::new();
    for (kind, corr, target) in VARIANTS {
        let label = if corr == "none" { format!("{kind}, none") } else { format!("{kind}, {corr}, {target}") };
        // the bar: refinement at delta = 3.015 h, then delta / h at n = 3
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        let mut bar_cases: Vec<(usize, f64)> = refinements.iter().map(|&n| (n, 3.015)).collect();
        bar_cases.extend(ratios.iter().filter(|&&r| r != 3.015).map(|&r| (3, r)));
        for (n, ratio) in bar_cases {
            cases.next(format_args!("bar, {label}, n = {n}, delta/h = {ratio}"));
            let scene = beam(
                &format!("bar-{kind}"),
                -0.5,
                n,
                ratio,
                |d| model(kind, corr, target, d, e_bar),
                [f_bar, 0.0, 0.0],
            );
            let m = solve(&scene, 0, &NoProgress)?;
            let err = m.mean / (f_bar / (e_bar * 0.01)) - 1.0;
            // the classical bar under a uniform body force on its last cell [l/2 - h, l/2],
            // clamped at -l/2, measured at the cell's centre: u = F (l - h + 3h/8) / (E A)
            let h = 0.1 / n as f64;
            let exact = f_bar * (1.0 - 5.0 * h / 8.0) / (e_bar * 0.01);
            record("bar", (kind, corr, target), n, ratio, &m, err, m.mean / exact - 1.0)?;
            if ratio == 3.015 {
                xs.push(0.1 / n as f64);
                ys.push(100.0 * err);
            }
        }
        bar_series.push(Series { label: label.clone(), x: xs, y: ys, style: SeriesStyle::LineMarkers, color: None });
        // the cantilever: refinement at delta = 3 h, then delta / h at n = 5
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        let mut beam_cases: Vec<(usize, f64)> = cantilever_n.iter().map(|&n| (n, 3.0)).collect();
        beam_cases.extend([(5, 2.0), (5, 4.0)]);
        for (n, ratio) in beam_cases {
            cases.next(format_args!("cantilever, {label}, n = {n}, delta/h = {ratio}"));
            let scene = beam(
                &format!("cantilever-{kind}"),
                0.0,
                n,
                ratio,
                |d| model(kind, corr, target, d, e_beam),
                [0.0, 0.0, -p_beam],
            );
            let m = solve(&scene, 2, &NoProgress)?;
            let (g, i, a) = (e_beam / (2.0 * (1.0 + nu)), 0.1f64.powi(4) / 12.0, 0.01);
            let kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
            let l = m.x_load;
            let timoshenko = p_beam * l.powi(3) / (3.0 * e_beam * i) + p_beam * l / (kappa * g * a);
            let err = -m.mean / timoshenko - 1.0;
            record("cantilever", (kind, corr, target), n, ratio, &m, err, err)?;
            if ratio == 3.0 {
                xs.push(0.1 / n as f64);
                ys.push(100.0 * err);
            }
        }
        beam_series.push(Series { label, x: xs, y: ys, style: SeriesStyle::LineMarkers, color: None });
    }
    write(dir, &json!({"study": "surface", "rows": rows}))?;
    plot(
        dir,
        "bar_error",
        "Tension bar 1 x 0.1 x 0.1 (Peridynamics.jl), delta = 3.015 h: error of the loaded end",
        "spacing h",
        "error vs F l / (E A) (%)",
        bar_series,
        false,
    )?;
    plot(
        dir,
        "cantilever_error",
        "Cantilever 1 x 0.1 x 0.1, delta = 3h: tip deflection vs Timoshenko",
        "spacing h",
        "error (%)",
        beam_series,
        false,
    )
}
