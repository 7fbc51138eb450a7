//! The loader's tip rules on `tests/data/arm7_hand.urdf` (7 joints, flange, hand, two
//! finger joints): a tip given ends the chain (the hand and fingers beyond the flange are
//! dropped), `fuse_beyond_tip` fuses them into the last link, and without a tip the rigid
//! bodies below the default tip are fused as before. Masses are checked against the URDF's
//! own `<mass>` values, so the test is the physics (what the arm carries), not a copy of
//! the loader's output.

use std::path::PathBuf;

use ivdyn::Robot;
use ivdyn::core::params::{M, link_col};
use ivdyn::robot::urdf::UrdfOptions;

fn urdf() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/arm7_hand.urdf")
}

/// `<mass>` of each named link, read straight from the file.
fn urdf_mass(links: &[&str]) -> f64 {
    let u = urdf_rs::read_file(urdf()).unwrap();
    links.iter().map(|l| u.links.iter().find(|x| x.name == *l).unwrap().inertial.mass.value).sum()
}

fn model_mass(r: &Robot, k: usize) -> f64 {
    r.params()[link_col(k, M)]
}

fn total_mass(r: &Robot) -> f64 {
    (0..r.dof()).map(|k| model_mass(r, k)).sum()
}

fn load(tip: Option<&str>, fuse_beyond_tip: bool) -> ivdyn::error::Result<Robot> {
    Robot::from_urdf_with(urdf(), &UrdfOptions { base: None, tip: tip.map(Into::into), fuse_beyond_tip })
}

const ARM: [&str; 7] = ["link1", "link2", "link3", "link4", "link5", "link6", "link7"];
const SIDE: [&str; 2] = ["camera", "cable"];
const HAND: [&str; 4] = ["hand", "tcp", "left_finger", "right_finger"];

#[test]
fn tip_at_the_flange_drops_the_hand() {
    let r = load(Some("flange"), false).unwrap();
    assert_eq!(r.dof(), 7);
    assert_eq!(r.tip_link, "flange");
    let want_last = urdf_mass(&["link7", "flange"]);
    assert!((model_mass(&r, 6) - want_last).abs() < 1e-12, "link7 carries {} kg", model_mass(&r, 6));
    let want = urdf_mass(&ARM) + urdf_mass(&SIDE) + urdf_mass(&["flange"]);
    assert!((total_mass(&r) - want).abs() < 1e-12, "{} vs {want}", total_mass(&r));
    let mut dropped = r.dropped_links.clone();
    dropped.sort();
    let mut hand = HAND.to_vec();
    hand.sort();
    assert_eq!(dropped, hand);
    // the finger joints are dropped, not locked; the side branch's joint is locked
    assert_eq!(r.locked_joints, vec!["cable_joint".to_string()]);
    let notes = r.chain_notes().join("\n");
    assert!(notes.contains("not in the model") && notes.contains("left_finger"), "{notes}");
}

#[test]
fn fuse_beyond_tip_adds_the_hand_to_the_last_link() {
    let drop = load(Some("flange"), false).unwrap();
    let r = load(Some("flange"), true).unwrap();
    assert!(r.dropped_links.is_empty());
    let want_last = urdf_mass(&["link7", "flange"]) + urdf_mass(&HAND);
    assert!((model_mass(&r, 6) - want_last).abs() < 1e-12, "link7 carries {} kg", model_mass(&r, 6));
    let want = urdf_mass(&ARM) + urdf_mass(&SIDE) + urdf_mass(&["flange"]) + urdf_mass(&HAND);
    assert!((total_mass(&r) - want).abs() < 1e-12);
    // only the last link changes; the tool frame is the tip's either way
    let (a, b) = (drop.params(), r.params());
    assert_eq!(a[..link_col(6, 0)], b[..link_col(6, 0)]);
    assert_eq!(drop.mass_matrix(&[0.0; 7]).unwrap().len(), 49);
    let mut locked = r.locked_joints.clone();
    locked.sort();
    assert_eq!(locked, vec!["cable_joint", "finger_joint1", "finger_joint2"]);
    let fused: Vec<&str> = r.fused_links.iter().filter(|(_, k)| k == "link7").map(|(l, _)| l.as_str()).collect();
    for l in HAND {
        assert!(fused.contains(&l), "{l} not listed as fused into link7: {fused:?}");
    }
}

#[test]
fn side_branches_stay_fused() {
    for fuse in [false, true] {
        let r = load(Some("flange"), fuse).unwrap();
        assert!(r.fused_links.contains(&("camera".into(), "link3".into())), "{:?}", r.fused_links);
        assert!(r.fused_links.contains(&("cable".into(), "link5".into())), "{:?}", r.fused_links);
        let want = urdf_mass(&["link3", "camera"]);
        assert!((model_mass(&r, 2) - want).abs() < 1e-12);
    }
}

#[test]
fn a_tip_inside_the_arm_drops_the_rest_of_it() {
    // tip link5: the side branch on link5 (cable) is below the tip, so it goes too
    let r = load(Some("link5"), false).unwrap();
    assert_eq!(r.dof(), 5);
    assert!(r.dropped_links.contains(&"cable".to_string()) && r.dropped_links.contains(&"link7".to_string()));
    assert!(r.locked_joints.is_empty());
    assert!((model_mass(&r, 4) - urdf_mass(&["link5"])).abs() < 1e-12);
}

#[test]
fn without_a_tip_the_side_joint_branches() {
    // the default tip follows movable joints: cable_joint and j6 are two branches at link5
    let e = load(None, false).unwrap_err();
    assert!(matches!(e, ivdyn::Error::Branching { .. }), "{e}");
}

/// Without a tip, the default tip is the last link reached through movable joints; what is
/// rigidly attached below it (flange, hand, fingers, here on fixed joints) is fused, as
/// the arm carries it. Naming that link as the tip drops them.
#[test]
fn default_tip_fuses_the_rigid_tool() {
    let text = std::fs::read_to_string(urdf())
        .unwrap()
        .replace(r#"type="prismatic""#, r#"type="fixed""#)
        .replace(r#"name="cable_joint" type="revolute""#, r#"name="cable_joint" type="fixed""#);
    let file = std::path::Path::new("arm7_rigid_hand.urdf");
    let load = |tip: Option<&str>| ivdyn::robot::urdf::load_str(&text, file, None, tip).unwrap();
    let default = load(None);
    assert_eq!(default.tip_link, "link7");
    assert!(default.dropped_links.is_empty());
    let tool = ["flange", "hand", "tcp", "left_finger", "right_finger"];
    let want = urdf_mass(&["link7"]) + urdf_mass(&tool);
    assert!((model_mass(&default, 6) - want).abs() < 1e-12, "{} vs {want}", model_mass(&default, 6));
    let named = load(Some("link7"));
    assert_eq!(named.dropped_links.len(), tool.len());
    assert!((model_mass(&named, 6) - urdf_mass(&["link7"])).abs() < 1e-12);
}

/// A URDF written back from a robot that dropped the hand reloads to the same robot.
#[test]
fn write_back_keeps_the_dropped_hand_out() {
    let r = load(Some("flange"), false).unwrap();
    let text = std::fs::read_to_string(urdf()).unwrap();
    let wb = ivdyn::robot::write::write_back(&text, &urdf(), &r, Some(&r.params()), None, vec![]).unwrap();
    let back = ivdyn::robot::urdf::load_str(&wb.urdf, &urdf(), None, Some("flange")).unwrap();
    let (a, b) = (r.params(), back.params());
    let d = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(d < 1e-12, "{d}");
}
