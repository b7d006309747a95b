//! `linpd study blend-<name>`: the numerical experiments of Seleson, Beneddine & Prudhomme
//! (2013), section 5, Figs. 7-14, plus a speed-versus-error map. Each study writes `data.json`,
//! PNG and SVG plots into its directory and prints a table.

use crate::out::{plot, write, Cases};
use crate::StudyError;
use linpd_blend::{
    ce_exact_point_load, solve_model, BlendParams, BlendSolution, BlendSolver, Blending, Load, ModelKind, Regions,
};
use linpd_core::progress::Progress;
use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
use serde_json::json;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

fn blendings() -> Vec<(&'static str, Blending)> {
    vec![("constant", Blending::Constant { value: 0.5 }), ("linear", Blending::Linear), ("cubic", Blending::Cubic)]
}

/// Relative errors (33), (34) and the weighted (35) of `u` against `pd`, over interior nodes
/// (`i = 2..N_x - 1` in the paper's 1-based numbering).
fn errors(pd: &BlendSolution, s: &BlendSolution) -> (f64, f64, f64) {
    let n = s.x.len();
    let (mut einf, mut uinf, mut e2, mut u2, mut ew, mut uw) = (0.0f64, 0.0f64, 0.0, 0.0, 0.0, 0.0);
    for i in 1..n - 1 {
        let r = pd.at(s.x[i]);
        let e = r - s.u[i];
        let w = 0.5 * (s.x[i + 1] - s.x[i - 1]);
        einf = einf.max(e.abs());
        uinf = uinf.max(r.abs());
        e2 += e * e;
        u2 += r * r;
        ew += e * e * w;
        uw += r * r * w;
    }
    (einf / uinf, (e2 / u2).sqrt(), (ew / uw).sqrt())
}

fn loglog(dir: &Path, name: &str, title: &str, xl: &str, yl: &str, series: Vec<Series>) -> Result<(), StudyError> {
    let p = LinePlot {
        title: title.into(),
        x_label: xl.into(),
        y_label: yl.into(),
        series,
        log_x: true,
        log_y: true,
        equal_aspect: false,
    };
    line_plot(&p, &dir.join(name)).map(|_| ()).map_err(StudyError::from)
}

fn series(label: &str, x: Vec<f64>, y: Vec<f64>, style: SeriesStyle) -> Series {
    Series { label: label.into(), x, y, style, color: None }
}

/// Drops non-positive values (for log axes).
fn positive(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    x.iter().zip(y).filter(|(_, v)| **v > 0.0).map(|(a, b)| (*a, *b)).unzip()
}

pub(crate) fn patch(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Table 2 with dx = 0.0125: the paper's dx = 0.02 gives eps/dx = 2.5, not an integer N.
    let mut p = BlendParams::table3(Blending::Cubic);
    p.regions = Regions { l1: 0.35, l2: 0.4, l3: 0.6, l4: 0.65 };
    p.dx = 0.0125;
    let mut cases: Vec<(String, ModelKind, Blending)> =
        vec![("CE".into(), ModelKind::PureCe, Blending::Cubic), ("PD".into(), ModelKind::PurePd, Blending::Cubic)];
    cases.extend(blendings().into_iter().map(|(n, b)| (format!("blended {n}"), ModelKind::Blended, b)));
    let (mut rows, mut prof, mut fluct) = (Vec::new(), Vec::new(), Vec::new());
    writeln!(report, "{:<18} {:>12} {:>12}", "model", "spread (30)", "solver")?;
    let n_cases = Cases::new(progress, "blend-patch", cases.len());
    for (label, kind, b) in cases {
        n_cases.next(&label);
        p.blending = b;
        let s = solve_model(&p, kind, 0.0, 1.0, &[], BlendSolver::Lu)?;
        let (xs, strain): (Vec<f64>, Vec<f64>) =
            s.x.windows(2)
                .zip(s.u.windows(2))
                .filter(|(x, _)| x[0] >= -1e-12 && x[1] <= 1.0 + 1e-12)
                .map(|(x, u)| (x[0], (u[1] - u[0]) / (x[1] - x[0])))
                .unzip();
        let mx = strain.iter().fold(f64::MIN, |a, v| a.max(v.abs()));
        let mn = strain.iter().fold(f64::MAX, |a, v| a.min(v.abs()));
        writeln!(report, "{label:<18} {:>12.3e} {:>12}", mx - mn, s.report.solver)?;
        rows.push(json!({"model": label, "strain_spread": mx - mn, "x": s.x, "u": s.u}));
        prof.push(series(&label, s.x.clone(), s.u.clone(), SeriesStyle::LineMarkers));
        fluct.push(series(&label, xs, strain.iter().map(|e| e - 1.0).collect(), SeriesStyle::LineMarkers));
    }
    write(dir, &json!({"study": "blend-patch", "params": format!("{p:?}"), "models": rows}))?;
    plot(dir, "fig7_profiles", "Patch test: u(0) = 0, u(1) = 1 (Table 2, dx = 0.0125)", "x", "u", prof, false)?;
    plot(dir, "fig8_strain_fluctuation", "Strain fluctuation du/dx - 1", "x", "du/dx - 1", fluct, false)
}

pub(crate) fn point_load(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let p = BlendParams::table3(Blending::Cubic);
    let load = [Load::Point { x: 0.5, force: 1.0 }];
    let pd = solve_model(&p, ModelKind::PurePd, 0.0, 0.0, &load, BlendSolver::Auto)?;
    let ce = solve_model(&p, ModelKind::PureCe, 0.0, 0.0, &load, BlendSolver::Auto)?;
    let xs: Vec<f64> = ce.x.clone();
    let exact: Vec<f64> = xs.iter().map(|&x| ce_exact_point_load(x, 0.0, 1.0, 0.0, 0.0, 0.5, 1.0, 1.0)).collect();
    let pd_on: Vec<f64> = xs.iter().map(|&x| pd.at(x)).collect();
    let mut out = Vec::new();
    let mut prof = vec![
        series("PD", xs.clone(), pd_on.clone(), SeriesStyle::Line),
        series("CE exact", xs.clone(), exact.clone(), SeriesStyle::Line),
        series("CE", xs.clone(), ce.u.clone(), SeriesStyle::Markers),
    ];
    let mut errs = Vec::new();
    let (ei, e2, _) = errors(&pd, &ce);
    writeln!(report, "{:<10} {:>12} {:>12}", "model", "e_r,inf (33)", "e_r,2 (34)")?;
    writeln!(report, "{:<10} {:>12.3e} {:>12.3e}", "CE", ei, e2)?;
    out.push(json!({"model": "CE", "e_inf": ei, "e_2": e2}));
    let cases = Cases::new(progress, "blend-point-load", blendings().len());
    for (name, b) in blendings() {
        cases.next(name);
        let mut q = p.clone();
        q.blending = b;
        let s = solve_model(&q, ModelKind::Blended, 0.0, 0.0, &load, BlendSolver::Auto)?;
        let (ei, e2, _) = errors(&pd, &s);
        writeln!(report, "{name:<10} {ei:>12.3e} {e2:>12.3e}")?;
        out.push(json!({"model": name, "e_inf": ei, "e_2": e2, "u": s.u, "solver": s.report.solver}));
        prof.push(series(&format!("blended {name}"), s.x.clone(), s.u.clone(), SeriesStyle::Line));
        let (x, y) = positive(&s.x, &s.x.iter().zip(&s.u).map(|(x, u)| (pd.at(*x) - u).abs()).collect::<Vec<_>>());
        errs.push(series(name, x, y, SeriesStyle::Line));
    }
    write(dir, &json!({"study": "blend-point-load", "x": xs, "u_pd": pd_on, "u_ce_exact": exact, "models": out}))?;
    plot(dir, "fig9_profiles", "Point load (Table 3): PD, CE and blended", "x", "u", prof.clone(), false)?;
    let zoom: Vec<Series> = prof
        .into_iter()
        .map(|mut s| {
            let keep: Vec<usize> = (0..s.x.len()).filter(|&i| (0.4..=0.6).contains(&s.x[i])).collect();
            s.x = keep.iter().map(|&i| s.x[i]).collect();
            s.y = keep.iter().map(|&i| s.y[i]).collect();
            s
        })
        .collect();
    plot(dir, "fig9_profiles_zoom", "Point load: close-up", "x", "u", zoom, false)?;
    plot(dir, "fig10_error_profiles", "|u_PD - u| for each blending function", "x", "|u_PD - u|", errs, true)
}

/// Shared sweep: for each horizon (eps, dx), solve PD once and blended models for each
/// geometry in `geometries(eps, dx)`; record e_r,2.
fn sweep(
    dir: &Path,
    report: &mut dyn Write,
    study: &str,
    xlabel: &str,
    geometries: impl Fn(f64, f64) -> Vec<(f64, Regions)>,
    load_at: f64,
    progress: &dyn Progress,
) -> Result<(), StudyError> {
    let mut data = Vec::new();
    let resolutions = [(0.05, 0.0005), (0.025, 0.00025)];
    let cases = Cases::new(progress, study, resolutions.len() * blendings().len());
    for (eps, dx) in resolutions {
        let mut p = BlendParams::table3(Blending::Cubic);
        p.horizon = eps;
        p.dx = dx;
        let load = [Load::Point { x: load_at, force: 1.0 }];
        let pd = solve_model(&p, ModelKind::PurePd, 0.0, 0.0, &load, BlendSolver::Auto)?;
        let ce = solve_model(&p, ModelKind::PureCe, 0.0, 0.0, &load, BlendSolver::Auto)?;
        let geos = geometries(eps, dx);
        let mut all = Vec::new();
        let mut plots = Vec::new();
        for (name, b) in blendings() {
            cases.next(format_args!("{name}, delta = {eps}"));
            let (mut xs, mut es) = (Vec::new(), Vec::new());
            for (param, r) in &geos {
                let mut q = p.clone();
                q.blending = b.clone();
                q.regions = *r;
                let s = solve_model(&q, ModelKind::Blended, 0.0, 0.0, &load, BlendSolver::Auto)?;
                xs.push(*param);
                es.push(errors(&pd, &s).1);
            }
            writeln!(
                report,
                "eps = {eps}: {name:<9} e_r,2 from {:.3e} (at {:.4}) to {:.3e} (at {:.4})",
                es[0],
                xs[0],
                es[es.len() - 1],
                xs[xs.len() - 1]
            )?;
            all.push(json!({"blending": name, "param": xs, "e_2": es}));
            let (x, y) = positive(&xs, &es);
            plots.push(series(name, x, y, SeriesStyle::LineMarkers));
        }
        let tag = if eps > 0.04 { "eps1" } else { "eps2" };
        plot(
            dir,
            &format!("{study}_{tag}"),
            &format!("e_r,2 vs {xlabel} (eps = {eps}, dx = {dx})"),
            xlabel,
            "e_r,2",
            plots,
            true,
        )?;
        let diff: Vec<f64> = ce.x.iter().zip(&ce.u).map(|(x, u)| pd.at(*x) - u).collect();
        plot(
            dir,
            &format!("pd_minus_ce_{tag}"),
            &format!("u_PD - u_CE (eps = {eps})"),
            "x",
            "u_PD - u_CE",
            vec![series("u_PD - u_CE", ce.x.clone(), diff, SeriesStyle::Line)],
            false,
        )?;
        data.push(json!({"eps": eps, "dx": dx, "curves": all}));
    }
    write(dir, &json!({"study": study, "sweeps": data}))
}

pub(crate) fn pd_size(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Section 5.2.1: bridges of 0.1 each, PD region centred at the load, size varied (the paper
    // steps by 2 dx; we step by 20 dx to keep the run short).
    sweep(
        dir,
        report,
        "blend-pd-size",
        "|Omega_PD|",
        |_eps, dx| {
            let mut g = Vec::new();
            let mut k = 1;
            loop {
                let s = 20.0 * dx * k as f64;
                if s > 0.6 + 1e-12 {
                    break;
                }
                g.push((
                    s,
                    Regions { l1: 0.5 - s / 2.0 - 0.1, l2: 0.5 - s / 2.0, l3: 0.5 + s / 2.0, l4: 0.5 + s / 2.0 + 0.1 },
                ));
                k += 1;
            }
            g
        },
        0.5,
        progress,
    )
}

pub(crate) fn bridge_size(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Section 5.2.2: |Omega_PD| = 2 eps - 6 dx, bridge half-size |Omega_b|/2 varied (the paper
    // steps by dx; we step by 10 dx).
    sweep(
        dir,
        report,
        "blend-bridge-size",
        "|Omega_b|/2",
        |eps, dx| {
            let s = 2.0 * eps - 6.0 * dx;
            let mut g = Vec::new();
            let mut k = 1;
            loop {
                let b = 10.0 * dx * k as f64;
                if b > 0.3 + 1e-12 {
                    break;
                }
                g.push((
                    b,
                    Regions { l1: 0.5 - s / 2.0 - b, l2: 0.5 - s / 2.0, l3: 0.5 + s / 2.0, l4: 0.5 + s / 2.0 + b },
                ));
                k += 1;
            }
            g
        },
        0.5,
        progress,
    )
}

pub(crate) fn load_location(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Section 5.2.3: eps = 0.05, dx = 0.005, bridges eps, |Omega_PD| = 6 eps centred.
    let mut p = BlendParams::table3(Blending::Cubic);
    p.dx = 0.005;
    p.regions = Regions { l1: 0.3, l2: 0.35, l3: 0.65, l4: 0.7 };
    let locations: Vec<f64> = (1..200).map(|k| k as f64 * p.dx).collect();
    let mut curves = Vec::new();
    let mut plots = Vec::new();
    let mut pds = Vec::new();
    let cases = Cases::new(progress, "blend-load-location", 1 + blendings().len());
    cases.next("PD");
    for &xp in &locations {
        let load = [Load::Point { x: xp, force: 1.0 }];
        pds.push(solve_model(&p, ModelKind::PurePd, 0.0, 0.0, &load, BlendSolver::Auto)?);
    }
    for (name, b) in blendings() {
        cases.next(name);
        let mut q = p.clone();
        q.blending = b;
        let mut es = Vec::new();
        for (k, &xp) in locations.iter().enumerate() {
            let load = [Load::Point { x: xp, force: 1.0 }];
            let s = solve_model(&q, ModelKind::Blended, 0.0, 0.0, &load, BlendSolver::Auto)?;
            es.push(errors(&pds[k], &s).1);
        }
        let centre = es[locations.iter().position(|&x| (x - 0.5).abs() < 1e-9).unwrap()];
        let worst = es.iter().cloned().fold(0.0, f64::max);
        writeln!(report, "{name:<9} e_r,2 at the centre {centre:.3e}, worst {worst:.3e}")?;
        let (x, y) = positive(&locations, &es);
        plots.push(series(name, x, y, SeriesStyle::LineMarkers));
        curves.push(json!({"blending": name, "x_p": locations, "e_2": es}));
    }
    write(dir, &json!({"study": "blend-load-location", "curves": curves}))?;
    plot(
        dir,
        "fig13_error_vs_load_location",
        "e_r,2 vs point-load location (eps = 0.05, dx = 0.005)",
        "x_p",
        "e_r,2",
        plots,
        true,
    )
}

/// Fig. 14 geometry: dx = 1e-4, eps = 0.05, |Omega_PD| = 6 eps, bridges 3 dx.
fn fig14_params(blending: Blending) -> BlendParams {
    let mut p = BlendParams::table3(blending);
    p.dx = 1e-4;
    p.regions = Regions { l1: 0.35 - 3e-4, l2: 0.35, l3: 0.65, l4: 0.65 + 3e-4 };
    p
}

fn timed(
    p: &BlendParams,
    kind: ModelKind,
    load: &[Load],
    solver: BlendSolver,
) -> Result<(BlendSolution, f64), StudyError> {
    let t = Instant::now();
    let s = solve_model(p, kind, 0.0, 0.0, load, solver)?;
    Ok((s, t.elapsed().as_secs_f64()))
}

pub(crate) fn speedup(
    dir: &Path,
    dense: bool,
    report: &mut dyn Write,
    progress: &dyn Progress,
) -> Result<(), StudyError> {
    let load = [Load::Point { x: 0.5, force: 1.0 }];
    let p = fig14_params(Blending::Cubic);
    let (pd, t_pd) = timed(&p, ModelKind::PurePd, &load, BlendSolver::Auto)?;
    let t_pd_dense = if dense { Some(timed(&p, ModelKind::PurePd, &load, BlendSolver::Dense)?.1) } else { None };
    writeln!(
        report,
        "PD: {} unknowns, {t_pd:.3} s ({}){}",
        pd.report.n,
        pd.report.solver,
        t_pd_dense.map_or(String::new(), |t| format!(", dense {t:.1} s"))
    )?;
    writeln!(
        report,
        "{:>6} {:>8} {:>12} {:>10} {:>9} {:>12} {:>22}",
        "ratio", "nodes", "e_w (35)", "time s", "speedup", "dense speedup", "solver"
    )?;
    let (mut rows, mut rs, mut ews, mut sps, mut dsps) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut blended_solution = None;
    let cases = Cases::new(progress, "blend-speedup", 10);
    for k in 0..=9 {
        let ratio = (1u32 << k) as f64;
        cases.next(format_args!("ratio {ratio}"));
        let mut q = p.clone();
        q.ce_spacing = Some(ratio * p.dx);
        let (s, t) = timed(&q, ModelKind::Blended, &load, BlendSolver::Auto)?;
        let ew = errors(&pd, &s).2;
        let td = if dense { Some(timed(&q, ModelKind::Blended, &load, BlendSolver::Dense)?.1) } else { None };
        let dsp = t_pd_dense.zip(td).map(|(a, b)| a / b);
        writeln!(
            report,
            "{ratio:>6} {:>8} {ew:>12.3e} {t:>10.3} {:>9.2} {:>12} {:>22}",
            s.x.len(),
            t_pd / t,
            dsp.map_or("-".into(), |v| format!("{v:.2}")),
            s.report.solver
        )?;
        rows.push(json!({"ratio": ratio, "nodes": s.x.len(), "e_w": ew, "time": t, "speedup": t_pd / t, "time_dense": td, "speedup_dense": dsp, "solver": s.report.solver, "timings": s.report.timings}));
        rs.push(ratio);
        ews.push(ew);
        sps.push(t_pd / t);
        if let Some(d) = dsp {
            dsps.push(d);
        }
        if k == 9 {
            blended_solution = Some(s);
        }
    }
    let b = blended_solution.unwrap();
    let exact: Vec<f64> = pd.x.iter().map(|&x| ce_exact_point_load(x, 0.0, 1.0, 0.0, 0.0, 0.5, 1.0, 1.0)).collect();
    write(
        dir,
        &json!({"study": "blend-speedup", "pd_time": t_pd, "pd_time_dense": t_pd_dense, "pd_solver": pd.report.solver, "rows": rows}),
    )?;
    let inside = |x: &f64| (0.0..=1.0).contains(x);
    let (px, pu): (Vec<f64>, Vec<f64>) =
        pd.x.iter().zip(&pd.u).filter(|(x, _)| inside(x)).map(|(a, b)| (*a, *b)).unzip();
    let ex: Vec<f64> = pd.x.iter().zip(&exact).filter(|(x, _)| inside(x)).map(|(_, e)| *e).collect();
    plot(
        dir,
        "fig14a_pd_vs_ce",
        "PD vs CE exact (dx = 1e-4, eps = 0.05)",
        "x",
        "u",
        vec![
            series("PD", px.clone(), pu.clone(), SeriesStyle::Line),
            series("CE exact", px.clone(), ex, SeriesStyle::Line),
        ],
        false,
    )?;
    plot(
        dir,
        "fig14b_pd_vs_blended",
        "PD vs blended (cubic, CE mesh ratio 512)",
        "x",
        "u",
        vec![
            series("PD", px, pu, SeriesStyle::Line),
            series("blended", b.x.clone(), b.u.clone(), SeriesStyle::Markers),
        ],
        false,
    )?;
    loglog(
        dir,
        "fig14c_error_vs_ratio",
        "Weighted relative error (35) vs CE mesh ratio",
        "dx_CE / dx",
        "e_w",
        vec![series("cubic", rs.clone(), ews, SeriesStyle::LineMarkers)],
    )?;
    let mut sp = vec![series("sparse, best solvers", rs.clone(), sps, SeriesStyle::LineMarkers)];
    if dsps.len() == rs.len() {
        sp.push(series("dense (MATLAB-like: Cholesky for PD, LU blended)", rs.clone(), dsps, SeriesStyle::LineMarkers));
    }
    loglog(dir, "fig14d_speedup_vs_ratio", "Speedup t_PD / t_blended vs CE mesh ratio", "dx_CE / dx", "speedup", sp)
}

pub(crate) fn speed_vs_error(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let load = [Load::Point { x: 0.5, force: 1.0 }];
    let p = fig14_params(Blending::Cubic);
    let (pd, t_pd) = timed(&p, ModelKind::PurePd, &load, BlendSolver::Auto)?;
    let (ce, t_ce) = timed(&p, ModelKind::PureCe, &load, BlendSolver::Auto)?;
    let e_ce = errors(&pd, &ce).1;
    let mut plots = Vec::new();
    let mut data = vec![
        json!({"model": "PD", "time": t_pd, "e_2": 0.0, "solver": pd.report.solver}),
        json!({"model": "CE", "time": t_ce, "e_2": e_ce, "solver": ce.report.solver}),
    ];
    writeln!(report, "PD {t_pd:.3} s ({}); CE {t_ce:.4} s, e_r,2 = {e_ce:.3e}", pd.report.solver)?;
    let mut ymin = e_ce;
    let cases = Cases::new(progress, "blend-speed-vs-error", 10 * blendings().len());
    for (name, b) in blendings() {
        let (mut ts, mut es) = (Vec::new(), Vec::new());
        for k in 0..=9 {
            cases.next(format_args!("{name}, ratio {}", 1u32 << k));
            let mut q = fig14_params(b.clone());
            q.ce_spacing = Some((1u32 << k) as f64 * p.dx);
            let (s, t) = timed(&q, ModelKind::Blended, &load, BlendSolver::Auto)?;
            let e = errors(&pd, &s).1;
            ymin = ymin.min(e);
            data.push(json!({"model": format!("blended {name}"), "ratio": 1u32 << k, "time": t, "e_2": e, "solver": s.report.solver}));
            ts.push(t);
            es.push(e);
        }
        writeln!(
            report,
            "blended {name:<9}: time {:.3}..{:.3} s, e_r,2 {:.3e}..{:.3e}",
            ts.iter().cloned().fold(f64::MAX, f64::min),
            ts.iter().cloned().fold(0.0, f64::max),
            es.iter().cloned().fold(f64::MAX, f64::min),
            es.iter().cloned().fold(0.0, f64::max)
        )?;
        plots.push(series(&format!("blended {name} (ratios 1..512)"), ts, es, SeriesStyle::LineMarkers));
    }
    plots.push(series("pure CE", vec![t_ce], vec![e_ce], SeriesStyle::Markers));
    // Full PD has zero error against itself: draw its time as a vertical line.
    plots.push(series(
        "full PD (reference) time",
        vec![t_pd, t_pd],
        vec![ymin.max(1e-16) / 2.0, e_ce * 2.0],
        SeriesStyle::Line,
    ));
    write(dir, &json!({"study": "blend-speed-vs-error", "points": data}))?;
    loglog(
        dir,
        "speed_vs_error",
        "Point load (dx = 1e-4, eps = 0.05): wall time vs e_r,2 against full PD",
        "wall time (s)",
        "e_r,2",
        plots,
    )
}
