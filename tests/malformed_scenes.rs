//! Malformed scenes: every one must be rejected with an error that names the JSON path of the
//! problem and says what is wrong, and none may panic inside linpd.
//!
//! The cases start from one small valid 1D scene (a bar like `data/bar-point-load.json`, 11
//! body nodes) or, for the 2D cases, a small valid plate, and break one thing each. The loop
//! runs every case and reports all failures at once.
//!
//! Set `LINPD_PRINT_ERRORS=1` to print every message (useful when reviewing the wording).

use linpd::problem::{CoarsenedModel, ModuliFile, Problem, ProblemError};
use serde_json::{json, Value};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// A valid 1D bar: nodes at 0, 0.1, ..., 1 plus two layer nodes per side, horizon 2h, both
/// layers clamped, a unit point load at the middle node.
fn base_1d() -> Value {
    json!({
        "name": "small-bar",
        "dimension": 1,
        "grid": {"min": [0.0], "max": [1.0], "spacing": 0.1, "layer": 0.2},
        "model": {"type": "bond", "horizon": 0.2, "partial_volume": false,
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                        {"region": {"box": {"min": [1.0], "max": [2.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "point", "at": [0.5], "force": [1.0]}],
        "solver": {"type": "auto"},
        "output": {"dir": "out/small-bar"}
    })
}

/// A valid 2D plate: 5x5 nodes, horizon 2h, plane stress, bottom row clamped, top row pulled.
fn base_2d() -> Value {
    json!({
        "name": "small-plate",
        "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": 0.25},
        "model": {"type": "bond", "horizon": 0.5, "plane": "stress",
                  "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "body", "region": {"box": {"min": [-1.0, 1.0], "max": [2.0, 2.0]}}, "density": [0.0, 1.0]}]
    })
}

/// A valid 3D cube (only parsed here): 3x3x3 nodes, horizon 2h.
fn base_3d() -> Value {
    json!({
        "name": "small-cube",
        "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": 0.5},
        "model": {"type": "bond", "horizon": 1.0,
                  "micromodulus": {"kernel": "constant", "modulus": 1.0}},
        "constraints": [{"region": "all", "displacement": {"value": [0.0, 0.0, 0.0]}, "components": [0, 1, 2]}]
    })
}

/// A small coarsened level on disk (written once per test process): 11 nodes at 0, 0.1, ..., 1,
/// volumes 0.1, `C = 1` between nodes one or two spacings apart. Returns the `.mtx` path.
fn coarse_moduli() -> &'static str {
    static PATH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PATH.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("linpd-malformed-coarse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let n = 11;
        let entries = (0..n)
            .flat_map(|i: usize| {
                (0..n).filter(move |&j: &usize| (1..=2).contains(&i.abs_diff(j))).map(move |j| (i, j, 1.0))
            })
            .collect();
        let m = ModuliFile {
            level: 1,
            dim: 1,
            positions: (0..n).map(|i| [0.1 * i as f64, 0.0, 0.0]).collect(),
            volumes: vec![0.1; n],
            level0: (0..n).map(|i| 2 * i).collect(),
            entries,
        };
        m.write(&dir.join("level-1")).unwrap();
        // A broken copy for the file-error case.
        std::fs::write(dir.join("bad.mtx"), "%%MatrixMarket matrix array real general\n").unwrap();
        dir.join("level-1.mtx").to_string_lossy().into_owned()
    })
}

/// A valid 1D coarsened scene on [`coarse_moduli`]: left end fixed, unit force at the right.
fn base_coarsened() -> Value {
    json!({
        "name": "small-coarse-bar",
        "dimension": 1,
        "model": {"type": "coarsened", "moduli": coarse_moduli()},
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "point", "at": [1.0], "force": [1.0]}]
    })
}

/// The coarsened base scene with `edit` applied.
fn ec(edit: impl FnOnce(&mut Value)) -> String {
    edited(base_coarsened, edit)
}

/// Where the error is expected.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Stage {
    /// `Problem::from_json_in` fails.
    Parse,
    /// `Problem::from_json_in` succeeds and `solve` fails with `ProblemError::Unsupported`.
    Solve,
}

struct Case {
    name: &'static str,
    text: String,
    stage: Stage,
    /// Must occur in `err.to_string()` (the JSON path, written as the message starts).
    path: &'static str,
    /// Must occur in `err.to_string()` as well.
    needle: &'static str,
    /// Extra check on the error value (e.g. the variant, line and column).
    check: Option<ErrorCheck>,
}

/// An extra check on a rejected scene's error and its message.
type ErrorCheck = fn(&ProblemError, &str) -> Result<(), String>;

/// Navigates a `/`-separated pointer (`model/micromodulus`) and returns the object there.
fn at<'a>(v: &'a mut Value, pointer: &str) -> &'a mut Value {
    let p = format!("/{pointer}");
    v.pointer_mut(&p).unwrap_or_else(|| panic!("test bug: no {p} in the base scene"))
}

/// The base scene with `edit` applied, as text.
fn edited(base: fn() -> Value, edit: impl FnOnce(&mut Value)) -> String {
    let mut v = base();
    edit(&mut v);
    serde_json::to_string_pretty(&v).unwrap()
}

/// Sets `key` in the object at `pointer` ("" for the document).
fn set(pointer: &'static str, key: &'static str, value: Value) -> impl FnOnce(&mut Value) {
    move |v: &mut Value| {
        let obj = if pointer.is_empty() { v } else { at(v, pointer) };
        obj.as_object_mut().expect("an object").insert(key.to_string(), value);
    }
}

/// Removes `key` from the object at `pointer`.
fn remove(pointer: &'static str, key: &'static str) -> impl FnOnce(&mut Value) {
    move |v: &mut Value| {
        let obj = if pointer.is_empty() { v } else { at(v, pointer) };
        assert!(obj.as_object_mut().expect("an object").remove(key).is_some(), "test bug: no key {key}");
    }
}

/// The 1D base scene with `edit` applied.
fn e1(edit: impl FnOnce(&mut Value)) -> String {
    edited(base_1d, edit)
}

/// The 2D base scene with `edit` applied.
fn e2(edit: impl FnOnce(&mut Value)) -> String {
    edited(base_2d, edit)
}

fn parse(name: &'static str, text: String, path: &'static str, needle: &'static str) -> Case {
    Case { name, text, stage: Stage::Parse, path, needle, check: None }
}

// A table of cases (one entry per malformed scene), not logic to split.
#[allow(clippy::too_many_lines)]
fn cases() -> Vec<Case> {
    let mm = "model/micromodulus";
    vec![
        // --- JSON syntax and shape (serde) ---
        Case {
            name: "syntax error (missing comma)",
            // Line 3 lacks the comma after the dimension: the parser trips on `"grid"` at column 3.
            text: "{\n  \"name\": \"x\",\n  \"dimension\": 1\n  \"grid\": {}\n}\n".into(),
            stage: Stage::Parse,
            path: ".",
            needle: "expected `,` or `}`",
            check: Some(|e, _| match e {
                ProblemError::Parse { line: 4, column: 3, .. } => Ok(()),
                ProblemError::Parse { line, column, .. } => {
                    Err(format!("expected line 4, column 3, got line {line}, column {column}"))
                }
                other => Err(format!("expected ProblemError::Parse, got {other:?}")),
            }),
        },
        Case {
            name: "syntax error inside an object (trailing comma)",
            text: "{\"name\": \"x\",\n \"dimension\": 1,\n \"grid\": {\"min\": [0.0],}}".into(),
            stage: Stage::Parse,
            path: "grid",
            needle: "trailing comma (line 3, column 24)",
            check: None,
        },
        parse(
            "unknown top-level key",
            e1(set("", "solvr", json!({}))),
            "solvr",
            "unknown field `solvr`, expected one of `name`",
        ),
        Case {
            name: "unknown nested key (kernal)",
            text: e1(set(mm, "kernal", json!("tent"))),
            stage: Stage::Parse,
            path: "model.micromodulus.kernal",
            needle: "unknown field `kernal`, expected one of `kernel`",
            // `model` is an internally tagged enum; the position must still be the key's own.
            check: Some(|e, text| match e {
                ProblemError::Parse { line, column, .. } => {
                    let l = text.lines().nth(line - 1).unwrap_or("");
                    let before = &l[..(*column).min(l.len())];
                    if before.contains("\"kernal\"") {
                        Ok(())
                    } else {
                        Err(format!("line {line}, column {column} is not at the key: {l:?}"))
                    }
                }
                other => Err(format!("expected ProblemError::Parse, got {other:?}")),
            }),
        },
        parse(
            "unknown key directly in model",
            e1(set("model", "horizn", json!(0.2))),
            "model.horizn",
            "unknown field `horizn`",
        ),
        parse(
            "missing key inside the tagged model (kernel)",
            e1(remove(mm, "kernel")),
            "model.micromodulus",
            "missing field `kernel`",
        ),
        parse(
            "wrong type inside the tagged model",
            e1(set("model", "partial_volume", json!("yes"))),
            "model.partial_volume",
            "expected true, false or \"ball\", got \"yes\"",
        ),
        parse(
            "wrong type inside a tagged load",
            e1(set("loads/0", "at", json!(0.5))),
            "loads[0].at",
            "invalid type: floating point `0.5`, expected a sequence",
        ),
        parse(
            "unknown key in grid",
            e1(set("grid", "spacings", json!(0.1))),
            "grid.spacings",
            "unknown field `spacings`",
        ),
        parse(
            "wrong type (spacing is a string)",
            e1(set("grid", "spacing", json!("0.1"))),
            "grid.spacing",
            "invalid type: string \"0.1\", expected f64",
        ),
        parse(
            "wrong type (dimension is negative)",
            e1(set("", "dimension", json!(-1))),
            "dimension",
            "invalid value: integer `-1`",
        ),
        parse("missing required key (grid.spacing)", e1(remove("grid", "spacing")), "grid", "missing field `spacing`"),
        parse(
            "missing required key (model.horizon)",
            e1(remove("model", "horizon")),
            "model",
            "missing field `horizon`",
        ),
        parse(
            "unknown model type",
            e1(set("model", "type", json!("state"))),
            "model.type",
            "unknown variant `state`, expected one of `bond`, `blend`, `ce`",
        ),
        parse(
            "unknown kernel",
            e1(set(mm, "kernel", json!("cubic"))),
            "model.micromodulus.kernel",
            "unknown variant `cubic`, expected one of `constant`",
        ),
        parse(
            "unknown solver",
            e1(set("solver", "type", json!("bicgstab"))),
            "solver.type",
            "unknown variant `bicgstab`",
        ),
        parse(
            "unknown region shape",
            e1(set("constraints/0", "region", json!({"circle": {"center": [0.0], "radius": 1.0}}))),
            "constraints[0].region",
            "unknown variant `circle`, expected one of `all`, `box`, `ball`, `cylinder`, `half_space`, `polygon`",
        ),
        // --- dimension and grid ---
        parse("dimension 4", e1(set("", "dimension", json!(4))), "dimension", "must be 1, 2 or 3, got 4"),
        parse("empty name", e1(set("", "name", json!("  "))), "name", "must not be empty"),
        parse(
            "grid.min/max length mismatch",
            e1(set("grid", "max", json!([1.0, 1.0]))),
            "grid.max",
            "expected 1 components",
        ),
        parse("grid max <= min", e1(set("grid", "max", json!([0.0]))), "grid.max", "must be greater than min"),
        parse(
            "spacing <= 0",
            e1(set("grid", "spacing", json!(0.0))),
            "grid.spacing",
            "must be a positive number, got 0e0",
        ),
        parse(
            "(max - min)/spacing not an integer",
            e1(set("grid", "spacing", json!(0.3))),
            "grid.spacing",
            "is not a positive integer",
        ),
        parse("negative layer", e1(set("grid", "layer", json!(-0.1))), "grid.layer", "must be >= 0, got -1e-1"),
        parse(
            "unknown placement",
            e1(set("grid", "placement", json!("corner"))),
            "grid.placement",
            "unknown variant `corner`",
        ),
        // --- horizon and plane ---
        parse("horizon <= 0", e1(set("model", "horizon", json!(-1.0))), "model.horizon", "must be > 0, got -1e0"),
        parse("horizon < spacing", e1(set("model", "horizon", json!(0.05))), "model.horizon", "gives no bonds"),
        parse("2D without plane", e2(remove("model", "plane")), "model.plane", "2D scenes need \"plane\""),
        parse(
            "2D horizon < sqrt(2) h",
            e2(set("model", "horizon", json!(0.3))),
            "model.horizon",
            "use horizon >= sqrt(2) * spacing",
        ),
        parse(
            "plane given in 1D",
            e1(set("model", "plane", json!("strain"))),
            "model.plane",
            "only meaningful in 2D (dimension is 1)",
        ),
        // --- micromodulus ---
        parse(
            "tabulated without table",
            e1(set(mm, "kernel", json!("tabulated"))),
            "model.micromodulus.table",
            "the tabulated kernel needs a table",
        ),
        parse(
            "tabulated with unequal lengths",
            e1(|v: &mut Value| {
                set(mm, "kernel", json!("tabulated"))(v);
                set(mm, "table", json!({"r_over_delta": [0.0, 0.5, 1.0], "g": [1.0, 0.0]}))(v);
            }),
            "model.micromodulus.table",
            "got 3 radii and 2 values",
        ),
        parse(
            "table for a non-tabulated kernel",
            e1(set(mm, "table", json!({"r_over_delta": [0.0, 1.0], "g": [1.0, 0.0]}))),
            "model.micromodulus.table",
            "only the tabulated kernel takes a table",
        ),
        parse(
            "gaussian with bad length",
            e1(|v: &mut Value| {
                set(mm, "kernel", json!("gaussian"))(v);
                set(mm, "length", json!(-0.1))(v);
            }),
            "model.micromodulus.length",
            "must be > 0, got -1e-1",
        ),
        parse(
            "length for a non-gaussian kernel",
            e1(set(mm, "length", json!(0.1))),
            "model.micromodulus.length",
            "only the gaussian kernel takes a length",
        ),
        parse(
            "normalize none without amplitude",
            e1(set(mm, "normalize", json!("none"))),
            "model.micromodulus.amplitude",
            "\"normalize\": \"none\" needs an explicit amplitude",
        ),
        parse(
            "amplitude together with modulus",
            e1(|v: &mut Value| {
                set(mm, "normalize", json!("none"))(v);
                set(mm, "amplitude", json!(2.0))(v);
            }),
            "model.micromodulus.modulus",
            "not both",
        ),
        parse(
            "amplitude without normalize none",
            e1(|v: &mut Value| {
                remove(mm, "modulus")(v);
                set(mm, "amplitude", json!(2.0))(v);
            }),
            "model.micromodulus.amplitude",
            "needs \"normalize\": \"none\"",
        ),
        parse(
            "amplitude <= 0",
            e1(|v: &mut Value| {
                remove(mm, "modulus")(v);
                set(mm, "normalize", json!("none"))(v);
                set(mm, "amplitude", json!(0.0))(v);
            }),
            "model.micromodulus.amplitude",
            "must be > 0, got 0",
        ),
        parse("modulus missing", e1(remove(mm, "modulus")), "model.micromodulus.modulus", "missing: the modulus"),
        parse(
            "modulus <= 0",
            e1(set(mm, "modulus", json!(-2.0))),
            "model.micromodulus.modulus",
            "must be > 0, got -2e0",
        ),
        // --- material ---
        parse(
            "phase modulus <= 0",
            e1(set("model", "material", json!({"phases": [{"region": "all", "modulus": 0.0}]}))),
            "model.material.phases[0].modulus",
            "must be > 0, got 0",
        ),
        parse(
            "phase box min > max",
            e1(set(
                "model",
                "material",
                json!({"phases": [{"region": {"union": ["all", {"box": {"min": [0.6], "max": [0.4]}}]}, "modulus": 2.0}]}),
            )),
            "model.material.phases[0].region.union[1].box",
            "min[0] = 6e-1 is greater than max[0] = 4e-1",
        ),
        parse(
            "defect with two shapes",
            e1(set(
                "model",
                "material",
                json!({"defects": [{"point": 0.55, "segment": [[0.0, 0.0], [1.0, 0.0]], "factor": 0.0}]}),
            )),
            "model.material.defects[0]",
            "give exactly one of",
        ),
        parse(
            "defect of the wrong dimension",
            e1(set("model", "material", json!({"defects": [{"segment": [[0.0, 0.0], [1.0, 0.0]], "factor": 0.0}]}))),
            "model.material.defects[0]",
            "a segment defect needs dimension 2, the scene has 1",
        ),
        parse(
            "defect with a negative factor",
            e1(set("model", "material", json!({"defects": [{"point": 0.55, "factor": -1.0}]}))),
            "model.material.defects[0].factor",
            "must be >= 0, got -1",
        ),
        parse(
            "plane defect with a zero normal",
            edited(
                base_3d,
                set(
                    "model",
                    "material",
                    json!({"defects": [{"plane": {"point": [0.5, 0.5, 0.5], "normal": [0.0, 0.0, 0.0]}, "factor": 0.0}]}),
                ),
            ),
            "model.material.defects[0].plane.normal",
            "must be nonzero",
        ),
        parse(
            "unknown bond rule",
            e1(set("model", "material", json!({"bond_rule": "median"}))),
            "model.material.bond_rule",
            "unknown variant `median`",
        ),
        // --- constraints ---
        parse(
            "constraint value of the wrong length",
            e1(set("constraints/0/displacement", "value", json!([0.0, 0.0]))),
            "constraints[0].displacement.value",
            "expected 1 components (the scene's dimension), got 2",
        ),
        parse(
            "gradient of the wrong shape",
            e1(set("constraints/1/displacement", "gradient", json!([[1.0, 0.0]]))),
            "constraints[1].displacement.gradient",
            "must be a 1x1 array of rows",
        ),
        parse(
            "components out of range",
            e1(set("constraints/0", "components", json!([1]))),
            "constraints[0].components",
            "must list components in 0..1, got [1]",
        ),
        parse(
            "constraint region with no node",
            e1(set("constraints/1", "region", json!({"box": {"min": [0.51], "max": [0.59]}}))),
            "constraints[1].region",
            "contains no node of the grid",
        ),
        parse(
            "constraint box of the wrong dimension inside a difference",
            e1(set(
                "constraints/0",
                "region",
                json!({"difference": ["all", {"box": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}]}),
            )),
            "constraints[0].region.difference[1].box.min",
            "expected 1 components",
        ),
        // --- loads ---
        parse(
            "point load not on a node",
            e1(set("loads/0", "at", json!([0.55]))),
            "loads[0].at",
            "point loads must sit on a node",
        ),
        parse(
            "point load force of the wrong length",
            e1(set("loads/0", "force", json!([1.0, 0.0]))),
            "loads[0].force",
            "expected 1 components",
        ),
        parse(
            "body load region with no node",
            e1(set(
                "",
                "loads",
                json!([{"type": "body", "region": {"box": {"min": [5.0], "max": [6.0]}}, "density": [1.0]}]),
            )),
            "loads[0].region",
            "contains no node of the grid",
        ),
        parse(
            "unknown load type",
            e1(set("loads/0", "type", json!("pressure"))),
            "loads[0].type",
            "unknown variant `pressure`, expected one of `point`, `body`, `resultant`",
        ),
        // --- solver ---
        parse(
            "solver rtol out of range",
            e1(set("", "solver", json!({"type": "cg", "rtol": 1.5}))),
            "solver.rtol",
            "must be in (0, 1), got 1.5e0",
        ),
        parse(
            "solver max_iter 0",
            e1(set("", "solver", json!({"type": "cg", "max_iter": 0}))),
            "solver.max_iter",
            "must be >= 1",
        ),
        parse(
            "matrix_free with cholesky",
            e1(set("", "solver", json!({"type": "cholesky", "matrix_free": true}))),
            "solver.matrix_free",
            "only the cg solver can run matrix-free",
        ),
        parse(
            "rtol with a direct solver",
            e1(set("", "solver", json!({"type": "lu", "rtol": 1e-8}))),
            "solver",
            "rtol and max_iter apply to the cg and gmres solvers only",
        ),
        // --- fails at solve time ---
        Case {
            name: "unconstrained body",
            text: e1(set("", "constraints", json!([]))),
            stage: Stage::Solve,
            path: "constraints",
            needle: "1 rigid motion(s) of a connected piece of 15 node(s) are not constrained",
            check: None,
        },
        Case {
            name: "1D defect exactly on a node isolates it",
            // Bonds touching the defect point count as crossing it: with factor 0 the node at
            // 0.5 loses every bond and floats.
            text: e1(set("model", "material", json!({"defects": [{"point": 0.5, "factor": 0.0}]}))),
            stage: Stage::Solve,
            path: "constraints",
            needle: "1 rigid motion(s) of a connected piece of 1 node(s) are not constrained (nodes [7])",
            check: None,
        },
        Case {
            name: "2D body pinned at one node only (rotation free)",
            text: e2(set(
                "",
                "constraints",
                json!([{"region": {"box": {"min": [0.0, 0.0], "max": [0.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}}]),
            )),
            stage: Stage::Solve,
            path: "constraints",
            needle: "1 rigid motion(s) of a connected piece of 25 node(s) are not constrained",
            check: None,
        },
        // --- lps scenes ---
        parse(
            "lps without shear modulus",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 2.0});
            }),
            "model.shear_modulus",
            "missing",
        ),
        parse(
            "lps with negative shear modulus",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 2.0, "shear_modulus": -1.0});
            }),
            "model.shear_modulus",
            "must be > 0",
        ),
        parse(
            "lps with zero bulk modulus",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 0.0, "shear_modulus": 1.0});
            }),
            "model.bulk_modulus",
            "must be > 0",
        ),
        parse(
            "lps with a micromodulus",
            e2(|v| {
                v["model"]["type"] = json!("lps");
                v["model"]["bulk_modulus"] = json!(2.0);
                v["model"]["shear_modulus"] = json!(1.0);
            }),
            "model.micromodulus",
            "not a key of lps models (only bond, blend and ce models take it)",
        ),
        parse(
            "lps in 1D",
            e1(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.2, "bulk_modulus": 2.0, "shear_modulus": 1.0});
            }),
            "dimension",
            "2D or 3D",
        ),
        parse(
            "lps horizon below the spacing",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.1, "plane": "strain", "bulk_modulus": 2.0, "shear_modulus": 1.0});
            }),
            "model.horizon",
            "gives no bonds (the horizon must be at least one spacing)",
        ),
        parse(
            "bulk modulus on a bond model",
            e1(|v| {
                v["model"]["bulk_modulus"] = json!(2.0);
            }),
            "model.bulk_modulus",
            "only lps models",
        ),
        parse(
            "bond model without micromodulus",
            e1(|v| {
                v["model"].as_object_mut().unwrap().remove("micromodulus");
            }),
            "model.micromodulus",
            "missing",
        ),
        // --- blend and ce scenes ---
        parse(
            "blend in 2D",
            e2(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["regions"] = json!([0.1, 0.2, 0.3, 0.4]);
                v["model"]["blending"] = json!("cubic");
                v["model"].as_object_mut().unwrap().remove("plane");
            }),
            "dimension",
            "blend models are 1D",
        ),
        parse(
            "blend without regions",
            e1(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending"] = json!("cubic");
                v["grid"]["layer"] = json!(0.0);
                v["constraints"] = json!([{"region": {"box": {"min": [0.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                                          {"region": {"box": {"min": [1.0], "max": [1.0]}}, "displacement": {"value": [0.0]}}]);
            }),
            "model.regions",
            "missing",
        ),
        parse(
            "blend regions not ordered",
            e1(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending"] = json!("linear");
                v["model"]["regions"] = json!([0.3, 0.2, 0.6, 0.8]);
                v["grid"]["layer"] = json!(0.0);
                v["constraints"] = json!([{"region": {"box": {"min": [0.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                                          {"region": {"box": {"min": [1.0], "max": [1.0]}}, "displacement": {"value": [0.0]}}]);
            }),
            "model.regions",
            "0 < L1 < L2 < L3 < L4",
        ),
        parse(
            "blend with a layer",
            e1(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending"] = json!("linear");
                v["model"]["regions"] = json!([0.2, 0.3, 0.6, 0.8]);
            }),
            "grid.layer",
            "no layer",
        ),
        parse(
            "blend regions key on a bond model",
            e1(|v| {
                v["model"]["regions"] = json!([0.2, 0.3, 0.6, 0.8]);
            }),
            "model.regions",
            "only blend models",
        ),
        parse(
            "blend with a cg solver",
            e1(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending"] = json!("linear");
                v["model"]["regions"] = json!([0.2, 0.3, 0.6, 0.8]);
                v["grid"]["layer"] = json!(0.0);
                v["solver"] = json!({"type": "cg"});
                v["constraints"] = json!([{"region": {"box": {"min": [0.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                                          {"region": {"box": {"min": [1.0], "max": [1.0]}}, "displacement": {"value": [0.0]}}]);
            }),
            "solver.type",
            "unsymmetric",
        ),
        parse(
            "preconditioner on a direct solver",
            e1(set("", "solver", json!({"type": "cholesky", "preconditioner": "jacobi"}))),
            "solver.preconditioner",
            "only the cg and gmres solvers take a preconditioner",
        ),
        Case {
            name: "unknown preconditioner",
            text: e1(set("", "solver", json!({"type": "cg", "preconditioner": "amg"}))),
            stage: Stage::Parse,
            path: "solver.preconditioner",
            needle: "unknown variant `amg`, expected `jacobi` or `multigrid`",
            // a read error at the value, like every enumerated key (issue #51: the names come
            // from the preconditioner registry, checked while the scene is read)
            check: Some(|e, text| match e {
                ProblemError::Parse { line, .. } if text.lines().nth(line - 1).is_some_and(|l| l.contains("amg")) => {
                    Ok(())
                }
                other => Err(format!("expected a read error on the line of \"amg\", got {other:?}")),
            }),
        },
        parse(
            // the model's refusal comes before the solver section's own error (issue #51: the
            // section is validated before the model, its error reported after the model's)
            "matrix_free on a 1D blend with lu",
            e1(|v| {
                v["model"] = json!({"type": "blend", "horizon": 0.2, "regions": [0.2, 0.4, 0.6, 0.8],
                                    "blending": "linear",
                                    "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0}});
                v["grid"] = json!({"min": [0.0], "max": [1.0], "spacing": 0.05});
                v["solver"] = json!({"type": "lu", "matrix_free": true});
            }),
            "solver.matrix_free",
            "blend",
        ),
        // --- each model type owns its keys (models/registry.rs): a key of another model type is an error ---
        parse(
            "lps with a blend key (hog)",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 2.0,
                                    "shear_modulus": 1.0, "hog": true});
            }),
            "model.hog",
            "not a key of lps models (only blend models take it)",
        ),
        parse(
            "lps with blending, regions and ce_spacing",
            e2(|v| {
                v["model"] = json!({"type": "lps", "horizon": 0.5, "plane": "strain", "bulk_modulus": 2.0,
                                    "shear_modulus": 1.0, "regions": [0.1, 0.2, 0.3, 0.4], "blending": "linear",
                                    "ce_spacing": 0.1});
            }),
            "model.blending",
            "not a key of lps models",
        ),
        parse(
            "ce with a blending value",
            e1(|v| {
                v["model"]["type"] = json!("ce");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending_value"] = json!(0.3);
            }),
            "model.blending_value",
            "not a key of ce models (only blend models take it)",
        ),
        parse(
            "ce with a blending table",
            e1(|v| {
                v["model"]["type"] = json!("ce");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["blending_table"] = json!({"s": [0.0, 1.0], "beta": [0.0, 1.0]});
            }),
            "model.blending_table",
            "not a key of ce models",
        ),
        parse(
            "blend with a plane",
            e1(|v| {
                v["model"]["type"] = json!("blend");
                v["model"].as_object_mut().unwrap().remove("partial_volume");
                v["model"]["plane"] = json!("stress");
            }),
            "model.plane",
            "not a key of blend models (only bond and lps models take it)",
        ),
        // --- added with the struct-based model/load mirror and the size guard ---
        parse(
            "point load with a body-load key",
            e1(|v| {
                v["loads"][0]["density"] = json!([1.0]);
            }),
            "loads[0].density",
            "not a key of a point load",
        ),
        parse(
            "body load without density",
            e1(|v| {
                v["loads"] = json!([{"type": "body", "region": "all"}]);
            }),
            "loads[0].density",
            "missing",
        ),
        parse(
            "operator too large for the machine",
            e1(|v| {
                // 401^3 nodes with 4,168 bonds each: the homogeneous stencil stores no bonds and
                // its multigrid (the geometric level) no fine bond graph, but the solve's
                // vectors and the outputs (~120 GB) do not fit
                v["dimension"] = json!(3);
                v["grid"] = json!({"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0], "spacing": 0.0025});
                v["model"]["horizon"] = json!(0.025);
                v["constraints"] = json!([]);
                v["loads"] = json!([]);
            }),
            "model.horizon",
            "GiB available",
        ),
        // --- grid and horizon are optional in the mirror, required by lattice models ---
        parse("bond model without a grid", e1(remove("", "grid")), "grid", "required for model type bond"),
        parse(
            "bond model with a moduli file",
            e1(set("model", "moduli", json!("level-1.mtx"))),
            "model.moduli",
            "only coarsened models",
        ),
        // --- coarsened scenes ---
        parse(
            "coarsened: moduli file missing",
            ec(set("model", "moduli", json!("/nonexistent/level-1.mtx"))),
            "model.moduli",
            "/nonexistent/level-1.mtx: cannot read",
        ),
        parse(
            "coarsened: relative moduli path resolved against the scene directory",
            ec(set("model", "moduli", json!("no-such-level.mtx"))),
            "model.moduli",
            "./no-such-level.mtx: cannot read",
        ),
        parse(
            "coarsened: moduli key missing",
            ec(remove("model", "moduli")),
            "model.moduli",
            "missing: the Matrix Market file",
        ),
        parse(
            "coarsened: malformed moduli file",
            ec(|v| v["model"]["moduli"] = json!(coarse_moduli().replace("level-1.mtx", "bad.mtx"))),
            "model.moduli",
            "bad.mtx, line 1: expected the banner",
        ),
        parse(
            "coarsened: dimension differs from the file",
            ec(set("", "dimension", json!(2))),
            "dimension",
            "the scene has dimension 2 but the moduli file",
        ),
        parse(
            "coarsened: grid given",
            ec(set("", "grid", json!({"min": [0.0], "max": [1.0], "spacing": 0.1}))),
            "grid",
            "not used by a coarsened model (its nodes come from",
        ),
        parse(
            "coarsened: horizon given",
            ec(set("model", "horizon", json!(0.2))),
            "model.horizon",
            "not a key of coarsened models",
        ),
        parse(
            "coarsened: micromodulus given",
            ec(set("model", "micromodulus", json!({"kernel": "constant", "modulus": 1.0}))),
            "model.micromodulus",
            "not a key of coarsened models",
        ),
        parse(
            "coarsened: bulk modulus given",
            ec(set("model", "bulk_modulus", json!(1.0))),
            "model.bulk_modulus",
            "not a key of coarsened models",
        ),
        parse(
            "coarsened: point load off the nodes",
            ec(|v| v["loads"] = json!([{"type": "point", "at": [0.55], "force": [1.0]}])),
            "loads[0].at",
            "point loads must sit on a node",
        ),
        parse(
            "coarsened: constraint region without nodes",
            ec(|v| v["constraints"][0]["region"] = json!({"box": {"min": [2.0], "max": [3.0]}})),
            "constraints[0].region",
            "contains no node of the coarsened level",
        ),
        Case {
            name: "coarsened: unconstrained body",
            text: ec(|v| v["constraints"] = json!([])),
            stage: Stage::Solve,
            path: "constraints",
            needle: "1 rigid motion(s) of a connected piece of 11 node(s) are not constrained",
            check: None,
        },
    ]
}

/// Runs one case; `Err` describes how it failed.
fn run(case: &Case) -> Result<String, String> {
    let outcome = catch_unwind(AssertUnwindSafe(|| -> Result<ProblemError, String> {
        match (Problem::from_json_in(&case.text, std::path::Path::new(".")), case.stage) {
            (Err(e), Stage::Parse) => Ok(e),
            (Err(e), Stage::Solve) => Err(format!("expected to parse, got: {e}")),
            (Ok(_), Stage::Parse) => Err("the scene was accepted".into()),
            (Ok(p), Stage::Solve) => match p.solve(&linpd::core::NoProgress) {
                Err(e @ ProblemError::Unsupported(_)) => Ok(e),
                Err(e) => Err(format!("expected ProblemError::Unsupported, got {e:?}")),
                Ok(_) => Err("the scene was solved".into()),
            },
        }
    }));
    let err = match outcome {
        Ok(r) => r?,
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            return Err(format!("panicked: {msg}"));
        }
    };
    let text = err.to_string();
    // The path starts the message: "grid.spacing: ...", "." for the document, "constraints: "
    // for unsupported bodies.
    if !text.starts_with(&format!("{}: ", case.path)) {
        return Err(format!("path `{}` not in: {text}", case.path));
    }
    if !text.contains(case.needle) {
        return Err(format!("`{}` not in: {text}", case.needle));
    }
    if let Some(check) = case.check {
        check(&err, &case.text).map_err(|m| format!("{m} ({text})"))?;
    }
    Ok(text)
}

#[test]
fn base_scenes_are_valid_and_solve() {
    for (name, base) in [("1D", base_1d as fn() -> Value), ("2D", base_2d), ("coarsened", base_coarsened)] {
        let p = Problem::from_json_in(&base().to_string(), std::path::Path::new("."))
            .unwrap_or_else(|e| panic!("{name} base scene: {e}"));
        let s = p.solve(&linpd::core::NoProgress).unwrap_or_else(|e| panic!("{name} base scene: {e}"));
        assert!(s.report.rel_residual < 1e-10, "{name}: residual {}", s.report.rel_residual);
    }
}

#[test]
fn coarsened_scenes_are_problems_without_a_lattice() {
    let p = Problem::from_json(&base_coarsened().to_string()).unwrap();
    assert!(p.model().downcast::<CoarsenedModel>().is_some());
    assert!(p.grid().is_none());
    assert_eq!(p.model().name(), "coarsened");
    // Lattice-only operations say why they cannot run.
    let e = p.operator().unwrap_err().to_string();
    assert!(e.starts_with("model.type: a bond model is needed here, the scene has coarsened"), "{e}");
}

#[test]
fn malformed_scenes_name_the_path_and_the_reason() {
    let print = std::env::var_os("LINPD_PRINT_ERRORS").is_some();
    let cases = cases();
    assert!(cases.len() >= 24);
    let mut failures = Vec::new();
    for case in &cases {
        match run(case) {
            Ok(text) if print => eprintln!("ok   {:<55} {text}", case.name),
            Ok(_) => {}
            Err(why) => {
                if print {
                    eprintln!("FAIL {:<55} {why}", case.name);
                }
                failures.push(format!("{}: {why}", case.name));
            }
        }
    }
    assert!(failures.is_empty(), "{} of {} cases failed:\n  {}", failures.len(), cases.len(), failures.join("\n  "));
}
