//! Signal conditioning: Butterworth responses, zero phase, differentiation accuracy,
//! Savitzky-Golay exactness, resampling, duplicates, decimation, parallel filtering,
//! outliers, and the whole-log `condition`.

use std::f64::consts::{PI, SQRT_2};

use ivdyn::dsp::*;
use ivdyn::log::JointLog;
use ivdyn::prep::{ConditionOptions, condition};

fn sine(fs: f64, f: f64, t: usize, phase: f64) -> Vec<f64> {
    (0..t).map(|k| (2.0 * PI * f * k as f64 / fs + phase).sin()).collect()
}

/// Amplitude of a sinusoid of frequency f in x (least squares on sin and cos), over the
/// middle half of the signal.
fn amplitude(x: &[f64], fs: f64, f: f64) -> f64 {
    let (a, b) = (x.len() / 4, 3 * x.len() / 4);
    let (mut ss, mut sc, mut cc, mut xs, mut xc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (k, &xk) in x.iter().enumerate().take(b).skip(a) {
        let w = 2.0 * PI * f * k as f64 / fs;
        let (s, c) = (w.sin(), w.cos());
        ss += s * s;
        sc += s * c;
        cc += c * c;
        xs += xk * s;
        xc += xk * c;
    }
    let det = ss * cc - sc * sc;
    let (p, q) = ((xs * cc - xc * sc) / det, (xc * ss - xs * sc) / det);
    (p * p + q * q).sqrt()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn butterworth_gain_at_cutoff() {
    for order in [1, 2, 3, 4, 5, 8] {
        for (fc, fs) in [(20.0, 500.0), (20.0, 5000.0), (100.0, 1000.0)] {
            // single-pass design: -3 dB at fc for one pass, so -6 dB forward-backward
            let b = Butterworth::lowpass(order, fc, fs).unwrap();
            assert!((b.gain(fc) - 1.0 / SQRT_2).abs() < 1e-9, "order {order} fc {fc} fs {fs}: {}", b.gain(fc));
            assert!((b.gain(0.0) - 1.0).abs() < 1e-9);
            // zero-phase design: forward-backward gain |H|^2 is -3 dB at fc
            let z = Butterworth::zero_phase(order, fc, fs).unwrap();
            assert!((z.gain(fc).powi(2) - 1.0 / SQRT_2).abs() < 1e-9);
        }
    }
    // measured on a signal, through filtfilt
    let (fs, fc) = (1000.0, 20.0);
    let x = sine(fs, fc, 20_000, 0.3);
    let z = Butterworth::zero_phase(4, fc, fs).unwrap();
    let a = amplitude(&z.filtfilt(&x), fs, fc);
    assert!((a - 1.0 / SQRT_2).abs() < 2e-3, "zero-phase amplitude at fc: {a}");
    let l = Butterworth::lowpass(4, fc, fs).unwrap();
    let a = amplitude(&l.filtfilt(&x), fs, fc);
    assert!((a - 0.5).abs() < 2e-3, "single-pass design after filtfilt: {a} (expected -6 dB)");
    // out of range
    assert!(Butterworth::lowpass(4, 600.0, 1000.0).is_err());
    assert!(Butterworth::lowpass(0, 10.0, 1000.0).is_err());
}

#[test]
fn filtfilt_has_no_lag_and_keeps_ramps() {
    let fs = 1000.0;
    let x = sine(fs, 2.0, 3000, 0.7);
    let y = Butterworth::default_for(fs).unwrap().filtfilt(&x);
    // zero phase: a causal filter would lag by several ms (~ 1e-2 at 2 Hz)
    assert!(max_abs_diff(&x[300..2700], &y[300..2700]) < 1e-6, "{}", max_abs_diff(&x[300..2700], &y[300..2700]));
    // ends: the odd extension continues the slope but not the curvature (~1e-3 here)
    assert!(max_abs_diff(&x, &y) < 3e-3, "ends: {}", max_abs_diff(&x, &y));
    let causal = Butterworth::default_for(fs).unwrap().filter(&x);
    assert!(max_abs_diff(&x[300..2700], &causal[300..2700]) > 1e-3, "the causal filter does lag");
    // a ramp and a constant pass exactly (odd extension + steady-state start)
    let ramp: Vec<f64> = (0..500).map(|k| 0.3 + 0.01 * k as f64).collect();
    let y = Butterworth::zero_phase(4, 20.0, fs).unwrap().filtfilt(&ramp);
    assert!(max_abs_diff(&ramp, &y) < 1e-7, "{}", max_abs_diff(&ramp, &y)); // rounding only
    // short signals do not panic
    let b = Butterworth::default_for(fs).unwrap();
    assert_eq!(b.filtfilt(&[]), Vec::<f64>::new());
    assert_eq!(b.filtfilt(&[2.0]), vec![2.0]);
    assert!(b.filtfilt(&[1.0, 2.0, 3.0]).iter().all(|v| v.is_finite()));
}

/// `filtfilt_columns` sweeps whole rows: each column of a 19-column array (columns of
/// different shapes and scales) equals that column filtered alone, bit for bit, at every
/// length around `padlen`.
#[test]
fn filtfilt_columns_equal_each_column_alone() {
    let fs = 500.0;
    let b = Butterworth::default_for(fs).unwrap();
    let m = 19;
    for t in [2, 3, b.padlen, b.padlen + 1, 1000] {
        let x: Vec<f64> = (0..t * m)
            .map(|i| {
                let (k, j) = ((i / m) as f64, (i % m) as f64);
                (1.0 + j) * (0.05 * (j + 1.0) * k).sin() + 0.01 * j * k + if j == 5.0 { 1e6 } else { 0.0 }
            })
            .collect();
        let y = b.filtfilt_columns(&x, m).unwrap();
        for j in 0..m {
            let col: Vec<f64> = (0..t).map(|k| x[k * m + j]).collect();
            let alone = b.filtfilt(&col);
            assert!((0..t).all(|k| y[k * m + j].to_bits() == alone[k].to_bits()), "T {t}, column {j}");
        }
    }
    assert!(b.filtfilt_columns(&[1.0, 2.0, 3.0], 2).is_err());
}

#[test]
fn differentiate_sinusoid_default() {
    for fs in [500.0, 1000.0, 5000.0] {
        let f = 1.5;
        let t = (4.0 * fs) as usize;
        let w = 2.0 * PI * f;
        // two columns: sin and cos
        let q: Vec<f64> = (0..t)
            .flat_map(|k| {
                let s = k as f64 / fs;
                [(w * s).sin(), 0.5 * (w * s).cos()]
            })
            .collect();
        let d = differentiate(&q, 2, 1.0 / fs, &DiffMethod::default()).unwrap();
        let mut e1: f64 = 0.0;
        let mut e2: f64 = 0.0;
        let (a, b) = (t / 10, 9 * t / 10);
        for k in a..b {
            let s = k as f64 / fs;
            e1 = e1.max((d.qd[2 * k] - w * (w * s).cos()).abs()).max((d.qd[2 * k + 1] + 0.5 * w * (w * s).sin()).abs());
            e2 = e2.max((d.qdd[2 * k] + w * w * (w * s).sin()).abs());
        }
        // relative errors: central-difference truncation (w dt)^2/6 plus the filter's
        // pass-band droop at 1.5 Hz vs 20 Hz (order 8 zero-phase: ~1e-9)
        assert!(e1 / w < 1e-4, "fs {fs}: qd error {e1}");
        assert!(e2 / (w * w) < 1e-4, "fs {fs}: qdd error {e2}");
    }
}

#[test]
fn savitzky_golay_exact_on_polynomials() {
    let dt = 0.002;
    let t = 200;
    // cubic: SG of order 3 is exact for value, first and second derivative, ends included
    let p = |s: f64| 0.3 - 2.0 * s + 5.0 * s * s - 7.0 * s * s * s;
    let p1 = |s: f64| -2.0 + 10.0 * s - 21.0 * s * s;
    let p2 = |s: f64| 10.0 - 42.0 * s;
    let x: Vec<f64> = (0..t).map(|k| p(k as f64 * dt)).collect();
    for (window, order) in [(7, 3), (11, 3), (21, 4), (31, 5)] {
        let sg = SavitzkyGolay::new(window, order).unwrap();
        let y0 = sg.apply(&x, 1, 0, dt).unwrap();
        let y1 = sg.apply(&x, 1, 1, dt).unwrap();
        let y2 = sg.apply(&x, 1, 2, dt).unwrap();
        for k in 0..t {
            let s = k as f64 * dt;
            assert!((y0[k] - p(s)).abs() < 1e-10, "w{window} o{order} k{k}");
            assert!((y1[k] - p1(s)).abs() < 1e-7, "w{window} o{order} k{k}: {} vs {}", y1[k], p1(s));
            assert!((y2[k] - p2(s)).abs() < 1e-4, "w{window} o{order} k{k}: {} vs {}", y2[k], p2(s));
        }
    }
    assert!(SavitzkyGolay::new(8, 3).is_err());
    assert!(SavitzkyGolay::new(5, 5).is_err());
    assert!(SavitzkyGolay::new(11, 3).unwrap().apply(&x[..5], 1, 1, dt).is_err());
    // as a DiffMethod on a sinusoid
    let fs = 1000.0;
    let w = 2.0 * PI * 2.0;
    let q = sine(fs, 2.0, 2000, 0.0);
    let sg = SavitzkyGolay::for_cutoff(3, 20.0, fs).unwrap();
    let d = differentiate(&q, 1, 1.0 / fs, &DiffMethod::SavitzkyGolay { window: sg.window, order: 3 }).unwrap();
    for k in 100..1900 {
        assert!((d.qd[k] - w * (w * k as f64 / fs).cos()).abs() < 1e-2 * w);
    }
}

#[test]
fn central_differences_exact_on_quadratics() {
    let dt = 0.01;
    let x: Vec<f64> = (0..10)
        .map(|k| {
            let s = k as f64 * dt;
            1.0 + 3.0 * s - 4.0 * s * s
        })
        .collect();
    let d1 = central_diff(&x, 1, dt).unwrap();
    let d2 = second_diff(&x, 1, dt).unwrap();
    for k in 0..10 {
        let s = k as f64 * dt;
        assert!((d1[k] - (3.0 - 8.0 * s)).abs() < 1e-9, "k {k}");
        assert!((d2[k] + 8.0).abs() < 1e-6, "k {k}: {}", d2[k]);
    }
}

#[test]
fn resampling_and_duplicates() {
    // uneven stamps with jitter and two duplicated samples
    let mut t = vec![];
    let mut s = 0.0;
    for k in 0..400 {
        s += 0.001 * (1.0 + 0.3 * ((k * 7919) % 13) as f64 / 13.0);
        t.push(s);
        if k == 50 || k == 200 {
            t.push(s);
        }
    }
    let lin: Vec<f64> = t.iter().flat_map(|&s| [2.0 - 3.0 * s, 0.5 * s]).collect();
    let dd = dedup_stamps(&t).unwrap();
    assert_eq!(dd.dropped, 2);
    let tk: Vec<f64> = dd.keep.iter().map(|&k| t[k]).collect();
    let xk = take_rows(&lin, 2, &dd.keep);
    assert!(resample_uniform(&t, &lin, 2, 1e-3, Interp::Linear).is_err(), "duplicates must be dropped first");
    let (g, y) = resample_uniform(&tk, &xk, 2, 1e-3, Interp::Linear).unwrap();
    assert!((g[1] - g[0] - 1e-3).abs() < 1e-15 && *g.last().unwrap() <= tk[tk.len() - 1] + 1e-12);
    for (k, &s) in g.iter().enumerate() {
        assert!((y[2 * k] - (2.0 - 3.0 * s)).abs() < 1e-12 && (y[2 * k + 1] - 0.5 * s).abs() < 1e-12);
    }
    // cubic reproduces a quadratic exactly
    let quad: Vec<f64> = tk.iter().map(|&s| 1.0 + s - 40.0 * s * s).collect();
    let (g, y) = resample_uniform(&tk, &quad, 1, 7e-4, Interp::Cubic).unwrap();
    for (k, &s) in g.iter().enumerate() {
        assert!((y[k] - (1.0 + s - 40.0 * s * s)).abs() < 1e-12, "k {k}");
    }
    // decreasing stamps are an error naming the sample
    let e = dedup_stamps(&[0.0, 0.1, 0.05]).unwrap_err().to_string();
    assert!(e.contains("sample 2"), "{e}");
}

#[test]
fn decimation_keeps_slow_removes_aliasing() {
    let (fs, factor) = (1000.0, 10); // output 100 Hz, Nyquist 50 Hz
    let t = 5000;
    let slow = sine(fs, 2.0, t, 0.2);
    let fast = sine(fs, 80.0, t, 0.0); // above the output Nyquist: would alias to 20 Hz
    let x: Vec<f64> = slow.iter().zip(&fast).flat_map(|(a, b)| [*a, *b, a + b]).collect();
    let d = Decimator::new(factor, fs).unwrap();
    let y = d.apply(&x, 3).unwrap();
    assert_eq!(y.len(), 3 * t.div_ceil(factor));
    let ts = d.apply_t(&(0..t).map(|k| k as f64).collect::<Vec<_>>());
    assert_eq!(ts[1], 10.0);
    let (a, b) = (50, t / factor - 50);
    for k in a..b {
        let s = slow[k * factor];
        assert!((y[3 * k] - s).abs() < 1e-4, "slow kept at {k}");
        assert!(y[3 * k + 1].abs() < 1e-4, "fast removed at {k}: {}", y[3 * k + 1]);
        assert!((y[3 * k + 2] - s).abs() < 2e-4, "sum -> slow at {k}");
    }
    // the filter's response: -3 dB at 40 Hz, < -90 dB at 100 Hz (forward-backward)
    assert!((d.filter.gain(40.0).powi(2) - 1.0 / SQRT_2).abs() < 1e-9);
    assert!(d.filter.gain(100.0).powi(2) < 3e-5);
}

#[test]
fn parallel_filtering_commutes_with_parameters() {
    // F(Y theta) == F(Y) theta for the same linear filter: tau and the regressor columns
    let (t, m) = (700, 5);
    let y: Vec<f64> = (0..t * m)
        .map(|i| {
            ((i % m) as f64 + 1.0) * ((i / m) as f64 * 0.013 * (1 + i % m) as f64).sin()
                + 0.01 * ((i * 2654435761usize) % 1000) as f64
        })
        .collect();
    let theta = [0.5, -2.0, 1.25, 3.0, -0.75];
    let tau: Vec<f64> = (0..t).map(|k| (0..m).map(|j| y[k * m + j] * theta[j]).sum()).collect();
    for dec in [
        Decimator::new(4, 1000.0).unwrap(),
        Decimator::with_filter(1, Butterworth::default_for(1000.0).unwrap()).unwrap(),
    ] {
        let fy = dec.apply(&y, m).unwrap();
        let ft = dec.apply(&tau, 1).unwrap();
        let scale = ft.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for k in 0..ft.len() {
            let pred: f64 = (0..m).map(|j| fy[k * m + j] * theta[j]).sum();
            assert!((pred - ft[k]).abs() < 1e-12 * scale, "row {k}");
        }
    }
}

#[test]
fn hampel_rejects_spikes() {
    let fs = 1000.0;
    let mut x: Vec<f64> = sine(fs, 3.0, 1000, 0.0)
        .iter()
        .enumerate()
        .map(|(k, v)| v + 1e-3 * (((k * 7919) % 101) as f64 / 101.0 - 0.5))
        .collect();
    let clean = x.clone();
    let spikes = [10usize, 333, 334, 700, 999];
    for &k in &spikes {
        x[k] += 5.0;
    }
    x[500] = f64::NAN;
    let rep = hampel(&mut x, 1, &HampelOptions::default()).unwrap();
    for &k in spikes.iter().chain(&[500]) {
        assert!((x[k] - clean[k]).abs() < 0.05, "sample {k} replaced: {} vs {}", x[k], clean[k]);
        assert!(rep.first.contains(&(k, 0)));
    }
    assert!(rep.total >= 6 && rep.total < 6 + 30, "few false positives: {}", rep.total);
    assert_eq!(rep.per_column, vec![rep.total]);
}

#[test]
fn condition_a_jittered_log() {
    let n = 2;
    let mut t = vec![];
    for k in 0..2000 {
        let s = k as f64 * 1e-3 + if k % 3 == 0 { 2e-4 } else { 0.0 };
        t.push(s);
    }
    t.insert(100, t[99]); // a duplicate
    let w = 2.0 * PI;
    let q: Vec<f64> = t.iter().flat_map(|&s| [(w * s).sin(), s]).collect();
    let log = JointLog {
        joint_names: vec!["a".into(), "b".into()],
        t: t.clone(),
        q,
        tau: Some(t.iter().flat_map(|&s| [s, -s]).collect()),
        ..Default::default()
    };
    let c = condition(&log, &ConditionOptions::default()).unwrap();
    assert_eq!(c.duplicates, 1);
    assert!(c.resampled);
    assert!((c.dt - 1e-3).abs() < 1e-12);
    assert_eq!(c.d.qd.len(), c.t.len() * n);
    for k in 200..c.t.len() - 200 {
        let s = c.t[k];
        assert!((c.d.qd[k * n] - w * (w * s).cos()).abs() < 2e-3 * w, "k {k}");
        assert!((c.d.qd[k * n + 1] - 1.0).abs() < 1e-6);
        assert!((c.tau.as_ref().unwrap()[k * n] - s).abs() < 1e-9);
    }
}

/// Issue 16: the cut-off is checked against the sample rate before any filter is built:
/// 1e-30 Hz (an integrator after rounding, NaN state) and past 0.4 fs are refused with the
/// option and the range named; the default is checked too, naming the stamps.
#[test]
fn cutoff_out_of_range_is_an_error_naming_the_option() {
    assert_eq!(resolve_cutoff(None, 500.0).unwrap(), 20.0);
    assert_eq!(resolve_cutoff(Some(0.05), 500.0).unwrap(), 0.05);
    assert_eq!(resolve_cutoff(Some(200.0), 500.0).unwrap(), 200.0);
    for bad in [1e-30, 0.0, -1.0, 201.0, f64::NAN, f64::INFINITY] {
        let e = resolve_cutoff(Some(bad), 500.0).unwrap_err().to_string();
        assert!(e.contains("--cutoff") && e.contains("allowed [0.05, 200] Hz"), "{e}");
    }
    let e = resolve_cutoff(None, 1e25).unwrap_err().to_string();
    assert!(e.contains("default cut-off 20 Hz") && e.contains("sample spacing 1e-25 s"), "{e}");
    let q: Vec<f64> = (0..300).map(|k| (k as f64 * 0.01).sin()).collect();
    let m = DiffMethod::Butterworth { order: 4, cutoff_hz: Some(1e-30) };
    assert!(differentiate(&q, 1, 0.002, &m).unwrap_err().to_string().contains("--cutoff"));
}

/// Issue 16: `simulate` refuses more than `limits::MAX_SAMPLES` samples before allocating.
#[test]
fn simulate_sample_count_bounded() {
    let mut o = ivdyn::app::SimulateOptions { duration_s: 1e12, ..Default::default() };
    let e = o.check().unwrap_err().to_string();
    assert!(e.contains("duration") && e.contains("at most 1e7"), "{e}");
    o.duration_s = 3600.0;
    o.rate_hz = 1000.0; // `make bench-hour`
    o.check().unwrap();
}
