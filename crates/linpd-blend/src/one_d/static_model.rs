//! The 1D models as a [`linpd_core::Model`]: blended, pure CE and pure PD operators are solved
//! by the one static solve of linpd-solve, like every other model.
//!
//! What the solver learns from this module: the operator is banded in the natural order
//! ([`Ordering::Band`]: Cholesky and LU keep the band, no fill-reducing permutation), and the
//! blended operator is unsymmetric but has an SPD approximation, its divergence form
//! ([`BlendOperator::divergence_preconditioner`]; the symmetric part `(A_ff + A_ff^T)/2` for
//! HOG rows), so `auto` runs GMRES preconditioned by its Cholesky factor (a handful of
//! iterations, one band factorization) and falls back to sparse LU if that fails.

use crate::one_d::model::{BlendOperator, ModelKind};
use linpd_core::sparse::{csr_to_csc, symmetric_part, Csc};
use linpd_core::{DofMap, Model, Ordering, Point, SpdApproximation, SpdApproximationKind};

impl BlendOperator {
    /// The reactions of the supports at `x <= L/2` and `x > L/2` for displacements `u`: `sum (A
    /// u - f)` over the constrained nodes of `dofs` on each side (the end rows are the force on
    /// the end node's half cell; see the crate docs on force balance), for a solution computed
    /// elsewhere (the distributed path).
    pub fn end_reactions(&self, dofs: &DofMap, f: &[f64], u: &[f64], length: f64) -> [f64; 2] {
        let mut au = vec![0.0; self.len()];
        self.apply(u, &mut au);
        let mut reactions = [0.0; 2];
        for (i, &x) in self.mesh.x.iter().enumerate() {
            if dofs.is_constrained(i) {
                reactions[usize::from(x > 0.5 * length)] += au[i] - f[i];
            }
        }
        reactions
    }

    /// The CSR rows and columns of the free DOFs of `dofs`, as a CSC matrix.
    fn restrict(&self, row_ptr: &[usize], col: &[usize], val: &[f64], dofs: &DofMap) -> Csc {
        let (mut rp, mut c, mut v) = (vec![0usize], Vec::new(), Vec::new());
        for i in (0..self.len()).filter(|&i| !dofs.is_constrained(i)) {
            for p in row_ptr[i]..row_ptr[i + 1] {
                if let Some(j) = dofs.free(col[p]) {
                    c.push(j);
                    v.push(val[p]);
                }
            }
            rp.push(c.len());
        }
        csr_to_csc(dofs.n_free(), &rp, &c, &v)
    }
}

impl Model for BlendOperator {
    fn kind(&self) -> &'static str {
        match self.kind {
            ModelKind::Blended => "blend",
            ModelKind::PureCe => "ce",
            ModelKind::PurePd => "pd",
        }
    }
    fn dim(&self) -> usize {
        1
    }
    fn n_nodes(&self) -> usize {
        self.len()
    }
    fn position(&self, i: usize) -> Point {
        [self.mesh.x[i], 0.0, 0.0]
    }
    fn for_each_partner(&self, i: usize, f: &mut dyn FnMut(usize)) {
        for p in self.row_ptr[i]..self.row_ptr[i + 1] {
            if self.col[p] != i && self.val[p] != 0.0 {
                f(self.col[p]);
            }
        }
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        BlendOperator::apply(self, u, y)
    }
    fn diagonal(&self) -> Vec<f64> {
        (0..self.len()).map(|i| self.get(i, i)).collect()
    }
    fn assemble_free(&self, dofs: &DofMap) -> Csc {
        self.restrict(&self.row_ptr, &self.col, &self.val, dofs)
    }
    /// Over the free rows and columns only: the end rows of the blended and CE operators have
    /// no local part (they carry the Dirichlet conditions) and are not symmetric to their
    /// neighbours' columns.
    fn asymmetry(&self, dofs: &DofMap) -> f64 {
        let (mut max, mut skew) = (0.0f64, 0.0f64);
        for i in (0..self.len()).filter(|&i| !dofs.is_constrained(i)) {
            for p in self.row_ptr[i]..self.row_ptr[i + 1] {
                let j = self.col[p];
                if !dofs.is_constrained(j) {
                    max = max.max(self.val[p].abs());
                    skew = skew.max((self.val[p] - self.get(j, i)).abs());
                }
            }
        }
        if max == 0.0 {
            0.0
        } else {
            skew / max
        }
    }
    fn ordering(&self, _dofs: &DofMap) -> Ordering {
        Ordering::Band
    }
    fn spd_approximation(&self, dofs: &DofMap) -> Option<SpdApproximation> {
        // HOG rows have no 3-point local part to rewrite: they use the symmetric part.
        Some(match self.divergence_preconditioner() {
            Some((rp, col, val)) => SpdApproximation {
                matrix: self.restrict(&rp, &col, &val, dofs),
                kind: SpdApproximationKind::DivergenceForm,
            },
            None => SpdApproximation {
                matrix: symmetric_part(&self.assemble_free(dofs)),
                kind: SpdApproximationKind::SymmetricPart,
            },
        })
    }
    /// Row `i` of the stored CSR operator (`d = 1`: a block is an entry): its columns are
    /// unique and include `i` (the row builder keeps the diagonal even when 0), so the rows of
    /// `A_ff` on demand cost nothing beyond the operator every rank builds.
    fn for_each_block(&self, i: usize, f: &mut dyn FnMut(usize, &[f64])) -> bool {
        for p in self.row_ptr[i]..self.row_ptr[i + 1] {
            f(self.col[p], &[self.val[p]]);
        }
        true
    }
    fn describe_node(&self, i: usize) -> String {
        format!("node {i} at x = {}", self.mesh.x[i])
    }
}
