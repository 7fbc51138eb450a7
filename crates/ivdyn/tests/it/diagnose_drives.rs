//! The effects of real drives (issue 15 item 2) on MuJoCo logs of the UR5
//! (`fixtures/diagnose_drives/`, `make_diagnose_cases.py --robot ur5_drives`: MuJoCo's joint
//! friction loss, applied generalized forces and sensor models, each case one effect on two
//! joints at 5-15 noise std). Truth and oracle RMS come from the generator's `cases.json`.
//!
//! Tolerances (stated before the runs, from the data, not from the output): the statistical
//! standard error of every parameter here is below 1 % (2 s at 1 kHz, noise 0.15 / 0.08 N m
//! against effects of 5-15 noise std: sigma / (effect RMS sqrt(N_eff)) with N_eff >= 100), so
//! what is left is the model error of a column against MuJoCo's mechanism (constraint friction
//! sticking near zero velocity, differentiated accelerations); 10 % of the value (the issue's
//! criterion) for levels and coefficients; for the gain, 10 % of `k - 1` (the part that is the
//! effect); for the ripple, 10 % of its amplitude on `a` and `b`, and the period exactly (it is
//! on the grid); for the smooth friction's `vs` 10 % as well (between its grid points since
//! 2026-12-05: the parabola through the grid's residuals, then fitted, `shape_scale`; a
//! factor 2.5, the grid's spacing then, before).

use super::diagnose_cases::{case_named, cases_in, f64s, run_with};
use ivdyn::diagnose::{DiagnoseOptions, Diagnosis};

fn check(name: &str) -> Diagnosis {
    // the drive vocabulary is searched on request (`--drives`)
    check_with(name, &DiagnoseOptions { drives: Some(true), ..Default::default() })
}

fn check_with(name: &str, opts: &DiagnoseOptions) -> Diagnosis {
    let set = "diagnose_drives";
    let m = cases_in(set);
    let case = case_named(&m, name);
    let diagnosis = run_with(set, case, &m, opts);
    let d = &diagnosis.json;
    let truth = &case["effects"].as_array().unwrap()[0];
    let named: Vec<(String, Vec<String>)> = d.effects.iter().map(|e| (e.name.clone(), e.joints.clone())).collect();
    let tj: Vec<String> = truth["joints"].as_array().unwrap().iter().map(|j| j.as_str().unwrap().to_string()).collect();
    assert_eq!(named, vec![(truth["name"].as_str().unwrap().to_string(), tj)], "{name}");
    let found = &d.effects[0].parameters;
    let tp = truth["parameters"].as_object().unwrap();
    for (k, tv) in tp {
        let (t, f) = (f64s(tv), f64s(&found[k]));
        for (i, (a, b)) in t.iter().zip(&f).enumerate() {
            let ok = match k.as_str() {
                "k" => (b - a).abs() <= 0.1 * (a - 1.0).abs(),
                "vs" => (b - a).abs() <= 0.1 * a,
                "period" => (b - a).abs() <= 1e-9,
                "a" | "b" => {
                    let amp = f64s(&tp["a"])[i].hypot(f64s(&tp["b"])[i]);
                    (b - a).abs() <= 0.1 * amp
                }
                _ => (b - a).abs() <= 0.1 * a.abs(),
            };
            assert!(ok, "{name}: {k}[{i}] = {b}, truth {a}");
        }
    }
    // the gap shrinks to within 1.5x of what the true effect leaves (the oracle)
    let oracle = f64s(&case["oracle"]["oracle_rms_exact"]);
    for (j, (f, o)) in d.final_rms.iter().zip(&oracle).enumerate() {
        assert!(*f <= 1.5 * o, "{name}: joint {j} final RMS {f} vs oracle {o}");
    }
    diagnosis
}

/// Shoulder (fc_pos 4.0, fc_neg 2.5 N m) and elbow (1.2 / 2.0 N m). Marked a known miss
/// (the elbow's came out as plain Coulomb friction) until 2026-12-03, when it was found
/// passing on `bd7e8ed` (after the corrected F statistic) and un-ignored.
#[test]
fn asymmetric_coulomb_friction() {
    check("asymmetric_coulomb");
}

/// Direction-dependent friction only refines Coulomb friction found on a joint, so the
/// basic search tries it too (`EffectKind::needs_drives`): the same log, default options.
/// Before 2026-12-03 the basic search named Coulomb friction there and rejected the offset
/// beside it as direction-dependent friction, which it could not name.
#[test]
fn asymmetric_coulomb_friction_without_drives() {
    check_with("asymmetric_coulomb", &DiagnoseOptions::default());
}

#[test]
fn smooth_coulomb_friction() {
    check("smooth_coulomb");
}

#[test]
fn load_dependent_friction() {
    check("load_dependent");
}

#[test]
fn torque_gain() {
    let d = check("torque_gain");
    // the gain's `k` is a ratio (measured / true), not a spring's N m/rad: in the verdict's
    // details and in the report's parameter table
    let line = d.details.iter().find(|l| l.contains("torque gain")).expect("the gain's line");
    assert!(line.contains("k = ") && !line.contains("N m/rad"), "{line}");
    let page = ivdyn::diagnose::report::html_page(&d, std::path::Path::new("unused")).unwrap();
    assert!(page.contains("measured / true torque") && !page.contains("spring stiffness"));
}

#[test]
fn torque_ripple() {
    check("torque_ripple");
}

#[test]
fn time_delay() {
    check("time_delay");
}

/// By default the effects of real drives are searched only on logs of at least 4 s with
/// white torque noise (`DiagnoseOptions::drives_for`): on this 2 s log the smooth friction
/// is not named as such, and the details say why (python/tests/test_diagnose_default_vocabulary.py
/// checks a 20-60 s MuJoCo log, and the same log low-passed).
#[test]
fn drive_effects_are_not_searched_by_default_on_a_short_log() {
    let set = "diagnose_drives";
    let m = cases_in(set);
    let case = case_named(&m, "smooth_coulomb");
    let d = run_with(set, case, &m, &DiagnoseOptions::default());
    assert!(d.json.effects.iter().all(|e| e.name != "smooth_coulomb_friction"), "{:?}", d.json.effects);
    let why = d.details.last().unwrap();
    assert!(why.starts_with("effects of real drives not searched: the log spans"), "{why}");
    assert!(why.contains("under 4 s"), "{why}");
}

/// The rule itself: given beats the log; by default both the duration and white noise.
#[test]
fn drive_effects_by_default_need_a_long_log_with_white_noise() {
    let auto = DiagnoseOptions::default();
    assert!(auto.drives_for(25.0, -0.5));
    assert!(auto.drives_for(4.0, -0.25), "interpolated noise is white enough");
    assert!(!auto.drives_for(3.9, -0.5), "short");
    assert!(!auto.drives_for(60.0, 0.0), "low-passed torque");
    assert!(DiagnoseOptions { drives: Some(true), ..auto.clone() }.drives_for(2.0, 0.0));
    assert!(!DiagnoseOptions { drives: Some(false), ..auto }.drives_for(60.0, -0.5));
}
