//! A rank's rows of the reduced system from its part of the scene alone (per-rank geometry,
//! docs/scale-out.md): the model is built on the rank's window ([`linpd_scene::part`]), the
//! rows of its owned nodes are exact (the halo holds everything they reach), and the global
//! numbering of the free DOFs comes from one exchange of per-plane counts.
//!
//! On a lattice the numbering is the whole scene's (the one of [`super::RowSystem`] and `linpd
//! export`): free DOFs ascend node-major, and the lattice's nodes ascend plane by plane along
//! the slowest axis, so the free DOFs of plane `k` are numbered from `sum_{l < k} c_l`, `c_l`
//! being plane `l`'s count of free DOFs. A point cloud's planes are its bins
//! ([`linpd_scene::part::Bins`]) and its window's nodes ascend bin by bin, then in file order:
//! the same rule numbers them, in that order rather than the file's
//! ([`linpd_scene::scene::PartScene::cloud`] maps a window node to its number in the file). A rank counts its owned planes' ([`PartRows::plane_free_counts`]);
//! the ranks gather everyone's, and [`PartRows::number`] numbers the window's free DOFs.
//!
//! What no window decides alone is handed to the caller to reduce: the presence checks
//! ([`linpd_scene::Problem::part`]), the resultant loads' volumes
//! ([`linpd_scene::Problem::resultant_volumes`]), the support check ([`PartRows::support`]:
//! the rigid modes' Gram matrices over the owned nodes, summed) and the force balance
//! ([`PartRows::balance`]).

use super::{block_rows, RowBlock};
use crate::models::{Capability, Purpose, System};
use crate::scene::PartBalance;
use crate::scene::Problem;
use crate::solution::Solution;
use crate::{ProblemError, Slab};
use linpd_core::RigidGram;
use linpd_solve::SolveReport;
use rayon::prelude::*;
use std::ops::Range;

/// A rank's rows of `A_ff u_f = f_f - (A u_bar)_f` (see the module docs).
pub struct PartRows {
    /// The system the scene's model built on the window.
    system: System,
    /// The scene it was built for.
    built_for: (String, &'static str),
    slab: Slab,
    /// The owned nodes (window numbering; contiguous, as the owned planes are).
    owned_nodes: Range<usize>,
    /// The owned free DOFs (the window's free numbering; contiguous).
    owned: Range<usize>,
    /// Free DOFs per owned plane.
    plane_free: Vec<usize>,
    /// Plane of each window node.
    plane_of: Vec<u32>,
    /// The window's DOF (`d * node + component`) of each owned row.
    row_dofs: Vec<usize>,
    /// `f_f - (A u_bar)_f` at the owned free DOFs.
    rhs: Vec<f64>,
    asymmetry: f64,
    /// After [`PartRows::number`]: the global row of each free DOF of the window, the first
    /// owned row and the total.
    numbering: Option<(Vec<usize>, usize, usize)>,
}

/// Builds rank's rows from its part `p` ([`Problem::from_path_part`]), whose resultant loads
/// know the whole body's volumes ([`Problem::with_resultant_volumes`]) when it has any.
/// Checks what a solve checks on the owned rows (finite loads and right-hand side, a positive
/// diagonal); the support is [`PartRows::support`]'s, over all ranks.
pub fn part_rows(p: &Problem) -> Result<PartRows, ProblemError> {
    let part = p.part().ok_or_else(|| ProblemError::invalid("ranks", "the scene is whole, not a rank's part"))?;
    let resultant = p.loads().iter().any(|l| matches!(l, crate::Load::Resultant { .. }));
    if resultant && part.resultant_volumes.is_none() {
        return Err(ProblemError::invalid(
            "loads",
            "a rank's resultant loads need the whole body's volumes (Problem::with_resultant_volumes)",
        ));
    }
    p.model().require(Capability::BlockRows)?;
    let system = p.model().system(p, Purpose::Rows, &linpd_core::NoProgress)?;
    let m = system.model();
    if m.n_nodes() > 0 && !m.for_each_block(0, &mut |_, _| {}) {
        return Err(ProblemError::invalid("model.type", format!("the {} model has no per-node block rows", m.kind())));
    }
    let d = p.dim();
    let slab = part.slab.clone();
    let plane_of = part.planes.clone();
    if plane_of.len() != m.n_nodes() || plane_of.windows(2).any(|w| w[0] > w[1]) {
        return Err(ProblemError::invalid("ranks", "the window's nodes are not in plane order"));
    }
    let first = plane_of.partition_point(|&k| (k as usize) < slab.owned.start);
    let last = plane_of.partition_point(|&k| (k as usize) < slab.owned.end);
    let dofs = system.bc.dofs();
    let free_before = |node: usize| (0..d * node).filter(|&g| !dofs.is_constrained(g)).count();
    let owned = free_before(first)..free_before(last);
    let mut plane_free = vec![0; slab.owned.len()];
    for n in first..last {
        let k = plane_of[n] as usize - slab.owned.start;
        plane_free[k] += (0..d).filter(|&a| !dofs.is_constrained(d * n + a)).count();
    }
    let rhs =
        linpd_solve::statics::reduced_rhs_of_rows(m, &system.bc, &system.f, owned.clone()).map_err(|e| match e {
            // a window's free DOF number means nothing outside the rank: name the node by its position
            linpd_solve::StaticError::AtDof {
                source: linpd_solve::SolveError::ZeroDiagonal { value, dof, .. },
                ..
            } => {
                let g = dofs.free_dofs()[dof];
                let x = p.nodes().position(g / d);
                ProblemError::invalid(
                    "constraints",
                    format!(
                    "the row system: the stiffness's diagonal entry at the node at {:?}, component {}, is {value:e}: \
                     the stiffness is singular there (a DOF nothing holds: a mechanism or a missing constraint)",
                    &x[..d],
                    g % d
                ),
                )
            }
            e => p.model().static_error(e),
        })?;
    let asymmetry = m.asymmetry(dofs);
    let row_dofs = (d * first..d * last).filter(|&g| !dofs.is_constrained(g)).collect();
    let built_for = (p.name().to_string(), p.model().name());
    Ok(PartRows {
        system,
        built_for,
        slab,
        owned_nodes: first..last,
        owned,
        plane_free,
        plane_of,
        row_dofs,
        rhs,
        asymmetry,
        numbering: None,
    })
}

impl PartRows {
    /// Dimension `d`.
    pub fn dim(&self) -> usize {
        self.system.model().dim()
    }
    /// The rank's slab.
    pub fn slab(&self) -> &Slab {
        &self.slab
    }
    /// Free DOFs of each owned plane, in plane order.
    pub fn plane_free_counts(&self) -> &[usize] {
        &self.plane_free
    }
    /// Numbers the window's free DOFs from every plane's count of free DOFs (`counts[k]` for
    /// plane `k`, all `planes` of them: the ranks' [`PartRows::plane_free_counts`] in rank
    /// order), which must agree with this rank's own over its whole window; nothing free in
    /// the whole scene is the static solve's error.
    pub fn number(&mut self, counts: &[usize]) -> Result<(), ProblemError> {
        let (d, dofs) = (self.dim(), self.system.bc.dofs());
        // every plane of the window, halo included, must count as the ranks that own it do
        let mut mine = vec![0usize; self.slab.window.len()];
        for (n, &k) in self.plane_of.iter().enumerate() {
            mine[k as usize - self.slab.window.start] += (0..d).filter(|&a| !dofs.is_constrained(d * n + a)).count();
        }
        if counts.len() != self.slab.planes || counts.get(self.slab.window.clone()) != Some(&mine[..]) {
            return Err(ProblemError::invalid(
                "ranks",
                format!(
                    "the per-plane free counts ({} planes) disagree with this rank's window ({} planes, window {:?}): \
                     every rank must read the same scene",
                    counts.len(),
                    self.slab.planes,
                    self.slab.window
                ),
            ));
        }
        let mut start = vec![0usize; counts.len() + 1];
        for k in 0..counts.len() {
            start[k + 1] = start[k] + counts[k];
        }
        if start[counts.len()] == 0 {
            return Err(ProblemError::Static(linpd_solve::StaticError::NothingFree));
        }
        let mut global = Vec::with_capacity(dofs.n_free());
        let mut next = start.clone();
        for (n, &k) in self.plane_of.iter().enumerate() {
            for a in 0..d {
                if !dofs.is_constrained(d * n + a) {
                    global.push(next[k as usize]);
                    next[k as usize] += 1;
                }
            }
        }
        let first = start[self.slab.owned.start];
        self.numbering = Some((global, first, start[counts.len()]));
        Ok(())
    }
    fn numbering(&self) -> Result<&(Vec<usize>, usize, usize), ProblemError> {
        self.numbering
            .as_ref()
            .ok_or_else(|| ProblemError::invalid("ranks", "number the rows first (PartRows::number)"))
    }
    /// Unknowns of the whole scene (after [`PartRows::number`]).
    pub fn n_global(&self) -> Result<usize, ProblemError> {
        Ok(self.numbering()?.2)
    }
    /// The rank's rows `first..last` in the global numbering (after [`PartRows::number`]).
    pub fn row_range(&self) -> Result<Range<usize>, ProblemError> {
        let first = self.numbering()?.1;
        Ok(first..first + self.owned.len())
    }
    /// The global row of every free DOF of the window, in the window's free order: where the
    /// window's values of a distributed solution are (its owned rows and its halo's).
    pub fn window_rows(&self) -> Result<&[usize], ProblemError> {
        Ok(&self.numbering()?.0)
    }
    /// The window's DOF (`d * node + component`) of every free DOF of the window, in the
    /// window's free order (that of [`PartRows::window_rows`]).
    pub fn window_free_dofs(&self) -> Vec<usize> {
        self.system.bc.dofs().free_dofs()
    }
    /// `f_f - (A u_bar)_f` of the owned rows.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }
    /// `max |A_ff - A_ff^T| / max |A_ff|` as the model bounds it on the window.
    pub fn asymmetry(&self) -> f64 {
        self.asymmetry
    }
    /// Whether `A_ff` is symmetric to [`linpd_core::sparse::SYMMETRY_RTOL`].
    pub fn is_symmetric(&self) -> bool {
        self.asymmetry <= linpd_core::sparse::SYMMETRY_RTOL
    }
    /// Whether every owned node has all or none of its components free (PETSc's block size `d`).
    pub fn whole_nodes(&self) -> bool {
        let (d, dofs) = (self.dim(), self.system.bc.dofs());
        self.owned_nodes.clone().all(|n| {
            let free = (0..d).filter(|&a| !dofs.is_constrained(d * n + a)).count();
            free == 0 || free == d
        })
    }
    /// The coordinate of each owned row's node along its component (PETSc's rigid-body modes).
    pub fn row_coordinates(&self) -> Vec<f64> {
        let (d, m, dofs) = (self.dim(), self.system.model(), self.system.bc.dofs());
        (d * self.owned_nodes.start..d * self.owned_nodes.end)
            .filter(|&g| !dofs.is_constrained(g))
            .map(|g| m.position(g / d)[g % d])
            .collect()
    }
    /// The owned rows `lo..hi` (counted from the rank's first row) of `A_ff` with global
    /// columns (after [`PartRows::number`]): the rank hands its rows to PETSc a chunk at a
    /// time, so that it never holds them twice.
    pub fn rows(&self, lo: usize, hi: usize) -> Result<RowBlock, ProblemError> {
        let (global, first, _) = self.numbering()?;
        if lo > hi || hi > self.owned.len() {
            return Err(ProblemError::invalid(
                "rows",
                format!("{lo}..{hi} is not a range of the rank's {} rows", self.owned.len()),
            ));
        }
        let d = self.dim();
        let mut nodes: Vec<usize> = self.row_dofs[lo..hi].iter().map(|g| g / d).collect();
        nodes.dedup();
        let keep = (self.owned.start + lo)..(self.owned.start + hi);
        let rows =
            block_rows(self.system.model(), self.system.bc.dofs(), &nodes, &|r| keep.contains(&r), &|c| global[c]);
        let rows = rows.into_iter().map(|(r, row)| (global[r], row)).collect();
        Ok(RowBlock::of(first + lo, first + hi, rows))
    }
    /// Per owned row, its entries in the rank's own columns and in the others' (PETSc's
    /// `d_nnz`, `o_nnz`), from the blocks' pattern ([`linpd_core::Model::for_each_coupled`]),
    /// without computing the rows: every free component of a node has the same columns.
    pub fn row_lengths(&self) -> Result<(Vec<u32>, Vec<u32>), ProblemError> {
        let (global, _, _) = self.numbering()?;
        let range = self.row_range()?;
        let (d, m, dofs) = (self.dim(), self.system.model(), self.system.bc.dofs());
        let per_node: Vec<(usize, u32, u32)> = self
            .owned_nodes
            .clone()
            .into_par_iter()
            .map(|i| {
                let (mut own, mut other) = (0u32, 0u32);
                m.for_each_coupled(i, &mut |j| {
                    for c in (0..d).filter_map(|c| dofs.free(d * j + c)) {
                        match range.contains(&global[c]) {
                            true => own += 1,
                            false => other += 1,
                        }
                    }
                });
                ((0..d).filter(|&a| !dofs.is_constrained(d * i + a)).count(), own, other)
            })
            .collect();
        let mut lengths = (Vec::with_capacity(range.len()), Vec::with_capacity(range.len()));
        for (rows, own, other) in per_node {
            lengths.0.extend(std::iter::repeat_n(own, rows));
            lengths.1.extend(std::iter::repeat_n(other, rows));
        }
        Ok(lengths)
    }
    /// The Gram matrices of the rigid modes over the owned nodes (all DOFs, held DOFs) about the
    /// centre of the lattice's body box, lengths scaled by its half diagonal: the ranks' sums
    /// added give the whole body's, whose [`RigidGram::free_modes`] must be 0. Treats the body
    /// as one piece: a piece that a crack or a gap cuts off is found by the KSP's failure.
    pub fn support(&self, p: &Problem) -> Result<RigidGram, ProblemError> {
        let d = self.dim();
        // the same centre and scale on every rank: the whole lattice's box or cloud's bounds
        let (lo, hi) = match (p.part().and_then(|part| part.cloud.as_ref()), p.grid()) {
            (Some(c), _) => (&c.bounds[0][..d], &c.bounds[1][..d]),
            (None, Some(grid)) => (grid.min(), grid.max()),
            (None, None) => return Err(ProblemError::invalid("ranks", "a part without a lattice or a cloud")),
        };
        let mut centre = [0.0; 3];
        (0..d).for_each(|a| centre[a] = 0.5 * (lo[a] + hi[a]));
        let size = 0.5 * (0..d).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
        let mut gram = RigidGram::new(d, centre, size);
        let dofs = self.system.bc.dofs();
        for n in self.owned_nodes.clone() {
            gram.add(&p.nodes().position(n), |a| dofs.is_constrained(d * n + a));
        }
        Ok(gram)
    }
    fn check_scene(&self, p: &Problem) -> Result<(), ProblemError> {
        match self.built_for == (p.name().to_string(), p.model().name()) {
            true => Ok(()),
            false => Err(ProblemError::invalid("rows", "these rows were built for another scene")),
        }
    }
    /// `u` over the window's DOFs from the window's free values (see [`PartRows::window_rows`]).
    fn expand(&self, u_window: &[f64]) -> Result<Vec<f64>, ProblemError> {
        let n = self.system.bc.dofs().n_free();
        if u_window.len() != n || u_window.iter().any(|x| !x.is_finite()) {
            return Err(ProblemError::invalid(
                "u",
                format!(
                    "needs {n} finite values (the window's free DOFs), got {} (or non-finite ones)",
                    u_window.len()
                ),
            ));
        }
        Ok(self.system.bc.expand(u_window))
    }
    /// The rank's share of the force balance for the window's free values `u_window`, moments
    /// about `reference` ([`Problem::part_balance`]).
    pub fn balance(&self, p: &Problem, u_window: &[f64], reference: &[f64]) -> Result<PartBalance, ProblemError> {
        self.check_scene(p)?;
        let u = self.expand(u_window)?;
        let m = self.system.model();
        Ok(p.part_balance(&|x, y| m.apply(x, y), &u, reference))
    }
    /// The solution on the owned nodes (its fields read the halo's values) for the window's
    /// free values `u_window`, `report` as the solve's report.
    pub fn solution(&self, p: &Problem, u_window: &[f64], report: SolveReport) -> Result<Solution, ProblemError> {
        self.check_scene(p)?;
        let u = self.expand(u_window)?;
        let whole = p.with_material(p.model().solution(p, &self.system, u, report)?);
        let nodes: Vec<usize> = self.owned_nodes.clone().collect();
        let mut piece = whole.restricted(&nodes);
        if let Some(cloud) = p.part().and_then(|part| part.cloud.as_ref()) {
            piece.file_node = Some(nodes.iter().map(|&k| cloud.file_node[k]).collect());
        }
        Ok(piece)
    }
}
