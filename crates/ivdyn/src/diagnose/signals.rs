//! The log conditioned for the diagnosis: uniform samples, smoothed positions and their
//! derivatives (or the log's own velocities), the measured torque, with the filters' edge
//! transients cut off; and the time shift of the acceleration that aligns it with the
//! torque.

use super::DiagnoseOptions;
use crate::dsp;
use crate::error::{Error, Result};
use crate::log::JointLog;
use crate::prep;

/// Samples the diagnosis needs after conditioning and dropping the filters' edges.
const MIN_SAMPLES: usize = 50;

/// Conditioned signals, row-major `T x N`: the log's segments (cut at gaps, prep's one
/// policy) one after the other, each without its filter edges.
pub(super) struct Signals {
    pub(super) t: Vec<f64>,
    pub(super) q: Vec<f64>,
    pub(super) qd: Vec<f64>,
    pub(super) qdd: Vec<f64>,
    pub(super) tau: Vec<f64>,
    pub(super) velocity_in_log: bool,
    pub(super) velocity: Vec<prep::VelocityChoice>,
    pub(super) dt: f64,
    /// Zero-phase cutoff used (Hz).
    pub(super) cutoff_hz: f64,
    /// Torque-to-motion alignment in samples (see [`accel_step`]).
    pub(super) align: f64,
    /// First sample of each segment (the first is 0): differences in time stop at these.
    pub(super) starts: Vec<usize>,
}

impl Signals {
    /// Time the samples used cover (s): their count times the sample time (the gaps
    /// between segments not counted).
    pub(super) fn duration(&self) -> f64 {
        self.t.len() as f64 * self.dt
    }

    /// The segments' sample ranges, in order.
    pub(super) fn segments(&self) -> Vec<std::ops::Range<usize>> {
        segment_ranges(&self.starts, self.t.len())
    }
}

/// Sample ranges of the segments starting at `starts` in `t_len` samples.
pub(super) fn segment_ranges(starts: &[usize], t_len: usize) -> Vec<std::ops::Range<usize>> {
    starts.iter().enumerate().map(|(i, &a)| a..starts.get(i + 1).copied().unwrap_or(t_len)).collect()
}

/// The log conditioned with zero-phase cutoff `cutoff_hz` (module docs): every segment
/// between gaps with more than 50 samples left once its filter edges are dropped, one
/// after the other (a jittered log with re-published samples can have gaps; the longest
/// segment alone lost half of some 20-60 s logs). Errors when it has no torque,
/// non-finite values, or no such segment.
pub(super) fn condition(log: &JointLog, opts: &DiagnoseOptions, cutoff_hz: f64) -> Result<Signals> {
    let n = log.dof();
    if log.tau.is_none() {
        return Err(Error::NoTorque { what: "log".into(), needed_by: "the diagnosis".into() });
    }
    let copts = prep::ConditionOptions {
        diff: dsp::DiffMethod::Butterworth { order: 4, cutoff_hz: Some(cutoff_hz) },
        velocity: opts.velocity,
        window: opts.window,
        exclude: opts.exclude.clone(),
        ..Default::default()
    };
    // prep's one policy: window, repeated samples, duplicates, gaps, resampling,
    // smoothing, and the log's velocity where it agrees with the positions
    let parts = prep::condition_segments(log, &copts)?;
    let dt = parts[0].dt;
    // the first and last samples carry the filters' and differences' edge transients:
    // two time constants of the cutoff (at least 2 samples) are left out at both ends
    // (`as usize` saturates for an absurd cutoff or sample spacing: the sum must not wrap)
    let trim = ((2.0 / (cutoff_hz * dt)).ceil() as usize).max(2);
    let need = trim.checked_mul(2).and_then(|e| e.checked_add(MIN_SAMPLES));
    let mut out = Signals {
        t: vec![],
        q: vec![],
        qd: vec![],
        qdd: vec![],
        tau: vec![],
        velocity_in_log: parts[0].velocity_from_log,
        velocity: parts[0].velocity.clone(),
        dt,
        cutoff_hz,
        align: 0.0,
        starts: vec![],
    };
    let mut first_sample = 0;
    for c in &parts {
        let t_len = c.t.len();
        let tau =
            c.tau.as_ref().ok_or_else(|| Error::NoTorque { what: "log".into(), needed_by: "the diagnosis".into() })?;
        if let Some(i) = tau.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFiniteSample {
                what: "effort".into(),
                sample: first_sample + i / n,
                joint: log.joint_names[i % n].clone(),
                value: tau[i],
            });
        }
        first_sample += t_len;
        if need.is_none_or(|need| t_len <= need) {
            continue;
        }
        let cut = |x: &[f64]| x[trim * n..(t_len - trim) * n].to_vec();
        out.starts.push(out.t.len());
        out.t.extend_from_slice(&c.t[trim..t_len - trim]);
        out.q.extend(cut(&c.d.q));
        out.qd.extend(cut(&c.d.qd));
        out.qdd.extend(cut(&c.d.qdd));
        out.tau.extend(cut(tau));
    }
    if out.t.is_empty() {
        let longest = parts.iter().map(|c| c.t.len()).max().unwrap_or(0);
        return Err(Error::ShortLog {
            what: "the log".into(),
            samples: longest.saturating_sub(trim.saturating_mul(2)),
            needed: MIN_SAMPLES,
            needed_by: format!(
                "the diagnosis (after dropping {trim} edge samples at each end for the cut-off {cutoff_hz} Hz)"
            ),
        });
    }
    Ok(out)
}

impl Signals {
    /// Moves the acceleration `a` samples in time ([`accel_step`]) and records the shift.
    pub(super) fn align_acceleration(&mut self, a: f64, n: usize) {
        let delta = accel_step(&self.qd, n, self.dt, &self.starts);
        for (x, dl) in self.qdd.iter_mut().zip(&delta) {
            *x += a * dl;
        }
        self.align = a;
    }
}

/// `qdd_fwd[k] - qdd_fwd[k-1]` with `qdd_fwd[k] = (qd[k+1] - qd[k]) / dt`: adding `a` times
/// it to the central-difference acceleration moves it by `a` samples in time
/// (`a = 1/2`: the forward difference, the acceleration a torque applied over
/// `[t_k, t_k+1)` produces; `-1/2`: the backward difference). Within each segment
/// (`starts`); 0 on a segment's first and last sample.
pub(super) fn accel_step(qd: &[f64], n: usize, dt: f64, starts: &[usize]) -> Vec<f64> {
    let mut out = vec![0.0; qd.len()];
    for seg in segment_ranges(starts, qd.len() / n) {
        for k in seg.start + 1..seg.end.saturating_sub(1) {
            for j in 0..n {
                let f1 = (qd[(k + 1) * n + j] - qd[k * n + j]) / dt;
                let f0 = (qd[k * n + j] - qd[(k - 1) * n + j]) / dt;
                out[k * n + j] = f1 - f0;
            }
        }
    }
    out
}
