//! `"model": {"type": "coarsened", "moduli": ...}` scenes end to end: a moduli file written with
//! `ModuliFile::write`, a scene that refers to it by a path relative to the scene file, solved
//! through the `linpd` binary and through the library, and checked against an independent dense
//! solve of `K u = f` built here from the definition
//! `K_ij = -v_i v_j C_ij (i != j)`, `K_ii = -sum_{j != i} K_ij`.
//!
//! Tolerances: the 1D bar has 40 free DOFs and a stiffness whose condition number is about
//! `(N / m)^2 * const ~ 10^3..10^4` (N = 40 nodes, m = 3 neighbours a side), so two backward-stable
//! solves agree to `kappa * eps * N ~ 1e-11` relative at worst; `1e-10` leaves a margin and still
//! catches any wrong volume factor or sign (those change `u` by O(1)). The 6x6 plate (60 free
//! DOFs) is as well conditioned; the same bound applies.

use linpd::problem::{CoarsenedModel, ModuliFile, Problem};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-coarsened-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The 1D bar: 41 nodes `x_i = 0.025 i` on [0, 1], volumes 0.025, tent micromodulus
/// `C(x, q) = 1 - |q - x| / 0.1` for `|q - x| < 0.1` (neighbours at 1, 2, 3 spacings; the fourth
/// sits on the horizon where the tent is 0 and is not stored).
fn bar() -> ModuliFile {
    let n = 41;
    let h = 0.025;
    let mut entries = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let k = (i as i64 - j as i64).unsigned_abs() as usize;
            if (1..=3).contains(&k) {
                entries.push((i, j, 1.0 - (k as f64 * h) / 0.1));
            }
        }
    }
    ModuliFile {
        level: 1,
        dim: 1,
        positions: (0..n).map(|i| [i as f64 * h, 0.0, 0.0]).collect(),
        volumes: vec![h; n],
        level0: (0..n).map(|i| 2 * i).collect(),
        entries,
    }
}

/// The 6x6 plate, spacing `h = 0.2`, volumes `h^2`, `C_ij = c n n^T` (n the unit bond vector)
/// for `|x_j - x_i| <= 1.5 h`, with `c = 1 + |x_j - x_i| / h` so the blocks are not all alike.
fn plate() -> ModuliFile {
    plate_of(6, 0.2)
}

/// [`plate`] with `m x m` nodes of spacing `h`.
fn plate_of(m: usize, h: f64) -> ModuliFile {
    let positions: Vec<[f64; 3]> = (0..m * m).map(|q| [(q % m) as f64 * h, (q / m) as f64 * h, 0.0]).collect();
    let mut entries = Vec::new();
    for i in 0..m * m {
        for j in 0..m * m {
            let dx = [positions[j][0] - positions[i][0], positions[j][1] - positions[i][1]];
            let r = dx[0].hypot(dx[1]);
            if i == j || r > 1.5 * h * (1.0 + 1e-9) {
                continue;
            }
            let nv = [dx[0] / r, dx[1] / r];
            let c = 1.0 + r / h;
            for a in 0..2 {
                for b in 0..2 {
                    entries.push((2 * i + a, 2 * j + b, c * nv[a] * nv[b]));
                }
            }
        }
    }
    ModuliFile { level: 2, dim: 2, positions, volumes: vec![h * h; m * m], level0: (0..m * m).collect(), entries }
}

/// Dense `K` from the definition (not through `ModuliFile::stiffness`).
fn dense_k(m: &ModuliFile) -> Vec<Vec<f64>> {
    let d = m.dim;
    let nd = d * m.volumes.len();
    let mut k = vec![vec![0.0; nd]; nd];
    for &(r, c, v) in &m.entries {
        let (i, j) = (r / d, c / d);
        let kij = -m.volumes[i] * m.volumes[j] * v;
        k[r][c] += kij;
        k[r][d * i + c % d] -= kij;
    }
    k
}

/// Gaussian elimination with partial pivoting on the free rows/columns; constrained DOFs are
/// held at zero. Returns the full displacement.
fn dense_solve(k: &[Vec<f64>], f: &[f64], fixed: &[bool]) -> Vec<f64> {
    let free: Vec<usize> = (0..f.len()).filter(|&q| !fixed[q]).collect();
    let n = free.len();
    let mut a: Vec<Vec<f64>> = free.iter().map(|&r| free.iter().map(|&c| k[r][c]).chain([f[r]]).collect()).collect();
    for col in 0..n {
        let p = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs())).unwrap();
        a.swap(col, p);
        for r in col + 1..n {
            let m = a[r][col] / a[col][col];
            for c in col..=n {
                a[r][c] -= m * a[col][c];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r][c] * x[c]).sum();
        x[r] = (a[r][n] - s) / a[r][r];
    }
    let mut u = vec![0.0; f.len()];
    for (q, &g) in free.iter().enumerate() {
        u[g] = x[q];
    }
    u
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0.0f64, |m, (p, q)| m.max((p - q).abs())) / scale
}

fn write_scene(dir: &Path, name: &str, scene: &Value) -> PathBuf {
    let p = dir.join(format!("{name}.json"));
    std::fs::write(&p, serde_json::to_string_pretty(scene).unwrap()).unwrap();
    p
}

fn bar_scene(out: &Path) -> Value {
    json!({
        "name": "coarse-bar",
        "dimension": 1,
        "model": {"type": "coarsened", "moduli": "level-1.mtx"},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "point", "at": [1.0], "force": [1.0]}],
        "output": {"dir": out.to_string_lossy()}
    })
}

#[test]
fn bar_1d_cli_and_library_match_a_dense_solve() {
    let dir = temp_dir("bar");
    let m = bar();
    m.write(&dir.join("level-1")).unwrap();
    let out = dir.join("out");
    let scene = write_scene(&dir, "scene", &bar_scene(&out));

    // Independent reference: node 0 fixed, unit force on node 40.
    let mut f = vec![0.0; 41];
    f[40] = 1.0;
    let mut fixed = vec![false; 41];
    fixed[0] = true;
    let reference = dense_solve(&dense_k(&m), &f, &fixed);
    assert!(reference[40] > 0.0);

    // Library (the relative moduli path resolves against the scene's directory).
    let p = Problem::from_path(&scene).unwrap();
    let c = p.model().downcast::<CoarsenedModel>().expect("expected a coarsened scene");
    assert_eq!((p.dim(), c.level(), p.nodes().len()), (1, 1, 41));
    assert!(c.is_symmetric());
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    assert_eq!(s.report.solver.to_string(), "cholesky-amd");
    assert!(s.report.rel_residual < 1e-12, "{}", s.report.rel_residual);
    assert_eq!(s.n_bonds, 2 * (38 + 39 + 40)); // pairs at distance 1, 2, 3, both directions
    assert!(s.is_layer.iter().all(|&l| !l));
    let e = max_rel_diff(&s.u, &reference);
    assert!(e < 1e-10, "library vs dense: {e:e}");

    // The binary: validate, then solve (result.json holds the exact f64s).
    let v = Command::new(env!("CARGO_BIN_EXE_linpd")).arg("validate").arg(&scene).output().unwrap();
    let text = String::from_utf8_lossy(&v.stdout);
    assert!(
        v.status.success() && text.contains("valid; coarsened level 1"),
        "{text} {}",
        String::from_utf8_lossy(&v.stderr)
    );
    let o = Command::new(env!("CARGO_BIN_EXE_linpd")).arg("solve").arg(&scene).arg("-q").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    let u: Vec<f64> = r["u"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let x: Vec<f64> = r["x"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(x.len(), 41);
    assert_eq!(x[40], 1.0);
    let e = max_rel_diff(&u, &reference);
    assert!(e < 1e-10, "cli vs dense: {e:e}");
    assert!(out.join("u.csv").is_file());
    assert!(out.join("u.png").is_file(), "1D coarsened scenes get the profile plot");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bar_1d_body_load_uses_node_volumes() {
    let dir = temp_dir("bar-body");
    let mut m = bar();
    // Non-uniform volumes: the body force on node i must be density * v_i.
    for (i, v) in m.volumes.iter_mut().enumerate() {
        *v *= 1.0 + 0.01 * i as f64;
    }
    m.write(&dir.join("level-1")).unwrap();
    let mut scene = bar_scene(&dir.join("out"));
    scene["loads"] = json!([{"type": "body", "region": "all", "density": [2.0]}]);
    let path = write_scene(&dir, "scene", &scene);
    let s = Problem::from_path(&path).unwrap().solve(&linpd::core::NoProgress).unwrap();
    let f: Vec<f64> = m.volumes.iter().map(|v| 2.0 * v).collect();
    let mut fixed = vec![false; 41];
    fixed[0] = true;
    let e = max_rel_diff(&s.u, &dense_solve(&dense_k(&m), &f, &fixed));
    assert!(e < 1e-10, "{e:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn plate_scene(solver: &str) -> Value {
    json!({
        "name": "coarse-plate",
        "dimension": 2,
        "model": {"type": "coarsened", "moduli": "level-2.mtx"},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "point", "at": [1.0, 1.0], "force": [0.5, 1.0]},
                  {"type": "body", "region": {"box": {"min": [-1.0, 0.9], "max": [2.0, 2.0]}}, "density": [0.0, 3.0]}],
        "solver": {"type": solver},
        "output": {"plot": false}
    })
}

#[test]
fn plate_2d_cholesky_lu_and_dense_agree() {
    let dir = temp_dir("plate");
    let m = plate();
    assert_eq!(m.asymmetry(), 0.0);
    m.write(&dir.join("level-2")).unwrap();
    let solve = |solver: &str| {
        let p = write_scene(&dir, solver, &plate_scene(solver));
        Problem::from_path(&p).unwrap().solve(&linpd::core::NoProgress).unwrap()
    };
    let chol = solve("cholesky");
    let auto = solve("auto");
    let lu = solve("lu");
    assert_eq!(chol.report.solver.to_string(), "cholesky-amd");
    assert_eq!(auto.report.solver.to_string(), "cholesky-amd", "a symmetric K takes the Cholesky path");
    assert_eq!(lu.report.solver.to_string(), "lu");
    let e = max_rel_diff(&lu.u, &chol.u);
    assert!(e < 1e-10, "lu vs cholesky: {e:e}");

    // Dense reference: bottom row (y = 0) fixed; point force at (1, 1) = node 35; body force
    // 3 v on the top row (y = 1).
    let n = 36;
    let mut f = vec![0.0; 2 * n];
    f[70] += 0.5;
    f[71] += 1.0;
    for q in 30..36 {
        f[2 * q + 1] += 3.0 * m.volumes[q];
    }
    let fixed: Vec<bool> = (0..2 * n).map(|k| k / 2 < 6).collect();
    let reference = dense_solve(&dense_k(&m), &f, &fixed);
    let e = max_rel_diff(&chol.u, &reference);
    assert!(e < 1e-10, "cholesky vs dense: {e:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unsymmetric_moduli_take_the_lu_path() {
    let dir = temp_dir("plate-unsym");
    let mut m = plate();
    // Break C_ij = C_ji^T on one pair: K is no longer symmetric.
    let (r, c, _) = m.entries[0];
    m.entries[0].2 *= 1.5;
    assert!(m.asymmetry() > 1e-3, "entry ({r}, {c})");
    m.write(&dir.join("level-2")).unwrap();
    let p = write_scene(&dir, "auto", &plate_scene("auto"));
    let problem = Problem::from_path(&p).unwrap();
    let c = problem.model().downcast::<CoarsenedModel>().expect("a coarsened scene");
    assert!(!c.is_symmetric());
    let s = problem.solve(&linpd::core::NoProgress).unwrap();
    assert_eq!(s.report.solver, linpd::solve::SolverId::Lu);
    let note = s.report.notes.join("; ");
    assert!(note.contains("A is unsymmetric (relative asymmetry"), "{note}");
    assert!(s.report.rel_residual < 1e-12, "{}", s.report.rel_residual);
    let n = 36;
    let mut f = vec![0.0; 2 * n];
    f[70] += 0.5;
    f[71] += 1.0;
    for q in 30..36 {
        f[2 * q + 1] += 3.0 * m.volumes[q];
    }
    let fixed: Vec<bool> = (0..2 * n).map(|k| k / 2 < 6).collect();
    let e = max_rel_diff(&s.u, &dense_solve(&dense_k(&m), &f, &fixed));
    assert!(e < 1e-10, "lu vs dense: {e:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Multigrid-PCG (SA-AMG built from the level's assembled `K`, rigid-body modes from its node
/// positions) on a coarsened 40x40 plate (3120 free DOFs: two levels) agrees with sparse
/// Cholesky to 1e-8 relative: CG stops at a relative residual of 1e-12 and kappa ~ 1e4.
#[test]
fn plate_2d_multigrid_agrees_with_cholesky() {
    let dir = temp_dir("plate-mg");
    plate_of(40, 1.0 / 39.0).write(&dir.join("level-2")).unwrap();
    let solve = |solver: Value| {
        let mut scene = plate_scene("cholesky");
        scene["solver"] = solver;
        scene["loads"][0]["at"] = json!([1.0, 1.0]);
        let p = write_scene(&dir, "mg", &scene);
        Problem::from_path(&p).unwrap().solve(&linpd::core::NoProgress).unwrap()
    };
    let chol = solve(json!({"type": "cholesky"}));
    let mg = solve(json!({"type": "cg", "preconditioner": "multigrid", "rtol": 1e-12}));
    assert_eq!(mg.report.solver.to_string(), "cg-multigrid");
    let summary = mg.report.preconditioner.clone().unwrap_or_default();
    assert!(summary.contains("2 levels"), "{summary}");
    println!("coarsened plate: {summary}, {:?} iterations", mg.report.iterations);
    // The cap of the lattice scenes (measured: 22).
    assert!(mg.report.iterations.unwrap() <= 30, "{:?}", mg.report.iterations);
    let e = max_rel_diff(&mg.u, &chol.u);
    assert!(e < 1e-8, "multigrid vs cholesky: {e:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue #15 item 7 (coarsened scene vs pipeline): `linpd coarsen` on the bundled bond plate
/// pipeline (two levels, `"solve": true`), then its coarsest level `level-2.mtx` loaded back as a
/// scene with the boundary-value problem the pipeline wrote beside it (`level-2.prescribed.csv`,
/// `level-2.forces.csv`, issue #29): the same `K` (read back bit for bit), the same nodal forces
/// and the same sparse LU (K is unsymmetric through its diagonal blocks). They differ only in the
/// order the diagonal blocks of `K` are summed (`ModuliFile::stiffness` vs
/// `LevelModel::stiffness`): `eps` relative in `K`, times `kappa(K_ff) ~ 1e3` for 91 nodes, so
/// agreement to 1e-12 relative of `max |u|` is the bound. Also checks that the symmetry check
/// names the right quantity: `K`, unsymmetric only in its diagonal blocks, with the written
/// moduli reciprocal.
#[test]
fn item_7_a_level_loaded_back_reproduces_the_pipeline() {
    let dir = temp_dir("roundtrip");
    let out = dir.join("pipeline");
    let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["coarsen", "data/coarsen-plate-2d.pipeline.json", "-q", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // the coarsest level with the boundary-value problem the pipeline transferred to it (the
    // scene's own loads re-evaluated on level-2 volumes would be another problem: a standalone
    // coarse model, docs/coarsening.md)
    let scene = json!({
        "name": "level-2-scene", "dimension": 2,
        "model": {"type": "coarsened", "moduli": out.join("level-2.mtx").to_string_lossy()},
        "constraints": [{"file": out.join("level-2.prescribed.csv").to_string_lossy()}],
        "loads": [{"type": "nodal", "file": out.join("level-2.forces.csv").to_string_lossy()}],
        "output": {"dir": dir.join("scene-out").to_string_lossy(), "plot": false}
    });
    let path = write_scene(&dir, "level-2-scene", &scene);
    let p = Problem::from_path(&path).unwrap();
    let c = p.model().downcast::<CoarsenedModel>().expect("expected a coarsened scene");
    assert_eq!(c.level(), 2);
    let s = p.solve(&linpd::core::NoProgress).unwrap();

    // the pipeline's level-2 displacements at the shared (= level-2) nodes, in level order
    let csv = std::fs::read_to_string(out.join("shared.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let (cx, cy, ux, uy) = (col("x"), col("y"), col("ux_level2"), col("uy_level2"));
    let mut u_pipeline = Vec::new();
    for (i, line) in lines.enumerate() {
        let f: Vec<f64> = line.split(',').map(|t| t.parse().unwrap()).collect();
        let x = p.nodes().position(i);
        assert_eq!((f[cx], f[cy]), (x[0], x[1]), "node {i}: same node order in shared.csv and the level file");
        u_pipeline.extend([f[ux], f[uy]]);
    }
    assert_eq!(u_pipeline.len(), s.u.len());
    let e = max_rel_diff(&s.u, &u_pipeline);
    println!("level 2 as a scene vs the pipeline's level-2 solve: max |du| / max |u| = {e:.2e}");
    assert!(e < 1e-12, "scene vs pipeline: {e:e}");

    // item 7, symmetry: the moduli are reciprocal, K is not (its diagonal blocks), and both the
    // validate line and the solve report say which
    assert!(c.reciprocity() <= 1e-12, "written moduli not reciprocal: {:e}", c.reciprocity());
    assert!(!c.is_symmetric(), "expected K unsymmetric through its diagonal blocks");
    assert!(c.symmetry().contains("diagonal blocks"), "{}", c.symmetry());
    let note = s.report.notes.join("; ");
    assert!(note.contains("diagonal blocks") && note.contains("sparse LU used"), "{note}");
    let v = Command::new(env!("CARGO_BIN_EXE_linpd")).arg("validate").arg(&path).output().unwrap();
    let text = String::from_utf8_lossy(&v.stdout);
    assert!(v.status.success() && text.contains("C_ij = C_ji^T"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A symmetric level reports a strain energy density whose volume-weighted sum is
/// `u.K u / 2` (1e-12 relative: one sum over ~400 bonds of the 6x6 plate), computed here from
/// the dense `K` of the definition; an unsymmetric level reports none.
#[test]
fn symmetric_levels_report_an_energy_density_that_sums_to_the_energy() {
    let dir = temp_dir("energy");
    let m = plate();
    let scene = write_scene(&dir, "plate", &plate_scene("cholesky"));
    m.write(&dir.join("level-2")).unwrap();
    let p = Problem::from_path(&scene).unwrap();
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    let w = s.strain_energy_density.expect("a symmetric level has an energy density");
    let total: f64 = w.iter().zip(&s.volumes).map(|(w, v)| w * v).sum();
    let k = dense_k(&m);
    let half_uku =
        0.5 * (0..k.len()).map(|r| s.u[r] * (0..k.len()).map(|c| k[r][c] * s.u[c]).sum::<f64>()).sum::<f64>();
    assert!((total - half_uku).abs() <= 1e-12 * half_uku.abs(), "{total:e} vs {half_uku:e}");
    assert!(w.iter().all(|&x| x >= -1e-15 * half_uku.abs()), "negative energy density");
}
