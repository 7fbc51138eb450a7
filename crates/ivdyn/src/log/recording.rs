//! A recording, whatever its storage: an MCAP file, a rosbag2 sqlite3 file, either
//! compressed as a whole, or a rosbag2 directory. [`for_each_sample`] streams it (the files
//! of a directory in order, as one log); [`read_mcap`] reads it whole, with the command and
//! current topics aligned to the measurement stamps. The storages' own readers are
//! [`super::mcap`] and [`super::db3`]; [`super::bag`] finds the files of a log.

use std::path::Path;

use super::JointLog;
use super::mcap::{CommandAlign, CommandField, ReadOptions, Sample, Source, StreamSummary, log_err};
use crate::error::Result;

/// Streams every message of the measured (and command) topic to `f`, in log order, in
/// one pass with bounded memory. Returns what was seen. Errors from `f` stop the pass
/// and are returned as they are.
///
/// `path` is an MCAP file, a rosbag2 sqlite3 file (`.db3`), either compressed as a whole
/// (`.mcap.zstd`, `.db3.zstd`), or a rosbag2 directory (split files read in order as one
/// log): see [`super::bag`].
pub fn for_each_sample<F>(path: impl AsRef<Path>, opts: &ReadOptions, f: F) -> Result<StreamSummary>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    super::bag::for_each_sample_in(path.as_ref(), opts, f)
}

/// Reads a whole JointState log into memory (one streaming pass; the result is `T x N`).
/// The command topic, if any, is aligned to the measurement stamps
/// ([`ReadOptions::command_align`]), the current topic by linear interpolation. Times are
/// relative to the first measurement.
pub fn read_mcap(path: impl AsRef<Path>, opts: &ReadOptions) -> Result<JointLog> {
    let path = path.as_ref();
    let n = opts.joint_names.len();
    let mut stamps: Vec<i64> = vec![];
    let (mut q, mut qd, mut tau) = (vec![], vec![], vec![]);
    let (mut has_qd, mut has_tau) = (false, false);
    let (mut cmd, mut cur) = (Aligned::default(), Aligned::default());
    let field = opts.command_field;
    let summary = for_each_sample(path, opts, |s| {
        let at = |topic: &Option<String>| format!("topic {}, sample {}", topic.as_deref().unwrap_or(""), s.index);
        let picked = match s.source {
            Source::Measured => {
                stamps.push(s.stamp_ns);
                q.extend_from_slice(s.q.unwrap_or(&[]));
                if let Some(v) = s.qd {
                    has_qd = true;
                    qd.extend_from_slice(v);
                }
                if let Some(v) = s.tau {
                    has_tau = true;
                    tau.extend_from_slice(v);
                }
                return Ok(());
            }
            Source::Command => cmd
                .push(s, field)
                .ok_or_else(|| format!("{}: the command field {field:?} is empty", at(&opts.command_topic))),
            Source::Current => cur
                .push(s, CommandField::Effort)
                .ok_or_else(|| format!("{}: effort (the current) is empty", at(&opts.current_topic))),
        };
        picked.map_err(|msg| log_err(path, msg))
    })?;
    let t0 = stamps[0];
    let t = stamps.iter().map(|&s| (s - t0) as f64 * 1e-9).collect();
    let u = opts.command_topic.as_ref().map(|_| align(&stamps, &cmd.t, &cmd.v, n, opts.command_align));
    let mut log = JointLog {
        joint_names: opts.joint_names.clone(),
        t0_ns: t0,
        t,
        q,
        qd: has_qd.then_some(qd),
        tau: has_tau.then_some(tau),
        u,
        current: None,
        truncated: summary.truncated,
    };
    if let Some(c) = &opts.current_topic {
        log.current = if *c == opts.topic {
            // the measured effort is the current: the log has no torque
            Some(log.tau.take().ok_or_else(|| log_err(path, format!("topic {c}: effort is empty (no current)")))?)
        } else {
            Some(align(&stamps, &cur.t, &cur.v, n, CommandAlign::Linear))
        };
    }
    Ok(log)
}

/// The rows of a second topic (command or current), to align to the measurement stamps.
#[derive(Default)]
struct Aligned {
    t: Vec<i64>,
    v: Vec<f64>,
}

impl Aligned {
    /// Appends `field` of `s`; `None` when the message has it empty.
    fn push(&mut self, s: &Sample<'_>, field: CommandField) -> Option<()> {
        let v = match field {
            CommandField::Position => s.q,
            CommandField::Velocity => s.qd,
            CommandField::Effort => s.tau,
        }?;
        self.t.push(s.stamp_ns);
        self.v.extend_from_slice(v);
        Some(())
    }
}

/// Aligns command rows (`ct`, non-decreasing, non-empty) to measurement stamps `mt`.
fn align(mt: &[i64], ct: &[i64], c: &[f64], n: usize, how: CommandAlign) -> Vec<f64> {
    let mut out = Vec::with_capacity(mt.len() * n);
    let mut i = 0; // last command index with ct[i] <= t (or 0)
    for &t in mt {
        while i + 1 < ct.len() && ct[i + 1] <= t {
            i += 1;
        }
        let row = |k: usize| &c[k * n..(k + 1) * n];
        if t <= ct[0] || i + 1 >= ct.len() || how == CommandAlign::ZeroOrderHold {
            out.extend_from_slice(row(i));
        } else {
            let (a, b) = (ct[i], ct[i + 1]);
            let w = if b > a { (t - a) as f64 / (b - a) as f64 } else { 0.0 };
            out.extend(row(i).iter().zip(row(i + 1)).map(|(x, y)| x + w * (y - x)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn align_zoh_and_linear() {
        let mt = [0, 5, 10, 15, 20, 25];
        let ct = [5, 15, 15, 20];
        let c = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(align(&mt, &ct, &c, 1, CommandAlign::ZeroOrderHold), vec![1.0, 1.0, 1.0, 3.0, 4.0, 4.0]);
        assert_eq!(align(&mt, &ct, &c, 1, CommandAlign::Linear), vec![1.0, 1.0, 1.5, 3.0, 4.0, 4.0]);
    }
}
