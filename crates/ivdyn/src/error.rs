//! Errors of the std crate: each names what it is about (file, joint, link, index).

use std::path::PathBuf;

/// Anything that can go wrong in `ivdyn`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A URDF file could not be read or parsed.
    #[error("{file}: cannot parse URDF: {msg}")]
    UrdfParse {
        /// The file.
        file: PathBuf,
        /// The parser's message.
        msg: String,
    },
    /// A joint of a kind the chain model cannot represent.
    #[error(
        "{file}: joint '{joint}' has unsupported type '{kind}' (supported: revolute, continuous, prismatic, fixed)"
    )]
    UnsupportedJoint {
        /// The file.
        file: PathBuf,
        /// Joint name.
        joint: String,
        /// Its type.
        kind: String,
    },
    /// A mimic joint on the chain (mimic joints couple two coordinates; not supported).
    #[error(
        "{file}: joint '{joint}' is a <mimic> joint on the chain; mimic joints are not supported (choose a tip before it, or lock it)"
    )]
    MimicJoint {
        /// The file.
        file: PathBuf,
        /// Joint name.
        joint: String,
    },
    /// A link name that the URDF does not contain.
    #[error("{file}: no link named '{link}' (links: {available})")]
    UnknownLink {
        /// The file.
        file: PathBuf,
        /// The requested link.
        link: String,
        /// Names that exist.
        available: String,
    },
    /// The chain branches and no tip was chosen.
    #[error("{file}: the tree branches at link '{link}' into movable joints {branches}; choose a tip link")]
    Branching {
        /// The file.
        file: PathBuf,
        /// Where it branches.
        link: String,
        /// First joints of each branch.
        branches: String,
    },
    /// The structure of the URDF is unusable (several roots, loops, tip not below base...).
    #[error("{file}: {msg}")]
    UrdfStructure {
        /// The file.
        file: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// A joint axis of zero length or a non-finite number in the file.
    #[error("{file}: joint '{joint}': {msg}")]
    BadJoint {
        /// The file.
        file: PathBuf,
        /// Joint name.
        joint: String,
        /// What is wrong.
        msg: String,
    },
    /// The chain has more joints than the runtime dispatch supports.
    #[error("chain has {dof} movable joints; ivdyn supports 1..={max}")]
    TooManyJoints {
        /// Joints in the chain.
        dof: usize,
        /// Supported maximum.
        max: usize,
    },
    /// An array argument has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    Dimension {
        /// Argument name.
        what: String,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// An error of the dynamics core.
    #[error(transparent)]
    Core(#[from] ivdyn_core::Error),
    /// An error of the dynamics core at one sample of a batch (the first failing one).
    #[error("sample {index}: {source}")]
    Sample {
        /// Index of the sample (row of the inputs).
        index: usize,
        /// What went wrong there.
        source: ivdyn_core::Error,
    },
    /// I/O error with the file it concerns.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The log has no effort (torque) data, which the named step needs.
    #[error("{what} has no effort (torque) data; {needed_by} needs measured torques")]
    NoTorque {
        /// Which log ("log", "validation log", "before log").
        what: String,
        /// What needs the torques ("identification", "payload estimation").
        needed_by: String,
    },
    /// A log without the drive currents that the drive-gain fit needs.
    #[error(
        "{what} has no drive currents (CSV columns <joint>.i, an MCAP current topic, or the effort field); the drive-gain fit needs them"
    )]
    NoCurrent {
        /// Which log ("unloaded log", "loaded log").
        what: String,
    },
    /// A log whose joints are not the robot's (names or order after matching).
    #[error("{what} joints {log:?} are not the robot's {robot:?}")]
    JointMismatch {
        /// Which log ("log", "validation log", "before log").
        what: String,
        /// The log's joints.
        log: Vec<String>,
        /// The robot's joints.
        robot: Vec<String>,
    },
    /// Fewer samples than the fit needs.
    #[error("log too short: {samples} samples of {joints} joints after conditioning for {params} base parameters")]
    TooFewSamples {
        /// Samples left after conditioning.
        samples: usize,
        /// Joints.
        joints: usize,
        /// Base parameters to fit.
        params: usize,
    },
    /// A simulation inside an estimator (an instrument, an IDIM-IV iteration) left the
    /// range of finite states.
    #[error("{what} diverged at sample {sample}{detail}")]
    Diverged {
        /// Which simulation.
        what: String,
        /// The sample where it happened.
        sample: usize,
        /// The cause, when known (", mass matrix not positive definite ...").
        detail: String,
    },
    /// An instrument that the IV fit cannot use (not correlated with the regressor).
    #[error("IV fit failed ({msg}): the instrument is not correlated with the regressor; try --method wls or idim-iv")]
    SingularInstrument {
        /// The fit's own message.
        msg: String,
    },
    /// A parameter file written for another chain.
    #[error(
        "parameter file for robot '{robot}' (joints {file_joints:?}) does not match this chain (joints {joints:?})"
    )]
    ParamsMismatch {
        /// The robot named in the file.
        robot: String,
        /// The file's joints.
        file_joints: Vec<String>,
        /// This chain's joints.
        joints: Vec<String>,
    },
    /// A transmission (motor-to-joint matrix) that cannot be used.
    #[error("transmission: {msg}")]
    Transmission {
        /// What is wrong.
        msg: String,
    },
    /// Parameters that a file format or a simulator cannot take (a negative mass, an inertia
    /// without positive principal moments or breaking the triangle inequalities): the
    /// write is refused, and nothing is written.
    #[error("{what} refused: {problems}")]
    PhysicallyInconsistent {
        /// What is refused ("URDF export", "URDF write-back", "writing payload.urdf").
        what: String,
        /// Which link or joint, what is wrong with it, and what to do.
        problems: String,
    },
    /// A numerical step that failed on the data: a decomposition given non-finite values
    /// or not converging, sums that overflow, a projection without a solution, directions
    /// the data do not excite.
    #[error("{what}: {msg}")]
    Numerical {
        /// The step and the matrix, link or joint ("consistent fit", "joint 'shoulder'").
        what: String,
        /// What went wrong.
        msg: String,
    },
    /// A value of a log (after conditioning, or as given) that is not a finite number.
    #[error("sample {sample}, joint {joint}: {what} is {value}")]
    NonFiniteSample {
        /// The signal ("velocity", "effort").
        what: String,
        /// Sample index.
        sample: usize,
        /// Joint name.
        joint: String,
        /// The value (NaN or infinite).
        value: f64,
    },
    /// A log with fewer usable samples than a step needs.
    #[error("{what} has {samples} usable samples; {needed_by} needs at least {needed}")]
    ShortLog {
        /// Which log ("the log", "validation log").
        what: String,
        /// Usable samples.
        samples: usize,
        /// Samples the step needs.
        needed: usize,
        /// The step ("the diagnosis", "the sample time").
        needed_by: String,
    },
    /// A log whose gaps leave no segment long enough to condition.
    #[error("the log has {gaps} gaps and no segment between them of at least {min_segment} samples")]
    NoSegment {
        /// Gaps found.
        gaps: usize,
        /// Shortest segment used.
        min_segment: usize,
    },
    /// A sample time below what the conditioning accepts (stamps in the wrong unit).
    #[error("sample time {dt:e} s is below the {min:e} s (100 kHz) accepted: stamps in the wrong unit?")]
    SampleTime {
        /// The sample time (s).
        dt: f64,
        /// The smallest accepted (s).
        min: f64,
    },
    /// Joint limits that a step cannot use (an empty position range, a velocity or
    /// acceleration limit that is not positive and finite).
    #[error("joint '{joint}' limits: {msg}")]
    JointLimits {
        /// Joint name.
        joint: String,
        /// What is wrong.
        msg: String,
    },
    /// Settings of the terminal-link estimator (`k`, `first_row`, columns, record counts,
    /// instrument) that do not fit the chain. Python raises `RuntimeError` for these.
    #[error("terminal link: {msg}")]
    TerminalLink {
        /// What is wrong.
        msg: String,
    },
    /// An error inside a named step of a larger one (the diagnosis' nominal model, an
    /// IDIM-IV iteration's simulation): the step, then the error.
    #[error("{step}: {source}")]
    During {
        /// The step.
        step: String,
        /// What went wrong.
        source: Box<Error>,
    },
    /// A broken internal invariant (a fit that was computed but is missing, a worker that
    /// stopped): a bug in ivdyn, never the input's fault.
    #[error("internal error in ivdyn (please report): {msg}")]
    Internal {
        /// The invariant.
        msg: String,
    },
    /// A log file (MCAP or CSV) that cannot be used: truncated or corrupt, topic not found,
    /// wrong schema, joint names that do not match, non-finite values, stamps going back.
    /// The message names the topic, sample index, joint and field where they are known.
    #[error("{file}: {msg}")]
    Log {
        /// The file.
        file: PathBuf,
        /// What is wrong, where.
        msg: String,
    },
    /// An option with a value that cannot be used. `option` is the option's name in
    /// Python's spelling (`payload_mass`); the command line shows it as `--payload-mass`.
    #[error("{option} {msg}")]
    Option {
        /// The option.
        option: String,
        /// What is wrong with it ("must be positive, got -1").
        msg: String,
    },
    /// Fleet statistics (`app::fleet`) that cannot be read or combined: another format
    /// version, another robot model, damaged bytes. `what` names the statistics (their logs).
    #[error("fleet statistics {what}: {msg}")]
    Stats {
        /// The statistics (e.g. "of arm-07 (3 logs)").
        what: String,
        /// What is wrong, naming both sides of a mismatch.
        msg: String,
    },
    /// An error while working on a file (a log, an output): the file, then the error.
    #[error("{file}: {source}")]
    InFile {
        /// The file.
        file: PathBuf,
        /// What went wrong.
        source: Box<Error>,
    },
    /// Bad input to a signal-conditioning function (an option out of range, too few
    /// samples, a non-finite value).
    #[error("signal: {msg}")]
    Signal {
        /// What is wrong.
        msg: String,
    },
}

impl Error {
    /// [`Error::Option`]: `option` (Python's spelling) and what is wrong with its value.
    pub fn option(option: impl Into<String>, msg: impl Into<String>) -> Error {
        Error::Option { option: option.into(), msg: msg.into() }
    }

    /// [`Error::During`]: `source` happened in `step`.
    pub fn during(step: impl Into<String>, source: Error) -> Error {
        Error::During { step: step.into(), source: Box::new(source) }
    }

    /// [`Error::Internal`] with the broken invariant `msg`.
    pub fn internal(msg: impl Into<String>) -> Error {
        Error::Internal { msg: msg.into() }
    }
}

/// Result alias.
pub type Result<T> = std::result::Result<T, Error>;
