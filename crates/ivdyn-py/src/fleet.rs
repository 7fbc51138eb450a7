//! `ivdyn.fleet`'s native half (thin: convert, call `app::fleet`, convert back): one log's
//! statistics as bytes, the merge of statistics, their fit. The GIL is released while
//! Rust works, so a Ray (or thread-pool) worker runs logs in parallel.

use crate::PyRobot;
use crate::error::to_py;
use crate::pipeline::{condition, json, log_input, log_source, robot_with_params, run};
use ivdyn::app::fleet::{self, LogStats};
use ivdyn::app::fleet_drift as drift;
use ivdyn::app::{IdentifyOptions, Method};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// The options statistics are built and fitted with (each must be the same for every
/// log of a fleet: they are part of the model's fingerprint or of the rows).
fn fleet_opts(
    method: &str,
    cutoff: Option<f64>,
    decimate: usize,
    friction: Option<Vec<String>>,
    armature: bool,
    offset: bool,
) -> PyResult<IdentifyOptions> {
    let method = match method {
        "ols" => Method::Ols,
        "wls" => Method::Wls,
        m => {
            return Err(PyValueError::new_err(format!(
                "method must be 'ols' or 'wls' for fleet statistics, got {m:?}"
            )));
        }
    };
    let friction = friction.unwrap_or_else(|| vec!["coulomb".into(), "viscous".into()]);
    let names: Vec<&str> = friction.iter().map(String::as_str).collect();
    let drive = ivdyn::ident::DriveTerms::from_names(&names, armature, offset).map_err(to_py)?;
    Ok(IdentifyOptions {
        method,
        condition: condition(cutoff, "auto", None, None)?,
        decimate,
        validation_fraction: 0.0,
        drive,
        coulomb: ivdyn::app::identify::CoulombMode::Sign,
        ..Default::default()
    })
}

fn stats_of(stats: &[u8], what: &str) -> PyResult<LogStats> {
    LogStats::from_bytes(stats, what).map_err(to_py)
}

/// The sufficient statistics of one log (a file path or a dict of arrays, as `identify`
/// takes) as versioned bytes; `name` names the log in the statistics and in errors.
#[pyfunction]
#[pyo3(signature = (robot, log, name, topic="/joint_states", log_time=false, cutoff=None, decimate=0,
                    params_json=None, friction=None, armature=true, offset=true, method="wls", stream=false))]
#[allow(clippy::too_many_arguments)]
fn fleet_log_stats<'py>(
    py: Python<'py>,
    robot: PyRef<'_, PyRobot>,
    log: &Bound<'_, PyAny>,
    name: &str,
    topic: &str,
    log_time: bool,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    friction: Option<Vec<String>>,
    armature: bool,
    offset: bool,
    method: &str,
    stream: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    let opts = fleet_opts(method, cutoff, decimate, friction, armature, offset)?;
    let r = robot_with_params(&robot.inner, params_json)?;
    let input = log_input(&r, log, name)?;
    let src = log_source(topic, None, log_time);
    let bytes = run(py, None, |_| fleet::log_stats(&r, &input, &src, name, &opts, stream)?.to_bytes())?;
    Ok(PyBytes::new(py, &bytes))
}

/// The merge of a non-empty list of statistics (bytes), as bytes.
#[pyfunction]
fn fleet_merge<'py>(py: Python<'py>, parts: Vec<Vec<u8>>) -> PyResult<Bound<'py, PyBytes>> {
    let bytes = run(py, None, |_| {
        let all = parts
            .iter()
            .enumerate()
            .map(|(i, b)| LogStats::from_bytes(b, &format!("part {}", i + 1)))
            .collect::<ivdyn::error::Result<Vec<_>>>()?;
        LogStats::merge_all(all)?.to_bytes()
    })?;
    Ok(PyBytes::new(py, &bytes))
}

/// What statistics (bytes) hold, as JSON: `{"model", "logs", "samples"}`.
#[pyfunction]
fn fleet_stats_info(stats: &[u8]) -> PyResult<String> {
    let s = stats_of(stats, "statistics")?;
    #[derive(serde::Serialize)]
    struct Info<'a> {
        model: &'a fleet::ModelFingerprint,
        logs: &'a [fleet::LogInfo],
        samples: usize,
    }
    json(&Info { model: &s.model, logs: &s.logs, samples: s.samples })
}

/// The fit of statistics (bytes) with `robot`'s model, as JSON: `{"report": identify's
/// report, "long_run": per joint, "logs": [...]}`.
#[pyfunction]
#[pyo3(signature = (robot, stats, cutoff=None, decimate=0, params_json=None, friction=None, armature=true,
                    offset=true, method="wls"))]
#[allow(clippy::too_many_arguments)]
fn fleet_fit(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    stats: &[u8],
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    friction: Option<Vec<String>>,
    armature: bool,
    offset: bool,
    method: &str,
) -> PyResult<String> {
    let opts = fleet_opts(method, cutoff, decimate, friction, armature, offset)?;
    let r = robot_with_params(&robot.inner, params_json)?;
    let fit = run(py, None, |_| fleet::fit_stats(&r, &LogStats::from_bytes(stats, "statistics")?, &opts))?;
    json(&fit)
}

/// Drift of `stats` against `reference` (bytes; both fitted with `robot`'s model), as JSON:
/// one test per effect, each with `"words"` naming the change for `robot_id` since `since`.
#[pyfunction]
#[pyo3(signature = (robot, reference, stats, robot_id, since, cutoff=None, decimate=0, params_json=None,
                    friction=None, armature=true, offset=true, method="wls"))]
#[allow(clippy::too_many_arguments)]
fn fleet_drift(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    reference: &[u8],
    stats: &[u8],
    robot_id: &str,
    since: &str,
    cutoff: Option<f64>,
    decimate: usize,
    params_json: Option<&str>,
    friction: Option<Vec<String>>,
    armature: bool,
    offset: bool,
    method: &str,
) -> PyResult<String> {
    let opts = fleet_opts(method, cutoff, decimate, friction, armature, offset)?;
    let r = robot_with_params(&robot.inner, params_json)?;
    let tests = run(py, None, |_| {
        let (a, b) = (LogStats::from_bytes(reference, "reference")?, LogStats::from_bytes(stats, "statistics")?);
        drift::drift_of_stats(&r, &a, &b, &opts)
    })?;
    #[derive(serde::Serialize)]
    struct Worded<'a> {
        #[serde(flatten)]
        test: &'a drift::DriftTest,
        words: String,
    }
    let out: Vec<Worded<'_>> =
        tests.iter().map(|t| Worded { test: t, words: drift::describe(robot_id, t, since) }).collect();
    json(&out)
}

/// The words of a drift test (JSON, one of `fleet_drift`'s tests) for `robot_id`, dated
/// `since`.
#[pyfunction]
fn fleet_describe(robot_id: &str, test_json: &str, since: &str) -> PyResult<String> {
    let t: drift::DriftTest = serde_json::from_str(test_json)
        .map_err(|e| PyValueError::new_err(format!("not a drift test of ivdyn.fleet.drift: {e}")))?;
    Ok(drift::describe(robot_id, &t, since))
}

/// Benjamini-Hochberg discoveries among `p_values` at false-discovery rate `q`.
#[pyfunction]
fn fleet_fdr(p_values: Vec<f64>, q: f64) -> PyResult<Vec<bool>> {
    if !(q > 0.0 && q < 1.0) {
        return Err(PyValueError::new_err(format!("q must be in (0, 1), got {q}")));
    }
    Ok(drift::benjamini_hochberg(&p_values, q))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fleet_log_stats, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_merge, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_stats_info, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_fit, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_drift, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_fdr, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_describe, m)?)?;
    Ok(())
}
