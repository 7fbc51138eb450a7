//! Outputs of one command written all or nothing ([`OutputSet`]): every file is first
//! written into a private staging directory and renamed into place only when the whole
//! command has succeeded, so an error (a full disk, a bad value found late, a later
//! output that cannot be written) leaves none of the command's new files, and a
//! pre-existing file at a target is left untouched.
//!
//! * A staging directory is created beside the targets (rename needs the same
//!   filesystem) with a random name `.ivdyn-XXXXXX`, mode 0700, by an exclusive
//!   `mkdir` that fails rather than reuse an existing name; its files are created with
//!   `O_EXCL`. Nothing there can be predicted or planted by another user, and no
//!   temporary file follows a symlink.
//! * A target that exists and is not a regular file (`/dev/null`, a FIFO, a socket) is
//!   written in place at commit, never replaced; `/dev/stdout` and `/dev/stderr` are the
//!   process's own handles. A target that is a symlink is written through the link in
//!   place (the link stays a link).
//! * Live staging directories are listed in a process-wide registry, so a signal
//!   handler (the command line installs one; the library installs none) can remove them
//!   with [`remove_staged`] before the process exits.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::Serialize;

use crate::error::{Error, Result};

/// Directories to remove if the process is stopped by a signal: `(path, is_staging)`;
/// a staging directory is removed with its contents, a directory created for an output
/// only if empty. `closed` is set by [`remove_staged`]: no set may register afterwards.
struct Registry {
    dirs: Vec<(PathBuf, bool)>,
    closed: bool,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry { dirs: Vec::new(), closed: false });

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    // a panic while holding the lock leaves a list that is still valid
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every live staging directory (and the empty directories created for
/// outputs) of this process, and refuses new ones: for a signal handler that then exits.
/// Renames already under way in [`OutputSet::commit`] finish first (it holds the same
/// lock), so a set is either wholly in place or wholly removed.
pub fn remove_staged() {
    let mut r = registry();
    r.closed = true;
    for (dir, staging) in r.dirs.drain(..).rev() {
        let _ = if staging { std::fs::remove_dir_all(&dir) } else { std::fs::remove_dir(&dir) };
    }
}

/// How a staged file reaches its target at commit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// Renamed over the target (absent or a regular file).
    Rename,
    /// Copied into the target opened for writing (a special file, or a symlink);
    /// truncated first when it is (or resolves to) a regular file.
    InPlace { truncate: bool },
    /// The process's own stdout (1) or stderr (2), named as `/dev/stdout`, `/dev/fd/1`,
    /// `/proc/self/fd/1` (or 2): written to the handle, at its current offset, as the
    /// shell does for these names (reopening a redirected file would write at offset 0,
    /// under the summary printed later).
    Stream(u8),
    /// The target is itself inside a live staging directory (a writer called by
    /// another set's writer): written there directly, the outer set commits it.
    Direct,
}

#[derive(Debug)]
struct Staged {
    target: PathBuf,
    staged: PathBuf,
    route: Route,
}

/// The outputs of one command, written all or nothing: [`stage`](Self::stage) (or
/// [`write`](Self::write)) each file, then [`commit`](Self::commit) once everything
/// succeeded. Dropping the set without committing removes everything it staged and the
/// directories it created.
#[derive(Debug, Default)]
pub struct OutputSet {
    /// Staging directories (absolute), one per target directory, with the target
    /// directory they serve (`None`: the system temporary directory, for in-place targets).
    staging: Vec<(Option<PathBuf>, PathBuf)>,
    files: Vec<Staged>,
    /// Directories created by [`create_dir_all`](Self::create_dir_all), outermost first.
    created: Vec<PathBuf>,
    committed: bool,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// A new path to write `target`'s content to: a fresh empty file (created with
    /// `O_EXCL`) in this set's private staging directory. A `target` that is a directory
    /// is refused here, before anything is written.
    pub fn stage(&mut self, target: &Path) -> Result<PathBuf> {
        let io = |source| Error::Io { file: target.to_path_buf(), source };
        let route = route_of(target).map_err(io)?;
        if route == Route::Direct {
            return Ok(target.to_path_buf());
        }
        let dir = match route {
            Route::Rename => Some(std::path::absolute(parent(target)).map_err(io)?),
            _ => None,
        };
        let staging = self.staging_dir(dir).map_err(io)?;
        let name = target.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
        let staged = staging.join(format!("{}-{name}", self.files.len()));
        let f = OpenOptions::new().write(true).create_new(true).open(&staged).map_err(io)?;
        if route == Route::Rename
            && let Ok(m) = std::fs::metadata(target)
        {
            // replacing a file keeps its permissions (a 0600 parameter file stays private)
            f.set_permissions(m.permissions()).map_err(io)?;
        }
        self.files.push(Staged { target: target.to_path_buf(), staged: staged.clone(), route });
        Ok(staged)
    }

    /// Stages `target` and lets `write` fill the staged path; errors that name the
    /// staged path are made to name `target`.
    pub fn write(&mut self, target: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        let staged = self.stage(target)?;
        write(&staged).map_err(|e| target_named(e, &staged, target))
    }

    /// `v` as pretty JSON (and a newline) for `target`.
    pub fn write_json<T: Serialize>(&mut self, target: &Path, v: &T) -> Result<()> {
        self.write(target, |p| {
            let io = |source| Error::Io { file: p.to_path_buf(), source };
            let mut f = File::create(p).map_err(io)?;
            serde_json::to_writer_pretty(&mut f, v).map_err(|e| io(std::io::Error::other(e)))?;
            f.write_all(b"\n").map_err(io)?;
            f.sync_all().map_err(io)
        })
    }

    /// `bytes` for `target`.
    pub fn write_bytes(&mut self, target: &Path, bytes: &[u8]) -> Result<()> {
        self.write(target, |p| std::fs::write(p, bytes).map_err(|source| Error::Io { file: p.to_path_buf(), source }))
    }

    /// Creates `dir` and its missing parents; those created are removed again (when
    /// empty) if the set is not committed.
    pub fn create_dir_all(&mut self, dir: &Path) -> Result<()> {
        let io = |source| Error::Io { file: dir.to_path_buf(), source };
        let abs = std::path::absolute(dir).map_err(io)?;
        let missing: Vec<&Path> = abs.ancestors().take_while(|a| std::fs::symlink_metadata(a).is_err()).collect();
        for d in missing.into_iter().rev() {
            let made = create_listed(false, || match std::fs::create_dir(d) {
                Ok(()) => Ok(Some(d.to_path_buf())),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(None),
                Err(e) => Err(e),
            })
            .map_err(io)?;
            self.created.extend(made);
        }
        // an existing non-directory at `dir` fails here
        std::fs::create_dir_all(&abs).map_err(io)
    }

    /// Puts every staged file in place: first the copies into special files and symlinks
    /// (they can block, as a FIFO without a reader does, or fail, as `/dev/full` does:
    /// nothing is renamed then), then the renames, holding the registry lock so that a
    /// signal handler waits for them; then the staging directories are removed. A rename
    /// can only fail if the filesystem changed under the command; those before it stay.
    pub fn commit(mut self) -> Result<()> {
        for s in &self.files {
            let copied = match s.route {
                Route::InPlace { truncate } => copy_in_place(&s.staged, &s.target, truncate),
                Route::Stream(fd) => copy_to_stream(&s.staged, fd),
                Route::Rename | Route::Direct => Ok(()),
            };
            copied.map_err(|source| Error::Io { file: s.target.clone(), source })?;
        }
        let lock = registry();
        let renamed = self.files.iter().filter(|s| s.route == Route::Rename).try_for_each(|s| {
            std::fs::rename(&s.staged, &s.target).map_err(|source| Error::Io { file: s.target.clone(), source })
        });
        self.committed = renamed.is_ok();
        // released before `self` is dropped: Drop takes the lock too
        drop(lock);
        renamed
    }

    /// The staging directory for targets in `dir` (`None`: in-place targets), created
    /// and registered on first use.
    fn staging_dir(&mut self, dir: Option<PathBuf>) -> std::io::Result<PathBuf> {
        if let Some((_, s)) = self.staging.iter().find(|(d, _)| *d == dir) {
            return Ok(s.clone());
        }
        let base = std::path::absolute(dir.clone().unwrap_or_else(std::env::temp_dir))?;
        // random name, mode 0700, mkdir fails (and retries another name) on any existing entry
        let mut b = tempfile::Builder::new();
        b.prefix(".ivdyn-");
        #[cfg(unix)]
        b.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o700));
        let made =
            create_listed(true, || b.tempdir_in(&base).map(|t| Some(t.keep())).map_err(|e| staging_error(e, &base)))?
                .expect("a staging folder is always new");
        self.staging.push((dir, made.clone()));
        Ok(made)
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        let mut r = registry();
        for (_, s) in &self.staging {
            let _ = std::fs::remove_dir_all(s);
            r.dirs.retain(|(d, _)| d != s);
        }
        for d in self.created.iter().rev() {
            if !self.committed {
                let _ = std::fs::remove_dir(d);
            }
            r.dirs.retain(|(x, _)| x != d);
        }
    }
}

/// `e` from creating a staging directory in `base`, with the folder named and without
/// the random name tempfile appends (it never existed).
fn staging_error(e: std::io::Error, base: &Path) -> std::io::Error {
    let text = e.to_string();
    let cause = text.split_once(" at path ").map_or(text.as_str(), |(c, _)| c);
    std::io::Error::new(e.kind(), format!("cannot create a staging folder in {}: {cause}", base.display()))
}

/// Creates a directory with `make` (its path, or `None` when it already existed) and lists
/// it for [`remove_staged`], both under the registry's lock: a signal handler's
/// `remove_staged` then either sees it or ran first, and it is not created (created first
/// and listed after, a signal in between left it behind). Refused once a handler has run.
fn create_listed(
    staging: bool,
    make: impl FnOnce() -> std::io::Result<Option<PathBuf>>,
) -> std::io::Result<Option<PathBuf>> {
    let mut r = registry();
    if r.closed {
        return Err(std::io::Error::new(std::io::ErrorKind::Interrupted, "the process is stopping"));
    }
    let made = make()?;
    if let Some(d) = &made {
        r.dirs.push((d.clone(), staging));
    }
    Ok(made)
}

/// `target`'s directory (`.` for a bare file name).
fn parent(target: &Path) -> &Path {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// How `target` is to be written, from what is at the path now.
fn route_of(target: &Path) -> std::io::Result<Route> {
    let is_dir_err = || std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a directory");
    if let Some(fd) = std_stream(target) {
        return Ok(Route::Stream(fd));
    }
    let abs_parent = std::path::absolute(parent(target))?;
    if registry().dirs.iter().any(|(d, staging)| *staging && *d == abs_parent) {
        return Ok(Route::Direct);
    }
    let link = match std::fs::symlink_metadata(target) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Route::Rename),
        Err(e) => return Err(e),
        Ok(m) if m.is_dir() => return Err(is_dir_err()),
        Ok(m) if m.is_file() => return Ok(Route::Rename),
        Ok(m) => m,
    };
    if !link.file_type().is_symlink() {
        return Ok(Route::InPlace { truncate: false });
    }
    // a symlink: written through, never replaced; a dangling one is created as the shell does
    match std::fs::metadata(target) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Route::InPlace { truncate: true }),
        Err(e) => Err(e),
        Ok(m) if m.is_dir() => Err(is_dir_err()),
        Ok(m) => Ok(Route::InPlace { truncate: m.is_file() }),
    }
}

/// Copies `staged` into `target`, opened for writing without replacing it: a device or
/// FIFO keeps its node, a symlink stays a link.
fn copy_in_place(staged: &Path, target: &Path, truncate: bool) -> std::io::Result<()> {
    let mut from = File::open(staged)?;
    let mut to = OpenOptions::new().write(true).create(truncate).truncate(truncate).open(target)?;
    std::io::copy(&mut from, &mut to)?;
    to.flush()
}

/// 1 or 2 when `target` names this process's stdout or stderr.
fn std_stream(target: &Path) -> Option<u8> {
    let t = target.to_str()?;
    ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]
        .contains(&t)
        .then_some(1)
        .or_else(|| ["/dev/stderr", "/dev/fd/2", "/proc/self/fd/2"].contains(&t).then_some(2))
}

/// Copies `staged` to stdout (`fd` 1) or stderr (2).
fn copy_to_stream(staged: &Path, fd: u8) -> std::io::Result<()> {
    let mut from = File::open(staged)?;
    if fd == 1 {
        let mut to = std::io::stdout().lock();
        std::io::copy(&mut from, &mut to)?;
        to.flush()
    } else {
        std::io::copy(&mut from, &mut std::io::stderr().lock()).map(|_| ())
    }
}

/// `e` with the staged path replaced by the target in the file it names.
fn target_named(e: Error, staged: &Path, target: &Path) -> Error {
    let fix = |f: PathBuf| if f == staged { target.to_path_buf() } else { f };
    match e {
        Error::Io { file, source } => Error::Io { file: fix(file), source },
        Error::Log { file, msg } => Error::Log { file: fix(file), msg },
        Error::InFile { file, source } => Error::InFile { file: fix(file), source },
        e => e,
    }
}

/// Writes one file all or nothing (a set of one): `write` fills a staged path, which is
/// then put in place at `path`.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let mut set = OutputSet::new();
    set.write(path, write)?;
    set.commit()
}

/// `v` as pretty JSON (and a newline) in `path`, all or nothing (a set of one).
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<()> {
    let mut set = OutputSet::new();
    set.write_json(path, v)?;
    set.commit()
}
