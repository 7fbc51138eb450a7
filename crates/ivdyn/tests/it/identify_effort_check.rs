//! `identify` stops on a joint whose logged effort runs opposite to the model's joint torque
//! or is in another unit (`app::effort_check`): the truth is what a test did to the log.

use std::path::{Path, PathBuf};

use ivdyn::Robot;
use ivdyn::app::{self, IdentifyOptions};
use ivdyn::log::{JointLog, ReadOptions, read_mcap};
use serde_json::Value;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The robot (case's URDF) and log of fixture case `name` in `cases`.
fn case(cases: &Path, name: &str) -> (Robot, JointLog) {
    let m: Value = serde_json::from_str(&std::fs::read_to_string(cases).unwrap()).unwrap();
    let c = m["cases"].as_array().unwrap().iter().find(|c| c["name"] == name).unwrap();
    let robot =
        Robot::from_urdf(root().join(c["urdf"].as_str().unwrap()), m["base"].as_str(), m["tip"].as_str()).unwrap();
    let log =
        read_mcap(cases.parent().unwrap().join(c["log"].as_str().unwrap()), &ReadOptions::new(&robot.joint_names))
            .unwrap();
    (robot, log)
}

/// `log` with joint `j`'s effort negated.
fn negated(log: &JointLog, j: usize) -> JointLog {
    let mut l = log.clone();
    let n = l.dof();
    l.tau.as_mut().unwrap().iter_mut().skip(j).step_by(n).for_each(|t| *t = -*t);
    l
}

/// `identify`'s error on `log`, `None` when it identifies.
fn refusal(robot: &Robot, log: &JointLog) -> Option<String> {
    app::identify(robot, log, &IdentifyOptions::default()).err().map(|e| e.to_string())
}

/// An effect-free 6-joint log (inertials 30 % off in the URDF, which identify replaces):
/// identified as logged; a middle joint's effort negated, and the terminal joint's (which
/// `diagnose`'s check on the nominal torque leaves alone, a payload can turn it around),
/// each an error naming that joint. Before, identify fitted the reversed torque as well as
/// it could and reported the result.
#[test]
fn a_joint_effort_of_the_opposite_sign_is_an_error_naming_the_joint() {
    let (robot, log) = case(&root().join("fixtures/diagnose_wide/rarm6_6j/cases.json"), "e30_0fx");
    assert_eq!(refusal(&robot, &log), None);
    for (j, name) in [(2, "joint_3"), (5, "joint_6")] {
        let err = refusal(&robot, &negated(&log, j)).expect("a reversed joint is refused");
        assert!(err.contains(&format!("joint '{name}': the logged effort runs opposite")), "{err}");
        let pct: f64 = err.split("negated leaves ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(pct < 20.0, "{err}");
    }
}

/// The same log with one joint's effort in mN m, then every joint's: an error naming a
/// joint so scaled, and the slope of its torque on the nominal model's, a thousand within
/// the URDF's 30 % inertial error. Before, identify fitted the log and reported inertial
/// parameters a thousand times the arm's (every joint in mN m: the fit cannot tell a scale
/// of all torques from one of all parameters).
#[test]
fn an_effort_in_mn_m_is_an_error_naming_the_joint() {
    let (robot, log) = case(&root().join("fixtures/diagnose_wide/rarm6_6j/cases.json"), "e30_0fx");
    let scaled = |joints: &[usize]| {
        let mut l = log.clone();
        let n = l.dof();
        for (k, t) in l.tau.as_mut().unwrap().iter_mut().enumerate() {
            if joints.contains(&(k % n)) {
                *t *= 1000.0;
            }
        }
        l
    };
    // every joint in mN m: any of them may be named (the first whose torque the model follows)
    for joints in [vec![2], (0..6).collect()] {
        let err = refusal(&robot, &scaled(&joints)).expect("an effort in mN m is refused");
        let named = joints.iter().any(|&j| err.contains(&format!("joint 'joint_{}': the logged effort is ", j + 1)));
        assert!(named && err.contains("not in N m"), "{err}");
        let k: f64 = err.split("the logged effort is ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!((700.0..1300.0).contains(&k), "slope {k}: 1000 within the 30 % CAD error");
    }
}

/// Every fixture log of `fixtures/diagnose*` (56 logs, 13 arms), as logged and with each
/// joint's effort negated in turn: a table of which negations identify names, and whether
/// any log as logged is refused (the numbers of `app::effort_check`'s module docs). A
/// measurement (2 minutes in a debug build), not part of the suite:
/// `cargo test --release -p ivdyn --test it reversed_effort_over_the_fixture_logs -- --ignored --nocapture`.
#[test]
#[ignore]
fn reversed_effort_over_the_fixture_logs() {
    let (mut named, mut joints, mut refused) = (0, 0, vec![]);
    for cases in cases_files(&root().join("fixtures")) {
        let m: Value = serde_json::from_str(&std::fs::read_to_string(&cases).unwrap()).unwrap();
        for c in m["cases"].as_array().unwrap() {
            let name = c["name"].as_str().unwrap();
            let (robot, log) = case(&cases, name);
            let what = format!("{}/{name}", cases.parent().unwrap().display());
            if let Some(e) = refusal(&robot, &log) {
                refused.push(format!("{what}: {e}"));
            }
            let hits: Vec<bool> = (0..robot.dof())
                .map(|j| {
                    let want = format!("joint '{}': the logged effort runs opposite", robot.joint_names[j]);
                    refusal(&robot, &negated(&log, j)).is_some_and(|e| e.contains(&want))
                })
                .collect();
            println!("{what}: {}", hits.iter().map(|h| if *h { 'x' } else { '.' }).collect::<String>());
            named += hits.iter().filter(|h| **h).count();
            joints += hits.len();
        }
    }
    println!("reversed joints named: {named} of {joints}; logs refused as logged: {}", refused.len());
    assert!(refused.is_empty(), "{refused:#?}");
}

fn cases_files(d: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(cases_files(&p));
        } else if p.file_name().unwrap() == "cases.json" {
            out.push(p);
        }
    }
    out.sort();
    out
}
