//! Node positions: the fine lattice `x = k dx` where the model is nonlocal, and optionally a
//! coarse CE mesh of spacing `dx_CE = 2^k dx` in the pure CE regions (section 5.2.4).
//!
//! A node's row is nonlocal when `beta` is nonzero within its horizon, i.e. for
//! `x in (L1 - eps, L4 + eps)`; its stencil reaches `eps` further. The fine zone is therefore
//! `[L1 - 2 eps, L4 + 2 eps]`, clipped to the domain and snapped outward to the fine lattice;
//! rows near its edges are pure CE rows, which use the non-uniform 3-point stencil. Outside it, coarse nodes step away from the zone by `dx_CE` towards the domain ends;
//! the last interval before an end is shorter when `dx_CE` does not divide the remaining length.
//! CE rows use the non-uniform second difference of section 5.2.4, exact for quadratics.

/// The nodes of a 1D blended model.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Positions, ascending.
    pub x: Vec<f64>,
    /// Fine-lattice index of each node (`x = x0 + k dx`), `None` for coarse nodes.
    pub fine: Vec<Option<i64>>,
    /// Node of fine-lattice index `k`: `k - k_first` into this table.
    fine_nodes: Vec<usize>,
    k_first: i64,
    /// Lattice origin and spacing.
    pub x0: f64,
    /// Fine spacing.
    pub dx: f64,
}

impl Mesh {
    /// Uniform nodes `x0 + k dx`, `k = 0..=n`.
    pub fn uniform(x0: f64, dx: f64, n: usize) -> Self {
        let x = (0..=n).map(|k| x0 + k as f64 * dx).collect();
        Mesh { x, fine: (0..=n).map(|k| Some(k as i64)).collect(), fine_nodes: (0..=n).collect(), k_first: 0, x0, dx }
    }

    /// Fine nodes on lattice indices `k_lo..=k_hi` of `x0 + k dx`, coarse nodes of spacing `dx_ce`
    /// from there to `lo` and `hi`.
    pub fn graded(x0: f64, dx: f64, k_lo: i64, k_hi: i64, dx_ce: f64, lo: f64, hi: f64) -> Self {
        let tol = 1e-9 * dx;
        let zl = x0 + k_lo as f64 * dx;
        let zr = x0 + k_hi as f64 * dx;
        let mut left = Vec::new();
        let mut p = zl - dx_ce;
        while p > lo + tol {
            left.push(p);
            p -= dx_ce;
        }
        if zl > lo + tol {
            left.push(lo);
        }
        left.reverse();
        let mut x = left.clone();
        let mut fine = vec![None; left.len()];
        let mut fine_nodes = Vec::new();
        for k in k_lo..=k_hi {
            fine_nodes.push(x.len());
            x.push(x0 + k as f64 * dx);
            fine.push(Some(k));
        }
        let mut p = zr + dx_ce;
        while p < hi - tol {
            x.push(p);
            fine.push(None);
            p += dx_ce;
        }
        if zr < hi - tol {
            x.push(hi);
            fine.push(None);
        }
        Mesh { x, fine, fine_nodes, k_first: k_lo, x0, dx }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// True without nodes.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// Node at fine index `k`, if it exists.
    pub fn node_of_fine(&self, k: i64) -> Option<usize> {
        let i = k - self.k_first;
        (i >= 0 && (i as usize) < self.fine_nodes.len()).then(|| self.fine_nodes[i as usize])
    }
    /// Dual cell length `(x_{i+1} - x_{i-1}) / 2` (half cells at the ends).
    pub fn dual_length(&self, i: usize) -> f64 {
        let n = self.x.len();
        let left = if i > 0 { self.x[i] - self.x[i - 1] } else { 0.0 };
        let right = if i + 1 < n { self.x[i + 1] - self.x[i] } else { 0.0 };
        0.5 * (left + right)
    }
}
