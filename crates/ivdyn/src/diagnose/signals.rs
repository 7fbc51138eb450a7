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
    /// Whether the log's stamps were resampled onto the uniform grid.
    pub(super) resampled: bool,
    /// Torque noise std per joint on the log's own samples and stamps
    /// (`residual::sample_noise`, set by `prepare`), when they were resampled: the
    /// interpolation onto the uniform grid averages neighbouring samples' noise, so the
    /// grid's residual shows less of it than the sensor has.
    pub(super) sample_noise: Option<Vec<f64>>,
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

    /// Every `k`-th block of [`SUBSAMPLE_BLOCK`] samples, `k` the smallest that keeps at
    /// most about `max_rows` of the `n`-joint samples; `None` when all of them fit. Spread
    /// over the whole log (every part of the motion is in it) and contiguous within a block
    /// (differences in time stay exact: each kept block starts a segment).
    pub(super) fn every_kth_block(&self, n: usize, max_rows: usize) -> Option<Signals> {
        let t_len = self.t.len();
        if t_len <= max_rows {
            return None;
        }
        let k = t_len.div_ceil(max_rows.max(SUBSAMPLE_BLOCK));
        let firsts: Vec<usize> = (0..t_len).step_by(k * SUBSAMPLE_BLOCK).collect();
        Some(self.blocks_at(n, &firsts))
    }

    /// As many whole blocks of [`SUBSAMPLE_BLOCK`] samples as `max_rows` holds (at least
    /// one), spread evenly over the log: block `floor(i m / keep)` of its `m` for `i < keep`.
    /// `None` when all samples fit. Unlike [`Signals::every_kth_block`] it keeps all but a
    /// block's worth of what fits, not as little as half of it.
    pub(super) fn spread_blocks(&self, n: usize, max_rows: usize) -> Option<Signals> {
        let t_len = self.t.len();
        if t_len <= max_rows {
            return None;
        }
        let m = t_len.div_ceil(SUBSAMPLE_BLOCK);
        let keep = (max_rows / SUBSAMPLE_BLOCK).clamp(1, m);
        let firsts: Vec<usize> = (0..keep).map(|i| i * m / keep * SUBSAMPLE_BLOCK).collect();
        Some(self.blocks_at(n, &firsts))
    }

    /// The blocks of [`SUBSAMPLE_BLOCK`] samples starting at `firsts` (increasing), each
    /// starting a segment, with any segment starting inside one.
    fn blocks_at(&self, n: usize, firsts: &[usize]) -> Signals {
        let t_len = self.t.len();
        let mut out = Signals {
            t: vec![],
            q: vec![],
            qd: vec![],
            qdd: vec![],
            tau: vec![],
            velocity_in_log: self.velocity_in_log,
            velocity: self.velocity.clone(),
            dt: self.dt,
            cutoff_hz: self.cutoff_hz,
            align: self.align,
            starts: vec![],
            resampled: self.resampled,
            sample_noise: self.sample_noise.clone(),
        };
        for &a in firsts {
            let b = (a + SUBSAMPLE_BLOCK).min(t_len);
            let base = out.t.len();
            out.starts.push(base);
            out.starts.extend(self.starts.iter().filter(|&&s| s > a && s < b).map(|&s| base + s - a));
            out.t.extend_from_slice(&self.t[a..b]);
            for (dst, src) in
                [(&mut out.q, &self.q), (&mut out.qd, &self.qd), (&mut out.qdd, &self.qdd), (&mut out.tau, &self.tau)]
            {
                dst.extend_from_slice(&src[a * n..b * n]);
            }
        }
        out
    }
}

/// Samples of one block of [`Signals::every_kth_block`] and [`Signals::spread_blocks`].
pub(super) const SUBSAMPLE_BLOCK: usize = 500;

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
        resampled: parts.iter().any(|c| c.resampled),
        sample_noise: None,
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

/// Smallest lag of a taken log velocity behind the positions' derivative, in samples, that
/// the details name (`Signals::velocity_lag_note`).
const LAG_NOTE_SAMPLES: f64 = 0.25;

impl Signals {
    /// A detail naming the joints whose log velocity, taken, lags the positions' derivative by
    /// at least `LAG_NOTE_SAMPLES` (docs/diagnose.md "Uncertainty": such a lag passes the
    /// velocity check, the torque's alignment cannot take it out on smooth motion, and
    /// viscous friction takes the inertial torque's shift: on MuJoCo logs at 1 kHz with half a
    /// sample, 0.5-0.8 % of `fv`, 12.7 % on one joint with little friction).
    pub(super) fn velocity_lag_note(&self) -> Option<String> {
        let lagged: Vec<(&str, f64)> = self
            .velocity
            .iter()
            .filter_map(|c| match (c.source.as_str(), c.lag_s) {
                ("log", Some(lag)) if lag.abs() >= LAG_NOTE_SAMPLES * self.dt => Some((c.joint.as_str(), lag)),
                _ => None,
            })
            .collect();
        if lagged.is_empty() {
            return None;
        }
        let names: Vec<&str> = lagged.iter().map(|x| x.0).collect();
        let (lo, hi) = lagged.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x.1), b.max(x.1)));
        let range = |k: f64| {
            if (hi - lo) * k < 0.005 { format!("{:.2}", lo * k) } else { format!("{:.2} to {:.2}", lo * k, hi * k) }
        };
        Some(format!(
            "the log's velocity lags the positions' derivative on {} by {} ms ({} sample): the velocity check passes a lag this small, but the torque's alignment to the motion cannot take it out on smooth motion, and viscous friction (and the levels fitted beside it) take part of the inertial torque's shift, by up to a few % of `fv` (13 % on a joint with little friction, docs/diagnose.md \"Uncertainty\"); `--velocity positions` diagnoses from the positions' derivative instead, to compare (noisier at a low sample rate)",
            names.join(", "),
            range(1e3),
            range(1.0 / self.dt)
        ))
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    /// `t_len` samples of 2 joints, value = sample index, segments at `starts`.
    fn ramp(t_len: usize, starts: Vec<usize>) -> Signals {
        let x: Vec<f64> = (0..t_len).flat_map(|k| [k as f64, k as f64]).collect();
        Signals {
            t: (0..t_len).map(|k| k as f64).collect(),
            q: x.clone(),
            qd: x.clone(),
            qdd: x.clone(),
            tau: x,
            velocity_in_log: true,
            velocity: vec![],
            dt: 1e-3,
            cutoff_hz: 20.0,
            align: 0.0,
            starts,
            resampled: false,
            sample_noise: None,
        }
    }

    /// A joint's velocity choice: `source`, lag `lag_s`.
    fn choice(joint: &str, source: &str, lag_s: Option<f64>) -> prep::VelocityChoice {
        prep::VelocityChoice {
            joint: joint.into(),
            source: source.into(),
            gain: Some(1.0),
            lag_s,
            r2: Some(1.0),
            why: String::new(),
        }
    }

    /// At 1 kHz: half a sample of lag on a taken log velocity is named, with its joints and
    /// size; a tenth of a sample, or a lag on a joint whose velocity comes from the positions,
    /// is not.
    #[test]
    fn a_taken_log_velocity_lagging_by_half_a_sample_is_named() {
        let mut s = ramp(10, vec![0]);
        s.velocity = vec![choice("j1", "log", Some(5e-4)), choice("j2", "positions", Some(5e-4))];
        let note = s.velocity_lag_note().expect("half a sample is named");
        assert!(note.contains("on j1 by 0.50 ms (0.50 sample)"), "{note}");
        assert!(!note.contains("j2"), "{note}");
        s.velocity = vec![choice("j1", "log", Some(1e-4)), choice("j2", "log", None)];
        assert_eq!(s.velocity_lag_note(), None);
    }

    #[test]
    fn every_kth_block_keeps_whole_blocks_and_their_segment_starts() {
        let b = SUBSAMPLE_BLOCK;
        assert!(ramp(3 * b, vec![0]).every_kth_block(2, 3 * b).is_none());
        // 10 blocks, at most 4 blocks' worth kept: k = 3, blocks 0, 3, 6, 9; a segment of
        // the log starting inside block 3 starts one in the subsample too
        let s = ramp(10 * b, vec![0, 3 * b + 7]).every_kth_block(2, 4 * b).unwrap();
        assert_eq!(s.t.len(), 4 * b);
        assert_eq!(s.starts, vec![0, b, b + 7, 2 * b, 3 * b]);
        for (i, blk) in [0, 3, 6, 9].iter().enumerate() {
            assert_eq!(s.t[i * b], (blk * b) as f64);
            assert_eq!(s.t[(i + 1) * b - 1], ((blk + 1) * b - 1) as f64);
            assert_eq!(s.tau[2 * (i * b) + 1], (blk * b) as f64);
        }
        assert_eq!(s.q.len(), 2 * s.t.len());
    }

    #[test]
    fn spread_blocks_keeps_as_many_blocks_as_fit_evenly_spread() {
        let b = SUBSAMPLE_BLOCK;
        assert!(ramp(3 * b, vec![0]).spread_blocks(2, 3 * b).is_none());
        // 10 blocks, 4.9 blocks' worth allowed: 4 kept, blocks floor(10 i / 4) = 0, 2, 5, 7
        // (every_kth_block keeps 0, 3, 6, 9 here)
        let s = ramp(10 * b, vec![0, 5 * b + 3]).spread_blocks(2, 4 * b + 450).unwrap();
        assert_eq!(s.t.len(), 4 * b);
        assert_eq!(s.starts, vec![0, b, 2 * b, 2 * b + 3, 3 * b]);
        for (i, blk) in [0, 2, 5, 7].iter().enumerate() {
            assert_eq!(s.t[i * b], (blk * b) as f64);
            assert_eq!(s.tau[2 * (i * b) + 1], (blk * b) as f64);
        }
        // 9.5 blocks' worth: 9 kept, where every_kth_block keeps every other one, 5
        let s = ramp(10 * b, vec![0]).spread_blocks(2, 9 * b + b / 2).unwrap();
        assert_eq!(s.t.len(), 9 * b);
        assert_eq!(ramp(10 * b, vec![0]).every_kth_block(2, 9 * b + b / 2).unwrap().t.len(), 5 * b);
        // less than a block allowed: one block, the first
        let s = ramp(10 * b, vec![0]).spread_blocks(2, 7).unwrap();
        assert_eq!((s.t.len(), s.t[0]), (b, 0.0));
    }
}
