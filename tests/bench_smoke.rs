//! `linpd bench --quick` runs end to end and writes the documented JSON fields (speed itself is
//! never asserted in tests; see docs/benchmarks.md for the measured figures).

use serde_json::Value;
use std::process::Command;

#[test]
fn quick_bench_writes_every_case_with_its_phases() {
    let dir = std::env::temp_dir().join(format!("linpd-bench-smoke-{}", std::process::id()));
    let out = dir.join("bench.json");
    let status = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["bench", "--quick", "--lps", "--dynamics", "--out"])
        .arg(&out)
        .status()
        .expect("run linpd bench");
    assert!(status.success());
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(doc["machine"]["copy_bandwidth_bytes_per_s"].as_f64().unwrap() > 0.0);
    for name in ["1d-n1e5-m50", "1d-n1e4-m500", "3d-20", "3d-30", "3d-40"] {
        let c = &doc["cases"][name];
        assert!(c["time_assembly"].as_f64().unwrap() > 0.0, "{name}");
        assert!(c["nnz_a"].as_u64().unwrap() > 0, "{name}");
        assert!(c["matvec"]["ratio_to_bound"].as_f64().unwrap() > 0.0, "{name}");
        // Every direct solve reached round-off; every CG its target.
        assert!(c["cholesky"]["rel_residual"].as_f64().unwrap() < 1e-10, "{name}");
        if name.starts_with("3d") {
            assert!(c["cg"]["rel_residual"].as_f64().unwrap() <= 1e-8, "{name}");
            assert!(c["cg_matrix_free"]["rel_residual"].as_f64().unwrap() <= 1e-8, "{name}");
            assert_eq!(c["cholesky"]["ordering"], "nested-dissection");
        }
    }
    // The LPS and dynamics sections ran too.
    assert!(doc["lps"].as_object().is_some_and(|o| !o.is_empty()), "no lps section");
    assert!(doc["dynamics"].is_object() || doc["dynamics"].is_array(), "no dynamics section");
    let _ = std::fs::remove_dir_all(&dir);
}
