//! Issue 15, item 6: `diagnose` on the real TX40 recording (`../shared/data/real`, FIGAROH's
//! example data, 8.9 s at 5 kHz, motor side), starting from its URDF. The log is brought to
//! the joint side by the transmission FIGAROH uses (`tx40_transmission`: gears, the coupled
//! wrist, the joint offsets), as a user's driver would publish it.
//!
//! Expected from physics and the literature, not from this code: an industrial arm's
//! joints carry viscous and Coulomb friction far above the current noise, and rotor
//! inertias (FIGAROH's `TX40_config.yaml`, README of the data: fv 8.05, 5.53, 1.97, 1.11,
//! 1.86, 0.65 N m s/rad; fs 7.14, 8.26, 6.34, 2.48, 3.03, 0.282 N m; Ia 0.362, 0.362,
//! 0.0988, 0.0313, 0.0468, 0.0105 kg m^2, identified with the coupled wrist's motor-6 terms
//! fvm6 0.616, fsm6 1.95, Iam6 0.00964 on `q5 + q6`). Joints 1-4 are compared with the
//! literature; on joints 5 and 6 the per-joint vocabulary has no column for the coupling, so
//! a viscous friction named there reads the joint's own term plus, at most, the coupling's
//! (`fv_j` to `fv_j + fvm6`: docs/diagnose.md, "A real industrial arm").

use ivdyn::diagnose::{DiagnoseOptions, diagnose};
use ivdyn::log::JointLog;
use ivdyn_lab::real::{load_tx40, tx40_transmission};
use std::path::PathBuf;

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/real")
}

#[test]
fn tx40_friction_and_rotor_inertia_are_named() {
    let tx = load_tx40(&root()).unwrap();
    let trans = tx40_transmission();
    let t_len = tx.len();
    let log = JointLog {
        joint_names: tx.robot.joint_names.clone(),
        t0_ns: 0,
        t: (0..t_len).map(|k| k as f64 * tx.dt).collect(),
        q: trans.joint_positions(&tx.q_m).unwrap(),
        qd: None,
        tau: Some(trans.joint_torques(&tx.tau_m).unwrap()),
        u: None,
        current: None,
        truncated: false,
    };
    let d = diagnose(&tx.robot, &log, &DiagnoseOptions::default()).unwrap().json;
    let on = |name: &str| -> Vec<String> {
        d.effects.iter().filter(|e| e.name == name).flat_map(|e| e.joints.clone()).collect()
    };
    let joints = |v: &[usize]| v.iter().map(|j| format!("joint_{j}")).collect::<Vec<_>>();
    // viscous friction on every joint; on joints 1-4 within the 10 % of the
    // literature's, on the wrist between its own term and that plus the coupling's, to 2 std
    assert_eq!(on("viscous_friction"), joints(&[1, 2, 3, 4, 5, 6]), "{:?}", d.effects);
    let visc = d.effects.iter().find(|e| e.name == "viscous_friction").unwrap();
    let (fv, fv_std) = (numbers(&visc.parameters["fv"]), numbers(&visc.parameters_std["fv"]));
    for (i, (f, lit)) in fv.iter().zip([8.05, 5.53, 1.97, 1.11]).enumerate() {
        assert!((f - lit).abs() <= 0.1 * lit, "joint {}: fv {f} vs {lit}", i + 1);
    }
    for (j, lit) in [(4, 1.86), (5, 0.65)] {
        let (lo, hi) = (lit - 2.0 * fv_std[j], lit + 0.616 + 2.0 * fv_std[j]);
        assert!((lo..=hi).contains(&fv[j]), "joint {}: fv {} +- {} vs {lit} (+ 0.616)", j + 1, fv[j], fv_std[j]);
    }
    // Coulomb friction of some shape on each of joints 1-4 (the wrist's may be named too:
    // the literature has fs5 3.03 and fs6 0.282, plus fsm6 1.95 through the coupling)
    let shapes = ["coulomb_friction", "asymmetric_coulomb_friction", "smooth_coulomb_friction", "stribeck_friction"];
    let coulomb: Vec<String> = shapes.iter().flat_map(|s| on(s)).collect();
    for j in joints(&[1, 2, 3, 4]) {
        assert!(coulomb.contains(&j), "no Coulomb friction on {j}: {:?}", d.effects);
    }
    // rotor inertia on joints 1-4, as the literature has it (0.0468 and 0.0105 kg m^2 on the
    // wrist may be too small to name); joint 1's column is the first link's z inertia's,
    // which the nominal re-fit holds: it is named by the size of the re-fit's change there
    // (`diagnose::rotor`), and its value holds link 1's CAD error too (not compared with
    // the literature's 0.362 kg m^2)
    let armature = on("armature");
    for j in joints(&[1, 2, 3, 4]) {
        assert!(armature.contains(&j), "no armature on {j}: {:?}", d.effects);
    }
    // nothing the arm does not have
    assert!(d.effects.iter().all(|e| e.name != "payload"), "{:?}", d.effects);
}

/// Issue 15, item 6 on the KUKA LWR4+ (`../shared/data/real`, FloBaRoID's run 2: 25 s at
/// 200 Hz, link-side joint torque sensors, low-passed by the data set's authors), starting
/// from its URDF, whose `<dynamics>` give every joint friction (0.05-0.8 N m, 0.2-1.2 N m
/// s/rad) that the log contradicts (`diagnose::urdf_friction`). The yardstick is the issue's:
/// the friction `identify`'s held-out validation shows (docs/real-data.md, identified on all
/// three runs with springs and offsets, validated across runs): Coulomb friction on
/// `lwr_1_joint` 0.457 and `lwr_2_joint` 0.538 N m, and on `lwr_4_joint` fc 1.036 with an
/// offset of -0.642 N m, which on that moving joint is direction-dependent friction fc_pos
/// 0.394, fc_neg 1.678 N m. Asserted: those named, each level within 40 % of `identify`'s (a
/// per-run diagnosis with its re-fit against an all-run fit: they differ by up to 31 %, on
/// `lwr_1_joint`), and the detail that says the URDF's friction was left out. With the URDF's
/// friction as the nominal, none was named (docs/diagnose.md, "The URDF's friction").
#[test]
fn lwr_friction_identify_validates_is_named_from_the_urdf() {
    use ivdyn_lab::real::{load_lwr_robot, load_lwr_run};
    let robot = load_lwr_robot(&root()).unwrap();
    let run = load_lwr_run(&root(), 2).unwrap();
    let d = diagnose(&robot, &run.joint_log(&robot.joint_names), &DiagnoseOptions::default()).unwrap();
    let level = |name: &str, key: &str, joint: &str| -> Option<f64> {
        let e = d.json.effects.iter().find(|e| e.name == name)?;
        let i = e.joints.iter().position(|j| j == joint)?;
        e.parameters[key].as_array()?.get(i)?.as_f64()
    };
    let near = |v: Option<f64>, reference: f64, what: &str| {
        let v = v.unwrap_or_else(|| panic!("{what} not named: {:?}", d.json.effects));
        assert!((v - reference).abs() <= 0.4 * reference, "{what}: {v} vs identify's {reference}");
    };
    near(level("coulomb_friction", "fc", "lwr_1_joint"), 0.457, "lwr_1_joint fc");
    near(level("coulomb_friction", "fc", "lwr_2_joint"), 0.538, "lwr_2_joint fc");
    near(level("asymmetric_coulomb_friction", "fc_pos", "lwr_4_joint"), 0.394, "lwr_4_joint fc_pos");
    near(level("asymmetric_coulomb_friction", "fc_neg", "lwr_4_joint"), 1.678, "lwr_4_joint fc_neg");
    assert!(d.details.iter().any(|l| l.contains("the URDF's friction is not the log's")), "{:?}", d.details);
    assert!(d.json.effects.iter().all(|e| e.name != "payload"), "{:?}", d.json.effects);
}

/// The LWR4+ run 1 (another 25 s of the same data set): friction on `lwr_0_joint` and
/// `lwr_2_joint`, where `identify`'s held-out validation shows it (identified on run 1,
/// validated on run 2: friction takes those joints from 0.77 to 0.23 and 0.87 to 0.24 N m;
/// docs/diagnose.md, "A real arm: KUKA LWR4+"), and direction-dependent friction on
/// `lwr_4_joint`. The terminal link's CAD error, fitted once the search is done
/// (`search::with_terminal_cad`), may take only what that light link could make: from
/// 2026-12-05 to 2026-12-06 it took the viscous friction of both joints (1.16 and 1.30 N m
/// s/rad, 0.40 and 0.76 N m RMS, against the link's nominal 0.08 and 0.28 N m there) and
/// `lwr_2_joint` was left with 0.50 N m RMS. Asserted: friction of some shape named on the three joints, and
/// `lwr_2_joint`'s final RMS within 1.5 times `identify`'s cross-run 0.24 N m.
#[test]
fn lwr_run_1_keeps_the_friction_the_terminal_link_cannot_make() {
    use ivdyn_lab::real::{load_lwr_robot, load_lwr_run};
    let robot = load_lwr_robot(&root()).unwrap();
    let run = load_lwr_run(&root(), 1).unwrap();
    let d = diagnose(&robot, &run.joint_log(&robot.joint_names), &DiagnoseOptions::default()).unwrap();
    let shapes = ["coulomb_friction", "viscous_friction", "asymmetric_coulomb_friction", "smooth_coulomb_friction"];
    let friction_on = |joint: &str| {
        d.json.effects.iter().any(|e| shapes.contains(&e.name.as_str()) && e.joints.iter().any(|j| j == joint))
    };
    for joint in ["lwr_0_joint", "lwr_2_joint", "lwr_4_joint"] {
        assert!(friction_on(joint), "{joint}: {:?}", d.json.effects);
    }
    let j2 = robot.joint_names.iter().position(|j| j == "lwr_2_joint").unwrap();
    assert!(d.json.final_rms[j2] <= 1.5 * 0.24, "lwr_2_joint final RMS {}", d.json.final_rms[j2]);
}
