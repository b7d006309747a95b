//! Atomic output directories: a run writes all its files into a fresh staging directory beside
//! its output directory and swaps it into place only when every file is complete, so an output
//! directory always holds the complete files of exactly one run, and nothing else.
//!
//! [`OutputDir::begin`] takes the lock `<dir>.lock` (created with `O_EXCL`; it holds the pid)
//! and creates the staging directory `<dir>.tmp-<pid>-<nanos>` in the same parent, so on the
//! same filesystem, where a rename is atomic. The writers write into [`OutputDir::path`].
//! [`OutputDir::commit`] writes the run's main document (`result.json`, `history.json`,
//! `summary.json`, `export.json`, or a study's `data.json` through [`OutputDir::commit_staged`]) last, with the run's identity ([`RunIdentity`]) and the name and size of
//! every other file, then
//! 1. renames an existing `<dir>` to `<dir>.old-<pid>-<nanos>`,
//! 2. renames the staging directory to `<dir>`,
//! 3. deletes the old directory and the lock (a failure to delete it is an error naming it: a
//!    copy is never left behind silently).
//!
//! A directory that is read-only (no owner write bit, itself or a subdirectory) is refused at
//! [`OutputDir::begin`]: its files could not be deleted (as root they could, but read-only says
//! "keep these").
//!
//! Dropping an `OutputDir` without committing deletes the staging directory (and the parent
//! directories `begin` created): a failed run writes nothing and the previous results stay.
//!
//! A killed run (SIGKILL, or SIGINT: no destructor runs) leaves its lock and staging directory
//! behind; `<dir>` itself is always either the old run's or the new run's complete directory,
//! except between steps 1 and 2, when `<dir>` is missing and the old results are complete in
//! `<dir>.old-*`. The next run into `<dir>` finds the lock's process gone (Linux: `/proc`),
//! takes the lock over, renames a left-over `<dir>.old-*` back to `<dir>` if `<dir>` is missing,
//! and deletes the other left-overs. Where `/proc` is not available, the error names the lock
//! file to delete. Files are not fsynced: this protects against a killed process, not against a
//! power loss.
//!
//! Two runs into one `<dir>`: the second fails at once with "another linpd run (pid N) is
//! writing `<dir>`" while the first holds the lock.
//!
//! A run never deletes what it did not write: it replaces `<dir>` only if `<dir>` is missing,
//! empty, or a linpd output directory, i.e. it holds a main document whose `run.files` lists
//! every other entry of the directory.

use crate::ProblemError;
use serde::{Deserialize, Serialize};
use std::fs::{self, File};
use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// The file names of the main documents: a directory that holds one (and nothing it does not
/// list) was written by linpd.
pub const MAIN_DOCUMENTS: [&str; 5] = ["result.json", "history.json", "summary.json", "data.json", "export.json"];

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ProblemError + '_ {
    move |source| ProblemError::Io { path: path.display().to_string(), source }
}

fn refuse(dir: &Path, reason: impl Into<String>) -> ProblemError {
    ProblemError::Output { dir: dir.display().to_string(), reason: reason.into() }
}

/// One file of a run's output directory, as listed in its main document.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// File name inside the output directory.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
}

/// An input file of a run: where it was read from, its size and its FNV-1a 64 hash.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct InputFile {
    /// The path as given (on the command line, or resolved from a pipeline file).
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// FNV-1a 64 of the bytes ([`fnv1a64`]), 16 hex digits.
    pub fnv1a64: String,
}

/// What identifies a run in its main document (`"run"`): the linpd version, the input files
/// with their hashes, and (added by [`OutputDir::commit`]) the time and the files written.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RunIdentity {
    /// `linpd --version`.
    pub linpd_version: String,
    /// The scene, pipeline or moduli files the run read.
    pub inputs: Vec<InputFile>,
}

impl RunIdentity {
    /// Reads and hashes every input file.
    pub fn of_inputs(paths: &[&Path]) -> Result<Self, ProblemError> {
        let mut inputs = Vec::new();
        for p in paths {
            let bytes = fs::read(p).map_err(io(p))?;
            inputs.push(InputFile {
                path: p.display().to_string(),
                bytes: bytes.len() as u64,
                fnv1a64: format!("{:016x}", fnv1a64(&bytes)),
            });
        }
        Ok(Self { linpd_version: env!("CARGO_PKG_VERSION").to_string(), inputs })
    }
}

/// FNV-1a, 64 bits (offset basis 0xcbf29ce484222325, prime 0x100000001b3): not cryptographic,
/// enough to tell which version of a scene file produced a result.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// `YYYY-MM-DDThh:mm:ssZ` of seconds since the Unix epoch (proleptic Gregorian calendar,
/// Hinnant's `civil_from_days`).
pub fn utc_string(secs: u64) -> String {
    let (days, rem) = ((secs / 86400) as i64, secs % 86400);
    let z = days + 719_468;
    let (era, doe) = (z.div_euclid(146_097), z.rem_euclid(146_097));
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// A run's output directory while the run writes it (see the module docs).
#[derive(Debug)]
pub struct OutputDir {
    target: PathBuf,
    staging: PathBuf,
    lock: PathBuf,
    /// Parent directories `begin` created (deepest first), removed again if the run fails.
    created: Vec<PathBuf>,
    committed: bool,
}

impl OutputDir {
    /// Takes the lock of `dir`, checks that `dir` may be replaced, and creates the staging
    /// directory. `dir` must end in a name (not `.`, `..` or `/`).
    pub fn begin(dir: &Path) -> Result<Self, ProblemError> {
        // A symbolic link to a directory: replace the directory it points to, not the link.
        let target = match fs::symlink_metadata(dir) {
            Ok(m) if m.file_type().is_symlink() => fs::canonicalize(dir).map_err(io(dir))?,
            _ => dir.to_path_buf(),
        };
        let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
            return Err(refuse(dir, "an output directory must end in a name (not `.`, `..` or `/`)"));
        };
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let created: Vec<PathBuf> = parent
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        // Name the output directory in the error: the parent is an implementation detail.
        fs::create_dir_all(&parent).map_err(io(dir))?;
        let lock = parent.join(format!("{name}.lock"));
        let mut out = OutputDir {
            staging: parent.join(format!("{name}.tmp-{}", unique())),
            target,
            lock,
            created,
            committed: false,
        };
        if let Err(e) = take_lock(&out.lock, &out.target) {
            out.lock = PathBuf::new(); // not ours: do not delete it on drop
            return Err(e);
        }
        clean_leftovers(&parent, &name, &out.target);
        check_replaceable(&out.target)?;
        fs::create_dir(&out.staging).map_err(io(&out.staging))?;
        Ok(out)
    }

    /// Where the run writes its files.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The directory the results go to.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Writes the main document `main` (the JSON object `doc` with a `"run"` member: `identity`,
    /// the time, and the name and size of every other file written), then swaps the staging
    /// directory into place. Returns the paths of the files in their final place.
    pub fn commit(
        mut self,
        main: &str,
        mut doc: serde_json::Value,
        identity: &RunIdentity,
    ) -> Result<Vec<PathBuf>, ProblemError> {
        let files = list_files(&self.staging, main)?;
        let now = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
        if let Some(object) = doc.as_object_mut() {
            let mut run = serde_json::to_value(identity).map_err(|e| io(&self.staging)(e.into()))?;
            run["time_unix"] = now.into();
            run["time_utc"] = utc_string(now).into();
            run["files"] = serde_json::to_value(&files).map_err(|e| io(&self.staging)(e.into()))?;
            object.insert("run".into(), run);
        }
        let main_path = self.staging.join(main);
        let mut w = std::io::BufWriter::new(File::create(&main_path).map_err(io(&main_path))?);
        serde_json::to_writer_pretty(&mut w, &doc).map_err(|e| io(&main_path)(e.into()))?;
        w.flush().map_err(io(&main_path))?;
        drop(w);

        // Something may have appeared in the target since `begin`.
        check_replaceable(&self.target)?;
        let aside = self.target.with_file_name(format!("{}.old-{}", file_name(&self.target), unique()));
        let had_old = match fs::rename(&self.target, &aside) {
            Ok(()) => true,
            Err(e) if e.kind() == ErrorKind::NotFound => false,
            Err(e) => return Err(io(&self.target)(e)),
        };
        if let Err(e) = fs::rename(&self.staging, &self.target) {
            if had_old {
                let _ = fs::rename(&aside, &self.target);
            }
            return Err(io(&self.target)(e));
        }
        self.committed = true;
        if had_old {
            discard_old(&aside, &self.target, |p| fs::remove_dir_all(p))?;
        }
        let mut paths: Vec<PathBuf> = files.iter().map(|f| self.target.join(&f.name)).collect();
        paths.push(self.target.join(main));
        Ok(paths)
    }
}

impl OutputDir {
    /// [`OutputDir::commit`] for a run that wrote its main document `main` itself (a study's
    /// `data.json`): reads it back from the staging directory, adds the `"run"` member and
    /// commits. `main` must be a JSON object.
    pub fn commit_staged(self, main: &str, identity: &RunIdentity) -> Result<Vec<PathBuf>, ProblemError> {
        let path = self.staging.join(main);
        let bytes = fs::read(&path).map_err(io(&path))?;
        let doc: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| io(&path)(e.into()))?;
        if !doc.is_object() {
            return Err(refuse(&self.target, format!("{main} is not a JSON object")));
        }
        self.commit(main, doc, identity)
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
        }
        if !self.lock.as_os_str().is_empty() {
            let _ = fs::remove_file(&self.lock);
        }
        if !self.committed {
            // Only empty directories go: remove_dir fails on anything else.
            for d in &self.created {
                let _ = fs::remove_dir(d);
            }
        }
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// `<pid>-<nanoseconds since the epoch>`: unique per process and call.
fn unique() -> String {
    let nanos = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    format!("{}-{nanos}", std::process::id())
}

/// The regular files of `dir` except `main`, sorted by name.
fn list_files(dir: &Path, main: &str) -> Result<Vec<FileEntry>, ProblemError> {
    let mut files = Vec::new();
    for e in fs::read_dir(dir).map_err(io(dir))? {
        let e = e.map_err(io(dir))?;
        let name = e.file_name().to_string_lossy().into_owned();
        let meta = e.metadata().map_err(io(&e.path()))?;
        if meta.is_file() && name != main {
            files.push(FileEntry { name, bytes: meta.len() });
        }
    }
    files.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(files)
}

/// The `run.files` list of a main document (only that member is parsed).
fn listed_files(main: &Path) -> Option<Vec<FileEntry>> {
    #[derive(Deserialize)]
    struct Doc {
        run: Run,
    }
    #[derive(Deserialize)]
    struct Run {
        files: Vec<FileEntry>,
    }
    // The documents written by `commit` are pretty-printed, so a top-level member starts a line
    // with two spaces (deeper keys have more; strings hold no raw newline) and its object ends
    // at a line starting `  }`: stream the lines and parse the `run` member alone, holding one
    // line at a time, instead of reading the whole document (a 390 MB result.json at 70^3: its
    // read was 1.2 s of CPU and the peak of a re-run into the same directory, 1.45x a fresh one).
    use std::io::BufRead;
    const TOP_LEVEL_RUN: &[u8] = b"  \"run\": ";
    let mut reader = std::io::BufReader::with_capacity(1 << 16, fs::File::open(main).ok()?);
    let mut line = Vec::new();
    loop {
        line.clear();
        if reader.read_until(b'\n', &mut line).ok()? == 0 {
            break;
        }
        if line.starts_with(TOP_LEVEL_RUN) {
            let mut value = line[TOP_LEVEL_RUN.len()..].to_vec();
            // an object over several lines ends at the line that closes it at the member's indent
            if value.trim_ascii_end().ends_with(b"{") {
                loop {
                    line.clear();
                    if reader.read_until(b'\n', &mut line).ok()? == 0 {
                        break;
                    }
                    value.extend_from_slice(&line);
                    if line.starts_with(b"  }") {
                        break;
                    }
                }
            }
            let mut de = serde_json::Deserializer::from_slice(&value);
            if let Ok(run) = Run::deserialize(&mut de) {
                return Some(run.files);
            }
            break;
        }
        if line.len() > 1 << 20 {
            // one long line: not this layout; `line` holds the document read so far
            let mut bytes = std::mem::take(&mut line);
            std::io::Read::read_to_end(&mut reader, &mut bytes).ok()?;
            return serde_json::from_slice::<Doc>(&bytes).ok().map(|d| d.run.files);
        }
    }
    // another layout: the whole document (from_slice: several times faster than from_reader)
    let bytes = fs::read(main).ok()?;
    serde_json::from_slice::<Doc>(&bytes).ok().map(|d| d.run.files)
}

/// Deletes the previous run's directory, set aside at `aside` when the new one took its place at
/// `target`, with `remove` (`fs::remove_dir_all`). A failure is an error naming both (a copy
/// left behind for good, e.g. in a directory made read-only, is not a success): the new results
/// are complete in `target`.
fn discard_old(aside: &Path, target: &Path, remove: impl Fn(&Path) -> std::io::Result<()>) -> Result<(), ProblemError> {
    remove(aside).map_err(|e| {
        refuse(
            target,
            format!(
                "the new results are in place, but the previous run's files, set aside in {}, could not be \
                 deleted ({e}); delete that directory",
                aside.display()
            ),
        )
    })
}

/// `Err` naming the first directory at or under `dir` without write permission for its owner
/// (`chmod a-w`): its files could not be deleted when `dir` is replaced (as root they could,
/// but a read-only output directory says "keep these", so it is refused for everyone).
#[cfg(unix)]
fn check_writable(dir: &Path) -> Result<(), ProblemError> {
    use std::os::unix::fs::PermissionsExt;
    let mode = fs::symlink_metadata(dir).map_err(io(dir))?.permissions().mode();
    if mode & 0o200 == 0 {
        return Err(ProblemError::Output {
            dir: dir.display().to_string(),
            reason: format!(
                "is read-only (mode {:o}): linpd replaces an output directory as a whole and could not delete \
                 the files in it; make it writable (chmod u+w) or choose another output directory",
                mode & 0o7777
            ),
        });
    }
    for e in fs::read_dir(dir).map_err(io(dir))? {
        let e = e.map_err(io(dir))?;
        if e.file_type().map_err(io(dir))?.is_dir() {
            check_writable(&e.path())?;
        }
    }
    Ok(())
}

#[cfg(not(unix))]
fn check_writable(_dir: &Path) -> Result<(), ProblemError> {
    Ok(())
}

/// `Ok` if `dir` is missing, empty, or a linpd output directory (a main document listing every
/// other entry) whose directories are writable (`check_writable`); the error says why not.
pub fn check_replaceable(dir: &Path) -> Result<(), ProblemError> {
    match fs::symlink_metadata(dir) {
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io(dir)(e)),
        Ok(m) if !m.is_dir() => return Err(refuse(dir, "exists and is not a directory")),
        Ok(_) => {}
    }
    check_writable(dir)?;
    let mut entries = Vec::new();
    for e in fs::read_dir(dir).map_err(io(dir))? {
        entries.push(e.map_err(io(dir))?.file_name().to_string_lossy().into_owned());
    }
    if entries.is_empty() {
        return Ok(());
    }
    let advice = "linpd replaces its output directory as a whole; choose another output directory or move it away";
    let Some(main) = MAIN_DOCUMENTS.iter().find(|m| entries.iter().any(|e| e == *m)) else {
        return Err(refuse(
            dir,
            format!("exists and is not a linpd output directory (no {}); {advice}", MAIN_DOCUMENTS.join(", ")),
        ));
    };
    let Some(listed) = listed_files(&dir.join(main)) else {
        return Err(refuse(
            dir,
            format!("its {main} has no list of the files linpd wrote (`run.files`; an older linpd?); {advice}"),
        ));
    };
    match entries.iter().find(|e| *e != main && !listed.iter().any(|f| &f.name == *e)) {
        Some(foreign) => Err(refuse(dir, format!("holds `{foreign}`, which is not listed in its {main}; {advice}"))),
        None => Ok(()),
    }
}

/// The contents of our lock file: pid and, on Linux, the process start time (so a recycled
/// pid is not taken for a live holder).
fn lock_tag() -> String {
    let pid = std::process::id();
    match start_time(pid) {
        Some((_, start)) => format!("{pid} {start}\n"),
        None => format!("{pid}\n"),
    }
}

/// State letter and start time (clock ticks since boot) of process `pid`, from
/// `/proc/<pid>/stat`; `None` if unreadable.
fn start_time(pid: u32) -> Option<(char, u64)> {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // `pid (comm) state ...`: comm may hold spaces and parentheses, so split after the last ')'.
    let fields: Vec<&str> = stat[stat.rfind(')')? + 1..].split_whitespace().collect();
    Some((fields.first()?.chars().next()?, fields.get(19)?.parse().ok()?))
}

/// Whether the process that wrote lock contents `tag` still runs: `None` if unknown (no /proc,
/// unreadable tag).
fn holder_alive(tag: &str) -> Option<bool> {
    let mut t = tag.split_whitespace();
    let pid: u32 = t.next()?.parse().ok()?;
    let start: Option<u64> = t.next().and_then(|s| s.parse().ok());
    if !Path::new("/proc/self/stat").exists() {
        return None;
    }
    if !Path::new(&format!("/proc/{pid}")).exists() {
        return Some(false);
    }
    let (state, started) = start_time(pid)?;
    Some(!matches!(state, 'Z' | 'X') && start.is_none_or(|s| s == started))
}

/// Creates `lock` exclusively; takes over a lock whose process is gone.
///
/// Two runs that find the same stale lock at the same instant may both take it over (each
/// deletes it, then one creates it and the other may delete that); a lock-free rename in
/// [`OutputDir::commit`] still leaves `<dir>` complete, from the last run to finish.
fn take_lock(lock: &Path, dir: &Path) -> Result<(), ProblemError> {
    for _ in 0..2 {
        match File::create_new(lock) {
            Ok(mut f) => return f.write_all(lock_tag().as_bytes()).map_err(io(lock)),
            Err(e) if e.kind() == ErrorKind::AlreadyExists => {
                let tag = fs::read_to_string(lock).unwrap_or_default();
                match holder_alive(&tag) {
                    Some(false) => match fs::remove_file(lock) {
                        Ok(()) => continue,
                        Err(e) if e.kind() == ErrorKind::NotFound => continue,
                        Err(e) => return Err(io(lock)(e)),
                    },
                    Some(true) => {
                        let pid = tag.split_whitespace().next().unwrap_or("?");
                        return Err(refuse(
                            dir,
                            format!(
                                "another linpd run (pid {pid}) is writing it (lock file {})",
                                lock.display()
                            ),
                        ));
                    }
                    None => {
                        return Err(refuse(
                            dir,
                            format!(
                                "another linpd run is writing it, or one was killed: if no linpd run is writing there, delete {}",
                                lock.display()
                            ),
                        ))
                    }
                }
            }
            Err(e) => return Err(io(lock)(e)),
        }
    }
    Err(refuse(dir, format!("could not take the lock {}", lock.display())))
}

/// What killed runs into `dir` left in `parent` (we hold the lock: no live run owns them):
/// staging directories are deleted; a set-aside old directory is renamed back if `dir` is
/// missing (the run was killed between its two renames), else deleted.
fn clean_leftovers(parent: &Path, name: &str, dir: &Path) {
    let Ok(entries) = fs::read_dir(parent) else { return };
    let mut tmp = Vec::new();
    let mut old = Vec::new();
    for e in entries.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = n.strip_prefix(name) else { continue };
        // Only names we make: `<name>.tmp-<pid>-<nanos>` and `<name>.old-<pid>-<nanos>`.
        let ours = |s: &str| s.split_once('-').is_some_and(|(a, b)| is_digits(a) && is_digits(b));
        if rest.strip_prefix(".tmp-").is_some_and(ours) {
            tmp.push(e.path());
        } else if rest.strip_prefix(".old-").is_some_and(ours) {
            old.push(e.path());
        }
    }
    // The newest old directory is the one set aside last.
    old.sort_by_key(|p| file_name(p).rsplit('-').next().and_then(|s| s.parse::<u128>().ok()));
    if !dir.exists() {
        if let Some(newest) = old.pop() {
            let _ = fs::rename(newest, dir);
        }
    }
    for p in tmp.into_iter().chain(old) {
        let _ = fs::remove_dir_all(p);
    }
}

fn is_digits(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn temp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("linpd-atomic-{}-{tag}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn identity() -> RunIdentity {
        RunIdentity { linpd_version: "test".into(), inputs: vec![] }
    }

    #[test]
    fn fnv1a64_known_values() {
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn utc_string_known_values() {
        assert_eq!(utc_string(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_string(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_string(1_700_000_000), "2023-11-14T22:13:20Z");
    }

    /// `run.files` is read from the top-level member of a pretty-printed document without
    /// parsing the rest, not from a nested `run` key before it; any other layout is parsed
    /// whole.
    #[test]
    fn listed_files_reads_the_top_level_run_member() {
        let root = temp("listed");
        fs::create_dir_all(&root).unwrap();
        let path = root.join("result.json");
        let doc = serde_json::json!({
            "a": {"run": {"files": [{"name": "nested.csv", "bytes": 1}]}},
            "run": {"files": [{"name": "u.csv", "bytes": 12}], "time_unix": 5},
            "u": [1.0, 2.0]
        });
        let files = |text: String| {
            fs::write(&path, text).unwrap();
            listed_files(&path).map(|f| f.into_iter().map(|e| (e.name, e.bytes)).collect::<Vec<_>>())
        };
        let want = Some(vec![("u.csv".to_string(), 12)]);
        assert_eq!(files(serde_json::to_string_pretty(&doc).unwrap()), want);
        assert_eq!(files(serde_json::to_string(&doc).unwrap()), want);
        assert_eq!(files("{\"u\": [1.0]}".into()), None);
        let _ = fs::remove_dir_all(&root);
    }

    #[test]
    fn commit_replaces_the_whole_directory() {
        let root = temp("replace");
        let dir = root.join("a/b/out");
        let o = OutputDir::begin(&dir).unwrap();
        fs::write(o.path().join("one.csv"), "1").unwrap();
        fs::write(o.path().join("two.csv"), "22").unwrap();
        let files = o.commit("result.json", json!({"x": 1}), &identity()).unwrap();
        assert_eq!(files.len(), 3);
        let doc: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join("result.json")).unwrap()).unwrap();
        assert_eq!(doc["run"]["files"], json!([{"name": "one.csv", "bytes": 1}, {"name": "two.csv", "bytes": 2}]));
        let o = OutputDir::begin(&dir).unwrap();
        fs::write(o.path().join("three.csv"), "333").unwrap();
        o.commit("result.json", json!({}), &identity()).unwrap();
        let mut names: Vec<String> = fs::read_dir(&dir).unwrap().map(|e| file_name(&e.unwrap().path())).collect();
        names.sort();
        assert_eq!(names, ["result.json", "three.csv"], "the first run's files are gone");
        let siblings: Vec<String> =
            fs::read_dir(dir.parent().unwrap()).unwrap().map(|e| file_name(&e.unwrap().path())).collect();
        assert_eq!(siblings, ["out"], "no lock, staging or old directory left");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_failed_removal_of_the_old_directory_is_an_error() {
        let root = temp("discard");
        let (target, aside) = (root.join("out"), root.join("out.old-1-2"));
        fs::create_dir_all(&aside).unwrap();
        let e = discard_old(&aside, &target, |_| Err(std::io::Error::from(ErrorKind::PermissionDenied)))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&target.display().to_string()) && e.contains("out.old-1-2"), "{e}");
        assert!(e.contains("could not be deleted") && e.contains("ermission denied"), "{e}");
        discard_old(&aside, &target, |p| fs::remove_dir_all(p)).unwrap();
        assert!(!aside.exists());
        fs::remove_dir_all(&root).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_read_only_output_directory_is_refused_before_the_run() {
        use std::os::unix::fs::PermissionsExt;
        let root = temp("read-only");
        let dir = root.join("out");
        let first = OutputDir::begin(&dir).unwrap();
        fs::write(first.path().join("u.csv"), "1\n").unwrap();
        first.commit("result.json", serde_json::json!({}), &identity()).unwrap();
        fs::set_permissions(&dir, fs::Permissions::from_mode(0o555)).unwrap();
        let e = OutputDir::begin(&dir).unwrap_err().to_string();
        fs::set_permissions(&dir, fs::Permissions::from_mode(0o755)).unwrap();
        assert!(e.contains(&dir.display().to_string()) && e.contains("is read-only (mode 555)"), "{e}");
        // nothing set aside or staged, the old results intact
        let names: Vec<String> =
            fs::read_dir(&root).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        assert_eq!(names, vec!["out".to_string()]);
        assert!(dir.join("u.csv").exists());
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn dropped_without_commit_leaves_nothing() {
        let root = temp("drop");
        let dir = root.join("new/out");
        let o = OutputDir::begin(&dir).unwrap();
        fs::write(o.path().join("u.csv"), "1").unwrap();
        drop(o);
        assert!(!root.join("new").exists(), "the created parent is removed again");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn refuses_foreign_directories_and_held_locks() {
        let root = temp("refuse");
        let dir = root.join("mine");
        fs::create_dir_all(&dir).unwrap();
        fs::write(dir.join("thesis.tex"), "x").unwrap();
        let e = OutputDir::begin(&dir).unwrap_err().to_string();
        assert!(e.contains("not a linpd output directory"), "{e}");
        fs::write(dir.join("result.json"), "{}").unwrap();
        let e = OutputDir::begin(&dir).unwrap_err().to_string();
        assert!(e.contains("no list of the files"), "{e}");
        fs::write(dir.join("result.json"), r#"{"run": {"files": []}}"#).unwrap();
        let e = OutputDir::begin(&dir).unwrap_err().to_string();
        assert!(e.contains("holds `thesis.tex`"), "{e}");
        assert!(dir.join("thesis.tex").exists());
        fs::remove_file(dir.join("thesis.tex")).unwrap();
        let held = OutputDir::begin(&dir).unwrap();
        let e = OutputDir::begin(&dir).unwrap_err().to_string();
        assert!(e.contains("another linpd run") && e.contains("mine.lock"), "{e}");
        drop(held);
        assert!(!root.join("mine.lock").exists());
        // A lock left by a dead process is taken over; left-over staging directories go.
        fs::write(root.join("mine.lock"), "4194304999 1\n").unwrap();
        fs::create_dir(root.join("mine.tmp-4194304999-1")).unwrap();
        let o = OutputDir::begin(&dir).unwrap();
        assert!(!root.join("mine.tmp-4194304999-1").exists());
        drop(o);
        let e = OutputDir::begin(Path::new("..")).unwrap_err().to_string();
        assert!(e.contains("must end in a name"), "{e}");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn an_old_directory_set_aside_by_a_killed_run_comes_back() {
        let root = temp("restore");
        let old = root.join("out.old-1-2");
        fs::create_dir(&old).unwrap();
        fs::write(old.join("result.json"), r#"{"run": {"files": []}}"#).unwrap();
        let o = OutputDir::begin(&root.join("out")).unwrap();
        assert!(root.join("out/result.json").exists() && !old.exists());
        drop(o);
        assert!(root.join("out/result.json").exists(), "a failed run keeps the restored results");
        fs::remove_dir_all(&root).unwrap();
    }
}
