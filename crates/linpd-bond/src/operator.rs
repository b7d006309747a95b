//! Per-bond weights, the matrix-free apply and the nonlinear PMB force it linearizes.

use crate::quadrature::{volume_factor, Quadrature};
use linpd_core::kernel::partial_volume;
use linpd_core::{BondFamily, CoreError, Grid, Material, Micromodulus, Point, GEOMETRY_RTOL};
use rayon::prelude::*;

/// The bond-based operator: geometry, family and the symmetric bond weights `w_ij`.
#[derive(Debug, Clone)]
pub struct BondOperator {
    dim: usize,
    positions: Vec<Point>,
    /// Lattice indices and spacing when built on a grid: bond vectors are then `(k_j - k_i) h`,
    /// exact, instead of `x_j - x_i`, which loses `log10(|x| / |xi|)` digits to the rounding of
    /// the positions (150 eps at x = 0.5 with h = 1/300).
    lattice: Option<(Vec<[i32; 3]>, f64)>,
    /// Unit bond vectors by lattice offset ([`UnitTable`]), when on a lattice.
    units: Option<UnitTable>,
    family: BondFamily,
    /// `w_ij = lambda_ij nu_ij V_i V_j`, indexed like the family's neighbour lists.
    pub(crate) weights: Vec<f64>,
}

impl BondOperator {
    /// Builds the operator on a lattice: family within `horizon`, micromodulus normalized per
    /// [`Micromodulus::amplitude`], bond moduli and defects from `material`.
    ///
    /// Errors when the horizon gives no bonds, when a 2D/3D horizon is below `sqrt(2) h`
    /// (axis-only bonds leave zero-energy shear modes), or when the micromodulus is invalid.
    pub fn on_grid(
        grid: &Grid,
        horizon: f64,
        micromodulus: &Micromodulus,
        material: &Material,
    ) -> Result<Self, CoreError> {
        let dim = grid.dim();
        let h = grid.spacing();
        let ratio = horizon / h;
        check_lattice_inputs(grid, horizon, micromodulus, material)?;
        let c = micromodulus.amplitude(dim, horizon, h)?;
        let family = BondFamily::from_grid(grid, horizon);
        let positions = grid.positions();
        let lattice: Vec<[i32; 3]> = (0..grid.len())
            .map(|n| {
                let k = grid.lattice_index(n);
                [k[0] as i32, k[1] as i32, k[2] as i32]
            })
            .collect();
        let k_ref = micromodulus.reference_modulus();
        let moduli = (!material.phases.is_empty()).then(|| material.node_moduli(grid, k_ref));
        let tol = GEOMETRY_RTOL * h;
        let weights: Vec<f64> = (0..family.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let xi = positions[i];
                let family = &family;
                let positions = &positions;
                let moduli = &moduli;
                let lattice = &lattice;
                family.neighbors(i).iter().map(move |&j| {
                    let xj = positions[j as usize];
                    let r = h * lattice_len(&lattice[i], &lattice[j as usize]);
                    let nu = if micromodulus.partial_volume { partial_volume(r, horizon, h) } else { 1.0 };
                    let (ki, kj) = match moduli {
                        Some(m) => (m[i], m[j as usize]),
                        None => (k_ref, k_ref),
                    };
                    let f = if material.is_homogeneous() {
                        1.0
                    } else {
                        material.bond_factor(&xi, &xj, ki, kj, k_ref, tol)
                    };
                    c * micromodulus.kernel.shape(r, horizon)
                        * nu
                        * f
                        * grid.node_volume(i)
                        * grid.node_volume(j as usize)
                })
            })
            .collect();
        let units = UnitTable::new(dim, ratio, h);
        Ok(BondOperator { dim, positions, lattice: Some((lattice, h)), units, family, weights })
    }

    /// Builds the operator on an arbitrary point set with per-node volumes `V_i` (a point
    /// cloud): family by a cell list ([`BondFamily::from_points`]), weights
    /// `w_ij = c g(|xi|) nu_ij f_ij V_i V_j` with `f_ij` from `material` (phases by region,
    /// overridden per node by `moduli` when given) as on a lattice.
    ///
    /// The volume factor `nu_ij` is `quadrature`'s ([`crate::quadrature`]): 1 within
    /// `delta` ([`Quadrature::Full`]), the one-sided ramp of node size `h_ij = (V_i^(1/d) +
    /// V_j^(1/d)) / 2` ([`Quadrature::Ramp`]; a lattice's `h` when the volumes are `h^d`; the
    /// mean keeps `w_ij = w_ji`), or the fraction of the neighbour's equivalent ball inside the
    /// horizon ball ([`Quadrature::Ball`], bonds to `delta + max R`). With
    /// [`linpd_core::Normalization::Discrete`] the moment is the mean over the `interior`
    /// nodes (those whose whole horizon lies in the body; an error when there is none) of
    /// `M_i = sum_j g(|xi|) nu_ij V_j |xi|^2`, the cloud's own sum as a lattice's stencil sum is
    /// the lattice's; otherwise the amplitude is taken with `h = 0` and `interior` is not read.
    /// The micromodulus' `partial_volume` is ignored here. `whole`: the nodes are a rank's part
    /// of a larger cloud, whose smallest node size scales the crossing and phase tolerances.
    #[allow(clippy::too_many_arguments)]
    pub fn on_points(
        dim: usize,
        positions: Vec<Point>,
        volumes: &[f64],
        horizon: f64,
        micromodulus: &Micromodulus,
        material: &Material,
        moduli: Option<&[f64]>,
        quadrature: Quadrature,
        interior: &[bool],
        whole: Option<linpd_core::family::CloudScales>,
    ) -> Result<Self, CoreError> {
        if !(horizon.is_finite() && horizon > 0.0) {
            return Err(CoreError::param("horizon", format!("must be > 0, got {horizon:e}")));
        }
        assert_eq!(positions.len(), volumes.len(), "one volume per node");
        micromodulus.validate(dim)?;
        material.validate(dim)?;
        // a part of a cloud tests crossings and phases at the whole cloud's tolerance
        let h_min = match whole {
            Some(w) => w.min_size,
            None => volumes.iter().fold(f64::INFINITY, |m, &v| m.min(v.powf(1.0 / dim as f64))),
        };
        let tol = GEOMETRY_RTOL * h_min;
        let scale: Vec<f64> = volumes.iter().map(|&v| quadrature.node_scale(dim, v)).collect();
        // the largest equivalent radius (the ball quadrature's scales), how far bonds reach
        let r_max = scale.iter().fold(0.0f64, |m, &s| m.max(s));
        let nu = |i: usize, j: usize, r: f64| volume_factor(quadrature, dim, r, horizon, scale[i], scale[j]);
        let family = match quadrature {
            Quadrature::Ball => {
                // bonds to delta + max R, of them those whose fraction is not 0
                let wide = BondFamily::from_points(&positions, dim, horizon + r_max);
                let lists = (0..wide.len())
                    .into_par_iter()
                    .map(|i| {
                        let xi = positions[i];
                        let within = |&j: &u32| {
                            let xj = positions[j as usize];
                            let r = (0..dim).map(|a| (xj[a] - xi[a]).powi(2)).sum::<f64>().sqrt();
                            nu(i, j as usize, r) > 0.0
                        };
                        wide.neighbors(i).iter().copied().filter(within).collect()
                    })
                    .collect();
                BondFamily::from_lists(lists)
            }
            _ => BondFamily::from_points(&positions, dim, horizon),
        };
        let c = match micromodulus.normalization == linpd_core::Normalization::Discrete {
            true => {
                let moment = |i: usize| -> f64 {
                    let xi = positions[i];
                    family
                        .neighbors(i)
                        .iter()
                        .map(|&j| {
                            let j = j as usize;
                            let r = (0..dim).map(|a| (positions[j][a] - xi[a]).powi(2)).sum::<f64>().sqrt();
                            micromodulus.kernel.shape(r, horizon) * nu(i, j, r) * volumes[j] * r * r
                        })
                        .sum()
                };
                let inner: Vec<usize> =
                    (0..positions.len()).filter(|&i| interior.get(i).copied().unwrap_or(false)).collect();
                if inner.is_empty() {
                    return Err(CoreError::param(
                        "micromodulus",
                        "the discrete normalization on a point cloud averages the interior nodes' sums, and no node lies a horizon inside the body",
                    ));
                }
                let mean = inner.iter().map(|&i| moment(i)).sum::<f64>() / inner.len() as f64;
                micromodulus.moment_target(dim) / mean
            }
            false => micromodulus.amplitude(dim, horizon, 0.0)?,
        };
        let k_ref = micromodulus.reference_modulus();
        let own;
        let moduli = match moduli {
            Some(m) => Some(m),
            None if !material.phases.is_empty() => {
                own = material.node_moduli_at(&positions, dim, k_ref, tol);
                Some(own.as_slice())
            }
            None => None,
        };
        let weights: Vec<f64> = (0..family.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let (xi, family, positions, nu) = (positions[i], &family, &positions, &nu);
                family.neighbors(i).iter().map(move |&j| {
                    let j = j as usize;
                    let xj = positions[j];
                    let r = (0..dim).map(|a| (xj[a] - xi[a]).powi(2)).sum::<f64>().sqrt();
                    let nu = nu(i, j, r);
                    let (ki, kj) = moduli.map_or((k_ref, k_ref), |m| (m[i], m[j]));
                    let f = if material.is_homogeneous() && moduli.is_none() {
                        1.0
                    } else {
                        material.bond_factor(&xi, &xj, ki, kj, k_ref, tol)
                    };
                    c * micromodulus.kernel.shape(r, horizon) * nu * f * volumes[i] * volumes[j]
                })
            })
            .collect();
        Ok(BondOperator { dim, positions, lattice: None, units: None, family, weights })
    }

    /// Builds an operator from explicit parts (weights indexed like `family`'s bonds and
    /// symmetric: `w_ij = w_ji`).
    pub fn from_parts(dim: usize, positions: Vec<Point>, family: BondFamily, weights: Vec<f64>) -> Self {
        assert_eq!(family.n_bonds(), weights.len(), "one weight per bond");
        assert_eq!(family.len(), positions.len(), "one position per node");
        BondOperator { dim, positions, lattice: None, units: None, family, weights }
    }

    /// Spatial dimension = DOFs per node.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.positions.len()
    }
    /// Number of DOFs (`dim * n_nodes`).
    pub fn n_dofs(&self) -> usize {
        self.dim * self.positions.len()
    }
    /// Node positions.
    pub fn positions(&self) -> &[Point] {
        &self.positions
    }
    /// The bond family.
    pub fn family(&self) -> &BondFamily {
        &self.family
    }
    /// Bond weights `w_ij` of node `i`, aligned with `family().neighbors(i)`.
    pub fn weights(&self, i: usize) -> &[f64] {
        let o = self.family.bond_offset(i);
        &self.weights[o..o + self.family.neighbors(i).len()]
    }

    /// Reference bond vector `xi_ij = x_j - x_i` (exact lattice offset times `h` on grids).
    #[inline]
    pub fn bond_vector(&self, i: usize, j: usize) -> [f64; 3] {
        let mut e = [0.0; 3];
        match &self.lattice {
            Some((k, h)) => {
                for a in 0..self.dim {
                    e[a] = (k[j][a] - k[i][a]) as f64 * h;
                }
            }
            None => {
                let (a, b) = (&self.positions[i], &self.positions[j]);
                for k in 0..self.dim {
                    e[k] = b[k] - a[k];
                }
            }
        }
        e
    }

    /// Unit bond vector `e_ij` (first `dim` entries meaningful).
    #[inline]
    pub fn unit(&self, i: usize, j: usize) -> [f64; 3] {
        if let (Some((k, _)), Some(t)) = (&self.lattice, &self.units) {
            return t.get(&k[i], &k[j]);
        }
        normalized(self.bond_vector(i, j))
    }

    /// The lattice offset `k_j - k_i` of bond `(i, j)` (`None` off a lattice).
    #[inline]
    pub fn offset(&self, i: usize, j: usize) -> Option<[i32; 3]> {
        let (k, _) = self.lattice.as_ref()?;
        Some([0, 1, 2].map(|a| k[j][a] - k[i][a]))
    }

    /// The unit vector of lattice offset `o`: [`BondOperator::unit`] of any bond with
    /// [`BondOperator::offset`] `o`, bit for bit (`None` off a lattice).
    pub fn unit_of_offset(&self, o: [i32; 3]) -> Option<[f64; 3]> {
        let (_, h) = self.lattice.as_ref()?;
        if let Some(t) = &self.units {
            if o.iter().all(|&x| x.abs() <= t.r) {
                return Some(t.get(&[0; 3], &o));
            }
        }
        let mut e = [0.0; 3];
        (0..self.dim).for_each(|a| e[a] = o[a] as f64 * h);
        Some(normalized(e))
    }

    /// `y = A u` over all DOFs, without storing `A` (parallel over nodes).
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        let d = self.dim;
        assert_eq!(u.len(), self.n_dofs());
        assert_eq!(y.len(), self.n_dofs());
        y.par_chunks_mut(d).enumerate().for_each(|(i, yi)| {
            yi.iter_mut().for_each(|v| *v = 0.0);
            for (&j, &w) in self.family.neighbors(i).iter().zip(self.weights(i)) {
                let j = j as usize;
                let e = self.unit(i, j);
                // (e . (u_i - u_j)) e w
                let mut s = 0.0;
                for k in 0..d {
                    s += e[k] * (u[d * i + k] - u[d * j + k]);
                }
                for k in 0..d {
                    yi[k] += w * s * e[k];
                }
            }
        });
    }

    /// Strain energy `(1/2) u . A u` per node: `W_i = (1/4) sum_j w_ij (e . (u_j - u_i))^2 / V_i`
    /// is returned as energy (not density); divide by the node volume for a density.
    pub fn node_energy(&self, u: &[f64]) -> Vec<f64> {
        let d = self.dim;
        (0..self.n_nodes())
            .into_par_iter()
            .map(|i| {
                let mut w_i = 0.0;
                for (&j, &w) in self.family.neighbors(i).iter().zip(self.weights(i)) {
                    let j = j as usize;
                    let e = self.unit(i, j);
                    let s: f64 = (0..d).map(|k| e[k] * (u[d * j + k] - u[d * i + k])).sum();
                    w_i += 0.25 * w * s * s;
                }
                w_i
            })
            .collect()
    }
}

/// The checks of [`BondOperator::on_grid`] before anything is built: a positive horizon of at
/// least one spacing (and `sqrt 2` spacings in 2D/3D: bonds along the axes only leave shear
/// modes without energy), a valid micromodulus and material.
pub(crate) fn check_lattice_inputs(
    grid: &Grid,
    horizon: f64,
    micromodulus: &Micromodulus,
    material: &Material,
) -> Result<(), CoreError> {
    let dim = grid.dim();
    if !(horizon.is_finite() && horizon > 0.0) {
        return Err(CoreError::param("horizon", format!("must be > 0, got {horizon:e}")));
    }
    let ratio = horizon / grid.spacing();
    if ratio < 1.0 - GEOMETRY_RTOL {
        return Err(CoreError::param("horizon", format!("horizon/spacing = {ratio:e} gives no bonds (need >= 1)")));
    }
    if dim > 1 && ratio < std::f64::consts::SQRT_2 * (1.0 - GEOMETRY_RTOL) {
        return Err(CoreError::param(
            "horizon",
            format!(
                "horizon/spacing = {ratio:e} bonds only along the axes: the bond-based operator \
                 then has zero-energy shear modes (need >= sqrt(2))"
            ),
        ));
    }
    micromodulus.validate(dim)?;
    material.validate(dim)
}

/// `|k_j - k_i|` in lattice units.
#[inline]
fn lattice_len(a: &[i32; 3], b: &[i32; 3]) -> f64 {
    let d: i64 = (0..3).map(|k| ((b[k] - a[k]) as i64).pow(2)).sum();
    (d as f64).sqrt()
}

/// The nonlinear PMB force of the LAMMPS howto (Algorithm 5 without bond breaking and without
/// short-range contact forces), generalized to the operator's micromodulus:
///
/// ```text
/// F_i = sum_j w_ij |xi| s_ij (y_j - y_i)/|y_j - y_i|,   s_ij = (|y_j - y_i| - |xi|)/|xi|,
/// ```
///
/// with `y = x + u`. For `lambda = c/|xi|` this is `sum_j c s nu V_i V_j n` (Algorithm 5's
/// `k = c/|xi| nu V dr` times `V_i`). Its Jacobian at `u = 0` is `-A`.
pub fn pmb_force(op: &BondOperator, u: &[f64]) -> Vec<f64> {
    let d = op.dim;
    let mut f = vec![0.0; op.n_dofs()];
    f.par_chunks_mut(d).enumerate().for_each(|(i, fi)| {
        for (&j, &w) in op.family.neighbors(i).iter().zip(op.weights(i)) {
            let j = j as usize;
            let xi = op.bond_vector(i, j);
            let mut y = [0.0; 3];
            let mut r0 = 0.0;
            for k in 0..d {
                let x = xi[k];
                r0 += x * x;
                y[k] = x + u[d * j + k] - u[d * i + k];
            }
            let r0 = r0.sqrt();
            let r = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt();
            let dr = r - r0;
            for k in 0..d {
                fi[k] += w * dr * y[k] / r;
            }
        }
    });
    f
}

/// `e / |e|`.
#[inline]
fn normalized(mut e: [f64; 3]) -> [f64; 3] {
    let r = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    e.iter_mut().for_each(|v| *v /= r);
    e
}

/// Unit bond vectors `e = k h / |k h|` of the lattice offsets `k` in `[-r, r]^dim`: a lattice
/// has a few hundred distinct bond directions, and `unit` runs in every product, assembly and
/// stiffness block, so they are computed once (with the same arithmetic as per bond: the
/// results are bitwise identical) instead of a square root and divisions per bond and use.
#[derive(Debug, Clone)]
struct UnitTable {
    dim: usize,
    r: i32,
    units: Vec<[f64; 3]>,
}

impl UnitTable {
    /// Tables above this many offsets are not built (`unit` then computes per bond).
    const MAX_OFFSETS: usize = 1 << 20;

    fn new(dim: usize, ratio: f64, h: f64) -> Option<Self> {
        // a table of more than MAX_OFFSETS is not built anyway; a huge ratio (a horizon of 1e18
        // spacings on a small grid) would overflow `r` below
        if !(ratio.is_finite() && ratio < Self::MAX_OFFSETS as f64) {
            return None;
        }
        let r = ratio.ceil() as i64 + 1;
        let w = (2 * r + 1) as usize;
        let size = (0..dim).try_fold(1usize, |s, _| s.checked_mul(w))?;
        if size > Self::MAX_OFFSETS {
            return None;
        }
        let r = r as i32;
        let units = (0..size)
            .map(|idx| {
                let mut e = [0.0; 3];
                let mut q = idx;
                for v in e.iter_mut().take(dim) {
                    *v = ((q % w) as i32 - r) as f64 * h;
                    q /= w;
                }
                let n = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
                if n > 0.0 {
                    e.iter_mut().for_each(|v| *v /= n);
                }
                e
            })
            .collect();
        Some(UnitTable { dim, r, units })
    }

    /// `e_ij` for the lattice indices `ki`, `kj` (within the table's reach).
    #[inline]
    fn get(&self, ki: &[i32; 3], kj: &[i32; 3]) -> [f64; 3] {
        let w = 2 * self.r + 1;
        let mut idx = 0;
        for a in (0..self.dim).rev() {
            idx = idx * w + (kj[a] - ki[a] + self.r);
        }
        self.units[idx as usize]
    }
}
