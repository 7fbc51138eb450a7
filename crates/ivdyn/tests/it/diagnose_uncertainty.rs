//! The standard errors of the diagnosis's parameters (`parameters_std`, issue 15 item 3),
//! checked against statistics: over seeded logs with known white torque noise, the true
//! friction lies within one and two standard errors of the estimate as often as a normal
//! estimator's would (68.3 % and 95.4 %).

use ivdyn::Robot;
use ivdyn::app::simulate::{SimulateOptions, Trajectory, simulate};
use ivdyn::diagnose::{DiagnoseOptions, diagnose};

const FC: [f64; 3] = [1.0, 2.0, 1.0];
const FV: [f64; 3] = [0.5, 1.0, 0.5];
const SEEDS: u64 = 40;

/// The first three joints of the UR5 (shoulder pan and lift, elbow): a small arm whose
/// URDF has no friction, so the simulated friction is exactly what the diagnosis misses.
fn ur5_three() -> Robot {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("forearm_link")).unwrap()
}

/// One seeded 4 s log's options: 250 Hz, a 0.5 Hz Fourier motion of 3 harmonics, white
/// torque noise of 0.05 N m.
fn log_options(seed: u64) -> SimulateOptions {
    SimulateOptions {
        rate_hz: 250.0,
        duration_s: 4.0,
        seed,
        base_freq_hz: 0.5,
        harmonics: 3,
        noise_tau: 0.05,
        ..Default::default()
    }
}

/// `(fc, fc_std, fv, fv_std)` per joint of the diagnosis of one seeded 4 s log (250 Hz,
/// exact velocity, white torque noise of 0.05 N m: the friction adds 20-40 noise std).
fn estimate(robot: &Robot, seed: u64) -> Vec<[f64; 4]> {
    let opts = SimulateOptions { fc: Some(FC.to_vec()), fv: Some(FV.to_vec()), ..log_options(seed) };
    let log = simulate(robot, &Trajectory::Fourier, &opts).unwrap();
    let d = diagnose(robot, &log, &DiagnoseOptions { cutoff_hz: Some(20.0), ..Default::default() }).unwrap();
    let mut named: Vec<(&str, usize)> = d.json.effects.iter().map(|e| (e.name.as_str(), e.joints.len())).collect();
    named.sort();
    assert_eq!(named, [("coulomb_friction", 3), ("viscous_friction", 3)], "seed {seed}");
    assert!(d.json.nominal_refit.is_none(), "seed {seed}: the nominal model is exact");
    let get = |name: &str, key: &str| -> (Vec<f64>, Vec<f64>) {
        let e = d.json.effects.iter().find(|e| e.name == name).unwrap();
        let v = |m: &serde_json::Map<String, serde_json::Value>| -> Vec<f64> {
            m[key].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
        };
        (v(&e.parameters), v(&e.parameters_std))
    };
    let ((fc, sc), (fv, sv)) = (get("coulomb_friction", "fc"), get("viscous_friction", "fv"));
    (0..3).map(|j| [fc[j], sc[j], fv[j], sv[j]]).collect()
}

/// 40 seeds x 3 joints x 2 parameters = 240 intervals. Each covers the truth with
/// probability 0.683 (one std) and 0.954 (two) if the standard errors are right. fc and
/// fv of one joint are correlated, so the count's variance is at most twice the binomial
/// one: bounds at 3 such standard deviations (one std: 164 +- 31; two std: at most 25
/// misses of an expected 11). Standard errors 1.5x too large or too small fail the first.
#[test]
fn truth_within_the_standard_errors_at_the_normal_rate() {
    let robot = ur5_three();
    let mut z = vec![];
    for seed in 1..=SEEDS {
        for (j, [fc, sc, fv, sv]) in estimate(&robot, seed).into_iter().enumerate() {
            for (est, std, truth) in [(fc, sc, FC[j]), (fv, sv, FV[j])] {
                assert!(std > 0.0 && std < 0.05 * truth, "seed {seed} joint {j}: {est} +- {std}");
                z.push((est - truth).abs() / std);
            }
        }
    }
    at_normal_rates("fc, fv", &z, 2.0);
}

/// The errors in standard errors `z` fall within one and two of them as often as a normal
/// estimator's would (68.3 % and 95.4 %), to 3 standard deviations of the count: binomial,
/// its variance times `inflation` where intervals are correlated.
fn at_normal_rates(what: &str, z: &[f64], inflation: f64) {
    let n = z.len() as f64;
    let within = |k: f64| z.iter().filter(|&&z| z <= k).count();
    let (within1, within2) = (within(1.0), within(2.0));
    let band = |p: f64| 3.0 * (inflation * n * p * (1.0 - p)).sqrt();
    let (e1, e2) = (0.6827 * n, 0.9545 * n);
    eprintln!("{what}: within 1 std {within1} of {n} (expected {e1:.0}); within 2 std {within2} (expected {e2:.0})");
    assert!((within1 as f64 - e1).abs() <= band(0.6827), "{what}: within 1 std {within1} of {n}");
    assert!(within2 as f64 >= e2 - band(0.9545), "{what}: within 2 std {within2} of {n}");
}

/// Smooth friction `fc tanh(qd / vs)` with `vs` at these fractions of each joint's RMS speed:
/// between the points of the diagnosis's grid (0.15, 0.2, 0.3, 0.4, 0.6), where the fitted
/// scale (`shape_scale`) and its standard error are what is reported.
const VS_SHARE: [f64; 3] = [0.25, 0.35, 0.5];

/// `(vs, vs_std, vs_true)` per joint of one seeded log as `estimate`'s, with smooth friction
/// of levels `FC` added to the measured torque by its formula (exact velocities in the log).
fn estimate_smooth(robot: &Robot, seed: u64) -> Vec<[f64; 3]> {
    let opts = SimulateOptions { write_velocity: true, ..log_options(seed) };
    let mut log = simulate(robot, &Trajectory::Fourier, &opts).unwrap();
    let n = robot.dof();
    let qd = log.qd.clone().unwrap();
    let t_len = log.len();
    let vs: Vec<f64> = (0..n)
        .map(|j| VS_SHARE[j] * ((0..t_len).map(|k| qd[k * n + j].powi(2)).sum::<f64>() / t_len as f64).sqrt())
        .collect();
    for (k, tau) in log.tau.as_mut().unwrap().chunks_mut(n).enumerate() {
        for j in 0..n {
            tau[j] += FC[j] * (qd[k * n + j] / vs[j]).tanh();
        }
    }
    let opts = DiagnoseOptions { cutoff_hz: Some(20.0), drives: Some(true), ..Default::default() };
    let d = diagnose(robot, &log, &opts).unwrap();
    let e = d.json.effects.iter().find(|e| e.name == "smooth_coulomb_friction").expect("smooth friction named");
    assert_eq!(e.joints.len(), 3, "seed {seed}: {:?}", d.json.effects.iter().map(|e| &e.name).collect::<Vec<_>>());
    let v = |x: &serde_json::Value| -> Vec<f64> { x.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    let (est, std) = (v(&e.parameters["vs"]), v(&e.parameters_std["vs"]));
    (0..n).map(|j| [est[j], std[j], vs[j]]).collect()
}

/// 40 seeds x 3 joints = 120 intervals of the smooth friction's fitted `vs`, each covering the
/// truth with probability 0.683 (one std) and 0.954 (two) if the Gauss-Newton standard error
/// is right: bounds at 3 binomial standard deviations (one std: 82 +- 15; two std: at least
/// 108). Errors 1.5x too small or too large fail the first.
#[test]
fn smooth_friction_scale_within_its_standard_error_at_the_normal_rate() {
    let robot = ur5_three();
    let mut z = vec![];
    for seed in 1..=SEEDS {
        for (j, [est, std, truth]) in estimate_smooth(&robot, seed).into_iter().enumerate() {
            assert!(std > 0.0 && std < 0.1 * truth, "seed {seed} joint {j}: vs {est} +- {std}, truth {truth}");
            z.push((est - truth).abs() / std);
        }
    }
    at_normal_rates("smooth friction's vs", &z, 1.0);
}

/// The committed logs whose nominal inertials are off (5-30 %, the nominal re-fit on) and
/// whose effort is a torque: CAD arms, random arms, friction everywhere, wide sweeps,
/// MuJoCo's soft friction, Stribeck friction, a ripple between harmonics.
const CAD_SETS: [&str; 7] = [
    "diagnose_cad",
    "diagnose_random",
    "diagnose_every",
    "diagnose_wide",
    "diagnose_soft_every",
    "diagnose_stribeck",
    "diagnose_ripple_off",
];

/// `(|estimate - truth| / std)` of every parameter of every (effect, joint) named right on
/// the case (a vector parameter, the payload's COM, by component; none without a std).
fn z_of_case(set: &str, case: &serde_json::Value, m: &serde_json::Value) -> Vec<f64> {
    use crate::diagnose_cases::run_with;
    let d = run_with(set, case, m, &DiagnoseOptions::default());
    let scalars = |v: &serde_json::Value| -> Vec<Option<f64>> {
        match v.as_array() {
            Some(a) => a.iter().map(|x| x.as_f64()).collect(),
            None => vec![v.as_f64()],
        }
    };
    let mut z = vec![];
    for t in case["effects"].as_array().unwrap() {
        let Some(e) = d.json.effects.iter().find(|e| e.name == t["name"].as_str().unwrap()) else { continue };
        let tj: Vec<&str> = t["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap()).collect();
        for (k, tv) in t["parameters"].as_object().unwrap() {
            let (Some(ev), Some(sv)) = (e.parameters.get(k), e.parameters_std.get(k)) else { continue };
            let (tv, ev, sv) = (scalars(tv), scalars(ev), scalars(sv));
            // per joint for a joint effect (the named list is over the named joints), per
            // component for the payload's
            let pairs: Vec<(Option<f64>, Option<f64>, Option<f64>)> = if tj.is_empty() {
                (0..tv.len()).map(|i| (tv[i], ev.get(i).copied().flatten(), sv.get(i).copied().flatten())).collect()
            } else {
                tj.iter()
                    .enumerate()
                    .filter_map(|(i, j)| e.joints.iter().position(|x| x == j).map(|p| (tv[i], ev[p], sv[p])))
                    .collect()
            };
            for (t, e, s) in pairs {
                if let (Some(t), Some(e), Some(s)) = (t, e, s)
                    && s > 0.0
                {
                    z.push((e - t).abs() / s);
                }
            }
        }
    }
    z
}

/// On logs with CAD-error inertials the standard errors cannot hold what they leave out (the
/// conditioning's bias, the grid's shapes: docs/diagnose.md, "Uncertainty"), but they hold
/// the fit's spread over the log's blocks and the re-fit's ridge: over the committed torque
/// logs of `CAD_SETS`, the truth lies within two standard errors for 61 of 94 parameters
/// named right (65 %; 60 with the two folds' half difference in place of the blocks);
/// with the noise's covariance alone (before 2026-12-06) it was 45 of 94 (48 %). The bound
/// is half: a drop below it is a regression of what the ± of the report means.
#[test]
fn cad_error_parameters_within_two_standard_errors_at_least_half_the_time() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let mut z = vec![];
    for set in CAD_SETS {
        let mut robots: Vec<_> = std::fs::read_dir(root.join(set)).unwrap().map(|e| e.unwrap().path()).collect();
        robots.sort();
        for dir in robots.iter().filter(|p| p.join("cases.json").exists()) {
            let sub = format!("{set}/{}", dir.file_name().unwrap().to_str().unwrap());
            let m = crate::diagnose_cases::cases_in(&sub);
            for case in m["cases"].as_array().unwrap() {
                let torque = case["sensor"]["torque_constant"].is_null();
                if torque && dir.join(case["log"].as_str().unwrap()).exists() {
                    z.extend(z_of_case(&sub, case, &m));
                }
            }
        }
    }
    let within2 = z.iter().filter(|&&z| z <= 2.0).count();
    eprintln!("CAD-error fixtures: within 2 std {within2} of {}", z.len());
    assert!(z.len() >= 90, "{} parameters named right", z.len());
    assert!(2 * within2 >= z.len(), "within 2 std {within2} of {}", z.len());
}

/// A CAD model's terminal link: its mass and its centre of mass each scaled by these factors
/// (12.5-25 % either way, signs mixed; a CAD export's error, `make_cad_cases.py`'s 25 % level).
const TERMINAL_CAD: [(f64, f64); 8] = [
    (0.20, -0.15),
    (-0.25, 0.20),
    (0.15, 0.25),
    (-0.13, -0.22),
    (0.24, 0.14),
    (-0.18, -0.17),
    (0.22, -0.24),
    (-0.16, 0.19),
];

/// The UR5's first three joints with the forearm's mass scaled by `1 + sm` and its centre of
/// mass by `1 + sc` (inertia about the centre of mass kept).
fn with_terminal_cad_error(robot: &Robot, sm: f64, sc: f64) -> Robot {
    let (mut nominal, mut p) = (robot.clone(), robot.params());
    let n = robot.dof();
    let li = ivdyn_core::LinkInertia(p[10 * (n - 1)..10 * n].try_into().unwrap());
    let (m, c, ic) = li.to_mass_com_inertia(n - 1).unwrap();
    let off = ivdyn_core::LinkInertia::from_mass_com_inertia(
        m * (1.0 + sm),
        &(c * (1.0 + sc)),
        &nalgebra::Matrix3::identity(),
        &ic,
    );
    p[10 * (n - 1)..10 * n].copy_from_slice(&off.0);
    nominal.set_params(&p).unwrap();
    nominal
}

/// A payload is a change of the terminal link, so what the fit calls the payload holds that
/// link's CAD error (`payload_cad`): a 3 kg payload on the UR5's forearm (2.275 kg, its centre
/// of mass 0.25 m out), diagnosed against a nominal forearm off by `TERMINAL_CAD`, 4 s logs
/// with 0.05 N m of white torque noise. The payload's centre of mass is off by up to 86 mm
/// (along the forearm, whose error goes into the payload); the noise alone gave standard
/// errors of 0.05-1 mm (0 of 24 components within 2 of them; 2026-12-06). Now 24 of 24, 21
/// within one: wide across the forearm, since the CAD error is taken as isotropic. A normal
/// estimator has 95 % within 2 std; the three components of a draw share its mass error, so
/// the bound is 18 of 24 (7 misses: 3 of 8 draws all out, probability < 1 % at that rate).
#[test]
fn payload_com_holds_the_terminal_links_cad_error() {
    let truth = ur5_three();
    let payload =
        ivdyn::report::PayloadSpec { mass: 3.0, com: [0.04, -0.03, 0.35], inertia: [0.01, 0.0, 0.01, 0.0, 0.0, 0.01] };
    let mut z = vec![];
    for (k, &(sm, sc)) in TERMINAL_CAD.iter().enumerate() {
        let nominal = with_terminal_cad_error(&truth, sm, sc);
        let opts = SimulateOptions { payload: Some(payload), ..log_options(100 + k as u64) };
        let log = simulate(&truth, &Trajectory::Fourier, &opts).unwrap();
        let d = diagnose(&nominal, &log, &DiagnoseOptions { cutoff_hz: Some(20.0), ..Default::default() }).unwrap();
        let e = d.json.effects.iter().find(|e| e.name == "payload").unwrap_or_else(|| panic!("draw {k}: no payload"));
        let v =
            |x: &serde_json::Value| -> Vec<f64> { x.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        let (com, std) = (v(&e.parameters["com"]), v(&e.parameters_std["com"]));
        eprintln!("draw {k} ({sm}, {sc}): com {com:?} +- {std:?}");
        z.extend((0..3).map(|i| (com[i] - payload.com[i]).abs() / std[i]));
    }
    let within = |k: f64| z.iter().filter(|&&z| z <= k).count();
    let within2 = within(2.0);
    eprintln!("payload COM within 1 std: {}, within 2 std: {within2} of {}", within(1.0), z.len());
    assert!(within2 >= 18, "payload COM within 2 std {within2} of 24: {z:?}");
}
