//! Small parallel helpers shared by the assemblers.

use rayon::prelude::*;

/// Runs `f(i, &mut data[start[i]..start[i + 1]])` for every `i` in parallel: the column-by-column
/// CSC fills of the bond-based and LPS assemblers, where node `i` owns a contiguous range of
/// the value (or row-index) array.
pub fn for_each_node_slice<T: Send>(data: &mut [T], start: &[usize], f: impl Fn(usize, &mut [T]) + Sync) {
    let mut slices = Vec::with_capacity(start.len().saturating_sub(1));
    let mut rest = data;
    for w in start.windows(2) {
        let (head, tail) = rest.split_at_mut(w[1] - w[0]);
        slices.push(head);
        rest = tail;
    }
    slices.into_par_iter().enumerate().for_each(|(i, s)| f(i, s));
}
