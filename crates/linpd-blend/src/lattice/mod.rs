//! The blended PD / local-elasticity model in 2D and 3D on a lattice: Algorithm A of Seleson,
//! Beneddine & Prudhomme (2013) carried to `d` dimensions for the bond-based model.
//!
//! # The model
//!
//! A blending function `beta_i` in `[0, 1]` per node (1 in the PD regions, 0 in the local zone,
//! a profile across a transition of given width). The bond-based row in force form is
//! `(A u)_i = sum_j w_ij e e^T (u_i - u_j)` (`w_ij` the bond model's weights, `V_i V_j`
//! included). As in eq. (15) each bond is split into a nonlocal share
//! `a_ij = (beta_i + beta_j) / 2` and a local share `1 - a_ij`, and the local share is written
//!
//! ```text
//! 1 - a_ij = (1 - beta_i) + (beta_i - beta_j) / 2 .
//! ```
//!
//! The first part is the same for every bond of node `i`: the whole family's local share,
//! replaced by **the local model's row** scaled by `1 - beta_i`. The second part is odd in the
//! bond's direction across a transition and vanishes where `beta` is constant on the family; it
//! is replaced by its second-order Taylor expansion, as Algorithm A does with its `SUM1`, `SUM2`:
//!
//! ```text
//! (A u)_i = sum_j a_ij w_ij e e^T (u_i - u_j)                                    nonlocal share
//!         + (1 - beta_i) (K_loc u)_i                                              local model
//!         - M1_i : grad u(x_i) - M2_i : grad grad u(x_i)                         transition terms
//! (M1_i)_abc  = sum_j s_ij e_a e_b xi_c,   (M2_i)_abcd = (1/2) sum_j s_ij e_a e_b xi_c xi_d,
//! s_ij = (beta_i - beta_j) / 2 w_ij,
//! ```
//!
//! (`u_j - u_i = grad u xi + (1/2) grad grad u : xi xi + ...` in each bond), with `grad u` and
//! `grad grad u` by second-order differences on the lattice: central where both neighbours
//! exist, one-sided three-point otherwise, mixed second derivatives as products of first
//! differences; all are exact for quadratic fields.
//!
//! # The local model
//!
//! Trilinear (bilinear in 2D) finite elements on the lattice's cells (the boxes of `2^d`
//! neighbouring nodes), full `2^d`-point Gauss quadrature, with per-cell moduli chosen so that
//! **the local energy of every affine field equals the PD energy, node by node**: the PD energy
//! of `u = G x` is `sum_i (1/2) G : D_i : G` with
//!
//! ```text
//! (D_i)_abcd = (1/2) sum_j w_ij e_a xi_b e_c xi_d        (the bond energy w (e.G xi)^2 / 2, half per end)
//! ```
//!
//! and a cell gets `C_e vol_e = sum_{corners i} D_i / n_i` (`n_i` the number of complete cells at
//! node `i`). A support node of the grid's layer (the layer stands for the body beyond it, not
//! for a free surface) counts the mirror image of each bond whose mirror partner is missing,
//! i.e. it gets the bulk `D`: rows next to a supporting layer are then exact for affine fields
//! (the patch test). In the bulk `C_e` is the PD model's elasticity tensor (`lambda = mu` in 3D and 2D
//! plane... the Cauchy relations of bond-based PD); near a free surface `D_i` sums a truncated
//! family, so the local model is as soft there as the PD model is for affine fields. Why finite
//! elements and not the Taylor expansion of the whole family with one-sided differences (the
//! literal reading of Algorithm A): that operator is not in divergence form, and at free
//! surfaces its first-moment terms `M1` are `O(w / h)`; measured on a 60 x 60 plate in tension
//! (`delta = 3h`) it made the whole plate 15 % softer than PD, where the elements, which are
//! conservative and carry the traction-free condition naturally, differ by 2 %.
//!
//! # Properties (tested in `tests/lattice_blend.rs`)
//!
//! * Where `beta = 1` on a node's family, its row is the bond model's row, bit for bit.
//! * Every row is exact for affine fields (the nonlocal share plus the transition terms give
//!   `beta_i` times the PD row, the elements give `1 - beta_i` times zero in the bulk), and rows
//!   whose node has a full family and complete cells are exact for quadratic fields (the
//!   elements' stencil with the PD's tensor is exact there): the blended rows equal the PD rows.
//! * Where `beta = 0` on the family, the row is the element row: `A` is symmetric there; the
//!   transition rows are not (the `1 - beta_i` row scaling and the Taylor terms), so the solvers
//!   see an unsymmetric `A` (GMRES or LU; see docs/solvers.md).
//! * The local model cannot hold a pre-crack, a defect or a material interface: nodes whose row
//!   has a local share must have a family with one bond factor (all weights the homogeneous
//!   weights times one number), and the cells they use must have such corners; anything else is
//!   a named error telling to cover the feature with `pd_regions`.

mod regular;
pub use regular::{regular_near_defects, regular_nodes, row_blocks};

use crate::graded_mesh::element::{add_element_row, ElementBlocks};
use crate::BlendError;
use linpd_bond::BondOperator;
use linpd_core::family::grid_stencil;
use linpd_core::sparse::Csc;
use linpd_core::{nested_dissection, AssembledModel, BondFamily, DofMap, Grid, Model, Ordering, Point};
use rayon::prelude::*;

/// How `beta` falls from 1 at a PD region's boundary to 0 at the transition's outer edge, as a
/// function of `s = distance / width` in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Profile {
    /// `1 - s`.
    Linear,
    /// `1 - (3 s^2 - 2 s^3)` (C^1 at both ends).
    Cubic,
    /// A constant `value` across the transition.
    Constant(f64),
}

impl Profile {
    /// `beta` at `s = distance / width` (`s <= 0`: inside a PD region; `s >= 1`: local).
    pub fn beta(self, s: f64) -> f64 {
        if s <= 0.0 {
            return 1.0;
        }
        if s >= 1.0 {
            return 0.0;
        }
        match self {
            Profile::Linear => 1.0 - s,
            Profile::Cubic => 1.0 - s * s * (3.0 - 2.0 * s),
            Profile::Constant(v) => v,
        }
    }
}

/// `beta` per node: 1 on the nodes in `inside`, `profile(dist / width)` elsewhere, `dist` the
/// distance to the nearest node of `inside` (searched in the lattice box of radius `width`).
pub fn beta_from_zone(grid: &Grid, inside: &[bool], width: f64, profile: Profile) -> Vec<f64> {
    let h = grid.spacing();
    // the nearest node inside, if it is within the stencil of `width` (lattice_stencil's
    // inclusion rule), by a distance transform: O(sites) whatever the width (a stencil of
    // `width / h` per node was O(n (width / h)^d): transition 100 on a 1,269-node plate ran
    // past 120 s, 1e6 aborted allocating the stencil)
    let ratio = width / h;
    let r2 = ratio * ratio * (1.0 + linpd_core::GEOMETRY_RTOL);
    squared_lattice_distances(grid, inside)
        .into_par_iter()
        .enumerate()
        .map(|(i, n2)| {
            if inside[i] {
                return 1.0;
            }
            let best = if n2 <= r2 { n2.sqrt() * h } else { f64::INFINITY };
            profile.beta(best / width)
        })
        .collect()
}

/// Per node of `grid`, the squared lattice distance `|k_j - k_i|^2` (in spacings) to the
/// nearest node `j` with `seeds[j]` (0 on a seed; infinite without seeds), over the lattice box
/// (sites removed by a body neither seed nor block): the exact Euclidean distance transform of
/// Felzenszwalb & Huttenlocher, one lower envelope of parabolas per line and axis, O(sites d).
/// The same minimum as a search over every offset, in linear time.
pub fn squared_lattice_distances(grid: &Grid, seeds: &[bool]) -> Vec<f64> {
    squared_site_distances(grid, &|site| grid.node_at_site(site).is_some_and(|j| seeds[j]))
}

/// Per node of `grid`, the squared lattice distance to the nearest site of the box that a body
/// removed (`None` on a full grid): where families are truncated by the body's boundary.
pub(crate) fn squared_distances_to_removed(grid: &Grid) -> Option<Vec<f64>> {
    (!grid.is_full()).then(|| squared_site_distances(grid, &|site| grid.node_at_site(site).is_none()))
}

/// [`squared_lattice_distances`] to the sites for which `seed(site)` holds.
fn squared_site_distances(grid: &Grid, seed: &(dyn Fn([usize; 3]) -> bool + Sync)) -> Vec<f64> {
    let c = grid.counts();
    let sites = c[0] * c[1] * c[2];
    let site_of = |s: usize| [s % c[0], (s / c[0]) % c[1], s / (c[0] * c[1])];
    let mut f: Vec<f64> =
        (0..sites).into_par_iter().map(|s| if seed(site_of(s)) { 0.0 } else { f64::INFINITY }).collect();
    let stride = [1, c[0], c[0] * c[1]];
    for a in 0..grid.dim() {
        let len = c[a];
        // the lines along axis a (one per site with k_a = 0), in parallel, written back after
        let starts: Vec<usize> = (0..sites / len).map(|k| k % stride[a] + k / stride[a] * stride[a] * len).collect();
        let lines: Vec<Vec<f64>> = starts
            .par_iter()
            .map_init(
                || (vec![0.0; len], vec![0usize; len], vec![0.0; len + 1]),
                |(line, v, z), &s| {
                    for q in 0..len {
                        line[q] = f[s + q * stride[a]];
                    }
                    let mut out = vec![0.0; len];
                    envelope(line, &mut out, v, z);
                    out
                },
            )
            .collect();
        for (&s, out) in starts.iter().zip(&lines) {
            for (q, &x) in out.iter().enumerate() {
                f[s + q * stride[a]] = x;
            }
        }
    }
    (0..grid.len())
        .into_par_iter()
        .map(|j| {
            let k = grid.site_of(j);
            f[k[0] + c[0] * (k[1] + c[1] * k[2])]
        })
        .collect()
}

/// `out[q] = min_p (q - p)^2 + f[p]` over the finite `f[p]` (infinite when there is none).
fn envelope(f: &[f64], out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let mut finite = (0..f.len()).filter(|&q| f[q].is_finite());
    let Some(first) = finite.next() else {
        out.fill(f64::INFINITY);
        return;
    };
    let meet = |q: usize, p: usize| ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
    let mut k = 0;
    (v[0], z[0], z[1]) = (first, f64::NEG_INFINITY, f64::INFINITY);
    for q in finite {
        let mut s = meet(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = meet(q, v[k]);
        }
        k += 1;
        (v[k], z[k], z[k + 1]) = (q, s, f64::INFINITY);
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        *o = (q as f64 - v[k] as f64).powi(2) + f[v[k]];
    }
}

/// Node counts of the three zones and the stored entries saved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Zones {
    /// Nodes whose row is the PD row (`beta = 1` on the node and its family).
    pub pd: usize,
    /// Nodes with both shares.
    pub transition: usize,
    /// Nodes whose row is the local model's (`beta = 0` on the node and its family).
    pub local: usize,
    /// Stored entries of the blended `A` over all DOFs.
    pub nnz: usize,
    /// Stored entries the bond model's `A` would have on the same lattice.
    pub nnz_pd: usize,
}

/// The blended model on a lattice, assembled over all DOFs (see the module docs).
#[derive(Debug, Clone)]
pub struct LatticeBlend {
    grid: Grid,
    beta: Vec<f64>,
    /// `A` over all DOFs, with the product, diagonal, restriction, asymmetry (computed once) and
    /// interaction graph of any stored stiffness.
    a: AssembledModel,
    /// The SPD companion of `A` that preconditions it: the nonlocal shares `a_ij` (symmetric)
    /// plus the elements weighted per cell by the mean `1 - beta` of their corners (an energy,
    /// so symmetric and positive semi-definite), without the transition terms.
    m: Csc,
    zones: Zones,
    /// Largest lattice offset of a coupling, per the nested dissection's reach.
    ratio: f64,
}

/// A `d x d` block row: `(node, block)` with the block row-major in a 3 x 3 array.
pub(crate) type BlockRow = Vec<(usize, [f64; 9])>;

/// Accumulates blocks of one row by node (a dense slot per node, reset after each row).
pub(crate) struct RowBuilder {
    slot: Vec<u32>,
    row: BlockRow,
}

impl RowBuilder {
    pub(crate) fn new(n: usize) -> Self {
        RowBuilder { slot: vec![u32::MAX; n], row: Vec::new() }
    }
    pub(crate) fn at(&mut self, j: usize) -> &mut [f64; 9] {
        if self.slot[j] == u32::MAX {
            self.slot[j] = self.row.len() as u32;
            self.row.push((j, [0.0; 9]));
        }
        &mut self.row[self.slot[j] as usize].1
    }
    /// The row, sorted by node, in a vector of its exact size; the builder keeps its buffer
    /// for the next row (taking the buffer itself made every row regrow from empty, ~8
    /// reallocations of up to 10 KB for a 3D row of 123 blocks).
    pub(crate) fn take(&mut self) -> BlockRow {
        for (j, _) in &self.row {
            self.slot[*j] = u32::MAX;
        }
        self.row.sort_unstable_by_key(|e| e.0);
        let row = self.row.clone();
        self.row.clear();
        row
    }
}

/// A difference stencil along one axis: `(offset, weight)` pairs.
type Stencil1 = Vec<(i64, f64)>;

impl LatticeBlend {
    /// Builds the blended model from the bond model `op` on `grid` (its `horizon`) and `beta`
    /// per node. `mirrored[i]`: node `i` stands for the body beyond it (a support in the grid's
    /// layer), so its element moduli are the bulk ones (see the module docs).
    /// `regular[i]` says node `i`'s family has one bond factor (no defect, no interface within
    /// its horizon); `None` means a homogeneous material (every node regular).
    pub fn new(
        op: &BondOperator,
        grid: &Grid,
        horizon: f64,
        beta: Vec<f64>,
        regular: Option<&[bool]>,
        mirrored: &[bool],
    ) -> Result<Self, BlendError> {
        let d = op.dim();
        let n = op.n_nodes();
        check_inputs(d, n, &beta, mirrored)?;
        let h = grid.spacing();
        let family = op.family();
        let blend_rows = BlendRows {
            op,
            grid,
            beta: &beta,
            regular,
            d_tensor: element_moduli(op, grid, &beta, mirrored),
            n_cells: (0..n).map(|i| cells_at(grid, i).count() as u8).collect(),
        };
        let (rows, m_rows) = blend_rows.assemble()?;
        let (pd, transition, local) = zone_counts(family, &beta);
        // each set of block rows goes as soon as its matrix is made (they take 80 bytes a block)
        let k = block_rows_to_csc(d, &rows);
        drop(rows);
        let m = block_rows_to_csc(d, &m_rows);
        drop(m_rows);
        let nnz_pd = d * d * (n + family.n_bonds());
        let zones = Zones { pd, transition, local, nnz: k.val().len(), nnz_pd };
        let ratio = (horizon / h).max(2.0);
        Ok(LatticeBlend {
            grid: grid.clone(),
            beta,
            a: AssembledModel::new("blend", d, op.positions().to_vec(), k),
            m,
            zones,
            ratio,
        })
    }

    /// `beta` per node.
    pub fn beta(&self) -> &[f64] {
        &self.beta
    }
    /// The zone counts and stored entries.
    pub fn zones(&self) -> Zones {
        self.zones
    }
    /// `A` over all DOFs.
    pub fn stiffness(&self) -> &Csc {
        self.a.stiffness()
    }
    /// The SPD companion `M` over all DOFs.
    pub fn companion(&self) -> &Csc {
        &self.m
    }
}

/// Checks the dimension and that `beta` (each in `[0, 1]`) and `mirrored` have one value per
/// node.
pub(crate) fn check_inputs(d: usize, n: usize, beta: &[f64], mirrored: &[bool]) -> Result<(), BlendError> {
    if d < 2 {
        return Err(BlendError::Dimension(d));
    }
    if beta.len() != n {
        return Err(BlendError::Inputs(format!("beta: {} values for {n} nodes", beta.len())));
    }
    if mirrored.len() != n {
        return Err(BlendError::Inputs(format!("mirrored: {} values for {n} nodes", mirrored.len())));
    }
    if let Some(i) = beta.iter().position(|b| !(0.0..=1.0).contains(b)) {
        return Err(BlendError::Inputs(format!("beta = {} at node {i} is not in [0, 1]", beta[i])));
    }
    Ok(())
}

/// `D_i` per node for the element moduli, only where a local share may read it (the node's
/// own row or a row sharing a cell with it has `beta < 1`); zero elsewhere.
pub(crate) fn element_moduli(op: &BondOperator, grid: &Grid, beta: &[f64], mirrored: &[bool]) -> Vec<[f64; 81]> {
    let n = op.n_nodes();
    let needs_local: Vec<bool> = (0..n).map(|i| beta[i] < 1.0).collect();
    (0..n)
        .into_par_iter()
        .map(|i| {
            if !needs_local[i] && !cell_neighbours(grid, i).any(|j| needs_local[j]) {
                return [0.0; 81];
            }
            node_moduli(op, grid, i, mirrored[i])
        })
        .collect()
}

/// `(D_i)_abcd = (1/2) sum_j w_ij e_a xi_b e_c xi_d` of node `i` (the bond energy
/// `w (e.G xi)^2 / 2`, half per end); a `layer` node counts a bond whose mirror partner is
/// missing in full (see the module docs).
pub(crate) fn node_moduli(op: &BondOperator, grid: &Grid, i: usize, layer: bool) -> [f64; 81] {
    let d = op.dim();
    let mut t = [0.0; 81];
    let k = grid.lattice_index(i);
    for (&j, &w) in op.family().neighbors(i).iter().zip(op.weights(i)) {
        let j = j as usize;
        let xi = op.bond_vector(i, j);
        let e = op.unit(i, j);
        // a layer node stands for the body beyond it: its family's missing half
        // is the mirror image of the bonds it has
        let kj = grid.lattice_index(j);
        let mirror = [0, 1, 2].map(|a| 2 * k[a] - kj[a]);
        let f = if layer && grid.node_at(mirror).is_none() { 1.0 } else { 0.5 };
        for a in 0..d {
            for b in 0..d {
                let ab = f * w * e[a] * xi[b];
                for c in 0..d {
                    for dd in 0..d {
                        t[((a * 3 + b) * 3 + c) * 3 + dd] += ab * e[c] * xi[dd];
                    }
                }
            }
        }
    }
    t
}

/// Node counts `(pd, transition, local)`: `beta = 1` on the node and its family, neither,
/// `beta = 0` on the node and its family.
pub(crate) fn zone_counts(family: &BondFamily, beta: &[f64]) -> (usize, usize, usize) {
    let (mut pd, mut transition, mut local) = (0, 0, 0);
    for i in 0..beta.len() {
        let all = |v: f64| beta[i] == v && family.neighbors(i).iter().all(|&j| beta[j as usize] == v);
        if all(1.0) {
            pd += 1;
        } else if all(0.0) {
            local += 1;
        } else {
            transition += 1;
        }
    }
    (pd, transition, local)
}

/// What the rows of `A` and of its SPD companion `M` (see `LatticeBlend::m`) read.
pub(crate) struct BlendRows<'a> {
    pub(crate) op: &'a BondOperator,
    pub(crate) grid: &'a Grid,
    pub(crate) beta: &'a [f64],
    /// Node `i`'s family has one bond factor (`None`: every node).
    pub(crate) regular: Option<&'a [bool]>,
    /// `D_i` per node (see [`element_moduli`]).
    pub(crate) d_tensor: Vec<[f64; 81]>,
    /// Complete lattice cells at each node.
    pub(crate) n_cells: Vec<u8>,
}

impl BlendRows<'_> {
    /// The block rows of `A` and of `M`, in parallel; the first error in node order.
    fn assemble(&self) -> Result<(Vec<BlockRow>, Vec<BlockRow>), BlendError> {
        let n = self.beta.len();
        type Rows = (BlockRow, BlockRow);
        let rows: Vec<Result<Rows, BlendError>> = (0..n)
            .into_par_iter()
            .map_init(|| (RowBuilder::new(n), RowBuilder::new(n)), |(rb, mb), i| self.row(i, rb, mb))
            .collect();
        Ok(rows.into_iter().collect::<Result<Vec<Rows>, _>>()?.into_iter().unzip())
    }

    fn is_regular(&self, i: usize) -> bool {
        self.regular.is_none_or(|r| r[i])
    }

    /// Node `i` with its position and `beta`, for the error messages.
    fn describe(&self, i: usize) -> String {
        let x = self.grid.position(i);
        format!("node {i} at {:?} (beta = {:.3})", &x[..self.op.dim()], self.beta[i])
    }

    /// Row `i` of `A` (nonlocal shares, transition terms, local elements scaled by
    /// `1 - beta_i`) and of `M` (nonlocal shares, elements weighted per cell).
    pub(crate) fn row(
        &self,
        i: usize,
        rb: &mut RowBuilder,
        mb: &mut RowBuilder,
    ) -> Result<(BlockRow, BlockRow), BlendError> {
        self.row_with(i, true, rb, mb)
    }

    /// Row `i` of `A` and of `M` without the nonlocal shares `a_ij w_ij e e^T`, which both
    /// rows have alike: what [`crate::GradedBlend`] stores, applying the shares from the
    /// bonds. The rows' checks are those of [`BlendRows::row`].
    pub(crate) fn rest_row(
        &self,
        i: usize,
        rb: &mut RowBuilder,
        mb: &mut RowBuilder,
    ) -> Result<(BlockRow, BlockRow), BlendError> {
        self.row_with(i, false, rb, mb)
    }

    /// [`BlendRows::row`], with the nonlocal shares when `shares`.
    fn row_with(
        &self,
        i: usize,
        shares: bool,
        rb: &mut RowBuilder,
        mb: &mut RowBuilder,
    ) -> Result<(BlockRow, BlockRow), BlendError> {
        let bi = self.beta[i];
        let s = self.nonlocal_shares(i, shares, rb, mb);
        let local = bi < 1.0;
        if (local || !s.is_empty()) && !self.is_regular(i) {
            return Err(BlendError::NotLocal {
                node: self.describe(i),
                reason: "its row has a local share but a defect or a material interface is within its horizon, \
                         which local elasticity cannot represent; extend the nonlocal region (with the transition) to \
                         keep every defect and interface more than a horizon from beta < 1"
                    .into(),
            });
        }
        if !s.is_empty() {
            transition_terms(self.op, self.grid, i, &s, rb)
                .map_err(|reason| BlendError::NotLocal { node: self.describe(i), reason })?;
        }
        if local {
            self.local_elements(i, rb)?;
        }
        self.companion_elements(i, mb);
        Ok((rb.take(), mb.take()))
    }

    /// Adds (when `add`) the nonlocal shares `a_ij w_ij e e^T (u_i - u_j)`,
    /// `a_ij = (beta_i + beta_j) / 2`, to the rows of `A` and `M`; returns the transition
    /// shares `(j, s_ij)`, `s_ij = (beta_i - beta_j) / 2 w_ij`, of the bonds with
    /// `beta_j != beta_i`.
    fn nonlocal_shares(&self, i: usize, add: bool, rb: &mut RowBuilder, mb: &mut RowBuilder) -> Vec<(usize, f64)> {
        let (op, beta, d) = (self.op, self.beta, self.op.dim());
        let bi = beta[i];
        let mut s = Vec::new();
        for (&j, &w) in op.family().neighbors(i).iter().zip(op.weights(i)) {
            let j = j as usize;
            let a_ij = 0.5 * (bi + beta[j]);
            let e = op.unit(i, j);
            if add && a_ij > 0.0 {
                for a in 0..d {
                    for b in 0..d {
                        let v = a_ij * w * e[a] * e[b];
                        rb.at(i)[a * 3 + b] += v;
                        rb.at(j)[a * 3 + b] -= v;
                        mb.at(i)[a * 3 + b] += v;
                        mb.at(j)[a * 3 + b] -= v;
                    }
                }
            }
            if beta[j] != bi {
                s.push((j, 0.5 * (bi - beta[j]) * w));
            }
        }
        s
    }

    /// Adds the local model's row `i` scaled by `1 - beta_i`: the elements of every complete
    /// cell at the node, whose corners must all be regular.
    fn local_elements(&self, i: usize, rb: &mut RowBuilder) -> Result<(), BlendError> {
        if self.n_cells[i] == 0 {
            return Err(BlendError::NotLocal {
                node: self.describe(i),
                reason: "has a local share but is the corner of no complete lattice cell (a body thinner than two \
                         nodes there): extend the nonlocal region to cover it"
                    .into(),
            });
        }
        let (d, h) = (self.op.dim(), self.grid.spacing());
        for cell in cells_at(self.grid, i) {
            if let Some(c) = cell.iter().find(|&&c| !self.is_regular(c)) {
                return Err(BlendError::NotLocal {
                    node: self.describe(i),
                    reason: format!(
                        "its local elements reach {} near a defect or a material interface; extend the nonlocal \
                         region to cover it",
                        self.describe(*c)
                    ),
                });
            }
            element_row(d, h, i, &cell, &self.d_tensor, &self.n_cells, 1.0 - self.beta[i], rb);
        }
        Ok(())
    }

    /// M: the elements weighted per cell by the mean local share of its corners.
    fn companion_elements(&self, i: usize, mb: &mut RowBuilder) {
        let (d, h) = (self.op.dim(), self.grid.spacing());
        for cell in cells_at(self.grid, i) {
            let w_e = cell.iter().map(|&c| 1.0 - self.beta[c]).sum::<f64>() / cell.len() as f64;
            if w_e > 0.0 {
                element_row(d, h, i, &cell, &self.d_tensor, &self.n_cells, w_e, mb);
            }
        }
    }
}

/// CSC over all DOFs of `d x d` block rows (one per node, each sorted by node): a counting
/// sort of the blocks by column node, in parallel over chunks of block rows, each chunk
/// writing the slots it counted; no intermediate CSR copy. (The sequential CSR-then-transpose
/// took ~4 s of a 9.8 s build of a 79k-node 3D blend, most of it first-touch page faults of
/// one thread: docs/models.md.)
pub(crate) fn block_rows_to_csc(d: usize, rows: &[BlockRow]) -> Csc {
    /// The value and row arrays, written through raw pointers by the chunks (see below).
    struct Out(*mut usize, *mut f64);
    // SAFETY: shared between the chunks only to write disjoint positions (see the fill).
    unsafe impl Sync for Out {}
    impl Out {
        /// Writes entry `p`. SAFETY: `p` in bounds and written by no other thread.
        unsafe fn put(&self, p: usize, row: usize, v: f64) {
            unsafe {
                *self.0.add(p) = row;
                *self.1.add(p) = v;
            }
        }
    }
    let n = rows.len();
    // a few chunks per thread for balance, at most 16: each holds a count per node
    let chunks = (4 * rayon::current_num_threads()).min(16);
    let chunk = n.div_ceil(chunks).max(1);
    // per chunk, its blocks in each column node; then (in place) its first slot there
    let mut slot: Vec<Vec<usize>> = rows
        .par_chunks(chunk)
        .map(|rs| {
            let mut c = vec![0usize; n];
            for &(j, _) in rs.iter().flatten() {
                c[j] += 1;
            }
            c
        })
        .collect();
    let mut col_ptr = Vec::with_capacity(d * n + 1);
    col_ptr.push(0usize);
    for j in 0..n {
        let mut blocks = 0;
        for c in slot.iter_mut() {
            let k = c[j];
            c[j] = blocks;
            blocks += k;
        }
        // each of node j's d columns holds d entries of each of its blocks
        for _ in 0..d {
            col_ptr.push(col_ptr.last().unwrap() + blocks * d);
        }
    }
    let nnz = *col_ptr.last().unwrap();
    let (mut row_idx, mut val) = (vec![0usize; nnz], vec![0.0; nnz]);
    let out = Out(row_idx.as_mut_ptr(), val.as_mut_ptr());
    rows.par_chunks(chunk).zip(slot.par_iter_mut()).enumerate().for_each(|(k, (rs, next))| {
        for (offset, row) in rs.iter().enumerate() {
            let i = k * chunk + offset;
            for (j, blk) in row {
                let s = next[*j];
                next[*j] += 1;
                for b in 0..d {
                    let p0 = col_ptr[d * j + b] + s * d;
                    for a in 0..d {
                        // SAFETY: block slot `s` of column node `j` belongs to this chunk alone
                        // (the chunks' counts were turned into disjoint slot ranges above), each
                        // row has node `j` once, and `p0 + a < col_ptr[d j + b + 1] <= nnz`.
                        unsafe { out.put(p0 + a, d * i + a, blk[a * 3 + b]) };
                    }
                }
            }
        }
    });
    // Slots run over the chunks in order and over each chunk's rows in order: the rows of
    // every column ascend, as faer's CSC requires (checked by `new_checked`).
    Csc::new(faer::sparse::SymbolicSparseColMat::new_checked(d * n, d * n, col_ptr, None, row_idx), val)
}

/// The complete lattice cells with node `i` as a corner: each as its `2^d` corner nodes in the
/// order of the bits of the corner number (bit `a` set: `+1` along axis `a`).
pub(crate) fn cells_at(grid: &Grid, i: usize) -> impl Iterator<Item = Vec<usize>> + '_ {
    let d = grid.dim();
    let k = grid.lattice_index(i);
    (0..1usize << d).filter_map(move |lower| {
        // the cell whose lowest corner is k - (bits of `lower`)
        let base: [i64; 3] = [0, 1, 2].map(|a| if a < d && lower >> a & 1 == 1 { k[a] - 1 } else { k[a] });
        (0..1usize << d)
            .map(|c| grid.node_at([0, 1, 2].map(|a| if a < d && c >> a & 1 == 1 { base[a] + 1 } else { base[a] })))
            .collect::<Option<Vec<usize>>>()
    })
}

/// The nodes sharing a complete cell with `i` (`i` included).
fn cell_neighbours(grid: &Grid, i: usize) -> impl Iterator<Item = usize> + '_ {
    cells_at(grid, i).flatten()
}

/// Adds `scale` times row `i` of the element matrix of `cell` (corner nodes in bit order).
#[allow(clippy::too_many_arguments)]
fn element_row(
    d: usize,
    h: f64,
    i: usize,
    cell: &[usize],
    d_tensor: &[[f64; 81]],
    n_cells: &[u8],
    scale: f64,
    rb: &mut RowBuilder,
) {
    // C_e vol_e = sum over corners of D / n_cells
    let mut e = [0.0; 81];
    for &c in cell {
        let f = 1.0 / n_cells[c] as f64;
        for (x, y) in e.iter_mut().zip(&d_tensor[c]) {
            *x += f * y;
        }
    }
    let r = cell.iter().position(|&c| c == i).expect("i is a corner");
    /// The row builder's blocks of the cell's corners.
    struct Corners<'a, 'b>(&'a [usize], &'b mut RowBuilder);
    impl ElementBlocks for Corners<'_, '_> {
        fn block(&mut self, l: usize) -> &mut [f64; 9] {
            self.1.at(self.0[l])
        }
    }
    add_element_row(d, h, &e, r, scale, &mut Corners(cell, rb));
}

/// First and second difference stencils of node `i` along axis `c` (offsets in lattice steps,
/// weights with `1/h` and `1/h^2`): central where both neighbours exist, else one-sided over
/// three nodes. `Err` when neither fits.
fn axis_stencils(grid: &Grid, i: usize, c: usize) -> Result<(Stencil1, Stencil1), String> {
    let h = grid.spacing();
    let k = grid.lattice_index(i);
    let has = |o: i64| {
        let mut kk = k;
        kk[c] += o;
        grid.node_at(kk).is_some()
    };
    if has(-1) && has(1) {
        return Ok((
            vec![(-1, -0.5 / h), (1, 0.5 / h)],
            vec![(-1, 1.0 / (h * h)), (0, -2.0 / (h * h)), (1, 1.0 / (h * h))],
        ));
    }
    for s in [1i64, -1] {
        if has(s) && has(2 * s) {
            let sf = s as f64;
            return Ok((
                vec![(0, -1.5 * sf / h), (s, 2.0 * sf / h), (2 * s, -0.5 * sf / h)],
                vec![(0, 1.0 / (h * h)), (s, -2.0 / (h * h)), (2 * s, 1.0 / (h * h))],
            ));
        }
    }
    Err(format!(
        "its transition terms need a difference along axis {c}, but the lattice has fewer than three nodes in a row \
         there; widen pd_regions or the body"
    ))
}

/// Adds `-M1_i : grad u - M2_i : grad grad u` for the transition shares `s` = `(j, s_ij)`.
fn transition_terms(
    op: &BondOperator,
    grid: &Grid,
    i: usize,
    s: &[(usize, f64)],
    rb: &mut RowBuilder,
) -> Result<(), String> {
    let d = op.dim();
    let mut m1 = [0.0; 27];
    let mut m2 = [0.0; 81];
    for &(j, sij) in s {
        let xi = op.bond_vector(i, j);
        let e = op.unit(i, j);
        for a in 0..d {
            for b in 0..d {
                let ab = sij * e[a] * e[b];
                for c in 0..d {
                    m1[(a * 3 + b) * 3 + c] += ab * xi[c];
                    for dd in 0..d {
                        m2[((a * 3 + b) * 3 + c) * 3 + dd] += 0.5 * ab * xi[c] * xi[dd];
                    }
                }
            }
        }
    }
    let stencils: Vec<(Stencil1, Stencil1)> = (0..d).map(|c| axis_stencils(grid, i, c)).collect::<Result<_, _>>()?;
    let k = grid.lattice_index(i);
    let node = |off: [i64; 3]| -> Result<usize, String> {
        grid.node_at([k[0] + off[0], k[1] + off[1], k[2] + off[2]]).ok_or_else(|| {
            format!(
                "its transition terms need the node at lattice offset {:?}, which the body lacks; widen pd_regions",
                &off[..d]
            )
        })
    };
    let along = |c: usize, o: i64| {
        let mut off = [0i64; 3];
        off[c] = o;
        off
    };
    // coefficient of u_{node, b} in row component a: -(M1_abc g^c + M2_abcd h^cd)
    for c in 0..d {
        for &(o, wgt) in &stencils[c].0 {
            let j = node(along(c, o))?;
            let blk = rb.at(j);
            for a in 0..d {
                for b in 0..d {
                    blk[a * 3 + b] -= m1[(a * 3 + b) * 3 + c] * wgt;
                }
            }
        }
        for dd in 0..d {
            if c == dd {
                for &(o, wgt) in &stencils[c].1 {
                    let j = node(along(c, o))?;
                    let blk = rb.at(j);
                    for a in 0..d {
                        for b in 0..d {
                            blk[a * 3 + b] -= m2[((a * 3 + b) * 3 + c) * 3 + c] * wgt;
                        }
                    }
                }
            } else {
                for &(o1, w1) in &stencils[c].0 {
                    for &(o2, w2) in &stencils[dd].0 {
                        let mut off = along(c, o1);
                        off[dd] += o2;
                        let j = node(off)?;
                        let blk = rb.at(j);
                        for a in 0..d {
                            for b in 0..d {
                                blk[a * 3 + b] -= m2[((a * 3 + b) * 3 + c) * 3 + dd] * w1 * w2;
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// `A`'s own methods are those of the stored matrix ([`AssembledModel`]); the blend adds the
/// lattice ordering, its SPD companion and no block rows (its energy is not defined: `A` is not
/// symmetric).
impl Model for LatticeBlend {
    fn kind(&self) -> &'static str {
        "blend"
    }
    fn dim(&self) -> usize {
        self.a.dim()
    }
    fn n_nodes(&self) -> usize {
        self.a.n_nodes()
    }
    fn position(&self, i: usize) -> Point {
        self.a.position(i)
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.a.for_each_partner(i, f)
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        self.a.apply(u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        self.a.diagonal()
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        self.a.assemble_free(dofs)
    }
    /// That of the full `A` (a bound for `A_ff`).
    fn asymmetry(&self, dofs: &DofMap) -> f64 {
        self.a.asymmetry(dofs)
    }
    /// Nested dissection over the bond stencil (the elements' and the differences' couplings
    /// reach at most two lattice steps along an axis, inside it for `delta >= 2h`).
    fn ordering(&self, dofs: &DofMap) -> Ordering {
        let stencil = grid_stencil(&self.grid, self.ratio);
        Ordering::NestedDissection(nested_dissection(&self.grid, &stencil, dofs))
    }
    /// The energy form `M` (see the field's docs): always SPD on a supported body, unlike the
    /// symmetric part of `A`, which was indefinite on a plate with a hole (its multigrid and
    /// Cholesky setups failed).
    fn spd_approximation(&self, dofs: &DofMap) -> Option<linpd_core::SpdApproximation> {
        Some(linpd_core::SpdApproximation {
            matrix: linpd_core::sparse::restrict_to_free(&self.m, dofs),
            kind: linpd_core::SpdApproximationKind::EnergyForm,
        })
    }
    fn matrix_free_unavailable(&self) -> Option<&'static str> {
        Some("the blended model is assembled")
    }
}

#[cfg(test)]
mod distance_tests {
    use super::*;
    use linpd_core::Placement;

    /// The distance transform equals the minimum over every lattice offset of a brute-force
    /// search, on a 2D grid with layers and a hole (removed sites neither seed nor block) and
    /// on a 3D box; no seed gives infinity.
    #[test]
    fn distance_transform_matches_brute_force() {
        let g2 = Grid::new(&[0.0, 0.0], &[1.0, 0.6], 0.05, 0.1, Placement::Vertex).unwrap();
        let hole = |x: &Point| (x[0] - 0.5).powi(2) + (x[1] - 0.3).powi(2) > 0.02;
        let g3 = Grid::new(&[0.0, 0.0, 0.0], &[0.5, 0.4, 0.3], 0.05, 0.0, Placement::Vertex).unwrap();
        for g in [g2.with_body(hole).unwrap(), g3] {
            let seeds: Vec<bool> = (0..g.len()).map(|i| (i * 7919) % 97 == 0).collect();
            let d = squared_lattice_distances(&g, &seeds);
            for i in 0..g.len() {
                let k = g.lattice_index(i);
                let brute = (0..g.len())
                    .filter(|&j| seeds[j])
                    .map(|j| {
                        let m = g.lattice_index(j);
                        (0..3).map(|a| ((k[a] - m[a]) as f64).powi(2)).sum::<f64>()
                    })
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(d[i], brute, "node {i}");
            }
            assert!(squared_lattice_distances(&g, &vec![false; g.len()]).iter().all(|x| x.is_infinite()));
        }
    }
}
