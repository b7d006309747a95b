//! `linpd coarsen`: a pipeline's coarsening levels and their table.

use crate::{input, output, CliError, Reporter};
use linpd_problem::{OutputDir, RunIdentity};
use std::path::{Path, PathBuf};

/// Runs the coarsening pipeline `pipeline` into `out` (default: the pipeline's output
/// directory); prints a table of the levels (nodes, bonds, radius, tail, classes, hit rate,
/// error at the shared nodes).
pub(crate) fn coarsen(pipeline: &Path, out: Option<PathBuf>, quiet: bool) -> Result<(), CliError> {
    let p = linpd_problem::Pipeline::from_path(pipeline).map_err(input(pipeline))?;
    let progress = Reporter::new(quiet);
    let identity = RunIdentity::of_inputs(&[pipeline, &p.scene_path]).map_err(input(pipeline))?;
    let staged = OutputDir::begin(&out.unwrap_or_else(|| p.output_dir.clone())).map_err(output)?;
    let r = p.run(staged.path(), &progress).map_err(input(pipeline))?;
    let dir = staged.target().to_path_buf();
    staged.commit("summary.json", r.summary_json(), &identity).map_err(output)?;
    say!("{}: {} levels coarsened in {:.3} s", r.name, r.levels.len() - 1, r.seconds_coarsening)?;
    say!(
        "{:>5} {:>9} {:>10} {:>11} {:>10} {:>8} {:>9} {:>11}",
        "level",
        "nodes",
        "bonds",
        "radius",
        "tail",
        "classes",
        "hit rate",
        "err shared"
    )?;
    for l in &r.levels {
        let (radius, tail, classes, hit) =
            l.step.as_ref().map_or(("-".into(), "-".into(), "-".into(), "-".into()), |s| {
                (
                    format!("{:.4e}", s.radius),
                    format!("{:.2e}", s.tail),
                    s.classes.to_string(),
                    format!("{:.4}", s.hit_rate),
                )
            });
        let err = l.error_shared.map_or("-".into(), |e| format!("{e:.3e}"));
        say!(
            "{:>5} {:>9} {:>10} {:>11} {:>10} {:>8} {:>9} {:>11}",
            l.level,
            l.nodes,
            l.bonds,
            radius,
            tail,
            classes,
            hit,
            err
        )?;
    }
    for l in &r.levels {
        for note in &l.notes {
            say!("level {}: {note}", l.level)?;
        }
    }
    say!("wrote {}", dir.display())?;
    Ok(())
}
