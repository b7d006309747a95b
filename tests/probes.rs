//! Line probes, the stress map and the deformed-shape plot (issue #32 items 4 and 5;
//! crates/linpd-scene/src/probe.rs, crates/linpd-cli/src/plots/): the interpolation is exact
//! for affine fields on every kind of node set and at the nodes of a lattice, points off the
//! body are reported outside, `linpd solve` writes the CSV and the plots, and bad probes are
//! named errors.

use linpd::core::NoProgress;
use linpd::problem::probe::{sample, Probe};
use linpd::problem::{Problem, Solution};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn scene(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap()
}

fn problem(v: &Value) -> Problem {
    Problem::from_json_in(&v.to_string(), &data("")).unwrap()
}

/// A displacement gradient (3D; its upper-left block in lower dimensions).
const GRAD: [[f64; 3]; 3] = [[1e-3, 2e-3, -1e-3], [-5e-4, 3e-3, 1e-3], [2e-3, 0.0, -1e-3]];
const SHIFT: [f64; 3] = [1e-4, -2e-4, 3e-4];

fn affine(d: usize, x: &[f64]) -> Vec<f64> {
    (0..d).map(|a| SHIFT[a] + (0..d).map(|b| GRAD[a][b] * x[b]).sum::<f64>()).collect()
}

fn probe(d: usize, from: [f64; 3], to: [f64; 3], points: usize) -> Probe {
    let cut = |x: [f64; 3]| {
        let mut y = [0.0; 3];
        y[..d].copy_from_slice(&x[..d]);
        y
    };
    Probe { name: "p".into(), from: cut(from), to: cut(to), points }
}

/// The largest `|u_probe - G x - c|` over the probe's inside points, over `max |G x + c|`,
/// and the number of inside points.
fn affine_error(s: &Solution, p: &Problem, pr: &Probe) -> (f64, usize) {
    let d = s.dim;
    let samples = sample(std::slice::from_ref(pr), s, p.grid()).remove(0);
    let (mut err, mut scale, mut inside) = (0.0f64, 0.0f64, 0);
    for k in (0..samples.s.len()).filter(|&k| samples.inside[k]) {
        let exact = affine(d, &samples.x[k]);
        for a in 0..d {
            err = err.max((samples.u[d * k + a] - exact[a]).abs());
            scale = scale.max(exact[a].abs());
        }
        inside += 1;
    }
    (err / scale, inside)
}

/// Every interpolation reproduces an affine displacement exactly: the lattice's `d`-linear
/// cells and, next to the hole, the fits to a cell's remaining corners (2D plate with a hole,
/// 3D cantilever), the 1D line, a point cloud's moving least
/// squares (linear basis) and a graded mesh's elements. The nodal values are set to the affine
/// field after a solve of the bundled scene, so that the interpolation alone is tested: to
/// 1e-12 of the field (the rounding of `sum_j phi_j f_j` over at most a few dozen nodes,
/// and of the MLS moment matrix's eigen-solve).
#[test]
fn probes_reproduce_affine_fields_on_every_node_set() {
    let cases: [(&str, [f64; 3], [f64; 3]); 6] = [
        ("plate-hole-2d.json", [0.013, 0.017, 0.0], [0.987, 0.463, 0.0]),
        ("cantilever-cell-3d.json", [0.003, 0.011, 0.007], [0.991, 0.093, 0.089]),
        ("bar-point-load.json", [-0.04, 0.0, 0.0], [1.03, 0.0, 0.0]),
        ("bracket-cloud-2d.json", [0.05, 0.05, 0.0], [0.35, 0.95, 0.0]),
        ("bracket-cloud-2d.json", [0.05, 0.05, 0.0], [0.95, 0.35, 0.0]),
        ("plate-crack-graded-2d.json", [0.013, 0.021, 0.0], [0.987, 0.979, 0.0]),
    ];
    for (name, from, to) in cases {
        let p = problem(&scene(name));
        let mut s = p.solve(&NoProgress).unwrap();
        let d = s.dim;
        s.u = s.x.iter().flat_map(|x| affine(d, x)).collect();
        let (err, inside) = affine_error(&s, &p, &probe(d, from, to, 97));
        // the plate's diagonal crosses the hole: 17 points in it
        assert!(inside >= 80, "{name}: {inside} of 97 points inside");
        assert!(err <= 1e-12, "{name}: probe differs from the affine field by {err:e}");
    }
}

/// The solved patch tests: a lattice held to an affine field all around solves to it, so the
/// probe's u, strain and Hooke stress along a diagonal are the affine field's, its strain and
/// `sigma_xx = E/(1 - nu^2) (eps_xx + nu eps_yy)` (plane stress, bond: `E = K`, `nu = 1/3`),
/// to 1e-9 relative (the solve's residual through the strain's least squares).
#[test]
fn solved_patch_gives_the_affine_strain_and_stress_along_a_probe() {
    let g: Vec<Vec<f64>> = (0..2).map(|a| (0..2).map(|b| GRAD[a][b]).collect()).collect();
    let v = json!({"name": "patch", "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": 0.05, "layer": 0.15},
        "model": {"type": "bond", "horizon": 0.15, "plane": "stress",
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 2.0}},
        "constraints": [{"region": {"difference": [{"box": {"min": [-1.0, -1.0], "max": [2.0, 2.0]}},
                                                     {"box": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}]},
                         "displacement": {"value": [SHIFT[0], SHIFT[1]], "gradient": g}}],
        "solver": {"type": "cholesky"}});
    let p = problem(&v);
    let s = p.solve(&NoProgress).unwrap();
    let pr = probe(2, [0.02, 0.03, 0.0], [0.97, 0.91, 0.0], 41);
    let (err, inside) = affine_error(&s, &p, &pr);
    assert_eq!(inside, 41);
    assert!(err <= 1e-9, "u: {err:e}");
    let samples = sample(&[pr], &s, p.grid()).remove(0);
    let (exx, eyy, exy) = (GRAD[0][0], GRAD[1][1], 0.5 * (GRAD[0][1] + GRAD[1][0]));
    let (e, nu) = (2.0, 1.0 / 3.0);
    let sxx = e / (1.0 - nu * nu) * (exx + nu * eyy);
    for k in 0..41 {
        let strain = samples.strain.as_ref().unwrap()[k];
        for (got, want) in [(strain[0], exx), (strain[4], eyy), (strain[1], exy)] {
            assert!((got - want).abs() <= 1e-9 * exx.abs().max(eyy.abs()), "point {k}: strain {got} vs {want}");
        }
        let stress = samples.stress.as_ref().unwrap()[k];
        assert!((stress[0] - sxx).abs() <= 1e-9 * sxx.abs(), "point {k}: sigma_xx {} vs {sxx}", stress[0]);
    }
    // s, x, y, inside, u_x, u_y, three strains, three stresses, von Mises
    assert_eq!(samples.columns().len(), 1 + 2 + 1 + 2 + 3 + 3 + 1);
}

/// At a lattice node the probe takes the node's own values (the `d`-linear weights are 1 and
/// 0), to rounding; off the body it reports outside: on the plate with a hole (radius 0.1 at
/// (0.5, 0.25), h = 0.01) the points of the axis farther than a spacing inside the hole are
/// outside, those farther than a spacing from it inside.
#[test]
fn probes_take_nodal_values_and_see_the_hole() {
    let p = problem(&scene("plate-hole-2d.json"));
    let s = p.solve(&NoProgress).unwrap();
    let grid = p.grid().unwrap();
    // from node (0.1, 0.05) to node (0.9, 0.45): 41 points, every one on a node
    let pr = probe(2, [0.1, 0.05, 0.0], [0.9, 0.45, 0.0], 41);
    let samples = sample(&[pr], &s, p.grid()).remove(0);
    let scale = s.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for k in 0..41 {
        let (n, dist) = grid.nearest_node(&samples.x[k][..2]);
        if dist > 1e-12 {
            // a site the hole removed
            assert!(!samples.inside[k], "point {k} at {:?} is inside", samples.x[k]);
            continue;
        }
        // the sample lies on the node to the rounding of `from + t (to - from)`, which moves
        // the d-linear weights by ~1e-15
        for a in 0..2 {
            let (got, want) = (samples.u[2 * k + a], s.u[2 * n + a]);
            assert!((got - want).abs() <= 1e-13 * scale, "point {k}: {got} vs {want}");
        }
    }
    let axis = probe(2, [0.0, 0.25, 0.0], [1.0, 0.25, 0.0], 201);
    let samples = sample(&[axis], &s, p.grid()).remove(0);
    for k in 0..201 {
        let r = (samples.x[k][0] - 0.5).abs();
        if r < 0.1 - 0.01 {
            assert!(!samples.inside[k], "x = {} is in the hole", samples.x[k][0]);
            assert!(samples.u[2 * k].is_nan() && samples.von_mises(k).unwrap().is_nan());
        } else if r > 0.1 + 0.01 {
            assert!(samples.inside[k], "x = {} is in the plate", samples.x[k][0]);
        }
    }
}

fn linpd(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().unwrap()
}

/// `linpd solve` on the bundled plate with a hole writes each probe's CSV (a header of the
/// documented columns and one row per point, `NaN` in the hole) and its two plots, the von
/// Mises map and the deformed shape; `output.stress_map` picks another quantity.
#[test]
fn solve_writes_probes_and_plots() {
    let dir = std::env::temp_dir().join(format!("linpd-probes-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut v = scene("plate-hole-2d.json");
    v["output"]["stress_map"] = json!("sigma_xx");
    v["output"]["deformed_scale"] = json!(0.02);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.json");
    std::fs::write(&path, v.to_string()).unwrap();
    let out = dir.join("out");
    let o = linpd(&["solve".as_ref(), path.as_os_str(), "--out".as_ref(), out.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ligament = std::fs::read_to_string(out.join("ligament.csv")).unwrap();
    let mut lines = ligament.lines();
    assert_eq!(lines.next(), Some("s,x,y,inside,u_x,u_y,eps_xx,eps_yy,eps_xy,sigma_xx,sigma_yy,sigma_xy,von_mises"));
    assert_eq!(lines.count(), 61);
    let axis = std::fs::read_to_string(out.join("axis.csv")).unwrap();
    let outside = axis.lines().skip(1).filter(|l| l.split(',').nth(3) == Some("0")).count();
    let nan = axis.lines().skip(1).filter(|l| l.contains("NaN")).count();
    // the hole spans 0.2 of the axis's 1.0 at 201 points: 41 points, less those within a
    // spacing of its edge (at most 2 a side)
    assert!((37..=41).contains(&outside) && nan == outside, "{outside} outside, {nan} with NaN");
    for f in ["ligament_u", "ligament_stress", "axis_u", "axis_stress", "stress_sigma_xx", "deformed"] {
        assert!(std::fs::metadata(out.join(format!("{f}.png"))).is_ok_and(|m| m.len() > 0), "{f}.png");
    }
    let svg = std::fs::read_to_string(out.join("deformed.svg")).unwrap();
    assert!(svg.contains("deformed (u x 0.02)") && svg.contains("undeformed"), "legend of deformed.svg");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad probes and plot options are named by their JSON path.
#[test]
fn bad_probes_are_named() {
    let cases: [(Value, &str); 8] = [
        (json!({"probes": [{"from": [0.0], "to": [1.0, 0.0]}]}), "output.probes[0].from: needs 2 coordinates, got 1"),
        (json!({"probes": [{"from": [0.1, 0.1], "to": [0.1, 0.1]}]}), "output.probes[0].to: equals `from`"),
        (
            json!({"probes": [{"from": [0.0, 0.0], "to": [1.0, 0.0], "points": 1}]}),
            "output.probes[0].points: must be between 2",
        ),
        (
            json!({"probes": [{"from": [0.0, 0.0], "to": [1.0, 0.0]}, {"name": "probe-1", "from": [0.0, 0.0], "to": [0.0, 1.0]}]}),
            "output.probes[1].name: \"probe-1\" is also the name of probe 0",
        ),
        (
            json!({"probes": [{"name": "../x", "from": [0.0, 0.0], "to": [1.0, 0.0]}]}),
            "output.probes[0].name: \"../x\" is not a file stem",
        ),
        (json!({"probes": [{"from": [0.0, 0.0], "to": [1.0, 0.0], "step": 2}]}), "unknown field `step`"),
        (
            json!({"stress_map": "sigma_zz"}),
            "output.stress_map: \"sigma_zz\" is not one of von_mises, max_principal, sigma_xx, sigma_yy, sigma_xy",
        ),
        (json!({"deformed_scale": 0.0}), "output.deformed_scale: must be > 0"),
    ];
    for (output, want) in cases {
        let mut v = scene("plate-hole-2d.json");
        v["output"] = output;
        let e = Problem::from_json_in(&v.to_string(), &data("")).unwrap_err().to_string();
        assert!(e.contains(want), "expected {want:?} in {e:?}");
    }
}
