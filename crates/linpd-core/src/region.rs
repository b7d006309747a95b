//! Regions that name node sets and shape bodies: boxes (intervals in 1D), balls (disks in 2D),
//! cylinders (3D), half spaces, polygons (2D, extruded along z in 3D), unions and differences.
//!
//! Membership is closed (a node on a box face, a sphere or a polygon edge belongs to the
//! region) with a tolerance of [`GEOMETRY_RTOL`](crate::GEOMETRY_RTOL) times the lattice
//! spacing, so that nodes computed as `min + i h` in floating point are not lost on round-off.

use crate::{CoreError, Grid, Point};

/// A subset of space.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// Every point.
    All,
    /// The closed box `[min, max]` (an interval in 1D, a rectangle in 2D).
    Box {
        /// Lower corner.
        min: Vec<f64>,
        /// Upper corner.
        max: Vec<f64>,
    },
    /// The closed ball `|x - center| <= radius` (a disk in 2D, an interval in 1D).
    Ball {
        /// Centre.
        center: Vec<f64>,
        /// Radius `> 0`.
        radius: f64,
    },
    /// 3D: the closed circular cylinder of `radius` around the line through `center` along
    /// `axis`; with `length`, only `|(x - center) . axis| <= length / 2` (`center` is the middle).
    Cylinder {
        /// A point of the axis (the middle when `length` is given).
        center: Vec<f64>,
        /// Axis direction (any length `> 0`; normalized on use).
        axis: Vec<f64>,
        /// Radius `> 0`.
        radius: f64,
        /// Length along the axis (infinite when `None`).
        length: Option<f64>,
    },
    /// The closed half space `(x - point) . normal <= 0`: `normal` points out of it, as a
    /// body's outward normal does.
    HalfSpace {
        /// A point of the bounding plane.
        point: Vec<f64>,
        /// Outward normal (any nonzero length; only all zeros is refused).
        normal: Vec<f64>,
    },
    /// 2D: the closed polygon with these vertices (either orientation; inside by the even-odd
    /// rule, edges included; edges may cross: a part wound around twice is outside). 3D: the
    /// prism `polygon x [z0, z1]`.
    Polygon {
        /// Vertices `(x, y)`, at least 3.
        vertices: Vec<[f64; 2]>,
        /// 3D only: `[z0, z1]`, the extent along z.
        extrude: Option<[f64; 2]>,
    },
    /// The nodes of a named set of a mesh (a Gmsh physical group; `{"set": "clamp"}`): a set
    /// of nodes, not of points, so [`Region::contains`] is false everywhere and only
    /// [`Region::contains_with`] with the node's membership selects it.
    Set(String),
    /// Points in any of the regions.
    Union(Vec<Region>),
    /// Points in the first region and not in the second.
    Difference(Box<Region>, Box<Region>),
}

impl Region {
    /// Checks that every box has `dim` components and `min <= max`.
    pub fn validate(&self, dim: usize) -> Result<(), CoreError> {
        match self {
            Region::All | Region::Set(_) => Ok(()),
            Region::Box { min, max } => {
                for v in [min, max] {
                    if v.len() != dim {
                        return Err(CoreError::Components { expected: dim, got: v.len() });
                    }
                }
                for a in 0..dim {
                    if !(min[a].is_finite() && max[a].is_finite()) || min[a] > max[a] {
                        return Err(CoreError::param(
                            "box",
                            format!("axis {a}: min ({}) must be <= max ({})", min[a], max[a]),
                        ));
                    }
                }
                Ok(())
            }
            Region::Ball { center, radius } => {
                components(center, dim)?;
                positive("ball.radius", *radius)
            }
            Region::Cylinder { center, axis, radius, length } => {
                if dim != 3 {
                    return Err(CoreError::param("cylinder", format!("is a 3D region (use ball in {dim}D)")));
                }
                components(center, dim)?;
                components(axis, dim)?;
                if is_zero(axis) {
                    return Err(CoreError::param(
                        "cylinder.axis",
                        "must not be zero (any nonzero length is a direction)",
                    ));
                }
                positive("cylinder.radius", *radius)?;
                length.map_or(Ok(()), |l| positive("cylinder.length", l))
            }
            Region::HalfSpace { point, normal } => {
                components(point, dim)?;
                components(normal, dim)?;
                if is_zero(normal) {
                    return Err(CoreError::param(
                        "half_space.normal",
                        "must not be zero (any nonzero length is a direction)",
                    ));
                }
                Ok(())
            }
            Region::Polygon { vertices, extrude } => {
                if dim == 1 {
                    return Err(CoreError::param("polygon", "is a 2D region (extruded in 3D); use box in 1D"));
                }
                if vertices.len() < 3 {
                    return Err(CoreError::param(
                        "polygon.vertices",
                        format!("needs at least 3, got {}", vertices.len()),
                    ));
                }
                if vertices.iter().flatten().any(|v| !v.is_finite()) {
                    return Err(CoreError::param("polygon.vertices", "must be finite"));
                }
                match (dim, extrude) {
                    (2, Some(_)) => Err(CoreError::param("polygon.extrude", "is for 3D scenes only")),
                    (3, None) => Err(CoreError::param(
                        "polygon.extrude",
                        "missing: a 3D polygon is extruded along z over [z0, z1]",
                    )),
                    (3, Some([z0, z1])) if !(z0.is_finite() && z1.is_finite() && z0 <= z1) => Err(CoreError::param(
                        "polygon.extrude",
                        format!("must be [z0, z1] with z0 <= z1, got [{z0:e}, {z1:e}]"),
                    )),
                    _ => Ok(()),
                }
            }
            Region::Union(parts) => parts.iter().try_for_each(|r| r.validate(dim)),
            Region::Difference(a, b) => {
                a.validate(dim)?;
                b.validate(dim)
            }
        }
    }

    /// True when `x` lies in the region, faces included up to `tol` (false in a named set:
    /// see [`Region::contains_with`]).
    pub fn contains(&self, x: &Point, dim: usize, tol: f64) -> bool {
        self.contains_with(x, dim, tol, &|_| false)
    }

    /// [`Region::contains`] for a node at `x` that belongs to the named sets for which
    /// `in_set(name)` is true.
    pub fn contains_with(&self, x: &Point, dim: usize, tol: f64, in_set: &dyn Fn(&str) -> bool) -> bool {
        match self {
            Region::All => true,
            Region::Set(name) => in_set(name),
            Region::Box { min, max } => (0..dim).all(|a| x[a] >= min[a] - tol && x[a] <= max[a] + tol),
            // Ball, cylinder and half space compare quarter differences with quarter bounds
            // (exact scaling: the same result as the plain comparison wherever that is finite).
            Region::Ball { center, radius } => norm(&quarter_diff(x, center, dim)[..dim]) <= 0.25 * radius + 0.25 * tol,
            Region::Cylinder { center, axis, radius, length } => {
                let (s, n) = direction(axis, 3);
                let r = quarter_diff(x, center, 3);
                let t = (0..3).map(|a| r[a] * s[a]).sum::<f64>() / n;
                let radial = norm(&[0, 1, 2].map(|a| r[a] - t * s[a] / n));
                radial <= 0.25 * radius + 0.25 * tol && length.is_none_or(|l| t.abs() <= 0.125 * l + 0.25 * tol)
            }
            Region::HalfSpace { point, normal } => {
                let (s, n) = direction(normal, dim);
                let r = quarter_diff(x, point, dim);
                (0..dim).map(|a| r[a] * s[a]).sum::<f64>() / n <= 0.25 * tol
            }
            Region::Polygon { vertices, extrude } => {
                let z_ok = match (dim, extrude) {
                    (3, Some([z0, z1])) => x[2] >= z0 - tol && x[2] <= z1 + tol,
                    _ => true,
                };
                z_ok && in_polygon([x[0], x[1]], vertices, tol)
            }
            Region::Union(parts) => parts.iter().any(|r| r.contains_with(x, dim, tol, in_set)),
            Region::Difference(a, b) => a.contains_with(x, dim, tol, in_set) && !b.contains_with(x, dim, tol, in_set),
        }
    }

    /// A box `(lo, hi)` holding every point of the region in the first `dim` coordinates
    /// (the others unbounded), `None` when the region is unbounded (all, a half space, an
    /// endless cylinder, a named set). Not the tightest box for a cylinder (its centre plus
    /// half its length and its radius along every axis) or a difference (the first region's).
    pub fn bounds(&self, dim: usize) -> Option<([f64; 3], [f64; 3])> {
        let mut lo = [f64::NEG_INFINITY; 3];
        let mut hi = [f64::INFINITY; 3];
        match self {
            Region::All | Region::Set(_) | Region::HalfSpace { .. } => return None,
            Region::Box { min, max } => {
                (0..dim).for_each(|a| (lo[a], hi[a]) = (min[a], max[a]));
            }
            Region::Ball { center, radius } => {
                (0..dim).for_each(|a| (lo[a], hi[a]) = (center[a] - radius, center[a] + radius));
            }
            Region::Cylinder { center, radius, length, .. } => {
                let r = radius + length.as_ref()? / 2.0;
                (0..dim).for_each(|a| (lo[a], hi[a]) = (center[a] - r, center[a] + r));
            }
            Region::Polygon { vertices, extrude } => {
                for a in 0..2 {
                    lo[a] = vertices.iter().map(|v| v[a]).fold(f64::INFINITY, f64::min);
                    hi[a] = vertices.iter().map(|v| v[a]).fold(f64::NEG_INFINITY, f64::max);
                }
                if let (3, Some([z0, z1])) = (dim, extrude) {
                    (lo[2], hi[2]) = (*z0, *z1);
                }
            }
            Region::Union(parts) => {
                (lo, hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for part in parts {
                    let (l, h) = part.bounds(dim)?;
                    (0..3).for_each(|a| (lo[a], hi[a]) = (lo[a].min(l[a]), hi[a].max(h[a])));
                }
            }
            Region::Difference(a, _) => return a.bounds(dim),
        }
        Some((lo, hi))
    }

    /// The names of the sets the region refers to.
    pub fn set_names(&self) -> Vec<&str> {
        match self {
            Region::Set(name) => vec![name.as_str()],
            Region::Union(parts) => parts.iter().flat_map(Region::set_names).collect(),
            Region::Difference(a, b) => a.set_names().into_iter().chain(b.set_names()).collect(),
            _ => Vec::new(),
        }
    }

    /// True for a shape (box, ball, ...), false for `all`, unions and differences.
    pub fn is_leaf(&self) -> bool {
        !matches!(self, Region::All | Region::Union(_) | Region::Difference(..))
    }

    /// The nodes of `grid` inside the region, ascending. Only the sites in the region's
    /// [`Region::bounds`] are tested (a face's layer of a 1.26e8-node lattice is 2.5e5 of
    /// them), in parallel over lattice lines.
    pub fn nodes(&self, grid: &Grid) -> Vec<usize> {
        use rayon::prelude::*;
        let (dim, tol) = (grid.dim(), crate::GEOMETRY_RTOL * grid.spacing());
        let inside = |n: &usize| self.contains(&grid.position(*n), dim, tol);
        let [xs, ys, zs] = match self.bounds(dim) {
            Some((lo, hi)) => grid.sites_within(lo, hi, tol),
            None => grid.counts().map(|c| 0..c),
        };
        let lines: Vec<[usize; 2]> = zs.flat_map(|z| ys.clone().map(move |y| [y, z])).collect();
        lines
            .into_par_iter()
            .flat_map_iter(|[y, z]| xs.clone().filter_map(move |x| grid.node_at_site([x, y, z])).filter(inside))
            .collect()
    }
}

// Scale-safe arithmetic. Every predicate below works on copies of its inputs multiplied by
// powers of two, which is exact (until a result is subnormal) and commutes with the rounding
// of `+ - * / sqrt`: on huge or tiny inputs (extents up to +-1.8e308, direction vectors of any
// nonzero length) no product, square or difference overflows or underflows to 0, and on
// ordinary ones the ball, cylinder and half space compute bit for bit what the plain formulas
// compute (the polygon's edge distance is measured from the nearer end, the same distance up
// to round-off).

/// The exponent `e` with `2^(e-1) <= m < 2^e` (so `m 2^-e` is in `[0.5, 1)`), for finite
/// `m > 0`; 0 for `m = 0` (or a non-finite `m`, which validation refuses).
pub(crate) fn exponent(m: f64) -> i32 {
    if !(m.is_finite() && m > 0.0) {
        return 0;
    }
    let bits = m.to_bits();
    match ((bits >> 52) & 0x7ff) as i32 {
        // subnormal: m = mantissa 2^-1074
        0 => (64 - (bits & ((1u64 << 52) - 1)).leading_zeros() as i32) - 1074,
        biased => biased - 1022,
    }
}

/// `2^e` for `-1074 <= e <= 1023`.
fn pow2(e: i32) -> f64 {
    if e >= -1022 {
        f64::from_bits(((e + 1023) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (e + 1074))
    }
}

/// `x 2^e` for `-1074 <= e <= 2 x 1023` (exact unless the result is subnormal or overflows).
pub(crate) fn ldexp(x: f64, e: i32) -> f64 {
    if e > 1023 {
        x * pow2(1023) * pow2(e - 1023)
    } else {
        x * pow2(e.max(-1074))
    }
}

/// The largest `|v_a|`.
pub(crate) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The Euclidean norm, without overflow or underflow: `2^e |v 2^-e|`, the same bits as
/// `sqrt(sum v_a^2)` whenever that neither overflows nor underflows.
pub(crate) fn norm(v: &[f64]) -> f64 {
    let e = exponent(max_abs(v));
    ldexp(v.iter().map(|x| ldexp(*x, -e).powi(2)).sum::<f64>().sqrt(), e)
}

/// True when every component is zero: the only direction vector refused (any nonzero length
/// is a direction, `[1e-200, 0]` included).
pub(crate) fn is_zero(v: &[f64]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

/// `(x - p) / 4` per component (at most `0.45e308` in size for finite inputs), exactly a
/// quarter of the difference when that does not overflow.
pub(crate) fn quarter_diff(x: &[f64], p: &[f64], dim: usize) -> [f64; 3] {
    let mut d = [0.0; 3];
    for a in 0..dim {
        d[a] = 0.25 * x[a] - 0.25 * p[a];
    }
    d
}

/// The direction `v` scaled by a power of two (largest component in `[0.5, 1)`) and its norm
/// (in `[0.5, sqrt 3)`): `d . s / |s|` is the component of `d` along `v` with the bits of
/// `d . v / |v|` where that is finite.
fn direction(v: &[f64], dim: usize) -> ([f64; 3], f64) {
    let e = exponent(max_abs(&v[..dim]));
    let mut s = [0.0; 3];
    for a in 0..dim {
        s[a] = ldexp(v[a], -e);
    }
    (s, norm(&s[..dim]))
}

fn components(v: &[f64], dim: usize) -> Result<(), CoreError> {
    if v.len() != dim {
        return Err(CoreError::Components { expected: dim, got: v.len() });
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(CoreError::param("region", "coordinates must be finite numbers"));
    }
    Ok(())
}

fn positive(what: &str, x: f64) -> Result<(), CoreError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(CoreError::param(what, format!("must be > 0, got {x:e}")))
    }
}

/// Even-odd point-in-polygon test with the edges included: inside when a ray from `p` crosses
/// an odd number of edges, or when `p` lies within `tol` of an edge. A self-crossing polygon
/// is taken as it is: the parts its edges wind around an even number of times are outside.
///
/// Each edge is tested in its own frame: `p`, the two vertices and `tol` multiplied by the power
/// of two that brings their largest coordinate into `[0.5, 1)`, so differences stay below 2 and
/// squares below 8 for any finite vertices (an edge from `-1e308` to `1e308` included).
fn in_polygon(p: [f64; 2], v: &[[f64; 2]], tol: f64) -> bool {
    let mut inside = false;
    for k in 0..v.len() {
        let (on_edge, crosses) = edge_test(p, v[k], v[(k + 1) % v.len()], tol);
        if on_edge {
            return true;
        }
        inside ^= crosses;
    }
    inside
}

/// One edge `ab` of [`in_polygon`] at `p`: (within `tol` of the edge, crosses the ray from `p`
/// along +x), in the edge's power-of-two-scaled frame. Shared with the polygon index
/// (`crate::polygon_index`), so that both answer alike.
pub(crate) fn edge_test(p: [f64; 2], a: [f64; 2], b: [f64; 2], tol: f64) -> (bool, bool) {
    let e = exponent(max_abs(&[p[0], p[1], a[0], a[1], b[0], b[1]]));
    let (p, a, b, tol) = (p.map(|x| ldexp(x, -e)), a.map(|x| ldexp(x, -e)), b.map(|x| ldexp(x, -e)), ldexp(tol, -e));
    if segment_distance(p, a, b) <= tol {
        return (true, false);
    }
    let crosses = (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
    (false, crosses)
}

/// The distance from `p` to the closed segment `ab` (coordinates below 1 in size): the distance
/// to `a` or to `b` when `p` projects beyond that end, else the distance from the line. Each
/// part is computed from the end nearer to `p`: on a long edge (`1e308` in a frame where the
/// lattice spans `1e-308`), `p - a` rounds to a multiple of the far end's unit and would put a
/// point below the near end on the edge.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let e = [b[0] - a[0], b[1] - a[1]];
    let (pa, pb) = ([p[0] - a[0], p[1] - a[1]], [p[0] - b[0], p[1] - b[1]]);
    let dot = |u: [f64; 2]| u[0] * e[0] + u[1] * e[1];
    let len = e[0].hypot(e[1]);
    if len == 0.0 || dot(pa) <= 0.0 {
        pa[0].hypot(pa[1])
    } else if dot(pb) >= 0.0 {
        pb[0].hypot(pb[1])
    } else {
        let r = if pa[0].hypot(pa[1]) <= pb[0].hypot(pb[1]) { pa } else { pb };
        (e[0] * r[1] - e[1] * r[0]).abs() / len
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Placement;

    /// Every point a region contains (sampled on a lattice of `[-1, 1]^3`) is in its bounds;
    /// the bounds of a box and a ball are exact; unbounded regions have none.
    #[test]
    fn bounds_hold_every_point() {
        let ball = Region::Ball { center: vec![0.1, -0.2, 0.3], radius: 0.4 };
        let cyl =
            Region::Cylinder { center: vec![0.0, 0.1, 0.0], axis: vec![1.0, 1.0, 0.0], radius: 0.2, length: Some(0.6) };
        let poly = Region::Polygon { vertices: vec![[-0.5, -0.1], [0.4, 0.0], [0.0, 0.7]], extrude: Some([-0.3, 0.2]) };
        let bx = Region::Box { min: vec![-0.3, -0.2, -0.1], max: vec![0.2, 0.5, 0.6] };
        let union = Region::Union(vec![ball.clone(), bx.clone()]);
        let diff = Region::Difference(Box::new(cyl.clone()), Box::new(ball.clone()));
        for r in [&ball, &cyl, &poly, &bx, &union, &diff] {
            let (lo, hi) = r.bounds(3).expect("bounded");
            let mut inside = 0;
            for k in 0..41usize.pow(3) {
                let x = [k % 41, k / 41 % 41, k / 1681].map(|i| -1.0 + 0.05 * i as f64);
                if r.contains(&x, 3, 0.0) {
                    inside += 1;
                    assert!((0..3).all(|a| lo[a] <= x[a] && x[a] <= hi[a]), "{r:?}: {x:?} outside {lo:?}..{hi:?}");
                }
            }
            assert!(inside > 0, "{r:?} samples no point");
        }
        assert_eq!(bx.bounds(3), Some(([-0.3, -0.2, -0.1], [0.2, 0.5, 0.6])));
        let (lo, hi) = ball.bounds(3).unwrap();
        assert!((lo[0] + 0.3).abs() < 1e-15 && (hi[2] - 0.7).abs() < 1e-15);
        let endless = Region::Cylinder { center: vec![0.0; 3], axis: vec![0.0, 0.0, 1.0], radius: 0.1, length: None };
        for r in [Region::All, Region::Set("a".into()), endless] {
            assert_eq!(r.bounds(3), None);
        }
    }

    /// The selection within the bounds equals the plain scan of every node: both placements,
    /// layers, a body that removed sites, regions touching the layers and lying outside.
    #[test]
    fn bounded_selection_is_the_full_scan() {
        let layers = [[0.2, 0.1], [0.0, 0.15], [0.1, 0.1]];
        let regions = [
            Region::Box { min: vec![-1.0, -1.0, 0.7], max: vec![2.0, 2.0, 2.0] },
            Region::Box { min: vec![0.3, 0.3, 0.3], max: vec![0.3, 0.6, 0.3] },
            Region::Ball { center: vec![0.0, 0.5, 0.5], radius: 0.33 },
            Region::Ball { center: vec![5.0, 5.0, 5.0], radius: 0.1 },
            Region::Cylinder { center: vec![0.5; 3], axis: vec![1.0, 2.0, 0.5], radius: 0.2, length: Some(0.5) },
            Region::Union(vec![
                Region::Box { min: vec![-1.0, -1.0, -1.0], max: vec![0.0, 2.0, 2.0] },
                Region::Ball { center: vec![1.0, 1.0, 1.0], radius: 0.25 },
            ]),
            Region::HalfSpace { point: vec![0.5, 0.5, 0.5], normal: vec![1.0, -1.0, 0.3] },
            // bounds far beyond the lattice's index range
            Region::Box { min: vec![-1e300, 0.0, -1e300], max: vec![1e300, 0.5, 1e20] },
            Region::Ball { center: vec![0.5, 0.5, 0.5], radius: 1e300 },
            Region::Box { min: vec![f64::NEG_INFINITY, 0.2, 0.0], max: vec![0.3, f64::INFINITY, 0.4] },
        ];
        for placement in [Placement::Vertex, Placement::Cell] {
            for dim in [2, 3] {
                let g = Grid::with_layers(&vec![0.0; dim], &vec![1.0; dim], 0.05, layers, placement).unwrap();
                let holed = g.with_body(|x| (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) > 0.04).unwrap();
                for grid in [&g, &holed] {
                    let tol = crate::GEOMETRY_RTOL * grid.spacing();
                    for r in &regions {
                        let scan: Vec<usize> =
                            (0..grid.len()).filter(|&n| r.contains(&grid.position(n), dim, tol)).collect();
                        assert_eq!(r.nodes(grid), scan, "{r:?}, {placement:?}, {dim}D, {} nodes", grid.len());
                    }
                }
            }
        }
    }

    #[test]
    fn boxes_unions_differences_select_lattice_nodes() {
        let g = Grid::new(&[0.0], &[1.0], 0.1, 0.2, Placement::Vertex).unwrap();
        let left = Region::Box { min: vec![-1.0], max: vec![0.0] };
        // -0.2, -0.1, 0.0: the face node at 0 is included despite round-off.
        assert_eq!(left.nodes(&g).len(), 3);
        let both = Region::Union(vec![left.clone(), Region::Box { min: vec![1.0], max: vec![2.0] }]);
        assert_eq!(both.nodes(&g).len(), 6);
        let inner = Region::Difference(Box::new(Region::All), Box::new(both));
        assert_eq!(inner.nodes(&g).len(), g.len() - 6);
        // 0.3 is computed as 0.30000000000000004 on the lattice: still inside [0.3, 0.3].
        assert_eq!(Region::Box { min: vec![0.3], max: vec![0.3] }.nodes(&g).len(), 1);
    }

    /// Lattice points (spacing h = 0.05, vertex grid on [-1, 1]^d) inside each primitive,
    /// against independent integer counts: Gauss's circle count `#{(i, j): i^2 + j^2 <= R^2}`
    /// (R = r / h = 13), Pick's theorem `I + B = A + B/2 + 1` for a lattice triangle, the
    /// half space `x + y <= 0.1` by summing columns, and a cylinder as a disk count times its
    /// planes. A node on the boundary is inside: every one of these shapes has nodes exactly on
    /// its boundary (R^2 = 169 = 5^2 + 12^2), which the counts include.
    #[test]
    fn primitives_count_lattice_points_exactly() {
        let h = 0.05;
        let g2 = Grid::new(&[-1.0, -1.0], &[1.0, 1.0], h, 0.0, Placement::Vertex).unwrap();
        let r = 13i64;
        let gauss =
            (-r..=r).flat_map(|i| (-r..=r).map(move |j| (i, j))).filter(|(i, j)| i * i + j * j <= r * r).count();
        let disk = Region::Ball { center: vec![0.0, 0.0], radius: r as f64 * h };
        disk.validate(2).unwrap();
        assert_eq!(disk.nodes(&g2).len(), gauss);
        assert_eq!(gauss, 529); // sum over i of 2 floor(sqrt(169 - i^2)) + 1

        // triangle (0,0), (12h,0), (0,8h): area 48 h^2, boundary points 12 + 8 + gcd(12, 8) = 24
        let tri = Region::Polygon { vertices: vec![[0.0, 0.0], [12.0 * h, 0.0], [0.0, 8.0 * h]], extrude: None };
        tri.validate(2).unwrap();
        assert_eq!(tri.nodes(&g2).len(), 48 + 24 / 2 + 1);
        // the same triangle listed clockwise
        let cw = Region::Polygon { vertices: vec![[0.0, 0.0], [0.0, 8.0 * h], [12.0 * h, 0.0]], extrude: None };
        assert_eq!(cw.nodes(&g2).len(), 61);

        // x + y <= 2h: for column i (x = i h, i in -20..=20) the rows j <= 2 - i, j >= -20
        let half = Region::HalfSpace { point: vec![0.1, 0.0], normal: vec![2.0, 2.0] };
        half.validate(2).unwrap();
        let expected: i64 = (-20i64..=20).map(|i| (2 - i).min(20) - (-20) + 1).map(|c| c.max(0)).sum();
        assert_eq!(half.nodes(&g2).len() as i64, expected);

        // 3D: cylinder along z of radius 13h, length 10h around z = 0: planes k = -5..=5
        let g3 = Grid::new(&[-1.0, -1.0, -1.0], &[1.0, 1.0, 1.0], h, 0.0, Placement::Vertex).unwrap();
        let cyl = Region::Cylinder {
            center: vec![0.0; 3],
            axis: vec![0.0, 0.0, 3.0],
            radius: 13.0 * h,
            length: Some(10.0 * h),
        };
        cyl.validate(3).unwrap();
        assert_eq!(cyl.nodes(&g3).len(), gauss * 11);
        let prism = Region::Polygon {
            vertices: vec![[0.0, 0.0], [12.0 * h, 0.0], [0.0, 8.0 * h]],
            extrude: Some([0.0, 2.0 * h]),
        };
        prism.validate(3).unwrap();
        assert_eq!(prism.nodes(&g3).len(), 61 * 3);
        let ball = Region::Ball { center: vec![0.0; 3], radius: 4.0 * h };
        let lattice_ball = (-4i64..=4)
            .flat_map(|i| (-4i64..=4).flat_map(move |j| (-4i64..=4).map(move |k| i * i + j * j + k * k)))
            .filter(|s| *s <= 16)
            .count();
        assert_eq!(ball.nodes(&g3).len(), lattice_ball);
    }

    #[test]
    fn primitives_validate() {
        let bad = [
            (Region::Ball { center: vec![0.0, 0.0], radius: 0.0 }, 2, "radius"),
            (Region::Ball { center: vec![0.0], radius: 1.0 }, 2, "expected 2"),
            (Region::Cylinder { center: vec![0.0; 2], axis: vec![1.0, 0.0], radius: 1.0, length: None }, 2, "3D"),
            (Region::Cylinder { center: vec![0.0; 3], axis: vec![0.0; 3], radius: 1.0, length: None }, 3, "axis"),
            (Region::HalfSpace { point: vec![0.0; 2], normal: vec![0.0; 2] }, 2, "normal"),
            (Region::Polygon { vertices: vec![[0.0, 0.0], [1.0, 0.0]], extrude: None }, 2, "at least 3"),
            (Region::Polygon { vertices: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], extrude: None }, 3, "extrude"),
            (
                Region::Polygon { vertices: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], extrude: Some([0.0, 1.0]) },
                2,
                "3D",
            ),
        ];
        for (r, dim, needle) in bad {
            let e = r.validate(dim).expect_err(needle).to_string();
            assert!(e.contains(needle), "{e}");
        }
    }

    /// The scale-safe helpers: `exponent` brackets normal and subnormal numbers as documented,
    /// `ldexp` reaches `2^1073` (two steps), `norm` has the bits of the plain formula where that
    /// is finite (exact powers of two commute with rounding: no tolerance) and the right value
    /// (1e-15 relative: a few roundings) where the plain one overflows or underflows.
    #[test]
    fn scale_safe_helpers() {
        for m in [1.0, 0.75, 3.0, 1e-300, 1e300, f64::MAX, 5e-324, 1e-310] {
            let e = exponent(m);
            let s = ldexp(m, -e);
            assert!((0.5..1.0).contains(&s), "{m:e}: 2^-{e} m = {s}");
        }
        assert_eq!(ldexp(5e-324, 1073), 0.5);
        for v in [[3.0, 4.0, 0.0], [0.1, 0.2, 0.3], [1e-150, 2e-150, 0.0], [1e150, 1.0, 7.0]] {
            assert_eq!(norm(&v).to_bits(), v.iter().map(|x| x * x).sum::<f64>().sqrt().to_bits(), "{v:?}");
        }
        for s in [1e200, 1e-200, 1e300, 1e-300] {
            let n = norm(&[3.0 * s, 4.0 * s]);
            assert!((n / (5.0 * s) - 1.0).abs() < 1e-15, "{s:e}: {n:e}");
        }
        assert!(is_zero(&[0.0, -0.0]) && !is_zero(&[0.0, 5e-324]));
    }

    #[test]
    fn validation_names_the_problem() {
        let r = Region::Box { min: vec![1.0, 0.0], max: vec![0.0, 1.0] };
        assert!(matches!(r.validate(2), Err(CoreError::Parameter { .. })));
        assert!(matches!(r.validate(3), Err(CoreError::Components { expected: 3, got: 2 })));
    }
}
