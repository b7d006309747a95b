//! Fill-reducing orderings that use the lattice geometry.
//!
//! faer ships only AMD, which on 3D lattices with `delta = 3h` gives 1.2-1.7x the fill of nested
//! dissection (shared notes, pitfall 1). On a lattice the separators are known: a model couples
//! node `i` to the nodes at lattice offsets in its `stencil` (the bond family's offsets
//! `|k| h <= delta`; for LPS the two-hop offsets `|k| h <= 2 delta`, [`two_hop_stencil`]), so a
//! slab of `r_a` lattice planes normal to axis `a`, `r_a = max |k_a|` over the stencil (the
//! stencil's reach along that axis), cuts every coupling between its two sides; no thinner
//! slab does, since the offset `r_a e_a` is in every ball stencil.
//!
//! [`nested_dissection`] orders the nodes that carry a free DOF (constrained nodes take no part
//! and must not shift the cuts): it splits the current set by the slab that leaves the two sides
//! within 40-60% of the remaining nodes with the fewest separator nodes (the cut normal to the
//! longest extent, for a box), orders the two sides first and the slab last, and recurses until
//! at most [`LEAF`] nodes remain or no slab fits; leaves and separators keep their natural
//! (lexicographic) order. A node's DOFs stay together. Measured against METIS (`METIS_NodeND`
//! on the node graph) and AMD in `docs/solvers.md`: fewer factor entries and flops than METIS on
//! 3D bond and LPS lattices, 9.5% more entries and 17% more flops on a 2D plate, in 1-20 ms
//! where METIS takes 0.8-1.5 s.
//!
//! [`planar_nested_dissection`] is the first version (geometric midpoints of the whole grid
//! box, constrained nodes included), kept as the baseline of the benchmarks and tests.

use crate::{DofMap, Grid};

/// Node sets with at most this many nodes are not split further. 64-128 gave the same fill on
/// the benchmark lattices; 256 and more gave more (natural order inside a leaf is banded).
pub const LEAF: usize = 64;

/// Largest deviation of a cut's left share `left / (left + right)` from 1/2 that still counts
/// as balanced; among balanced cuts the one with the fewest separator nodes wins.
const BALANCE_TOL: f64 = 0.1;

/// The free-DOF permutation `perm[new] = old` of nested dissection over the nodes of `grid`
/// that have a free DOF in `dofs`, for a model coupling lattice offsets in `stencil` (see the
/// module docs). An empty stencil (no couplings) gives the natural order.
pub fn nested_dissection(grid: &Grid, stencil: &[[i64; 3]], dofs: &DofMap) -> Vec<usize> {
    let d = dofs.dim();
    let mut reach = [0i64; 3];
    for o in stencil {
        for a in 0..3 {
            reach[a] = reach[a].max(o[a].abs());
        }
    }
    let active: Vec<usize> = (0..grid.len()).filter(|&n| (0..d).any(|a| dofs.free(d * n + a).is_some())).collect();
    let coords: Vec<[i64; 3]> = active.iter().map(|&n| grid.lattice_index(n)).collect();
    let mut idx: Vec<u32> = (0..active.len() as u32).collect();
    dissect(&coords, reach, &mut idx);
    let nodes: Vec<usize> = idx.iter().map(|&i| active[i as usize]).collect();
    expand(&nodes, dofs)
}

/// The offsets `a + b` for `a`, `b` in `stencil` or zero, except zero: the couplings of a model
/// whose force on a node depends on every node in the family of each node of its own family
/// (the LPS tangent couples `j` and `k` through a common `i`).
pub fn two_hop_stencil(stencil: &[[i64; 3]]) -> Vec<[i64; 3]> {
    let mut out: Vec<[i64; 3]> = stencil.to_vec();
    for a in stencil {
        for b in stencil {
            out.push([a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        }
    }
    out.retain(|o| *o != [0, 0, 0]);
    out.sort_unstable_by_key(|o| (o[2], o[1], o[0]));
    out.dedup();
    out
}

/// The first lattice nested dissection (the baseline of `docs/solvers.md`): the whole grid box,
/// constrained nodes included, split at the geometric middle of its longest axis by a slab of
/// `reach` planes, boxes of at most 64 nodes in natural order; then restricted to the free DOFs.
pub fn planar_nested_dissection(grid: &Grid, reach: usize, dofs: &DofMap) -> Vec<usize> {
    let counts = grid.counts();
    let mut nodes = Vec::with_capacity(grid.len());
    planar_dissect([0; 3], counts, reach.max(1), counts, &mut nodes);
    expand(&nodes, dofs)
}

/// The free DOFs of `nodes`, node by node.
fn expand(nodes: &[usize], dofs: &DofMap) -> Vec<usize> {
    let d = dofs.dim();
    let mut perm = Vec::with_capacity(dofs.n_free());
    for &n in nodes {
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

fn planar_dissect(lo: [usize; 3], hi: [usize; 3], reach: usize, counts: [usize; 3], out: &mut Vec<usize>) {
    let len = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let size: usize = len.iter().product();
    let axis = (0..3).max_by_key(|&a| len[a]).unwrap();
    if size <= 64 || len[axis] < 2 * reach + 2 {
        push_box(lo, hi, counts, out);
        return;
    }
    let mid = lo[axis] + (len[axis] - reach) / 2;
    let (mut left_hi, mut sep_lo, mut sep_hi, mut right_lo) = (hi, lo, hi, lo);
    left_hi[axis] = mid;
    sep_lo[axis] = mid;
    sep_hi[axis] = mid + reach;
    right_lo[axis] = mid + reach;
    planar_dissect(lo, left_hi, reach, counts, out);
    planar_dissect(right_lo, hi, reach, counts, out);
    push_box(sep_lo, sep_hi, counts, out);
}

/// Lexicographic order, first axis fastest.
fn natural(coords: &[[i64; 3]], idx: &mut [u32]) {
    idx.sort_unstable_by_key(|&i| {
        let c = coords[i as usize];
        (c[2], c[1], c[0])
    });
}

/// A cut: the slab `plane .. plane + reach[axis]` normal to `axis`.
#[derive(Clone, Copy)]
struct Cut {
    axis: usize,
    plane: i64,
    sep: usize,
    /// `|left / (left + right) - 1/2|`.
    off: f64,
}

/// The balanced cut with the fewest separator nodes (else the best balanced one), if any slab
/// leaves both sides non-empty.
fn best_cut(coords: &[[i64; 3]], reach: [i64; 3], idx: &[u32]) -> Option<Cut> {
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    for &i in idx {
        let c = coords[i as usize];
        for a in 0..3 {
            lo[a] = lo[a].min(c[a]);
            hi[a] = hi[a].max(c[a]);
        }
    }
    let mut best: Option<Cut> = None;
    for a in 0..3 {
        let r = reach[a] as usize;
        let ext = (hi[a] - lo[a] + 1) as usize;
        if r == 0 || ext < 2 * r + 2 {
            continue;
        }
        // prefix[t] = nodes in planes lo[a] .. lo[a] + t.
        let mut prefix = vec![0usize; ext + 1];
        for &i in idx {
            prefix[(coords[i as usize][a] - lo[a]) as usize + 1] += 1;
        }
        for t in 0..ext {
            prefix[t + 1] += prefix[t];
        }
        for p in 1..ext - r {
            let left = prefix[p];
            let sep = prefix[p + r] - left;
            let right = idx.len() - left - sep;
            if left == 0 || right == 0 {
                continue;
            }
            let off = (left as f64 / (left + right) as f64 - 0.5).abs();
            let cut = Cut { axis: a, plane: lo[a] + p as i64, sep, off };
            let better = match best {
                None => true,
                Some(b) => match (off <= BALANCE_TOL, b.off <= BALANCE_TOL) {
                    (true, false) => true,
                    (false, true) => false,
                    (true, true) => (sep, off) < (b.sep, b.off),
                    (false, false) => off < b.off,
                },
            };
            if better {
                best = Some(cut);
            }
        }
    }
    best
}

/// Reorders `idx` in place: the left side (dissected), the right side (dissected), the slab.
fn dissect(coords: &[[i64; 3]], reach: [i64; 3], idx: &mut [u32]) {
    let cut = if idx.len() <= LEAF { None } else { best_cut(coords, reach, idx) };
    let Some(cut) = cut else {
        natural(coords, idx);
        return;
    };
    let side = |i: u32| {
        let c = coords[i as usize][cut.axis];
        if c < cut.plane {
            0u8
        } else if c >= cut.plane + reach[cut.axis] {
            1
        } else {
            2
        }
    };
    idx.sort_unstable_by_key(|&i| side(i));
    let n_left = idx.iter().take_while(|&&i| side(i) == 0).count();
    let n_right = idx[n_left..].iter().take_while(|&&i| side(i) == 1).count();
    let (left, rest) = idx.split_at_mut(n_left);
    let (right, sep) = rest.split_at_mut(n_right);
    dissect(coords, reach, left);
    dissect(coords, reach, right);
    natural(coords, sep);
}
