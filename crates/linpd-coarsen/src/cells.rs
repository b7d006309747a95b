//! A uniform cell list over node positions for ball and nearest-node queries.

use crate::level::dist;
use linpd_core::Point;

/// Nodes binned in cubic cells of side `s` (a dense array of cells over the bounding box).
pub(crate) struct Cells {
    dim: usize,
    lo: Point,
    s: f64,
    counts: [usize; 3],
    starts: Vec<usize>,
    items: Vec<usize>,
}

impl Cells {
    /// Bins `points[ids]` with cell side `s` (grown if the box would need more than
    /// `8 ids.len() + 64` cells, to bound memory).
    pub(crate) fn new(dim: usize, points: &[Point], ids: &[usize], s: f64) -> Self {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for a in 0..dim {
            lo[a] = ids.iter().map(|&i| points[i][a]).fold(f64::INFINITY, f64::min);
            hi[a] = ids.iter().map(|&i| points[i][a]).fold(f64::NEG_INFINITY, f64::max);
        }
        let mut s = if s.is_finite() && s > 0.0 { s } else { 1.0 };
        let cap = 8 * ids.len() + 64;
        let count = |s: f64| -> [usize; 3] {
            let mut c = [1usize; 3];
            for a in 0..dim {
                c[a] = ((hi[a] - lo[a]) / s).floor() as usize + 1;
            }
            c
        };
        while count(s).iter().product::<usize>() > cap {
            s *= 2.0;
        }
        let counts = count(s);
        let mut cells =
            Self { dim, lo, s, counts, starts: vec![0; counts.iter().product::<usize>() + 1], items: Vec::new() };
        let keys: Vec<usize> = ids.iter().map(|&i| cells.flat(cells.cell_of(&points[i]))).collect();
        for &k in &keys {
            cells.starts[k + 1] += 1;
        }
        for k in 1..cells.starts.len() {
            cells.starts[k] += cells.starts[k - 1];
        }
        let mut fill = cells.starts.clone();
        cells.items = vec![0; ids.len()];
        for (&i, &k) in ids.iter().zip(&keys) {
            cells.items[fill[k]] = i;
            fill[k] += 1;
        }
        cells
    }

    fn cell_of(&self, p: &Point) -> [i64; 3] {
        let mut c = [0i64; 3];
        for a in 0..self.dim {
            c[a] = ((p[a] - self.lo[a]) / self.s).floor() as i64;
        }
        c
    }

    fn flat(&self, c: [i64; 3]) -> usize {
        let c = [
            c[0].clamp(0, self.counts[0] as i64 - 1) as usize,
            c[1].clamp(0, self.counts[1] as i64 - 1) as usize,
            c[2].clamp(0, self.counts[2] as i64 - 1) as usize,
        ];
        c[0] + self.counts[0] * (c[1] + self.counts[1] * c[2])
    }

    /// Calls `f(i)` for every binned node in the cells overlapping the box `center +- r`.
    fn for_box(&self, center: &Point, r: f64, mut f: impl FnMut(usize)) {
        let mut lo = [0i64; 3];
        let mut hi = [0i64; 3];
        for a in 0..self.dim {
            lo[a] = (((center[a] - r - self.lo[a]) / self.s).floor() as i64).max(0);
            hi[a] = (((center[a] + r - self.lo[a]) / self.s).floor() as i64).min(self.counts[a] as i64 - 1);
            if hi[a] < lo[a] {
                return;
            }
        }
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                for cx in lo[0]..=hi[0] {
                    let k = self.flat([cx, cy, cz]);
                    for &i in &self.items[self.starts[k]..self.starts[k + 1]] {
                        f(i);
                    }
                }
            }
        }
    }

    /// Binned nodes with `|p - center| <= r` (closed ball, relative slack 1e-9 as
    /// `linpd_core::GEOMETRY_RTOL`), in no particular order.
    pub(crate) fn ball(&self, points: &[Point], center: &Point, r: f64, out: &mut Vec<usize>) {
        out.clear();
        let rr = r * (1.0 + 1e-9);
        self.for_box(center, rr, |i| {
            if dist(&points[i], center) <= rr {
                out.push(i);
            }
        });
    }

    /// The binned nodes nearest to `center` (all within a relative 1e-9 of the minimum distance).
    pub(crate) fn nearest(&self, points: &[Point], center: &Point, out: &mut Vec<usize>) {
        out.clear();
        let mut r = self.s;
        loop {
            let mut best = f64::INFINITY;
            self.for_box(center, r, |i| best = best.min(dist(&points[i], center)));
            if best <= r || r > 1e3 * self.s * (self.starts.len() as f64) {
                let tol = best * (1.0 + 1e-9) + 1e-300;
                self.for_box(center, tol, |i| {
                    if dist(&points[i], center) <= tol {
                        out.push(i);
                    }
                });
                out.sort_unstable();
                out.dedup();
                return;
            }
            r *= 2.0;
        }
    }
}
