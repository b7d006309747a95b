//! The bytes of the solvers' structures per DOF, for the memory guard of a scene (which sums
//! what its solver plan names, [`mod@crate::plan`]): the vectors of an assembled solve and of
//! matrix-free CG, GMRES's Krylov basis, and the multigrid hierarchies (smoothed aggregation on
//! an assembled matrix, on a matrix-free operator's block rows, on a lattice stencil's bond
//! graph). Fits of measured peaks against the same runs with Jacobi; docs/robustness.md.
//!
//! The factors of a sparse Cholesky or LU are not in here: their fill is only known after the
//! symbolic analysis, where they are checked ([`crate::Cholesky::factor`], [`crate::Lu::factor`]).

/// Per DOF, assembled solve.
pub const ASSEMBLED_DOF_BYTES: f64 = 128.0;

/// Per DOF, matrix-free CG.
pub const MATRIX_FREE_DOF_BYTES: f64 = 176.0;

/// Per DOF, GMRES on top of an assembled solve's vectors: the restart-50 Krylov basis.
pub const GMRES_DOF_BYTES: f64 = 408.0;

/// Per bond (counted from both ends), the interaction graph multigrid aggregates its finest
/// level on (`linpd_solve::DofGeometry::partners`: one `u32`).
pub const GRAPH_BOND_BYTES: f64 = 4.0;

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

/// Per DOF, what smoothed-aggregation multigrid adds to `linpd_scene::memory::stencil_dof_bytes` besides the bond
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
/// peak (`linpd_scene::memory::stencil_dof_bytes`) for `nodes` nodes with `ratio = delta / h`
/// ([`crate::LatticeMultigrid`]): the SA hierarchy of the coarse lattice, an eighth of the
/// nodes with the families of `ratio / 2`, counted like [`stencil_multigrid_dof_bytes`]; the
/// interpolation (8 bytes an entry, ~3.4 entries a fine DOF, and its transpose) and the
/// smoother's vectors are freed before the outputs are built. Against `/usr/bin/time` peaks of
/// `linpd solve` on the 56^3 / 76^3 cantilevers at `delta = 3h`: estimates 1.04x / 1.06x.
pub fn geometric_multigrid_bytes(nodes: usize, ratio: f64) -> f64 {
    let coarse_nodes = nodes as f64 / 8.0;
    let nb = linpd_core::memory::neighbours(3, ratio / 2.0).min(coarse_nodes);
    coarse_nodes * (3.0 * stencil_multigrid_dof_bytes(3) + nb * GRAPH_BOND_BYTES)
}

/// Per DOF, what multigrid on an SPD companion's block rows adds to a matrix-free solve besides
/// its bond graph ([`GRAPH_BOND_BYTES`] a bond), measured on the LPS tangent's pair part against
/// `linpd_lps::memory::lps_matrix_free_dof_bytes`: the same fits with multigrid-CG put the peak
/// 973-979 bytes a DOF above Jacobi's in 3D (163 of them the graph) and 373-379 in 2D (56).
pub fn companion_multigrid_dof_bytes(dim: usize) -> f64 {
    if dim == 3 {
        820.0
    } else {
        320.0
    }
}
