//! A graded local mesh (issue #31): bilinear (2D) / trilinear (3D) finite elements on a
//! quadtree / octree aligned with the lattice, fine next to a given region of lattice cells
//! and coarser (x2 per level) away from it, with hanging nodes eliminated.
//!
//! # Cells
//!
//! The lattice box has nodes `x0 + h k`, `0 <= k_a < n_a`. A cell of level `l` is the box of
//! side `h 2^l` whose lowest corner is the lattice node `o` with every `o_a` a multiple of `2^l`
//! (aligned), covering the nodes `o .. o + 2^l`; level 0 is a lattice cell. The leaves tile the
//! box's `prod (n_a - 1)` lattice cells exactly: a coarse cell is used only where it lies
//! entirely inside the box (so boxes whose sizes are not powers of two get finer cells along
//! their far faces, down to level 0).
//!
//! # Grading rule
//!
//! `F` is the set of level-0 cells that must stay fine, `m = cells_per_level >= 1`. With
//! `g(e)` the gap between a cell `e` and `F` in the maximum norm, in lattice spacings (0 when
//! they touch or overlap), a cell of level `l >= 1` is admissible when
//!
//! ```text
//! g(e) >= m (2^l - 1)  =  m (1 + 2 + ... + 2^(l-1)),      l <= max_level,  e inside the box,
//! ```
//!
//! i.e. between `F` and any level-`l` cell there is room for `m` cells of each finer level
//! `0, 1, ..., l - 1`: `cells_per_level` is the number of layers of each level, each measured
//! in that level's cell size, counted outward from the finer region. Every level-0 cell gets
//! the largest admissible level of the aligned cells containing it (admissibility passes to
//! the children, so this is a tree). `g` comes from the exact Chebyshev distance transform of
//! `F` on the lattice cells (`g = dist - 1` for a level-0 cell, the minimum over a coarse
//! cell's level-0 cells). The maximum norm (not the Euclidean one) because the cells are boxes:
//! the bands of each level are then boxes around `F` too. The rule is a lower bound on the gap:
//! alignment (a coarse cell must start at a multiple of its side) and the balance below only
//! refine further, so the fine bands come out somewhat wider than `m` cells of their level.
//!
//! # Balance rule
//!
//! After grading, leaves are split until any two leaves **sharing a point** (a face, an edge or
//! a corner) differ by at most one level: 2:1 balance across faces, edges and corners. Corner
//! balance (stronger than the face balance that conformity needs) makes every hanging node's
//! masters regular nodes: a hanging node on a coarse face or edge is a corner of a finer leaf
//! that also touches the corners of that face or edge, so no level-`l + 2` leaf can leave those
//! corners hanging. The constraints are then one level deep (no chains), and the mesh grows by
//! a few cells per level transition only.
//!
//! # Hanging nodes
//!
//! A node (a leaf corner) lying inside an edge or a face of a coarser leaf `e` of side `s` is
//! hanging: by balance it sits at the midpoint of the edge or the centre of the face, and the
//! conforming field is the trilinear interpolant of `e` there:
//!
//! ```text
//! u_h = sum_{m in masters} w_m u_m,   w_m = (1/2)^(number of axes at mid-side)
//! ```
//!
//! (edge midpoint: the two edge ends with `1/2`; face centre: its four corners with `1/4`). With
//! `T` the `d n_nodes x d n_masters` matrix of these weights (identity rows for the regular
//! nodes, the masters) the displacement is `u = T u_M` and the assembled stiffness over the
//! master DOFs is
//!
//! ```text
//! K_M = T^T K T,     K = sum_e K_e  (all nodes, the element matrices below),
//! ```
//!
//! with the element matrix of a leaf of side `s = h 2^l` (module `element`, the routine the
//! fine-lattice local model of [`crate::lattice`] uses too, so an ungraded mesh reproduces it)
//!
//! ```text
//! K_e[(r,a),(l,b)] = sum_g w_g dN_r/dx_q(t_g) (C vol_e)_aqbt dN_l/dx_t(t_g),
//! t_g = 1/2 +- 1/(2 sqrt 3) per axis, w_g = 2^-d       (2^d Gauss points, exact for constant C).
//! ```
//!
//! (`N_r` the bilinear / trilinear shape function of corner `r`). `K_M` is the stiffness of the
//! energy `(1/2) u^T K u` restricted to the conforming fields `u = T u_M`: the hanging DOFs are
//! eliminated rather than kept with Lagrange multipliers, so `K_M` stays SPD on a supported body
//! (a Cholesky factorization or CG applies) and has fewer unknowns than `K`. It is assembled
//! element by element, each corner expanded into its masters ([`GradedMesh::stiffness`]); it is
//! exact for affine fields because `T` interpolates them exactly (the masters of a hanging node
//! are the ends of the edge or the corners of the face it sits on).
//!
//! # Element moduli
//!
//! `c_of_cell(cell)` returns the elasticity tensor `C_abcd` of the cell as a `3 x 3 x 3 x 3`
//! array (index `((a*3 + b)*3 + c)*3 + d`, the layout of [`crate::lattice`]'s `D_i`; only
//! `a, b, c, d < dim` are read): the full tensor rather than a Voigt matrix, because the PD
//! moduli of the lattice come as such tensors and need not have the minor symmetries Voigt
//! notation assumes. The element uses `C vol_e`, `vol_e = (h 2^l)^d`.
//!
//! # Memory
//!
//! The construction holds one byte (leaf level) and, while grading, four bytes (distance) per
//! lattice cell; the mesh itself holds its leaves and nodes only.

pub(crate) mod element;
mod fields;
mod grading;
mod interpolate;
mod stiffness;
pub use stiffness::RowAssembler;

use crate::BlendError;
use grading::CellBox;

/// The lattice box: nodes `x0 + h k`, `0 <= k_a < n_a`, in 2D or 3D.
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeBox {
    dim: usize,
    x0: [f64; 3],
    h: f64,
    n: [usize; 3],
}

impl LatticeBox {
    /// The box of `n[a]` nodes along axis `a` (2 or 3 axes, at least 2 nodes each) from `x0`,
    /// spacing `h > 0`.
    pub fn new(x0: &[f64], h: f64, n: &[usize]) -> Result<Self, BlendError> {
        let dim = n.len();
        if !(2..=3).contains(&dim) || x0.len() != dim {
            return Err(BlendError::Inputs(format!(
                "a lattice box is 2D or 3D: {} node counts, {} origin coordinates",
                dim,
                x0.len()
            )));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(BlendError::Inputs(format!("a lattice box's spacing h = {h} is not positive")));
        }
        if let Some(a) = (0..dim).find(|&a| n[a] < 2) {
            return Err(BlendError::Inputs(format!("{} nodes along axis {a}: a cell needs 2", n[a])));
        }
        let mut b = LatticeBox { dim, x0: [0.0; 3], h, n: [1; 3] };
        b.x0[..dim].copy_from_slice(x0);
        b.n[..dim].copy_from_slice(n);
        Ok(b)
    }
    /// 2 or 3.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Lattice spacing.
    pub fn spacing(&self) -> f64 {
        self.h
    }
    /// Nodes per axis (1 on unused axes).
    pub fn counts(&self) -> [usize; 3] {
        self.n
    }
    /// Linear index of lattice node `k` (axis 0 fastest, the order of `linpd_core::Grid`).
    fn key(&self, k: [usize; 3]) -> usize {
        k[0] + self.n[0] * (k[1] + self.n[1] * k[2])
    }
    fn cells(&self) -> CellBox {
        CellBox { d: self.dim, m: [0, 1, 2].map(|a| if a < self.dim { self.n[a] - 1 } else { 1 }) }
    }
}

/// How the mesh coarsens away from the fine region (see the module docs); valid by
/// construction ([`Grading::new`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grading {
    cells_per_level: usize,
    max_level: usize,
}

/// Why a [`Grading`] is invalid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GradingError {
    /// `cells_per_level` is 0.
    #[error("cells_per_level must be at least 1")]
    NoCellsPerLevel,
    /// `max_level` is above [`Grading::MAX_LEVEL`].
    #[error("the coarsest level {0} is above {max} (cells of 2^{max} spacings)", max = Grading::MAX_LEVEL)]
    LevelTooHigh(usize),
}

impl Grading {
    /// The coarsest level a mesh may have (lattice indices of `2^l` fit a `usize` with room).
    pub const MAX_LEVEL: usize = 30;

    /// `cells_per_level` layers of cells of each level before the next (at least 1), and
    /// cells of side at most `h 2^max_level` (`max_level` at most [`Grading::MAX_LEVEL`]).
    pub fn new(cells_per_level: usize, max_level: usize) -> Result<Self, GradingError> {
        if cells_per_level == 0 {
            return Err(GradingError::NoCellsPerLevel);
        }
        if max_level > Self::MAX_LEVEL {
            return Err(GradingError::LevelTooHigh(max_level));
        }
        Ok(Grading { cells_per_level, max_level })
    }

    /// Layers of cells of each level before the next level.
    pub fn cells_per_level(&self) -> usize {
        self.cells_per_level
    }

    /// The coarsest level: cells of side at most `h 2^max_level`.
    pub fn max_level(&self) -> usize {
        self.max_level
    }
}

/// A leaf: the box of side `h 2^level` from lattice node `origin` (a multiple of `2^level`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cell {
    /// Level `l` (side `h 2^l`).
    pub level: u8,
    /// Lattice index of the lowest corner (0 on unused axes).
    pub origin: [usize; 3],
}

impl Cell {
    /// Side in lattice steps, `2^level`.
    pub fn side(&self) -> usize {
        1 << self.level
    }
    /// Lattice index of corner `c` (bit `a` set: `+side` along axis `a`).
    pub fn corner(&self, d: usize, c: usize) -> [usize; 3] {
        let s = self.side();
        [0, 1, 2].map(|a| self.origin[a] + if a < d && c >> a & 1 == 1 { s } else { 0 })
    }
}

/// A hanging node and its constraint `u_node = sum_m w_m u_m`.
#[derive(Debug, Clone, PartialEq)]
pub struct Hanging {
    /// The hanging node (index into [`GradedMesh::nodes`]).
    pub node: usize,
    /// `(master node, w_m)`: the corners of the coarse edge (`1/2` each) or face (`1/4` each).
    pub masters: Vec<(usize, f64)>,
}

/// Leaves and nodes of one level. A node's level is the finest level of the leaves it is a
/// corner of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct LevelCounts {
    /// The level.
    pub level: usize,
    /// Leaves of this level.
    pub cells: usize,
    /// Master (regular) nodes of this level.
    pub masters: usize,
    /// Hanging nodes of this level.
    pub hanging: usize,
}

/// The graded mesh (see the module docs).
#[derive(Debug, Clone)]
pub struct GradedMesh {
    lattice: LatticeBox,
    cells: Vec<Cell>,
    /// Linear lattice index of every node, ascending (the node order).
    keys: Vec<usize>,
    /// Lattice index of every node.
    nodes: Vec<[usize; 3]>,
    /// Finest level of the leaves at every node.
    node_level: Vec<u8>,
    hanging: Vec<Hanging>,
    /// Master number of every node (`u32::MAX` for a hanging one).
    master: Vec<u32>,
    n_masters: usize,
    /// The level of the leaf covering each level-0 cell (lattice cell order).
    leaf_level: Vec<u8>,
    /// The level-0 cells that are no element (a corner outside the body; empty: none).
    void: Vec<bool>,
}

impl GradedMesh {
    /// The mesh of `lattice` keeping the level-0 cells for which `fine(cell index)` holds
    /// (the index has `dim` entries, cell `c` spans nodes `c .. c + 1`), graded by `grading`
    /// and 2:1 balanced (see the module docs).
    pub fn new(lattice: &LatticeBox, fine: &dyn Fn(&[usize]) -> bool, grading: Grading) -> Result<Self, BlendError> {
        Self::with_voids(lattice, fine, &|_| false, grading)
    }

    /// [`GradedMesh::new`] on a body: the level-0 cells for which `void(cell index)` holds (a
    /// corner is not a node of the body) stay level-0 (the grading counts them as fine) but
    /// are no element; the mesh's nodes are the corners of the other leaves.
    pub fn with_voids(
        lattice: &LatticeBox,
        fine: &dyn Fn(&[usize]) -> bool,
        void: &dyn Fn(&[usize]) -> bool,
        grading: Grading,
    ) -> Result<Self, BlendError> {
        let b = lattice.cells();
        let d = lattice.dim;
        let voids: Vec<bool> = (0..b.len()).map(|i| void(&b.coords(i)[..d])).collect();
        let f: Vec<bool> = (0..b.len()).map(|i| voids[i] || fine(&b.coords(i)[..d])).collect();
        let dist = grading::chebyshev_distance(&b, &f);
        drop(f);
        let mut level = grading::graded_levels(&b, &dist, &grading);
        drop(dist);
        grading::balance(&b, &mut level);
        let voids = if voids.iter().any(|&v| v) { voids } else { Vec::new() };
        Ok(Self::from_levels(lattice.clone(), &b, &level, voids))
    }

    /// The leaves, nodes and constraints of a balanced level map (without the `void` cells).
    fn from_levels(lattice: LatticeBox, b: &CellBox, level: &[u8], void: Vec<bool>) -> Self {
        let d = lattice.dim;
        let cells: Vec<Cell> = (0..b.len())
            .filter_map(|i| {
                let (l, o) = (level[i], b.coords(i));
                let is_void = void.get(i).copied().unwrap_or(false);
                ((0..d).all(|a| o[a] % (1 << l) == 0) && !is_void).then_some(Cell { level: l, origin: o })
            })
            .collect();
        let mut corners: Vec<(usize, u8)> = cells
            .iter()
            .flat_map(|e| (0..1usize << d).map(move |c| (e.corner(d, c), e.level)))
            .map(|(k, l)| (lattice.key(k), l))
            .collect();
        corners.sort_unstable();
        corners.dedup_by_key(|c| c.0);
        let keys: Vec<usize> = corners.iter().map(|c| c.0).collect();
        let n = lattice.n;
        let nodes = keys.iter().map(|&k| [k % n[0], (k / n[0]) % n[1], k / (n[0] * n[1])]).collect();
        let node_level = corners.iter().map(|c| c.1).collect();
        let mut mesh = GradedMesh {
            lattice,
            cells,
            keys,
            nodes,
            node_level,
            hanging: Vec::new(),
            master: Vec::new(),
            n_masters: 0,
            leaf_level: level.to_vec(),
            void,
        };
        mesh.hanging = mesh.find_hanging();
        mesh.number_masters();
        mesh
    }

    /// The hanging nodes: leaf corners at an edge midpoint or a face centre of a coarser leaf
    /// (by balance these are the only places; see the module docs), in node order.
    fn find_hanging(&self) -> Vec<Hanging> {
        let d = self.lattice.dim;
        let mut found: Vec<Option<Hanging>> = vec![None; self.keys.len()];
        for e in self.cells.iter().filter(|e| e.level > 0) {
            let half = e.side() / 2;
            // offsets 0, half, side per axis: 0 < axes at mid-side < d is the inside of an
            // edge or a face
            for code in 0..3usize.pow(d as u32) {
                let digit = |a: usize| code / 3usize.pow(a as u32) % 3;
                let mids: Vec<usize> = (0..d).filter(|&a| digit(a) == 1).collect();
                if mids.is_empty() || mids.len() == d {
                    continue;
                }
                let k = [0, 1, 2].map(|a| e.origin[a] + if a < d { digit(a) * half } else { 0 });
                let Some(j) = self.node_at(k) else { continue };
                if found[j].is_some() {
                    continue;
                }
                let w = 0.5f64.powi(mids.len() as i32);
                let masters = (0..1usize << mids.len())
                    .map(|bits| {
                        let mut km = k;
                        for (t, &a) in mids.iter().enumerate() {
                            km[a] = if bits >> t & 1 == 1 { k[a] + half } else { k[a] - half };
                        }
                        (self.node_at(km).expect("a master is a corner of the leaf"), w)
                    })
                    .collect();
                found[j] = Some(Hanging { node: j, masters });
            }
        }
        found.into_iter().flatten().collect()
    }

    /// Numbers the regular nodes (the masters) in node order.
    fn number_masters(&mut self) {
        self.master = vec![0; self.keys.len()];
        for h in &self.hanging {
            self.master[h.node] = u32::MAX;
        }
        let mut next = 0u32;
        for m in self.master.iter_mut().filter(|m| **m != u32::MAX) {
            *m = next;
            next += 1;
        }
        self.n_masters = next as usize;
    }

    /// The lattice box.
    pub fn lattice(&self) -> &LatticeBox {
        &self.lattice
    }
    /// 2 or 3.
    pub fn dim(&self) -> usize {
        self.lattice.dim
    }
    /// The leaves, in the lattice order of their origins.
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }
    /// Lattice index of every node (leaf corners), in lattice order.
    pub fn nodes(&self) -> &[[usize; 3]] {
        &self.nodes
    }
    /// Position `x0 + h k` of node `i`.
    pub fn position(&self, i: usize) -> [f64; 3] {
        let l = &self.lattice;
        [0, 1, 2].map(|a| if a < l.dim { l.x0[a] + l.h * self.nodes[i][a] as f64 } else { 0.0 })
    }
    /// The node at lattice index `k`, if `k` is a leaf corner.
    pub fn node_at(&self, k: [usize; 3]) -> Option<usize> {
        if (0..3).any(|a| k[a] >= self.lattice.n[a]) {
            return None;
        }
        self.keys.binary_search(&self.lattice.key(k)).ok()
    }
    /// Corner nodes of a leaf, in corner order (bit `a`: `+side` along axis `a`).
    pub fn cell_nodes(&self, e: &Cell) -> Vec<usize> {
        let d = self.dim();
        (0..1usize << d).map(|c| self.node_at(e.corner(d, c)).expect("leaf corners are nodes")).collect()
    }
    /// The finest level of the leaves at node `i` (0: a corner of a lattice cell of the mesh).
    pub fn node_level(&self, i: usize) -> usize {
        self.node_level[i] as usize
    }
    /// The hanging nodes and their constraints, in node order.
    pub fn hanging(&self) -> &[Hanging] {
        &self.hanging
    }
    /// Master number of node `i` (its DOFs are `d m .. d m + d` of [`GradedMesh::stiffness`]),
    /// `None` when it hangs.
    pub fn master_of(&self, i: usize) -> Option<usize> {
        Some(self.master[i]).filter(|&m| m != u32::MAX).map(|m| m as usize)
    }
    /// Number of master (regular) nodes.
    pub fn n_masters(&self) -> usize {
        self.n_masters
    }
    /// Leaves, masters and hanging nodes per level, from level 0 to the coarsest used.
    pub fn counts(&self) -> Vec<LevelCounts> {
        let top = self.cells.iter().map(|e| e.level as usize).max().unwrap_or(0);
        let mut out: Vec<LevelCounts> = (0..=top).map(|level| LevelCounts { level, ..Default::default() }).collect();
        for e in &self.cells {
            out[e.level as usize].cells += 1;
        }
        for (i, &l) in self.node_level.iter().enumerate() {
            let c = &mut out[l as usize];
            if self.master_of(i).is_some() {
                c.masters += 1;
            } else {
                c.hanging += 1;
            }
        }
        out
    }
}
