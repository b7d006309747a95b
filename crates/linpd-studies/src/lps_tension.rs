//! A static 3D tension bar, solved with the LPS tangent and compared with classical
//! elasticity: the driver of `linpd study lps-tension-bar` (module `lps`).
//!
//! # Set-up
//!
//! * Body `[0, L] x [0, W] x [0, W]`, lattice spacing `h` (`L/h`, `W/h` integers), nodes at
//!   cell centres ([`Placement::Cell`]), so the cross-section holds `(W/h)^2` nodes of area
//!   `h^2` each: the discrete bar has exactly the area `W^2` (a vertex lattice would have
//!   `(W + h)^2`). Horizon `delta = ratio h`.
//! * Two layers of `n_l = floor(ratio)` node planes (thickness `n_l h`, one horizon for
//!   integer ratios) are added OUTSIDE the body along x only: the grid is built on
//!   `[-n_l h, L + n_l h] x [0, W]^2` rather than with `Grid`'s `layer` argument, which would
//!   also put layers around the lateral faces (they must stay free surfaces).
//! * Grip: every node with `x < 0` is fixed in x, y and z. Fixing all three removes the rigid
//!   motions, but it also clamps the lateral contraction of the bar end: the body within
//!   roughly one width `W` (Saint-Venant) of the grip contracts less than `nu sigma / E`, which
//!   stiffens the bar (shorter elongation) and is why the strains are measured away from it.
//! * Load: the total force `sigma W^2` in +x is spread uniformly over the nodes with
//!   `x > L` (force per node `sigma W^2 / n_load`), a body force on the load layer that acts
//!   as the traction `sigma` on the face `x = L`. The load-layer material is part of the model
//!   (it carries the force into the body), the grip layer is rigid.
//! * Solve `A_ff u_f = f_f` on the free DOFs, `A` from [`linpd_lps::assemble_tangent`] (the
//!   linearization at `u = 0`, i.e. small strains), reduced by keeping free rows/columns:
//!   sparse Cholesky (nested dissection) up to [`CHOLESKY_LIMIT`] unknowns, else Jacobi-PCG
//!   (`rtol 1e-10`), through [`linpd_solve::solve_model`].
//!   Partial volumes are on (`nu` of [`linpd_core::kernel::partial_volume`]).
//!
//! # Measurements (body nodes only)
//!
//! With `u_bar(b)` the mean `u_x` over body plane `b = 0..L/h` (at `x_b = (b + 1/2) h`):
//!
//! * elongation `u_bar(last) - u_bar(0)`, between the two face planes, whose distance is the
//!   gauge length `L - h`; the classical value is `sigma (L - h) / E` for the same gauge;
//! * axial strain at mid-length from the planes `b_a = n/4` and `b_b = n - 1 - n/4`
//!   (symmetric about `L/2`, about half the length apart): `(u_bar(b_b) - u_bar(b_a)) /
//!   (x_b - x_a)`;
//! * lateral strain: the least-squares slopes `d u_y / d y` and `d u_z / d z` over each plane
//!   `b_a..=b_b`, averaged; effective Poisson ratio `- lateral / axial`;
//!
//! against `E = 9KG/(3K+G)`, `nu = (3K-2G)/(2(3K+G))`: axial strain `sigma/E`, lateral
//! `-nu sigma / E`.

use linpd_core::{CoreError, Grid, Placement};
use linpd_lps::{Influence, LpsError, LpsModel, LpsParams, SurfaceCorrection};
use linpd_solve::{solve_model, CgParams, Dirichlet, SolverSpec, StaticError};
use std::time::Instant;
use thiserror::Error;

/// Up to this many unknowns the bar is solved by sparse Cholesky, above by Jacobi-PCG.
pub const CHOLESKY_LIMIT: usize = 60_000;

/// The tension bar problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionBar {
    /// `L` (x extent of the body).
    pub length: f64,
    /// `W` (y and z extent).
    pub width: f64,
    /// Lattice spacing `h`.
    pub spacing: f64,
    /// `delta / h`.
    pub horizon_ratio: f64,
    /// Bulk modulus `K`.
    pub bulk: f64,
    /// Shear modulus `G`.
    pub shear: f64,
    /// Applied axial stress `sigma` (total force `sigma W^2`).
    pub sigma: f64,
    /// Influence function.
    pub influence: Influence,
    /// Weighted-volume surface correction.
    pub surface: SurfaceCorrection,
}

/// What [`tension_bar`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct TensionResult {
    /// Mean `u_x` of the last body plane minus that of the first (gauge `L - h`).
    pub elongation: f64,
    /// `sigma (L - h) / E`, the classical elongation over the same gauge.
    pub elongation_classical: f64,
    /// Axial strain at mid-length (two cross sections).
    pub axial_strain_mid: f64,
    /// `sigma / E`.
    pub axial_strain_classical: f64,
    /// Mean transverse strain at mid-length.
    pub lateral_strain_mid: f64,
    /// `-lateral_strain_mid / axial_strain_mid`.
    pub poisson_effective: f64,
    /// `(3K - 2G) / (2 (3K + G))`.
    pub poisson_classical: f64,
    /// Gauge length of `elongation`: `L - h`.
    pub gauge_length: f64,
    /// Nodes, both layers included.
    pub nodes: usize,
    /// Free DOFs solved for.
    pub unknowns: usize,
    /// Wall time of the linear solve (factorization + solve, or PCG).
    pub solve_seconds: f64,
    /// PCG iterations (0 when Cholesky was used).
    pub cg_iterations: usize,
}

/// Why [`tension_bar`] failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum TensionError {
    /// A geometric or load parameter is invalid.
    #[error("tension bar: {0}")]
    Params(String),
    /// The lattice could not be built.
    #[error(transparent)]
    Grid(#[from] CoreError),
    /// The LPS model could not be built.
    #[error(transparent)]
    Lps(#[from] LpsError),
    /// The linear solve failed.
    #[error(transparent)]
    Solve(#[from] StaticError),
}

/// Solves the static tension bar `params` (see the module documentation).
pub fn tension_bar(params: &TensionBar) -> Result<TensionResult, TensionError> {
    let p = params;
    let pos = |v: f64| v.is_finite() && v > 0.0;
    if !(pos(p.length) && pos(p.width) && pos(p.spacing)) {
        return Err(TensionError::Params(format!(
            "length, width and spacing must be positive numbers (got {}, {}, {})",
            p.length, p.width, p.spacing
        )));
    }
    if !p.sigma.is_finite() {
        return Err(TensionError::Params(format!("sigma must be finite, got {:e}", p.sigma)));
    }
    if !(p.horizon_ratio.is_finite() && p.horizon_ratio >= 1.0) {
        return Err(TensionError::Params(format!("horizon_ratio must be >= 1, got {:e}", p.horizon_ratio)));
    }
    let h = p.spacing;
    let nl = (p.horizon_ratio * (1.0 + linpd_core::GEOMETRY_RTOL)).floor() as i64;
    let t = nl as f64 * h;
    let grid = Grid::new(&[-t, 0.0, 0.0], &[p.length + t, p.width, p.width], h, 0.0, Placement::Cell)?;
    let nb = (p.length / h).round() as i64;
    if nb < 4 {
        return Err(TensionError::Params(format!("the bar needs at least 4 node planes along x, got {nb}")));
    }
    let lps = LpsParams {
        K: p.bulk,
        G: p.shear,
        horizon: p.horizon_ratio * h,
        influence: p.influence,
        partial_volume: true,
        plane: None,
    };
    let model = LpsModel::new(&grid, &lps)?.with_surface_correction(p.surface);
    let n = model.n_nodes();
    // Body plane index b = ix - nl: < 0 grip, >= nb load layer.
    let plane: Vec<i64> = (0..n).map(|i| grid.lattice_index(i)[0] - nl).collect();
    let n_load = plane.iter().filter(|&&b| b >= nb).count();

    // The grip (every node with x < 0) is held in x, y and z; the load layer carries the force.
    let grip: Vec<bool> = (0..3 * n).map(|dof| plane[dof / 3] < 0).collect();
    let bc = Dirichlet::new(3, &grip, vec![0.0; 3 * n]);
    let free = bc.dofs().n_free();
    let mut f = vec![0.0; 3 * n];
    let f_node = p.sigma * p.width * p.width / n_load as f64;
    for i in 0..n {
        if plane[i] >= nb {
            f[3 * i] = f_node;
        }
    }
    let spec = if free <= CHOLESKY_LIMIT {
        SolverSpec::Cholesky
    } else {
        SolverSpec::cg(CgParams { rtol: 1e-10, max_iter: 50_000 })
    };
    let start = Instant::now();
    let solved = solve_model(&model, &bc, &f, &spec, &linpd_core::NoProgress)?;
    let cg_iterations = solved.report.iterations.unwrap_or(0);
    let solve_seconds = start.elapsed().as_secs_f64();
    let u = |i: usize, c: usize| solved.u[3 * i + c];

    // Per body plane: mean u_x and the transverse least-squares slopes.
    let nbu = nb as usize;
    let positions = model.positions();
    let (mut sum_ux, mut count) = (vec![0.0; nbu], vec![0usize; nbu]);
    for i in 0..n {
        if (0..nb).contains(&plane[i]) {
            sum_ux[plane[i] as usize] += u(i, 0);
            count[plane[i] as usize] += 1;
        }
    }
    let ubar: Vec<f64> = sum_ux.iter().zip(&count).map(|(s, &c)| s / c as f64).collect();
    let (ba, bb) = (nbu / 4, nbu - 1 - nbu / 4);
    let axial = (ubar[bb] - ubar[ba]) / ((bb - ba) as f64 * h);
    let centre = 0.5 * p.width;
    let (mut num, mut den) = ([0.0; 2], [0.0; 2]);
    for i in 0..n {
        if plane[i] >= ba as i64 && plane[i] <= bb as i64 {
            for c in 0..2 {
                let y = positions[i][c + 1] - centre;
                num[c] += u(i, c + 1) * y;
                den[c] += y * y;
            }
        }
    }
    let lateral = 0.5 * (num[0] / den[0] + num[1] / den[1]);

    let (k, g) = (p.bulk, p.shear);
    let e = 9.0 * k * g / (3.0 * k + g);
    let nu = (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g));
    let gauge = (nb - 1) as f64 * h;
    Ok(TensionResult {
        elongation: ubar[nbu - 1] - ubar[0],
        elongation_classical: p.sigma * gauge / e,
        axial_strain_mid: axial,
        axial_strain_classical: p.sigma / e,
        lateral_strain_mid: lateral,
        poisson_effective: -lateral / axial,
        poisson_classical: nu,
        gauge_length: gauge,
        nodes: n,
        unknowns: free,
        solve_seconds,
        cg_iterations,
    })
}
