//! The outputs of one command are all or nothing: a later output that fails, SIGINT or
//! SIGTERM leave none of the command's new files and no staging folder; special files
//! (FIFOs, /dev/null) are written in place, never replaced.
#![cfg(unix)]
use crate::util;
use util::*;

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `ivdyn <args>`, expects exit code 1, and checks that `d` holds exactly `keep`.
fn fails_leaving(name: &str, args: Vec<String>, d: &Path, keep: &[&str]) {
    let out = run(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{name}: {err}");
    assert_eq!(files_in(d), keep, "{name}: left new outputs or staging folders; stderr {err}");
}

fn ur5_log() -> String {
    fixture("logs/ur5_500hz.mcap")
}

#[test]
fn identify_later_output_fails_leaves_none() {
    let d = tmpdir("all_identify");
    let p = |f: &str| s(&d.join(f));
    // the URDF write-back refuses physically inconsistent parameters (no --consistent), after --out-params
    let a = ur5_cmd(
        "identify",
        &["--log", &ur5_log(), "--out-params", &p("p.json"), "--write-urdf", &p("u.urdf"), "--json", &p("r.json")],
    );
    fails_leaving("identify urdf", a, &d, &[]);
    // the prediction MCAP goes to a folder that does not exist, after the other three
    std::fs::write(d.join("p.json"), "old").unwrap();
    let a = ur5_cmd(
        "identify",
        &["--log", &ur5_log(), "--out-params", &p("p.json"), "--json", &p("r.json"), "--out-mcap", &p("no/r.mcap")],
    );
    fails_leaving("identify mcap", a, &d, &["p.json"]);
    assert_eq!(std::fs::read_to_string(d.join("p.json")).unwrap(), "old", "a file already there is untouched");
}

#[test]
fn diagnose_later_output_fails_leaves_none() {
    let d = tmpdir("all_diagnose");
    std::fs::create_dir(d.join("taken.json")).unwrap();
    let a = ur5_cmd(
        "diagnose",
        &["--log", &ur5_log(), "--out", &s(&d.join("new/out")), "--json", &s(&d.join("taken.json"))],
    );
    // the output folder it created is removed too
    fails_leaving("diagnose", a, &d, &["taken.json"]);
}

#[test]
fn simulate_later_output_fails_leaves_none() {
    let d = tmpdir("all_simulate");
    for out in ["x.mcap", "x.csv"] {
        let a =
            ur5_cmd("simulate", &["--duration", "2", "--out", &s(&d.join(out)), "--json", &s(&d.join("no/s.json"))]);
        fails_leaving(out, a, &d, &[]);
    }
}

#[test]
fn excite_later_output_fails_leaves_none() {
    let d = tmpdir("all_excite");
    let quick = ["--duration", "5", "--starts", "1", "--iterations", "5", "--random", "2"];
    let mut rest: Vec<String> = quick.iter().map(|s| s.to_string()).collect();
    rest.extend(["--out", &s(&d.join("e.csv")), "--out-mcap", &s(&d.join("e.mcap"))].map(String::from));
    rest.extend(["--json".into(), s(&d.join("no/e.json"))]);
    let r: Vec<&str> = rest.iter().map(|s| s.as_str()).collect();
    fails_leaving("excite", ur5_cmd("excite", &r), &d, &[]);
}

#[test]
fn payload_later_output_fails_leaves_none() {
    let input = tmpdir("all_payload_in");
    let after = s(&input.join("after.mcap"));
    let sim = ["--seed", "21", "--payload-mass", "2", "--payload-com", "0.01,-0.02,0.05", "--out", &after];
    ok(&run(ur5_cmd("simulate", &sim)));
    let d = tmpdir("all_payload");
    // the URDF's side file cannot be written (a folder is there): not the URDF, not the report
    std::fs::create_dir(d.join("u.urdf.json")).unwrap();
    let (j, u) = (s(&d.join("p.json")), s(&d.join("u.urdf")));
    fails_leaving(
        "payload",
        ur5_cmd("payload", &["--log", &after, "--json", &j, "--write-urdf", &u]),
        &d,
        &["u.urdf.json"],
    );
}

/// `mkfifo p`.
fn mkfifo(p: &Path) {
    assert!(Command::new("mkfifo").arg(p).status().unwrap().success());
}

/// Starts `simulate --out d/x.mcap --json d/f` with `d/f` a FIFO nobody reads (the job
/// then blocks at commit, its MCAP staged) and sends `signal` once a staging folder is in
/// `d` (`at_commit` false: from the start of the MCAP write on) or in the child's TMPDIR
/// (`at_commit`: the JSON for the FIFO is staged, the job is at or near its commit).
/// Checks the exit code and that nothing is left in `d` or the TMPDIR.
fn stopped(name: &str, signal: &str, code: i32, at_commit: bool) {
    let d = tmpdir(name);
    let tmp = tmpdir(&format!("{name}_tmp"));
    mkfifo(&d.join("f"));
    let a = ur5_cmd("simulate", &["--duration", "20", "--out", &s(&d.join("x.mcap")), "--json", &s(&d.join("f"))]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_ivdyn"))
        .args(&a)
        .arg("--quiet")
        .env("TMPDIR", tmp.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let watch = if at_commit { &tmp } else { &d };
    let t0 = Instant::now();
    while !files_in(watch).iter().any(|f| f.starts_with(".ivdyn-")) {
        assert!(t0.elapsed() < Duration::from_secs(120), "{name}: no staging folder appeared");
        assert!(child.try_wait().unwrap().is_none(), "{name}: ended before its outputs were staged");
        std::thread::sleep(Duration::from_millis(1));
    }
    let staged = files_in(&d);
    assert!(Command::new("kill").args([signal, &child.id().to_string()]).status().unwrap().success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(code), "{name}: {status}");
    assert_eq!(files_in(&d), ["f"], "{name}: left {:?} (staged before the signal: {staged:?})", files_in(&d));
    assert!(files_in(&tmp).is_empty(), "{name}: left {:?} in TMPDIR", files_in(&tmp));
    assert!(std::fs::symlink_metadata(d.join("f")).unwrap().file_type().is_fifo());
}

#[test]
fn sigint_and_sigterm_leave_nothing() {
    stopped("sigint_write", "-INT", 130, false);
    stopped("sigterm_write", "-TERM", 143, false);
    stopped("sigint_commit", "-INT", 130, true);
    stopped("sigterm_commit", "-TERM", 143, true);
}

#[test]
fn json_into_a_fifo_and_dev_null_written_in_place() {
    let d = tmpdir("special");
    let fifo = d.join("f");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let a = ur5_cmd("simulate", &["--duration", "2", "--out", &s(&d.join("x.csv")), "--json", &s(&fifo)]);
    ok(&run(a));
    let v: serde_json::Value = serde_json::from_str(&reader.join().unwrap()).unwrap();
    assert_eq!(
        v["samples"].as_u64().unwrap() as usize + 2,
        std::fs::read_to_string(d.join("x.csv")).unwrap().lines().count()
    );
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced");
    assert_eq!(files_in(&d), ["f", "x.csv"]);

    let a = ur5_cmd("identify", &["--log", &ur5_log(), "--json", "/dev/null", "--out-params", "/dev/null"]);
    ok(&run(a));
    assert!(std::fs::symlink_metadata("/dev/null").unwrap().file_type().is_char_device(), "/dev/null was replaced");
}

#[test]
fn json_to_dev_stdout_redirected_to_a_file() {
    // `> out.txt`: the JSON goes to the process's stdout at its offset, between the notes
    // printed before and the summary printed after, and /dev/stdout is not replaced
    let d = tmpdir("stdout");
    let out = d.join("out.txt");
    let a = ur5_cmd("simulate", &["--duration", "2", "--out", &s(&d.join("x.csv")), "--json", "/dev/stdout"]);
    let status = Command::new(env!("CARGO_BIN_EXE_ivdyn"))
        .args(&a)
        .arg("--quiet")
        .stdout(std::fs::File::create(&out).unwrap())
        .status()
        .unwrap();
    assert!(status.success());
    let text = std::fs::read_to_string(&out).unwrap();
    let (start, end) = (text.find("\n{\n").unwrap() + 1, text.rfind("\n}\n").unwrap() + 2);
    let v: serde_json::Value = serde_json::from_str(&text[start..end]).unwrap();
    assert_eq!(v["samples"], 1000);
    assert!(text[end..].contains("wrote 1000 samples"), "the summary follows the JSON: {:?}", &text[end..]);
    assert!(!std::fs::symlink_metadata("/dev/stdout").unwrap().is_file(), "/dev/stdout was replaced");
    assert_eq!(files_in(&d), ["out.txt", "x.csv"]);
}

#[test]
fn json_to_dev_full_fails_before_any_rename() {
    // the in-place copies come first: when one fails, no other output is put in place
    if !Path::new("/dev/full").exists() {
        return;
    }
    let d = tmpdir("full");
    let a = ur5_cmd("simulate", &["--duration", "2", "--out", &s(&d.join("x.mcap")), "--json", "/dev/full"]);
    fails_leaving("/dev/full", a, &d, &[]);
    assert!(std::fs::symlink_metadata("/dev/full").unwrap().file_type().is_char_device());
}
