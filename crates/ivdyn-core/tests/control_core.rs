//! Controllers, simulator and the online payload estimator of `control` and `sim`.

use ivdyn_core::control::{ComputedTorque, Gains, PayloadEstimator, Pd, Reference, saturate};
use ivdyn_core::estim::Riv;
use ivdyn_core::estim::terminal::Method;
use ivdyn_core::rng::Rng;
use ivdyn_core::sim::{Differentiator, Integrator, SimConfig, Simulator};
use ivdyn_core::trajectory::Fourier;
use ivdyn_core::{DriveParams, LinkInertia, Mat3, Model, Vec3, VecN, forward_dynamics, gravity, mass_matrix, paper};
use nalgebra::{Const, SVector};

fn rand_vec(rng: &mut Rng, s: f64) -> VecN<6> {
    VecN::<6>::from_fn(|_, _| rng.uniform(-s, s))
}

/// The paper's robot without drive terms: a conservative system under zero torque.
fn frictionless() -> Model<6> {
    let mut m = paper::robot();
    m.drive = [DriveParams::ZERO; 6];
    m
}

/// Computed torque with the exact model and zero error, through forward dynamics, gives
/// `qdd = qdd_d`; with an error it gives `qdd = qdd_d + Kd ed + Kp e`. Tolerance: the
/// Cholesky solve loses `cond(M) * eps` relative; on the paper's robot `cond(M) ~ 1e3..1e5`
/// at random poses, so 1e-8 relative to the torque-scale of `qdd` is far above rounding
/// and far below any modelling error.
#[test]
fn computed_torque_exact_model_gives_desired_acceleration() {
    let model = paper::robot();
    let mut data = ivdyn_core::Data::<6>::new();
    let mut rng = Rng::new(11);
    let ct = ComputedTorque::new(Gains::<6>::critically_damped(20.0));
    for _ in 0..200 {
        let r = Reference { q: rand_vec(&mut rng, 3.0), qd: rand_vec(&mut rng, 1.0), qdd: rand_vec(&mut rng, 5.0) };
        // zero error
        let tau = *ct.torque(&model, &mut data, &r.q, &r.qd, &r).unwrap();
        let qdd = *forward_dynamics(&model, &mut data, &r.q, &r.qd, &tau).unwrap();
        assert!((qdd - r.qdd).norm() <= 1e-8 * (1.0 + r.qdd.norm()), "{qdd} vs {}", r.qdd);
        // with an error
        let (q, qd) = (r.q + rand_vec(&mut rng, 0.1), r.qd + rand_vec(&mut rng, 0.1));
        let tau = *ct.torque(&model, &mut data, &q, &qd, &r).unwrap();
        let want = ct.qdd_ref(&q, &qd, &r);
        let qdd = *forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
        assert!((qdd - want).norm() <= 1e-8 * (1.0 + want.norm()));
    }
    // non-finite measurement is an error, not a panic
    let r = Reference::hold(VecN::<6>::zeros());
    let mut q = VecN::<6>::zeros();
    q[2] = f64::NAN;
    assert!(ct.torque(&model, &mut data, &q, &q, &r).is_err());
}

/// PD + gravity at rest on the setpoint is `g(q)`: zero acceleration, and the closed loop
/// in the simulator (RK4, ideal sensors) holds the pose. Tolerance 1e-9 rad: the only
/// motion is rounding (the smoothed Coulomb term is exactly zero at zero velocity).
#[test]
fn pd_gravity_holds_static_pose() {
    let model = paper::robot();
    let mut data = ivdyn_core::Data::<6>::new();
    let q0 = VecN::<6>::from_column_slice(&[0.3, 0.8, -1.1, 0.6, 0.4, -0.2]);
    let pd = Pd::with_gravity(Gains::<6>::new(VecN::<6>::repeat(5.0), VecN::<6>::repeat(0.5)));
    let r = Reference::hold(q0);
    let tau = *pd.torque(&model, &mut data, &q0, &VecN::<6>::zeros(), &r).unwrap();
    let g = *gravity(&model, &mut data, &q0);
    assert!((tau - g).norm() < 1e-15 * (1.0 + g.norm()));
    let qdd = *forward_dynamics(&model, &mut data, &q0, &VecN::<6>::zeros(), &tau).unwrap();
    assert!(qdd.norm() < 1e-10, "{qdd}");
    let mut sim = Simulator::new(model.clone(), SimConfig::<6>::ideal(), &q0, &VecN::<6>::zeros()).unwrap();
    for _ in 0..2000 {
        let s = *sim.sensors();
        let u = *pd.torque(&model, &mut data, &s.q, &s.qd, &r).unwrap();
        sim.step(&u).unwrap();
    }
    assert!((sim.q - q0).norm() < 1e-9, "drift {}", (sim.q - q0).norm());
    // plain PD (no gravity) sags instead
    let pd0 = Pd::new(pd.gains);
    let tau0 = *pd0.torque(&model, &mut data, &q0, &VecN::<6>::zeros(), &r).unwrap();
    assert_eq!(tau0, VecN::<6>::zeros());
}

/// Torque limits are respected by `saturate`, by the controllers and by the simulator.
#[test]
fn saturation() {
    let mut t = VecN::<6>::from_column_slice(&[3.0, -3.0, 0.5, -0.5, 10.0, 0.0]);
    assert!(saturate(&mut t, &VecN::<6>::repeat(1.0)));
    assert_eq!(t.as_slice(), &[1.0, -1.0, 0.5, -0.5, 1.0, 0.0]);
    let model = paper::robot();
    let mut cfg = SimConfig::<6>::ideal();
    cfg.tau_limit = VecN::<6>::repeat(0.2);
    let mut sim = Simulator::new(model, cfg, &VecN::<6>::zeros(), &VecN::<6>::zeros()).unwrap();
    sim.step(&VecN::<6>::repeat(5.0)).unwrap();
    assert!(sim.saturated && sim.tau_applied == VecN::<6>::repeat(0.2));
}

fn free_run(integrator: Integrator, substeps: usize, dt: f64, t_end: f64) -> (VecN<6>, VecN<6>, f64, f64) {
    let mut cfg = SimConfig::<6>::ideal();
    cfg.integrator = integrator;
    cfg.substeps = substeps;
    cfg.dt = dt;
    let q0 = VecN::<6>::from_column_slice(&[0.1, 0.7, -1.0, 0.5, 0.3, 0.0]);
    let qd0 = VecN::<6>::from_column_slice(&[1.0, -1.0, 1.5, 2.0, -2.0, 3.0]);
    let mut sim = Simulator::new(frictionless(), cfg, &q0, &qd0).unwrap();
    let e0 = sim.energy();
    let mut drift: f64 = 0.0;
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        sim.step(&VecN::<6>::zeros()).unwrap();
        drift = drift.max((sim.energy() - e0).abs());
    }
    (sim.q, sim.qd, drift, e0)
}

/// RK4 on the frictionless arm under zero torque conserves energy. Measured: max drift
/// over 2 s at h = 1 ms is 6e-10 J with a kinetic energy of ~0.1 J (RK4's energy error is
/// O(h^4)); the bound 1e-7 J leaves two orders of margin and would catch any error in
/// the dynamics (a wrong Coriolis term drifts by O(1) of the energy). Semi-implicit Euler
/// (h = 0.1 ms) measured 1.7e-3 J, bounded (symplectic) but O(h): bound 1e-2 J.
#[test]
fn rk4_conserves_energy_without_friction() {
    let (_, _, drift, e0) = free_run(Integrator::Rk4, 1, 1e-3, 2.0);
    eprintln!("RK4 h = 1 ms, 2 s: max |E - E0| = {drift:.3e} J (E0 = {e0:.4} J)");
    assert!(drift < 1e-7, "energy drift {drift}");
    let (_, _, drift_e, _) = free_run(Integrator::SemiImplicitEuler, 1, 1e-4, 2.0);
    eprintln!("semi-implicit Euler h = 0.1 ms, 2 s: max |E - E0| = {drift_e:.3e} J");
    assert!(drift_e < 1e-2, "energy drift {drift_e}");
}

/// Global error at t = 0.5 s against a reference with h / 64: the observed order
/// `log2(e(h) / e(h/2))` is ~4 for RK4 and ~1 for semi-implicit Euler. Bounds +-0.5 on the
/// order (asymptotic regime reached at these steps, checked by the two step pairs agreeing).
#[test]
fn integrators_converge_at_their_order() {
    let t_end = 0.5;
    for (integ, h, order) in [(Integrator::Rk4, 4e-3, 4.0), (Integrator::SemiImplicitEuler, 1e-3, 1.0)] {
        let sub = |k: usize| free_run(integ, k, h, t_end);
        let (qr, qdr, _, _) = sub(64);
        let err = |k: usize| {
            let (q, qd, _, _) = sub(k);
            (q - qr).norm() + (qd - qdr).norm()
        };
        let (e1, e2, e4) = (err(1), err(2), err(4));
        let (p1, p2) = ((e1 / e2).log2(), (e2 / e4).log2());
        eprintln!("{integ:?}: errors {e1:.3e} {e2:.3e} {e4:.3e}, orders {p1:.2} {p2:.2}");
        assert!((p1 - order).abs() < 0.5 && (p2 - order).abs() < 0.5, "{integ:?} orders {p1} {p2}");
    }
}

/// Central differences are exact on quadratics; the backward difference lags half a step.
#[test]
fn differentiator_on_a_parabola() {
    let dt = 1e-3;
    let mut d = Differentiator::<6>::new(dt, 0.0);
    let f = |t: f64| VecN::<6>::from_fn(|i, _| (i as f64 + 1.0) * (0.5 * t * t + 0.2 * t + 0.1));
    d.reset(&f(0.0));
    let mut last = None;
    for k in 1..20 {
        let (qd, c) = d.push(&f(k as f64 * dt));
        if k >= 3 {
            let c = c.unwrap();
            let t = (k - 1) as f64 * dt;
            for i in 0..6 {
                let s = i as f64 + 1.0;
                assert!((c.qd[i] - s * (t + 0.2)).abs() < 1e-9);
                assert!((c.qdd[i] - s).abs() < 1e-6); // rounding of q / dt^2 (~1e-16 / 1e-6 * 10)
                // backward difference = derivative at the midpoint
                assert!((qd[i] - s * (t + 0.5 * dt + 0.2)).abs() < 1e-9);
            }
        }
        last = c;
    }
    assert!(last.is_some());
}

/// The Gaussian generator: mean and variance within 5 standard errors over 2e5 draws.
#[test]
fn rng_normal_moments() {
    let mut r = Rng::new(3);
    let n = 200_000;
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let x = r.normal();
        s += x;
        s2 += x * x;
    }
    let (m, v) = (s / n as f64, s2 / n as f64);
    assert!(m.abs() < 5.0 / (n as f64).sqrt(), "mean {m}");
    assert!((v - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(), "var {v}");
}

/// All ten inertial parameters of the last link are identifiable from the rows of all
/// joints on the paper's robot (smallest singular value of the column-scaled regressor far
/// from zero); from joints 5-6 alone the mass is not (NOTES.md).
#[test]
fn last_link_identifiable_from_all_rows() {
    let model = paper::robot();
    let mut data = ivdyn_core::Data::<6>::new();
    let mut rng = Rng::new(5);
    let (mut all, mut wrist) = (vec![], vec![]);
    for _ in 0..60 {
        let (q, qd, qdd) = (rand_vec(&mut rng, 3.0), rand_vec(&mut rng, 1.0), rand_vec(&mut rng, 1.0));
        let y = ivdyn_core::regressor(&model, &mut data, &q, &qd, &qdd);
        for i in 0..6 {
            all.push(y.link[i][5]);
            if i >= 4 {
                wrist.push(y.link[i][5]);
            }
        }
    }
    let rel_min_sv = |rows: &Vec<[f64; 10]>| {
        let m = nalgebra::DMatrix::from_fn(rows.len(), 10, |i, j| rows[i][j]);
        let norms: Vec<f64> = (0..10).map(|j| m.column(j).norm().max(1e-300)).collect();
        let ms = nalgebra::DMatrix::from_fn(rows.len(), 10, |i, j| m[(i, j)] / norms[j]);
        let sv = ms.svd(false, false).singular_values;
        (sv.min() / sv.max(), m.column(0).norm())
    };
    let (a, _) = rel_min_sv(&all);
    assert!(a > 1e-3, "{a}");
    let (_, mass_col_norm) = rel_min_sv(&wrist);
    assert!(mass_col_norm < 1e-10, "mass column seen by the wrist: {mass_col_norm}");
}

/// Online IV estimation of a 250 g payload on the paper's robot in closed loop (computed
/// torque with the nominal model), with 18-bit encoders differentiated (acceleration noise
/// ~17 rad/s^2) and 0.01 N m torque noise: the mass is within 5 % after 1.5 s at 1 kHz
/// (the example reaches 0.1 % in 8 s; 5 % is the criterion).
#[test]
fn online_estimator_converges_to_payload_mass() {
    let nominal = paper::robot();
    let payload = LinkInertia::from_mass_com_inertia(
        0.25,
        &Vec3::new(0.02, 0.0, 0.03),
        &Mat3::identity(),
        &(Mat3::identity() * 6.7e-5),
    );
    let mut loaded = nominal.clone();
    loaded.inertia[5] = loaded.inertia[5].add(&payload);
    let w = std::f64::consts::PI;
    let mut traj = Fourier::<6, 1> { omega: w, q0: [0.0, 0.8, -1.2, 0.6, 0.5, 0.0], a: [[0.0]; 6], b: [[0.0]; 6] };
    for i in 0..6 {
        let ph = 0.3 * i as f64;
        traj.a[i][0] = 0.5 * w * ph.cos();
        traj.b[i][0] = -0.5 * w * ph.sin();
    }
    let mut cfg = SimConfig::<6>::ideal().with_encoder_bits(18);
    cfg.tau_noise = VecN::<6>::repeat(0.01);
    cfg.seed = 42;
    let (q0, qd0, _) = traj.eval(0.0);
    let mut sim = Simulator::new(loaded, cfg, &q0, &qd0).unwrap();
    let ct = ComputedTorque::new(Gains::<6>::critically_damped(20.0));
    let mut data = ivdyn_core::Data::<6>::new();
    let cols = SVector::<usize, 10>::from_fn(|i, _| i);
    let riv = Riv::<Const<10>>::new(SVector::zeros(), 1e3);
    // row weights ~ 1 / (torque-noise + acceleration-noise through M) variance; unit weights
    // also converge, these make the P-based variance meaningful
    let mut est = PayloadEstimator::new(nominal.clone(), cols, [1e2; 6], 0.2, Method::Iv(riv)).unwrap();
    for k in 0..1500 {
        let t = k as f64 * 1e-3;
        let r = Reference::from_tuple(traj.eval(t));
        let s = *sim.sensors();
        let u = *ct.torque(&nominal, &mut data, &s.q, &s.qd, &r).unwrap();
        if let Some(smp) = sim.step(&u).unwrap() {
            let z = traj.eval(smp.t).2;
            est.update(&smp.x.q, &smp.x.qd, &smp.x.qdd, &smp.tau, &z).unwrap();
        }
    }
    let dm = est.theta()[0];
    eprintln!(
        "dm = {dm:.5} kg after 1.5 s ({} rows used, {} skipped), std {:.2e}",
        est.link.rows_used,
        est.link.rows_skipped,
        est.variance(0).sqrt()
    );
    assert!(((dm - 0.25) / 0.25).abs() < 0.05, "dm = {dm}");
    // the estimate written into a model gives the loaded last link's mass
    let mut m = nominal.clone();
    assert!(est.write_model_if_consistent(&mut m, 1e-12));
    assert!((m.inertia[5].mass() - nominal.inertia[5].mass() - dm).abs() < 1e-15);
    let _ = mass_matrix(&m, &mut data, &q0);
}
