//! `linpd._linpd`: the native half of the `linpd` Python package (the Python half, `linpd/`,
//! gives it its documented API: `linpd.Scene`, `linpd.coarsen`, `linpd.petsc`).
//!
//! Thin on purpose: every number comes from the Rust crates through the same functions the CLI
//! calls (`Problem::from_path`, `Commands::reduced_system` of `linpd export`, `Problem::solve`
//! of `linpd solve`, `Commands::row_system` for PETSc's per-rank rows), so the Python results are
//! the CLI's bit for bit. Arrays cross as numpy arrays (copied once), documents as JSON text
//! (parsed by the Python half), errors as `linpd.LinpdError` carrying linpd's message (the
//! error's `Display`, e.g. `model.horizon: must be > 0, got -1e0`). Long computations release
//! the GIL.

use linpd_core::NoProgress;
use linpd_problem::{
    part_rows, Commands, OutputDir, Part, PartRows, Pipeline, Problem, ProblemError, RowSystem, RunIdentity,
};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pyo3::create_exception!(_linpd, LinpdError, PyException, "An error of linpd; its message is linpd's own.");

fn err(e: ProblemError) -> PyErr {
    LinpdError::new_err(e.to_string())
}

/// A validated scene (see `linpd.Scene`).
#[pyclass(frozen, module = "linpd._linpd")]
struct NativeScene {
    problem: Problem,
    /// The scene file, when read from one (the run identity of `write_result`).
    path: Option<PathBuf>,
    /// Built on the first row request (the model, its DOF split and right-hand side).
    rows: OnceLock<RowSystem>,
}

impl NativeScene {
    fn row_system(&self, py: Python<'_>) -> PyResult<&RowSystem> {
        if let Some(r) = self.rows.get() {
            return Ok(r);
        }
        let built = py.detach(|| self.problem.row_system()).map_err(err)?;
        Ok(self.rows.get_or_init(|| built))
    }
}

type Csc<'py> = (
    usize,
    Bound<'py, PyArray1<usize>>,
    Bound<'py, PyArray1<usize>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// `(n, block_size, free_dofs, rhs)` of [`NativeScene::row_info`].
type RowInfo<'py> = (usize, usize, Bound<'py, PyArray1<usize>>, Bound<'py, PyArray1<f64>>);
/// `(d_nnz, o_nnz)` of [`NativePart::row_lengths`].
type RowLengths<'py> = (Bound<'py, PyArray1<u32>>, Bound<'py, PyArray1<u32>>);
/// `(sum of positions, count, lower corner, upper corner)` of [`NativePart::owned_frame`].
type Frame = ([f64; 3], usize, [f64; 3], [f64; 3]);
/// `(loads, load_moments, reactions, reaction_moments, held_dofs)` of [`NativePart::balance`].
type PartShare = (Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<usize>);
/// `(indptr, indices, data)` of a block of rows.
type Csr<'py> = (Bound<'py, PyArray1<usize>>, Bound<'py, PyArray1<usize>>, Bound<'py, PyArray1<f64>>);

#[pymethods]
impl NativeScene {
    /// Reads and validates a scene file.
    #[staticmethod]
    fn from_path(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let problem = py.detach(|| Problem::from_path(&path)).map_err(err)?;
        Ok(NativeScene { problem, path: Some(path), rows: OnceLock::new() })
    }

    /// Validates scene text; relative file names in it start at `base_dir`.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str, base_dir: PathBuf) -> PyResult<Self> {
        let problem = py.detach(|| Problem::from_json_in(text, &base_dir)).map_err(err)?;
        Ok(NativeScene { problem, path: None, rows: OnceLock::new() })
    }

    #[getter]
    fn name(&self) -> String {
        self.problem.name().to_string()
    }
    #[getter]
    fn dim(&self) -> usize {
        self.problem.dim()
    }
    #[getter]
    fn n_nodes(&self) -> usize {
        self.problem.nodes().len()
    }
    #[getter]
    fn model_type(&self) -> &'static str {
        self.problem.model().name()
    }
    #[getter]
    fn output_dir(&self) -> String {
        self.problem.output_dir().to_string()
    }

    /// `(n, col_ptr, row_idx, values, rhs)`: `A_ff` in CSC (as `linpd export` writes it) and
    /// `f_f - (A u_bar)_f`.
    fn reduced_system<'py>(&self, py: Python<'py>) -> PyResult<Csc<'py>> {
        let s = py.detach(|| self.problem.reduced_system(&NoProgress)).map_err(err)?;
        let n = s.n();
        let (cp, ri, val) = (s.k.symbolic().col_ptr().to_vec(), s.k.symbolic().row_idx().to_vec(), s.k.val().to_vec());
        Ok((n, cp.into_pyarray(py), ri.into_pyarray(py), val.into_pyarray(py), s.f.into_pyarray(py)))
    }

    /// `(node, component)` of every unknown, shape `(n, 2)`, from the DOF split of the
    /// constraints (no assembly).
    fn dofs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<usize>>> {
        let d = self.problem.dim();
        let (mask, _) = self.problem.constrained();
        let rows: Vec<Vec<usize>> =
            mask.iter().enumerate().filter(|(_, &c)| !c).map(|(g, _)| vec![g / d, g % d]).collect();
        if rows.is_empty() {
            return Ok(numpy::PyArray2::zeros(py, [0, 2], false));
        }
        PyArray2::from_vec2(py, &rows).map_err(|e| LinpdError::new_err(e.to_string()))
    }

    /// Node positions, shape `(nodes, d)`.
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let d = self.problem.dim();
        let rows: Vec<Vec<f64>> = self.problem.nodes().positions().iter().map(|x| x[..d].to_vec()).collect();
        PyArray2::from_vec2(py, &rows).map_err(|e| LinpdError::new_err(e.to_string()))
    }

    /// Node volumes, shape `(nodes,)`.
    fn volumes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let nodes = self.problem.nodes();
        (0..nodes.len()).map(|n| nodes.volume(n)).collect::<Vec<_>>().into_pyarray(py)
    }

    /// `(u, result_json)`: the displacements over all DOFs (node-major) and `result.json`'s
    /// document, from the same solve as `linpd solve`.
    fn solve<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyArray1<f64>>, String)> {
        let s = py.detach(|| self.problem.solve(&NoProgress)).map_err(err)?;
        let doc = s.to_json().to_string();
        Ok((s.u.into_pyarray(py), doc))
    }

    /// The stiffness over every DOF, no constraint applied, as CSC arrays (with an empty rhs).
    fn unconstrained_stiffness<'py>(&self, py: Python<'py>) -> PyResult<Csc<'py>> {
        let k = py.detach(|| self.problem.unconstrained_stiffness(&NoProgress)).map_err(err)?;
        let n = k.nrows();
        let (cp, ri) = (k.symbolic().col_ptr().to_vec(), k.symbolic().row_idx().to_vec());
        let val = k.val().to_vec();
        Ok((n, cp.into_pyarray(py), ri.into_pyarray(py), val.into_pyarray(py), Vec::<f64>::new().into_pyarray(py)))
    }

    /// The lumped mass per DOF.
    fn mass<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(self.problem.lumped_mass().map_err(err)?.into_pyarray(py))
    }

    /// `(modes_json, shapes)`: `linpd modes`'s document and the shapes, one row per mode over
    /// all DOFs.
    fn modes<'py>(&self, py: Python<'py>, count: usize) -> PyResult<(String, Bound<'py, PyArray2<f64>>)> {
        let m = py.detach(|| self.problem.modes(count, &NoProgress)).map_err(err)?;
        let shapes: Vec<Vec<f64>> = m.modes.iter().map(|x| x.shape.clone()).collect();
        let doc = m.to_json().to_string();
        let array = numpy::PyArray2::from_vec2(py, &shapes).map_err(|e| LinpdError::new_err(e.to_string()))?;
        Ok((doc, array))
    }

    /// `(n, block_size, free_dofs, rhs)` of the row system (builds it on the first call).
    fn row_info<'py>(&self, py: Python<'py>) -> PyResult<RowInfo<'py>> {
        let r = self.row_system(py)?;
        let bs = linpd_problem::petsc::whole_nodes_block_size(r.dim(), r.free_dofs());
        Ok((r.n(), bs, r.free_dofs().to_vec().into_pyarray(py), r.rhs().to_vec().into_pyarray(py)))
    }

    /// `(symmetric, asymmetry)` of `A_ff`: the model's bound on `max |A_ff - A_ff^T| / max
    /// |A_ff|` and whether it is within `SYMMETRY_RTOL` (builds the row system on the first call).
    fn row_symmetry(&self, py: Python<'_>) -> PyResult<(bool, f64)> {
        let r = self.row_system(py)?;
        Ok((r.is_symmetric(), r.asymmetry()))
    }

    /// `(indptr, indices, data)` of rows `first..last` of `A_ff` with global column indices.
    fn assemble_rows<'py>(&self, py: Python<'py>, first: usize, last: usize) -> PyResult<Csr<'py>> {
        let r = self.row_system(py)?;
        let b = py.detach(|| r.rows(first, last)).map_err(err)?;
        Ok((b.indptr.into_pyarray(py), b.indices.into_pyarray(py), b.data.into_pyarray(py)))
    }

    /// `u = u_bar + u_f` over all DOFs of the row system's model from the free values `u_free`
    /// (row order; for a blend scene with a coarse CE mesh the DOFs are the mesh's).
    fn expand<'py>(&self, py: Python<'py>, u_free: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let u_free = u_free.as_slice()?;
        let u = self.row_system(py)?.expand(u_free).map_err(err)?;
        Ok(u.into_pyarray(py))
    }

    /// Writes `u.csv`, `result.vtu` and `result.json` into `out` (all or none, as `linpd
    /// solve`) for displacements `u` over all DOFs solved elsewhere; `report_json` replaces
    /// `stats.solve`. Returns the paths written.
    fn write_result(
        &self,
        py: Python<'_>,
        u: PyReadonlyArray1<'_, f64>,
        report_json: &str,
        out: PathBuf,
    ) -> PyResult<Vec<String>> {
        let u = u.as_slice()?.to_vec();
        let report: serde_json::Value =
            serde_json::from_str(report_json).map_err(|e| LinpdError::new_err(format!("report_json: {e}")))?;
        let r = self.row_system(py)?;
        let identity = match &self.path {
            Some(p) => RunIdentity::of_inputs(&[p.as_path()]),
            None => RunIdentity::of_inputs(&[]),
        }
        .map_err(err)?;
        py.detach(|| {
            // checked (finite u of the right length) before anything is created
            let placeholder = linpd_solve::SolveReport::new(linpd_solve::SolverId::Lu, r.n(), 0);
            let solution = self.problem.solution_from(r, u, placeholder)?;
            let staged = OutputDir::begin(&out)?;
            solution.write(staged.path())?;
            let mut doc = solution.to_json();
            doc["stats"]["solve"] = report;
            staged.commit("result.json", doc, &identity)
        })
        .map(|paths| paths.iter().map(|p| p.display().to_string()).collect())
        .map_err(err)
    }
}

/// One MPI rank's part of a lattice or point-cloud scene (`linpd.petsc`'s per-rank geometry): the stages in
/// the order the driver calls them, each after the reduction over the ranks it needs.
#[pyclass(module = "linpd._linpd")]
struct NativePart {
    /// The validated part (taken while `build` adds the resultant volumes).
    problem: Option<Problem>,
    rows: Option<PartRows>,
}

impl NativePart {
    fn problem(&self) -> PyResult<&Problem> {
        self.problem.as_ref().ok_or_else(|| LinpdError::new_err("the part's scene was lost in a failed build"))
    }
    fn rows(&self) -> PyResult<&PartRows> {
        self.rows.as_ref().ok_or_else(|| LinpdError::new_err("build the part's rows first (NativePart.build)"))
    }
}

#[pymethods]
impl NativePart {
    /// Reads and validates rank `rank` of `ranks`'s part of a scene file.
    #[staticmethod]
    fn from_path(py: Python<'_>, path: PathBuf, rank: usize, ranks: usize) -> PyResult<Self> {
        let problem = py.detach(|| Problem::from_path_part(&path, Part { rank, ranks })).map_err(err)?;
        Ok(NativePart { problem: Some(problem), rows: None })
    }
    #[getter]
    fn name(&self) -> PyResult<String> {
        Ok(self.problem()?.name().to_string())
    }
    #[getter]
    fn dim(&self) -> PyResult<usize> {
        Ok(self.problem()?.dim())
    }
    #[getter]
    fn output_dir(&self) -> PyResult<String> {
        Ok(self.problem()?.output_dir().to_string())
    }
    /// `(planes, owned_first, owned_last, window_first, window_last, window_nodes)`.
    fn slab(&self) -> PyResult<(usize, usize, usize, usize, usize, usize)> {
        let p = self.problem()?;
        let s = &p.part().ok_or_else(|| LinpdError::new_err("not a part"))?.slab;
        Ok((s.planes, s.owned.start, s.owned.end, s.window.start, s.window.end, p.nodes().len()))
    }
    /// Whether this rank found what each presence check looks for (or them over the ranks).
    fn presences(&self) -> PyResult<Vec<bool>> {
        Ok(self.problem()?.part().map(|p| p.presences.iter().map(|c| c.found).collect()).unwrap_or_default())
    }
    /// The first check no rank found, as the whole scene's error.
    fn settle(&self, found_anywhere: Vec<bool>) -> PyResult<()> {
        let presences = self.problem()?.part().map(|p| p.presences.clone()).unwrap_or_default();
        linpd_problem::part::settle(&presences, &found_anywhere).map_err(err)
    }
    /// Per load, its region's volume over the owned nodes (sum them over the ranks).
    fn resultant_volumes(&self) -> PyResult<Vec<f64>> {
        Ok(self.problem()?.resultant_volumes())
    }
    /// Builds the window's model and the owned rows' right-hand side with the whole body's
    /// resultant volumes.
    fn build(&mut self, py: Python<'_>, volumes: Vec<f64>) -> PyResult<()> {
        let problem = self.problem.take().ok_or_else(|| LinpdError::new_err("built twice"))?;
        let problem = problem.with_resultant_volumes(volumes).map_err(err)?;
        let rows = py.detach(|| part_rows(&problem));
        self.problem = Some(problem);
        self.rows = Some(rows.map_err(err)?);
        Ok(())
    }
    /// Free DOFs per owned plane (gather them in rank order).
    fn plane_free_counts(&self) -> PyResult<Vec<usize>> {
        Ok(self.rows()?.plane_free_counts().to_vec())
    }
    /// Numbers the rows from every plane's count.
    fn number(&mut self, counts: Vec<usize>) -> PyResult<()> {
        self.rows.as_mut().ok_or_else(|| LinpdError::new_err("build first"))?.number(&counts).map_err(err)
    }
    /// `(M^T M, R^T R)` of the rigid modes over the owned nodes (sum them over the ranks).
    fn support_gram(&self) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let g = self.rows()?.support(self.problem()?).map_err(err)?;
        Ok((g.all, g.held))
    }
    /// The error of a body the summed Gram matrices leave free to move.
    fn check_support(&self, all: Vec<f64>, held: Vec<f64>) -> PyResult<()> {
        let mut g = self.rows()?.support(self.problem()?).map_err(err)?;
        let m = g.all.len();
        if all.len() != m || held.len() != m {
            return Err(LinpdError::new_err(format!("Gram matrices of {m} entries expected")));
        }
        g.all = all;
        g.held = held;
        match g.free_modes() {
            0 => Ok(()),
            k => Err(LinpdError::new_err(format!(
                "constraints: {k} rigid motion(s) of the body are not constrained (summed over the ranks' nodes); add \
                 displacement constraints"
            ))),
        }
    }
    /// `(first, last, n)`: the owned rows and the unknowns of the whole scene.
    fn row_range(&self) -> PyResult<(usize, usize, usize)> {
        let r = self.rows()?;
        let range = r.row_range().map_err(err)?;
        Ok((range.start, range.end, r.n_global().map_err(err)?))
    }
    /// `(symmetric, asymmetry, whole_nodes)` of the window's rows.
    fn row_kind(&self) -> PyResult<(bool, f64, bool)> {
        let r = self.rows()?;
        Ok((r.is_symmetric(), r.asymmetry(), r.whole_nodes()))
    }
    /// The owned rows `lo..hi` (from the rank's first) of `A_ff` (`indptr` from 0, global
    /// columns).
    fn assemble_rows<'py>(&self, py: Python<'py>, lo: usize, hi: usize) -> PyResult<Csr<'py>> {
        let r = self.rows()?;
        let b = py.detach(|| r.rows(lo, hi)).map_err(err)?;
        Ok((b.indptr.into_pyarray(py), b.indices.into_pyarray(py), b.data.into_pyarray(py)))
    }
    /// `(d_nnz, o_nnz)`: per owned row, its entries in the rank's columns and in the others'.
    fn row_lengths<'py>(&self, py: Python<'py>) -> PyResult<RowLengths<'py>> {
        let r = self.rows()?;
        let (d, o) = py.detach(|| r.row_lengths()).map_err(err)?;
        Ok((d.into_pyarray(py), o.into_pyarray(py)))
    }
    /// `f_f - (A u_bar)_f` of the owned rows.
    fn rhs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(self.rows()?.rhs().to_vec().into_pyarray(py))
    }
    /// Each owned row's node coordinate along its component.
    fn row_coordinates<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(self.rows()?.row_coordinates().into_pyarray(py))
    }
    /// The global row of each free DOF of the window (where to gather the window's values).
    fn window_rows<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<usize>>> {
        Ok(self.rows()?.window_rows().map_err(err)?.to_vec().into_pyarray(py))
    }
    /// `(sum of positions, count, lower corner, upper corner)` of the owned nodes (reduce them:
    /// the moments' reference point is the mean position).
    fn owned_frame(&self) -> PyResult<Frame> {
        Ok(self.problem()?.owned_frame())
    }
    /// `(loads, load_moments, reactions, reaction_moments, held_dofs)`: the rank's share of the
    /// balance, moments about `reference` (sum them over the ranks).
    fn balance(&self, py: Python<'_>, u_window: PyReadonlyArray1<'_, f64>, reference: Vec<f64>) -> PyResult<PartShare> {
        let u = u_window.as_slice()?;
        let (r, p) = (self.rows()?, self.problem()?);
        let b = py.detach(|| r.balance(p, u, &reference)).map_err(err)?;
        Ok((b.loads, b.load_moments, b.reactions, b.reaction_moments, b.held_dofs))
    }
    /// Writes the owned nodes' solution into `dir/name` (a piece of `result.pvtu`); with
    /// `index`, also the index `dir/index` over `pieces`.
    #[pyo3(signature = (u_window, dir, name, index=None, pieces=Vec::new()))]
    fn write_piece(
        &self,
        py: Python<'_>,
        u_window: PyReadonlyArray1<'_, f64>,
        dir: PathBuf,
        name: &str,
        index: Option<&str>,
        pieces: Vec<String>,
    ) -> PyResult<usize> {
        let u = u_window.as_slice()?;
        let (r, p) = (self.rows()?, self.problem()?);
        py.detach(|| {
            let report = linpd_solve::SolveReport::new(linpd_solve::SolverId::Lu, u.len(), 0);
            let piece = r.solution(p, u, report)?;
            piece.write_vtu(&dir.join(name))?;
            if let Some(index) = index {
                piece.write_pvtu(&dir.join(index), &pieces)?;
            }
            Ok(piece.x.len())
        })
        .map_err(err)
    }
}

/// A run's output directory while the ranks write their pieces (rank 0 holds it).
#[pyclass(module = "linpd._linpd")]
struct NativeOutput {
    staged: Option<OutputDir>,
    inputs: Vec<PathBuf>,
}

#[pymethods]
impl NativeOutput {
    /// Locks `dir` and creates its staging directory (nothing is in `dir` until `commit`).
    #[staticmethod]
    fn begin(dir: PathBuf, inputs: Vec<PathBuf>) -> PyResult<Self> {
        Ok(NativeOutput { staged: Some(OutputDir::begin(&dir).map_err(err)?), inputs })
    }
    /// Where the ranks write.
    fn path(&self) -> PyResult<String> {
        let s = self.staged.as_ref().ok_or_else(|| LinpdError::new_err("committed"))?;
        Ok(s.path().display().to_string())
    }
    /// Writes `main` (the JSON text `doc`, with the run member) and swaps the directory into
    /// place; returns the paths written.
    fn commit(&mut self, main: &str, doc: &str) -> PyResult<Vec<String>> {
        let doc: serde_json::Value =
            serde_json::from_str(doc).map_err(|e| LinpdError::new_err(format!("result document: {e}")))?;
        let inputs: Vec<&Path> = self.inputs.iter().map(PathBuf::as_path).collect();
        let identity = RunIdentity::of_inputs(&inputs).map_err(err)?;
        let staged = self.staged.take().ok_or_else(|| LinpdError::new_err("committed twice"))?;
        let paths = staged.commit(main, doc, &identity).map_err(err)?;
        Ok(paths.iter().map(|p| p.display().to_string()).collect())
    }
    /// Drops the staging directory: nothing is written.
    fn discard(&mut self) {
        self.staged = None;
    }
}

/// Runs a coarsening pipeline (file or JSON text with `base_dir`) into `out` (default: the
/// pipeline's output directory), as `linpd coarsen`; returns `(output_dir, summary_json)`.
#[pyfunction]
#[pyo3(signature = (path=None, text=None, base_dir=None, out=None))]
fn coarsen(
    py: Python<'_>,
    path: Option<PathBuf>,
    text: Option<String>,
    base_dir: Option<PathBuf>,
    out: Option<PathBuf>,
) -> PyResult<(String, String)> {
    py.detach(|| {
        let (p, inputs) = match (&path, &text) {
            (Some(path), None) => (Pipeline::from_path(path)?, vec![path.clone()]),
            (None, Some(text)) => {
                (Pipeline::from_json_in(text, base_dir.as_deref().unwrap_or(Path::new(".")))?, vec![])
            }
            _ => return Err(ProblemError::invalid("pipeline", "give a path or JSON text")),
        };
        let mut inputs = inputs;
        inputs.push(p.scene_path.clone());
        let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
        let identity = RunIdentity::of_inputs(&inputs)?;
        let staged = OutputDir::begin(&out.clone().unwrap_or_else(|| p.output_dir.clone()))?;
        let r = p.run(staged.path(), &NoProgress)?;
        let dir = staged.target().display().to_string();
        let summary = r.summary_json();
        staged.commit("summary.json", summary.clone(), &identity)?;
        Ok((dir, summary.to_string()))
    })
    .map_err(err)
}

#[pymodule]
fn _linpd(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LinpdError", m.py().get_type::<LinpdError>())?;
    m.add_class::<NativeScene>()?;
    m.add_class::<NativePart>()?;
    m.add_class::<NativeOutput>()?;
    m.add_function(wrap_pyfunction!(coarsen, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
