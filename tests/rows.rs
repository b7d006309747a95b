//! Row-block assembly (`Problem::row_system`, `RowSystem::rows`; issue #16): rows computed from
//! their own nodes' block rows equal the rows of the assembled `A_ff` of `linpd export`
//! (`Problem::reduced_system`), over splits into 1, 2, 3 and 7 blocks whose cuts fall inside a
//! node's rows too, for every static model: bond (lattice, cloud, defect), LPS (lattice, cloud,
//! defect, a surface correction, 3D), coarsened levels (symmetric and unsymmetric `K`) and the
//! 1D blend/CE models (a pre-crack, a coarse CE mesh). Compared entry by entry over the union of
//! both patterns, a missing entry counting as 0 (explicit zeros of the assembled pattern, such
//! as bonds a defect cuts or the LPS lattice pattern's structural zeros, are absent from the
//! block rows, and an LPS entry that is 0 in exact arithmetic may round to 0 in one sum order
//! only); values to `1e-13 max|A_ff|`:
//! a bond diagonal entry is a sum over a node's bonds (m of about 30-120) that the two
//! assemblies may add in different orders, an LPS entry a sum of up to `2 |F|^2` terms taken
//! from the other end (measured here: at most 7e-17; 1.8e-15 in crates/linpd-lps/tests), so
//! they may differ by about `1e-14`; a wrong bond, sign or component changes an entry by
//! O(max|A|). Coarsened and blend rows are copies of stored entries: equal bit for bit. Also:
//! the right-hand side is export's bit for bit, the symmetry flag is the export's, and the
//! solution from given displacements is `linpd solve`'s; bad ranges are errors that say so.

use linpd::core::sparse::{relative_asymmetry, SYMMETRY_RTOL};
use linpd::core::NoProgress;
use linpd::problem::Commands;
use linpd::problem::{ModuliFile, Problem};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn scene(name: &str) -> Problem {
    Problem::from_path(&data(name)).unwrap()
}

/// A bundled scene with `edit` applied to its JSON (relative paths still start at data/).
fn edited(name: &str, edit: impl FnOnce(&mut Value)) -> Problem {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap();
    edit(&mut v);
    Problem::from_json_in(&v.to_string(), &data("")).unwrap()
}

/// Nonzero entries of rows `first..last` of a CSC matrix, as `(row, col) -> value`.
fn csc_rows(k: &linpd::core::sparse::Csc, first: usize, last: usize) -> BTreeMap<(usize, usize), f64> {
    let (cp, ri, val) = (k.symbolic().col_ptr(), k.symbolic().row_idx(), k.val());
    let mut m = BTreeMap::new();
    for j in 0..k.ncols() {
        for p in cp[j]..cp[j + 1] {
            if (first..last).contains(&ri[p]) && val[p] != 0.0 {
                m.insert((ri[p], j), val[p]);
            }
        }
    }
    m
}

fn check(name: &str) {
    check_problem(name, &scene(name), 1e-13);
}

/// [`check`] on a built scene; `rtol` relative to `max|A_ff|` (0: bit for bit). Returns the
/// row system's symmetry flag after checking it against the assembled `A_ff`'s.
fn check_problem(name: &str, p: &Problem, rtol: f64) -> bool {
    let sys = p.reduced_system(&NoProgress).unwrap();
    let rows = p.row_system().unwrap();
    let n = sys.n();
    assert_eq!(rows.n(), n);
    assert_eq!(rows.free_dofs(), &sys.free_dofs[..]);
    assert!(rows.rhs().iter().zip(&sys.f).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: rhs");
    let scale = sys.k.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut measured = 0.0f64;
    for parts in [1usize, 2, 3, 7] {
        let mut cuts: Vec<usize> = (1..parts).map(|q| (n * q / parts + q % 2).min(n)).collect();
        cuts.insert(0, 0);
        cuts.push(n);
        for w in cuts.windows(2) {
            let (first, last) = (w[0], w[1]);
            let b = rows.rows(first, last).unwrap();
            assert_eq!(b.indptr.len(), last - first + 1);
            let mut got = BTreeMap::new();
            for r in 0..last - first {
                let cols = &b.indices[b.indptr[r]..b.indptr[r + 1]];
                assert!(cols.windows(2).all(|c| c[0] < c[1]), "{name}: row {} columns ascending", first + r);
                for p in b.indptr[r]..b.indptr[r + 1] {
                    if b.data[p] != 0.0 {
                        got.insert((first + r, b.indices[p]), b.data[p]);
                    }
                }
            }
            let want = csc_rows(&sys.k, first, last);
            // over the union of both patterns, a missing entry as 0: an entry that is 0 in exact
            // arithmetic (e.g. an off-axis component of an axis bond's LPS terms) may round to 0
            // in one sum order and to ~1e-17 max|A| in the other
            let worst = got
                .keys()
                .chain(want.keys())
                .map(|k| (got.get(k).unwrap_or(&0.0) - want.get(k).unwrap_or(&0.0)).abs())
                .fold(0.0f64, f64::max);
            assert!(worst <= rtol * scale, "{name}: rows {first}..{last} differ by {worst:e} (max|A| {scale:e})");
            measured = measured.max(worst / scale);
        }
    }
    eprintln!("{name}: {n} rows, worst difference {measured:.1e} max|A_ff|, asymmetry {:.1e}", rows.asymmetry());
    blocks_match_apply(name, rows.model());
    let symmetric = relative_asymmetry(&sys.k) <= SYMMETRY_RTOL;
    assert_eq!(rows.is_symmetric(), symmetric, "{name}: symmetry flag (asymmetry {:e})", rows.asymmetry());
    symmetric
}

/// The contract of `Model::for_each_block` over all DOFs (constrained rows too): each coupled
/// node once, the node itself included, and `sum_j A_ij u_j = (A u)_i` for a seeded random `u`
/// to `1e-13 max|A u|` (the apply sums the same products in another order, and for LPS in its
/// factored form: `|F|^2` terms per entry, see the module docs).
fn blocks_match_apply(name: &str, model: &dyn linpd::core::Model) {
    let (d, n) = (model.dim(), model.n_nodes());
    let mut s = 0x9e3779b97f4a7c15u64;
    let u: Vec<f64> = (0..d * n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let mut au = vec![0.0; d * n];
    model.apply(&u, &mut au);
    let scale = au.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for i in 0..n {
        let mut seen = Vec::new();
        let mut y = [0.0f64; 3];
        assert!(model.for_each_block(i, &mut |j, b| {
            seen.push(j);
            for a in 0..d {
                for c in 0..d {
                    y[a] += b[a * d + c] * u[d * j + c];
                }
            }
        }));
        let k = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), k, "{name}: node {i} offered a partner twice");
        assert!(seen.binary_search(&i).is_ok(), "{name}: node {i} offered no diagonal block");
        for a in 0..d {
            worst = worst.max((y[a] - au[d * i + a]).abs());
        }
    }
    assert!(worst <= 1e-13 * scale, "{name}: block rows times u differ from A u by {worst:e} (max|A u| {scale:e})");
}

/// `Problem::solution_from` with `linpd solve`'s displacements and report is `linpd solve`'s
/// solution, document for document (the same functions on the same `u`).
fn check_solution(name: &str, p: &Problem) {
    let solved = p.solve(&NoProgress).unwrap();
    let rows = p.row_system().unwrap();
    let again = p.solution_from(&rows, solved.u.clone(), solved.report.clone()).unwrap();
    assert_eq!(again.to_json(), solved.to_json(), "{name}: solution_from differs from the solve's");
    // the free values expand back to the same u
    let u_free: Vec<f64> = rows.free_dofs().iter().map(|&g| solved.u[g]).collect();
    assert_eq!(rows.expand(&u_free).unwrap(), solved.u, "{name}: expand");
}

/// A 6 x 6 level (spacing 0.2) whose moduli `C_ij = (1 + r/h + skew * i / n) n n^T` are
/// reciprocal for `skew = 0` (a symmetric `K`) and not otherwise, written into `dir`; the
/// scene constrains the bottom row and loads the top.
fn level_scene(dir: &Path, skew: f64) -> Problem {
    let (m, h) = (6usize, 0.2);
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
            let c = 1.0 + r / h + skew * i as f64 / (m * m) as f64;
            for a in 0..2 {
                for b in 0..2 {
                    entries.push((2 * i + a, 2 * j + b, c * nv[a] * nv[b]));
                }
            }
        }
    }
    let file =
        ModuliFile { level: 1, dim: 2, positions, volumes: vec![h * h; m * m], level0: (0..m * m).collect(), entries };
    std::fs::create_dir_all(dir).unwrap();
    file.write(&dir.join("level-1")).unwrap();
    let scene = json!({
        "name": "rows-level",
        "dimension": 2,
        "model": {"type": "coarsened", "moduli": "level-1.mtx"},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "point", "at": [1.0, 1.0], "force": [0.5, 1.0]},
                  {"type": "body", "region": {"box": {"min": [-1.0, 0.9], "max": [2.0, 2.0]}}, "density": [0.0, 3.0]}],
        "output": {"dir": dir.join("out").to_string_lossy(), "plot": false}
    });
    Problem::from_json_in(&scene.to_string(), dir).unwrap()
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-rows-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// An LPS plate with a pre-crack (a cut between lattice rows from the left edge).
fn cracked_lps_plate() -> Problem {
    edited("lps-plate-2d.json", |v| {
        v["model"]["material"] = json!({"defects": [{"segment": [[-0.1, 0.2625], [0.4, 0.2625]], "factor": 0.0}]});
    })
}

#[test]
fn rows_equal_the_assembled_matrix() {
    check("cantilever-3d.json");
    check("plate-hole-2d.json");
    check("plate-crack-2d.json");
    check("bracket-cloud-2d.json");
    check("bar-point-load.json");
}

#[test]
fn lps_rows_equal_the_assembled_tangent() {
    assert!(check_problem("lps-plate-2d.json", &scene("lps-plate-2d.json"), 1e-13));
    assert!(check_problem("lps-plate-2d.json with a pre-crack", &cracked_lps_plate(), 1e-13));
    assert!(check_problem("bracket-cloud-lps-2d.json", &scene("bracket-cloud-lps-2d.json"), 1e-13));
    assert!(check_problem("surface-bar-3d.json", &scene("surface-bar-3d.json"), 1e-13));
    assert!(check_problem("lps-tension-3d.json", &scene("lps-tension-3d.json"), 1e-13));
}

#[test]
fn coarsened_and_blend_rows_are_the_stored_rows() {
    let dir = temp_dir("levels");
    assert!(check_problem("symmetric level", &level_scene(&dir.join("sym"), 0.0), 0.0));
    assert!(!check_problem("unsymmetric level", &level_scene(&dir.join("skew"), 0.3), 0.0));
    for name in ["blend-point-load.json", "blend-bar-crack.json", "blend-coarse-ce.json"] {
        assert!(!check_problem(name, &scene(name), 0.0), "{name}: the blended operator is unsymmetric");
    }
    // pure CE: a symmetric 3-point operator on the free rows
    assert!(check_problem("ce-point-load.json", &scene("ce-point-load.json"), 0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn solution_from_given_displacements_is_the_solves() {
    check_solution("bar-point-load.json", &scene("bar-point-load.json"));
    check_solution("bracket-cloud-2d.json", &scene("bracket-cloud-2d.json"));
    check_solution("lps-plate-2d.json", &scene("lps-plate-2d.json"));
    check_solution("lps-plate-2d.json with a pre-crack", &cracked_lps_plate());
    check_solution("bracket-cloud-lps-2d.json", &scene("bracket-cloud-lps-2d.json"));
    let dir = temp_dir("solutions");
    check_solution("symmetric level", &level_scene(&dir.join("sym"), 0.0));
    check_solution("unsymmetric level", &level_scene(&dir.join("skew"), 0.3));
    for name in ["blend-point-load.json", "blend-bar-crack.json", "blend-coarse-ce.json", "ce-point-load.json"] {
        check_solution(name, &scene(name));
    }
    let _ = std::fs::remove_dir_all(&dir);
    // a row system of another scene is refused, naming both models
    let bond = scene("bar-point-load.json");
    let rows = scene("blend-point-load.json").row_system().unwrap();
    let e = bond
        .solution_from(
            &rows,
            vec![0.0; rows.dofs().n_dofs()],
            linpd::solve::SolveReport::new(linpd::solve::SolverId::Lu, 0, 0),
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("blend") && e.contains("bond"), "{e}");
}

#[test]
fn rows_refuse_what_they_cannot_do() {
    // the 2D/3D blended bond model is assembled whole (its local elements have no block rows)
    let e = scene("plate-crack-blend-2d.json").row_system().err().unwrap().to_string();
    assert!(
        e.starts_with("model.type: row-block assembly") && e.contains("pd_regions") && e.contains("blended"),
        "{e}"
    );
    let rows = scene("bar-point-load.json").row_system().unwrap();
    let n = rows.n();
    let e = rows.rows(0, n + 1).unwrap_err().to_string();
    assert!(e.contains("not a range"), "{e}");
    assert!(rows.rows(3, 2).is_err());
    assert_eq!(rows.rows(5, 5).unwrap().indptr, vec![0]);
}
