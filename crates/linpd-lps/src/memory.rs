//! The bytes and the work of the LPS model's structures, for the memory guard of a scene (which
//! sums what its solver plan names): the tangent (reach **2 delta**: `g_k g_k^T` couples the
//! family of a node with itself, so a column node has `|O - O|` row nodes, `O` the family
//! offsets with 0: 8.5x the bond neighbourhood at `delta = 2h` in 3D; the full tangent and its
//! restriction to the free DOFs coexist, with the 8-byte row lists of the pattern), its
//! matrix-free form and the pair part's multigrid. Fits of measured peaks; docs/robustness.md.

use linpd_core::family::lattice_stencil;
use linpd_core::memory::{ball, EXACT_STENCIL};
use std::collections::HashSet;

/// Per stored entry of the LPS tangent (the full tangent and its free-DOF copy).
pub const TANGENT_ENTRY_BYTES: f64 = 32.0;

/// Per stored entry of the LPS tangent on a point cloud (fits: 41.7-41.9 against the exact
/// count of node pairs within 2 delta).
pub const CLOUD_TANGENT_ENTRY_BYTES: f64 = 42.0;

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

/// Most column terms the LPS tangent's assembly may cost (`linpd_scene::memory::check_lps_work`): about 65 s at
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
