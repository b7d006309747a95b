//! The blended model on a graded local mesh (`linpd_blend::GradedBlend`, issue #31): without
//! grading it is the lattice blend; with grading it passes the patch test across level jumps
//! and its solution of affine boundary data is the affine field; `P` interpolates affine fields
//! exactly and `P^T` conserves force.

use linpd_blend::graded_blend::{Bond, FreeFaces, LocalMesh};
use linpd_blend::graded_mesh::Grading;
use linpd_blend::{beta_from_zone, GradedBlend, LatticeBlend, Profile};
use linpd_bond::BondOperator;
use linpd_core::sparse::Csc;
use linpd_core::{Grid, Kernel, Material, Micromodulus, Model, Normalization, Placement, PlaneModel};
use linpd_solve::{solve_model, Dirichlet, SolverSpec};

/// The graded blend on `g` (homogeneous, nothing kept) with one cell per level up to
/// `max_level`.
fn graded(g: &Grid, horizon: f64, beta: Vec<f64>, mirrored: &[bool], max_level: usize) -> GradedBlend {
    let local = LocalMesh { grading: Grading::new(1, max_level).unwrap(), free_faces: FreeFaces::Lattice };
    GradedBlend::new(bond(horizon), g, beta, None, mirrored, &vec![false; g.len()], local).unwrap()
}

/// The bond model of the operator of [`setting`] (homogeneous).
fn bond(horizon: f64) -> Bond<'static> {
    static MICROMODULUS: std::sync::OnceLock<Micromodulus> = std::sync::OnceLock::new();
    static MATERIAL: std::sync::OnceLock<Material> = std::sync::OnceLock::new();
    Bond {
        horizon,
        micromodulus: MICROMODULUS.get_or_init(micromodulus),
        material: MATERIAL.get_or_init(Material::default),
    }
}

fn micromodulus() -> Micromodulus {
    Micromodulus {
        kernel: Kernel::Constant,
        normalization: Normalization::Continuum,
        modulus: 2.0,
        plane: Some(PlaneModel::Stress),
        partial_volume: true,
    }
}

/// A box of `n` cells a side (`n/2` along z in 3D), `h = 1/n`, horizon `3h`, a layer of
/// `layer` spacings; `beta` = 1 in a ball of radius `r` at the centre, a cubic transition of
/// `3h`.
fn setting(dim: usize, n: usize, layer: f64, r: f64) -> (Grid, BondOperator, f64, Vec<f64>) {
    setting_in(dim, n, layer, r, [1.0, 1.0, 0.5])
}

/// [`setting`] in the box `[0, max]`.
fn setting_in(dim: usize, n: usize, layer: f64, r: f64, max: [f64; 3]) -> (Grid, BondOperator, f64, Vec<f64>) {
    let h = 1.0 / n as f64;
    let g = Grid::new(&vec![0.0; dim], &max[..dim], h, layer * h, Placement::Vertex).unwrap();
    let horizon = 3.0 * h;
    let op = BondOperator::on_grid(&g, horizon, &micromodulus(), &Material::default()).unwrap();
    let centre = max.map(|m| m / 2.0);
    let inside: Vec<bool> = (0..g.len())
        .map(|i| {
            let x = g.position(i);
            (0..dim).map(|a| (x[a] - centre[a]).powi(2)).sum::<f64>() <= r * r
        })
        .collect();
    let beta = beta_from_zone(&g, &inside, 3.0 * h, Profile::Cubic);
    (g, op, horizon, beta)
}

fn matvec(a: &Csc, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; a.nrows()];
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    for j in 0..a.ncols() {
        for p in cp[j]..cp[j + 1] {
            y[ri[p]] += v[p] * x[j];
        }
    }
    y
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// A displacement gradient for the affine fields.
const GRAD: [[f64; 3]; 3] = [[1e-3, 2e-3, -1e-3], [-5e-4, 3e-3, 1e-3], [2e-3, 0.0, -1e-3]];

fn affine(dim: usize, x: &[f64]) -> Vec<f64> {
    (0..dim).map(|a| (0..dim).map(|b| GRAD[a][b] * x[b]).sum()).collect()
}

/// Without grading (`max_level` 0) every node is a master, in node order, and `A` and `M` are
/// the lattice blend's: `|A_graded x - A x| <= 1e-13 |A| |x|` for a pseudo-random `x` (the same
/// terms summed in another order; rows have ~100 blocks).
#[test]
fn ungraded_equals_the_lattice_blend() {
    for (dim, n, r) in [(2, 40, 0.15), (3, 16, 0.22)] {
        let (g, op, horizon, beta) = setting(dim, n, 0.0, r);
        let mirrored = vec![false; g.len()];
        let lattice = LatticeBlend::new(&op, &g, horizon, beta.clone(), None, &mirrored).unwrap();
        let graded = graded(&g, horizon, beta, &mirrored, 0);
        assert_eq!(graded.master_nodes(), (0..g.len()).collect::<Vec<_>>().as_slice());
        let z = lattice.zones();
        assert!(z.pd > 0 && z.transition > 0 && z.local > 0, "{dim}D: {z:?}");
        let x: Vec<f64> = (0..dim * g.len()).map(|k| ((k * 7919) % 1000) as f64 / 1000.0 - 0.5).collect();
        // the graded model's A and M as applied (the shares listed, the rest stored) and
        // as assembled from their block rows
        let companion = graded.multigrid_companion().expect("the graded blend offers its companion");
        let applied = |m: &dyn Model| {
            let mut y = vec![0.0; x.len()];
            m.apply(&x, &mut y);
            y
        };
        for (name, a, b, b_applied) in [
            ("A", lattice.stiffness(), graded.stiffness(), applied(&graded)),
            ("M", lattice.companion(), graded.companion(), applied(&*companion)),
        ] {
            let scale = max_abs(a.val()) * max_abs(&x);
            let reference = matvec(a, &x);
            for (how, y) in [("assembled", matvec(&b, &x)), ("applied", b_applied)] {
                let diff = reference.iter().zip(&y).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
                println!("{dim}D {name} {how}: max |graded - lattice| / (|A| |x|) = {:.2e}", diff / scale);
                assert!(diff <= 1e-13 * scale, "{dim}D {name} {how}: {:e}", diff / scale);
            }
        }
    }
}

/// With grading (cells up to `8h`), `A u_M = 0` for an affine `u_M` on every master off the
/// supporting layer (the patch test across level jumps and hanging nodes), to round-off of
/// `|A| |u|` (1e-12), and the masters are a fraction of the lattice. (Along a free face the
/// local model is softened like PD's surface and no row there is exact for affine fields, on
/// the lattice or not.)
#[test]
fn graded_rows_pass_the_patch_test() {
    // a cube in 3D: the fine cells reach ~12 sites around the ball and 4 from each face
    for (dim, n, max) in [(2, 128, [1.0, 1.0, 0.5]), (3, 42, [1.0; 3])] {
        let (g, _, horizon, beta) = setting_in(dim, n, 3.0, 0.06, max);
        let layer: Vec<bool> = (0..g.len()).map(|i| g.is_layer(i)).collect();
        let graded = graded(&g, horizon, beta, &layer, 3);
        let masters = graded.master_nodes();
        println!("{dim}D: {} masters of {} lattice nodes", masters.len(), g.len());
        // (the 3D box is too small for more than one coarse level beside the fine region)
        let (levels, share) = if dim == 2 { (3, 0.5) } else { (2, 0.95) };
        assert!(graded.mesh().counts().len() >= levels, "{dim}D: levels {:?}", graded.mesh().counts());
        assert!((masters.len() as f64) < share * g.len() as f64, "{dim}D: {} masters of {}", masters.len(), g.len());
        let u: Vec<f64> = masters.iter().flat_map(|&i| affine(dim, &g.position(i))).collect();
        let a = graded.stiffness();
        let scale = max_abs(a.val()) * max_abs(&u);
        let r = matvec(&a, &u);
        let worst = masters
            .iter()
            .enumerate()
            .filter(|(_, &i)| !layer[i])
            .map(|(k, _)| max_abs(&r[dim * k..dim * k + dim]))
            .fold(0.0, f64::max);
        println!("{dim}D: max |A u| / (|A| |u|) off the layer = {:.2e}", worst / scale);
        assert!(worst <= 1e-12 * scale, "{dim}D: {:e}", worst / scale);
        // M (not exact in transitions, on the lattice either) is symmetric: K_M's rows and the
        // companion rows of the lattice blend
        let m = graded.companion();
        let x: Vec<f64> = (0..m.nrows()).map(|k| ((k * 7919) % 1000) as f64 / 1000.0 - 0.5).collect();
        let y: Vec<f64> = (0..m.nrows()).map(|k| ((k * 104729) % 997) as f64 / 997.0 - 0.5).collect();
        let dot = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(a, b)| a * b).sum::<f64>();
        let (xmy, ymx) = (dot(&x, &matvec(&m, &y)), dot(&y, &matvec(&m, &x)));
        assert!((xmy - ymx).abs() <= 1e-12 * max_abs(m.val()) * m.nrows() as f64, "{dim}D: x.My {xmy} vs y.Mx {ymx}");
    }
}

/// Affine displacements on a supporting layer (three nodes, the horizon) give the affine field
/// at every lattice node through `P` (LU on the masters, 1e-10 relative), and `P^T` of a
/// unit force on every lattice node sums to the lattice's total force (2D).
#[test]
fn graded_solve_reproduces_affine_fields() {
    // (3D: coarse cells need a box several times the fine region's ~25 sites, too large for
    // sparse LU here; the 3D rows are checked by the patch test above)
    for (dim, n) in [(2, 96)] {
        let (g, _, horizon, beta) = setting(dim, n, 3.0, 0.08);
        let layer: Vec<bool> = (0..g.len()).map(|i| g.is_layer(i)).collect();
        let graded = graded(&g, horizon, beta, &layer, 2);
        let masters = graded.master_nodes();
        let constrained: Vec<bool> = masters.iter().flat_map(|&i| vec![layer[i]; dim]).collect();
        let exact_m: Vec<f64> = masters.iter().flat_map(|&i| affine(dim, &g.position(i))).collect();
        let ubar: Vec<f64> = exact_m.iter().zip(&constrained).map(|(v, &c)| if c { *v } else { 0.0 }).collect();
        let bc = Dirichlet::new(dim, &constrained, ubar);
        let sol = solve_model(&graded, &bc, &vec![0.0; exact_m.len()], &SolverSpec::Lu, &linpd_core::NoProgress)
            .expect("solve");
        let u = graded.expand(&g, &sol.u);
        let exact: Vec<f64> = (0..g.len()).flat_map(|i| affine(dim, &g.position(i))).collect();
        let err = u.iter().zip(&exact).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / max_abs(&exact);
        println!("{dim}D: {} masters of {} nodes, affine solve error {err:.2e}", masters.len(), g.len());
        assert!(masters.len() < g.len(), "{dim}D: no coarse cell");
        assert!(err <= 1e-10, "{dim}D: {err:e}");
        let f: Vec<f64> = vec![1.0; dim * g.len()];
        let fm = graded.restrict(&g, &f);
        for a in 0..dim {
            let total: f64 = fm.iter().skip(a).step_by(dim).sum();
            assert!((total - g.len() as f64).abs() <= 1e-9 * g.len() as f64, "{dim}D axis {a}: {total}");
        }
    }
}

/// `C_xxxx` of the bond model at node `i` (whole family) from PD's own energy, not from the
/// blend's element routine: under `u = eps x e_x` the node's share of `u^T A u / 2` is
/// `W_i V_i = 1/4 sum_j xi_x^2 eps^2 (-A_{jx, ix})`, and `W_i = C_xxxx eps^2 / 2`.
fn pd_c_xxxx(g: &Grid, op: &BondOperator, i: usize) -> f64 {
    let dim = g.dim();
    let a = linpd_bond::assemble::assemble_free_with_progress(
        op,
        &linpd_core::DofMap::all_free(g.len(), dim),
        &linpd_core::NoProgress,
    );
    let (cp, ri, v) = (a.symbolic().col_ptr(), a.symbolic().row_idx(), a.val());
    let col = dim * i;
    let xi = g.position(i)[0];
    let mut sum = 0.0;
    for p in cp[col]..cp[col + 1] {
        let (j, c) = (ri[p] / dim, ri[p] % dim);
        if j != i && c == 0 {
            sum += (g.position(j)[0] - xi).powi(2) * -v[p];
        }
    }
    sum / (2.0 * g.spacing().powi(dim as i32))
}

/// `model.local_mesh.free_faces: "bulk"`: coarse cells reach the free faces with the bulk's
/// moduli, so under the affine `u = eps x e_x` the forces `A u` on the masters of the face
/// `x = max` sum to `C_xxxx eps` times the face's area (the FE forces of a uniform stress
/// `sigma = C eps`, whose `sigma_xy` and `sigma_xz` vanish on the other faces by the lattice's
/// cubic symmetry), with `C_xxxx` from PD's energy at an interior node (1e-10: the same sums
/// in another order), and fewer masters than with the lattice's faces; with the lattice's
/// faces (the truncated families' soft skin) the face carries less, by more than 1e-3.
#[test]
fn bulk_free_faces_carry_the_bulk_stress() {
    for (dim, n, max) in [(2, 40, [2.0, 1.0, 0.0]), (3, 16, [2.0, 1.0, 1.0])] {
        let (g, op, horizon, beta) = setting_in(dim, n, 0.0, 0.1, max);
        let centre = g.nearest_node(&max.map(|m| m / 2.0)[..dim]).0;
        let c_xxxx = pd_c_xxxx(&g, &op, centre);
        let eps = 1e-3;
        let mirrored = vec![false; g.len()];
        let mut face_force = Vec::new();
        let mut n_masters = Vec::new();
        for free_faces in [FreeFaces::Bulk, FreeFaces::Lattice] {
            let local = LocalMesh { grading: Grading::new(1, 2).unwrap(), free_faces };
            let graded =
                GradedBlend::new(bond(horizon), &g, beta.clone(), None, &mirrored, &vec![false; g.len()], local)
                    .unwrap();
            let masters = graded.master_nodes();
            let u: Vec<f64> = masters
                .iter()
                .flat_map(|&i| {
                    let x = g.position(i)[0];
                    (0..dim).map(move |a| if a == 0 { eps * x } else { 0.0 })
                })
                .collect();
            let r = matvec(&graded.stiffness(), &u);
            let on_face = |i: usize| (g.position(i)[0] - max[0]).abs() < 1e-9;
            face_force
                .push(masters.iter().enumerate().filter(|(_, &i)| on_face(i)).map(|(k, _)| r[dim * k]).sum::<f64>());
            n_masters.push(masters.len());
        }
        let area: f64 = max[1..dim].iter().product();
        let expected = c_xxxx * eps * area;
        println!(
            "{dim}D: face force bulk {:.6e}, lattice {:.6e}, C_xxxx eps A {expected:.6e}; masters {n_masters:?}",
            face_force[0], face_force[1]
        );
        assert!((face_force[0] - expected).abs() <= 1e-10 * expected, "{dim}D: {face_force:?} vs {expected:e}");
        assert!(face_force[1] < (1.0 - 1e-3) * expected, "{dim}D: the lattice's faces are not softer: {face_force:?}");
        assert!(n_masters[0] < n_masters[1], "{dim}D: masters {n_masters:?}");
    }
}

/// `P^T v` leaf by leaf (`GradedBlend::restrict_scalar`) equals the sums of the interpolation
/// rows node by node (`GradedBlend::interpolation`) to round-off (1e-13 of the total), on a
/// graded 2D plate (cells up to 8h, hanging nodes) and on a 3D box with a hole (void cells,
/// nodes of the far faces), for a value that is not affine (`1 + x + 3 y^2`).
#[test]
fn restriction_leaf_by_leaf_equals_the_rows() {
    let cases: Vec<(usize, Grid, f64, Vec<f64>)> = vec![
        {
            let (g, _, horizon, beta) = setting_in(2, 96, 3.0, 0.06, [1.0, 1.0, 0.5]);
            (2, g, horizon, beta)
        },
        {
            let h = 1.0 / 40.0;
            let g = Grid::new(&[0.0; 3], &[1.0, 0.8, 0.6], h, 0.0, Placement::Vertex).unwrap();
            let hole = |x: &linpd_core::Point| (x[0] - 0.3).powi(2) + (x[1] - 0.4).powi(2) > 0.01;
            let g = g.with_body(hole).unwrap();
            let inside: Vec<bool> = (0..g.len()).map(|i| (g.position(i)[0] - 0.75).abs() < 0.05).collect();
            let beta = beta_from_zone(&g, &inside, 6.0 * h, Profile::Cubic);
            (3, g, 3.0 * h, beta)
        },
    ];
    for (dim, g, horizon, beta) in cases {
        let mirrored = vec![false; g.len()];
        let graded = graded(&g, horizon, beta, &mirrored, 3);
        assert!(!graded.mesh().hanging().is_empty(), "{dim}D: the case has hanging nodes");
        let value = |i: usize| {
            let x = g.position(i);
            1.0 + x[0] + 3.0 * x[1] * x[1]
        };
        let fast = graded.restrict_scalar(&g, &value);
        let mut rows = vec![0.0; graded.master_nodes().len()];
        for i in 0..g.len() {
            for (m, w) in graded.interpolation(&g, i) {
                rows[m] += w * value(i);
            }
        }
        let total: f64 = rows.iter().sum();
        let diff = fast.iter().zip(&rows).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        println!("{dim}D: {} masters, max |leaf-wise - rows| / total = {:.1e}", rows.len(), diff / total);
        assert_eq!(fast.len(), rows.len());
        assert!(diff <= 1e-13 * total, "{dim}D: {diff:e} of {total}");
    }
}
