//! Transmissions: the motor/joint maps, the motor-side regressor against the Newton-Euler
//! path, recovery of simulated coupled-wrist data, and drive gains from a known payload.

use ivdyn::Robot;
use ivdyn::ident::transmission::{CurrentLog, MotorRegressor, Transmission, fit_drive_gains, motor_torque};
use ivdyn::ident::{LsAccumulator, fit_ls};
use ivdyn_core::params::{DriveParams, FC, FV, IA};
use ivdyn_core::rng::Rng;
use std::path::PathBuf;

fn ur5() -> Robot {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap()
}

/// A TX40-like transmission on a 6-joint arm: gears with a reversed axis 4, motor 6 turning
/// with N6 (q5 + q6), and joint offsets.
fn coupled() -> Transmission {
    Transmission::gears(&[32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
        .unwrap()
        .with_coupling(5, 4, 32.0)
        .unwrap()
        .with_offset(&[0.0, -0.5, 0.5, 0.0, 0.1, 0.0])
        .unwrap()
}

fn motor_drives() -> Vec<DriveParams> {
    (0..6)
        .map(|i| DriveParams {
            fc: 0.05 + 0.01 * i as f64,
            fv: 0.002 * (i + 1) as f64,
            ia: 1e-4 * (6 - i) as f64,
            tau0: 0.01 * i as f64 - 0.02,
            ..DriveParams::ZERO
        })
        .collect()
}

/// Joint-side sums of sines (analytic q, qd, qdd), `T x 6`.
fn joint_trajectory(seed: u64, t: usize, dt: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = Rng::new(seed);
    let w0 = 2.0 * std::f64::consts::PI * 0.2;
    let coef: Vec<[(f64, f64); 4]> =
        (0..6).map(|_| std::array::from_fn(|_| (rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4)))).collect();
    let (mut q, mut qd, mut qdd) = (vec![], vec![], vec![]);
    for k in 0..t {
        let s = k as f64 * dt;
        for c in &coef {
            let (mut a, mut b, mut d) = (0.0, 0.0, 0.0);
            for (h, &(ca, cb)) in c.iter().enumerate() {
                let w = w0 * (h + 1) as f64;
                let (sn, cs) = (w * s).sin_cos();
                a += ca * sn / w + cb * cs / w;
                b += ca * cs - cb * sn;
                d += -ca * w * sn - cb * w * cs;
            }
            q.push(a);
            qd.push(b);
            qdd.push(d);
        }
    }
    (q, qd, qdd)
}

#[test]
fn maps_round_trip_and_conserve_power() {
    let tr = coupled();
    let mut rng = Rng::new(3);
    let x: Vec<f64> = (0..60).map(|_| rng.uniform(-2.0, 2.0)).collect();
    let back = tr.joint_positions(&tr.motor_positions(&x).unwrap()).unwrap();
    let back_rates = tr.motor_rates(&tr.joint_rates(&x).unwrap()).unwrap();
    let back_tau = tr.joint_torques(&tr.motor_torques(&x).unwrap()).unwrap();
    for i in 0..60 {
        assert!(
            (back[i] - x[i]).abs() < 1e-12
                && (back_rates[i] - x[i]).abs() < 1e-12
                && (back_tau[i] - x[i]).abs() < 1e-12,
            "entry {i}"
        );
    }
    // virtual work: the motors deliver the power the joints receive, tau_m . qd_m = tau . qd
    let (qd, tau) = (&x[..30], &x[30..]);
    let (qd_m, tau_m) = (tr.motor_rates(qd).unwrap(), tr.motor_torques(tau).unwrap());
    for s in 0..5 {
        let pj: f64 = (0..6).map(|i| qd[s * 6 + i] * tau[s * 6 + i]).sum();
        let pm: f64 = (0..6).map(|i| qd_m[s * 6 + i] * tau_m[s * 6 + i]).sum();
        assert!((pj - pm).abs() < 1e-12 * (1.0 + pj.abs()), "sample {s}: {pj} vs {pm}");
    }
    // motor 6 turns with 32 (q5 + q6)
    let q_m = tr.motor_positions(&[0.0, -0.5, 0.5, 0.0, 0.1 + 0.2, 0.3]).unwrap();
    assert!((q_m[5] - 32.0 * 0.5).abs() < 1e-12 && (q_m[4] - 45.0 * 0.2).abs() < 1e-12);
    // a singular K is refused
    let e = Transmission::new(&[1.0, 2.0, 2.0, 4.0], 2, None).unwrap_err().to_string();
    assert!(e.contains("K is singular"), "{e}");
}

#[test]
fn motor_regressor_matches_newton_euler() {
    let mut robot = ur5();
    // joint-side drive terms too, so the K^-T mapping of those columns is checked
    let mut theta = robot.params();
    let n = 6;
    for (j, v) in theta[10 * n..].iter_mut().enumerate() {
        *v = 0.1 + 0.03 * j as f64;
    }
    robot.set_params(&theta).unwrap();
    let tr = coupled();
    let (q, qd, qdd) = joint_trajectory(5, 40, 0.07);
    let (q_m, qd_m, qdd_m) =
        (tr.motor_positions(&q).unwrap(), tr.motor_rates(&qd).unwrap(), tr.motor_rates(&qdd).unwrap());
    let drives = motor_drives();
    let want = motor_torque(&robot, &tr, &drives, &q_m, &qd_m, &qdd_m).unwrap();
    let reg = MotorRegressor::new(&robot, &tr, true).unwrap();
    let p = reg.num_params();
    assert_eq!(p, 14 * n + 4 * n);
    let rows = reg.rows(&q_m, &qd_m, &qdd_m).unwrap();
    let th = reg.params(&drives).unwrap();
    for r in 0..want.len() {
        let got: f64 = rows[r * p..(r + 1) * p].iter().zip(&th).map(|(a, b)| a * b).sum();
        assert!((got - want[r]).abs() < 1e-10 * (1.0 + want[r].abs()), "row {r}: {got} vs {}", want[r]);
    }
}

#[test]
fn recovers_coupled_motor_friction_from_simulated_data() {
    let robot = ur5();
    let tr = coupled();
    let reg = MotorRegressor::new(&robot, &tr, false).unwrap();
    let base = reg.base_params(150, 7).unwrap();
    let drives = motor_drives();
    let truth = reg.params(&drives).unwrap();
    let (q, qd, qdd) = joint_trajectory(11, 1500, 0.01);
    let (q_m, qd_m, qdd_m) =
        (tr.motor_positions(&q).unwrap(), tr.motor_rates(&qd).unwrap(), tr.motor_rates(&qdd).unwrap());
    let tau_m = motor_torque(&robot, &tr, &drives, &q_m, &qd_m, &qdd_m).unwrap();
    let rows = reg.rows(&q_m, &qd_m, &qdd_m).unwrap();
    let phi = base.select_rows(&rows, tau_m.len()).unwrap();
    let mut acc = LsAccumulator::new(base.base_count());
    acc.add_rows(&phi, &tau_m, None).unwrap();
    let fit = fit_ls(&acc, &base.names).unwrap();
    assert!(fit.unexcited.is_empty(), "unexcited: {:?}", fit.unexcited);
    let want = base.project(&truth).unwrap();
    for (i, (g, w)) in fit.theta.iter().zip(&want).enumerate() {
        assert!((g - w).abs() < 1e-7 * (1.0 + w.abs()), "{}: {g} vs {w}", base.names[i]);
    }
    // the coupled motor's friction and rotor inertia are base parameters on their own
    // (columns sign(qd5 + qd6), qd5 + qd6, qdd5 + qdd6 that no other parameter has)
    for k in [FC, FV, IA] {
        let col = reg.motor_col(5, k);
        let b = base.independent.iter().position(|&c| c == col).expect("motor 6 term is independent");
        assert_eq!(base.names[b], reg.param_names()[col], "no other parameter merged into it");
        assert!((fit.theta[b] - truth[col]).abs() < 1e-8, "{}: {} vs {}", base.names[b], fit.theta[b], truth[col]);
    }
}

#[test]
fn drive_gains_from_a_known_payload_mass() {
    let robot = ur5();
    let tr = coupled();
    let reg = MotorRegressor::new(&robot, &tr, false).unwrap();
    let base = reg.base_params(150, 7).unwrap();
    let drives = motor_drives();
    let gains = [0.8, 1.2, 0.5, 0.9, 1.5, 0.7];
    let mass = 2.5;
    // payload fixed to the last link: mass, first moments and inertia unknown to the fit
    let mut loaded = robot.clone();
    let mut th = loaded.params();
    let last = 10 * 5;
    let (c, inertia) = ([0.03, -0.02, 0.08], [0.02, 0.001, 0.025, -0.002, 0.003, 0.015]);
    th[last] += mass;
    for a in 0..3 {
        th[last + 1 + a] += mass * c[a];
    }
    for (a, v) in inertia.iter().enumerate() {
        th[last + 4 + a] += v;
    }
    loaded.set_params(&th).unwrap();
    let run = |r: &Robot, seed: u64| {
        let (q, qd, qdd) = joint_trajectory(seed, 1200, 0.01);
        let (q_m, qd_m, qdd_m) =
            (tr.motor_positions(&q).unwrap(), tr.motor_rates(&qd).unwrap(), tr.motor_rates(&qdd).unwrap());
        let tau_m = motor_torque(r, &tr, &drives, &q_m, &qd_m, &qdd_m).unwrap();
        let current: Vec<f64> = tau_m.iter().enumerate().map(|(i, t)| t / gains[i % 6]).collect();
        (q_m, qd_m, qdd_m, current)
    };
    let u = run(&robot, 21);
    let l = run(&loaded, 22);
    let res = fit_drive_gains(
        &reg,
        &base,
        &CurrentLog { q_m: &u.0, qd_m: &u.1, qdd_m: &u.2, current: &u.3 },
        &CurrentLog { q_m: &l.0, qd_m: &l.1, qdd_m: &l.2, current: &l.3 },
        mass,
    )
    .unwrap();
    // the known mass loads the shoulder and elbow motors directly: their gains must be found
    for i in 0..3 {
        assert!(res.identifiable[i], "gain {i} should be identifiable: {:?}", res.identifiable);
    }
    for i in 0..6 {
        if res.identifiable[i] {
            assert!((res.gains[i] - gains[i]).abs() < 1e-6 * gains[i], "gain {i}: {} vs {}", res.gains[i], gains[i]);
        } else {
            assert!(res.gains[i].is_nan());
        }
    }
    // with the scale fixed, the base parameters come out in absolute units
    let want = base.project(&reg.params(&drives).unwrap()).unwrap();
    for i in 0..base.base_count() {
        let g = res.fit.theta[i];
        if g.is_finite() {
            assert!((g - want[i]).abs() < 1e-6 * (1.0 + want[i].abs()), "{}: {g} vs {}", base.names[i], want[i]);
        }
    }
    // no known mass: refused
    assert!(
        fit_drive_gains(
            &reg,
            &base,
            &CurrentLog { q_m: &u.0, qd_m: &u.1, qdd_m: &u.2, current: &u.3 },
            &CurrentLog { q_m: &l.0, qd_m: &l.1, qdd_m: &l.2, current: &l.3 },
            0.0
        )
        .is_err()
    );
}
