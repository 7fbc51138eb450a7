//! Batch identification on simulated UR5 and Panda trajectories with a full parameter set
//! (inertial + drive): noise-free data recovers the true base parameters; with torque
//! noise of known sigma the reported standard deviations cover the truth at the nominal
//! rate; recursive and batch estimates agree to rounding.

use ivdyn::Robot;
use ivdyn::ident::{BaseParams, LsAccumulator, base::robot_base_params, fit_ls};
use ivdyn_core::VecN;
use ivdyn_core::rng::Rng;
use ivdyn_core::trajectory::Fourier;
use std::path::PathBuf;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn ur5() -> Robot {
    let mut r = Robot::from_urdf(fixtures().join("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    set_drives(&mut r, 11);
    r
}

fn panda() -> Robot {
    let mut r = Robot::from_urdf(fixtures().join("panda.urdf"), Some("panda_link0"), Some("panda_hand")).unwrap();
    set_drives(&mut r, 12);
    r
}

/// Realistic nonzero drive parameters, so that every column of the model matters.
fn set_drives(r: &mut Robot, seed: u64) {
    let n = r.dof();
    let mut theta = r.params();
    let mut rng = Rng::new(seed);
    for j in 0..n {
        let d = 10 * n + 4 * j;
        theta[d] = rng.uniform(0.5, 3.0); // fc
        theta[d + 1] = rng.uniform(0.1, 1.0); // fv
        theta[d + 2] = rng.uniform(0.01, 0.3); // ia
        theta[d + 3] = rng.uniform(-0.5, 0.5); // tau0
    }
    r.set_params(&theta).unwrap();
}

/// An exciting 5-harmonic trajectory (period 10 s) sampled at `hz` for `secs`.
fn trajectory<const N: usize>(seed: u64, hz: f64, secs: f64) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let mut rng = Rng::new(seed);
    let mut f =
        Fourier::<N, 5> { omega: std::f64::consts::TAU / 10.0, q0: [0.0; N], a: [[0.0; 5]; N], b: [[0.0; 5]; N] };
    for i in 0..N {
        f.q0[i] = rng.uniform(-0.5, 0.5);
        for l in 0..5 {
            f.a[i][l] = rng.uniform(-0.5, 0.5);
            f.b[i][l] = rng.uniform(-0.5, 0.5);
        }
    }
    f.scale_to_qdd_rms(&VecN::<N>::repeat(1.5));
    (0..(hz * secs) as usize)
        .map(|k| {
            let (q, qd, qdd) = f.eval(k as f64 / hz);
            (q.as_slice().to_vec(), qd.as_slice().to_vec(), qdd.as_slice().to_vec())
        })
        .collect()
}

/// Stacks the base regressor rows and the torques (plus Gaussian noise `sigma`).
fn accumulate(
    robot: &Robot,
    base: &BaseParams,
    traj: &[(Vec<f64>, Vec<f64>, Vec<f64>)],
    sigma: f64,
    seed: u64,
) -> LsAccumulator {
    let (n, p) = (robot.dof(), robot.num_params());
    let mut acc = LsAccumulator::new(base.base_count());
    let mut rng = Rng::new(seed);
    let mut row_b = vec![0.0; base.base_count()];
    let (mut phi, mut y) = (vec![], vec![]);
    for (q, qd, qdd) in traj {
        let yf = robot.regressor(q, qd, qdd).unwrap();
        let tau = robot.rnea(q, qd, qdd).unwrap();
        for i in 0..n {
            base.select_row(&yf[i * p..(i + 1) * p], &mut row_b).unwrap();
            phi.extend_from_slice(&row_b);
            y.push(tau[i] + sigma * rng.normal());
        }
    }
    acc.add_rows(&phi, &y, None).unwrap();
    acc
}

fn check_noise_free(robot: &Robot, traj_seed: u64, n_joints: usize) {
    let base = robot_base_params(robot, 60, 1).unwrap();
    let truth = base.project(&robot.params()).unwrap();
    let traj =
        if n_joints == 6 { trajectory::<6>(traj_seed, 50.0, 30.0) } else { trajectory::<7>(traj_seed, 50.0, 30.0) };
    let acc = accumulate(robot, &base, &traj, 0.0, 0);
    let fit = fit_ls(&acc, &base.names).unwrap();
    assert!(fit.unexcited.is_empty(), "unexcited: {:?}", fit.unexcited);
    let mut worst: f64 = 0.0;
    for (b, (e, t)) in fit.theta.iter().zip(&truth).enumerate() {
        let rel = (e - t).abs() / t.abs().max(1e-3);
        worst = worst.max(rel);
        assert!(rel < 1e-6, "{}: {e} vs {t} (rel {rel:e})", base.names[b]);
    }
    eprintln!(
        "{}: {} base parameters, cond {:.3e}, worst rel error {worst:.1e}",
        robot.name,
        base.base_count(),
        fit.condition_number
    );
}

#[test]
fn ur5_noise_free_recovers_base_parameters() {
    check_noise_free(&ur5(), 3, 6);
}

#[test]
fn panda_noise_free_recovers_base_parameters() {
    check_noise_free(&panda(), 4, 7);
}

/// With Gaussian torque noise (sigma = 0.2 N m), the 95 % intervals `theta +- 1.96 std`
/// contain the truth in 95 % of the cases. Over 40 seeds x B parameters (B = 50 for the UR5:
/// 2000 intervals) the observed rate has a binomial standard error of ~0.5 %; accept
/// 93-97 % (about +-4 standard errors).
#[test]
fn ur5_standard_deviations_cover_the_truth() {
    let robot = ur5();
    let base = robot_base_params(&robot, 60, 1).unwrap();
    let truth = base.project(&robot.params()).unwrap();
    let traj = trajectory::<6>(5, 20.0, 20.0);
    let (mut inside, mut total) = (0usize, 0usize);
    for seed in 0..40 {
        let acc = accumulate(&robot, &base, &traj, 0.2, 100 + seed);
        let fit = fit_ls(&acc, &base.names).unwrap();
        for b in 0..truth.len() {
            total += 1;
            if (fit.theta[b] - truth[b]).abs() <= 1.96 * fit.std[b] {
                inside += 1;
            }
        }
        // sigma2 estimates the noise variance
        assert!((fit.sigma2.sqrt() - 0.2).abs() < 0.02, "sigma {}", fit.sigma2.sqrt());
    }
    let rate = inside as f64 / total as f64;
    eprintln!("coverage {rate:.4} over {total} intervals");
    assert!((0.93..=0.97).contains(&rate), "coverage {rate}");
}

/// Recursive least squares (core, UD form) started from the batch solution of the
/// first chunk equals the batch fit of all the data.
#[test]
fn recursive_and_batch_agree_to_rounding() {
    use ivdyn_core::estim::Rls;
    use nalgebra::{DMatrix, DVector, Dyn};
    let robot = ur5();
    let base = robot_base_params(&robot, 60, 1).unwrap();
    let b = base.base_count();
    let (n, p) = (robot.dof(), robot.num_params());
    let traj = trajectory::<6>(6, 20.0, 20.0);
    let mut rng = Rng::new(9);
    let mut rows = vec![];
    for (q, qd, qdd) in &traj {
        let yf = robot.regressor(q, qd, qdd).unwrap();
        let tau = robot.rnea(q, qd, qdd).unwrap();
        for i in 0..n {
            let mut rb = vec![0.0; b];
            base.select_row(&yf[i * p..(i + 1) * p], &mut rb).unwrap();
            rows.push((DVector::from_vec(rb), tau[i] + 0.1 * rng.normal()));
        }
    }
    let split = 600;
    let mut info = DMatrix::<f64>::zeros(b, b);
    let mut rhs = DVector::<f64>::zeros(b);
    for (phi, y) in &rows[..split] {
        info += phi * phi.transpose();
        rhs += phi * *y;
    }
    let mut rls = Rls::<Dyn>::from_information(&info, &rhs).unwrap();
    for (phi, y) in &rows[split..] {
        rls.update(phi, *y, 1.0).unwrap();
    }
    let mut acc = LsAccumulator::new(b);
    let flat: Vec<f64> = rows.iter().flat_map(|(phi, _)| phi.iter().copied()).collect();
    let ys: Vec<f64> = rows.iter().map(|r| r.1).collect();
    acc.add_rows(&flat, &ys, None).unwrap();
    let batch = fit_ls(&acc, &base.names).unwrap();
    let mut worst: f64 = 0.0;
    for k in 0..b {
        let rel = (rls.theta[k] - batch.theta[k]).abs() / batch.theta[k].abs().max(1e-6);
        worst = worst.max(rel);
    }
    eprintln!("recursive vs batch: worst rel diff {worst:.1e} (cond {:.2e})", batch.condition_number);
    // The recursion works in information form, whose rounding error scales with
    // cond(Phi^T Phi) eps = cond(R)^2 eps; allow 10x that.
    let bound = 10.0 * batch.condition_number.powi(2) * f64::EPSILON;
    assert!(worst < bound, "worst {worst:e} > {bound:e}");
}

/// The fused, multi-threaded batch fit equals the sequential accumulation (rounding of a
/// different summation order, merged QR factors) and recovers the truth noise-free.
#[test]
fn fused_multithreaded_fit_equals_sequential() {
    let robot = ur5();
    let base = robot_base_params(&robot, 60, 1).unwrap();
    let traj = trajectory::<6>(8, 50.0, 20.0);
    let (mut q, mut qd, mut qdd, mut tau) = (vec![], vec![], vec![], vec![]);
    let mut rng = Rng::new(4);
    for (a, b, c) in &traj {
        q.extend_from_slice(a);
        qd.extend_from_slice(b);
        qdd.extend_from_slice(c);
        tau.extend(robot.rnea(a, b, c).unwrap().iter().map(|t| t + 0.1 * rng.normal()));
    }
    let fused = ivdyn::ident::fit_ls_batch(&robot, &base, &q, &qd, &qdd, &tau, None).unwrap();
    let seq = {
        let mut acc = LsAccumulator::new(base.base_count());
        let (n, p) = (6, robot.num_params());
        let mut rb = vec![0.0; base.base_count()];
        let (mut phi, mut y) = (vec![], vec![]);
        for k in 0..traj.len() {
            let yf =
                robot.regressor(&q[k * n..(k + 1) * n], &qd[k * n..(k + 1) * n], &qdd[k * n..(k + 1) * n]).unwrap();
            for i in 0..n {
                base.select_row(&yf[i * p..(i + 1) * p], &mut rb).unwrap();
                phi.extend_from_slice(&rb);
                y.push(tau[k * n + i]);
            }
        }
        acc.add_rows(&phi, &y, None).unwrap();
        fit_ls(&acc, &base.names).unwrap()
    };
    for b in 0..base.base_count() {
        let d = (fused.theta[b] - seq.theta[b]).abs();
        // merged and sequential QR factors differ by rounding, amplified by cond(R)
        assert!(
            d <= 1e-12 * seq.condition_number * seq.theta[b].abs().max(seq.std[b]),
            "{}: {} vs {}",
            base.names[b],
            fused.theta[b],
            seq.theta[b]
        );
        assert!((fused.std[b] - seq.std[b]).abs() <= 1e-9 * seq.std[b]);
    }
    assert_eq!(fused.rows, seq.rows);
}
