//! Fleet statistics (`app::fleet`): one log's statistics fit to `identify`'s numbers on
//! that log; statistics merged in any order and tree equal one pass over the logs' rows
//! (each log conditioned on its own, rows concatenated) to 1e-12 relative; the byte format
//! round-trips exactly and refuses another version, damaged bytes and another model.

use crate::scratch::ScratchFile;
use ivdyn::Robot;
use ivdyn::app::fleet::{self, LogStats};
use ivdyn::app::identify::CoulombMode;
use ivdyn::app::{self, IdentifyOptions, LogInput, LogSource, Method, SimulateOptions, Trajectory};
use ivdyn::log::JointLog;
use nalgebra::DMatrix;
use std::path::PathBuf;

/// The UR5's first three joints (base to `forearm_link`).
fn arm() -> Robot {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("forearm_link")).unwrap()
}

/// A simulated log of `seconds` at 500 Hz (Fourier excitation of `seed`, friction,
/// torque noise 0.1 N m), starting `day` days after the epoch.
fn log(robot: &Robot, seed: u64, seconds: f64, day: i64) -> JointLog {
    let o = SimulateOptions {
        rate_hz: 500.0,
        duration_s: seconds,
        seed,
        fc: Some(vec![2.0, 2.0, 1.5]),
        fv: Some(vec![0.8, 0.8, 0.5]),
        noise_tau: 0.1,
        ..Default::default()
    };
    let mut l = app::simulate(robot, &Trajectory::Fourier, &o).unwrap();
    l.t0_ns = day * 86_400_000_000_000;
    l
}

fn opts() -> IdentifyOptions {
    IdentifyOptions { method: Method::Wls, validation_fraction: 0.0, coulomb: CoulombMode::Sign, ..Default::default() }
}

fn stats(robot: &Robot, l: &JointLog, name: &str) -> LogStats {
    fleet::log_stats(robot, &LogInput::Arrays(l.clone()), &LogSource::default(), name, &opts(), false).unwrap()
}

/// `‖a - b‖ / ‖b‖` over the finite entries (both must be finite at the same places).
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let (mut d, mut n) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.is_finite(), y.is_finite(), "{x} vs {y}");
        if y.is_finite() {
            d += (x - y) * (x - y);
            n += y * y;
        }
    }
    (d / n).sqrt()
}

fn theta_cov(f: &fleet::FleetFit) -> (Vec<f64>, DMatrix<f64>) {
    let fr = f.report.fit_report.as_ref().unwrap();
    (fr.theta.clone(), fr.covariance.clone())
}

#[test]
fn one_log_fits_to_identify_on_that_log() {
    let robot = arm();
    let l = log(&robot, 3, 6.0, 0);
    let direct = app::identify(&robot, &l, &opts()).unwrap();
    let f = fleet::fit_stats(&robot, &stats(&robot, &l, "a.mcap"), &opts()).unwrap();
    let d = direct.fit_report.as_ref().unwrap();
    let (theta, cov) = theta_cov(&f);
    assert!(rel(&theta, &d.theta) <= 1e-12, "theta {}", rel(&theta, &d.theta));
    assert!(rel(cov.as_slice(), d.covariance.as_slice()) <= 1e-12);
    assert_eq!(f.report.fit.samples, direct.fit.samples);
    assert!(rel(&f.report.fit.rms, &direct.fit.rms) <= 1e-12);
    assert!(f.long_run.iter().all(|c| c.is_finite() && *c > 0.0), "{:?}", f.long_run);
}

#[test]
fn merged_statistics_equal_one_pass_over_the_logs_in_any_order() {
    let robot = arm();
    let logs: Vec<JointLog> = (0..5).map(|k| log(&robot, 10 + k, 3.0 + k as f64, k as i64)).collect();
    let names: Vec<String> = (0..5).map(|k| format!("day{k}.mcap")).collect();
    let inputs: Vec<LogInput> = logs.iter().map(|l| LogInput::Arrays(l.clone())).collect();
    let pairs: Vec<(&str, &LogInput)> = names.iter().map(|s| s.as_str()).zip(&inputs).collect();
    let one_pass = fleet::logs_stats(&robot, &pairs, &LogSource::default(), &opts(), false).unwrap();
    // each log's statistics through bytes, as an engine ships them
    let parts: Vec<LogStats> = logs
        .iter()
        .zip(&names)
        .map(|(l, n)| LogStats::from_bytes(&stats(&robot, l, n).to_bytes().unwrap(), n).unwrap())
        .collect();
    let tree = LogStats::merge_all(parts.clone()).unwrap();
    let mut reversed = parts[4].clone();
    for p in parts[..4].iter().rev() {
        reversed.merge(p).unwrap();
    }
    let reference = fleet::fit_stats(&robot, &one_pass, &opts()).unwrap();
    let (t0, c0) = theta_cov(&reference);
    for (what, s) in [("tree", &tree), ("reversed chain", &reversed)] {
        assert_eq!(s.samples, one_pass.samples, "{what}");
        assert_eq!(s.logs, one_pass.logs, "{what}: logs in one order");
        let f = fleet::fit_stats(&robot, s, &opts()).unwrap();
        let (t, c) = theta_cov(&f);
        let (rt, rc) = (rel(&t, &t0), rel(c.as_slice(), c0.as_slice()));
        eprintln!("{what}: theta {rt:.1e}, covariance {rc:.1e} relative to one pass");
        assert!(rt <= 1e-12 && rc <= 1e-12, "{what}: theta {rt:e}, covariance {rc:e}");
        // γ(l) = vᵀ M_l v cancels the torque's square down to the residual's: rounding
        // grows by (τ_rms / σ)² ≈ 1e5 here (tens of N m over 0.1 N m of noise)
        let rl = rel(&f.long_run, &reference.long_run);
        assert!(rl <= 1e-8, "{what}: long-run factors {:?} vs {:?}", f.long_run, reference.long_run);
    }
    // the merge adds information: more rows, smaller variances than any one log
    let single = fleet::fit_stats(&robot, &parts[0], &opts()).unwrap();
    let (_, c1) = theta_cov(&single);
    let (tr0, tr1): (f64, f64) = (
        (0..c0.nrows()).map(|i| c0[(i, i)]).filter(|v| v.is_finite()).sum(),
        (0..c1.nrows()).map(|i| c1[(i, i)]).filter(|v| v.is_finite()).sum(),
    );
    assert!(tr0 < tr1 / 3.0, "trace of the covariance {tr0} (5 logs) vs {tr1} (1 log)");
}

#[test]
fn bytes_round_trip_exactly_and_refuse_other_versions_and_damage() {
    let robot = arm();
    let s = stats(&robot, &log(&robot, 5, 3.0, 0), "arm-07/day0.mcap");
    let b = s.to_bytes().unwrap();
    assert_eq!(LogStats::from_bytes(&b, "x").unwrap(), s);
    let (ours, next) = (fleet::STATS_FORMAT, fleet::STATS_FORMAT + 1);
    let mut other = b.clone();
    other[8..12].copy_from_slice(&next.to_le_bytes());
    let e = LogStats::from_bytes(&other, "arm-07.stats").unwrap_err().to_string();
    assert!(
        e.contains("arm-07.stats")
            && e.contains(&format!("format version {next}"))
            && e.contains(&format!("version {ours}")),
        "{e}"
    );
    let e = LogStats::from_bytes(b"not statistics at all", "junk.bin").unwrap_err().to_string();
    assert!(e.contains("junk.bin") && e.contains("not ivdyn fleet statistics"), "{e}");
    let e = LogStats::from_bytes(&b[..b.len() / 2], "cut.bin").unwrap_err().to_string();
    assert!(e.contains("cut.bin") && e.contains("damaged"), "{e}");
}

#[test]
fn statistics_of_another_model_are_refused_naming_both() {
    let robot = arm();
    let a = stats(&robot, &log(&robot, 6, 3.0, 0), "arm-01/day0.mcap");
    let paper = Robot::paper();
    let o = SimulateOptions { rate_hz: 500.0, duration_s: 3.0, seed: 1, noise_tau: 0.1, ..Default::default() };
    let pl = app::simulate(&paper, &Trajectory::Fourier, &o).unwrap();
    let b = stats(&paper, &pl, "paper/day0.mcap");
    let mut m = a.clone();
    let e = m.merge(&b).unwrap_err().to_string();
    assert!(e.contains("arm-01/day0.mcap") && e.contains("paper/day0.mcap"), "{e}");
    assert!(e.contains(&a.model.describe()) && e.contains(&b.model.describe()), "{e}");
    assert_eq!(m, a, "a refused merge leaves the statistics unchanged");
    // same joints, other drive model: another parameter layout
    let no_offset =
        IdentifyOptions { drive: ivdyn::ident::DriveTerms { offset: false, ..Default::default() }, ..opts() };
    let e = fleet::fit_stats(&robot, &a, &no_offset).unwrap_err().to_string();
    assert!(e.contains("statistics of different models cannot be combined"), "{e}");
}

/// Four arms, two periods of three logs each; arm 2's elbow Coulomb friction rises by
/// 40 % (1.5 -> 2.1 N m) in the second period, nothing else changes. At a false-discovery
/// rate of 1 % across all the fleet's tests, exactly that change is flagged: under the
/// null the chance of any false flag is at most about 1 % (Benjamini-Hochberg bounds the
/// family-wise error by q when all but one hypothesis are null, up to the true change's
/// share), and the change is ~10 standard deviations (fc is known to ~0.03 N m here).
#[test]
fn drift_flags_exactly_the_planted_friction_change() {
    use ivdyn::app::fleet_drift::{benjamini_hochberg, describe, drift_tests, payload_params};
    let robot = arm();
    let period = |arm: u64, p: u64, elbow_fc: f64| -> fleet::FleetFit {
        let parts: Vec<LogStats> = (0..3)
            .map(|k| {
                let o = SimulateOptions {
                    rate_hz: 500.0,
                    duration_s: 6.0,
                    seed: 1000 * arm + 10 * p + k,
                    fc: Some(vec![2.0, 2.0, elbow_fc]),
                    fv: Some(vec![0.8, 0.8, 0.5]),
                    noise_tau: 0.1,
                    ..Default::default()
                };
                let l = app::simulate(&robot, &Trajectory::Fourier, &o).unwrap();
                stats(&robot, &l, &format!("arm-{arm}/p{p}-{k}.mcap"))
            })
            .collect();
        fleet::fit_stats(&robot, &LogStats::merge_all(parts).unwrap(), &opts()).unwrap()
    };
    let payload = payload_params(&robot, &opts()).unwrap();
    let mut all = vec![];
    for arm in 0..4u64 {
        let later_fc = if arm == 2 { 2.1 } else { 1.5 };
        let tests = drift_tests(&period(arm, 0, 1.5), &period(arm, 1, later_fc), &payload).unwrap();
        all.extend(tests.into_iter().map(|t| (arm, t)));
    }
    let p: Vec<f64> = all.iter().map(|(_, t)| t.p_value).collect();
    let flags = benjamini_hochberg(&p, 0.01);
    let flagged: Vec<&(u64, _)> = all.iter().zip(&flags).filter(|(_, f)| **f).map(|(t, _)| t).collect();
    let words: Vec<String> = flagged.iter().map(|(a, t)| describe(&format!("arm-{a}"), t, "p0")).collect();
    eprintln!("{} tests, flagged: {words:?}", all.len());
    assert_eq!(flagged.len(), 1, "{words:?}");
    let (a, t) = flagged[0];
    assert_eq!((*a, t.effect.as_str(), t.joint.as_deref()), (2, "coulomb_friction", Some("elbow_joint")));
    // the change within 4 standard deviations of the planted 0.6 N m
    assert!((t.change[0] - 0.6).abs() < 4.0 * t.std[0], "{} ± {}", t.change[0], t.std[0]);
    assert!(words[0].starts_with("arm-2, elbow_joint: coulomb friction +"), "{}", words[0]);
}

#[test]
fn benjamini_hochberg_matches_its_definition() {
    use ivdyn::app::fleet_drift::benjamini_hochberg;
    // m = 5, q = 0.05: thresholds 0.01, 0.02, 0.03, 0.04, 0.05; the largest k with
    // p_(k) <= k q / m is k = 3 (0.029 <= 0.03), so the three smallest are discoveries
    // although 0.025 > 0.02 (the step-up rule)
    let p = [0.2, 0.029, 0.001, 0.025, 0.9];
    assert_eq!(benjamini_hochberg(&p, 0.05), vec![false, true, true, true, false]);
    assert_eq!(benjamini_hochberg(&[0.5, 0.6], 0.05), vec![false, false]);
}

/// `log(...)` written as an MCAP file `name` in a scratch directory of its own.
fn mcap_file(l: &JointLog, name: &str) -> ScratchFile {
    let path = ScratchFile::new("ivdyn-fleet-stream", name);
    ivdyn::log::write_mcap(&path, l, &[]).unwrap();
    path
}

fn file_stats(robot: &Robot, path: &std::path::Path) -> LogStats {
    let name = path.to_string_lossy();
    fleet::log_stats(robot, &LogInput::File(path.to_path_buf()), &LogSource::default(), &name, &opts(), true).unwrap()
}

/// An MCAP file is streamed, and its statistics are the streamed `identify`'s: the fit of
/// one log's statistics equals `identify_mcap` on that file with no held-out tail.
#[test]
fn a_log_file_is_streamed_and_fits_to_the_streamed_identify() {
    let robot = arm();
    // 30 s at 500 Hz: past the stream's sample-time probe (10 000 samples) and several blocks
    let l = log(&robot, 21, 30.0, 0);
    let path = mcap_file(&l, "streamed.mcap");
    let s = file_stats(&robot, &path);
    assert!(s.logs[0].streamed, "{:?}", s.logs[0].notes);
    let f = fleet::fit_stats(&robot, &s, &opts()).unwrap();
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    let app::stream::Streamed::Done(direct) = app::stream::identify_mcap(&robot, &path, None, &read, &opts()).unwrap()
    else {
        panic!("identify did not stream the log")
    };
    assert!(direct.streamed && direct.validation.is_none());
    let d = direct.fit_report.as_ref().unwrap();
    let (theta, cov) = theta_cov(&f);
    let (rt, rc) = (rel(&theta, &d.theta), rel(cov.as_slice(), d.covariance.as_slice()));
    assert!(rt <= 1e-12 && rc <= 1e-12, "theta {rt:e}, covariance {rc:e}");
    assert_eq!((f.report.fit.samples, s.samples), (direct.fit.samples, direct.fit.samples));
    // the span is the log's first and last stamp
    let (t0, t1) = s.logs[0].span_s;
    assert!((t0 - l.t[0]).abs() < 1e-6 && (t1 - l.t[l.t.len() - 1]).abs() < 1e-6, "{t0} {t1}");
}

/// Streamed logs merged in any tree equal one streamed pass over the files, log after log
/// into one set of accumulators (each log conditioned on its own: a log boundary is a
/// segment break), to 1e-12 relative.
#[test]
fn merged_streamed_statistics_equal_one_streamed_pass_over_the_files() {
    let robot = arm();
    let paths: Vec<ScratchFile> = [(31, 8.0), (32, 24.0), (33, 12.0)]
        .iter()
        .enumerate()
        .map(|(k, &(seed, secs))| mcap_file(&log(&robot, seed, secs, k as i64), &format!("merge-{k}.mcap")))
        .collect();
    let names: Vec<String> = paths.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let inputs: Vec<LogInput> = paths.iter().map(|p| LogInput::File(p.to_path_buf())).collect();
    let pairs: Vec<(&str, &LogInput)> = names.iter().map(|s| s.as_str()).zip(&inputs).collect();
    let one_pass = fleet::logs_stats(&robot, &pairs, &LogSource::default(), &opts(), true).unwrap();
    assert!(one_pass.logs.iter().all(|l| l.streamed));
    let parts: Vec<LogStats> = paths.iter().map(|p| file_stats(&robot, p)).collect();
    let reversed = LogStats::merge_all(parts.into_iter().rev().collect()).unwrap();
    assert_eq!((reversed.samples, &reversed.logs), (one_pass.samples, &one_pass.logs));
    let (t0, c0) = theta_cov(&fleet::fit_stats(&robot, &one_pass, &opts()).unwrap());
    let (t, c) = theta_cov(&fleet::fit_stats(&robot, &reversed, &opts()).unwrap());
    let (rt, rc) = (rel(&t, &t0), rel(c.as_slice(), c0.as_slice()));
    eprintln!("streamed, merged in reverse: theta {rt:.1e}, covariance {rc:.1e} relative to one pass");
    assert!(rt <= 1e-12 && rc <= 1e-12, "theta {rt:e}, covariance {rc:e}");
}

/// A file the stream cannot take (uneven stamps need resampling) is read into memory,
/// says so, and gives the statistics of the same log given as arrays.
#[test]
fn a_file_the_stream_cannot_take_is_read_into_memory() {
    let robot = arm();
    let mut l = log(&robot, 41, 30.0, 0);
    // one interval 30 % long, after the stream's sample-time probe
    for t in l.t.iter_mut().skip(12_000) {
        *t += 0.3 * 2e-3;
    }
    let path = mcap_file(&l, "uneven.mcap");
    let s = file_stats(&robot, &path);
    let info = &s.logs[0];
    assert!(!info.streamed);
    assert!(
        info.notes.iter().any(|n| n.starts_with("read into memory (not streamed): uneven stamps")),
        "{:?}",
        info.notes
    );
    let arrays = stats(&robot, &LogSource::default().read(&path, &robot).unwrap(), "arrays");
    let (t0, c0) = theta_cov(&fleet::fit_stats(&robot, &arrays, &opts()).unwrap());
    let (t, c) = theta_cov(&fleet::fit_stats(&robot, &s, &opts()).unwrap());
    assert_eq!((t, c), (t0, c0));
}
