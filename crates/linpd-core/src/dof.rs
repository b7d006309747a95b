//! Degrees of freedom: `d` displacement components per node, numbered node-major
//! (`dof = d * node + component`), and the map from full DOFs to the free (unconstrained)
//! DOFs of a reduced system.
//!
//! The free numbering preserves the order of full DOFs, so a sorted list of full DOFs maps to
//! a sorted list of free DOFs; sparse patterns built column by column stay sorted.

/// Map from full DOF numbers to free DOF numbers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DofMap {
    dim: usize,
    free_index: Vec<usize>,
    n_free: usize,
}

const CONSTRAINED: usize = usize::MAX;

impl DofMap {
    /// Every DOF free.
    pub fn all_free(n_nodes: usize, dim: usize) -> Self {
        DofMap { dim, free_index: (0..n_nodes * dim).collect(), n_free: n_nodes * dim }
    }

    /// DOFs flagged in `constrained` (indexed by full DOF) are eliminated.
    pub fn new(dim: usize, constrained: &[bool]) -> Self {
        let mut next = 0;
        let free_index = constrained
            .iter()
            .map(|&c| {
                if c {
                    CONSTRAINED
                } else {
                    next += 1;
                    next - 1
                }
            })
            .collect();
        DofMap { dim, free_index, n_free: next }
    }

    /// Components per node.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Number of full DOFs.
    pub fn n_dofs(&self) -> usize {
        self.free_index.len()
    }
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.free_index.len() / self.dim
    }
    /// Number of free DOFs.
    pub fn n_free(&self) -> usize {
        self.n_free
    }
    /// Free number of a full DOF, `None` when constrained.
    #[inline]
    pub fn free(&self, dof: usize) -> Option<usize> {
        let f = self.free_index[dof];
        (f != CONSTRAINED).then_some(f)
    }
    /// True when the full DOF is constrained.
    pub fn is_constrained(&self, dof: usize) -> bool {
        self.free_index[dof] == CONSTRAINED
    }
    /// Full DOF of every free DOF, ascending.
    pub fn free_dofs(&self) -> Vec<usize> {
        (0..self.n_dofs()).filter(|&d| !self.is_constrained(d)).collect()
    }
    /// Scatters a free vector into a full one (constrained entries untouched).
    pub fn scatter(&self, free: &[f64], full: &mut [f64]) {
        for (dof, &f) in self.free_index.iter().enumerate() {
            if f != CONSTRAINED {
                full[dof] = free[f];
            }
        }
    }
    /// Gathers the free entries of a full vector.
    pub fn gather(&self, full: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.n_free];
        self.gather_into(full, &mut out);
        out
    }
    /// Gathers the free entries of a full vector into `free` (length [`DofMap::n_free`]).
    pub fn gather_into(&self, full: &[f64], free: &mut [f64]) {
        for (dof, &f) in self.free_index.iter().enumerate() {
            if f != CONSTRAINED {
                free[f] = full[dof];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_numbering_is_order_preserving() {
        let m = DofMap::new(2, &[true, false, false, true, false, false]);
        assert_eq!(m.n_free(), 4);
        assert_eq!(m.free_dofs(), vec![1, 2, 4, 5]);
        assert_eq!(m.free(4), Some(2));
        assert_eq!(m.free(3), None);
        let mut full = vec![9.0; 6];
        m.scatter(&[1.0, 2.0, 3.0, 4.0], &mut full);
        assert_eq!(full, vec![9.0, 1.0, 2.0, 9.0, 3.0, 4.0]);
        assert_eq!(m.gather(&full), vec![1.0, 2.0, 3.0, 4.0]);
    }
}
