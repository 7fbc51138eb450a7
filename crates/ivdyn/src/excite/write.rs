//! The trajectory writers: CSV for inspection and re-reading, MCAP for a robot to replay.

use std::path::Path;

use super::fourier::Samples;
use crate::error::Result;
use crate::log::JointLog;

/// Writes the trajectory as CSV: `t`, `<joint>.q`, `<joint>.qd`, `<joint>.qdd` (the
/// `docs/logs.md` naming; `io::read_csv` reads `t`, `q`, `qd` and ignores `qdd`), shortest
/// round-trip decimals, all or nothing ([`crate::output`]).
pub fn write_csv(path: &Path, joints: &[String], s: &Samples) -> Result<()> {
    crate::log::csv::write_columns(path, 0, joints, &s.t, &[("q", &s.q), ("qd", &s.qd), ("qdd", &s.qdd)])
}

/// Writes the trajectory as MCAP `/joint_states` (position and velocity; no effort) for a
/// robot to replay.
pub fn write_mcap(path: &Path, joints: &[String], s: &Samples) -> Result<()> {
    let log = JointLog {
        joint_names: joints.to_vec(),
        t0_ns: 0,
        t: s.t.clone(),
        q: s.q.clone(),
        qd: Some(s.qd.clone()),
        tau: None,
        u: None,
        current: None,
        truncated: false,
    };
    crate::log::write_mcap(path, &log, &[]).map(|_| ())
}
