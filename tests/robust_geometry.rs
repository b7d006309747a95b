//! Issue #30, "geometry arithmetic is not scale-safe": region and defect predicates must give
//! the same nodes and cut the same bonds whatever the length of a direction vector (a
//! cylinder's `axis`, a half space's or a crack plane's `normal`) and for extents up to
//! `+-1e308`. Before the fix a plain `sqrt(sum v^2)` overflowed to `inf` (axis `1e200`: 19
//! nodes kept instead of the cylinder's; normal `1e200`: every node kept), underflowed to 0
//! (normal `1e-200` refused as zero), and plain differences and cross products of polygon and
//! segment vertices overflowed (a triangle at `+-1e308` lost nodes, a crack at `+-1e160`
//! "crossed" every bond: a false zero pivot).
//!
//! The predicates now work on copies scaled by powers of two, which is exact: on ordinary
//! inputs they compute the bits they computed before. The comparisons below between a huge (or
//! tiny) input and its ordinary twin are exact equalities of node sets, bond sets and
//! displacements, no tolerance: a direction scaled by a power of two gives the same bits, one
//! scaled otherwise differs by round-off (1e-16 relative), far inside the `1e-9 h` tolerance
//! band of the closed regions, and no node of these lattices lies within round-off of that
//! band's edge.

use linpd::core::{Defect, Grid, NoProgress, Placement, Point};
use linpd::problem::Problem;
use serde_json::{json, Value};

/// A bond-model scene on the grid `[0, 1]^dim` (spacing `h`, horizon `3h`, no layer) whose
/// body is `body`: its node set is the region's.
fn body_scene(dim: usize, h: f64, body: Value) -> Value {
    let mut s = json!({
        "name": "robust-geometry",
        "dimension": dim,
        "grid": {"min": vec![0.0; dim], "max": vec![1.0; dim], "spacing": h},
        "body": body,
        "model": {"type": "bond", "horizon": 3.0 * h,
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
        "output": {"dir": "out/robust-geometry"}
    });
    if dim == 2 {
        s["model"]["plane"] = json!("strain");
    }
    s
}

fn problem(v: &Value) -> Problem {
    Problem::from_json(&v.to_string()).unwrap_or_else(|e| panic!("refused: {e}\n{v}"))
}

fn error_of(v: &Value) -> String {
    match Problem::from_json(&v.to_string()) {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts `a == b` without printing thousands of entries: the sizes and the first difference.
fn same<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T], what: &str) {
    if a != b {
        let k = a.iter().zip(b).position(|(x, y)| x != y).unwrap_or(a.len().min(b.len()));
        panic!("{what}: {} vs {} entries, first difference at {k}: {:?} vs {:?}", a.len(), b.len(), a.get(k), b.get(k));
    }
}

/// The positions of the nodes a body region keeps (bit patterns, comparable exactly).
fn kept(dim: usize, h: f64, body: Value) -> Vec<[u64; 3]> {
    let p = problem(&body_scene(dim, h, body));
    (0..p.nodes().len()).map(|n| p.nodes().position(n).map(f64::to_bits)).collect()
}

/// Case 1: a cylinder along x of radius `2.4 h` and length `4.8 h` around the centre of the
/// 9^3 lattice (`h = 1/8`, so every coordinate is exact) keeps the lattice points `(i, j, k)`
/// with `j^2 + k^2 <= 5.76` (21 of them: 1 + 4 + 4 + 4 + 8) and `|i| <= 2.4` (5 planes): 105
/// nodes, for the axis `[1, 0, 0]` and for the same axis scaled by 1e200, 1e-200 and 3. An
/// oblique axis gives one set at every scale. (Before: `[1e200, 0, 0]` kept 19 nodes.)
#[test]
fn cylinder_axis_scale_does_not_change_the_nodes() {
    let cyl =
        |axis: [f64; 3]| json!({"cylinder": {"center": [0.5, 0.5, 0.5], "axis": axis, "radius": 0.3, "length": 0.6}});
    let unit = kept(3, 0.125, cyl([1.0, 0.0, 0.0]));
    assert_eq!(unit.len(), 21 * 5);
    for s in [1e200, 1e-200, 3.0, 1e300, 5e-324] {
        same(&kept(3, 0.125, cyl([s, 0.0, 0.0])), &unit, &format!("axis [{s:e}, 0, 0]"));
    }
    let oblique = kept(3, 0.125, cyl([2.0, 2.0, 1.0]));
    assert!(!oblique.is_empty() && oblique != unit);
    for s in [1e200, 1e-200, 1e-310] {
        same(&kept(3, 0.125, cyl([2.0 * s, 2.0 * s, s])), &oblique, &format!("axis {s:e} [2, 2, 1]"));
    }
}

/// Cases 2 and 4: the half space `x <= 0.45` (normal `[1, 0]`) on the 11 x 11 lattice
/// (`h = 0.1`) keeps the 5 columns `x = 0 ... 0.4`: 55 nodes; the normal scaled by 1e200
/// (before: every node kept) or 1e-200 (before: refused as zero) keeps the same nodes, as
/// does an oblique normal at any scale. Only an all-zero normal is refused, by its path.
#[test]
fn half_space_normal_scale_does_not_change_the_nodes() {
    let half = |n: [f64; 2]| json!({"half_space": {"point": [0.45, 0.0], "normal": n}});
    let unit = kept(2, 0.1, half([1.0, 0.0]));
    assert_eq!(unit.len(), 5 * 11);
    for s in [1e200, 1e-200, 1e300, 1e-300, 5e-324, 7.0] {
        same(&kept(2, 0.1, half([s, 0.0])), &unit, &format!("normal [{s:e}, 0]"));
    }
    let oblique = kept(2, 0.1, half([1.0, 2.0]));
    for s in [1e200, 1e-200, 1e-320] {
        same(&kept(2, 0.1, half([s, 2.0 * s])), &oblique, &format!("normal {s:e} [1, 2]"));
    }
    let e = error_of(&body_scene(2, 0.1, half([0.0, 0.0])));
    assert!(e.starts_with("body.half_space.normal: must not be zero"), "{e}");
    let e = error_of(&body_scene(
        3,
        0.125,
        json!({"cylinder": {"center": [0.5, 0.5, 0.5], "axis": [0.0, 0.0, 0.0], "radius": 0.3}}),
    ));
    assert!(e.starts_with("body.cylinder.axis: must not be zero"), "{e}");
}

/// Case 3: a triangle with vertices at `+-1e308` contains the whole lattice: it keeps all
/// 11 x 11 nodes (before: edge vectors overflowed to `inf` and 408 of 459 were kept), as does
/// a square at `+-1.7e308` (near `f64::MAX`). A triangle with one edge exactly on the row
/// `y = 0.5` and the others near 1e308 keeps the nodes with `x >= 0` and `y >= 0.5`, the row
/// on the edge included (closed regions): the edge tolerance still works at that scale.
#[test]
fn polygons_with_huge_vertices_keep_what_they_contain() {
    let all = kept(2, 0.125, json!("all"));
    assert_eq!(all.len(), 81);
    let tri = json!({"polygon": {"vertices": [[-1e308, -1e308], [1e308, -1e308], [0.0, 1e308]]}});
    same(&kept(2, 0.125, tri), &all, "triangle at +-1e308");
    let square = json!({"polygon": {"vertices": [[-1.7e308, -1.7e308], [1.7e308, -1.7e308],
                                                 [1.7e308, 1.7e308], [-1.7e308, 1.7e308]]}});
    same(&kept(2, 0.125, square), &all, "square at +-1.7e308");
    let wedge = json!({"polygon": {"vertices": [[0.0, 0.5], [1e308, 0.5], [0.0, 1e308]]}});
    let expected: Vec<[u64; 3]> =
        all.iter().copied().filter(|x| f64::from_bits(x[1]) >= 0.5 && f64::from_bits(x[0]) >= 0.0).collect();
    assert_eq!(expected.len(), 5 * 9);
    same(&kept(2, 0.125, wedge), &expected, "wedge on the row y = 0.5");
    // and the same wedge shifted off the row by a tenth of a spacing loses the row
    let above = json!({"polygon": {"vertices": [[0.0, 0.5125], [1e308, 0.5125], [0.0, 1e308]]}});
    assert_eq!(kept(2, 0.125, above).len(), 4 * 9);
}

/// The documented even-odd rule on a self-crossing polygon (docs/problem-format.md,
/// "Regions"): a pentagram of circumradius 0.5 around the centre of the 17 x 17 lattice
/// (`h = 1/16`). Its edges wind twice around the inner pentagon (circumradius
/// `0.5 sin 18 / sin 126 = 0.191`), which the even-odd rule leaves out: the centre node is not
/// kept, while the nodes in the five tips (e.g. at `0.375` above the centre) are.
#[test]
fn self_crossing_polygons_follow_the_even_odd_rule() {
    let star: Vec<[f64; 2]> = (0..5)
        .map(|k| {
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * 4.0 * std::f64::consts::PI / 5.0;
            [0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin()]
        })
        .collect();
    let p = problem(&body_scene(2, 0.0625, json!({"polygon": {"vertices": star}})));
    let has = |x: f64, y: f64| {
        (0..p.nodes().len()).any(|n| {
            let q = p.nodes().position(n);
            (q[0] - x).abs() < 1e-12 && (q[1] - y).abs() < 1e-12
        })
    };
    assert!(!has(0.5, 0.5), "the doubly wound centre is outside");
    assert!(!has(0.5, 0.5625) && !has(0.5625, 0.5), "so is the rest of the inner pentagon");
    assert!(has(0.5, 0.875), "a tip is inside");
    // the whole star less the inner pentagon: every kept node is outside the inner pentagon's
    // inscribed circle (radius 0.191 cos 36 = 0.1545)
    for n in 0..p.nodes().len() {
        let q = p.nodes().position(n);
        assert!((q[0] - 0.5).hypot(q[1] - 0.5) > 0.15, "node at {q:?}");
    }
}

/// Every lattice bond (`|x - y| <= horizon`, brute force) of the full grid that `defect`
/// crosses, with the scenes' tolerance `1e-9 h`.
fn crossed(grid: &Grid, horizon: f64, defect: &Defect) -> Vec<(usize, usize)> {
    let x: Vec<Point> = grid.positions();
    let tol = linpd::core::GEOMETRY_RTOL * grid.spacing();
    let mut out = Vec::new();
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let r: f64 = (0..3).map(|a| (x[i][a] - x[j][a]).powi(2)).sum::<f64>().sqrt();
            if r <= horizon * (1.0 + 1e-12) && defect.crosses(&x[i], &x[j], tol) {
                out.push((i, j));
            }
        }
    }
    out
}

/// Case 5 at the core: a segment along `y = 0.51` from `-1e160` (or `-1e308`) to `1e160`
/// (`1e308`) crosses exactly the bonds the segment from -10 to 10 crosses on the unit plate
/// (`h = 0.02`, horizon `3h`): the bonds from a row `y <= 0.5` to a row `y >= 0.52`, counted
/// independently from the stencil: per column offset `di` the row offsets `dj` with
/// `di^2 + dj^2 <= 9`, each crossing `dj` of the cut (at most 3 rows). A diagonal crack
/// through the origin at `+-1e160` likewise cuts the bonds of its `+-10` twin (on a lattice
/// shifted by h/2 in x, so that no node lies on the crack): distances from a crack's line are
/// measured from its nearest point among its ends and its middle, which here is exact.
/// (Before: every distance came out 0 and every bond "crossed".)
#[test]
fn huge_segments_cut_the_bonds_they_cross() {
    let (h, horizon) = (0.02, 0.06);
    let grid = Grid::new(&[0.0, 0.0], &[1.0, 1.0], h, 0.0, Placement::Vertex).unwrap();
    let seg = |l: f64| Defect::Segment { a: [-l, 0.51], b: [l, 0.51], factor: 0.0 };
    let ordinary = crossed(&grid, horizon, &seg(10.0));
    // per pair of rows across y = 0.51 (rows 25 and below, 26 and above), bonds between columns
    let mut count = 0usize;
    for di in -3i64..=3 {
        for dj in 1i64..=3 {
            if di * di + dj * dj <= 9 {
                // dj row pairs cross the cut, 51 - |di| column pairs each
                count += dj as usize * (51 - di.unsigned_abs() as usize);
            }
        }
    }
    assert_eq!(ordinary.len(), count);
    for l in [1e160, 1e200, 1e308] {
        same(&crossed(&grid, horizon, &seg(l)), &ordinary, &format!("segment at +-{l:e}"));
    }
    let shifted = Grid::new(&[0.01, 0.0], &[1.01, 1.0], h, 0.0, Placement::Vertex).unwrap();
    let diag = |l: f64| Defect::Segment { a: [-l, -l], b: [l, l], factor: 0.0 };
    let twin = crossed(&shifted, horizon, &diag(10.0));
    assert!(!twin.is_empty());
    same(&crossed(&shifted, horizon, &diag(1e160)), &twin, "diagonal at +-1e160");
}

/// Case 5 in a scene: the crack plate `data/plate-crack-2d.json` with its crack extended to
/// `+-1e160` across the whole plate (before: refused with a false zero pivot) splits it; it
/// solves to exactly the displacements of the crack from -10 to 10 (same bonds cut, same
/// operator), and the two pieces move rigidly with their clamps: the top one by the top
/// layer's `(0, 0.01)`, the bottom one not at all (1e-9 of 0.01: the solver's round-off).
#[test]
fn huge_crack_in_a_scene_splits_the_plate() {
    let mut s: Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/data/plate-crack-2d.json")).unwrap(),
    )
    .unwrap();
    s["solver"] = json!({"type": "cholesky"});
    s["grid"]["spacing"] = json!(0.05);
    s["grid"]["layer"] = json!(0.15);
    s["model"]["horizon"] = json!(0.15);
    let solve = |l: f64| {
        let mut t = s.clone();
        t["model"]["material"]["defects"][0]["segment"] = json!([[-l, 0.51], [l, 0.51]]);
        let p = problem(&t);
        let u = p.solve(&NoProgress).unwrap_or_else(|e| panic!("+-{l:e}: {e}")).u;
        (p, u)
    };
    let (p, u) = solve(10.0);
    let (_, huge) = solve(1e160);
    same(&huge, &u, "displacements, crack at +-1e160");
    for n in 0..p.nodes().len() {
        let y = p.nodes().position(n)[1];
        let expected = if y > 0.51 { 0.01 } else { 0.0 };
        assert!(u[2 * n].abs() < 1e-11 && (u[2 * n + 1] - expected).abs() < 1e-11, "node {n} at y = {y}");
    }
}

/// Case 6: a crack plane `x = 0.53` with normal `[1e200, 0, 0]` (before: "crosses no bond")
/// or `[1e-200, 0, 0]` cuts the bonds of `[1, 0, 0]` (h = 0.125, horizon 3h: per offset with
/// `di > 0`, `di` column pairs across the cut times 9 - |dj| times 9 - |dk| row pairs), also
/// with an extent; in a scene, the cube compressed between its clamps solves to the same bits.
#[test]
fn crack_plane_normal_scale_does_not_change_the_cut() {
    let (h, horizon) = (0.125, 0.375);
    let grid = Grid::new(&[0.0; 3], &[1.0; 3], h, 0.0, Placement::Vertex).unwrap();
    let plane = |n: [f64; 3], extent: Option<linpd::core::Region>| Defect::Plane {
        point: [0.53, 0.0, 0.0],
        normal: n,
        extent,
        factor: 0.0,
    };
    let unit = crossed(&grid, horizon, &plane([1.0, 0.0, 0.0], None));
    let mut count = 0usize;
    for di in 1i64..=3 {
        for dj in -3i64..=3 {
            for dk in -3i64..=3 {
                if di * di + dj * dj + dk * dk <= 9 {
                    count += di as usize * (9 - dj.unsigned_abs() as usize) * (9 - dk.unsigned_abs() as usize);
                }
            }
        }
    }
    assert_eq!(unit.len(), count);
    let patch = || Some(linpd::core::Region::Box { min: vec![0.0, 0.0, 0.0], max: vec![1.0, 0.5, 1.0] });
    let unit_patch = crossed(&grid, horizon, &plane([1.0, 0.0, 0.0], patch()));
    assert!(!unit_patch.is_empty() && unit_patch.len() < unit.len());
    for s in [1e200, 1e-200, 1e308, 5e-324] {
        same(&crossed(&grid, horizon, &plane([s, 0.0, 0.0], None)), &unit, &format!("normal [{s:e}, 0, 0]"));
        same(&crossed(&grid, horizon, &plane([s, 0.0, 0.0], patch())), &unit_patch, &format!("with extent, {s:e}"));
    }

    let scene = |n: [f64; 3]| {
        json!({
            "name": "robust-geometry-plane",
            "dimension": 3,
            "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": h, "layer": horizon},
            "model": {"type": "bond", "horizon": horizon,
                      "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"},
                      "material": {"defects": [{"plane": {"point": [0.53, 0.0, 0.0], "normal": n}, "factor": 0.0}]}},
            "constraints": [
                {"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0, 0.0]}},
                {"region": {"box": {"min": [-1.0, -1.0, 1.0], "max": [2.0, 2.0, 2.0]}}, "displacement": {"value": [0.0, 0.0, -0.01]}}
            ],
            "solver": {"type": "cholesky"},
            "output": {"dir": "out/robust-geometry-plane"}
        })
    };
    let u = problem(&scene([1.0, 0.0, 0.0])).solve(&NoProgress).unwrap().u;
    for n in [[1e200, 0.0, 0.0], [1e-200, 0.0, 0.0]] {
        same(&problem(&scene(n)).solve(&NoProgress).unwrap().u, &u, &format!("normal {n:?}"));
    }
    let e = error_of(&scene([0.0, 0.0, 0.0]));
    assert!(e.starts_with("model.material.defects[0].plane.normal: must be nonzero"), "{e}");
}

/// "An isolated body part holding no node drops out of the cut-cell volume total": with
/// `"boundary_volumes": "cut"`, a disk of radius 0.02 at (0.83, 0.47), 0.042 from the nearest
/// lattice site and more than a cell from every kept node, holds no node and no neighbour of
/// its cells is kept; its area would be lost, so the scene is refused naming the union part.
/// With full volumes (nothing is summed) it is accepted. The same disk against the plate's
/// cells (at (0.57, 0.47): in the cell of the removed site (0.6, 0.5), whose neighbours at
/// x = 0.5 are kept) is accepted and adds to the volume total exactly the sub-cells whose
/// midpoints it holds (16 x 16 per cell, counted here independently; 1e-15: sums of volumes).
#[test]
fn an_isolated_body_part_without_nodes_is_refused_with_cut_volumes() {
    let plate = json!({"box": {"min": [0.0, 0.0], "max": [0.5, 1.0]}});
    let body = |c: [f64; 2]| json!({"union": [plate.clone(), {"ball": {"center": c, "radius": 0.02}}]});
    let mut s = body_scene(2, 0.1, body([0.83, 0.47]));
    problem(&s);
    s["boundary_volumes"] = json!("cut");
    let e = error_of(&s);
    eprintln!("{e}");
    assert!(e.starts_with("body.union[1]: a part of the body around [0.8"), "{e}");
    assert!(e.contains("holds no node") && e.contains("cut-cell volumes"), "{e}");
    let total = |s: &Value| {
        let p = problem(s);
        (0..p.nodes().len()).map(|n| p.nodes().volume(n)).sum::<f64>()
    };
    s["body"] = body([0.57, 0.47]);
    let with_disk = total(&s);
    s["body"] = plate.clone();
    let without = total(&s);
    let sub = 0.1 / 16.0;
    let mid = |r: usize, lo: f64| lo + (r as f64 + 0.5) * sub;
    let inside = (0..16)
        .flat_map(|i| (0..16).map(move |j| (i, j)))
        .filter(|&(i, j)| (mid(i, 0.55) - 0.57).hypot(mid(j, 0.45) - 0.47) <= 0.02)
        .count();
    assert!(inside > 0);
    let added = inside as f64 * sub * sub;
    assert!((with_disk - without - added).abs() < 1e-15, "added {} for {added}", with_disk - without);
}
