//! The command line's jobs from Python: `ivdyn::app::{identify_job, payload_job,
//! gains_job, simulate_job, diagnose_job, excite_job}` (the same functions the command line calls, with
//! the same options) on a robot and a log (a file, or arrays), returning the JSON document
//! the command line writes with `--json` (as a string; the Python wrapper parses it), with
//! the GIL released. This file only converts arguments and results.
//!
//! Progress goes through the pipeline's own `Progress` hook (the one the command line
//! draws its bars with). The hook re-acquires the GIL only to call the Python callback and
//! to check for Ctrl-C. A Python exception there (or KeyboardInterrupt) must stop the
//! pipeline, but `Progress` cannot return an error: the hook stores the exception and
//! unwinds with `resume_unwind` (no panic message), the binding catches the unwind and
//! raises the stored exception. Nothing is shared with the caller but read-only inputs,
//! so no half-updated state survives the abort.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::PyRobot;
use crate::error::to_py;
use ivdyn::Robot;
use ivdyn::app::{
    self, Effort, IdentifyOptions, LogInput, LogSource, Method, PayloadOptions, PerJoint, SimulateOptions,
    TorqueConstants, Trajectory,
};
use ivdyn::dsp::{DEFAULT_ORDER, DiffMethod};
use ivdyn::log::JointLog;
use ivdyn::prep::ConditionOptions;
use ivdyn::progress::Progress;
use ivdyn::report::PayloadSpec;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

// ------------------------------------------------------------------ progress

/// `Progress` that calls `callback(stage, done, total)` (when given) and checks for
/// Ctrl-C, with the GIL taken only for that.
struct PyProgress {
    callback: Option<Py<PyAny>>,
    /// Current stage, its total (0: unknown) and the units done.
    state: Mutex<(String, u64, u64)>,
    /// The exception that stopped the run.
    failed: Mutex<Option<PyErr>>,
}

/// Unwind payload of an abort requested from Python.
struct Abort;

impl PyProgress {
    fn report(&self) {
        let (stage, total, done) = self.state.lock().map(|s| s.clone()).unwrap_or_default();
        let r = Python::attach(|py| -> PyResult<()> {
            py.check_signals()?;
            if let Some(cb) = &self.callback {
                cb.call1(py, (stage, done, total))?;
            }
            Ok(())
        });
        if let Err(e) = r {
            if let Ok(mut f) = self.failed.lock() {
                *f = Some(e);
            }
            resume_unwind(Box::new(Abort));
        }
    }
}

impl Progress for PyProgress {
    fn begin(&self, stage: &str, total: u64) {
        if let Ok(mut s) = self.state.lock() {
            *s = (stage.to_string(), total, 0);
        }
        self.report();
    }
    fn advance(&self, n: u64) {
        if let Ok(mut s) = self.state.lock() {
            s.2 += n;
        }
        self.report();
    }
    fn end(&self) {}
}

/// Runs `f` (a pipeline) with the GIL released and `progress` as its sink; turns an abort
/// from the callback back into its Python exception.
pub(crate) fn run<T: Send>(
    py: Python<'_>,
    callback: Option<Py<PyAny>>,
    f: impl FnOnce(ivdyn::progress::ProgressSink) -> ivdyn::error::Result<T> + Send,
) -> PyResult<T> {
    let sink = Arc::new(PyProgress { callback, state: Mutex::new((String::new(), 0, 0)), failed: Mutex::new(None) });
    let s2: Arc<dyn Progress> = sink.clone();
    let r = py.detach(|| catch_unwind(AssertUnwindSafe(|| f(Some(s2)))));
    let failed = sink.failed.lock().ok().and_then(|mut f| f.take());
    match (r, failed) {
        (_, Some(e)) => Err(e),
        (Ok(r), None) => r.map_err(to_py),
        // a RuntimeError, not pyo3's PanicException (a BaseException `except Exception` misses)
        (Err(p), None) => Err(crate::error::panic_to_py(p)),
    }
}

// ------------------------------------------------------------------ inputs

pub(crate) fn robot_with_params(robot: &Robot, params_json: Option<&str>) -> PyResult<Robot> {
    let mut r = robot.clone();
    if let Some(js) = params_json {
        ivdyn::robot::load::apply_params_json(&mut r, js, Path::new("params")).map_err(to_py)?;
    }
    Ok(r)
}

fn f64_1d(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Option<Vec<f64>>> {
    match d.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => {
            let a: PyReadonlyArray1<f64> = v
                .extract()
                .map_err(|_| PyValueError::new_err(format!("log['{key}'] must be a float64 array of shape (T,)")))?;
            Ok(Some(a.as_array().iter().copied().collect()))
        }
    }
}

fn f64_2d(d: &Bound<'_, PyDict>, key: &str, t: usize, n: usize) -> PyResult<Option<Vec<f64>>> {
    match d.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => {
            let a: PyReadonlyArray2<f64> = v.extract().map_err(|_| {
                PyValueError::new_err(format!("log['{key}'] must be a float64 array of shape ({t}, {n})"))
            })?;
            if a.shape() != [t, n] {
                return Err(PyValueError::new_err(format!(
                    "log['{key}'] must have shape ({t}, {n}), got ({}, {})",
                    a.shape()[0],
                    a.shape()[1]
                )));
            }
            Ok(Some(a.as_array().iter().copied().collect()))
        }
    }
}

/// A log given as a path (read by the job, as the command line reads it) or as a dict of
/// arrays (`t`, `q`, optional `qd`, `tau`, `u`, `current`, `joint_names`), checked like a
/// file's.
pub(crate) fn log_input(robot: &Robot, log: &Bound<'_, PyAny>, what: &str) -> PyResult<LogInput> {
    let Ok(d) = log.cast::<PyDict>() else {
        let path: PathBuf = log.extract().map_err(|_| {
            PyValueError::new_err(format!("{what} must be a path (str or os.PathLike) or a dict of arrays"))
        })?;
        return Ok(LogInput::File(path));
    };
    let n = robot.dof();
    let t = f64_1d(d, "t")?
        .ok_or_else(|| PyValueError::new_err(format!("{what}: a log dict needs 't' (T,) and 'q' (T, {n})")))?;
    let len = t.len();
    let q = f64_2d(d, "q", len, n)?
        .ok_or_else(|| PyValueError::new_err(format!("{what}: a log dict needs 'q' (T, {n})")))?;
    if let Some(names) = d.get_item("joint_names")?
        && !names.is_none()
    {
        let names: Vec<String> = names.extract()?;
        if names != robot.joint_names {
            return Err(PyValueError::new_err(format!(
                "{what}: log joints {names:?} are not the robot's {:?}",
                robot.joint_names
            )));
        }
    }
    let jl = JointLog {
        joint_names: robot.joint_names.clone(),
        t0_ns: 0,
        t,
        q,
        qd: f64_2d(d, "qd", len, n)?,
        tau: f64_2d(d, "tau", len, n)?,
        u: f64_2d(d, "u", len, n)?,
        current: f64_2d(d, "current", len, n)?,
        truncated: false,
    };
    ivdyn::log::check_pipeline_log(&jl, Path::new(what), "(arrays)").map_err(to_py)?;
    Ok(LogInput::Arrays(jl))
}

pub(crate) fn log_source(topic: &str, command_topic: Option<&str>, log_time: bool) -> LogSource {
    LogSource { topic: topic.into(), command_topic: command_topic.map(Into::into), log_time, ..Default::default() }
}

/// A per-joint value as Python gives it: a number (every joint), a sequence (one per
/// joint), a dict `{joint: value}`, or the command line's text.
fn per_joint(option: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<PerJoint>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(None) };
    if let Ok(d) = v.cast::<PyDict>() {
        let pair = |(k, v): (Bound<'_, PyAny>, Bound<'_, PyAny>)| Ok((k.extract::<String>()?, v.extract::<f64>()?));
        let pairs: PyResult<Vec<(String, f64)>> = d.iter().map(pair).collect();
        return pairs.map(|p| Some(PerJoint::Named(p))).map_err(|_: PyErr| bad_per_joint(option));
    }
    if let Ok(text) = v.extract::<String>() {
        return PerJoint::parse(option, &text).map(Some).map_err(to_py);
    }
    if let Ok(x) = v.extract::<f64>() {
        return Ok(Some(PerJoint::All(x)));
    }
    v.extract::<Vec<f64>>().map(|l| Some(PerJoint::List(l))).map_err(|_| bad_per_joint(option))
}

fn bad_per_joint(option: &str) -> PyErr {
    PyValueError::new_err(format!(
        "{option} must be a number, a sequence of numbers (one per joint) or a dict {{joint: number}}"
    ))
}

/// Which effort is the joint torque, and how currents become torques (`ivdyn::app::effort`).
struct EffortArgs<'a, 'py> {
    current_topic: Option<&'a str>,
    effort: &'a str,
    torque_constant: Option<&'a Bound<'py, PyAny>>,
    gear_ratio: Option<&'a Bound<'py, PyAny>>,
    motor_constant: Option<&'a Bound<'py, PyAny>>,
}

impl EffortArgs<'_, '_> {
    /// `src` with these effort options.
    fn apply(&self, src: LogSource) -> PyResult<LogSource> {
        Ok(LogSource {
            current_topic: self.current_topic.map(Into::into),
            effort: Effort::from_name(self.effort).map_err(to_py)?,
            torque_constants: TorqueConstants {
                torque_constant: per_joint("torque_constant", self.torque_constant)?,
                gear_ratio: per_joint("gear_ratio", self.gear_ratio)?,
                motor_constant: per_joint("motor_constant", self.motor_constant)?,
            },
            ..src
        })
    }
}

pub(crate) fn condition(
    cutoff: Option<f64>,
    velocity: &str,
    window: Option<(f64, f64)>,
    exclude: Option<Vec<(f64, f64)>>,
) -> PyResult<ConditionOptions> {
    let mut c = ConditionOptions {
        velocity: ivdyn::prep::VelocitySource::parse(velocity).map_err(to_py)?,
        window,
        exclude: exclude.unwrap_or_default(),
        ..Default::default()
    };
    if let Some(fc) = cutoff {
        if !(fc > 0.0 && fc.is_finite()) {
            return Err(PyValueError::new_err(format!("cutoff must be finite and > 0 Hz, got {fc}")));
        }
        c.diff = DiffMethod::Butterworth { order: DEFAULT_ORDER, cutoff_hz: Some(fc) };
    }
    Ok(c)
}

pub(crate) fn json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| PyRuntimeError::new_err(format!("internal error: report to JSON: {e}")))
}

/// The URDF a write-back starts from: the file the robot was loaded from.
fn urdf_of(robot: &PyRobot, what: &str) -> PyResult<PathBuf> {
    robot
        .urdf
        .clone()
        .ok_or_else(|| PyValueError::new_err(format!("{what} needs a robot loaded from a URDF file (Robot.from_urdf)")))
}

// ------------------------------------------------------------------ identify / payload

/// `ivdyn identify` -> the `--json` document (a string); writes the outputs asked for.
#[pyfunction]
#[pyo3(signature = (robot, log, method="wls", validate=None, holdout=0.25, topic="/joint_states", command_topic=None,
                    log_time=false, cutoff=None, decimate=0, params_json=None, progress=None, friction=None,
                    armature=true, offset=true, consistent=false, in_memory=false, json_out=None, out_params=None,
                    write_urdf=None, out_mcap=None, velocity="auto", window=None, exclude=None, stream=false,
                    current_topic=None, effort="auto", torque_constant=None,
                    gear_ratio=None, motor_constant=None, coulomb="auto", write_mjcf=None, report=None))]
#[allow(clippy::too_many_arguments)]
fn identify(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    method: &str,
    validate: Option<&Bound<'_, PyAny>>,
    holdout: f64,
    topic: &str,
    command_topic: Option<&str>,
    log_time: bool,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    progress: Option<Py<PyAny>>,
    friction: Option<Vec<String>>,
    armature: bool,
    offset: bool,
    consistent: bool,
    in_memory: bool,
    json_out: Option<PathBuf>,
    out_params: Option<PathBuf>,
    write_urdf: Option<PathBuf>,
    out_mcap: Option<PathBuf>,
    velocity: &str,
    window: Option<(f64, f64)>,
    exclude: Option<Vec<(f64, f64)>>,
    stream: bool,
    current_topic: Option<&str>,
    effort: &str,
    torque_constant: Option<&Bound<'_, PyAny>>,
    gear_ratio: Option<&Bound<'_, PyAny>>,
    motor_constant: Option<&Bound<'_, PyAny>>,
    coulomb: &str,
    write_mjcf: Option<PathBuf>,
    report: Option<PathBuf>,
) -> PyResult<String> {
    let effort = EffortArgs { current_topic, effort, torque_constant, gear_ratio, motor_constant };
    let coulomb = app::identify::CoulombMode::from_name(coulomb).map_err(to_py)?;
    let method = match method {
        "ols" => Method::Ols,
        "wls" => Method::Wls,
        "iv" => Method::Iv,
        "idim-iv" | "idim_iv" => Method::IdimIv,
        m => return Err(PyValueError::new_err(format!("method must be 'ols', 'wls', 'iv' or 'idim-iv', got {m:?}"))),
    };
    // holdout: checked with the other options by the app layer (IdentifyOptions::check)
    let friction = friction.unwrap_or_else(|| vec!["coulomb".into(), "viscous".into()]);
    let names: Vec<&str> = friction.iter().map(String::as_str).collect();
    let drive = ivdyn::ident::DriveTerms::from_names(&names, armature, offset).map_err(to_py)?;
    let urdf = write_urdf.map(|o| urdf_of(&robot, "write_urdf").map(|i| (i, o))).transpose()?;
    let r = robot_with_params(&robot.inner, params_json)?;
    // a list of logs: identified together
    let (log, also) = match log.cast::<pyo3::types::PyList>() {
        Ok(list) if !list.is_empty() => {
            let all = list.iter().enumerate().map(|(i, l)| log_input(&r, &l, &format!("log {}", i + 1)));
            let mut all = all.collect::<PyResult<Vec<_>>>()?;
            let first = all.remove(0);
            (first, all)
        }
        _ => (log_input(&r, log, "log")?, vec![]),
    };
    let job = app::IdentifyJob {
        log,
        also,
        validate: validate.map(|v| log_input(&r, v, "validation log")).transpose()?,
        source: effort.apply(log_source(topic, command_topic, log_time))?,
        in_memory,
        stream,
        opts: IdentifyOptions {
            method,
            condition: condition(cutoff, velocity, window, exclude)?,
            decimate,
            validation_fraction: holdout,
            drive,
            coulomb,
            consistent,
            ..Default::default()
        },
        outputs: app::IdentifyOutputs {
            json: json_out,
            params: out_params,
            urdf,
            mcap: out_mcap,
            mjcf: write_mjcf,
            report,
        },
    };
    let out = run(py, progress, |p| {
        app::identify_job(
            &r,
            &app::IdentifyJob { opts: IdentifyOptions { progress: p, ..job.opts.clone() }, ..job.clone() },
        )
    })?;
    json(&out.report)
}

/// `ivdyn payload` -> the `--json` document (a string); writes the outputs asked for.
#[pyfunction]
#[pyo3(signature = (robot, log, before=None, topic="/joint_states", log_time=false, cutoff=None,
                    decimate=0, params_json=None, progress=None, json_out=None, write_urdf=None, payload_as="link",
                    velocity="auto", window=None, exclude=None,
                    current_topic=None, effort="auto", torque_constant=None, gear_ratio=None, motor_constant=None,
                    torque_constant_std=None, gains=None, write_mjcf=None, report=None))]
#[allow(clippy::too_many_arguments)]
fn payload(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    before: Option<&Bound<'_, PyAny>>,
    topic: &str,
    log_time: bool,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    progress: Option<Py<PyAny>>,
    json_out: Option<PathBuf>,
    write_urdf: Option<PathBuf>,
    payload_as: &str,
    velocity: &str,
    window: Option<(f64, f64)>,
    exclude: Option<Vec<(f64, f64)>>,
    current_topic: Option<&str>,
    effort: &str,
    torque_constant: Option<&Bound<'_, PyAny>>,
    gear_ratio: Option<&Bound<'_, PyAny>>,
    motor_constant: Option<&Bound<'_, PyAny>>,
    torque_constant_std: Option<&Bound<'_, PyAny>>,
    gains: Option<String>,
    write_mjcf: Option<PathBuf>,
    report: Option<PathBuf>,
) -> PyResult<String> {
    let effort = EffortArgs { current_topic, effort, torque_constant, gear_ratio, motor_constant };
    let prior =
        app::TorqueConstantPrior { std: per_joint("torque_constant_std", torque_constant_std)?, gains_report: gains };
    let mode = match payload_as {
        "link" => app::PayloadMode::Link,
        "merge" => app::PayloadMode::Merge,
        m => return Err(PyValueError::new_err(format!("payload_as must be 'link' or 'merge', got {m:?}"))),
    };
    let urdf = write_urdf.map(|o| urdf_of(&robot, "write_urdf").map(|i| (i, o, mode))).transpose()?;
    let r = robot_with_params(&robot.inner, params_json)?;
    let job = app::PayloadJob {
        log: log_input(&r, log, "log")?,
        before: before.map(|b| log_input(&r, b, "before log")).transpose()?,
        source: effort.apply(log_source(topic, None, log_time))?,
        opts: PayloadOptions {
            condition: condition(cutoff, velocity, window, exclude)?,
            decimate,
            ..Default::default()
        },
        json: json_out,
        report,
        urdf,
        mjcf: write_mjcf,
        torque_constant_prior: prior,
    };
    let out = run(py, progress, |p| {
        app::payload_job(
            &r,
            &app::PayloadJob { opts: PayloadOptions { progress: p, ..job.opts.clone() }, ..job.clone() },
        )
    })?;
    json(&out.report)
}

/// `ivdyn gains` -> the `--json` document (a string); writes it to `json_out` when given.
#[pyfunction]
#[pyo3(signature = (robot, unloaded, loaded, payload_mass, payload_com=None, payload_inertia=None,
                    topic="/joint_states", log_time=false, cutoff=None, decimate=0, params_json=None, progress=None,
                    json_out=None, velocity="auto", window=None, current_topic=None, effort="auto", max_rel_std=0.1))]
#[allow(clippy::too_many_arguments)]
fn gains(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    unloaded: &Bound<'_, PyAny>,
    loaded: &Bound<'_, PyAny>,
    payload_mass: f64,
    payload_com: Option<Vec<f64>>,
    payload_inertia: Option<Vec<f64>>,
    topic: &str,
    log_time: bool,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    progress: Option<Py<PyAny>>,
    json_out: Option<PathBuf>,
    velocity: &str,
    window: Option<(f64, f64)>,
    current_topic: Option<&str>,
    effort: &str,
    max_rel_std: f64,
) -> PyResult<String> {
    // the torque constants are what the job estimates: none are passed on
    let effort = EffortArgs { current_topic, effort, torque_constant: None, gear_ratio: None, motor_constant: None };
    let r = robot_with_params(&robot.inner, params_json)?;
    let job = app::GainsJob {
        unloaded: log_input(&r, unloaded, "unloaded log")?,
        loaded: log_input(&r, loaded, "loaded log")?,
        source: effort.apply(log_source(topic, None, log_time))?,
        payload: app::KnownPayload::from_parts(payload_mass, payload_com.as_deref(), payload_inertia.as_deref())
            .map_err(to_py)?,
        opts: app::GainsOptions {
            condition: condition(cutoff, velocity, window, None)?,
            decimate,
            max_rel_std,
            ..Default::default()
        },
        json: json_out,
    };
    let out = run(py, progress, |p| {
        app::gains_job(
            &r,
            &app::GainsJob { opts: app::GainsOptions { progress: p, ..job.opts.clone() }, ..job.clone() },
        )
    })?;
    json(&out.report)
}

// ------------------------------------------------------------------ simulate

/// A log as the dict of arrays every Python function takes and returns: `t` (T,), `q`,
/// `qd`, `tau`, `u` (T, N) or None, `joint_names`, `t0_ns` (the first stamp), `truncated`.
pub(crate) fn log_dict<'py>(py: Python<'py>, log: JointLog) -> PyResult<Bound<'py, PyDict>> {
    let (t, nn) = (log.len(), log.dof());
    let as2 = |v: Option<Vec<f64>>| -> PyResult<Option<Bound<'py, numpy::PyArray2<f64>>>> {
        v.map(|v| {
            Array2::from_shape_vec((t, nn), v)
                .map(|a| a.into_pyarray(py))
                .map_err(|e| PyValueError::new_err(e.to_string()))
        })
        .transpose()
    };
    let d = PyDict::new(py);
    d.set_item("t", log.t.into_pyarray(py))?;
    d.set_item("q", as2(Some(log.q))?)?;
    d.set_item("qd", as2(log.qd)?)?;
    d.set_item("tau", as2(log.tau)?)?;
    d.set_item("u", as2(log.u)?)?;
    d.set_item("current", as2(log.current)?)?;
    d.set_item("joint_names", log.joint_names)?;
    d.set_item("t0_ns", log.t0_ns)?;
    d.set_item("truncated", log.truncated)?;
    Ok(d)
}

/// `ivdyn simulate` -> (the `--json` summary as a string, the log as a dict of arrays);
/// writes the log to `out` (`.mcap` or `.csv`) and the summary to `json_out` when given.
#[pyfunction]
#[pyo3(signature = (robot, out=None, traj_t=None, traj_q=None, duration=20.0, rate=500.0, seed=1, amplitude=0.8,
                    payload_mass=None, payload_com=None, payload_inertia=None, fc=None, fv=None, noise=0.0, noise_q=0.0,
                    encoder_bits=None, tau_resolution=None, velocity=true, command=false, params_json=None, json_out=None))]
#[allow(clippy::too_many_arguments)]
fn simulate<'py>(
    py: Python<'py>,
    robot: PyRef<'py, PyRobot>,
    out: Option<PathBuf>,
    traj_t: Option<PyReadonlyArray1<'py, f64>>,
    traj_q: Option<PyReadonlyArray2<'py, f64>>,
    duration: f64,
    rate: f64,
    seed: u64,
    amplitude: f64,
    payload_mass: Option<f64>,
    payload_com: Option<Vec<f64>>,
    payload_inertia: Option<Vec<f64>>,
    fc: Option<Vec<f64>>,
    fv: Option<Vec<f64>>,
    noise: f64,
    noise_q: f64,
    encoder_bits: Option<u32>,
    tau_resolution: Option<f64>,
    velocity: bool,
    command: bool,
    params_json: Option<&str>,
    json_out: Option<PathBuf>,
) -> PyResult<(String, Bound<'py, PyDict>)> {
    let r = robot_with_params(&robot.inner, params_json)?;
    let n = r.dof();
    let payload =
        PayloadSpec::from_parts(payload_mass, payload_com.as_deref(), payload_inertia.as_deref()).map_err(to_py)?;
    let opts = SimulateOptions {
        rate_hz: rate,
        duration_s: duration,
        seed,
        amplitude,
        payload,
        fc,
        fv,
        noise_tau: noise,
        noise_q,
        encoder_bits,
        tau_resolution,
        write_velocity: velocity,
        write_command: command,
        ..Default::default()
    };
    let traj = match (traj_t, traj_q) {
        (None, None) => Trajectory::Fourier,
        (Some(t), Some(q)) => {
            let len = t.shape()[0];
            if q.shape() != [len, n] {
                return Err(PyValueError::new_err(format!(
                    "traj['q'] must have shape ({len}, {n}), got ({}, {})",
                    q.shape()[0],
                    q.shape()[1]
                )));
            }
            Trajectory::Samples { t: t.as_array().to_vec(), q: q.as_array().iter().copied().collect() }
        }
        _ => return Err(PyValueError::new_err("traj needs both 't' and 'q'")),
    };
    let job = app::SimulateJob { opts, traj, out, json: json_out };
    let done = run(py, None, |p| app::simulate_job(&r, &job, &p))?;
    let (log, summary) = done.report;
    Ok((json(&summary)?, log_dict(py, log)?))
}

// ------------------------------------------------------------------ diagnose / excite

/// `ivdyn diagnose` -> `diagnosis.json` (a string); with `out`, also writes
/// diagnosis.json, report.html and residuals.mcap there.
#[pyfunction]
#[pyo3(signature = (robot, log, out=None, topic="/joint_states", log_time=false, cutoff=None, alpha=1e-3,
                    min_effect=0.5, ignore_log_velocity=false, report=true, params_json=None, json_out=None, progress=None,
                    velocity="auto", window=None, exclude=None,
                    current_topic=None, effort="auto", torque_constant=None, gear_ratio=None, motor_constant=None,
                    drives=None, verdict=false, threads=None, max_dictionary_gib=None))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    out: Option<PathBuf>,
    topic: &str,
    log_time: bool,
    cutoff: Option<f64>,
    alpha: f64,
    min_effect: f64,
    ignore_log_velocity: bool,
    report: bool,
    params_json: Option<&str>,
    json_out: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
    velocity: &str,
    window: Option<(f64, f64)>,
    exclude: Option<Vec<(f64, f64)>>,
    current_topic: Option<&str>,
    effort: &str,
    torque_constant: Option<&Bound<'_, PyAny>>,
    gear_ratio: Option<&Bound<'_, PyAny>>,
    motor_constant: Option<&Bound<'_, PyAny>>,
    drives: Option<bool>,
    verdict: bool,
    threads: Option<i64>,
    max_dictionary_gib: Option<f64>,
) -> PyResult<String> {
    use ivdyn::diagnose::DiagnoseOptions;
    let effort = EffortArgs { current_topic, effort, torque_constant, gear_ratio, motor_constant };
    let r = robot_with_params(&robot.inner, params_json)?;
    let urdf_name = robot.urdf.as_ref().map(|p| p.display().to_string()).unwrap_or_default();
    let job = app::DiagnoseJob {
        log: log_input(&r, log, "log")?,
        source: effort.apply(log_source(topic, None, log_time))?,
        opts: DiagnoseOptions {
            alpha,
            min_effect,
            drives,
            // a negative count is named here; 0 and counts past the bound by `check`
            threads: threads
                .map(|k| usize::try_from(k).map_err(|_| PyValueError::new_err(format!("threads: {k} is negative"))))
                .transpose()?,
            max_dictionary_bytes: match max_dictionary_gib {
                Some(g) => DiagnoseOptions::dictionary_bytes_of_gib(g).map_err(to_py)?,
                None => ivdyn::diagnose::DICTIONARY_MAX_BYTES,
            },
            cutoff_hz: cutoff,
            velocity: if ignore_log_velocity {
                ivdyn::prep::VelocitySource::Positions
            } else {
                ivdyn::prep::VelocitySource::parse(velocity).map_err(to_py)?
            },
            window,
            exclude: exclude.unwrap_or_default(),
            urdf_name,
            // the chain as loaded, for the `ivdyn identify` command the diagnosis suggests
            next_args: [("--base", r.base_link.as_str()), ("--tip", r.tip_link.as_str())]
                .into_iter()
                .chain((topic != "/joint_states").then_some(("--topic", topic)))
                .flat_map(|(k, v)| [k.to_string(), v.to_string()])
                .collect(),
            ..Default::default()
        },
        out,
        report,
        json: json_out,
    };
    let done = run(py, progress, |p| app::diagnose_job(&r, &job, &p))?;
    if !verdict {
        return json(&done.report.json);
    }
    // diagnosis.json and, beside it, the report's headline and details (what is left above
    // the noise and why no effect was named on it: words only the diagnosis has)
    let mut doc = serde_json::to_value(&done.report.json)
        .map_err(|e| PyRuntimeError::new_err(format!("internal error: report to JSON: {e}")))?;
    doc["verdict"] = done.report.verdict.clone().into();
    doc["details"] = done.report.details.clone().into();
    json(&doc)
}

/// `ivdyn excite` -> (the `--json` report as a string, the trajectory as a dict of
/// arrays `t`, `q`, `qd`, `qdd`); writes the CSV / MCAP / JSON files asked for.
#[pyfunction]
#[pyo3(signature = (robot, out=None, out_mcap=None, json_out=None, duration=20.0, harmonics=5, f0=0.1, rate=100.0,
                    criterion="cond", acc_limit=None, vel_limit=None, margin=0.01, starts=6, iterations=150, random=20,
                    seed=1, params_json=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn excite<'py>(
    py: Python<'py>,
    robot: PyRef<'py, PyRobot>,
    out: Option<PathBuf>,
    out_mcap: Option<PathBuf>,
    json_out: Option<PathBuf>,
    duration: f64,
    harmonics: usize,
    f0: f64,
    rate: f64,
    criterion: &str,
    acc_limit: Option<Vec<f64>>,
    vel_limit: Option<Vec<f64>>,
    margin: f64,
    starts: usize,
    iterations: usize,
    random: usize,
    seed: u64,
    params_json: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Bound<'py, PyDict>)> {
    use ivdyn::excite::{Criterion, ExciteOptions};
    let criterion = match criterion {
        "cond" => Criterion::Cond,
        "logdet" => Criterion::Logdet,
        c => return Err(PyValueError::new_err(format!("criterion must be 'cond' or 'logdet', got {c:?}"))),
    };
    let r = robot_with_params(&robot.inner, params_json)?;
    let opts = ExciteOptions {
        duration_s: duration,
        harmonics,
        f0_hz: f0,
        rate_hz: rate,
        criterion,
        acc_limit: acc_limit.unwrap_or_else(|| vec![ivdyn::excite::DEFAULT_ACC_LIMIT]),
        vel_limit,
        margin,
        starts,
        iterations,
        random_draws: random,
        seed,
        ..Default::default()
    };
    let job = app::ExciteJob { opts, csv: out, mcap: out_mcap, json: json_out };
    let done = run(py, progress, |p| {
        app::excite_job(&r, &app::ExciteJob { opts: ExciteOptions { progress: p, ..job.opts.clone() }, ..job.clone() })
    })?;
    let rep = done.report;
    let (t, n) = (rep.trajectory.t.len(), rep.joints.len());
    let as2 = |v: &[f64]| {
        Array2::from_shape_vec((t, n), v.to_vec())
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyValueError::new_err(e.to_string()))
    };
    let d = PyDict::new(py);
    d.set_item("t", rep.trajectory.t.clone().into_pyarray(py))?;
    d.set_item("q", as2(&rep.trajectory.q)?)?;
    d.set_item("qd", as2(&rep.trajectory.qd)?)?;
    d.set_item("qdd", as2(&rep.trajectory.qdd)?)?;
    d.set_item("joint_names", rep.joints.clone())?;
    Ok((json(&rep)?, d))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(excite, m)?)?;
    m.add_function(wrap_pyfunction!(gains, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(payload, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    Ok(())
}
