//! Special functions and distributions against published table values.

use ivdyn::ident::stats::*;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn ln_gamma_known_values() {
    // Γ(1) = Γ(2) = 1, Γ(1/2) = √π, Γ(5) = 24, Γ(10.5) = 1133278.3889487856
    assert!(ln_gamma(1.0).abs() < 1e-14);
    assert!(ln_gamma(2.0).abs() < 1e-14);
    assert!(rel(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln()) < 1e-14);
    assert!(rel(ln_gamma(5.0), 24f64.ln()) < 1e-14);
    assert!(rel(ln_gamma(10.5), 1_133_278.388_948_785_6f64.ln()) < 1e-13);
    assert!(rel(ln_gamma(0.1), 9.513_507_698_668_732f64.ln()) < 1e-13);
}

#[test]
fn incomplete_gamma_and_beta() {
    // P(1, x) = 1 - e^{-x}; P + Q = 1; I_x(1, 1) = x; I_x(a, b) = 1 - I_{1-x}(b, a)
    for &x in &[0.01, 0.5, 1.0, 3.0, 20.0] {
        assert!((gamma_p(1.0, x) - (1.0 - (-x).exp())).abs() < 1e-14);
        assert!((gamma_p(2.5, x) + gamma_q(2.5, x) - 1.0).abs() < 1e-14);
    }
    for &x in &[0.1, 0.3, 0.7, 0.95] {
        assert!((beta_inc(1.0, 1.0, x) - x).abs() < 1e-14);
        assert!((beta_inc(2.5, 4.0, x) - (1.0 - beta_inc(4.0, 2.5, 1.0 - x))).abs() < 1e-13);
        // I_x(a, 1) = x^a
        assert!((beta_inc(3.0, 1.0, x) - x.powi(3)).abs() < 1e-14);
    }
    // erfc(1) = 0.157299207050285
    assert!(rel(erfc(1.0), 0.157_299_207_050_285_13) < 1e-13);
}

#[test]
fn chi2_quantiles_match_tables() {
    for &(k, q) in &[(1.0, 3.841_459), (5.0, 11.070_498), (10.0, 18.307_038), (30.0, 43.772_972)] {
        let x = chi2_quantile(0.95, k);
        assert!(rel(x, q) < 1e-6, "chi2 0.95 quantile k={k}: {x} vs {q}");
        assert!((chi2_sf(q, k) - 0.05).abs() < 1e-6);
    }
    // 0.99 quantiles: k=1 6.634897, k=4 13.276704
    assert!(rel(chi2_quantile(0.99, 1.0), 6.634_897) < 1e-6);
    assert!(rel(chi2_quantile(0.99, 4.0), 13.276_704) < 1e-6);
    // round trip deep in the tail
    let x = chi2_quantile(1.0 - 1e-10, 3.0);
    assert!(rel(chi2_sf(x, 3.0), 1e-10) < 1e-6);
}

#[test]
fn f_critical_values_match_tables() {
    for &(d1, d2, q) in &[(5.0, 10.0, 3.3258), (1.0, 20.0, 4.3512), (10.0, 100.0, 1.9267)] {
        let x = f_quantile(0.95, d1, d2);
        assert!(rel(x, q) < 1e-4, "F({d1},{d2}) 5% critical value {x} vs {q}");
        assert!((f_sf(q, d1, d2) - 0.05).abs() < 1e-4);
        assert!((f_sf(x, d1, d2) + f_cdf(x, d1, d2) - 1.0).abs() < 1e-14);
    }
    // F(1, d2) = t(d2)²: t_{0.975}(20) = 2.085963
    assert!(rel(f_quantile(0.95, 1.0, 20.0).sqrt(), 2.085_963) < 1e-6);
}

#[test]
fn normal_quantile_matches_tables() {
    assert!(rel(normal_quantile(0.975), 1.959_963_984_540_054) < 1e-12);
    assert!(rel(normal_quantile(0.95), 1.644_853_626_951_472) < 1e-12);
    assert!(rel(normal_quantile(0.995), 2.575_829_303_548_901) < 1e-12);
    assert!(rel(normal_quantile(1e-8), -5.612_001_244_174_789) < 1e-10);
    assert!(normal_quantile(0.5).abs() < 1e-15);
    for &p in &[1e-12, 0.01, 0.3, 0.77, 0.999] {
        assert!((normal_cdf(normal_quantile(p)) - p).abs() < 1e-13 * p.max(1e-3) * 1e3);
    }
}
