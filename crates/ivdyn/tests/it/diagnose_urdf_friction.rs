//! A URDF's joint friction the log contradicts outright (`diagnose::urdf_friction`,
//! docs/diagnose.md "The URDF's friction"). Case: `fixtures/diagnose_panda` `coulomb_viscous`
//! (exact inertials, 2 s at 1 kHz; MuJoCo's `frictionloss` and `damping`: Coulomb friction fc
//! 1.2 and 0.6 N m, viscous friction fv 0.6 and 0.3 N m s/rad on `panda_joint2` and
//! `panda_joint6`; none elsewhere), its URDF given friction on one joint.

use std::path::Path;

use ivdyn::Robot;
use ivdyn::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use ivdyn::log::{ReadOptions, read_mcap};

use super::diagnose_cases::{case_named, cases_in, f64s, run_in};

/// The case diagnosed from its URDF with `<dynamics friction=fc damping=fv>` on `joint`.
fn with_urdf_friction(joint: &str, fc: f64, fv: f64) -> Diagnosis {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let m = cases_in("diagnose_panda");
    let case = case_named(&m, "coulomb_viscous");
    let text = std::fs::read_to_string(root.join(case["urdf"].as_str().unwrap())).unwrap();
    // the `<dynamics>` of the joint's element, the first after its opening tag
    let at = text.find(&format!("<joint name=\"{joint}\"")).unwrap();
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

const CONTRADICTED: &str = "the URDF's friction is not the log's";

/// URDF friction (fc 1.0 N m, fv 0.5 N m s/rad) on `panda_joint3`, which has none: the
/// change it calls for is its whole level, negative; the diagnosis is redone without the
/// URDF's friction: exactly the diagnosis of the fixture's own URDF (which has none), the
/// true friction named on joints 2 and 6 (joint 2's levels within 10 % of truth), nothing on
/// joint 3, and a detail saying why.
#[test]
fn a_urdf_friction_the_log_has_none_of_is_not_the_nominal() {
    let d = with_urdf_friction("panda_joint3", 1.0, 0.5);
    let (joints, fc) = named(&d, "coulomb_friction", "fc");
    assert_eq!(joints, vec!["panda_joint2", "panda_joint6"], "{:?}", d.details);
    assert!((fc[0] - 1.2).abs() <= 0.12, "fc {} vs truth 1.2", fc[0]);
    let (joints, fv) = named(&d, "viscous_friction", "fv");
    assert_eq!(joints, vec!["panda_joint2", "panda_joint6"], "{:?}", d.details);
    assert!((fv[0] - 0.6).abs() <= 0.06, "fv {} vs truth 0.6", fv[0]);
    let m = cases_in("diagnose_panda");
    let case = case_named(&m, "coulomb_viscous");
    let own = run_in("diagnose_panda", case, &m);
    assert_eq!(serde_json::to_value(&d.json).unwrap(), serde_json::to_value(&own).unwrap());
    assert!(d.details.iter().any(|l| l.contains(CONTRADICTED) && l.contains("panda_joint3")), "{:?}", d.details);
}

/// The true friction in the URDF on `panda_joint2`: it is the nominal model's (not missing),
/// only `panda_joint6`'s is named, and the URDF is not called into question.
#[test]
fn a_urdf_friction_the_log_has_is_the_nominal() {
    let d = with_urdf_friction("panda_joint2", 1.2, 0.6);
    assert_eq!(named(&d, "coulomb_friction", "fc").0, vec!["panda_joint6"], "{:?}", d.details);
    assert_eq!(named(&d, "viscous_friction", "fv").0, vec!["panda_joint6"], "{:?}", d.details);
    assert!(!d.details.iter().any(|l| l.contains(CONTRADICTED)), "{:?}", d.details);
}
