//! `ivdyn gains` on a simulated UR5 pair: currents (`tau / g + noise`) in CSV `.i` columns
//! (unloaded) and on an MCAP current topic (loaded, 2 kg payload); the gains that gravity
//! loads come out within 2 % of the simulation's truth, and torque constants are refused.
use crate::util;
use util::*;

use ivdyn::app::{self, SimulateOptions};
use ivdyn::core::rng::Rng;
use ivdyn::report::PayloadSpec;

const GAINS: [f64; 6] = [12.0, 12.5, 11.0, 8.0, 8.5, 7.5];

/// A simulated log of the UR5 fixture with currents instead of torques.
fn current_log(seed: u64, payload: bool) -> ivdyn::log::JointLog {
    let robot = ivdyn::Robot::from_urdf(fixture("ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    let opts = SimulateOptions {
        seed,
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        payload: payload.then_some(PayloadSpec { mass: 2.0, com: [0.01, -0.02, 0.05], inertia: [0.0; 6] }),
        ..Default::default()
    };
    let mut log = app::simulate(&robot, &app::Trajectory::Fourier, &opts).unwrap();
    let tau = log.tau.take().unwrap();
    let mut rng = Rng::new(seed + 100);
    log.current = Some(tau.iter().enumerate().map(|(i, t)| t / GAINS[i % 6] + 0.02 * rng.normal()).collect());
    log
}

#[test]
fn cli_gains_ur5_pair() {
    let d = tmpdir("gains");
    let (u, l, j, j2) = (d.join("unloaded.csv"), d.join("loaded.mcap"), d.join("gains.json"), d.join("refused.json"));
    let (us, ls, js, j2s) = (s(&u), s(&l), s(&j), s(&j2));
    ivdyn::log::write_csv(&u, &current_log(11, false)).unwrap();
    ivdyn::log::write_mcap(&l, &current_log(12, true), &[]).unwrap();
    let logs = ["--unloaded", &us, "--loaded", &ls, "--current-topic", "/ivdyn/current", "--payload-mass", "2"];
    let mut args = logs.to_vec();
    args.extend(["--json", &js]);
    let out = run(ur5_cmd("gains", &args));
    ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}");
    assert!(stdout.contains("identifiable") && stdout.contains("shoulder_lift_joint"), "{stdout}");
    let r = json(&j);
    for k in 1..=3 {
        let g = &r["gains"][k];
        let v = g["value"].as_f64().unwrap_or_else(|| panic!("{g}"));
        assert!((v - GAINS[k]).abs() < 0.02 * GAINS[k], "{g}");
        assert_eq!(g["identifiable"], true);
    }
    assert_eq!(r["loaded"]["current_from"], "motor current");
    // the payload with these gains as the torque constants and their covariance in its std
    // (the joints the pair leaves open: a datasheet 5 % off, with a 10 % std)
    let pj = d.join("payload.json");
    let pjs = s(&pj);
    let datasheet: Vec<String> = GAINS.iter().map(|g| format!("{}", 1.05 * g)).collect();
    let (kt, kt_std) = (datasheet.join(","), "1.0".to_string());
    let args = ["--log", &ls, "--before", &us, "--current-topic", "/ivdyn/current", "--gains", &js];
    let mut with = args.to_vec();
    with.extend(["--torque-constant", &kt, "--torque-constant-std", &kt_std, "--json", &pjs]);
    let out = run(ur5_cmd("payload", &with));
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("the std cover: noise, before model, torque constants"));
    let p = json(&pj);
    let m = p["mass"].as_f64().unwrap();
    assert!((m - 2.0).abs() < 0.03 * 2.0 && (m - 2.0).abs() < 2.5 * p["mass_std"].as_f64().unwrap(), "{p}");
    assert_eq!(p["uncertainty_sources"][2], "torque constants");
    let mut torque = args.to_vec();
    torque.extend(["--effort", "torque"]);
    let err = run(ur5_cmd("payload", &torque));
    assert!(!err.status.success() && String::from_utf8_lossy(&err.stderr).contains("--effort is 'torque'"));
    // the gains are what is estimated: constants are refused, and nothing is written
    let mut args = logs.to_vec();
    args.extend(["--torque-constant", "10", "--json", &j2s]);
    let out = run(ur5_cmd("gains", &args));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--torque-constant is what the drive-gain fit estimates"), "{err}");
    assert!(!j2.exists());
    let _ = std::fs::remove_dir_all(&d);
}
