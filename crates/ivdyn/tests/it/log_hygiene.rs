//! Real-log hygiene end to end on simulated UR5 logs whose truth is known: repeated
//! samples, gaps, several logs, the log's velocity, a time window. The yardstick is the
//! validation RMS on a separate clean log (the same friction, the same noise), against
//! the same identification on the clean log.

use ivdyn::Robot;
use ivdyn::app::simulate::{SimulateOptions, Trajectory, simulate};
use ivdyn::app::{IdentifyOptions, IdentifyReport, identify, identify_logs};
use ivdyn::log::JointLog;
use ivdyn::prep::VelocitySource;

fn ur5() -> Robot {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap()
}

/// A 20 s, 500 Hz log with friction, 0.05 N m torque noise, a 16-bit encoder and the
/// exact velocity.
fn sim(robot: &Robot, seed: u64, duration: f64) -> JointLog {
    let opts = SimulateOptions {
        duration_s: duration,
        seed,
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        noise_tau: 0.05,
        encoder_bits: Some(16),
        ..Default::default()
    };
    simulate(robot, &Trajectory::Fourier, &opts).unwrap()
}

fn validated(robot: &Robot, logs: &[&JointLog], val: &JointLog, velocity: VelocitySource) -> IdentifyReport {
    let mut opts = IdentifyOptions { validation_log: Some(val.clone()), ..Default::default() };
    opts.condition.velocity = velocity;
    identify_logs(robot, logs, &opts).unwrap()
}

fn mean_rms(r: &IdentifyReport) -> f64 {
    let v = r.validation.as_ref().unwrap();
    v.rms.iter().sum::<f64>() / v.rms.len() as f64
}

/// Every `k`-th sample (from `first`) replaced by the previous one: q, qd and tau (a
/// stale message published again under a new stamp).
fn with_repeats(log: &JointLog, first: usize, k: usize) -> (JointLog, usize) {
    let n = log.dof();
    let mut out = log.clone();
    let mut count = 0;
    for s in (first..log.len()).step_by(k) {
        for a in [Some(&mut out.q), out.qd.as_mut(), out.tau.as_mut()].into_iter().flatten() {
            let prev: Vec<f64> = a[(s - 1) * n..s * n].to_vec();
            a[s * n..(s + 1) * n].copy_from_slice(&prev);
        }
        count += 1;
    }
    (out, count)
}

#[test]
fn repeated_samples_are_found_and_cost_little() {
    let robot = ur5();
    let (clean, val) = (sim(&robot, 1, 20.0), sim(&robot, 2, 20.0));
    // every 17th sample: 5.9 %
    let (messy, injected) = with_repeats(&clean, 5, 17);
    let r_clean = validated(&robot, &[&clean], &val, VelocitySource::Auto);
    let r_messy = validated(&robot, &[&messy], &val, VelocitySource::Auto);
    // a repeat is found unless the joints were already standing still there (none are)
    assert_eq!(r_messy.conditioning.hygiene.repeated, injected);
    assert!(r_messy.conditioning.resampled);
    let ratio = mean_rms(&r_messy) / mean_rms(&r_clean);
    eprintln!("repeats: {injected} injected; validation RMS messy / clean = {ratio:.3}");
    assert!(ratio < 1.2, "{ratio}");
}

#[test]
fn gaps_cut_the_log_into_segments() {
    let robot = ur5();
    let (clean, val) = (sim(&robot, 3, 20.0), sim(&robot, 4, 20.0));
    // 0.4 s missing from 8 s on (200 samples, far more than GAP_INTERVALS sample times)
    let keep: Vec<usize> = (0..clean.len()).filter(|&k| !(8.0..8.4).contains(&clean.t[k])).collect();
    let gapped = clean.rows(&keep);
    let r = validated(&robot, &[&gapped], &val, VelocitySource::Auto);
    let h = &r.conditioning.hygiene;
    assert_eq!((h.gaps, h.segments, h.short_samples), (1, 2, 0));
    assert!(!r.conditioning.resampled, "the segments are uniform: nothing to resample");
    let r_clean = validated(&robot, &[&clean], &val, VelocitySource::Auto);
    let ratio = mean_rms(&r) / mean_rms(&r_clean);
    eprintln!("gap: validation RMS gapped / clean = {ratio:.3}");
    assert!(ratio < 1.1, "{ratio}");
    // a piece shorter than MIN_SEGMENT_SAMPLES between two gaps is left out
    let keep: Vec<usize> =
        (0..clean.len()).filter(|&k| !(8.0..8.4).contains(&clean.t[k]) && !(8.45..9.0).contains(&clean.t[k])).collect();
    let r = validated(&robot, &[&clean.rows(&keep)], &val, VelocitySource::Auto);
    let h = &r.conditioning.hygiene;
    assert_eq!((h.gaps, h.segments, h.short_samples), (2, 2, 25));
}

#[test]
fn several_logs_are_identified_together() {
    let robot = ur5();
    let (a, b, val) = (sim(&robot, 5, 12.0), sim(&robot, 6, 12.0), sim(&robot, 7, 20.0));
    let both = validated(&robot, &[&a, &b], &val, VelocitySource::Auto);
    let one = validated(&robot, &[&a], &val, VelocitySource::Auto);
    assert_eq!(both.conditioning.hygiene.segments, 2);
    // twice the data: the estimate's standard deviations shrink by about sqrt(2)
    let s = |r: &IdentifyReport| r.base.iter().filter(|b| b.std.is_finite()).map(|b| b.std).sum::<f64>();
    let shrink = s(&one) / s(&both);
    eprintln!("two logs: std one / both = {shrink:.2}; validation RMS {:.4} vs {:.4}", mean_rms(&both), mean_rms(&one));
    assert!(shrink > 1.2, "{shrink}");
    assert!(mean_rms(&both) <= mean_rms(&one) * 1.02);
}

#[test]
fn the_logs_velocity_is_checked_and_helps_on_a_quantised_encoder() {
    let robot = ur5();
    let (log, val) = (sim(&robot, 8, 20.0), sim(&robot, 9, 20.0));
    let auto = validated(&robot, &[&log], &val, VelocitySource::Auto);
    assert!(auto.conditioning.velocity.iter().all(|v| v.source == "log"), "{:?}", auto.conditioning.velocity);
    for v in &auto.conditioning.velocity {
        // the exact velocity: scale 1, no lag
        assert!((v.gain.unwrap() - 1.0).abs() < 0.01 && v.lag_s.unwrap().abs() < 2e-4, "{v:?}");
    }
    let pos = validated(&robot, &[&log], &val, VelocitySource::Positions);
    eprintln!("velocity: validation RMS log {:.4} vs positions {:.4}", mean_rms(&auto), mean_rms(&pos));
    assert!(mean_rms(&auto) <= mean_rms(&pos) * 1.01);
    // a velocity stored in degrees per second is refused and named
    let mut deg = log.clone();
    deg.qd.as_mut().unwrap().iter_mut().for_each(|v| *v = v.to_degrees());
    let r = validated(&robot, &[&deg], &val, VelocitySource::Auto);
    assert!(r.conditioning.velocity.iter().all(|v| v.source == "positions" && v.why.contains("degrees/s?")));
    assert!(r.notes.iter().any(|n| n.contains("degrees/s?")), "{:?}", r.notes);
}

#[test]
fn a_window_keeps_its_seconds() {
    let robot = ur5();
    let log = sim(&robot, 10, 20.0);
    let mut opts = IdentifyOptions::default();
    opts.condition.window = Some((2.0, 12.0));
    let r = identify(&robot, &log, &opts).unwrap();
    let h = &r.conditioning.hygiene;
    // 500 Hz: 5001 samples in [2, 12] s of 10001
    assert_eq!(h.outside_window, log.len() - 5001);
    opts.condition.window = Some((25.0, 30.0));
    let e = identify(&robot, &log, &opts).unwrap_err().to_string();
    assert!(e.contains("window") && e.contains("the log lasts"), "{e}");
}

#[test]
fn excluded_spans_cut_like_gaps_and_clipped_torques_are_named() {
    let robot = ur5();
    let (log, val) = (sim(&robot, 11, 20.0), sim(&robot, 12, 20.0));
    let mut opts = IdentifyOptions { validation_log: Some(val), ..Default::default() };
    opts.condition.exclude = vec![(8.0, 8.4)];
    let r = identify(&robot, &log, &opts).unwrap();
    let h = &r.conditioning.hygiene;
    // 500 Hz: the samples at 8.000 .. 8.400 s inclusive
    assert_eq!((h.excluded, h.gaps, h.segments), (201, 1, 2));
    assert!(h.clipped.is_empty(), "{:?}", h.clipped);
    // the shoulder's torque clipped at 80 % of its largest magnitude: named, with its samples
    let n = log.dof();
    let mut clip = log.clone();
    let tau = clip.tau.as_mut().unwrap();
    let limit = 0.8 * (0..log.len()).map(|k| tau[k * n + 1].abs()).fold(0.0, f64::max);
    let hits = (0..log.len()).filter(|&k| tau[k * n + 1].abs() > limit).count();
    (0..log.len()).for_each(|k| tau[k * n + 1] = tau[k * n + 1].clamp(-limit, limit));
    let r = identify(&robot, &clip, &opts).unwrap();
    let c = &r.conditioning.hygiene.clipped;
    assert!(!c.is_empty() && c.iter().all(|c| c.joint == robot.joint_names[1] && c.value.abs() == limit), "{c:?}");
    let found: usize = c.iter().map(|c| c.samples).sum();
    // the excluded span's samples are gone before the count
    assert!(found <= hits && found + 201 >= hits, "{found} of {hits}");
    assert!(r.notes.iter().any(|s| s.contains("clipped")), "{:?}", r.notes);
}

#[test]
fn standstills_are_measured() {
    let robot = ur5();
    // 2 s at rest, a 1 s smoothstep into a 0.3 Hz sine on every joint, 7 s of motion
    let (rate, n) = (500.0, 6);
    let t: Vec<f64> = (0..5000).map(|k| k as f64 / rate).collect();
    let q: Vec<f64> = t
        .iter()
        .flat_map(|&s| {
            let u = ((s - 2.0) / 1.0).clamp(0.0, 1.0);
            let w = u * u * (3.0 - 2.0 * u);
            (0..n).map(move |j| 0.3 + w * 0.5 * (2.0 * std::f64::consts::PI * 0.3 * s + j as f64).sin())
        })
        .collect();
    let opts = SimulateOptions { noise_tau: 0.05, encoder_bits: Some(16), ..Default::default() };
    let log = simulate(&robot, &Trajectory::Samples { t, q }, &opts).unwrap();
    let r = identify(&robot, &log, &IdentifyOptions::default()).unwrap();
    let s = r.conditioning.hygiene.standstill_s;
    // the 2 s hold, plus the start of the ramp where every joint is still below 2 % of its
    // RMS velocity (smoothstep: ~0.1 s), minus filter edges
    assert!((1.9..2.4).contains(&s), "{s}");
    assert!(r.notes.iter().any(|x| x.contains("standstill")), "{:?}", r.notes);
}

/// Positions logged in degrees: far outside the UR5's limits (±2π), inside them read as
/// degrees. Every job's log goes through `LogInput::load`: a clear error naming the joint,
/// not a fit of nonsense. Radians of the same motion pass.
#[test]
fn positions_in_degrees_are_refused() {
    use ivdyn::app::{LogInput, LogSource};
    let robot = ur5();
    let log = sim(&robot, 9, 4.0);
    assert!(LogInput::Arrays(log.clone()).load(&robot, &LogSource::default()).is_ok());
    let mut deg = log.clone();
    deg.q.iter_mut().for_each(|q| *q = q.to_degrees());
    // at least one joint's motion spans more than 2π + π rad once in degrees
    let err = LogInput::Arrays(deg).load(&robot, &LogSource::default()).unwrap_err().to_string();
    eprintln!("{err}");
    assert!(err.contains("degrees") && err.contains("give positions in radians"), "{err}");
    assert!(robot.joint_names.iter().any(|j| err.contains(&format!("'{j}'"))), "{err}");
}

/// The shoulder pan's angle reported modulo 2π, as a continuous joint's driver may: the
/// UR5's pan axis is vertical, so a constant added to it changes no torque, and the log
/// turned to cross ±π and wrapped into (-π, π] is the same motion. Every job's log goes
/// through `LogInput::load`, which unwraps it: the identification equals the one on the
/// continuous log to rounding (the wrapped samples sit 2π away, where sin and cos round
/// differently), where the wraps, differentiated, would be spikes of 2π / dt.
#[test]
fn angles_wrapped_modulo_two_pi_are_unwrapped() {
    use ivdyn::app::{LogInput, LogSource};
    use std::f64::consts::{PI, TAU};
    let robot = ur5();
    let n = robot.dof();
    let (log, val) = (sim(&robot, 11, 8.0), sim(&robot, 12, 4.0));
    let mut turned = log.clone();
    let mean = log.q.iter().step_by(n).sum::<f64>() / log.len() as f64;
    turned.q.iter_mut().step_by(n).for_each(|q| *q += PI - mean);
    let mut wrapped = turned.clone();
    wrapped.q.iter_mut().step_by(n).for_each(|q| *q = (*q + PI).rem_euclid(TAU) - PI);
    let wraps =
        wrapped.q.iter().step_by(n).zip(wrapped.q.iter().step_by(n).skip(1)).filter(|(a, b)| (*b - *a).abs() > PI);
    assert!(wraps.count() >= 2, "the motion crosses ±π");
    let load = |l: &JointLog| LogInput::Arrays(l.clone()).load(&robot, &LogSource::default()).unwrap().into_owned();
    let opts = IdentifyOptions { validation_log: Some(val), ..Default::default() };
    let a = identify_logs(&robot, &[&load(&turned)], &opts).unwrap();
    let b = identify_logs(&robot, &[&load(&wrapped)], &opts).unwrap();
    assert_eq!(a.base.len(), b.base.len());
    for (x, y) in a.base.iter().zip(&b.base).filter(|(x, _)| x.value.is_finite()) {
        assert!((x.value - y.value).abs() <= 1e-8 * x.value.abs().max(1.0), "{}: {} vs {}", x.name, x.value, y.value);
    }
    assert!((mean_rms(&a) - mean_rms(&b)).abs() <= 1e-9 * mean_rms(&a), "{} vs {}", mean_rms(&a), mean_rms(&b));
}
