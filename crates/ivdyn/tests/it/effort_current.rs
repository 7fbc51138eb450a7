//! Effort given as motor current (`app::effort`, applied in `app::io::LogInput::load`):
//! a simulated UR5 torque log divided by known torque constants, as CSV `<joint>.i`
//! columns and as an MCAP current topic, identifies the simulation's true base parameters
//! as the torque log does; the jobs' errors name the option and the joint.

use crate::scratch::ScratchFile;
use std::path::{Path, PathBuf};

use ivdyn::Robot;
use ivdyn::app::{
    self, Effort, IdentifyJob, IdentifyReport, LogInput, LogSource, PerJoint, SimulateOptions, TorqueConstants,
    Trajectory,
};
use ivdyn::log::JointLog;

/// Torque constants at the joints, N m/A (a UR5's drives are of this order).
const K_T: [f64; 6] = [13.5, 13.5, 9.3, 4.8, 4.8, 4.8];

fn ur5() -> Robot {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Robot::from_urdf(urdf, Some("base_link"), Some("tool0")).unwrap()
}

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn_effort", name)
}

fn sim_opts() -> SimulateOptions {
    SimulateOptions {
        seed: 5,
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        noise_tau: 0.05,
        ..Default::default()
    }
}

/// The simulated log with its torque replaced by the motor current `tau / k_t`.
fn as_currents(log: &JointLog) -> JointLog {
    let tau = log.tau.as_ref().unwrap();
    let current = tau.iter().enumerate().map(|(i, t)| t / K_T[i % 6]).collect();
    JointLog { tau: None, current: Some(current), ..log.clone() }
}

fn constants() -> TorqueConstants {
    TorqueConstants { torque_constant: Some(PerJoint::List(K_T.to_vec())), ..Default::default() }
}

fn identify(robot: &Robot, log: &Path, source: LogSource) -> ivdyn::error::Result<IdentifyReport> {
    run(robot, log, source, false)
}

/// `stream`: stream the MCAP log. Velocities are differentiated positions in every run, so
/// that streamed and in-memory runs compare to rounding whatever the velocity check decides
/// (the stream checks the log's velocity on its first samples, memory on the whole log).
fn run(robot: &Robot, log: &Path, source: LogSource, stream: bool) -> ivdyn::error::Result<IdentifyReport> {
    let mut opts = ivdyn::app::IdentifyOptions::default();
    opts.condition.velocity = ivdyn::prep::VelocitySource::Positions;
    let job = IdentifyJob {
        log: LogInput::File(log.to_path_buf()),
        also: vec![],
        validate: None,
        source,
        in_memory: false,
        stream,
        opts,
        outputs: Default::default(),
    };
    app::identify_job(robot, &job).map(|o| o.report)
}

/// Base parameters within 4 standard deviations of the truth (at most 1 in 20 outside), as
/// the command-line round trip checks them.
fn check_truth(robot: &Robot, rep: &IdentifyReport, what: &str) {
    let truth = app::true_robot(robot, &sim_opts()).unwrap().params();
    let bp = ivdyn::ident::robot_base_params(robot, 200, 1).unwrap();
    let tb = bp.project(&truth).unwrap();
    assert_eq!(rep.base.len(), tb.len());
    let outside = rep.base.iter().zip(&tb).filter(|(b, t)| (b.value - *t).abs() > 4.0 * b.std.max(1e-12)).count();
    eprintln!("{what}: {outside} of {} base parameters outside 4 std", tb.len());
    assert!(outside <= tb.len() / 20, "{what}: {outside} outside 4 std");
}

fn max_rel(a: &IdentifyReport, b: &IdentifyReport) -> f64 {
    a.base.iter().zip(&b.base).map(|(x, y)| (x.value - y.value).abs() / y.value.abs().max(1e-3)).fold(0.0, f64::max)
}

#[test]
fn csv_currents_identify_the_true_parameters() {
    let robot = ur5();
    let log = app::simulate(&robot, &Trajectory::Fourier, &sim_opts()).unwrap();
    let (tau_csv, i_csv) = (tmp("tau.csv"), tmp("i.csv"));
    ivdyn::log::write_csv(&tau_csv, &log).unwrap();
    ivdyn::log::write_csv(&i_csv, &as_currents(&log)).unwrap();
    let by_torque = identify(&robot, &tau_csv, LogSource::default()).unwrap();
    let source = LogSource { torque_constants: constants(), ..Default::default() };
    let by_current = identify(&robot, &i_csv, source.clone()).unwrap();
    check_truth(&robot, &by_current, "CSV currents");
    // the same numbers as the torque log, to the rounding of tau / k_t * k_t
    let d = max_rel(&by_current, &by_torque);
    eprintln!("CSV currents vs CSV torques: max relative difference of the base parameters {d:.1e}");
    assert!(d < 1e-9, "{d}");
    // by joint name, in another order; and as gear ratio x motor constant
    let named: Vec<(String, f64)> = robot.joint_names.iter().cloned().zip(K_T).rev().collect();
    let by_name = TorqueConstants { torque_constant: Some(PerJoint::Named(named)), ..Default::default() };
    let r = identify(&robot, &i_csv, LogSource { torque_constants: by_name, ..Default::default() }).unwrap();
    assert_eq!(
        r.base.iter().map(|b| b.value).collect::<Vec<_>>(),
        by_current.base.iter().map(|b| b.value).collect::<Vec<_>>()
    );
    let geared = TorqueConstants {
        gear_ratio: Some(PerJoint::List(vec![101.0, 101.0, 101.0, 101.0, 101.0, 101.0])),
        motor_constant: Some(PerJoint::List(K_T.iter().map(|k| k / 101.0).collect())),
        ..Default::default()
    };
    let r = identify(&robot, &i_csv, LogSource { torque_constants: geared, ..Default::default() }).unwrap();
    assert!(max_rel(&r, &by_current) < 1e-9);
}

#[test]
fn mcap_current_topic_identifies_the_true_parameters() {
    let robot = ur5();
    let log = app::simulate(&robot, &Trajectory::Fourier, &sim_opts()).unwrap();
    let tau_mcap = tmp("tau.mcap");
    ivdyn::log::write_mcap(&tau_mcap, &log, &[]).unwrap();
    let by_torque = run(&robot, &tau_mcap, LogSource::default(), true).unwrap();
    assert!(by_torque.streamed);
    // a separate current topic (/ivdyn/current, written for JointLog::current)
    let i_mcap = tmp("i.mcap");
    ivdyn::log::write_mcap(&i_mcap, &as_currents(&log), &[]).unwrap();
    let source =
        LogSource { current_topic: Some("/ivdyn/current".into()), torque_constants: constants(), ..Default::default() };
    let r = identify(&robot, &i_mcap, source).unwrap();
    check_truth(&robot, &r, "MCAP current topic");
    assert!(!r.streamed && r.notes.iter().any(|n| n.contains("currents")), "{:?}", r.notes);
    // streamed vs in memory: the same to rounding (the streaming path's own tolerance)
    let d = max_rel(&r, &by_torque);
    eprintln!("MCAP current topic (in memory) vs torques (streamed): max relative difference {d:.1e}");
    assert!(d < 1e-6, "{d}");
    // a driver publishing its current as the measured effort
    let mut same = as_currents(&log);
    same.tau = same.current.take();
    let s_mcap = tmp("same.mcap");
    ivdyn::log::write_mcap(&s_mcap, &same, &[]).unwrap();
    let source =
        LogSource { current_topic: Some("/joint_states".into()), torque_constants: constants(), ..Default::default() };
    let s = identify(&robot, &s_mcap, source).unwrap();
    assert!(max_rel(&s, &r) < 1e-9);
}

/// Currents without constants, wrong constants, an effort the log does not have: errors
/// that name the option (and the joint), from every job that reads a log.
#[test]
fn errors_name_the_option_and_the_joint() {
    let robot = ur5();
    let log = app::simulate(&robot, &Trajectory::Fourier, &SimulateOptions { duration_s: 4.0, ..sim_opts() }).unwrap();
    let (tau_csv, i_csv) = (tmp("e_tau.csv"), tmp("e_i.csv"));
    ivdyn::log::write_csv(&tau_csv, &log).unwrap();
    ivdyn::log::write_csv(&i_csv, &as_currents(&log)).unwrap();
    let err = |log: &Path, source: LogSource| identify(&robot, log, source).unwrap_err().to_string();

    let e = err(&i_csv, LogSource::default());
    assert!(e.contains("e_i.csv") && e.contains("torque_constant is needed"), "{e}");
    let short = TorqueConstants { torque_constant: Some(PerJoint::List(vec![1.0; 5])), ..Default::default() };
    let e = err(&i_csv, LogSource { torque_constants: short, ..Default::default() });
    assert!(e.contains("5 values for the 6 joints") && e.contains("wrist_3_joint"), "{e}");
    let mut named: Vec<(String, f64)> = robot.joint_names.iter().cloned().zip(K_T).collect();
    named[2].0 = "elbow".into();
    let typo = TorqueConstants { torque_constant: Some(PerJoint::Named(named)), ..Default::default() };
    let e = err(&i_csv, LogSource { torque_constants: typo.clone(), ..Default::default() });
    assert!(e.contains("joint 'elbow', which is not in the chain"), "{e}");
    // wrong constants are reported even when the log's torque is used
    let e = err(&tau_csv, LogSource { torque_constants: typo, ..Default::default() });
    assert!(e.contains("'elbow'"), "{e}");
    let e = err(&tau_csv, LogSource { effort: Effort::Current, torque_constants: constants(), ..Default::default() });
    assert!(e.contains("effort is 'current'") && e.contains("<joint>.i"), "{e}");
    let e = err(&i_csv, LogSource { effort: Effort::Torque, ..Default::default() });
    assert!(e.contains("effort is 'torque'"), "{e}");

    // payload and diagnose load their logs the same way
    let payload = app::PayloadJob {
        log: LogInput::File(i_csv.to_path_buf()),
        before: None,
        source: LogSource::default(),
        opts: Default::default(),
        json: None,
        report: None,
        urdf: None,
        mjcf: None,
        torque_constant_prior: Default::default(),
    };
    let e = app::payload_job(&robot, &payload).unwrap_err().to_string();
    assert!(e.contains("torque_constant is needed"), "{e}");
    let diag = app::DiagnoseJob {
        log: LogInput::Arrays(as_currents(&log)),
        source: LogSource::default(),
        opts: Default::default(),
        out: None,
        report: false,
        json: None,
    };
    let e = app::diagnose_job(&robot, &diag, &None).unwrap_err().to_string();
    assert!(e.contains("torque_constant is needed"), "{e}");
}
