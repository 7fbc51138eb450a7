//! Log input and output: ROS 2 recordings (`sensor_msgs/msg/JointState` in MCAP or sqlite3 bags) and CSV.
//!
//! Every reader returns (or streams) joint data in **the URDF joint order** the caller
//! asks for, matched by name, whatever order and extra joints the log has. Arrays are
//! row-major `T x N` (sample-major: `q[k * n + j]` is joint `j` at sample `k`).
//!
//! * [`read_mcap`] / [`for_each_sample`]: a ROS 2 recording (`ros2 bag record`: an MCAP or
//!   sqlite3 file, or the bag directory, [`bag`]), read
//!   in one pass with bounded memory (the file is streamed, never loaded whole).
//! * [`read_csv`] / [`write_csv`]: one row per sample, columns `t`, `<joint>.q`,
//!   `<joint>.qd`, `<joint>.tau`, `<joint>.u`, `<joint>.i` (see `docs/logs.md`).
//! * [`McapWriter`] / [`write_mcap`]: JointState topics (measured, predicted, residual)
//!   that a viewer such as Foxglove plots side by side.
//!
//! Bad input gives [`crate::Error::Log`] naming the file and, where known,
//! the topic, sample index, joint and field.
//!
//! ```no_run
//! use ivdyn::log::{read_mcap, ReadOptions};
//! let robot = ivdyn::Robot::from_urdf("fixtures/ur5.urdf", None, Some("tool0")).unwrap();
//! let log = read_mcap("run.mcap", &ReadOptions::new(&robot.joint_names)).unwrap();
//! println!("{} samples of {} joints, effort: {}", log.len(), log.dof(), log.tau.is_some());
//! ```

pub mod bag;
pub mod cdr;
pub mod csv;
pub mod db3;
pub mod mcap;
pub mod mcap_out;
mod mcap_rec;
pub mod read;
pub mod recording;

use std::path::Path;

pub use self::bag::{LogFile, LogFiles, Storage, log_files, message_count};
pub use self::csv::{MAX_CSV_LINE, read_csv, read_csv_from, write_csv};
pub use self::mcap::{
    CommandAlign, CommandField, MAX_MCAP_RECORD, ReadOptions, Sample, Source, StreamSummary, for_each_sample_from,
};
pub use self::mcap_out::{
    Compression, MEASURED_TOPIC, McapWriter, PREDICTED_TOPIC, PredictionWriter, RESIDUAL_TOPIC, TopicId, write_mcap,
};
pub use self::read::{check_pipeline_log, read_joint_log, read_pipeline_log};
pub use self::recording::{for_each_sample, read_mcap};

use crate::error::{Error, Result};

/// A joint log in URDF joint order: `T` samples of `N` joints, row-major `T x N`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointLog {
    /// Joint names (the order asked for, e.g. the URDF's).
    pub joint_names: Vec<String>,
    /// Absolute time of `t = 0` in nanoseconds (ROS time of the first sample for MCAP;
    /// 0 for CSV, whose `t` column is used as is).
    pub t0_ns: i64,
    /// Sample times in seconds since `t0_ns`, non-decreasing (length `T`).
    pub t: Vec<f64>,
    /// Positions, `T x N`.
    pub q: Vec<f64>,
    /// Velocities, `T x N`, `None` when the log has none (empty `velocity` arrays).
    pub qd: Option<Vec<f64>>,
    /// Measured efforts (torques), `T x N`, `None` when the log has none.
    pub tau: Option<Vec<f64>>,
    /// Actuator command (the instrumental model's input), aligned to `t`, `T x N`.
    pub u: Option<Vec<f64>>,
    /// Measured motor currents (A), aligned to `t`, `T x N`: the effort of drives that
    /// report current instead of torque (`app::io` turns them into torques).
    pub current: Option<Vec<f64>>,
    /// The MCAP file was truncated and `allow_truncated` kept what came before.
    pub truncated: bool,
}

impl JointLog {
    /// Number of samples `T`.
    pub fn len(&self) -> usize {
        self.t.len()
    }
    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Number of joints `N`.
    pub fn dof(&self) -> usize {
        self.joint_names.len()
    }
    /// Median sample interval in seconds (`None` with fewer than two distinct stamps).
    pub fn median_dt(&self) -> Option<f64> {
        crate::dsp::median_dt(&self.t)
    }
    /// Removes samples whose stamp equals the previous one (keeps the first of each run),
    /// in every array. Returns how many were dropped.
    pub fn drop_duplicate_stamps(&mut self) -> usize {
        let mut keep = Vec::with_capacity(self.t.len());
        for k in 0..self.t.len() {
            if k == 0 || self.t[k] != self.t[k - 1] {
                keep.push(k);
            }
        }
        let dropped = self.t.len() - keep.len();
        if dropped > 0 {
            *self = self.rows(&keep);
        }
        dropped
    }
    /// The samples `keep` (indices in order) of every array.
    pub fn rows(&self, keep: &[usize]) -> JointLog {
        let n = self.dof();
        let take = |x: &[f64]| crate::dsp::take_rows(x, n, keep);
        JointLog {
            joint_names: self.joint_names.clone(),
            t0_ns: self.t0_ns,
            t: keep.iter().map(|&k| self.t[k]).collect(),
            q: take(&self.q),
            qd: self.qd.as_deref().map(take),
            tau: self.tau.as_deref().map(take),
            u: self.u.as_deref().map(take),
            current: self.current.as_deref().map(take),
            truncated: self.truncated,
        }
    }
    /// Checks shapes, finiteness and stamp order (what the readers guarantee); useful for
    /// logs built by hand. `file` names the source in the error.
    pub fn validate(&self, file: &Path) -> Result<()> {
        self.check_shapes()?;
        let (t, n) = (self.len(), self.dof());
        let err = |msg: String| Error::Log { file: file.to_path_buf(), msg };
        for (field, a) in self.fields() {
            let Some(a) = a else { continue };
            if let Some(i) = a.iter().position(|x| !x.is_finite()) {
                return Err(err(format!("sample {}: joint '{}' {field} is {}", i / n, self.joint_names[i % n], a[i])));
            }
        }
        for k in 0..t {
            if !self.t[k].is_finite() {
                return Err(err(format!("sample {k}: time is {}", self.t[k])));
            }
            if k > 0 && self.t[k] < self.t[k - 1] {
                return Err(err(format!(
                    "sample {k}: time goes back ({} s after {} s at sample {})",
                    self.t[k],
                    self.t[k - 1],
                    k - 1
                )));
            }
        }
        Ok(())
    }
}

impl JointLog {
    /// Every `T x N` array with its field name (`None`: not in the log).
    pub(crate) fn fields(&self) -> [(&'static str, Option<&Vec<f64>>); 5] {
        [
            ("q", Some(&self.q)),
            ("qd", self.qd.as_ref()),
            ("tau", self.tau.as_ref()),
            ("u", self.u.as_ref()),
            ("current", self.current.as_ref()),
        ]
    }

    /// Checks that every array is `T x N`.
    pub fn check_shapes(&self) -> Result<()> {
        let (t, n) = (self.len(), self.dof());
        for (field, a) in self.fields() {
            if let Some(a) = a
                && a.len() != t * n
            {
                return Err(Error::Dimension {
                    what: format!("JointLog.{field} ({t} samples x {n} joints)"),
                    expected: t * n,
                    got: a.len(),
                });
            }
        }
        Ok(())
    }
}

/// Formats a name list for error messages: `[a, b, c]` (at most 20 names, then "...").
/// The first name that occurs twice in `names`, with both positions: a JointState or a
/// CSV header naming a joint twice is refused, since either entry could be the joint's
/// (the first used to win silently, and a stale duplicate made a joint look motionless).
/// A hash set, not a pairwise scan: the list's length comes from the file.
pub(crate) fn first_duplicate<S: AsRef<str>>(names: &[S]) -> Option<(&str, usize, usize)> {
    let mut seen = std::collections::HashMap::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        if let Some(first) = seen.insert(n.as_ref(), i) {
            return Some((n.as_ref(), first, i));
        }
    }
    None
}

pub(crate) fn name_list<S: AsRef<str>>(names: &[S]) -> String {
    let mut s: Vec<&str> = names.iter().take(20).map(|x| x.as_ref()).collect();
    if names.len() > 20 {
        s.push("...");
    }
    format!("[{}]", s.join(", "))
}
