//! `ivdyn gains`: the drive gains (torque constants at the joint) from a log without and a
//! log with a payload of known mass (docs/cli.md).

use crate::stdout::say;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::{
    Bars, FilterArgs, LogArgs, R, RobotArgs, condition_opts, fmt_list, load_robot, log_source, msg,
    payload_inertia_arg, print_written,
};
use ivdyn::app::{GainsJob, GainsOptions, GainsReport, KnownPayload, LogInput, gains_job};

#[derive(Args)]
pub struct GainsArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Log of the arm without the payload (.mcap or .csv), with the drive currents.
    #[arg(long)]
    unloaded: PathBuf,
    /// Log of the arm with the payload on the last link, with the drive currents.
    #[arg(long)]
    loaded: PathBuf,
    #[command(flatten)]
    log_args: LogArgs,
    #[command(flatten)]
    filter: FilterArgs,
    /// The payload's mass (kg): it sets the scale of every gain.
    #[arg(long)]
    payload_mass: f64,
    /// The payload's COM x,y,z (m) in the last link's frame, if known (else estimated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    payload_com: Option<Vec<f64>>,
    /// The payload's inertia about its COM Ixx,Ixy,Ixz,Iyy,Iyz,Izz (kg m^2, URDF attribute order), if known (needs --payload-com).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    payload_inertia: Option<Vec<f64>>,
    /// Largest relative std of a gain reported as identifiable.
    #[arg(long, default_value_t = 0.1)]
    max_rel_std: f64,
    /// JSON report.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: GainsArgs, bars: &Bars) -> R<ExitCode> {
    let robot = load_robot(&a.robot)?;
    let inertia = payload_inertia_arg(a.payload_inertia.as_deref());
    let payload =
        KnownPayload::from_parts(a.payload_mass, a.payload_com.as_deref(), inertia.as_deref()).map_err(msg)?;
    let job = GainsJob {
        unloaded: LogInput::File(a.unloaded.clone()),
        loaded: LogInput::File(a.loaded.clone()),
        source: log_source(&a.log_args, None)?,
        payload,
        opts: GainsOptions {
            condition: condition_opts(&a.log_args, a.filter.cutoff)?,
            decimate: a.filter.decimate,
            max_rel_std: a.max_rel_std,
            progress: bars.sink(),
            ..Default::default()
        },
        json: a.json.clone(),
    };
    let out = gains_job(&robot, &job).map_err(msg)?;
    print_gains(&out.report);
    print_written(&out.written);
    if out.report.gains.iter().all(|g| !g.identifiable) {
        eprintln!("ivdyn: error: no drive gain is identifiable from this pair");
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}

fn print_gains(rep: &GainsReport) {
    let p = &rep.payload;
    say!(
        "drive gains (N m per current unit, at the joint) with a payload of {} kg on '{}' (given: {})",
        p.mass,
        p.link,
        p.given.join(", ")
    );
    let w = rep.joints.iter().map(|j| j.len()).max().unwrap_or(5).max(5);
    say!("  {:<w$}  {:>11}  {:>10}  {:>9}  identifiable", "joint", "gain", "std", "rel std %");
    for g in &rep.gains {
        let num = |v: Option<f64>, prec: usize| v.map_or("-".to_string(), |x| format!("{x:.prec$}"));
        let verdict = match &g.reason {
            None => "yes".to_string(),
            Some(r) => format!("no: {r}"),
        };
        say!(
            "  {:<w$}  {:>11}  {:>10}  {:>9}  {verdict}",
            g.joint,
            num(g.value, 5),
            num(g.std, 5),
            num(g.rel_std_pct, 2)
        );
    }
    say!("  payload COM [{}] m (std [{}])", fmt_list(&p.com, 4), fmt_list(&p.com_std, 4));
    for (what, r) in [("unloaded", &rep.unloaded), ("loaded", &rep.loaded)] {
        say!(
            "  {what} log ({}, {} samples at {:.1} Hz): residual rms per joint [{}], current rms [{}]",
            r.current_from,
            r.samples,
            r.sample_rate_hz,
            fmt_list(&r.rms, 4),
            fmt_list(&r.current_rms, 4)
        );
    }
    for n in &rep.notes {
        say!("note: {n}");
    }
}
