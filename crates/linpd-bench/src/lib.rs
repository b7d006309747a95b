//! `linpd bench`: assembly, factorization, matvec and CG on the standard cases of the
//! foundation issue, with peak memory per case and, optionally, the Python peers (scipy
//! COO->CSR, CHOLMOD, scipy CG) run on the very same matrices in the same invocation, so every
//! number can be reported as a ratio against a baseline measured alongside it.
//!
//! Cases (`--quick` shrinks every size so the whole run takes seconds, for smoke tests):
//! * `1d-n1e5-m50`: 1D, 10^5 nodes, 50 neighbours per side;
//! * `1d-n1e4-m500`: 1D, 10^4 nodes, 500 neighbours per side;
//! * `3d-20`, `3d-30`, `3d-40`: 3D cubes of 20^3, 30^3, 40^3 nodes, delta = 3h (122 bonds).
//!
//! Every case: inverse-distance kernel with discrete normalization (K = 1); 1D bars clamped on
//! `m` nodes at each end and loaded by a uniform body force; 3D cubes clamped on their three
//! bottom planes and loaded by a downward body force on the top plane.
//!
//! Optional sections (flags of [`BenchArgs`]): `--lps` (module `lps`), `--dynamics` (module
//! `dynamics`), `--coarsen` (module `coarsen`), `--orderings` (module `orderings`: Cholesky
//! orderings on 2D/3D bond and LPS lattices, against CHOLMOD with `--peers`). The Python peers live in `benches/peers/` at the
//! repository root; [`run`] drives them with `--peers`.
//!
//! ```no_run
//! use clap::Parser;
//! #[derive(Parser)]
//! struct Cli {
//!     #[command(flatten)]
//!     bench: linpd_bench::BenchArgs,
//! }
//! let cli = Cli::parse_from(["bench", "--quick", "--out", "/tmp/bench.json"]);
//! let doc = linpd_bench::run(&cli.bench)?;
//! linpd_bench::print_table(&doc, &mut std::io::stdout()).expect("stdout is open");
//! # Ok::<(), linpd_bench::BenchError>(())
//! ```
#![deny(missing_docs)]

mod coarsen;
mod dynamics;
mod lps;
mod orderings;
mod statics;

use clap::Args;
use linpd_bond::{nested_dissection, BondOperator, Pattern, StencilOperator};
use linpd_core::family::lattice_stencil;
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use linpd_solve::{
    pcg, peak_rss_bytes, relative_residual, sym_matvec, CgParams, Cholesky, Jacobi, LinearOperator, ReducedOperator,
    SymCsc,
};
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `linpd bench` (a clap [`Args`] group: flatten it into a parser, or fill it in).
#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Small sizes (seconds in total): checks the pipeline, not the performance.
    #[arg(long)]
    pub quick: bool,
    /// Only run cases whose name contains this string.
    #[arg(long)]
    pub case: Option<String>,
    /// Where to write the JSON results.
    #[arg(long, default_value = "out/bench/bench.json")]
    pub out: PathBuf,
    /// Also run the Python peers (benches/peers/peer_bench.py) on the same matrices and report
    /// ratios. Install them first with `bash benches/peers/install.sh`.
    #[arg(long)]
    pub peers: bool,
    /// Python interpreter for the peers.
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// Largest number of assembly triplets exported to the peers (24 bytes each: a 30^3 cube
    /// has 59M triplets, 1.4 GB, and scipy needs several times that in memory).
    #[arg(long, default_value_t = 40_000_000)]
    pub peers_max_triplets: usize,
    /// Also run the LPS tangent cases (3D cubes 10^3-40^3, delta = 3h).
    #[arg(long)]
    pub lps: bool,
    /// Also run the velocity-Verlet throughput cases (1D 10^5 nodes m = 20, 3D 40^3 delta = 3h)
    /// with the assembled, per-bond and stencil operators.
    #[arg(long)]
    pub dynamics: bool,
    /// Also run the coarsening cases (1D 10^5-10^6 nodes two levels, 2D 200 x 200 one level).
    #[arg(long)]
    pub coarsen: bool,
    /// Also run whole static solves (assembly + setup + solve) of the 3D cantilevers 20^3..150^3
    /// (a cracked and a two-phase one at 70^3) and the 2D plates 101^2..801^2 with Jacobi-PCG,
    /// multigrid-PCG, Cholesky and `auto` (`--case` picks some: 150^3 needs ~12 GiB).
    #[arg(long)]
    pub statics: bool,
    /// Also run the Cholesky orderings cases (nested dissection, its planar first version, AMD,
    /// and METIS when built with the `metis` feature) on 2D/3D bond and 3D LPS lattices; with
    /// `--peers`, CHOLMOD runs on the same matrices.
    #[arg(long)]
    pub orderings: bool,
    /// Run sparse Cholesky on 3D cases up to this many unknowns (AMD fill grows fast in 3D).
    #[arg(long, default_value_t = 30_000)]
    pub direct_max_3d: usize,
}

struct Case {
    name: String,
    dim: usize,
    /// Nodes per axis (total, layers included).
    nodes: usize,
    /// Horizon in lattice units.
    m: usize,
}

fn cases(quick: bool) -> Vec<Case> {
    let c = |name: &str, dim, nodes, m| Case { name: name.into(), dim, nodes, m };
    if quick {
        vec![
            c("1d-n1e5-m50", 1, 2_000, 10),
            c("1d-n1e4-m500", 1, 1_000, 50),
            c("3d-20", 3, 8, 3),
            c("3d-30", 3, 10, 3),
            c("3d-40", 3, 12, 3),
        ]
    } else {
        vec![
            c("1d-n1e5-m50", 1, 100_000, 50),
            c("1d-n1e4-m500", 1, 10_000, 500),
            c("3d-20", 3, 20, 3),
            c("3d-30", 3, 30, 3),
            c("3d-40", 3, 40, 3),
        ]
    }
}

/// The multigrid-PCG solver of the statics section, when linpd-solve offers one.
fn multigrid_solver(params: &CgParams, matrix_free: bool) -> Option<(&'static str, linpd_solve::SolverSpec)> {
    // Matrix-free: the finest level's blocks are computed on demand, never stored.
    let spec = linpd_solve::SolverSpec::Cg {
        params: params.clone(),
        preconditioner: linpd_solve::PreconditionerKind::MULTIGRID,
        matrix_free,
    };
    Some(("cg-multigrid", spec))
}

/// Resets the kernel's peak-RSS counter (`VmHWM`) so each case reports its own peak.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

/// The best seconds of `repeat` calls of `f` (the shared machine's least disturbed run) and the
/// last result (the previous one is dropped before each call).
pub(crate) fn best_of<T>(repeat: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::MAX;
    let mut out = None;
    for _ in 0..repeat.max(1) {
        drop(out.take());
        let t = Instant::now();
        out = Some(f());
        best = best.min(secs(t));
    }
    (best, out.expect("at least one call"))
}

/// Copy bandwidth in bytes/s (read + write counted), best of 5 copies of 256 MiB.
fn copy_bandwidth() -> f64 {
    let n = 32 << 20; // 32 Mi f64 = 256 MiB
    let src = vec![1.0f64; n];
    let mut dst = vec![0.0f64; n];
    let mut best = f64::MAX;
    for _ in 0..5 {
        let t = Instant::now();
        dst.copy_from_slice(&src);
        best = best.min(secs(t));
        std::hint::black_box(&dst);
    }
    (2 * 8 * n) as f64 / best
}

/// Average seconds of `f` over enough calls to last >= 0.3 s.
pub(crate) fn time_avg(mut f: impl FnMut()) -> (f64, usize) {
    f();
    let t = Instant::now();
    let mut calls = 0;
    while secs(t) < 0.3 || calls < 3 {
        f();
        calls += 1;
    }
    (secs(t) / calls as f64, calls)
}

struct Built {
    grid: Grid,
    op: BondOperator,
    mm: Micromodulus,
    horizon: f64,
    dofs: DofMap,
    f: Vec<f64>,
}

fn build(case: &Case) -> Built {
    let h = 1.0;
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane: None,
        partial_volume: false,
    };
    let horizon = case.m as f64 * h;
    let d = case.dim;
    let last = (case.nodes - 1) as f64 * h;
    let grid = Grid::new(&vec![0.0; d], &vec![last; d], h, 0.0, Placement::Vertex).expect("bench grid");
    let op = BondOperator::on_grid(&grid, horizon, &mm, &Material::default()).expect("bench operator");
    let mut mask = vec![false; d * grid.len()];
    let mut f = vec![0.0; d * grid.len()];
    for n in 0..grid.len() {
        let k = grid.lattice_index(n);
        if d == 1 {
            if k[0] < case.m as i64 || k[0] >= (case.nodes - case.m) as i64 {
                mask[n] = true;
            } else {
                f[n] = 1e-3 * grid.volume();
            }
        } else {
            if k[2] < 3 {
                (0..3).for_each(|a| mask[3 * n + a] = true);
            }
            if k[2] == case.nodes as i64 - 1 {
                f[3 * n + 2] = -1e-3 * grid.volume();
            }
        }
    }
    let dofs = DofMap::new(d, &mask);
    let f = dofs.gather(&f);
    Built { grid, op, mm, horizon, dofs, f }
}

/// Writes the per-bond (unsummed) triplets of the reduced matrix, the right-hand side and a
/// descriptor in the format of benches/peers/README.md.
fn export(dir: &Path, name: &str, b: &Built, nnz: usize, max_iter: usize) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let d = b.op.dim();
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..b.op.n_nodes() {
        for (&j, &w) in b.op.family().neighbors(i).iter().zip(b.op.weights(i)) {
            let j = j as usize;
            if j < i {
                continue;
            }
            let e = b.op.unit(i, j);
            // One bond = four blocks: +(i,i), +(j,j), -(i,j), -(j,i).
            for (p, q, s) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                for a in 0..d {
                    for c in 0..d {
                        if let (Some(r), Some(cc)) = (b.dofs.free(d * p + a), b.dofs.free(d * q + c)) {
                            rows.push(r as u64);
                            cols.push(cc as u64);
                            vals.push(s * w * e[a] * e[c]);
                        }
                    }
                }
            }
        }
    }
    let n = b.dofs.n_free() as u64;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{name}.coo.bin")))?);
    for v in [n, n, rows.len() as u64] {
        w.write_all(&v.to_le_bytes())?;
    }
    for v in rows.iter().chain(&cols) {
        w.write_all(&v.to_le_bytes())?;
    }
    for v in &vals {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{name}.rhs.bin")))?);
    w.write_all(&n.to_le_bytes())?;
    for v in &b.f {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let desc = json!({"name": name, "n": n, "nnz": nnz, "cg_rtol": 1e-8, "cg_maxiter": max_iter});
    std::fs::write(dir.join(format!("{name}.json")), desc.to_string())
}

fn run_case(case: &Case, args: &BenchArgs, bw: f64, export_dir: Option<&Path>) -> Value {
    reset_peak_rss();
    eprintln!("[bench] {}: building", case.name);
    let t = Instant::now();
    let b = build(case);
    let t_bonds = secs(t);
    let t = Instant::now();
    let pattern = Pattern::new(&b.op, &b.dofs);
    let t_pattern = secs(t);
    let mut values = vec![0.0; pattern.nnz()];
    let t = Instant::now();
    pattern.fill(&b.op, &b.dofs, &mut values);
    let t_values = secs(t);
    let a = faer::sparse::SparseColMat::new(pattern.symbolic().clone(), values);
    let n = a.nrows();
    let nnz = a.val().len();
    let mut out = json!({
        "dim": case.dim, "nodes": b.grid.len(), "unknowns": n, "bonds": b.op.family().n_bonds(), "nnz_a": nnz,
        "time_bonds": t_bonds, "time_pattern": t_pattern, "time_values": t_values, "time_assembly": t_pattern + t_values,
    });

    // Matvec against the memory-bandwidth bound: at least 16 bytes per stored entry (value +
    // row index), 8 per column pointer, 8 to write y and 8 to read x once.
    let x: Vec<f64> = (0..n).map(|k| (k as f64 * 0.1).sin()).collect();
    let mut y = vec![0.0; n];
    let (t_mv, calls) = time_avg(|| sym_matvec(&a, &x, &mut y));
    let bytes = 16.0 * nnz as f64 + 24.0 * n as f64;
    out["matvec"] = json!({"time": t_mv, "calls": calls, "bytes": bytes, "bound_time": bytes / bw, "ratio_to_bound": t_mv / (bytes / bw)});

    let direct_ok = case.dim == 1 || n <= args.direct_max_3d;
    if direct_ok {
        // 1D: the natural order is the band (and AMD for reference). 3D: nested dissection on
        // the lattice (and AMD for reference).
        let t = Instant::now();
        let first = if case.dim == 1 {
            (0..n).collect()
        } else {
            nested_dissection(&b.grid, &lattice_stencil(case.dim, case.m as f64), &b.dofs)
        };
        let t_ord = secs(t);
        for (key, perm, t_ord) in [("cholesky", Some(first), t_ord), ("cholesky_amd", None, 0.0)] {
            eprintln!("[bench] {}: sparse Cholesky ({key}) on {n} unknowns", case.name);
            // Best of 3, as the peers time CHOLMOD (peer_bench.py --repeat 3).
            let (t_sym, chol) = best_of(3, || Cholesky::analyze_with_ordering(&a, perm.as_deref()).expect("analysis"));
            let (t_num, fac) = best_of(3, || chol.factor(&a).expect("SPD"));
            let t = Instant::now();
            let u = fac.solve(&b.f);
            let t_sol = secs(t);
            let ordering = match (&perm, case.dim) {
                (None, _) => "amd",
                (Some(_), 1) => "natural",
                (Some(_), _) => "nested-dissection",
            };
            out[key] = json!({"ordering": ordering, "time_ordering": t_ord,
                "time_symbolic": t_sym, "time_numeric": t_num, "time_solve": t_sol,
                "nnz_l": chol.nnz_factor(), "rel_residual": relative_residual(&a, true, &u, &b.f)});
        }
    } else {
        out["cholesky"] = json!({"skipped": format!("{n} unknowns > --direct-max-3d {}: AMD fill makes it minutes and many GiB", args.direct_max_3d)});
    }

    if case.dim == 3 {
        eprintln!("[bench] {}: Jacobi-PCG (assembled)", case.name);
        let params = CgParams { rtol: 1e-8, max_iter: 20_000 };
        let jacobi = Jacobi::new(&linpd_solve::diagonal(&a)).expect("SPD diagonal");
        let mut u = vec![0.0; n];
        let t = Instant::now();
        let info = pcg(&SymCsc(&a), &jacobi, &b.f, &mut u, &params);
        let t_cg = secs(t);
        out["cg"] = match info {
            Ok(i) => {
                json!({"time": t_cg, "iterations": i.iterations, "rel_residual": i.rel_residual, "rtol": params.rtol, "max_iter": params.max_iter})
            }
            Err(e) => json!({"error": e.to_string(), "time": t_cg}),
        };
        eprintln!("[bench] {}: Jacobi-PCG (matrix-free stencil)", case.name);
        let st = StencilOperator::new(&b.grid, b.horizon, &b.mm).expect("stencil");
        let red = ReducedOperator::new(&st, &b.dofs);
        let (t_st, _) = time_avg(|| red.apply(&x, &mut y));
        let mut u = vec![0.0; n];
        let t = Instant::now();
        let info = pcg(&red, &jacobi, &b.f, &mut u, &params);
        let t_cg = secs(t);
        out["cg_matrix_free"] = match info {
            Ok(i) => {
                json!({"time": t_cg, "iterations": i.iterations, "rel_residual": i.rel_residual, "rtol": params.rtol, "max_iter": params.max_iter, "apply_time": t_st})
            }
            Err(e) => json!({"error": e.to_string(), "time": t_cg}),
        };
    } else {
        out["cg"] = json!({"skipped": "1D bars have kappa ~ (N/m)^2 (4e6 here): CG needs thousands of iterations; solve 1D directly"});
    }
    out["peak_rss_bytes"] = json!(peak_rss_bytes());
    if let Some(dir) = export_dir {
        // Each bond pair contributes four d x d blocks.
        let triplets = b.op.family().n_bonds() / 2 * 4 * case.dim * case.dim;
        if triplets <= args.peers_max_triplets {
            eprintln!("[bench] {}: exporting triplets for the peers", case.name);
            if let Err(e) = export(dir, &case.name, &b, nnz, 20_000) {
                out["export_error"] = json!(e.to_string());
            }
        }
    }
    out
}

fn ratio(a: Option<f64>, b: Option<f64>) -> Value {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => json!(a / b),
        _ => Value::Null,
    }
}

/// Why a benchmark run failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// Building a grid, micromodulus or operator.
    #[error(transparent)]
    Core(#[from] linpd_core::CoreError),
    /// A coarsening case.
    #[error(transparent)]
    Coarsen(#[from] linpd_coarsen::CoarsenError),
    /// A dynamics case.
    #[error(transparent)]
    Dynamics(#[from] linpd_dynamics::DynamicsError),
    /// The Python peers could not be started.
    #[error("could not run {python} {}: {source}", script.display())]
    PeersStart {
        /// The interpreter (`--python`).
        python: String,
        /// The peers' driver script.
        script: PathBuf,
        /// Why it did not start.
        source: std::io::Error,
    },
    /// The Python peers ran and failed.
    #[error("the peers failed ({0}); install them with `bash benches/peers/install.sh`")]
    PeersFailed(std::process::ExitStatus),
    /// The peers' `peers.json` is not JSON.
    #[error("{}: {source}", path.display())]
    PeersOutput {
        /// The file.
        path: PathBuf,
        /// The parse error.
        source: serde_json::Error,
    },
    /// Reading or writing a file.
    #[error("{}: {source}", path.display())]
    File {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

fn file_error(path: &Path, source: std::io::Error) -> BenchError {
    BenchError::File { path: path.to_path_buf(), source }
}

/// Runs the benchmark: writes the JSON document to `args.out` (and, with `--peers`, the
/// exported matrices and `peers.json` beside it) and returns it. Progress goes to stderr.
pub fn run(args: &BenchArgs) -> Result<Value, BenchError> {
    eprintln!("[bench] measuring copy bandwidth");
    let bw = copy_bandwidth();
    let export_dir = args.peers.then(|| args.out.with_file_name("matrices"));
    let mut results = serde_json::Map::new();
    for case in cases(args.quick) {
        if args.case.as_ref().is_some_and(|c| !case.name.contains(c.as_str())) {
            continue;
        }
        let r = run_case(&case, args, bw, export_dir.as_deref());
        results.insert(case.name.clone(), r);
    }
    let mut doc = json!({
        "machine": {"threads": rayon::current_num_threads(), "copy_bandwidth_bytes_per_s": bw},
        "quick": args.quick,
        "cases": Value::Object(results),
    });
    if args.lps {
        doc["lps"] = crate::lps::run(args.quick);
    }
    if args.statics {
        doc["statics"] =
            crate::statics::run(args.quick, args.case.as_deref(), args.direct_max_3d, export_dir.as_deref());
    }
    if args.orderings {
        doc["orderings"] = crate::orderings::run(args.quick, export_dir.as_deref());
    }
    if args.coarsen {
        doc["coarsen"] = crate::coarsen::run(args.quick)?;
    }
    if args.dynamics {
        doc["dynamics"] = crate::dynamics::run(args.quick, bw)?;
    }
    if let Some(dir) = &export_dir {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../benches/peers/peer_bench.py");
        let peers_out = args.out.with_file_name("peers.json");
        eprintln!("[bench] running the Python peers on {}", dir.display());
        let status = std::process::Command::new(&args.python)
            .arg(&script)
            .arg(dir)
            .arg("--out")
            .arg(&peers_out)
            .status()
            .map_err(|source| BenchError::PeersStart { python: args.python.clone(), script: script.clone(), source })?;
        if !status.success() {
            return Err(BenchError::PeersFailed(status));
        }
        let text = std::fs::read_to_string(&peers_out).map_err(|source| file_error(&peers_out, source))?;
        let peers: Value = serde_json::from_str(&text)
            .map_err(|source| BenchError::PeersOutput { path: peers_out.clone(), source })?;
        let mut ratios = serde_json::Map::new();
        for (name, ours) in doc["cases"].as_object().unwrap().clone() {
            let Some(p) = peers["cases"].get(&name) else { continue };
            let f = |v: &Value| v.as_f64();
            // Ordering + symbolic + numeric (the ordering is timed apart from the analysis).
            let chol_ours = ours["cholesky"]["time_symbolic"]
                .as_f64()
                .zip(ours["cholesky"]["time_numeric"].as_f64())
                .map(|(a, b)| a + b + ours["cholesky"]["time_ordering"].as_f64().unwrap_or(0.0));
            let chol_peer = f(&p["cholesky_analyze"])
                .zip(f(&p["cholesky_factor"]).or(f(&p["cholmod_factor"])))
                .map(|(a, b)| a + b)
                .or(f(&p["cholmod_analyze"]).zip(f(&p["cholmod_factor"])).map(|(a, b)| a + b));
            ratios.insert(name, json!({
                "assembly_speedup_vs_scipy_coo_to_csr": ratio(f(&p["coo_to_csr"]), f(&ours["time_assembly"])),
                "cholesky_numeric_ratio_to_cholmod": ratio(f(&ours["cholesky"]["time_numeric"]), f(&p["cholmod_factor"])),
                "cholesky_total_ratio_to_cholmod": ratio(chol_ours, chol_peer),
                "nnz_l_ratio_to_cholmod": ratio(f(&ours["cholesky"]["nnz_l"]), f(&p["cholmod_nnz_l"])),
                "matvec_ratio_to_scipy": ratio(f(&ours["matvec"]["time"]), f(&p["matvec"])),
                "cg_ratio_to_scipy": ratio(f(&ours["cg"]["time"]), f(&p["cg"])),
            }));
        }
        if args.orderings {
            ratios.insert("orderings".into(), crate::orderings::ratios(&doc["orderings"], &peers));
        }
        if args.statics {
            ratios.insert("statics".into(), crate::statics::ratios(&doc["statics"], &peers));
        }
        doc["peers"] = peers;
        doc["ratios"] = Value::Object(ratios);
    }
    if let Some(parent) = args.out.parent() {
        std::fs::create_dir_all(parent).map_err(|source| file_error(parent, source))?;
    }
    // Written beside the target and renamed into place: a killed or failed bench never leaves a
    // cut document where the previous one was. `Value`'s alternate Display is its pretty JSON
    // and cannot fail.
    let staged = args.out.with_extension(format!("json.tmp-{}", std::process::id()));
    std::fs::write(&staged, format!("{doc:#}")).map_err(|source| file_error(&staged, source))?;
    std::fs::rename(&staged, &args.out).map_err(|source| {
        let _ = std::fs::remove_file(&staged);
        file_error(&args.out, source)
    })?;
    Ok(doc)
}

/// Writes the tables of a document returned by [`run`] to `w` (one row per standard case, then
/// the sections that ran and the ratios against the peers if they ran). An error of `w` (a
/// closed pipe: `linpd bench | head`) ends the writing; the document is already written.
pub fn print_table(doc: &Value, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let g = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
    writeln!(
        w,
        "copy bandwidth {:.2} GB/s, {} threads",
        doc["machine"]["copy_bandwidth_bytes_per_s"].as_f64().unwrap_or(0.0) / 1e9,
        doc["machine"]["threads"]
    )?;
    writeln!(
        w,
        "{:<14} {:>9} {:>11} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8} {:>8}",
        "case", "unknowns", "nnz(A)", "asm s", "mv/bnd", "chol s", "nnzL/A", "cg s", "cg iters", "mf-cg s", "RSS GiB"
    )?;
    for (name, c) in doc["cases"].as_object().into_iter().flatten() {
        let chol =
            c["cholesky"]["time_symbolic"].as_f64().zip(c["cholesky"]["time_numeric"].as_f64()).map(|(a, b)| a + b);
        let fill = c["cholesky"]["nnz_l"].as_f64().zip(c["nnz_a"].as_f64()).map(|(l, a)| l / a);
        writeln!(
            w,
            "{:<14} {:>9} {:>11} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8} {:>8}",
            name,
            c["unknowns"].to_string(),
            c["nnz_a"].to_string(),
            g(&c["time_assembly"]),
            g(&c["matvec"]["ratio_to_bound"]),
            chol.map_or("-".into(), |x| format!("{x:.3}")),
            fill.map_or("-".into(), |x| format!("{x:.2}")),
            g(&c["cg"]["time"]),
            c["cg"]["iterations"].as_u64().map_or("-".into(), |x| x.to_string()),
            g(&c["cg_matrix_free"]["time"]),
            c["peak_rss_bytes"].as_f64().map_or("-".into(), |b| format!("{:.2}", b / 1073741824.0)),
        )?;
    }
    if let Some(st) = doc.get("statics") {
        writeln!(w, "whole static solves (rtol 1e-8; vs jac: Jacobi-PCG total / this total, same run):")?;
        crate::statics::print(st, w)?;
    }
    if let Some(c) = doc.get("coarsen") {
        crate::coarsen::print(c, w)?;
    }
    if let Some(d) = doc.get("dynamics") {
        crate::dynamics::print(d, w)?;
    }
    if let Some(r) = doc.get("ratios") {
        writeln!(w, "ratios against the peers (same run): {r:#}")?;
    }
    Ok(())
}
