//! `identify` as a command: the stream-or-memory choice, then the outputs (parameter file,
//! URDF write-back, MJCF, JSON report, prediction MCAP), written all or none ([`OutputSet`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::Outcome;
use super::html::{IdentifyPage, Series, identify_page};
use super::identify::{IdentifyOptions, IdentifyReport, identify_logs, write_prediction};
use super::io::{LogInput, LogSource};
use super::stream::{Streamed, identify_mcap, write_prediction_mcap};
use crate::Robot;
use crate::error::{Error, Result};
use crate::log::JointLog;
use crate::output::OutputSet;
use crate::progress::Stage;
use crate::robot::physical::refuse_inconsistent;
use crate::robot::{load::side_path, mjcf, write as urdf_write};

/// What `identify` writes (each optional).
#[derive(Debug, Clone, Default)]
pub struct IdentifyOutputs {
    /// The JSON report.
    pub json: Option<PathBuf>,
    /// The identified full parameters (reloadable with `--params`).
    pub params: Option<PathBuf>,
    /// A copy of the URDF `.0` with the identified inertials and friction, written to `.1`
    /// (with its side file).
    pub urdf: Option<(PathBuf, PathBuf)>,
    /// Measured, predicted and residual torques as JointState topics.
    pub mcap: Option<PathBuf>,
    /// An MJCF (MuJoCo) model of the chain with the identified parameters (with its side
    /// file), [`crate::robot::mjcf`].
    pub mjcf: Option<PathBuf>,
    /// The HTML report (one self-contained page, [`super::html`]).
    pub report: Option<PathBuf>,
}

/// One `identify` run.
#[derive(Clone)]
pub struct IdentifyJob {
    /// The log.
    pub log: LogInput,
    /// More logs of the same arm, identified together with `log` (each conditioned and
    /// filtered on its own; the held-out tail is the last one's).
    pub also: Vec<LogInput>,
    /// A validation log (default: the tail of the log, `opts.validation_fraction`).
    pub validate: Option<LogInput>,
    /// How log files are read.
    pub source: LogSource,
    /// Read the whole log into memory even when it could be streamed.
    pub in_memory: bool,
    /// Stream an MCAP log even when it is small enough for memory (the default streams
    /// only logs of more than [`STREAM_ABOVE`] values).
    pub stream: bool,
    /// Fit options (its `validation_log` is set from `validate` when read whole).
    pub opts: IdentifyOptions,
    /// What to write.
    pub outputs: IdentifyOutputs,
}

/// Logs with more than this many values (samples x joints) are streamed: in memory, a
/// 7-joint arm's regressor takes about 560 bytes a value (1 M values: 0.6 GB, twice that
/// while filtering), and memory is where the full conditioning runs (resampling,
/// repeated samples, the log's velocity).
pub const STREAM_ABOVE: u64 = 1_000_000;

/// Runs `job` on `robot`: MCAP logs larger than [`STREAM_ABOVE`] (or any with
/// `job.stream`) are streamed (bounded memory) unless the options or the log need
/// memory, then the outputs are written.
pub fn identify_job(robot: &Robot, job: &IdentifyJob) -> Result<Outcome<IdentifyReport>> {
    let (mut report, mem) = fit(robot, job)?;
    let inputs = std::iter::once(&job.log).chain(&job.also).chain(&job.validate);
    report.notes.extend(inputs.flat_map(LogInput::notes));
    let written = write_outputs(robot, job, &report, mem.as_ref())?;
    Ok(Outcome { report, written })
}

/// The logs of a fit that read them into memory (the outputs use them again).
struct InMemory<'a> {
    /// The first log.
    log: Cow<'a, JointLog>,
    /// The last of the other logs (`also`), if any.
    last: Option<JointLog>,
    /// The validation log, if any.
    validation: Option<JointLog>,
}

/// The fit, and the logs if they were read into memory.
fn fit<'a>(robot: &Robot, job: &'a IdentifyJob) -> Result<(IdentifyReport, Option<InMemory<'a>>)> {
    let mut why_not = job.log.mcap_path().and(job.source.in_memory_reason());
    let streamable = !job.in_memory
        && why_not.is_none()
        && job.also.is_empty()
        && job.validate.as_ref().is_none_or(|v| v.mcap_path().is_some());
    if job.stream && job.in_memory {
        return Err(Error::option("stream", "and in_memory cannot both be set"));
    }
    let large = |p: &Path| -> Result<bool> {
        let count = super::stream::message_count(p, &job.source.topic)?.unwrap_or(0);
        Ok(count.saturating_mul(robot.dof() as u64) > STREAM_ABOVE)
    };
    let wanted = match job.log.mcap_path() {
        Some(p) if streamable => job.stream || large(p).map_err(|e| job.log.context(e))?,
        _ => false,
    };
    if let (Some(path), true) = (job.log.mcap_path(), wanted) {
        let vpath = job.validate.as_ref().and_then(|v| v.mcap_path());
        match identify_mcap(robot, path, vpath, &job.source.read_options(robot), &job.opts)
            .map_err(|e| job.log.context(e))?
        {
            Streamed::Done(r) => return Ok((r, None)),
            Streamed::Unsupported(why) => why_not = Some(why),
        }
    }
    let log = read(robot, &job.log, &job.source, &job.opts)?;
    let mut opts = job.opts.clone();
    opts.validation_log =
        job.validate.as_ref().map(|v| read(robot, v, &job.source, &opts).map(Cow::into_owned)).transpose()?;
    let mut also = job.also.iter().map(|l| read(robot, l, &job.source, &opts)).collect::<Result<Vec<_>>>()?;
    let mut logs: Vec<&JointLog> = vec![&log];
    logs.extend(also.iter().map(|l| l.as_ref()));
    let mut r = identify_logs(robot, &logs, &opts).map_err(|e| job.log.context(e))?;
    if let Some(w) = why_not {
        r.notes.push(format!("read into memory (not streamed): {w}"));
    }
    let last = also.pop().map(Cow::into_owned);
    Ok((r, Some(InMemory { log, last, validation: opts.validation_log.take() })))
}

fn read<'a>(robot: &Robot, input: &'a LogInput, src: &LogSource, opts: &IdentifyOptions) -> Result<Cow<'a, JointLog>> {
    let _st = input.path().map(|p| Stage::begin(&opts.progress, &format!("reading {}", p.display()), 0));
    input.load(robot, src)
}

fn write_outputs(
    robot: &Robot,
    job: &IdentifyJob,
    rep: &IdentifyReport,
    mem: Option<&InMemory<'_>>,
) -> Result<Vec<String>> {
    let out = &job.outputs;
    let mut written = vec![];
    // all of the command's files or none of them
    let mut set = OutputSet::new();
    let params = rep.consistent.as_ref().map(|c| &c.params).unwrap_or(&rep.params);
    if let Some(p) = &out.params {
        set.write_json(p, params)?;
        written.push(format!("parameters written to {}", p.display()));
    }
    let source = if rep.consistent.is_some() {
        "ivdyn identify --consistent: physically consistent full parameters"
    } else {
        "ivdyn identify: nominal parameters corrected in the identifiable directions (BaseParams::apply)"
    };
    // the robot with the written parameters and Coulomb shapes
    let shaped = || -> Result<Robot> {
        let mut r = robot.clone();
        crate::robot::load::load_params(&mut r, params)?;
        Ok(r)
    };
    if let Some((input, path)) = &out.urdf {
        let text = std::fs::read_to_string(input).map_err(|e| Error::Io { file: input.clone(), source: e })?;
        let arm = shaped()?;
        refuse_inconsistent(&arm, &params.theta, "URDF").map_err(|e| in_output(e, path))?;
        let wb = urdf_write::write_back(&text, input, &arm, Some(&params.theta), None, vec![source.to_string()])?;
        urdf_write::stage_files(&mut set, path, &wb)?;
        written.push(format!(
            "URDF written to {} (armature and offsets in {})",
            path.display(),
            side_path(path).display()
        ));
    }
    if let Some(path) = &out.mjcf {
        let mj = mjcf::to_mjcf(&shaped()?, None, vec![source.to_string()]).map_err(|e| in_output(e, path))?;
        mjcf::stage_files(&mut set, path, &mj)?;
        written.push(format!("MJCF written to {} (torque offsets in {})", path.display(), side_path(path).display()));
    }
    if let Some(p) = &out.json {
        set.write_json(p, rep)?;
        written.push(format!("report written to {}", p.display()));
    }
    if let Some(p) = &out.mcap {
        let mut model = robot.clone();
        crate::robot::load::load_params(&mut model, &rep.params)?;
        let k = prediction(&mut set, robot, &model, job, mem.map(|m| m.log.as_ref()), p)?;
        written.push(format!("measured, predicted and residual torques ({k} samples) written to {} (topics /joint_states, /ivdyn/predicted, /ivdyn/residual)", p.display()));
    }
    if let Some(p) = &out.report {
        let page = report_page(robot, job, rep, mem, p)?;
        set.write_bytes(p, page.as_bytes())?;
        written.push(format!("HTML report written to {}", p.display()));
    }
    set.commit()?;
    Ok(written)
}

/// `e` as an error of the output file `path` (nothing was written).
fn in_output(e: Error, path: &Path) -> Error {
    Error::InFile { file: path.to_path_buf(), source: Box::new(e) }
}

/// The HTML report's text: the last log (its held-out tail) and the validation log,
/// predicted by the identified model; a streamed log is read whole here (only its joint
/// states: the regressor, which made it too large, is not built).
fn report_page(
    robot: &Robot,
    job: &IdentifyJob,
    rep: &IdentifyReport,
    mem: Option<&InMemory<'_>>,
    file: &Path,
) -> Result<String> {
    let _st = Stage::begin(&job.opts.progress, "HTML report", 0);
    let mut model = robot.clone();
    crate::robot::load::load_params(&mut model, &rep.params)?;
    let cond = &job.opts.condition;
    let in_log = |input: &LogInput, log: &JointLog| Series::of(&[&model], log, cond).map_err(|e| input.context(e));
    let last_input = job.also.last().unwrap_or(&job.log);
    let log = match mem {
        Some(m) => in_log(last_input, m.last.as_ref().unwrap_or(&m.log))?,
        None => in_log(&job.log, &*job.log.load(robot, &job.source)?)?,
    };
    let validation = match (mem, &job.validate) {
        (Some(InMemory { validation: Some(v), .. }), Some(input)) => Some(in_log(input, v)?),
        (_, Some(input)) => Some(in_log(input, &*input.load(robot, &job.source)?)?),
        (_, None) => None,
    };
    let f = job.opts.validation_fraction;
    let held_out_from = (validation.is_none() && f > 0.0).then(|| ((1.0 - f) * log.len() as f64) as usize);
    let logs = std::iter::once(&job.log).chain(&job.also).map(input_name).collect();
    let page = IdentifyPage { robot, report: rep, logs, log: &log, held_out_from, validation: validation.as_ref() };
    identify_page(&page, file)
}

/// A log input as the report names it: its file, or "(arrays)".
pub(crate) fn input_name(input: &LogInput) -> String {
    input.path().map(|p| p.display().to_string()).unwrap_or_else(|| "(arrays)".into())
}

/// The prediction MCAP, staged in `set`: streamed from the log file when the fit was,
/// else from memory.
fn prediction(
    set: &mut OutputSet,
    robot: &Robot,
    model: &Robot,
    job: &IdentifyJob,
    mem: Option<&JointLog>,
    out: &Path,
) -> Result<usize> {
    let in_file = |e: Error| match e {
        e @ (Error::Log { .. } | Error::Io { .. } | Error::InFile { .. }) => e,
        e => Error::InFile { file: out.to_path_buf(), source: Box::new(e) },
    };
    let mut k = 0;
    set.write(out, |tmp| {
        if let (None, Some(path)) = (mem, job.log.mcap_path())
            && let Streamed::Done(n) =
                write_prediction_mcap(tmp, model, path, &job.source.read_options(robot), &job.opts).map_err(in_file)?
        {
            k = n;
            return Ok(());
        }
        let log = match mem {
            Some(l) => Cow::Borrowed(l),
            None => job.log.load(robot, &job.source)?,
        };
        k = write_prediction(tmp, model, &log, &job.opts.condition).map_err(in_file)?;
        Ok(())
    })?;
    Ok(k)
}
