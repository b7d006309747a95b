//! Natural modes of a scene (`linpd modes`, issue #32): the lowest frequencies and mode shapes
//! of `K phi = omega^2 M phi` with the scene's stiffness over its free DOFs and a lumped mass
//! `M = rho V_i` per DOF (`density` in the scene), by shift-invert Krylov-Schur
//! ([`linpd_solve::modes`]).
//!
//! A body with fewer constraints than its rigid motions (none: free-free) has zero modes
//! (`omega^2 = 0` up to round-off); they are found with the elastic ones (the shift keeps
//! `K + s M` definite), reported apart (`zero_modes`, their `omega^2` below
//! [`ZERO_MODE_RATIO`] of the largest computed) and left out of the `count` elastic modes,
//! whose shapes are scaled to `max |phi| = 1` with that component positive.

use crate::scene::{Problem, Purpose};
use crate::ProblemError;
use linpd_core::progress::Progress;
use linpd_core::Point;
use serde::Serialize;
use std::time::Instant;

/// A computed `omega^2` below this fraction of the largest computed one is a zero (rigid) mode:
/// rigid modes come out near `1e-8` of the shift (`1e-16` of the stiffness's scale), elastic
/// ones within the lowest few dozen span far less than `1e6` in `omega^2`.
pub const ZERO_MODE_RATIO: f64 = 1e-6;

/// The relative tolerance of the shifted-inverse eigenvalues.
const TOLERANCE: f64 = 1e-10;

/// One elastic mode.
#[derive(Debug, Clone, Serialize)]
pub struct Mode {
    /// `omega^2` (rad^2 / time^2 in the scene's units).
    pub omega2: f64,
    /// `omega`.
    pub omega: f64,
    /// `omega / (2 pi)`.
    pub frequency: f64,
    /// The shape over all DOFs (`d` per node, held DOFs 0), `max |phi| = 1`.
    #[serde(skip)]
    pub shape: Vec<f64>,
}

/// The modes of a scene.
#[derive(Debug, Clone, Serialize)]
pub struct Modes {
    /// Scene name.
    pub name: String,
    /// Dimension.
    #[serde(skip)]
    pub dim: usize,
    /// Node positions.
    #[serde(skip)]
    pub x: Vec<Point>,
    /// The density of the lumped mass.
    pub density: f64,
    /// Free DOFs.
    pub unknowns: usize,
    /// `omega^2` of the zero (rigid) modes found, ascending.
    pub zero_modes: Vec<f64>,
    /// The `count` lowest elastic modes, ascending.
    pub modes: Vec<Mode>,
    /// The shift of the shift-invert (see [`linpd_solve::modes`]).
    pub shift: f64,
    /// Wall seconds of building, factorizing and solving.
    pub seconds: f64,
}

impl Problem {
    /// The `count` lowest elastic modes of the scene (see the module docs).
    ///
    /// # Errors
    /// A scene without `density`, `count` 0 or above the free DOFs, an unsymmetric model (the
    /// 2D/3D blends), or a failed factorization or eigensolve.
    pub fn modes(&self, count: usize, progress: &dyn Progress) -> Result<Modes, ProblemError> {
        let t0 = Instant::now();
        let density = self.density.ok_or_else(|| {
            ProblemError::invalid("density", "missing: linpd modes needs the mass density (lumped mass rho V per node)")
        })?;
        if count == 0 {
            return Err(ProblemError::invalid("count", "must be at least 1"));
        }
        let system = self.model.system(self, Purpose::Assembled, progress)?;
        let model = system.model();
        let dofs = system.bc.dofs();
        let n = dofs.n_free();
        if count > n {
            return Err(ProblemError::invalid(
                "count",
                format!("{count} modes asked for, the scene has {n} free DOFs"),
            ));
        }
        if model.asymmetry(dofs) > linpd_core::sparse::SYMMETRY_RTOL {
            return Err(ProblemError::invalid(
                "model",
                format!("{} has an unsymmetric stiffness: modes need a symmetric one", self.model.describe()),
            ));
        }
        let d = self.dim();
        progress.phase(&format!("assembling: {n} free DOFs"));
        let k = model.assemble_free(dofs);
        let mass: Vec<f64> = dofs.free_dofs().iter().map(|&g| density * self.nodes.volume(g / d)).collect();
        // the rigid motions a body can have: asked for on top of `count`, then set apart
        let rigid = [1, 3, 6][d - 1];
        let asked = (count + rigid).min(n);
        progress.phase(&format!("modes: the {asked} lowest of {n} DOFs (shift-invert Krylov-Schur)"));
        let r = linpd_solve::modes::lowest_modes(&k, &mass, asked, TOLERANCE)
            .map_err(|e| ProblemError::invalid("model", format!("the modes' solve failed: {e}")))?;
        drop(k);
        let top = r.omega2.iter().fold(0.0f64, |m, w| m.max(w.abs()));
        let mut zero_modes = Vec::new();
        let mut modes = Vec::new();
        for (omega2, phi) in r.omega2.into_iter().zip(r.shapes) {
            if omega2.abs() <= ZERO_MODE_RATIO * top {
                zero_modes.push(omega2);
            } else if modes.len() < count {
                let mut shape = vec![0.0; d * self.nodes.len()];
                dofs.scatter(&phi, &mut shape);
                let big = shape.iter().copied().fold(0.0f64, |m, v| if v.abs() > m.abs() { v } else { m });
                shape.iter_mut().for_each(|v| *v /= big);
                let omega = omega2.max(0.0).sqrt();
                modes.push(Mode { omega2, omega, frequency: omega / (2.0 * std::f64::consts::PI), shape });
            }
        }
        Ok(Modes {
            name: self.name.clone(),
            dim: d,
            x: (0..self.nodes.len()).map(|i| self.nodes.position(i)).collect(),
            density,
            unknowns: n,
            zero_modes,
            modes,
            shift: r.shift,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

impl Problem {
    /// The stiffness over every DOF (node-major, `d` per node) with no constraint applied: a
    /// free body's, singular by its rigid motions (`Scene.stiffness(free=True)` in Python).
    pub fn unconstrained_stiffness(&self, progress: &dyn Progress) -> Result<linpd_core::Csc, ProblemError> {
        let system = self.model.system(self, Purpose::Assembled, progress)?;
        let dofs = linpd_core::DofMap::all_free(self.nodes.len(), self.dim());
        Ok(system.model().assemble_free(&dofs))
    }

    /// The lumped mass `density V_i` per DOF (node-major, `d` per node).
    ///
    /// # Errors
    /// A scene without `density`.
    pub fn lumped_mass(&self) -> Result<Vec<f64>, ProblemError> {
        let density = self
            .density
            .ok_or_else(|| ProblemError::invalid("density", "missing: the lumped mass is density x V per node"))?;
        let d = self.dim();
        Ok((0..d * self.nodes.len()).map(|k| density * self.nodes.volume(k / d)).collect())
    }
}

impl Modes {
    /// Writes `mode-<k>.vtu` for every mode `k = 1, 2, ...` (point data `u`: the shape, 0-padded
    /// to 3 components) into `dir`; returns their paths.
    pub fn write(&self, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, ProblemError> {
        std::fs::create_dir_all(dir).map_err(|source| ProblemError::Io { path: dir.display().to_string(), source })?;
        let d = self.dim;
        let mut files = Vec::new();
        for (k, m) in self.modes.iter().enumerate() {
            let path = dir.join(format!("mode-{}.vtu", k + 1));
            let u = |i: usize, a: usize| if a < d { m.shape[d * i + a] } else { 0.0 };
            let arrays = [linpd_io::vtk::PointArray {
                name: "u",
                values: linpd_io::vtk::PointValues::Float64 { components: 3, value: &u },
            }];
            linpd_io::vtk::write_vtu_cells(&path, d, &self.x, &arrays, None).map_err(ProblemError::from)?;
            files.push(path);
        }
        Ok(files)
    }

    /// The `modes.json` document (frequencies; the shapes are in the VTU files).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }
}
