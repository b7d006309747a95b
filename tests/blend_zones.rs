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
    let note = b.report.note.clone().unwrap_or_default();
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
    assert!(e.contains("model.blend.pd_regions") && e.contains("defect"), "{e}");
    let e = error_of(|v| v["model"]["transition_profile"] = serde_json::json!("piecewise"));
    assert!(e.contains("model.transition_profile"), "{e}");
}
