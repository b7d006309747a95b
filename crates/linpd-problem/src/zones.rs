//! Bond scenes with `model.pd_regions`: the 2D/3D blended PD / local-elasticity model of
//! [`linpd_blend::lattice`] (PD inside the regions, local elasticity beyond the transition).
//!
//! `beta` is 1 on the nodes inside any PD region and falls with the transition profile over
//! the distance (between nodes) to the nearest such node. The solve report's note gives the
//! node counts of the three zones and the stored entries against the pure bond model's.

use crate::run::append_note;
use crate::PdRegions;
use crate::{Problem, ProblemError, Solution};
use linpd_blend::{beta_from_zone, LatticeBlend};
use linpd_bond::BondOperator;
use linpd_core::family::lattice_stencil;
use linpd_core::progress::Progress;
use linpd_core::{Grid, Material, GEOMETRY_RTOL};
use rayon::prelude::*;
use std::time::Instant;

impl Problem {
    /// The scene's blended model (its bond model must have `pd_regions`).
    pub fn lattice_blend(&self) -> Result<LatticeBlend, ProblemError> {
        let b = self.bond_model()?;
        let zone = b.zone.as_ref().ok_or_else(|| ProblemError::invalid("model.pd_regions", "missing"))?;
        let grid = self.lattice()?;
        let op = self.operator()?;
        let dim = grid.dim();
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
        let (mask, _) = self.constrained();
        let constrained: Vec<bool> = (0..grid.len()).map(|i| (0..dim).any(|a| mask[dim * i + a])).collect();
        let inside = match &zone.regions {
            PdRegions::Given(regions) => {
                let tol = GEOMETRY_RTOL * grid.spacing();
                (0..grid.len())
                    .map(|i| {
                        let x = grid.position(i);
                        regions.iter().any(|r| r.contains(&x, dim, tol))
                    })
                    .collect()
            }
            PdRegions::Auto { radius } => {
                let (hard, soft) = self.features(regular.as_deref(), &constrained)?;
                // a node beside a defect, an interface or a removed site may have no local share
                // at all (its family and difference stencils cross them): its whole family must
                // be PD, so those features get at least one horizon
                let mut inside = dilate(grid, &hard, radius.max(b.horizon));
                for (i, x) in dilate(grid, &soft, *radius).into_iter().enumerate() {
                    inside[i] |= x;
                }
                inside
            }
        };
        let beta = beta_from_zone(grid, &inside, zone.transition, zone.profile);
        // supports in the layer stand for the body beyond them
        let mirrored: Vec<bool> = (0..grid.len()).map(|i| grid.is_layer(i) && constrained[i]).collect();
        LatticeBlend::new(&op, grid, b.horizon, beta, regular.as_deref(), &mirrored)
            .map_err(|e| ProblemError::invalid("model", e.to_string()))
    }

    /// The nodes `"pd_regions": "auto"` refines around: where the solution is rough or the
    /// local model cannot go. A node is a feature when
    /// * its family is not regular (a defect cuts a bond of it, or a material interface is
    ///   within its horizon),
    /// * a lattice neighbour (the `3^d` box) inside the grid's box was removed by the scene's
    ///   `body` (a hole, a notch, or a face of the body cut from the box: stress
    ///   concentrations; the grid box's own faces are free surfaces that the local model's
    ///   softened elements carry, measured in docs/models.md),
    /// * it is loaded and a box neighbour is not, or the other way round (point loads, the
    ///   edges of loaded regions), or
    /// * it is constrained and a box neighbour is not, or the other way round (the edges of
    ///   supports, where the local and the nonlocal boundary conditions differ most).
    ///
    /// Returned as `(hard, soft)`: the first two kinds, which no local share may reach, and the
    /// last two. `Err` when there is none: nothing to refine around.
    fn features(&self, regular: Option<&[bool]>, constrained: &[bool]) -> Result<(Vec<bool>, Vec<bool>), ProblemError> {
        let grid = self.lattice()?;
        let d = grid.dim();
        let f = self.load_vector();
        let loaded: Vec<bool> = (0..grid.len()).map(|i| (0..d).any(|a| f[d * i + a] != 0.0)).collect();
        // 0: none, 1: soft, 2: hard
        let kind: Vec<u8> = (0..grid.len())
            .into_par_iter()
            .map(|i| {
                if regular.is_some_and(|r| !r[i]) {
                    return 2;
                }
                let mut soft = false;
                let k = grid.lattice_index(i);
                let span = |a: usize| if a < d { -1i64..=1 } else { 0..=0 };
                for o2 in span(2) {
                    for o1 in span(1) {
                        for o0 in span(0) {
                            let kk = [k[0] + o0, k[1] + o1, k[2] + o2];
                            match grid.node_at(kk) {
                                None if grid.box_contains(kk) => return 2,
                                Some(j) if loaded[j] != loaded[i] || constrained[j] != constrained[i] => soft = true,
                                _ => {}
                            }
                        }
                    }
                }
                u8::from(soft)
            })
            .collect();
        if kind.iter().all(|&k| k == 0) {
            return Err(ProblemError::invalid(
                "model.pd_regions",
                "\"auto\" found nothing to refine around (no defect, material interface, hole, load edge or \
                 support edge): give the regions, or drop pd_regions",
            ));
        }
        Ok((kind.iter().map(|&k| k == 2).collect(), kind.iter().map(|&k| k == 1).collect()))
    }
}

/// The nodes within `radius` of a node of `features` (inclusive).
fn dilate(grid: &Grid, features: &[bool], radius: f64) -> Vec<bool> {
    let h = grid.spacing();
    let offsets = lattice_stencil(grid.dim(), radius / h);
    let mut inside = features.to_vec();
    for i in (0..grid.len()).filter(|&i| features[i]) {
        let k = grid.lattice_index(i);
        for o in &offsets {
            if let Some(j) = grid.node_at([k[0] + o[0], k[1] + o[1], k[2] + o[2]]) {
                inside[j] = true;
            }
        }
    }
    inside
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
