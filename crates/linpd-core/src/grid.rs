//! Uniform lattices in 1D, 2D and 3D.
//!
//! A [`Grid`] covers the body box `[min, max]` with spacing `h` and, optionally, a layer of
//! the same spacing outside the box on every side. With [`Placement::Vertex`] the nodes sit
//! at `min + i h`, `i = 0..=n`, `n = (max - min) / h` (both ends are nodes); with
//! [`Placement::Cell`] they sit at cell centres `min + (i + 1/2) h`, `i = 0..n`.
//! Every node carries the volume `V = h^d` (unit cross-section in 1D, unit thickness in 2D),
//! so layer nodes weigh the same as body nodes.
//!
//! Nodes are numbered lexicographically with the first axis fastest; the lattice index of a
//! node is kept so that neighbour search and region tests can work in lattice units.
//!
//! The layer may differ per side ([`Grid::with_layers`]: a cantilever clamped through a layer
//! at `x-` only), and a body may keep only some of the lattice's sites ([`Grid::with_body`]: a
//! plate with a hole). Then nodes are numbered over the kept sites in the same lexicographic
//! order; [`Grid::node_at`] returns `None` for a removed site, so every neighbour search that
//! goes through it (families, LPS reach, orderings) sees the hole as empty space.

use crate::{CoreError, Point, GEOMETRY_RTOL};

/// Where nodes sit inside the lattice cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Placement {
    /// Nodes at `min + i h`, both box ends included.
    #[default]
    Vertex,
    /// Nodes at cell centres `min + (i + 1/2) h`.
    Cell,
}

/// The site `(i, j, k)` of number `n` in a full box of `counts` sites per axis, numbered
/// lexicographically with axis 0 fastest (a full [`Grid`]'s node numbering).
#[inline]
pub fn box_site(n: usize, counts: [usize; 3]) -> [usize; 3] {
    [n % counts[0], (n / counts[0]) % counts[1], n / (counts[0] * counts[1])]
}

/// The number of site `s` in a full box of `counts` sites per axis (the inverse of
/// [`box_site`]).
#[inline]
pub fn box_node(s: [usize; 3], counts: [usize; 3]) -> usize {
    s[0] + counts[0] * (s[1] + counts[1] * s[2])
}

/// Calls `f(j, s)` for the node `j = n + offsets[s]` of every lattice offset that stays in a
/// full box of `counts` sites per axis, in offset order (monomorphized: no call through a
/// trait object per offset).
#[inline]
pub fn for_each_box_offset(n: usize, counts: [usize; 3], offsets: &[[i64; 3]], mut f: impl FnMut(usize, usize)) {
    let site = box_site(n, counts);
    let stride = [1i64, counts[0] as i64, (counts[0] * counts[1]) as i64];
    for (s, k) in offsets.iter().enumerate() {
        let inside = (0..3).all(|a| {
            let v = site[a] as i64 + k[a];
            v >= 0 && v < counts[a] as i64
        });
        if inside {
            f((n as i64 + k[0] * stride[0] + k[1] * stride[1] + k[2] * stride[2]) as usize, s);
        }
    }
}

/// A uniform lattice of nodes covering a box plus an optional outer layer.
#[derive(Debug, Clone)]
pub struct Grid {
    dim: usize,
    h: f64,
    min: Point,
    max: Point,
    placement: Placement,
    /// Lattice index of the first node along each axis (negative inside the lower layer).
    lo: [i64; 3],
    /// Number of nodes along each axis (1 for unused axes).
    counts: [usize; 3],
    /// Lattice index range `[body_lo, body_hi]` of body (non-layer) nodes per axis.
    body_lo: [i64; 3],
    body_hi: [i64; 3],
    /// The kept sites when a body removed some (`None`: every site is a node).
    mask: Option<std::sync::Arc<SiteMask>>,
    /// Per-node volumes of cells cut by the body's boundary ([`Grid::with_cut_volumes`];
    /// `None`: every node has `h^d`).
    volumes: Option<std::sync::Arc<Vec<f64>>>,
}

/// Which lattice sites are nodes ([`Grid::with_body`]).
#[derive(Debug)]
struct SiteMask {
    /// Site (lexicographic index over the full lattice) of each node.
    site_of: Vec<u32>,
    /// Node of each site, `u32::MAX` for a removed site.
    node_of: Vec<u32>,
}

/// Sub-cells per axis of [`Grid::with_cut_volumes`] in 1D, 2D and 3D.
pub const CUT_SAMPLES: [usize; 3] = [16, 16, 8];

/// Layer thicknesses `[lower, upper]` per axis (unused axes ignored).
pub type Layers = [[f64; 2]; 3];

impl Grid {
    /// Builds the lattice on `[min, max]` with spacing `h` and `layer` thickness outside.
    ///
    /// `(max - min) / h` must be an integer up to a relative tolerance of `1e-6`; the layer
    /// holds `floor(layer / h)` nodes per side (a layer thinner than `h` holds none).
    pub fn new(min: &[f64], max: &[f64], h: f64, layer: f64, placement: Placement) -> Result<Self, CoreError> {
        Self::with_layers(min, max, h, [[layer; 2]; 3], placement)
    }

    /// [`Grid::new`] with a layer thickness per side: `layers[a] = [below min_a, above max_a]`.
    pub fn with_layers(
        min: &[f64],
        max: &[f64],
        h: f64,
        layers: Layers,
        placement: Placement,
    ) -> Result<Self, CoreError> {
        let dim = min.len();
        if !(1..=3).contains(&dim) {
            return Err(CoreError::Dimension(dim));
        }
        if max.len() != dim {
            return Err(CoreError::Components { expected: dim, got: max.len() });
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(CoreError::param("spacing", format!("must be a positive number, got {h:e}")));
        }
        // Node counts in checked integer arithmetic: a float count beyond `i64` would saturate
        // in `as i64` and `last + 2 nl + 1` would wrap (`layer: 1e300` gave "99 nodes" at
        // x = -9.2e18). `MAX_AXIS` keeps every sum below `i64::MAX`.
        const MAX_AXIS: f64 = (1u64 << 52) as f64;
        let mut nl = [[0i64; 2]; 3];
        for a in 0..dim {
            for (side, &layer) in layers[a].iter().enumerate() {
                if !(layer.is_finite() && layer >= 0.0) {
                    return Err(CoreError::param("layer", format!("must be >= 0, got {layer:e}")));
                }
                let layer_nodes = (layer / h * (1.0 + GEOMETRY_RTOL)).floor();
                if layer_nodes > MAX_AXIS {
                    return Err(CoreError::param(
                        "layer",
                        format!("layer {layer:e} with spacing {h:e} gives more than usize::MAX nodes"),
                    ));
                }
                nl[a][side] = layer_nodes as i64;
            }
        }
        let mut g = Grid {
            dim,
            h,
            min: [0.0; 3],
            max: [0.0; 3],
            placement,
            lo: [0; 3],
            counts: [1; 3],
            body_lo: [0; 3],
            body_hi: [0; 3],
            mask: None,
            volumes: None,
        };
        for a in 0..dim {
            if !(min[a].is_finite() && max[a].is_finite()) || max[a] <= min[a] {
                return Err(CoreError::param(
                    "max",
                    format!("axis {a}: max ({:e}) must be greater than min ({:e})", max[a], min[a]),
                ));
            }
            let cells = (max[a] - min[a]) / h;
            if !(cells <= MAX_AXIS) {
                return Err(CoreError::param(
                    "spacing",
                    format!("axis {a}: (max - min) / spacing = {cells:e} gives more than usize::MAX nodes"),
                ));
            }
            let n = cells.round();
            if (cells - n).abs() > 1e-6 * cells.max(1.0) || n < 1.0 {
                return Err(CoreError::param(
                    "spacing",
                    format!("axis {a}: (max - min) / spacing = {cells:e} is not a positive integer"),
                ));
            }
            let n = n as i64;
            let last = match placement {
                Placement::Vertex => n,
                Placement::Cell => n - 1,
            };
            let count = nl[a][0]
                .checked_add(nl[a][1])
                .and_then(|x| x.checked_add(last + 1))
                .and_then(|c| usize::try_from(c).ok());
            let Some(count) = count else {
                return Err(CoreError::param(
                    "layer",
                    format!(
                        "layers {:e}, {:e} with spacing {h:e} give more than usize::MAX nodes",
                        layers[a][0], layers[a][1]
                    ),
                ));
            };
            g.min[a] = min[a];
            g.max[a] = max[a];
            g.body_lo[a] = 0;
            g.body_hi[a] = last;
            g.lo[a] = -nl[a][0];
            g.counts[a] = count;
        }
        let total: u128 = g.counts.iter().map(|&c| c as u128).product();
        if total > u32::MAX as u128 {
            return Err(CoreError::param(
                "spacing",
                format!("the grid would have {total:.3e} nodes; at most 2^32 - 1 are supported", total = total as f64),
            ));
        }
        Ok(g)
    }

    /// Spatial dimension (1, 2 or 3).
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Lattice spacing `h`.
    pub fn spacing(&self) -> f64 {
        self.h
    }
    /// Node volume `h^d` (the volume of every node unless [`Grid::with_cut_volumes`] cut
    /// some: then see [`Grid::node_volume`]).
    pub fn volume(&self) -> f64 {
        self.h.powi(self.dim as i32)
    }
    /// Volume of node `n`: `h^d`, or its cell's inside fraction times `h^d` after
    /// [`Grid::with_cut_volumes`].
    pub fn node_volume(&self, n: usize) -> f64 {
        match &self.volumes {
            Some(v) => v[n],
            None => self.volume(),
        }
    }
    /// True when every node has the volume `h^d`.
    pub fn has_uniform_volumes(&self) -> bool {
        self.volumes.is_none()
    }

    /// The grid with node volumes from the body `inside` (call it on the grid
    /// [`Grid::with_body`] made with the same predicate): each node gets `h^d` times the
    /// fraction of its cell (the cube of side `h` centred on it) that is inside, and the inside
    /// part of the cell of a *removed* site (its node lies outside, part of its cell inside)
    /// goes to the kept lattice neighbour (one of the `3^d - 1` around it) nearest to that
    /// part's centroid. So the volumes sum to the body's measure within the lattice box, where
    /// dropping the removed sites' parts would miss about half a cell row along the boundary.
    ///
    /// Fractions by the midpoint rule on `s^d` sub-cells (`s` = [`CUT_SAMPLES`] per axis: 16
    /// in 1D and 2D, 8 in 3D): exact for whole cells and cuts along sub-cell faces; for a
    /// smooth boundary a cut cell's error is about one sub-cell row, `h^d / s`, of either sign,
    /// averaging out along the boundary. A kept node's fraction is at least one sub-cell, so
    /// no node gets volume 0. A removed part with no kept neighbour is dropped (see
    /// [`Grid::with_cut_volumes_dropping`] to learn about it).
    pub fn with_cut_volumes(&self, inside: impl Fn(&Point) -> bool + Sync) -> Grid {
        self.with_cut_volumes_dropping(inside).0
    }

    /// [`Grid::with_cut_volumes`], and the parts of the body it had to drop: `(centroid,
    /// volume)` of each removed site's inside part with no kept lattice neighbour (a piece of
    /// the body, such as an isolated union part, that holds no node and borders no kept node's
    /// cell), in site order. Empty when the volumes add up to the body's measure.
    pub fn with_cut_volumes_dropping(&self, inside: impl Fn(&Point) -> bool + Sync) -> (Grid, Vec<(Point, f64)>) {
        use rayon::prelude::*;
        let d = self.dim;
        let s = CUT_SAMPLES[d - 1];
        let cells = s.pow(d as u32);
        let v0 = self.volume();
        // inside sub-cells of the cell at `x` and their centroid
        let fraction = |x: &Point| -> (usize, Point) {
            let (mut count, mut c) = (0usize, [0.0; 3]);
            for k in 0..cells {
                let mut p = *x;
                let mut r = k;
                for a in 0..d {
                    p[a] = x[a] + self.h * (((r % s) as f64 + 0.5) / s as f64 - 0.5);
                    r /= s;
                }
                if inside(&p) {
                    count += 1;
                    (0..d).for_each(|a| c[a] += p[a]);
                }
            }
            (0..d).for_each(|a| c[a] /= count.max(1) as f64);
            (count, c)
        };
        let mut volumes: Vec<f64> = (0..self.len())
            .into_par_iter()
            .map(|n| v0 * fraction(&self.position(n)).0.max(1) as f64 / cells as f64)
            .collect();
        let removed: Vec<(Option<usize>, Point, f64)> = (0..self.n_sites())
            .into_par_iter()
            .filter_map(|site| {
                let mut q = [0usize; 3];
                let mut r = site;
                for a in 0..3 {
                    q[a] = r % self.counts[a];
                    r /= self.counts[a];
                }
                if self.node_at_site(q).is_some() {
                    return None;
                }
                let (count, c) = fraction(&self.site_position(q));
                if count == 0 {
                    return None;
                }
                let idx = [0, 1, 2].map(|a| self.lo[a] + q[a] as i64);
                let span = |a: usize| if a < d { -1..=1i64 } else { 0..=0 };
                let mut best: Option<(f64, usize)> = None;
                for k2 in span(2) {
                    for k1 in span(1) {
                        for k0 in span(0) {
                            if let Some(n) = self.node_at([idx[0] + k0, idx[1] + k1, idx[2] + k2]) {
                                let p = self.position(n);
                                let dist: f64 = (0..d).map(|a| (p[a] - c[a]).powi(2)).sum();
                                if best.is_none_or(|(b, _)| dist < b) {
                                    best = Some((dist, n));
                                }
                            }
                        }
                    }
                }
                Some((best.map(|(_, n)| n), c, v0 * count as f64 / cells as f64))
            })
            .collect();
        let mut dropped = Vec::new();
        for (n, c, v) in removed {
            match n {
                Some(n) => volumes[n] += v,
                None => dropped.push((c, v)),
            }
        }
        let mut g = self.clone();
        g.volumes = Some(std::sync::Arc::new(volumes));
        (g, dropped)
    }
    /// Number of nodes, layers included (the kept sites only, when a body removed some).
    pub fn len(&self) -> usize {
        match &self.mask {
            Some(m) => m.site_of.len(),
            None => self.n_sites(),
        }
    }
    /// Number of lattice sites, kept or not: the product of [`Grid::counts`].
    pub fn n_sites(&self) -> usize {
        self.counts.iter().product()
    }
    /// True when every lattice site is a node (no body removed any): the full box that the
    /// stencil operator and the lattice plots need.
    pub fn is_full(&self) -> bool {
        self.mask.is_none()
    }

    /// The grid with only the nodes for which `keep(position)` holds (see the module docs).
    /// Nodes keep their lattice indices, positions, volumes and layer flags; they are
    /// renumbered in the same order. Errors when no node is kept.
    pub fn with_body(&self, keep: impl Fn(&Point) -> bool + Sync) -> Result<Grid, CoreError> {
        use rayon::prelude::*;
        let kept: Vec<bool> = (0..self.len()).into_par_iter().map(|n| keep(&self.position(n))).collect();
        self.with_nodes(&kept)
    }

    /// The grid of the nodes `n` with `kept[n]` (one flag per node): [`Grid::with_body`] by
    /// node rather than by position. The kept nodes keep their lattice indices and volumes; the
    /// others are removed sites (as a body's).
    pub fn with_nodes(&self, kept: &[bool]) -> Result<Grid, CoreError> {
        assert_eq!(kept.len(), self.len(), "one flag per node");
        let mut site_of = Vec::with_capacity(kept.iter().filter(|k| **k).count());
        let mut node_of = vec![u32::MAX; self.n_sites()];
        for (n, _) in kept.iter().enumerate().filter(|(_, k)| **k) {
            let site = self.site(n);
            node_of[site] = site_of.len() as u32;
            site_of.push(site as u32);
        }
        if site_of.is_empty() {
            return Err(CoreError::param("body", format!("keeps none of the {} nodes of the grid", self.len())));
        }
        let mut g = self.clone();
        if let Some(v) = &self.volumes {
            let kept_volumes = (0..self.len()).filter(|&n| kept[n]).map(|n| v[n]).collect();
            g.volumes = Some(std::sync::Arc::new(kept_volumes));
        }
        g.mask = Some(std::sync::Arc::new(SiteMask { site_of, node_of }));
        Ok(g)
    }

    /// The slab of sites `first..last` along the slowest axis (`dim - 1`: z in 3D, y in 2D;
    /// 0-based site numbers, layers included) as a grid of its own: one rank's part of a
    /// distributed scene. Every kept site keeps its lattice index, position, layer flag and
    /// body box, so regions, faces and tractions select the same nodes they select in the
    /// whole grid; neighbour searches see the slab's ends as the end of the box. Only for a
    /// grid before any body or cut volumes (apply those to the slab); `None` when the range
    /// is empty or leaves the box.
    pub fn window(&self, first: usize, last: usize) -> Option<Grid> {
        let axis = self.dim - 1;
        if first >= last || last > self.counts[axis] || self.mask.is_some() || self.volumes.is_some() {
            return None;
        }
        let mut g = self.clone();
        g.lo[axis] = self.lo[axis] + first as i64;
        g.counts[axis] = last - first;
        Some(g)
    }

    /// Lexicographic site index of node `n`.
    fn site(&self, n: usize) -> usize {
        match &self.mask {
            Some(m) => m.site_of[n] as usize,
            None => n,
        }
    }
    /// True when the grid has no nodes (never, for a grid built by [`Grid::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Nodes per axis, layers included (1 on unused axes).
    pub fn counts(&self) -> [usize; 3] {
        self.counts
    }
    /// Lower corner of the body box.
    pub fn min(&self) -> &[f64] {
        &self.min[..self.dim]
    }
    /// Upper corner of the body box.
    pub fn max(&self) -> &[f64] {
        &self.max[..self.dim]
    }
    /// Node placement.
    pub fn placement(&self) -> Placement {
        self.placement
    }

    /// Lattice index of node `n` (layer nodes have indices below 0 or above the body's).
    pub fn lattice_index(&self, n: usize) -> [i64; 3] {
        let mut idx = [0i64; 3];
        let mut r = self.site(n);
        for a in 0..3 {
            idx[a] = (r % self.counts[a]) as i64 + self.lo[a];
            r /= self.counts[a];
        }
        idx
    }

    /// Site `(i, j, k)` of node `n` in the lattice box (0-based, layers included; the inverse
    /// of [`Grid::node_at_site`]).
    pub fn site_of(&self, n: usize) -> [usize; 3] {
        let r = self.site(n);
        [r % self.counts[0], (r / self.counts[0]) % self.counts[1], r / (self.counts[0] * self.counts[1])]
    }

    /// Whether lattice index `idx` lies in the lattice box (layers included), node or not: a
    /// site inside the box without a node was removed by a body.
    pub fn box_contains(&self, idx: [i64; 3]) -> bool {
        (0..3).all(|a| idx[a] >= self.lo[a] && idx[a] < self.lo[a] + self.counts[a] as i64)
    }

    /// Node number of a lattice index, or `None` outside the grid.
    pub fn node_at(&self, idx: [i64; 3]) -> Option<usize> {
        let mut n = 0usize;
        for a in (0..3).rev() {
            let k = idx[a] - self.lo[a];
            if k < 0 || k >= self.counts[a] as i64 {
                return None;
            }
            n = n * self.counts[a] + k as usize;
        }
        match &self.mask {
            Some(m) => Some(m.node_of[n]).filter(|&k| k != u32::MAX).map(|k| k as usize),
            None => Some(n),
        }
    }

    /// The node at site `(i, j, k)` of the lattice box (`0 <= i < counts[0]`, ...; layers
    /// included), or `None` where a body removed it or outside the box.
    pub fn node_at_site(&self, site: [usize; 3]) -> Option<usize> {
        self.node_at([0, 1, 2].map(|a| self.lo[a] + site[a] as i64))
    }

    /// The site ranges per axis (see [`Grid::node_at_site`]) holding every site whose position
    /// lies in the box `[lo - tol, hi + tol]` (first `dim` coordinates; infinite bounds allowed),
    /// with a site to spare at each end against rounding.
    pub fn sites_within(&self, lo: [f64; 3], hi: [f64; 3], tol: f64) -> [std::ops::Range<usize>; 3] {
        let shift = match self.placement {
            Placement::Vertex => 0.0,
            Placement::Cell => 0.5,
        };
        std::array::from_fn(|a| {
            let count = self.counts[a];
            if a >= self.dim {
                return 0..count;
            }
            // site k sits at min + (lo_a + k + shift) h; clamped as floats, so that huge and
            // infinite bounds give the whole axis
            let site = |x: f64| (x - self.min[a]) / self.h - shift - self.lo[a] as f64;
            let first = (site(lo[a] - tol).floor() - 1.0).clamp(0.0, count as f64) as usize;
            let last = (site(hi[a] + tol).ceil() + 2.0).clamp(0.0, count as f64) as usize;
            first..last.max(first)
        })
    }

    /// Position of lattice site `(i, j, k)` (see [`Grid::node_at_site`]), node or not.
    pub fn site_position(&self, site: [usize; 3]) -> Point {
        self.position_of_index([0, 1, 2].map(|a| self.lo[a] + site[a] as i64))
    }

    /// Position of node `n`.
    pub fn position(&self, n: usize) -> Point {
        self.position_of_index(self.lattice_index(n))
    }

    fn position_of_index(&self, idx: [i64; 3]) -> Point {
        let shift = match self.placement {
            Placement::Vertex => 0.0,
            Placement::Cell => 0.5,
        };
        let mut x = [0.0; 3];
        for a in 0..self.dim {
            x[a] = self.min[a] + (idx[a] as f64 + shift) * self.h;
        }
        x
    }

    /// All node positions, in node order.
    pub fn positions(&self) -> Vec<Point> {
        (0..self.len()).map(|n| self.position(n)).collect()
    }

    /// True for nodes of the outer layer (outside the body box).
    pub fn is_layer(&self, n: usize) -> bool {
        let idx = self.lattice_index(n);
        (0..self.dim).any(|a| idx[a] < self.body_lo[a] || idx[a] > self.body_hi[a])
    }

    /// The node nearest to `x` and its distance.
    pub fn nearest_node(&self, x: &[f64]) -> (usize, f64) {
        let shift = match self.placement {
            Placement::Vertex => 0.0,
            Placement::Cell => 0.5,
        };
        let mut idx = [0i64; 3];
        for a in 0..self.dim {
            let k = ((x[a] - self.min[a]) / self.h - shift).round() as i64;
            idx[a] = k.clamp(self.lo[a], self.lo[a] + self.counts[a] as i64 - 1);
        }
        let dist = |n: usize| {
            let p = self.position(n);
            (0..self.dim).map(|a| (p[a] - x[a]).powi(2)).sum::<f64>().sqrt()
        };
        match self.node_at(idx) {
            Some(n) => (n, dist(n)),
            // the nearest site was removed by a body: search the kept nodes
            None => {
                (0..self.len()).map(|n| (n, dist(n))).fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_grid_has_both_ends_and_layers() {
        // spacing 1/300 written in decimal: (max-min)/h = 299.99999999999997 must round to 300.
        let g = Grid::new(&[0.0], &[1.0], 0.0033333333333333335, 0.05, Placement::Vertex).unwrap();
        // 301 body nodes + 15 layer nodes on each side.
        assert_eq!(g.len(), 301 + 30);
        assert_eq!(g.lattice_index(0)[0], -15);
        assert!((g.position(15)[0] - 0.0).abs() < 1e-15);
        assert!((g.position(315)[0] - 1.0).abs() < 1e-12);
        assert!(g.is_layer(14) && !g.is_layer(15) && !g.is_layer(315) && g.is_layer(316));
    }

    #[test]
    fn window_keeps_positions_layers_and_body_box() {
        let whole =
            Grid::with_layers(&[0.0, 0.0], &[1.0, 2.0], 0.25, [[0.0; 2], [0.5, 0.25], [0.0; 2]], Placement::Vertex)
                .unwrap();
        assert_eq!(whole.counts(), [5, 12, 1]);
        let w = whole.window(1, 4).unwrap();
        assert_eq!(w.counts(), [5, 3, 1]);
        assert_eq!((w.min(), w.max()), (whole.min(), whole.max()));
        for n in 0..w.len() {
            // node n of the window is node n + 5 of the whole grid (one plane of 5 below it)
            assert_eq!(w.lattice_index(n), whole.lattice_index(n + 5));
            assert_eq!(w.position(n), whole.position(n + 5));
            assert_eq!(w.is_layer(n), whole.is_layer(n + 5));
        }
        // a neighbour search stops at the window's ends
        assert_eq!(w.node_at(whole.lattice_index(0)), None);
        assert!(whole.window(4, 4).is_none() && whole.window(0, 13).is_none());
        let body = whole.with_body(|x| x[0] < 0.6).unwrap();
        assert!(body.window(0, 2).is_none(), "a window is cut before the body");
    }

    #[test]
    fn cell_grid_and_node_lookup_roundtrip() {
        let g = Grid::new(&[0.0, 0.0, 0.0], &[1.0, 2.0, 0.5], 0.25, 0.0, Placement::Cell).unwrap();
        assert_eq!(g.counts(), [4, 8, 2]);
        for n in 0..g.len() {
            assert_eq!(g.node_at(g.lattice_index(n)), Some(n));
        }
        assert!((g.position(0)[1] - 0.125).abs() < 1e-15);
        let (n, d) = g.nearest_node(&[0.6, 1.1, 0.4]);
        assert_eq!(g.lattice_index(n), [2, 4, 1]);
        assert!(d < 0.25);
    }

    #[test]
    fn rejects_non_integer_cells_and_bad_spacing() {
        assert!(Grid::new(&[0.0], &[1.0], 0.3, 0.0, Placement::Vertex).is_err());
        assert!(Grid::new(&[0.0], &[1.0], -0.1, 0.0, Placement::Vertex).is_err());
        assert!(Grid::new(&[1.0], &[0.0], 0.1, 0.0, Placement::Vertex).is_err());
        assert!(Grid::new(&[0.0, 0.0], &[1.0], 0.1, 0.0, Placement::Vertex).is_err());
    }

    /// Per-side layers: 3 layer nodes below x = 0 only, none elsewhere.
    #[test]
    fn per_side_layers() {
        let mut layers = [[0.0; 2]; 3];
        layers[0][0] = 0.3;
        let g = Grid::with_layers(&[0.0, 0.0], &[1.0, 0.5], 0.1, layers, Placement::Vertex).unwrap();
        assert_eq!(g.counts(), [11 + 3, 6, 1]);
        assert!((g.position(0)[0] + 0.3).abs() < 1e-15);
        let layer = (0..g.len()).filter(|&n| g.is_layer(n)).count();
        assert_eq!(layer, 3 * 6);
        assert!((0..g.len()).all(|n| !g.is_layer(n) || g.position(n)[0] < 0.0));
    }

    /// A body keeps the sites inside it, renumbered in order; removed sites look up as `None`,
    /// and the nearest node of a point in the hole is a kept node.
    #[test]
    fn body_keeps_sites_and_renumbers() {
        let full = Grid::new(&[0.0, 0.0], &[1.0, 1.0], 0.1, 0.0, Placement::Vertex).unwrap();
        let inside = |x: &Point| (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) >= 0.2f64.powi(2);
        let g = full.with_body(inside).unwrap();
        let kept: Vec<usize> = (0..full.len()).filter(|&n| inside(&full.position(n))).collect();
        assert_eq!(g.len(), kept.len());
        assert!(g.len() < full.len() && !g.is_full() && full.is_full());
        assert_eq!(g.n_sites(), full.n_sites());
        for (n, &f) in kept.iter().enumerate() {
            assert_eq!(g.position(n), full.position(f));
            assert_eq!(g.node_at(g.lattice_index(n)), Some(n));
        }
        assert_eq!(g.node_at(full.lattice_index(full.nearest_node(&[0.5, 0.5]).0)), None, "the centre is gone");
        let (n, d) = g.nearest_node(&[0.5, 0.5]);
        assert!(inside(&g.position(n)) && d >= 0.2 - 1e-12);
        assert!(full.with_body(|_| false).unwrap_err().to_string().contains("keeps none of the 121 nodes"));
    }

    /// Cut-cell volumes: a half-space through a node cuts its cell in half exactly; a disk's
    /// area is recovered far better than with full volumes; wholly inside cells keep `h^d`.
    #[test]
    fn cut_volumes_are_inside_fractions() {
        let full = Grid::new(&[0.0, 0.0], &[1.0, 1.0], 0.1, 0.0, Placement::Vertex).unwrap();
        let half = |x: &Point| x[0] <= 0.5;
        let g = full.with_body(half).unwrap().with_cut_volumes(half);
        let on_cut = (0..g.len()).filter(|&n| (g.position(n)[0] - 0.5).abs() < 1e-12).count();
        assert_eq!(on_cut, 11);
        for n in 0..g.len() {
            let x = g.position(n)[0];
            // boundary rows of the box are not cut by `half` (samples outside the box count)
            let want = if (x - 0.5).abs() < 1e-12 { 0.005 } else { 0.01 };
            assert!((g.node_volume(n) - want).abs() < 1e-15, "node {n} at x = {x}: {}", g.node_volume(n));
        }
        // a disk of radius 0.3: cut volumes sum to its area within 0.05 %, full volumes miss by 0.5 %
        let disk = |x: &Point| (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) <= 0.09;
        let fine = Grid::new(&[0.0, 0.0], &[1.0, 1.0], 0.02, 0.0, Placement::Vertex).unwrap();
        let body = fine.with_body(disk).unwrap();
        let area = std::f64::consts::PI * 0.09;
        let full_err = (body.len() as f64 * body.volume() - area).abs() / area;
        let cut = body.with_cut_volumes(disk);
        let cut_err = ((0..cut.len()).map(|n| cut.node_volume(n)).sum::<f64>() - area).abs() / area;
        assert!(cut_err < 5e-4 && cut_err < full_err / 5.0, "cut {cut_err:e}, full {full_err:e}");
        assert!(full.has_uniform_volumes() && !cut.has_uniform_volumes());
    }

    /// Node counts are checked integers: a huge layer or box is an error, never a wrapped count.
    #[test]
    fn grid_layer_overflow_is_an_error() {
        let e = Grid::new(&[0.0], &[1.0], 0.1, 1e300, Placement::Vertex).unwrap_err().to_string();
        assert!(e.contains("layer 1e300 with spacing 1e-1 gives more than usize::MAX nodes"), "{e}");
        // Just below the float limit of the check, the integer sum still must not wrap.
        let e = Grid::new(&[0.0], &[1.0], 1.0, 4.5e15, Placement::Vertex).unwrap_err().to_string();
        assert!(e.contains("nodes"), "{e}");
        let e = Grid::new(&[0.0], &[1e300], 1e-10, 0.0, Placement::Vertex).unwrap_err().to_string();
        assert!(e.contains("= inf gives more than usize::MAX nodes"), "{e}");
        let e = Grid::new(&[-1e308], &[1e308], 1.0, 0.0, Placement::Vertex).unwrap_err().to_string();
        assert!(e.contains("more than usize::MAX nodes"), "{e}");
    }
}
