//! `linpd bench --quick` runs end to end and the JSON it writes is consistent with the problems
//! it claims to have solved (crates/linpd-bench/src/lib.rs): the sizes and stored entries
//! against independent lattice counts, every solve against its stopping rule or the accuracy of
//! a backward-stable factorization. Times are never asserted (docs/benchmarks.md has the
//! measured figures).

use serde_json::Value;
use std::process::Command;

/// The `--quick` cases of `linpd_bench::cases`: (name, dim, nodes per axis, horizon / h).
const CASES: [(&str, usize, usize, usize); 5] = [
    ("1d-n1e5-m50", 1, 2_000, 10),
    ("1d-n1e4-m500", 1, 1_000, 50),
    ("3d-20", 3, 8, 3),
    ("3d-30", 3, 10, 3),
    ("3d-40", 3, 12, 3),
];

/// Counts of a case computed from the lattice alone (no linpd code): free nodes (1D: `m` nodes
/// clamped at each end; 3D: the bottom three planes, `k_z < 3`), directed bonds (pairs with
/// `0 < |k - l| <= m` in lattice units, the family of a horizon of exactly `m h`) and stored
/// entries of the reduced stiffness (both triangles): one `d x d` block per ordered pair of free
/// nodes at lattice distance `<= m`, the diagonal included. Structurally zero entries of
/// `e (x) e` are stored (linpd_bond::assemble keeps the pattern value-independent).
fn lattice_counts(dim: usize, nodes: usize, m: usize) -> (usize, usize, usize) {
    let n = nodes as i64;
    let m = m as i64;
    let free = |k: &[i64]| if dim == 1 { k[0] >= m && k[0] < n - m } else { k[2] >= 3 };
    let inside = |k: &[i64]| k.iter().all(|&c| (0..n).contains(&c));
    let r = |c: usize| if c < dim { -m..=m } else { 0..=0 };
    let mut offsets = Vec::new();
    for a in r(0) {
        for b in r(1) {
            for c in r(2) {
                if a * a + b * b + c * c <= m * m {
                    offsets.push([a, b, c]);
                }
            }
        }
    }
    let (mut n_free, mut bonds, mut blocks) = (0, 0, 0);
    let total = nodes.pow(dim as u32);
    for idx in 0..total {
        let mut k = [0i64; 3];
        let mut rest = idx;
        for c in k.iter_mut().take(dim) {
            *c = (rest % nodes) as i64;
            rest /= nodes;
        }
        let k = &k[..dim];
        for o in &offsets {
            let l: Vec<i64> = (0..dim).map(|c| k[c] + o[c]).collect();
            if !inside(&l) {
                continue;
            }
            if o != &[0, 0, 0] {
                bonds += 1;
            }
            if free(k) && free(&l) {
                blocks += 1;
            }
        }
        if free(k) {
            n_free += 1;
        }
    }
    (dim * n_free, bonds, blocks * dim * dim)
}

fn f(v: &Value, what: &str) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{what} missing or not a number: {v}"))
}

fn u(v: &Value, what: &str) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("{what} missing or not an integer: {v}"))
}

/// A CG record met its own stopping rule: `0 < iterations < max_iter` and the reported
/// relative residual `<= rtol` (the stopping test itself, so no slack). Returns the iterations.
fn cg_converged(c: &Value, rtol: f64, max_iter: u64, what: &str) -> u64 {
    assert!(c.get("error").is_none(), "{what}: {c}");
    let it = u(&c["iterations"], what);
    assert!(it > 0 && it < max_iter, "{what}: {it} iterations (max {max_iter})");
    let r = f(&c["rel_residual"], what);
    assert!(r <= rtol, "{what}: relative residual {r:e} > rtol {rtol:e}");
    it
}

#[test]
fn quick_bench_is_consistent_with_the_problems_it_solved() {
    let dir = std::env::temp_dir().join(format!("linpd-bench-smoke-{}", std::process::id()));
    let out = dir.join("bench.json");
    let run = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["bench", "--quick", "--lps", "--dynamics", "--out"])
        .arg(&out)
        .output()
        .expect("run linpd bench");
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // the tables come from the written document: one row per standard case and per dynamics
    // operator
    let table = String::from_utf8_lossy(&run.stdout);
    assert!(table.contains("dynamics: velocity Verlet"), "{table}");
    for op in ["per_bond", "assembled", "stencil"] {
        assert!(table.lines().any(|l| l.contains(op) && l.contains("3d")), "{op} row: {table}");
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "staged document left behind: {leftovers:?}");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(doc["quick"], true);
    assert_eq!(doc["cases"].as_object().map(|o| o.len()), Some(CASES.len()), "{}", doc["cases"]);
    for (name, dim, nodes, m) in CASES {
        let c = &doc["cases"][name];
        let (unknowns, bonds, nnz) = lattice_counts(dim, nodes, m);
        assert_eq!(u(&c["dim"], name), dim as u64, "{name}");
        assert_eq!(u(&c["nodes"], name), nodes.pow(dim as u32) as u64, "{name}");
        assert_eq!(u(&c["unknowns"], name), unknowns as u64, "{name}: unknowns");
        assert_eq!(u(&c["bonds"], name), bonds as u64, "{name}: directed bonds");
        assert_eq!(u(&c["nnz_a"], name), nnz as u64, "{name}: stored entries of A");
        if dim == 1 {
            // Closed form of the same count: n free consecutive nodes, band of half-width m.
            let n = nodes - 2 * m;
            assert_eq!(nnz, n * (2 * m + 1) - m * (m + 1), "{name}: lattice count vs closed form");
        }

        // Direct solves (every quick case is below --direct-max-3d). A backward-stable
        // Cholesky solve has ||f - A u|| / ||f|| <= c eps kappa(A). The worst quick case is the
        // 1D bar with N/m = 200, kappa ~ (N/m)^2 = 4e4 (the bench's own estimate for 1D
        // bars), so eps kappa = 9e-12; 1e-10 allows c <= 10. The 3D cubes have kappa < 1e2.
        let n = unknowns as u64;
        let nnz_a = nnz as u64;
        for (key, ordering) in
            [("cholesky", if dim == 1 { "natural" } else { "nested-dissection" }), ("cholesky_amd", "amd")]
        {
            let ch = &c[key];
            assert_eq!(ch["ordering"], ordering, "{name} {key}");
            let r = f(&ch["rel_residual"], key);
            assert!(r < 1e-10, "{name} {key}: relative residual {r:e}");
            // L holds at least the lower triangle of A (fill-in only adds entries).
            let nnz_l = u(&ch["nnz_l"], key);
            assert!(nnz_l >= (nnz_a + n) / 2, "{name} {key}: nnz(L) {nnz_l} < nnz(tril A) {}", (nnz_a + n) / 2);
        }

        if dim == 3 {
            let cg = &c["cg"];
            let (rtol, max_iter) = (f(&cg["rtol"], "rtol"), u(&cg["max_iter"], "max_iter"));
            assert_eq!(rtol, 1e-8, "{name}: the bench's documented CG tolerance");
            let it = cg_converged(cg, rtol, max_iter, &format!("{name} cg"));
            // CG terminates in at most n steps in exact arithmetic; at these sizes (< 6000
            // unknowns, Jacobi-scaled lattice operators) round-off cannot delay it that much.
            assert!(it <= n, "{name}: {it} CG iterations for {n} unknowns");
            let mf = &c["cg_matrix_free"];
            let it_mf = cg_converged(mf, f(&mf["rtol"], "rtol"), u(&mf["max_iter"], "max_iter"), &format!("{name} mf"));
            // Same operator (stencil vs assembled, equal to round-off) and the same Jacobi
            // preconditioner: the residual histories agree to ~1e-13 relative, so the stopping
            // test can only trip one iteration apart if a residual lands within that of rtol.
            assert!(it.abs_diff(it_mf) <= 1, "{name}: assembled CG {it} vs matrix-free {it_mf} iterations");
            // The direct solve is at least as accurate as CG stopped at rtol.
            assert!(f(&c["cholesky"]["rel_residual"], "chol") <= f(&cg["rel_residual"], "cg"), "{name}");
        } else {
            assert!(c["cg"]["skipped"].is_string(), "{name}: 1D bars are solved directly only");
        }
    }

    // LPS tangent (quick: 6^3 assembled, 8^3 matrix-free).
    let lps = &doc["lps"];
    let a = &lps["lps-3d-6"];
    assert_eq!(u(&a["dofs"], "dofs"), 3 * 6 * 6 * 6);
    // The bond operator's stored entries on the same grid, from the lattice: all DOFs free.
    let (_, bonds6, _) = lattice_counts(3, 6, 3);
    assert_eq!(u(&a["bond_nnz"], "bond_nnz"), (9 * bonds6 + 9 * 216) as u64);
    // The LPS tangent couples nodes up to 2 delta apart: its pattern strictly contains the
    // bond pattern (delta) on a 6^3 grid whose diameter exceeds delta.
    assert!(f(&a["nnz_ratio_to_bond"], "ratio") > 1.0, "{a}");
    // Central differences of step 1e-6 h: truncation O(1e-12), round-off ~ eps / 1e-6 = 2e-10
    // relative to the largest entry; 1e-8 leaves a factor 50.
    let fd = f(&a["fd_tangent"]["max_rel_difference"], "fd");
    assert!(fd < 1e-8, "finite-difference vs analytic LPS tangent: {fd:e}");
    cg_converged(&a["cg"], 1e-8, 20_000, "lps-3d-6 cg");
    cg_converged(&lps["lps-3d-8"]["cg_matrix_free_unpreconditioned"], 1e-8, 5_000, "lps-3d-8 cg");

    // Dynamics: the three operators are the same matrix, so the Verlet trajectories agree to
    // round-off. Verlet at dt = half the stability limit does not amplify perturbations; each
    // step adds ~ (bonds per node) eps relative, so after `steps` steps the difference is
    // below 1e3 eps steps (122 bonds per node in 3D, plus the update's own rounding).
    let dy = &doc["dynamics"];
    let steps = u(&dy["steps"], "steps");
    assert!(steps > 0);
    let tol = 1e3 * f64::EPSILON * steps as f64;
    let dcases = dy["cases"].as_object().expect("dynamics cases");
    assert_eq!(dcases.len(), 2);
    for (name, c) in dcases {
        let dim = u(&c["dim"], "dim") as usize;
        let dofs = u(&c["dofs"], "dofs");
        assert_eq!(dofs, dim as u64 * u(&c["nodes"], "nodes"), "{name}");
        // Free body: A is stored in full, one d x d block per bond plus the diagonal.
        let bonds = u(&c["bonds"], "bonds");
        assert_eq!(u(&c["nnz_a"], "nnz_a"), (dim * dim) as u64 * (bonds + dofs / dim as u64), "{name}");
        assert!(f(&c["dt"], "dt") < f(&c["dt_limit_gershgorin"], "limit"), "{name}: dt not below the limit");
        for op in ["assembled", "stencil"] {
            let d = f(&c["operators"][op]["max_rel_diff_u_vs_per_bond"], op);
            assert!(d <= tol, "{name} {op}: |u - u_per_bond| / |u| = {d:e} > {tol:e}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `linpd bench | head -1` (issue #15: no panic on a closed stdout). The read end is closed
/// before the bench prints anything, so every write of the table meets a closed pipe (reading a
/// first line instead would let the whole small table fit in the pipe's buffer and test
/// nothing): the bench still writes its document and exits 0 without a panic message.
#[test]
fn bench_into_a_closed_pipe_writes_its_document_and_exits_0() {
    let dir = std::env::temp_dir().join(format!("linpd-bench-pipe-{}", std::process::id()));
    let out = dir.join("bench.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["bench", "--quick", "--dynamics", "--out"])
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone
    let o = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && !stderr.contains("panicked"), "{:?} {stderr}", o.status);
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(doc["dynamics"]["cases"].is_object());
    let _ = std::fs::remove_dir_all(&dir);
}
