//! What CAD exports and hand-edited URDFs hold. Files that urdfdom (ROS's parser) reads and
//! urdf-rs refuses load as urdfdom reads them: a `<texture />` without a file name, as CAD
//! exporters write it, inside a link's `<visual>` and in a top-level `<material>`. The
//! appearance carries no dynamics, so the robot is the one of the same file without it; the
//! masses are checked against the file's own `<mass>`. A link whose inertials no body has is
//! noted by name; a point mass (zero inertia about its COM, a rigid body's limit) is not.

use std::path::PathBuf;

use ivdyn::Robot;
use ivdyn::core::params::{M, link_col};
use ivdyn::robot::urdf::{UrdfOptions, load_str_with};

fn arm7() -> (PathBuf, String) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/arm7_hand.urdf");
    let text = std::fs::read_to_string(&p).unwrap();
    (p, text)
}

/// arm7_hand.urdf with a textured visual on link3 and a top-level textured material.
fn with_textures(text: &str) -> String {
    let visual = r#"<visual><geometry><mesh filename="package://arm/link3.stl"/></geometry><material name="grey"><color rgba="0.5 0.5 0.5 1"/><texture /></material></visual>"#;
    let t = text.replacen("<link name=\"link3\">", &format!("<link name=\"link3\">{visual}"), 1);
    t.replacen("<link ", "<material name=\"metal\"><texture/></material>\n  <link ", 1)
}

#[test]
fn texture_without_file_loads_as_urdfdom_reads_it() {
    let (p, text) = arm7();
    let textured = with_textures(&text);
    assert!(urdf_rs::read_from_string(&textured).is_err(), "urdf-rs alone would refuse it");
    let opts = UrdfOptions::new(None, Some("flange"));
    let r = load_str_with(&textured, &p, &opts).unwrap();
    let plain = Robot::from_urdf_with(&p, &opts).unwrap();
    assert_eq!(r.joint_names, plain.joint_names);
    assert_eq!(r.params(), plain.params());
    let u = urdf_rs::read_file(&p).unwrap();
    let mass = |l: &str| u.links.iter().find(|x| x.name == l).unwrap().inertial.mass.value;
    // the last link carries link7 and the flange fused to it (the hand beyond the tip dropped)
    let last = r.params()[link_col(6, M)];
    assert!((last - mass("link7") - mass("flange")).abs() < 1e-12, "{last}");
}

/// A file refused for another reason beside a texture gets the error of that reason (not the
/// texture's, which is forgiven), with where the attribute urdf-rs names as missing is (here
/// `<mass/>` of link3: line 24 of arm7_hand.urdf, 25 with the material inserted above it).
#[test]
fn a_broken_file_says_what_is_beyond_the_texture() {
    let (p, text) = arm7();
    let broken = with_textures(&text).replacen("<mass value=\"2.2\"/>", "<mass/>", 1);
    let e = load_str_with(&broken, &p, &UrdfOptions::default()).unwrap_err().to_string();
    assert!(e.contains("arm7_hand.urdf") && e.contains("cannot parse URDF"), "{e}");
    // urdf-rs names the attribute; where it is missing is found in the text
    assert!(e.contains("`<mass>` of link 'link3' (line 25) has no `value` attribute"), "{e}");
}

/// A xacro file (not expanded) is refused with a parse error that says to expand it.
#[test]
fn an_unexpanded_xacro_says_so() {
    let (p, text) = arm7();
    let xacro = text.replacen("<mass value=\"2.2\"/>", "<mass value=\"${m3}\"/>", 1);
    let e = load_str_with(&xacro, &p, &UrdfOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cannot parse URDF") && e.contains("xacro robot.urdf.xacro > robot.urdf"), "{e}");
}

/// arm7_hand.urdf with link3's `<inertia>` replaced.
fn link3_inertia(text: &str, inertia: &str) -> String {
    let old = r#"<inertia ixx="0.015" ixy="0.002" ixz="0.001" iyy="0.013" iyz="-0.001" izz="0.008"/>"#;
    assert!(text.contains(old));
    text.replacen(old, inertia, 1)
}

fn notes_of(text: &str) -> String {
    let (p, _) = arm7();
    load_str_with(text, &p, &UrdfOptions::new(None, Some("flange"))).unwrap().chain_notes().join("\n")
}

#[test]
fn links_no_body_has_are_noted() {
    let (_, text) = arm7();
    assert!(!notes_of(&text).contains("no rigid body"), "{}", notes_of(&text));
    // a negative principal moment
    let neg =
        notes_of(&link3_inertia(&text, r#"<inertia ixx="-0.01" ixy="0" ixz="0" iyy="0.013" iyz="0" izz="0.008"/>"#));
    assert!(neg.contains("link 'link3' is no rigid body") && neg.contains("not positive definite"), "{neg}");
    // 0.013 + 0.008 < 0.05: the triangle inequality of the principal moments broken
    let tri =
        notes_of(&link3_inertia(&text, r#"<inertia ixx="0.05" ixy="0" ixz="0" iyy="0.013" iyz="0" izz="0.008"/>"#));
    assert!(tri.contains("link 'link3' is no rigid body") && tri.contains("triangle inequality"), "{tri}");
    // a point mass is a rigid body's limit
    let point = notes_of(&link3_inertia(&text, r#"<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>"#));
    assert!(!point.contains("no rigid body"), "{point}");
}
