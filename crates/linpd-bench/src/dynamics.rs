//! `linpd bench --dynamics`: velocity-Verlet throughput with three stiffness operators.
//!
//! Cases (`--quick` shrinks them): 1D bar of 10^5 nodes with m = 20 neighbours per side, and a
//! 3D cube of 40^3 nodes with delta = 3h (122 bonds per interior node). Free ends, inverse
//! distance kernel with discrete normalization, rho = 1, at rest from a smooth displacement.
//!
//! Operators (same matrix `A`, all DOFs):
//! * `assembled`: full CSC storage, parallel [`sym_matvec`] wrapped as a closure in a
//!   [`FnOperator`];
//! * `per_bond`: matrix-free [`BondOperator::apply`] (per-bond weights and neighbour lists);
//! * `stencil`: matrix-free [`StencilOperator::apply`] (one stencil for the whole lattice).
//!
//! Each runs `steps` Verlet steps of `dt = 0.5 dt_G` where `dt_G` is the Gershgorin limit
//! (conservative, so stable; passed as [`DtLimit::Given`], no power iteration), best of `reps`
//! repetitions from the same initial state. The run includes one start-up apply and two energy
//! evaluations (< 1.5% of 200 steps).
//!
//! Bandwidth model, bytes per step (`n` DOFs, `N` nodes, `B` directed bonds, `Z` stored entries):
//! * vectors of the Verlet step: kick+drift reads acc, v, u and writes v, u (5 streams); the
//!   apply reads u and writes Au (2); the acceleration reads Au, 1/M and writes acc (3); the
//!   second half kick reads acc, v and writes v (3): 13 streams of `8 n` bytes;
//! * assembled: `16 Z` (value + row index) `+ 8 n` (column pointers);
//! * per-bond: `12 B` (f64 weight + u32 neighbour index) `+ 20 N` (family offset, i32 lattice
//!   index per node); the lattice index of `j` and the `u_j` gathers are assumed cached;
//! * stencil: vectors only (the stencil is a few KiB).
//!
//! The bound is bytes / copy bandwidth (read + write counted), the ratio is time / bound.

use crate::BenchError;
use linpd_bond::{assemble, BondOperator, StencilOperator};
use linpd_core::{DofMap, FnOperator, Grid, Kernel, LinearOperator, Material, Micromodulus, Normalization, Placement};
use linpd_dynamics::stability::{gershgorin, verlet_limit};
use linpd_dynamics::{DtLimit, LumpedMass, State, Verlet, VerletParams};
use linpd_solve::{peak_rss_bytes, sym_matvec};
use serde_json::{json, Value};
use std::ops::ControlFlow;
use std::time::Instant;

fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Best wall time of `reps` runs of `steps` steps from `u0` at rest; returns it and the final `u`.
fn time_run<A: LinearOperator + ?Sized>(
    op: &A,
    mass: &LumpedMass,
    u0: &[f64],
    dt: f64,
    limit: f64,
    steps: usize,
    reps: usize,
) -> Result<(f64, Vec<f64>), BenchError> {
    let verlet = Verlet::new(op, mass.clone());
    let params = VerletParams { dt, steps, output_every: 0, limit: DtLimit::Given(limit), allow_unstable: false };
    let mut best = f64::MAX;
    let mut last = Vec::new();
    for _ in 0..reps {
        let mut state = State::at_rest(u0.to_vec());
        let t = Instant::now();
        verlet.run(&mut state, &params, None, |_| ControlFlow::Continue(()))?;
        best = best.min(t.elapsed().as_secs_f64());
        last = state.u;
    }
    Ok((best, last))
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
    a.iter().zip(b).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max) / scale
}

/// Runs the dynamics cases and prints a table; `bw` is the copy bandwidth (bytes/s).
pub fn run(quick: bool, bw: f64) -> Result<Value, BenchError> {
    // (name, dim, nodes per axis, horizon / h)
    let cases: [(&str, usize, usize, usize); 2] = if quick {
        [("1d-n1e5-m20", 1, 2_000, 5), ("3d-40-d3", 3, 8, 3)]
    } else {
        [("1d-n1e5-m20", 1, 100_000, 20), ("3d-40-d3", 3, 40, 3)]
    };
    let (steps, reps) = if quick { (20, 2) } else { (200, 3) };
    let mut out = serde_json::Map::new();
    for (name, d, nodes, m) in cases {
        eprintln!("[bench] dynamics {name}: building");
        let h = 1.0;
        let mm = Micromodulus {
            kernel: Kernel::InverseDistance,
            normalization: Normalization::Discrete,
            modulus: 1.0,
            plane: None,
            partial_volume: false,
        };
        let horizon = m as f64 * h;
        let last = (nodes - 1) as f64 * h;
        let grid = Grid::new(&vec![0.0; d], &vec![last; d], h, 0.0, Placement::Vertex)?;
        let n_nodes = grid.len();
        let n = d * n_nodes;
        let mass = LumpedMass::uniform(1.0, grid.volume(), n)?;
        let u0: Vec<f64> = (0..n).map(|k| 1e-3 * (k as f64 * 0.013).sin()).collect();
        let vec_bytes = 13.0 * 8.0 * n as f64;
        let mut ops = serde_json::Map::new();
        let mut entry = |key: &str, time: f64, bytes: f64, bonds: usize, rss: Option<u64>, diff: Option<f64>| {
            let per_step = time / steps as f64;
            let bound = bytes / bw;
            let v = json!({"time": time, "time_per_step": per_step, "steps_per_s": 1.0 / per_step,
                "bond_updates_per_s": bonds as f64 / per_step, "bytes_per_step": bytes, "bound_time_per_step": bound,
                "ratio_to_bound": per_step / bound, "peak_rss_bytes": rss, "max_rel_diff_u_vs_per_bond": diff});
            ops.insert(key.to_string(), v);
        };

        // Matrix-free per bond (also gives the bond count and the Gershgorin limit).
        reset_peak_rss();
        let op = BondOperator::on_grid(&grid, horizon, &mm, &Material::default())?;
        let bonds = op.family().n_bonds();
        let lambda = gershgorin(&op, &mass, &[])?;
        let limit = verlet_limit(lambda);
        let dt = 0.5 * limit;
        eprintln!("[bench] dynamics {name}: per-bond, {steps} steps x {reps}");
        let (t_pb, u_ref) = time_run(&op, &mass, &u0, dt, limit, steps, reps)?;
        entry("per_bond", t_pb, vec_bytes + 12.0 * bonds as f64 + 20.0 * n_nodes as f64, bonds, peak_rss_bytes(), None);

        // Assembled (the BondOperator stays alive during assembly: counted in the peak).
        reset_peak_rss();
        eprintln!("[bench] dynamics {name}: assembling");
        let t = Instant::now();
        let a = assemble(&op, &DofMap::new(d, &vec![false; n]));
        let t_asm = t.elapsed().as_secs_f64();
        drop(op);
        let nnz = a.val().len();
        let apply = FnOperator { n, apply: |x: &[f64], y: &mut [f64]| sym_matvec(&a, x, y) };
        eprintln!("[bench] dynamics {name}: assembled, {steps} steps x {reps}");
        let (t_as, u_as) = time_run(&apply, &mass, &u0, dt, limit, steps, reps)?;
        entry(
            "assembled",
            t_as,
            vec_bytes + 16.0 * nnz as f64 + 8.0 * n as f64,
            bonds,
            peak_rss_bytes(),
            Some(max_rel_diff(&u_as, &u_ref)),
        );
        drop(a);

        // Matrix-free stencil.
        reset_peak_rss();
        let st = StencilOperator::new(&grid, horizon, &mm)?;
        eprintln!("[bench] dynamics {name}: stencil, {steps} steps x {reps}");
        let (t_st, u_st) = time_run(&st, &mass, &u0, dt, limit, steps, reps)?;
        entry("stencil", t_st, vec_bytes, bonds, peak_rss_bytes(), Some(max_rel_diff(&u_st, &u_ref)));

        out.insert(
            name.to_string(),
            json!({"dim": d, "nodes": n_nodes, "dofs": n, "bonds": bonds, "nnz_a": nnz,
            "time_assembly": t_asm, "dt": dt, "dt_limit_gershgorin": limit, "operators": Value::Object(ops)}),
        );
    }
    Ok(
        json!({"steps": steps, "repetitions": reps, "copy_bandwidth_bytes_per_s": bw, "threads": rayon::current_num_threads(),
        "bandwidth_model": "13 vector streams of 8n bytes per step + assembled 16 B/entry + 8 B/column, per-bond 12 B/bond + 20 B/node, stencil vectors only",
        "cases": Value::Object(out)}),
    )
}

/// Writes the section returned by [`run`] as a table.
pub fn print(section: &Value, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let x = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    writeln!(
        w,
        "dynamics: velocity Verlet, {} steps (best of {}), dt = 0.5 x Gershgorin limit, copy bandwidth {:.2} GB/s",
        section["steps"],
        section["repetitions"],
        x(&section["copy_bandwidth_bytes_per_s"]) / 1e9
    )?;
    writeln!(
        w,
        "{:<12} {:<9} {:>9} {:>10} {:>11} {:>9} {:>8} {:>8}",
        "case", "operator", "ms/step", "steps/s", "bond upd/s", "MB/step", "t/bound", "RSS GiB"
    )?;
    for (name, case) in section["cases"].as_object().into_iter().flatten() {
        for (key, o) in case["operators"].as_object().into_iter().flatten() {
            writeln!(
                w,
                "{:<12} {:<9} {:>9.3} {:>10.1} {:>11.3e} {:>9.3} {:>8.2} {:>8.3}",
                name,
                key,
                x(&o["time_per_step"]) * 1e3,
                x(&o["steps_per_s"]),
                x(&o["bond_updates_per_s"]),
                x(&o["bytes_per_step"]) / 1e6,
                x(&o["ratio_to_bound"]),
                x(&o["peak_rss_bytes"]) / 1073741824.0
            )?;
        }
    }
    Ok(())
}
