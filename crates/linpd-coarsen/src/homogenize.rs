//! Effective (homogenized) elasticity of a level ([`effective_moduli`]).
//!
//! For a level's force density `L u_i = sum_j C_ij (u_j - u_i) v_j` and a smooth `u`, Taylor
//! expansion of `u_j - u_i` about `x_i` gives, where the family of `x_i` is complete and
//! centrosymmetric (the first-order term cancels),
//!
//! ```text
//! (L u)_a = 1/2 sum_j v_j C_ij[a][c] xi_b xi_d  d_b d_d u_c  =  d_b (CC_abcd d_d u_c),
//! CC_abcd(x_i) = 1/2 sum_j v_j C_ij[a][c] xi_b xi_d,      xi = x_j - x_i               (H)
//! ```
//!
//! the linear-elastic tensor the level implies at `x_i` (1D: the bar modulus
//! `E_i = 1/2 sum_j v_j C_ij xi_ij^2`; for a bond-based level 0 this is Silling's 2000 relation).
//! `(H)` is projected onto the tensors with the symmetries of elasticity (minor `ab`, `cd`,
//! major `ab <-> cd`), which is what a strain field `d_d u_c` sees; a coarsened level's blocks
//! `C_ij` are general `d x d` matrices, a bond model's are `c e (x) e` and need no projection.
//!
//! The same tensor is the energy of an affine field: with `u = H x`, the level's energy is
//! `sum_i v_i 1/2 eps : CC(x_i) : eps`. Its volume average over a region is therefore the
//! *affine* (Voigt-type) modulus of that region of the level: it equals the homogenized modulus
//! when the level is translation invariant at its own spacing (a coarse node per period of a
//! periodic material), and is an upper bound otherwise (the level's nodes still fluctuate under a
//! uniform load; see docs/coarsening.md, "Homogenization").
//!
//! The average is taken over the *interior*: nodes farther than the level's reach (its horizon,
//! the longest bond) from every face of the box that holds the level's nodes, where `(H)`'s
//! family is complete. Bodies with holes are not recognised (the level model has no body).

use crate::LevelModel;
use serde::Serialize;

/// The interior average of `(H)` in Voigt notation (1D: `[E]`; 2D: `[xx, yy, xy]`; 3D:
/// `[xx, yy, zz, yz, xz, xy]`, engineering shear strains), with its extremes over the nodes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectiveModuli {
    /// Volume-weighted mean over the interior nodes (`n x n`, `n` = 1, 3, 6).
    pub voigt: Vec<Vec<f64>>,
    /// Entry-wise smallest over the interior nodes.
    pub min: Vec<Vec<f64>>,
    /// Entry-wise largest over the interior nodes.
    pub max: Vec<Vec<f64>>,
    /// `max_i |CC_i - mean|_F / |mean|_F` over the interior nodes (Voigt entries).
    pub spread: f64,
    /// Interior nodes averaged.
    pub nodes: usize,
    /// The reach used: nodes at least this far from every face of the box were averaged.
    pub reach: f64,
}

/// Voigt index pairs per dimension.
fn pairs(d: usize) -> &'static [(usize, usize)] {
    match d {
        1 => &[(0, 0)],
        2 => &[(0, 0), (1, 1), (0, 1)],
        _ => &[(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)],
    }
}

/// `(H)` at node `i`, symmetrized, in Voigt notation (row-major `n x n`).
pub fn nodal_moduli(model: &LevelModel, i: usize) -> Vec<f64> {
    let d = model.dim();
    let x = model.positions();
    let v = model.volumes();
    // t[a][b][c][e] = 1/2 sum_j v_j C_ij[a][c] xi_b xi_e
    let mut t = vec![0.0; d * d * d * d];
    let idx = |a: usize, b: usize, c: usize, e: usize| ((a * d + b) * d + c) * d + e;
    for (&j, blk) in model.partners(i).iter().zip(model.blocks(i).chunks(d * d)) {
        let xi: Vec<f64> = (0..d).map(|a| x[j][a] - x[i][a]).collect();
        let w = 0.5 * v[j];
        for a in 0..d {
            for c in 0..d {
                let cac = w * blk[a * d + c];
                if cac == 0.0 {
                    continue;
                }
                for b in 0..d {
                    for e in 0..d {
                        t[idx(a, b, c, e)] += cac * xi[b] * xi[e];
                    }
                }
            }
        }
    }
    let sym = |a: usize, b: usize, c: usize, e: usize| {
        (t[idx(a, b, c, e)]
            + t[idx(b, a, c, e)]
            + t[idx(a, b, e, c)]
            + t[idx(b, a, e, c)]
            + t[idx(c, e, a, b)]
            + t[idx(e, c, a, b)]
            + t[idx(c, e, b, a)]
            + t[idx(e, c, b, a)])
            / 8.0
    };
    let p = pairs(d);
    let mut out = Vec::with_capacity(p.len() * p.len());
    for &(a, b) in p {
        for &(c, e) in p {
            out.push(sym(a, b, c, e));
        }
    }
    out
}

/// The interior average of `(H)` (see the module docs) with reach `reach` (default: the level's
/// horizon). `None` when no node is that far inside the box of the level's nodes.
pub fn effective_moduli(model: &LevelModel, reach: Option<f64>) -> Option<EffectiveModuli> {
    let d = model.dim();
    let reach = reach.unwrap_or_else(|| model.horizon());
    let x = model.positions();
    let lo: Vec<f64> = (0..d).map(|a| x.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min)).collect();
    let hi: Vec<f64> = (0..d).map(|a| x.iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max)).collect();
    // a relative allowance for positions that are sums of spacings
    let slack = 1e-9 * reach;
    let interior: Vec<usize> = (0..model.len())
        .filter(|&i| (0..d).all(|a| x[i][a] - lo[a] >= reach - slack && hi[a] - x[i][a] >= reach - slack))
        .collect();
    if interior.is_empty() {
        return None;
    }
    let n = pairs(d).len();
    let nodal: Vec<Vec<f64>> = interior.iter().map(|&i| nodal_moduli(model, i)).collect();
    let v = model.volumes();
    let total: f64 = interior.iter().map(|&i| v[i]).sum();
    let mut mean = vec![0.0; n * n];
    for (k, &i) in interior.iter().enumerate() {
        mean.iter_mut().zip(&nodal[k]).for_each(|(m, c)| *m += c * v[i] / total);
    }
    let mut min = vec![f64::INFINITY; n * n];
    let mut max = vec![f64::NEG_INFINITY; n * n];
    let norm = mean.iter().map(|t| t * t).sum::<f64>().sqrt();
    let mut spread: f64 = 0.0;
    for c in &nodal {
        for k in 0..n * n {
            min[k] = min[k].min(c[k]);
            max[k] = max[k].max(c[k]);
        }
        let dev = c.iter().zip(&mean).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        spread = spread.max(if norm > 0.0 { dev / norm } else { dev });
    }
    let square = |m: Vec<f64>| m.chunks(n).map(<[f64]>::to_vec).collect();
    Some(EffectiveModuli {
        voigt: square(mean),
        min: square(min),
        max: square(max),
        spread,
        nodes: interior.len(),
        reach,
    })
}
