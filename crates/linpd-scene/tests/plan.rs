//! The solver plan a scene keeps (issue #51: the solve path decided in one place): made once
//! at validation from what the scene's model declares ([`linpd_scene::SceneModel::offers`]), it
//! must be the plan the built model itself implies ([`linpd_solve::Offers::of_model`]), so that
//! the memory guard counts what the solve runs.

use linpd_core::NoProgress;
use linpd_scene::models::Purpose;
use linpd_scene::Problem;
use linpd_solve::statics::AutoParams;
use linpd_solve::{plan, CgParams, Offers, PreconditionerKind, Route, SolverSpec};
use std::path::{Path, PathBuf};

fn bundled_scenes() -> Vec<PathBuf> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json") && !p.to_string_lossy().ends_with(".pipeline.json"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 30, "the bundled scenes: {} found in {}", scenes.len(), data.display());
    scenes
}

/// The plan `p` keeps against the plan of its built model, for its solver.
fn check(p: &Problem, name: &str) -> Option<Route> {
    let kept = p.plan()?.clone();
    let system = p.model().system(p, Purpose::Solve, &NoProgress).unwrap();
    let dofs = system.bc.dofs();
    let model = system.model();
    let offers = Offers::of_model(model, dofs, model.asymmetry(dofs));
    assert_eq!(kept.offers, offers, "{name} ({}): the declared offers differ from the built model's", p.solver());
    assert_eq!(kept, plan(p.solver(), &offers, &AutoParams::default()), "{name}");
    Some(kept.route)
}

/// Every bundled scene with its own solver, `auto` and matrix-free multigrid-CG where its model
/// runs matrix-free: the kept plan is the built model's. `auto`'s matrix-free route must be
/// among the routes seen (the 3D cube takes it), so the check is not only of assembled plans.
#[test]
fn kept_plan_is_the_built_models() {
    let mut routes = Vec::new();
    let mut planned = 0;
    for scene in bundled_scenes() {
        let name = scene.file_name().unwrap().to_string_lossy().to_string();
        let mut p = Problem::from_path(&scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        if p.plan().is_none() || p.dynamics().is_some() {
            continue;
        }
        planned += 1;
        routes.extend(check(&p, &name));
        p.set_solver(SolverSpec::Auto(CgParams::default()));
        routes.extend(check(&p, &name));
        if p.model().lacks(linpd_scene::Capability::MatrixFree).is_none() {
            let params = CgParams::default();
            p.set_solver(SolverSpec::Cg { params, preconditioner: PreconditionerKind::MULTIGRID, matrix_free: true });
            routes.extend(check(&p, &name));
        }
    }
    assert!(planned >= 20, "{planned} scenes planned at validation");
    assert!(routes.contains(&Route::AutoMatrixFreeCg), "no scene took auto's matrix-free route: {routes:?}");
    assert!(routes.contains(&Route::Assembled));
}

/// A model that plans from its built operator keeps no plan: the graded blend (its unknowns are
/// its mesh's masters) and the 1D blend (its own solvers).
#[test]
fn graded_and_1d_blends_plan_when_built() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    for name in ["plate-crack-graded-2d.json", "blend-point-load.json"] {
        let p = Problem::from_path(&data.join(name)).unwrap();
        assert!(p.plan().is_none(), "{name}");
    }
    let p = Problem::from_path(&data.join("plate-crack-blend-2d.json")).unwrap();
    assert_eq!(p.plan().map(|k| k.offers.symmetric), Some(false));
}
