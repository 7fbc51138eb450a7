//! Outputs written whole or not at all: every file ivdyn writes goes to a temporary file
//! beside its target and is renamed over it only once complete, so a failure (a full disk,
//! a bad value found late) never leaves a partial or stale-looking file.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};

/// A temporary path in the same directory as `path` (renamed over it on success).
pub fn tmp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `path` whole or not at all: `write` fills a temporary file beside it, which is
/// then renamed over `path`; on any error the temporary file is removed.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = tmp_path(path);
    let r = write(&tmp)
        .and_then(|_| std::fs::rename(&tmp, path).map_err(|source| Error::Io { file: path.to_path_buf(), source }));
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

/// `v` as pretty JSON (and a newline) in `path`, written whole or not at all.
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<()> {
    write_atomic(path, |tmp| {
        let io = |source| Error::Io { file: path.to_path_buf(), source };
        let mut f = std::fs::File::create(tmp).map_err(io)?;
        serde_json::to_writer_pretty(&mut f, v).map_err(|e| io(std::io::Error::other(e)))?;
        f.write_all(b"\n").map_err(io)?;
        f.sync_all().map_err(io)
    })
}
