//! Closed-loop simulation from Python: `ivdyn::closed_loop` (the core's `Simulator`
//! driven by its `ComputedTorque` or `Pd` controller along a reference given as arrays),
//! and the Fig. 5 payload experiments of `ivdyn_lab::control::Experiment`
//! (`control_experiment`). Glue only, GIL released; the Python wrapper
//! (`python/ivdyn/_control.py`) documents the API.

use crate::PyRobot;
use crate::error::to_py;
use ivdyn::Error;
use ivdyn::closed_loop::{Controller, LoopSettings};
use ivdyn::core::sim::Integrator;
use ivdyn_lab::control::{EstimatorKind, Experiment, Instrument, RunLog, Scheme};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn arr2<'py>(py: Python<'py>, v: Vec<f64>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Ok(Array2::from_shape_vec((rows, cols), v).map_err(|e| PyValueError::new_err(e.to_string()))?.into_pyarray(py))
}

fn nested<'py>(py: Python<'py>, v: &[Vec<f64>], cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    arr2(py, v.iter().flatten().copied().collect(), v.len(), cols)
}

fn flat<'a>(x: &'a PyReadonlyArray2<'_, f64>, name: &str, t: usize, n: usize) -> PyResult<&'a [f64]> {
    if x.shape() != [t, n] {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({t}, {n}), got ({}, {})",
            x.shape()[0],
            x.shape()[1]
        )));
    }
    x.as_slice().map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

/// A closed-loop run along a reference; returns a dict of arrays (see `ivdyn.closed_loop`).
#[pyfunction]
#[pyo3(signature = (robot, q_des, qd_des, qdd_des, dt, controller="computed_torque", model=None, wn=20.0, zeta=1.0,
                    coulomb="reference", q0=None, qd0=None, tau_limit=None, encoder_bits=None, q_noise=0.0, tau_noise=0.0,
                    substeps=10, integrator="rk4", coulomb_band=0.05, velocity_cutoff_hz=0.0, seed=0))]
#[allow(clippy::too_many_arguments)]
fn closed_loop<'py>(
    py: Python<'py>,
    robot: PyRef<'py, PyRobot>,
    q_des: PyReadonlyArray2<'py, f64>,
    qd_des: PyReadonlyArray2<'py, f64>,
    qdd_des: PyReadonlyArray2<'py, f64>,
    dt: f64,
    controller: &str,
    model: Option<PyRef<'py, PyRobot>>,
    wn: f64,
    zeta: f64,
    coulomb: &str,
    q0: Option<Vec<f64>>,
    qd0: Option<Vec<f64>>,
    tau_limit: Option<Vec<f64>>,
    encoder_bits: Option<u32>,
    q_noise: f64,
    tau_noise: f64,
    substeps: usize,
    integrator: &str,
    coulomb_band: f64,
    velocity_cutoff_hz: f64,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let n = robot.inner.dof();
    let t = q_des.shape()[0];
    if t == 0 {
        return Err(PyValueError::new_err("q_des must have at least one sample"));
    }
    let (qs, qds, qdds) =
        (flat(&q_des, "q_des", t, n)?, flat(&qd_des, "qd_des", t, n)?, flat(&qdd_des, "qdd_des", t, n)?);
    let bad = |what: &str| PyValueError::new_err(what.to_string());
    let controller = match controller {
        "computed_torque" | "ct" => Controller::ComputedTorque,
        "pd" => Controller::Pd,
        "pd_gravity" => Controller::PdGravity,
        c => return Err(bad(&format!("controller must be 'computed_torque', 'pd' or 'pd_gravity', got {c:?}"))),
    };
    let integrator = match integrator {
        "rk4" => Integrator::Rk4,
        "euler" | "semi_implicit_euler" => Integrator::SemiImplicitEuler,
        i => return Err(bad(&format!("integrator must be 'rk4' or 'euler', got {i:?}"))),
    };
    let coulomb_reference = match coulomb {
        "measured" => false,
        "reference" => true,
        c => return Err(bad(&format!("coulomb must be 'measured' or 'reference', got {c:?}"))),
    };
    let settings = LoopSettings {
        controller,
        wn,
        zeta,
        coulomb_reference,
        dt,
        substeps,
        integrator,
        coulomb_band,
        tau_limit: tau_limit.unwrap_or_else(|| vec![f64::INFINITY; n]),
        encoder_bits,
        q_noise,
        tau_noise,
        velocity_cutoff_hz,
        seed,
    };
    let ctrl = model.as_ref().map(|m| m.inner.clone()).unwrap_or_else(|| robot.inner.clone());
    let truth = &robot.inner;
    let rec = py
        .detach(|| {
            ivdyn::closed_loop::closed_loop(truth, &ctrl, &settings, qs, qds, qdds, q0.as_deref(), qd0.as_deref())
        })
        .map_err(to_py)?;
    let mi = rec.id_t.len();
    let d = PyDict::new(py);
    d.set_item("t", rec.t.into_pyarray(py))?;
    d.set_item("q", arr2(py, rec.q, t, n)?)?;
    d.set_item("qd", arr2(py, rec.qd, t, n)?)?;
    d.set_item("q_meas", arr2(py, rec.q_meas, t, n)?)?;
    d.set_item("qd_meas", arr2(py, rec.qd_meas, t, n)?)?;
    d.set_item("u", arr2(py, rec.u, t, n)?)?;
    d.set_item("tau", arr2(py, rec.tau, t, n)?)?;
    d.set_item("saturated", rec.saturated.into_pyarray(py))?;
    d.set_item("id_t", rec.id_t.into_pyarray(py))?;
    d.set_item("id_q", arr2(py, rec.id_q, mi, n)?)?;
    d.set_item("id_qd", arr2(py, rec.id_qd, mi, n)?)?;
    d.set_item("id_qdd", arr2(py, rec.id_qdd, mi, n)?)?;
    d.set_item("id_tau", arr2(py, rec.id_tau, mi, n)?)?;
    d.set_item("id_u", arr2(py, rec.id_u, mi, n)?)?;
    Ok(d)
}

// ------------------------------------------------------------------ Fig. 5 experiments

/// Settings changed from the experiment's defaults.
struct ExpSettings {
    duration: Option<f64>,
    grasp_time: Option<f64>,
    estimator: EstimatorKind,
    p0: Option<f64>,
    switch_error_tol: Option<f64>,
    record_every: Option<usize>,
}

struct ExpResult {
    run: RunLog,
    names: Vec<String>,
    truth: Vec<f64>,
    grasp_time: f64,
    payload_mass: f64,
    dof: usize,
    mass_index: Option<usize>,
}

fn run_experiment<const N: usize>(mut exp: Experiment<N>, s: &ExpSettings, scheme: Scheme) -> Result<ExpResult, Error> {
    if let Some(d) = s.duration {
        exp.duration = d;
    }
    if let Some(g) = s.grasp_time {
        exp.grasp_time = g;
    }
    if let Some(p) = s.p0 {
        exp.p0 = p;
    }
    if let Some(e) = s.switch_error_tol {
        exp.switch_error_tol = e;
    }
    if let Some(r) = s.record_every {
        exp.record_every = r;
    }
    exp.estimator = s.estimator;
    let run = exp.run(scheme)?;
    Ok(ExpResult {
        run,
        names: exp.column_names.clone(),
        truth: exp.truth_columns(),
        grasp_time: exp.grasp_time,
        payload_mass: exp.payload.mass,
        dof: N,
        mass_index: exp.columns.iter().position(|&c| c == 0),
    })
}

/// One scheme of the Fig. 5 experiment; returns a dict (see `ivdyn.control_experiment`).
#[pyfunction]
#[pyo3(signature = (scheme, robot="paper", urdf=None, duration=None, grasp_time=None, estimator="iv", instrument="planned",
                    delay=3, p0=None, switch_error_tol=None, record_every=None))]
#[allow(clippy::too_many_arguments)]
fn control_experiment<'py>(
    py: Python<'py>,
    scheme: &str,
    robot: &str,
    urdf: Option<std::path::PathBuf>,
    duration: Option<f64>,
    grasp_time: Option<f64>,
    estimator: &str,
    instrument: &str,
    delay: usize,
    p0: Option<f64>,
    switch_error_tol: Option<f64>,
    record_every: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let bad = |m: String| PyValueError::new_err(m);
    let scheme = Scheme::ALL
        .into_iter()
        .find(|s| s.key() == scheme)
        .ok_or_else(|| bad(format!("scheme must be one of {:?}, got {scheme:?}", Scheme::ALL.map(|s| s.key()))))?;
    let estimator = match (estimator, instrument) {
        ("ls", _) => EstimatorKind::Ls,
        ("iv", "planned") => EstimatorKind::Iv(Instrument::Planned),
        ("iv", "eq35") => EstimatorKind::Iv(Instrument::Eq35 { delay }),
        ("iv", i) => return Err(bad(format!("instrument must be 'planned' or 'eq35', got {i:?}"))),
        (e, _) => return Err(bad(format!("estimator must be 'iv' or 'ls', got {e:?}"))),
    };
    if duration.is_some_and(|d| !(d > 0.0 && d.is_finite())) || grasp_time.is_some_and(|g| !(g >= 0.0 && g.is_finite()))
    {
        return Err(bad("duration must be > 0 and grasp_time >= 0".into()));
    }
    if p0.is_some_and(|p| !(p > 0.0 && p.is_finite())) {
        return Err(bad("p0 must be finite and > 0".into()));
    }
    if record_every == Some(0) {
        return Err(bad("record_every must be >= 1".into()));
    }
    let s = ExpSettings { duration, grasp_time, estimator, p0, switch_error_tol, record_every };
    let res = match robot {
        "paper" => py.detach(|| Experiment::paper().and_then(|e| run_experiment(e, &s, scheme))),
        "panda" => {
            let urdf =
                urdf.ok_or_else(|| bad("robot 'panda' needs urdf= (the Panda URDF, e.g. fixtures/panda.urdf)".into()))?;
            py.detach(|| Experiment::panda(&urdf).and_then(|e| run_experiment(e, &s, scheme)))
        }
        r => return Err(bad(format!("robot must be 'paper' or 'panda', got {r:?}"))),
    }
    .map_err(to_py)?;
    let (n, r, b) = (res.dof, &res.run, res.names.len());
    let d = PyDict::new(py);
    d.set_item("scheme", scheme.key())?;
    d.set_item("label", scheme.label())?;
    d.set_item("t", r.t.clone().into_pyarray(py))?;
    d.set_item("q_des", nested(py, &r.q_des, n)?)?;
    d.set_item("q", nested(py, &r.q, n)?)?;
    d.set_item("tau", nested(py, &r.tau, n)?)?;
    d.set_item("t_all", r.t_all.clone().into_pyarray(py))?;
    d.set_item("err", nested(py, &r.err_all, n)?)?;
    let est = PyDict::new(py);
    est.set_item("t", r.estimates.iter().map(|e| e.t).collect::<Vec<_>>().into_pyarray(py))?;
    let th: Vec<Vec<f64>> = r.estimates.iter().map(|e| e.theta.clone()).collect();
    est.set_item("theta", nested(py, &th, b)?)?;
    est.set_item("mass_std", r.estimates.iter().map(|e| e.mass_std).collect::<Vec<_>>().into_pyarray(py))?;
    est.set_item("err_std", r.estimates.iter().map(|e| e.err_std).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("estimates", est)?;
    d.set_item("names", res.names.clone())?;
    d.set_item("truth", res.truth.clone().into_pyarray(py))?;
    d.set_item("mass_index", res.mass_index)?;
    d.set_item("payload_mass", res.payload_mass)?;
    d.set_item("grasp_time", res.grasp_time)?;
    d.set_item("switch_time", r.switch_time)?;
    d.set_item("saturated_steps", r.saturated_steps)?;
    let (rms, peak) = r.rms_peak(r.switch_time.unwrap_or(res.grasp_time));
    d.set_item("rms_after_switch", rms.into_pyarray(py))?;
    d.set_item("peak_after_switch", peak.into_pyarray(py))?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(closed_loop, m)?)?;
    m.add_function(wrap_pyfunction!(control_experiment, m)?)?;
    Ok(())
}
