//! Strength of connection and standard aggregation on the node graph of a level.

use super::vbr::Vbr;

/// The strong neighbours of every node (row block) of `a`: `J != I` with
/// `s_IJ >= theta sqrt(s_II s_JJ)` and `s_IJ > 0`, where `s_IJ = ||A_IJ||_F` is the Frobenius
/// norm of the block (pyamg's `symmetric` strength on the amalgamated block matrix). With
/// `theta = 0` every structurally nonzero block is strong.
pub(crate) fn strong_neighbours(a: &Vbr, theta: f64) -> (Vec<usize>, Vec<u32>) {
    let nb = a.n_row_blocks();
    let norm = |b: usize| a.val[a.voff[b]..a.voff[b + 1]].iter().map(|v| v * v).sum::<f64>().sqrt();
    let diag: Vec<f64> = (0..nb).map(|i| a.find(i, i).map_or(0.0, norm)).collect();
    let mut ptr = Vec::with_capacity(nb + 1);
    ptr.push(0);
    let mut idx = Vec::new();
    for i in 0..nb {
        for b in a.bptr[i]..a.bptr[i + 1] {
            let j = a.bidx[b] as usize;
            if j == i {
                continue;
            }
            let s = norm(b);
            if s > 0.0 && s >= theta * (diag[i] * diag[j]).sqrt() {
                idx.push(j as u32);
            }
        }
        ptr.push(idx.len());
    }
    (ptr, idx)
}

/// Standard aggregation (Vanek, Mandel & Brezina 1996, section 3; pyamg's
/// `standard_aggregation`) of the graph `(ptr, idx)`: returns the aggregate of every node and
/// the number of aggregates.
///
/// 1. each node whose strong neighbours are all unaggregated forms an aggregate with them;
/// 2. each node left joins the aggregate of a strong neighbour aggregated in step 1 (the one
///    it is most strongly tied to would need the weights; the first one is pyamg's choice and
///    keeps aggregates compact on lattices, whose neighbour lists are sorted);
/// 3. each node still left forms an aggregate with its unaggregated strong neighbours
///    (a node with no strong neighbour becomes a singleton, so every node is aggregated and
///    the tentative prolongator keeps every row).
pub(crate) fn standard_aggregation(ptr: &[usize], idx: &[u32]) -> (Vec<u32>, usize) {
    const NONE: u32 = u32::MAX;
    let n = ptr.len() - 1;
    let mut agg = vec![NONE; n];
    let mut n_agg = 0u32;
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        let nb = &idx[ptr[i]..ptr[i + 1]];
        if nb.is_empty() {
            // Isolated (e.g. cut off by the Dirichlet elimination): a singleton in pass 3.
            continue;
        }
        if nb.iter().all(|&j| agg[j as usize] == NONE) {
            agg[i] = n_agg;
            for &j in nb {
                agg[j as usize] = n_agg;
            }
            n_agg += 1;
        }
    }
    let pass1 = agg.clone();
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        if let Some(&j) = idx[ptr[i]..ptr[i + 1]].iter().find(|&&j| pass1[j as usize] != NONE) {
            agg[i] = pass1[j as usize];
        }
    }
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        agg[i] = n_agg;
        for &j in &idx[ptr[i]..ptr[i + 1]] {
            if agg[j as usize] == NONE {
                agg[j as usize] = n_agg;
            }
        }
        n_agg += 1;
    }
    (agg, n_agg as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path 0-1-2-3-4-5-6: pass 1 takes {0,1} at node 0; node 2 waits (its neighbour 1 is
    /// taken); node 3 takes {2,3,4}; node 5 waits (4 is taken); node 6 takes {5,6}.
    #[test]
    fn path_graph_aggregates() {
        let n = 7;
        let mut ptr = vec![0];
        let mut idx = Vec::new();
        for i in 0..n {
            if i > 0 {
                idx.push(i as u32 - 1);
            }
            if i + 1 < n {
                idx.push(i as u32 + 1);
            }
            ptr.push(idx.len());
        }
        let (agg, na) = standard_aggregation(&ptr, &idx);
        assert_eq!(na, 3);
        assert_eq!(agg, vec![0, 0, 1, 1, 1, 2, 2]);
    }
}
