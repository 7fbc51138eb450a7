//! ROS 2 recordings as `ros2 bag record` writes them: which files make up a log, in which
//! order, in which storage and compression, and one streaming pass over all of them.
//!
//! A log path is one of
//! * a rosbag2 directory: `metadata.yaml` (`rosbag2_bagfile_information`) lists the
//!   files (`relative_file_paths`, the split files `<name>_0`, `<name>_1`, ... in order),
//!   their storage (`storage_identifier`: `mcap`, or `sqlite3`, Humble's default) and
//!   compression (`compression_mode` `file`: each file is `.zstd` as a whole; `message`:
//!   each message's data is); without a readable `metadata.yaml` the directory's
//!   `*.mcap` / `*.db3` files are taken in the order of their `_N` index, with a note;
//! * one file: `.mcap`, `.db3`, `.mcap.zstd`, `.db3.zstd` (anything else is read as MCAP).
//!
//! rosbag2's recorder writes one file at a time and starts the next when the current one
//! is full (its sequential reader reads them in the listed order), so the files are read
//! one after the other as one log. Stamps carry on across files, and the per-topic check
//! that they never go back (in [`super::mcap`]) runs across the file boundaries: a bag
//! whose files overlap in time is refused with the file named, not silently re-sorted.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::mcap::{Pass, ReadOptions, Sample, StreamSummary, stream_into, stream_mcap_file};
use crate::error::{Error, Result};

/// How a rosbag2 file stores its messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// MCAP (`ros2 bag record -s mcap`; Iron's and later distributions' default).
    Mcap,
    /// SQLite 3 (`.db3`; Humble's default).
    Sqlite3,
}

/// One file of a log, in reading order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogFile {
    /// The file.
    pub path: PathBuf,
    /// Its storage.
    pub storage: Storage,
    /// Compressed as a whole with zstd (`.zstd`, `compression_mode: file`).
    pub zstd: bool,
}

/// The files of a log and what `metadata.yaml` says of them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LogFiles {
    /// The files, in reading order.
    pub files: Vec<LogFile>,
    /// Each message's data is zstd-compressed (`compression_mode: message`).
    pub message_zstd: bool,
    /// Messages per topic according to `metadata.yaml` (`None`: no metadata).
    pub counts: Option<Vec<(String, u64)>>,
    /// What the user should know about how the log was found (e.g. no `metadata.yaml`).
    pub notes: Vec<String>,
}

impl LogFiles {
    /// Messages on `topic` according to `metadata.yaml` (`None`: not known from it).
    pub fn count(&self, topic: &str) -> Option<u64> {
        let counts = self.counts.as_ref()?;
        let mut found = counts.iter().filter(|(t, _)| t == topic).peekable();
        found.peek()?;
        Some(found.map(|(_, c)| c).sum())
    }
}

/// `metadata.yaml` as rosbag2 writes it (versions 4 to 9); the fields read.
#[derive(Debug, Deserialize)]
struct Metadata {
    rosbag2_bagfile_information: BagInfo,
}

#[derive(Debug, Deserialize)]
struct BagInfo {
    storage_identifier: String,
    #[serde(default)]
    relative_file_paths: Vec<String>,
    #[serde(default)]
    compression_format: String,
    #[serde(default)]
    compression_mode: String,
    #[serde(default)]
    topics_with_message_count: Vec<TopicCount>,
}

#[derive(Debug, Deserialize)]
struct TopicCount {
    topic_metadata: TopicMetadata,
    message_count: u64,
}

#[derive(Debug, Deserialize)]
struct TopicMetadata {
    name: String,
}

/// Largest `metadata.yaml` read (bytes): rosbag2 writes a few KB; the bound keeps a
/// hostile file from being parsed at any size.
const MAX_METADATA: u64 = 16 << 20;

fn log_err(path: &Path, msg: String) -> Error {
    Error::Log { file: path.to_path_buf(), msg }
}

/// The files that make up the log at `path` (a rosbag2 directory or one file), in order.
pub fn log_files(path: &Path) -> Result<LogFiles> {
    if !path.is_dir() {
        let (storage, zstd) = file_kind(path).unwrap_or((Storage::Mcap, false));
        return Ok(LogFiles {
            files: vec![LogFile { path: path.to_path_buf(), storage, zstd }],
            ..LogFiles::default()
        });
    }
    let meta = path.join("metadata.yaml");
    match read_metadata(&meta) {
        Ok(info) => from_metadata(path, &meta, info),
        Err(why) => from_listing(path, why),
    }
}

/// The storage of a file by its name, and whether it is zstd-compressed as a whole.
fn file_kind(path: &Path) -> Option<(Storage, bool)> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    let (stem, zstd) = match name.strip_suffix(".zstd") {
        Some(s) => (s, true),
        None => (name.as_str(), false),
    };
    let storage = if stem.ends_with(".db3") {
        Storage::Sqlite3
    } else if stem.ends_with(".mcap") {
        Storage::Mcap
    } else {
        return None;
    };
    Some((storage, zstd))
}

/// Parses `metadata.yaml`; the error in words (for the note of the fallback).
fn read_metadata(meta: &Path) -> std::result::Result<BagInfo, String> {
    let file = File::open(meta).map_err(|e| format!("cannot open metadata.yaml ({e})"))?;
    let mut text = String::new();
    file.take(MAX_METADATA + 1).read_to_string(&mut text).map_err(|e| format!("cannot read metadata.yaml ({e})"))?;
    if text.len() as u64 > MAX_METADATA {
        return Err(format!("metadata.yaml is larger than {MAX_METADATA} bytes"));
    }
    let m: Metadata =
        serde_norway::from_str(&text).map_err(|e| format!("metadata.yaml is not rosbag2 metadata ({e})"))?;
    Ok(m.rosbag2_bagfile_information)
}

/// The files listed by `metadata.yaml`, checked: known storage and compression, every
/// listed file present.
fn from_metadata(dir: &Path, meta: &Path, info: BagInfo) -> Result<LogFiles> {
    let storage = match info.storage_identifier.as_str() {
        "mcap" => Storage::Mcap,
        "sqlite3" => Storage::Sqlite3,
        other => {
            return Err(log_err(meta, format!("storage_identifier '{other}': only mcap and sqlite3 bags are read")));
        }
    };
    let mode = info.compression_mode.to_ascii_lowercase();
    let compressed = !(mode.is_empty() || mode == "none");
    if compressed && !info.compression_format.eq_ignore_ascii_case("zstd") {
        return Err(log_err(
            meta,
            format!("compression_format '{}': only zstd compression is read", info.compression_format),
        ));
    }
    if compressed && mode != "file" && mode != "message" {
        return Err(log_err(meta, format!("compression_mode '{mode}': expected file, message or none")));
    }
    if info.relative_file_paths.is_empty() {
        return Err(log_err(meta, "relative_file_paths lists no file".into()));
    }
    let mut files = Vec::with_capacity(info.relative_file_paths.len());
    for rel in &info.relative_file_paths {
        // rosbag2 before Foxy wrote paths with the bag directory in front; a path that is
        // absolute or climbs out (`..`) is only looked up by its file name in the bag:
        // metadata.yaml never makes ivdyn read a file outside the bag directory
        let rel_path = Path::new(rel);
        let inside = rel_path.components().all(|c| matches!(c, std::path::Component::Normal(_)));
        let by_name = dir.join(rel_path.file_name().unwrap_or_default());
        let p = [inside.then(|| dir.join(rel_path)), Some(by_name)]
            .into_iter()
            .flatten()
            .find(|p| p.is_file())
            .ok_or_else(|| log_err(meta, format!("the bag file {rel} listed in relative_file_paths is missing")))?;
        let zstd = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("zstd"));
        files.push(LogFile { path: p, storage, zstd });
    }
    let counts = info.topics_with_message_count.into_iter().map(|t| (t.topic_metadata.name, t.message_count)).collect();
    Ok(LogFiles { files, message_zstd: compressed && mode == "message", counts: Some(counts), notes: vec![] })
}

/// The bag files of a directory without usable metadata, in the order of their `_N`
/// index. Several files must be one split recording, `<name>_0`, `<name>_1`, ... of one
/// storage: a folder of unrelated logs is refused rather than read as one.
fn from_listing(dir: &Path, why: String) -> Result<LogFiles> {
    /// A bag file found in the directory.
    struct Found {
        /// recording name and split index (`<name>_<N>`), if the file name has them
        split: Option<(String, u64)>,
        name: String,
        file: LogFile,
    }
    let entries = std::fs::read_dir(dir).map_err(|e| Error::Io { file: dir.to_path_buf(), source: e })?;
    let mut found: Vec<Found> = vec![];
    for e in entries {
        let path = e.map_err(|e| Error::Io { file: dir.to_path_buf(), source: e })?.path();
        let Some((storage, zstd)) = file_kind(&path).filter(|_| path.is_file()) else { continue };
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
        found.push(Found { split: split_name(&name), name, file: LogFile { path, storage, zstd } });
    }
    if found.is_empty() {
        return Err(log_err(dir, format!("not a ROS 2 bag: {why}, and no .mcap or .db3 file in the directory")));
    }
    fn recording(f: &Found) -> Option<(&str, Storage)> {
        f.split.as_ref().map(|s| (s.0.as_str(), f.file.storage))
    }
    let one_recording =
        found.len() == 1 || found.iter().all(|f| f.split.is_some() && recording(f) == recording(&found[0]));
    let names = |f: &[Found]| f.iter().map(|x| x.name.as_str()).collect::<Vec<_>>().join(", ");
    if !one_recording {
        return Err(log_err(
            dir,
            format!(
                "{why}, and the files {} are not the split files <name>_0, <name>_1, ... of one recording: \
                 give one file as the log, or restore metadata.yaml",
                names(&found)
            ),
        ));
    }
    found.sort_by_key(|f| f.split.as_ref().map_or(0, |s| s.1));
    let note = format!("{}: {why}; read the bag files {} in this order", dir.display(), names(&found));
    Ok(LogFiles { files: found.into_iter().map(|f| f.file).collect(), notes: vec![note], ..LogFiles::default() })
}

/// The recording name and split index `N` of `<name>_N.mcap` (`None` without an index).
fn split_name(file_name: &str) -> Option<(String, u64)> {
    let stem = file_name.split('.').next().unwrap_or_default();
    stem.rsplit_once('_').and_then(|(name, n)| Some((name.to_string(), n.parse().ok()?)))
}

/// [`super::for_each_sample`] on any log path: every file of the log in order, through one
/// [`Pass`] (stamps and counts continue across files).
pub(super) fn for_each_sample_in<F>(path: &Path, opts: &ReadOptions, mut f: F) -> Result<StreamSummary>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let log = log_files(path)?;
    let mut pass = Pass::new(path, opts)?;
    pass.set_message_zstd(log.message_zstd);
    for file in &log.files {
        match (file.storage, file.zstd) {
            (Storage::Mcap, false) => stream_mcap_file(&mut pass, &file.path, &mut f)?,
            (Storage::Mcap, true) => {
                // decompressed as it is read: memory stays bounded as for a plain file
                let io = |e| Error::Io { file: file.path.clone(), source: e };
                let raw = File::open(&file.path).map_err(io)?;
                let dec = zstd::Decoder::new(BufReader::with_capacity(256 * 1024, raw)).map_err(io)?;
                pass.begin_file(&file.path);
                stream_into(&mut pass, dec, None, &mut f)?;
            }
            (Storage::Sqlite3, zstd) => super::db3::stream_db3_file(&mut pass, &file.path, zstd, &mut f)?,
        }
    }
    let mut summary = pass.finish().map_err(|e| if log.files.len() > 1 { in_bag(path, e) } else { e })?;
    summary.notes.splice(0..0, log.notes);
    Ok(summary)
}

/// An error of the whole bag (a topic missing from every file) names the bag, not its
/// last file.
fn in_bag(dir: &Path, e: Error) -> Error {
    match e {
        Error::Log { msg, .. } => log_err(dir, msg),
        e => e,
    }
}

/// Messages on `topic` in the log at `path`: from `metadata.yaml`, else the sum of the
/// MCAP files' summaries (`None` when a file has none, or is compressed or sqlite3).
pub fn message_count(path: &Path, topic: &str) -> Result<Option<u64>> {
    let log = log_files(path)?;
    if let Some(c) = log.count(topic) {
        return Ok(Some(c));
    }
    let mut total = 0;
    for file in &log.files {
        if file.storage != Storage::Mcap || file.zstd {
            return Ok(None);
        }
        let Some(c) = super::mcap::summary_count(&file.path, topic)? else { return Ok(None) };
        total += c;
    }
    Ok(Some(total))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_names() {
        assert_eq!(split_name("run_0.mcap"), Some(("run".into(), 0)));
        assert_eq!(split_name("my_run_12.db3.zstd"), Some(("my_run".into(), 12)));
        assert_eq!(split_name("run.mcap"), None);
        assert_eq!(split_name("run_x.mcap"), None);
        assert_eq!(file_kind(Path::new("a/run_1.DB3.zstd")), Some((Storage::Sqlite3, true)));
        assert_eq!(file_kind(Path::new("a/run.csv")), None);
    }
}
