//! Excitation design: the written trajectory respects every limit (re-evaluated here from
//! the reported coefficients with the Fourier-series formula written out independently, on
//! a 7x finer grid than the written samples), the CSV / MCAP outputs agree with it, and
//! the optimised condition number beats the random trajectories of the same harmonics and
//! bounds.

use crate::scratch::Scratch;
use ivdyn::Robot;
use ivdyn::excite::{self, Criterion, ExciteOptions};

const UR5: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");

/// `q_i(t) = q0_i + sum_l a_il/(l w) sin(l w t) - b_il/(l w) cos(l w t)` (Swevers 1997)
/// and its two derivatives, written from the formula.
fn series(q0: f64, a: &[f64], b: &[f64], w: f64, t: f64) -> (f64, f64, f64) {
    let (mut q, mut qd, mut qdd) = (q0, 0.0, 0.0);
    for l in 0..a.len() {
        let lw = (l + 1) as f64 * w;
        q += a[l] / lw * (lw * t).sin() - b[l] / lw * (lw * t).cos();
        qd += a[l] * (lw * t).cos() + b[l] * (lw * t).sin();
        qdd += -a[l] * lw * (lw * t).sin() + b[l] * lw * (lw * t).cos();
    }
    (q, qd, qdd)
}

fn small_opts(seed: u64, criterion: Criterion) -> ExciteOptions {
    ExciteOptions {
        duration_s: 10.0,
        harmonics: 3,
        f0_hz: 0.1,
        rate_hz: 20.0,
        criterion,
        starts: 1,
        iterations: 30,
        opt_samples: 40,
        random_draws: 5,
        seed,
        ..Default::default()
    }
}

#[test]
#[allow(clippy::approx_constant)] // the URDF's own literals, not approximations of pi
fn optimised_trajectory_respects_the_limits_and_beats_random() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let n = robot.dof();
    let rep = excite::design(&robot, &small_opts(3, Criterion::Cond)).unwrap();
    // limits from the URDF text itself (fixtures/ur5.urdf <limit>), velocity as given there,
    // acceleration the documented default
    let lower = [-6.28318530718, -6.28318530718, -3.14159265359, -6.28318530718, -6.28318530718, -6.28318530718];
    let vel = [3.15, 3.15, 3.15, 3.2, 3.2, 3.2];
    let acc = excite::DEFAULT_ACC_LIMIT;
    let w = std::f64::consts::TAU * 0.1;
    let fine = 7 * 200;
    for i in 0..n {
        for k in 0..=fine {
            let t = 10.0 * k as f64 / fine as f64;
            let (q, qd, qdd) = series(rep.q0[i], &rep.a[i], &rep.b[i], w, t);
            assert!(q >= lower[i] && q <= -lower[i], "joint {i}: q = {q} at t = {t} outside the URDF limits");
            assert!(qd.abs() <= vel[i], "joint {i}: |qd| = {} at t = {t} above {}", qd.abs(), vel[i]);
            assert!(qdd.abs() <= acc, "joint {i}: |qdd| = {} at t = {t} above {acc}", qdd.abs());
        }
        // starts at rest (the rest constraints)
        let (_, qd0, qdd0) = series(rep.q0[i], &rep.a[i], &rep.b[i], w, 0.0);
        assert!(qd0.abs() < 1e-12 && qdd0.abs() < 1e-12, "joint {i}: not at rest at t = 0 ({qd0}, {qdd0})");
    }
    // the written samples are the series at k / rate
    let tr = &rep.trajectory;
    assert_eq!(tr.t.len(), 201);
    for (k, &t) in tr.t.iter().enumerate() {
        for i in 0..n {
            let (q, qd, qdd) = series(rep.q0[i], &rep.a[i], &rep.b[i], w, t);
            assert!(
                (tr.q[k * n + i] - q).abs() < 1e-12
                    && (tr.qd[k * n + i] - qd).abs() < 1e-12
                    && (tr.qdd[k * n + i] - qdd).abs() < 1e-11
            );
        }
    }
    // better conditioned than every random draw's median (and the optimiser did something)
    assert!(
        rep.optimised.cond < rep.random.cond_median,
        "optimised cond {} vs random median {}",
        rep.optimised.cond,
        rep.random.cond_median
    );
    assert!((rep.cond_improvement - rep.random.cond_median / rep.optimised.cond).abs() < 1e-12);
    // the reported condition number is the one of the stacked base regressor, recomputed here
    // with an SVD of the dense matrix
    let base = ivdyn::ident::robot_base_params(&robot, 200.max(2 * robot.num_params() / n), 3).unwrap();
    let b = base.base_count();
    let p = robot.num_params();
    let mut phi = nalgebra::DMatrix::<f64>::zeros(tr.t.len() * n, b);
    for k in 0..tr.t.len() {
        let y = robot
            .regressor(&tr.q[k * n..(k + 1) * n], &tr.qd[k * n..(k + 1) * n], &tr.qdd[k * n..(k + 1) * n])
            .unwrap();
        for r in 0..n {
            for (c, &j) in base.independent.iter().enumerate() {
                phi[(k * n + r, c)] = y[r * p + j];
            }
        }
    }
    let sv = phi.singular_values();
    let cond = sv.max() / sv.min();
    assert!((cond / rep.optimised.cond - 1.0).abs() < 1e-6, "cond {cond} vs reported {}", rep.optimised.cond);
}

#[test]
fn logdet_criterion_beats_random_logdet() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let rep = excite::design(&robot, &small_opts(5, Criterion::Logdet)).unwrap();
    assert!(
        rep.optimised.logdet > rep.random.logdet_max,
        "log det {} vs best random {}",
        rep.optimised.logdet,
        rep.random.logdet_max
    );
}

#[test]
fn csv_and_mcap_outputs_read_back() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let n = robot.dof();
    let opts = ExciteOptions { iterations: 2, random_draws: 1, ..small_opts(1, Criterion::Cond) };
    let rep = excite::design(&robot, &opts).unwrap();
    let dir = Scratch::new("ivdyn_excite");
    let (csv, mcap) = (dir.join("traj.csv"), dir.join("traj.mcap"));
    excite::write_csv(&csv, &rep.joints, &rep.trajectory).unwrap();
    excite::write_mcap(&mcap, &rep.joints, &rep.trajectory).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().nth(1).unwrap();
    assert!(header.starts_with("t,shoulder_pan_joint.q,") && header.ends_with("wrist_3_joint.qdd"), "{header}");
    let log = ivdyn::log::read_csv(&csv, &robot.joint_names).unwrap();
    assert_eq!(log.q, rep.trajectory.q);
    assert_eq!(log.qd.as_ref().unwrap(), &rep.trajectory.qd);
    let m = ivdyn::log::read_mcap(&mcap, &ivdyn::log::ReadOptions::new(&robot.joint_names)).unwrap();
    assert_eq!(m.q, rep.trajectory.q);
    assert_eq!(m.qd.as_ref().unwrap(), &rep.trajectory.qd);
    assert!(m.tau.is_none());
    assert_eq!(m.t.len(), rep.trajectory.t.len());
    assert_eq!(m.dof(), n);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_options_are_errors() {
    let robot = Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap();
    let e = excite::design(&robot, &ExciteOptions { harmonics: 1, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("harmonics"), "{e}");
    let e = excite::design(&robot, &ExciteOptions { acc_limit: vec![1.0, 2.0], ..Default::default() })
        .unwrap_err()
        .to_string();
    assert!(e.contains("acceleration limit"), "{e}");
    let e =
        excite::design(&robot, &ExciteOptions { acc_limit: vec![-1.0], ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("shoulder_pan_joint"), "{e}");
}
