//! `linpd export --format petsc` (issue #16, item 2) against `linpd export` (Matrix Market) of
//! the same scene: the PETSc binary files, read back with [`linpd::problem::petsc::read_mat`]
//! and `read_vec` (written from PETSc's format description, not from the writer), hold the same
//! matrix and right-hand side **bit for bit** (both are the same `f64`s: binary `float64` is
//! exact, and sprs's Matrix Market values read back to the same bits), in CSR order (rows
//! ascending, columns ascending in a row); `coords.petsc` holds each row's node coordinate;
//! `K.petsc.info` the block size. Also: the reader refuses a truncated file and a wrong class id.

use linpd::problem::petsc::{read_mat, read_vec};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-petsc-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn export(scene: &Path, out: &Path, format: &str) {
    let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["export".as_ref(), scene.as_os_str(), "--out".as_ref(), out.as_os_str(), "-q".as_ref()])
        .args(["--format", format])
        .output()
        .expect("the linpd binary runs");
    assert!(o.status.success(), "linpd export {scene:?} --format {format}: {}", String::from_utf8_lossy(&o.stderr));
}

/// `(rows, cols, [(row, col, bits)])` sorted by row then column, from Matrix Market (sprs).
fn read_mtx_sorted(path: &Path) -> (usize, usize, Vec<(usize, usize, u64)>) {
    let t: sprs::TriMat<f64> = sprs::io::read_matrix_market(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut e: Vec<_> =
        t.row_inds().iter().zip(t.col_inds()).zip(t.data()).map(|((&r, &c), v)| (r, c, v.to_bits())).collect();
    e.sort_unstable_by_key(|&(r, c, _)| (r, c));
    (t.rows(), t.cols(), e)
}

/// `want_bs`: the block size the scene's constraints give (d for whole nodes, 1 when some node
/// has only some components constrained, e.g. a roller).
fn check_scene(name: &str, dim: usize, want_bs: usize) {
    let scene = data(name);
    let (mtx, pet) = (temp_dir(&format!("{name}-mtx")), temp_dir(&format!("{name}-petsc")));
    export(&scene, &mtx, "mtx");
    export(&scene, &pet, "petsc");

    let (m, n, want) = read_mtx_sorted(&mtx.join("K.mtx"));
    let k = read_mat(&pet.join("K.petsc")).unwrap();
    assert_eq!((k.nrows, k.ncols), (m, n), "{name}: sizes");
    let got: Vec<(usize, usize, u64)> = (0..k.nrows)
        .flat_map(|r| (k.row_ptr[r]..k.row_ptr[r + 1]).map(move |p| (r, p)))
        .map(|(r, p)| (r, k.col[p], k.val[p].to_bits()))
        .collect();
    assert_eq!(got.len(), want.len(), "{name}: stored entries");
    assert_eq!(got, want, "{name}: K.petsc differs from K.mtx");

    let (fm, _, f_want) = read_mtx_sorted(&mtx.join("f.mtx"));
    let f = read_vec(&pet.join("f.petsc")).unwrap();
    assert_eq!(f.len(), fm);
    assert!(f_want.iter().all(|&(r, _, bits)| f[r].to_bits() == bits), "{name}: f.petsc differs from f.mtx");

    // coords: row r is component c of node i (dofs.csv), its value x_i[c] from result positions
    let dofs = std::fs::read_to_string(pet.join("dofs.csv")).unwrap();
    assert_eq!(dofs, std::fs::read_to_string(mtx.join("dofs.csv")).unwrap(), "{name}: dofs.csv");
    let problem = linpd::problem::Problem::from_path(&scene).unwrap();
    let coords = read_vec(&pet.join("coords.petsc")).unwrap();
    for (line, &c) in dofs.lines().skip(1).zip(&coords) {
        let v: Vec<usize> = line.split(',').map(|s| s.parse().unwrap()).collect();
        assert_eq!(c.to_bits(), problem.nodes().position(v[1])[v[2]].to_bits(), "{name}: coords row {}", v[0]);
    }
    // block size d exactly when every node has all or none of its components free
    // (counted here from dofs.csv)
    let mut per_node = std::collections::BTreeMap::<usize, usize>::new();
    for line in dofs.lines().skip(1) {
        *per_node.entry(line.split(',').nth(1).unwrap().parse().unwrap()).or_default() += 1;
    }
    let bs = if per_node.values().all(|&k| k == dim) { dim } else { 1 };
    assert_eq!(bs, want_bs, "{name}: the scene's free DOFs (whole nodes or not) are not what the test expects");
    let info = std::fs::read_to_string(pet.join("K.petsc.info")).unwrap();
    assert_eq!(info.trim(), format!("-matload_block_size {bs}"), "{name}: K.petsc.info");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(pet.join("export.json")).unwrap()).unwrap();
    assert_eq!(doc["block_size"], bs);
    let _ = std::fs::remove_dir_all(&mtx);
    let _ = std::fs::remove_dir_all(&pet);
}

#[test]
fn petsc_export_equals_matrix_market_3d() {
    check_scene("cantilever-3d.json", 3, 3);
}

#[test]
fn petsc_export_equals_matrix_market_2d_and_1d() {
    // the plate's symmetry constraints fix one component of some nodes: block size 1
    check_scene("plate-hole-2d.json", 2, 1);
    check_scene("bar-point-load.json", 1, 1);
}

/// `--format petsc64`: the same matrix and vectors with 64-bit integers (PETSc configured
/// `--with-64-bit-indices`): the class id as an 8-byte big-endian integer, every size, row
/// length and column 8 bytes, so the file is `4 * 8 + M * 8 + nnz * (8 + 8)` bytes long.
#[test]
fn petsc64_export_holds_the_same_system_with_64_bit_integers() {
    let scene = data("cantilever-3d.json");
    let (p32, p64) = (temp_dir("cantilever-32"), temp_dir("cantilever-64"));
    export(&scene, &p32, "petsc");
    export(&scene, &p64, "petsc64");
    let (a, b) = (read_mat(&p32.join("K.petsc")).unwrap(), read_mat(&p64.join("K.petsc")).unwrap());
    assert_eq!(a, b, "K.petsc");
    for f in ["f.petsc", "coords.petsc"] {
        assert_eq!(read_vec(&p32.join(f)).unwrap(), read_vec(&p64.join(f)).unwrap(), "{f}");
    }
    let bytes = std::fs::read(p64.join("K.petsc")).unwrap();
    assert_eq!(bytes[..8], 1_211_216i64.to_be_bytes());
    assert_eq!(bytes.len(), 4 * 8 + a.nrows * 8 + a.val.len() * 16);
    assert_eq!(bytes[8..16], (a.nrows as i64).to_be_bytes());
    let f = std::fs::read(p64.join("f.petsc")).unwrap();
    assert_eq!(f[..8], 1_211_214i64.to_be_bytes());
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p64.join("export.json")).unwrap()).unwrap();
    assert!(doc["format"]["K.petsc"].as_str().unwrap().contains("int64"), "{doc}");
    let _ = std::fs::remove_dir_all(&p32);
    let _ = std::fs::remove_dir_all(&p64);
}

#[test]
fn petsc_reader_refuses_damaged_files() {
    let dir = temp_dir("damaged");
    export(&data("bar-point-load.json"), &dir, "petsc");
    let bytes = std::fs::read(dir.join("K.petsc")).unwrap();
    let cut = dir.join("cut.petsc");
    std::fs::write(&cut, &bytes[..bytes.len() - 3]).unwrap();
    let e = read_mat(&cut).unwrap_err().to_string();
    assert!(e.contains("cut.petsc") && e.contains("too short for"), "{e}");
    // a Vec is not a Mat
    let e = read_mat(&dir.join("f.petsc")).unwrap_err().to_string();
    assert!(e.contains("class id 1211214"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
