//! Seeded mutation fuzz of the bundled inputs through the `linpd` binary (issue #15): every
//! `data/*.json` scene (with the node file of a point-cloud scene) and `*.pipeline.json`
//! pipeline, and the level files (`level-<m>.mtx`,
//! `level-<m>.nodes.csv`) that `linpd coarsen` writes for the bundled pipelines, loaded through a
//! coarsened scene. Each case applies 1-3 mutations chosen by a seeded PRNG (JSON-aware ones on
//! the parsed document, byte-level ones on the serialized text and on the level files) and runs
//! the matching command: `validate` then `solve` (`run` for a scene with `dynamics`), or
//! `coarsen` for a pipeline.
//!
//! Every run is classified; the test fails on any panic, abort (a signal other than our timeout
//! kill), output of a failed run (the contract: an error writes no file), stray file (a lock, a
//! staging directory, anything beside the output), success without its main document, a
//! `result.json` whose positions or displacements are not all numbers (NaN or inf), error
//! without a message on stderr, or run over the resident-memory ceiling. Every failing case is
//! saved under `target/fuzz-failures/<seed>-<case>/` (inputs, `command.txt`, `stderr.txt`).
//!
//! Environment: `LINPD_FUZZ_SECS` (time budget, default 60; the assertion is on the counts of
//! failures, never on time), `LINPD_FUZZ_SEED` (default [`DEFAULT_SEED`]), `LINPD_FUZZ_CASE`
//! (run only that case of the seed, to reproduce it), `LINPD_FUZZ_VERBOSE` (print every run: its
//! mutations, class and last line of stderr). The runs are sequential (2-core machines).
//! Results of the documented runs: docs/robustness.md.

#![cfg(unix)]

use serde_json::{json, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const DEFAULT_SEED: u64 = 20_261_115;
const DEFAULT_SECS: u64 = 60;
/// Wall-clock limit of one run; the bundled scenes take at most about a second each.
const RUN_TIMEOUT: Duration = Duration::from_secs(20);
/// The memory guard's limit in the runs (`LINPD_MEMORY_GIB`): a mutated grid of billions of
/// nodes is rejected at validation instead of being allocated.
const MEMORY_GIB: &str = "2";
/// A run whose resident memory passes this is killed and counted `over_memory`: the guard let
/// through a run that needs more than twice its limit (and the machine is shared).
const RSS_LIMIT: u64 = 4 << 30;

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
enum Class {
    Panic,
    Abort,
    OutputFromFailedRun,
    StrayFile,
    SuccessWithoutResult,
    NonFiniteResult,
    SilentRejection,
    OverMemory,
    Hang,
    Timeout,
    OkRejected,
    OkSuccess,
}

impl Class {
    const ALL: [Class; 12] = [
        Class::Panic,
        Class::Abort,
        Class::OutputFromFailedRun,
        Class::StrayFile,
        Class::SuccessWithoutResult,
        Class::NonFiniteResult,
        Class::SilentRejection,
        Class::OverMemory,
        Class::Hang,
        Class::Timeout,
        Class::OkRejected,
        Class::OkSuccess,
    ];

    fn name(self) -> &'static str {
        match self {
            Class::Panic => "panic",
            Class::Abort => "abort",
            Class::OutputFromFailedRun => "output_from_failed_run",
            Class::StrayFile => "stray_file",
            Class::SuccessWithoutResult => "success_without_result",
            Class::NonFiniteResult => "non_finite_result",
            Class::SilentRejection => "rejected_without_message",
            Class::OverMemory => "over_memory",
            Class::Hang => "hang",
            Class::Timeout => "timeout",
            Class::OkRejected => "ok_rejected",
            Class::OkSuccess => "ok_success",
        }
    }

    /// A class the test fails on. Not `timeout`: a run killed at [`RUN_TIMEOUT`] while
    /// computing. The mutations make valid but large problems that no guard bounds in time
    /// (the memory guard bounds memory): a 3D grid of half the spacing (8x the nodes, 16x the
    /// CG work), a coarsening radius or tolerance that makes every local problem the whole
    /// body, `dynamics.steps` of 4294967297. Those are legitimate long runs, not hangs (each one
    /// of the documented runs was rerun to its end, docs/robustness.md); they are printed and
    /// saved like failures, for inspection. A run killed at the timeout having used little CPU
    /// (blocked: a deadlock, a wait on a lock or on input) is a `hang`, which fails.
    fn is_failure(self) -> bool {
        !matches!(self, Class::OkRejected | Class::OkSuccess | Class::Timeout)
    }

    /// Saved under target/fuzz-failures and listed at the end.
    fn is_saved(self) -> bool {
        self.is_failure() || self == Class::Timeout
    }
}

/// A case's files: (name, bytes), the main file first.
type Files = Vec<(String, Vec<u8>)>;

/// What a case's files are and which command runs them.
enum Kind {
    /// A scene file and the node file it reads, if any (`validate`, then `solve` or `run`).
    Scene { side: Vec<(String, Vec<u8>)> },
    /// A pipeline and the scene it names (`coarsen`).
    Pipeline { scene_file: String, scene: Value },
    /// A coarsened scene and its level files (`validate`, then `solve`).
    Level { mtx_file: String, mtx: Vec<u8>, csv_file: String, csv: Vec<u8> },
}

struct Input {
    /// Shown in the per-input counts, e.g. `coarsen-plate-2d/level-1`.
    label: String,
    /// The main file's name in the case directory.
    file: String,
    doc: Value,
    kind: Kind,
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().map(|s| s.trim().parse().unwrap_or_else(|_| panic!("{name}={s:?} is not a number")))
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Names in `dir`, sorted (empty when `dir` does not exist).
fn names(dir: &Path) -> BTreeSet<String> {
    match std::fs::read_dir(dir) {
        Ok(rd) => rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect(),
        Err(_) => BTreeSet::new(),
    }
}

/// The bundled scenes and pipelines, and the levels `linpd coarsen` writes for the pipelines
/// (into `root/levels`, without the pipelines' per-level solves).
fn inputs(root: &Path) -> Vec<Input> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(data_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    let mut out = Vec::new();
    for p in &paths {
        let file = p.file_name().unwrap().to_string_lossy().into_owned();
        let doc = read_json(p);
        if !file.ends_with(".pipeline.json") {
            // a point cloud's node file goes with its scene (and is mutated as bytes)
            let side = ["csv", "vtk"]
                .iter()
                .filter_map(|k| doc["nodes"][k].as_str())
                .map(|f| (f.to_string(), std::fs::read(data_dir().join(f)).unwrap()))
                .collect();
            if doc["nodes"]["csv"].is_string() {
                out.push(vtu_variant(root, &file, &doc));
            }
            out.push(Input { label: file.clone(), file, doc, kind: Kind::Scene { side } });
            continue;
        }
        let scene_file = doc["scene"].as_str().expect("a pipeline names its scene").to_string();
        let scene = read_json(&data_dir().join(&scene_file));
        // The levels: the pipeline without its per-level solves, into root/levels/<name>.
        let name = file.trim_end_matches(".pipeline.json").to_string();
        let src = root.join("levels-src").join(&name);
        std::fs::create_dir_all(&src).unwrap();
        let mut quick = doc.clone();
        quick["solve"] = json!(false);
        std::fs::write(src.join(&file), quick.to_string()).unwrap();
        std::fs::write(src.join(&scene_file), scene.to_string()).unwrap();
        let lv = root.join("levels").join(&name);
        let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
            .args(["coarsen".as_ref(), src.join(&file).as_os_str(), "--out".as_ref(), lv.as_os_str(), "-q".as_ref()])
            .output()
            .unwrap();
        assert!(o.status.success(), "linpd coarsen {file}: {}", String::from_utf8_lossy(&o.stderr));
        let mut levels: Vec<String> = names(&lv).into_iter().filter(|n| n.ends_with(".mtx")).collect();
        levels.sort();
        assert!(!levels.is_empty(), "linpd coarsen {file} wrote no level");
        for mtx_file in levels {
            let stem = mtx_file.trim_end_matches(".mtx").to_string();
            let csv_file = format!("{stem}.nodes.csv");
            let mut s = scene.clone();
            let obj = s.as_object_mut().unwrap();
            obj.remove("grid");
            obj.insert("model".into(), json!({"type": "coarsened", "moduli": mtx_file}));
            obj.insert("name".into(), json!(format!("{name}-{stem}")));
            // the level with the boundary-value problem the pipeline transferred to it
            // (`nodal` loads and `file` constraints read from the level's CSV files)
            let (forces, prescribed) = (format!("{stem}.forces.csv"), format!("{stem}.prescribed.csv"));
            let mut with_bvp = s.clone();
            with_bvp["constraints"] = json!([{"file": prescribed}]);
            with_bvp["loads"] = json!([{"type": "nodal", "file": forces}]);
            with_bvp["name"] = json!(format!("{name}-{stem}-bvp"));
            let side = [&mtx_file, &csv_file, &forces, &prescribed]
                .iter()
                .map(|f| (f.to_string(), std::fs::read(lv.join(f)).unwrap()))
                .collect();
            out.push(Input {
                label: format!("{name}/{stem} (pipeline BVP)"),
                file: "scene.json".into(),
                doc: with_bvp,
                kind: Kind::Scene { side },
            });
            out.push(Input {
                label: format!("{name}/{stem}"),
                file: "scene.json".into(),
                doc: s,
                kind: Kind::Level {
                    mtx: std::fs::read(lv.join(&mtx_file)).unwrap(),
                    csv: std::fs::read(lv.join(&csv_file)).unwrap(),
                    mtx_file,
                    csv_file,
                },
            });
        }
        out.push(Input { label: file.clone(), file, doc, kind: Kind::Pipeline { scene_file, scene } });
    }
    out
}

/// A point-cloud scene read from VTU instead of CSV: the `result.vtu` that `linpd solve` writes
/// for the scene (it carries the `volume` and `layer` point arrays) as its node file.
fn vtu_variant(root: &Path, file: &str, doc: &Value) -> Input {
    let src = root.join("vtu-src").join(file.trim_end_matches(".json"));
    std::fs::create_dir_all(&src).unwrap();
    let csv = doc["nodes"]["csv"].as_str().unwrap();
    std::fs::copy(data_dir().join(csv), src.join(csv)).unwrap();
    let mut quick = doc.clone();
    quick["output"] = json!({"plot": false});
    std::fs::write(src.join(file), quick.to_string()).unwrap();
    let out = src.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_linpd"))
        .args(["solve".as_ref(), src.join(file).as_os_str(), "--out".as_ref(), out.as_os_str(), "-q".as_ref()])
        .output()
        .unwrap();
    assert!(o.status.success(), "linpd solve {file}: {}", String::from_utf8_lossy(&o.stderr));
    let mut d = doc.clone();
    let nodes = d["nodes"].as_object_mut().unwrap();
    nodes.remove("csv");
    nodes.insert("vtk".into(), json!("nodes.vtu"));
    let side = vec![("nodes.vtu".to_string(), std::fs::read(out.join("result.vtu")).unwrap())];
    Input { label: format!("{file} (vtu nodes)"), file: file.to_string(), doc: d, kind: Kind::Scene { side } }
}

/// Keys and strings of every input: mutations draw names and enum values from it.
fn dictionary(inputs: &[Input]) -> (Vec<String>, Vec<String>) {
    fn walk(v: &Value, keys: &mut BTreeSet<String>, strings: &mut BTreeSet<String>) {
        match v {
            Value::Object(m) => {
                for (k, c) in m {
                    keys.insert(k.clone());
                    walk(c, keys, strings);
                }
            }
            Value::Array(a) => a.iter().for_each(|c| walk(c, keys, strings)),
            Value::String(s) => {
                strings.insert(s.clone());
            }
            _ => {}
        }
    }
    let (mut keys, mut strings) = (BTreeSet::new(), BTreeSet::new());
    for i in inputs {
        walk(&i.doc, &mut keys, &mut strings);
        if let Kind::Pipeline { scene, .. } = &i.kind {
            walk(scene, &mut keys, &mut strings);
        }
    }
    (keys.into_iter().collect(), strings.into_iter().collect())
}

// ---------------------------------------------------------------------------------------------
// Mutations

/// JSON pointers of every node of `v` (the root is "").
fn pointers(v: &Value, at: &str, out: &mut Vec<String>) {
    out.push(at.to_string());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                pointers(c, &format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")), out);
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                pointers(c, &format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// A random pointer of `doc` whose node satisfies `pred`, if any.
fn pick(rng: &mut fastrand::Rng, doc: &Value, pred: impl Fn(&Value) -> bool) -> Option<String> {
    let mut all = Vec::new();
    pointers(doc, "", &mut all);
    let ok: Vec<String> = all.into_iter().filter(|p| pred(doc.pointer(p).unwrap())).collect();
    if ok.is_empty() {
        None
    } else {
        Some(ok[rng.usize(..ok.len())].clone())
    }
}

fn special_number(rng: &mut fastrand::Rng, old: &Value) -> Value {
    let x = old.as_f64().unwrap_or(1.0);
    // Half of the time a nearby value: it gets past validation more often and reaches the
    // solvers (a grid 10x finer, a load twice as large).
    match rng.usize(..24) {
        0 => json!(0),
        1 => json!(-0.0),
        2 => json!(-1),
        3 => json!(1e-308),
        4 => json!(1e308),
        5 => json!(1e18),
        6 => json!(4_294_967_297u64),
        7 => json!(0.5),
        8 => json!(u64::MAX),
        9 => json!(i64::MIN),
        10 => json!(5e-324),
        11 => json!(rng.u8(1..4)),
        12 | 13 => json!(x * 10.0),
        14 | 15 => json!(x / 10.0),
        16 | 17 => json!(x * 2.0),
        18 | 19 => json!(x / 2.0),
        20 | 21 => json!(x + 1.0),
        _ => json!(-x),
    }
}

fn any_value(rng: &mut fastrand::Rng, strings: &[String]) -> Value {
    match rng.usize(..12) {
        0 => json!("x"),
        1 => json!(""),
        2 => Value::Null,
        3 => json!([]),
        4 => json!({}),
        5 => json!(true),
        6 => json!([0.0]),
        7 => json!({"fuzz": 1}),
        8 => json!("NaN"),
        9 => json!([[1.0, 0.0], [0.0, 1.0]]),
        10 => special_number(rng, &Value::Null),
        _ => json!(strings[rng.usize(..strings.len())]),
    }
}

/// One JSON-aware mutation of `doc`; returns what it did.
fn mutate_json(rng: &mut fastrand::Rng, doc: &mut Value, keys: &[String], strings: &[String]) -> String {
    for _ in 0..8 {
        let done = match rng.usize(..11) {
            // Replace a number.
            0..=2 => pick(rng, doc, Value::is_number).map(|p| {
                let node = doc.pointer_mut(&p).unwrap();
                *node = special_number(rng, node);
                format!("number {p} -> {node}")
            }),
            // Replace a value by another type (or another string of the inputs).
            3 => pick(rng, doc, |_| true).filter(|p| !p.is_empty()).map(|p| {
                let node = doc.pointer_mut(&p).unwrap();
                *node = any_value(rng, strings);
                format!("value {p} -> {node}")
            }),
            4 => pick(rng, doc, Value::is_string).map(|p| {
                let node = doc.pointer_mut(&p).unwrap();
                *node = json!(strings[rng.usize(..strings.len())]);
                format!("string {p} -> {node}")
            }),
            // Delete a key.
            5 => pick(rng, doc, |v| v.as_object().is_some_and(|m| !m.is_empty())).map(|p| {
                let m = doc.pointer_mut(&p).unwrap().as_object_mut().unwrap();
                let k = m.keys().nth(rng.usize(..m.len())).unwrap().clone();
                m.remove(&k);
                format!("delete {p}/{k}")
            }),
            // Add an unknown key, or a key of another place.
            6 => pick(rng, doc, Value::is_object).map(|p| {
                let k = if rng.bool() { "fuzz_unknown".to_string() } else { keys[rng.usize(..keys.len())].clone() };
                let v = any_value(rng, strings);
                let m = doc.pointer_mut(&p).unwrap().as_object_mut().unwrap();
                m.insert(k.clone(), v);
                format!("add {p}/{k}")
            }),
            // Duplicate an array element.
            7 => pick(rng, doc, |v| v.as_array().is_some_and(|a| !a.is_empty())).map(|p| {
                let a = doc.pointer_mut(&p).unwrap().as_array_mut().unwrap();
                let i = rng.usize(..a.len());
                let e = a[i].clone();
                a.insert(rng.usize(..=a.len()), e);
                format!("duplicate {p}/{i}")
            }),
            // Empty an array.
            8 => pick(rng, doc, |v| v.as_array().is_some_and(|a| !a.is_empty())).map(|p| {
                doc.pointer_mut(&p).unwrap().as_array_mut().unwrap().clear();
                format!("empty {p}")
            }),
            // Rename a key.
            9 => pick(rng, doc, |v| v.as_object().is_some_and(|m| !m.is_empty())).map(|p| {
                let m = doc.pointer_mut(&p).unwrap().as_object_mut().unwrap();
                let k = m.keys().nth(rng.usize(..m.len())).unwrap().clone();
                let new = match rng.usize(..3) {
                    0 => keys[rng.usize(..keys.len())].clone(),
                    1 => k.to_uppercase(),
                    _ => format!("{k}_"),
                };
                let v = m.remove(&k).unwrap();
                m.insert(new.clone(), v);
                format!("rename {p}/{k} -> {new}")
            }),
            // Replace a node by a copy of another node of the document.
            _ => {
                let (a, b) = (pick(rng, doc, |_| true), pick(rng, doc, |_| true));
                match (a, b) {
                    (Some(a), Some(b)) if !a.is_empty() => {
                        let v = doc.pointer(&b).unwrap().clone();
                        *doc.pointer_mut(&a).unwrap() = v;
                        Some(format!("splice {a} <- {b}"))
                    }
                    _ => None,
                }
            }
        };
        if let Some(d) = done {
            return d;
        }
    }
    *doc = any_value(rng, strings);
    "root replaced".into()
}

/// One byte-level mutation of `b`; returns what it did.
fn mutate_bytes(rng: &mut fastrand::Rng, b: &mut Vec<u8>) -> String {
    let n = b.len();
    if n == 0 {
        b.extend((0..rng.usize(1..16)).map(|_| rng.u8(..)));
        return "insert into empty".into();
    }
    // A range [start, start + len) inside `b`: mostly short, sometimes long.
    let range = |rng: &mut fastrand::Rng| {
        let start = rng.usize(..n);
        let max = [8, 64, 4096][rng.usize(..3)].min(n - start);
        (start, rng.usize(1..=max))
    };
    match rng.usize(..6) {
        0 => {
            let i = rng.usize(..n);
            b[i] ^= 1 << rng.u32(..8);
            format!("flip byte {i}")
        }
        1 => {
            let (s, l) = range(rng);
            b.drain(s..s + l);
            format!("delete {s}..{}", s + l)
        }
        2 => {
            let (s, l) = range(rng);
            let piece: Vec<u8> = b[s..s + l].to_vec();
            let at = rng.usize(..=n);
            b.splice(at..at, piece);
            format!("duplicate {s}..{} at {at}", s + l)
        }
        3 => {
            let at = rng.usize(..n);
            b.truncate(at);
            format!("truncate at {at}")
        }
        4 => {
            const ODD: [&[u8]; 9] =
                [b"\0", b"\x01", b"\x07", b"\x1b", b"\x7f", b"\r", "\u{feff}".as_bytes(), b"\xff\xfe", "é".as_bytes()];
            let at = rng.usize(..=n);
            let piece: Vec<u8> = (0..rng.usize(1..8))
                .flat_map(|_| if rng.bool() { vec![rng.u8(..)] } else { ODD[rng.usize(..ODD.len())].to_vec() })
                .collect();
            b.splice(at..at, piece);
            format!("insert bytes at {at}")
        }
        _ => {
            // Replace a run of digits by a huge or special number.
            let runs: Vec<(usize, usize)> = {
                let mut v = Vec::new();
                let mut i = 0;
                while i < n {
                    if b[i].is_ascii_digit() {
                        let s = i;
                        while i < n && b[i].is_ascii_digit() {
                            i += 1;
                        }
                        v.push((s, i));
                    } else {
                        i += 1;
                    }
                }
                v
            };
            if runs.is_empty() {
                b.truncate(n / 2);
                return "truncate at half (no digits)".into();
            }
            let (s, e) = runs[rng.usize(..runs.len())];
            let new: String = match rng.usize(..8) {
                0 => "9".repeat(rng.usize(20..400)),
                1 => "18446744073709551616".into(),
                2 => "4294967297".into(),
                3 => "1e999".into(),
                4 => "0".into(),
                5 => "-1".into(),
                6 => "nan".into(),
                _ => "inf".into(),
            };
            b.splice(s..e, new.bytes());
            format!("digits {s}..{e} -> {}", if new.len() > 24 { format!("{} digits", new.len()) } else { new })
        }
    }
}

/// The files of case `case` of `seed` and the mutations applied.
fn make_case(
    seed: u64,
    case: u64,
    inputs: &[Input],
    keys: &[String],
    strings: &[String],
) -> (usize, Files, Vec<String>) {
    let mut rng = fastrand::Rng::with_seed(seed ^ case.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let which = rng.usize(..inputs.len());
    let input = &inputs[which];
    // The files: (name, JSON document if one, bytes).
    let mut files: Vec<(String, Option<Value>, Vec<u8>)> =
        vec![(input.file.clone(), Some(input.doc.clone()), Vec::new())];
    match &input.kind {
        Kind::Scene { side } => files.extend(side.iter().map(|(n, b)| (n.clone(), None, b.clone()))),
        Kind::Pipeline { scene_file, scene } => files.push((scene_file.clone(), Some(scene.clone()), Vec::new())),
        Kind::Level { mtx_file, mtx, csv_file, csv } => {
            files.push((mtx_file.clone(), None, mtx.clone()));
            files.push((csv_file.clone(), None, csv.clone()));
        }
    }
    // The plan: (file, JSON-aware?), the main file half of the time. 1 mutation half of the
    // time (more cases get past validation), else 2 or 3.
    let plan: Vec<(usize, bool)> = (0..[1, 1, 1, 2, 2, 3][rng.usize(..6)])
        .map(|_| {
            let f = if files.len() == 1 || rng.usize(..10) < 5 { 0 } else { rng.usize(1..files.len()) };
            (f, files[f].1.is_some() && rng.usize(..10) < 8)
        })
        .collect();
    let mut log = Vec::new();
    for &(f, _) in plan.iter().filter(|p| p.1) {
        let d = mutate_json(&mut rng, files[f].1.as_mut().unwrap(), keys, strings);
        log.push(format!("{}: {d}", files[f].0));
    }
    for file in files.iter_mut() {
        if let Some(doc) = &file.1 {
            file.2 =
                if rng.bool() { serde_json::to_vec_pretty(doc).unwrap() } else { serde_json::to_vec(doc).unwrap() };
        }
    }
    for &(f, _) in plan.iter().filter(|p| !p.1) {
        let d = mutate_bytes(&mut rng, &mut files[f].2);
        log.push(format!("{}: {d}", files[f].0));
    }
    (which, files.into_iter().map(|(n, _, b)| (n, b)).collect(), log)
}

// ---------------------------------------------------------------------------------------------
// Runs

/// Resident memory of `pid` in bytes (0 when /proc does not tell).
fn rss(pid: u32) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/statm"))
        .ok()
        .and_then(|s| s.split_whitespace().nth(1).and_then(|p| p.parse::<u64>().ok()))
        .map_or(0, |pages| pages * 4096)
}

/// CPU time (user + system, all threads) of `pid` in seconds, if /proc tells (Linux; clock
/// ticks of 1/100 s, the value of `sysconf(_SC_CLK_TCK)` on Linux).
fn cpu_secs(pid: u32) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the `(comm)`: state is field 3, utime 14, stime 15.
    let rest: Vec<&str> = stat[stat.rfind(')')? + 1..].split_whitespace().collect();
    let ticks: u64 = rest.get(11)?.parse::<u64>().ok()? + rest.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

/// `v` is a number or a non-empty array of numbers (or of such arrays).
fn numbers(v: &Value) -> bool {
    match v {
        Value::Number(_) => true,
        Value::Array(a) => !a.is_empty() && a.iter().all(numbers),
        _ => false,
    }
}

struct Run {
    args: Vec<String>,
    class: Class,
    stderr: String,
    detail: String,
}

/// Runs `linpd args` in `dir` (the case directory, holding exactly `inputs`) and classifies it.
/// `main`: the document a successful run writes into `dir/out` (None for `validate`).
fn run(args: Vec<String>, dir: &Path, logs: &Path, inputs: &BTreeSet<String>, main: Option<&str>) -> Run {
    run_program(env!("CARGO_BIN_EXE_linpd"), RUN_TIMEOUT, args, dir, logs, inputs, main)
}

/// [`run`] of any program (the classifier's own test runs `sh`).
fn run_program(
    program: &str,
    timeout: Duration,
    args: Vec<String>,
    dir: &Path,
    logs: &Path,
    inputs: &BTreeSet<String>,
    main: Option<&str>,
) -> Run {
    let (out_log, err_log) = (logs.join("stdout"), logs.join("stderr"));
    let mut child = Command::new(program)
        .args(&args)
        .current_dir(dir)
        .env("LINPD_MEMORY_GIB", MEMORY_GIB)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_log).unwrap())
        .stderr(std::fs::File::create(&err_log).unwrap())
        .spawn()
        .expect("the linpd binary runs");
    let start = Instant::now();
    let mut killed = None;
    let mut cpu = None;
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if start.elapsed() > timeout {
            // Under a tenth of a core on average: blocked, not computing.
            cpu = cpu_secs(child.id());
            let busy = cpu.is_none_or(|c| c > 0.1 * start.elapsed().as_secs_f64());
            killed = Some(if busy { Class::Timeout } else { Class::Hang });
        } else if rss(child.id()) > RSS_LIMIT {
            killed = Some(Class::OverMemory);
        }
        if killed.is_some() {
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(if start.elapsed() < Duration::from_millis(100) { 2 } else { 10 }));
    };
    let stderr = String::from_utf8_lossy(&std::fs::read(&err_log).unwrap_or_default()).into_owned();
    let present = names(dir);
    let extra: Vec<&String> = present.difference(inputs).collect();
    let (class, detail) = if let Some(k) = killed {
        let cpu = cpu.map_or(String::new(), |c| format!(", {c:.1} s of CPU"));
        (k, format!("killed after {:.1} s{cpu}", start.elapsed().as_secs_f64()))
    } else if status.code() == Some(101) || stderr.contains("panicked") {
        (Class::Panic, format!("exit {status}"))
    } else if let Some(sig) = status.signal() {
        (Class::Abort, format!("signal {sig}"))
    } else if !status.success() {
        if !extra.is_empty() {
            (Class::OutputFromFailedRun, format!("left {extra:?}"))
        } else if stderr.trim().is_empty() {
            (Class::SilentRejection, format!("exit {status}, empty stderr"))
        } else {
            (Class::OkRejected, String::new())
        }
    } else {
        match main {
            None if extra.is_empty() => (Class::OkSuccess, String::new()),
            None => (Class::StrayFile, format!("validate left {extra:?}")),
            Some(m) => {
                let doc = std::fs::read_to_string(dir.join("out").join(m))
                    .ok()
                    .and_then(|d| serde_json::from_str::<Value>(&d).ok());
                if extra.iter().any(|e| e.as_str() != "out") {
                    (Class::StrayFile, format!("left {extra:?}"))
                } else if doc.is_none() {
                    (
                        Class::SuccessWithoutResult,
                        format!("no parsable out/{m}; out holds {:?}", names(&dir.join("out"))),
                    )
                } else if m == "result.json" && !["x", "u"].iter().all(|k| numbers(&doc.as_ref().unwrap()[k])) {
                    // serde_json writes a non-finite f64 as null.
                    (Class::NonFiniteResult, "result.json: x or u holds a non-number (null: NaN or inf)".into())
                } else {
                    (Class::OkSuccess, String::new())
                }
            }
        }
    };
    Run { args, class, stderr, detail }
}

/// Runs the commands of a case; the directory holds its files.
fn run_case(input: &Input, files: &Files, dir: &Path, logs: &Path) -> Vec<Run> {
    let names: BTreeSet<String> = files.iter().map(|f| f.0.clone()).collect();
    let main = input.file.clone();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<String>>();
    match input.kind {
        Kind::Pipeline { .. } => {
            vec![run(s(&["coarsen", &main, "--out", "out", "-q"]), dir, logs, &names, Some("summary.json"))]
        }
        Kind::Scene { .. } | Kind::Level { .. } => {
            let dynamics = serde_json::from_slice::<Value>(&files[0].1).is_ok_and(|v| v.get("dynamics").is_some());
            let (cmd, doc) = if dynamics { ("run", "history.json") } else { ("solve", "result.json") };
            let mut runs = vec![run(s(&["validate", &main]), dir, logs, &names, None)];
            let extra: Vec<&str> = if dynamics { vec!["-q"] } else { vec![] };
            let mut args = s(&[cmd, &main, "--out", "out"]);
            args.extend(s(&extra));
            runs.push(run(args, dir, logs, &names, Some(doc)));
            runs
        }
    }
}

/// Saves a failing case for reproduction: its files, the commands, their classes and stderr.
fn save_failure(dest: &Path, files: &Files, mutations: &[String], runs: &[Run]) {
    let _ = std::fs::remove_dir_all(dest);
    std::fs::create_dir_all(dest).unwrap();
    for (n, b) in files {
        std::fs::write(dest.join(n), b).unwrap();
    }
    let mut cmd = String::new();
    let mut err = String::new();
    for r in runs {
        cmd += &format!(
            "# {}{}\nLINPD_MEMORY_GIB={MEMORY_GIB} linpd {}\n",
            r.class.name(),
            if r.detail.is_empty() { String::new() } else { format!(" ({})", r.detail) },
            r.args.join(" ")
        );
        err += &format!("$ linpd {}\n{}\n", r.args.join(" "), r.stderr);
    }
    cmd += &format!("# mutations:\n{}\n", mutations.iter().map(|m| format!("#   {m}\n")).collect::<String>());
    std::fs::write(dest.join("command.txt"), cmd).unwrap();
    std::fs::write(dest.join("stderr.txt"), err).unwrap();
}

#[test]
fn mutation_fuzz_of_the_bundled_inputs() {
    let seed = env_u64("LINPD_FUZZ_SEED").unwrap_or(DEFAULT_SEED);
    let secs = env_u64("LINPD_FUZZ_SECS").unwrap_or(DEFAULT_SECS);
    let only = env_u64("LINPD_FUZZ_CASE");
    let verbose = std::env::var_os("LINPD_FUZZ_VERBOSE").is_some();
    println!("fuzz: seed {seed} (LINPD_FUZZ_SEED), {secs} s (LINPD_FUZZ_SECS)");

    let root = std::env::temp_dir().join(format!("linpd-fuzz-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let inputs = inputs(&root);
    let (keys, strings) = dictionary(&inputs);
    let (work, logs) = (root.join("work"), root.join("logs"));
    std::fs::create_dir_all(&work).unwrap();
    std::fs::create_dir_all(&logs).unwrap();
    let failures_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().unwrap().join("fuzz-failures");

    let mut per_class: BTreeMap<Class, u64> = BTreeMap::new();
    let mut per_input: BTreeMap<usize, (u64, BTreeMap<Class, u64>)> = BTreeMap::new();
    let (mut failed, mut timeouts): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    let mut validate_disagrees = 0u64;
    let (mut cases, mut runs_n) = (0u64, 0u64);
    let start = Instant::now();
    let mut case = only.unwrap_or(0);
    while (only.is_some() && cases == 0) || (only.is_none() && start.elapsed() < Duration::from_secs(secs)) {
        let (which, files, mutations) = make_case(seed, case, &inputs, &keys, &strings);
        let dir = work.join(case.to_string());
        std::fs::create_dir_all(&dir).unwrap();
        for (n, b) in &files {
            std::fs::write(dir.join(n), b).unwrap();
        }
        let mut runs = run_case(&inputs[which], &files, &dir, &logs);
        // Nothing may appear beside the case directory.
        let beside: Vec<String> = names(&work).into_iter().filter(|n| *n != case.to_string()).collect();
        if !beside.is_empty() {
            let last = runs.last_mut().unwrap();
            last.detail = format!("{}; beside the case: {beside:?}", last.detail);
            last.class = Class::StrayFile;
            for n in &beside {
                let p = work.join(n);
                let _ = std::fs::remove_dir_all(&p).or_else(|_| std::fs::remove_file(&p));
            }
        }
        if runs.len() == 2 && runs[0].class == Class::OkRejected && runs[1].class == Class::OkSuccess {
            validate_disagrees += 1;
        }
        let entry = per_input.entry(which).or_default();
        entry.0 += 1;
        for r in &runs {
            *per_class.entry(r.class).or_default() += 1;
            *entry.1.entry(r.class).or_default() += 1;
        }
        runs_n += runs.len() as u64;
        if verbose {
            for r in &runs {
                let first = r.stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("");
                println!("case {case} {} [{}] {}: {first}", inputs[which].label, mutations.join("; "), r.class.name());
            }
        }
        if runs.iter().any(|r| r.class.is_saved()) {
            let dest = failures_dir.join(format!("{seed}-{case}"));
            save_failure(&dest, &files, &mutations, &runs);
            for r in runs.iter().filter(|r| r.class.is_saved()) {
                let first = r.stderr.lines().find(|l| !l.trim().is_empty()).unwrap_or("").to_string();
                let list = if r.class.is_failure() { &mut failed } else { &mut timeouts };
                list.push(format!(
                    "case {case} ({}): {} `linpd {}` {}: {first}\n    saved in {}",
                    inputs[which].label,
                    r.class.name(),
                    r.args.join(" "),
                    r.detail,
                    dest.display()
                ));
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
        cases += 1;
        case += 1;
    }
    let _ = std::fs::remove_dir_all(&root);

    println!(
        "fuzz: seed {seed}: {cases} cases, {runs_n} runs in {:.0} s, {} inputs",
        start.elapsed().as_secs_f64(),
        inputs.len()
    );
    for c in Class::ALL {
        println!("  {:<26} {}", c.name(), per_class.get(&c).copied().unwrap_or(0));
    }
    println!("  (validate rejected but solve/run succeeded: {validate_disagrees} cases)");
    println!("per input (cases; runs per class):");
    for (i, input) in inputs.iter().enumerate() {
        let (n, by) = per_input.get(&i).cloned().unwrap_or_default();
        let by: Vec<String> = by.iter().map(|(c, k)| format!("{} {k}", c.name())).collect();
        println!("  {:<40} {n:>5}; {}", input.label, by.join(", "));
    }
    if !timeouts.is_empty() {
        println!("timeouts (busy when killed; see Class::is_failure):\n  {}", timeouts.join("\n  "));
    }
    assert!(cases > 0, "no case ran");
    assert!(failed.is_empty(), "{} failing runs (seed {seed}):\n  {}", failed.len(), failed.join("\n  "));
}

/// The CPU reading behind the `hang` class: it grows while this process computes (a busy loop
/// of up to 10 s of wall time, until 0.2 s of CPU are counted; the machine may be shared).
#[test]
fn cpu_secs_reads_the_cpu_time_of_a_process() {
    if !Path::new("/proc/self/stat").exists() {
        return; // not Linux: timeouts are never classified as hangs
    }
    let before = cpu_secs(std::process::id()).expect("/proc/<pid>/stat parses");
    let start = Instant::now();
    let mut x = 0u64;
    let mut after = before;
    while after - before < 0.2 && start.elapsed() < Duration::from_secs(10) {
        for _ in 0..1_000_000 {
            x = std::hint::black_box(x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1));
        }
        after = cpu_secs(std::process::id()).unwrap();
    }
    assert!(after - before >= 0.2, "{before} s then {after} s of CPU after {:?}", start.elapsed());
}

/// The classifier on runs of `sh` that do what a faulty linpd would: every class it must tell.
#[test]
fn the_classifier_tells_each_class() {
    let root = std::env::temp_dir().join(format!("linpd-fuzz-classifier-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (dir, logs) = (root.join("case"), root.join("logs"));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::create_dir_all(&logs).unwrap();
    std::fs::write(dir.join("scene.json"), "{}").unwrap();
    let inputs: BTreeSet<String> = ["scene.json".to_string()].into();
    let cases: [(&str, Option<&str>, Class); 12] = [
        ("echo 'error: bad' >&2; exit 1", Some("result.json"), Class::OkRejected),
        ("exit 1", Some("result.json"), Class::SilentRejection),
        ("echo 'thread main panicked at x' >&2; exit 101", Some("result.json"), Class::Panic),
        ("kill -ABRT $$", Some("result.json"), Class::Abort),
        ("mkdir out.tmp-1-2; echo 'error: bad' >&2; exit 1", Some("result.json"), Class::OutputFromFailedRun),
        ("mkdir out; echo '{}' > out/result.json; touch out.lock", Some("result.json"), Class::StrayFile),
        ("touch notes.txt", None, Class::StrayFile),
        ("mkdir out", Some("history.json"), Class::SuccessWithoutResult),
        (
            "mkdir out; echo '{\"x\": [0.0], \"u\": [null]}' > out/result.json",
            Some("result.json"),
            Class::NonFiniteResult,
        ),
        (
            "mkdir out; echo '{\"x\": [0.0], \"u\": [[1.0, 2.0]]}' > out/result.json",
            Some("result.json"),
            Class::OkSuccess,
        ),
        ("sleep 5", None, Class::Hang),
        ("while :; do :; done", None, Class::Timeout),
    ];
    for (script, main, class) in cases {
        let r = run_program("sh", Duration::from_secs(1), vec!["-c".into(), script.into()], &dir, &logs, &inputs, main);
        assert_eq!(r.class, class, "`{script}`: {}", r.detail);
        for n in names(&dir).difference(&inputs) {
            let p = dir.join(n);
            let _ = std::fs::remove_dir_all(&p).or_else(|_| std::fs::remove_file(&p));
        }
    }
    let _ = std::fs::remove_dir_all(&root);
}
