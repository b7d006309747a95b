//! Surface corrections in scenes (issue #14): the uniform tension bar of Peridynamics.jl's
//! verification suite (`data/surface-bar-3d.json`: l = 1, cross-section 0.1 x 0.1, dx = 1/30
//! cell-centred, 33 x 3 x 3 points with 3 held layers at x < -l/2, horizon 3.015 dx, E = 200e9,
//! nu = 0.25, the last layer loaded with F = 2e6 N in total; measured: the mean x-displacement
//! of the loaded points against F l / (E A) = 1e-3), for none / energy / position_aware, bond
//! and LPS; and the scene errors of the new key.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn bar() -> Value {
    serde_json::from_str(&std::fs::read_to_string(data("surface-bar-3d.json")).unwrap()).unwrap()
}

/// The bar with `model` replaced by the LPS model (K, G from E, nu) or the bond model
/// (inverse-distance micromodulus normalized to the bulk modulus by the continuum integral, as
/// Peridynamics.jl does), with `correction`.
fn bar_with(model: &str, correction: &str, normalize: &str) -> Value {
    let mut v = bar();
    let k = 200e9 / (3.0 * (1.0 - 2.0 * 0.25));
    v["model"] = match model {
        "lps" => json!({"type": "lps", "horizon": 0.1005, "bulk_modulus": k, "shear_modulus": 80e9,
                        "surface_correction": correction}),
        _ => json!({"type": "bond", "horizon": 0.1005, "surface_correction": correction,
                    "micromodulus": {"kernel": "inverse_distance", "modulus": k, "normalize": normalize}}),
    };
    v
}

/// Relative error of the mean x-displacement of the loaded points against `F l / (E A)`.
fn elongation_error(v: &Value) -> f64 {
    let p = Problem::from_json(&v.to_string()).unwrap();
    let s = p.solve(&NoProgress).unwrap();
    let loaded: Vec<usize> = (0..s.x.len()).filter(|&i| s.x[i][0] > 0.5 - 1.0 / 30.0).collect();
    assert_eq!(loaded.len(), 9);
    let mean = loaded.iter().map(|&i| s.u[3 * i]).sum::<f64>() / loaded.len() as f64;
    mean / (2e6 * 1.0 / (200e9 * 0.01)) - 1.0
}

/// The numbers of the closing note of issue #14 (see docs/models.md, "Surface corrections"):
/// uncorrected, LPS is 36.8 % too stiff and bond-based 80.2 % too soft (the figures);
/// with `energy` the bond model meets the 5 % target (2.8 %; the peer's energy
/// correction: 13 %), and LPS is 9.0 % (`energy`) and 9.5 % (`position_aware`) too soft: better
/// than uncorrected by 4x, but far from the 0.5 % target (see docs/models.md for why an
/// energy-matching correction stops there). The bounds are the target where met and the
/// measured values +- 0.5 % where not, so that a regression either way fails.
#[test]
fn the_peridynamics_jl_tension_bar() {
    let cases = [
        ("lps", "none", "continuum", -0.368, 0.005),
        ("lps", "energy", "continuum", 0.0902, 0.005),
        ("lps", "position_aware", "continuum", 0.0945, 0.005),
        ("bond", "none", "continuum", 0.802, 0.005),
    ];
    for (model, correction, normalize, expected, tol) in cases {
        let e = elongation_error(&bar_with(model, correction, normalize));
        eprintln!("{model} {correction}: {:+.2} %", 100.0 * e);
        assert!((e - expected).abs() <= tol, "{model} {correction}: {e:+.4} (expected {expected:+.4})");
    }
    let bond = elongation_error(&bar_with("bond", "energy", "continuum"));
    eprintln!("bond energy: {:+.2} %", 100.0 * bond);
    assert!(bond.abs() <= 0.05, "bond-based with energy: {bond:+.4} (target 5 %)");
    // with the discrete normalization (the interior reproduces K exactly) the bond model with
    // `energy` is +13.0 %: the continuum normalization's 2.8 % includes its interior stiffening
    let discrete = elongation_error(&bar_with("bond", "energy", "discrete"));
    assert!((discrete - 0.130).abs() <= 0.005, "bond energy, discrete normalization: {discrete:+.4}");
}

/// Every corrected bond model still gives the same solution by the direct and the iterative
/// path (a corrected operator is not homogeneous: the stencil must not be used).
#[test]
fn a_corrected_bond_model_is_not_applied_by_the_stencil() {
    let mut direct = bar_with("bond", "energy", "discrete");
    let mut cg = direct.clone();
    direct["solver"] = json!({"type": "cholesky"});
    cg["solver"] = json!({"type": "cg", "matrix_free": true, "rtol": 1e-12});
    let solve = |v: &Value| Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap().u;
    let (a, b) = (solve(&direct), solve(&cg));
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    // CG to 1e-12 relative residual; the bar's condition number ~1e4 bounds the error by 1e-8
    assert!(diff <= 1e-8 * scale, "matrix-free CG vs Cholesky: {:e}", diff / scale);
}

fn error_of(v: &Value) -> String {
    match Problem::from_json(&v.to_string()) {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_surface_corrections_are_named_errors() {
    let mut v = bar();
    v["model"]["surface_correction"] = json!("volume");
    let e = error_of(&v);
    assert!(e.contains("model.surface_correction") && e.contains("position_aware"), "{e}");
    let e = error_of(&bar_with("bond", "position_aware", "continuum"));
    assert!(e.contains("model.surface_correction") && e.contains("LPS"), "{e}");
    let mut cloud: Value =
        serde_json::from_str(&std::fs::read_to_string(data("bracket-cloud-2d.json")).unwrap()).unwrap();
    cloud["model"]["surface_correction"] = json!("energy");
    let text = cloud.to_string();
    let e = match Problem::from_json_in(&text, &data("")) {
        Ok(_) => panic!("a cloud took a surface correction"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("model.surface_correction") && e.contains("point clouds"), "{e}");
    let mut blend: Value =
        serde_json::from_str(&std::fs::read_to_string(data("blend-point-load.json")).unwrap()).unwrap();
    blend["model"]["surface_correction"] = json!("energy");
    let e = error_of(&blend);
    assert!(e.contains("surface_correction"), "{e}");
}

/// No loss in the interior: an affine field given on a layer all around a 2D plate is still the
/// exact solution with a correction on (the layer is not a free surface, so no node is
/// corrected), for the bond model with `energy` and LPS with either correction (layer one
/// horizon thick for bonds, two for LPS, as without correction); 1e-11 relative
/// (the uncorrected bond patch tests reach 1e-13..1e-12 with Cholesky on ~1e3 unknowns; LPS
/// couples two horizons, whose larger condition number costs a digit).
#[test]
fn the_patch_test_holds_with_corrections_on() {
    let h = [[1e-3, 2e-4], [5e-4, -3e-4]];
    for (kind, correction) in [("bond", "energy"), ("lps", "energy"), ("lps", "position_aware")] {
        let model = match kind {
            "lps" => json!({"type": "lps", "horizon": 0.15, "bulk_modulus": 2.0, "shear_modulus": 1.0,
                            "plane": "strain", "surface_correction": correction}),
            _ => json!({"type": "bond", "horizon": 0.15, "plane": "strain", "surface_correction": correction,
                        "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0}}),
        };
        // the LPS tangent couples two horizons (through a neighbour's dilatation), so its layer
        // must be 2 delta thick for the body rows to see only full families
        let layer = if kind == "lps" { 0.3 } else { 0.15 };
        let v = json!({
            "name": "patch", "dimension": 2,
            "grid": {"min": [0.0, 0.0], "max": [1.0, 0.5], "spacing": 0.05, "layer": layer},
            "model": model,
            "constraints": [{"region": {"difference": ["all", {"box": {"min": [0.0, 0.0], "max": [1.0, 0.5]}}]},
                             "displacement": {"value": [0.0, 0.0], "gradient": h}}],
            "loads": [],
            "solver": {"type": "cholesky"}
        });
        let s = Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap();
        let mut worst = 0.0f64;
        for (i, x) in s.x.iter().enumerate() {
            for a in 0..2 {
                let exact = h[a][0] * x[0] + h[a][1] * x[1];
                worst = worst.max((s.u[2 * i + a] - exact).abs());
            }
        }
        assert!(worst <= 1e-11 * 1e-3, "{kind} {correction}: affine field off by {worst:e}");
    }
}
