//! Issue #15 item 9, "long work is silent": the library reports progress through
//! `linpd::core::progress::Progress` (CG iterations and residuals, time steps, coarsening levels
//! and their local solves), and the `linpd` binary keeps its captured stderr free of progress
//! bars (no `\r`, no escape sequences) while still printing the `[linpd]` phase lines.

use linpd::core::progress::Progress;
use linpd::problem::Commands;
use linpd::problem::{Pipeline, Problem};
use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;

/// One report received.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    Phase(String),
    Start(String, Option<u64>),
    Set(u64, String),
    Finish,
}

/// Records every report, in order.
#[derive(Default)]
struct Recorder(Mutex<Vec<Event>>);

impl Progress for Recorder {
    fn phase(&self, line: &str) {
        self.0.lock().unwrap().push(Event::Phase(line.to_string()));
    }
    fn start(&self, task: &str, total: Option<u64>) {
        self.0.lock().unwrap().push(Event::Start(task.to_string(), total));
    }
    fn set(&self, done: u64, message: &str) {
        self.0.lock().unwrap().push(Event::Set(done, message.to_string()));
    }
    fn finish(&self) {
        self.0.lock().unwrap().push(Event::Finish);
    }
}

impl Recorder {
    fn events(self) -> Vec<Event> {
        self.0.into_inner().unwrap()
    }
}

/// The updates `(done, message)` of one task.
type Updates = Vec<(u64, String)>;

/// The updates of every task named `name` (by prefix), per task, with the task's total; panics
/// when the starts and finishes do not nest.
fn updates(events: &[Event], name: &str) -> Vec<(Option<u64>, Updates)> {
    let mut open: Vec<(String, Option<u64>, Updates)> = Vec::new();
    let mut done = Vec::new();
    for e in events {
        match e {
            Event::Phase(_) => {}
            Event::Start(task, total) => open.push((task.clone(), *total, Vec::new())),
            Event::Set(k, m) => open.last_mut().expect("an update outside any task").2.push((*k, m.clone())),
            Event::Finish => {
                let (task, total, sets) = open.pop().expect("a finish without a start");
                if task.starts_with(name) {
                    done.push((total, sets));
                }
            }
        }
    }
    assert!(open.is_empty(), "tasks never finished: {:?}", open.iter().map(|t| &t.0).collect::<Vec<_>>());
    done
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linpd-progress-test-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `"iteration <k>, relative residual <r>"` -> `(k, r)`.
fn cg_update(message: &str) -> (u64, f64) {
    let (it, res) = message
        .strip_prefix("iteration ")
        .and_then(|m| m.split_once(", relative residual "))
        .unwrap_or_else(|| panic!("a CG update reads {message:?}"));
    (it.parse().unwrap(), res.parse().unwrap())
}

#[test]
fn item_9_long_work_reports_progress() {
    // 1. CG (matrix-free, 28k unknowns): iterations and relative residuals.
    let problem = Problem::from_path(&root().join("data/cube-compression-3d-cg.json")).unwrap();
    let rec = Recorder::default();
    let solution = problem.solve(&rec).unwrap();
    let iterations = solution.report.iterations.expect("a CG report has iterations") as u64;
    let events = rec.events();
    assert!(events.iter().any(|e| matches!(e, Event::Phase(l) if l.starts_with("solving"))), "no phase line");
    let cg = updates(&events, "CG");
    assert_eq!(cg.len(), 1, "one CG task");
    let (total, sets) = &cg[0];
    assert_eq!(*total, None, "CG has no known total");
    assert!(!sets.is_empty(), "no CG update arrived");
    let mut last = 0;
    for (k, message) in sets {
        let (it, res) = cg_update(message);
        assert_eq!(it, *k, "{message}");
        assert!(it >= last, "iterations went back: {it} after {last}");
        assert!(res.is_finite() && res > 0.0, "residual {res} in {message:?}");
        last = it;
    }
    assert!(last <= iterations, "last update at iteration {last}, the report says {iterations}");
    assert_eq!(last, iterations, "the final count is reported");
    println!("CG: {} updates, last at iteration {last} of {iterations}", sets.len());

    // 2. Dynamics: the time steps reach the final step count.
    let problem = Problem::from_path(&root().join("data/wave-square-pulse-1d.json")).unwrap();
    let rec = Recorder::default();
    let run = problem.run_dynamics(&rec).unwrap();
    let steps = updates(&rec.events(), "time steps");
    assert_eq!(steps.len(), 1, "one time-step task");
    let (total, sets) = &steps[0];
    assert_eq!(*total, Some(run.steps as u64));
    assert!(sets.windows(2).all(|w| w[0].0 <= w[1].0), "steps went back: {sets:?}");
    assert_eq!(sets.last().map(|s| s.0), Some(run.steps as u64), "updates stop short of {} steps", run.steps);

    // 3. Coarsening: a task of the levels, and one task of local solves per level (fixed radii).
    let dir = temp_dir("coarsen");
    let pipeline = dir.join("p.pipeline.json");
    let scene = root().join("data/coarsen-composite-bar.json");
    std::fs::write(
        &pipeline,
        format!(
            r#"{{"name": "p", "scene": "{}", "levels": [{{"every": 2, "radius": 0.2}}, {{"every": 2, "radius": 0.4}}, {{"every": 2, "radius": 0.8}}], "solve": true}}"#,
            scene.display()
        ),
    )
    .unwrap();
    let p = Pipeline::from_path(&pipeline).unwrap();
    let rec = Recorder::default();
    let result = p.run(&dir.join("out"), &rec).unwrap();
    let n_levels = result.levels.len() as u64 - 1;
    assert_eq!(n_levels, 3);
    let events = rec.events();
    let local = updates(&events, "local solves");
    assert_eq!(local.len() as u64, n_levels, "one task of local solves per level");
    for (total, sets) in &local {
        assert_eq!(sets.last().map(|s| s.0), *total, "the local solves reach their total");
    }
    let levels = updates(&events, "coarsening levels");
    assert_eq!(levels.len(), 1);
    let (total, sets) = &levels[0];
    assert_eq!(*total, Some(n_levels));
    let messages: Vec<&str> = sets.iter().map(|s| s.1.as_str()).filter(|m| !m.is_empty()).collect();
    assert_eq!(messages, ["level 1 of 3", "level 2 of 3", "level 3 of 3"]);
    assert_eq!(sets.last().map(|s| s.0), Some(n_levels));
    // The local solves of a level run inside the levels' task.
    let first_local = events.iter().position(|e| matches!(e, Event::Start(t, _) if t.starts_with("local solves")));
    let levels_start = events.iter().position(|e| matches!(e, Event::Start(t, _) if t == "coarsening levels"));
    assert!(levels_start < first_local);
    let _ = std::fs::remove_dir_all(&dir);
}

fn linpd(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_linpd")).args(args).output().expect("the linpd binary runs")
}

/// No carriage return and no escape sequence: what a progress bar would leave in a log.
fn assert_plain(stderr: &str, what: &str) {
    assert!(!stderr.contains('\r'), "{what}: a carriage return on captured stderr:\n{stderr:?}");
    assert!(!stderr.contains('\x1b'), "{what}: an escape sequence on captured stderr:\n{stderr:?}");
}

#[test]
fn item_9_captured_stderr_has_phase_lines_and_no_bars() {
    let dir = temp_dir("cli");
    let data = |f: &str| root().join("data").join(f).display().to_string();
    let out = |tag: &str| dir.join(tag).display().to_string();
    let runs: [(&str, Vec<String>); 3] = [
        ("solve", vec!["solve".into(), data("cube-compression-3d-cg.json")]),
        ("run", vec!["run".into(), data("wave-square-pulse-1d.json")]),
        ("coarsen", vec!["coarsen".into(), data("coarsen-defect-bar.pipeline.json")]),
    ];
    for (tag, args) in &runs {
        let loud = out(&format!("{tag}-loud"));
        let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
        a.extend(["--out", &loud]);
        let o = linpd(&a);
        let stderr = String::from_utf8(o.stderr).unwrap();
        assert!(o.status.success(), "linpd {tag}: {stderr}");
        assert_plain(&stderr, tag);
        let lines: Vec<&str> = stderr.lines().collect();
        assert!(lines.len() >= 2, "linpd {tag}: phase lines expected on stderr, got {stderr:?}");
        assert!(lines.iter().all(|l| l.starts_with("[linpd] ")), "linpd {tag}: {stderr}");

        let quiet = out(&format!("{tag}-quiet"));
        let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
        a.extend(["--out", &quiet, "-q"]);
        let o = linpd(&a);
        assert!(o.status.success(), "linpd {tag} -q: {}", String::from_utf8_lossy(&o.stderr));
        assert!(o.stderr.is_empty(), "linpd {tag} -q: stderr {:?}", String::from_utf8_lossy(&o.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
