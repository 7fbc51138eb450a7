//! IDIM-IV on a closed-loop UR5 experiment with noisy accelerations: least squares is
//! biased (DWH flags it), IDIM-IV converges to the truth.

use ivdyn::Robot;
use ivdyn::ident::{Experiment, idim_iv, robot_base_params};
use ivdyn_core::rng::Rng;
use ivdyn_core::trajectory::Fourier;
use std::path::PathBuf;

#[test]
fn idim_iv_removes_the_least_squares_bias() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    let mut truth = Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap();
    let n = truth.dof();
    let mut th = truth.params();
    for j in 0..n {
        th[10 * n + 4 * j + 1] = 0.5; // viscous
        th[10 * n + 4 * j + 2] = 0.1; // armature
    }
    truth.set_params(&th).unwrap();
    let base = robot_base_params(&truth, 60, 1).unwrap();
    let theta_true = base.project(&truth.params()).unwrap();

    // the robot's controller: PD on a Fourier reference with gravity compensation from a
    // fixed (unloaded, here: true) model; the same law drives the IDIM-IV simulations
    let mut tr = Rng::new(2);
    let mut f = Fourier::<6, 4> {
        omega: std::f64::consts::TAU / 5.0,
        q0: [0.0, -1.2, 1.2, -1.0, -1.4, 0.3],
        a: [[0.0; 4]; 6],
        b: [[0.0; 4]; 6],
    };
    for i in 0..6 {
        for l in 0..4 {
            f.a[i][l] = tr.uniform(-0.6, 0.6);
            f.b[i][l] = tr.uniform(-0.6, 0.6);
        }
    }
    let dt = 1e-3;
    let kp = [4000.0, 4000.0, 2000.0, 400.0, 400.0, 200.0];
    let kd = [120.0, 120.0, 60.0, 12.0, 12.0, 6.0];
    let gravity_model = truth.clone();
    let control = |k: usize, q: &[f64], qd: &[f64]| -> Vec<f64> {
        let (qr, qdr, _) = f.eval(k as f64 * dt);
        let g = gravity_model.gravity(q).unwrap();
        (0..6).map(|i| kp[i] * (qr[i] - q[i]) + kd[i] * (qdr[i] - qd[i]) + g[i]).collect()
    };
    // the real experiment: the true robot under that law (semi-implicit Euler at 1 kHz)
    let t_len = 10_000;
    let (r0, rd0, _) = f.eval(0.0);
    let (mut q, mut qd) = (r0.as_slice().to_vec(), rd0.as_slice().to_vec());
    let (mut lq, mut lqd, mut lqdd, mut ltau) = (vec![], vec![], vec![], vec![]);
    let mut noise = Rng::new(3);
    for k in 0..t_len {
        let tau = control(k, &q, &qd);
        let qdd = truth.forward_dynamics(&q, &qd, &tau).unwrap();
        lq.extend_from_slice(&q);
        lqd.extend_from_slice(&qd);
        lqdd.extend(qdd.iter().map(|a| a + 5.0 * noise.normal())); // noisy accelerations
        ltau.extend_from_slice(&tau);
        for i in 0..6 {
            qd[i] += qdd[i] * dt;
            q[i] += qd[i] * dt;
        }
    }
    // the nominal model the method starts from: true geometry, 20 % off inertials
    let mut nominal = truth.clone();
    let mut thn = nominal.params();
    for v in thn.iter_mut() {
        *v *= 1.2;
    }
    nominal.set_params(&thn).unwrap();
    let exp = Experiment { dt, q: &lq, qd: &lqd, qdd: &lqdd, tau: &ltau };
    let res = idim_iv(&nominal, &base, &exp, control, 30, 1e-5).unwrap();
    // error in units of the LS standard deviation, over all base parameters
    let z = |theta: &[f64]| -> f64 {
        let s: f64 = theta.iter().zip(&theta_true).zip(&res.ls.std).map(|((e, t), sd)| ((e - t) / sd).powi(2)).sum();
        (s / theta.len() as f64).sqrt()
    };
    let (z_ls, z_iv) = (z(&res.ls.theta), z(&res.fit.theta));
    let changes: Vec<f64> = res
        .history
        .windows(2)
        .map(|w| {
            let d: f64 = w[1].iter().zip(&w[0]).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
            d / w[0].iter().map(|a| a * a).sum::<f64>().sqrt()
        })
        .collect();
    eprintln!(
        "iterations {} converged {} shrink {:?} changes {:?} | rms error / LS std: LS {z_ls:.2} IDIM-IV {z_iv:.2} | DWH p = {:?}",
        res.history.len() - 1,
        res.converged,
        res.shrink,
        changes,
        res.fit.dwh.map(|d| d.p_value)
    );
    for (b, name) in base.names.iter().enumerate().take(12) {
        eprintln!(
            "  {name:<40} truth {:+.4e} LS {:+.4e} IV {:+.4e} (LS std {:.1e})",
            theta_true[b], res.ls.theta[b], res.fit.theta[b], res.ls.std[b]
        );
    }
    assert!(res.converged);
    assert!(res.fit.dwh.unwrap().ls_biased, "DWH should flag the LS bias");
    assert!(z_iv < 0.25 * z_ls, "IDIM-IV {z_iv} not much better than LS {z_ls}");
}
