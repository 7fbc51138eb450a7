//! rosbag2's sqlite3 storage (`.db3`, the default of ROS 2 Humble): the messages of the
//! wanted topics, in time order, fed to the same decoding pass as MCAP's.
//!
//! The schema (rosbag2_storage_default_plugins): `topics(id, name, type,
//! serialization_format, offered_qos_profiles)` and `messages(id, topic_id, timestamp,
//! data)`, `timestamp` the receive time in ns, `data` the CDR message (as in MCAP).
//!
//! The file comes from outside: SQL text is constant (values go in as parameters), the
//! file is opened read-only, and a message larger than [`MAX_MESSAGE`] is
//! refused before SQLite hands its bytes over.

use std::path::{Path, PathBuf};

use rusqlite::{Connection, OpenFlags, params};

use super::mcap::{MAX_MCAP_RECORD, Pass, Sample};
use crate::error::{Error, Result};

/// Largest data of one message (bytes), compressed or not: the MCAP record bound.
pub(super) const MAX_MESSAGE: usize = MAX_MCAP_RECORD;

/// Largest `.db3` that a `.db3.zstd` is decompressed to (bytes): SQLite needs a file on
/// disk, and a hostile frame must not fill the disk.
pub const MAX_DB3_DECOMPRESSED: u64 = 64 << 30;

fn log_err(path: &Path, msg: String) -> Error {
    Error::Log { file: path.to_path_buf(), msg }
}

/// Streams the messages of the wanted topics of the sqlite3 bag file `path` into `pass`,
/// ordered by time (then by row). `zstd`: the file is compressed as a whole and is first
/// decompressed to a temporary file.
pub(super) fn stream_db3_file<F>(pass: &mut Pass<'_>, path: &Path, zstd: bool, f: &mut F) -> Result<()>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let unpacked = if zstd { Some(decompress(path)?) } else { None };
    let db_path: PathBuf = unpacked.as_ref().map_or_else(|| path.to_path_buf(), |t| t.path().to_path_buf());
    pass.begin_file(path);
    let db = Connection::open_with_flags(&db_path, OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX)
        .map_err(|e| log_err(path, format!("cannot open as a sqlite3 bag: {e}")))?;
    let ids = bind_topics(pass, &db, path)?;
    stream_messages(pass, &db, path, &ids, f)
}

/// Binds every row of `topics` in the pass; the ids of the wanted topics (at most three:
/// measured, command, current).
fn bind_topics(pass: &mut Pass<'_>, db: &Connection, path: &Path) -> Result<Vec<i64>> {
    let schema_err = |table: &str, e: rusqlite::Error| {
        log_err(path, format!("not a rosbag2 sqlite3 bag: table '{table}' is missing or has other columns ({e})"))
    };
    let mut stmt = db
        .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
        .map_err(|e| schema_err("topics", e))?;
    let rows = stmt
        .query_map([], |r| {
            Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?, r.get::<_, String>(2)?, r.get::<_, String>(3)?))
        })
        .map_err(|e| schema_err("topics", e))?;
    let mut wanted = vec![];
    for row in rows {
        let (id, name, ty, format) = row.map_err(|e| schema_err("topics", e))?;
        // rosbag2's topics table has the type name only; its definition is the ROS one
        pass.bind(id, &name, Some((ty, "ros2msg".into())), &format)?;
        if pass.is_wanted(id) {
            wanted.push(id);
        }
    }
    Ok(wanted)
}

/// Feeds the messages of the topics `ids` to the pass in time order.
fn stream_messages<F>(pass: &mut Pass<'_>, db: &Connection, path: &Path, ids: &[i64], f: &mut F) -> Result<()>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let Some(&first) = ids.first() else { return Ok(()) };
    let id = |k: usize| ids.get(k).copied().unwrap_or(first);
    // the data of an oversized row is not fetched (NULL), only its length
    let mut stmt = db
        .prepare(
            "SELECT topic_id, timestamp, length(data), CASE WHEN length(data) <= ?4 THEN data END \
             FROM messages WHERE topic_id IN (?1, ?2, ?3) ORDER BY timestamp, id",
        )
        .map_err(|e| {
            log_err(path, format!("not a rosbag2 sqlite3 bag: table 'messages' is missing or has other columns ({e})"))
        })?;
    let max = i64::try_from(MAX_MESSAGE).unwrap_or(i64::MAX);
    let mut rows = stmt
        .query(params![id(0), id(1), id(2), max])
        .map_err(|e| log_err(path, format!("cannot read table 'messages': {e}")))?;
    let mut k = 0u64;
    loop {
        let row = rows.next().map_err(|e| log_err(path, format!("cannot read table 'messages' at row {k}: {e}")))?;
        let Some(row) = row else { break };
        let bad = |e: rusqlite::Error| log_err(path, format!("table 'messages', row {k}: {e}"));
        let topic_id: i64 = row.get(0).map_err(bad)?;
        let stamp: i64 = row.get(1).map_err(bad)?;
        let len: Option<i64> = row.get(2).map_err(bad)?;
        let data = match row.get_ref(3).map_err(bad)? {
            rusqlite::types::ValueRef::Blob(b) => b,
            _ if len.unwrap_or(0) > max => {
                return Err(log_err(
                    path,
                    format!("table 'messages', row {k}: data of {len:?} bytes: at most {MAX_MESSAGE} bytes are read"),
                ));
            }
            _ => return Err(log_err(path, format!("table 'messages', row {k}: data is not a blob"))),
        };
        // receive times before 1970 do not occur; clamp rather than wrap
        pass.message(topic_id, u64::try_from(stamp).unwrap_or(0), data, f)?;
        k += 1;
    }
    Ok(())
}

/// Decompresses the `.db3.zstd` at `path` into a temporary file (removed when dropped),
/// at most [`MAX_DB3_DECOMPRESSED`] bytes.
fn decompress(path: &Path) -> Result<tempfile::NamedTempFile> {
    let io = |e| Error::Io { file: path.to_path_buf(), source: e };
    let src = std::fs::File::open(path).map_err(io)?;
    let mut dec = zstd::Decoder::new(std::io::BufReader::new(src)).map_err(io)?;
    let mut tmp = tempfile::Builder::new().prefix("ivdyn-bag-").suffix(".db3").tempfile().map_err(io)?;
    let mut limited = std::io::Read::take(&mut dec, MAX_DB3_DECOMPRESSED + 1);
    let n = std::io::copy(&mut limited, tmp.as_file_mut())
        .map_err(|e| log_err(path, format!("cannot decompress (zstd): {e}")))?;
    if n > MAX_DB3_DECOMPRESSED {
        return Err(log_err(path, format!("decompresses to more than {MAX_DB3_DECOMPRESSED} bytes")));
    }
    Ok(tmp)
}
