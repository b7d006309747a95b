//! The memory guard of a scene: the estimated peak of its model and solver path ([`Path`], from
//! the scene's solver plan), checked against the machine's available memory
//! ([`linpd_core::memory`]) when the scene is validated and again before it is solved, i.e.
//! before anything large is allocated.
//!
//! The bytes of each structure live in the crate that defines it, with the fit that produced
//! them (peak resident memory measured against these numbers in docs/solvers.md, "Memory
//! guard", and docs/robustness.md): the lattice's nodes and neighbour counts in
//! [`linpd_core::memory`], the bond family and stiffness in [`linpd_bond::memory`], the LPS
//! tangent in [`linpd_lps::memory`], the blends in [`linpd_blend::memory`], the solvers'
//! vectors and multigrid hierarchies in [`linpd_solve::memory`], explicit dynamics in
//! [`linpd_dynamics::memory`]. This module sums those a path names ([`estimate_counts`]) and
//! keeps what is the scene's own: the written outputs of a stencil solve
//! ([`stencil_dof_bytes`]) and of a graded solution drawn on the lattice
//! ([`GRADED_LATTICE_OUTPUT_BYTES`]), and the pair counts of a point cloud ([`count_pairs`]).
//!
//! The factors of a sparse Cholesky or LU are not in here: their fill is only known after the
//! symbolic analysis, where linpd-solve checks it ([`linpd_solve::Cholesky::factor`],
//! [`linpd_solve::Lu::factor`]).

use crate::ProblemError;
use linpd_blend::memory::{BLEND_ENTRY_BYTES, GRADED_NODE_BYTES};
use linpd_bond::memory::{BOND_BYTES, CLOUD_ENTRY_BYTES, ENTRY_BYTES};
pub use linpd_core::memory::neighbours;
use linpd_core::memory::{self, OutOfMemory, NODE_BYTES};
use linpd_core::Grid;
use linpd_dynamics::memory::DYNAMICS_DOF_BYTES;
pub use linpd_lps::memory::lps_assembly_terms;
use linpd_lps::memory::{
    lps_matrix_free_dof_bytes, tangent_rows, CLOUD_TANGENT_ENTRY_BYTES, LPS_ASSEMBLY_TERMS_LIMIT, LPS_BOND_BYTES,
    TANGENT_ENTRY_BYTES,
};
use linpd_solve::memory::{ASSEMBLED_DOF_BYTES, GMRES_DOF_BYTES, MATRIX_FREE_DOF_BYTES};
use linpd_solve::precond::kind::{Operator, SetupOn};
use linpd_solve::PreconditionerKind;

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

/// Per lattice node, the graded blend's solution drawn on every lattice node
/// (`output.nodes: "lattice"`): positions, `u`, volumes, strain, reactions and flags, and the
/// written files' buffers.
pub const GRADED_LATTICE_OUTPUT_BYTES: f64 = 200.0;

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
/// operator's `bonds` and the solve's vectors per DOF, and the setup of the preconditioners `setup`. The
/// estimate before the zones ([`Path::BlendAssembled`]) counts the bond model's entries, an
/// upper bound: `"auto"` zones on a cracked plate keep 0.36x of them.
pub fn blend_zone_bytes(dim: usize, nodes: usize, bonds: usize, blocks: f64, setup: &[PreconditionerKind]) -> f64 {
    let (n, dofs) = (nodes as f64, (nodes * dim) as f64);
    let on = SetupOn { dim, nodes, dofs: nodes * dim, operator: Operator::Assembled };
    let (hierarchy, _) = setup_bytes(setup, &on);
    n * NODE_BYTES
        + bonds as f64 * BOND_BYTES
        + blocks * (dim * dim) as f64 * BLEND_ENTRY_BYTES
        + dofs * (ASSEMBLED_DOF_BYTES + GMRES_DOF_BYTES)
        + hierarchy
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
/// large their volumes. `setup`: the preconditioners the solver plan sets up (`auto` on a bond
/// cloud may build a multigrid hierarchy). `Ok` holds the estimate in bytes.
pub fn check_cloud(
    path: Path,
    dim: usize,
    points: &[linpd_core::Point],
    horizon: f64,
    setup: &[PreconditionerKind],
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
    let (extra, said) = setup_bytes(setup, &SetupOn { dim, nodes: n, dofs: n * dim, operator: Operator::Assembled });
    bytes += extra;
    what += &said;
    let how = if partial || p { "extrapolated from the families counted" } else { "counted within the horizon" };
    memory::check(
        format!("{what} ({how})"),
        bytes,
        "use fewer nodes, a smaller horizon, or spread the nodes (their families, not their volumes, decide the size)",
    )
    .map_err(|e: OutOfMemory| ProblemError::invalid("model.horizon", e.to_string()))?;
    Ok(bytes)
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

/// The path of the homogeneous stencil of `micromodulus` on `grid`: [`Path::BondStencilGeometric`]
/// when it offers its coarse lattice, else [`Path::BondStencil`].
pub fn stencil_path(grid: &Grid, horizon: f64, micromodulus: &linpd_core::Micromodulus) -> Path {
    if linpd_bond::offers_coarse_lattice(grid, horizon, micromodulus) {
        Path::BondStencilGeometric
    } else {
        Path::BondStencil
    }
}

/// `Err` (at `model.horizon`) when `path` would not fit in the available memory; `Ok` holds
/// the estimate in bytes.
pub fn check(path: Path, grid: &Grid, horizon: f64) -> Result<f64, ProblemError> {
    check_solver(path, grid, horizon, &[])
}

/// The operator the preconditioner of `path` on `grid` is set up on ([`SetupOn`]): the
/// assembled matrix, the per-bond matrix-free operator, the stencil's bond graph, the
/// geometric lattice or the LPS pair part.
pub fn setup_on(path: Path, grid: &Grid, horizon: f64) -> SetupOn {
    let (dim, nodes) = (grid.dim(), grid.len());
    let ratio = horizon / grid.spacing();
    let bonds = || neighbours(dim, ratio).min(nodes as f64);
    let operator = match path {
        Path::BondStencilGeometric => Operator::GeometricStencil { ratio },
        Path::BondStencil => Operator::Stencil { bonds: bonds() },
        Path::LpsMatrixFree => Operator::Companion { bonds: bonds() },
        Path::BondMatrixFree => Operator::MatrixFree,
        _ => Operator::Assembled,
    };
    SetupOn { dim, nodes, dofs: nodes * dim, operator }
}

/// The largest setup of the preconditioners `setup` (a solver plan's,
/// [`linpd_solve::SolvePlan::preconditioners`]) on `on`, and what it adds to a description.
fn setup_bytes(setup: &[PreconditionerKind], on: &SetupOn) -> (f64, String) {
    match linpd_solve::precond::kind::largest_setup(setup, on) {
        Some((bytes, k)) if bytes > 0.0 && k.multilevel() => (bytes, " and its multigrid hierarchy".into()),
        Some((bytes, k)) if bytes > 0.0 => (bytes, format!(" and its {} preconditioner", k.name())),
        _ => (0.0, String::new()),
    }
}

/// [`check`] with the setup of the preconditioners `setup` counted (the solver plan's).
pub fn check_solver(path: Path, grid: &Grid, horizon: f64, setup: &[PreconditionerKind]) -> Result<f64, ProblemError> {
    let (mut what, mut bytes) = estimate(path, grid, horizon);
    let (extra, said) = setup_bytes(setup, &setup_on(path, grid, horizon));
    bytes += extra;
    what += &said;
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
