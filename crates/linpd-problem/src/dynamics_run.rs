//! `linpd run`: explicit velocity-Verlet time stepping of a scene's `dynamics` section
//! ([`crate::dynamics`]) on its bond operator: the stability limit, the run, its history and
//! snapshots.

use crate::capability::Capability;
use crate::dynamics::{Dynamics, TimeStep};
use crate::scene::{DynamicsOperator, Problem};
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_core::Point;
use linpd_dynamics::stability::{lattice_limit, power_iteration_with_progress, verlet_limit, PowerParams};
use linpd_dynamics::{DtLimit, DynamicsError, Energy, LumpedMass, Verlet, VerletParams};
use serde_json::json;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The stability limit of a scene and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct StabilityLimit {
    /// `dt_max`.
    pub dt: f64,
    /// How it was computed.
    pub method: String,
    /// Seconds spent computing it (a power iteration on a large 2D/3D scene takes seconds to
    /// minutes; part of the run's setup time).
    pub seconds: f64,
}

/// The result of `linpd run`: energies at every output, displacement snapshots, throughput.
#[derive(Debug, Clone)]
pub struct DynamicsRun {
    /// Scene name.
    pub name: String,
    /// Dimension.
    pub dim: usize,
    /// Node positions.
    pub x: Vec<Point>,
    /// True for nodes of the outer layer.
    pub is_layer: Vec<bool>,
    /// Time step used.
    pub dt: f64,
    /// The stability limit.
    pub limit: StabilityLimit,
    /// Steps taken.
    pub steps: usize,
    /// Snapshot interval.
    pub output_every: usize,
    /// Bonds (each pair counted from both ends).
    pub n_bonds: usize,
    /// DOFs, of which `n_fixed` are held.
    pub n_dofs: usize,
    /// Held DOFs.
    pub n_fixed: usize,
    /// Step number of every output.
    pub output_steps: Vec<usize>,
    /// Time of every output.
    pub times: Vec<f64>,
    /// Energies at every output.
    pub energies: Vec<Energy>,
    /// Displacements (all DOFs) at every output.
    pub snapshots: Vec<Vec<f64>>,
    /// Wall time of the time loop (seconds, outputs included).
    pub wall_seconds: f64,
    /// Wall time of the set-up (operator, limit).
    pub setup_seconds: f64,
    /// The memory guard's estimate of the run's peak (operator, vectors, snapshots).
    pub memory_estimate_bytes: f64,
    /// The measured peak resident memory (`None` where the OS does not say).
    pub peak_rss_bytes: Option<u64>,
}

impl DynamicsRun {
    /// Time steps per second of wall time.
    pub fn steps_per_second(&self) -> f64 {
        self.steps as f64 / self.wall_seconds
    }
    /// Bond updates (one per bond end per step) per second.
    pub fn bond_updates_per_second(&self) -> f64 {
        self.steps as f64 * self.n_bonds as f64 / self.wall_seconds
    }
    /// The energy scale the drifts are relative to: the largest energy the run holds,
    ///
    /// ```text
    /// E_ref = max( |E_0|, max_n E_k,n, max_n |E_p,n| ).
    /// ```
    ///
    /// Not `|E_0|` alone: a run from rest under a constant load starts at `E_0 = 0` (no motion,
    /// no strain) and `|E_n - E_0| / |E_0|` is `inf` (until 2026-11 it was, and `null` in
    /// history.json). For a free wave `E_ref = E_0` up to the `O(dt^2)` oscillation of `E_k + E_p`.
    /// `E_ref = 0` only when nothing moves; then the drifts are 0.
    pub fn energy_scale(&self) -> f64 {
        let e0 = self.energies[0].total().abs();
        self.energies.iter().fold(e0, |m, e| m.max(e.kinetic).max(e.potential.abs()))
    }
    /// `(x_n - x_0) / E_ref` for every output ([`DynamicsRun::energy_scale`]).
    fn relative(&self, x: impl Fn(&linpd_dynamics::Energy) -> f64) -> Vec<f64> {
        let scale = self.energy_scale();
        let x0 = x(&self.energies[0]);
        self.energies.iter().map(|e| if scale > 0.0 { (x(e) - x0) / scale } else { 0.0 }).collect()
    }
    /// `max_n |E_n - E_0| / E_ref` of `E = E_k + E_p`: velocity Verlet makes it oscillate by
    /// `O(dt^2)` without drift, so this is an oscillation amplitude, not an error that grows.
    pub fn max_total_drift(&self) -> f64 {
        self.relative(|e| e.total()).iter().fold(0.0, |m, d| m.max(d.abs()))
    }
    /// `max_n |E~_n - E~_0| / E_ref` of the shadow energy (conserved to round-off).
    pub fn max_shadow_drift(&self) -> f64 {
        self.relative(|e| e.shadow).iter().fold(0.0, |m, d| m.max(d.abs()))
    }

    /// The `history.json` document.
    pub fn history_json(&self) -> serde_json::Value {
        json!({
            "name": self.name,
            "dimension": self.dim,
            "dt": self.dt,
            "dt_limit": self.limit.dt,
            "dt_limit_method": self.limit.method,
            "dt_limit_seconds": self.limit.seconds,
            "steps": self.steps,
            "output_every": self.output_every,
            "nodes": self.x.len(),
            "dofs": self.n_dofs,
            "fixed_dofs": self.n_fixed,
            "bonds": self.n_bonds,
            "step": self.output_steps,
            "times": self.times,
            "energies": {
                "kinetic": self.energies.iter().map(|e| e.kinetic).collect::<Vec<_>>(),
                "potential": self.energies.iter().map(|e| e.potential).collect::<Vec<_>>(),
                "total": self.energies.iter().map(|e| e.total()).collect::<Vec<_>>(),
                "shadow": self.energies.iter().map(|e| e.shadow).collect::<Vec<_>>(),
                "scale": self.energy_scale(),
                "drift": self.relative(|e| e.total()),
                "shadow_drift": self.relative(|e| e.shadow),
            },
            "stats": {
                "wall_seconds": self.wall_seconds,
                "setup_seconds": self.setup_seconds,
                "steps_per_second": self.steps_per_second(),
                "bond_updates_per_second": self.bond_updates_per_second(),
                "max_total_drift": self.max_total_drift(),
                "max_shadow_drift": self.max_shadow_drift(),
                "memory_estimate_bytes": self.memory_estimate_bytes,
                "peak_rss_bytes": self.peak_rss_bytes,
            }
        })
    }

    /// Writes `u_<step>.csv` (step zero-padded) into `dir` (created if missing), and in 2D/3D
    /// also `u_<step>.vtu` ([`DynamicsRun::write_vtu`]) and the ParaView collection
    /// `snapshots.pvd` listing them with their times; returns the paths. `history.json`
    /// ([`DynamicsRun::history_json`]) is written by [`crate::OutputDir::commit`].
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ProblemError> {
        let io = |path: &Path| {
            let path = path.display().to_string();
            move |source| ProblemError::Io { path, source }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let mut files = Vec::new();
        let width = self.steps.to_string().len();
        let d = self.dim;
        let header = ["x,u,layer", "x,y,u,v,layer", "x,y,z,u,v,w,layer"][d - 1];
        for (step, u) in self.output_steps.iter().zip(&self.snapshots) {
            let path = dir.join(format!("u_{step:0width$}.csv"));
            let mut w = std::io::BufWriter::new(std::fs::File::create(&path).map_err(io(&path))?);
            writeln!(w, "{header}").map_err(io(&path))?;
            for (k, x) in self.x.iter().enumerate() {
                let mut row: Vec<String> = (0..d).map(|a| format!("{:.17e}", x[a])).collect();
                row.extend((0..d).map(|a| format!("{:.17e}", u[d * k + a])));
                row.push((self.is_layer[k] as u8).to_string());
                writeln!(w, "{}", row.join(",")).map_err(io(&path))?;
            }
            w.flush().map_err(io(&path))?;
            files.push(path);
        }
        if d >= 2 {
            let mut datasets = Vec::new();
            for (i, step) in self.output_steps.iter().enumerate() {
                let name = format!("u_{step:0width$}.vtu");
                let path = dir.join(&name);
                self.write_vtu(i, &path)?;
                files.push(path);
                datasets.push((self.times[i], name));
            }
            let path = dir.join("snapshots.pvd");
            linpd_io::vtk::write_pvd(&path, &datasets)?;
            files.push(path);
        }
        Ok(files)
    }

    /// Writes snapshot `i` as VTK XML `UnstructuredGrid` ([`linpd_io::vtk::write_vtu`], the
    /// writer of `result.vtu`): one vertex cell per node (`z = 0` in 2D), point data `u` (3
    /// components, 0-padded in 2D) and `layer` (0/1).
    pub fn write_vtu(&self, i: usize, path: &Path) -> Result<(), ProblemError> {
        use linpd_io::vtk::{PointArray, PointValues};
        let (d, u) = (self.dim, &self.snapshots[i]);
        let disp = |k: usize, a: usize| if a < d { u[d * k + a] } else { 0.0 };
        let layer = |k: usize| self.is_layer[k] as u8;
        let arrays = [
            PointArray { name: "u", values: PointValues::Float64 { components: 3, value: &disp } },
            PointArray { name: "layer", values: PointValues::UInt8(&layer) },
        ];
        Ok(linpd_io::vtk::write_vtu(path, d, &self.x, &arrays)?)
    }
}

fn dynamics_section(p: &Problem) -> Result<&Dynamics, ProblemError> {
    p.dynamics().ok_or_else(|| {
        ProblemError::invalid("dynamics", "missing: this scene has no \"dynamics\" section (dt or dt_safety, steps, density); `linpd solve` solves it statically")
    })
}

/// The velocity-Verlet stability limit of the scene (see the module docs).
pub fn stability_limit(p: &Problem) -> Result<StabilityLimit, ProblemError> {
    let dynamics = dynamics_section(p)?;
    let op = p.model().dynamics_operator(p)?;
    limit_of(p, &op, dynamics, &linpd_core::NoProgress)
}

fn mass(p: &Problem, rho: f64) -> Result<LumpedMass, ProblemError> {
    let grid = p.lattice()?;
    let d = p.dim();
    let volumes: Vec<f64> = (0..d * grid.len()).map(|k| grid.node_volume(k / d)).collect();
    LumpedMass::new(rho, &volumes).map_err(|e| ProblemError::invalid("dynamics.density", e.to_string()))
}

fn fixed(p: &Problem) -> Vec<(usize, f64)> {
    let (mask, ubar) = p.constrained();
    mask.iter().enumerate().filter(|(_, m)| **m).map(|(i, _)| (i, ubar[i])).collect()
}

fn limit_of(
    p: &Problem,
    operator: &DynamicsOperator,
    dynamics: &Dynamics,
    progress: &dyn Progress,
) -> Result<StabilityLimit, ProblemError> {
    let t0 = Instant::now();
    let rho = dynamics.density();
    if let Some(chain) = &operator.chain {
        let l = lattice_limit(chain, rho);
        return Ok(StabilityLimit {
            dt: l.dt,
            method: "2/omega_max of the infinite lattice (exact; a lower bound for the bar)".into(),
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    let mass = mass(p, rho)?;
    let fixed: Vec<usize> = fixed(p).iter().map(|p| p.0).collect();
    let info = power_iteration_with_progress(
        &operator.op,
        &mass,
        &fixed,
        &PowerParams { max_iter: 5000, rtol: 1e-10, ..Default::default() },
        progress,
    )
    .map_err(|e| ProblemError::invalid("dynamics", e.to_string()))?;
    Ok(StabilityLimit {
        dt: verlet_limit(info.lambda) * (1.0 - 1e-3),
        method: format!("2/sqrt(lambda_max) by power iteration ({} iterations), less 0.1%", info.iterations),
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Runs the `dynamics` section. `progress` receives one line per phase and the tasks of the
/// stable-time-step estimate (power iteration, 2D/3D) and of the time steps.
pub fn run_dynamics(p: &Problem, progress: &dyn Progress) -> Result<DynamicsRun, ProblemError> {
    let dynamics = dynamics_section(p)?;
    p.model().require(Capability::Dynamics)?;
    let t0 = Instant::now();
    let d = p.dim();
    let grid = p.lattice()?;
    let n_nodes = grid.len();
    progress.phase(&format!(
        "building bonds: {n_nodes} nodes, horizon/spacing = {:.3}",
        p.model().horizon().unwrap_or(f64::NAN) / grid.spacing()
    ));
    let operator = p.model().dynamics_operator(p)?;
    let op = &operator.op;
    progress.phase(&format!(
        "estimating the stable time step ({} free DOFs)",
        d * n_nodes - p.constrained().0.iter().filter(|m| **m).count()
    ));
    let limit = limit_of(p, &operator, dynamics, progress)?;
    let dt = match *dynamics.step() {
        TimeStep::Dt(dt) => dt,
        TimeStep::Safety(s) => s * limit.dt,
    };
    if dt > limit.dt && !dynamics.allow_unstable() {
        let path = match *dynamics.step() {
            TimeStep::Dt(_) => "dynamics.dt",
            TimeStep::Safety(_) => "dynamics.dt_safety",
        };
        return Err(ProblemError::invalid(
            path,
            format!(
                "dt = {dt:e} exceeds the velocity-Verlet stability limit dt_max = {:e} ({}); use dt <= {:e}, dt_safety <= 1, or set \"allow_unstable\": true",
                limit.dt, limit.method, limit.dt
            ),
        ));
    }
    progress.phase(&format!(
        "dt = {dt:.6e} = {:.4} dt_max (dt_max = {:.6e}, {}; {:.3} s)",
        dt / limit.dt,
        limit.dt,
        limit.method,
        limit.seconds
    ));
    let fixed = fixed(p);
    let mass = mass(p, dynamics.density())?;
    let verlet = Verlet::new(op, mass)
        .with_progress(progress)
        .with_fixed(&fixed)
        .map_err(|e| ProblemError::invalid("constraints", e.to_string()))?;
    let positions = op.positions().to_vec();
    let load = p.load_vector();
    let loaded = load.iter().any(|f| *f != 0.0);
    let params = VerletParams {
        dt,
        steps: dynamics.steps(),
        output_every: dynamics.output_every(),
        limit: DtLimit::Given(limit.dt),
        allow_unstable: dynamics.allow_unstable(),
    };
    let mut state = dynamics.initial().state(&positions, d);
    let (mut output_steps, mut times, mut energies, mut snapshots) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let setup_seconds = t0.elapsed().as_secs_f64();
    progress.phase(&format!(
        "running {} steps ({} DOFs, {} held, {} bonds)",
        dynamics.steps(),
        d * n_nodes,
        fixed.len(),
        op.family().n_bonds()
    ));
    let t1 = Instant::now();
    let mut force = |_t: f64, f: &mut [f64]| f.copy_from_slice(&load);
    let info = verlet
        .run(&mut state, &params, if loaded { Some(&mut force) } else { None }, |s| {
            output_steps.push(s.step);
            times.push(s.t);
            energies.push(s.energy);
            snapshots.push(s.u.to_vec());
            ControlFlow::Continue(())
        })
        .map_err(|e| match e {
            // finite initial values whose forces or energies overflow (an amplitude of 1e308 with
            // a stiffness above 1): the initial condition's scale, not a divergence of the run
            DynamicsError::Diverged { step: 0, .. } => ProblemError::invalid(
                "dynamics.initial",
                "the initial state's forces or energies overflow (K u or the sum of squares is not finite): \
                 use a smaller amplitude or smaller units",
            ),
            e => ProblemError::Dynamics(e),
        })?;
    let wall_seconds = t1.elapsed().as_secs_f64();
    progress.phase(&format!("done: t = {:.6e} in {wall_seconds:.3} s", info.t));
    Ok(DynamicsRun {
        name: p.name().to_string(),
        dim: d,
        x: positions,
        is_layer: (0..n_nodes).map(|k| grid.is_layer(k)).collect(),
        dt,
        limit,
        steps: info.steps,
        output_every: dynamics.output_every(),
        n_bonds: op.family().n_bonds(),
        n_dofs: d * n_nodes,
        n_fixed: fixed.len(),
        output_steps,
        times,
        energies,
        snapshots,
        wall_seconds,
        setup_seconds,
        memory_estimate_bytes: memory_estimate(d, n_nodes, dynamics, op.family().n_bonds()),
        peak_rss_bytes: linpd_solve::peak_rss_bytes(),
    })
}

/// The memory guard's estimate of a run ([`crate::memory::Path::BondDynamics`] with the real
/// bond count, and the snapshots).
fn memory_estimate(d: usize, n_nodes: usize, dynamics: &Dynamics, bonds: usize) -> f64 {
    let nb = bonds as f64 / n_nodes.max(1) as f64;
    let (_, operator) = crate::memory::estimate_counts(crate::memory::Path::BondDynamics, d, n_nodes, nb, 1.0);
    operator + crate::dynamics::snapshot_bytes(dynamics.steps(), dynamics.output_every(), d, n_nodes)
}

#[cfg(test)]
mod tests {
    use crate::{Commands, Problem};
    use serde_json::{json, Value};

    /// 5 x 5 nodes (h = 0.1, no layer), delta = 3h, plane strain, no constraints.
    fn scene(initial: Value) -> Value {
        json!({
            "name": "tiny-2d",
            "dimension": 2,
            "grid": {"min": [0.0, 0.0], "max": [0.4, 0.4], "spacing": 0.1},
            "model": {"type": "bond", "horizon": 0.3, "plane": "strain", "partial_volume": false,
                      "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "discrete"}},
            "dynamics": {"dt_safety": 0.5, "steps": 4, "output_every": 2, "density": 1.0, "initial": initial}
        })
    }

    fn error_of(v: &Value) -> String {
        match Problem::from_json(&v.to_string()) {
            Ok(_) => "ok".into(),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn data_initial_fields_set_u_and_v() {
        let n = 25;
        let u: Vec<f64> = (0..2 * n).map(|k| 1e-3 * (k as f64).sin()).collect();
        let p = Problem::from_json(&scene(json!({"type": "data", "u": u})).to_string()).unwrap();
        let r = p.run_dynamics(&linpd_core::NoProgress).unwrap();
        // serde_json's default float parsing may be off by an ulp.
        assert!(r.snapshots[0].iter().zip(&u).all(|(a, b)| (a - b).abs() <= 1e-15 * b.abs()), "step 0 is the data");
        assert!(r.energies[0].potential > 0.0);
        // A uniform velocity translates the free body rigidly: u = v t exactly.
        let v: Vec<f64> = (0..2 * n).map(|k| if k % 2 == 0 { 0.5 } else { -0.25 }).collect();
        let p = Problem::from_json(&scene(json!({"type": "data", "u": vec![0.0; 2 * n], "v": v})).to_string()).unwrap();
        let r = p.run_dynamics(&linpd_core::NoProgress).unwrap();
        let (t, last) = (*r.times.last().unwrap(), r.snapshots.last().unwrap());
        for (k, x) in last.iter().enumerate() {
            assert!((x - v[k] * t).abs() < 1e-12, "dof {k}: {x} vs {}", v[k] * t);
        }
    }

    #[test]
    fn data_initial_errors_name_the_path() {
        let cases = [
            (
                json!({"type": "data", "u": vec![0.0; 49]}),
                "dynamics.initial.u: has 49 values, expected 50 = 25 nodes x 2 components",
            ),
            (
                json!({"type": "data", "u": vec![0.0; 50], "v": vec![0.0; 75]}),
                "dynamics.initial.v: has 75 values, expected 50",
            ),
            (json!({"type": "data", "v": vec![0.0; 50]}), "dynamics.initial.u: missing"),
            (
                json!({"type": "data", "u": vec![0.0; 50], "amplitude": 2.0}),
                "dynamics.initial.amplitude: not a key of a data initial condition",
            ),
            (
                json!({"type": "rest", "u": vec![0.0; 50]}),
                "dynamics.initial.u: only a \"data\" initial condition takes u and v",
            ),
            (json!({"type": "data", "u": "abc"}), "dynamics.initial.u"),
        ];
        for (initial, needle) in cases {
            let msg = error_of(&scene(initial));
            assert!(msg.contains(needle), "{msg:?} lacks {needle:?}");
        }
    }

    /// 2D runs write `u_<step>.vtu` (the writer of `result.vtu`; meshio opens them in
    /// `tests/fields_out.rs`) and `snapshots.pvd` listing them with their times; no legacy
    /// `.vtk`.
    #[test]
    fn two_dimensional_runs_write_vtu_snapshots_and_a_collection() {
        let u: Vec<f64> = (0..50).map(|k| 1e-3 * k as f64).collect();
        let p = Problem::from_json(&scene(json!({"type": "data", "u": u})).to_string()).unwrap();
        let r = p.run_dynamics(&linpd_core::NoProgress).unwrap();
        let dir = std::env::temp_dir().join(format!("linpd-vtu-test-{}", std::process::id()));
        let files = r.write(&dir).unwrap();
        let ext = |e: &str| files.iter().filter(|f| f.extension().is_some_and(|x| x == e)).count();
        assert_eq!((ext("vtu"), ext("pvd"), ext("vtk"), ext("csv")), (3, 1, 0, 3), "steps 0, 2, 4: {files:?}");
        let text = std::fs::read_to_string(dir.join("u_0.vtu")).unwrap();
        assert!(text.contains(r#"<Piece NumberOfPoints="25" NumberOfCells="25">"#));
        assert!(text.contains(r#"Name="u" NumberOfComponents="3""#) && text.contains(r#"Name="layer""#));
        let pvd = std::fs::read_to_string(dir.join("snapshots.pvd")).unwrap();
        assert!(pvd.contains(r#"<VTKFile type="Collection""#));
        for (i, step) in [0, 2, 4].iter().enumerate() {
            let t = format!("{:.16e}", r.times[i]);
            assert!(pvd.contains(&format!(r#"timestep="{t}" group="" part="0" file="u_{step}.vtu""#)), "{pvd}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
