//! `linpd export`: the reduced linear system of a static scene, for another solver.

use crate::{input, output, scene_identity, CliError, ExportFormat, Reporter};
use linpd_core::progress::Progress;
use linpd_problem::Commands;
use linpd_problem::{OutputDir, Problem};
use std::path::Path;

/// Writes the reduced system `A_ff u_f = f_f - (A u_bar)_f` of `scene` into `out` in `format`
/// with dofs.csv and export.json; prints the system's size and the files written.
pub(crate) fn export(scene: &Path, out: &Path, format: ExportFormat, quiet: bool) -> Result<(), CliError> {
    let problem = Problem::from_path(scene).map_err(input(scene))?;
    let progress = Reporter::new(quiet);
    let identity = scene_identity(&problem, scene)?;
    let staged = OutputDir::begin(out).map_err(output)?;
    let system = problem.reduced_system(&progress).map_err(input(scene))?;
    let mut doc = system.to_json();
    match format {
        ExportFormat::Mtx => {
            progress.phase(&format!("writing K.mtx ({} entries), f.mtx, dofs.csv", system.nnz()));
            system.write(staged.path()).map_err(output)?;
        }
        ExportFormat::Petsc | ExportFormat::Petsc64 => {
            let int = match format {
                ExportFormat::Petsc64 => linpd_problem::petsc::PetscInt::I64,
                _ => linpd_problem::petsc::PetscInt::I32,
            };
            progress.phase(&format!("writing K.petsc ({} entries), f.petsc, coords.petsc, dofs.csv", system.nnz()));
            // coordinates of the scene's nodes (a blend scene's operator may have others:
            // then no coords.petsc)
            let nodes = problem.nodes();
            let x = (nodes.len() == system.n_nodes).then(|| nodes.positions());
            system.write_petsc(staged.path(), x.as_deref(), int).map_err(output)?;
            doc["format"] = system.petsc_format_json(x.is_some(), int);
            doc["block_size"] = system.block_size().into();
        }
    }
    let files = staged.commit("export.json", doc, &identity).map_err(output)?;
    say!(
        "{}: {} unknowns ({} nodes x {} DOFs, {} constrained), {} stored entries of A_ff ({} model)",
        problem.name(),
        system.n(),
        system.n_nodes,
        system.dim,
        system.dim * system.n_nodes - system.n(),
        system.nnz(),
        system.model
    )?;
    for f in files {
        say!("wrote {}", f.display())?;
    }
    Ok(())
}
