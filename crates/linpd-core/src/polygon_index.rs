//! A spatial index of a polygon's edges, so that a point-in-polygon test touches only the edges
//! near the point instead of all of them ([`Region::contains`] walks every edge: a body with a
//! 200,000-vertex polygon hole and `"volumes": "cut"`, 459 nodes times 256 sub-cells, took
//! more than 120 s to validate).
//!
//! The edges are bucketed by horizontal bands of the polygon's bounding box (an edge goes into
//! every band its y-range meets). A query tests, with the very predicate of
//! [`Region::contains`] (the even-odd rule with edges included up to `tol`, each edge in the
//! power-of-two-scaled frame of its own coordinates), only
//!
//! * for the crossing count, the edges of the band holding `p_y`: an edge crosses the ray from
//!   `p` only if its y-range holds `p_y`, and the band map is monotone in `y`, so such an edge
//!   is in that band (each edge once: the parity is exact);
//! * for the edge distance, the edges of the bands meeting `p_y -+ (tol + slack)`, `slack` a
//!   bound on the rounding of the distance (16 eps of the largest coordinate): an edge within
//!   `tol` of `p` meets that interval.
//!
//! So the answer is [`Region::contains`]'s, bit for bit (tested against it). Bands hold at most
//! about 4 entries per edge on average: with long edges (a zigzag across the whole polygon) the
//! band count is halved until they do, and such a polygon falls back towards a scan.
//!
//! [`PreparedRegion`] is a region with its polygons indexed, for the callers that query one
//! region very often (a scene's body: every lattice site, and every sub-cell of the cut cells).

use crate::region::{edge_test, Region};
use crate::Point;

/// A polygon's edges bucketed by horizontal bands.
#[derive(Debug, Clone)]
pub struct PolygonIndex {
    vertices: Vec<[f64; 2]>,
    /// `y` of the bounding box's bottom, and bands per unit `y`.
    y0: f64,
    inv_width: f64,
    /// Band `k` holds edges `edges[start[k]..start[k + 1]]` (edge `e` joins vertices `e`, `e + 1`).
    start: Vec<usize>,
    edges: Vec<u32>,
    /// Largest absolute vertex coordinate.
    scale: f64,
}

impl PolygonIndex {
    /// The index of the closed polygon `vertices` (at least one vertex, finite coordinates).
    pub fn new(vertices: &[[f64; 2]]) -> Self {
        let n = vertices.len();
        let (y0, y1) =
            vertices.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v[1]), hi.max(v[1])));
        let scale = vertices.iter().fold(0.0f64, |m, v| m.max(v[0].abs()).max(v[1].abs()));
        let span = |e: usize, bands: usize, inv: f64| {
            let (a, b) = (vertices[e][1], vertices[(e + 1) % n][1]);
            (band(a.min(b), y0, inv, bands), band(a.max(b), y0, inv, bands))
        };
        let mut bands = n.max(1);
        let inv_of = |bands: usize| {
            let inv = bands as f64 / (y1 - y0);
            if inv.is_finite() {
                inv
            } else {
                0.0
            }
        };
        // fewer bands until the entries stay within 4 per edge
        while bands > 1 {
            let inv = inv_of(bands);
            let entries: usize = (0..n).map(|e| span(e, bands, inv)).map(|(lo, hi)| hi - lo + 1).sum();
            if entries <= 4 * n + bands {
                break;
            }
            bands /= 2;
        }
        let inv_width = inv_of(bands);
        let mut count = vec![0usize; bands + 1];
        for e in 0..n {
            let (lo, hi) = span(e, bands, inv_width);
            (lo..=hi).for_each(|k| count[k + 1] += 1);
        }
        for k in 0..bands {
            count[k + 1] += count[k];
        }
        let start = count.clone();
        let mut edges = vec![0u32; start[bands]];
        for e in 0..n {
            let (lo, hi) = span(e, bands, inv_width);
            for k in lo..=hi {
                edges[count[k]] = e as u32;
                count[k] += 1;
            }
        }
        PolygonIndex { vertices: vertices.to_vec(), y0, inv_width, start, edges, scale }
    }

    fn bands(&self) -> usize {
        self.start.len() - 1
    }

    fn band_edges(&self, k: usize) -> &[u32] {
        &self.edges[self.start[k]..self.start[k + 1]]
    }

    /// The even-odd test with edges included up to `tol`: [`Region::contains`] of the polygon.
    pub fn contains(&self, p: [f64; 2], tol: f64) -> bool {
        let n = self.vertices.len();
        let edge =
            |e: u32| -> ([f64; 2], [f64; 2]) { (self.vertices[e as usize], self.vertices[(e as usize + 1) % n]) };
        let reach = tol + 16.0 * f64::EPSILON * self.scale.max(p[0].abs()).max(p[1].abs());
        let bands = self.bands();
        let lo = band(p[1] - reach, self.y0, self.inv_width, bands);
        let hi = band(p[1] + reach, self.y0, self.inv_width, bands);
        for k in lo..=hi {
            if self.band_edges(k).iter().any(|&e| {
                let (a, b) = edge(e);
                edge_test(p, a, b, tol).0
            }) {
                return true;
            }
        }
        let k = band(p[1], self.y0, self.inv_width, bands);
        self.band_edges(k)
            .iter()
            .filter(|&&e| {
                let (a, b) = edge(e);
                edge_test(p, a, b, tol).1
            })
            .count()
            % 2
            == 1
    }
}

/// The band of `y`: `floor((y - y0) inv)` clamped to `0..bands` (monotone in `y`).
fn band(y: f64, y0: f64, inv: f64, bands: usize) -> usize {
    let t = ((y - y0) * inv).floor();
    if t.is_nan() || t <= 0.0 {
        0
    } else {
        (t.min((bands - 1) as f64)) as usize
    }
}

/// A region whose polygons are indexed ([`PolygonIndex`]): [`Region::contains`], with each
/// polygon query touching only nearby edges.
#[derive(Debug, Clone)]
pub enum PreparedRegion<'a> {
    /// A region queried as it is.
    Plain(&'a Region),
    /// An indexed polygon and its extrusion.
    Polygon(PolygonIndex, Option<[f64; 2]>),
    /// Any of the parts.
    Union(Vec<PreparedRegion<'a>>),
    /// In the first and not in the second.
    Difference(Box<PreparedRegion<'a>>, Box<PreparedRegion<'a>>),
}

/// Polygons of fewer vertices are queried as they are (the index would not pay).
const INDEX_FROM: usize = 32;

impl<'a> PreparedRegion<'a> {
    /// `region` with its polygons of `INDEX_FROM` (32) or more vertices indexed.
    pub fn new(region: &'a Region) -> Self {
        match region {
            Region::Polygon { vertices, extrude } if vertices.len() >= INDEX_FROM => {
                PreparedRegion::Polygon(PolygonIndex::new(vertices), *extrude)
            }
            Region::Union(parts) => PreparedRegion::Union(parts.iter().map(PreparedRegion::new).collect()),
            Region::Difference(a, b) => {
                PreparedRegion::Difference(Box::new(PreparedRegion::new(a)), Box::new(PreparedRegion::new(b)))
            }
            r => PreparedRegion::Plain(r),
        }
    }

    /// [`Region::contains`].
    pub fn contains(&self, x: &Point, dim: usize, tol: f64) -> bool {
        match self {
            PreparedRegion::Plain(r) => r.contains(x, dim, tol),
            PreparedRegion::Polygon(index, extrude) => {
                let z_ok = match (dim, extrude) {
                    (3, Some([z0, z1])) => x[2] >= z0 - tol && x[2] <= z1 + tol,
                    _ => true,
                };
                z_ok && index.contains([x[0], x[1]], tol)
            }
            PreparedRegion::Union(parts) => parts.iter().any(|r| r.contains(x, dim, tol)),
            PreparedRegion::Difference(a, b) => a.contains(x, dim, tol) && !b.contains(x, dim, tol),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The indexed test answers as [`Region::contains`] on points inside, outside, on edges
    /// and vertices, and within and beyond `tol` of edges, for a star (concave, 400 vertices),
    /// a zigzag of long edges (few bands) and a 3D extruded difference.
    #[test]
    fn same_answer_as_the_region() {
        let star: Vec<[f64; 2]> = (0..400)
            .map(|k| {
                let t = k as f64 / 400.0 * std::f64::consts::TAU;
                let r = if k % 2 == 0 { 1.0 } else { 0.45 };
                [0.3 + r * t.cos(), -0.2 + r * t.sin()]
            })
            .collect();
        let mut zig: Vec<[f64; 2]> = (0..100).map(|k| [k as f64 * 0.02, if k % 2 == 0 { 0.0 } else { 1.0 }]).collect();
        zig.push([2.0, -1.0]);
        zig.push([0.0, -1.0]);
        let tol = 1e-9;
        let mut points: Vec<[f64; 2]> = Vec::new();
        let mut s = 12345u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for v in [&star, &zig] {
            for k in 0..v.len() {
                let (a, b) = (v[k], v[(k + 1) % v.len()]);
                let t = rnd();
                let on = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                let (nx, ny) = (-(b[1] - a[1]), b[0] - a[0]);
                let l = nx.hypot(ny);
                for off in [0.0, 0.5e-9, 2e-9, 1e-3, -0.5e-9, -2e-9, -1e-3] {
                    points.push([on[0] + off * nx / l, on[1] + off * ny / l]);
                }
                points.push(a);
            }
        }
        for _ in 0..20_000 {
            points.push([-1.5 + 4.0 * rnd(), -1.5 + 3.0 * rnd()]);
        }
        for v in [star, zig] {
            let region = Region::Polygon { vertices: v.clone(), extrude: None };
            let index = PolygonIndex::new(&v);
            assert!(index.bands() >= 1);
            let (mut inside, mut outside) = (0, 0);
            for p in &points {
                let x = [p[0], p[1], 0.0];
                let want = region.contains(&x, 2, tol);
                assert_eq!(index.contains(*p, tol), want, "{p:?}");
                if want {
                    inside += 1
                } else {
                    outside += 1
                }
            }
            assert!(inside > 1000 && outside > 1000, "{inside} {outside}");
        }
        let outer = Region::Box { min: vec![-2.0, -2.0, 0.0], max: vec![2.0, 2.0, 1.0] };
        let hole: Vec<[f64; 2]> = (0..64)
            .map(|k| (k as f64 / 64.0 * std::f64::consts::TAU).sin_cos())
            .map(|(s, c)| [0.5 * c, 0.5 * s])
            .collect();
        let body = Region::Difference(
            Box::new(outer),
            Box::new(Region::Union(vec![Region::Polygon { vertices: hole, extrude: Some([0.25, 0.75]) }])),
        );
        let prepared = PreparedRegion::new(&body);
        for p in points.iter().take(5000) {
            for z in [0.0, 0.25, 0.5, 1.0] {
                let x = [p[0], p[1], z];
                assert_eq!(prepared.contains(&x, 3, tol), body.contains(&x, 3, tol), "{x:?}");
            }
        }
    }
}
