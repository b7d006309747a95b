//! Progress reporting from long computations, without a terminal dependency.
//!
//! The library crates report through [`Progress`]; the `linpd` command line implements it with
//! progress bars (and prints the phase lines as `[linpd] ...`), tests implement it to record
//! what arrived, and everything else passes [`NoProgress`]. Two kinds of report:
//!
//! * **phase lines** ([`Progress::phase`]): one line per phase of a run ("assembling: ...",
//!   "solving: ...", "done in ..."), meant to be printed as they come;
//! * **tasks** ([`Progress::start`], [`Progress::set`], [`Progress::finish`]): a unit of work
//!   with a count of steps done (CG iterations, time steps, coarsening levels, local solves,
//!   study cases), total known or not, meant for a progress bar or a spinner.
//!
//! Tasks nest: a task started while another is open is its sub-task (the local solves of a
//! coarsening level inside the task of the levels), and [`Progress::finish`] closes the
//! innermost open task. `start` and `finish` come from the thread that runs the computation;
//! `set` may come from any thread (rayon workers) and refers to the innermost open task.
//!
//! Code that reports opens a [`Task`], which is throttled ([`Task::due`] is true at most every
//! [`REPORT_INTERVAL`] and costs one `Instant::now` and one atomic load otherwise, nothing at
//! all when the receiver does not track tasks) and finishes the task when dropped, error paths
//! included.
//!
//! ```
//! use linpd_core::progress::{NoProgress, Progress, Task};
//! fn work(progress: &dyn Progress) {
//!     progress.phase("working: 100 items");
//!     let task = Task::start(progress, "items", Some(100));
//!     for i in 1..=100u64 {
//!         if task.due() {
//!             task.set(i, &format!("item {i}"));
//!         }
//!     }
//! } // the task is finished here
//! work(&NoProgress);
//! work(&|line: &str| println!("{line}")); // a closure receives the phase lines only
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How often a [`Task`] passes updates on at most (10 per second: a bar looks live, and the
/// receiver's cost, a formatted message and a terminal write, stays negligible).
pub const REPORT_INTERVAL: Duration = Duration::from_millis(100);

/// A receiver of progress reports (see the module docs). Every method has a no-op default;
/// `Sync` so that parallel (rayon) code can report.
pub trait Progress: Sync {
    /// One line naming a phase of the run (printed as `[linpd] <line>` by the command line).
    fn phase(&self, _line: &str) {}
    /// Whether this receiver shows tasks at all; `false` lets [`Task`] skip even the clock.
    fn tracks_tasks(&self) -> bool {
        true
    }
    /// A task begins: `task` names it, `total` is the number of steps when known (`None`: a
    /// count with no known end, such as the iterations of CG).
    fn start(&self, _task: &str, _total: Option<u64>) {}
    /// `done` steps of the innermost open task are done; `message` says more (for CG the
    /// iteration and the relative residual), possibly empty.
    fn set(&self, _done: u64, _message: &str) {}
    /// The innermost open task ended.
    fn finish(&self) {}
}

/// Reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn tracks_tasks(&self) -> bool {
        false
    }
}

/// A closure receives the phase lines and no task (the form of the `progress` argument before
/// tasks existed: `&|line: &str| eprintln!("{line}")`).
impl<F: Fn(&str) + Sync> Progress for F {
    fn phase(&self, line: &str) {
        self(line)
    }
    fn tracks_tasks(&self) -> bool {
        false
    }
}

/// An open task of a [`Progress`] receiver: started by [`Task::start`], finished on drop.
pub struct Task<'a> {
    progress: &'a dyn Progress,
    on: bool,
    t0: Instant,
    /// Nanoseconds since `t0` before which [`Task::due`] is false.
    next: AtomicU64,
    /// Steps counted by [`Task::advance`].
    count: AtomicU64,
}

impl<'a> Task<'a> {
    /// Starts task `name` with `total` steps (if known) on `progress`.
    pub fn start(progress: &'a dyn Progress, name: &str, total: Option<u64>) -> Self {
        let on = progress.tracks_tasks();
        if on {
            progress.start(name, total);
        }
        Task { progress, on, t0: Instant::now(), next: AtomicU64::new(0), count: AtomicU64::new(0) }
    }

    /// True when an update should be sent now: on the first call, then at most once per
    /// [`REPORT_INTERVAL`] (one caller wins when threads race); always false when the receiver
    /// does not track tasks. Cheap enough for every iteration of a loop whose body does a
    /// matrix-vector product.
    #[inline]
    pub fn due(&self) -> bool {
        if !self.on {
            return false;
        }
        let now = self.t0.elapsed().as_nanos() as u64;
        let next = self.next.load(Ordering::Relaxed);
        now >= next
            && self
                .next
                .compare_exchange(next, now + REPORT_INTERVAL.as_nanos() as u64, Ordering::Relaxed, Ordering::Relaxed)
                .is_ok()
    }

    /// Sends `done` and `message` now (unthrottled: for the final count, or after [`Task::due`]).
    pub fn set(&self, done: u64, message: &str) {
        if self.on {
            self.progress.set(done, message);
        }
    }

    /// Counts `steps` more steps done (from any thread: parallel loops call it per item or per
    /// chunk of items) and, when [`Task::due`], reports the count with an empty message.
    #[inline]
    pub fn advance(&self, steps: u64) {
        if self.on {
            let done = self.count.fetch_add(steps, Ordering::Relaxed) + steps;
            if self.due() {
                self.progress.set(done, "");
            }
        }
    }

    /// Whether the receiver tracks tasks (false: every update is dropped anyway).
    pub fn is_on(&self) -> bool {
        self.on
    }
}

impl Drop for Task<'_> {
    fn drop(&mut self) {
        if self.on {
            self.progress.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Log(Mutex<Vec<String>>);
    impl Progress for Log {
        fn phase(&self, line: &str) {
            self.0.lock().unwrap().push(format!("phase {line}"));
        }
        fn start(&self, task: &str, total: Option<u64>) {
            self.0.lock().unwrap().push(format!("start {task} {total:?}"));
        }
        fn set(&self, done: u64, message: &str) {
            self.0.lock().unwrap().push(format!("set {done} {message}"));
        }
        fn finish(&self) {
            self.0.lock().unwrap().push("finish".into());
        }
    }

    #[test]
    fn a_task_is_throttled_and_finished_on_drop() {
        let log = Log::default();
        {
            let task = Task::start(&log, "t", Some(3));
            assert!(task.due(), "the first call is due");
            task.set(1, "one");
            assert!(!task.due(), "the second, within the interval, is not");
            task.set(3, "");
        }
        let got = log.0.into_inner().unwrap();
        assert_eq!(got, ["start t Some(3)", "set 1 one", "set 3 ", "finish"]);
    }

    #[test]
    fn no_progress_and_closures_track_no_task() {
        let task = Task::start(&NoProgress, "t", None);
        assert!(!task.due() && !task.is_on());
        let lines = Mutex::new(Vec::new());
        let f = |l: &str| lines.lock().unwrap().push(l.to_string());
        f.phase("hello");
        assert!(!Task::start(&f, "t", None).due());
        assert_eq!(lines.into_inner().unwrap(), ["hello"]);
    }
}
