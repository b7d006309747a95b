//! Smoothed-aggregation algebraic multigrid (SA-AMG): a symmetric V-cycle preconditioner for
//! the reduced SPD stiffness `A = A_ff` of linear PD (and elasticity-like) operators, for CG
//! ([`crate::pcg`]) and GMRES.
//!
//! # Algorithm
//!
//! Vanek, Mandel & Brezina, *Algebraic multigrid by smoothed aggregation for second and fourth
//! order elliptic problems*, Computing 56 (1996) 179-196; the defaults follow pyamg's
//! `smoothed_aggregation_solver` (5.x) where they fit a bond lattice, and say where not.
//!
//! Level `l` has the matrix `A_l` (`A_0 = A`) in blocks: on level 0 the free components of one
//! node, on a coarse level the unknowns of one aggregate. The setup repeats, until `A_l` has at
//! most [`AmgParams::max_coarse`] rows:
//!
//! 1. **Strength.** Nodes `I != J` are strongly connected when
//!    `||A_IJ||_F >= theta sqrt(||A_II||_F ||A_JJ||_F)` (pyamg's `symmetric` strength on the
//!    amalgamated block matrix); `theta = 0` on level 0 (pyamg's default), 0.05 on coarse
//!    levels (measured, below). When the DOF geometry carries the model's interaction graph
//!    ([`DofGeometry::partners`], from a model's `for_each_partner`: its bonds), level 0 is
//!    aggregated on that graph instead: for bond models it is the graph of `A`'s nonzero
//!    blocks (plus, on rollers, bonds whose free-component block vanishes), for LPS the
//!    one-horizon bonds rather than the tangent's two-horizon couplings, which gave aggregates
//!    8x larger in 3D and 31 / 49 iterations on the bundled LPS scenes instead of 18 / 29.
//! 2. **Aggregation** of the strength graph (`aggregate`'s three passes, VMB96 section 3):
//!    a node whose neighbours are all free seeds an aggregate with them; leftovers join a
//!    neighbouring aggregate or form their own.
//! 3. **Tentative prolongator.** The near-null space `B_l` (`B_0`: the rigid-body modes,
//!    [`rigid_body_modes`], 1/3/6 in 1D/2D/3D) restricted to each aggregate is factored
//!    `B_a = Q_a R_a`; `T` is block diagonal with the orthonormal `Q_a` (dependent columns
//!    dropped), and `B_{l+1}` stacks the `R_a`, so `T B_{l+1} = B_l`: the coarse space
//!    reproduces the rigid motions exactly.
//! 4. **Prolongator smoothing.** `P = (I - omega D^{-1} A) T` with `D = diag(A)` and
//!    `omega = (4/3) / rho(D^{-1} A)`, `rho` from 15 Lanczos steps (on a 401^2 plate 12 steps
//!    underestimate it by 5%, 15 by 1%, 20 and 40 agree to 3 digits; cubes converge faster;
//!    a step is one product with `A_l`, a third of an AMG-PCG iteration on level 0): one Jacobi step lowers the energy of
//!    the coarse basis functions (VMB96 eq. (3.6)). On a finest level with wide families
//!    (at least [`AmgParams::filter_min_partners`] partners a node on average: 3D bond
//!    lattices with `delta = 3h`) the step uses the filtered matrix `A_F` of the partners
//!    within [`AmgParams::filter_ratio`] of each node's nearest distance instead of `A`
//!    (module `filter`, VMB96's `A^F`): `P` then reaches 1.5 spacings beyond its aggregate
//!    rather than a horizon, with half the entries.
//! 5. **Galerkin coarse operator** `A_{l+1} = P^T A P` with the explicit transpose `R = P^T`:
//!    the block rows of `A P` are computed one at a time (Gustavson's accumulation on dense
//!    blocks) and added into `R`'s rows right away, one range of rows per thread, so that
//!    `A P` (the largest array of the setup) is never stored (`vbr::galerkin_rows`).
//!
//! The coarsest matrix (at most [`AmgParams::max_coarse`] = 2000 rows by default; a level-1
//! matrix of 2328 rows and 836k entries factors in 0.1 s) is factored by the sparse Cholesky
//! of [`crate::Cholesky`].
//!
//! One application `z = M^{-1} r` is the V-cycle `z = V_0(r)`, with `V_l(b)`:
//!
//! ```text
//! x = S_l(0, b)                     pre-smoothing from x = 0
//! x = x + P V_{l+1}(R (b - A x))    coarse correction (V_L = A_L^{-1}, exact)
//! x = S_l(x, b)                     post-smoothing, the same smoother
//! ```
//!
//! The smoother `S_l` is the Chebyshev polynomial in `D^{-1} A` on `[rho/30, 1.1 rho]`
//! (Adams, Brezina, Hu & Tuminaro 2003; the interval of MueLu/Ifpack2), of degree 1 by
//! default, which is Jacobi with weight `2 / (1.1 rho + rho/30) = 1.77 / rho`. Its error
//! propagator `I - p(D^{-1}A) D^{-1} A` is self-adjoint in the `A` inner product with norm
//! below 1, so the V-cycle is symmetric positive definite (required by CG) and fixed (no
//! inner tolerance). pyamg (symmetric block Gauss-Seidel smoothing by default) reaches 8-9
//! iterations on these lattices (issue #12) where this cycle takes 15-18; Gauss-Seidel is
//! sequential, a Chebyshev degree is one parallel product per smoothing step.
//!
//! # Measured choices
//!
//! Clamped bond lattices (`delta = 3h` in 3D, 122 partners; `2h` in 2D, 12), PCG to 1e-8;
//! the `amg_lattice` example of this crate reproduces them.
//!
//! * `theta = 0` on level 0. On a 30^3 cube `theta = 0.02` gives 5x more coarse rows for the
//!   same 16 iterations and twice the setup; at `0.05` aggregation stalls (level 1 keeps
//!   71538 of 72900 rows; 179 s setup): one bond's block is ~1/100 of the diagonal block of
//!   a node with 122 partners, so `theta` must stay below ~1/partners. On 2D plates
//!   `theta` in 0..0.08 gives the same level-0 aggregates.
//! * `theta = 0.05` on coarse levels. With 0, a level-1 aggregate (of ~120 nodes) sees ~60
//!   others and the next level merges them by the dozen: the 40^3 cube got a 36-row level 2
//!   and 23 iterations, the 401^2 plate 27; with 0.05, 294 rows and 16, and 18.
//! * Filtered smoothing on wide 3D families (`filter_ratio` 1.5 from 60 partners a node). On the
//!   70^3 cantilever (122 partners, matrix-free): `P` 47.1M -> 20.4M entries, hierarchy 912 ->
//!   429 MiB, Galerkin product 3.3 -> 1.6 s, setup 5.4 -> 4.3 s, 15 -> 19 iterations, solve
//!   1.6 -> 1.9 s; at 106^3 (3.47M unknowns): hierarchy 2557 -> 1194 MiB, setup 23.4 -> 16.9 s,
//!   16 -> 19 iterations, solve 4.9 -> 5.0 s. On a 401^2 plate (`delta = 2h`, 12 partners) it
//!   costs: 17 -> 20 iterations and a slower setup, hence the threshold.
//! * Degree 1. Before the coarse threshold (iterations 2D 101^2 / 3D 30^3), degree 1: 23/16,
//!   2: 18/16, 3: 15/12, 4: 14/10; with it, degrees 1 and 2 both take 15-18 from 2D 101^2
//!   to 3D 40^3, and degree 1 costs 2 products per level per cycle instead of 4.
//!
//! # Inputs
//!
//! The rows of `A` are described by `(node, component)` pairs; the rows of one node must be
//! consecutive (as in linpd's node-major numbering, whatever components the Dirichlet
//! elimination left free: see [`DofGeometry::of`]). Node positions give the rigid-body modes; any
//! other near-null space can be given with [`Amg::with_near_null_space`].
//!
//! # Matrix-free finest level
//!
//! [`Amg::matrix_free`] takes the model instead of its assembled `A_ff`: the setup reads the
//! finest level's blocks from [`Model::for_each_block`] when it needs them (the strength
//! graph, `A T` and `A P`: each block computed three times, a few multiply-adds each), and the
//! cycle's products on that level run the model's matrix-free apply (the lattice stencil of a
//! homogeneous bond model). The hierarchy is the assembled one (same levels, same `rho`, same
//! iterations: tested), without the finest matrix, which on a 3D lattice with 123 partners
//! is ~4/5 of what the assembled hierarchy holds. Stored: `P`, `R = P^T`, the coarse levels,
//! the smoothers' `D^{-1}`.

mod aggregate;
mod filter;
mod geometric;
mod level;
mod prolongator;
mod smoother;
mod streamed;
mod vbr;

pub use geometric::{CoarseSpace, LatticeMultigrid};
pub use prolongator::rigid_body_modes;
pub use smoother::AmgSmoother;

use super::{DofGeometry, Preconditioner};
use crate::direct::{Cholesky, CholeskyFactor, DIRECT_RESIDUAL_LIMIT};
use crate::SolveError;
use level::LevelMatrix;
use linpd_core::sparse::Csc;
use linpd_core::{DofMap, LinearOperator, Model, Point};
use serde::Serialize;
use std::time::Instant;
use streamed::Streamed;
pub(crate) use vbr::split_at_bounds;
use vbr::Vbr;

/// Setup parameters of [`Amg`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AmgParams {
    /// Strength threshold `theta` on level 0 (0: every nonzero block is strong).
    pub strength_theta: f64,
    /// Strength threshold on the coarse levels (aggregates of aggregates).
    pub coarse_strength_theta: f64,
    /// The smoother of every level but the coarsest.
    pub smoother: AmgSmoother,
    /// Stop coarsening at this many rows (the coarsest level is factored).
    pub max_coarse: usize,
    /// At most this many levels (the last one is factored whatever its size).
    pub max_levels: usize,
    /// `omega rho(D^{-1} A)` of the prolongator smoothing (pyamg: 4/3).
    pub prolongation_omega: f64,
    /// Lanczos steps of the `rho(D^{-1} A)` estimate.
    pub lanczos_steps: usize,
    /// Smooth the finest level's prolongator with the filtered matrix of the partners within
    /// this multiple of each node's nearest distance (`None`: with `A`), when the level's
    /// interaction graph and positions are known and its nodes have at least
    /// [`AmgParams::filter_min_partners`] partners on average (module docs, "Measured choices").
    pub filter_ratio: Option<f64>,
    /// The mean partners per node from which [`AmgParams::filter_ratio`] applies.
    pub filter_min_partners: usize,
}

impl Default for AmgParams {
    fn default() -> Self {
        AmgParams {
            strength_theta: 0.0,
            coarse_strength_theta: 0.05,
            smoother: AmgSmoother::default(),
            max_coarse: 2000,
            max_levels: 10,
            prolongation_omega: 4.0 / 3.0,
            lanczos_steps: 15,
            filter_ratio: Some(1.5),
            filter_min_partners: 60,
        }
    }
}

impl AmgParams {
    /// Rejects parameters that would make the cycle singular or not SPD: no smoothing, an
    /// empty or inverted Chebyshev interval, a negative threshold, no coarsening at all.
    pub fn validate(&self) -> Result<(), AmgError> {
        let bad = |what: String| Err(AmgError::Input(format!("AMG parameters: {what}")));
        match self.smoother {
            AmgSmoother::Chebyshev { degree, lower, upper } => {
                if degree == 0 || !(lower > 0.0 && lower < upper && upper.is_finite()) {
                    return bad(format!(
                        "Chebyshev degree {degree} on [{lower}, {upper}] rho (need degree >= 1, 0 < lower < upper)"
                    ));
                }
            }
            AmgSmoother::Jacobi { omega, sweeps } => {
                if sweeps == 0 || !(omega > 0.0 && omega < 2.0) {
                    return bad(format!("Jacobi omega {omega} x {sweeps} sweeps (need 0 < omega < 2, sweeps >= 1)"));
                }
            }
        }
        if !(self.strength_theta >= 0.0 && self.coarse_strength_theta >= 0.0) {
            return bad(format!(
                "strength thresholds {} / {} (need >= 0)",
                self.strength_theta, self.coarse_strength_theta
            ));
        }
        if !(self.prolongation_omega > 0.0 && self.prolongation_omega < 2.0) {
            return bad(format!("prolongation omega {} (need 0 < omega < 2)", self.prolongation_omega));
        }
        if let Some(r) = self.filter_ratio.filter(|r| !(r.is_finite() && *r >= 1.0)) {
            return bad(format!("filter ratio {r} (need >= 1: the nearest partners are kept)"));
        }
        if self.max_levels == 0 {
            return bad("max_levels 0 (need >= 1)".into());
        }
        Ok(())
    }
}

/// Whether the interaction graph `(ptr, idx)` is wide enough for the filtered prolongator
/// smoothing ([`AmgParams::filter_min_partners`]).
fn wide(graph: &(Vec<usize>, Vec<u32>), params: &AmgParams) -> bool {
    let nodes = graph.0.len().saturating_sub(1).max(1);
    graph.1.len() >= params.filter_min_partners * nodes
}

/// The position of every row block (a run of rows of one node) of the free DOFs `rows`.
fn block_positions(rows: &[(usize, usize)], positions: &[Point]) -> Vec<Point> {
    let mut out = Vec::new();
    for (r, &(node, _)) in rows.iter().enumerate() {
        if r == 0 || rows[r - 1].0 != node {
            out.push(positions[node]);
        }
    }
    out
}

/// One level of the hierarchy.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AmgLevelStats {
    /// Rows (unknowns).
    pub rows: usize,
    /// Stored entries of the level's matrix.
    pub nnz: usize,
    /// Row blocks: nodes on level 0, aggregates on coarse levels.
    pub blocks: usize,
    /// `rho(D^{-1} A)` estimate (not computed on the coarsest level).
    pub rho: Option<f64>,
    /// Stored entries of the prolongator to the next level.
    pub prolongator_nnz: Option<usize>,
}

/// Where the setup time went, in seconds.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct AmgSetupTimes {
    /// Copying `A` into blocks.
    pub convert: f64,
    /// Strength and aggregation.
    pub aggregate: f64,
    /// Tentative prolongators.
    pub tentative: f64,
    /// Lanczos estimates.
    pub spectral: f64,
    /// Prolongator smoothing `A T`.
    pub smooth: f64,
    /// Galerkin products `R (A P)` and transposes.
    pub galerkin: f64,
    /// Symbolic and numeric Cholesky of the coarsest level.
    pub coarse_factor: f64,
}

/// What the setup built and what it cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AmgStats {
    /// Levels, finest first; the last is factored.
    pub levels: Vec<AmgLevelStats>,
    /// `sum_l nnz(A_l) / nnz(A_0)`.
    pub operator_complexity: f64,
    /// `sum_l rows(A_l) / rows(A_0)`.
    pub grid_complexity: f64,
    /// Stored entries of the coarsest Cholesky factor.
    pub coarse_factor_nnz: usize,
    /// Bytes the hierarchy holds: the block copies of `A_l`, `P`, `R = P^T`, the smoothers'
    /// `D^{-1}` and the coarse factor's values (the caller's `A` not counted).
    pub memory_bytes: usize,
    /// Total setup time (seconds).
    pub setup_seconds: f64,
    /// Setup time by phase.
    pub times: AmgSetupTimes,
}

/// An AMG setup failure.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AmgError {
    /// The row description does not fit the matrix.
    #[error("AMG input: {0}")]
    Input(String),
    /// A diagonal entry is not positive: `e_i . A e_i <= 0`, so the level is not SPD.
    #[error(
        "AMG level {level}: diagonal entry {value:e} of row {row} is not positive: the matrix is not positive definite"
    )]
    NonPositiveDiagonal {
        /// Level (0: the input matrix).
        level: usize,
        /// Row on that level.
        row: usize,
        /// The entry.
        value: f64,
    },
    /// A level's matrix has a non-finite entry.
    #[error("AMG level {level}: the matrix has non-finite entries")]
    NonFinite {
        /// Level.
        level: usize,
    },
    /// The `rho(D^{-1} A)` estimate is not positive or not finite.
    #[error("AMG level {level}: spectral radius estimate {value:e} of D^-1 A is not positive: the matrix is not positive definite")]
    BadSpectrum {
        /// Level.
        level: usize,
        /// The estimate.
        value: f64,
    },
    /// The Cholesky factorization of the coarsest level met a non-positive pivot.
    #[error("AMG level {level} (coarsest, {rows} rows): the coarse matrix is not positive definite (pivot at coarse row {row}); the input matrix is singular or indefinite")]
    CoarseNotPositiveDefinite {
        /// Level.
        level: usize,
        /// Its rows.
        rows: usize,
        /// The row of the failed pivot.
        row: usize,
    },
    /// The coarsest factor solves its own matrix badly: a positive but round-off-sized pivot,
    /// i.e. the coarse matrix (and so the input) is numerically singular.
    #[error("AMG level {level} (coarsest): the coarse matrix is numerically singular (relative residual {rel_residual:.2e} of a test solve); the input matrix is singular")]
    CoarseSingular {
        /// Level.
        level: usize,
        /// `||A_c x - b|| / ||b||` for `b = A_c v`, `v` pseudo-random.
        rel_residual: f64,
    },
    /// The coarse factorization failed for another reason.
    #[error("AMG level {level}: coarse factorization failed: {reason}")]
    CoarseFactorization {
        /// Level.
        level: usize,
        /// faer's message.
        reason: String,
    },
}

/// The transfer operators and smoother of a level above the coarsest.
#[derive(Debug)]
struct Level {
    p: Vbr,
    r: Vbr,
    smoother: smoother::Smoother,
}

/// The finest level's matrix: the input matrix in blocks, or a model's `A_ff` computed on
/// demand ([`Amg::matrix_free`]).
enum Fine<'a> {
    Assembled(Vbr),
    Streamed(Streamed<'a>),
}

impl Fine<'_> {
    fn matrix(&self) -> &dyn LevelMatrix {
        match self {
            Fine::Assembled(a) => a,
            Fine::Streamed(s) => s,
        }
    }
}

/// The SA-AMG V-cycle preconditioner (see the module docs). `'a`: the model a matrix-free
/// finest level reads ([`Amg::matrix_free`]); `'static` for an assembled input.
pub struct Amg<'a> {
    /// `A_0`.
    fine: Fine<'a>,
    /// `A_l` of the smoothed coarse levels `l = 1 .. L - 1` (the coarsest is only factored).
    mats: Vec<Vbr>,
    levels: Vec<Level>,
    coarse: CholeskyFactor,
    stats: AmgStats,
    /// Per smoothed level the cycle's vectors `r`, `d` (its size) and `b_c`, `x_c` (the next
    /// level's), kept between cycles: allocated per cycle they were fresh pages every time
    /// (at 11M unknowns about 180 MB a V-cycle, a share of the 43 s of system time).
    work: Vec<std::sync::Mutex<[Vec<f64>; 4]>>,
}

impl std::fmt::Debug for Amg<'_> {
    /// The statistics only: the level matrices hold millions of entries.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Amg").field("stats", &self.stats).finish_non_exhaustive()
    }
}

impl Amg<'static> {
    /// Sets up the hierarchy for the symmetric positive definite `a` (both triangles stored)
    /// whose row `i` is component `rows[i].1` of node `rows[i].0`, with node positions
    /// `positions[node]` in dimension `dim` (1, 2, 3); the near-null space is the rigid-body
    /// modes ([`rigid_body_modes`]).
    pub fn new(
        a: &Csc,
        dim: usize,
        rows: &[(usize, usize)],
        positions: &[Point],
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        let geometry = DofGeometry { dim, rows: rows.to_vec(), positions: positions.to_vec(), partners: None };
        Self::from_geometry(a, &geometry, params)
    }

    /// [`Amg::new`] from the [`DofGeometry`] of a reduced system (what a
    /// [`crate::PreconditionerInput`] carries); the finest level is aggregated on
    /// `geometry.partners` (the model's bonds) when given.
    pub fn from_geometry(a: &Csc, geometry: &DofGeometry, params: &AmgParams) -> Result<Self, AmgError> {
        let dim = geometry.dim;
        if !(1..=3).contains(&dim) {
            return Err(AmgError::Input(format!("dimension {dim} (need 1, 2 or 3)")));
        }
        let (rows, positions) = (&geometry.rows, &geometry.positions);
        if let Some((i, &(node, c))) = rows.iter().enumerate().find(|(_, &(n, c))| c >= dim || n >= positions.len()) {
            return Err(AmgError::Input(format!(
                "row {i} is component {c} of node {node}: need a component < {dim} and a node < {}",
                positions.len()
            )));
        }
        let modes = rigid_body_modes(dim, rows, positions);
        let nodes: Vec<usize> = rows.iter().map(|r| r.0).collect();
        Self::assembled(a, &nodes, &modes, geometry.partners.as_ref(), Some(positions), params)
    }

    /// Sets up the hierarchy with a caller's near-null space: `modes[m][i]` is mode `m` at
    /// row `i`, and `row_node[i]` the node of row `i` (rows of a node consecutive).
    pub fn with_near_null_space(
        a: &Csc,
        row_node: &[usize],
        modes: &[Vec<f64>],
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        Self::assembled(a, row_node, modes, None, None, params)
    }

    /// [`Amg::with_near_null_space`], the finest level aggregated on `graph` (over the row
    /// blocks) when given, else on the strength graph of `a`.
    fn assembled(
        a: &Csc,
        row_node: &[usize],
        modes: &[Vec<f64>],
        graph: Option<&(Vec<usize>, Vec<u32>)>,
        node_positions: Option<&[Point]>,
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        let t0 = Instant::now();
        params.validate()?;
        let n = a.nrows();
        if a.ncols() != n || row_node.len() != n || n == 0 {
            return Err(AmgError::Input(format!(
                "A is {} x {} with {} row descriptions (need square, nonempty, one per row)",
                a.nrows(),
                a.ncols(),
                row_node.len()
            )));
        }
        if modes.is_empty() || modes.iter().any(|m| m.len() != n) {
            return Err(AmgError::Input(format!("need at least one near-null-space mode of length {n}")));
        }
        // Blocks: runs of equal node numbers, each node in one run.
        let mut rptr = vec![0usize];
        let mut seen = std::collections::HashSet::new();
        for i in 0..n {
            if i > 0 && row_node[i] != row_node[i - 1] {
                rptr.push(i);
            }
            if (i == 0 || row_node[i] != row_node[i - 1]) && !seen.insert(row_node[i]) {
                return Err(AmgError::Input(format!(
                    "the rows of node {} are not consecutive (row {i} again)",
                    row_node[i]
                )));
            }
        }
        rptr.push(n);
        if a.val().iter().any(|v| !v.is_finite()) {
            return Err(AmgError::NonFinite { level: 0 });
        }
        let k = modes.len();
        let b: Vec<f64> = (0..n * k).map(|p| modes[p % k][p / k]).collect();
        let mut times = AmgSetupTimes::default();
        let t = Instant::now();
        let amat = Vbr::from_symmetric_csc(a, &rptr);
        times.convert = t.elapsed().as_secs_f64();
        let positions = node_positions
            .filter(|_| params.filter_ratio.is_some())
            .map(|p| rptr[..rptr.len() - 1].iter().map(|&r| p[row_node[r]]).collect());
        Amg::build(Fine::Assembled(amat), (b, k), graph, positions, params, t0, times)
    }
}

impl<'a> Amg<'a> {
    /// Sets up the hierarchy for `A_ff` of `model` on the free DOFs of `dofs` without storing
    /// it (the finest level is matrix-free: see the module docs), with the rigid-body modes of
    /// the free DOFs as near-null space. `full` applies the model's `A` over all DOFs (its
    /// fast stencil apply where it has one); the cycle's products on the finest level run
    /// through it. Needs the model's blocks ([`Model::for_each_block`]).
    pub fn matrix_free(
        model: &'a dyn Model,
        dofs: &'a DofMap,
        full: &'a dyn LinearOperator,
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        Self::matrix_free_with(model, dofs, full, None, params)
    }

    /// [`Amg::matrix_free`] reusing what the caller already computed: the free DOFs'
    /// geometry ([`DofGeometry::of`] of `model` and `dofs`: its bond graph is a pass over
    /// every bond) and the diagonal of `A_ff`.
    pub fn matrix_free_with(
        model: &'a dyn Model,
        dofs: &'a DofMap,
        full: &'a dyn LinearOperator,
        known: Option<(&DofGeometry, &[f64])>,
        params: &AmgParams,
    ) -> Result<Self, AmgError> {
        let t0 = Instant::now();
        params.validate()?;
        let dim = model.dim();
        if !(1..=3).contains(&dim) {
            return Err(AmgError::Input(format!("dimension {dim} (need 1, 2 or 3)")));
        }
        if dofs.n_free() == 0 {
            return Err(AmgError::Input("no free DOF".into()));
        }
        let mut times = AmgSetupTimes::default();
        let t = Instant::now();
        if let Some((g, d)) = known {
            if g.rows.len() != dofs.n_free() || d.len() != dofs.n_free() || g.positions.len() != model.n_nodes() {
                return Err(AmgError::Input(format!(
                    "the given geometry ({} rows, {} nodes) or diagonal ({}) is not that of the {} free DOFs",
                    g.rows.len(),
                    g.positions.len(),
                    d.len(),
                    dofs.n_free()
                )));
            }
        }
        let fine = Streamed::new(model, dofs, full, known.map(|k| k.1.to_vec())).ok_or_else(|| {
            AmgError::Input(format!(
                "the {} model does not provide its stiffness blocks: matrix-free multigrid is not available for it \
                 (assemble: \"matrix_free\": false)",
                model.kind()
            ))
        })?;
        let computed;
        let geometry = match known {
            Some((g, _)) => g,
            None => {
                computed = DofGeometry::of(model, dofs);
                &computed
            }
        };
        let modes = rigid_body_modes(dim, &geometry.rows, &geometry.positions);
        let (n, k) = (dofs.n_free(), modes.len());
        let b: Vec<f64> = (0..n * k).map(|p| modes[p % k][p / k]).collect();
        if fine.diagonal().iter().any(|v| !v.is_finite()) {
            return Err(AmgError::NonFinite { level: 0 });
        }
        times.convert = t.elapsed().as_secs_f64();
        let positions = params.filter_ratio.map(|_| block_positions(&geometry.rows, &geometry.positions));
        Amg::build(Fine::Streamed(fine), (b, k), geometry.partners.as_ref(), positions, params, t0, times)
    }

    /// The setup loop (module docs, steps 1-5) from the finest level `fine` and the
    /// near-null space `b` (row-major `n x k`); the finest level is aggregated on `graph`
    /// when given (the model's bonds between the row blocks, [`DofGeometry::partners`]), and
    /// its prolongator smoothed with the filtered matrix when `positions` (of its row blocks)
    /// and a wide enough `graph` are given ([`AmgParams::filter_ratio`]).
    fn build(
        fine: Fine<'a>,
        (mut b, k): (Vec<f64>, usize),
        graph: Option<&(Vec<usize>, Vec<u32>)>,
        positions: Option<Vec<Point>>,
        params: &AmgParams,
        t0: Instant,
        mut times: AmgSetupTimes,
    ) -> Result<Self, AmgError> {
        let mut levels = Vec::new();
        let mut mats: Vec<Vbr> = Vec::new();
        let mut level_stats = Vec::new();
        loop {
            let l = levels.len();
            let amat: &dyn LevelMatrix = if l == 0 { fine.matrix() } else { &mats[l - 1] };
            let rows = amat.nrows();
            level_stats.push(AmgLevelStats {
                rows,
                nnz: amat.nnz(),
                blocks: amat.n_row_blocks(),
                rho: None,
                prolongator_nnz: None,
            });
            if rows <= params.max_coarse || l + 1 >= params.max_levels {
                break;
            }
            let diag = amat.diagonal();
            if let Some((row, &value)) = diag.iter().enumerate().find(|(_, &d)| !(d > 0.0)) {
                return Err(AmgError::NonPositiveDiagonal { level: l, row, value });
            }
            let dinv: Vec<f64> = diag.iter().map(|d| 1.0 / d).collect();
            let t = Instant::now();
            let theta = if l == 0 { params.strength_theta } else { params.coarse_strength_theta };
            let (agg, n_agg) = match graph.filter(|_| l == 0) {
                Some((ptr, idx)) => {
                    if ptr.len() != amat.n_row_blocks() + 1 {
                        return Err(AmgError::Input(format!(
                            "the interaction graph has {} nodes, the matrix {} row blocks",
                            ptr.len() - 1,
                            amat.n_row_blocks()
                        )));
                    }
                    aggregate::standard_aggregation(ptr, idx)
                }
                None => {
                    let (sp, si) = amat.strong_neighbours(theta);
                    aggregate::standard_aggregation(&sp, &si)
                }
            };
            times.aggregate += t.elapsed().as_secs_f64();
            if n_agg == amat.n_row_blocks() {
                // No node has a strong neighbour: coarsening stalled; factor this level.
                break;
            }
            let t = Instant::now();
            let (tent, bc) = prolongator::tentative(amat, &agg, n_agg, &b, k);
            times.tentative += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let rho = smoother::spectral_radius(amat, &dinv, params.lanczos_steps);
            times.spectral += t.elapsed().as_secs_f64();
            if !(rho > 0.0 && rho.is_finite()) {
                return Err(AmgError::BadSpectrum { level: l, value: rho });
            }
            let t = Instant::now();
            let p = match (l, params.filter_ratio) {
                (0, Some(ratio)) if positions.is_some() && graph.is_some_and(|g| wide(g, params)) => {
                    let pos = positions.as_deref().unwrap_or_default();
                    match filter::smooth_filtered(amat, &tent, pos, ratio, graph.expect("checked"), params) {
                        Some((p, entries)) => {
                            level_stats[0].nnz = entries;
                            p
                        }
                        None => prolongator::smooth(amat, &tent, &dinv, params.prolongation_omega / rho),
                    }
                }
                _ => prolongator::smooth(amat, &tent, &dinv, params.prolongation_omega / rho),
            };
            drop(tent);
            // A matrix-free level counts its entries in its first pass over the blocks (the
            // filter's, when it ran).
            level_stats[l].nnz = level_stats[l].nnz.max(amat.nnz());
            times.smooth += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let r = p.transpose();
            let ac = amat.galerkin(&p, &r);
            times.galerkin += t.elapsed().as_secs_f64();
            if ac.val.iter().any(|v| !v.is_finite()) {
                return Err(AmgError::NonFinite { level: l + 1 });
            }
            let s = level_stats.last_mut().unwrap();
            s.rho = Some(rho);
            s.prolongator_nnz = Some(p.nnz());
            levels.push(Level { p, r, smoother: smoother::Smoother::new(params.smoother, dinv, rho) });
            mats.push(ac);
            b = bc;
        }
        let t = Instant::now();
        let l = levels.len();
        // The coarsest matrix is only factored: take it out of the smoothed levels.
        let coarsest = match (l, &fine) {
            (0, Fine::Assembled(a)) => a.to_symmetric_csc(),
            (0, Fine::Streamed(s)) => {
                let a = s.assemble();
                level_stats[0].nnz = a.nnz();
                a.to_symmetric_csc()
            }
            _ => mats.pop().expect("a coarse level per smoothed level").to_symmetric_csc(),
        };
        let (coarse_factor_nnz, coarse) = Self::factor_coarsest(&coarsest, l)?;
        times.coarse_factor = t.elapsed().as_secs_f64();
        let nnz0 = level_stats[0].nnz as f64;
        let rows0 = level_stats[0].rows as f64;
        let stats = AmgStats {
            operator_complexity: level_stats.iter().map(|s| s.nnz as f64).sum::<f64>() / nnz0,
            grid_complexity: level_stats.iter().map(|s| s.rows as f64).sum::<f64>() / rows0,
            levels: level_stats,
            coarse_factor_nnz,
            memory_bytes: fine.matrix().bytes()
                + mats.iter().map(Vbr::bytes).sum::<usize>()
                + levels.iter().map(|lv| lv.p.bytes() + lv.r.bytes() + 8 * lv.p.nrows()).sum::<usize>()
                + 8 * coarse_factor_nnz,
            setup_seconds: t0.elapsed().as_secs_f64(),
            times,
        };
        let work = levels.iter().map(|_| std::sync::Mutex::new(Default::default())).collect();
        Ok(Amg { fine, mats, levels, coarse, stats, work })
    }

    /// The Cholesky factor of the coarsest matrix `a` (level `level`) and its stored entries.
    /// A singular coarse matrix can factor with round-off pivots instead of failing: a test
    /// solve catches it (the limit of the direct solvers, `kappa` beyond ~1e10).
    fn factor_coarsest(a: &Csc, level: usize) -> Result<(usize, CholeskyFactor), AmgError> {
        let rows = a.nrows();
        let map = |e: SolveError| match e {
            SolveError::NotPositiveDefinite { dof } => AmgError::CoarseNotPositiveDefinite { level, rows, row: dof },
            other => AmgError::CoarseFactorization { level, reason: other.to_string() },
        };
        let chol = Cholesky::analyze(a).map_err(map)?;
        let coarse = chol.factor(a).map_err(map)?;
        let v: Vec<f64> = (0..rows).map(|i| 1.0 + ((i * 7919) % 113) as f64 / 113.0).collect();
        let mut bc = vec![0.0; rows];
        linpd_core::sparse::sym_matvec(a, &v, &mut bc);
        let xc = coarse.solve(&bc);
        let rel_residual = linpd_core::sparse::relative_residual(a, true, &xc, &bc);
        if !(rel_residual <= DIRECT_RESIDUAL_LIMIT) {
            return Err(AmgError::CoarseSingular { level, rel_residual });
        }
        Ok((chol.nnz_factor(), coarse))
    }

    /// What the setup built and what it cost.
    pub fn stats(&self) -> &AmgStats {
        &self.stats
    }

    /// `A` itself: the block copy the hierarchy holds (the same values; its product reads 8
    /// bytes per entry plus one index per block instead of the 16 of a `usize` CSC entry, so
    /// CG with it runs its own products faster than with [`crate::SymCsc`]), or the model's
    /// apply of a matrix-free finest level.
    pub fn operator(&self) -> AmgOperator<'_> {
        AmgOperator(self.fine.matrix())
    }

    /// Whether the finest level is matrix-free ([`Amg::matrix_free`]).
    pub fn is_matrix_free(&self) -> bool {
        matches!(self.fine, Fine::Streamed(_))
    }

    /// The matrix of level `l` (not the coarsest).
    fn level_matrix(&self, l: usize) -> &dyn LevelMatrix {
        if l == 0 {
            self.fine.matrix()
        } else {
            &self.mats[l - 1]
        }
    }

    /// `x = V_l(b)` (see the module docs).
    fn cycle(&self, l: usize, b: &[f64], x: &mut [f64]) {
        let Some(level) = self.levels.get(l) else {
            x.copy_from_slice(&self.coarse.solve(b));
            return;
        };
        let (n, nc) = (b.len(), level.r.nrows());
        // the kept vectors, or fresh ones when another cycle on this level holds them (a
        // blocking lock could wait on a task its own thread has to run)
        let mut fresh: [Vec<f64>; 4] = Default::default();
        let mut kept = self.work[l].try_lock().ok();
        let [r, d, bc, xc] = kept.as_deref_mut().unwrap_or(&mut fresh);
        r.resize(n, 0.0);
        d.resize(n, 0.0);
        bc.resize(nc, 0.0);
        xc.resize(nc, 0.0);
        let a = self.level_matrix(l);
        level.smoother.smooth(a, b, x, r, d, true, true);
        // zeroed: a product that scales its output by 0 keeps a NaN of a previous cycle
        bc.iter_mut().for_each(|v| *v = 0.0);
        level.r.matvec(r, bc);
        xc.iter_mut().for_each(|v| *v = 0.0);
        self.cycle(l + 1, bc, xc);
        level.p.matvec_add(xc, x);
        level.smoother.smooth(a, b, x, r, d, false, false);
    }
}

impl Preconditioner for Amg<'_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        self.cycle(0, r, z);
    }
    fn summary(&self) -> Option<String> {
        let s = &self.stats;
        let rows: Vec<String> = s.levels.iter().map(|l| l.rows.to_string()).collect();
        Some(format!(
            "SA-AMG: {} levels ({} rows), operator complexity {:.2}, {}{:.1} MiB, setup {:.2} s",
            s.levels.len(),
            rows.join(" > "),
            s.operator_complexity,
            if self.is_matrix_free() { "finest level matrix-free, " } else { "" },
            s.memory_bytes as f64 / 1048576.0,
            s.setup_seconds
        ))
    }
    fn operator_copy(&self) -> Option<&dyn linpd_core::LinearOperator> {
        match &self.fine {
            Fine::Assembled(a) => Some(a),
            // Level 0 is the caller's operator, or a companion of it
            // (`Model::multigrid_companion`): never offered as the operator to solve.
            Fine::Streamed(_) => None,
        }
    }
}

/// The input matrix `A` as a [`linpd_core::LinearOperator`], from [`Amg::operator`].
#[derive(Clone, Copy)]
pub struct AmgOperator<'a>(&'a dyn LevelMatrix);

impl std::fmt::Debug for AmgOperator<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "AmgOperator({} rows)", self.0.nrows())
    }
}

impl linpd_core::LinearOperator for Vbr {
    fn n(&self) -> usize {
        self.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.matvec(x, y)
    }
}

impl linpd_core::LinearOperator for AmgOperator<'_> {
    fn n(&self) -> usize {
        self.0.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.matvec(x, y)
    }
}
