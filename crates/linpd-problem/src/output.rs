//! Writing a [`Solution`]: `u.csv` ([`Solution::write`]) and the `result.json` document
//! ([`Solution::to_json`]), which [`crate::OutputDir::commit`] writes last with the run's
//! identity and the list of the files written.

use crate::{ProblemError, Solution};
use serde_json::json;
use std::io::Write;
use std::path::Path;

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ProblemError + '_ {
    move |source| ProblemError::Io { path: path.display().to_string(), source }
}

impl Solution {
    /// Displacement of node `n` (plain number in 1D, array otherwise) as JSON.
    fn u_json(&self, n: usize) -> serde_json::Value {
        let d = self.dim;
        if d == 1 {
            json!(self.u[n])
        } else {
            json!(self.u[d * n..d * n + d])
        }
    }

    /// The `result.json` document.
    pub fn to_json(&self) -> serde_json::Value {
        let d = self.dim;
        let n = self.x.len();
        let x: Vec<serde_json::Value> =
            (0..n).map(|k| if d == 1 { json!(self.x[k][0]) } else { json!(self.x[k][..d]) }).collect();
        let u: Vec<serde_json::Value> = (0..n).map(|k| self.u_json(k)).collect();
        json!({
            "name": self.name,
            "dimension": d,
            "x": x,
            "u": u,
            "layer": self.is_layer,
            "balance": self.balance,
            "stats": {
                "nodes": n,
                "bonds": self.n_bonds,
                "dofs": d * n,
                "solve": self.report,
            }
        })
    }

    /// Writes `u.csv` into `dir` (created if missing); returns its path. `result.json`
    /// ([`Solution::to_json`]) is written by [`crate::OutputDir::commit`].
    pub fn write(&self, dir: &Path) -> Result<Vec<std::path::PathBuf>, ProblemError> {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let csv_path = dir.join("u.csv");
        let mut w = std::io::BufWriter::new(std::fs::File::create(&csv_path).map_err(io(&csv_path))?);
        let d = self.dim;
        let names = ["x", "y", "z"];
        let unames = ["u", "v", "w"];
        let header: Vec<&str> = names[..d].iter().chain(&unames[..d]).copied().chain(["layer"]).collect();
        writeln!(w, "{}", header.join(",")).map_err(io(&csv_path))?;
        for k in 0..self.x.len() {
            let mut row: Vec<String> = (0..d).map(|a| format!("{:.17e}", self.x[k][a])).collect();
            row.extend((0..d).map(|a| format!("{:.17e}", self.u[d * k + a])));
            row.push((self.is_layer[k] as u8).to_string());
            writeln!(w, "{}", row.join(",")).map_err(io(&csv_path))?;
        }
        w.flush().map_err(io(&csv_path))?;
        Ok(vec![csv_path])
    }
}
