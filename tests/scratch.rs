//! Scratch directories for tests: fresh and empty when made, removed when the test ends.
//! A failing test keeps its directory (its path is in the panic's output) for a look at
//! what it wrote. Shared by the test binaries of `ivdyn` and `ivdyn-cli` (`#[path]`).

#![allow(dead_code)] // each binary uses a part

use std::ops::Deref;
use std::path::{Path, PathBuf};

/// A directory under the system's temporary directory, named `{name}_{pid}`.
pub struct Scratch(PathBuf);

impl Scratch {
    /// Made fresh (whatever an earlier run with the same process id left is removed).
    pub fn new(name: &str) -> Scratch {
        let d = std::env::temp_dir().join(format!("{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("scratch directory {}: {e}", d.display()));
        Scratch(d)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept for a look: {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A file path `name` in a scratch directory of its own (`{prefix}-{name}_{pid}`): the file
/// and anything written beside it go when the test passes.
pub struct ScratchFile {
    dir: Scratch,
    path: PathBuf,
}

impl ScratchFile {
    pub fn new(prefix: &str, name: &str) -> ScratchFile {
        let dir = Scratch::new(&format!("{prefix}-{name}"));
        let path = dir.join(name);
        ScratchFile { dir, path }
    }
}

impl Deref for ScratchFile {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for ScratchFile {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}
