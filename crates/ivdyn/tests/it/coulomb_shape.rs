//! Each joint's Coulomb-friction shape chosen by held-out validation, on simulated UR5
//! logs whose friction shape is known: the smooth `tanh(qd / v)` with its scale, the
//! direction-dependent variant, and the paper's exact sign when that is the truth.

use ivdyn::Robot;
use ivdyn::app::identify::CoulombMode;
use ivdyn::app::simulate::{SimulateOptions, Trajectory, simulate};
use ivdyn::app::{IdentifyOptions, IdentifyReport, identify};
use ivdyn::log::JointLog;
use ivdyn_core::CoulombShape;

const FC: [f64; 6] = [2.0, 2.0, 1.5, 0.6, 0.6, 0.4];

fn ur5() -> Robot {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap()
}

/// A 20 s, 500 Hz log of `truth` with friction, 0.05 N m torque noise, a 16-bit encoder
/// and the exact velocity.
fn sim(truth: &Robot, seed: u64) -> JointLog {
    let opts = SimulateOptions {
        duration_s: 20.0,
        seed,
        fc: Some(FC.to_vec()),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        noise_tau: 0.05,
        encoder_bits: Some(16),
        ..Default::default()
    };
    simulate(truth, &Trajectory::Fourier, &opts).unwrap()
}

fn run(robot: &Robot, log: &JointLog, val: &JointLog, coulomb: CoulombMode) -> IdentifyReport {
    let opts = IdentifyOptions { validation_log: Some(val.clone()), coulomb, ..Default::default() };
    identify(robot, log, &opts).unwrap()
}

fn mean_rms(r: &IdentifyReport) -> f64 {
    let v = r.validation.as_ref().unwrap();
    v.rms.iter().sum::<f64>() / v.rms.len() as f64
}

fn with_shapes(shapes: &[CoulombShape]) -> Robot {
    let mut r = ur5();
    r.set_coulomb_shapes(shapes).unwrap();
    r
}

fn show(r: &IdentifyReport) {
    for c in &r.coulomb {
        eprintln!(
            "{:>20}: {:<28} v {:.4} asym {:+.3} held-out RMS {:.4} (sign {:.4})",
            c.joint, c.shape, c.v_scale, c.asym, c.heldout_rms, c.heldout_rms_sign
        );
    }
}

#[test]
fn smooth_friction_is_found_with_its_scale() {
    let v = [0.02, 0.05, 0.1, 0.05, 0.05, 0.05];
    let truth = with_shapes(&v.map(|v_scale| CoulombShape { v_scale, asym: 0.0 }));
    let (log, val) = (sim(&truth, 1), sim(&truth, 2));
    let auto = run(&ur5(), &log, &val, CoulombMode::Auto);
    let sign = run(&ur5(), &log, &val, CoulombMode::Sign);
    show(&auto);
    eprintln!("validation mean RMS: auto {:.4}, sign {:.4}", mean_rms(&auto), mean_rms(&sign));
    for (c, v) in auto.coulomb.iter().zip(v) {
        assert_eq!(c.shape, "smooth", "{}", c.joint);
        // the fine grid is 2^(1/4) apart: the nearest scale is within 9 %, noise adds the rest
        assert!((c.v_scale / v).ln().abs() < 1.5f64.ln(), "{}: v {} (truth {v})", c.joint, c.v_scale);
    }
    // the sign leaves ±fc wherever |qd| < a few v: most of the residual
    assert!(mean_rms(&auto) < 0.2 * mean_rms(&sign));
}

#[test]
fn direction_dependent_friction_is_found() {
    let asym = [0.3, 0.0, 0.3, 0.0, 0.3, 0.0];
    let truth = with_shapes(&asym.map(|asym| CoulombShape { v_scale: 0.05, asym }));
    let (log, val) = (sim(&truth, 3), sim(&truth, 4));
    let auto = run(&ur5(), &log, &val, CoulombMode::Auto);
    let sign = run(&ur5(), &log, &val, CoulombMode::Sign);
    show(&auto);
    eprintln!("validation mean RMS: auto {:.4}, sign {:.4}", mean_rms(&auto), mean_rms(&sign));
    for (c, a) in auto.coulomb.iter().zip(asym) {
        assert!(c.shape.starts_with("smooth"), "{}: {}", c.joint, c.shape);
        assert_eq!(c.shape.ends_with("direction-dependent"), a != 0.0, "{}: {}", c.joint, c.shape);
        // fc± = fc (1 ± asym); fc ~ 0.6-2 N m against 0.05 N m noise: asym to a few hundredths
        assert!((c.asym - a).abs() < 0.05, "{}: asym {} (truth {a})", c.joint, c.asym);
        assert!((c.v_scale / 0.05).ln().abs() < 1.5f64.ln(), "{}: v {}", c.joint, c.v_scale);
    }
    assert!(mean_rms(&auto) < 0.2 * mean_rms(&sign));
}

#[test]
fn exact_sign_friction_keeps_the_sign() {
    let truth = ur5();
    let (log, val) = (sim(&truth, 5), sim(&truth, 6));
    let auto = run(&ur5(), &log, &val, CoulombMode::Auto);
    let sign = run(&ur5(), &log, &val, CoulombMode::Sign);
    show(&auto);
    eprintln!("validation mean RMS: auto {:.4}, sign {:.4}", mean_rms(&auto), mean_rms(&sign));
    for c in &auto.coulomb {
        assert_eq!(c.shape, "sign", "{}: the truth is the exact sign", c.joint);
    }
    assert!(sign.coulomb.is_empty() && sign.notes.iter().all(|n| !n.contains("Coulomb friction shape chosen")));
}

/// The chosen shapes travel with the parameter file: reloaded, the model predicts the
/// validation log as the report says.
#[test]
fn shapes_are_saved_and_reloaded() {
    let truth = with_shapes(&[CoulombShape { v_scale: 0.05, asym: 0.0 }; 6]);
    let (log, val) = (sim(&truth, 7), sim(&truth, 8));
    let r = run(&ur5(), &log, &val, CoulombMode::Auto);
    let file = r.params.coulomb.clone().expect("smooth shapes are written");
    let mut reloaded = ur5();
    ivdyn::robot::load::load_params(&mut reloaded, &r.params).unwrap();
    for (c, f) in reloaded.coulomb_shapes().iter().zip(&file) {
        assert_eq!((c.v_scale, c.asym), (f.v_scale, f.asym));
    }
    // the reloaded model's torque at a slow velocity carries fc tanh(qd / v), not fc sign(qd)
    let (q, qd, qdd) = ([0.1; 6], [0.01; 6], [0.0; 6]);
    let mut sign_model = reloaded.clone();
    sign_model.set_coulomb_shapes(&[CoulombShape::SIGN; 6]).unwrap();
    let (a, b) = (reloaded.rnea(&q, &qd, &qdd).unwrap(), sign_model.rnea(&q, &qd, &qdd).unwrap());
    let fc: Vec<f64> = (0..6).map(|j| r.params.theta[60 + 4 * j]).collect();
    for j in 0..6 {
        let expected = fc[j] * ((0.01 / file[j].v_scale).tanh() - 1.0);
        assert!((a[j] - b[j] - expected).abs() < 1e-9 * (1.0 + expected.abs()), "joint {j}");
    }
}
