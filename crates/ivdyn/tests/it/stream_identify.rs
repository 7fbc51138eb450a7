//! The streaming identification path against the in-memory one: the block-wise
//! zero-phase filter against `filtfilt` on the whole signal, the streamed conditioning
//! against `dsp::differentiate`, and `stream::identify_mcap` against
//! `app::identify` on the same log.

use crate::scratch::Scratch;
use ivdyn::app::stream::{self as st, Streamed};
use ivdyn::app::{self, IdentifyOptions, SimulateOptions, Trajectory};
use ivdyn::core::rng::Rng;
use ivdyn::dsp::{self, Butterworth, Decimator};
use ivdyn::prep::filtfilt::StreamFiltfilt;
use ivdyn::prep::stream::{CondRows, StreamCondition};

/// `T x m` test signal: slow sines (robot motion) plus white noise (a noisy torque).
fn signal(t: usize, m: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let mut x = vec![0.0; t * m];
    for j in 0..m {
        let (a, f, ph) = (rng.uniform(0.5, 3.0), rng.uniform(0.05, 2.0), rng.uniform(0.0, 6.0));
        for k in 0..t {
            x[k * m + j] = a * (std::f64::consts::TAU * f * k as f64 * 1e-3 + ph).sin() + 0.1 * rng.normal() + j as f64;
        }
    }
    x
}

/// Pushes `x` in chunks of varying size, returns the emitted `(index, row)`s.
fn stream_all(f: &mut StreamFiltfilt, x: &[f64], m: usize) -> (Vec<usize>, Vec<f64>) {
    let (mut idx, mut out) = (vec![], vec![]);
    let mut take = |g: usize, row: &[f64]| {
        idx.push(g);
        out.extend_from_slice(row);
    };
    let sizes = [1usize, 7, 1000, 4096, 333, 9000];
    let (mut at, mut i) = (0, 0);
    let t = x.len() / m;
    while at < t {
        let k = sizes[i % sizes.len()].min(t - at);
        f.push(&x[at * m..(at + k) * m], &mut take);
        at += k;
        i += 1;
    }
    f.finish(&mut take);
    (idx, out)
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    a.iter().zip(b).fold(0.0f64, |s, (x, y)| s.max((x - y).abs())) / scale
}

#[test]
fn block_filtfilt_matches_whole_signal_filtfilt() {
    let (t, m) = (60_000, 5);
    let x = signal(t, m, 1);
    // the decimator of a 1 kHz log (factor 20) and the differentiation filter
    for (dec, name) in [
        (Decimator::new(20, 1000.0).unwrap(), "decimator 20"),
        (Decimator::with_filter(1, Butterworth::default_for(1000.0).unwrap()).unwrap(), "20 Hz diff filter"),
    ] {
        let whole = dec.apply(&x, m).unwrap();
        let mut f = StreamFiltfilt::new(&dec.filter, m, dec.factor, 2048);
        let (idx, got) = stream_all(&mut f, &x, m);
        assert_eq!(idx, (0..t).step_by(dec.factor).collect::<Vec<_>>(), "{name}");
        assert_eq!(got.len(), whole.len());
        let d = max_rel_diff(&got, &whole);
        eprintln!("{name}: look-ahead {} rows, max |stream - whole| / max |whole| = {d:.2e}", f.look());
        assert!(d < 1e-10, "{name}: {d}");
    }
    // a signal shorter than the padding: the whole-signal filter itself
    let short = signal(100, 2, 2);
    let bw = Butterworth::default_for(1000.0).unwrap();
    let mut f = StreamFiltfilt::new(&bw, 2, 1, 2048);
    let (_, got) = stream_all(&mut f, &short, 2);
    assert_eq!(got, bw.filtfilt_columns(&short, 2).unwrap());
}

#[test]
fn streamed_conditioning_matches_differentiate() {
    let (t, n, dt) = (25_000, 3, 1e-3);
    let q = signal(t, n, 3);
    let whole = dsp::differentiate(&q, n, dt, &dsp::DiffMethod::default()).unwrap();
    let f = Butterworth::default_for(1.0 / dt).unwrap();
    let mut c = StreamCondition::new(&f, n, dt, 4096);
    let mut out = CondRows::default();
    for chunk in q.chunks(3 * 1111) {
        c.push(chunk, None, &mut out);
    }
    c.finish(&mut out);
    for (what, a, b) in [("q", &out.q, &whole.q), ("qd", &out.qd, &whole.qd), ("qdd", &out.qdd, &whole.qdd)] {
        assert_eq!(a.len(), b.len(), "{what}");
        let d = max_rel_diff(a, b);
        eprintln!("{what}: max relative difference {d:.2e}");
        assert!(d < 1e-10, "{what}: {d}");
    }
}

/// With the log's velocity on some joints, the streamed rows are the in-memory ones:
/// `dsp::differentiate` on the positions, then `prep::velocity::apply` (the smoothed log
/// velocity and its central difference) on those joints; also for logs shorter than the
/// four rows the stream's window needs.
#[test]
fn streamed_conditioning_with_log_velocity_matches_in_memory() {
    let (n, dt) = (3, 1e-3);
    let names: Vec<String> = (0..n).map(|j| format!("j{j}")).collect();
    let method = dsp::DiffMethod::default();
    let f = Butterworth::default_for(1.0 / dt).unwrap();
    let log = vec![true, false, true];
    for t in [25_000, 3, 2] {
        let (q, qd) = (signal(t, n, 5), signal(t, n, 6));
        let mut whole = dsp::differentiate(&q, n, dt, &method).unwrap();
        let lv = ivdyn::prep::velocity::LogVelocity::new(&qd, &names, dt, &method).unwrap();
        let choices: Vec<_> = names
            .iter()
            .zip(&log)
            .map(|(j, &l)| ivdyn::prep::VelocityChoice {
                joint: j.clone(),
                source: if l { "log" } else { "positions" }.into(),
                gain: None,
                lag_s: None,
                r2: None,
                why: String::new(),
            })
            .collect();
        ivdyn::prep::velocity::apply(&mut whole, Some(&lv), &choices);
        let mut c = StreamCondition::with_log_velocity(&f, n, dt, 4096, log.clone());
        let mut out = CondRows::default();
        for (cq, cv) in q.chunks(3 * 1111).zip(qd.chunks(3 * 1111)) {
            c.push(cq, Some(cv), &mut out);
        }
        c.finish(&mut out);
        for (what, a, b) in [("q", &out.q, &whole.q), ("qd", &out.qd, &whole.qd), ("qdd", &out.qdd, &whole.qdd)] {
            assert_eq!(a.len(), b.len(), "{t} samples, {what}");
            let d = max_rel_diff(a, b);
            eprintln!("{t} samples, {what}: max relative difference {d:.2e}");
            assert!(d < 1e-10, "{t} samples, {what}: {d}");
        }
    }
}

/// A 40 s, 1 kHz UR5 log with friction and torque noise, as an MCAP file.
fn ur5_log(dir: &std::path::Path) -> (ivdyn::Robot, std::path::PathBuf) {
    let robot = ivdyn::Robot::from_urdf(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf"),
        Some("base_link"),
        Some("tool0"),
    )
    .unwrap();
    let o = SimulateOptions {
        rate_hz: 1000.0,
        duration_s: 40.0,
        seed: 4,
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        noise_tau: 0.1,
        ..Default::default()
    };
    let log = app::simulate(&robot, &Trajectory::Fourier, &o).unwrap();
    let path = dir.join("ur5.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    (robot, path)
}

/// The streamed `identify` against the in-memory one on the log at `path`: the same rows,
/// estimates to 1e-6 of a standard deviation, the same velocity source per joint.
fn assert_stream_matches_memory(robot: &ivdyn::Robot, path: &std::path::Path, opts: &IdentifyOptions) -> Vec<String> {
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    let log = ivdyn::log::read_mcap(path, &read).unwrap();
    let mem = app::identify(robot, &log, opts).unwrap();
    let Streamed::Done(s) = st::identify_mcap(robot, path, None, &read, opts).unwrap() else { panic!("not streamed") };
    let sources =
        |r: &app::IdentifyReport| r.conditioning.velocity.iter().map(|c| c.source.clone()).collect::<Vec<_>>();
    assert_eq!(sources(&s), sources(&mem), "velocity per joint: {:?}", s.conditioning.velocity);
    assert_eq!(s.base.len(), mem.base.len());
    assert_eq!((s.rows, s.rank, s.decimation), (mem.rows, mem.rank, mem.decimation));
    let mut worst: f64 = 0.0;
    for (a, b) in s.base.iter().zip(&mem.base) {
        assert_eq!(a.name, b.name);
        // difference in units of the estimate's standard deviation, and relative
        let z = (a.value - b.value).abs() / b.std;
        worst = worst.max(z);
        assert!((a.std - b.std).abs() <= 1e-6 * b.std, "{}: std {} vs {}", a.name, a.std, b.std);
    }
    eprintln!("base parameters: worst |stream - memory| = {worst:.2e} std");
    assert!(worst < 1e-6, "{worst}");
    let (vs, vm) = (s.validation.as_ref().unwrap(), mem.validation.as_ref().unwrap());
    assert_eq!((vs.samples, &vs.data), (vm.samples, &vm.data));
    assert_eq!(s.fit.samples, mem.fit.samples);
    for j in 0..6 {
        for (a, b) in [(vs.rms[j], vm.rms[j]), (s.fit.rms[j], mem.fit.rms[j]), (s.fit.tau_rms[j], mem.fit.tau_rms[j])] {
            assert!((a - b).abs() <= 1e-8 * b, "joint {j}: {a} vs {b}");
        }
    }
    let (ds, dm) = (s.dwh.as_ref().unwrap(), mem.dwh.as_ref().unwrap());
    eprintln!("DWH: stream {} vs memory {}", ds.statistic, dm.statistic);
    assert!((ds.statistic - dm.statistic).abs() <= 1e-6 * dm.statistic.abs().max(1.0));
    assert_eq!(s.weights.len(), 6);
    for (a, b) in s.params.theta.iter().zip(&mem.params.theta) {
        assert!((a - b).abs() <= 1e-7 * b.abs().max(1e-3), "{a} vs {b}");
    }
    sources(&s)
}

#[test]
fn streamed_identify_matches_in_memory_identify() {
    let dir = Scratch::new("ivdyn-stream-id");
    let (robot, path) = ur5_log(&dir);
    // velocities differentiated from the positions
    let mut opts = IdentifyOptions::default();
    opts.condition.velocity = ivdyn::prep::VelocitySource::Positions;
    assert_eq!(assert_stream_matches_memory(&robot, &path, &opts), vec!["positions"; 6]);
    // the log's velocity where it is consistent (`auto`): a log whose joint 3 reports
    // degrees/s keeps the positions' derivative there, in memory and streamed
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    let mut log = ivdyn::log::read_mcap(&path, &read).unwrap();
    for row in log.qd.as_mut().unwrap().chunks_exact_mut(6) {
        row[2] = row[2].to_degrees();
    }
    let deg = dir.join("degrees.mcap");
    ivdyn::log::write_mcap(&deg, &log, &[]).unwrap();
    let mut want = vec!["log"; 6];
    want[2] = "positions";
    assert_eq!(assert_stream_matches_memory(&robot, &deg, &IdentifyOptions::default()), want);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The UR5 and a Fourier-excited log of it, `duration_s` long, 0.05 N m torque noise.
fn ur5_fourier(duration_s: f64) -> (ivdyn::Robot, ivdyn::log::JointLog) {
    let robot = ivdyn::Robot::from_urdf(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf"),
        Some("base_link"),
        Some("tool0"),
    )
    .unwrap();
    let opts = SimulateOptions { duration_s, noise_tau: 0.05, ..Default::default() };
    let log = app::simulate(&robot, &Trajectory::Fourier, &opts).unwrap();
    (robot, log)
}

/// Logs the stream cannot reproduce are handed back (the CLI then reads them into
/// memory): uneven stamps (they need resampling), and IDIM-IV.
#[test]
fn uneven_stamps_and_idim_are_not_streamed() {
    let dir = Scratch::new("ivdyn-stream-uneven");
    let (robot, mut log) = ur5_fourier(30.0);
    // one interval 30 % long, after the first 10 000 samples
    for t in log.t.iter_mut().skip(12_000) {
        *t += 0.3 * 2e-3;
    }
    let path = dir.join("uneven.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    match st::identify_mcap(&robot, &path, None, &read, &IdentifyOptions::default()).unwrap() {
        Streamed::Unsupported(why) => assert!(why.contains("uneven stamps") && why.contains("12000"), "{why}"),
        Streamed::Done(_) => panic!("an uneven log was streamed"),
    }
    let idim = IdentifyOptions { method: app::Method::IdimIv, ..Default::default() };
    assert!(matches!(st::identify_mcap(&robot, &path, None, &read, &idim).unwrap(), Streamed::Unsupported(_)));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A log whose shoulder pan angle wraps modulo 2π (the pan axis is vertical: a constant
/// added to it changes no torque, `log_hygiene::angles_wrapped_modulo_two_pi_are_unwrapped`)
/// is handed back by the stream, which cannot tell a revolute joint from a prismatic one,
/// naming the joint and the sample; read in memory it is unwrapped.
#[test]
fn a_wrapped_angle_is_not_streamed() {
    use std::f64::consts::{PI, TAU};
    let dir = Scratch::new("ivdyn-stream-wrapped");
    let (robot, mut log) = ur5_fourier(8.0);
    let n = robot.dof();
    let mean = log.q.iter().step_by(n).sum::<f64>() / log.len() as f64;
    log.q.iter_mut().step_by(n).for_each(|q| *q = (*q + PI - mean + PI).rem_euclid(TAU) - PI);
    let first = (1..log.len()).find(|&k| (log.q[k * n] - log.q[(k - 1) * n]).abs() > PI).expect("a wrap");
    let path = dir.join("wrapped.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    match st::identify_mcap(&robot, &path, None, &read, &IdentifyOptions::default()).unwrap() {
        Streamed::Unsupported(why) => {
            assert!(why.contains("'shoulder_pan_joint'") && why.contains(&format!("sample {first} ")), "{why}")
        }
        Streamed::Done(_) => panic!("a wrapped log was streamed"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
