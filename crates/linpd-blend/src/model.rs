//! Assembly of the blended, pure CE (28) and pure PD (29) operators in force form.

use crate::material::{check_defects, check_interfaces, BarMaterial};
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
    /// [`crate::material`]. Empty: homogeneous, Algorithm A as printed.
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
    /// ([`crate::material::check_defects`], [`crate::material::check_interfaces`]): defects
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
        let dx = params.dx;
        let eps = n_side as f64 * dx;
        let (mesh, beta) = params.mesh_and_beta(kind)?;
        let mat = BarMaterial::new(&params.material, params.modulus, dx);
        // K(x_i) at the nodes (the bond model's node moduli) for the bond factors.
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

        let n = mesh.len();
        let width = 2 * (n_side + 2) + 1;
        // Rows are independent: assemble them in parallel, each into its own small buffers.
        let row = |i: usize| -> (Vec<usize>, Vec<f64>, bool, LocalPart) {
            let mut col = Vec::with_capacity(width);
            let mut val = Vec::with_capacity(width);
            let mut acc = vec![0.0; width];
            let v_i = mesh.dual_length(i);
            let k = mesh.fine[i];
            // Nonlocal shares a_j for j = -N..N (0 where the neighbour is missing) and the
            // bonds' material factors mu_j (crate::material; 1 for a homogeneous bar).
            let mut a = vec![0.0; 2 * n_side + 1];
            let mut mu = vec![1.0; 2 * n_side + 1];
            let mut any = false;
            if let Some(k) = k {
                for j in 1..=n_side as i64 {
                    for s in [-1i64, 1] {
                        let slot = (n_side as i64 + s * j) as usize;
                        if let Some(q) = mesh.node_of_fine(k + s * j) {
                            let share = 0.5 * (beta[i] + beta[q]);
                            a[slot] = share;
                            any |= share > 0.0;
                            mu[slot] = mat.bond_factor(mesh.x[i], mesh.x[q], node_k[i], node_k[q]);
                        } else if !mat.is_homogeneous() {
                            // A bond leaving the domain is all local (a = 0): its modulus is
                            // that of the point it would reach.
                            let y = mesh.x[i] + (s * j) as f64 * dx;
                            mu[slot] = mat.bond_factor(mesh.x[i], y, node_k[i], mat.modulus_at(y));
                        }
                    }
                }
            }
            let pure_ce = !any && !params.hog;
            let end = i == 0 || i + 1 == n;
            if end && kind != ModelKind::PurePd {
                // End nodes carry the Dirichlet conditions, so the solve never uses their rows.
                // They hold the force on the end node's half cell in the local model,
                // k_{1/2} (u_0 - u_1) / (x_1 - x_0) (and mirrored), so that (A u - f) there is
                // the support's reaction (crate::solve, BlendSolution::reactions).
                let q = if i == 0 { 1 } else { n - 2 };
                let kf = mat.face_modulus(mesh.x[i.min(q)], mesh.x[i.max(q)]);
                let len = (mesh.x[q] - mesh.x[i]).abs();
                let mut entries = [(i, kf / len), (q, -kf / len)];
                entries.sort_by_key(|e| e.0);
                for (q, v) in entries {
                    col.push(q);
                    val.push(v);
                }
                return (col, val, false, LocalPart::End);
            }
            if pure_ce {
                // Non-uniform CE row (section 5.2.4) with the series face moduli of K(x)
                // (crate::material), force form: symmetric.
                let (dl, dr) = (mesh.x[i] - mesh.x[i - 1], mesh.x[i + 1] - mesh.x[i]);
                let kl = mat.face_modulus(mesh.x[i - 1], mesh.x[i]);
                let kr = mat.face_modulus(mesh.x[i], mesh.x[i + 1]);
                col.extend([i - 1, i, i + 1]);
                val.extend([-kl / dl, kl / dl + kr / dr, -kr / dr]);
                return (col, val, false, LocalPart::Ce { k_left: kl, k_right: kr });
            }
            let k = k.expect("nonlocal rows lie on the fine lattice");
            let off = |o: i64| (o + n_side as i64 + 2) as usize;
            // D_n = (1/n!) sum_j mu_j w_j (1 - a_j) xi_j^n  over j = +-1..+-N.
            let mut d = [0.0f64; 5];
            let mut all_pd = true;
            for j in 1..=n_side as i64 {
                for s in [-1i64, 1] {
                    let aj = a[(n_side as i64 + s * j) as usize];
                    // mu = 1 multiplies exactly: a homogeneous bar is Algorithm A bit for bit.
                    let wj = w[(j - 1) as usize] * mu[(n_side as i64 + s * j) as usize];
                    if aj > 0.0 {
                        acc[off(s * j)] -= wj * aj;
                        acc[off(0)] += wj * aj;
                    }
                    if aj < 1.0 {
                        all_pd = false;
                    }
                    let xi = (s * j) as f64 * dx;
                    let mut p = 1.0;
                    let mut fact = 1.0;
                    for (m, dm) in d.iter_mut().enumerate().skip(1).take(m_order) {
                        p *= xi;
                        fact *= m as f64;
                        *dm += wj * (1.0 - aj) * p / fact;
                    }
                }
            }
            let is_transition = !all_pd;
            let has = |o: i64| mesh.node_of_fine(k + o).is_some();
            // -(D1 u' + D2 u'') with centred 3-point differences (eq. (20)-(21)); with HOG,
            // -(D1 u' + ... + D4 u'''') with centred 5-point differences for every derivative,
            // so that the local part is exact for quartics like the Taylor expansion (36) with
            // M = 4 (a 3-point u' would leave an O(u''' dx^2) error even for cubics).
            let h2 = dx * dx;
            if params.hog && has(-2) && has(2) {
                let c1 = d[1] / (12.0 * dx);
                let c2 = d[2] / (12.0 * h2);
                let c3 = d[3] / (2.0 * dx * h2);
                let c4 = d[4] / (h2 * h2);
                // u'    = (-u2 + 8 u1 - 8 u-1 + u-2) / (12 dx)
                // u''   = (-u2 + 16 u1 - 30 u0 + 16 u-1 - u-2) / (12 dx^2)
                // u'''  = (u2 - 2 u1 + 2 u-1 - u-2) / (2 dx^3)
                // u'''' = (u2 - 4 u1 + 6 u0 - 4 u-1 + u-2) / dx^4
                acc[off(2)] -= -c1 - c2 + c3 + c4;
                acc[off(1)] -= 8.0 * c1 + 16.0 * c2 - 2.0 * c3 - 4.0 * c4;
                acc[off(0)] -= -30.0 * c2 + 6.0 * c4;
                acc[off(-1)] -= -8.0 * c1 + 16.0 * c2 + 2.0 * c3 - 4.0 * c4;
                acc[off(-2)] -= c1 - c2 - c3 + c4;
            }
            let local3 = !(params.hog && has(-2) && has(2)) && has(-1) && has(1);
            if local3 {
                // (Also HOG rows next to a domain end, where the 5-point stencil does not fit:
                // the third and fourth derivative terms are dropped there.)
                acc[off(1)] -= d[1] / (2.0 * dx) + d[2] / h2;
                acc[off(-1)] -= -d[1] / (2.0 * dx) + d[2] / h2;
                acc[off(0)] += 2.0 * d[2] / h2;
            }
            let reach = n_side as i64 + 2;
            for o in -reach..=reach {
                let v = acc[off(o)];
                if v != 0.0 || o == 0 {
                    if let Some(q) = mesh.node_of_fine(k + o) {
                        col.push(q);
                        val.push(v * v_i);
                    }
                }
            }
            let part =
                if end { LocalPart::End } else { LocalPart::Lattice { d1: d[1], d2: d[2], three_point: local3 } };
            (col, val, is_transition, part)
        };
        let rows: Vec<(Vec<usize>, Vec<f64>, bool, LocalPart)> = (0..n).into_par_iter().map(row).collect();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0usize);
        for r in &rows {
            row_ptr.push(row_ptr.last().unwrap() + r.0.len());
        }
        let mut col = Vec::with_capacity(*row_ptr.last().unwrap());
        let mut val = Vec::with_capacity(*row_ptr.last().unwrap());
        let mut transition = Vec::with_capacity(n);
        let mut local = Vec::with_capacity(n);
        for (c, v, t, l) in rows {
            col.extend(c);
            val.extend(v);
            transition.push(t);
            local.push(l);
        }
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
