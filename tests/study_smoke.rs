//! The fast studies (blended model, dispersion, md-pd, coarsen-tent, coarsen-defect) regenerate
//! their data and figures from the CLI (the slow ones, blend-pd-size, blend-bridge-size,
//! blend-speedup, blend-speed-vs-error and coarsen-speed-vs-error, take 30-90 s each and are run by hand; their outputs are committed under docs/studies/).

use serde_json::Value;
use std::process::Command;

#[test]
fn fast_studies_write_data_and_plots() {
    let root = std::env::temp_dir().join(format!("linpd-study-smoke-{}", std::process::id()));
    for (name, figures) in [
        ("blend-patch", vec!["fig7_profiles", "fig8_strain_fluctuation"]),
        ("blend-point-load", vec!["fig9_profiles", "fig9_profiles_zoom", "fig10_error_profiles"]),
        ("blend-load-location", vec!["fig13_error_vs_load_location"]),
        ("dispersion", vec!["lattice_bond_3d", "lattice_lps_2d"]),
        ("md-pd", vec!["snapshot", "square_md_pd_t150"]),
        ("coarsen-tent", vec!["fig3_micromodulus"]),
        ("coarsen-defect", vec!["fig7_defect"]),
    ] {
        let dir = root.join(name);
        let out = Command::new(env!("CARGO_BIN_EXE_linpd")).args(["study", name, "--out"]).arg(&dir).output().unwrap();
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        let data: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("data.json")).unwrap()).unwrap();
        assert_eq!(data["study"], name);
        for f in figures {
            for ext in ["png", "svg"] {
                let p = dir.join(format!("{f}.{ext}"));
                assert!(
                    std::fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false),
                    "{} missing or empty",
                    p.display()
                );
            }
        }
    }
    // The patch study's table: every model's strain spread at round-off (direct solves).
    let data: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("blend-patch/data.json")).unwrap()).unwrap();
    for m in data["models"].as_array().unwrap() {
        assert!(m["strain_spread"].as_f64().unwrap() < 1e-12, "{}", m["model"]);
    }
    // Silling 2010 Example 5.3 (crates/linpd-coarsen/tests/examples.rs): with a whole-body
    // radius the coarse levels reproduce the level-0 jump across the defect to round-off.
    let data: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("coarsen-defect/data.json")).unwrap()).unwrap();
    let whole: Vec<&Value> =
        data["jumps"].as_array().unwrap().iter().filter(|r| r["r1"].as_f64() == Some(10.0)).collect();
    assert_eq!(whole.len(), 2);
    for r in whole {
        assert!(r["jump_rel_error"].as_f64().unwrap().abs() < 1e-12, "{r}");
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["study", "blend-nope", "--out"])
        .arg(root.join("x"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    // clap rejects the name and lists every study (the registry is `linpd_studies::Study`).
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("invalid value 'blend-nope'"), "{stderr}");
    for name in ["list", "blend-patch", "lps-tension-bar", "dispersion", "md-pd", "coarsen-speed-vs-error"] {
        assert!(stderr.contains(name), "{name} not in: {stderr}");
    }
    assert!(!root.join("x").exists(), "no output for a failed study");
    let _ = std::fs::remove_dir_all(&root);
}
