//! The 2D/3D blended model with a graded local mesh (issue #31): Algorithm A's rows
//! ([`crate::lattice`]) on the fine lattice where the model is nonlocal, and the elements of a
//! [`GradedMesh`] (cells of side `h 2^l`, hanging nodes eliminated) where it is local.
//!
//! # Unknowns
//!
//! The unknowns are the masters of the graded mesh: every lattice node in its level-0 cells,
//! and the regular corners of its coarse cells. The level-0 cells ("fine") are those with a
//! corner within `r_F = delta + max(delta, 2 h) + 2 h` of a node with `beta > 0`: a node `i`
//! whose row has a nonlocal share or transition terms (set `R`: `beta_i > 0` or a family member
//! with `beta_j > 0`, so within `delta` of `beta > 0`) reads nodes up to `max(delta, 2 h)`
//! away (its family, its cells, its difference stencils), and all of these are then corners of
//! level-0 cells, never hanging (grading keeps at least one level-0 cell between the fine
//! cells and a coarse one). The cells with a corner in the grid's layer are fine too: the
//! layer's element moduli are not the bulk's (its outermost nodes have fewer cells, its corner
//! supports count half the bulk's bonds), and a coarse cell averaging them into the body's
//! would leave forces on the body nodes beside it under an affine field (4.1e-5 of `|A| |u|`
//! with cells of `4h` reaching the layer's corner; 4.7e-3 when the outermost nodes' `D_c` were
//! also spread over their few cells).
//! So are the cells within a horizon (plus a cell) of the box's faces: families are truncated
//! there, so the element moduli soften, and a coarse cell would average that away
//! ([`FreeFaces::Lattice`], the default). With [`FreeFaces::Bulk`] the faces are graded as the
//! bulk and their coarse cells take the bulk's moduli: classical elasticity up to the face
//! (tested: the forces of an affine field on a face's masters sum to `C eps` times its area,
//! `C` from PD's energy at an interior node; the lattice's faces carry 21 % less in 2D, 19 %
//! in 3D). It is the choice for scenes whose question is far from the faces (a crack in a
//! block: the 3D bands of level-0 cells at the faces are most of the unknowns otherwise). And the
//! cells at the nodes the caller must keep (the scene's constrained nodes: a constraint on a
//! node a coarse cell interpolates would be lost).
//!
//! # Bodies
//!
//! On a grid a body cut (holes, notches, any shape in the box) the level-0 cells with a corner
//! outside the body are no elements ([`GradedMesh::with_voids`]), as the lattice blend uses
//! complete cells only, and the cells within a horizon and a spacing of a removed site stay on
//! the lattice (families are truncated there as at the box's faces). A body node whose cells
//! are all incomplete (a wall or spike one node thin) is in no leaf: it is an unknown of its
//! own, after the mesh's masters, with Algorithm A's row (which names it as the lattice blend
//! does when that row would need a local share), and `P` keeps it as it is.
//!
//! # What is built: the window
//!
//! Only the nodes within `max(delta, sqrt(d) h)` of a corner of a level-0 cell (the window, a
//! sub-grid of the lattice box) get bonds and element moduli `D_i`: the fine cells' moduli
//! read their corners' whole families and cell counts, and the rows of `R` read no farther
//! than their own level-0 cells. A coarse leaf covers lattice nodes farther than `r_F` from
//! `beta > 0`, a horizon and a spacing from the box's faces, off the layer and away from
//! defects and interfaces (`regular`): every one of its lattice cells has corners with whole,
//! regular families, so its `C_e vol_e` is the bulk `D` of the homogeneous material, taken
//! once from a small box of the same spacing, and `C_E = D / h^d` whatever the leaf's level.
//! What the whole lattice costs is then a few bytes a node (`beta`, two distance transforms,
//! flags) and the mesh's leaf levels; the bonds, moduli and rows scale with the fine region.
//! With phases a coarse leaf averages its lattice cells' moduli (below), so the window is the
//! whole lattice.
//!
//! # Rows
//!
//! * For a master at a node of `R`: its row of Algorithm A on the lattice, unchanged, its
//!   columns renumbered to masters.
//! * For any other master: its row of `K_M = T^T K T`, the graded mesh's stiffness
//!   ([`GradedMesh::stiffness`]). Where the master's cells are level-0 cells this is the
//!   lattice model's local row with `beta_i = 0` (the same element routine and moduli), so
//!   without grading the operator equals [`crate::LatticeBlend`]'s.
//!
//! The SPD companion `M` takes the companion rows of `R` and `K_M`'s rows elsewhere.
//!
//! Neither is stored whole: a row is its nonlocal shares, listed once for both, plus a stored
//! rest of at most `3^d` blocks (module `operator`); GMRES runs on `A`'s apply and
//! the multigrid on `M`'s block rows ([`linpd_core::Model::multigrid_companion`]).
//!
//! # Element moduli of a coarse cell
//!
//! A lattice cell `e` has `C_e vol_e = sum_{corners c} D_c / n_c` ([`crate::lattice`]); a
//! coarse cell `E` gets `C_E vol_E = sum_{lattice cells e in E} C_e vol_e`: the energy of an
//! affine field on `E` is the sum of its lattice cells' energies, so the local model's
//! energy equivalence with PD for affine fields holds for the coarse cells too. In a
//! homogeneous bulk every `C_e` is the PD model's tensor and so is `C_E` (coarse cells stay a
//! horizon and a spacing from the box's faces, whose softened cells they would average); a
//! cell over several phases gets the volume average of
//! their tensors (the Voigt bound: stiffer than the lattice's elements for a field that is not
//! affine there). Material interfaces and defects are PD features of `"auto"` zones, so coarse
//! cells are single-phase in those scenes.
//!
//! # Loads and output
//!
//! Forces given on lattice nodes reach the masters as `P^T f` and the solution is drawn on
//! every lattice node as `P u_M` ([`GradedMesh::interpolation_row`]).

mod fields;
mod operator;

use crate::graded_mesh::{Cell, GradedMesh, Grading, LatticeBox};
use crate::lattice::{
    cells_at, element_moduli, node_moduli, squared_lattice_distances, BlendRows, BlockRow, RowBuilder,
};
use crate::{BlendError, Zones};
use linpd_bond::BondOperator;
use linpd_core::family::lattice_stencil;
use linpd_core::{Grid, Material, Micromodulus, Point, GEOMETRY_RTOL};
use operator::{BlockCsr, Shares};
use rayon::prelude::*;

/// The bond model a graded blend is built from: [`GradedBlend::new`] builds its operator on
/// the window of the lattice its rows read (see the module docs), not on the whole box.
#[derive(Debug, Clone, Copy)]
pub struct Bond<'a> {
    /// The horizon `delta`.
    pub horizon: f64,
    /// The micromodulus (kernel, normalization, modulus).
    pub micromodulus: &'a Micromodulus,
    /// Phases, bond rule and defects.
    pub material: &'a Material,
}

/// What the cells at the lattice box's free faces model (`model.local_mesh.free_faces`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FreeFaces {
    /// The cells within a horizon and a spacing of the faces stay on the lattice, with the
    /// moduli of their truncated families (PD's soft skin), as the lattice blend has them.
    #[default]
    Lattice,
    /// The cells at the faces are graded as in the bulk, and a coarse one takes the bulk
    /// moduli: classical elasticity up to the face, without PD's skin (what a surface
    /// correction aims at). Level-0 cells keep the lattice's moduli. Homogeneous materials
    /// only.
    Bulk,
}

/// The graded local mesh of [`GradedBlend::new`]: its grading and what its cells at the free
/// faces model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalMesh {
    /// Cell sizes and layers per size.
    pub grading: Grading,
    /// The cells at the box's free faces.
    pub free_faces: FreeFaces,
}

impl LocalMesh {
    /// `FreeFaces::Bulk` needs a material without phases.
    fn check(&self, homogeneous: bool) -> Result<(), BlendError> {
        if self.free_faces == FreeFaces::Bulk && !homogeneous {
            return Err(BlendError::BulkFacesWithPhases);
        }
        Ok(())
    }
}

/// The blended model on a lattice with a graded local mesh over the masters' DOFs, applied
/// from its bonds and stored rests
/// (see the module docs).
#[derive(Debug, Clone)]
pub struct GradedBlend {
    mesh: GradedMesh,
    /// The lattice node of every master: the mesh's masters, then the extra nodes.
    master_node: Vec<usize>,
    /// The lattice nodes of no leaf (all their cells void: a body thinner than a cell there),
    /// ascending; masters `mesh.n_masters()..` in this order, with Algorithm A's rows.
    extra: Vec<usize>,
    /// The masters' positions.
    positions: Vec<Point>,
    /// The nonlocal shares `N` of `A` and `M`, listed per row (`graded_blend::operator`).
    shares: Shares,
    /// The rest of `A`'s rows: Algorithm A's without the shares for the masters of `R` and
    /// the extra nodes, `K_M`'s for the others.
    rest_a: BlockCsr,
    /// The rest of `M`'s rows for the masters of `R` and the extra nodes (the companion's
    /// elements); empty for the others, whose `M` row is `K_M`'s, in `rest_a`.
    rest_m: BlockCsr,
    /// `max |A - A^T| / max |A|` over all DOFs (see `graded_blend::operator`).
    asymmetry: f64,
    /// The nodes whose bonds were built (the window, a sub-grid of the lattice box) and the
    /// bond operator on them.
    window: Grid,
    op: BondOperator,
    zones: Zones,
    estimate: f64,
}

impl GradedBlend {
    /// The blended model of [`crate::LatticeBlend::new`] with its local zone on a mesh graded
    /// by `grading` away from the nonlocal rows, on the lattice `grid` (a full box or a body);
    /// `beta`, `regular` (`None`: every node), `mirrored` and `keep` have one value per node of
    /// it.
    /// `keep[i]`: node `i` must be an unknown (a constrained node: a constraint on a node that a
    /// coarse cell interpolates would be lost), so the cells at it stay on the lattice.
    /// `regular[i] == false` (a defect or an interface within the node's horizon) keeps its
    /// cells on the lattice too, where its rows are checked as the lattice blend's are.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        bond: Bond<'_>,
        grid: &Grid,
        beta: Vec<f64>,
        regular: Option<&[bool]>,
        mirrored: &[bool],
        keep: &[bool],
        local: LocalMesh,
    ) -> Result<Self, BlendError> {
        let (d, n, h, horizon) = (grid.dim(), grid.len(), grid.spacing(), bond.horizon);
        crate::lattice::check_inputs(d, n, &beta, mirrored)?;
        if keep.len() != n || regular.is_some_and(|r| r.len() != n) {
            return Err(BlendError::Inputs(format!("keep or regular flags not one per node of {n}")));
        }
        let ratio = horizon / h;
        // with phases a coarse cell sums its lattice cells' moduli, which needs every node's
        // bonds; otherwise they are the bulk's (see the module docs)
        let homogeneous = bond.material.phases.is_empty();
        local.check(homogeneous)?;
        let (in_r, zones, mesh) = layout(grid, &beta, regular, keep, horizon, local)?;
        // the nodes of no leaf: unknowns of their own (see the module docs)
        let extra: Vec<usize> = (0..n)
            .into_par_iter()
            .filter(|&i| {
                let k = grid.site_of(i);
                mesh.leaf_at(k).is_none() && mesh.node_at(k).is_none()
            })
            .collect();
        let window: Vec<bool> = if homogeneous { window_nodes(grid, &mesh, &extra, ratio) } else { vec![true; n] };
        let n_window = window.iter().filter(|&&w| w).count();
        let estimate = peak_bytes(grid, n_window, lattice_stencil(d, ratio).len(), &mesh, extra.len(), &in_r);
        linpd_core::memory::check(
            format!(
                "the graded blend ({n} lattice nodes, {n_window} of them with their bonds and element moduli, {} \
                 masters with their rows)",
                mesh.n_masters()
            ),
            estimate,
            "use a larger max_cell or fewer cells_per_level, or a coarser spacing",
        )?;

        let sub = if homogeneous { grid.with_nodes(&window)? } else { grid.clone() };
        drop(window);
        let op = BondOperator::on_grid(&sub, horizon, bond.micromodulus, bond.material)?;
        // node of the lattice of every node of the window, and the other way round
        let full_of: Vec<usize> = (0..sub.len())
            .map(|w| grid.node_at(sub.lattice_index(w)).expect("the window is a sub-grid of the lattice"))
            .collect();
        let mut sub_of = vec![u32::MAX; n];
        for (w, &i) in full_of.iter().enumerate() {
            sub_of[i] = w as u32;
        }
        let pick = |v: &[bool]| -> Vec<bool> { full_of.iter().map(|&i| v[i]).collect() };
        let master_node: Vec<usize> = (0..mesh.nodes().len())
            .filter(|&g| mesh.master_of(g).is_some())
            .map(|g| grid.node_at_site(mesh.nodes()[g]).expect("a leaf's corners are nodes"))
            .chain(extra.iter().copied())
            .collect();
        let mut master_of_window = vec![u32::MAX; sub.len()];
        for (m, &i) in master_node.iter().enumerate() {
            if sub_of[i] != u32::MAX {
                master_of_window[sub_of[i] as usize] = m as u32;
            }
        }
        // Algorithm A's rows: the masters of R and the extra nodes
        let window_of: Vec<u32> = master_node
            .iter()
            .enumerate()
            .map(|(m, &i)| if in_r[i] || m >= mesh.n_masters() { sub_of[i] } else { u32::MAX })
            .collect();
        // a bond reaches `ratio` lattice steps, and no farther than across the window (a cap
        // on the unit vectors' table for a horizon of many spacings on a small window)
        let across = sub.counts().iter().max().map_or(0.0, |&c| c as f64 - 1.0);
        let reach = (ratio.ceil() + 1.0).min(across) as i32;
        let unkept = |w: usize, j: usize| {
            BlendError::Invalid(format!(
                "the row of lattice node {} reads node {}, which the graded mesh does not keep",
                full_of[w], full_of[j]
            ))
        };
        let beta_w = full_of.iter().map(|&i| beta[i]).collect();
        drop(beta);
        let shares =
            Shares::new(&op, window_of, master_of_window, beta_w, reach, ROW_CHUNK).map_err(|(w, j)| unkept(w, j))?;
        let regular_w = regular.map(pick);
        let mirrored_w = pick(mirrored);
        let rows = BlendRows {
            op: &op,
            grid: &sub,
            beta: &shares.beta,
            regular: regular_w.as_deref(),
            d_tensor: element_moduli(&op, &sub, &shares.beta, &mirrored_w),
            n_cells: (0..sub.len()).map(|w| cells_at(&sub, w).count() as u8).collect(),
        };
        let bulk = if homogeneous { Some(bulk_moduli(bond, grid)?) } else { None };
        let moduli = |e: &Cell| match (&bulk, e.level) {
            (Some(c), 1..) => c.map(|x| x / h.powi(d as i32)),
            _ => cell_moduli(&sub, &sub_of, grid, &rows, e, h),
        };
        let k_rows = mesh.row_assembler();
        let (rest_a, rest_m) = rests(d, &rows, &shares, &k_rows, &moduli, &unkept)?;
        drop(k_rows);
        drop(rows);
        let positions: Vec<Point> = master_node.iter().map(|&i| grid.position(i)).collect();
        let mut graded = GradedBlend {
            mesh,
            master_node,
            extra,
            positions,
            shares,
            rest_a,
            rest_m,
            asymmetry: 0.0,
            window: sub,
            op,
            zones,
            estimate,
        };
        let (blocks, max_a) = graded.count_and_max();
        graded.asymmetry = graded.full_asymmetry(max_a);
        graded.zones.nnz = blocks * d * d;
        Ok(graded)
    }

    /// The estimate of the peak bytes of building and solving this model (checked against the
    /// available memory once the mesh was known, before the rows were built; see `peak_bytes`).
    pub fn memory_estimate(&self) -> f64 {
        self.estimate
    }

    /// The nodes whose bonds were built (a sub-grid of the lattice box: the level-0 cells and
    /// a horizon around them; the whole box with phases) and the bond operator on them, whose
    /// families are whole for every node of a level-0 cell.
    pub fn window(&self) -> (&Grid, &BondOperator) {
        (&self.window, &self.op)
    }

    /// Bytes of the stored rests of `A` and `M` (columns, row pointers and the distinct
    /// rows' values; see `graded_blend::operator`).
    pub fn stored_bytes(&self) -> usize {
        self.rest_a.bytes() + self.rest_m.bytes()
    }

    /// Bytes of the lists of the nonlocal shares (16 a share; see `graded_blend::operator`).
    pub fn share_bytes(&self) -> usize {
        self.shares.list_bytes()
    }

    /// The graded mesh.
    pub fn mesh(&self) -> &GradedMesh {
        &self.mesh
    }
    /// The lattice node of every master (the unknowns' nodes, in unknown order).
    pub fn master_nodes(&self) -> &[usize] {
        &self.master_node
    }
    /// The zone counts (over the lattice nodes) and the entries of `A` (over the masters,
    /// the stored rests' and the listed shares' merged) against the bond model's on the whole lattice.
    pub fn zones(&self) -> Zones {
        self.zones
    }

    /// The lattice nodes of no leaf (their cells all void), ascending: masters
    /// `mesh().n_masters()..` in this order.
    pub fn extra_nodes(&self) -> &[usize] {
        &self.extra
    }

    /// The master at lattice node `i` of `grid` (`None`: a hanging node, or inside a coarse
    /// leaf).
    pub fn master_at(&self, grid: &Grid, i: usize) -> Option<usize> {
        match self.extra.binary_search(&i) {
            Ok(x) => Some(self.mesh.n_masters() + x),
            Err(_) => self.mesh.node_at(grid.site_of(i)).and_then(|g| self.mesh.master_of(g)),
        }
    }

    /// Row `i` of `P` for lattice node `i` of `grid`: `(master, weight)` (`u_i = sum w u_m`;
    /// a force `f` at node `i` is `w f` on each master).
    pub fn interpolation(&self, grid: &Grid, i: usize) -> Vec<(usize, f64)> {
        self.p_row(grid, i)
    }

    /// `P^T v` for one value `value(i)` per lattice node `i` of `grid`, without a lattice-sized
    /// array (e.g. the masters' shares of the nodes' volumes), leaf by leaf
    /// ([`GradedMesh::restrict_values`]), the extra nodes their own.
    pub fn restrict_scalar(&self, grid: &Grid, value: &(dyn Fn(usize) -> f64 + Sync)) -> Vec<f64> {
        let mut out = self.mesh.restrict_values(&|k| grid.node_at_site(k).map_or(0.0, value));
        out.extend(self.extra.iter().map(|&i| value(i)));
        out
    }

    /// Row `i` of `P` for lattice node `i` of `grid`: `(master, weight)`.
    fn p_row(&self, grid: &Grid, i: usize) -> Vec<(usize, f64)> {
        match self.extra.binary_search(&i) {
            Ok(x) => vec![(self.mesh.n_masters() + x, 1.0)],
            Err(_) => self.mesh.interpolation_row(grid.site_of(i)),
        }
    }

    /// `u = P u_M` on every node of `grid` (the lattice the model was built on), `d` values per
    /// node (see the module docs).
    pub fn expand(&self, grid: &Grid, u_master: &[f64]) -> Vec<f64> {
        let d = self.mesh.dim();
        assert_eq!(u_master.len(), d * self.master_node.len(), "one value per master DOF");
        let mut u = vec![0.0; d * grid.len()];
        u.par_chunks_mut(d).enumerate().for_each(|(i, ui)| ui.copy_from_slice(&self.u_at(grid, i, u_master)[..d]));
        u
    }

    /// `u_i = (P u_M)_i` at lattice node `i` of `grid` (the first `d` values).
    pub fn u_at(&self, grid: &Grid, i: usize, u_master: &[f64]) -> [f64; 3] {
        let d = self.mesh.dim();
        let mut u = [0.0; 3];
        for (m, w) in self.p_row(grid, i) {
            for a in 0..d {
                u[a] += w * u_master[d * m + a];
            }
        }
        u
    }

    /// `P^T f`: forces `f` on the nodes of `grid` (`d` per node) as consistent forces on the
    /// masters.
    pub fn restrict(&self, grid: &Grid, f: &[f64]) -> Vec<f64> {
        let d = self.mesh.dim();
        assert_eq!(f.len(), d * grid.len(), "one value per lattice DOF");
        let mut out = vec![0.0; d * self.master_node.len()];
        for i in 0..grid.len() {
            if f[d * i..d * i + d].iter().all(|&x| x == 0.0) {
                continue;
            }
            for (m, w) in self.p_row(grid, i) {
                for a in 0..d {
                    out[d * m + a] += w * f[d * i + a];
                }
            }
        }
        out
    }
}

/// The stored rests of `A` and `M` over the masters (see `graded_blend::operator`): for a master of
/// `R` or an extra node (window node `shares.window_of[m]`) Algorithm A's rows without the
/// shares, renumbered to masters; for the others its row of `K_M` (`k_rows`, the leaves'
/// moduli from `moduli`), in `A`'s rest only. Built in chunks of [`ROW_CHUNK`] masters, each
/// stored before the next. `unkept(w, j)`: the error for window node `w`'s row reading window
/// node `j`, which is no master.
fn rests(
    d: usize,
    rows: &BlendRows,
    shares: &Shares,
    k_rows: &crate::graded_mesh::RowAssembler,
    moduli: &(dyn Fn(&Cell) -> [f64; 81] + Sync),
    unkept: &(dyn Fn(usize, usize) -> BlendError + Sync),
) -> Result<(BlockCsr, BlockCsr), BlendError> {
    let to_master = |row: BlockRow, w: usize| -> Result<BlockRow, BlendError> {
        row.into_iter()
            .map(|(j, b)| match shares.master_of[j] {
                u32::MAX => Err(unkept(w, j)),
                m => Ok((m as usize, b)),
            })
            .collect()
    };
    let (n_sub, n_masters) = (shares.master_of.len(), shares.window_of.len());
    let (mut rest_a, mut rest_m) = (BlockCsr::new(d), BlockCsr::new(d));
    for start in (0..n_masters).step_by(ROW_CHUNK) {
        let end = (start + ROW_CHUNK).min(n_masters);
        let built: Vec<Result<(BlockRow, BlockRow), BlendError>> = (start..end)
            .into_par_iter()
            .map_init(
                || (RowBuilder::new(n_sub), RowBuilder::new(n_sub)),
                |(rb, mb), m| match shares.window_of[m] {
                    u32::MAX => Ok((k_rows.stiffness_row(m, moduli), Vec::new())),
                    w => {
                        let w = w as usize;
                        let (ra, rm) = rows.rest_row(w, rb, mb)?;
                        Ok((to_master(ra, w)?, to_master(rm, w)?))
                    }
                },
            )
            .collect();
        let (a_rows, m_rows): (Vec<BlockRow>, Vec<BlockRow>) =
            built.into_iter().collect::<Result<Vec<_>, _>>()?.into_iter().unzip();
        rest_a.extend(&a_rows);
        rest_m.extend(&m_rows);
    }
    rest_a.finish();
    rest_m.finish();
    Ok((rest_a, rest_m))
}

/// The rows of `R` (nodes with a nonlocal share or transition terms), the zone counts and the
/// graded mesh whose level-0 cells are those at the nodes that must stay on the lattice (see
/// the module docs).
fn layout(
    grid: &Grid,
    beta: &[f64],
    regular: Option<&[bool]>,
    keep: &[bool],
    horizon: f64,
    local: LocalMesh,
) -> Result<(Vec<bool>, Zones, GradedMesh), BlendError> {
    let (d, n, h) = (grid.dim(), grid.len(), grid.spacing());
    let ratio = horizon / h;
    // the family's inclusion rule (lattice_stencil): |k_j - k_i|^2 <= ratio^2 (1 + rtol)
    let in_family = ratio * ratio * (1.0 + GEOMETRY_RTOL);
    let nonlocal: Vec<bool> = beta.iter().map(|&b| b > 0.0).collect();
    let to_nonlocal = squared_lattice_distances(grid, &nonlocal);
    // R: rows with a nonlocal share or transition terms (a family member with beta > 0)
    let in_r: Vec<bool> = to_nonlocal.iter().map(|&q| q <= in_family).collect();
    let r_f = (horizon + horizon.max(2.0 * h)) / h;
    let surface = match local.free_faces {
        FreeFaces::Lattice => (horizon / h).ceil() as usize + 1,
        FreeFaces::Bulk => 0,
    };
    // families are truncated within a horizon of a removed site as at the box's faces
    let to_removed = crate::lattice::squared_distances_to_removed(grid);
    let beside_removed = (ratio + 1.0) * (ratio + 1.0);
    // the grid's layer stays on the lattice too (see the module docs)
    let near: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|i| {
            to_nonlocal[i] <= r_f * r_f
                || grid.is_layer(i)
                || near_face(grid, i, surface)
                || to_removed.as_ref().is_some_and(|t| t[i] <= beside_removed)
                || keep[i]
                || regular.is_some_and(|r| !r[i])
        })
        .collect();
    let zones = lattice_zones(grid, beta, &in_r, ratio);
    drop(to_nonlocal);
    let counts = grid.counts();
    let lattice = LatticeBox::new(&grid.site_position([0, 0, 0])[..d], h, &counts[..d])?;
    let corner_near = |c: &[usize]| {
        (0..1usize << d).any(|bits| {
            let k = [0, 1, 2].map(|a| if a < d { c[a] + (bits >> a & 1) } else { 0 });
            grid.node_at_site(k).is_some_and(|i| near[i])
        })
    };
    // a cell with a corner outside the body is no element (the lattice blend's cells are the
    // complete ones too)
    let void = |c: &[usize]| {
        (0..1usize << d).any(|bits| {
            let k = [0, 1, 2].map(|a| if a < d { c[a] + (bits >> a & 1) } else { 0 });
            grid.node_at_site(k).is_none()
        })
    };
    let mesh = if grid.is_full() {
        GradedMesh::new(&lattice, &corner_near, local.grading)?
    } else {
        GradedMesh::with_voids(&lattice, &corner_near, &void, local.grading)?
    };
    drop(near);
    Ok((in_r, zones, mesh))
}

/// Masters whose rows are built together and stored before the next ones (the block rows
/// under construction take 80 bytes a block).
const ROW_CHUNK: usize = 1 << 16;
/// Bytes per lattice node held through the build: `beta`, the distances to the nonlocal
/// nodes, the window's numbering and the per-node flags (R, near, window, mirrored, keep,
/// regular, the mesh's leaf level).
const LATTICE_NODE_BYTES: f64 = 8.0 + 8.0 + 4.0 + 12.0;
/// Bytes per lattice node held through the solve: the mesh's leaf level per lattice cell (the
/// build's per-node arrays are gone by then).
const LATTICE_NODE_SOLVE_BYTES: f64 = 2.0;
/// Bytes per window node: the bond operator's per-node lists, the rows' per-node arrays and
/// the shares' `beta` and master number.
const WINDOW_NODE_BYTES: f64 = 96.0 + 8.0 + 24.0 + 12.0;
/// Bytes per window node of the element moduli `D_i` (81 values), dropped after the rows.
const MODULI_BYTES: f64 = 648.0;
/// Bytes per bond of the bond operator (neighbour index and weight).
const BOND_BYTES: f64 = 12.0;
/// Bytes of one listed share (`graded_blend::operator::Share`).
const SHARE_BYTES: f64 = 16.0;

/// Bytes per master DOF of the solve: the vectors, GMRES's basis (restart 50) and the
/// multigrid hierarchy of `M` with its finest level matrix-free (measured on the penny block
/// of `linpd study penny-sneddon` at n = 500: 2968 MiB for 3.53M DOFs, 880 bytes a DOF; the
/// 2D figure is the assembled hierarchy's less its finest level).
fn master_dof_bytes(d: usize) -> f64 {
    128.0 + 408.0 + if d == 3 { 1000.0 } else { 500.0 }
}

/// The peak bytes of [`GradedBlend::new`] and its solve (`n` lattice nodes, `n_window` of them
/// with bonds, `stencil` bonds a node at most), the larger of its two phases, both holding the
/// window's bond operator `L` (measured on the penny block of `linpd study penny-sneddon` at
/// 1/500: 8.3 GiB peak against 9.7 GiB estimated):
/// 1. the rows: the per-node maps of the lattice, `L`, the moduli and the stored rests: `3^d`
///    blocks of `K_M` for a master off `R` (a 4-byte column each, the values shared with the
///    rows of the same setting: counted as a tenth of them own theirs), and `3^d` more for one
///    of `R` (`4 + 8 d^2` bytes a block: its rests in `A` and `M`, none in the PD zone, where
///    the row is all shares);
/// 2. the solve: the mesh's leaf levels, `L`, the rests, the interaction graph (4 bytes a
///    partner: the family and the rests' nodes for a master of `R`), the vectors and the
///    multigrid hierarchy per master DOF.
///
/// Both hold the lists of the shares, [`SHARE_BYTES`] a bond of a row of `R`.
fn peak_bytes(grid: &Grid, n_window: usize, stencil: usize, mesh: &GradedMesh, extra: usize, in_r: &[bool]) -> f64 {
    let (d, n) = (grid.dim(), grid.len());
    let window = n_window as f64 * (WINDOW_NODE_BYTES + stencil as f64 * BOND_BYTES);
    let moduli = n_window as f64 * MODULI_BYTES;
    let local = 3f64.powi(d as i32);
    let rows_a = (0..mesh.nodes().len())
        .filter(|&g| mesh.master_of(g).is_some())
        .filter(|&g| grid.node_at_site(mesh.nodes()[g]).is_none_or(|i| in_r[i]))
        .count()
        + extra;
    let masters = (mesh.n_masters() + extra) as f64;
    let rows_a = rows_a as f64;
    let partners = masters * local + rows_a * (stencil as f64 + local);
    let (value, column) = (8.0 * (d * d) as f64, 4.0);
    let stored = masters * (16.0 + local * (column + 0.1 * value))
        + rows_a * local * (column + value)
        + masters * 8.0
        + rows_a * stencil as f64 * SHARE_BYTES;
    let build = n as f64 * LATTICE_NODE_BYTES + window + moduli + stored;
    let solve = n as f64 * LATTICE_NODE_SOLVE_BYTES
        + window
        + stored
        + 4.0 * partners
        + d as f64 * masters * master_dof_bytes(d);
    build.max(solve)
}

/// The nodes whose bonds the rows read: those within `max(ratio, sqrt d)` lattice steps of a
/// corner of a level-0 cell or an extra node (their element moduli need their whole family, their cell counts
/// their box neighbours; the rows of `R` read no farther, see the module docs).
fn window_nodes(grid: &Grid, mesh: &GradedMesh, extra: &[usize], ratio: f64) -> Vec<bool> {
    let d = grid.dim();
    let mut fine = vec![false; grid.len()];
    for e in mesh.cells().iter().filter(|e| e.level == 0) {
        for c in 0..1usize << d {
            fine[grid.node_at_site(e.corner(d, c)).expect("a leaf's corners are nodes")] = true;
        }
    }
    for &i in extra {
        fine[i] = true;
    }
    let r = ratio.max((d as f64).sqrt());
    let r2 = r * r * (1.0 + GEOMETRY_RTOL);
    squared_lattice_distances(grid, &fine).into_iter().map(|q| q <= r2).collect()
}

/// The zone counts of the lattice nodes (as [`crate::lattice::zone_counts`], from distances:
/// a family is the nodes within `ratio` lattice steps) and the bond model's stored
/// entries on the whole box, `d^2 (n + bonds)` with the bonds counted per stencil offset.
fn lattice_zones(grid: &Grid, beta: &[f64], in_r: &[bool], ratio: f64) -> Zones {
    let in_family = ratio * ratio * (1.0 + GEOMETRY_RTOL);
    let below_one: Vec<bool> = beta.iter().map(|&b| b < 1.0).collect();
    let to_below = squared_lattice_distances(grid, &below_one);
    let pd = to_below.iter().filter(|&&q| q > in_family).count();
    let local = in_r.iter().filter(|&&r| !r).count();
    let (d, c) = (grid.dim(), grid.counts());
    let stencil = lattice_stencil(d, ratio);
    let bonds: usize = if grid.is_full() {
        stencil
            .iter()
            .map(|k| (0..d).map(|a| c[a].saturating_sub(k[a].unsigned_abs() as usize)).product::<usize>())
            .sum()
    } else {
        (0..grid.len())
            .into_par_iter()
            .map(|i| {
                let k = grid.lattice_index(i);
                stencil.iter().filter(|o| grid.node_at([k[0] + o[0], k[1] + o[1], k[2] + o[2]]).is_some()).count()
            })
            .sum()
    };
    Zones { pd, transition: grid.len() - pd - local, local, nnz: 0, nnz_pd: d * d * (grid.len() + bonds) }
}

/// `D` of a node with a whole family in the homogeneous material (no phases, no defects): the
/// element moduli of every lattice cell of a coarse leaf, whose nodes are all such (see the
/// module docs). Taken at the centre of a small box of the lattice's spacing and placement.
fn bulk_moduli(bond: Bond<'_>, grid: &Grid) -> Result<[f64; 81], BlendError> {
    let (d, h) = (grid.dim(), grid.spacing());
    let r = (bond.horizon / h * (1.0 + GEOMETRY_RTOL)).ceil() as usize + 1;
    let side = vec![2.0 * r as f64 * h; d];
    let small = Grid::new(&vec![0.0; d], &side, h, 0.0, grid.placement())?;
    let op = BondOperator::on_grid(&small, bond.horizon, bond.micromodulus, &Material::default())?;
    let centre = small.node_at_site([0, 1, 2].map(|a| if a < d { r } else { 0 })).expect("the box has its centre");
    Ok(node_moduli(&op, &small, centre, false))
}

/// Whether node `i` is within `r` sites of a face of the lattice box.
fn near_face(grid: &Grid, i: usize, r: usize) -> bool {
    let (c, k) = (grid.counts(), grid.site_of(i));
    (0..grid.dim()).any(|a| k[a] < r || k[a] + r >= c[a])
}

/// `C_E` of a leaf: `sum_{lattice cells e in E} C_e vol_e / vol_E` with
/// `C_e vol_e = sum_{corners c} D_c / n_c` (see the module docs); for a level-0 leaf this is
/// the lattice's cell. The lattice nodes of `E` must be in the window (`sub_of`: window node
/// of each lattice node).
fn cell_moduli(sub: &Grid, sub_of: &[u32], grid: &Grid, rows: &BlendRows, e: &Cell, h: f64) -> [f64; 81] {
    let d = grid.dim();
    let s = e.side();
    let mut sum = [0.0; 81];
    for t in 0..s.pow(d as u32) {
        let o = [0, 1, 2].map(|a| if a < d { e.origin[a] + t / s.pow(a as u32) % s } else { 0 });
        for bits in 0..1usize << d {
            let k = [0, 1, 2].map(|a| if a < d { o[a] + (bits >> a & 1) } else { 0 });
            let i = grid.node_at_site(k).expect("a leaf's lattice cells are the body's");
            let c = sub_of[i] as usize;
            debug_assert!(c < sub.len(), "a cell's nodes are in the window");
            let f = 1.0 / rows.n_cells[c] as f64;
            for (x, y) in sum.iter_mut().zip(&rows.d_tensor[c]) {
                *x += f * y;
            }
        }
    }
    let vol = (h * s as f64).powi(d as i32);
    sum.map(|x| x / vol)
}
