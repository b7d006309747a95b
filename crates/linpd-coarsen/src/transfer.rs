//! Load transfer of one coarsening step: `f^m = S^T f^{m-1}` ([`Transfer`]).
//!
//! # Derivation
//!
//! Write the level-(m-1) nodal equilibrium as `sum_p W_xp (u_p - u_x) + F_x = 0` with
//! `W_xp = v_x v_p C(x,p)` and `F` the nodal forces. In the local problem of a retained node `x`
//! the excluded nodes `E_x` of `N_x` are in equilibrium *with their loads* (the paper's (5)
//! assumes them unloaded):
//!
//! ```text
//! M u_E + B u_R + F_E = 0   =>   u_E = S_E u_R - M^{-1} F_E,   S_E = -M^{-1} B          (13')
//! ```
//!
//! and the equation of `x` becomes, with `G = W_{x,E}` (the blocks the step already assembles),
//!
//! ```text
//! sum_q W^m_xq (u_q - u_x) + F_x - G M^{-1} F_E = 0                                     (T)
//! ```
//!
//! so the level-m nodal force of `x` is `F^m_x = F_x + T_x F_E` with the transfer row
//! `T_x = -G M^{-1}` (`d x d|E_x|`). The step computes `Z^T = M^{-T} G^T` anyway (one transposed
//! solve per class), so `T_x = -Z` costs nothing more than keeping it. When `M` is symmetric
//! (bond-based models), `T_x = (S^x_{E,x})^T`: the transpose of column `x` of the interpolation
//! `S^x` of `x`'s own neighbourhood, i.e. `f^m = S^T f^{m-1}` of the issue's wording.
//!
//! # Which neighbourhood serves a node that several contain
//!
//! Each coarse node collects from **its own** neighbourhood: an excluded node `p` gives a share
//! `T_x(p)` of its force to every retained `x` whose `N_x` contains it. This is the right-hand
//! side of the coarse row (T) exactly as the coarse stiffness row is the condensation of `N_x`:
//! one local problem per row, for the matrix and the load alike. The alternative (one chosen
//! neighbourhood per excluded node, e.g. the nearest retained node's, spreading `F_p` by the
//! row `S^y_p`) conserves the total force exactly by (8) but loads row `x` with a resolvent that
//! is not the one its stiffness row was condensed with. With `N_x` = the whole body both are the
//! exact static condensation `F_R - K_RE K_EE^{-1} F_E`. With finite neighbourhoods the total
//! force changes by a little (bounded by the tail); [`Transfer::restrict`]'s callers report it.
//!
//! The force-density convention ([`crate::Matching::ForceDensity`]) divides the coarse row of
//! `x` by `v^{m-1}_x` instead of `v^m_x`; its nodal force is then `v^m_x / v^{m-1}_x` times (T).

/// The load transfer of one step (see the module docs): per coarse node `k` (level-(m-1) node
/// `parent[k]`), its excluded neighbours and the transfer row of its neighbourhood class.
#[derive(Debug, Clone, PartialEq)]
pub struct Transfer {
    dim: usize,
    n_fine: usize,
    parent: Vec<usize>,
    /// `excluded[offsets[k]..offsets[k + 1]]`: level-(m-1) indices of `E_x`, in the local order
    /// of the class's transfer row.
    offsets: Vec<usize>,
    excluded: Vec<usize>,
    /// Each coarse node's class.
    class_of: Vec<usize>,
    /// Per class: `T_x = -G M^{-1}`, `d x d|E_x|`, row-major.
    rows: Vec<Vec<f64>>,
    /// Per coarse node: the nodal-force factor (1 for nodal-force matching).
    factor: Vec<f64>,
}

impl Transfer {
    /// Assembles a transfer; `rows[c]` must have `d * d * |E_x|` entries for every node of class
    /// `c` (checked by the debug assertions of [`Transfer::restrict`]).
    pub(crate) fn new(
        dim: usize,
        n_fine: usize,
        parent: Vec<usize>,
        excluded: Vec<Vec<usize>>,
        class_of: Vec<usize>,
        rows: Vec<Vec<f64>>,
        factor: Vec<f64>,
    ) -> Self {
        let mut offsets = Vec::with_capacity(excluded.len() + 1);
        offsets.push(0);
        let mut flat = Vec::with_capacity(excluded.iter().map(Vec::len).sum());
        for e in excluded {
            flat.extend(e);
            offsets.push(flat.len());
        }
        Self { dim, n_fine, parent, offsets, excluded: flat, class_of, rows, factor }
    }

    /// Number of level-(m-1) nodes the transfer reads.
    pub fn n_fine(&self) -> usize {
        self.n_fine
    }

    /// Number of level-m nodes it writes.
    pub fn n_coarse(&self) -> usize {
        self.parent.len()
    }

    /// Level-m nodal forces `F^m` (`d` per coarse node) from level-(m-1) nodal forces `f`
    /// (`d` per fine node): `F^m_x = factor_x (F_x + T_x F_{E_x})`, eq. (T) of the module docs.
    ///
    /// # Panics
    /// If `f.len() != d * n_fine` (a caller's bug; the pipeline builds `f` from the same level).
    pub fn restrict(&self, f: &[f64]) -> Vec<f64> {
        let d = self.dim;
        assert_eq!(f.len(), d * self.n_fine, "load vector of the wrong level");
        let mut out = vec![0.0; d * self.parent.len()];
        for (k, &xi) in self.parent.iter().enumerate() {
            let ex = &self.excluded[self.offsets[k]..self.offsets[k + 1]];
            let t = &self.rows[self.class_of[k]];
            let de = d * ex.len();
            debug_assert_eq!(t.len(), d * de);
            for a in 0..d {
                let mut s = f[d * xi + a];
                for (e, &p) in ex.iter().enumerate() {
                    for c in 0..d {
                        s += t[a * de + d * e + c] * f[d * p + c];
                    }
                }
                out[d * k + a] = self.factor[k] * s;
            }
        }
        out
    }
}
