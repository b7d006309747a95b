//! `linpd solve`: a static scene's solution, its files and plots.

use crate::{input, output, scene_identity, CliError, Reporter};
use linpd_problem::{OutputDir, Problem};
use std::path::{Path, PathBuf};

/// Solves the static scene `scene` into `out` (default: the scene's output directory); writes
/// result.json, u.csv and the plots; prints the solve's summary, the force balance and the
/// files written.
pub(crate) fn solve(scene: &Path, out: Option<PathBuf>, quiet: bool) -> Result<(), CliError> {
    let problem = Problem::from_path(scene).map_err(input(scene))?;
    let progress = Reporter::new(quiet);
    let identity = scene_identity(&problem, scene)?;
    // Locked (and checked) before the solve: a second run into the directory fails now,
    // not after its solve. Everything is written into `staged.path()`.
    let staged = OutputDir::begin(&out.unwrap_or_else(|| PathBuf::from(problem.output_dir()))).map_err(output)?;
    let solution = problem.solve(&progress).map_err(input(scene))?;
    let dir = staged.path();
    solution.write(dir).map_err(output)?;
    let options = crate::plots::PlotOptions::of(&problem);
    match problem.grid() {
        Some(grid) if problem.plot() => {
            crate::plots::solution_plots(grid, &solution, dir, &options)?;
        }
        // Point clouds and coarsened levels: the map rasterized from the scattered
        // nodes (1D: the displacement profile).
        None if problem.plot() => {
            crate::plots::scattered_plots(&solution, dir, &options)?;
        }
        _ => {}
    }
    for probe in problem.sample_probes(&solution) {
        probe.write_csv(dir).map_err(output)?;
        if problem.plot() {
            crate::plots::probe_plots(problem.name(), &probe, dir)?;
        }
    }
    let files = staged.commit("result.json", solution.to_json(), &identity).map_err(output)?;
    let r = &solution.report;
    say!(
        "{}: {} nodes, {} unknowns, solver {}, relative residual {:.3e}, {:.3} s (assemble {:.3} s), peak memory {}",
        problem.name(),
        solution.x.len(),
        r.n,
        r.solver,
        r.rel_residual,
        r.timings.assemble + r.timings.total,
        r.timings.assemble,
        match (r.peak_rss_bytes, r.memory_estimate_bytes) {
            (Some(b), Some(e)) => format!("{:.1} MiB (estimated {:.1} MiB)", b as f64 / 1048576.0, e / 1048576.0),
            (Some(b), None) => format!("{:.1} MiB", b as f64 / 1048576.0),
            _ => "n/a".into(),
        },
    )?;
    if let Some(b) = &solution.balance {
        // (+ 0.0: a sum of no forces is -0.0, printed "-0.0000e0")
        let v = |x: &[f64]| x.iter().map(|c| format!("{:.4e}", c + 0.0)).collect::<Vec<_>>().join(", ");
        // node counts per load or constraint ("no" without any: "loads on no nodes")
        let caught = |n: Vec<usize>| match n.is_empty() {
            true => "no".to_string(),
            false => n.iter().map(usize::to_string).collect::<Vec<_>>().join("/"),
        };
        say!(
            "{}: applied force [{}] (loads on {} nodes), reactions [{}] (constraints on {} nodes), relative imbalance {:.1e}{}",
            problem.name(),
            v(&b.applied),
            caught(b.loads.iter().map(|l| l.nodes).collect()),
            v(&b.reaction),
            caught(b.constraints.iter().map(|c| c.nodes).collect()),
            b.relative_imbalance,
            match b.applied_moment.is_empty() {
                true => String::new(),
                false => format!(", moment imbalance {:.1e}", b.relative_moment_imbalance),
            }
        )?;
    }
    if let Some(p) = solution.peak_von_mises() {
        let x: Vec<String> = p.x.iter().map(|c| format!("{c:.6}")).collect();
        say!("{}: peak von Mises stress {:.4e} at node {} (x = [{}])", problem.name(), p.value, p.node, x.join(", "))?;
    }
    for f in files {
        say!("wrote {}", f.display())?;
    }
    Ok(())
}
