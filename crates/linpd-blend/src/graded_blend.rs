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
//! there, so the element moduli soften, and a coarse cell would average that away. And the
//! cells at the nodes the caller must keep (the scene's constrained nodes: a constraint on a
//! node a coarse cell interpolates would be lost).
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
//! # Element moduli of a coarse cell
//!
//! A lattice cell `e` has `C_e vol_e = sum_{corners c} D_c / n_c` ([`crate::lattice`]); a
//! coarse cell `E` gets `C_E vol_E = sum_{lattice cells e in E} C_e vol_e`: the energy of an
//! affine field on `E` is the sum of its lattice cells' energies, so the local model's
//! energy equivalence with PD for affine fields holds for the coarse cells too. In a
//! homogeneous bulk every `C_e` is the PD model's tensor and so is `C_E`; along a free surface
//! `C_E` averages the softened cells it covers (the trilinear field on `E` cannot follow a
//! surface layer thinner than `E`); a cell over several phases gets the volume average of
//! their tensors (the Voigt bound: stiffer than the lattice's elements for a field that is not
//! affine there). Material interfaces and defects are PD features of `"auto"` zones, so coarse
//! cells are single-phase in those scenes.
//!
//! # Loads and output
//!
//! Forces given on lattice nodes reach the masters as `P^T f` and the solution is drawn on
//! every lattice node as `P u_M` ([`GradedMesh::interpolation_row`]).

use crate::graded::{Cell, GradedMesh, Grading, LatticeBox};
use crate::lattice::{
    block_rows_to_csc, cells_at, element_moduli, squared_lattice_distances, zone_counts, BlendRows, BlockRow,
    RowBuilder,
};
use crate::{BlendError, Zones};
use linpd_bond::BondOperator;
use linpd_core::sparse::Csc;
use linpd_core::{AssembledModel, DofMap, Grid, Model, Ordering, Point};
use rayon::prelude::*;

/// The blended model on a lattice with a graded local mesh, assembled over the masters' DOFs
/// (see the module docs).
#[derive(Debug, Clone)]
pub struct GradedBlend {
    mesh: GradedMesh,
    /// The lattice node of every master.
    master_node: Vec<usize>,
    /// `A` over the masters' DOFs (positions: the masters').
    a: AssembledModel,
    /// The SPD companion of `A` (see the module docs).
    m: Csc,
    zones: Zones,
    estimate: f64,
}

impl GradedBlend {
    /// The blended model of [`crate::LatticeBlend::new`] (same arguments; `grid` must be the
    /// full lattice box, which blended scenes are) with its local zone on a mesh graded by
    /// `grading` away from the nonlocal rows.
    /// `keep[i]`: node `i` must be an unknown (a constrained node: a constraint on a node that a
    /// coarse cell interpolates would be lost), so the cells at it stay on the lattice.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        op: &BondOperator,
        grid: &Grid,
        horizon: f64,
        beta: Vec<f64>,
        regular: Option<&[bool]>,
        mirrored: &[bool],
        keep: &[bool],
        grading: Grading,
    ) -> Result<Self, BlendError> {
        let (d, n, h) = (op.dim(), op.n_nodes(), grid.spacing());
        crate::lattice::check_inputs(d, n, &beta, mirrored)?;
        if keep.len() != n {
            return Err(BlendError::param("local_mesh", format!("{} keep flags for {n} nodes", keep.len())));
        }
        if !grid.is_full() {
            return Err(BlendError::param("local_mesh", "a graded local mesh needs the full lattice box (no body)"));
        }
        let family = op.family();
        let nonlocal: Vec<bool> = beta.iter().map(|&b| b > 0.0).collect();
        // R: rows with a nonlocal share or transition terms
        let in_r: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|i| nonlocal[i] || family.neighbors(i).iter().any(|&j| nonlocal[j as usize]))
            .collect();
        let r_f = (horizon + horizon.max(2.0 * h)) / h + 2.0;
        let surface = (horizon / h).ceil() as usize + 1;
        // the grid's layer stays on the lattice too (see the module docs)
        let near: Vec<bool> = squared_lattice_distances(grid, &nonlocal)
            .into_iter()
            .enumerate()
            .map(|(i, q)| q <= r_f * r_f || grid.is_layer(i) || near_face(grid, i, surface) || keep[i])
            .collect();
        let counts = grid.counts();
        let lattice = LatticeBox::new(&grid.site_position([0, 0, 0])[..d], h, &counts[..d])?;
        let corner_near = |c: &[usize]| {
            (0..1usize << d).any(|bits| {
                let k = [0, 1, 2].map(|a| if a < d { c[a] + (bits >> a & 1) } else { 0 });
                grid.node_at_site(k).is_some_and(|i| near[i])
            })
        };
        let mesh = GradedMesh::new(&lattice, &corner_near, grading)?;
        let estimate = peak_bytes(op, &mesh, &in_r, grid);
        linpd_core::memory::check(
            format!(
                "the graded blend ({} lattice nodes with their bonds and element moduli, {} masters with their rows)",
                n,
                mesh.n_masters()
            ),
            estimate,
            "use a larger max_cell or fewer cells_per_level, or a coarser spacing",
        )
        .map_err(|e| BlendError::param("model.local_mesh", e.to_string()))?;

        let rows = BlendRows {
            op,
            grid,
            beta: &beta,
            regular,
            d_tensor: element_moduli(op, grid, &beta, mirrored),
            n_cells: (0..n).map(|i| cells_at(grid, i).count() as u8).collect(),
        };
        let master_node: Vec<usize> = (0..mesh.nodes().len())
            .filter(|&g| mesh.master_of(g).is_some())
            .map(|g| grid.node_at_site(mesh.nodes()[g]).expect("a full grid has every site"))
            .collect();
        let mut master_of_node = vec![u32::MAX; n];
        for (m, &i) in master_node.iter().enumerate() {
            master_of_node[i] = m as u32;
        }
        let k_m = mesh.stiffness(&|e: &Cell| coarse_moduli(grid, &rows, e, h));
        let to_master = |row: BlockRow, i: usize| -> Result<BlockRow, BlendError> {
            row.into_iter()
                .map(|(j, b)| match master_of_node[j] {
                    u32::MAX => Err(BlendError::param(
                        "local_mesh",
                        format!("the row of lattice node {i} reads node {j}, which the graded mesh does not keep"),
                    )),
                    m => Ok((m as usize, b)),
                })
                .collect()
        };
        let built: Vec<Result<(BlockRow, BlockRow), BlendError>> = master_node
            .par_iter()
            .enumerate()
            .map_init(
                || (RowBuilder::new(n), RowBuilder::new(n)),
                |(rb, mb), (m, &i)| {
                    if in_r[i] {
                        let (ra, rm) = rows.row(i, rb, mb)?;
                        Ok((to_master(ra, i)?, to_master(rm, i)?))
                    } else {
                        let r = symmetric_block_row(&k_m, d, m);
                        Ok((r.clone(), r))
                    }
                },
            )
            .collect();
        let (a_rows, m_rows): (Vec<BlockRow>, Vec<BlockRow>) =
            built.into_iter().collect::<Result<Vec<_>, _>>()?.into_iter().unzip();
        drop(k_m);
        let a = block_rows_to_csc(d, &a_rows);
        drop(a_rows);
        let m = block_rows_to_csc(d, &m_rows);
        drop(m_rows);
        let (pd, transition, local) = zone_counts(family, &beta);
        let zones = Zones { pd, transition, local, nnz: a.val().len(), nnz_pd: d * d * (n + family.n_bonds()) };
        let positions: Vec<Point> = master_node.iter().map(|&i| grid.position(i)).collect();
        Ok(GradedBlend { mesh, master_node, a: AssembledModel::new("blend", d, positions, a), m, zones, estimate })
    }

    /// The estimate of the peak bytes of building and solving this model (checked against the
    /// available memory once the mesh was known, before the rows were built; see `peak_bytes`).
    pub fn memory_estimate(&self) -> f64 {
        self.estimate
    }

    /// The graded mesh.
    pub fn mesh(&self) -> &GradedMesh {
        &self.mesh
    }
    /// The lattice node of every master (the unknowns' nodes, in unknown order).
    pub fn master_nodes(&self) -> &[usize] {
        &self.master_node
    }
    /// The zone counts (over the lattice nodes) and the stored entries of `A` (over the
    /// masters) against the bond model's on the whole lattice.
    pub fn zones(&self) -> Zones {
        self.zones
    }
    /// `A` over the masters' DOFs.
    pub fn stiffness(&self) -> &Csc {
        self.a.stiffness()
    }
    /// The SPD companion `M` over the masters' DOFs.
    pub fn companion(&self) -> &Csc {
        &self.m
    }

    /// `u = P u_M` on every node of `grid` (the lattice the model was built on), `d` values per
    /// node (see the module docs).
    pub fn expand(&self, grid: &Grid, u_master: &[f64]) -> Vec<f64> {
        let d = self.mesh.dim();
        assert_eq!(u_master.len(), d * self.master_node.len(), "one value per master DOF");
        let mut u = vec![0.0; d * grid.len()];
        u.par_chunks_mut(d).enumerate().for_each(|(i, ui)| {
            for (m, w) in self.mesh.interpolation_row(site(grid, i)) {
                for a in 0..d {
                    ui[a] += w * u_master[d * m + a];
                }
            }
        });
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
            for (m, w) in self.mesh.interpolation_row(site(grid, i)) {
                for a in 0..d {
                    out[d * m + a] += w * f[d * i + a];
                }
            }
        }
        out
    }
}

/// Bytes per lattice node held through the build: the bond operator's per-node lists, `beta`,
/// the zone and distance maps.
const LATTICE_NODE_BYTES: f64 = 96.0 + 8.0 + 24.0;
/// Bytes per lattice node of the element moduli `D_i` (81 values), dropped after the rows.
const MODULI_BYTES: f64 = 648.0;
/// Bytes per bond of the bond operator (neighbour index and weight).
const BOND_BYTES: f64 = 12.0;
/// Bytes per master DOF of the solve: the assembled solve's vectors, GMRES's basis and a
/// multigrid hierarchy from `M` (the scene's blend estimate, `crates/linpd-scene/src/memory.rs`:
/// 1500 in 3D, 700 in 2D).
fn master_dof_bytes(d: usize) -> f64 {
    128.0 + 408.0 + if d == 3 { 1500.0 } else { 700.0 }
}

/// The peak bytes of [`GradedBlend::new`] and its solve, the largest of its three phases over
/// what the whole run holds (the bond operator and the per-node maps, `L`):
/// 1. `K_M` from its triplets: `L`, the moduli, the triplets (24 bytes and 8 of faer's sort
///    each, [`GradedMesh::stiffness_triplets`]) and `K_M` (16 bytes an entry, `3^d d^2` a
///    master);
/// 2. the rows: `L`, the moduli, `K_M`, the block rows of `A` and `M` (80 bytes a block each:
///    Algorithm A's `|F| + 1` for the nodes of `R`, `3^d` for the others) and `A`, `M` (16
///    bytes an entry each);
/// 3. the solve: `L`, `A`, `M` and their free restrictions (16 bytes an entry each), `A`'s
///    interaction graph, the vectors and the multigrid hierarchy per master DOF.
fn peak_bytes(op: &BondOperator, mesh: &GradedMesh, in_r: &[bool], grid: &Grid) -> f64 {
    let d = op.dim();
    let n = op.n_nodes() as f64;
    let held = n * LATTICE_NODE_BYTES + op.family().n_bonds() as f64 * BOND_BYTES;
    let moduli = n * MODULI_BYTES;
    let local_blocks = 3f64.powi(d as i32);
    let blocks: f64 = (0..mesh.nodes().len())
        .filter(|&g| mesh.master_of(g).is_some())
        .map(|g| {
            let i = grid.node_at_site(mesh.nodes()[g]).expect("a full grid has every site");
            if in_r[i] {
                op.family().neighbors(i).len() as f64 + 1.0
            } else {
                local_blocks
            }
        })
        .sum();
    let dd = (d * d) as f64;
    let (entries, masters) = (blocks * dd, mesh.n_masters() as f64);
    let k_m = masters * local_blocks * dd * 16.0;
    // K_M's triplets (24 bytes) and faer's argsort of them (8 bytes)
    let triplets = mesh.stiffness_triplets() as f64 * 32.0;
    let build = held + moduli + k_m + triplets.max(2.0 * blocks * 80.0 + 2.0 * entries * 16.0);
    // A, M, their free restrictions, and the interaction graph of A (4 bytes a block each way)
    let solve = held + 4.0 * entries * 16.0 + 8.0 * blocks + d as f64 * masters * master_dof_bytes(d);
    build.max(solve)
}

/// Whether node `i` is within `r` sites of a face of the lattice box.
fn near_face(grid: &Grid, i: usize, r: usize) -> bool {
    let (c, k) = (grid.counts(), site(grid, i));
    (0..grid.dim()).any(|a| k[a] < r || k[a] + r >= c[a])
}

/// The site (0-based lattice index, layers included) of node `i` of a full grid.
fn site(grid: &Grid, i: usize) -> [usize; 3] {
    let c = grid.counts();
    [i % c[0], (i / c[0]) % c[1], i / (c[0] * c[1])]
}

/// `C_E` of a leaf: `sum_{lattice cells e in E} C_e vol_e / vol_E` with
/// `C_e vol_e = sum_{corners c} D_c / n_c` (see the module docs); for a level-0 leaf this is
/// the lattice's cell.
fn coarse_moduli(grid: &Grid, rows: &BlendRows, e: &Cell, h: f64) -> [f64; 81] {
    let d = grid.dim();
    let s = e.side();
    let mut sum = [0.0; 81];
    for t in 0..s.pow(d as u32) {
        let o = [0, 1, 2].map(|a| if a < d { e.origin[a] + t / s.pow(a as u32) % s } else { 0 });
        for bits in 0..1usize << d {
            let k = [0, 1, 2].map(|a| if a < d { o[a] + (bits >> a & 1) } else { 0 });
            let c = grid.node_at_site(k).expect("a full grid has every site");
            let f = 1.0 / rows.n_cells[c] as f64;
            for (x, y) in sum.iter_mut().zip(&rows.d_tensor[c]) {
                *x += f * y;
            }
        }
    }
    let vol = (h * s as f64).powi(d as i32);
    sum.map(|x| x / vol)
}

/// Block row `m` of the symmetric `K` (`d x d` blocks): its block column `m`, transposed.
fn symmetric_block_row(k: &Csc, d: usize, m: usize) -> BlockRow {
    let (cp, ri, v) = (k.symbolic().col_ptr(), k.symbolic().row_idx(), k.val());
    let mut row: BlockRow = Vec::new();
    for a in 0..d {
        for p in cp[d * m + a]..cp[d * m + a + 1] {
            let (j, b) = (ri[p] / d, ri[p] % d);
            let at = match row.binary_search_by_key(&j, |e| e.0) {
                Ok(q) => q,
                Err(q) => {
                    row.insert(q, (j, [0.0; 9]));
                    q
                }
            };
            // K[(m,a),(j,b)] = K[(j,b),(m,a)], the entry at row (j,b) of column (m,a)
            row[at].1[a * 3 + b] = v[p];
        }
    }
    row
}

/// `A`'s own methods are those of the stored matrix ([`AssembledModel`]) over the masters.
impl Model for GradedBlend {
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
    /// AMD: the masters are not a lattice.
    fn ordering(&self, _dofs: &DofMap) -> Ordering {
        Ordering::Amd
    }
    fn spd_approximation(&self, dofs: &DofMap) -> Option<linpd_core::SpdApproximation> {
        Some(linpd_core::SpdApproximation {
            matrix: linpd_core::sparse::restrict_to_free(&self.m, dofs),
            kind: linpd_core::SpdApproximationKind::EnergyForm,
        })
    }
    fn matrix_free_unavailable(&self) -> Option<&'static str> {
        Some("the blended model is assembled")
    }
    /// The lattice node and position of master `i` (the numbers users see are the lattice's).
    fn describe_node(&self, i: usize) -> String {
        let x = self.a.position(i);
        format!("node {} (master {i}) at {:?}", self.master_node[i], &x[..self.a.dim()])
    }
}
