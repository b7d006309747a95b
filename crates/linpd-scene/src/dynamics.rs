//! The `dynamics` section of a scene: explicit velocity-Verlet time stepping of
//! `M u'' = -A u + f` (`linpd-dynamics`) on the bond operator of the scene.
//!
//! * Masses are lumped, `M_i = rho V_i` (`V = h^d`, the node volume of the grid).
//! * Constrained DOFs are held at their prescribed values (zero velocity) for the whole run;
//!   bonds to them still act on free neighbours (volume constraints).
//! * Loads are a constant external force (`f . u` enters the potential energy).
//! * The stability limit is `dt_max = 2/sqrt(lambda_max(M_f^-1 A_ff))`. For a homogeneous 1D
//!   bar it is taken as the limit of the infinite lattice, `2/omega_max` (the bar's matrix is a
//!   principal submatrix of a Toeplitz section of the lattice minus a PSD diagonal, so this is a
//!   lower bound of the bar's limit that the bar approaches as it grows); otherwise
//!   `lambda_max` is found by power iteration (sharp, approaches `lambda_max` from below), and
//!   the limit is used with a 1e-3 safety margin.
//!
//! Errors name the JSON path: `dynamics.dt: must be > 0, got 0`.

use crate::raw::{RawDynamics, RawInitial, RawInitialKind};
use crate::ProblemError;
use linpd_core::Point;
use linpd_dynamics::initial::smooth_pulse;
use linpd_dynamics::State;

/// How the time step is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// An explicit `dt`.
    Dt(f64),
    /// `dt = dt_safety * dt_max`.
    Safety(f64),
}

/// The initial displacement (velocities start at zero, except for [`Initial::Data`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Initial {
    /// `u = 0`.
    Rest,
    /// `u = amplitude` on `[from, to]`, 0 elsewhere ((4.14) of the paper).
    SquarePulse {
        /// Left end.
        from: f64,
        /// Right end.
        to: f64,
        /// Height.
        amplitude: f64,
    },
    /// The smooth pulse of section 4.4.1 (degree-21 smoothstep on each side), peak
    /// `amplitude` at `center`, support `[center - width/2, center + width/2]`.
    SmoothPulse {
        /// Peak location.
        center: f64,
        /// Support width.
        width: f64,
        /// Peak height.
        amplitude: f64,
    },
    /// `u = amplitude cos(wavenumber x)`.
    Mode {
        /// `k`.
        wavenumber: f64,
        /// Amplitude.
        amplitude: f64,
    },
    /// User data (any dimension): `u` and `v` over all DOFs, node-major (`dof = d node + a`,
    /// nodes in grid order as in `result.json`), lengths checked against the grid.
    Data {
        /// Initial displacements.
        u: Vec<f64>,
        /// Initial velocities (zero when not given).
        v: Option<Vec<f64>>,
    },
}

impl Initial {
    /// Displacement at `x` (1D; 0 for [`Initial::Data`], which is not a function of `x`).
    pub fn at(&self, x: f64) -> f64 {
        match *self {
            Initial::Data { .. } => 0.0,
            Initial::Rest => 0.0,
            Initial::SquarePulse { from, to, amplitude } => {
                if (from..=to).contains(&x) {
                    amplitude
                } else {
                    0.0
                }
            }
            Initial::SmoothPulse { center, width, amplitude } => {
                amplitude * smooth_pulse(500.0 + (x - center) * 20.0 / width)
            }
            Initial::Mode { wavenumber, amplitude } => amplitude * (wavenumber * x).cos(),
        }
    }

    /// The initial `(u, v)` over all DOFs at the node `positions`, `d` DOFs per node.
    pub fn state(&self, positions: &[Point], d: usize) -> State {
        match self {
            Initial::Data { u, v } => State::new(u.clone(), v.clone().unwrap_or_else(|| vec![0.0; u.len()])),
            _ if d == 1 => State::at_rest(positions.iter().map(|x| self.at(x[0])).collect()),
            _ => State::at_rest(vec![0.0; d * positions.len()]),
        }
    }
}

/// A validated `dynamics` section.
#[derive(Debug, Clone, PartialEq)]
pub struct Dynamics {
    /// The time step.
    pub(crate) step: TimeStep,
    /// Number of steps.
    pub(crate) steps: usize,
    /// Snapshot interval (steps).
    pub(crate) output_every: usize,
    /// Mass density.
    pub(crate) density: f64,
    /// Initial displacement.
    pub(crate) initial: Initial,
    /// Run above the stability limit.
    pub(crate) allow_unstable: bool,
}

impl Dynamics {
    /// The time step.
    pub fn step(&self) -> &TimeStep {
        &self.step
    }
    /// Number of steps.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// Snapshot interval (steps).
    pub fn output_every(&self) -> usize {
        self.output_every
    }
    /// Mass density.
    pub fn density(&self) -> f64 {
        self.density
    }
    /// Initial displacement.
    pub fn initial(&self) -> &Initial {
        &self.initial
    }
    /// Run above the stability limit.
    pub fn allow_unstable(&self) -> bool {
        self.allow_unstable
    }
}

fn positive(path: &str, x: f64) -> Result<f64, ProblemError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(ProblemError::invalid(path, format!("must be > 0, got {x:e}")))
    }
}

/// Most snapshots a run keeps (each is `d n` values in memory until the run ends, for the
/// plots, and a `u_<step>.csv` plus, in 2D/3D, a `u_<step>.vtu` file): 10,000, a frame per 0.01 % of the
/// run, more than any plot or animation shows.
pub const MAX_SNAPSHOTS: usize = 10_000;

/// Most bond updates (`steps x nodes x bonds per node`) a run may ask for: 1e14, i.e. 1.3 to 3.8
/// days at the 3e8-8.6e8 bond updates per second `linpd bench --dynamics` measures (2 cores,
/// docs/benchmarks.md). A runaway guard against `"steps": 1e18`-sized typos, not a policy: any
/// run a session can wait for is far below it.
pub const MAX_BOND_UPDATES: f64 = 1e14;

/// Refuses runs that cannot finish (see [`MAX_BOND_UPDATES`]) or whose snapshots would not fit
/// ([`MAX_SNAPSHOTS`], and their bytes against the available memory) before anything runs.
fn check_run_size(
    steps: usize,
    output_every: usize,
    dim: usize,
    n_nodes: usize,
    horizon_ratio: f64,
) -> Result<(), ProblemError> {
    let per_step = n_nodes as f64 * crate::memory::neighbours(dim, horizon_ratio).max(1.0);
    let work = steps as f64 * per_step;
    if work > MAX_BOND_UPDATES {
        return Err(ProblemError::invalid(
            "dynamics.steps",
            format!(
                "{steps:e} steps x {per_step:e} bond updates per step = {work:e}, more than {MAX_BOND_UPDATES:e} (days at the measured 3e8-8.6e8 bond updates per second): use fewer steps or nodes"
            ),
        ));
    }
    let snapshots = steps / output_every + 1;
    if snapshots > MAX_SNAPSHOTS {
        return Err(ProblemError::invalid(
            "dynamics.output_every",
            format!(
                "{steps} steps every {output_every} gives {snapshots} snapshots (each kept in memory and written as u_<step>.csv and, in 2D/3D, u_<step>.vtu), more than {MAX_SNAPSHOTS}: use output_every >= {}",
                steps.div_ceil(MAX_SNAPSHOTS - 1)
            ),
        ));
    }
    let (what, operator) =
        crate::memory::estimate_nodes(crate::memory::Path::BondDynamics, dim, n_nodes, horizon_ratio);
    let bytes = operator + snapshot_bytes(steps, output_every, dim, n_nodes);
    linpd_core::memory::check(
        format!("{what}, with {snapshots} displacement snapshots"),
        bytes,
        "use a larger output_every, or fewer nodes",
    )
    .map_err(|e| ProblemError::invalid("dynamics.output_every", e.to_string()))
}

/// The bytes of the snapshots a run keeps until it writes them: `steps / output_every + 1`
/// vectors of the DOFs.
pub fn snapshot_bytes(steps: usize, output_every: usize, dim: usize, n_nodes: usize) -> f64 {
    (steps / output_every.max(1) + 1) as f64 * (dim * n_nodes) as f64 * 8.0
}

/// Validates `dynamics` (shape was checked by serde; whether the model has explicit dynamics
/// by its [`Capability::Dynamics`]).
pub(crate) fn validate(
    raw: &RawDynamics,
    dim: usize,
    n_nodes: usize,
    horizon_ratio: f64,
) -> Result<Dynamics, ProblemError> {
    let step = match (raw.dt, raw.dt_safety) {
        (Some(_), Some(_)) => {
            return Err(ProblemError::invalid("dynamics", "give exactly one of dt and dt_safety, got both"))
        }
        (None, None) => {
            return Err(ProblemError::invalid(
                "dynamics",
                "missing the time step: give dt or dt_safety (a fraction of the stability limit)",
            ))
        }
        (Some(dt), None) => TimeStep::Dt(positive("dynamics.dt", dt)?),
        (None, Some(s)) => TimeStep::Safety(positive("dynamics.dt_safety", s)?),
    };
    if raw.steps == 0 {
        return Err(ProblemError::invalid("dynamics.steps", "must be >= 1, got 0"));
    }
    let density = positive("dynamics.density", raw.density)?;
    let output_every = match raw.output_every {
        Some(0) => return Err(ProblemError::invalid("dynamics.output_every", "must be >= 1, got 0")),
        Some(k) => k,
        None => (raw.steps / 10).max(1),
    };
    check_run_size(raw.steps, output_every, dim, n_nodes, horizon_ratio)?;
    let initial = match &raw.initial {
        None => Initial::Rest,
        Some(i) => initial(i, dim, n_nodes)?,
    };
    Ok(Dynamics { step, steps: raw.steps, output_every, density, initial, allow_unstable: raw.allow_unstable })
}

fn initial(i: &RawInitial, dim: usize, n_nodes: usize) -> Result<Initial, ProblemError> {
    let p = "dynamics.initial";
    if i.kind == RawInitialKind::Data {
        return data_initial(i, dim, n_nodes);
    }
    if i.u.is_some() || i.v.is_some() {
        let key = if i.u.is_some() { "u" } else { "v" };
        return Err(ProblemError::invalid(format!("{p}.{key}"), "only a \"data\" initial condition takes u and v"));
    }
    let keys = [
        ("from", i.from),
        ("to", i.to),
        ("center", i.center),
        ("width", i.width),
        ("wavenumber", i.wavenumber),
        ("amplitude", i.amplitude),
    ];
    let (name, allowed): (&str, &[&str]) = match i.kind {
        RawInitialKind::Rest => ("rest", &[]),
        RawInitialKind::SquarePulse => ("square_pulse", &["from", "to", "amplitude"]),
        RawInitialKind::SmoothPulse => ("smooth_pulse", &["center", "width", "amplitude"]),
        RawInitialKind::Mode => ("mode", &["wavenumber", "amplitude"]),
        RawInitialKind::Data => return data_initial(i, dim, n_nodes),
    };
    if let Some((key, _)) = keys.iter().find(|(k, v)| v.is_some() && !allowed.contains(k)) {
        return Err(ProblemError::invalid(format!("{p}.{key}"), format!("not a key of a {name} initial condition")));
    }
    if dim != 1 && i.kind != RawInitialKind::Rest {
        return Err(ProblemError::invalid(
            format!("{p}.type"),
            format!("{name} is a 1D initial condition (dimension is {dim}); use \"rest\" with loads or prescribed constraints"),
        ));
    }
    let need = |key: &str, v: Option<f64>| -> Result<f64, ProblemError> {
        let v =
            v.ok_or_else(|| ProblemError::invalid(format!("{p}.{key}"), format!("missing (required by {name})")))?;
        if !v.is_finite() {
            return Err(ProblemError::invalid(format!("{p}.{key}"), format!("must be finite, got {v:e}")));
        }
        Ok(v)
    };
    let amplitude = match i.amplitude {
        None => 1.0,
        Some(a) => need("amplitude", Some(a))?,
    };
    Ok(match i.kind {
        RawInitialKind::Rest => Initial::Rest,
        RawInitialKind::SquarePulse => {
            let (from, to) = (need("from", i.from)?, need("to", i.to)?);
            if from > to {
                return Err(ProblemError::invalid(
                    format!("{p}.from"),
                    format!("from = {from:e} is greater than to = {to:e}"),
                ));
            }
            Initial::SquarePulse { from, to, amplitude }
        }
        RawInitialKind::SmoothPulse => Initial::SmoothPulse {
            center: need("center", i.center)?,
            width: positive(&format!("{p}.width"), need("width", i.width)?)?,
            amplitude,
        },
        RawInitialKind::Mode => Initial::Mode { wavenumber: need("wavenumber", i.wavenumber)?, amplitude },
        RawInitialKind::Data => return data_initial(i, dim, n_nodes),
    })
}

/// `"initial": {"type": "data", "u": [...], "v": [...]}`: `dim` values per node, node order.
fn data_initial(i: &RawInitial, dim: usize, n_nodes: usize) -> Result<Initial, ProblemError> {
    let p = "dynamics.initial";
    let keys = [
        ("from", i.from),
        ("to", i.to),
        ("center", i.center),
        ("width", i.width),
        ("wavenumber", i.wavenumber),
        ("amplitude", i.amplitude),
    ];
    if let Some((key, _)) = keys.iter().find(|(_, v)| v.is_some()) {
        return Err(ProblemError::invalid(
            format!("{p}.{key}"),
            "not a key of a data initial condition (it takes u and optionally v)",
        ));
    }
    let expected = dim * n_nodes;
    let check = |key: &str, values: &[f64]| -> Result<(), ProblemError> {
        if values.len() != expected {
            return Err(ProblemError::invalid(
                format!("{p}.{key}"),
                format!(
                    "has {} values, expected {expected} = {n_nodes} nodes x {dim} components (node-major, nodes in grid order as in result.json, layers included)",
                    values.len()
                ),
            ));
        }
        if let Some(k) = values.iter().position(|x| !x.is_finite()) {
            return Err(ProblemError::invalid(
                format!("{p}.{key}[{k}]"),
                format!("must be finite, got {:e}", values[k]),
            ));
        }
        // finite values whose squares overflow (v = 1e308): the kinetic and strain energies, and
        // every state of the run, would be infinite, reported only as "the run diverged"
        if !values.iter().map(|x| x * x).sum::<f64>().is_finite() {
            let max = values.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            return Err(ProblemError::invalid(
                format!("{p}.{key}"),
                format!(
                    "values up to {max:e} overflow: the sum of their squares (the {} energy) is not finite; use \
                     smaller units",
                    if key == "v" { "kinetic" } else { "strain" }
                ),
            ));
        }
        Ok(())
    };
    let u = i.u.clone().ok_or_else(|| ProblemError::invalid(format!("{p}.u"), "missing (required by data)"))?;
    check("u", &u)?;
    if let Some(v) = &i.v {
        check("v", v)?;
    }
    Ok(Initial::Data { u, v: i.v.clone() })
}
