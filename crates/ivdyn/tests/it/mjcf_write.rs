//! MJCF export (`ivdyn::robot::mjcf`): the XML is well formed (every element closed, names
//! escaped), one body per link nested base to tip, and reading the bodies' placements,
//! inertials and joints back gives the robot's parameters; impossible inertials and drive
//! parameters are refused with the link's (joint's, payload's) name; a payload is a welded
//! body in the last link. MuJoCo itself loads the file in python/tests_io/test_mjcf_export.py.

use crate::scratch::Scratch;
use std::collections::HashMap;

use ivdyn::Robot;
use ivdyn::report::PayloadSpec;
use ivdyn::robot::load::side_path;
use ivdyn::robot::mjcf::{to_mjcf, write_files};
use ivdyn_core::params::{FC, FV, IA, LINK_PARAMS, drive_col, link_col};
use ivdyn_core::{LinkInertia, Mat3, Transform, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};
use quick_xml::Reader;
use quick_xml::events::Event;

const UR5: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");

fn ur5() -> Robot {
    Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap()
}

/// An element: tag, attributes, names of the enclosing `<body>` elements.
struct Elem {
    tag: String,
    attrs: HashMap<String, String>,
    bodies: Vec<String>,
}

/// Every element of `xml`, parsed by quick-xml with end-name checks (panics on malformed XML).
fn elements(xml: &str) -> Vec<Elem> {
    let mut r = Reader::from_str(xml);
    let mut out = vec![];
    let mut bodies: Vec<String> = vec![];
    let mut stack: Vec<String> = vec![];
    loop {
        let ev = r.read_event().expect("well-formed XML");
        let (e, open) = match &ev {
            Event::Start(e) => (e, true),
            Event::Empty(e) => (e, false),
            Event::End(e) => {
                let tag = String::from_utf8(e.local_name().as_ref().to_vec()).unwrap();
                assert_eq!(stack.pop().as_deref(), Some(tag.as_str()));
                if tag == "body" {
                    bodies.pop();
                }
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        let tag = String::from_utf8(e.local_name().as_ref().to_vec()).unwrap();
        let attrs: HashMap<String, String> = e
            .attributes()
            .map(|a| {
                let a = a.unwrap();
                (String::from_utf8(a.key.as_ref().to_vec()).unwrap(), a.unescape_value().unwrap().into_owned())
            })
            .collect();
        out.push(Elem { tag: tag.clone(), attrs: attrs.clone(), bodies: bodies.clone() });
        if open {
            if tag == "body" {
                bodies.push(attrs["name"].clone());
            }
            stack.push(tag);
        }
    }
    assert!(stack.is_empty(), "unclosed elements {stack:?}");
    out
}

fn floats(s: &str) -> Vec<f64> {
    s.split_whitespace().map(|x| x.parse().unwrap()).collect()
}

/// The 10 parameters of an MJCF `<inertial pos mass fullinertia>` in the body frame.
fn inertial_params(a: &HashMap<String, String>) -> [f64; LINK_PARAMS] {
    let (c, m, fi) = (floats(&a["pos"]), floats(&a["mass"])[0], floats(&a["fullinertia"]));
    // fullinertia = Ixx Iyy Izz Ixy Ixz Iyz about the COM
    let ic = Mat3::new(fi[0], fi[3], fi[4], fi[3], fi[1], fi[5], fi[4], fi[5], fi[2]);
    LinkInertia::from_mass_com_inertia(m, &Vec3::new(c[0], c[1], c[2]), &Mat3::identity(), &ic).0
}

fn placement(a: &HashMap<String, String>) -> Transform {
    let (p, q) = (floats(&a["pos"]), floats(&a["quat"]));
    let rot = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix();
    Transform::new(*rot.matrix(), Vec3::new(p[0], p[1], p[2]))
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn bodies_joints_and_inertials_read_back_as_the_robot() {
    let mut robot = ur5();
    let n = robot.dof();
    let mut theta = robot.params();
    for j in 0..n {
        theta[drive_col(n, j, FC)] = 0.5 + j as f64;
        theta[drive_col(n, j, FV)] = 0.25 * (j + 1) as f64;
        theta[drive_col(n, j, IA)] = 0.01 * (j + 1) as f64;
    }
    robot.set_params(&theta).unwrap();
    let mj = to_mjcf(&robot, None, vec!["a note with -- dashes".into()]).unwrap();
    let els = elements(&mj.xml);
    let chain = robot.model.to_chain();
    let bodies: Vec<&Elem> = els.iter().filter(|e| e.tag == "body").collect();
    assert_eq!(bodies.len(), n);
    for (k, b) in bodies.iter().enumerate() {
        // nested base to tip: link k's parents are links 0..k
        assert_eq!(b.attrs["name"], robot.link_names[k]);
        assert_eq!(b.bodies, robot.link_names[..k].to_vec());
        let x = placement(&b.attrs);
        assert!((x.trans - chain.x_tree[k].trans).norm() < 1e-15);
        assert!((x.rot - chain.x_tree[k].rot).norm() < 1e-14, "link {k}");
        let inertial: Vec<&Elem> =
            els.iter().filter(|e| e.tag == "inertial" && e.bodies.last() == Some(&robot.link_names[k])).collect();
        let p = inertial_params(&inertial[0].attrs);
        for c in 0..LINK_PARAMS {
            assert!(
                close(p[c], theta[link_col(k, c)], 1e-12),
                "link {k} param {c}: {} vs {}",
                p[c],
                theta[link_col(k, c)]
            );
        }
        let j = els.iter().find(|e| e.tag == "joint" && e.bodies.last() == Some(&robot.link_names[k])).unwrap();
        assert_eq!(j.attrs["name"], robot.joint_names[k]);
        assert_eq!(j.attrs["type"], "hinge");
        let axis = floats(&j.attrs["axis"]);
        assert_eq!(axis, chain.joints[k].axis.as_slice());
        // drive values exactly (shortest round-trip numbers)
        assert_eq!(floats(&j.attrs["frictionloss"])[0], theta[drive_col(n, k, FC)]);
        assert_eq!(floats(&j.attrs["damping"])[0], theta[drive_col(n, k, FV)]);
        assert_eq!(floats(&j.attrs["armature"])[0], theta[drive_col(n, k, IA)]);
        assert_eq!(floats(&j.attrs["range"]), vec![chain.limits[k].lower, chain.limits[k].upper]);
    }
    let opt = els.iter().find(|e| e.tag == "option").unwrap();
    assert_eq!(floats(&opt.attrs["gravity"]), chain.gravity.as_slice());
    let motors: Vec<&str> = els.iter().filter(|e| e.tag == "motor").map(|e| e.attrs["joint"].as_str()).collect();
    assert_eq!(motors, robot.joint_names);
    // the torque offsets and the note reach the side file
    assert_eq!(mj.side.joints, robot.joint_names);
    assert!(mj.side.notes.iter().any(|s| s.starts_with("torque offsets")));
    assert!(mj.xml.contains("a note with - - dashes"));
}

#[test]
fn names_are_escaped_and_files_written_with_the_side_file() {
    let mut robot = Robot::paper();
    robot.name = "arm <\"&\"> 1".into();
    robot.link_names[0] = "l&1".into();
    let mj = to_mjcf(&robot, None, vec![]).unwrap();
    let els = elements(&mj.xml);
    assert_eq!(els[0].attrs["model"], "arm <\"&\"> 1");
    assert!(els.iter().any(|e| e.tag == "body" && e.attrs["name"] == "l&1"));
    let dir = Scratch::new("ivdyn_mjcf");
    let out = dir.join("paper.xml");
    write_files(&out, &mj).unwrap();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), mj.xml);
    assert!(side_path(&out).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

fn refusal(robot: &Robot, payload: Option<&PayloadSpec>) -> String {
    to_mjcf(robot, payload, vec![]).expect_err("must refuse").to_string()
}

#[test]
fn impossible_inertials_and_drives_are_refused_naming_them() {
    let base = ur5();
    let n = base.dof();
    let k = 2; // forearm_link
    // negative mass
    let mut r = base.clone();
    let mut th = r.params();
    th[link_col(k, 0)] = -1.0;
    r.set_params(&th).unwrap();
    let e = refusal(&r, None);
    assert!(e.contains("link 'forearm_link'") && e.contains("mass"), "{e}");
    // positive mass, inertia about the COM diag(1, 1, 3): the triangle inequality fails
    let mut r = base.clone();
    let mut th = r.params();
    let li = LinkInertia::from_mass_com_inertia(
        2.0,
        &Vec3::zeros(),
        &Mat3::identity(),
        &Mat3::from_diagonal(&Vec3::new(1.0, 1.0, 3.0)),
    );
    th[link_col(k, 0)..link_col(k, LINK_PARAMS)].copy_from_slice(&li.0);
    r.set_params(&th).unwrap();
    let e = refusal(&r, None);
    assert!(e.contains("link 'forearm_link'") && e.contains("triangle"), "{e}");
    // negative Coulomb friction
    let mut r = base.clone();
    let mut th = r.params();
    th[drive_col(n, 4, FC)] = -0.1;
    r.set_params(&th).unwrap();
    let e = refusal(&r, None);
    assert!(e.contains("wrist_2_joint") && e.contains("Coulomb"), "{e}");
    // a payload whose inertia is not a body's (a negative principal moment)
    let bad = PayloadSpec { mass: 1.0, com: [0.0, 0.0, 0.05], inertia: [1e-3, 0.0, 1e-3, 0.0, 0.0, -1e-4] };
    let e = refusal(&base, Some(&bad));
    assert!(e.contains("payload 'ivdyn_payload'"), "{e}");
}

#[test]
fn payload_is_a_welded_body_in_the_last_link() {
    let robot = ur5();
    // inertia in ivdyn's order [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
    let p = PayloadSpec { mass: 2.0, com: [0.01, -0.02, 0.05], inertia: [2e-3, 1e-4, 3e-3, 0.0, 0.0, 4e-3] };
    let mj = to_mjcf(&robot, Some(&p), vec![]).unwrap();
    let els = elements(&mj.xml);
    let body = els.iter().find(|e| e.tag == "body" && e.attrs["name"] == "ivdyn_payload").unwrap();
    assert_eq!(body.bodies.last(), robot.link_names.last());
    // no joint inside: welded
    assert!(!els.iter().any(|e| e.tag == "joint" && e.bodies.last().map(String::as_str) == Some("ivdyn_payload")));
    let inertial = els
        .iter()
        .find(|e| e.tag == "inertial" && e.bodies.last().map(String::as_str) == Some("ivdyn_payload"))
        .unwrap();
    let got = inertial_params(&inertial.attrs);
    let ic = &p.inertia;
    let i_c = Mat3::new(ic[0], ic[1], ic[3], ic[1], ic[2], ic[4], ic[3], ic[4], ic[5]);
    let want = LinkInertia::from_mass_com_inertia(p.mass, &Vec3::from(p.com), &Mat3::identity(), &i_c).0;
    for c in 0..LINK_PARAMS {
        assert!(close(got[c], want[c], 1e-12), "payload param {c}: {} vs {}", got[c], want[c]);
    }
    assert_eq!(mj.side.payload, Some(p));
}
