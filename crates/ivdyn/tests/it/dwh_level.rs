//! The level of the Durbin-Wu-Hausman LS-vs-IV test of `identify` on simulated logs where
//! LS is unbiased by construction: the recorded positions and velocities are exact (the
//! regressor carries no noise), white noise sits on the torque only, the nominal model is
//! the true one (the instrument is as good as it gets). Then `H ~ χ²(dof)` and the test
//! must reject at the 1 % level in about 1 % of the logs.
//!
//! Before the fix (Hausman's shortcut `V_IV - V_LS` with iid covariances) the parallel
//! filter's low-pass left the residual autocorrelated and the statistic inflated: mean
//! `H / dof` 1.2 with the automatic decimation and ~10 without decimation (every log
//! rejected). The test runs the whole pipeline (conditioning, parallel filter, automatic
//! decimation, two-step WLS, the nominal-model tracking instrument).

use ivdyn::Robot;
use ivdyn::app::{self, IdentifyOptions, Method, SimulateOptions, Trajectory};
use std::path::PathBuf;

/// A small arm: the UR5's first three joints (base to `forearm_link`).
fn arm() -> Robot {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("forearm_link")).unwrap()
}

/// One simulated log (8 s at 500 Hz, Fourier excitation of `seed`, Coulomb and viscous
/// friction, torque noise 0.1 N m) identified with `method`: its DWH p-value (`None` when
/// no test could be made, e.g. a singular instrument).
fn dwh_p(robot: &Robot, seed: u64, method: Method) -> Option<f64> {
    let o = SimulateOptions {
        rate_hz: 500.0,
        duration_s: 8.0,
        seed,
        fc: Some(vec![2.0, 2.0, 1.5]),
        fv: Some(vec![0.8, 0.8, 0.5]),
        noise_tau: 0.1,
        ..Default::default()
    };
    let log = app::simulate(robot, &Trajectory::Fourier, &o).unwrap();
    let opts = IdentifyOptions { method, ..Default::default() };
    let r = app::identify(robot, &log, &opts).unwrap();
    let d = r.dwh?;
    assert!(d.dof > 0, "seed {seed}: nothing tested ({})", d.verdict);
    if d.ls_biased {
        assert!(d.verdict.contains("differ beyond"), "{}", d.verdict);
    } else {
        assert!(d.verdict.contains("agree within their uncertainty"), "{}", d.verdict);
    }
    Some(d.p_value)
}

/// 200 seeds. Under H0 the rejections at the 1 % level are Binomial(m, 0.01) over the `m`
/// logs tested (m = 200 when every instrument is regular): P(X <= 8) = 0.99979 for
/// m = 200, so at most 8 rejections is a band of more than 99.9 % confidence (the lower
/// end is 0: P(X = 0) = 0.134). And the test must not be dead: the p-values are uniform,
/// the count below 0.5 is Binomial(m, 0.5), sd 7.1 at m = 200; the band 100 ± 24 (3.4 sd)
/// has 99.9 % confidence.
#[test]
fn dwh_holds_its_level_where_ls_is_unbiased() {
    let robot = arm();
    let p: Vec<f64> = (1..=200).filter_map(|seed| dwh_p(&robot, seed, Method::Wls)).collect();
    let m = p.len();
    let (rej1, rej5, below_half) = (
        p.iter().filter(|&&v| v < 0.01).count(),
        p.iter().filter(|&&v| v < 0.05).count(),
        p.iter().filter(|&&v| v < 0.5).count(),
    );
    eprintln!("DWH on {m} unbiased logs: rejections at 1 % {rej1}, at 5 % {rej5}, p < 0.5 in {below_half}");
    assert!(m >= 190, "only {m} of 200 logs had a DWH test");
    assert!(rej1 <= 8, "{rej1} of {m} rejections at the 1 % level (band 0..=8)");
    let mid = m as f64 / 2.0;
    assert!((below_half as f64 - mid).abs() <= 24.0, "{below_half} of {m} p-values below 0.5");
}

/// `--method iv` (the instrument is the simulated identified model, iterated) on the same
/// kind of log: LS is unbiased, so both agree and the verdict keeps LS. 20 seeds: the
/// rejections at 1 % are Binomial(20, 0.01), P(X <= 2) = 0.999.
#[test]
fn iv_with_the_identified_model_agrees_with_ls_where_ls_is_unbiased() {
    let robot = arm();
    let p: Vec<f64> = (1001..=1020).filter_map(|seed| dwh_p(&robot, seed, Method::Iv)).collect();
    let rej1 = p.iter().filter(|&&v| v < 0.01).count();
    eprintln!("IV (identified model): {rej1} of {} rejections at 1 %", p.len());
    assert!(p.len() >= 18 && rej1 <= 2, "{rej1} of {}", p.len());
}
