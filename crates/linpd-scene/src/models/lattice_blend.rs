//! Bond scenes with `model.pd_regions`: the 2D/3D blended PD / local-elasticity model of
//! [`linpd_blend::lattice`] (PD inside the regions, local elasticity beyond the transition).
//!
//! `beta` is 1 on the nodes inside any PD region and falls with the transition profile over
//! the distance (between nodes) to the nearest such node. The solve report's note gives the
//! node counts of the three zones and the stored entries against the pure bond model's.
//!
//! The blended operator is unsymmetric and assembled whole: no matrix-free solve, no block
//! rows (yet), no explicit dynamics. It is not coarsened either: Silling's coarsening condenses
//! a nonlocal model whose every node interacts through bonds, and the local zone's element
//! rows are already the coarse description there (coarsen the pure bond scene instead).

use super::bond_model::{self as bond, BondModel, RawBond, RawFreeFaces, Surface};
use super::{Capability, Purpose, SceneModel, System};
use crate::scene::Problem;
use crate::solution::{GradedMeshSummary, Solution};
use crate::validate::region;
use crate::ProblemError;
use linpd_blend::graded_blend::{Bond, FreeFaces, LocalMesh};
use linpd_blend::graded_mesh::{GradedMesh, Grading, GradingError};
use linpd_blend::lattice::{regular_near_defects, regular_nodes};
use linpd_blend::{beta_from_zone, BlendError, GradedBlend, LatticeBlend};
use linpd_bond::BondOperator;
use linpd_core::progress::Progress;
use linpd_core::{Grid, Region, GEOMETRY_RTOL};
use linpd_lps::SurfaceCorrection;
use linpd_solve::SolveReport;
use rayon::prelude::*;
use std::any::Any;
use std::sync::Arc;

/// A bond scene with `pd_regions`: the bond model and where it is PD.
#[derive(Debug, Clone)]
pub struct LatticeBlendModel {
    /// The bond model's parameters.
    pub bond: BondModel,
    /// The PD regions and the transition.
    pub zone: PdZone,
}

/// `model.pd_regions`, `transition`, `transition_profile`, `local_mesh`: where the blended
/// model is PD and how its local zone is meshed.
#[derive(Debug, Clone, PartialEq)]
pub struct PdZone {
    /// The PD regions (`beta = 1` on the nodes inside any of them).
    pub regions: PdRegions,
    /// The transition's width.
    pub transition: f64,
    /// How `beta` falls across it.
    pub profile: linpd_blend::Profile,
    /// The graded local mesh (`None`: the local zone's elements are the lattice cells).
    pub local_mesh: Option<LocalMesh>,
}

/// Default `model.local_mesh.cells_per_level`: on the centre-cracked plate at 401^2 (docs/models.md)
/// 4 left 7.3e-4 of max |u| against pure PD at 0.25x its unknowns, 2 left 1.4e-3 at 0.21x.
pub const CELLS_PER_LEVEL: usize = 4;

/// `model.local_mesh` on `grid`: `max_cell` (at least the spacing) rounds down to `h 2^L`.
fn local_mesh(
    grid: &Grid,
    raw: Option<crate::models::bond_model::RawLocalMesh>,
) -> Result<Option<LocalMesh>, ProblemError> {
    let Some(raw) = raw else { return Ok(None) };
    let h = grid.spacing();
    let ratio = raw.max_cell / h;
    if !(ratio.is_finite() && ratio >= 1.0 - linpd_core::GEOMETRY_RTOL) {
        return Err(ProblemError::invalid(
            "model.local_mesh.max_cell",
            format!(
                "{:e} is below the grid spacing {h:e}: the coarsest cell is at least one lattice cell",
                raw.max_cell
            ),
        ));
    }
    let max_level = ((ratio * (1.0 + linpd_core::GEOMETRY_RTOL)).log2().floor() as usize).min(Grading::MAX_LEVEL);
    let cells_per_level = raw.cells_per_level.unwrap_or(CELLS_PER_LEVEL);
    let grading = Grading::new(cells_per_level, max_level).map_err(|e| match e {
        GradingError::NoCellsPerLevel => {
            ProblemError::invalid("model.local_mesh.cells_per_level", "must be at least 1")
        }
        e => ProblemError::invalid("model.local_mesh.max_cell", e.to_string()),
    })?;
    let free_faces = match raw.free_faces {
        None | Some(RawFreeFaces::Lattice) => FreeFaces::Lattice,
        Some(RawFreeFaces::Bulk) => FreeFaces::Bulk,
    };
    Ok(Some(LocalMesh { grading, free_faces }))
}

/// The PD regions of a blended scene.
#[derive(Debug, Clone, PartialEq)]
pub enum PdRegions {
    /// Given regions.
    Given(Vec<Region>),
    /// Every node within `radius` (a length) of a feature of the scene ([`LatticeBlendModel::build`]).
    Auto {
        /// The radius, `auto_radius` horizons.
        radius: f64,
    },
}

/// Default `model.auto_radius`, in horizons, from `linpd study blend-2d` (docs/studies/blend-2d,
/// transition 1 horizon, linear): at radius 2 the error against pure PD is <= 6.4e-4 of max |u|
/// on the edge-cracked plate (41,607 and 92,407 nodes) and <= 4.5e-4 on the plate with a hole
/// (19,650 and 43,536 nodes) at 0.39x-0.46x the entries; radius 1 leaves 1.5e-3 on the hole,
/// radius 0.5 2.6e-2 (the roller support's edge), radius 3 gains < 10 % for +7 % entries.
pub const AUTO_RADIUS: f64 = 2.0;
/// Default `model.transition` with `"pd_regions": "auto"` in 2D, in horizons (docs/models.md: on
/// the centre-cracked plate 2 horizons gave 5.2e-4 against 5.9e-4 for 1, at 0.436x against
/// 0.405x the entries).
pub const AUTO_TRANSITION: f64 = 1.0;
/// The same in 3D: with one horizon GMRES stagnated with every preconditioner built from `M`
/// (a 21^3 blended cube: multigrid at 2.3e-5, the Cholesky of `M` at 7.8e-8 after 200
/// iterations; a 32^3 block with a penny crack: multigrid at 4.3e-6, Jacobi 2.4e-7), with two it
/// converges in 28-33 iterations (docs/models.md).
pub const AUTO_TRANSITION_3D: f64 = 2.0;

/// `model.pd_regions` and its transition keys on a bond model of a 2D/3D lattice.
pub(crate) fn zone(grid: &Grid, raw: &RawBond, surface: Surface) -> Result<Option<PdZone>, ProblemError> {
    use crate::raw::{RawBlending as B, RawPdRegions};
    let (horizon, regions, auto_radius, transition) =
        (raw.horizon, raw.pd_regions.as_ref(), raw.auto_radius, raw.transition);
    let (profile, value) = (raw.transition_profile, raw.transition_value);
    let Some(raw_regions) = regions else {
        for (key, given) in [
            ("auto_radius", auto_radius.is_some()),
            ("transition", transition.is_some()),
            ("transition_profile", profile.is_some()),
            ("transition_value", value.is_some()),
            ("local_mesh", raw.local_mesh.is_some()),
        ] {
            if given {
                return Err(ProblemError::invalid(format!("model.{key}"), "belongs to pd_regions, which is missing"));
            }
        }
        return Ok(None);
    };
    let dim = grid.dim();
    if dim == 1 {
        return Err(ProblemError::invalid(
            "model.pd_regions",
            "2D and 3D only: a 1D blend is `\"type\": \"blend\"` (Algorithm A with L1..L4)",
        ));
    }
    if surface.correction != SurfaceCorrection::None {
        return Err(ProblemError::invalid(
            "model.pd_regions",
            "not with a surface correction yet (the local model's moduli come from the uncorrected bonds)",
        ));
    }
    let auto = matches!(raw_regions, RawPdRegions::Auto);
    if auto_radius.is_some() && !auto {
        return Err(ProblemError::invalid("model.auto_radius", "only with \"pd_regions\": \"auto\""));
    }
    let h = grid.spacing();
    let width = match transition {
        Some(w) => w,
        None if auto && dim == 3 => AUTO_TRANSITION_3D * horizon,
        None if auto => AUTO_TRANSITION * horizon,
        None => {
            return Err(ProblemError::invalid(
                "model",
                "missing field `transition` (the width of the PD-to-local transition)",
            ))
        }
    };
    if !(width.is_finite() && width >= h * (1.0 - linpd_core::GEOMETRY_RTOL)) {
        return Err(ProblemError::invalid(
            "model.transition",
            format!("{width:e} is narrower than the grid spacing {h:e}: a transition needs at least one node"),
        ));
    }
    let regions = match raw_regions {
        RawPdRegions::Auto => {
            let k = auto_radius.unwrap_or(AUTO_RADIUS);
            if !(k.is_finite() && k >= 0.0) {
                return Err(ProblemError::invalid("model.auto_radius", format!("must be >= 0 horizons, got {k:e}")));
            }
            PdRegions::Auto { radius: k * horizon }
        }
        RawPdRegions::Regions(raw_regions) => {
            if raw_regions.is_empty() {
                return Err(ProblemError::invalid("model.pd_regions", "empty: give at least one region, or \"auto\""));
            }
            let mut out = Vec::with_capacity(raw_regions.len());
            for (k, r) in raw_regions.iter().enumerate() {
                let path = format!("model.pd_regions[{k}]");
                let region = region(&path, r, dim)?;
                let tol = linpd_core::GEOMETRY_RTOL * h;
                if !(0..grid.len()).any(|i| !grid.is_layer(i) && region.contains(&grid.position(i), dim, tol)) {
                    return Err(ProblemError::invalid(path, "holds no node of the body (outside it, or in a hole)"));
                }
                out.push(region);
            }
            PdRegions::Given(out)
        }
    };
    let profile = match (profile, value) {
        (None | Some(B::Linear), None) => linpd_blend::Profile::Linear,
        (Some(B::Cubic), None) => linpd_blend::Profile::Cubic,
        (Some(B::Constant), v) => {
            let v = v.unwrap_or(0.5);
            if !(v > 0.0 && v < 1.0) {
                return Err(ProblemError::invalid("model.transition_value", format!("{v:e} is not in (0, 1)")));
            }
            linpd_blend::Profile::Constant(v)
        }
        (Some(B::Piecewise), _) => {
            return Err(ProblemError::invalid(
                "model.transition_profile",
                "piecewise is a 1D blend profile: use linear, cubic or constant",
            ))
        }
        (_, Some(_)) => {
            return Err(ProblemError::invalid(
                "model.transition_value",
                "only with \"transition_profile\": \"constant\"",
            ))
        }
    };
    let local_mesh = local_mesh(grid, raw.local_mesh)?;
    Ok(Some(PdZone { regions, transition: width, profile, local_mesh }))
}

/// What both blended models are built from: the bond operator, `beta`, the regular nodes
/// and the mirrored supports.
struct BlendInputs {
    op: BondOperator,
    beta: Vec<f64>,
    regular: Option<Vec<bool>>,
    mirrored: Vec<bool>,
}

/// `beta`, the mirrored supports and the constrained nodes of a blended scene
/// ([`LatticeBlendModel::zones_of`]).
struct ZoneInputs {
    beta: Vec<f64>,
    mirrored: Vec<bool>,
    constrained: Vec<bool>,
}

/// The graded blend as solved (over its masters).
pub struct GradedSystem {
    /// The model over the masters.
    pub graded: GradedBlend,
    /// Per load, its forces on the masters and the lattice nodes it loaded: the right-hand
    /// side's terms, kept for the balance.
    pub loads: Vec<MasterLoad>,
}

/// One load on the graded blend's masters: `P^T f`, the nonzero ones as `(master, force)`, and
/// the number of lattice nodes it loaded.
pub type MasterLoad = (Vec<(usize, [f64; 3])>, usize);

/// Solved as the graded model over its masters; handed back to the scene model by type (the
/// solution is drawn on the mesh or the lattice).
impl super::Built for GradedSystem {
    fn model(&self) -> &dyn linpd_core::Model {
        &self.graded
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl LatticeBlendModel {
    /// The bond operator, `beta`, the regular nodes and the mirrored supports of the scene.
    fn inputs(&self, p: &Problem) -> Result<BlendInputs, ProblemError> {
        let b = &self.bond;
        let grid = p.lattice()?;
        let (op, _) = b.operator(p.nodes())?;
        // with phases or defects, a node is regular when its bonds carry the homogeneous weights
        // times one factor (no defect and no interface within its horizon)
        let regular = if b.material.is_homogeneous() {
            None
        } else {
            Some(regular_nodes(grid, b.horizon, &b.micromodulus, &op).map_err(blend_error)?)
        };
        let ZoneInputs { beta, mirrored, .. } = self.zones_of(p, regular.as_deref())?;
        Ok(BlendInputs { op, beta, regular, mirrored })
    }

    /// `beta` per node (from the PD regions, or the features of `"auto"`), the mirrored
    /// supports (constrained nodes of the layer, which stand for the body beyond them) and the
    /// constrained nodes (a component or more).
    fn zones_of(&self, p: &Problem, regular: Option<&[bool]>) -> Result<ZoneInputs, ProblemError> {
        let (b, zone) = (&self.bond, &self.zone);
        let grid = p.lattice()?;
        let dim = grid.dim();
        let mut constrained = vec![false; grid.len()];
        p.for_each_prescribed(&mut |i, _, _| constrained[i] = true);
        let inside = match &zone.regions {
            PdRegions::Given(regions) => {
                let tol = GEOMETRY_RTOL * grid.spacing();
                (0..grid.len())
                    .into_par_iter()
                    .map(|i| {
                        let x = grid.position(i);
                        regions.iter().any(|r| r.contains(&x, dim, tol))
                    })
                    .collect()
            }
            PdRegions::Auto { radius } => {
                let (hard, soft) = features(p, regular, &constrained)?;
                // a node beside a defect, an interface or a removed site may have no local share
                // at all (its family and difference stencils cross them): its whole family must
                // be PD, so those features get at least one horizon
                let mut inside = dilate(grid, &hard, radius.max(b.horizon));
                for (i, x) in dilate(grid, &soft, *radius).into_iter().enumerate() {
                    inside[i] |= x;
                }
                inside
            }
        };
        let beta = beta_from_zone(grid, &inside, zone.transition, zone.profile);
        let mirrored: Vec<bool> = (0..grid.len()).map(|i| grid.is_layer(i) && constrained[i]).collect();
        Ok(ZoneInputs { beta, mirrored, constrained })
    }

    /// The scene's blended model on the lattice.
    pub fn build(&self, p: &Problem) -> Result<LatticeBlend, ProblemError> {
        let i = self.inputs(p)?;
        LatticeBlend::new(&i.op, p.lattice()?, self.bond.horizon, i.beta, i.regular.as_deref(), &i.mirrored)
            .map_err(blend_error)
    }

    /// The scene's blended model with its local zone on the graded mesh of `grading`. Only the
    /// nodes near the fine cells get bonds ([`GradedBlend::new`]): the regular nodes come from
    /// the bonds near the defects ([`regular_near_defects`]); with phases, from the whole lattice's.
    pub fn build_graded(&self, p: &Problem, local: LocalMesh) -> Result<GradedSystem, ProblemError> {
        let b = &self.bond;
        let grid = p.lattice()?;
        let regular = if b.material.is_homogeneous() {
            None
        } else if b.material.phases.is_empty() {
            Some(regular_near_defects(grid, b.horizon, &b.micromodulus, &b.material).map_err(blend_error)?)
        } else {
            let (op, _) = b.operator(p.nodes())?;
            Some(regular_nodes(grid, b.horizon, &b.micromodulus, &op).map_err(blend_error)?)
        };
        // every constrained node stays an unknown (its cells on the lattice)
        let ZoneInputs { beta, mirrored, constrained } = self.zones_of(p, regular.as_deref())?;
        let bond = Bond { horizon: b.horizon, micromodulus: &b.micromodulus, material: &b.material };
        let graded = GradedBlend::new(bond, grid, beta, regular.as_deref(), &mirrored, &constrained, local)
            .map_err(blend_error)?;
        Ok(GradedSystem { graded, loads: Vec::new() })
    }
}

impl LatticeBlendModel {
    /// The system of the graded blend: over the masters, the scene's constraints at the
    /// masters' nodes and its loads as `P^T f`.
    fn graded_system(&self, p: &Problem, local: LocalMesh) -> Result<System, ProblemError> {
        let grid = p.lattice()?;
        let mut g = self.build_graded(p, local)?;
        let grading = local.grading;
        let memory_estimate = Some(g.graded.memory_estimate());
        let d = p.dim();
        let masters = g.graded.master_nodes();
        // the constraints at the masters' nodes (every constrained node is one: its cells stay
        // on the lattice) and the loads as P^T f, without lattice-sized vectors
        let (mut mask_m, mut ubar_m) = (vec![false; d * masters.len()], vec![0.0; d * masters.len()]);
        p.for_each_prescribed(&mut |i, a, value| {
            if let Some(m) = g.graded.master_at(grid, i) {
                mask_m[d * m + a] = true;
                ubar_m[d * m + a] = value;
            }
        });
        let mut f = vec![0.0; d * masters.len()];
        let mut loads = Vec::new();
        for k in 0..p.n_loads() {
            let mut fk = vec![0.0; d * masters.len()];
            let loaded = p.visit_load(k, &mut |i, force| g.graded.add_force(grid, i, force, &mut fk));
            f.iter_mut().zip(&fk).for_each(|(t, x)| *t += x);
            let on_masters: Vec<(usize, [f64; 3])> = fk
                .chunks_exact(d)
                .enumerate()
                .filter(|(_, v)| v.iter().any(|&x| x != 0.0))
                .map(|(m, v)| (m, [0, 1, 2].map(|a| if a < d { v[a] } else { 0.0 })))
                .collect();
            loads.push((on_masters, loaded));
        }
        g.loads = loads;
        let z = g.graded.zones();
        let levels: Vec<String> =
            g.graded.mesh().counts().iter().map(|c| format!("{} cells of {}h", c.cells, 1usize << c.level)).collect();
        let describe = format!(
            "blend on a graded local mesh: {} PD, {} transition, {} local lattice nodes; {} unknowns on {} masters \
             ({:.3}x the lattice's {} DOFs); {} entries ({:.3}x the bond model's {}; the nonlocal shares listed in \
             {:.1} MiB, the rest stored in {:.1} MiB); {}",
            z.pd,
            z.transition,
            z.local,
            d * masters.len(),
            masters.len(),
            masters.len() as f64 / grid.len() as f64,
            d * grid.len(),
            z.nnz,
            z.nnz as f64 / z.nnz_pd as f64,
            z.nnz_pd,
            g.graded.share_bytes() as f64 / 1048576.0,
            g.graded.stored_bytes() as f64 / 1048576.0,
            levels.join(", ")
        );
        let mut notes = vec![describe];
        // the largest cells the grading allowed, when max_cell asked for larger ones
        let top = g.graded.mesh().counts().len() - 1;
        if top < grading.max_level() {
            notes.push(format!(
                "local_mesh: no cell of {}h (max_cell) fits: the coarsest are {}h (the box, the fine region and \
                 cells_per_level leave no room for larger ones)",
                1usize << grading.max_level(),
                1usize << top
            ));
        }
        Ok(System {
            n_bonds: z.nnz_pd / (d * d) - grid.len(),
            model: Arc::new(g),
            bc: linpd_solve::Dirichlet::new(d, &mask_m, ubar_m),
            f,
            notes,
            built_before: 0.0,
            memory_estimate,
        })
    }
}

/// The solution of the graded blend: on the mesh's nodes (masters and hanging nodes, with
/// the leaves as VTU cells), or with `output.nodes: "lattice"` on every lattice node, `u = P
/// u_M` ([`GradedBlend::expand`]). The balance is taken on the masters, the model's own
/// unknowns: `A_M u_M` against the scene's loads as `P^T f` (the forces the solve balanced;
/// `P` interpolates affine fields exactly, so `P^T` keeps each load's resultant and moment)
/// and the supports at the masters' nodes (the strain energy density is not defined for the
/// unsymmetric blend, as on the lattice). The strain ([`graded_strain`]) is PD's on the
/// corners of lattice cells and the elements' elsewhere. A mesh node's volume is its share
/// `sum_i P_im V_i` of the lattice nodes' volumes (0 for a hanging node), so the volumes still
/// sum to the body's. Nothing of the size of the lattice is held unless the output asks for
/// every lattice node.
fn graded_solution(
    p: &Problem,
    g: &GradedSystem,
    n_bonds: usize,
    u_m: &[f64],
    report: SolveReport,
) -> Result<Solution, ProblemError> {
    let grid = p.lattice()?;
    let (graded, d) = (&g.graded, p.dim());
    let mesh = graded.mesh();
    let mut balance = graded_balance(p, g, grid, u_m);
    let extra = graded.extra_nodes();
    // the sites the solution is drawn on: every lattice node, or the model's nodes (the mesh's,
    // then the extra nodes), all of them lattice nodes
    let sites: Vec<[usize; 3]> = if p.lattice_output() {
        (0..grid.len()).map(|i| grid.site_of(i)).collect()
    } else {
        mesh.nodes().iter().copied().chain(extra.iter().map(|&i| grid.site_of(i))).collect()
    };
    // u at a lattice site: P u_M
    let u_at = |k: [usize; 3]| -> [f64; 3] { grid.node_at_site(k).map_or([0.0; 3], |i| graded.u_at(grid, i, u_m)) };
    let strain = graded.strain_at(grid, &u_at, &sites);
    // the supports' reactions, from the masters to the sites
    let reaction_of = |k: [usize; 3]| -> Vec<f64> {
        let m = grid.node_at_site(k).and_then(|i| graded.master_at(grid, i));
        m.map_or(vec![0.0; d], |m| balance.nodal_reaction[d * m..d * m + d].to_vec())
    };
    let nodal_reaction: Vec<f64> = sites.par_iter().flat_map_iter(|&k| reaction_of(k)).collect();
    balance.nodal_reaction = nodal_reaction;
    let (u, volumes, cells) = if p.lattice_output() {
        let volumes = (0..grid.len()).map(|i| grid.node_volume(i)).collect();
        let cells = element_cells(mesh, &|k| grid.node_at_site(k).unwrap_or(usize::MAX));
        (graded.expand(grid, u_m), volumes, cells)
    } else {
        // a node's volume is its masters' share P^T V (0 for a hanging node)
        let v_m = graded.restrict_scalar(grid, &|i| grid.node_volume(i));
        let mut volumes: Vec<f64> =
            (0..mesh.nodes().len()).map(|i| mesh.master_of(i).map_or(0.0, |m| v_m[m])).collect();
        volumes.extend((0..extra.len()).map(|x| v_m[mesh.n_masters() + x]));
        let cells = element_cells(mesh, &|k| mesh.node_at(k).unwrap_or(usize::MAX));
        let u = sites.par_iter().flat_map_iter(|&k| u_at(k)[..d].to_vec()).collect();
        (u, volumes, cells)
    };
    Ok(Solution {
        name: p.name().to_string(),
        dim: d,
        x: sites.iter().map(|&k| grid.site_position(k)).collect(),
        is_layer: sites.iter().map(|&k| grid.node_at_site(k).is_some_and(|i| grid.is_layer(i))).collect(),
        u,
        volumes,
        n_bonds,
        balance: Some(balance),
        strain_energy_density: None,
        strain: Some(strain),
        dilatation: None,
        cells: Some(cells),
        material: Vec::new(),
        stress: None,
        pd_stress: None,
        graded_mesh: Some(GradedMeshSummary {
            lattice_nodes: grid.len(),
            levels: mesh.counts(),
            masters: mesh.n_masters(),
            extra_nodes: extra.len(),
            window_nodes: graded.window().0.len(),
            nnz: graded.zones().nnz,
            nnz_pd: graded.zones().nnz_pd,
        }),
        file_node: None,
        report,
    })
}

/// The force balance of the graded blend's solution `u_m` on its masters (see
/// [`graded_solution`]): `A_M u_M`, the scene's loads as `P^T f`, its supports at the
/// masters' nodes.
fn graded_balance(p: &Problem, g: &GradedSystem, grid: &Grid, u_m: &[f64]) -> crate::balance::Balance {
    let (graded, d) = (&g.graded, p.dim());
    let mut au = vec![0.0; u_m.len()];
    linpd_core::Model::apply(graded, u_m, &mut au);
    // the loads' forces on the masters, as the right-hand side had them
    let load = |k: usize, visit: &mut dyn FnMut(usize, &[f64])| {
        let (forces, loaded) = &g.loads[k];
        forces.iter().for_each(|(m, v)| visit(*m, &v[..d]));
        *loaded
    };
    let held = |k: usize| -> Vec<(usize, usize)> {
        p.held_dofs(k).into_iter().filter_map(|(i, a)| graded.master_at(grid, i).map(|m| (m, a))).collect()
    };
    let nodes = crate::scene::BalanceNodes {
        n: graded.master_nodes().len(),
        position: &|m| grid.position(graded.master_nodes()[m]),
        load: &load,
        held: &held,
    };
    p.balance_on(&nodes, &au)
}

/// The graded mesh's leaves as VTK cells (`VTK_QUAD` / `VTK_HEXAHEDRON`) over the output's
/// points, `point(k)` the point of lattice site `k` ([`GradedMesh::cell_corners`]).
fn element_cells(mesh: &GradedMesh, point: &dyn Fn([usize; 3]) -> usize) -> linpd_io::vtk::Cells {
    let d = mesh.dim();
    linpd_io::vtk::Cells {
        vtk_type: if d == 2 { 9 } else { 12 },
        per_cell: 1 << d,
        connectivity: mesh.cell_corners(point),
    }
}

/// [`crate::memory::blend_zone_bytes`] of the blend of `inputs`, from its rows' blocks
/// ([`linpd_blend::lattice::row_blocks`]).
fn zone_bytes(inputs: &BlendInputs, setup: &[linpd_solve::PreconditionerKind]) -> f64 {
    let (op, beta) = (&inputs.op, &inputs.beta);
    let blocks = linpd_blend::lattice::row_blocks(op, beta);
    crate::memory::blend_zone_bytes(op.dim(), op.n_nodes(), op.family().n_bonds(), blocks, setup)
}

/// What a blended model offers the solvers with `unknowns` free DOFs: an unsymmetric `A`; on a
/// graded local mesh (`graded`) applied matrix-free with an SPD companion that has block rows
/// (`auto`'s matrix-free GMRES), on the lattice assembled whole.
pub(crate) fn offers(dim: usize, unknowns: usize, graded: bool) -> linpd_solve::Offers {
    linpd_solve::Offers { dim, unknowns, symmetric: false, fast_apply: false, companion_gmres: graded }
}

/// A blend error as the scene's, at the key that decides it: a node the local model cannot
/// take at `model.pd_regions`, the graded mesh's memory and faces at `model.local_mesh`, the
/// rest (inputs the scene built, a lattice that could not be built) at `model`.
fn blend_error(e: BlendError) -> ProblemError {
    match e {
        BlendError::NotLocal { node, reason } => ProblemError::invalid("model.pd_regions", format!("{node}: {reason}")),
        BlendError::Dimension(_) => ProblemError::invalid("model.pd_regions", e.to_string()),
        BlendError::Memory(e) => ProblemError::invalid("model.local_mesh", e.to_string()),
        e @ BlendError::BulkFacesWithPhases => ProblemError::invalid("model.local_mesh.free_faces", e.to_string()),
        e => ProblemError::invalid("model", e.to_string()),
    }
}

/// The nodes `"pd_regions": "auto"` refines around: where the solution is rough or the
/// local model cannot go. A node is a feature when
/// * its family is not regular (a defect cuts a bond of it, or a material interface is
///   within its horizon),
/// * a lattice neighbour (the `3^d` box) inside the grid's box was removed by the scene's
///   `body` (a hole, a notch, or a face of the body cut from the box: stress
///   concentrations; the grid box's own faces are free surfaces that the local model's
///   softened elements carry, measured in docs/models.md),
/// * it is loaded and a box neighbour is not, or the other way round (point loads, the
///   edges of loaded regions), or
/// * it is constrained and a box neighbour is not, or the other way round (the edges of
///   supports, where the local and the nonlocal boundary conditions differ most).
///
/// Returned as `(hard, soft)`: the first two kinds, which no local share may reach, and the
/// last two. `Err` when there is none: nothing to refine around.
fn features(
    p: &Problem,
    regular: Option<&[bool]>,
    constrained: &[bool],
) -> Result<(Vec<bool>, Vec<bool>), ProblemError> {
    let grid = p.lattice()?;
    let d = grid.dim();
    let f = p.load_vector();
    let loaded: Vec<bool> = (0..grid.len()).map(|i| (0..d).any(|a| f[d * i + a] != 0.0)).collect();
    // 0: none, 1: soft, 2: hard
    let kind: Vec<u8> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            if regular.is_some_and(|r| !r[i]) {
                return 2;
            }
            let mut soft = false;
            let k = grid.lattice_index(i);
            let span = |a: usize| if a < d { -1i64..=1 } else { 0..=0 };
            for o2 in span(2) {
                for o1 in span(1) {
                    for o0 in span(0) {
                        let kk = [k[0] + o0, k[1] + o1, k[2] + o2];
                        match grid.node_at(kk) {
                            None if grid.box_contains(kk) => return 2,
                            Some(j) if loaded[j] != loaded[i] || constrained[j] != constrained[i] => soft = true,
                            _ => {}
                        }
                    }
                }
            }
            u8::from(soft)
        })
        .collect();
    if kind.iter().all(|&k| k == 0) {
        return Err(ProblemError::invalid(
            "model.pd_regions",
            "\"auto\" found nothing to refine around (no defect, material interface, hole, load edge or \
                 support edge): give the regions, or drop pd_regions",
        ));
    }
    Ok((kind.iter().map(|&k| k == 2).collect(), kind.iter().map(|&k| k == 1).collect()))
}

/// The nodes within `radius` of a node of `features` (inclusive, by the inclusion rule of
/// [`linpd_core::family::lattice_stencil`]), by a distance transform: O(sites) whatever the radius (the stencil of
/// `radius / h` per feature node aborted allocating it at `auto_radius: 1e6`).
fn dilate(grid: &Grid, features: &[bool], radius: f64) -> Vec<bool> {
    let ratio = radius / grid.spacing();
    let r2 = ratio * ratio * (1.0 + GEOMETRY_RTOL);
    linpd_blend::lattice::squared_lattice_distances(grid, features).into_iter().map(|n2| n2 <= r2).collect()
}

impl SceneModel for LatticeBlendModel {
    fn node_elastic(&self, p: &Problem, x: &[linpd_core::Point]) -> Option<crate::scene::NodeElastic> {
        let tol = linpd_core::GEOMETRY_RTOL * crate::nodes::NodeSet::spacing(p.nodes());
        Some((self.bond.micromodulus.plane, self.bond.node_elastic(x, p.dim(), tol)?))
    }
    fn elastic_constants(&self) -> Vec<crate::elastic::PhaseConstants> {
        self.bond.elastic_constants()
    }
    fn name(&self) -> &'static str {
        "bond"
    }
    fn describe(&self) -> String {
        "bond with pd_regions (the blended model)".into()
    }
    fn horizon(&self) -> Option<f64> {
        Some(self.bond.horizon)
    }
    /// The lattice blend's (its unknowns are the lattice's); a graded mesh's unknowns are its
    /// masters, known once it is built, so its solve plans from the built model.
    fn offers(&self, p: &Problem, unknowns: usize) -> Option<linpd_solve::Offers> {
        match self.zone.local_mesh {
            None => Some(offers(p.dim(), unknowns, false)),
            Some(_) => None,
        }
    }
    fn lacks(&self, capability: Capability) -> Option<String> {
        // a graded mesh's unknowns are its masters, not the lattice's nodes, which export and
        // the row-block paths number
        const GRADED: &str = "a graded local mesh is solved by `linpd solve` only (its unknowns are not the lattice's \
                              nodes); remove local_mesh for the lattice blend";
        match capability {
            Capability::Export | Capability::BlockRows if self.zone.local_mesh.is_some() => Some(GRADED.into()),
            Capability::MatrixFree => {
                Some("the blended model is unsymmetric and assembled whole: use \"gmres\" or \"auto\"".into())
            }
            Capability::BlockRows => Some(
                "row-block assembly (the distributed path) does not take blended scenes yet: the blended model is \
                 assembled whole; use `linpd solve` or `linpd export`"
                    .into(),
            ),
            Capability::Coarsen => Some(
                "Silling's coarsening condenses a nonlocal bond model, and the blended model's local zone is already \
                 its coarse description: coarsen the scene without pd_regions"
                    .into(),
            ),
            Capability::Dynamics => Some("the blended model is static: remove pd_regions for dynamics".into()),
            _ => None,
        }
    }
    fn system(&self, p: &Problem, purpose: Purpose, progress: &dyn Progress) -> Result<System, ProblemError> {
        // assembled whole for every purpose but rows; GMRES when solved (its multigrid hierarchy,
        // when asked, comes from M)
        let path = match self.zone.local_mesh {
            Some(_) => crate::memory::Path::GradedBlendLattice,
            None => crate::memory::Path::BlendAssembled,
        };
        // the graded model checks its masters' hierarchy itself (GradedBlend::new); the lattice
        // blend's auto runs GMRES + multigrid first from 20k unknowns
        let setup = match (&self.zone.local_mesh, purpose) {
            (None, Purpose::Solve) => p.planned()?.preconditioners.clone(),
            _ => Vec::new(),
        };
        let memory_estimate = match purpose {
            Purpose::Rows => None,
            _ => Some(crate::memory::check_solver(path, p.lattice()?, self.bond.horizon, &setup)?),
        };
        if let Some(local) = self.zone.local_mesh {
            if p.lattice_output() {
                let n = p.nodes().len() as f64;
                let bytes = n * (linpd_blend::memory::GRADED_NODE_BYTES + crate::memory::GRADED_LATTICE_OUTPUT_BYTES);
                linpd_core::memory::check(
                    format!("the graded blend's solution on every one of {} lattice nodes", p.nodes().len()),
                    bytes,
                    "remove output.nodes: \"lattice\" (the model's nodes are written: the mesh's and its cells)",
                )
                .map_err(|e| ProblemError::invalid("output.nodes", e.to_string()))?;
            }
            progress.phase(&format!(
                "building the blended model on a graded local mesh over {} lattice nodes",
                p.nodes().len()
            ));
            if purpose != Purpose::Solve {
                // export and rows are refused by capability before they get here; modes builds
                // the assembled system over the lattice's nodes too
                return Err(ProblemError::invalid(
                    "model.local_mesh",
                    "a graded local mesh is solved by `linpd solve` only (its unknowns are not the lattice's nodes, \
                     which modes, export and the row-block paths number); remove local_mesh for the lattice blend",
                ));
            }
            return self.graded_system(p, local);
        }
        progress.phase(&bond::building(p, self.bond.horizon));
        progress.phase(&format!("building the blended model: {} nodes", p.nodes().len()));
        let inputs = self.inputs(p)?;
        // the zones are known: the estimate from the blend's own rows, checked before they are
        // built (the one above counted the bond model's entries, an upper bound)
        let refined = zone_bytes(&inputs, &setup);
        linpd_core::memory::check(
            format!("the blended model and its SPD companion on {} nodes (from its zones)", p.nodes().len()),
            refined,
            "use a coarser spacing, a smaller horizon, or smaller PD regions",
        )
        .map_err(|e| ProblemError::invalid("model.pd_regions", e.to_string()))?;
        let memory_estimate = memory_estimate.map(|_| refined);
        let model = LatticeBlend::new(
            &inputs.op,
            p.lattice()?,
            self.bond.horizon,
            inputs.beta,
            inputs.regular.as_deref(),
            &inputs.mirrored,
        )
        .map_err(blend_error)?;
        let z = model.zones();
        let describe = format!(
            "blend: {} PD, {} transition, {} local nodes; {} stored entries, {:.3}x the bond model's {}",
            z.pd,
            z.transition,
            z.local,
            z.nnz,
            z.nnz as f64 / z.nnz_pd as f64,
            z.nnz_pd
        );
        // the bond model's directed bonds, from its stored entries d^2 (n + bonds)
        let d = p.dim();
        Ok(System {
            n_bonds: z.nnz_pd / (d * d) - p.nodes().len(),
            model: Arc::new(model),
            bc: p.dirichlet(),
            f: p.load_vector(),
            notes: vec![describe],
            built_before: 0.0,
            memory_estimate,
        })
    }
    fn solution(&self, p: &Problem, s: &System, u: Vec<f64>, report: SolveReport) -> Result<Solution, ProblemError> {
        match s.model.as_any().downcast_ref::<GradedSystem>() {
            Some(g) => graded_solution(p, g, s.n_bonds, &u, report),
            None => Ok(bond::solution(p, s.model(), s.n_bonds, u, report)),
        }
    }
    fn bond_operator(
        &self,
        p: &Problem,
    ) -> Result<(linpd_bond::BondOperator, Option<linpd_core::surface::CorrectionSummary>), ProblemError> {
        self.bond.operator(p.nodes())
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The regular nodes from the bonds near the defects are those from the whole lattice's
    /// bonds: a 2D crack (a segment between node rows) and a 3D notch (a plane with an extent),
    /// each with nodes on both kinds of side.
    #[test]
    fn defect_regular_equals_the_whole_lattice() {
        let scenes = [
            r#"{"name": "c", "dimension": 2, "grid": {"min": [0, 0], "max": [1, 1], "spacing": 0.05, "layer": 0.15},
                "model": {"type": "bond", "horizon": 0.15, "plane": "strain", "micromodulus": {"kernel": "constant", "modulus": 1},
                          "material": {"defects": [{"segment": [[0.3, 0.525], [0.7, 0.525]], "factor": 0}]}}}"#,
            r#"{"name": "n", "dimension": 3, "grid": {"min": [0, 0, 0], "max": [1, 1, 1], "spacing": 0.1, "layer": 0.2},
                "model": {"type": "bond", "horizon": 0.25, "micromodulus": {"kernel": "constant", "modulus": 1},
                          "material": {"defects": [{"plane": {"point": [0, 0, 0.55], "normal": [0, 0, 1],
                              "extent": {"box": {"min": [-1, -1, 0], "max": [0.3, 2, 1]}}}, "factor": 0.5}]}}}"#,
        ];
        for text in scenes {
            let p = Problem::from_json(text).unwrap();
            let b = &p.model_as::<crate::models::bond_lattice::BondLatticeModel>("a bond model").unwrap().bond;
            let grid = p.lattice().unwrap();
            let (op, _) = b.operator(p.nodes()).unwrap();
            let whole = regular_nodes(grid, b.horizon, &b.micromodulus, &op).unwrap();
            let near = regular_near_defects(grid, b.horizon, &b.micromodulus, &b.material).unwrap();
            let irregular = whole.iter().filter(|r| !**r).count();
            assert!(irregular > 0 && irregular < grid.len() / 2, "{irregular} irregular nodes");
            assert_eq!(near, whole);
        }
    }
}
