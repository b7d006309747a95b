//! Phases and defects of a 1D blended bar: how a [`linpd_core::Material`] (the bond model's
//! `material`) enters the three parts of Algorithm A.
//!
//! # Moduli: a point function `K(x)`
//!
//! `K(x)` is the modulus of the last phase whose (closed) region contains `x`, and the model's
//! `K` (the reference `K_ref`) where none does, exactly as for the bond model's nodes.
//!
//! * **Nonlocal (PD) terms.** Bond `(x_i, x_j)` gets the bond model's factor
//!   `mu_ij = rule(K(x_i), K(x_j)) / K_ref * prod_{defects crossed} factor_d`, so its
//!   micromodulus is `mu_ij C(|xi|)` and the nonlocal coefficient of eq. (22) becomes
//!   `a_ij mu_ij w_j` with `a_ij = (beta_i + beta_j) / 2`.
//! * **Local terms of a transition row** (a row with both shares): eq. (13)-(14) applied to the
//!   heterogeneous kernel `mu C`: the local share `(1 - a_ij) mu_ij C` is Taylor expanded, so
//!
//!   ```text
//!   D_n^i = (1/n!) sum_{j=-N..N} (1 - a_ij) mu_ij w_j (j dx)^n,
//!   ```
//!
//!   and Algorithm A's `SUM1 = D_1`, `SUM2 = D_2`, where the paper's identity
//!   `(1/2) int C xi^2 = K` (eq. (7), used to write `D_2 = K (1 - beta/2) - ...` in (15)) now
//!   reads `(1/2) sum_j mu_ij w_j (j dx)^2 = K_h(x_i)`, the horizon average of the bond moduli.
//!   `K_h(x_i) = K(x_i)` because a transition row must see one modulus on its whole stencil
//!   `[x_i - eps, x_i + eps]` ([`check_interfaces`]): at a phase interface `u'` jumps, the
//!   Taylor expansion (12) of a transition row would be wrong there, and its local part would
//!   be a horizon-smeared, bond-rule-dependent modulus (measured: an interface 0.01 = eps/2 past
//!   a transition row moved a bar's displacements by 1.3 %). Interfaces may lie in the pure
//!   PD rows' zone `[L2 + 2 eps, L3 - 2 eps]` and in the pure CE zones `x <= L1 - 2 eps`,
//!   `x >= L4 + 2 eps`, or a phase may cover a whole transition zone (then `K_h = K_phase`
//!   there and the blended rows are Algorithm A with that modulus).
//! * **Pure CE rows** (`beta = 0` on the whole stencil, and every row of a coarse CE mesh):
//!   classical elasticity `-(K(x) u')'` in divergence form, in force form
//!
//!   ```text
//!   (A u)_i = k_{i-1/2} (u_i - u_{i-1}) / (x_i - x_{i-1}) + k_{i+1/2} (u_i - u_{i+1}) / (x_{i+1} - x_i),
//!   k_{i+1/2} = (x_{i+1} - x_i) / int_{x_i}^{x_{i+1}} dx / K(x),
//!   ```
//!
//!   the series (length-weighted harmonic) modulus of the interval: the exact stiffness of a
//!   bar segment whose modulus jumps inside it, so point loads give the exact piecewise-linear
//!   solution at the nodes wherever the interfaces lie. With `K(x) = K` it is eq. (28). The
//!   integral is exact: `K` is constant between the region boundaries of the phases
//!   ([`breakpoints`]), and is evaluated at the midpoint of each piece.
//!
//! # Defects
//!
//! A defect multiplies the micromodulus of the bonds crossing it (`factor 0`: a pre-crack). The
//! local terms of Algorithm A assume a displacement that is smooth over their stencil (the
//! Taylor expansion (12) and the differences (20)-(21)); across a crack or a weakened bond it is
//! not, and a local operator has nothing to weaken (a point has zero length in classical
//! elasticity). Scaling the local terms would put a weak zone of width `2 eps`, a PD length,
//! into the local model, and the differences would still couple the two faces of a pre-crack.
//! So a defect must sit where the model is exactly PD: every row with a bond crossing it (and
//! every row whose local difference stencil spans it) must be a pure PD row, `a_ij = 1` on its
//! whole stencil, the paper's set II (eq. (29)). That holds for defects in
//! `[L2 + 2 eps, L3 - 2 eps]`, a horizon inside `Omega_PD^0 = (L2 + eps, L3 - eps)` (11);
//! [`check_defects`] tests the rows themselves and refuses any other defect, naming it.
//!
//! The same reason keeps phase interfaces out of the stencils of transition rows (above);
//! pure PD rows take any interface through `mu_ij`, pure CE rows through `k_{i+1/2}`.

use crate::{BlendError, Mesh};
use linpd_core::{Material, Region, GEOMETRY_RTOL};

/// The points of `[lo, hi]` where `region`'s indicator may jump, for a 1D region (interval
/// ends of boxes and balls, the point of a half space), appended to `out`.
fn region_breakpoints(region: &Region, out: &mut Vec<f64>) {
    match region {
        Region::Box { min, max } => out.extend([min[0], max[0]]),
        Region::Ball { center, radius } => out.extend([center[0] - radius, center[0] + radius]),
        Region::HalfSpace { point, .. } => out.push(point[0]),
        Region::Union(parts) => parts.iter().for_each(|r| region_breakpoints(r, out)),
        Region::Difference(a, b) => {
            region_breakpoints(a, out);
            region_breakpoints(b, out);
        }
        // `all` has no boundary; cylinders and polygons are not 1D regions (refused by
        // `Region::validate(1)`).
        _ => {}
    }
}

/// Every point where `K(x)` may jump, ascending: the region boundaries of all phases.
pub fn breakpoints(material: &Material) -> Vec<f64> {
    let mut out = Vec::new();
    material.phases.iter().for_each(|(r, _)| region_breakpoints(r, &mut out));
    out.retain(|v| v.is_finite());
    out.sort_by(f64::total_cmp);
    out.dedup();
    out
}

/// `K(x)` and the bond factors of a material on a bar with lattice spacing `dx`.
#[derive(Debug, Clone)]
pub struct BarMaterial<'a> {
    material: &'a Material,
    k_ref: f64,
    tol: f64,
    cuts: Vec<f64>,
}

impl<'a> BarMaterial<'a> {
    /// `K_ref` is the model's modulus; region tests use the bond model's tolerance
    /// `GEOMETRY_RTOL dx`, so that nodes get the same moduli as in a bond scene.
    pub fn new(material: &'a Material, k_ref: f64, dx: f64) -> Self {
        BarMaterial { material, k_ref, tol: GEOMETRY_RTOL * dx, cuts: breakpoints(material) }
    }

    /// True without phases or defects.
    pub fn is_homogeneous(&self) -> bool {
        self.material.is_homogeneous()
    }

    /// `K(x)`: the last phase containing `x`, `K_ref` outside every phase.
    pub fn modulus_at(&self, x: f64) -> f64 {
        let p = [x, 0.0, 0.0];
        self.material.phases.iter().rev().find(|(r, _)| r.contains(&p, 1, self.tol)).map_or(self.k_ref, |(_, k)| *k)
    }

    /// The series modulus `(b - a) / int_a^b dx / K(x)` of the interval `[a, b]` (exact:
    /// `K` is constant between breakpoints). Returns `K` itself, bit for bit, when `K` is the
    /// same on the whole interval.
    pub fn face_modulus(&self, a: f64, b: f64) -> f64 {
        if self.material.phases.is_empty() {
            return self.k_ref;
        }
        let lo = self.cuts.partition_point(|&c| c <= a);
        let hi = self.cuts.partition_point(|&c| c < b);
        let mut pts = Vec::with_capacity(hi.saturating_sub(lo) + 2);
        pts.push(a);
        pts.extend_from_slice(&self.cuts[lo..hi.max(lo)]);
        pts.push(b);
        let pieces: Vec<(f64, f64)> = pts
            .windows(2)
            .filter(|w| w[1] > w[0])
            .map(|w| (w[1] - w[0], self.modulus_at(0.5 * (w[0] + w[1]))))
            .collect();
        let first = pieces.first().map_or(self.k_ref, |p| p.1);
        if pieces.iter().all(|p| p.1 == first) {
            return first;
        }
        (b - a) / pieces.iter().map(|(l, k)| l / k).sum::<f64>()
    }

    /// The micromodulus multiplier `mu_ij` of the bond from `x` (modulus `kx`) to `y` (modulus
    /// `ky`): the bond model's rule and defects ([`Material::bond_factor`]).
    pub fn bond_factor(&self, x: f64, y: f64, kx: f64, ky: f64) -> f64 {
        if self.is_homogeneous() {
            return 1.0;
        }
        self.material.bond_factor(&[x, 0.0, 0.0], &[y, 0.0, 0.0], kx, ky, self.k_ref, self.tol)
    }

    /// `K` on the closed interval `[a, b]` if it is one value there, else the first point of
    /// `[a, b]` where it changes.
    pub fn uniform_on(&self, a: f64, b: f64) -> Result<f64, f64> {
        let k0 = self.modulus_at(a);
        if self.material.phases.is_empty() {
            return Ok(k0);
        }
        let lo = self.cuts.partition_point(|&c| c < a);
        let hi = self.cuts.partition_point(|&c| c <= b);
        let mut prev = a;
        for &c in self.cuts[lo..hi.max(lo)].iter().chain(std::iter::once(&b)) {
            // The piece before `c` and `c` itself (a node on a boundary takes the closed
            // region's modulus).
            if self.modulus_at(0.5 * (prev + c)) != k0 || self.modulus_at(c) != k0 {
                return Err(c);
            }
            prev = c;
        }
        Ok(k0)
    }

    /// The index of a phase whose region has a boundary at `x` (the one an error names).
    fn phase_with_boundary_at(&self, x: f64) -> usize {
        self.material
            .phases
            .iter()
            .position(|(r, _)| {
                let mut b = Vec::new();
                region_breakpoints(r, &mut b);
                b.contains(&x)
            })
            .unwrap_or(0)
    }

    /// Checks that every phase region holds some part of the bar `[0, length]` (a phase that
    /// holds none is a typo: it would change nothing).
    pub fn check_phases(&self, length: f64) -> Result<(), BlendError> {
        for (k, (region, _)) in self.material.phases.iter().enumerate() {
            let mut pts = vec![0.0, length];
            region_breakpoints(region, &mut pts);
            pts.retain(|v| (0.0..=length).contains(v));
            pts.sort_by(f64::total_cmp);
            let mids = pts.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect::<Vec<_>>();
            let inside = pts.iter().chain(&mids).any(|&x| region.contains(&[x, 0.0, 0.0], 1, self.tol));
            if !inside {
                return Err(BlendError::param(
                    format!("material.phases[{k}].region"),
                    format!("contains no point of the bar [0, {length}]"),
                ));
            }
        }
        Ok(())
    }
}

/// Refuses phase interfaces within the stencil `[x_i - eps, x_i + eps]` of a transition row
/// (a row with both a nonlocal and a local share; see the module docs). Errors are named
/// `material.phases[k].region`.
pub fn check_interfaces(
    mat: &BarMaterial,
    mesh: &Mesh,
    beta: &[f64],
    n_side: usize,
    eps: f64,
    regions: &crate::Regions,
) -> Result<(), BlendError> {
    if mat.material.phases.is_empty() {
        return Ok(());
    }
    for i in 0..mesh.len() {
        let Some(k) = mesh.fine[i] else { continue };
        let (mut any, mut all) = (false, beta[i] == 1.0);
        for q in (1..=n_side as i64).flat_map(|j| [k - j, k + j]) {
            match mesh.node_of_fine(q) {
                Some(p) => {
                    any |= beta[i] + beta[p] > 0.0;
                    all &= beta[p] == 1.0;
                }
                None => all = false,
            }
        }
        if !any || all {
            continue;
        }
        let x = mesh.x[i];
        if let Err(c) = mat.uniform_on(x - eps, x + eps) {
            let (l1, l2, l3, l4) = (regions.l1, regions.l2, regions.l3, regions.l4);
            return Err(BlendError::param(
                format!("material.phases[{}].region", mat.phase_with_boundary_at(c)),
                format!(
                    "its boundary at x = {c} lies within a horizon of the transition row at x = {x} (a row with both PD and CE shares): the local terms of such a row are the Taylor expansion (12) of u, which the kink of u at a phase interface breaks. Keep interfaces out of [L1 - 2 eps, L2 + 2 eps] = [{}, {}] and [L3 - 2 eps, L4 + 2 eps] = [{}, {}], or let one phase cover a whole transition zone",
                    l1 - 2.0 * eps,
                    l2 + 2.0 * eps,
                    l3 - 2.0 * eps,
                    l4 + 2.0 * eps
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses every defect that is not inside the pure PD zone (see the module docs): for defect
/// `d` at `x_d`, every node within a horizon of `x_d` (it has bonds crossing it) and every node
/// whose neighbours straddle `x_d` (its local differences would span it) must have a pure PD
/// row, i.e. `beta = 1` at the node and at all `2N` lattice neighbours. `pure_ce` is true for
/// the pure CE model (no bonds at all). Errors are named `material.defects[k]`.
pub fn check_defects(
    material: &Material,
    mesh: &Mesh,
    beta: &[f64],
    n_side: usize,
    eps: f64,
    pure_ce: bool,
    zone: (f64, f64),
) -> Result<(), BlendError> {
    let x = &mesh.x;
    let n = x.len();
    let tol = GEOMETRY_RTOL * mesh.dx;
    let pure_pd = |i: usize| -> bool {
        let Some(k) = mesh.fine[i] else { return false };
        beta[i] == 1.0
            && (1..=n_side as i64)
                .all(|j| [k - j, k + j].iter().all(|&q| mesh.node_of_fine(q).is_some_and(|p| beta[p] == 1.0)))
    };
    for (k, d) in material.defects.iter().enumerate() {
        let name = format!("material.defects[{k}]");
        let linpd_core::Defect::Point { x: xd, .. } = d else {
            return Err(BlendError::param(name, "the 1D blended model takes point defects"));
        };
        if pure_ce {
            return Err(BlendError::param(
                name,
                "ce models have no bonds for a defect to weaken (classical elasticity cannot hold a crack at a point): use a blend model with the defect in its pure PD zone",
            ));
        }
        let touches = |i: usize| {
            let near = (x[i] - xd).abs() <= eps + tol;
            let spans = i > 0 && i + 1 < n && x[i - 1] - tol <= *xd && *xd <= x[i + 1] + tol;
            near || spans
        };
        if let Some(i) = (0..n).find(|&i| touches(i) && !pure_pd(i)) {
            return Err(BlendError::param(
                name,
                format!(
                    "x = {xd} is not in the pure PD zone: the row of node {i} (x = {}) has a bond crossing it and a local (CE) share (beta < 1 within its horizon); the local terms of Algorithm A assume a displacement smooth across their stencil (eq. (12), (20)-(21)) and cannot hold a crack or a weakened bond. Place defects a horizon inside Omega_PD^0 = (L2 + eps, L3 - eps), i.e. in [L2 + 2 eps, L3 - 2 eps] = [{}, {}]",
                    x[i], zone.0, zone.1
                ),
            ));
        }
    }
    Ok(())
}
