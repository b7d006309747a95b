//! The leaf level of every level-0 cell: the grading rule and the 2:1 balance (see the
//! parent module's docs for the rules).

use super::Grading;

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
/// when there is none): the two-pass chamfer transform with the `3^d - 1` touching cells at
/// distance 1, exact for this metric (Rosenfeld & Pfaltz 1966).
pub(super) fn chebyshev_distance(b: &CellBox, fine: &[bool]) -> Vec<u32> {
    let mut dist: Vec<u32> = fine.iter().map(|&f| if f { 0 } else { u32::MAX }).collect();
    let relax = |dist: &mut Vec<u32>, i: usize, earlier: bool| {
        let c = b.coords(i);
        let mut best = dist[i];
        for j in b.touching(c) {
            // the forward pass reads the neighbours already swept, the backward pass the others
            if (j < i) == earlier {
                best = best.min(dist[j].saturating_add(1));
            }
        }
        dist[i] = best;
    };
    for i in 0..b.len() {
        relax(&mut dist, i, true);
    }
    for i in (0..b.len()).rev() {
        relax(&mut dist, i, false);
    }
    dist
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
        let mut next = vec![u32::MAX; coarse.len()];
        for (i, &v) in min_d.iter().enumerate() {
            let c = fine_box.coords(i);
            let p = coarse.index([c[0] / 2, c[1] / 2, c[2] / 2]);
            next[p] = next[p].min(v);
        }
        min_d = next;
        let side = 1usize << l;
        let threshold = min_distance(grading.cells_per_level, l);
        let allowed = |p: usize| {
            let o = coarse.coords(p);
            (0..d).all(|a| (o[a] + 1) * side <= b.m[a]) && min_d[p] as u64 >= threshold
        };
        let mut any = false;
        for (i, lv) in level.iter_mut().enumerate() {
            let c = b.coords(i);
            if allowed(coarse.index([c[0] >> l, c[1] >> l, c[2] >> l])) {
                *lv = l as u8;
                any = true;
            }
        }
        if !any {
            break;
        }
    }
    level
}

/// Refines leaves until every two touching level-0 cells (sharing a point: a face, an edge or
/// a corner) have leaf levels differing by at most one, i.e. the 2:1 balance across faces,
/// edges and corners. Splitting only lowers levels, so the sweeps end.
pub(super) fn balance(b: &CellBox, level: &mut [u8]) {
    loop {
        let mut changed = false;
        for i in 0..b.len() {
            let l = level[i];
            if l < 2 {
                continue;
            }
            let c = b.coords(i);
            if b.touching(c).any(|j| level[j] + 1 < l) {
                split_leaf(b, level, c, l);
                changed = true;
            }
        }
        if !changed {
            return;
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

    /// The chamfer transform against the brute-force Chebyshev distance, on scattered fine
    /// cells in 2D and 3D (a missed direction of either pass would overestimate somewhere).
    #[test]
    fn chebyshev_distance_is_exact() {
        for (d, m) in [(2usize, [23usize, 17, 1]), (3, [11, 9, 13])] {
            let b = CellBox { d, m };
            let fine: Vec<bool> = (0..b.len()).map(|i| (i * 7919 + 13) % 97 == 0).collect();
            let seeds: Vec<[usize; 3]> = (0..b.len()).filter(|&i| fine[i]).map(|i| b.coords(i)).collect();
            assert!(seeds.len() > 2);
            let dist = chebyshev_distance(&b, &fine);
            for (i, &v) in dist.iter().enumerate() {
                let c = b.coords(i);
                let brute =
                    seeds.iter().map(|s| (0..d).map(|a| c[a].abs_diff(s[a])).max().unwrap()).min().unwrap() as u32;
                assert_eq!(v, brute, "{d}D cell {c:?}");
            }
        }
    }

    /// No fine cell: every cell is as coarse as the box and `max_level` allow.
    #[test]
    fn no_fine_cell_is_as_coarse_as_fits() {
        let b = CellBox { d: 2, m: [12, 9, 1] };
        let dist = chebyshev_distance(&b, &vec![false; b.len()]);
        let level = graded_levels(&b, &dist, &Grading { cells_per_level: 1, max_level: 2 });
        // 12 = 3 cells of 4, 9 = 2 cells of 4 + one row of level 0 (a level-1 cell would not fit)
        assert_eq!(level[b.index([11, 7, 0])], 2);
        assert_eq!(level[b.index([5, 8, 0])], 0);
    }
}
