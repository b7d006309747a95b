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
            "strain_energy_density": self.strain_energy_density,
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
        let vtu_path = dir.join("result.vtu");
        self.write_vtu(&vtu_path)?;
        Ok(vec![csv_path, vtu_path])
    }

    /// Writes the solution as VTK XML `UnstructuredGrid` (ParaView, VisIt, meshio, pyvista):
    /// one vertex cell per node; point data `u` (3 components, 0-padded), `layer` (0/1),
    /// `volume` and `strain_energy_density` when known. ASCII with `{:e}` numbers (17
    /// significant digits: read back bit for bit). Written by hand: the format is a fixed
    /// XML skeleton around number lists, and the Rust VTK crates (`vtkio`) pull in a large
    /// dependency tree for it.
    pub fn write_vtu(&self, path: &Path) -> Result<(), ProblemError> {
        let (d, n) = (self.dim, self.x.len());
        let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io(path))?);
        let mut body = || -> std::io::Result<()> {
            writeln!(w, r#"<?xml version="1.0"?>"#)?;
            writeln!(
                w,
                r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
            )?;
            writeln!(w, "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">")?;
            writeln!(w, "      <PointData>")?;
            let vector = |w: &mut dyn Write, name: &str, v: &dyn Fn(usize, usize) -> f64| -> std::io::Result<()> {
                writeln!(
                    w,
                    r#"        <DataArray type="Float64" Name="{name}" NumberOfComponents="3" format="ascii">"#
                )?;
                for k in 0..n {
                    writeln!(w, "          {:.16e} {:.16e} {:.16e}", v(k, 0), v(k, 1), v(k, 2))?;
                }
                writeln!(w, "        </DataArray>")
            };
            let scalar =
                |w: &mut dyn Write, name: &str, ty: &str, v: &dyn Fn(usize) -> String| -> std::io::Result<()> {
                    writeln!(w, r#"        <DataArray type="{ty}" Name="{name}" format="ascii">"#)?;
                    for k in 0..n {
                        writeln!(w, "          {}", v(k))?;
                    }
                    writeln!(w, "        </DataArray>")
                };
            vector(&mut w, "u", &|k, a| if a < d { self.u[d * k + a] } else { 0.0 })?;
            scalar(&mut w, "layer", "UInt8", &|k| (self.is_layer[k] as u8).to_string())?;
            if self.volumes.len() == n {
                scalar(&mut w, "volume", "Float64", &|k| format!("{:.16e}", self.volumes[k]))?;
            }
            if let Some(e) = &self.strain_energy_density {
                scalar(&mut w, "strain_energy_density", "Float64", &|k| format!("{:.16e}", e[k]))?;
            }
            writeln!(w, "      </PointData>\n      <Points>")?;
            vector(&mut w, "points", &|k, a| if a < d { self.x[k][a] } else { 0.0 })?;
            writeln!(w, "      </Points>\n      <Cells>")?;
            scalar(&mut w, "connectivity", "Int64", &|k| k.to_string())?;
            scalar(&mut w, "offsets", "Int64", &|k| (k + 1).to_string())?;
            // VTK_VERTEX = 1
            scalar(&mut w, "types", "UInt8", &|_| "1".to_string())?;
            writeln!(w, "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>")?;
            w.flush()
        };
        body().map_err(io(path))
    }
}
