//! The command line's pipelines from Python: `ivdyn::app::{identify, payload,
//! simulate}` on a robot and a log (a file, or arrays), returning the JSON document the
//! command line writes with `--json` (as a string; the Python wrapper parses it), with the
//! GIL released.
//!
//! Progress goes through the pipeline's own `Progress` hook (the one the command line
//! draws its bars with). The hook re-acquires the GIL only to call the Python callback and
//! to check for Ctrl-C. A Python exception there (or KeyboardInterrupt) must stop the
//! pipeline, but `Progress` cannot return an error: the hook stores the exception and
//! unwinds with `resume_unwind` (no panic message), the binding catches the unwind and
//! raises the stored exception. Nothing is shared with the caller but read-only inputs,
//! so no half-updated state survives the abort.

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::error::to_py;
use crate::PyRobot;
use ivdyn::log::JointLog;
use ivdyn::app::{self, IdentifyOptions, Method, PayloadOptions, SimulateOptions, Trajectory};
use ivdyn::progress::Progress;
use ivdyn::report::{ParamsFile, PayloadSpec};
use ivdyn::dsp::{DiffMethod, DEFAULT_ORDER};
use ivdyn::prep::ConditionOptions;
use ivdyn::Robot;
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
fn run<T: Send>(py: Python<'_>, callback: Option<Py<PyAny>>, f: impl FnOnce(ivdyn::progress::ProgressSink) -> ivdyn::error::Result<T> + Send) -> PyResult<T> {
    let sink = Arc::new(PyProgress { callback, state: Mutex::new((String::new(), 0, 0)), failed: Mutex::new(None) });
    let s2: Arc<dyn Progress> = sink.clone();
    let r = py.detach(|| catch_unwind(AssertUnwindSafe(|| f(Some(s2)))));
    let failed = sink.failed.lock().ok().and_then(|mut f| f.take());
    match (r, failed) {
        (_, Some(e)) => Err(e),
        (Ok(r), None) => r.map_err(to_py),
        (Err(p), None) => resume_unwind(p),
    }
}

// ------------------------------------------------------------------ inputs

fn robot_with_params(robot: &Robot, params_json: Option<&str>) -> PyResult<Robot> {
    let mut r = robot.clone();
    if let Some(js) = params_json {
        let pf: ParamsFile = serde_json::from_str(js).map_err(|e| PyValueError::new_err(format!("params: not a parameter file: {e}")))?;
        ivdyn::robot::load::load_params(&mut r, &pf).map_err(|e| PyValueError::new_err(format!("params: {e}")))?;
    }
    Ok(r)
}

/// Log options shared by identify and payload.
struct LogSource<'a> {
    topic: &'a str,
    command_topic: Option<&'a str>,
    log_time: bool,
}

fn f64_1d(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Option<Vec<f64>>> {
    match d.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => {
            let a: PyReadonlyArray1<f64> = v.extract().map_err(|_| PyValueError::new_err(format!("log['{key}'] must be a float64 array of shape (T,)")))?;
            Ok(Some(a.as_array().iter().copied().collect()))
        }
    }
}

fn f64_2d(d: &Bound<'_, PyDict>, key: &str, t: usize, n: usize) -> PyResult<Option<Vec<f64>>> {
    match d.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => {
            let a: PyReadonlyArray2<f64> = v.extract().map_err(|_| PyValueError::new_err(format!("log['{key}'] must be a float64 array of shape ({t}, {n})")))?;
            if a.shape() != [t, n] {
                return Err(PyValueError::new_err(format!("log['{key}'] must have shape ({t}, {n}), got ({}, {})", a.shape()[0], a.shape()[1])));
            }
            Ok(Some(a.as_array().iter().copied().collect()))
        }
    }
}

/// A log from a path (read as the command line does) or from a dict of arrays
/// (`t`, `q`, optional `qd`, `tau`, `u`, `joint_names`), checked like a file's.
fn joint_log(py: Python<'_>, robot: &Robot, log: &Bound<'_, PyAny>, src: &LogSource<'_>, what: &str) -> PyResult<JointLog> {
    if let Ok(d) = log.cast::<PyDict>() {
        let n = robot.dof();
        let t = f64_1d(d, "t")?.ok_or_else(|| PyValueError::new_err(format!("{what}: a log dict needs 't' (T,) and 'q' (T, {n})")))?;
        let len = t.len();
        let q = f64_2d(d, "q", len, n)?.ok_or_else(|| PyValueError::new_err(format!("{what}: a log dict needs 'q' (T, {n})")))?;
        if let Some(names) = d.get_item("joint_names")?
            && !names.is_none()
        {
            let names: Vec<String> = names.extract()?;
            if names != robot.joint_names {
                return Err(PyValueError::new_err(format!("{what}: log joints {names:?} are not the robot's {:?}", robot.joint_names)));
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
            truncated: false,
        };
        ivdyn::log::check_pipeline_log(&jl, Path::new(what), "(arrays)").map_err(to_py)?;
        return Ok(jl);
    }
    let path: PathBuf = log.extract().map_err(|_| PyValueError::new_err(format!("{what} must be a path (str or os.PathLike) or a dict of arrays")))?;
    py.detach(|| ivdyn::log::read_pipeline_log(&path, &robot.joint_names, src.topic, src.command_topic, src.log_time)).map_err(to_py)
}

fn condition(cutoff: Option<f64>) -> PyResult<ConditionOptions> {
    let mut c = ConditionOptions::default();
    if let Some(fc) = cutoff {
        if !(fc > 0.0 && fc.is_finite()) {
            return Err(PyValueError::new_err(format!("cutoff must be finite and > 0 Hz, got {fc}")));
        }
        c.diff = DiffMethod::Butterworth { order: DEFAULT_ORDER, cutoff_hz: Some(fc) };
    }
    Ok(c)
}

fn json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| PyRuntimeError::new_err(format!("internal error: report to JSON: {e}")))
}

// ------------------------------------------------------------------ identify / payload

/// `ivdyn identify` -> the `--json` document (a string).
#[pyfunction]
#[pyo3(signature = (robot, log, method="wls", validate=None, holdout=0.25, topic="/joint_states", command_topic=None,
                    log_time=false, cutoff=None, decimate=0, params_json=None, progress=None))]
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
) -> PyResult<String> {
    let method = match method {
        "ols" => Method::Ols,
        "wls" => Method::Wls,
        "iv" => Method::Iv,
        "idim-iv" | "idim_iv" => Method::IdimIv,
        m => return Err(PyValueError::new_err(format!("method must be 'ols', 'wls', 'iv' or 'idim-iv', got {m:?}"))),
    };
    if !(0.0..1.0).contains(&holdout) {
        return Err(PyValueError::new_err(format!("holdout must be in [0, 1), got {holdout}")));
    }
    let r = robot_with_params(&robot.inner, params_json)?;
    let src = LogSource { topic, command_topic, log_time };
    let mut opts = IdentifyOptions { method, condition: condition(cutoff)?, decimate, validation_fraction: holdout, ..Default::default() };
    // an MCAP path is streamed (bounded memory) as the command line does, when the
    // options allow; otherwise (arrays, CSV, options that need memory) read whole
    let path_of = |x: &Bound<'_, PyAny>| -> Option<PathBuf> {
        x.extract::<PathBuf>().ok().filter(|p| !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
    };
    let mut why_not = None;
    if let (Some(lp), true) = (path_of(log), validate.is_none_or(|v| path_of(v).is_some())) {
        let vp = validate.and_then(path_of);
        let read = ivdyn::log::ReadOptions::new(&r.joint_names).topic(topic).command_topic_opt(command_topic).log_time(log_time);
        let o2 = opts.clone();
        match run(py, progress.as_ref().map(|p| p.clone_ref(py)), |p| {
            ivdyn::app::stream::identify_mcap(&r, &lp, vp.as_deref(), &read, &IdentifyOptions { progress: p, ..o2 })
        })? {
            ivdyn::app::stream::Streamed::Done(rep) => return json(&rep),
            ivdyn::app::stream::Streamed::Unsupported(why) => why_not = Some(why),
        }
    }
    let log = joint_log(py, &r, log, &src, "log")?;
    opts.validation_log = validate.map(|v| joint_log(py, &r, v, &src, "validation log")).transpose()?;
    let mut rep = run(py, progress, |p| app::identify(&r, &log, &IdentifyOptions { progress: p, ..opts }))?;
    if let Some(w) = why_not {
        rep.notes.push(format!("read into memory (not streamed): {w}"));
    }
    json(&rep)
}

/// `ivdyn payload` -> the `--json` document (a string).
#[pyfunction]
#[pyo3(signature = (robot, log, before=None, topic="/joint_states", command_topic=None, log_time=false, cutoff=None,
                    decimate=0, params_json=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn payload(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    before: Option<&Bound<'_, PyAny>>,
    topic: &str,
    command_topic: Option<&str>,
    log_time: bool,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let r = robot_with_params(&robot.inner, params_json)?;
    let src = LogSource { topic, command_topic, log_time };
    let after = joint_log(py, &r, log, &src, "log")?;
    let before = before.map(|b| joint_log(py, &r, b, &src, "before log")).transpose()?;
    // as the command line: the before-log is conditioned and decimated like the log
    let mut opts = PayloadOptions { condition: condition(cutoff)?, decimate, ..Default::default() };
    opts.before.condition = opts.condition.clone();
    opts.before.decimate = opts.decimate;
    let rep = run(py, progress, |p| app::payload(&r, &after, before.as_ref(), &PayloadOptions { progress: p, ..opts }))?;
    json(&rep)
}

// ------------------------------------------------------------------ simulate

/// `ivdyn simulate` -> (the `--json` summary as a string, the log as a dict of arrays);
/// writes the log to `out` (`.mcap` or `.csv`) when given.
#[pyfunction]
#[pyo3(signature = (robot, out=None, traj_t=None, traj_q=None, duration=20.0, rate=500.0, seed=1, amplitude=0.8,
                    payload_mass=None, payload_com=None, payload_inertia=None, fc=None, fv=None, noise=0.0, noise_q=0.0,
                    encoder_bits=None, tau_resolution=None, velocity=true, command=false, params_json=None))]
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
) -> PyResult<(String, Bound<'py, PyDict>)> {
    let bad = |m: String| PyValueError::new_err(m);
    let r = robot_with_params(&robot.inner, params_json)?;
    let n = r.dof();
    // the command line's checks of the payload options
    let payload = match (payload_mass, &payload_com, &payload_inertia) {
        (None, None, None) => None,
        (Some(m), c, i) => {
            if !(m.is_finite() && m > 0.0) {
                return Err(bad(format!("payload_mass must be positive, got {m}")));
            }
            if c.as_ref().is_some_and(|c| c.len() != 3) {
                return Err(bad("payload_com needs 3 values x, y, z (m)".into()));
            }
            if i.as_ref().is_some_and(|i| i.len() != 6) {
                return Err(bad("payload_inertia needs 6 values Ixx, Ixy, Ixz, Iyy, Iyz, Izz (kg m^2)".into()));
            }
            let com = c.as_ref().map(|c| [c[0], c[1], c[2]]).unwrap_or([0.0; 3]);
            let inertia = i.as_ref().map(|i| [i[0], i[1], i[2], i[3], i[4], i[5]]).unwrap_or([0.0; 6]);
            Some(PayloadSpec { mass: m, com, inertia })
        }
        (None, _, _) => return Err(bad("payload_com / payload_inertia need payload_mass".into())),
    };
    for (name, x) in [("duration", duration), ("rate", rate)] {
        if !(x > 0.0 && x.is_finite()) {
            return Err(bad(format!("{name} must be finite and > 0, got {x}")));
        }
    }
    for (name, x) in [("noise", noise), ("noise_q", noise_q), ("amplitude", amplitude)] {
        if !(x >= 0.0 && x.is_finite()) {
            return Err(bad(format!("{name} must be finite and >= 0, got {x}")));
        }
    }
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
                return Err(bad(format!("traj['q'] must have shape ({len}, {n}), got ({}, {})", q.shape()[0], q.shape()[1])));
            }
            Trajectory::Samples { t: t.as_array().to_vec(), q: q.as_array().iter().copied().collect() }
        }
        _ => return Err(bad("traj needs both 't' and 'q'".into())),
    };
    let (log, truth) = py
        .detach(|| -> ivdyn::error::Result<_> {
            let log = app::simulate(&r, &traj, &opts)?;
            let truth = app::true_robot(&r, &opts)?;
            if let Some(p) = &out {
                // as the command line: a temporary file renamed on success, never a partial one
                let name = p.file_name().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| "out".into());
                let tmp = p.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
                let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
                let written = match ext.as_str() {
                    "csv" => ivdyn::log::write_csv(&tmp, &log),
                    "mcap" => ivdyn::log::write_mcap(&tmp, &log, &[]).map(|_| ()),
                    e => Err(ivdyn::Error::Log { file: p.clone(), msg: format!("unknown output format '.{e}' (use .mcap or .csv)") }),
                }
                .and_then(|_| std::fs::rename(&tmp, p).map_err(|source| ivdyn::Error::Io { file: p.clone(), source }));
                if written.is_err() {
                    let _ = std::fs::remove_file(&tmp);
                }
                written?;
            }
            Ok((log, truth))
        })
        .map_err(to_py)?;
    // the command line's `--json` summary
    let tp = ParamsFile { robot: r.name.clone(), joints: r.joint_names.clone(), names: r.param_names(), theta: truth.params() };
    let summary = serde_json::json!({
        "out": out.as_ref().map(|p| p.display().to_string()),
        "samples": log.len(),
        "joints": r.joint_names,
        "options": opts,
        "true_params": tp,
    });
    let (t, nn) = (log.len(), log.dof());
    let as2 = |v: Option<Vec<f64>>| -> PyResult<Option<Bound<'py, numpy::PyArray2<f64>>>> {
        v.map(|v| Array2::from_shape_vec((t, nn), v).map(|a| a.into_pyarray(py)).map_err(|e| PyValueError::new_err(e.to_string()))).transpose()
    };
    let d = PyDict::new(py);
    d.set_item("t", log.t.into_pyarray(py))?;
    d.set_item("q", as2(Some(log.q))?)?;
    d.set_item("qd", as2(log.qd)?)?;
    d.set_item("tau", as2(log.tau)?)?;
    d.set_item("u", as2(log.u)?)?;
    d.set_item("joint_names", log.joint_names)?;
    Ok((json(&summary)?, d))
}

/// `ivdyn diagnose` -> `diagnosis.json` (a string); with `out`, also writes
/// diagnosis.json, report.html and residuals.mcap there.
#[pyfunction]
#[pyo3(signature = (robot, log, out=None, topic="/joint_states", log_time=false, cutoff=None, alpha=1e-3,
                    min_effect=0.5, ignore_log_velocity=false, report=true, params_json=None))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    out: Option<std::path::PathBuf>,
    topic: &str,
    log_time: bool,
    cutoff: Option<f64>,
    alpha: f64,
    min_effect: f64,
    ignore_log_velocity: bool,
    report: bool,
    params_json: Option<&str>,
) -> PyResult<String> {
    use ivdyn::diagnose::{self as dg, DiagnoseOptions};
    let r = robot_with_params(&robot.inner, params_json)?;
    let src = LogSource { topic, command_topic: None, log_time };
    let jl = joint_log(py, &r, log, &src, "log")?;
    let log_name = log.extract::<std::path::PathBuf>().map(|p| p.display().to_string()).unwrap_or_else(|_| "(arrays)".into());
    let opts = DiagnoseOptions { alpha, min_effect, cutoff_hz: cutoff, ignore_log_velocity, log_name, ..Default::default() };
    let text = run(py, None, |_| {
        let d = dg::diagnose(&r, &jl, &opts)?;
        if let Some(dir) = &out {
            std::fs::create_dir_all(dir).map_err(|e| ivdyn::Error::Io { file: dir.clone(), source: e })?;
            if report {
                dg::report::write_html(&d, dir)?;
            }
            dg::report::write_mcap_stamped(&d, &r.joint_names, jl.t0_ns, dir)?;
            let text = serde_json::to_string_pretty(&d.json).map_err(|e| ivdyn::Error::Estimation { msg: e.to_string() })?;
            let path = dir.join("diagnosis.json");
            std::fs::write(&path, text + "\n").map_err(|e| ivdyn::Error::Io { file: path.clone(), source: e })?;
        }
        serde_json::to_string(&d.json).map_err(|e| ivdyn::Error::Estimation { msg: e.to_string() })
    })?;
    Ok(text)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(payload, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    Ok(())
}
