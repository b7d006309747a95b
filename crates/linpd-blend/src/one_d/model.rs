//! Assembly of the blended, pure CE (28) and pure PD (29) operators in force form.

use crate::one_d::material::{check_defects, check_interfaces, BarMaterial};
use crate::{BlendError, Blending, Mesh, Regions};
use linpd_core::{Kernel, Material, Micromodulus, Normalization};
use rayon::prelude::*;

/// Which model to assemble.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    /// The blended PD/CE (or PD/HOG) model, eq. (22) / (37).
    Blended,
    /// Classical elasticity everywhere, eq. (28).
    PureCe,
    /// Peridynamics everywhere, eq. (29), on the domain extended by a nonlocal boundary layer of
    /// `N - 1` nodes per side (section 5).
    PurePd,
}

/// Everything that defines a 1D blended problem's operator.
#[derive(Debug, Clone, PartialEq)]
pub struct BlendParams {
    /// Domain `(0, length)`.
    pub length: f64,
    /// Fine spacing `dx`.
    pub dx: f64,
    /// Horizon `eps`; must be `N dx` for an integer `N >= 1`.
    pub horizon: f64,
    /// Modulus `K` of eq. (7).
    pub modulus: f64,
    /// Micromodulus shape (normalized discretely: the lattice sum reproduces `K`).
    pub kernel: Kernel,
    /// `L1 < L2 < L3 < L4`.
    pub regions: Regions,
    /// Bridge shape.
    pub blending: Blending,
    /// Coarse CE spacing `2^k dx` in the pure CE regions (`None`: uniform `dx`).
    pub ce_spacing: Option<f64>,
    /// Use the PD/HOG model with `M = 4` (eq. (37)-(38)) instead of PD/CE (`M = 2`).
    pub hog: bool,
    /// Phases (moduli `K(x)`; `modulus` is the reference `K_ref` outside them), bond rule and
    /// point defects, as in the bond model; how each enters the blended rows is in
    /// [`crate::one_d::material`]. Empty: homogeneous, Algorithm A as printed.
    pub material: Material,
}

impl BlendParams {
    /// The paper's Table 3 setting: `(0, 1)`, `K = 1`, `eps = 0.05`, `dx = 1/300`,
    /// `L = (0.12, 0.25, 0.75, 0.88)`, inverse-distance kernel, with the given blending.
    pub fn table3(blending: Blending) -> Self {
        BlendParams {
            length: 1.0,
            dx: 1.0 / 300.0,
            horizon: 0.05,
            modulus: 1.0,
            kernel: Kernel::InverseDistance,
            regions: Regions { l1: 0.12, l2: 0.25, l3: 0.75, l4: 0.88 },
            blending,
            ce_spacing: None,
            hog: false,
            material: Material::default(),
        }
    }

    /// Neighbours per side `N = eps / dx` (an integer up to `1e-6` relative).
    pub fn n_side(&self) -> Result<usize, BlendError> {
        let r = self.horizon / self.dx;
        let n = r.round();
        if !(r.is_finite()) || n < 1.0 || (r - n).abs() > 1e-6 * r.max(1.0) {
            return Err(BlendError::param(
                "horizon",
                format!(
                    "horizon/dx = {r:e} must be a positive integer N (the paper's N = eps/dx); adjust horizon or dx"
                ),
            ));
        }
        Ok(n as usize)
    }

    /// Validates the geometry and parameters (also the model-independent ones).
    pub fn validate(&self) -> Result<(), BlendError> {
        let p = |n: &str, v: f64| -> Result<(), BlendError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(BlendError::param(n, format!("must be > 0, got {v:e}")))
            }
        };
        p("length", self.length)?;
        p("dx", self.dx)?;
        p("horizon", self.horizon)?;
        p("modulus", self.modulus)?;
        let cells = self.length / self.dx;
        if (cells - cells.round()).abs() > 1e-6 * cells || cells.round() < 2.0 {
            return Err(BlendError::param("dx", format!("length/dx = {cells:e} must be an integer >= 2")));
        }
        self.n_side()?;
        let r = &self.regions;
        let l = [r.l1, r.l2, r.l3, r.l4];
        if !(0.0 < r.l1 && r.l1 < r.l2 && r.l2 < r.l3 && r.l3 < r.l4 && r.l4 < self.length) {
            return Err(BlendError::param(
                "regions",
                format!("need 0 < L1 < L2 < L3 < L4 < length = {}, got {l:?}", self.length),
            ));
        }
        for (k, w) in [r.l2 - r.l1, r.l3 - r.l2, r.l4 - r.l3].iter().enumerate() {
            if *w < self.dx * (1.0 - 1e-9) {
                let name = ["left bridge L2 - L1", "PD region L3 - L2", "right bridge L4 - L3"][k];
                return Err(BlendError::param(
                    "regions",
                    format!("{name} = {w:e} is narrower than dx = {:e}", self.dx),
                ));
            }
        }
        self.blending.validate()?;
        self.kernel.validate().map_err(|e| BlendError::param("kernel", e.to_string()))?;
        if let Some(h) = self.ce_spacing {
            let ratio = h / self.dx;
            let k = ratio.log2().round();
            if !(ratio.is_finite() && ratio >= 1.0) || (ratio - 2f64.powi(k as i32)).abs() > 1e-9 * ratio {
                return Err(BlendError::param(
                    "ce_spacing",
                    format!("must be dx times a power of two (1, 2, 4, ...), got {ratio:e} dx"),
                ));
            }
            if self.hog && ratio > 1.0 {
                return Err(BlendError::param("ce_spacing", "the HOG model (hog = true) needs a uniform mesh"));
            }
        }
        self.material.validate(1).map_err(|e| BlendError::param("material", e.to_string()))?;
        if self.hog && !self.material.is_homogeneous() {
            // The pure HOG rows would be the Taylor limit of the heterogeneous PD operator
            // (smeared over a horizon), not a local model with the phase modulus K(x): no
            // such local operator is derived, so the combination is refused.
            return Err(BlendError::param(
                "material",
                "phases and defects are not available with the HOG model (hog = true): its local rows have no divergence form to carry a phase modulus",
            ));
        }
        BarMaterial::new(&self.material, self.modulus, self.dx).check_phases(self.length)
    }

    /// Checks where the material's defects and phase interfaces lie for the model `kind`
    /// ([`crate::one_d::material::check_defects`], [`crate::one_d::material::check_interfaces`]): defects
    /// only inside the pure PD zone of a blended model (anywhere in the pure PD model, nowhere
    /// in the pure CE model), interfaces nowhere within a horizon of a transition row.
    pub fn check_material(&self, kind: ModelKind) -> Result<(), BlendError> {
        if self.material.is_homogeneous() {
            return Ok(());
        }
        let (mesh, beta) = self.mesh_and_beta(kind)?;
        let n_side = self.n_side()?;
        let eps = n_side as f64 * self.dx;
        let zone = (self.regions.l2 + 2.0 * eps, self.regions.l3 - 2.0 * eps);
        check_defects(&self.material, &mesh, &beta, n_side, eps, kind == ModelKind::PureCe, zone)?;
        let mat = BarMaterial::new(&self.material, self.modulus, self.dx);
        check_interfaces(&mat, &mesh, &beta, n_side, eps, &self.regions)
    }

    /// The nodes of model `kind` and `beta` at them.
    fn mesh_and_beta(&self, kind: ModelKind) -> Result<(Mesh, Vec<f64>), BlendError> {
        let n_side = self.n_side()?;
        let dx = self.dx;
        let n_cells = (self.length / dx).round() as usize;
        let eps = n_side as f64 * dx;
        let tol = 1e-9 * dx;
        let mesh = match kind {
            ModelKind::PurePd => Mesh::uniform(-((n_side - 1) as f64) * dx, dx, n_cells + 2 * (n_side - 1)),
            ModelKind::PureCe => Mesh::uniform(0.0, dx, n_cells),
            ModelKind::Blended => match self.ce_spacing {
                Some(h) if h > dx * (1.0 + 1e-9) => {
                    let r = &self.regions;
                    let k_lo = (((r.l1 - 2.0 * eps) / dx).floor() as i64).max(0);
                    let k_hi = (((r.l4 + 2.0 * eps) / dx).ceil() as i64).min(n_cells as i64);
                    Mesh::graded(0.0, dx, k_lo, k_hi, h, 0.0, self.length)
                }
                _ => Mesh::uniform(0.0, dx, n_cells),
            },
        };
        let beta: Vec<f64> = mesh
            .x
            .iter()
            .map(|&x| match kind {
                ModelKind::PurePd => 1.0,
                ModelKind::PureCe => 0.0,
                ModelKind::Blended => self.blending.beta(x, &self.regions, tol),
            })
            .collect();
        Ok((mesh, beta))
    }
}

/// An assembled operator `A` (force form, `A u = f`) in CSR, with its mesh and blending values.
#[derive(Debug, Clone)]
pub struct BlendOperator {
    /// Which model.
    pub kind: ModelKind,
    /// Nodes.
    pub mesh: Mesh,
    /// `beta` at the nodes.
    pub beta: Vec<f64>,
    /// Neighbours per side.
    pub n_side: usize,
    /// CSR row pointers.
    pub row_ptr: Vec<usize>,
    /// CSR columns (ascending per row).
    pub col: Vec<usize>,
    /// CSR values.
    pub val: Vec<f64>,
    /// Rows that mix nonlocal and local terms (the transition region `Omega_t`).
    pub transition: Vec<bool>,
    /// How each row's local (Taylor) part was assembled.
    pub local: Vec<LocalPart>,
}

/// The local part of a row of the blended operator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LocalPart {
    /// An end row (carries a Dirichlet condition).
    End,
    /// A pure CE row: `-(K u')'` by the (non-uniform) 3-point difference, nothing nonlocal.
    Ce {
        /// Series modulus `k_{i-1/2}` of the interval to the left (`K` for a homogeneous bar).
        k_left: f64,
        /// Series modulus `k_{i+1/2}` of the interval to the right.
        k_right: f64,
    },
    /// A lattice row: nonlocal terms plus `-(D1 u' + D2 u'' [+ ...])`.
    Lattice {
        /// `D1`.
        d1: f64,
        /// `D2`.
        d2: f64,
        /// The local part uses the 3-point stencils (false: 5-point HOG stencils).
        three_point: bool,
    },
}

impl LocalPart {
    /// The second-derivative coefficient on the side of the interval to the right (`right`) or
    /// left of the node (0 for end rows): `D2` of a lattice row, the face modulus of a CE row.
    pub fn d2(&self, right: bool) -> f64 {
        match self {
            LocalPart::End => 0.0,
            LocalPart::Ce { k_left, k_right } => {
                if right {
                    *k_right
                } else {
                    *k_left
                }
            }
            LocalPart::Lattice { d2, .. } => *d2,
        }
    }
}

impl BlendOperator {
    /// Assembles the operator of `kind` for `params`.
    pub fn assemble(params: &BlendParams, kind: ModelKind) -> Result<Self, BlendError> {
        params.validate()?;
        params.check_material(kind)?;
        let n_side = params.n_side()?;
        let (mesh, beta) = params.mesh_and_beta(kind)?;
        let rows = Rows::new(params, kind, &mesh, &beta, n_side)?;
        // Rows are independent: assemble them in parallel, each into its own small buffers.
        let assembled: Vec<Row> = (0..mesh.len()).into_par_iter().map(|i| rows.row(i)).collect();
        let (row_ptr, col, val, transition, local) = concatenate(assembled);
        Ok(BlendOperator { kind, mesh, beta, n_side, row_ptr, col, val, transition, local })
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.mesh.len()
    }
    /// True without nodes.
    pub fn is_empty(&self) -> bool {
        self.mesh.is_empty()
    }
    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.val.len()
    }
    /// Entry `A(i, j)` (0 when not stored).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let cols = &self.col[self.row_ptr[i]..self.row_ptr[i + 1]];
        match cols.binary_search(&j) {
            Ok(p) => self.val[self.row_ptr[i] + p],
            Err(_) => 0.0,
        }
    }
    /// The SPD preconditioner `P = A_nonlocal + A_div` in CSR: `A` with every row's 3-point local
    /// part `-(D1 u' + D2 u'')` replaced by the divergence form `-(D2 u')'`, discretized with face
    /// coefficients `(D2_i + D2_{i+1}) / 2` over each mesh interval (force form:
    /// `k_f = D_f / (x_{i+1} - x_i)`). Both parts are symmetric positive semi-definite, whatever
    /// the blending function, so `P` is SPD once Dirichlet conditions are applied; `A - P` is the
    /// small non-divergence remainder (zero for linear `beta` in the continuum). Rows whose local
    /// part uses 5-point stencils (HOG) keep them. Returns `None` when some interior row has no
    /// 3-point local part to replace (then use `(A + A^T)/2` or LU).
    pub fn divergence_preconditioner(&self) -> Option<(Vec<usize>, Vec<usize>, Vec<f64>)> {
        let n = self.len();
        let x = &self.mesh.x;
        let dx = self.mesh.dx;
        // Only entries (i, i-1), (i, i), (i, i+1) change: update a copy of the values in place.
        // They are stored for every row with a local part (CE rows store exactly them; lattice
        // rows store their whole stencil); a missing one means no divergence form is possible.
        let mut val = self.val.clone();
        let pos = |i: usize, j: usize| -> Option<usize> {
            let cols = &self.col[self.row_ptr[i]..self.row_ptr[i + 1]];
            cols.binary_search(&j).ok().map(|p| self.row_ptr[i] + p)
        };
        let add = |val: &mut [f64], i: usize, j: usize, v: f64| -> Option<()> {
            val[pos(i, j)?] += v;
            Some(())
        };
        for i in 0..n {
            // Subtract the assembled local part, leaving the nonlocal part.
            match self.local[i] {
                LocalPart::End => {}
                LocalPart::Ce { k_left, k_right } => {
                    let (dl, dr) = (x[i] - x[i - 1], x[i + 1] - x[i]);
                    add(&mut val, i, i - 1, k_left / dl)?;
                    add(&mut val, i, i, -(k_left / dl + k_right / dr))?;
                    add(&mut val, i, i + 1, k_right / dr)?;
                }
                LocalPart::Lattice { d1, d2, three_point } => {
                    if !three_point {
                        return None;
                    }
                    let v = self.mesh.dual_length(i);
                    add(&mut val, i, i + 1, (d1 / (2.0 * dx) + d2 / (dx * dx)) * v)?;
                    add(&mut val, i, i - 1, (-d1 / (2.0 * dx) + d2 / (dx * dx)) * v)?;
                    add(&mut val, i, i, -2.0 * d2 / (dx * dx) * v)?;
                }
            }
        }
        // Add the divergence form -(D2 u')' interval by interval (end rows are never used).
        for i in 0..n - 1 {
            // An end row has no local part of its own: its face takes the neighbour's D2.
            let (l, r) = (self.local[i], self.local[i + 1]);
            // (Two CE rows share the face modulus: (k + k)/2 = k exactly, the CE part is kept.)
            let (dl, dr) = match (l, r) {
                (LocalPart::End, _) => (r.d2(false), r.d2(false)),
                (_, LocalPart::End) => (l.d2(true), l.d2(true)),
                _ => (l.d2(true), r.d2(false)),
            };
            let kf = 0.5 * (dl + dr) / (x[i + 1] - x[i]);
            if kf == 0.0 {
                continue;
            }
            for (a, b) in [(i, i + 1), (i + 1, i)] {
                if self.local[a] != LocalPart::End {
                    add(&mut val, a, a, kf)?;
                    add(&mut val, a, b, -kf)?;
                }
            }
        }
        Some((self.row_ptr.clone(), self.col.clone(), val))
    }

    /// `y = A u`.
    pub fn apply(&self, u: &[f64], y: &mut [f64]) {
        for i in 0..self.len() {
            y[i] = (self.row_ptr[i]..self.row_ptr[i + 1]).map(|p| self.val[p] * u[self.col[p]]).sum();
        }
    }
}

/// One assembled row of `A`: columns (ascending) and values, whether it mixes nonlocal and
/// local terms (the transition region `Omega_t`), and how its local part was assembled.
struct Row {
    col: Vec<usize>,
    val: Vec<f64>,
    transition: bool,
    local: LocalPart,
}

/// The CSR arrays, transition flags and local parts of the rows, in row order.
type Csr = (Vec<usize>, Vec<usize>, Vec<f64>, Vec<bool>, Vec<LocalPart>);

/// Concatenates the rows into CSR arrays (`row_ptr`, `col`, `val`) and the per-row flags.
fn concatenate(rows: Vec<Row>) -> Csr {
    let n = rows.len();
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0usize);
    for r in &rows {
        row_ptr.push(row_ptr.last().unwrap() + r.col.len());
    }
    let mut col = Vec::with_capacity(*row_ptr.last().unwrap());
    let mut val = Vec::with_capacity(*row_ptr.last().unwrap());
    let mut transition = Vec::with_capacity(n);
    let mut local = Vec::with_capacity(n);
    for r in rows {
        col.extend(r.col);
        val.extend(r.val);
        transition.push(r.transition);
        local.push(r.local);
    }
    (row_ptr, col, val, transition, local)
}

/// What the rows of one assembly share: the nodes, `beta`, the material, the bond weights.
struct Rows<'a> {
    params: &'a BlendParams,
    kind: ModelKind,
    mesh: &'a Mesh,
    beta: &'a [f64],
    mat: BarMaterial<'a>,
    /// `K(x_i)` at the nodes (the bond model's node moduli) for the bond factors.
    node_k: Vec<f64>,
    /// Bond weights `w_j = C(j dx) dx`, `j = 1..N`.
    w: Vec<f64>,
    /// Neighbours per side `N`.
    n_side: usize,
    dx: f64,
    /// Order `M` of the Taylor expansion of the local part: 2 (PD/CE) or 4 (PD/HOG).
    m_order: usize,
}

impl<'a> Rows<'a> {
    fn new(
        params: &'a BlendParams,
        kind: ModelKind,
        mesh: &'a Mesh,
        beta: &'a [f64],
        n_side: usize,
    ) -> Result<Self, BlendError> {
        let dx = params.dx;
        let eps = n_side as f64 * dx;
        let mat = BarMaterial::new(&params.material, params.modulus, dx);
        let node_k: Vec<f64> = if params.material.phases.is_empty() {
            vec![params.modulus; mesh.len()]
        } else {
            mesh.x.iter().map(|&x| mat.modulus_at(x)).collect()
        };
        // Bond weights w_j = C(j dx) dx with C = c g normalized on the lattice (eq. (19)).
        let mm = Micromodulus {
            kernel: params.kernel.clone(),
            normalization: Normalization::Discrete,
            modulus: params.modulus,
            plane: None,
            partial_volume: false,
        };
        let c = mm.amplitude(1, eps, dx).map_err(|e| BlendError::param("kernel", e.to_string()))?;
        let w: Vec<f64> = (1..=n_side).map(|j| c * params.kernel.shape(j as f64 * dx, eps) * dx).collect();
        let m_order = if params.hog { 4 } else { 2 };
        Ok(Rows { params, kind, mesh, beta, mat, node_k, w, n_side, dx, m_order })
    }

    /// Slots of the row's accumulator: lattice offsets `-N-2..=N+2` (the bonds and the widest
    /// difference stencil).
    fn width(&self) -> usize {
        2 * (self.n_side + 2) + 1
    }

    /// The accumulator slot of lattice offset `o`.
    fn off(&self, o: i64) -> usize {
        (o + self.n_side as i64 + 2) as usize
    }

    /// Row `i`: an end row, a pure CE row, or a lattice row (nonlocal shares plus the Taylor
    /// local part).
    fn row(&self, i: usize) -> Row {
        let n = self.mesh.len();
        let k = self.mesh.fine[i];
        let (a, mu, any) = self.shares(i, k);
        let pure_ce = !any && !self.params.hog;
        let end = i == 0 || i + 1 == n;
        if end && self.kind != ModelKind::PurePd {
            return self.end_row(i);
        }
        if pure_ce {
            return self.ce_row(i);
        }
        let k = k.expect("nonlocal rows lie on the fine lattice");
        self.lattice_row(i, k, &a, &mu, end)
    }

    /// Nonlocal shares `a_j = (beta_i + beta_q) / 2` for `j = -N..N` (0 where the neighbour is
    /// missing) and the bonds' material factors `mu_j` (crate::one_d::material; 1 for a homogeneous
    /// bar) of node `i` at fine-lattice index `k`; and whether any share is positive.
    fn shares(&self, i: usize, k: Option<i64>) -> (Vec<f64>, Vec<f64>, bool) {
        let (mesh, mat, n_side) = (self.mesh, &self.mat, self.n_side);
        let mut a = vec![0.0; 2 * n_side + 1];
        let mut mu = vec![1.0; 2 * n_side + 1];
        let mut any = false;
        let Some(k) = k else { return (a, mu, any) };
        for j in 1..=n_side as i64 {
            for s in [-1i64, 1] {
                let slot = (n_side as i64 + s * j) as usize;
                if let Some(q) = mesh.node_of_fine(k + s * j) {
                    let share = 0.5 * (self.beta[i] + self.beta[q]);
                    a[slot] = share;
                    any |= share > 0.0;
                    mu[slot] = mat.bond_factor(mesh.x[i], mesh.x[q], self.node_k[i], self.node_k[q]);
                } else if !mat.is_homogeneous() {
                    // A bond leaving the domain is all local (a = 0): its modulus is
                    // that of the point it would reach.
                    let y = mesh.x[i] + (s * j) as f64 * self.dx;
                    mu[slot] = mat.bond_factor(mesh.x[i], y, self.node_k[i], mat.modulus_at(y));
                }
            }
        }
        (a, mu, any)
    }

    /// End nodes carry the Dirichlet conditions, so the solve never uses their rows. They hold
    /// the force on the end node's half cell in the local model,
    /// `k_{1/2} (u_0 - u_1) / (x_1 - x_0)` (and mirrored), so that `(A u - f)` there is the
    /// support's reaction (crate::one_d::solve, BlendSolution::reactions).
    fn end_row(&self, i: usize) -> Row {
        let (x, n) = (&self.mesh.x, self.mesh.len());
        let q = if i == 0 { 1 } else { n - 2 };
        let kf = self.mat.face_modulus(x[i.min(q)], x[i.max(q)]);
        let len = (x[q] - x[i]).abs();
        let mut entries = [(i, kf / len), (q, -kf / len)];
        entries.sort_by_key(|e| e.0);
        let (col, val) = entries.into_iter().unzip();
        Row { col, val, transition: false, local: LocalPart::End }
    }

    /// Non-uniform CE row (section 5.2.4) with the series face moduli of `K(x)`
    /// (crate::one_d::material), force form: symmetric.
    fn ce_row(&self, i: usize) -> Row {
        let x = &self.mesh.x;
        let (dl, dr) = (x[i] - x[i - 1], x[i + 1] - x[i]);
        let kl = self.mat.face_modulus(x[i - 1], x[i]);
        let kr = self.mat.face_modulus(x[i], x[i + 1]);
        let col = vec![i - 1, i, i + 1];
        let val = vec![-kl / dl, kl / dl + kr / dr, -kr / dr];
        Row { col, val, transition: false, local: LocalPart::Ce { k_left: kl, k_right: kr } }
    }

    /// Row `i` at fine-lattice index `k`: the nonlocal shares plus `-(D1 u' + D2 u'' [+ ...])`,
    /// scaled by the node's dual length `v_i`.
    fn lattice_row(&self, i: usize, k: i64, a: &[f64], mu: &[f64], end: bool) -> Row {
        let mut acc = vec![0.0; self.width()];
        let (d, all_pd) = self.nonlocal_and_moments(&mut acc, a, mu);
        let local3 = self.local_part(&mut acc, &d, k);
        let (col, val) = self.gather(&acc, k, self.mesh.dual_length(i));
        let local = if end { LocalPart::End } else { LocalPart::Lattice { d1: d[1], d2: d[2], three_point: local3 } };
        Row { col, val, transition: !all_pd, local }
    }

    /// Adds the nonlocal shares `mu_j w_j a_j (u_i - u_j)` to `acc` and returns the moments of
    /// the local shares,
    ///
    /// ```text
    /// D_n = (1/n!) sum_j mu_j w_j (1 - a_j) xi_j^n   over j = +-1..+-N,  n = 1..M,
    /// ```
    ///
    /// and whether every bond is all nonlocal (`a_j >= 1`: a pure PD row).
    fn nonlocal_and_moments(&self, acc: &mut [f64], a: &[f64], mu: &[f64]) -> ([f64; 5], bool) {
        let n_side = self.n_side as i64;
        let mut d = [0.0f64; 5];
        let mut all_pd = true;
        for j in 1..=n_side {
            for s in [-1i64, 1] {
                let aj = a[(n_side + s * j) as usize];
                // mu = 1 multiplies exactly: a homogeneous bar is Algorithm A bit for bit.
                let wj = self.w[(j - 1) as usize] * mu[(n_side + s * j) as usize];
                if aj > 0.0 {
                    acc[self.off(s * j)] -= wj * aj;
                    acc[self.off(0)] += wj * aj;
                }
                if aj < 1.0 {
                    all_pd = false;
                }
                let xi = (s * j) as f64 * self.dx;
                let mut p = 1.0;
                let mut fact = 1.0;
                for (m, dm) in d.iter_mut().enumerate().skip(1).take(self.m_order) {
                    p *= xi;
                    fact *= m as f64;
                    *dm += wj * (1.0 - aj) * p / fact;
                }
            }
        }
        (d, all_pd)
    }

    /// Adds the local part `-(D1 u' + D2 u'')` with centred 3-point differences (eq. (20)-(21));
    /// with HOG, `-(D1 u' + ... + D4 u'''')` with centred 5-point differences for every
    /// derivative, so that the local part is exact for quartics like the Taylor expansion (36)
    /// with `M = 4` (a 3-point `u'` would leave an `O(u''' dx^2)` error even for cubics).
    /// Returns whether the 3-point stencils were used.
    fn local_part(&self, acc: &mut [f64], d: &[f64; 5], k: i64) -> bool {
        let has = |o: i64| self.mesh.node_of_fine(k + o).is_some();
        let five_point = self.params.hog && has(-2) && has(2);
        if five_point {
            self.hog_stencil(acc, d);
        }
        let local3 = !five_point && has(-1) && has(1);
        if local3 {
            // (Also HOG rows next to a domain end, where the 5-point stencil does not fit:
            // the third and fourth derivative terms are dropped there.)
            self.three_point_stencil(acc, d);
        }
        local3
    }

    /// `-(D1 u' + D2 u'' + D3 u''' + D4 u'''')` with centred 5-point differences.
    fn hog_stencil(&self, acc: &mut [f64], d: &[f64; 5]) {
        let dx = self.dx;
        let h2 = dx * dx;
        let c1 = d[1] / (12.0 * dx);
        let c2 = d[2] / (12.0 * h2);
        let c3 = d[3] / (2.0 * dx * h2);
        let c4 = d[4] / (h2 * h2);
        // u'    = (-u2 + 8 u1 - 8 u-1 + u-2) / (12 dx)
        // u''   = (-u2 + 16 u1 - 30 u0 + 16 u-1 - u-2) / (12 dx^2)
        // u'''  = (u2 - 2 u1 + 2 u-1 - u-2) / (2 dx^3)
        // u'''' = (u2 - 4 u1 + 6 u0 - 4 u-1 + u-2) / dx^4
        acc[self.off(2)] -= -c1 - c2 + c3 + c4;
        acc[self.off(1)] -= 8.0 * c1 + 16.0 * c2 - 2.0 * c3 - 4.0 * c4;
        acc[self.off(0)] -= -30.0 * c2 + 6.0 * c4;
        acc[self.off(-1)] -= -8.0 * c1 + 16.0 * c2 + 2.0 * c3 - 4.0 * c4;
        acc[self.off(-2)] -= c1 - c2 - c3 + c4;
    }

    /// `-(D1 u' + D2 u'')` with centred 3-point differences (eq. (20)-(21)).
    fn three_point_stencil(&self, acc: &mut [f64], d: &[f64; 5]) {
        let dx = self.dx;
        let h2 = dx * dx;
        acc[self.off(1)] -= d[1] / (2.0 * dx) + d[2] / h2;
        acc[self.off(-1)] -= -d[1] / (2.0 * dx) + d[2] / h2;
        acc[self.off(0)] += 2.0 * d[2] / h2;
    }

    /// The row's entries from the accumulator of the node at fine index `k`: the nonzero
    /// offsets (and the diagonal) that are nodes, in ascending order, times `v_i`.
    fn gather(&self, acc: &[f64], k: i64, v_i: f64) -> (Vec<usize>, Vec<f64>) {
        let mut col = Vec::with_capacity(self.width());
        let mut val = Vec::with_capacity(self.width());
        let reach = self.n_side as i64 + 2;
        for o in -reach..=reach {
            let v = acc[self.off(o)];
            if v != 0.0 || o == 0 {
                if let Some(q) = self.mesh.node_of_fine(k + o) {
                    col.push(q);
                    val.push(v * v_i);
                }
            }
        }
        (col, val)
    }
}
