//! Per-node stress of a solved scene (issue #32): the Cauchy stress of the model's elastic
//! constants and the nodal strain ([`hooke`]), its von Mises and principal values, and for
//! bond-based models the peridynamic (force-flux) stress ([`force_flux`]).
//!
//! # Hooke
//!
//! With the node's `E`, `nu` ([`crate::elastic`]; `lambda = E nu / ((1 + nu)(1 - 2 nu))`,
//! `mu = E / (2 (1 + nu))`) and its strain `eps` ([`crate::fields`]):
//!
//! * 3D: `sigma = lambda tr(eps) I + 2 mu eps`;
//! * plane strain: the same with `eps_zz = 0` (so `sigma_zz = lambda (eps_xx + eps_yy)`);
//! * plane stress: `lambda* = 2 lambda mu / (lambda + 2 mu)` in place of `lambda`, `sigma_zz = 0`;
//! * 1D: `sigma = E eps`.
//!
//! An affine field has the exact strain at every node, so its Hooke stress is exact there.
//!
//! # Force flux (Lehoucq & Silling 2008)
//!
//! The peridynamic stress `nu(x)` of Lehoucq & Silling ("Force flux and the peridynamic stress
//! tensor", JMPS 56, 2008, eq. (26)) is defined so that `nu n` integrated over a plane is the
//! force the bonds crossing it carry. On the nodes it is taken in its virial form, the pair
//! forces of the node's bonds times half their vectors over the node's volume:
//!
//! ```text
//! nu_i = 1 / (2 V_i) sum_j xi_ij (x) f_ij,     f_ij = -A_ij (u_j - u_i),   xi_ij = x_j - x_i,
//! ```
//!
//! with `A_ij` the blocks of the stiffness (the linearized pair force of bond `ij` on node `i`).
//! For a field that is invariant under a lattice translation across a plane, the sum of
//! `nu_i n V_i / h` over one layer of nodes parallel to it is the force through the plane
//! (each bond spanning `k` layers is counted `k` times from its two ends, as it crosses `k`
//! planes); elsewhere the two differ by the field's variation over a horizon. Under a uniform
//! strain `nu = C eps` with `C` the tensor of the bonds' energy, `3K eps` under an isotropic
//! extension `eps I` in 3D.
//!
//! # Von Mises and principal stresses
//!
//! Of the full `3 x 3` tensor (with the `sigma_zz` of the plane model in 2D): `sigma_vm =
//! sqrt(3/2 s:s)`, `s` the deviator; principal stresses of the in-plane `d x d` block (1, 2 or
//! 3 values), in descending order.

use crate::fields::{NodalStrain, VOIGT};
use linpd_core::{Model, PlaneModel};
use rayon::prelude::*;

/// A stress tensor per node.
#[derive(Debug, Clone, PartialEq)]
pub struct NodalStress {
    /// Dimension `d`.
    pub dim: usize,
    /// Per node the full `3 x 3` tensor, row-major (`sigma_zz` of the plane model in 2D).
    pub tensor: Vec<[f64; 9]>,
}

impl NodalStress {
    /// The Voigt components of node `n` (`[xx, yy, zz, yz, xz, xy]` in 3D, `[xx, yy, xy]` in
    /// 2D, `[xx]` in 1D).
    pub fn voigt(&self, n: usize) -> Vec<f64> {
        crate::fields::voigt_of(self.dim, &self.tensor[n])
    }

    /// The von Mises stress of node `n`.
    pub fn von_mises(&self, n: usize) -> f64 {
        von_mises(&self.tensor[n])
    }

    /// The principal stresses of node `n`'s `d x d` block, descending.
    pub fn principal(&self, n: usize) -> Vec<f64> {
        let d = self.dim;
        let t = &self.tensor[n];
        let m: Vec<f64> = (0..d * d).map(|k| 0.5 * (t[3 * (k / d) + k % d] + t[3 * (k % d) + k / d])).collect();
        let mut e = linpd_core::eigen::symmetric_eigen(&m, d).values;
        e.sort_by(|a, b| b.total_cmp(a));
        e
    }
}

/// The von Mises stress `sqrt(3/2 s:s)` of a full `3 x 3` tensor (row-major), `s` its deviator.
pub fn von_mises(t: &[f64; 9]) -> f64 {
    let p = (t[0] + t[4] + t[8]) / 3.0;
    let mut ss = 0.0;
    for a in 0..3 {
        for b in 0..3 {
            let s = t[3 * a + b] - if a == b { p } else { 0.0 };
            ss += s * s;
        }
    }
    (1.5 * ss).sqrt()
}

/// The quantity of the stress map `linpd solve` draws (`output.stress_map`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StressMap {
    /// `sigma_vm` (default).
    #[default]
    VonMises,
    /// The largest principal stress.
    MaxPrincipal,
    /// One component `sigma_ab` (`a <= b < d`).
    Component(usize, usize),
}

impl StressMap {
    /// `"von_mises"`, `"max_principal"` or `"sigma_<ab>"` (`ab` one of `xx, yy, zz, xy, xz,
    /// yz` within the dimension `d`).
    pub(crate) fn parse(key: Option<&str>, d: usize) -> Result<Self, crate::ProblemError> {
        let names: Vec<String> = crate::fields::voigt_labels(d).iter().map(|v| format!("sigma_{v}")).collect();
        match key {
            None | Some("von_mises") => Ok(StressMap::VonMises),
            Some("max_principal") => Ok(StressMap::MaxPrincipal),
            Some(k) => match names.iter().position(|n| n == k) {
                Some(i) => Ok(StressMap::Component(VOIGT[d - 1][i].0, VOIGT[d - 1][i].1)),
                None => Err(crate::ProblemError::invalid(
                    "output.stress_map",
                    format!("{k:?} is not one of von_mises, max_principal, {}", names.join(", ")),
                )),
            },
        }
    }

    /// The quantity at node `n` of `s`.
    pub fn value(&self, s: &NodalStress, n: usize) -> f64 {
        match *self {
            StressMap::VonMises => s.von_mises(n),
            StressMap::MaxPrincipal => s.principal(n)[0],
            StressMap::Component(a, b) => s.tensor[n][3 * a + b],
        }
    }

    /// Its name: the file stem `stress_<name>` and the colour bar's label.
    pub fn name(&self) -> String {
        const AXES: [char; 3] = ['x', 'y', 'z'];
        match *self {
            StressMap::VonMises => "von_mises".into(),
            StressMap::MaxPrincipal => "max_principal".into(),
            StressMap::Component(a, b) => format!("sigma_{}{}", AXES[a], AXES[b]),
        }
    }
}

/// The Cauchy stress of every node from its strain and its `(E, nu)` (`nu` `None` in 1D), with
/// the plane model in 2D (see the module docs).
pub fn hooke(
    strain: &NodalStrain,
    plane: Option<PlaneModel>,
    constants: &dyn Fn(usize) -> (f64, Option<f64>),
) -> NodalStress {
    let d = strain.dim;
    let tensor = (0..strain.tensor.len())
        .map(|n| {
            let eps = &strain.tensor[n];
            let (e, nu) = constants(n);
            let mut s = [0.0; 9];
            let Some(nu) = nu else {
                s[0] = e * eps[0];
                return s;
            };
            let (lambda, mu) = (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)));
            let lambda_in = if d == 2 && plane == Some(PlaneModel::Stress) {
                2.0 * lambda * mu / (lambda + 2.0 * mu)
            } else {
                lambda
            };
            let trace: f64 = (0..d).map(|a| eps[4 * a]).sum();
            for a in 0..d {
                for b in 0..d {
                    s[3 * a + b] = 2.0 * mu * eps[3 * a + b] + if a == b { lambda_in * trace } else { 0.0 };
                }
            }
            if d == 2 && plane != Some(PlaneModel::Stress) {
                s[8] = lambda * trace;
            }
            s
        })
        .collect();
    NodalStress { dim: d, tensor }
}

/// The force-flux stress of every node of a model with blocks ([`Model::for_each_block`]), the
/// nodes' volumes `volumes` and the displacement `u` (see the module docs); `None` when the
/// model has no blocks.
pub fn force_flux(model: &dyn Model, volumes: &[f64], u: &[f64]) -> Option<NodalStress> {
    energy_and_force_flux(model, volumes, u).map(|(_, stress)| stress)
}

/// The strain energy `W_i V_i` of every node and its force-flux stress ([`force_flux`]), in one
/// pass over the block rows (two passes cost 1.1 s at 70^3 with `delta = 3h`, this one 0.6 s);
/// `None` when the model has no blocks ([`Model::for_each_block`]).
///
/// The energy: for a symmetric `A` with zero block-row sums (`A_ii = -sum_{j != i} A_ij`),
///
/// ```text
/// u.A u / 2 = -(1/4) sum_i sum_{j != i} (u_j - u_i)^T A_ij (u_j - u_i),
/// ```
///
/// and node `i` takes its term of the outer sum: half of the energy of each of its bonds (for
/// the bond-based model `A_ij = -w_ij e e^T`, so `W_i V_i = (1/4) sum_j w_ij (e . (u_j -
/// u_i))^2`, never negative, and a rigid motion gives 0). The values sum to `u.A u / 2`. Used
/// for the bond models; LPS scenes report [`linpd_lps::LpsModel::linearized_energy_density`]
/// and coarsened levels the same split read from the columns of `K`.
pub fn energy_and_force_flux(model: &dyn Model, volumes: &[f64], u: &[f64]) -> Option<(Vec<f64>, NodalStress)> {
    let d = model.dim();
    let n = model.n_nodes();
    if n > 0 && !model.for_each_block(0, &mut |_, _| {}) {
        return None;
    }
    if let Some(st) = model.lattice_stencil() {
        return Some(stencil_energy_and_force_flux(&st, d, volumes, u));
    }
    // positions read once: a model's `position` may compute them (a lattice's from its index),
    // and each is read from every partner's row
    let x: Vec<linpd_core::Point> = (0..n).into_par_iter().map(|i| model.position(i)).collect();
    let (energy, tensor) = (0..n)
        .into_par_iter()
        .map(|i| {
            let xi_i = x[i];
            let (mut w, mut s) = (0.0, [0.0; 9]);
            model.for_each_block(i, &mut |j, b| {
                if j == i {
                    return;
                }
                let xj = x[j];
                let mut du = [0.0; 3];
                (0..d).for_each(|a| du[a] = u[d * j + a] - u[d * i + a]);
                // f = -A_ij du; the energy's term -(1/4) du . A_ij du = du . f / 4
                let mut f = [0.0; 3];
                for a in 0..d {
                    f[a] = -(0..d).map(|c| b[d * a + c] * du[c]).sum::<f64>();
                    w += 0.25 * du[a] * f[a];
                }
                for a in 0..d {
                    for c in 0..d {
                        s[3 * a + c] += 0.5 * (xj[a] - xi_i[a]) * f[c] / volumes[i];
                    }
                }
            });
            (w, s)
        })
        .unzip();
    Some((energy, NodalStress { dim: d, tensor }))
}

/// [`energy_and_force_flux`] on a lattice stencil: the same terms in the same order, with
/// `A_ij = -K_s` and `x_j - x_i = h k_s` read from the stencil instead of per-bond calls (0.42 ->
/// 0.08 s on the 70^3 cantilever).
fn stencil_energy_and_force_flux(
    st: &linpd_core::LatticeStencil,
    d: usize,
    volumes: &[f64],
    u: &[f64],
) -> (Vec<f64>, NodalStress) {
    let h = st.spacing;
    let n = volumes.len();
    let (energy, tensor) = (0..n)
        .into_par_iter()
        .map(|i| {
            let (mut w, mut s) = (0.0, [0.0; 9]);
            st.for_each_bond(i, |j, b| {
                let k = &st.blocks[b];
                let off = st.offsets[b];
                let mut du = [0.0; 3];
                (0..d).for_each(|a| du[a] = u[d * j + a] - u[d * i + a]);
                let mut f = [0.0; 3];
                for a in 0..d {
                    f[a] = (0..d).map(|c| k[d * a + c] * du[c]).sum::<f64>();
                    w += 0.25 * du[a] * f[a];
                }
                for a in 0..d {
                    for c in 0..d {
                        s[3 * a + c] += 0.5 * (h * off[a] as f64) * f[c] / volumes[i];
                    }
                }
            });
            (w, s)
        })
        .unzip();
    (energy, NodalStress { dim: d, tensor })
}

#[cfg(test)]
mod lattice_stencil_tests {
    use super::*;
    use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement, PlaneModel};

    /// The stencil paths of the nodal fields ([`Model::lattice_stencil`]) give the per-bond
    /// paths' energy, force-flux stress and strain (the same terms summed in another order:
    /// `1e-12` relative to each field's largest value) on a 2D and a 3D lattice under a
    /// non-affine displacement.
    #[test]
    fn stencil_fields_equal_the_per_bond_fields() {
        for (dim, n, horizon) in [(3usize, 9usize, 3.0), (2, 15, 2.5)] {
            let max = vec![(n - 1) as f64 * 0.1; dim];
            let grid = Grid::new(&vec![0.0; dim], &max, 0.1, 0.0, Placement::Vertex).unwrap();
            let mm = Micromodulus {
                kernel: Kernel::InverseDistance,
                normalization: Normalization::Discrete,
                modulus: 1.0,
                plane: (dim == 2).then_some(PlaneModel::Stress),
                partial_volume: false,
            };
            let delta = horizon * 0.1;
            let fast = linpd_bond::LatticeBondModel::stencil(grid.clone(), delta, mm.clone()).unwrap();
            let op = linpd_bond::BondOperator::on_grid(&grid, delta, &mm, &Material::default()).unwrap();
            let slow = linpd_bond::LatticeBondModel::corrected(op, grid.clone(), delta, mm);
            assert!(fast.lattice_stencil().is_some() && slow.lattice_stencil().is_none());
            let u: Vec<f64> = (0..dim * grid.len()).map(|k| ((k * 7919) % 97) as f64 / 97.0 - 0.4).collect();
            let volumes = vec![grid.volume(); grid.len()];
            let (ef, sf) = energy_and_force_flux(&fast, &volumes, &u).unwrap();
            let (es, ss) = energy_and_force_flux(&slow, &volumes, &u).unwrap();
            let close = |a: &[f64], b: &[f64]| {
                let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                a.iter().zip(b).all(|(p, q)| (p - q).abs() <= 1e-12 * scale)
            };
            assert!(close(&ef, &es), "{dim}D energy");
            let flat = |t: &[[f64; 9]]| t.iter().flatten().copied().collect::<Vec<f64>>();
            assert!(close(&flat(&sf.tensor), &flat(&ss.tensor)), "{dim}D stress");
            let (gf, gs) = (crate::nodal_strain(&fast, &volumes, &u), crate::nodal_strain(&slow, &volumes, &u));
            assert!(close(&flat(&gf.tensor), &flat(&gs.tensor)), "{dim}D strain");
            assert_eq!(gf.singular, gs.singular);
        }
    }
}
