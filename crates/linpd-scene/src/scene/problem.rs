//! The validated scene ([`Problem`]): its nodes, model, constraints, loads, solver and outputs,
//! and what every model reads of them (prescribed displacements, nodal forces, the force
//! balance of a solution).

use super::model::SceneModel;
use crate::balance::{moment, Balance, ConstraintBalance, LoadBalance, MomentFrame};
use crate::nodes::{NodeSet, Nodes};
use crate::ProblemError;
use linpd_core::{Grid, Region};
use linpd_solve::{Dirichlet, SolverSpec};
use std::sync::Arc;

/// A prescribed displacement: an affine field on a region, or values per DOF from a file.
#[derive(Debug, Clone, PartialEq)]
pub enum Constraint {
    /// `u = value + gradient x` on some components of the nodes of a region.
    Affine {
        /// Where.
        region: Region,
        /// Constant part.
        value: Vec<f64>,
        /// Gradient `H` (row-major `dim x dim`).
        gradient: Vec<f64>,
        /// Constrained components.
        components: Vec<usize>,
    },
    /// Values per DOF, `(node, component, value)`, read from a CSV file
    /// ([`linpd_io::nodal`]; e.g. a coarsening level's `level-<m>.prescribed.csv`).
    Nodal {
        /// The file, as the scene names it.
        file: String,
        /// `(node, component, value)`.
        values: Vec<(usize, usize, f64)>,
    },
}

impl Constraint {
    /// Prescribed value of component `a` of an affine constraint at `x` (0 for a nodal one).
    pub fn displacement(&self, x: &[f64], a: usize) -> f64 {
        match self {
            Constraint::Affine { value, gradient, .. } => {
                let d = value.len();
                value[a] + (0..d).map(|b| gradient[a * d + b] * x[b]).sum::<f64>()
            }
            Constraint::Nodal { .. } => 0.0,
        }
    }

    /// Every DOF the constraint prescribes, `(node, component, value)`, on `nodes`.
    pub(crate) fn prescribed(&self, nodes: &dyn NodeSet, dim: usize) -> Vec<(usize, usize, f64)> {
        match self {
            Constraint::Affine { region, components, .. } => {
                let mut out = Vec::new();
                for node in nodes.select(region) {
                    let x = nodes.position(node);
                    for &a in components {
                        out.push((node, a, self.displacement(&x[..dim], a)));
                    }
                }
                out
            }
            Constraint::Nodal { values, .. } => values.clone(),
        }
    }
}

/// A load.
#[derive(Debug, Clone, PartialEq)]
pub enum Load {
    /// Force on one node.
    Point {
        /// The node.
        node: usize,
        /// The force.
        force: Vec<f64>,
    },
    /// Nodal forces per node, `(node, force)`, read from a CSV file ([`linpd_io::nodal`];
    /// e.g. a coarsening level's `level-<m>.forces.csv`).
    Nodal {
        /// The file, as the scene names it.
        file: String,
        /// `(node, force)`.
        forces: Vec<(usize, Vec<f64>)>,
    },
    /// Body-force density on a region.
    Body {
        /// Where.
        region: Region,
        /// Force per unit volume.
        density: Vec<f64>,
    },
    /// A total force spread over a region's nodes in proportion to their volumes,
    /// `f_i = F v_i / sum_{j in R} v_j`: the applied total is `F` whatever the spacing.
    Resultant {
        /// Where.
        region: Region,
        /// The total force `F`.
        force: Vec<f64>,
    },
}

/// A validated scene. Its fields are private: every value in it has passed validation, and
/// only the solver may be changed afterwards ([`Problem::set_solver`]).
#[derive(Debug, Clone)]
pub struct Problem {
    /// Name.
    pub(crate) name: String,
    /// The nodes: a lattice, or a coarsened level's nodes.
    pub(crate) nodes: Nodes,
    /// The model ([`crate::models`]).
    pub(crate) model: Arc<dyn SceneModel>,
    /// Volume constraints.
    pub(crate) constraints: Vec<Constraint>,
    /// Loads.
    pub(crate) loads: Vec<Load>,
    /// Solver.
    pub(crate) solver: SolverSpec,
    /// Output directory.
    pub(crate) output_dir: String,
    /// Write plots.
    pub(crate) plot: bool,
    /// 3D maps: the plane `x[axis] = value` (`output.slice`), `None` for the middle z plane.
    pub(crate) slice: Option<(usize, f64)>,
    /// `output.nodes` is `lattice`: the solution on every lattice node, also where the model's
    /// unknowns are not (a graded local mesh).
    pub(crate) lattice_output: bool,
    /// The `dynamics` section (explicit time stepping with `linpd run`), if any.
    pub(crate) dynamics: Option<crate::dynamics::Dynamics>,
    /// `density` (`linpd modes`).
    pub(crate) density: Option<f64>,
    /// `output.probes`.
    pub(crate) probes: Vec<crate::probe::Probe>,
    /// `output.stress_map`.
    pub(crate) stress_map: crate::stress::StressMap,
    /// `output.deformed_scale`.
    pub(crate) deformed_scale: Option<f64>,
    /// A rank's part of a distributed scene: the nodes are its window.
    pub(crate) part: Option<PartScene>,
    /// The solver plan, made once from the model's offers and the solver ([`Problem::plan`]).
    pub(crate) plan: Option<linpd_solve::SolvePlan>,
}

/// A rank's share of a distributed solution's force balance ([`Problem::part_balance`]): the
/// ranks' values add up to the whole body's.
#[derive(Debug, Clone, PartialEq)]
pub struct PartBalance {
    /// Per load, its force on the owned nodes.
    pub loads: Vec<Vec<f64>>,
    /// Per load, the moment of that force about the reference point (1 component in 2D, 3
    /// in 3D, none in 1D).
    pub load_moments: Vec<Vec<f64>>,
    /// Per constraint, the supports' force at the owned DOFs it holds (a DOF two constraints
    /// hold counts for the first, as in [`crate::Balance`]).
    pub reactions: Vec<Vec<f64>>,
    /// Per constraint, the moment of that force about the reference point.
    pub reaction_moments: Vec<Vec<f64>>,
    /// Per constraint, the owned DOFs it holds.
    pub held_dofs: Vec<usize>,
}

/// Load `k`'s nodal forces on a balance's nodes, `visit(node, force)`; returns the scene's
/// nodes it loaded ([`BalanceNodes::load`]).
pub(crate) type LoadVisitor<'a> = &'a dyn Fn(usize, &mut dyn FnMut(usize, &[f64])) -> usize;

/// The nodes a force balance is taken on ([`Problem::balance_on`]) and how the scene's loads
/// and supports reach them.
pub(crate) struct BalanceNodes<'a> {
    /// Number of nodes.
    pub n: usize,
    /// Position of node `i`.
    pub position: &'a dyn Fn(usize) -> linpd_core::Point,
    /// Load `k`'s nodal forces on these nodes, `visit(node, force)`; returns the scene's nodes
    /// it loaded.
    pub load: LoadVisitor<'a>,
    /// Constraint `k`'s held DOFs on these nodes, `(node, component)`, grouped by node.
    pub held: &'a dyn Fn(usize) -> Vec<(usize, usize)>,
}

/// What a rank's part of a scene knows beyond its window's nodes ([`crate::part`]).
#[derive(Debug, Clone)]
pub struct PartScene {
    /// The planes it owns and builds.
    pub slab: crate::part::Slab,
    /// The plane of each window node (its slowest-axis plane on a lattice, its bin in a
    /// cloud), ascending.
    pub planes: Vec<u32>,
    /// A point cloud's bins and the window's nodes' numbers in the file (`None` on a lattice).
    pub cloud: Option<crate::part::CloudWindow>,
    /// The checks it recorded, in the same order on every rank.
    pub presences: Vec<crate::part::Presence>,
    /// Per load, the volume `sum_j v_j` over the whole body of a resultant load's region (the
    /// ranks' [`Problem::resultant_volumes`] summed), once [`Problem::with_resultant_volumes`]
    /// set them; `None` before.
    pub resultant_volumes: Option<Vec<f64>>,
}

impl Problem {
    /// A rank's part of a distributed scene ([`Problem::from_path_part`]), `None` for a whole
    /// scene.
    pub fn part(&self) -> Option<&PartScene> {
        self.part.as_ref()
    }
    /// Whether node `n` is one this rank owns (every node of a whole scene).
    pub fn owns(&self, n: usize) -> bool {
        match &self.part {
            Some(part) => part.planes.get(n).is_some_and(|&k| part.slab.owned.contains(&(k as usize))),
            None => true,
        }
    }
    /// Per load, the volume of a resultant load's region over the nodes this rank owns (0 for
    /// other loads): the ranks' values summed are the whole body's `sum_j v_j`.
    pub fn resultant_volumes(&self) -> Vec<f64> {
        self.loads
            .iter()
            .map(|l| match l {
                Load::Resultant { region, .. } => {
                    self.nodes.select(region).into_iter().filter(|&n| self.owns(n)).map(|n| self.nodes.volume(n)).sum()
                }
                _ => 0.0,
            })
            .collect()
    }
    /// A rank's part with the whole body's resultant volumes `totals` (per load, the ranks'
    /// [`Problem::resultant_volumes`] summed), which its loads then use; an error on a whole
    /// scene or for a wrong count.
    pub fn with_resultant_volumes(mut self, totals: Vec<f64>) -> Result<Problem, ProblemError> {
        let n = self.loads.len();
        match &mut self.part {
            Some(part) if totals.len() == n => {
                part.resultant_volumes = Some(totals);
                Ok(self)
            }
            Some(_) => Err(ProblemError::invalid("loads", format!("{} resultant volumes for {n} loads", totals.len()))),
            None => Err(ProblemError::invalid("loads", "a whole scene computes its resultant volumes itself")),
        }
    }
    /// Spatial dimension.
    pub fn dim(&self) -> usize {
        self.nodes.dim()
    }
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The lattice (`None` for a coarsened level).
    pub fn grid(&self) -> Option<&Grid> {
        self.nodes.lattice()
    }
    /// The nodes.
    pub fn nodes(&self) -> &Nodes {
        &self.nodes
    }
    /// The lattice, or an error for models without one.
    pub fn lattice(&self) -> Result<&Grid, ProblemError> {
        self.nodes.lattice().ok_or_else(|| {
            ProblemError::invalid("model.type", format!("{} models have no lattice here", self.model.describe()))
        })
    }
    /// The model.
    pub fn model(&self) -> &dyn SceneModel {
        self.model.as_ref()
    }
    /// Volume constraints.
    pub fn constraints(&self) -> &[Constraint] {
        &self.constraints
    }
    /// Loads.
    pub fn loads(&self) -> &[Load] {
        &self.loads
    }
    /// The solver.
    pub fn solver(&self) -> &SolverSpec {
        &self.solver
    }
    /// Replaces the solver (every [`SolverSpec`] is valid for every model: one a model cannot
    /// run, e.g. matrix-free LPS, fails at solve time with a typed error).
    pub fn set_solver(&mut self, solver: SolverSpec) {
        self.solver = solver;
        self.make_plan();
    }
    /// What the static solve will run ([`linpd_solve::plan()`]): made once, when the scene is
    /// validated (and again when [`Problem::set_solver`] changes the solver), from what the model
    /// offers ([`crate::SceneModel::offers`]) with the scene's free DOFs; the memory guard counts
    /// it and the solve runs it. `None` for a model that plans from its built operator.
    pub fn plan(&self) -> Option<&linpd_solve::SolvePlan> {
        self.plan.as_ref()
    }
    /// [`Problem::plan`] where a model's memory estimate needs it (its model declares offers).
    pub(crate) fn planned(&self) -> Result<&linpd_solve::SolvePlan, ProblemError> {
        self.plan.as_ref().ok_or_else(|| {
            ProblemError::invalid("solver", format!("the {} model made no solver plan", self.model.describe()))
        })
    }
    /// Makes [`Problem::plan`] from the model's offers with the scene's free DOFs.
    pub(crate) fn make_plan(&mut self) {
        let d = self.dim();
        let mut held = vec![false; d * self.nodes.len()];
        self.for_each_prescribed(&mut |node, a, _| held[d * node + a] = true);
        let unknowns = held.iter().filter(|&&h| !h).count();
        drop(held);
        self.plan = self
            .model
            .offers(self, unknowns)
            .map(|offers| linpd_solve::plan(&self.solver, &offers, &linpd_solve::statics::AutoParams::default()));
    }
    /// Output directory (`output.dir`, else `out/<name>`).
    pub fn output_dir(&self) -> &str {
        &self.output_dir
    }
    /// Whether to write plots.
    pub fn plot(&self) -> bool {
        self.plot
    }
    /// 3D maps: `(axis, value)` of the plane to show (`output.slice`), `None` for the middle
    /// z plane.
    pub fn slice(&self) -> Option<(usize, f64)> {
        self.slice
    }
    /// Whether the solution is written on every lattice node (`output.nodes: "lattice"`) rather
    /// than on the model's nodes.
    pub fn lattice_output(&self) -> bool {
        self.lattice_output
    }
    /// `output.probes`.
    pub fn probes(&self) -> &[crate::probe::Probe] {
        &self.probes
    }
    /// The probes sampled on `solution` (a solution of this scene).
    pub fn sample_probes(&self, solution: &crate::solution::Solution) -> Vec<crate::probe::ProbeSamples> {
        crate::probe::sample(&self.probes, solution, self.grid())
    }
    /// The stress map's quantity (`output.stress_map`).
    pub fn stress_map(&self) -> crate::stress::StressMap {
        self.stress_map
    }
    /// The deformed-shape plot's displacement scale (`output.deformed_scale`; `None`: chosen
    /// from the solution).
    pub fn deformed_scale(&self) -> Option<f64> {
        self.deformed_scale
    }
    /// The `dynamics` section, if any.
    pub fn dynamics(&self) -> Option<&crate::dynamics::Dynamics> {
        self.dynamics.as_ref()
    }
    /// Constrained-DOF mask and the prescribed full displacement `u_bar`.
    pub fn constrained(&self) -> (Vec<bool>, Vec<f64>) {
        let d = self.dim();
        let n = self.nodes.len();
        let mut mask = vec![false; d * n];
        let mut ubar = vec![0.0; d * n];
        self.for_each_prescribed(&mut |node, a, g| {
            mask[d * node + a] = true;
            ubar[d * node + a] = g;
        });
        (mask, ubar)
    }
    /// The DOFs constraint `k` holds, `(node, component)`, grouped by node.
    pub(crate) fn held_dofs(&self, k: usize) -> Vec<(usize, usize)> {
        self.constraints[k].prescribed(&self.nodes, self.dim()).into_iter().map(|(i, a, _)| (i, a)).collect()
    }
    /// The number of loads.
    pub(crate) fn n_loads(&self) -> usize {
        self.loads.len()
    }
    /// `f(node, component, value)` for every DOF each constraint prescribes, constraint by
    /// constraint in scene order (a later one's value wins where two hold a DOF): what
    /// [`Problem::constrained`] stores densely.
    pub(crate) fn for_each_prescribed(&self, f: &mut dyn FnMut(usize, usize, f64)) {
        for c in &self.constraints {
            for (node, a, g) in c.prescribed(&self.nodes, self.dim()) {
                f(node, a, g);
            }
        }
    }
    /// External force per full DOF (point forces plus density times node volume).
    pub fn load_vector(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.dim() * self.nodes.len()];
        for k in 0..self.loads.len() {
            self.add_load(k, &mut f);
        }
        f
    }
    /// The prescribed displacements of the constraints.
    pub fn dirichlet(&self) -> Dirichlet {
        let (mask, ubar) = self.constrained();
        Dirichlet::new(self.dim(), &mask, ubar)
    }
}

impl Problem {
    /// Adds the nodal forces of load `k` to `f` (full DOFs); returns the nodes it loaded.
    pub(crate) fn add_load(&self, k: usize, f: &mut [f64]) -> usize {
        let d = self.dim();
        self.visit_load(k, &mut |node, force| (0..d).for_each(|a| f[d * node + a] += force[a]))
    }

    /// `visit(node, force)` for each nodal force of load `k` (`d` components; a node may come
    /// more than once, the forces add); returns the nodes it loaded.
    pub(crate) fn visit_load(&self, k: usize, visit: &mut dyn FnMut(usize, &[f64])) -> usize {
        let (d, load) = (self.dim(), &self.loads[k]);
        // f_i = density v_i (body), or force v_i / sum_j v_j (resultant)
        let total = |nodes: &[usize]| match self.part.as_ref().and_then(|p| p.resultant_volumes.as_ref()) {
            Some(totals) => totals[k],
            None => nodes.iter().map(|&n| self.nodes.volume(n)).sum::<f64>(),
        };
        let (region, vector, resultant) = match load {
            Load::Point { node, force } => {
                visit(*node, &force[..d]);
                return 1;
            }
            Load::Nodal { forces, .. } => {
                for (node, force) in forces {
                    visit(*node, &force[..d]);
                }
                return forces.len();
            }
            Load::Body { region, density } => (region, density, false),
            Load::Resultant { region, force } => (region, force, true),
        };
        let nodes = self.nodes.select(region);
        let per_volume = if resultant { 1.0 / total(&nodes) } else { 1.0 };
        let mut force = [0.0; 3];
        for &node in &nodes {
            let v = self.nodes.volume(node) * per_volume;
            (0..d).for_each(|a| force[a] = vector[a] * v);
            visit(node, &force[..d]);
        }
        nodes.len()
    }

    /// The balance of the solution `u` of this scene on `model` (its full operator), forces and
    /// moments ([`crate::balance`]).
    pub(crate) fn balance(&self, apply: &dyn Fn(&[f64], &mut [f64]), u: &[f64]) -> Balance {
        let d = self.dim();
        let mut au = vec![0.0; d * self.nodes.len()];
        apply(u, &mut au);
        let nodes = BalanceNodes {
            n: self.nodes.len(),
            position: &|i| self.nodes.position(i),
            load: &|k, visit| self.visit_load(k, visit),
            held: &|k| self.held_dofs(k),
        };
        self.balance_on(&nodes, &au)
    }

    /// The balance on `nodes` of the internal forces `au` (`A u`, `d` per node of `nodes`):
    /// [`Problem::balance`] when `nodes` are the scene's; a model may map the scene's loads
    /// and supports onto its own unknowns' nodes (a graded mesh's masters: `P^T f`). The
    /// moments are about the mean position of the scene's nodes.
    pub(crate) fn balance_on(&self, nodes: &BalanceNodes, au: &[f64]) -> Balance {
        let d = self.dim();
        let n = d * nodes.n;
        let frame = self.moment_frame();
        // the moment about the reference point of the forces `f` (d per node) on `loaded`
        let moment_of = |loaded: &mut dyn Iterator<Item = usize>, f: &[f64]| {
            let mut m = moment(d, &[0.0; 3], &[0.0; 3]);
            if frame.reference.is_empty() {
                return m;
            }
            for i in loaded {
                let x = (nodes.position)(i);
                let r: Vec<f64> = (0..d).map(|a| x[a] - frame.reference[a]).collect();
                m.iter_mut().zip(moment(d, &r, &f[d * i..d * i + d])).for_each(|(t, v)| *t += v);
            }
            m
        };
        let mut f = vec![0.0; n];
        let mut loads = Vec::new();
        for (k, l) in self.loads.iter().enumerate() {
            let mut fl = vec![0.0; n];
            let loaded_nodes = (nodes.load)(k, &mut |i, force| (0..d).for_each(|a| fl[d * i + a] += force[a]));
            let force: Vec<f64> = (0..d).map(|a| fl.iter().skip(a).step_by(d).sum()).collect();
            let loaded = &mut (0..nodes.n).filter(|&i| fl[d * i..d * i + d].iter().any(|&x| x != 0.0));
            let moment = moment_of(loaded, &fl);
            f.iter_mut().zip(&fl).for_each(|(t, x)| *t += x);
            let kind = match l {
                Load::Point { .. } => "point",
                Load::Nodal { .. } => "nodal",
                Load::Body { .. } => "body",
                Load::Resultant { .. } => "resultant",
            };
            loads.push(LoadBalance { kind, nodes: loaded_nodes, force, moment });
        }
        let mut held_by = vec![false; n];
        let mut nodal_reaction = vec![0.0; n];
        let mut constraints = Vec::new();
        for k in 0..self.constraints.len() {
            let held = (nodes.held)(k);
            let mut reaction = vec![0.0; d];
            let mut dofs = 0;
            // the reactions' moment about O, one held DOF's force at a time
            let mut about_o = moment(d, &[0.0; 3], &[0.0; 3]);
            for &(node, a) in &held {
                let dof = d * node + a;
                if !held_by[dof] {
                    held_by[dof] = true;
                    dofs += 1;
                    let r = au[dof] - f[dof];
                    reaction[a] += r;
                    nodal_reaction[dof] = r;
                    if !frame.reference.is_empty() {
                        let x = (nodes.position)(node);
                        let arm: Vec<f64> = (0..d).map(|b| x[b] - frame.reference[b]).collect();
                        let mut force = [0.0; 3];
                        force[a] = r;
                        about_o.iter_mut().zip(moment(d, &arm, &force)).for_each(|(t, v)| *t += v);
                    }
                }
            }
            let mut held_nodes: Vec<usize> = held.iter().map(|e| e.0).collect();
            held_nodes.dedup();
            let centroid: Vec<f64> = (0..d)
                .map(|a| {
                    held_nodes.iter().map(|&i| (nodes.position)(i)[a]).sum::<f64>() / held_nodes.len().max(1) as f64
                })
                .collect();
            // about the centroid: the moment about O less the resultant's at the centroid
            let r: Vec<f64> = (0..d).map(|a| centroid[a] - frame.reference.get(a).copied().unwrap_or(0.0)).collect();
            let moment = about_o.iter().zip(moment(d, &r, &reaction)).map(|(a, b)| a - b).collect();
            constraints.push(ConstraintBalance { nodes: held_nodes.len(), dofs, reaction, centroid, moment });
        }
        Balance::from_parts(d, loads, constraints, frame, nodal_reaction)
    }

    /// A rank's share of the force balance of the solution `u` of its window on `model` (its
    /// full operator): the sums over the nodes it owns ([`PartBalance`]), which the ranks add;
    /// moments about `reference` (the ranks' [`Problem::owned_frame`] reduced: the mean position
    /// of all nodes).
    pub fn part_balance(&self, apply: &dyn Fn(&[f64], &mut [f64]), u: &[f64], reference: &[f64]) -> PartBalance {
        let d = self.dim();
        let n = d * self.nodes.len();
        let f = self.load_vector();
        let owned = |dof: usize| self.owns(dof / d);
        // the moment about `reference` of the force `v` along `a` at node `i` (none in 1D)
        let moment_at = |i: usize, a: usize, v: f64| {
            let x = self.nodes.position(i);
            let arm: Vec<f64> = (0..d).map(|b| x[b] - reference.get(b).copied().unwrap_or(0.0)).collect();
            let mut force = [0.0; 3];
            force[a] = v;
            moment(d, &arm, &force[..d])
        };
        let add = |total: &mut Vec<f64>, m: Vec<f64>| total.iter_mut().zip(m).for_each(|(t, v)| *t += v);
        let zero_moment = moment(d, &[0.0; 3], &[0.0; 3]);
        let (mut loads, mut load_moments) = (Vec::new(), Vec::new());
        for k in 0..self.loads.len() {
            let mut fl = vec![0.0; n];
            self.add_load(k, &mut fl);
            let (mut force, mut about) = (vec![0.0; d], zero_moment.clone());
            for dof in (0..n).filter(|&g| owned(g) && fl[g] != 0.0) {
                force[dof % d] += fl[dof];
                add(&mut about, moment_at(dof / d, dof % d, fl[dof]));
            }
            loads.push(force);
            load_moments.push(about);
        }
        let mut au = vec![0.0; n];
        apply(u, &mut au);
        let mut held = vec![false; n];
        let (mut reactions, mut reaction_moments, mut held_dofs) = (Vec::new(), Vec::new(), Vec::new());
        for c in &self.constraints {
            let (mut reaction, mut about, mut dofs) = (vec![0.0; d], zero_moment.clone(), 0);
            for (node, a, _) in c.prescribed(&self.nodes, d) {
                let dof = d * node + a;
                if !held[dof] && owned(dof) {
                    held[dof] = true;
                    reaction[a] += au[dof] - f[dof];
                    add(&mut about, moment_at(node, a, au[dof] - f[dof]));
                    dofs += 1;
                }
            }
            reactions.push(reaction);
            reaction_moments.push(about);
            held_dofs.push(dofs);
        }
        PartBalance { loads, load_moments, reactions, reaction_moments, held_dofs }
    }

    /// `(sum of positions, count, lower corner, upper corner)` of the nodes this rank owns: the
    /// ranks' values reduced give the moments' reference point (the mean position) and the
    /// bounding box whose diagonal scales the moment imbalance, as [`crate::Balance`] has them.
    pub fn owned_frame(&self) -> ([f64; 3], usize, [f64; 3], [f64; 3]) {
        let (mut sum, mut count, mut lo, mut hi) = ([0.0; 3], 0, [f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for i in (0..self.nodes.len()).filter(|&i| self.owns(i)) {
            let x = self.nodes.position(i);
            for a in 0..self.dim() {
                sum[a] += x[a];
                lo[a] = lo[a].min(x[a]);
                hi[a] = hi[a].max(x[a]);
            }
            count += 1;
        }
        (sum, count, lo, hi)
    }

    /// The mean position of the nodes and the diagonal of their bounding box (none in 1D).
    fn moment_frame(&self) -> MomentFrame {
        let (d, n) = (self.dim(), self.nodes.len());
        if d < 2 || n == 0 {
            return MomentFrame::default();
        }
        let (mut lo, mut hi, mut sum) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], [0.0; 3]);
        for i in 0..n {
            let x = self.nodes.position(i);
            for a in 0..d {
                lo[a] = lo[a].min(x[a]);
                hi[a] = hi[a].max(x[a]);
                sum[a] += x[a];
            }
        }
        let diagonal = (0..d).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
        MomentFrame { reference: (0..d).map(|a| sum[a] / n as f64).collect(), diagonal }
    }
}
