//! Runs `ivdyn diagnose` on every hidden-effect case of a `cases.json` (default
//! `fixtures/diagnose/cases.json`) and prints, per case, what was named against the truth,
//! the parameter errors and the final RMS against the oracle RMS (the table of
//! docs/diagnose.md).
//!
//!     cargo run --release -p ivdyn --example diagnose_cases [-- path/to/cases.json [--verbose]]

use std::path::{Path, PathBuf};
use std::time::Instant;

use ivdyn::Robot;
use ivdyn::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use ivdyn::log::{ReadOptions, read_mcap};
use serde_json::Value;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let verbose = args.iter().any(|a| a == "--verbose");
    let manifest =
        args.iter().find(|a| !a.starts_with("--")).cloned().unwrap_or_else(|| "fixtures/diagnose/cases.json".into());
    let manifest = PathBuf::from(manifest);
    let dir = manifest.parent().unwrap_or(Path::new(".")).to_path_buf();
    let m: Value = serde_json::from_str(&std::fs::read_to_string(&manifest).expect("read cases.json")).expect("json");
    let (base, tip) = (m["base"].as_str(), m["tip"].as_str());
    println!("| case | truth | named | parameter error | final / oracle RMS (worst joint) | time |");
    println!("|---|---|---|---|---|---|");
    for c in m["cases"].as_array().expect("cases") {
        run_case(c, &dir, base, tip, verbose);
    }
}

/// Diagnoses case `c` of the manifest (URDF chain `base`..`tip`, log under `dir`) and
/// prints its table row: truth, named effects, parameter errors, final / oracle RMS, time.
fn run_case(c: &Value, dir: &Path, base: Option<&str>, tip: Option<&str>, verbose: bool) {
    let name = c["name"].as_str().unwrap();
    let urdf = c["urdf"].as_str().unwrap();
    let robot = Robot::from_urdf(urdf, base, tip).expect("urdf");
    let log = read_mcap(dir.join(c["log"].as_str().unwrap()), &ReadOptions::new(&robot.joint_names)).expect("log");
    let t0 = Instant::now();
    let d = diagnose(&robot, &log, &DiagnoseOptions::default()).expect("diagnose");
    let secs = t0.elapsed().as_secs_f64();
    let truth = truth_effects(c);
    let named: Vec<String> = d
        .json
        .effects
        .iter()
        .map(|e| format!("{} {:?}", e.name, e.joints.iter().map(|j| short(j)).collect::<Vec<_>>()))
        .collect();
    let errs = parameter_errors(c, &d);
    let oracle: Vec<f64> =
        c["oracle"]["oracle_rms_exact"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let ratio = d.json.final_rms.iter().zip(&oracle).map(|(a, b)| a / b).fold(0.0, f64::max);
    println!(
        "| {name} | {} | {} | {} | {ratio:.2} | {secs:.2} s |",
        if truth.is_empty() { "none".into() } else { truth.join("; ") },
        if named.is_empty() { "none".into() } else { named.join("; ") },
        errs.join(", ")
    );
    if verbose {
        print_details(&d, &oracle);
    }
}

/// The effects hidden in case `c` (the manifest's truth), as `name [joints]`.
fn truth_effects(c: &Value) -> Vec<String> {
    c["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            format!(
                "{} {:?}",
                e["name"].as_str().unwrap(),
                e["joints"].as_array().unwrap().iter().map(|j| short(j.as_str().unwrap())).collect::<Vec<_>>()
            )
        })
        .collect()
}

/// Worst relative error of each parameter of the effects both hidden in `c` and named by
/// `d`, as `parameter error%`.
fn parameter_errors(c: &Value, d: &Diagnosis) -> Vec<String> {
    let mut errs = vec![];
    for te in c["effects"].as_array().unwrap() {
        let Some(fe) = d.json.effects.iter().find(|e| e.name == te["name"].as_str().unwrap()) else { continue };
        for (k, tv) in te["parameters"].as_object().unwrap() {
            let Some(fv) = fe.parameters.get(k) else { continue };
            let worst = rel_err(tv, fv, te["joints"].as_array().unwrap(), &fe.joints);
            errs.push(format!("{k} {:.1}%", 100.0 * worst));
        }
    }
    errs
}

/// `--verbose`: the conditioning, noise and RMS per joint, the effects' parameters, and
/// every candidate's score per step and at the end.
fn print_details(d: &Diagnosis, oracle: &[f64]) {
    println!("    cutoff {} Hz, align {:.3} samples", d.info.cutoff_hz, d.info.align_samples);
    println!("    noise {:?}", d.noise_std.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>());
    println!("    final {:?}", d.json.final_rms.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>());
    println!("    oracl {:?}", oracle.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>());
    for e in &d.json.effects {
        println!("    {} {:?} {}", e.name, e.joints, Value::Object(e.parameters.clone()));
    }
    for st in &d.steps {
        println!("    step {}:", st.effect.name());
        for cs in &st.candidates {
            println!(
                "      {:<18} score {:>10.1} joints {:?} {}",
                cs.effect.name(),
                cs.score,
                cs.joints,
                cs.per_joint
                    .iter()
                    .map(|s| format!(
                        "[F {:.0} g {:.2} e {:.3}{}]",
                        s.f,
                        s.heldout_gain,
                        s.effect_rms,
                        if s.significant { "*" } else { "" }
                    ))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
    }
    for cs in &d.final_candidates {
        println!(
            "      final {:<18} {}",
            cs.effect.name(),
            cs.per_joint
                .iter()
                .map(|s| format!("[F {:.0} g {:.2} e {:.3}]", s.f, s.heldout_gain, s.effect_rms))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
}

/// A joint name without its `_joint` suffix (the table's short form).
fn short(j: &str) -> String {
    j.trim_end_matches("_joint").to_string()
}

/// Worst relative error of an identified parameter (scalar or list over joints) against
/// the truth, matching joints by name.
fn rel_err(truth: &Value, found: &Value, tj: &[Value], fj: &[String]) -> f64 {
    match (truth, found) {
        (Value::Number(a), Value::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
            (b - a).abs() / a.abs().max(1e-12)
        }
        (Value::Array(a), Value::Array(b)) if tj.is_empty() => {
            // payload com / inertia: relative to the vector's norm
            let na = a.iter().map(|v| v.as_f64().unwrap().powi(2)).sum::<f64>().sqrt().max(1e-12);
            a.iter()
                .zip(b)
                .map(|(x, y)| (y.as_f64().unwrap_or(f64::NAN) - x.as_f64().unwrap()).abs() / na)
                .fold(0.0, f64::max)
        }
        (Value::Array(a), Value::Array(b)) => {
            let mut worst = 0.0f64;
            for (k, j) in tj.iter().enumerate() {
                let t = a[k].as_f64().unwrap();
                match fj.iter().position(|x| x == j.as_str().unwrap()) {
                    Some(i) => {
                        let f = b[i].as_f64().unwrap();
                        let e = if t.abs() > 1e-9 { (f - t).abs() / t.abs() } else { (f - t).abs() };
                        worst = worst.max(e);
                    }
                    None => worst = f64::INFINITY,
                }
            }
            worst
        }
        _ => f64::NAN,
    }
}
