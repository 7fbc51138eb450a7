//! ivdyn against the fixtures: Pinocchio's values (and the NumPy reference's, for the
//! drive terms) on UR5, the Panda arm, the paper's robot and a loader-exercising test
//! arm. The fixtures come from `python/reference/gen_fixtures.py`; see
//! `fixtures/MANIFEST.md`.

use ivdyn::Robot;
use ivdyn::robot::urdf::UrdfOptions;
use serde_json::Value;
use std::path::PathBuf;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn vecf(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn matf(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().flat_map(vecf).collect()
}

/// |a - b| / max(|b|, 1) in the 2-norm, as the fixture generator measured it.
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
    let n: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    d / n.max(1.0)
}

const TOL: f64 = 1e-10;

fn load(name: &str) -> (Robot, Value) {
    let text = std::fs::read_to_string(fixtures().join(format!("dyn_{name}.json"))).unwrap();
    let fx: Value = serde_json::from_str(&text).unwrap();
    let m = &fx["model"];
    let robot = match m["kind"].as_str().unwrap() {
        "urdf" => {
            // Pinocchio's reduced model (the fixtures) locks every joint off the chain,
            // the ones below the tip too (the Panda's fingers): fuse them likewise
            let opts = UrdfOptions {
                base: m["base"].as_str().map(Into::into),
                tip: m["tip"].as_str().map(Into::into),
                fuse_beyond_tip: true,
            };
            let r = Robot::from_urdf_with(fixtures().join(m["file"].as_str().unwrap()), &opts).unwrap();
            let locked: Vec<String> =
                m["locked_joints"].as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect();
            let mut got = r.locked_joints.clone();
            got.sort();
            let mut want = locked.clone();
            want.sort();
            assert_eq!(got, want, "{name}: locked joints");
            r
        }
        "dh" => Robot::paper(),
        k => panic!("unknown model kind {k}"),
    };
    let names: Vec<&str> = fx["joint_names"].as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect();
    if m["kind"] == "urdf" {
        assert_eq!(robot.joint_names, names, "{name}: joint order");
    }
    (robot, fx)
}

fn check(name: &str) {
    let (mut robot, fx) = load(name);
    let n = robot.dof();
    let theta = vecf(&fx["theta"]);
    assert_eq!(theta.len(), 14 * n);
    // the loaded inertial parameters are Pinocchio's (the fixture's theta holds them;
    // its drive block is the generator's random choice, or Table 2's F for the paper)
    let own = robot.params();
    let e = rel(&own[..10 * n], &theta[..10 * n]);
    assert!(e < 1e-12, "{name}: inertial parameters from the loader differ from Pinocchio's: {e:e}");
    robot.set_params(&theta).unwrap();
    let mut rigid = robot.clone();
    let mut theta_rigid = theta.clone();
    theta_rigid[10 * n..].fill(0.0);
    rigid.set_params(&theta_rigid).unwrap();

    let mut worst = [0.0f64; 9];
    for (k, s) in fx["samples"].as_array().unwrap().iter().enumerate() {
        let (q, qd, qdd) = (vecf(&s["q"]), vecf(&s["qd"]), vecf(&s["qdd"]));
        let mut upd = |i: usize, e: f64, what: &str| {
            assert!(e <= TOL, "{name} sample {k}: {what} rel error {e:e}");
            worst[i] = worst[i].max(e);
        };
        upd(0, rel(&robot.rnea(&q, &qd, &qdd).unwrap(), &vecf(&s["tau"])), "tau");
        upd(1, rel(&rigid.rnea(&q, &qd, &qdd).unwrap(), &vecf(&s["tau_rigid"])), "tau_rigid (Pinocchio)");
        let y = robot.regressor(&q, &qd, &qdd).unwrap();
        upd(2, rel(&y, &matf(&s["Y"])), "Y");
        let y_rigid: Vec<f64> = y.chunks(14 * n).flat_map(|r| r[..10 * n].to_vec()).collect();
        upd(3, rel(&y_rigid, &matf(&s["Y_rigid"])), "Y_rigid (Pinocchio)");
        upd(4, rel(&robot.mass_matrix(&q).unwrap(), &matf(&s["M"])), "M");
        upd(5, rel(&rigid.mass_matrix(&q).unwrap(), &matf(&s["M_rigid"])), "M_rigid (Pinocchio)");
        upd(6, rel(&robot.gravity(&q).unwrap(), &vecf(&s["g"])), "g (Pinocchio)");
        let tau_fd = vecf(&s["tau_fd"]);
        upd(7, rel(&robot.forward_dynamics(&q, &qd, &tau_fd).unwrap(), &vecf(&s["qdd_fd"])), "qdd_fd");
        upd(
            8,
            rel(&rigid.forward_dynamics(&q, &qd, &tau_fd).unwrap(), &vecf(&s["qdd_fd_rigid"])),
            "qdd_fd_rigid (Pinocchio aba)",
        );
    }
    eprintln!(
        "{name}: worst rel errors tau {:.1e} tau_rigid {:.1e} Y {:.1e} Y_rigid {:.1e} M {:.1e} M_rigid {:.1e} g {:.1e} fd {:.1e} fd_rigid {:.1e}",
        worst[0], worst[1], worst[2], worst[3], worst[4], worst[5], worst[6], worst[7], worst[8]
    );
}

fn check_energy(name: &str) {
    use ivdyn_core::energy::{kinetic_energy, potential_energy};
    let (mut robot, fx) = load(name);
    let n = robot.dof();
    let mut theta = vecf(&fx["theta"]);
    theta[10 * n..].fill(0.0);
    robot.set_params(&theta).unwrap();
    for s in fx["samples"].as_array().unwrap() {
        let (q, qd) = (vecf(&s["q"]), vecf(&s["qd"]));
        let (ke, pe) = ivdyn::with_model!(&robot.model, m => {
            let mut data = ivdyn_core::Data::new();
            let qv = ivdyn_core::nalgebra::SVector::from_column_slice(&q);
            let qdv = ivdyn_core::nalgebra::SVector::from_column_slice(&qd);
            (kinetic_energy(&**m, &mut data, &qv, &qdv), potential_energy(&**m, &mut data, &qv))
        });
        assert!(rel(&[ke], &[s["kinetic_energy"].as_f64().unwrap()]) < TOL, "{name}: kinetic energy");
        assert!(rel(&[pe], &[s["potential_energy"].as_f64().unwrap()]) < TOL, "{name}: potential energy");
    }
}

#[test]
fn ur5() {
    check("ur5");
    check_energy("ur5");
}

#[test]
fn panda7() {
    check("panda7");
    check_energy("panda7");
}

#[test]
fn paper_robot() {
    check("paper");
    check_energy("paper");
}

#[test]
fn test_arm_urdf_features() {
    check("test_arm");
    check_energy("test_arm");
}
