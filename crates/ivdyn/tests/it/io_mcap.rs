//! MCAP input/output: fixtures written by Python's mcap-ros2-support
//! (python/tools/make_log_fixtures.py), every bad-input error, and round trips through
//! ivdyn's own writer.

use crate::scratch::ScratchFile;
use std::path::{Path, PathBuf};

use ivdyn::Error;
use ivdyn::log::{
    self, CommandAlign, CommandField, Compression, JointLog, McapWriter, ReadOptions, Source, for_each_sample,
    read_mcap,
};

const T0_NS: i64 = 1_700_000_000_000_000_000;
const UR5: [&str; 6] =
    ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/logs").join(name)
}

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn-io-mcap", name)
}

/// The URDF's joint order (from the URDF itself, so the matching-by-name is end to end).
fn urdf_joints() -> Vec<String> {
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    let robot = ivdyn::Robot::from_urdf(urdf, None, Some("tool0")).unwrap();
    assert_eq!(robot.joint_names, UR5);
    robot.joint_names
}

// the fixture signals (make_log_fixtures.py)
fn q_of(j: usize, t: f64) -> f64 {
    let f = 0.5 + 0.25 * j as f64;
    0.3 * (j as f64 + 1.0) / 6.0 * (2.0 * std::f64::consts::PI * f * t + 0.1 * j as f64).sin() + 0.05 * j as f64
}
fn tau_of(j: usize, t: f64) -> f64 {
    let f = 0.5 + 0.25 * j as f64;
    3.0 * (2.0 * std::f64::consts::PI * f * t).cos() + j as f64
}

fn log_err(r: ivdyn::error::Result<impl std::fmt::Debug>) -> String {
    match r {
        Err(e @ Error::Log { .. }) => {
            let s = e.to_string();
            assert!(!s.contains('\n'), "one-line error: {s}");
            eprintln!("{s}");
            s
        }
        other => panic!("expected Error::Log, got {other:?}"),
    }
}

#[test]
fn reads_python_written_ros2_log_in_urdf_order() {
    let names = urdf_joints();
    let log = read_mcap(fixture("ur5_500hz.mcap"), &ReadOptions::new(&names)).unwrap();
    assert_eq!(log.len(), 1000);
    assert_eq!(log.dof(), 6);
    assert_eq!(log.joint_names, UR5);
    assert_eq!(log.t0_ns, T0_NS);
    assert!(log.qd.is_none(), "velocity arrays are empty in the fixture");
    assert!(log.u.is_none() && !log.truncated);
    let tau = log.tau.as_ref().expect("effort present");
    for k in [0, 1, 499, 999] {
        assert!((log.t[k] - k as f64 * 0.002).abs() < 1e-12);
        for j in 0..6 {
            assert!((log.q[k * 6 + j] - q_of(j, k as f64 * 0.002)).abs() < 1e-12, "q k={k} j={j}");
            assert!((tau[k * 6 + j] - tau_of(j, k as f64 * 0.002)).abs() < 1e-12);
        }
    }
    assert!((log.median_dt().unwrap() - 0.002).abs() < 1e-12);
    log.validate(Path::new("x")).unwrap();
}

#[test]
fn command_topic_zero_order_hold_and_linear() {
    let names = urdf_joints();
    let mut o = ReadOptions::new(&names).command_topic("/joint_command");
    let zoh = read_mcap(fixture("ur5_500hz.mcap"), &o).unwrap();
    let u = zoh.u.as_ref().unwrap();
    // commands at t_k + 1 ms for even k, u = 2 tau(t + 1 ms)
    let cmd = |k: usize, j: usize| 2.0 * tau_of(j, k as f64 * 0.002 + 1e-3);
    for j in 0..6 {
        assert_eq!(u[j], cmd(0, j), "before the first command: the first one");
        assert_eq!(u[6 + j], cmd(0, j)); // t=2ms: last command is k=0's (1 ms)
        assert_eq!(u[2 * 6 + j], cmd(0, j)); // t=4ms: k=2's command comes at 5 ms
        assert_eq!(u[3 * 6 + j], cmd(2, j));
    }
    o.command_align = CommandAlign::Linear;
    let lin = read_mcap(fixture("ur5_500hz.mcap"), &o).unwrap();
    let u = lin.u.as_ref().unwrap();
    for j in 0..6 {
        // t = 4 ms lies halfway between the commands at 1 ms and 5 ms... at 3/4
        let want = cmd(0, j) + 0.75 * (cmd(2, j) - cmd(0, j));
        assert!((u[2 * 6 + j] - want).abs() < 1e-12);
    }
    o.command_field = CommandField::Position;
    let e = log_err(read_mcap(fixture("ur5_500hz.mcap"), &o));
    assert!(e.contains("/joint_command") && e.contains("Position") && e.contains("empty"), "{e}");
}

#[test]
fn lz4_uncompressed_and_log_time() {
    let names = urdf_joints();
    let log = read_mcap(fixture("ur5_lz4.mcap"), &ReadOptions::new(&names)).unwrap();
    assert_eq!(log.len(), 100);
    let qd = log.qd.as_ref().expect("velocity present in the lz4 fixture");
    let f = 0.5;
    assert!((qd[0] - 0.3 / 6.0 * 2.0 * std::f64::consts::PI * f).abs() < 1e-12);
    // header stamps are all zero in ur5_plain: header time is flat, log time is not
    let flat = read_mcap(fixture("ur5_plain.mcap"), &ReadOptions::new(&names)).unwrap();
    assert!(flat.t.iter().all(|&t| t == 0.0));
    assert_eq!(flat.t0_ns, 0);
    let mut o = ReadOptions::new(&names);
    o.use_log_time = true;
    let lt = read_mcap(fixture("ur5_plain.mcap"), &o).unwrap();
    assert_eq!(lt.t0_ns, T0_NS);
    assert!((lt.t[49] - 49.0 * 0.002).abs() < 1e-12);
    assert_eq!(lt.q, flat.q);
}

#[test]
fn streaming_callback() {
    let names = urdf_joints();
    let o = ReadOptions::new(&names).command_topic("/joint_command");
    let (mut meas, mut cmds, mut last) = (0, 0, i64::MIN);
    let s = for_each_sample(fixture("ur5_500hz.mcap"), &o, |s| {
        match s.source {
            Source::Measured => {
                assert_eq!(s.index, meas);
                assert!(s.q.is_some() && s.qd.is_none() && s.tau.is_some());
                assert!(s.stamp_ns >= last);
                last = s.stamp_ns;
                meas += 1
            }
            Source::Command => cmds += 1,
            Source::Current => unreachable!("no current topic asked for"),
        }
        Ok(())
    })
    .unwrap();
    assert_eq!((meas, cmds), (1000, 500));
    assert_eq!((s.measured, s.commands), (1000, 500));
    let topics: Vec<&str> = s.topics.iter().map(|t| t.0.as_str()).collect();
    assert!(topics.contains(&"/tf") && topics.contains(&"/joint_states"));
    // an error from the callback stops the pass and comes back unchanged
    let r = for_each_sample(fixture("ur5_500hz.mcap"), &o, |s| {
        if s.index == 10 { Err(Error::Signal { msg: "stop".into() }) } else { Ok(()) }
    });
    assert!(matches!(r, Err(Error::Signal { .. })));
    let listed = log::mcap::list_topics(fixture("ur5_500hz.mcap")).unwrap();
    assert!(listed.contains(&("/tf".to_string(), "tf2_msgs/msg/TFMessage".to_string(), 100)));
}

#[test]
fn error_truncated() {
    let names = urdf_joints();
    let e = log_err(read_mcap(fixture("ur5_truncated.mcap"), &ReadOptions::new(&names)));
    assert!(e.contains("ur5_truncated.mcap") && e.contains("truncated") && e.contains("byte"), "{e}");
    let mut o = ReadOptions::new(&names);
    o.allow_truncated = true;
    let log = read_mcap(fixture("ur5_truncated.mcap"), &o).unwrap();
    assert!(log.truncated);
    assert!(log.len() > 100 && log.len() < 1000, "{}", log.len());
    // what was read is right
    let k = log.len() - 1;
    assert!((log.q[k * 6 + 2] - q_of(2, k as f64 * 0.002)).abs() < 1e-12);
}

#[test]
fn error_corrupt() {
    let names = urdf_joints();
    let mut bytes = std::fs::read(fixture("ur5_500hz.mcap")).unwrap();
    // damage the compressed data of a chunk in the middle
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let p = tmp("corrupt.mcap");
    std::fs::write(&p, &bytes).unwrap();
    let e = log_err(read_mcap(&p, &ReadOptions::new(&names)));
    assert!(e.contains("corrupt.mcap") && e.contains("corrupt MCAP") && e.contains("byte"), "{e}");
    // not an MCAP at all
    let p = tmp("not.mcap");
    std::fs::write(&p, b"hello, this is not an mcap file at all, just text").unwrap();
    let e = log_err(read_mcap(&p, &ReadOptions::new(&names)));
    assert!(e.contains("not an MCAP file"), "{e}");
    // missing file: an Io error naming it
    let e = read_mcap(tmp("missing.mcap"), &ReadOptions::new(&names)).unwrap_err();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("missing.mcap"));
}

#[test]
fn error_joint_names_do_not_match() {
    let mut names = urdf_joints();
    names[1] = "shoulder_lift".into();
    names.push("elbow_2_joint".into());
    let e = log_err(read_mcap(fixture("ur5_500hz.mcap"), &ReadOptions::new(&names)));
    assert!(e.contains("[shoulder_lift, elbow_2_joint] are not in the log"), "{e}");
    assert!(e.contains("gripper_joint") && e.contains("shoulder_lift_joint"), "lists what the log has: {e}");
    assert!(e.contains("sample 0") && e.contains("/joint_states"), "{e}");
}

#[test]
fn error_nan_sample() {
    let names = urdf_joints();
    let e = log_err(read_mcap(fixture("ur5_nan.mcap"), &ReadOptions::new(&names)));
    assert!(e.contains("sample 17") && e.contains("'elbow_joint'") && e.contains("position is NaN"), "{e}");
}

#[test]
fn error_non_monotonic_stamps() {
    let names = urdf_joints();
    let e = log_err(read_mcap(fixture("ur5_backwards.mcap"), &ReadOptions::new(&names)));
    assert!(e.contains("sample 23") && e.contains("goes back") && e.contains("before sample 22"), "{e}");
    assert!(e.contains("0.005"), "by how much: {e}");
}

#[test]
fn error_topic_not_found_lists_topics() {
    let names = urdf_joints();
    let e = log_err(read_mcap(fixture("ur5_500hz.mcap"), &ReadOptions::new(&names).topic("/robot/joint_states")));
    assert!(e.contains("topic /robot/joint_states not found"), "{e}");
    assert!(
        e.contains("/joint_states (sensor_msgs/msg/JointState)") && e.contains("/tf (tf2_msgs/msg/TFMessage)"),
        "{e}"
    );
    let e = log_err(read_mcap(fixture("ur5_500hz.mcap"), &ReadOptions::new(&names).command_topic("/cmd")));
    assert!(e.contains("topic /cmd not found"), "{e}");
}

#[test]
fn error_wrong_schema() {
    let names = urdf_joints();
    let e = log_err(read_mcap(fixture("ur5_500hz.mcap"), &ReadOptions::new(&names).topic("/tf")));
    assert!(
        e.contains("topic /tf has schema 'tf2_msgs/msg/TFMessage'")
            && e.contains("expected sensor_msgs/msg/JointState"),
        "{e}"
    );
}

fn synthetic_log(t: usize, names: &[&str]) -> JointLog {
    let n = names.len();
    let mut log = JointLog {
        joint_names: names.iter().map(|s| s.to_string()).collect(),
        t0_ns: T0_NS,
        t: (0..t).map(|k| k as f64 * 1e-3).collect(),
        ..Default::default()
    };
    log.q = (0..t * n).map(|i| ((i / n) as f64 * 0.01 + (i % n) as f64).sin()).collect();
    log.qd = Some((0..t * n).map(|i| i as f64 * 0.5).collect());
    log.tau = Some((0..t * n).map(|i| -(i as f64) / 3.0).collect());
    log
}

#[test]
fn round_trip_own_writer_all_compressions() {
    let names = urdf_joints();
    let log = synthetic_log(300, &UR5);
    for (c, name) in
        [(Compression::Zstd, "rt_zstd.mcap"), (Compression::Lz4, "rt_lz4.mcap"), (Compression::None, "rt_none.mcap")]
    {
        let p = tmp(name);
        let mut w = McapWriter::create_with(&p, c).unwrap();
        // a different joint order in the file, plus an extra joint: matched by name
        let file_order = [
            "wrist_3_joint",
            "elbow_joint",
            "gripper_joint",
            "shoulder_pan_joint",
            "wrist_2_joint",
            "shoulder_lift_joint",
            "wrist_1_joint",
        ];
        let perm: Vec<Option<usize>> = file_order.iter().map(|f| UR5.iter().position(|u| u == f)).collect();
        let id = w.add_joint_state_topic("/joint_states").unwrap();
        for k in 0..log.len() {
            let pick = |a: &[f64]| -> Vec<f64> { perm.iter().map(|p| p.map_or(0.5, |j| a[k * 6 + j])).collect() };
            let stamp = T0_NS + (log.t[k] * 1e9).round() as i64;
            w.write(
                id,
                stamp,
                &file_order,
                &pick(&log.q),
                &pick(log.qd.as_ref().unwrap()),
                &pick(log.tau.as_ref().unwrap()),
            )
            .unwrap();
        }
        w.finish().unwrap();
        let back = read_mcap(&p, &ReadOptions::new(&names)).unwrap();
        assert_eq!(back.q, log.q, "{name}");
        assert_eq!(back.qd, log.qd);
        assert_eq!(back.tau, log.tau);
        assert_eq!(back.t0_ns, T0_NS);
        for k in 0..log.len() {
            assert!((back.t[k] - log.t[k]).abs() < 1e-12);
        }
    }
}

/// Motor currents: written as `/ivdyn/current`, read back from that topic (interpolated
/// onto the measurement stamps: the same stamps here, so exactly), or from the measured
/// topic's own effort; the current topic must differ from the command topic.
#[test]
fn current_topic_round_trip() {
    let names = urdf_joints();
    let mut log = synthetic_log(40, &UR5);
    let current: Vec<f64> = log.tau.as_ref().unwrap().iter().map(|v| v / 7.0).collect();
    log.current = Some(current.clone());
    let p = tmp("current.mcap");
    log::write_mcap(&p, &log, &[]).unwrap();
    let back = read_mcap(&p, &ReadOptions::new(&names).current_topic_opt(Some("/ivdyn/current"))).unwrap();
    assert_eq!(back.current.as_ref(), Some(&current));
    assert_eq!(back.tau, log.tau);
    // without the option the currents are not read
    assert_eq!(read_mcap(&p, &ReadOptions::new(&names)).unwrap().current, None);
    // the measured effort as the current: the log then has no torque
    let same = read_mcap(&p, &ReadOptions::new(&names).current_topic_opt(Some("/joint_states"))).unwrap();
    assert_eq!((same.tau, same.current), (None, log.tau.clone()));
    let o = ReadOptions::new(&names).command_topic("/ivdyn/current").current_topic_opt(Some("/ivdyn/current"));
    assert!(log_err(read_mcap(&p, &o)).contains("is the command topic"));
    let e = log_err(read_mcap(&p, &ReadOptions::new(&names).current_topic_opt(Some("/motor_current"))));
    assert!(e.contains("topic /motor_current not found"), "{e}");
}

#[test]
fn write_mcap_with_predicted_and_residual() {
    let names = urdf_joints();
    let mut log = synthetic_log(50, &UR5);
    log.u = Some(vec![1.5; 300]);
    let pred: Vec<f64> = log.tau.as_ref().unwrap().iter().map(|v| v * 0.9).collect();
    let res: Vec<f64> = log.tau.as_ref().unwrap().iter().zip(&pred).map(|(a, b)| a - b).collect();
    let p = tmp("with_model.mcap");
    log::write_mcap(&p, &log, &[("/ivdyn/predicted", &pred), ("/ivdyn/residual", &res)]).unwrap();
    let topics = log::mcap::list_topics(&p).unwrap();
    let tn: Vec<(&str, usize)> = topics.iter().map(|t| (t.0.as_str(), t.2)).collect();
    assert_eq!(tn, [("/joint_states", 50), ("/ivdyn/predicted", 50), ("/ivdyn/residual", 50), ("/ivdyn/command", 50)]);
    // position is empty on /ivdyn/residual: it cannot be the measured topic
    let e = log_err(read_mcap(&p, &ReadOptions::new(&names).topic("/ivdyn/residual")));
    assert!(e.contains("position is empty"), "{e}");
    let mut o = ReadOptions::new(&names).topic("/joint_states").command_topic("/ivdyn/residual");
    o.command_field = CommandField::Effort;
    let back = read_mcap(&p, &o).unwrap();
    assert_eq!(back.u.as_ref().unwrap(), &res);
    // shapes are checked
    let e = log::write_mcap(tmp("bad.mcap"), &log, &[("/x", &pred[..10])]).unwrap_err();
    assert!(matches!(e, Error::Dimension { .. }));
}

#[test]
fn unfinished_writer_leaves_no_file() {
    // a folder of its own: nothing else is written there
    let dir = tmp("unfinished");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("unfinished.mcap");
    {
        let mut w = McapWriter::create(&p).unwrap();
        let id = w.add_joint_state_topic("/joint_states").unwrap();
        w.write(id, 0, &["a"], &[1.0], &[], &[]).unwrap();
        assert!(w.write(id, 1, &["a"], &[1.0, 2.0], &[], &[]).is_err(), "length mismatch");
        // dropped without finish()
    }
    assert!(!p.exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(leftovers.is_empty(), "staged file or folder left: {leftovers:?}");
    let mut w = McapWriter::create(&p).unwrap();
    let id = w.add_joint_state_topic("/joint_states").unwrap();
    w.write(id, -5, &["a"], &[1.0], &[], &[]).unwrap(); // negative stamps are allowed
    assert_eq!(w.finish().unwrap(), p);
    assert!(p.exists());
}

/// Two publishers on one topic (an arm's driver and a gripper's, as on many robots'
/// `/joint_states`): the messages naming none of the chain's joints are skipped, counted and
/// said in the pass's notes, whatever their stamps and fields; a topic of only such messages
/// is an error naming the joints it has.
#[test]
fn another_publishers_messages_on_the_topic_are_skipped() {
    let names = urdf_joints();
    let p = tmp("two_publishers.mcap");
    let mut w = McapWriter::create(&p).unwrap();
    let topic = w.add_joint_state_topic("/joint_states").unwrap();
    let (arm, gripper) = (200, 67);
    for k in 0..arm {
        let t = k as f64 * 1e-3;
        let q: Vec<f64> = (0..6).map(|j| q_of(j, t)).collect();
        let tau: Vec<f64> = (0..6).map(|j| tau_of(j, t)).collect();
        w.write(topic, T0_NS + k as i64 * 1_000_000, &names, &q, &[], &tau).unwrap();
        if k % 3 == 0 {
            // stamped 2.5 ms late, position only: none of the arm's rules apply to it
            w.write(topic, T0_NS + k as i64 * 1_000_000 + 2_500_000, &["finger_joint"], &[0.01], &[], &[]).unwrap();
        }
    }
    w.finish().unwrap();
    let log = read_mcap(&p, &ReadOptions::new(&names)).unwrap();
    assert_eq!(log.len(), arm);
    for k in [0, 1, 100, arm - 1] {
        for j in 0..6 {
            assert_eq!(log.q[k * 6 + j], q_of(j, k as f64 * 1e-3));
            assert_eq!(log.tau.as_ref().unwrap()[k * 6 + j], tau_of(j, k as f64 * 1e-3));
        }
    }
    let s = for_each_sample(&p, &ReadOptions::new(&names), |_| Ok(())).unwrap();
    assert_eq!(s.measured, arm);
    assert!(
        s.notes.iter().any(|n| n.contains(&format!("{gripper} message(s) naming none")) && n.contains("finger_joint"))
    );
    // only the gripper's: an error naming what the topic has
    let e = log_err(read_mcap(&p, &ReadOptions::new(&["finger_2".to_string()])));
    assert!(e.contains(&format!("none of its {} messages names the chain's joints [finger_2]", arm + gripper)), "{e}");
}
