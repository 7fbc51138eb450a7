//! Terminal-link (payload) estimation over arrays: `ivdyn::ident::arrays::terminal_link_run`
//! (the core's `TerminalLink`, paper eqs 38-54) and `ivdyn::ident::arrays::terminal_base`, with
//! the GIL released. Glue only; the Python wrapper (`python/ivdyn/_control.py`) converts
//! the arrays and documents the API.

use crate::PyRobot;
use crate::error::to_py;
use crate::ident::PyBaseParams;
use ivdyn::core::estim::TerminalSpec;
use ivdyn::core::params::DRIVE_PARAMS;
use ivdyn::ident::arrays::{self, TerminalInstrument, TerminalOptions};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `[fc, fv, ia, tau0]` flags from the names of the changing drive parameters.
fn drive_flags(drive: &[String]) -> PyResult<[bool; DRIVE_PARAMS]> {
    let mut f = [false; DRIVE_PARAMS];
    for d in drive {
        let i = ivdyn::core::params::DRIVE_PARAM_NAMES.iter().position(|n| n == d).ok_or_else(|| {
            PyValueError::new_err(format!("drive: unknown drive parameter {d:?} (expected some of fc, fv, ia, tau0)"))
        })?;
        f[i] = true;
    }
    Ok(f)
}

fn spec(n: usize, k: Option<usize>, drive: &[String], first_row: Option<usize>) -> PyResult<TerminalSpec> {
    if n == 0 {
        return Err(PyValueError::new_err("the robot has no joints"));
    }
    let k = k.unwrap_or(n - 1);
    let first_row = first_row.unwrap_or(k);
    if k >= n || first_row > k {
        return Err(PyValueError::new_err(format!(
            "need 0 <= first_row <= k < N = {n}, got k = {k}, first_row = {first_row}"
        )));
    }
    Ok(TerminalSpec { k, drive: drive_flags(drive)?, first_row })
}

/// Identifiable columns of the terminal problem (`ivdyn::ident::arrays::terminal_base`).
#[pyfunction]
#[pyo3(signature = (robot, k=None, drive=Vec::new(), first_row=None, samples=200, seed=42))]
fn terminal_base(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    k: Option<usize>,
    drive: Vec<String>,
    first_row: Option<usize>,
    samples: usize,
    seed: u64,
) -> PyResult<PyBaseParams> {
    let sp = spec(robot.inner.dof(), k, &drive, first_row)?;
    if samples == 0 {
        return Err(PyValueError::new_err("samples must be >= 1"));
    }
    let r = &robot.inner;
    let inner = py.detach(|| arrays::terminal_base(r, &sp, samples, seed)).map_err(to_py)?;
    Ok(PyBaseParams { inner })
}

fn rows<'a>(x: &'a PyReadonlyArray2<'_, f64>, name: &str, t: usize, n: usize) -> PyResult<&'a [f64]> {
    let s = x.shape();
    if s != [t, n] {
        return Err(PyValueError::new_err(format!("{name} must have shape ({t}, {n}), got ({}, {})", s[0], s[1])));
    }
    x.as_slice().map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

/// Runs the terminal-link estimator; returns a dict (see `ivdyn.terminal_link`).
#[pyfunction]
#[pyo3(signature = (robot, q, qd, qdd, tau, columns, k=None, drive=Vec::new(), first_row=None, iv=true,
                    qdd_instr=None, u=None, row_weight=None, p0=1e4, min_speed=0.0, record=Vec::new()))]
#[allow(clippy::too_many_arguments)]
fn terminal_link<'py>(
    py: Python<'py>,
    robot: PyRef<'py, PyRobot>,
    q: PyReadonlyArray2<'py, f64>,
    qd: PyReadonlyArray2<'py, f64>,
    qdd: PyReadonlyArray2<'py, f64>,
    tau: PyReadonlyArray2<'py, f64>,
    columns: Vec<usize>,
    k: Option<usize>,
    drive: Vec<String>,
    first_row: Option<usize>,
    iv: bool,
    qdd_instr: Option<PyReadonlyArray2<'py, f64>>,
    u: Option<PyReadonlyArray2<'py, f64>>,
    row_weight: Option<Vec<f64>>,
    p0: f64,
    min_speed: f64,
    record: Vec<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let n = robot.inner.dof();
    let sp = spec(n, k, &drive, first_row)?;
    let t = q.shape()[0];
    let (q, qd, qdd, tau) =
        (rows(&q, "q", t, n)?, rows(&qd, "qd", t, n)?, rows(&qdd, "qdd", t, n)?, rows(&tau, "tau", t, n)?);
    let instrument = match (&qdd_instr, &u) {
        (Some(_), Some(_)) => return Err(PyValueError::new_err("give one instrument: qdd_instr or u, not both")),
        (Some(z), None) => TerminalInstrument::Qdd(rows(z, "qdd_instr", t, n)?),
        (None, Some(u)) => TerminalInstrument::Eq35(rows(u, "u", t, n)?),
        (None, None) => TerminalInstrument::None,
    };
    if iv && matches!(instrument, TerminalInstrument::None) {
        return Err(PyValueError::new_err("method 'iv' needs an instrument: qdd_instr (T, N) or the command u (T, N)"));
    }
    let row_weight = row_weight.unwrap_or_else(|| vec![1.0; n]);
    if row_weight.len() != n || row_weight.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
        return Err(PyValueError::new_err(format!("row_weight must be {n} finite weights >= 0, got {row_weight:?}")));
    }
    if !(min_speed >= 0.0) {
        return Err(PyValueError::new_err(format!("min_speed must be >= 0, got {min_speed}")));
    }
    let b = columns.len();
    let opts = TerminalOptions { spec: sp, columns, row_weight, iv, p0, min_speed, record };
    let r = &robot.inner;
    let run = py.detach(|| arrays::terminal_link_run(r, &opts, q, qd, qdd, tau, instrument)).map_err(to_py)?;
    let all = arrays::terminal_names(r, &sp);
    let d = PyDict::new(py);
    d.set_item("names", opts.columns.iter().map(|&c| all[c].clone()).collect::<Vec<_>>())?;
    d.set_item("theta", run.theta.into_pyarray(py))?;
    let to2 = |v: Vec<f64>, r: usize, c: usize| {
        Array2::from_shape_vec((r, c), v).map_err(|e| PyValueError::new_err(e.to_string()))
    };
    d.set_item("trace", to2(run.trace, opts.record.len(), b)?.into_pyarray(py))?;
    d.set_item("record", opts.record.clone())?;
    d.set_item("P", to2(run.p, b, b)?.into_pyarray(py))?;
    d.set_item("rows_used", run.rows_used)?;
    d.set_item("rows_skipped", run.rows_skipped)?;
    d.set_item("method", if iv { "iv" } else { "ls" })?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(terminal_base, m)?)?;
    m.add_function(wrap_pyfunction!(terminal_link, m)?)?;
    Ok(())
}
