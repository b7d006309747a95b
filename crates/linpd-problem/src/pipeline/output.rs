//! The files of a pipeline run: per level the moduli (`level-<m>.mtx`, `level-<m>.nodes.csv`),
//! its boundary-value problem (`level-<m>.forces.csv`, `level-<m>.prescribed.csv`, read back by
//! a scene's `nodal` loads and `file` constraints) and its report (`level-<m>.json`); the
//! shared nodes' displacements (`shared.csv`).

use super::bvp::LevelBvp;
use super::inv;
use super::result::PipelineResult;
use crate::ProblemError;
use linpd_coarsen::LevelModel;
use linpd_io::mtx::ModuliFile;
use serde_json::json;
use std::path::Path;

/// Writes `level-<m>.mtx`, `level-<m>.nodes.csv`, `level-<m>.forces.csv` and
/// `level-<m>.prescribed.csv`; returns their names.
pub(super) fn write_level(
    model: &LevelModel,
    bvp: &LevelBvp,
    m: usize,
    dir: &Path,
) -> Result<Vec<String>, ProblemError> {
    let d = model.dim();
    let (offsets, cols, c) = model.csr();
    let mut entries = Vec::with_capacity(c.len());
    for i in 0..model.len() {
        for k in offsets[i]..offsets[i + 1] {
            let j = cols[k];
            for a in 0..d {
                for b in 0..d {
                    let v = c[k * d * d + a * d + b];
                    if v != 0.0 {
                        entries.push((d * i + a, d * j + b, v));
                    }
                }
            }
        }
    }
    let file = ModuliFile {
        level: m,
        dim: d,
        positions: model.positions().to_vec(),
        volumes: model.volumes().to_vec(),
        level0: model.level0().to_vec(),
        entries,
    };
    let stem = dir.join(format!("level-{m}"));
    let mut files = file.write(&stem).map_err(|e| inv("output", e.to_string()))?;
    let forces = dir.join(format!("level-{m}.forces.csv"));
    linpd_io::nodal::write_forces(&forces, d, &bvp.f).map_err(|e| inv("output", e.to_string()))?;
    let prescribed = dir.join(format!("level-{m}.prescribed.csv"));
    let entries: Vec<(usize, usize, f64)> = bvp.fixed().into_iter().map(|(k, g)| (k / d, k % d, g)).collect();
    linpd_io::nodal::write_prescribed(&prescribed, &entries).map_err(|e| inv("output", e.to_string()))?;
    files.extend([forces, prescribed]);
    Ok(files.iter().filter_map(|f| f.file_name()).map(|n| n.to_string_lossy().into_owned()).collect())
}

impl PipelineResult {
    /// The `summary.json` document: all levels.
    pub fn summary_json(&self) -> serde_json::Value {
        json!(self)
    }

    /// Writes `level-<m>.json` (one per coarsened level), plus `shared.csv` with the BVP
    /// displacements at the shared nodes per level when solved.
    pub fn write(&self, dir: &Path) -> Result<(), ProblemError> {
        let io = |p: &Path| {
            let p = p.display().to_string();
            move |source| ProblemError::Io { path: p, source }
        };
        for l in self.levels.iter().filter(|l| l.level > 0) {
            let path = dir.join(format!("level-{}.json", l.level));
            let text = serde_json::to_string_pretty(l).map_err(|e| io(&path)(std::io::Error::other(e)))?;
            std::fs::write(&path, text).map_err(io(&path))?;
        }
        if self.levels[0].solve_seconds.is_some() {
            let d = self.dimension;
            let mut s = String::new();
            let names = ["x", "y", "z"];
            let mut header: Vec<String> = names[..d].iter().map(|t| t.to_string()).collect();
            for l in &self.levels {
                for a in 0..d {
                    header.push(format!("u{}_level{}", ["x", "y", "z"][a], l.level));
                }
            }
            s.push_str(&header.join(","));
            s.push('\n');
            for (k, x) in self.shared_x.iter().enumerate() {
                let mut row: Vec<String> = x[..d].iter().map(|t| format!("{t:.17e}")).collect();
                for l in &self.levels {
                    for a in 0..d {
                        row.push(format!("{:.17e}", l.u_shared[d * k + a]));
                    }
                }
                s.push_str(&row.join(","));
                s.push('\n');
            }
            let path = dir.join("shared.csv");
            std::fs::write(&path, s).map_err(io(&path))?;
        }
        Ok(())
    }
}
