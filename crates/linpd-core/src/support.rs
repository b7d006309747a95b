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

/// The Gram matrices `M^T M` (all DOFs) and `R^T R` (held DOFs) of the rigid modes over a set
/// of nodes, the modes being the translations and the rotations about `centre` scaled by
/// `size`: the numbers [`check_support`] compares. Sums over disjoint node sets add, so the
/// ranks of a distributed scene each sum their own nodes and reduce the matrices with one sum
/// ([`RigidGram::add_gram`]) before [`RigidGram::free_modes`].
#[derive(Debug, Clone, PartialEq)]
pub struct RigidGram {
    dim: usize,
    centre: [f64; 3],
    size: f64,
    /// `M^T M`, `modes x modes` row-major.
    pub all: Vec<f64>,
    /// `R^T R` over the held DOFs.
    pub held: Vec<f64>,
}

impl RigidGram {
    /// Empty sums for `dim` and the modes about `centre`, lengths scaled by `size > 0`.
    pub fn new(dim: usize, centre: [f64; 3], size: f64) -> Self {
        let m = Self::modes(dim);
        RigidGram { dim, centre, size: size.max(f64::MIN_POSITIVE), all: vec![0.0; m * m], held: vec![0.0; m * m] }
    }

    /// Rigid modes in `dim` dimensions: 1, 3 or 6.
    pub fn modes(dim: usize) -> usize {
        match dim {
            1 => 1,
            2 => 3,
            _ => 6,
        }
    }

    /// Component `k` at `x` of rigid mode `m` (translations first).
    fn mode(&self, m: usize, x: &crate::Point, k: usize) -> f64 {
        let d = self.dim;
        if m < d {
            return if m == k { 1.0 } else { 0.0 };
        }
        let r = [0, 1, 2].map(|a| (x[a] - self.centre[a]) / self.size);
        if d == 2 {
            return if k == 0 { -r[1] } else { r[0] };
        }
        // omega = unit vector m - 3; (omega x r)_k
        let mut om = [0.0; 3];
        om[m - 3] = 1.0;
        let cr = [om[1] * r[2] - om[2] * r[1], om[2] * r[0] - om[0] * r[2], om[0] * r[1] - om[1] * r[0]];
        cr[k]
    }

    /// Adds the node at `x`, component `k` held when `held(k)`.
    pub fn add(&mut self, x: &crate::Point, held: impl Fn(usize) -> bool) {
        let modes = Self::modes(self.dim);
        for k in 0..self.dim {
            let v: Vec<f64> = (0..modes).map(|m| self.mode(m, x, k)).collect();
            let held = held(k);
            for a in 0..modes {
                for b in 0..modes {
                    self.all[a * modes + b] += v[a] * v[b];
                    if held {
                        self.held[a * modes + b] += v[a] * v[b];
                    }
                }
            }
        }
    }

    /// Adds another node set's sums (the same `dim`, `centre` and `size`).
    pub fn add_gram(&mut self, all: &[f64], held: &[f64]) {
        self.all.iter_mut().zip(all).for_each(|(t, v)| *t += v);
        self.held.iter_mut().zip(held).for_each(|(t, v)| *t += v);
    }

    /// Rigid motions the held DOFs leave free: `rank(M^T M) - rank(R^T R)`.
    pub fn free_modes(&self) -> usize {
        let modes = Self::modes(self.dim);
        rank(&self.all, modes).saturating_sub(rank(&self.held, modes))
    }
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
        let mut c = [0.0; 3];
        for &i in nodes {
            for k in 0..d {
                c[k] += x[i][k] / nodes.len() as f64;
            }
        }
        let size =
            nodes.iter().map(|&i| (0..d).map(|k| (x[i][k] - c[k]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max);
        let mut gram = RigidGram::new(d, c, size);
        for &i in nodes {
            gram.add(&x[i], |k| dofs.is_constrained(d * i + k));
        }
        let free = gram.free_modes();
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
