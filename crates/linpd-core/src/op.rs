//! The one operator trait of linpd: `y = A x` for a square linear operator.
//!
//! Every solver (CG, GMRES), every preconditioner's set-up and the explicit dynamics take their
//! operator through [`LinearOperator`], so an assembled matrix, a matrix-free bond sum, a
//! lattice stencil and a reduced (constrained-DOF-eliminated) operator are interchangeable.

/// `y = A x` for a square operator of size [`n`](LinearOperator::n).
pub trait LinearOperator: Sync {
    /// Size (rows = columns).
    fn n(&self) -> usize;
    /// `y = A x`; `y` is overwritten.
    fn apply(&self, x: &[f64], y: &mut [f64]);

    /// Absolute row sums over kept columns, for Gershgorin bounds of the explicit dynamics
    /// (`linpd_dynamics::gershgorin`, `DtLimit::Gershgorin`).
    ///
    /// Writes `r_i = sum_{j : keep[j]} |A_ij|` for every row `i` (`keep` and `r` have length
    /// [`n`](LinearOperator::n); rows with `keep[i] = false` may hold anything) and returns
    /// `true`; returns `false` when the operator does not know its entries (the default, e.g.
    /// for [`FnOperator`]), in which case `r` is left unspecified.
    fn abs_row_sums(&self, keep: &[bool], r: &mut [f64]) -> bool {
        let _ = (keep, r);
        false
    }
}

impl<T: LinearOperator + ?Sized> LinearOperator for &T {
    fn n(&self) -> usize {
        (**self).n()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (**self).apply(x, y)
    }
    fn abs_row_sums(&self, keep: &[bool], r: &mut [f64]) -> bool {
        (**self).abs_row_sums(keep, r)
    }
}

/// An operator given by its size and a closure (`y = A x`).
pub struct FnOperator<F: Fn(&[f64], &mut [f64]) + Sync> {
    /// Size.
    pub n: usize,
    /// `y = A x`.
    pub apply: F,
}

impl<F: Fn(&[f64], &mut [f64]) + Sync> LinearOperator for FnOperator<F> {
    fn n(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (self.apply)(x, y)
    }
}
