//! Lab: fill and time of Cholesky orderings on PD lattices (not part of the bench).
use linpd_bond::{BondOperator, Pattern};
use linpd_core::family::lattice_stencil;
use linpd_core::ordering::{nested_dissection_with, old_nested_dissection, two_hop_stencil, LeafOrder, NdParams};
use linpd_core::{DofMap, Grid, Kernel, Material, Micromodulus, Model, Normalization, Placement};
use linpd_lps::{Influence, LpsModel, LpsParams};
use linpd_solve::Cholesky;
use std::time::Instant;

fn metis_order(a: &faer::sparse::SparseColMat<usize, f64>, dofs: &DofMap) -> Vec<usize> {
    // Compress: free DOF -> node, node graph over nodes with a free DOF.
    let d = dofs.dim();
    let free = dofs.free_dofs();
    let mut node_of = vec![usize::MAX; dofs.n_nodes()];
    let mut nodes = Vec::new();
    for &g in &free {
        let n = g / d;
        if node_of[n] == usize::MAX {
            node_of[n] = nodes.len();
            nodes.push(n);
        }
    }
    let nn = nodes.len();
    let mut adj: Vec<Vec<i32>> = vec![Vec::new(); nn];
    let (cp, ri) = (a.symbolic().col_ptr(), a.symbolic().row_idx());
    for c in 0..a.ncols() {
        let nc = node_of[free[c] / d];
        for &r in &ri[cp[c]..cp[c + 1]] {
            let nr = node_of[free[r] / d];
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
    let mut n = nn as i32;
    let mut perm = vec![0i32; nn];
    let mut iperm = vec![0i32; nn];
    let mut options = [-1i32; metis_sys::METIS_NOPTIONS as usize];
    unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        let r = metis_sys::METIS_NodeND(
            &mut n,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        );
        assert_eq!(r, metis_sys::rstatus_et_METIS_OK);
    }
    let mut out = Vec::with_capacity(a.nrows());
    for &p in &perm {
        let node = nodes[p as usize];
        for c in 0..d {
            if let Some(f) = dofs.free(d * node + c) {
                out.push(f);
            }
        }
    }
    out
}

struct Case {
    name: String,
    grid: Grid,
    a: faer::sparse::SparseColMat<usize, f64>,
    dofs: DofMap,
    stencil: Vec<[i64; 3]>,
    reach: usize,
}

fn bond_case(dim: usize, nodes: usize, m: usize) -> Case {
    let plane = (dim == 2).then_some(linpd_core::PlaneModel::Stress);
    let mm = Micromodulus { kernel: Kernel::InverseDistance, normalization: Normalization::Discrete, modulus: 1.0, plane, partial_volume: false };
    let last = (nodes - 1) as f64;
    let grid = Grid::new(&vec![0.0; dim], &vec![last; dim], 1.0, 0.0, Placement::Vertex).unwrap();
    let op = BondOperator::on_grid(&grid, m as f64, &mm, &Material::default()).unwrap();
    let mut mask = vec![false; dim * grid.len()];
    for n in 0..grid.len() {
        let k = grid.lattice_index(n);
        if k[dim - 1] < m as i64 {
            (0..dim).for_each(|a| mask[dim * n + a] = true);
        }
    }
    let dofs = DofMap::new(dim, &mask);
    let pattern = Pattern::new(&op, &dofs);
    let mut values = vec![0.0; pattern.nnz()];
    pattern.fill(&op, &dofs, &mut values);
    let a = faer::sparse::SparseColMat::new(pattern.symbolic().clone(), values);
    Case { name: format!("bond-{dim}d-{nodes}-m{m}"), grid, a, dofs, stencil: lattice_stencil(dim, m as f64), reach: m }
}

fn lps_case(nodes: usize, m: usize) -> Case {
    let last = (nodes - 1) as f64;
    let grid = Grid::new(&[0.0; 3], &[last; 3], 1.0, 0.0, Placement::Vertex).unwrap();
    let params = LpsParams { K: 2.0, G: 0.5, horizon: m as f64, influence: Influence::InverseDistance, partial_volume: false, plane: None };
    let model = LpsModel::new(&grid, &params).unwrap();
    let mut mask = vec![false; 3 * grid.len()];
    for n in 0..grid.len() {
        if grid.lattice_index(n)[2] < m as i64 {
            (0..3).for_each(|a| mask[3 * n + a] = true);
        }
    }
    let dofs = DofMap::new(3, &mask);
    let a = model.assemble_free(&dofs);
    let s = lattice_stencil(3, m as f64);
    Case { name: format!("lps-3d-{nodes}-m{m}"), grid, a, dofs, stencil: two_hop_stencil(&s), reach: 2 * m }
}

/// Exact nnz(L) and flops (no supernode padding): a simplicial analysis.
fn exact(a: &faer::sparse::SparseColMat<usize, f64>, perm: Option<&[usize]>) -> (usize, f64) {
    use faer::sparse::linalg::cholesky::*;
    use faer::sparse::linalg::SupernodalThreshold;
    let inv: Vec<usize>;
    let ord = match perm {
        None => SymmetricOrdering::Amd,
        Some(p) => {
            let mut q = vec![0usize; p.len()];
            for (n, &o) in p.iter().enumerate() { q[o] = n; }
            inv = q;
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(p, &inv, p.len()))
        }
    };
    let params = CholeskySymbolicParams { supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL, ..Default::default() };
    let s = factorize_symbolic_cholesky(a.symbolic(), faer::Side::Lower, ord, params).unwrap();
    let SymbolicCholeskyRaw::Simplicial(x) = s.raw() else { panic!() };
    let cc: Vec<usize> = x.col_ptr().windows(2).map(|w| w[1] - w[0]).collect();
    let fl = cc.iter().map(|&c| (c as f64).powi(2)).sum();
    if std::env::var("LAB_PROFILE").is_ok() {
        let n = cc.len();
        let dense = (0..n).rev().take_while(|&j| cc[j] == n - j).count();
        let mut dec = [0f64; 10];
        for j in 0..n { dec[j * 10 / n] += (cc[j] as f64).powi(2); }
        let tot: f64 = dec.iter().sum();
        eprintln!("   top dense block {dense}; flops by decile of the order: {:?}", dec.iter().map(|d| (100.0 * d / tot).round()).collect::<Vec<_>>());
    }
    (s.len_val(), fl)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let numeric = args.iter().any(|a| a == "--numeric");
    let which: Vec<&str> = args.iter().skip(1).filter(|a| !a.starts_with("--")).map(|s| s.as_str()).collect();
    let mut cases = Vec::new();
    for w in &which {
        let p: Vec<&str> = w.split(':').collect();
        let n: usize = p[2].parse().unwrap();
        let m: usize = p[3].parse().unwrap();
        cases.push(match p[0] {
            "bond" => bond_case(p[1].parse().unwrap(), n, m),
            _ => lps_case(n, m),
        });
    }
    for c in &cases {
        println!("== {} n={} nnzA={}", c.name, c.a.nrows(), c.a.val().len());
        if std::env::var("LAB_PARAMS").is_ok() {
            let p = nested_dissection_with(&c.grid, &c.stencil, &c.dofs, NdParams { leaf: 64, leaf_order: LeafOrder::Natural, balance: true });
            params_lab(&c.a, &p);
            continue;
        }
        let mut orders: Vec<(String, Box<dyn Fn() -> Option<Vec<usize>>>)> = Vec::new();
        orders.push(("amd".into(), Box::new(|| None)));
        orders.push(("old-nd".into(), Box::new(|| Some(old_nested_dissection(&c.grid, c.reach, &c.dofs)))));
        for leaf in [64usize, 128, 256, 512] {
            for lo in [LeafOrder::Natural, LeafOrder::Amd] {
                let p = NdParams { leaf, leaf_order: lo, balance: true };
                orders.push((format!("nd-{leaf}-{lo:?}"), Box::new(move || Some(nested_dissection_with(&c.grid, &c.stencil, &c.dofs, p)))));
            }
        }
        orders.push(("metis".into(), Box::new(|| Some(metis_order(&c.a, &c.dofs)))));
        for (name, f) in &orders {
            let t = Instant::now();
            let perm = f();
            let t_ord = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let chol = Cholesky::analyze_with_ordering(&c.a, perm.as_deref()).unwrap();
            let t_sym = t.elapsed().as_secs_f64();
            let (ex, exf) = exact(&c.a, perm.as_deref());
            if let (Some(p), Ok(dir)) = (&perm, std::env::var("LAB_PERM_DIR")) {
                let bytes: Vec<u8> = p.iter().flat_map(|&x| (x as u64).to_le_bytes()).collect();
                std::fs::write(format!("{dir}/{}.{name}.perm.bin", c.name), bytes).unwrap();
            }
            let mut line = format!("{name:<18} ord {t_ord:7.3} sym {t_sym:7.3} nnzL {:>11} flops {:.3e} exact {:>11} {:.3e}", chol.nnz_factor(), chol.flops(), ex, exf);
            if numeric {
                let t = Instant::now();
                let _f = chol.factor(&c.a).unwrap();
                line += &format!(" num {:7.3}", t.elapsed().as_secs_f64());
            }
            println!("{line}");
        }
    }
}

/// `LAB_PARAMS=1 ordering_lab params CASE`: numeric time of the new ND with faer variants.
pub fn params_lab(a: &faer::sparse::SparseColMat<usize, f64>, perm: &[usize]) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::sparse::linalg::cholesky::*;
    use faer::sparse::linalg::{SupernodalThreshold, SymbolicSupernodalParams};
    let mut q = vec![0usize; perm.len()];
    for (n, &o) in perm.iter().enumerate() { q[o] = n; }
    let relax_default: &[(usize, f64)] = &[(4, 1.0), (16, 0.8), (48, 0.1), (usize::MAX, 0.05)];
    let relax_more: &[(usize, f64)] = &[(4, 1.0), (16, 0.8), (48, 0.2), (usize::MAX, 0.1)];
    let relax_much: &[(usize, f64)] = &[(8, 1.0), (32, 0.8), (96, 0.3), (usize::MAX, 0.15)];
    let relax_less: &[(usize, f64)] = &[(4, 1.0), (16, 0.5), (usize::MAX, 0.02)];
    let variants: Vec<(&str, Option<&[(usize, f64)]>, faer::Par)> = vec![
        ("default/rayon", Some(relax_default), faer::Par::rayon(0)),
        ("default/seq", Some(relax_default), faer::Par::Seq),
        ("none/rayon", None, faer::Par::rayon(0)),
        ("less/rayon", Some(relax_less), faer::Par::rayon(0)),
        ("more/rayon", Some(relax_more), faer::Par::rayon(0)),
        ("much/rayon", Some(relax_much), faer::Par::rayon(0)),
    ];
    let mut best = vec![f64::MAX; variants.len()];
    let mut info = vec![(0usize, 0f64); variants.len()];
    for _rep in 0..3 {
        for (k, (_, relax, par)) in variants.iter().enumerate() {
            let ord = SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(perm, &q, perm.len()));
            let params = CholeskySymbolicParams { supernodal_flop_ratio_threshold: SupernodalThreshold::AUTO, supernodal_params: SymbolicSupernodalParams { relax: *relax }, ..Default::default() };
            let s = factorize_symbolic_cholesky(a.symbolic(), faer::Side::Lower, ord, params).unwrap();
            let mut l = vec![0.0; s.len_val()];
            let req = s.factorize_numeric_llt_scratch::<f64>(*par, Default::default());
            let mut mem = MemBuffer::new(req);
            let t = Instant::now();
            s.factorize_numeric_llt::<f64>(&mut l, a.as_ref(), faer::Side::Lower, Default::default(), *par, MemStack::new(&mut mem), Default::default()).unwrap();
            best[k] = best[k].min(t.elapsed().as_secs_f64());
            let fl = match s.raw() {
                SymbolicCholeskyRaw::Supernodal(x) => (0..x.n_supernodes()).map(|k| { let w = x.supernode_end()[k]-x.supernode_begin()[k]; let b = x.col_ptr_for_row_idx()[k+1]-x.col_ptr_for_row_idx()[k]; (0..w).map(|i| ((w-i+b) as f64).powi(2)).sum::<f64>() }).sum(),
                _ => 0.0,
            };
            info[k] = (s.len_val(), fl);
        }
    }
    for (k, (name, _, _)) in variants.iter().enumerate() {
        println!("  {name:<16} nnzL {:>10} flops {:.3e} numeric best {:.3}", info[k].0, info[k].1, best[k]);
    }
}
