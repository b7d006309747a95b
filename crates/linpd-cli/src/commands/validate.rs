//! `linpd validate`: checks a scene without solving it.

use crate::{input, CliError};
use linpd_problem::Problem;
use std::path::Path;

/// Reads and checks `scene`; prints its model's summary, constrained DOFs and loads.
pub(crate) fn validate(scene: &Path) -> Result<(), CliError> {
    let p = Problem::from_path(scene).map_err(input(scene))?;
    let (mask, _) = p.constrained();
    let constrained = mask.iter().filter(|&&m| m).count();
    say!(
        "{}: valid; {}, {} constrained DOFs, {} loads",
        p.name(),
        p.model().summary(&p),
        constrained,
        p.loads().len()
    )?;
    Ok(())
}
