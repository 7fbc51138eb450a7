//! The URDF's joint friction (`<dynamics friction damping>`) is checked against the log,
//! not taken as known (`diagnose::urdf_friction`, docs/diagnose.md "The URDF's friction").
//! Case: `fixtures/diagnose_panda` `coulomb_viscous` (exact inertials, 2 s at 1 kHz; MuJoCo's
//! `frictionloss` and `damping`: Coulomb friction fc 1.2 and 0.6 N m, viscous friction fv 0.6
//! and 0.3 N m s/rad on `panda_joint2` and `panda_joint6`), its URDF given friction on
//! `panda_joint2`: the truth (the URDF holds it: not missing) or three times the truth (the
//! log's own level is named, not a correction to the URDF's).

use std::path::Path;

use ivdyn::Robot;
use ivdyn::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use ivdyn::log::{ReadOptions, read_mcap};

use super::diagnose_cases::{cases_in, f64s};

/// The case diagnosed from its URDF with `<dynamics friction=fc damping=fv>` on `panda_joint2`.
fn with_urdf_friction(fc: f64, fv: f64) -> Diagnosis {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let m = cases_in("diagnose_panda");
    let case = m["cases"].as_array().unwrap().iter().find(|c| c["name"] == "coulomb_viscous").unwrap();
    let text = std::fs::read_to_string(root.join(case["urdf"].as_str().unwrap())).unwrap();
    // the `<dynamics>` of the joint's element, the first after its opening tag
    let at = text.find("<joint name=\"panda_joint2\"").unwrap();
    let d0 = at + text[at..].find("<dynamics").unwrap();
    let d1 = d0 + text[d0..].find("/>").unwrap() + 2;
    let urdf = format!("{}<dynamics damping=\"{fv}\" friction=\"{fc}\"/>{}", &text[..d0], &text[d1..]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("panda_arm.urdf");
    std::fs::write(&path, urdf).unwrap();
    let robot = Robot::from_urdf(&path, m["base"].as_str(), m["tip"].as_str()).unwrap();
    let log = read_mcap(
        root.join("fixtures/diagnose_panda").join(case["log"].as_str().unwrap()),
        &ReadOptions::new(&robot.joint_names),
    )
    .unwrap();
    diagnose(&robot, &log, &DiagnoseOptions::default()).unwrap()
}

/// The joints `name` is named on, and its parameter `key` there.
fn named(d: &Diagnosis, name: &str, key: &str) -> (Vec<String>, Vec<f64>) {
    match d.json.effects.iter().find(|e| e.name == name) {
        Some(e) => (e.joints.clone(), f64s(&e.parameters[key])),
        None => (vec![], vec![]),
    }
}

#[test]
fn friction_the_urdf_holds_is_not_missing() {
    let d = with_urdf_friction(1.2, 0.6);
    assert_eq!(named(&d, "coulomb_friction", "fc").0, vec!["panda_joint6"], "{:?}", d.details);
    assert_eq!(named(&d, "viscous_friction", "fv").0, vec!["panda_joint6"], "{:?}", d.details);
    let line = d.details.iter().find(|l| l.starts_with("URDF friction on panda_joint2")).expect("a detail line");
    assert_eq!(line.matches("holds it").count(), 2, "{line}");
}

#[test]
fn friction_the_urdf_has_wrong_is_named_at_the_logs_level() {
    let d = with_urdf_friction(3.6, 1.8);
    let (joints, fc) = named(&d, "coulomb_friction", "fc");
    assert_eq!(joints, vec!["panda_joint2", "panda_joint6"], "{:?}", d.details);
    assert!((fc[0] - 1.2).abs() <= 0.12, "fc {} vs truth 1.2", fc[0]);
    let (joints, fv) = named(&d, "viscous_friction", "fv");
    assert_eq!(joints, vec!["panda_joint2", "panda_joint6"], "{:?}", d.details);
    assert!((fv[0] - 0.6).abs() <= 0.06, "fv {} vs truth 0.6", fv[0]);
    let line = d.details.iter().find(|l| l.starts_with("URDF friction on panda_joint2")).expect("a detail line");
    assert_eq!(line.matches("is off").count(), 2, "{line}");
}
