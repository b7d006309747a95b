//! `linpd study dispersion` and `linpd study stability`: section 4 of Seleson, Parks, Gunzburger
//! & Lehoucq (2009), "Peridynamics as an upscaling of molecular dynamics", on the nonlocal-spring
//! lattice (`K_1 = rho = 1`, horizon `delta = 5`, `N = delta/dx` neighbours per side).
//!
//! * dispersion: `omega(k)` of the lattice (exact), of the PD continuum, of the series
//!   (4.8)/(4.9), and measured from single-mode velocity-Verlet runs on a ring (compared with the
//!   lattice relation corrected for Verlet, `sin(omega_num dt/2) = omega dt/2`), for N = 1, 5, 20.
//! * stability: the bound (4.12), the exact limit `2/omega_max` and the measured blow-up limit of
//!   the square pulse (4.14) on the bar `[0, 1000]` (fixed layers of width `delta`) over `dx`
//!   (Fig. 4.2).

use crate::out::{create_dir, write_text, Cases};
use crate::StudyError;
use linpd_bond::BondOperator;
use linpd_core::progress::Progress;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_dynamics::dispersion::{
    continuum_amplitude, measure_omega, omega, omega_continuum, omega_paper_series, verlet_omega, ModalFit, ModeRun,
};
use linpd_dynamics::initial::square_pulse;
use linpd_dynamics::stability::{lattice_limit, paper_bound};
use linpd_dynamics::{spring_constant, Chain, DynamicsError, LumpedMass, State, Verlet, VerletParams};
use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
use serde_json::json;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

const DELTA: f64 = 5.0;
const K1: f64 = 1.0;
const RHO: f64 = 1.0;

/// Runs `dispersion` into `dir`.
pub(crate) fn run_dispersion(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    create_dir(dir)?;
    dispersion(dir, report, progress)
}

/// Runs `stability` into `dir`.
pub(crate) fn run_stability(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    create_dir(dir)?;
    stability(dir, report, progress)
}

fn write_data(dir: &Path, data: &serde_json::Value) -> Result<(), StudyError> {
    write_text(&dir.join("data.json"), &format!("{data:#}"))
}

fn max_rel(a: &[f64], b: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
    a.iter().zip(b).enumerate().filter(|(i, _)| keep(*i)).map(|(_, (x, y))| ((x - y) / y).abs()).fold(0.0, f64::max)
}

fn dispersion(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // 3 chains, then the 4 lattices of `lattice_dispersion`.
    let cases = Cases::new(progress, "dispersion", 7);
    let kernel = Kernel::InverseDistance;
    let c = continuum_amplitude(&kernel, K1, DELTA)?;
    let mut rows = Vec::new();
    let mut table = String::from(
        "| N | dx | continuum vs lattice, k delta <= 1 | continuum vs lattice, all k | (4.8)/(4.9) vs lattice, k delta <= 1 | (4.8)/(4.9) vs lattice, k delta <= 2 | measured vs Verlet-corrected lattice | measured vs uncorrected lattice |\n|---|---|---|---|---|---|---|---|\n",
    );
    writeln!(report, "max relative errors in omega(k) (K_1 = rho = 1, delta = 5, k in (0, pi/dx]):")?;
    for n in [1usize, 5, 20] {
        cases.next(format_args!("N = {n}"));
        let dx = DELTA / n as f64;
        let chain = Chain::springs(K1, n, dx)?;
        let kmax = std::f64::consts::PI / dx;
        let ks: Vec<f64> = (1..=200).map(|i| kmax * i as f64 / 200.0).collect();
        let disc: Vec<f64> = ks.iter().map(|&k| omega(&chain, RHO, k)).collect();
        let cont: Vec<f64> = ks.iter().map(|&k| omega_continuum(&kernel, c, DELTA, RHO, k)).collect();
        let ser: Vec<f64> = ks.iter().map(|&k| omega_paper_series(K1, RHO, DELTA, k)).collect();
        let ksr = &ks;
        let long = |lim: f64| move |i: usize| ksr[i] * DELTA <= lim;
        let e_cont_long = max_rel(&cont, &disc, long(1.0));
        let e_cont_all = max_rel(&cont, &disc, |_| true);
        let e_ser_1 = max_rel(&ser, &disc, long(1.0));
        let e_ser_2 = max_rel(&ser, &disc, long(2.0));
        // Single-mode runs on a ring of 200 nodes, dt = half the ring's limit, 4000 steps.
        let nx = 200;
        let ring = chain.ring(nx)?;
        let dt = 0.5 * ring.dt_limit(RHO);
        let (mut mk, mut mw, mut mpred, mut mdisc) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for m in [2usize, 5, 10, 20, 35, 50, 65, 80, 90, 100] {
            let meas = measure_omega(&chain, RHO, &ModeRun { nx, mode: m, dt, steps: 4000 }, ModalFit::Recurrence)?;
            let w = omega(&chain, RHO, meas.k);
            mk.push(meas.k);
            mw.push(meas.omega);
            mpred.push(verlet_omega(w, dt).ok_or(StudyError::Check("mode above the limit".into()))?);
            mdisc.push(w);
        }
        let e_meas = max_rel(&mw, &mpred, |_| true);
        let e_meas_raw = max_rel(&mw, &mdisc, |_| true);
        writeln!(report,
            "N = {n:2} (dx = {dx}): continuum {e_cont_long:.2e} (k delta <= 1), {e_cont_all:.2e} (all k); series {e_ser_1:.2e} (k delta <= 1), {e_ser_2:.2e} (<= 2); measured vs Verlet-corrected {e_meas:.2e}, vs uncorrected {e_meas_raw:.2e}"
        )?;
        table.push_str(&format!(
            "| {n} | {dx} | {e_cont_long:.2e} | {e_cont_all:.2e} | {e_ser_1:.2e} | {e_ser_2:.2e} | {e_meas:.2e} | {e_meas_raw:.2e} |\n"
        ));
        let mut meas_series = Series::new("measured (Verlet run)", mk.clone(), mw.clone());
        meas_series.style = SeriesStyle::Markers;
        let plot = LinePlot {
            title: format!("dispersion, N = {n} (dx = {dx}, delta = 5)"),
            x_label: "k".into(),
            y_label: "omega".into(),
            series: vec![
                Series::new("lattice (exact)", ks.clone(), disc.clone()),
                Series::new(
                    format!("lattice, Verlet-corrected (dt = {dt:.3})"),
                    ks.clone(),
                    disc.iter().map(|w| verlet_omega(*w, dt).unwrap_or(f64::NAN)).collect(),
                ),
                Series::new("PD continuum", ks.clone(), cont.clone()),
                Series::new(
                    "series (4.8)/(4.9)",
                    ks.iter().copied().filter(|k| k * DELTA <= 2.5).collect(),
                    ser.iter().zip(&ks).filter(|(_, k)| *k * DELTA <= 2.5).map(|(s, _)| *s).collect(),
                ),
                meas_series,
            ],
            log_x: false,
            log_y: false,
            equal_aspect: false,
        };
        line_plot(&plot, &dir.join(format!("dispersion_N{n}")))?;
        rows.push(json!({
            "N": n, "dx": dx, "k": ks, "omega_lattice": disc, "omega_continuum": cont, "omega_series": ser,
            "measured": {"ring_nodes": nx, "dt": dt, "steps": 4000, "k": mk, "omega": mw, "omega_verlet_lattice": mpred, "omega_lattice": mdisc},
            "max_rel_error": {
                "continuum_vs_lattice_kdelta_le_1": e_cont_long, "continuum_vs_lattice_all": e_cont_all,
                "series_vs_lattice_kdelta_le_1": e_ser_1, "series_vs_lattice_kdelta_le_2": e_ser_2,
                "measured_vs_verlet_corrected": e_meas, "measured_vs_uncorrected": e_meas_raw,
            }
        }));
    }
    write_text(&dir.join("table.md"), &table)?;
    write_data(dir, &json!({"study": "dispersion", "K1": K1, "rho": RHO, "delta": DELTA, "cases": rows}))?;
    lattice_dispersion(dir, report, &cases)
}

/// Bloch dispersion of the 2D (plane strain) and 3D bond-based and LPS operators along
/// [100], [110], [111] (`linpd_dynamics::bloch`): `h = 1`, `delta = 3h`, `K = rho = 1`;
/// bond-based `lambda = mu = 3K/5`, LPS `G = 0.3` (`lambda = K - 2G/3`, `mu = G`).
/// Writes `lattice_<model>_<d>d.{png,svg}`, `lattice_table.md`, `lattice.json`.
fn lattice_dispersion(dir: &Path, report: &mut dyn Write, progress: &Cases<'_>) -> Result<(), StudyError> {
    use linpd_core::{DofMap, PlaneModel};
    use linpd_dynamics::bloch::{classical_speeds, lattice_direction, lattice_reach, BlochStencil};
    use linpd_lps::{assemble_tangent, Influence, LpsModel, LpsParams};
    let (h, delta, k_bulk, g_lps) = (1.0, 3.0, 1.0, 0.3);
    let mut table = String::from(
        "| model | dim | direction | c_L (lattice) | c_P (classical) | c_L/c_P - 1 | c_T (lattice) | c_S (classical) | max c_T/c_S - 1 |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut cases = Vec::new();
    writeln!(report, "Bloch dispersion, delta = 3h, K = rho = 1 (2D: plane strain); long-wave speeds vs classical:")?;
    for model in ["bond", "lps"] {
        for dim in [2usize, 3] {
            progress.next(format_args!("{model}, {dim}D"));
            let plane = (dim == 2).then_some(PlaneModel::Strain);
            let reach = lattice_reach(delta, h) * if model == "lps" { 2 } else { 1 };
            let side = 2.0 * reach as f64 * h;
            let g = Grid::new(&vec![0.0; dim], &vec![side; dim], h, 0.0, Placement::Vertex)?;
            let (a, lambda, mu) = if model == "bond" {
                let mm = Micromodulus {
                    kernel: Kernel::InverseDistance,
                    normalization: Normalization::Discrete,
                    modulus: k_bulk,
                    plane,
                    partial_volume: false,
                };
                let op = BondOperator::on_grid(&g, delta, &mm, &Material::default())?;
                (linpd_bond::assemble(&op, &DofMap::all_free(g.len(), dim)), 0.6 * k_bulk, 0.6 * k_bulk)
            } else {
                let p = LpsParams {
                    K: k_bulk,
                    G: g_lps,
                    horizon: delta,
                    influence: Influence::InverseDistance,
                    partial_volume: false,
                    plane,
                };
                (assemble_tangent(&LpsModel::new(&g, &p)?), k_bulk - 2.0 * g_lps / 3.0, g_lps)
            };
            let s = BlochStencil::from_matrix(&a, dim, g.counts(), h, reach)?;
            let (cp, cs) = classical_speeds(lambda, mu, RHO);
            let dirs: &[[i32; 3]] = if dim == 2 { &[[1, 0, 0], [1, 1, 0]] } else { &[[1, 0, 0], [1, 1, 0], [1, 1, 1]] };
            let mut series = Vec::new();
            let mut dir_rows = Vec::new();
            for m in dirs {
                let n = lattice_direction(dim, *m);
                let name = format!("[{}]", m[..dim].iter().map(|v| v.to_string()).collect::<String>());
                // Zone edge along n: k n_a h = pi on the largest component.
                let k_edge = std::f64::consts::PI / (h * n.iter().fold(0.0f64, |a, v| a.max(v.abs())));
                let fr: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
                let omegas: Vec<Vec<f64>> =
                    fr.iter().map(|f| s.omegas(&n.iter().map(|v| v * f * k_edge).collect::<Vec<_>>(), RHO)).collect();
                for b in 0..dim {
                    series.push(Series::new(
                        format!("{name} branch {}", b + 1),
                        fr.clone(),
                        omegas.iter().map(|w| w[b]).collect(),
                    ));
                }
                let (cl, ct) = s.long_wave_speeds(&n, RHO);
                let et = ct.iter().map(|c| c / cs - 1.0).fold(0.0f64, |a, e| if e.abs() > a.abs() { e } else { a });
                writeln!(report, "  {model} {dim}D {name}: c_L = {cl:.6} (c_P = {cp:.6}, {:+.2e}), c_T = {ct:.6?} (c_S = {cs:.6}, {et:+.2e})", cl / cp - 1.0)?;
                table.push_str(&format!(
                    "| {model} | {dim} | {name} | {cl:.6} | {cp:.6} | {:+.2e} | {} | {cs:.6} | {et:+.2e} |\n",
                    cl / cp - 1.0,
                    ct.iter().map(|c| format!("{c:.6}")).collect::<Vec<_>>().join(", ")
                ));
                dir_rows.push(json!({"direction": name, "k_edge": k_edge, "k_over_k_edge": fr, "omega": omegas,
                    "c_L": cl, "c_T": ct, "c_P": cp, "c_S": cs}));
            }
            let plot = LinePlot {
                title: format!(
                    "Bloch dispersion, {model} {dim}D{} (delta = 3h, K = rho = 1)",
                    if dim == 2 { " plane strain" } else { "" }
                ),
                x_label: "k / k_edge (k_edge = pi / (h max|n_a|))".into(),
                y_label: "omega".into(),
                series,
                log_x: false,
                log_y: false,
                equal_aspect: false,
            };
            line_plot(&plot, &dir.join(format!("lattice_{model}_{dim}d")))?;
            cases.push(
                json!({"model": model, "dim": dim, "lambda": lambda, "mu": mu, "grid_nodes_per_axis": 2 * reach + 1,
                "stencil_nodes": s.len(), "directions": dir_rows}),
            );
        }
    }
    write_text(&dir.join("lattice_table.md"), &table)?;
    write_text(
        &dir.join("lattice.json"),
        &format!(
            "{:#}",
            json!({"h": h, "delta": delta, "K": k_bulk, "rho": RHO,
        "lps_G": g_lps, "plane": "strain", "cases": cases})
        ),
    )
}

/// Runs the square pulse on the bar; `true` when it blows up (energy x1e3 or non-finite).
fn blows_up(
    op: &BondOperator,
    mass: &LumpedMass,
    fixed: &[(usize, f64)],
    u0: &[f64],
    dt: f64,
    steps: usize,
) -> Result<bool, StudyError> {
    let verlet = Verlet::new(op, mass.clone()).with_fixed(fixed)?;
    let params = VerletParams { output_every: 10, allow_unstable: true, ..VerletParams::new(dt, steps) };
    let mut state = State::at_rest(u0.to_vec());
    let mut e0 = f64::NAN;
    let mut blew = false;
    let r = verlet.run(&mut state, &params, None, |s| {
        if s.step == 0 {
            e0 = s.energy.total();
        }
        let e = s.energy.total();
        if !e.is_finite() || e > 1e3 * e0 {
            blew = true;
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    });
    match r {
        Ok(_) => Ok(blew),
        Err(DynamicsError::Diverged { .. }) => Ok(true),
        Err(e) => Err(e.into()),
    }
}

fn stability(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let ns = [1usize, 2, 3, 5, 10, 20];
    let cases = Cases::new(progress, "stability", ns.len());
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: K1,
        plane: None,
        partial_volume: false,
    };
    let steps = 2000;
    let mut rows = Vec::new();
    let mut table = String::from(
        "| N | dx | dt (4.12) | dt_max exact (2/omega_max) | measured blow-up dt | exact / (4.12) | measured / (4.12) | measured / exact |\n|---|---|---|---|---|---|---|---|\n",
    );
    let (mut dxs, mut b412, mut exact, mut meas) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    writeln!(
        report,
        "square pulse (4.14) on [0, 1000], delta = 5, K_1 = rho = 1, {steps} steps; blow-up = energy x1e3"
    )?;
    for n in ns {
        cases.next(format_args!("N = {n}"));
        let t = Instant::now();
        let dx = DELTA / n as f64;
        let chain = Chain::new(dx, DELTA, &mm)?;
        let dt_exact = lattice_limit(&chain, RHO).dt;
        let dt_412 = paper_bound(RHO, spring_constant(K1, n), n, dx);
        let g = Grid::new(&[0.0], &[1000.0], dx, DELTA, Placement::Vertex)?;
        let op = BondOperator::on_grid(&g, DELTA, &mm, &Material::default())?;
        let fixed: Vec<(usize, f64)> = (0..g.len()).filter(|&i| g.is_layer(i)).map(|i| (i, 0.0)).collect();
        let mass = LumpedMass::uniform(RHO, dx, g.len())?;
        let u0: Vec<f64> = (0..g.len()).map(|i| square_pulse(g.position(i)[0])).collect();
        // Bisection on dt / dt_exact in [0.9, 1.2].
        let (mut lo, mut hi) = (0.9, 1.2);
        if blows_up(&op, &mass, &fixed, &u0, lo * dt_exact, steps)?
            || !blows_up(&op, &mass, &fixed, &u0, hi * dt_exact, steps)?
        {
            return Err(StudyError::Check(format!("N = {n}: the blow-up limit is not in [0.9, 1.2] dt_max")));
        }
        for _ in 0..12 {
            let mid = 0.5 * (lo + hi);
            if blows_up(&op, &mass, &fixed, &u0, mid * dt_exact, steps)? {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let dt_meas = 0.5 * (lo + hi) * dt_exact;
        writeln!(report,
            "N = {n:2}, dx = {dx:.4}: (4.12) {dt_412:.6}, exact {dt_exact:.6}, measured {dt_meas:.6} (stable at {:.6}, blows up at {:.6}); exact/(4.12) = {:.4}, measured/(4.12) = {:.4}, measured/exact = {:.5} [{:.1} s]",
            lo * dt_exact,
            hi * dt_exact,
            dt_exact / dt_412,
            dt_meas / dt_412,
            dt_meas / dt_exact,
            t.elapsed().as_secs_f64()
        )?;
        table.push_str(&format!(
            "| {n} | {dx:.4} | {dt_412:.6} | {dt_exact:.6} | {dt_meas:.6} | {:.4} | {:.4} | {:.5} |\n",
            dt_exact / dt_412,
            dt_meas / dt_412,
            dt_meas / dt_exact
        ));
        rows.push(json!({"N": n, "dx": dx, "dt_4_12": dt_412, "dt_exact": dt_exact, "dt_measured": dt_meas,
            "dt_stable": lo * dt_exact, "dt_unstable": hi * dt_exact, "nodes": g.len()}));
        dxs.push(dx);
        b412.push(dt_412);
        exact.push(dt_exact);
        meas.push(dt_meas);
    }
    let mut m = Series::new("measured blow-up (square pulse)", dxs.clone(), meas);
    m.style = SeriesStyle::Markers;
    let mut e = Series::new("exact 2/omega_max", dxs.clone(), exact);
    e.style = SeriesStyle::LineMarkers;
    let plot = LinePlot {
        title: "velocity-Verlet stability limit vs dx (delta = 5, K_1 = rho = 1)".into(),
        x_label: "dx".into(),
        y_label: "dt".into(),
        series: vec![Series::new("(4.12)", dxs, b412), e, m],
        log_x: false,
        log_y: false,
        equal_aspect: false,
    };
    line_plot(&plot, &dir.join("stability"))?;
    write_text(&dir.join("table.md"), &table)?;
    write_data(
        dir,
        &json!({"study": "stability", "K1": K1, "rho": RHO, "delta": DELTA, "domain": [0.0, 1000.0], "steps": steps,
        "blow_up": "total energy above 1e3 x its initial value, or non-finite", "cases": rows}),
    )
}
