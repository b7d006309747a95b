//! `linpd bench --coarsen`: the speed targets of issue #4 (Silling 2010 coarsening).
//!
//! * 1D tent kernel of Example 5.1 (`delta = 10h`), two levels (every 4th, then every 2nd node,
//!   `r^m = 2 delta^{m-1}`), at `10^5`, `3 10^5` and `10^6` level-0 nodes: seconds per level-0
//!   node must stay flat (cost linear in `K_0`, Sec. 6). Target: `10^6` nodes in < 10 s.
//! * 2D bond-based plate, `200 x 200` nodes, `delta = 3h`, one level (every 2nd node per
//!   axis), `r = 2 delta`, with and without the neighbourhood cache. Target: < 60 s. Baseline
//!   in the same run: the sparse Cholesky solve of the level-0 plate (clamped edge).

use crate::BenchError;
use linpd_bond::{assemble, BondOperator};
use linpd_coarsen::{coarsen, coarsen_with, every_kth, retain_every, LevelModel, Options};
use linpd_core::progress::NoProgress;
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};
use linpd_problem::level_solve::solve_level;
use serde_json::{json, Value};
use std::time::Instant;

/// Interaction distance `r0 = 10 h` of the 1D bar (Silling 2010, Example 5.1).
const R0: f64 = 0.05;

/// Example 5.1's tent micromodulus `C0 = 1 - |q - x| / r0` for `0 < |q - x| < r0`, the bond
/// lengths compared with a relative guard of `1e-9` (a bond of exactly 10 spacings, computed
/// as a difference of `i h`, stays out of the family).
fn tent(x: f64, q: f64) -> f64 {
    let d = (q - x).abs();
    if d > 1e-9 * R0 && d < R0 * (1.0 - 1e-9) {
        1.0 - d / R0
    } else {
        0.0
    }
}

fn tent_bar(n: usize) -> LevelModel {
    let h = 0.005;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * h).collect();
    LevelModel::from_kernel(x, vec![h; n], R0, tent).expect("a valid bar")
}

fn case_1d(n: usize) -> Result<Value, BenchError> {
    let t = Instant::now();
    let m0 = tent_bar(n);
    let t_build = t.elapsed().as_secs_f64();
    let c1 = coarsen(&m0, &every_kth(n, 4), 2.0 * m0.horizon())?;
    let c2 = coarsen(&c1.model, &every_kth(c1.model.len(), 2), 2.0 * c1.model.horizon())?;
    let total = t.elapsed().as_secs_f64();
    eprintln!(
        "[bench] coarsen 1D {n:>8} nodes: level 0 build {t_build:.2} s, level 1 {:.2} s (hit rate {:.4}), level 2 {:.2} s (hit rate {:.4}); total {total:.2} s = {:.2} us/node",
        c1.report.seconds_total,
        c1.report.hit_rate,
        c2.report.seconds_total,
        c2.report.hit_rate,
        1e6 * total / n as f64
    );
    Ok(json!({"nodes": n, "seconds_build": t_build, "level1": c1.report, "level2": c2.report,
              "seconds_total": total, "us_per_node": 1e6 * total / n as f64}))
}

fn case_2d(n: usize) -> Result<Value, BenchError> {
    let h = 1.0 / (n - 1) as f64;
    let g = Grid::new(&[0.0, 0.0], &[1.0, 1.0], h, 0.0, Placement::Vertex)?;
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Continuum,
        modulus: 1.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: false,
    };
    let t = Instant::now();
    let op = BondOperator::on_grid(&g, 3.0 * h, &mm, &Material::default())?;
    let k = assemble(&op, &DofMap::all_free(g.len(), 2));
    let m0 = LevelModel::from_stiffness(2, g.positions(), vec![g.volume(); g.len()], &k)?;
    let t_build = t.elapsed().as_secs_f64();
    // baseline: the level-0 static solve (left edge clamped, pull on the right edge)
    let mut fixed = Vec::new();
    let mut f = vec![0.0; 2 * g.len()];
    for (i, p) in m0.positions().iter().enumerate() {
        if p[0] < 1e-12 {
            fixed.push((2 * i, 0.0));
            fixed.push((2 * i + 1, 0.0));
        } else if p[0] > 1.0 - 1e-12 {
            f[2 * i] = 1e-3;
        }
    }
    let t = Instant::now();
    solve_level(&m0, &f, &fixed, &NoProgress)?;
    let t_solve = t.elapsed().as_secs_f64();
    let ret = retain_every(&m0, 2)?;
    let r = 2.0 * m0.horizon();
    let cached = coarsen_with(&m0, &ret, &Options::fixed(r))?;
    let plain = coarsen_with(&m0, &ret, &Options { cache: false, ..Options::fixed(r) })?;
    let (tc, tp) = (cached.report.seconds_total, plain.report.seconds_total);
    eprintln!(
        "[bench] coarsen 2D {n}x{n} delta = 3h, r = 2 delta: cached {tc:.2} s ({} classes, hit rate {:.4}), uncached {tp:.2} s; level-0 build {t_build:.2} s, level-0 Cholesky solve {t_solve:.2} s; ratios cached/solve {:.2}, uncached/solve {:.2}, cached/uncached {:.3}",
        cached.report.classes,
        cached.report.hit_rate,
        tc / t_solve,
        tp / t_solve,
        tc / tp
    );
    Ok(json!({"nodes_per_axis": n, "seconds_build": t_build, "seconds_fine_solve": t_solve,
              "cached": cached.report, "uncached": plain.report,
              "ratio_cached_to_fine_solve": tc / t_solve, "ratio_uncached_to_fine_solve": tp / t_solve}))
}

/// Runs the cases; `quick` uses small sizes (checks the code path only).
pub fn run(quick: bool) -> Result<Value, BenchError> {
    let sizes_1d: &[usize] = if quick { &[20_000, 60_000] } else { &[100_000, 300_000, 1_000_000] };
    let mut one = Vec::new();
    for &n in sizes_1d {
        one.push(case_1d(n)?);
    }
    let two = case_2d(if quick { 60 } else { 200 })?;
    Ok(json!({"one_d": one, "two_d": two}))
}

/// Writes the section returned by [`run`] as a table.
pub fn print(section: &Value, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let f = |v: &Value, p: usize| v.as_f64().map_or("-".to_string(), |x| format!("{x:.p$}"));
    let one = section["one_d"].as_array().cloned().unwrap_or_default();
    let first = one.first().and_then(|c| c["us_per_node"].as_f64()).unwrap_or(f64::NAN);
    writeln!(
        w,
        "coarsen 1D (tent bar, two levels): nodes, seconds, us/node, relative to the smallest (1.00 = linear)"
    )?;
    for c in &one {
        let rel = c["us_per_node"].as_f64().map_or("-".into(), |u| format!("{:.2}", u / first));
        writeln!(
            w,
            "  {:>9} {:>8} s {:>8} us/node {:>6}  hit rates {} / {}",
            c["nodes"],
            f(&c["seconds_total"], 2),
            f(&c["us_per_node"], 2),
            rel,
            f(&c["level1"]["hit_rate"], 4),
            f(&c["level2"]["hit_rate"], 4)
        )?;
    }
    let two = &section["two_d"];
    writeln!(
        w,
        "coarsen 2D {n}x{n} delta = 3h, r = 2 delta: cached {} s ({} classes, hit rate {}), uncached {} s, level-0 solve {} s; cached/solve {}, uncached/solve {}",
        f(&two["cached"]["seconds_total"], 2),
        two["cached"]["classes"],
        f(&two["cached"]["hit_rate"], 4),
        f(&two["uncached"]["seconds_total"], 2),
        f(&two["seconds_fine_solve"], 2),
        f(&two["ratio_cached_to_fine_solve"], 2),
        f(&two["ratio_uncached_to_fine_solve"], 2),
        n = two["nodes_per_axis"]
    )
}
