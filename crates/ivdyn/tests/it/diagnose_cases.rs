//! The model-gap diagnosis on the hidden-effect logs of `fixtures/diagnose/` (MuJoCo as
//! the independent "real robot", docs/diagnose-data.md). Truth and oracle RMS come from
//! the generator's `cases.json`, not from ivdyn.
//!
//! Issue 7's criteria: every single-effect case names exactly its effect on the right
//! joints, clean cases name nothing, the two-effect case names both; final RMS within
//! 1.5x of the oracle RMS on every joint; identified parameters within 10 %.

use std::path::{Path, PathBuf};

use ivdyn::Robot;
use ivdyn::diagnose::{DiagnoseOptions, Diagnosis, DiagnosisJson, EffectKind, diagnose};
use ivdyn::log::{ReadOptions, read_mcap};
use serde_json::Value;

pub(crate) fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub(crate) fn cases_in(set: &str) -> Value {
    let p = root().join("fixtures").join(set).join("cases.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

pub(crate) fn run_in(set: &str, case: &Value, m: &Value) -> DiagnosisJson {
    run_full(set, case, m).json
}

fn run_full(set: &str, case: &Value, m: &Value) -> Diagnosis {
    run_with(set, case, m, &DiagnoseOptions::default())
}

/// A fixture case diagnosed with `opts`.
pub(crate) fn run_with(set: &str, case: &Value, m: &Value, opts: &DiagnoseOptions) -> Diagnosis {
    let urdf = root().join(case["urdf"].as_str().unwrap());
    let robot = Robot::from_urdf(urdf, m["base"].as_str(), m["tip"].as_str()).unwrap();
    let log = read_mcap(
        root().join("fixtures").join(set).join(case["log"].as_str().unwrap()),
        &ReadOptions::new(&robot.joint_names),
    )
    .unwrap();
    let d = diagnose(&robot, &log, opts).unwrap();
    payload_is_a_body(&d.json);
    d
}

/// A fixture case diagnosed as the command line does, default options (`app::diagnose_job`:
/// the log read with the job's log options, as `ivdyn diagnose --log`; a log of motor
/// currents with its torque constants, as the case's `diagnose_args` say).
fn run_job(set: &str, case: &Value, m: &Value) -> Diagnosis {
    use ivdyn::app::{self, DiagnoseJob, Effort, LogInput, LogSource, PerJoint, TorqueConstants};
    let robot =
        Robot::from_urdf(root().join(case["urdf"].as_str().unwrap()), m["base"].as_str(), m["tip"].as_str()).unwrap();
    let source = match case["sensor"]["torque_constant"].as_array() {
        Some(_) => LogSource {
            current_topic: Some("/joint_states".into()),
            effort: Effort::Current,
            torque_constants: TorqueConstants {
                torque_constant: Some(PerJoint::List(f64s(&case["sensor"]["torque_constant"]))),
                ..Default::default()
            },
            ..Default::default()
        },
        None => Default::default(),
    };
    let job = DiagnoseJob {
        log: LogInput::File(root().join("fixtures").join(set).join(case["log"].as_str().unwrap())),
        source,
        opts: DiagnoseOptions::default(),
        out: None,
        report: false,
        json: None,
    };
    app::diagnose_job(&robot, &job, &None).unwrap().report
}

/// A payload's inertia, when reported, is that of a body: principal moments about its
/// centre of mass non-negative and each at most the sum of the other two (eigenvalues of
/// the 3x3 tensor, URDF order `ixx ixy ixz iyy iyz izz`).
pub(crate) fn payload_is_a_body(d: &DiagnosisJson) {
    for e in d.effects.iter().filter(|e| e.name == "payload") {
        if e.parameters["inertia"].is_null() {
            continue;
        }
        let i = f64s(&e.parameters["inertia"]);
        let m = nalgebra::Matrix3::new(i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5]);
        let ev = m.symmetric_eigenvalues();
        let tol = 1e-9 * ev.amax();
        let (a, b, c) = (ev[0], ev[1], ev[2]);
        let body = ev.min() >= -tol && a <= b + c + tol && b <= a + c + tol && c <= a + b + tol;
        assert!(body, "payload inertia {i:?} is not that of a body (principal moments {ev:?})");
    }
}

/// The case `name` of a set's manifest (`cases.json`).
pub(crate) fn case_named<'a>(m: &'a Value, name: &str) -> &'a Value {
    m["cases"].as_array().unwrap().iter().find(|c| c["name"] == name).unwrap_or_else(|| panic!("no case {name}"))
}

pub(crate) fn f64s(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn check_case(name: &str) {
    check_case_in("diagnose", name);
}

fn check_case_in(set: &str, name: &str) -> DiagnosisJson {
    let m = cases_in(set);
    let case = case_named(&m, name);
    let d = run_in(set, case, &m);
    let truth = case["effects"].as_array().unwrap();

    // the JSON's shape (DESIGN.md): joints in URDF order, one RMS per joint
    let joints: Vec<String> = m["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().to_string()).collect();
    assert_eq!(d.joints, joints);
    assert_eq!(d.baseline_rms.len(), d.joints.len());
    assert_eq!(d.final_rms.len(), d.joints.len());

    // exactly the true effects, on the true joints
    let mut named: Vec<(String, Vec<String>)> = d.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    let mut want: Vec<(String, Vec<String>)> = truth
        .iter()
        .map(|e| {
            (
                e["name"].as_str().unwrap().to_string(),
                e["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().to_string()).collect(),
            )
        })
        .collect();
    named.sort();
    want.sort();
    assert_eq!(named, want, "{name}: named {named:?}, truth {want:?}");

    // parameters within 10 % (per joint; q0 = 0 compared in absolute terms, 0.05 rad)
    for te in truth {
        let fe = d.effects.iter().find(|e| e.name == te["name"].as_str().unwrap()).unwrap();
        for (k, tv) in te["parameters"].as_object().unwrap() {
            if fe.name == "payload" && k == "inertia" {
                // not within 10 % on 2 s logs (9.7 % and 29.5 % of its norm; 0.4 % and 5.7 % at
                // 60 s): reported in docs/diagnose.md, not asserted with a tolerance fitted to it
                continue;
            }
            let fv = &fe.parameters[k];
            match tv {
                Value::Number(t) => {
                    let (t, f) = (t.as_f64().unwrap(), fv.as_f64().unwrap());
                    assert!((f - t).abs() <= 0.1 * t.abs(), "{name}: {k} = {f}, truth {t}");
                }
                Value::Array(_) if fe.name == "payload" => {
                    // the COM: within 10 % of its distance from the link origin
                    let (t, f) = (f64s(tv), f64s(fv));
                    let norm = t.iter().map(|x| x * x).sum::<f64>().sqrt();
                    for (a, b) in t.iter().zip(&f) {
                        assert!((a - b).abs() <= 0.1 * norm, "{name}: {k} = {f:?}, truth {t:?}");
                    }
                }
                Value::Array(_) => {
                    let (t, f) = (f64s(tv), f64s(fv));
                    for (i, (a, b)) in t.iter().zip(&f).enumerate() {
                        let tol = if k == "q0" { 0.05 } else { 0.1 * a.abs() };
                        assert!((a - b).abs() <= tol, "{name}: {k}[{i}] = {b}, truth {a}");
                    }
                }
                _ => panic!("unexpected parameter {k}"),
            }
        }
    }

    // the gap shrinks to within 1.5x of what the true effects leave (the oracle)
    let oracle = f64s(&case["oracle"]["oracle_rms_exact"]);
    for (j, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "{name}: joint {j} final RMS {f} vs oracle {o}");
    }
    // and each step lowers the RMS on the joints it names
    for e in &d.effects {
        for jn in &e.joints {
            let j = d.joints.iter().position(|x| x == jn).unwrap();
            assert!(e.rms_after[j] < e.rms_before[j], "{name}: {} did not lower {jn}", e.name);
        }
    }
    d
}

#[test]
fn clean_logs_name_nothing() {
    check_case("clean_a");
    check_case("clean_b");
}

#[test]
fn coulomb_friction() {
    check_case("coulomb");
}

#[test]
fn viscous_friction() {
    check_case("viscous");
}

#[test]
fn armature() {
    check_case("armature");
}

#[test]
fn payload() {
    check_case("payload");
}

#[test]
fn torque_offset() {
    check_case("torque_offset");
}

#[test]
fn joint_spring() {
    check_case("joint_spring");
}

#[test]
fn two_effects_viscous_and_payload() {
    check_case("viscous_payload");
}

#[test]
fn no_velocity_in_the_log() {
    check_case("coulomb_novel");
}

#[test]
fn nominal_inertials_five_percent_off() {
    check_case("inertia5_coulomb");
}

/// Issue 15: nominal URDFs whose link masses, COMs and inertias are 5-30 % off
/// (`fixtures/diagnose_cad`, python/tools/make_cad_cases.py, cases of its tuning part):
/// the re-fit of the nominal model is reported (`nominal_refit`) and exactly the true
/// effects are named, none of the look-alikes the model error used to produce.
#[test]
fn cad_nominal_model_is_refitted() {
    for (set, name) in
        [("diagnose_cad/ur5", "e05_2fx"), ("diagnose_cad/ur5", "e30_0fx"), ("diagnose_cad/ur3", "e15_1fx")]
    {
        let d = check_case_in(set, name);
        let r = d.nominal_refit.as_ref().unwrap_or_else(|| panic!("{set}/{name}: no nominal_refit"));
        let b = &r.base_params;
        assert!(!b.names.is_empty() && b.names.len() == b.nominal.len() && b.values.len() == b.nominal.len());
        // the re-fit alone lowers the residual on the joints it was needed for
        let lowered = r.rms_after.iter().zip(&r.rms_before).filter(|(a, b)| a < b).count();
        assert!(lowered > 0 && !r.why.is_empty(), "{set}/{name}: {r:?}");
    }
}

/// Issue 15: two effects on one joint (`diagnose_cad/panda/e05_2fx`, tuning part, inertials
/// 5 % off: Coulomb friction and an offset on joint 1, Coulomb friction on joint 2, an offset
/// on joint 7). On joint 1 each alone removes only part of the held-out structure and fails
/// the held-out share; the pair is tried once no single candidate is left (`pairs`). Before
/// 2026-12-03 joint 1 was left with 9x its true-model oracle RMS and nothing named there.
#[test]
fn two_effects_on_one_joint() {
    let d = check_case_in("diagnose_cad/panda", "e05_2fx");
    let m = cases_in("diagnose_cad/panda");
    let oracle = f64s(&m["cases"][0]["oracle"]["oracle_rms_true_model"]);
    for (j, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "joint {j}: final RMS {f} vs true-model oracle {o}");
    }
}

/// Issue 15: a 0.66 kg payload on a CAD model whose links are up to 30 % off
/// (`diagnose_cad/talos_arm/e30_2fx`, tuning part; armatures on three joints beside it). On
/// top of the nominal re-fit a payload's mass regroups into the previous link's parameters,
/// which the re-fit holds: the payload is decided by its torque against the terminal link's
/// CAD margin, named, and its mass reported only where it is separable from that link's CAD
/// error (then within 3 of its standard errors of the truth), else null with its centre of
/// mass: never a centre of mass metres from the flange. Before 2026-12-03 the payload was
/// rejected by its unidentifiable fitted mass (0.017 kg) and joint 7 kept 17x its oracle RMS.
#[test]
fn payload_on_a_cad_model() {
    let (set, name) = ("diagnose_cad/talos_arm", "e30_2fx");
    let m = cases_in(set);
    let case = case_named(&m, name);
    let d = run_in(set, case, &m);
    assert!(d.nominal_refit.is_some(), "{name}: no nominal_refit");
    let p = d.effects.iter().find(|e| e.name == "payload").unwrap_or_else(|| panic!("{name}: {:?}", d.effects));
    let truth = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "payload").unwrap();
    match p.parameters["mass"].as_f64() {
        None => assert!(p.parameters["com"].is_null() && p.parameters["inertia"].is_null(), "{p:?}"),
        Some(mass) => {
            let (t, s) = (truth["parameters"]["mass"].as_f64().unwrap(), p.parameters_std["mass"].as_f64().unwrap());
            assert!((mass - t).abs() <= 3.0 * s, "{name}: mass {mass} +- {s}, truth {t}");
        }
    }
    // what is left is what the true effects leave with the true model, within the 1.2x
    // (the armatures are 2.7e-4 kg m^2 on the wrist, below the noise, and on the chain's first
    // joint, where an armature is that link's inertia about its fixed axis: the re-fit's)
    let oracle = f64s(&case["oracle"]["oracle_rms_true_model"]);
    for (j, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.2 * o, "{name}: joint {j} final RMS {f} vs oracle {o}");
    }
}

/// Issue 15: an effect-free log on a CAD model whose links are up to 30 % off
/// (`diagnose_cad/panda/e30_0fx`, tuning part) names nothing. The terminal link's own
/// error stays in the residual beside the re-fit; a payload is named only beyond what a
/// link whose mass and COM are each up to 50 % off makes, 125 % of its nominal torque on
/// a joint. Before 2026-12-03 a payload was named here (its torque 50 % of the terminal
/// link's on `panda_joint7`, the margin then 50 %).
#[test]
fn cad_error_of_the_terminal_link_is_no_payload() {
    check_case_in("diagnose_cad/panda", "e30_0fx");
}

/// Issue 15: on top of the re-fit a payload's mass is not separable from the previous links'
/// (it regroups into their parameters, which the re-fit's ridge holds toward the nominal),
/// so an unpenalised payload takes their CAD errors over. `diagnose_unseen/rarm27_7j/e30_0fx`
/// (random 7-joint arm, 9 s, inertials 30 % off, links 5 and 6 30 % light, no effect) named
/// a 1.84 kg payload on a 1.60 kg terminal link until 2026-12-06: 0.87 N m on joint 5, of
/// which 0.008 N m no re-fitted link makes (0.45 of the same part of the terminal link's
/// nominal torque). Asserted: nothing named, and the payload's row on joint 5 rejected by
/// the margin on that part.
#[test]
fn a_payload_is_weighed_by_what_the_refitted_links_cannot_make() {
    let set = "diagnose_unseen/rarm27_7j";
    let m = cases_in(set);
    let case = case_named(&m, "e30_0fx");
    let d = run_full(set, case, &m);
    assert!(d.json.effects.is_empty(), "{:?}", d.json.effects);
    let payload = d.final_candidates.iter().find(|c| c.effect == EffectKind::Payload).expect("payload scored");
    let why = payload.per_joint[4].rejected_by.as_deref().unwrap_or("significant");
    assert!(why.contains("beyond what the re-fitted links can make"), "{why}");
}

/// A ripple's period fitted at an end of its scanned range is a bound, not an estimate
/// (`ripple_period::AT_END`): `diagnose_unseen/rarm24_6j/e15_2fx` (random 6-joint arm, 11 s,
/// inertials 15 % off; Coulomb friction on joints 1 and 2, ripples of 8, 8 and 4 per turn on
/// joints 1, 5 and 6). Joints 5 and 6 sweep too little for the grid's lower harmonics, so their
/// ripples were read at 12 per turn and fitted down to the range's lower end (9.06 and 11.2 per
/// turn), where they had standard errors of 0.6-0.8 % of periods 12 and 64 % short. Asserted:
/// the three ripples named, no standard error on those two periods, a detail calling each a
/// bound, and the true period at least that bound.
#[test]
fn a_ripple_period_at_the_end_of_its_range_is_a_bound() {
    let set = "diagnose_unseen/rarm24_6j";
    let m = cases_in(set);
    let case = case_named(&m, "e15_2fx");
    let d = run_full(set, case, &m);
    let ripple = d.json.effects.iter().find(|e| e.name == "torque_ripple").expect("ripple named");
    assert_eq!(ripple.joints, ["joint_1", "joint_5", "joint_6"]);
    let truth = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "torque_ripple").unwrap();
    let (period, t) = (f64s(&ripple.parameters["period"]), f64s(&truth["parameters"]["period"]));
    for (i, joint) in [(1, "joint_5"), (2, "joint_6")] {
        assert!(ripple.parameters_std["period"][i].is_null(), "{joint}: {:?}", ripple.parameters_std);
        let note = format!("torque ripple on {joint}: period fitted");
        let why = d.details.iter().find(|l| l.starts_with(&note)).expect("a detail");
        assert!(why.contains("a bound, without a standard error"), "{why}");
        assert!(t[i] >= period[i], "{joint}: true period {} below the bound {}", t[i], period[i]);
    }
}

/// On a log whose stamps were resampled the size rule measures against the sensor's noise
/// (`Signals::sample_noise`): `diagnose_unseen/rarm42_6j/e05_0fx` (random 6-joint arm, 7.6 s,
/// inertials 5 % off, no effect; stamps 0.7-1.3 ms apart, 350 samples re-published stale, no
/// velocity, motor currents). The grid's residual shows 0.70-0.79 of the sensor's noise, and
/// a viscous friction of 0.68 grid noise std was named on joint 1 until 2026-12-06.
/// Asserted: nothing named, and joint 1's viscous friction rejected by the size rule.
#[test]
fn a_jittered_logs_effects_are_sized_against_the_sensors_noise() {
    let set = "diagnose_unseen/rarm42_6j";
    let m = cases_in(set);
    let case = case_named(&m, "e05_0fx");
    let d = run_job(set, case, &m);
    assert!(d.json.effects.is_empty(), "{:?}", d.json.effects);
    let viscous = d.final_candidates.iter().find(|c| c.effect == EffectKind::Viscous).unwrap();
    let why = viscous.per_joint[0].rejected_by.as_deref().unwrap_or("significant");
    assert!(why.starts_with("size:"), "{why}");
}

/// Every fixture set names its files by paths inside the repository (a clean checkout has
/// no generator's scratch directory), and those files are there.
#[test]
fn fixture_sets_name_files_inside_the_repository() {
    let mut sets = vec![];
    for dir in std::fs::read_dir(root().join("fixtures")).unwrap() {
        let dir = dir.unwrap().path();
        sets.push(dir.join("cases.json"));
        if dir.is_dir() {
            sets.extend(std::fs::read_dir(&dir).unwrap().map(|d| d.unwrap().path().join("cases.json")));
        }
    }
    let mut checked = 0;
    for p in sets.into_iter().filter(|p| p.is_file()) {
        let m: Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        let cases = m["cases"].as_array().map(|c| c.as_slice()).unwrap_or(&[]);
        let named = ["robot_urdf", "mujoco_model"].iter().filter_map(|k| m[k].as_str());
        for f in named.chain(cases.iter().filter_map(|c| c["urdf"].as_str())) {
            assert!(Path::new(f).is_relative() && root().join(f).is_file(), "{}: {f}", p.display());
            checked += 1;
        }
    }
    assert!(checked > 40, "{checked} paths");
}

/// Issue 15: without the nominal re-fit too, the terminal link's own CAD error is a
/// look-alike (`diagnose_cad/ur3/e15_2fx`, tuning part, inertials 15 % off: springs on
/// `shoulder_pan_joint` and `elbow_joint`, an offset on `wrist_1_joint`). Before
/// 2026-12-03 that check ran only on top of the re-fit, and an offset was also named on
/// `shoulder_lift_joint`, which the terminal link's error imitates.
/// (Names only: the offset's `tau0`, -0.202 N m against -0.229, is 12 % off with the
/// inertials 15 % off and no re-fit; the parameters' accuracy is in docs/diagnose.md.)
#[test]
fn cad_error_of_the_terminal_link_without_the_refit() {
    let (set, name) = ("diagnose_cad/ur3", "e15_2fx");
    let m = cases_in(set);
    let case = case_named(&m, name);
    let d = run_in(set, case, &m);
    let mut named: Vec<(&str, Vec<&str>)> =
        d.effects.iter().map(|e| (e.name.as_str(), e.joints.iter().map(|j| j.as_str()).collect())).collect();
    named.sort();
    let want =
        vec![("joint_spring", vec!["shoulder_pan_joint", "elbow_joint"]), ("torque_offset", vec!["wrist_1_joint"])];
    assert_eq!(named, want, "{name}");
}

/// Issue 15 item 3: the headline is one sentence of at most 200 characters; every
/// candidate row not named on a joint says which rule rejected it, with its numbers.
#[test]
fn headline_and_rejection_rules() {
    for (set, name) in [("diagnose", "viscous_payload"), ("diagnose_cad/ur5", "e05_2fx")] {
        let m = cases_in(set);
        let case = case_named(&m, name);
        let d = run_full(set, case, &m);
        assert!(d.verdict.chars().count() <= 200, "{}", d.verdict);
        assert!(d.verdict.starts_with("Missing:") && !d.verdict.contains('\n'), "{}", d.verdict);
        let next = d.json.next_command.as_deref().unwrap_or_default();
        assert!(next.starts_with("ivdyn identify --urdf "), "{name}: next command {next:?}");
        let rows = d.steps.iter().flat_map(|s| &s.candidates).chain(&d.final_candidates);
        let mut rejected = 0;
        for c in rows {
            for (j, s) in c.per_joint.iter().enumerate() {
                match &s.rejected_by {
                    None => assert!(s.significant, "{name}: {} joint {j}", c.effect.name()),
                    Some(why) => {
                        rejected += 1;
                        assert!(!s.significant, "{name}: {} joint {j}: {why}", c.effect.name());
                        let rule = ["F test", "held-out share", "size", "sign", "CAD-uncertainty margin", "look-alike"];
                        let named = rule.iter().any(|r| why.starts_with(r));
                        assert!(
                            why.starts_with("not tried") || named && why.chars().any(|ch| ch.is_ascii_digit()),
                            "{name}: {} joint {j}: {why}",
                            c.effect.name()
                        );
                    }
                }
            }
        }
        assert!(rejected > 0, "{name}: nothing rejected");
    }
}

#[test]
fn errors_name_the_problem() {
    let robot = Robot::from_urdf(root().join("fixtures/ur5.urdf"), Some("base_link"), Some("tool0")).unwrap();
    let log = read_mcap(root().join("fixtures/diagnose/clean_a.mcap"), &ReadOptions::new(&robot.joint_names)).unwrap();
    // no torque
    let mut no_tau = log.clone();
    no_tau.tau = None;
    let e = diagnose(&robot, &no_tau, &DiagnoseOptions::default()).unwrap_err().to_string();
    assert!(e.contains("effort"), "{e}");
    // NaN torque: the sample and the joint are named
    let mut nan = log.clone();
    nan.tau.as_mut().unwrap()[500 * 6 + 2] = f64::NAN;
    let e = diagnose(&robot, &nan, &DiagnoseOptions::default()).unwrap_err().to_string();
    assert!(e.contains("500") && e.contains("elbow_joint"), "{e}");
    // too short
    let mut short = log.clone();
    short.t.truncate(40);
    short.q.truncate(40 * 6);
    short.qd.as_mut().unwrap().truncate(40 * 6);
    short.tau.as_mut().unwrap().truncate(40 * 6);
    let e = diagnose(&robot, &short, &DiagnoseOptions::default()).unwrap_err().to_string();
    assert!(e.contains("samples"), "{e}");
}

/// A log with a gap (40 ms of samples missing at 0.7 s: more than `prep::GAP_INTERVALS`
/// sample times) is cut there into two segments, and the diagnosis uses both, each without
/// its filter edges, and names the same effect on the same joints as on the whole log.
/// Before, only the longer segment was used: on jittered 20-60 s logs with re-published
/// samples it lost 16-53 % of them (docs/diagnose.md).
#[test]
fn a_log_with_a_gap_is_diagnosed_on_both_segments() {
    let m = cases_in("diagnose");
    let case = case_named(&m, "coulomb");
    let urdf = root().join(case["urdf"].as_str().unwrap());
    let robot = Robot::from_urdf(urdf, m["base"].as_str(), m["tip"].as_str()).unwrap();
    let path = root().join("fixtures/diagnose").join(case["log"].as_str().unwrap());
    let log = read_mcap(path, &ReadOptions::new(&robot.joint_names)).unwrap();
    let keep: Vec<usize> = (0..log.len()).filter(|&k| !(700..740).contains(&k)).collect();
    let cut = log.rows(&keep);
    let whole = diagnose(&robot, &log, &DiagnoseOptions::default()).unwrap();
    let d = diagnose(&robot, &cut, &DiagnoseOptions::default()).unwrap();
    // each segment loses two time constants of the cutoff at both ends (docs/diagnose.md)
    let trim = (2.0 * d.info.rate / d.info.cutoff_hz).ceil() as usize;
    let (first, second) = (700 - 2 * trim, log.len() - 740 - 2 * trim);
    assert_eq!(d.info.samples, first + second, "cutoff {} Hz", d.info.cutoff_hz);
    let named = |d: &Diagnosis| -> Vec<(String, Vec<String>)> {
        d.json.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect()
    };
    assert_eq!(named(&d), named(&whole));
    let truth: Vec<String> =
        case["effects"][0]["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().into()).collect();
    assert_eq!(named(&d), vec![("coulomb_friction".to_string(), truth)]);
}

/// Issue 15 item 1: an armature whose column is a link's. On the random arm `rarm4_6j` joint
/// 2 turns about an axis perpendicular to joint 1's, so a rotor inertia on joint 2 has the
/// kinetic energy of link 2's axial inertia (`ia qd_2^2 / 2`): the same regressor column on
/// any log, which the nominal re-fit takes (`fixtures/diagnose_random/rarm4_6j/e15_1fx`, of
/// the 5-12 s tuning part: armature 0.689 kg m^2 on joint 2, inertials 15 % off, float32;
/// nothing was named before `diagnose::rotor`). Named by its size: the re-fit's change of that
/// base parameter beyond the CAD margin. Asserted: exactly the true name and joint, the note
/// saying rotor and link inertia are not told apart, `ia` within 10 % of what the log holds
/// there: the rotor inertia plus the true model's change of that base parameter against the
/// nominal (`ZZR_2`, from both URDFs by the base-parameter map the re-fit uses), and the
/// final RMS within 1.5x of the oracle.
#[test]
fn an_armature_the_refit_holds_is_named_by_its_size() {
    use ivdyn::ident::base::robot_base_params_excluding;
    let set = "diagnose_random/rarm4_6j";
    let m = cases_in(set);
    let case = &m["cases"][0];
    let d = run_full(set, case, &m);
    let named: Vec<(String, Vec<String>)> = d.json.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    assert_eq!(named, vec![("armature".to_string(), vec!["joint_2".to_string()])], "{:?}", d.details);
    assert!(d.details.iter().any(|s| s.contains("no log tells rotor from link inertia")), "{:?}", d.details);
    let urdf = |key: &Value| {
        Robot::from_urdf(root().join(key.as_str().unwrap()), m["base"].as_str(), m["tip"].as_str()).unwrap()
    };
    let (nominal, truth) = (urdf(&case["urdf"]), urdf(&m["robot_urdf"]));
    // the re-fit's base parameters: every link but the terminal one (`diagnose::dictionary`)
    let base = robot_base_params_excluding(&truth, 200, 15, true, &(50..60).collect::<Vec<_>>()).unwrap();
    let zz2 = base.independent.iter().position(|&c| c == 10 + 9).expect("link 2's Izz is a base column");
    let p = base.full_cols;
    let change = base.project(&truth.params()[..p]).unwrap()[zz2] - base.project(&nominal.params()[..p]).unwrap()[zz2];
    let ia_true = f64s(&case["effects"][0]["parameters"]["ia"])[0];
    let ia = f64s(&d.json.effects[0].parameters["ia"])[0];
    let held = ia_true + change;
    assert!((ia - held).abs() <= 0.1 * held, "ia {ia}, rotor {ia_true} + link 2's change {change}");
    let oracle = f64s(&case["oracle"]["oracle_rms_exact"]);
    for (j, (f, o)) in d.json.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "joint {j} final RMS {f} vs oracle {o}");
    }
}

/// Issue 15: direction-dependent Coulomb friction where neither Coulomb friction alone nor
/// with an offset passes (`fixtures/diagnose_random/rarm0_6j/e05_3fx`, a random 6-joint arm
/// of the 5-12 s tuning part, inertials 5 % off, motor currents with torque constants, float32;
/// a payload, viscous friction on joints 1 and 4, direction-dependent friction on joints 1
/// and 2: on joint 2 fc_pos 0.22, fc_neg 0.54 N m). It refines Coulomb friction found on a
/// joint, so on joint 2, where Coulomb friction alone fails the held-out share, it was never
/// tried and the pair Coulomb friction + offset came out instead; it is now tried as a pair
/// (`pairs::score_asymmetric`). Asserted: exactly the true names and joints, the levels'
/// signs, and the final RMS within 1.5x of the oracle. Not asserted: the 10 % on every
/// parameter (`fv` on joint 1 is 0.063 against 0.098, `fc_pos` on joint 2 0.178 against
/// 0.220: their columns share the joint's slow motion; docs/diagnose.md). Run with the basic
/// vocabulary, where the pair belongs: on this 6 s log the default also searches the effects
/// of real drives (from 4 s), whose larger all-candidates floor leaves viscous friction on
/// joint 1 at a 73 % held-out share, short of 75 % (docs/diagnose.md, "Effects of real
/// drives from 4 s").
#[test]
fn direction_dependent_friction_as_a_pair() {
    use ivdyn::app::{self, DiagnoseJob, Effort, LogInput, LogSource, PerJoint, TorqueConstants};
    let set = "diagnose_random/rarm0_6j";
    let m = cases_in(set);
    let case = &m["cases"][0];
    let robot =
        Robot::from_urdf(root().join(case["urdf"].as_str().unwrap()), m["base"].as_str(), m["tip"].as_str()).unwrap();
    let k_t = f64s(&case["sensor"]["torque_constant"]);
    let source = LogSource {
        current_topic: Some("/joint_states".into()),
        effort: Effort::Current,
        torque_constants: TorqueConstants { torque_constant: Some(PerJoint::List(k_t)), ..Default::default() },
        ..Default::default()
    };
    let job = DiagnoseJob {
        log: LogInput::File(root().join("fixtures").join(set).join(case["log"].as_str().unwrap())),
        source,
        opts: DiagnoseOptions { drives: Some(false), ..DiagnoseOptions::default() },
        out: None,
        report: false,
        json: None,
    };
    let d = app::diagnose_job(&robot, &job, &None).unwrap().report.json;
    let mut named: Vec<(String, Vec<String>)> = d.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    named.sort();
    let j = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let want = vec![
        ("asymmetric_coulomb_friction".to_string(), j(&["joint_1", "joint_2"])),
        ("payload".to_string(), vec![]),
        ("viscous_friction".to_string(), j(&["joint_1", "joint_4"])),
    ];
    assert_eq!(named, want);
    let asym = d.effects.iter().find(|e| e.name == "asymmetric_coulomb_friction").unwrap();
    let (pos, neg) = (f64s(&asym.parameters["fc_pos"]), f64s(&asym.parameters["fc_neg"]));
    // joint 2 pushes harder backwards than forwards (truth 0.22 / 0.54 N m)
    assert!(pos.iter().chain(&neg).all(|&x| x > 0.0) && neg[1] > 2.0 * pos[1], "{pos:?} {neg:?}");
    let oracle = f64s(&case["oracle"]["oracle_rms_exact"]);
    for (i, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "joint {i}: final RMS {f} vs oracle {o}");
    }
}

/// Issue 15: two effects of real drives on one joint (`fixtures/diagnose_random/rarm5_7j/e05_3fx`,
/// a random 7-joint arm of the 5-12 s tuning part, inertials 5 % off: a torque ripple of
/// period pi/6 rad and a 6.2 ms torque-to-motion delay on joint 3, armatures on joints 4 and
/// 7). On joint 3 the delay alone removed 51 % of the explainable held-out residual and the
/// ripple 37 %, both short of the 75 % share, and pairs were tried over the basic vocabulary
/// only, so neither was named. Pairs now take the single-column drive effects and the ripple
/// on its harmonic grid (`pairs`). Asserted: the required names and joints (the armature on
/// joint 7 makes 0.09 noise std there: it may be named or not), the ripple's period, the
/// delay and the ripple's amplitude within 10 % of truth, and the final RMS within 1.5x of
/// the true-model oracle on every joint.
#[test]
fn two_drive_effects_on_one_joint() {
    let set = "diagnose_random/rarm5_7j";
    let m = cases_in(set);
    let case = &m["cases"][0];
    let d = run_full(set, case, &m).json;
    let named = |e: &str| d.effects.iter().find(|x| x.name == e).map(|x| x.joints.clone());
    assert_eq!(d.effects.len(), 3, "{:?}", d.effects);
    let arm = named("armature").unwrap_or_default();
    assert!(arm.contains(&"joint_4".to_string()) && arm.iter().all(|j| j == "joint_4" || j == "joint_7"), "{arm:?}");
    assert_eq!(named("torque_ripple"), Some(vec!["joint_3".to_string()]));
    assert_eq!(named("time_delay"), Some(vec!["joint_3".to_string()]));
    let truth = |e: &str, p: &str| {
        let t = case["effects"].as_array().unwrap().iter().find(|x| x["name"] == e).unwrap();
        f64s(&t["parameters"][p])[0]
    };
    let got = |e: &str, p: &str| f64s(&d.effects.iter().find(|x| x.name == e).unwrap().parameters[p])[0];
    assert_eq!(got("torque_ripple", "period"), truth("torque_ripple", "period"));
    let amp = |f: &dyn Fn(&str, &str) -> f64| f("torque_ripple", "a").hypot(f("torque_ripple", "b"));
    assert!((amp(&got) / amp(&truth) - 1.0).abs() <= 0.1, "amplitude {} vs {}", amp(&got), amp(&truth));
    let (delay, delay_true) = (got("time_delay", "delay_s"), truth("time_delay", "delay_s"));
    assert!((delay / delay_true - 1.0).abs() <= 0.1, "delay {delay} vs {delay_true}");
    let oracle = f64s(&case["oracle"]["oracle_rms_true_model"]);
    for (j, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "joint {j}: final RMS {f} vs true-model oracle {o}");
    }
}

/// The diagnosis on several threads is the diagnosis on one, bit for bit (`ivdyn::par`: each
/// task runs as it would alone, results in order): `diagnosis.json`, the report's steps
/// and details, and the residual traces of `fixtures/diagnose_random/rarm5_7j/e05_3fx`
/// with `threads` 1 and 2 (this short log would otherwise run on one thread:
/// `PARALLEL_MIN_SAMPLES`; `par` caps the count at the machine's cores, so this needs two,
/// which CI has). And a thread count of 0 is an error naming the option.
#[test]
fn threads_do_not_change_the_diagnosis() {
    let set = "diagnose_random/rarm5_7j";
    let m = cases_in(set);
    let case = &m["cases"][0];
    let with = |threads| run_with(set, case, &m, &DiagnoseOptions { threads: Some(threads), ..Default::default() });
    let (one, two) = (with(1), with(2));
    let json = |d: &Diagnosis| serde_json::to_string(&d.json).unwrap();
    assert_eq!(json(&one), json(&two));
    assert_eq!(one.details, two.details);
    assert_eq!(format!("{:?}", one.steps), format!("{:?}", two.steps));
    assert_eq!(format!("{:?}", one.final_candidates), format!("{:?}", two.final_candidates));
    assert_eq!(format!("{:?}", one.traces), format!("{:?}", two.traces));
    let bad = DiagnoseOptions { threads: Some(0), ..Default::default() };
    let err = bad.check().unwrap_err().to_string();
    assert!(err.contains("threads"), "{err}");
}

/// A log whose candidate columns would pass `max_dictionary_bytes` is diagnosed on blocks
/// spread over it, with a note saying so, not refused and not left to exhaust the memory (a
/// 600 s, 1 kHz, 7-joint log took 6.0 GB before the cap). The UR5 Coulomb log of
/// `fixtures/diagnose/` (2000 samples, 6 joints: up to 8 x 6 x (C_BASE + 50) bytes a sample
/// with the re-fit's columns, 6.1 KB) under an 8 MiB cap keeps two of its four blocks of 500
/// samples, 1000 of the 1974 conditioned, and still names its Coulomb friction on exactly
/// its three joints, each `fc` within 10 % of the generator's (issue 7's criterion). A cap
/// under 1 MiB is an error naming the option.
#[test]
fn a_log_too_long_for_the_memory_cap_is_diagnosed_on_blocks_spread_over_it() {
    let m = cases_in("diagnose");
    let case = case_named(&m, "coulomb");
    let opts = DiagnoseOptions { max_dictionary_bytes: 8 << 20, ..Default::default() };
    let d = run_with("diagnose", case, &m, &opts);
    let note = d.details.iter().find(|x| x.starts_with("log diagnosed on ")).expect("a note on the subsample");
    // two of the conditioned log's (1974 samples) four blocks, over the 8 MiB allowed
    assert!(
        note.starts_with("log diagnosed on 1000 of its 1974 samples: all of them would take up to 11 MiB"),
        "{note}"
    );
    assert!(note.contains("over the 8 MiB allowed"), "{note}");
    let truth = &case["effects"][0];
    let e = d.json.effects.iter().find(|e| e.name == "coulomb_friction").expect("Coulomb friction");
    assert_eq!(d.json.effects.len(), 1, "{:?}", d.json.effects);
    let joints: Vec<&str> = truth["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap()).collect();
    assert_eq!(e.joints, joints);
    for (fc, want) in f64s(&e.parameters["fc"]).iter().zip(f64s(&truth["parameters"]["fc"])) {
        assert!((fc - want).abs() <= 0.1 * want, "fc {fc} vs {want}");
    }
    // the whole log under the default cap: no note
    assert!(
        run_with("diagnose", case, &m, &DiagnoseOptions::default())
            .details
            .iter()
            .all(|x| !x.starts_with("log diagnosed on "))
    );
    let err = DiagnoseOptions { max_dictionary_bytes: 1 << 19, ..Default::default() }.check().unwrap_err().to_string();
    assert!(err.contains("max_dictionary_bytes"), "{err}");
}

/// Issue 15: the size rule counts what a candidate removes beyond the other effects (and
/// the nominal re-fit), not only the torque it adds: a column the re-fit's base columns
/// nearly span can add 0.3 N m RMS and remove 0.005 N m of the residual. Two logs of the
/// random-arm tuning parts, diagnosed as the command line does (`app::diagnose_job`):
/// * `fixtures/diagnose_random_2s/rarm6_6j/e05_0fx` (2 s, no effect, inertials 5 % off,
///   jittered stamps with 98 re-published samples, float32, no velocity): offsets on joints
///   2 and 4 were named (0.14 and -0.02 N m); the model the nominal re-fit is decided with
///   (every candidate that passes the rules) no longer takes them, and the re-fit then
///   explains what they did;
/// * `fixtures/diagnose_random/rarm5_7j/e30_2fx` (9 s, inertials 30 % off): Coulomb friction
///   on joint 6 and smooth friction on joint 7, and viscous friction on joint 7 beside them
///   (removing 0.4 noise std) was named too.
///
/// Asserted: exactly the true names and joints (both fail on the previous binary).
#[test]
fn a_candidate_the_other_effects_hold_is_not_named() {
    let named = |d: &Diagnosis| {
        let mut v: Vec<(String, Vec<String>)> =
            d.json.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
        v.sort();
        v
    };
    let (set, m) = ("diagnose_random_2s/rarm6_6j", cases_in("diagnose_random_2s/rarm6_6j"));
    let case = &m["cases"][0];
    assert!(case["effects"].as_array().unwrap().is_empty());
    let d = run_job(set, case, &m);
    assert_eq!(named(&d), vec![], "{:?}", d.details);

    let (set, m) = ("diagnose_random/rarm5_7j", cases_in("diagnose_random/rarm5_7j"));
    let case = case_named(&m, "e30_2fx");
    let d = run_job(set, case, &m);
    let mut truth: Vec<(String, Vec<String>)> = case["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            let j = e["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().to_string()).collect();
            (e["name"].as_str().unwrap().to_string(), j)
        })
        .collect();
    truth.sort();
    assert_eq!(named(&d), truth, "{:?}", d.details);
}

/// Issue 15 ("90 % of identified parameters within 10 %"): load-dependent friction's `mu` is
/// read against the load the final fit models (the nominal torque corrected by the re-fit's
/// base corrections, `drive_rules::load_mu_on_fitted_load`), not against the CAD model's
/// torque, which is 15 % off here: `fixtures/diagnose_random/rarm0_6j/e15_2fx` (tuning part,
/// 7 s, inertials 15 % off; load-dependent friction mu 0.0707 on joint 4, smooth friction on
/// joints 2, 3 and 6). The nominal load gave 0.0598 (15 % low). Asserted: load-dependent
/// friction named on joint 4 and its `mu` within 10 % of truth.
#[test]
fn load_dependent_friction_against_the_fitted_load() {
    let (mu, mu_true, _) =
        found_and_true("diagnose_random/rarm0_6j", "e15_2fx", "load_dependent_friction", "mu", "joint_4");
    assert!((mu - mu_true).abs() <= 0.1 * mu_true, "mu {mu} vs truth {mu_true}");
}

/// Issue 15 (item 2, friction shapes decided per joint on held-out data): load-dependent
/// friction competes with Coulomb and smooth friction without refining them, and the forward
/// step adds whichever explains most at its step; the search then tries the other shape in
/// its place (`diagnose::swap`). Same case as above: smooth friction on joints 2, 3 and 6,
/// load-dependent friction on joint 4; load-dependent friction was named on joints 2 and 3
/// before the swap. Asserted: exactly the true names on the true joints, and the swapped
/// joints' smooth friction level within 10 % of truth.
#[test]
fn friction_shape_decided_on_heldout_data() {
    let (case, d, names) = named_in("diagnose_random/rarm0_6j", "e15_2fx");
    let joints = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let mut names = names;
    names.sort();
    assert_eq!(
        names,
        vec![
            ("load_dependent_friction".to_string(), joints(&["joint_4"])),
            ("smooth_coulomb_friction".to_string(), joints(&["joint_2", "joint_3", "joint_6"])),
        ]
    );
    let fc = f64s(&d.effects.iter().find(|e| e.name == "smooth_coulomb_friction").unwrap().parameters["fc"]);
    let fc_true = f64s(&case["effects"][0]["parameters"]["fc"]);
    for (k, (a, b)) in fc.iter().zip(&fc_true).take(2).enumerate() {
        assert!((a - b).abs() <= 0.1 * b, "joint {}: fc {a} vs truth {b}", [2, 3][k]);
    }
}

/// Issue 15 (item 2, smooth friction): a refinement of Coulomb friction is scored against a
/// model that already has Coulomb friction on its joint and needs `REFINEMENT_SHARE` (0.8) of
/// the held-out share there (`score::Ctx::refinement_share`): `fixtures/diagnose_random/
/// rarm0_6j/e15_2fx` (as above), whose joint 6 carries smooth friction fc 0.1034 N m, vs
/// 0.139 rad/s. At the full share nothing was named on joint 6. Asserted: smooth friction
/// named on joint 6, its `fc` within 10 % of truth (a noise-free property of the friction
/// level; `vs` is read from a grid and is not asserted).
#[test]
fn a_refinement_of_coulomb_friction_at_its_own_share() {
    let (fc, fc_true, joints) =
        found_and_true("diagnose_random/rarm0_6j", "e15_2fx", "smooth_coulomb_friction", "fc", "joint_6");
    assert!(joints.contains(&"joint_6".to_string()));
    assert!((fc - fc_true).abs() <= 0.1 * fc_true, "fc {fc} vs truth {fc_true}");
}

/// Issue 15 (item 2, direction-dependent friction): the refinement is scored with the
/// joint's stuck samples apart (`score::rest_apart`, the stick column in both models), so the
/// reversals' stick-slip, which no friction level holds, does not count as structure it
/// leaves: `fixtures/diagnose_unseen/rarm36_6j/e15_2fx` (tuning part of the arms rarm36-47,
/// 11 s, inertials 15 % off; direction-dependent friction fc_pos 0.367, fc_neg 0.067 N m on
/// joint 5 and a 1.79 kg payload). Before, the asymmetry removed under the 60 % a refinement
/// needs and Coulomb friction 0.214 N m was named. Asserted: exactly the true effects (the
/// payload and direction-dependent friction on joint 5), both levels within 10 % of truth.
#[test]
fn a_direction_dependent_friction_read_apart_from_the_stuck_samples() {
    let (set, m) = ("diagnose_unseen/rarm36_6j", cases_in("diagnose_unseen/rarm36_6j"));
    let case = case_named(&m, "e15_2fx");
    let d = run_job(set, case, &m).json;
    let names: Vec<_> = d.effects.iter().map(|e| (e.name.as_str(), e.joints.clone())).collect();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names.contains(&("payload", vec![])), "{names:?}");
    for p in ["fc_pos", "fc_neg"] {
        let (x, x_true, joints) = found_and_true(set, "e15_2fx", "asymmetric_coulomb_friction", p, "joint_5");
        assert_eq!(joints, ["joint_5"]);
        assert!((x - x_true).abs() <= 0.1 * x_true, "{p} {x} vs truth {x_true}");
    }
}

/// Physics over the whole model, not only the candidate: an effect added beside one it is
/// correlated with must not push that one's level through zero. `fixtures/diagnose_random/
/// rarm9_7j/e05_3fx` (tuning part, 5 % CAD error, jittered and re-published currents;
/// direction-dependent friction fc_pos 0.149, fc_neg 0.042 N m on joint 7): viscous friction
/// added there last took the friction backward to fc_neg -0.0053 N m, which was reported.
/// Since 2026-12-07 (frictions held out beside the terminal link's own CAD error,
/// `Ctx::terminal_cad_in`) smooth friction comes in on joint 7 before any viscous friction
/// could, the viscous friction never does, and the sign rule has nothing to take out here (nor
/// on any of the 463 logs scored that day; docs/diagnose.md "Frictions scored beside the
/// terminal link's CAD error"): joint 7's friction is named smooth, a miss. Asserted: every
/// reported friction level, `fv`, `ia`, `k`, `mu` and delay positive (the friction opposes
/// the motion in both directions), and no viscous friction on joint 7.
#[test]
fn no_effect_pushes_another_through_zero() {
    let (set, m) = ("diagnose_random/rarm9_7j", cases_in("diagnose_random/rarm9_7j"));
    let case = case_named(&m, "e05_3fx");
    let d = run_job(set, case, &m);
    let levels = ["fc", "fc_pos", "fc_neg", "fv", "ia", "k", "mu", "delay_s"];
    for e in &d.json.effects {
        for (p, v) in e.parameters.iter().filter(|(p, _)| levels.contains(&p.as_str())) {
            for (j, x) in e.joints.iter().zip(f64s(v)) {
                assert!(x > 0.0, "{} {p} on {j}: {x}", e.name);
            }
        }
    }
    let on = |name: &str| d.json.effects.iter().find(|e| e.name == name).map(|e| e.joints.clone()).unwrap_or_default();
    assert!(!on("viscous_friction").contains(&"joint_7".to_string()), "{:?}", d.details);
}

/// Issue 15 ("90 % of identified parameters within 10 %"): Coulomb friction's level is read
/// where the joint moves (`levels::coulomb_levels`): a joint that reverses sticks for a while
/// (MuJoCo's friction loss holds it, as a real drive's static friction does), and there the
/// friction is whatever balances the drive, not `fc sign(qd)`.
/// `fixtures/diagnose_random/rarm6_6j/e05_2fx` (tuning part, 5 s, inertials 5 % off; Coulomb
/// friction 0.130, 0.121, 0.113 N m on joints 3, 5, 6, armatures on joints 3 and 4): on all
/// samples joint 6 read 0.0968 (14 % low). Asserted: Coulomb friction on exactly joints 3, 5,
/// 6, each `fc` within 10 % of truth.
#[test]
fn coulomb_friction_where_the_joint_moves() {
    let (set, m) = ("diagnose_random/rarm6_6j", cases_in("diagnose_random/rarm6_6j"));
    let case = case_named(&m, "e05_2fx");
    let d = run_job(set, case, &m).json;
    let e = d.effects.iter().find(|e| e.name == "coulomb_friction").unwrap();
    let truth = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "coulomb_friction").unwrap();
    let joints: Vec<String> =
        truth["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().to_string()).collect();
    assert_eq!(e.joints, joints);
    for (fc, fc_true) in f64s(&e.parameters["fc"]).into_iter().zip(f64s(&truth["parameters"]["fc"])) {
        assert!((fc - fc_true).abs() <= 0.1 * fc_true, "fc {fc} vs truth {fc_true}");
    }
}

/// A tuning-part fixture case diagnosed as the command line does: parameter `p` of `effect`
/// on `joint` as found and as true, and the joints the effect was named on (panics, with
/// the names, when it was not named on `joint`).
fn found_and_true(set: &str, case: &str, effect: &str, p: &str, joint: &str) -> (f64, f64, Vec<String>) {
    let m = cases_in(set);
    let case = case_named(&m, case);
    let d = run_job(set, case, &m).json;
    let names: Vec<_> = d.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    let e = d.effects.iter().find(|e| e.name == effect).unwrap_or_else(|| panic!("{names:?}"));
    let at = e.joints.iter().position(|j| j == joint).unwrap_or_else(|| panic!("{names:?}"));
    let truth = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == effect).unwrap();
    let tj = truth["joints"].as_array().unwrap().iter().position(|j| j == joint).unwrap();
    (f64s(&e.parameters[p])[at], f64s(&truth["parameters"][p])[tj], e.joints.clone())
}

/// Issue 15 ("90 % of identified parameters within 10 %"): a time delay is reported from the
/// exact shift of the fitted rigid-body torque, `tau(t - delay) - tau(t)`, not from the
/// search's first-order column `-delay tau'`, which reads it short by `(w delay)^2 / 6` at
/// each frequency `w` of the torque (`drive_rules::delay_exact`):
/// `fixtures/diagnose_random/rarm6_6j/e30_3fx` (tuning part, 5 s, inertials 30 % off; a
/// delay of 7.09 ms on joint 1, torque gains on joints 1 and 2, springs on joints 1 and 3).
/// The first order gave 6.14 ms (13 % short). Asserted: the delay named on joint 1 and within
/// 10 % of truth. Not asserted: the gains (a known miss, docs/diagnose.md).
#[test]
fn a_time_delay_from_the_exact_shift() {
    let (delay, delay_true, joints) =
        found_and_true("diagnose_random/rarm6_6j", "e30_3fx", "time_delay", "delay_s", "joint_1");
    assert_eq!(joints, vec!["joint_1".to_string()]);
    assert!((delay - delay_true).abs() <= 0.1 * delay_true, "delay {delay} vs truth {delay_true}");
}

/// Issue 15 (item 1, look-alikes): the terminal link's CAD error imitates a candidate off the
/// terminal joint only if its change, fitted to every joint's row, removes as much of the
/// held-out residual of all joints as the candidate does (`rules::terminal_error_lookalike`).
/// `fixtures/diagnose_random/rarm10_6j/e05_1fx` (tuning part, 9 s, inertials 5 % off; torque
/// gains k 0.892 on joint 1 and 1.072 on joint 2): the gain on joint 1 (1.07 N m RMS, 17
/// noise std) was rejected as that link's CAD error, which took it from joint 1's row at the
/// other rows' cost, and 0.33 N m stayed on joint 1 (5 noise std); the gain on joint 2 read
/// k 1.124. Asserted: exactly the truth named, each `k - 1` within 10 % of truth, and joint
/// 1's final RMS within 20 % of the generator's oracle (the true effects on the nominal
/// model).
#[test]
fn a_gain_the_terminal_link_takes_only_from_its_own_row() {
    let (case, d, names) = named_in("diagnose_random/rarm10_6j", "e05_1fx");
    assert_eq!(names, vec![("torque_gain".to_string(), vec!["joint_1".to_string(), "joint_2".to_string()])]);
    let (k, k_true) = (f64s(&d.effects[0].parameters["k"]), f64s(&case["effects"][0]["parameters"]["k"]));
    for (x, t) in k.iter().zip(&k_true) {
        assert!(((x - 1.0) - (t - 1.0)).abs() <= 0.1 * (t - 1.0).abs(), "k {k:?} vs truth {k_true:?}");
    }
    let oracle = f64s(&case["oracle"]["oracle_rms_exact"]);
    assert!(d.final_rms[0] <= 1.2 * oracle[0], "final {} vs oracle {}", d.final_rms[0], oracle[0]);
}

/// Issue 15 (item 1, "never let the re-fit absorb a real effect"; the issue's "a
/// direction-dependent Coulomb friction comes out as Coulomb + offset"): the re-fit's ridge is
/// the smaller of the choices with and without an offset on every joint in the base
/// (`refit::ridge_of_either_base`). `fixtures/diagnose_random/rarm10_6j/e15_1fx` (tuning
/// part, 8 s, inertials 15 % off; direction-dependent friction fc_pos 1.281, fc_neg 0.249 N m
/// on joint 3): the ridge chosen on friction alone was 1e-2, a stiff re-fit bent toward the
/// asymmetry's constant, and Coulomb friction + an offset were named there. Asserted:
/// exactly direction-dependent friction on joint 3, `fc_pos` within 10 % of truth (`fc_neg`,
/// 35 % low, is not: the smaller level sits on the joint's stick phases).
#[test]
fn direction_dependent_friction_beside_a_looser_refit() {
    let (case, d, names) = named_in("diagnose_random/rarm10_6j", "e15_1fx");
    assert_eq!(names, vec![("asymmetric_coulomb_friction".to_string(), vec!["joint_3".to_string()])]);
    assert!(d.nominal_refit.is_some());
    let (fc, fc_true) =
        (f64s(&d.effects[0].parameters["fc_pos"])[0], f64s(&case["effects"][0]["parameters"]["fc_pos"])[0]);
    assert!((fc - fc_true).abs() <= 0.1 * fc_true, "fc_pos {fc} vs truth {fc_true}");
}

/// A fixture case of `set` diagnosed as the command line does: the case, its diagnosis and
/// the (effect, joints) named.
fn named_in(set: &str, name: &str) -> (Value, DiagnosisJson, Vec<(String, Vec<String>)>) {
    let m = cases_in(set);
    let case = case_named(&m, name).clone();
    let d = run_job(set, &case, &m).json;
    let names = d.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    (case, d, names)
}

/// The case's true effects and their joints; asserted: every named (effect, joint) among them.
fn named_within_truth(
    case: &Value,
    names: &[(String, Vec<String>)],
) -> std::collections::BTreeMap<String, Vec<String>> {
    let truth: std::collections::BTreeMap<String, Vec<String>> = case["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["name"].as_str().unwrap().to_string(), serde_json::from_value(e["joints"].clone()).unwrap()))
        .collect();
    for (name, joints) in names {
        assert!(joints.iter().all(|j| truth.get(name).is_some_and(|t| t.contains(j))), "{name} on {joints:?}");
    }
    truth
}

/// Friction on every joint, as a real arm has it (issue 15: viscous friction on all 7 joints
/// named on 3): `fixtures/diagnose_every/rarm4_6j/e30_3fx` (`make_cad_cases.py --everywhere`,
/// inertials 30 % off, 11 s jittered with re-published samples): viscous and smooth friction
/// on all six joints, springs on joints 5 and 6. Viscous friction is named first on every
/// joint, its level taking the tanh's slope; smooth friction then refines no Coulomb friction
/// found, and alone (`pairs::score_smooth`) leaves the share short where a spring is missing
/// too. Since smooth friction is a member of the pairs (session 27) it is named on joints 1-5
/// and the spring on joint 5 (before: smooth friction on joints 3 and 4, no spring on 5,
/// joint 5's `fv` 0.90 against a true 0.52). Joint 6's smooth friction, 0.12 N m beside a
/// spring on the terminal joint, stayed in viscous friction's level until it was scored
/// beside the terminal link's own CAD error (`Ctx::terminal_cad_in`, 2026-12-07); it is named
/// now, but its levels are not read apart (`fc` 0.045 against a true 0.122, `fv` 0.57
/// against 0.23: the miss left). Asserted: nothing beyond the truth; viscous and smooth
/// friction on all six joints, springs on 5 and 6; `fv` and `fc` on joints 2-5 within 12 %
/// of truth.
#[test]
fn friction_on_every_joint() {
    let (case, d, names) = named_in("diagnose_every/rarm4_6j", "e30_3fx");
    named_within_truth(&case, &names);
    let on = |name: &str| names.iter().find(|(n, _)| n == name).map(|(_, j)| j.clone()).unwrap_or_default();
    let all: Vec<String> = (1..=6).map(|k| format!("joint_{k}")).collect();
    assert_eq!(on("viscous_friction"), all);
    assert_eq!(on("joint_spring"), vec!["joint_5", "joint_6"]);
    assert_eq!(on("smooth_coulomb_friction"), all);
    let param = |name: &str, key: &str| {
        let named = f64s(&d.effects.iter().find(|e| e.name == name).unwrap().parameters[key]);
        let e = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == name).unwrap();
        (named, f64s(&e["parameters"][key]))
    };
    let (fv, fv_true) = param("viscous_friction", "fv");
    let (fc, fc_true) = param("smooth_coulomb_friction", "fc");
    for k in 1..5 {
        assert!((fv[k] - fv_true[k]).abs() <= 0.12 * fv_true[k], "joint {}: fv {} vs {}", k + 1, fv[k], fv_true[k]);
        assert!((fc[k] - fc_true[k]).abs() <= 0.12 * fc_true[k], "joint {}: fc {} vs {}", k + 1, fc[k], fc_true[k]);
    }
}

/// Coulomb friction and rotor inertia on every joint through MuJoCo's default (soft)
/// friction constraint, as in the issue's hidden case "Coulomb + viscous + armature on every
/// joint" (`fixtures/diagnose_soft_every/rarm5_7j/e15_2fx`: `make_cad_cases.py --set random
/// --arms 6 --duration 5:12 --friction-solref mujoco --everywhere
/// coulomb_friction,viscous_friction,armature`, its tuning part; 7 joints, inertials 15 % off,
/// 7 s jittered with re-published float32 samples, no velocity in the log). With one
/// held-out share to come in and to stay, Coulomb friction on `joint_1` and `joint_2`, each
/// just under the share given the other (71 and 72 %), went out together and came back one
/// by one until the step limit: Coulomb friction named on `joint_6` alone, final RMS up to 3.9
/// times the oracle's. An effect now stays on 0.8 of the share it came in on once the search
/// returns to a model it has been at (`search::STAY_SHARE`). Asserted: nothing beyond the truth;
/// Coulomb friction on all seven joints; every joint's final RMS within 1.5 times what the
/// true effects leave on the true rigid-body model at the exact states
/// (`oracle_rms_true_model`: the noise, and the soft stick's departure from `fc sign(qd)`).
#[test]
fn coulomb_friction_on_every_joint_through_a_soft_constraint() {
    let (case, d, names) = named_in("diagnose_soft_every/rarm5_7j", "e15_2fx");
    let truth = named_within_truth(&case, &names);
    let coulomb = names.iter().find(|(n, _)| n == "coulomb_friction").map(|(_, j)| j.clone()).unwrap_or_default();
    assert_eq!(coulomb, truth["coulomb_friction"], "{names:?}");
    let oracle = f64s(&case["oracle"]["oracle_rms_true_model"]);
    for (j, (got, floor)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*got <= 1.5 * floor, "joint_{}: final RMS {got} vs the oracle's {floor}", j + 1);
    }
}

/// Stribeck friction from MuJoCo (issue 15: "Stribeck friction on three joints is named
/// Coulomb on two of them"): `fixtures/diagnose_stribeck/rarm1_7j/e15_3fx` (`make_cad_cases.py
/// --kinds stribeck_friction,...`, the joint's `frictionloss` set every step to
/// fc + fs exp(-(qd/vs)^2); inertials 15 % off, motor currents, 8 s jittered with re-published
/// samples): Stribeck friction on joints 2, 3 and 7 (fs 0.48, 0.40, 0.034 N m), Coulomb
/// friction on 1, 4 and 7, armatures on 2, 3 and 7. Near a reversal the joint sticks, held
/// by any friction within its static level, and those samples, weighed most by the Stribeck
/// shape, pulled `fs` to half its value (0.26, 0.20 N m before the stick column, session 28).
/// Asserted: nothing beyond the truth; Stribeck friction on joints 2 and 3 with `fs` within
/// 15 % and `fc` within 5 % of truth (joint 7's, 3.4 noise std at its peak beside Coulomb
/// friction of its own, is the miss left), and `vs` within the 10 % since it is fitted
/// between the grid's points (session 31: 1.4 and 1.3 % off; the grid's 20 and 26 %).
#[test]
fn stribeck_friction_from_a_sticking_joint() {
    let (case, d, names) = named_in("diagnose_stribeck/rarm1_7j", "e15_3fx");
    let effects = case["effects"].as_array().unwrap();
    for (name, joints) in &names {
        let truth = effects.iter().find(|e| e["name"] == name.as_str());
        let true_joints: Vec<String> =
            truth.map(|e| serde_json::from_value(e["joints"].clone()).unwrap()).unwrap_or_default();
        assert!(joints.iter().all(|j| true_joints.contains(j)), "{name} on {joints:?}");
    }
    let named = d.effects.iter().find(|e| e.name == "stribeck_friction").expect("Stribeck friction named");
    assert_eq!(named.joints, vec!["joint_2", "joint_3"]);
    let truth = effects.iter().find(|e| e["name"] == "stribeck_friction").unwrap();
    for (key, tol) in [("fs", 0.15), ("fc", 0.05), ("vs", 0.1)] {
        let (got, want) = (f64s(&named.parameters[key]), f64s(&truth["parameters"][key]));
        for k in 0..2 {
            let rel = (got[k] - want[k]).abs() / want[k];
            assert!(rel <= tol, "joint {}: {key} {} vs {} ({:.0} %)", k + 2, got[k], want[k], 100.0 * rel);
        }
    }
}

/// On an exact model (the UR5 fixture's effect-free `clean_a`, MuJoCo from the same URDF)
/// the nominal re-fit stays off, and the details say why with its numbers: the most it
/// removes of a joint's held-out residual above the noise is below the 50 % it needs.
#[test]
fn an_exact_model_says_why_it_is_not_refitted() {
    let m = cases_in("diagnose");
    let case = case_named(&m, "clean_a");
    let d = run_job("diagnose", case, &m);
    assert!(d.json.effects.is_empty(), "{:?}", d.details);
    assert!(d.json.nominal_refit.is_none());
    let line = d.details.iter().find(|l| l.starts_with("nominal model not re-fitted: ")).expect("why not re-fitted");
    let at = line.find("removes at most ").expect("its share") + "removes at most ".len();
    let share: f64 = line[at..].split(' ').next().unwrap().parse().unwrap();
    assert!((0.0..50.0).contains(&share), "{line}");
    assert!(line.contains("it needs 50 %"), "{line}");
}

/// An effect-free log of an arm swept over identification-like angles
/// (`fixtures/diagnose_wide/rarm6_6j/e30_0fx`: `make_cad_cases.py --set random --arms 12
/// --duration 5:12 --motion wide`, 1-2 rad peak to peak, inertials 30 % off, 8 s jittered with
/// re-published samples) names nothing. Before the ripple's look-alike check took the
/// terminal link's margin on every row (session 29), the terminal link's CAD error, which the
/// re-fit leaves out, was named a torque ripple on joint 5 (period 1.05 rad): that link's
/// change took the ripple's significance away but needed 93 % of its nominal torque, beyond
/// the 50 % margin then asked off the terminal joint.
#[test]
fn a_wide_sweep_with_cad_inertials_names_no_ripple() {
    let (_, d, names) = named_in("diagnose_wide/rarm6_6j", "e30_0fx");
    assert!(names.is_empty(), "{names:?}");
    assert!(d.nominal_refit.is_some(), "inertials 30 % off: the re-fit is on");
}

/// The same effect-free log with one joint's effort negated (a driver's sign convention
/// opposite to the URDF axis): the diagnosis stops with an error naming the joint and the
/// slope of its torque on the model's, near -1 (CAD inertials 30 % off); in mN m, near 1000. Before
/// `effort_check`, the re-fit took what it could of the reversed torque and the diagnosis
/// named a gain of 2.8 on joint 1, leaving residual on every joint.
#[test]
fn an_effort_of_the_opposite_sign_or_in_mn_m_is_an_error_naming_the_joint() {
    let set = "diagnose_wide/rarm6_6j";
    let (robot, mut log) = case_log(set, "e30_0fx");
    let n = robot.dof();
    log.tau.as_mut().unwrap().iter_mut().skip(2).step_by(n).for_each(|t| *t = -*t);
    let err = match diagnose(&robot, &log, &DiagnoseOptions::default()) {
        Ok(d) => panic!("diagnosed: {:?}", d.json.effects.iter().map(|e| &e.name).collect::<Vec<_>>()),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("joint 'joint_3': the logged effort runs opposite to the torque"), "{err}");
    let k: f64 = err.split("it is ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((-1.5..-0.5).contains(&k), "slope {k}: -1 within the 30 % CAD error");
    // the same joint's effort in mN m: a thousand times the model's, within the CAD error
    log.tau.as_mut().unwrap().iter_mut().skip(2).step_by(n).for_each(|t| *t *= -1000.0);
    let err = match diagnose(&robot, &log, &DiagnoseOptions::default()) {
        Ok(d) => panic!("diagnosed: {:?}", d.json.effects.iter().map(|e| &e.name).collect::<Vec<_>>()),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("joint 'joint_3': the logged effort is ") && err.contains("it is not in N m"), "{err}");
    let k: f64 = err.split("the logged effort is ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((500.0..1500.0).contains(&k), "slope {k}: 1000 within the 30 % CAD error");
}

/// The same log with the terminal joint's effort negated, which the check on the nominal
/// torque leaves out (a payload can turn that joint's torque around): the `diagnose` job
/// (command line, Python) stops with an error naming it, from `identify`'s check on the
/// log's first 20 s (`app::diagnose::check_log`). Before, the diagnosis named a
/// 1.07 kg payload on this log.
#[test]
fn a_terminal_joint_effort_of_the_opposite_sign_is_an_error_of_the_job() {
    use ivdyn::app::{self, DiagnoseJob, LogInput};
    let set = "diagnose_wide/rarm6_6j";
    let (robot, mut log) = case_log(set, "e30_0fx");
    let n = robot.dof();
    log.tau.as_mut().unwrap().iter_mut().skip(n - 1).step_by(n).for_each(|t| *t = -*t);
    let job = DiagnoseJob {
        log: LogInput::Arrays(log),
        source: Default::default(),
        opts: DiagnoseOptions::default(),
        out: None,
        report: false,
        json: None,
    };
    let err = match app::diagnose_job(&robot, &job, &None) {
        Ok(d) => panic!("diagnosed: {:?}", d.report.json.effects.iter().map(|e| &e.name).collect::<Vec<_>>()),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("joint 'joint_6': the logged effort runs opposite"), "{err}");
}

/// The robot (the case's URDF) and the log of fixture case `name` of `set`.
fn case_log(set: &str, name: &str) -> (Robot, ivdyn::log::JointLog) {
    let m = cases_in(set);
    let case = case_named(&m, name);
    let robot =
        Robot::from_urdf(root().join(case["urdf"].as_str().unwrap()), m["base"].as_str(), m["tip"].as_str()).unwrap();
    let path = root().join("fixtures").join(set).join(case["log"].as_str().unwrap());
    let log = read_mcap(path, &ReadOptions::new(&robot.joint_names)).unwrap();
    (robot, log)
}

/// Fixture case `name` of `set` diagnosed as the command line does, asserted to name exactly
/// the true effects on exactly their joints; the case and the diagnosis.
fn exactly_right(set: &str, name: &str) -> (Value, Diagnosis) {
    let m = cases_in(set);
    let case = case_named(&m, name).clone();
    let d = run_job(set, &case, &m);
    let mut named: Vec<(String, Vec<String>)> =
        d.json.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    let mut truth: Vec<(String, Vec<String>)> = case["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["name"].as_str().unwrap().to_string(), serde_json::from_value(e["joints"].clone()).unwrap()))
        .collect();
    named.sort();
    truth.sort();
    assert_eq!(named, truth, "{set}/{name}: {:?}", d.details);
    (case, d)
}

/// A grid shape chosen again once the model has grown (`regrid`, session 29):
/// `fixtures/diagnose_wide/rarm7_7j/e05_3fx` (the wide-motion random set, inertials 5 % off,
/// 7 s): direction-dependent friction on joints 3 and 6, smooth friction on joints 1, 4 and 7,
/// a torque gain on joint 2. The smooth friction of joint 4 is added at `vs` 20 % of the
/// joint's RMS speed; once the other effects are in, 30 % leaves less held-out residual, and
/// the viscous friction that had been named beside it for the slope the narrower tanh lacked
/// goes. Asserted: exactly the true effects on exactly their joints, and the note.
#[test]
fn a_smooth_friction_reshaped_once_the_model_has_grown() {
    let (_, d) = exactly_right("diagnose_wide/rarm7_7j", "e05_3fx");
    assert!(
        d.details
            .iter()
            .any(|l| l.contains("smooth (sigmoid) Coulomb friction on joint 4") && l.contains("chosen again")),
        "{:?}",
        d.details
    );
}

/// A ripple off the grid's harmonics gets its period fitted (`ripple_period`, session 30):
/// `fixtures/diagnose_ripple_off/rarm2_6j/e05_2fx` (`make_cad_cases.py --ripple-n
/// 3,5,7,10,14,20 --motion wide`, inertials 5 % off, 12 s, no velocity in the log): a ripple
/// of period 2 pi / 14 on joint 3, which sweeps 0.73 rad, between the grid's 12 and 16 (12.5
/// and 14 % off in period), and viscous friction on joint 4. Asserted: exactly the true
/// effects on their joints, the period within 5 % and the amplitude vector `(a, b)` within
/// 10 % (the parameter target; at the grid's 16 they were 12.5 % and 19 % off), and
/// the note saying the period was fitted.
#[test]
fn a_ripple_between_the_grids_harmonics_gets_its_period_fitted() {
    let (case, d) = exactly_right("diagnose_ripple_off/rarm2_6j", "e05_2fx");
    let truth = case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "torque_ripple").unwrap();
    let got = d.json.effects.iter().find(|e| e.name == "torque_ripple").unwrap();
    let one = |v: &Value, k: &str| f64s(&v[k])[0];
    let (tp, gp) = (one(&truth["parameters"], "period"), one(&Value::Object(got.parameters.clone()), "period"));
    assert!((gp - tp).abs() < 0.05 * tp, "period {gp} vs {tp}");
    let (ta, tb) = (one(&truth["parameters"], "a"), one(&truth["parameters"], "b"));
    let (ga, gb) = (one(&Value::Object(got.parameters.clone()), "a"), one(&Value::Object(got.parameters.clone()), "b"));
    let err = ((ga - ta).powi(2) + (gb - tb).powi(2)).sqrt() / (ta * ta + tb * tb).sqrt();
    assert!(err < 0.1, "(a, b) = ({ga}, {gb}) vs ({ta}, {tb}): {err}");
    assert!(
        d.details.iter().any(|l| l.contains("torque ripple on joint_3: period fitted between the grid's harmonics")),
        "{:?}",
        d.details
    );
}

/// What a log cannot tell, said with its numbers (`constant_view`): on
/// `fixtures/diagnose_random/rarm9_7j/e05_3fx` (joints sweeping 0.3-0.4 rad, inertials 5 %
/// off) the true direction-dependent frictions of joints 2 and 5 differ between the
/// directions by 1.78 and 0.21 N m, but over those sweeps a constant torque is nearly all a
/// change of the links' base parameters, and neither is named as such. The details list both
/// joints with a difference of levels each would need to be seen, above the true one; joint 7,
/// the terminal one (no link before it makes torque there, so a constant shows whole), is
/// not listed. (Its direction-dependent friction, fc_pos 0.149 and fc_neg 0.042 N m, was named
/// until 2026-12-07; with frictions scored beside the terminal link's own CAD error,
/// `Ctx::terminal_cad_in`, smooth friction comes in there first and a payload takes the
/// constant: a miss, docs/diagnose.md "Frictions scored beside the terminal link's CAD
/// error".)
#[test]
fn the_details_say_which_asymmetries_the_log_cannot_show() {
    let (set, m) = ("diagnose_random/rarm9_7j", cases_in("diagnose_random/rarm9_7j"));
    let case = case_named(&m, "e05_3fx");
    let d = run_job(set, case, &m);
    let truth =
        case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "asymmetric_coulomb_friction").unwrap();
    let (pos, neg) = (f64s(&truth["parameters"]["fc_pos"]), f64s(&truth["parameters"]["fc_neg"]));
    let line = d
        .details
        .iter()
        .find(|l| l.starts_with("offsets and direction-dependent friction are not told"))
        .expect("the note");
    for (k, joint) in [(0, "joint_2"), (1, "joint_5")] {
        let at = line.find(&format!("{joint} (sweeps")).unwrap_or_else(|| panic!("{joint} not listed: {line}"));
        let rest = &line[at..];
        let x = rest.find("differing by under ").unwrap() + "differing by under ".len();
        let limit: f64 = rest[x..].split(' ').next().unwrap().parse().unwrap();
        assert!(limit > (pos[k] - neg[k]).abs(), "{joint}: limit {limit} vs true {}", (pos[k] - neg[k]).abs());
    }
    assert!(!line.contains("joint_7 (sweeps"), "{line}");
}

/// An offset named before its joint's Coulomb friction is read as direction-dependent
/// friction once the search would stop (`offset_swap`), as the forward step reads an offset
/// named after it: `fixtures/diagnose_unseen/rarm22_6j/e30_3fx` (one of the random arms no
/// tuning saw; inertials 30 % off, a jittered float32 log with re-published samples):
/// direction-dependent friction on `joint_1` with fc_pos 0.254, fc_neg 0.669 N m, viscous
/// friction beside it. An offset there came as a pair with viscous friction, Coulomb friction
/// after it, and the joint was named Coulomb friction 0.435 + offset -0.213 N m until
/// 2026-12-06. Asserted: direction-dependent friction on `joint_1`, its levels within 15 %
/// (the zero-phase filter smears each reversal, which reads levels a few % low:
/// docs/diagnose.md, "Uncertainty"), and no offset anywhere.
#[test]
fn an_offset_before_its_coulomb_friction_is_read_as_direction_dependent_friction() {
    let set = "diagnose_unseen/rarm22_6j";
    let m = cases_in(set);
    let case = case_named(&m, "e30_3fx");
    let d = run_in(set, case, &m);
    assert!(d.effects.iter().all(|e| e.name != "torque_offset"), "{:?}", d.effects);
    let asym = d.effects.iter().find(|e| e.name == "asymmetric_coulomb_friction").expect("named");
    let at = asym.joints.iter().position(|j| j == "joint_1").expect("on joint_1");
    let truth =
        case["effects"].as_array().unwrap().iter().find(|e| e["name"] == "asymmetric_coulomb_friction").unwrap();
    for key in ["fc_pos", "fc_neg"] {
        let (est, t) = (f64s(&asym.parameters[key])[at], f64s(&truth["parameters"][key])[0]);
        assert!((est - t).abs() <= 0.15 * t, "{key}: {est} vs truth {t}");
    }
}

/// The terminal link's CAD error and a friction on the terminal joint:
/// `fixtures/diagnose_wide/rarm9_7j/e30_1fx` (wide motion, inertials 30 % off, 8 s): Coulomb
/// friction on joints 1, 2 and 7. The re-fit leaves the terminal link out, and its CAD error
/// had a viscous friction named on joint 7 beside the friction there; from session 29 the
/// backward step after the search, with that link's inertials free (`search::with_terminal_cad`),
/// took it out; since 2026-12-07 every friction is scored beside that link's error
/// (`Ctx::terminal_cad_in`) and the viscous friction does not come in (69 % of the
/// explainable held-out residual, the share needs 75 %). Asserted: no viscous friction
/// anywhere, the final candidates' viscous friction on joint 7 rejected by a rule, and
/// Coulomb friction on joints 1 and 2 within 5 % of truth.
#[test]
fn the_terminal_links_cad_error_takes_no_viscous_friction() {
    let set = "diagnose_wide/rarm9_7j";
    let m = cases_in(set);
    let case = case_named(&m, "e30_1fx");
    let d = run_job(set, case, &m);
    assert!(d.json.effects.iter().all(|e| e.name != "viscous_friction"), "{:?}", d.details);
    let viscous = d.final_candidates.iter().find(|c| c.effect == EffectKind::Viscous).expect("scored");
    assert!(
        !viscous.per_joint[6].significant && viscous.per_joint[6].rejected_by.is_some(),
        "{:?}",
        viscous.per_joint[6]
    );
    let fc_true = f64s(&case["effects"][0]["parameters"]["fc"]);
    let coulomb = d.json.effects.iter().find(|e| e.name == "coulomb_friction").expect("Coulomb friction");
    for (k, joint) in [(0, "joint_1"), (1, "joint_2")] {
        let i = coulomb.joints.iter().position(|j| j == joint).unwrap_or_else(|| panic!("{joint}: {coulomb:?}"));
        let fc = f64s(&coulomb.parameters["fc"])[i];
        assert!((fc - fc_true[k]).abs() <= 0.05 * fc_true[k], "{joint}: fc {fc} vs {}", fc_true[k]);
    }
}

/// Three effects on one joint (`pairs::best_triple`): a spring, viscous friction and
/// load-dependent friction on `joint_1` of the random arm `rarm51_7j` (`e05_3fx` of the arms
/// first run on 2026-12-06, regenerated at 12 s: `make_cad_cases.py --set random --first-arm
/// 51 --arms 1 --duration 12 --only rarm51_7j/e05_3fx`; inertials 5 % off, jittered stamps,
/// no velocity). Each of them alone, and each two, leave the joint's held-out residual short
/// of the share; until 2026-12-06 nothing was named there (0.71 N m left against 0.05 of
/// noise on the 58 s log). Asserted: exactly the true (effect, joint) pairs, and the three
/// levels on `joint_1` within 10 % of the truth (issue 15's criterion).
#[test]
fn three_effects_on_one_joint_are_tried_as_one() {
    let set = "diagnose_unseen/rarm51_7j";
    let m = cases_in(set);
    let case = case_named(&m, "e05_3fx");
    let d = run_job(set, case, &m);
    let named = serde_json::to_value(&d.json.effects).unwrap();
    assert_eq!(effect_pairs(&named), effect_pairs(&case["effects"]), "{:?}", d.details);
    for (name, key) in [("joint_spring", "k"), ("viscous_friction", "fv"), ("load_dependent_friction", "mu")] {
        let (truth, est) = (level_on(&case["effects"], name, key, "joint_1"), level_on(&named, name, key, "joint_1"));
        assert!((est - truth).abs() <= 0.1 * truth.abs(), "{name} {key} on joint_1: {est} against {truth}");
    }
}

/// The (effect, joint) pairs of a list of effects (`diagnosis.json` or `cases.json`).
fn effect_pairs(effects: &Value) -> std::collections::BTreeSet<(String, String)> {
    let mut out = std::collections::BTreeSet::new();
    for e in effects.as_array().unwrap() {
        for j in e["joints"].as_array().unwrap() {
            out.insert((e["name"].as_str().unwrap().to_string(), j.as_str().unwrap().to_string()));
        }
    }
    out
}

/// Parameter `key` of effect `name` on `joint` in a list of effects.
fn level_on(effects: &Value, name: &str, key: &str, joint: &str) -> f64 {
    let e = effects.as_array().unwrap().iter().find(|e| e["name"] == name).unwrap();
    let at = e["joints"].as_array().unwrap().iter().position(|j| j == joint).unwrap();
    f64s(&e["parameters"][key])[at]
}

/// Coulomb friction read through its stick phase stays named: the backward step that checks
/// the model again once `stick::coulomb_through_stick` has read a smooth friction as Coulomb
/// friction does not take that Coulomb friction out (`search`). `fixtures/diagnose_soft_stick/
/// rarm110_6j/e15_1fx` (`make_cad_cases.py --set random --first-arm 110 --arms 1 --duration 10
/// --ripple-n 5,7,10,14 --friction-solref mujoco --only rarm110_6j/e15_1fx`: 10 s of a case of
/// the session-45 first run rarm104-111, inertials 15 % off, a jittered log with re-published
/// samples): Coulomb friction of 0.093 and 0.123 N m on joints 4 and 6 through MuJoCo's soft
/// friction constraint. On joint 6 (light, its soft stick band about 0.19 rad/s wide) the
/// friction was named smooth, read as Coulomb friction's stick phase, then taken out again:
/// its sign shape misfits the band it was read from, and the backward step's held-out share
/// fell below the one to stay; the joint kept its whole residual, 10 noise std. Asserted:
/// Coulomb friction on joints 4 and 6 and nothing else, each level within 10 % of truth, and
/// the stick note on joint 6.
#[test]
fn coulomb_friction_read_through_its_stick_phase_stays_named() {
    let (set, m) = ("diagnose_soft_stick/rarm110_6j", cases_in("diagnose_soft_stick/rarm110_6j"));
    let case = case_named(&m, "e15_1fx");
    let d = run_job(set, case, &m);
    let names: Vec<_> = d.json.effects.iter().map(|e| (e.name.as_str(), e.joints.clone())).collect();
    let both = vec!["joint_4".to_string(), "joint_6".to_string()];
    assert_eq!(names, vec![("coulomb_friction", both)], "{:?}", d.details);
    let truth = &case["effects"][0];
    assert_eq!(truth["name"], "coulomb_friction");
    for (fc, fc_true) in f64s(&d.json.effects[0].parameters["fc"]).into_iter().zip(f64s(&truth["parameters"]["fc"])) {
        assert!((fc - fc_true).abs() <= 0.1 * fc_true, "fc {fc} vs truth {fc_true}");
    }
    let note = "joint_6: smooth Coulomb friction named Coulomb friction";
    assert!(d.details.iter().any(|l| l.starts_with(note)), "{:?}", d.details);
}

/// A refinement of Coulomb friction is not taken out against a Coulomb friction that would
/// not stay either (`search::pair_stands`): the backward step removed the smooth friction of
/// `joint_7` as not significant beside its Coulomb friction, then that Coulomb friction as
/// not significant beside the rest, and the joint's friction, which the two held together,
/// went without ever being tested as a whole; a viscous friction took its place.
/// `fixtures/diagnose_soft_stick/rarm115_7j/e05_2fx` (`make_cad_cases.py --set random
/// --first-arm 115 --arms 1 --duration 10 --everywhere
/// smooth_coulomb_friction,asymmetric_coulomb_friction --friction-solref mujoco --only
/// rarm115_7j/e05_2fx`; inertials 5 % off): smooth friction on every joint (on `joint_7`
/// 0.081 N m, vs 0.082 rad/s, 4 noise std) and rotor inertia on joints 2, 4 and 5. Asserted:
/// exactly those names on exactly those joints.
#[test]
fn a_friction_is_not_taken_out_piece_by_piece() {
    exactly_right("diagnose_soft_stick/rarm115_7j", "e05_2fx");
}
