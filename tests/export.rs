//! `linpd export SCENE --out DIR` end to end: the files read back with sprs's own Matrix Market
//! reader hold the reduced system the static solve works on, bit for bit.
//!
//! * `K.mtx` against `Model::assemble_free` called here on the scene's model (not through the
//!   export code), entry by entry, same order, same bits (sprs prints the shortest decimal that
//!   reads back to the same `f64`: 0 ulp, no tolerance needed);
//! * `f.mtx` against `f_f - (A u_bar)_f` from `Dirichlet::reduced_rhs` here, same bits;
//! * `dofs.csv` against the scene's `DofMap`;
//! * the read-back `K u = f` solved with linpd's sparse Cholesky (AMD) against `result.json`'s `u`
//!   at the free DOFs of a `linpd solve` of the same scene with `"solver": "cholesky"` (nested
//!   dissection ordering): two backward-stable solves of one SPD system differ by about
//!   `kappa * eps` (different orderings round differently). Measured: 3.4e-14 for the 2D plate
//!   (3512 unknowns), 5.3e-13 for the 3D cantilever (3000 unknowns), so `kappa` is about
//!   1e2..1e4; the bound 1e-10 leaves a factor 190 and still catches a wrong row, sign or scale
//!   (those change `u` by O(1));
//! * a bad scene: the same message as `linpd solve`, a non-zero exit and nothing written.

use linpd::core::{Model, ModelOperator, NoProgress};
use linpd::problem::Commands;
use linpd::problem::{CoarsenedModel, ModuliFile, Problem};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn linpd(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().expect("the linpd binary runs")
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-export-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of a bundled scene in `dir` with `changes` merged into its top level.
fn scene_copy(dir: &Path, name: &str, changes: Value) -> PathBuf {
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap();
    for (k, v) in changes.as_object().unwrap() {
        doc[k] = v.clone();
    }
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    p
}

fn run_ok(args: &[&std::ffi::OsStr]) {
    let o = linpd(args);
    assert!(o.status.success(), "linpd {args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// `(rows, cols, [(row, col, bits)])` of a Matrix Market file, read by sprs.
fn read_mtx(path: &Path) -> (usize, usize, Vec<(usize, usize, u64)>) {
    let t: sprs::TriMat<f64> = sprs::io::read_matrix_market(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let e = t.row_inds().iter().zip(t.col_inds()).zip(t.data()).map(|((&r, &c), v)| (r, c, v.to_bits())).collect();
    (t.rows(), t.cols(), e)
}

/// The stored entries of a CSC matrix in column order, as `(row, col, bits)`.
fn csc_entries(a: &linpd::core::sparse::Csc) -> Vec<(usize, usize, u64)> {
    let (cp, ri, val) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    (0..a.ncols()).flat_map(|j| (cp[j]..cp[j + 1]).map(move |p| (ri[p], j, val[p].to_bits()))).collect()
}

/// `f.mtx` as a dense vector (an `n x 1` matrix).
fn read_vector(path: &Path) -> Vec<f64> {
    let (n, cols, e) = read_mtx(path);
    assert_eq!(cols, 1);
    let mut f = vec![0.0; n];
    for (r, c, b) in e {
        assert_eq!(c, 0);
        f[r] += f64::from_bits(b);
    }
    f
}

/// `dofs.csv` as `(node, component)` per row, checking the header and the row numbers.
fn read_dofs(path: &Path) -> Vec<(usize, usize)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("row,node,component"));
    lines
        .enumerate()
        .map(|(k, l)| {
            let f: Vec<usize> = l.split(',').map(|s| s.parse().unwrap()).collect();
            assert_eq!((f.len(), f[0]), (3, k), "dofs.csv line {}: {l}", k + 2);
            (f[1], f[2])
        })
        .collect()
}

/// `u` of a result.json over all DOFs (node-major).
fn result_u(path: &Path) -> Vec<f64> {
    let r: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut u = Vec::new();
    for v in r["u"].as_array().unwrap() {
        match v {
            Value::Array(c) => u.extend(c.iter().map(|x| x.as_f64().unwrap())),
            x => u.push(x.as_f64().unwrap()),
        }
    }
    u
}

fn to_csc(n: usize, e: &[(usize, usize, u64)]) -> linpd::core::sparse::Csc {
    let t: Vec<faer::sparse::Triplet<usize, usize, f64>> =
        e.iter().map(|&(r, c, b)| faer::sparse::Triplet::new(r, c, f64::from_bits(b))).collect();
    faer::sparse::SparseColMat::try_new_from_triplets(n, n, &t).unwrap()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// One bundled bond scene: export and solve (Cholesky), then every check of the module docs.
fn check_bond_scene(name: &str, dim: usize) {
    let dir = temp_dir(name.trim_end_matches(".json"));
    let scene = scene_copy(&dir, name, json!({"solver": {"type": "cholesky"}, "output": {"plot": false}}));
    let (ex, sol) = (dir.join("export"), dir.join("solve"));
    run_ok(&["export".as_ref(), scene.as_os_str(), "--out".as_ref(), ex.as_os_str(), "-q".as_ref()]);
    run_ok(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), sol.as_os_str(), "-q".as_ref()]);

    // The reduced system built here from the model, not through the export code.
    let p = Problem::from_path(&scene).unwrap();
    assert_eq!(p.dim(), dim);
    let model = p.lattice_model().unwrap();
    let bc = p.dirichlet();
    let dofs = bc.dofs();
    let k = model.assemble_free(dofs);
    let rhs = bc.reduced_rhs(&ModelOperator(&model), &p.load_vector());
    let n = dofs.n_free();
    assert!(n > 100 && n < dofs.n_dofs(), "{name}: {n} free of {}", dofs.n_dofs());

    let (rows, cols, entries) = read_mtx(&ex.join("K.mtx"));
    assert_eq!((rows, cols), (n, n));
    assert_eq!(entries, csc_entries(&k), "{name}: K.mtx differs from assemble_free");
    let f = read_vector(&ex.join("f.mtx"));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&f), bits(&rhs), "{name}: f.mtx differs from f_f - (A u_bar)_f");
    assert!(norm(&f) > 0.0);
    let map: Vec<(usize, usize)> = dofs.free_dofs().iter().map(|&g| (g / dim, g % dim)).collect();
    assert_eq!(read_dofs(&ex.join("dofs.csv")), map, "{name}: dofs.csv differs from the DofMap");

    let doc: Value = serde_json::from_str(&std::fs::read_to_string(ex.join("export.json")).unwrap()).unwrap();
    assert_eq!((doc["n"].as_u64(), doc["nnz"].as_u64()), (Some(n as u64), Some(entries.len() as u64)));
    assert_eq!((doc["dimension"].as_u64(), doc["symmetric"].as_bool()), (Some(dim as u64), Some(true)));
    let listed: Vec<&str> =
        doc["run"]["files"].as_array().unwrap().iter().map(|f| f["name"].as_str().unwrap()).collect();
    assert_eq!(listed, ["K.mtx", "dofs.csv", "f.mtx"]);
    assert_eq!(doc["run"]["inputs"][0]["path"].as_str(), Some(scene.to_str().unwrap()));

    // Solve the read-back system with linpd's own sparse Cholesky; compare with result.json.
    let a = to_csc(n, &entries);
    let chol = linpd::solve::Cholesky::analyze_with_ordering(&a, None).unwrap();
    let u_f = chol.factor(&a).unwrap().solve(&f);
    let u = result_u(&sol.join("result.json"));
    assert_eq!(u.len(), dofs.n_dofs());
    let u_ref = dofs.gather(&u);
    let diff: Vec<f64> = u_f.iter().zip(&u_ref).map(|(a, b)| a - b).collect();
    let e = norm(&diff) / norm(&u_ref);
    println!("{name}: n = {n}, nnz = {}, ||u_export - u_solve|| / ||u_solve|| = {e:.2e}", entries.len());
    assert!(e < 1e-10, "{name}: {e:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_2d_plate_is_the_solved_system() {
    check_bond_scene("plate-tension-2d.json", 2);
}

#[test]
fn export_3d_cantilever_is_the_solved_system() {
    check_bond_scene("cantilever-3d.json", 3);
}

/// The 1D blended model (unsymmetric, its own constraints): K.mtx is the operator of its solve,
/// and `linpd solve`'s `u` satisfies the read-back system to its reported residual (1e-8 is the
/// bound tests/cli.rs puts on every bundled scene's residual).
#[test]
fn export_1d_blend_scene() {
    let dir = temp_dir("blend");
    let (ex, sol) = (dir.join("export"), dir.join("solve"));
    let scene = data("blend-point-load.json");
    run_ok(&["export".as_ref(), scene.as_os_str(), "--out".as_ref(), ex.as_os_str(), "-q".as_ref()]);
    run_ok(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), sol.as_os_str(), "-q".as_ref()]);
    let sys = Problem::from_path(&scene).unwrap().reduced_system(&NoProgress).unwrap();
    assert_eq!(sys.model, "blend");
    let (n, _, entries) = read_mtx(&ex.join("K.mtx"));
    assert_eq!(entries, csc_entries(&sys.k));
    let f = read_vector(&ex.join("f.mtx"));
    let dofs: Vec<usize> = read_dofs(&ex.join("dofs.csv")).iter().map(|&(node, c)| node + c).collect();
    assert_eq!(dofs, sys.free_dofs);
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(ex.join("export.json")).unwrap()).unwrap();
    assert_eq!(doc["symmetric"].as_bool(), Some(false), "the blended operator is unsymmetric");
    let u = result_u(&sol.join("result.json"));
    let u_f: Vec<f64> = dofs.iter().map(|&g| u[g]).collect();
    let a = to_csc(n, &entries);
    let mut r = f.clone();
    let (cp, ri, val) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    for j in 0..n {
        for p in cp[j]..cp[j + 1] {
            r[ri[p]] -= val[p] * u_f[j];
        }
    }
    let res = norm(&r) / norm(&f);
    assert!(res < 1e-8, "||f - K u_solve|| / ||f|| = {res:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A coarsened level (nodes and moduli from files): K.mtx is its stiffness restricted to the
/// free DOFs (`restrict_to_free` of `ModuliFile::stiffness` here).
#[test]
fn export_coarsened_level_scene() {
    let dir = temp_dir("level");
    let n = 21;
    let h = 0.05;
    let mut entries = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let k = (i as i64 - j as i64).unsigned_abs() as f64;
            if (1.0..=2.0).contains(&k) {
                entries.push((i, j, 1.0 / (3.0 * k) + 0.1 * i as f64));
            }
        }
    }
    let level = ModuliFile {
        level: 1,
        dim: 1,
        positions: (0..n).map(|i| [i as f64 * h, 0.0, 0.0]).collect(),
        volumes: (0..n).map(|i| h * (1.0 + 0.01 * i as f64)).collect(),
        level0: (0..n).map(|i| 2 * i).collect(),
        entries,
    };
    level.write(&dir.join("level-1")).unwrap();
    let scene = dir.join("scene.json");
    let doc = json!({
        "name": "level-bar",
        "dimension": 1,
        "model": {"type": "coarsened", "moduli": "level-1.mtx"},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.5]}}],
        "loads": [{"type": "point", "at": [1.0], "force": [1.0]}]
    });
    std::fs::write(&scene, doc.to_string()).unwrap();
    let ex = dir.join("export");
    run_ok(&["export".as_ref(), scene.as_os_str(), "--out".as_ref(), ex.as_os_str(), "-q".as_ref()]);
    let p = Problem::from_path(&scene).unwrap();
    assert!(p.model().downcast::<CoarsenedModel>().is_some());
    let bc = p.dirichlet();
    let k = linpd::core::sparse::restrict_to_free(&level.stiffness().unwrap(), bc.dofs());
    assert_eq!(read_mtx(&ex.join("K.mtx")).2, csc_entries(&k));
    let f = read_vector(&ex.join("f.mtx"));
    // u_bar = 0.5 at node 0 enters the right-hand side: f_f - (K u_bar)_f, not just the load.
    let model = linpd::core::AssembledModel::new("coarsened", 1, level.positions.clone(), level.stiffness().unwrap());
    let rhs = bc.reduced_rhs(&ModelOperator(&model), &p.load_vector());
    assert_eq!(f, rhs);
    assert!(f[0] != 0.0, "the prescribed displacement reaches the first free row");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad scenes: the message `linpd solve` gives, a non-zero exit, and nothing written (nor the
/// missing parent directories of `--out`), for an error found while reading the scene and one
/// found after the output directory was staged (a body free to move).
#[test]
fn export_of_a_bad_scene_writes_nothing() {
    let dir = temp_dir("bad");
    let invalid = dir.join("invalid.json");
    let mut doc: Value =
        serde_json::from_str(&std::fs::read_to_string(data("plate-tension-2d.json")).unwrap()).unwrap();
    doc["model"]["horizon"] = json!(-1.0);
    std::fs::write(&invalid, doc.to_string()).unwrap();
    let floating = scene_copy(&dir, "plate-tension-2d.json", json!({"constraints": []}));
    for (scene, needle) in [(&invalid, "model.horizon: must be > 0"), (&floating, "constraints:")] {
        let out = dir.join("new/deeper/out");
        let e = linpd(&["export".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str()]);
        let s = linpd(&["solve".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str(), "-q".as_ref()]);
        let (e_err, s_err) = (String::from_utf8_lossy(&e.stderr), String::from_utf8_lossy(&s.stderr));
        assert!(!e.status.success() && !s.status.success());
        let last = |t: &str| t.lines().last().unwrap_or("").to_string();
        assert_eq!(last(&e_err), last(&s_err), "export and solve report the same error");
        assert!(e_err.contains(needle) && e_err.contains(&scene.display().to_string()), "{e_err}");
        assert!(!dir.join("new").exists(), "nothing written for {}", scene.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
