//! Bad input fails with a message naming the problem, never a panic.

use ivdyn::{Error, Robot, robot::urdf::load_str};
use std::path::Path;

fn link(name: &str) -> String {
    format!(
        r#"<link name="{name}"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>"#
    )
}

fn joint(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/>{extra}</joint>"#
    )
}

fn urdf(body: &[String]) -> String {
    format!(r#"<?xml version="1.0"?><robot name="t">{}</robot>"#, body.concat())
}

fn err(text: &str, base: Option<&str>, tip: Option<&str>) -> String {
    match load_str(text, Path::new("arm.urdf"), base, tip) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn floating_and_planar_joints_are_named() {
    for kind in ["floating", "planar"] {
        let t = urdf(&[
            link("a"),
            link("b"),
            link("c"),
            joint("j1", "revolute", "a", "b", ""),
            joint("free", kind, "b", "c", ""),
        ]);
        let msg = err(&t, None, Some("c"));
        assert!(msg.contains("'free'") && msg.contains(kind) && msg.contains("arm.urdf"), "{msg}");
    }
}

#[test]
fn mimic_joint_on_the_chain_is_named() {
    let t = urdf(&[
        link("a"),
        link("b"),
        link("c"),
        joint("j1", "revolute", "a", "b", ""),
        joint("j2", "revolute", "b", "c", r#"<mimic joint="j1" multiplier="1" offset="0"/>"#),
    ]);
    let msg = err(&t, None, None);
    assert!(msg.contains("'j2'") && msg.contains("mimic"), "{msg}");
}

#[test]
fn branching_without_tip_names_the_branches_and_a_tip_resolves_it() {
    let t = urdf(&[
        link("a"),
        link("b"),
        link("l"),
        link("r"),
        joint("j1", "revolute", "a", "b", ""),
        joint("left", "revolute", "b", "l", ""),
        joint("right", "prismatic", "b", "r", ""),
    ]);
    let msg = err(&t, None, None);
    assert!(msg.contains("'b'") && msg.contains("'left'") && msg.contains("'right'"), "{msg}");
    let r = load_str(&t, Path::new("arm.urdf"), None, Some("l")).unwrap();
    assert_eq!(r.joint_names, ["j1", "left"]);
    assert_eq!(r.locked_joints, ["right"]);
}

#[test]
fn unknown_links_and_bad_structure() {
    let t = urdf(&[link("a"), link("b"), joint("j1", "revolute", "a", "b", "")]);
    let msg = err(&t, None, Some("nope"));
    assert!(msg.contains("'nope'") && msg.contains("a, b"), "{msg}");
    let msg = err(&t, Some("b"), Some("a"));
    assert!(msg.contains("not below"), "{msg}");
    let t = urdf(&[link("a"), link("b"), joint("j1", "revolute", "a", "ghost", "")]);
    assert!(err(&t, None, None).contains("'ghost'"));
    let t = urdf(&[link("a"), link("b"), joint("j1", "fixed", "a", "b", "")]);
    assert!(err(&t, None, None).contains("no movable joint"));
}

#[test]
fn zero_axis_is_named() {
    let t = urdf(&[link("a"), link("b"), joint("j1", "revolute", "a", "b", "")])
        .replace(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="0 0 0"/>"#);
    let msg = err(&t, None, None);
    assert!(msg.contains("'j1'") && msg.contains("axis"), "{msg}");
}

#[test]
fn unparsable_and_missing_files() {
    let msg = err("<robot name='x'><link name='a'></robot>", None, None);
    assert!(msg.contains("arm.urdf") && msg.contains("cannot parse"), "{msg}");
    let e = Robot::from_urdf("/nonexistent/robot.urdf", None, None).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/robot.urdf"), "{e}");
}

#[test]
fn wrong_length_and_non_finite_inputs_are_errors() {
    let r = Robot::paper();
    let e = r.rnea(&[0.0; 5], &[0.0; 6], &[0.0; 6]).unwrap_err();
    assert!(matches!(e, Error::Dimension { expected: 6, got: 5, .. }), "{e}");
    assert!(e.to_string().contains("q"), "{e}");
    let mut qd = [0.0; 6];
    qd[3] = f64::NAN;
    let e = r.rnea(&[0.0; 6], &qd, &[0.0; 6]).unwrap_err();
    assert_eq!(e.to_string(), "non-finite value in qd[3]");
    let mut theta = r.params();
    theta[7] = f64::INFINITY;
    let mut r2 = r.clone();
    assert!(r2.set_params(&theta).unwrap_err().to_string().contains("theta[7]"));
    assert!(r2.set_params(&theta[..10]).is_err());
}

#[test]
fn fixed_joints_fuse_and_continuous_joints_are_unlimited() {
    let t = urdf(&[
        link("a"),
        link("b"),
        link("c"),
        link("tool"),
        joint("j1", "continuous", "a", "b", ""),
        joint("mid", "fixed", "b", "c", ""),
        joint("tool_joint", "fixed", "c", "tool", ""),
    ]);
    let r = load_str(&t, Path::new("arm.urdf"), None, None).unwrap();
    assert_eq!(r.dof(), 1);
    assert_eq!(r.tip_link, "b"); // no movable joint beyond b: default tip stops there
    let theta = r.params();
    // b, c and tool fused: 3 kg on link b
    assert!((theta[0] - 3.0).abs() < 1e-12);
    let r = load_str(&t, Path::new("arm.urdf"), None, Some("tool")).unwrap();
    assert_eq!(r.tip_link, "tool");
    ivdyn::with_model!(&r.model, m => {
        assert!((m.tool.trans.z - 0.2).abs() < 1e-12);
        assert!(m.limits[0].lower.is_infinite());
    });
}
