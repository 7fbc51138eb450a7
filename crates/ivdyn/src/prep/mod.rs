//! The one conditioning policy of identify, payload, diagnose and prediction: the window
//! and repeated samples ([`hygiene`]), a log's stamps deduplicated and made uniform, `q`
//! smoothed and differentiated, the log's own velocity taken where it agrees with the
//! positions ([`velocity`]) ([`condition`]), and the parallel filter that torque and
//! regressor share ([`parallel_filter`]).
//! [`stream`] and [`filtfilt`] are its block-by-block twins for logs larger than memory.

pub mod filtfilt;
pub mod hygiene;
pub mod stream;
pub mod velocity;

use serde::Serialize;

use crate::dsp::{
    Butterworth, Decimator, Derivatives, DiffMethod, HampelOptions, Interp, OutlierReport, dedup_stamps,
    default_cutoff, differentiate, hampel, median_dt, resample_uniform, take_rows,
};
use crate::error::{Error, Result};
use crate::log::JointLog;
pub use hygiene::Hygiene;
pub use velocity::{VelocityChoice, VelocitySource};

/// Options of [`condition`].
#[derive(Debug, Clone, PartialEq)]
pub struct ConditionOptions {
    /// Resampling step (s); `None`: the median stamp interval.
    pub dt: Option<f64>,
    /// Resample when stamp intervals deviate from the step by more than this fraction
    /// (default 0.01); resampling is skipped on an already uniform log.
    pub max_jitter: f64,
    /// Interpolation when resampling (default linear).
    pub interp: Interp,
    /// Outlier rejection on the measured torque (`None`: off, the default).
    pub tau_outliers: Option<HampelOptions>,
    /// Differentiation of `q` (default: Butterworth order 4, 20 Hz zero-phase).
    pub diff: DiffMethod,
    /// Where the velocity comes from (default: the log's where consistent).
    pub velocity: VelocitySource,
    /// Only the samples in `[start, end]` seconds from the log's first sample.
    pub window: Option<(f64, f64)>,
    /// Spans `[start, end]` (seconds from the log's first sample, like the window) left
    /// out; the log is cut there like at a gap.
    pub exclude: Vec<(f64, f64)>,
}

impl Default for ConditionOptions {
    fn default() -> Self {
        ConditionOptions {
            dt: None,
            max_jitter: 0.01,
            interp: Interp::Linear,
            tau_outliers: None,
            diff: DiffMethod::default(),
            velocity: VelocitySource::Auto,
            window: None,
            exclude: vec![],
        }
    }
}

/// A conditioned log: uniform samples, smoothed `q` and its derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct Conditioned {
    /// Uniform stamps (s, relative to the log's `t0_ns`).
    pub t: Vec<f64>,
    /// Sample time (s).
    pub dt: f64,
    /// Smoothed positions, velocities, accelerations (`T x N`).
    pub d: Derivatives,
    /// Measured torque resampled (and outlier-cleaned), NOT low-pass filtered: filter it
    /// with the same filter as the regressor ([`Butterworth::filtfilt_columns`] or
    /// [`Decimator`]).
    pub tau: Option<Vec<f64>>,
    /// Command resampled.
    pub u: Option<Vec<f64>>,
    /// Samples dropped as duplicated stamps.
    pub duplicates: usize,
    /// Whether the stamps were resampled.
    pub resampled: bool,
    /// Outliers replaced in the torque.
    pub outliers: Option<OutlierReport>,
    /// Whether `d.qd` (and so `d.qdd`) comes from the log's own velocity on some joint.
    pub velocity_from_log: bool,
    /// What was done before conditioning.
    pub hygiene: Hygiene,
    /// The velocity's source, per joint.
    pub velocity: Vec<VelocityChoice>,
}

/// What conditioning did to a log, for reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConditionSummary {
    /// The window and the repeated samples ([`hygiene`]).
    #[serde(flatten)]
    pub hygiene: Hygiene,
    /// Samples dropped as duplicated stamps.
    pub duplicate_stamps: usize,
    /// Whether uneven stamps were resampled onto a uniform grid.
    pub resampled: bool,
    /// Sample time after conditioning (s).
    pub dt: f64,
    /// The velocity's source, per joint, and why.
    pub velocity: Vec<VelocityChoice>,
}

impl Conditioned {
    /// What was done, for reports.
    pub fn summary(&self) -> ConditionSummary {
        ConditionSummary::of(std::slice::from_ref(self))
    }
}

impl ConditionSummary {
    /// What was done to one log, conditioned into the segments `parts`.
    pub fn of(parts: &[Conditioned]) -> ConditionSummary {
        ConditionSummary {
            hygiene: parts[0].hygiene.clone(),
            duplicate_stamps: parts.iter().map(|p| p.duplicates).sum(),
            resampled: parts.iter().any(|p| p.resampled),
            dt: parts[0].dt,
            velocity: parts[0].velocity.clone(),
        }
    }

    /// Several logs' summaries as one: the counts add; the window, sample time and
    /// velocity choice are the first log's.
    pub fn merge(all: &[ConditionSummary]) -> ConditionSummary {
        let mut m = all[0].clone();
        for s in &all[1..] {
            let (h, o) = (&mut m.hygiene, &s.hygiene);
            h.outside_window += o.outside_window;
            h.repeated += o.repeated;
            h.gaps += o.gaps;
            h.segments += o.segments;
            h.short_samples += o.short_samples;
            h.excluded += o.excluded;
            h.standstill_s += o.standstill_s;
            h.clipped.extend(o.clipped.iter().cloned());
            m.duplicate_stamps += s.duplicate_stamps;
            m.resampled |= s.resampled;
        }
        m
    }
}

/// An interval longer than this many sample times is a gap: the log is cut there into
/// segments, each conditioned on its own (never interpolated across).
pub const GAP_INTERVALS: f64 = 10.0;
/// Segments shorter than this many samples are left out (the filters need room).
pub const MIN_SEGMENT_SAMPLES: usize = 50;

/// A segment on a uniform grid, before the velocity choice.
struct Uniform {
    t: Vec<f64>,
    d: Derivatives,
    qd: Option<Vec<f64>>,
    tau: Option<Vec<f64>>,
    u: Option<Vec<f64>>,
    resampled: bool,
    outliers: Option<OutlierReport>,
}

/// Rows `keep` of `log` (increasing, distinct stamps) onto the grid of step `dt` when the
/// stamps are uneven (or `opts.dt` forces it), torque outliers rejected, `q` differentiated.
fn uniform(log: &JointLog, keep: &[usize], dt: f64, opts: &ConditionOptions) -> Result<Uniform> {
    let n = log.dof();
    let t: Vec<f64> = keep.iter().map(|&k| log.t[k]).collect();
    let uneven = t.windows(2).any(|w| ((w[1] - w[0]) - dt).abs() > opts.max_jitter * dt);
    let resampled = uneven || opts.dt.is_some();
    let re = |a: &[f64]| -> Result<Vec<f64>> {
        let a = take_rows(a, n, keep);
        if resampled { Ok(resample_uniform(&t, &a, n, dt, opts.interp)?.1) } else { Ok(a) }
    };
    let q = re(&log.q)?;
    let qd = log.qd.as_ref().map(|a| re(a)).transpose()?;
    let mut tau = log.tau.as_ref().map(|a| re(a)).transpose()?;
    let u = log.u.as_ref().map(|a| re(a)).transpose()?;
    let tg = if resampled { resample_uniform(&t, &t, 1, dt, Interp::Linear)?.0 } else { t };
    let outliers = match (&mut tau, &opts.tau_outliers) {
        (Some(tau), Some(h)) => Some(hampel(tau, n, h)?),
        _ => None,
    };
    let d = differentiate(&q, n, dt, &opts.diff)?;
    Ok(Uniform { t: tg, d, qd, tau, u, resampled, outliers })
}

/// The rows of each segment: `rows` (distinct, increasing stamps of `t`) cut where an
/// interval exceeds [`GAP_INTERVALS`] sample times. Returns the segments and the gaps.
fn split_at_gaps(t: &[f64], rows: &[usize], dt: f64) -> (Vec<Vec<usize>>, usize) {
    let mut out: Vec<Vec<usize>> = vec![vec![]];
    for (i, &k) in rows.iter().enumerate() {
        if i > 0 && t[k] - t[rows[i - 1]] > GAP_INTERVALS * dt {
            out.push(vec![]);
        }
        out.last_mut().expect("one").push(k);
    }
    let gaps = out.len() - 1;
    (out, gaps)
}

/// The window and repeated samples ([`hygiene::clean`]), duplicated stamps dropped, the
/// log cut at gaps into segments ([`GAP_INTERVALS`]; segments shorter than
/// [`MIN_SEGMENT_SAMPLES`] left out), each segment resampled if its stamps are uneven (the
/// log's velocity with the rest), torque outliers rejected (if asked), `q`
/// differentiated; then the velocity's source per joint over all segments
/// ([`velocity::decide`]). One [`Conditioned`] per segment, in time order.
pub fn condition_segments(log: &JointLog, opts: &ConditionOptions) -> Result<Vec<Conditioned>> {
    log.check_shapes()?;
    let (log, mut hygiene) = hygiene::clean(log, opts.window, &opts.exclude)?;
    let dd = dedup_stamps(&log.t)?;
    let t_kept: Vec<f64> = dd.keep.iter().map(|&k| log.t[k]).collect();
    let dt = match opts.dt {
        Some(dt) => dt,
        None => median_dt(&t_kept).ok_or_else(|| Error::ShortLog {
            what: "the log".into(),
            samples: t_kept.len(),
            needed: 2,
            needed_by: "the sample time (distinct stamps)".into(),
        })?,
    };
    check_sample_time(dt)?;
    let (segments, gaps) = split_at_gaps(&log.t, &dd.keep, dt);
    hygiene.gaps = gaps;
    let mut parts = vec![];
    for rows in segments {
        if gaps > 0 && rows.len() < MIN_SEGMENT_SAMPLES {
            hygiene.short_samples += rows.len();
            continue;
        }
        parts.push(uniform(&log, &rows, dt, opts)?);
    }
    if parts.is_empty() {
        return Err(Error::NoSegment { gaps, min_segment: MIN_SEGMENT_SAMPLES });
    }
    hygiene.segments = parts.len();
    let names = &log.joint_names;
    let lvs = parts
        .iter()
        .map(|p| match (&p.qd, opts.velocity) {
            (Some(qd), VelocitySource::Auto | VelocitySource::Log) => {
                velocity::LogVelocity::new(qd, names, dt, &opts.diff).map(Some)
            }
            _ => Ok(None),
        })
        .collect::<Result<Vec<_>>>()?;
    let pairs: Vec<_> = parts.iter().zip(&lvs).map(|(p, lv)| (&p.d, lv.as_ref())).collect();
    let choices = velocity::decide(&pairs, names, opts.velocity)?;
    let from_log = choices.iter().any(|v| v.source == "log");
    for (p, lv) in parts.iter_mut().zip(&lvs) {
        velocity::apply(&mut p.d, lv.as_ref(), &choices);
    }
    hygiene.standstill_s = settle_standstills(&mut parts, log.dof(), dt);
    Ok(parts
        .into_iter()
        .zip(&lvs)
        .enumerate()
        .map(|(i, (p, _))| {
            Conditioned {
                t: p.t,
                dt,
                d: p.d,
                tau: p.tau,
                u: p.u,
                // the log's count, on its first segment
                duplicates: if i == 0 { dd.dropped } else { 0 },
                resampled: p.resampled,
                outliers: p.outliers,
                velocity_from_log: from_log,
                hygiene: hygiene.clone(),
                velocity: choices.clone(),
            }
        })
        .collect())
}

/// Seconds of standstill over the segments (every joint below
/// [`hygiene::STANDSTILL_SHARE`] of its RMS velocity over all of them, for at least
/// [`hygiene::STANDSTILL_MIN_S`]), where the arm is set at rest: `qd = qdd = 0`. The
/// zero-phase filter spreads the motion's edges into a standstill as ringing of ~1e-6
/// rad/s, whose sign would switch the Coulomb column between `+1` and `-1` while the arm
/// holds still; at rest the model's Coulomb term is then 0, the middle of the band
/// `[-fc, fc]` a joint at rest can hold (on a messy UR5 pair with 2 s standstills at both
/// ends the chatter put the wrist gains 2-8 % off, python/tools/messy_log.py).
fn settle_standstills(parts: &mut [Uniform], n: usize, dt: f64) -> f64 {
    let rows: usize = parts.iter().map(|p| p.t.len()).sum();
    let thr: Vec<f64> = (0..n)
        .map(|j| {
            let ss: f64 = parts.iter().flat_map(|p| p.d.qd.iter().skip(j).step_by(n)).map(|v| v * v).sum();
            hygiene::STANDSTILL_SHARE * (ss / rows.max(1) as f64).sqrt()
        })
        .collect();
    let mut still = 0;
    for p in parts.iter_mut() {
        for r in hygiene::standstills(&p.d.qd, n, dt, &thr) {
            still += r.len();
            p.d.qd[r.start * n..r.end * n].fill(0.0);
            p.d.qdd[r.start * n..r.end * n].fill(0.0);
        }
    }
    still as f64 * dt
}

/// [`condition_segments`], keeping the longest segment when the log has gaps (for the
/// analyses that need one continuous signal; `hygiene.unused_segments` says how many
/// were left out).
pub fn condition(log: &JointLog, opts: &ConditionOptions) -> Result<Conditioned> {
    let mut parts = condition_segments(log, opts)?;
    let unused = parts.len() - 1;
    let duplicates = parts.iter().map(|p| p.duplicates).sum();
    let longest = (0..parts.len()).max_by_key(|&i| (parts[i].t.len(), usize::MAX - i)).expect("one segment");
    let mut c = parts.swap_remove(longest);
    c.duplicates = duplicates;
    c.hygiene.unused_segments = unused;
    Ok(c)
}

/// Decimation factor chosen by `decimate == 0` ("auto"): the output rate is about 2.5x the
/// differentiation cut-off, so that the low-passed noise left in the residual is close to
/// white at the output rate (the LS/IV covariances and the DWH test assume white residuals).
pub fn auto_decimation(fs: f64, condition: &ConditionOptions) -> usize {
    let fc = match &condition.diff {
        DiffMethod::Butterworth { cutoff_hz: Some(c), .. } => *c,
        _ => default_cutoff(fs),
    };
    ((fs / (2.5 * fc) + 1e-9).floor() as usize).max(1)
}

/// Shortest sample time accepted (s): 100 kHz, above any arm's logging rate. The
/// filters are designed at the sample rate and their start-up padding grows with it (a log
/// with 1 ns stamps asked for 12 GB of filter state); such stamps are in the wrong unit.
pub const MIN_SAMPLE_TIME: f64 = 1e-5;

/// Refuses a sample time below [`MIN_SAMPLE_TIME`] (or not positive and finite).
pub fn check_sample_time(dt: f64) -> Result<()> {
    if dt.is_finite() && dt >= MIN_SAMPLE_TIME {
        return Ok(());
    }
    Err(Error::SampleTime { dt, min: MIN_SAMPLE_TIME })
}

/// The parallel filter: [`Decimator::new`] for a factor > 1 (`0` = [`auto_decimation`]),
/// else the default differentiation filter alone. A factor above `samples` (the log's
/// sample count) would leave no sample, and the filter for it would be designed at a
/// vanishing cutoff: refused, naming the option.
pub(crate) fn parallel_filter(
    decimate: usize,
    fs: f64,
    samples: usize,
    condition: &ConditionOptions,
) -> Result<Decimator> {
    // a cut-off far below the rate would make the automatic factor overflow: refuse it here,
    // with the option named, before anything is sized by it
    if let DiffMethod::Butterworth { cutoff_hz, .. } = &condition.diff {
        crate::dsp::resolve_cutoff(*cutoff_hz, fs)?;
    }
    if decimate > samples.max(1) {
        return Err(Error::option("decimate", format!("must be at most the log's {samples} samples, got {decimate}")));
    }
    let f = if decimate == 0 { auto_decimation(fs, condition) } else { decimate };
    if f > 1 { Decimator::new(f, fs) } else { Decimator::with_filter(1, Butterworth::default_for(fs)?) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-joint sine log at 1 kHz with its exact velocity; `jitter` moves every third
    /// stamp by 0.3 ms (the samples are taken at the moved stamps), `duplicate` repeats one.
    fn sine_log(jitter: bool, duplicate: bool) -> JointLog {
        let mut t: Vec<f64> =
            (0..2000).map(|k| k as f64 * 1e-3 + if jitter && k % 3 == 1 { 3e-4 } else { 0.0 }).collect();
        if duplicate {
            t.insert(100, t[99]);
        }
        let w = 2.0 * std::f64::consts::PI;
        JointLog {
            joint_names: vec!["a".into(), "b".into()],
            q: t.iter().flat_map(|&s| [(w * s).sin(), 0.5 * (w * s).cos()]).collect(),
            qd: Some(t.iter().flat_map(|&s| [w * (w * s).cos(), -0.5 * w * (w * s).sin()]).collect()),
            tau: Some(t.iter().flat_map(|&s| [s, -s]).collect()),
            t,
            ..Default::default()
        }
    }

    #[test]
    fn log_velocity_survives_duplicates_and_resampling() {
        let opts = ConditionOptions::default();
        let w = 2.0 * std::f64::consts::PI;
        for (jitter, duplicate) in [(false, false), (true, true)] {
            let log = sine_log(jitter, duplicate);
            let c = condition(&log, &opts).unwrap();
            assert_eq!((c.resampled, c.duplicates), (jitter, usize::from(duplicate)));
            assert!(c.velocity_from_log && c.velocity.iter().all(|v| v.source == "log"), "{:?}", c.velocity);
            // the smoothed log velocity on the uniform grid: w cos(w t), -0.5 w sin(w t)
            let exact = |k: usize| [w * (w * c.t[k]).cos(), -0.5 * w * (w * c.t[k]).sin()];
            for k in 200..1800 {
                for j in 0..2 {
                    assert!((c.d.qd[2 * k + j] - exact(k)[j]).abs() < 1e-3 * w, "sample {k} joint {j}");
                }
            }
        }
    }

    #[test]
    fn positions_policy_and_a_log_without_velocity_differentiate_q() {
        let log = sine_log(false, false);
        let opts = ConditionOptions { velocity: VelocitySource::Positions, ..Default::default() };
        let c = condition(&log, &opts).unwrap();
        assert!(!c.velocity_from_log);
        assert!(c.d == differentiate(&log.q, 2, c.dt, &DiffMethod::default()).unwrap());
        let plain = JointLog { qd: None, ..log };
        let c2 = condition(&plain, &ConditionOptions::default()).unwrap();
        assert!(c2.d == c.d && c2.velocity[0].why == "the log has no velocity");
    }

    #[test]
    fn a_standstill_is_at_rest() {
        // 1 s at rest, then a 1 Hz sine on both joints, 1 s at rest again: the filter rings
        // into the rests; there the velocity and acceleration are exactly 0
        let t: Vec<f64> = (0..4000).map(|k| k as f64 * 1e-3).collect();
        let w = 2.0 * std::f64::consts::PI;
        let moving = |s: f64| (1.0..3.0).contains(&s);
        let log = JointLog {
            joint_names: vec!["a".into(), "b".into()],
            q: t.iter()
                .flat_map(|&s| if moving(s) { [(w * s).sin(), 1.0 - (w * s).cos()] } else { [0.0; 2] })
                .collect(),
            tau: Some(vec![0.0; 8000]),
            t: t.clone(),
            ..Default::default()
        };
        let c = condition(&log, &ConditionOptions::default()).unwrap();
        assert!((1.8..2.0).contains(&c.hygiene.standstill_s), "{}", c.hygiene.standstill_s);
        let at = |k: usize| &c.d.qd[2 * k..2 * k + 2];
        for k in (0..900).chain(3100..4000) {
            assert_eq!(at(k), &[0.0, 0.0], "sample {k}");
            assert_eq!(&c.d.qdd[2 * k..2 * k + 2], &[0.0, 0.0], "sample {k}");
        }
        assert!(at(2000)[0].abs() > 1.0);
    }

    #[test]
    fn log_velocity_must_be_finite() {
        let mut log = sine_log(false, false);
        log.qd.as_mut().unwrap()[7] = f64::NAN;
        let e = condition(&log, &ConditionOptions::default()).unwrap_err();
        assert!(e.to_string().contains("sample 3, joint b: velocity is NaN"), "{e}");
        let opts = ConditionOptions { velocity: VelocitySource::Positions, ..Default::default() };
        assert!(condition(&log, &opts).is_ok());
    }
}
