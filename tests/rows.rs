//! Row-block assembly (`Problem::row_system`, `RowSystem::rows`; issue #16): rows computed from
//! their own nodes' bonds equal the rows of the assembled `A_ff` of `linpd export`
//! (`Problem::reduced_system`), over splits into 1, 2, 3 and 7 blocks whose cuts fall inside a
//! node's rows too. Same columns (bonds a defect cuts are explicit zeros in the assembled
//! pattern and absent from the block rows: compared on nonzeros); values to
//! `1e-13 max|A_ff|`: a diagonal entry is a sum over a node's bonds (m of about 30-120) that the
//! two assemblies may add in different orders, so they may differ by `m eps max|A|`, about 1e-14;
//! a wrong bond, sign or component changes an entry by O(max|A|). Also: the right-hand side is
//! export's bit for bit, and models without block rows and bad ranges are errors that say so.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use std::collections::BTreeMap;
use std::path::Path;

fn scene(name: &str) -> Problem {
    Problem::from_path(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)).unwrap()
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
    let p = scene(name);
    let sys = p.reduced_system(&NoProgress).unwrap();
    let rows = p.row_system().unwrap();
    let n = sys.n();
    assert_eq!(rows.n(), n);
    assert_eq!(rows.free_dofs(), &sys.free_dofs[..]);
    assert!(rows.rhs().iter().zip(&sys.f).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: rhs");
    let scale = sys.k.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
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
            assert_eq!(got.keys().collect::<Vec<_>>(), want.keys().collect::<Vec<_>>(), "{name}: {first}..{last}");
            let worst = got.iter().map(|(k, v)| (v - want[k]).abs()).fold(0.0f64, f64::max);
            assert!(worst <= 1e-13 * scale, "{name}: rows {first}..{last} differ by {worst:e} (max|A| {scale:e})");
        }
    }
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
fn rows_refuse_what_they_cannot_do() {
    let e = scene("lps-plate-2d.json").row_system().err().unwrap().to_string();
    assert!(e.contains("bond models only") && e.contains("lps"), "{e}");
    let rows = scene("bar-point-load.json").row_system().unwrap();
    let n = rows.n();
    let e = rows.rows(0, n + 1).unwrap_err().to_string();
    assert!(e.contains("not a range"), "{e}");
    assert!(rows.rows(3, 2).is_err());
    assert_eq!(rows.rows(5, 5).unwrap().indptr, vec![0]);
}
