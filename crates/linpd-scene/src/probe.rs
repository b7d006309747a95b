//! Line probes (`output.probes`, issue #32): the displacement, strain and stress of a solved
//! scene sampled at `points` equally spaced points of a segment `from -> to` (both ends
//! included), written as `<name>.csv` by `linpd solve` beside a plot of each.
//!
//! # Interpolation
//!
//! A sample point's value is `sum_j phi_j(x) f_j` over nodal values `f_j` (u, the strain
//! tensor, the Hooke stress tensor; von Mises is taken of the interpolated stress), with the
//! weights `phi_j` of the solution's nodes:
//!
//! * **1D**: linear between the two nodes around `x` (the nodes sorted by position).
//! * **Lattice** (the solution holds every lattice node): the `d`-linear interpolant of the
//!   lattice cell around `x`, `phi_c = prod_a (t_a or 1 - t_a)` over its `2^d` corners, exact
//!   at the nodes and for affine fields. In a cell of the boundary, whose corners are not all
//!   nodes (outside the body, in a hole), the affine least-squares fit to the nodes of the
//!   `4^d` sites around the cell, weighted by hats of two spacings `prod_a max(0, 1 - |x_a -
//!   x_ja| / 2h)` (still exact for affine fields; at a node, its own value), or, where those
//!   nodes are fewer than `d + 1` in general position, the cell's `phi_c` over its nodes
//!   renormalized to sum 1.
//! * **Graded local mesh** (a blended scene written on its own nodes): the `d`-linear
//!   interpolant of the element (quad / hexahedron) containing `x`, the model's own field in the
//!   local zone; the lattice cells of the PD zone are elements of the mesh too.
//! * **Point clouds and coarsened levels**: moving least squares with a linear basis (exact for
//!   affine fields) over the nodes within `R = 2 max_i V_i^(1/d)`, weight `(1 - r^2/R^2)^2`;
//!   where the moment matrix is singular to `1e-10` (fewer than `d + 1` nodes in general
//!   position), the nearest node's value.
//!
//! A point is **outside** (its row in the CSV holds `NaN` and `inside = 0`) if no node of its
//! lattice cell weighs on it (in a hole or off the body, beyond the cell of its boundary
//! nodes; more than half a spacing off the lattice), in no element of a graded mesh, farther than its nearest
//! node's size `V^(1/d)` from every node of a cloud, or, in 1D, off the nodes' span.
//!
//! The interpolation does not see defects: values at a point within a cell of a crack mix its
//! two faces, so a probe across a crack shows the opening smeared over one spacing.

use crate::fields::{voigt_labels, voigt_of};
use crate::solution::Solution;
use crate::ProblemError;
use linpd_core::{Grid, Point};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The most sample points a probe may have.
pub const MAX_PROBE_POINTS: usize = 100_000;

/// A validated `output.probes` entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// The file stem (`<name>.csv`).
    pub name: String,
    /// The segment's start.
    pub from: Point,
    /// The segment's end.
    pub to: Point,
    /// Sample points, both ends included (`>= 2`).
    pub points: usize,
}

/// Validates `output.probes` of a `dim`-dimensional scene.
pub(crate) fn validate(raw: &[crate::raw::RawProbe], dim: usize) -> Result<Vec<Probe>, ProblemError> {
    let mut probes: Vec<Probe> = Vec::new();
    for (k, p) in raw.iter().enumerate() {
        let at = |key: &str| format!("output.probes[{k}].{key}");
        let name = p.name.clone().unwrap_or_else(|| format!("probe-{}", k + 1));
        let safe = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
        if name.is_empty() || !name.chars().all(safe) {
            return Err(ProblemError::invalid(
                at("name"),
                format!("{name:?} is not a file stem: use letters, digits, '-' and '_'"),
            ));
        }
        if let Some(j) = probes.iter().position(|q| q.name == name) {
            return Err(ProblemError::invalid(at("name"), format!("{name:?} is also the name of probe {j}")));
        }
        let mut ends = [[0.0; 3]; 2];
        for (end, (key, x)) in ends.iter_mut().zip([("from", &p.from), ("to", &p.to)]) {
            if x.len() != dim {
                return Err(ProblemError::invalid(at(key), format!("needs {dim} coordinates, got {}", x.len())));
            }
            if let Some(c) = x.iter().position(|v| !v.is_finite()) {
                return Err(ProblemError::invalid(format!("{}[{c}]", at(key)), "must be finite"));
            }
            end[..dim].copy_from_slice(x);
        }
        if ends[0] == ends[1] {
            return Err(ProblemError::invalid(at("to"), "equals `from`: a probe is a segment of nonzero length"));
        }
        let points = p.points.unwrap_or(101);
        if !(2..=MAX_PROBE_POINTS).contains(&points) {
            return Err(ProblemError::invalid(
                at("points"),
                format!("must be between 2 and {MAX_PROBE_POINTS} (both ends are sampled), got {points}"),
            ));
        }
        probes.push(Probe { name, from: ends[0], to: ends[1], points });
    }
    Ok(probes)
}

/// A probe's samples: per point its distance from `from`, its position, whether it is inside
/// the body, and the interpolated fields (`NaN` outside).
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeSamples {
    /// The probe.
    pub probe: Probe,
    /// Dimension `d`.
    pub dim: usize,
    /// Distance of each point from `from`.
    pub s: Vec<f64>,
    /// Positions.
    pub x: Vec<Point>,
    /// Whether each point is inside the body (see the module docs).
    pub inside: Vec<bool>,
    /// Displacement, `d` per point.
    pub u: Vec<f64>,
    /// Strain tensor per point (full `3 x 3`, row-major), if the solution has strains.
    pub strain: Option<Vec<[f64; 9]>>,
    /// Hooke stress tensor per point, if the solution has stresses.
    pub stress: Option<Vec<[f64; 9]>>,
}

impl ProbeSamples {
    /// The von Mises stress of point `k` (of the interpolated tensor).
    pub fn von_mises(&self, k: usize) -> Option<f64> {
        Some(crate::stress::von_mises(&self.stress.as_ref()?[k]))
    }

    /// The CSV's column names: `s`, the coordinates, `inside`, `u_*`, `eps_*`, `sigma_*`,
    /// `von_mises`.
    pub fn columns(&self) -> Vec<String> {
        let axes = ["x", "y", "z"];
        let d = self.dim;
        let mut c: Vec<String> = vec!["s".into()];
        c.extend(axes[..d].iter().map(|a| a.to_string()));
        c.push("inside".into());
        c.extend(axes[..d].iter().map(|a| format!("u_{a}")));
        let voigt = voigt_labels(d);
        if self.strain.is_some() {
            c.extend(voigt.iter().map(|v| format!("eps_{v}")));
        }
        if self.stress.is_some() {
            c.extend(voigt.iter().map(|v| format!("sigma_{v}")));
            c.push("von_mises".into());
        }
        c
    }

    /// Writes `<dir>/<name>.csv` (one header line of [`Self::columns`], one row per point,
    /// `NaN` outside the body, `inside` as 0 or 1); returns its path.
    pub fn write_csv(&self, dir: &Path) -> Result<PathBuf, ProblemError> {
        let path = dir.join(format!("{}.csv", self.probe.name));
        let io = |source| ProblemError::Io { path: path.display().to_string(), source };
        let mut w = std::io::BufWriter::new(std::fs::File::create(&path).map_err(io)?);
        writeln!(w, "{}", self.columns().join(",")).map_err(io)?;
        let d = self.dim;
        for k in 0..self.s.len() {
            let mut row: Vec<f64> = vec![self.s[k]];
            row.extend_from_slice(&self.x[k][..d]);
            let mut text: Vec<String> = row.iter().map(|v| format!("{v:.12e}")).collect();
            text.push(if self.inside[k] { "1" } else { "0" }.into());
            let mut row: Vec<f64> = self.u[d * k..d * k + d].to_vec();
            if let Some(e) = &self.strain {
                row.extend(voigt_of(d, &e[k]));
            }
            if let Some(sig) = &self.stress {
                row.extend(voigt_of(d, &sig[k]));
                row.push(self.von_mises(k).unwrap_or(f64::NAN));
            }
            text.extend(row.iter().map(|v| format!("{v:.12e}")));
            writeln!(w, "{}", text.join(",")).map_err(io)?;
        }
        w.flush().map_err(io)?;
        Ok(path)
    }
}

/// Samples every probe on the solution `s` (`grid`: the scene's lattice, if it has one).
pub fn sample(probes: &[Probe], s: &Solution, grid: Option<&Grid>) -> Vec<ProbeSamples> {
    if probes.is_empty() {
        return Vec::new();
    }
    let weights = Interpolant::new(s, grid);
    probes.iter().map(|p| sample_one(p, s, &weights)).collect()
}

fn sample_one(probe: &Probe, s: &Solution, interp: &Interpolant) -> ProbeSamples {
    let d = s.dim;
    let n = probe.points;
    let length = (0..d).map(|a| (probe.to[a] - probe.from[a]).powi(2)).sum::<f64>().sqrt();
    let mut out = ProbeSamples {
        probe: probe.clone(),
        dim: d,
        s: Vec::with_capacity(n),
        x: Vec::with_capacity(n),
        inside: Vec::with_capacity(n),
        u: Vec::with_capacity(d * n),
        strain: s.strain.as_ref().map(|_| Vec::with_capacity(n)),
        stress: s.stress.as_ref().map(|_| Vec::with_capacity(n)),
    };
    for k in 0..n {
        let t = k as f64 / (n - 1) as f64;
        let mut x = [0.0; 3];
        for a in 0..d {
            x[a] = probe.from[a] + t * (probe.to[a] - probe.from[a]);
        }
        let w = interp.weights(&x);
        out.s.push(t * length);
        out.x.push(x);
        out.inside.push(w.is_some());
        let w = w.unwrap_or_default();
        let blank = w.is_empty();
        let mix = |f: &dyn Fn(usize) -> f64| if blank { f64::NAN } else { w.iter().map(|&(j, c)| c * f(j)).sum() };
        for a in 0..d {
            out.u.push(mix(&|j| s.u[d * j + a]));
        }
        let tensor = |field: &[[f64; 9]]| -> [f64; 9] { std::array::from_fn(|c| mix(&|j| field[j][c])) };
        if let (Some(e), Some(field)) = (&mut out.strain, &s.strain) {
            e.push(tensor(&field.tensor));
        }
        if let (Some(e), Some(field)) = (&mut out.stress, &s.stress) {
            e.push(tensor(&field.tensor));
        }
    }
    out
}

/// The interpolation weights over a solution's nodes (see the module docs).
enum Interpolant<'a> {
    /// 1D: the nodes sorted by position.
    Line { x: Vec<f64>, order: Vec<usize> },
    /// Every lattice node.
    Lattice(&'a Grid),
    /// The elements of a graded mesh.
    Cells(BoxCells),
    /// Moving least squares over scattered nodes.
    Scattered(Mls<'a>),
}

impl<'a> Interpolant<'a> {
    fn new(s: &'a Solution, grid: Option<&'a Grid>) -> Self {
        if s.dim == 1 {
            let mut order: Vec<usize> = (0..s.x.len()).collect();
            order.sort_by(|&i, &j| s.x[i][0].total_cmp(&s.x[j][0]));
            return Interpolant::Line { x: order.iter().map(|&i| s.x[i][0]).collect(), order };
        }
        match (grid, &s.cells) {
            (Some(g), _) if g.len() == s.x.len() => Interpolant::Lattice(g),
            (_, Some(cells)) => Interpolant::Cells(BoxCells::new(s, cells)),
            _ => Interpolant::Scattered(Mls::new(s)),
        }
    }

    /// `(node, phi)` at `x`, `None` outside.
    fn weights(&self, x: &Point) -> Option<Vec<(usize, f64)>> {
        match self {
            Interpolant::Line { x: xs, order } => line_weights(xs, order, x[0]),
            Interpolant::Lattice(g) => lattice_weights(g, x),
            Interpolant::Cells(c) => c.weights(x),
            Interpolant::Scattered(m) => m.weights(x),
        }
    }
}

/// Relative slack of "inside" tests against rounding of the sample positions.
const SLACK: f64 = 1e-9;

fn line_weights(xs: &[f64], order: &[usize], x: f64) -> Option<Vec<(usize, f64)>> {
    let (first, last) = (*xs.first()?, *xs.last()?);
    let tol = SLACK * (last - first).abs().max(f64::MIN_POSITIVE);
    if !(x >= first - tol && x <= last + tol) {
        return None;
    }
    let x = x.clamp(first, last);
    let hi = xs.partition_point(|&v| v < x).min(xs.len() - 1);
    if hi == 0 || xs[hi] == x {
        return Some(vec![(order[hi], 1.0)]);
    }
    let t = (x - xs[hi - 1]) / (xs[hi] - xs[hi - 1]);
    Some(vec![(order[hi - 1], 1.0 - t), (order[hi], t)])
}

/// The `d`-linear weights of the lattice cell around `x` over its corners that are nodes.
fn lattice_weights(g: &Grid, x: &Point) -> Option<Vec<(usize, f64)>> {
    let (d, h, x0, counts) = (g.dim(), g.spacing(), g.site_position([0; 3]), g.counts());
    let (mut lo, mut frac) = ([0usize; 3], [0.0; 3]);
    for a in 0..d {
        let t = (x[a] - x0[a]) / h;
        let top = (counts[a] - 1) as f64;
        if !(t >= -0.5 - SLACK && t <= top + 0.5 + SLACK) {
            return None;
        }
        let t = t.clamp(0.0, top);
        let k = (t.floor() as usize).min(counts[a].saturating_sub(2));
        lo[a] = k;
        frac[a] = (t - k as f64).clamp(0.0, 1.0);
    }
    let mut w = Vec::with_capacity(1 << d);
    let mut complete = true;
    for c in 0..1usize << d {
        let mut site = lo;
        let mut phi = 1.0;
        for a in 0..d {
            let up = c >> a & 1 == 1;
            site[a] += usize::from(up);
            phi *= if up { frac[a] } else { 1.0 - frac[a] };
        }
        let node = (0..d).all(|a| site[a] < counts[a]).then(|| g.node_at_site(site)).flatten();
        match node {
            Some(n) if phi > 0.0 => w.push((n, phi)),
            Some(_) => {}
            None => complete = false,
        }
    }
    // no node of the cell weighs on x: off the body
    if w.is_empty() {
        return None;
    }
    // at a node (to the rounding of the sample's position), the node's own value
    if let Some(&(n, _)) = w.iter().find(|p| p.1 >= 1.0 - 1e-9) {
        return Some(vec![(n, 1.0)]);
    }
    if complete {
        return normalized(w);
    }
    // a corner is missing: the affine fit to the nodes of the 4^d sites around the cell,
    // weighted by hats of two spacings, prod_a max(0, 1 - |t_a - k_a| / 2)
    let mut near: Vec<(usize, Point, f64)> = Vec::new();
    for c in 0..4usize.pow(d as u32) {
        let mut site = [0usize; 3];
        let mut phi = 1.0;
        for a in 0..d {
            let k = (lo[a] + (c / 4usize.pow(a as u32)) % 4).checked_sub(1);
            let Some(k) = k.filter(|&k| k < counts[a]) else {
                phi = 0.0;
                break;
            };
            site[a] = k;
            phi *= (1.0 - (lo[a] as f64 + frac[a] - k as f64).abs() / 2.0).max(0.0);
        }
        if let Some(n) = (phi > 0.0).then(|| g.node_at_site(site)).flatten() {
            near.push((n, g.position(n), phi));
        }
    }
    linear_fit(d, x, h, &near).or_else(|| normalized(w))
}

/// The weights `phi_j` of the weighted linear least-squares fit at `x` over `near` (node,
/// position, weight `w_j`): with `p_j = [1, (x_j - x) / scale]` and `M = sum_j w_j p_j p_j^T`,
/// `phi_j = w_j p_j . M^-1 e_0`, exact for affine fields; `None` where `M` is singular to
/// `1e-10` (fewer than `d + 1` weighted nodes in general position).
fn linear_fit(d: usize, x: &Point, scale: f64, near: &[(usize, Point, f64)]) -> Option<Vec<(usize, f64)>> {
    let m = d + 1;
    let basis = |q: &Point| -> Vec<f64> { std::iter::once(1.0).chain((0..d).map(|a| (q[a] - x[a]) / scale)).collect() };
    let mut moment = vec![0.0; m * m];
    for (_, q, w) in near {
        let p = basis(q);
        for k in 0..m * m {
            moment[k] += w * p[k / m] * p[k % m];
        }
    }
    let e = linpd_core::eigen::symmetric_eigen(&moment, m);
    let top = e.values.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
    if !(top > 0.0) || e.values.iter().any(|&v| v <= 1e-10 * top) {
        return None;
    }
    // M^-1 e_0 = sum_k v_k (v_k . e_0) / lambda_k
    let c: Vec<f64> = (0..m).map(|i| (0..m).map(|k| e.vector(i, k) * e.vector(0, k) / e.values[k]).sum()).collect();
    Some(near.iter().map(|(j, q, w)| (*j, w * basis(q).iter().zip(&c).map(|(p, c)| p * c).sum::<f64>())).collect())
}

/// `w` scaled to sum 1 (`None` if it sums to 0).
fn normalized(mut w: Vec<(usize, f64)>) -> Option<Vec<(usize, f64)>> {
    let total: f64 = w.iter().map(|p| p.1).sum();
    if total <= SLACK {
        return None;
    }
    w.iter_mut().for_each(|p| p.1 /= total);
    Some(w)
}

/// Elements by the key of their lower corner.
type ByKey = HashMap<[i64; 3], Vec<u32>>;

/// Axis-aligned box elements (quads / hexahedra in VTK's corner order), found by their side:
/// for each side `l` the elements by `floor(lo / l)` of their lower corner, so that the element
/// containing `x` is among the `2^d` keys `floor(x / l) - {0, 1}`.
struct BoxCells {
    dim: usize,
    /// Per element its lower corner, side and corners by bit order (bit `a`: upper along `a`).
    cells: Vec<(Point, f64, [usize; 8])>,
    /// Per distinct side, the elements by key.
    by_side: Vec<(f64, ByKey)>,
}

impl BoxCells {
    fn new(s: &Solution, c: &linpd_io::vtk::Cells) -> Self {
        let d = s.dim;
        let bits: &[usize] = if d == 2 { &[0, 1, 3, 2] } else { &[0, 1, 3, 2, 4, 5, 7, 6] };
        let mut cells = Vec::new();
        for conn in c.connectivity.chunks(c.per_cell.max(1)) {
            let mut corner = [0usize; 8];
            for (v, &p) in conn.iter().enumerate().take(bits.len()) {
                corner[bits[v]] = p;
            }
            let (lo, hi) = (s.x[corner[0]], s.x[corner[(1 << d) - 1]]);
            cells.push((lo, hi[0] - lo[0], corner));
        }
        let mut by_side: Vec<(f64, ByKey)> = Vec::new();
        for (e, (lo, side, _)) in cells.iter().enumerate() {
            let slot = match by_side.iter().position(|(l, _)| (l - side).abs() <= SLACK * side) {
                Some(i) => i,
                None => {
                    by_side.push((*side, HashMap::new()));
                    by_side.len() - 1
                }
            };
            let key = Self::key(d, lo, by_side[slot].0, [0; 3]);
            by_side[slot].1.entry(key).or_default().push(e as u32);
        }
        BoxCells { dim: d, cells, by_side }
    }

    fn key(d: usize, x: &Point, side: f64, minus: [i64; 3]) -> [i64; 3] {
        std::array::from_fn(|a| if a < d { (x[a] / side).floor() as i64 - minus[a] } else { 0 })
    }

    fn weights(&self, x: &Point) -> Option<Vec<(usize, f64)>> {
        let d = self.dim;
        for (side, map) in &self.by_side {
            for m in 0..1usize << d {
                let minus = std::array::from_fn(|a| (m >> a & 1) as i64);
                for &e in map.get(&Self::key(d, x, *side, minus)).into_iter().flatten() {
                    let (lo, l, corner) = &self.cells[e as usize];
                    let t: Vec<f64> = (0..d).map(|a| (x[a] - lo[a]) / l).collect();
                    if t.iter().all(|&v| (-SLACK..=1.0 + SLACK).contains(&v)) {
                        let w = (0..1usize << d)
                            .map(|c| {
                                let phi = (0..d)
                                    .map(|a| {
                                        let v = t[a].clamp(0.0, 1.0);
                                        if c >> a & 1 == 1 {
                                            v
                                        } else {
                                            1.0 - v
                                        }
                                    })
                                    .product();
                                (corner[c], phi)
                            })
                            .collect();
                        return normalized(w);
                    }
                }
            }
        }
        None
    }
}

/// Moving least squares with a linear basis over scattered nodes (see the module docs).
struct Mls<'a> {
    s: &'a Solution,
    radius: f64,
    list: linpd_core::family::CellList,
}

impl<'a> Mls<'a> {
    fn new(s: &'a Solution) -> Self {
        let d = s.dim as i32;
        let size = s.volumes.iter().map(|v| v.powf(1.0 / d as f64)).fold(0.0, f64::max);
        let radius = if size > 0.0 { 2.0 * size } else { 2.0 * box_spacing(&s.x, s.dim) };
        Mls { s, radius, list: linpd_core::family::CellList::new(&s.x, s.dim, radius) }
    }

    fn weights(&self, x: &Point) -> Option<Vec<(usize, f64)>> {
        let (d, r2) = (self.s.dim, self.radius * self.radius);
        let mut near: Vec<(usize, f64)> = Vec::new();
        self.list.for_each_within(&self.s.x, x, |j| {
            let q = self.s.x[j as usize];
            near.push((j as usize, (0..d).map(|a| (q[a] - x[a]).powi(2)).sum()));
        });
        let &(nearest, dist2) = near.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
        let size = self.s.volumes.get(nearest).map_or(0.5 * self.radius, |v| v.powf(1.0 / d as f64));
        if dist2.sqrt() > size * (1.0 + SLACK) {
            return None;
        }
        let weighted: Vec<(usize, Point, f64)> =
            near.iter().map(|&(j, rj)| (j, self.s.x[j], (1.0 - rj / r2).max(0.0).powi(2))).collect();
        linear_fit(d, x, self.radius, &weighted).or(Some(vec![(nearest, 1.0)]))
    }
}

/// `(bounding box volume / nodes)^(1/d)`: a spacing for nodes without volumes.
fn box_spacing(x: &[Point], d: usize) -> f64 {
    let extent: f64 = (0..d)
        .map(|a| {
            let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p[a]), h.max(p[a])));
            (hi - lo).max(f64::MIN_POSITIVE)
        })
        .product();
    (extent / x.len().max(1) as f64).powf(1.0 / d as f64)
}
