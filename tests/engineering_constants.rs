//! Engineering constants (issue #32): `young_modulus` and `poisson_ratio` in place of the
//! bulk modulus (bond micromodulus, phases) or of `K` and `G` (LPS) give the same model as the
//! moduli they imply, a Poisson's ratio a bond model cannot represent is a named error, and
//! `result.json` lists `E, nu, K, G` per phase.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::{json, Value};

fn scene(name: &str) -> Value {
    let path = format!("{}/data/{name}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn solve(v: &Value) -> linpd::problem::Solution {
    Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap()
}

fn error_of(v: &Value) -> String {
    match Problem::from_json(&v.to_string()) {
        Ok(p) => p.solve(&NoProgress).map(|_| ()).unwrap_err().to_string(),
        Err(e) => e.to_string(),
    }
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let m = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / m
}

/// `young_modulus` gives `K = E / (E/K)` with the table of docs/problem-format.md: `E = 3K/2`
/// in 3D and plane strain, `E = K` in plane stress, so `E = 3` (3D, plane strain) and `E = 2`
/// (plane stress) are `modulus: 2` exactly, and the solutions are bit for bit the same; with
/// the model's own `poisson_ratio` too.
#[test]
fn young_modulus_is_the_modulus_it_implies() {
    for (name, plane, e, nu) in [
        ("cube-compression-3d", None, 3.0, 0.25),
        ("plate-tension-2d", Some("strain"), 3.0, 0.25),
        ("plate-tension-2d", Some("stress"), 2.0, 1.0 / 3.0),
    ] {
        let mut by_k = scene(name);
        if let Some(plane) = plane {
            by_k["model"]["plane"] = json!(plane);
        }
        by_k["model"]["micromodulus"]["modulus"] = json!(2.0);
        let mut by_e = by_k.clone();
        let mm = by_e["model"]["micromodulus"].as_object_mut().unwrap();
        mm.remove("modulus");
        mm.insert("young_modulus".into(), json!(e));
        let mut by_e_nu = by_e.clone();
        by_e_nu["model"]["micromodulus"]["poisson_ratio"] = json!(nu);
        let reference = solve(&by_k);
        assert!(reference.u.iter().any(|&x| x != 0.0), "{name}: nothing moved");
        for v in [&by_e, &by_e_nu] {
            assert_eq!(solve(v).u, reference.u, "{name} {plane:?}");
        }
    }
}

/// A phase's `young_modulus` is its `modulus` through the same table (a 3D cube with a stiffer
/// slab: `E = 6` is `K = 4`), and `result.json`'s `material` lists the reference and the phase
/// with `E = 3K/2`, `nu = 1/4`, `G = E / (2 (1 + nu))`.
#[test]
fn phases_take_young_modulus_and_result_json_lists_the_constants() {
    let mut by_k = scene("cube-compression-3d");
    by_k["model"]["material"] =
        json!({"phases": [{"region": {"box": {"min": [-1.0, -1.0, 0.4], "max": [2.0, 2.0, 0.6]}}, "modulus": 4.0}]});
    let mut by_e = by_k.clone();
    by_e["model"]["material"]["phases"][0] =
        json!({"region": {"box": {"min": [-1.0, -1.0, 0.4], "max": [2.0, 2.0, 0.6]}}, "young_modulus": 6.0});
    let (a, b) = (solve(&by_k), solve(&by_e));
    assert_eq!(a.u, b.u);
    let doc = b.to_json();
    let material = doc["material"].as_array().unwrap();
    assert_eq!(material.len(), 2, "{doc:?}");
    for (m, phase, k) in [(&material[0], "reference", 1.0), (&material[1], "phases[0]", 4.0)] {
        let e = 1.5 * k;
        assert_eq!(m["phase"], phase);
        assert_eq!(m["bulk_modulus"].as_f64().unwrap(), k);
        assert_eq!(m["young_modulus"].as_f64().unwrap(), e);
        assert_eq!(m["poisson_ratio"].as_f64().unwrap(), 0.25);
        assert!((m["shear_modulus"].as_f64().unwrap() - e / 2.5).abs() <= 1e-15 * e, "{m}");
    }
}

/// LPS takes `young_modulus` and `poisson_ratio` for `K = E / (3 (1 - 2 nu))` and
/// `G = E / (2 (1 + nu))`: the same solution as the scene's `K = 2`, `G = 0.5` to round-off
/// (`E` and `nu` are not exact in binary: 1e-12), and `result.json` gives them back.
#[test]
fn lps_takes_young_modulus_and_poisson_ratio() {
    let by_kg = scene("lps-tension-3d");
    let (k, g): (f64, f64) = (2.0, 0.5);
    let (e, nu) = (9.0 * k * g / (3.0 * k + g), (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g)));
    let mut by_e = by_kg.clone();
    let m = by_e["model"].as_object_mut().unwrap();
    m.remove("bulk_modulus");
    m.remove("shear_modulus");
    m.insert("young_modulus".into(), json!(e));
    m.insert("poisson_ratio".into(), json!(nu));
    let (a, b) = (solve(&by_kg), solve(&by_e));
    let diff = max_rel_diff(&b.u, &a.u);
    assert!(diff <= 1e-12, "{diff:e}");
    let c = &b.to_json()["material"][0];
    assert!((c["bulk_modulus"].as_f64().unwrap() - k).abs() <= 1e-14 * k, "{c}");
    assert!((c["shear_modulus"].as_f64().unwrap() - g).abs() <= 1e-14 * g, "{c}");
    assert!((c["poisson_ratio"].as_f64().unwrap() - nu).abs() <= 1e-15, "{c}");
}

/// Named errors: both moduli, a Poisson's ratio the bond model cannot represent (it states the
/// model's nu and points at LPS), `poisson_ratio` without `young_modulus`, nu outside
/// (-1, 1/2), a non-positive E, a phase's E with an explicit amplitude, LPS with a mix of
/// moduli or half a pair.
#[test]
fn bad_engineering_constants_are_named() {
    let cube = scene("cube-compression-3d");
    let mm = |v: &mut Value| v["model"]["micromodulus"].as_object_mut().unwrap().clone();
    let with = |edit: &dyn Fn(&mut serde_json::Map<String, Value>)| {
        let mut v = cube.clone();
        let mut m = mm(&mut v);
        edit(&mut m);
        v["model"]["micromodulus"] = Value::Object(m);
        error_of(&v)
    };
    let e = with(&|m| {
        m.insert("young_modulus".into(), json!(1.5));
    });
    assert!(e.contains("model.micromodulus.young_modulus") && e.contains("not both"), "{e}");
    let e = with(&|m| {
        m.remove("modulus");
        m.insert("young_modulus".into(), json!(1.5));
        m.insert("poisson_ratio".into(), json!(0.3));
    });
    assert!(e.contains("model.micromodulus.poisson_ratio") && e.contains("nu = 1/4") && e.contains("\"lps\""), "{e}");
    let e = with(&|m| {
        m.insert("poisson_ratio".into(), json!(0.25));
    });
    assert!(e.contains("model.micromodulus.poisson_ratio") && e.contains("goes with young_modulus"), "{e}");
    for nu in [0.5, -1.0, 0.7] {
        let e = with(&|m| {
            m.remove("modulus");
            m.insert("young_modulus".into(), json!(1.5));
            m.insert("poisson_ratio".into(), json!(nu));
        });
        assert!(e.contains("model.micromodulus.poisson_ratio") && e.contains("(-1, 0.5)"), "{nu}: {e}");
    }
    let e = with(&|m| {
        m.remove("modulus");
        m.insert("young_modulus".into(), json!(-1.0));
    });
    assert!(e.contains("model.micromodulus.young_modulus") && e.contains("must be > 0"), "{e}");
    // plane stress: nu = 1/3, and 1/4 is refused naming it
    let mut plate = scene("plate-tension-2d");
    let m = plate["model"]["micromodulus"].as_object_mut().unwrap();
    m.remove("modulus");
    m.insert("young_modulus".into(), json!(1.0));
    m.insert("poisson_ratio".into(), json!(0.25));
    let e = error_of(&plate);
    assert!(e.contains("nu = 1/3") && e.contains("plane stress"), "{e}");
    // an explicit amplitude: phase moduli are multipliers
    let mut bar = scene("composite-bar");
    bar["model"]["material"]["phases"][0].as_object_mut().unwrap().remove("modulus");
    bar["model"]["material"]["phases"][0]["young_modulus"] = json!(10.0);
    let e = error_of(&bar);
    assert!(e.contains("model.material.phases[0].young_modulus") && e.contains("amplitude"), "{e}");
    // LPS
    let lps = scene("lps-tension-3d");
    let mut mix = lps.clone();
    mix["model"]["young_modulus"] = json!(1.0);
    let e = error_of(&mix);
    assert!(e.contains("model.young_modulus") && e.contains("not a mix"), "{e}");
    let mut half = lps.clone();
    half["model"].as_object_mut().unwrap().remove("shear_modulus");
    let e = error_of(&half);
    assert!(e.contains("model.shear_modulus") && e.contains("missing"), "{e}");
    let mut e_only = lps;
    let m = e_only["model"].as_object_mut().unwrap();
    m.remove("shear_modulus");
    m.remove("bulk_modulus");
    m.insert("young_modulus".into(), json!(1.0));
    let e = error_of(&e_only);
    assert!(e.contains("model.poisson_ratio") && e.contains("missing"), "{e}");
}
