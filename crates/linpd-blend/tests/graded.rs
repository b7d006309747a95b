//! The graded local mesh (`linpd_blend::graded_mesh`, issue #31): the ungraded mesh is the lattice's
//! element assembly, the tree is a tiling that keeps the grading and 2:1 balance rules, the
//! hanging-node constraints pass the patch test in 2D and 3D, affine energies are exact, and
//! the unknowns fall against the uniform mesh.

use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use linpd_blend::graded_mesh::{Cell, GradedMesh, Grading, GradingError, LatticeBox};
use linpd_blend::LatticeBlend;
use linpd_bond::BondOperator;
use linpd_core::sparse::Csc;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};

/// `C_abcd = lambda d_ab d_cd + mu (d_ac d_bd + d_ad d_bc)` in the `3 x 3 x 3 x 3` layout.
fn isotropic(d: usize, lambda: f64, mu: f64) -> [f64; 81] {
    let dl = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
    let mut c = [0.0; 81];
    for a in 0..d {
        for b in 0..d {
            for e in 0..d {
                for f in 0..d {
                    c[((a * 3 + b) * 3 + e) * 3 + f] =
                        lambda * dl(a, b) * dl(e, f) + mu * (dl(a, e) * dl(b, f) + dl(a, f) * dl(b, e));
                }
            }
        }
    }
    c
}

fn dense(a: &Csc) -> Vec<Vec<f64>> {
    let mut m = vec![vec![0.0; a.ncols()]; a.nrows()];
    for t in a.triplet_iter() {
        m[t.row][t.col] += *t.val;
    }
    m
}

/// The level-0 cells of a disc of radius `r` (in lattice steps) around `c`, or a slit.
fn disc(c: [f64; 3], r: f64) -> impl Fn(&[usize]) -> bool {
    move |k: &[usize]| k.iter().enumerate().map(|(a, &v)| (v as f64 + 0.5 - c[a]).powi(2)).sum::<f64>() <= r * r
}

// ---- 1. no grading: the lattice's elements -------------------------------------------------

fn micromodulus() -> Micromodulus {
    Micromodulus {
        kernel: Kernel::Constant,
        normalization: Normalization::Continuum,
        modulus: 2.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: true,
    }
}

/// `D_i = (1/2) sum_j w_ij e (x) xi (x) e (x) xi` (no mirrored nodes), as lattice.rs defines it.
fn node_moduli(op: &BondOperator, d: usize, i: usize) -> [f64; 81] {
    let mut t = [0.0; 81];
    for (&j, &w) in op.family().neighbors(i).iter().zip(op.weights(i)) {
        let (xi, e) = (op.bond_vector(i, j as usize), op.unit(i, j as usize));
        for a in 0..d {
            for b in 0..d {
                for c in 0..d {
                    for f in 0..d {
                        t[((a * 3 + b) * 3 + c) * 3 + f] += 0.5 * w * e[a] * xi[b] * e[c] * xi[f];
                    }
                }
            }
        }
    }
    t
}

#[test]
fn no_grading_is_the_lattice_element_assembly() {
    for dim in [2usize, 3] {
        let n = if dim == 2 { 14 } else { 8 };
        let h = 1.0 / n as f64;
        let g = Grid::new(&vec![0.0; dim], &[1.0, 1.0, 0.5][..dim], h, 0.0, Placement::Cell).unwrap();
        let op = BondOperator::on_grid(&g, 3.0 * h, &micromodulus(), &Material::default()).unwrap();
        // beta = 0 everywhere: A is the local model alone, the elements with C_e vol_e = sum D_c / n_c
        let blend = LatticeBlend::new(&op, &g, 3.0 * h, vec![0.0; g.len()], None, &vec![false; g.len()]).unwrap();
        let counts = g.counts();
        let lattice = LatticeBox::new(&vec![0.5 * h; dim], h, &counts[..dim]).unwrap();
        let mesh = GradedMesh::new(&lattice, &|_| true, Grading::new(1, 4).unwrap()).unwrap();
        assert!(mesh.hanging().is_empty() && mesh.cells().iter().all(|e| e.level == 0));
        assert_eq!(mesh.n_masters(), g.len());
        let d_i: Vec<[f64; 81]> = (0..g.len()).map(|i| node_moduli(&op, dim, i)).collect();
        // complete cells at each node: 2 choices per axis, one at a box face
        let n_cells =
            |k: [usize; 3]| (0..dim).map(|a| if k[a] == 0 || k[a] == counts[a] - 1 { 1 } else { 2 }).product::<usize>();
        let c_of_cell = |e: &Cell| {
            let mut c = [0.0; 81];
            for corner in 0..1 << dim {
                let k = e.corner(dim, corner);
                let i = g.node_at(k.map(|v| v as i64)).unwrap();
                for (x, y) in c.iter_mut().zip(&d_i[i]) {
                    *x += y / n_cells(k) as f64 / h.powi(dim as i32);
                }
            }
            c
        };
        let (km, a) = (dense(&mesh.stiffness(&c_of_cell)), dense(blend.stiffness()));
        let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let err = km.iter().flatten().zip(a.iter().flatten()).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        println!("{dim}D ungraded vs lattice elements: max |K_M - A| / max |A| = {:.2e}", err / scale);
        // the same element routine; only the order of the sums differs (a few ulps)
        assert!(err <= 1e-14 * scale, "{dim}D: {:e}", err / scale);
    }
}

// ---- 2. tiling, grading rule and balance ---------------------------------------------------

/// Whether two closed boxes `[o, o + s]` (lattice steps) share a point.
fn touch(a: &Cell, b: &Cell, d: usize) -> bool {
    (0..d).all(|x| a.origin[x] <= b.origin[x] + b.side() && b.origin[x] <= a.origin[x] + a.side())
}

/// Which level-0 cells stay fine.
type Fine<'a> = &'a dyn Fn(&[usize]) -> bool;

/// Brute-force checks of a mesh against the rules of the module docs.
fn check_rules(mesh: &GradedMesh, fine: &dyn Fn(&[usize]) -> bool, m: usize) {
    let d = mesh.dim();
    let n = mesh.lattice().counts();
    let mc = [0, 1, 2].map(|a| if a < d { n[a] - 1 } else { 1 });
    // tiling: every lattice cell covered exactly once, leaves inside the box and aligned
    let mut cover = vec![0u8; mc.iter().product()];
    for e in mesh.cells() {
        let s = e.side();
        let ext = [0, 1, 2].map(|a| if a < d { s } else { 1 });
        assert!((0..d).all(|a| e.origin[a] % s == 0 && e.origin[a] + s <= mc[a]), "{e:?} unaligned or outside");
        for z in 0..ext[2] {
            for y in 0..ext[1] {
                for x in 0..ext[0] {
                    let k = [e.origin[0] + x, e.origin[1] + y, e.origin[2] + z];
                    cover[k[0] + mc[0] * (k[1] + mc[1] * k[2])] += 1;
                    assert!(e.level == 0 || !fine(&k[..d]), "{e:?} covers the fine cell {k:?}");
                }
            }
        }
    }
    assert!(cover.iter().all(|&c| c == 1), "the leaves tile the box");
    // grading rule: gap to the fine cells >= m (2^l - 1) lattice steps
    let fine_cells: Vec<Cell> = mesh.cells().iter().filter(|e| e.level == 0 && fine(&e.origin[..d])).copied().collect();
    for e in mesh.cells().iter().filter(|e| e.level > 0) {
        let need = m * ((1 << e.level) - 1);
        for f in &fine_cells {
            let gap = (0..d)
                .map(|a| {
                    let (lo, hi) = (e.origin[a] as i64, (e.origin[a] + e.side()) as i64);
                    (f.origin[a] as i64 - hi).max(lo - f.origin[a] as i64 - 1).max(0)
                })
                .max()
                .unwrap();
            assert!(gap as usize >= need, "{e:?} is {gap} steps from {f:?}, the rule needs {need}");
        }
    }
    // 2:1 balance across faces, edges and corners
    let cells = mesh.cells();
    for (i, a) in cells.iter().enumerate() {
        for b in &cells[i + 1..] {
            if touch(a, b, d) {
                assert!(a.level.abs_diff(b.level) <= 1, "{a:?} and {b:?} touch");
            }
        }
    }
    // constraints: masters are regular, weights sum to 1
    for hn in mesh.hanging() {
        assert!(hn.masters.iter().all(|&(j, _)| mesh.master_of(j).is_some()), "a master hangs");
        assert!((hn.masters.iter().map(|m| m.1).sum::<f64>() - 1.0).abs() < 1e-15);
    }
}

#[test]
fn tiling_grading_and_balance_on_irregular_regions() {
    let slit = |k: &[usize]| k[1] == 20 && (8..30).contains(&k[0]);
    let disc2 = disc([13.0, 21.0, 0.0], 4.5);
    let ball = disc([17.0, 15.0, 16.0], 3.0);
    let cases: [(&[usize], Fine); 3] = [(&[45, 37], &slit), (&[45, 37], &disc2), (&[37, 33, 35], &ball)];
    for (n, fine) in cases {
        for m in [1, 2, 3] {
            let lattice = LatticeBox::new(&vec![0.0; n.len()], 0.1, n).unwrap();
            let mesh = GradedMesh::new(&lattice, fine, Grading::new(m, 5).unwrap()).unwrap();
            let top = mesh.cells().iter().map(|e| e.level).max().unwrap();
            println!(
                "{n:?}, m = {m}: {} leaves up to level {top}, {} hanging",
                mesh.cells().len(),
                mesh.hanging().len()
            );
            // the rules must not hold vacuously
            assert!(top >= 2 && !mesh.hanging().is_empty());
            check_rules(&mesh, fine, m);
        }
    }
}

// ---- 3. patch test, 4. affine energy -------------------------------------------------------

/// Solves `K_M u_M = 0` on the interior masters with `u_M` prescribed on the box faces;
/// returns `u` at every node.
fn solve_with_boundary(mesh: &GradedMesh, k: &Csc, u_bc: &dyn Fn([f64; 3]) -> [f64; 3]) -> Vec<f64> {
    let d = mesh.dim();
    let n = mesh.lattice().counts();
    let mut fixed = vec![false; d * mesh.n_masters()];
    let mut u = vec![0.0; d * mesh.n_masters()];
    for (i, k) in mesh.nodes().iter().enumerate() {
        let Some(m) = mesh.master_of(i) else { continue };
        if (0..d).any(|a| k[a] == 0 || k[a] == n[a] - 1) {
            let v = u_bc(mesh.position(i));
            for a in 0..d {
                fixed[d * m + a] = true;
                u[d * m + a] = v[a];
            }
        }
    }
    let free: Vec<usize> = (0..u.len()).filter(|&p| !fixed[p]).collect();
    let mut slot = vec![usize::MAX; u.len()];
    for (s, &p) in free.iter().enumerate() {
        slot[p] = s;
    }
    let (mut t, mut rhs) = (Vec::new(), Mat::<f64>::zeros(free.len(), 1));
    for e in k.triplet_iter() {
        match (slot[e.row], slot[e.col]) {
            (r, c) if r != usize::MAX && c != usize::MAX => t.push(Triplet::new(r, c, *e.val)),
            (r, usize::MAX) if r != usize::MAX => rhs[(r, 0)] -= e.val * u[e.col],
            _ => {}
        }
    }
    let kff = SparseColMat::<usize, f64>::try_new_from_triplets(free.len(), free.len(), &t).unwrap();
    let x = kff.sp_cholesky(Side::Lower).expect("K_ff is SPD").solve(rhs);
    for (s, &p) in free.iter().enumerate() {
        u[p] = x[(s, 0)];
    }
    mesh.expand(&u)
}

/// `u = G x + c` with a non-symmetric `G` (stretch, shear and rotation).
fn affine(x: [f64; 3]) -> [f64; 3] {
    let g = [[0.013, -0.021, 0.007], [0.017, -0.009, 0.011], [-0.005, 0.019, 0.023]];
    let c = [0.3, -0.2, 0.1];
    [0, 1, 2].map(|a| c[a] + (0..3).map(|b| g[a][b] * x[b]).sum::<f64>())
}

#[test]
fn patch_test_across_hanging_nodes() {
    let cases: [(&[usize], f64); 2] = [(&[61, 53], 4.5), (&[29, 27, 25], 2.5)];
    for (n, r) in cases {
        let d = n.len();
        let lattice = LatticeBox::new(&[-0.3, 0.2, 0.1][..d], 0.05, n).unwrap();
        let fine = disc([17.0, 23.0, 11.0], r);
        let mesh = GradedMesh::new(&lattice, &fine, Grading::new(1, 4).unwrap()).unwrap();
        let hanging = mesh.hanging();
        let faces = hanging.iter().filter(|h| h.masters.len() == 4).count();
        assert!(hanging.len() > 10 && (d == 2 || faces > 0), "edge and face constraints exercised");
        let c = isotropic(d, 1.3, 0.7);
        let k = mesh.stiffness(&|_| c);
        let u = solve_with_boundary(&mesh, &k, &|x| affine_in(d, x));
        let (mut err, mut err_hanging, mut top) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..mesh.nodes().len() {
            let exact = affine_in(d, mesh.position(i));
            for a in 0..d {
                let e = (u[d * i + a] - exact[a]).abs();
                err = err.max(e);
                top = top.max(exact[a].abs());
                if mesh.master_of(i).is_none() {
                    err_hanging = err_hanging.max(e);
                }
            }
        }
        println!(
            "{d}D patch test: {} masters, {} hanging ({faces} on faces): max error / max |u| = {:.2e} (hanging nodes {:.2e})",
            mesh.n_masters(),
            hanging.len(),
            err / top,
            err_hanging / top
        );
        // the affine field is the discrete solution: only the factorization's rounding is left
        // (cond(K_ff) eps ~ 1e-13 on these sizes)
        assert!(err <= 1e-10 * top, "{d}D: {:e}", err / top);
    }
}

/// [`affine`] with the unused axes' terms dropped.
fn affine_in(d: usize, mut x: [f64; 3]) -> [f64; 3] {
    x[d..].iter_mut().for_each(|v| *v = 0.0);
    let mut u = affine(x);
    u[d..].iter_mut().for_each(|v| *v = 0.0);
    u
}

#[test]
fn affine_energy_is_exact() {
    let cases: [(&[usize], f64); 2] = [(&[41, 37], 3.5), (&[21, 19, 17], 2.5)];
    for (n, r) in cases {
        let d = n.len();
        let h = 0.1;
        let lattice = LatticeBox::new(&vec![0.0; d], h, n).unwrap();
        let mesh = GradedMesh::new(&lattice, &disc([9.0, 8.0, 7.0], r), Grading::new(2, 3).unwrap()).unwrap();
        assert!(!mesh.hanging().is_empty());
        // moduli varying per cell
        let c_of = |e: &Cell| isotropic(d, 1.0 + 0.3 * e.level as f64, 0.5 + 0.01 * (e.origin[0] % 7) as f64);
        let k = mesh.stiffness(&c_of);
        let mut um = vec![0.0; d * mesh.n_masters()];
        for i in 0..mesh.nodes().len() {
            if let Some(m) = mesh.master_of(i) {
                um[d * m..d * m + d].copy_from_slice(&affine_in(d, mesh.position(i))[..d]);
            }
        }
        let mut ku = vec![0.0; um.len()];
        linpd_core::sparse::matvec(&k, &um, &mut ku);
        let energy = 0.5 * um.iter().zip(&ku).map(|(a, b)| a * b).sum::<f64>();
        // sum over cells of vol/2 G : C : G (C has the minor symmetries: G:C:G = eps:C:eps)
        let gm = [0, 1, 2].map(|a| {
            let mut e = [0.0; 3];
            e[a] = 1.0;
            let (u1, u0) = (affine_in(d, e), affine_in(d, [0.0; 3]));
            [0, 1, 2].map(|b| u1[b] - u0[b])
        }); // gm[b][a] = G_ab
        let mut exact = 0.0;
        for e in mesh.cells() {
            let c = c_of(e);
            let vol = (h * e.side() as f64).powi(d as i32);
            let mut w = 0.0;
            for a in 0..d {
                for b in 0..d {
                    for p in 0..d {
                        for q in 0..d {
                            w += gm[b][a] * c[((a * 3 + b) * 3 + p) * 3 + q] * gm[q][p];
                        }
                    }
                }
            }
            exact += 0.5 * vol * w;
        }
        let rel = (energy - exact).abs() / exact;
        println!("{d}D affine energy: {energy:.15e} vs {exact:.15e} (relative {rel:.1e})");
        // exact in exact arithmetic; rounding of ~1e4 products of O(1) terms, with
        // cancellation of the rigid part c (|u| ~ 10 |G x|)
        assert!(rel <= 1e-11, "{d}D: {rel:e}");
    }
}

#[test]
fn bad_grading_is_a_named_error() {
    let lattice = LatticeBox::new(&[0.0, 0.0], 0.1, &[9, 9]).unwrap();
    assert_eq!(Grading::new(0, 3), Err(GradingError::NoCellsPerLevel));
    assert_eq!(Grading::new(1, Grading::MAX_LEVEL + 1), Err(GradingError::LevelTooHigh(Grading::MAX_LEVEL + 1)));
    assert!(GradedMesh::new(&lattice, &|_| false, Grading::new(1, Grading::MAX_LEVEL).unwrap()).is_ok());
    assert!(LatticeBox::new(&[0.0], 0.1, &[9]).is_err());
    assert!(LatticeBox::new(&[0.0, 0.0], 0.0, &[9, 9]).is_err());
    assert!(LatticeBox::new(&[0.0, 0.0], 0.1, &[9, 1]).is_err());
}

// ---- 5. unknowns against the uniform mesh --------------------------------------------------

#[test]
fn unknowns_per_level_against_the_uniform_mesh() {
    let cases: [(&[usize], f64); 2] = [(&[257, 257], 8.0), (&[65, 65, 65], 4.0)];
    for (n, r) in cases {
        let centre = [0.5 * (n[0] - 1) as f64; 3];
        let d = n.len();
        let lattice = LatticeBox::new(&vec![0.0; d], 1.0 / (n[0] - 1) as f64, n).unwrap();
        let uniform: usize = n.iter().product();
        for m in [1, 2, 4] {
            let t0 = std::time::Instant::now();
            let mesh = GradedMesh::new(&lattice, &disc(centre, r), Grading::new(m, 6).unwrap()).unwrap();
            let built = t0.elapsed().as_secs_f64();
            println!("{n:?}, fine disc r = {r} h, cells_per_level = {m}: {} masters vs {uniform} uniform nodes ({:.4}x), built in {built:.3} s", mesh.n_masters(), mesh.n_masters() as f64 / uniform as f64);
            for c in mesh.counts() {
                println!("  level {}: {} cells, {} masters, {} hanging", c.level, c.cells, c.masters, c.hanging);
            }
            let total: usize = mesh.counts().iter().map(|c| c.masters + c.hanging).sum();
            assert_eq!(total, mesh.nodes().len());
            assert!(mesh.counts()[0].cells > 0, "the fine disc is in the box");
            assert!(mesh.n_masters() * 10 < uniform, "far fewer unknowns than the uniform mesh");
        }
    }
}

/// The masters' rows built one at a time (`RowAssembler::stiffness_row`, what the graded blend
/// uses) are the rows of the assembled `K_M = T^T K T` (triplets), with a different tensor per
/// level so that a mix-up of leaves shows: `|row - K_M row| <= 1e-14 max |K_M|` (the same
/// products summed in another order), on a 2D and a 3D mesh with edge and face constraints.
#[test]
fn rows_one_at_a_time_are_the_assembled_rows() {
    let cases: [(&[usize], f64); 2] = [(&[41, 37], 4.5), (&[25, 23, 21], 2.5)];
    for (n, r) in cases {
        let d = n.len();
        let lattice = LatticeBox::new(&vec![0.0; d], 0.05, n).unwrap();
        let mesh = GradedMesh::new(&lattice, &disc([11.0, 9.0, 8.0], r), Grading::new(1, 3).unwrap()).unwrap();
        assert!(!mesh.hanging().is_empty());
        let moduli = |e: &Cell| isotropic(d, 1.3 + e.level as f64, 0.7 + 0.1 * e.level as f64);
        let k = dense(&mesh.stiffness(&moduli));
        let top = k.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let rows = mesh.row_assembler();
        for m in 0..mesh.n_masters() {
            for (j, blk) in rows.stiffness_row(m, &moduli) {
                for a in 0..d {
                    for b in 0..d {
                        let want = k[d * m + a][d * j + b];
                        assert!((blk[a * 3 + b] - want).abs() <= 1e-14 * top, "{d}D master {m}, block {j} ({a},{b})");
                    }
                }
            }
            // and no entry of K_M's row is missing from it
            let listed: Vec<usize> = rows.stiffness_row(m, &moduli).iter().map(|x| x.0).collect();
            for j in 0..mesh.n_masters() {
                let nonzero = (0..d).any(|a| (0..d).any(|b| k[d * m + a][d * j + b].abs() > 1e-14 * top));
                assert!(!nonzero || listed.contains(&j), "{d}D master {m}: column block {j} missing");
            }
        }
    }
}
