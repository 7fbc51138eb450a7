//! `ivdyn diagnose` on the real arms of `../shared/data/real`, each from its own URDF (see
//! docs/diagnose.md): the KUKA LWR4+ runs (joint torque sensors, 200 Hz, pre-filtered by
//! their authors; the nominal torque includes the URDF's `<dynamics>` friction and
//! damping: docs/diagnose.md, the LWR4+), then the Staubli TX40 (FIGAROH's 5 kHz motor-side
//! log, brought to the joint side by its transmission: gears, the coupled wrist, the joint
//! offsets; docs/diagnose.md, "A real industrial arm").
//!
//!     cargo run --release -p ivdyn-lab --example diagnose_real -- [DATA_ROOT] [OUT_DIR]
//!
//! `VERBOSE=1` prints every final candidate with the rule that decided it.

use std::path::{Path, PathBuf};

use ivdyn::Robot;
use ivdyn::diagnose::{self, DiagnoseOptions};
use ivdyn::log::JointLog;
use ivdyn_lab::real::{load_lwr_robot, load_lwr_run, load_tx40, tx40_transmission};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = PathBuf::from(args.first().cloned().unwrap_or_else(|| "../shared/data/real".into()));
    let out = PathBuf::from(args.get(1).cloned().unwrap_or_else(|| "out/diagnose_real".into()));
    let robot = load_lwr_robot(&root)?;
    for k in [1usize, 2, 3] {
        let run = load_lwr_run(&root, k)?;
        let log = run.joint_log(&robot.joint_names);
        let name = run.file.display().to_string();
        diagnose_one(&format!("LWR4+ run {k}"), &robot, &log, (&name, "kuka_lwr4.urdf"), &out.join(format!("run{k}")))?;
    }
    let (robot, log) = tx40_joint_log(&root)?;
    diagnose_one("TX40", &robot, &log, ("curr_data.csv", "tx40_mdh_modified.urdf"), &out.join("tx40"))?;
    Ok(())
}

/// The TX40's log on the joint side, as a user's driver would publish it (no velocities).
fn tx40_joint_log(root: &Path) -> Res<(Robot, JointLog)> {
    let tx = load_tx40(root)?;
    let trans = tx40_transmission();
    let log = JointLog {
        joint_names: tx.robot.joint_names.clone(),
        t0_ns: 0,
        t: (0..tx.len()).map(|k| k as f64 * tx.dt).collect(),
        q: trans.joint_positions(&tx.q_m)?,
        qd: None,
        tau: Some(trans.joint_torques(&tx.tau_m)?),
        u: None,
        current: None,
        truncated: false,
    };
    Ok((tx.robot, log))
}

/// Diagnoses one log, writes `report.html` and `diagnosis.json` into `dir` and prints the
/// verdict, the effects and the RMS per joint.
fn diagnose_one(
    title: &str,
    robot: &Robot,
    log: &JointLog,
    (log_name, urdf_name): (&str, &str),
    dir: &Path,
) -> Res<()> {
    let opts = DiagnoseOptions { log_name: log_name.into(), urdf_name: urdf_name.into(), ..Default::default() };
    let t0 = std::time::Instant::now();
    let d = diagnose::diagnose(robot, log, &opts)?;
    std::fs::create_dir_all(dir)?;
    diagnose::report::write_html(&d, dir)?;
    std::fs::write(dir.join("diagnosis.json"), serde_json::to_string_pretty(&d.json)? + "\n")?;
    println!("{title} ({:.2} s): {}", t0.elapsed().as_secs_f64(), d.verdict);
    for e in &d.json.effects {
        println!("  {} on {:?}: {}", e.name, e.joints, serde_json::Value::Object(e.parameters.clone()));
    }
    if std::env::var("VERBOSE").is_ok() {
        for c in &d.final_candidates {
            let rows: Vec<String> = c
                .per_joint
                .iter()
                .map(|s| {
                    let why = s.rejected_by.as_deref().unwrap_or("significant");
                    format!("[F {:.0} p {:.0e} g {:.2} e {:.3}: {why}]", s.f, s.p, s.heldout_gain, s.effect_rms)
                })
                .collect();
            println!("    {:<18} {}", c.effect.name(), rows.join(" "));
        }
    }
    let f = |v: &[f64]| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(" ");
    println!(
        "  baseline RMS {}\n  final    RMS {}\n  noise        {}",
        f(&d.json.baseline_rms),
        f(&d.json.final_rms),
        f(&d.noise_std)
    );
    Ok(())
}
