//! `linpd study`: a paper study, or the list of them.

use crate::{output, CliError, Reporter, Suspending, UntilClosed};
use linpd_problem::{OutputDir, RunIdentity};
use linpd_studies::{Study, StudyOptions};
use std::path::PathBuf;

/// Runs the study `name` into `out` (default: the study's directory), its table on stdout;
/// `list` prints every study with its description instead. `no_dense` skips the dense-solver
/// timings of blend-speedup; `max_nodes` caps the lattices of multires and penny-sneddon
/// and the meshes of `meshes`; `python` runs `meshes`' mesher and FE reference.
pub(crate) fn study(
    name: String,
    out: Option<PathBuf>,
    no_dense: bool,
    max_nodes: Option<usize>,
    python: String,
) -> Result<(), CliError> {
    if name == "list" {
        for s in Study::all() {
            say!("{:<22} {}", s.name(), s.description())?;
        }
        return Ok(());
    }
    // clap accepted the name, so it is `list` or a study.
    let study = Study::from_name(&name).ok_or_else(|| CliError::UnknownStudy(name.clone()))?;
    let dir = out.unwrap_or_else(|| study.default_out_dir());
    // all of a study's files or none, as for the other commands: staged, then swapped
    // into place with data.json as the main document
    let staged = OutputDir::begin(&dir).map_err(output)?;
    let progress = Reporter::new(false);
    let mut table = Suspending(&progress, UntilClosed(Some(std::io::stdout().lock())));
    study
        .run_with_progress(staged.path(), &StudyOptions { dense: !no_dense, max_nodes, python }, &mut table, &progress)
        .map_err(|source| CliError::Study { name, source })?;
    let identity = RunIdentity::of_inputs(&[]).map_err(output)?;
    staged.commit_staged("data.json", &identity).map_err(output)?;
    say!("wrote {}", dir.display())?;
    Ok(())
}
