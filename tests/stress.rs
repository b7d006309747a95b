//! Stress (issue #32): the Hooke stress of the model's constants and the nodal strain, its von
//! Mises and principal values, and the force-flux stress of the bond-based models
//! (crates/linpd-scene/src/stress.rs), in result.json and result.vtu.

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::{json, Value};

/// A displacement gradient for the affine fields (3D; its upper-left block in 2D).
const GRAD: [[f64; 3]; 3] = [[1e-3, 2e-3, -1e-3], [-5e-4, 3e-3, 1e-3], [2e-3, 0.0, -1e-3]];

/// A box `[0, 1]^d` at `h = 0.1` with a layer of `4h` held to `u = G x` all around (the
/// reach of LPS rows with `delta = 2h`: the dilatation of a neighbour's neighbours).
fn patch(d: usize, model: Value, grad: &[Vec<f64>]) -> Value {
    let (lo, hi) = (vec![-1.0; d], vec![2.0; d]);
    json!({"name": "patch", "dimension": d,
        "grid": {"min": vec![0.0; d], "max": vec![1.0; d], "spacing": 0.1, "layer": 0.4},
        "model": model,
        "constraints": [{"region": {"difference": [{"box": {"min": lo, "max": hi}}, {"box": {"min": vec![0.0; d], "max": vec![1.0; d]}}]},
            "displacement": {"value": vec![0.0; d], "gradient": grad}}],
        "solver": {"type": "cholesky"}})
}

fn bond(plane: Option<&str>) -> Value {
    let mut m = json!({"type": "bond", "horizon": 0.3, "micromodulus": {"kernel": "inverse_distance", "modulus": 2.0}});
    if let Some(p) = plane {
        m["plane"] = json!(p);
    }
    m
}

fn grad(d: usize, scale: f64) -> Vec<Vec<f64>> {
    (0..d).map(|a| (0..d).map(|b| scale * GRAD[a][b]).collect()).collect()
}

/// The body nodes (not the layer) of a solution.
fn body(s: &linpd::problem::Solution) -> impl Iterator<Item = usize> + '_ {
    (0..s.x.len()).filter(|&i| !s.is_layer[i])
}

/// Under an affine field the strain is exact at every node, so the Hooke stress is the closed
/// form `lambda tr(eps) I + 2 mu eps` (3D, plane strain) or with `lambda* = 2 lambda mu /
/// (lambda + 2 mu)` (plane stress), `E`, `nu` those of the model (bond: `E = 3K/2`, `nu = 1/4`,
/// plane stress `E = K`, `nu = 1/3`; LPS: its `K`, `G`), to 1e-9 of `|sigma|` (the solve's
/// residual through the strain's least squares).
#[test]
fn affine_fields_give_the_hooke_stress() {
    let lps = json!({"type": "lps", "horizon": 0.2, "bulk_modulus": 2.0, "shear_modulus": 0.5});
    let lps_2d = json!({"type": "lps", "horizon": 0.2, "bulk_modulus": 2.0, "shear_modulus": 0.5, "plane": "stress"});
    // (dimension, model, E, nu, plane stress)
    let cases = [
        (3, bond(None), 3.0, 0.25, false),
        (2, bond(Some("strain")), 3.0, 0.25, false),
        (2, bond(Some("stress")), 2.0, 1.0 / 3.0, true),
        (3, lps, 9.0 * 2.0 * 0.5 / 6.5, 5.0 / 13.0, false),
        (2, lps_2d, 9.0 * 2.0 * 0.5 / 6.5, 5.0 / 13.0, true),
    ];
    for (d, model, e, nu, plane_stress) in cases {
        let g = grad(d, 1.0);
        let s = Problem::from_json(&patch(d, model.clone(), &g).to_string()).unwrap().solve(&NoProgress).unwrap();
        let stress = s.stress.as_ref().expect("a stress");
        let (lambda, mu) = (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)));
        let lambda_in = if plane_stress { 2.0 * lambda * mu / (lambda + 2.0 * mu) } else { lambda };
        let eps = |a: usize, b: usize| 0.5 * (g[a][b] + g[b][a]);
        let tr: f64 = (0..d).map(|a| eps(a, a)).sum();
        let exact = |a: usize, b: usize| 2.0 * mu * eps(a, b) + if a == b { lambda_in * tr } else { 0.0 };
        let scale = (0..d).flat_map(|a| (0..d).map(move |b| (a, b))).fold(0.0f64, |m, (a, b)| m.max(exact(a, b).abs()));
        let worst = body(&s)
            .flat_map(|i| (0..d).flat_map(move |a| (0..d).map(move |b| (i, a, b))))
            .map(|(i, a, b)| (stress.tensor[i][3 * a + b] - exact(a, b)).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-9 * scale, "{d}D {}: {:e}", model["type"], worst / scale);
        // von Mises of the full tensor and the principal values of the in-plane block
        let i = body(&s).next().unwrap();
        let t = &stress.tensor[i];
        let p = (t[0] + t[4] + t[8]) / 3.0;
        let dev2: f64 = (0..9).map(|k| (t[k] - if k % 4 == 0 { p } else { 0.0 }).powi(2)).sum();
        assert!((stress.von_mises(i) - (1.5 * dev2).sqrt()).abs() <= 1e-12 * scale);
        let pr = stress.principal(i);
        assert!(pr.windows(2).all(|w| w[0] >= w[1]), "{pr:?}");
        let trace_in: f64 = (0..d).map(|a| t[4 * a]).sum();
        assert!((pr.iter().sum::<f64>() - trace_in).abs() <= 1e-12 * scale, "{pr:?}");
    }
}

/// The force-flux stress under an isotropic extension `eps I` is the model's bulk response in
/// the interior, from the moment condition of its normalization (docs/problem-format.md,
/// "What `modulus` means"): `3K eps` in 3D, `2 K_2 eps` in 2D with `K_2 = 3K/4` (plane stress)
/// or `6K/5` (plane strain), to 1e-9 (round-off of the solve); LPS scenes have none.
#[test]
fn isotropic_extension_gives_the_bulk_flux() {
    let k = 2.0;
    for (d, plane, bulk) in [(3, None, 3.0 * k), (2, Some("stress"), 1.5 * k), (2, Some("strain"), 2.4 * k)] {
        let g: Vec<Vec<f64>> = (0..d).map(|a| (0..d).map(|b| if a == b { 1e-3 } else { 0.0 }).collect()).collect();
        let s = Problem::from_json(&patch(d, bond(plane), &g).to_string()).unwrap().solve(&NoProgress).unwrap();
        let flux = s.pd_stress.as_ref().expect("a bond model's force flux");
        let worst = body(&s)
            .flat_map(|i| (0..d).flat_map(move |a| (0..d).map(move |b| (i, a, b))))
            .map(|(i, a, b)| (flux.tensor[i][3 * a + b] - if a == b { bulk * 1e-3 } else { 0.0 }).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-9 * bulk * 1e-3, "{d}D {plane:?}: {:e}", worst / (bulk * 1e-3));
    }
    let lps = json!({"type": "lps", "horizon": 0.2, "bulk_modulus": 2.0, "shear_modulus": 0.5});
    let s = Problem::from_json(&patch(3, lps, &grad(3, 1.0)).to_string()).unwrap().solve(&NoProgress).unwrap();
    assert!(s.pd_stress.is_none() && s.stress.is_some());
}

/// data/plate-hole-2d.json solved at spacing `h` (horizon and layers `3h`, the row held in y
/// at the hole's height one spacing thick).
fn plate_hole(h: f64) -> linpd::problem::Solution {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/data/plate-hole-2d.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["grid"]["spacing"] = json!(h);
    v["grid"]["layer"] = json!({"x-": 3.0 * h, "x+": 3.0 * h});
    v["model"]["horizon"] = json!(3.0 * h);
    v["constraints"][1]["region"]["box"] = json!({"min": [-1.0, 0.25 - h / 2.0], "max": [0.0, 0.25 + h / 2.0]});
    Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress).unwrap()
}

/// `sum_i nu_xx(i) V_i / h` over one layer of nodes `x = x0` against the applied force.
fn section_force(s: &linpd::problem::Solution, x0: f64, h: f64) -> f64 {
    let flux = s.pd_stress.as_ref().unwrap();
    (0..s.x.len()).filter(|&i| (s.x[i][0] - x0).abs() < 1e-9).map(|i| flux.tensor[i][0] * s.volumes[i] / h).sum()
}

/// The force flux integrated over a section is the force through it: on a bond bar pulled by a
/// resultant (1 x 0.1 x 0.1, 4 cells across, clamped through a layer) at mid-length to 1e-8 of
/// the load (measured 1e-11: the field is invariant along the bar there up to the ends'
/// decay, 4e-7 at a quarter length, where the bound is 1e-5); on the plate with a hole
/// (data/plate-hole-2d.json) at `x = 0.2` and `0.8` to 1e-4 (measured 4.7e-5: the field's
/// variation across a horizon); through the hole's centre the nodal (virial) form is off by
/// the stress concentration's variation over a horizon: 5.5 % at `h = 0.01`, 3.0 % at `h/2`,
/// tested as below 6 % and falling at least like `h^0.8`.
#[test]
fn force_flux_through_a_section_is_the_load() {
    let h = 0.025;
    let bar = json!({"name": "bar", "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 0.1, 0.1], "spacing": h, "layer": {"x-": 3.0 * h}},
        "model": {"type": "bond", "horizon": 3.0 * h, "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0}},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [0.0, 1.0, 1.0]}}, "displacement": {"value": [0.0, 0.0, 0.0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [1.0, -1.0, -1.0], "max": [2.0, 1.0, 1.0]}}, "force": [1e-3, 0.0, 0.0]}]});
    let s = Problem::from_json(&bar.to_string()).unwrap().solve(&NoProgress).unwrap();
    for (x0, tol) in [(0.5, 1e-8), (0.25, 1e-5), (0.75, 1e-5)] {
        let f = section_force(&s, x0, h);
        assert!((f / 1e-3 - 1.0).abs() <= tol, "bar at x = {x0}: {f:e}");
    }
    let mut errors = Vec::new();
    for h in [0.01, 0.005] {
        let s = plate_hole(h);
        let applied = s.balance.as_ref().unwrap().applied[0];
        if h == 0.01 {
            for x0 in [0.2, 0.8] {
                let f = section_force(&s, x0, h);
                assert!((f / applied - 1.0).abs() <= 1e-4, "plate at x = {x0}: {f} vs {applied}");
            }
        }
        errors.push((section_force(&s, 0.5, h) / applied - 1.0).abs());
    }
    println!("through the hole: {errors:?}");
    assert!(errors[0] < 0.06 && errors[1] <= errors[0] * 0.5f64.powf(0.8), "{errors:?}");
}

/// result.json carries `stress`, `von_mises`, `principal_stress` and (bond models) `pd_stress`
/// per node, result.vtu the fields `stress`, `von_mises` and `pd_stress`.
#[test]
fn stress_reaches_result_json_and_vtu() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/plate-hole-2d.json");
    let s = Problem::from_path(std::path::Path::new(path)).unwrap().solve(&NoProgress).unwrap();
    let doc = s.to_json();
    let n = s.x.len();
    for key in ["stress", "von_mises", "principal_stress", "pd_stress"] {
        assert_eq!(doc[key].as_array().map(Vec::len), Some(n), "{key}");
    }
    assert_eq!(doc["stress"][0].as_array().unwrap().len(), 3, "2D Voigt");
    let dir = std::env::temp_dir().join(format!("linpd-stress-{}", std::process::id()));
    s.write(&dir).unwrap();
    let vtu = std::fs::read_to_string(dir.join("result.vtu")).unwrap();
    for name in ["stress", "von_mises", "pd_stress"] {
        assert!(vtu.contains(&format!("Name=\"{name}\"")), "{name}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `stats.peak_von_mises` of the plate with a hole (1 x 0.5, a hole of diameter 0.2 at the
/// centre, pulled by 0.5: nominal gross stress 1) is the largest `von_mises` of the body's
/// nodes, it sits on the hole's edge (within a spacing and a half of radius 0.1, on the
/// section through the hole's centre at `x = 0.5 +- 2h`), and it rises towards Howland's
/// 3.74 (`d/W = 0.4`) as `h` halves: 2.81 at `h = 0.01`, 3.10 at `h = 0.005` (docs/models.md
/// gives the sequence to `h = 0.00125`: 3.65), at least 0.2 per halving here.
#[test]
fn the_peak_von_mises_sits_at_the_hole_and_rises_towards_howland() {
    let mut peaks = Vec::new();
    for h in [0.01, 0.005] {
        let s = plate_hole(h);
        let doc = s.to_json();
        let p = &doc["stats"]["peak_von_mises"];
        let value = p["value"].as_f64().unwrap();
        let body_max = (0..s.x.len())
            .filter(|&i| !s.is_layer[i])
            .map(|i| doc["von_mises"][i].as_f64().unwrap())
            .fold(f64::MIN, f64::max);
        assert_eq!(value, body_max, "h = {h}");
        let x: Vec<f64> = p["x"].as_array().unwrap().iter().map(|c| c.as_f64().unwrap()).collect();
        let r = ((x[0] - 0.5).powi(2) + (x[1] - 0.25).powi(2)).sqrt();
        assert!(r <= 0.1 + 1.5 * h && (x[0] - 0.5).abs() <= 2.0 * h + 1e-12, "h = {h}: peak at {x:?}");
        peaks.push(value);
    }
    println!("peak von Mises {peaks:?} (Howland 3.74)");
    assert!(peaks[1] - peaks[0] >= 0.2 && peaks[1] < 3.74, "{peaks:?}");
}
