//! Bond scenes with `model.pd_regions` (the 2D/3D blended model): the bundled edge-crack
//! plate against the pure bond model, and the named errors of the new keys.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::Value;

fn scene() -> Value {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/data/plate-crack-blend-2d.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn solve(v: &Value) -> linpd::problem::Solution {
    Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap()
}

#[test]
fn blended_crack_plate_matches_the_bond_model() {
    let blended = scene();
    let mut pd = blended.clone();
    for key in ["pd_regions", "transition", "transition_profile"] {
        pd["model"].as_object_mut().unwrap().remove(key);
    }
    let (b, p) = (solve(&blended), solve(&pd));
    let umax = p.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = b.u.iter().zip(&p.u).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / umax;
    // measured 9.6e-4 (a deterministic number: both solves reach rtol 1e-8, far below it);
    // bound 1.2e-3 leaves 25 % for changes of the solvers' paths. The 1e-3 target is for
    // >= 40k nodes: at h = 0.005 (42,849 nodes) the same zones give 5.3e-4 (docs/models.md).
    assert!(err <= 1.2e-3, "max |u_blend - u_pd| / max |u_pd| = {err:e}");
    let note = b.report.notes.join("; ");
    assert!(note.contains("blend:") && note.contains("local nodes"), "{note}");
}

fn error_of(edit: impl Fn(&mut Value)) -> String {
    let mut v = scene();
    edit(&mut v);
    match Problem::from_json(&v.to_string()) {
        Ok(p) => p.solve(&NoProgress).map(|_| ()).unwrap_err().to_string(),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_pd_zones_are_named() {
    let e =
        error_of(|v| v["model"]["pd_regions"][0] = serde_json::json!({"box": {"min": [5.0, 5.0], "max": [6.0, 6.0]}}));
    assert!(e.contains("model.pd_regions[0]") && e.contains("no node"), "{e}");
    let e = error_of(|v| v["model"]["transition"] = serde_json::json!(0.001));
    assert!(e.contains("model.transition") && e.contains("narrower than the grid spacing"), "{e}");
    let e = error_of(|v| {
        v["model"].as_object_mut().unwrap().remove("pd_regions");
    });
    assert!(e.contains("model.transition") && e.contains("pd_regions"), "{e}");
    // the crack inside the local zone
    let e = error_of(|v| {
        v["model"]["pd_regions"].as_array_mut().unwrap().remove(0);
    });
    assert!(e.starts_with("model.pd_regions: ") && e.contains("defect"), "{e}");
    let e = error_of(|v| v["model"]["auto_radius"] = serde_json::json!(2.0));
    assert!(e.contains("model.auto_radius") && e.contains("auto"), "{e}");
    let e = error_of(|v| v["model"]["pd_regions"] = serde_json::json!("everywhere"));
    assert!(e.contains("model.pd_regions") && e.contains("auto"), "{e}");
    let e = error_of(|v| v["model"]["pd_regions"] = serde_json::json!([{"box": {"min": [0.0], "mx": [1.0]}}]));
    assert!(e.contains("model.pd_regions[0]"), "{e}");
    let e = error_of(|v| v["model"]["transition_profile"] = serde_json::json!("piecewise"));
    assert!(e.contains("model.transition_profile"), "{e}");
}

/// `"pd_regions": "auto"` on the crack plate: every node with a cut bond and every support
/// edge is PD, and the solution stays within the explicit zones' error of the bond model.
#[test]
fn auto_zones_cover_the_crack_and_the_support_edges() {
    let mut auto = scene();
    auto["model"]["pd_regions"] = serde_json::json!("auto");
    let p = Problem::from_json(&auto.to_string()).unwrap();
    let blend = p.lattice_blend().unwrap();
    let grid = p.grid().unwrap();
    let beta = blend.beta();
    let h = grid.spacing();
    for i in 0..grid.len() {
        let x = grid.position(i);
        // nodes with a bond across the crack (within a horizon of the segment)
        let near_crack = x[0] > 0.3 && x[0] < 0.7 && (x[1] - 0.5125).abs() < 0.03;
        // the first free row next to a support layer, and the layer row beside it
        let support_edge = x[1].abs() < 0.5 * h || (x[1] - 1.0).abs() < 0.5 * h;
        if near_crack || support_edge {
            assert_eq!(beta[i], 1.0, "node at {:?}", &x[..2]);
        }
    }
    let z = blend.zones();
    assert!(z.local > z.pd, "{z:?}");
    let mut pd = scene();
    for key in ["pd_regions", "transition", "transition_profile"] {
        pd["model"].as_object_mut().unwrap().remove(key);
    }
    auto["model"].as_object_mut().unwrap().remove("transition");
    let (b, p) = (solve(&auto), solve(&pd));
    let umax = p.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = b.u.iter().zip(&p.u).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / umax;
    // measured 1.07e-3 on these 11,449 nodes (below the 40k: the zones of radius 2 +
    // transition 1 horizon are 9 lattice steps wide here); at 41,607 nodes the study's edge
    // crack gives 6.4e-4. The bound is the explicit zones' (above).
    assert!(err <= 1.2e-3, "auto: max |u_blend - u_pd| / max |u_pd| = {err:e}");
}

/// Auto zones around a hole, a point load and a corner cut off by the `body` (which removes the
/// box's first site, so the box must not be read from node 0); the grid box's own faces are not
/// features: nodes beside them, the free layer included, stay local.
#[test]
fn auto_zones_cover_holes_and_point_loads() {
    let scene = serde_json::json!({
        "name": "auto-hole-load",
        "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": 0.02, "layer": 0.06},
        "body": {"difference": [{"difference": ["all", {"ball": {"center": [-0.06, -0.06], "radius": 0.1}}]},
                                 {"ball": {"center": [0.3, 0.5], "radius": 0.1}}]},
        "model": {"type": "bond", "horizon": 0.06, "plane": "stress",
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"},
                  "pd_regions": "auto", "auto_radius": 1.0},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [0.0, 2.0]}}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "point", "at": [0.76, 0.5], "force": [0.0, -1e-3]}],
        "output": {"dir": "out/auto-hole-load"}
    });
    let p = Problem::from_json(&scene.to_string()).unwrap();
    let blend = p.lattice_blend().unwrap();
    let grid = p.grid().unwrap();
    for i in 0..grid.len() {
        let x = grid.position(i);
        let r_hole = ((x[0] - 0.3).powi(2) + (x[1] - 0.5).powi(2)).sqrt();
        let r_load = ((x[0] - 0.76).powi(2) + (x[1] - 0.5).powi(2)).sqrt();
        if r_hole < 0.1 + 0.03 || r_load < 0.03 {
            assert_eq!(blend.beta()[i], 1.0, "node at {:?}", &x[..2]);
        }
        // beyond radius + transition = 2 horizons from every feature: the hole, the load and
        // (with a `body`) the body's faces
        let m = 0.125;
        // (features are the nodes beside a removed site or a loaded node: up to sqrt(2) h beyond;
        // the support's edge is x = 0; the box's other faces are no features)
        let r_corner = ((x[0] + 0.06).powi(2) + (x[1] + 0.06).powi(2)).sqrt();
        if r_hole > 0.1 + 0.03 + m && r_load > 0.03 + m && r_corner > 0.1 + 0.03 + m && x[0] > m {
            assert_eq!(blend.beta()[i], 0.0, "node at {:?} should be local", &x[..2]);
        }
    }
    let s = p.solve(&NoProgress).unwrap();
    assert!(s.report.rel_residual < 1e-8);
}

/// GMRES from scenes (Jacobi and multigrid) agrees with sparse LU on the unsymmetric blend and
/// with Cholesky on the symmetric bond model, to the 1e-8 the issue asks of iterative solves.
#[test]
fn gmres_agrees_with_the_direct_solvers() {
    let with_solver = |mut v: Value, solver: Value| {
        v["solver"] = solver;
        solve(&v)
    };
    let mut pd = scene();
    for key in ["pd_regions", "transition", "transition_profile"] {
        pd["model"].as_object_mut().unwrap().remove(key);
    }
    for (v, direct) in [(scene(), "lu"), (pd, "cholesky")] {
        let reference = with_solver(v.clone(), serde_json::json!({"type": direct}));
        let umax = reference.u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for pc in ["jacobi", "multigrid"] {
            let s = with_solver(v.clone(), serde_json::json!({"type": "gmres", "preconditioner": pc, "rtol": 1e-11}));
            let err = s.u.iter().zip(&reference.u).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
            assert!(err <= 1e-8, "{direct} vs gmres-{pc}: {err:e}");
            assert_eq!(s.report.solver.to_string(), format!("gmres-{pc}"));
            // multigrid keeps GMRES short: measured 31 (blend) and 17 (bond) iterations
            if pc == "multigrid" {
                assert!(s.report.iterations.unwrap() <= 45, "{:?}", s.report.iterations);
            }
        }
    }
}

/// Auto zones around a material interface (a stiffer right half of a 2 x 0.5 plate): every node within a horizon
/// of the interface is PD (its family is not regular: bonds cross it), and nodes beyond the
/// radius, the transition and a horizon of margin from the interface and from the support and
/// load edges are local. `auto` with nothing to refine around is a named error.
#[test]
fn auto_zones_cover_material_interfaces_and_need_a_feature() {
    let scene = |edit: &dyn Fn(&mut Value)| {
        let mut v = serde_json::json!({
            "name": "auto-interface",
            "dimension": 2,
            "grid": {"min": [0.0, 0.0], "max": [2.0, 0.5], "spacing": 0.02, "layer": {"x-": 0.06, "x+": 0.06}},
            "model": {"type": "bond", "horizon": 0.06, "plane": "stress",
                      "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"},
                      "material": {"phases": [{"region": {"box": {"min": [1.0, -1.0], "max": [3.0, 2.0]}}, "modulus": 2.0}]},
                      "pd_regions": "auto", "auto_radius": 1.0},
            "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [0.0, 2.0]}}, "displacement": {"value": [0.0, 0.0]}}],
            "loads": [{"type": "body", "region": {"box": {"min": [2.0, -1.0], "max": [3.0, 2.0]}}, "density": [1.0, 0.0]}],
            "output": {"plot": false}
        });
        edit(&mut v);
        Problem::from_json(&v.to_string()).unwrap()
    };
    let p = scene(&|_| {});
    let blend = p.lattice_blend().unwrap();
    let grid = p.grid().unwrap();
    let (mut pd, mut local) = (0, 0);
    for i in 0..grid.len() {
        let x = grid.position(i);
        let to_interface = (x[0] - 1.0).abs();
        if to_interface < 0.06 {
            assert_eq!(blend.beta()[i], 1.0, "node at {:?} beside the interface", &x[..2]);
            pd += 1;
        }
        // radius 1 + transition 1 horizon + a horizon of margin (the features are the nodes
        // whose family crosses the interface, up to a horizon from it)
        let m = 4.0 * 0.06;
        if to_interface > m && x[0] > m && x[0] < 2.0 - m {
            assert_eq!(blend.beta()[i], 0.0, "node at {:?} should be local", &x[..2]);
            local += 1;
        }
    }
    assert!(pd > 0 && local > 0, "{pd} PD and {local} local nodes checked");
    let s = p.solve(&NoProgress).unwrap();
    assert!(s.report.rel_residual < 1e-8);

    // every node held: no support edge, no load, no defect, no interface
    let bare = scene(&|v| {
        v["model"].as_object_mut().unwrap().remove("material");
        v.as_object_mut().unwrap().remove("loads");
        v["constraints"][0]["region"]["box"]["max"][0] = serde_json::json!(3.0);
    });
    let e = bare.lattice_blend().expect_err("nothing to refine around").to_string();
    assert!(e.contains("model.pd_regions") && e.contains("nothing to refine around"), "{e}");
}

/// `auto` on a 2D blend from 20k unknowns runs GMRES + multigrid from the energy form (faster
/// than the Cholesky of `M` there: `AutoParams::gmres_multigrid_2d_min_unknowns`) and says so; its solution agrees
/// with sparse LU within `kappa * rtol` (`kappa <= ~1e4`, `(L/h)^2`; auto's `rtol` 1e-10: 1e-6).
/// Below 20k unknowns `auto` keeps the Cholesky of `M` (the 11k-node plate above).
#[test]
fn auto_runs_gmres_multigrid_on_large_2d_blends() {
    let n = 110.0;
    let h = 1.0 / n;
    let d = 3.0 * h;
    let scene = serde_json::json!({
        "name": "edge-crack-110", "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": h, "layer": {"y-": d, "y+": d}},
        "model": {"type": "bond", "horizon": d, "plane": "strain",
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "continuum"},
                  "material": {"defects": [{"segment": [[-1.0, 0.5 + h / 4.0], [0.4, 0.5 + h / 4.0]], "factor": 0.0}]},
                  "pd_regions": "auto"},
        "constraints": [
            {"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}},
            {"region": {"box": {"min": [-1.0, 1.0], "max": [2.0, 2.0]}}, "displacement": {"value": [0.0, 0.01]}}],
        "output": {"plot": false}
    });
    let s = solve(&scene);
    assert!(s.report.n >= 20_000, "{} unknowns", s.report.n);
    assert_eq!(s.report.solver.to_string(), "gmres-multigrid", "{:?}", s.report.notes);
    assert!(s.report.notes.join("; ").contains("auto: gmres + multigrid"), "{:?}", s.report.notes);
    let mut lu = scene.clone();
    lu["solver"] = serde_json::json!({"type": "lu"});
    let reference = solve(&lu);
    let umax = reference.u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let err = s.u.iter().zip(&reference.u).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
    assert!(err <= 1e-6, "auto vs lu: {err:e}");
}
