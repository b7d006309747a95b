//! One coarsening step, eqs. (8)-(14), with the neighbourhood-class cache and the radius rule.

use crate::cells::Cells;
use crate::level::dist;
use crate::retain::{check_retained, coarse_volumes};
use crate::transfer::Transfer;
use crate::{CoarsenError, LevelModel};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use linpd_core::progress::{NoProgress, Progress, Task};
use linpd_core::Point;
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Instant;

/// One local solve's output: the coarsened row values, the load-transfer row `T_x`
/// ([`crate::Transfer`]), whether the sparse LU was used, and the local problem's size.
type LocalRow = (Vec<f64>, Vec<f64>, bool, usize);

/// What "the level-m force equals the level-(m-1) force" (9) is applied to; see the crate docs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Matching {
    /// `v^m_x L^m(x) = v^{m-1}_x L^{m-1}(x)`: the nodal *force* matches (default). Preserves
    /// the bulk modulus and gives a symmetric `C^m` for any coarse volumes when `N_x` is the
    /// whole body. Body forces are lumped as nodal forces.
    TotalForce,
    /// `L^m(x) = L^{m-1}(x)`: the force *density* matches, literally as printed in (9).
    ForceDensity,
}

/// Most radii the radius rule ([`Radius::Auto`]) may try: with the default growth 1.25 from
/// `2 delta`, 40 radii reach `1.25^39 x 2 delta ~ 6000 delta`, beyond any body a coarsening
/// step can hold; a growth so close to 1 that more are needed (`1.000000001`) would run for
/// days and is refused before the first step.
pub const MAX_RADII: usize = 40;

/// How the neighbourhood radius `r^m` is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Radius {
    /// Use this `r^m` (must be at least the level-(m-1) horizon).
    Fixed(f64),
    /// The rule of Sec. 3 made precise: try `r = start, start*growth, ...` (at most `max`) and
    /// stop at the first `r` whose tail ([`StepReport::tail`]) is below `tol`.
    Auto {
        /// Relative tail tolerance.
        tol: f64,
        /// First radius (default `2 delta^{m-1}`, the paper's footnote 1, capped by `max`).
        start: Option<f64>,
        /// Growth factor (> 1).
        growth: f64,
        /// Largest radius tried (default: the body's diameter, where `N_x` is the whole body,
        /// or `start` if that is larger).
        max: Option<f64>,
    },
}

/// Options of a coarsening step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// `r^m`.
    pub radius: Radius,
    /// Force or force-density matching.
    pub matching: Matching,
    /// Share one local solve among nodes whose neighbourhoods are equal up to translation.
    pub cache: bool,
    /// Local problems with more unknowns than this use a sparse LU instead of a dense one.
    pub dense_limit: usize,
}

impl Options {
    /// Fixed radius, force matching, cache on, dense up to 1500 local unknowns.
    pub fn fixed(radius: f64) -> Self {
        Self { radius: Radius::Fixed(radius), matching: Matching::TotalForce, cache: true, dense_limit: 1500 }
    }
}

/// What one step did and cost.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct StepReport {
    /// Nodes of level m-1.
    pub n_fine: usize,
    /// Nodes of level m.
    pub n_coarse: usize,
    /// The level-(m-1) horizon `delta^{m-1}` (largest bond length).
    pub horizon_fine: f64,
    /// The radius used.
    pub radius: f64,
    /// Tail: the largest `|C^m(x,q)|_F` with `r - w < |q - x| <= r`, relative to the
    /// row's largest `|C^m(x,q)|_F`, maximised over `x`; 0 when every `N_x` is the whole body.
    /// The shell's width `w = max(delta^{m-1}, h^m)` is at least the coarse node spacing
    /// `h^m = max_x (v^m_x)^{1/d}`, so that it holds a ring of coarse nodes (a shell one fine
    /// horizon wide can fall between two rings of coarse nodes and read 0).
    pub tail: f64,
    /// The shell width `w` of the tail.
    pub shell_width: f64,
    /// Every `(radius, tail)` tried by the radius rule, in order.
    pub tried: Vec<(f64, f64)>,
    /// Every `N_x` was the whole body (the radius reached the body's diameter): the step is
    /// exact static condensation and the tail is 0.
    pub whole_body: bool,
    /// Distinct neighbourhood classes (local solves done).
    pub classes: usize,
    /// `1 - classes / n_coarse`: the fraction of retained nodes whose local solve was reused.
    pub hit_rate: f64,
    /// Largest number of local unknowns `d |N_x \ R_x|`.
    pub local_unknowns_max: usize,
    /// Mean number of local unknowns over the classes.
    pub local_unknowns_mean: f64,
    /// Local solves by sparse LU.
    pub sparse_solves: usize,
    /// Local solves by dense Cholesky (symmetric case) or LU.
    pub dense_solves: usize,
    /// `max |C^m_ij - C^m_ji^T| / max |C^m|` of the coarse rows (before any symmetrisation).
    pub asymmetry: f64,
    /// Wall time of the last radius tried: neighbourhoods and signatures.
    pub seconds_neighbourhoods: f64,
    /// ... local solves.
    pub seconds_solves: f64,
    /// ... assembling the coarse model.
    pub seconds_assemble: f64,
    /// Wall time of the whole step, all radii.
    pub seconds_total: f64,
}

/// Result of one coarsening step.
#[derive(Debug, Clone)]
pub struct Coarsened {
    /// The level-m model (node `k` is level-(m-1) node `parent[k]`).
    pub model: LevelModel,
    /// Level-(m-1) index of each level-m node (sorted).
    pub parent: Vec<usize>,
    /// Radius, tail, cache and timings.
    pub report: StepReport,
    /// The load transfer `f^m = S^T f^{m-1}` of this step ([`Transfer::restrict`]).
    pub transfer: Transfer,
}

/// The local problem (13)-(14) of one retained node.
#[derive(Debug, Clone)]
pub struct LocalResolvent {
    /// Level-(m-1) indices of `N_x`: retained nodes (`R_x`) first, then the excluded ones, each
    /// group ordered by offset from `x`.
    pub nodes: Vec<usize>,
    /// Number of retained nodes `R` (the first `R` entries of `nodes`).
    pub n_retained: usize,
    /// `S` (`d N x d R`): the retained columns of `A^{-1}`, eq. (14); `u_p = sum_q S_pq u_q`.
    pub s: Mat<f64>,
}

/// One coarsening step with a fixed radius and default options.
pub fn coarsen(fine: &LevelModel, retained: &[usize], radius: f64) -> Result<Coarsened, CoarsenError> {
    coarsen_with(fine, retained, &Options::fixed(radius))
}

/// One coarsening step (8)-(14) of `fine` onto `retained` (level-(m-1) indices of `B^m`).
pub fn coarsen_with(fine: &LevelModel, retained: &[usize], opts: &Options) -> Result<Coarsened, CoarsenError> {
    coarsen_with_progress(fine, retained, opts, &NoProgress)
}

/// [`coarsen_with`] reporting to `progress`: one task `"local solves (r = <r>)"` per radius tried (one
/// per step with a fixed radius) whose steps are the neighbourhood classes solved.
pub fn coarsen_with_progress(
    fine: &LevelModel,
    retained: &[usize],
    opts: &Options,
    progress: &dyn Progress,
) -> Result<Coarsened, CoarsenError> {
    let t0 = Instant::now();
    let parent = check_retained(retained, fine.len())?;
    let delta = fine.horizon();
    let diameter = diameter(fine);
    let check_radius = |r: f64| -> Result<(), CoarsenError> {
        if !r.is_finite() || r <= 0.0 {
            return Err(CoarsenError::InvalidInput(format!("coarsening radius must be finite and > 0, got {r:e}")));
        }
        if r < delta * (1.0 - 1e-9) {
            return Err(CoarsenError::RadiusBelowHorizon { radius: r, horizon: delta });
        }
        Ok(())
    };
    let step = Step::new(fine, parent, opts, progress)?;
    let (mut out, tried) = match opts.radius {
        Radius::Fixed(r) => {
            check_radius(r)?;
            let c = step.run(r, delta, diameter)?;
            let t = c.report.tail;
            (c, vec![(r, t)])
        }
        Radius::Auto { tol, start, growth, max } => {
            if !(tol > 0.0) || !(growth > 1.0) {
                return Err(CoarsenError::InvalidInput(format!(
                    "radius rule needs tol > 0 and growth > 1, got tol = {tol}, growth = {growth}"
                )));
            }
            // Defaults never contradict each other or a value the user gave: the default start
            // 2 delta is capped by the largest radius (the body's diameter by default, where
            // N_x is the whole body and the tail is 0), and the default largest radius is at
            // least a start the user gave. Only a user's start above a user's maximum is an error.
            let whole = diameter * (1.0 + 1e-9);
            let r_max = max.unwrap_or_else(|| whole.max(start.unwrap_or(0.0)));
            let mut r = start.unwrap_or_else(|| (2.0 * delta).min(r_max));
            check_radius(r)?;
            if r_max < r {
                return Err(CoarsenError::InvalidInput(format!(
                    "radius rule: radius_max {r_max:e} is below radius_start {r:e}"
                )));
            }
            // Every radius tried is a whole coarsening step: bound their number before the
            // first one. Radii beyond the body's diameter all give the whole body (tail 0), so
            // the rule stops at the first of them.
            let last = r_max.min(diameter * (1.0 + 1e-9)).max(r);
            let radii = ((last / r).ln() / growth.ln()).ceil() + 1.0;
            if radii > MAX_RADII as f64 {
                return Err(CoarsenError::InvalidInput(format!(
                    "radius rule: growth {growth:e} from {r:e} to {last:e} would try up to {radii:e} radii (each a full coarsening step), more than {MAX_RADII}: raise radius_growth (default 1.25) or narrow radius_start..radius_max"
                )));
            }
            let mut tried = Vec::new();
            loop {
                let c = step.run(r, delta, diameter)?;
                tried.push((r, c.report.tail));
                if c.report.tail <= tol {
                    break (c, tried);
                }
                if r >= r_max {
                    return Err(CoarsenError::TailNotReached { tol, radius: r, tail: c.report.tail, tried });
                }
                r = (r * growth).min(r_max);
            }
        }
    };
    out.report.tried = tried;
    out.report.seconds_total = t0.elapsed().as_secs_f64();
    Ok(out)
}

fn diameter(m: &LevelModel) -> f64 {
    let d = m.dim();
    (0..d)
        .map(|a| {
            let lo = m.positions().iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let hi = m.positions().iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max);
            (hi - lo).powi(2)
        })
        .sum::<f64>()
        .sqrt()
}

/// A neighbourhood's retained nodes, its excluded nodes (local order) and its class signature.
type HoodSplit = (Vec<usize>, Vec<usize>, (u64, u64));

/// The neighbourhood classes of a step's retained nodes (see `Step::classes`).
struct Classes {
    /// The retained nodes of each node's `N_x`, in local order.
    retained: Vec<Vec<usize>>,
    /// The excluded nodes of each node's `N_x`, in local order.
    excluded: Vec<Vec<usize>>,
    /// Each node's class.
    class_of: Vec<usize>,
    /// Each class's first node (whose local problem is solved).
    reps: Vec<usize>,
}

/// Radius-independent data of a step.
struct Step<'a> {
    fine: &'a LevelModel,
    parent: Vec<usize>,
    is_retained: Vec<bool>,
    coarse_index: Vec<usize>,
    vm: Vec<f64>,
    opts: Options,
    progress: &'a dyn Progress,
    /// Quantum of the micromodulus values and volumes in the class signature.
    c_quantum: f64,
    v_quantum: f64,
    /// The coarse node spacing `h^m = max_x (v^m_x)^{1/d}`.
    h_coarse: f64,
}

/// A neighbourhood: retained nodes first, then excluded, each group ordered by offset.
struct Hood {
    nodes: Vec<usize>,
    n_r: usize,
    /// `(global, local)` sorted by global index, for lookups.
    lookup: Vec<(usize, u32)>,
}

impl Hood {
    fn local(&self, p: usize) -> Option<usize> {
        self.lookup.binary_search_by_key(&p, |e| e.0).ok().map(|k| self.lookup[k].1 as usize)
    }
}

impl<'a> Step<'a> {
    fn new(
        fine: &'a LevelModel,
        parent: Vec<usize>,
        opts: &Options,
        progress: &'a dyn Progress,
    ) -> Result<Self, CoarsenError> {
        let n = fine.len();
        let mut is_retained = vec![false; n];
        let mut coarse_index = vec![usize::MAX; n];
        for (k, &p) in parent.iter().enumerate() {
            is_retained[p] = true;
            coarse_index[p] = k;
        }
        let vm = coarse_volumes(fine, &parent);
        let c_quantum = 1e-12 * fine.max_abs().max(f64::MIN_POSITIVE);
        let v_quantum = 1e-12 * fine.volumes().iter().copied().fold(0.0, f64::max);
        let h_coarse = vm.iter().map(|v| v.powf(1.0 / fine.dim() as f64)).fold(0.0, f64::max);
        Ok(Self { fine, parent, is_retained, coarse_index, vm, opts: *opts, progress, c_quantum, v_quantum, h_coarse })
    }

    /// `N_x` for retained node `xi` in canonical order (see [`Hood`]); `keys` are the quantized
    /// offsets `round((p - x) / q)`, `q = 1e-9 r`.
    fn hood(&self, cells: &Cells, xi: usize, r: f64, buf: &mut Vec<usize>) -> (Hood, Vec<[i64; 3]>) {
        let x = self.fine.positions();
        cells.ball(x, &x[xi], r, buf);
        let q = 1e-9 * r;
        let key = |p: usize| -> [i64; 3] {
            let mut k = [0i64; 3];
            for a in 0..3 {
                k[a] = ((x[p][a] - x[xi][a]) / q).round() as i64;
            }
            k
        };
        let mut tagged: Vec<(bool, [i64; 3], usize)> = buf.iter().map(|&p| (!self.is_retained[p], key(p), p)).collect();
        tagged.sort_unstable();
        let n_r = tagged.iter().take_while(|t| !t.0).count();
        let nodes: Vec<usize> = tagged.iter().map(|t| t.2).collect();
        let keys: Vec<[i64; 3]> = tagged.iter().map(|t| t.1).collect();
        let mut lookup: Vec<(usize, u32)> = nodes.iter().enumerate().map(|(l, &p)| (p, l as u32)).collect();
        lookup.sort_unstable();
        (Hood { nodes, n_r, lookup }, keys)
    }

    /// 128-bit signature of everything the local solve of `hood` reads: the offsets, retained
    /// flags and volumes of `N_x`, and the bonds inside `N_x` of `x` and of every excluded node
    /// (values quantized at 1e-12 of the level's largest |C| and volume). Equal signatures mean
    /// neighbourhoods equal up to translation, to that quantum.
    fn signature(&self, hood: &Hood, keys: &[[i64; 3]], xl: usize) -> (u64, u64) {
        let mut h = Hasher::new();
        let d = self.fine.dim();
        h.add(d as u64);
        h.add(hood.n_r as u64);
        h.add(hood.nodes.len() as u64);
        h.add(xl as u64);
        for (l, &p) in hood.nodes.iter().enumerate() {
            for &k in &keys[l] {
                h.add(k as u64);
            }
            h.add((self.fine.volumes()[p] / self.v_quantum).round() as i64 as u64);
        }
        let rows = std::iter::once(xl).chain(hood.n_r..hood.nodes.len());
        for l in rows {
            let z = hood.nodes[l];
            // bonds in any storage order: a commutative sum of per-bond hashes
            let (mut s1, mut s2, mut count) = (0u64, 0u64, 0u64);
            for (&p, b) in self.fine.partners(z).iter().zip(self.fine.blocks(z).chunks(d * d)) {
                if let Some(lp) = hood.local(p) {
                    let mut hb = Hasher::new();
                    hb.add(lp as u64);
                    for &c in b {
                        hb.add((c / self.c_quantum).round() as i64 as u64);
                    }
                    let (a1, a2) = hb.finish();
                    s1 = s1.wrapping_add(a1);
                    s2 = s2.wrapping_add(a2);
                    count += 1;
                }
            }
            h.add(l as u64);
            h.add(count);
            h.add(s1);
            h.add(s2);
        }
        h.finish()
    }

    /// The rows of `x` in `N_x`: the direct blocks `W_{x,R}` to the retained nodes (`d x dR`,
    /// blocks row-major in local order) and `G = W_{x,E}` to the excluded ones (`d x dE`).
    fn x_rows(&self, hood: &Hood, xi: usize) -> (Vec<f64>, Mat<f64>) {
        let fine = self.fine;
        let d = fine.dim();
        let (nr, v) = (hood.n_r, fine.volumes());
        let mut direct = vec![0.0; d * d * nr];
        let mut g = Mat::<f64>::zeros(d, d * (hood.nodes.len() - nr));
        for (&p, b) in fine.partners(xi).iter().zip(fine.blocks(xi).chunks(d * d)) {
            let Some(lp) = hood.local(p) else { continue };
            let w = v[xi] * v[p];
            for a in 0..d {
                for c in 0..d {
                    let val = w * b[a * d + c];
                    if lp < nr {
                        direct[lp * d * d + a * d + c] += val;
                    } else {
                        g[(a, d * (lp - nr) + c)] += val;
                    }
                }
            }
        }
        (direct, g)
    }

    /// The equilibrium rows (3)-(5) of the excluded nodes, interactions inside `N_x` (4):
    /// `M u_E = -B u_R` with `M_zp = W_zp` (`p` excluded), `M_zz = -sum_{p in N_x} W_zp`,
    /// `B_zq = W_zq`; `M` as triplets (`dE x dE`), `B` dense (`dE x dR`).
    fn excluded_rows(&self, hood: &Hood) -> (Vec<Triplet<usize, usize, f64>>, Mat<f64>) {
        let fine = self.fine;
        let d = fine.dim();
        let (nr, v) = (hood.n_r, fine.volumes());
        let ne = hood.nodes.len() - nr;
        let mut m_trip: Vec<Triplet<usize, usize, f64>> = Vec::new();
        let mut bmat = Mat::<f64>::zeros(d * ne, d * nr);
        for e in 0..ne {
            let z = hood.nodes[nr + e];
            let mut diag = vec![0.0; d * d];
            for (&p, b) in fine.partners(z).iter().zip(fine.blocks(z).chunks(d * d)) {
                let Some(lp) = hood.local(p) else { continue };
                let w = v[z] * v[p];
                for a in 0..d {
                    for c in 0..d {
                        let val = w * b[a * d + c];
                        if val == 0.0 {
                            continue;
                        }
                        diag[a * d + c] -= val;
                        if lp < nr {
                            bmat[(d * e + a, d * lp + c)] += val;
                        } else {
                            m_trip.push(Triplet::new(d * e + a, d * (lp - nr) + c, val));
                        }
                    }
                }
            }
            for a in 0..d {
                for c in 0..d {
                    m_trip.push(Triplet::new(d * e + a, d * e + c, diag[a * d + c]));
                }
            }
        }
        (m_trip, bmat)
    }

    /// The coarse nodal-stiffness row `W^m_{x,q}`, `q` over the retained nodes of `hood` in
    /// local order (`d x d` blocks, row-major), the load-transfer row `T_x = -G M^{-1}`
    /// (`d x d|E_x|`, row-major; [`Transfer`]), and the local solver used (true = sparse).
    fn local_row(&self, hood: &Hood, xi: usize, r: f64) -> Result<(Vec<f64>, Vec<f64>, bool), CoarsenError> {
        let fine = self.fine;
        let d = fine.dim();
        let (nn, nr) = (hood.nodes.len(), hood.n_r);
        let ne = nn - nr;
        structural_check(fine, hood, xi, r)?;
        let de = d * ne;
        let (direct, g) = self.x_rows(hood, xi);
        let (m_trip, bmat) = self.excluded_rows(hood);
        // Z^T = M^{-T} G^T (d right-hand sides instead of the d R of S = -M^{-1} B):
        // W^m_{x,R} = W_{x,R} + W_{x,E} S_E = direct - G M^{-1} B = direct - Z B.
        let sparse = de > self.opts.dense_limit;
        let singular = |excl_local: usize, reason: &str| {
            let z = hood.nodes[nr + excl_local.min(ne.saturating_sub(1))];
            CoarsenError::singular(fine, xi, r, z, reason)
        };
        let zt: Mat<f64> = if ne == 0 {
            Mat::zeros(0, d)
        } else if sparse {
            let mt: Vec<Triplet<usize, usize, f64>> =
                m_trip.iter().map(|t| Triplet::new(t.col, t.row, t.val)).collect();
            let mt = SparseColMat::<usize, f64>::try_new_from_triplets(de, de, &mt).expect("indices in range");
            let lu = mt.sp_lu().map_err(|_| singular(0, "makes the sparse LU of the local problem fail"))?;
            use faer::linalg::solvers::Solve;
            lu.solve(g.transpose().to_owned())
        } else {
            let mut m = Mat::<f64>::zeros(de, de);
            for t in &m_trip {
                m[(t.row, t.col)] += t.val;
            }
            let scale = m.norm_max();
            let symmetric = (0..de).all(|i| (0..i).all(|j| (m[(i, j)] - m[(j, i)]).abs() <= 1e-12 * scale));
            if symmetric {
                // -M is SPD when the excluded nodes are held by the retained ones
                let neg = -&m;
                match neg.llt(Side::Lower) {
                    Ok(llt) => {
                        use faer::linalg::solvers::Solve;
                        -llt.solve(g.transpose().to_owned())
                    }
                    Err(faer::linalg::solvers::LltError::NonPositivePivot { index }) => {
                        return Err(singular(
                            index / d,
                            "is not held in every direction by bonds inside N_x (zero or negative pivot of the local problem (13); a mechanism)",
                        ))
                    }
                }
            } else {
                use faer::linalg::solvers::Solve;
                m.transpose().to_owned().partial_piv_lu().solve(g.transpose().to_owned())
            }
        };
        // numeric check: finite and a small residual of M^T Z^T = G^T
        if ne > 0 {
            if zt.col_iter().any(|c| c.iter().any(|t| !t.is_finite())) {
                return Err(singular(0, "makes the local problem (13) singular (non-finite solution)"));
            }
            let mut res = g.transpose().to_owned();
            let mut mnorm: f64 = 0.0;
            for t in &m_trip {
                mnorm = mnorm.max(t.val.abs());
                for k in 0..d {
                    res[(t.col, k)] -= t.val * zt[(t.row, k)];
                }
            }
            let rel = res.norm_max() / (mnorm * zt.norm_max() * de as f64 + g.norm_max()).max(f64::MIN_POSITIVE);
            if rel > 1e-8 {
                return Err(singular(
                    0,
                    &format!("makes the local problem (13) numerically singular (relative residual {rel:.1e})"),
                ));
            }
        }
        let zb = zt.transpose() * &bmat; // d x dR
        let mut t_row = vec![0.0; d * de];
        for a in 0..d {
            for j in 0..de {
                t_row[a * de + j] = -zt[(j, a)];
            }
        }
        let mut row = direct;
        for q in 0..nr {
            for a in 0..d {
                for c in 0..d {
                    row[q * d * d + a * d + c] -= zb[(a, d * q + c)];
                }
            }
        }
        Ok((row, t_row, sparse))
    }

    /// The retained nodes of every `N_x` with its signature (parallel over retained nodes), and
    /// the classes of equal signatures: each node's class and each class's first node. Without
    /// the cache every node is a class of its own.
    fn classes(&self, cells: &Cells, r: f64) -> Classes {
        let hoods: Vec<HoodSplit> = self
            .parent
            .par_iter()
            .map_init(Vec::new, |buf, &xi| {
                let (hood, keys) = self.hood(cells, xi, r, buf);
                let xl = hood.local(xi).expect("x is in its own neighbourhood");
                let sig = if self.opts.cache { self.signature(&hood, &keys, xl) } else { (xi as u64, 0) };
                (hood.nodes[..hood.n_r].to_vec(), hood.nodes[hood.n_r..].to_vec(), sig)
            })
            .collect();
        let mut class_of = Vec::with_capacity(hoods.len());
        let mut reps: Vec<usize> = Vec::new();
        let mut index: HashMap<(u64, u64), usize> = HashMap::new();
        for (k, h) in hoods.iter().enumerate() {
            let c = *index.entry(h.2).or_insert_with(|| {
                reps.push(k);
                reps.len() - 1
            });
            class_of.push(c);
        }
        let (retained, excluded) = hoods.into_iter().map(|h| (h.0, h.1)).unzip();
        Classes { retained, excluded, class_of, reps }
    }

    /// Coarse row `k` (columns, `d x d` blocks, tail) from its class's row `w` over the retained
    /// nodes `retained` of `N_x`: `C^m(x,q) = f_x W^m_xq / v^m_q`, `f_x = 1/v^m_x`
    /// (TotalForce, (11'')) or `1/v^{m-1}_x` (ForceDensity, (11')). The tail is the largest
    /// block norm in the shell `|q - x| > r - w` (`w` the shell width, [`StepReport::tail`])
    /// relative to the row's largest.
    fn coarse_row(
        &self,
        k: usize,
        retained: &[usize],
        w: &[f64],
        xm: &[Point],
        r: f64,
        width: f64,
    ) -> (Vec<usize>, Vec<f64>, f64) {
        let dd = self.fine.dim() * self.fine.dim();
        let xi = self.parent[k];
        let fx = match self.opts.matching {
            Matching::TotalForce => 1.0 / self.vm[k],
            Matching::ForceDensity => 1.0 / self.fine.volumes()[xi],
        };
        let mut entries: Vec<(usize, &[f64])> = Vec::new();
        for (l, &q) in retained.iter().enumerate() {
            if q != xi {
                entries.push((self.coarse_index[q], &w[l * dd..(l + 1) * dd]));
            }
        }
        entries.sort_unstable_by_key(|e| e.0);
        let mut cols = Vec::with_capacity(entries.len());
        let mut vals = Vec::with_capacity(entries.len() * dd);
        let (mut peak, mut shell): (f64, f64) = (0.0, 0.0);
        for (j, b) in entries {
            let s = fx / self.vm[j];
            let norm = b.iter().map(|t| t * t).sum::<f64>().sqrt() * s.abs();
            if norm == 0.0 {
                continue;
            }
            peak = peak.max(norm);
            if dist(&xm[k], &xm[j]) > r - width {
                shell = shell.max(norm);
            }
            cols.push(j);
            vals.extend(b.iter().map(|t| t * s));
        }
        let tail = if peak > 0.0 { shell / peak } else { 0.0 };
        (cols, vals, tail)
    }

    /// The step at radius `r`: 1. neighbourhoods and signatures, 2. classes, 3. one local solve
    /// per class, 4. the coarse rows; `diameter` tells when every `N_x` is the whole body.
    fn run(&self, r: f64, delta: f64, diameter: f64) -> Result<Coarsened, CoarsenError> {
        let shell_width = delta.max(self.h_coarse);
        let fine = self.fine;
        let d = fine.dim();
        let x = fine.positions();
        let all: Vec<usize> = (0..fine.len()).collect();
        let cells = Cells::new(d, x, &all, r);
        let whole_body = r >= diameter * (1.0 + 1e-9);
        // 1. neighbourhoods and signatures, 2. classes
        let t1 = Instant::now();
        let Classes { retained, excluded, class_of, reps } = self.classes(&cells, r);
        let t_hoods = t1.elapsed().as_secs_f64();
        // 3. one local solve per class
        let t2 = Instant::now();
        let task = Task::start(self.progress, &format!("local solves (r = {r:.3e})"), Some(reps.len() as u64));
        let solved: Vec<Result<LocalRow, CoarsenError>> = reps
            .par_iter()
            .map_init(Vec::new, |buf, &k| {
                let xi = self.parent[k];
                let (hood, _) = self.hood(&cells, xi, r, buf);
                let (row, t_row, sparse) = self.local_row(&hood, xi, r)?;
                task.advance(1);
                Ok((row, t_row, sparse, d * (hood.nodes.len() - hood.n_r)))
            })
            .collect();
        task.set(reps.len() as u64, "");
        drop(task);
        let mut rows_w = Vec::with_capacity(solved.len());
        let mut rows_t = Vec::with_capacity(solved.len());
        let (mut n_sparse, mut unknowns_max, mut unknowns_sum) = (0, 0, 0usize);
        for s in solved {
            let (row, t_row, sparse, nu) = s?;
            rows_t.push(t_row);
            n_sparse += sparse as usize;
            unknowns_max = unknowns_max.max(nu);
            unknowns_sum += nu;
            rows_w.push(row);
        }
        let t_solves = t2.elapsed().as_secs_f64();
        // 4. coarse rows: C^m(x,q) = f_x W^m_xq / v^m_q, f_x = 1/v^m_x (TotalForce, (11''))
        //    or 1/v^{m-1}_x (ForceDensity, (11'))
        let t3 = Instant::now();
        let xm: Vec<Point> = self.parent.iter().map(|&p| x[p]).collect();
        let built: Vec<(Vec<usize>, Vec<f64>, f64)> = (0..self.parent.len())
            .into_par_iter()
            .map(|k| self.coarse_row(k, &retained[k], &rows_w[class_of[k]], &xm, r, shell_width))
            .collect();
        let mut offsets = vec![0];
        let (mut cols, mut c) = (Vec::new(), Vec::new());
        let mut tail: f64 = 0.0;
        for (cl, vl, t) in built {
            cols.extend(cl);
            c.extend(vl);
            offsets.push(cols.len());
            tail = tail.max(t);
        }
        if whole_body {
            tail = 0.0;
        }
        let factor: Vec<f64> = match self.opts.matching {
            Matching::TotalForce => vec![1.0; self.parent.len()],
            Matching::ForceDensity => {
                self.parent.iter().zip(&self.vm).map(|(&p, &vm)| vm / fine.volumes()[p]).collect()
            }
        };
        let transfer = Transfer::new(d, fine.len(), self.parent.clone(), excluded, class_of, rows_t, factor);
        let level0: Vec<usize> = self.parent.iter().map(|&p| fine.level0()[p]).collect();
        let model = LevelModel::from_csr(d, xm, self.vm.clone(), level0, offsets, cols, c)?;
        let t_assemble = t3.elapsed().as_secs_f64();
        let classes = reps.len();
        let report = StepReport {
            n_fine: fine.len(),
            n_coarse: self.parent.len(),
            horizon_fine: delta,
            radius: r,
            tail,
            shell_width,
            tried: Vec::new(),
            whole_body,
            classes,
            hit_rate: 1.0 - classes as f64 / self.parent.len() as f64,
            local_unknowns_max: unknowns_max,
            local_unknowns_mean: unknowns_sum as f64 / classes.max(1) as f64,
            sparse_solves: n_sparse,
            dense_solves: classes - n_sparse,
            asymmetry: model.asymmetry(),
            seconds_neighbourhoods: t_hoods,
            seconds_solves: t_solves,
            seconds_assemble: t_assemble,
            seconds_total: 0.0,
        };
        Ok(Coarsened { model, parent: self.parent.clone(), report, transfer })
    }
}

/// Every excluded node of `N_x` must have a bond inside `N_x` and be connected through such
/// bonds to a retained node, otherwise (13) is singular; names the first offender.
fn structural_check(fine: &LevelModel, hood: &Hood, xi: usize, r: f64) -> Result<(), CoarsenError> {
    let (nn, nr) = (hood.nodes.len(), hood.n_r);
    let d = fine.dim();
    let mut rev: Vec<Vec<usize>> = vec![Vec::new(); nn];
    let mut own = vec![0usize; nn];
    for a in nr..nn {
        let z = hood.nodes[a];
        for (&q, b) in fine.partners(z).iter().zip(fine.blocks(z).chunks(d * d)) {
            if b.iter().any(|&t| t != 0.0) {
                if let Some(lb) = hood.local(q) {
                    rev[lb].push(a);
                    own[a] += 1;
                }
            }
        }
    }
    let mut reached = vec![false; nn];
    let mut queue: Vec<usize> = (0..nr).collect();
    reached[..nr].iter_mut().for_each(|t| *t = true);
    while let Some(a) = queue.pop() {
        for &b in &rev[a] {
            if !reached[b] {
                reached[b] = true;
                queue.push(b);
            }
        }
    }
    for a in nr..nn {
        if own[a] == 0 {
            return Err(CoarsenError::singular(fine, xi, r, hood.nodes[a], "has no bond inside N_x"));
        }
        if !reached[a] {
            return Err(CoarsenError::singular(
                fine,
                xi,
                r,
                hood.nodes[a],
                "is not connected through bonds inside N_x to any retained node",
            ));
        }
    }
    Ok(())
}

/// The full resolvent `S` of retained node `xi` (eq. (14)), by solving `M S_E = -B` (dense LU):
/// for tests of (8) and for reconstructing level-(m-1) displacements from level-m ones.
pub fn local_resolvent(
    fine: &LevelModel,
    is_retained: &[bool],
    xi: usize,
    radius: f64,
) -> Result<LocalResolvent, CoarsenError> {
    let parent: Vec<usize> = (0..fine.len()).filter(|&p| is_retained[p]).collect();
    let step = Step::new(fine, parent, &Options::fixed(radius), &NoProgress)?;
    let all: Vec<usize> = (0..fine.len()).collect();
    let cells = Cells::new(fine.dim(), fine.positions(), &all, radius);
    let (hood, _) = step.hood(&cells, xi, radius, &mut Vec::new());
    structural_check(fine, &hood, xi, radius)?;
    let d = fine.dim();
    let (nn, nr) = (hood.nodes.len(), hood.n_r);
    let v = fine.volumes();
    // A of (13): identity rows for R_x, equilibrium rows for the excluded nodes
    let mut a = Mat::<f64>::zeros(d * nn, d * nn);
    for k in 0..d * nr {
        a[(k, k)] = 1.0;
    }
    for e in nr..nn {
        let z = hood.nodes[e];
        for (&p, b) in fine.partners(z).iter().zip(fine.blocks(z).chunks(d * d)) {
            let Some(lp) = hood.local(p) else { continue };
            for i in 0..d {
                for j in 0..d {
                    let w = v[z] * v[p] * b[i * d + j];
                    a[(d * e + i, d * lp + j)] += w;
                    a[(d * e + i, d * e + j)] -= w;
                }
            }
        }
    }
    let rhs = Mat::<f64>::from_fn(d * nn, d * nr, |i, j| if i == j { 1.0 } else { 0.0 });
    use faer::linalg::solvers::Solve;
    let s = a.partial_piv_lu().solve(rhs);
    if s.col_iter().any(|c| c.iter().any(|t| !t.is_finite())) {
        return Err(CoarsenError::singular(
            fine,
            xi,
            radius,
            hood.nodes[nr.min(nn - 1)],
            "makes the local problem (13) singular",
        ));
    }
    Ok(LocalResolvent { nodes: hood.nodes, n_retained: nr, s })
}

/// A 128-bit streaming hash (two 64-bit multiply-xorshift lanes with different seeds).
struct Hasher(u64, u64);

impl Hasher {
    fn new() -> Self {
        Self(0x9E37_79B9_7F4A_7C15, 0xD1B5_4A32_D192_ED03)
    }
    #[inline]
    fn add(&mut self, v: u64) {
        self.0 = mix(self.0 ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15);
        self.1 = mix(self.1.rotate_left(17) ^ v.wrapping_mul(0xFF51_AFD7_ED55_8CCD));
    }
    fn finish(&self) -> (u64, u64) {
        (mix(self.0), mix(self.1 ^ 0xC4CE_B9FE_1A85_EC53))
    }
}

#[inline]
fn mix(mut z: u64) -> u64 {
    // splitmix64 finaliser
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
