//! `linpd run`: a scene's explicit dynamics, its history, snapshots and plots.

use crate::{input, output, scene_identity, CliError, Reporter};
use linpd_problem::Commands;
use linpd_problem::{OutputDir, Problem};
use std::path::{Path, PathBuf};

/// Runs the explicit dynamics of `scene` into `out` (default: the scene's output directory);
/// writes history.json, the snapshots and the plots; prints the run's summary (time step,
/// throughput, energy drifts) and, unless `quiet`, what was written.
pub(crate) fn run(scene: &Path, out: Option<PathBuf>, quiet: bool) -> Result<(), CliError> {
    let problem = Problem::from_path(scene).map_err(input(scene))?;
    let progress = Reporter::new(quiet);
    let identity = scene_identity(&problem, scene)?;
    let staged = OutputDir::begin(&out.unwrap_or_else(|| PathBuf::from(problem.output_dir()))).map_err(output)?;
    let run = problem.run_dynamics(&progress).map_err(input(scene))?;
    run.write(staged.path()).map_err(output)?;
    if problem.plot() {
        crate::plots::dynamics_plots(&run, staged.path())?;
    }
    let dir = staged.target().to_path_buf();
    let files = staged.commit("history.json", run.history_json(), &identity).map_err(output)?;
    say!(
        "{}: {} steps of dt = {:.4e} ({:.4} of dt_max = {:.4e}, estimated in {:.3} s), {} DOFs ({} held), {} bonds; {:.3} s: {:.3e} steps/s, {:.3e} bond updates/s; relative to E_ref = {:.4e}: E_k + E_p oscillates by {:.2e} (O(dt^2), bounded), shadow energy drift {:.2e}",
        run.name,
        run.steps,
        run.dt,
        run.dt / run.limit.dt,
        run.limit.dt,
        run.limit.seconds,
        run.n_dofs,
        run.n_fixed,
        run.n_bonds,
        run.wall_seconds,
        run.steps_per_second(),
        run.bond_updates_per_second(),
        run.energy_scale(),
        run.max_total_drift(),
        run.max_shadow_drift(),
    )?;
    if !quiet {
        say!("wrote {} files into {} (history.json, {} snapshots)", files.len(), dir.display(), run.snapshots.len())?;
    }
    Ok(())
}
