//! MCAP output: JointState topics (profile `ros2`, schema `sensor_msgs/msg/JointState`
//! encoded `ros2msg`, messages `cdr`), readable by `ros2 bag`, Foxglove and Python's
//! `mcap_ros2`.
//!
//! The file is written into a private staging directory ([`crate::output::OutputSet`])
//! and put in place by [`McapWriter::finish`]; if anything fails (or the writer is dropped
//! unfinished) the staged file is removed, so no partial file that looks valid is ever left.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use super::JointLog;
use super::cdr::encode_parts;
use crate::error::{Error, Result};
use crate::output::OutputSet;

/// The `ros2msg` text of `sensor_msgs/msg/JointState` with its dependencies, as
/// `ros2 bag` stores it.
pub const JOINT_STATE_MSGDEF: &str = "\
std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";

/// Chunk compression of the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Uncompressed chunks.
    None,
    /// zstd (the default, as `ros2 bag` and Python's writer).
    #[default]
    Zstd,
    /// lz4.
    Lz4,
}

/// A topic registered with [`McapWriter::add_joint_state_topic`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicId(u16);

/// Writes JointState topics to an MCAP file (staged, put in place on success).
pub struct McapWriter {
    path: PathBuf,
    set: OutputSet,
    w: Option<::mcap::Writer<BufWriter<File>>>,
    schema: u16,
    topics: Vec<(u16, String, u32)>,
    frame_id: String,
}

impl std::fmt::Debug for McapWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapWriter").field("path", &self.path).finish()
    }
}

impl McapWriter {
    /// Starts a zstd-compressed file at `path` (written to a staged file until
    /// [`finish`](Self::finish)).
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        Self::create_with(path, Compression::Zstd)
    }

    /// As [`create`](Self::create) with a chosen chunk compression.
    pub fn create_with(path: impl AsRef<Path>, compression: Compression) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let mut set = OutputSet::new();
        let tmp = set.stage(&path)?;
        let file = File::create(&tmp).map_err(|e| Error::Io { file: path.clone(), source: e })?;
        let comp = match compression {
            Compression::None => None,
            Compression::Zstd => Some(::mcap::Compression::Zstd),
            Compression::Lz4 => Some(::mcap::Compression::Lz4),
        };
        let mut me = McapWriter { path, set, w: None, schema: 0, topics: vec![], frame_id: String::new() };
        let mut w = ::mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("ivdyn ", env!("CARGO_PKG_VERSION")))
            .compression(comp)
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|e| me.fail(e))?;
        me.schema = w
            .add_schema("sensor_msgs/msg/JointState", "ros2msg", JOINT_STATE_MSGDEF.as_bytes())
            .map_err(|e| me.fail(e))?;
        me.w = Some(w);
        Ok(me)
    }

    /// Sets `header.frame_id` of the messages written from now on (default empty).
    pub fn set_frame_id(&mut self, frame_id: &str) {
        self.frame_id = frame_id.into();
    }

    fn fail(&self, e: impl std::fmt::Display) -> Error {
        Error::Log { file: self.path.clone(), msg: format!("cannot write MCAP: {e}") }
    }

    /// Registers a JointState topic (e.g. `/joint_states`, `/ivdyn/predicted`,
    /// `/ivdyn/residual`).
    pub fn add_joint_state_topic(&mut self, topic: &str) -> Result<TopicId> {
        if let Some(t) = self.topics.iter().find(|t| t.1 == topic) {
            return Ok(TopicId(t.0));
        }
        let w = self.w.as_mut().expect("writer is open until finish");
        let r = w.add_channel(self.schema, topic, "cdr", &BTreeMap::new());
        let id = r.map_err(|e| self.fail(e))?;
        self.topics.push((id, topic.into(), 0));
        Ok(TopicId(id))
    }

    /// Writes one JointState: header stamp and log time are `stamp_ns` (negative stamps
    /// are written as log time 0). `velocity` and `effort` may be empty; a non-empty
    /// array must have one value per name.
    pub fn write<S: AsRef<str>>(
        &mut self,
        topic: TopicId,
        stamp_ns: i64,
        names: &[S],
        position: &[f64],
        velocity: &[f64],
        effort: &[f64],
    ) -> Result<()> {
        for (what, a) in [("position", position), ("velocity", velocity), ("effort", effort)] {
            if !a.is_empty() && a.len() != names.len() {
                return Err(Error::Dimension {
                    what: format!("JointState {what}"),
                    expected: names.len(),
                    got: a.len(),
                });
            }
        }
        let Some(slot) = self.topics.iter_mut().find(|t| t.0 == topic.0) else {
            return Err(self.fail(format!("unknown topic id {}", topic.0)));
        };
        let sequence = slot.2;
        slot.2 = slot.2.wrapping_add(1);
        let sec = stamp_ns.div_euclid(1_000_000_000).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        let nanosec = stamp_ns.rem_euclid(1_000_000_000) as u32;
        let data = encode_parts(sec, nanosec, &self.frame_id, names, position, velocity, effort);
        let log_time = stamp_ns.max(0) as u64;
        let header = ::mcap::records::MessageHeader { channel_id: topic.0, sequence, log_time, publish_time: log_time };
        let w = self.w.as_mut().expect("writer is open until finish");
        let r = w.write_to_known_channel(&header, &data);
        r.map_err(|e| self.fail(e))
    }

    /// Writes the summary, flushes and puts the staged file in place at the target path.
    pub fn finish(mut self) -> Result<PathBuf> {
        let mut w = self.w.take().expect("writer is open until finish");
        w.finish().map_err(|e| self.fail(e))?;
        let buf = w.into_inner();
        let file = buf.into_inner().map_err(|e| Error::Io { file: self.path.clone(), source: e.into_error() })?;
        file.sync_all().map_err(|e| Error::Io { file: self.path.clone(), source: e })?;
        drop(file);
        std::mem::take(&mut self.set).commit()?;
        Ok(self.path.clone())
    }
}

impl Drop for McapWriter {
    fn drop(&mut self) {
        // Close the file before the set (dropped after this) removes what it staged:
        // everything when unfinished (error or early return), nothing after finish().
        self.w.take();
    }
}

/// Writes a [`JointLog`] as `/joint_states` (q, qd, tau) plus one JointState topic per
/// `(topic, T x N array)` in `extra`, carried in the `effort` field (e.g.
/// `("/ivdyn/predicted", &tau_model)`, `("/ivdyn/residual", &res)`), plus
/// `/ivdyn/command` if the log has `u` and `/ivdyn/current` if it has motor currents.
/// Stamps are `t0_ns + t`.
pub fn write_mcap(path: impl AsRef<Path>, log: &JointLog, extra: &[(&str, &[f64])]) -> Result<PathBuf> {
    let (t, n) = (log.len(), log.dof());
    log.check_shapes()?; // non-finite values are allowed in an output; bad shapes are not
    for (topic, a) in extra {
        if a.len() != t * n {
            return Err(Error::Dimension { what: format!("array for {topic}"), expected: t * n, got: a.len() });
        }
    }
    let mut w = McapWriter::create(path)?;
    let meas = w.add_joint_state_topic("/joint_states")?;
    let ids: Vec<TopicId> = extra.iter().map(|(tp, _)| w.add_joint_state_topic(tp)).collect::<Result<_>>()?;
    let cmd = if log.u.is_some() { Some(w.add_joint_state_topic("/ivdyn/command")?) } else { None };
    let cur = if log.current.is_some() { Some(w.add_joint_state_topic("/ivdyn/current")?) } else { None };
    let row = |a: &Option<Vec<f64>>, k: usize| -> Vec<f64> {
        a.as_ref().map(|a| a[k * n..(k + 1) * n].to_vec()).unwrap_or_default()
    };
    for k in 0..t {
        let stamp = log.t0_ns.saturating_add((log.t[k] * 1e9).round() as i64);
        w.write(meas, stamp, &log.joint_names, &log.q[k * n..(k + 1) * n], &row(&log.qd, k), &row(&log.tau, k))?;
        for (id, (_, a)) in ids.iter().zip(extra) {
            w.write(*id, stamp, &log.joint_names, &[], &[], &a[k * n..(k + 1) * n])?;
        }
        if let Some(c) = cmd {
            w.write(c, stamp, &log.joint_names, &[], &[], &row(&log.u, k))?;
        }
        if let Some(c) = cur {
            w.write(c, stamp, &log.joint_names, &[], &[], &row(&log.current, k))?;
        }
    }
    w.finish()
}

/// Topic of the model's predicted torques written by `identify --out-mcap`.
pub const PREDICTED_TOPIC: &str = "/ivdyn/predicted";
/// Topic of the residuals (measured - predicted) written by `identify --out-mcap`.
pub const RESIDUAL_TOPIC: &str = "/ivdyn/residual";
/// Topic of the measured copy written by `identify --out-mcap` and `diagnose`: under
/// `/ivdyn/` like every output topic, so that the output opened next to the original bag
/// (in Foxglove) does not add a second `/joint_states`.
pub const MEASURED_TOPIC: &str = "/ivdyn/measured";

/// Writes, sample by sample on the same stamps, the measured JointState
/// ([`MEASURED_TOPIC`]: position, velocity if measured, effort), the model's prediction
/// ([`PREDICTED_TOPIC`]: the smoothed position and velocity the model was evaluated at,
/// effort = predicted torque) and the residual ([`RESIDUAL_TOPIC`]: effort = measured -
/// predicted, computed here so that it is exactly the difference of the two written
/// values). Staged and put in place at `finish` as [`McapWriter`].
#[derive(Debug)]
pub struct PredictionWriter {
    w: McapWriter,
    ids: [TopicId; 3],
    names: Vec<String>,
    samples: usize,
}

impl PredictionWriter {
    /// Starts the file for these joints.
    pub fn create(path: impl AsRef<Path>, names: &[String]) -> Result<Self> {
        let mut w = McapWriter::create(path)?;
        let ids = [
            w.add_joint_state_topic(MEASURED_TOPIC)?,
            w.add_joint_state_topic(PREDICTED_TOPIC)?,
            w.add_joint_state_topic(RESIDUAL_TOPIC)?,
        ];
        Ok(PredictionWriter { w, ids, names: names.to_vec(), samples: 0 })
    }

    /// Writes `T` samples (`stamps` in ns; arrays `T x N`; `qd_meas` may be empty).
    #[allow(clippy::too_many_arguments)]
    pub fn write_block(
        &mut self,
        stamps: &[i64],
        q_meas: &[f64],
        qd_meas: &[f64],
        tau_meas: &[f64],
        q_model: &[f64],
        qd_model: &[f64],
        tau_pred: &[f64],
    ) -> Result<()> {
        let n = self.names.len();
        let t = stamps.len();
        for (what, a, need) in [
            ("q", q_meas, true),
            ("qd", qd_meas, false),
            ("tau", tau_meas, true),
            ("q model", q_model, true),
            ("qd model", qd_model, true),
            ("prediction", tau_pred, true),
        ] {
            if (need || !a.is_empty()) && a.len() != t * n {
                return Err(Error::Dimension {
                    what: format!("PredictionWriter {what} (T x N)"),
                    expected: t * n,
                    got: a.len(),
                });
            }
        }
        let mut res = vec![0.0; n];
        for k in 0..t {
            let r = k * n..(k + 1) * n;
            let qd = if qd_meas.is_empty() { &[][..] } else { &qd_meas[r.clone()] };
            self.w.write(self.ids[0], stamps[k], &self.names, &q_meas[r.clone()], qd, &tau_meas[r.clone()])?;
            self.w.write(
                self.ids[1],
                stamps[k],
                &self.names,
                &q_model[r.clone()],
                &qd_model[r.clone()],
                &tau_pred[r.clone()],
            )?;
            for (j, v) in res.iter_mut().enumerate() {
                *v = tau_meas[k * n + j] - tau_pred[k * n + j];
            }
            self.w.write(self.ids[2], stamps[k], &self.names, &[], &[], &res)?;
        }
        self.samples += t;
        Ok(())
    }

    /// Samples written.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Finishes the file (summary, rename).
    pub fn finish(self) -> Result<PathBuf> {
        self.w.finish()
    }
}
