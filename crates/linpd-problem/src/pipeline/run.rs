//! Running a pipeline: the coarsening steps, every level's boundary-value problem and solve,
//! and the report ([`PipelineResult`], [`super::result`]).

use super::bvp::LevelBvp;
use super::result::{LevelResult, PipelineResult};
use super::{inv, Pipeline, Retain};
use crate::level_solve::{solve_level, TasksOnly};
use crate::ProblemError;
use linpd_coarsen::{
    check_retained, coarsen_with_progress, effective_moduli, retain_every, Coarsened, LevelModel, Options, StepReport,
};
use linpd_core::progress::{Progress, Task};
use std::path::Path;
use std::time::Instant;

impl Pipeline {
    /// Runs every step, writes the levels into `dir` ([`PipelineResult::write`]), and (if asked)
    /// solves and compares; `progress` receives one line per level and the tasks of the run (the
    /// levels, each level's local solves, the BVP solves). `summary.json`
    /// ([`PipelineResult::summary_json`]) is written by [`crate::OutputDir::commit`].
    pub fn run(&self, dir: &Path, progress: &dyn Progress) -> Result<PipelineResult, ProblemError> {
        let d = self.scene.dim();
        let t = Instant::now();
        let m0 = super::level0_model(&self.scene)?;
        progress.phase(&format!(
            "level 0: {} nodes, {} bonds, horizon {:.4e} ({:.2} s)",
            m0.len(),
            m0.n_bonds(),
            m0.horizon(),
            t.elapsed().as_secs_f64()
        ));
        let bvp0 = LevelBvp::of_scene(&self.scene);
        let mut results = vec![level_result(0, &m0, None, bvp0, None, Vec::new())];
        let mut models = vec![m0];
        let t_all = Instant::now();
        let n_levels = self.levels.len();
        let levels_task = Task::start(progress, "coarsening levels", Some(n_levels as u64));
        for i in 0..n_levels {
            let m = i + 1;
            levels_task.set(i as u64, &format!("level {m} of {n_levels}"));
            let c = self.step(i, &models[i], progress)?;
            let rep = &c.report;
            progress.phase(&format!(
                "level {m}: {} -> {} nodes, r = {:.4e} (horizon {:.4e}{}), tail {:.2e}, {} classes (hit rate {:.4}), asymmetry {:.1e}, {:.2} s",
                rep.n_fine, rep.n_coarse, rep.radius, rep.horizon_fine,
                if rep.whole_body { "; whole body" } else { "" },
                rep.tail, rep.classes, rep.hit_rate, rep.asymmetry, rep.seconds_total
            ));
            let model = if self.symmetrize { c.model.symmetrized() } else { c.model.clone() };
            let bvp = results[i].bvp.transferred(&c.transfer, &model, &results[0].bvp);
            let notes = level_notes(&c, &bvp, &results[0].bvp, &self.levels[i].radius);
            let before = results[i].bvp.total_force(d);
            results.push(level_result(m, &model, Some(c.report), bvp, Some(&before), notes));
            models.push(model);
        }
        levels_task.set(n_levels as u64, "");
        drop(levels_task);
        let seconds_coarsening = t_all.elapsed().as_secs_f64();
        let shared_x: Vec<[f64; 3]> = models[n_levels].positions().to_vec();
        if self.solve {
            self.solve_levels(&models, &mut results, progress)?;
        }
        // nothing is written before every level (and every solve) has succeeded
        std::fs::create_dir_all(dir).map_err(|source| ProblemError::Io { path: dir.display().to_string(), source })?;
        for (m, model) in models.iter().enumerate().skip(1) {
            results[m].files = super::output::write_level(model, &results[m].bvp, m, dir)?;
        }
        let result =
            PipelineResult { name: self.name.clone(), dimension: d, levels: results, shared_x, seconds_coarsening };
        result.write(dir)?;
        Ok(result)
    }

    /// Coarsening step `i` (level `i + 1` from `fine`).
    fn step(&self, i: usize, fine: &LevelModel, progress: &dyn Progress) -> Result<Coarsened, ProblemError> {
        let spec = &self.levels[i];
        let path = format!("levels[{i}]");
        let retained = match &spec.retain {
            Retain::Every(k) => retain_every(fine, *k).map_err(|e| inv(&path, e.to_string()))?,
            Retain::Nodes(n) => {
                check_retained(n, fine.len()).map_err(|e| inv(format!("{path}.nodes"), e.to_string()))?
            }
        };
        if retained.len() == fine.len() {
            return Err(inv(&path, format!("retains all {} nodes of level {i}: nothing to coarsen", fine.len())));
        }
        let opts = Options { radius: spec.radius, cache: self.cache, ..Options::fixed(1.0) };
        coarsen_with_progress(fine, &retained, &opts, progress).map_err(|e| inv(&path, format!("level {}: {e}", i + 1)))
    }

    /// Solves every level's boundary-value problem: level 0 by the scene's own solve (what
    /// `linpd solve` computes), the coarse levels on their moduli; compares at the shared nodes.
    fn solve_levels(
        &self,
        models: &[LevelModel],
        results: &mut [LevelResult],
        progress: &dyn Progress,
    ) -> Result<(), ProblemError> {
        let d = self.scene.dim();
        let shared0: Vec<usize> = models[models.len() - 1].level0().to_vec();
        let bvp_task = Task::start(progress, "BVP solves", Some(models.len() as u64));
        for (lvl, model) in models.iter().enumerate() {
            bvp_task.set(lvl as u64, &format!("level {lvl} of {}", models.len() - 1));
            let r = &mut results[lvl];
            if r.prescribed_dofs == 0 {
                return Err(inv(
                    "constraints",
                    format!("level {lvl} keeps no prescribed DOF: the scene's constraints select only nodes that the coarsening drops; constrain nodes the coarsest level keeps (its `every`-th nodes) or widen the constraint regions"),
                ));
            }
            let t = Instant::now();
            let u = if lvl == 0 {
                self.scene.solve(&TasksOnly(progress))?.u
            } else {
                solve_level(model, &r.bvp.f, &r.bvp.fixed(), progress)
                    .map_err(|source| ProblemError::Level { level: lvl, source })?
            };
            r.solve_seconds = Some(t.elapsed().as_secs_f64());
            let mut at = std::collections::HashMap::new();
            for (k, &p) in model.level0().iter().enumerate() {
                at.insert(p, k);
            }
            r.u_shared =
                shared0.iter().flat_map(|p| (0..d).map(move |a| (p, a))).map(|(p, a)| u[d * at[p] + a]).collect();
            r.u = u;
        }
        bvp_task.set(models.len() as u64, "");
        drop(bvp_task);
        let u0 = results[0].u_shared.clone();
        let umax = u0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for r in results.iter_mut() {
            let e = r.u_shared.iter().zip(&u0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            r.error_shared = Some(if umax > 0.0 { e / umax } else { e });
        }
        for r in results.iter() {
            progress.phase(&format!(
                "BVP level {}: {} nodes, {} prescribed DOFs, solve {:.3} s, error at the {} shared nodes {:.3e}",
                r.level,
                r.nodes,
                r.prescribed_dofs,
                r.solve_seconds.unwrap_or(0.0),
                shared0.len(),
                r.error_shared.unwrap_or(0.0)
            ));
        }
        Ok(())
    }
}

fn level_result(
    level: usize,
    model: &LevelModel,
    step: Option<StepReport>,
    bvp: LevelBvp,
    before: Option<&[f64]>,
    notes: Vec<String>,
) -> LevelResult {
    let d = model.dim();
    let force = bvp.total_force(d);
    let norm = |v: &[f64]| v.iter().map(|t| t * t).sum::<f64>().sqrt();
    let force_change = before.map_or(0.0, |b| {
        let diff: Vec<f64> = bvp.arrived.iter().zip(b).map(|(a, b)| a - b).collect();
        if norm(b) > 0.0 {
            norm(&diff) / norm(b)
        } else {
            norm(&diff)
        }
    });
    LevelResult {
        level,
        nodes: model.len(),
        bonds: model.n_bonds(),
        step,
        files: Vec::new(),
        prescribed_dofs: bvp.n_prescribed(),
        force,
        force_change,
        effective_moduli: effective_moduli(model, None),
        notes,
        error_shared: None,
        solve_seconds: None,
        u_shared: Vec::new(),
        u: Vec::new(),
        bvp,
    }
}

/// Notes on a level: a radius rule whose defaults took the whole body, prescribed DOFs of the
/// scene that the level's nodes do not carry.
fn level_notes(c: &Coarsened, bvp: &LevelBvp, bvp0: &LevelBvp, radius: &linpd_coarsen::Radius) -> Vec<String> {
    let mut notes = Vec::new();
    if c.report.whole_body {
        let how = match radius {
            linpd_coarsen::Radius::Auto { start: None, .. } => {
                "the radius rule's default start (2 x horizon) reached the body's diameter"
            }
            _ => "the radius reaches the body's diameter",
        };
        notes.push(format!(
            "{how}: every neighbourhood is the whole body (r = {:.4e}), the step is exact static condensation, tail 0",
            c.report.radius
        ));
    }
    let (n, n0) = (bvp.n_prescribed(), bvp0.n_prescribed());
    if n < n0 {
        notes.push(format!(
            "keeps {n} of the scene's {n0} prescribed DOFs: the others are on nodes this level drops, which the coarse moduli were condensed with free; the level poses a softer problem than the scene"
        ));
    }
    notes
}
