//! Per-node strain of a solved scene: the small-strain tensor estimated by weighted least
//! squares over each node's partners (the peridynamic shape tensor of Silling et al. 2007,
//! "Peridynamic states and constitutive modeling", section 18, the correspondence model).
//!
//! # The estimate
//!
//! For node `i` with partners `j` (those of [`Model::for_each_partner`]: the bond family,
//! cut bonds excluded; for a coarsened level the nodes its stiffness couples), bonds
//! `xi_j = x_j - x_i` and displacement differences `eta_j = u_j - u_i`, the displacement
//! gradient `G_i ~ grad u` minimizes
//!
//! ```text
//! sum_j w_j |eta_j - G xi_j|^2,        w_j = V_j (the partner's volume),
//! ```
//!
//! so that
//!
//! ```text
//! K_i = sum_j w_j xi_j (x) xi_j        (the shape tensor, d x d, symmetric),
//! B_i = sum_j w_j eta_j (x) xi_j,      G_i = B_i K_i^-1,
//! eps_i = (G_i + G_i^T) / 2            (the small strain, sym(F_i - I)).
//! ```
//!
//! For an affine field `u = c + A x`, `eta_j = A xi_j`, so `B_i = A K_i` and `G_i = A` at
//! every node whose `K_i` is invertible, surface and layer nodes included (a truncated family
//! changes `K_i`, not the identity): `eps_i = sym(A)` up to round-off, and a linearized rigid
//! motion (`A` skew) gives `eps_i = 0`.
//!
//! The weight is the partner's volume `V_j`, not `omega V_j`: the same for every model (the
//! bond-based micromodulus, the LPS influence function and a coarsened level's moduli are
//! different things), and it makes `K_i` the second moment of the family's volume. Any
//! positive weight gives the exactness above; it only changes how a non-affine field is
//! averaged.
//!
//! # Singular shape tensors
//!
//! `K_i` is singular when node `i` has fewer than `d` partners spanning `R^d` (no partner, or
//! all of them on one line in 2D/3D, or one plane in 3D: a node isolated by cracks, say). Its
//! `L D L^T` factorization then meets a pivot `<= SHAPE_RTOL trace(K_i)`; the node's strain is
//! written as 0 and its number listed in [`NodalStrain::singular`] (`strain_singular_nodes`
//! in `result.json`), never NaN.
//!
//! # Voigt order
//!
//! [`NodalStrain::voigt`] gives the tensor components (not engineering shears):
//! `[xx, yy, zz, yz, xz, xy]` in 3D, `[xx, yy, xy]` in 2D, `[xx]` in 1D.

use crate::Model;
use rayon::prelude::*;

/// A pivot of the shape tensor's `L D L^T` factorization at most this times its trace marks it
/// singular: exactly collinear families leave a pivot of a few `f64::EPSILON` times the trace.
pub const SHAPE_RTOL: f64 = 1e-10;

/// The strain tensor of every node (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct NodalStrain {
    /// Dimension `d`.
    pub dim: usize,
    /// Per node the full `3 x 3` tensor, row-major, 0 outside the `d x d` block.
    pub tensor: Vec<[f64; 9]>,
    /// Nodes whose shape tensor is singular (their strain is 0), ascending.
    pub singular: Vec<usize>,
}

/// The Voigt positions `(row, column)` in 1D, 2D and 3D (see the module docs).
pub const VOIGT: [&[(usize, usize)]; 3] =
    [&[(0, 0)], &[(0, 0), (1, 1), (0, 1)], &[(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]];

/// The Voigt components of a full `3 x 3` tensor (row-major) in dimension `dim`.
pub fn voigt_of(dim: usize, t: &[f64; 9]) -> Vec<f64> {
    VOIGT[dim - 1].iter().map(|&(a, b)| t[3 * a + b]).collect()
}

/// The names of the Voigt components in dimension `dim`: `xx, yy, xy` in 2D, ... (the suffixes
/// of `eps_*` and `sigma_*`).
pub fn voigt_labels(dim: usize) -> Vec<String> {
    const AXES: [char; 3] = ['x', 'y', 'z'];
    VOIGT[dim - 1].iter().map(|&(a, b)| format!("{}{}", AXES[a], AXES[b])).collect()
}

impl NodalStrain {
    /// The Voigt components of node `n` (1, 3 or 6; see the module docs).
    pub fn voigt(&self, n: usize) -> Vec<f64> {
        voigt_of(self.dim, &self.tensor[n])
    }
}

/// The least-squares displacement gradient `G = B K^-1` of one node from its bonds
/// `(xi, eta, w)` (`d` used components each), row-major `d x d` in a `3 x 3` array; `None`
/// when the shape tensor `K` is singular (see the module docs).
pub fn displacement_gradient(d: usize, bonds: impl IntoIterator<Item = ([f64; 3], [f64; 3], f64)>) -> Option<[f64; 9]> {
    let mut m = Moments::default();
    bonds.into_iter().for_each(|(xi, eta, w)| m.add(d, &xi, &eta, w));
    m.gradient(d)
}

/// The sums `K = sum_j w_j xi_j (x) xi_j` and `B = sum_j w_j eta_j (x) xi_j` of one node,
/// accumulated bond by bond (no allocation).
#[derive(Default)]
struct Moments {
    k: [[f64; 3]; 3],
    b: [[f64; 3]; 3],
}

impl Moments {
    fn add(&mut self, d: usize, xi: &[f64; 3], eta: &[f64; 3], w: f64) {
        for p in 0..d {
            for q in 0..d {
                self.k[p][q] += w * xi[p] * xi[q];
                self.b[p][q] += w * eta[p] * xi[q];
            }
        }
    }

    /// `G = B K^-1`, or `None` when `K` is singular.
    fn gradient(&self, d: usize) -> Option<[f64; 9]> {
        let (k, b) = (&self.k, &self.b);
        // K = L D L^T (L unit lower triangular; no square roots: a 1D gradient is b / k)
        let trace: f64 = (0..d).map(|p| k[p][p]).sum();
        let (mut l, mut diag) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
        for p in 0..d {
            for q in 0..p {
                l[p][q] = (k[p][q] - (0..q).map(|r| l[p][r] * diag[r] * l[q][r]).sum::<f64>()) / diag[q];
            }
            diag[p] = k[p][p] - (0..p).map(|r| l[p][r] * l[p][r] * diag[r]).sum::<f64>();
            if !(diag[p] > SHAPE_RTOL * trace) {
                return None;
            }
        }
        // G K = B, i.e. K g = b for every row g of G and b of B (K symmetric)
        let mut g = [0.0f64; 9];
        for row in 0..d {
            let mut y = [0.0f64; 3];
            for p in 0..d {
                y[p] = b[row][p] - (0..p).map(|r| l[p][r] * y[r]).sum::<f64>();
            }
            for p in (0..d).rev() {
                let s: f64 = (p + 1..d).map(|r| l[r][p] * g[3 * row + r]).sum();
                g[3 * row + p] = y[p] / diag[p] - s;
            }
        }
        Some(g)
    }
}

/// The strain of every node of `model` for the displacement `u` (all DOFs), with the node
/// volumes `volumes` as least-squares weights (see the module docs).
pub fn nodal_strain(model: &dyn Model, volumes: &[f64], u: &[f64]) -> NodalStrain {
    let d = model.dim();
    let n = model.n_nodes();
    assert_eq!(volumes.len(), n, "one volume per node");
    assert_eq!(u.len(), d * n, "displacement length");
    // positions read once (see `stress::energy_and_force_flux`); a lattice stencil gives the
    // bonds' `xi = h k_s` itself
    let stencil = model.lattice_stencil();
    let x: Vec<crate::Point> = match stencil {
        Some(_) => Vec::new(),
        None => (0..n).into_par_iter().map(|i| model.position(i)).collect(),
    };
    let per_node: Vec<Option<[f64; 9]>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut moments = Moments::default();
            let mut bond = |j: usize, xi: [f64; 3]| {
                let mut eta = [0.0; 3];
                for a in 0..d {
                    eta[a] = u[d * j + a] - u[d * i + a];
                }
                moments.add(d, &xi, &eta, volumes[j]);
            };
            match &stencil {
                Some(st) => st.for_each_bond(i, |j, s| {
                    let k = st.offsets[s];
                    bond(j, [0, 1, 2].map(|a| st.spacing * k[a] as f64));
                }),
                None => {
                    let xi_i = x[i];
                    model.for_each_partner(i, &mut |j| {
                        let xj = x[j];
                        bond(j, [0, 1, 2].map(|a| xj[a] - xi_i[a]));
                    })
                }
            }
            moments.gradient(d).map(|g| {
                let mut eps = [0.0; 9];
                for a in 0..d {
                    for b in 0..d {
                        eps[3 * a + b] = 0.5 * (g[3 * a + b] + g[3 * b + a]);
                    }
                }
                eps
            })
        })
        .collect();
    let singular = (0..n).filter(|&i| per_node[i].is_none()).collect();
    NodalStrain { dim: d, tensor: per_node.into_iter().map(|e| e.unwrap_or([0.0; 9])).collect(), singular }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Collinear bonds in 2D (and coplanar in 3D) leave `K` singular; a pivot far below the
    /// tolerance, not NaN.
    #[test]
    fn degenerate_families_are_singular() {
        let line = [([1.0, 1.0, 0.0], [0.5, 0.0, 0.0], 1.0), ([-2.0, -2.0, 0.0], [0.1, 0.0, 0.0], 2.0)];
        assert_eq!(displacement_gradient(2, line), None);
        let plane =
            [([1.0, 0.0, 0.0], [0.0; 3], 1.0), ([0.0, 1.0, 0.0], [0.0; 3], 1.0), ([1.0, 1.0, 0.0], [0.0; 3], 1.0)];
        assert_eq!(displacement_gradient(3, plane), None);
        assert_eq!(displacement_gradient(1, []), None);
        // one bond is enough in 1D; two independent ones in 2D
        assert_eq!(displacement_gradient(1, [([0.5, 0.0, 0.0], [0.25, 0.0, 0.0], 3.0)]).unwrap()[0], 0.5);
        let g = displacement_gradient(
            2,
            [([1.0, 0.0, 0.0], [1.0, 2.0, 0.0], 1.0), ([0.0, 1.0, 0.0], [3.0, 4.0, 0.0], 1.0)],
        )
        .unwrap();
        assert_eq!(&g[..2], &[1.0, 3.0]);
        assert_eq!(&g[3..5], &[2.0, 4.0]);
    }
}
