//! The memory estimate of a lattice scene: one estimate per model and solver path, checked
//! against the machine's available memory ([`linpd_core::memory`]) when the scene is
//! validated and again before it is solved, i.e. before anything large is allocated.
//!
//! Bytes per item, from the allocations of each path (peak resident memory measured against
//! these numbers in docs/solvers.md, "Memory guard"):
//!
//! * every node: positions, lattice index, family offsets and the per-node lists the family
//!   is built from, layer flags: [`NODE_BYTES`];
//! * bond building: 4 bytes per neighbour (u32), twice while the per-node lists are
//!   flattened, plus the bond weights (8 bytes): [`BOND_BYTES`]; LPS keeps `omega nu V` and
//!   `|xi|` per bond instead (also 16);
//! * assembled bond stiffness: `n (|F| + 1) d^2` entries of 8 bytes of value and 8 of row
//!   index, plus a copy of the pattern while the matrix is made ([`ENTRY_BYTES`] = 24);
//! * LPS tangent: its reach is **2 delta** (`g_k g_k^T` couples the family of a node with
//!   itself), so a column node has `|O - O|` row nodes, `O` the family offsets with 0: 8.5x
//!   the bond neighbourhood at delta = 2h in 3D. The full tangent (16 bytes per entry) and its
//!   restriction to the free DOFs (16 more) coexist, with the 8-byte row lists of the pattern:
//!   [`TANGENT_ENTRY_BYTES`] per entry plus 8 per `(node, row node)`;
//! * the blended model (`pd_regions`): its `A` and its SPD companion `M` over all DOFs, their
//!   restrictions to the free DOFs, and while they are built the block rows of both (80 bytes
//!   a block of up to 9 entries): [`BLEND_ENTRY_BYTES`] per entry of the bond model's `A` (the
//!   blend stores at most as many), plus GMRES's Krylov basis (51 vectors):
//!   [`GMRES_DOF_BYTES`] per DOF;
//! * solver vectors per DOF: [`ASSEMBLED_DOF_BYTES`] (right-hand side, prescribed values, DOF
//!   maps, CG's four vectors, preconditioner, solution, outputs), [`MATRIX_FREE_DOF_BYTES`]
//!   for matrix-free CG (the same plus the full diagonal and the operator's two scratch
//!   vectors).
//!
//! The factors of a sparse Cholesky or LU are not in here: their fill is only known after the
//! symbolic analysis, where linpd-solve checks it ([`linpd_solve::Cholesky::factor`],
//! [`linpd_solve::Lu::factor`]).

use crate::ProblemError;
use linpd_core::family::lattice_stencil;
use linpd_core::memory::{self, OutOfMemory};
use linpd_core::Grid;
use std::collections::HashSet;

/// Per node (see the module docs).
pub const NODE_BYTES: f64 = 96.0;
/// Per bond while the family and its weights are built (fits of two sizes each, the process
/// baseline cancelled: 10.6-11.7 in 3D matrix-free runs, 15.4 in 2D; docs/robustness.md).
pub const BOND_BYTES: f64 = 12.0;
/// Per stored entry of the assembled bond stiffness (fits: 18.6-19.1 in 3D, 19.8-21.6 in 2D).
pub const ENTRY_BYTES: f64 = 20.0;
/// Per stored entry of the LPS tangent (the full tangent and its free-DOF copy).
pub const TANGENT_ENTRY_BYTES: f64 = 32.0;
/// Per stored entry of the LPS tangent on a point cloud (fits: 41.7-41.9 against the exact
/// count of node pairs within 2 delta).
pub const CLOUD_TANGENT_ENTRY_BYTES: f64 = 42.0;
/// Per stored entry of the assembled bond stiffness on a point cloud (fit: ~28 with the exact
/// bond counts; its families are built by a cell list, not a stencil).
pub const CLOUD_ENTRY_BYTES: f64 = 28.0;

/// What a point cloud's estimate adds to the lattice formula of [`estimate_counts`] for `path`
/// (`nb` bonds and `rows` tangent row nodes per node): the dearer entries of its assembly.
pub fn cloud_extra(path: Path, dim: usize, nodes: usize, nb: f64, rows: f64) -> f64 {
    let (n, dd) = (nodes as f64, (dim * dim) as f64);
    match path {
        Path::LpsAssembled => n * rows * dd * (CLOUD_TANGENT_ENTRY_BYTES - TANGENT_ENTRY_BYTES),
        Path::BondAssembled => n * (nb + 1.0) * dd * (CLOUD_ENTRY_BYTES - ENTRY_BYTES),
        _ => 0.0,
    }
}
/// Per bond of the matrix-free LPS tangent: the family (`u32`), `omega nu V` and `|xi|`.
pub const LPS_BOND_BYTES: f64 = 20.0;
/// Per DOF, a matrix-free LPS solve besides its bonds: the CG vectors, the stencils' per-node
/// data and the outputs. With [`LPS_BOND_BYTES`], fits of `/usr/bin/time` peaks of `linpd
/// solve` with matrix-free Jacobi-CG at two sizes each (`delta = 3h`): 3D cantilevers 50^3 and
/// 70^3 (115-117 bonds a node, 2934-2948 bytes a node in all; the estimate is 1.04x the peak,
/// counting the interior's 122 bonds for every node), 2D plates 401^2 and 801^2 (28 bonds,
/// 1218-1264 bytes a node).
pub fn lps_matrix_free_dof_bytes(dim: usize) -> f64 {
    if dim == 3 {
        175.0
    } else {
        300.0
    }
}

/// Per DOF, what the pair part's multigrid adds to [`lps_matrix_free_dof_bytes`] besides its
/// bond graph ([`GRAPH_BOND_BYTES`] a bond): the same fits with multigrid-CG put the peak
/// 973-979 bytes a DOF above Jacobi's in 3D (163 of them the graph) and 373-379 in 2D (56).
pub fn lps_multigrid_dof_bytes(dim: usize) -> f64 {
    if dim == 3 {
        820.0
    } else {
        320.0
    }
}

/// Per DOF, assembled solve.
pub const ASSEMBLED_DOF_BYTES: f64 = 128.0;
/// Per DOF, matrix-free CG.
pub const MATRIX_FREE_DOF_BYTES: f64 = 176.0;
/// Per stored entry of the bond model's `A`, the blended model (`A`, `M`, their free-DOF
/// restrictions, 16 bytes each).
pub const BLEND_ENTRY_BYTES: f64 = 64.0;
/// Per DOF, explicit dynamics: displacement, velocity, acceleration, force, load, mass and the
/// operator's scratch (fit of a 1D bar at 1M and 2M nodes: 395-460 bytes a node with 20 bonds
/// and two snapshots, i.e. 43-108 a DOF beyond the bonds).
pub const DYNAMICS_DOF_BYTES: f64 = 96.0;
/// Per lattice node of a graded blend (no bonds: those are built near the fine cells only and
/// checked with the masters, [`linpd_blend::GradedBlend::new`]): `beta` and the distance
/// transforms, the per-node flags, the mesh's cell levels and distances (the constraints, the
/// loads and the balance reach the masters without lattice-sized vectors). Measured: 23 bytes
/// a node at the peak of the build on the 15.8M-node penny block of `linpd study penny-sneddon`.
pub const GRADED_NODE_BYTES: f64 = 40.0;
/// Per lattice node, the graded blend's solution drawn on every lattice node
/// (`output.nodes: "lattice"`): positions, `u`, volumes, strain, reactions and flags, and the
/// written files' buffers.
pub const GRADED_LATTICE_OUTPUT_BYTES: f64 = 200.0;
/// Per DOF, GMRES on top of an assembled solve's vectors: the restart-50 Krylov basis.
pub const GMRES_DOF_BYTES: f64 = 408.0;

/// The largest stencil enumerated exactly; beyond it the ball's volume in lattice units is
/// used (enumerating a 3D stencil of ratio 1e4 would itself never end).
const EXACT_STENCIL: f64 = 2000.0;

/// `pi^(d/2) / Gamma(d/2 + 1) r^d`: lattice points per unit ball of radius `r` spacings.
fn ball(dim: usize, r: f64) -> f64 {
    match dim {
        1 => 2.0 * r,
        2 => std::f64::consts::PI * r * r,
        _ => 4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
    }
}

/// Lattice neighbours within `ratio` spacings (self excluded).
pub fn neighbours(dim: usize, ratio: f64) -> f64 {
    if ball(dim, ratio) > EXACT_STENCIL {
        return ball(dim, ratio);
    }
    lattice_stencil(dim, ratio).len() as f64
}

/// Row nodes of a column of the LPS tangent: the distinct offsets `O - O` of the stencil `O`
/// with 0, i.e. the lattice points within the 2-delta reach that two family members span.
pub fn tangent_rows(dim: usize, ratio: f64) -> f64 {
    if ball(dim, ratio) > EXACT_STENCIL {
        return ball(dim, 2.0 * ratio);
    }
    let mut o = lattice_stencil(dim, ratio);
    o.push([0, 0, 0]);
    let set: HashSet<[i64; 3]> =
        o.iter().flat_map(|s| o.iter().map(move |t| [s[0] - t[0], s[1] - t[1], s[2] - t[2]])).collect();
    set.len() as f64
}

/// The model and solver path of a lattice scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    /// Bond-based (and blend/ce) operator, assembled.
    BondAssembled,
    /// Bond-based operator applied matrix-free (CG or explicit dynamics).
    BondMatrixFree,
    /// The homogeneous lattice stencil applied matrix-free, without per-bond data
    /// (`linpd_bond::LatticeBondModel::stencil`); its multigrid is smoothed aggregation.
    BondStencil,
    /// [`Path::BondStencil`] on a lattice that offers its coarse lattice
    /// (`linpd_bond::offers_coarse_lattice`): the multigrid puts the geometric level on top
    /// (`linpd_solve::LatticeMultigrid`).
    BondStencilGeometric,
    /// The LPS tangent, assembled.
    LpsAssembled,
    /// The LPS tangent applied matrix-free (the per-bond lists, the stencils on a homogeneous
    /// full box); its multigrid is the pair part's ([`linpd_lps::PairPart`]), one horizon.
    LpsMatrixFree,
    /// The blended model (`pd_regions`) with its SPD companion, solved by GMRES.
    BlendAssembled,
    /// The bond operator stepped by explicit dynamics (`linpd run`), without its snapshots
    /// (counted by the dynamics section's check).
    BondDynamics,
    /// The lattice-wide part of a blended model on a graded local mesh (`local_mesh`): a few
    /// maps per lattice node; the bonds near the fine cells and the masters' part are checked
    /// once the mesh is known ([`linpd_blend::GradedBlend::new`]).
    GradedBlendLattice,
}

/// The estimated peak bytes of `path` on `grid` with `horizon`, and a description of it.
pub fn estimate(path: Path, grid: &Grid, horizon: f64) -> (String, f64) {
    estimate_nodes(path, grid.dim(), grid.len(), horizon / grid.spacing())
}

/// [`estimate`] for `nodes` nodes in dimension `dim` with `ratio` = horizon / spacing. A
/// family holds at most the `nodes - 1` other nodes and a tangent column at most `nodes` rows,
/// so both counts are capped there (a 1,694-node grid at `delta = 50 h` was refused at 191.6
/// GiB for the bonds of an infinite lattice; it needs 0.4 GB).
pub fn estimate_nodes(path: Path, dim: usize, nodes: usize, ratio: f64) -> (String, f64) {
    let n = nodes as f64;
    let nb = neighbours(dim, ratio).min((n - 1.0).max(0.0));
    let rows = tangent_rows(dim, ratio).min(n);
    estimate_counts(path, dim, nodes, nb, rows)
}

/// The estimate of `path` for `nodes` nodes with `nb` bonds and (LPS) `rows` tangent row
/// nodes per node on average.
pub fn estimate_counts(path: Path, dim: usize, nodes: usize, nb: f64, rows: f64) -> (String, f64) {
    let n = nodes as f64;
    let dofs = n * dim as f64;
    let dd = (dim * dim) as f64;
    let base = n * (NODE_BYTES + nb * BOND_BYTES);
    match path {
        Path::BondAssembled => (
            format!("the assembled stiffness of {nodes} nodes with ~{nb:.0} bonds each"),
            base + n * (nb + 1.0) * dd * ENTRY_BYTES + dofs * ASSEMBLED_DOF_BYTES,
        ),
        Path::BondMatrixFree => (
            format!("the matrix-free operator and CG vectors of {nodes} nodes with ~{nb:.0} bonds each"),
            base + dofs * MATRIX_FREE_DOF_BYTES,
        ),
        Path::BondStencil | Path::BondStencilGeometric => (
            format!("the lattice stencil, the CG vectors and the outputs of {nodes} nodes"),
            n * NODE_BYTES + dofs * stencil_dof_bytes(dim),
        ),
        Path::BlendAssembled => (
            format!("the blended model and its SPD companion on {nodes} nodes with ~{nb:.0} bonds each"),
            base + n * (nb + 1.0) * dd * BLEND_ENTRY_BYTES + dofs * (ASSEMBLED_DOF_BYTES + GMRES_DOF_BYTES),
        ),
        Path::BondDynamics => (
            format!("the bond operator and velocity-Verlet vectors of {nodes} nodes with ~{nb:.0} bonds each"),
            base + dofs * DYNAMICS_DOF_BYTES,
        ),
        Path::GradedBlendLattice => {
            (format!("the per-node maps of the graded blend's {nodes} lattice nodes"), n * GRADED_NODE_BYTES)
        }
        Path::LpsMatrixFree => (
            format!(
                "the matrix-free LPS tangent, the CG vectors and the outputs of {nodes} nodes with ~{nb:.0} bonds each"
            ),
            n * (NODE_BYTES + nb * LPS_BOND_BYTES) + dofs * lps_matrix_free_dof_bytes(dim),
        ),
        Path::LpsAssembled => (
            format!(
                "the LPS tangent of {nodes} nodes (reach 2 delta: ~{rows:.0} coupled nodes per node, ~{nb:.0} bonds)"
            ),
            base + n * rows * (dd * TANGENT_ENTRY_BYTES + 8.0) + dofs * ASSEMBLED_DOF_BYTES,
        ),
    }
}

/// The bytes of a lattice blend whose zones are known: `blocks` block rows' blocks over its
/// `nodes` (Algorithm A's `|F| + 1` for a node with a nonlocal share, the `3^d` of the element
/// stencil for a local one; the blend's `A` and `M` have about as many), with the bond
/// operator's `bonds` and the solve's vectors (and `multigrid` hierarchy) per DOF. The
/// estimate before the zones ([`Path::BlendAssembled`]) counts the bond model's entries, an
/// upper bound: `"auto"` zones on a cracked plate keep 0.36x of them.
pub fn blend_zone_bytes(dim: usize, nodes: usize, bonds: usize, blocks: f64, multigrid: bool) -> f64 {
    let (n, dofs) = (nodes as f64, (nodes * dim) as f64);
    let hierarchy = if multigrid { dofs * multigrid_dof_bytes(dim, false) } else { 0.0 };
    n * NODE_BYTES
        + bonds as f64 * BOND_BYTES
        + blocks * (dim * dim) as f64 * BLEND_ENTRY_BYTES
        + dofs * (ASSEMBLED_DOF_BYTES + GMRES_DOF_BYTES)
        + hierarchy
}

/// Most column terms the LPS tangent's assembly may cost ([`check_lps_work`]): about 65 s at
/// the measured 6.5 ns per term (a 2,601-node 2D plate at `delta = 50 h`, every node in every
/// family: 1.76e10 terms, 114 s of assembly), refused at validation above this instead of
/// running for minutes.
pub const LPS_ASSEMBLY_TERMS_LIMIT: f64 = 1e10;

/// The column terms of the LPS tangent's assembly: every column node `p` adds `g_k g_k^T` for
/// `k in {p} U F_p`, each over `|F_k| + 1` rows (`crates/linpd-lps/src/tangent.rs`): about
/// `n (|F| + 1)^2` for `n` nodes with `|F|` bonds each (capped at `n - 1`).
pub fn lps_assembly_terms(nodes: usize, family: f64) -> f64 {
    let n = nodes as f64;
    n * (family.min((n - 1.0).max(0.0)) + 1.0).powi(2)
}

/// Refuses an LPS scene whose tangent assembly would cost more than
/// [`LPS_ASSEMBLY_TERMS_LIMIT`] terms (the families are a large part of the body: the cost
/// grows as `n |F|^2`, cubically in the nodes once every family holds the body), naming
/// `model.horizon`, the work and the way out.
pub fn check_lps_work(nodes: usize, family: f64, ratio: f64) -> Result<(), ProblemError> {
    let terms = lps_assembly_terms(nodes, family);
    if terms > LPS_ASSEMBLY_TERMS_LIMIT {
        return Err(ProblemError::invalid(
            "model.horizon",
            format!(
                "the LPS tangent of {nodes} nodes with ~{:.0} bonds each (horizon/spacing {ratio:.4}) costs about \
                 {terms:.2e} column terms to assemble (n (|F| + 1)^2; ~{:.0} s at 6.5 ns each), more than the limit \
                 {LPS_ASSEMBLY_TERMS_LIMIT:e}: lower the horizon/spacing ratio (LPS is usually run at 2-4)",
                family.min(nodes.saturating_sub(1) as f64),
                terms * 6.5e-9
            ),
        ));
    }
    Ok(())
}

/// Pair tests [`count_pairs`] spends on an exact count when the cells' bound already shows the
/// count fits (about a second on 2 cores).
pub const EXACT_PAIR_TESTS: u64 = 1_000_000_000;

/// The ordered pairs `(i, j)`, `i != j`, of `points` within `radius` (the bonds of families of
/// that horizon, counted from both ends, with the tolerance of
/// [`linpd_core::BondFamily::from_points`]), by a cell list of cell size `radius`, without
/// building a family. Stops as soon as the count exceeds `stop` (then returns a count `> stop`,
/// with the number of nodes whose pairs were counted, `< points.len()`), so a cloud whose
/// families would not fit costs about `stop` pair tests; when the cells' populations alone
/// bound the count by `stop` (`sum_c |c| |neighbourhood of c|`) and that bound is above
/// [`EXACT_PAIR_TESTS`], nothing is tested and the bound is returned (it overcounts a uniform
/// cloud's pairs by the `3^d` cells against the ball: 2.9x in 2D). Returns `(pairs, nodes
/// counted)`.
pub fn count_pairs(points: &[linpd_core::Point], dim: usize, radius: f64, stop: u64) -> (u64, usize) {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    if !(radius > 0.0 && radius.is_finite()) || points.len() < 2 {
        return (0, points.len());
    }
    let cells = linpd_core::family::CellList::new(points, dim, radius);
    let bound = cells.pair_bound();
    if bound <= stop && bound > EXACT_PAIR_TESTS {
        return (bound, points.len());
    }
    let (total, counted) = (AtomicU64::new(0), AtomicU64::new(0));
    let _ = points.par_iter().enumerate().try_for_each(|(i, x)| {
        if total.load(Ordering::Relaxed) > stop {
            return Err(());
        }
        let mut count = 0u64;
        cells.for_each_within(points, x, |j| count += (j as usize != i) as u64);
        total.fetch_add(count, Ordering::Relaxed);
        counted.fetch_add(1, Ordering::Relaxed);
        Ok(())
    });
    (total.into_inner(), counted.into_inner() as usize)
}

/// `Err` (at `model.horizon`) when `path` on the point cloud `points` with `horizon` would
/// not fit in the available memory, from the real family sizes: the bonds within the horizon
/// (and, for the LPS tangent, the node pairs within its 2-delta reach) counted by
/// [`count_pairs`] before any family is allocated. The mean spacing says nothing about a
/// cloud's families: 3,000 nodes within one horizon hold 9e6 bonds (1.2 GB assembled) however
/// large their volumes. `multigrid`: the solver builds a multigrid hierarchy (`auto` on a bond
/// cloud does). `Ok` holds the estimate in bytes.
pub fn check_cloud(
    path: Path,
    dim: usize,
    points: &[linpd_core::Point],
    horizon: f64,
    multigrid: bool,
) -> Result<f64, ProblemError> {
    let n = points.len();
    let nf = (n as f64).max(1.0);
    let (available, _) = memory::available_bytes();
    // The estimate is affine in the mean counts: count until 4 times the count at which it
    // passes `available` (a refusal then states a realistic amount), and extrapolate the mean
    // from the nodes counted when the count stops early.
    let stop_at = |bytes0: f64, bytes1: f64| -> u64 {
        let per = (bytes1 - bytes0).max(1.0);
        (4.0 * ((available - bytes0) / per).max(1.0) * nf).min(u64::MAX as f64 / 2.0) as u64
    };
    let mean = |(pairs, counted): (u64, usize)| -> (f64, bool) {
        ((pairs as f64 / counted.max(1) as f64).min(nf - 1.0), counted < n)
    };
    let (mut rows, mut partial) = (1.0, false);
    if path == Path::LpsAssembled {
        let (_, b0) = estimate_counts(path, dim, n, 0.0, 0.0);
        let (_, b1) = estimate_counts(path, dim, n, 0.0, 1.0);
        let (r, p) = mean(count_pairs(points, dim, 2.0 * horizon, stop_at(b0, b1)));
        (rows, partial) = (rows + r, p);
    }
    let (_, b0) = estimate_counts(path, dim, n, 0.0, rows);
    let (_, b1) = estimate_counts(path, dim, n, 1.0, rows);
    let (nb, p) = mean(count_pairs(points, dim, horizon, stop_at(b0, b1)));
    let rows = rows.max(nb + 1.0);
    let (mut what, mut bytes) = estimate_counts(path, dim, n, nb, rows);
    bytes += cloud_extra(path, dim, n, nb, rows);
    if multigrid {
        bytes += (n * dim) as f64 * multigrid_dof_bytes(dim, false);
        what += " and its multigrid hierarchy";
    }
    let how = if partial || p { "extrapolated from the families counted" } else { "counted within the horizon" };
    memory::check(
        format!("{what} ({how})"),
        bytes,
        "use fewer nodes, a smaller horizon, or spread the nodes (their families, not their volumes, decide the size)",
    )
    .map_err(|e: OutOfMemory| ProblemError::invalid("model.horizon", e.to_string()))?;
    Ok(bytes)
}

/// Per DOF, the multigrid hierarchy on top of its path: `P`, `R = P^T`, the coarse levels and
/// the transient `A P` of the setup; on a matrix-free path the finest level is not stored.
/// Measured as the peak of a multigrid run minus that of the same run with Jacobi, across two
/// sizes (docs/robustness.md): 3D matrix-free 1165-1276 B, assembled 1491-1516 B; 2D
/// matrix-free 418-458 B, assembled 499 (blend) to 759-866 (point cloud). 1D: the 2D figures.
pub fn multigrid_dof_bytes(dim: usize, matrix_free: bool) -> f64 {
    match (dim == 3, matrix_free) {
        (true, true) => 1250.0,
        (true, false) => 1500.0,
        (false, true) => 460.0,
        (false, false) => 700.0,
    }
}

/// Per DOF, a matrix-free solve on the homogeneous stencil ([`Path::BondStencil`]): no
/// bonds are stored, so the peak is that of writing the outputs (the nodal strain, stress and
/// energy fields and result.json / result.vtu / u.csv built in memory). Fits of two sizes
/// each, `/usr/bin/time` peaks of `linpd solve` with Jacobi-CG: 3D cantilevers 56^3 / 76^3
/// (617 B, refitted 2026-11-27 after the VTU writer and the nodal fields were rewritten;
/// 943 B before), 2D plates 405^2 / 805^2 (713 B).
pub fn stencil_dof_bytes(dim: usize) -> f64 {
    if dim == 3 {
        620.0
    } else {
        720.0
    }
}

/// Per DOF, what smoothed-aggregation multigrid adds to [`stencil_dof_bytes`] besides the bond
/// graph it aggregates on ([`GRAPH_BOND_BYTES`] a bond): its setup's peak (the graph, the
/// hierarchy, the filtered level-0 matrix) lies above the outputs'. Fits of the same two sizes
/// with multigrid-CG: 3D at `delta = 2h` (54^3 / 74^3: 1207 B a DOF in all, 43 B of graph), 2D
/// at `2h` (35 B above the outputs, 24 B of graph). 3D lattices with `delta >= 3h` take the
/// geometric level instead ([`geometric_multigrid_bytes`]).
pub fn stencil_multigrid_dof_bytes(dim: usize) -> f64 {
    if dim == 3 {
        470.0
    } else {
        20.0
    }
}

/// What the geometric multigrid of a 3D stencil with `delta >= 3h` adds to the outputs'
/// peak ([`stencil_dof_bytes`]) for `nodes` nodes with `ratio = delta / h`
/// (`linpd_solve::LatticeMultigrid`): the SA hierarchy of the coarse lattice, an eighth of the
/// nodes with the families of `ratio / 2`, counted like [`stencil_multigrid_dof_bytes`]; the
/// interpolation (8 bytes an entry, ~3.4 entries a fine DOF, and its transpose) and the
/// smoother's vectors are freed before the outputs are built. Against `/usr/bin/time` peaks of
/// `linpd solve` on the 56^3 / 76^3 cantilevers at `delta = 3h`: estimates 1.04x / 1.06x.
pub fn geometric_multigrid_bytes(nodes: usize, ratio: f64) -> f64 {
    let coarse_nodes = nodes as f64 / 8.0;
    let nb = neighbours(3, ratio / 2.0).min(coarse_nodes);
    coarse_nodes * (3.0 * stencil_multigrid_dof_bytes(3) + nb * GRAPH_BOND_BYTES)
}

/// The path of the homogeneous stencil of `micromodulus` on `grid`: [`Path::BondStencilGeometric`]
/// when it offers its coarse lattice, else [`Path::BondStencil`].
pub fn stencil_path(grid: &Grid, horizon: f64, micromodulus: &linpd_core::Micromodulus) -> Path {
    if linpd_bond::offers_coarse_lattice(grid, horizon, micromodulus) {
        Path::BondStencilGeometric
    } else {
        Path::BondStencil
    }
}

/// Per bond (counted from both ends), the interaction graph multigrid aggregates its finest
/// level on (`linpd_solve::DofGeometry::partners`: one `u32`).
pub const GRAPH_BOND_BYTES: f64 = 4.0;

/// `Err` (at `model.horizon`) when `path` would not fit in the available memory; `Ok` holds
/// the estimate in bytes.
pub fn check(path: Path, grid: &Grid, horizon: f64) -> Result<f64, ProblemError> {
    check_solver(path, grid, horizon, false)
}

/// [`check`] with the multigrid hierarchy counted when `multigrid` (the solver is known).
pub fn check_solver(path: Path, grid: &Grid, horizon: f64, multigrid: bool) -> Result<f64, ProblemError> {
    let (mut what, mut bytes) = estimate(path, grid, horizon);
    if multigrid {
        let dofs = (grid.len() * grid.dim()) as f64;
        bytes += match path {
            Path::BondStencilGeometric => geometric_multigrid_bytes(grid.len(), horizon / grid.spacing()),
            Path::BondStencil | Path::LpsMatrixFree => {
                let nb = neighbours(grid.dim(), horizon / grid.spacing()).min(grid.len() as f64);
                let per_dof = match path {
                    Path::LpsMatrixFree => lps_multigrid_dof_bytes(grid.dim()),
                    _ => stencil_multigrid_dof_bytes(grid.dim()),
                };
                dofs * per_dof + grid.len() as f64 * nb * GRAPH_BOND_BYTES
            }
            _ => dofs * multigrid_dof_bytes(grid.dim(), path == Path::BondMatrixFree),
        };
        what += " and its multigrid hierarchy";
    }
    let hint = match path {
        Path::BondAssembled => "use a coarser spacing, a smaller horizon or the matrix-free cg solver",
        Path::BlendAssembled | Path::GradedBlendLattice => {
            "use a coarser spacing, a smaller horizon, or smaller PD regions"
        }
        _ => "use a coarser spacing or a smaller horizon",
    };
    memory::check(what, bytes, hint).map_err(|e: OutOfMemory| ProblemError::invalid("model.horizon", e.to_string()))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_match_the_lattice() {
        assert_eq!(neighbours(3, 2.0), 32.0);
        assert_eq!(neighbours(3, 3.0), 122.0);
        // The tangent's column pattern: O - O with |O| = 33 at delta = 2h in 3D.
        assert_eq!(tangent_rows(3, 2.0), 185.0);
        assert_eq!(tangent_rows(2, 3.0), 105.0);
        // Large ratios fall back to volumes without enumerating.
        assert!(neighbours(3, 1e4) > 4e12);
        assert_eq!(tangent_rows(3, 1e4), 8.0 * neighbours(3, 1e4));
    }
}
