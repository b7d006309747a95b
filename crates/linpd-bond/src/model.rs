//! The bond-based operator as a [`Model`]: [`BondOperator`] on any point set (AMD ordering),
//! and [`LatticeBondModel`], the same operator on a lattice, which adds the lattice's
//! fill-reducing ordering and, for a homogeneous material, the stencil apply for matrix-free CG.

use crate::{BondOperator, CorrectedStencil, StencilOperator};
use linpd_core::family::grid_stencil;
use linpd_core::progress::Progress;
use linpd_core::sparse::Csc;
use linpd_core::{nested_dissection, DofMap, FastApply, Grid, LinearOperator, Micromodulus, Model, Ordering, Point};
use std::sync::OnceLock;

impl LinearOperator for BondOperator {
    fn n(&self) -> usize {
        self.n_dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        BondOperator::apply(self, x, y)
    }

    /// Block row of node `i`: `A_ii = sum_j w_ij e (x) e`, `A_ij = -w_ij e (x) e`.
    fn abs_row_sums(&self, keep: &[bool], r: &mut [f64]) -> bool {
        let d = self.dim();
        for i in 0..self.n_nodes() {
            let mut diag = [[0.0f64; 3]; 3];
            let mut off = [0.0f64; 3];
            for (&j, &w) in self.family().neighbors(i).iter().zip(self.weights(i)) {
                let j = j as usize;
                let e = self.unit(i, j);
                for a in 0..d {
                    for b in 0..d {
                        let v = w * e[a] * e[b];
                        diag[a][b] += v;
                        if keep[d * j + b] {
                            off[a] += v.abs();
                        }
                    }
                }
            }
            for a in 0..d {
                let own: f64 = (0..d).filter(|&b| keep[d * i + b]).map(|b| diag[a][b].abs()).sum();
                r[d * i + a] = own + off[a];
            }
        }
        true
    }
}

impl LinearOperator for StencilOperator {
    fn n(&self) -> usize {
        self.n_dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        StencilOperator::apply(self, x, y)
    }
}

impl BondOperator {
    /// Diagonal of `A` over all DOFs: `A[(i,a),(i,a)] = sum_j w_ij e_a^2`.
    pub fn diagonal(&self) -> Vec<f64> {
        let d = self.dim();
        let mut diag = vec![0.0; self.n_dofs()];
        for i in 0..self.n_nodes() {
            for (&j, &w) in self.family().neighbors(i).iter().zip(self.weights(i)) {
                let e = self.unit(i, j as usize);
                for a in 0..d {
                    diag[d * i + a] += w * e[a] * e[a];
                }
            }
        }
        diag
    }

    /// `A_ff` assembled on the free DOFs (pattern, then values).
    pub fn assemble_free(&self, dofs: &DofMap) -> Csc {
        crate::assemble::assemble_free_with_progress(self, dofs, &linpd_core::NoProgress)
    }
}

impl Model for BondOperator {
    fn kind(&self) -> &'static str {
        "bond"
    }
    fn dim(&self) -> usize {
        BondOperator::dim(self)
    }
    fn n_nodes(&self) -> usize {
        BondOperator::n_nodes(self)
    }
    fn position(&self, i: usize) -> Point {
        self.positions()[i]
    }
    /// Bonds with `w > 0` (a defect with factor 0 cuts a bond).
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        for (&j, &w) in self.family().neighbors(i).iter().zip(self.weights(i)) {
            if w > 0.0 {
                f(j as usize);
            }
        }
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        BondOperator::apply(self, u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        BondOperator::diagonal(self)
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        BondOperator::assemble_free(self, dofs)
    }
    fn assemble_free_with_progress(&self, dofs: &DofMap, progress: &dyn Progress) -> Csc {
        crate::assemble::assemble_free_with_progress(self, dofs, progress)
    }
    /// `A_ij = -w_ij e_ij e_ij^T` for every bond with `w_ij > 0` and `A_ii = sum_j w_ij
    /// e_ij e_ij^T` (the blocks [`BondOperator::apply`] multiplies with).
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        let d = BondOperator::dim(self);
        let mut diag = [0.0; 9];
        let mut block = [0.0; 9];
        // One pass over the bonds: the off-diagonal blocks as they come, their sum (the
        // diagonal block) last.
        for (&j, &w) in self.family().neighbors(i).iter().zip(self.weights(i)).filter(|(_, &w)| w > 0.0) {
            let e = self.unit(i, j as usize);
            for a in 0..d {
                for c in 0..d {
                    block[a * d + c] = -w * e[a] * e[c];
                    diag[a * d + c] -= block[a * d + c];
                }
            }
            f(j as usize, &block[..d * d]);
        }
        f(i, &diag[..d * d]);
        true
    }
}

/// A [`BondOperator`] on the nodes of a lattice.
///
/// A homogeneous material on the full box ([`LatticeBondModel::stencil`]) holds no per-bond
/// data: its products, block rows, diagonal and bonds come from the [`StencilOperator`], and
/// the [`BondOperator`] (12 bytes a bond) is built only when [`LatticeBondModel::operator`]
/// is asked for it (an assembly, an export).
#[derive(Debug, Clone)]
pub struct LatticeBondModel {
    op: OnceLock<BondOperator>,
    grid: Grid,
    /// A homogeneous material's stencil on the full box ([`LatticeBondModel::stencil`], or
    /// [`LatticeBondModel::new`] with its micromodulus) and that micromodulus, which builds
    /// `op` when it was not given.
    stencil: Option<(StencilOperator, Micromodulus)>,
    horizon: f64,
    /// Otherwise the reference micromodulus of [`CorrectedStencil`] and the operator, built
    /// on the first request.
    corrected: Option<(Micromodulus, OnceLock<Option<CorrectedStencil>>)>,
}

impl LatticeBondModel {
    /// The operator `op` built on `grid` with `horizon`; `homogeneous` is the micromodulus
    /// when every bond has it unmodified (no phases, no defects): on the full box its stencil
    /// then applies `A`.
    pub fn new(op: BondOperator, grid: Grid, horizon: f64, homogeneous: Option<Micromodulus>) -> Self {
        let stencil = homogeneous.and_then(|mm| Some((StencilOperator::new(&grid, horizon, &mm).ok()?, mm)));
        LatticeBondModel { op: OnceLock::from(op), grid, stencil, horizon, corrected: None }
    }
    /// The homogeneous material of `micromodulus` on the full box of `grid` (volumes `h^d`),
    /// without per-bond storage (see the type's docs).
    /// Errors as [`BondOperator::on_grid`] would (so that [`LatticeBondModel::operator`] can
    /// build the operator later) and when the grid is not the full box.
    pub fn stencil(grid: Grid, horizon: f64, micromodulus: Micromodulus) -> Result<Self, linpd_core::CoreError> {
        crate::operator::check_lattice_inputs(&grid, horizon, &micromodulus, &linpd_core::Material::default())?;
        micromodulus.amplitude(grid.dim(), horizon, grid.spacing())?;
        let stencil = StencilOperator::new(&grid, horizon, &micromodulus)?;
        Ok(LatticeBondModel {
            op: OnceLock::new(),
            grid,
            stencil: Some((stencil, micromodulus)),
            horizon,
            corrected: None,
        })
    }
    /// The model whose bonds `op` differ from the stencil of `micromodulus` (phases, defects,
    /// a surface correction, a body): its fast apply is the [`CorrectedStencil`] when the box
    /// is full enough ([`CorrectedStencil::fits`]).
    pub fn corrected(op: BondOperator, grid: Grid, horizon: f64, micromodulus: Micromodulus) -> Self {
        let corrected = CorrectedStencil::fits(&grid).then(|| (micromodulus, OnceLock::new()));
        LatticeBondModel { op: OnceLock::from(op), grid, stencil: None, horizon, corrected }
    }
    /// The corrected stencil (built on the first call), if the model has one.
    pub fn corrected_stencil(&self) -> Option<&CorrectedStencil> {
        let (mm, cell) = self.corrected.as_ref()?;
        cell.get_or_init(|| CorrectedStencil::new(&self.grid, self.horizon, mm, self.operator()).ok()).as_ref()
    }
    /// The operator (built on the first call for [`LatticeBondModel::stencil`]).
    pub fn operator(&self) -> &BondOperator {
        self.op.get_or_init(|| {
            let (_, mm) = self.stencil.as_ref().expect("a model without its operator has the stencil");
            BondOperator::on_grid(&self.grid, self.horizon, mm, &linpd_core::Material::default())
                .expect("LatticeBondModel::stencil checked what on_grid checks")
        })
    }
    /// Bonds counted from both ends (without building the operator on the stencil).
    pub fn n_bonds(&self) -> usize {
        match (&self.stencil, self.op.get()) {
            (_, Some(op)) => op.family().n_bonds(),
            (Some((st, _)), None) => st.n_bonds(),
            (None, None) => unreachable!("a model has its operator or its stencil"),
        }
    }
    /// The lattice.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }
}

/// Whether the homogeneous stencil of `micromodulus` with `horizon` on `grid` offers its coarse
/// lattice ([`Model::coarse_lattice`] of [`LatticeBondModel::stencil`]): the lattice of spacing
/// `2h` whose site `I` is the fine site `2I` (one spacing beyond the box where a count is even:
/// [`linpd_core::CoarseLattice`]) with the same micromodulus and horizon, when it makes a good
/// coarse level:
///
/// * 3D (on the 401^2 plate with `delta = 2h` a coarse level with its horizon raised to 3 or
///   4 fine spacings took 30 iterations against SA's 17: 2D keeps the algebraic levels);
/// * `delta >= 3h`, so `delta >= 1.5 (2h)`: the 18 nearest coarse sites or more (at `2h` the
///   coarse lattice would keep only the 6 axis bonds, which carry no shear);
/// * at least 3 sites along every axis, the full box with volumes `h^3`;
/// * a kernel that does not vanish at the coarse axis and face-diagonal offsets (a tabulated
///   kernel zero beyond `0.6 delta` leaves a fine lattice SPD and its coarse stencil empty),
///   and is nowhere negative (the smoother's bound needs positive semi-definite bonds).
///
/// The model and the memory estimate both ask it.
pub fn offers_coarse_lattice(grid: &Grid, horizon: f64, micromodulus: &Micromodulus) -> bool {
    coarse_lattice_of(grid, horizon, micromodulus).is_some()
}

/// The coarse grid and stencil of [`offers_coarse_lattice`], when it offers them.
pub(crate) fn coarse_lattice_of(grid: &Grid, horizon: f64, mm: &Micromodulus) -> Option<(Grid, StencilOperator)> {
    let h = grid.spacing();
    let counts = grid.counts();
    if grid.dim() != 3
        || horizon < 3.0 * h * (1.0 - 1e-9)
        || !grid.is_full()
        || !grid.has_uniform_volumes()
        || counts.iter().any(|&n| n < 3)
    {
        return None;
    }
    let nc = linpd_core::CoarseLattice::coarse_counts(counts);
    let min = grid.site_position([0; 3]);
    let max: Vec<f64> = (0..3).map(|a| min[a] + 2.0 * h * (nc[a] - 1) as f64).collect();
    let coarse = Grid::new(&min, &max, 2.0 * h, 0.0, linpd_core::Placement::Vertex).ok()?;
    crate::operator::check_lattice_inputs(&coarse, horizon, mm, &linpd_core::Material::default()).ok()?;
    mm.amplitude(3, horizon, 2.0 * h).ok()?;
    let stencil = StencilOperator::new(&coarse, horizon, mm).ok()?;
    // the geometric level's smoother needs A = sum of positive semi-definite bond terms
    // (Model::coarse_lattice): no negative micromodulus on the fine lattice
    let fine = StencilOperator::new(grid, horizon, mm).ok()?;
    if fine.weights().iter().any(|w| !(*w >= 0.0)) {
        return None;
    }
    let stiff = |k: [i64; 3]| {
        stencil.offsets().iter().position(|o| *o == k).is_some_and(|s| {
            let b = stencil.block(s);
            b[0] + b[4] + b[8] > 0.0
        })
    };
    (stiff([1, 0, 0]) && stiff([1, 1, 0])).then_some((coarse, stencil))
}

impl Model for LatticeBondModel {
    fn kind(&self) -> &'static str {
        "bond"
    }
    fn dim(&self) -> usize {
        self.grid.dim()
    }
    fn n_nodes(&self) -> usize {
        self.grid.len()
    }
    fn position(&self, i: usize) -> Point {
        self.grid.position(i)
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        match &self.stencil {
            Some((st, _)) => st.for_each_neighbour(i, &mut |j, _| f(j)),
            None => Model::for_each_partner(self.operator(), i, f),
        }
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        match &self.stencil {
            Some((st, _)) => st.apply(u, y),
            None => self.operator().apply(u, y),
        }
    }
    fn diagonal(&self) -> Vec<f64> {
        match &self.stencil {
            Some((st, _)) => st.diagonal(),
            None => self.operator().diagonal(),
        }
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        self.operator().assemble_free(dofs)
    }
    fn assemble_free_with_progress(&self, dofs: &DofMap, progress: &dyn Progress) -> Csc {
        crate::assemble::assemble_free_with_progress(self.operator(), dofs, progress)
    }
    fn lattice_stencil(&self) -> Option<linpd_core::LatticeStencil<'_>> {
        let (st, _) = self.stencil.as_ref()?;
        Some(linpd_core::LatticeStencil {
            counts: st.counts(),
            offsets: st.offsets(),
            blocks: st.blocks(),
            spacing: self.grid.spacing(),
        })
    }
    fn diagonal_block(&self, i: usize, out: &mut [f64]) -> bool {
        match &self.stencil {
            Some((st, _)) => {
                st.diagonal_block(i, out);
                true
            }
            None => {
                let d = self.grid.dim();
                self.for_each_block(i, &mut |j, b| {
                    if j == i {
                        out[..d * d].copy_from_slice(&b[..d * d]);
                    }
                })
            }
        }
    }
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        match &self.stencil {
            Some((st, _)) => {
                st.for_each_block(i, f);
                true
            }
            None => Model::for_each_block(self.operator(), i, f),
        }
    }
    /// 1D: the natural order is a band, already fill-optimal (AMD's analysis of a 10^5-node
    /// band costs ~1 s for nothing). 2D/3D: nested dissection on the lattice over the bond
    /// stencil beats AMD and METIS (docs/solvers.md).
    fn ordering(&self, dofs: &DofMap) -> Ordering {
        if self.grid.dim() == 1 {
            return Ordering::Natural;
        }
        let stencil = grid_stencil(&self.grid, self.horizon / self.grid.spacing());
        Ordering::NestedDissection(nested_dissection(&self.grid, &stencil, dofs))
    }
    /// The homogeneous stencil's model on the coarse lattice (see [`offers_coarse_lattice`]).
    fn coarse_lattice(&self) -> Option<linpd_core::CoarseLattice<'_>> {
        let (_, mm) = self.stencil.as_ref()?;
        let (coarse, stencil) = coarse_lattice_of(&self.grid, self.horizon, mm)?;
        let model = LatticeBondModel {
            op: OnceLock::new(),
            grid: coarse,
            stencil: Some((stencil, mm.clone())),
            horizon: self.horizon,
            corrected: None,
        };
        Some(linpd_core::CoarseLattice { model: Box::new(model), counts: self.grid.counts() })
    }
    /// The stencil of a homogeneous material on the full box, or the [`CorrectedStencil`].
    fn fast_apply(&self) -> Option<FastApply<'_>> {
        if let Some((st, _)) = &self.stencil {
            return Some(FastApply { op: Box::new(st), label: "stencil" });
        }
        let corrected = self.corrected_stencil()?;
        Some(FastApply { op: Box::new(corrected), label: "corrected-stencil" })
    }
}
