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
/// Peridynamics.jl does), with `correction` matched to `target` (`None`: the default).
fn bar_with(model: &str, correction: &str, normalize: &str, target: Option<&str>) -> Value {
    let mut v = bar();
    let k = 200e9 / (3.0 * (1.0 - 2.0 * 0.25));
    v["model"] = match model {
        "lps" => json!({"type": "lps", "horizon": 0.1005, "bulk_modulus": k, "shear_modulus": 80e9,
                        "surface_correction": correction}),
        _ => json!({"type": "bond", "horizon": 0.1005, "surface_correction": correction,
                    "micromodulus": {"kernel": "inverse_distance", "modulus": k, "normalize": normalize}}),
    };
    if let Some(t) = target {
        v["model"]["surface_target"] = json!(t);
    }
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

/// The measure: the mean x-displacement of the loaded points against `F l / (E A)`.
/// The exact classical bar loaded by the same body force on its last cell `[l/2 - h, l/2]` and
/// measured at that cell's centre reads `1 - 5h/8` of it (-2.08 % at `h = 1/30`), so an exact
/// model would show -2.08 % here.
///
/// Measured (issue #14; docs/models.md, "Surface corrections"): uncorrected, LPS is 36.8 % too
/// stiff and bond-based 80.2 % too soft (the figures). With the classical target (the
/// default) LPS `position_aware` is -2.64 % (0.57 % stiffer than the exact bar), LPS `energy`
/// -3.06 %, bond `energy` -0.30 % (the 5 % target; the peer's energy correction 13 %);
/// the 0.5 % target for LPS is missed by 2.1 points, 2.08 of which are the measure's own offset.
/// With the lattice target the corrected models converge to the lattice's cubic anisotropy
/// instead (LPS +9.0 / +9.5 %, bond +1.9 %). Bounds: the target where met, the measured value
/// +- 0.5 % (points) where not, so that a regression either way fails.
#[test]
fn the_peridynamics_jl_tension_bar() {
    let cases = [
        ("lps", "none", None, -0.368),
        ("lps", "energy", None, -0.0306),
        ("lps", "position_aware", None, -0.0264),
        ("bond", "none", None, 0.802),
        ("lps", "energy", Some("lattice"), 0.0902),
        ("lps", "position_aware", Some("lattice"), 0.0945),
        ("bond", "energy", Some("lattice"), 0.0191),
    ];
    for (model, correction, target, expected) in cases {
        let e = elongation_error(&bar_with(model, correction, "continuum", target));
        eprintln!("{model} {correction} {target:?}: {:+.2} %", 100.0 * e);
        assert!((e - expected).abs() <= 0.005, "{model} {correction} {target:?}: {e:+.4} (expected {expected:+.4})");
    }
    let bond = elongation_error(&bar_with("bond", "energy", "continuum", None));
    eprintln!("bond energy: {:+.2} %", 100.0 * bond);
    assert!(bond.abs() <= 0.05, "bond-based with energy: {bond:+.4} (target 5 %)");
    // with the lattice target and the discrete normalization (the interior reproduces K
    // exactly) the bond model is +12.0 %: the continuum normalization's +1.9 % includes its
    // interior stiffening (the lattice sum exceeds the integral by 9.9 % at 3.015 h)
    let discrete = elongation_error(&bar_with("bond", "energy", "discrete", Some("lattice")));
    assert!((discrete - 0.1196).abs() <= 0.005, "bond energy, discrete normalization: {discrete:+.4}");
}

/// With the classical target every bond-based node stores the classical energy of the scene's
/// modulus whatever the normalization: the continuum and the discrete normalization give the
/// same corrected weights (`c phi` is the same product), hence the same solution to round-off
/// (Cholesky on 810 unknowns, condition ~1e4: 1e-11 relative).
#[test]
fn the_classical_target_makes_the_bond_normalization_irrelevant() {
    let solve = |v: &Value| Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap().u;
    let a = solve(&bar_with("bond", "energy", "continuum", None));
    let b = solve(&bar_with("bond", "energy", "discrete", None));
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(diff <= 1e-11 * scale, "continuum vs discrete normalization: {:e}", diff / scale);
    // and without the correction they differ by the normalizations' ratio (~10 % at 3.015 h)
    let c = solve(&bar_with("bond", "none", "continuum", None));
    let d = solve(&bar_with("bond", "none", "discrete", None));
    let diff = c.iter().zip(&d).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(diff > 1e-2 * scale, "uncorrected normalizations agree: {:e}", diff / scale);
}

/// The cantilever: 1 x 0.1 x 0.1, clamped through three held layers at x < 0, tip
/// plane loaded in -z, `h = 0.01`, `delta = 3h`, `nu = 1/4`; tip plane's mean deflection
/// against Timoshenko `P L^3/(3EI) + P L/(kappa G A)` at the tip plane's `x = L` with Cowper's
/// `kappa = 10(1 + nu)/(12 + 11 nu)` (0.8475). Measured: LPS `energy` +1.02 %, bond `energy`
/// +2.49 % (the 3 % target: met by both; bond-based with the mean of the ends alone,
/// without the trace scaling (S5), was +9.7 %). Bound: the target.
#[test]
fn the_cantilever_at_h_0_01() {
    let (e, p, nu, h) = (1.0, 1e-5, 0.25, 0.01);
    for (kind, expected, tol) in [("lps", 0.0, 0.03), ("bond", 0.0, 0.03)] {
        let model = match kind {
            "lps" => json!({"type": "lps", "horizon": 3.0 * h, "bulk_modulus": e / 1.5, "shear_modulus": e / 2.5,
                            "surface_correction": "energy"}),
            _ => json!({"type": "bond", "horizon": 3.0 * h, "surface_correction": "energy",
                        "micromodulus": {"kernel": "inverse_distance", "modulus": e / 1.5, "normalize": "continuum"}}),
        };
        let v = json!({
            "name": "cantilever", "dimension": 3,
            "grid": {"min": [0.0, -0.05, -0.05], "max": [1.0, 0.05, 0.05], "spacing": h,
                     "placement": "cell", "layer": {"x-": 3.0 * h}},
            "model": model,
            "constraints": [{"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [0.0, 1.0, 1.0]}},
                             "displacement": {"value": [0.0, 0.0, 0.0]}}],
            "loads": [{"type": "resultant", "region": {"box": {"min": [1.0 - h, -1.0, -1.0], "max": [2.0, 1.0, 1.0]}},
                       "force": [0.0, 0.0, -p]}],
            "solver": {"type": "cg", "preconditioner": "multigrid", "rtol": 1e-9}
        });
        let s = Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap();
        let x_tip = s.x.iter().fold(f64::NEG_INFINITY, |m, x| m.max(x[0]));
        let tip: Vec<usize> = (0..s.x.len()).filter(|&i| s.x[i][0] > x_tip - 1e-9).collect();
        assert_eq!(tip.len(), 100);
        let w = -tip.iter().map(|&i| s.u[3 * i + 2]).sum::<f64>() / tip.len() as f64;
        let (g, i, a) = (e / (2.0 * (1.0 + nu)), 0.1f64.powi(4) / 12.0, 0.01);
        let kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
        let timoshenko = p * x_tip.powi(3) / (3.0 * e * i) + p * x_tip / (kappa * g * a);
        let err = w / timoshenko - 1.0;
        eprintln!("cantilever {kind} energy: {:+.2} %", 100.0 * err);
        assert!((err - expected).abs() <= tol, "{kind}: {err:+.4} (expected {expected:+.4} +- {tol})");
    }
}

/// Every corrected bond model still gives the same solution by the direct and the iterative
/// path (a corrected operator is not homogeneous: the stencil alone must not be used, the
/// stencil with the corrected bonds is).
#[test]
fn a_corrected_bond_model_is_not_applied_by_the_stencil_alone() {
    let mut direct = bar_with("bond", "energy", "discrete", None);
    let mut cg = direct.clone();
    direct["solver"] = json!({"type": "cholesky"});
    cg["solver"] = json!({"type": "cg", "matrix_free": true, "rtol": 1e-12});
    let solve = |v: &Value| Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap();
    let (a, b) = (solve(&direct), solve(&cg));
    assert_eq!(b.report.solver.to_string(), "cg-jacobi-matrix-free-corrected-stencil");
    let (a, b) = (a.u, b.u);
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
    let e = error_of(&bar_with("bond", "position_aware", "continuum", None));
    assert!(e.contains("model.surface_correction") && e.contains("LPS"), "{e}");
    let mut v = bar();
    v["model"]["surface_target"] = json!("bulk");
    let e = error_of(&v);
    assert!(e.contains("model.surface_target") && e.contains("classical"), "{e}");
    // a target without a correction, the default value included
    for target in ["lattice", "classical"] {
        let e = error_of(&bar_with("lps", "none", "continuum", Some(target)));
        assert!(e.contains("model.surface_target") && e.contains("surface_correction"), "{target}: {e}");
    }
    // clouds take the corrections with the classical target only (tests/point_cloud.rs,
    // tests/meshes.rs): the lattice target is named
    let mut cloud: Value =
        serde_json::from_str(&std::fs::read_to_string(data("bracket-cloud-lps-2d.json")).unwrap()).unwrap();
    cloud["model"]["surface_correction"] = json!("energy");
    cloud["model"]["surface_target"] = json!("lattice");
    let text = cloud.to_string();
    let e = match Problem::from_json_in(&text, &data("")) {
        Ok(_) => panic!("an LPS cloud took the lattice target"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("model.surface_target") && e.contains("a point cloud has none"), "{e}");
    let mut blend: Value =
        serde_json::from_str(&std::fs::read_to_string(data("blend-point-load.json")).unwrap()).unwrap();
    blend["model"]["surface_correction"] = json!("energy");
    let e = error_of(&blend);
    assert!(e.contains("surface_correction"), "{e}");
}

/// No loss in the interior: an affine field given on a layer all around a 2D plate is still the
/// exact solution with a correction on (the layer is not a free surface, so every node gets the
/// full family's factor: with the default classical target one function of the direction, the
/// same on every node, which keeps every family symmetric), for the bond model with `energy` and LPS with either correction (layer one
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
