//! What a residual (measured minus predicted torque, row-major `T x N`) looks like: its
//! noise level and autocorrelation time (which set the F tests' effective sample count),
//! its RMS, and where it is (the regimes the report and the evidence quote).

use super::Regimes;
use super::signals::Signals;

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

/// Lag of the differences the noise is measured on. A log with jittered stamps is
/// resampled onto a uniform grid by linear interpolation (`prep`), which mixes each
/// sample's noise into its two neighbours: the lag-1 differences of that noise shrink,
/// lag-2 ones (mostly disjoint pairs of raw samples) do not. On the jittered random-arm
/// logs (5-12 s) lag 1 put the noise ~40 % under the residual the model leaves, and a
/// clean log got a viscous friction named in that gap. For white noise any lag is the same.
const NOISE_LAG: usize = 2;

/// Noise std and integrated autocorrelation time of the residual `r` on joint `j`.
///
/// The noise comes from differences two samples apart (MAD, robust to jumps;
/// `NOISE_LAG`), which slow structure barely moves, when the residual is rough (lag-1
/// autocorrelation below 0.5, a raw sensor). A smooth residual (a log low-passed by its
/// authors) says nothing about the noise through its differences: then its RMS is used,
/// i.e. what no candidate explains. The autocorrelation time `1 + 2 sum rho_k` (summed
/// while `rho_k > 0.05`) turns the sample count into an effective count for the F tests.
pub(super) fn noise_and_tau(r: &[f64], n: usize, j: usize) -> (f64, f64) {
    let t_len = r.len() / n;
    let x = |k: usize| r[k * n + j];
    let mean = (0..t_len).map(x).sum::<f64>() / t_len as f64;
    let c0: f64 = (0..t_len).map(|k| (x(k) - mean).powi(2)).sum();
    let rho = |lag: usize| -> f64 {
        if c0 <= 0.0 {
            return 0.0;
        }
        (lag..t_len).map(|k| (x(k) - mean) * (x(k - lag) - mean)).sum::<f64>() / c0
    };
    let rho1 = rho(1);
    let mut tau = 1.0;
    for lag in 1..(t_len / 10).max(2) {
        let rk = if lag == 1 { rho1 } else { rho(lag) };
        if rk < 0.05 {
            break;
        }
        tau += 2.0 * rk;
    }
    let sigma = if rho1 < 0.5 {
        let dif: Vec<f64> = (NOISE_LAG..t_len).map(|k| x(k) - x(k - NOISE_LAG)).collect();
        let med = median(dif.clone());
        let mad = median(dif.iter().map(|d| (d - med).abs()).collect());
        1.4826 * mad / 2f64.sqrt()
    } else {
        ((0..t_len).map(|k| x(k) * x(k)).sum::<f64>() / t_len as f64).sqrt()
    };
    (sigma.max(1e-12), tau)
}

/// Torque noise std per joint of a log on its own samples and stamps `t`: each sample less
/// the line through its two neighbours, `tau_k - (h2 tau_(k-1) + h1 tau_(k+1)) / (h1 + h2)`,
/// divided by its white-noise std factor `sqrt(1 + (h1^2 + h2^2) / (h1 + h2)^2)` (`h1`, `h2`
/// the intervals before and after), robustly (MAD: re-published stale samples and gaps are a
/// few %). A torque's slope cancels; its curvature over two sample periods is far below the
/// noise at logging rates. Samples with a zero interval are skipped.
pub(super) fn sample_noise(t: &[f64], tau: &[f64], n: usize) -> Vec<f64> {
    let t_len = t.len().min(tau.len() / n.max(1));
    (0..n)
        .map(|j| {
            let d: Vec<f64> = (1..t_len.saturating_sub(1))
                .filter_map(|k| {
                    let (h1, h2) = (t[k] - t[k - 1], t[k + 1] - t[k]);
                    (h1 > 0.0 && h2 > 0.0).then(|| {
                        let line = (h2 * tau[(k - 1) * n + j] + h1 * tau[(k + 1) * n + j]) / (h1 + h2);
                        (tau[k * n + j] - line) / (1.0 + (h1 * h1 + h2 * h2) / ((h1 + h2) * (h1 + h2))).sqrt()
                    })
                })
                .collect();
            let med = median(d.clone());
            1.4826 * median(d.iter().map(|x| (x - med).abs()).collect())
        })
        .collect()
}

/// Lag-1 autocorrelation of the sample-to-sample differences of the residual `r` on
/// joint `j`: -0.5 for white noise (whatever slow structure it rides on), about -0.25 for
/// noise interpolated onto a resampled grid, about 0 for a torque low-passed before it was
/// logged (its differences are the smooth noise's slope).
pub(super) fn difference_lag1(r: &[f64], n: usize, j: usize) -> f64 {
    let t_len = r.len() / n;
    let dx: Vec<f64> = (1..t_len).map(|k| r[k * n + j] - r[(k - 1) * n + j]).collect();
    let mean = dx.iter().sum::<f64>() / dx.len().max(1) as f64;
    let c0: f64 = dx.iter().map(|v| (v - mean).powi(2)).sum();
    let c1: f64 = dx.windows(2).map(|w| (w[0] - mean) * (w[1] - mean)).sum();
    if c0 > 0.0 { c1 / c0 } else { 0.0 }
}

/// RMS per joint of a residual (N m).
pub(super) fn rms_per_joint(r: &[f64], n: usize) -> Vec<f64> {
    let t_len = r.len() / n;
    (0..n).map(|j| ((0..t_len).map(|k| r[k * n + j].powi(2)).sum::<f64>() / t_len as f64).sqrt()).collect()
}

/// Where the residual `r` is on each joint: near velocity reversals, at high acceleration
/// or elsewhere, and how it correlates with the joint's motion.
pub(super) fn regimes(s: &Signals, r: &[f64], n: usize) -> Vec<Regimes> {
    let t_len = s.t.len();
    let window = ((0.02 / s.dt).round() as usize).max(2);
    (0..n)
        .map(|j| {
            let qd = |k: usize| s.qd[k * n + j];
            let rv = |k: usize| r[k * n + j];
            let mut near = vec![false; t_len];
            let mut jumps = vec![];
            for k in 1..t_len {
                if qd(k - 1) * qd(k) < 0.0 || (qd(k - 1) == 0.0 && qd(k) != 0.0 && k > 1 && qd(k - 2) * qd(k) < 0.0) {
                    let lo = k.saturating_sub(window);
                    let hi = (k + window).min(t_len);
                    for x in near.iter_mut().take(hi).skip(lo) {
                        *x = true;
                    }
                    if k >= 3 * window && k + 3 * window < t_len {
                        let before: f64 = (k - 3 * window..k - window).map(rv).sum::<f64>() / (2 * window) as f64;
                        let after: f64 = (k + window..k + 3 * window).map(rv).sum::<f64>() / (2 * window) as f64;
                        jumps.push((after - before) * qd(k).signum());
                    }
                }
            }
            let mut acc: Vec<f64> = (0..t_len).map(|k| s.qdd[k * n + j].abs()).collect();
            acc.sort_by(|a, b| a.total_cmp(b));
            let thr = acc[(0.8 * t_len as f64) as usize];
            let (mut sr, mut nr, mut sa, mut na, mut so, mut no) = (0.0, 0, 0.0, 0, 0.0, 0);
            for (k, &nk) in near.iter().enumerate() {
                let v = rv(k).powi(2);
                if nk {
                    sr += v;
                    nr += 1;
                } else if s.qdd[k * n + j].abs() >= thr {
                    sa += v;
                    na += 1;
                } else {
                    so += v;
                    no += 1;
                }
            }
            let ms = |s: f64, c: usize| if c > 0 { (s / c as f64).sqrt() } else { f64::NAN };
            let corr = |x: &dyn Fn(usize) -> f64| {
                let mx = (0..t_len).map(x).sum::<f64>() / t_len as f64;
                let mr = (0..t_len).map(rv).sum::<f64>() / t_len as f64;
                let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
                for k in 0..t_len {
                    let (a, b) = (x(k) - mx, rv(k) - mr);
                    sxy += a * b;
                    sxx += a * a;
                    syy += b * b;
                }
                if sxx > 0.0 && syy > 0.0 { sxy / (sxx * syy).sqrt() } else { 0.0 }
            };
            Regimes {
                rms: ms((0..t_len).map(|k| rv(k).powi(2)).sum(), t_len),
                rms_reversal: ms(sr, nr),
                rms_high_acc: ms(sa, na),
                rms_rest: ms(so, no),
                reversal_jump: if jumps.is_empty() { f64::NAN } else { jumps.iter().sum::<f64>() / jumps.len() as f64 },
                reversals: jumps.len(),
                corr_q: corr(&|k| s.q[k * n + j]),
                corr_qd: corr(&|k| s.qd[k * n + j]),
                corr_qdd: corr(&|k| s.qdd[k * n + j]),
                mean: (0..t_len).map(rv).sum::<f64>() / t_len as f64,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth torque plus white noise of std 0.01 on jittered stamps (intervals 0.7-1.3 ms,
    /// 5 % of the samples re-published stale, as `messy_log` makes them): the noise on the
    /// log's own samples comes out within 10 % of 0.01 (the MAD estimate over ~5000 samples
    /// has a relative standard error of about 2 %: 10 % is beyond 4 of them).
    #[test]
    fn sample_noise_reads_the_sensors_noise_on_jittered_stamps() {
        let mut state = 987654321u64;
        let mut u = || {
            // 64-bit LCG (Knuth's constants)
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (mut t, mut tau) = (vec![0.0], vec![]);
        while t.len() < 5000 {
            let last = t[t.len() - 1];
            t.push(last + 1e-3 * (0.7 + 0.6 * u()));
        }
        for (k, &x) in t.iter().enumerate() {
            // Box-Muller
            let e = 0.01 * (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos();
            let stale = k > 0 && u() < 0.05;
            tau.push(if stale { tau[k - 1] } else { 2.0 * (6.0 * x).sin() + 0.5 * x + e });
        }
        let s = sample_noise(&t, &tau, 1)[0];
        assert!((s - 0.01).abs() < 0.001, "noise {s}");
    }
}
