//! A log as identify, payload and diagnose read it: the reader chosen by extension, then
//! the checks every pipeline needs.

use std::path::Path;

use super::{JointLog, ReadOptions, read_csv, read_mcap};
use crate::error::{Error, Result};

/// Reads a joint log by extension: `.csv` with [`read_csv`] (the topics are not used); a
/// ROS 2 recording with [`read_mcap`] (measured `topic`, optional `command_topic` for `u`):
/// a `.mcap` or `.db3` file, either one `.zstd`-compressed, or a rosbag2 directory
/// ([`super::bag`]). Joints come out in the order of `joint_names`.
pub fn read_joint_log(
    path: impl AsRef<Path>,
    joint_names: &[String],
    topic: &str,
    command_topic: Option<&str>,
) -> Result<JointLog> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if ext.as_deref() == Some("csv") {
        return read_csv(path, joint_names);
    }
    if path.is_dir() || is_bag_file(path) {
        return read_mcap(path, &ReadOptions::new(joint_names).topic(topic).command_topic_opt(command_topic));
    }
    Err(Error::Log {
        file: path.to_path_buf(),
        msg: "unknown log format: expected a .mcap, .db3 or .csv file or a ROS 2 bag directory".into(),
    })
}

/// A file name a ROS 2 recording has (`.mcap`, `.db3`, maybe `.zstd`).
fn is_bag_file(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_ascii_lowercase();
    let name = name.strip_suffix(".zstd").unwrap_or(&name);
    name.ends_with(".mcap") || name.ends_with(".db3")
}

// ------------------------------------------------------------------ logs for the pipelines

/// Reads a log as the `ivdyn` command line does for `--log`: `.csv` with [`read_csv`],
/// anything else as a ROS 2 recording (an MCAP or sqlite3 file or a rosbag2 directory:
/// [`read_mcap`] with `opts`: the measured topic, the command and current topics, the
/// stamps), then [`check_pipeline_log`].
pub fn read_pipeline_log(path: &Path, opts: &ReadOptions) -> Result<JointLog> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let log = if ext.as_deref() == Some("csv") { read_csv(path, &opts.joint_names)? } else { read_mcap(path, opts)? };
    check_pipeline_log(&log, path, &opts.topic)?;
    Ok(log)
}

/// What the pipelines need of a log (`source` names it in errors): consistent shapes,
/// finite values, non-decreasing stamps ([`JointLog::validate`]), stamps that are not all
/// equal (unset header stamps), and at least 10 samples.
pub fn check_pipeline_log(log: &JointLog, source: &Path, topic: &str) -> Result<()> {
    log.validate(source)?;
    let err = |msg: String| Error::Log { file: source.to_path_buf(), msg };
    if log.len() >= 2 && log.t.first() == log.t.last() {
        return Err(err(format!(
            "all {} samples on topic {topic} have the same stamp (header stamps not set?); use the MCAP log times (--log-time)",
            log.len()
        )));
    }
    if log.len() < 10 {
        return Err(err(format!("only {} samples on topic {topic}", log.len())));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_joint_log_rejects_unknown_extension() {
        let e = read_joint_log("x.bag", &["a".into()], "/joint_states", None).unwrap_err();
        assert!(e.to_string().contains(".mcap, .db3 or .csv"), "{e}");
    }
}
