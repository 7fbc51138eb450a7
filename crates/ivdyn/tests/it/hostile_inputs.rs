//! Issue 16, input that used to be accepted silently: option values out of range, a joint
//! named twice, torques that are all zero, huge values on the streamed path, NaN in a
//! URDF, duplicated stamps read two ways. Each must end in an error naming the problem
//! (or, for duplicated stamps, give the same numbers both ways). Inputs are built here.

use crate::scratch::ScratchFile;
use std::path::Path;

use ivdyn::app::stream::{self as st, Streamed};
use ivdyn::app::{self, IdentifyOptions, SimulateOptions, Trajectory};
use ivdyn::diagnose::DiagnoseOptions;
use ivdyn::excite::ExciteOptions;
use ivdyn::log::{JointLog, ReadOptions};

fn ur5() -> ivdyn::Robot {
    ivdyn::Robot::from_urdf(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf"),
        Some("base_link"),
        Some("tool0"),
    )
    .unwrap()
}

fn sim(robot: &ivdyn::Robot, duration_s: f64) -> JointLog {
    let o = SimulateOptions {
        duration_s,
        rate_hz: 500.0,
        fc: Some(vec![1.0; 6]),
        fv: Some(vec![0.5; 6]),
        noise_tau: 0.05,
        ..Default::default()
    };
    app::simulate(robot, &Trajectory::Fourier, &o).unwrap()
}

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn-hostile-inputs", name)
}

fn err<T>(r: ivdyn::error::Result<T>) -> String {
    match r {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

fn streamed(robot: &ivdyn::Robot, path: &Path, opts: &IdentifyOptions) -> String {
    let read = ReadOptions::new(&robot.joint_names);
    match st::identify_mcap(robot, path, None, &read, opts) {
        Ok(Streamed::Done(_)) => panic!("streamed"),
        Ok(Streamed::Unsupported(why)) => panic!("not streamed: {why}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn simulate_options_out_of_range_name_the_option() {
    let robot = ur5();
    let base = SimulateOptions { duration_s: 1.0, ..Default::default() };
    let cases: Vec<(SimulateOptions, &str)> = vec![
        (SimulateOptions { noise_tau: 1e300, ..base.clone() }, "noise must be in [0, 1e6], got 1e300"),
        (SimulateOptions { noise_q: -1.0, ..base.clone() }, "noise_q must be in"),
        (SimulateOptions { encoder_bits: Some(0), ..base.clone() }, "encoder_bits must be in 1..=52, got 0"),
        (SimulateOptions { encoder_bits: Some(100), ..base.clone() }, "encoder_bits must be in 1..=52"),
        (SimulateOptions { tau_resolution: Some(f64::NAN), ..base.clone() }, "tau_resolution must be in"),
        (SimulateOptions { fc: Some(vec![1.0, 1.0, -1.0, 1.0, 1.0, 1.0]), ..base.clone() }, "fc[2] must be in"),
        (SimulateOptions { fv: Some(vec![1e300; 6]), ..base.clone() }, "fv[0] must be in"),
        (SimulateOptions { harmonics: 1_000_000, ..base.clone() }, "harmonics must be in 1..=100"),
        (SimulateOptions { base_freq_hz: 100.0, ..base.clone() }, "above the Nyquist frequency 250 Hz"),
    ];
    for (o, want) in cases {
        let e = err(app::simulate(&robot, &Trajectory::Fourier, &o));
        assert!(e.contains(want), "{e} (want {want})");
    }
    // a payload: heavier than any arm carries, outside the arm's reach, not a body
    for (m, com, i, want) in [
        (1e308, None, None, "payload_mass must be positive and at most 10000 kg, got 1e308"),
        (1.0, Some(vec![1e300, 0.0, 0.0]), None, "payload_com"),
        (1.0, None, Some(vec![-1.0, 0.0, 0.0, 1.0, 0.0, 1.0]), "payload_inertia is not a body's inertia"),
        // principal moments 0.1, 0.1, 1: 0.1 + 0.1 < 1
        (1.0, None, Some(vec![1.0, 0.0, 0.0, 0.1, 0.0, 0.1]), "I1 + I2 >= I3"),
        (1.0, None, Some(vec![1e308, 0.0, 0.0, 1e308, 0.0, 1e308]), "payload_inertia values must be within"),
    ] {
        let e = err(ivdyn::report::PayloadSpec::from_parts(Some(m), com.as_deref(), i.as_deref()));
        assert!(e.contains(want), "{e} (want {want})");
    }
}

#[test]
fn excite_counts_and_sizes_are_bounded_before_any_work() {
    let robot = ur5();
    let base = ExciteOptions { starts: 1, iterations: 1, random_draws: 0, ..Default::default() };
    let cases: Vec<(ExciteOptions, &str)> = vec![
        // each used to allocate 160 GB to 10 TB, or to run for days
        (ExciteOptions { duration_s: 1e9, ..base.clone() }, "at most 1e7 per run"),
        (ExciteOptions { rate_hz: 1e9, ..base.clone() }, "at most 1e7 per run"),
        (ExciteOptions { harmonics: 100_000, ..base.clone() }, "harmonics must be in 2..=100"),
        (ExciteOptions { starts: 1_000_000_000, ..base.clone() }, "starts must be in 1..=1000"),
        (ExciteOptions { iterations: 1_000_000_000, ..base.clone() }, "iterations must be in 0..=100000"),
        (ExciteOptions { random_draws: 1_000_000_000, ..base.clone() }, "random must be in 0..=10000"),
        // 5 harmonics of 1 kHz are not resolved at 100 Hz
        (ExciteOptions { f0_hz: 1000.0, ..base.clone() }, "above the Nyquist frequency 50 Hz"),
        (ExciteOptions { acc_limit: vec![1e300], ..base.clone() }, "acc_limit must be at most 1e6, got 1e300"),
        (ExciteOptions { vel_limit: Some(vec![-1.0]), ..base.clone() }, "joint 'shoulder_pan_joint'"),
    ];
    for (o, want) in cases {
        let t = std::time::Instant::now();
        let e = err(ivdyn::excite::design(&robot, &o));
        assert!(e.contains(want), "{e} (want {want})");
        assert!(t.elapsed().as_secs_f64() < 5.0, "{want}: the check came after the work");
    }
}

#[test]
fn identify_and_diagnose_options_out_of_range_name_the_option() {
    let robot = ur5();
    let log = sim(&robot, 4.0);
    for (h, want) in [(-0.1, "got -0.1"), (1.0, "got 1"), (f64::NAN, "got NaN")] {
        let o = IdentifyOptions { validation_fraction: h, ..Default::default() };
        let e = err(app::identify(&robot, &log, &o));
        assert!(e.contains("holdout must be in [0, 0.9]") && e.contains(want), "{e}");
    }
    let o = IdentifyOptions { idim_max_iter: 1_000_000_000, ..Default::default() };
    assert!(err(app::identify(&robot, &log, &o)).contains("idim_max_iter must be in 1..=1000"));
    for (o, want) in [
        (DiagnoseOptions { alpha: 2.0, ..Default::default() }, "alpha must be > 0 and at most 0.5, got 2"),
        (DiagnoseOptions { alpha: 0.0, ..Default::default() }, "alpha must be > 0"),
        (DiagnoseOptions { min_effect: f64::NAN, ..Default::default() }, "min_effect must be in [0, 1000], got NaN"),
        (DiagnoseOptions { min_share: 2.0, ..Default::default() }, "min_share must be in [0, 1]"),
    ] {
        let e = err(ivdyn::diagnose::diagnose(&robot, &log, &o));
        assert!(e.contains(want), "{e} (want {want})");
    }
}

/// A JointState that names a joint twice: either entry could be the joint's (the first
/// used to win, and a stale duplicate made the joint look motionless).
#[test]
fn a_joint_named_twice_is_refused_in_mcap_and_csv() {
    let robot = ur5();
    let log = sim(&robot, 1.0);
    let (t, n) = (log.len(), 6);
    // a seventh entry named like the third, with other values
    let widen = |a: &Vec<f64>, extra: f64| -> Vec<f64> {
        (0..t).flat_map(|k| a[k * n..(k + 1) * n].iter().copied().chain([a[k * n + 2] + extra])).collect()
    };
    let mut names = robot.joint_names.clone();
    names.push(names[2].clone());
    let twice = JointLog {
        joint_names: names,
        q: widen(&log.q, 0.5),
        qd: log.qd.as_ref().map(|v| widen(v, 0.0)),
        tau: log.tau.as_ref().map(|v| widen(v, 1.0)),
        ..log.clone()
    };
    let mcap = tmp("twice.mcap");
    ivdyn::log::write_mcap(&mcap, &twice, &[]).unwrap();
    let e = err(ivdyn::log::read_mcap(&mcap, &ReadOptions::new(&robot.joint_names)));
    assert!(e.contains("sample 0") && e.contains("'elbow_joint' is named twice (entries 2 and 6)"), "{e}");
    let csv = tmp("twice.csv");
    ivdyn::log::write_csv(&csv, &twice).unwrap();
    let e = err(ivdyn::log::read_csv(&csv, &robot.joint_names));
    assert!(e.contains("column 'elbow_joint.q' appears twice"), "{e}");
}

/// A driver that leaves the effort field at 0: every parameter came out 0 with std 0.
#[test]
fn a_torque_that_is_exactly_zero_throughout_is_refused_in_memory_and_streamed() {
    let robot = ur5();
    let mut log = sim(&robot, 6.0);
    let tau = log.tau.as_mut().unwrap();
    for k in 0..log.t.len() {
        tau[k * 6 + 4] = 0.0;
    }
    let want = "[\"wrist_2_joint\"] is exactly 0 in all 3000 samples";
    let e = err(app::identify(&robot, &log, &IdentifyOptions::default()));
    assert!(e.contains(want), "{e}");
    let e = err(ivdyn::diagnose::diagnose(&robot, &log, &DiagnoseOptions::default()));
    assert!(e.contains(want), "{e}");
    let path = tmp("zero_tau.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let mut opts = IdentifyOptions::default();
    opts.condition.velocity = ivdyn::prep::VelocitySource::Positions;
    let e = streamed(&robot, &path, &opts);
    assert!(e.contains(want), "{e}");
}

/// The streamed path applies the in-memory path's magnitude rule (a 1e300 torque squared
/// in the accumulators is infinite).
#[test]
fn a_huge_value_is_refused_when_streamed() {
    let robot = ur5();
    let mut log = sim(&robot, 6.0);
    log.tau.as_mut().unwrap()[2345 * 6 + 1] = 1e300;
    let path = tmp("huge.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let mut opts = IdentifyOptions::default();
    opts.condition.velocity = ivdyn::prep::VelocitySource::Positions;
    let e = streamed(&robot, &path, &opts);
    assert!(e.contains("sample 2345: joint 'shoulder_lift_joint' tau is 1e300"), "{e}");
    let e = err(app::identify(&robot, &log, &opts));
    assert!(e.contains("sample 2345: joint 'shoulder_lift_joint' tau is 1e300"), "{e}");
}

#[test]
fn nan_or_absurd_numbers_in_a_urdf_name_the_joint_or_link() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf")).unwrap();
    let load = |t: &str| err(ivdyn::robot::urdf::load_str(t, Path::new("bad.urdf"), Some("base_link"), Some("tool0")));
    // the elbow's origin, then the first limit, then an inertial origin
    let at = text.find("<joint name=\"elbow_joint\"").unwrap();
    let o = at + text[at..].find("xyz=\"").unwrap() + 5;
    for (v, want) in [("NaN 0 0", "NaN"), ("0 0 1e300", "1e300")] {
        let end = o + text[o..].find('"').unwrap();
        let bad = format!("{}{v}{}", &text[..o], &text[end..]);
        let e = load(&bad);
        assert!(e.contains("bad.urdf: joint 'elbow_joint': origin") && e.contains(want), "{e}");
    }
    let l = text.find("lower=\"").unwrap() + 7;
    let end = l + text[l..].find('"').unwrap();
    let e = load(&format!("{}nan{}", &text[..l], &text[end..]));
    assert!(e.contains("limit lower NaN"), "{e}");
    let i = text.find("<inertial>").unwrap();
    let x = i + text[i..].find("xyz=\"").unwrap() + 5;
    let end = x + text[x..].find('"').unwrap();
    let e = load(&format!("{}0 inf 0{}", &text[..x], &text[end..]));
    assert!(e.contains("inertial origin") && e.contains("inf"), "{e}");
}

/// Re-published samples with the stamp of the sample before (values of the next): the
/// streamed and the in-memory identify keep the same (first) sample of each stamp and give
/// the same numbers.
#[test]
fn duplicated_stamps_give_the_same_fit_streamed_and_in_memory() {
    let robot = ur5();
    let log = sim(&robot, 30.0);
    let (t, n) = (log.len(), 6);
    let mut rows: Vec<(usize, bool)> = vec![];
    for k in 0..t {
        rows.push((k, false));
        // every 97th sample is followed by a copy of the next one stamped like itself
        if k % 97 == 50 && k + 1 < t {
            rows.push((k + 1, true));
        }
    }
    let pick = |a: &Vec<f64>| -> Vec<f64> { rows.iter().flat_map(|&(k, _)| a[k * n..(k + 1) * n].to_vec()).collect() };
    let dup = JointLog {
        t: rows.iter().map(|&(k, d)| if d { log.t[k - 1] } else { log.t[k] }).collect(),
        q: pick(&log.q),
        qd: log.qd.as_ref().map(pick),
        tau: log.tau.as_ref().map(pick),
        ..log.clone()
    };
    let path = tmp("dup_stamps.mcap");
    ivdyn::log::write_mcap(&path, &dup, &[]).unwrap();
    let read = ReadOptions::new(&robot.joint_names);
    let from_file = ivdyn::log::read_mcap(&path, &read).unwrap();
    // the streamed path keeps the sign Coulomb shape: both the same here
    let mut opts = IdentifyOptions { coulomb: app::identify::CoulombMode::Sign, ..Default::default() };
    opts.condition.velocity = ivdyn::prep::VelocitySource::Positions;
    let mem = app::identify(&robot, &from_file, &opts).unwrap();
    let Streamed::Done(s) = st::identify_mcap(&robot, &path, None, &read, &opts).unwrap() else {
        panic!("not streamed")
    };
    assert_eq!((s.rows, s.fit.samples), (mem.rows, mem.fit.samples));
    for (a, b) in s.base.iter().zip(&mem.base) {
        // the filters run block-wise when streamed: equal to rounding, far inside one std
        assert!((a.value - b.value).abs() <= 1e-6 * b.std, "{}: {} vs {}", a.name, a.value, b.value);
    }
}

/// A file of kilobytes whose one zstd chunk holds a message of more than 256 MiB (zeros,
/// on another topic): the reader decompressed it whole (a 28 KB file of this kind took
/// 887 MB); now a record or decompressed chunk above `MAX_MCAP_RECORD` is refused by its
/// length, before it is read.
#[test]
fn an_mcap_record_decompressing_beyond_the_bound_is_refused() {
    let path = tmp("amplified.mcap");
    {
        let f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = mcap::WriteOptions::new()
            .chunk_size(Some(1 << 40))
            .compression(Some(mcap::Compression::Zstd))
            .create(f)
            .unwrap();
        let s = w.add_schema("raw", "none", b"").unwrap();
        let c = w.add_channel(s, "/camera", "raw", &Default::default()).unwrap();
        let blob = vec![0u8; ivdyn::log::MAX_MCAP_RECORD + (1 << 20)];
        let h = mcap::records::MessageHeader { channel_id: c, sequence: 0, log_time: 0, publish_time: 0 };
        w.write_to_known_channel(&h, &blob).unwrap();
        w.finish().unwrap();
    }
    assert!(std::fs::metadata(&path).unwrap().len() < 1 << 20, "the file is small");
    let e = err(ivdyn::log::read_mcap(&path, &ReadOptions::new(&ur5().joint_names)));
    assert!(e.contains("at most 268435456 bytes are read"), "{e}");
}

/// A "CSV" without newlines is not read whole into one line.
#[test]
fn a_csv_line_longer_than_the_bound_is_refused() {
    let mut text = b"t,".to_vec();
    text.extend(std::iter::repeat_n(b'1', ivdyn::log::MAX_CSV_LINE + 10));
    let e = err(ivdyn::log::read_csv_from(&text[..], Path::new("long.csv"), &ur5().joint_names));
    assert!(e.contains("long.csv: line 1 is longer than 1048576 bytes"), "{e}");
}

/// A record that claims more bytes than its uncompressed chunk holds (the chunk's CRC made
/// to match): mcap 0.26's reader subtracts the claimed length from what is left of the
/// chunk unchecked (found by the `mcap` fuzz target): a panic where overflow checks are on
/// (this test's profile). ivdyn walks chunks itself; it must be an error naming the file.
#[test]
fn a_record_overrunning_its_chunk_is_an_error_not_a_panic() {
    let path = tmp("overrun.mcap");
    let mut bytes = vec![];
    {
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .chunk_size(Some(1 << 20))
            .create(std::io::Cursor::new(&mut bytes))
            .unwrap();
        let s = w.add_schema("raw", "none", b"").unwrap();
        let c = w.add_channel(s, "/camera", "raw", &Default::default()).unwrap();
        let h = mcap::records::MessageHeader { channel_id: c, sequence: 0, log_time: 0, publish_time: 0 };
        w.write_to_known_channel(&h, &[7u8; 16]).unwrap();
        w.finish().unwrap();
    }
    // the message record inside the chunk: opcode 0x05, then its length 2 + 4 + 8 + 8 + 16
    let rec = [&[0x05u8][..], &38u64.to_le_bytes()].concat();
    let at = bytes.windows(rec.len()).position(|w| w == rec).expect("the message record");
    // the chunk's records end with this 47-byte record and start where the u64 before them
    // says so; before that length: compression "" (4 bytes) and the records' CRC
    let end = at + 47;
    let start = (16..at)
        .find(|&i| {
            u64::from_le_bytes(bytes[i - 8..i].try_into().unwrap()) == (end - i) as u64
                && bytes[i - 12..i - 8] == [0; 4]
        })
        .unwrap();
    assert_eq!(&bytes[start - 16..start - 12], &crc32fast::hash(&bytes[start..end]).to_le_bytes(), "the chunk CRC");
    // 100 bytes: within the file, beyond the chunk; the CRC made to match
    bytes[at + 1..at + 9].copy_from_slice(&100u64.to_le_bytes());
    let crc = crc32fast::hash(&bytes[start..end]).to_le_bytes();
    bytes[start - 16..start - 12].copy_from_slice(&crc);
    std::fs::write(&path, &bytes).unwrap();
    let e = err(ivdyn::log::read_mcap(&path, &ReadOptions::new(&ur5().joint_names)));
    assert!(e.contains("overrun.mcap") && e.contains("of 100 bytes with 38 bytes left in its chunk"), "{e}");
}
