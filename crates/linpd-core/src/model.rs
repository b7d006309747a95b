//! The one interface of a static linear PD model.
//!
//! Every model (bond-based, LPS, coarsened level, ...) is a linear map from nodal displacements
//! to nodal forces, `F_int = -A u`, with `A` the stiffness: `d` DOFs per node, numbered
//! node-major ([`crate::DofMap`]). What a solver needs of a model, and nothing else, is here:
//!
//! * geometry: the dimension, the node positions, and which nodes interact (the pairs with a
//!   nonzero coupling, for the rigid-motion check of [`crate::support`]);
//! * `A` three ways: applied over all DOFs ([`Model::apply`], for the constrained right-hand
//!   side `f - A u_bar` and matrix-free Krylov), its diagonal (Jacobi), and assembled on the
//!   free DOFs only ([`Model::assemble_free`], never the full matrix when the model can avoid
//!   it);
//! * solver hints: whether `A` is symmetric ([`Model::asymmetry`]), a fill-reducing ordering
//!   for a sparse Cholesky ([`Model::ordering`]), a cheaper matrix-free apply
//!   ([`Model::fast_apply`]).
//!
//! The Dirichlet elimination and the solver dispatch are written once, in `linpd-solve`,
//! against this trait; a new model implements it and is solved by every solver.

use crate::op::LinearOperator;
use crate::progress::{Progress, Task};
use crate::sparse::Csc;
use crate::{DofMap, Point};

/// A fill-reducing ordering for a sparse Cholesky of `A_ff`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ordering {
    /// faer's approximate minimum degree.
    Amd,
    /// The natural order (already fill-optimal for a 1D lattice).
    Natural,
    /// The natural order of a banded `A` (1D models): Cholesky and LU both keep the band (the
    /// LU analysis is told not to reorder columns).
    Band,
    /// A model-specific permutation `perm[new] = old` of the free DOFs (e.g. nested dissection
    /// on the lattice).
    NestedDissection(Vec<usize>),
}

/// Which SPD approximation of an unsymmetric `A` a model offers (for reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpdApproximationKind {
    /// A model-specific SPD rewrite (e.g. the blended model's local part in divergence form).
    DivergenceForm,
    /// The symmetric part `(A_ff + A_ff^T) / 2`.
    SymmetricPart,
    /// An energy (symmetric positive semi-definite by construction) close to `A`: the 2D/3D
    /// blended model's shares and elements without its transition terms.
    EnergyForm,
}

/// An SPD matrix `M_ff` close to an unsymmetric `A_ff`: GMRES preconditioned with its
/// Cholesky factor needs a handful of iterations where `A - M` is small.
#[derive(Debug, Clone)]
pub struct SpdApproximation {
    /// `M_ff` on the free DOFs (both triangles).
    pub matrix: Csc,
    /// What it is.
    pub kind: SpdApproximationKind,
}

/// A cheaper way to apply `A` over all DOFs than [`Model::apply`], with a label for reports.
pub struct FastApply<'a> {
    /// `y = A x` over all DOFs.
    pub op: Box<dyn LinearOperator + 'a>,
    /// What it is (`"stencil"`), appended to the solver's name in reports.
    pub label: &'static str,
}

/// The same model re-discretized on the lattice of twice the spacing: the coarse level of a
/// geometric multigrid ([`Model::coarse_lattice`]).
///
/// The fine model's nodes are the sites of a full lattice box with `counts` sites per axis,
/// numbered lexicographically (axis 0 fastest); the coarse model's nodes are the sites
/// `(2I, 2J, 2K)` of that lattice, extended by one fine spacing where a count is even, so
/// that every fine site lies in a coarse cell: coarse node `(I, J, K)` is number
/// `I + nc_0 (J + nc_1 K)` with `nc_a = ceil((counts_a - 1) / 2) + 1`.
pub struct CoarseLattice<'a> {
    /// The coarse model (same material and horizon, spacing `2h`).
    pub model: Box<dyn Model + 'a>,
    /// Fine sites per axis (1 on unused axes).
    pub counts: [usize; 3],
}

impl CoarseLattice<'_> {
    /// Coarse sites per axis for `counts` fine sites (see the type's docs).
    pub fn coarse_counts(counts: [usize; 3]) -> [usize; 3] {
        counts.map(|n| (n.max(1) - 1).div_ceil(2) + 1)
    }
}

/// A homogeneous bond model on a full lattice box, as its stencil: node `i` (site `(i_0, i_1,
/// i_2)`, numbered lexicographically with axis 0 fastest) is bonded to the site `i + k_s` of
/// every offset `k_s` that stays in the box, with the block `A_ij = -K_s` (and `A_ii = sum_s
/// K_s`). Loops over bonds (the nodal fields) run on it without a call per bond.
#[derive(Clone, Copy)]
pub struct LatticeStencil<'a> {
    /// Sites per axis (1 on unused axes).
    pub counts: [usize; 3],
    /// The lattice offsets `k_s`.
    pub offsets: &'a [[i64; 3]],
    /// `K_s`, row-major `d x d` in the first `d * d` entries.
    pub blocks: &'a [[f64; 9]],
    /// The lattice spacing `h` (`xi_s = h k_s`).
    pub spacing: f64,
}

impl LatticeStencil<'_> {
    /// Calls `f(j, s)` for the node `j = i + k_s` of every offset `s` that stays in the box,
    /// in offset order ([`crate::grid::for_each_box_offset`]).
    #[inline]
    pub fn for_each_bond(&self, i: usize, f: impl FnMut(usize, usize)) {
        crate::grid::for_each_box_offset(i, self.counts, self.offsets, f)
    }
}

/// A static linear peridynamic model: `F_int = -A u` (see the module docs).
pub trait Model: Sync {
    /// The model family for messages (`"bond"`, `"lps"`, `"coarsened"`).
    fn kind(&self) -> &'static str;
    /// Spatial dimension `d` (DOFs per node).
    fn dim(&self) -> usize;
    /// Number of nodes.
    fn n_nodes(&self) -> usize;
    /// Position of node `i` (unused coordinates 0).
    fn position(&self, i: usize) -> Point;
    /// Calls `f(j)` for every node `j != i` coupled to `i` by a nonzero stiffness block
    /// (order and repeats do not matter). Only connectivity is asked: for the LPS model the
    /// bond family suffices (the two-horizon couplings connect the same pieces).
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize));
    /// `y = A u` over all `d * n_nodes` DOFs.
    fn apply(&self, u: &[f64], y: &mut [f64]);
    /// The diagonal of `A` over all DOFs.
    fn diagonal(&self) -> Vec<f64>;
    /// `A_ff`: the rows and columns of the free DOFs of `dofs`, assembled (both triangles,
    /// sorted rows in each column).
    fn assemble_free(&self, dofs: &DofMap) -> Csc;
    /// [`Model::assemble_free`] reporting to `progress`: by default a task `"assembling"` with
    /// no steps around it; a model whose assembly loops over nodes reports them (the bond model).
    fn assemble_free_with_progress(&self, dofs: &DofMap, progress: &dyn Progress) -> Csc {
        let _task = Task::start(progress, "assembling", None);
        self.assemble_free(dofs)
    }
    /// `max |A_ff - A_ff^T| / max |A_ff|` over the free DOFs of `dofs` (a model may return a
    /// bound, e.g. that of the full `A`); the solvers treat `A_ff` as symmetric when it is at
    /// most [`crate::sparse::SYMMETRY_RTOL`].
    fn asymmetry(&self, _dofs: &DofMap) -> f64 {
        0.0
    }
    /// A fill-reducing ordering of the free DOFs for a sparse Cholesky.
    fn ordering(&self, _dofs: &DofMap) -> Ordering {
        Ordering::Amd
    }
    /// A cheaper matrix-free apply than [`Model::apply`], if the model has one.
    fn fast_apply(&self) -> Option<FastApply<'_>> {
        None
    }
    /// For an unsymmetric `A`: an SPD approximation of `A_ff` whose Cholesky factor
    /// preconditions GMRES under `auto` (`None`: `auto` uses sparse LU).
    fn spd_approximation(&self, _dofs: &DofMap) -> Option<SpdApproximation> {
        None
    }
    /// The nonzero `d x d` blocks of block row `i` of `A` over all DOFs, computed on demand:
    /// `f(j, A_ij)` (row-major) for every coupled node `j`, `j = i` included, each `j` once,
    /// in any order. Multigrid builds its hierarchy from them without storing the finest
    /// matrix (`"matrix_free": true`). Returns `false` when the model cannot (the default; `f`
    /// is then not called).
    fn for_each_block(&self, _i: usize, _f: &mut dyn FnMut(usize, &[f64])) -> bool {
        false
    }
    /// The nodes `j` of the blocks [`Model::for_each_block`] offers for row `i` (`j = i`
    /// included, each once, in any order), without computing the blocks: what a sparse matrix's
    /// preallocation needs. `false` when the model has no block rows. The default computes
    /// the blocks and drops them; a model whose blocks cost more than their pattern overrides it.
    fn for_each_coupled(&self, i: usize, f: &mut dyn FnMut(usize)) -> bool {
        self.for_each_block(i, &mut |j, _| f(j))
    }
    /// The model as a lattice stencil, when it is one ([`LatticeStencil`]; the homogeneous
    /// bond lattice). `None` (the default): loops over bonds go through
    /// [`Model::for_each_block`].
    fn lattice_stencil(&self) -> Option<LatticeStencil<'_>> {
        None
    }
    /// The diagonal block `A_ii` of node `i` (row-major `d x d` into `out`); `false` when
    /// the model has no blocks ([`Model::for_each_block`], which the default reads: a whole
    /// block row for one block; a lattice stencil answers from its boundary classes).
    fn diagonal_block(&self, i: usize, out: &mut [f64]) -> bool {
        let d = self.dim();
        self.for_each_block(i, &mut |j, b| {
            if j == i {
                out[..d * d].copy_from_slice(&b[..d * d]);
            }
        })
    }
    /// An SPD model spectrally equivalent to `A` (`c_1 M <= A <= c_2 M` with a modest
    /// `c_2 / c_1`, stated by the model) on the same nodes, whose block rows are much cheaper
    /// than `A`'s: the matrix-free multigrid builds its whole hierarchy (levels, smoothers) from
    /// it and preconditions CG on `A` with it. `None` (the default): the hierarchy is `A`'s
    /// own. The LPS tangent offers its pair part (one horizon against two).
    fn multigrid_companion(&self) -> Option<Box<dyn Model + '_>> {
        None
    }
    /// The model re-discretized on the lattice of twice its spacing, when it is a homogeneous
    /// lattice model for which that coarse model is a good coarse space (see
    /// [`CoarseLattice`]); the matrix-free multigrid then puts a geometric level on top of its
    /// algebraic ones. `None` (the default): algebraic levels only. A model that offers it
    /// must be a sum of positive semi-definite pair terms,
    /// `u^T A u = sum (u_i - u_j)^T K_ij (u_i - u_j)` (bond-based), so that
    /// `A <= 2 blockdiag(A)`: the geometric level's smoother takes that bound as its spectral
    /// radius.
    fn coarse_lattice(&self) -> Option<CoarseLattice<'_>> {
        None
    }
    /// Why the model cannot run matrix-free (`None`: it can).
    fn matrix_free_unavailable(&self) -> Option<&'static str> {
        None
    }
    /// Describes node `i` for an error message (position, and e.g. its level-0 number).
    fn describe_node(&self, i: usize) -> String {
        let x = self.position(i);
        format!("node {i} at {:?}", &x[..self.dim()])
    }
}

/// Number of DOFs of a model.
pub fn n_dofs(model: &dyn Model) -> usize {
    model.dim() * model.n_nodes()
}

/// `A_ff` of a model assembled from its block rows ([`Model::for_each_block`]; `None` when
/// the model has none): the free entries of every block, summed where repeated. What a model
/// whose rows are computed on demand answers to [`Model::assemble_free`].
pub fn assemble_free_from_blocks(model: &dyn Model, dofs: &DofMap) -> Option<Csc> {
    use rayon::prelude::*;
    let d = model.dim();
    let mut has_blocks = true;
    if model.n_nodes() > 0 {
        has_blocks = model.for_each_block(0, &mut |_, _| {});
    }
    if !has_blocks {
        return None;
    }
    let triplets: Vec<faer::sparse::Triplet<usize, usize, f64>> = (0..model.n_nodes())
        .into_par_iter()
        .flat_map_iter(|i| {
            let mut out = Vec::new();
            model.for_each_block(i, &mut |j, b| {
                for a in 0..d {
                    for c in 0..d {
                        if let (Some(r), Some(col)) = (dofs.free(d * i + a), dofs.free(d * j + c)) {
                            out.push(faer::sparse::Triplet::new(r, col, b[a * d + c]));
                        }
                    }
                }
            });
            out
        })
        .collect();
    let n = dofs.n_free();
    Some(Csc::try_new_from_triplets(n, n, &triplets).expect("free DOFs index an n x n matrix"))
}

/// A model's full-DOF `apply` as a [`LinearOperator`].
pub struct ModelOperator<'a>(pub &'a dyn Model);

impl LinearOperator for ModelOperator<'_> {
    fn n(&self) -> usize {
        n_dofs(self.0)
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.apply(x, y)
    }
}

/// A model given by its assembled stiffness `K` over all DOFs (a coarsened level read from a
/// file, a matrix from elsewhere): `apply` is the CSC product, the interaction graph is the
/// pattern of the nonzero off-diagonal blocks.
#[derive(Debug, Clone)]
pub struct AssembledModel {
    kind: &'static str,
    dim: usize,
    positions: Vec<Point>,
    k: Csc,
    /// Computed on first use (a hash over the entries of `K`).
    asymmetry: std::sync::OnceLock<f64>,
    /// `K^T` in CSC (the rows of `K`), built on the first block row of an unsymmetric `K`
    /// ([`Model::for_each_block`]).
    rows: std::sync::OnceLock<Csc>,
    partners: crate::BondFamily,
    labels: Option<(&'static str, Vec<usize>)>,
}

/// The interaction graph of `K` over `n` nodes of `dim` DOFs: `j` is in the list of `i`, and
/// `i` in that of `j`, when `K_ij` or `K_ji` (`i != j`) has a nonzero entry; each list sorted,
/// without repeats. In parallel over the column blocks (`K_ij != 0` seen from column node `j`),
/// the other direction by a counting sort over those lists, then one merge per node.
fn block_partners(k: &Csc, dim: usize, n: usize) -> Vec<Vec<u32>> {
    use rayon::prelude::*;
    let (cp, ri, val) = (k.symbolic().col_ptr(), k.symbolic().row_idx(), k.val());
    // by_col[j]: the nodes i != j with K_ij != 0
    let by_col: Vec<Vec<u32>> = (0..n)
        .into_par_iter()
        .map(|j| {
            let mut l: Vec<u32> = (dim * j..dim * (j + 1))
                .flat_map(|c| cp[c]..cp[c + 1])
                .filter(|&p| val[p] != 0.0 && ri[p] / dim != j)
                .map(|p| (ri[p] / dim) as u32)
                .collect();
            l.sort_unstable();
            l.dedup();
            l
        })
        .collect();
    // by_row[i]: the nodes j with i in by_col[j], ascending (j visited in order)
    let mut start = vec![0usize; n + 1];
    for &i in by_col.iter().flatten() {
        start[i as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut by_row = vec![0u32; start[n]];
    for (j, l) in by_col.iter().enumerate() {
        for &i in l {
            by_row[next[i as usize]] = j as u32;
            next[i as usize] += 1;
        }
    }
    by_col
        .par_iter()
        .enumerate()
        .map(|(i, a)| {
            let b = &by_row[start[i]..start[i + 1]];
            let mut out = Vec::with_capacity(a.len().max(b.len()));
            let (mut p, mut q) = (0, 0);
            while p < a.len() || q < b.len() {
                let next = match (a.get(p), b.get(q)) {
                    (Some(&x), Some(&y)) if x == y => {
                        p += 1;
                        q += 1;
                        x
                    }
                    (Some(&x), Some(&y)) if x < y => {
                        p += 1;
                        x
                    }
                    (Some(&x), None) => {
                        p += 1;
                        x
                    }
                    (_, Some(&y)) => {
                        q += 1;
                        y
                    }
                    (None, None) => unreachable!("the loop condition"),
                };
                out.push(next);
            }
            out
        })
        .collect()
}

impl AssembledModel {
    /// `K` (`dim * positions.len()` square) on the nodes at `positions`; `kind` names the model
    /// in messages.
    pub fn new(kind: &'static str, dim: usize, positions: Vec<Point>, k: Csc) -> Self {
        assert_eq!(k.nrows(), dim * positions.len(), "K size");
        let lists = block_partners(&k, dim, positions.len());
        AssembledModel {
            kind,
            dim,
            positions,
            k,
            asymmetry: std::sync::OnceLock::new(),
            rows: std::sync::OnceLock::new(),
            partners: crate::BondFamily::from_lists(lists),
            labels: None,
        }
    }

    /// Names every node in messages also by `label` (e.g. `"level-0 node"`) and its number.
    pub fn with_labels(mut self, label: &'static str, numbers: Vec<usize>) -> Self {
        assert_eq!(numbers.len(), self.positions.len(), "one number per node");
        self.labels = Some((label, numbers));
        self
    }

    /// The stiffness over all DOFs.
    pub fn stiffness(&self) -> &Csc {
        &self.k
    }

    /// `max |K - K^T| / max |K|` over all DOFs (computed once).
    pub fn stiffness_asymmetry(&self) -> f64 {
        *self.asymmetry.get_or_init(|| crate::sparse::relative_asymmetry(&self.k))
    }

    /// The interaction graph (nonzero off-diagonal blocks, both directions).
    pub fn partners(&self) -> &crate::BondFamily {
        &self.partners
    }

    /// The CSC arrays whose column `r` holds row `r` of `K`: `K` itself when it is exactly
    /// symmetric, else its transpose, built once on the first call: one more copy of `K`
    /// (`16` bytes per stored entry plus `8` per DOF) and one `O(nnz)` counting-sort pass.
    fn row_major(&self) -> &Csc {
        if self.stiffness_asymmetry() == 0.0 {
            return &self.k;
        }
        self.rows.get_or_init(|| {
            let (cp, ri, val) = (self.k.symbolic().col_ptr(), self.k.symbolic().row_idx(), self.k.val());
            // the CSR arrays of K are the CSC arrays of K^T
            crate::sparse::csr_to_csc(self.k.nrows(), cp, ri, val)
        })
    }
}

impl Model for AssembledModel {
    fn kind(&self) -> &'static str {
        self.kind
    }
    fn dim(&self) -> usize {
        self.dim
    }
    fn n_nodes(&self) -> usize {
        self.positions.len()
    }
    fn position(&self, i: usize) -> Point {
        self.positions[i]
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        self.partners.neighbors(i).iter().for_each(|&j| f(j as usize));
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        crate::sparse::matvec(&self.k, u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        crate::sparse::diagonal(&self.k)
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        crate::sparse::restrict_to_free(&self.k, dofs)
    }
    /// That of the full `K`: a bound for `A_ff`, computed once whatever the constraints.
    fn asymmetry(&self, _dofs: &DofMap) -> f64 {
        self.stiffness_asymmetry()
    }
    /// From the stored `K`: the `d` rows of node `i` (see `AssembledModel::row_major` for
    /// what the first call costs on an unsymmetric `K`), grouped by column node; the diagonal
    /// block always, off-diagonal blocks with a nonzero entry. Duplicate entries are summed.
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        let d = self.dim;
        let t = self.row_major();
        let (cp, ri, val) = (t.symbolic().col_ptr(), t.symbolic().row_idx(), t.val());
        let mut blocks: std::collections::BTreeMap<usize, [f64; 9]> = Default::default();
        blocks.insert(i, [0.0; 9]);
        for a in 0..d {
            for p in cp[d * i + a]..cp[d * i + a + 1] {
                let (j, c) = (ri[p] / d, ri[p] % d);
                blocks.entry(j).or_insert([0.0; 9])[a * d + c] += val[p];
            }
        }
        for (j, b) in &blocks {
            if *j == i || b[..d * d].iter().any(|&x| x != 0.0) {
                f(*j, &b[..d * d]);
            }
        }
        true
    }
    fn matrix_free_unavailable(&self) -> Option<&'static str> {
        Some("K is read assembled")
    }
    fn describe_node(&self, i: usize) -> String {
        let x = &self.positions[i][..self.dim];
        match &self.labels {
            Some((label, numbers)) => format!("node {i} at {x:?} ({label} {})", numbers[i]),
            None => format!("node {i} at {x:?}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, SymbolicSparseColMat};

    /// The parallel interaction graph against its definition (pairs of nodes with a nonzero
    /// entry in either block), on an unsymmetric pattern with explicit zeros, 2 DOFs a node.
    #[test]
    fn block_partners_is_the_symmetrized_block_pattern() {
        let (dim, n) = (2, 7);
        let nd = dim * n;
        // a pseudo-random unsymmetric pattern, some stored entries exactly zero
        let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nd];
        for c in 0..nd {
            for r in 0..nd {
                let h = (r * 31 + c * 17 + r * c) % 11;
                if r == c || h < 3 {
                    cols[c].push((r, if h == 2 && r != c { 0.0 } else { 1.0 + h as f64 }));
                }
            }
        }
        let mut col_ptr = vec![0usize];
        let (mut rows, mut vals) = (Vec::new(), Vec::new());
        for col in &cols {
            for &(r, v) in col {
                rows.push(r);
                vals.push(v);
            }
            col_ptr.push(rows.len());
        }
        let k = SparseColMat::new(SymbolicSparseColMat::new_checked(nd, nd, col_ptr, None, rows), vals);
        let mut expected = vec![std::collections::BTreeSet::new(); n];
        for (c, col) in cols.iter().enumerate() {
            for &(r, v) in col {
                let (i, j) = (r / dim, c / dim);
                if i != j && v != 0.0 {
                    expected[i].insert(j as u32);
                    expected[j].insert(i as u32);
                }
            }
        }
        let got = block_partners(&k, dim, n);
        for i in 0..n {
            assert_eq!(got[i], expected[i].iter().copied().collect::<Vec<_>>(), "node {i}");
        }
        assert!(expected.iter().any(|e| !e.is_empty()), "the pattern couples nodes");
    }
}
