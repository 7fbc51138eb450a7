//! Batch LS / IV fits: statistical behaviour over seeded Monte Carlo runs, and
//! unexcited parameters. Tolerances follow from the simulated noise (see each test).

use ivdyn::ident::stats::normal_quantile;
use ivdyn::ident::{IvAccumulator, LsAccumulator, fit_iv, fit_ls};
use ivdyn_core::rng::Rng;

fn names(p: usize) -> Vec<String> {
    (0..p).map(|j| format!("theta{j}")).collect()
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// One errors-in-variables data set: `y = θ0 x + θ1 u + θ2 + e` with `e ~ N(0, 0.5²)`,
/// `x, u ~ N(0, 1)`. The regressor uses `x_meas = x + N(0, sx²)`, the instrument for `x`
/// is an independent noisy copy `x + N(0, 0.5²)`; `u` and the constant are their own
/// instruments.
fn eiv_trial(rng: &mut Rng, m: usize, sx: f64, theta: &[f64; 3]) -> IvAccumulator {
    let (mut phi, mut z, mut y) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..m {
        let (x, u) = (rng.normal(), rng.normal());
        let x_meas = x + sx * rng.normal();
        let z_x = x + 0.5 * rng.normal();
        y.push(theta[0] * x + theta[1] * u + theta[2] + 0.5 * rng.normal());
        phi.extend([x_meas, u, 1.0]);
        z.extend([z_x, u, 1.0]);
    }
    let mut acc = IvAccumulator::new(3);
    acc.add_rows(&phi, &z, &y, None).unwrap();
    acc
}

/// Errors in variables, 200 seeded trials of 400 rows, `sx = 0.5`:
/// LS is attenuated by `var(x) / (var(x) + sx²) = 0.8`, a bias of `-0.4` on `θ0 = 2`
/// (~90 standard errors of the 200-trial mean); IV is consistent (first-stage
/// F ~ 1600, finite-sample bias ~ 0.4/F ≈ 2.5e-4, far below 3 standard errors ≈ 0.013).
/// DWH: `H ≈ 0.4² / (V_IV - V_LS) ≈ 100`, so `p < 0.01` in essentially every trial.
/// IV 95 % intervals cover `θ0` in 95 % of trials (binomial sd 1.5 %: band ±4.5 %).
#[test]
fn iv_is_consistent_where_ls_is_biased_and_dwh_detects_it() {
    let theta = [2.0, -1.0, 0.5];
    let mut rng = Rng::new(0xE1F);
    let trials = 200;
    let (mut iv0, mut ls0, mut flagged, mut covered) = (vec![], vec![], 0, 0);
    for _ in 0..trials {
        let acc = eiv_trial(&mut rng, 400, 0.5, &theta);
        let fit = fit_iv(&acc, &names(3)).unwrap();
        let dwh = fit.dwh.unwrap();
        assert_eq!(dwh.dof, 1, "only x is endogenous");
        iv0.push(fit.theta[0]);
        ls0.push(fit.theta_ls.as_ref().unwrap()[0]);
        flagged += dwh.ls_biased as usize;
        covered += ((fit.theta[0] - theta[0]).abs() <= 1.96 * fit.std[0]) as usize;
    }
    let (m_iv, sd_iv) = mean_sd(&iv0);
    let (m_ls, sd_ls) = mean_sd(&ls0);
    let (se_iv, se_ls) = (sd_iv / (trials as f64).sqrt(), sd_ls / (trials as f64).sqrt());
    println!(
        "IV mean {m_iv:.5} (se {se_iv:.5}), LS mean {m_ls:.5} (se {se_ls:.5}), DWH flagged {flagged}/{trials}, IV coverage {covered}/{trials}"
    );
    assert!((m_iv - theta[0]).abs() < 3.0 * se_iv, "IV mean {m_iv} vs {}", theta[0]);
    assert!((m_ls - theta[0]).abs() > 10.0 * se_ls, "LS mean {m_ls} should be biased");
    assert!(flagged as f64 >= 0.95 * trials as f64, "DWH flagged LS bias in {flagged}/{trials}");
    let cov = covered as f64 / trials as f64;
    assert!((0.905..=0.995).contains(&cov), "IV coverage {cov}");
}

/// No measurement noise in the regressor: LS is consistent, H ~ χ²(1) and the DWH test
/// rejects at the 5 % level in Binomial(200, 0.05) trials: mean 10, sd 3.1; the band
/// [1 %, 10 %] = [2, 20] rejections is about ±3 sd.
#[test]
fn dwh_p_value_is_uniform_without_measurement_noise() {
    let theta = [2.0, -1.0, 0.5];
    let mut rng = Rng::new(0xD0E5);
    let trials = 200;
    let mut p_values = Vec::with_capacity(trials);
    for _ in 0..trials {
        let acc = eiv_trial(&mut rng, 400, 0.0, &theta);
        let fit = fit_iv(&acc, &names(3)).unwrap();
        p_values.push(fit.dwh.unwrap().p_value);
    }
    let rejections = p_values.iter().filter(|&&p| p < 0.05).count();
    let below_half = p_values.iter().filter(|&&p| p < 0.5).count();
    println!(
        "DWH without measurement noise: rejections at 5 % {rejections}/{trials}, p < 0.5 in {below_half}/{trials}"
    );
    assert!((2..=20).contains(&rejections), "{rejections} rejections");
    // uniform: median near 0.5 (Binomial(200, 0.5) sd 7: ±25 is ~3.5 sd)
    assert!((75..=125).contains(&below_half), "{below_half} p-values below 0.5");
}

/// Coverage: heteroscedastic Gaussian noise of known sigma_i in [0.1, 0.4], weights
/// `1/sigma_i²`, 400 trials of 100 rows, 4 parameters. With 96 residual dof the
/// `±1.96 std` interval has coverage 94.7 %; the average over 4 parameters of 400
/// trials has sd ≤ 1.1 %, so 95 % ± 3 % holds with > 99 % confidence.
/// Also `sigma2` (the variance of unit-weight noise) averages 1 (sd of the mean ≈ 0.007).
#[test]
fn ls_confidence_intervals_have_nominal_coverage() {
    let p = 4;
    let theta = [1.5, -0.3, 0.0, 4.0];
    let z = normal_quantile(0.975);
    let mut rng = Rng::new(0xC0FE);
    let trials = 400;
    let (mut hits, mut sigma2) = (0usize, vec![]);
    for _ in 0..trials {
        let (mut phi, mut y, mut w) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..100 {
            let row: Vec<f64> = (0..p).map(|_| rng.normal()).collect();
            let sigma = rng.uniform(0.1, 0.4);
            y.push(row.iter().zip(&theta).map(|(a, b)| a * b).sum::<f64>() + sigma * rng.normal());
            w.push(1.0 / (sigma * sigma));
            phi.extend(row);
        }
        let mut acc = LsAccumulator::new(p);
        acc.add_rows(&phi, &y, Some(&w)).unwrap();
        let fit = fit_ls(&acc, &names(p)).unwrap();
        hits += (0..p).filter(|&j| (fit.theta[j] - theta[j]).abs() <= z * fit.std[j]).count();
        sigma2.push(fit.sigma2);
    }
    let coverage = hits as f64 / (trials * p) as f64;
    let (ms2, _) = mean_sd(&sigma2);
    println!("coverage {coverage:.4}, mean sigma2 {ms2:.4}");
    assert!((0.92..=0.98).contains(&coverage), "coverage {coverage}");
    assert!((ms2 - 1.0).abs() < 0.03, "mean sigma2 {ms2}");
}

#[test]
fn unexcited_columns_are_reported_not_invented() {
    let p = 5;
    let theta = [0.7, -2.0, 3.0, 0.25, 1.0];
    let mut rng = Rng::new(77);
    let (mut phi, mut z, mut y) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..120 {
        let mut row: Vec<f64> = (0..p).map(|_| rng.normal()).collect();
        row[2] = 0.0; // parameter 2 is never excited by this data
        y.push(row.iter().zip(&theta).map(|(a, b)| a * b).sum::<f64>());
        z.extend(row.iter().map(|v| v + 0.1 * rng.normal()));
        phi.extend(row);
    }
    let n = names(p);
    let mut acc = LsAccumulator::new(p);
    acc.add_rows(&phi, &y, None).unwrap();
    let fit = fit_ls(&acc, &n).unwrap();
    println!("{fit}");
    assert_eq!(fit.unexcited, vec!["theta2".to_string()]);
    assert_eq!(fit.rank, 4);
    assert!(fit.theta[2].is_nan() && fit.std[2].is_nan());
    for j in [0, 1, 3, 4] {
        assert!((fit.theta[j] - theta[j]).abs() < 1e-10, "theta{j} = {}", fit.theta[j]);
        assert!(fit.std[j].is_finite());
    }
    assert!(fit.condition_number.is_finite());

    let mut iv = IvAccumulator::new(p);
    iv.add_rows(&phi, &z, &y, None).unwrap();
    let fit = fit_iv(&iv, &n).unwrap();
    println!("{fit}");
    assert_eq!(fit.unexcited, vec!["theta2".to_string()]);
    assert!(fit.theta[2].is_nan());
    for j in [0, 1, 3, 4] {
        assert!((fit.theta[j] - theta[j]).abs() < 1e-10);
    }
    // exact data: LS and IV agree, the DWH test has nothing to test
    assert!(!fit.dwh.unwrap().ls_biased);

    // Two columns equal on this data (col 4 = 2 col 0): one is unexcited and the other
    // carries the identifiable combination.
    let phi2: Vec<f64> = phi.chunks(p).flat_map(|r| [r[0], r[1], r[3], 2.0 * r[0]]).collect();
    let y2: Vec<f64> = phi.chunks(p).map(|r| 0.7 * r[0] - 2.0 * r[1] + 0.25 * r[3] + 1.0 * 2.0 * r[0]).collect();
    let mut acc = LsAccumulator::new(4);
    acc.add_rows(&phi2, &y2, None).unwrap();
    let fit = fit_ls(&acc, &names(4)).unwrap();
    assert_eq!(fit.unexcited.len(), 1);
    let combo = if fit.theta[0].is_nan() { fit.theta[3] * 2.0 } else { fit.theta[0] };
    assert!((combo - (0.7 + 2.0)).abs() < 1e-10, "{fit}");
}
