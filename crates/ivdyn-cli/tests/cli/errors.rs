//! Bad input: one line on stderr naming the problem, non-zero exit, no output file.
use crate::util;
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
    fails("threads_0", "diagnose", &with(&["--threads", "0", "--out", "/nonexistent/d"]), &["--threads", "0"]);
    fails("coulomb", "identify", &with(&["--coulomb", "tanh"]), &["coulomb", "'auto', 'sign' or 'model'", "tanh"]);
}

/// Issue 16: a cut-off far below the sample rate (or past Nyquist) is refused with the
/// option and the allowed range named, in every job that differentiates. `1e-30` used to
/// panic (the diagnosis' edge trim wrapped, the automatic decimation factor overflowed).
#[test]
fn cli_error_cutoff_out_of_range() {
    let with = |extra: &[&str]| {
        let mut a = ur5_log("ur5_500hz.mcap");
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let want = ["ur5_500hz.mcap", "--cutoff", "1e-30 Hz", "500 Hz", "allowed [0.05, 200] Hz"];
    fails("fc_id", "identify", &with(&["--cutoff", "1e-30"]), &want);
    fails("fc_id_stream", "identify", &with(&["--cutoff", "1e-30", "--stream"]), &want);
    fails("fc_pl", "payload", &with(&["--cutoff", "1e-30"]), &want);
    fails("fc_nyq", "identify", &with(&["--cutoff", "300"]), &["--cutoff", "300 Hz", "Nyquist frequency 250 Hz"]);
    let d = tmpdir("fc_diag_out");
    let diag = with(&["--cutoff", "1e-30", "--out", &s(&d.join("diag"))]);
    fails("fc_diag", "diagnose", &diag, &want);
    let _ = std::fs::remove_dir_all(&d);
}

/// Issue 16: 200 rows 1e-25 s apart (stamps in the wrong unit, say): the default cut-off
/// is out of range at that rate; the error says so and points at the stamps. The
/// diagnosis used to panic ("range start index 18446744073709551615").
#[test]
fn cli_error_absurd_sample_spacing() {
    let d = tmpdir("tiny_dt_src");
    let names: Vec<String> = ["shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"]
        .iter()
        .map(|j| format!("{j}_joint"))
        .collect();
    let mut csv = String::from("t");
    for j in &names {
        csv += &format!(",{j}.q");
    }
    for j in &names {
        csv += &format!(",{j}.tau");
    }
    csv += "\n";
    for k in 0..200 {
        csv += &format!("{:e}", k as f64 * 1e-25);
        for j in 0..2 * names.len() {
            csv += &format!(",{}", 0.1 * j as f64 + 0.01 * (0.1 * k as f64 + j as f64).sin());
        }
        csv += "\n";
    }
    let path = d.join("tiny_dt.csv");
    std::fs::write(&path, csv).unwrap();
    let mut a = ur5_args();
    a.extend(["--log".into(), s(&path)]);
    // the sample-time floor (prep::check_sample_time, 1e-5 s) speaks before the cut-off's
    // range check would: the file, the spacing and the likely cause are named
    let want = ["tiny_dt.csv", "sample time 1.00000", "e-25 s is below", "stamps in the wrong unit"];
    fails("tiny_dt_id", "identify", &a, &want);
    a.extend(["--out".into(), s(&d.join("diag"))]);
    fails("tiny_dt_diag", "diagnose", &a, &want);
    let _ = std::fs::remove_dir_all(&d);
}

/// Issue 16: `simulate` sizes its arrays by `--duration x --rate`: an infinite or huge
/// duration is refused with the bound, before anything is allocated or written.
#[test]
fn cli_error_simulate_duration_bounded() {
    let d = tmpdir("sim_dur");
    for (dur, want) in [("inf", "finite"), ("1e12", "at most 1e7")] {
        let mut a = ur5_args();
        a.extend(["--duration".into(), dur.into(), "--out".into(), s(&d.join("x.mcap"))]);
        fails(&format!("sim_dur_{dur}"), "simulate", &a, &["--duration", want]);
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Runs `identify` with stdout `out` (a pipe closed before the start, or /dev/full):
/// exit code 3, no panic, and the JSON report written and whole.
fn identify_with_stdout(name: &str, out: std::process::Stdio) {
    let d = tmpdir(name);
    let report = d.join("out.json");
    let mut a = ur5_log("ur5_500hz.mcap");
    a.extend(["--json".into(), s(&report), "--quiet".into()]);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ivdyn"))
        .arg("identify")
        .args(&a)
        .stdout(out)
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run ivdyn");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{name}: {err}");
    assert_eq!(o.status.code(), Some(3), "{name}: {err}");
    // whole: it parses (json() panics otherwise) and has the fit in it
    assert!(json(&report).get("fit").is_some(), "{name}: report without the fit");
    let _ = std::fs::remove_dir_all(&d);
}

/// Issue 16: `ivdyn identify ... | head -1` and `> /dev/full` used to panic on the first
/// line of the summary (before the job ran: no JSON). The job now finishes, its files are
/// whole, and the exit code is 3; a closed pipe prints nothing, a full device one line.
#[test]
fn cli_closed_or_full_stdout() {
    let (r, w) = std::io::pipe().unwrap();
    drop(r); // the reader is gone before the first byte, as after `head -1` has read its line
    identify_with_stdout("epipe", w.into());
    if std::path::Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
        identify_with_stdout("enospc", full.into());
    }
}
