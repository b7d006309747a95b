//! Which lattice nodes are regular: their bonds carry the homogeneous material's weights times
//! one factor (no defect and no material interface within their horizon). The lattice blend
//! gives an irregular node no local share; the graded blend keeps its cells on the lattice.
//! And the size of the lattice blend's rows before they are built ([`row_blocks`]).

use crate::BlendError;
use linpd_bond::BondOperator;
use linpd_core::{Grid, Material, Micromodulus};
use rayon::prelude::*;

/// Whether each node's bonds carry the homogeneous weights times one factor (no defect and no
/// interface within its horizon). On a full lattice with uniform volumes a homogeneous weight
/// depends on the bond's lattice offset only, so the weights of one interior node of a small
/// grid (`2 ceil(delta/h) + 2` cells a side) serve every node; a constant amplitude (the
/// discrete normalization of a grid narrower than its horizon) cancels in the ratio. Other grids
/// compare with a homogeneous operator on the whole grid.
pub fn regular_nodes(
    grid: &Grid,
    horizon: f64,
    micromodulus: &Micromodulus,
    op: &BondOperator,
) -> Result<Vec<bool>, BlendError> {
    let invalid = BlendError::Core;
    let same = |w: &[f64], w0: &mut dyn Iterator<Item = Option<f64>>| {
        let mut f = None;
        w.iter().all(|&a| match w0.next().flatten() {
            None => false,
            Some(b) => {
                let f = *f.get_or_insert(a / b);
                (a - f * b).abs() <= 1e-12 * a.abs().max(f * b.abs())
            }
        })
    };
    let d = grid.dim();
    if !(grid.is_full() && grid.has_uniform_volumes()) {
        let hom = BondOperator::on_grid(grid, horizon, micromodulus, &Material::default()).map_err(invalid)?;
        return Ok((0..grid.len())
            .into_par_iter()
            .map(|i| {
                op.weights(i).len() == hom.weights(i).len()
                    && same(op.weights(i), &mut hom.weights(i).iter().map(|&x| Some(x)))
            })
            .collect());
    }
    let h = grid.spacing();
    let r = (horizon / h).ceil() as i64 + 1;
    let side = vec![2.0 * r as f64 * h; d];
    let small = Grid::new(&vec![0.0; d], &side, h, 0.0, grid.placement()).map_err(invalid)?;
    let hom = BondOperator::on_grid(&small, horizon, micromodulus, &Material::default()).map_err(invalid)?;
    let centre = [0, 1, 2].map(|a| if a < d { small.lattice_index(0)[a] + r } else { 0 });
    let c = small
        .node_at(centre)
        .ok_or_else(|| BlendError::Invalid("the reference grid of the bond weights has no centre node".into()))?;
    let kc = small.lattice_index(c);
    let w0: std::collections::HashMap<[i64; 3], f64> = hom
        .family()
        .neighbors(c)
        .iter()
        .zip(hom.weights(c))
        .map(|(&j, &w)| {
            let kj = small.lattice_index(j as usize);
            ([0, 1, 2].map(|a| kj[a] - kc[a]), w)
        })
        .collect();
    Ok((0..grid.len())
        .into_par_iter()
        .map(|i| {
            let ki = grid.lattice_index(i);
            let mut w0s = op.family().neighbors(i).iter().map(|&j| {
                let kj = grid.lattice_index(j as usize);
                w0.get(&[0, 1, 2].map(|a| kj[a] - ki[a])).copied()
            });
            same(op.weights(i), &mut w0s)
        })
        .collect())
}

/// [`regular_nodes`] for a `material` without phases, from the bonds near its defects only: a
/// bond no longer than the horizon can cross a defect only if its end is within a horizon of
/// it ([`linpd_core::Defect::distance_to`]), so the nodes farther than a horizon and a spacing
/// are regular, and the others are judged on the operator of the sub-grid they form (each of
/// them sees there every bond a defect may cut, and the homogeneous operator it is compared
/// with is truncated alike).
pub fn regular_near_defects(
    grid: &Grid,
    horizon: f64,
    micromodulus: &Micromodulus,
    material: &Material,
) -> Result<Vec<bool>, BlendError> {
    let invalid = BlendError::Core;
    let reach = horizon + grid.spacing();
    let near: Vec<bool> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            let x = grid.position(i);
            material.defects.iter().any(|d| d.distance_to(&x) <= reach)
        })
        .collect();
    let mut regular = vec![true; grid.len()];
    if !near.iter().any(|&x| x) {
        return Ok(regular);
    }
    let window = grid.with_nodes(&near).map_err(invalid)?;
    let op = BondOperator::on_grid(&window, horizon, micromodulus, material).map_err(invalid)?;
    let on_window = regular_nodes(&window, horizon, micromodulus, &op)?;
    for (w, _) in on_window.iter().enumerate().filter(|(_, r)| !**r) {
        if let Some(i) = grid.node_at(window.lattice_index(w)) {
            regular[i] = false;
        }
    }
    Ok(regular)
}

/// The blocks of the lattice blend's rows over the nodes of `op` with blending `beta`: a node
/// with a nonlocal share (`beta > 0` on it or a family member) has Algorithm A's `|F| + 1`, a
/// local one the element stencil's `3^d` (what its `A` and `M` store, for a memory estimate
/// before they are built).
pub fn row_blocks(op: &BondOperator, beta: &[f64]) -> f64 {
    let local = 3f64.powi(op.dim() as i32);
    (0..op.n_nodes())
        .into_par_iter()
        .map(|i| {
            let family = op.family().neighbors(i);
            if beta[i] > 0.0 || family.iter().any(|&j| beta[j as usize] > 0.0) {
                family.len() as f64 + 1.0
            } else {
                local
            }
        })
        .sum()
}
