//! Cross-algorithm identities on random chains and states (Pinocchio's and MuJoCo's test
//! style): regressor vs RNEA, CRBA vs RNEA columns, forward vs inverse dynamics, energy.

mod common;
use common::{Rng, assert_close, random_model};
use ivdyn_core::energy::{kinetic_energy, potential_energy};
use ivdyn_core::rnea::rnea_rigid;
use ivdyn_core::{
    CoulombShape, Data, Model, VecN, forward_dynamics, gravity, gravity_regressor, mass_matrix, params::param_count,
    regressor, rnea,
};
use proptest::prelude::*;

const N: usize = 6;

fn state(rng: &mut Rng) -> (VecN<N>, VecN<N>, VecN<N>) {
    let q = rng.vecn::<N>(-3.0, 3.0);
    let mut qd = rng.vecn::<N>(-2.0, 2.0);
    qd[2] = 0.0; // exercise sign(0) = 0
    (q, qd, rng.vecn::<N>(-3.0, 3.0))
}

fn theta(model: &Model<N>) -> Vec<f64> {
    let mut t = vec![0.0; param_count(N)];
    model.params_to_slice(&mut t).unwrap();
    t
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn regressor_times_theta_is_rnea(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let mut rng = Rng(seed ^ 0xabc);
        let (q, qd, qdd) = state(&mut rng);
        let tau = *rnea(&model, &mut data, &q, &qd, &qdd);
        let y = regressor(&model, &mut data, &q, &qd, &qdd).clone();
        let tau_y = y.mul(&theta(&model));
        assert_close(tau_y.as_slice(), tau.as_slice(), 1e-12, 1e-12, "Y theta");
        // the dense copy agrees with the blocks
        let mut dense = vec![0.0; N * param_count(N)];
        y.write_row_major(&mut dense);
        let t = theta(&model);
        for i in 0..N {
            let row = &dense[i * param_count(N)..(i + 1) * param_count(N)];
            let s: f64 = row.iter().zip(&t).map(|(a, b)| a * b).sum();
            prop_assert!((s - tau[i]).abs() <= 1e-12 * (1.0 + tau[i].abs()));
        }
        let ym = y.to_matrix::<84>();
        prop_assert!(((ym * model.params::<84>()) - tau).norm() <= 1e-12 * (1.0 + tau.norm()));
    }

    /// With shaped Coulomb friction (smooth, direction-dependent: a model constant) the
    /// regressor is still linear in theta and reproduces RNEA; the Coulomb column is
    /// `tanh(qd / v) + asym |tanh(qd / v)|` (or the sign's).
    #[test]
    fn regressor_times_theta_is_rnea_with_coulomb_shapes(seed in any::<u64>(), prismatic in any::<bool>()) {
        let mut model = random_model::<N>(seed, prismatic);
        let mut rng = Rng(seed ^ 0x5eed);
        for d in model.drive.iter_mut() {
            d.coulomb = CoulombShape { v_scale: rng.uniform(0.0, 0.5), asym: rng.uniform(-0.9, 0.9) };
        }
        model.drive[1].coulomb.v_scale = 0.0; // the sign with an asymmetry
        let mut data = Data::<N>::new();
        let (q, qd, qdd) = state(&mut rng);
        let tau = *rnea(&model, &mut data, &q, &qd, &qdd);
        let y = regressor(&model, &mut data, &q, &qd, &qdd).clone();
        assert_close(y.mul(&theta(&model)).as_slice(), tau.as_slice(), 1e-12, 1e-12, "Y theta");
        for i in 0..N {
            let c = model.drive[i].coulomb;
            let s = if c.v_scale > 0.0 { (qd[i] / c.v_scale).tanh() } else { qd[i].signum() * (qd[i] != 0.0) as u8 as f64 };
            prop_assert!((y.drive[i][0] - (s + c.asym * s.abs())).abs() <= 1e-15);
        }
    }

    #[test]
    fn gravity_regressor_matches_gravity(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let q = Rng(seed).vecn::<N>(-3.0, 3.0);
        let g = *gravity(&model, &mut data, &q);
        let yg = gravity_regressor(&model, &mut data, &q).clone();
        assert_close(yg.mul(&theta(&model)).as_slice(), g.as_slice(), 1e-12, 1e-12, "Yg theta");
        // equals the full regressor at rest, minus the drive columns
        let z = VecN::<N>::zeros();
        let y = regressor(&model, &mut data, &q, &z, &z).clone();
        for i in 0..N { for j in 0..N {
            assert_close(&yg.link[i][j], &y.link[i][j], 1e-12, 1e-12, "Yg block");
        }}
    }

    #[test]
    fn mass_matrix_is_spd_and_matches_rnea_columns(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let q = Rng(seed).vecn::<N>(-3.0, 3.0);
        let m = *mass_matrix(&model, &mut data, &q);
        prop_assert!((m - m.transpose()).norm() <= 1e-13 * m.norm());
        prop_assert!(m.cholesky().is_some(), "M not positive definite");
        // column k = rnea_rigid(q, 0, e_k) - g(q) + ia_k e_k
        let z = VecN::<N>::zeros();
        let g = *rnea_rigid(&model, &mut data, &q, &z, &z);
        for k in 0..N {
            let mut e = VecN::<N>::zeros();
            e[k] = 1.0;
            let mut col = *rnea_rigid(&model, &mut data, &q, &z, &e) - g;
            col[k] += model.drive[k].ia;
            assert_close(m.column(k).as_slice(), col.as_slice(), 1e-12, 1e-12, "M column");
        }
    }

    #[test]
    fn forward_inverts_inverse(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let (q, qd, qdd) = state(&mut Rng(seed ^ 7));
        let tau = *rnea(&model, &mut data, &q, &qd, &qdd);
        let qdd2 = *forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
        let cond_scale = 1.0 + qdd.norm();
        prop_assert!((qdd2 - qdd).norm() <= 1e-9 * cond_scale, "{qdd2} vs {qdd}");
    }

    /// Power balance dE/dt = qd . (tau - fc sign(qd) - fv qd - tau0), with E = T + V, by a
    /// central difference along the motion (error O(h^2) ~ 1e-10 relative).
    #[test]
    fn energy_balance(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let mut rng = Rng(seed ^ 99);
        let q = rng.vecn::<N>(-3.0, 3.0);
        let qd = rng.vecn::<N>(-1.0, 1.0); // no zero velocities: sign() must be smooth here
        let tau = rng.vecn::<N>(-5.0, 5.0);
        let qdd = *forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
        let mut energy = |q: &VecN<N>, qd: &VecN<N>| {
            kinetic_energy(&model, &mut data, q, qd) + potential_energy(&model, &mut data, q)
        };
        let h = 1e-5;
        let de = (energy(&(q + qd * h), &(qd + qdd * h)) - energy(&(q - qd * h), &(qd - qdd * h))) / (2.0 * h);
        let mut p = 0.0;
        for i in 0..N {
            let d = &model.drive[i];
            p += qd[i] * (tau[i] - d.fc * qd[i].signum() - d.fv * qd[i] - d.tau0);
        }
        prop_assert!((de - p).abs() <= 1e-6 * (1.0 + p.abs()), "dE/dt {de} vs power {p}");
    }

    /// Kinetic energy equals 1/2 qd^T M qd.
    #[test]
    fn kinetic_energy_is_quadratic_form(seed in any::<u64>(), prismatic in any::<bool>()) {
        let model = random_model::<N>(seed, prismatic);
        let mut data = Data::<N>::new();
        let mut rng = Rng(seed ^ 5);
        let (q, qd) = (rng.vecn::<N>(-3.0, 3.0), rng.vecn::<N>(-2.0, 2.0));
        let t = kinetic_energy(&model, &mut data, &q, &qd);
        let m = *mass_matrix(&model, &mut data, &q);
        let t2 = 0.5 * qd.dot(&(m * qd));
        prop_assert!((t - t2).abs() <= 1e-12 * (1.0 + t.abs()));
    }
}

/// Energy balance over a simulated trajectory: RK4 at 1 kHz for 2 s under a smooth torque
/// with friction, offset and armature; the energy change equals the integrated power.
#[test]
fn energy_balance_on_simulated_trajectory() {
    let mut model = random_model::<N>(42, true);
    for d in model.drive.iter_mut() {
        d.fc = 0.0; // Coulomb's discontinuity breaks RK4's order; viscous + offset stay
    }
    let mut data = Data::<N>::new();
    let tau_of = |t: f64| VecN::<N>::from_fn(|i, _| 3.0 * (1.3 * t + i as f64).sin());
    let power = |model: &Model<N>, qd: &VecN<N>, tau: &VecN<N>| {
        (0..N).map(|i| qd[i] * (tau[i] - model.drive[i].fv * qd[i] - model.drive[i].tau0)).sum::<f64>()
    };
    let mut q = VecN::<N>::from_element(0.1);
    let mut qd = VecN::<N>::zeros();
    let dt = 1e-3;
    let energy = |data: &mut Data<N>, q: &VecN<N>, qd: &VecN<N>| {
        kinetic_energy(&model, data, q, qd) + potential_energy(&model, data, q)
    };
    let e0 = energy(&mut data, &q, &qd);
    let mut work = 0.0;
    let fd = |q: &VecN<N>, qd: &VecN<N>, t: f64, data: &mut Data<N>| {
        *forward_dynamics(&model, data, q, qd, &tau_of(t)).unwrap()
    };
    for k in 0..2000 {
        let t = k as f64 * dt;
        // RK4 on (q, qd); Simpson's rule on the power, with the same stages
        let a1 = fd(&q, &qd, t, &mut data);
        let (q2, qd2) = (q + qd * (dt / 2.0), qd + a1 * (dt / 2.0));
        let a2 = fd(&q2, &qd2, t + dt / 2.0, &mut data);
        let (q3, qd3) = (q + qd2 * (dt / 2.0), qd + a2 * (dt / 2.0));
        let a3 = fd(&q3, &qd3, t + dt / 2.0, &mut data);
        let (q4, qd4) = (q + qd3 * dt, qd + a3 * dt);
        let a4 = fd(&q4, &qd4, t + dt, &mut data);
        let p1 = power(&model, &qd, &tau_of(t));
        let p2 = power(&model, &qd2, &tau_of(t + dt / 2.0));
        let p3 = power(&model, &qd3, &tau_of(t + dt / 2.0));
        let p4 = power(&model, &qd4, &tau_of(t + dt));
        work += dt / 6.0 * (p1 + 2.0 * p2 + 2.0 * p3 + p4);
        q += (qd + qd2 * 2.0 + qd3 * 2.0 + qd4) * (dt / 6.0);
        qd += (a1 + a2 * 2.0 + a3 * 2.0 + a4) * (dt / 6.0);
    }
    let e1 = energy(&mut data, &q, &qd);
    let scale = 1.0 + work.abs() + e0.abs();
    // RK4 global error O(dt^4): with |qdd| ~ 10 rad/s^2 the energy error is << 1e-6
    assert!(((e1 - e0) - work).abs() <= 1e-6 * scale, "dE {} vs work {}", e1 - e0, work);
}
