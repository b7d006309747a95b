//! Surface corrections by moment matching: per-node directional factors that give every node
//! the bulk's response to the basic affine deformations (issue #14).
//!
//! # Why fourth moments
//!
//! Near a free surface a node's family is truncated, so the node stores the wrong strain energy
//! for a homogeneous deformation (the peridynamic surface effect). For an affine field
//! `u = eps x` every bond's linearized extension is `e_ij = n . eps . n |xi|` (`n = xi / |xi|`),
//! so every energy that is a weighted sum of squared extensions over a node's bonds is a
//! quadratic form in `eps` whose coefficients are the node's fourth moments
//! `sum_j beta_ij n^alpha` (`|alpha| = 4`), `beta_ij` the bond's geometric weight
//! (`g(|xi|) nu V_j |xi|^2` for a bond-based micromodulus shape `g`, `omega nu V_j |xi|^2` for
//! LPS). The bond-based energy density of node `i` is `(c/4) sum_j beta_ij (n . eps . n)^2`; the
//! LPS weighted volume `m_i`, the shape tensor `sum_j omega nu V_j xi (x) xi` (which decides
//! whether the dilatation of an affine field is exact) and the deviatoric energy are
//! contractions of the same moments (with `sum_c n_c^2 = 1`).
//!
//! # Which moments: the even ones
//!
//! We match the **even** moments
//!
//! ```text
//! T_i[a a a a] = sum_j beta_ij n_a^4,     T_i[a a b b] = sum_j beta_ij n_a^2 n_b^2   (a != b)  (S1)
//! ```
//!
//! (6 in 3D, 3 in 2D, 1 in 1D) to the interior lattice values `T_0`. They are the energies of the
//! uniaxial strains `eps = e_a (x) e_a` and the simple shears `eps = sym(e_a (x) e_b)` along the
//! lattice axes, and they fix every affine state whose strain is diagonal in those axes (e.g.
//! uniaxial stress along a bar): its energy `sum_ab eps_a eps_b T[aabb]`, and for LPS the weighted
//! volume `m_i = sum_ab T[aabb]` and the dilatation `d sum_a eps_a T_i[a a . .] / m_i`. The odd
//! moments (`n_x^3 n_y`, `n_x^2 n_y n_z`, ...) couple normal strains to shears; they vanish in the
//! interior and on a flat face (mirror symmetry) and **cannot** be zero at an edge or corner with
//! positive weights (on a quarter-space family `n_x^3 n_y >= 0` for every bond), so matching them
//! needs negative influence: tried first (15 moments, least-squares factors), it made
//! factors of -29..55 at the corners of a 7^3 cube and an indefinite tangent. We keep the
//! factors positive and leave the odd moments alone.
//!
//! # The per-node factor
//!
//! Among the positive factors `phi_ij` that match (S1), the one of maximum entropy relative to
//! 1 (minimum `sum_j beta_ij (phi_ij log phi_ij - phi_ij + 1)`) has the form
//!
//! ```text
//! phi_i(n) = exp(lambda_i . psi(n)),    psi = (n_x^4, n_y^4, n_z^4, n_x^2 n_y^2, n_y^2 n_z^2, n_x^2 n_z^2),   (S2)
//! ```
//!
//! a smooth positive function of the bond direction; `lambda_i` (Lagrange multipliers of the
//! moment constraints) minimizes the convex dual `sum_j beta_ij phi_i(n_ij) - lambda . T_0`, found
//! by Newton's method ([`fit_moments`]). The constant function is in the span
//! (`sum_a n_a^4 + 2 sum_{a<b} n_a^2 n_b^2 = 1`), so a uniform scalar correction is one case.
//! `phi` is even in `n`, so both ends of a bond evaluate it on the same direction.
//!
//! **Interior nodes are all corrected alike**: when `|T_0 - T_i| <= 1e-12 |T_0|` (a full family:
//! the two sums differ only by summation order) the node takes the full stencil's fit, computed
//! once, so every interior node has the same factors bit for bit (exactly 1 for the lattice
//! target below).
//!
//! # What is matched against what: the classical or the lattice target
//!
//! [`SurfaceTarget::Classical`] (the default) matches every node to the moments of classical
//! isotropic elasticity, the integrals of (S1) over a ball (`int n_a^4 dOmega = 3 int n_a^2
//! n_b^2 dOmega`):
//!
//! ```text
//! 3D:  T*[a a a a] = tr / 5,     T*[a a b b] = tr / 15
//! 2D:  T*[a a a a] = 3 tr / 8,   T*[a a b b] = tr / 8                                     (S4)
//! 1D:  T* = tr
//! ```
//!
//! with `tr = sum_ab T[a a b b] = sum_j beta_ij` the moment that fixes the bulk modulus (the
//! model's normalization: the exact integral `int g |xi|^2 dV` for a continuum-normalized
//! micromodulus, the full stencil's lattice sum otherwise; LPS divides by the node's own `m_i`,
//! so only the shape matters). A cubic lattice's interior family is **not** isotropic: with
//! `omega = 1/|xi|` and `delta = 3h` in 3D its `T_0[xxxx] / (3 T_0[xxyy]) = 0.868`, which makes the
//! LPS interior 11 % too soft in uniaxial stress along an axis (`E_x = 0.891 E` at `nu = 1/4`);
//! corrected to the lattice target, thin bars then converge to that error instead of to the
//! classical solution (`linpd study surface`, docs/models.md). With the classical target the
//! interior nodes get a factor too: one function `phi_0(n)` of the bond direction, the same for
//! every node with a full family (computed once from the stencil; bit for bit the same on every
//! such node and on the grid's layer), which removes the lattice's cubic anisotropy from (S1).
//!
//! [`SurfaceTarget::Lattice`] matches the interior **lattice** moments `T_0` (the full stencil
//! with the bulk cell volume): the interior is left exactly unchanged (factors exactly 1) and a
//! surface node's response equals the interior's, cubic anisotropy included.
//!
//! # From node factors to bond factors
//!
//! [`FactorRule`]: a per-node influence function (LPS `position_aware`: node `i` uses
//! `phi_i(n)` in its own sums), the mean of the ends `(phi_i + phi_j) / 2` (S3) (LPS `energy`,
//! a symmetric influence function; LPS divides by each node's own weighted volume, which fixes
//! the scale the mean loses), or (S3) followed by the mean of the ends' trace ratios (S5)
//! (bond-based `energy`: `linpd_bond::surface`).
//!
//! The weights `beta` are geometric (no material modulus, no defect weakening): a material
//! interface is not a surface and must not be corrected; a bond cut by a defect (factor 0) is
//! missing from the family, so crack faces are corrected like any other free surface.

/// What the corrected moments (S1) are matched to (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurfaceTarget {
    /// The isotropic moments of classical elasticity (S4): every node, interior included, gets
    /// the classical energy for the states of (S1).
    #[default]
    Classical,
    /// The interior lattice's moments: interior nodes keep factor exactly 1.
    Lattice,
}

impl SurfaceTarget {
    /// The name used in scene files (`model.surface_target`).
    pub fn name(self) -> &'static str {
        match self {
            SurfaceTarget::Classical => "classical",
            SurfaceTarget::Lattice => "lattice",
        }
    }
}

/// The isotropic moments (S4) with trace `tr`, in the order of [`monomials`].
pub fn isotropic_moments(dim: usize, tr: f64) -> Vec<f64> {
    match dim {
        1 => vec![tr],
        2 => vec![3.0 * tr / 8.0, 3.0 * tr / 8.0, tr / 8.0],
        _ => vec![tr / 5.0, tr / 5.0, tr / 5.0, tr / 15.0, tr / 15.0, tr / 15.0],
    }
}

/// The trace `sum_ab T[a a b b] = sum_j beta_j` of moments (S1) (`sum_a n_a^2 = 1`).
pub fn moment_trace(dim: usize, t: &[f64]) -> f64 {
    match dim {
        1 => t[0],
        2 => t[0] + t[1] + 2.0 * t[2],
        _ => t[0] + t[1] + t[2] + 2.0 * (t[3] + t[4] + t[5]),
    }
}

/// Exponents `(a1, a2, a3)` of the even degree-4 monomials `n_x^a1 n_y^a2 n_z^a3`, per
/// dimension: the moments of the uniaxial strains `e_a (x) e_a` (`n_a^4`) and of the simple
/// shears `sym(e_a (x) e_b)` (`n_a^2 n_b^2`).
const EXPONENTS_3D: [[i32; 3]; 6] = [[4, 0, 0], [0, 4, 0], [0, 0, 4], [2, 2, 0], [0, 2, 2], [2, 0, 2]];
/// The same in 2D.
const EXPONENTS_2D: [[i32; 3]; 3] = [[4, 0, 0], [0, 4, 0], [2, 2, 0]];
/// And in 1D (`n_x^4 = 1`: the factor is a scalar per node).
const EXPONENTS_1D: [[i32; 3]; 1] = [[4, 0, 0]];

/// Relative mismatch `|T_0 - T_i| / |T_0|` below which a family counts as full and takes the
/// full stencil's fit (summation-order round-off of the two sums is `~ n_bonds eps`).
pub const INTERIOR_RTOL: f64 = 1e-12;

/// Newton's iteration for (S2) stops when the moments match to this relative accuracy.
pub const FIT_RTOL: f64 = 1e-13;

/// At most this many Newton steps per node (quadratic convergence takes 4-8 from `lambda = 0`;
/// a target out of reach makes `lambda` run away, and the fit stops with its mismatch).
const MAX_NEWTON: usize = 60;

fn exponents(dim: usize) -> &'static [[i32; 3]] {
    match dim {
        1 => &EXPONENTS_1D,
        2 => &EXPONENTS_2D,
        _ => &EXPONENTS_3D,
    }
}

/// Number of moments (and multipliers) per node: 1, 3 or 6.
pub fn n_moments(dim: usize) -> usize {
    exponents(dim).len()
}

/// The monomials `psi_k(n) = n^alpha_k` of a unit vector `n`, written into `out`
/// (length [`n_moments`]).
pub fn monomials(dim: usize, n: &[f64; 3], out: &mut [f64]) {
    for (o, a) in out.iter_mut().zip(exponents(dim)) {
        *o = n[0].powi(a[0]) * n[1].powi(a[1]) * n[2].powi(a[2]);
    }
}

/// The moments (S1) of a set of bonds given as `(unit direction, beta)`.
pub fn moments(dim: usize, bonds: impl IntoIterator<Item = ([f64; 3], f64)>) -> Vec<f64> {
    let k = n_moments(dim);
    let (mut t, mut psi) = (vec![0.0; k], vec![0.0; k]);
    for (n, beta) in bonds {
        monomials(dim, &n, &mut psi);
        for (t, p) in t.iter_mut().zip(&psi) {
            *t += beta * p;
        }
    }
    t
}

/// The multipliers of one node's factor `phi(n) = exp(lambda . psi(n))` (S2).
#[derive(Debug, Clone, PartialEq)]
pub struct MomentFit {
    /// `lambda` (all zero for an interior node).
    pub lambda: Vec<f64>,
    /// `|T_0 - T(phi)| / |T_0|` after the fit: below [`FIT_RTOL`] when the moments are
    /// matched, larger when the target is out of the family's reach.
    pub mismatch: f64,
    /// Newton steps taken.
    pub iterations: usize,
    /// True when no bounded positive factor matches the target and the fit is the regularized
    /// one ([`fit_moments`]).
    pub out_of_reach: bool,
}

impl MomentFit {
    /// The fit that leaves every bond unchanged (`lambda = 0`).
    pub fn identity(dim: usize) -> Self {
        MomentFit { lambda: vec![0.0; n_moments(dim)], mismatch: 0.0, iterations: 0, out_of_reach: false }
    }

    /// The factor `phi(n)` for the unit bond direction `n` (exactly 1 for the identity fit).
    pub fn factor(&self, dim: usize, n: &[f64; 3]) -> f64 {
        if self.is_identity() {
            return 1.0;
        }
        let mut psi = [0.0; 6];
        let k = n_moments(dim);
        monomials(dim, n, &mut psi[..k]);
        exponent_factor(self.lambda.iter().zip(&psi[..k]).map(|(l, p)| l * p).sum())
    }

    /// True when every factor of this fit is exactly 1.
    pub fn is_identity(&self) -> bool {
        self.lambda.iter().all(|&l| l == 0.0)
    }
}

/// `exp(x)`, capped at `exp(+-600)` so that a run-away fit cannot overflow (the regularized
/// refit of [`fit_moments`] replaces such fits).
fn exponent_factor(x: f64) -> f64 {
    x.clamp(-600.0, 600.0).exp()
}

/// Solves (S2) for one node: the positive factor `phi(n) = exp(lambda . psi(n))` whose bonds'
/// moments equal `target`, by Newton's method on the convex dual
/// `L(lambda) = sum_j beta_j phi_j - lambda . target` (gradient `T(phi) - target`, Hessian the
/// `phi`-weighted Gram matrix `sum_j beta_j phi_j psi_j psi_j^T`) from `lambda = 0`, with
/// backtracking on `L`. `bonds` are `(unit direction, beta)` with `beta >= 0`.
///
/// **Out of reach.** When no positive factor matches the target (a family whose directions all
/// lie in a narrow wedge: the tip of a corner sharper than about 60 degrees in 2D), the dual has
/// no minimum and `lambda` runs away (measured: `|lambda| ~ 1e9` after 60 steps, deleting some
/// bonds with factors `exp(-1e9)`). Then the fit is redone on the regularized dual
/// `L + (rho/2) |lambda|^2` with `rho = 1` (in units of `|target|`), whose minimizer is bounded:
/// the moments are matched as far as bounded factors allow, [`MomentFit::out_of_reach`] says
/// so, and [`MomentFit::mismatch`] says by how much.
pub fn fit_moments(dim: usize, bonds: &[([f64; 3], f64)], target: &[f64]) -> MomentFit {
    let k = n_moments(dim);
    assert_eq!(target.len(), k, "fit_moments: target length");
    let scale = norm(target);
    if scale == 0.0 {
        return MomentFit::identity(dim);
    }
    let psi: Vec<Vec<f64>> = bonds
        .iter()
        .map(|(n, _)| {
            let mut p = vec![0.0; k];
            monomials(dim, n, &mut p);
            p
        })
        .collect();
    let dual = Dual { bonds, psi: &psi, target, scale, k };
    let first = dual.eval(&vec![0.0; k], 0.0);
    if norm(&first.moment_residual) <= INTERIOR_RTOL {
        return MomentFit { mismatch: norm(&first.moment_residual), ..MomentFit::identity(dim) };
    }
    let fit = dual.newton(0.0);
    if fit.mismatch <= OUT_OF_REACH_RTOL {
        return fit;
    }
    let bounded = dual.newton(1.0);
    MomentFit { iterations: fit.iterations + bounded.iterations, out_of_reach: true, ..bounded }
}

/// A fit whose moments still miss by more than this (relative) after Newton on the plain dual
/// is redone on the regularized dual ([`fit_moments`]).
pub const OUT_OF_REACH_RTOL: f64 = 1e-8;

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The dual of (S2) for one node, everything divided by `|target|` to keep it O(1).
struct Dual<'a> {
    bonds: &'a [([f64; 3], f64)],
    psi: &'a [Vec<f64>],
    target: &'a [f64],
    scale: f64,
    k: usize,
}

/// The dual's value, gradient and Hessian (lower triangle, row-major) at one `lambda`, and the
/// moment residual `(T(phi) - target) / |target|` (the gradient without the regularization).
struct DualAt {
    value: f64,
    gradient: Vec<f64>,
    hessian: Vec<f64>,
    moment_residual: Vec<f64>,
}

impl Dual<'_> {
    fn eval(&self, lambda: &[f64], rho: f64) -> DualAt {
        let k = self.k;
        let (mut value, mut res, mut hessian) = (0.0, vec![0.0; k], vec![0.0; k * k]);
        for ((_, beta), p) in self.bonds.iter().zip(self.psi) {
            let w = beta / self.scale * exponent_factor(lambda.iter().zip(p).map(|(a, b)| a * b).sum());
            value += w;
            for a in 0..k {
                res[a] += w * p[a];
                for b in 0..=a {
                    hessian[a * k + b] += w * p[a] * p[b];
                }
            }
        }
        for a in 0..k {
            value += -lambda[a] * self.target[a] / self.scale + 0.5 * rho * lambda[a] * lambda[a];
            res[a] -= self.target[a] / self.scale;
            hessian[a * k + a] += rho;
        }
        let gradient = res.iter().zip(lambda).map(|(r, l)| r + rho * l).collect();
        DualAt { value, gradient, hessian, moment_residual: res }
    }

    /// Newton with backtracking from `lambda = 0` on the dual regularized by `rho`.
    fn newton(&self, rho: f64) -> MomentFit {
        let k = self.k;
        let mut lambda = vec![0.0; k];
        let mut at = self.eval(&lambda, rho);
        let mut iterations = 0;
        while norm(&at.gradient) > FIT_RTOL && iterations < MAX_NEWTON {
            iterations += 1;
            // Newton step -H^+ g (pseudo-inverse: H is singular when the family's directions do
            // not separate the monomials).
            let eig = crate::eigen::symmetric_eigen(&at.hessian, k);
            let top = eig.values.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            let mut step = vec![0.0; k];
            for (s, &mu) in eig.values.iter().enumerate() {
                if mu > 1e-14 * top {
                    let c = -(0..k).map(|a| eig.vector(a, s) * at.gradient[a]).sum::<f64>() / mu;
                    for (a, x) in step.iter_mut().enumerate() {
                        *x += c * eig.vector(a, s);
                    }
                }
            }
            let slope: f64 = step.iter().zip(&at.gradient).map(|(a, b)| a * b).sum();
            if slope >= 0.0 {
                break;
            }
            let mut t = 1.0;
            let accepted = loop {
                let trial: Vec<f64> = lambda.iter().zip(&step).map(|(a, b)| a + t * b).collect();
                let next = self.eval(&trial, rho);
                if next.value <= at.value + 1e-4 * t * slope || norm(&next.gradient) < norm(&at.gradient) {
                    lambda = trial;
                    at = next;
                    break true;
                }
                t *= 0.5;
                if t < 1e-10 {
                    break false;
                }
            };
            if !accepted {
                break;
            }
        }
        MomentFit { lambda, mismatch: norm(&at.moment_residual), iterations, out_of_reach: false }
    }
}

/// The factors of a moment-matching correction for every bond of a lattice family (flat, in
/// family order), and the summary for the report: the one implementation behind the bond
/// `energy` correction and the LPS `energy` / `position_aware` corrections.
///
/// * `beta(r, v)`: the geometric weight of a bond of length `r` whose far node has volume `v`
///   (it includes `r^2`); `T_0` is the sum over the full lattice stencil with the bulk cell
///   volume;
/// * `target`: [`SurfaceTarget::Lattice`] matches `T_0`; [`SurfaceTarget::Classical`] the
///   isotropic moments (S4) with trace `trace` (`None`: the trace of `T_0`). Nodes whose family
///   is full (moments equal to `T_0` to [`INTERIOR_RTOL`]) and the layer's nodes all get the one
///   fit of the full stencil (the identity for the lattice target);
/// * `bond(i, b)`: the unit vector and length of node `i`'s `b`-th bond, or `None` for a bond
///   that does not count (cut by a defect); it gets factor 1;
/// * nodes of the grid's layer keep factor 1 (the layer holds constraints and loads, it is not
///   a free surface);
/// * `rule`: how a bond's factor is made from its ends' ([`FactorRule`]).
#[allow(clippy::too_many_arguments)]
pub fn family_factors(
    dim: usize,
    grid: &crate::Grid,
    family: &crate::BondFamily,
    horizon: f64,
    beta: impl Fn(f64, f64) -> f64 + Sync,
    bond: impl Fn(usize, usize) -> Option<([f64; 3], f64)> + Sync,
    rule: FactorRule,
    kind: &'static str,
    target: SurfaceTarget,
    trace: Option<f64>,
) -> (Vec<f64>, CorrectionSummary) {
    use rayon::prelude::*;
    let start = std::time::Instant::now();
    let h = grid.spacing();
    let stencil: Vec<([f64; 3], f64)> = crate::family::lattice_stencil(dim, horizon / h)
        .into_iter()
        .map(|k| {
            let xi = [k[0] as f64 * h, k[1] as f64 * h, k[2] as f64 * h];
            let r = norm(&xi);
            ([xi[0] / r, xi[1] / r, xi[2] / r], beta(r, grid.volume()))
        })
        .collect();
    let lattice = moments(dim, stencil.iter().copied());
    let goal = match target {
        SurfaceTarget::Lattice => lattice.clone(),
        SurfaceTarget::Classical => isotropic_moments(dim, trace.unwrap_or_else(|| moment_trace(dim, &lattice))),
    };
    // the full family's fit (the identity for the lattice target), shared by every full family
    let bulk = fit_moments(dim, &stencil, &goal);
    let full = |t: &[f64]| {
        let d: Vec<f64> = t.iter().zip(&lattice).map(|(a, b)| a - b).collect();
        norm(&d) <= INTERIOR_RTOL * norm(&lattice)
    };
    let fits: Vec<(MomentFit, bool)> = (0..family.len())
        .into_par_iter()
        .map(|i| {
            if grid.is_layer(i) {
                return (bulk.clone(), false);
            }
            let bonds: Vec<([f64; 3], f64)> = family
                .neighbors(i)
                .iter()
                .enumerate()
                .filter_map(|(b, &j)| bond(i, b).map(|(n, r)| (n, beta(r, grid.node_volume(j as usize)))))
                .collect();
            if full(&moments(dim, bonds.iter().copied())) {
                return (bulk.clone(), false);
            }
            (fit_moments(dim, &bonds, &goal), true)
        })
        .collect();
    let surface_nodes = fits.iter().filter(|f| f.1).count();
    let fits: Vec<MomentFit> = fits.into_iter().map(|f| f.0).collect();
    let bulk_range = stencil.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |r, (n, _)| {
        let f = bulk.factor(dim, n);
        [r[0].min(f), r[1].max(f)]
    });
    let bond_beta = |i: usize, b: usize| {
        let j = family.neighbors(i)[b] as usize;
        bond(i, b).map(|(n, r)| (n, beta(r, grid.node_volume(j))))
    };
    let fitted = Fitted { fits, surface_nodes, interior_range: bulk_range, start };
    let what = (kind, target, moment_trace(dim, &goal));
    combine(dim, family, fitted, &bond_beta, &|i| grid.is_layer(i), rule, what)
}

/// The fits of every node and what the summary reports of them.
struct Fitted {
    fits: Vec<MomentFit>,
    surface_nodes: usize,
    interior_range: [f64; 2],
    start: std::time::Instant,
}

/// The bond factors of the node fits `fitted` by `rule` ((S3), and (S5) with the target's
/// trace), and the summary. `bond(i, b)`: the unit vector and `beta` of node `i`'s `b`-th bond
/// (`None`: a bond that does not count, factor 1); `layer(i)`: nodes that keep their scale.
fn combine(
    dim: usize,
    family: &crate::BondFamily,
    fitted: Fitted,
    bond: &(impl Fn(usize, usize) -> Option<([f64; 3], f64)> + Sync),
    layer: &(impl Fn(usize) -> bool + Sync),
    rule: FactorRule,
    (kind, target, trace): (&'static str, SurfaceTarget, f64),
) -> (Vec<f64>, CorrectionSummary) {
    use rayon::prelude::*;
    let fits = &fitted.fits;
    let per_node = rule == FactorRule::OwnEnd;
    let mut per_bond: Vec<Vec<f64>> = (0..family.len())
        .into_par_iter()
        .map(|i| {
            let fi = &fits[i];
            family
                .neighbors(i)
                .iter()
                .enumerate()
                .map(|(b, &j)| {
                    let fj = &fits[j as usize];
                    match bond(i, b) {
                        Some(_) if fi.is_identity() && (per_node || fj.is_identity()) => 1.0,
                        Some((n, _)) if per_node => fi.factor(dim, &n),
                        Some((n, _)) => 0.5 * (fi.factor(dim, &n) + fj.factor(dim, &n)),
                        None => 1.0,
                    }
                })
                .collect()
        })
        .collect();
    if rule == FactorRule::MeanOfEndsScaled {
        scale_by_traces(family, layer, bond, trace, &mut per_bond);
    }
    let factors: Vec<f64> = per_bond.into_iter().flatten().collect();
    let range = factors
        .iter()
        .filter(|&&f| f != 1.0)
        .fold([f64::INFINITY, f64::NEG_INFINITY], |r, &f| [r[0].min(f), r[1].max(f)]);
    let summary = CorrectionSummary {
        kind,
        target,
        corrected_nodes: fitted.surface_nodes,
        interior_factor_range: fitted.interior_range,
        factor_range: if range[0] > range[1] { [1.0, 1.0] } else { range },
        max_mismatch: fits.iter().fold(0.0, |m, f| m.max(f.mismatch)),
        max_iterations: fits.iter().map(|f| f.iterations).max().unwrap_or(0),
        out_of_reach_nodes: fits.iter().filter(|f| f.out_of_reach).count(),
        seconds: fitted.start.elapsed().as_secs_f64(),
    };
    (factors, summary)
}

/// The factors of a moment-matching correction on a point cloud: as [`family_factors`] with the
/// classical target of trace `trace` (a cloud has no lattice stencil to match), every node not
/// in `layer` fitted on its own (an irregular cloud's interior families differ from node to
/// node, so the fit also evens out their quadrature), and the `layer` nodes, as a lattice's,
/// treated as interior: they take the fit of the fullest family (the largest moment trace),
/// which on a cloud of a lattice's nodes is the full lattice family's fit; `bond(i, b)`: the
/// unit vector and the geometric weight `beta` of node `i`'s `b`-th bond (`None`: a bond that
/// does not count).
pub fn cloud_factors(
    dim: usize,
    family: &crate::BondFamily,
    bond: impl Fn(usize, usize) -> Option<([f64; 3], f64)> + Sync,
    layer: &[bool],
    rule: FactorRule,
    kind: &'static str,
    trace: f64,
) -> (Vec<f64>, CorrectionSummary) {
    use rayon::prelude::*;
    let start = std::time::Instant::now();
    let goal = isotropic_moments(dim, trace);
    let is_layer = |i: usize| layer.get(i).copied().unwrap_or(false);
    // each node's fit and its moments' trace (the layer's fits are set below)
    let fitted: Vec<(MomentFit, f64)> = (0..family.len())
        .into_par_iter()
        .map(|i| {
            if is_layer(i) {
                return (MomentFit::identity(dim), f64::NEG_INFINITY);
            }
            let bonds: Vec<([f64; 3], f64)> = (0..family.neighbors(i).len()).filter_map(|b| bond(i, b)).collect();
            (fit_moments(dim, &bonds, &goal), moment_trace(dim, &moments(dim, bonds.iter().copied())))
        })
        .collect();
    // the layer as interior, as on a lattice: the fit of the fullest family (the largest
    // moment trace), a full lattice family's fit on a cloud of lattice nodes
    let fullest = (0..family.len()).filter(|&i| !is_layer(i)).max_by(|&a, &b| fitted[a].1.total_cmp(&fitted[b].1));
    let bulk = fullest.map(|i| fitted[i].0.clone());
    let mut fits: Vec<MomentFit> = fitted.into_iter().map(|f| f.0).collect();
    if let Some(bulk) = bulk {
        (0..family.len()).filter(|&i| is_layer(i)).for_each(|i| fits[i] = bulk.clone());
    }
    let surface_nodes = (0..family.len()).filter(|&i| !is_layer(i)).count();
    // the spread of the interior's factors is the whole cloud's here
    let range = (0..family.len()).filter(|&i| !is_layer(i)).fold([f64::INFINITY, f64::NEG_INFINITY], |r, i| {
        (0..family.neighbors(i).len()).filter_map(|b| bond(i, b)).fold(r, |r, (n, _)| {
            let f = fits[i].factor(dim, &n);
            [r[0].min(f), r[1].max(f)]
        })
    });
    let fitted = Fitted { fits, surface_nodes, interior_range: range, start };
    combine(dim, family, fitted, &bond, &is_layer, rule, (kind, SurfaceTarget::Classical, trace))
}

/// (S5): every node's trace ratio `r_i = tr T* / sum_j beta_ij f_ij` under the bond factors
/// `f_ij` of (S3) (1 on the layer, and snapped to 1 within [`INTERIOR_RTOL`] so that interior
/// nodes stay bit for bit alike), then `f_ij *= (r_i + r_j) / 2`.
fn scale_by_traces(
    family: &crate::BondFamily,
    layer: &(impl Fn(usize) -> bool + Sync),
    bond: &(impl Fn(usize, usize) -> Option<([f64; 3], f64)> + Sync),
    trace: f64,
    per_bond: &mut [Vec<f64>],
) {
    use rayon::prelude::*;
    let ratio: Vec<f64> = (0..family.len())
        .into_par_iter()
        .map(|i| {
            if layer(i) {
                return 1.0;
            }
            let m: f64 =
                (0..family.neighbors(i).len()).filter_map(|b| bond(i, b).map(|(_, beta)| beta * per_bond[i][b])).sum();
            let r = trace / m;
            if m <= 0.0 || (r - 1.0).abs() <= INTERIOR_RTOL {
                1.0
            } else {
                r
            }
        })
        .collect();
    per_bond.par_iter_mut().enumerate().for_each(|(i, factors)| {
        for (b, &j) in family.neighbors(i).iter().enumerate() {
            if bond(i, b).is_some() {
                factors[b] *= 0.5 * (ratio[i] + ratio[j as usize]);
            }
        }
    });
}

/// How [`family_factors`] makes a bond's factor from its two ends' factors `phi_i`, `phi_j`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FactorRule {
    /// `phi_i(n)` in node `i`'s sums (a per-node influence function: LPS `position_aware`).
    OwnEnd,
    /// The mean of the ends, `(phi_i(n) + phi_j(n)) / 2` (S3), the same from both ends (LPS
    /// `energy`: each node's own weighted volume `m_i` then sets its scale).
    MeanOfEnds,
    /// (S3), then scaled by the mean of the ends' trace ratios (S5) (bond-based `energy`: a
    /// bond model has no `m_i` of its own to do it).
    MeanOfEndsScaled,
}

/// The cost and effect of a surface correction, for the solve report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CorrectionSummary {
    /// Which correction (`"energy"`, `"position_aware"`).
    pub kind: &'static str,
    /// What the moments were matched to.
    pub target: SurfaceTarget,
    /// Nodes with a truncated family, fitted one by one (the others share the full family's fit).
    pub corrected_nodes: usize,
    /// The full family's factors `phi_0(n)` over the stencil's directions (exactly `[1, 1]`
    /// for the lattice target; the lattice's cubic anisotropy removed for the classical one).
    pub interior_factor_range: [f64; 2],
    /// The smallest and largest bond factor applied.
    pub factor_range: [f64; 2],
    /// The largest relative moment mismatch left after a fit (0 when every node matched).
    pub max_mismatch: f64,
    /// The most Newton steps one node's fit took.
    pub max_iterations: usize,
    /// Nodes whose moments no bounded positive factor matches (sharp corners): fitted on the
    /// regularized dual, their mismatch included in `max_mismatch`.
    pub out_of_reach_nodes: usize,
    /// Wall time of computing and applying the factors.
    pub seconds: f64,
}

impl CorrectionSummary {
    /// One line for reports: `surface correction energy (classical target): interior factors
    /// 0.87..1.13, 1234 surface nodes fitted, bond factors 0.81..2.4, moments matched to 3e-15,
    /// 0.02 s`.
    pub fn describe(&self) -> String {
        format!(
            "surface correction {} ({} target): interior factors {:.3}..{:.3}, {} surface nodes fitted, \
             bond factors {:.3}..{:.3}, moments matched to {:.1e} (<= {} Newton steps){}, {:.3} s",
            self.kind,
            self.target.name(),
            self.interior_factor_range[0],
            self.interior_factor_range[1],
            self.corrected_nodes,
            self.factor_range[0],
            self.factor_range[1],
            self.max_mismatch,
            self.max_iterations,
            if self.out_of_reach_nodes > 0 {
                format!(
                    "; {} nodes out of reach of positive factors (sharp corners), matched only partly",
                    self.out_of_reach_nodes
                )
            } else {
                String::new()
            },
            self.seconds
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / r, v[1] / r, v[2] / r]
    }

    /// The bonds of the 3D stencil of radius 3 (beta = |k|: omega = 1/|xi| times |xi|^2)
    /// restricted by `keep`.
    fn stencil(keep: impl Fn(&[i64; 3]) -> bool) -> Vec<([f64; 3], f64)> {
        crate::family::lattice_stencil(3, 3.0)
            .into_iter()
            .filter(|k| keep(k))
            .map(|k| {
                let v = [k[0] as f64, k[1] as f64, k[2] as f64];
                let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                (unit(v), r)
            })
            .collect()
    }

    #[test]
    fn a_full_family_keeps_factors_exactly_one() {
        let full = stencil(|_| true);
        let target = moments(3, full.iter().copied());
        // a different summation order of the same bonds
        let mut rev = full.clone();
        rev.reverse();
        let fit = fit_moments(3, &rev, &target);
        assert!(fit.is_identity(), "{:?}", fit.lambda);
        assert_eq!(fit.factor(3, &unit([1.0, 2.0, 0.5])), 1.0);
    }

    #[test]
    fn truncated_families_match_the_interior_moments() {
        let full = stencil(|_| true);
        let target = moments(3, full.iter().copied());
        // half space, quarter space (edge), octant (corner)
        for keep in [
            Box::new(|k: &[i64; 3]| k[0] >= 0) as Box<dyn Fn(&[i64; 3]) -> bool>,
            Box::new(|k: &[i64; 3]| k[0] >= 0 && k[1] >= 0),
            Box::new(|k: &[i64; 3]| k[0] >= 0 && k[1] >= 0 && k[2] >= 0),
        ] {
            let bonds = stencil(keep);
            let fit = fit_moments(3, &bonds, &target);
            let corrected = moments(3, bonds.iter().map(|&(n, b)| (n, b * fit.factor(3, &n))));
            let err = corrected.iter().zip(&target).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            let scale = target.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // Newton stops at FIT_RTOL of |T_0|; max-norm <= 2-norm
            assert!(err <= FIT_RTOL * 3.0 * scale, "moment error {err:e}");
            assert!(fit.mismatch <= FIT_RTOL, "mismatch {:e}", fit.mismatch);
            assert!(fit.iterations <= 12, "{} Newton steps", fit.iterations);
            let min = bonds.iter().map(|(n, _)| fit.factor(3, n)).fold(f64::INFINITY, f64::min);
            assert!(min > 0.0);
        }
    }

    /// (S4) are the sphere's (circle's) averages of the monomials: uniform in the azimuth
    /// (exact for trigonometric polynomials of degree < 128), Gauss-Legendre in `z = cos t`
    /// (the azimuthal average is a polynomial of degree 4 in `z`: exact), so only round-off.
    #[test]
    fn isotropic_moments_are_the_averages_over_directions() {
        let iso = isotropic_moments(3, 1.0);
        for (k, e) in iso.iter().enumerate() {
            let ring = |z: f64| -> f64 {
                let s = (1.0 - z * z).max(0.0).sqrt();
                (0..128)
                    .map(|b| {
                        let p = 2.0 * std::f64::consts::PI * b as f64 / 128.0;
                        let mut psi = [0.0; 6];
                        monomials(3, &[s * p.cos(), s * p.sin(), z], &mut psi);
                        psi[k] / 128.0
                    })
                    .sum()
            };
            let mean = 0.5 * crate::kernel::gauss_legendre(ring, &[-1.0, 1.0], |_| 1);
            assert!((mean - e).abs() <= 1e-15, "{mean} vs {e}");
        }
        let circle: Vec<f64> = (0..3)
            .map(|k| {
                (0..256)
                    .map(|b| {
                        let p = 2.0 * std::f64::consts::PI * b as f64 / 256.0;
                        let mut psi = [0.0; 3];
                        monomials(2, &[p.cos(), p.sin(), 0.0], &mut psi);
                        psi[k] / 256.0
                    })
                    .sum()
            })
            .collect();
        for (m, e) in circle.iter().zip(isotropic_moments(2, 1.0)) {
            // the uniform rule on the circle is exact for degree < 256
            assert!((m - e).abs() <= 1e-15, "{m} vs {e}");
        }
        assert_eq!(moment_trace(3, &iso), 1.0);
        assert_eq!(moment_trace(2, &isotropic_moments(2, 1.0)), 1.0);
    }

    /// The classical target (S4): the full 3D stencil, a half space, an edge and a corner all
    /// fit it with positive factors; the full stencil needs a non-trivial factor (its cubic
    /// anisotropy, `T_0[xxxx] / (3 T_0[xxyy]) = 0.868` at radius 3 with `beta = |k|`).
    #[test]
    fn every_family_fits_the_isotropic_target() {
        let full = stencil(|_| true);
        let lattice = moments(3, full.iter().copied());
        assert!((lattice[0] / (3.0 * lattice[3]) - 0.8677).abs() < 1e-4, "{lattice:?}");
        let target = isotropic_moments(3, moment_trace(3, &lattice));
        for keep in [
            Box::new(|_: &[i64; 3]| true) as Box<dyn Fn(&[i64; 3]) -> bool>,
            Box::new(|k: &[i64; 3]| k[0] >= 0),
            Box::new(|k: &[i64; 3]| k[0] >= 0 && k[1] >= 0),
            Box::new(|k: &[i64; 3]| k[0] >= 0 && k[1] >= 0 && k[2] >= 0),
        ] {
            let bonds = stencil(keep);
            let fit = fit_moments(3, &bonds, &target);
            assert!(!fit.is_identity() && !fit.out_of_reach && fit.mismatch <= FIT_RTOL, "{fit:?}");
            let corrected = moments(3, bonds.iter().map(|&(n, b)| (n, b * fit.factor(3, &n))));
            let err = corrected.iter().zip(&target).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err <= FIT_RTOL * 3.0 * norm(&target), "moment error {err:e}");
        }
    }

    #[test]
    fn a_half_space_in_1d_gets_the_scalar_ratio() {
        let target = [6.0];
        let fit = fit_moments(1, &[([1.0, 0.0, 0.0], 1.0), ([-1.0, 0.0, 0.0], 2.0)], &target);
        // Newton stops at FIT_RTOL of the moment: the factor is 2 to ~1e-13
        assert!((fit.factor(1, &[1.0, 0.0, 0.0]) - 2.0).abs() <= 1e-12);
    }

    /// The tip of a 45-degree wedge in 2D: bonds within [0, 45] degrees cannot carry the
    /// interior's `n_x^2 n_y^2` and `n_y^4` with positive factors; the fit is the regularized
    /// one, bounded (every factor within exp(+-10)), positive, and says it is out of reach.
    #[test]
    fn a_sharp_corner_is_fitted_bounded_and_flagged() {
        let stencil = |keep: &dyn Fn(f64) -> bool| -> Vec<([f64; 3], f64)> {
            crate::family::lattice_stencil(2, 3.0)
                .into_iter()
                .filter(|k| keep((k[1] as f64).atan2(k[0] as f64)))
                .map(|k| {
                    let v = [k[0] as f64, k[1] as f64, 0.0];
                    let r = v[0].hypot(v[1]);
                    (unit(v), r)
                })
                .collect()
        };
        let target = moments(2, stencil(&|_| true).iter().copied());
        let wedge = stencil(&|a| (-1e-9..=std::f64::consts::FRAC_PI_4 + 1e-9).contains(&a));
        let fit = fit_moments(2, &wedge, &target);
        assert!(fit.out_of_reach && fit.mismatch > OUT_OF_REACH_RTOL, "{fit:?}");
        for (n, _) in &wedge {
            let f = fit.factor(2, n);
            assert!(f > (-10.0f64).exp() && f < 10.0f64.exp(), "factor {f:e} at {n:?}");
        }
        // a right angle is within reach
        let quarter = stencil(&|a| (-1e-9..=std::f64::consts::FRAC_PI_2 + 1e-9).contains(&a));
        let fit = fit_moments(2, &quarter, &target);
        assert!(!fit.out_of_reach && fit.mismatch <= FIT_RTOL, "{fit:?}");
    }

    #[test]
    fn too_few_directions_match_in_the_least_squares_sense() {
        // bonds along x and y only cannot carry n_x^2 n_y^2
        let bonds = [([1.0, 0.0, 0.0], 1.0), ([0.0, 1.0, 0.0], 1.0)];
        let fit = fit_moments(2, &bonds, &[1.0, 1.0, 0.5]);
        assert!(fit.mismatch > 0.1, "{:e}", fit.mismatch);
        assert!(fit.lambda.iter().all(|l| l.is_finite()));
    }
}
