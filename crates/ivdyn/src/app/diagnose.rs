//! `diagnose` as a command: the model-gap diagnosis of one log, and its three files
//! (`diagnosis.json`, `report.html`, `residuals.mcap`) in an output folder.

use std::path::PathBuf;

use super::Outcome;
use super::effort_check;
use super::identify::{accumulate, identify_base, split_ranges, starting_shapes};
use super::identify_options::{CoulombMode, IdentifyOptions};
use super::io::{LogInput, LogSource};
use super::prepare::prepare;
use crate::Robot;
use crate::diagnose::{self, DiagnoseOptions, Diagnosis, report};
use crate::error::Result;
use crate::ident::joint_acc::JointAccs;
use crate::log::JointLog;
use crate::output::OutputSet;
use crate::progress::{ProgressSink, Stage};

/// One `diagnose` run.
#[derive(Debug, Clone)]
pub struct DiagnoseJob {
    /// The log.
    pub log: LogInput,
    /// How log files are read (the command topic is not used).
    pub source: LogSource,
    /// Options (`log_name` is filled from the log file when empty).
    pub opts: DiagnoseOptions,
    /// Output folder for diagnosis.json, report.html and residuals.mcap (created).
    pub out: Option<PathBuf>,
    /// Write report.html too.
    pub report: bool,
    /// A second copy of diagnosis.json.
    pub json: Option<PathBuf>,
}

/// Runs `job` on `robot`, then writes its files (all or none).
pub fn diagnose_job(robot: &Robot, job: &DiagnoseJob, progress: &ProgressSink) -> Result<Outcome<Diagnosis>> {
    let log = {
        let _st = job.log.path().map(|p| Stage::begin(progress, &format!("reading {}", p.display()), 0));
        job.log.load(robot, &job.source)?
    };
    let mut opts = job.opts.clone();
    if opts.log_name.is_empty() {
        opts.log_name = job.log.path().map(|p| p.display().to_string()).unwrap_or_else(|| "(arrays)".into());
    }
    let d = {
        let _st = Stage::begin(progress, "diagnosing", 0);
        check_log(robot, &log, &opts).map_err(|e| job.log.context(e))?;
        diagnose::diagnose(robot, &log, &opts).map_err(|e| job.log.context(e))?
    };
    // all of the command's files or none of them
    let mut set = OutputSet::new();
    if let Some(dir) = &job.out {
        set.create_dir_all(dir)?;
        let _st = Stage::begin(progress, "writing the report and residuals", 0);
        // the page (its plots) and the residual file are independent: side by side on a
        // long log (`DiagnoseOptions::threads_for`)
        let mcap = dir.join(report::MCAP_FILE);
        let write_residuals =
            |set: &mut OutputSet| set.write(&mcap, |p| report::write_residuals(&d, &robot.joint_names, log.t0_ns, p));
        let (page, residuals) = if opts.threads_for(log.t.len()) > 1 {
            std::thread::scope(|scope| {
                let page = job.report.then(|| scope.spawn(|| report::html_page(&d, dir)));
                let residuals = write_residuals(&mut set);
                (page.map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))), residuals)
            })
        } else {
            (job.report.then(|| report::html_page(&d, dir)), write_residuals(&mut set))
        };
        if let Some(page) = page {
            set.write_bytes(&dir.join(report::HTML_FILE), page?.as_bytes())?;
        }
        residuals?;
        set.write_json(&dir.join("diagnosis.json"), &d.json)?;
    }
    if let Some(j) = &job.json {
        set.write_json(j, &d.json)?;
    }
    set.commit()?;
    Ok(Outcome { report: d, written: vec![] })
}

/// Seconds of a log [`check_log`] reads at most, from the start of `diagnose`'s window:
/// the fits it compares have a few dozen parameters, and `diagnose`'s time stays within
/// its budget.
const CHECK_SECONDS: f64 = 20.0;

/// [`effort_check::check`] on the first [`CHECK_SECONDS`] of `log` (of `diagnose`'s
/// window), prepared as `identify` prepares a log (with the diagnosis's spans left out and
/// velocity source):
/// what `diagnose` runs before its search, where its own check on the nominal torque
/// leaves the terminal joint out (there a payload column took a reversed torque in: a
/// 6-joint arm's terminal effort negated was named a 1.07 kg payload). Only the effort's
/// errors stop the diagnosis: a log this preparation cannot take is left to the
/// diagnosis's own checks.
fn check_log(robot: &Robot, log: &JointLog, opts: &DiagnoseOptions) -> Result<()> {
    let mut io = IdentifyOptions { coulomb: CoulombMode::Sign, validation_fraction: 0.0, ..Default::default() };
    let (start, end) = opts.window.unwrap_or((0.0, f64::INFINITY));
    io.condition.window = Some((start, end.min(start + CHECK_SECONDS)));
    io.condition.exclude = opts.exclude.clone();
    io.condition.velocity = opts.velocity;
    let stats = || -> Result<(JointAccs, Vec<f64>)> {
        let robot = starting_shapes(robot, CoulombMode::Sign)?;
        let base = identify_base(&robot, &io)?;
        let prep = prepare(&robot, &base.independent, &[log], &io, "log")?;
        let (rows, _) = split_ranges(prep.len(), &io);
        let mut acc = JointAccs::new(robot.dof(), base.base_count(), false);
        accumulate(&mut acc, &prep, rows, false)?;
        Ok((acc, base.project(&robot.params())?))
    };
    match stats() {
        Ok((acc, nom_base)) if acc.samples() > 0 => effort_check::check(&acc, &nom_base, &robot.joint_names),
        _ => Ok(()),
    }
}
