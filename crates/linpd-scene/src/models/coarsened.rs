//! `"type": "coarsened"` scenes: a coarsened level model read from a moduli file
//! ([`linpd_io::mtx`]), one more model ([`super::SceneModel`]) of the same [`crate::Problem`],
//! with the same constraints, loads, solvers and outputs as the lattice models.
//!
//! The level's nodes (positions `x_i`, volumes `v_i`) come from the nodes file beside the
//! Matrix Market file, so a coarsened scene has no `grid` and no `horizon`. The nodal stiffness
//! is [`ModuliFile::stiffness`]:
//!
//! ```text
//! K_ij = -v_i v_j C(x_i, x_j)   (i != j),      K_ii = -sum_{j != i} K_ij,
//! ```
//!
//! and equilibrium is `K u = f` with `f_i` the point forces plus `b v_i` for a body-force density
//! `b`. Constraints are eliminated as for every model ([`linpd_solve::solve_model`]): `u = u_bar + u_f`,
//! `K_ff u_f = f_f - (K u_bar)_f`. Before factorizing, the bonded-pair graph is checked for
//! rigid motions the constraints leave free ([`linpd_core::check_support`]), so a floating body
//! is reported by its nodes rather than as a zero pivot. `K` is symmetric when
//! `C(x, q) = C(q, x)^T`; then the solve is a sparse Cholesky (or the scene's solver), otherwise
//! a sparse LU, and the report's `solver` says why.

use super::model_type::{struct_fields, ModelType, Validated};
use super::{Capability, Purpose, SceneModel, System};
use crate::nodes::{LevelNodes, Nodes};
use crate::scene::Problem;
use crate::solution::Solution;
use crate::validate::Context;
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_core::AssembledModel;
use linpd_solve::SolveReport;
use serde::Deserialize;
use std::any::Any;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub use linpd_io::mtx::{ModuliFile, MtxError};

pub use linpd_core::sparse::SYMMETRY_RTOL;

/// The model of a coarsened scene: the level's stiffness `K` and where it came from.
#[derive(Debug, Clone)]
pub struct CoarsenedModel {
    /// Coarsening level of the file.
    pub(crate) level: usize,
    /// The moduli file (resolved against the scene's directory).
    pub(crate) moduli_path: PathBuf,
    /// Index of each node in the level-0 model.
    pub(crate) level0: Vec<usize>,
    /// The level as a model: its nodal stiffness `K` (`dim * n` square, CSC), shared with the
    /// systems built from it.
    pub(crate) model: Arc<AssembledModel>,
    /// Bonded pairs: nonzero off-diagonal blocks of `K` (each pair counted from both ends when
    /// both directions are stored).
    pub(crate) n_bonds: usize,
    /// `max |K - K^T| / max |K|`.
    pub(crate) asymmetry: f64,
    /// Reciprocity defect of the moduli, `max |C_ij - C_ji^T| / max |C|` over the file's entries
    /// ([`ModuliFile::asymmetry`]).
    pub(crate) reciprocity: f64,
    /// Seconds spent reading the files and building `K`.
    pub(crate) build_seconds: f64,
}

impl CoarsenedModel {
    /// Coarsening level of the file.
    pub fn level(&self) -> usize {
        self.level
    }
    /// The moduli file (resolved against the scene's directory).
    pub fn moduli_path(&self) -> &std::path::Path {
        &self.moduli_path
    }
    /// Index of each node in the level-0 model.
    pub fn level0(&self) -> &[usize] {
        &self.level0
    }
    /// The level as a model (its stiffness `K`).
    pub fn model(&self) -> &AssembledModel {
        &self.model
    }
    /// Bonded pairs: nonzero off-diagonal blocks of `K`.
    pub fn n_bonds(&self) -> usize {
        self.n_bonds
    }
    /// `max |K - K^T| / max |K|`.
    pub fn asymmetry(&self) -> f64 {
        self.asymmetry
    }
    /// `max |C_ij - C_ji^T| / max |C|`: 0 for the levels `linpd coarsen` writes (symmetrized).
    pub fn reciprocity(&self) -> f64 {
        self.reciprocity
    }
    /// What the symmetry check found, for `linpd validate` and the solve report. `K` is what
    /// is factorized, so `K` is judged. Reciprocal moduli (`C_ij = C_ji^T`) make the off-diagonal
    /// blocks `K_ij = -v_i v_j C_ij` symmetric, but the diagonal block
    /// `K_ii = sum_j v_i v_j C_ij` is symmetric only when the sum of the tensors `C_ij` is,
    /// which Silling's coarsened moduli do not promise (the bond plate's level 1: 1.5e-4); a
    /// Cholesky factorization of such a `K` would solve another system (relative residual
    /// 2.4e-3, docs/coarsening.md).
    pub fn symmetry(&self) -> String {
        if self.is_symmetric() {
            return "symmetric".to_string();
        }
        if self.reciprocity <= SYMMETRY_RTOL {
            format!(
                "unsymmetric (relative asymmetry {:.2e}, all in the diagonal blocks K_ii = sum_j v_i v_j C_ij: the moduli are reciprocal, C_ij = C_ji^T to {:.1e}, but the tensors C_ij are not symmetric)",
                self.asymmetry, self.reciprocity
            )
        } else {
            format!(
                "unsymmetric (relative asymmetry {:.2e}; the moduli are not reciprocal: max |C_ij - C_ji^T| / max |C| = {:.2e})",
                self.asymmetry, self.reciprocity
            )
        }
    }
    /// Seconds spent reading the files and building `K`.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }
}

impl CoarsenedModel {
    /// True when `K` is symmetric to [`SYMMETRY_RTOL`].
    pub fn is_symmetric(&self) -> bool {
        self.asymmetry <= SYMMETRY_RTOL
    }
}

/// The keys of a coarsened model.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCoarsened {
    /// `"coarsened"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// The Matrix Market moduli file (relative paths start at the scene's directory).
    #[serde(default)]
    pub moduli: Option<String>,
}

/// The coarsened model type.
pub struct CoarsenedType;

/// The registry entry.
pub static COARSENED: CoarsenedType = CoarsenedType;

impl ModelType for CoarsenedType {
    fn name(&self) -> &'static str {
        "coarsened"
    }
    fn fields(&self) -> &'static [&'static str] {
        struct_fields::<RawCoarsened>()
    }
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError> {
        let keys: RawCoarsened = cx.model_keys()?;
        validate(cx, &keys)
    }
}

/// Validates a scene whose `model.type` is `coarsened`: reads the level and builds its `K`.
fn validate(cx: &Context, keys: &RawCoarsened) -> Result<Validated, ProblemError> {
    let t0 = Instant::now();
    let (raw, dim, base_dir) = (cx.raw, cx.dim(), cx.base_dir);
    let moduli = &keys.moduli;
    let moduli = moduli.as_ref().ok_or_else(|| {
        ProblemError::invalid(
            "model.moduli",
            "missing: the Matrix Market file of the coarsened moduli (e.g. \"out/level-1.mtx\")",
        )
    })?;
    let moduli_path = if Path::new(moduli).is_absolute() { PathBuf::from(moduli) } else { base_dir.join(moduli) };
    if raw.output.slice.is_some() {
        return Err(ProblemError::invalid(
            "output.slice",
            "coarsened levels get no map yet (their nodes are not on a lattice)",
        ));
    }
    if raw.body.is_some() {
        return Err(ProblemError::invalid(
            "body",
            "not used by a coarsened model (its nodes come from its nodes file)",
        ));
    }
    if raw.grid.is_some() {
        return Err(ProblemError::invalid(
            "grid",
            format!(
                "not used by a coarsened model (its nodes come from {})",
                linpd_io::mtx::nodes_path(&moduli_path).display()
            ),
        ));
    }
    if raw.nodes.is_some() {
        return Err(ProblemError::invalid(
            "nodes",
            "not used by a coarsened model (its nodes come from its nodes file)",
        ));
    }
    let file = ModuliFile::read(&moduli_path).map_err(|e| ProblemError::invalid("model.moduli", e.to_string()))?;
    if file.dim != dim {
        return Err(ProblemError::invalid(
            "dimension",
            format!(
                "the scene has dimension {dim} but the moduli file {} holds a {}D model (% dim {})",
                moduli_path.display(),
                file.dim,
                file.dim
            ),
        ));
    }
    let nodes = LevelNodes::new(dim, file.positions.clone(), file.volumes.clone());
    if file.n_nodes() == 0 {
        return Err(ProblemError::invalid(
            "model.moduli",
            format!("{}: the level has no nodes", moduli_path.display()),
        ));
    }
    let model = AssembledModel::new(
        "coarsened",
        dim,
        file.positions.clone(),
        file.stiffness().map_err(|e| ProblemError::invalid("model.moduli", e.to_string()))?,
    )
    .with_labels("level-0 node", file.level0.clone());
    let asymmetry = model.stiffness_asymmetry();
    let reciprocity = file.asymmetry();
    let mut pairs: Vec<(usize, usize)> =
        file.entries.iter().filter(|e| e.2 != 0.0).map(|e| (e.0 / dim, e.1 / dim)).collect();
    pairs.sort_unstable();
    pairs.dedup();
    let coarsened = CoarsenedModel {
        level: file.level,
        moduli_path,
        level0: file.level0,
        model: Arc::new(model),
        n_bonds: pairs.len(),
        asymmetry,
        reciprocity,
        build_seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(Validated { nodes: Nodes::Level(nodes), model: Box::new(coarsened) })
}

impl SceneModel for CoarsenedModel {
    fn name(&self) -> &'static str {
        "coarsened"
    }
    fn horizon(&self) -> Option<f64> {
        None
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        match capability {
            Capability::MatrixFree => Some("not available for coarsened models (K is read assembled)".into()),
            Capability::Dynamics => {
                Some("explicit dynamics is not available for coarsened models (bond models only)".into())
            }
            Capability::Coarsen => Some(
                "a pipeline coarsens its scene's model level after level; add a level to the pipeline instead of \
                 coarsening a level file"
                    .into(),
            ),
            _ => None,
        }
    }
    fn summary(&self, p: &Problem) -> String {
        format!(
            "coarsened level {} from {}, dimension {}, {} nodes, {} bonded pairs, K {}",
            self.level,
            self.moduli_path.display(),
            p.dim(),
            p.nodes().len(),
            self.n_bonds,
            self.symmetry()
        )
    }
    fn inputs(&self) -> Vec<PathBuf> {
        vec![self.moduli_path.clone()]
    }
    /// The level was read (its `K` built) at validation: counted as assembly.
    fn system(&self, p: &Problem, _: Purpose, _: &dyn Progress) -> Result<System, ProblemError> {
        // say which quantity is unsymmetric, beside the solver's generic note
        let notes = if self.is_symmetric() { Vec::new() } else { vec![format!("K is {}", self.symmetry())] };
        Ok(System {
            model: self.model.clone(),
            bc: p.dirichlet(),
            f: p.load_vector(),
            n_bonds: self.n_bonds,
            notes,
            built_before: self.build_seconds,
            memory_estimate: None,
        })
    }
    fn solution(&self, p: &Problem, _: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        Ok(solution(p, self, u, report))
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The [`Solution`] of a coarsened scene for displacements `u` over all DOFs (solved here or
/// elsewhere, `linpd_problem::RowSystem`).
fn solution(p: &Problem, c: &CoarsenedModel, u: Vec<f64>, report: SolveReport) -> Solution {
    let balance = p.balance(&|u, y| linpd_core::Model::apply(c.model.as_ref(), u, y), &u);
    let volumes: Vec<f64> = (0..p.nodes.len()).map(|n| p.nodes.volume(n)).collect();
    let strain = Some(crate::nodal_strain(c.model.as_ref(), &volumes, &u));
    // an energy density only where K is the Hessian of an energy (symmetric)
    let strain_energy_density = c.is_symmetric().then(|| {
        let e = level_nodal_energy(c.model.stiffness(), p.dim(), &u);
        e.iter().zip(&volumes).map(|(w, v)| w / v).collect()
    });
    Solution {
        name: p.name.clone(),
        dim: p.dim(),
        x: p.nodes.positions(),
        u,
        is_layer: vec![false; p.nodes.len()],
        volumes,
        n_bonds: c.n_bonds,
        balance: Some(balance),
        strain_energy_density,
        strain,
        dilatation: None,
        cells: None,
        graded_mesh: None,
        file_node: None,
        material: Vec::new(),
        stress: None,
        pd_stress: None,
        report,
    }
}

/// The strain energy `W_i V_i` of every node of a level with a **symmetric** `K`: as for the
/// bond model ([`crate::stress::energy_and_force_flux`]), with zero block-row sums (`K_ii = -sum_{j != i}
/// K_ij`, true of every level by construction) and `K_ji = K_ij^T`,
///
/// ```text
/// u.K u / 2 = -(1/4) sum_i sum_{j != i} (u_j - u_i)^T K_ji (u_j - u_i),
/// ```
///
/// and node `i` takes its term: read from the `d` columns of node `i` (the blocks `K_ji`), so the
/// values sum to `u.K u / 2`. An unsymmetric level (reciprocal but unsymmetric tensors, or
/// non-reciprocal moduli) is not the Hessian of an energy, and gets no density.
fn level_nodal_energy(k: &linpd_core::Csc, d: usize, u: &[f64]) -> Vec<f64> {
    let (cp, ri, val) = (k.symbolic().col_ptr(), k.symbolic().row_idx(), k.val());
    let n = u.len() / d;
    (0..n)
        .map(|i| {
            let mut w = 0.0;
            for b in 0..d {
                let c = d * i + b;
                for p in cp[c]..cp[c + 1] {
                    let (j, a) = (ri[p] / d, ri[p] % d);
                    if j != i {
                        w -= 0.25 * (u[d * j + a] - u[d * i + a]) * val[p] * (u[d * j + b] - u[d * i + b]);
                    }
                }
            }
            w
        })
        .collect()
}
