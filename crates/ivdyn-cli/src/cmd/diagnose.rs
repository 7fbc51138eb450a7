//! `ivdyn diagnose`: the model-gap diagnosis (docs/diagnose.md).

use crate::stdout::say;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::{Bars, LogArgs, R, RobotArgs, condition_opts, load_robot, log_source, msg};
use ivdyn::app::{DiagnoseJob, LogInput, diagnose_job};
use ivdyn::diagnose::{self, DiagnoseOptions};

#[derive(Args)]
pub struct DiagnoseArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Log file (.mcap or .csv) with positions and measured torques.
    #[arg(long)]
    log: PathBuf,
    #[command(flatten)]
    log_args: LogArgs,
    /// Zero-phase cut-off (Hz) of the differentiation filter (default: the one on a grid
    /// of 10-160 Hz, at most fs/4, that leaves the least residual).
    #[arg(long)]
    cutoff: Option<f64>,
    /// Output directory: diagnosis.json, report.html, residuals.mcap.
    #[arg(long)]
    out: PathBuf,
    /// Significance level of the per-joint F test.
    #[arg(long, default_value_t = 1e-3)]
    alpha: f64,
    /// Smallest effect named, in noise standard deviations of RMS torque.
    #[arg(long, default_value_t = 0.5)]
    min_effect: f64,
    /// Differentiate positions even if the log has velocities (= --velocity positions).
    #[arg(long)]
    ignore_log_velocity: bool,
    /// Also write diagnosis.json here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Skip report.html (faster; diagnosis.json and residuals.mcap only).
    #[arg(long)]
    no_report: bool,
    /// Search the effects of real drives (smooth and load-dependent friction, torque gain,
    /// torque ripple, time delay). By default they are searched on logs of at least 4 s
    /// (docs/diagnose.md). Direction-dependent friction, a refinement of Coulomb friction
    /// found on a joint, is searched either way.
    #[arg(long, conflicts_with = "no_drives")]
    drives: bool,
    /// Leave the effects of real drives out, whatever the log's length.
    #[arg(long)]
    no_drives: bool,
    /// Most threads to use (1: this thread alone). Default: the machine's cores on logs of
    /// 20 000 samples or more, else one. The diagnosis is the same with any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Most memory (GiB) for the candidate columns the diagnosis fits (about 10 MB per second of a 1 kHz, 7-joint log): a longer log is diagnosed on blocks spread over all of it, and a detail says so [default: 4]
    #[arg(long, value_name = "GIB")]
    max_dictionary_gib: Option<f64>,
}

pub fn run(a: DiagnoseArgs, bars: &Bars) -> R<ExitCode> {
    let robot = load_robot(&a.robot)?;
    let cond = condition_opts(&a.log_args, a.cutoff)?;
    let velocity = if a.ignore_log_velocity { ivdyn::prep::VelocitySource::Positions } else { cond.velocity };
    let opts = DiagnoseOptions {
        alpha: a.alpha,
        min_effect: a.min_effect,
        drives: if a.drives {
            Some(true)
        } else if a.no_drives {
            Some(false)
        } else {
            None
        },
        threads: a.threads,
        max_dictionary_bytes: match a.max_dictionary_gib {
            Some(g) => DiagnoseOptions::dictionary_bytes_of_gib(g).map_err(msg)?,
            None => ivdyn::diagnose::DICTIONARY_MAX_BYTES,
        },
        cutoff_hz: a.cutoff,
        velocity,
        window: cond.window,
        exclude: cond.exclude.clone(),
        log_name: a.log.display().to_string(),
        urdf_name: a.robot.urdf.display().to_string(),
        next_args: identify_args(&a),
        ..Default::default()
    };
    let job = DiagnoseJob {
        log: LogInput::File(a.log.clone()),
        source: log_source(&a.log_args, None)?,
        opts,
        out: Some(a.out.clone()),
        report: !a.no_report,
        json: a.json.clone(),
    };
    let out = diagnose_job(&robot, &job, &bars.sink()).map_err(msg)?;
    print_summary(&out.report);
    Ok(ExitCode::SUCCESS)
}

/// This run's robot and log options as `ivdyn identify` arguments (both commands share
/// `RobotArgs` and `LogArgs`), for the next command the diagnosis suggests.
fn identify_args(a: &DiagnoseArgs) -> Vec<String> {
    let (r, l) = (&a.robot, &a.log_args);
    let mut out: Vec<String> = vec![];
    let mut opt = |name: &str, v: Option<String>| {
        if let Some(v) = v {
            out.extend([format!("--{name}"), v]);
        }
    };
    opt("base", r.base.clone());
    opt("tip", r.tip.clone());
    opt("params", r.params.as_ref().map(|p| p.display().to_string()));
    opt("topic", (l.topic != "/joint_states").then(|| l.topic.clone()));
    opt("current-topic", l.current_topic.clone());
    opt("torque-constant", l.torque_constant.clone());
    opt("gear-ratio", l.gear_ratio.clone());
    opt("motor-constant", l.motor_constant.clone());
    opt("window", l.window.clone());
    for e in &l.exclude {
        opt("exclude", Some(e.clone()));
    }
    let name = |v: Option<clap::builder::PossibleValue>| v.map(|p| p.get_name().to_string());
    let effort = name(l.effort.to_possible_value()).filter(|e| e != "auto");
    opt("effort", effort);
    let velocity = if a.ignore_log_velocity {
        Some("positions".to_string())
    } else {
        name(l.velocity.to_possible_value()).filter(|v| v != "auto")
    };
    opt("velocity", velocity);
    if r.fuse_beyond_tip {
        out.push("--fuse-beyond-tip".into());
    }
    if l.log_time {
        out.push("--log-time".into());
    }
    out
}

fn print_summary(d: &diagnose::Diagnosis) {
    let j = &d.json;
    say!("{}", d.verdict);
    for line in &d.details {
        say!("  * {line}");
    }
    if let Some(cmd) = &j.next_command {
        say!("  * next: {cmd}");
    }
    for (st, e) in d.steps.iter().zip(&j.effects) {
        say!("\n{} ({})", st.effect.label(), e.name);
        for line in &st.evidence {
            say!("  - {line}");
        }
        say!("  parameters: {}", serde_json::Value::Object(e.parameters.clone()));
    }
    say!("\nRMS residual per joint (N m):");
    say!("  {:<24} {:>10} {:>10} {:>10}", "joint", "nominal", "final", "noise");
    for (k, name) in j.joints.iter().enumerate() {
        say!("  {:<24} {:>10.4} {:>10.4} {:>10.4}", name, j.baseline_rms[k], j.final_rms[k], d.noise_std[k]);
    }
}
