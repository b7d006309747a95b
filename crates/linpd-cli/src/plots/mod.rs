//! The figures `linpd solve` and `linpd run` write beside their results: the 1D displacement
//! profile; in 2D the displacement-magnitude map, in 3D the magnitude on a lattice plane (the
//! middle z plane, or `output.slice`); the energies of a dynamics run and, in 1D, its space-time map.

mod deformed;
mod probes;

pub use probes::probe_plots;

use linpd_core::Grid;
use linpd_plot::{line_plot, scalar_map, LinePlot, PlotError, ScalarMap, Series, SeriesStyle};
use linpd_problem::{DynamicsRun, Solution, StressMap};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// What `linpd solve` draws besides `|u|` (`output.*`): the plane of a 3D map, the stress
/// map's quantity and the deformed shape's displacement scale.
#[derive(Debug, Clone, Copy, Default)]
pub struct PlotOptions {
    /// 3D: `(axis, value)` of the plane to draw (`None`: the middle z plane).
    pub slice: Option<(usize, f64)>,
    /// The stress map's quantity.
    pub stress_map: StressMap,
    /// The deformed shape's displacement scale (`None`: [`deformed::auto_scale`]).
    pub deformed_scale: Option<f64>,
}

impl PlotOptions {
    /// The options of `problem`'s `output` section.
    pub fn of(problem: &linpd_problem::Problem) -> Self {
        Self { slice: problem.slice(), stress_map: problem.stress_map(), deformed_scale: problem.deformed_scale() }
    }
}

/// A lattice plane a 2D or 3D map shows: the plane normal to axis `c` at site index `k0`,
/// drawn over the axes `(a, b)`, with its `nx x ny` sites' nodes (`None`: a site a body
/// removed).
pub(crate) struct Plane {
    pub(crate) a: usize,
    pub(crate) b: usize,
    c: usize,
    k0: usize,
    pub(crate) nx: usize,
    pub(crate) ny: usize,
    pub(crate) nodes: Vec<Option<usize>>,
}

impl Plane {
    /// The plane of a `d`-dimensional lattice nearest to `slice` (the middle z plane when
    /// `None`; the lattice itself in 2D).
    fn new(grid: &Grid, d: usize, slice: Option<(usize, f64)>) -> Self {
        let counts = grid.counts();
        let (c, k0) = match (d, slice) {
            (3, Some((axis, value))) => {
                let x0 = grid.site_position([0; 3])[axis];
                let k = ((value - x0) / grid.spacing()).round().clamp(0.0, (counts[axis] - 1) as f64);
                (axis, k as usize)
            }
            (3, None) => (2, counts[2] / 2),
            _ => (2, 0),
        };
        let (a, b) = plane_axes(c);
        let (nx, ny) = (counts[a], counts[b]);
        let mut plane = Plane { a, b, c, k0, nx, ny, nodes: Vec::new() };
        plane.nodes = (0..nx * ny).map(|q| grid.node_at_site(plane.site(q % nx, q / nx))).collect();
        plane
    }

    /// The lattice site at `(i, j)` of the plane.
    pub(crate) fn site(&self, i: usize, j: usize) -> [usize; 3] {
        let mut q = [0usize; 3];
        (q[self.a], q[self.b], q[self.c]) = (i, j, self.k0);
        q
    }

    /// The title of a map of `what` on this plane of the scene `name` (`d`-dimensional).
    pub(crate) fn title(&self, grid: &Grid, d: usize, name: &str, what: &str) -> String {
        let x = grid.site_position(self.site(0, 0));
        match d {
            3 => format!("{name}: {what} on {} = {:.4}", AXES[self.c], x[self.c]),
            _ => format!("{name}: {what}"),
        }
    }

    /// The colour map of `value(node)` over the plane, written to `stem`.
    fn map(
        &self,
        grid: &Grid,
        title: String,
        label: &str,
        value: &dyn Fn(usize) -> f64,
        stem: &Path,
    ) -> Result<Vec<PathBuf>, PlotError> {
        let (a, b, nx, ny) = (self.a, self.b, self.nx, self.ny);
        let first = grid.site_position(self.site(0, 0));
        let last = grid.site_position(self.site(nx - 1, ny - 1));
        let h = grid.spacing();
        let map = ScalarMap {
            title,
            x_label: AXES[a].into(),
            y_label: AXES[b].into(),
            nx,
            ny,
            x_range: (first[a] - 0.5 * h, last[a] + 0.5 * h),
            y_range: (first[b] - 0.5 * h, last[b] + 0.5 * h),
            values: self.nodes.iter().map(|n| n.map_or(0.0, value)).collect(),
            value_label: label.into(),
            // a site a body removed is an empty (white) cell
            empty: if grid.is_full() { Vec::new() } else { self.nodes.iter().map(Option::is_none).collect() },
            // the body's shape: a 1 x 0.1 beam is drawn 10 times wider than tall
            equal_aspect: true,
        };
        scalar_map(&map, stem)
    }
}

/// The axis names.
pub(crate) const AXES: [&str; 3] = ["x", "y", "z"];

/// The plots of a static solution on the lattice `grid` (in 3D on the lattice plane nearest
/// to `options.slice`): `|u|` (`u_magnitude`), the stress map (`stress_<quantity>`, when the
/// solution has stresses) and the deformed shape (`deformed`); in 1D the displacement
/// profile. A solution on a graded mesh's nodes is drawn on the lattice, interpolated over its
/// elements.
pub fn solution_plots(grid: &Grid, s: &Solution, dir: &Path, options: &PlotOptions) -> Result<Vec<PathBuf>, PlotError> {
    let d = s.dim;
    if d == 1 {
        return profile_1d(s, dir);
    }
    let plane = Plane::new(grid, d, options.slice);
    let on_lattice = s.x.len() == grid.len();
    let u: Cow<[f64]> = match on_lattice {
        true => Cow::Borrowed(&s.u),
        false => match from_cells(grid, s, d, &|p, k| s.u[d * p + k]) {
            Some(u) => Cow::Owned(u),
            None => return Ok(Vec::new()),
        },
    };
    let norm = |n: usize| u[d * n..d * n + d].iter().map(|x| x * x).sum::<f64>().sqrt();
    let title = plane.title(grid, d, &s.name, "|u|");
    let mut files = plane.map(grid, title, "|u|", &norm, &dir.join("u_magnitude"))?;
    if let Some(stress) = &s.stress {
        let q = options.stress_map;
        let v: Option<Vec<f64>> = match on_lattice {
            true => Some((0..grid.len()).map(|n| q.value(stress, n)).collect()),
            false => {
                // once per point: a principal stress is an eigen-solve, and a coarse cell's
                // corners are read for each of its sites
                let at_points: Vec<f64> = (0..s.x.len()).map(|p| q.value(stress, p)).collect();
                from_cells(grid, s, 1, &|p, _| at_points[p])
            }
        };
        if let Some(v) = v {
            let title = plane.title(grid, d, &s.name, &stress_title(q));
            files.extend(plane.map(grid, title, &q.name(), &|n| v[n], &dir.join(format!("stress_{}", q.name())))?);
        }
    }
    files.extend(deformed::on_plane(grid, &plane, s, &u, options.deformed_scale, dir)?);
    Ok(files)
}

/// The stress map's title.
fn stress_title(q: StressMap) -> String {
    match q {
        StressMap::VonMises => "von Mises stress".into(),
        StressMap::MaxPrincipal => "largest principal stress".into(),
        StressMap::Component(..) => format!("stress {}", q.name()),
    }
}

/// The axes `(a, b)` a map of the plane normal to axis `c` is drawn over.
fn plane_axes(c: usize) -> (usize, usize) {
    match c {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// The `width` values `value(p, k)` (`k < width`) of the solution's points `p`, interpolated
/// to every node of `grid` over `s.cells` (quads or hexahedra whose corners are lattice sites,
/// VTK's corner order): each cell's sites get the bilinear / trilinear interpolant, and each of
/// the solution's points its own value (`None` without cells, or when a corner is not a
/// lattice site).
fn from_cells(grid: &Grid, s: &Solution, width: usize, value: &dyn Fn(usize, usize) -> f64) -> Option<Vec<f64>> {
    let (d, cells) = (s.dim, s.cells.as_ref()?);
    let (h, x0, counts) = (grid.spacing(), grid.site_position([0; 3]), grid.counts());
    // bit order (bit a: the upper corner along axis a) of VTK's corners
    let bits: &[usize] = if d == 2 { &[0, 1, 3, 2] } else { &[0, 1, 3, 2, 4, 5, 7, 6] };
    let site_of = |p: usize| -> Option<[usize; 3]> {
        let x = s.x.get(p)?;
        let mut k = [0usize; 3];
        for a in 0..d {
            let t = ((x[a] - x0[a]) / h).round();
            if !(t >= 0.0 && (t as usize) < counts[a]) {
                return None;
            }
            k[a] = t as usize;
        }
        Some(k)
    };
    let mut out = vec![0.0; width * grid.len()];
    for cell in cells.connectivity.chunks(cells.per_cell.max(1)) {
        let mut corner = vec![0usize; 1 << d];
        for (v, &p) in cell.iter().enumerate() {
            corner[*bits.get(v)?] = p;
        }
        let (lo, hi) = (site_of(corner[0])?, site_of(corner[(1 << d) - 1])?);
        let side = hi[0].checked_sub(lo[0])?.max(1) as f64;
        let span = |a: usize| if a < d { lo[a]..=hi[a] } else { 0..=0 };
        for k2 in span(2) {
            for k1 in span(1) {
                for k0 in span(0) {
                    let k = [k0, k1, k2];
                    let node = grid.node_at_site(k)?;
                    // the field is continuous: a site on a face shared by two cells gets
                    // the same value from both
                    let slot = &mut out[width * node..width * node + width];
                    slot.fill(0.0);
                    for (c, &p) in corner.iter().enumerate() {
                        let w: f64 = (0..d)
                            .map(|a| {
                                let t = (k[a] - lo[a]) as f64 / side;
                                if c >> a & 1 == 1 {
                                    t
                                } else {
                                    1.0 - t
                                }
                            })
                            .product();
                        for (j, v) in slot.iter_mut().enumerate() {
                            *v += w * value(p, j);
                        }
                    }
                }
            }
        }
    }
    // the solution's own points (also those of no cell: a body thinner than a cell)
    for p in 0..s.x.len() {
        if let Some(node) = site_of(p).and_then(|k| grid.node_at_site(k)) {
            for j in 0..width {
                out[width * node + j] = value(p, j);
            }
        }
    }
    Some(out)
}

/// `|u|` of node `n`.
fn magnitude(s: &Solution, n: usize) -> f64 {
    let d = s.dim;
    (0..d).map(|k| s.u[d * n + k].powi(2)).sum::<f64>().sqrt()
}

/// The largest raster [`scattered_plots`] draws per side (cells).
pub const MAX_SCATTER_CELLS: usize = 800;

/// The plots of a static solution on scattered nodes (a point cloud or a coarsened level):
/// `|u|`, the stress map (when the solution has stresses) and the deformed shape (markers),
/// each on the nodes within half their size of the plane `options.slice` in 3D (the plane
/// through the middle of the nodes' z extent when `None`); 1D solutions get [`profile_1d`].
pub fn scattered_plots(s: &Solution, dir: &Path, options: &PlotOptions) -> Result<Vec<PathBuf>, PlotError> {
    let d = s.dim;
    if d == 1 {
        return profile_1d(s, dir);
    }
    let Some(plane) = Scatter::new(s, options.slice) else { return Ok(Vec::new()) };
    let mut files = plane.map(s, "|u|", "|u|", &|n| magnitude(s, n), &dir.join("u_magnitude"))?;
    if let Some(stress) = &s.stress {
        let q = options.stress_map;
        let stem = dir.join(format!("stress_{}", q.name()));
        files.extend(plane.map(s, &stress_title(q), &q.name(), &|n| q.value(stress, n), &stem)?);
    }
    files.extend(deformed::scattered(s, &plane, options.deformed_scale, dir)?);
    Ok(files)
}

/// The nodes of a scattered solution a map shows: in 2D all, in 3D those within half their
/// size `V_i^(1/d)` of the plane `x[c] = value`, drawn over the axes `(a, b)`.
pub(crate) struct Scatter {
    pub(crate) a: usize,
    pub(crate) b: usize,
    c: usize,
    value: f64,
    pub(crate) nodes: Vec<usize>,
}

impl Scatter {
    /// `None` without nodes on the plane or without node volumes.
    fn new(s: &Solution, slice: Option<(usize, f64)>) -> Option<Self> {
        let d = s.dim;
        let bounds = |axis: usize| {
            s.x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[axis]), hi.max(p[axis])))
        };
        let (c, value) = match (d, slice) {
            (3, Some(sl)) => sl,
            (3, None) => (2, 0.5 * (bounds(2).0 + bounds(2).1)),
            _ => (2, 0.0),
        };
        let (a, b) = plane_axes(c);
        let nodes: Vec<usize> =
            (0..s.x.len()).filter(|&n| d == 2 || (s.x[n][c] - value).abs() <= 0.5 * node_size(s, n)).collect();
        let finite = nodes.iter().all(|&n| node_size(s, n).is_finite() && node_size(s, n) > 0.0);
        (!nodes.is_empty() && finite).then_some(Scatter { a, b, c, value, nodes })
    }

    /// The colour map of `value(node)` rasterized on square cells of the smallest node size
    /// `min_i V_i^(1/d)` (coarser if the raster would exceed [`MAX_SCATTER_CELLS`] per side).
    /// Each node paints the cells within `V_i^(1/d)` of it (a node's square of volume `V_i`
    /// has its corners at `0.71 V_i^(1/d)`; the margin covers the gaps of irregular clouds,
    /// such as element centroids), a cell taking the value of its nearest node; cells no node
    /// reaches are empty (white), so holes show and edges are drawn up to half a node size
    /// too far out.
    fn map(
        &self,
        s: &Solution,
        what: &str,
        label: &str,
        value: &dyn Fn(usize) -> f64,
        stem: &Path,
    ) -> Result<Vec<PathBuf>, PlotError> {
        let (a, b, nodes) = (self.a, self.b, &self.nodes);
        let bounds = |axis: usize| {
            nodes
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &n| (lo.min(s.x[n][axis]), hi.max(s.x[n][axis])))
        };
        let (ax, bx) = (bounds(a), bounds(b));
        let pad = nodes.iter().map(|&n| node_size(s, n)).fold(0.0, f64::max);
        let (x0, x1, y0, y1) = (ax.0 - pad, ax.1 + pad, bx.0 - pad, bx.1 + pad);
        let smallest = nodes.iter().map(|&n| node_size(s, n)).fold(f64::INFINITY, f64::min);
        let cell = smallest.max((x1 - x0).max(y1 - y0) / MAX_SCATTER_CELLS as f64);
        let nx = (((x1 - x0) / cell).ceil() as usize).max(1);
        let ny = (((y1 - y0) / cell).ceil() as usize).max(1);
        let mut best = vec![(f64::INFINITY, 0.0f64); nx * ny];
        for &n in nodes {
            let (px, py, r) = (s.x[n][a], s.x[n][b], node_size(s, n));
            let i_lo = (((px - r - x0) / cell).floor().max(0.0)) as usize;
            let j_lo = (((py - r - y0) / cell).floor().max(0.0)) as usize;
            let i_hi = (((px + r - x0) / cell).ceil() as usize).min(nx - 1);
            let j_hi = (((py + r - y0) / cell).ceil() as usize).min(ny - 1);
            for j in j_lo..=j_hi {
                for i in i_lo..=i_hi {
                    let (cx, cy) = (x0 + (i as f64 + 0.5) * cell, y0 + (j as f64 + 0.5) * cell);
                    let dist = (cx - px).hypot(cy - py);
                    let slot = &mut best[i + nx * j];
                    if dist <= r && dist < slot.0 {
                        *slot = (dist, value(n));
                    }
                }
            }
        }
        let map = ScalarMap {
            title: self.title(s, what),
            x_label: AXES[a].into(),
            y_label: AXES[b].into(),
            nx,
            ny,
            x_range: (x0, x0 + nx as f64 * cell),
            y_range: (y0, y0 + ny as f64 * cell),
            values: best.iter().map(|c| if c.0.is_finite() { c.1 } else { 0.0 }).collect(),
            value_label: label.into(),
            empty: best.iter().map(|c| !c.0.is_finite()).collect(),
            equal_aspect: true,
        };
        scalar_map(&map, stem)
    }

    /// The title of a map of `what`.
    pub(crate) fn title(&self, s: &Solution, what: &str) -> String {
        match s.dim {
            3 => format!("{}: {what} on {} = {:.4} ({} nodes)", s.name, AXES[self.c], self.value, self.nodes.len()),
            _ => format!("{}: {what} ({} nodes)", s.name, self.nodes.len()),
        }
    }
}

/// A node's size `V_n^(1/d)` (`nan` without volumes).
fn node_size(s: &Solution, n: usize) -> f64 {
    s.volumes.get(n).map_or(f64::NAN, |v| v.powf(1.0 / s.dim as f64))
}

/// The 1D displacement profile (layer nodes as markers); needs only the solution, so it also
/// serves coarsened levels.
pub fn profile_1d(s: &Solution, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let (mut body, mut layer) = (Series::new("body", vec![], vec![]), Series::new("layer", vec![], vec![]));
    layer.style = SeriesStyle::Markers;
    for k in 0..s.x.len() {
        let t = if s.is_layer[k] { &mut layer } else { &mut body };
        t.x.push(s.x[k][0]);
        t.y.push(s.u[k]);
    }
    let mut series = vec![body];
    if !layer.x.is_empty() {
        series.push(layer);
    }
    let plot = LinePlot {
        title: format!("{}: displacement", s.name),
        x_label: "x".into(),
        y_label: "u".into(),
        series,
        log_x: false,
        log_y: false,
        equal_aspect: false,
    };
    line_plot(&plot, &dir.join("u"))
}

/// Plots of a dynamics run: energies over time; in 1D also the space-time map of `u(x, t)`.
pub fn dynamics_plots(r: &DynamicsRun, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let t = r.times.clone();
    let series = vec![
        Series::new("kinetic", t.clone(), r.energies.iter().map(|e| e.kinetic).collect()),
        Series::new("potential", t.clone(), r.energies.iter().map(|e| e.potential).collect()),
        Series::new("total E_k + E_p", t.clone(), r.energies.iter().map(|e| e.total()).collect()),
        // the energy velocity Verlet conserves exactly (the total oscillates around it)
        Series::new("shadow (conserved)", t.clone(), r.energies.iter().map(|e| e.shadow).collect()),
    ];
    let plot = LinePlot {
        title: format!("{}: energies", r.name),
        x_label: "t".into(),
        y_label: "energy".into(),
        series,
        log_x: false,
        log_y: false,
        equal_aspect: false,
    };
    let mut files = line_plot(&plot, &dir.join("energy"))?;
    if r.dim == 1 && r.snapshots.len() >= 2 {
        let nx = r.x.len();
        let ny = r.snapshots.len();
        let h = if nx > 1 { r.x[1][0] - r.x[0][0] } else { 1.0 };
        let dt_out = (t[ny - 1] - t[0]) / (ny - 1) as f64;
        let values: Vec<f64> = r.snapshots.iter().flat_map(|u| u.iter().copied()).collect();
        let map = ScalarMap {
            title: format!("{}: u(x, t)", r.name),
            x_label: "x".into(),
            y_label: "t".into(),
            nx,
            ny,
            x_range: (r.x[0][0] - 0.5 * h, r.x[nx - 1][0] + 0.5 * h),
            y_range: (t[0] - 0.5 * dt_out, t[ny - 1] + 0.5 * dt_out),
            values,
            value_label: "u".into(),
            empty: Vec::new(),
            equal_aspect: false,
        };
        files.extend(scalar_map(&map, &dir.join("u_xt"))?);
    }
    Ok(files)
}
