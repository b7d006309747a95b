//! The shape of `result.json` (every key path and the JSON type found there) for one scene of
//! each model, against the snapshot in tests/snapshots/result-schema.txt. A change of a key, a
//! type or of which fields a model reports fails here; a deliberate change rewrites the
//! snapshot with `LINPD_UPDATE_SNAPSHOTS=1 cargo test --release --test result_schema` and the
//! diff of that file is reviewed with the change (and docs/problem-format.md updated).

use linpd::core::NoProgress;
use linpd::problem::Problem;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::Path;

/// Every path of `v` with its type: `a.b[].c: number`; arrays contribute the union of their
/// elements' shapes under `[]`.
fn shape(v: &Value, path: &str, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            out.insert(format!("{path}: object"));
            for (k, x) in m {
                shape(x, &format!("{path}.{k}"), out);
            }
        }
        Value::Array(a) => {
            out.insert(format!("{path}: array"));
            for x in a {
                shape(x, &format!("{path}[]"), out);
            }
        }
        Value::Null => drop(out.insert(format!("{path}: null"))),
        Value::Bool(_) => drop(out.insert(format!("{path}: bool"))),
        Value::Number(_) => drop(out.insert(format!("{path}: number"))),
        Value::String(_) => drop(out.insert(format!("{path}: string"))),
    }
}

#[test]
fn result_json_keeps_its_shape() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut text = String::new();
    // a bond plate (2D), an LPS plate, the 1D blend, a bar (1D bond)
    for scene in ["plate-tension-2d.json", "lps-plate-2d.json", "blend-point-load.json", "bar-point-load.json"] {
        let p = Problem::from_path(&root.join("data").join(scene)).unwrap();
        let doc = p.solve(&NoProgress).unwrap().to_json();
        let mut paths = BTreeSet::new();
        shape(&doc, "", &mut paths);
        text += &format!("## {scene}\n");
        paths.iter().for_each(|l| text += &format!("{l}\n"));
    }
    let snapshot = root.join("tests/snapshots/result-schema.txt");
    if std::env::var_os("LINPD_UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(&snapshot, &text).unwrap();
    }
    let want = std::fs::read_to_string(&snapshot).unwrap_or_default();
    if want != text {
        let diff: Vec<String> = {
            let (a, b): (BTreeSet<&str>, BTreeSet<&str>) = (want.lines().collect(), text.lines().collect());
            a.difference(&b).map(|l| format!("- {l}")).chain(b.difference(&a).map(|l| format!("+ {l}"))).collect()
        };
        panic!("result.json's shape changed (snapshot {}):\n{}", snapshot.display(), diff.join("\n"));
    }
}
