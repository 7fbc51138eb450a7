//! `diagnose` as a command: the model-gap diagnosis of one log, and its three files
//! (`diagnosis.json`, `report.html`, `residuals.mcap`) in an output folder.

use std::path::PathBuf;

use super::Outcome;
use super::io::{LogInput, LogSource};
use crate::Robot;
use crate::diagnose::{self, DiagnoseOptions, Diagnosis};
use crate::error::{Error, Result};
use crate::output::write_json;
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

/// Runs `job` on `robot`, then writes its files.
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
        diagnose::diagnose(robot, &log, &opts).map_err(|e| job.log.context(e))?
    };
    if let Some(dir) = &job.out {
        std::fs::create_dir_all(dir).map_err(|e| Error::Io { file: dir.clone(), source: e })?;
        if job.report {
            let _st = Stage::begin(progress, "writing report.html", 0);
            diagnose::report::write_html(&d, dir)?;
        }
        diagnose::report::write_mcap_stamped(&d, &robot.joint_names, log.t0_ns, dir)?;
        write_json(&dir.join("diagnosis.json"), &d.json)?;
    }
    if let Some(j) = &job.json {
        write_json(j, &d.json)?;
    }
    Ok(Outcome { report: d, written: vec![] })
}
