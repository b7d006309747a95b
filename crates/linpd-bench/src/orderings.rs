//! `linpd bench --orderings`: fill-reducing orderings for the sparse Cholesky of PD lattices.
//!
//! Cases (`--quick` shrinks them): `ord-3d-20` (bond, 20^3 nodes, `delta = 3h`, bottom 3
//! planes clamped: the matrix of the `3d-20` case), `ord-2d-201` (bond, plane stress, 201^2
//! nodes, `delta = 3h`, bottom 3 rows clamped), `ord-lps-3d-16` (LPS, 16^3 nodes,
//! `delta = 3h`, bottom 3 planes clamped; the tangent reaches `2 delta`).
//!
//! Orderings: `nd` (the lattice nested dissection of the models, [`nested_dissection`]),
//! `nd-planar` (its first version, [`planar_nested_dissection`]), `amd` (faer's), and with the
//! `metis` feature `metis` (`METIS_NodeND` on the node graph: nodes with a free DOF, coupled
//! where `A_ff` has a nonzero block; the node order expanded to the free DOFs). Each reports
//! the ordering, symbolic, numeric and solve seconds (best of [`REPEAT`]), faer's stored
//! `nnz(L)` (relaxed supernodes include explicit zeros), the exact `nnz(L)` of a simplicial
//! analysis (comparable with CHOLMOD's `L()`), the flops of faer's factorization
//! ([`Cholesky::flops`]) and the relative residual. With `--peers` each matrix is exported for
//! CHOLMOD (`benches/peers/peer_bench.py`), which runs in the same invocation.

use linpd_bond::{nested_dissection, planar_nested_dissection, BondOperator, Pattern};
use linpd_core::family::lattice_stencil;
use linpd_core::PlaneModel;
use linpd_core::{two_hop_stencil, DofMap, Grid, Kernel, Material, Micromodulus, Model, Normalization, Placement};
use linpd_lps::{Influence, LpsModel, LpsParams};
use linpd_solve::{relative_residual, Cholesky};
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

/// Timings are the best of this many runs (the machine is shared; the minimum is the least
/// disturbed run).
pub const REPEAT: usize = 2;

type Csc = faer::sparse::SparseColMat<usize, f64>;

struct Case {
    name: String,
    grid: Grid,
    a: Csc,
    dofs: DofMap,
    /// Lattice offsets the model couples.
    stencil: Vec<[i64; 3]>,
    /// Slab thickness of the planar baseline (the stencil's reach).
    reach: usize,
}

fn clamped(grid: &Grid, dim: usize, planes: i64) -> DofMap {
    let mut mask = vec![false; dim * grid.len()];
    for n in 0..grid.len() {
        if grid.lattice_index(n)[dim - 1] < planes {
            (0..dim).for_each(|a| mask[dim * n + a] = true);
        }
    }
    DofMap::new(dim, &mask)
}

fn bond_case(name: &str, dim: usize, nodes: usize, m: usize) -> Case {
    let plane = (dim == 2).then_some(PlaneModel::Stress);
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane,
        partial_volume: false,
    };
    let last = (nodes - 1) as f64;
    let grid = Grid::new(&vec![0.0; dim], &vec![last; dim], 1.0, 0.0, Placement::Vertex).expect("grid");
    let op = BondOperator::on_grid(&grid, m as f64, &mm, &Material::default()).expect("operator");
    let dofs = clamped(&grid, dim, m as i64);
    let pattern = Pattern::new(&op, &dofs);
    let mut values = vec![0.0; pattern.nnz()];
    pattern.fill(&op, &dofs, &mut values);
    let a = Csc::new(pattern.symbolic().clone(), values);
    Case { name: name.into(), grid, a, dofs, stencil: lattice_stencil(dim, m as f64), reach: m }
}

fn lps_case(name: &str, nodes: usize, m: usize) -> Case {
    let last = (nodes - 1) as f64;
    let grid = Grid::new(&[0.0; 3], &[last; 3], 1.0, 0.0, Placement::Vertex).expect("grid");
    let params = LpsParams {
        K: 2.0,
        G: 0.5,
        horizon: m as f64,
        influence: Influence::InverseDistance,
        partial_volume: false,
        plane: None,
    };
    let model = LpsModel::new(&grid, &params).expect("LPS model");
    let dofs = clamped(&grid, 3, m as i64);
    let a = model.assemble_free(&dofs);
    Case { name: name.into(), grid, a, dofs, stencil: two_hop_stencil(&lattice_stencil(3, m as f64)), reach: 2 * m }
}

/// `METIS_NodeND` on the node graph of `A_ff`, expanded to the free DOFs.
#[cfg(feature = "metis")]
fn metis_order(a: &Csc, dofs: &DofMap) -> Vec<usize> {
    let d = dofs.dim();
    let free = dofs.free_dofs();
    let mut local = vec![usize::MAX; dofs.n_nodes()];
    let mut nodes = Vec::new();
    for &g in &free {
        if local[g / d] == usize::MAX {
            local[g / d] = nodes.len();
            nodes.push(g / d);
        }
    }
    let mut adj: Vec<Vec<i32>> = vec![Vec::new(); nodes.len()];
    let (cp, ri) = (a.symbolic().col_ptr(), a.symbolic().row_idx());
    for c in 0..a.ncols() {
        let nc = local[free[c] / d];
        for &r in &ri[cp[c]..cp[c + 1]] {
            let nr = local[free[r] / d];
            if nr != nc {
                adj[nc].push(nr as i32);
            }
        }
    }
    let mut xadj = vec![0i32];
    let mut adjncy = Vec::new();
    for l in &mut adj {
        l.sort_unstable();
        l.dedup();
        adjncy.extend_from_slice(l);
        xadj.push(adjncy.len() as i32);
    }
    let mut n = nodes.len() as i32;
    let mut perm = vec![0i32; nodes.len()];
    let mut iperm = vec![0i32; nodes.len()];
    let mut options = [0i32; metis_sys::METIS_NOPTIONS as usize];
    // SAFETY: xadj/adjncy are a valid CSR graph of n vertices (no self loops, symmetric), perm
    // and iperm have n entries, options has METIS_NOPTIONS entries.
    let status = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_NodeND(
            &mut n,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    assert_eq!(status, metis_sys::rstatus_et_METIS_OK, "METIS_NodeND failed");
    let mut out = Vec::with_capacity(a.nrows());
    for &p in &perm {
        let node = nodes[p as usize];
        out.extend((0..d).filter_map(|c| dofs.free(d * node + c)));
    }
    out
}

/// Exact `nnz(L)` (no relaxed-supernode padding): a simplicial symbolic analysis.
fn exact_nnz_l(a: &Csc, perm: Option<&[usize]>) -> usize {
    use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering};
    use faer::sparse::linalg::SupernodalThreshold;
    let inv: Vec<usize>;
    let ordering = match perm {
        None => SymmetricOrdering::Amd,
        Some(p) => {
            let mut q = vec![0usize; p.len()];
            p.iter().enumerate().for_each(|(new, &old)| q[old] = new);
            inv = q;
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(p, &inv, p.len()))
        }
    };
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
        ..Default::default()
    };
    factorize_symbolic_cholesky(a.symbolic(), faer::Side::Lower, ordering, params).expect("symbolic").len_val()
}

fn best<T>(f: impl FnMut() -> T) -> (f64, T) {
    crate::best_of(REPEAT, f)
}

fn run_ordering(case: &Case, b: &[f64], name: &str, order: &dyn Fn() -> Option<Vec<usize>>) -> Value {
    eprintln!("[bench] {}: ordering {name}", case.name);
    let (t_ord, perm) = best(order);
    let (t_sym, chol) = best(|| Cholesky::analyze_with_ordering(&case.a, perm.as_deref()).expect("analysis"));
    let (t_num, fac) = best(|| chol.factor(&case.a).expect("SPD"));
    let (t_sol, u) = best(|| fac.solve(b));
    json!({
        "time_ordering": t_ord, "time_symbolic": t_sym, "time_numeric": t_num, "time_solve": t_sol,
        "time_total": t_ord + t_sym + t_num,
        "nnz_l": chol.nnz_factor(), "nnz_l_exact": exact_nnz_l(&case.a, perm.as_deref()), "flops": chol.flops(),
        "rel_residual": relative_residual(&case.a, true, &u, b),
    })
}

/// Writes `A_ff` (both triangles, one triplet per stored entry), the right-hand side and the
/// descriptor in the format of benches/peers/README.md.
fn export(dir: &Path, case: &Case, b: &[f64]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let a = &case.a;
    let n = a.nrows() as u64;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{}.coo.bin", case.name)))?);
    for v in [n, n, a.val().len() as u64] {
        w.write_all(&v.to_le_bytes())?;
    }
    for &r in a.symbolic().row_idx() {
        w.write_all(&(r as u64).to_le_bytes())?;
    }
    for c in 0..a.ncols() {
        for _ in a.symbolic().col_range(c) {
            w.write_all(&(c as u64).to_le_bytes())?;
        }
    }
    for v in a.val() {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{}.rhs.bin", case.name)))?);
    w.write_all(&n.to_le_bytes())?;
    for v in b {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    // These cases compare Cholesky only: the peers' CG is capped at one iteration.
    let desc = json!({"name": case.name, "n": n, "nnz": a.val().len(), "cg_rtol": 1e-8, "cg_maxiter": 1});
    std::fs::write(dir.join(format!("{}.json", case.name)), desc.to_string())
}

/// Runs the ordering cases (exporting their matrices to `export_dir` for the peers).
pub fn run(quick: bool, export_dir: Option<&Path>) -> Value {
    let specs: [(&str, usize); 3] = if quick {
        [("ord-3d-20", 8), ("ord-2d-201", 31), ("ord-lps-3d-16", 8)]
    } else {
        [("ord-3d-20", 20), ("ord-2d-201", 201), ("ord-lps-3d-16", 16)]
    };
    let mut out = serde_json::Map::new();
    for (k, (name, nodes)) in specs.into_iter().enumerate() {
        eprintln!("[bench] {name}: building");
        let case = match k {
            0 => bond_case(name, 3, nodes, 3),
            1 => bond_case(name, 2, nodes, 3),
            _ => lps_case(name, nodes, 3),
        };
        // A smooth load over the free DOFs.
        let b: Vec<f64> = (0..case.a.nrows()).map(|i| 1e-3 * (1.0 + (i as f64 * 0.37).sin())).collect();
        let mut r = json!({"unknowns": case.a.nrows(), "nnz_a": case.a.val().len(), "stencil": case.stencil.len()});
        r["nd"] = run_ordering(&case, &b, "nd", &|| Some(nested_dissection(&case.grid, &case.stencil, &case.dofs)));
        r["nd-planar"] = run_ordering(&case, &b, "nd-planar", &|| {
            Some(planar_nested_dissection(&case.grid, case.reach, &case.dofs))
        });
        r["amd"] = run_ordering(&case, &b, "amd", &|| None);
        #[cfg(feature = "metis")]
        {
            r["metis"] = run_ordering(&case, &b, "metis", &|| Some(metis_order(&case.a, &case.dofs)));
        }
        if let Some(dir) = export_dir {
            eprintln!("[bench] {name}: exporting the matrix for the peers");
            if let Err(e) = export(dir, &case, &b) {
                r["export_error"] = json!(e.to_string());
            }
        }
        out.insert(name.into(), r);
    }
    Value::Object(out)
}

/// Per case and ordering: our total (ordering + symbolic + numeric) and numeric time over
/// CHOLMOD's (analyze + factor, and factor), and the exact `nnz(L)` over CHOLMOD's `L()`.
pub fn ratios(ours: &Value, peers: &Value) -> Value {
    let mut out = serde_json::Map::new();
    let Some(cases) = ours.as_object() else { return Value::Null };
    for (name, c) in cases {
        let Some(p) = peers["cases"].get(name) else { continue };
        let (Some(ana), Some(fac), Some(nnz)) =
            (p["cholmod_analyze"].as_f64(), p["cholmod_factor"].as_f64(), p["cholmod_nnz_l"].as_f64())
        else {
            continue;
        };
        let mut r = serde_json::Map::new();
        for (key, o) in c.as_object().into_iter().flatten() {
            let (Some(total), Some(num), Some(exact)) =
                (o["time_total"].as_f64(), o["time_numeric"].as_f64(), o["nnz_l_exact"].as_f64())
            else {
                continue;
            };
            r.insert(
                key.clone(),
                json!({"total_ratio_to_cholmod": total / (ana + fac), "numeric_ratio_to_cholmod": num / fac,
                       "nnz_l_exact_ratio_to_cholmod": exact / nnz}),
            );
        }
        out.insert(name.clone(), Value::Object(r));
    }
    Value::Object(out)
}
