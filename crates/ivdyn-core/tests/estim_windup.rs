//! Issue 16 item 5, recursive estimators on a controller: forgetting with a direction that
//! is never excited (the filed defect: with exponential forgetting at `lambda = 0.99` from
//! `p0 = 1e4` the covariance overflowed after 69,707 rows), tracking a parameter jump,
//! absurd rows, and the outlier gate. Every estimator here runs on its defaults unless
//! the test is about an option.

mod common;
use common::Rng;
use ivdyn_core::Error;
use ivdyn_core::estim::{Riv, Rls};
use nalgebra::{Const, SMatrix, SVector};

const P: usize = 3;
type V = SVector<f64, P>;
type M = SMatrix<f64, P, P>;

const LAMBDA: f64 = 0.99;
const P0: f64 = 1e4;
/// Row noise: uniform on `[-A, A]`, standard deviation `A / sqrt(3) = 0.01`.
const A: f64 = 0.01 * 1.732_050_807_568_877_2;
const SIGMA: f64 = 0.01;

/// A row exciting parameters 0 and 2 (uniform on `[-1, 1]`, variance 1/3 each); parameter
/// 1 is never excited.
fn row(rng: &mut Rng) -> V {
    V::new(rng.uniform(-1.0, 1.0), 0.0, rng.uniform(-1.0, 1.0))
}

/// `d_j > 0` and finite, `P` finite, symmetric and Cholesky-factorable.
fn assert_spd(d: &V, p: &M) {
    assert!(d.iter().all(|&dj| dj > 0.0 && dj.is_finite()), "D = {d}");
    assert!(p.iter().all(|v| v.is_finite()), "P = {p}");
    assert!((p - p.transpose()).norm() <= 1e-15 * p.norm(), "P not symmetric: {p}");
    assert!(p.cholesky().is_some(), "P lost positive definiteness: {p}");
}

/// The filed defect, 1,000,000 rows (14x the 69,707 at which the old covariance
/// overflowed) with `lambda = 0.99`, `p0 = 1e4`, parameter 1 never excited, weights
/// `w = 1 / sigma^2`. Directional forgetting removes information only along each row's
/// `phi`, which never has a component on parameter 1, so that parameter keeps its prior
/// exactly: variance `p0`, estimate 0. The excited ones settle at the steady state of
/// `R <- R - (1 - lambda) phi phi^T / (phi^T P phi) + w phi phi^T`: with `R = r I` and
/// isotropic `phi` in the `m = 2` excited coordinates, `E[phi phi^T / phi^T P phi] = r I / m`,
/// so `r = m w var(phi) / (1 - lambda)` and the variance `1 / r = 1.5e-6` (factor-2 band
/// for the fluctuation of `R` over a memory of `m / (1 - lambda) = 200` rows).
#[test]
fn filed_defect_unexcited_direction_stays_at_the_prior_for_a_million_rows() {
    let mut rng = Rng(161);
    let truth = V::new(0.7, -0.4, 1.3);
    let w = 1.0 / (SIGMA * SIGMA);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), P0);
    rls.forgetting = LAMBDA;
    for _ in 0..1_000_000 {
        let phi = row(&mut rng);
        rls.update(&phi, phi.dot(&truth) + rng.uniform(-A, A), w).unwrap();
    }
    assert_eq!(rls.count, 1_000_000);
    assert_spd(rls.d(), &rls.covariance());
    let mut var = V::zeros();
    rls.variances(&mut var);
    assert!((var[1] - P0).abs() <= 1e-12 * P0, "unexcited variance {} != p0", var[1]);
    assert_eq!(rls.theta[1], 0.0);
    let steady = (1.0 - LAMBDA) / (2.0 * w / 3.0);
    for i in [0, 2] {
        assert!(var[i] > 0.5 * steady && var[i] < 2.0 * steady, "var[{i}] = {} vs {steady}", var[i]);
        // estimate variance ~ P / (1 + lambda) (exponentially weighted LS): 6 sigma
        let std = (steady / 2.0).sqrt();
        assert!((rls.theta[i] - truth[i]).abs() < 6.0 * std, "theta[{i}] = {} vs {}", rls.theta[i], truth[i]);
    }
}

/// An unexcited direction that is not a coordinate, `c = (1, 1, 1) / sqrt(3)` (every
/// `phi` orthogonal to it): `c` stays an eigenvector of `R = I / p0 + sum eps phi phi^T`
/// with eigenvalue `1 / p0`, so `c^T P c = p0` (to the rounding of 300,000 UD updates).
#[test]
fn unexcited_oblique_direction_keeps_its_prior_variance() {
    let mut rng = Rng(162);
    let c = V::repeat(1.0 / 3f64.sqrt());
    let mut rls = Rls::<Const<P>>::new(V::zeros(), P0);
    rls.forgetting = LAMBDA;
    for _ in 0..300_000 {
        let x = V::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        let phi = x - c * c.dot(&x);
        rls.update(&phi, phi.dot(&V::new(1.0, 2.0, 3.0)) + rng.uniform(-A, A), 1e4).unwrap();
    }
    let p = rls.covariance();
    assert_spd(rls.d(), &p);
    let cpc = c.dot(&(p * c));
    assert!((cpc - P0).abs() <= 1e-6 * P0, "c^T P c = {cpc}");
}

/// Tracking: parameter 0 jumps by 1 after 100,000 rows. The old data's weight decays
/// per row by the fraction `(1 - lambda) / m` of the information forgotten along the
/// excited subspace (`m = 2`): memory `tau = 200` rows, so after 3,000 rows (15 tau)
/// the jump's residue is `e^-15 ~ 3e-7`, below the noise: the estimate is back within
/// 6 standard deviations (`sqrt(1.5e-6 / 2)`, as above) of the new value. Without
/// forgetting the same rows leave it near the old value.
#[test]
fn forgetting_tracks_a_parameter_jump() {
    let mut rng = Rng(163);
    let mut truth = V::new(0.7, -0.4, 1.3);
    let w = 1.0 / (SIGMA * SIGMA);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), P0);
    rls.forgetting = LAMBDA;
    let mut plain = Rls::<Const<P>>::new(V::zeros(), P0);
    for k in 0..103_000 {
        if k == 100_000 {
            truth[0] += 1.0;
        }
        let phi = row(&mut rng);
        let y = phi.dot(&truth) + rng.uniform(-A, A);
        rls.update(&phi, y, w).unwrap();
        plain.update(&phi, y, w).unwrap();
    }
    let std = ((1.0 - LAMBDA) / (2.0 * w / 3.0) / 2.0).sqrt();
    for i in [0, 2] {
        assert!((rls.theta[i] - truth[i]).abs() < 6.0 * std, "theta[{i}] = {} vs {}", rls.theta[i], truth[i]);
    }
    // plain LS averages 100,000 old rows with 3,000 new: ~0.03 of the jump
    assert!((plain.theta[0] - (truth[0] - 1.0)).abs() < 0.05, "plain theta[0] = {}", plain.theta[0]);
    assert_spd(rls.d(), &rls.covariance());
}

/// A row that carries little information (`w s << 1 - lambda`) makes directional
/// forgetting inflate its direction; the anti-windup cap (default `p0`) bounds every `d_j`.
#[test]
fn cap_bounds_d_under_uninformative_rows() {
    let mut rng = Rng(164);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), 1.0);
    rls.forgetting = LAMBDA;
    for _ in 0..200_000 {
        let phi = row(&mut rng);
        rls.update(&phi, 0.0, 1e-12).unwrap();
    }
    assert!(rls.d().iter().all(|&dj| dj > 0.0 && dj <= 1.0), "D = {}", rls.d());
    assert_spd(rls.d(), &rls.covariance());
}

/// The filed absurd rows (`phi = 1e150`, `w = 1e300`; and `phi = 1e150`, `w = 1`) are
/// refused with the state bit-for-bit unchanged, and later rows converge as if they had
/// never been offered: noise-free rows recover the truth up to the prior's pull,
/// `|theta - truth| ~ |truth| / (p0 * information) ~ 1e-12` with `p0 = 1e12`.
#[test]
fn absurd_rows_are_refused_and_leave_no_trace() {
    let mut rng = Rng(165);
    let truth = V::new(0.7, -0.4, 1.3);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), 1e12);
    rls.forgetting = LAMBDA;
    let mut riv = Riv::<Const<P>>::new(V::zeros(), 1e12);
    riv.forgetting = LAMBDA;
    for k in 0..400 {
        let phi = V::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        if k % 50 == 7 {
            let (theta, p, count) = (rls.theta, rls.covariance(), rls.count);
            let (theta_iv, p_iv) = (riv.theta, riv.p);
            let huge = V::repeat(1e150);
            for w in [1e300, 1.0] {
                assert!(matches!(rls.update(&huge, 1.0, w), Err(Error::RowOutOfRange { .. })));
                assert!(matches!(riv.update(&huge, &huge, 1.0, w), Err(Error::RowOutOfRange { .. })));
            }
            assert_eq!((rls.theta, rls.covariance(), rls.count), (theta, p, count));
            assert_eq!((riv.theta, riv.p), (theta_iv, p_iv));
        }
        rls.update(&phi, phi.dot(&truth), 1.0).unwrap();
        riv.update(&phi, &phi, phi.dot(&truth), 1.0).unwrap();
    }
    assert!((rls.theta - truth).norm() < 1e-10, "{}", rls.theta);
    assert!((riv.theta - truth).norm() < 1e-10, "{}", riv.theta);
}

/// The outlier gate (off by default): a row 1000 sigma off is refused once the estimator
/// has converged; an ordinary row passes. The normalised innovation of a good row is
/// standard normal, so a gate of 6 refuses good rows with probability 2e-9.
#[test]
fn outlier_gate_refuses_gross_errors_only() {
    let mut rng = Rng(166);
    let truth = V::new(0.7, -0.4, 1.3);
    let w = 1.0 / (SIGMA * SIGMA);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), P0);
    rls.outlier_gate = 6.0;
    for _ in 0..1000 {
        let phi = V::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        rls.update(&phi, phi.dot(&truth) + rng.uniform(-A, A), w).unwrap();
    }
    let phi = V::new(0.5, -0.5, 0.5);
    let theta = rls.theta;
    match rls.update(&phi, phi.dot(&truth) + 1000.0 * SIGMA, w) {
        Err(Error::Outlier { innovation, gate }) => assert!(innovation > 900.0 && gate == 6.0),
        other => panic!("expected an outlier, got {other:?}"),
    }
    assert_eq!(rls.theta, theta);
    rls.update(&phi, phi.dot(&truth), w).unwrap();
}

/// Recursive IV with exponential forgetting on the same defect: the unexcited `P_11`
/// stays at the cap `p0` (to rounding) instead of growing as `lambda^-k`; the excited
/// parameters are estimated within the noise. The instrument `z` is the noise-free
/// regressor and `phi = z + u`, `u` uniform on `[-0.05, 0.05]`, so the equation error is
/// `e - u^T theta` with variance `sigma^2 + |theta|^2 0.05^2 / 3`; exponentially weighted
/// over `(1 + lambda) / (1 - lambda) = 199` effective rows of variance-1/3 instruments,
/// the estimate's standard deviation is `sqrt(3 var / 199)`, and we allow 6 of them.
#[test]
fn riv_cap_keeps_unexcited_direction_bounded() {
    let mut rng = Rng(167);
    let truth = V::new(0.7, -0.4, 1.3);
    let mut riv = Riv::<Const<P>>::new(V::zeros(), P0);
    riv.forgetting = LAMBDA;
    for _ in 0..1_000_000 {
        let z = row(&mut rng);
        let phi = z + V::new(0.05 * rng.uniform(-1.0, 1.0), 0.0, 0.05 * rng.uniform(-1.0, 1.0));
        riv.update(&phi, &z, z.dot(&truth) + rng.uniform(-A, A), 1.0).unwrap();
    }
    assert!(riv.p.iter().all(|v| v.is_finite()));
    assert!((0..P).all(|i| riv.p[(i, i)].abs() <= P0 * (1.0 + 1e-15)), "P = {}", riv.p);
    assert_eq!(riv.theta[1], 0.0);
    let var_e = SIGMA * SIGMA + (truth[0] * truth[0] + truth[2] * truth[2]) * 0.05 * 0.05 / 3.0;
    let std = (3.0 * var_e * (1.0 - LAMBDA) / (1.0 + LAMBDA)).sqrt();
    for i in [0, 2] {
        assert!((riv.theta[i] - truth[i]).abs() < 6.0 * std, "theta[{i}] = {} vs {}", riv.theta[i], truth[i]);
    }
}
