//! The fields `linpd solve` and `linpd run` write (issue #13 item 5), opened with a real VTK
//! reader (meshio 5.3.5, installed by `.ci/run`) and compared bit for bit with `result.json`,
//! the snapshot CSVs and `history.json`: the VTU files print 17 significant digits, the JSON
//! the shortest round-trip digits and the CSVs 18, and Python parses all three correctly
//! rounded, so the comparisons are `==` (done in Python: serde_json's default float parsing
//! may be off by an ulp).
//!
//! * `result.vtu` of an LPS scene (`data/lps-plate-2d.json`: `strain`, `dilatation`,
//!   `strain_energy_density`) and a 3D bond scene (`data/cantilever-3d.json`: `strain` with 6
//!   Voigt components, `strain_energy_density`): the `strain` array has 9 components, the full
//!   tensor row-major, symmetric, equal to the Voigt components of `result.json` and 0 outside
//!   the `d x d` block;
//! * the LPS scene's energy density sums to the energy of its tangent, `sum_i W_i V_i = u.A u /
//!   2` (1e-12 relative: a sum of ~1000 terms `>= 0` against one dot product);
//! * a 2D `linpd run`: every `u_<step>.vtu` listed in `snapshots.pvd` (in order, with the times
//!   of `history.json`) opens with the displacements of `u_<step>.csv`; no legacy `.vtk`.

use linpd::problem::Problem;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

fn temp(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-fields-out-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn linpd(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().unwrap();
    assert!(o.status.success(), "linpd {args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// Runs `script` with `python3` on `arg`; its standard output as JSON.
fn python(script: &str, arg: &Path) -> Value {
    let py = Command::new("python3").arg("-c").arg(script).arg(arg).output().expect("python3 runs");
    assert!(py.status.success(), "python: {}", String::from_utf8_lossy(&py.stderr));
    serde_json::from_slice(&py.stdout).unwrap()
}

const STATIC: &str = r#"
import json, sys, os, meshio
out = sys.argv[1]
m = meshio.read(os.path.join(out, "result.vtu"))
r = json.load(open(os.path.join(out, "result.json")))
d, n = r["dimension"], len(r["x"])
voigt = {1: [(0, 0)], 2: [(0, 0), (1, 1), (0, 1)], 3: [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]}[d]
pd = m.point_data
bad, checked = {}, {}
def cmp(name, a, b):
    checked[name] = checked.get(name, 0) + 1
    if not (float(a) == float(b)):
        bad[name] = bad.get(name, 0) + 1
one = lambda v: v if isinstance(v, list) else [v]
for k in range(n):
    for a in range(d):
        cmp("points", m.points[k][a], one(r["x"][k])[a])
        cmp("u", pd["u"][k][a], one(r["u"][k])[a])
    s = pd["strain"][k]
    for c, (p, q) in enumerate(voigt):
        cmp("strain", s[3 * p + q], one(r["strain"][k])[c])
        cmp("strain", s[3 * q + p], one(r["strain"][k])[c])
    for p in range(3):
        for q in range(3):
            if p >= d or q >= d:
                cmp("strain_padding", s[3 * p + q], 0.0)
    for key in ["stress", "pd_stress"]:
        if key in pd:
            t = pd[key][k]
            for c, (p, q) in enumerate(voigt):
                cmp(key, t[3 * p + q], one(r[key][k])[c])
    if "von_mises" in pd:
        cmp("von_mises", pd["von_mises"][k], r["von_mises"][k])
    cmp("strain_energy_density", pd["strain_energy_density"][k], r["strain_energy_density"][k])
    if r["dilatation"] is not None:
        cmp("dilatation", pd["dilatation"][k], r["dilatation"][k])
print(json.dumps({"arrays": sorted(pd.keys()), "strain_shape": list(pd["strain"].shape), "bad": bad,
                  "checked": checked, "singular": r["strain_singular_nodes"],
                  "max_strain": max(abs(float(x)) for x in pd["strain"].flatten())}))
"#;

#[test]
fn result_vtu_holds_strain_dilatation_and_energy_equal_to_result_json() {
    // (and the stresses and the supports' reactions, issue #32)
    for (scene, arrays, checks) in [
        (
            "lps-plate-2d.json",
            vec![
                "dilatation",
                "layer",
                "reaction",
                "strain",
                "strain_energy_density",
                "stress",
                "u",
                "volume",
                "von_mises",
            ],
            json!({"points": 0, "u": 0, "strain": 0, "strain_padding": 0, "strain_energy_density": 0, "dilatation": 0,
                   "stress": 0, "von_mises": 0}),
        ),
        (
            "cantilever-3d.json",
            vec![
                "layer",
                "pd_stress",
                "reaction",
                "strain",
                "strain_energy_density",
                "stress",
                "u",
                "volume",
                "von_mises",
            ],
            json!({"points": 0, "u": 0, "strain": 0, "strain_energy_density": 0, "stress": 0, "pd_stress": 0,
                   "von_mises": 0}),
        ),
    ] {
        let out = temp(scene);
        linpd(&["solve", data(scene).to_str().unwrap(), "-q", "--out", out.to_str().unwrap()]);
        let v = python(STATIC, &out);
        eprintln!("{scene}: {v}");
        assert_eq!(v["arrays"], json!(arrays), "{scene}");
        assert_eq!(v["strain_shape"][1], 9, "{scene}: 9 components");
        assert_eq!(v["bad"], json!({}), "{scene}: values differ from result.json");
        for key in checks.as_object().unwrap().keys() {
            assert!(v["checked"][key].as_u64().unwrap() > 0, "{scene}: {key} compared");
        }
        assert_eq!(v["singular"], json!([]), "{scene}");
        assert!(v["max_strain"].as_f64().unwrap() > 0.0, "{scene}: a loaded body strains");
        let _ = std::fs::remove_dir_all(&out);
    }
    // sum W_i V_i = u.A u / 2 on the solved LPS scene
    let p = Problem::from_path(&data("lps-plate-2d.json")).unwrap();
    let s = p.solve(&linpd::core::NoProgress).unwrap();
    let model = p.lps_model().unwrap();
    let mut au = vec![0.0; s.u.len()];
    linpd::core::Model::apply(&model, &s.u, &mut au);
    let energy = 0.5 * s.u.iter().zip(&au).map(|(a, b)| a * b).sum::<f64>();
    let w = s.strain_energy_density.as_ref().unwrap();
    let summed: f64 = w.iter().zip(&s.volumes).map(|(w, v)| w * v).sum();
    eprintln!("lps-plate-2d: |sum W V / (u.Au/2) - 1| = {:.2e}", (summed / energy - 1.0).abs());
    assert!(w.iter().all(|x| *x >= 0.0), "LPS energy density is >= 0");
    assert!((summed / energy - 1.0).abs() < 1e-12, "sum W V = {summed:e}, u.Au/2 = {energy:e}");
    assert_eq!(s.dilatation.as_ref().unwrap(), &model.linearized_theta(&s.u));
}

const DYNAMICS: &str = r#"
import json, sys, os, meshio, xml.etree.ElementTree as ET
out = sys.argv[1]
h = json.load(open(os.path.join(out, "history.json")))
sets = ET.parse(os.path.join(out, "snapshots.pvd")).getroot().find("Collection").findall("DataSet")
bad, files = 0, []
for i, ds in enumerate(sets):
    files.append(ds.get("file"))
    if float(ds.get("timestep")) != h["times"][i]:
        bad += 1
    m = meshio.read(os.path.join(out, ds.get("file")))
    rows = [l.strip().split(",") for l in open(os.path.join(out, ds.get("file")[:-4] + ".csv")).readlines()[1:]]
    for k, row in enumerate(rows):
        for a in range(2):
            if float(m.point_data["u"][k][a]) != float(row[2 + a]) or float(m.points[k][a]) != float(row[a]):
                bad += 1
        if float(m.point_data["u"][k][2]) != 0.0 or int(m.point_data["layer"][k]) != int(row[4]):
            bad += 1
print(json.dumps({"files": files, "bad": bad, "vtk": [f for f in os.listdir(out) if f.endswith(".vtk")],
                  "vtu": sorted(f for f in os.listdir(out) if f.endswith(".vtu"))}))
"#;

#[test]
fn dynamics_snapshots_are_vtu_files_in_a_pvd_collection() {
    let dir = temp("run");
    std::fs::create_dir_all(&dir).unwrap();
    let u: Vec<f64> = (0..50).map(|k| 1e-3 * (k as f64).sin()).collect();
    let scene = json!({
        "name": "tiny-2d",
        "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [0.4, 0.4], "spacing": 0.1},
        "model": {"type": "bond", "horizon": 0.3, "plane": "strain", "partial_volume": false,
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
        "dynamics": {"dt_safety": 0.5, "steps": 12, "output_every": 3, "density": 1.0,
                     "initial": {"type": "data", "u": u}},
        "output": {"plot": false}
    });
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let out = dir.join("out");
    linpd(&["run", path.to_str().unwrap(), "-q", "--out", out.to_str().unwrap()]);
    let v = python(DYNAMICS, &out);
    let steps = ["00", "03", "06", "09", "12"];
    let expected: Vec<String> = steps.iter().map(|s| format!("u_{s}.vtu")).collect();
    assert_eq!(v["files"], json!(expected), "{v}");
    assert_eq!(v["vtu"], json!(expected));
    assert_eq!(v["vtk"], json!([]), "no legacy VTK");
    assert_eq!(v["bad"], 0, "snapshot values or times differ");
    let _ = std::fs::remove_dir_all(&dir);
}
