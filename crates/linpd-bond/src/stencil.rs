//! Matrix-free apply on a homogeneous full-box lattice from the stencil alone.
//!
//! On a uniform lattice with one material every bond with lattice offset `k` has the same
//! weight `w_k = c g(|k h|) nu_k V^2` and direction `e_k`, so `A u` needs only the stencil
//! (122 entries for `delta = 3h` in 3D) instead of per-bond storage (122 weights per node).
//! Nodes whose stencil stays inside the box skip the bounds checks.

use linpd_core::family::lattice_stencil;
use linpd_core::kernel::partial_volume;
use linpd_core::{CoreError, Grid, Micromodulus};
use rayon::prelude::*;

/// The stiffness `A` of a homogeneous lattice, applied from its stencil.
#[derive(Debug, Clone)]
pub struct StencilOperator {
    dim: usize,
    counts: [usize; 3],
    offsets: Vec<[i64; 3]>,
    linear: Vec<isize>,
    weights: Vec<f64>,
    units: Vec<[f64; 3]>,
    reach: i64,
}

impl StencilOperator {
    /// The stencil of `micromodulus` on `grid` with horizon `horizon` (homogeneous material).
    pub fn new(grid: &Grid, horizon: f64, micromodulus: &Micromodulus) -> Result<Self, CoreError> {
        let dim = grid.dim();
        let h = grid.spacing();
        micromodulus.validate(dim)?;
        if !grid.is_full() || !grid.has_uniform_volumes() {
            // the linear offsets below index every lattice site
            return Err(CoreError::param(
                "grid",
                "the stencil operator needs the full lattice box with volumes h^d; a body removed nodes or cut their cells",
            ));
        }
        let c = micromodulus.amplitude(dim, horizon, h)?;
        let counts = grid.counts();
        let offsets = lattice_stencil(dim, horizon / h);
        if offsets.is_empty() {
            return Err(CoreError::param("horizon", "gives no bonds"));
        }
        let vol = grid.volume();
        let mut linear = Vec::new();
        let mut weights = Vec::new();
        let mut units = Vec::new();
        for k in &offsets {
            linear.push(k[0] as isize + counts[0] as isize * (k[1] as isize + counts[1] as isize * k[2] as isize));
            let r = h * ((k[0] * k[0] + k[1] * k[1] + k[2] * k[2]) as f64).sqrt();
            let nu = if micromodulus.partial_volume { partial_volume(r, horizon, h) } else { 1.0 };
            weights.push(c * micromodulus.kernel.shape(r, horizon) * nu * vol * vol);
            units.push([k[0] as f64 * h / r, k[1] as f64 * h / r, k[2] as f64 * h / r]);
        }
        let reach = offsets.iter().flat_map(|k| k.iter().map(|v| v.abs())).max().unwrap_or(0);
        Ok(StencilOperator { dim, counts, offsets, linear, weights, units, reach })
    }

    /// Number of DOFs.
    pub fn n_dofs(&self) -> usize {
        self.dim * self.counts.iter().product::<usize>()
    }
    /// Stencil size (bonds per interior node).
    pub fn stencil_len(&self) -> usize {
        self.offsets.len()
    }

    /// `y = A u` over all DOFs.
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        let d = self.dim;
        assert_eq!(u.len(), self.n_dofs());
        assert_eq!(y.len(), self.n_dofs());
        let [n0, n1, n2] = self.counts;
        let interior = |v: i64, n: usize, used: bool| !used || (v >= self.reach && v + self.reach < n as i64);
        y.par_chunks_mut(d).enumerate().for_each(|(i, yi)| {
            let idx = [(i % n0) as i64, ((i / n0) % n1) as i64, (i / (n0 * n1)) as i64];
            let inside = interior(idx[0], n0, true) && interior(idx[1], n1, d > 1) && interior(idx[2], n2, d > 2);
            let mut acc = [0.0; 3];
            for s in 0..self.offsets.len() {
                if !inside {
                    let k = &self.offsets[s];
                    let ok = (0..d).all(|a| {
                        let v = idx[a] + k[a];
                        v >= 0 && v < self.counts[a] as i64
                    });
                    if !ok {
                        continue;
                    }
                }
                let j = (i as isize + self.linear[s]) as usize;
                let e = &self.units[s];
                let mut t = 0.0;
                for a in 0..d {
                    t += e[a] * (u[d * i + a] - u[d * j + a]);
                }
                t *= self.weights[s];
                for a in 0..d {
                    acc[a] += t * e[a];
                }
            }
            yi.copy_from_slice(&acc[..d]);
        });
    }
}
