//! One rank's part of a distributed scene (`python -m linpd.petsc`): the slab of lattice planes
//! it owns and the window it builds, owned planes plus a halo (docs/scale-out.md, "Per-rank
//! geometry").
//!
//! A lattice scene of `P` ranks is cut along its slowest axis (z in 3D, y in 2D): rank `p` owns
//! the planes `first..last` of an even split of the `planes` sites along that axis and builds
//! the scene on the window `first - halo .. last + halo` only ([`linpd_core::Grid::window`]), so
//! no rank holds an array over the whole lattice. The halo holds every node the owned rows
//! couple to and every node whose data those couplings read ([`halo_reaches`]): one reach of
//! the bonds for the bond model, three with its `energy` surface correction (a bond's factor
//! reads its ends' trace ratios, made of their bonds' factors, each the mean of two nodes' fits
//! over their families); two for LPS (the dilatation of a common partner), three with its
//! `energy` correction (a partner's dilatation reads the mean of two nodes' fits;
//! `position_aware`'s factors are the partner's own). A reach is `floor(delta / h)` planes, the lattice stencil's own reach
//! ([`linpd_core::family::lattice_stencil`], with its tolerance: a bond of length exactly
//! `delta` is one; the partial volumes' ramp stays inside `delta`).
//!
//! A point cloud (`"nodes"`, a CSV, VTK or mesh file) is cut the same way along its longest
//! axis, its planes being bins of a quarter of the bonds' reach ([`Bins`]): every rank reads
//! the file and keeps the nodes of its window only ([`Slab::balanced`] splits the bins so that
//! the ranks own as many nodes each as whole bins allow); the window's nodes are ordered by bin,
//! then by their number in the file, and that order numbers the distributed unknowns.
//!
//! What a window cannot decide alone (a constraint's region holding a node, a point load
//! sitting on one, a defect cutting a bond) is recorded as a [`Presence`] per rank in the same
//! order on every rank, and settled by one reduction (a logical or over the ranks):
//! ([`crate::scene::PartScene::presences`]).

use crate::ProblemError;
use linpd_core::Grid;
use std::cell::RefCell;
use std::ops::Range;

/// Rank `rank` of `ranks`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Part {
    /// This rank, `0..ranks`.
    pub rank: usize,
    /// Number of ranks, `>= 1`.
    pub ranks: usize,
}

/// The planes a rank owns and the window it builds, in site numbers `0..planes` along the
/// lattice's slowest axis (layers included).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slab {
    /// Sites along the slowest axis of the whole lattice.
    pub planes: usize,
    /// The planes this rank owns (empty when there are more ranks than planes).
    pub owned: Range<usize>,
    /// The planes it builds: the owned ones and `halo` on each side (one plane, owning
    /// nothing, when `owned` is empty).
    pub window: Range<usize>,
    /// Lattice index of plane 0 along the slowest axis (below 0 inside a lower layer).
    pub index0: i64,
}

impl Slab {
    /// The slab of `part` on `whole` (a grid before any body) with `halo` planes on each side:
    /// an even split of the planes, the first `planes % ranks` ranks one plane more.
    pub fn of(whole: &Grid, part: Part, halo: usize) -> Slab {
        let axis = whole.dim() - 1;
        let planes = whole.counts()[axis];
        let (q, r) = (planes / part.ranks, planes % part.ranks);
        let first = part.rank * q + part.rank.min(r);
        let last = first + q + usize::from(part.rank < r);
        let window = if first == last {
            let p = first.min(planes - 1);
            p..p + 1
        } else {
            first.saturating_sub(halo)..(last + halo).min(planes)
        };
        Slab { planes, owned: first..last, window, index0: whole.lattice_index(0)[axis] }
    }

    /// The slab of `part` over planes holding `counts[k]` nodes each, with `halo` planes on each
    /// side: contiguous runs of planes, rank `p`'s starting at the first plane `k` with
    /// `sum_{l < k} counts[l] >= p N / P` (`N` nodes in all), so that the ranks own about
    /// `N / P` nodes each; a rank owning nothing builds one plane, the last plane before its
    /// empty run (which holds nodes: a run starts just after the plane that reached its share).
    pub fn balanced(counts: &[usize], part: Part, halo: usize) -> Slab {
        let planes = counts.len();
        let total: u128 = counts.iter().map(|&c| c as u128).sum();
        let (p, ranks) = (part.rank as u128, part.ranks as u128);
        let cut = |q: u128| -> usize {
            let mut before = 0u128;
            for (k, &c) in counts.iter().enumerate() {
                if before * ranks >= q * total {
                    return k;
                }
                before += c as u128;
            }
            planes
        };
        let (first, last) = (cut(p), if p + 1 == ranks { planes } else { cut(p + 1) });
        let window = if first == last {
            let k = first.saturating_sub(1).min(planes.saturating_sub(1));
            k..k + 1
        } else {
            first.saturating_sub(halo)..(last + halo).min(planes)
        };
        Slab { planes, owned: first..last, window, index0: 0 }
    }

    /// The plane (`0..planes`) of a node with lattice index `idx`.
    pub fn plane(&self, idx: [i64; 3], dim: usize) -> usize {
        (idx[dim - 1] - self.index0) as usize
    }
}

/// Halo planes of a model whose rows reach `reaches` horizons (1: bond, 2: LPS; one more with a
/// surface correction) at `horizon / spacing = ratio`.
pub fn halo_reaches(reaches: usize, ratio: f64) -> usize {
    reaches * (ratio * (1.0 + linpd_core::GEOMETRY_RTOL)).floor() as usize
}

/// A point cloud's planes: bins of equal width along the axis the cloud is longest in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bins {
    /// The axis (`0..d`).
    pub axis: usize,
    /// The smallest coordinate along it.
    pub origin: f64,
    /// The width of a bin.
    pub width: f64,
    /// The number of bins.
    pub count: usize,
}

impl Bins {
    /// At most this many bins (a cloud far longer than its reach gets wider bins).
    pub const MAX: usize = 1 << 20;

    /// Bins of `reach / 4` (wider if there would be more than [`Bins::MAX`]) over the box
    /// `bounds` (lower and upper corners of the nodes) along its longest axis (the last of
    /// equally long ones, as a lattice's slowest axis).
    pub fn over(bounds: &[linpd_core::Point; 2], dim: usize, reach: f64) -> Bins {
        let side = |a: usize| bounds[1][a] - bounds[0][a];
        let axis = (0..dim).rev().max_by(|&a, &b| side(a).total_cmp(&side(b))).unwrap_or(0);
        let (lo, hi) = (bounds[0][axis], bounds[1][axis]);
        let extent = if hi > lo { hi - lo } else { 0.0 };
        let width = (reach / 4.0).max(extent / Self::MAX as f64);
        let width = if width.is_finite() && width > 0.0 { width } else { 1.0 };
        let count = ((extent / width).floor() as usize + 1).min(Self::MAX);
        Bins { axis, origin: if lo.is_finite() { lo } else { 0.0 }, width, count }
    }

    /// The bin of a node at `x`.
    pub fn of_point(&self, x: &linpd_core::Point) -> usize {
        (((x[self.axis] - self.origin) / self.width).floor().max(0.0) as usize).min(self.count - 1)
    }

    /// Bins on each side that hold every node within `distance` of a node in a given bin:
    /// nodes `a` and `b` bins apart are more than `(a - b - 1) width` apart along the axis, so
    /// `ceil(distance / width)` bins (the distance widened by `1e-6` for the family's own
    /// tolerance and the bins' rounding).
    pub fn halo(&self, distance: f64) -> usize {
        (distance * (1.0 + 1e-6) / self.width).ceil() as usize
    }
}

/// A rank's window of a point cloud: the file's nodes the rank keeps, in bin order.
#[derive(Debug, Clone, PartialEq)]
pub struct CloudWindow {
    /// The bins.
    pub bins: Bins,
    /// Each window node's number in the file (0-based, in the order the file lists them).
    pub file_node: Vec<u32>,
    /// The whole cloud's bounding box, lower and upper corners (unused coordinates 0).
    pub bounds: [linpd_core::Point; 2],
}

/// A check a window cannot decide alone: does some rank's part hold what `path` needs?
#[derive(Debug, Clone, PartialEq)]
pub struct Presence {
    /// The JSON path the error names.
    pub path: String,
    /// The error's reason when no rank found it.
    pub reason: String,
    /// Whether this rank's window found it.
    pub found: bool,
}

/// Presence checks during validation: errors at once on a whole scene, recorded on a part.
#[derive(Debug, Default)]
pub(crate) struct Presences(Option<RefCell<Vec<Presence>>>);

impl Presences {
    /// For a part (`true`) or a whole scene.
    pub(crate) fn new(part: bool) -> Self {
        Presences(part.then(|| RefCell::new(Vec::new())))
    }
    /// Whether this validates a part.
    pub(crate) fn is_part(&self) -> bool {
        self.0.is_some()
    }
    /// `found`, or the error `missing()` (on a whole scene at once; on a part recorded).
    pub(crate) fn require(&self, found: bool, missing: impl FnOnce() -> ProblemError) -> Result<(), ProblemError> {
        match &self.0 {
            None if found => Ok(()),
            None => Err(missing()),
            Some(list) => {
                let (path, reason) = match missing() {
                    ProblemError::Invalid { path, reason } => (path, reason),
                    other => (String::new(), other.to_string()),
                };
                list.borrow_mut().push(Presence { path, reason, found });
                Ok(())
            }
        }
    }
    /// The recorded checks.
    pub(crate) fn take(&self) -> Vec<Presence> {
        self.0.as_ref().map(|l| l.take()).unwrap_or_default()
    }
}

/// The first check no rank found (`found_anywhere[k]`: the or over the ranks of check `k`'s
/// `found`), as the error a whole scene would give.
pub fn settle(presences: &[Presence], found_anywhere: &[bool]) -> Result<(), ProblemError> {
    if presences.len() != found_anywhere.len() {
        return Err(ProblemError::invalid(
            "ranks",
            format!(
                "the ranks recorded different checks ({} here, {} reduced): every rank must read the same scene",
                presences.len(),
                found_anywhere.len()
            ),
        ));
    }
    match presences.iter().zip(found_anywhere).find(|(_, f)| !**f) {
        Some((p, _)) => Err(ProblemError::invalid(p.path.clone(), p.reason.clone())),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use linpd_core::Placement;

    #[test]
    fn slabs_cover_the_planes_once_with_halos_inside_the_box() {
        let whole = Grid::new(&[0.0, 0.0, 0.0], &[1.0, 1.0, 1.0], 0.1, 0.0, Placement::Vertex).unwrap();
        for ranks in [1, 2, 3, 4, 11, 13] {
            let mut next = 0;
            for rank in 0..ranks {
                let s = Slab::of(&whole, Part { rank, ranks }, 4);
                assert_eq!(s.owned.start, next);
                next = s.owned.end;
                assert!(s.window.start < s.window.end && s.window.end <= 11);
                if !s.owned.is_empty() {
                    assert_eq!(s.window.start, s.owned.start.saturating_sub(4));
                    assert_eq!(s.window.end, (s.owned.end + 4).min(11));
                }
            }
            assert_eq!(next, 11, "{ranks} ranks");
        }
        assert_eq!((halo_reaches(2, 3.0), halo_reaches(1, 2.999)), (6, 2));
    }

    #[test]
    fn a_check_fails_only_where_no_rank_found() {
        let p = Presences::new(true);
        p.require(false, || ProblemError::invalid("loads[0].region", "contains no node")).unwrap();
        p.require(true, || ProblemError::invalid("loads[1].region", "contains no node")).unwrap();
        let list = p.take();
        assert!(settle(&list, &[true, true]).is_ok());
        let e = settle(&list, &[false, true]).unwrap_err().to_string();
        assert_eq!(e, "loads[0].region: contains no node");
        assert!(settle(&list, &[true]).is_err());
        assert!(Presences::new(false).require(false, || ProblemError::invalid("x", "y")).is_err());
    }
}
