//! `linpd study coarsen-<name>`: the examples of Silling (2010), "A coarsening method for linear
//! peridynamics", section 5 (Figs. 3, 5 and 7), and a speed-versus-error map of a 2D plate.
//! Each study writes `data.json`, PNG and SVG plots into its directory and prints a table.
//!
//! Level 0 of the 1D studies: bar [0, 1], spacing = volume `v = 0.005` (201 nodes),
//! `r0 = 0.05`. Loads are nodal forces on nodes shared by all levels, the same at every level
//! (`Matching::TotalForce`, the crate's default; a body-force density `b` gives `f = b v^0`).
//! The same examples are tests in `crates/linpd-studies/tests/coarsen_examples.rs` (with the
//! tolerances).

use crate::fixtures::{cell_modulus, composite, defect, tent, H, R0};
use crate::out::{plot, write, Cases};
use crate::StudyError;
use linpd_bond::{assemble, BondOperator};
use linpd_coarsen::{
    coarsen, coarsen_with_progress, every_kth, retain_every, Coarsened, LevelModel, Options, StepReport,
};
use linpd_core::progress::{NoProgress, Progress};
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};
use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
use linpd_problem::level_solve::solve_level;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

const N: usize = 201;
/// Larger than the bar: every neighbourhood is the whole body (exact static condensation).
const WHOLE: f64 = 10.0;
/// Radius pairs (r^1, r^2): the paper's (2 r0, 2 r^1), larger ones, the whole body.
const RADII: [(f64, f64); 4] = [(0.1, 0.2), (0.2, 0.4), (0.3, 0.6), (WHOLE, WHOLE)];

fn series(label: &str, x: Vec<f64>, y: Vec<f64>, style: SeriesStyle) -> Series {
    Series { label: label.into(), x, y, style, color: None }
}

fn radius_label(r: f64) -> String {
    if r >= WHOLE {
        "whole body".into()
    } else {
        format!("{r}")
    }
}

// ----------------------------------------------------------------------------------------------
// 1D level-0 models (Examples 5.1-5.3)
// ----------------------------------------------------------------------------------------------

fn level0(c: fn(f64, f64) -> f64) -> Result<LevelModel, StudyError> {
    LevelModel::from_kernel((0..N).map(|i| i as f64 * H).collect(), vec![H; N], R0, c).map_err(StudyError::from)
}

fn chain(m0: &LevelModel, k1: usize, k2: usize, r1: f64, r2: f64) -> Result<(Coarsened, Coarsened), StudyError> {
    let c1 = coarsen(m0, &every_kth(m0.len(), k1), r1)?;
    let c2 = coarsen(&c1.model, &every_kth(c1.model.len(), k2), r2)?;
    Ok((c1, c2))
}

/// Solves a 1D level with prescribed displacements and nodal forces given by level-0 index;
/// returns `(x, u)` of the level's nodes and `u` by level-0 index (NaN where absent).
/// `(x, u, u by level-0 index)` of a 1D level.
type Fields = (Vec<f64>, Vec<f64>, Vec<f64>);

fn solve(m: &LevelModel, fixed: &[(usize, f64)], loads: &[(usize, f64)]) -> Result<Fields, StudyError> {
    let local = |p: usize| {
        m.level0()
            .iter()
            .position(|&q| q == p)
            .ok_or(StudyError::Check(format!("level-0 node {p} is not in the level")))
    };
    let mut f = vec![0.0; m.len()];
    for &(p, v) in loads {
        f[local(p)?] += v;
    }
    let fixed = fixed.iter().map(|&(p, g)| Ok((local(p)?, g))).collect::<Result<Vec<_>, StudyError>>()?;
    let u = solve_level(m, &f, &fixed, &NoProgress)?;
    let mut by0 = vec![f64::NAN; N];
    for (k, &p) in m.level0().iter().enumerate() {
        by0[p] = u[k];
    }
    Ok((m.positions().iter().map(|p| p[0]).collect(), u, by0))
}

/// `(q - x, C(x, q))` of the row at level-0 node `p`, sorted by offset.
fn row(m: &LevelModel, p: usize) -> (Vec<f64>, Vec<f64>) {
    let i = m.level0().iter().position(|&q| q == p).expect("node in level");
    let x = m.positions();
    m.bonds_1d(i).map(|(j, c)| (x[j][0] - x[i][0], c)).unzip()
}

// ----------------------------------------------------------------------------------------------
// coarsen-tent (Fig. 3)
// ----------------------------------------------------------------------------------------------

pub(crate) fn tent_study(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let cases = Cases::new(progress, "coarsen-tent", 2);
    let m0 = level0(tent)?;
    // x = 0.5 (node 100) is a level-1 node; level 2 (every 8th node) has none there: its row is
    // taken at 0.48 (node 96), the level-2 node nearest the centre.
    let (s0, c0) = row(&m0, 100);
    let mut out = vec![json!({"level": 0, "x": 0.5, "radius": R0, "offset": s0, "c": c0})];
    let mut plots = vec![series("C^0 (x = 0.5)", s0, c0, SeriesStyle::LineMarkers)];
    writeln!(
        report,
        "{:>6} {:>11} {:>6} {:>12} {:>12} {:>10} {:>10}",
        "level", "radius", "x", "C(x, x+h_m)", "M/M^0 - 1", "tail", "bonds"
    )?;
    let m_ref = m0.second_moment(100);
    for (r1, r2) in [RADII[0], RADII[3]] {
        cases.next(radius_label(r1));
        let (c1, c2) = chain(&m0, 4, 2, r1, r2)?;
        for (lvl, c, p, x, r) in [(1, &c1, 100, 0.5, r1), (2, &c2, 96, 0.48, r2)] {
            let (s, v) = row(&c.model, p);
            let i = c.model.level0().iter().position(|&q| q == p).unwrap();
            let moment = c.model.second_moment(i) / m_ref - 1.0;
            let near = s.iter().zip(&v).find(|(o, _)| **o > 0.0).map_or(0.0, |t| *t.1);
            writeln!(
                report,
                "{lvl:>6} {:>11} {x:>6} {near:>12.4e} {moment:>+12.3e} {:>10.2e} {:>10}",
                radius_label(r),
                c.report.tail,
                s.len()
            )?;
            out.push(json!({"level": lvl, "x": x, "radius": r, "offset": s.clone(), "c": v.clone(), "moment_rel_error": moment, "report": c.report}));
            // the plot stops at |q - x| = 0.25 (the whole-body rows are < 1e-2 of their peak beyond)
            let (ps, pv): (Vec<f64>, Vec<f64>) =
                s.iter().zip(&v).filter(|(o, _)| o.abs() <= 0.25 + 1e-9).map(|(a, b)| (*a, *b)).unzip();
            plots.push(series(
                &format!("C^{lvl} (x = {x}), r^{lvl} = {}", radius_label(r)),
                ps,
                pv,
                if r >= WHOLE { SeriesStyle::Line } else { SeriesStyle::LineMarkers },
            ));
        }
    }
    write(
        dir,
        &json!({"study": "coarsen-tent", "spacing": H, "r0": R0, "levels": "every 4th, then every 2nd (201 -> 51 -> 26)", "rows": out}),
    )?;
    plot(
        dir,
        "fig3_micromodulus",
        "Fig. 3: tent kernel coarsened (201 -> 51 -> 26 nodes), rows at the centre",
        "bond distance q - x",
        "C(x, q)",
        plots,
        false,
    )
}

// ----------------------------------------------------------------------------------------------
// coarsen-composite (Fig. 5)
// ----------------------------------------------------------------------------------------------

pub(crate) fn composite_study(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let cases = Cases::new(progress, "coarsen-composite", RADII.len());
    let m0 = level0(composite)?;
    let e_eff = cell_modulus(20, composite);
    // leftmost three level-2 nodes fixed, rightmost three loaded with b v^0, b = 0.001
    let fixed = [(0, 0.0), (8, 0.0), (16, 0.0)];
    let loads: Vec<(usize, f64)> = [184, 192, 200].iter().map(|&p| (p, 0.001 * H)).collect();
    let force: f64 = loads.iter().map(|l| l.1).sum();
    let target = force / e_eff;
    // stretch between x = 0.2 and 0.8: level-2 nodes, 6 periods apart, 0.12 from the BCs
    let stretch = |u: &[f64]| (u[160] - u[40]) / 0.6;
    let (x0, u0, by0) = solve(&m0, &fixed, &loads)?;
    let s0 = stretch(&by0);
    writeln!(report, "E_eff (periodic cell) = {e_eff:.6e}, F = {force:.3e}, F/E_eff = {target:.6e}")?;
    writeln!(
        report,
        "{:>6} {:>11} {:>11} {:>14} {:>14} {:>10}",
        "level", "r^1", "r^2", "stretch", "vs F/E_eff", "vs level 0"
    )?;
    writeln!(report, "{:>6} {:>11} {:>11} {s0:>14.6e} {:>+14.3e} {:>10}", 0, "-", "-", s0 / target - 1.0, "-")?;
    let mut table = vec![json!({"level": 0, "stretch": s0, "rel_to_target": s0 / target - 1.0})];
    let mut plots = vec![series("level 0", x0.clone(), u0.clone(), SeriesStyle::Line)];
    let mut fields = vec![json!({"level": 0, "x": x0, "u": u0})];
    for (r1, r2) in RADII {
        cases.next(radius_label(r1));
        let (c1, c2) = chain(&m0, 4, 2, r1, r2)?;
        for (lvl, c, r) in [(1, &c1, r1), (2, &c2, r2)] {
            let (x, u, by) = solve(&c.model, &fixed, &loads)?;
            let s = stretch(&by);
            writeln!(
                report,
                "{lvl:>6} {:>11} {:>11} {s:>14.6e} {:>+14.3e} {:>+10.3e}",
                radius_label(r1),
                radius_label(r2),
                s / target - 1.0,
                s / s0 - 1.0
            )?;
            table.push(json!({"level": lvl, "r1": r1, "r2": r2, "radius": r, "stretch": s, "rel_to_target": s / target - 1.0, "rel_to_level0": s / s0 - 1.0, "tail": c.report.tail}));
            if r1 == RADII[0].0 {
                plots.push(series(
                    &format!("level {lvl} (r^{lvl} = {r})"),
                    x.clone(),
                    u.clone(),
                    SeriesStyle::LineMarkers,
                ));
                fields.push(json!({"level": lvl, "radius": r, "x": x, "u": u}));
            }
        }
    }
    let homogenized = effective_modulus_per_spacing(report, e_eff)?;
    write(
        dir,
        &json!({"study": "coarsen-composite", "e_eff": e_eff, "force": force, "stretch_target": target, "stretch_between": [0.2, 0.8], "stretch": table, "fields": fields, "effective_modulus": homogenized}),
    )?;
    plot(
        dir,
        "fig5_displacement",
        "Fig. 5: striped composite, levels 0, 1, 2 (r^1 = 0.1, r^2 = 0.2)",
        "x",
        "u",
        plots,
        false,
    )?;
    let (spacing, e): (Vec<f64>, Vec<f64>) = homogenized
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|r| Some((r["spacing_over_period"].as_f64()?, r["e_over_m0"].as_f64()?)))
        .unzip();
    let m0 = bar_modulus_of_unit_c();
    let reuss = 2.0 / (1.0 / 10.0 + 1.0);
    let span = vec![0.0, spacing.iter().copied().fold(0.0, f64::max)];
    plot(
        dir,
        "effective_modulus",
        "Striped composite: effective modulus of a coarse level vs its node spacing",
        "coarse node spacing / stripe period",
        "E / m0",
        vec![
            series("level's (H), interior average", spacing, e, SeriesStyle::LineMarkers),
            series(
                "homogenized (periodic cell = level-0 solution)",
                span.clone(),
                vec![e_eff / m0; 2],
                SeriesStyle::Line,
            ),
            series("stripes in series (Reuss)", span, vec![reuss; 2], SeriesStyle::Line),
        ],
        false,
    )
}

/// `(1/2) sum_j C xi_j^2 v` of a homogeneous bar with `C = 1` (bonds of 1..9 spacings a side):
/// `m0 = 285 H^3`, the unit the composite's moduli are given in.
fn bar_modulus_of_unit_c() -> f64 {
    285.0 * H.powi(3)
}

/// The effective modulus `(H)` (interior average of `1/2 sum_j v_j C_ij xi_ij^2`,
/// [`linpd_coarsen::effective_moduli`]) of one coarsening step of the composite on a bar of
/// length 4 (20 periods), keeping every k-th node, k = 1 (level 0), 4, 8, 10, 20, 40, with
/// `r = 0.8` (tail < 1e-6): it equals the homogenized modulus only where a coarse node sits at
/// every period (k = 20, 40); with several nodes per period it is the affine (Voigt-type) bound
/// of the level, which still fluctuates under a uniform load.
fn effective_modulus_per_spacing(report: &mut dyn Write, e_eff: f64) -> Result<Value, StudyError> {
    let n = 801;
    let m0 = LevelModel::from_kernel((0..n).map(|i| i as f64 * H).collect(), vec![H; n], R0, composite)?;
    let unit = bar_modulus_of_unit_c();
    writeln!(
        report,
        "effective modulus per coarse spacing (bar of length 4, r = 0.8): homogenized {:.6} m0, Reuss {:.6} m0",
        e_eff / unit,
        2.0 / 1.1
    )?;
    writeln!(report, "{:>6} {:>10} {:>12} {:>12} {:>10}", "every", "spacing/P", "E/m0", "vs homog.", "spread")?;
    let mut rows = Vec::new();
    for k in [1usize, 4, 8, 10, 20, 40] {
        let level = if k == 1 { m0.clone() } else { coarsen(&m0, &every_kth(n, k), 0.8)?.model };
        let em = linpd_coarsen::effective_moduli(&level, None)
            .ok_or(StudyError::Check(format!("every {k}: no interior node")))?;
        let e = em.voigt[0][0];
        let spacing = k as f64 * H / 0.1;
        writeln!(report, "{k:>6} {spacing:>10.2} {:>12.6} {:>+12.3e} {:>10.2e}", e / unit, e / e_eff - 1.0, em.spread)?;
        rows.push(json!({"every": k, "spacing_over_period": spacing, "e": e, "e_over_m0": e / unit, "rel_to_homogenized": e / e_eff - 1.0, "spread": em.spread, "interior_nodes": em.nodes}));
    }
    Ok(Value::Array(rows))
}

// ----------------------------------------------------------------------------------------------
// coarsen-defect (Fig. 7)
// ----------------------------------------------------------------------------------------------

pub(crate) fn defect_study(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let cases = Cases::new(progress, "coarsen-defect", RADII.len());
    let m0 = level0(defect)?;
    // u = x on the three leftmost and rightmost level-2 nodes (every 9th level-0 node)
    let fixed: Vec<(usize, f64)> = [0, 9, 18, 180, 189, 198].iter().map(|&p| (p, p as f64 * H)).collect();
    let (x0, u0, by0) = solve(&m0, &fixed, &[])?;
    let shared: Vec<usize> = (0..=198).step_by(9).collect();
    let umax = shared.iter().fold(0.0f64, |a, &p| a.max(by0[p].abs()));
    // the shared pair either side of 0.5 (0.495, 0.54) and, per level, its adjacent pair
    let jump_shared = |u: &[f64]| u[108] - u[99];
    let adjacent = [(99, 101), (99, 102), (99, 108)];
    let j0 = jump_shared(&by0);
    writeln!(
        report,
        "{:>6} {:>11} {:>11} {:>16} {:>11} {:>22} {:>14}",
        "level", "r^1", "r^2", "u(.54)-u(.495)", "vs level 0", "adjacent-pair jump", "shared err"
    )?;
    writeln!(
        report,
        "{:>6} {:>11} {:>11} {j0:>16.6e} {:>11} {:>22} {:>14}",
        0,
        "-",
        "-",
        "-",
        format!("{:.5e} (.495-.505)", by0[101] - by0[99]),
        "-"
    )?;
    let mut table =
        vec![json!({"level": 0, "jump_shared": j0, "jump_adjacent": by0[101] - by0[99], "adjacent": [0.495, 0.505]})];
    let window = |x: &[f64], u: &[f64]| -> (Vec<f64>, Vec<f64>) {
        x.iter().zip(u).filter(|(x, _)| (0.35 - 1e-9..=0.65 + 1e-9).contains(*x)).map(|(a, b)| (*a, *b)).unzip()
    };
    let (wx, wu) = window(&x0, &u0);
    let mut plots = vec![series("level 0", wx.clone(), wu.clone(), SeriesStyle::LineMarkers)];
    let mut fields = vec![json!({"level": 0, "x": wx, "u": wu})];
    for (r1, r2) in RADII {
        cases.next(radius_label(r1));
        let (c1, c2) = chain(&m0, 3, 3, r1, r2)?;
        for (lvl, c, r) in [(1, &c1, r1), (2, &c2, r2)] {
            let (x, u, by) = solve(&c.model, &fixed, &[])?;
            let j = jump_shared(&by);
            let (a, b) = adjacent[lvl];
            let ja = by[b] - by[a];
            let e = shared.iter().map(|&p| (by[p] - by0[p]).abs()).fold(0.0, f64::max) / umax;
            writeln!(
                report,
                "{lvl:>6} {:>11} {:>11} {j:>16.6e} {:>+11.3e} {:>22} {e:>14.3e}",
                radius_label(r1),
                radius_label(r2),
                j / j0 - 1.0,
                format!("{ja:.5e} ({:.3}-{:.3})", a as f64 * H, b as f64 * H)
            )?;
            table.push(json!({"level": lvl, "r1": r1, "r2": r2, "radius": r, "jump_shared": j, "jump_rel_error": j / j0 - 1.0,
                "jump_adjacent": ja, "adjacent": [a as f64 * H, b as f64 * H], "shared_rel_error": e, "tail": c.report.tail}));
            if r1 == RADII[0].0 {
                let (wx, wu) = window(&x, &u);
                plots.push(series(
                    &format!("level {lvl} (r^{lvl} = {r})"),
                    wx.clone(),
                    wu.clone(),
                    SeriesStyle::LineMarkers,
                ));
                fields.push(json!({"level": lvl, "radius": r, "x": wx, "u": wu}));
            }
        }
    }
    write(
        dir,
        &json!({"study": "coarsen-defect", "x_defect": 0.5, "mu": 0.1, "levels": "every 3rd, then every 3rd (201 -> 67 -> 23)", "jumps": table, "fields": fields}),
    )?;
    plot(
        dir,
        "fig7_defect",
        "Fig. 7: bar with a defect at x = 0.5, levels 0, 1, 2 (r^1 = 0.1, r^2 = 0.2)",
        "x",
        "u",
        plots,
        false,
    )
}

// ----------------------------------------------------------------------------------------------
// coarsen-speed-vs-error (2D plate)
// ----------------------------------------------------------------------------------------------

/// Plate nodes per side, spacing, horizon in spacings.
const PLATE_N: usize = 121;
const PLATE_H: f64 = 0.1;
const PLATE_M: f64 = 3.0;

fn plate_level0() -> Result<LevelModel, StudyError> {
    let side = (PLATE_N - 1) as f64 * PLATE_H;
    let g = Grid::new(&[0.0, 0.0], &[side, side], PLATE_H, 0.0, Placement::Vertex)?;
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Continuum,
        modulus: 1.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: false,
    };
    let op = BondOperator::on_grid(&g, PLATE_M * PLATE_H, &mm, &Material::default())?;
    let k = assemble(&op, &DofMap::all_free(g.len(), 2));
    LevelModel::from_stiffness(2, g.positions(), vec![g.volume(); g.len()], &k).map_err(StudyError::from)
}

/// Fixed DOFs and nodal forces of the plate BVP at level `m`: every DOF of the shared (level-2,
/// every 4th node per axis) nodes on x = 0 held, a total force 1e-3 in x split equally over the
/// shared nodes on x = max. By level-0 index, so the same at every level.
fn plate_bvp(m0: &LevelModel) -> (Vec<usize>, Vec<(usize, f64)>) {
    let side = (PLATE_N - 1) as f64 * PLATE_H;
    let on = |t: f64| ((t / PLATE_H).round() as usize).is_multiple_of(4);
    let shared: Vec<usize> = (0..m0.len()).filter(|&i| on(m0.positions()[i][0]) && on(m0.positions()[i][1])).collect();
    let left: Vec<usize> = shared.iter().copied().filter(|&i| m0.positions()[i][0] < 1e-9).collect();
    let right: Vec<usize> = shared.iter().copied().filter(|&i| m0.positions()[i][0] > side - 1e-9).collect();
    let f = 1e-3 / right.len() as f64;
    (left, right.iter().map(|&i| (2 * i, f)).collect())
}

/// Solves level `m` with the plate BVP; returns `u` by level-0 node (2 per node, NaN if absent)
/// and the solve time.
fn plate_solve(m: &LevelModel, held: &[usize], loads: &[(usize, f64)]) -> Result<(Vec<f64>, f64), StudyError> {
    let n0 = PLATE_N * PLATE_N;
    let mut local = vec![usize::MAX; n0];
    for (k, &p) in m.level0().iter().enumerate() {
        local[p] = k;
    }
    let t = Instant::now();
    let mut f = vec![0.0; 2 * m.len()];
    for &(dof0, v) in loads {
        f[2 * local[dof0 / 2] + dof0 % 2] += v;
    }
    let fixed: Vec<(usize, f64)> = held.iter().flat_map(|&p| [(2 * local[p], 0.0), (2 * local[p] + 1, 0.0)]).collect();
    let u = solve_level(m, &f, &fixed, &NoProgress)?;
    let secs = t.elapsed().as_secs_f64();
    let mut by0 = vec![f64::NAN; 2 * n0];
    for (k, &p) in m.level0().iter().enumerate() {
        by0[2 * p] = u[2 * k];
        by0[2 * p + 1] = u[2 * k + 1];
    }
    Ok((by0, secs))
}

/// `max |u^m - u^0| / max |u^0|` (Euclidean per node) over the shared nodes.
fn shared_error(u: &[f64], u0: &[f64]) -> f64 {
    let on = |p: usize| (p % PLATE_N).is_multiple_of(4) && (p / PLATE_N).is_multiple_of(4);
    let (mut e, mut m) = (0.0f64, 0.0f64);
    for p in (0..PLATE_N * PLATE_N).filter(|&p| on(p)) {
        e = e.max(((u[2 * p] - u0[2 * p]).powi(2) + (u[2 * p + 1] - u0[2 * p + 1]).powi(2)).sqrt());
        m = m.max((u0[2 * p].powi(2) + u0[2 * p + 1].powi(2)).sqrt());
    }
    e / m
}

fn report_json(r: &StepReport) -> Value {
    json!(r)
}

pub(crate) fn speed_vs_error(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    // Level 1 for r = k delta, k in 2, 3, 4, 6; level 2 on the first three.
    let cases = Cases::new(progress, "coarsen-speed-vs-error", 7);
    let t = Instant::now();
    let m0 = plate_level0()?;
    let t_build = t.elapsed().as_secs_f64();
    let (held, loads) = plate_bvp(&m0);
    let (u0, t_fine) = plate_solve(&m0, &held, &loads)?;
    let d0 = m0.horizon();
    writeln!(report,
        "level 0: {} nodes ({PLATE_N}^2, h = {PLATE_H}, delta = {PLATE_M}h, inverse-distance, plane stress), {} DOFs, built in {t_build:.2} s, fine solve {t_fine:.3} s",
        m0.len(),
        2 * m0.len()
    )?;
    writeln!(
        report,
        "(level 2: 'coarsen s' includes its level-1 step; time ratio = (coarsen s + solve s) / fine solve)"
    )?;
    writeln!(
        report,
        "{:>6} {:>7} {:>8} {:>8} {:>10} {:>10} {:>10} {:>10} {:>11} {:>10}",
        "level", "r/delta", "radius", "nodes", "tail", "coarsen s", "solve s", "time ratio", "rel. error", "hit rate"
    )?;
    let mut rows = Vec::new();
    let mut pts: [(Vec<f64>, Vec<f64>); 2] = [(vec![], vec![]), (vec![], vec![])];
    // Level 2 is built on the level 1 of the same k with the paper's rule r^2 = 2 delta^1
    // (footnote 1; delta^1 = k delta^0 is the level-1 horizon). k delta^1 = k^2 delta^0 would
    // cover most of the plate with dense local problems of several thousand unknowns, and
    // k = 6 (r^2 = 3.6, ~20 s) would take the study past a minute: levels 2 are k = 2, 3, 4.
    let mut level1 = Vec::new();
    for k in [2.0, 3.0, 4.0, 6.0] {
        cases.next(format_args!("level 1, r = {k} delta"));
        let t = Instant::now();
        let c1 = coarsen_with_progress(&m0, &retain_every(&m0, 2)?, &Options::fixed(k * d0), progress)?;
        let t_c1 = t.elapsed().as_secs_f64();
        let (u1, t_s1) = plate_solve(&c1.model, &held, &loads)?;
        let e1 = shared_error(&u1, &u0);
        let ratio = (t_c1 + t_s1) / t_fine;
        writeln!(
            report,
            "{:>6} {:>7} {:>8.3} {:>8} {:>10.2e} {t_c1:>10.3} {t_s1:>10.3} {ratio:>10.2} {e1:>11.3e} {:>10.3}",
            1,
            format!("{k}"),
            k * d0,
            c1.model.len(),
            c1.report.tail,
            c1.report.hit_rate
        )?;
        rows.push(json!({"level": 1, "radius_over_horizon": k, "radius": k * d0, "coarsen_seconds": t_c1, "solve_seconds": t_s1, "time_ratio": ratio, "rel_error": e1, "report": report_json(&c1.report)}));
        pts[0].0.push(ratio);
        pts[0].1.push(e1);
        if k < 6.0 {
            level1.push((k, c1, t_c1));
        }
    }
    for (k, c1, t_c1) in level1 {
        cases.next(format_args!("level 2 on r = {k} delta"));
        let d1 = c1.model.horizon();
        let t = Instant::now();
        let c2 = coarsen_with_progress(&c1.model, &retain_every(&c1.model, 2)?, &Options::fixed(2.0 * d1), progress)?;
        let t_c2 = t.elapsed().as_secs_f64() + t_c1;
        let (u2, t_s2) = plate_solve(&c2.model, &held, &loads)?;
        let e2 = shared_error(&u2, &u0);
        let ratio = (t_c2 + t_s2) / t_fine;
        writeln!(
            report,
            "{:>6} {:>7} {:>8.3} {:>8} {:>10.2e} {t_c2:>10.3} {t_s2:>10.3} {ratio:>10.2} {e2:>11.3e} {:>10.3}",
            2,
            format!("{k}, 2"),
            2.0 * d1,
            c2.model.len(),
            c2.report.tail,
            c2.report.hit_rate
        )?;
        rows.push(json!({"level": 2, "level1_radius_over_horizon": k, "radius_over_horizon": 2.0, "radius": 2.0 * d1, "level1_radius": k * d0,
            "coarsen_seconds": t_c2, "solve_seconds": t_s2, "time_ratio": ratio, "rel_error": e2, "report": report_json(&c2.report)}));
        pts[1].0.push(ratio);
        pts[1].1.push(e2);
    }
    let [(x1, y1), (x2, y2)] = pts;
    write(
        dir,
        &json!({"study": "coarsen-speed-vs-error", "nodes_per_side": PLATE_N, "spacing": PLATE_H, "horizon": d0, "fine_solve_seconds": t_fine, "rows": rows}),
    )?;
    let p = LinePlot {
        title: format!("2D plate {PLATE_N}^2, delta = 3h: coarsening error vs time"),
        x_label: "time ratio (coarsening + coarse solve) / fine solve".into(),
        y_label: "max |u^m - u^0| / max |u^0|".into(),
        series: vec![
            series("level 1 (r = 2, 3, 4, 6 delta^0)", x1, y1, SeriesStyle::LineMarkers),
            series("level 2 (r^1 = 2, 3, 4 delta^0; r^2 = 2 delta^1)", x2, y2, SeriesStyle::LineMarkers),
        ],
        log_x: false,
        log_y: true,
        equal_aspect: false,
    };
    line_plot(&p, &dir.join("speed_vs_error")).map(|_| ()).map_err(StudyError::from)
}
