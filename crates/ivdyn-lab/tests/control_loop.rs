//! The online loop: payload estimate converges, the controller switches, and computed
//! torque with the estimate beats computed torque with the nominal model (Fig. 5).

use ivdyn_lab::control::{Experiment, RunLog, Scheme};

fn mean_rms(r: &RunLog, from: f64) -> f64 {
    let (rms, _) = r.rms_peak(from);
    rms.iter().sum::<f64>() / rms.len() as f64
}

fn window_rms(r: &RunLog, a: f64, b: f64) -> f64 {
    let v: Vec<f64> = r
        .t_all
        .iter()
        .zip(&r.err_all)
        .filter(|(t, _)| **t >= a && **t < b)
        .map(|(_, e)| e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64)
        .collect();
    (v.iter().sum::<f64>() / v.len() as f64).sqrt()
}

/// Shared checks. Tolerances: the mass within 5 % is the criterion (the seeded
/// runs reach 0.1-0.5 %); "beats" is a factor 5 on the mean RMS after the switch plus 0.5 s
/// of settling, where the full example measures 100-130 x on the paper's robot and 75 x on
/// the Panda, so 5 x only fails if the estimate is not used or is wrong; the error after
/// the switch must be 5 x below the error between grasp and switch (measured 100 x).
fn check<const N: usize>(mut exp: Experiment<N>) {
    exp.grasp_time = 1.0;
    exp.duration = 4.0;
    let c = exp.run(Scheme::CtEstimated).unwrap();
    let b = exp.run(Scheme::CtNominal).unwrap();
    let switch = c.switch_time.expect("the controller switched to the estimate");
    let m = exp.columns.iter().position(|&k| k == 0).expect("mass is estimated");
    let dm = c.final_estimate()[m];
    let truth = exp.payload.mass;
    let settle = switch + 0.5;
    let (rc, rb) = (mean_rms(&c, settle), mean_rms(&b, settle));
    let (before, after) = (window_rms(&c, exp.grasp_time, switch), window_rms(&c, settle, f64::INFINITY));
    eprintln!(
        "{}: dm = {dm:.4} kg (truth {truth}), switch {:.3} s after the grasp, RMS after settle: (c) {:.3} mrad, (b) {:.3} mrad; (c) grasp..switch {:.3} mrad",
        exp.name,
        switch - exp.grasp_time,
        1e3 * rc,
        1e3 * rb,
        1e3 * before
    );
    assert!(((dm - truth) / truth).abs() < 0.05, "mass estimate {dm} vs {truth}");
    assert!(settle < exp.duration - 0.5, "switched too late for the check: {switch}");
    assert!(rc * 5.0 < rb, "(c) {rc} does not beat (b) {rb}");
    assert!(after * 5.0 < before, "error did not drop after the switch: {before} -> {after}");
}

#[test]
fn paper_robot_online_payload_and_computed_torque() {
    check(Experiment::paper().unwrap());
}

#[test]
fn panda_online_payload_and_computed_torque() {
    let urdf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/panda.urdf");
    check(Experiment::panda(urdf).unwrap());
}

/// The identifiable set of the last link seen from all joints is all ten inertial
/// parameters on both robots (BaseParams on sampled regressor rows).
#[test]
fn last_link_fully_identifiable_from_all_joints() {
    let b = ivdyn_lab::control::last_link_base(&ivdyn_core::paper::robot(), 40, 1);
    assert_eq!(b.independent, (0..10).collect::<Vec<_>>(), "{:?}", b.names);
}

/// The paper's experiment in full: the nominal model starts 10 % wrong (every mass, COM,
/// inertia and friction value of Table 2, uniform +-10 %), the unloaded arm is identified
/// first (batch IV on 8 s of unloaded tracking), then the payload is estimated online
/// against the identified model. Without the identification step the payload estimate
/// absorbs the prior's errors (NOTES.md: 10-40 % mass bias); with it, the mass must be
/// within 5 % (the criterion).
#[test]
fn paper_robot_payload_after_identifying_the_unloaded_arm() {
    use ivdyn_core::rng::Rng;
    let prior = ivdyn_core::paper::robot_from_table(&ivdyn_lab::repro::perturbed_table(&mut Rng::new(1234), 0.10));
    let exact = Experiment::paper().unwrap();
    let mut with_prior = exact.clone();
    with_prior.nominal = prior.clone();
    let (mut identified, info) = exact.clone().with_identified_nominal(prior, 8.0).unwrap();
    eprintln!(
        "model torque error vs the true unloaded arm, RMS over a period (N m): prior {:?} -> identified {:?} ({} rows, {} base parameters)",
        info.rms_prior.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>(),
        info.rms_identified.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>(),
        info.rows,
        info.fit.theta.len()
    );
    let mass = |exp: &mut Experiment<6>| {
        exp.grasp_time = 1.0;
        exp.duration = 4.0;
        let c = exp.run(Scheme::CtEstimated).unwrap();
        let m = exp.columns.iter().position(|&k| k == 0).expect("mass is estimated");
        c.final_estimate()[m]
    };
    let with_prior_cols = {
        let mut e = with_prior.clone();
        let lb = ivdyn_lab::control::last_link_base(&e.nominal, 40, 7);
        e.columns = lb.independent;
        e
    };
    let dm_prior = mass(&mut with_prior_cols.clone());
    let dm_ident = mass(&mut identified);
    let truth = exact.payload.mass;
    eprintln!("payload mass: prior as nominal {dm_prior:.4} kg, identified nominal {dm_ident:.4} kg (truth {truth})");
    assert!(((dm_ident - truth) / truth).abs() < 0.05, "{dm_ident} vs {truth}");
    // the identified model is closer to the truth overall (a joint whose prior error is
    // below the estimation noise, ~1 mN m on the light wrist, need not improve)
    let total = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(
        total(&info.rms_identified) < 0.5 * total(&info.rms_prior),
        "{:?} vs {:?}",
        info.rms_identified,
        info.rms_prior
    );
}
