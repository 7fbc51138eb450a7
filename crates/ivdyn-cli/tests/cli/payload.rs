//! A simulated UR5 carrying 2 kg: `ivdyn payload` within 3 % (mass) and 1 cm (COM).
use crate::util;
use util::*;

fn run(mut args: Vec<String>, sub: &str, extra: &[&str]) -> std::process::Output {
    args.insert(0, sub.into());
    args.extend(extra.iter().map(|s| s.to_string()));
    let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    ivdyn(&a)
}

const COM: [f64; 3] = [0.01, -0.02, 0.05];

fn check(p: &std::path::Path, label: &str) {
    let r = json(p);
    let m = r["mass"].as_f64().unwrap();
    let com: Vec<f64> = r["com"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let dc = ((com[0] - COM[0]).powi(2) + (com[1] - COM[1]).powi(2) + (com[2] - COM[2]).powi(2)).sqrt();
    eprintln!(
        "{label}: mass {m:.4} kg (err {:.3} %), com {com:?} (err {:.2} mm), mass_std {}",
        100.0 * (m - 2.0).abs() / 2.0,
        1e3 * dc,
        r["mass_std"]
    );
    assert!((m - 2.0).abs() < 0.03 * 2.0, "{label}: mass {m}");
    assert!(dc < 0.01, "{label}: com {com:?}");
    for k in ["mass_std", "com_std", "inertia", "inertia_std"] {
        assert!(!r[k].is_null(), "{label}: {k} missing");
    }
    assert_eq!(r["com_std"].as_array().unwrap().len(), 3);
    assert_eq!(r["inertia"].as_array().unwrap().len(), 6);
    assert_eq!(r["inertia_std"].as_array().unwrap().len(), 6);
}

#[test]
fn cli_payload_ur5_2kg() {
    let d = tmpdir("payload");
    let (after, before, j1, j2) = (d.join("after.mcap"), d.join("before.mcap"), d.join("p1.json"), d.join("p2.json"));
    ok(&run(
        ur5_args(),
        "simulate",
        &[
            "--noise",
            "0.1",
            "--seed",
            "21",
            "--payload-mass",
            "2",
            "--payload-com",
            "0.01,-0.02,0.05",
            "--payload-inertia",
            "0.004,0,0,0.004,0,0.003",
            "--out",
            &s(&after),
        ],
    ));
    ok(&run(ur5_args(), "simulate", &["--noise", "0.1", "--seed", "22", "--out", &s(&before)]));
    let out = run(ur5_args(), "payload", &["--log", &s(&after), "--json", &s(&j1)]);
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("mass"));
    check(&j1, "against the URDF");
    ok(&run(ur5_args(), "payload", &["--log", &s(&after), "--before", &s(&before), "--json", &s(&j2)]));
    check(&j2, "with a before log");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cli_payload_nominal_error_cancelled_by_before_log() {
    // the "true" arm differs from the URDF (friction the URDF lacks): the before log cancels it
    let d = tmpdir("payload_before");
    let (after, before, j) = (d.join("after.csv"), d.join("before.csv"), d.join("p.json"));
    let fr = ["--fc", "1,1,0.8,0.3,0.3,0.2", "--fv", "2,2,1,0.3,0.3,0.2"];
    let mut a =
        vec!["--noise", "0.05", "--seed", "31", "--payload-mass", "2", "--payload-com", "0.01,-0.02,0.05", "--out"];
    let after_s = s(&after);
    a.push(&after_s);
    a.extend(fr);
    ok(&run(ur5_args(), "simulate", &a));
    let before_s = s(&before);
    let mut b = vec!["--noise", "0.05", "--seed", "32", "--out", &before_s];
    b.extend(fr);
    ok(&run(ur5_args(), "simulate", &b));
    ok(&run(ur5_args(), "payload", &["--log", &s(&after), "--before", &s(&before), "--json", &s(&j)]));
    check(&j, "friction in the arm, before log");
    let _ = std::fs::remove_dir_all(&d);
}

/// As a new user would: a log NOT written by ivdyn. `fixtures/diagnose/payload.mcap` comes
/// from MuJoCo (an independent simulator: a 2 kg body welded to wrist_3_link, PD tracking,
/// torque noise 0.02-0.15 N m, quantised encoders) written by Python's mcap-ros2-support
/// (`python/tools/make_diagnose_cases.py`); the truth is in `fixtures/diagnose/cases.json`.
/// The criterion: mass within 3 %, COM within 1 cm; with and without a before-log.
#[test]
fn cli_payload_on_an_independent_mujoco_log_written_by_python() {
    let cases: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("diagnose/cases.json")).unwrap()).unwrap();
    let case = cases["cases"].as_array().unwrap().iter().find(|c| c["name"] == "payload").unwrap();
    let truth = &case["effects"][0]["parameters"];
    let mass = truth["mass"].as_f64().unwrap();
    let com: Vec<f64> = truth["com"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let dir = tmpdir("payload_mujoco");
    for (label, before) in [("urdf nominal", None), ("before-log nominal", Some(fixture("diagnose/clean_a.mcap")))] {
        let out = dir.join(format!("{}.json", label.replace(' ', "_")));
        let (log, json_out) = (fixture("diagnose/payload.mcap"), s(&out));
        let mut extra = vec!["--log", log.as_str(), "--json", json_out.as_str()];
        if let Some(b) = before.as_deref() {
            extra.extend(["--before", b]);
        }
        ok(&run(ur5_args(), "payload", &extra));
        let r = json(&out);
        let m = r["mass"].as_f64().unwrap();
        let c: Vec<f64> = r["com"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let dc = (0..3).map(|k| (c[k] - com[k]).powi(2)).sum::<f64>().sqrt();
        eprintln!("{label}: mass {m:.4} kg (truth {mass}), COM error {:.2} mm", 1e3 * dc);
        assert!((m - mass).abs() < 0.03 * mass, "{label}: mass {m} vs {mass}");
        assert!(dc < 0.01, "{label}: com {c:?} vs {com:?}");
    }
}
