//! `linpd study md-pd`: section 4.4 of Seleson, Parks, Gunzburger & Lehoucq (2009),
//! "Peridynamics as an upscaling of molecular dynamics" (Figs. 4.3-4.6, Table 4.1), on the
//! nonlocal-spring lattice (`K_1 = rho = 1`, `Omega = [0, 1000]`, smooth pulse `p(x)` at 500).
//!
//! Models (all `Chain::springs(K_1, N, dx)`, `K(N) = 2 K_1/(N (N+1))`, velocity Verlet):
//! MD (`a = 1`, `N = 5`), fine PD (`dx = 0.1`, `N = 50`), coarse PD (`dx = 1.25`, `N = 4` and
//! `dx = 2.5`, `N = 2`; horizon 5 for all three), CCM (`N = 1`, `dx = 0.1`: the classical wave
//! equation) and local MD (`a = 1`, `N = 1`, Fig. 4.5(a)). The domain is closed on itself (a ring
//! of length 1000): the waves travel at speed `sqrt(K_1/rho) = 1`, so by `t = 150` they reach
//! `[340, 660]` and never meet the "ends", exactly as with fixed ends far away.
//!
//! Smooth pulse: `dt` by (4.13) with `dt_0 = 1` per model, rounded down so that an integer number
//! of steps ends at `t = 150.05` (Fig. 4.4). Square pulse (4.14): `dt = 0.0649` for all models
//! (Fig. 4.6), snapshots at `t ~ 50` and `t ~ 150`.

use crate::out::{create_dir, write, Cases};
use crate::StudyError;
use linpd_core::progress::Progress;
use linpd_dynamics::initial::{smooth_pulse, square_pulse};
use linpd_dynamics::stability::refinement_dt;
use linpd_dynamics::{Chain, DtLimit, Ring, State, Verlet, VerletParams};
use linpd_plot::{line_plot, scalar_map_png, LinePlot, ScalarMap, Series};
use serde_json::json;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

/// Study name (in `data.json`).
const NAME: &str = "md-pd";
const L: f64 = 1000.0;
const K1: f64 = 1.0;
const RHO: f64 = 1.0;
const DT0: f64 = 1.0;
const T_SMOOTH: f64 = 150.05;
const DT_SQUARE: f64 = 0.0649;
const T_SQUARE: [f64; 2] = [50.0, 150.0];
/// Window of reference positions kept in plots and data (the pulses stay inside it).
const WIN: (f64, f64) = (320.0, 680.0);
/// Cap on density-map cells per axis.
const MAP_COLS: usize = 400;
const MAP_ROWS: usize = 200;

struct Model {
    key: &'static str,
    label: &'static str,
    dx: f64,
    n: usize,
}

const MODELS: &[Model] = &[
    Model { key: "md", label: "MD (a = 1, N = 5)", dx: 1.0, n: 5 },
    Model { key: "pd_fine", label: "fine PD (dx = 0.1, N = 50)", dx: 0.1, n: 50 },
    Model { key: "pd_coarse", label: "coarse PD (dx = 1.25, N = 4)", dx: 1.25, n: 4 },
    Model { key: "pd_coarser", label: "coarse PD (dx = 2.5, N = 2)", dx: 2.5, n: 2 },
    Model { key: "ccm", label: "CCM (dx = 0.1, N = 1)", dx: 0.1, n: 1 },
    Model { key: "md_local", label: "local MD (a = 1, N = 1)", dx: 1.0, n: 1 },
];

struct Run {
    nx: usize,
    dt: f64,
    steps: usize,
    /// (t, u) at the requested steps.
    snaps: Vec<(f64, Vec<f64>)>,
    /// Density rows (window columns, strided) and their times.
    map: Vec<Vec<f64>>,
    map_t: Vec<f64>,
    map_stride: (usize, usize),
    drift_total: f64,
    drift_shadow: f64,
    wall: f64,
}

impl Run {
    fn bond_updates(&self, n: usize) -> f64 {
        (self.nx * n) as f64 * self.steps as f64
    }
}

/// Nodes of the window `WIN`.
fn window(m: &Model, nx: usize) -> (usize, usize) {
    let lo = (WIN.0 / m.dx).ceil() as usize;
    let hi = ((WIN.1 / m.dx).floor() as usize).min(nx - 1);
    (lo, hi)
}

fn simulate(
    m: &Model,
    u0: impl Fn(f64) -> f64,
    dt: f64,
    steps: usize,
    snap_steps: &[usize],
    with_map: bool,
) -> Result<Run, StudyError> {
    let start = Instant::now();
    let nx = (L / m.dx).round() as usize;
    let ring: Ring = Chain::springs(K1, m.n, m.dx)?.ring(nx)?;
    let limit = ring.dt_limit(RHO);
    let verlet = Verlet::new(&ring, ring.mass(RHO)?);
    let params = VerletParams { output_every: 1, limit: DtLimit::Given(limit), ..VerletParams::new(dt, steps) };
    let mut state = State::at_rest((0..nx).map(|i| u0(ring.position(i))).collect());
    let (lo, hi) = window(m, nx);
    let col_stride = (hi - lo + 1).div_ceil(MAP_COLS);
    let row_stride = (steps + 1).div_ceil(MAP_ROWS).max(1);
    let two_dx = 2.0 * m.dx;
    let (mut snaps, mut map, mut map_t) = (Vec::new(), Vec::new(), Vec::new());
    let (mut e0, mut s0, mut drift_total, mut drift_shadow) = (0.0, 0.0, 0.0f64, 0.0f64);
    verlet.run(&mut state, &params, None, |s| {
        if s.step == 0 {
            e0 = s.energy.total();
            s0 = s.energy.shadow;
        }
        drift_total = drift_total.max(((s.energy.total() - e0) / e0).abs());
        drift_shadow = drift_shadow.max(((s.energy.shadow - s0) / s0).abs());
        if snap_steps.contains(&s.step) {
            snaps.push((s.t, s.u.to_vec()));
        }
        if with_map && s.step % row_stride == 0 {
            let row = (lo..=hi)
                .step_by(col_stride)
                .map(|j| two_dx / (two_dx + s.u[(j + 1) % nx] - s.u[(j + nx - 1) % nx]))
                .collect();
            map.push(row);
            map_t.push(s.t);
        }
        ControlFlow::Continue(())
    })?;
    Ok(Run {
        nx,
        dt,
        steps,
        snaps,
        map,
        map_t,
        map_stride: (col_stride, row_stride),
        drift_total,
        drift_shadow,
        wall: start.elapsed().as_secs_f64(),
    })
}

/// Positions and values of `u` inside `[a, b]`.
fn cut(m: &Model, u: &[f64], a: f64, b: f64) -> (Vec<f64>, Vec<f64>) {
    (0..u.len()).map(|i| (i as f64 * m.dx, u[i])).filter(|(x, _)| *x >= a && *x <= b).unzip()
}

/// Every `stride`-th entry, `stride = ceil(len / 800)` (keeps data.json small).
fn thin(v: Vec<f64>) -> Vec<f64> {
    let stride = v.len().div_ceil(800).max(1);
    v.into_iter().step_by(stride).collect()
}

fn density_map(m: &Model, r: &Run, dir: &Path, what: &str) -> Result<(), StudyError> {
    let (lo, _) = window(m, r.nx);
    let ncol = r.map[0].len();
    let h = m.dx * r.map_stride.0 as f64;
    let x0 = lo as f64 * m.dx - 0.5 * h;
    let dtr = r.dt * r.map_stride.1 as f64;
    let ny = r.map.len();
    let values: Vec<f64> = r.map.iter().flatten().copied().collect();
    let map = ScalarMap {
        title: format!("{what}: density (x_j+1 - x_j-1)/(y_j+1 - y_j-1), {} ", m.label),
        x_label: "reference position x".into(),
        y_label: "time t".into(),
        nx: ncol,
        ny,
        x_range: (x0, x0 + ncol as f64 * h),
        y_range: (r.map_t[0] - 0.5 * dtr, r.map_t[0] - 0.5 * dtr + ny as f64 * dtr),
        values,
        value_label: "density".into(),
        empty: Vec::new(),
        equal_aspect: false,
    };
    // the PNG only: the SVG of a cell map is megabytes
    scalar_map_png(&map, &dir.join(format!("density_{}", m.key)))?;
    Ok(())
}

/// A smooth-pulse run: the model, its `dt` by (4.13) and the run.
type SmoothRun = (&'static Model, f64, Run);
/// A square-pulse run: the model and the run.
type SquareRun = (&'static Model, Run);

/// Runs the study into `dir`.
pub(crate) fn run(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Every model twice: the smooth pulse, then the square pulse.
    let cases = Cases::new(progress, "md-pd", 2 * MODELS.len());
    create_dir(dir)?;
    let total = Instant::now();

    // ---- Smooth pulse (Figs. 4.3-4.5, Table 4.1) ----
    let smooth = smooth_runs(report, &cases)?;
    smooth_plots(dir, &smooth)?;
    let shape = smooth_shape(report, &smooth)?;
    let (paper_ratio, costs) = table_4_1(report, &smooth)?;

    // ---- Square pulse (Fig. 4.6): dt = 0.0649 for all ----
    let (square, sq_runs) = square_runs(report, &cases)?;
    square_plots(dir, &sq_runs)?;

    let wall = total.elapsed().as_secs_f64();
    writeln!(report, "total wall {wall:.1} s")?;
    let data = json!({
        "study": NAME, "K1": K1, "rho": RHO, "dt0": DT0, "domain": [0.0, L], "boundary": "periodic (ring of length 1000)",
        "window": [WIN.0, WIN.1],
        "smooth": {"t_final": T_SMOOTH, "runs": smooth_json(&smooth), "shape": shape},
        "table_4_1": {"paper_relative_cost": 0.22, "paper_recomputed": paper_ratio, "runs": costs},
        "square": {"dt": DT_SQUARE, "t_requested": T_SQUARE, "runs": square},
        "wall_seconds": wall,
    });
    write(dir, &data)
}

/// The smooth pulse on every model with `dt` by (4.13) (`dt_0 = 1`), rounded down so that an
/// integer number of steps ends at `t = T_SMOOTH`; prints a row per model.
fn smooth_runs(report: &mut dyn Write, cases: &Cases) -> Result<Vec<SmoothRun>, StudyError> {
    writeln!(
        report,
        "smooth pulse p(x) at 500 on the ring [0, 1000), K_1 = rho = 1, dt by (4.13) with dt_0 = {DT0}, t = {T_SMOOTH}"
    )?;
    writeln!(
        report,
        "{:<30} {:>6} {:>3} {:>9} {:>9} {:>6} {:>12} {:>10} {:>10} {:>7}",
        "model", "Nx", "N", "dt (4.13)", "dt used", "Nt", "Nx N Nt", "dE/E", "dE~/E~", "wall s"
    )?;
    let mut smooth = Vec::new();
    for m in MODELS {
        cases.next(format_args!("smooth pulse, {}", m.label));
        let dt_rule = refinement_dt(DT0, RHO, K1, m.n, m.dx);
        let steps = (T_SMOOTH / dt_rule).ceil() as usize;
        let dt = T_SMOOTH / steps as f64;
        let r = simulate(m, smooth_pulse, dt, steps, &[steps], true)?;
        writeln!(
            report,
            "{:<30} {:>6} {:>3} {:>9.5} {:>9.5} {:>6} {:>12.4e} {:>10.2e} {:>10.2e} {:>7.2}",
            m.label,
            r.nx,
            m.n,
            dt_rule,
            dt,
            steps,
            r.bond_updates(m.n),
            r.drift_total,
            r.drift_shadow,
            r.wall
        )?;
        smooth.push((m, dt_rule, r));
    }
    Ok(smooth)
}

/// The smooth-pulse run of the model `key`.
fn smooth_run<'a>(smooth: &'a [SmoothRun], key: &str) -> &'a SmoothRun {
    smooth.iter().find(|(m, _, _)| m.key == key).expect("every key names a model of MODELS")
}

/// The models of the snapshot plots (Fig. 4.4), in drawing order.
const SNAPSHOT_MODELS: [&str; 5] = ["ccm", "pd_fine", "md", "pd_coarse", "pd_coarser"];

/// The density maps of every smooth-pulse run and the displacement snapshots at the final
/// time: Fig. 4.4 (all models, and a zoom on the left-going pulse) and Fig. 4.5 (local vs
/// nonlocal MD).
fn smooth_plots(dir: &Path, smooth: &[SmoothRun]) -> Result<(), StudyError> {
    for (m, _, r) in smooth {
        density_map(m, r, dir, "smooth pulse")?;
    }
    let snapshot = |keys: &[&str], a: f64, b: f64, title: &str, stem: &str| -> Result<(), StudyError> {
        let series = keys
            .iter()
            .map(|k| {
                let (m, _, r) = smooth_run(smooth, k);
                let (x, u) = cut(m, &r.snaps[0].1, a, b);
                Series::new(m.label, x, u)
            })
            .collect();
        let plot = LinePlot {
            title: title.into(),
            x_label: "x".into(),
            y_label: "u".into(),
            series,
            log_x: false,
            log_y: false,
            equal_aspect: false,
        };
        line_plot(&plot, &dir.join(stem)).map(|_| ()).map_err(StudyError::from)
    };
    let all = SNAPSHOT_MODELS;
    snapshot(&all, WIN.0, WIN.1, &format!("smooth pulse, displacement at t = {T_SMOOTH}"), "snapshot")?;
    snapshot(
        &all,
        330.0,
        420.0,
        &format!("smooth pulse at t = {T_SMOOTH}, zoom on the left-going wave"),
        "snapshot_zoom",
    )?;
    snapshot(
        &["md_local", "md"],
        WIN.0,
        WIN.1,
        &format!("local vs nonlocal MD at t = {T_SMOOTH} (Fig. 4.5)"),
        "snapshot_local_vs_nonlocal",
    )
}

/// The left-going peak (d'Alembert: 0.5) and the dispersive tail per model: the amplitude of
/// the trailing ripple behind the left-going front, `|u|` on `[365, 420]` (d'Alembert: the
/// wave occupies `[340, 360]` at `t = 150.05`, zero elsewhere). Prints them; returns them for
/// data.json.
fn smooth_shape(report: &mut dyn Write, smooth: &[SmoothRun]) -> Result<Vec<serde_json::Value>, StudyError> {
    let tail = |key: &str| {
        let (m, _, r) = smooth_run(smooth, key);
        let (_, u) = cut(m, &r.snaps[0].1, 365.0, 420.0);
        u.iter().fold(0.0f64, |a, v| a.max(v.abs()))
    };
    let peak = |key: &str| {
        let (m, _, r) = smooth_run(smooth, key);
        let (_, u) = cut(m, &r.snaps[0].1, WIN.0, 500.0);
        u.iter().fold(0.0f64, |a, v| a.max(*v))
    };
    writeln!(
        report,
        "smooth pulse at t = {T_SMOOTH}: left-going peak (d'Alembert 0.5) and trailing ripple max|u| on [365, 420]:"
    )?;
    let mut shape = Vec::new();
    for k in SNAPSHOT_MODELS.iter().chain(&["md_local"]) {
        writeln!(report, "  {:<30} peak {:.4}  ripple {:.3e}", smooth_run(smooth, k).0.label, peak(k), tail(k))?;
        shape.push(json!({"model": k, "peak": peak(k), "ripple_365_420": tail(k)}));
    }
    Ok(shape)
}

/// Table 4.1: the cost `Nx N Nt` of every smooth-pulse run relative to MD's, printed and
/// returned for data.json with the paper's ratio recomputed from its `Nx`, `N`, `Nt`.
fn table_4_1(report: &mut dyn Write, smooth: &[SmoothRun]) -> Result<(f64, Vec<serde_json::Value>), StudyError> {
    let cost_md = smooth_run(smooth, "md").2.bond_updates(5);
    let paper_ratio = (2001.0 * 10.0 * 162.0) / (4001.0 * 20.0 * 184.0);
    writeln!(report, "Table 4.1 (cost = Nx N Nt, relative to MD): paper 0.22 ({paper_ratio:.4} from its Nx, N, Nt)")?;
    let mut costs = Vec::new();
    for (m, _, r) in smooth {
        let rel = r.bond_updates(m.n) / cost_md;
        writeln!(report, "  {:<30} Nx {:>6} N {:>3} Nt {:>5} relative cost {:.3}", m.label, r.nx, m.n, r.steps, rel)?;
        costs.push(
            json!({"model": m.key, "Nx": r.nx, "N": m.n, "Nt": r.steps, "cost": r.bond_updates(m.n), "relative": rel}),
        );
    }
    Ok((paper_ratio, costs))
}

/// The smooth-pulse runs for data.json (the window of the final displacement, thinned).
fn smooth_json(smooth: &[SmoothRun]) -> Vec<serde_json::Value> {
    smooth
        .iter()
        .map(|(m, dt_rule, r)| {
            let (x, u) = cut(m, &r.snaps[0].1, WIN.0, WIN.1);
            json!({"model": m.key, "label": m.label, "dx": m.dx, "N": m.n, "horizon": m.dx * m.n as f64, "Nx": r.nx,
                "dt_4_13": dt_rule, "dt": r.dt, "steps": r.steps, "t_final": r.dt * r.steps as f64,
                "bond_updates": r.bond_updates(m.n), "energy_drift_total": r.drift_total, "energy_drift_shadow": r.drift_shadow,
                "wall_seconds": r.wall, "x": thin(x), "u_final": thin(u)})
        })
        .collect()
}

/// Overshoot above the d'Alembert maximum 0.5 and undershoot below 0 of a square-pulse
/// snapshot, over the ring or near the travelling fronts only, and its total variation.
struct SquareStats {
    /// `(overshoot, undershoot)` per snapshot, over the ring.
    whole: Vec<(f64, f64)>,
    /// The same near the fronts: d'Alembert supports `[490 -+ t, 510 -+ t]` widened by 10 (the
    /// short waves of MD/PD lag behind near `x = 490, 510`).
    front: Vec<(f64, f64)>,
    /// Total variation over the ring (d'Alembert: 4 jumps of 0.5 = 2): counts every wiggle.
    tv: Vec<f64>,
}

impl SquareStats {
    fn of(m: &Model, r: &Run) -> Self {
        let whole = r
            .snaps
            .iter()
            .map(|(_, u)| {
                let mx = u.iter().fold(f64::MIN, |a, v| a.max(*v));
                let mn = u.iter().fold(f64::MAX, |a, v| a.min(*v));
                (mx - 0.5, -mn)
            })
            .collect();
        let front = r
            .snaps
            .iter()
            .map(|(t, u)| {
                let near = |x: f64| (x >= 480.0 - t && x <= 520.0 - t) || (x >= 480.0 + t && x <= 520.0 + t);
                let vals: Vec<f64> = (0..u.len()).filter(|&i| near(i as f64 * m.dx)).map(|i| u[i]).collect();
                (vals.iter().fold(f64::MIN, |a, v| a.max(*v)) - 0.5, -vals.iter().fold(f64::MAX, |a, v| a.min(*v)))
            })
            .collect();
        let tv = r.snaps.iter().map(|(_, u)| (0..u.len()).map(|i| (u[(i + 1) % u.len()] - u[i]).abs()).sum()).collect();
        SquareStats { whole, front, tv }
    }
}

/// The square pulse (4.14) on every model with `dt = DT_SQUARE`, snapshots at `T_SQUARE`;
/// prints a row per model and the front statistics; returns the runs for data.json and the
/// runs themselves.
fn square_runs(report: &mut dyn Write, cases: &Cases) -> Result<(Vec<serde_json::Value>, Vec<SquareRun>), StudyError> {
    let snap_steps: Vec<usize> = T_SQUARE.iter().map(|t| (t / DT_SQUARE).round() as usize).collect();
    let steps = *snap_steps.last().unwrap();
    writeln!(report,
        "square pulse (4.14), dt = {DT_SQUARE} for all, snapshots at t = {:.4}, {:.4}; d'Alembert: two pulses of height 0.5",
        snap_steps[0] as f64 * DT_SQUARE,
        snap_steps[1] as f64 * DT_SQUARE
    )?;
    writeln!(
        report,
        "{:<30} {:>10} {:>10} {:>8} {:>10} {:>10} {:>8} {:>9} {:>9} {:>7}",
        "model", "over t1", "under t1", "TV t1", "over t2", "under t2", "TV t2", "dE/E", "dE~/E~", "wall s"
    )?;
    let mut square = Vec::new();
    let mut sq_runs = Vec::new();
    let mut fronts = Vec::new();
    for m in MODELS {
        cases.next(format_args!("square pulse, {}", m.label));
        let r = simulate(m, square_pulse, DT_SQUARE, steps, &snap_steps, false)?;
        let SquareStats { whole: stats, front, tv } = SquareStats::of(m, &r);
        writeln!(
            report,
            "{:<30} {:>10.4} {:>10.4} {:>8.2} {:>10.4} {:>10.4} {:>8.2} {:>9.2e} {:>9.2e} {:>7.2}",
            m.label,
            stats[0].0,
            stats[0].1,
            tv[0],
            stats[1].0,
            stats[1].1,
            tv[1],
            r.drift_total,
            r.drift_shadow,
            r.wall
        )?;
        fronts.push(format!(
            "  {:<30} over {:.4} under {:.4} | over {:.4} under {:.4}",
            m.label, front[0].0, front[0].1, front[1].0, front[1].1
        ));
        square.push(json!({
            "model": m.key, "label": m.label, "dx": m.dx, "N": m.n, "Nx": r.nx, "dt": DT_SQUARE, "steps": steps,
            "t": r.snaps.iter().map(|s| s.0).collect::<Vec<_>>(),
            "overshoot_above_0.5": [stats[0].0, stats[1].0], "undershoot_below_0": [stats[0].1, stats[1].1],
            "total_variation": tv, "total_variation_dalembert": 2.0,
            "front_overshoot_above_0.5": [front[0].0, front[1].0], "front_undershoot_below_0": [front[0].1, front[1].1],
            "energy_drift_total": r.drift_total, "energy_drift_shadow": r.drift_shadow, "wall_seconds": r.wall,
            "x": thin(cut(m, &r.snaps[0].1, WIN.0, WIN.1).0),
            "u_t1": thin(cut(m, &r.snaps[0].1, WIN.0, WIN.1).1), "u_t2": thin(cut(m, &r.snaps[1].1, WIN.0, WIN.1).1),
        }));
        sq_runs.push((m, r));
    }
    writeln!(report, "square pulse near the travelling fronts ([480, 520] -+ t), t1 | t2:")?;
    for f in &fronts {
        writeln!(report, "{f}")?;
    }
    Ok((square, sq_runs))
}

/// Fig. 4.6: the left half of the square pulse at each snapshot time, MD and PD models in one
/// plot, CCM in another.
fn square_plots(dir: &Path, sq_runs: &[SquareRun]) -> Result<(), StudyError> {
    for (i, t) in T_SQUARE.iter().enumerate() {
        for (ccm, stem) in [(false, "md_pd"), (true, "ccm")] {
            let series = sq_runs
                .iter()
                .filter(|(m, _)| {
                    if ccm {
                        m.key == "ccm"
                    } else {
                        ["md", "pd_fine", "pd_coarse", "pd_coarser"].contains(&m.key)
                    }
                })
                .map(|(m, r)| {
                    let (x, u) = cut(m, &r.snaps[i].1, WIN.0, 500.0);
                    Series::new(m.label, x, u)
                })
                .collect();
            let plot = LinePlot {
                title: format!("square pulse (4.14), dt = {DT_SQUARE}, t = {:.3}, left half", r_t(sq_runs, i)),
                x_label: "x".into(),
                y_label: "u".into(),
                series,
                log_x: false,
                log_y: false,
                equal_aspect: false,
            };
            line_plot(&plot, &dir.join(format!("square_{stem}_t{}", *t as usize)))?;
        }
    }
    Ok(())
}

/// The time of snapshot `i` (the same in every run).
fn r_t(runs: &[SquareRun], i: usize) -> f64 {
    runs[0].1.snaps[i].0
}
