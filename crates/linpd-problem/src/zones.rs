//! Bond scenes with `model.pd_regions`: the 2D/3D blended PD / local-elasticity model of
//! [`linpd_blend::lattice`] (PD inside the regions, local elasticity beyond the transition).
//!
//! `beta` is 1 on the nodes inside any PD region and falls with the transition profile over
//! the distance (between nodes) to the nearest such node. The solve report's note gives the
//! node counts of the three zones and the stored entries against the pure bond model's.

use crate::run::append_note;
use crate::{Problem, ProblemError, Solution};
use linpd_blend::{beta_from_zone, LatticeBlend};
use linpd_bond::BondOperator;
use linpd_core::progress::Progress;
use linpd_core::{Material, GEOMETRY_RTOL};
use std::time::Instant;

impl Problem {
    /// The scene's blended model (its bond model must have `pd_regions`).
    pub fn lattice_blend(&self) -> Result<LatticeBlend, ProblemError> {
        let b = self.bond_model()?;
        let zone = b.zone.as_ref().ok_or_else(|| ProblemError::invalid("model.pd_regions", "missing"))?;
        let grid = self.lattice()?;
        let op = self.operator()?;
        let dim = grid.dim();
        let tol = GEOMETRY_RTOL * grid.spacing();
        let inside: Vec<bool> = (0..grid.len())
            .map(|i| {
                let x = grid.position(i);
                zone.regions.iter().any(|r| r.contains(&x, dim, tol))
            })
            .collect();
        let beta = beta_from_zone(grid, &inside, zone.transition, zone.profile);
        // with phases or defects, a node is regular when its bonds carry the homogeneous weights
        // times one factor (no defect and no interface within its horizon)
        let regular = if b.material.is_homogeneous() {
            None
        } else {
            let hom = BondOperator::on_grid(grid, b.horizon, &b.micromodulus, &Material::default())
                .map_err(|e| ProblemError::invalid("model", e.to_string()))?;
            Some(
                (0..grid.len())
                    .map(|i| {
                        let (w, w0) = (op.weights(i), hom.weights(i));
                        w.len() == w0.len() && {
                            let f = w[0] / w0[0];
                            w.iter().zip(w0).all(|(a, b)| (a - f * b).abs() <= 1e-12 * a.abs().max(f * b.abs()))
                        }
                    })
                    .collect::<Vec<bool>>(),
            )
        };
        // supports in the layer stand for the body beyond them
        let (mask, _) = self.constrained();
        let mirrored: Vec<bool> =
            (0..grid.len()).map(|i| grid.is_layer(i) && (0..dim).any(|a| mask[dim * i + a])).collect();
        LatticeBlend::new(&op, grid, b.horizon, beta, regular.as_deref(), &mirrored)
            .map_err(|e| ProblemError::invalid("model", e.to_string()))
    }
}

/// Solves a blended scene (called by [`Problem::solve`] with the time the solve started).
pub(crate) fn solve(problem: &Problem, t0: Instant, progress: &dyn Progress) -> Result<Solution, ProblemError> {
    progress.phase(&format!("building the blended model: {} nodes", problem.nodes.len()));
    let model = problem.lattice_blend()?;
    let z = model.zones();
    let describe = format!(
        "blend: {} PD, {} transition, {} local nodes; {} stored entries, {:.3}x the bond model's {}",
        z.pd,
        z.transition,
        z.local,
        z.nnz,
        z.nnz as f64 / z.nnz_pd as f64,
        z.nnz_pd
    );
    progress.phase(&describe);
    let (u, mut report) = problem.timed_solve(&model, t0, progress)?;
    append_note(&mut report, describe);
    // the bond model's directed bonds, from its stored entries d^2 (n + bonds)
    let d = problem.dim();
    let n_bonds = z.nnz_pd / (d * d) - problem.nodes.len();
    problem.bond_solution(&model, n_bonds, u, report)
}
