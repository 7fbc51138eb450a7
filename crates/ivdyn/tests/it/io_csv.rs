//! CSV logs: the Python-written fixture, an exact write/read round trip, and bad input.

use crate::scratch::ScratchFile;
use std::path::{Path, PathBuf};

use ivdyn::Error;
use ivdyn::log::{JointLog, read_csv, write_csv};

const UR5: [&str; 6] =
    ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/logs").join(name)
}

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn-io-csv", name)
}

fn err_of(text: &str, name: &str, joints: &[&str]) -> String {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    match read_csv(&p, joints) {
        Err(e @ Error::Log { .. }) => {
            let s = e.to_string();
            assert!(s.contains(name) && !s.contains('\n'), "{s}");
            s
        }
        other => panic!("expected Error::Log, got {other:?}"),
    }
}

#[test]
fn reads_fixture_in_requested_order() {
    // reversed order, and the file has an extra gripper_joint.q column
    let want: Vec<&str> = UR5.iter().rev().copied().collect();
    let log = read_csv(fixture("ur5_short.csv"), &want).unwrap();
    assert_eq!(log.len(), 20);
    assert!(log.qd.is_none() && log.u.is_none());
    let tau = log.tau.as_ref().unwrap();
    let f = 0.5 + 0.25 * 5.0; // wrist_3 = URDF joint 5, first column here
    let t = 0.07;
    assert_eq!(log.t[7], t);
    assert!((log.q[7 * 6] - (0.3 * (2.0 * std::f64::consts::PI * f * t + 0.5).sin() + 0.25)).abs() < 1e-14);
    assert!((tau[7 * 6] - (3.0 * (2.0 * std::f64::consts::PI * f * t).cos() + 5.0)).abs() < 1e-14);
}

#[test]
fn round_trip_is_exact() {
    let n = 3;
    let names = ["a", "b.c", "d"];
    let t = 40;
    let log = JointLog {
        joint_names: names.iter().map(|s| s.to_string()).collect(),
        t0_ns: -1_234_567_890,
        t: (0..t).map(|k| k as f64 / 3.0).collect(),
        q: (0..t * n).map(|i| (i as f64).sin() * 1e-7).collect(),
        qd: Some((0..t * n).map(|i| (i as f64).cos() * 1e9).collect()),
        tau: None,
        u: Some((0..t * n).map(|i| 1.0 / (i as f64 + 0.3)).collect()),
        current: Some((0..t * n).map(|i| -(i as f64) / 7.0).collect()),
        truncated: false,
    };
    let p = tmp("rt.csv");
    write_csv(&p, &log).unwrap();
    let back = read_csv(&p, &names).unwrap();
    assert_eq!(back, log);
}

#[test]
fn errors() {
    let j = ["a", "b"];
    let e = err_of("t,a.q,c.q\n0,1,2\n", "missing.csv", &j);
    assert!(e.contains("[b.q] are missing") && e.contains("[a.q, c.q]"), "{e}");
    let e = err_of("time,a.q,b.q\n0,1,2\n", "not.csv", &j);
    assert!(e.contains("no time column 't'"), "{e}");
    let e = err_of("t,a.q,b.q\n0,1,2\n0.1,1,nan\n", "nan.csv", &j);
    assert!(e.contains("sample 1") && e.contains("joint 'b' q is NaN") && e.contains("line 3"), "{e}");
    let e = err_of("t,a.q,b.q,a.tau,b.tau\n0,1,2,3,inf\n", "inf.csv", &j);
    assert!(e.contains("sample 0") && e.contains("joint 'b' tau is inf"), "{e}");
    let e = err_of("# c\nt,a.q,b.q\n0,1,2\n0.2,1,2\n0.1,1,2\n", "back.csv", &j);
    assert!(e.contains("sample 2") && e.contains("time goes back"), "{e}");
    let e = err_of("t,a.q,b.q\n0,1,x\n", "num.csv", &j);
    assert!(e.contains("column 'b.q': 'x' is not a number"), "{e}");
    let e = err_of("t,a.q,b.q\n0,1\n", "short.csv", &j);
    assert!(e.contains("2 cells, the header has 3"), "{e}");
    let e = err_of("t,a.q,b.q,a.qd\n0,1,2,3\n", "partial.csv", &j);
    assert!(e.contains("[b.qd] are missing"), "{e}");
    let e = err_of("t,a.q,b.q\n", "empty.csv", &j);
    assert!(e.contains("no samples"), "{e}");
}
