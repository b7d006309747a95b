//! `linpd modes`: a scene's lowest natural frequencies and mode shapes.

use crate::{input, output, scene_identity, CliError, Reporter};
use linpd_problem::{OutputDir, Problem};
use std::path::{Path, PathBuf};

/// Computes the `count` lowest elastic modes of `scene` into `out` (default: the scene's output
/// directory): modes.json (frequencies, the zero modes found) and mode-<k>.vtu (shapes);
/// prints the frequencies and the files written.
pub(crate) fn modes(scene: &Path, count: usize, out: Option<PathBuf>, quiet: bool) -> Result<(), CliError> {
    let problem = Problem::from_path(scene).map_err(input(scene))?;
    let progress = Reporter::new(quiet);
    let identity = scene_identity(&problem, scene)?;
    let staged = OutputDir::begin(&out.unwrap_or_else(|| PathBuf::from(problem.output_dir()))).map_err(output)?;
    let modes = problem.modes(count, &progress).map_err(input(scene))?;
    modes.write(staged.path()).map_err(output)?;
    let files = staged.commit("modes.json", modes.to_json(), &identity).map_err(output)?;
    say!(
        "{}: {} free DOFs, {} zero modes, {} elastic modes, {:.3} s",
        problem.name(),
        modes.unknowns,
        modes.zero_modes.len(),
        modes.modes.len(),
        modes.seconds
    )?;
    for (k, m) in modes.modes.iter().enumerate() {
        say!("mode {}: frequency {:.6e} (omega^2 {:.6e})", k + 1, m.frequency, m.omega2)?;
    }
    for f in files {
        say!("wrote {}", f.display())?;
    }
    Ok(())
}
