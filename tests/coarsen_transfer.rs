//! A coarsening pipeline poses the scene's own problem at every level (issue #29):
//!
//! * level 0 is `linpd solve` of the scene, bit for bit (every bundled pipeline);
//! * loads reach coarse levels by the step's transfer `F^m = S^T F^{m-1}`: with whole-body
//!   neighbourhoods every level is the exact Schur complement, for loads on eliminated nodes too;
//!   loads on shared nodes pass unchanged (Silling's Examples 5.2/5.3 as printed);
//! * a level loaded back as a scene with the pipeline's `forces.csv` and `prescribed.csv`
//!   reproduces the pipeline's level;
//! * the radius rule's defaults never contradict each other (Examples 5.1-5.3 with only a
//!   tolerance);
//! * the effective modulus of a level against the one measured from the level-0 solution.
//!
//! Every measured number is printed (`cargo test --release --test coarsen_transfer --
//! --nocapture`); each tolerance says what it was set from.

use linpd::core::progress::NoProgress;
use linpd::problem::{Pipeline, PipelineResult, Problem};
use linpd::studies::fixtures::{cell_modulus, composite, H};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-transfer-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn data(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(root().join("data").join(name)).unwrap()).unwrap()
}

/// Writes `scene` and a pipeline over it with `levels` into `dir`; runs it (solving every level).
fn run(dir: &Path, scene: &Value, levels: Value) -> PipelineResult {
    std::fs::write(dir.join("scene.json"), scene.to_string()).unwrap();
    let text = json!({"name": "t", "scene": "scene.json", "levels": levels, "solve": true}).to_string();
    let p = Pipeline::from_json_in(&text, dir).unwrap();
    p.run(&dir.join("out"), &NoProgress).unwrap()
}

#[test]
fn level_0_is_the_scene_bit_for_bit() {
    for name in ["coarsen-composite-bar", "coarsen-defect-bar", "coarsen-plate-2d", "coarsen-lps-plate-2d"] {
        let mut p = Pipeline::from_path(&root().join(format!("data/{name}.pipeline.json"))).unwrap();
        p.solve = true;
        let r = p.run(&temp_dir(name), &NoProgress).unwrap();
        let scene = Problem::from_path(&root().join(format!("data/{name}.json"))).unwrap();
        let (mask, ubar) = scene.constrained();
        let f = scene.load_vector();
        let l0 = &r.levels[0];
        assert_eq!(l0.bvp.mask, mask, "{name}: prescribed DOFs");
        assert_eq!(l0.bvp.ubar, ubar, "{name}: prescribed values");
        for k in 0..f.len() {
            let want = if mask[k] { 0.0 } else { f[k] };
            assert_eq!(l0.bvp.f[k].to_bits(), want.to_bits(), "{name}: nodal force of DOF {k}");
        }
        let u = scene.solve(&NoProgress).unwrap().u;
        assert!(u.iter().zip(&l0.u).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: level-0 u");
        println!(
            "{name}: level 0 = the scene ({} DOFs, {} prescribed), bit for bit; levels' errors at the shared nodes {:?}",
            f.len(),
            l0.prescribed_dofs,
            r.levels.iter().map(|l| format!("{:.2e}", l.error_shared.unwrap())).collect::<Vec<_>>()
        );
    }
}

/// Example 5.2's bar with loads on nodes that level 1 eliminates: a point force at x = 0.505
/// (level-0 node 101) and a body load on [0.3, 0.6].
fn composite_loaded_inside() -> Value {
    let mut s = data("coarsen-composite-bar.json");
    s["loads"] = json!([
        {"type": "point", "at": [0.505], "force": [1e-5]},
        {"type": "body", "region": {"box": {"min": [0.3], "max": [0.6]}}, "density": [0.002]}
    ]);
    s
}

/// A 13 x 13 bond plate held at three nodes that every level keeps ((0,0), (0,4h), (4h,0):
/// every 2nd then every 2nd node keeps the multiples of 4h), loaded at the eliminated node
/// (5h, 7h) and by a body load on its right half.
fn plate_loaded_inside() -> Value {
    let h = 1.0 / 12.0;
    let at =
        |i: f64, j: f64| json!({"box": {"min": [i * h - 1e-3, j * h - 1e-3], "max": [i * h + 1e-3, j * h + 1e-3]}});
    json!({
        "name": "plate", "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": h},
        "model": {"type": "bond", "horizon": 2.5 * h, "plane": "stress",
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"}},
        "constraints": [{"region": {"union": [at(0.0, 0.0), at(0.0, 4.0), at(4.0, 0.0)]}, "displacement": {"value": [0.0, 0.0]}}],
        "loads": [{"type": "point", "at": [5.0 * h, 7.0 * h], "force": [1e-2, -5e-3]},
                  {"type": "body", "region": {"box": {"min": [0.5, 0.0], "max": [1.0, 1.0]}}, "density": [3e-3, 1e-3]}],
        "solver": {"type": "cholesky"}
    })
}

#[test]
fn whole_body_levels_are_the_schur_complement_for_loads_on_eliminated_nodes() {
    // N_x = the whole body: each level is the exact static condensation of level 0 and F^m its
    // right-hand side F_R - K_RE K_EE^{-1} F_E. Tolerance 1e-10 on the relative error at the shared
    // nodes: eps times the condition numbers (~1e5 for both stiffnesses) times a margin of 10;
    // the total force is conserved by the rows of S summing to the identity (eq. (8)): 1e-12.
    let cases = [
        (
            "1D composite bar",
            composite_loaded_inside(),
            json!([{"every": 4, "radius": 10.0}, {"every": 2, "radius": 10.0}]),
        ),
        ("2D bond plate", plate_loaded_inside(), json!([{"every": 2, "radius": 10.0}, {"every": 2, "radius": 10.0}])),
    ];
    for (name, scene, levels) in cases {
        let dir = temp_dir(&name.replace(' ', "-"));
        let r = run(&dir, &scene, levels);
        for l in &r.levels {
            let e = l.error_shared.unwrap();
            println!(
                "{name}, level {}: {} nodes, whole body {}, error at the shared nodes {e:.2e}, total force {:?} (change {:.1e})",
                l.level,
                l.nodes,
                l.step.as_ref().is_some_and(|s| s.whole_body),
                l.force,
                l.force_change
            );
            assert!(e < 1e-10, "{name} level {}: {e:e}", l.level);
            assert!(l.force_change < 1e-12, "{name} level {}: {:e}", l.level, l.force_change);
            assert!(l.level == 0 || l.step.as_ref().unwrap().whole_body);
        }
    }
}

/// Example 5.2 global stretch between x = 0.2 and x = 0.8 (shared nodes 5 and 20 of the
/// coarsest level, spacing 0.04; six periods apart so the stripes' fluctuation cancels).
fn stretch(u_shared: &[f64]) -> f64 {
    (u_shared[20] - u_shared[5]) / 0.6
}

#[test]
fn example_5_2_as_printed_keeps_the_nodal_forces_and_the_global_stretch() {
    // The bundled pipeline at the paper's radii (r^1 = 0.1, r^2 = 0.2): loads and supports on
    // level-2 nodes, so every level carries level 0's nodal forces exactly.
    let mut p = Pipeline::from_path(&root().join("data/coarsen-composite-bar.pipeline.json")).unwrap();
    let symmetrized = p.run(&temp_dir("ex52-sym"), &NoProgress).unwrap();
    // the paper does not symmetrize C^m; linpd does by default
    p.symmetrize = false;
    let r = p.run(&temp_dir("ex52"), &NoProgress).unwrap();
    let l0 = &r.levels[0];
    for l in &r.levels[1..] {
        // the three loaded nodes keep b v^0 = 0.001 x 0.005 each, bit for bit; no other node is
        // loaded (the transfer adds exact zeros from the unloaded eliminated nodes)
        let loaded: Vec<f64> = l.bvp.f.iter().copied().filter(|&t| t != 0.0).collect();
        assert_eq!(loaded.len(), 3, "level {}: {loaded:?}", l.level);
        assert!(loaded.iter().all(|fk| fk.to_bits() == (0.001 * H).to_bits()), "level {}: {loaded:?}", l.level);
        assert_eq!(l.prescribed_dofs, 3);
    }
    assert_eq!(l0.bvp.f.iter().filter(|&&t| t != 0.0).count(), 3);
    // the stretch against the independent periodic-cell modulus (Gaussian elimination on the
    // paper's micromodulus, linpd-studies' fixtures): F / E_eff
    let target = 3.0 * 0.001 * H / cell_modulus(20, composite);
    let s: Vec<f64> = r.levels.iter().map(|l| stretch(&l.u_shared)).collect();
    println!(
        "Example 5.2 (r = 0.1, 0.2): F/E_eff = {target:.6e}; stretch {:?}; vs F/E_eff {:?}",
        s.iter().map(|v| format!("{v:.6e}")).collect::<Vec<_>>(),
        s.iter().map(|v| format!("{:+.2e}", v / target - 1.0)).collect::<Vec<_>>()
    );
    // level 0: 8e-7 measured in linpd-studies' coarsen_examples (the end disturbances); 1e-5
    assert!((s[0] / target - 1.0).abs() < 1e-5);
    // levels 1, 2 at the paper's radii: +4.8e-2 / +5.7e-2 in linpd-studies' coarsen_examples
    // (N_x cuts the bonds that carry load around the soft stripes), the same here; bound 8e-2
    assert!((s[1] / s[0] - 1.0).abs() < 8e-2 && (s[2] / s[0] - 1.0).abs() < 8e-2);
    // Symmetrized (the default), the coarse bar is softer still at these radii, +19.6 % and
    // +21.2 %: the rows of C^1 come from neighbourhoods that differ along the period (5 coarse
    // nodes per stripe pair), and averaging C_ij with C_ji^T (each cut by a different N_x) mixes
    // two truncations (not analysed further); with the radius rule (tail 1e-6) both agree with level 0 to 1e-8 (the
    // test below). Bound 0.3, to notice a change.
    let ss: Vec<f64> = symmetrized.levels.iter().map(|l| stretch(&l.u_shared)).collect();
    println!("symmetrized: stretch vs level 0 {:+.3e}, {:+.3e}", ss[1] / ss[0] - 1.0, ss[2] / ss[0] - 1.0);
    assert!(ss[1..].iter().all(|v| (v / ss[0] - 1.0).abs() < 0.3));
}

#[test]
fn radius_rule_defaults_run_silling_examples_5_1_to_5_3_without_a_radius() {
    // The paper's settings with a tolerance only (no radius_start, no radius_max). Example 5.1:
    // the tent kernel on the bar; 5.2: the composite; 5.3: the bar with a defect (every 3rd,
    // twice, as in linpd-studies). Until 2026-11 the defaults contradicted each other at level 2
    // of 5.1 (`radius_max 9.8e-1 is below the first radius 1.04e0`).
    // Example 5.1 under Example 5.2's supports and loads (nodes every level keeps)
    let mut tent = data("coarsen-composite-bar.json");
    tent["model"]["micromodulus"]["kernel"] = json!("tent");
    tent["model"]["horizon"] = json!(0.05);
    tent["model"]["material"] = json!({});
    let rule = json!({"every": 4, "tolerance": 1e-6});
    let rule2 = json!({"every": 2, "tolerance": 1e-6});
    let rule3 = json!({"every": 3, "tolerance": 1e-6});
    let cases = [
        ("Example 5.1", tent, json!([rule, rule2])),
        ("Example 5.2", data("coarsen-composite-bar.json"), json!([rule, rule2])),
        ("Example 5.3", data("coarsen-defect-bar.json"), json!([rule3, rule3])),
    ];
    for (name, scene, levels) in cases {
        let dir = temp_dir(&name.replace(' ', "-"));
        let r = run(&dir, &scene, levels);
        for l in &r.levels[1..] {
            let st = l.step.as_ref().unwrap();
            println!(
                "{name} level {}: r = {:.4e} (horizon {:.4e}), tail {:.1e}, whole body {}, error at shared nodes {:.2e}; notes {:?}",
                l.level,
                st.radius,
                st.horizon_fine,
                st.tail,
                st.whole_body,
                l.error_shared.unwrap(),
                l.notes
            );
            assert!(st.tail <= 1e-6);
            // a whole-body step says so in the level's notes
            assert_eq!(st.whole_body, l.notes.iter().any(|n| n.contains("whole body")), "{name}");
        }
        if name == "Example 5.2" {
            // the global stretch of every level equals level 0's to the rule's tolerance: the
            // tail bounds the truncated coarse bonds relative to the row's largest; measured
            // 1e-7..1e-6 relative. Bound 1e-5 (10x the tolerance).
            let s0 = stretch(&r.levels[0].u_shared);
            for l in &r.levels[1..] {
                let e = stretch(&l.u_shared) / s0 - 1.0;
                println!("{name} level {}: stretch vs level 0 {e:+.2e}", l.level);
                assert!(e.abs() < 1e-5);
            }
        }
    }
}

#[test]
fn a_level_loaded_back_with_the_pipelines_files_reproduces_the_pipeline() {
    // Finite radii and loads on eliminated nodes: level 1 (not the coarsest) and level 2 loaded
    // as scenes with `level-<m>.forces.csv` and `level-<m>.prescribed.csv`. The moduli read back
    // bit for bit (sprs, shortest round-trip values), the forces and values too; the two solves
    // are the same sparse factorization of the same matrix. Bound 1e-12 relative.
    let dir = temp_dir("load-back");
    let r = run(&dir, &composite_loaded_inside(), json!([{"every": 4, "radius": 0.15}, {"every": 2, "radius": 0.3}]));
    for m in [1, 2] {
        let scene = json!({
            "name": format!("level{m}"), "dimension": 1,
            "model": {"type": "coarsened", "moduli": format!("out/level-{m}.mtx")},
            "constraints": [{"file": format!("out/level-{m}.prescribed.csv")}],
            "loads": [{"type": "nodal", "file": format!("out/level-{m}.forces.csv")}]
        });
        let path = dir.join(format!("level{m}.json"));
        std::fs::write(&path, scene.to_string()).unwrap();
        let u = Problem::from_path(&path).unwrap().solve(&NoProgress).unwrap().u;
        let want = &r.levels[m].u;
        assert_eq!(u.len(), want.len());
        let umax = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let err = u.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / umax;
        println!("level {m} as a scene with the pipeline's files: rel. difference {err:.2e} over {} nodes", u.len());
        assert!(err < 1e-12, "level {m}: {err:e}");
    }
}

#[test]
fn effective_modulus_of_the_striped_composite_per_level() {
    // Example 5.2's stripes on a bar of length 4 (20 periods of 0.1), levels every 4th (spacing
    // 0.02) then every 5th (spacing 0.1 = one period). Measured from the level-0 solution:
    // E = F / stretch between x = 1 and x = 3 (whole periods, far from the ends).
    let mut scene = data("coarsen-composite-bar.json");
    scene["grid"]["max"] = json!([4.0]);
    let stripes: Vec<Value> =
        (0..40).map(|k| json!({"box": {"min": [0.1 * k as f64], "max": [0.1 * k as f64 + 0.0499]}})).collect();
    scene["model"]["material"]["phases"][0]["region"] = json!({"union": stripes});
    let at = |xs: &[f64]| json!({"union": xs.iter().map(|x| json!({"box": {"min": [x - 1e-3], "max": [x + 1e-3]}})).collect::<Vec<_>>()});
    scene["constraints"][0]["region"] = at(&[0.0, 0.1, 0.2]);
    scene["loads"][0]["region"] = at(&[3.8, 3.9, 4.0]);
    let dir = temp_dir("moduli");
    let r = run(&dir, &scene, json!([{"every": 4, "tolerance": 1e-6}, {"every": 5, "tolerance": 1e-6}]));
    let force = 3.0 * 0.001 * H;
    // shared nodes: x = 0.1 k; x = 1 and 3 are nodes 10 and 30
    let s0 = &r.levels[0].u_shared;
    let e_meas = force / ((s0[30] - s0[10]) / 2.0);
    let e_cell = cell_modulus(20, composite);
    let m0 = 285.0 * H.powi(3); // (1/2) sum C xi^2 v of C = 1: the bar modulus of unit C
    let reuss = 2.0 / (1.0 / (10.0 * m0) + 1.0 / m0);
    let e: Vec<f64> = r.levels.iter().map(|l| l.effective_moduli.as_ref().unwrap().voigt[0][0]).collect();
    println!(
        "E/m0: measured from level 0 {:.8}, periodic cell {:.8}, Reuss (series) {:.6}, Voigt 5.5; \
         effective moduli per level {:?}",
        e_meas / m0,
        e_cell / m0,
        reuss / m0,
        e.iter().map(|v| format!("{:.8}", v / m0)).collect::<Vec<_>>()
    );
    for l in &r.levels {
        let em = l.effective_moduli.as_ref().unwrap();
        println!(
            "level {}: {} interior nodes (reach {:.3}), spread {:.2e}, E/m0 in [{:.4}, {:.4}]",
            l.level,
            em.nodes,
            em.reach,
            em.spread,
            em.min[0][0] / m0,
            em.max[0][0] / m0
        );
    }
    // level 0's measurement against the periodic cell (independent): the end disturbances decay
    // over a few horizons, 1 is 20 horizons from the supports; 1e-6
    assert!((e_meas / e_cell - 1.0).abs() < 1e-6);
    // level 2 holds one node per period: translation invariant, its effective modulus is the
    // homogenized one, to the tail tolerance (1e-6) of the two steps; bound 1e-5
    assert!((e[2] / e_meas - 1.0).abs() < 1e-5, "level 2 {} vs measured {}", e[2], e_meas);
    // levels 0 and 1 have several nodes per period: their interior average is the affine
    // (Voigt-type) modulus, an upper bound (level 0: 2.30 m0, level 1: 1.64 m0, +88 % and +34 %)
    assert!(e[0] > e[1] && e[1] > 1.1 * e_meas);
    // the composite is softer than its stripes in series: bonds that cross a stripe boundary
    // take the soft modulus (`bond_rule: min`), and the stripes (0.05) are one horizon wide
    assert!(e_meas < reuss);
}

/// The layered plate of the 2D homogenization test: 49 x 49 nodes (h = 1/48), bond-based plane
/// stress, `delta = 1.5 h`, layers normal to y with period `P = 6h`: three node rows of modulus 4
/// (rows `6k, 6k+1, 6k+2`), three of modulus 1, bonds between phases take the smaller
/// (`bond_rule: min`). `load` is `"x"` or `"y"`: a unit-order traction on the `+` face, the
/// opposite face held in that direction and one corner in both.
fn laminate(load: &str, layered: bool) -> Value {
    let h = 1.0 / 48.0;
    let layers: Vec<Value> = (0..9)
        .map(|k| json!({"box": {"min": [-1.0, 6.0 * h * k as f64 - 1e-9], "max": [2.0, 6.0 * h * k as f64 + 2.5 * h]}}))
        .collect();
    let material = if layered {
        json!({"bond_rule": "min", "phases": [{"region": {"union": layers}, "modulus": 4.0}]})
    } else {
        json!({})
    };
    let (axis, face, traction) = if load == "x" { (0, "x+", [1e-3, 0.0]) } else { (1, "y+", [0.0, 1e-3]) };
    let mut held = json!({"box": {"min": [-1.0, -1.0], "max": [2.0, 2.0]}});
    held["box"]["max"][axis] = json!(1e-6);
    json!({
        "name": format!("laminate-{load}"), "dimension": 2,
        "grid": {"min": [0.0, 0.0], "max": [1.0, 1.0], "spacing": h},
        "model": {"type": "bond", "horizon": 1.5 * h, "plane": "stress",
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "continuum"},
                  "material": material},
        "constraints": [
            {"region": held, "displacement": {"value": [0.0, 0.0]}, "components": [axis]},
            {"region": {"box": {"min": [-1.0, -1.0], "max": [1e-6, 1e-6]}}, "displacement": {"value": [0.0, 0.0]}}
        ],
        "loads": [{"type": "traction", "face": face, "traction": traction}],
        "solver": {"type": "cholesky"}
    })
}

/// `[C11, C12, C22]` of a layered medium (layers normal to y, volume fractions `f`, each layer's
/// in-plane stiffness `[C11, C12, C22]`): the exact laminate of uniform fields (`eps_xx`,
/// `sigma_yy` the same in every layer):
/// `C22 = 1 / <1/C22>`, `C12 = <C12/C22> C22`, `C11 = <C11 - C12^2/C22> + <C12/C22>^2 C22`.
fn laminate_closed_form(layers: &[(f64, [f64; 3])]) -> [f64; 3] {
    let avg = |g: &dyn Fn(&[f64; 3]) -> f64| layers.iter().map(|(f, c)| f * g(c)).sum::<f64>();
    let c22 = 1.0 / avg(&|c| 1.0 / c[2]);
    let r = avg(&|c| c[1] / c[2]);
    [avg(&|c| c[0] - c[1] * c[1] / c[2]) + r * r * c22, r * c22, c22]
}

#[test]
fn effective_moduli_of_a_layered_plate_against_its_level_0_solution_and_the_laminate() {
    let dir = temp_dir("laminate");
    let h = 1.0 / 48.0;
    // measured from two level-0 solves: uniaxial stress sigma = 1e-3 along x, then along y; the
    // strains between (0.25, 0.5) and (0.75, 0.5) (x) and (0.5, 12h) and (0.5, 36h) (y, four
    // whole periods); S = [eps(load x), eps(load y)] / sigma, C = S^-1
    let mut strains = Vec::new();
    for load in ["x", "y"] {
        let path = dir.join(format!("laminate-{load}.json"));
        std::fs::write(&path, laminate(load, true).to_string()).unwrap();
        let p = Problem::from_path(&path).unwrap();
        let u = p.solve(&NoProgress).unwrap().u;
        let node = |x: f64, y: f64| ((y / h).round() * 49.0 + (x / h).round()) as usize;
        let (a, b, c, d) = (node(0.25, 0.5), node(0.75, 0.5), node(0.5, 12.0 * h), node(0.5, 36.0 * h));
        assert_eq!(p.nodes().position(b)[0], 36.0 * h);
        strains.push([(u[2 * b] - u[2 * a]) / 0.5, (u[2 * d + 1] - u[2 * c + 1]) / (24.0 * h)]);
    }
    let sigma = 1e-3; // traction x 49 h of face / (49 h): the lattice's faces are 49 h long
    let s = [[strains[0][0] / sigma, strains[1][0] / sigma], [strains[0][1] / sigma, strains[1][1] / sigma]];
    let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    let measured = [s[1][1] / det, -s[0][1] / det, s[0][0] / det];
    // the phases' own tensors: (H) of the homogeneous plate (modulus 1) at level 0, x 4 for the
    // stiff phase
    let homogeneous = Problem::from_json(&laminate("x", false).to_string()).unwrap();
    let c1 = linpd::coarsen::effective_moduli(&linpd::problem::level0_model(&homogeneous).unwrap(), None).unwrap();
    let soft = [c1.voigt[0][0], c1.voigt[0][1], c1.voigt[1][1]];
    let stiff = soft.map(|t| 4.0 * t);
    let closed = laminate_closed_form(&[(0.5, stiff), (0.5, soft)]);
    let rel = |a: &[f64; 3], b: &[f64; 3]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x / y - 1.0).collect() };
    println!("phase tensor (modulus 1): C11 {:.4}, C12 {:.4}, C22 {:.4}", soft[0], soft[1], soft[2]);
    println!("measured from level 0: C11 {:.4}, C12 {:.4}, C22 {:.4}", measured[0], measured[1], measured[2]);
    println!(
        "laminate closed form (f = 1/2): C11 {:.4}, C12 {:.4}, C22 {:.4}; measured vs it {:+.3?}",
        closed[0],
        closed[1],
        closed[2],
        rel(&measured, &closed)
    );
    // one coarsening step keeping every 6th node per axis (one node per period) at growing radii
    let mut errors = Vec::new();
    for periods in [2.0, 3.0, 4.0] {
        let r = run(&dir, &laminate("x", true), json!([{"every": 6, "radius": periods * 6.0 * h}]));
        let em = r.levels[1].effective_moduli.as_ref().unwrap();
        let c = [em.voigt[0][0], em.voigt[0][1], em.voigt[1][1]];
        let e = rel(&c, &measured);
        println!(
            "r = {periods} periods: tail {:.2e}, {} interior nodes, (H) C11 {:.4}, C12 {:.4}, C22 {:.4}; vs measured {:+.3?}",
            r.levels[1].step.as_ref().unwrap().tail,
            em.nodes,
            c[0],
            c[1],
            c[2],
            e
        );
        errors.push(e.iter().fold(0.0f64, |m, t| m.max(t.abs())));
    }
    // the period level's (H) approaches the homogenized tensor as the radius grows (the 1D
    // composite reaches 1e-8 at a tail of 1e-6; in 2D the tail decays slower: 0.99, 0.35, 0.07
    // at 2, 3, 4 periods); bound at 4 periods from the measurement (5 %): 8 %
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "{errors:?}");
    assert!(errors[2] < 0.08, "{errors:?}");
    // level 0 against the local laminate: the bonds that cross a phase boundary take the soft
    // modulus and the layers are two horizons thick, so the plate is softer than the laminate
    // of its phases; bound from the measurement
    let lam = rel(&measured, &closed);
    assert!(lam.iter().all(|t| t.abs() < 0.25), "{lam:?}");
}

#[test]
fn bad_nodal_files_are_refused_naming_the_file_and_line() {
    // scenes that read nodal forces or prescribed values from files: every defect is an error
    // with the JSON path, the file and its line, a non-zero exit, no panic, nothing written
    let dir = temp_dir("bad-files");
    std::fs::write(dir.join("ok.prescribed.csv"), "node,component,value\n0,0,0.0\n").unwrap();
    std::fs::write(dir.join("ok.forces.csv"), "node,f_x\n200,1e-5\n").unwrap();
    let files = [
        ("f1.csv", "node,f_x\n3,1.0\n201,1.0\n"),
        ("f2.csv", "node,f_y\n3,1.0\n"),
        ("f3.csv", "node,f_x\n3,1.0\n3,2.0\n"),
        ("p1.csv", "node,component,value\n0,1,0.0\n"),
        ("p2.csv", "node,component,value\n0,0,inf\n"),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let base = data("coarsen-composite-bar.json");
    let with = |constraints: Value, loads: Value| {
        let mut s = base.clone();
        s["constraints"] = constraints;
        s["loads"] = loads;
        s
    };
    let ok_c = json!([{"file": "ok.prescribed.csv"}]);
    let ok_l = json!([{"type": "nodal", "file": "ok.forces.csv"}]);
    let cases = [
        (
            with(ok_c.clone(), json!([{"type": "nodal", "file": "f1.csv"}])),
            "loads[0].file",
            "line 3: node = \"201\" is not an index below 201",
        ),
        (with(ok_c.clone(), json!([{"type": "nodal", "file": "f2.csv"}])), "loads[0].file", "line 1: header"),
        (
            with(ok_c.clone(), json!([{"type": "nodal", "file": "f3.csv"}])),
            "loads[0].file",
            "line 3: node 3 is listed twice",
        ),
        (with(ok_c.clone(), json!([{"type": "nodal", "file": "missing.csv"}])), "loads[0].file", "missing.csv"),
        (with(ok_c.clone(), json!([{"type": "nodal"}])), "loads[0].file", "missing"),
        (
            with(ok_c.clone(), json!([{"type": "nodal", "file": "ok.forces.csv", "density": [1.0]}])),
            "loads[0].density",
            "not a key of a nodal load",
        ),
        (
            with(json!([{"file": "p1.csv"}]), ok_l.clone()),
            "constraints[0].file",
            "line 2: component = \"1\" is not an index below 1",
        ),
        (
            with(json!([{"file": "p2.csv"}]), ok_l.clone()),
            "constraints[0].file",
            "line 2: value = \"inf\" is not a finite number",
        ),
        (
            with(json!([{"file": "ok.prescribed.csv", "region": {"box": {"min": [0.0], "max": [0.1]}}}]), ok_l.clone()),
            "constraints[0].region",
            "give either `file` or `region`",
        ),
        (with(json!([{"displacement": {"value": [0.0]}}]), ok_l.clone()), "constraints[0].region", "missing"),
    ];
    for (k, (scene, path, reason)) in cases.iter().enumerate() {
        let file = dir.join(format!("bad{k}.json"));
        std::fs::write(&file, scene.to_string()).unwrap();
        let out = dir.join(format!("out{k}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_linpd"))
            .args(["solve", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("case {k}: {}", stderr.trim());
        assert!(!o.status.success() && !stderr.contains("panicked"), "case {k}: {stderr}");
        assert!(stderr.contains(path) && stderr.contains(reason), "case {k}: {stderr:?} lacks {path:?} / {reason:?}");
        assert!(!out.exists(), "case {k} wrote output");
    }
    // and the good files solve
    let file = dir.join("good.json");
    std::fs::write(&file, with(ok_c, ok_l).to_string()).unwrap();
    let u = Problem::from_path(&file).unwrap().solve(&NoProgress).unwrap().u;
    assert!(u[200] > 0.0);
}
