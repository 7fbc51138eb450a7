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

/// Conditioned signals, row-major `T x N`.
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
}

impl Signals {
    /// Time from the first to the last sample used (s).
    pub(super) fn duration(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0) - self.t.first().copied().unwrap_or(0.0)
    }
}

/// The log conditioned with zero-phase cutoff `cutoff_hz` (module docs); errors when it
/// has no torque, non-finite values, or fewer than 50 samples left.
pub(super) fn condition(log: &JointLog, opts: &DiagnoseOptions, cutoff_hz: f64) -> Result<Signals> {
    let n = log.dof();
    let tau =
        log.tau.as_ref().ok_or_else(|| Error::NoTorque { what: "log".into(), needed_by: "the diagnosis".into() })?;
    let copts = prep::ConditionOptions {
        diff: dsp::DiffMethod::Butterworth { order: 4, cutoff_hz: Some(cutoff_hz) },
        velocity: opts.velocity,
        window: opts.window,
        exclude: opts.exclude.clone(),
        ..Default::default()
    };
    // prep's one policy: window, repeated samples, duplicates, resampling, smoothing, and
    // the log's velocity where it agrees with the positions
    let c = prep::condition(log, &copts)?;
    let t_len = c.t.len();
    if t_len < MIN_SAMPLES {
        return Err(Error::ShortLog {
            what: "the log".into(),
            samples: t_len,
            needed: MIN_SAMPLES,
            needed_by: "the diagnosis".into(),
        });
    }
    let tau = c.tau.as_ref().unwrap_or(tau);
    if let Some(i) = tau.iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFiniteSample {
            what: "effort".into(),
            sample: i / n,
            joint: log.joint_names[i % n].clone(),
            value: tau[i],
        });
    }
    // the first and last samples carry the filters' and differences' edge transients:
    // two time constants of the cutoff (at least 2 samples) are left out at both ends
    // (`as usize` saturates for an absurd cutoff or sample spacing: the sum must not wrap)
    let trim = ((2.0 / (cutoff_hz * c.dt)).ceil() as usize).max(2);
    if trim.checked_mul(2).and_then(|e| e.checked_add(MIN_SAMPLES)).is_none_or(|need| t_len <= need) {
        return Err(Error::ShortLog {
            what: "the log".into(),
            samples: t_len.saturating_sub(trim.saturating_mul(2)),
            needed: MIN_SAMPLES,
            needed_by: format!(
                "the diagnosis (after dropping {trim} edge samples at each end for the cut-off {cutoff_hz} Hz)"
            ),
        });
    }
    let cut = |x: &[f64]| x[trim * n..(t_len - trim) * n].to_vec();
    Ok(Signals {
        t: c.t[trim..t_len - trim].to_vec(),
        q: cut(&c.d.q),
        qd: cut(&c.d.qd),
        qdd: cut(&c.d.qdd),
        tau: cut(tau),
        velocity_in_log: c.velocity_from_log,
        velocity: c.velocity.clone(),
        dt: c.dt,
        cutoff_hz,
        align: 0.0,
    })
}

impl Signals {
    /// Moves the acceleration `a` samples in time ([`accel_step`]) and records the shift.
    pub(super) fn align_acceleration(&mut self, a: f64, n: usize) {
        let delta = accel_step(&self.qd, n, self.dt);
        for (x, dl) in self.qdd.iter_mut().zip(&delta) {
            *x += a * dl;
        }
        self.align = a;
    }
}

/// `qdd_fwd[k] - qdd_fwd[k-1]` with `qdd_fwd[k] = (qd[k+1] - qd[k]) / dt`: adding `a` times
/// it to the central-difference acceleration moves it by `a` samples in time
/// (`a = 1/2`: the forward difference, the acceleration a torque applied over
/// `[t_k, t_k+1)` produces; `-1/2`: the backward difference).
pub(super) fn accel_step(qd: &[f64], n: usize, dt: f64) -> Vec<f64> {
    let t_len = qd.len() / n;
    let mut out = vec![0.0; qd.len()];
    for k in 1..t_len.saturating_sub(1) {
        for j in 0..n {
            let f1 = (qd[(k + 1) * n + j] - qd[k * n + j]) / dt;
            let f0 = (qd[k * n + j] - qd[(k - 1) * n + j]) / dt;
            out[k * n + j] = f1 - f0;
        }
    }
    out
}
