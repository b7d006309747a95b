//! The `linpd` command line: parses the arguments, calls the library crates, prints the
//! results. The studies are in `linpd-studies`, the benchmarks in `linpd-bench`; this crate
//! only adds the solution plots of `solve` and `run` (module `plots`).
//!
//! Each command is a module of `commands` with one function taking the command's parsed
//! arguments.
//!
//! The binary itself (`src/main.rs` of the facade package) only calls [`main`].
#![deny(missing_docs)]
// Bad input is reported, never a panic: no unwrap/expect outside tests.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use linpd_core::progress::Progress;
use linpd_problem::{Problem, ProblemError, RunIdentity};
use linpd_studies::Study;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Duration;

/// `println!` that returns an error instead of panicking when stdout is closed
/// (`linpd solve scene.json | head -1`); [`main`] exits quietly on a broken pipe.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*).map_err($crate::CliError::Stdout)
    }};
}

mod commands;
mod plots;

/// Linear peridynamics: sparse operators and static solves from JSON scenes.
///
/// A scene file describes the grid, the model, constraints, loads and the solver; see
/// docs/problem-format.md. Example: `linpd solve data/bar-point-load.json`.
#[derive(Parser)]
#[command(name = "linpd", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve a static scene; write result.json, u.csv and plots (PNG and SVG).
    Solve {
        /// The scene file (JSON).
        scene: PathBuf,
        /// Output directory (default: the scene's output.dir, else out/<name>); replaced as a
        /// whole, only when the run succeeds.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print no progress messages (no phase lines, no progress bars).
        #[arg(long, short)]
        quiet: bool,
    },
    /// The lowest natural frequencies and mode shapes of a scene with a "density" (lumped mass
    /// rho V per node; free-free bodies too: their zero modes are reported apart); write
    /// modes.json and mode-<k>.vtu.
    Modes {
        /// The scene file (JSON) with a "density".
        scene: PathBuf,
        /// How many elastic modes (the lowest).
        #[arg(long, default_value_t = 6)]
        count: usize,
        /// Output directory (default: the scene's output.dir, else out/<name>); replaced as a
        /// whole, only when the run succeeds.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print no progress messages.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run a scene's explicit dynamics (velocity Verlet); write history.json (energies),
    /// u_<step>.csv snapshots and plots (1D: space-time map of u, energies).
    Run {
        /// The scene file (JSON) with a "dynamics" section.
        scene: PathBuf,
        /// Output directory (default: the scene's output.dir, else out/<name>); replaced as a
        /// whole, only when the run succeeds.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print no progress messages (no phase lines, no progress bars).
        #[arg(long, short)]
        quiet: bool,
    },
    /// Coarsen a scene's model over several levels (Silling 2010); write per level the coarsened
    /// moduli (level-<m>.mtx + level-<m>.nodes.csv) and a JSON summary; optionally solve the
    /// scene's problem at every level and compare at the shared nodes. See docs/coarsening.md.
    Coarsen {
        /// The pipeline file (JSON).
        pipeline: PathBuf,
        /// Output directory (default: the pipeline's output.dir, else out/<name>); replaced as a
        /// whole, only when the run succeeds.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print no progress messages (no phase lines, no progress bars).
        #[arg(long, short)]
        quiet: bool,
    },
    /// Export the reduced linear system of a static scene, A_ff u_f = f_f - (A u_bar)_f, for
    /// another solver: K.mtx (A_ff) and f.mtx (Matrix Market, 1-based, general), dofs.csv
    /// (row,node,component) and export.json. See docs/problem-format.md.
    Export {
        /// The scene file (JSON).
        scene: PathBuf,
        /// Output directory; replaced as a whole, only when the export succeeds.
        #[arg(long)]
        out: PathBuf,
        /// File format: `mtx` (Matrix Market: K.mtx, f.mtx) or `petsc` (PETSc binary: K.petsc
        /// with K.petsc.info giving the block size, f.petsc, coords.petsc for rigid-body modes),
        /// `petsc64` for a PETSc built with 64-bit indices.
        #[arg(long, value_enum, default_value_t = ExportFormat::Mtx)]
        format: ExportFormat,
        /// Print no progress messages (no phase lines, no progress bars).
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check a scene without solving it; prints a summary.
    Validate {
        /// The scene file (JSON).
        scene: PathBuf,
    },
    /// Benchmark assembly, factorization, matvec and CG on standard cases; write JSON.
    Bench(linpd_bench::BenchArgs),
    /// Reproduce a paper study: writes data.json, PNG and SVG plots, prints a table.
    ///
    /// Studies: blend-patch, blend-point-load, blend-pd-size, blend-bridge-size,
    /// blend-load-location, blend-speedup, blend-speed-vs-error (Seleson, Beneddine &
    /// Prudhomme 2013, Figs. 7-14); lps-tension-bar; surface (surface corrections on a thin bar
    /// and a cantilever); dispersion, stability, md-pd (Seleson,
    /// Parks, Gunzburger & Lehoucq 2009, section 4); coarsen-tent, coarsen-composite,
    /// coarsen-defect, coarsen-speed-vs-error (Silling 2010, Figs. 3, 5, 7, and a 2D
    /// speed-vs-error map).
    Study {
        /// The study name (e.g. blend-point-load); `list` prints them all.
        #[arg(value_parser = study_names())]
        name: String,
        /// Output directory (default out/studies/<name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Skip the dense-solver timings of blend-speedup (they take about a minute).
        #[arg(long)]
        no_dense: bool,
        /// multires, penny-sneddon: solve only the lattices of at most this many nodes;
        /// meshes: the meshes of at most this many elements.
        #[arg(long)]
        max_nodes: Option<usize>,
        /// meshes: the Python with gmsh, meshio, scikit-fem and pyamg.
        #[arg(long, default_value = "python3")]
        python: String,
    },
}

/// The accepted study names: `list`, then every [`Study`] (with its description for `--help`).
fn study_names() -> PossibleValuesParser {
    let list = PossibleValue::new("list").help("print every study with a one-line description");
    PossibleValuesParser::new(
        std::iter::once(list).chain(Study::value_variants().iter().filter_map(ValueEnum::to_possible_value)),
    )
}

/// Why a command failed. Each message names its file once: the scene or pipeline file for what
/// is wrong in it (read, validation and solve errors alike), the output file for a failed write.
#[derive(Debug, thiserror::Error)]
enum CliError {
    /// A scene or pipeline file: invalid, or its solve failed.
    #[error("{}", in_file(file, source))]
    Input {
        /// The file given on the command line.
        file: PathBuf,
        /// What went wrong.
        source: Box<ProblemError>,
    },
    /// Writing the results (the error names the output file).
    #[error("{0}")]
    Output(Box<ProblemError>),
    /// Drawing a plot.
    #[error("plot: {0}")]
    Plot(#[from] linpd_plot::PlotError),
    /// A study.
    #[error("study {name}: {source}")]
    Study {
        /// The study's name.
        name: String,
        /// What went wrong.
        source: linpd_studies::StudyError,
    },
    /// `linpd study NAME` with a name clap let through but the registry does not know.
    #[error("unknown study `{0}`")]
    UnknownStudy(String),
    /// A benchmark.
    #[error("bench: {0}")]
    Bench(#[from] linpd_bench::BenchError),
    /// Writing to standard output.
    #[error("stdout: {0}")]
    Stdout(std::io::Error),
}

impl CliError {
    /// Standard output was closed by its reader (`| head`): not worth an error message.
    fn is_broken_pipe(&self) -> bool {
        match self {
            CliError::Stdout(e) | CliError::Study { source: linpd_studies::StudyError::Table(e), .. } => {
                e.kind() == std::io::ErrorKind::BrokenPipe
            }
            _ => false,
        }
    }
}

/// `file: error`, unless the error already starts with the file (a read error names it).
fn in_file(file: &std::path::Path, e: &ProblemError) -> String {
    match e {
        ProblemError::Io { .. } => e.to_string(),
        _ => format!("{}: {e}", file.display()),
    }
}

/// File format of `linpd export`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ExportFormat {
    /// Matrix Market (`K.mtx`, `f.mtx`), 1-based, readable by every sparse library.
    Mtx,
    /// PETSc binary (`K.petsc`, `f.petsc`, `coords.petsc`), read by MatLoad/VecLoad on any
    /// number of ranks: 32-bit indices (a default PETSc build).
    Petsc,
    /// PETSc binary with 64-bit indices (a PETSc configured `--with-64-bit-indices`).
    Petsc64,
}

fn input(file: &std::path::Path) -> impl Fn(ProblemError) -> CliError + '_ {
    move |source| CliError::Input { file: file.to_path_buf(), source: Box::new(source) }
}

fn output(e: ProblemError) -> CliError {
    CliError::Output(Box::new(e))
}

/// The identity of a run of `scene`: its bytes' hash and, for a coarsened level, the moduli
/// file's (see [`RunIdentity`]).
fn scene_identity(problem: &Problem, scene: &Path) -> Result<RunIdentity, CliError> {
    let others = problem.model().inputs();
    let inputs: Vec<&Path> = std::iter::once(scene).chain(others.iter().map(PathBuf::as_path)).collect();
    RunIdentity::of_inputs(&inputs).map_err(input(scene))
}

/// Parses the command line, runs the command, prints errors to stderr.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs the parsed command: one function per command, in module `commands`.
fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Solve { scene, out, quiet } => commands::solve(&scene, out, quiet),
        Command::Run { scene, out, quiet } => commands::run(&scene, out, quiet),
        Command::Modes { scene, count, out, quiet } => commands::modes(&scene, count, out, quiet),
        Command::Export { scene, out, format, quiet } => commands::export(&scene, &out, format, quiet),
        Command::Validate { scene } => commands::validate(&scene),
        Command::Coarsen { pipeline, out, quiet } => commands::coarsen(&pipeline, out, quiet),
        Command::Bench(args) => commands::bench(&args),
        Command::Study { name, out, no_dense, max_nodes, python } => {
            commands::study(name, out, no_dense, max_nodes, python)
        }
    }
}

/// The command line's [`Progress`]: every phase line as `[linpd] <line>` on stderr (unless
/// `-q`), and the tasks as indicatif progress bars on stderr, only when stderr is a terminal
/// (and not `-q`): a bar with ETA for a task with a known total (time steps, coarsening levels,
/// local solves, assembly, study cases), a spinner with the message for one without (CG and
/// GMRES: iteration and relative residual). Nested tasks stack as lines under their parent.
/// Redirected or captured stderr gets the phase lines only: no `\r`, no escape sequences.
struct Reporter {
    quiet: bool,
    /// `None`: no bars (quiet, or stderr is not a terminal).
    bars: Option<MultiProgress>,
    /// The open tasks, innermost last.
    open: Mutex<Vec<ProgressBar>>,
}

impl Reporter {
    fn new(quiet: bool) -> Self {
        // indicatif hides a stderr target that is not a terminal by itself; checking here as
        // well means no bar state (nor the spinner's tick thread) exists then.
        let bars = (!quiet && std::io::stderr().is_terminal())
            .then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr()));
        Reporter { quiet, bars, open: Mutex::new(Vec::new()) }
    }

    /// Runs `f` with the bars cleared from the screen (for lines printed while they show).
    fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.bars {
            Some(m) => m.suspend(f),
            None => f(),
        }
    }

    fn open(&self) -> std::sync::MutexGuard<'_, Vec<ProgressBar>> {
        self.open.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Progress for Reporter {
    fn phase(&self, line: &str) {
        if !self.quiet {
            self.suspend(|| eprintln!("[linpd] {line}"));
        }
    }
    fn tracks_tasks(&self) -> bool {
        self.bars.is_some()
    }
    fn start(&self, task: &str, total: Option<u64>) {
        let Some(multi) = &self.bars else { return };
        let bar = match total {
            Some(n) => ProgressBar::new(n).with_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} [{elapsed} elapsed, {eta} left] {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            ),
            None => ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{spinner} {prefix} [{elapsed}] {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            ),
        };
        let bar = multi.add(bar.with_prefix(task.to_string()));
        if total.is_none() {
            // A spinner moves (and its clock runs) between updates: factorizations send none.
            bar.enable_steady_tick(Duration::from_millis(100));
        }
        self.open().push(bar);
    }
    fn set(&self, done: u64, message: &str) {
        if let Some(bar) = self.open().last() {
            bar.set_position(done);
            bar.set_message(message.to_string());
        }
    }
    fn finish(&self) {
        let bar = self.open().pop();
        if let (Some(bar), Some(multi)) = (bar, &self.bars) {
            bar.finish_and_clear();
            multi.remove(&bar);
        }
    }
}

/// A study's table stream written with the progress bars out of the way.
struct Suspending<'a, W>(&'a Reporter, W);

impl<W: std::io::Write> std::io::Write for Suspending<'_, W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let Suspending(bars, w) = self;
        bars.suspend(|| w.write(buf))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        let Suspending(bars, w) = self;
        bars.suspend(|| w.flush())
    }
}

/// A study's table stream that stops writing when the reader goes away (`linpd study NAME |
/// head`): the study still writes all its files, it only loses the rest of its table.
struct UntilClosed<W>(Option<W>);

impl<W: std::io::Write> std::io::Write for UntilClosed<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let Some(w) = &mut self.0 else { return Ok(buf.len()) };
        match w.write(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                self.0 = None;
                Ok(buf.len())
            }
            other => other,
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.0 {
            Some(w) => match w.flush() {
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                    self.0 = None;
                    Ok(())
                }
                other => other,
            },
            None => Ok(()),
        }
    }
}
