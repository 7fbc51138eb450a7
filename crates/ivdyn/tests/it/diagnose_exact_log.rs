//! A log without noise (`ivdyn simulate`'s default, a researcher's exact simulation): what
//! the diagnosis's widest model leaves is the conditioning's own error, ~1e-7 of the torque
//! and smooth, and read as noise its autocorrelation time left the F tests a few effective
//! samples: on the test arm (five joints, one prismatic) Coulomb and viscous friction of
//! half a N m on every joint went unnamed and the final residual ended above the nominal one.
//! The noise has a floor of 1e-5 of each joint's nominal torque (`model::NOISE_FLOOR`).

use ivdyn::Robot;
use ivdyn::app::simulate::{SimulateOptions, Trajectory, simulate};
use ivdyn::diagnose::{DiagnoseOptions, diagnose};

const FC: [f64; 5] = [0.5, 0.5, 0.3, 0.5, 0.5];
const FV: [f64; 5] = [0.2; 5];

/// Expected: the true effects on every joint and nothing else, no re-fit (the URDF is the
/// simulation's), the levels to 1e-3 (exact data: what is left is the differentiation's error,
/// ~1e-6 of them) and the residual down to 1e-3 of the nominal one.
#[test]
fn an_exact_log_gets_its_friction_named_on_every_joint() {
    let urdf = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/test_arm.urdf");
    let robot = Robot::from_urdf(urdf, None, Some("link5")).unwrap();
    let opts = SimulateOptions {
        duration_s: 10.0,
        fc: Some(FC.to_vec()),
        fv: Some(FV.to_vec()),
        noise_tau: 0.0,
        ..Default::default()
    };
    let log = simulate(&robot, &Trajectory::Fourier, &opts).unwrap();
    let d = diagnose(&robot, &log, &DiagnoseOptions::default()).unwrap().json;
    let named: Vec<(&str, usize)> = d.effects.iter().map(|e| (e.name.as_str(), e.joints.len())).collect();
    assert_eq!(named, [("coulomb_friction", 5), ("viscous_friction", 5)]);
    assert!(d.nominal_refit.is_none(), "the URDF is the simulation's");
    for (e, truth, key) in [(&d.effects[0], FC, "fc"), (&d.effects[1], FV, "fv")] {
        let got: Vec<f64> = e.parameters[key].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        for (j, (g, t)) in got.iter().zip(truth).enumerate() {
            assert!((g - t).abs() <= 1e-3 * t, "joint {j}: {key} {g} vs {t}");
        }
    }
    for (j, (f, b)) in d.final_rms.iter().zip(&d.baseline_rms).enumerate() {
        assert!(*f <= 1e-3 * b, "joint {j}: final RMS {f} vs nominal {b}");
    }
}
