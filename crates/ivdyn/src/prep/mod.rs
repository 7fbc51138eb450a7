//! The one conditioning policy of identify, payload, diagnose and prediction: a log's
//! stamps deduplicated and made uniform, `q` smoothed and differentiated ([`condition`]),
//! and the parallel filter that torque and regressor share ([`parallel_filter`]).
//! [`stream`] and [`filtfilt`] are its block-by-block twins for logs larger than memory.

pub mod filtfilt;
pub mod stream;

use crate::dsp::{
    Butterworth, Decimator, Derivatives, DiffMethod, HampelOptions, Interp, OutlierReport, dedup_stamps,
    default_cutoff, differentiate, hampel, median_dt, resample_uniform, take_rows,
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
    Ok(Conditioned { t: tg, dt, d, tau, u, duplicates: dd.dropped, resampled: uneven || opts.dt.is_some(), outliers })
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
