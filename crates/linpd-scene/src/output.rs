//! Writing a [`Solution`]: `u.csv` and `result.vtu` ([`Solution::write`]) and the
//! `result.json` document ([`Solution::to_json`]), which `linpd_problem::OutputDir::commit` writes
//! last with the run's identity and the list of the files written; and the one VTU writer
//! ([`linpd_io::vtk::write_vtu`]) and ParaView collection writer ([`linpd_io::vtk::write_pvd`]) that `linpd run`'s snapshots
//! share.

use crate::balance::Balance;
use crate::solution::Solution;
use crate::ProblemError;
use linpd_io::vtk::{PointArray, PointValues};
use linpd_solve::SolveReport;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ProblemError + '_ {
    move |source| ProblemError::Io { path: path.display().to_string(), source }
}

/// A node's value in `result.json`: a plain number in 1D, an array of `d` components otherwise.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub enum NodeValue<'a> {
    /// 1D.
    Scalar(f64),
    /// 2D and 3D.
    Vector(&'a [f64]),
    /// 2D and 3D, computed (a strain's Voigt components).
    Owned(Vec<f64>),
}

impl<'a> NodeValue<'a> {
    /// The `d` values of `v` (node-major, `d` per node) of node `n`.
    fn of(v: &'a [f64], d: usize, n: usize) -> Self {
        if d == 1 {
            NodeValue::Scalar(v[n])
        } else {
            NodeValue::Vector(&v[d * n..d * n + d])
        }
    }
}

/// The `result.json` document of a static solve ([`Solution::to_json`]; the `"run"` member is
/// added by `linpd_problem::OutputDir::commit`). Its keys are listed in docs/problem-format.md and
/// checked by tests/result_schema.rs.
#[derive(Debug, Serialize)]
pub struct ResultDoc<'a> {
    /// Scene name.
    pub name: &'a str,
    /// `d`.
    pub dimension: usize,
    /// Node positions.
    pub x: Vec<NodeValue<'a>>,
    /// Displacements.
    pub u: Vec<NodeValue<'a>>,
    /// Layer flags.
    pub layer: &'a [bool],
    /// Loads, reactions and the force balance.
    pub balance: Option<&'a Balance>,
    /// `W_i` per node.
    pub strain_energy_density: Option<&'a [f64]>,
    /// LPS: `theta_i` per node.
    pub dilatation: Option<&'a [f64]>,
    /// Voigt strain per node (a number in 1D).
    pub strain: Option<Vec<NodeValue<'a>>>,
    /// Nodes whose strain is undefined (singular shape tensor).
    pub strain_singular_nodes: Option<&'a [usize]>,
    /// Cauchy stress per node (Voigt, a number in 1D; [`crate::stress`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stress: Option<Vec<NodeValue<'a>>>,
    /// Von Mises stress per node.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub von_mises: Option<Vec<f64>>,
    /// Principal stresses per node, descending.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub principal_stress: Option<Vec<Vec<f64>>>,
    /// Force-flux (peridynamic) stress per node (Voigt): bond-based models.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pd_stress: Option<Vec<NodeValue<'a>>>,
    /// `E, nu, K, G` of the reference material and of every phase ([`crate::elastic`]).
    pub material: &'a [crate::elastic::PhaseConstants],
    /// Sizes and the solve report.
    pub stats: Stats<'a>,
}

/// `result.json`'s `stats`.
#[derive(Debug, Serialize)]
pub struct Stats<'a> {
    /// Nodes.
    pub nodes: usize,
    /// Bonds (each pair from both ends).
    pub bonds: usize,
    /// `d` times nodes.
    pub dofs: usize,
    /// Accuracy and cost.
    pub solve: &'a SolveReport,
    /// A graded local mesh against its lattice.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub graded_mesh: Option<&'a crate::solution::GradedMeshSummary>,
    /// The largest von Mises stress over the body's nodes (layer nodes left out) and where.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_von_mises: Option<StressPeak>,
}

/// Where a stress peaks: `result.json`'s `stats.peak_von_mises`.
#[derive(Debug, Clone, Serialize)]
pub struct StressPeak {
    /// The value.
    pub value: f64,
    /// The node (in node order).
    pub node: usize,
    /// Its position.
    pub x: Vec<f64>,
}

impl Solution {
    /// The typed `result.json` document.
    pub fn doc(&self) -> ResultDoc<'_> {
        let (d, n) = (self.dim, self.x.len());
        let x = self.x.iter().map(|p| if d == 1 { NodeValue::Scalar(p[0]) } else { NodeValue::Vector(&p[..d]) });
        let strain = self.strain.as_ref().map(|s| {
            (0..n)
                .map(|i| if d == 1 { NodeValue::Scalar(s.tensor[i][0]) } else { NodeValue::Owned(s.voigt(i)) })
                .collect()
        });
        let voigt = |s: &crate::stress::NodalStress| -> Vec<NodeValue<'_>> {
            (0..n)
                .map(|i| if d == 1 { NodeValue::Scalar(s.tensor[i][0]) } else { NodeValue::Owned(s.voigt(i)) })
                .collect()
        };
        ResultDoc {
            stress: self.stress.as_ref().map(voigt),
            von_mises: self.stress.as_ref().map(|s| (0..n).map(|i| s.von_mises(i)).collect()),
            principal_stress: self.stress.as_ref().map(|s| (0..n).map(|i| s.principal(i)).collect()),
            pd_stress: self.pd_stress.as_ref().map(voigt),
            name: &self.name,
            dimension: d,
            x: x.collect(),
            u: (0..n).map(|k| NodeValue::of(&self.u, d, k)).collect(),
            layer: &self.is_layer,
            balance: self.balance.as_ref(),
            strain_energy_density: self.strain_energy_density.as_deref(),
            dilatation: self.dilatation.as_deref(),
            strain,
            strain_singular_nodes: self.strain.as_ref().map(|s| s.singular.as_slice()),
            material: &self.material,
            stats: Stats {
                nodes: n,
                bonds: self.n_bonds,
                dofs: d * n,
                solve: &self.report,
                graded_mesh: self.graded_mesh.as_ref(),
                peak_von_mises: self.peak_von_mises(),
            },
        }
    }

    /// The node of the body (not the layer) with the largest von Mises stress, when there is a
    /// stress.
    pub fn peak_von_mises(&self) -> Option<StressPeak> {
        let s = self.stress.as_ref()?;
        let node = (0..self.x.len())
            .filter(|&i| !self.is_layer[i])
            .max_by(|&a, &b| s.von_mises(a).total_cmp(&s.von_mises(b)))?;
        Some(StressPeak { value: s.von_mises(node), node, x: self.x[node][..self.dim].to_vec() })
    }

    /// The `result.json` document as a JSON value (keys in alphabetical order, as written).
    /// Serializing it cannot fail: every map key is a string, and non-finite numbers become
    /// `null` (as they did in the document built by hand).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self.doc()).unwrap_or_default()
    }

    /// Writes `u.csv` and `result.vtu` into `dir` (created if missing); returns their paths. `result.json`
    /// ([`Solution::to_json`]) is written by `linpd_problem::OutputDir::commit`.
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

    /// Writes the solution as VTK XML `UnstructuredGrid` ([`linpd_io::vtk::write_vtu`]): point data `u` (3
    /// components, 0-padded), `layer` (0/1), and when known `volume`, `reaction` (the supports'
    /// force on each held node, 0-padded, 0 elsewhere), `stress` and `von_mises` (Hooke),
    /// `pd_stress` (force flux; 9 components like `strain`), `strain_energy_density`,
    /// `dilatation` (LPS) and `strain` (the full `3 x 3` tensor, 9 components row-major, 0
    /// outside the `d x d` block: VTK's tensor convention).
    pub fn write_vtu(&self, path: &Path) -> Result<(), ProblemError> {
        self.with_point_arrays(&|arrays| {
            linpd_io::vtk::write_vtu_cells(path, self.dim, &self.x, arrays, self.cells.as_ref())
                .map_err(ProblemError::from)
        })
    }

    /// Writes the parallel index `result.pvtu` over the pieces `pieces` (files beside it, each
    /// a [`Solution::write_vtu`] of a rank's solution with the same arrays as this one).
    pub fn write_pvtu(&self, path: &Path, pieces: &[String]) -> Result<(), ProblemError> {
        self.with_point_arrays(&|arrays| linpd_io::vtk::write_pvtu(path, arrays, pieces).map_err(ProblemError::from))
    }

    /// Calls `write` with the point arrays of [`Solution::write_vtu`].
    fn with_point_arrays(&self, write: &dyn Fn(&[PointArray]) -> Result<(), ProblemError>) -> Result<(), ProblemError> {
        let (d, n) = (self.dim, self.x.len());
        let u = |k: usize, a: usize| if a < d { self.u[d * k + a] } else { 0.0 };
        let layer = |k: usize| self.is_layer[k] as u8;
        let mut arrays = vec![
            PointArray { name: "u", values: PointValues::Float64 { components: 3, value: &u } },
            PointArray { name: "layer", values: PointValues::UInt8(&layer) },
        ];
        let file_node = |k: usize| self.file_node.as_ref().map_or(0, |f| f[k]);
        if self.file_node.as_ref().is_some_and(|f| f.len() == n) {
            arrays.push(PointArray { name: "file_node", values: PointValues::UInt32(&file_node) });
        }
        let volume = |k: usize, _: usize| self.volumes[k];
        if self.volumes.len() == n {
            arrays.push(PointArray { name: "volume", values: PointValues::Float64 { components: 1, value: &volume } });
        }
        let energy = |k: usize, _: usize| self.strain_energy_density.as_ref().map_or(0.0, |e| e[k]);
        if self.strain_energy_density.is_some() {
            arrays.push(PointArray {
                name: "strain_energy_density",
                values: PointValues::Float64 { components: 1, value: &energy },
            });
        }
        let theta = |k: usize, _: usize| self.dilatation.as_ref().map_or(0.0, |t| t[k]);
        if self.dilatation.is_some() {
            arrays
                .push(PointArray { name: "dilatation", values: PointValues::Float64 { components: 1, value: &theta } });
        }
        // the supports' nodal reactions, on the nodes the balance was taken on
        let reactions = self.balance.as_ref().map(|b| b.nodal_reaction.as_slice()).filter(|r| r.len() == d * n);
        let reaction = |k: usize, a: usize| if a < d { reactions.map_or(0.0, |r| r[d * k + a]) } else { 0.0 };
        if reactions.is_some() {
            arrays.push(PointArray {
                name: "reaction",
                values: PointValues::Float64 { components: 3, value: &reaction },
            });
        }
        let stress = |k: usize, c: usize| self.stress.as_ref().map_or(0.0, |s| s.tensor[k][c]);
        let von_mises = |k: usize, _: usize| self.stress.as_ref().map_or(0.0, |s| s.von_mises(k));
        if self.stress.is_some() {
            arrays.push(PointArray { name: "stress", values: PointValues::Float64 { components: 9, value: &stress } });
            arrays.push(PointArray {
                name: "von_mises",
                values: PointValues::Float64 { components: 1, value: &von_mises },
            });
        }
        let pd_stress = |k: usize, c: usize| self.pd_stress.as_ref().map_or(0.0, |s| s.tensor[k][c]);
        if self.pd_stress.is_some() {
            arrays.push(PointArray {
                name: "pd_stress",
                values: PointValues::Float64 { components: 9, value: &pd_stress },
            });
        }
        let strain = |k: usize, c: usize| self.strain.as_ref().map_or(0.0, |s| s.tensor[k][c]);
        if self.strain.is_some() {
            arrays.push(PointArray { name: "strain", values: PointValues::Float64 { components: 9, value: &strain } });
        }
        write(&arrays)
    }
}
