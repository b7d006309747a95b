//! The model x capability matrix: every model of the scene layer (crates/linpd-problem/src/models)
//! under every command (validate, solve, export, rows, coarsen, run, the matrix-free solver)
//! either runs or is refused with the typed [`ProblemError::Unavailable`] naming the capability,
//! and which of the two agrees with what the model says it can do
//! ([`linpd::problem::SceneModel::lacks`]). A refusal of any other kind, a panic, or a command
//! that runs where the model says it cannot, fails the test.
//!
//! Also: a new model type is one module plus one registry entry. [`ScaledBond`] below is a
//! whole model type defined in this file (its keys, validation, build and fields), registered
//! with `Registry::default().with(..)`; nothing else in linpd changes for it.

use linpd::core::progress::Progress;
use linpd::core::{AssembledModel, DofMap, Material, NoProgress};
use linpd::problem::models::registry::{struct_fields, Context, Validated};
use linpd::problem::models::{Purpose, System};
use linpd::problem::raw::{RawMicromodulus, RawPlane};
use linpd::problem::Commands;
use linpd::problem::{
    level0_model, Capability, ModelType, ModuliFile, Nodes, Problem, ProblemError, Registry, SceneModel, Solution,
};
use serde::Deserialize;
use serde_json::{json, Value};
use std::any::Any;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn plate(model: Value) -> Value {
    json!({
        "name": "plate",
        "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": 0.125, "layer": {"y-": 0.25}},
        "model": model,
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0], "max": [2.0, 0.0]}}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "body", "region": {"box": {"min": [-1.0, 0.9], "max": [2.0, 2.0]}}, "density": [0.0, 1.0]}],
        "output": {"plot": false}
    })
}

fn bond_keys() -> Value {
    json!({"type": "bond", "horizon": 0.3, "plane": "stress",
           "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0}})
}

fn bar(model: Value) -> Value {
    json!({
        "name": "bar",
        "dimension": 1,
        "grid": {"min": [0.0], "max": [1.0], "spacing": 0.0125},
        "model": model,
        "constraints": [{"region": {"box": {"min": [-1.0], "max": [0.0]}}, "displacement": {"value": [0.0]}},
                        {"region": {"box": {"min": [1.0], "max": [2.0]}}, "displacement": {"value": [0.0]}}],
        "loads": [{"type": "point", "at": [0.5], "force": [1.0]}],
        "output": {"plot": false}
    })
}

/// A directory of this test's files (a point cloud, a coarsened level).
fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-scene-models-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// One scene per model of the scene layer.
fn scenes() -> Vec<(&'static str, Value)> {
    let dir = scratch();
    // the plate's nodes as a point cloud
    let mut csv = String::from("x,y,volume\n");
    for j in 0..9 {
        for i in 0..9 {
            csv += &format!("{},{},{}\n", 0.125 * i as f64, 0.125 * j as f64, 0.125f64.powi(2));
        }
    }
    std::fs::write(dir.join("plate.csv"), csv).unwrap();
    let mut cloud = plate(json!({"type": "bond", "horizon": 0.3, "plane": "stress",
        "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "continuum"}}));
    let o = cloud.as_object_mut().unwrap();
    o.remove("grid");
    o.insert("nodes".into(), json!({"csv": dir.join("plate.csv")}));
    // a coarsened level: every other node of a 1D bar, C = 1 one and two spacings apart
    let n = 11;
    let level = ModuliFile {
        level: 1,
        dim: 1,
        positions: (0..n).map(|i| [0.1 * i as f64, 0.0, 0.0]).collect(),
        volumes: vec![0.1; n],
        level0: (0..n).map(|i| 2 * i).collect(),
        entries: (0..n)
            .flat_map(|i: usize| {
                (0..n).filter(move |&j: &usize| (1..=2).contains(&i.abs_diff(j))).map(move |j| (i, j, 1.0))
            })
            .collect(),
    };
    level.write(&dir.join("level-1")).unwrap();
    let mut coarsened = bar(json!({"type": "coarsened", "moduli": dir.join("level-1.mtx")}));
    coarsened.as_object_mut().unwrap().remove("grid");
    let mut blend = bond_keys();
    blend["pd_regions"] = json!([{"box": {"min": [0.25, 0.25], "max": [0.75, 0.75]}}]);
    blend["transition"] = json!(0.25);
    let mm = json!({"kernel": "constant", "modulus": 1.0});
    vec![
        ("bond", plate(bond_keys())),
        ("bond (point cloud)", cloud),
        ("bond with pd_regions", plate(blend)),
        (
            "lps",
            plate(json!({"type": "lps", "horizon": 0.3, "plane": "stress", "bulk_modulus": 1.0, "shear_modulus": 0.6})),
        ),
        (
            "blend",
            bar(json!({"type": "blend", "horizon": 0.05, "micromodulus": mm,
                             "regions": [0.2, 0.4, 0.6, 0.8], "blending": "linear"})),
        ),
        ("ce", bar(json!({"type": "ce", "horizon": 0.05, "micromodulus": mm}))),
        ("coarsened", coarsened),
    ]
}

/// What a command did: ran, or was refused for `Capability`.
#[derive(Debug, PartialEq)]
enum Outcome {
    Ran,
    Refused(Capability),
}

fn outcome<T>(r: Result<T, ProblemError>) -> Result<Outcome, String> {
    match r {
        Ok(_) => Ok(Outcome::Ran),
        Err(ProblemError::Unavailable { capability, ref reason, .. }) if !reason.is_empty() => {
            Ok(Outcome::Refused(capability))
        }
        Err(e) => Err(e.to_string()),
    }
}

/// Runs the command of `capability` on the scene `v`.
fn command(v: &Value, capability: Capability) -> Result<Outcome, String> {
    let parse = |v: &Value| outcome(Problem::from_json(&v.to_string()));
    let p = || Problem::from_json(&v.to_string()).map_err(|e| e.to_string());
    match capability {
        Capability::StaticSolve => outcome(p()?.solve(&NoProgress)),
        Capability::Export => outcome(p()?.reduced_system(&NoProgress)),
        Capability::BlockRows => outcome(p()?.row_system()),
        Capability::Coarsen => outcome(level0_model(&p()?)),
        Capability::MatrixFree => {
            let mut v = v.clone();
            v["solver"] = json!({"type": "cg", "matrix_free": true});
            match parse(&v)? {
                Outcome::Ran => outcome(Problem::from_json(&v.to_string()).unwrap().solve(&NoProgress)),
                refused => Ok(refused),
            }
        }
        Capability::Dynamics => {
            let mut v = v.clone();
            v["dynamics"] = json!({"dt_safety": 0.5, "steps": 4, "density": 1.0});
            match parse(&v)? {
                Outcome::Ran => outcome(Problem::from_json(&v.to_string()).unwrap().run_dynamics(&NoProgress)),
                refused => Ok(refused),
            }
        }
        other => Err(format!("no command for {other:?}")),
    }
}

#[test]
fn every_model_runs_or_refuses_every_command_by_name() {
    let mut table = String::from("model                  ");
    for c in Capability::ALL {
        table += &format!(" {:>11}", format!("{c:?}"));
    }
    let mut failures = Vec::new();
    let mut refusals = 0;
    for (name, v) in scenes() {
        let p = Problem::from_json(&v.to_string()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(p.model().describe().split(' ').next(), name.split(' ').next(), "{name}");
        table += &format!("\n{name:<23}");
        for c in Capability::ALL {
            let can = p.model().can(c);
            let got = command(&v, c);
            let cell = match (&got, can) {
                (Ok(Outcome::Ran), true) => "runs",
                (Ok(Outcome::Refused(r)), false) if *r == c => {
                    refusals += 1;
                    "refused"
                }
                _ => {
                    failures.push(format!("{name} x {c:?}: the model says can = {can}, the command gave {got:?}"));
                    "WRONG"
                }
            };
            table += &format!(" {cell:>11}");
        }
    }
    println!("{table}");
    assert!(failures.is_empty(), "{}\n{table}", failures.join("\n"));
    // the matrix is not trivial: 17 refusals (docs/extending.md lists them; lps lattices run
    // matrix-free since issue #35)
    assert_eq!(refusals, 17, "{table}");
}

/// `linpd coarsen` on a `pd_regions` scene is refused by name (it coarsened the plain bond
/// model before, silently).
#[test]
fn coarsening_a_blended_scene_is_refused_by_name() {
    let mut keys = bond_keys();
    keys["pd_regions"] = json!("auto");
    let p = Problem::from_json(&plate(keys).to_string()).unwrap();
    let e = level0_model(&p).unwrap_err();
    assert!(matches!(e, ProblemError::Unavailable { capability: Capability::Coarsen, .. }), "{e}");
    let m = e.to_string();
    assert!(m.starts_with("model.type: coarsening is not available for bond with pd_regions"), "{m}");
}

// --- a new model type in one module -------------------------------------------------------

/// The keys of `"type": "scaled_bond"`: a bond model whose stiffness is `scale` times the bond
/// model's (its own key, `scale`, beside the bond keys it reads).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScaledBond {
    #[serde(rename = "type")]
    _kind: String,
    horizon: f64,
    plane: Option<RawPlane>,
    micromodulus: Option<RawMicromodulus>,
    scale: f64,
}

struct ScaledBondType;
static SCALED_BOND: ScaledBondType = ScaledBondType;

impl ModelType for ScaledBondType {
    fn name(&self) -> &'static str {
        "scaled_bond"
    }
    fn fields(&self) -> &'static [&'static str] {
        struct_fields::<RawScaledBond>()
    }
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError> {
        let raw: RawScaledBond = cx.model_keys()?;
        if !(raw.scale > 0.0) {
            return Err(ProblemError::invalid("model.scale", format!("must be > 0, got {:e}", raw.scale)));
        }
        let grid = cx.lattice(raw.horizon, linpd::problem::memory::Path::BondAssembled)?;
        let micromodulus = cx.micromodulus(raw.horizon, raw.micromodulus.as_ref(), raw.plane, false)?;
        let op = linpd::bond::BondOperator::on_grid(&grid, raw.horizon, &micromodulus, &Material::default())
            .map_err(|e| ProblemError::invalid("model", e.to_string()))?;
        let model = ScaledBond { op, horizon: raw.horizon, scale: raw.scale };
        Ok(Validated { nodes: Nodes::Lattice(grid), model: Box::new(model) })
    }
}

#[derive(Debug)]
struct ScaledBond {
    op: linpd::bond::BondOperator,
    horizon: f64,
    scale: f64,
}

impl SceneModel for ScaledBond {
    fn name(&self) -> &'static str {
        "scaled_bond"
    }
    fn horizon(&self) -> Option<f64> {
        Some(self.horizon)
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        match capability {
            Capability::StaticSolve | Capability::Export | Capability::BlockRows => None,
            _ => Some("a test model: static solves, export and rows only".into()),
        }
    }
    fn system(&self, p: &Problem, _: Purpose, _: &dyn Progress) -> Result<System, ProblemError> {
        let mut k = linpd::bond::assemble(&self.op, &DofMap::all_free(p.nodes().len(), p.dim()));
        k.val_mut().iter_mut().for_each(|v| *v *= self.scale);
        let model = AssembledModel::new("scaled_bond", p.dim(), p.nodes().positions(), k);
        let n_bonds = self.op.family().n_bonds();
        Ok(System {
            model: Arc::new(model),
            bc: p.dirichlet(),
            f: p.load_vector(),
            n_bonds,
            notes: vec![],
            built_before: 0.0,
            memory_estimate: None,
        })
    }
    fn solution(
        &self,
        p: &Problem,
        s: &System,
        u: Vec<f64>,
        report: linpd::solve::SolveReport,
    ) -> Result<Solution, ProblemError> {
        Ok(Solution {
            name: p.name().into(),
            dim: p.dim(),
            x: p.nodes().positions(),
            u,
            is_layer: (0..p.nodes().len()).map(|i| p.nodes().is_layer(i)).collect(),
            volumes: (0..p.nodes().len()).map(|i| p.nodes().volume(i)).collect(),
            n_bonds: s.n_bonds,
            report,
            balance: None,
            strain_energy_density: None,
            strain: None,
            dilatation: None,
            cells: None,
            graded_mesh: None,
            file_node: None,
            material: Vec::new(),
            stress: None,
            pd_stress: None,
        })
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The scaled model solves `(s K) u = f`: its displacements are the bond model's over `s`
/// (both by sparse Cholesky; relative difference within 1e-12, rounding of two factorizations
/// of a matrix with condition ~1e3), its unknown key is named, and it refuses what it lacks.
#[test]
fn a_new_model_type_is_one_module_and_one_registry_entry() {
    let registry = Registry::default().with(&SCALED_BOND);
    let mut keys = bond_keys();
    keys["type"] = json!("scaled_bond");
    keys["scale"] = json!(4.0);
    let mut v = plate(keys);
    v["solver"] = json!({"type": "cholesky"});
    let here = Path::new(".");
    let scaled = Problem::from_json_with(&v.to_string(), here, &registry).unwrap();
    let mut b = plate(bond_keys());
    b["solver"] = json!({"type": "cholesky"});
    let bond = Problem::from_json(&b.to_string()).unwrap();
    let (us, ub) = (scaled.solve(&NoProgress).unwrap().u, bond.solve(&NoProgress).unwrap().u);
    let umax = ub.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = us.iter().zip(&ub).map(|(s, b)| (4.0 * s - b).abs()).fold(0.0, f64::max);
    assert!(umax > 0.0 && diff <= 1e-12 * umax, "diff {diff:e}, max |u| {umax:e}");
    // its rows and export come from the shared commands
    assert_eq!(scaled.row_system().unwrap().n(), scaled.reduced_system(&NoProgress).unwrap().n());
    // refusals name the capability
    let e = level0_model(&scaled).unwrap_err().to_string();
    assert!(e.starts_with("model.type: coarsening is not available for scaled_bond models"), "{e}");
    // its keys are its own: a bond key it does not take names the types that take it
    let mut bad = v.clone();
    bad["model"]["pd_regions"] = json!("auto");
    let e = Problem::from_json_with(&bad.to_string(), here, &registry).unwrap_err().to_string();
    assert!(e.starts_with("model.pd_regions: not a key of scaled_bond models (only bond models take it)"), "{e}");
    // and `scale` is unknown to the registry without it
    let e = Problem::from_json(&v.to_string()).unwrap_err().to_string();
    assert!(e.starts_with("model.type: unknown variant `scaled_bond`, expected one of `bond`"), "{e}");
}
