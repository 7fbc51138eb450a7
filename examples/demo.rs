//! `make demo`: what ivdyn does today, on the bundled robots.
//!
//! Loads the UR5 and Panda URDFs shipped in `fixtures/`, and the paper's robot; prints
//! each chain, then inverse dynamics, the regressor identity `Y theta = tau`, the mass
//! matrix and forward dynamics at a state, with timings per call.

use ivdyn::Robot;
use std::path::PathBuf;
use std::time::Instant;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn show(robot: &Robot) -> Result<(), ivdyn::Error> {
    let n = robot.dof();
    println!("== {} ({} joints, base '{}', tip '{}')", robot.name, n, robot.base_link, robot.tip_link);
    if !robot.locked_joints.is_empty() {
        println!("   locked at 0 and fused: {}", robot.locked_joints.join(", "));
    }
    let theta = robot.params();
    for (j, name) in robot.joint_names.iter().enumerate() {
        println!("   {:<22} link {:<16} mass {:>7.3} kg", name, robot.link_names[j], theta[10 * j]);
    }
    let q: Vec<f64> = (0..n).map(|i| 0.3 * (1.0 + i as f64).sin()).collect();
    let qd: Vec<f64> = (0..n).map(|i| 0.5 * (2.0 + i as f64).cos()).collect();
    let qdd: Vec<f64> = (0..n).map(|i| 0.7 * (3.0 + 0.5 * i as f64).sin()).collect();
    let tau = robot.rnea(&q, &qd, &qdd)?;
    let y = robot.regressor(&q, &qd, &qdd)?;
    let p = robot.num_params();
    let err = (0..n)
        .map(|i| (y[i * p..(i + 1) * p].iter().zip(&theta).map(|(a, b)| a * b).sum::<f64>() - tau[i]).abs())
        .fold(0.0, f64::max);
    let qdd_back = robot.forward_dynamics(&q, &qd, &tau)?;
    let fd_err = qdd_back.iter().zip(&qdd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!("   tau (N m)       = {}", fmt(&tau));
    println!("   |Y theta - tau| = {err:.1e} N m    |fd(rnea(qdd)) - qdd| = {fd_err:.1e} rad/s^2");
    let m = robot.mass_matrix(&q)?;
    println!("   diag M (kg m^2) = {}", fmt(&(0..n).map(|i| m[i * n + i]).collect::<Vec<_>>()));
    let reps = 20_000;
    let t0 = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(robot.rnea(&q, &qd, &qdd)?);
    }
    let t1 = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(robot.regressor(&q, &qd, &qdd)?);
    }
    let t2 = Instant::now();
    println!(
        "   per call (incl. Vec allocation): rnea {:.2} us, regressor {:.2} us",
        (t1 - t0).as_secs_f64() / reps as f64 * 1e6,
        (t2 - t1).as_secs_f64() / reps as f64 * 1e6
    );
    Ok(())
}

fn fmt(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:8.3}")).collect::<Vec<_>>().join(" ")
}

fn main() -> Result<(), ivdyn::Error> {
    let fx = root().join("fixtures");
    show(&Robot::from_urdf(fx.join("ur5.urdf"), Some("base_link"), Some("tool0"))?)?;
    show(&Robot::from_urdf(fx.join("panda.urdf"), Some("panda_link0"), Some("panda_hand"))?)?;
    show(&Robot::paper())?;
    Ok(())
}
