//! `app::payload` on simulated UR5 logs (exact inverse dynamics plus Gaussian torque noise):
//! the payload reported is a physically possible rigid body, a log without payload gives
//! ~0 kg, a before log of another arm is flagged, and no impossible inertia is written.

use crate::scratch::ScratchFile;
use ivdyn::Robot;
use ivdyn::app::payload::{RIGID_P_VALUE, check_writable};
use ivdyn::app::{self, LogInput, LogSource, PayloadJob, PayloadMode, PayloadOptions, PayloadReport, SimulateOptions};
use ivdyn::log::JointLog;
use ivdyn::report::PayloadSpec;
use std::path::PathBuf;

const UR5: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
const COM: [f64; 3] = [0.01, -0.02, 0.05];
const FC: [f64; 6] = [2.0, 2.0, 1.5, 0.6, 0.6, 0.4];
const FV: [f64; 6] = [0.8, 0.8, 0.5, 0.2, 0.2, 0.1];

fn ur5() -> Robot {
    Robot::from_urdf(UR5, Some("base_link"), Some("tool0")).unwrap()
}

fn tmp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn_payload_physical", name)
}

/// A 20 s, 500 Hz excitation log of `seed`, torque noise `noise` N m.
fn log(robot: &Robot, seed: u64, noise: f64, payload: Option<PayloadSpec>, friction: Option<(f64, f64)>) -> JointLog {
    let opts = SimulateOptions {
        seed,
        noise_tau: noise,
        payload,
        fc: friction.map(|(s, _)| FC.iter().map(|f| s * f).collect()),
        fv: friction.map(|(_, s)| FV.iter().map(|f| s * f).collect()),
        ..Default::default()
    };
    app::simulate(robot, &app::Trajectory::Fourier, &opts).unwrap()
}

fn point_mass(mass: f64) -> PayloadSpec {
    PayloadSpec { mass, com: COM, inertia: [0.0; 6] }
}

fn com_error(rep: &PayloadReport) -> f64 {
    let c = rep.com.unwrap();
    (0..3).map(|k| (c[k] - COM[k]).powi(2)).sum::<f64>().sqrt()
}

/// A 2 kg box-like payload (principal moments 3-5e-3 kg m^2) on a clean log (noise 0.01 N m,
/// inertia std ~2e-4 kg m^2): the least-squares payload is a body already, so the report is
/// that fit, with no distance and no note about constraints.
#[test]
fn payload_with_inertia_is_recovered_as_fitted() {
    let robot = ur5();
    // ivdyn's order [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]: Iyy and Ixz differ in sign and size, so a
    // swapped order anywhere between the simulation and the report fails the 4-std check
    let inertia = [0.004, 0.0002, 0.005, -0.0001, 0.0003, 0.003];
    let spec = PayloadSpec { mass: 2.0, com: COM, inertia };
    let rep = app::payload(&robot, &log(&robot, 3, 0.01, Some(spec), None), None, &PayloadOptions::default()).unwrap();
    let (m, ph) = (rep.mass.unwrap(), rep.physical.as_ref().unwrap());
    assert!((m - 2.0).abs() < 0.03 * 2.0, "mass {m}");
    assert!(com_error(&rep) < 0.01, "com {:?}", rep.com);
    let (i, s) = (rep.inertia.unwrap(), rep.inertia_std.unwrap());
    for k in 0..6 {
        assert!((i[k] - inertia[k]).abs() < 4.0 * s[k], "I[{k}] {} vs {} (std {})", i[k], inertia[k], s[k]);
    }
    assert!(ph.ls_possible && !ph.constraints_active && ph.mahalanobis2 == 0.0, "{ph:?}");
    assert!(!rep.notes.iter().any(|n| n.contains("constraints")), "{:?}", rep.notes);
}

/// A 2 kg point mass: its three second moments about the COM are zero, so the fit's noise
/// (inertia std ~2e-3 kg m^2 at 0.1 N m) makes the least-squares inertia impossible unless
/// all three come out >= 0: about 1/8 of the time if they were independent, so in 6 seeds
/// at least 4 violations with probability 1 - P(Bin(6, 7/8) <= 3) = 0.994. The reported
/// payload is possible in every seed (positive principal moments, strict triangle
/// inequalities), within 3 % and 1 cm, and the truth being a rigid body, the distance is
/// no alarm (p < 1e-3 in one seed in 1000).
#[test]
fn point_mass_least_squares_violates_and_the_report_does_not() {
    let robot = ur5();
    let mut violated = 0;
    for seed in 0..6 {
        let rep =
            app::payload(&robot, &log(&robot, 40 + seed, 0.1, Some(point_mass(2.0)), None), None, &Default::default())
                .unwrap();
        let ph = rep.physical.as_ref().unwrap();
        let (m, v) = (rep.mass.unwrap(), &ph.violation);
        eprintln!(
            "seed {seed}: mass {m:.5} kg, com error {:.2} mm, LS possible {}, LS min eig J {:.2e}, LS triangle {:?}, d2 {:.2}, p {:.3}",
            1e3 * com_error(&rep),
            ph.ls_possible,
            ph.ls_violation.min_eig_pseudo_inertia,
            ph.ls_violation.triangle_margin,
            ph.mahalanobis2,
            ph.p_value
        );
        if !ph.ls_possible {
            violated += 1;
            assert!(ph.constraints_active && ph.ls_violation.min_eig_pseudo_inertia < 0.0);
            assert!(rep.notes.iter().any(|n| n.contains("not a physically possible rigid body")), "{:?}", rep.notes);
        }
        assert!(v.possible && v.min_principal_moment.unwrap() > 0.0 && v.triangle_margin.unwrap() > 0.0, "{v:?}");
        assert!((m - 2.0).abs() < 0.03 * 2.0 && com_error(&rep) < 0.01, "mass {m}, com {:?}", rep.com);
        assert!(ph.p_value > RIGID_P_VALUE, "p {}", ph.p_value);
        let spec = PayloadSpec { mass: m, com: rep.com.unwrap(), inertia: rep.inertia.unwrap() };
        check_writable(&spec, &tmp("never.urdf")).unwrap();
    }
    assert!(violated >= 4, "least squares violated in {violated} of 6 seeds");
}

/// No payload: the least-squares mass is N(0, std), negative half the time (the old code
/// failed then: "not physically realisable"). The consistent mass is >= 0 and, as the mass
/// is the best determined parameter, moved by a fraction of its std: |m| <= 3 std should
/// hold with probability ~0.9973 per seed, so in at least 11 of 12 seeds with probability
/// 1 - P(Bin(12, 0.0027) >= 2) = 0.9995. And a rigid "payload" of 0 kg is no alarm either.
#[test]
fn no_payload_gives_zero_kilograms_without_error() {
    let robot = ur5();
    let (mut within, mut ls_negative) = (0, 0);
    let seeds = 12;
    for seed in 0..seeds {
        let rep = app::payload(&robot, &log(&robot, 60 + seed, 0.1, None, None), None, &Default::default()).unwrap();
        let ph = rep.physical.as_ref().unwrap();
        let (m, s) = (rep.mass.unwrap(), rep.mass_std.unwrap());
        eprintln!(
            "seed {seed}: mass {m:.2e} kg, std {s:.2e}, LS mass {:.2e}, d2 {:.2}",
            ph.ls_params[0], ph.mahalanobis2
        );
        assert!(rep.identifiable && m >= 0.0 && s > 0.0);
        assert!(ph.violation.possible);
        if m.abs() <= 3.0 * s {
            within += 1;
        }
        if ph.ls_params[0] <= 0.0 {
            ls_negative += 1;
            assert!(rep.notes.iter().any(|n| n.starts_with("no payload detected")), "{:?}", rep.notes);
        }
        assert!(ph.p_value > RIGID_P_VALUE, "p {}", ph.p_value);
    }
    eprintln!("|m| <= 3 std in {within} of {seeds} seeds; least-squares mass negative in {ls_negative}");
    assert!(within >= seeds - 1, "{within} of {seeds}");
}

/// A before log of the same arm fits (a false flag has probability 1e-3 by construction);
/// one of the arm with 20 % more friction (a warm arm) leaves 0.1-0.4 N m of Coulomb
/// friction in the after log's residual, against 0.1 N m of noise: flagged, with a note.
#[test]
fn before_log_of_another_arm_is_flagged() {
    let robot = ur5();
    let after = log(&robot, 80, 0.1, Some(point_mass(2.0)), Some((1.0, 1.0)));
    let opts = PayloadOptions::default();
    let same = app::payload(&robot, &after, Some(&log(&robot, 81, 0.1, None, Some((1.0, 1.0)))), &opts).unwrap();
    let c = same.before_check.as_ref().unwrap();
    eprintln!("same arm: ratios {:?}, critical {}", c.variance_ratio, c.critical_ratio);
    assert!(c.fits && c.flagged.is_empty(), "{c:?}");
    assert!((same.mass.unwrap() - 2.0).abs() < 0.03 * 2.0 && com_error(&same) < 0.01);
    let other = app::payload(&robot, &after, Some(&log(&robot, 82, 0.1, None, Some((1.2, 1.2)))), &opts).unwrap();
    let c = other.before_check.as_ref().unwrap();
    eprintln!("other arm: ratios {:?}, critical {}", c.variance_ratio, c.critical_ratio);
    assert!(!c.fits && !c.flagged.is_empty(), "{c:?}");
    assert!(other.notes.iter().any(|n| n.starts_with("the before log does not fit this log")), "{:?}", other.notes);
    // the critical ratio is the F quantile: for ~1000 samples per joint a few per cent above 1
    assert!(c.critical_ratio > 1.0 && c.critical_ratio < 1.5, "{}", c.critical_ratio);
}

/// The guard before a URDF is written: an inertia about the COM with a negative principal
/// moment is refused with an error naming the file, and no file is written.
#[test]
fn an_impossible_payload_is_never_written() {
    let out = tmp("impossible.urdf");
    let bad = PayloadSpec { mass: 2.0, com: COM, inertia: [-0.002, 0.0002, -0.003, 0.0015, 0.002, -0.0003] };
    let e = check_writable(&bad, &out).unwrap_err();
    assert!(matches!(e, ivdyn::Error::PhysicallyInconsistent { .. }), "{e:?}");
    let e = e.to_string();
    assert!(e.contains("writing") && e.contains("impossible.urdf refused") && e.contains("principal moment"), "{e}");
    let flat = PayloadSpec { mass: 2.0, com: COM, inertia: [0.001, 0.0, 0.001, 0.0, 0.0, 0.003] };
    let e = check_writable(&flat, &out).unwrap_err().to_string();
    assert!(e.contains("triangle inequality"), "{e}");
    assert!(check_writable(&PayloadSpec { mass: 0.0, ..flat }, &out).is_err());
    assert!(!out.exists());
    // the job on a point-mass log writes the consistent payload, which passes the guard
    let robot = ur5();
    let written = tmp("point_mass.urdf");
    let job = PayloadJob {
        log: LogInput::Arrays(log(&robot, 44, 0.1, Some(point_mass(2.0)), None)),
        before: None,
        source: LogSource::default(),
        opts: PayloadOptions::default(),
        json: None,
        report: None,
        urdf: Some((PathBuf::from(UR5), written.to_path_buf(), PayloadMode::Link)),
        mjcf: None,
        torque_constant_prior: Default::default(),
    };
    let out = app::payload_job(&robot, &job).unwrap();
    assert!(written.exists() && out.written.iter().any(|w| w.contains("point_mass.urdf")));
    let back = Robot::from_urdf(&written, Some("base_link"), Some("tool0")).unwrap();
    let p = &back.params()[ivdyn_core::params::link_col(5, 0)..ivdyn_core::params::link_col(5, 10)];
    assert!(ivdyn::robot::physical::check_link(p).is_empty(), "{:?}", ivdyn::robot::physical::check_link(p));
}

/// The torque constants' covariance in the payload's ([`PayloadOptions::torque_constant_cov`]):
/// a common 1 % scale error of every constant is a 1 % error of the whole payload (the
/// estimate is homogeneous in the torques), so the mass's variance grows by `(0.01 m)^2`.
#[test]
fn torque_constant_covariance_reaches_the_payload() {
    let robot = ur5();
    let spec = PayloadSpec { mass: 2.0, com: COM, inertia: [0.004, 0.0, 0.005, 0.0, 0.0, 0.003] };
    let before = log(&robot, 5, 0.05, None, Some((1.0, 1.0)));
    let after = log(&robot, 6, 0.05, Some(spec), Some((1.0, 1.0)));
    let run = |cov: Option<Vec<f64>>| {
        let opts = PayloadOptions { torque_constant_cov: cov, ..Default::default() };
        app::payload(&robot, &after, Some(&before), &opts).unwrap()
    };
    let plain = run(None);
    assert_eq!(plain.uncertainty_sources, ["noise", "before model"]);
    let common = run(Some(vec![1e-4; 36]));
    assert_eq!(common.uncertainty_sources, ["noise", "before model", "torque constants"]);
    let (m, s0, s1) = (plain.mass.unwrap(), plain.mass_std.unwrap(), common.mass_std.unwrap());
    let added = (s1 * s1 - s0 * s0).sqrt();
    assert!((added / (0.01 * m) - 1.0).abs() < 0.02, "added mass std {added}, 1 % of the mass {}", 0.01 * m);
    // the same estimate: only its stated uncertainty changed
    assert!((common.mass.unwrap() - m).abs() < 0.5 * s1, "{} vs {m}", common.mass.unwrap());
    let bad = PayloadOptions { torque_constant_cov: Some(vec![1e-4; 35]), ..Default::default() };
    let e = app::payload(&robot, &after, Some(&before), &bad).unwrap_err().to_string();
    assert!(e.starts_with("torque_constant_cov needs 6 x 6"), "{e}");
}
