//! Fill-reducing orderings that use the lattice geometry.
//!
//! faer ships only AMD, which on 3D lattices with `delta = 3h` gives 1.2-1.7x the fill of nested
//! dissection (shared notes, pitfall 1). On a box lattice the separators are known: a slab of
//! `reach` lattice planes (the stencil's radius in lattice units) cuts every bond between its
//! two sides. [`nested_dissection`] splits the longest axis recursively, orders both halves
//! first and the separator last, and stops at boxes of at most `LEAF` nodes, which keep their
//! natural (lexicographic) order.

use crate::{DofMap, Grid};

/// Boxes with at most this many nodes are not split further.
const LEAF: usize = 64;

/// The free-DOF permutation `perm[new] = old` of nested dissection on the lattice of `grid`
/// with separators `reach` planes thick.
pub fn nested_dissection(grid: &Grid, reach: usize, dofs: &DofMap) -> Vec<usize> {
    let counts = grid.counts();
    let mut nodes = Vec::with_capacity(grid.len());
    let lo = [0usize; 3];
    dissect(lo, counts, reach.max(1), counts, &mut nodes);
    debug_assert_eq!(nodes.len(), grid.len());
    let d = dofs.dim();
    let mut perm = Vec::with_capacity(dofs.n_free());
    for n in nodes {
        for a in 0..d {
            if let Some(f) = dofs.free(d * n + a) {
                perm.push(f);
            }
        }
    }
    perm
}

fn push_box(lo: [usize; 3], hi: [usize; 3], counts: [usize; 3], out: &mut Vec<usize>) {
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            for i in lo[0]..hi[0] {
                out.push(i + counts[0] * (j + counts[1] * k));
            }
        }
    }
}

fn dissect(lo: [usize; 3], hi: [usize; 3], reach: usize, counts: [usize; 3], out: &mut Vec<usize>) {
    let len = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let size: usize = len.iter().product();
    let axis = (0..3).max_by_key(|&a| len[a]).unwrap();
    // Too small to split usefully: both halves must be non-empty around the separator.
    if size <= LEAF || len[axis] < 2 * reach + 2 {
        push_box(lo, hi, counts, out);
        return;
    }
    let mid = lo[axis] + (len[axis] - reach) / 2;
    let (mut left_hi, mut sep_lo, mut sep_hi, mut right_lo) = (hi, lo, hi, lo);
    left_hi[axis] = mid;
    sep_lo[axis] = mid;
    sep_hi[axis] = mid + reach;
    right_lo[axis] = mid + reach;
    dissect(lo, left_hi, reach, counts, out);
    dissect(right_lo, hi, reach, counts, out);
    push_box(sep_lo, sep_hi, counts, out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Placement;

    #[test]
    fn is_a_permutation_of_the_free_dofs() {
        let g = Grid::new(&[0.0, 0.0, 0.0], &[1.0, 0.6, 0.8], 0.05, 0.0, Placement::Vertex).unwrap();
        let mut mask = vec![false; 3 * g.len()];
        mask.iter_mut().step_by(7).for_each(|m| *m = true);
        let dofs = DofMap::new(3, &mask);
        let mut p = nested_dissection(&g, 3, &dofs);
        p.sort_unstable();
        assert_eq!(p, (0..dofs.n_free()).collect::<Vec<_>>());
    }
}
