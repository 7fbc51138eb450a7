//! One inertia order in the API (ivdyn's `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`, that of the
//! 10-vector), URDF attribute order `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` in files, and the
//! explicit conversions between them. Every inertia here is asymmetric (Iyy != Ixz), so a
//! swapped order anywhere fails.

use crate::scratch::ScratchFile;
use ivdyn::Robot;
use ivdyn::core::{
    INERTIA_ORDER, INERTIA_URDF_ORDER, inertia_from_urdf, inertia_matrix, inertia_to_urdf, inertia_vector,
};
use ivdyn::report::PayloadSpec;

/// URDF attribute values ixx, ixy, ixz, iyy, iyz, izz of a body (positive definite).
const URDF_ATTRS: [f64; 6] = [0.04, 0.002, -0.003, 0.05, 0.001, 0.03];

/// A one-joint arm whose link has its COM at the joint origin and the inertia above.
fn one_link_urdf() -> ScratchFile {
    let [ixx, ixy, ixz, iyy, iyz, izz] = URDF_ATTRS;
    let text = format!(
        r#"<robot name="one"><link name="base"/>
<link name="arm"><inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="2"/>
<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/></inertial></link>
<joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
<limit lower="-3" upper="3" effort="10" velocity="1"/></joint></robot>"#
    );
    let p = ScratchFile::new("ivdyn_inertia_order", "one.urdf");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn the_urdf_loader_and_the_conversion_agree() {
    // the URDF reader takes each attribute by name: the parameters' inertia entries are the
    // attributes in ivdyn's order, which is what inertia_from_urdf gives
    let robot = Robot::from_urdf(one_link_urdf(), None, None).unwrap();
    let names = robot.param_names();
    let theta = robot.params();
    for (k, name) in INERTIA_ORDER.iter().enumerate() {
        assert_eq!(names[4 + k], format!("arm.{name}"));
        let u = INERTIA_URDF_ORDER.iter().position(|n| n == name).unwrap();
        assert_eq!(theta[4 + k], URDF_ATTRS[u], "{name}");
    }
    assert_eq!(&theta[4..10], &inertia_from_urdf(URDF_ATTRS)[..]);
    assert_eq!(inertia_to_urdf(inertia_from_urdf(URDF_ATTRS)), URDF_ATTRS);
}

#[test]
fn the_tensor_of_a_six_vector() {
    let i = inertia_from_urdf(URDF_ATTRS);
    let m = inertia_matrix(&i);
    // rows of the tensor as the URDF attributes name them
    let [ixx, ixy, ixz, iyy, iyz, izz] = URDF_ATTRS;
    let want = nalgebra::Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz);
    assert_eq!(m, want);
    assert_eq!(inertia_vector(&m), i);
}

#[test]
fn a_payload_spec_is_ivdyn_order_in_memory_and_urdf_order_in_json() {
    let spec = PayloadSpec { mass: 2.0, com: [0.01, -0.02, 0.05], inertia: inertia_from_urdf(URDF_ATTRS) };
    let v = serde_json::to_value(spec).unwrap();
    let written: Vec<f64> = v["inertia"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert_eq!(written, URDF_ATTRS.to_vec());
    let back: PayloadSpec = serde_json::from_value(v).unwrap();
    assert_eq!(back, spec);
    // its 10 parameters about the link origin: COM offset by the parallel-axis theorem,
    // inertia entries in the 10-vector's order
    let p = spec.link_inertia().0;
    let (m, c) = (spec.mass, spec.com);
    let i = spec.inertia;
    let want = [
        m,
        m * c[0],
        m * c[1],
        m * c[2],
        i[0] + m * (c[1] * c[1] + c[2] * c[2]),
        i[1] - m * c[0] * c[1],
        i[2] + m * (c[0] * c[0] + c[2] * c[2]),
        i[3] - m * c[0] * c[2],
        i[4] - m * c[1] * c[2],
        i[5] + m * (c[0] * c[0] + c[1] * c[1]),
    ];
    for k in 0..10 {
        assert!((p[k] - want[k]).abs() < 1e-15, "{k}: {} vs {}", p[k], want[k]);
    }
}
