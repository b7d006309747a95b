//! Pre-cracks in scenes (issue #13 item 3): a defect segment (2D) or plane patch (3D) with
//! factor 0 cuts the bonds it crosses, in bond and LPS models alike (the LPS model's
//! consistency with a defect, FD Jacobian, symmetry and null space, is tested in
//! crates/linpd-lps/tests/extensions.rs). Bundled: `data/plate-notch-2d.json`, an LPS plate
//! with an edge notch from x = 0 to 0.5 pulled by a resultant force on its top layer.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::{json, Value};
use std::path::Path;

fn scene(name: &str) -> Value {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name);
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn error_of(v: &Value) -> String {
    match Problem::from_json(&v.to_string()) {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    }
}

/// The notch opens: across y = 0.51, the jump of u_y between the node rows y = 0.50 and 0.52
/// at x = 0.24 (inside the notch) is more than 20 times the jump at x = 0.76 (intact
/// material, where it is the elastic strain over one spacing; measured ratio in the
/// message). Without the notch the two jumps are within a factor 2 (no opening), and the
/// force balance holds to 1e-10 in both.
#[test]
fn the_notch_opens_in_the_lps_plate() {
    let jump = |s: &Value| -> (f64, f64) {
        let p = Problem::from_json(&s.to_string()).unwrap();
        let sol = p.solve(&NoProgress).unwrap();
        let b = sol.balance.as_ref().unwrap();
        assert!(b.relative_imbalance < 1e-10, "imbalance {:e}", b.relative_imbalance);
        let uy = |x: f64, y: f64| {
            let n = (0..sol.x.len()).find(|&n| (sol.x[n][0] - x).abs() < 1e-9 && (sol.x[n][1] - y).abs() < 1e-9);
            sol.u[2 * n.unwrap_or_else(|| panic!("no node at ({x}, {y})")) + 1]
        };
        ((uy(0.24, 0.52) - uy(0.24, 0.50)).abs(), (uy(0.76, 0.52) - uy(0.76, 0.50)).abs())
    };
    let notched = scene("plate-notch-2d.json");
    let (open, intact) = jump(&notched);
    eprintln!("notch opening {open:e}, intact jump {intact:e}, ratio {:.1}", open / intact);
    assert!(open > 20.0 * intact, "opening {open:e} vs intact jump {intact:e} (ratio {:.1})", open / intact);
    let mut plain = notched.clone();
    plain["model"]["material"] = json!({});
    let (a, b) = jump(&plain);
    assert!(a < 2.0 * b && b < 2.0 * a, "no notch: jumps {a:e} and {b:e}");
}

/// A crack that crosses no bond (outside the body) is an error naming the defect, for LPS as
/// for bond models; LPS takes no phases yet, said so.
#[test]
fn bad_cracks_are_refused() {
    let mut s = scene("plate-notch-2d.json");
    s["model"]["material"]["defects"][0]["segment"] = json!([[2.0, 0.5], [3.0, 0.5]]);
    let e = error_of(&s);
    assert!(e.starts_with("model.material.defects[0]: crosses no bond of the body"), "{e}");
    let mut s = scene("plate-crack-2d.json");
    s["model"]["material"]["defects"][0]["segment"] = json!([[2.0, 0.5], [3.0, 0.5]]);
    let e = error_of(&s);
    assert!(e.starts_with("model.material.defects[0]: crosses no bond of the body"), "{e}");
    // a notch along the node row y = 0.5 isolates its nodes: the message says why
    let mut s = scene("plate-notch-2d.json");
    s["model"]["material"]["defects"][0]["segment"] = json!([[-0.1, 0.5], [0.5, 0.5]]);
    let e = Problem::from_json(&s.to_string()).unwrap().solve(&NoProgress).unwrap_err().to_string();
    assert!(e.starts_with("model.material.defects: node ") && e.contains("place defects between lattice rows"), "{e}");
    let mut s = scene("plate-notch-2d.json");
    s["model"]["material"]["phases"] = json!([{"region": "all", "modulus": 2.0}]);
    let e = error_of(&s);
    assert!(
        e.starts_with("model.material.phases[0].modulus: an lps phase gives young_modulus and poisson_ratio"),
        "{e}"
    );
    let mut s = scene("plate-notch-2d.json");
    s["model"]["material"]["defects"][0] =
        json!({"plane": {"point": [0.5, 0.5, 0.0], "normal": [1.0, 0.0, 0.0]}, "factor": 0.0});
    let e = error_of(&s);
    assert!(e.contains("defects[0]") && e.contains("dimension 3"), "{e}");
}
