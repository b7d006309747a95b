//! Velocity Verlet for `M u'' = -A u + f(t)` (LAMMPS howto, Algorithm 1).
//!
//! # The semi-discrete system
//!
//! `A` is the symmetric positive semi-definite stiffness in force form (`F = -A u`, the
//! convention of `linpd-bond`), `M = diag(M_i)` the lumped mass `M_i = rho V_i` and `f(t)` an
//! external force (force, not force density). Dividing row `i` by `V_i` gives the semi-discrete
//! PD equation of motion (2.3) of Seleson, Parks, Gunzburger & Lehoucq (2009),
//! `rho u_i'' = sum_j kappa(...) V_j + b_i`.
//!
//! # Algorithm 1 (velocity Verlet)
//!
//! With `a^n = M^-1 (f(t^n) - A u^n)`:
//!
//! ```text
//! 1: v^{n+1/2} = v^n + (dt/2) a^n
//! 2: u^{n+1}   = u^n + dt v^{n+1/2}
//! 3: v^{n+1}   = v^{n+1/2} + (dt/2) a^{n+1}
//! ```
//!
//! (Algorithm 1 writes `dt/(2 rho_i)` times the force density; dividing force by `M_i = rho_i
//! V_i` is the same thing.) One operator apply per step; the time loop allocates nothing: `u`,
//! `v` live in the caller's [`State`], `A u`, `a` and `f` in buffers allocated before the loop.
//!
//! # Boundary conditions
//!
//! * **Fixed DOFs** ([`Verlet::with_fixed`]): `u_c` is set to its prescribed value and `v_c = 0`
//!   before the first step, and `a_c = 0` at every step, so they never move. Bonds to them
//!   still act on their free neighbours (a volume constraint).
//! * **Free ends**: no constraint; boundary nodes simply have fewer bonds.
//! * **Periodic ends** (1D): use the periodic operator [`crate::chain::Ring`].
//!
//! # Energy
//!
//! At every output the integrator reports (over all DOFs; fixed DOFs have `v = 0`)
//!
//! ```text
//! E_k = (1/2) v . M v,     E_p = (1/2) u . A u - f . u,
//! E~  = E_k + E_p - (dt^2/8) r . M^-1 r,      r = f - A u  on the free DOFs.
//! ```
//!
//! For constant `f`, `E~` (the "shadow" energy) is conserved *exactly* by velocity Verlet on
//! a linear system (per mode `omega`: `v^2/2 + omega^2 (1 - (omega dt/2)^2) u^2/2` is invariant),
//! while `E_k + E_p` oscillates by `O(dt^2)` around it without drift. Fixed DOFs held at nonzero
//! values act through `A` as a constant load, which does not change this.
//!
//! # Stability
//!
//! A mode of `M^-1 A` with eigenvalue `omega^2` is stable iff `omega dt <= 2` (the quadratic
//! (4.11) of the paper, `zeta^2 - 2(1 - omega^2 dt^2/2) zeta + 1 = 0`, has `|zeta| = 1` iff
//! `omega dt <= 2`), so the limit is `dt_max = 2 / sqrt(lambda_max(M^-1 A))` over the free DOFs.
//! [`Verlet::run`] computes it by the method of [`VerletParams::limit`] and returns
//! [`DynamicsError::Unstable`] when `dt > dt_max`, unless [`VerletParams::allow_unstable`] is set.

use crate::error::{DynamicsError, LimitMethod};
use crate::mass::{check_size, LumpedMass};
use crate::stability::{gershgorin, power_iteration_with_progress, verlet_limit, PowerParams};
use linpd_core::progress::{NoProgress, Progress, Task};
use linpd_core::LinearOperator;
use std::ops::ControlFlow;

/// An external force `f(t)`: called as `force(t, f)` with `f` zeroed, it writes the force
/// (not force density) on every loaded DOF.
pub type Force<'f> = &'f mut dyn FnMut(f64, &mut [f64]);

/// Displacements `u`, velocities `v` and time `t`; advanced in place by [`Verlet::run`].
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Time.
    pub t: f64,
    /// Displacements, one per DOF.
    pub u: Vec<f64>,
    /// Velocities, one per DOF.
    pub v: Vec<f64>,
}

impl State {
    /// `u` at rest (`v = 0`) at `t = 0`.
    pub fn at_rest(u: Vec<f64>) -> Self {
        let v = vec![0.0; u.len()];
        State { t: 0.0, u, v }
    }
    /// `u`, `v` at `t = 0`.
    pub fn new(u: Vec<f64>, v: Vec<f64>) -> Self {
        State { t: 0.0, u, v }
    }
}

/// Energies at one instant (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energy {
    /// `E_k = (1/2) v . M v`.
    pub kinetic: f64,
    /// `E_p = (1/2) u . A u - f . u`.
    pub potential: f64,
    /// `E~ = E_k + E_p - (dt^2/8) r . M^-1 r`, exactly conserved for constant `f`.
    pub shadow: f64,
}

impl Energy {
    /// `E_k + E_p`.
    pub fn total(&self) -> f64 {
        self.kinetic + self.potential
    }
}

/// What the output callback sees.
#[derive(Debug, Clone, Copy)]
pub struct Snapshot<'s> {
    /// Step number (0 = initial state).
    pub step: usize,
    /// Time.
    pub t: f64,
    /// Displacements.
    pub u: &'s [f64],
    /// Velocities.
    pub v: &'s [f64],
    /// Energies.
    pub energy: Energy,
}

/// How [`Verlet::run`] obtains the stability limit.
#[derive(Debug, Clone, PartialEq)]
pub enum DtLimit {
    /// `lambda_max(M^-1 A)` by power iteration: sharp; it approaches `lambda_max` from below,
    /// so the limit it gives is slightly *above* the true one (by its convergence error).
    PowerIteration(PowerParams),
    /// Gershgorin discs: conservative (never above the true limit), needs
    /// [`LinearOperator::abs_row_sums`].
    Gershgorin,
    /// A limit computed by the caller (e.g. [`crate::chain::Ring::dt_limit`]).
    Given(f64),
}

impl Default for DtLimit {
    fn default() -> Self {
        DtLimit::PowerIteration(PowerParams::default())
    }
}

/// Time-stepping parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct VerletParams {
    /// Time step `dt > 0`.
    pub dt: f64,
    /// Number of steps `>= 1`.
    pub steps: usize,
    /// Call the output callback every `output_every` steps (always at step 0 and at the last
    /// step; `0` means only those two).
    pub output_every: usize,
    /// How to compute the stability limit.
    pub limit: DtLimit,
    /// Run even when `dt` exceeds the limit (the limit is then not computed).
    pub allow_unstable: bool,
}

impl VerletParams {
    /// `steps` steps of `dt`, output at the first and last step, limit by power iteration.
    pub fn new(dt: f64, steps: usize) -> Self {
        VerletParams { dt, steps, output_every: 0, limit: DtLimit::default(), allow_unstable: false }
    }
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct VerletInfo {
    /// Steps taken.
    pub steps: usize,
    /// Final time.
    pub t: f64,
    /// The stability limit and how it was obtained (`None` with `allow_unstable`).
    pub dt_limit: Option<(f64, LimitMethod)>,
    /// Energies at step 0.
    pub initial: Energy,
    /// Energies at the last step taken.
    pub last: Energy,
    /// True when the callback stopped the run early.
    pub stopped: bool,
}

/// Velocity Verlet over an operator `A`, lumped masses and fixed DOFs.
#[derive(Debug, Clone)]
pub struct Verlet<'a, A: ?Sized> {
    operator: &'a A,
    mass: LumpedMass,
    inv_m: Vec<f64>,
    fixed: Vec<(usize, f64)>,
    progress: Reporter<'a>,
}

/// Where [`Verlet::run`] reports (a newtype for `Debug`).
#[derive(Clone, Copy)]
struct Reporter<'a>(&'a dyn Progress);

impl std::fmt::Debug for Reporter<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.tracks_tasks() { "Progress" } else { "NoProgress" })
    }
}

impl<'a, A: LinearOperator + ?Sized> Verlet<'a, A> {
    /// The system `M u'' = -A u + f` with every DOF free.
    pub fn new(operator: &'a A, mass: LumpedMass) -> Self {
        let inv_m = mass.masses().iter().map(|m| 1.0 / m).collect();
        Verlet { operator, mass, inv_m, fixed: Vec::new(), progress: Reporter(&NoProgress) }
    }

    /// Reports to `progress` from [`Verlet::run`]: a task `"time steps"` of `params.steps`
    /// steps (updated at most every [`linpd_core::progress::REPORT_INTERVAL`]; the time loop
    /// still allocates nothing between updates), and the power iteration of
    /// [`Verlet::dt_limit`].
    pub fn with_progress(mut self, progress: &'a dyn Progress) -> Self {
        self.progress = Reporter(progress);
        self
    }

    /// Holds DOF `dof` at `value` (zero velocity) for every `(dof, value)`.
    pub fn with_fixed(mut self, fixed: &[(usize, f64)]) -> Result<Self, DynamicsError> {
        let n = self.n();
        if let Some(&(dof, value)) = fixed.iter().find(|(d, v)| *d >= n || !v.is_finite()) {
            return Err(DynamicsError::FixedDof { dof, value, n });
        }
        self.fixed = fixed.to_vec();
        Ok(self)
    }

    /// Number of DOFs.
    pub fn n(&self) -> usize {
        self.mass.len()
    }
    /// The masses.
    pub fn mass(&self) -> &LumpedMass {
        &self.mass
    }
    /// Fixed DOFs and their values.
    pub fn fixed(&self) -> &[(usize, f64)] {
        &self.fixed
    }
    fn fixed_dofs(&self) -> Vec<usize> {
        self.fixed.iter().map(|p| p.0).collect()
    }

    /// The stability limit `2 / sqrt(lambda_max(M^-1 A))` over the free DOFs.
    pub fn dt_limit(&self, how: &DtLimit) -> Result<(f64, LimitMethod), DynamicsError> {
        let fixed = self.fixed_dofs();
        Ok(match how {
            DtLimit::PowerIteration(p) => {
                let info = power_iteration_with_progress(self.operator, &self.mass, &fixed, p, self.progress.0)?;
                (verlet_limit(info.lambda), LimitMethod::PowerIteration)
            }
            DtLimit::Gershgorin => {
                (verlet_limit(gershgorin(self.operator, &self.mass, &fixed)?), LimitMethod::Gershgorin)
            }
            DtLimit::Given(l) => {
                if !(l.is_finite() && *l > 0.0) && *l != f64::INFINITY {
                    return Err(DynamicsError::param("limit", format!("a given limit must be > 0, got {l:e}")));
                }
                (*l, LimitMethod::Given)
            }
        })
    }

    /// `a = M^-1 (f - A u)` on free DOFs, `0` on fixed ones.
    #[inline]
    fn acceleration(&self, f: Option<&[f64]>, au: &[f64], acc: &mut [f64]) {
        match f {
            Some(f) => {
                for i in 0..acc.len() {
                    acc[i] = (f[i] - au[i]) * self.inv_m[i];
                }
            }
            None => {
                for i in 0..acc.len() {
                    acc[i] = -au[i] * self.inv_m[i];
                }
            }
        }
        for &(d, _) in &self.fixed {
            acc[d] = 0.0;
        }
    }

    #[inline]
    fn energy_of(&self, u: &[f64], v: &[f64], au: &[f64], f: Option<&[f64]>, acc: &[f64], dt: f64) -> Energy {
        let m = self.mass.masses();
        let mut ek = 0.0;
        let mut uau = 0.0;
        let mut rr = 0.0;
        for i in 0..u.len() {
            ek += m[i] * v[i] * v[i];
            uau += u[i] * au[i];
            rr += m[i] * acc[i] * acc[i];
        }
        let fu: f64 = f.map_or(0.0, |f| f.iter().zip(u).map(|(a, b)| a * b).sum());
        let kinetic = 0.5 * ek;
        let potential = 0.5 * uau - fu;
        Energy { kinetic, potential, shadow: kinetic + potential - dt * dt / 8.0 * rr }
    }

    /// Energies of a state (allocates one work vector; `f` is the external force or `None`).
    pub fn energy(&self, u: &[f64], v: &[f64], f: Option<&[f64]>, dt: f64) -> Energy {
        let mut au = vec![0.0; u.len()];
        let mut acc = vec![0.0; u.len()];
        self.operator.apply(u, &mut au);
        self.acceleration(f, &au, &mut acc);
        self.energy_of(u, v, &au, f, &acc, dt)
    }

    /// Advances `state` by `params.steps` steps of `params.dt` (Algorithm 1).
    ///
    /// `force`, if given, is called as `force(t, f)` with `f` zeroed and must write the
    /// external force at time `t` (it is called once per step, at the new time). `output` sees
    /// the state at step 0, every `params.output_every` steps and at the last step, and may stop
    /// the run with `ControlFlow::Break(())`.
    ///
    /// Errors: [`DynamicsError::TimeStep`], [`DynamicsError::NoSteps`],
    /// [`DynamicsError::Length`] (state or masses vs operator), [`DynamicsError::Unstable`]
    /// (before any step), and
    /// [`DynamicsError::Diverged`] as soon as the velocities (checked every step) or the energy
    /// (checked at outputs) stop being finite; `state` then holds the overflowed values.
    pub fn run(
        &self,
        state: &mut State,
        params: &VerletParams,
        mut force: Option<Force<'_>>,
        mut output: impl FnMut(&Snapshot<'_>) -> ControlFlow<()>,
    ) -> Result<VerletInfo, DynamicsError> {
        let dt = params.dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(DynamicsError::TimeStep(dt));
        }
        if params.steps == 0 {
            return Err(DynamicsError::NoSteps);
        }
        let n = self.n();
        check_size(self.operator, n)?;
        for (what, len) in [("u", state.u.len()), ("v", state.v.len())] {
            if len != n {
                return Err(DynamicsError::Length { what, expected: n, got: len });
            }
        }
        if !state.t.is_finite() {
            return Err(DynamicsError::param("t", format!("initial time must be finite, got {:e}", state.t)));
        }
        let dt_limit = if params.allow_unstable { None } else { Some(self.dt_limit(&params.limit)?) };
        if let Some((limit, method)) = dt_limit {
            if dt > limit {
                return Err(DynamicsError::Unstable { dt, limit, method });
            }
        }

        // Every buffer of the time loop, allocated once.
        let mut f = vec![0.0; if force.is_some() { n } else { 0 }];
        let mut au = vec![0.0; n];
        let mut acc = vec![0.0; n];

        let State { t: t_state, u, v } = state;
        for &(d, value) in &self.fixed {
            u[d] = value;
            v[d] = 0.0;
        }
        let t0 = *t_state;
        if let Some(g) = force.as_mut() {
            g(t0, &mut f);
        }
        self.operator.apply(u, &mut au);
        self.acceleration(fo(&f), &au, &mut acc);
        let initial = self.energy_of(u, v, &au, fo(&f), &acc, dt);
        if !initial.total().is_finite() {
            return Err(DynamicsError::Diverged { step: 0, t: t0 });
        }
        let task = Task::start(self.progress.0, "time steps", Some(params.steps as u64));
        let mut last = initial;
        let mut stopped = output(&Snapshot { step: 0, t: t0, u: &u[..], v: &v[..], energy: initial }).is_break();
        let mut taken = 0;
        let half = 0.5 * dt;
        while !stopped && taken < params.steps {
            let step = taken + 1;
            // 1 and 2: half kick, drift.
            for i in 0..n {
                v[i] += half * acc[i];
                u[i] += dt * v[i];
            }
            let t = t0 + step as f64 * dt;
            if let Some(g) = force.as_mut() {
                f.iter_mut().for_each(|x| *x = 0.0);
                g(t, &mut f);
            }
            self.operator.apply(u, &mut au);
            self.acceleration(fo(&f), &au, &mut acc);
            // 3: half kick; sum |v| on the way, so a blow-up is caught at the step it overflows.
            let mut v_abs = 0.0;
            for i in 0..n {
                v[i] += half * acc[i];
                v_abs += v[i].abs();
            }
            taken = step;
            *t_state = t;
            if task.due() {
                task.set(step as u64, "");
            }
            if !v_abs.is_finite() {
                return Err(DynamicsError::Diverged { step, t });
            }
            let due = step == params.steps || (params.output_every > 0 && step % params.output_every == 0);
            if due {
                last = self.energy_of(u, v, &au, fo(&f), &acc, dt);
                if !last.total().is_finite() {
                    return Err(DynamicsError::Diverged { step, t });
                }
                stopped = output(&Snapshot { step, t, u: &u[..], v: &v[..], energy: last }).is_break();
            }
        }
        task.set(taken as u64, "");
        Ok(VerletInfo { steps: taken, t: *t_state, dt_limit, initial, last, stopped: stopped && taken < params.steps })
    }
}

/// `None` for the empty buffer that stands for "no external force".
#[inline]
fn fo(f: &[f64]) -> Option<&[f64]> {
    (!f.is_empty()).then_some(f)
}
