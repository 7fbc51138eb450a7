//! What the jobs read and write: the robot and log sources of a command, and outputs
//! written whole or not at all (staged in an [`crate::output::OutputSet`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::effort::{self, Effort, TorqueConstants};
use crate::Robot;
use crate::error::{Error, Result};
use crate::log::{JointLog, ReadOptions, read_pipeline_log};
use crate::output::OutputSet;
use crate::robot::load;
use crate::robot::urdf::UrdfOptions;

/// Where a command's robot comes from: a URDF (with its side file, when present), the
/// chain's base and tip links, and optionally a parameter file replacing every parameter.
#[derive(Debug, Clone, Default)]
pub struct RobotSource {
    /// URDF file.
    pub urdf: PathBuf,
    /// Base link (default: the URDF's root).
    pub base: Option<String>,
    /// Tip link (default: the end of an unbranched chain; a tip given ends the chain).
    pub tip: Option<String>,
    /// Fuse the bodies below a given tip into the last link instead of dropping them.
    pub fuse_beyond_tip: bool,
    /// Parameter file written by `identify --out-params`.
    pub params: Option<PathBuf>,
}

impl RobotSource {
    /// Loads the robot ([`load::load`]).
    pub fn load(&self) -> Result<Robot> {
        let opts =
            UrdfOptions { base: self.base.clone(), tip: self.tip.clone(), fuse_beyond_tip: self.fuse_beyond_tip };
        load::load(&self.urdf, &opts, self.params.as_deref())
    }

    /// The side file that [`RobotSource::load`] applies, if there is one (the command
    /// line says so).
    pub fn side_file(&self) -> Option<PathBuf> {
        let side = load::side_path(&self.urdf);
        (self.params.is_none() && side.exists()).then_some(side)
    }
}

/// How logs are read: the JointState topic, an optional command topic, the stamps, and
/// which effort is the joint torque (a measured torque, or a motor current times the
/// torque constants: [`super::effort`]).
#[derive(Debug, Clone)]
pub struct LogSource {
    /// JointState topic of MCAP logs.
    pub topic: String,
    /// JointState topic carrying the actuator command `u` (its effort field).
    pub command_topic: Option<String>,
    /// MCAP log times instead of header stamps.
    pub log_time: bool,
    /// JointState topic whose effort field is the motor current (may be `topic` itself).
    pub current_topic: Option<String>,
    /// Which effort is the joint torque.
    pub effort: Effort,
    /// How motor currents become joint torques.
    pub torque_constants: TorqueConstants,
}

impl Default for LogSource {
    fn default() -> Self {
        LogSource {
            topic: "/joint_states".into(),
            command_topic: None,
            log_time: false,
            current_topic: None,
            effort: Effort::Auto,
            torque_constants: TorqueConstants::default(),
        }
    }
}

impl LogSource {
    /// The streaming reader's options for `robot`'s joints.
    pub fn read_options(&self, robot: &Robot) -> ReadOptions {
        ReadOptions::new(&robot.joint_names)
            .topic(&self.topic)
            .command_topic_opt(self.command_topic.as_deref())
            .current_topic_opt(self.current_topic.as_deref())
            .log_time(self.log_time)
    }

    /// Why logs read this way are not streamed (`None`: they may be): currents are turned
    /// into torques in memory.
    pub fn in_memory_reason(&self) -> Option<String> {
        (self.current_topic.is_some() || self.effort == Effort::Current)
            .then(|| "motor currents are turned into torques in memory".into())
    }

    /// Reads a whole log file (`.csv`, or MCAP) and checks it ([`read_pipeline_log`]).
    pub fn read(&self, path: &Path, robot: &Robot) -> Result<JointLog> {
        read_pipeline_log(path, &self.read_options(robot))
    }
}

/// A log given as a file (read, or streamed when the options allow) or as arrays.
#[derive(Debug, Clone)]
pub enum LogInput {
    /// A `.mcap` or `.csv` file.
    File(PathBuf),
    /// Arrays already in memory (checked as a file's would be).
    Arrays(JointLog),
}

impl LogInput {
    /// The file, if the log is one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            LogInput::File(p) => Some(p),
            LogInput::Arrays(_) => None,
        }
    }

    /// What the user should know about how a ROS 2 bag directory was read (its files
    /// found without `metadata.yaml`: [`crate::log::LogFiles::notes`]); none otherwise.
    pub fn notes(&self) -> Vec<String> {
        match self.path() {
            Some(p) if p.is_dir() => crate::log::log_files(p).map(|l| l.notes).unwrap_or_default(),
            _ => vec![],
        }
    }

    /// An MCAP file (what the streaming reader takes; CSV and arrays are read whole).
    pub fn mcap_path(&self) -> Option<&Path> {
        self.path().filter(|p| !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
    }

    /// The log in memory, its effort chosen and, for a motor current, turned into joint
    /// torques ([`effort::to_torque`]): the one place every job's logs go through.
    pub fn load(&self, robot: &Robot, src: &LogSource) -> Result<Cow<'_, JointLog>> {
        let log = self.raw(robot, src)?;
        effort::to_torque(log, src.effort, &src.torque_constants, &robot.joint_names).map_err(|e| self.context(e))
    }

    /// The log in memory with the drive current as its effort, for the drive-gain fit
    /// ([`effort::current_as_effort`]), and which signal that is.
    pub fn load_current(
        &self,
        robot: &Robot,
        src: &LogSource,
        what: &str,
    ) -> Result<(Cow<'_, JointLog>, &'static str)> {
        let log = self.raw(robot, src)?;
        effort::current_as_effort(log, src.effort, &src.torque_constants, what).map_err(|e| self.context(e))
    }

    /// The log as read (a file) or given (arrays).
    fn raw(&self, robot: &Robot, src: &LogSource) -> Result<Cow<'_, JointLog>> {
        let log = match self {
            LogInput::File(p) => Cow::Owned(src.read(p, robot)?),
            LogInput::Arrays(l) => Cow::Borrowed(l),
        };
        // positions in degrees would pass every other check and fit nonsense
        crate::prep::hygiene::degrees_check(&log, &revolute_limits(robot)).map_err(|e| self.context(e))?;
        // an angle reported modulo 2 pi would be differentiated into spikes of 2 pi / dt
        let n = log.dof();
        if crate::prep::hygiene::first_wrap(&log.q, n, None).is_none() {
            return Ok(log);
        }
        let mut log = log.into_owned();
        crate::prep::hygiene::unwrap_angles(&mut log.q, n, &revolute(robot));
        Ok(Cow::Owned(log))
    }

    /// `e` prefixed with the log file, unless it already names a file.
    pub fn context(&self, e: Error) -> Error {
        match (self, e) {
            (_, e @ (Error::Log { .. } | Error::Io { .. } | Error::InFile { .. })) => e,
            (LogInput::File(p), e) => Error::InFile { file: p.clone(), source: Box::new(e) },
            (LogInput::Arrays(_), e) => e,
        }
    }
}

/// A log written as `.mcap` or `.csv` (by the extension), whole or not at all.
pub fn write_log(path: &Path, log: &JointLog) -> Result<()> {
    let mut set = OutputSet::new();
    stage_log(&mut set, path, log)?;
    set.commit()
}

/// [`write_log`] into `set` (put in place when `set` is committed).
pub fn stage_log(set: &mut OutputSet, path: &Path, log: &JointLog) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext != "csv" && ext != "mcap" {
        return Err(Error::Log {
            file: path.to_path_buf(),
            msg: format!("unknown output format '.{ext}' (use .mcap or .csv)"),
        });
    }
    set.write(path, |tmp| {
        if ext == "csv" { crate::log::write_csv(tmp, log) } else { crate::log::write_mcap(tmp, log, &[]).map(|_| ()) }
    })
}

/// Whether each joint is revolute (its position an angle).
fn revolute(robot: &Robot) -> Vec<bool> {
    robot.model.to_chain().joints.iter().map(|j| j.kind == ivdyn_core::JointKind::Revolute).collect()
}

/// Each joint's position limits in rad when it is revolute and has them.
fn revolute_limits(robot: &Robot) -> Vec<Option<(f64, f64)>> {
    let c = robot.model.to_chain();
    c.joints
        .iter()
        .zip(&c.limits)
        .map(|(j, l)| {
            (j.kind == ivdyn_core::JointKind::Revolute
                && l.lower.is_finite()
                && l.upper.is_finite()
                && l.upper > l.lower)
                .then_some((l.lower, l.upper))
        })
        .collect()
}
