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
//! free columns. [`linpd_core::Model::for_each_block`] computes a block row from the model's
//! bonds without assembling anything else; bond models (on a lattice or a point cloud) offer it.
//! LPS, coarsened and 1D blend/CE models do not: [`Problem::row_system`] says so.
//!
//! What each rank still holds whole: the model's bond family and weights (about `12` bytes per
//! bond, a tenth of the assembled matrix's `d^2 (8 + 4)` bytes per bond block in PETSc's AIJ) and
//! the vectors over all DOFs that the right-hand side `f_f - (A u_bar)_f` needs; see
//! `docs/scale-out.md` for the plan that removes them (per-rank geometry).

use crate::run::static_error;
use crate::{ModelSpec, Problem, ProblemError, Solution};
use linpd_core::{DofMap, Model};
use linpd_solve::SolveReport;
use rayon::prelude::*;

/// One row of `A_ff`: its number and its `(column, value)` entries.
type Row = (usize, Vec<(usize, f64)>);

/// A scene's model with its Dirichlet split and reduced right-hand side, ready to hand out
/// blocks of rows of `A_ff` ([`RowSystem::rows`]).
pub struct RowSystem {
    model: Box<dyn Model + Send + Sync>,
    n_bonds: usize,
    dofs: DofMap,
    free_dofs: Vec<usize>,
    rhs: Vec<f64>,
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

impl Problem {
    /// The scene's model and reduced right-hand side for row-block assembly, with the checks
    /// of a solve (support, finite loads): every error a solve of this scene would raise before
    /// its solver runs is raised here. Bond models only (see the module docs).
    pub fn row_system(&self) -> Result<RowSystem, ProblemError> {
        // `n_bonds` as `linpd solve` counts them (cut bonds included)
        let (model, n_bonds): (Box<dyn Model + Send + Sync>, usize) = match &self.model {
            ModelSpec::Bond(_) if self.nodes.cloud().is_some() => {
                let op = self.operator()?;
                let n_bonds = op.family().n_bonds();
                (Box::new(op), n_bonds)
            }
            ModelSpec::Bond(b) if b.zone.is_some() => {
                return Err(ProblemError::invalid(
                    "model.pd_regions",
                    "row-block assembly (the distributed path) does not take blended scenes yet: the blended \
                     model is assembled whole; use `linpd solve` or `linpd export`",
                ))
            }
            ModelSpec::Bond(_) => {
                let model = self.lattice_model()?;
                let n_bonds = model.operator().family().n_bonds();
                (Box::new(model), n_bonds)
            }
            other => {
                return Err(ProblemError::invalid(
                    "model.type",
                    format!(
                    "row-block assembly (the distributed path) is available for bond models only, the scene has {}: \
                         its model has no per-node block rows yet; use `linpd solve` or `linpd export`",
                    other.name()
                ),
                ))
            }
        };
        let bc = self.dirichlet();
        let rhs = linpd_solve::reduced_rhs_checked(model.as_ref(), &bc, &self.load_vector()).map_err(static_error)?;
        let dofs = bc.dofs().clone();
        let free_dofs = dofs.free_dofs();
        Ok(RowSystem { model, n_bonds, dofs, free_dofs, rhs })
    }

    /// The [`Solution`] of a bond scene for displacements `u` over all DOFs computed elsewhere
    /// (by PETSc): the balance, strain energy density and strain `linpd solve` reports, with
    /// `report` as the solve's report. `u` must have `d * nodes` entries.
    pub fn solution_from(
        &self,
        system: &RowSystem,
        u: Vec<f64>,
        report: SolveReport,
    ) -> Result<Solution, ProblemError> {
        let model = system.model.as_ref();
        if u.len() != system.dofs.n_dofs() {
            return Err(ProblemError::invalid(
                "u",
                format!("has {} values, the scene has {} DOFs", u.len(), system.dofs.n_dofs()),
            ));
        }
        self.bond_solution(model, system.n_bonds, u, report)
    }
}

impl RowSystem {
    /// Number of unknowns (rows of `A_ff`).
    pub fn n(&self) -> usize {
        self.free_dofs.len()
    }
    /// Dimension `d`.
    pub fn dim(&self) -> usize {
        self.model.dim()
    }
    /// The model.
    pub fn model(&self) -> &dyn Model {
        self.model.as_ref()
    }
    /// The full DOF (`d * node + component`) of every row.
    pub fn free_dofs(&self) -> &[usize] {
        &self.free_dofs
    }
    /// The free/constrained split.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }
    /// The reduced right-hand side `f_f - (A u_bar)_f`.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// Rows `first..last` of `A_ff` (see [`RowBlock`]), computed from the block rows of their
    /// nodes only. Every entry of those block rows at a free column is stored, zeros included
    /// (the pattern of [`crate::ReducedSystem`]'s matrix for bond models).
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
        let per_node: Vec<Vec<Row>> = nodes
            .par_iter()
            .map(|&i| {
                let mut block_row: Vec<Vec<(usize, f64)>> = vec![Vec::new(); d];
                let offered = self.model.for_each_block(i, &mut |j, b| {
                    for c in 0..d {
                        if let Some(col) = self.dofs.free(d * j + c) {
                            for (a, row) in block_row.iter_mut().enumerate() {
                                row.push((col, b[a * d + c]));
                            }
                        }
                    }
                });
                debug_assert!(offered, "row_system admits models with block rows only");
                (0..d)
                    .filter_map(|a| self.dofs.free(d * i + a).filter(|r| (first..last).contains(r)).map(|r| (r, a)))
                    .map(|(r, a)| {
                        let mut row = std::mem::take(&mut block_row[a]);
                        row.sort_unstable_by_key(|e| e.0);
                        (r, row)
                    })
                    .collect()
            })
            .collect();
        let mut block = RowBlock { first, last, indptr: vec![0], indices: Vec::new(), data: Vec::new() };
        for (r, row) in per_node.into_iter().flatten() {
            debug_assert_eq!(r, first + block.indptr.len() - 1);
            block.indices.extend(row.iter().map(|e| e.0));
            block.data.extend(row.iter().map(|e| e.1));
            block.indptr.push(block.indices.len());
        }
        Ok(block)
    }
}
