//! Rows of the reduced system on demand: the distributed path (PETSc through the Python
//! package, `python -m linpd.petsc`) assembles on each MPI rank only its own rows of
//!
//! ```text
//! A_ff u_f = f_f - (A u_bar)_f
//! ```
//!
//! (the system of [`crate::export`], numbered the same way: row `r` is the free DOF
//! `free_dofs[r]`), so that no rank holds the whole matrix.
//!
//! Row `r` with `free_dofs[r] = d i + a` is row `a` of block row `i` of `A`, restricted to the
//! free columns. [`linpd_core::Model::for_each_block`] computes a block row on demand; every
//! static model offers it, at these costs per rank (`|F|` partners per node, `n` nodes):
//!
//! * **bond** (lattice or point cloud): from node `i`'s bonds, `O(|F| d^2)` per node. Held whole
//!   on every rank: the bond family and weights (about `12` bytes per bond, a tenth of the
//!   assembled matrix's `d^2 (8 + 4)` bytes per bond block in PETSc's AIJ);
//! * **LPS**: the tangent couples nodes two horizons apart (the dilatation of a common
//!   partner); block row `i` is summed from the families of `i` and of its partners
//!   ([`linpd_lps::LpsModel::tangent_block_row`], the assembly's own per-node formulas),
//!   `O(|F|^2 d^2)` per node, about `|F|` times a bond row, and `O(|F|^2)` scratch. Held whole:
//!   the family, per-bond weights and lengths (`20` bytes per bond) and `m` per node; the rows
//!   themselves are about `|F|` times denser than the bond model's (the two-hop stencil);
//! * **coarsened** levels: read from the stored `K` (held whole on every rank, it is read from
//!   one file; the level is the coarse end of a hierarchy). A symmetric `K` gives its rows as
//!   its columns; an unsymmetric one gets a transposed copy built on the first row request
//!   (one more `16` bytes per stored entry, one `O(nnz)` pass), see
//!   [`linpd_core::AssembledModel`]. The row system shares the scene's `K` (no copy);
//! * **1D blend/CE**: the rows of the stored CSR operator (banded, `O(n eps / dx)` entries),
//!   nothing more.
//!
//! Refused by name ([`Capability::BlockRows`]): bond scenes with `model.pd_regions` (the 2D/3D blended model of
//! `linpd_blend::lattice`), which is assembled whole and has no block rows yet.
//!
//! The models that are not symmetric (blend, CE-blend, unsymmetric coarsened levels) report it
//! ([`RowSystem::is_symmetric`]: the model's [`linpd_core::Model::asymmetry`] against
//! [`linpd_core::sparse::SYMMETRY_RTOL`], as the static solve decides between CG and GMRES/LU),
//! so that the PETSc driver picks GMRES for them.
//!
//! A scene built whole gives every rank the vectors over all DOFs that the right-hand side
//! `f_f - (A u_bar)_f` needs; a rank's part ([`part_rows`], per-rank geometry) holds only its
//! window's.

mod part;

pub use part::{part_rows, PartRows};

use crate::models::{Capability, Purpose, System};
use crate::scene::Problem;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_core::sparse::SYMMETRY_RTOL;
use linpd_core::{DofMap, Model};
use linpd_solve::SolveReport;
use rayon::prelude::*;

/// One row of `A_ff`: its number and its `(column, value)` entries.
type Row = (usize, Vec<(usize, f64)>);

/// A scene's model with its Dirichlet split and reduced right-hand side, ready to hand out
/// blocks of rows of `A_ff` ([`RowSystem::rows`]).
pub struct RowSystem {
    /// The system the scene's model built (with what its solution needs).
    system: System,
    /// The scene (`name`) and model type it was built for.
    built_for: (String, &'static str),
    free_dofs: Vec<usize>,
    rhs: Vec<f64>,
    asymmetry: f64,
}

/// Rows `first..last` of `A_ff` in CSR form with global (reduced) column indices: row
/// `first + k` holds `indices[indptr[k]..indptr[k + 1]]` (ascending) and the matching `data`.
#[derive(Debug, Clone, PartialEq)]
pub struct RowBlock {
    /// First row (reduced numbering).
    pub first: usize,
    /// One past the last row.
    pub last: usize,
    /// Row pointers, `last - first + 1` of them, starting at 0.
    pub indptr: Vec<usize>,
    /// Column of each entry (reduced numbering), ascending within a row.
    pub indices: Vec<usize>,
    /// Value of each entry.
    pub data: Vec<f64>,
}

/// The scene's model (built as `linpd solve` builds it) and reduced right-hand side for
/// row-block assembly, with the checks of a solve (support, finite loads): every error a
/// solve of this scene would raise before its solver runs is raised here. Every model with
/// [`Capability::BlockRows`] (see the module docs for what each costs).
pub fn row_system(p: &Problem) -> Result<RowSystem, ProblemError> {
    refuse_part(p)?;
    p.model().require(Capability::BlockRows)?;
    let system = p.model().system(p, Purpose::Rows, &linpd_core::NoProgress)?;
    let m = system.model();
    // a model that claims block rows and has none is named, not mis-assembled
    if m.n_nodes() > 0 && !m.for_each_block(0, &mut |_, _| {}) {
        return Err(ProblemError::invalid(
            "model.type",
            format!(
                "the {} model has no per-node block rows (Model::for_each_block), so its rows cannot be assembled \
                 apart: use `linpd solve` or `linpd export`",
                m.kind()
            ),
        ));
    }
    let rhs = linpd_solve::reduced_rhs_checked(m, &system.bc, &system.f).map_err(|e| p.model().static_error(e))?;
    let asymmetry = m.asymmetry(system.bc.dofs());
    let free_dofs = system.bc.dofs().free_dofs();
    let built_for = (p.name().to_string(), p.model().name());
    Ok(RowSystem { system, built_for, free_dofs, rhs, asymmetry })
}

/// A rank's part is not a scene of its own: its window's rows and solve would be wrong at the
/// window's ends ([`part_rows`] is its row system).
fn refuse_part(p: &Problem) -> Result<(), ProblemError> {
    match p.part() {
        Some(_) => Err(ProblemError::invalid("ranks", "this is one rank's part of the scene: use part_rows")),
        None => Ok(()),
    }
}

/// The [`Solution`] `linpd solve` would write for displacements `u` over all DOFs computed
/// elsewhere (by PETSc), with `report` as the solve's report: the balance and the fields of
/// the scene's model ([`crate::models::SceneModel::solution`]). `u` must have one value per
/// DOF of `system` ([`RowSystem::dofs`]), which this scene must have built, and be finite.
pub fn solution_from(
    p: &Problem,
    system: &RowSystem,
    u: Vec<f64>,
    report: SolveReport,
) -> Result<Solution, ProblemError> {
    let n_dofs = system.dofs().n_dofs();
    if u.len() != n_dofs {
        return Err(ProblemError::invalid("u", format!("has {} values, the scene has {n_dofs} DOFs", u.len())));
    }
    // NaN or infinite displacements (a diverged or failed solve elsewhere) would be written as
    // `null` in result.json, NaN in u.csv and result.vtu, with a balance of 0
    if let Some(k) = u.iter().position(|x| !x.is_finite()) {
        let d = system.dim();
        let n_bad = u.iter().filter(|x| !x.is_finite()).count();
        return Err(ProblemError::invalid(
            "u",
            format!(
                "{n_bad} of the {n_dofs} displacements are not finite (first u[{k}] = {}, node {} component {}):                  the solve that computed them failed or diverged; nothing written",
                u[k],
                k / d,
                k % d
            ),
        ));
    }
    if system.built_for != (p.name().to_string(), p.model().name()) {
        return Err(ProblemError::invalid(
            "rows",
            format!(
                "the row system was built for the {} scene {:?}, this is the {} scene {:?}: build it with this \
                 scene's row_system",
                system.built_for.1,
                system.built_for.0,
                p.model().name(),
                p.name()
            ),
        ));
    }
    Ok(p.with_material(p.model().solution(p, &system.system, u, report)?))
}

impl RowSystem {
    /// Number of unknowns (rows of `A_ff`).
    pub fn n(&self) -> usize {
        self.free_dofs.len()
    }
    /// Dimension `d`.
    pub fn dim(&self) -> usize {
        self.model().dim()
    }
    /// The model.
    pub fn model(&self) -> &dyn Model {
        self.system.model()
    }
    /// The full DOF (`d * node + component`) of every row.
    pub fn free_dofs(&self) -> &[usize] {
        &self.free_dofs
    }
    /// The free/constrained split (of the model's nodes: for a blend scene with a coarse CE
    /// mesh these are the mesh's nodes, not the grid's).
    pub fn dofs(&self) -> &DofMap {
        self.system.bc.dofs()
    }
    /// `u = u_bar + u_f` over all DOFs from the values `u_free` of the unknowns (row order).
    pub fn expand(&self, u_free: &[f64]) -> Result<Vec<f64>, ProblemError> {
        if u_free.len() != self.n() {
            return Err(ProblemError::invalid(
                "u_free",
                format!("has {} values, the scene has {} unknowns", u_free.len(), self.n()),
            ));
        }
        Ok(self.system.bc.expand(u_free))
    }
    /// `max |A_ff - A_ff^T| / max |A_ff|` as the model bounds it ([`Model::asymmetry`]).
    pub fn asymmetry(&self) -> f64 {
        self.asymmetry
    }
    /// Whether `A_ff` is symmetric to [`SYMMETRY_RTOL`] (the static solve's test: CG when it
    /// is, GMRES or LU when it is not).
    pub fn is_symmetric(&self) -> bool {
        self.asymmetry <= SYMMETRY_RTOL
    }
    /// The reduced right-hand side `f_f - (A u_bar)_f`.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// Rows `first..last` of `A_ff` (see [`RowBlock`]), computed from the block rows of their
    /// nodes only. Every entry of the blocks the model offers at a free column is stored, zeros
    /// included; the assembled matrix of [`crate::ReducedSystem`] may store more explicit zeros
    /// (bonds a defect cuts; the LPS lattice pattern's structural zeros).
    pub fn rows(&self, first: usize, last: usize) -> Result<RowBlock, ProblemError> {
        let n = self.n();
        if first > last || last > n {
            return Err(ProblemError::invalid(
                "rows",
                format!("{first}..{last} is not a range of the {n} unknowns (need first <= last <= {n})"),
            ));
        }
        let d = self.dim();
        let rows = &self.free_dofs[first..last];
        // the nodes of the range, in order (rows are node-major, so each node's rows are adjacent)
        let mut nodes: Vec<usize> = rows.iter().map(|g| g / d).collect();
        nodes.dedup();
        let rows = block_rows(self.model(), self.dofs(), &nodes, &|r| (first..last).contains(&r), &|c| c);
        Ok(RowBlock::of(first, last, rows))
    }
}

impl RowBlock {
    /// The block of rows `first..last` from `rows` (in order, one per row of the range).
    fn of(first: usize, last: usize, rows: Vec<Row>) -> RowBlock {
        let mut block = RowBlock { first, last, indptr: vec![0], indices: Vec::new(), data: Vec::new() };
        for (r, row) in rows {
            debug_assert_eq!(r, first + block.indptr.len() - 1);
            block.indices.extend(row.iter().map(|e| e.0));
            block.data.extend(row.iter().map(|e| e.1));
            block.indptr.push(block.indices.len());
        }
        block
    }
}

/// The rows of `A_ff` of `nodes` (ascending) whose free index `keep` accepts, from the nodes'
/// block rows, in row order, each sorted by column after its free indices `c` are renumbered
/// `column(c)`.
fn block_rows(
    model: &dyn Model,
    dofs: &DofMap,
    nodes: &[usize],
    keep: &(dyn Fn(usize) -> bool + Sync),
    column: &(dyn Fn(usize) -> usize + Sync),
) -> Vec<Row> {
    let d = model.dim();
    let per_node: Vec<Vec<Row>> = nodes
        .par_iter()
        .map(|&i| {
            let mut block_row: Vec<Vec<(usize, f64)>> = vec![Vec::new(); d];
            let offered = model.for_each_block(i, &mut |j, b| {
                for c in 0..d {
                    if let Some(col) = dofs.free(d * j + c) {
                        for (a, row) in block_row.iter_mut().enumerate() {
                            row.push((column(col), b[a * d + c]));
                        }
                    }
                }
            });
            debug_assert!(offered, "row_system checked that the model has block rows");
            (0..d)
                .filter_map(|a| dofs.free(d * i + a).filter(|&r| keep(r)).map(|r| (r, a)))
                .map(|(r, a)| {
                    let mut row = std::mem::take(&mut block_row[a]);
                    row.sort_unstable_by_key(|e| e.0);
                    (r, row)
                })
                .collect()
        })
        .collect();
    per_node.into_iter().flatten().collect()
}
