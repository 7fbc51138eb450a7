//! Which velocity the models see, per joint: the log's own (an encoder or drive estimate,
//! usually less noisy than a differentiated position, and one differentiation fewer for
//! `qdd`) when it agrees with the derivative of the positions, else the derivative.
//!
//! The check fits, over the interior samples, `qd_pos = a qd_log + c qdd_log` (both
//! through the same zero-phase low-pass): `a` is the log's scale error (1: same units),
//! `c` its lag (s, to first order `qd_log(t) = qd(t - c)`). The log's velocity is
//! consistent when `|a - 1| <= MAX_GAIN_ERR`, the lag's velocity error
//! `|c| rms(qdd) / rms(qd)` is at most `MAX_LAG_ERR`, and the fit explains at least
//! `MIN_R2` of the derivative. Regressing the (noisier) derivative on the log's velocity
//! keeps `a` unbiased by the differentiation noise.

use serde::{Deserialize, Serialize};

use crate::dsp::Derivatives;
use crate::dsp::{Butterworth, DiffMethod, SavitzkyGolay, central_diff};
use crate::error::{Error, Result};

/// Largest relative scale error of a consistent log velocity.
pub const MAX_GAIN_ERR: f64 = 0.05;
/// Largest relative velocity error caused by the log velocity's lag.
pub const MAX_LAG_ERR: f64 = 0.05;
/// Smallest share of the derivative's energy the log velocity must explain.
pub const MIN_R2: f64 = 0.5;

/// Where the velocity comes from (`--velocity`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VelocitySource {
    /// The log's velocity on every joint where it is consistent with the positions.
    #[default]
    Auto,
    /// The log's velocity on every joint (an error when the log has none).
    Log,
    /// Differentiated positions.
    Positions,
}

impl VelocitySource {
    /// Parses `auto`, `log` or `positions`.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "auto" => Ok(VelocitySource::Auto),
            "log" => Ok(VelocitySource::Log),
            "positions" => Ok(VelocitySource::Positions),
            _ => Err(Error::option("velocity", format!("must be auto, log or positions, got '{s}'"))),
        }
    }
}

/// The choice made for one joint, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VelocityChoice {
    /// Joint name.
    pub joint: String,
    /// `"log"` or `"positions"`.
    pub source: String,
    /// Scale `a` of the check (`null`: no check, e.g. no velocity in the log).
    pub gain: Option<f64>,
    /// Lag `c` of the log's velocity behind the positions' derivative (s).
    pub lag_s: Option<f64>,
    /// Share of the derivative's energy explained by the log's velocity.
    pub r2: Option<f64>,
    /// The reason, in words.
    pub why: String,
}

/// Sums of the check's normal equations for one joint (they add over segments).
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    sxx: f64,
    sxz: f64,
    szz: f64,
    sxy: f64,
    szy: f64,
    syy: f64,
}

impl Sums {
    /// Adds samples: `y` the positions' derivative, `x` the log velocity, `z` its derivative.
    fn add(&mut self, y: impl Iterator<Item = f64>, x: impl Iterator<Item = f64>, z: impl Iterator<Item = f64>) {
        for ((y, x), z) in y.zip(x).zip(z) {
            self.sxx += x * x;
            self.sxz += x * z;
            self.szz += z * z;
            self.sxy += x * y;
            self.szy += z * y;
            self.syy += y * y;
        }
    }

    /// `(a, c, r2, lag error)`, `None` when the log's velocity carries no motion (zero
    /// energy or a singular fit).
    fn numbers(&self) -> Option<(f64, f64, f64, f64)> {
        let Sums { sxx, sxz, szz, sxy, szy, syy } = *self;
        let det = sxx * szz - sxz * sxz;
        if !(sxx > 0.0 && syy > 0.0 && det > 1e-12 * sxx * szz) {
            return None;
        }
        // 2x2 normal equations of qd_pos = a qd_log + c qdd_log
        let a = (szz * sxy - sxz * szy) / det;
        let c = (sxx * szy - sxz * sxy) / det;
        let ssr = syy - a * sxy - c * szy;
        let lag_err = c.abs() * (szz / sxx).sqrt();
        Some((a, c, 1.0 - ssr.max(0.0) / syy, lag_err))
    }
}

/// Why a checked log velocity is or is not consistent (`None`: consistent).
fn inconsistency(a: f64, c: f64, r2: f64, lag_err: f64) -> Option<String> {
    if r2 < MIN_R2 {
        Some(format!("the log's velocity does not follow the positions' derivative (R² {r2:.2})"))
    } else if (a - 1.0).abs() > MAX_GAIN_ERR {
        let hint = if ((1.0 / a) / (180.0 / std::f64::consts::PI) - 1.0).abs() < 0.05 { " (degrees/s?)" } else { "" };
        Some(format!("the log's velocity is {:.3}x the positions' derivative{hint}", 1.0 / a))
    } else if lag_err > MAX_LAG_ERR {
        Some(format!("the log's velocity lags the positions' derivative by {:.1} ms", 1e3 * c))
    } else {
        None
    }
}

/// A measured velocity (`T x n`) smoothed like `q` in [`crate::dsp::differentiate`], and
/// its derivative: the zero-phase Butterworth low-pass then central differences, or the
/// Savitzky-Golay fit's value and first derivative.
fn smooth(qd: &[f64], n: usize, dt: f64, method: &DiffMethod) -> Result<(Vec<f64>, Vec<f64>)> {
    match method {
        DiffMethod::Butterworth { order, cutoff_hz } => {
            let fs = 1.0 / dt;
            let f = Butterworth::zero_phase(*order, crate::dsp::resolve_cutoff(*cutoff_hz, fs)?, fs)?;
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

/// The log's velocity of one segment, smoothed ([`smooth`]), and its derivative.
#[derive(Debug, Clone)]
pub struct LogVelocity {
    qd: Vec<f64>,
    qdd: Vec<f64>,
}

impl LogVelocity {
    /// Smooths a segment's log velocity (`T x n`, finite: an error names the sample).
    pub fn new(qd_log: &[f64], names: &[String], dt: f64, method: &DiffMethod) -> Result<Self> {
        let n = names.len();
        if let Some(i) = qd_log.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFiniteSample {
                what: "velocity".into(),
                sample: i / n,
                joint: names[i % n].clone(),
                value: qd_log[i],
            });
        }
        let (qd, qdd) = smooth(qd_log, n, dt, method)?;
        Ok(LogVelocity { qd, qdd })
    }
}

/// The choice per joint over the segments `parts` (the positions' derivatives and, when
/// the log has velocities, each segment's [`LogVelocity`]): the check's sums are added
/// over the interior samples of every segment.
pub fn decide(
    parts: &[(&Derivatives, Option<&LogVelocity>)],
    names: &[String],
    policy: VelocitySource,
) -> Result<Vec<VelocityChoice>> {
    let plain = |joint: &String, why: &str| VelocityChoice {
        joint: joint.clone(),
        source: "positions".into(),
        gain: None,
        lag_s: None,
        r2: None,
        why: why.into(),
    };
    if policy == VelocitySource::Positions {
        return Ok(names.iter().map(|j| plain(j, "asked for (velocity: positions)")).collect());
    }
    if parts.iter().any(|p| p.1.is_none()) || parts.is_empty() {
        if policy == VelocitySource::Log {
            return Err(Error::option("velocity", "is 'log' but the log has no velocity"));
        }
        return Ok(names.iter().map(|j| plain(j, "the log has no velocity")).collect());
    }
    let n = names.len();
    let mut sums = vec![Sums::default(); n];
    for (d, lv) in parts {
        let lv = lv.expect("checked");
        let t = lv.qd.len() / n.max(1);
        let e = (t / 50).max(2).min(t / 2);
        for (j, s) in sums.iter_mut().enumerate() {
            let col = |x: &[f64]| (e..t - e).map(move |k| x[k * n + j]).collect::<Vec<f64>>().into_iter();
            s.add(col(&d.qd), col(&lv.qd), col(&lv.qdd));
        }
    }
    Ok(names.iter().zip(&sums).map(|(joint, s)| verdict(joint, s.numbers(), policy)).collect())
}

/// The choice for one joint from the check's numbers.
fn verdict(joint: &str, numbers: Option<(f64, f64, f64, f64)>, policy: VelocitySource) -> VelocityChoice {
    let why_not = match numbers {
        None => Some("the log's velocity carries no motion on this joint".to_string()),
        Some((a, c, r2, lag)) => inconsistency(a, c, r2, lag),
    };
    let use_log = policy == VelocitySource::Log || why_not.is_none();
    let why = match (&why_not, policy) {
        (None, _) => "consistent with the positions' derivative".to_string(),
        (Some(w), VelocitySource::Log) => format!("asked for (velocity: log), although {w}"),
        (Some(w), _) => w.clone(),
    };
    VelocityChoice {
        joint: joint.into(),
        source: if use_log { "log" } else { "positions" }.into(),
        gain: numbers.map(|x| x.0),
        lag_s: numbers.map(|x| x.1),
        r2: numbers.map(|x| x.2),
        why,
    }
}

/// Replaces `d.qd` and `d.qdd` by the smoothed log velocity on the joints `choices` take
/// it from.
pub fn apply(d: &mut Derivatives, lv: Option<&LogVelocity>, choices: &[VelocityChoice]) {
    let Some(lv) = lv else { return };
    let n = choices.len();
    for (j, c) in choices.iter().enumerate().filter(|(_, c)| c.source == "log") {
        debug_assert_eq!(c.joint, choices[j].joint);
        for k in 0..lv.qd.len() / n {
            d.qd[k * n + j] = lv.qd[k * n + j];
            d.qdd[k * n + j] = lv.qdd[k * n + j];
        }
    }
}

/// [`decide`] and [`apply`] on one segment.
pub fn choose(
    d: &mut Derivatives,
    qd_log: Option<&[f64]>,
    names: &[String],
    dt: f64,
    policy: VelocitySource,
    method: &DiffMethod,
) -> Result<Vec<VelocityChoice>> {
    let lv = match (qd_log, policy) {
        (Some(qd), VelocitySource::Auto | VelocitySource::Log) => Some(LogVelocity::new(qd, names, dt, method)?),
        _ => None,
    };
    let choices = decide(&[(&*d, lv.as_ref())], names, policy)?;
    apply(d, lv.as_ref(), &choices);
    Ok(choices)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dsp::differentiate;

    /// One joint `q = sin(w t)` at 1 kHz, its derivative `d`, and a log velocity
    /// `scale w cos(w (t - lag))`.
    fn case(scale: f64, lag: f64) -> (Derivatives, Vec<f64>) {
        let w = 2.0 * std::f64::consts::PI * 0.7;
        let t: Vec<f64> = (0..4000).map(|k| k as f64 * 1e-3).collect();
        let q: Vec<f64> = t.iter().map(|&s| (w * s).sin()).collect();
        let qd: Vec<f64> = t.iter().map(|&s| scale * w * (w * (s - lag)).cos()).collect();
        (differentiate(&q, 1, 1e-3, &DiffMethod::default()).unwrap(), qd)
    }

    fn run(scale: f64, lag: f64, policy: VelocitySource) -> (VelocityChoice, Derivatives) {
        let (mut d, qd) = case(scale, lag);
        let c = choose(&mut d, Some(&qd), &["j".into()], 1e-3, policy, &DiffMethod::default()).unwrap();
        (c[0].clone(), d)
    }

    #[test]
    fn a_consistent_velocity_is_taken_and_its_numbers_are_physical() {
        let (c, d) = run(1.0, 0.0, VelocitySource::Auto);
        assert_eq!(c.source, "log", "{c:?}");
        assert!((c.gain.unwrap() - 1.0).abs() < 1e-3 && c.lag_s.unwrap().abs() < 1e-5, "{c:?}");
        // d.qd is now the smoothed log velocity: w cos(w t) inside
        let w = 2.0 * std::f64::consts::PI * 0.7;
        assert!((500..3500).all(|k| (d.qd[k] - w * (w * k as f64 * 1e-3).cos()).abs() < 1e-3 * w));
    }

    #[test]
    fn lag_degrees_and_garbage_are_refused() {
        // 20 ms of lag: the relative velocity error is w 0.02 = 0.088 > MAX_LAG_ERR
        let (c, _) = run(1.0, 0.02, VelocitySource::Auto);
        assert_eq!(c.source, "positions");
        assert!((c.lag_s.unwrap() - 0.02).abs() < 1e-3, "{c:?}");
        assert!(c.why.contains("lags") && c.why.contains("20.0 ms"), "{}", c.why);
        // 2 ms: error 0.009, taken
        assert_eq!(run(1.0, 0.002, VelocitySource::Auto).0.source, "log");
        let (c, _) = run(180.0 / std::f64::consts::PI, 0.0, VelocitySource::Auto);
        assert!(c.source == "positions" && c.why.contains("degrees/s?"), "{c:?}");
        let (c, _) = run(0.0, 0.0, VelocitySource::Auto);
        assert!(c.source == "positions" && c.gain.is_none(), "{c:?}");
        // forced: taken with the reason kept
        let (c, _) = run(1.0, 0.02, VelocitySource::Log);
        assert!(c.source == "log" && c.why.contains("although"), "{c:?}");
        let (c, d) = run(1.0, 0.0, VelocitySource::Positions);
        assert_eq!(c.source, "positions");
        assert!(d == case(1.0, 0.0).0);
    }

    #[test]
    fn log_policy_needs_a_velocity() {
        let (mut d, _) = case(1.0, 0.0);
        let e = choose(&mut d, None, &["j".into()], 1e-3, VelocitySource::Log, &DiffMethod::default()).unwrap_err();
        assert!(e.to_string().contains("velocity is 'log' but the log has no velocity"), "{e}");
        assert!(VelocitySource::parse("encoder").unwrap_err().to_string().contains("auto, log or positions"));
    }
}
