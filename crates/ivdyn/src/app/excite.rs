//! `excite` as a command: an excitation trajectory designed for `robot`, written as CSV
//! (and MCAP) for the robot to replay, with its report.

use std::path::PathBuf;

use super::Outcome;
use crate::Robot;
use crate::error::Result;
use crate::excite::{self, ExciteOptions, ExciteReport};
use crate::output::OutputSet;

/// One `excite` run.
#[derive(Clone)]
pub struct ExciteJob {
    /// Design options.
    pub opts: ExciteOptions,
    /// The trajectory as CSV (`t`, `<joint>.q`, `.qd`, `.qdd`).
    pub csv: Option<PathBuf>,
    /// The trajectory as MCAP `/joint_states`.
    pub mcap: Option<PathBuf>,
    /// The JSON report.
    pub json: Option<PathBuf>,
}

/// Designs the trajectory, then writes the files of `job` (all or none); `written` lists the
/// trajectory files, then the report.
pub fn excite_job(robot: &Robot, job: &ExciteJob) -> Result<Outcome<ExciteReport>> {
    let rep = excite::design(robot, &job.opts)?;
    let mut written = vec![];
    // all of the command's files or none of them
    let mut set = OutputSet::new();
    if let Some(p) = &job.csv {
        set.write(p, |p| excite::write_csv(p, &rep.joints, &rep.trajectory))?;
    }
    if let Some(p) = &job.mcap {
        set.write(p, |p| excite::write_mcap(p, &rep.joints, &rep.trajectory))?;
    }
    let files: Vec<String> = job.csv.iter().chain(&job.mcap).map(|p| p.display().to_string()).collect();
    if !files.is_empty() {
        written.push(format!("trajectory written to {}", files.join(" and ")));
    }
    if let Some(p) = &job.json {
        set.write_json(p, &rep)?;
        written.push(format!("report written to {}", p.display()));
    }
    set.commit()?;
    Ok(Outcome { report: rep, written })
}
