//! Do the constraints remove every rigid motion?
//!
//! A component of a model's interaction graph ([`Model::for_each_partner`]: for the bond model
//! the bonds with `w > 0`) whose constrained DOFs do not pin all of
//! its rigid motions makes the reduced stiffness singular. For each component with rigid-mode
//! matrix `M` (translations and rotations about its centroid, scaled by its size) and its rows
//! `R` at constrained DOFs, the number of floating modes is `rank(M^T M) - rank(R^T R)`; ranks
//! are counted with a relative eigenvalue threshold of `1e-10` on these at most 6x6 Gram
//! matrices. This catches floating pieces before a factorization can return garbage (a
//! rotation mode of a pinned 2D body gives a tiny positive pivot, not a zero one).

use crate::eigen::symmetric_eigen;
use crate::model::Model;
use crate::DofMap;

/// A part of the body that constraints do not hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Unsupported {
    /// Nodes of the floating component (ascending; at most 10 listed).
    pub nodes: Vec<usize>,
    /// Number of nodes in the component.
    pub component_size: usize,
    /// Rigid motions left free.
    pub free_modes: usize,
}

impl std::fmt::Display for Unsupported {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} rigid motion(s) of a connected piece of {} node(s) are not constrained (nodes {:?}{}); \
             add displacement constraints on it",
            self.free_modes,
            self.component_size,
            self.nodes,
            if self.component_size > self.nodes.len() { ", ..." } else { "" }
        )
    }
}

impl std::error::Error for Unsupported {}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Numerical rank of the symmetric `n x n` (row-major) Gram matrix `g`.
fn rank(g: &[f64], n: usize) -> usize {
    let ev = symmetric_eigen(g, n).values;
    let max = ev.iter().cloned().fold(0.0f64, f64::max);
    if max <= 0.0 {
        return 0;
    }
    ev.iter().filter(|&&v| v > 1e-10 * max).count()
}

/// Checks every connected piece of the model's interaction graph; returns the first
/// unsupported one.
pub fn check_support(model: &dyn Model, dofs: &DofMap) -> Result<(), Unsupported> {
    let n = model.n_nodes();
    let d = model.dim();
    let mut parent: Vec<usize> = (0..n).collect();
    for i in 0..n {
        model.for_each_partner(i, &mut |j| {
            let (a, b) = (find(&mut parent, i), find(&mut parent, j));
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        });
    }
    let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for i in 0..n {
        let r = find(&mut parent, i);
        members.entry(r).or_default().push(i);
    }
    let x: Vec<crate::Point> = (0..n).map(|i| model.position(i)).collect();
    for nodes in members.values() {
        // Quick accept: a component with every DOF of some node constrained in 1D.
        let mut c = [0.0; 3];
        for &i in nodes {
            for k in 0..d {
                c[k] += x[i][k] / nodes.len() as f64;
            }
        }
        let size = nodes
            .iter()
            .map(|&i| (0..d).map(|k| (x[i][k] - c[k]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let modes = match d {
            1 => 1,
            2 => 3,
            _ => 6,
        };
        // mode(m, node, comp)
        let mode = |m: usize, i: usize, k: usize| -> f64 {
            if m < d {
                return if m == k { 1.0 } else { 0.0 };
            }
            let r = [(x[i][0] - c[0]) / size, (x[i][1] - c[1]) / size, (x[i][2] - c[2]) / size];
            if d == 2 {
                return if k == 0 { -r[1] } else { r[0] };
            }
            // omega = unit vector m - 3; (omega x r)_k
            let w = m - 3;
            let mut om = [0.0; 3];
            om[w] = 1.0;
            let cr = [om[1] * r[2] - om[2] * r[1], om[2] * r[0] - om[0] * r[2], om[0] * r[1] - om[1] * r[0]];
            cr[k]
        };
        let mut gm = vec![0.0; modes * modes];
        let mut gr = vec![0.0; modes * modes];
        for &i in nodes {
            for k in 0..d {
                let v: Vec<f64> = (0..modes).map(|m| mode(m, i, k)).collect();
                let constrained = dofs.is_constrained(d * i + k);
                for a in 0..modes {
                    for b in 0..modes {
                        gm[a * modes + b] += v[a] * v[b];
                        if constrained {
                            gr[a * modes + b] += v[a] * v[b];
                        }
                    }
                }
            }
        }
        let free = rank(&gm, modes).saturating_sub(rank(&gr, modes));
        let all_constrained = nodes.iter().all(|&i| (0..d).all(|k| dofs.is_constrained(d * i + k)));
        if free > 0 && !all_constrained {
            return Err(Unsupported {
                nodes: nodes.iter().take(10).cloned().collect(),
                component_size: nodes.len(),
                free_modes: free,
            });
        }
    }
    Ok(())
}
