//! The stencil apply of a homogeneous LPS lattice ([`LpsStencil`]) and the pair part
//! ([`PairPart`], the multigrid companion; issue #35).
//!
//! * The stencils apply `A` and `A_pair` as the per-bond applies do, to `1e-12 max|A u|`: the
//!   same terms (at most `2 |F| + 2` per entry, `|F| <= 122`) summed in another order, and the
//!   pair part factored as `(1/m_i) S u + S (u/m) + D u`, whose terms reach a few `max|A u|`
//!   in the surface layer; measured 1e-15..1e-14 (printed). A wrong sign or a missing
//!   `D_i` or `T_k` changes boundary rows by O(max|A u|).
//! * `LpsStencil::new` declines every model that is not a homogeneous full box: defects,
//!   surface corrections, cut volumes, a body, per-node moduli.
//! * `A_pair`'s block rows, diagonal and assembly agree with its apply, and `A - A_pair` is the
//!   dilatation part: zero at the 3D Poisson ratio 1/4 (`K = 5G/3`), positive semi-definite
//!   above it, negative semi-definite below (the energy bound of `linpd_lps::pair`), checked on
//!   random vectors.

mod common;
use common::{random_vec, H};
use linpd_core::{Defect, Grid, Model, Placement};
use linpd_lps::{Influence, LpsModel, LpsParams, PairPart, PlaneModel, SurfaceCorrection};

fn grid(dim: usize, counts: [usize; 3]) -> Grid {
    let max: Vec<f64> = (0..dim).map(|a| (counts[a] - 1) as f64 * H).collect();
    Grid::new(&vec![0.0; dim], &max, H, 0.0, Placement::Vertex).unwrap()
}

fn variants() -> Vec<(usize, [usize; 3], LpsParams)> {
    let p = common::params;
    vec![
        (3, [9, 7, 8], p(3.0, Influence::InverseDistance, true, None)),
        (3, [6, 6, 6], p(2.0, Influence::Constant, false, None)),
        (2, [17, 13, 1], p(3.0, Influence::InverseDistance, true, Some(PlaneModel::Strain))),
        (2, [12, 14, 1], p(2.5, Influence::Constant, false, Some(PlaneModel::Stress))),
    ]
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / max_abs(b)
}

#[test]
fn stencils_apply_the_tangent_and_its_pair_part() {
    let mut worst = 0.0f64;
    for (dim, counts, p) in variants() {
        let m = LpsModel::new(&grid(dim, counts), &p).unwrap();
        let st = m.stencil().expect("a homogeneous full box has stencils");
        for seed in [3, 5] {
            let u = random_vec(m.n_dofs(), seed);
            let (mut want, mut got) = (vec![0.0; u.len()], vec![0.0; u.len()]);
            m.apply_tangent(&u, &mut want);
            st.apply(&u, &mut got);
            let e = rel_diff(&got, &want);
            assert!(e <= 1e-12, "{dim}D {p:?}: stencil A u off by {e:e}");
            worst = worst.max(e);
            Model::apply(&PairPart(&m), &u, &mut want);
            st.apply_pair(&u, &mut got);
            let e = rel_diff(&got, &want);
            assert!(e <= 1e-12, "{dim}D {p:?}: stencil A_pair u off by {e:e}");
            worst = worst.max(e);
        }
        // the pair part's block rows from the stencils: the per-bond blocks (same order)
        let m_bonds = LpsModel::new(&grid(dim, counts), &p)
            .unwrap()
            .with_node_moduli(&vec![p.K; m.n_nodes()], &vec![p.G; m.n_nodes()]);
        let per_bond = m_bonds.unwrap();
        assert!(per_bond.stencil().is_none());
        let scale = {
            let mut s = 0.0f64;
            Model::for_each_block(&PairPart(&per_bond), 0, &mut |_, b| s = b.iter().fold(s, |a, v| a.max(v.abs())));
            s
        };
        for i in 0..m.n_nodes() {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            Model::for_each_block(&PairPart(&m), i, &mut |j, blk| a.push((j, blk.to_vec())));
            Model::for_each_block(&PairPart(&per_bond), i, &mut |j, blk| b.push((j, blk.to_vec())));
            assert_eq!(a.len(), b.len(), "{dim}D node {i}: block count");
            for ((ja, ba), (jb, bb)) in a.iter().zip(&b) {
                assert_eq!(ja, jb, "{dim}D node {i}: block order");
                let e = ba.iter().zip(bb).fold(0.0f64, |w, (x, y)| w.max((x - y).abs()));
                assert!(e <= 1e-13 * scale, "{dim}D node {i}: stencil block off by {e:e}");
            }
        }
        let e = rel_diff(&Model::diagonal(&PairPart(&m)), &Model::diagonal(&PairPart(&per_bond)));
        assert!(e <= 1e-13, "{dim}D: stencil diagonal of A_pair off by {e:e}");
        // the model's fast apply is the stencil, the companion's its pair part
        assert_eq!(Model::fast_apply(&m).map(|f| f.label), Some("lps-stencil"));
        assert_eq!(Model::fast_apply(&PairPart(&m)).map(|f| f.label), Some("lps-pair-stencil"));
    }
    eprintln!("stencil vs per-bond: worst {worst:.2e} max|A u|");
}

#[test]
fn only_a_homogeneous_full_box_has_stencils() {
    let p = common::params(2.0, Influence::InverseDistance, true, None);
    let g = grid(3, [7, 7, 7]);
    let plane = Defect::Plane { point: [0.32, 0.0, 0.0], normal: [1.0, 0.0, 0.0], extent: None, factor: 0.0 };
    let weak = Defect::Plane { point: [0.32, 0.0, 0.0], normal: [1.0, 0.0, 0.0], extent: None, factor: 0.5 };
    let n = g.len();
    let declined = [
        ("a cut", LpsModel::with_defects(&g, &p, &[plane]).unwrap()),
        ("a weakened plane", LpsModel::with_defects(&g, &p, &[weak]).unwrap()),
        (
            "bulk weighted volume",
            LpsModel::new(&g, &p).unwrap().with_surface_correction(SurfaceCorrection::BulkWeightedVolume),
        ),
        ("energy correction", LpsModel::new(&g, &p).unwrap().with_surface_correction(SurfaceCorrection::Energy)),
        ("per-node moduli", LpsModel::new(&g, &p).unwrap().with_node_moduli(&vec![2.0; n], &vec![0.5; n]).unwrap()),
        ("a body", LpsModel::new(&g.with_body(|x| x[0] < 0.45).unwrap(), &p).unwrap()),
    ];
    for (what, m) in declined {
        assert!(m.stencil().is_none(), "{what}: stencils offered");
        assert!(Model::fast_apply(&m).is_none(), "{what}: a fast apply offered");
    }
    // a cleared cache: the correction applied after the stencils were built
    let m = LpsModel::new(&g, &p).unwrap();
    assert!(m.stencil().is_some());
    assert!(m.with_surface_correction(SurfaceCorrection::BulkWeightedVolume).stencil().is_none());
}

#[test]
fn pair_part_is_consistent_and_bounds_the_tangent() {
    for (dim, counts, p) in variants() {
        let g = grid(dim, counts);
        // a defect, so that the per-bond paths run on a non-uniform family
        let cut = if dim == 3 {
            Defect::Plane { point: [0.42, 0.0, 0.0], normal: [1.0, 0.0, 0.0], extent: None, factor: 0.4 }
        } else {
            Defect::Segment { a: [0.42, -1.0], b: [0.42, 0.6], factor: 0.0 }
        };
        let m = LpsModel::with_defects(&g, &p, &[cut]).unwrap();
        let pair = PairPart(&m);
        let u = random_vec(m.n_dofs(), 7);
        let mut y = vec![0.0; u.len()];
        Model::apply(&pair, &u, &mut y);
        // block rows times u, the diagonal and the assembly (all DOFs free)
        let dofs = linpd_core::DofMap::all_free(m.n_nodes(), dim);
        let a = Model::assemble_free(&pair, &dofs);
        let mut y_asm = vec![0.0; u.len()];
        linpd_core::sparse::sym_matvec(&a, &u, &mut y_asm);
        assert!(rel_diff(&y_asm, &y) <= 1e-13, "{dim}D: assembled A_pair u differs");
        let diag = linpd_core::sparse::diagonal(&a);
        assert!(rel_diff(&Model::diagonal(&pair), &diag) <= 1e-13, "{dim}D: A_pair diagonal differs");
        // u . (A - A_pair) u has the sign of kappa - kappa_pair, for several u
        let kappa_pair = LpsParams::deviatoric_factor(dim) * p.G / (dim * dim) as f64;
        let sign = (p.kappa(dim) - kappa_pair).signum();
        for seed in [7, 11, 13] {
            let u = random_vec(m.n_dofs(), seed);
            let (mut ya, mut yp) = (vec![0.0; u.len()], vec![0.0; u.len()]);
            m.apply_tangent(&u, &mut ya);
            Model::apply(&pair, &u, &mut yp);
            let (ea, ep): (f64, f64) = (dot(&u, &ya), dot(&u, &yp));
            assert!(ep > 0.0, "{dim}D: A_pair not positive");
            assert!(
                sign * (ea - ep) >= -1e-12 * ep,
                "{dim}D: u.A u = {ea}, u.A_pair u = {ep}, kappa - kappa_pair of sign {sign}"
            );
            let ratio = p.kappa(dim) / kappa_pair;
            assert!(
                ea <= ep * ratio.max(1.0) * (1.0 + 1e-12) && ea >= ep * ratio.min(1.0) * (1.0 - 1e-12),
                "{dim}D: energy bound"
            );
        }
    }
    // the 3D Poisson ratio 1/4: A = A_pair
    let p = LpsParams { K: 5.0 / 3.0, G: 1.0, ..common::params(3.0, Influence::InverseDistance, true, None) };
    let m = LpsModel::new(&grid(3, [6, 7, 5]), &p).unwrap();
    let u = random_vec(m.n_dofs(), 19);
    let (mut ya, mut yp) = (vec![0.0; u.len()], vec![0.0; u.len()]);
    m.apply_tangent(&u, &mut ya);
    Model::apply(&PairPart(&m), &u, &mut yp);
    assert!(rel_diff(&yp, &ya) <= 1e-13, "nu = 1/4: A_pair differs from A by {:e}", rel_diff(&yp, &ya));
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
