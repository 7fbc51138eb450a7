//! `ivdyn diagnose` on a real arm: the KUKA LWR4+ runs of `../shared/data/real` (joint
//! torque sensors, 200 Hz, pre-filtered by their authors; see docs/diagnose.md). The
//! nominal model is the data set's URDF (CentroEPiaggio inertials, and its `<dynamics>`
//! friction and damping, which the nominal torque includes: docs/diagnose.md, the LWR4+).
//!
//!     cargo run --release -p ivdyn --example diagnose_real -- [DATA_ROOT] [OUT_DIR]

use std::path::PathBuf;

use ivdyn::diagnose::{self, DiagnoseOptions};
use ivdyn_lab::real::{load_lwr_robot, load_lwr_run};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = PathBuf::from(args.first().cloned().unwrap_or_else(|| "../shared/data/real".into()));
    let out = PathBuf::from(args.get(1).cloned().unwrap_or_else(|| "out/diagnose_lwr".into()));
    let robot = load_lwr_robot(&root)?;
    for k in [1usize, 2, 3] {
        let run = load_lwr_run(&root, k)?;
        let log = run.joint_log(&robot.joint_names);
        let opts = DiagnoseOptions {
            log_name: run.file.display().to_string(),
            urdf_name: "kuka_lwr4.urdf".into(),
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        let d = diagnose::diagnose(&robot, &log, &opts)?;
        let dir = out.join(format!("run{k}"));
        std::fs::create_dir_all(&dir)?;
        diagnose::report::write_html(&d, &dir)?;
        std::fs::write(dir.join("diagnosis.json"), serde_json::to_string_pretty(&d.json)? + "\n")?;
        println!("run {k} ({:.2} s): {}", t0.elapsed().as_secs_f64(), d.verdict);
        for (st, e) in d.steps.iter().zip(&d.json.effects) {
            println!("  {} on {:?}: {}", e.name, e.joints, serde_json::Value::Object(e.parameters.clone()));
            let _ = st;
        }
        if std::env::var("VERBOSE").is_ok() {
            for c in &d.final_candidates {
                println!(
                    "    {:<18} {}",
                    c.effect.name(),
                    c.per_joint
                        .iter()
                        .map(|s| {
                            let why = s.rejected_by.as_deref().unwrap_or("significant");
                            format!("[F {:.0} p {:.0e} g {:.2} e {:.3}: {why}]", s.f, s.p, s.heldout_gain, s.effect_rms)
                        })
                        .collect::<Vec<_>>()
                        .join(" ")
                );
            }
        }
        let f = |v: &[f64]| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(" ");
        println!(
            "  baseline RMS {}\n  final    RMS {}\n  noise        {}",
            f(&d.json.baseline_rms),
            f(&d.json.final_rms),
            f(&d.noise_std)
        );
    }
    Ok(())
}
