//! The one orchestration: every command (`identify`, `payload`, `gains`, `simulate`,
//! `diagnose`, `excite`; `fleet`'s engine-neutral statistics) as a job that reads its inputs, runs, and writes its outputs whole or not at
//! all. The command line (`crates/ivdyn-cli`) and the Python package (`crates/ivdyn-py`)
//! build a job from their arguments, call it, and present the result; neither holds any
//! orchestration of its own.
//!
//! Below the jobs: [`identify()`], [`payload()`] and [`simulate()`] on logs in memory, and
//! the streaming identify of MCAP files ([`stream`]).

mod coulomb;
pub mod diagnose;
pub mod effort;
mod effort_check;
pub mod excite;
pub mod fleet;
pub mod fleet_drift;
pub mod gains;
pub mod html;
pub mod identify;
pub mod identify_job;
mod identify_options;
pub mod io;
pub mod payload;
pub mod payload_before;
mod payload_gains;
mod prepare;
pub mod simulate;
pub mod stream;

pub use diagnose::{DiagnoseJob, diagnose_job};
pub use effort::{Effort, PerJoint, TorqueConstants};
pub use excite::{ExciteJob, excite_job};
pub use gains::{GainsJob, GainsOptions, GainsReport, KnownPayload, drive_gains, gains_job};
pub use identify::{IdentifyOptions, IdentifyReport, Method, identify, identify_base, identify_logs, write_prediction};
pub use identify_job::{IdentifyJob, IdentifyOutputs, identify_job};
pub use io::{LogInput, LogSource, RobotSource};
pub use payload::{
    BeforeCheck, Hidden, PayloadJob, PayloadMode, PayloadOptions, PayloadReport, TorqueConstantPrior, payload,
    payload_job,
};
pub use simulate::{
    SimulateJob, SimulateOptions, SimulateSummary, Trajectory, fourier_trajectory, simulate, simulate_job, true_robot,
};

/// A job's report and, in order, one line per file written (for the command line).
#[derive(Debug, Clone)]
pub struct Outcome<R> {
    /// The report.
    pub report: R,
    /// "... written to PATH" lines, in the order the files were written.
    pub written: Vec<String>,
}
