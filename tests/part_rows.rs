//! Per-rank geometry (issue #34; `Problem::from_path_part`, `linpd::problem::part_rows`): a
//! scene cut into 1, 2, 3 and 5 slabs, each rank building only its window, gives the whole
//! scene's reduced system and solution. The reductions MPI does in the PETSc driver (an or over
//! the presence checks, sums of the resultant volumes, of the rigid-mode Gram matrices and of the
//! balance, a gather of the per-plane counts) are done here in-process, so these tests run the
//! numbering and the windows without MPI; `python/tests/check_petsc.py` runs them under MPI.
//!
//! Compared with the whole scene's `RowSystem` (itself checked against `linpd export` in
//! tests/rows.rs): row numbers and columns exactly; values to `1e-13 max|A_ff|` (an entry is a
//! sum over a node's bonds that the window adds in the same order, so in practice bit for bit;
//! the bound is the one tests/rows.rs gives sums in another order); the right-hand side to
//! `1e-13 max|f|` for the same reason. The pieces' displacements, strains, stresses (Hooke and
//! force flux), energy densities and dilatations from the whole solution's values equal the
//! whole solution's on the owned nodes to `1e-12` of each field's largest value (the fields read the halo's displacements; a halo one plane too thin changes
//! a boundary node's strain by O(1)).

use linpd::problem::{part_rows, Commands, Part, PartRows, Problem};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

/// `name` from data/ with `edit` applied, written to a temporary file (parts read files).
fn scene_file(name: &str, tag: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap();
    edit(&mut v);
    let dir = std::env::temp_dir().join(format!("linpd-part-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}.json"));
    std::fs::write(&path, v.to_string()).unwrap();
    path
}

/// Every rank's part and rows after the reductions the driver does.
fn parts(path: &Path, ranks: usize) -> Result<Vec<(Problem, PartRows)>, String> {
    let mut problems = Vec::new();
    for rank in 0..ranks {
        problems.push(Problem::from_path_part(path, Part { rank, ranks }).map_err(|e| e.to_string())?);
    }
    // the presence checks: an or over the ranks
    let checks = problems[0].part().unwrap().presences.len();
    let found: Vec<bool> = (0..checks).map(|k| problems.iter().any(|p| p.part().unwrap().presences[k].found)).collect();
    for p in &problems {
        linpd::scene::part::settle(&p.part().unwrap().presences, &found).map_err(|e| e.to_string())?;
    }
    // the resultant volumes: a sum
    let mut volumes = vec![0.0; problems[0].loads().len()];
    for p in &problems {
        volumes.iter_mut().zip(p.resultant_volumes()).for_each(|(t, v)| *t += v);
    }
    let problems: Vec<Problem> =
        problems.into_iter().map(|p| p.with_resultant_volumes(volumes.clone()).unwrap()).collect();
    let mut rows: Vec<PartRows> = Vec::new();
    for p in &problems {
        rows.push(part_rows(p).map_err(|e| e.to_string())?);
    }
    // the per-plane counts: a gather in rank order
    let counts: Vec<usize> = rows.iter().flat_map(|r| r.plane_free_counts().to_vec()).collect();
    for r in &mut rows {
        r.number(&counts).unwrap();
    }
    // the support: a sum of the Gram matrices
    let mut gram = rows[0].support(&problems[0]).unwrap();
    for (p, r) in problems.iter().zip(&rows).skip(1) {
        let g = r.support(p).unwrap();
        gram.add_gram(&g.all, &g.held);
    }
    if gram.free_modes() > 0 {
        return Err(format!("{} rigid motions free", gram.free_modes()));
    }
    Ok(problems.into_iter().zip(rows).collect())
}

/// A solution's nodal tensors (strain, Hooke stress, force-flux stress).
fn tensors(s: &linpd::scene::Solution) -> [Option<&[[f64; 9]]>; 3] {
    [
        s.strain.as_ref().map(|f| &f.tensor[..]),
        s.stress.as_ref().map(|f| &f.tensor[..]),
        s.pd_stress.as_ref().map(|f| &f.tensor[..]),
    ]
}

/// A solution's nodal scalars (strain energy density, dilatation).
fn scalars(s: &linpd::scene::Solution) -> [Option<&[f64]>; 2] {
    [s.strain_energy_density.as_deref(), s.dilatation.as_deref()]
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The whole scene's row of every distributed row: a lattice's parts number the free DOFs as
/// the whole scene does (asserted); a point cloud's by bin, then by the file's order (the window
/// nodes' numbers in the file give the map). Every rank's window must map each row it sees to
/// the same whole row.
fn whole_rows(whole: &Problem, whole_free: &[usize], parts: &[(Problem, PartRows)]) -> Vec<usize> {
    let d = whole.dim();
    let mut free_of = vec![usize::MAX; d * whole.nodes().len()];
    whole_free.iter().enumerate().for_each(|(k, &g)| free_of[g] = k);
    let mut perm = vec![usize::MAX; whole_free.len()];
    for (p, r) in parts {
        let cloud = p.part().unwrap().cloud.as_ref();
        let grid = whole.grid();
        for (&g, &wd) in r.window_rows().unwrap().iter().zip(&r.window_free_dofs()) {
            let node = match (cloud, grid) {
                (Some(c), _) => c.file_node[wd / d] as usize,
                (None, Some(grid)) => grid.nearest_node(&p.nodes().position(wd / d)).0,
                (None, None) => panic!("a part without a lattice or a cloud"),
            };
            let w = free_of[d * node + wd % d];
            assert!(w != usize::MAX, "a window's free DOF is held in the whole scene");
            assert!(perm[g] == usize::MAX || perm[g] == w, "two ranks map row {g} differently");
            perm[g] = w;
        }
    }
    let mut seen = perm.clone();
    seen.sort_unstable();
    assert!(seen.iter().enumerate().all(|(k, &w)| k == w), "the distributed rows are not a permutation");
    if whole.grid().is_some() {
        assert!(perm.iter().enumerate().all(|(k, &w)| k == w), "a lattice's parts number as the whole scene");
    }
    perm
}

/// The parts of `path` over `ranks` against the whole scene.
fn check(path: &Path, ranks: usize) {
    let whole = Problem::from_path(path).unwrap();
    let rows = whole.row_system().unwrap();
    let n = rows.n();
    let block = rows.rows(0, n).unwrap();
    let scale = max_abs(block.data.iter().copied());
    let parts = parts(path, ranks).unwrap();
    let solution = whole.solve(&linpd::core::NoProgress).unwrap();
    let d = whole.dim();
    let u_free: Vec<f64> = rows.free_dofs().iter().map(|&g| solution.u[g]).collect();
    let perm = whole_rows(&whole, rows.free_dofs(), &parts);
    // the whole scene's nodes by position, for the pieces' nodes
    let key = |x: &linpd::core::Point| -> [i64; 3] { std::array::from_fn(|a| (x[a] * 1e9).round() as i64) };
    let node_at: std::collections::HashMap<[i64; 3], usize> =
        (0..whole.nodes().len()).map(|k| (key(&whole.nodes().position(k)), k)).collect();
    let mut next = 0;
    let mut owned_nodes = 0;
    let mut u_windows = Vec::new();
    for (rank, (p, r)) in parts.iter().enumerate() {
        let what = format!("{} rank {rank}/{ranks}", whole.name());
        assert_eq!(r.n_global().unwrap(), n, "{what}: unknowns");
        let range = r.row_range().unwrap();
        assert_eq!(range.start, next, "{what}: the ranks' rows follow each other");
        next = range.end;
        let mine = r.rows(0, range.len()).unwrap();
        // in chunks, as the driver hands them to PETSc: the same rows
        let half = range.len() / 2;
        let (a, b) = (r.rows(0, half).unwrap(), r.rows(half, range.len()).unwrap());
        assert_eq!([a.indices, b.indices].concat(), mine.indices, "{what}: chunks");
        let (diagonal, off) = r.row_lengths().unwrap();
        for (k, (dn, on)) in diagonal.iter().zip(&off).enumerate() {
            let cols = &mine.indices[mine.indptr[k]..mine.indptr[k + 1]];
            assert_eq!((*dn + *on) as usize, cols.len(), "{what}: row length");
            assert_eq!(*dn as usize, cols.iter().filter(|c| range.contains(c)).count(), "{what}: own columns");
        }
        for (k, row) in range.clone().enumerate() {
            let w = perm[row];
            let (a, b) = (block.indptr[w], block.indptr[w + 1]);
            let (c, e) = (mine.indptr[k], mine.indptr[k + 1]);
            let mut entries: Vec<(usize, f64)> =
                mine.indices[c..e].iter().zip(&mine.data[c..e]).map(|(&col, &v)| (perm[col], v)).collect();
            entries.sort_by_key(|e| e.0);
            let columns: Vec<usize> = entries.iter().map(|e| e.0).collect();
            assert_eq!(&columns[..], &block.indices[a..b], "{what}: row {row}'s columns");
            let worst = max_abs(entries.iter().zip(&block.data[a..b]).map(|(x, y)| x.1 - y));
            assert!(worst <= 1e-13 * scale, "{what}: row {row} differs by {worst:e} (max|A| {scale:e})");
        }
        let f_scale = max_abs(rows.rhs().iter().copied()).max(f64::MIN_POSITIVE);
        let worst = max_abs(r.rhs().iter().zip(range.clone()).map(|(x, g)| x - rows.rhs()[perm[g]]));
        assert!(worst <= 1e-13 * f_scale, "{what}: rhs differs by {worst:e}");
        // the piece from the whole solution's values at the window's rows
        let u_window: Vec<f64> = r.window_rows().unwrap().iter().map(|&g| u_free[perm[g]]).collect();
        let report = linpd::solve::SolveReport::new(linpd::solve::SolverId::Lu, n, 0);
        let piece = r.solution(p, &u_window, report).unwrap();
        for (k, x) in piece.x.iter().enumerate() {
            let node = *node_at.get(&key(x)).unwrap_or_else(|| panic!("{what}: piece node {k} at {x:?}"));
            // a cloud's piece names each node's number in the file: the whole scene's node
            let file_node = piece.file_node.as_ref().map(|f| f[k] as usize);
            assert_eq!(file_node.is_some(), whole.grid().is_none(), "{what}: file numbers on clouds only");
            assert!(
                file_node.is_none_or(|f| f == node),
                "{what}: piece node {k} is file node {file_node:?}, not {node}"
            );
            let du = max_abs((0..d).map(|a| piece.u[d * k + a] - solution.u[d * node + a]));
            assert!(du <= 1e-12 * max_abs(solution.u.iter().copied()), "{what}: u at {x:?} differs by {du:e}");
            // each field against its own largest value
            for (mine, all) in tensors(&piece).into_iter().zip(tensors(&solution)) {
                let (Some(mine), Some(all)) = (mine, all) else { continue };
                let scale = max_abs(all.iter().flatten().copied());
                let worst = max_abs(mine[k].iter().zip(&all[node]).map(|(a, b)| a - b));
                assert!(worst <= 1e-12 * scale, "{what}: a field at {x:?} differs by {worst:e} (of {scale:e})");
            }
            for (mine, all) in scalars(&piece).into_iter().zip(scalars(&solution)) {
                let (Some(mine), Some(all)) = (mine, all) else { continue };
                let worst = (mine[k] - all[node]).abs();
                assert!(worst <= 1e-12 * max_abs(all.iter().copied()), "{what}: a nodal scalar at {x:?} differs");
            }
        }
        owned_nodes += piece.x.len();
        u_windows.push(u_window);
    }
    assert_eq!(next, n, "{}: the ranks' rows cover the unknowns", whole.name());
    assert_eq!(owned_nodes, whole.nodes().len(), "{}: every node in one piece", whole.name());
    check_balance(&parts, &solution, &u_windows);
    eprintln!("{}: {ranks} ranks agree ({n} unknowns)", whole.name());
}

#[test]
fn bond_3d_cantilever_with_a_resultant_load() {
    let path = scene_file("cantilever-3d.json", "cantilever", |_| {});
    for ranks in [1, 2, 3, 5] {
        check(&path, ranks);
    }
}

#[test]
fn bond_2d_plate_with_a_hole_a_point_load_and_a_constraint_on_one_line() {
    // the constraint on y = 0.25 and the point load lie in one rank's planes only
    let path = scene_file("plate-hole-2d.json", "hole", |v| {
        v["grid"]["spacing"] = 0.025.into();
        v["model"]["horizon"] = 0.075.into();
        v["grid"]["layer"] = serde_json::json!({"x-": 0.075, "x+": 0.075});
        v["loads"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({"type": "point", "at": [0.5, 0.5], "force": [0.0, 0.1]}));
    });
    for ranks in [1, 2, 3] {
        check(&path, ranks);
    }
}

#[test]
fn lps_2d_plate_two_reaches_of_halo() {
    let path = scene_file("lps-plate-2d.json", "lps", |_| {});
    for ranks in [2, 3, 5] {
        check(&path, ranks);
    }
}

#[test]
fn heterogeneous_cracked_plate() {
    let path = scene_file("plate-crack-2d.json", "crack", |v| {
        v["grid"]["spacing"] = 0.04.into();
        v["grid"]["layer"] = 0.12.into();
        v["model"]["horizon"] = 0.12.into();
        v["model"]["material"]["phases"] =
            serde_json::json!([{"region": {"box": {"min": [0.0, 0.6], "max": [1.0, 1.0]}}, "modulus": 3.0}]);
    });
    for ranks in [2, 3] {
        check(&path, ranks);
    }
}

#[test]
fn surface_corrected_lps_3d() {
    // a slab of 30 planes along z, so that the windows (a halo of 9 planes) cut it
    for correction in ["position_aware", "energy"] {
        let path = scene_file("surface-bar-3d.json", correction, |v| {
            v["grid"]["max"][2] = 0.95.into();
            v["model"]["surface_correction"] = correction.into();
        });
        for ranks in [3, 5] {
            check(&path, ranks);
        }
    }
}

#[test]
fn surface_corrected_bond_2d() {
    // the bond model's factor is the mean of its ends': a halo node's own factor enters
    let path = scene_file("plate-hole-2d.json", "bond-energy", |v| {
        v["model"]["surface_correction"] = "energy".into();
        v["grid"]["spacing"] = 0.025.into();
        v["model"]["horizon"] = 0.075.into();
        v["grid"]["layer"] = serde_json::json!({"x-": 0.075, "x+": 0.075});
    });
    for ranks in [3, 4] {
        check(&path, ranks);
    }
}

#[test]
fn point_clouds_and_meshes() {
    // bond and LPS on the CSV bracket (2D), the Gmsh bracket with named sets (3D), the holed
    // plate's mesh with the energy correction (three reaches of halo)
    for (name, ranks) in [
        ("bracket-cloud-2d.json", &[1, 2, 3, 5][..]),
        ("bracket-cloud-lps-2d.json", &[2, 3][..]),
        ("bracket-mesh-3d.json", &[2, 3][..]),
        ("plate-hole-mesh-2d.json", &[2, 3][..]),
    ] {
        let path = scene_file(name, name.trim_end_matches(".json"), |v| {
            for key in ["csv", "mesh"] {
                if let Some(f) = v["nodes"][key].as_str() {
                    v["nodes"][key] = data(f).to_str().unwrap().into();
                }
            }
        });
        for &r in ranks {
            check(&path, r);
        }
    }
    // LPS on the graded mesh with the position-aware correction (two reaches of halo)
    let path = scene_file("plate-hole-mesh-2d.json", "mesh-lps", |v| {
        v["nodes"]["mesh"] = data("plate-hole-mesh-2d.msh").to_str().unwrap().into();
        v["model"] = serde_json::json!({"type": "lps", "horizon": 0.02, "plane": "stress", "bulk_modulus": 1.0,
                                        "shear_modulus": 0.6, "surface_correction": "position_aware"});
    });
    for ranks in [2, 3] {
        check(&path, ranks);
    }
}

#[test]
fn more_ranks_than_planes_leave_some_ranks_empty() {
    let path = scene_file("lps-plate-2d.json", "lps-many", |v| {
        v["grid"]["max"] = serde_json::json!([1.0, 0.1]);
        v["grid"]["layer"] = serde_json::json!({"x-": 0.075, "x+": 0.075});
    });
    // 5 planes along y over 8 ranks: three own nothing
    let parts = parts(&path, 8).unwrap();
    assert_eq!(parts.iter().filter(|(_, r)| r.row_range().unwrap().is_empty()).count(), 3);
    check(&path, 8);
}

#[test]
fn what_no_rank_finds_is_the_whole_scenes_error() {
    let path = scene_file("cantilever-3d.json", "nowhere", |v| {
        v["loads"][0]["region"] = serde_json::json!({"box": {"min": [5.0, 5.0, 5.0], "max": [6.0, 6.0, 6.0]}});
    });
    let whole = Problem::from_path(&path).unwrap_err().to_string();
    let parted = parts(&path, 3).err().unwrap();
    assert_eq!(parted, whole);
    assert!(whole.starts_with("loads[0].region: contains no node"), "{whole}");

    let path = scene_file("plate-hole-2d.json", "off-node", |v| {
        v["loads"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({"type": "point", "at": [0.505, 0.5], "force": [0.0, 1.0]}));
    });
    let parted = parts(&path, 2).err().unwrap();
    assert!(parted.starts_with("loads[1].at: no node at [0.505, 0.5]"), "{parted}");

    // held only against x: the plate may move along y and rotate
    let path = scene_file("plate-hole-2d.json", "floating", |v| {
        v["constraints"].as_array_mut().unwrap().pop();
    });
    assert!(Problem::from_path(&path).unwrap().row_system().is_err());
    assert_eq!(parts(&path, 3).err().unwrap(), "1 rigid motions free");
}

#[test]
fn models_without_per_rank_geometry_are_refused_by_name() {
    for (name, key) in [
        ("plate-crack-blend-2d.json", "model.pd_regions: the blended model has no per-rank geometry"),
        ("blend-bar-crack.json", "model.type"),
    ] {
        let e = Problem::from_path_part(&data(name), Part { rank: 0, ranks: 2 }).unwrap_err().to_string();
        assert!(e.starts_with(key) && e.contains("--gather"), "{name}: {e}");
    }
    // a body that leaves a rank's slab empty: named, with what to do
    let path = scene_file("lps-plate-2d.json", "half-body", |v| {
        v["body"] = serde_json::json!({"box": {"min": [-1.0, -1.0], "max": [2.0, 0.2]}});
    });
    if let Err(e) = parts(&path, 2) {
        panic!("{e}");
    }
    let e = parts(&path, 3).err().unwrap();
    assert!(e.starts_with("body: rank 2 of 3: its slab of the lattice (planes 12..27 of 27"), "{e}");
    let e = Problem::from_path_part(&data("cantilever-3d.json"), Part { rank: 2, ranks: 2 }).unwrap_err();
    assert!(e.to_string().starts_with("ranks:"), "{e}");
}

/// The ranks' shares of the balance add up to the whole body's (loads, reactions and the DOFs
/// each constraint holds, a DOF two constraints hold counted for the first; the moments about
/// the mean position, itself reduced from the ranks' sums), to 1e-12 of the largest force (times
/// the body's diagonal for moments): sums of the same nodal forces in another order.
fn check_balance(parts: &[(Problem, PartRows)], solution: &linpd::scene::Solution, u_windows: &[Vec<f64>]) {
    let d = solution.dim;
    let b = solution.balance.as_ref().unwrap();
    // the reference point of the moments: the ranks' position sums reduced
    let (mut sum, mut count) = ([0.0; 3], 0);
    for (p, _) in parts {
        let (s, c, _, _) = p.owned_frame();
        (0..3).for_each(|a| sum[a] += s[a]);
        count += c;
    }
    let reference: Vec<f64> = (0..d).map(|a| sum[a] / count as f64).collect();
    if d > 1 {
        let off = max_abs(reference.iter().zip(&b.reference).map(|(x, y)| x - y));
        assert!(off <= 1e-12 * max_abs(b.reference.iter().copied()).max(1.0), "reference point");
    }
    let shares: Vec<_> =
        parts.iter().zip(u_windows).map(|((p, r), u_window)| r.balance(p, u_window, &reference).unwrap()).collect();
    let scale = b
        .loads
        .iter()
        .flat_map(|l| l.force.iter())
        .chain(b.constraints.iter().flat_map(|c| c.reaction.iter()))
        .fold(0.0f64, |m, x| m.max(x.abs()));
    for (k, l) in b.loads.iter().enumerate() {
        for a in 0..d {
            let sum: f64 = shares.iter().map(|s| s.loads[k][a]).sum();
            assert!((sum - l.force[a]).abs() <= 1e-12 * scale, "load {k}");
        }
    }
    // moments about the reference, to 1e-12 of the largest force times the body's diagonal
    let diagonal = (0..d)
        .map(|a| {
            let (lo, hi) =
                solution.x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(x[a]), h.max(x[a])));
            (hi - lo).powi(2)
        })
        .sum::<f64>()
        .sqrt();
    let arm = scale * diagonal;
    for (k, l) in b.loads.iter().enumerate() {
        for (c, want) in l.moment.iter().enumerate() {
            let sum: f64 = shares.iter().map(|s| s.load_moments[k][c]).sum();
            assert!((sum - want).abs() <= 1e-12 * arm, "load {k}'s moment {sum:e} vs {want:e}");
        }
    }
    for (c, want) in b.reaction_moment.iter().enumerate() {
        let sum: f64 = shares.iter().flat_map(|s| s.reaction_moments.iter().map(move |m| m[c])).sum();
        assert!((sum - want).abs() <= 1e-12 * arm, "reactions' moment {sum:e} vs {want:e}");
    }
    for (k, c) in b.constraints.iter().enumerate() {
        assert_eq!(shares.iter().map(|s| s.held_dofs[k]).sum::<usize>(), c.dofs, "constraint {k}'s DOFs");
        for a in 0..d {
            let sum: f64 = shares.iter().map(|s| s.reactions[k][a]).sum();
            assert!(
                (sum - c.reaction[a]).abs() <= 1e-12 * scale,
                "constraint {k}'s reaction {sum:e} vs {:e}",
                c.reaction[a]
            );
        }
    }
}

/// The CSV bracket with a `phase` column (1 where `x > 0.5`), written beside the scenes; `edit`
/// changes its data lines (0-based) first.
fn phased_bracket(tag: &str, edit: impl Fn(usize, String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(data("bracket-nodes.csv")).unwrap();
    let mut out = String::from("x,y,volume,phase\n");
    for (k, line) in text.lines().filter(|l| !l.starts_with('#')).skip(1).enumerate() {
        let x: f64 = line.split(',').next().unwrap().parse().unwrap();
        out.push_str(&edit(k, format!("{line},{}", u8::from(x > 0.5))));
        out.push('\n');
    }
    let dir = std::env::temp_dir().join(format!("linpd-part-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}.csv"));
    std::fs::write(&path, out).unwrap();
    path
}

#[test]
fn heterogeneous_cracked_cloud() {
    // a phase by number (the file's column) and a crack that only some windows hold
    let csv = phased_bracket("phased", |_, l| l);
    let path = scene_file("bracket-cloud-2d.json", "cloud-crack", |v| {
        v["nodes"]["csv"] = csv.to_str().unwrap().into();
        v["model"]["material"] = serde_json::json!({
            "phases": [{"phase": 1, "modulus": 3.0}],
            "defects": [{"segment": [[0.05, 0.2], [0.25, 0.2]], "factor": 0.0}]
        });
    });
    for ranks in [2, 3] {
        check(&path, ranks);
    }
}

#[test]
fn more_ranks_than_a_clouds_bins_can_share() {
    // 3200 nodes in about 70 bins over 100 ranks: the ranks whose share a single bin exceeds
    // own nothing and build one bin that holds nodes
    let path = scene_file("bracket-cloud-2d.json", "cloud-many", |v| {
        v["nodes"]["csv"] = data("bracket-nodes.csv").to_str().unwrap().into();
    });
    let parts = parts(&path, 100).unwrap();
    let empty = parts.iter().filter(|(_, r)| r.row_range().unwrap().is_empty()).count();
    assert!(empty > 0, "no rank owns nothing");
    check(&path, 100);
}

#[test]
fn a_cloud_part_gives_the_whole_scenes_errors() {
    let parted = |path: &Path, ranks: usize| parts(path, ranks).err().unwrap();
    // a phase number no node carries, a crack that cuts no bond: the whole scene's message from
    // the ranks' or
    for (tag, material, want) in [
        ("no-phase", serde_json::json!({"phases": [{"phase": 7, "modulus": 3.0}]}), "model.material.phases[0].phase"),
        (
            "no-cut",
            serde_json::json!({"defects": [{"segment": [[5.0, 5.0], [6.0, 5.0]], "factor": 0.0}]}),
            "model.material.defects[0]",
        ),
    ] {
        let csv = phased_bracket(tag, |_, l| l);
        let path = scene_file("bracket-cloud-2d.json", tag, |v| {
            v["nodes"]["csv"] = csv.to_str().unwrap().into();
            v["model"]["material"] = material.clone();
        });
        let whole = Problem::from_path(&path).unwrap_err().to_string();
        assert!(whole.starts_with(want), "{whole}");
        assert_eq!(parted(&path, 3), whole);
    }
    // a bad line far from rank 0's nodes: rank 0's first pass reads every line
    let csv = phased_bracket("bad-line", |k, l| if k == 3100 { l.replacen(',', ",abc,", 1) } else { l });
    let path = scene_file("bracket-cloud-2d.json", "bad-line", |v| v["nodes"]["csv"] = csv.to_str().unwrap().into());
    let whole = Problem::from_path(&path).unwrap_err().to_string();
    assert!(whole.contains("line 3102: 5 fields, the header has 4"), "{whole}");
    let e = Problem::from_path_part(&path, Part { rank: 0, ranks: 4 }).unwrap_err().to_string();
    assert_eq!(e, whole);
    // two coincident nodes: the ranks whose windows hold them name them as the whole scene does
    let csv = phased_bracket("twins", |k, l| if k == 2000 { format!("{l}\n{l}") } else { l });
    let path = scene_file("bracket-cloud-2d.json", "twins", |v| v["nodes"]["csv"] = csv.to_str().unwrap().into());
    let whole = Problem::from_path(&path).unwrap_err().to_string();
    assert!(whole.contains("coincides with the node of line"), "{whole}");
    let found: Vec<String> = (0..3)
        .filter_map(|rank| Problem::from_path_part(&path, Part { rank, ranks: 3 }).err().map(|e| e.to_string()))
        .collect();
    assert!(!found.is_empty() && found.iter().all(|e| *e == whole), "{found:?} vs {whole}");
    // a surface correction with layer nodes: their fit is the whole cloud's fullest family's,
    // which no window knows: refused by name
    let text = std::fs::read_to_string(data("bracket-nodes.csv")).unwrap();
    let mut layered = String::from("x,y,volume,layer\n");
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let y: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
        layered.push_str(&format!("{line},{}\n", u8::from(y > 0.97)));
    }
    let csv = std::env::temp_dir().join(format!("linpd-part-rows-{}", std::process::id())).join("layered.csv");
    std::fs::write(&csv, layered).unwrap();
    let path = scene_file("bracket-cloud-2d.json", "layered", |v| {
        v["nodes"]["csv"] = csv.to_str().unwrap().into();
        v["model"]["surface_correction"] = "energy".into();
    });
    assert!(Problem::from_path(&path).is_ok());
    let e = Problem::from_path_part(&path, Part { rank: 1, ranks: 2 }).unwrap_err().to_string();
    assert!(
        e.starts_with(
            "model.surface_correction: a surface correction on a point cloud with `layer` nodes has no per-rank"
        ),
        "{e}"
    );
    // the discrete normalization's mean over the whole interior: refused by name (the driver
    // then runs the whole scene on every rank)
    let path = scene_file("plate-hole-mesh-2d.json", "discrete", |v| {
        v["nodes"]["mesh"] = data("plate-hole-mesh-2d.msh").to_str().unwrap().into();
        v["model"]["surface_correction"] = "none".into();
        v["model"]["micromodulus"]["normalize"] = "discrete".into();
    });
    assert!(Problem::from_path(&path).is_ok());
    let e = Problem::from_path_part(&path, Part { rank: 0, ranks: 2 }).unwrap_err().to_string();
    assert!(e.starts_with("model.micromodulus.normalize: \"discrete\"") && e.contains("--gather"), "{e}");
}

#[test]
fn a_mechanism_is_named_by_its_nodes_position() {
    // a plate one node thick in 3D: nothing holds its nodes out of plane (tests/robust_entry.rs)
    let path = scene_file("cantilever-3d.json", "flat", |v| {
        v["grid"] =
            serde_json::json!({"min": [0.0, 0.0, 0.0], "max": [1.0, 0.5, 0.1], "spacing": 0.1, "layer": {"x-": 0.3}});
        v["body"] = serde_json::json!({"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.01]}});
        v["model"]["horizon"] = 0.3.into();
    });
    assert!(Problem::from_path(&path).unwrap().row_system().is_err());
    let e = parts(&path, 1).err().unwrap();
    assert!(
        e.starts_with("constraints: the row system: the stiffness's diagonal entry at the node at [")
            && e.contains("component 2"),
        "{e}"
    );
}

#[test]
fn a_graded_clouds_windows_keep_the_whole_clouds_tolerance() {
    // fine nodes (h = 0.01) on x < 0.5, coarse ones (0.02) beyond: the windows of the coarse
    // part alone have a smallest node twice the whole cloud's. A phase boundary 1.5e-11 beyond a
    // column of coarse nodes (x = 1.5) leaves them outside at the whole cloud's tolerance
    // (1e-9 x 0.01), inside at a coarse window's (1e-9 x 0.02)
    let mut text = String::from("x,y,volume\n");
    for (x0, x1, h) in [(0.0, 0.5, 0.01), (0.5, 2.0, 0.02)] {
        let (nx, ny) = (((x1 - x0) / h) as usize, (0.5 / h) as usize);
        for i in 0..nx {
            for j in 0..ny {
                text.push_str(&format!("{},{},{}\n", x0 + (i as f64 + 0.5) * h, (j as f64 + 0.5) * h, h * h));
            }
        }
    }
    let dir = std::env::temp_dir().join(format!("linpd-part-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("graded.csv");
    std::fs::write(&csv, text).unwrap();
    let path = scene_file("bracket-cloud-2d.json", "graded", |v| {
        v["nodes"]["csv"] = csv.to_str().unwrap().into();
        v["model"]["horizon"] = 0.05.into();
        v["model"]["material"] = serde_json::json!({"phases": [{"region": {"box": {"min": [1.51 + 1.5e-11, -1.0], "max": [3.0, 1.0]}}, "modulus": 3.0}]});
        v["constraints"][0]["region"] = serde_json::json!({"box": {"min": [-1.0, -1.0], "max": [0.02, 1.0]}});
        v["loads"][0]["region"] = serde_json::json!({"box": {"min": [1.98, -1.0], "max": [3.0, 1.0]}});
    });
    check(&path, 8);
}
