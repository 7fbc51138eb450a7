//! Bad input: one line on stderr naming the problem, non-zero exit, no output file.
#[path = "cli_util/mod.rs"]
mod util;
use util::*;

/// Runs `ivdyn <sub> <args..> --json D/out.json [--out-params D/params.json]` and checks
/// the failure contract; returns the stderr line.
fn fails(name: &str, sub: &str, args: &[String], must_contain: &[&str]) -> String {
    let d = tmpdir(name);
    let mut a: Vec<String> = vec![sub.into()];
    a.extend(args.iter().cloned());
    a.extend(["--json".into(), s(&d.join("out.json"))]);
    if sub == "identify" {
        a.extend(["--out-params".into(), s(&d.join("params.json"))]);
    }
    let a: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
    let out = ivdyn(&a);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "{name}: should fail; stdout {}", String::from_utf8_lossy(&out.stdout));
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{name}: stderr must be one line, got {err:?}");
    for w in must_contain {
        assert!(lines[0].contains(w), "{name}: {:?} should contain {w:?}", lines[0]);
    }
    assert!(files_in(&d).is_empty(), "{name}: left files {:?}", files_in(&d));
    let _ = std::fs::remove_dir_all(&d);
    lines[0].to_string()
}

fn ur5_log(log: &str) -> Vec<String> {
    let mut a = ur5_args();
    a.extend(["--log".into(), fixture(&format!("logs/{log}"))]);
    a
}

#[test]
fn cli_error_truncated_mcap() {
    fails("trunc_id", "identify", &ur5_log("ur5_truncated.mcap"), &["ur5_truncated.mcap", "truncated"]);
    fails("trunc_pl", "payload", &ur5_log("ur5_truncated.mcap"), &["ur5_truncated.mcap", "truncated"]);
}

#[test]
fn cli_error_nan_sample() {
    fails("nan", "identify", &ur5_log("ur5_nan.mcap"), &["ur5_nan.mcap", "sample 17", "elbow_joint", "NaN"]);
}

#[test]
fn cli_error_stamps_go_back() {
    fails("back", "identify", &ur5_log("ur5_backwards.mcap"), &["ur5_backwards.mcap", "sample 23", "back"]);
}

#[test]
fn cli_error_joint_names_do_not_match() {
    // a chain of test_arm.urdf whose joints the UR5 log does not have
    let a: Vec<String> =
        ["--urdf", &fixture("test_arm.urdf"), "--tip", "tool", "--log", &fixture("logs/ur5_500hz.mcap")]
            .iter()
            .map(|s| s.to_string())
            .collect();
    let line = fails("names", "identify", &a, &["ur5_500hz.mcap"]);
    eprintln!("{line}");
}

#[test]
fn cli_error_urdf_does_not_parse() {
    let d = tmpdir("badurdf_src");
    let urdf = d.join("broken.urdf");
    std::fs::write(&urdf, "<robot name=\"x\"><link name=\"a\"").unwrap();
    let mut a: Vec<String> = vec!["--urdf".into(), s(&urdf), "--log".into(), fixture("logs/ur5_500hz.mcap")];
    fails("badurdf", "identify", &a, &["broken.urdf", "URDF"]);
    a.truncate(2);
    a.extend(["--out".into(), s(&d.join("never.mcap"))]);
    fails("badurdf_sim", "simulate", &a, &["broken.urdf"]);
    assert_eq!(files_in(&d), vec!["broken.urdf".to_string()]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cli_error_missing_log_and_header_stamps() {
    fails("missing", "identify", &ur5_log("does_not_exist.mcap"), &["does_not_exist.mcap"]);
    fails("zero_stamps", "identify", &ur5_log("ur5_plain.mcap"), &["ur5_plain.mcap", "--log-time"]);
}

#[test]
fn cli_error_simulate_bad_options_leave_no_file() {
    let d = tmpdir("sim_bad");
    let mut a = ur5_args();
    a.insert(0, "simulate".into());
    a.extend(["--fc".into(), "1,2".into(), "--out".into(), s(&d.join("x.mcap"))]);
    let a: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
    let out = ivdyn(&a);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("fc"), "{err}");
    assert!(files_in(&d).is_empty(), "{:?}", files_in(&d));
    let _ = std::fs::remove_dir_all(&d);
}

/// A log whose effort is motor current (`<joint>.i`): without torque constants, or with
/// constants that name a joint the chain does not have, the error names the flag (and
/// the joint).
#[test]
fn cli_error_currents_need_torque_constants() {
    let d = tmpdir("current_src");
    let names: Vec<String> = ["shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"]
        .iter()
        .map(|j| format!("{j}_joint"))
        .collect();
    let mut log = ivdyn::log::read_csv(fixture("logs/ur5_short.csv"), &names).unwrap();
    log.current = log.tau.take();
    let csv = d.join("i.csv");
    ivdyn::log::write_csv(&csv, &log).unwrap();
    let mut a = ur5_args();
    a.extend(["--log".into(), s(&csv)]);
    fails("no_kt", "identify", &a, &["i.csv", "--torque-constant is needed", "motor current"]);
    a.extend(["--torque-constant".into(), "elbow=1".into()]);
    fails("bad_kt", "identify", &a, &["--torque-constant", "joint 'elbow'"]);
    a.truncate(a.len() - 2);
    a.extend(["--gear-ratio".into(), "100".into()]);
    fails("half_kt", "payload", &a, &["--motor-constant is needed"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cli_error_window_and_exclude() {
    let with = |extra: &[&str]| {
        let mut a = ur5_log("ur5_500hz.mcap");
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    fails("win_syntax", "identify", &with(&["--window", "2-3"]), &["--window", "START:END", "2-3"]);
    fails("win_after", "identify", &with(&["--window", "500:600"]), &["ur5_500hz.mcap", "--window", "the log lasts"]);
    fails("excl_order", "identify", &with(&["--exclude", "3:1"]), &["--exclude", "3:1"]);
    fails("velocity_log", "diagnose", &with(&["--velocity", "log", "--out", "/nonexistent/d"]), &["--velocity"]);
    fails("coulomb", "identify", &with(&["--coulomb", "tanh"]), &["coulomb", "'auto', 'sign' or 'model'", "tanh"]);
}
