//! Outputs that never replace inputs, and that appear all together or not at all.
//!
//! A command names its inputs and stages each output into an [`Outputs`]: the bytes go to
//! a temporary file beside the target (same directory, so the final rename stays on one
//! file system). [`Outputs::publish`] renames them all into place once every one was
//! written; dropping an unpublished [`Outputs`] (an error on the way) removes the temporary
//! files and the directories it created, and leaves every existing file untouched.
//!
//! ```
//! use drive_data::output::Outputs;
//! let dir = tempfile::tempdir().unwrap();
//! let data = dir.path().join("run.csv");
//! std::fs::write(&data, "window,phase\n").unwrap();
//!
//! // An output on an input is refused before anything is written.
//! let outputs = Outputs::new(&[("--data", &data)]);
//! assert!(outputs.check(&[("--out", &data)]).is_err());
//!
//! let mut outputs = Outputs::new(&[("--data", &data)]);
//! let report = dir.path().join("out/report.md");
//! outputs.write(&report, "# Report\n").unwrap();
//! assert!(!report.exists()); // staged only
//! outputs.publish().unwrap();
//! assert_eq!(std::fs::read_to_string(&report).unwrap(), "# Report\n");
//! ```

use std::fmt::Display;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use thiserror::Error;

/// Why outputs were not written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// An output path is an input of the command, or another of its outputs.
    #[error("{role} {} is also {other_role} {}: writing it would replace that file; choose another path", .path.display(), .other.display())]
    Clash {
        /// The output's flag or description (`--out`, `the sidecar of --out`).
        role: String,
        /// The output path as given.
        path: PathBuf,
        /// What else the path is (`the input --data`, `the output --raw-out`).
        other_role: String,
        /// That path as given.
        other: PathBuf,
    },
    /// A file could not be written (nothing was published).
    #[error("cannot write {}: {reason}", .path.display())]
    Write {
        /// The target path.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// Another run kept publishing into the same directory for longer than
    /// [`PUBLISH_WAIT_S`] (nothing was published).
    #[error("cannot write into {}: another run has been writing there for over {PUBLISH_WAIT_S} s (its lock {}); nothing written", .dir.display(), .dir.join(PUBLISH_LOCK).display())]
    Busy {
        /// The directory.
        dir: PathBuf,
    },
    /// A staged file could not be moved into place.
    #[error("cannot write {}: {reason}{}", .path.display(), published_note(.published))]
    Publish {
        /// The target that failed.
        path: PathBuf,
        /// What went wrong.
        reason: String,
        /// The targets already in place.
        published: Vec<PathBuf>,
    },
}

fn published_note(published: &[PathBuf]) -> String {
    if published.is_empty() {
        String::new()
    } else {
        let names: Vec<String> = published.iter().map(|p| p.display().to_string()).collect();
        format!(" (already replaced: {})", names.join(", "))
    }
}

/// A path's identity: its canonical form (symbolic links and `..` resolved as far as the
/// path exists) and, for an existing file on Unix, its device and inode (hard links).
#[derive(Debug, Clone)]
struct Identity {
    canonical: PathBuf,
    #[cfg(unix)]
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Identity {
        Identity {
            canonical: canonical(path),
            #[cfg(unix)]
            inode: {
                use std::os::unix::fs::MetadataExt;
                std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
            },
        }
    }

    fn same(&self, other: &Identity) -> bool {
        #[cfg(unix)]
        if let (Some(a), Some(b)) = (self.inode, other.inode) {
            return a == b;
        }
        self.canonical == other.canonical
    }
}

/// The canonical form of the longest existing ancestor of `path`, joined with the rest
/// (normalized lexically).
fn canonical(path: &Path) -> PathBuf {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    let mut normal = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                normal.pop();
            }
            c => normal.push(c),
        }
    }
    let mut rest = Vec::new();
    let mut head = normal.as_path();
    loop {
        if let Ok(c) = head.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return out;
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                head = parent;
            }
            _ => return normal,
        }
    }
}

/// A file staged for writing.
#[derive(Debug)]
struct Staged {
    /// The path as given.
    target: PathBuf,
    /// Where the bytes wait.
    temp: PathBuf,
    /// The target's identity, for clashes.
    id: Identity,
    /// The file the bytes go to: the target, or the file its symbolic link points to.
    destination: PathBuf,
    /// How the bytes reach the destination.
    kind: Destination,
}

/// How staged bytes reach their destination.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Destination {
    /// Renamed into place (a regular file, or a new one).
    File,
    /// Written into the process's standard output or error (`/dev/stdout`, `/dev/fd/2`,
    /// ...), where the shell may have sent it to a file being appended to.
    Stream(i32),
    /// Written into a device, a pipe or a socket (`/dev/null`): renaming over it would
    /// replace the device with a file.
    Device,
}

/// The standard stream a path names, if it does (`/dev/stdout`, `/dev/fd/1`,
/// `/proc/self/fd/1`; 2 for standard error).
fn stream_of(path: &Path) -> Option<i32> {
    let p = path.to_str()?;
    for (fd, names) in [
        (1, ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]),
        (2, ["/dev/stderr", "/dev/fd/2", "/proc/self/fd/2"]),
    ] {
        if names.contains(&p) {
            return Some(fd);
        }
    }
    None
}

/// Whether `path` is, or leads to, something other than a regular file or a directory:
/// a device, a pipe, a socket or a standard stream. Such a path cannot take a file beside
/// it (a dataset's sidecar).
pub fn is_special(path: &Path) -> bool {
    stream_of(path).is_some() || std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Files staged for writing, published together (see the module documentation).
#[derive(Debug, Default)]
pub struct Outputs {
    inputs: Vec<(String, PathBuf, Identity)>,
    staged: Vec<Staged>,
    created_dirs: Vec<PathBuf>,
    /// Directories whose whole set of files this command writes ([`Outputs::own`]).
    owned: Vec<PathBuf>,
}

/// The file in an output directory that lists the files the last run published there
/// ([`Outputs::own`]), one name per line.
pub const OUTPUT_MANIFEST: &str = ".drive-outputs";

static TEMP_COUNTER: AtomicUsize = AtomicUsize::new(0);

/// Removes from `dir` the temporaries (`.drive-tmp-PID-...`) of runs that no longer exist: a
/// run killed before it published (SIGKILL runs no cleanup) left them there. A live run's,
/// this one's included, are kept; where whether a process lives cannot be told (no `/proc`),
/// nothing is removed.
fn remove_stale_temporaries(dir: &Path) {
    let proc_dir = Path::new("/proc");
    if !proc_dir.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(".drive-tmp-")) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let file = entry.file_type().is_ok_and(|t| t.is_file());
        if file && pid != std::process::id() && !proc_dir.join(pid.to_string()).exists() {
            // Best effort: one that cannot be removed stays, as it was.
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

impl Outputs {
    /// Outputs of a command whose inputs are `inputs` (flag or description, path); paths
    /// that do not exist are kept too (an output must not take their place either).
    pub fn new(inputs: &[(&str, &Path)]) -> Outputs {
        Outputs {
            inputs: inputs
                .iter()
                .map(|(role, p)| {
                    (
                        format!("the input {role}"),
                        p.to_path_buf(),
                        Identity::of(p),
                    )
                })
                .collect(),
            staged: Vec::new(),
            created_dirs: Vec::new(),
            owned: Vec::new(),
        }
    }

    /// Marks `dir` as a directory whose whole set of files this command writes (`--out
    /// DIR` of bench, report, track, adapt, matrix): on [`Outputs::publish`], the files the
    /// previous run published there ([`OUTPUT_MANIFEST`]) that this one does not are
    /// removed, so that the directory holds one run's set (a figure of a training source
    /// this run does not have, a table of an option it was not given, never stays beside
    /// the new ones). Files a run of this project did not publish are never touched.
    ///
    /// ```
    /// use drive_data::output::Outputs;
    /// let dir = tempfile::tempdir().unwrap();
    /// let out = dir.path().join("out");
    /// let mut first = Outputs::new(&[]);
    /// first.own(&out);
    /// first.write(&out.join("a.csv"), "a\n").unwrap();
    /// first.write(&out.join("b.csv"), "b\n").unwrap();
    /// first.publish().unwrap();
    /// std::fs::write(out.join("mine.txt"), "the user's").unwrap();
    /// let mut second = Outputs::new(&[]);
    /// second.own(&out);
    /// second.write(&out.join("a.csv"), "a2\n").unwrap();
    /// second.publish().unwrap();
    /// assert!(!out.join("b.csv").exists()); // the first run's, not this one's
    /// assert!(out.join("mine.txt").exists()); // never the user's
    /// ```
    pub fn own(&mut self, dir: &Path) {
        self.owned.push(dir.to_path_buf());
    }

    /// Checks planned outputs (flag or description, path) against the inputs, the files
    /// staged so far and each other, before any work: an error names the two roles.
    pub fn check(&self, outputs: &[(&str, &Path)]) -> Result<(), OutputError> {
        let mut seen: Vec<(String, PathBuf, Identity)> = self.inputs.clone();
        seen.extend(
            self.staged
                .iter()
                .map(|f| ("the output".to_string(), f.target.clone(), f.id.clone())),
        );
        for (role, path) in outputs {
            // A directory on the way that is a file: said before any work (creating the
            // directories later failed with "File exists").
            if let Some(file) = path
                .ancestors()
                .skip(1)
                .find(|a| !a.as_os_str().is_empty() && a.exists())
                .filter(|a| !a.is_dir())
            {
                return Err(OutputError::Write {
                    path: path.to_path_buf(),
                    reason: format!(
                        "{} is a file, not a directory (the output {role} would be inside it)",
                        file.display()
                    ),
                });
            }
            let id = Identity::of(path);
            if let Some((other_role, other, _)) = seen.iter().find(|(_, _, o)| o.same(&id)) {
                return Err(OutputError::Clash {
                    role: role.to_string(),
                    path: path.to_path_buf(),
                    other_role: other_role.clone(),
                    other: other.clone(),
                });
            }
            seen.push((format!("the output {role}"), path.to_path_buf(), id));
        }
        Ok(())
    }

    /// Stages `bytes` to be published at `target`.
    pub fn write(&mut self, target: &Path, bytes: impl AsRef<[u8]>) -> Result<(), OutputError> {
        self.write_with(target, |temp| -> std::io::Result<()> {
            let mut file = std::fs::File::create(temp)?;
            file.write_all(bytes.as_ref())?;
            file.sync_all()
        })
    }

    /// Stages a file that `write` writes at the temporary path it is given (which keeps
    /// the target's extension, for writers that choose a format by it).
    pub fn write_with<E: Display>(
        &mut self,
        target: &Path,
        write: impl FnOnce(&Path) -> Result<(), E>,
    ) -> Result<(), OutputError> {
        self.check(&[("the output", target)])?;
        let failed = |reason: String| OutputError::Write {
            path: target.to_path_buf(),
            reason,
        };
        // Through a symbolic link to the file it points to (the link stays a link).
        let destination = match std::fs::symlink_metadata(target) {
            Ok(m) if m.file_type().is_symlink() => {
                std::fs::canonicalize(target).unwrap_or_else(|_| target.to_path_buf())
            }
            _ => target.to_path_buf(),
        };
        let meta = std::fs::metadata(&destination).ok();
        if meta.as_ref().is_some_and(|m| m.is_dir()) {
            return Err(failed("it is a directory".into()));
        }
        let kind = match stream_of(target) {
            Some(fd) => Destination::Stream(fd),
            None if meta.as_ref().is_some_and(|m| !m.is_file()) => Destination::Device,
            None => Destination::File,
        };
        let direct = kind != Destination::File;
        destination
            .file_name()
            .ok_or_else(|| failed("not a file name".into()))?;
        // The temporary keeps the target's name (and extension: a writer may choose its
        // format by it), even when the target is a link to a file of another name.
        let name = target
            .file_name()
            .or_else(|| destination.file_name())
            .ok_or_else(|| failed("not a file name".into()))?;
        let dir = if direct {
            std::env::temp_dir()
        } else {
            match destination.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            }
        };
        self.create_dir(&dir).map_err(|e| failed(e.to_string()))?;
        if !direct {
            remove_stale_temporaries(&dir);
        }
        let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        let temp = dir.join(format!(
            ".drive-tmp-{}-{n}-{}",
            std::process::id(),
            name.to_string_lossy()
        ));
        self.staged.push(Staged {
            target: target.to_path_buf(),
            temp: temp.clone(),
            id: Identity::of(target),
            destination,
            kind,
        });
        write(&temp).map_err(|e| failed(e.to_string()))
    }

    /// Creates `dir` and its missing ancestors, remembering them to remove on failure.
    fn create_dir(&mut self, dir: &Path) -> std::io::Result<()> {
        let missing: Vec<PathBuf> = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(dir)?;
        self.created_dirs.extend(missing);
        Ok(())
    }

    /// The targets staged so far.
    pub fn targets(&self) -> impl Iterator<Item = &Path> {
        self.staged.iter().map(|f| f.target.as_path())
    }

    /// Moves every staged file into place, in the order staged; returns the targets.
    pub fn publish(mut self) -> Result<Vec<PathBuf>, OutputError> {
        // One run publishes into a directory at a time: two runs writing one output leave
        // one run's whole set, never a mix (held until the end of this call).
        let mut dirs: Vec<PathBuf> = self
            .staged
            .iter()
            .filter(|f| f.kind == Destination::File)
            .filter_map(|f| f.destination.parent().map(Path::to_path_buf))
            // One directory however it is spelled (`run.csv`'s "" and a link's target's
            // "/abs/dir"): its lock is taken once, not waited on by this very run.
            .map(|d| {
                let d = if d.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    d
                };
                std::fs::canonicalize(&d).unwrap_or(d)
            })
            .collect();
        dirs.sort();
        dirs.dedup();
        let mut locks = Vec::new();
        for dir in &dirs {
            locks.push(PublishLock::take(dir)?);
        }
        let staged = std::mem::take(&mut self.staged);
        let mut published = Vec::new();
        let mut pending = staged.into_iter();
        while let Some(f) = pending.next() {
            let moved = match f.kind {
                Destination::File => std::fs::rename(&f.temp, &f.destination),
                Destination::Stream(_) | Destination::Device => {
                    let copied = write_into(&f);
                    let copied = match copied {
                        // A pipe whose reader has gone (`--per-window /dev/stdout | head`).
                        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
                        other => other,
                    };
                    copied.and_then(|()| std::fs::remove_file(&f.temp))
                }
            };
            if let Err(e) = moved {
                let path = f.target.clone();
                // Give the rest back to Drop to remove, with this one.
                self.staged = std::iter::once(f).chain(pending).collect();
                self.created_dirs.clear();
                return Err(OutputError::Publish {
                    path,
                    reason: e.to_string(),
                    published,
                });
            }
            published.push(f.target);
        }
        self.created_dirs.clear();
        for dir in &self.owned {
            settle_owned(dir, &published);
        }
        Ok(published)
    }
}

/// After a publish into the owned directory `dir` (under its publish lock): removes the
/// files the previous run's manifest lists that this run did not publish, and writes this
/// run's manifest. Best effort: a file that cannot be removed stays (it was written by
/// an earlier run, and is named in no new output).
fn settle_owned(dir: &Path, published: &[PathBuf]) {
    let manifest = dir.join(OUTPUT_MANIFEST);
    let mine: Vec<String> = published
        .iter()
        .filter(|p| p.parent().is_some_and(|d| same_dir(d, dir)))
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    if mine.is_empty() {
        // Nothing of this run's there: the previous set stays as it was.
        return;
    }
    if let Ok(previous) = std::fs::read_to_string(&manifest) {
        for name in previous.lines() {
            // A plain file name in this directory only, never a path out of it.
            let plain = !name.is_empty()
                && Path::new(name).components().count() == 1
                && matches!(
                    Path::new(name).components().next(),
                    Some(Component::Normal(_))
                );
            if plain && !mine.iter().any(|m| m == name) {
                let stale = dir.join(name);
                if std::fs::symlink_metadata(&stale).is_ok_and(|m| m.is_file()) {
                    let _ = std::fs::remove_file(stale);
                }
            }
        }
    }
    let _ = std::fs::write(&manifest, mine.join("\n") + "\n");
}

/// Whether `a` and `b` name one directory (`out` and `./out`).
fn same_dir(a: &Path, b: &Path) -> bool {
    a == b
        || match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
}

/// The lock file a run holds in a directory while it publishes its outputs there.
pub const PUBLISH_LOCK: &str = ".drive-publish.lock";
/// How long a run waits for another's publishing in the same directory (s).
pub const PUBLISH_WAIT_S: u64 = 30;
/// A lock older than this (s) is a crashed run's, and is taken over: publishing takes
/// milliseconds.
const PUBLISH_STALE_S: u64 = 120;

/// A directory's publish lock, removed when dropped.
struct PublishLock(Option<PathBuf>);

impl PublishLock {
    /// Takes `dir`'s lock, waiting up to [`PUBLISH_WAIT_S`] for another run's; a directory
    /// where no lock can be created (read-only, absent) gets none: the renames then say why.
    fn take(dir: &Path) -> Result<PublishLock, OutputError> {
        let path = dir.join(PUBLISH_LOCK);
        let start = std::time::Instant::now();
        loop {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(_) => return Ok(PublishLock(Some(path))),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let age = std::fs::metadata(&path)
                        .and_then(|m| m.modified())
                        .ok()
                        .and_then(|t| t.elapsed().ok());
                    if age.is_some_and(|a| a.as_secs() > PUBLISH_STALE_S) {
                        let _ = std::fs::remove_file(&path);
                        continue;
                    }
                    if start.elapsed().as_secs() >= PUBLISH_WAIT_S {
                        return Err(OutputError::Busy {
                            dir: dir.to_path_buf(),
                        });
                    }
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
                Err(_) => return Ok(PublishLock(None)),
            }
        }
    }
}

impl Drop for PublishLock {
    fn drop(&mut self) {
        if let Some(path) = &self.0 {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// Copies a staged file into a stream or a device, in place (no truncation, no rename).
fn write_into(f: &Staged) -> std::io::Result<()> {
    let mut bytes = std::fs::File::open(&f.temp)?;
    match f.kind {
        Destination::Stream(1) => {
            let mut out = std::io::stdout().lock();
            std::io::copy(&mut bytes, &mut out)?;
            out.flush()
        }
        Destination::Stream(_) => {
            let mut out = std::io::stderr().lock();
            std::io::copy(&mut bytes, &mut out)?;
            out.flush()
        }
        _ => {
            let mut out = std::fs::OpenOptions::new()
                .write(true)
                .open(&f.destination)?;
            std::io::copy(&mut bytes, &mut out)?;
            out.flush()
        }
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        for f in &self.staged {
            let _ = std::fs::remove_file(&f.temp);
        }
        // Deepest first; only directories left empty.
        for dir in &self.created_dirs {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 63: a run killed before it published left its temporaries; the next run into
    /// that directory removes those of runs that no longer exist, and only those.
    #[cfg(target_os = "linux")]
    #[test]
    fn temporaries_of_runs_that_no_longer_exist_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // No process has that id (beyond Linux's largest, 4194304).
        let stale = d.join(".drive-tmp-4294967-0-report.md");
        let live = d.join(format!(".drive-tmp-{}-99-x.md", std::process::id()));
        let other = d.join(".drive-tmp-notes.txt");
        for f in [&stale, &live, &other] {
            std::fs::write(f, "x").unwrap();
        }
        let mut outputs = Outputs::new(&[]);
        outputs.write(&d.join("out.txt"), "new").unwrap();
        outputs.publish().unwrap();
        assert!(!stale.exists());
        assert!(live.exists() && other.exists());
        assert_eq!(std::fs::read_to_string(d.join("out.txt")).unwrap(), "new");
    }

    #[test]
    fn an_output_inside_a_file_is_refused_before_any_work() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("afile");
        std::fs::write(&file, "").unwrap();
        let outputs = Outputs::new(&[]);
        let e = outputs
            .check(&[("--out", &file.join("deeper/x.json"))])
            .unwrap_err();
        assert!(
            e.to_string().contains("afile is a file, not a directory"),
            "{e}"
        );
        // Directories not there yet are made when publishing: no error.
        assert!(outputs
            .check(&[("--out", &dir.path().join("new/x.json"))])
            .is_ok());
    }

    #[test]
    fn an_output_on_an_input_through_another_spelling_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("a.csv");
        std::fs::write(&data, "x").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let other = dir.path().join("sub/../a.csv");
        let outputs = Outputs::new(&[("--data", &data)]);
        let e = outputs.check(&[("--out", &other)]).unwrap_err();
        assert!(e.to_string().contains("is also the input --data"), "{e}");
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::fs::hard_link(&data, &link).unwrap();
            assert!(outputs.check(&[("--out", &link)]).is_err());
            let sym = dir.path().join("sym.csv");
            std::os::unix::fs::symlink(&data, &sym).unwrap();
            assert!(outputs.check(&[("--out", &sym)]).is_err());
        }
        // Two outputs on one new path.
        let new = dir.path().join("new/b.json");
        let e = outputs
            .check(&[("--out", &new), ("the sidecar of --out", &new)])
            .unwrap_err();
        assert!(e.to_string().contains("is also the output --out"), "{e}");
        assert!(outputs
            .check(&[("--out", &dir.path().join("b.csv"))])
            .is_ok());
    }

    #[test]
    fn a_failed_command_leaves_nothing_and_existing_files_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let old = dir.path().join("old.csv");
        std::fs::write(&old, "previous").unwrap();
        {
            let mut outputs = Outputs::new(&[]);
            outputs.write(&old, "new").unwrap();
            outputs
                .write(&dir.path().join("deep/er/x.md"), "x")
                .unwrap();
            let e = outputs
                .write_with(&dir.path().join("y.png"), |_| Err("the plot failed"))
                .unwrap_err();
            assert!(e.to_string().starts_with("cannot write"), "{e}");
        }
        assert_eq!(std::fs::read_to_string(&old).unwrap(), "previous");
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("old.csv")]);
    }

    /// An eleventh outside sweep: an output through a link beside another output of the same
    /// directory, spelled otherwise (`--out new.csv`, a link, and its sidecar `new.meta.json`),
    /// waited 30 s on its own publish lock and then blamed another run.
    #[cfg(unix)]
    #[test]
    fn a_link_beside_another_output_of_its_directory_publishes_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        std::fs::write(&real, "old").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("real.csv", &link).unwrap();
        // The directory also reached through a link to it (as `new.csv` is reached as "").
        let alias = dir.path().join("alias");
        std::os::unix::fs::symlink(dir.path(), &alias).unwrap();
        let mut outputs = Outputs::new(&[]);
        outputs.write(&alias.join("link.csv"), "new").unwrap();
        outputs.write(&alias.join("link.meta.json"), "{}").unwrap();
        let start = std::time::Instant::now();
        outputs.publish().unwrap();
        assert!(start.elapsed().as_secs() < PUBLISH_WAIT_S);
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_links_are_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        std::fs::write(&real, "old").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        // A named pipe stands for a device (/dev/null, /dev/stdout): renaming over it would
        // replace it with a file.
        let pipe = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&pipe).status();
        let reader = made.is_ok_and(|s| s.success()).then(|| {
            let pipe = pipe.clone();
            std::thread::spawn(move || std::fs::read_to_string(pipe).unwrap())
        });
        let mut outputs = Outputs::new(&[]);
        outputs.write(&link, "new").unwrap();
        if reader.is_some() {
            outputs.write(&pipe, "through the pipe").unwrap();
        }
        outputs.publish().unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        if let Some(reader) = reader {
            assert_eq!(reader.join().unwrap(), "through the pipe");
            assert!(!std::fs::metadata(&pipe).unwrap().is_file(), "still a pipe");
        }
    }

    #[test]
    fn published_files_replace_the_old_ones_together() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("a.json"));
        std::fs::write(&a, "old a").unwrap();
        let mut outputs = Outputs::new(&[]);
        outputs.write(&a, "new a").unwrap();
        outputs.write(&b, "new b").unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        assert_eq!(outputs.publish().unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn two_runs_publishing_into_one_directory_take_turns_and_leave_one_runs_set() {
        let dir = tempfile::tempdir().unwrap();
        let names = ["bench.json", "bench.md", "datasets.csv", "windows.csv"];
        let read = |dir: &Path| -> Vec<String> {
            names
                .iter()
                .map(|n| std::fs::read_to_string(dir.join(n)).unwrap_or_default())
                .collect()
        };
        // Four runs at once, each publishing the four files with its own number (staged
        // together, then published together, round after round), while a reader looks
        // between publishes (holding the lock as a run does): it always finds one run's
        // whole set.
        let rounds = 30;
        let barrier = std::sync::Arc::new(std::sync::Barrier::new(4));
        let runs: Vec<_> = (0..4)
            .map(|run| {
                let dir = dir.path().to_path_buf();
                let barrier = barrier.clone();
                std::thread::spawn(move || {
                    for _ in 0..rounds {
                        let mut outputs = Outputs::new(&[]);
                        for name in names {
                            outputs
                                .write(&dir.join(name), format!("run {run}"))
                                .unwrap();
                        }
                        barrier.wait();
                        outputs.publish().unwrap();
                        barrier.wait();
                    }
                })
            })
            .collect();
        let mut looked = 0;
        while !runs.iter().all(|r| r.is_finished()) || looked == 0 {
            let _lock = PublishLock::take(dir.path()).unwrap();
            let seen = read(dir.path());
            assert!(
                seen.iter().all(|x| x == &seen[0]) || seen.iter().all(String::is_empty),
                "{seen:?}"
            );
            looked += 1;
        }
        for r in runs {
            r.join().unwrap();
        }
        let last = read(dir.path());
        assert!(last.iter().all(|x| x == &last[0]), "{last:?}");
        assert!(!dir.path().join(PUBLISH_LOCK).exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), names.len());
    }

    #[test]
    fn a_crashed_runs_lock_is_taken_over_and_a_held_one_waited_for() {
        let dir = tempfile::tempdir().unwrap();
        let lock = dir.path().join(PUBLISH_LOCK);
        // A lock from a run that crashed long ago.
        let file = std::fs::File::create(&lock).unwrap();
        let old = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        file.set_modified(old).unwrap();
        let mut outputs = Outputs::new(&[]);
        outputs.write(&dir.path().join("a.csv"), "a").unwrap();
        outputs.publish().unwrap();
        assert!(!lock.exists());
        // A lock held by a run still publishing: waited for, then taken.
        std::fs::File::create(&lock).unwrap();
        let release = {
            let lock = lock.clone();
            std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_millis(200));
                std::fs::remove_file(lock).unwrap();
            })
        };
        let mut outputs = Outputs::new(&[]);
        outputs.write(&dir.path().join("a.csv"), "b").unwrap();
        let start = std::time::Instant::now();
        outputs.publish().unwrap();
        assert!(start.elapsed() >= std::time::Duration::from_millis(150));
        release.join().unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("a.csv")).unwrap(),
            "b"
        );
    }
}
