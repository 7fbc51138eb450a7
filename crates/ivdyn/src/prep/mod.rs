//! The one conditioning policy of identify, payload, diagnose and prediction: a log's
//! stamps deduplicated and made uniform, `q` smoothed and differentiated ([`condition`];
//! the diagnosis takes the log's own velocity instead where it can,
//! [`condition_with_log_velocity`]), and the parallel filter that torque and regressor
//! share ([`parallel_filter`]).
//! [`stream`] and [`filtfilt`] are its block-by-block twins for logs larger than memory.

pub mod filtfilt;
pub mod stream;

use crate::dsp::{
    Butterworth, Decimator, Derivatives, DiffMethod, HampelOptions, Interp, OutlierReport, SavitzkyGolay, central_diff,
    dedup_stamps, default_cutoff, differentiate, hampel, median_dt, resample_uniform, take_rows,
};
use crate::error::{Error, Result};
use crate::log::JointLog;

fn bad(msg: &str) -> Error {
    Error::Estimation { msg: msg.into() }
}

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
}

impl Default for ConditionOptions {
    fn default() -> Self {
        ConditionOptions {
            dt: None,
            max_jitter: 0.01,
            interp: Interp::Linear,
            tau_outliers: None,
            diff: DiffMethod::default(),
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
    /// Whether `d.qd` (and so `d.qdd`) comes from the log's own velocity
    /// ([`condition_with_log_velocity`]) rather than from differentiating `q`.
    pub velocity_from_log: bool,
}

/// Drops duplicated stamps, resamples if the stamps are uneven, rejects torque outliers
/// (if asked) and differentiates `q` (the log's own `qd` is not used: encoder velocity
/// estimates of drives are often lagged).
pub fn condition(log: &JointLog, opts: &ConditionOptions) -> Result<Conditioned> {
    log.check_shapes()?;
    let n = log.dof();
    let dd = dedup_stamps(&log.t)?;
    let t: Vec<f64> = dd.keep.iter().map(|&k| log.t[k]).collect();
    let pick = |a: &[f64]| take_rows(a, n, &dd.keep);
    let dt = match opts.dt {
        Some(dt) => dt,
        None => median_dt(&t).ok_or_else(|| bad("need at least two distinct stamps"))?,
    };
    let uneven = t.windows(2).any(|w| ((w[1] - w[0]) - dt).abs() > opts.max_jitter * dt);
    let re = |a: &[f64]| -> Result<Vec<f64>> {
        if uneven || opts.dt.is_some() { Ok(resample_uniform(&t, a, n, dt, opts.interp)?.1) } else { Ok(a.to_vec()) }
    };
    let q = re(&pick(&log.q))?;
    let mut tau = log.tau.as_ref().map(|a| re(&pick(a))).transpose()?;
    let u = log.u.as_ref().map(|a| re(&pick(a))).transpose()?;
    let tg = if uneven || opts.dt.is_some() { resample_uniform(&t, &t, 1, dt, Interp::Linear)?.0 } else { t.clone() };
    let outliers = match (&mut tau, &opts.tau_outliers) {
        (Some(tau), Some(h)) => Some(hampel(tau, n, h)?),
        _ => None,
    };
    let d = differentiate(&q, n, dt, &opts.diff)?;
    let resampled = uneven || opts.dt.is_some();
    Ok(Conditioned { t: tg, dt, d, tau, u, duplicates: dd.dropped, resampled, outliers, velocity_from_log: false })
}

/// [`condition`], but with the log's own velocity when it has one and its samples were
/// kept as they are (no duplicated stamps, no resampling): an encoder or simulator
/// velocity is better than a differentiated position when it is not lagged (the
/// diagnosis; identification keeps [`condition`]). The velocity is smoothed by the same
/// method as `q` and differentiated for `qdd` ([`log_velocity`]); `q` stays as
/// [`condition`] smooths it. Otherwise the same as [`condition`].
pub fn condition_with_log_velocity(log: &JointLog, opts: &ConditionOptions) -> Result<Conditioned> {
    let mut c = condition(log, opts)?;
    let Some(qd) = log.qd.as_ref() else {
        return Ok(c);
    };
    if c.resampled || c.duplicates > 0 {
        // its rows no longer match the conditioned stamps
        return Ok(c);
    }
    let n = log.dof();
    if let Some(i) = qd.iter().position(|v| !v.is_finite()) {
        return Err(bad(&format!("sample {}, joint {}: velocity is {}", i / n, log.joint_names[i % n], qd[i])));
    }
    (c.d.qd, c.d.qdd) = log_velocity(qd, n, c.dt, &opts.diff)?;
    c.velocity_from_log = true;
    Ok(c)
}

/// A measured velocity (`T x n`) smoothed like `q` in [`differentiate`], and its
/// derivative: the zero-phase Butterworth low-pass then central differences, or the
/// Savitzky-Golay fit's value and first derivative.
fn log_velocity(qd: &[f64], n: usize, dt: f64, method: &DiffMethod) -> Result<(Vec<f64>, Vec<f64>)> {
    match method {
        DiffMethod::Butterworth { order, cutoff_hz } => {
            let fs = 1.0 / dt;
            let f = Butterworth::zero_phase(*order, cutoff_hz.unwrap_or_else(|| default_cutoff(fs)), fs)?;
            let qd = f.filtfilt_columns(qd, n)?;
            let qdd = central_diff(&qd, n, dt)?;
            Ok((qd, qdd))
        }
        DiffMethod::SavitzkyGolay { window, order } => {
            let sg = SavitzkyGolay::new(*window, *order)?;
            Ok((sg.apply(qd, n, 0, dt)?, sg.apply(qd, n, 1, dt)?))
        }
    }
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

/// The parallel filter: [`Decimator::new`] for a factor > 1 (`0` = [`auto_decimation`]),
/// else the default differentiation filter alone.
pub(crate) fn parallel_filter(decimate: usize, fs: f64, condition: &ConditionOptions) -> Result<Decimator> {
    let f = if decimate == 0 { auto_decimation(fs, condition) } else { decimate };
    if f > 1 { Decimator::new(f, fs) } else { Decimator::with_filter(1, Butterworth::default_for(fs)?) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-joint sine log at 1 kHz with its exact velocity, optionally one stamp repeated.
    fn sine_log(duplicate: bool) -> JointLog {
        let mut t: Vec<f64> = (0..1000).map(|k| k as f64 * 1e-3).collect();
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
    fn log_velocity_only_on_kept_samples() {
        let opts = ConditionOptions::default();
        let log = sine_log(false);
        let plain = condition(&log, &opts).unwrap();
        assert!(!plain.velocity_from_log);
        let c = condition_with_log_velocity(&log, &opts).unwrap();
        assert!(c.velocity_from_log);
        // q and everything but the derivatives as `condition` gives them
        assert_eq!((&c.t, &c.d.q, &c.tau), (&plain.t, &plain.d.q, &plain.tau));
        // the log's velocity through the same filter as q (the default: DEFAULT_ORDER at
        // the default cutoff)
        let fs = 1.0 / c.dt;
        let f = Butterworth::zero_phase(crate::dsp::DEFAULT_ORDER, default_cutoff(fs), fs).unwrap();
        let qd = f.filtfilt_columns(log.qd.as_ref().unwrap(), 2).unwrap();
        assert!(c.d.qd == qd);
        assert!(c.d.qdd == central_diff(&qd, 2, c.dt).unwrap());
        // and close to the exact velocity inside (not the differentiated q's lag or noise)
        let exact = log.qd.as_ref().unwrap();
        assert!((200..1600).all(|i| (c.d.qd[i] - exact[i]).abs() < 1e-3 * 6.3), "smoothed velocity off");
        // a repeated stamp: the log's rows no longer match, `condition` as is
        let log = sine_log(true);
        let c = condition_with_log_velocity(&log, &opts).unwrap();
        assert!(!c.velocity_from_log);
        assert!(c == condition(&log, &opts).unwrap());
    }

    #[test]
    fn log_velocity_must_be_finite() {
        let mut log = sine_log(false);
        log.qd.as_mut().unwrap()[7] = f64::NAN;
        let e = condition_with_log_velocity(&log, &ConditionOptions::default()).unwrap_err();
        assert!(e.to_string().contains("sample 3, joint b: velocity is NaN"), "{e}");
        assert!(condition(&log, &ConditionOptions::default()).is_ok());
    }
}
