//! `"type": "blend"` and `"type": "ce"` scenes: the 1D blended PD/CE model of Seleson,
//! Beneddine & Prudhomme (2013) and its pure-CE limit, eq. (28).
//!
//! The generic scene keys keep their meaning: `grid` gives the domain `(0, L)` (`min` must be
//! 0, no layer: the blended model has local Dirichlet conditions at both ends) and `dx`;
//! `model.horizon` and `model.micromodulus` give `eps` (a multiple of `dx`), the kernel and `K`
//! (discrete normalization, the paper's `eps^2 -> N(N+1) dx^2`); constraints must fix exactly the
//! end nodes `x = 0` and `x = L`; loads are point loads on nodes (`b_i = delta_ip / dx` is a
//! unit force) or body-force densities on boxes; `model.material` (phases, bond rule, defects)
//! is the bond model's, entering the blended rows as [`linpd_blend::material`] derives.
//! Solutions carry the force balance: per load its nodes and force, per constraint its
//! reaction ([`linpd_blend::BlendSolution::reactions`]).

use crate::raw::{RawBlending, RawModelKind, RawNormalize, RawProblem, RawSolverKind};
use crate::{Balance, BlendScene, Constraint, ConstraintBalance, Load, LoadBalance, Problem, ProblemError, Solution};
use linpd_blend::{solve_model, BlendParams, BlendSolver, Blending, ModelKind, Regions};
use linpd_core::progress::Progress;
use linpd_core::{Grid, Material, Region};

/// Validates the blend-specific keys and translates constraints and loads.
pub(crate) fn scene(
    kind: RawModelKind,
    raw: &RawProblem,
    grid: &Grid,
    horizon: f64,
    material: Material,
    constraints: &[Constraint],
    loads: &[Load],
) -> Result<BlendScene, ProblemError> {
    let m = &raw.model;
    let Some(grid_raw) = raw.grid.as_ref() else {
        return Err(ProblemError::invalid("grid", "required for blend and ce models"));
    };
    let name = if kind == RawModelKind::Ce { "ce" } else { "blend" };
    let mm = m
        .micromodulus
        .as_ref()
        .ok_or_else(|| ProblemError::invalid("model.micromodulus", "missing: the kernel and its normalization"))?;
    if raw.dimension != 1 {
        return Err(ProblemError::invalid(
            "dimension",
            format!("{name} models are 1D, got dimension {}", raw.dimension),
        ));
    }
    if grid_raw.min[0] != 0.0 {
        return Err(ProblemError::invalid("grid.min", format!("{name} models live on (0, L): min must be [0.0]")));
    }
    if !grid_raw.has_no_layer(1) {
        return Err(ProblemError::invalid(
            "grid.layer",
            format!("{name} models have local Dirichlet conditions at both ends: no layer"),
        ));
    }
    if mm.normalize != RawNormalize::Discrete {
        return Err(ProblemError::invalid(
            "model.micromodulus.normalize",
            format!("{name} models use the discrete normalization (eq. (19)): set \"discrete\""),
        ));
    }
    // partial_volume, plane and (for ce) the blending keys are not keys of these models:
    // rejected by `check_model_keys` before this point. `material` was validated (paths,
    // moduli, defect shapes) by `crate::problem::material`.
    let blended = kind == RawModelKind::Blend;
    let (regions, blending) = if blended {
        let r = m.regions.ok_or_else(|| {
            ProblemError::invalid("model.regions", "missing: [L1, L2, L3, L4] with 0 < L1 < L2 < L3 < L4 < L")
        })?;
        let b = match m.blending {
            None => {
                return Err(ProblemError::invalid("model.blending", "missing: constant, linear, cubic or piecewise"))
            }
            Some(RawBlending::Constant) => Blending::Constant { value: m.blending_value.unwrap_or(0.5) },
            Some(RawBlending::Linear) => Blending::Linear,
            Some(RawBlending::Cubic) => Blending::Cubic,
            Some(RawBlending::Piecewise) => {
                let t = m.blending_table.as_ref().ok_or_else(|| {
                    ProblemError::invalid(
                        "model.blending_table",
                        "piecewise blending needs {\"s\": [...], \"beta\": [...]}",
                    )
                })?;
                Blending::Piecewise { s: t.s.clone(), beta: t.beta.clone() }
            }
        };
        if m.blending_value.is_some() && m.blending != Some(RawBlending::Constant) {
            return Err(ProblemError::invalid("model.blending_value", "only constant blending takes a value"));
        }
        if m.blending_table.is_some() && m.blending != Some(RawBlending::Piecewise) {
            return Err(ProblemError::invalid("model.blending_table", "only piecewise blending takes a table"));
        }
        (Regions { l1: r[0], l2: r[1], l3: r[2], l4: r[3] }, b)
    } else {
        // Pure CE: any admissible geometry, beta = 0 everywhere.
        let l = grid_raw.max[0];
        (Regions { l1: 0.25 * l, l2: 0.4 * l, l3: 0.6 * l, l4: 0.75 * l }, Blending::Linear)
    };
    let length = grid_raw.max[0];
    let params = BlendParams {
        length,
        dx: grid_raw.spacing,
        horizon,
        modulus: mm.modulus.unwrap_or(1.0),
        kernel: Problem::kernel_of(mm, horizon)?,
        regions,
        blending,
        ce_spacing: m.ce_spacing,
        hog: m.hog.unwrap_or(false),
        material,
    };
    let kind = if blended { ModelKind::Blended } else { ModelKind::PureCe };
    params.validate().and_then(|()| params.check_material(kind)).map_err(|e| match e {
        linpd_blend::BlendError::Parameter { name, reason } if name == "horizon" => {
            ProblemError::invalid("model.horizon", reason)
        }
        linpd_blend::BlendError::Parameter { name, reason } if name == "dx" => {
            ProblemError::invalid("grid.spacing", reason)
        }
        linpd_blend::BlendError::Parameter { name, reason } if name == "length" => {
            ProblemError::invalid("grid.max", reason)
        }
        linpd_blend::BlendError::Parameter { name, reason } => ProblemError::invalid(format!("model.{name}"), reason),
        other => ProblemError::invalid("model", other.to_string()),
    })?;
    // Dirichlet conditions: exactly the two end nodes.
    let n = grid.len();
    let (mut left, mut right) = (None, None);
    let mut constraint_ends = vec![[false; 2]; constraints.len()];
    for (k, c) in constraints.iter().enumerate() {
        for node in c.region.nodes(grid) {
            let x = grid.position(node)[0];
            let v = c.displacement(&[x], 0);
            if node == 0 {
                left = Some(v);
                constraint_ends[k][0] = true;
            } else if node == n - 1 {
                right = Some(v);
                constraint_ends[k][1] = true;
            } else {
                return Err(ProblemError::invalid(
                    format!("constraints[{k}].region"),
                    format!(
                        "{name} models take Dirichlet conditions at x = 0 and x = L only; the region contains x = {x}"
                    ),
                ));
            }
        }
    }
    let (u_left, u_right) = match (left, right) {
        (Some(a), Some(b)) => (a, b),
        _ => {
            return Err(ProblemError::invalid(
                "constraints",
                format!(
                    "{name} models need u fixed at both x = 0 and x = L ({} given)",
                    left.is_some() as u8 + right.is_some() as u8
                ),
            ))
        }
    };
    let mut out = Vec::new();
    let mut load_of = Vec::new();
    let mut load_kinds = Vec::new();
    for (k, l) in loads.iter().enumerate() {
        load_kinds.push(if matches!(l, Load::Point { .. }) { "point" } else { "body" });
        match l {
            Load::Point { node, force } => {
                out.push(linpd_blend::Load::Point { x: grid.position(*node)[0], force: force[0] });
                load_of.push(k);
            }
            Load::Body { region, density } => {
                let boxes = match region {
                    Region::Box { min, max } => vec![(min[0], max[0])],
                    Region::Union(parts) => parts
                        .iter()
                        .map(|r| match r {
                            Region::Box { min, max } => Ok((min[0], max[0])),
                            _ => Err(ProblemError::invalid(
                                format!("loads[{k}].region"),
                                "blend body loads take boxes or unions of boxes",
                            )),
                        })
                        .collect::<Result<_, _>>()?,
                    _ => {
                        return Err(ProblemError::invalid(
                            format!("loads[{k}].region"),
                            "blend body loads take boxes or unions of boxes",
                        ))
                    }
                };
                // A node in two boxes of a union is loaded once, as for lattice scenes: merge
                // boxes that overlap or touch (closed intervals sharing a node).
                let mut boxes: Vec<(f64, f64)> = boxes;
                boxes.sort_by(|p, q| p.0.total_cmp(&q.0));
                let tol = linpd_core::GEOMETRY_RTOL * grid.spacing();
                let mut merged: Vec<(f64, f64)> = Vec::new();
                for (a, b) in boxes {
                    match merged.last_mut() {
                        Some(last) if a <= last.1 + tol => last.1 = last.1.max(b),
                        _ => merged.push((a, b)),
                    }
                }
                for (a, b) in merged {
                    out.push(linpd_blend::Load::Body { from: a, to: b, density: density[0] });
                    load_of.push(k);
                }
            }
            Load::Resultant { .. } => {
                return Err(ProblemError::invalid(
                    format!("loads[{k}]"),
                    format!("{name} models take point and body loads (a resultant needs the model's node volumes)"),
                ))
            }
        }
    }
    let solver = match raw.solver.kind {
        RawSolverKind::Auto => BlendSolver::Auto,
        RawSolverKind::Lu => BlendSolver::Lu,
        RawSolverKind::Dense => BlendSolver::Dense,
        other => {
            return Err(ProblemError::invalid(
                "solver.type",
                format!("{other:?} is not available for {name} models (the blended matrix is unsymmetric): use auto, lu or dense").to_lowercase(),
            ))
        }
    };
    Ok(BlendScene { params, kind, u_left, u_right, loads: out, load_of, load_kinds, constraint_ends, solver })
}

/// Solves a blend scene.
pub(crate) fn solve(name: &str, b: &BlendScene, progress: &dyn Progress) -> Result<Solution, ProblemError> {
    progress.phase(&format!(
        "assembling the 1D {:?} model: dx = {}, N = {}",
        b.kind,
        b.params.dx,
        b.params.n_side().unwrap_or(0)
    ));
    let s = solve_model(&b.params, b.kind, b.u_left, b.u_right, &b.loads, b.solver).map_err(|e| match e {
        // Point loads are checked against the mesh here (a coarse CE mesh has fewer nodes than
        // the grid): name the scene's load, not the blend load it became.
        linpd_blend::BlendError::Parameter { name, reason } => match name
            .strip_prefix("loads[")
            .and_then(|r| r.split_once(']'))
            .and_then(|(k, rest)| Some((b.load_of.get(k.parse::<usize>().ok()?)?, rest)))
        {
            Some((k, rest)) => ProblemError::invalid(format!("loads[{k}]{rest}"), reason),
            None => ProblemError::invalid(name, reason),
        },
        other => ProblemError::Blend(other),
    })?;
    progress.phase(&format!(
        "done: {} unknowns, solver {}, relative residual {:.2e}",
        s.report.n, s.report.solver, s.report.rel_residual
    ));
    Ok(solution(name, b, s))
}

/// The [`Solution`] of a solved blend scene (here or elsewhere, [`crate::RowSystem`]).
pub(crate) fn solution(name: &str, b: &BlendScene, s: linpd_blend::BlendSolution) -> Solution {
    let balance = balance(b, &s);
    Solution {
        name: name.to_string(),
        dim: 1,
        x: s.x.iter().map(|&x| [x, 0.0, 0.0]).collect(),
        u: s.u,
        is_layer: vec![false; s.x.len()],
        volumes: Vec::new(),
        n_bonds: 0,
        report: s.report,
        balance: Some(balance),
        strain_energy_density: None,
        strain: None,
        dilatation: None,
    }
}

/// The balance of a solved blend scene (the definitions of [`crate::balance`]): per scene load
/// the mesh nodes it caught and its total force, per constraint the end nodes it holds (an end
/// two constraints hold belongs to the first) and their reactions `A u - f`.
fn balance(b: &BlendScene, s: &linpd_blend::BlendSolution) -> Balance {
    let tol = 1e-9 * b.params.dx;
    let mut loads: Vec<LoadBalance> =
        b.load_kinds.iter().map(|&kind| LoadBalance { kind, nodes: 0, force: vec![0.0] }).collect();
    for (l, &k) in b.loads.iter().zip(&b.load_of) {
        // The loads were applied in the solve, so each one's nodes exist.
        let nodes = l.nodes(&s.x, tol).unwrap_or_default();
        let f = linpd_blend::nodal_forces(&s.x, std::slice::from_ref(l), tol).unwrap_or_default();
        loads[k].nodes += nodes.len();
        loads[k].force[0] += f.iter().sum::<f64>();
    }
    let mut owned = [false; 2];
    let constraints = b
        .constraint_ends
        .iter()
        .map(|ends| {
            let mut reaction = 0.0;
            let mut dofs = 0;
            for e in 0..2 {
                if ends[e] && !owned[e] {
                    owned[e] = true;
                    dofs += 1;
                    reaction += s.reactions[e];
                }
            }
            ConstraintBalance { nodes: ends.iter().filter(|&&h| h).count(), dofs, reaction: vec![reaction] }
        })
        .collect();
    Balance::from_parts(1, loads, constraints)
}
