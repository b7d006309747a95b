//! The leaf level of every level-0 cell: the grading rule and the 2:1 balance (see the
//! parent module's docs for the rules).

use super::Grading;
use rayon::prelude::*;

/// The level-0 cells of the lattice box: `m[a] = n[a] - 1` per used axis (1 on unused axes),
/// numbered lexicographically with axis 0 fastest (the lattice's node order).
#[derive(Debug, Clone, Copy)]
pub(super) struct CellBox {
    pub d: usize,
    pub m: [usize; 3],
}

impl CellBox {
    pub fn len(&self) -> usize {
        self.m.iter().product()
    }
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.m[0] * (c[1] + self.m[1] * c[2])
    }
    pub fn coords(&self, i: usize) -> [usize; 3] {
        [i % self.m[0], (i / self.m[0]) % self.m[1], i / (self.m[0] * self.m[1])]
    }
    /// The cells `c + o`, `o in {-1, 0, 1}^d \ {0}`, inside the box: those sharing a point with `c`.
    #[cfg(test)]
    pub fn touching(&self, c: [usize; 3]) -> impl Iterator<Item = usize> + '_ {
        let d = self.d;
        (0..3usize.pow(d as u32)).filter_map(move |code| {
            let mut k = [0usize; 3];
            let mut r = code;
            let mut zero = true;
            for a in 0..d {
                let o = (r % 3) as i64 - 1;
                r /= 3;
                zero &= o == 0;
                let v = c[a] as i64 + o;
                if v < 0 || v >= self.m[a] as i64 {
                    return None;
                }
                k[a] = v as usize;
            }
            (!zero).then(|| self.index(k))
        })
    }
}

/// Chebyshev distance, in cells, from every level-0 cell to the nearest fine one (`u32::MAX`
/// when there is none). The maximum norm is separable, `min_s max_a |c_a - s_a|` taken one
/// axis at a time: after the passes along axes `0..a` each cell holds the distance to the
/// nearest fine cell of its `a`-dimensional slice, and the pass along axis `a` is the 1D
/// transform `f(x) = min_y max(|x - y|, g(y))` of every line ([`line_transform`]), the lines
/// in parallel. (The two-pass chamfer over the `3^d - 1` touching cells gives the same values,
/// sequentially: 3.0 s of a 15.8M-cell lattice.)
pub(super) fn chebyshev_distance(b: &CellBox, fine: &[bool]) -> Vec<u32> {
    let mut dist: Vec<u32> = fine.iter().map(|&f| if f { 0 } else { u32::MAX }).collect();
    let stride = [1, b.m[0], b.m[0] * b.m[1]];
    for a in 0..b.d {
        let len = b.m[a];
        // the lines along axis a: one per cell with c_a = 0
        let starts: Vec<usize> = (0..b.len() / len)
            .map(|k| {
                let (lo, hi) = (k % stride[a], k / stride[a]);
                lo + hi * stride[a] * len
            })
            .collect();
        let lines: Vec<Vec<u32>> = starts
            .par_iter()
            .map_init(
                || (Vec::new(), Vec::new()),
                |(g, table), &s| {
                    g.clear();
                    g.extend((0..len).map(|q| dist[s + q * stride[a]]));
                    line_transform(g, table)
                },
            )
            .collect();
        for (&s, line) in starts.iter().zip(&lines) {
            for (q, &v) in line.iter().enumerate() {
                dist[s + q * stride[a]] = v;
            }
        }
    }
    dist
}

/// `f(x) = min_y max(|x - y|, g(y))` over a line (`u32::MAX`: no fine cell; all of `f` then
/// too). `f` is 1-Lipschitz, so `f(x + 1)` is the first of `f(x) - 1, f(x), f(x) + 1` for which
/// some `g(y) <= r` within `|x + 1 - y| <= r`, a range minimum of a sparse table (`table`:
/// scratch), O(L log L) a line.
fn line_transform(g: &[u32], table: &mut Vec<u32>) -> Vec<u32> {
    let len = g.len();
    if g.iter().all(|&v| v == u32::MAX) {
        return vec![u32::MAX; len];
    }
    // table[k * len + i] = min g[i .. i + 2^k]
    let levels = (usize::BITS - len.leading_zeros()) as usize;
    table.clear();
    table.extend_from_slice(g);
    for k in 1..levels {
        let half = 1usize << (k - 1);
        for i in 0..len {
            let right = if i + half < len { table[(k - 1) * len + i + half] } else { u32::MAX };
            table.push(table[(k - 1) * len + i].min(right));
        }
    }
    let range_min = |lo: usize, hi: usize| {
        let k = (usize::BITS - (hi - lo + 1).leading_zeros() - 1) as usize;
        table[k * len + lo].min(table[k * len + hi + 1 - (1 << k)])
    };
    let fits = |x: usize, r: u64| {
        let lo = x.saturating_sub(r.min(len as u64) as usize);
        let hi = (x as u64 + r).min(len as u64 - 1) as usize;
        range_min(lo, hi) as u64 <= r
    };
    let mut f = Vec::with_capacity(len);
    let first = (0..len).map(|y| (y as u64).max(g[y] as u64)).min().expect("a line has cells");
    f.push(first);
    for x in 1..len {
        let prev = f[x - 1];
        let r = [prev.saturating_sub(1), prev, prev + 1].into_iter().find(|&r| fits(x, r)).expect("1-Lipschitz");
        f.push(r);
    }
    f.into_iter().map(|v| v.min(u32::MAX as u64 - 1) as u32).collect()
}

/// The smallest Chebyshev distance (of [`chebyshev_distance`]) a level-0 cell of a level-`l`
/// cell may have: `m (2^l - 1) + 1`, i.e. a gap of `m (2^l - 1)` lattice spacings between the
/// cell and the fine region.
fn min_distance(cells_per_level: usize, l: usize) -> u64 {
    (cells_per_level as u64).saturating_mul((1u64 << l) - 1).saturating_add(1)
}

/// The leaf level of every level-0 cell by the grading rule alone: the largest `l <=
/// max_level` whose aligned level-`l` cell containing it fits in the box and keeps the
/// distance of [`min_distance`] (both conditions pass to the children, so the levels describe
/// a tree of aligned cells).
pub(super) fn graded_levels(b: &CellBox, dist: &[u32], grading: &Grading) -> Vec<u8> {
    let d = b.d;
    let mut level = vec![0u8; b.len()];
    // min distance over the aligned level-l cells, level by level from the level-0 cells
    let mut counts = b.m;
    let mut min_d = dist.to_vec();
    for l in 1..=grading.max_level {
        let prev = counts;
        for a in 0..d {
            counts[a] = prev[a].div_ceil(2);
        }
        let coarse = CellBox { d, m: counts };
        let fine_box = CellBox { d, m: prev };
        // each coarse cell gathers its (up to 2^d) children, in parallel
        min_d = (0..coarse.len())
            .into_par_iter()
            .map(|p| {
                let o = coarse.coords(p);
                let mut best = u32::MAX;
                for bits in 0..1usize << d {
                    let c = [0, 1, 2].map(|a| 2 * o[a] + (bits >> a & 1));
                    if (0..3).all(|a| c[a] < fine_box.m[a]) {
                        best = best.min(min_d[fine_box.index(c)]);
                    }
                }
                best
            })
            .collect();
        let side = 1usize << l;
        let threshold = min_distance(grading.cells_per_level, l);
        let allowed = |p: usize| {
            let o = coarse.coords(p);
            (0..d).all(|a| (o[a] + 1) * side <= b.m[a]) && min_d[p] as u64 >= threshold
        };
        let any = level
            .par_iter_mut()
            .enumerate()
            .map(|(i, lv)| {
                let c = b.coords(i);
                let up = allowed(coarse.index([c[0] >> l, c[1] >> l, c[2] >> l]));
                if up {
                    *lv = l as u8;
                }
                up
            })
            .reduce(|| false, |x, y| x || y);
        if !any {
            break;
        }
    }
    level
}

/// Refines leaves until every two touching level-0 cells (sharing a point: a face, an edge or
/// a corner) have leaf levels differing by at most one, i.e. the 2:1 balance across faces,
/// edges and corners. Splitting only lowers levels, so the sweeps end; and each split is forced
/// (no balanced map at or below the levels keeps the leaf), so the result is the same whatever
/// the order of the splits. A leaf is checked as a whole, against the shell of cells around it
/// (inside a leaf all levels are equal): each sweep finds the violating leaves in parallel,
/// splits them, and the next sweep checks only the split leaves' children and the leaves that
/// touch them.
pub(super) fn balance(b: &CellBox, level: &mut [u8]) {
    // every leaf at level >= 2, by its origin cell
    let mut candidates: Vec<usize> = (0..b.len())
        .into_par_iter()
        .filter(|&i| {
            let l = level[i];
            l >= 2 && b.coords(i).iter().all(|&v| v & ((1 << l) - 1) == 0)
        })
        .collect();
    while !candidates.is_empty() {
        let split: Vec<(usize, u8)> = candidates
            .into_par_iter()
            .filter_map(|o| {
                let l = level[o];
                // a candidate may have been split already (then its children are candidates)
                let c = b.coords(o);
                let origin = c.iter().all(|&v| v & ((1 << l) - 1) == 0);
                (l >= 2 && origin && leaf_violates(b, level, c, l)).then_some((o, l))
            })
            .collect();
        let mut next = Vec::new();
        for &(o, l) in &split {
            let c = b.coords(o);
            split_leaf(b, level, c, l);
            // the children, and the leaves touching the split one (their origins)
            let half = 1usize << (l - 1);
            for bits in 0..1usize << b.d {
                let k = [0, 1, 2].map(|a| c[a] + if bits >> a & 1 == 1 { half } else { 0 });
                next.push(b.index(k));
            }
            for_each_shell_cell(b, c, l, &mut |k| {
                let lk = level[k];
                let kc = b.coords(k);
                next.push(b.index(kc.map(|v| v >> lk << lk)));
            });
        }
        next.sort_unstable();
        next.dedup();
        candidates = next;
    }
}

/// Whether the level-`l` leaf with origin `o` touches a cell more than one level finer.
fn leaf_violates(b: &CellBox, level: &[u8], o: [usize; 3], l: u8) -> bool {
    let mut found = false;
    for_each_shell_cell(b, o, l, &mut |k| found |= level[k] + 1 < l);
    found
}

/// `f(cell)` for each cell of the box touching the level-`l` leaf with origin `o` from
/// outside (the shell one cell thick around it).
fn for_each_shell_cell(b: &CellBox, o: [usize; 3], l: u8, f: &mut dyn FnMut(usize)) {
    let side = 1i64 << l;
    let lo = [0, 1, 2].map(|a| if a < b.d { o[a] as i64 - 1 } else { 0 });
    let hi = [0, 1, 2].map(|a| if a < b.d { o[a] as i64 + side } else { 0 });
    let inside = |k: [i64; 3]| (0..b.d).all(|a| k[a] >= o[a] as i64 && k[a] < o[a] as i64 + side);
    for k2 in lo[2]..=hi[2] {
        for k1 in lo[1]..=hi[1] {
            // the whole row when it lies outside the leaf, else its two ends
            let row_outside = !inside([o[0] as i64, k1, k2]);
            let mut visit = |k0: i64| {
                let k = [k0, k1, k2];
                if (0..b.d).all(|a| k[a] >= 0 && (k[a] as usize) < b.m[a]) {
                    f(b.index(k.map(|v| v as usize)));
                }
            };
            if row_outside {
                (lo[0]..=hi[0]).for_each(&mut visit);
            } else {
                visit(lo[0]);
                visit(hi[0]);
            }
        }
    }
}

/// Sets the level-0 cells of the level-`l` leaf containing `c` to level `l - 1` (its children).
fn split_leaf(b: &CellBox, level: &mut [u8], c: [usize; 3], l: u8) {
    let side = 1usize << l;
    let o = c.map(|v| v >> l << l);
    let ext = [0, 1, 2].map(|a| if a < b.d { side } else { 1 });
    for k2 in 0..ext[2] {
        for k1 in 0..ext[1] {
            for k0 in 0..ext[0] {
                level[b.index([o[0] + k0, o[1] + k1, o[2] + k2])] = l - 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separable transform against the brute-force Chebyshev distance, on scattered fine
    /// cells in 2D and 3D, dense and sparse (a wrong step of the 1D pass would over- or
    /// underestimate somewhere), and a single fine cell in a long line.
    #[test]
    fn chebyshev_distance_is_exact() {
        let cases = [(2usize, [23usize, 17, 1], 97), (3, [11, 9, 13], 97), (3, [19, 7, 12], 7), (2, [64, 3, 1], 150)];
        for (d, m, every) in cases {
            let b = CellBox { d, m };
            let fine: Vec<bool> = (0..b.len()).map(|i| (i * 7919 + 13) % every == 0).collect();
            let seeds: Vec<[usize; 3]> = (0..b.len()).filter(|&i| fine[i]).map(|i| b.coords(i)).collect();
            assert!(!seeds.is_empty());
            let dist = chebyshev_distance(&b, &fine);
            for (i, &v) in dist.iter().enumerate() {
                let c = b.coords(i);
                let brute =
                    seeds.iter().map(|s| (0..d).map(|a| c[a].abs_diff(s[a])).max().unwrap()).min().unwrap() as u32;
                assert_eq!(v, brute, "{d}D cell {c:?}");
            }
        }
    }

    /// The parallel balance equals the plain in-place sweep (the splits are forced, so their
    /// order does not matter) on graded level maps around scattered fine cells in boxes of odd
    /// sizes, 2D and 3D (1,024 to 22,464 cells split), and leaves no two touching cells more
    /// than one level apart.
    #[test]
    fn balance_is_the_sequential_sweep() {
        fn sweep(b: &CellBox, level: &mut [u8]) {
            loop {
                let mut changed = false;
                for i in 0..b.len() {
                    let l = level[i];
                    if l >= 2 && b.touching(b.coords(i)).any(|j| level[j] + 1 < l) {
                        split_leaf(b, level, b.coords(i), l);
                        changed = true;
                    }
                }
                if !changed {
                    return;
                }
            }
        }
        for (d, m, every, per_level) in [
            (2usize, [97usize, 81, 1], 997, 1),
            (2, [83, 99, 1], 331, 2),
            (3, [41, 33, 49], 9973, 1),
            (3, [37, 45, 35], 4001, 2),
        ] {
            let b = CellBox { d, m };
            let fine: Vec<bool> = (0..b.len()).map(|i| (i * 7919 + 13) % every == 0).collect();
            let dist = chebyshev_distance(&b, &fine);
            let graded = graded_levels(&b, &dist, &Grading::new(per_level, 4).unwrap());
            let (mut fast, mut plain) = (graded.clone(), graded.clone());
            balance(&b, &mut fast);
            sweep(&b, &mut plain);
            assert_eq!(fast, plain, "{d}D {m:?}");
            let splits = fast.iter().zip(&graded).filter(|(x, y)| x != y).count();
            // (odd box sizes: the far faces keep finer cells than the bulk beside them)
            assert!(splits > 0, "{d}D {m:?}: the case needs no split");
            for i in 0..b.len() {
                assert!(b.touching(b.coords(i)).all(|j| fast[j] + 1 >= fast[i]), "{d}D cell {:?}", b.coords(i));
            }
        }
    }

    /// No fine cell: every cell is as coarse as the box and `max_level` allow.
    #[test]
    fn no_fine_cell_is_as_coarse_as_fits() {
        let b = CellBox { d: 2, m: [12, 9, 1] };
        let dist = chebyshev_distance(&b, &vec![false; b.len()]);
        let level = graded_levels(&b, &dist, &Grading::new(1, 2).unwrap());
        // 12 = 3 cells of 4, 9 = 2 cells of 4 + one row of level 0 (a level-1 cell would not fit)
        assert_eq!(level[b.index([11, 7, 0])], 2);
        assert_eq!(level[b.index([5, 8, 0])], 0);
    }
}
