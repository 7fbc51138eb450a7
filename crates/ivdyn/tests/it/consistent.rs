//! Physical consistency: the checks in words, the log-Cholesky map, and the fit with
//! consistency enforced on exact (noise-free) UR5 data: it recovers a valid robot's base
//! parameters, and turns data from an invalid "robot" into parameters whose pseudo-inertias
//! are positive definite (eigenvalues computed here, independently of the module).

use ivdyn::Robot;
use ivdyn::ident::consistent::{ConsistentOptions, fit_consistent, link_from_log_cholesky, log_cholesky_from_link};
use ivdyn::ident::{LsAccumulator, fit_ls, robot_base_params};
use ivdyn::robot::physical::{check_link, check_robot_params};
use ivdyn_core::params::{FC, FV, IA, TAU0, drive_col, link_col};
use ivdyn_core::rng::Rng;
use nalgebra::{Matrix3, Matrix4};

const UR5: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");

fn ur5() -> Robot {
    Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap()
}

/// Pseudo-inertia written from its definition: `J = int [r; 1][r; 1]^T dm`, i.e.
/// `[[int r r^T, h], [h^T, m]]` with `int r r^T = tr(I_o)/2 1 - I_o`.
fn pseudo(p: &[f64]) -> Matrix4<f64> {
    let io = Matrix3::new(p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9]);
    let rr = Matrix3::identity() * (0.5 * io.trace()) - io;
    let mut j = Matrix4::zeros();
    for a in 0..3 {
        for b in 0..3 {
            j[(a, b)] = rr[(a, b)];
        }
        j[(a, 3)] = p[1 + a];
        j[(3, a)] = p[1 + a];
    }
    j[(3, 3)] = p[0];
    j
}

fn assert_physical(robot: &Robot, theta: &[f64]) {
    let n = robot.dof();
    for i in 0..n {
        let p = &theta[link_col(i, 0)..link_col(i, 10)];
        let emin = pseudo(p).symmetric_eigenvalues().min();
        assert!(
            p[0] > 0.0 && emin > 0.0,
            "link {}: mass {}, smallest pseudo-inertia eigenvalue {emin}",
            robot.link_names[i],
            p[0]
        );
    }
    for j in 0..n {
        for k in [FC, FV, IA] {
            assert!(theta[drive_col(n, j, k)] >= 0.0, "joint {j} drive {k}: {}", theta[drive_col(n, j, k)]);
        }
    }
}

/// Exact torques of `truth` at random states, accumulated on the base regressor.
fn exact_data(robot: &Robot, truth: &Robot) -> (ivdyn::ident::BaseParams, LsAccumulator) {
    let n = robot.dof();
    let base = robot_base_params(robot, 200, 1).unwrap();
    let mut acc = LsAccumulator::new(base.base_count());
    let mut rng = Rng::new(9);
    for _ in 0..400 {
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let qdd: Vec<f64> = (0..n).map(|_| rng.uniform(-4.0, 4.0)).collect();
        let y = robot.regressor(&q, &qd, &qdd).unwrap();
        let rows = base.select_rows(&y, n).unwrap();
        acc.add_rows(&rows, &truth.rnea(&q, &qd, &qdd).unwrap(), None).unwrap();
    }
    (base, acc)
}

#[test]
fn log_cholesky_round_trip() {
    let robot = ur5();
    let th = robot.params();
    for i in 0..robot.dof() {
        let p = &th[link_col(i, 0)..link_col(i, 10)];
        let x = log_cholesky_from_link(p).expect("URDF links are consistent");
        let back = link_from_log_cholesky(&x);
        for k in 0..10 {
            assert!((back[k] - p[k]).abs() <= 1e-13 * p[0].max(1.0), "link {i} param {k}: {} vs {}", back[k], p[k]);
        }
    }
    // any x gives a positive definite pseudo-inertia
    let mut rng = Rng::new(4);
    for _ in 0..200 {
        let x: Vec<f64> = (0..10).map(|_| rng.normal()).collect();
        assert!(pseudo(&link_from_log_cholesky(&x)).symmetric_eigenvalues().min() > 0.0);
    }
}

#[test]
fn checks_name_the_problem() {
    // a thin rod along x (point masses at +-0.5 m): consistent only as a limit
    let good = [1.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.12, 0.0, 0.0, 0.05];
    assert!(check_link(&good).is_empty(), "{:?}", check_link(&good));
    let neg_mass = [-1.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.1, 0.0, 0.0, 0.1];
    assert!(check_link(&neg_mass).iter().any(|s| s.contains("mass") && s.contains("not positive")));
    // principal moments 0.01, 0.01, 0.1: 0.01 + 0.01 < 0.1
    let tri = [1.0, 0.0, 0.0, 0.0, 0.01, 0.0, 0.01, 0.0, 0.0, 0.1];
    let v = check_link(&tri);
    assert!(v.iter().any(|s| s.contains("triangle")) && v.iter().any(|s| s.contains("pseudo-inertia")), "{v:?}");
    // COM 1 m away with a small inertia about the origin: I_c not positive definite
    let far = [1.0, 1.0, 0.0, 0.0, 0.1, 0.0, 0.1, 0.0, 0.0, 0.1];
    assert!(check_link(&far).iter().any(|s| s.contains("centre of mass is not positive definite")));
    let robot = ur5();
    let mut th = robot.params();
    th[drive_col(6, 2, FV)] = -0.3;
    let c = check_robot_params(&robot, &th);
    assert!(!c.consistent && c.links.is_empty());
    assert_eq!(c.joints.len(), 1);
    assert_eq!(c.joints[0].name, "elbow_joint");
    assert!(c.joints[0].problems[0].contains("viscous friction fv"));
    assert!(check_robot_params(&robot, &robot.params()).consistent);
}

#[test]
fn consistent_fit_recovers_a_valid_robot() {
    let robot = ur5();
    let n = robot.dof();
    let mut truth = robot.clone();
    let mut t = robot.params();
    for i in 0..n {
        for k in 0..10 {
            t[link_col(i, k)] *= 1.0 + 0.1 * (i as f64 + 1.0) / n as f64; // heavier links, still consistent
        }
        t[drive_col(n, i, FC)] = 1.0 + 0.2 * i as f64;
        t[drive_col(n, i, FV)] = 0.5;
        t[drive_col(n, i, IA)] = 0.05 * (i + 1) as f64;
        t[drive_col(n, i, TAU0)] = 0.1 * (i as f64 - 2.0);
    }
    truth.set_params(&t).unwrap();
    assert!(check_robot_params(&robot, &t).consistent);
    let (base, acc) = exact_data(&robot, &truth);
    let fit = fit_ls(&acc, &base.names).unwrap();
    let nominal = robot.params();
    let theta_ls = base.apply(&fit.theta, &nominal, 1.0).unwrap();
    let cf = fit_consistent(
        &acc,
        &base,
        &theta_ls,
        &nominal,
        &robot.link_names,
        &robot.joint_names,
        &ConsistentOptions::default(),
    )
    .unwrap();
    assert!(cf.check.consistent, "{:?}", cf.check.lines());
    assert_physical(&robot, &cf.theta);
    // recovered: the fit reproduces the data to 10 ppm (relative RMS), and the true torques
    // at other states to 10 ppm of their RMS
    assert!(cf.cost.rss <= 1e-10 * cf.sum_wyy, "rss {} of sum y^2 {}", cf.cost.rss, cf.sum_wyy);
    let mut fitted = robot.clone();
    fitted.set_params(&cf.theta).unwrap();
    let mut rng = Rng::new(77);
    let (mut err2, mut tau2) = (0.0f64, 0.0f64);
    let mut worst = 0.0f64;
    for _ in 0..50 {
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let qdd: Vec<f64> = (0..n).map(|_| rng.uniform(-4.0, 4.0)).collect();
        let (a, b) = (fitted.rnea(&q, &qd, &qdd).unwrap(), truth.rnea(&q, &qd, &qdd).unwrap());
        for j in 0..n {
            err2 += (a[j] - b[j]).powi(2);
            tau2 += b[j].powi(2);
            worst = worst.max((a[j] - b[j]).abs());
        }
    }
    assert!(
        worst <= 1e-5 * (tau2 / (50 * n) as f64).sqrt(),
        "worst torque error {worst} (rms error {}, torque rms {})",
        (err2 / (50 * n) as f64).sqrt(),
        (tau2 / (50 * n) as f64).sqrt()
    );
}

#[test]
fn infeasible_estimate_is_flagged_and_the_enforced_fit_is_physical() {
    let robot = ur5();
    let n = robot.dof();
    let mut truth = robot.clone();
    let mut t = robot.params();
    t[drive_col(n, 0, FV)] = -0.5; // negative viscous friction on shoulder_pan_joint
    t[drive_col(n, 3, FC)] = -0.8; // negative Coulomb friction on wrist_1_joint
    t[link_col(2, 1)] += 2.0; // forearm: first moment 2 kg m further along x, inertia unchanged
    truth.set_params(&t).unwrap();
    let (base, acc) = exact_data(&robot, &truth);
    let fit = fit_ls(&acc, &base.names).unwrap();
    let nominal = robot.params();
    let theta_ls = base.apply(&fit.theta, &nominal, 1.0).unwrap();
    let cf = fit_consistent(
        &acc,
        &base,
        &theta_ls,
        &nominal,
        &robot.link_names,
        &robot.joint_names,
        &ConsistentOptions::default(),
    )
    .unwrap();
    assert!(!cf.ls_check.consistent);
    let flagged: Vec<&str> = cf.ls_check.joints.iter().map(|v| v.name.as_str()).collect();
    assert!(flagged.contains(&"shoulder_pan_joint") && flagged.contains(&"wrist_1_joint"), "{:?}", cf.ls_check.lines());
    assert!(cf.check.consistent, "{:?}", cf.check.lines());
    assert_physical(&robot, &cf.theta);
    // the data cannot be fitted exactly any more: the degradation is reported
    assert!(cf.cost.rss > cf.cost.rss_ls && cf.cost.rss_increase > 0.0);
}
