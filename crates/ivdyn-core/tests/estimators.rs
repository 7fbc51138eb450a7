//! Recursive estimators against closed-form batch solutions, noise-free recovery,
//! long runs, and degenerate input.

mod common;
use common::Rng;
use ivdyn_core::Error;
use ivdyn_core::estim::{Riv, RivInfo, Rls};
use nalgebra::{Const, SMatrix, SVector};

const P: usize = 8;
type V = SVector<f64, P>;
type M = SMatrix<f64, P, P>;

fn row(rng: &mut Rng) -> V {
    V::from_fn(|i, _| rng.uniform(-1.0, 1.0) * (1.0 + i as f64))
}

/// RLS from `theta0 = 0`, `P0 = p0 I` is exactly ridge-regularised weighted LS:
/// `theta = (Phi^T W Phi + I / p0)^{-1} Phi^T W y`.
#[test]
fn rls_equals_regularised_batch_solution() {
    let mut rng = Rng(1);
    let truth = row(&mut rng);
    let p0 = 10.0;
    let mut rls = Rls::<Const<P>>::new(V::zeros(), p0);
    let (mut info, mut rhs) = (M::identity() / p0, V::zeros());
    for _ in 0..500 {
        let phi = row(&mut rng);
        let w = rng.uniform(0.1, 2.0);
        let y = phi.dot(&truth) + 0.1 * rng.uniform(-1.0, 1.0);
        rls.update(&phi, y, w).unwrap();
        info += w * phi * phi.transpose();
        rhs += w * y * phi;
    }
    let batch = info.cholesky().unwrap().solve(&rhs);
    assert!((rls.theta - batch).norm() <= 1e-10 * batch.norm(), "{} vs {}", rls.theta, batch);
    // and the covariance is the inverse information
    let p = rls.covariance();
    assert!((p * info - M::identity()).norm() < 1e-9);
    assert!((p - p.transpose()).norm() == 0.0 || (p - p.transpose()).norm() < 1e-15 * p.norm());
}

/// Started from a batch solution, the recursion continues it to rounding.
#[test]
fn rls_from_information_continues_batch_exactly() {
    let mut rng = Rng(2);
    let truth = row(&mut rng);
    let rows: Vec<(V, f64, f64)> = (0..300)
        .map(|_| {
            let phi = row(&mut rng);
            (phi, phi.dot(&truth) + 0.05 * rng.uniform(-1.0, 1.0), rng.uniform(0.5, 1.5))
        })
        .collect();
    let (mut info, mut rhs) = (M::zeros(), V::zeros());
    for (phi, y, w) in &rows[..20] {
        info += *w * phi * phi.transpose();
        rhs += *w * *y * phi;
    }
    let mut rls = Rls::<Const<P>>::from_information(&info, &rhs).unwrap();
    for (phi, y, w) in &rows[20..] {
        rls.update(phi, *y, *w).unwrap();
        info += *w * phi * phi.transpose();
        rhs += *w * *y * phi;
    }
    let batch = info.cholesky().unwrap().solve(&rhs);
    assert!((rls.theta - batch).norm() <= 1e-11 * batch.norm());
}

/// Noise-free data: the recursion recovers the parameters to rounding.
#[test]
fn rls_noise_free_recovery() {
    let mut rng = Rng(3);
    let truth = row(&mut rng);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), 1e12);
    for _ in 0..200 {
        let phi = row(&mut rng);
        rls.update(&phi, phi.dot(&truth), 1.0).unwrap();
    }
    assert!((rls.theta - truth).norm() <= 1e-8 * truth.norm());
}

/// Millions of updates with forgetting and a direction that is almost never excited:
/// the UD form keeps the covariance symmetric positive definite and the estimate finite;
/// the excited directions track the truth within the noise.
#[test]
fn rls_two_million_updates_stay_well_posed() {
    let mut rng = Rng(4);
    let truth = row(&mut rng);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), 1.0);
    rls.forgetting = 0.999;
    rls.max_variance = 1e6;
    for k in 0..2_000_000u64 {
        let mut phi = row(&mut rng);
        if k % 100_000 != 0 {
            phi[P - 1] = 0.0; // last parameter excited once every 100 000 rows
        }
        let y = phi.dot(&truth) + 1e-3 * rng.uniform(-1.0, 1.0);
        rls.update(&phi, y, 1.0).unwrap();
    }
    let p = rls.covariance();
    assert!(p.iter().all(|v| v.is_finite()));
    assert!(p.cholesky().is_some(), "covariance lost positive definiteness");
    let mut var = V::zeros();
    rls.variances(&mut var);
    assert!(var.iter().all(|&v| v > 0.0 && v <= 1e6 * 1.0001));
    for i in 0..P - 1 {
        assert!((rls.theta[i] - truth[i]).abs() < 1e-2, "param {i}: {} vs {}", rls.theta[i], truth[i]);
    }
}

/// Recursive IV from a batch start equals the batch IV `(Z^T W Phi)^{-1} Z^T W y`.
#[test]
fn riv_equals_batch_iv() {
    let mut rng = Rng(5);
    let truth = row(&mut rng);
    let (mut info, mut rhs) = (M::zeros(), V::zeros());
    let mut data = vec![];
    for _ in 0..400 {
        let z = row(&mut rng);
        // regressor = instrument + noise (errors in variables), output from the noise-free part
        let phi = z + V::from_fn(|_, _| 0.3 * rng.uniform(-1.0, 1.0));
        let y = z.dot(&truth) + 0.01 * rng.uniform(-1.0, 1.0);
        data.push((phi, z, y, rng.uniform(0.5, 2.0)));
    }
    for (phi, z, y, w) in &data[..30] {
        info += *w * z * phi.transpose();
        rhs += *w * *y * z;
    }
    let mut riv = Riv::<Const<P>>::from_information(&info, &rhs).unwrap();
    for (phi, z, y, w) in &data[30..] {
        riv.update(phi, z, *y, *w).unwrap();
        info += *w * z * phi.transpose();
        rhs += *w * *y * z;
    }
    let batch = info.lu().solve(&rhs).unwrap();
    assert!((riv.theta - batch).norm() <= 1e-10 * batch.norm(), "{} vs {}", riv.theta, batch);
}

#[test]
fn degenerate_updates_are_errors_and_leave_the_state_alone() {
    let mut rls = Rls::<Const<P>>::new(V::repeat(0.5), 1.0);
    let before = rls.theta;
    let phi = V::repeat(1.0);
    assert_eq!(rls.update(&phi, 1.0, 0.0), Err(Error::DegenerateUpdate));
    assert_eq!(rls.update(&phi, f64::NAN, 1.0), Err(Error::DegenerateUpdate));
    let mut bad = phi;
    bad[3] = f64::INFINITY;
    assert_eq!(rls.update(&bad, 1.0, 1.0), Err(Error::NonFinite { what: "phi", index: 3 }));
    assert_eq!(rls.theta, before);
    assert_eq!(rls.count, 0);

    let mut riv = Riv::<Const<P>>::new(V::zeros(), 1.0);
    // instrument orthogonal to the regressor with P = I: phi^T P z = 0 and r ~ 0
    let mut z = V::zeros();
    z[0] = 1.0;
    let mut phi2 = V::zeros();
    phi2[1] = 1.0;
    assert_eq!(riv.update(&phi2, &z, 1.0, 1e300), Err(Error::DegenerateUpdate));
    assert_eq!(riv.theta, V::zeros());
}

/// The information form from the prior `P = p0 I`, `theta0`, with rows of every sparsity
/// (leading zeros, holes), estimated once per two rows, equals the batch IV
/// `(I / p0 + Z^T W Phi)^{-1} (theta0 / p0 + Z^T W y)` and the covariance form.
#[test]
fn riv_info_equals_batch_iv_and_the_covariance_form() {
    let mut rng = Rng(15);
    let truth = row(&mut rng);
    let theta0 = row(&mut rng);
    let p0 = 10.0;
    let mut info = M::identity() / p0;
    let mut rhs = theta0 / p0;
    let mut ri = RivInfo::<Const<P>>::new(theta0, p0);
    let mut rc = Riv::<Const<P>>::new(theta0, p0);
    for k in 0..300 {
        let first = k % P;
        let support = SVector::<bool, P>::from_fn(|i, _| i >= first && (i + k) % 5 != 0);
        let mask = |v: V| V::from_fn(|i, _| if support[i] { v[i] } else { 0.0 });
        let z = mask(row(&mut rng));
        let phi = mask(z + V::from_fn(|_, _| 0.3 * rng.uniform(-1.0, 1.0)));
        let y = z.dot(&truth) + 0.01 * rng.uniform(-1.0, 1.0);
        let w = rng.uniform(0.5, 2.0);
        // entries outside the support are not read
        let mut phi_junk = phi;
        phi_junk[(first + P - 1) % P] += if support[(first + P - 1) % P] { 0.0 } else { 1e3 };
        ri.add_row_sparse(&phi_junk, &z, &support, y, w).unwrap();
        rc.update(&phi, &z, y, w).unwrap();
        info += w * z * phi.transpose();
        rhs += w * y * z;
        if k % 2 == 1 {
            ri.estimate().unwrap();
            let batch = info.lu().solve(&rhs).unwrap();
            assert!((ri.theta - batch).norm() <= 1e-10 * batch.norm(), "row {k}: {} vs {}", ri.theta, batch);
            assert!((ri.theta - rc.theta).norm() <= 1e-10 * batch.norm(), "row {k}");
        }
    }
    let p = info.try_inverse().unwrap();
    assert!((ri.p() - p).norm() <= 1e-10 * p.norm());
    assert!((ri.p() - rc.p).norm() <= 1e-10 * p.norm());
    assert_eq!(ri.count, 300);
    // a full-support update estimates at once
    let (z, y) = (row(&mut rng), 0.5);
    ri.update(&z, &z, y, 1.0).unwrap();
    info += z * z.transpose();
    rhs += y * z;
    let batch = info.lu().solve(&rhs).unwrap();
    assert!((ri.theta - batch).norm() <= 1e-10 * batch.norm());
}

/// Refused rows (non-finite input, a vanishing pivot, a row out of range) leave the state
/// as it was: the next good row gives what it gives without them.
#[test]
fn riv_info_refused_rows_leave_the_state_alone() {
    let mut rng = Rng(16);
    let mut a = RivInfo::<Const<P>>::new(V::zeros(), 1.0);
    for _ in 0..20 {
        let z = row(&mut rng);
        a.update(&z, &z, rng.uniform(-1.0, 1.0), 1.0).unwrap();
    }
    let b = a.clone();
    let z = row(&mut rng);
    let mut bad = z;
    bad[3] = f64::NAN;
    assert_eq!(a.update(&bad, &z, 1.0, 1.0), Err(Error::NonFinite { what: "phi", index: 3 }));
    assert_eq!(a.update(&z, &z, 1.0, 0.0), Err(Error::DegenerateUpdate));
    // instrument and regressor that cancel the first pivot exactly: u11' = u11 + w z1 phi1 = 0
    let u11 = a.p().try_inverse().unwrap()[(0, 0)];
    let (mut zc, mut phic) = (V::zeros(), V::zeros());
    zc[0] = 1.0;
    phic[0] = -u11;
    phic[5] = 2.0;
    assert_eq!(a.update(&phic, &zc, 1.0, 1.0), Err(Error::DegenerateUpdate));
    // a row whose information dwarfs what is held (1 / eps^2)
    let huge = z * 1e20;
    assert!(matches!(a.update(&huge, &huge, 1.0, 1.0), Err(Error::RowOutOfRange { .. })));
    assert_eq!(a.count, b.count);
    assert_eq!(a.p(), b.p());
    let mut b = b;
    a.update(&z, &z, 0.3, 1.0).unwrap();
    b.update(&z, &z, 0.3, 1.0).unwrap();
    assert_eq!(a.theta, b.theta);
}

/// `P`'s bits (NaN-safe equality of two states).
fn p_bits(r: &RivInfo<Const<P>>) -> Vec<u64> {
    r.p().iter().map(|v| v.to_bits()).collect()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Rows of any size (1e-200 to 1e200), weight, sparsity and instrument (from
    /// uncorrelated to equal to the regressor), some non-finite: the information form never
    /// panics, a refused row leaves the state bit for bit as it was, and an accepted one
    /// leaves the factors finite (the estimate is finite or an error).
    #[test]
    fn riv_info_any_rows_never_panic_and_refusals_leave_the_state(
        seed in proptest::prelude::any::<u64>(),
        exp in -200i32..200,
        w_exp in -40i32..40,
        corr in 0.0f64..=1.0,
    ) {
        let mut rng = Rng(seed);
        let scale = 10f64.powi(exp);
        let mut r = RivInfo::<Const<P>>::new(V::zeros(), 10f64.powi(exp.clamp(-100, 100) / 2));
        for k in 0..40 {
            let first = (rng.uniform(0.0, P as f64) as usize).min(P - 1);
            let support = SVector::<bool, P>::from_fn(|i, _| i >= first && rng.uniform(0.0, 1.0) < 0.8);
            let z = row(&mut rng) * scale;
            let mut phi = z * corr + row(&mut rng) * (scale * (1.0 - corr));
            if k % 13 == 7 {
                phi[first] = [f64::NAN, f64::INFINITY, f64::MAX][k % 3];
            }
            let y = rng.uniform(-1.0, 1.0) * scale;
            let w = 10f64.powi(w_exp) * rng.uniform(0.5, 2.0);
            let before = (r.count, p_bits(&r));
            match r.add_row_sparse(&phi, &z, &support, y, w) {
                Ok(()) => proptest::prop_assert_eq!(r.count, before.0 + 1),
                Err(_) => {
                    proptest::prop_assert_eq!(r.count, before.0);
                    proptest::prop_assert_eq!(p_bits(&r), before.1);
                }
            }
            if r.estimate().is_ok() {
                proptest::prop_assert!(r.theta.iter().all(|v| v.is_finite()));
            }
        }
    }
}
