//! URDF write-back: identify -> write URDF (+ side file) -> reload -> predict reproduces
//! the identified torques to 1e-9; the rest of the XML is kept; payloads as a link or merged.

use crate::scratch::ScratchFile;
use ivdyn::Robot;
use ivdyn::app::{self, IdentifyOptions, SimulateOptions, Trajectory};
use ivdyn::report::PayloadSpec;
use ivdyn::robot::load::side_path;
use ivdyn::robot::write::{PayloadMode, write_back, write_files};
use ivdyn_core::rng::Rng;
use std::path::Path;

const UR5: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
const PANDA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/panda.urdf");

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn_urdf_write", name)
}

/// Largest |tau_a - tau_b| over random states.
fn max_torque_diff(a: &Robot, b: &Robot) -> f64 {
    let n = a.dof();
    let mut rng = Rng::new(11);
    let mut worst = 0.0f64;
    for _ in 0..100 {
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let qdd: Vec<f64> = (0..n).map(|_| rng.uniform(-5.0, 5.0)).collect();
        let (ta, tb) = (a.rnea(&q, &qd, &qdd).unwrap(), b.rnea(&q, &qd, &qdd).unwrap());
        for j in 0..n {
            worst = worst.max((ta[j] - tb[j]).abs());
        }
    }
    worst
}

fn write_and_reload(
    input: &Path,
    robot: &Robot,
    theta: Option<&[f64]>,
    payload: Option<(&PayloadSpec, PayloadMode)>,
    out: &Path,
) -> Robot {
    let text = std::fs::read_to_string(input).unwrap();
    let wb = write_back(&text, input, robot, theta, payload, vec![]).unwrap();
    write_files(out, &wb).unwrap();
    assert!(side_path(out).exists());
    Robot::from_urdf(out, Some(&robot.base_link), Some(&robot.tip_link)).unwrap()
}

/// Lines of the input that must survive unchanged (everything but inertials and dynamics).
fn kept_lines(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| {
            l.contains("<visual")
                || l.contains("<collision")
                || l.contains("<!--")
                || l.contains("gazebo")
                || l.contains("<limit")
                || l.contains("<origin rpy") && !l.contains("rpy=\"0 0 0\" xyz")
        })
        .collect()
}

#[test]
fn identify_write_reload_reproduces_the_identified_torques() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let sim = SimulateOptions {
        duration_s: 10.0,
        rate_hz: 200.0,
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        noise_tau: 0.05,
        ..Default::default()
    };
    let log = app::simulate(&robot, &Trajectory::Fourier, &sim).unwrap();
    let rep = app::identify(&robot, &log, &IdentifyOptions { consistent: true, ..Default::default() }).unwrap();
    let c = rep.consistent.as_ref().unwrap();
    assert!(c.result.check.consistent, "{:?}", c.result.check.lines());
    for (what, theta) in [("consistent", &c.params.theta), ("least squares", &rep.params.theta)] {
        let mut identified = robot.clone();
        identified.set_params(theta).unwrap();
        let out = tmp(&format!("ur5_{}.urdf", what.replace(' ', "_")));
        let back = write_and_reload(Path::new(UR5), &robot, Some(theta), None, &out);
        let d = max_torque_diff(&identified, &back);
        assert!(d < 1e-9, "{what}: reloaded model differs by {d:e} N m");
        let p = back.params();
        for (k, (a, b)) in p.iter().zip(theta.iter()).enumerate() {
            assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{what}: parameter {k}: {a} vs {b}");
        }
        // everything else in the file is kept
        let (orig, new) = (std::fs::read_to_string(UR5).unwrap(), std::fs::read_to_string(&out).unwrap());
        assert_eq!(kept_lines(&orig), kept_lines(&new));
        assert_eq!(orig.lines().count(), new.lines().count());
    }
}

#[test]
fn payload_as_link_or_merged_reloads_to_the_loaded_arm() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let spec =
        PayloadSpec { mass: 2.0, com: [0.01, -0.02, 0.05], inertia: [0.003, 0.0001, 0.004, -0.0002, 0.0003, 0.002] }; // ivdyn order
    let truth = app::true_robot(&robot, &SimulateOptions { payload: Some(spec), ..Default::default() }).unwrap();
    for mode in [PayloadMode::Link, PayloadMode::Merge] {
        let out = tmp(&format!("ur5_payload_{mode:?}.urdf"));
        let back = write_and_reload(Path::new(UR5), &robot, None, Some((&spec, mode)), &out);
        let d = max_torque_diff(&truth, &back);
        assert!(d < 1e-9, "{mode:?}: {d:e}");
        let text = std::fs::read_to_string(&out).unwrap();
        assert_eq!(text.contains("<link name=\"ivdyn_payload\">"), mode == PayloadMode::Link);
    }
}

#[test]
fn fused_links_keep_their_inertials_on_the_panda() {
    // Panda to its hand: link7 carries link8, the hand and the (locked) fingers
    let robot = Robot::from_urdf(PANDA, Some("panda_link0"), Some("panda_hand")).unwrap();
    let n = robot.dof();
    let mut theta = robot.params();
    for k in 0..10 {
        theta[60 + k] *= 1.07; // link7 segment 7 % heavier (still consistent)
    }
    for j in 0..n {
        theta[70 + 4 * j] = 0.3; // fc
        theta[70 + 4 * j + 1] = 0.2; // fv
        theta[70 + 4 * j + 2] = 0.01 * (j + 1) as f64; // ia
        theta[70 + 4 * j + 3] = -0.05; // tau0
    }
    let mut identified = robot.clone();
    identified.set_params(&theta).unwrap();
    let out = tmp("panda.urdf");
    let back = write_and_reload(Path::new(PANDA), &robot, Some(&theta), None, &out);
    let d = max_torque_diff(&identified, &back);
    assert!(d < 1e-9, "{d:e}");
    // the hand and finger inertials are untouched
    let text = std::fs::read_to_string(&out).unwrap();
    let orig = std::fs::read_to_string(PANDA).unwrap();
    let hand =
        |t: &str| t.split("<link name=\"panda_hand\">").nth(1).unwrap().split("</link>").next().unwrap().to_string();
    assert_eq!(hand(&text), hand(&orig));
    // without the side file the armature and offsets are missing (so it is needed)
    let no_side = ivdyn::robot::urdf::load(&out, Some("panda_link0"), Some("panda_hand")).unwrap();
    assert!(max_torque_diff(&identified, &no_side) > 1e-3);
}
