//! Heterogeneous materials: per-region moduli, the rule that gives a bond its modulus from
//! its two end nodes, and defects that degrade the bonds crossing them.
//!
//! A bond `(i, j)` gets the micromodulus
//! `lambda_ij = (rule(K_i, K_j) / K_ref) * prod_defects mu_d(i, j) * c g(|xi|)`,
//! where `K_i` is the modulus of the last phase region containing node `i` (the reference
//! modulus `K_ref` where none does). Silling (2010) Example 5.2 ("bonds that have both ends
//! in a hard stripe have hard properties") is [`BondRule::Min`]; Example 5.3's defect is
//! `mu = 0.1` when `x <= x_d <= q` or `q <= x_d <= x` (closed: a bond ending on the defect
//! point counts as crossing it), here [`Defect::Point`] in 1D, [`Defect::Segment`] in 2D and
//! [`Defect::Plane`] in 3D.

use crate::region::{exponent, is_zero, ldexp, max_abs, norm, quarter_diff};
use crate::{CoreError, Grid, Point, Region};

/// How a bond's modulus follows from the moduli at its ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BondRule {
    /// The softer end wins (stiff only if both ends are stiff).
    Min,
    /// The stiffer end wins.
    Max,
    /// `(K_i + K_j) / 2`.
    Arithmetic,
    /// `2 K_i K_j / (K_i + K_j)`: two half-bonds in series.
    #[default]
    Harmonic,
    /// `sqrt(K_i K_j)`.
    Geometric,
}

impl BondRule {
    /// The bond modulus from the end moduli.
    pub fn combine(self, a: f64, b: f64) -> f64 {
        match self {
            BondRule::Min => a.min(b),
            BondRule::Max => a.max(b),
            BondRule::Arithmetic => 0.5 * (a + b),
            BondRule::Harmonic => 2.0 * a * b / (a + b),
            BondRule::Geometric => (a * b).sqrt(),
        }
    }
}

/// A surface of weakness: bonds crossing it are multiplied by `factor` (0 cuts them).
#[derive(Debug, Clone, PartialEq)]
pub enum Defect {
    /// 1D: the point `x`.
    Point {
        /// Location `x_d`.
        x: f64,
        /// Stiffness multiplier `mu`.
        factor: f64,
    },
    /// 2D: the closed segment from `a` to `b`.
    Segment {
        /// First end.
        a: [f64; 2],
        /// Second end.
        b: [f64; 2],
        /// Stiffness multiplier.
        factor: f64,
    },
    /// 3D: the plane through `point` with normal `normal`, restricted to `extent` if given.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// Its normal (need not be unit).
        normal: [f64; 3],
        /// Where on the plane the defect is (crossing points outside are not degraded).
        extent: Option<Region>,
        /// Stiffness multiplier.
        factor: f64,
    },
}

impl Defect {
    /// The stiffness multiplier `mu` of the bonds it crosses.
    pub fn factor(&self) -> f64 {
        match self {
            Defect::Point { factor, .. } | Defect::Segment { factor, .. } | Defect::Plane { factor, .. } => *factor,
        }
    }

    /// Checks that the defect fits the dimension and has a factor in `[0, 1]`... or above
    /// (a stiffening "defect" is allowed, a negative one is not).
    pub fn validate(&self, dim: usize) -> Result<(), CoreError> {
        let f = self.factor();
        if !(f.is_finite() && f >= 0.0) {
            return Err(CoreError::param("factor", format!("must be >= 0, got {f:e}")));
        }
        let needed = match self {
            Defect::Point { .. } => 1,
            Defect::Segment { .. } => 2,
            Defect::Plane { normal, .. } => {
                if is_zero(normal) {
                    return Err(CoreError::param("normal", "must be nonzero (any nonzero length is a direction)"));
                }
                3
            }
        };
        if needed != dim {
            return Err(CoreError::param(
                "defects",
                format!(
                    "a {} defect needs dimension {needed}, the scene has {dim}",
                    match needed {
                        1 => "point",
                        2 => "segment",
                        _ => "plane",
                    }
                ),
            ));
        }
        Ok(())
    }

    /// The distance from `x` to the defect (the point, the segment, the plane); for a plane
    /// restricted to an extent, the larger of the distances to the whole plane and to the
    /// extent's bounding box ([`Region::bounds`]), a lower bound. A bond of `x` no longer than
    /// `r` can cross the defect only if this is at most `r`: what a caller needs to find the
    /// nodes whose families a defect may cut without testing every bond.
    pub fn distance_to(&self, x: &Point) -> f64 {
        match self {
            Defect::Point { x: d, .. } => (x[0] - d).abs(),
            Defect::Segment { a, b, .. } => {
                let (ab, ax) = ([b[0] - a[0], b[1] - a[1]], [x[0] - a[0], x[1] - a[1]]);
                let len2 = ab[0] * ab[0] + ab[1] * ab[1];
                let t = if len2 > 0.0 { ((ax[0] * ab[0] + ax[1] * ab[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
                (ax[0] - t * ab[0]).hypot(ax[1] - t * ab[1])
            }
            Defect::Plane { point, normal, extent, .. } => {
                let e = exponent(max_abs(normal));
                let n = normal.map(|v| ldexp(v, -e));
                let plane = (0..3).map(|k| (x[k] - point[k]) * n[k]).sum::<f64>().abs() / norm(&n);
                // the crossing points lie in the extent, hence in its box
                let to_box = extent.as_ref().and_then(|r| r.bounds(3)).map_or(0.0, |(lo, hi)| {
                    (0..3).map(|k| (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0).powi(2)).sum::<f64>().sqrt()
                });
                plane.max(to_box)
            }
        }
    }

    /// True when the bond from `x` to `y` crosses (or touches) the defect. `tol` is a length.
    pub fn crosses(&self, x: &Point, y: &Point, tol: f64) -> bool {
        match self {
            Defect::Point { x: d, .. } => {
                let (lo, hi) = if x[0] <= y[0] { (x[0], y[0]) } else { (y[0], x[0]) };
                lo - tol <= *d && *d <= hi + tol
            }
            Defect::Segment { a, b, .. } => {
                // boxes more than twice the tolerance apart along an axis: the bond is farther
                // than the tolerance from the segment, no crossing, without the scale-safe
                // distances (most bonds of a lattice near a crack). The orientation test alone
                // may accept such a bond when its end and the segment's both lie within the
                // tolerance of the other's line, beyond each other's ends: that is no crossing.
                let m = 2.0 * tol;
                let apart = (0..2).any(|k| x[k].max(y[k]) < a[k].min(b[k]) - m || x[k].min(y[k]) > a[k].max(b[k]) + m);
                !apart && segments_intersect([x[0], x[1]], [y[0], y[1]], *a, *b, tol)
            }
            Defect::Plane { point, normal, extent, .. } => {
                // signed distances from the plane, a quarter of them against a quarter of `tol`,
                // with the normal scaled by a power of two: any finite point and nonzero normal,
                // and the bits of `(x - point) . normal / |normal|` on ordinary inputs
                let e = exponent(max_abs(normal));
                let n = normal.map(|v| ldexp(v, -e));
                let nn = norm(&n);
                let s = |p: &Point| {
                    let d = quarter_diff(p, point, 3);
                    (0..3).map(|k| d[k] * n[k]).sum::<f64>() / nn
                };
                let (sx, sy, tol) = (s(x), s(y), 0.25 * tol);
                if (sx > tol && sy > tol) || (sx < -tol && sy < -tol) {
                    return false;
                }
                match extent {
                    None => true,
                    Some(region) => {
                        let t = if (sx - sy).abs() > 0.0 { sx / (sx - sy) } else { 0.0 };
                        let t = t.clamp(0.0, 1.0);
                        let p = [x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1]), x[2] + t * (y[2] - x[2])];
                        region.contains(&p, 3, 4.0 * tol)
                    }
                }
            }
        }
    }
}

/// Closed-segment intersection in 2D with a length tolerance.
///
/// Scale-safe: each signed distance is computed by [`signed_distance`] in frames scaled by
/// powers of two, so segments with ends at `+-1e160` or `+-1e308` give the crossings their
/// geometry gives (before, a plain cross product or length overflowed to `inf`, every
/// distance became 0 and every bond "crossed").
fn segments_intersect(p: [f64; 2], q: [f64; 2], a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
    // Signed distances of each segment's ends from the other's line, each with the tolerance
    // in its own scale.
    let side = |o: [f64; 2], u: [f64; 2], r: [f64; 2]| {
        let (d, t) = signed_distance(o, u, r, tol);
        if d > t {
            1
        } else if d < -t {
            -1
        } else {
            0
        }
    };
    let (s1, s2, s3, s4) = (side(a, b, p), side(a, b, q), side(p, q, a), side(p, q, b));
    let straddles = |s: i8, t: i8| !(s == t && s != 0);
    if !(straddles(s1, s2) && straddles(s3, s4)) {
        return false;
    }
    // Collinear case: require overlapping projections (halves: no overflow).
    if s1 == 0 && s2 == 0 {
        let axis = if (0.5 * b[0] - 0.5 * a[0]).abs() >= (0.5 * b[1] - 0.5 * a[1]).abs() { 0 } else { 1 };
        let (lo1, hi1) = (p[axis].min(q[axis]), p[axis].max(q[axis]));
        let (lo2, hi2) = (a[axis].min(b[axis]), a[axis].max(b[axis]));
        return lo1 <= hi2 + tol && lo2 <= hi1 + tol;
    }
    true
}

/// The signed distance `(u - o) x (r - c) / |u - o|` of `r` from the line through `o` and `u`,
/// and the tolerance `tol`, both multiplied by one power of two (compare them with each other
/// only). The line's point `c` is whichever of `o`, `u` and their midpoint lies nearest `r`: a
/// crack from `-1e160` to `1e160` measures the lattice from its middle, where `r - o` would
/// round away everything the lattice holds. `u - o` and `r - c` are halved (no overflow) and
/// each multiplied by its own power of two that brings its largest component into
/// `[0.5, 1)`, so neither the cross product nor the length overflows or underflows whatever
/// their sizes. A degenerate line (`u = o`) gives distance 0.
fn signed_distance(o: [f64; 2], u: [f64; 2], r: [f64; 2], tol: f64) -> (f64, f64) {
    let half = |v: [f64; 2], w: [f64; 2]| [0.5 * v[0] - 0.5 * w[0], 0.5 * v[1] - 0.5 * w[1]];
    let mid = [0.5 * o[0] + 0.5 * u[0], 0.5 * o[1] + 0.5 * u[1]];
    let du = half(u, o);
    let dr = [half(r, o), half(r, mid), half(r, u)]
        .into_iter()
        .min_by(|x, y| max_abs(x).total_cmp(&max_abs(y)))
        .expect("three candidates");
    let (eu, er) = (exponent(max_abs(&du)), exponent(max_abs(&dr)));
    let (su, sr) = (du.map(|v| ldexp(v, -eu)), dr.map(|v| ldexp(v, -er)));
    let len = norm(&su).max(f64::MIN_POSITIVE);
    // distance 2^-(1 + er) times the plain one, tolerance likewise
    ((su[0] * sr[1] - su[1] * sr[0]) / len, ldexp(0.5 * tol, -er))
}

/// Phases, bond rule and defects of a body.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Material {
    /// `(region, modulus)`; later entries override earlier ones where they overlap.
    pub phases: Vec<(Region, f64)>,
    /// How a bond's modulus follows from its ends.
    pub rule: BondRule,
    /// Surfaces that degrade crossing bonds.
    pub defects: Vec<Defect>,
}

impl Material {
    /// True without phases or defects: every bond has the reference modulus.
    pub fn is_homogeneous(&self) -> bool {
        self.phases.is_empty() && self.defects.is_empty()
    }

    /// Checks moduli, regions and defects against the dimension.
    pub fn validate(&self, dim: usize) -> Result<(), CoreError> {
        for (region, k) in &self.phases {
            region.validate(dim)?;
            if !(k.is_finite() && *k > 0.0) {
                return Err(CoreError::param("modulus", format!("must be > 0, got {k:e}")));
            }
        }
        self.defects.iter().try_for_each(|d| d.validate(dim))
    }

    /// The index of the first defect that crosses no bond of the lattice `grid` with horizon
    /// `horizon` (it lies outside the body, in a hole, or in a gap no bond spans), or `None`.
    /// Visits every node's lattice stencil until a crossing bond is found, so a defect that
    /// does cut costs little and one that does not costs one pass over the bonds, as building
    /// the operator does.
    pub fn defect_cutting_nothing(&self, grid: &Grid, horizon: f64) -> Option<usize> {
        self.defects_cutting(grid, horizon).iter().position(|cuts| !cuts)
    }

    /// Per defect, whether it crosses a bond of `grid` (see
    /// [`Material::defect_cutting_nothing`]).
    pub fn defects_cutting(&self, grid: &Grid, horizon: f64) -> Vec<bool> {
        use rayon::prelude::*;
        let offsets = crate::family::grid_stencil(grid, horizon / grid.spacing());
        let tol = crate::GEOMETRY_RTOL * grid.spacing();
        self.defects
            .iter()
            .map(|d| {
                (0..grid.len()).into_par_iter().any(|i| {
                    let (k, x) = (grid.lattice_index(i), grid.position(i));
                    offsets.iter().any(|o| {
                        grid.node_at([k[0] + o[0], k[1] + o[1], k[2] + o[2]])
                            .is_some_and(|j| d.crosses(&x, &grid.position(j), tol))
                    })
                })
            })
            .collect()
    }

    /// Per defect, whether it crosses a bond of `family` on `positions` (a point cloud);
    /// `tol` is the length tolerance of the crossing test.
    pub fn defects_cutting_in(&self, family: &crate::BondFamily, positions: &[Point], tol: f64) -> Vec<bool> {
        use rayon::prelude::*;
        self.defects
            .iter()
            .map(|d| {
                (0..family.len())
                    .into_par_iter()
                    .any(|i| family.neighbors(i).iter().any(|&j| d.crosses(&positions[i], &positions[j as usize], tol)))
            })
            .collect()
    }

    /// Modulus of every node (`reference` outside all phases).
    pub fn node_moduli(&self, grid: &Grid, reference: f64) -> Vec<f64> {
        let tol = crate::GEOMETRY_RTOL * grid.spacing();
        self.node_moduli_at(&grid.positions(), grid.dim(), reference, tol)
    }

    /// Modulus of the nodes at `positions` (`reference` outside all phases); `tol` is the
    /// length tolerance of the region tests.
    pub fn node_moduli_at(&self, positions: &[Point], dim: usize, reference: f64, tol: f64) -> Vec<f64> {
        positions
            .iter()
            .map(|x| self.phases.iter().rev().find(|(r, _)| r.contains(x, dim, tol)).map_or(reference, |(_, k)| *k))
            .collect()
    }

    /// The multiplier of bond `(i, j)` relative to the reference micromodulus.
    pub fn bond_factor(&self, x: &Point, y: &Point, ki: f64, kj: f64, reference: f64, tol: f64) -> f64 {
        let mut f = if ki == reference && kj == reference { 1.0 } else { self.rule.combine(ki, kj) / reference };
        for d in &self.defects {
            if d.crosses(x, y, tol) {
                f *= d.factor();
            }
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_combine_as_documented() {
        assert_eq!(BondRule::Min.combine(10.0, 1.0), 1.0);
        assert_eq!(BondRule::Max.combine(10.0, 1.0), 10.0);
        assert_eq!(BondRule::Harmonic.combine(2.0, 2.0), 2.0);
        assert!((BondRule::Harmonic.combine(10.0, 1.0) - 20.0 / 11.0).abs() < 1e-15);
    }

    #[test]
    fn defects_detect_crossing_bonds() {
        let p = Defect::Point { x: 0.5, factor: 0.1 };
        assert!(p.crosses(&[0.4, 0.0, 0.0], &[0.6, 0.0, 0.0], 1e-12));
        assert!(p.crosses(&[0.5, 0.0, 0.0], &[0.6, 0.0, 0.0], 1e-12)); // closed, as in Example 5.3
        assert!(!p.crosses(&[0.51, 0.0, 0.0], &[0.6, 0.0, 0.0], 1e-12));
        let s = Defect::Segment { a: [0.5, 0.0], b: [0.5, 1.0], factor: 0.0 };
        assert!(s.crosses(&[0.4, 0.5, 0.0], &[0.6, 0.6, 0.0], 1e-12));
        assert!(!s.crosses(&[0.4, 1.5, 0.0], &[0.6, 1.6, 0.0], 1e-12));
        assert!(!s.crosses(&[0.6, 0.5, 0.0], &[0.7, 0.6, 0.0], 1e-12));
        let pl = Defect::Plane {
            point: [0.5, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
            extent: Some(Region::Box { min: vec![0.4, 0.0, 0.0], max: vec![0.6, 0.5, 1.0] }),
            factor: 0.0,
        };
        assert!(pl.crosses(&[0.4, 0.2, 0.5], &[0.6, 0.2, 0.5], 1e-12));
        assert!(!pl.crosses(&[0.4, 0.7, 0.5], &[0.6, 0.7, 0.5], 1e-12)); // outside the extent
        assert!(pl.validate(2).is_err());
    }

    /// The box test in front of a segment's crossing test rejects no bond the scale-safe test
    /// accepts: bonds with ends on a lattice around the segment (touching its ends and its line
    /// exactly), at tolerances below the lattice's distances from the segment (a tolerance as
    /// wide as them makes the orientation test accept a bond whose end lies on the segment's
    /// line beyond its end while the segment's end lies within the tolerance of the bond's
    /// line; the box test then rightly rejects it).
    #[test]
    fn segment_box_test_keeps_every_crossing() {
        let (a, b) = ([0.3, 0.25], [0.7, 0.45]);
        let s = Defect::Segment { a, b, factor: 0.0 };
        let pts: Vec<Point> =
            (0..=40).flat_map(|i| (0..=40).map(move |j| [i as f64 * 0.025, j as f64 * 0.025, 0.0])).collect();
        for tol in [1e-12, 1e-6] {
            let (mut tested, mut crossing) = (0, 0);
            for (k, x) in pts.iter().enumerate() {
                for y in pts.iter().skip(k + 1).step_by(7) {
                    let exact = segments_intersect([x[0], x[1]], [y[0], y[1]], a, b, tol);
                    assert_eq!(s.crosses(x, y, tol), exact, "{x:?} - {y:?}, tol {tol}");
                    tested += 1;
                    crossing += exact as usize;
                }
            }
            assert!(crossing > 1000 && tested - crossing > 1000, "{crossing} of {tested} cross at tol {tol}");
        }
    }

    /// `distance_to` of a plane with an extent is a lower bound of the distance to the
    /// crossing points (the disc of a penny crack, sampled finely) and is the larger of the
    /// plane's and the extent box's distances.
    #[test]
    fn plane_distance_bounds_the_extent() {
        let disc = Region::Ball { center: vec![0.5, 0.5, 0.5], radius: 0.1 };
        let pl = Defect::Plane { point: [0.5, 0.5, 0.5], normal: [0.0, 0.0, 2.0], extent: Some(disc), factor: 0.0 };
        let samples: Vec<Point> = (0..=400)
            .flat_map(|i| (0..=400).map(move |j| [0.4 + 0.0005 * i as f64, 0.4 + 0.0005 * j as f64, 0.5]))
            .filter(|p| (p[0] - 0.5).hypot(p[1] - 0.5) <= 0.1)
            .collect();
        for x in [[0.5, 0.5, 0.52], [0.9, 0.5, 0.5], [0.7, 0.8, 0.45], [0.55, 0.45, 0.5], [0.0, 0.0, 1.0]] {
            let exact = samples
                .iter()
                .map(|p| ((0..3).map(|k| (p[k] - x[k]).powi(2)).sum::<f64>()).sqrt())
                .fold(f64::INFINITY, f64::min);
            let bound = pl.distance_to(&x);
            assert!(bound <= exact + 1e-12, "{x:?}: {bound} above {exact}");
        }
        // beside the disc's box along x: 0.3 from the box, 0.0 from the plane
        assert!((pl.distance_to(&[0.9, 0.5, 0.5]) - 0.3).abs() < 1e-12);
        assert!((pl.distance_to(&[0.5, 0.5, 0.52]) - 0.02).abs() < 1e-12);
    }
}
