//! The paper studies of linpd: `linpd study NAME` reproduces a figure or table of a paper
//! (data in `data.json`, PNG and SVG plots, a table on stdout).
//!
//! * `blend-*`: Seleson, Beneddine & Prudhomme (2013), section 5, Figs. 7-14, and a
//!   speed-versus-error map (module `blend`);
//! * `lps-tension-bar`: a 3D LPS tension bar against classical elasticity (module `lps`, the
//!   solve in [`lps_tension`]);
//! * `surface`: the surface corrections on a thin tension bar and a cantilever (module `surface`);
//! * `blend-2d`: the 2D/3D blended model with auto zones against pure PD (module `blend2d`);
//! * `dispersion`, `stability`: Seleson, Parks, Gunzburger & Lehoucq (2009), sections 4.2-4.3,
//!   Fig. 4.2 (module `dynamics`);
//! * `md-pd`: the same paper, section 4.4, Figs. 4.3-4.6, Table 4.1 (module `md_pd`);
//! * `multires`: the graded local mesh against pure PD (module `multires`);
//! * `penny-sneddon`: a penny crack on the graded local mesh against Sneddon (module `penny`);
//! * `meshes`: bodies from Gmsh meshes against a converged finite-element solution (module
//!   `meshes`; runs Python: gmsh, scikit-fem);
//! * `coarsen-*`: Silling (2010), section 5, Figs. 3, 5 and 7, and a 2D speed-versus-error map
//!   (module `coarsen`).
//!
//! [`Study`] is the registry: one variant per study, parsed by clap ([`clap::ValueEnum`]) so
//! that `linpd study --help` and the error for an unknown name list every study. The paper
//! fixtures (Silling's section 5 micromoduli and dense references), shared by the studies and
//! the tests, are [`fixtures`].
//!
//! ```no_run
//! use linpd_studies::{Study, StudyOptions};
//! let dir = std::path::Path::new("out/studies/coarsen-tent");
//! Study::CoarsenTent.run(dir, &StudyOptions::default(), &mut std::io::stdout())?;
//! # Ok::<(), linpd_studies::StudyError>(())
//! ```
#![deny(missing_docs)]

mod blend;
mod blend2d;
mod coarsen;
mod dynamics;
pub mod fixtures;
mod lps;
pub mod lps_tension;
mod md_pd;
mod meshes;
mod multires;
mod out;
mod penny;
mod surface;

use clap::ValueEnum;
use linpd_core::progress::{NoProgress, Progress};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a study failed: the model or solver error of the case it was running, a plot, a file
/// it could not write (named), or the table stream (e.g. a closed pipe).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A blended/CE/PD model or its solve (`blend-*`).
    #[error(transparent)]
    Blend(#[from] linpd_blend::BlendError),
    /// A coarsening step or a level's solve (`coarsen-*`).
    #[error(transparent)]
    Coarsen(#[from] linpd_coarsen::CoarsenError),
    /// A grid, micromodulus or operator of linpd-core.
    #[error(transparent)]
    Core(#[from] linpd_core::CoreError),
    /// An LPS model (`dispersion`'s lattice cases).
    #[error(transparent)]
    Lps(#[from] linpd_lps::LpsError),
    /// The LPS tension bar (`lps-tension-bar`).
    #[error(transparent)]
    TensionBar(#[from] lps_tension::TensionError),
    /// A dynamics run (`dispersion`, `stability`, `md-pd`).
    #[error(transparent)]
    Dynamics(#[from] linpd_dynamics::DynamicsError),
    /// Drawing a figure.
    #[error("plot: {0}")]
    Plot(#[from] linpd_plot::PlotError),
    /// Writing a file of the study.
    #[error("{}: {source}", path.display())]
    File {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A result the study checks (a paper's claim it reproduces, an invariant of its setup)
    /// came out wrong.
    #[error("check failed: {0}")]
    Check(String),
    /// Writing the table to the output stream.
    #[error("writing the table: {0}")]
    Table(#[from] std::io::Error),
}

/// Every study, in the order of `linpd study list`. The clap names are the kebab-case variant
/// names (`BlendPatch` is `blend-patch`); each doc comment is the study's one-line description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum Study {
    /// Figs. 7-8: patch test (Table 2), strain spread (30) for CE, PD and blended models
    BlendPatch,
    /// Figs. 9-10: point load (Table 3), profiles and error profiles per blending
    BlendPointLoad,
    /// Fig. 11: error vs PD-region size for eps = 0.05 and 0.025
    BlendPdSize,
    /// Fig. 12: error vs bridge size for eps = 0.05 and 0.025
    BlendBridgeSize,
    /// Fig. 13: error vs point-load location
    BlendLoadLocation,
    /// Fig. 14: weighted error (35) and speedup vs CE mesh ratio 1..512 (dx = 1e-4)
    BlendSpeedup,
    /// wall time vs relative error: PD, CE, blended x blending x CE mesh ratio
    BlendSpeedVsError,
    /// LPS tension bar vs classical elasticity, with and without surface correction
    LpsTensionBar,
    /// Surface corrections (none / energy / position_aware), bond and LPS: tension bar and cantilever vs h and delta/h
    Surface,
    /// 2D/3D blended PD / local elasticity (auto zones) vs pure PD: edge crack, hole, notched block; error vs entries and time
    #[value(name = "blend-2d")]
    Blend2d,
    /// Seleson et al. 2009 sec. 4.2: omega(k) lattice vs continuum vs (4.8)/(4.9) vs measured (Verlet), N = 1, 5, 20; 2D/3D Bloch dispersion of bond/LPS
    Dispersion,
    /// Seleson et al. 2009 Fig. 4.2: (4.12) vs exact limit vs measured square-pulse blow-up over dx
    Stability,
    /// Seleson et al. 2009 sec. 4.4 (Figs. 4.3-4.6, Table 4.1): MD vs fine/coarse PD vs CCM, smooth and square pulses
    MdPd,
    /// Graded local mesh (issue #31) vs pure PD, same run: edge-cracked plate 65k-1M nodes, error vs unknowns and time
    Multires,
    /// Penny crack (a = 0.1, delta = 3h) on the graded local mesh: max opening vs Sneddon, 69k-4.2M nodes
    PennySneddon,
    /// Meshed plate with a hole and 3D bracket (gmsh, 3 sizes, energy correction or none) vs converged P2 finite elements
    Meshes,
    /// Silling 2010 Fig. 3: C^0, C^1, C^2 vs bond distance at the centre (tent kernel)
    CoarsenTent,
    /// Silling 2010 Fig. 5: striped composite, u per level, global stretch vs F/E_eff
    CoarsenComposite,
    /// Silling 2010 Fig. 7: bar with a defect, u near it per level, jumps vs radius
    CoarsenDefect,
    /// 2D bond-based plate: (coarsening + coarse solve) / fine solve time vs error
    CoarsenSpeedVsError,
}

/// Options of [`Study::run`] that only some studies read.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Time the dense solvers in `blend-speedup` (about a minute; `linpd study --no-dense`
    /// turns it off).
    pub dense: bool,
    /// The largest lattice (nodes) `multires` and `penny-sneddon` solve, the largest mesh
    /// (elements) `meshes` solves (`linpd study --max-nodes`; `None`: all
    /// its sizes).
    pub max_nodes: Option<usize>,
    /// The Python that runs `meshes`' mesher and FE reference (`linpd study --python`).
    pub python: String,
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self { dense: true, max_nodes: None, python: "python3".into() }
    }
}

impl Study {
    /// Every study, in registry order.
    pub fn all() -> &'static [Study] {
        Self::value_variants()
    }

    /// The study's name on the command line (e.g. `blend-patch`).
    pub fn name(&self) -> String {
        self.possible_value().get_name().to_string()
    }

    /// One line saying what the study reproduces (the variant's doc comment).
    pub fn description(&self) -> String {
        self.possible_value().get_help().map(ToString::to_string).unwrap_or_default()
    }

    /// The study named `name` (its kebab-case name), if any.
    pub fn from_name(name: &str) -> Option<Study> {
        Self::all().iter().copied().find(|s| s.name() == name)
    }

    /// The default output directory: `out/studies/<name>` (relative to the working directory).
    pub fn default_out_dir(&self) -> PathBuf {
        Path::new("out/studies").join(self.name())
    }

    /// Runs the study: writes `data.json` and the PNG/SVG figures into `out_dir` (created if
    /// needed) and its table to `out` (the CLI passes stdout).
    pub fn run(&self, out_dir: &Path, options: &StudyOptions, report: &mut dyn Write) -> Result<(), StudyError> {
        self.run_with_progress(out_dir, options, report, &NoProgress)
    }

    /// [`Study::run`] reporting to `progress`: a task `"<study>: cases"` whose steps are the
    /// study's cases ("case i of n: `<label>`"), with the tasks of their solves and coarsening
    /// steps nested where the study passes them on.
    pub fn run_with_progress(
        &self,
        out_dir: &Path,
        options: &StudyOptions,
        report: &mut dyn Write,
        progress: &dyn Progress,
    ) -> Result<(), StudyError> {
        let dir = out_dir;
        match self {
            Study::BlendPatch => blend::patch(dir, report, progress),
            Study::BlendPointLoad => blend::point_load(dir, report, progress),
            Study::BlendPdSize => blend::pd_size(dir, report, progress),
            Study::BlendBridgeSize => blend::bridge_size(dir, report, progress),
            Study::BlendLoadLocation => blend::load_location(dir, report, progress),
            Study::BlendSpeedup => blend::speedup(dir, options.dense, report, progress),
            Study::BlendSpeedVsError => blend::speed_vs_error(dir, report, progress),
            Study::LpsTensionBar => lps::run(dir, report, progress),
            Study::Surface => surface::run(dir, report, progress),
            Study::Blend2d => blend2d::run(dir, report, progress),
            Study::Dispersion => dynamics::run_dispersion(dir, report, progress),
            Study::Stability => dynamics::run_stability(dir, report, progress),
            Study::MdPd => md_pd::run(dir, report, progress),
            Study::Multires => multires::run(dir, options.max_nodes, report, progress),
            Study::PennySneddon => penny::run(dir, options.max_nodes, report, progress),
            Study::Meshes => meshes::run(dir, options.max_nodes, &options.python, report, progress),
            Study::CoarsenTent => coarsen::tent_study(dir, report, progress),
            Study::CoarsenComposite => coarsen::composite_study(dir, report, progress),
            Study::CoarsenDefect => coarsen::defect_study(dir, report, progress),
            Study::CoarsenSpeedVsError => coarsen::speed_vs_error(dir, report, progress),
        }
    }

    fn possible_value(&self) -> clap::builder::PossibleValue {
        // Every variant has a name: none is `#[value(skip)]`.
        self.to_possible_value().expect("no study is skipped")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names are the ones `linpd study` accepted before the registry (docs/studies/README.md
    /// and the committed outputs under docs/studies/ use them), in `linpd study list` order.
    #[test]
    fn registry_names_are_the_cli_names() {
        let names: Vec<String> = Study::all().iter().map(Study::name).collect();
        assert_eq!(
            names,
            [
                "blend-patch",
                "blend-point-load",
                "blend-pd-size",
                "blend-bridge-size",
                "blend-load-location",
                "blend-speedup",
                "blend-speed-vs-error",
                "lps-tension-bar",
                "surface",
                "blend-2d",
                "dispersion",
                "stability",
                "md-pd",
                "multires",
                "penny-sneddon",
                "meshes",
                "coarsen-tent",
                "coarsen-composite",
                "coarsen-defect",
                "coarsen-speed-vs-error",
            ]
        );
        for s in Study::all() {
            assert_eq!(Study::from_name(&s.name()), Some(*s));
            assert!(!s.description().is_empty(), "{s:?} has no description");
            assert_eq!(s.default_out_dir(), Path::new("out/studies").join(s.name()));
        }
        assert_eq!(Study::from_name("list"), None);
    }
}
