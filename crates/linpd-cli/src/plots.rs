//! The figures `linpd solve` and `linpd run` write beside their results: the 1D displacement
//! profile; in 2D the displacement-magnitude map, in 3D the magnitude on a lattice plane (the
//! middle z plane, or `output.slice`); the energies of a dynamics run and, in 1D, its space-time map.

use linpd_core::Grid;
use linpd_plot::{line_plot, scalar_map, LinePlot, PlotError, ScalarMap, Series, SeriesStyle};
use linpd_problem::{DynamicsRun, Solution};
use std::path::{Path, PathBuf};

/// The plots of a static solution on the lattice `grid`; in 3D the map shows the lattice
/// plane nearest to `slice = (axis, value)` (the middle z plane when `None`).
pub fn solution_plots(
    grid: &Grid,
    s: &Solution,
    dir: &Path,
    slice: Option<(usize, f64)>,
) -> Result<Vec<PathBuf>, PlotError> {
    let d = s.dim;
    let counts = grid.counts();
    if d == 1 {
        return profile_1d(s, dir);
    }
    // the plane's normal axis `c` at site index `k0`, drawn over the axes (a, b)
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
    let site = |i: usize, j: usize| {
        let mut q = [0usize; 3];
        (q[a], q[b], q[c]) = (i, j, k0);
        q
    };
    let (nx, ny) = (counts[a], counts[b]);
    // a solution on a graded mesh's nodes: |u| on the lattice from its cells
    let on_cells = (s.x.len() != grid.len()).then(|| magnitude_from_cells(grid, s)).flatten();
    let mag = |n: usize| on_cells.as_ref().map_or_else(|| magnitude(s, n), |m| m[n]);
    // lattice sites of the plane; a site a body removed is an empty (white) cell
    let nodes: Vec<Option<usize>> = (0..nx * ny).map(|q| grid.node_at_site(site(q % nx, q / nx))).collect();
    let values: Vec<f64> = nodes.iter().map(|n| n.map_or(0.0, mag)).collect();
    let empty: Vec<bool> = if grid.is_full() { Vec::new() } else { nodes.iter().map(Option::is_none).collect() };
    let first = grid.site_position(site(0, 0));
    let last = grid.site_position(site(nx - 1, ny - 1));
    let h = grid.spacing();
    let names = ["x", "y", "z"];
    let title =
        if d == 3 { format!("{}: |u| on {} = {:.4}", s.name, names[c], first[c]) } else { format!("{}: |u|", s.name) };
    let map = ScalarMap {
        title,
        x_label: names[a].into(),
        y_label: names[b].into(),
        nx,
        ny,
        x_range: (first[a] - 0.5 * h, last[a] + 0.5 * h),
        y_range: (first[b] - 0.5 * h, last[b] + 0.5 * h),
        values,
        value_label: "|u|".into(),
        empty,
        // the body's shape: a 1 x 0.1 beam is drawn 10 times wider than tall
        equal_aspect: true,
    };
    scalar_map(&map, &dir.join("u_magnitude"))
}

/// The axes `(a, b)` a map of the plane normal to axis `c` is drawn over.
fn plane_axes(c: usize) -> (usize, usize) {
    match c {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// `|u|` on every node of `grid` from a solution on the corners of `s.cells` (quads or
/// hexahedra whose corners are lattice sites, VTK's corner order): each cell's sites get the
/// bilinear / trilinear interpolant of `u`, and each of the solution's points its own value
/// (`None` without cells, or when a corner is not a lattice site).
fn magnitude_from_cells(grid: &Grid, s: &Solution) -> Option<Vec<f64>> {
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
    let mut u = vec![0.0; d * grid.len()];
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
                    let mut v = [0.0; 3];
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
                        for a in 0..d {
                            v[a] += w * s.u.get(d * p + a)?;
                        }
                    }
                    u[d * node..d * node + d].copy_from_slice(&v[..d]);
                }
            }
        }
    }
    // the solution's own points (also those of no cell: a body thinner than a cell)
    for p in 0..s.x.len() {
        if let Some(node) = site_of(p).and_then(|k| grid.node_at_site(k)) {
            u[d * node..d * node + d].copy_from_slice(s.u.get(d * p..d * p + d)?);
        }
    }
    Some((0..grid.len()).map(|n| u[d * n..d * n + d].iter().map(|x| x * x).sum::<f64>().sqrt()).collect())
}

/// `|u|` of node `n`.
fn magnitude(s: &Solution, n: usize) -> f64 {
    let d = s.dim;
    (0..d).map(|k| s.u[d * n + k].powi(2)).sum::<f64>().sqrt()
}

/// The largest raster [`scattered_plots`] draws per side (cells).
pub const MAX_SCATTER_CELLS: usize = 800;

/// The map of a static solution on scattered nodes (a point cloud or a coarsened level):
/// `|u|` rasterized on square cells of the smallest node size `min_i V_i^(1/d)` (coarser if
/// the raster would exceed [`MAX_SCATTER_CELLS`] per side). Each node paints the cells within
/// `V_i^(1/d)` of it (a node's square of volume `V_i` has its corners at `0.71 V_i^(1/d)`;
/// the margin covers the gaps of irregular clouds, such as element centroids), a cell taking
/// the value of its nearest node; cells no node reaches are empty (white), so holes show and
/// edges are drawn up to half a node size too far out. In 3D the nodes within half their size of the plane `slice = (axis,
/// value)` are drawn (the plane through the middle of the nodes' z extent when `None`).
/// 1D solutions get [`profile_1d`].
pub fn scattered_plots(s: &Solution, dir: &Path, slice: Option<(usize, f64)>) -> Result<Vec<PathBuf>, PlotError> {
    let d = s.dim;
    if d == 1 {
        return profile_1d(s, dir);
    }
    let size = |n: usize| s.volumes.get(n).map_or(f64::NAN, |v| v.powf(1.0 / d as f64));
    let n_all = s.x.len();
    let bounds = |axis: usize| {
        s.x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[axis]), hi.max(p[axis])))
    };
    let (c, value) = match (d, slice) {
        (3, Some(sl)) => sl,
        (3, None) => (2, 0.5 * (bounds(2).0 + bounds(2).1)),
        _ => (2, 0.0),
    };
    let (a, b) = plane_axes(c);
    let nodes: Vec<usize> = (0..n_all).filter(|&n| d == 2 || (s.x[n][c] - value).abs() <= 0.5 * size(n)).collect();
    let names = ["x", "y", "z"];
    let finite = nodes.iter().all(|&n| size(n).is_finite() && size(n) > 0.0);
    if nodes.is_empty() || !finite {
        return Ok(Vec::new());
    }
    let (ax, bx) = (bounds(a), bounds(b));
    let reach = |n: usize| size(n);
    let pad = nodes.iter().map(|&n| reach(n)).fold(0.0, f64::max);
    let (x0, x1, y0, y1) = (ax.0 - pad, ax.1 + pad, bx.0 - pad, bx.1 + pad);
    let smallest = nodes.iter().map(|&n| size(n)).fold(f64::INFINITY, f64::min);
    let cell = smallest.max((x1 - x0).max(y1 - y0) / MAX_SCATTER_CELLS as f64);
    let nx = (((x1 - x0) / cell).ceil() as usize).max(1);
    let ny = (((y1 - y0) / cell).ceil() as usize).max(1);
    let mut best = vec![(f64::INFINITY, 0.0f64); nx * ny];
    let mag = |n: usize| magnitude(s, n);
    for &n in &nodes {
        let (px, py, r) = (s.x[n][a], s.x[n][b], reach(n));
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
                    *slot = (dist, mag(n));
                }
            }
        }
    }
    let title = if d == 3 {
        format!("{}: |u| on {} = {:.4} ({} nodes)", s.name, names[c], value, nodes.len())
    } else {
        format!("{}: |u| ({} nodes)", s.name, nodes.len())
    };
    let map = ScalarMap {
        title,
        x_label: names[a].into(),
        y_label: names[b].into(),
        nx,
        ny,
        x_range: (x0, x0 + nx as f64 * cell),
        y_range: (y0, y0 + ny as f64 * cell),
        values: best.iter().map(|c| if c.0.is_finite() { c.1 } else { 0.0 }).collect(),
        value_label: "|u|".into(),
        empty: best.iter().map(|c| !c.0.is_finite()).collect(),
        equal_aspect: true,
    };
    scalar_map(&map, &dir.join("u_magnitude"))
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
