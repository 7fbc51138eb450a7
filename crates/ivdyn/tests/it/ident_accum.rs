//! Streaming LS / IV accumulators: exactness, merging, QR against SVD, input checks.

use ivdyn::ident::{IvAccumulator, LsAccumulator, fit_iv, fit_ls};
use ivdyn_core::rng::Rng;
use nalgebra::{DMatrix, DVector};

/// A random problem: `phi` (`m x p` row-major, entries N(0,1)), `theta` (N(0,1)),
/// weights uniform in [0.5, 2], `y = phi theta + noise / sqrt(w)`.
struct Problem {
    m: usize,
    p: usize,
    phi: Vec<f64>,
    theta: Vec<f64>,
    y: Vec<f64>,
    w: Vec<f64>,
}

fn problem(seed: u64, m: usize, p: usize, noise: f64) -> Problem {
    let mut rng = Rng::new(seed);
    let phi: Vec<f64> = (0..m * p).map(|_| rng.normal()).collect();
    let theta: Vec<f64> = (0..p).map(|_| rng.normal()).collect();
    let w: Vec<f64> = (0..m).map(|_| rng.uniform(0.5, 2.0)).collect();
    let y = (0..m)
        .map(|i| (0..p).map(|j| phi[i * p + j] * theta[j]).sum::<f64>() + noise * rng.normal() / w[i].sqrt())
        .collect();
    Problem { m, p, phi, theta, y, w }
}

fn names(p: usize) -> Vec<String> {
    (0..p).map(|j| format!("theta{j}")).collect()
}

fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    num / den
}

#[test]
fn noise_free_rows_recover_theta() {
    let pr = problem(1, 300, 7, 0.0);
    let mut acc = LsAccumulator::new(pr.p);
    acc.add_rows(&pr.phi, &pr.y, Some(&pr.w)).unwrap();
    let fit = fit_ls(&acc, &names(pr.p)).unwrap();
    assert!(rel_err(&fit.theta, &pr.theta) < 1e-10, "{:?} vs {:?}", fit.theta, pr.theta);
    assert!(rel_err(&acc.solve().unwrap(), &pr.theta) < 1e-10);
    assert_eq!(fit.rank, pr.p);
    assert!(fit.unexcited.is_empty());
    assert!(acc.rss() < 1e-20);
    assert_eq!(acc.rows(), 300);

    // IV with Z = Phi is LS.
    let mut iv = IvAccumulator::new(pr.p);
    iv.add_rows(&pr.phi, &pr.phi, &pr.y, Some(&pr.w)).unwrap();
    let fit = fit_iv(&iv, &names(pr.p)).unwrap();
    assert!(rel_err(&fit.theta, &pr.theta) < 1e-10);
}

/// Gram matrix `R_augᵀ R_aug` (the sign-free content of the factor).
fn gram(acc: &LsAccumulator) -> DMatrix<f64> {
    let r = acc.r_aug();
    r.transpose() * r
}

fn rel_mat(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

#[test]
fn chunked_and_merged_equal_one_shot() {
    let pr = problem(2, 1000, 9, 0.3);
    let (p, m) = (pr.p, pr.m);
    let mut one = LsAccumulator::new(p);
    one.add_rows(&pr.phi, &pr.y, Some(&pr.w)).unwrap();
    let fit_one = fit_ls(&one, &names(p)).unwrap();

    for sizes in [vec![1usize, 7, 50, 333], vec![500], vec![3; 10], vec![999]] {
        // (i) one accumulator fed chunk by chunk, (ii) one accumulator per chunk, merged.
        let mut fed = LsAccumulator::new(p);
        let mut merged = LsAccumulator::new(p);
        let mut start = 0;
        let mut bounds: Vec<usize> = sizes
            .iter()
            .map(|s| {
                start += s;
                start.min(m)
            })
            .collect();
        bounds.push(m);
        let mut lo = 0;
        for &hi in &bounds {
            let (phi, y, w) = (&pr.phi[lo * p..hi * p], &pr.y[lo..hi], &pr.w[lo..hi]);
            fed.add_rows(phi, y, Some(w)).unwrap();
            let mut part = LsAccumulator::new(p);
            part.add_rows(phi, y, Some(w)).unwrap();
            if hi % 2 == 0 {
                part.finish(); // merging flushed and unflushed parts alike
            }
            merged.merge(&part).unwrap();
            lo = hi;
        }
        for acc in [&fed, &merged] {
            assert_eq!(acc.rows(), m);
            assert!(rel_mat(&gram(acc), &gram(&one)) < 1e-12);
            assert!(((acc.sum_wyy() - one.sum_wyy()) / one.sum_wyy()).abs() < 1e-12);
            let fit = fit_ls(acc, &names(p)).unwrap();
            assert!(rel_err(&fit.theta, &fit_one.theta) < 1e-12, "sizes {sizes:?}");
            assert!(((fit.sigma2 - fit_one.sigma2) / fit_one.sigma2).abs() < 1e-12);
            assert!(rel_mat(&fit.covariance, &fit_one.covariance) < 1e-12);
        }
    }

    // IV accumulators merge too (instrument: a noisy copy of phi).
    let mut rng = Rng::new(22);
    let z: Vec<f64> = pr.phi.iter().map(|v| v + 0.5 * rng.normal()).collect();
    let mut one = IvAccumulator::new(p);
    one.add_rows(&pr.phi, &z, &pr.y, Some(&pr.w)).unwrap();
    let mut merged = IvAccumulator::new(p);
    for (lo, hi) in [(0, 1), (1, 400), (400, 401), (401, 1000)] {
        let mut part = IvAccumulator::new(p);
        part.add_rows(&pr.phi[lo * p..hi * p], &z[lo * p..hi * p], &pr.y[lo..hi], Some(&pr.w[lo..hi])).unwrap();
        merged.merge(&part).unwrap();
    }
    let (a, b) = (fit_iv(&one, &names(p)).unwrap(), fit_iv(&merged, &names(p)).unwrap());
    assert!(rel_err(&b.theta, &a.theta) < 1e-12);
    assert!(rel_mat(&b.covariance, &a.covariance) < 1e-12);
    assert!(rel_mat(merged.ztwz(), one.ztwz()) < 1e-12);
}

#[test]
fn qr_least_squares_equals_svd_solution() {
    let pr = problem(3, 200, 6, 1.0);
    let (m, p) = (pr.m, pr.p);
    let mut acc = LsAccumulator::new(p);
    acc.add_rows(&pr.phi, &pr.y, Some(&pr.w)).unwrap();
    let fit = fit_ls(&acc, &names(p)).unwrap();

    let sw: Vec<f64> = pr.w.iter().map(|w| w.sqrt()).collect();
    let a = DMatrix::from_fn(m, p, |i, j| sw[i] * pr.phi[i * p + j]);
    let b = DVector::from_fn(m, |i, _| sw[i] * pr.y[i]);
    let x = a.clone().svd(true, true).solve(&b, 1e-14).unwrap();
    assert!(rel_err(&fit.theta, x.as_slice()) < 1e-12);
    let rss = (&a * &x - &b).norm_squared();
    assert!(((acc.rss() - rss) / rss).abs() < 1e-10);
    assert!(((fit.sigma2 - rss / (m - p) as f64) / fit.sigma2).abs() < 1e-10);
    // covariance = sigma2 (AᵀA)⁻¹
    let cov = (a.transpose() * &a).try_inverse().unwrap() * fit.sigma2;
    assert!(rel_mat(&fit.covariance, &cov) < 1e-10);
    // condition number of R = that of sqrt(W) Phi
    let sv = a.singular_values();
    let cond = sv.max() / sv.min();
    assert!(((fit.condition_number - cond) / cond).abs() < 1e-10);
}

#[test]
fn bad_input_is_rejected_with_the_row_and_leaves_the_accumulator_unchanged() {
    use ivdyn::Error;
    let pr = problem(4, 10, 3, 0.1);
    let mut acc = LsAccumulator::new(3);
    acc.add_rows(&pr.phi[..6], &pr.y[..2], None).unwrap();
    let before = acc.clone();
    let nonfinite = |e: Error| match e {
        Error::Core(ivdyn::core::Error::NonFinite { what, index }) => (what, index),
        e => panic!("unexpected error {e:?}"),
    };
    let mut phi = pr.phi.clone();
    phi[3 * 3 + 1] = f64::NAN;
    assert_eq!(nonfinite(acc.add_rows(&phi, &pr.y, None).unwrap_err()), ("phi", 3));
    let mut y = pr.y.clone();
    y[7] = f64::INFINITY;
    assert_eq!(nonfinite(acc.add_rows(&pr.phi, &y, None).unwrap_err()), ("y", 7));
    let mut w = pr.w.clone();
    w[5] = f64::NAN;
    assert_eq!(nonfinite(acc.add_rows(&pr.phi, &pr.y, Some(&w)).unwrap_err()), ("w", 5));
    w[5] = -1.0;
    assert_eq!(nonfinite(acc.add_rows(&pr.phi, &pr.y, Some(&w)).unwrap_err()), ("w", 5));
    assert!(matches!(acc.add_rows(&pr.phi[..29], &pr.y, None), Err(Error::Dimension { .. })));
    assert!(matches!(acc.add_rows(&pr.phi, &pr.y, Some(&pr.w[..9])), Err(Error::Dimension { .. })));
    assert!(matches!(acc.merge(&LsAccumulator::new(4)), Err(Error::Dimension { .. })));
    let mut iv = IvAccumulator::new(3);
    let mut z = pr.phi.clone();
    z[2 * 3] = f64::NEG_INFINITY;
    assert_eq!(nonfinite(iv.add_rows(&pr.phi, &z, &pr.y, None).unwrap_err()), ("z", 2));
    assert_eq!(iv.rows(), 0);
    assert_eq!(acc, before);
    // zero weights carry no information and do not count as rows
    let mut acc0 = LsAccumulator::new(3);
    acc0.add_rows(&pr.phi, &pr.y, Some(&[0.0; 10])).unwrap();
    assert_eq!(acc0.rows(), 0);
}

/// IV estimate, residuals and covariance against the textbook formulas evaluated
/// directly on the data (explicit inverses are fine in a test).
#[test]
fn iv_matches_direct_formulas() {
    let pr = problem(5, 300, 4, 0.5);
    let (m, p) = (pr.m, pr.p);
    let mut rng = Rng::new(55);
    let z: Vec<f64> = pr.phi.iter().map(|v| v + 0.7 * rng.normal()).collect();
    let mut acc = IvAccumulator::new(p);
    acc.add_rows(&pr.phi, &z, &pr.y, Some(&pr.w)).unwrap();
    let fit = fit_iv(&acc, &names(p)).unwrap();

    let phi = DMatrix::from_row_slice(m, p, &pr.phi);
    let zm = DMatrix::from_row_slice(m, p, &z);
    let w = DMatrix::from_diagonal(&DVector::from_column_slice(&pr.w));
    let y = DVector::from_column_slice(&pr.y);
    let a_inv = (zm.transpose() * &w * &phi).try_inverse().unwrap();
    let theta = &a_inv * (zm.transpose() * &w * &y);
    assert!(rel_err(&fit.theta, theta.as_slice()) < 1e-12);
    let res = &y - &phi * &theta;
    let rss = (res.transpose() * &w * &res)[(0, 0)];
    // the expanded form from the stored statistics: yᵀWy - 2θᵀΦᵀWy + θᵀ RᵀR θ
    let r = acc.ls().r();
    let phity = r.transpose() * acc.ls().qty();
    let expanded = acc.sum_wyy() - 2.0 * theta.dot(&phity) + (&r * &theta).norm_squared();
    assert!(((expanded - rss) / rss).abs() < 1e-8);
    let sigma2 = rss / (m - p) as f64;
    assert!(((fit.sigma2 - sigma2) / sigma2).abs() < 1e-10);
    let cov = &a_inv * (zm.transpose() * &w * &zm) * a_inv.transpose() * sigma2;
    assert!(rel_mat(&fit.covariance, &cov) < 1e-10);
    // LS comparison estimate and the DWH statistic with an explicit pseudo-inverse
    let v_ls = (phi.transpose() * &w * &phi).try_inverse().unwrap() * sigma2;
    let theta_ls = v_ls.clone() / sigma2 * (phi.transpose() * &w * &y);
    assert!(rel_err(fit.theta_ls.as_ref().unwrap(), theta_ls.as_slice()) < 1e-12);
    let d = &theta - &theta_ls;
    let h = (d.transpose() * (&cov - &v_ls).pseudo_inverse(1e-14).unwrap() * &d)[(0, 0)];
    let dwh = fit.dwh.unwrap();
    assert_eq!(dwh.dof, p);
    assert!(((dwh.statistic - h) / h).abs() < 1e-8, "{} vs {h}", dwh.statistic);
    assert!((dwh.p_value - ivdyn::ident::stats::chi2_sf(h, p as f64)).abs() < 1e-8);
}
