//! Bond families: for every node `i`, the nodes `j != i` with `|x_j - x_i| <= delta`
//! (eq. (11) of the LAMMPS howto).
//!
//! Two constructions, never O(n^2):
//!
//! * [`BondFamily::from_grid`] works in lattice units: the stencil is the set of integer
//!   offsets `k` with `|k|^2 <= (delta/h)^2 (1 + GEOMETRY_RTOL)`. Squared lattice distances are
//!   integers, so the tolerance decides only the exact-horizon case (`delta = 3h` bonds the
//!   node at `3h`), never a genuine gap (gaps are >= `1 / (delta/h)^2 >> 1e-9`).
//! * [`BondFamily::from_points`] is a cell-list search for arbitrary point sets with the same
//!   relative tolerance on the squared distance.
//!
//! Neighbour lists are sorted ascending; offsets are `usize`, so more than 2^31 bonds are fine.

use crate::{Grid, Point, GEOMETRY_RTOL};
use rayon::prelude::*;
use std::collections::HashMap;

/// Compressed neighbour lists (self excluded).
#[derive(Debug, Clone, PartialEq)]
pub struct BondFamily {
    offsets: Vec<usize>,
    neighbors: Vec<u32>,
}

/// Integer lattice offsets `k != 0` with `|k| h <= delta`, sorted so that neighbour numbers
/// (first axis fastest) come out ascending.
pub fn lattice_stencil(dim: usize, ratio: f64) -> Vec<[i64; 3]> {
    stencil_within(dim, ratio, [i64::MAX; 3])
}

/// [`lattice_stencil`] of the offsets that can join two nodes of `grid`: `|k_a| < n_a`, the
/// grid's node count along axis `a` (the others never find a partner). Exact for every use
/// that looks partners up on the grid, and bounded by the grid whatever the ratio (a mutated
/// horizon of 1e18 spacings enumerated 6 GB of offsets before).
pub fn grid_stencil(grid: &Grid, ratio: f64) -> Vec<[i64; 3]> {
    let n = grid.counts();
    stencil_within(grid.dim(), ratio, n.map(|c| c.saturating_sub(1) as i64))
}

/// The offsets of [`lattice_stencil`] with `|k_a| <= reach[a]`.
fn stencil_within(dim: usize, ratio: f64, reach: [i64; 3]) -> Vec<[i64; 3]> {
    let r = (ratio * (1.0 + GEOMETRY_RTOL)).floor().min(i64::MAX as f64) as i64;
    let r2 = ratio * ratio * (1.0 + GEOMETRY_RTOL);
    let span = |a: usize| if a < dim { -r.min(reach[a])..=r.min(reach[a]) } else { 0..=0 };
    let mut out = Vec::new();
    for k2 in span(2) {
        for k1 in span(1) {
            for k0 in span(0) {
                let n2 = (k0 * k0 + k1 * k1 + k2 * k2) as f64;
                if n2 > 0.0 && n2 <= r2 {
                    out.push([k0, k1, k2]);
                }
            }
        }
    }
    out
}

impl BondFamily {
    /// Families on a lattice, by the stencil of [`lattice_stencil`].
    pub fn from_grid(grid: &Grid, horizon: f64) -> Self {
        let stencil = grid_stencil(grid, horizon / grid.spacing());
        let n = grid.len();
        let lists: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let idx = grid.lattice_index(i);
                stencil
                    .iter()
                    .filter_map(|k| grid.node_at([idx[0] + k[0], idx[1] + k[1], idx[2] + k[2]]).map(|j| j as u32))
                    .collect()
            })
            .collect();
        Self::from_lists(lists)
    }

    /// Families of an arbitrary point set by a cell list of cell size `horizon` ([`CellList`]).
    pub fn from_points(points: &[Point], dim: usize, horizon: f64) -> Self {
        assert!(horizon > 0.0, "horizon must be positive");
        let cells = CellList::new(points, dim, horizon);
        let lists: Vec<Vec<u32>> = points
            .par_iter()
            .enumerate()
            .map(|(i, x)| {
                let mut list = Vec::new();
                cells.for_each_within(points, x, |j| {
                    if j as usize != i {
                        list.push(j);
                    }
                });
                list.sort_unstable();
                list
            })
            .collect();
        Self::from_lists(lists)
    }

    /// Builds a family from per-node lists (each sorted ascending, self excluded).
    pub fn from_lists(lists: Vec<Vec<u32>>) -> Self {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        offsets.push(0usize);
        for l in &lists {
            offsets.push(offsets.last().unwrap() + l.len());
        }
        let neighbors = lists.into_iter().flatten().collect();
        BondFamily { offsets, neighbors }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }
    /// True for a family of no nodes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Neighbours of node `i`, ascending.
    pub fn neighbors(&self, i: usize) -> &[u32] {
        &self.neighbors[self.offsets[i]..self.offsets[i + 1]]
    }
    /// Position of node `i`'s first bond in bond-indexed arrays.
    pub fn bond_offset(&self, i: usize) -> usize {
        self.offsets[i]
    }
    /// Total number of (directed) bonds: each pair is counted from both ends.
    pub fn n_bonds(&self) -> usize {
        self.neighbors.len()
    }
    /// Nodes without any bond.
    pub fn isolated(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.neighbors(i).is_empty()).collect()
    }
}

/// Points binned into cubes slightly larger than `radius`: two points within
/// `radius (1 + GEOMETRY_RTOL)` always sit in the same or adjacent cells, whatever the rounding
/// of `x / size`. Shared by the families of point clouds ([`BondFamily::from_points`]) and by
/// the pair count of the memory guard, so that both see the same pairs.
pub struct CellList {
    dim: usize,
    size: f64,
    r2: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl CellList {
    /// Bins `points` (`radius > 0`).
    pub fn new(points: &[Point], dim: usize, radius: f64) -> Self {
        let size = radius * (1.0 + 1e-6);
        let mut list = Self { dim, size, r2: radius * radius * (1.0 + GEOMETRY_RTOL), cells: HashMap::new() };
        for (i, x) in points.iter().enumerate() {
            let c = list.cell(x);
            list.cells.entry(c).or_default().push(i as u32);
        }
        list
    }

    fn cell(&self, x: &Point) -> [i64; 3] {
        let mut c = [0i64; 3];
        for a in 0..self.dim {
            c[a] = (x[a] / self.size).floor() as i64;
        }
        c
    }

    /// The `3^d` cells around `c` (itself included).
    fn around(&self, c: [i64; 3]) -> impl Iterator<Item = [i64; 3]> + '_ {
        let span = move |a: usize| if a < self.dim { -1i64..=1 } else { 0..=0 };
        span(2).flat_map(move |d2| {
            span(1).flat_map(move |d1| {
                span(0).map(move |d0| [c[0].saturating_add(d0), c[1].saturating_add(d1), c[2].saturating_add(d2)])
            })
        })
    }

    /// Calls `f(j)` for every point `j` within `radius` of `x` (`x` itself included if it is
    /// one of the points), in cell order.
    pub fn for_each_within(&self, points: &[Point], x: &Point, mut f: impl FnMut(u32)) {
        for k in self.around(self.cell(x)) {
            for &j in self.cells.get(&k).map_or(&[][..], |v| v.as_slice()) {
                let y = &points[j as usize];
                let d: f64 = (0..self.dim).map(|a| (y[a] - x[a]).powi(2)).sum();
                if d <= self.r2 {
                    f(j);
                }
            }
        }
    }

    /// `sum over cells of |c| (|neighbourhood of c| - 1)`: a bound on the ordered pairs within
    /// `radius` that costs no distance test.
    pub fn pair_bound(&self) -> u64 {
        self.cells
            .iter()
            .map(|(&c, members)| {
                let near: u64 = self.around(c).filter_map(|k| self.cells.get(&k)).map(|m| m.len() as u64).sum();
                members.len() as u64 * (near - 1)
            })
            .sum()
    }
}

/// What a rank's part of a point cloud takes from the whole cloud (a distributed solve: the
/// part holds only the rank's window of the nodes), so that the rows it builds are the whole
/// cloud's: the scales its geometric tolerances and checks are relative to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudScales {
    /// The whole cloud's smallest node size `min_i V_i^(1/d)` (tolerances `GEOMETRY_RTOL` times it).
    pub min_size: f64,
    /// The whole cloud's mean node volume `sum_i V_i / n`.
    pub mean_volume: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Placement;

    #[test]
    fn stencil_counts_match_known_values() {
        // delta = 3h: 6 in 1D, 28 in 2D, 122 in 3D (lattice points in the closed ball minus one).
        assert_eq!(lattice_stencil(1, 3.0).len(), 6);
        assert_eq!(lattice_stencil(2, 3.0).len(), 28);
        assert_eq!(lattice_stencil(3, 3.0).len(), 122);
        // Computed ratios that land a hair under 3 still bond the node at 3h.
        assert_eq!(lattice_stencil(3, 0.0015 / 0.0005).len(), 122);
        assert_eq!(lattice_stencil(1, 0.05 / (1.0 / 300.0)).len(), 30);
    }

    #[test]
    fn cell_list_agrees_with_lattice_stencil() {
        for (dim, max) in [(1, vec![1.0]), (2, vec![1.0, 0.7]), (3, vec![0.5, 0.4, 0.3])] {
            let min = vec![0.0; dim];
            let h = 0.1;
            let g = Grid::new(&min, &max, h, 0.2, Placement::Vertex).unwrap();
            let a = BondFamily::from_grid(&g, 3.0 * h);
            let b = BondFamily::from_points(&g.positions(), dim, 3.0 * h);
            assert_eq!(a, b, "dim {dim}");
            // Symmetry: j in F_i iff i in F_j.
            for i in 0..a.len() {
                for &j in a.neighbors(i) {
                    assert!(a.neighbors(j as usize).binary_search(&(i as u32)).is_ok());
                }
            }
        }
    }
}
